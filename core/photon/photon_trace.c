/*
 * Host side of photon tracing (pf_photon_trace in pf_photon.h;
 * shaders/photon_trace.comp does the work): in one submission where the
 * device traces the rays, in waves where the host does (photon_trace_wave.c).
 */
#include "photon_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TRACE_GROUP_SIZE 64u
/* Workgroups per dispatch: below the 65535 every device allows. */
#define TRACE_MAX_GROUPS 16384u
/* Default map capacity: stores per emitted photon (a bounce or two survive roulette on average). */
#define DEFAULT_STORES_PER_PHOTON 4u

_Static_assert(sizeof(photon_trace_params) == 96, "photon_trace_params must match PhotonTraceParams");

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
        pf_vk_spec_constant constants[3] = {
            {PF_SPEC_SCENE_HAS_ALPHA, (features & PF_SURFACE_ALPHA) ? 1u : 0u},
            {PF_SPEC_SCENE_HAS_CORNERS, (features & PF_SURFACE_CORNERS) ? 1u : 0u},
            {PHOTON_STEP_CONSTANT, (uint32_t)step}};
        pf_status status = pf_vk_pipeline_create_named(
            tracer->ctx, features ? "photon_trace_surfaces" : "photon_trace", TRACE_BUFFERS,
            sizeof(trace_push), constants, step == PF_PHOTON_TRACED_HERE ? 2 : 3, slot, err);
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
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
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
 * Traces count photons into the maps bound in buffers (their counters zeroed first), each
 * invocation per_invocation of them in turn (photon_trace.comp), and reads back the counters
 * and the GPU time (< 0 without timestamps). One submission and one wait: the uploads, the
 * counters zeroed, the dispatches and the counters' readback.
 */
static pf_status trace_photons(pf_photon_tracer *tracer, pf_vk_pipeline *kernel,
                               pf_vk_buffer **buffers, const trace_uploads *uploads,
                               uint32_t count, uint32_t per_invocation, trace_counters *counters,
                               double *gpu_ms, pf_error *err)
{
    pf_vk_context *ctx = tracer->ctx;
    pf_vk_buffer *counter_buffer = buffers[TRACE_COUNTERS];
    memset(counters, 0, sizeof *counters);
    *gpu_ms = -1.0;
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_photon_trace_uploads(cmds, buffers, uploads, err);
    int begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    const uint64_t per_dispatch = (uint64_t)TRACE_GROUP_SIZE * TRACE_MAX_GROUPS * per_invocation;
    for (uint64_t first = 0; status == PF_OK && first < count; first += per_dispatch) {
        trace_push push = {(uint32_t)first, count - (uint32_t)first, 0, 1};
        if (push.photon_count > per_dispatch)
            push.photon_count = (uint32_t)per_dispatch;
        uint32_t invocations = (push.photon_count + per_invocation - 1) / per_invocation;
        uint32_t groups = (invocations + TRACE_GROUP_SIZE - 1) / TRACE_GROUP_SIZE;
        push.photon_stride = groups * TRACE_GROUP_SIZE;
        status = pf_vk_cmd_dispatch(cmds, kernel, buffers, TRACE_BUFFERS, &push,
                                    sizeof push, groups, 1, 1, err);
    }
    int end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, counter_buffer, 0, counters, sizeof *counters, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK && begin >= 0 && end >= 0)
        *gpu_ms = pf_vk_commands_elapsed_ms(cmds, begin, end);
    pf_vk_commands_destroy(cmds);
    return status;
}

pf_status pf_photon_trace(pf_photon_tracer *tracer, const pf_photon_scene *scene,
                          const pf_photon_emitters *emitters,
                          const pf_photon_trace_settings *settings, pf_photon_maps *out,
                          pf_error *err)
{
    memset(out, 0, sizeof *out);
    out->gpu_ms = -1.0;
    if (settings->photon_count == 0)
        return pf_error_set(err, PF_ERR_INVALID, "photon trace: 0 photons requested");
    pf_vk_context *ctx = tracer->ctx;
    const pf_vk_device_info *info = pf_vk_info(ctx);
    photon_trace_params params;
    memset(&params, 0, sizeof params);
    pf_status status = map_capacity(info, settings->global_capacity, settings->photon_count,
                                    "global", &params.global_capacity, err);
    if (status == PF_OK)
        status = map_capacity(info, settings->caustic_capacity, settings->photon_count,
                              "caustic", &params.caustic_capacity, err);
    if (status != PF_OK)
        return status;
    double total_luminance = luminance(emitters->total_power);
    out->flux_scale = emitters->count > 0 ? (float)(total_luminance / settings->photon_count) : 0.0f;
    for (int k = 0; k < 3; k++) {
        params.bih_bounds_min[k] = scene->bih.bounds_min[k];
        params.bih_bounds_max[k] = scene->bih.bounds_max[k];
        params.scene_sphere[k] = emitters->scene_center[k];
    }
    params.scene_sphere[3] = emitters->scene_radius;
    params.photon_count = settings->photon_count;
    params.emitter_count = emitters->count;
    params.store_direct = settings->store_direct ? 1u : 0u;
    params.global_reflected = settings->global_reflected ? 1u : 0u;
    params.triangle_count = scene->triangle_count;
    params.bih_node_count = scene->bih.node_count;
    params.seed_lo = (uint32_t)settings->seed;
    params.seed_hi = (uint32_t)(settings->seed >> 32);
    params.max_depth = settings->max_depth ? settings->max_depth : PF_PHOTON_DEFAULT_MAX_DEPTH;
    params.ray_offset = scene->ray_offset;

    pf_vk_buffer *params_buffer = NULL, *emitter_buffer = NULL, *counter_buffer = NULL;
    pf_vk_buffer *placeholder = NULL; /* the texture bindings of a scene without textures */
    pf_vk_pipeline *kernel = NULL;
    status = pf_photon_trace_pipeline(tracer, PF_PHOTON_TRACED_HERE, scene->surface_features,
                                      &kernel, err);
    const trace_counters zero = {0, 0, 0, 0, 0};
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof params, "photon trace parameters",
                                     &params_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(emitters->count ? emitters->count : 1) *
                                         sizeof(pf_photon_emitter),
                                     "photon emitters", &emitter_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof zero, "photon trace counters", &counter_buffer,
                                     err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(params.global_capacity ? params.global_capacity : 1) *
                                         sizeof(pf_photon),
                                     "global photon map", &out->global, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx,
                                     (uint64_t)(params.caustic_capacity ? params.caustic_capacity : 1) *
                                         sizeof(pf_photon),
                                     "caustic photon map", &out->caustic, err);

    if (status == PF_OK && !(scene->corners && scene->textures && scene->texels))
        status = pf_vk_buffer_create(ctx, 4 * sizeof(uint32_t), "no textures", &placeholder, err);
    pf_vk_buffer *buffers[TRACE_BUFFERS] = {
        [PF_SCENE_BINDING_PARAMS] = params_buffer,
        [PF_SCENE_BINDING_VERTICES] = scene->vertices,
        [PF_SCENE_BINDING_NORMALS] = scene->normals,
        [PF_SCENE_BINDING_TRIANGLE_MATERIALS] = scene->triangle_material,
        [PF_SCENE_BINDING_MATERIALS] = scene->materials,
        [PF_SCENE_BINDING_LIGHTS] = scene->lights,
        [PF_SCENE_BINDING_EMISSIVE] = emitter_buffer,
        [PF_SCENE_BINDING_CORNERS] = scene->corners ? scene->corners : placeholder,
        [PF_SCENE_BINDING_TEXTURES] = scene->textures ? scene->textures : placeholder,
        [PF_SCENE_BINDING_TEXELS] = scene->texels ? scene->texels : placeholder,
        [PF_SCENE_BINDING_COUNT + 0] = scene->bih.nodes,
        [PF_SCENE_BINDING_COUNT + 1] = scene->bih.vertices,
        [PF_SCENE_BINDING_COUNT + 2] = scene->bih.triangle_index,
        [PF_SCENE_BINDING_COUNT + 3] = out->global,
        [PF_SCENE_BINDING_COUNT + 4] = out->caustic,
        [TRACE_COUNTERS] = counter_buffer};
    /* The waves' buffers, where the host traces (photon_trace_wave.c binds its own). */
    for (uint32_t b = TRACE_COUNTERS + 1; b < TRACE_BUFFERS; b++)
        buffers[b] = counter_buffer;
    uint32_t per_invocation = settings->per_invocation ? settings->per_invocation
                              : pf_vk_device_is_cpu(ctx) ? PF_PHOTON_TRACE_PER_INVOCATION
                                                              : 1u;
    trace_counters counters = zero;
    trace_uploads uploads = {&params, emitters, placeholder};
    if (status == PF_OK && emitters->count > 0 && settings->host_tree) {
        per_invocation = 1;
        status = pf_photon_trace_waves(ctx, tracer, scene->surface_features, buffers, &uploads,
                                       settings->host_tree, settings->host_wide,
                                       settings->photon_count, &counters, out, err);
    } else if (status == PF_OK && emitters->count > 0) {
        status = trace_photons(tracer, kernel, buffers, &uploads, settings->photon_count,
                               per_invocation, &counters, &out->gpu_ms, err);
    }
    /* Photons that share an invocation add up its loop iterations: where that met the cap,
     * the pass is traced again with one photon each (slots restart at 0: nothing is kept). */
    if (status == PF_OK && counters.loop_truncated > 0 && per_invocation > 1) {
        per_invocation = 1;
        double first_ms = out->gpu_ms;
        status = trace_photons(tracer, kernel, buffers, &uploads, settings->photon_count,
                               per_invocation, &counters, &out->gpu_ms, err);
        out->gpu_ms = first_ms >= 0.0 && out->gpu_ms >= 0.0 ? first_ms + out->gpu_ms : -1.0;
    }
    out->per_invocation = per_invocation;
    release(ctx, &params_buffer);
    release(ctx, &emitter_buffer);
    release(ctx, &counter_buffer);
    release(ctx, &placeholder);
    if (status == PF_OK && counters.traversal_failures > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%u photons overflowed the %u-entry BIH traversal stack",
                              counters.traversal_failures, PF_BIH_STACK_SIZE);
    if (status == PF_OK && counters.loop_truncated > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%u invocations (%u photons each) stopped at the device's loop cap "
                              "(llvmpipe: 65,535 loop iterations an invocation), cutting their "
                              "photons' paths short",
                              counters.loop_truncated, per_invocation);
    if (status != PF_OK) {
        pf_photon_maps_release(ctx, out);
        out->gpu_ms = -1.0;
        pf_error_prefix(err, "photon trace (%u photons, %u emitters)", settings->photon_count,
                        emitters->count);
        return status;
    }
    out->emitted = emitters->count > 0 ? settings->photon_count : 0;
    out->global_offered = counters.global_stored;
    out->caustic_offered = counters.caustic_stored;
    out->global_count = counters.global_stored < params.global_capacity ? counters.global_stored
                                                                         : params.global_capacity;
    out->caustic_count = counters.caustic_stored < params.caustic_capacity
                             ? counters.caustic_stored
                             : params.caustic_capacity;
    out->non_finite = counters.non_finite;
    return PF_OK;
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
