/*
 * A queue of closest-hit rays that a kernel writes and the host traces in
 * place (issue 43), where the device is the CPU: its memory is the host's,
 * and the wide AVX2 BIH traversal on every core (wave_trace.c) traces
 * several times faster than the device's GLSL loop. final's gather writes
 * the first segments of its gather rays here (final_gather.glsl's
 * GATHER_STEP), the host traces them, and the gather reads the hits.
 */
#include "render_internal.h"

#include <stdlib.h>
#include <string.h>

enum { HOST_RAYS, HOST_HITS, HOST_QUEUE, HOST_BUFFER_COUNT };

struct pf_host_rays {
    pf_vk_context *ctx;
    uint32_t slots;
    pf_vk_buffer *buffers[HOST_BUFFER_COUNT];
    pf_wave_queues queues; /* the buffers as the host sees them */
    uint32_t *active;      /* the trace step's list of slots, rewritten by each trace */
    pf_wave_tracer *tracer;
};

void pf_host_rays_destroy(pf_host_rays *queue)
{
    if (!queue)
        return;
    for (int b = 0; b < HOST_BUFFER_COUNT; b++)
        pf_render_buffer_release(queue->ctx, &queue->buffers[b]);
    pf_wave_tracer_destroy(queue->tracer);
    free(queue->active);
    free(queue);
}

pf_status pf_host_rays_create(pf_renderer *renderer, uint32_t slots, const char *label,
                              pf_host_rays **out, pf_error *err)
{
    *out = NULL;
    pf_host_rays *queue = calloc(1, sizeof *queue);
    if (!queue)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", label);
    queue->ctx = renderer->ctx;
    queue->slots = slots;
    const uint64_t sizes[HOST_BUFFER_COUNT] = {(uint64_t)slots * sizeof(pf_ray),
                                               (uint64_t)slots * sizeof(pf_hit),
                                               (uint64_t)slots * sizeof(uint32_t)};
    pf_status status = PF_OK;
    for (int b = 0; status == PF_OK && b < HOST_BUFFER_COUNT; b++) {
        status = pf_vk_buffer_create(renderer->ctx, sizes[b], label, &queue->buffers[b], err);
        if (status == PF_OK && !pf_vk_buffer_host_memory(queue->buffers[b]))
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "%s: the device's buffers are not in host memory (the host "
                                  "traces only where the device is the CPU)",
                                  label);
    }
    queue->active = status == PF_OK ? malloc(((size_t)slots + 1) * sizeof *queue->active) : NULL;
    if (status == PF_OK && !queue->active)
        status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for %u rays", label, slots);
    if (status == PF_OK) {
        queue->queues.rays = pf_vk_buffer_host_memory(queue->buffers[HOST_RAYS]);
        queue->queues.hits = pf_vk_buffer_host_memory(queue->buffers[HOST_HITS]);
        queue->queues.queue = pf_vk_buffer_host_memory(queue->buffers[HOST_QUEUE]);
        /* Closest hits only: a slot's word is 1 or 0, no shadow rays. */
        status = pf_wave_tracer_create(&renderer->bih, slots, 1, &queue->tracer, err);
    }
    if (status != PF_OK) {
        pf_host_rays_destroy(queue);
        return status;
    }
    *out = queue;
    return PF_OK;
}

void pf_host_rays_buffers(const pf_host_rays *queue, pf_vk_buffer *out[3])
{
    memcpy(out, queue->buffers, sizeof queue->buffers);
}

uint32_t pf_host_rays_threads(const pf_host_rays *queue)
{
    return pf_wave_tracer_threads(queue->tracer);
}

pf_status pf_host_rays_trace(pf_host_rays *queue, uint32_t count, uint64_t *rays,
                             double *host_ms, pf_error *err)
{
    if (count > queue->slots)
        return pf_error_set(err, PF_ERR_INTERNAL, "host rays: %u slots of %u", count,
                            queue->slots);
    double start = pf_time_ms();
    for (uint32_t i = 0; i < count; i++)
        queue->active[i] = i;
    uint32_t remaining = 0, hit = 0;
    pf_status status = pf_wave_trace(queue->tracer, &queue->queues, queue->active, count,
                                     &remaining, &hit, rays, err);
    *host_ms += pf_time_ms() - start;
    return status;
}
