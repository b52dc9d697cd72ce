/* The host's traffic with the device (pf_vk_traffic): counts, times and the copies. */
#include "pf_vk_internal.h"

#include <string.h>

pf_vk_traffic pf_vk_traffic_of(pf_vk_context *ctx)
{
    return (pf_vk_traffic){atomic_load(&ctx->submits),
                           atomic_load(&ctx->host_waits),
                           atomic_load(&ctx->readback_bytes),
                           atomic_load(&ctx->upload_bytes),
                           atomic_load(&ctx->wait_ns) / 1e6,
                           atomic_load(&ctx->allocate_ns) / 1e6,
                           atomic_load(&ctx->copy_ns) / 1e6};
}

uint64_t pf_vk_waits_behind(pf_vk_context *ctx)
{
    return atomic_load(&ctx->waits_behind);
}

pf_vk_traffic pf_vk_traffic_since(pf_vk_context *ctx, pf_vk_traffic before)
{
    pf_vk_traffic now = pf_vk_traffic_of(ctx);
    return (pf_vk_traffic){now.submits - before.submits,
                           now.host_waits - before.host_waits,
                           now.readback_bytes - before.readback_bytes,
                           now.upload_bytes - before.upload_bytes,
                           now.wait_ms - before.wait_ms,
                           now.allocate_ms - before.allocate_ms,
                           now.copy_ms - before.copy_ms};
}

void pf_vk_time_add(_Atomic uint64_t *total_ns, double start_ms)
{
    double ns = (pf_time_ms() - start_ms) * 1e6;
    atomic_fetch_add(total_ns, ns > 0.0 ? (uint64_t)ns : 0);
}

/* A large copy in slices, one per core (pf_run_ranges): the first touch of fresh host
 * pages (an image allocated for the frame) costs a page fault each, which one core pays
 * serially. Slices of 8 MB at least. */
#define COPY_SLICE_MIN (8u * 1024 * 1024)

typedef struct copy_job {
    char *to;
    const char *from;
} copy_job;

static void copy_range(void *context, uint64_t begin, uint64_t end)
{
    const copy_job *job = context;
    memcpy(job->to + begin, job->from + begin, end - begin);
}

void pf_vk_copy(pf_vk_context *ctx, void *to, const void *from, uint64_t size)
{
    double start = pf_time_ms();
    copy_job job = {to, from};
    pf_run_ranges(size, PF_RUN_RANGES_MAX, COPY_SLICE_MIN, copy_range, &job);
    pf_vk_time_add(&ctx->copy_ns, start);
}

void pf_vk_count_copy(pf_vk_context *ctx, uint64_t bytes, int upload)
{
    atomic_fetch_add(upload ? &ctx->upload_bytes : &ctx->readback_bytes, bytes);
}
