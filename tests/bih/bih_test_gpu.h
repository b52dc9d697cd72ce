/*
 * The GPU side of the BIH tests: one Vulkan context with the brute-force
 * oracle (pf_raycast_brute_force), a pf_bih_gpu to trace uploaded trees and
 * a GPU builder, and the oracle/traversal calls that fill a bih_ray_set.
 */
#ifndef BIH_TEST_GPU_H
#define BIH_TEST_GPU_H

#include "bih_test_util.h"
#include "pf_render.h"
#include "../vk/vk_test_util.h"

typedef struct bih_gpu_env {
    pf_vk_context *ctx;
    pf_renderer *renderer;
    pf_bih_gpu *gpu;
    pf_bih_gpu_builder *builder;
} bih_gpu_env;

/* Creates everything (validation on when PF_VK_VALIDATION says so); 0 and a message on failure. */
static inline int bih_gpu_env_create(bih_gpu_env *env)
{
    memset(env, 0, sizeof *env);
    pf_error err = {0};
    pf_vk_options options = vk_test_options();
    if (pf_vk_create(&options, &env->ctx, &err) != PF_OK ||
        pf_renderer_create(env->ctx, &env->renderer, &err) != PF_OK ||
        pf_bih_gpu_create(env->ctx, &env->gpu, &err) != PF_OK ||
        pf_bih_gpu_builder_create(env->ctx, &env->builder, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 0;
    }
    return 1;
}

/* Destroys env and checks that the validation layer stayed silent. */
static inline void bih_gpu_env_destroy(bih_gpu_env *env)
{
    pf_bih_gpu_builder_destroy(env->builder);
    pf_bih_gpu_destroy(env->gpu);
    pf_renderer_destroy(env->renderer);
    uint32_t messages = env->ctx ? pf_vk_validation_message_count(env->ctx) : 0;
    pf_vk_destroy(env->ctx);
    PF_CHECK_MSG(messages == 0, "%u validation messages", messages);
    memset(env, 0, sizeof *env);
}

/* The GPU brute-force oracle's closest hits into set->oracle. */
static inline void bih_oracle_gpu(bih_gpu_env *env, const pf_scene_frame *frame, bih_ray_set *set)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_raycast_brute_force(env->renderer, frame, set->rays, set->count, set->oracle,
                                       &err),
                &err);
}

/* Uploads bih and traces set->rays on the GPU, closest and any hit, into set->closest and set->any. */
static inline void bih_trace_gpu_both(bih_gpu_env *env, const pf_bih *bih, bih_ray_set *set)
{
    pf_error err = {0};
    /* Misses where a failed call leaves nothing, so the comparison reports it, never reads garbage. */
    for (uint32_t r = 0; r < set->count; r++)
        set->closest[r] = set->any[r] = (pf_hit){-1.0f, PF_NO_HIT, 0.0f, 0.0f};
    PF_CHECK_OK(pf_bih_gpu_upload(env->gpu, bih, &err), &err);
    PF_CHECK_OK(pf_bih_raycast(env->gpu, set->rays, set->count, 0, set->closest, &err), &err);
    PF_CHECK_OK(pf_bih_raycast(env->gpu, set->rays, set->count, 1, set->any, &err), &err);
}

#endif
