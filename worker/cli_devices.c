/* `photonfarm devices [--json] [--device SEL]`: every Vulkan device and its key limits. */
#include "cli_options.h"
#include "pf_cli.h"

#include "pf_vk.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MIB (1024.0 * 1024.0)

/* "major.minor.patch" of a VK_MAKE_API_VERSION value (Vulkan spec, "Version Numbers":
 * major in bits 22-28, minor in 12-21, patch in 0-11); the worker stays free of vulkan.h. */
static const char *api_version_text(uint32_t version, char *buffer, size_t size)
{
    snprintf(buffer, size, "%u.%u.%u", (version >> 22) & 0x7fu, (version >> 12) & 0x3ffu,
             version & 0xfffu);
    return buffer;
}

/* Index the device selector picks ("" = automatic choice), via the real selection code. */
static pf_status chosen_index(const char *selector, uint32_t *index, pf_error *err)
{
    pf_vk_options options = pf_cli_vk_options(selector, NULL);
    options.validation = 0; /* only the choice matters here */
    pf_vk_context *ctx = NULL;
    pf_status status = pf_vk_create(&options, &ctx, err);
    if (status != PF_OK)
        return status;
    *index = pf_vk_info(ctx)->index;
    pf_vk_destroy(ctx);
    return PF_OK;
}

static void print_json_string(const char *text)
{
    putchar('"');
    for (const unsigned char *c = (const unsigned char *)text; *c; c++) {
        if (*c == '"' || *c == '\\')
            printf("\\%c", *c);
        else if (*c < 0x20)
            printf("\\u%04x", *c);
        else
            putchar(*c);
    }
    putchar('"');
}

static void print_json(const pf_vk_device_info *devices, uint32_t count, uint32_t default_index,
                       uint32_t selected_index)
{
    printf("{\"default_index\": %u, \"selected_index\": %u, \"devices\": [", default_index,
           selected_index);
    for (uint32_t i = 0; i < count; i++) {
        const pf_vk_device_info *d = &devices[i];
        printf("%s\n  {\"index\": %u, \"name\": ", i ? "," : "", d->index);
        print_json_string(d->name);
        printf(", \"type\": ");
        print_json_string(d->type);
        printf(", \"driver\": ");
        print_json_string(d->driver);
        char version[32];
        printf(", \"vendor_id\": %u, \"device_id\": %u, \"api_version\": \"%s\""
               ", \"max_storage_buffer_range\": %llu, \"device_local_bytes\": %llu"
               ", \"max_workgroup_size\": [%u, %u, %u], \"max_workgroup_invocations\": %u"
               ", \"max_workgroup_count\": [%u, %u, %u], \"max_shared_memory_bytes\": %u"
               ", \"max_push_constant_bytes\": %u, \"subgroup_size\": %u"
               ", \"timestamps\": %s, \"timestamp_valid_bits\": %u, \"timestamp_period_ns\": %g"
               ", \"int64\": %s, \"int64_atomics\": %s, \"denorm_preserve\": %s"
               ", \"default\": %s, \"selected\": %s}",
               d->vendor_id, d->device_id, api_version_text(d->api_version, version, sizeof version),
               (unsigned long long)d->max_storage_buffer_range,
               (unsigned long long)d->device_local_bytes, d->max_workgroup_size[0],
               d->max_workgroup_size[1], d->max_workgroup_size[2], d->max_workgroup_invocations,
               d->max_workgroup_count[0], d->max_workgroup_count[1], d->max_workgroup_count[2],
               d->max_shared_memory_bytes, d->max_push_constant_bytes, d->subgroup_size,
               d->timestamp_valid_bits ? "true" : "false", d->timestamp_valid_bits,
               (double)d->timestamp_period_ns, d->has_int64 ? "true" : "false",
               d->has_int64_atomics ? "true" : "false", d->has_denorm_preserve ? "true" : "false",
               i == default_index ? "true" : "false",
               i == selected_index ? "true" : "false");
    }
    printf("\n]}\n");
}

static void print_text(const pf_vk_device_info *devices, uint32_t count, uint32_t default_index,
                       uint32_t selected_index)
{
    for (uint32_t i = 0; i < count; i++) {
        const pf_vk_device_info *d = &devices[i];
        printf("%s %u: %s [%s]%s%s\n", i == selected_index ? "*" : " ", d->index, d->name,
               d->type, i == default_index ? " (default)" : "",
               i == selected_index && i != default_index ? " (selected)" : "");
        char version[32];
        printf("      driver %s, Vulkan %s, vendor 0x%04x device 0x%04x\n", d->driver,
               api_version_text(d->api_version, version, sizeof version), d->vendor_id,
               d->device_id);
        printf("      maxStorageBufferRange %llu (%.0f MiB), device-local memory %.0f MiB\n",
               (unsigned long long)d->max_storage_buffer_range,
               (double)d->max_storage_buffer_range / MIB, (double)d->device_local_bytes / MIB);
        printf("      workgroup size max (%u, %u, %u), %u invocations, count max (%u, %u, %u)\n",
               d->max_workgroup_size[0], d->max_workgroup_size[1], d->max_workgroup_size[2],
               d->max_workgroup_invocations, d->max_workgroup_count[0],
               d->max_workgroup_count[1], d->max_workgroup_count[2]);
        printf("      shared memory %u B, push constants %u B, subgroup size %u\n",
               d->max_shared_memory_bytes, d->max_push_constant_bytes, d->subgroup_size);
        if (d->timestamp_valid_bits)
            printf("      timestamps %u bits at %g ns/tick", d->timestamp_valid_bits,
                   (double)d->timestamp_period_ns);
        else
            printf("      no compute timestamps");
        printf(", int64 %s, int64 atomics %s, denorm preserve %s\n", d->has_int64 ? "yes" : "no",
               d->has_int64_atomics ? "yes" : "no", d->has_denorm_preserve ? "yes" : "no");
    }
    printf("\n* = the device photonfarm uses");
    const char *environment = getenv("PHOTONFARM_DEVICE");
    if (environment && *environment)
        printf(" ($PHOTONFARM_DEVICE=%s)", environment);
    printf("\n");
}

int pf_cli_devices(int argc, char **argv)
{
    int json = 0;
    const char *selector = NULL;
    const pf_cli_option options[] = {
        {"--json", NULL, NULL, "machine-readable output", "text", pf_cli_store_flag, &json, 0, 0,
         NULL},
        {"--device", NULL, "NAME|INDEX", "show which device this selector picks",
         "$PHOTONFARM_DEVICE, else the automatic choice", pf_cli_store_text, &selector, 0, 0,
         NULL},
    };
    pf_cli_command command = {
        .name = "devices",
        .synopsis = "[options]",
        .description = "Lists every Vulkan device with the limits photonfarm depends on, and\n"
                       "marks the one it would use: by default a real GPU (discrete >\n"
                       "integrated > virtual), else the CPU device (lavapipe).",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
    };
    int help = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;

    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    pf_status status = pf_vk_enumerate(&devices, &count, &err);
    if (status != PF_OK)
        return pf_cli_fail("devices", pf_status_exit_code(status), "%s", err.message);
    uint32_t default_index = 0, selected_index = 0;
    status = chosen_index("", &default_index, &err); /* "": the automatic choice */
    if (status == PF_OK)
        status = chosen_index(selector, &selected_index, &err);
    if (status != PF_OK) {
        free(devices);
        return pf_cli_fail("devices", pf_status_exit_code(status), "%s", err.message);
    }
    if (json)
        print_json(devices, count, default_index, selected_index);
    else
        print_text(devices, count, default_index, selected_index);
    free(devices);
    return 0;
}
