/* core/vk device enumeration and choice, and the validation layer plumbing. */
#include "vk_test_util.h"

#include "pf_vk_internal.h"

#include <ctype.h>
#include <sys/stat.h>

static pf_vk_context *create_with(const char *selector, pf_status expected, pf_error *err)
{
    pf_vk_context *ctx = NULL;
    pf_vk_options options = vk_test_options();
    options.device_selector = selector;
    pf_status status = pf_vk_create(&options, &ctx, err);
    PF_CHECK_MSG(status == expected, "selector '%s': status %d, expected %d (%s)",
                 selector ? selector : "(null)", (int)status, (int)expected, err->message);
    PF_CHECK((ctx != NULL) == (status == PF_OK));
    return ctx;
}

PF_TEST(enumerate_lists_devices_with_limits)
{
    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    PF_REQUIRE_OK(pf_vk_enumerate(&devices, &count, &err), &err);
    PF_CHECK(count >= 1);
    for (uint32_t i = 0; i < count; i++) {
        const pf_vk_device_info *d = &devices[i];
        PF_CHECK(d->index == i);
        PF_CHECK(d->name[0] != '\0' && d->driver[0] != '\0');
        PF_CHECK(d->max_storage_buffer_range > 0);
        PF_CHECK(d->max_workgroup_invocations > 0 && d->max_workgroup_size[0] > 0);
        PF_CHECK(d->max_workgroup_count[0] > 0 && d->max_shared_memory_bytes > 0);
        PF_CHECK(d->max_push_constant_bytes >= 128); /* Vulkan's guaranteed minimum */
        PF_CHECK(d->subgroup_size > 0);
        PF_CHECK(strcmp(d->type, "") != 0);
    }
    free(devices);
}

PF_TEST(select_by_index)
{
    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    PF_REQUIRE_OK(pf_vk_enumerate(&devices, &count, &err), &err);
    for (uint32_t i = 0; i < count; i++) {
        char selector[16];
        snprintf(selector, sizeof selector, "%u", i);
        pf_vk_context *ctx = create_with(selector, PF_OK, &err);
        if (!ctx)
            continue;
        PF_CHECK(pf_vk_info(ctx)->index == i);
        PF_CHECK(!strcmp(pf_vk_info(ctx)->name, devices[i].name));
        VK_TEST_FINISH(ctx);
    }
    free(devices);
}

PF_TEST(select_by_name_substring_ignoring_case)
{
    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    PF_REQUIRE_OK(pf_vk_enumerate(&devices, &count, &err), &err);
    PF_REQUIRE(count >= 1);
    /* The last device's name without its first character, in upper case. */
    const char *name = devices[count - 1].name;
    char selector[256];
    size_t length = strlen(name);
    PF_REQUIRE(length >= 2);
    for (size_t i = 1; i <= length; i++)
        selector[i - 1] = (char)toupper((unsigned char)name[i]);
    pf_vk_context *ctx = create_with(selector, PF_OK, &err);
    if (ctx) {
        PF_CHECK_MSG(strstr(pf_vk_info(ctx)->name, name + 1) != NULL, "chose '%s' for '%s'",
                     pf_vk_info(ctx)->name, selector);
        VK_TEST_FINISH(ctx);
    }
    free(devices);
}

/* Core reads no environment: the CLI maps $PHOTONFARM_DEVICE and $PF_VK_VALIDATION
 * (worker/cli_environment.c, test_cli_render); a library user gets what it asks for. */
PF_TEST(core_ignores_the_environment)
{
    pf_error err = {0};
    setenv("PHOTONFARM_DEVICE", "no-such-device-anywhere", 1);
    pf_vk_context *ctx = create_with(NULL, PF_OK, &err);
    if (ctx)
        VK_TEST_FINISH(ctx);
    unsetenv("PHOTONFARM_DEVICE");
    const char *saved = getenv("PF_VK_VALIDATION");
    char kept[16] = "";
    if (saved)
        snprintf(kept, sizeof kept, "%s", saved);
    setenv("PF_VK_VALIDATION", "1", 1);
    pf_vk_options options = {0};
    ctx = NULL;
    PF_CHECK_OK(pf_vk_create(&options, &ctx, &err), &err);
    if (ctx) {
        PF_CHECK(!pf_vk_validation_enabled(ctx));
        pf_vk_destroy(ctx);
    }
    if (saved)
        setenv("PF_VK_VALIDATION", kept, 1);
    else
        unsetenv("PF_VK_VALIDATION");
}

PF_TEST(bad_selector_lists_the_devices)
{
    pf_error err = {0};
    pf_vk_device_info *devices = NULL;
    uint32_t count = 0;
    PF_REQUIRE_OK(pf_vk_enumerate(&devices, &count, &err), &err);
    create_with("GeForce 9999 Imaginary", PF_ERR_INVALID, &err);
    PF_CHECK(strstr(err.message, "GeForce 9999 Imaginary") != NULL);
    PF_CHECK(strstr(err.message, "available devices") != NULL);
    PF_CHECK_MSG(strstr(err.message, devices[0].name) != NULL, "%s", err.message);
    char out_of_range[16];
    snprintf(out_of_range, sizeof out_of_range, "%u", count);
    create_with(out_of_range, PF_ERR_INVALID, &err);
    PF_CHECK(strstr(err.message, devices[0].name) != NULL);
    free(devices);
}

/*
 * The counter counts: a fence created with flag bits Vulkan does not define is
 * reported by the layer (VUID-VkFenceCreateInfo-flags-parameter) while every
 * driver ignores the bits, so the misuse is harmless. Its own context, with
 * validation forced on, so no other test sees the message.
 */
PF_TEST(validation_counter_counts_messages)
{
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {.device_selector = NULL, .validation = 1};
    PF_REQUIRE_OK(pf_vk_create(&options, &ctx, &err), &err);
    PF_CHECK(pf_vk_validation_enabled(ctx));
    PF_CHECK(pf_vk_validation_message_count(ctx) == 0);
    fprintf(stderr, "(one validation error about VkFenceCreateInfo flags is expected next)\n");
    const VkFenceCreateFlags undefined_flag = 0x40000000u;
    VkFenceCreateInfo info = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO,
                              .flags = undefined_flag};
    VkFence fence = VK_NULL_HANDLE;
    if (vkCreateFence(ctx->device, &info, NULL, &fence) == VK_SUCCESS)
        vkDestroyFence(ctx->device, fence, NULL);
    PF_CHECK(pf_vk_validation_message_count(ctx) > 0);
    pf_vk_destroy(ctx);
}

/* Asking for validation without the layer is an error naming it, never a silent downgrade. */
PF_TEST(missing_validation_layer_is_an_error)
{
    char empty[512], tmp[256];
    snprintf(empty, sizeof empty, "%s/no-layers", pf_test_tmpdir(tmp, sizeof tmp));
    mkdir(empty, 0755);
    /* The loader searches only VK_LAYER_PATH for explicit layers when it is set. */
    const char *saved = getenv("VK_LAYER_PATH");
    char saved_copy[1024] = "";
    if (saved)
        snprintf(saved_copy, sizeof saved_copy, "%s", saved);
    setenv("VK_LAYER_PATH", empty, 1);
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {.device_selector = NULL, .validation = 1};
    PF_CHECK(pf_vk_create(&options, &ctx, &err) == PF_ERR_UNSUPPORTED);
    PF_CHECK(ctx == NULL);
    PF_CHECK_MSG(strstr(err.message, "VK_LAYER_KHRONOS_validation") != NULL, "%s", err.message);
    if (saved)
        setenv("VK_LAYER_PATH", saved_copy, 1);
    else
        unsetenv("VK_LAYER_PATH");
    /* Validation off needs no layer at all. */
    setenv("VK_LAYER_PATH", empty, 1);
    options.validation = 0;
    PF_CHECK_OK(pf_vk_create(&options, &ctx, &err), &err);
    if (ctx) {
        PF_CHECK(!pf_vk_validation_enabled(ctx));
        pf_vk_destroy(ctx);
    }
    if (saved)
        setenv("VK_LAYER_PATH", saved_copy, 1);
    else
        unsetenv("VK_LAYER_PATH");
}

int main(void)
{
    PF_RUN(enumerate_lists_devices_with_limits);
    PF_RUN(select_by_index);
    PF_RUN(select_by_name_substring_ignoring_case);
    PF_RUN(core_ignores_the_environment);
    PF_RUN(bad_selector_lists_the_devices);
    PF_RUN(validation_counter_counts_messages);
    PF_RUN(missing_validation_layer_is_an_error);
    return pf_test_finish();
}
