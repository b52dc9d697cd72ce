/*
 * The `denoise` stage (issue 40): an edge-avoiding à-trous wavelet filter
 * (Dammertz et al. 2010, "Edge-Avoiding À-Trous Wavelet Transform for fast
 * Global Illumination Filtering") with the luminance edge-stopping function
 * of SVGF (Schied et al. 2017), over the finished image: on the host's cores here, or as
 * the same arithmetic in two compute kernels (denoise_device.c) where the renderer's site
 * says so (pf_render_denoise).
 *
 * Before the filter, a frame of a sequence blends the previous frame's lighting where this
 * renderer kept it (denoise_temporal.c), and the filter then runs on that average; the
 * direct light is blended too (never filtered).
 *
 * What is filtered is the indirect light without its caustics, the noisiest
 * part of every preset that has a split film: the direct layer (with the
 * emission the camera sees: a light source is not noisy, and filtering it
 * into its surroundings moved the Cornell box's mean by 15 %) and the caustic
 * layer (sharp by nature) are kept as rendered, and beauty = direct +
 * indirect still holds. The signal is divided by the albedo of the surface
 * the pixel sees (the albedo AOV), filtered, and multiplied back, so that
 * texture detail is not blurred; where that albedo is (nearly) black it is
 * filtered as it is.
 *
 * Guides, per tap q of pixel p (SVGF §4.1):
 *   normal     max(0, n_p · n_q)^128
 *   depth      exp(-|z_p - z_q| / (|dz_p| · |p - q| + 1e-3 z_p)), dz the depth's
 *              change per pixel at p (the larger of its two central differences)
 *   luminance  exp(-|l_p - l_q| / (4 · sqrt(g(var_p)) + 1e-6)), var the variance of
 *              the lighting's luminance, g a 3×3 Gaussian blur of it
 * with the B3-spline kernel (1/16, 1/4, 3/8, 1/4, 1/16) spread 1, 2, 4, 8, 16
 * pixels over five passes, the variance carried along (var' = Σ (h w)² var / (Σ h w)²).
 *
 * The variance is estimated spatially, as SVGF does for pixels without
 * history, but over the four 4×4 quadrants around the pixel, keeping the
 * smallest (estimate_variance says why), weighted by the normal and depth
 * guides, then scaled by what the temporal blend averaged. The film keeps no per-sample
 * moments yet.
 *
 * A non-finite input value is treated as 0 and gets no weight, so one bad
 * pixel cannot spread.
 */
#include "denoise_internal.h"
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DENOISE_PASSES 5
/* Albedo below which a pixel is filtered as it is (a light source, black paint, nothing). */
#define DENOISE_MIN_ALBEDO 0.01f

/* Where the stage reads and writes in the image (channel indices). */
typedef struct denoise_channels {
    int beauty[3], direct[3], indirect[3], caustic[3], albedo[3], normal[3], depth;
} denoise_channels;

static float finite_or_zero(float value)
{
    return isfinite(value) ? value : 0.0f;
}

static void planes_free(denoise_planes *planes)
{
    free(planes->lighting);
    free(planes->direct);
    free(planes->albedo);
    free(planes->normal);
    free(planes->depth);
    free(planes->depth_step);
    free(planes->variance);
    free(planes->history_length);
    free(planes->variance_factor);
    free(planes->scratch);
    free(planes->planar);
}

/* Demodulated lighting and the guides from the image's channels. */
typedef struct fill_job {
    const pf_image *image;
    const denoise_channels *at;
    denoise_planes *planes;
} fill_job;

/* Rows [begin, end) of the planes from the image's layers. */
static void fill_rows(void *context, uint64_t begin, uint64_t end)
{
    const fill_job *job = context;
    const pf_image *image = job->image;
    const denoise_channels *at = job->at;
    denoise_planes *planes = job->planes;
    for (size_t p = (size_t)begin * image->width; p < (size_t)end * image->width; p++) {
        const float *in = image->pixels + p * image->channel_count;
        for (int c = 0; c < 3; c++) {
            float albedo = finite_or_zero(in[at->albedo[c]]);
            float signal = finite_or_zero(in[at->indirect[c]]) - finite_or_zero(in[at->caustic[c]]);
            int demodulate = albedo >= DENOISE_MIN_ALBEDO;
            planes->albedo[3 * p + c] = demodulate ? albedo : 1.0f;
            planes->lighting[3 * p + c] = demodulate ? signal / albedo : signal;
            planes->direct[3 * p + c] = finite_or_zero(in[at->direct[c]]);
            planes->normal[3 * p + c] = finite_or_zero(in[at->normal[c]]);
        }
        float depth = finite_or_zero(in[at->depth]);
        planes->depth[p] = depth > 0.0f ? depth : 0.0f;
        /* A frame's own lighting: a history of one, kept for the next frame where the
         * pixel sees a surface. */
        planes->history_length[p] = depth > 0.0f ? 1.0f : 0.0f;
        planes->variance_factor[p] = 1.0f;
    }
}

/* Rows [begin, end) of the depth steps (after every row's depth is in). */
static void depth_step_rows(void *context, uint64_t begin, uint64_t end)
{
    denoise_planes *planes = context;
    uint32_t w = planes->width, h = planes->height;
    for (uint32_t y = (uint32_t)begin; y < end; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            float z = planes->depth[p];
            float left = planes->depth[y * (size_t)w + (x > 0 ? x - 1 : x)];
            float right = planes->depth[y * (size_t)w + (x + 1 < w ? x + 1 : x)];
            float up = planes->depth[(size_t)(y > 0 ? y - 1 : y) * w + x];
            float down = planes->depth[(size_t)(y + 1 < h ? y + 1 : y) * w + x];
            /* Only neighbours on a surface count (the background's 0 is no depth). */
            float dx = left > 0.0f && right > 0.0f ? 0.5f * fabsf(right - left) : 0.0f;
            float dy = up > 0.0f && down > 0.0f ? 0.5f * fabsf(down - up) : 0.0f;
            planes->depth_step[p] = z > 0.0f ? fmaxf(dx, dy) : 0.0f;
        }
}

static int planes_fill(const pf_image *image, const denoise_channels *at, denoise_planes *planes)
{
    size_t pixels = (size_t)image->width * image->height;
    planes->width = image->width;
    planes->height = image->height;
    planes->lighting = malloc(3 * pixels * sizeof(float));
    planes->direct = malloc(3 * pixels * sizeof(float));
    planes->albedo = malloc(3 * pixels * sizeof(float));
    planes->normal = malloc(3 * pixels * sizeof(float));
    planes->depth = malloc(pixels * sizeof(float));
    planes->depth_step = malloc(pixels * sizeof(float));
    planes->variance = malloc(pixels * sizeof(float));
    planes->history_length = malloc(pixels * sizeof(float));
    planes->variance_factor = malloc(pixels * sizeof(float));
    if (!planes->lighting || !planes->direct || !planes->albedo || !planes->normal || !planes->depth ||
        !planes->depth_step || !planes->variance || !planes->history_length ||
        !planes->variance_factor)
        return 0;
    fill_job job = {image, at, planes};
    pf_run_ranges(image->height, DENOISE_MAX_THREADS, 1, fill_rows, &job);
    pf_run_ranges(image->height, DENOISE_MAX_THREADS, 1, depth_step_rows, planes);
    return 1;
}

/* What a run over the rows does: the planar guides (lighting and normals, before the variance
 * estimate), a pass's planar inputs (lighting and luminance scale), the variance estimate, an
 * à-trous pass. */
typedef enum filter_work { FILTER_GUIDES, FILTER_PREPARE, FILTER_VARIANCE, FILTER_ATROUS } filter_work;

typedef struct filter_job {
    denoise_planes *planes;
    filter_work work;
    int step; /* FILTER_ATROUS's spread */
} filter_job;

static void filter_rows(void *context, uint64_t begin, uint64_t end)
{
    const filter_job *job = context;
    switch (job->work) {
    case FILTER_GUIDES:
    case FILTER_PREPARE:
        pf_denoise_atrous_prepare(job->planes, (int)begin, (int)end,
                                  job->work == FILTER_PREPARE);
        break;
    case FILTER_VARIANCE:
        pf_denoise_variance_rows(job->planes, (int)begin, (int)end);
        break;
    case FILTER_ATROUS:
        pf_denoise_atrous_rows(job->planes, job->step, (int)begin, (int)end);
        break;
    }
}

/* Runs work over every row, split between the cores; rows only read the planes the work does
 * not write, so the slices need no locks. */
static void run_rows(denoise_planes *planes, filter_work work, int step)
{
    filter_job job = {planes, work, step};
    pf_run_ranges(planes->height, DENOISE_MAX_THREADS, 1, filter_rows, &job);
}

/* One à-trous pass of spread `step` from planes->lighting/variance into them again. */
static void atrous_pass(denoise_planes *planes, int step)
{
    run_rows(planes, FILTER_PREPARE, 0);
    run_rows(planes, FILTER_ATROUS, step);
    size_t pixels = (size_t)planes->width * planes->height;
    for (size_t p = 0; p < pixels; p++) {
        memcpy(planes->lighting + 3 * p, planes->scratch + 4 * p, 3 * sizeof(float));
        planes->variance[p] = planes->scratch[4 * p + 3];
    }
}

/* The `temporal` row: what the blend reused, or why it reused nothing. */
static void temporal_row(pf_frame_report *report, const pf_denoise_sequence *sequence,
                         int blended, const char *why_not, const denoise_temporal_stats *stats,
                         double wall_ms)
{
    pf_stage_timing *row = pf_frame_report_row(report, "temporal", blended ? NULL : why_not,
                                               wall_ms, -1.0);
    if (!row || !blended)
        return;
    double share = stats->surface_pixels
                       ? 100.0 * (double)stats->reprojected_pixels / (double)stats->surface_pixels
                       : 0.0;
    snprintf(row->reason, sizeof row->reason,
             "previous frame (%lld) on this worker; %.0f %% of pixels reprojected, memory %u "
             "frames (%s)",
             (long long)(sequence->frame - 1), share, stats->memory,
             stats->still ? "geometry unchanged" : "geometry moved");
    pf_stage_add_counter(row, "surface_pixels", (double)stats->surface_pixels);
    pf_stage_add_counter(row, "reprojected_pixels", (double)stats->reprojected_pixels);
    pf_stage_add_counter(row, "mean_history_frames", stats->mean_history);
    pf_stage_add_counter(row, "memory_frames", stats->memory);
}

/* The bytes a pixel of the device filter's largest plane (denoise_device.c: RGBA32F). */
#define DENOISE_DEVICE_PLANE_BYTES 16u

/* Where the filter runs: the device (renderer given, and its planes fit one device buffer
 * each; a larger frame is filtered on the host, and the row says why) or the host's cores. */
static int on_device(const pf_renderer *renderer, size_t pixels, int *too_large)
{
    *too_large = 0;
    if (!renderer)
        return 0;
    pf_denoise_site site = renderer->denoise_site;
    if (site == PF_DENOISE_SITE_AUTO)
        site = pf_vk_device_is_cpu(renderer->ctx) ? PF_DENOISE_SITE_HOST
                                                  : PF_DENOISE_SITE_DEVICE;
    if (site != PF_DENOISE_SITE_DEVICE)
        return 0;
    *too_large = (uint64_t)pixels * DENOISE_DEVICE_PLANE_BYTES >
                 pf_renderer_buffer_limit(renderer);
    return !*too_large;
}

typedef struct write_back_job {
    pf_image *image;
    const denoise_channels *at;
    const denoise_planes *planes;
    const float *estimate;
    int keep_noisy;
    uint32_t first_added;
} write_back_job;

/* Rows [begin, end) of the image from the filtered planes (and the noisy layer first). */
static void write_back_rows(void *context, uint64_t begin, uint64_t end)
{
    const write_back_job *job = context;
    pf_image *image = job->image;
    const denoise_channels *at = job->at;
    const denoise_planes *planes = job->planes;
    const float *estimate = job->estimate;
    int keep_noisy = job->keep_noisy;
    uint32_t first_added = job->first_added;
    for (size_t p = (size_t)begin * image->width; p < (size_t)end * image->width; p++) {
        float *texel = image->pixels + p * image->channel_count;
        if (keep_noisy) {
            for (int c = 0; c < 3; c++)
                texel[first_added + c] = finite_or_zero(texel[at->beauty[c]]);
            texel[first_added + 3] = estimate[p];
        }
        /* The direct light where the blend averaged it over frames (else as rendered);
         * beauty = direct + indirect, caustic ⊆ indirect: still so after filtering. */
        if (planes->history_length[p] > 1.0f)
            for (int c = 0; c < 3; c++)
                texel[at->direct[c]] = planes->direct[3 * p + c];
        for (int c = 0; c < 3; c++) {
            float indirect = finite_or_zero(texel[at->caustic[c]]) +
                             planes->lighting[3 * p + c] * planes->albedo[3 * p + c];
            texel[at->indirect[c]] = indirect;
            texel[at->beauty[c]] = finite_or_zero(texel[at->direct[c]]) + indirect;
        }
    }
}

/* The stage, the filter on renderer's device (NULL: on the host). */
static pf_status denoise_run(pf_renderer *renderer, pf_image *image, int keep_noisy,
                             const pf_denoise_sequence *sequence, pf_frame_report *report,
                             pf_error *err)
{
    double start = pf_time_ms();
    static const char *const layers[6] = {"", "direct.", "indirect.", "caustic.", "albedo.",
                                          "normal."};
    static const char *const rgb[3] = {"R", "G", "B"}, *const xyz[3] = {"X", "Y", "Z"};
    denoise_channels at;
    int *slots[6] = {at.beauty, at.direct, at.indirect, at.caustic, at.albedo, at.normal};
    for (int layer = 0; layer < 6; layer++)
        for (int c = 0; c < 3; c++) {
            char name[32];
            snprintf(name, sizeof name, "%s%s", layers[layer], layer == 5 ? xyz[c] : rgb[c]);
            slots[layer][c] = pf_image_channel(image, name);
            if (slots[layer][c] < 0)
                return pf_error_set(err, PF_ERR_INVALID, "denoise: the image has no %s channel",
                                    name);
        }
    at.depth = pf_image_channel(image, "depth.Z");
    if (at.depth < 0)
        return pf_error_set(err, PF_ERR_INVALID, "denoise: the image has no depth.Z channel");
    denoise_planes planes = {0};
    size_t pixels = (size_t)image->width * image->height;
    int too_large;
    int device = on_device(renderer, pixels, &too_large);
    /* The device estimates the variance from this frame's own lighting after a blend has
     * replaced it on the host: then a copy goes along (NULL: the lighting is the frame's
     * own). The variance layer is the estimate the filter started from (after any blend's
     * factor). */
    float *noisy = NULL;
    float *estimate = malloc(pixels * sizeof *estimate + 1); /* the row's mean, the layer */
    if (!planes_fill(image, &at, &planes) || !estimate) {
        planes_free(&planes);
        free(estimate);
        return pf_error_set(err, PF_ERR_NOMEM, "denoise: out of memory for %ux%u",
                            image->width, image->height);
    }
    /* The variance from this frame's own lighting, before any blend (the host's filter). */
    if (!device && !(planes.planar = malloc(PLANAR_COUNT * pixels * sizeof(float)))) {
        planes_free(&planes);
        free(estimate);
        return pf_error_set(err, PF_ERR_NOMEM, "denoise: out of memory for %ux%u",
                            image->width, image->height);
    }
    if (!device) {
        run_rows(&planes, FILTER_GUIDES, 0);
        run_rows(&planes, FILTER_VARIANCE, 0);
    }
    if (sequence) {
        double temporal_start = pf_time_ms();
        char why_not[PF_STAGE_REASON_MAX] = "--denoise spatial: every frame filtered alone";
        denoise_temporal_stats stats = {0};
        int blended = sequence->history &&
                      pf_denoise_history_usable(sequence->history, sequence, image->width,
                                                image->height, why_not, sizeof why_not);
        if (blended && device && !(noisy = malloc(3 * pixels * sizeof *noisy))) {
            planes_free(&planes);
            free(estimate);
            return pf_error_set(err, PF_ERR_NOMEM, "denoise: out of memory for %ux%u",
                                image->width, image->height);
        }
        if (noisy)
            memcpy(noisy, planes.lighting, 3 * pixels * sizeof *noisy);
        if (blended)
            denoise_temporal_blend(sequence->history, sequence, image, &planes, &stats);
        else if (sequence->first_length > 1.0f)
            /* A run's first frame rendered with more samples starts a longer history: the
             * next frame weighs it as that many frames. */
            for (size_t p = 0; p < pixels; p++)
                if (planes.history_length[p] > 0.0f)
                    planes.history_length[p] = sequence->first_length;
        /* Kept whatever happened, for the next frame (a fresh history where none was used);
         * out of memory only costs the next frame its reuse. */
        if (sequence->history && sequence->sequence)
            denoise_temporal_keep(sequence->history, sequence, &planes);
        temporal_row(report, sequence, blended, why_not, &stats, pf_time_ms() - temporal_start);
        start += pf_time_ms() - temporal_start; /* the denoise row is the filter's alone */
    }
    double noisy_variance = 0.0, gpu_ms = -1.0;
    pf_status status = PF_OK;
    pf_vk_traffic traffic = {0};
    if (device) {
        pf_vk_traffic before = pf_vk_traffic_of(renderer->ctx);
        status = denoise_device_filter(renderer, &planes, noisy, DENOISE_PASSES, estimate,
                                       &gpu_ms, err);
        traffic = pf_vk_traffic_since(renderer->ctx, before);
        for (size_t p = 0; status == PF_OK && p < pixels; p++)
            noisy_variance += estimate[p];
    } else if (!(planes.scratch = malloc(4 * pixels * sizeof(float)))) {
        status = pf_error_set(err, PF_ERR_NOMEM, "denoise: out of memory for %ux%u",
                              image->width, image->height);
    } else {
        for (size_t p = 0; p < pixels; p++) {
            planes.variance[p] *= planes.variance_factor[p];
            noisy_variance += planes.variance[p];
            estimate[p] = planes.variance[p];
        }
        for (int pass = 0; pass < DENOISE_PASSES; pass++)
            atrous_pass(&planes, 1 << pass);
    }
    free(noisy);

    uint32_t first_added = 0, channels_before = image->channel_count;
    if (status == PF_OK && keep_noisy)
        status = pf_image_later_layer(image, pf_noisy_channels, 4, &first_added, err);
    if (status != PF_OK) {
        free(estimate);
        planes_free(&planes);
        return status;
    }
    write_back_job job = {image, &at, &planes, estimate, keep_noisy, first_added};
    pf_run_ranges(image->height, DENOISE_MAX_THREADS, 1, write_back_rows, &job);
    free(estimate);
    planes_free(&planes);
    pf_stage_timing *row = pf_frame_report_row(report, "denoise", NULL, pf_time_ms() - start,
                                               gpu_ms);
    if (row) {
        snprintf(row->reason, sizeof row->reason,
                 "à-trous (%d passes) on the demodulated indirect light, on the %s%s",
                 DENOISE_PASSES, device ? "device" : "host",
                 too_large ? " (its planes exceed one device buffer)" : "");
        pf_stage_add_counter(row, "pixels", (double)pixels);
        pf_stage_add_counter(row, "passes", DENOISE_PASSES);
        pf_stage_add_counter(row, "mean_variance", noisy_variance / (double)pixels);
        pf_stage_add_counter(row, "on_device", device);
        /* 1: the noisy layer appended to a copy of the image (not created with it). */
        pf_stage_add_counter(row, "image_copied", image->channel_count != channels_before);
        if (device) /* one submission, one wait (issue 44) */
            pf_stage_add_traffic(row, traffic);
    }
    return PF_OK;
}

pf_status pf_denoise_image(pf_image *image, int keep_noisy, const pf_denoise_sequence *sequence,
                           pf_frame_report *report, pf_error *err)
{
    return denoise_run(NULL, image, keep_noisy, sequence, report, err);
}

pf_status pf_render_denoise(pf_renderer *renderer, pf_image *image, int keep_noisy,
                            const pf_denoise_sequence *sequence, pf_frame_report *report,
                            pf_error *err)
{
    return denoise_run(renderer, image, keep_noisy, sequence, report, err);
}
