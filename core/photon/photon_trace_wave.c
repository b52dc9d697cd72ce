/*
 * Photon tracing in waves, its rays traced by the host (issue 43): where the
 * device is the CPU its memory is the host's, and the wide AVX2 traversal on
 * every core (core/bih/bih_wave_trace.c) traces several times faster than
 * the device's GLSL loop. A batch of photons is emitted (PHOTON_EMIT, each
 * photon's state and first ray into the waves' buffers); then, until none is
 * left, the host traces the rays in place and a dispatch bounces the photons
 * whose ray hit a surface (PHOTON_BOUNCE: store, scatter, roulette, the next
 * ray). photon_path.glsl's photon_start and photon_bounce are the flat
 * loop's, so the photons are the same; only the maps' order differs.
 */
#include "photon_internal.h"

#include <stdlib.h>
#include <string.h>

#define WAVE_GROUP_SIZE 64u
/* Photons in flight at once: the waves' buffers (~110 bytes a photon) stay ~28 MB. */
#define WAVE_MAX_PHOTONS (1u << 18)
/* PhotonWave in photon_path.glsl: 3 vec4. */
#define WAVE_STATE_BYTES 48u

enum { WAVE_STATE, WAVE_RAYS, WAVE_HITS, WAVE_QUEUE, WAVE_ACTIVE, WAVE_BUFFER_COUNT };

typedef struct photon_waves {
    pf_vk_context *ctx;
    pf_vk_buffer *buffers[WAVE_BUFFER_COUNT];
    pf_bih_wave_queues queues;
    uint32_t *active;
    pf_bih_wave_tracer *tracer;
} photon_waves;

static void waves_release(photon_waves *w)
{
    for (int b = 0; b < WAVE_BUFFER_COUNT; b++)
        if (w->buffers[b])
            pf_vk_buffer_destroy(w->ctx, w->buffers[b]);
    pf_bih_wave_tracer_destroy(w->tracer);
}

static pf_status waves_create(pf_vk_context *ctx, const pf_bih *host_tree,
                              const pf_bih_wide *host_wide, uint32_t capacity, photon_waves *w,
                              pf_error *err)
{
    memset(w, 0, sizeof *w);
    w->ctx = ctx;
    static const char *labels[WAVE_BUFFER_COUNT] = {"photon waves' states", "photon waves' rays",
                                                    "photon waves' hits", "photon waves' queue",
                                                    "photon waves' active photons"};
    const uint64_t sizes[WAVE_BUFFER_COUNT] = {
        (uint64_t)capacity * WAVE_STATE_BYTES, (uint64_t)capacity * sizeof(pf_ray),
        (uint64_t)capacity * sizeof(pf_hit), (uint64_t)capacity * 4u, (uint64_t)capacity * 4u};
    pf_status status = PF_OK;
    for (int b = 0; status == PF_OK && b < WAVE_BUFFER_COUNT; b++) {
        status = pf_vk_buffer_create(ctx, sizes[b], labels[b], &w->buffers[b], err);
        if (status == PF_OK && !pf_vk_buffer_host_memory(w->buffers[b]))
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "%s are not in host memory (the host traces only where the "
                                  "device is the CPU)",
                                  labels[b]);
    }
    if (status == PF_OK) {
        w->queues.rays = pf_vk_buffer_host_memory(w->buffers[WAVE_RAYS]);
        w->queues.hits = pf_vk_buffer_host_memory(w->buffers[WAVE_HITS]);
        w->queues.queue = pf_vk_buffer_host_memory(w->buffers[WAVE_QUEUE]);
        w->active = pf_vk_buffer_host_memory(w->buffers[WAVE_ACTIVE]);
        /* Closest hits only: a photon's word is 1 or 0, no shadow rays. */
        status = pf_bih_wave_tracer_create(host_tree, host_wide, capacity, 1, &w->tracer, err);
    }
    if (status != PF_OK)
        waves_release(w);
    return status;
}

/* One dispatch of step over count photons in a submission of its own (setup's, when given),
 * its GPU time added to out's. */
static pf_status wave_dispatch(pf_vk_context *ctx, pf_vk_pipeline *kernel,
                               pf_vk_buffer *const *buffers, uint32_t first_photon,
                               uint32_t count, pf_vk_commands *setup, trace_counters *read_back,
                               pf_photon_maps *out, pf_error *err)
{
    pf_vk_commands *cmds = setup;
    pf_status status = cmds ? PF_OK : pf_vk_commands_begin(ctx, &cmds, err);
    if (status != PF_OK)
        return status;
    int begin = pf_vk_cmd_timestamp(cmds);
    trace_push push = {first_photon, count, 0, 1};
    if (count > 0)
        status = pf_vk_cmd_dispatch(cmds, kernel, buffers, TRACE_BUFFERS, &push, sizeof push,
                                    (count + WAVE_GROUP_SIZE - 1) / WAVE_GROUP_SIZE, 1, 1, err);
    int end = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK && read_back)
        status = pf_vk_cmd_download(cmds, buffers[TRACE_COUNTERS], 0, read_back,
                                    sizeof *read_back, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK && begin >= 0 && end >= 0) {
        double ms = pf_vk_commands_elapsed_ms(cmds, begin, end);
        out->gpu_ms = (out->gpu_ms < 0.0 ? 0.0 : out->gpu_ms) + ms;
    }
    pf_vk_commands_destroy(cmds);
    out->waves += count > 0;
    return status;
}

pf_status pf_photon_trace_waves(pf_vk_context *ctx, pf_photon_tracer *tracer, uint32_t features,
                                pf_vk_buffer *const *buffers, const trace_uploads *uploads,
                                const pf_bih *host_tree, const pf_bih_wide *host_wide,
                                uint32_t count, trace_counters *counters, pf_photon_maps *out,
                                pf_error *err)
{
    memset(counters, 0, sizeof *counters);
    pf_vk_pipeline *emit = NULL, *bounce = NULL;
    pf_status status = pf_photon_trace_pipeline(tracer, PF_PHOTON_EMIT, features, &emit, err);
    if (status == PF_OK)
        status = pf_photon_trace_pipeline(tracer, PF_PHOTON_BOUNCE, features, &bounce, err);
    uint32_t capacity = count < WAVE_MAX_PHOTONS ? count : WAVE_MAX_PHOTONS;
    photon_waves w;
    if (status == PF_OK)
        status = waves_create(ctx, host_tree, host_wide, capacity, &w, err);
    if (status != PF_OK)
        return status;
    pf_vk_buffer *bound[TRACE_BUFFERS];
    memcpy(bound, buffers, sizeof bound);
    bound[TRACE_COUNTERS + 1] = w.buffers[WAVE_STATE];
    bound[TRACE_COUNTERS + 2] = w.buffers[WAVE_RAYS];
    bound[TRACE_COUNTERS + 3] = w.buffers[WAVE_HITS];
    bound[TRACE_COUNTERS + 4] = w.buffers[WAVE_QUEUE];
    bound[TRACE_COUNTERS + 5] = w.buffers[WAVE_ACTIVE];
    bound[TRACE_COUNTERS + 6] = w.buffers[WAVE_STATE]; /* read back as texels */
    bound[TRACE_COUNTERS + 7] = w.buffers[WAVE_RAYS];
    /* The uploads go with the first batch's emission. */
    pf_vk_commands *setup = NULL;
    status = pf_vk_commands_begin(ctx, &setup, err);
    if (status == PF_OK)
        status = pf_photon_trace_uploads(setup, bound, uploads, err);
    uint64_t rays = 0;
    for (uint32_t first = 0; status == PF_OK && first < count; first += capacity) {
        uint32_t batch = count - first < capacity ? count - first : capacity;
        status = wave_dispatch(ctx, emit, bound, first, batch, setup, NULL, out, err);
        setup = NULL;
        for (uint32_t i = 0; i < batch; i++)
            w.active[i] = i;
        uint32_t live = batch;
        while (status == PF_OK && live > 0) {
            double start = pf_time_ms();
            uint32_t remaining = 0, hit = 0;
            status = pf_bih_wave_trace(w.tracer, &w.queues, w.active, live, &remaining, &hit,
                                       &rays, err);
            out->host_trace_ms += pf_time_ms() - start;
            /* The photons whose ray missed end here; those with a hit bounce. */
            if (status == PF_OK && hit > 0)
                status = wave_dispatch(ctx, bounce, bound, first, hit, NULL, NULL, out, err);
            live = hit;
        }
    }
    pf_vk_commands_destroy(setup); /* not taken: nothing traced */
    /* The counters, once every batch is done. */
    if (status == PF_OK)
        status = wave_dispatch(ctx, bounce, bound, 0, 0, NULL, counters, out, err);
    waves_release(&w);
    return status;
}
