/*
 * Read paths of the Vulkan device: dependent 3-word reads (one BIH node's
 * worth per step) through a storage buffer against the same words through a
 * uniform texel buffer, one R32 uint fetch a word or one RGBA32 fetch a node
 * (shaders/load_probe.comp), for a chain of nodes that fits the caches and
 * one that does not. Prints ns per invocation-step and the ratios; every
 * path must sum the same words.
 */
#include "bench_dispatch.h"
#include "pf_vk.h"

#include <stdio.h>
#include <stdlib.h>

#define INVOCATIONS (64u * 4096u)
#define STEPS 64u
#define REPEATS 4
#define PATHS 3 /* storage, R32 texels, RGBA32 texels */

static const char *const path_names[PATHS] = {"storage buffer", "R32 texels", "RGBA32 texels"};

int main(void)
{
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK) {
        fprintf(stderr, "load_bench: %s\n", err.message);
        return 1;
    }
    printf("load_bench: device %s (%s), %u invocations x %u steps of 3 words\n",
           pf_vk_info(ctx)->name, pf_vk_info(ctx)->driver, INVOCATIONS, STEPS);
    pf_vk_pipeline *pipelines[PATHS] = {NULL, NULL, NULL};
    for (uint32_t path = 0; path < PATHS; path++) {
        const pf_vk_spec_constant spec[] = {{0, path}};
        if (pf_vk_pipeline_create_named(ctx, "load_probe", 4, 8, spec, 1, &pipelines[path],
                                        &err) != PF_OK) {
            fprintf(stderr, "load_bench: %s\n", err.message);
            return 1;
        }
    }
    static const uint32_t sizes[] = {16384u, 1u << 20}; /* 256 KiB, 16 MiB of nodes */
    int ok = 1;
    for (size_t s = 0; s < 2 && ok; s++) {
        uint32_t nodes = sizes[s];
        uint32_t *words = malloc((size_t)nodes * 16);
        uint32_t *sums[PATHS] = {malloc(INVOCATIONS * 4), malloc(INVOCATIONS * 4),
                                 malloc(INVOCATIONS * 4)};
        pf_vk_buffer *buffers[4] = {NULL, NULL, NULL, NULL};
        ok = words && sums[0] && sums[1] && sums[2] &&
             pf_vk_buffer_create(ctx, (uint64_t)nodes * 16, "load words", &buffers[0], &err) ==
                 PF_OK &&
             pf_vk_buffer_create(ctx, INVOCATIONS * 4, "load sums", &buffers[2], &err) == PF_OK;
        uint32_t state = 1u;
        for (uint32_t n = 0; ok && n < nodes; n++) {
            state = state * 1664525u + 1013904223u; /* a random next node: no locality */
            words[4 * n] = state % nodes;
            words[4 * n + 1] = n;
            words[4 * n + 2] = state;
            words[4 * n + 3] = 0;
        }
        ok = ok && pf_vk_buffer_upload(ctx, buffers[0], 0, words, (uint64_t)nodes * 16, &err) ==
                       PF_OK;
        buffers[1] = buffers[3] = buffers[0]; /* the same words, bound every way */
        double ms[PATHS] = {-1.0, -1.0, -1.0};
        for (int path = 0; ok && path < PATHS; path++) {
            const uint32_t push[2] = {nodes, STEPS};
            ms[path] = bench_best_dispatch_ms(ctx, pipelines[path], buffers, 4, push,
                                              sizeof push, INVOCATIONS / 64, REPEATS, &err);
            ok = ms[path] > 0.0 && pf_vk_buffer_download(ctx, buffers[2], 0, sums[path],
                                                         INVOCATIONS * 4, &err) == PF_OK;
        }
        int same = ok;
        for (uint32_t i = 0; same && i < INVOCATIONS; i++)
            same = sums[0][i] == sums[1][i] && sums[0][i] == sums[2][i];
        if (ok) {
            printf("%8u nodes (%5.1f MiB):", nodes, nodes * 16.0 / 1048576.0);
            for (int path = 0; path < PATHS; path++)
                printf(" %s %7.2f ns,", path_names[path],
                       ms[path] * 1e6 / (INVOCATIONS * (double)STEPS));
            printf(" per invocation-step; storage / R32 %.2fx, R32 / RGBA32 %.2fx, sums %s\n",
                   ms[0] / ms[1], ms[1] / ms[2], same ? "equal" : "DIFFER");
        }
        ok = ok && same;
        pf_vk_buffer_destroy(ctx, buffers[0]);
        pf_vk_buffer_destroy(ctx, buffers[2]);
        free(words);
        for (int path = 0; path < PATHS; path++)
            free(sums[path]);
    }
    if (!ok && err.message[0])
        fprintf(stderr, "load_bench: %s\n", err.message);
    for (int path = 0; path < PATHS; path++)
        pf_vk_pipeline_destroy(ctx, pipelines[path]);
    pf_vk_destroy(ctx);
    return ok ? 0 : 1;
}
