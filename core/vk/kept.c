/*
 * Buffers kept for reuse instead of freed: device-local storage buffers and staging
 * buffers. A GPU driver clears every new device allocation and pins host memory the device
 * can reach page by page, and a 1920x1080 `final` frame makes some 700 MB of storage
 * buffers (film, path vertices, bands of the split image, the denoiser's planes) and 370 MB
 * of staging (the film's 215 MB readback, the denoiser's uploads): on an H200 that was
 * 90-145 ms of shade's wall time and 70-100 ms of denoise's a frame, for 17 and 1 ms of
 * GPU. Frames repeat their sizes, so what one frame frees the next one takes.
 *
 * A kept storage buffer serves a request of exactly its allocated size
 * (pf_vk_buffer_allocation_size: its texel views stay valid); a kept staging buffer one of
 * its direction that it holds and that needs at least half of it. The oldest go first
 * where a new one would pass the slots or the bytes (PF_VK_*_KEPT*; a frame holds some 60
 * storage buffers at once, so fewer slots had each frame allocate anew); where the device
 * runs out of memory, memory.c frees them all and tries again. Kept memory is not counted
 * as in use (the frames' memory rows count what frames use). It holds its last user's
 * data: no kernel may read what it did not write first (with validation on, new mapped
 * buffers start as NaN bytes so that the tests check it on lavapipe).
 */
#include "pf_vk_internal.h"

#include <string.h>

/* Mapped buffers are the host's memory (lavapipe's): cheap to make, not kept. */
static uint64_t buffer_bytes_most(const pf_vk_context *ctx)
{
    uint64_t quarter = ctx->info.device_local_bytes / 4;
    return quarter < PF_VK_BUFFERS_KEPT_BYTES ? quarter : PF_VK_BUFFERS_KEPT_BYTES;
}

pf_vk_buffer *pf_vk_kept_buffer_take(pf_vk_context *ctx, uint64_t allocated)
{
    pf_vk_buffer *found = NULL;
    pthread_mutex_lock(&ctx->kept_lock);
    for (uint32_t i = ctx->buffers_kept_count; i-- > 0 && !found;) {
        if (ctx->buffers_kept[i]->allocated != allocated)
            continue;
        found = ctx->buffers_kept[i];
        memmove(&ctx->buffers_kept[i], &ctx->buffers_kept[i + 1],
                (ctx->buffers_kept_count - i - 1) * sizeof ctx->buffers_kept[0]);
        ctx->buffers_kept_count--;
    }
    pthread_mutex_unlock(&ctx->kept_lock);
    if (found)
        pf_vk_memory_held(ctx, found->memory_bytes); /* in use again */
    return found;
}

int pf_vk_kept_buffer_put(pf_vk_context *ctx, pf_vk_buffer *buffer)
{
    uint64_t most = buffer_bytes_most(ctx);
    if (buffer->mapped || buffer->memory_bytes > most)
        return 0;
    pf_vk_buffer *evicted[PF_VK_BUFFERS_KEPT];
    uint32_t evicted_count = 0;
    pthread_mutex_lock(&ctx->kept_lock);
    uint64_t bytes = buffer->memory_bytes;
    for (uint32_t i = 0; i < ctx->buffers_kept_count; i++)
        bytes += ctx->buffers_kept[i]->memory_bytes;
    while (ctx->buffers_kept_count > 0 &&
           (ctx->buffers_kept_count == PF_VK_BUFFERS_KEPT || bytes > most)) {
        evicted[evicted_count++] = ctx->buffers_kept[0];
        bytes -= ctx->buffers_kept[0]->memory_bytes;
        memmove(&ctx->buffers_kept[0], &ctx->buffers_kept[1],
                (ctx->buffers_kept_count - 1) * sizeof ctx->buffers_kept[0]);
        ctx->buffers_kept_count--;
    }
    ctx->buffers_kept[ctx->buffers_kept_count++] = buffer;
    pf_vk_memory_released(ctx, buffer->memory_bytes);
    pthread_mutex_unlock(&ctx->kept_lock);
    for (uint32_t i = 0; i < evicted_count; i++)
        pf_vk_buffer_free(ctx, evicted[i], 0);
    return 1;
}

int pf_vk_kept_staging_take(pf_vk_context *ctx, uint64_t size, int to_device,
                            pf_vk_staging *out)
{
    pthread_mutex_lock(&ctx->kept_lock);
    uint32_t best = UINT32_MAX;
    for (uint32_t i = 0; i < ctx->staging_kept_count; i++) {
        const pf_vk_staging *kept = &ctx->staging_kept[i];
        if (kept->to_device == to_device && kept->capacity >= size &&
            kept->capacity / 2 <= size &&
            (best == UINT32_MAX || kept->capacity < ctx->staging_kept[best].capacity))
            best = i;
    }
    if (best != UINT32_MAX) {
        *out = ctx->staging_kept[best];
        memmove(&ctx->staging_kept[best], &ctx->staging_kept[best + 1],
                (ctx->staging_kept_count - best - 1) * sizeof ctx->staging_kept[0]);
        ctx->staging_kept_count--;
    }
    pthread_mutex_unlock(&ctx->kept_lock);
    if (best != UINT32_MAX)
        pf_vk_memory_held(ctx, out->bytes); /* in use again */
    return best != UINT32_MAX;
}

int pf_vk_kept_staging_put(pf_vk_context *ctx, const pf_vk_staging *staging)
{
    if (!staging->buffer || !staging->memory || !staging->mapped ||
        staging->bytes > PF_VK_STAGING_KEPT_BYTES)
        return 0;
    pf_vk_staging evicted[PF_VK_STAGING_KEPT];
    uint32_t evicted_count = 0;
    pthread_mutex_lock(&ctx->kept_lock);
    uint64_t bytes = staging->bytes;
    for (uint32_t i = 0; i < ctx->staging_kept_count; i++)
        bytes += ctx->staging_kept[i].bytes;
    while (ctx->staging_kept_count > 0 && (ctx->staging_kept_count == PF_VK_STAGING_KEPT ||
                                           bytes > PF_VK_STAGING_KEPT_BYTES)) {
        evicted[evicted_count++] = ctx->staging_kept[0];
        bytes -= ctx->staging_kept[0].bytes;
        memmove(&ctx->staging_kept[0], &ctx->staging_kept[1],
                (ctx->staging_kept_count - 1) * sizeof ctx->staging_kept[0]);
        ctx->staging_kept_count--;
    }
    ctx->staging_kept[ctx->staging_kept_count++] = *staging;
    pf_vk_memory_released(ctx, staging->bytes);
    pthread_mutex_unlock(&ctx->kept_lock);
    for (uint32_t i = 0; i < evicted_count; i++)
        pf_vk_staging_free(ctx, &evicted[i], 0);
    return 1;
}

uint32_t pf_vk_kept_release(pf_vk_context *ctx)
{
    pf_vk_buffer *buffers[PF_VK_BUFFERS_KEPT];
    pf_vk_staging staging[PF_VK_STAGING_KEPT];
    pthread_mutex_lock(&ctx->kept_lock);
    uint32_t buffer_count = ctx->buffers_kept_count, staging_count = ctx->staging_kept_count;
    memcpy(buffers, ctx->buffers_kept, buffer_count * sizeof buffers[0]);
    memcpy(staging, ctx->staging_kept, staging_count * sizeof staging[0]);
    ctx->buffers_kept_count = ctx->staging_kept_count = 0;
    pthread_mutex_unlock(&ctx->kept_lock);
    for (uint32_t i = 0; i < buffer_count; i++)
        pf_vk_buffer_free(ctx, buffers[i], 0);
    for (uint32_t i = 0; i < staging_count; i++)
        pf_vk_staging_free(ctx, &staging[i], 0);
    return buffer_count + staging_count;
}

void pf_vk_kept_counts(pf_vk_context *ctx, uint32_t *buffers, uint32_t *staging)
{
    pthread_mutex_lock(&ctx->kept_lock);
    *buffers = ctx->buffers_kept_count;
    *staging = ctx->staging_kept_count;
    pthread_mutex_unlock(&ctx->kept_lock);
}
