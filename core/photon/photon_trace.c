/*
 * Host side of photon tracing (pf_photon_trace in pf_photon.h;
 * shaders/photon_trace.comp does the work): in one submission where the
 * device traces the rays, in waves where the host does (photon_trace_wave.c).
 */
#include "photon_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TRACE_GROUP_SIZE 64u
/* Workgroups per dispatch: below the 65535 every device allows. */
#define TRACE_MAX_GROUPS 16384u
/* Default map capacity: stores per emitted photon (a bounce or two survive roulette on average). */
#define DEFAULT_STORES_PER_PHOTON 4u

_Static_assert(sizeof(photon_trace_params) == 128, "photon_trace_params must match PhotonTraceParams");

struct pf_photon_tracer {
    pf_vk_context *ctx;
    /* Per step (PHOTON_STEP: traced here, emit, bounce) and PF_SURFACE_* combination: the
     * plain kernel, or its "_surfaces" variant specialised for the scene's (pf_scene.h),
     * each made at first use. */
    pf_vk_pipeline *trace[PF_PHOTON_STEPS][PF_SURFACE_VARIANTS];
};

pf_status pf_photon_trace_pipeline(pf_photon_tracer *tracer, pf_photon_step step,
                                   uint32_t features, pf_vk_pipeline **out, pf_error *err)
{
    features %= PF_SURFACE_VARIANTS;
    pf_vk_pipeline **slot = &tracer->trace[step][features];
    if (!*slot) {
        pf_vk_spec_constant constants[PF_SCENE_SPEC_CONSTANTS + 1];
        uint32_t ids[PF_SCENE_SPEC_CONSTANTS], values[PF_SCENE_SPEC_CONSTANTS];
        pf_scene_spec_constants(features, ids, values);
        for (uint32_t c = 0; c < PF_SCENE_SPEC_CONSTANTS; c++)
            constants[c] = (pf_vk_spec_constant){ids[c], values[c]};
        constants[PF_SCENE_SPEC_CONSTANTS] = (pf_vk_spec_constant){PHOTON_STEP_CONSTANT, step};
        /* A module a step (photon_path.glsl), its "_surfaces" variant where the scene has them. */
        static const char *const modules[PF_PHOTON_STEPS] = {"photon_trace", "photon_wave_emit",
                                                             "photon_wave_bounce"};
        char name[48];
        snprintf(name, sizeof name, "%s%s", modules[step],
                 (features & PF_SURFACE_TEXTURED) ? "_surfaces" : "");
        pf_status status = pf_vk_pipeline_create_named(
            tracer->ctx, name, TRACE_BUFFERS, sizeof(trace_push), constants,
            PF_SCENE_SPEC_CONSTANTS + (step == PF_PHOTON_TRACED_HERE ? 0 : 1), slot, err);
        if (status != PF_OK)
            return status;
    }
    *out = *slot;
    return PF_OK;
}

pf_status pf_photon_tracer_create(pf_vk_context *ctx, pf_photon_tracer **out, pf_error *err)
{
    *out = NULL;
    pf_photon_tracer *tracer = calloc(1, sizeof *tracer);
    if (!tracer)
        return pf_error_set(err, PF_ERR_NOMEM, "photon tracer: out of memory");
    tracer->ctx = ctx;
    /* No kernel yet: a tracer whose photons the host traces never makes the flat loop's
     * (one compile of the large module less in a process's first frame). */
    *out = tracer;
    return PF_OK;
}

void pf_photon_tracer_destroy(pf_photon_tracer *tracer)
{
    if (!tracer)
        return;
    for (uint32_t step = 0; step < PF_PHOTON_STEPS; step++)
        for (uint32_t v = 0; v < PF_SURFACE_VARIANTS; v++)
            if (tracer->trace[step][v])
                pf_vk_pipeline_destroy(tracer->ctx, tracer->trace[step][v]);
    free(tracer);
}

static void release(pf_vk_context *ctx, pf_vk_buffer **buffer)
{
    if (*buffer)
        pf_vk_buffer_destroy(ctx, *buffer);
    *buffer = NULL;
}

void pf_photon_maps_release(pf_vk_context *ctx, pf_photon_maps *maps)
{
    release(ctx, &maps->global);
    release(ctx, &maps->caustic);
    memset(maps, 0, sizeof *maps);
}

static double luminance(const double rgb[3])
{
    return PF_LUMINANCE_R * rgb[0] + PF_LUMINANCE_G * rgb[1] + PF_LUMINANCE_B * rgb[2];
}

/* A map's capacity: the request, or the default bounded by one buffer. */
static pf_status map_capacity(const pf_vk_device_info *info, uint32_t requested,
                              uint32_t photon_count, const char *name, uint32_t *capacity,
                              pf_error *err)
{
    uint64_t fits = info->max_storage_buffer_range / sizeof(pf_photon);
    if (requested == 0) {
        uint64_t wanted = (uint64_t)photon_count * DEFAULT_STORES_PER_PHOTON;
        *capacity = (uint32_t)(wanted < fits ? wanted : fits);
        return PF_OK;
    }
    if (requested > fits)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "%s photon map of %u photons exceeds one buffer on '%s' (%llu photons of %zu bytes fit); trace in more passes",
                            name, requested, info->name, (unsigned long long)fits,
                            sizeof(pf_photon));
    *capacity = requested;
    return PF_OK;
}

uint64_t pf_photon_trace_bytes(const pf_vk_device_info *info,
                               const pf_photon_trace_settings *settings)
{
    uint32_t capacity[2] = {settings->global_capacity, settings->caustic_capacity};
    uint64_t bytes = 0;
    pf_error ignored = {0};
    for (int m = 0; m < 2; m++) {
        uint32_t slots = capacity[m];
        if (map_capacity(info, capacity[m], settings->photon_count, "", &slots, &ignored) != PF_OK)
            slots = capacity[m]; /* the trace refuses it: count what was asked */
        bytes += (uint64_t)(slots ? slots : 1) * sizeof(pf_photon);
    }
    return bytes;
}

pf_status pf_photon_trace_uploads(pf_vk_commands *cmds, pf_vk_buffer *const *buffers,
                                  const trace_uploads *uploads, pf_error *err)
{
    static const trace_counters zero = {0, 0, 0, 0, 0};
    static const uint32_t zeros[4];
    pf_status status =
        pf_vk_cmd_upload(cmds, buffers[TRACE_COUNTERS], 0, &zero, sizeof zero, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, buffers[PF_SCENE_BINDING_PARAMS], 0, uploads->params,
                                  sizeof *uploads->params, err);
    if (status == PF_OK && uploads->emitters->count > 0)
        status = pf_vk_cmd_upload(cmds, buffers[PF_SCENE_BINDING_EMISSIVE], 0,
                                  uploads->emitters->entries,
                                  (uint64_t)uploads->emitters->count * sizeof(pf_photon_emitter),
                                  err);
    if (status == PF_OK && uploads->placeholder)
        status = pf_vk_cmd_upload(cmds, uploads->placeholder, 0, zeros, sizeof zeros, err);
    return status;
}

/*
 * One pass of a trace (pf_photon_trace_passes): its parameters, its own buffers and what
 * its submission reads back, until the batch's submission is done.
 */
typedef struct trace_job {
    const pf_photon_trace_settings *settings;
    photon_trace_params params;
    pf_vk_buffer *params_buffer, *emitter_buffer, *counter_buffer;
    pf_vk_buffer *placeholder; /* the texture bindings of a scene without textures */
    pf_vk_buffer *buffers[TRACE_BUFFERS];
    trace_uploads uploads;
    uint32_t per_invocation;
    trace_counters counters;
    int begin, end; /* timestamp slots around its dispatches (< 0: none) */
    uint32_t submitted; /* its submissions so far */
    double gpu_ms;      /* their GPU time (< 0 without timestamps) */
} trace_job;

static void job_release(pf_vk_context *ctx, trace_job *job)
{
    release(ctx, &job->params_buffer);
    release(ctx, &job->emitter_buffer);
    release(ctx, &job->counter_buffer);
    release(ctx, &job->placeholder);
}

/* The pass's parameters and buffers (its maps into out), bound as photon_trace.comp reads them. */
static pf_status job_prepare(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                             const pf_photon_emitters *emitters,
                             const pf_photon_trace_settings *settings, trace_job *job,
                             pf_photon_maps *out, pf_error *err)
{
    memset(job, 0, sizeof *job);
    job->settings = settings;
    job->begin = job->end = -1;
    job->gpu_ms = -1.0;
    if (settings->photon_count == 0)
        return pf_error_set(err, PF_ERR_INVALID, "photon trace: 0 photons requested");
    pf_vk_context *ctx = tracer->ctx;
    const pf_vk_device_info *info = pf_vk_info(ctx);
    photon_trace_params *params = &job->params;
    pf_status status = map_capacity(info, settings->global_capacity, settings->photon_count,
                                    "global", &params->global_capacity, err);
    if (status == PF_OK)
        status = map_capacity(info, settings->caustic_capacity, settings->photon_count,
                              "caustic", &params->caustic_capacity, err);
    if (status != PF_OK)
        return status;
    double total_luminance = luminance(emitters->total_power);
    out->flux_scale = emitters->count > 0 ? (float)(total_luminance / settings->photon_count) : 0.0f;
    for (int k = 0; k < 3; k++) {
        params->bih_bounds_min[k] = scene->bih.bounds_min[k];
        params->bih_bounds_max[k] = scene->bih.bounds_max[k];
        params->scene_sphere[k] = emitters->scene_center[k];
    }
    params->scene_sphere[3] = emitters->scene_radius;
    params->photon_count = settings->photon_count;
    params->emitter_count = emitters->count;
    params->store_direct = settings->store_direct ? 1u : 0u;
    params->global_reflected = settings->global_reflected ? 1u : 0u;
    params->triangle_count = scene->triangle_count;
    params->bih_node_count = scene->bih.node_count;
    params->seed_lo = (uint32_t)settings->seed;
    params->seed_hi = (uint32_t)(settings->seed >> 32);
    params->max_depth = settings->max_depth ? settings->max_depth : PF_PHOTON_DEFAULT_MAX_DEPTH;
    params->ray_offset = scene->ray_offset;
    for (int k = 0; k < 3; k++) {
        params->arrival_box_min[k] = settings->arrival_box_min[k];
        params->arrival_box_max[k] = settings->arrival_box_max[k];
    }

    status = pf_vk_buffer_create(ctx, sizeof *params, "photon trace parameters",
                                 &job->params_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(emitters->count ? emitters->count : 1) *
                                         sizeof(pf_photon_emitter),
                                     "photon emitters", &job->emitter_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof(trace_counters), "photon trace counters",
                                     &job->counter_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(params->global_capacity ? params->global_capacity
                                                                        : 1) *
                                         sizeof(pf_photon),
                                     "global photon map", &out->global, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(params->caustic_capacity ? params->caustic_capacity
                                                                         : 1) *
                                         sizeof(pf_photon),
                                     "caustic photon map", &out->caustic, err);
    if (status == PF_OK && !(scene->corners && scene->textures && scene->texels))
        status = pf_vk_buffer_create(ctx, 4 * sizeof(uint32_t), "no textures", &job->placeholder,
                                     err);
    if (status != PF_OK)
        return status;
    pf_vk_buffer **buffers = job->buffers;
    buffers[PF_SCENE_BINDING_PARAMS] = job->params_buffer;
    buffers[PF_SCENE_BINDING_VERTICES] = scene->vertices;
    buffers[PF_SCENE_BINDING_NORMALS] = scene->normals;
    buffers[PF_SCENE_BINDING_TRIANGLE_MATERIALS] = scene->triangle_material;
    buffers[PF_SCENE_BINDING_MATERIALS] = scene->materials;
    buffers[PF_SCENE_BINDING_LIGHTS] = scene->lights;
    buffers[PF_SCENE_BINDING_EMISSIVE] = job->emitter_buffer;
    buffers[PF_SCENE_BINDING_CORNERS] = scene->corners ? scene->corners : job->placeholder;
    buffers[PF_SCENE_BINDING_TEXTURES] = scene->textures ? scene->textures : job->placeholder;
    buffers[PF_SCENE_BINDING_TEXELS] = scene->texels ? scene->texels : job->placeholder;
    buffers[PF_SCENE_BINDING_COUNT + 0] = scene->bih.nodes;
    buffers[PF_SCENE_BINDING_COUNT + 1] = scene->bih.vertices;
    buffers[PF_SCENE_BINDING_COUNT + 2] = scene->bih.triangle_index;
    buffers[PF_SCENE_BINDING_COUNT + 3] = out->global;
    buffers[PF_SCENE_BINDING_COUNT + 4] = out->caustic;
    buffers[TRACE_COUNTERS] = job->counter_buffer;
    /* The waves' buffers, where the host traces (photon_trace_wave.c binds its own). */
    for (uint32_t b = TRACE_COUNTERS + 1; b < TRACE_BUFFERS; b++)
        buffers[b] = job->counter_buffer;
    job->per_invocation = settings->per_invocation ? settings->per_invocation
                          : pf_vk_device_is_cpu(ctx) ? PF_PHOTON_TRACE_PER_INVOCATION
                                                     : 1u;
    job->uploads = (trace_uploads){&job->params, emitters, job->placeholder};
    return PF_OK;
}

/*
 * Records the job's uploads, its counters zeroed, its dispatches (each invocation tracing
 * per_invocation photons in turn: photon_trace.comp) between two timestamps, and the
 * counters' readback.
 */
static pf_status job_record(pf_vk_commands *cmds, pf_vk_pipeline *kernel, trace_job *job,
                            pf_error *err)
{
    uint32_t count = job->settings->photon_count, per_invocation = job->per_invocation;
    memset(&job->counters, 0, sizeof job->counters);
    pf_status status = pf_photon_trace_uploads(cmds, job->buffers, &job->uploads, err);
    job->begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    const uint64_t per_dispatch = (uint64_t)TRACE_GROUP_SIZE * TRACE_MAX_GROUPS * per_invocation;
    for (uint64_t first = 0; status == PF_OK && first < count; first += per_dispatch) {
        trace_push push = {(uint32_t)first, count - (uint32_t)first, 0, 1};
        if (push.photon_count > per_dispatch)
            push.photon_count = (uint32_t)per_dispatch;
        uint32_t invocations = (push.photon_count + per_invocation - 1) / per_invocation;
        uint32_t groups = (invocations + TRACE_GROUP_SIZE - 1) / TRACE_GROUP_SIZE;
        push.photon_stride = groups * TRACE_GROUP_SIZE;
        status = pf_vk_cmd_dispatch(cmds, kernel, job->buffers, TRACE_BUFFERS, &push,
                                    sizeof push, groups, 1, 1, err);
    }
    job->end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, job->counter_buffer, 0, &job->counters,
                                    sizeof job->counters, err);
    return status;
}

/*
 * Traces the selected jobs (every one the device traces at first; again those whose shared
 * invocations met the loop cap) in one submission and one wait; adds each one's GPU time
 * to its own.
 */
static pf_status submit_jobs(pf_photon_tracer *tracer, pf_vk_pipeline *kernel, trace_job *jobs,
                             const int *selected, uint32_t count, pf_error *err)
{
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(tracer->ctx, &cmds, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++)
        if (selected[i])
            status = job_record(cmds, kernel, &jobs[i], err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        if (!selected[i])
            continue;
        trace_job *job = &jobs[i];
        double ms = job->begin >= 0 && job->end >= 0
                        ? pf_vk_commands_elapsed_ms(cmds, job->begin, job->end)
                        : -1.0;
        job->gpu_ms = job->submitted == 0 ? ms
                      : job->gpu_ms >= 0.0 && ms >= 0.0 ? job->gpu_ms + ms
                                                         : -1.0;
        job->submitted++;
    }
    pf_vk_commands_destroy(cmds);
    return status;
}

/* The job's counters as its maps' counts, or the error they name. */
static pf_status job_finish(const trace_job *job, const pf_photon_emitters *emitters,
                            pf_photon_maps *out, pf_error *err)
{
    const trace_counters *counters = &job->counters;
    out->per_invocation = job->per_invocation;
    if (counters->traversal_failures > 0)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "%u photons overflowed the %u-entry BIH traversal stack",
                            counters->traversal_failures, PF_BIH_STACK_SIZE);
    if (counters->loop_truncated > 0)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "%u invocations (%u photons each) stopped at the device's loop cap "
                            "(llvmpipe: 65,535 loop iterations an invocation), cutting their "
                            "photons' paths short",
                            counters->loop_truncated, job->per_invocation);
    const photon_trace_params *params = &job->params;
    out->emitted = emitters->count > 0 ? job->settings->photon_count : 0;
    out->global_offered = counters->global_stored;
    out->caustic_offered = counters->caustic_stored;
    out->global_count = counters->global_stored < params->global_capacity
                            ? counters->global_stored
                            : params->global_capacity;
    out->caustic_count = counters->caustic_stored < params->caustic_capacity
                             ? counters->caustic_stored
                             : params->caustic_capacity;
    out->non_finite = counters->non_finite;
    for (uint32_t d = 0; d < PF_PHOTON_ARRIVAL_DIRECTIONS; d++)
        out->arrival_direction_flux[d] =
            ((double)counters->arrivals[2 * d + 1] * 4294967296.0 + counters->arrivals[2 * d]) /
            65536.0;
    return PF_OK;
}

pf_status pf_photon_trace_passes(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                                 const pf_photon_emitters *emitters,
                                 const pf_photon_trace_settings *settings, uint32_t count,
                                 pf_photon_maps *out, pf_error *err)
{
    pf_vk_context *ctx = tracer->ctx;
    for (uint32_t i = 0; i < count; i++) {
        memset(&out[i], 0, sizeof out[i]);
        out[i].gpu_ms = -1.0;
    }
    trace_job *jobs = calloc(count ? count : 1, sizeof *jobs);
    int *selected = calloc(count ? count : 1, sizeof *selected);
    pf_status status = jobs && selected ? PF_OK
                                        : pf_error_set(err, PF_ERR_NOMEM,
                                                       "photon trace: out of memory (%u passes)",
                                                       count);
    uint32_t failed = count; /* the pass an error names (count: the batch's submission) */
    for (uint32_t i = 0; status == PF_OK && i < count; i++)
        if ((status = job_prepare(tracer, scene, emitters, &settings[i], &jobs[i], &out[i],
                                  err)) != PF_OK)
            failed = i;
    /* Where the host traces the rays, each pass in its waves; else every pass in one
     * submission (the flat loop's kernel made only then: 0.1-0.3 s of llvmpipe's a process). */
    pf_vk_pipeline *kernel = NULL;
    int batched = 0;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        selected[i] = emitters->count > 0 && !settings[i].host_tree;
        batched += selected[i];
        if (emitters->count > 0 && settings[i].host_tree) {
            jobs[i].per_invocation = 1;
            status = pf_photon_trace_waves(ctx, tracer, scene->surface_features, jobs[i].buffers,
                                           &jobs[i].uploads, settings[i].host_tree,
                                           settings[i].host_wide, settings[i].photon_count,
                                           &jobs[i].counters, &out[i], err);
            if (status != PF_OK)
                failed = i;
        }
    }
    if (status == PF_OK && batched > 0)
        status = pf_photon_trace_pipeline(tracer, PF_PHOTON_TRACED_HERE, scene->surface_features,
                                          &kernel, err);
    if (status == PF_OK && batched > 0)
        status = submit_jobs(tracer, kernel, jobs, selected, count, err);
    /* Photons that share an invocation add up its loop iterations: where that met the cap,
     * the pass is traced again with one photon each (slots restart at 0: nothing is kept). */
    int again = 0;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        selected[i] = selected[i] && jobs[i].counters.loop_truncated > 0 &&
                      jobs[i].per_invocation > 1;
        if (selected[i])
            jobs[i].per_invocation = 1;
        again += selected[i];
    }
    if (status == PF_OK && again > 0)
        status = submit_jobs(tracer, kernel, jobs, selected, count, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        if (jobs[i].submitted > 0)
            out[i].gpu_ms = jobs[i].gpu_ms;
        if ((status = job_finish(&jobs[i], emitters, &out[i], err)) != PF_OK)
            failed = i;
    }
    for (uint32_t i = 0; jobs && i < count; i++)
        job_release(ctx, &jobs[i]);
    free(jobs);
    free(selected);
    if (status != PF_OK) {
        for (uint32_t i = 0; i < count; i++) {
            pf_photon_maps_release(ctx, &out[i]);
            out[i].gpu_ms = -1.0;
        }
        if (count > 1 && failed < count)
            pf_error_prefix(err, "photon trace of pass %u of %u (%u photons, %u emitters)",
                            failed + 1, count, settings[failed].photon_count, emitters->count);
        else if (count > 1)
            pf_error_prefix(err, "photon trace of %u passes (%u photons each, %u emitters)",
                            count, settings[0].photon_count, emitters->count);
        else
            pf_error_prefix(err, "photon trace (%u photons, %u emitters)",
                            count ? settings[0].photon_count : 0, emitters->count);
    }
    return status;
}

pf_status pf_photon_trace(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                          const pf_photon_emitters *emitters,
                          const pf_photon_trace_settings *settings, pf_photon_maps *out,
                          pf_error *err)
{
    return pf_photon_trace_passes(tracer, scene, emitters, settings, 1, out, err);
}

pf_status pf_photon_map_download(pf_vk_context *ctx, pf_vk_buffer *map, uint32_t count,
                                 pf_photon **photons, pf_error *err)
{
    *photons = NULL;
    if (count == 0)
        return PF_OK;
    *photons = malloc((size_t)count * sizeof **photons);
    if (!*photons)
        return pf_error_set(err, PF_ERR_NOMEM, "photon map download: %u photons", count);
    pf_status status =
        pf_vk_buffer_download(ctx, map, 0, *photons, (uint64_t)count * sizeof **photons, err);
    if (status != PF_OK) {
        free(*photons);
        *photons = NULL;
    }
    return status;
}

pf_status pf_photon_plan_passes(pf_vk_context *ctx, uint64_t budget, uint32_t stores_per_photon,
                                pf_photon_pass_plan *plan, pf_error *err)
{
    memset(plan, 0, sizeof *plan);
    if (budget == 0)
        return pf_error_set(err, PF_ERR_INVALID, "photon pass plan: a budget of 0 photons");
    const pf_vk_device_info *info = pf_vk_info(ctx);
    uint32_t stores = stores_per_photon ? stores_per_photon : DEFAULT_STORES_PER_PHOTON;
    /* The grid's other buffers (ranges, keys, values: <= 16 bytes per photon) fit when the map does. */
    uint64_t fits = info->max_storage_buffer_range / sizeof(pf_photon);
    uint64_t per_pass = fits / stores;
    if (per_pass > UINT32_MAX / stores)
        per_pass = UINT32_MAX / stores;
    if (per_pass == 0)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "photon pass plan: %u stores per photon exceed one buffer on '%s' (%llu photons fit)",
                            stores, info->name, (unsigned long long)fits);
    uint64_t passes = budget / per_pass + (budget % per_pass != 0); /* no overflow near UINT64_MAX */
    if (passes > UINT32_MAX)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "photon pass plan: a budget of %llu photons needs %llu passes of %llu on '%s' (at most %u)",
                            (unsigned long long)budget, (unsigned long long)passes,
                            (unsigned long long)per_pass, info->name, UINT32_MAX);
    if (budget < per_pass)
        per_pass = budget;
    plan->passes = (uint32_t)passes;
    plan->photons_per_pass = (uint32_t)per_pass;
    plan->last_pass_photons = (uint32_t)(budget - (passes - 1) * per_pass);
    plan->capacity = (uint32_t)(per_pass * stores);
    return PF_OK;
}
