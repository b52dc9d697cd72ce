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

/* A large copy in slices, one per core: the first touch of fresh host pages (an image
 * allocated for the frame) costs a page fault each, which one core pays serially. */
#define COPY_SLICE_MIN (8u * 1024 * 1024)

typedef struct copy_slice {
    char *to;
    const char *from;
    uint64_t size;
} copy_slice;

static void copy_one_slice(void *item)
{
    copy_slice *slice = item;
    memcpy(slice->to, slice->from, slice->size);
}

void pf_vk_copy(pf_vk_context *ctx, void *to, const void *from, uint64_t size)
{
    double start = pf_time_ms();
    uint32_t slices = size / COPY_SLICE_MIN > 64 ? 64 : (uint32_t)(size / COPY_SLICE_MIN);
    slices = pf_cpu_cores(slices > 0 ? slices : 1);
    if (slices <= 1) {
        memcpy(to, from, size);
    } else {
        copy_slice parts[64];
        uint64_t step = (size + slices - 1) / slices;
        uint32_t count = 0;
        for (uint64_t at = 0; at < size; at += step, count++)
            parts[count] = (copy_slice){(char *)to + at, (const char *)from + at,
                                        size - at < step ? size - at : step};
        pf_run_parallel(parts, sizeof parts[0], count, copy_one_slice);
    }
    pf_vk_time_add(&ctx->copy_ns, start);
}

void pf_vk_count_copy(pf_vk_context *ctx, uint64_t bytes, int upload)
{
    atomic_fetch_add(upload ? &ctx->upload_bytes : &ctx->readback_bytes, bytes);
}
