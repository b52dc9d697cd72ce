/*
 * The Vulkan context and renderer a tests/render program runs against:
 * created as the test environment asks (vk_test_context: validation from
 * PF_VK_VALIDATION, and checked to be on when asked), torn down with the
 * zero-validation-messages check (VK_TEST_FINISH).
 */
#ifndef RENDER_TEST_ENV_H
#define RENDER_TEST_ENV_H

#include "../vk/vk_test_util.h"
#include "pf_render.h"

/* 1 with *ctx and *renderer created; 0 after printing why. */
static inline int render_test_setup(pf_vk_context **ctx, pf_renderer **renderer)
{
    pf_error err = {0};
    *renderer = NULL;
    *ctx = vk_test_context(&err);
    if (!*ctx)
        return 0;
    if (pf_renderer_create(*ctx, renderer, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        pf_vk_destroy(*ctx);
        *ctx = NULL;
        return 0;
    }
    return 1;
}

/* Destroys both, failing the test on any validation message; returns the exit status. */
static inline int render_test_finish(pf_vk_context *ctx, pf_renderer *renderer)
{
    pf_renderer_destroy(renderer);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}

#endif
