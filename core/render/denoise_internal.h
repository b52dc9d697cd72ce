/*
 * What the denoise stage's two files share: the planes the filter works on (denoise.c)
 * and the temporal blend that runs on them before it (denoise_temporal.c).
 */
#ifndef PF_DENOISE_INTERNAL_H
#define PF_DENOISE_INTERNAL_H

#include "pf_render.h"

#include <stdint.h>

/* Slices the stage's per-pixel loops split their rows into (pf_run_ranges): the machine's
 * cores, at most this many. */
#define DENOISE_MAX_THREADS 16

/* The filter's constants (denoise.c's header says what they weigh). */
#define DENOISE_NORMAL_SQUARINGS 7 /* the normal weight's exponent: 2^7 = 128 */
#define DENOISE_SIGMA_LUMINANCE 4.0f
/* Reach of the spatial variance estimate: quadrants of (1 + this)² pixels. */
#define DENOISE_VARIANCE_RADIUS 3

/* The guides and the signal of one image, one float array each. */
typedef struct denoise_planes {
    uint32_t width, height;
    float *lighting;   /* 3 per pixel: demodulated */
    float *direct;     /* 3 per pixel: the direct light as rendered (blended over frames,
                        * never filtered, so never divided by the albedo: the light sources
                        * the camera sees are in it, over an albedo a pixel's samples see
                        * only in part) */
    float *albedo;     /* 3 per pixel: what the lighting was divided by (1 where not) */
    float *normal;     /* 3 per pixel */
    float *depth;      /* 1 per pixel; 0: nothing seen */
    float *depth_step; /* 1 per pixel: |dz| per pixel */
    float *variance;   /* 1 per pixel */
    /* 1 per pixel: frames this pixel's lighting averages (0: no surface, or not demodulated:
     * nothing to carry to the next frame), and what that average did to its variance. */
    float *history_length;
    float *variance_factor;
    float *scratch;    /* 4 per pixel: the next pass's lighting and variance (the host's
                        * filter alone allocates it) */
    float *planar;     /* PLANAR_COUNT planes of one float a pixel: the host's à-trous pass's
                        * inputs in runs a vector loads at once (pf_denoise_atrous_prepare;
                        * the host's filter alone allocates it) */
} denoise_planes;

/* The planes of denoise_planes.planar: the lighting, the normal, the pass's luminance scale
 * (SVGF's 4 √(3×3 Gaussian of the variance) + 1e-6). */
enum { PLANAR_R, PLANAR_G, PLANAR_B, PLANAR_NX, PLANAR_NY, PLANAR_NZ, PLANAR_SCALE,
       PLANAR_COUNT };

/* What the temporal blend did, for its row. */
typedef struct denoise_temporal_stats {
    uint64_t surface_pixels;     /* pixels that see a surface (could have had a history) */
    uint64_t reprojected_pixels; /* of those, the ones that found their point in history */
    double mean_history;         /* frames behind the reprojected pixels' lighting, mean */
    int still;                   /* the geometry is as in the previous frame */
    uint32_t memory;             /* the most frames a pixel's lighting averages (1/α_min) */
} denoise_temporal_stats;

/*
 * Blends history's lighting into planes (lighting and direct; variance_factor says what the
 * blend did to the variance, by which the filter scales its estimate from this frame alone)
 * where history holds the previous frame and its point still matches; image gives the
 * motion vectors. Call with history usable (pf_denoise_history_usable).
 */
void denoise_temporal_blend(const pf_denoise_history *history,
                            const pf_denoise_sequence *sequence, const pf_image *image,
                            denoise_planes *planes, denoise_temporal_stats *stats);

/* Leaves planes' lighting (blended, before the spatial filter) and guides in history as
 * the frame sequence->frame; history lengths are those of the last blend (1 when none ran).
 * 0: out of memory (history is then emptied). */
int denoise_temporal_keep(pf_denoise_history *history, const pf_denoise_sequence *sequence,
                          const denoise_planes *planes);

/*
 * Rows [row_begin, row_end) of one à-trous pass of spread step on the host, from planes'
 * lighting and variance into planes->scratch (4 floats a pixel): 8 pixels a vector where
 * the CPU has AVX2, else 4 (denoise_atrous_body.h; the two agree bit for bit).
 */
void pf_denoise_atrous_rows(denoise_planes *planes, int step, int row_begin, int row_end);
/* Rows [row_begin, row_end) of planes->planar: the lighting and the normals before the
 * variance estimate (pass 0), the lighting and the luminance scale from the variance before
 * each à-trous pass (pass 1; the normals stay as the first call left them). Every row
 * before anything reads them. */
void pf_denoise_atrous_prepare(denoise_planes *planes, int row_begin, int row_end, int pass);
/* Rows [row_begin, row_end) of the variance estimate on the host into planes->variance, from
 * planes->planar's lighting and normals; 8 or 4 wide as the pass. */
void pf_denoise_variance_rows(denoise_planes *planes, int row_begin, int row_end);
void pf_denoise_variance_rows_4(denoise_planes *planes, int row_begin, int row_end);
void pf_denoise_variance_rows_8(denoise_planes *planes, int row_begin, int row_end);
void pf_denoise_atrous_rows_4(denoise_planes *planes, int step, int row_begin, int row_end);
void pf_denoise_atrous_rows_8(denoise_planes *planes, int step, int row_begin, int row_end);

/*
 * The filter on the device (denoise_device.c): the variance estimate of noisy (this frame's
 * own demodulated lighting, 3 per pixel; NULL: planes' lighting, where no blend changed it)
 * times planes' variance factors, then `passes`
 * à-trous passes of planes' lighting, in one submission. Leaves the filtered lighting and
 * its variance in planes, the estimate the passes started from in estimate (one float per
 * pixel), the kernels' GPU time in gpu_ms (< 0 without timestamps).
 */
pf_status denoise_device_filter(pf_renderer *renderer, denoise_planes *planes,
                                const float *noisy, int passes, float *estimate,
                                double *gpu_ms, pf_error *err);

#endif
