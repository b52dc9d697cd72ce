/*
 * The `fast` integrator (issue 11): direct light by next-event estimation,
 * diffuse indirect light from cascaded light propagation volumes, caustics
 * from a caustic photon map. Host side of shaders/render_fast.comp.
 *
 * Stages, in order (each a row, skipped ones with their reason):
 *   bih_build      the frame's BIH (frame_bih.c)
 *   photon_trace   one photon pass (settings->photons_per_pass, default
 *                  FAST_DEFAULT_PHOTONS) whose global map keeps every
 *                  diffuse hit with the flux the surface reflects: these
 *                  are the virtual point lights, so the LPV carries every
 *                  bounce of indirect light, not only the first
 *   caustic_map    the caustic photons (L S+ D) gridded for a k-nearest
 *                  estimate, only when some light reaches a mirror or glass
 *   lpv_geometry   the geometry volume of the frame's triangles (core/lpv)
 *   lpv_inject     the VPLs into every cascade
 *   lpv_propagate  each cascade's iterations on the device
 *   shade          samples_per_pixel (default FAST_DEFAULT_SAMPLES) camera
 *                  samples per pixel
 *
 * Reuse (renderer->fast_cache): the VPLs and the caustic grid when the BIH
 * stage reused the tree right after the frame that made them and lights,
 * materials, seed and photon count are equal (as final's photon passes);
 * the geometry volume when the geometry and the cascade layout are
 * unchanged; the injected volume when the VPLs and the layout are; the
 * propagation when neither input changed and the iterations are equal.
 * The cascade layout follows the camera only through its snapped origins,
 * so a camera that moves within a cell reuses everything.
 */
#include "pf_lpv.h"
#include "pf_photon.h"
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/*
 * Camera samples per pixel: the direct light's one light sample per camera
 * sample is the noise of this preset (the LPV is smooth). Measured on the
 * Cornell box at 160×120 against a 512-spp reference: relMSE 0.035, 0.016,
 * 0.011 at 1, 2, 4 spp (preview: 0.062), at 0.45, 0.95, 1.9 s of shading
 * per 640×480 frame on lavapipe. 2 keeps the error well under a third of
 * preview's at half the cost of 4.
 */
#define FAST_DEFAULT_SAMPLES 2u
/*
 * Photons per frame: the LPV averages a cell's VPLs, so a few tens of
 * thousands suffice (the Kaplanyan paper injects 128² = 16k VPLs per
 * cascade); this count costs well under a second on lavapipe.
 */
#define FAST_DEFAULT_PHOTONS 32768u
/* Photons in the caustic estimate's largest disc at the VPLs' mean density (as final's r_1). */
#define FAST_CAUSTIC_NEIGHBOURS 20.0
#define FAST_MAX_SPECULAR_DEPTH 8u
#define FAST_BUFFERS 19u
#define GROUP_EDGE 8u
/* A frame fails when more than this fraction of its samples hit the loop cap (as final). */
#define FAST_TRUNCATED_LIMIT 0.01

/* render_fast.comp's Push (72 bytes). */
typedef struct fast_push {
    float grid_origin[3];
    float grid_inv_cell;
    uint32_t grid_dims[3];
    uint32_t grid_hashed;
    uint32_t grid_table_size;
    uint32_t grid_photons;
    uint32_t sample_index;
    uint32_t cascade_count;
    uint32_t lpv_size;
    float radius;
    float flux_scale;
    uint32_t loop_sentinel;
    uint32_t lpv_damping;
    uint32_t padding;
} fast_push;

_Static_assert(sizeof(fast_push) == 72, "fast_push must match render_fast.comp's Push");

typedef struct fast_counters {
    uint32_t discarded_samples;
    uint32_t traversal_failures;
    uint32_t rays_low, rays_high;
    uint32_t loop_truncated;
    uint32_t lpv_outside;
} fast_counters;

struct pf_fast_cache {
    /* Photons: the VPLs and the caustic grid, and what they were traced for. */
    pf_photon_identity identity;
    pf_lpv_vpl *vpls;
    uint32_t vpl_count;
    uint32_t emitted, caustic_count;
    pf_photon_grid *caustic;      /* NULL: no caustic map */
    float caustic_radius, caustic_flux_scale;
    double trace_gpu_ms;
    /* LPV: the layout and volumes of the last frame. */
    pf_lpv *lpv;
    pf_lpv_layout layout;
    int geometry_valid, injected_valid, propagated_valid;
    float *geometry, *injected;
    pf_lpv_inject_stats inject_stats;
    uint64_t geometry_pieces;
    pf_vk_buffer *cascades;       /* vec4 per cascade: origin, cell size */
};

void pf_fast_cache_destroy(pf_vk_context *ctx, struct pf_fast_cache *cache)
{
    if (!cache)
        return;
    pf_photon_identity_free(&cache->identity);
    free(cache->vpls);
    free(cache->geometry);
    free(cache->injected);
    pf_photon_grid_destroy(cache->caustic);
    pf_render_buffer_release(ctx, &cache->cascades);
    pf_lpv_destroy(cache->lpv);
    free(cache);
}

/* Frame-wide figures for the rows. */
typedef struct fast_progress {
    int has_emitters, has_specular, traced;
    double trace_ms, caustic_ms, geometry_ms, inject_ms, propagate_ms, propagate_gpu_ms;
    int geometry_built, injected, propagated;
    uint32_t samples;
    uint64_t rays, discarded, truncated, failures, lpv_outside;
    double shade_gpu_ms;
} fast_progress;

/* Traces the frame's photons: VPLs (every diffuse hit, reflected flux) and the caustic grid. */
static pf_status trace_photons(pf_renderer *renderer, struct pf_fast_cache *cache,
                               const pf_photon_frame *inputs, const pf_scene_frame *frame,
                               const pf_render_settings *settings, uint32_t photons,
                               fast_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    double start = pf_time_ms();
    pf_photon_trace_settings trace = {.photon_count = photons,
                                      .seed = settings->seed,
                                      .store_direct = 1,
                                      .global_reflected = 1};
    pf_photon_maps maps = {0};
    pf_status status = pf_photon_trace(inputs->tracer, &inputs->photons, &inputs->emitters,
                                       &trace, &maps, err);
    if (status != PF_OK)
        return status;
    cache->trace_gpu_ms = maps.gpu_ms;
    if (maps.traversal_failures > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%u photons overflowed the BIH traversal stack",
                              maps.traversal_failures);
    pf_photon *photons_host = NULL;
    if (status == PF_OK)
        status = pf_photon_map_download(ctx, maps.global, maps.global_count, &photons_host, err);
    free(cache->vpls);
    cache->vpls = NULL;
    cache->vpl_count = 0;
    if (status == PF_OK && maps.global_count > 0) {
        cache->vpls = malloc((size_t)maps.global_count * sizeof *cache->vpls);
        if (!cache->vpls)
            status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory for %u VPLs",
                                  maps.global_count);
    }
    for (uint32_t i = 0; status == PF_OK && i < maps.global_count; i++) {
        pf_lpv_vpl *vpl = &cache->vpls[i];
        float incoming[3];
        pf_photon_unpack(&photons_host[i], vpl->position, vpl->flux, incoming, vpl->normal);
        for (int c = 0; c < 3; c++)
            vpl->flux[c] *= maps.flux_scale;
    }
    free(photons_host);
    if (status == PF_OK)
        cache->vpl_count = maps.global_count;
    cache->emitted = maps.emitted;
    progress->trace_ms += pf_time_ms() - start;
    start = pf_time_ms();
    cache->caustic_count = progress->has_specular && status == PF_OK ? maps.caustic_count : 0;
    cache->caustic_flux_scale = maps.flux_scale;
    cache->caustic_radius = pf_photon_radius_for_density(frame, FAST_CAUSTIC_NEIGHBOURS,
                                                         maps.global_count, 0.01);
    if (status == PF_OK && cache->caustic_count > 0) {
        if (!cache->caustic)
            status = pf_photon_grid_create(ctx, &cache->caustic, err);
        if (status == PF_OK)
            status = pf_photon_grid_build_device(cache->caustic, maps.caustic, maps.caustic_count,
                                                 frame->bounds_min, frame->bounds_max,
                                                 cache->caustic_radius, err);
    } else {
        pf_photon_grid_destroy(cache->caustic);
        cache->caustic = NULL;
    }
    progress->caustic_ms += pf_time_ms() - start;
    pf_photon_maps_release(ctx, &maps);
    if (status != PF_OK)
        pf_error_prefix(err, "photon pass (%u photons)", photons);
    return status;
}

static int same_shape(const pf_lpv_layout *a, const pf_lpv_layout *b)
{
    return a->count == b->count && a->size == b->size;
}

static int same_cascades(const pf_lpv_layout *a, const pf_lpv_layout *b)
{
    if (!same_shape(a, b) || a->offset_cells != b->offset_cells)
        return 0;
    for (uint32_t k = 0; k < a->count; k++) {
        if (a->cascades[k].cell_size != b->cascades[k].cell_size ||
            memcmp(a->cascades[k].origin_cell, b->cascades[k].origin_cell,
                   sizeof a->cascades[k].origin_cell))
            return 0;
    }
    return 1;
}

static int same_iterations(const pf_lpv_layout *a, const pf_lpv_layout *b)
{
    for (uint32_t k = 0; k < a->count; k++) {
        if (a->cascades[k].iterations != b->cascades[k].iterations)
            return 0;
    }
    return 1;
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

/* The LPV stages: geometry volume, injection, propagation, each only when its inputs changed. */
static pf_status run_lpv(pf_renderer *renderer, struct pf_fast_cache *cache,
                         const pf_scene_frame *frame, const pf_lpv_layout *layout,
                         int geometry_changed, int vpls_changed, fast_progress *progress,
                         pf_error *err)
{
    pf_status status = PF_OK;
    int cascades_moved = !same_cascades(&cache->layout, layout);
    uint64_t sh_floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    uint64_t gv_floats = pf_lpv_volume_floats(layout, PF_LPV_GV_FLOATS_PER_CELL);
    if (!cache->lpv)
        status = pf_lpv_create(renderer->ctx, &cache->lpv, err);
    if (status == PF_OK && (!cache->geometry_valid || geometry_changed || cascades_moved)) {
        double start = pf_time_ms();
        cache->geometry_valid = 0;
        status = ensure_host_volume(&cache->geometry, gv_floats, err);
        if (status == PF_OK) {
            cache->geometry_pieces = pf_lpv_geometry_build(layout, frame, cache->geometry);
            cache->geometry_valid = 1;
            progress->geometry_built = 1;
        }
        progress->geometry_ms = pf_time_ms() - start;
    }
    if (status == PF_OK && (!cache->injected_valid || vpls_changed || cascades_moved)) {
        double start = pf_time_ms();
        cache->injected_valid = 0;
        status = ensure_host_volume(&cache->injected, sh_floats, err);
        if (status == PF_OK) {
            memset(cache->injected, 0, sh_floats * sizeof *cache->injected);
            pf_lpv_inject(layout, cache->vpls, cache->vpl_count, cache->injected,
                          &cache->inject_stats);
            cache->injected_valid = 1;
            progress->injected = 1;
        }
        progress->inject_ms = pf_time_ms() - start;
    }
    if (status == PF_OK && (!cache->propagated_valid || progress->geometry_built ||
                            progress->injected || !same_iterations(&cache->layout, layout))) {
        double start = pf_time_ms();
        cache->propagated_valid = 0;
        pf_lpv_propagate_stats stats;
        status = pf_lpv_propagate(cache->lpv, layout, cache->injected, cache->geometry, &stats,
                                  err);
        progress->propagate_gpu_ms = stats.gpu_ms;
        if (status == PF_OK) {
            cache->propagated_valid = 1;
            progress->propagated = 1;
        }
        progress->propagate_ms = pf_time_ms() - start;
    }
    float cascades[PF_LPV_MAX_CASCADES][4];
    for (uint32_t k = 0; k < layout->count; k++) {
        memcpy(cascades[k], layout->cascades[k].origin, 3 * sizeof(float));
        cascades[k][3] = layout->cascades[k].cell_size;
    }
    if (status == PF_OK && !cache->cascades)
        status = pf_vk_buffer_create(renderer->ctx, sizeof cascades, "LPV cascades",
                                     &cache->cascades, err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(renderer->ctx, cache->cascades, 0, cascades,
                                     layout->count * sizeof cascades[0], err);
    cache->layout = *layout;
    return status;
}

/* Device buffers of one frame's shading; every pointer NULL or owned. */
typedef struct fast_buffers {
    pf_vk_buffer *params, *film, *film_aov, *counters, *empty_grid;
} fast_buffers;

static void fast_buffers_release(pf_vk_context *ctx, fast_buffers *b)
{
    pf_vk_buffer **all[] = {&b->params, &b->film, &b->film_aov, &b->counters, &b->empty_grid};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        pf_render_buffer_release(ctx, all[i]);
}

/* The shade stage: samples dispatches of render_fast.comp into the split film, then the image. */
static pf_status shade(pf_renderer *renderer, struct pf_fast_cache *cache,
                       const pf_scene_frame *frame, const pf_render_settings *settings,
                       const pf_gpu_scene *scene, const pf_bih_gpu_view *bih, pf_image *image,
                       fast_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    uint32_t samples = settings->samples_per_pixel ? settings->samples_per_pixel
                                                   : FAST_DEFAULT_SAMPLES;
    pf_frame_params params;
    pf_frame_params_fill(frame, settings, samples, scene, bih, &params);
    params.max_specular_depth = FAST_MAX_SPECULAR_DEPTH;
    fast_buffers owned = {0};
    pf_status status = PF_OK;
    const fast_counters zero = {0};
    if (status == PF_OK)
        status = pf_render_buffer_with_data(ctx, "frame parameters", &params, sizeof params,
                                            sizeof params, &owned.params, err);
    if (status == PF_OK)
        status = pf_split_film_create(ctx, settings, 1, "fast", &owned.film, &owned.film_aov, err);
    if (status == PF_OK)
        status = pf_render_buffer_with_data(ctx, "fast counters", &zero, sizeof zero, sizeof zero,
                                            &owned.counters, err);
    if (status == PF_OK)
        status = pf_render_buffer_with_data(ctx, "empty photon grid", NULL, 0, 16,
                                            &owned.empty_grid, err);
    fast_push push = {0};
    push.loop_sentinel = 1;
    push.lpv_damping = settings->lpv.undamped ? 0u : 1u;
    push.cascade_count = cache->layout.count;
    push.lpv_size = cache->layout.size;
    pf_vk_buffer *words = owned.empty_grid, *ranges = owned.empty_grid;
    if (cache->caustic) {
        pf_photon_grid_info info = pf_photon_grid_get_info(cache->caustic);
        pf_photon_grid_view view = pf_photon_grid_view_get(cache->caustic);
        memcpy(push.grid_origin, info.origin, sizeof push.grid_origin);
        push.grid_inv_cell = 1.0f / info.cell_size;
        memcpy(push.grid_dims, info.dims, sizeof push.grid_dims);
        push.grid_hashed = info.hashed;
        push.grid_table_size = info.table_size;
        push.grid_photons = info.photon_count;
        push.radius = cache->caustic_radius;
        push.flux_scale = cache->caustic_flux_scale;
        words = view.photons;
        ranges = view.ranges;
    }
    pf_vk_buffer *buffers[FAST_BUFFERS] = {
        owned.params,    scene->vertices, scene->normals,   scene->triangle_material,
        scene->materials, scene->lights,  scene->emissive,  owned.film,
        owned.film_aov,  owned.counters,  bih->nodes,       bih->vertices,
        bih->triangle_index, pf_lpv_accumulated(cache->lpv), cache->cascades, words,
        ranges, pf_lpv_snapshots(cache->lpv), pf_lpv_geometry(cache->lpv)};
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    uint32_t groups_x = (settings->width + GROUP_EDGE - 1) / GROUP_EDGE;
    uint32_t groups_y = (settings->height + GROUP_EDGE - 1) / GROUP_EDGE;
    int begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    for (uint32_t s = 0; status == PF_OK && s < samples; s++) {
        push.sample_index = s;
        status = pf_vk_cmd_dispatch(cmds, renderer->render_fast, buffers, FAST_BUFFERS, &push,
                                    sizeof push, groups_x, groups_y, 1, err);
        pf_vk_cmd_barrier(cmds);
    }
    int end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK && begin >= 0 && end >= 0)
        progress->shade_gpu_ms = pf_vk_commands_elapsed_ms(cmds, begin, end);
    pf_vk_commands_destroy(cmds);
    fast_counters counters;
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, owned.counters, 0, &counters, sizeof counters, err);
    if (status == PF_OK) {
        progress->samples = samples;
        progress->rays = ((uint64_t)counters.rays_high << 32) | counters.rays_low;
        progress->discarded = counters.discarded_samples;
        progress->truncated = counters.loop_truncated;
        progress->failures = counters.traversal_failures;
        progress->lpv_outside = counters.lpv_outside;
    }
    if (status == PF_OK)
        status = pf_split_film_read(ctx, owned.film, owned.film_aov, settings->aovs, 1, image, err);
    fast_buffers_release(ctx, &owned);
    return status;
}

static void report_rows(pf_frame_report *report, const struct pf_fast_cache *cache,
                        const fast_progress *progress, double shade_ms, uint64_t pixels)
{
    const char *no_light = "no lights or emissive surfaces → no photons, no LPV light";
    const pf_lpv_layout *layout = &cache->layout;
    pf_stage_timing *row = pf_frame_report_row(
        report, "photon_trace",
        !progress->has_emitters ? no_light
        : !progress->traced     ? "lights and geometry unchanged → VPLs and caustic map reused"
                                : NULL,
        progress->trace_ms, progress->traced ? cache->trace_gpu_ms : -1.0);
    if (row) {
        pf_stage_add_counter(row, "photons", cache->emitted);
        pf_stage_add_counter(row, "vpls", cache->vpl_count);
        pf_stage_add_counter(row, "caustic_photons", cache->caustic_count);
    }
    const char *caustic_skip =
        !progress->has_specular ? "no specular or refractive material → no caustic map"
        : !progress->has_emitters ? no_light
        : cache->caustic_count == 0 ? "no light reaches a mirror or glass surface → no caustic map"
        : !progress->traced         ? "lights and geometry unchanged → caustic map reused"
                                    : NULL;
    row = pf_frame_report_row(report, "caustic_map", caustic_skip, progress->caustic_ms, -1.0);
    if (row) {
        pf_stage_add_counter(row, "photons", cache->caustic ? cache->caustic_count : 0);
        pf_stage_add_counter(row, "radius", cache->caustic ? cache->caustic_radius : 0.0);
    }
    row = pf_frame_report_row(report, "lpv_geometry",
                  progress->geometry_built ? NULL
                                           : "geometry and cascade origins unchanged → geometry "
                                             "volume reused",
                  progress->geometry_ms, -1.0);
    uint64_t cells = (uint64_t)layout->size * layout->size * layout->size;
    if (row) {
        pf_stage_add_counter(row, "cascades", layout->count);
        pf_stage_add_counter(row, "cells", (double)(cells * layout->count));
        pf_stage_add_counter(row, "triangle_pieces", (double)cache->geometry_pieces);
        pf_stage_add_counter(row, "finest_cell_m", layout->cascades[0].cell_size);
        pf_stage_add_counter(row, "scene_covered", layout->covers_scene);
    }
    row = pf_frame_report_row(report, "lpv_inject",
                  progress->injected ? NULL
                                     : "VPLs and cascade origins unchanged → injection reused",
                  progress->inject_ms, -1.0);
    if (row) {
        pf_stage_add_counter(row, "vpls", cache->vpl_count);
        pf_stage_add_counter(row, "outside", cache->inject_stats.outside);
        for (uint32_t k = 0; k < layout->count && row->counter_count < PF_STAGE_COUNTERS_MAX;
             k++) {
            char name[32];
            snprintf(name, sizeof name, "vpls_cascade%u", k);
            pf_stage_add_counter(row, name, cache->inject_stats.injected[k]);
        }
    }
    row = pf_frame_report_row(report, "lpv_propagate",
                  progress->propagated ? NULL
                                       : "lights, geometry and snapped cascade origins unchanged "
                                         "→ LPV reused",
                  progress->propagate_ms, progress->propagated ? progress->propagate_gpu_ms : -1.0);
    if (row) {
        pf_stage_add_counter(row, "cascades", layout->count);
        pf_stage_add_counter(row, "cells_per_cascade", (double)cells);
        for (uint32_t k = 0; k < layout->count && row->counter_count < PF_STAGE_COUNTERS_MAX;
             k++) {
            char name[32];
            snprintf(name, sizeof name, "iterations_cascade%u", k);
            pf_stage_add_counter(row, name, layout->cascades[k].iterations);
        }
    }
    row = pf_frame_report_row(report, "shade", NULL, shade_ms, progress->shade_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "samples_per_pixel", progress->samples);
        pf_stage_add_counter(row, "paths", (double)pixels * progress->samples);
        pf_stage_add_counter(row, "rays", (double)progress->rays);
        pf_stage_add_counter(row, "discarded_samples", (double)progress->discarded);
        pf_stage_add_counter(row, "loop_truncated", (double)progress->truncated);
        pf_stage_add_counter(row, "lpv_outside", (double)progress->lpv_outside);
    }
    if (report)
        report->discarded_samples += progress->discarded;
}

/* Everything of one frame after the BIH. */
static pf_status render_after_bih(pf_renderer *renderer, const pf_scene_frame *frame,
                                  const pf_render_settings *settings, int bih_reused,
                                  pf_image *image, fast_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    struct pf_fast_cache *cache = renderer->fast_cache;
    uint32_t photons = settings->photons_per_pass ? settings->photons_per_pass
                                                  : FAST_DEFAULT_PHOTONS;
    pf_photon_frame inputs;
    pf_status status = pf_photon_frame_prepare(renderer, frame, &inputs, err);
    if (status != PF_OK)
        return status;
    progress->has_emitters = inputs.emitters.count > 0;
    progress->has_specular = pf_scene_frame_has_specular(frame);
    int reuse = pf_photon_identity_matches(&cache->identity, renderer, frame, settings->seed,
                                           photons, 0, bih_reused);
    if (!reuse && progress->has_emitters) {
        cache->identity.valid = 0;
        status = trace_photons(renderer, cache, &inputs, frame, settings, photons, progress, err);
        progress->traced = 1;
    } else if (!reuse) {
        free(cache->vpls);
        cache->vpls = NULL;
        cache->vpl_count = cache->emitted = cache->caustic_count = 0;
        pf_photon_grid_destroy(cache->caustic);
        cache->caustic = NULL;
        progress->traced = 1;
    }
    pf_lpv_layout layout;
    if (status == PF_OK) {
        float focus[3];
        pf_lpv_focus(frame, focus);
        pf_lpv_layout_make(&settings->lpv, focus, settings->lpv.cell_size, frame, &layout);
        if (!layout.covers_scene)
            pf_log(PF_LOG_WARN,
                   "fast: the coarsest LPV cascade (%u cells of %g m around the camera's focus) "
                   "does not hold the whole scene: surfaces outside it get no indirect light",
                   layout.size, (double)layout.cascades[layout.count - 1].cell_size);
        status = run_lpv(renderer, cache, frame, &layout, !bih_reused, progress->traced, progress,
                         err);
    }
    if (status == PF_OK)
        status = shade(renderer, cache, frame, settings, &inputs.scene, &inputs.bih, image,
                       progress, err);
    pf_photon_frame_release(ctx, &inputs);
    if (status == PF_OK && progress->traced)
        status = pf_photon_identity_remember(&cache->identity, frame, settings->seed, photons, 0,
                                             err);
    if (status == PF_OK) {
        cache->identity.bih_frame = renderer->bih_frames;
        cache->identity.valid = 1;
    }
    return status;
}

pf_status pf_render_frame_fast(pf_renderer *renderer, const pf_scene_frame *frame,
                               const pf_render_settings *settings, pf_image *image,
                               pf_frame_report *report, pf_error *err)
{
    pf_lpv_setting which;
    pf_status status = pf_lpv_settings_check(
        &settings->lpv, pf_vk_info(renderer->ctx)->max_storage_buffer_range, &which, err);
    if (status != PF_OK)
        return status;
    if (!renderer->render_fast)
        status = pf_vk_pipeline_create_named(renderer->ctx, "render_fast", FAST_BUFFERS,
                                             sizeof(fast_push), NULL, 0, &renderer->render_fast,
                                             err);
    if (status == PF_OK && !renderer->fast_cache) {
        renderer->fast_cache = calloc(1, sizeof *renderer->fast_cache);
        if (!renderer->fast_cache)
            status = pf_error_set(err, PF_ERR_NOMEM, "fast: out of memory");
    }
    if (status == PF_OK)
        status = pf_split_image_create(image, settings->width, settings->height, settings->aovs,
                                       err);
    if (status != PF_OK)
        return status;
    int bih_reused = 0;
    status = pf_render_prepare_bih_reuse(renderer, frame, report, &bih_reused, err);
    double start = pf_time_ms();
    fast_progress progress = {0};
    progress.shade_gpu_ms = progress.propagate_gpu_ms = -1.0;
    if (status == PF_OK)
        status = render_after_bih(renderer, frame, settings, bih_reused, image, &progress, err);
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    if (status == PF_OK)
        status = pf_render_check_traversal(renderer, progress.failures, err);
    if (status == PF_OK &&
        (double)progress.truncated > FAST_TRUNCATED_LIMIT * (double)pixels * progress.samples)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%llu of %llu samples stopped at the loop cap (a caustic estimate "
                              "met more photons than one invocation may visit)",
                              (unsigned long long)progress.truncated,
                              (unsigned long long)(pixels * progress.samples));
    if (status != PF_OK) {
        struct pf_fast_cache *cache = renderer->fast_cache;
        cache->identity.valid = 0;
        cache->geometry_valid = cache->injected_valid = cache->propagated_valid = 0;
        pf_image_free(image);
        pf_error_prefix(err, "fast render (%ux%u, %u triangles)", settings->width,
                        settings->height, frame->triangle_count);
        return status;
    }
    double shade_ms = pf_time_ms() - start - progress.trace_ms - progress.caustic_ms -
                      progress.geometry_ms - progress.inject_ms - progress.propagate_ms;
    report_rows(report, renderer->fast_cache, &progress, shade_ms > 0.0 ? shade_ms : 0.0, pixels);
    return PF_OK;
}
