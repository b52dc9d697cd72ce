/*
 * Store paths of the Vulkan device: a 160-byte record an invocation (the
 * reference wavefront's path state) written as 10 vec4 stores against 5
 * u64vec4 stores of the same bytes, and against one word (what the rest of
 * the dispatch costs) (shaders/store_probe.comp). Prints ns per record and
 * checks that both ways wrote the same bytes.
 */
#include "bench_dispatch.h"
#include "pf_vk.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define INVOCATIONS (64u * 4096u)
#define RECORD_BYTES 160u
#define REPEATS 5
#define PATHS 3

static const char *const path_names[PATHS] = {"10 vec4", "5 u64vec4", "one word"};

int main(void)
{
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK) {
        fprintf(stderr, "store_bench: %s\n", err.message);
        return 1;
    }
    printf("store_bench: device %s (%s), %u invocations, a %u-byte record each\n",
           pf_vk_info(ctx)->name, pf_vk_info(ctx)->driver, INVOCATIONS, RECORD_BYTES);
    const uint64_t bytes = (uint64_t)INVOCATIONS * RECORD_BYTES;
    pf_vk_pipeline *pipelines[PATHS] = {NULL, NULL, NULL};
    pf_vk_buffer *records = NULL;
    unsigned char *seen[2] = {malloc(bytes), malloc(bytes)};
    int ok = seen[0] && seen[1] &&
             pf_vk_buffer_create(ctx, bytes, "store records", &records, &err) == PF_OK;
    for (uint32_t path = 0; ok && path < PATHS; path++) {
        const pf_vk_spec_constant spec[] = {{0, path}};
        ok = pf_vk_pipeline_create_named(ctx, "store_probe", 1, 4, spec, 1, &pipelines[path],
                                         &err) == PF_OK;
    }
    double ms[PATHS] = {-1.0, -1.0, -1.0};
    for (int path = 0; ok && path < PATHS; path++) {
        const uint32_t push[1] = {INVOCATIONS};
        ms[path] = bench_best_dispatch_ms(ctx, pipelines[path], &records, 1, push, sizeof push,
                                          INVOCATIONS / 64, REPEATS, &err);
        ok = ms[path] > 0.0;
        if (ok && path < 2)
            ok = pf_vk_buffer_download(ctx, records, 0, seen[path], bytes, &err) == PF_OK;
    }
    int same = ok && memcmp(seen[0], seen[1], bytes) == 0;
    if (ok) {
        for (int path = 0; path < PATHS; path++)
            printf("  %-10s %7.2f ns a record\n", path_names[path],
                   ms[path] * 1e6 / INVOCATIONS);
        printf("  stores alone: 10 vec4 %.2f ns, 5 u64vec4 %.2f ns (%.2fx); bytes %s\n",
               (ms[0] - ms[2]) * 1e6 / INVOCATIONS, (ms[1] - ms[2]) * 1e6 / INVOCATIONS,
               (ms[0] - ms[2]) / (ms[1] - ms[2]), same ? "equal" : "DIFFER");
    }
    ok = ok && same;
    if (!ok && err.message[0])
        fprintf(stderr, "store_bench: %s\n", err.message);
    for (int path = 0; path < PATHS; path++)
        pf_vk_pipeline_destroy(ctx, pipelines[path]);
    pf_vk_buffer_destroy(ctx, records);
    free(seen[0]);
    free(seen[1]);
    pf_vk_destroy(ctx);
    return ok ? 0 : 1;
}
