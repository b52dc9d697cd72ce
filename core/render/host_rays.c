/*
 * A queue of closest-hit rays that a shade kernel writes and the host traces
 * in place (issue 43), where the device is the CPU: its memory is the host's,
 * and the wide AVX2 BIH traversal on every core (wave_trace.c) traces several
 * times faster than the device's GLSL loop. final's primary and fast write
 * their camera rays here, final's gather its rays' first segments
 * (shaders/common/host_rays.glsl's TRACE_STEP); the host traces them; the
 * kernels read the hits.
 */
#include "render_internal.h"

#include <stdlib.h>
#include <string.h>

/*
 * The kernels go in bands of rows of at most this many pixels, so that the queue (52 bytes
 * a ray) stays bounded at any image size: ~54 MB at 4 rays a pixel...
 */
#define HOST_RAYS_BAND_PIXELS (1u << 18)
/* ... and of whole groups of the shade kernels' 8 × 8, so that no group lies in two bands. */
#define HOST_RAYS_GROUP_EDGE 8u

enum { HOST_RAYS, HOST_HITS, HOST_QUEUE, HOST_BUFFER_COUNT };

struct pf_host_rays {
    pf_vk_context *ctx;
    uint32_t band_rows, slots;
    pf_vk_buffer *buffers[HOST_BUFFER_COUNT];
    pf_bih_wave_queues queues; /* the buffers as the host sees them */
    uint32_t *active;      /* the trace step's list of slots, rewritten by each trace */
    pf_bih_wave_tracer *tracer;
};

void pf_host_rays_destroy(pf_host_rays *queue)
{
    if (!queue)
        return;
    for (int b = 0; b < HOST_BUFFER_COUNT; b++)
        pf_render_buffer_release(queue->ctx, &queue->buffers[b]);
    pf_bih_wave_tracer_destroy(queue->tracer);
    free(queue->active);
    free(queue);
}

pf_status pf_host_rays_create(pf_renderer *renderer, uint32_t width, uint32_t height,
                              uint32_t rays_per_pixel, const char *label, pf_host_rays **out,
                              pf_error *err)
{
    *out = NULL;
    pf_host_rays *queue = calloc(1, sizeof *queue);
    if (!queue)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", label);
    queue->ctx = renderer->ctx;
    uint32_t rows = HOST_RAYS_BAND_PIXELS / width / HOST_RAYS_GROUP_EDGE * HOST_RAYS_GROUP_EDGE;
    uint32_t image_rows = (height + HOST_RAYS_GROUP_EDGE - 1) / HOST_RAYS_GROUP_EDGE *
                          HOST_RAYS_GROUP_EDGE;
    /* No more rows than the image has: a small image's queue is small. */
    queue->band_rows = rows > HOST_RAYS_GROUP_EDGE ? rows : HOST_RAYS_GROUP_EDGE;
    if (queue->band_rows > image_rows)
        queue->band_rows = image_rows;
    queue->slots = queue->band_rows * width * rays_per_pixel;
    const uint64_t sizes[HOST_BUFFER_COUNT] = {(uint64_t)queue->slots * sizeof(pf_ray),
                                               (uint64_t)queue->slots * sizeof(pf_hit),
                                               (uint64_t)queue->slots * sizeof(uint32_t)};
    pf_status status = PF_OK;
    for (int b = 0; status == PF_OK && b < HOST_BUFFER_COUNT; b++) {
        status = pf_vk_buffer_create(renderer->ctx, sizes[b], label, &queue->buffers[b], err);
        if (status == PF_OK && !pf_vk_buffer_host_memory(queue->buffers[b]))
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "%s: the device's buffers are not in host memory (the host "
                                  "traces only where the device is the CPU)",
                                  label);
    }
    queue->active =
        status == PF_OK ? malloc(((size_t)queue->slots + 1) * sizeof *queue->active) : NULL;
    if (status == PF_OK && !queue->active)
        status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for %u rays", label,
                              queue->slots);
    if (status == PF_OK) {
        queue->queues.rays = pf_vk_buffer_host_memory(queue->buffers[HOST_RAYS]);
        queue->queues.hits = pf_vk_buffer_host_memory(queue->buffers[HOST_HITS]);
        queue->queues.queue = pf_vk_buffer_host_memory(queue->buffers[HOST_QUEUE]);
        /* Closest hits only: a slot's word is 1 or 0, no shadow rays. */
        status = pf_renderer_wave_tracer_create(renderer, queue->slots, 1, &queue->tracer, err);
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
    return pf_bih_wave_tracer_threads(queue->tracer);
}

/* Traces the rays of slots [0, count) that the queue marks, writing their hits. */
static pf_status trace(pf_host_rays *queue, uint32_t count, pf_host_trace_totals *totals,
                       pf_error *err)
{
    if (count > queue->slots)
        return pf_error_set(err, PF_ERR_INTERNAL, "host rays: %u slots of %u", count,
                            queue->slots);
    double start = pf_time_ms();
    for (uint32_t i = 0; i < count; i++)
        queue->active[i] = i;
    uint32_t remaining = 0, hit = 0;
    pf_status status = pf_bih_wave_trace(queue->tracer, &queue->queues, queue->active, count,
                                     &remaining, &hit, &totals->rays, err);
    totals->host_ms += pf_time_ms() - start;
    totals->traces++;
    return status;
}

pf_status pf_host_rays_dispatch(pf_host_rays *queue, const pf_host_traced_kernel *kernel,
                                pf_vk_commands **cmds, int *begin, pf_host_trace_totals *totals,
                                pf_error *err)
{
    pf_status status = PF_OK;
    uint32_t groups_x = (kernel->width + HOST_RAYS_GROUP_EDGE - 1) / HOST_RAYS_GROUP_EDGE;
    for (uint32_t row = 0; status == PF_OK && row < kernel->height; row += queue->band_rows) {
        uint32_t rows = kernel->height - row < queue->band_rows ? kernel->height - row
                                                                : queue->band_rows;
        uint32_t groups_y = (rows + HOST_RAYS_GROUP_EDGE - 1) / HOST_RAYS_GROUP_EDGE;
        *kernel->write.row_first = *kernel->given.row_first = row;
        pf_vk_cmd_barrier(*cmds);
        status = pf_vk_cmd_dispatch(*cmds, kernel->write.pipeline, kernel->write.buffers,
                                    kernel->write.buffer_count, kernel->write.push,
                                    kernel->write.push_bytes, groups_x, groups_y, 1, err);
        int end = pf_vk_cmd_timestamp(*cmds);
        if (status == PF_OK)
            status = pf_vk_commands_submit(*cmds, err);
        if (status == PF_OK)
            pf_gpu_ms_add(&totals->gpu_ms, pf_commands_gpu_ms(*cmds, *begin, end));
        pf_vk_commands_destroy(*cmds);
        *cmds = NULL;
        if (status == PF_OK)
            status = trace(queue, rows * kernel->width * kernel->rays_per_pixel, totals, err);
        if (status == PF_OK)
            status = pf_vk_commands_begin(queue->ctx, cmds, err);
        if (status != PF_OK)
            break;
        *begin = pf_vk_cmd_timestamp(*cmds);
        status = pf_vk_cmd_dispatch(*cmds, kernel->given.pipeline, kernel->given.buffers,
                                    kernel->given.buffer_count, kernel->given.push,
                                    kernel->given.push_bytes, groups_x, groups_y, 1, err);
    }
    *kernel->write.row_first = *kernel->given.row_first = 0;
    return status;
}

pf_status pf_host_rays_camera_step(pf_renderer *renderer, const pf_host_rays *queue,
                                   pf_vk_buffer *const *kernel_buffers,
                                   pf_vk_buffer *buffers[PF_CAMERA_RAYS_BUFFERS],
                                   pf_camera_rays_push *push, pf_host_traced_step *step,
                                   pf_error *err)
{
    memcpy(buffers, kernel_buffers, PF_SCENE_BINDING_COUNT * sizeof *buffers);
    memcpy(buffers + PF_SCENE_BINDING_COUNT, queue->buffers, sizeof queue->buffers);
    memset(push, 0, sizeof *push);
    *step = (pf_host_traced_step){NULL, buffers, PF_CAMERA_RAYS_BUFFERS, push, sizeof *push,
                                  &push->row_first};
    return pf_renderer_pipeline(renderer, PF_PIPELINE_CAMERA_RAYS, &step->pipeline, err);
}
