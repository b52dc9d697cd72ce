/* `photonfarm devices` lists every device pf_vk_enumerate sees, as text and as JSON. */
#include "pf_test.h"
#include "pf_vk.h"

#include <cjson/cJSON.h>
#include <sys/wait.h>

/* Runs "$PHOTONFARM args" and returns its stdout (malloc'ed) and exit status. */
static char *run_photonfarm(const char *args, int *exit_status)
{
    const char *photonfarm = getenv("PHOTONFARM");
    char command[1024];
    snprintf(command, sizeof command, "'%s' %s", photonfarm ? photonfarm : "photonfarm", args);
    FILE *pipe = popen(command, "r");
    if (!pipe)
        return NULL;
    size_t capacity = 4096, length = 0;
    char *output = malloc(capacity);
    size_t got;
    while (output && (got = fread(output + length, 1, capacity - length - 1, pipe)) > 0) {
        length += got;
        if (capacity - length < 1024) {
            char *grown = realloc(output, capacity * 2);
            if (!grown) {
                free(output);
                output = NULL;
                break;
            }
            output = grown;
            capacity *= 2;
        }
    }
    int status = pclose(pipe);
    *exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    if (output)
        output[length] = '\0';
    return output;
}

PF_TEST(devices_lists_every_device)
{
    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    PF_REQUIRE_OK(pf_vk_enumerate(&devices, &count, &err), &err);
    int exit_status = -1;
    char *text = run_photonfarm("devices", &exit_status);
    PF_REQUIRE(text);
    PF_CHECK(exit_status == 0);
    for (uint32_t i = 0; i < count; i++)
        PF_CHECK_MSG(strstr(text, devices[i].name) != NULL, "'%s' missing from:\n%s",
                     devices[i].name, text);
    PF_CHECK(strstr(text, "maxStorageBufferRange") != NULL);
    free(text);

    char *json_text = run_photonfarm("devices --json", &exit_status);
    PF_REQUIRE(json_text);
    PF_CHECK(exit_status == 0);
    cJSON *json = cJSON_Parse(json_text);
    PF_CHECK_MSG(json != NULL, "not JSON:\n%s", json_text);
    const cJSON *list = cJSON_GetObjectItemCaseSensitive(json, "devices");
    PF_CHECK(cJSON_IsArray(list) && (uint32_t)cJSON_GetArraySize(list) == count);
    const cJSON *chosen = cJSON_GetObjectItemCaseSensitive(json, "default_index");
    PF_CHECK(cJSON_IsNumber(chosen) && chosen->valueint >= 0 && (uint32_t)chosen->valueint < count);
    for (uint32_t i = 0; list && i < count; i++) {
        const cJSON *device = cJSON_GetArrayItem(list, (int)i);
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(device, "name");
        const cJSON *range = cJSON_GetObjectItemCaseSensitive(device, "max_storage_buffer_range");
        PF_CHECK(cJSON_IsString(name) && !strcmp(name->valuestring, devices[i].name));
        PF_CHECK(cJSON_IsNumber(range) &&
                 (uint64_t)range->valuedouble == devices[i].max_storage_buffer_range);
        const cJSON *denorm = cJSON_GetObjectItemCaseSensitive(device, "denorm_preserve");
        PF_CHECK(cJSON_IsBool(denorm) &&
                 cJSON_IsTrue(denorm) == (devices[i].has_denorm_preserve != 0));
    }
    cJSON_Delete(json);
    free(json_text);
    free(devices);
}

PF_TEST(devices_usage)
{
    int exit_status = -1;
    char *help = run_photonfarm("devices --help", &exit_status);
    PF_REQUIRE(help);
    PF_CHECK(exit_status == 0 && strstr(help, "--json") != NULL);
    free(help);
    char *bad = run_photonfarm("devices --bogus 2>/dev/null", &exit_status);
    PF_CHECK(exit_status == 2);
    free(bad);
    char *unknown = run_photonfarm("devices --device no-such-gpu 2>/dev/null", &exit_status);
    PF_CHECK(exit_status == 2);
    free(unknown);
}

int main(void)
{
    PF_RUN(devices_lists_every_device);
    PF_RUN(devices_usage);
    return pf_test_finish();
}
