/*
 * core/render internals shared by its .c files: the renderer object, the GPU
 * copy of one frame's scene, and the std430 structs whose GLSL mirrors live in
 * shaders/common/scene_types.glsl (keep both in step).
 */
#ifndef PF_RENDER_INTERNAL_H
#define PF_RENDER_INTERNAL_H

#include "pf_photon.h"
#include "pf_render.h"

/* auto's decision for one scene and request (plan.c), kept for the frames after it. */
struct pf_plan_cache {
    int valid; /* calibrated by a pilot for the request below */
    uint32_t triangle_count, light_count, material_count, width, height;
    double budget_ms, target_relmse;
    pf_quality quality;
    uint32_t passes;               /* final: passes chosen */
    double fast_ms, pass_ms;       /* predicted at the full size */
    double fast_relmse, pass_relmse;
    pf_denoise_mode denoise;       /* the request's: the pilot denoises what the frame will */
    int denoised;                  /* final is denoised: its pilot errors are after the filter */
    double denoise_ms;             /* final's denoise stage, predicted at the full size */
    double slope_relmse;           /* denoised: PLAN_SLOPE_PASSES passes' pilot relMSE */
    double slope;                  /* final's error ∝ passes^-slope (2/3 raw; measured denoised) */
    uint32_t anchor_passes;        /* the pilot point the passes are counted from: 1 raw, */
    double anchor_relmse;          /* PLAN_SLOPE_PASSES denoised, and its relMSE */
    double predicted_ms;
    char reason[PF_STAGE_REASON_MAX];
};

/*
 * The renderer's compute pipelines. Each is created the first time a frame
 * needs it, so a worker that renders `fast` never builds `final`'s, and the
 * test oracles (raycast_brute) exist only in the processes that call them
 * (issue 12): process start pays for what the job renders.
 */
typedef enum pf_renderer_pipeline_id {
    PF_PIPELINE_RAYCAST_CLOSEST, /* raycast_brute.comp, ANY_HIT = false (the oracle) */
    PF_PIPELINE_RAYCAST_ANY,     /* raycast_brute.comp, ANY_HIT = true */
    PF_PIPELINE_DIRECT,          /* render_direct.comp */
    PF_PIPELINE_REFERENCE,       /* render_reference.comp, AOVs written */
    PF_PIPELINE_REFERENCE_RGB,   /* render_reference.comp, no AOVs */
    PF_PIPELINE_MATERIAL_PROBE,  /* material_probe.comp */
    PF_PIPELINE_FINAL_PRIMARY,   /* render_final.comp */
    PF_PIPELINE_FINAL_GATHER,    /* final_gather.comp */
    PF_PIPELINE_FINAL_GATHER_ESTIMATE, /* final_gather_estimate.comp */
    PF_PIPELINE_FINAL_FALLBACK,  /* final_deferred.comp */
    PF_PIPELINE_FINAL_RESOLVE,   /* final_resolve.comp */
    PF_PIPELINE_FINAL_CAUSTIC,   /* final_caustic.comp */
    /* final where the host traces (host_rays.glsl's TRACE_STEP) */
    PF_PIPELINE_FINAL_PRIMARY_GIVEN, /* render_final.comp, HITS_GIVEN */
    PF_PIPELINE_FINAL_GATHER_RAYS,   /* final_gather_rays.comp (WRITE_RAYS) */
    PF_PIPELINE_FINAL_GATHER_GIVEN,  /* final_gather.comp, HITS_GIVEN */
    PF_PIPELINE_FINAL_GATHER_ESTIMATE_GIVEN, /* final_gather_estimate.comp, HITS_GIVEN */
    PF_PIPELINE_CAMERA_RAYS,         /* camera_rays.comp: final's camera rays */
    PF_PIPELINE_FAST,            /* render_fast.comp */
    PF_PIPELINE_FAST_CAUSTIC,    /* render_fast_caustic.comp */
    PF_PIPELINE_FAST_ENERGY,     /* render_fast_energy.comp */
    PF_PIPELINE_DENOISE_VARIANCE, /* denoise_variance.comp */
    PF_PIPELINE_DENOISE_ATROUS,  /* denoise_atrous.comp */
    PF_PIPELINE_REFERENCE_WAVE_GENERATE, /* render_reference_wave_ends.comp, WAVE_GENERATE */
    PF_PIPELINE_REFERENCE_WAVE,          /* render_reference_wave.comp, WAVE_SHADE */
    PF_PIPELINE_REFERENCE_WAVE_FINISH,   /* render_reference_wave_ends.comp, WAVE_FINISH (AOVs) */
    PF_PIPELINE_REFERENCE_WAVE_FINISH_RGB, /* render_reference_wave_ends.comp, WAVE_FINISH_RGB */
    PF_PIPELINE_REFERENCE_WAVE_TAIL,       /* render_reference_wave_tail.comp, WAVE_TAIL */
    PF_PIPELINE_DEFORM,                  /* deform.comp */
    PF_PIPELINE_SPLIT_FILM,              /* split_film.comp: the film into the image */
    PF_PIPELINE_FINAL_RETRACE_ARGS,      /* final_retrace_args.comp: the retrace's groups */
    PF_PIPELINE_COUNT
} pf_renderer_pipeline_id;


/* The final kernels' bindings (final_shared.glsl), the same in all of its pipelines. */
#define PF_FINAL_BUFFERS (PF_SCENE_BINDING_COUNT + 28u)
/* The fast kernels' bindings (fast_shade.glsl), the same in both pipelines. */
#define PF_FAST_BUFFERS (PF_SCENE_BINDING_COUNT + 15u)

/*
 * The stage plan (stage_plan.c): each stage of a frame, its decision and
 * reason, the inputs' fingerprints the decisions were taken on, and the
 * parameters the integrator renders with.
 */
typedef enum pf_stage_id {
    PF_STAGE_BIH_BUILD,
    PF_STAGE_PHOTON_TRACE,
    PF_STAGE_PHOTON_GRID,
    PF_STAGE_CAUSTIC_MAP,
    PF_STAGE_LPV_GEOMETRY,
    PF_STAGE_LPV_INJECT,
    PF_STAGE_LPV_PROPAGATE,
    PF_STAGE_SHADE,
    PF_STAGE_COUNT
} pf_stage_id;

/* What a stage's output depends on; each a 64-bit content fingerprint per frame. */
typedef enum pf_stage_input {
    PF_INPUT_GEOMETRY,   /* triangle count and vertices */
    PF_INPUT_SURFACES,   /* materials and the triangles' material indices */
    PF_INPUT_LIGHTS,     /* the punctual lights */
    PF_INPUT_PHOTONS,    /* seed, photons per pass, photon depth */
    PF_INPUT_CASCADES,   /* the LPV layout: shape, cell sizes, snapped origins */
    PF_INPUT_ITERATIONS, /* the LPV's propagation iterations per cascade */
    PF_INPUT_COUNT
} pf_stage_input;

typedef enum pf_stage_action {
    PF_STAGE_ABSENT = 0, /* not a stage of this preset */
    PF_STAGE_RUN,
    PF_STAGE_REUSE,      /* the previous frame's output holds: row skipped */
    PF_STAGE_SKIP        /* the scene does not need it: row skipped */
} pf_stage_action;

typedef struct pf_stage_decision {
    pf_stage_action action;
    char reason[PF_STAGE_REASON_MAX];
} pf_stage_decision;

/* What a preset's kept outputs were made from (one per preset, in the renderer). */
typedef struct pf_stage_memory {
    int valid[PF_STAGE_COUNT];
    uint64_t made_from[PF_STAGE_COUNT][PF_INPUT_COUNT];
    uint32_t kept_passes; /* final: photon passes kept, a prefix of the next frame's */
    uint64_t frames;      /* frames planned with this memory */
    int pilot_replaced;   /* auto's pilot dropped what the previous frame kept (pilot.c) */
} pf_stage_memory;

typedef struct pf_stage_plan {
    pf_quality preset;
    pf_stage_decision stages[PF_STAGE_COUNT];
    uint64_t inputs[PF_INPUT_COUNT];
    /* Parameters: camera samples (final: passes), photons per pass, photon depth (0:
     * the tracer's default), whether the scene gets a caustic map, final's passes
     * reused from the previous frame, fast's cascades. */
    uint32_t samples, photons, photon_depth;
    int has_specular, caustic_map;
    pf_photon_emitters emitters; /* fast, final: what photons are emitted from (plan-owned) */
    uint32_t reused_passes;
    pf_lpv_layout layout;
    /* The host traces, else the device: reference's rays (a wavefront); final's camera rays,
     * gather rays' first segments and photons; fast's photons */
    int host_traces;
    /* reference's wavefront: a wave of at most this many paths goes to the tail, which
     * runs them to their ends on the device (frame_reference_wave.c); 0: none */
    uint32_t wave_tail_paths;
    /* ... and the tails its frame would have (passes × slices), tail or not */
    uint64_t wave_tails;
} pf_stage_plan;

/*
 * What the previous frame left that a plan may reuse, and the device's limits: with the
 * frame and the settings, all a plan depends on (pf_stage_previous_of reads them off a
 * renderer; a test writes them by hand, with no device).
 */
typedef struct pf_stage_previous {
    const pf_stage_memory *memory; /* the preset's stage memory (NULL: none) */
    const pf_bih *tree;            /* the BIH kept from the previous frame (NULL: none) */
    uint64_t bih_frames;           /* frames that got a tree so far */
    int bih_pilot_replaced;        /* auto's pilot dropped the previous frame's tree */
    uint64_t max_buffer_range;     /* the device's largest storage buffer (the LPV's bound) */
    /* Who may trace reference's rays and final's gather rays: the renderer's setting,
     * whether the device is the CPU with its buffers in host memory
     * (pf_vk_storage_is_host_memory), whether this CPU has the wide traversal, and whether
     * bih_build leaves its tree on the host. */
    pf_trace_site trace_site;
    int device_is_host, host_traversal, tree_on_host;
    /* The wavefront's tail kernel compiled: bit v % 64 of word v / 64 for the surface
     * variant v; and the tails the renderer's earlier frames would have had
     * (pf_stage_plan.wave_tails summed). */
    uint64_t wave_tail_compiled[(PF_SURFACE_VARIANTS + 63u) / 64u];
    uint64_t wave_tails_before;
} pf_stage_previous;

/* Adds ms to a GPU-time total that stays < 0 while nothing was timed; an ms < 0 (no
 * timestamps) adds nothing. */
static inline void pf_gpu_ms_add(double *total, double ms)
{
    if (ms >= 0.0)
        *total = (*total < 0.0 ? 0.0 : *total) + ms;
}

/* The GPU time between two timestamp slots of submitted cmds; -1 where either is missing. */
static inline double pf_commands_gpu_ms(const pf_vk_commands *cmds, int begin, int end)
{
    return begin >= 0 && end >= 0 ? pf_vk_commands_elapsed_ms(cmds, begin, end) : -1.0;
}

/* reference's totals over the passes of one frame (frame_reference.c). */
typedef struct pf_reference_progress {
    uint32_t passes;
    uint64_t rays;
    uint64_t discarded;
    uint64_t failures;
    uint64_t truncated;   /* samples cut at llvmpipe's loop cap (discarded too) */
    double gpu_ms;        /* < 0: no timestamps */
    uint32_t waves;       /* the wavefront's dispatches */
    double host_trace_ms; /* the wavefront's trace steps on the host */
    uint64_t tail_paths;  /* paths the wavefront's tail ran to their ends on the device */
} pf_reference_progress;

/*
 * reference's passes as a wavefront whose rays the host traces (frame_reference_wave.c):
 * created for a frame (its size, its punctual lights) once bih_build has left the tree in
 * renderer->bih; run with the megakernel's buffers (frame_reference.c's binding order)
 * for count passes, adding to progress; setup (may be NULL) goes with the first dispatch,
 * and is taken either way.
 */
#define PF_REFERENCE_WAVE_MAX_BUFFERS 32u
/*
 * The wavefront's tail (render_reference_wave_tail.comp): once at most this many
 * paths of a slice go on, one dispatch runs them to their ends, tracing on the device.
 * Roulette leaves a dozen waves a pass of a few hundred paths, each costing a submission's
 * round trip (~0.2 ms on llvmpipe) more than its vertices; the device traces a ray several
 * times slower than the host, but on so few rays that costs less (bench/RESULTS.md,
 * "Eleventh stop": flat between 512 and 2,048).
 */
#define PF_REFERENCE_WAVE_TAIL_PATHS 512u
/*
 * The tail's kernel costs a worker ~0.3 s to compile, once (the renderer keeps it), and saves
 * ~2 ms a tail on this VM: it is compiled once the renderer's frames, this one included,
 * would have had this many tails (passes × slices), as a JIT compiles a hot loop: a worker's
 * job of small frames gets it after a few, a one-frame render of few passes goes without.
 */
#define PF_REFERENCE_WAVE_TAIL_MIN_TAILS 128u
/*
 * Paths in flight at once: the wavefront's image goes in slices of at most this many
 * pixels, so its buffers (~200 bytes a path plus 64 a shadow slot) stay bounded at any size.
 */
#define PF_REFERENCE_WAVE_MAX_PATHS (1u << 18)
typedef struct pf_reference_wave pf_reference_wave;
pf_status pf_reference_wave_create(pf_renderer *renderer, const pf_render_settings *settings,
                                   uint32_t light_count, uint32_t tail_paths,
                                   pf_reference_wave **out, pf_error *err);
void pf_reference_wave_destroy(pf_reference_wave *wave);
uint32_t pf_reference_wave_threads(const pf_reference_wave *wave);
pf_status pf_reference_wave_passes(pf_reference_wave *wave, pf_vk_buffer *const *reference_buffers,
                                   uint32_t reference_buffer_count,
                                   const pf_render_settings *settings, uint32_t count,
                                   pf_vk_commands *setup, pf_reference_progress *progress,
                                   pf_error *err);

/*
 * A queue of closest-hit rays that shade kernels write and the host traces in place
 * (host_rays.c; shaders/common/host_rays.glsl): final's and fast's camera rays and final's
 * gather rays where the device is the CPU. Three device buffers in host memory, bound where
 * the kernel expects them: the rays (pf_ray), their hits (pf_hit) and a word per slot, 1
 * where the slot holds a ray. Created once bih_build has left the frame's tree in
 * renderer->bih, for images of width × height pixels and up to rays_per_pixel rays a pixel; the
 * kernels then run in bands of rows, each band's rays traced at once.
 */
typedef struct pf_host_rays pf_host_rays;
pf_status pf_host_rays_create(pf_renderer *renderer, uint32_t width, uint32_t height,
                              uint32_t rays_per_pixel, const char *label, pf_host_rays **out,
                              pf_error *err);
void pf_host_rays_destroy(pf_host_rays *queue);
/* rays, hits, queue words, in that order. */
void pf_host_rays_buffers(const pf_host_rays *queue, pf_vk_buffer *out[3]);
uint32_t pf_host_rays_threads(const pf_host_rays *queue);

/* One dispatch of a host-traced kernel: pipeline, buffers, push constants, whose row_first
 * the dispatch sets. */
typedef struct pf_host_traced_step {
    pf_vk_pipeline *pipeline;
    pf_vk_buffer *const *buffers;
    uint32_t buffer_count;
    void *push;
    uint32_t push_bytes;
    uint32_t *row_first; /* in push */
} pf_host_traced_step;

/* A kernel whose rays the host traces: the step that writes them (camera_rays.comp, or the
 * kernel's own WRITE_RAYS) and the kernel's HITS_GIVEN step (host_rays.glsl). */
typedef struct pf_host_traced_kernel {
    pf_host_traced_step write, given;
    uint32_t width, height, rays_per_pixel;
} pf_host_traced_kernel;

/* camera_rays.comp's Push: the sample, the band's first row. */
typedef struct pf_camera_rays_push {
    uint32_t sample_index, row_first;
} pf_camera_rays_push;
/* camera_rays.comp's buffers: the scene's, then the queue's three. */
#define PF_CAMERA_RAYS_BUFFERS (PF_SCENE_BINDING_COUNT + 3u)
/* Fills steps's write step with camera_rays.comp over queue, its buffers (the scene's from
 * kernel_buffers, then the queue's) in buffers and its push in push. */
pf_status pf_host_rays_camera_step(pf_renderer *renderer, const pf_host_rays *queue,
                                   pf_vk_buffer *const *kernel_buffers,
                                   pf_vk_buffer *buffers[PF_CAMERA_RAYS_BUFFERS],
                                   pf_camera_rays_push *push, pf_host_traced_step *step,
                                   pf_error *err);

/* What the host's traces of a frame came to, for its shade row. */
typedef struct pf_host_trace_totals {
    double gpu_ms;  /* the submissions' GPU time (< 0: none timed) */
    double host_ms; /* the host's trace steps */
    uint64_t rays;  /* rays the host traced */
    uint32_t traces;
} pf_host_trace_totals;

/*
 * Per band of rows: `write` writes the band's rays at the end of the open submission *cmds,
 * which goes; the host traces them in place; a new submission runs `given` over the band
 * with their hits. *cmds is left open after the last band, *begin its first timestamp (the
 * GPU time of each submission from *begin to its end goes to totals). On failure *cmds may be
 * NULL.
 */
pf_status pf_host_rays_dispatch(pf_host_rays *queue, const pf_host_traced_kernel *kernel,
                                pf_vk_commands **cmds, int *begin, pf_host_trace_totals *totals,
                                pf_error *err);

/* The fingerprints' 64-bit hash, from h (PF_HASH_START for a fresh one). */
#define PF_HASH_START 0xcbf29ce484222325ull
uint64_t pf_hash_bytes(uint64_t h, const void *data, size_t bytes);

pf_stage_previous pf_stage_previous_of(const pf_renderer *renderer, pf_quality preset);

/* renderer's tree for the host to trace or measure, its clip values fitted first where a
 * device refit left them (frame_bih.c); PF_ERR_INTERNAL without a tree. */
pf_status pf_renderer_bih_host(pf_renderer *renderer, const pf_bih **out, pf_error *err);
/* The wide view of renderer->bih, built once per tree (frame_bih.c); the host's traces of a
 * frame (reference's wavefront, final's rays, the photons) share it. */
pf_status pf_renderer_bih_wide(pf_renderer *renderer, const pf_bih_wide **out, pf_error *err);
/* A host tracer of the frame's tree for up to paths paths of shadow_slots shadow rays each
 * (pf_bih_wave_tracer_create over renderer's tree and wide view); destroy it before the
 * tree changes. */
pf_status pf_renderer_wave_tracer_create(pf_renderer *renderer, uint32_t paths,
                                         uint32_t shadow_slots, pf_bih_wave_tracer **out,
                                         pf_error *err);
/* Forgets the wide view: renderer->bih changed or is gone. */
void pf_renderer_bih_wide_drop(pf_renderer *renderer);

/* Plans the frame's stages for settings->quality (not auto): a pure function of its
 * arguments. PF_ERR_LIMIT for LPV settings the device cannot hold, PF_ERR_NOMEM. */
pf_status pf_plan_stages(const pf_scene_frame *frame, const pf_render_settings *settings,
                         const pf_stage_previous *previous, pf_stage_plan *plan, pf_error *err);
/* Frees what the plan owns (its emitters); a zeroed plan is fine. */
void pf_stage_plan_release(pf_stage_plan *plan);
/* Run (naming the changed inputs) or reuse, by memory's fingerprints for the stage. */
void pf_stage_decide(pf_stage_plan *plan, pf_stage_id stage, const pf_stage_memory *memory);
void pf_stage_skip(pf_stage_plan *plan, pf_stage_id stage, const char *reason);
/* After the stage ran: its output is now made from the plan's inputs. */
void pf_stage_remember(pf_stage_memory *memory, const pf_stage_plan *plan, pf_stage_id stage);
/* After a failure: nothing kept holds. */
void pf_stage_forget(pf_stage_memory *memory);
const char *pf_stage_name(pf_stage_id stage);
/* The row of a planned stage: skipped unless it runs, with the plan's reason. */
pf_stage_timing *pf_stage_row(pf_frame_report *report, const pf_stage_plan *plan,
                              pf_stage_id stage, double wall_ms, double gpu_ms);
/* bih_build's decision: reuse the kept tree for bitwise-equal triangles, else build or
 * refit (frame_bih.c carries it out). */
void pf_bih_plan(const pf_stage_previous *previous, const pf_scene_frame *frame,
                 pf_stage_decision *decision);

/*
 * One frame as the stage loop (render_frame.c) carries it through an
 * integrator: the plan, the caller's outputs and the integrator's own state.
 */
typedef struct pf_frame_run {
    pf_renderer *renderer;
    const pf_scene_frame *frame;
    const pf_render_settings *settings;
    const pf_stage_plan *plan;
    pf_image *image;            /* created by the integrator, freed by it on failure */
    pf_frame_report *report;    /* may be NULL */
    double start_ms;            /* when the frame began: time budgets count from here */
    void *state;                /* the integrator's, from begin to end */
    /* Each stage's device traffic (issue 44), metered by the stage loop around the calls
     * it makes: textures and bih_build around their preparation, every other stage around
     * integrator->run, shade also around begin and end (the scene upload, the film's
     * readback); added to the rows as counters once end has written them. */
    pf_vk_traffic traffic[PF_STAGE_COUNT];
    pf_vk_traffic textures_traffic;
    uint32_t passes; /* the plan's samples (final: passes), or fewer where a time budget ended them */
} pf_frame_run;

/*
 * An integrator (frame_direct.c, frame_reference.c, frame_fast.c,
 * frame_final.c) as the stage loop drives it, after the loop has run the
 * bih_build stage: begin readies the frame (image, buffers, scene upload;
 * on failure it cleans up after itself and end is not called; NULL: nothing
 * to ready); run
 * performs one stage: every stage the plan runs, once, in pf_stage_id
 * order, except those in per_pass, which run once per pass (plan->samples
 * passes, cut by settings->time_budget_ms after the first) unless the plan
 * skips them, kept passes included (the integrator reuses them); end, called
 * with the status so far, reads back, checks, writes the rows and frees the
 * state (and the image on failure; NULL: run did all of that).
 */
typedef struct pf_integrator {
    uint32_t per_pass; /* 1u << pf_stage_id for each stage repeated per pass */
    pf_status (*begin)(pf_frame_run *run, pf_error *err);
    pf_status (*run)(pf_frame_run *run, pf_stage_id stage, uint32_t pass, pf_error *err);
    pf_status (*end)(pf_frame_run *run, pf_status status, pf_error *err);
} pf_integrator;

extern const pf_integrator pf_integrator_preview;
extern const pf_integrator pf_integrator_reference;
extern const pf_integrator pf_integrator_fast;
extern const pf_integrator pf_integrator_final;

/*
 * The scene's textures on the device, uploaded once per scene (pf_scene_frame.texture_set)
 * and kept across frames and presets: the DESIGN's scene-lifetime cache.
 */
typedef struct pf_texture_cache {
    uint64_t texture_set;   /* 0: empty */
    pf_vk_buffer *textures; /* the texture table */
    pf_vk_buffer *texels;   /* every mip chain */
} pf_texture_cache;

struct pf_renderer {
    pf_vk_context *ctx;
    struct pf_plan_cache plan;
    /* Per preset: what its kept stage outputs were made from (stage_plan.c). */
    pf_stage_memory stage_memory[PF_QUALITY_AUTO];
    /*
     * The current frame's BIH: the CPU tree (kept for reuse and refit across
     * frames), its GPU copy that the shading kernels traverse, and the GPU
     * builder (created on first use: only GPU builds need its pipelines).
     */
    pf_bih bih;
    int bih_valid;
    /* bih's wide view for the host's traces (pf_renderer_bih_wide): built at first use,
     * dropped whenever bih changes (a build, a refit, auto's pilot freeing it). */
    pf_bih_wide bih_wide;
    int bih_wide_valid;
    /*
     * Reuse state (frame_bih.c): the tree's own leaf-order vertices are the
     * previous frame's geometry; bih_sah is the current tree's SAH cost and
     * bih_fresh_sah that of the last fresh build, the refit's yardstick.
     * bih_frames counts frames that got a tree (0: the next is the first).
     */
    double bih_sah;
    double bih_fresh_sah;
    pf_bih_build_site bih_build_site; /* pf_renderer_set_bih_build */
    pf_lpv_site lpv_site;             /* pf_renderer_set_lpv_site */
    pf_bih_gpu_build_report bih_gpu_report; /* the last GPU build's, for its row */
    pf_bih_gpu_refit_report bih_refit_report; /* the last device refit's, for its row */
    /* What the host's copy of bih lacks until the host traces it (pf_renderer_bih_host):
     * nothing; its clip values (the device refit the tree: pf_bih_refit_bounds); or its
     * nodes (the device built the tree and keeps them: pf_bih_gpu_download_nodes). */
    enum { PF_BIH_HOST_COMPLETE, PF_BIH_HOST_UNFITTED, PF_BIH_HOST_NO_NODES } bih_host;
    uint64_t bih_frames;
    int bih_pilot_replaced; /* auto's pilot dropped the previous frame's tree (pilot.c) */
    pf_bih_gpu *bih_gpu;
    pf_bih_gpu_builder *bih_builder;
    pf_texture_cache textures;
    /* The integrators' pipelines, each created at its first use (pf_renderer_pipeline), per
     * combination of the surface features (PF_SURFACE_*) a frame uses, and for the kernels
     * that sample the camera, per pixel filter. */
    pf_vk_pipeline *pipelines[PF_PIXEL_FILTER_COUNT][PF_SURFACE_VARIANTS][PF_PIPELINE_COUNT];
    uint32_t surface_features; /* the current frame's (pf_render_prepare_textures) */
    uint32_t pixel_filter;     /* the current frame's (its settings, run_stages) */
    /* The final integrator's photon passes kept for reuse by the next frame (frame_final.c). */
    struct pf_final_cache *final_cache;
    /* Tests: at most this many of the final gather's estimates deferred per sample, the
     * rest retraced with their estimates (0: as many as its buffer holds). */
    uint32_t final_deferred_cap;
    /* The fast integrator's photons and LPV (frame_fast.c; NULL until a fast frame). */
    struct pf_fast_cache *fast_cache;
    /* The photon tracer final and fast share (created on first use, kept: its pipeline). */
    pf_photon_tracer *photon_tracer;
    /* The fingerprints of the frame pf_render_preset planned last (after auto's pilots, the
     * frame's own): what the temporal denoiser compares with its history's. */
    uint64_t frame_inputs[PF_INPUT_COUNT];
    /* What the denoiser kept of the last frame it denoised (created on first use). */
    pf_denoise_history *denoise_history;
    pf_denoise_site denoise_site; /* pf_renderer_set_denoise_site */
    pf_trace_site trace_site;     /* pf_renderer_set_trace_site */
    uint64_t wave_tails;          /* reference frames' tails so far (pf_stage_previous) */
    pf_deform_site deform_site;   /* pf_renderer_set_deform_site */
    uint64_t band_bytes;          /* pf_renderer_set_band_bytes (0: the device's range) */
    /* The deforming nodes' rest poses on the device (deform_device.c; NULL until used). */
    struct pf_deform_cache *deform_cache;
    /* Host work to run while the device finishes the frame's last submission, the one that
     * reads its film back (pf_split_film_submit), once; NULL: none. pf_frame_render's motion
     * vectors (issue 43: the readback in the background). Called with PF_OVERLAP_PREPARE just
     * before that submission (what needs the device first: the host's copy of a tree kept
     * on the device), then with PF_OVERLAP_RUN while the device works. */
    void (*overlap)(void *arg, int phase);
    void *overlap_arg;
};

/* pf_renderer.overlap's phases. */
#define PF_OVERLAP_PREPARE 0
#define PF_OVERLAP_RUN 1

typedef struct pf_deform_cache pf_deform_cache;
void pf_deform_cache_destroy(pf_vk_context *ctx, pf_deform_cache *cache);

/* Where bih_build builds a fresh tree for this renderer: its forced site, else the device's. */
pf_bih_build_site pf_renderer_bih_site(const pf_renderer *renderer);

/* The pipeline id, created now if this renderer has not needed it before (renderer.c). */
pf_status pf_renderer_pipeline(pf_renderer *renderer, pf_renderer_pipeline_id id,
                               pf_vk_pipeline **out, pf_error *err);

/*
 * Creates the pipelines of ids that do not exist yet, side by side on threads of their own:
 * a driver that translates a pipeline's whole module on the creating thread (lavapipe: ~0.3 s
 * for a final kernel) then takes about the longest one's time instead of their sum. The first
 * error is returned; the pipelines made stay.
 */
pf_status pf_renderer_pipelines_prepare(pf_renderer *renderer, const pf_renderer_pipeline_id *ids,
                                        size_t count, pf_error *err);

/* FrameParams in scene_types.glsl (std430, 160 bytes). */
typedef struct pf_frame_params {
    float camera_position[4]; /* w: half width of the image plane at distance 1 */
    float camera_forward[4];  /* w: half height of the image plane at distance 1 */
    float camera_right[4];    /* w: ray offset along the geometric normal */
    float camera_up[4];       /* w: 1 for an orthographic camera (the half extents are
                               * then the view's, in world units), else 0 */
    uint32_t width, height, samples_per_pixel, triangle_count;
    uint32_t light_count, emissive_count, seed_lo, seed_hi;
    uint32_t max_specular_depth, bih_node_count;
    uint32_t pixel_filter;    /* pf_pixel_filter */
    uint32_t max_bounces;     /* reference: most bounces (0xffffffff: no limit) */
    float bih_bounds_min[4];  /* the BIH root box (trace_bih's bounds); w unused */
    float bih_bounds_max[4];
    float emissive_weight_total; /* Σ area × luminance of the emissive table's triangles */
    uint32_t max_path_depth;     /* reference: most vertices of one path */
    /* The film's first row in the image, and the image's height: a band's render
     * (pf_render_settings.band_*; 0 and height where the film is the whole image). */
    uint32_t row_offset, image_height;
} pf_frame_params;

/*
 * EmissiveEntry in scene_types.glsl (32 bytes): one column of the alias table
 * (Vose 1991) that picks emissive triangles in proportion to their power.
 */
typedef struct pf_emissive_entry {
    uint32_t triangle;
    uint32_t alias;        /* column picked when the threshold test fails */
    float alias_threshold; /* probability of keeping this column's triangle */
    float pick_pdf;        /* overall probability of picking this triangle */
    float area;
    uint32_t padding[3];
} pf_emissive_entry;

/* The GLSL mirrors assume these std430 sizes. */
_Static_assert(sizeof(pf_frame_params) == 160, "pf_frame_params must match FrameParams");
_Static_assert(sizeof(pf_emissive_entry) == 32, "pf_emissive_entry must match EmissiveEntry");
_Static_assert(sizeof(pf_material) == 176, "pf_material must match Material");

_Static_assert(sizeof(pf_texture_ref) == 48, "pf_texture_ref must match TextureRef");
_Static_assert(sizeof(pf_light) == 64, "pf_light must match Light");
_Static_assert(sizeof(pf_ray) == 32, "pf_ray must match raycast_brute.comp's Ray");
_Static_assert(sizeof(pf_hit) == 16, "pf_hit must match raycast_brute.comp's HitRecord");

/*
 * One frame's scene on the GPU. Every buffer exists even when its array is
 * empty (one zeroed element), so descriptor sets are always complete; the
 * counts in pf_frame_params say how much of each is real.
 */
typedef struct pf_gpu_scene {
    pf_vk_buffer *vertices;          /* vec4 × 3 per triangle */
    pf_vk_buffer *normals;           /* vec4 × 3 per triangle */
    pf_vk_buffer *triangle_material; /* uint per triangle */
    pf_vk_buffer *materials;
    pf_vk_buffer *lights;
    pf_vk_buffer *emissive;          /* pf_emissive_entry table */
    pf_vk_buffer *corners;           /* texture coordinates, colours, tangents per corner */
    pf_vk_buffer *textures;          /* the texture table */
    pf_vk_buffer *texels;            /* the textures' mip chains */
    int textures_borrowed;           /* textures and texels are the renderer's texture cache's */
    uint32_t emissive_count;
    float emissive_weight_total;     /* pf_emissive_table_build's weight_total */
} pf_gpu_scene;

/*
 * The bih_build stage as planned (pf_bih_plan's decision): reuse, or a
 * refit, or a fresh build, then the GPU copy; appends the row (reason: the
 * decision as taken, counters triangles, nodes, depth, sah, built_on_gpu,
 * decision). On failure the tree is dropped and the next frame builds anew.
 */
pf_status pf_render_prepare_bih(pf_renderer *renderer, const pf_scene_frame *frame,
                                const pf_stage_decision *planned, pf_frame_report *report,
                                pf_error *err);

/*
 * Appends a stage row with its times, skipped with skip_reason when that is
 * not NULL; NULL when report is NULL or full.
 */
/* Adds traffic's submits, host_waits, readback_bytes and upload_bytes, and its wait_ms,
 * allocate_ms and copy_ms, to row as counters (issue 44; nothing when row is NULL). The
 * stage loop adds them after the integrator's own: a row's optional counters leave
 * PF_STAGE_TRAFFIC_COUNTERS free. */
#define PF_STAGE_TRAFFIC_COUNTERS 7u
void pf_stage_add_traffic(pf_stage_timing *row, pf_vk_traffic traffic);
/* A shade row's light_samples: the punctual lights a vertex resamples (per_vertex) where the
 * frame has more than PF_DIRECT_LIGHTS_EVERY_MAX; no counter where it visits each. */
void pf_stage_add_light_samples(pf_stage_timing *row, uint32_t light_count, uint32_t per_vertex);
/* sum += more. */
void pf_traffic_add(pf_vk_traffic *sum, pf_vk_traffic more);

pf_stage_timing *pf_frame_report_row(pf_frame_report *report, const char *stage,
                                     const char *skip_reason, double wall_ms, double gpu_ms);

/*
 * PF_ERR_LIMIT naming the count when some of a frame's rays overflowed the
 * BIH traversal stack (their hits were misses), else PF_OK: a frame is never
 * written with silently missing hits.
 */
pf_status pf_render_check_traversal(const pf_renderer *renderer, uint64_t failures,
                                    pf_error *err);

/*
 * What a photon-mapping integrator (final, fast) needs of a frame on the
 * device: the BIH's view, the emitters (the plan's, built once per frame),
 * the uploaded scene, the tracer's view of both (photons), and the
 * renderer's tracer (created on first use).
 */
typedef struct pf_photon_frame {
    pf_bih_gpu_view bih;
    const pf_photon_emitters *emitters;
    pf_gpu_scene scene;
    pf_photon_scene photons;
    pf_photon_tracer *tracer;
} pf_photon_frame;

/* After pf_render_prepare_bih; on failure nothing is left to release. */
pf_status pf_photon_frame_prepare(pf_renderer *renderer, const pf_scene_frame *frame,
                                  const pf_photon_emitters *emitters, pf_photon_frame *out,
                                  pf_error *err);
void pf_photon_frame_release(pf_vk_context *ctx, pf_photon_frame *photon_frame);
/* Traces count photon passes of the frame (trace[i] into maps[i]; pf_photon_trace_passes),
 * their rays traced on the host through the renderer's tree (and its shared wide view)
 * where the plan says the host traces. */
pf_status pf_photon_frame_trace(pf_renderer *renderer, const pf_photon_frame *inputs,
                                const pf_stage_plan *plan, pf_photon_trace_settings *trace,
                                uint32_t count, pf_photon_maps *maps, pf_error *err);

/*
 * The `textures` stage (before bih_build): uploads the frame's textures into the renderer's
 * cache unless they are there already, and appends the row (skipped without textures;
 * counters textures, megabytes, uploaded 0/1).
 */
pf_status pf_render_prepare_textures(pf_renderer *renderer, const pf_scene_frame *frame,
                                     pf_frame_report *report, pf_error *err);

/*
 * Fills bindings[0 .. PF_SCENE_BINDING_COUNT) with scene's buffers (params at
 * PF_SCENE_BINDING_PARAMS) and the kernel's own buffers after them, in order;
 * returns PF_SCENE_BINDING_COUNT + own_count.
 */
uint32_t pf_gpu_scene_bindings(const pf_gpu_scene *scene, pf_vk_buffer *params,
                               pf_vk_buffer *const *own, uint32_t own_count,
                               pf_vk_buffer **bindings);

/* Uploads only the vertex buffer (all the ray-casting oracle needs) when full is 0. The
 * textures come from cache when it holds the frame's (else they are uploaded for this use). */
pf_status pf_gpu_scene_upload(pf_vk_context *ctx, const pf_scene_frame *frame, int full,
                              const pf_texture_cache *cache, pf_gpu_scene *out, pf_error *err);
/* The same with every upload recorded in cmds (issue 44): the buffers exist and their
 * contents land before the commands recorded after; the caller submits. */
pf_status pf_gpu_scene_record(pf_vk_context *ctx, pf_vk_commands *cmds,
                              const pf_scene_frame *frame, int full,
                              const pf_texture_cache *cache, pf_gpu_scene *out, pf_error *err);
void pf_gpu_scene_release(pf_vk_context *ctx, pf_gpu_scene *scene);

/*
 * Builds the emissive-triangle alias table (weight = area × Rec. 709
 * luminance of the emitted radiance, front face only; zero-area triangles are
 * left out: no ray hits them). *entries is malloc'ed (NULL when none);
 * *weight_total (may be NULL) receives the sum of the weights, so a triangle
 * of radiance Le is picked with probability area·lum(Le)/total.
 */
pf_status pf_emissive_table_build(const pf_scene_frame *frame, pf_emissive_entry **entries,
                                  uint32_t *count, double *weight_total, pf_error *err);

/*
 * pf_raycast_brute_force with a choice of variant: any_hit = 1 reports some
 * hit in (tmin, tmax) (shadow rays) instead of the closest. Candidate for
 * pf_render.h; the BIH's any-hit traversal will be tested against it.
 */
pf_status pf_raycast_brute(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_ray *rays, uint32_t ray_count, int any_hit, pf_hit *hits,
                           pf_error *err);

/*
 * auto (plan.c): the preset and samples that render this frame, chosen into
 * *chosen (a copy of settings with quality and samples_per_pixel set); adds
 * the `plan` row (run, its reason the decision). May render pilots first.
 */
/*
 * What real frames leave on the renderer for the next one (pilot.c): the stage memories'
 * frame counts, the BIH's, the texture cache's set. auto's pilot renders through the
 * same renderer; pf_pilot_begin saves this before them and pf_pilot_end drops all they
 * kept, so the real frame's rows say what it did, and claim work from previous real
 * frames only (issue 45).
 */
typedef struct pf_pilot_history {
    uint64_t frames[PF_QUALITY_AUTO];
    uint64_t bih_frames;
    uint64_t texture_set;
    /* The frame's overlap (pf_renderer.overlap), held back for the real frame's readback. */
    void (*overlap)(void *arg, int phase);
    void *overlap_arg;
} pf_pilot_history;

void pf_pilot_begin(pf_renderer *renderer, pf_pilot_history *saved);
void pf_pilot_end(pf_renderer *renderer, const pf_pilot_history *saved);

/* The request's image size, budgets and target in range (PF_ERR_INVALID naming them). */
pf_status pf_render_settings_check(const pf_render_settings *settings, pf_error *err);

/* One frame of settings->quality, which is a preset, not auto (render_frame.c):
 * pf_render_frame's and auto's pilot's. */
pf_status pf_render_preset(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_render_settings *settings, pf_image *image,
                           pf_frame_report *report, pf_error *err);
/* One render of the stage loop: the whole image, or a band of it (settings->band_*); the
 * samples (final: passes) it rendered in *samples (NULL: not wanted). Settings checked. */
pf_status pf_render_band(pf_renderer *renderer, const pf_scene_frame *frame,
                         const pf_render_settings *settings, pf_image *image,
                         pf_frame_report *report, uint32_t *samples, pf_error *err);
/* render_bands.c: the most bytes one device buffer of per-pixel data may hold (the device's
 * maxStorageBufferRange, or less where a test set pf_renderer_set_band_bytes); the rows of a
 * band of a frame of these settings (its height where the film fits one device buffer), and
 * the frame in bands of band_rows. */
uint64_t pf_renderer_buffer_limit(const pf_renderer *renderer);
uint32_t pf_render_band_rows(const pf_renderer *renderer, const pf_render_settings *settings);
pf_status pf_render_bands(pf_renderer *renderer, const pf_scene_frame *frame,
                          const pf_render_settings *settings, uint32_t band_rows,
                          pf_image *image, pf_frame_report *report, pf_error *err);

pf_status pf_plan_frame(pf_renderer *renderer, const pf_scene_frame *frame,
                        const pf_render_settings *settings, pf_render_settings *chosen,
                        pf_frame_report *report, pf_error *err);

/* What final (its photon passes) and fast (VPLs, caustic grid, LPV) keep in the renderer
 * between frames; NULL is fine. */
void pf_final_cache_destroy(struct pf_final_cache *cache);
void pf_fast_cache_destroy(pf_vk_context *ctx, struct pf_fast_cache *cache);

/*
 * The split film of the reference and final integrators (split_film.c), sums
 * over samples per pixel: film vec4s (direct RGB, coverage), (indirect RGB,
 * kept samples), (caustic RGB, 0); AOV film vec4s (albedo RGB, depth),
 * (normal XYZ, AOV samples or 0).
 */
#define PF_SPLIT_FILM_VEC4_PER_PIXEL 3u
#define PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL 2u

/* Creates the image with pf_render.h's channels for these integrators (AOVs or not),
 * followed by those of later_layers (pf_render_settings.later_layers), zero. */
pf_status pf_split_image_create(pf_image *image, uint32_t width, uint32_t height, int aovs,
                                uint32_t later_layers, pf_error *err);

/*
 * pf_render_motion in two halves (motion_vectors.c), so that pf_frame_render computes the
 * vectors while the device finishes the frame (pf_renderer.overlap) and writes them into
 * the image once it is read back: compute traces the pixel centres of a width × height
 * image into the field (two floats a pixel, and each pixel's depth change); apply writes
 * them into image's motion layer and depth_change (NULL: not wanted), and adds the
 * `motion` row (overlapped: computed during the device's work).
 */
typedef struct pf_motion_field {
    float *vectors;      /* motion.X, motion.Y a pixel */
    float *depth_change; /* pf_render_motion's, a pixel */
    uint32_t width, height;
    uint64_t moving, seen;
    int still;           /* camera and geometry as they were: nothing traced */
    double ms;           /* compute's wall time */
} pf_motion_field;
pf_status pf_motion_compute(pf_renderer *renderer, const pf_scene_frame *frame,
                            const pf_scene_frame *previous, uint32_t width, uint32_t height,
                            pf_motion_field *out, pf_error *err);
pf_status pf_motion_apply(const pf_motion_field *field, pf_image *image, float *depth_change,
                          int overlapped, pf_frame_report *report, pf_error *err);
void pf_motion_field_free(pf_motion_field *field);

/* The channels the motion and denoise stages add (PF_LATER_LAYER_MOTION, _NOISY). */
extern const char *const pf_motion_channels[2];
extern const char *const pf_noisy_channels[4];
/*
 * Where image's count channels names[0..count) are, in *first on: in place where the
 * image has them in that order (created with them: pf_split_image_create's later layers),
 * else after a copy of the image with them appended (zero).
 */
pf_status pf_image_later_layer(pf_image *image, const char *const *names, uint32_t count,
                               uint32_t *first, pf_error *err);

/*
 * Film sums → channel values: means over each pixel's kept samples; the AOVs
 * over the kept samples too, or with aov_own_count over the count the AOV
 * film keeps in its second vec4's w. The host's arithmetic of split_film.comp,
 * which does it on the device: test_split_film's oracle.
 */
void pf_split_film_to_image(const float *film, const float *film_aov, int aovs,
                            int aov_own_count, pf_image *image);

/*
 * The device films of a split integrator for the settings' size, labelled
 * "<integrator> film" and "<integrator> AOV film"; the AOV film is a single
 * vec4 unless full_aov (kernels that never write it).
 */
pf_status pf_split_film_create(pf_vk_context *ctx, const pf_render_settings *settings,
                               int full_aov, const char *integrator, pf_vk_buffer **film,
                               pf_vk_buffer **film_aov, pf_error *err);

/* Reads both films back into image, split into its channels on the device (the AOV film
 * only with aovs): one submission. */
pf_status pf_split_film_read(pf_renderer *renderer, pf_vk_buffer *film, pf_vk_buffer *film_aov,
                             int aovs, int aov_own_count, pf_image *image, pf_error *err);

/* The same readback recorded in cmds, to go with a stage's dispatches (issue 44):
 * pf_split_film_record_read records split_film.comp into device image buffers it creates
 * (bands of rows within the storage-buffer range) and their downloads straight into
 * image's pixels; once cmds is submitted the pixels are there, and
 * pf_split_film_finish_read releases the buffers (call it after a failure too). */
typedef struct pf_split_film_readback {
    pf_vk_context *ctx;
    pf_vk_buffer **bands; /* the image's channels on the device, in bands of rows */
    uint32_t band_count;
} pf_split_film_readback;
pf_status pf_split_film_record_read(pf_renderer *renderer, pf_vk_commands *cmds,
                                    pf_vk_buffer *film, pf_vk_buffer *film_aov, int aovs,
                                    int aov_own_count, pf_image *image,
                                    pf_split_film_readback *out, pf_error *err);
void pf_split_film_finish_read(pf_split_film_readback *readback);
/* Submits cmds and waits for them; where they read the film back (readback has bands),
 * the renderer's overlap runs between the submission and the wait, while the device
 * renders. */
pf_status pf_split_film_submit(pf_renderer *renderer, pf_vk_commands *cmds,
                               const pf_split_film_readback *readback, pf_error *err);

/* How far secondary rays start off a surface in this frame (FrameParams' camera_right.w). */
float pf_render_ray_offset(const pf_scene_frame *frame);

/* splitmix64 of seed and index: unrelated seeds for nearby indices (final's photon passes,
 * the camera samples of a frame whose settings carry sample_salt). */
uint64_t pf_seed_mix(uint64_t seed, uint64_t index);

/* The height of the image the settings render: the whole image's where they are a
 * band of it (pf_render_settings.band_image_height). */
static inline uint32_t pf_render_image_height(const pf_render_settings *settings)
{
    return settings->band_image_height ? settings->band_image_height : settings->height;
}

/*
 * Fills the FrameParams the integrators share: camera, image (and the band of it the film
 * holds), counts, seed, ray offset, the emissive table's total weight and the BIH's root box
 * and node count (integrator-specific fields are left 0 for the caller).
 */
void pf_frame_params_fill(const pf_scene_frame *frame, const pf_render_settings *settings,
                          uint32_t spp, const pf_gpu_scene *scene, const pf_bih_gpu_view *bih,
                          pf_frame_params *params);

/* material_probe.comp's input (std430 ProbeQuery, 240 bytes). */
typedef struct pf_material_probe_query {
    pf_material material;
    float wo[3];          /* unit, away from the surface */
    uint32_t front;       /* PF_PROBE_FRONT (glass: entering) | PF_PROBE_IMPORTANCE */
    float normal[3];      /* unit shading normal */
    float fresnel_cos;    /* cosine of incidence for fresnel_dielectric */
    float xi[3];          /* bsdf_sample's random numbers, each in [0, 1) */
    float fresnel_eta;    /* transmitted over incident index for fresnel_dielectric */
    float geometric_normal[3]; /* unit, on wo's side */
    float padding;
} pf_material_probe_query;

/* pf_material_probe_query.front: arriving at the front face; sampling for a photon (flux). */
#define PF_PROBE_FRONT 1u
#define PF_PROBE_IMPORTANCE 2u

#define PF_PROBE_SPECULAR 1u
#define PF_PROBE_TRANSMITTED 2u

/* material_probe.comp's output (std430 ProbeResult, 64 bytes). */
typedef struct pf_material_probe_result {
    float direction[3];   /* bsdf_sample: unit direction away from the surface */
    float pdf;            /* its solid-angle pdf (0 for specular) */
    float weight[3];      /* f·|cos|/pdf, the throughput factor */
    uint32_t flags;       /* PF_PROBE_SPECULAR | PF_PROBE_TRANSMITTED */
    float eval_cos[3];    /* bsdf_eval_cos(direction) */
    float eval_pdf;       /* bsdf_pdf(direction) */
    float fresnel;        /* fresnel_dielectric(fresnel_cos, fresnel_eta) */
    float rough_albedo[3]; /* material_rough_albedo(wo): what estimates multiply by */
} pf_material_probe_result;

_Static_assert(sizeof(pf_material_probe_query) == 240, "must match ProbeQuery");
_Static_assert(sizeof(pf_material_probe_result) == 64, "must match ProbeResult");

/*
 * Runs the shared GPU material code (shaders/common/materials.glsl) on count
 * queries: bsdf_sample with each query's inputs, bsdf_eval_cos and bsdf_pdf
 * at the sampled direction, and fresnel_dielectric. For tests: the materials
 * every integrator uses, checked against tabulated values.
 */
pf_status pf_material_probe(pf_renderer *renderer, const pf_material_probe_query *queries,
                            uint32_t count, pf_material_probe_result *results, pf_error *err);

/*
 * The radius holding `neighbours` photons at the mean density of `stored`
 * photons over the scene's surface area, r² = K A / (π N); with none
 * stored, fallback_fraction × the scene's diagonal.
 */
float pf_photon_radius_for_density(const pf_scene_frame *frame, double neighbours,
                                   uint32_t stored, double fallback_fraction);

/* Destroys *buffer if there is one and clears the pointer. */
void pf_render_buffer_release(pf_vk_context *ctx, pf_vk_buffer **buffer);

/* Creates a buffer of at least min_bytes and uploads size bytes of data (may be 0). */
pf_status pf_render_buffer_with_data(pf_vk_context *ctx, const char *label, const void *data,
                                     uint64_t size, uint64_t min_bytes, pf_vk_buffer **out,
                                     pf_error *err);
/* The same with the upload recorded in cmds (pf_vk_cmd_upload): it lands before the
 * commands recorded after it, in the same submission (issue 44). */
pf_status pf_render_buffer_recorded(pf_vk_context *ctx, pf_vk_commands *cmds, const char *label,
                                    const void *data, uint64_t size, uint64_t min_bytes,
                                    pf_vk_buffer **out, pf_error *err);

#endif
