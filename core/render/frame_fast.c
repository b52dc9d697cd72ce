/*
 * The `fast` integrator (issue 11): direct light by next-event estimation,
 * diffuse indirect light from cascaded light propagation volumes, caustics
 * from a caustic photon map. Host side of shaders/render_fast.comp and
 * render_fast_caustic.comp (shaders/common/fast_shade.glsl).
 *
 * Stages, in order (each a row, skipped ones with their reason), as the
 * stage planner (stage_plan.c) decided them before the frame:
 *   bih_build      the frame's BIH (frame_bih.c)
 *   photon_trace   one photon pass (the plan's photons) whose global map keeps every
 *                  diffuse hit with the flux the surface reflects: these
 *                  are the virtual point lights, so the LPV carries every
 *                  bounce of indirect light, not only the first
 *   caustic_map    the caustic photons (L S+ D) gridded for a k-nearest
 *                  estimate, only when some light reaches a mirror or glass
 *   lpv_geometry   the geometry volume of the frame's triangles (core/lpv)
 *   lpv_inject     the VPLs into every cascade
 *   lpv_propagate  each cascade's iterations on the device
 *   shade          the LPV's delivered energy weighed against the photons' arrivals
 *                  (fast_shade.glsl's lpv_energy_scale), then the plan's camera
 *                  samples per pixel
 *
 * Reuse (renderer->fast_cache holds the outputs, the renderer's stage
 * memory what they were made from): the VPLs and the caustic grid while
 * geometry, lights, materials, seed and photon count are equal; the
 * geometry volume while the geometry and the cascade layout are; the
 * injected volume while the VPLs and the layout are; the propagation while
 * all of those and the iterations are. The cascade layout follows the
 * camera only through its snapped origins, so a camera that moves within a
 * cell reuses everything.
 */
#include "pf_lpv.h"
#include "pf_photon.h"
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Photons in the caustic estimate's largest disc at the VPLs' mean density (as final's r_1). */
#define FAST_CAUSTIC_NEIGHBOURS 20.0
#define FAST_MAX_SPECULAR_DEPTH 8u
#define GROUP_EDGE 8u
/* A frame fails when more than this fraction of its samples hit the loop cap (as final). */
#define FAST_TRUNCATED_LIMIT 0.01
/* Points on the diffuse surfaces where the LPV's delivered energy is weighed (shade): its
 * irradiance is smooth, and 16,384 points put the sum's noise under a percent. */
#define FAST_ENERGY_SAMPLES 16384u
/* fast_shade.glsl's LPV_ENERGY_SCALE_MAX. */
#define FAST_ENERGY_SCALE_MAX 1.0

/* fast_shade.glsl's Push (76 bytes). */
typedef struct fast_push {
    pf_photon_grid_push grid;
    uint32_t grid_photons;
    uint32_t sample_index;
    uint32_t cascade_count;
    uint32_t lpv_size;
    float radius;
    float flux_scale;
    uint32_t loop_sentinel;
    uint32_t lpv_damping;
    uint32_t energy_samples;
    float energy_weight;
} fast_push;

_Static_assert(sizeof(fast_push) == 76, "fast_push must match fast_shade.glsl's Push");

/* fast_shade.glsl's LpvEnergy: a 64-bit sum in two words, in 1 / FAST_ENERGY_UNITS of the
 * map's flux unit (its LPV_ENERGY_UNITS). */
#define FAST_ENERGY_UNITS 256.0
typedef struct fast_energy {
    float arrivals[8]; /* PF_PHOTON_ARRIVAL_DIRECTIONS used */
    uint32_t delivered[2 * PF_PHOTON_ARRIVAL_DIRECTIONS];
} fast_energy;

typedef struct fast_counters {
    uint32_t discarded_samples;
    uint32_t traversal_failures;
    uint32_t rays_low, rays_high;
    uint32_t loop_truncated;
    uint32_t lpv_outside;
} fast_counters;

struct pf_fast_cache {
    /* Photons: the VPLs (the global map's records, kept on the device) and the caustic
     * grid. */
    pf_vk_buffer *vpls;
    uint32_t vpl_count;
    float vpl_flux_scale;
    uint32_t emitted, caustic_count;
    /* The photons' arrival flux inside the coarsest cascade by direction
     * (pf_photon_maps.arrival_direction_flux): what the LPV's delivered energy is scaled to. */
    double arrival_direction_flux[PF_PHOTON_ARRIVAL_DIRECTIONS];
    pf_photon_grid *caustic;      /* NULL: no caustic map */
    float caustic_radius, caustic_flux_scale;
    double trace_gpu_ms;
    /* LPV: the layout and volumes of the last frame. */
    pf_lpv *lpv;
    pf_lpv_layout layout;
    float *geometry, *injected;
    /* The last injection ran on the device, which keeps the volume (pf_lpv); else injected
     * holds it. */
    int injected_on_device;
    pf_lpv_inject_stats inject_stats;
    uint64_t geometry_pieces;
    /* Points on the diffuse surfaces (pf_lpv_energy_samples), made with the geometry volume,
     * and the area they cover. */
    float *energy_samples;
    double energy_area;
    pf_vk_buffer *cascades;       /* vec4 per cascade: origin, cell size */
};

void pf_fast_cache_destroy(pf_vk_context *ctx, struct pf_fast_cache *cache)
{
    if (!cache)
        return;
    pf_render_buffer_release(ctx, &cache->vpls);
    free(cache->geometry);
    free(cache->injected);
    free(cache->energy_samples);
    pf_photon_grid_destroy(cache->caustic);
    pf_render_buffer_release(ctx, &cache->cascades);
    pf_lpv_destroy(cache->lpv);
    free(cache);
}

/* Frame-wide figures for the rows. */
typedef struct fast_progress {
    double trace_ms, caustic_ms, geometry_ms, inject_ms, inject_gpu_ms, propagate_ms;
    double propagate_gpu_ms;
    double propagate_cascade_gpu_ms[PF_LPV_MAX_CASCADES]; /* < 0: not measured */
    int propagate_on_host; /* the propagation ran on the host's CPUs (pf_lpv_propagate_stats) */
    uint32_t samples;
    uint64_t rays, discarded, truncated, failures, lpv_outside;
    /* The LPV's delivered flux at the points (map units; 0: not weighed), in all and by the
     * direction the surfaces face (pf_photon_maps.arrival_direction_flux's). */
    double lpv_direction_delivered[PF_PHOTON_ARRIVAL_DIRECTIONS];
    double shade_gpu_ms;
    /* Where the host traced the photons: the waves' dispatches and its traces' time. */
    uint32_t photon_waves;
    double photon_host_ms;
} fast_progress;

/* Traces the frame's photons into *maps and keeps the VPLs (every diffuse hit, reflected
 * flux): the global map, which stays on the device. */
static pf_status trace_photons(struct pf_fast_cache *cache, const pf_photon_frame *inputs,
                               const pf_scene_frame *frame, const pf_render_settings *settings,
                               const pf_stage_plan *plan, pf_renderer *renderer,
                               pf_photon_maps *maps, fast_progress *progress, pf_error *err)
{
    double start = pf_time_ms();
    pf_photon_trace_settings trace = {.photon_count = plan->photons,
                                      .seed = settings->seed,
                                      .store_direct = 1,
                                      .global_reflected = 1};
    /* Arrivals are counted where a lookup finds the coarsest cascade (lpv_lookup.glsl):
     * between its first and last cells' centres. */
    const pf_lpv_cascade *coarsest = &plan->layout.cascades[plan->layout.count - 1];
    for (int k = 0; k < 3; k++) {
        trace.arrival_box_min[k] = coarsest->origin[k] + 0.5f * coarsest->cell_size;
        trace.arrival_box_max[k] =
            coarsest->origin[k] + ((float)plan->layout.size - 0.5f) * coarsest->cell_size;
    }
    pf_status status = pf_photon_frame_trace(renderer, inputs, plan, &trace, 1, maps, err);
    if (status != PF_OK)
        return status;
    cache->trace_gpu_ms = maps->gpu_ms;
    progress->photon_waves = maps->waves;
    progress->photon_host_ms = maps->host_trace_ms;
    if (maps->traversal_failures > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%u photons overflowed the BIH traversal stack",
                              maps->traversal_failures);
    if (status == PF_OK) { /* the VPLs stay on the device, the cache's now */
        cache->vpls = maps->global;
        maps->global = NULL;
        cache->vpl_count = maps->global_count;
        cache->vpl_flux_scale = maps->flux_scale;
    }
    cache->emitted = maps->emitted;
    memcpy(cache->arrival_direction_flux, maps->arrival_direction_flux,
           sizeof cache->arrival_direction_flux);
    cache->caustic_count = plan->caustic_map && status == PF_OK ? maps->caustic_count : 0;
    cache->caustic_flux_scale = maps->flux_scale;
    cache->caustic_radius = pf_photon_radius_for_density(frame, FAST_CAUSTIC_NEIGHBOURS,
                                                         maps->global_count, 0.01);
    progress->trace_ms += pf_time_ms() - start;
    if (status != PF_OK)
        pf_error_prefix(err, "photon pass (%u photons)", plan->photons);
    return status;
}

/* The caustic grid of the traced photons (none when no caustic photon was stored). */
static pf_status build_caustic_map(pf_vk_context *ctx, struct pf_fast_cache *cache,
                                   const pf_scene_frame *frame, const pf_photon_maps *maps,
                                   fast_progress *progress, pf_error *err)
{
    double start = pf_time_ms();
    pf_status status = PF_OK;
    if (cache->caustic_count > 0) {
        if (!cache->caustic)
            status = pf_photon_grid_create(ctx, &cache->caustic, err);
        if (status == PF_OK)
            status = pf_photon_grid_build_device(cache->caustic, maps->caustic,
                                                 maps->caustic_count, frame->bounds_min,
                                                 frame->bounds_max, cache->caustic_radius, err);
    } else {
        pf_photon_grid_destroy(cache->caustic);
        cache->caustic = NULL;
    }
    progress->caustic_ms += pf_time_ms() - start;
    return status;
}

/* Grows *volume to floats floats (contents undefined). */
static pf_status ensure_host_volume(float **volume, uint64_t floats, pf_error *err)
{
    float *grown = realloc(*volume, floats * sizeof **volume);
    if (!grown)
        return pf_error_set(err, PF_ERR_NOMEM, "LPV: out of memory for %llu floats",
                            (unsigned long long)floats);
    *volume = grown;
    return PF_OK;
}

/* lpv_geometry: the geometry volume of the frame's triangles in every cascade. */
static pf_status build_geometry_volume(struct pf_fast_cache *cache, const pf_scene_frame *frame,
                                       const pf_lpv_layout *layout, fast_progress *progress,
                                       pf_error *err)
{
    double start = pf_time_ms();
    pf_status status = ensure_host_volume(
        &cache->geometry, pf_lpv_volume_floats(layout, PF_LPV_GV_FLOATS_PER_CELL), err);
    if (status == PF_OK)
        cache->geometry_pieces = pf_lpv_geometry_build(layout, frame, cache->geometry);
    if (status == PF_OK && !cache->energy_samples) {
        cache->energy_samples = malloc((size_t)FAST_ENERGY_SAMPLES *
                                       PF_LPV_ENERGY_SAMPLE_FLOATS * sizeof(float));
        if (!cache->energy_samples)
            status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory for the LPV's points");
    }
    if (status == PF_OK)
        cache->energy_area =
            pf_lpv_energy_samples(frame, FAST_ENERGY_SAMPLES, cache->energy_samples);
    progress->geometry_ms = pf_time_ms() - start;
    return status;
}

/* The host's injection (inject_vpls says where it runs): the VPL records read from the
 * device, mapped memory on a CPU device. */
static pf_status inject_on_host(pf_vk_context *ctx, struct pf_fast_cache *cache,
                                const pf_lpv_layout *layout, uint64_t sh_floats, pf_error *err)
{
    pf_photon *photons = NULL;
    pf_lpv_vpl *vpls = NULL;
    pf_status status = pf_photon_map_download(ctx, cache->vpls, cache->vpl_count,
                                              &photons, err);
    if (status == PF_OK && cache->vpl_count > 0) {
        vpls = malloc((size_t)cache->vpl_count * sizeof *vpls);
        if (!vpls)
            status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory for %u VPLs",
                                  cache->vpl_count);
    }
    for (uint32_t i = 0; status == PF_OK && i < cache->vpl_count; i++) {
        float incoming[3];
        pf_photon_unpack(&photons[i], vpls[i].position, vpls[i].flux, incoming, vpls[i].normal);
        for (int c = 0; c < 3; c++)
            vpls[i].flux[c] *= cache->vpl_flux_scale;
    }
    if (status == PF_OK) {
        memset(cache->injected, 0, sh_floats * sizeof *cache->injected);
        pf_lpv_inject(layout, vpls, cache->vpl_count, cache->injected, &cache->inject_stats);
    }
    free(photons);
    free(vpls);
    return status;
}

/*
 * lpv_inject: the VPLs' SH into every cascade, where the propagation runs. On a GPU that
 * is the device: one submission, and neither the photons nor the volume leave it. Where
 * the propagation runs on the host (a CPU device, lavapipe), the injection does too: the
 * records are read from mapped memory without a submission, and the host's loop measures
 * 2.7× faster there than the kernel's 64-bit atomics, which llvmpipe serialises (428k VPLs
 * into 4 cascades on staircase2: 60 ms against 160 ms, bench/RESULTS.md). A device
 * without 64-bit atomics injects on the host as well.
 */
static pf_status inject_vpls(pf_vk_context *ctx, struct pf_fast_cache *cache,
                             const pf_lpv_layout *layout, fast_progress *progress, pf_error *err)
{
    double start = pf_time_ms();
    uint64_t sh_floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    int on_device = !pf_lpv_propagates_on_host(cache->lpv) &&
                    pf_lpv_injects_on_device(cache->lpv, layout);
    pf_status status = PF_OK;
    progress->inject_gpu_ms = -1.0;
    if (on_device) {
        status = pf_lpv_inject_photons(cache->lpv, layout, cache->vpls, cache->vpl_count,
                                       cache->vpl_flux_scale, NULL, &cache->inject_stats,
                                       &progress->inject_gpu_ms, err);
    } else {
        status = ensure_host_volume(&cache->injected, sh_floats, err);
        if (status == PF_OK)
            status = inject_on_host(ctx, cache, layout, sh_floats, err);
    }
    cache->injected_on_device = on_device;
    progress->inject_ms = pf_time_ms() - start;
    return status;
}

/* lpv_propagate: every cascade's iterations, on the device or, where it is the CPU, the host. */
static pf_status propagate(struct pf_fast_cache *cache, const pf_lpv_layout *layout,
                           fast_progress *progress, pf_error *err)
{
    double start = pf_time_ms();
    pf_lpv_propagate_stats stats;
    pf_status status =
        pf_lpv_propagate(cache->lpv, layout, cache->injected_on_device ? NULL : cache->injected,
                         cache->geometry, &stats, err);
    progress->propagate_gpu_ms = stats.gpu_ms;
    memcpy(progress->propagate_cascade_gpu_ms, stats.cascade_gpu_ms,
           sizeof progress->propagate_cascade_gpu_ms);
    progress->propagate_on_host = stats.on_host;
    progress->propagate_ms = pf_time_ms() - start;
    return status;
}

/* The cascades' origins and cell sizes for the shading kernel, uploaded with its
 * dispatches (issue 44: no submission of their own). */
static pf_status record_cascades(pf_vk_context *ctx, pf_vk_commands *cmds,
                                 struct pf_fast_cache *cache, const pf_lpv_layout *layout,
                                 pf_error *err)
{
    float cascades[PF_LPV_MAX_CASCADES][4];
    for (uint32_t k = 0; k < layout->count; k++) {
        memcpy(cascades[k], layout->cascades[k].origin, 3 * sizeof(float));
        cascades[k][3] = layout->cascades[k].cell_size;
    }
    pf_status status = PF_OK;
    if (!cache->cascades)
        status = pf_vk_buffer_create(ctx, sizeof cascades, "LPV cascades", &cache->cascades, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, cache->cascades, 0, cascades,
                                  layout->count * sizeof cascades[0], err);
    return status;
}

/* Device buffers of one frame's shading; every pointer NULL or owned. */
typedef struct fast_buffers {
    pf_vk_buffer *params, *film, *film_aov, *counters, *empty_grid, *energy, *energy_samples;
} fast_buffers;

static void fast_buffers_release(pf_vk_context *ctx, fast_buffers *b)
{
    pf_vk_buffer **all[] = {&b->params,     &b->film,   &b->film_aov,      &b->counters,
                            &b->empty_grid, &b->energy, &b->energy_samples};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        pf_render_buffer_release(ctx, all[i]);
}

/*
 * The LPV's energy scale (fast_shade.glsl): the photons' arrivals by direction and the
 * points where the LPV's delivered flux is weighed on the device before the samples,
 * uploaded with them; *weighed 0 where the LPV is not scaled (lpv.unscaled, no diffuse
 * surface, no photon flux), the points' buffer then a placeholder.
 */
static pf_status record_energy(pf_vk_context *ctx, pf_vk_commands *cmds,
                               const struct pf_fast_cache *cache,
                               const pf_render_settings *settings, fast_buffers *owned,
                               fast_push *push, int *weighed, pf_error *err)
{
    *weighed = !settings->lpv.unscaled && cache->energy_area > 0.0 &&
               cache->vpl_flux_scale > 0.0f && cache->layout.count > 0;
    fast_energy energy = {0};
    for (uint32_t d = 0; d < PF_PHOTON_ARRIVAL_DIRECTIONS; d++)
        energy.arrivals[d] = (float)cache->arrival_direction_flux[d];
    pf_status status = pf_render_buffer_recorded(ctx, cmds, "LPV energy", &energy,
                                                 sizeof energy, sizeof energy, &owned->energy,
                                                 err);
    uint64_t sample_bytes = (uint64_t)FAST_ENERGY_SAMPLES * PF_LPV_ENERGY_SAMPLE_FLOATS *
                            sizeof(float);
    if (status == PF_OK)
        status = pf_render_buffer_recorded(ctx, cmds, "LPV energy points",
                                           *weighed ? cache->energy_samples : NULL,
                                           *weighed ? sample_bytes : 0,
                                           *weighed ? sample_bytes : 32,
                                           &owned->energy_samples, err);
    if (*weighed) {
        push->energy_samples = FAST_ENERGY_SAMPLES;
        push->energy_weight = (float)(cache->energy_area / FAST_ENERGY_SAMPLES /
                                      cache->vpl_flux_scale);
    }
    return status;
}

/* The scale fast_shade.glsl gives the LPV for these arrivals and this delivered flux. */
static double energy_scale(double arrivals, double delivered, double otherwise)
{
    return delivered > 0.0 ? fmin(arrivals / delivered, FAST_ENERGY_SCALE_MAX) : otherwise;
}

/* The shade stage: samples dispatches of the fast kernel into the split film, then the image. */
static pf_status shade(pf_renderer *renderer, struct pf_fast_cache *cache,
                       const pf_scene_frame *frame, const pf_render_settings *settings,
                       const pf_stage_plan *plan,
                       const pf_gpu_scene *scene, const pf_bih_gpu_view *bih, pf_image *image,
                       fast_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    uint32_t samples = plan->samples;
    pf_frame_params params;
    pf_frame_params_fill(frame, settings, samples, scene, bih, &params);
    params.max_specular_depth = FAST_MAX_SPECULAR_DEPTH;
    fast_buffers owned = {0};
    static const fast_counters zero = {0};
    /* The uploads, the samples and the readbacks of the counters and the film: one
     * submission (issue 44). */
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status == PF_OK)
        status = record_cascades(ctx, cmds, cache, &plan->layout, err);
    if (status == PF_OK)
        status = pf_render_buffer_recorded(ctx, cmds, "frame parameters", &params, sizeof params,
                                           sizeof params, &owned.params, err);
    if (status == PF_OK)
        status = pf_split_film_create(ctx, settings, 1, "fast", &owned.film, &owned.film_aov, err);
    if (status == PF_OK)
        status = pf_render_buffer_recorded(ctx, cmds, "fast counters", &zero, sizeof zero,
                                           sizeof zero, &owned.counters, err);
    if (status == PF_OK)
        status = pf_render_buffer_recorded(ctx, cmds, "empty photon grid", NULL, 0, 16,
                                           &owned.empty_grid, err);
    fast_push push = {0};
    push.loop_sentinel = 1;
    push.lpv_damping = settings->lpv.undamped ? 0u : 1u;
    push.cascade_count = cache->layout.count;
    push.lpv_size = cache->layout.size;
    int weighed = 0;
    if (status == PF_OK)
        status = record_energy(ctx, cmds, cache, settings, &owned, &push, &weighed, err);
    pf_vk_buffer *records = owned.empty_grid, *flux = owned.empty_grid;
    pf_vk_buffer *ranges = owned.empty_grid;
    if (cache->caustic) {
        pf_photon_grid_info info = pf_photon_grid_get_info(cache->caustic);
        pf_photon_grid_view view = pf_photon_grid_view_get(cache->caustic);
        push.grid = pf_photon_grid_push_of(&info);
        push.grid_photons = info.photon_count;
        push.radius = cache->caustic_radius;
        push.flux_scale = cache->caustic_flux_scale;
        records = view.records;
        flux = view.flux;
        ranges = view.ranges;
    }
    pf_vk_buffer *own[] = {owned.film,       owned.film_aov,
                           owned.counters,   bih->nodes,
                           bih->vertices,    bih->triangle_index,
                           pf_lpv_accumulated(cache->lpv), cache->cascades,
                           records,          ranges,
                           pf_lpv_far_fields(cache->lpv),  pf_lpv_geometry(cache->lpv),
                           flux,             owned.energy,
                           owned.energy_samples};
    pf_vk_buffer *buffers[PF_FAST_BUFFERS];
    pf_gpu_scene_bindings(scene, owned.params, own, sizeof own / sizeof *own, buffers);
    /* The kernel with the caustic estimate only for a frame with caustic photons. */
    pf_vk_pipeline *kernel = NULL;
    if (status == PF_OK)
        status = pf_renderer_pipeline(
            renderer, push.grid_photons > 0 ? PF_PIPELINE_FAST_CAUSTIC : PF_PIPELINE_FAST, &kernel,
            err);
    pf_vk_pipeline *weigh = NULL;
    if (status == PF_OK && weighed)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FAST_ENERGY, &weigh, err);
    uint32_t groups_x = (settings->width + GROUP_EDGE - 1) / GROUP_EDGE;
    uint32_t groups_y = (settings->height + GROUP_EDGE - 1) / GROUP_EDGE;
    int begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK && weighed) {
        status = pf_vk_cmd_dispatch(cmds, weigh, buffers, PF_FAST_BUFFERS, &push, sizeof push,
                                    (FAST_ENERGY_SAMPLES + GROUP_EDGE * GROUP_EDGE - 1) /
                                        (GROUP_EDGE * GROUP_EDGE),
                                    1, 1, err);
        pf_vk_cmd_barrier(cmds);
    }
    for (uint32_t s = 0; status == PF_OK && s < samples; s++) {
        push.sample_index = s;
        status = pf_vk_cmd_dispatch(cmds, kernel, buffers, PF_FAST_BUFFERS,
                                    &push, sizeof push, groups_x, groups_y, 1, err);
        pf_vk_cmd_barrier(cmds);
    }
    fast_counters counters;
    fast_energy energy = {0};
    pf_split_film_readback readback = {0};
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, owned.counters, 0, &counters, sizeof counters, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, owned.energy, 0, &energy, sizeof energy, err);
    /* The film's split into the image's channels is the stage's device work too. */
    if (status == PF_OK)
        status = pf_split_film_record_read(renderer, cmds, owned.film, owned.film_aov,
                                           settings->aovs, 1, image, &readback, err);
    int end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_split_film_submit(renderer, cmds, &readback, err);
    if (status == PF_OK)
        progress->shade_gpu_ms = pf_commands_gpu_ms(cmds, begin, end);
    pf_vk_commands_destroy(cmds);
    if (status == PF_OK) {
        progress->samples = samples;
        progress->rays = ((uint64_t)counters.rays_high << 32) | counters.rays_low;
        progress->discarded = counters.discarded_samples;
        progress->truncated = counters.loop_truncated;
        progress->failures = counters.traversal_failures;
        progress->lpv_outside = counters.lpv_outside;
        for (uint32_t d = 0; d < PF_PHOTON_ARRIVAL_DIRECTIONS; d++)
            progress->lpv_direction_delivered[d] =
                ((double)energy.delivered[2 * d + 1] * 4294967296.0 + energy.delivered[2 * d]) /
                FAST_ENERGY_UNITS;
    }
    pf_split_film_finish_read(&readback);
    fast_buffers_release(ctx, &owned);
    return status;
}

static void report_rows(pf_frame_report *report, const struct pf_fast_cache *cache,
                        const pf_stage_plan *plan, const fast_progress *progress,
                        double shade_ms, uint64_t pixels, const pf_scene_frame *frame)
{
    const pf_lpv_layout *layout = &cache->layout;
    pf_stage_timing *row = pf_stage_row(report, plan, PF_STAGE_PHOTON_TRACE, progress->trace_ms,
                                        cache->trace_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "photons", cache->emitted);
        pf_stage_add_counter(row, "vpls", cache->vpl_count);
        pf_stage_add_counter(row, "caustic_photons", cache->caustic_count);
        if (progress->photon_waves) {
            pf_stage_add_counter(row, "waves", progress->photon_waves);
            pf_stage_add_counter(row, "host_trace_ms", progress->photon_host_ms);
        }
    }
    /* The plan traced for a caustic map; the photons found no mirror or glass. */
    if (plan->stages[PF_STAGE_CAUSTIC_MAP].action == PF_STAGE_RUN && cache->caustic_count == 0)
        row = pf_frame_report_row(report, "caustic_map",
                                  "no light reaches a mirror or glass surface → no caustic map",
                                  progress->caustic_ms, -1.0);
    else
        row = pf_stage_row(report, plan, PF_STAGE_CAUSTIC_MAP, progress->caustic_ms, -1.0);
    if (row) {
        pf_stage_add_counter(row, "photons", cache->caustic ? cache->caustic_count : 0);
        pf_stage_add_counter(row, "radius", cache->caustic ? cache->caustic_radius : 0.0);
    }
    row = pf_stage_row(report, plan, PF_STAGE_LPV_GEOMETRY, progress->geometry_ms, -1.0);
    uint64_t cells = (uint64_t)layout->size * layout->size * layout->size;
    if (row) {
        pf_stage_add_counter(row, "cascades", layout->count);
        pf_stage_add_counter(row, "cells", (double)(cells * layout->count));
        pf_stage_add_counter(row, "triangle_pieces", (double)cache->geometry_pieces);
        pf_stage_add_counter(row, "finest_cell_m", layout->cascades[0].cell_size);
        pf_stage_add_counter(row, "scene_covered", layout->covers_scene);
    }
    row = pf_stage_row(report, plan, PF_STAGE_LPV_INJECT, progress->inject_ms,
                       progress->inject_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "vpls", cache->vpl_count);
        pf_stage_add_counter(row, "on_device", cache->injected_on_device);
        pf_stage_add_counter(row, "outside", cache->inject_stats.outside);
        for (uint32_t k = 0; k < layout->count && row->counter_count < PF_STAGE_COUNTERS_MAX;
             k++) {
            char name[32];
            snprintf(name, sizeof name, "vpls_cascade%u", k);
            pf_stage_add_counter(row, name, cache->inject_stats.injected[k]);
        }
    }
    row = pf_stage_row(report, plan, PF_STAGE_LPV_PROPAGATE, progress->propagate_ms,
                       progress->propagate_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "cascades", layout->count);
        pf_stage_add_counter(row, "cells_per_cascade", (double)cells);
        pf_stage_add_counter(row, "on_host", progress->propagate_on_host);
        for (uint32_t k = 0; k < layout->count && row->counter_count < PF_STAGE_COUNTERS_MAX;
             k++) {
            char name[32];
            snprintf(name, sizeof name, "iterations_cascade%u", k);
            pf_stage_add_counter(row, name, layout->cascades[k].iterations);
        }
        /* Where the device time went, cascade by cascade (issue 44). */
        for (uint32_t k = 0; k < layout->count && progress->propagate_gpu_ms >= 0.0 &&
                             row->counter_count + PF_STAGE_TRAFFIC_COUNTERS <
                                 PF_STAGE_COUNTERS_MAX;
             k++) {
            char name[32];
            snprintf(name, sizeof name, "gpu_ms_cascade%u", k);
            pf_stage_add_counter(row, name, progress->propagate_cascade_gpu_ms[k]);
        }
    }
    row = pf_stage_row(report, plan, PF_STAGE_SHADE, shade_ms, progress->shade_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "samples_per_pixel", progress->samples);
        pf_stage_add_counter(row, "paths", (double)pixels * progress->samples);
        pf_stage_add_counter(row, "rays", (double)progress->rays);
        pf_stage_add_light_samples(row, frame->light_count, PF_DIRECT_LIGHT_PIXEL_SAMPLES);
        pf_stage_add_counter(row, "discarded_samples", (double)progress->discarded);
        pf_stage_add_counter(row, "loop_truncated", (double)progress->truncated);
        pf_stage_add_counter(row, "lpv_outside", (double)progress->lpv_outside);
        /* The scales fast_shade.glsl gave the LPV (1: not weighed): the whole scene's, and
         * each direction's (the whole's where the LPV delivers nothing facing that way). */
        double arrivals = 0.0, delivered = 0.0;
        for (uint32_t d = 0; d < PF_PHOTON_ARRIVAL_DIRECTIONS; d++) {
            arrivals += cache->arrival_direction_flux[d];
            delivered += progress->lpv_direction_delivered[d];
        }
        double scale = energy_scale(arrivals, delivered, 1.0);
        pf_stage_add_counter(row, "lpv_energy_scale", scale);
        static const char *const directions[PF_PHOTON_ARRIVAL_DIRECTIONS] = {
            "lpv_scale_px", "lpv_scale_nx", "lpv_scale_py",
            "lpv_scale_ny", "lpv_scale_pz", "lpv_scale_nz"};
        for (uint32_t d = 0; d < PF_PHOTON_ARRIVAL_DIRECTIONS && delivered > 0.0;
             d++)
            pf_stage_add_counter(row, directions[d],
                                 energy_scale(cache->arrival_direction_flux[d],
                                              progress->lpv_direction_delivered[d], scale));
    }
    if (report)
        report->discarded_samples += progress->discarded;
}

void pf_renderer_set_lpv_site(pf_renderer *renderer, pf_lpv_site site)
{
    renderer->lpv_site = site;
    /* The kept injection is where the old site read it: the next frame runs every stage. */
    pf_stage_forget(&renderer->stage_memory[PF_QUALITY_FAST]);
}

/* The frame's state between its stages (pf_frame_run.state). */
typedef struct fast_frame {
    pf_photon_frame inputs;
    int inputs_ready;
    fast_progress progress;
    double start_ms;        /* after the BIH: the shade row gets what the other stages leave */
    pf_photon_maps maps;    /* traced, until the caustic map is built from them */
    int maps_held;
} fast_frame;

static void fast_frame_free(pf_vk_context *ctx, fast_frame *f)
{
    if (f->maps_held)
        pf_photon_maps_release(ctx, &f->maps);
    if (f->inputs_ready)
        pf_photon_frame_release(ctx, &f->inputs);
    free(f);
}

/* The pipeline, the scene upload, and what the plan drops from the cache. */
static pf_status fast_begin(pf_frame_run *run, pf_error *err)
{
    pf_renderer *renderer = run->renderer;
    const pf_render_settings *settings = run->settings;
    const pf_stage_plan *plan = run->plan;
    pf_stage_memory *memory = &renderer->stage_memory[PF_QUALITY_FAST];
    pf_status status = PF_OK;
    if (!renderer->fast_cache) {
        renderer->fast_cache = calloc(1, sizeof *renderer->fast_cache);
        if (!renderer->fast_cache)
            status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory");
    }
    fast_frame *f = status == PF_OK ? calloc(1, sizeof *f) : NULL;
    if (status == PF_OK && !f)
        status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory");
    if (status != PF_OK)
        return status;
    struct pf_fast_cache *cache = renderer->fast_cache;
    f->start_ms = pf_time_ms();
    f->progress.shade_gpu_ms = f->progress.propagate_gpu_ms = f->progress.inject_gpu_ms = -1.0;
    status = pf_split_image_create(run->image, settings->width, settings->height, settings->aovs,
                                   settings->later_layers, err);
    if (status == PF_OK)
        status = pf_photon_frame_prepare(renderer, run->frame, &plan->emitters, &f->inputs, err);
    f->inputs_ready = status == PF_OK;
    pf_stage_action trace = plan->stages[PF_STAGE_PHOTON_TRACE].action;
    if (trace != PF_STAGE_REUSE) {
        /* Traced anew or not at all: the kept VPLs and caustic grid no longer hold. */
        memory->valid[PF_STAGE_PHOTON_TRACE] = memory->valid[PF_STAGE_CAUSTIC_MAP] = 0;
        pf_render_buffer_release(renderer->ctx, &cache->vpls);
        cache->vpl_count = cache->emitted = cache->caustic_count = 0;
        if (plan->stages[PF_STAGE_CAUSTIC_MAP].action != PF_STAGE_RUN) {
            pf_photon_grid_destroy(cache->caustic);
            cache->caustic = NULL;
        }
    }
    const pf_lpv_layout *layout = &plan->layout;
    if (!layout->covers_scene)
        pf_log(PF_LOG_WARN,
               "fast: the coarsest LPV cascade (%u cells of %g m around the camera's focus) "
               "does not hold the whole scene: surfaces outside it get no indirect light",
               layout->size, (double)layout->cascades[layout->count - 1].cell_size);
    if (status == PF_OK && !cache->lpv)
        status = pf_lpv_create(renderer->ctx, &cache->lpv, err);
    if (status == PF_OK)
        pf_lpv_set_site(cache->lpv, renderer->lpv_site);
    cache->layout = *layout;
    if (status != PF_OK) {
        pf_stage_forget(memory);
        pf_image_free(run->image);
        fast_frame_free(renderer->ctx, f);
        pf_error_prefix(err, "fast render (%ux%u, %u triangles)", settings->width,
                        settings->height, run->frame->triangle_count);
        return status;
    }
    run->state = f;
    return PF_OK;
}

/* One planned stage; each remembers, once done, what its output was made from. */
static pf_status fast_run(pf_frame_run *run, pf_stage_id stage, uint32_t pass, pf_error *err)
{
    (void)pass;
    fast_frame *f = run->state;
    pf_renderer *renderer = run->renderer;
    struct pf_fast_cache *cache = renderer->fast_cache;
    const pf_stage_plan *plan = run->plan;
    pf_stage_memory *memory = &renderer->stage_memory[PF_QUALITY_FAST];
    pf_status status = PF_OK;
    if (stage != PF_STAGE_SHADE)
        memory->valid[stage] = 0;
    switch (stage) {
    case PF_STAGE_PHOTON_TRACE:
        status = trace_photons(cache, &f->inputs, run->frame, run->settings, plan, renderer,
                               &f->maps, &f->progress, err);
        f->maps_held = status == PF_OK;
        /* Without a caustic stage the caustic photons are not wanted. */
        if (f->maps_held && plan->stages[PF_STAGE_CAUSTIC_MAP].action != PF_STAGE_RUN) {
            pf_photon_maps_release(renderer->ctx, &f->maps);
            f->maps_held = 0;
        }
        break;
    case PF_STAGE_CAUSTIC_MAP:
        if (f->maps_held) {
            status = build_caustic_map(renderer->ctx, cache, run->frame, &f->maps, &f->progress,
                                       err);
            pf_photon_maps_release(renderer->ctx, &f->maps);
            f->maps_held = 0;
        }
        break;
    case PF_STAGE_LPV_GEOMETRY:
        status = build_geometry_volume(cache, run->frame, &plan->layout, &f->progress, err);
        break;
    case PF_STAGE_LPV_INJECT:
        status = inject_vpls(renderer->ctx, cache, &plan->layout, &f->progress, err);
        break;
    case PF_STAGE_LPV_PROPAGATE:
        status = propagate(cache, &plan->layout, &f->progress, err);
        break;
    case PF_STAGE_SHADE:
        return shade(renderer, cache, run->frame, run->settings, plan, &f->inputs.scene,
                     &f->inputs.bih, run->image, &f->progress, err);
    default:
        return pf_error_set(err, PF_ERR_INTERNAL, "fast has no stage %s", pf_stage_name(stage));
    }
    if (status == PF_OK)
        pf_stage_remember(memory, plan, stage);
    return status;
}

/* The frame's checks and rows; on failure nothing kept is trusted. */
static pf_status fast_end(pf_frame_run *run, pf_status status, pf_error *err)
{
    fast_frame *f = run->state;
    pf_renderer *renderer = run->renderer;
    const pf_render_settings *settings = run->settings;
    fast_progress progress = f->progress;
    double elapsed = pf_time_ms() - f->start_ms;
    fast_frame_free(renderer->ctx, f);
    run->state = NULL;
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    if (status == PF_OK)
        status = pf_render_check_traversal(renderer, progress.failures, err);
    if (status == PF_OK &&
        (double)progress.truncated > FAST_TRUNCATED_LIMIT * (double)pixels * progress.samples)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%llu of %llu samples stopped at the loop cap (this device ends "
                              "an invocation's loops after 65,535 iterations: a caustic estimate "
                              "met more photons than one invocation may visit)",
                              (unsigned long long)progress.truncated,
                              (unsigned long long)(pixels * progress.samples));
    if (status != PF_OK) {
        pf_stage_forget(&renderer->stage_memory[PF_QUALITY_FAST]);
        pf_image_free(run->image);
        pf_error_prefix(err, "fast render (%ux%u, %u triangles)", settings->width,
                        settings->height, run->frame->triangle_count);
        return status;
    }
    double shade_ms = elapsed - progress.trace_ms - progress.caustic_ms - progress.geometry_ms -
                      progress.inject_ms - progress.propagate_ms;
    report_rows(run->report, renderer->fast_cache, run->plan, &progress,
                shade_ms > 0.0 ? shade_ms : 0.0, pixels, run->frame);
    return PF_OK;
}

/* fast renders every stage once per frame. */
const pf_integrator pf_integrator_fast = {0, fast_begin, fast_run, fast_end};
