/*
 * Temporal reuse in the denoise stage (issue 40). On image sequences made here: a still
 * shot converges towards the truth over frames and flickers less than one frame's spatial
 * error; a square moving over a wall leaves no ghost where it was; a sequence broken (a
 * frame skipped, another sequence, another size, changed lights) starts afresh and its row
 * says why; a NaN neither spreads nor enters the history. On the Cornell box at 4 spp the
 * same holds through the renderer, whose frames draw camera samples of their own, and a
 * frame rendered without history (another worker's) stays within a stated distance of its
 * neighbour.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#define SIZE 48u
#define SQUARE 12u
#define SQUARE_STEP 3 /* pixels the square moves right per frame */
#define CHANNELS 22u

static pf_vk_context *ctx;
static pf_renderer *renderer;

static const char *const names[CHANNELS] = {
    "R",          "G",          "B",         "A",         "direct.R",   "direct.G",
    "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
    "caustic.B",  "albedo.R",   "albedo.G",  "albedo.B",  "normal.X",   "normal.Y",
    "normal.Z",   "depth.Z",    "motion.X",  "motion.Y"};
enum { R = 0, A = 3, DIRECT = 4, INDIRECT = 7, ALBEDO = 13, NORMAL = 16, DEPTH = 19, MOTION = 20 };

static double uniform(uint64_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    return (double)(*state >> 11) / 9007199254740992.0;
}

/* Left edge of the square in frame (1-based); -1000: no square. */
static int square_left(int64_t frame, int moving)
{
    return moving ? 4 + SQUARE_STEP * (int)(frame - 1) : -1000;
}

/*
 * Frame `frame` of a sequence: a wall at depth 4 whose indirect light rises left to right
 * (0.5 to 1.0, albedo 0.5), and, when moving, a 12-pixel square at depth 2 lit 3.0 moving
 * SQUARE_STEP pixels right per frame, its motion vectors saying so (Cycles' convention:
 * previous minus this position). Noise multiplies the indirect light by 1 + noise·(u − ½),
 * u drawn per pixel from the frame's own seed. truth: the same without noise.
 */
static void make_frame(pf_image *image, pf_image *truth, int64_t frame, int moving, double noise)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_image_create(image, SIZE, SIZE, CHANNELS, names, &err), &err);
    if (truth)
        PF_CHECK_OK(pf_image_create(truth, SIZE, SIZE, CHANNELS, names, &err), &err);
    uint64_t state = (uint64_t)frame * 2654435761u + 12345u;
    int left = square_left(frame, moving);
    for (uint32_t y = 0; y < SIZE; y++)
        for (uint32_t x = 0; x < SIZE; x++) {
            int in_square = (int)x >= left && (int)x < left + (int)SQUARE && y >= 18 &&
                            y < 18 + SQUARE;
            float light = in_square ? 3.0f : 0.5f + 0.5f * (float)x / (float)SIZE;
            float factor = (float)(1.0 + noise * (uniform(&state) - 0.5));
            for (int which = 0; which < 2; which++) {
                pf_image *target = which ? truth : image;
                if (!target)
                    continue;
                float *texel = target->pixels + ((size_t)y * SIZE + x) * CHANNELS;
                for (int c = 0; c < 3; c++) {
                    texel[ALBEDO + c] = 0.5f;
                    texel[DIRECT + c] = 0.05f;
                    texel[INDIRECT + c] = 0.5f * light * (which ? 1.0f : factor);
                    texel[R + c] = texel[DIRECT + c] + texel[INDIRECT + c];
                }
                texel[A] = 1.0f;
                texel[NORMAL + 2] = 1.0f;
                texel[DEPTH] = in_square ? 2.0f : 4.0f;
                texel[MOTION] = in_square && frame > 1 ? -(float)SQUARE_STEP : 0.0f;
            }
        }
}

/* pf_image_flicker, which the test's images always satisfy. */
static double flicker_relmse(const pf_image *a, const pf_image *b, const pf_image *truth)
{
    double flicker = NAN;
    pf_error err = {0};
    PF_CHECK_OK(pf_image_flicker(a, b, truth, &flicker, &err), &err);
    return flicker;
}

static pf_denoise_sequence sequence_at(pf_denoise_history *history, int64_t frame)
{
    pf_denoise_sequence sequence = {history, 77, frame, 5, 9, NULL};
    return sequence;
}

/* Denoises image as frame `frame` of sequence 77 (geometry fingerprint geometry). */
static void denoise(pf_image *image, pf_denoise_history *history, int64_t frame,
                    uint64_t geometry, pf_frame_report *report)
{
    pf_error err = {0};
    pf_denoise_sequence sequence = sequence_at(history, frame);
    sequence.geometry = geometry;
    memset(report, 0, sizeof *report);
    PF_CHECK_OK(pf_denoise_image(image, 0, &sequence, report, &err), &err);
}

PF_TEST(a_still_shot_converges_over_frames_and_flickers_less_than_a_frame_errs)
{
    pf_denoise_history *history = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_history_create(&history, &err), &err);
    pf_image previous = {0}, truth = {0};
    double first_error = 0.0, last_error = 0.0, flicker = 0.0;
    const int frames = 24;
    for (int64_t frame = 1; frame <= frames; frame++) {
        pf_image image;
        pf_image_free(&truth);
        make_frame(&image, &truth, frame, 0, 1.2);
        pf_frame_report report;
        denoise(&image, history, frame, 9, &report);
        const pf_stage_timing *row = ref_row(&report, "temporal");
        PF_REQUIRE(row != NULL);
        if (frame == 1)
            PF_CHECK_MSG(row->skipped, "frame 1 reused: %s", row->reason);
        else
            /* A still camera finds every pixel where it was. */
            PF_CHECK_MSG(!row->skipped &&
                             ref_stage_counter(&report, "temporal", "reprojected_pixels") ==
                                 SIZE * SIZE,
                         "frame %lld: %s", (long long)frame, row->reason);
        double error = ref_layer_relmse(&image, &truth, REF_CH_RGB);
        if (frame == 1)
            first_error = error;
        if (frame == frames) {
            last_error = error;
            flicker = flicker_relmse(&image, &previous, &truth);
        }
        pf_image_free(&previous);
        previous = image;
    }
    printf("  still shot: relMSE %.6f at frame 1, %.6f at frame %d; flicker %d→%d %.6f\n",
           first_error, last_error, frames, frames - 1, frames, flicker);
    /* 24 frames average the noise of up to 24: the error falls at least fourfold, and
     * consecutive frames differ by less than one frame alone is off (the issue's goal). */
    PF_CHECK_MSG(last_error < 0.25 * first_error, "relMSE %g at frame 1, %g at frame %d",
                 first_error, last_error, frames);
    PF_CHECK_MSG(flicker < first_error, "flicker %g, one frame's error %g", flicker,
                 first_error);
    pf_image_free(&previous);
    pf_image_free(&truth);
    pf_denoise_history_destroy(history);
}

PF_TEST(a_moving_square_leaves_no_ghost)
{
    pf_denoise_history *history = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_history_create(&history, &err), &err);
    const int frames = 6;
    for (int64_t frame = 1; frame <= frames; frame++) {
        pf_image image, truth;
        make_frame(&image, &truth, frame, 1, 0.0);
        pf_frame_report report;
        denoise(&image, history, frame, 100 + (uint64_t)frame, &report);
        if (frame == frames) {
            PF_CHECK_NEAR(ref_stage_counter(&report, "temporal", "memory_frames"), 5.0, 0.0);
            /* The wall the square uncovered this frame: it was the square's last frame;
             * reusing that would leave a bright trail (3.0 against ~0.6). */
            int left = square_left(frame, 1), ghosts = 0, wrong_square = 0;
            for (uint32_t y = 18; y < 18 + SQUARE; y++) {
                for (int x = left - SQUARE_STEP; x < left; x++)
                    ghosts += fabs(ref_pixel(&image, R, (uint32_t)x, y) /
                                       ref_pixel(&truth, R, (uint32_t)x, y) - 1.0) > 0.02;
                for (int x = left; x < left + (int)SQUARE; x++)
                    wrong_square += fabs(ref_pixel(&image, R, (uint32_t)x, y) /
                                             ref_pixel(&truth, R, (uint32_t)x, y) - 1.0) > 0.02;
            }
            PF_CHECK_MSG(ghosts == 0, "%d uncovered pixels off by more than 2 %%", ghosts);
            PF_CHECK_MSG(wrong_square == 0, "%d square pixels off by more than 2 %%",
                         wrong_square);
            /* Everything but the uncovered strip found its point in the previous frame. */
            double reprojected = ref_stage_counter(&report, "temporal", "reprojected_pixels");
            PF_CHECK_MSG(reprojected >= SIZE * SIZE - SQUARE * SQUARE_STEP - 2 * SQUARE &&
                             reprojected <= SIZE * SIZE - SQUARE * SQUARE_STEP,
                         "%g pixels reprojected", reprojected);
        }
        pf_image_free(&image);
        pf_image_free(&truth);
    }
    pf_denoise_history_destroy(history);
}

/* The temporal row of frame's denoising under sequence (history already holding what). */
static void expect_skip(pf_denoise_history *history, pf_denoise_sequence sequence,
                        uint32_t size, const char *why)
{
    pf_image image;
    pf_error err = {0};
    static const char *const channel_names[20] = {
        "R",        "G",        "B",        "A",        "direct.R", "direct.G", "direct.B",
        "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G", "caustic.B",
        "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z", "depth.Z"};
    PF_REQUIRE_OK(pf_image_create(&image, size, size, 20, channel_names, &err), &err);
    for (size_t p = 0; p < (size_t)size * size; p++) {
        float *texel = image.pixels + p * 20;
        texel[ALBEDO] = texel[ALBEDO + 1] = texel[ALBEDO + 2] = 0.5f;
        texel[NORMAL + 2] = 1.0f;
        texel[DEPTH] = 3.0f;
    }
    sequence.history = history;
    pf_frame_report report = {0};
    PF_CHECK_OK(pf_denoise_image(&image, 0, &sequence, &report, &err), &err);
    const pf_stage_timing *row = ref_row(&report, "temporal");
    PF_REQUIRE(row != NULL);
    PF_CHECK_MSG(row->skipped && strstr(row->reason, why), "frame %lld: \"%s\", wanted \"%s\"",
                 (long long)sequence.frame, row->reason, why);
    pf_image_free(&image);
}

PF_TEST(a_broken_sequence_starts_afresh_and_says_why)
{
    pf_denoise_history *history = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_history_create(&history, &err), &err);
    pf_denoise_sequence s = sequence_at(history, 1);
    expect_skip(history, s, 16, "no previous frame of this sequence on this worker");
    s.frame = 3; /* frame 2 went to another worker */
    expect_skip(history, s, 16, "frame 1 came before frame 3 on this worker: not consecutive");
    s.frame = 4;
    s.sequence = 78; /* another job */
    expect_skip(history, s, 16, "no previous frame of this sequence on this worker");
    s.frame = 5;
    expect_skip(history, s, 20, "the image size changed");
    s.frame = 6;
    s.lighting = 6;
    expect_skip(history, s, 20, "lights or materials changed since frame 5");
    s.frame = 7;
    s.sequence = 0; /* no sequence: nothing kept */
    expect_skip(history, s, 20, "no previous frame of this sequence on this worker");
    s.frame = 8;
    s.sequence = 78;
    /* What frame 6 left is still there: 7 kept nothing. */
    expect_skip(history, s, 20, "frame 6 came before frame 8 on this worker: not consecutive");
    /* --denoise spatial: no history at all. */
    pf_denoise_sequence spatial = {NULL, 78, 9, 6, 9, NULL};
    pf_image image, truth;
    make_frame(&image, &truth, 2, 0, 0.5);
    pf_frame_report report = {0};
    PF_CHECK_OK(pf_denoise_image(&image, 0, &spatial, &report, &err), &err);
    const pf_stage_timing *row = ref_row(&report, "temporal");
    PF_CHECK(row && row->skipped && strstr(row->reason, "--denoise spatial"));
    pf_image_free(&image);
    pf_image_free(&truth);
    pf_denoise_history_destroy(history);
}

PF_TEST(a_bad_pixel_neither_spreads_nor_stays)
{
    pf_denoise_history *history = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_history_create(&history, &err), &err);
    for (int64_t frame = 1; frame <= 3; frame++) {
        pf_image image;
        make_frame(&image, NULL, frame, 1, 0.4);
        if (frame == 2) {
            float *bad = image.pixels + ((size_t)10 * SIZE + 10) * CHANNELS;
            bad[INDIRECT] = NAN;
            bad[DEPTH] = INFINITY;
            bad = image.pixels + ((size_t)24 * SIZE + 20) * CHANNELS;
            bad[MOTION] = NAN;
            bad[MOTION + 1] = INFINITY;
        }
        pf_frame_report report;
        denoise(&image, history, frame, 9, &report);
        size_t bad_values = 0;
        for (size_t p = 0; p < (size_t)SIZE * SIZE; p++)
            for (int c = 0; c < 3; c++)
                bad_values += !isfinite(image.pixels[p * CHANNELS + R + c]) +
                              !isfinite(image.pixels[p * CHANNELS + INDIRECT + c]);
        PF_CHECK_MSG(bad_values == 0, "frame %lld: %zu non-finite values", (long long)frame,
                     bad_values);
        pf_image_free(&image);
    }
    pf_denoise_history_destroy(history);
}

/*
 * Through the renderer: the Cornell box at 4 spp, frames 1..12 of a still shot, each drawing
 * its camera samples from its own salt, against 512 spp. The error falls over the frames;
 * consecutive frames differ less than one frame errs; and frame 12 rendered by a renderer
 * that did not render 11 (another worker: no history) differs from frame 11 by no more than
 * two independent frames would.
 */
PF_TEST(the_cornell_box_converges_over_frames_of_a_still_shot)
{
    pf_scene *scene = NULL;
    pf_scene_frame frame;
    PF_REQUIRE(ref_load_cornell(&scene, &frame));
    pf_error err = {0};
    pf_image converged = {0};
    pf_render_settings reference = ref_settings(40, 30, 512, 1, 1);
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &reference, &converged, NULL, &err), &err);
    pf_denoise_history *history = NULL;
    PF_REQUIRE_OK(pf_denoise_history_create(&history, &err), &err);
    pf_render_settings low = ref_settings(40, 30, 4, 7, 1);
    pf_image previous = {0}, raw_first = {0};
    double first = 0.0, last = 0.0, flicker = 0.0, seam = 0.0;
    const int frames = 12;
    for (int64_t number = 1; number <= frames; number++) {
        pf_image image = {0};
        low.sample_salt = (uint64_t)number;
        PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &low, &image, NULL, &err), &err);
        if (number == 2) /* frames draw samples of their own */
            PF_CHECK_MSG(ref_layer_relmse(&image, &raw_first, REF_CH_RGB) > 0.0,
                         "frames 1 and 2 drew the same samples");
        if (number == 1)
            PF_REQUIRE_OK(pf_image_select(&image, names, 20, &raw_first, &err), &err);
        if (number == frames) {
            /* Another worker's frame 12: the same samples, no history. */
            pf_image fresh = {0};
            PF_REQUIRE_OK(pf_image_select(&image, names, 20, &fresh, &err), &err);
            PF_REQUIRE_OK(pf_denoise_image(&fresh, 0, NULL, NULL, &err), &err);
            seam = flicker_relmse(&fresh, &previous, &converged);
            pf_image_free(&fresh);
        }
        pf_denoise_sequence sequence = {history, 5, number, 1, 1, NULL};
        PF_REQUIRE_OK(pf_denoise_image(&image, 0, &sequence, NULL, &err), &err);
        double error = ref_layer_relmse(&image, &converged, REF_CH_RGB);
        if (number == 1)
            first = error;
        if (number == frames) {
            last = error;
            flicker = flicker_relmse(&image, &previous, &converged);
        }
        pf_image_free(&previous);
        previous = image;
    }
    printf("  cornell 40x30 at 4 spp: relMSE %.5f at frame 1, %.5f at frame %d; flicker "
           "%.5f; frame %d without history against frame %d %.5f\n",
           first, last, frames, flicker, frames, frames - 1, seam);
    PF_CHECK_MSG(last < 0.5 * first, "relMSE %g at frame 1, %g at frame %d", first, last,
                 frames);
    PF_CHECK_MSG(flicker < first, "flicker %g, one frame's error %g", flicker, first);
    /* Two independent frames differ by about twice one's error (their errors add). */
    PF_CHECK_MSG(seam < 2.0 * first, "a frame without history differs by %g (one frame errs "
                 "by %g)", seam, first);
    /* With --denoise spatial the salt is ignored: frames keep the seed's samples. */
    pf_render_settings spatial = low;
    spatial.denoise = PF_DENOISE_SPATIAL;
    pf_image a = {0}, b = {0};
    spatial.sample_salt = 1;
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &spatial, &a, NULL, &err), &err);
    spatial.sample_salt = 2;
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &spatial, &b, NULL, &err), &err);
    PF_CHECK(ref_layer_relmse(&a, &b, REF_CH_RGB) == 0.0);
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&previous);
    pf_image_free(&raw_first);
    pf_image_free(&converged);
    pf_denoise_history_destroy(history);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/*
 * The filter on the device (denoise_variance.comp, denoise_atrous.comp, forced on lavapipe,
 * whose AUTO site is the host) gives the host's image within float rounding: the Cornell box
 * at 4 spp over three frames of a still shot, each path with its own history.
 */
PF_TEST(the_device_filters_as_the_host_does)
{
    pf_scene *scene = NULL;
    pf_scene_frame frame;
    PF_REQUIRE(ref_load_cornell(&scene, &frame));
    pf_error err = {0};
    pf_denoise_history *host_history = NULL, *device_history = NULL;
    PF_REQUIRE_OK(pf_denoise_history_create(&host_history, &err), &err);
    PF_REQUIRE_OK(pf_denoise_history_create(&device_history, &err), &err);
    pf_render_settings low = ref_settings(40, 30, 4, 7, 1);
    double first_upload = 0.0;
    for (int64_t number = 1; number <= 3; number++) {
        pf_image host = {0}, device = {0};
        low.sample_salt = (uint64_t)number;
        PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &low, &host, NULL, &err), &err);
        PF_REQUIRE_OK(pf_image_append_channels(&host, NULL, 0, &device, &err), &err);
        pf_denoise_sequence on_host = {host_history, 5, number, 1, 1, NULL};
        pf_denoise_sequence on_device = {device_history, 5, number, 1, 1, NULL};
        pf_frame_report host_report = {0}, device_report = {0};
        pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_HOST);
        PF_REQUIRE_OK(pf_render_denoise(renderer, &host, 1, &on_host, &host_report, &err), &err);
        pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_DEVICE);
        PF_REQUIRE_OK(pf_render_denoise(renderer, &device, 1, &on_device, &device_report, &err),
                      &err);
        pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_AUTO);
        PF_CHECK(ref_stage_counter(&device_report, "denoise", "on_device") == 1.0);
        PF_CHECK(ref_stage_counter(&host_report, "denoise", "on_device") == 0.0);
        const pf_stage_timing *row = ref_row(&device_report, "denoise");
        PF_CHECK(row && strstr(row->reason, "on the device"));
        /* Uploads, the six kernels and the readbacks: one submission, one wait (issue 44). */
        PF_CHECK_MSG(ref_stage_counter(&device_report, "denoise", "submits") == 1.0 &&
                         ref_stage_counter(&device_report, "denoise", "host_waits") == 1.0,
                     "%g submits, %g waits",
                     ref_stage_counter(&device_report, "denoise", "submits"),
                     ref_stage_counter(&device_report, "denoise", "host_waits"));
        PF_CHECK(ref_stage_counter(&device_report, "denoise", "readback_bytes") ==
                 20.0 * host.width * host.height);
        /* The frame's own noisy lighting goes up (16 bytes a pixel) only where a blend
         * replaced the lighting: frames 2 and 3, not frame 1, which has no history. */
        double uploaded = ref_stage_counter(&device_report, "denoise", "upload_bytes");
        if (number == 1)
            first_upload = uploaded;
        PF_CHECK_MSG(uploaded - first_upload == (number > 1 ? 16.0 : 0.0) * host.width *
                                                    host.height,
                     "frame %lld: %g bytes uploaded, %g for frame 1", (long long)number,
                     uploaded, first_upload);
        /* Every channel, the variance layer included: within 1e-4 of the larger value. */
        double worst = 0.0;
        size_t values = (size_t)host.width * host.height * host.channel_count;
        PF_REQUIRE(device.channel_count == host.channel_count);
        for (size_t k = 0; k < values; k++) {
            double a = host.pixels[k], b = device.pixels[k];
            worst = fmax(worst, fabs(a - b) / fmax(fmax(fabs(a), fabs(b)), 1e-3));
        }
        printf("  frame %lld: device against host, largest relative difference %.3g\n",
               (long long)number, worst);
        PF_CHECK_MSG(worst < 1e-4, "frame %lld: the device differs by %g", (long long)number,
                     worst);
        pf_image_free(&host);
        pf_image_free(&device);
    }
    /* Without the noisy layers the row's mean variance is still the one both paths estimate. */
    pf_image host = {0}, device = {0};
    pf_frame_report host_report = {0}, device_report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &low, &host, NULL, &err), &err);
    PF_REQUIRE_OK(pf_image_append_channels(&host, NULL, 0, &device, &err), &err);
    pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_HOST);
    PF_REQUIRE_OK(pf_render_denoise(renderer, &host, 0, NULL, &host_report, &err), &err);
    pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_DEVICE);
    PF_REQUIRE_OK(pf_render_denoise(renderer, &device, 0, NULL, &device_report, &err), &err);
    pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_AUTO);
    double host_mean = ref_stage_counter(&host_report, "denoise", "mean_variance");
    double device_mean = ref_stage_counter(&device_report, "denoise", "mean_variance");
    PF_CHECK_MSG(host_mean > 0.0 && fabs(device_mean / host_mean - 1.0) < 1e-4,
                 "mean variance %g on the host, %g on the device", host_mean, device_mean);
    pf_image_free(&device);
    /* A frame whose planes (16 bytes a pixel) exceed one device buffer (a limit lowered
     * below this frame's 19,200 bytes) is filtered on the host, as the host filters it, and
     * the row says why. */
    pf_image unfiltered = {0}, fallback = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &low, &unfiltered, NULL, &err), &err);
    pf_frame_report fallback_report = {0};
    PF_REQUIRE_OK(pf_image_append_channels(&unfiltered, NULL, 0, &fallback, &err), &err);
    pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_DEVICE);
    pf_renderer_set_band_bytes(renderer, 16u * 40u * 30u - 1u);
    PF_REQUIRE_OK(pf_render_denoise(renderer, &fallback, 0, NULL, &fallback_report, &err), &err);
    pf_renderer_set_band_bytes(renderer, 0);
    pf_renderer_set_denoise_site(renderer, PF_DENOISE_SITE_AUTO);
    PF_CHECK(ref_stage_counter(&fallback_report, "denoise", "on_device") == 0.0);
    const pf_stage_timing *fallback_row = ref_row(&fallback_report, "denoise");
    PF_CHECK(fallback_row && strstr(fallback_row->reason, "exceed one device buffer"));
    PF_CHECK(fallback.channel_count == host.channel_count &&
             memcmp(fallback.pixels, host.pixels,
                    (size_t)host.width * host.height * host.channel_count * sizeof(float)) == 0);
    pf_image_free(&unfiltered);
    pf_image_free(&fallback);
    pf_image_free(&host);
    pf_denoise_history_destroy(host_history);
    pf_denoise_history_destroy(device_history);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

int main(void)
{
    PF_RUN(a_still_shot_converges_over_frames_and_flickers_less_than_a_frame_errs);
    PF_RUN(a_moving_square_leaves_no_ghost);
    PF_RUN(a_broken_sequence_starts_afresh_and_says_why);
    PF_RUN(a_bad_pixel_neither_spreads_nor_stays);
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(the_cornell_box_converges_over_frames_of_a_still_shot);
    PF_RUN(the_device_filters_as_the_host_does);
    return render_test_finish(ctx, renderer);
}
