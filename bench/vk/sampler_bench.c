/*
 * The reference sampler's cost on the device: shaders/sampler_probe.comp draws
 * 16 of sampler.glsl's 4D groups (shuffled, Owen-scrambled Sobol) an
 * invocation; prints ns a group (the best of REPEATS dispatches) and a checksum
 * of every number drawn, the same for two builds whose samplers agree bit for
 * bit.
 */
#include "bench_dispatch.h"
#include "pf_vk.h"

#include <stdio.h>
#include <stdlib.h>

#define INVOCATIONS (64u * 4096u)
#define GROUPS 16u /* sampler_probe.comp's */
#define REPEATS 7

int main(void)
{
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK) {
        fprintf(stderr, "sampler_bench: %s\n", err.message);
        return 1;
    }
    printf("sampler_bench: device %s (%s), %u invocations, %u groups each\n",
           pf_vk_info(ctx)->name, pf_vk_info(ctx)->driver, INVOCATIONS, GROUPS);
    pf_vk_pipeline *pipeline = NULL;
    pf_vk_buffer *words = NULL;
    uint32_t *seen = malloc((size_t)INVOCATIONS * sizeof *seen);
    int ok = seen && pf_vk_buffer_create(ctx, (uint64_t)INVOCATIONS * 4u, "sampler words", &words,
                                         &err) == PF_OK &&
             pf_vk_pipeline_create_named(ctx, "sampler_probe", 1, 8, NULL, 0, &pipeline, &err) ==
                 PF_OK;
    const uint32_t push[2] = {INVOCATIONS, 3u};
    double ms = ok ? bench_best_dispatch_ms(ctx, pipeline, &words, 1, push, sizeof push,
                                            INVOCATIONS / 64, REPEATS, &err)
                   : -1.0;
    ok = ms > 0.0 &&
         pf_vk_buffer_download(ctx, words, 0, seen, (uint64_t)INVOCATIONS * 4u, &err) == PF_OK;
    if (ok) {
        uint64_t checksum = 0;
        for (uint32_t i = 0; i < INVOCATIONS; i++)
            checksum = checksum * 0x100000001b3ull ^ seen[i];
        printf("  %.2f ns a 4D group; checksum %016llx\n",
               ms * 1e6 / ((double)INVOCATIONS * GROUPS), (unsigned long long)checksum);
    } else if (err.message[0]) {
        fprintf(stderr, "sampler_bench: %s\n", err.message);
    }
    pf_vk_pipeline_destroy(ctx, pipeline);
    pf_vk_buffer_destroy(ctx, words);
    free(seen);
    pf_vk_destroy(ctx);
    return ok ? 0 : 1;
}
