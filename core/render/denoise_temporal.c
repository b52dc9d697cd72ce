/*
 * Temporal reuse for the denoise stage (issue 40): SVGF's reprojection and blend (Schied
 * et al. 2017, §4.2) on the demodulated indirect light that denoise.c filters.
 *
 * A renderer keeps the last frame it denoised: its lighting as blended (before the spatial
 * filter, so that the filter's bias does not feed back from frame to frame; multiplied back
 * by its albedo, and divided by this frame's, because the albedo AOV of a pixel whose samples
 * see a surface only in part, at an edge or a light source's rim, changes from frame to
 * frame with the share, as its lighting does), its direct
 * light (blended the same way but never filtered: a still shot's soft shadows average out
 * over frames, and their edges stay where they are), its normals
 * and depths and, per pixel, how many frames that lighting averages. The next frame of the
 * same sequence (same scene load, same job settings, frame number one higher, lights and
 * materials unchanged) finds each pixel's point in it through the motion vectors
 * (motion.X/Y: previous raster position minus this one), takes the bilinear taps around
 * that position whose depth and normal still match (a disoccluded point finds none and
 * starts afresh), and blends: lighting = (1 − α) · previous + α · this frame, with
 * α = max(1 / (n + 1), α_min), n the frames behind the previous value.
 *
 * α_min is the memory: 1/32 when the geometry has not changed since the previous frame
 * (only the camera may have moved: the light on each surface is the same, so a long average
 * is exact), SVGF's 0.2 when something moved (shadows and bounced light move with it, and
 * a long memory would drag them).
 *
 * The variance the filter's edge-stopping reads is this frame's spatial estimate times the
 * blend's own factor f = (1 − α)² f_previous + α² (the variance of a weighted sum of frames
 * whose noise is independent: each frame draws its camera samples from a seed of its own,
 * pf_render_settings.sample_salt), so the filter blurs less as a pixel's history grows and
 * a still shot converges towards the converged image over frames.
 */
#include "denoise_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The memories (1/α_min): frames a pixel's lighting averages at most. */
#define TEMPORAL_MEMORY_STILL 32u
#define TEMPORAL_MEMORY_MOVING 5u
/* A tap matches when its depth is within this fraction of the expected one (plus two
 * pixels' worth of the surface's depth slope) and its normal within ~25°. */
#define TEMPORAL_DEPTH_TOLERANCE 0.03f
#define TEMPORAL_NORMAL_COSINE 0.9f
/* Bilinear weight below which the matching taps say too little: no history. */
#define TEMPORAL_MIN_WEIGHT 0.05f

struct pf_denoise_history {
    int valid;
    uint64_t sequence, lighting_fingerprint, geometry_fingerprint;
    int64_t frame;
    uint32_t width, height;
    float *lighting;       /* 3 per pixel, blended, multiplied back by its albedo */
    float *direct;         /* 3 per pixel, as rendered, blended */
    float *normal;         /* 3 per pixel */
    float *depth;          /* 1 per pixel */
    float *length;         /* 1 per pixel: frames averaged; 0 = nothing to reuse */
    float *factor;         /* 1 per pixel: the blend's variance factor */
};

pf_status pf_denoise_history_create(pf_denoise_history **out, pf_error *err)
{
    *out = calloc(1, sizeof **out);
    if (!*out)
        return pf_error_set(err, PF_ERR_NOMEM, "denoise history: out of memory");
    return PF_OK;
}

static void history_empty(pf_denoise_history *history)
{
    free(history->lighting);
    free(history->direct);
    free(history->normal);
    free(history->depth);
    free(history->length);
    free(history->factor);
    memset(history, 0, sizeof *history);
}

void pf_denoise_history_destroy(pf_denoise_history *history)
{
    if (!history)
        return;
    history_empty(history);
    free(history);
}

/* Why history does not hold the frame before frame of sequence at this size (text may hold
 * the words), or NULL: the checks that need no fingerprints. */
static const char *history_gap(const pf_denoise_history *history, uint64_t sequence,
                               int64_t frame, uint32_t width, uint32_t height,
                               char text[PF_STAGE_REASON_MAX])
{
    if (!history || !history->valid || !sequence || history->sequence != sequence)
        return "no previous frame of this sequence on this worker";
    if (history->frame != frame - 1) {
        snprintf(text, PF_STAGE_REASON_MAX,
                 "frame %lld came before frame %lld on this worker: not consecutive",
                 (long long)history->frame, (long long)frame);
        return text;
    }
    if (history->width != width || history->height != height)
        return "the image size changed";
    return NULL;
}

int pf_denoise_history_continues(const pf_denoise_history *history, uint64_t sequence,
                                 int64_t frame, uint32_t width, uint32_t height)
{
    char text[PF_STAGE_REASON_MAX];
    return history_gap(history, sequence, frame, width, height, text) == NULL;
}

int pf_denoise_history_usable(const pf_denoise_history *history,
                              const pf_denoise_sequence *sequence, uint32_t width,
                              uint32_t height, char *reason, size_t size)
{
    char text[PF_STAGE_REASON_MAX];
    const char *why =
        history_gap(history, sequence->sequence, sequence->frame, width, height, text);
    if (!why && history->lighting_fingerprint != sequence->lighting) {
        snprintf(text, sizeof text, "lights or materials changed since frame %lld",
                 (long long)history->frame);
        why = text;
    }
    if (why && reason)
        snprintf(reason, size, "%s", why);
    return why == NULL;
}

static float dot3f(const float *a, const float *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The cosine between two normal AOVs: means over a pixel's samples, shorter than 1 where
 * only some samples saw a rough surface, so their directions are what is compared. */
static float normal_cosine(const float *a, const float *b)
{
    float lengths = dot3f(a, a) * dot3f(b, b);
    return lengths > 1e-12f ? dot3f(a, b) / sqrtf(lengths) : 0.0f;
}

/*
 * How much p's depth changes per pixel along its own surface: per axis the smaller of the
 * two one-sided differences (at a silhouette one side jumps to another surface; the other
 * side is still p's), the larger axis of the two. The spatial filter's central difference
 * would take the jump itself for the slope and let a disoccluded pixel match the occluder.
 */
static float surface_slope(const denoise_planes *planes, int x, int y)
{
    int w = (int)planes->width, h = (int)planes->height;
    const float *depth = planes->depth;
    float z = depth[(size_t)y * w + x], slope[2];
    for (int axis = 0; axis < 2; axis++) {
        float smallest = INFINITY;
        for (int side = -1; side <= 1; side += 2) {
            int qx = axis ? x : x + side, qy = axis ? y + side : y;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                continue;
            float zq = depth[(size_t)qy * w + qx];
            if (zq > 0.0f)
                smallest = fminf(smallest, fabsf(zq - z));
        }
        slope[axis] = isfinite(smallest) ? smallest : 0.0f;
    }
    return fmaxf(slope[0], slope[1]);
}

void denoise_temporal_blend(const pf_denoise_history *history,
                            const pf_denoise_sequence *sequence, const pf_image *image,
                            denoise_planes *planes, denoise_temporal_stats *stats)
{
    memset(stats, 0, sizeof *stats);
    int still = history->geometry_fingerprint == sequence->geometry;
    uint32_t memory = still ? TEMPORAL_MEMORY_STILL : TEMPORAL_MEMORY_MOVING;
    float alpha_min = 1.0f / (float)memory;
    stats->still = still;
    stats->memory = memory;
    int motion_x = pf_image_channel(image, "motion.X");
    int motion_y = pf_image_channel(image, "motion.Y");
    int w = (int)planes->width, h = (int)planes->height;
    double history_sum = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            if (planes->history_length[p] == 0.0f)
                continue;
            stats->surface_pixels++;
            float mx = 0.0f, my = 0.0f;
            if (motion_x >= 0 && motion_y >= 0) {
                const float *texel = image->pixels + p * image->channel_count;
                mx = texel[motion_x];
                my = texel[motion_y];
                if (!isfinite(mx) || !isfinite(my))
                    continue;
            }
            /* Where the point was, in pixel-index coordinates (centres at integers); the
             * vectors' y is up, the image's rows go down. */
            float hx = (float)x + mx, hy = (float)y - my;
            if (!(hx > -1.0f && hy > -1.0f && hx < (float)w && hy < (float)h))
                continue;
            float change = sequence->depth_change ? sequence->depth_change[p] : 0.0f;
            float expected = planes->depth[p] + (isfinite(change) ? change : 0.0f);
            float tolerance =
                TEMPORAL_DEPTH_TOLERANCE * expected + 2.0f * surface_slope(planes, x, y);
            int x0 = (int)floorf(hx), y0 = (int)floorf(hy);
            float fx = hx - (float)x0, fy = hy - (float)y0;
            float weights = 0.0f, sum[3] = {0, 0, 0}, direct[3] = {0, 0, 0};
            float length = 0.0f, factor = 0.0f;
            for (int tap = 0; tap < 4; tap++) {
                int qx = x0 + (tap & 1), qy = y0 + (tap >> 1);
                float weight = ((tap & 1) ? fx : 1.0f - fx) * ((tap >> 1) ? fy : 1.0f - fy);
                if (weight <= 0.0f || qx < 0 || qy < 0 || qx >= w || qy >= h)
                    continue;
                size_t q = (size_t)qy * w + qx;
                if (history->length[q] == 0.0f ||
                    fabsf(history->depth[q] - expected) > tolerance ||
                    normal_cosine(history->normal + 3 * q, planes->normal + 3 * p) <
                        TEMPORAL_NORMAL_COSINE)
                    continue;
                for (int c = 0; c < 3; c++) {
                    sum[c] += weight * history->lighting[3 * q + c];
                    direct[c] += weight * history->direct[3 * q + c];
                }
                length += weight * history->length[q];
                factor += weight * history->factor[q];
                weights += weight;
            }
            if (weights < TEMPORAL_MIN_WEIGHT)
                continue; /* disoccluded: this frame's own lighting, a history of 1 */
            float previous_length = length / weights;
            float alpha = fmaxf(1.0f / (previous_length + 1.0f), alpha_min);
            for (int c = 0; c < 3; c++) {
                planes->lighting[3 * p + c] =
                    (1.0f - alpha) * (sum[c] / weights) / planes->albedo[3 * p + c] +
                    alpha * planes->lighting[3 * p + c];
                planes->direct[3 * p + c] =
                    (1.0f - alpha) * (direct[c] / weights) + alpha * planes->direct[3 * p + c];
            }
            float f = (1.0f - alpha) * (1.0f - alpha) * (factor / weights) + alpha * alpha;
            planes->variance_factor[p] = f;
            planes->history_length[p] = fminf(previous_length + 1.0f, (float)memory);
            stats->reprojected_pixels++;
            history_sum += previous_length;
        }
    stats->mean_history =
        stats->reprojected_pixels ? history_sum / (double)stats->reprojected_pixels : 0.0;
}

int denoise_temporal_keep(pf_denoise_history *history, const pf_denoise_sequence *sequence,
                          const denoise_planes *planes)
{
    size_t pixels = (size_t)planes->width * planes->height;
    if (!history->lighting || history->width != planes->width ||
        history->height != planes->height) {
        history_empty(history);
        history->lighting = malloc(3 * pixels * sizeof(float));
        history->direct = malloc(3 * pixels * sizeof(float));
        history->normal = malloc(3 * pixels * sizeof(float));
        history->depth = malloc(pixels * sizeof(float));
        history->length = malloc(pixels * sizeof(float));
        history->factor = malloc(pixels * sizeof(float));
        if (!history->lighting || !history->direct || !history->normal || !history->depth ||
            !history->length || !history->factor) {
            history_empty(history);
            return 0;
        }
        history->width = planes->width;
        history->height = planes->height;
    }
    for (size_t k = 0; k < 3 * pixels; k++)
        history->lighting[k] = planes->lighting[k] * planes->albedo[k];
    memcpy(history->direct, planes->direct, 3 * pixels * sizeof(float));
    memcpy(history->normal, planes->normal, 3 * pixels * sizeof(float));
    memcpy(history->depth, planes->depth, pixels * sizeof(float));
    memcpy(history->length, planes->history_length, pixels * sizeof(float));
    memcpy(history->factor, planes->variance_factor, pixels * sizeof(float));
    history->valid = 1;
    history->sequence = sequence->sequence;
    history->frame = sequence->frame;
    history->lighting_fingerprint = sequence->lighting;
    history->geometry_fingerprint = sequence->geometry;
    return 1;
}
