/*
 * reference's passes as a wavefront (shaders/common/reference_wave.glsl), for
 * a device whose memory is the host's: a dispatch advances every live path
 * of a slice of the image by one vertex and writes its rays into device
 * buffers; the host traces them in place (core/bih/bih_wave_trace.c) and drops the paths
 * that are done; the next dispatch reads the hits. Once no path of the slice
 * is left, one dispatch finishes them all into the film. Once a wave would
 * shade only a few paths, one tail dispatch runs them to their ends instead,
 * tracing with the device's GLSL traversal (below). The megakernel
 * (frame_reference.c) traces inside its one dispatch a pass with the
 * device's GLSL traversal instead; both run reference_path.glsl's paths.
 */
#include "render_internal.h"

#include <stdlib.h>
#include <string.h>

/* Paths in flight at once (PF_REFERENCE_WAVE_MAX_PATHS, render_internal.h)... */
#define WAVE_MAX_PATHS PF_REFERENCE_WAVE_MAX_PATHS
/* ... and the buffers of a slice at most this many bytes (each shadow slot adds 64 bytes to
 * every path: pf_direct_light_slots). */
#define WAVE_MAX_BYTES (256ull << 20)
#define WAVE_GROUP_SIZE 64u
/* The tail's workgroups a trace thread (as many as the device's, on lavapipe): llvmpipe
 * runs a workgroup's lanes 8 at a time, so a thread's first lanes take paths until the
 * list is empty or their vertices run out, and the later ones find it empty; a second
 * workgroup a thread covers a device with more threads than the host traces on. */
#define WAVE_TAIL_GROUPS_PER_THREAD 2u
/* WavePath in reference_wave.glsl: 9 vec4. */
#define WAVE_PATH_BYTES (9u * 16u)

typedef struct wave_push {
    uint32_t sample_index, count, first_pixel, first_active;
    uint32_t loop_sentinel; /* 1: kernel_guard.glsl's proof loop */
} wave_push;

enum {
    WAVE_PATHS,
    WAVE_RAYS,
    WAVE_HITS,
    WAVE_SHADOW_RAYS,
    WAVE_SHADOW_LIGHT,
    WAVE_SHADOW_HITS,
    WAVE_QUEUE,
    WAVE_ACTIVE,
    WAVE_TAIL_CURSOR,
    WAVE_BUFFER_COUNT
};

struct pf_reference_wave {
    pf_renderer *renderer;
    uint32_t capacity;     /* paths a slice */
    uint32_t shadow_slots; /* pf_direct_light_slots of the frame's punctual lights */
    pf_vk_buffer *buffers[WAVE_BUFFER_COUNT];
    pf_bih_wave_queues queues; /* the buffers as the host sees them */
    uint32_t *active;
    uint32_t *tail_cursor;
    uint32_t tail_paths; /* a wave of at most this many paths goes to the tail; 0: none */
    pf_bih_wave_tracer *tracer;
};

void pf_reference_wave_destroy(pf_reference_wave *wave)
{
    if (!wave)
        return;
    for (int b = 0; b < WAVE_BUFFER_COUNT; b++)
        pf_render_buffer_release(wave->renderer->ctx, &wave->buffers[b]);
    pf_bih_wave_tracer_destroy(wave->tracer);
    free(wave);
}

pf_status pf_reference_wave_create(pf_renderer *renderer, const pf_render_settings *settings,
                                   uint32_t light_count, uint32_t tail_paths,
                                   pf_reference_wave **out, pf_error *err)
{
    *out = NULL;
    pf_reference_wave *wave = calloc(1, sizeof *wave);
    if (!wave)
        return pf_error_set(err, PF_ERR_NOMEM, "wavefront: out of memory");
    wave->renderer = renderer;
    wave->shadow_slots = pf_direct_light_slots(light_count);
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    uint64_t limit = pf_vk_info(renderer->ctx)->max_storage_buffer_range;
    uint64_t capacity = pixels < WAVE_MAX_PATHS ? pixels : WAVE_MAX_PATHS;
    uint64_t per_path_limit = limit / ((uint64_t)wave->shadow_slots * sizeof(pf_ray));
    if (capacity > per_path_limit)
        capacity = per_path_limit;
    /* Many lights make many shadow slots a path: fewer paths a slice, not more memory. */
    uint64_t path_bytes = WAVE_PATH_BYTES + sizeof(pf_ray) + sizeof(pf_hit) + 8u +
                          (uint64_t)wave->shadow_slots * (sizeof(pf_ray) + 16u + sizeof(pf_hit));
    if (capacity > WAVE_MAX_BYTES / path_bytes)
        capacity = WAVE_MAX_BYTES / path_bytes;
    if (capacity == 0) {
        free(wave);
        return pf_error_set(err, PF_ERR_LIMIT,
                            "wavefront: %u lights' shadow rays of one path exceed the device's "
                            "largest buffer (%llu bytes) or the wavefront's %llu MiB",
                            light_count, (unsigned long long)limit,
                            (unsigned long long)(WAVE_MAX_BYTES >> 20));
    }
    wave->capacity = (uint32_t)capacity;
    uint64_t slots = capacity * wave->shadow_slots;
    static const char *labels[WAVE_BUFFER_COUNT] = {
        "wavefront paths",        "wavefront rays",       "wavefront hits",
        "wavefront shadow rays",  "wavefront shadow light", "wavefront shadow hits",
        "wavefront queue",        "wavefront active paths", "wavefront tail cursor"};
    const uint64_t sizes[WAVE_BUFFER_COUNT] = {
        capacity * WAVE_PATH_BYTES, capacity * sizeof(pf_ray), capacity * sizeof(pf_hit),
        slots * sizeof(pf_ray),     slots * 16u,               slots * sizeof(pf_hit),
        capacity * 4u,              capacity * 4u,             4u};
    pf_status status = PF_OK;
    for (int b = 0; status == PF_OK && b < WAVE_BUFFER_COUNT; b++) {
        status = pf_vk_buffer_create(renderer->ctx, sizes[b], labels[b], &wave->buffers[b], err);
        if (status == PF_OK && !pf_vk_buffer_host_memory(wave->buffers[b]))
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "wavefront: the device's %s are not in host memory "
                                  "(the host traces only where the device is the CPU)",
                                  labels[b] + strlen("wavefront "));
    }
    if (status == PF_OK) {
        wave->queues.queue = pf_vk_buffer_host_memory(wave->buffers[WAVE_QUEUE]);
        wave->queues.rays = pf_vk_buffer_host_memory(wave->buffers[WAVE_RAYS]);
        wave->queues.hits = pf_vk_buffer_host_memory(wave->buffers[WAVE_HITS]);
        wave->queues.shadow_rays = pf_vk_buffer_host_memory(wave->buffers[WAVE_SHADOW_RAYS]);
        wave->queues.shadow_hits = pf_vk_buffer_host_memory(wave->buffers[WAVE_SHADOW_HITS]);
        wave->active = pf_vk_buffer_host_memory(wave->buffers[WAVE_ACTIVE]);
        wave->tail_cursor = pf_vk_buffer_host_memory(wave->buffers[WAVE_TAIL_CURSOR]);
        wave->tail_paths = tail_paths;
        status = pf_renderer_wave_tracer_create(renderer, wave->capacity, wave->shadow_slots,
                                                &wave->tracer, err);
    }
    if (status != PF_OK) {
        pf_reference_wave_destroy(wave);
        return status;
    }
    *out = wave;
    return PF_OK;
}

uint32_t pf_reference_wave_threads(const pf_reference_wave *wave)
{
    return pf_bih_wave_tracer_threads(wave->tracer);
}

/* One wave: pipeline's dispatch of groups workgroups in a submission of its own (setup's,
 * when given: the frame's uploads and the counters' zeroing go first). */
static pf_status dispatch_wave(pf_reference_wave *wave, pf_vk_pipeline *pipeline,
                               const wave_push *push, uint32_t groups,
                               pf_vk_buffer *const *buffers, uint32_t buffer_count,
                               pf_vk_commands *setup, pf_reference_progress *progress,
                               pf_error *err)
{
    pf_vk_commands *cmds = setup;
    pf_status status = cmds ? PF_OK : pf_vk_commands_begin(wave->renderer->ctx, &cmds, err);
    if (status != PF_OK)
        return status;
    int begin = pf_vk_cmd_timestamp(cmds);
    status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, buffer_count, push, sizeof *push,
                                groups, 1, 1, err);
    int end = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK)
        pf_gpu_ms_add(&progress->gpu_ms, pf_commands_gpu_ms(cmds, begin, end));
    pf_vk_commands_destroy(cmds);
    progress->waves++;
    return status;
}

/* Workgroups for count invocations. */
static uint32_t groups_for(uint32_t count)
{
    return (count + WAVE_GROUP_SIZE - 1) / WAVE_GROUP_SIZE;
}

/* The tail: one dispatch runs the push->count paths of the active list to their ends (and
 * another for those its lanes had no vertices left for, which is rare). */
static pf_status run_tail(pf_reference_wave *wave, pf_vk_pipeline *tail, const wave_push *push,
                          pf_vk_buffer *const *buffers, uint32_t buffer_count,
                          pf_reference_progress *progress, pf_error *err)
{
    uint32_t groups = WAVE_TAIL_GROUPS_PER_THREAD * pf_bih_wave_tracer_threads(wave->tracer);
    wave_push rest = *push;
    pf_status status = PF_OK;
    while (status == PF_OK && rest.count > 0) {
        *wave->tail_cursor = 0; /* host memory: visible to the submission */
        uint32_t needed = groups_for(rest.count);
        status = dispatch_wave(wave, tail, &rest, needed < groups ? needed : groups, buffers,
                               buffer_count, NULL, progress, err);
        /* Every lane that looked for a path moved the cursor, those that found none too. */
        uint32_t taken = *wave->tail_cursor < rest.count ? *wave->tail_cursor : rest.count;
        if (status == PF_OK && taken == 0) /* a lane always takes one: never loop on none */
            status = pf_error_set(err, PF_ERR_INTERNAL, "wavefront: the tail took no paths");
        /* A path the tail ended has nothing queued; one still queued was cut short (a
         * device that ends long loops, as llvmpipe's limiter would): never a silent bias. */
        for (uint32_t i = 0; status == PF_OK && i < taken; i++)
            if (wave->queues.queue[wave->active[rest.first_active + i]] != 0)
                status = pf_error_set(err, PF_ERR_INTERNAL,
                                      "wavefront: the device ended a tail path short (path %u)",
                                      wave->active[rest.first_active + i]);
        progress->tail_paths += taken;
        rest.first_active += taken;
        rest.count -= taken;
    }
    return status;
}

pf_status pf_reference_wave_passes(pf_reference_wave *wave, pf_vk_buffer *const *reference_buffers,
                                   uint32_t reference_buffer_count,
                                   const pf_render_settings *settings, uint32_t count,
                                   pf_vk_commands *setup, pf_reference_progress *progress,
                                   pf_error *err)
{
    pf_renderer *renderer = wave->renderer;
    pf_vk_buffer *buffers[PF_REFERENCE_WAVE_MAX_BUFFERS];
    /* The kernel's bindings after the reference kernel's: the wavefront's buffers up to the
     * active list, the texel views it reads the previous dispatch's writes through, the
     * tail's cursor. */
    uint32_t buffer_count = reference_buffer_count + WAVE_ACTIVE + 1u + 3u + 1u;
    if (buffer_count > PF_REFERENCE_WAVE_MAX_BUFFERS) {
        pf_vk_commands_destroy(setup);
        return pf_error_set(err, PF_ERR_INTERNAL, "wavefront: %u buffers", buffer_count);
    }
    memcpy(buffers, reference_buffers, reference_buffer_count * sizeof *buffers);
    memcpy(buffers + reference_buffer_count, wave->buffers, (WAVE_ACTIVE + 1u) * sizeof *buffers);
    buffers[buffer_count - 4] = wave->buffers[WAVE_PATHS];
    buffers[buffer_count - 3] = wave->buffers[WAVE_QUEUE];
    buffers[buffer_count - 2] = wave->buffers[WAVE_SHADOW_LIGHT];
    buffers[buffer_count - 1] = wave->buffers[WAVE_TAIL_CURSOR];
    /* generate, then per wave: shade the paths with a hit (or run the tail to the paths'
     * ends); once none is left, finish them all. One shade module either way: only the
     * finish writes the film (and the AOVs). A frame's first use makes its pipelines side by
     * side: each is the whole module specialised (0.1-0.5 s of llvmpipe's SPIR-V to NIR). */
    pf_renderer_pipeline_id finish_id = settings->aovs ? PF_PIPELINE_REFERENCE_WAVE_FINISH
                                                       : PF_PIPELINE_REFERENCE_WAVE_FINISH_RGB;
    const pf_renderer_pipeline_id ids[] = {PF_PIPELINE_REFERENCE_WAVE,
                                           PF_PIPELINE_REFERENCE_WAVE_GENERATE, finish_id,
                                           PF_PIPELINE_REFERENCE_WAVE_TAIL};
    pf_vk_pipeline *generate = NULL, *shade = NULL, *tail = NULL, *finish = NULL;
    pf_status status = pf_renderer_pipelines_prepare(renderer, ids,
                                                     wave->tail_paths > 0 ? 4u : 3u, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_REFERENCE_WAVE_GENERATE, &generate,
                                      err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_REFERENCE_WAVE, &shade, err);
    if (status == PF_OK && wave->tail_paths > 0)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_REFERENCE_WAVE_TAIL, &tail, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, finish_id, &finish, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(setup);
        return status;
    }
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    for (uint32_t pass = 0; status == PF_OK && pass < count; pass++) {
        uint32_t sample = progress->passes;
        for (uint64_t first = 0; status == PF_OK && first < pixels; first += wave->capacity) {
            uint32_t slice = (uint32_t)(pixels - first < wave->capacity ? pixels - first
                                                                        : wave->capacity);
            wave_push start = {sample, slice, (uint32_t)first, 0, 1};
            status = dispatch_wave(wave, generate, &start, groups_for(slice), buffers,
                                   buffer_count, setup, progress, err);
            setup = NULL;
            for (uint32_t i = 0; i < slice; i++)
                wave->active[i] = i;
            uint32_t live = slice;
            while (status == PF_OK) {
                double trace_start = pf_time_ms();
                uint32_t remaining = 0, hit = 0;
                status = pf_bih_wave_trace(wave->tracer, &wave->queues, wave->active, live,
                                           &remaining, &hit, &progress->rays, err);
                progress->host_trace_ms += pf_time_ms() - trace_start;
                if (status != PF_OK || remaining == 0)
                    break;
                /* Only the paths with a hit can have rays to trace after this wave. */
                live = hit;
                if (live == 0)
                    break;
                wave_push next = {sample, live, (uint32_t)first, 0, 1};
                if (live <= wave->tail_paths) {
                    status = run_tail(wave, tail, &next, buffers, buffer_count, progress, err);
                    break;
                }
                status = dispatch_wave(wave, shade, &next, groups_for(live), buffers,
                                       buffer_count, NULL, progress, err);
            }
            wave_push end = {sample, slice, (uint32_t)first, 0, 1};
            if (status == PF_OK)
                status = dispatch_wave(wave, finish, &end, groups_for(slice), buffers,
                                       buffer_count, NULL, progress, err);
        }
        if (status == PF_OK)
            progress->passes++;
    }
    pf_vk_commands_destroy(setup); /* not taken: nothing to render */
    return status;
}
