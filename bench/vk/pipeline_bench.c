/*
 * Pipeline creation of the integrators' kernels, as a new process creates them before its
 * first frame: the milliseconds vkCreateComputePipelines takes per kernel (median of
 * ROUNDS, each a fresh pipeline of the same module and constants), and their sum. On
 * lavapipe that is the SPIR-V -> NIR translation and NIR's passes (the compiled code comes
 * from Mesa's disk cache after the first round), which the build's spirv-opt shortens
 * (bench/RESULTS.md, "Pipeline creation").
 *
 *   pipeline_bench [ROUNDS]     (default 5)
 *
 * Constants: a scene like the Cornell box (emitters, no punctual light, no specular, no
 * transmission, coat or sheen), the Gaussian pixel filter; "_surfaces" rows are the
 * textured variants. Only core/vk's public interface is used, so the same source builds
 * against older trees for an A/B.
 */
#include "pf_vk.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

enum { SCENE_BINDINGS = 10 };

typedef struct kernel {
    const char *name;
    uint32_t buffers;
    uint32_t mode; /* constant_id 0, where the kernel has one (UINT32_MAX: none) */
} kernel;

static const kernel kernels[] = {
    {"render_direct", SCENE_BINDINGS + 5, UINT32_MAX},
    {"render_reference", SCENE_BINDINGS + 6, 1},
    {"render_fast", SCENE_BINDINGS + 15, UINT32_MAX},
    {"render_fast_caustic", SCENE_BINDINGS + 15, UINT32_MAX},
    {"render_final", SCENE_BINDINGS + 28, UINT32_MAX},
    {"final_gather", SCENE_BINDINGS + 28, UINT32_MAX},
    {"final_gather_estimate", SCENE_BINDINGS + 28, UINT32_MAX},
    {"final_resolve", SCENE_BINDINGS + 28, UINT32_MAX},
    {"photon_trace", SCENE_BINDINGS + 13, UINT32_MAX},
    {"render_reference_surfaces", SCENE_BINDINGS + 6, 1},
    {"render_fast_surfaces", SCENE_BINDINGS + 15, UINT32_MAX},
    {"render_final_surfaces", SCENE_BINDINGS + 28, UINT32_MAX},
    {"final_gather_surfaces", SCENE_BINDINGS + 28, UINT32_MAX},
};

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int rounds = argc > 1 ? atoi(argv[1]) : 5;
    if (rounds < 1 || rounds > 100) {
        fprintf(stderr, "usage: pipeline_bench [ROUNDS 1..100]\n");
        return 2;
    }
    /* ids 1001..1010: alpha, corners, lights, transmission, emitters, specular, (1007 the
     * pixel filter), many lights, clearcoat, sheen. */
    const pf_vk_spec_constant scene[] = {{1001, 0}, {1002, 0}, {1003, 0}, {1004, 0}, {1005, 1},
                                         {1006, 0}, {1007, 0}, {1008, 0}, {1009, 0}, {1010, 0}};
    enum { SCENE_CONSTANTS = sizeof scene / sizeof *scene };
    pf_vk_options options = {0};
    pf_vk_context *ctx;
    pf_error err = {0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK) {
        fprintf(stderr, "pipeline_bench: %s\n", err.message);
        return 2;
    }
    printf("pipeline creation, median of %d rounds, ms (%s)\n", rounds, pf_vk_info(ctx)->name);
    double total = 0;
    double *times = calloc((size_t)rounds, sizeof *times);
    for (size_t k = 0; times && k < sizeof kernels / sizeof *kernels; k++) {
        pf_vk_spec_constant constants[SCENE_CONSTANTS + 1];
        memcpy(constants, scene, sizeof scene);
        uint32_t count = SCENE_CONSTANTS;
        if (kernels[k].mode != UINT32_MAX)
            constants[count++] = (pf_vk_spec_constant){0, kernels[k].mode};
        for (int r = 0; r < rounds; r++) {
            pf_vk_pipeline *pipeline = NULL;
            double start = now_ms();
            if (pf_vk_pipeline_create_named(ctx, kernels[k].name, kernels[k].buffers, 128,
                                            constants, count, &pipeline, &err) != PF_OK) {
                fprintf(stderr, "pipeline_bench: %s\n", err.message);
                free(times);
                pf_vk_destroy(ctx);
                return 2;
            }
            times[r] = now_ms() - start;
            pf_vk_pipeline_destroy(ctx, pipeline);
        }
        qsort(times, (size_t)rounds, sizeof *times, compare_doubles);
        printf("%-28s %8.1f\n", kernels[k].name, times[rounds / 2]);
        total += times[rounds / 2];
    }
    printf("%-28s %8.1f\n", "sum", total);
    free(times);
    pf_vk_destroy(ctx);
    return 0;
}
