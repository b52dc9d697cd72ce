/*
 * core/render: the frame pipeline. A pf_renderer owns the GPU pipelines and the
 * per-scene caches that let consecutive frames reuse work; pf_render_frame runs
 * the stages a frame needs and reports one pf_stage_timing per stage (run or
 * skipped, with the reason), which the worker stores in the queue database.
 *
 * Where a frame goes: pf_frame_render (pipeline.c) evaluates the scene,
 * calls pf_render_frame and writes the EXR; pf_render_frame (render_frame.c)
 * lets auto pick a preset (plan.c), plans every stage (stage_plan.c: run,
 * reuse or skip, with parameters and reasons) and runs the plan in one
 * stage loop through the preset's integrator (frame_direct.c,
 * frame_reference.c, frame_fast.c, frame_final.c). The settings' one codec
 * is settings.c. `render` and the queue worker both come in through
 * pf_frame_render.
 */
#ifndef PF_RENDER_H
#define PF_RENDER_H

#include "pf_bih.h"
#include "pf_common.h"
#include "pf_image.h"
#include "pf_lpv.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

typedef struct pf_renderer pf_renderer;

typedef enum pf_quality {
    PF_QUALITY_PREVIEW = 0, /* direct light only, hard shadows (foundation) */
    PF_QUALITY_FAST = 1,
    PF_QUALITY_FINAL = 2,
    PF_QUALITY_REFERENCE = 3,
    PF_QUALITY_AUTO = 4
} pf_quality;

/* Parses "preview", "fast", "final", "reference", "auto"; -1 if unknown. */
int pf_quality_parse(const char *name);
const char *pf_quality_name(pf_quality quality);

/*
 * The pixel filter every preset samples camera rays through (filter
 * importance sampling: each sample weighs the same, a pixel is the mean of
 * its samples). Gaussian is the default: σ = 0.5 px truncated at 1.5 px,
 * smooth enough that the few samples of a farm frame do not alias, and the
 * filter every stored reference and test figure was made with. Box (width
 * 1, the pixel's own square) matches renderers that do not filter;
 * Blackman-Harris (width 1.5, separable) is Cycles' default, for
 * comparisons with it. Images made with different filters differ at every
 * edge whatever the integrator, which `compare` warns about.
 */
typedef enum pf_pixel_filter {
    PF_FILTER_GAUSSIAN = 0,
    PF_FILTER_BOX = 1,
    PF_FILTER_BLACKMAN_HARRIS = 2
} pf_pixel_filter;
#define PF_PIXEL_FILTER_COUNT 3u
/* The specialisation constant (pixel_filter.glsl's PIXEL_FILTER) that compiles a kernel
 * for one filter: llvmpipe runs every filter's code, masked, for every camera ray
 * otherwise (the Blackman-Harris bisection's sines were ~half of a camera sample). */
#define PF_SPEC_PIXEL_FILTER 1007u

/* Parses "gaussian", "box", "blackman-harris"; -1 if unknown. */
int pf_pixel_filter_parse(const char *name);
const char *pf_pixel_filter_name(pf_pixel_filter filter);

/*
 * --denoise: whether the `denoise` stage (denoise.c) filters the indirect light of fast,
 * final and reference frames (preview, direct light alone, never). auto: on for final and
 * reference, whose indirect light is sampled (bench/RESULTS.md, "Denoising": 2.9× and 1.8×
 * lower relMSE on the Cornell box), off for fast, whose indirect light is the LPV's, smooth
 * already (its error is bias: 0.0161 against 0.0159 denoised).
 *
 * on (and auto where it filters) also reuses the previous frame of the sequence when this
 * renderer denoised it (temporal reuse, denoise_temporal.c), and draws each frame's camera
 * samples from a seed of its own (pf_render_settings.sample_salt) so that frames average
 * out; spatial filters each frame alone, its samples the seed's, as off leaves them.
 */
typedef enum pf_denoise_mode {
    PF_DENOISE_AUTO = 0,
    PF_DENOISE_ON = 1,
    PF_DENOISE_OFF = 2,
    PF_DENOISE_SPATIAL = 3
} pf_denoise_mode;
#define PF_DENOISE_AUTO_TEXT "on for final and reference"

/* Parses "auto", "on", "off", "spatial"; -1 if unknown. */
int pf_denoise_parse(const char *name);
const char *pf_denoise_name(pf_denoise_mode mode);
/* Whether a frame rendered by preset (auto resolved) is denoised under mode. */
int pf_denoise_applies(pf_denoise_mode mode, pf_quality preset);
/* Whether it is denoised with temporal reuse (applies, and mode is not spatial). */
int pf_denoise_temporal(pf_denoise_mode mode, pf_quality preset);

/* Most bounces --max-bounces accepts. */
#define PF_MAX_BOUNCES_LIMIT 1024u

typedef struct pf_render_settings {
    uint32_t width, height;
    pf_quality quality;
    uint32_t samples_per_pixel; /* 0 = the preset's default */
    uint64_t seed;
    int aovs;                   /* 1: fill albedo/normal/depth layers */
    /*
     * Reference and final: stop accumulating samples (final: passes) once this much wall time has
     * passed since pf_render_frame began (BIH build and upload included; at
     * least 1 spp is always rendered, and a pass in flight finishes);
     * 0 = no limit.
     */
    double time_budget_ms;
    /* final: photons emitted per progressive pass; fast: photons per frame; 0 = the preset's default. */
    uint32_t photons_per_pass;
    /* fast: the light propagation volumes (all 0 = defaults; pf_lpv.h). */
    pf_lpv_settings lpv;
    pf_pixel_filter pixel_filter;
    /*
     * reference and final: 0 = no limit (the preset's own bound); otherwise
     * 1 + the most bounces light may take (so 1 is direct light only). A
     * bounce is a scattering after the first surface the camera sees, as
     * in Cycles' "total" bounces: bounces B allow light that scattered at
     * most B times before reaching that surface. reference counts every
     * scattering (diffuse and specular); final limits its photon paths to
     * B hits and, with B = 0, leaves out caustics and the final gather
     * (the specular vertices of camera and gather rays are not counted).
     */
    uint32_t bounce_limit;
    /*
     * auto: what to plan for (the planner, core/render/plan.c). budget_ms:
     * wall time per frame to aim at; target_relmse: the error to reach. Both
     * 0 = fast. A pilot render on the first frame calibrates either.
     */
    double budget_ms;
    double target_relmse;
    /* The frame's EXR: 32-bit float pixels instead of half (the frame
     * pipeline's, carried here so that a job's frames are written as asked). */
    int float_pixels;
    /* The denoise stage (pf_denoise_mode). */
    pf_denoise_mode denoise;
    /*
     * Not a job setting (the codec leaves it out): the frame pipeline sets it to the frame
     * number, and where the frame is denoised with temporal reuse (pf_denoise_temporal) the
     * camera samples' seed is the seed mixed with it, so that consecutive frames' noise is
     * independent and their average converges. 0, or any other frame: the seed alone.
     */
    uint64_t sample_salt;
    /*
     * Not a job setting either: the frame pipeline sets it (PF_TEMPORAL_WARM_UP) on a frame
     * that starts a run of consecutive frames on this worker with no previous frame to blend,
     * and the planner multiplies the preset's samples (final: passes) by it, so that the
     * frame meets its neighbours from another worker, whose history averages many frames,
     * with a fraction of the difference (issue 40's seam). 0 or 1: as planned.
     */
    uint32_t sample_scale;
    /*
     * Not a job setting either: the layers that stages after the render will add to the
     * image (PF_LATER_LAYER_*), which the frame pipeline knows before it renders. The split
     * integrators (fast, final, reference) then create the image with their channels
     * (zero), and the motion and denoise stages fill them in place instead of copying the
     * whole image into a wider one (two copies of ~170 MB for a 1920x1080 frame with AOVs).
     * 0: none; the stages append them.
     */
    uint32_t later_layers;
    /*
     * Not a job setting either: the band of rows this render is of a taller image, which
     * pf_render_preset renders in bands where its film would exceed one device buffer
     * (render_bands.c). The camera, the samples' seeds and every decision that follows the
     * image's size are the whole image's, so each band renders the rows the whole would.
     * band_image_height 0: the render is the whole image.
     */
    uint32_t band_row_first, band_image_height;
} pf_render_settings;

/* pf_render_settings.later_layers: motion.X/Y (the motion stage), noisy.R/G/B and
 * variance.Y (the denoise stage keeping the beauty as rendered). */
#define PF_LATER_LAYER_MOTION 1u
#define PF_LATER_LAYER_NOISY 2u

/* The sample scale of a run's first frame without history (pf_render_settings.sample_scale). */
#define PF_TEMPORAL_WARM_UP 4u

/* What every field means when nobody asked otherwise: auto quality, AOVs on, the rest 0. */
static inline pf_render_settings pf_render_settings_default(void)
{
    pf_render_settings settings = {0};
    settings.quality = PF_QUALITY_AUTO;
    settings.aovs = 1;
    return settings;
}

/* bounce_limit for "--max-bounces bounces" (bounces ≤ PF_MAX_BOUNCES_LIMIT). */
static inline uint32_t pf_bounce_limit(uint32_t bounces) { return bounces + 1u; }

#define PF_STAGE_NAME_MAX 32
#define PF_STAGE_REASON_MAX 160
/* Counters a row holds: final's shade row has 26 with many lights in bands (its work, the
 * host's traces, the device traffic, light_samples, bands, band_rows, overlap_ms); one past the
 * last is dropped. */
#define PF_STAGE_COUNTERS_MAX 32
/* Rows a frame's report holds: a `fast` frame under auto with denoising has 15 (plan,
 * scene_eval, deform, textures, bih_build, photon_trace, caustic_map, the three LPV stages,
 * shade, motion, temporal, denoise, exr_write); a row past the last is dropped. */
#define PF_FRAME_STAGES_MAX 24

typedef struct pf_stage_counter {
    char name[32];
    double value;
} pf_stage_counter;

typedef struct pf_stage_timing {
    char stage[PF_STAGE_NAME_MAX];  /* scene_eval, bih_build, shade, exr_write, ... */
    int skipped;                    /* 1: not run; reason says why */
    char reason[PF_STAGE_REASON_MAX];
    double wall_ms;
    double gpu_ms;                  /* < 0 when no GPU work or no timestamps */
    uint32_t counter_count;
    pf_stage_counter counters[PF_STAGE_COUNTERS_MAX];
} pf_stage_timing;

typedef struct pf_frame_report {
    pf_quality quality;             /* the preset that rendered (auto: the planner's choice) */
    uint32_t stage_count;
    pf_stage_timing stages[PF_FRAME_STAGES_MAX];
    uint64_t discarded_samples;     /* NaN/Inf samples kept off the film */
} pf_frame_report;

/* Appends a stage row; returns it (NULL when the report is full). */
pf_stage_timing *pf_frame_report_add(pf_frame_report *report, const char *stage);
void pf_stage_add_counter(pf_stage_timing *stage, const char *name, double value);

pf_status pf_renderer_create(pf_vk_context *ctx, pf_renderer **out, pf_error *err);
void pf_renderer_destroy(pf_renderer *renderer);
/* The device context it renders with (the one it was created with). */
pf_vk_context *pf_renderer_context(const pf_renderer *renderer);

/* Where the bih_build stage builds a fresh tree (core/render/frame_bih.c). */
typedef enum pf_bih_build_site {
    PF_BIH_BUILD_AUTO = 0, /* the default: on the CPU when the device is the CPU, else the GPU */
    PF_BIH_BUILD_CPU,
    PF_BIH_BUILD_GPU
} pf_bih_build_site;

/* Forces the build site of later frames (tests cover both paths with it). */
void pf_renderer_set_bih_build(pf_renderer *renderer, pf_bih_build_site site);

/* Forces where fast's LPV propagation runs in later frames (pf_lpv_set_site: tests cover
 * the device's path on lavapipe, where AUTO picks the host). */
void pf_renderer_set_lpv_site(pf_renderer *renderer, pf_lpv_site site);

/*
 * Where the `deform` stage deforms vertices (issue 39; deform_device.c). AUTO: the host
 * where the device is the CPU (its vector loop is faster there), else the device. Tests
 * force either.
 */
typedef enum pf_deform_site {
    PF_DEFORM_AUTO = 0,
    PF_DEFORM_HOST,
    PF_DEFORM_DEVICE
} pf_deform_site;

void pf_renderer_set_deform_site(pf_renderer *renderer, pf_deform_site site);

/*
 * The `deform` stage of a frame pf_scene_eval_rigid evaluated at time_seconds: fills the
 * deforming meshes' vertices (pf_scene_deform) where the renderer's site says, and adds its
 * row ("2 skinned meshes, 1 morphed, 18,432 vertices, on the host (...)", counters
 * skinned_meshes, morphed_meshes, vertices, on_device), or a skipped row without them.
 */
pf_status pf_render_deform(pf_renderer *renderer, const pf_scene *scene, double time_seconds,
                           pf_scene_frame *frame, pf_frame_report *report, pf_error *err);

/*
 * Who traces the rays the host can trace (issue 43): reference's (a wavefront, one path
 * vertex a dispatch: render_reference_wave.comp), final's camera and gather rays, final's
 * and fast's photons. AUTO: the host, with the wide AVX2 BIH traversal on every core, where
 * the device is the CPU and its memory the host's, unless the tree was built on the
 * device; elsewhere the device. Alpha-tested materials stay with the host: its traversal has
 * no textures, so the kernels test the hits it finds and go on past those that do not count
 * themselves (bih_traverse.glsl trace_bih_surfaces_after). The stage planner says which
 * and why, in the rows; tests and benches force either. Setting it forgets what the photon stages kept, so that the next
 * frame traces its photons where it says.
 */
typedef enum pf_trace_site {
    PF_TRACE_AUTO = 0,
    PF_TRACE_DEVICE,
    PF_TRACE_HOST
} pf_trace_site;

void pf_renderer_set_trace_site(pf_renderer *renderer, pf_trace_site site);

/*
 * Renders one frame of an evaluated scene into image (allocated here) with
 * the integrator of settings->quality and appends its stage rows to report
 * (may be NULL): `bih_build`, then `shade` (counters samples_per_pixel,
 * rays, ...). Before any stage runs, the stage planner (stage_plan.c)
 * decides for each stage of the preset whether it runs (its row's reason
 * names the inputs that changed since the output it would replace was made,
 * "traced: lights changed"), reuses the previous frame's output (row
 * skipped, "... unchanged → ... reused") or is not needed (row skipped with
 * what the scene lacks); every row carries its reason. Image is owned by
 * the caller (pf_image_free). Fails with
 * PF_ERR_INVALID on a bad size, time budget or LPV setting, PF_ERR_LIMIT
 * when the film or an LPV volume would not fit a device
 * buffer or a ray overflowed the BIH traversal stack.
 *
 * auto: the planner (core/render/plan.c) picks the preset and its samples
 *   and records why in a first row `plan` (run, its reason the decision):
 *   preview without lights; fast without budget_ms or target_relmse (the
 *   farm default); with either, a pilot render on the first frame of a
 *   scene and request (a quarter of the size each way) predicts fast's time
 *   and final's time per pass, or their errors against a higher-sample
 *   estimate, and final gets the passes that fit (at least 4), else fast,
 *   else preview. The decision is kept for the frames after it.
 *   report->quality says which preset rendered.
 *
 * preview: direct light with hard shadows through specular chains;
 *   channels R,G,B,A and, with settings->aovs, albedo.R/G/B, normal.X/Y/Z,
 *   depth.Z. samples_per_pixel 0 = 1 (pixel centres).
 *
 * reference: the unbiased path tracer (shaders/render_reference.comp: NEE +
 *   MIS, Russian roulette, Owen-scrambled Sobol, settings->pixel_filter,
 *   settings->bounce_limit). samples_per_pixel (0 = 64) are
 *   accumulated in whole-image passes until that count or until
 *   time_budget_ms has passed (at least one pass); the image depends only on
 *   the scene, the seed and the number of passes reached (bit-identical for
 *   equal ones). Channels, in order: R,G,B,A, direct.R/G/B, indirect.R/G/B,
 *   caustic.R/G/B, then with aovs albedo.R/G/B, normal.X/Y/Z, depth.Z.
 *   With E the camera, S a specular vertex (mirror, glass), D a diffuse one,
 *   L a light and D₁ the first diffuse vertex from the camera:
 *     direct   = L S* E and L D₁ S* E (emission seen directly or through
 *                specular chains; light reaching D₁ straight from a light),
 *     indirect = all other paths (light that scattered before reaching D₁),
 *     caustic  = the part of indirect that was only specular between the
 *                light and D₁: L S+ D₁ S* E (area lights only: a path tracer
 *                cannot find caustics of punctual lights),
 *   so R,G,B = direct + indirect exactly (float sum of the two channels) and
 *   caustic ⊆ indirect, matching what the photon-map presets compute as
 *   direct light, indirect light and caustic map. A = fraction of samples
 *   whose camera ray hit geometry. A sample with any NaN/Inf value adds
 *   nothing to any channel; it is counted in report->discarded_samples and
 *   the shade row's "discarded_samples", and every channel of the pixel is
 *   the mean over its kept samples (0 when none). The shade row's counters:
 *   samples_per_pixel (reached), paths, rays, discarded_samples.
 *
 * fast: direct light by the reference's NEE, diffuse indirect light from
 *   cascaded light propagation volumes and caustics from a caustic map
 *   (frame_fast.c, shaders/render_fast.comp, core/lpv): the reference's
 *   channels with the same split (indirect = LPV + caustic). One photon
 *   pass of settings->photons_per_pass photons (0 = 32,768) gives the VPLs
 *   (every diffuse hit, reflected flux) and the caustic map; settings->lpv
 *   the cascades; the LPV's light is scaled to the photons' energy (shade's
 *   lpv_energy_scale; lpv.unscaled: not); samples_per_pixel (0 = 2) camera
 *   samples. Rows:
 *   bih_build, photon_trace, caustic_map, lpv_geometry, lpv_inject,
 *   lpv_propagate, shade, each skipped with its reason when the scene does
 *   not need it or the previous frame's result still holds.
 *
 * final: photon mapping (frame_final.c, shaders/render_final.comp), the
 *   reference's channels with the same split: direct = the reference's NEE at
 *   D₁ plus emission seen through specular chains; caustic = the caustic
 *   map's estimate at D₁ (k nearest); indirect = caustic + final gather
 *   (4 cosine gather rays per sample from D₁, global map (every diffuse hit) at their
 *   first diffuse hit). Progressive photon passes (probabilistic PPM, Knaus & Zwicker
 *   2011, α = 2/3): each pass traces settings->photons_per_pass photons
 *   (0 = 100,000) with its own seed, grids them at the pass's shrinking
 *   radius and adds one camera sample per pixel; samples_per_pixel is the
 *   number of passes (0 = 4), cut short by time_budget_ms (at least one).
 *   Rows: bih_build, photon_trace, photon_grid, caustic_map (skipped with
 *   its reason without specular materials), shade; photon_trace and
 *   photon_grid are skipped when lights, materials and geometry are
 *   unchanged since the previous final frame (maps reused). The image
 *   depends only on the scene, seed, photons per pass and passes reached.
 *   Samples cut by lavapipe's loop cap are dropped and counted (shade row
 *   `loop_truncated`, discarded_samples); over 1% of them fails the frame
 *   with PF_ERR_LIMIT.
 *
 * fast, final and reference render a frame whose film exceeds one device buffer in bands of
 * rows (pf_renderer_set_band_bytes says how), the same image with one row a stage.
 */
pf_status pf_render_frame(pf_renderer *renderer, const pf_scene_frame *frame,
                          const pf_render_settings *settings, pf_image *image,
                          pf_frame_report *report, pf_error *err);

/*
 * Ray casting oracle: every ray against every triangle on the GPU with the
 * watertight test (Woop et al. 2013); pf_ray / pf_hit are defined in pf_bih.h.
 * The BIH is tested against this.
 */
pf_status pf_raycast_brute_force(pf_renderer *renderer, const pf_scene_frame *frame,
                                 const pf_ray *rays, uint32_t ray_count, pf_hit *hits,
                                 pf_error *err);

/* ---- The settings codec (core/render/settings.c) ---- */

/*
 * The one codec of pf_render_settings: JSON such as
 * {"width":640,"height":480,"quality":"auto","spp":0,"seed":0} plus every
 * field that differs from pf_render_settings_default() ("time_budget_ms",
 * "photons", "aovs", "float", "filter", "max_bounces", "budget_ms",
 * "target_relmse", "lpv"). `enqueue` stores it in the queue (jobs.parameters),
 * the worker reads it back for every task, and every EXR carries it as
 * photonfarm/settings. The bounds below are the command line's too
 * (cli_settings.c), so whatever one accepts the other does.
 */
#define PF_SETTINGS_MAX_SPP 65536
/* 2^53: the largest integer a JSON number carries exactly. */
#define PF_SETTINGS_MAX_SEED 9007199254740992ll
#define PF_SETTINGS_MAX_PHOTONS 100000000ll
/* --time-budget (a progressive preset's stop): a week. */
#define PF_SETTINGS_MAX_TIME_BUDGET_MS 604800000.0
/* --budget-ms (auto's aim per frame): a day. */
#define PF_SETTINGS_MAX_BUDGET_MS 86400000.0
#define PF_SETTINGS_MAX_TARGET_RELMSE 100.0

/* Formats settings as the JSON object above into out (0 if it does not fit). A job's
 * parameters add the farm's own keys to it (worker/job_extras.h). */
int pf_settings_format(const pf_render_settings *settings, char *out, size_t size);

/*
 * Parses a job's parameters into *settings (absent keys keep their defaults:
 * size 0x0 = the default size, auto quality, the preset's spp, seed 0, AOVs on).
 * Text that is not a JSON object, an unknown quality or an out-of-range number
 * → PF_ERR_FORMAT naming the key.
 */
pf_status pf_settings_parse(const char *json, pf_render_settings *settings, pf_error *err);

/*
 * A frame of fast, final or reference whose film (48 bytes a pixel, the largest of their
 * per-pixel buffers) exceeds one device buffer (maxStorageBufferRange: 128 MiB on lavapipe,
 * a 2560x1440 film is 169 MiB) is rendered in bands of rows, each its own film, and the
 * bands' images and rows joined (render_bands.c); the image is the one a single band would
 * make. The device's denoiser, whose planes are 16 bytes a pixel, leaves a frame past one
 * buffer to the host's. Tests: at most this many bytes a buffer, for both (0: the device's
 * range).
 */
void pf_renderer_set_band_bytes(pf_renderer *renderer, uint64_t film_bytes);

/*
 * The motion vectors AOV (motion_vectors.c): fills channels motion.X and motion.Y of
 * image (where it was created with them: PF_LATER_LAYER_MOTION; else appended), the
 * screen-space offset in pixels from each pixel's visible point to where that
 * point was in `previous` (the scene evaluated one frame earlier), with Cycles' Vector
 * pass convention: previous raster position minus this one, x right, y up; 0 where the
 * pixel sees nothing. Uses the tree pf_render_frame left for frame; adds a `motion` row.
 * depth_change (NULL: not wanted; else one float per pixel): how much farther the point was
 * from the previous camera than it is from this one (0 where nothing is seen), which the
 * temporal denoiser checks the previous frame's depth against.
 */
pf_status pf_render_motion(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_scene_frame *previous, pf_image *image, float *depth_change,
                           pf_frame_report *report, pf_error *err);

/*
 * Temporal reuse (denoise_temporal.c): what the denoiser keeps of the frame it denoised
 * last (its accumulated lighting, normals, depths and per-pixel history lengths), so that
 * the next frame of the same sequence can reproject and blend it (SVGF, Schied et al.
 * 2017). A renderer holds one (pf_renderer_denoise_history); tests make their own.
 */
typedef struct pf_denoise_history pf_denoise_history;
pf_status pf_denoise_history_create(pf_denoise_history **out, pf_error *err);
void pf_denoise_history_destroy(pf_denoise_history *history);
pf_denoise_history *pf_renderer_denoise_history(pf_renderer *renderer);

/* What the denoiser is told of a frame of a sequence, beyond its image. */
typedef struct pf_denoise_sequence {
    pf_denoise_history *history; /* NULL: spatial only (--denoise spatial) */
    /* Frames that may reuse one another share it (pf_frame_render: the scene's load and the
     * job's settings); 0: never reuse. */
    uint64_t sequence;
    int64_t frame;     /* reuse comes only from frame - 1 */
    uint64_t lighting; /* fingerprint of the lights and materials: a change drops the history */
    uint64_t geometry; /* fingerprint of the geometry: a change shortens the memory */
    /* pf_render_motion's depth_change for this image (NULL: every point is where it was).
     * The image's motion.X/Y channels say where each pixel's point was (none: nowhere else). */
    const float *depth_change;
    /* Frames this image counts as in the history it starts (its sample scale; 0: 1). */
    float first_length;
} pf_denoise_sequence;

/* Whether history holds the frame before sequence's, at this size: 1, else 0 and why not
 * in reason ("no previous frame on this worker", "frame 12 came before: not consecutive"). */
/* Whether history holds the frame before frame of sequence, at this size: the usable check
 * without the fingerprints, which a frame has only once it is planned. */
int pf_denoise_history_continues(const pf_denoise_history *history, uint64_t sequence,
                                 int64_t frame, uint32_t width, uint32_t height);
int pf_denoise_history_usable(const pf_denoise_history *history,
                              const pf_denoise_sequence *sequence, uint32_t width,
                              uint32_t height, char *reason, size_t size);

/* Where the denoise stage's filter runs (the temporal blend and the write-back run on the
 * host either way). */
typedef enum pf_denoise_site {
    PF_DENOISE_SITE_AUTO = 0, /* the host when the device is the CPU (measured faster:
                               * bench/RESULTS.md, "Denoising"), else the device */
    PF_DENOISE_SITE_HOST,
    PF_DENOISE_SITE_DEVICE    /* shaders/denoise_variance.comp, shaders/denoise_atrous.comp */
} pf_denoise_site;

/* Forces where later frames' filter runs (tests cover the device's path on lavapipe). */
void pf_renderer_set_denoise_site(pf_renderer *renderer, pf_denoise_site site);

/*
 * The denoise stage (denoise.c): filters image's indirect light (less its caustics) in place,
 * guided by its albedo, normal and depth channels, and updates the beauty to direct +
 * indirect; the image must have the split layers and those AOVs. Appends a `denoise` row.
 * keep_noisy: also appends noisy.R/G/B (the beauty as rendered) and variance.Y (the
 * estimated variance of the lighting's luminance the filter started from).
 * sequence (NULL: this image alone, no row): first blends the previous frame's lighting
 * where history holds it and it still matches (a `temporal` row, run or skipped with why),
 * then leaves this frame's in history for the next.
 */
pf_status pf_denoise_image(pf_image *image, int keep_noisy, const pf_denoise_sequence *sequence,
                           pf_frame_report *report, pf_error *err);
/* The same, the filter run where renderer's denoise site says (pf_denoise_image: the host);
 * the row says where, and has the kernels' GPU time when on the device. */
pf_status pf_render_denoise(pf_renderer *renderer, pf_image *image, int keep_noisy,
                            const pf_denoise_sequence *sequence, pf_frame_report *report,
                            pf_error *err);

/* ---- One frame from scene to file (core/render/pipeline.c) ---- */

/*
 * One frame from an evaluated scene to a finished EXR, shared by `photonfarm
 * render` and the queue worker so the frame code exists once (DESIGN.md §4):
 *
 *   pf_scene_eval_rigid      → stage row "scene_eval"
 *   pf_scene_deform          → stage row "deform" (skipped without skins or morph targets)
 *   pf_render_frame          → the renderer's GPU stage rows
 *   pf_render_motion         → stage row "motion" (with AOVs, or for temporal reuse)
 *   pf_render_denoise        → stage rows "temporal" and "denoise" (where --denoise applies)
 *   pf_exr_write to a temporary name beside the output → stage row "exr_write"
 *
 * With write_behind the frame stops before the write and keeps the image:
 * pf_frame_write then writes it, on any thread, so that a worker renders the
 * next frame meanwhile (issue 43: a GPU is not left idle for the EXR's
 * compression). The file is the same either way.
 *
 * The frame stops at the temporary and hands it back, so the caller can
 * re-check its lease before pf_frame_commit renames it into place (or
 * pf_frame_discard deletes it). Temporaries are named "<output>.partial-<tag>"
 * (and pf_exr_write's own "<that>.tmp-<pid>-<n>"), so every leftover of a
 * crashed worker for one output starts with "<output>.partial-" and
 * pf_frame_remove_stale can find it.
 */



#define PF_FRAME_PATH_MAX 4096
/* Default image width when none is asked for (the height follows the camera). */
#define PF_FRAME_DEFAULT_WIDTH 640u
#define PF_FRAME_DEFAULT_HEIGHT 480u
/* Largest image side (pf_render_frame's own limit). */
#define PF_FRAME_MAX_EDGE 16384u

typedef struct pf_frame_request {
    const pf_scene *scene;
    const char *scene_path;        /* recorded as metadata */
    int64_t frame;                 /* 1-based */
    pf_render_settings settings;   /* width 0: PF_FRAME_DEFAULT_WIDTH, height from the camera */
    const char *output_path;       /* final path of the EXR */
    const char *temp_tag;          /* makes the temporary name unique (a lease token, a pid) */
    const char *device_name;       /* recorded as metadata */
    /* Checked between stages; non-zero stops the frame (NULL: never). Set
     * from another thread, e.g. when a lease is lost. */
    const atomic_int *abort;
    /* Frames this process renders next with the same renderer, each the one after the one
     * before (frame + 1, + 2, ...): a task's chunk, a --frames range. 0: none or unknown.
     * A run's first frame with no history to blend gets PF_TEMPORAL_WARM_UP× samples. */
    uint32_t following;
    /* Non-zero: stop before the EXR write, keeping the image in out->pending for
     * pf_frame_write. The memory check then counts two frames' images: this one is
     * held while the next renders. */
    int write_behind;
} pf_frame_request;

/*
 * Where a failed frame failed; the worker decides what that means for the queue
 * (worker/frame_fault.h: whose fault it is).
 */
typedef enum pf_frame_failure {
    PF_FRAME_FAILED_RENDER = 0, /* the render itself: device, memory, limits */
    PF_FRAME_FAILED_SCENE,      /* evaluating the scene at the frame's time */
    PF_FRAME_FAILED_OUTPUT      /* writing, checking or committing the EXR */
} pf_frame_failure;

typedef struct pf_frame_output {
    char final_path[PF_FRAME_PATH_MAX];
    char temp_path[PF_FRAME_PATH_MAX]; /* "" when no temporary exists */
    pf_frame_report report;            /* scene_eval, GPU stages, exr_write */
    uint32_t width, height;            /* as rendered */
    double total_ms;
    int aborted;                       /* the abort flag stopped it; nothing on disk */
    pf_frame_failure failed;           /* after a failure: where it failed */
    /* What the frame took (issue 42), filled as far as it got: the most device memory
     * its context held at once from the frame's start (pf_vk_memory_use: the buffers
     * it keeps across frames included), and the bytes of the EXR it wrote. */
    uint64_t peak_device_bytes;
    uint64_t bytes_written;
    /* write_behind: the rendered image and its metadata until pf_frame_write (or
     * pf_frame_discard) takes them; NULL otherwise. */
    struct pf_frame_pending *pending;
} pf_frame_output;

/*
 * Renders request->frame to the temporary beside output_path and fills out.
 * On success the complete EXR (fsynced) lies at out->temp_path, unless
 * out->aborted (the abort flag was seen between stages: nothing is left on
 * disk). On failure nothing is left on disk, err names the scene/frame or
 * the file and out->failed says where it failed (scene evaluation, the
 * render, the EXR).
 */
pf_status pf_frame_render(pf_renderer *renderer, const pf_frame_request *request,
                          pf_frame_output *out, pf_error *err);

/*
 * Writes a frame rendered with write_behind (out->pending) to its temporary
 * and adds its "exr_write" row; out->total_ms grows by the write's time. The
 * outcomes are pf_frame_render's for the write: on failure nothing is left
 * on disk and out->failed is PF_FRAME_FAILED_OUTPUT. The pending image is
 * freed either way. Touches nothing but out, so it may run on another thread
 * while the renderer renders the next frame.
 */
pf_status pf_frame_write(pf_frame_output *out, pf_error *err);

/* Renames the temporary into place and fsyncs the directory. On failure the
 * temporary is removed, err names both paths and out->failed is PF_FRAME_FAILED_OUTPUT. */
pf_status pf_frame_commit(pf_frame_output *out, pf_error *err);

/*
 * Before anything renders: the output pattern's directory exists and this
 * process can create files in it (a probe file is made and removed), and a #
 * run lies in the file name. Fills absolute with the pattern made absolute
 * (workers may run elsewhere). PF_ERR_IO/PF_ERR_INVALID naming the directory.
 */
pf_status pf_frame_output_check(const char *pattern, char *absolute, size_t size, pf_error *err);

/* Host bytes per pixel a frame holds at once: the rendered image (11 float
 * channels: RGBA and the AOV layers) and the EXR writer's copy of it. */
#define PF_FRAME_HOST_BYTES_PER_PIXEL (2u * 11u * 4u)

/*
 * Whether a width x height frame fits in available_bytes of host memory
 * (0: half of this machine's physical memory), by PF_FRAME_HOST_BYTES_PER_PIXEL.
 * PF_ERR_INVALID naming the size, the estimate and the memory otherwise, so
 * that 16384x16384 (24 GB) is refused at once instead of rendering for
 * minutes and then running out of memory.
 */
pf_status pf_frame_memory_check(uint32_t width, uint32_t height, uint64_t available_bytes,
                                pf_error *err);

/* Deletes the temporary, if any, and frees a pending image (a lost lease, an error). */
void pf_frame_discard(pf_frame_output *out);

/*
 * Removes the temporaries whose tag (pf_frame_request.temp_tag) starts with
 * tag_prefix at output_path: "<output_path>.partial-<tag_prefix>*", the
 * leftovers of earlier attempts that tagged them so. Nothing else is touched.
 * Returns how many files were removed.
 */
int pf_frame_remove_partials(const char *output_path, const char *tag_prefix);

/* Splits path into its directory ("." when none, "/" at the root) and its file name. */
void pf_frame_split_path(const char *path, char *dir, size_t dir_size, const char **base);

/* Replaces the first run of '#' in pattern with the zero-padded frame number
 * (a pattern without '#' is used as is). 0 if the result does not fit. */
int pf_frame_output_path(const char *pattern, int64_t frame, char *out, size_t size);

#endif
