/* Helpers shared by the core/vk tests. */
#ifndef VK_TEST_UTIL_H
#define VK_TEST_UTIL_H

#include "pf_test.h"
#include "pf_vk.h"

/* Options as the test environment asks for them: validation when
 * PF_VK_VALIDATION is 1 (ctest sets it for VULKAN tests; core reads no
 * environment itself). */
static inline pf_vk_options vk_test_options(void)
{
    const char *validation = getenv("PF_VK_VALIDATION");
    pf_vk_options options = {0};
    options.validation = validation && !strcmp(validation, "1");
    return options;
}

/* A context as the test environment asks for it (PF_VK_VALIDATION=1 under ctest). */
static inline pf_vk_context *vk_test_context(pf_error *err)
{
    pf_vk_context *ctx = NULL;
    pf_vk_options options = vk_test_options();
    if (pf_vk_create(&options, &ctx, err) != PF_OK) {
        fprintf(stderr, "pf_vk_create failed: %s\n", err->message);
        return NULL;
    }
    const char *validation = getenv("PF_VK_VALIDATION");
    if (validation && !strcmp(validation, "1") && !pf_vk_validation_enabled(ctx)) {
        fprintf(stderr, "PF_VK_VALIDATION=1 but validation is off\n");
        pf_test_failures++;
    }
    return ctx;
}

/* Every VULKAN test ends here: zero validation messages, then the context is gone. */
#define VK_TEST_FINISH(ctx)                                                               \
    do {                                                                                  \
        PF_CHECK_MSG(pf_vk_validation_message_count(ctx) == 0, "%u validation messages",  \
                     pf_vk_validation_message_count(ctx));                                \
        pf_vk_destroy(ctx);                                                               \
    } while (0)

#endif
