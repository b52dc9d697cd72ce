/*
 * The vk benches' one timing loop (header only: each bench is a program of its own): a
 * dispatch submitted repeats times, each in a submission of its own, and the best
 * host-measured time of all but the first (which pays the shader's compile), in ms;
 * -1 on a failure (err says which).
 */
#ifndef PF_BENCH_DISPATCH_H
#define PF_BENCH_DISPATCH_H

#include "pf_vk.h"

static inline double bench_best_dispatch_ms(pf_vk_context *ctx, pf_vk_pipeline *pipeline,
                                             pf_vk_buffer **buffers, uint32_t buffer_count,
                                             const void *push, uint32_t push_bytes,
                                             uint32_t groups, int repeats, pf_error *err)
{
    double best = -1.0;
    for (int r = 0; r < repeats; r++) {
        pf_vk_commands *cmds = NULL;
        if (pf_vk_commands_begin(ctx, &cmds, err) != PF_OK)
            return -1.0;
        double start = pf_time_ms();
        pf_status status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, buffer_count, push,
                                              push_bytes, groups, 1, 1, err);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, err);
        double ms = pf_time_ms() - start;
        pf_vk_commands_destroy(cmds);
        if (status != PF_OK)
            return -1.0;
        if (r > 0 && (best < 0.0 || ms < best))
            best = ms;
    }
    return best;
}

#endif
