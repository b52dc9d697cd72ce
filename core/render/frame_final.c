/*
 * The `final` integrator: photon maps with final gather (issue 6). Host side
 * of shaders/render_final.comp, which documents the estimators and the
 * light-path split.
 *
 * Progressive passes. The issue asks for SPPM radius reduction (Hachisuka &
 * Jensen 2009, α = 2/3). This uses its probabilistic formulation (Knaus &
 * Zwicker 2011, "Progressive Photon Mapping: A Probabilistic Approach"):
 * pass i (1-based) traces a fresh photon set with its own seed, grids it at
 * radius r_i with
 *     r_{i+1}² = r_i² (i + α) / (i + 1),   α = 2/3,
 * renders one camera sample per pixel with it, and the frame is the mean of
 * the pass images. The passes' errors are independent, variance grows as the
 * radius shrinks and the bias falls with it, so the mean converges like
 * SPPM (MSE ∝ N^-2/3 at α = 2/3) without per-pixel photon statistics, and
 * the gather points may differ from pass to pass (they are the pass's
 * camera sample), which is what lets the passes also anti-alias.
 *
 * r_1: the radius holding FINAL_GLOBAL_NEIGHBOURS photons of the first
 * pass's global map at its mean density over the scene's surface area,
 * r_1² = K A / (π N_global). Caustics get a radius per pixel: the first
 * pass takes the k-nearest estimate (photon_irradiance_knn, bounded by r_1)
 * and keeps its radius; pass i uses that radius × r_i / r_1 at a fixed radius
 * (render_final.comp's caustic_radiance says why a k-nearest estimate in
 * every pass would not converge).
 *
 * Stage rows: photon_trace and photon_grid (one each per frame, totals over
 * the passes), caustic_map (the caustic grids; skipped without specular
 * materials), shade, run as the stage planner (stage_plan.c) decided them.
 * The stage loop calls the photon stages once a pass; the first pass to trace traces a
 * batch of them (FINAL_BATCH_PASSES) in one submission, grids them in one and their caustic
 * maps in one, and the batch's later passes find theirs made (issue 44: no host round trip
 * a pass). The pass images are those of the passes made one at a time.
 * Reuse: the passes' grids stay in the renderer (renderer->final_cache, up
 * to FINAL_KEPT_PASSES of them; the renderer's stage memory says what they
 * were made from); the next final frame reuses them as its first passes
 * while geometry, lights, materials, seed, photons per pass and photon depth
 * are equal, and traces only the passes beyond them.
 */
#include "pf_photon.h"
#include "render_internal.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/*
 * Gather rays per camera sample, and per dispatch (final_gather.comp's loop
 * cap budget). 4, not more: the image's error at a few passes is dominated
 * by the one direct-light sample per pass, and 8 rays doubled the shade
 * time for an indirect relMSE 0.0011 instead of 0.0022 (Cornell box, 8
 * passes, tests/render/test_final.c).
 */
#define FINAL_GATHER_RAYS 4u
#define FINAL_GATHER_RAYS_PER_DISPATCH 4u
/* Specular vertices a camera path follows to find D₁. */
#define FINAL_MAX_SPECULAR_DEPTH 8u
/* Knaus & Zwicker 2011 (and Hachisuka & Jensen 2009): α = 2/3. */
#define FINAL_ALPHA (2.0 / 3.0)
/* Photons in the first pass's gather disc at the global map's mean density. */
#define FINAL_GLOBAL_NEIGHBOURS 20.0
/* r_1 when the first pass stores nothing: this fraction of the scene's diagonal. */
#define FINAL_FALLBACK_RADIUS_FRACTION 0.01
/*
 * Precomputed irradiance (pf_photon_grid_build_irradiance: Christensen 1999)
 * serves the gather's lookups when it saves work and costs no accuracy that
 * shows. Work: its estimates (one per ~4 stored photons) and its grid must be
 * small beside the gather's estimates: at least FINAL_LOOKUP_MIN_RATIO
 * gather rays per pass for each stored photon (640x480 Cornell: 1.2M rays,
 * 184k photons; 96x72: 28k rays, 37k photons, where the precompute made the
 * frame 25 % slower). Accuracy: a lookup reads a point up to r away, so its
 * value is blurred over ~2r instead of r; once the photon maps' bias
 * dominates the image (many passes) that shows: bench/final's Cornell box,
 * lookups against estimates, relMSE +0.4 % at 4 passes, +1.6 % at 16,
 * +24 % at 64. So frames of at most FINAL_LOOKUP_MAX_PASSES passes.
 */
#define FINAL_LOOKUP_MIN_RATIO 2u
#define FINAL_LOOKUP_MAX_PASSES 16u
/* Passes whose grids are kept for reuse (memory: ~5 MB each at the default photons). */
#define FINAL_KEPT_PASSES 16u
/*
 * Passes traced, gridded and caustic-gridded together (issue 44: each photon stage one
 * submission a frame, not one a pass), and the most bytes their maps may hold at once
 * (both maps of each pass until it is shaded: 16 MB a pass at the default photons), or an
 * eighth of the device's memory where less. A time budget traces one pass at a time: a
 * pass the budget ends before its shade would be traced for nothing.
 */
#define FINAL_BATCH_PASSES 16u
#define FINAL_BATCH_BYTES (1ull << 30)
/* A frame fails when more than this fraction of its samples hit the loop cap. */
#define FINAL_TRUNCATED_LIMIT 0.01
/* render_final.comp's record of each pixel's D₁, vec4s per pixel: its vertex, then its
 * weights, in two buffers so that neither is larger than the film (a 1920x1080 record of 5
 * vec4 in one buffer is 158 MiB, past lavapipe's 128 MiB range). */
#define VERTEX_VEC4_PER_PIXEL 3u
#define VERTEX_WEIGHT_VEC4_PER_PIXEL 2u
_Static_assert(VERTEX_VEC4_PER_PIXEL <= PF_SPLIT_FILM_VEC4_PER_PIXEL &&
                   VERTEX_WEIGHT_VEC4_PER_PIXEL <= PF_SPLIT_FILM_VEC4_PER_PIXEL,
               "render_bands.c: no per-pixel buffer of final is larger than the film");
#define GROUP_EDGE 8u
/* The shade kernels' bindings (final_shared.glsl) of the photon grid they gather from and of its
 * irradiance points: records, flux, ranges. */
static const uint32_t grid_bindings[3] = {PF_SCENE_BINDING_COUNT + 8u, PF_SCENE_BINDING_COUNT + 15u,
                                          PF_SCENE_BINDING_COUNT + 9u};
static const uint32_t points_bindings[3] = {PF_SCENE_BINDING_COUNT + 11u,
                                            PF_SCENE_BINDING_COUNT + 16u,
                                            PF_SCENE_BINDING_COUNT + 12u};
/*
 * The gather's deferred estimates (final_deferred.comp): at
 * most one request per pixel and sample is held (a quarter of the gather
 * rays; ~5 % need one on the Cornell box), 3 vec4 each; the rest are
 * retraced with their estimates (final_gather_estimate.comp, shade_sample),
 * which is also the gather when no irradiance points are bound (every ray
 * estimates then, so there is nothing to gather up).
 */
#define FALLBACK_REQUEST_BYTES 48u
_Static_assert(FINAL_GATHER_RAYS <= 4, "final_gather.comp keeps a pixel's requests in a uvec4");


/* The shade kernels' Push (final_shared.glsl; 120 bytes). */
typedef struct final_push {
    pf_photon_grid_push grid;
    uint32_t grid_photons;
    uint32_t sample_index;
    uint32_t gather_first;
    uint32_t gather_count;
    uint32_t gather_total;
    uint32_t fallback_capacity;
    uint32_t loop_sentinel;
    float radius;
    float flux_scale;
    float caustic_scale;
    uint32_t points_count;
    pf_photon_grid_push points;
    uint32_t gather_retrace; /* final_gather_estimate.comp: only the rays marked OVERFLOW */
    uint32_t row_first; /* the primary's and gather's first row (where the host traces: bands) */
} final_push;

_Static_assert(sizeof(final_push) == 124, "final_push must match final_shared.glsl's Push");
_Static_assert(offsetof(final_push, points) % 16 == 0, "points_origin is a vec3");

typedef struct final_counters {
    uint32_t discarded_samples;
    uint32_t traversal_failures;
    uint32_t rays_low, rays_high;
    uint32_t loop_truncated;
    uint32_t gather_dropped;
    uint32_t fallback_requests;
} final_counters;

/* One photon pass: its grids (caustic NULL without a caustic map) and figures. */
typedef struct final_pass {
    pf_photon_grid *global;
    pf_photon_grid *points; /* the global map's precomputed irradiance (the gather's lookups) */
    int points_built;       /* points hold this pass's map (else the gather estimates) */
    pf_photon_grid *caustic;
    float radius;
    float flux_scale;
    uint32_t emitted, global_stored, caustic_stored;
} final_pass;

struct pf_final_cache {
    /* The kept passes' slots, then the slots of passes never kept (one a pass of a batch). */
    final_pass passes[FINAL_KEPT_PASSES + FINAL_BATCH_PASSES];
    float first_radius;                       /* valid passes: stage memory's kept_passes */
};

void pf_final_cache_destroy(struct pf_final_cache *cache)
{
    if (!cache)
        return;
    for (uint32_t i = 0; i < FINAL_KEPT_PASSES + FINAL_BATCH_PASSES; i++) {
        pf_photon_grid_destroy(cache->passes[i].global);
        pf_photon_grid_destroy(cache->passes[i].points);
        pf_photon_grid_destroy(cache->passes[i].caustic);
    }
    free(cache);
}

/* r_1 from the first pass's global map (header comment). */
static float first_radius(const pf_scene_frame *frame, uint32_t global_stored)
{
    return pf_photon_radius_for_density(frame, FINAL_GLOBAL_NEIGHBOURS, global_stored,
                                        FINAL_FALLBACK_RADIUS_FRACTION);
}

/* Radius of pass index (0-based) from r_1: r_{i+1}² = r_i² (i + α)/(i + 1), i 1-based. */
static float pass_radius(float radius_1, uint32_t index)
{
    double r2 = (double)radius_1 * radius_1;
    for (uint32_t i = 1; i <= index; i++)
        r2 *= (i + FINAL_ALPHA) / (i + 1.0);
    return (float)sqrt(r2);
}

/* With --max-bounces 0 the frame is direct light only: no caustics, no gather. */
static uint32_t final_gather_rays(const pf_render_settings *settings)
{
    return settings->bounce_limit == 1 ? 0u : FINAL_GATHER_RAYS;
}

/* Frame-wide figures for the rows. */
typedef struct final_progress {
    uint32_t passes, traced, reused;
    uint64_t emitted, global_stored, caustic_stored, points, points_skipped;
    uint32_t lookup_passes; /* passes shaded with precomputed irradiance */
    double trace_ms, trace_gpu_ms, grid_ms, grid_gpu_ms, caustic_ms;
    /* Where the host traced the photons: the waves' dispatches and its traces' time. */
    uint32_t photon_waves;
    double photon_host_ms;
    /* grid_gpu_ms's two parts: the maps' grids, and the irradiance points with theirs. */
    double map_grid_gpu_ms, points_gpu_ms;
    float radius_first, radius_last;
    uint64_t rays, discarded, truncated, dropped, failures;
    uint64_t deferred, estimated_at_once; /* gather estimates run by final_deferred.comp, and not */
    double shade_gpu_ms;
    /* Where the host traced the camera and gather rays: its traces, and its threads. */
    pf_host_trace_totals host;
    uint32_t trace_threads;
} final_progress;

/* The frame's state between its stages (pf_frame_run.state). */
typedef struct final_frame final_frame;

/* The slot of pass index: its own while it can be kept, else one of the scratch slots,
 * distinct for the passes of a batch. */
static final_pass *pass_slot(struct pf_final_cache *cache, uint32_t index)
{
    return &cache->passes[index < FINAL_KEPT_PASSES
                              ? index
                              : FINAL_KEPT_PASSES + (index - FINAL_KEPT_PASSES) % FINAL_BATCH_PASSES];
}

/* The end of the batch of passes that starts at first (FINAL_BATCH_PASSES). */
static uint32_t batch_end(pf_vk_context *ctx, const pf_render_settings *settings,
                          const pf_stage_plan *plan, uint32_t first)
{
    if (settings->time_budget_ms > 0.0)
        return first + 1;
    pf_photon_trace_settings trace = {.photon_count = plan->photons};
    uint64_t per_pass = pf_photon_trace_bytes(pf_vk_info(ctx), &trace);
    uint64_t most = pf_vk_info(ctx)->device_local_bytes / 8;
    if (most == 0 || most > FINAL_BATCH_BYTES)
        most = FINAL_BATCH_BYTES;
    uint64_t fits = per_pass > 0 ? most / per_pass : FINAL_BATCH_PASSES;
    uint32_t count = fits < 1 ? 1u : fits > FINAL_BATCH_PASSES ? FINAL_BATCH_PASSES : (uint32_t)fits;
    return first + count < plan->samples ? first + count : plan->samples;
}

/* Traces passes [first, first + count) into maps[0 .. count) and sets their slots' figures
 * (radius, counts): one submission where the device traces (pf_photon_trace_passes). */
static pf_status trace_batch(pf_renderer *renderer, const pf_photon_frame *inputs,
                             const pf_scene_frame *frame, const pf_render_settings *settings,
                             const pf_stage_plan *plan, uint32_t first, uint32_t count,
                             struct pf_final_cache *cache, pf_photon_maps *maps,
                             final_progress *progress, pf_error *err)
{
    double start = pf_time_ms();
    pf_photon_trace_settings trace[FINAL_BATCH_PASSES];
    /* First hits too: the gather's secondary vertices take all their light from the map. */
    for (uint32_t i = 0; i < count; i++)
        trace[i] = (pf_photon_trace_settings){.photon_count = plan->photons,
                                              .seed = pf_seed_mix(settings->seed, first + i),
                                              .max_depth = plan->photon_depth,
                                              .store_direct = 1};
    pf_status status = pf_photon_frame_trace(renderer, inputs, plan, trace, count, maps, err);
    if (status != PF_OK)
        return status;
    progress->trace_ms += pf_time_ms() - start;
    if (first == 0 && cache->first_radius <= 0.0f)
        cache->first_radius = first_radius(frame, maps[0].global_count);
    for (uint32_t i = 0; i < count; i++) {
        progress->photon_waves += maps[i].waves;
        progress->photon_host_ms += maps[i].host_trace_ms;
        pf_gpu_ms_add(&progress->trace_gpu_ms, maps[i].gpu_ms);
        final_pass *slot = pass_slot(cache, first + i);
        slot->radius = pass_radius(cache->first_radius, first + i);
        slot->flux_scale = maps[i].flux_scale;
        slot->emitted = maps[i].emitted;
        slot->global_stored = maps[i].global_count;
        slot->caustic_stored = plan->caustic_map ? maps[i].caustic_count : 0;
    }
    return PF_OK;
}

/* Whether a frame of these settings and plan gathers through precomputed irradiance when a pass
 * stores `stored` global photons (FINAL_LOOKUP_MIN_RATIO, FINAL_LOOKUP_MAX_PASSES). The whole
 * image's rays, so that the bands of a frame (render_bands.c) all decide as it would. */
static int wants_lookups(const pf_render_settings *settings, const pf_stage_plan *plan,
                         uint64_t stored)
{
    uint64_t rays = (uint64_t)settings->width * pf_render_image_height(settings) *
                    final_gather_rays(settings);
    return plan->samples <= FINAL_LOOKUP_MAX_PASSES && rays > 0 &&
           rays >= FINAL_LOOKUP_MIN_RATIO * stored;
}

/* Grids the global photons of passes [first, first + count) into their slots, with their
 * precomputed irradiance points where the frame wants them (and drops caustic grids the
 * plan has none of): one submission (pf_photon_grid_build_batch). */
static pf_status grid_batch(pf_vk_context *ctx, const pf_scene_frame *frame,
                            const pf_render_settings *settings, const pf_stage_plan *plan,
                            struct pf_final_cache *cache, const pf_photon_maps *maps,
                            uint32_t first, uint32_t count, final_progress *progress,
                            pf_error *err)
{
    double start = pf_time_ms();
    pf_photon_grid_job jobs[FINAL_BATCH_PASSES];
    pf_status status = PF_OK;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        final_pass *slot = pass_slot(cache, first + i);
        slot->points_built = 0;
        if (!slot->global)
            status = pf_photon_grid_create(ctx, &slot->global, err);
        int lookups = status == PF_OK && wants_lookups(settings, plan, maps[i].global_count);
        if (lookups && !slot->points)
            status = pf_photon_grid_create(ctx, &slot->points, err);
        jobs[i] = (pf_photon_grid_job){slot->global, maps[i].global, maps[i].global_count,
                                       slot->radius, lookups ? slot->points : NULL, {0, 0}};
        if (!plan->caustic_map) {
            /* A grid left from an earlier scene must not be gathered from. */
            pf_photon_grid_destroy(slot->caustic);
            slot->caustic = NULL;
        }
    }
    if (status == PF_OK)
        status = pf_photon_grid_build_batch(jobs, count, frame->bounds_min, frame->bounds_max,
                                            err);
    if (status != PF_OK)
        return status;
    progress->grid_ms += pf_time_ms() - start;
    for (uint32_t i = 0; i < count; i++) {
        final_pass *slot = pass_slot(cache, first + i);
        double map_ms = pf_photon_grid_gpu_ms(slot->global);
        pf_gpu_ms_add(&progress->grid_gpu_ms, map_ms);
        pf_gpu_ms_add(&progress->map_grid_gpu_ms, map_ms);
        slot->points_built = jobs[i].points != NULL;
        if (slot->points_built) {
            double points_ms = pf_photon_grid_gpu_ms(slot->points);
            pf_gpu_ms_add(&progress->grid_gpu_ms, points_ms);
            pf_gpu_ms_add(&progress->points_gpu_ms, points_ms);
        }
        progress->points += jobs[i].counts.points;
        progress->points_skipped += jobs[i].counts.truncated;
    }
    return PF_OK;
}

/* Grids the caustic photons of passes [first, first + count) into their slots: one
 * submission. */
static pf_status caustic_batch(pf_vk_context *ctx, const pf_scene_frame *frame,
                               struct pf_final_cache *cache, const pf_photon_maps *maps,
                               uint32_t first, uint32_t count, final_progress *progress,
                               pf_error *err)
{
    double start = pf_time_ms();
    pf_photon_grid_job jobs[FINAL_BATCH_PASSES];
    pf_status status = PF_OK;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        final_pass *slot = pass_slot(cache, first + i);
        if (!slot->caustic)
            status = pf_photon_grid_create(ctx, &slot->caustic, err);
        jobs[i] = (pf_photon_grid_job){slot->caustic, maps[i].caustic, maps[i].caustic_count,
                                       slot->radius, NULL, {0, 0}};
    }
    if (status == PF_OK)
        status = pf_photon_grid_build_batch(jobs, count, frame->bounds_min, frame->bounds_max,
                                            err);
    progress->caustic_ms += pf_time_ms() - start;
    return status;
}

/* Device buffers of one frame; every pointer NULL or owned. */
typedef struct final_buffers {
    pf_vk_buffer *params, *film, *film_aov, *counters, *vertices, *vertex_weights, *samples;
    pf_vk_buffer *empty_grid;
    pf_vk_buffer *caustic_radii; /* per pixel: the caustic radius the first pass chose */
    pf_vk_buffer *fallback_requests, *pixel_fallbacks; /* the gather's deferred estimates */
    pf_vk_buffer *retrace_groups; /* final_retrace_args.comp's indirect dispatch */
    uint32_t fallback_capacity;  /* requests fallback_requests holds */
    /* Where the host traces: the camera and gather rays' queue. */
    pf_host_rays *host_rays;
} final_buffers;

static void final_buffers_release(pf_vk_context *ctx, final_buffers *b)
{
    pf_vk_buffer **all[] = {&b->params,          &b->film,           &b->film_aov,
                            &b->counters,        &b->vertices,       &b->vertex_weights,
                            &b->samples,
                            &b->empty_grid,      &b->caustic_radii,  &b->fallback_requests,
                            &b->pixel_fallbacks, &b->retrace_groups};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        pf_render_buffer_release(ctx, all[i]);
    pf_host_rays_destroy(b->host_rays);
    b->host_rays = NULL;
}

/* A built grid's push parameters and buffers (at bindings: records, flux, ranges); returns its
 * records (photons or points). Without one (NULL, or never built): the empty buffer and 0, which
 * the kernel reads as "none". */
static uint32_t bind_photon_grid(const pf_photon_grid *grid, pf_vk_buffer *empty,
                                 pf_photon_grid_push *params, pf_vk_buffer **buffers,
                                 const uint32_t bindings[3])
{
    pf_photon_grid_view view = {NULL, NULL, NULL};
    if (grid)
        view = pf_photon_grid_view_get(grid);
    buffers[bindings[0]] = view.records ? view.records : empty;
    buffers[bindings[1]] = view.records ? view.flux : empty;
    buffers[bindings[2]] = view.records ? view.ranges : empty;
    if (!view.records)
        return 0;
    pf_photon_grid_info info = pf_photon_grid_get_info(grid);
    *params = pf_photon_grid_push_of(&info);
    return info.photon_count;
}

/* Push constants and buffers for a grid (or none: no estimate). */
static void bind_grid(const pf_photon_grid *grid, float radius, float flux_scale,
                      pf_vk_buffer *empty, final_push *push, pf_vk_buffer **buffers)
{
    memset(push, 0, sizeof *push);
    push->grid_photons = bind_photon_grid(grid, empty, &push->grid, buffers, grid_bindings);
    if (push->grid_photons > 0) {
        push->radius = radius;
        push->flux_scale = flux_scale;
    }
}

/* Push constants and buffers for a grid's irradiance points (or none: estimates only). */
static void bind_points(const pf_photon_grid *points, pf_vk_buffer *empty, final_push *push,
                        pf_vk_buffer **buffers)
{
    push->points_count = bind_photon_grid(points, empty, &push->points, buffers, points_bindings);
}

/* Records the sample's timestamps' span into the shade row's GPU time and destroys cmds. */
static void finish_commands(pf_vk_commands *cmds, int begin, int end, final_progress *progress)
{
    pf_gpu_ms_add(&progress->shade_gpu_ms, pf_commands_gpu_ms(cmds, begin, end));
    pf_vk_commands_destroy(cmds);
}

/*
 * Renders camera sample sample_index with pass's grids (pass NULL: no photon maps): the
 * primary (and caustic) kernel and the gather, then the deferred estimates and the resolve.
 * Where the gather's requests overflowed fallback_requests, final_gather_estimate.comp
 * retraces the marked rays with their estimates in place before the resolve, so that
 * final_gather.comp never carries the estimate's code (final_gather.glsl says why). Whether
 * they did, the device decides: final_retrace_args.comp writes the retrace's indirect
 * dispatch, and the sample is one submission (issue 43: no host round trip inside it).
 * Where the host traces the rays (a CPU device) the sample is cut where the host traces,
 * and the host reads the counters after the gather as before, rather than compile the
 * retrace's kernel for every frame. Without irradiance points the gather is
 * final_gather_estimate.comp itself, defers nothing and needs no retrace.
 */
static pf_status shade_sample(pf_renderer *renderer, pf_vk_buffer **buffers,
                              const final_buffers *owned, const pf_render_settings *settings,
                              const pf_stage_plan *plan, const final_pass *pass,
                              uint32_t sample_index, pf_image *read_into,
                              pf_vk_commands **setup, final_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    static const final_counters zero = {0};
    pf_status status = PF_OK;
    pf_vk_pipeline *primary = NULL, *caustic = NULL, *gather = NULL, *fallback = NULL,
                   *resolve = NULL;
    /* The primary and the caustic kernel gather from the caustic map. */
    final_push push;
    memset(&push, 0, sizeof push);
    bind_grid(pass ? pass->caustic : NULL, pass ? pass->radius : 0.0f,
              pass ? pass->flux_scale : 0.0f, owned->empty_grid, &push, buffers);
    /* The caustic kernel only for a pass with caustic photons (scenes without a specular
     * surface never create it). A kept pass gridded without points (an earlier, smaller
     * frame) gathers by estimates. */
    int caustics = push.grid_photons > 0;
    int lookups = pass && pass->points_built && wants_lookups(settings, plan, pass->global_stored);
    /* Where the host traces the camera rays and the gather rays' first segments
     * (host_rays.glsl), the primary and the gather read their hits, after kernels of
     * their modules that write the rays. */
    int host_traced = owned->host_rays != NULL;
    pf_renderer_pipeline_id primary_id =
        host_traced ? PF_PIPELINE_FINAL_PRIMARY_GIVEN : PF_PIPELINE_FINAL_PRIMARY;
    pf_renderer_pipeline_id gather_id =
        host_traced ? (lookups ? PF_PIPELINE_FINAL_GATHER_GIVEN
                               : PF_PIPELINE_FINAL_GATHER_ESTIMATE_GIVEN)
                    : (lookups ? PF_PIPELINE_FINAL_GATHER : PF_PIPELINE_FINAL_GATHER_ESTIMATE);
    /* The film's split (split_film.comp) is made with them, not alone at the frame's end. */
    pf_renderer_pipeline_id kernels[8] = {primary_id, gather_id, PF_PIPELINE_FINAL_FALLBACK,
                                          PF_PIPELINE_FINAL_RESOLVE, PF_PIPELINE_SPLIT_FILM};
    uint32_t kernel_count = 5;
    if (caustics)
        kernels[kernel_count++] = PF_PIPELINE_FINAL_CAUSTIC;
    if (host_traced) {
        kernels[kernel_count++] = PF_PIPELINE_CAMERA_RAYS;
        kernels[kernel_count++] = PF_PIPELINE_FINAL_GATHER_RAYS;
    }
    /* The retrace dispatched by the device, in the sample's one submission. */
    int device_retrace = lookups && !host_traced;
    if (device_retrace) {
        kernels[kernel_count++] = PF_PIPELINE_FINAL_GATHER_ESTIMATE;
        kernels[kernel_count++] = PF_PIPELINE_FINAL_RETRACE_ARGS;
    }
    pf_vk_pipeline *gather_rays = NULL;
    if (status == PF_OK)
        status = pf_renderer_pipelines_prepare(renderer, kernels, kernel_count, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, primary_id, &primary, err);
    if (status == PF_OK && caustics)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_CAUSTIC, &caustic, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, gather_id, &gather, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_FALLBACK, &fallback, err);
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_RESOLVE, &resolve, err);
    /* The camera rays' step (camera_rays.comp), bound to the scene and the queue. */
    pf_vk_buffer *camera_buffers[PF_CAMERA_RAYS_BUFFERS];
    pf_camera_rays_push camera_push;
    pf_host_traced_kernel traced = {{0}, {primary, buffers, PF_FINAL_BUFFERS, &push, sizeof push,
                                          &push.row_first},
                                    settings->width, settings->height, 1};
    if (status == PF_OK && host_traced)
        status = pf_host_rays_camera_step(renderer, owned->host_rays, buffers, camera_buffers,
                                          &camera_push, &traced.write, err);
    if (status == PF_OK && host_traced)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_GATHER_RAYS, &gather_rays, err);
    /* The counters zeroed, the primary, caustic and gather kernels, the retrace, fallback
     * and resolve, the counters read back: one submission, or where the host traces, cut
     * where it does (twice a band) and after the gather, whose counters say whether the
     * deferred requests overflowed. */
    /* The frame's uploads, where they are still to be submitted, go first. */
    pf_vk_commands *cmds = *setup;
    *setup = NULL;
    if (status == PF_OK && !cmds)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(cmds);
        return status;
    }
    status = pf_vk_cmd_upload(cmds, owned->counters, 0, &zero, sizeof zero, err);
    uint32_t groups_x = (settings->width + GROUP_EDGE - 1) / GROUP_EDGE;
    uint32_t groups_y = (settings->height + GROUP_EDGE - 1) / GROUP_EDGE;
    int begin = pf_vk_cmd_timestamp(cmds);
    /* The caustic radii of the first pass shrink as the pass radius does. */
    push.caustic_scale = pass && progress->radius_first > 0.0f
                             ? pass->radius / progress->radius_first
                             : 1.0f;
    push.sample_index = sample_index;
    push.gather_total = final_gather_rays(settings);
    push.loop_sentinel = 1;
    push.gather_retrace = 0;
    bind_points(NULL, owned->empty_grid, &push, buffers);
    camera_push.sample_index = sample_index;
    if (status == PF_OK && host_traced)
        status = pf_host_rays_dispatch(owned->host_rays, &traced, &cmds, &begin, &progress->host,
                                       err);
    else if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, primary, buffers, PF_FINAL_BUFFERS,
                                    &push, sizeof push, groups_x, groups_y, 1, err);
    if (status == PF_OK && caustics) {
        pf_vk_cmd_barrier(cmds);
        status = pf_vk_cmd_dispatch(cmds, caustic, buffers, PF_FINAL_BUFFERS, &push, sizeof push,
                                    groups_x, groups_y, 1, err);
    }
    bind_grid(pass ? pass->global : NULL, pass ? pass->radius : 0.0f,
              pass ? pass->flux_scale : 0.0f, owned->empty_grid, &push, buffers);
    push.sample_index = sample_index;
    push.gather_total = final_gather_rays(settings);
    push.loop_sentinel = 1;
    bind_points(lookups ? pass->points : NULL, owned->empty_grid, &push, buffers);
    progress->lookup_passes += lookups;
    uint32_t cap = renderer->final_deferred_cap;
    push.fallback_capacity = !lookups ? 0
                             : cap && cap < owned->fallback_capacity ? cap
                                                                     : owned->fallback_capacity;
    for (uint32_t first = 0; status == PF_OK && first < FINAL_GATHER_RAYS;
         first += FINAL_GATHER_RAYS_PER_DISPATCH) {
        push.gather_first = first;
        push.gather_count = FINAL_GATHER_RAYS_PER_DISPATCH;
        if (host_traced) {
            traced.write = traced.given;
            traced.write.pipeline = gather_rays;
            traced.given.pipeline = gather;
            traced.rays_per_pixel = FINAL_GATHER_RAYS_PER_DISPATCH;
            status = pf_host_rays_dispatch(owned->host_rays, &traced, &cmds, &begin,
                                           &progress->host, err);
            continue;
        }
        pf_vk_cmd_barrier(cmds);
        status = pf_vk_cmd_dispatch(cmds, gather, buffers, PF_FINAL_BUFFERS,
                                    &push, sizeof push, groups_x, groups_y, 1, err);
    }
    if (status != PF_OK) { /* the host's trace may have left none open */
        pf_vk_commands_destroy(cmds);
        return status;
    }
    final_counters counters;
    int overflow = 0;
    pf_vk_pipeline *retrace = NULL;
    if (host_traced) {
        int end = pf_vk_cmd_timestamp(cmds);
        status = pf_vk_cmd_download(cmds, owned->counters, 0, &counters, sizeof counters, err);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, err);
        finish_commands(cmds, begin, status == PF_OK ? end : -1, progress);
        overflow =
            status == PF_OK && lookups && counters.fallback_requests > push.fallback_capacity;
        if (overflow)
            status =
                pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_GATHER_ESTIMATE, &retrace, err);
        cmds = NULL;
        if (status == PF_OK)
            status = pf_vk_commands_begin(ctx, &cmds, err);
        if (status != PF_OK)
            return status;
        begin = pf_vk_cmd_timestamp(cmds);
    }
    /* The rays past the capacity, all of the sample's gather rays in one dispatch (retraced
     * rays follow the same paths as in the gather, whatever dispatch they were in): where
     * the device decides, of as many groups as it writes, none without an overflow. */
    push.gather_first = 0;
    push.gather_count = FINAL_GATHER_RAYS;
    if (device_retrace) {
        pf_vk_pipeline *args = NULL;
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_GATHER_ESTIMATE, &retrace, err);
        if (status == PF_OK)
            status = pf_renderer_pipeline(renderer, PF_PIPELINE_FINAL_RETRACE_ARGS, &args, err);
        uint32_t args_push[3] = {groups_x, groups_y, push.fallback_capacity};
        pf_vk_buffer *args_buffers[] = {owned->counters, owned->retrace_groups};
        pf_vk_cmd_barrier(cmds);
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, args, args_buffers, 2, args_push, sizeof args_push,
                                        1, 1, 1, err);
        pf_vk_cmd_barrier(cmds);
        push.gather_retrace = 1;
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch_indirect(cmds, retrace, buffers, PF_FINAL_BUFFERS, &push,
                                                 sizeof push, owned->retrace_groups, 0, err);
        push.gather_retrace = 0;
        pf_vk_cmd_barrier(cmds);
    } else if (overflow) {
        push.gather_retrace = 1;
        status = pf_vk_cmd_dispatch(cmds, retrace, buffers, PF_FINAL_BUFFERS, &push, sizeof push,
                                    groups_x, groups_y, 1, err);
        push.gather_retrace = 0;
        pf_vk_cmd_barrier(cmds);
    }
    /* One invocation per request: the capacity is at most one per pixel. */
    if (status == PF_OK && push.fallback_capacity > 0) {
        status = pf_vk_cmd_dispatch(cmds, fallback, buffers, PF_FINAL_BUFFERS, &push, sizeof push,
                                    groups_x, groups_y, 1, err);
        pf_vk_cmd_barrier(cmds);
    }
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, resolve, buffers, PF_FINAL_BUFFERS, &push, sizeof push,
                                    groups_x, groups_y, 1, err);
    /* The frame's last sample: the film's split into the image and its readback go with
     * it (issue 44: no submission of their own). */
    pf_split_film_readback readback = {0};
    if (status == PF_OK && read_into)
        status = pf_split_film_record_read(renderer, cmds, owned->film, owned->film_aov,
                                           settings->aovs, 1, read_into, &readback, err);
    int end = pf_vk_cmd_timestamp(cmds);
    /* The counters (again): the retrace's truncations and failures are the sample's too. */
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, owned->counters, 0, &counters, sizeof counters, err);
    if (status == PF_OK)
        status = pf_split_film_submit(renderer, cmds, &readback, err);
    finish_commands(cmds, begin, status == PF_OK ? end : -1, progress);
    pf_split_film_finish_read(&readback);
    if (status == PF_OK) {
        progress->rays += ((uint64_t)counters.rays_high << 32) | counters.rays_low;
        progress->discarded += counters.discarded_samples;
        progress->truncated += counters.loop_truncated;
        progress->dropped += counters.gather_dropped;
        progress->failures += counters.traversal_failures;
        uint32_t deferred = counters.fallback_requests < push.fallback_capacity
                                ? counters.fallback_requests
                                : push.fallback_capacity;
        progress->deferred += deferred;
        progress->estimated_at_once += counters.fallback_requests - deferred;
    }
    return status;
}

static void report_rows(pf_frame_report *report, const pf_stage_plan *plan,
                        const final_progress *progress, double shade_ms, uint32_t pixels,
                        const pf_scene_frame *frame)
{
    pf_stage_timing *row;
    row = pf_stage_row(report, plan, PF_STAGE_PHOTON_TRACE, progress->trace_ms,
                       progress->trace_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "photons", (double)progress->emitted);
        pf_stage_add_counter(row, "stored", (double)(progress->global_stored +
                                                     progress->caustic_stored));
        pf_stage_add_counter(row, "passes", progress->passes);
        pf_stage_add_counter(row, "traced_passes", progress->traced);
        pf_stage_add_counter(row, "reused_passes", progress->reused);
        if (progress->photon_waves) {
            pf_stage_add_counter(row, "waves", progress->photon_waves);
            pf_stage_add_counter(row, "host_trace_ms", progress->photon_host_ms);
        }
    }
    row = pf_stage_row(report, plan, PF_STAGE_PHOTON_GRID, progress->grid_ms,
                       progress->grid_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "photons", (double)progress->global_stored);
        pf_stage_add_counter(row, "stored", (double)progress->global_stored);
        pf_stage_add_counter(row, "passes", progress->passes);
        pf_stage_add_counter(row, "radius_first", progress->radius_first);
        pf_stage_add_counter(row, "radius_last", progress->radius_last);
        pf_stage_add_counter(row, "irradiance_points", (double)progress->points);
        pf_stage_add_counter(row, "irradiance_points_skipped", (double)progress->points_skipped);
        /* Where the GPU time went inside the passes' submissions (issue 44). */
        if (progress->grid_gpu_ms >= 0.0) {
            pf_stage_add_counter(row, "gpu_ms_map_grid", progress->map_grid_gpu_ms);
            pf_stage_add_counter(row, "gpu_ms_irradiance_points",
                                 progress->points_gpu_ms > 0.0 ? progress->points_gpu_ms : 0.0);
        }
    }
    row = pf_stage_row(report, plan, PF_STAGE_CAUSTIC_MAP, progress->caustic_ms, -1.0);
    if (row) {
        pf_stage_add_counter(row, "photons", (double)progress->caustic_stored);
        pf_stage_add_counter(row, "passes", plan->caustic_map ? progress->passes : 0);
    }
    /* The host's traces cut the submissions: their GPU time is the shade's too. */
    double shade_gpu_ms = progress->shade_gpu_ms;
    pf_gpu_ms_add(&shade_gpu_ms, progress->host.gpu_ms);
    row = pf_stage_row(report, plan, PF_STAGE_SHADE, shade_ms, shade_gpu_ms);
    if (row) {
        pf_stage_add_counter(row, "samples_per_pixel", progress->passes);
        pf_stage_add_counter(row, "gather_rays", FINAL_GATHER_RAYS);
        pf_stage_add_counter(row, "lookup_passes", progress->lookup_passes);
        pf_stage_add_counter(row, "paths", (double)pixels * progress->passes);
        pf_stage_add_counter(row, "rays", (double)(progress->rays + progress->host.rays));
        pf_stage_add_light_samples(row, frame->light_count, PF_DIRECT_LIGHT_PIXEL_SAMPLES);
        pf_stage_add_counter(row, "discarded_samples", (double)progress->discarded);
        pf_stage_add_counter(row, "loop_truncated", (double)progress->truncated);
        pf_stage_add_counter(row, "gather_dropped", (double)progress->dropped);
        pf_stage_add_counter(row, "deferred_estimates", (double)progress->deferred);
        pf_stage_add_counter(row, "deferred_overflow", (double)progress->estimated_at_once);
        pf_stage_add_counter(row, "triangles", frame->triangle_count);
        if (progress->host.traces) {
            pf_stage_add_counter(row, "host_traces", progress->host.traces);
            pf_stage_add_counter(row, "host_trace_ms", progress->host.host_ms);
            pf_stage_add_counter(row, "trace_threads", progress->trace_threads);
        }
    }
    if (report)
        report->discarded_samples += progress->discarded;
}

struct final_frame {
    pf_photon_frame inputs;
    int inputs_ready;
    final_buffers owned;
    pf_vk_buffer *buffers[PF_FINAL_BUFFERS];
    final_progress progress;
    double start_ms;          /* after the BIH: the shade row gets what the photon stages leave */
    /* The passes traced together, [batch_first, batch_end), and their maps until each is
     * shaded; the batch's grids and caustic grids made (each once for the batch). */
    pf_photon_maps batch[FINAL_BATCH_PASSES];
    uint32_t batch_first, batch_end;
    int batch_gridded, batch_caustics;
    int pass_traced;          /* the current pass was traced in this frame (not kept) */
    int film_read;            /* the last pass read the film into the image with its own */
    /* The frame's own uploads (its parameters, the empty grid), recorded at its start and
     * submitted with the first sample's kernels, which are their first readers. */
    pf_vk_commands *setup;
};

static void final_frame_free(pf_vk_context *ctx, final_frame *f)
{
    pf_vk_commands_destroy(f->setup);
    for (uint32_t i = 0; i < FINAL_BATCH_PASSES; i++)
        pf_photon_maps_release(ctx, &f->batch[i]);
    final_buffers_release(ctx, &f->owned);
    if (f->inputs_ready)
        pf_photon_frame_release(ctx, &f->inputs);
    free(f);
}

/* Device buffers, the scene upload and the kept passes' fate, as planned. */
static pf_status final_begin(pf_frame_run *run, pf_error *err)
{
    pf_renderer *renderer = run->renderer;
    const pf_render_settings *settings = run->settings;
    const pf_stage_plan *plan = run->plan;
    pf_vk_context *ctx = renderer->ctx;
    pf_status status = PF_OK; /* its buffers fit: render_bands.c */
    if (!renderer->final_cache) {
        renderer->final_cache = calloc(1, sizeof *renderer->final_cache);
        if (!renderer->final_cache)
            status = pf_error_set(err, PF_ERR_NOMEM, "final: out of memory");
    }
    final_frame *f = status == PF_OK ? calloc(1, sizeof *f) : NULL;
    if (status == PF_OK && !f)
        status = pf_error_set(err, PF_ERR_NOMEM, "final: out of memory");
    if (status != PF_OK)
        return status;
    f->start_ms = pf_time_ms();
    f->progress.trace_gpu_ms = f->progress.grid_gpu_ms = f->progress.shade_gpu_ms = -1.0;
    f->progress.host.gpu_ms = -1.0;
    f->progress.map_grid_gpu_ms = f->progress.points_gpu_ms = -1.0;
    status = pf_split_image_create(run->image, settings->width, settings->height, settings->aovs,
                                   settings->later_layers, err);
    if (status == PF_OK)
        status = pf_photon_frame_prepare(renderer, run->frame, &plan->emitters, &f->inputs, err);
    f->inputs_ready = status == PF_OK;
    /* The plan reuses the kept passes as this frame's first ones, or none of them. */
    if (plan->reused_passes == 0) {
        renderer->stage_memory[PF_QUALITY_FINAL].kept_passes = 0;
        renderer->final_cache->first_radius = 0.0f;
    }
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    final_buffers *owned = &f->owned;
    const pf_gpu_scene *scene = &f->inputs.scene;
    const pf_bih_gpu_view *bih = &f->inputs.bih;
    pf_frame_params params;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &f->setup, err);
    if (status == PF_OK) {
        pf_frame_params_fill(run->frame, settings, plan->samples, scene, bih, &params);
        params.max_specular_depth = FINAL_MAX_SPECULAR_DEPTH;
        status = pf_render_buffer_recorded(ctx, f->setup, "frame parameters", &params,
                                           sizeof params, sizeof params, &owned->params, err);
    }
    if (status == PF_OK)
        status = pf_split_film_create(ctx, settings, 1, "final", &owned->film, &owned->film_aov,
                                      err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof(final_counters), "final counters",
                                     &owned->counters, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, 16, "final retrace groups", &owned->retrace_groups,
                                     err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, pixels * VERTEX_VEC4_PER_PIXEL * 16,
                                     "final gather vertices", &owned->vertices, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, pixels * VERTEX_WEIGHT_VEC4_PER_PIXEL * 16,
                                     "final gather vertex weights", &owned->vertex_weights, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, pixels * PF_SPLIT_FILM_VEC4_PER_PIXEL * 16,
                                     "final sample sums", &owned->samples, err);
    if (status == PF_OK)
        status = pf_render_buffer_recorded(ctx, f->setup, "empty photon grid", NULL, 0, 16,
                                           &owned->empty_grid, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, pixels * sizeof(float), "final caustic radii",
                                     &owned->caustic_radii, err);
    if (status == PF_OK) {
        uint64_t fits = pf_vk_info(ctx)->max_storage_buffer_range / FALLBACK_REQUEST_BYTES;
        owned->fallback_capacity = (uint32_t)(pixels < fits ? pixels : fits);
        status = pf_vk_buffer_create(ctx, (uint64_t)owned->fallback_capacity *
                                              FALLBACK_REQUEST_BYTES,
                                     "final deferred estimates", &owned->fallback_requests, err);
    }
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, pixels * 4 * sizeof(uint32_t),
                                     "final deferred estimates per pixel",
                                     &owned->pixel_fallbacks, err);
    if (status == PF_OK && plan->host_traces) {
        status = pf_host_rays_create(renderer, settings->width, settings->height,
                                     FINAL_GATHER_RAYS_PER_DISPATCH, "final host-traced rays",
                                     &owned->host_rays, err);
        if (status == PF_OK)
            f->progress.trace_threads = pf_host_rays_threads(owned->host_rays);
    }
    if (status != PF_OK) {
        pf_stage_forget(&renderer->stage_memory[PF_QUALITY_FINAL]);
        pf_image_free(run->image);
        final_frame_free(ctx, f);
        pf_error_prefix(err, "final render (%ux%u, %u triangles)", settings->width,
                        settings->height, run->frame->triangle_count);
        return status;
    }
    /* 23..25: the camera and gather rays' queue where the host traces, else a stand-in never
     * read. */
    pf_vk_buffer *queue[3] = {owned->empty_grid, owned->empty_grid, owned->empty_grid};
    if (owned->host_rays)
        pf_host_rays_buffers(owned->host_rays, queue);
    pf_vk_buffer *own[] = {
        owned->film,
        owned->film_aov,   owned->counters,  bih->nodes,      bih->vertices,
        bih->triangle_index, owned->vertices, owned->samples, NULL,
        NULL,              owned->caustic_radii, NULL,           NULL,
        owned->fallback_requests, owned->pixel_fallbacks, NULL,       NULL,
        /* 17..22 after the scene's: texel views of the film, the AOVs, the vertices, the sample sums, the
         * deferred estimates and their per-pixel slots (final_shared.glsl) */
        owned->film,       owned->film_aov,  owned->vertices, owned->samples,
        owned->fallback_requests, owned->pixel_fallbacks, queue[0], queue[1], queue[2],
        /* 26, 27: the D₁ records' weights, and their texel view */
        owned->vertex_weights, owned->vertex_weights};
    pf_gpu_scene_bindings(scene, owned->params, own, sizeof own / sizeof *own, f->buffers);
    run->state = f;
    return PF_OK;
}

/* One planned stage of pass `pass`: the photon stages build the pass (unless kept), shade adds
 * its camera sample. */
static pf_status final_run(pf_frame_run *run, pf_stage_id stage, uint32_t pass, pf_error *err)
{
    final_frame *f = run->state;
    pf_renderer *renderer = run->renderer;
    struct pf_final_cache *cache = renderer->final_cache;
    pf_stage_memory *memory = &renderer->stage_memory[PF_QUALITY_FINAL];
    final_progress *progress = &f->progress;
    final_pass *slot = pass_slot(cache, pass);
    pf_status status = PF_OK;
    switch (stage) {
    case PF_STAGE_PHOTON_TRACE:
        f->pass_traced = pass >= memory->kept_passes;
        /* The first pass to trace traces its batch; the batch's later passes are traced. */
        if (f->pass_traced && !(pass >= f->batch_first && pass < f->batch_end)) {
            f->batch_first = pass;
            f->batch_end = batch_end(renderer->ctx, run->settings, run->plan, pass);
            f->batch_gridded = f->batch_caustics = 0;
            status = trace_batch(renderer, &f->inputs, run->frame, run->settings, run->plan,
                                 pass, f->batch_end - pass, cache, f->batch, progress, err);
            if (status != PF_OK)
                f->batch_end = f->batch_first; /* nothing held */
        }
        if (f->pass_traced) {
            progress->traced += status == PF_OK;
        } else {
            progress->reused++;
        }
        if (status == PF_OK) {
            progress->emitted += slot->emitted;
            progress->global_stored += slot->global_stored;
            progress->caustic_stored += slot->caustic_stored;
            if (pass == 0)
                progress->radius_first = slot->radius;
            progress->radius_last = slot->radius;
        }
        break;
    case PF_STAGE_PHOTON_GRID:
        if (f->pass_traced && !f->batch_gridded) {
            status = grid_batch(renderer->ctx, run->frame, run->settings, run->plan, cache,
                                f->batch, f->batch_first, f->batch_end - f->batch_first,
                                progress, err);
            f->batch_gridded = 1;
        }
        break;
    case PF_STAGE_CAUSTIC_MAP:
        if (f->pass_traced && !f->batch_caustics) {
            status = caustic_batch(renderer->ctx, run->frame, cache, f->batch, f->batch_first,
                                   f->batch_end - f->batch_first, progress, err);
            f->batch_caustics = 1;
        }
        break;
    case PF_STAGE_SHADE:
        /* Its maps are gridded: the device memory goes back before the sample's kernels. */
        if (f->pass_traced)
            pf_photon_maps_release(renderer->ctx, &f->batch[pass - f->batch_first]);
        /* A pass traced whole in this frame is kept for the next (as a prefix). */
        if (f->pass_traced && pass < FINAL_KEPT_PASSES && pass == memory->kept_passes)
            memory->kept_passes = pass + 1;
        /* The plan's last pass is the frame's (a time budget ends passes only before it). */
        f->film_read = pass + 1 == run->plan->samples;
        status = shade_sample(renderer, f->buffers, &f->owned, run->settings, run->plan,
                              run->plan->emitters.count > 0 ? slot : NULL, pass,
                              f->film_read ? run->image : NULL, &f->setup, progress, err);
        if (status == PF_OK)
            progress->passes++;
        break;
    default:
        return pf_error_set(err, PF_ERR_INTERNAL, "final has no stage %s", pf_stage_name(stage));
    }
    if (status != PF_OK && stage != PF_STAGE_SHADE)
        pf_error_prefix(err, "photon pass %u (%u photons)", pass + 1, run->plan->photons);
    return status;
}

/* Film readback, the frame's checks, the memory of what the kept passes are, the rows. */
static pf_status final_end(pf_frame_run *run, pf_status status, pf_error *err)
{
    final_frame *f = run->state;
    pf_renderer *renderer = run->renderer;
    const pf_render_settings *settings = run->settings;
    const pf_stage_plan *plan = run->plan;
    final_progress *progress = &f->progress;
    pf_stage_memory *memory = &renderer->stage_memory[PF_QUALITY_FINAL];
    if (status == PF_OK && !f->film_read) /* a time budget ended the passes early */
        status = pf_split_film_read(renderer, f->owned.film, f->owned.film_aov,
                                    settings->aovs, 1, run->image, err);
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    if (status == PF_OK)
        status = pf_render_check_traversal(renderer, progress->failures, err);
    if (status == PF_OK &&
        (double)progress->truncated > FINAL_TRUNCATED_LIMIT * (double)pixels * progress->passes)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%llu of %llu samples stopped at the loop cap (this device ends "
                              "an invocation's loops after 65,535 iterations: a photon estimate "
                              "met more photons than one invocation may visit: photons clustered "
                              "far above the scene's mean density)",
                              (unsigned long long)progress->truncated,
                              (unsigned long long)(pixels * progress->passes));
    /* Photon stages ran between the shade dispatches: the shade row gets what is left. */
    double shade_ms = pf_time_ms() - f->start_ms - progress->trace_ms - progress->grid_ms -
                      progress->caustic_ms;
    final_progress done = *progress;
    final_frame_free(renderer->ctx, f);
    run->state = NULL;
    if (status != PF_OK) {
        pf_stage_forget(memory);
        pf_image_free(run->image);
        pf_error_prefix(err, "final render (%ux%u, %u triangles)", settings->width,
                        settings->height, run->frame->triangle_count);
        return status;
    }
    for (int stage = PF_STAGE_PHOTON_TRACE; stage <= PF_STAGE_CAUSTIC_MAP; stage++) {
        if (plan->emitters.count > 0)
            pf_stage_remember(memory, plan, (pf_stage_id)stage);
        else
            memory->valid[stage] = 0; /* no passes kept */
    }
    report_rows(run->report, plan, &done, shade_ms > 0.0 ? shade_ms : 0.0, (uint32_t)pixels,
                run->frame);
    return PF_OK;
}

/* final's photon stages and shade repeat per pass (progressive photon mapping). */
const pf_integrator pf_integrator_final = {
    (1u << PF_STAGE_PHOTON_TRACE) | (1u << PF_STAGE_PHOTON_GRID) | (1u << PF_STAGE_CAUSTIC_MAP) |
        (1u << PF_STAGE_SHADE),
    final_begin, final_run, final_end};
