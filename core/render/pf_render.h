/*
 * core/render: the frame pipeline. A pf_renderer owns the GPU pipelines and the
 * per-scene caches that let consecutive frames reuse work; pf_render_frame runs
 * the stages a frame needs and reports one pf_stage_timing per stage (run or
 * skipped, with the reason), which the worker stores in the queue database.
 */
#ifndef PF_RENDER_H
#define PF_RENDER_H

#include "pf_bih.h"
#include "pf_common.h"
#include "pf_image.h"
#include "pf_scene.h"
#include "pf_vk.h"

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

typedef struct pf_render_settings {
    uint32_t width, height;
    pf_quality quality;
    uint32_t samples_per_pixel; /* 0 = the preset's default */
    uint64_t seed;
    int aovs;                   /* 1: fill albedo/normal/depth layers */
} pf_render_settings;

#define PF_STAGE_NAME_MAX 32
#define PF_STAGE_REASON_MAX 160
#define PF_STAGE_COUNTERS_MAX 8
#define PF_FRAME_STAGES_MAX 16

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
    uint32_t stage_count;
    pf_stage_timing stages[PF_FRAME_STAGES_MAX];
    uint64_t discarded_samples;     /* NaN/Inf samples kept off the film */
} pf_frame_report;

/* Appends a stage row; returns it (NULL when the report is full). */
pf_stage_timing *pf_frame_report_add(pf_frame_report *report, const char *stage);
void pf_stage_add_counter(pf_stage_timing *stage, const char *name, double value);

pf_status pf_renderer_create(pf_vk_context *ctx, pf_renderer **out, pf_error *err);
void pf_renderer_destroy(pf_renderer *renderer);

/*
 * Renders one frame of an evaluated scene into image (allocated here: R,G,B,A
 * and, with settings->aovs, albedo.R/G/B, normal.X/Y/Z, depth.Z). Appends the
 * GPU stage rows to report. Image is owned by the caller (pf_image_free).
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

#endif
