/*
 * A frame whose film exceeds one device buffer renders in bands of rows (render_bands.c):
 * with the bands' films held to a few rows (pf_renderer_set_band_bytes), every split preset's
 * image is the one it renders whole (the same camera, seeds and decisions; the photon maps and
 * volumes the first band made serve the others), its report has one row a stage with the
 * bands' work summed, and a time budget gives every band the samples the first reached.
 * Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;
static pf_scene *cornell_scene;
static pf_scene_frame cornell;

/* 40 x 30 pixels; bands of at most 11 rows: three bands of 10. */
#define WIDTH 40u
#define HEIGHT 30u
#define BAND_BYTES (WIDTH * 48u * 11u)

static pf_render_settings settings_of(pf_quality quality, uint32_t samples)
{
    pf_render_settings settings = pf_render_settings_default();
    settings.width = WIDTH;
    settings.height = HEIGHT;
    settings.quality = quality;
    settings.samples_per_pixel = samples;
    settings.photons_per_pass = 20000;
    settings.seed = 7;
    return settings;
}

/* The largest difference between two images' values, relative to the larger of 1 and the
 * value (the channels alike: the split's layers and the AOVs). */
static double largest_difference(const pf_image *a, const pf_image *b)
{
    if (a->width != b->width || a->height != b->height || a->channel_count != b->channel_count)
        return INFINITY;
    double largest = 0.0;
    size_t values = (size_t)a->width * a->height * a->channel_count;
    for (size_t i = 0; i < values; i++) {
        double x = a->pixels[i], y = b->pixels[i];
        double scale = fabs(x) > 1.0 ? fabs(x) : 1.0;
        double d = fabs(x - y) / scale;
        if (!(d <= largest)) /* NaN too */
            largest = isnan(d) ? INFINITY : d;
    }
    return largest;
}

static uint32_t rows_named(const pf_frame_report *report, const char *stage)
{
    uint32_t count = 0;
    for (uint32_t i = 0; i < report->stage_count; i++)
        count += !strcmp(report->stages[i].stage, stage);
    return count;
}

/* Renders settings whole, then in bands; the two images' largest difference. */
static double whole_against_bands(const pf_render_settings *settings, pf_frame_report *whole,
                                  pf_frame_report *banded)
{
    pf_error err = {0};
    pf_image a = {0}, b = {0};
    memset(whole, 0, sizeof *whole);
    memset(banded, 0, sizeof *banded);
    pf_renderer_set_band_bytes(renderer, 0);
    pf_status status = pf_render_frame(renderer, &cornell, settings, &a, whole, &err);
    if (status == PF_OK) {
        pf_renderer_set_band_bytes(renderer, BAND_BYTES);
        status = pf_render_frame(renderer, &cornell, settings, &b, banded, &err);
        pf_renderer_set_band_bytes(renderer, 0);
    }
    if (status != PF_OK)
        fprintf(stderr, "  %s: %s\n", pf_quality_name(settings->quality), err.message);
    double difference = status == PF_OK ? largest_difference(&a, &b) : INFINITY;
    pf_image_free(&a);
    pf_image_free(&b);
    return difference;
}

/*
 * Each split preset banded against whole: reference's paths are the pixels' own (bit for
 * bit); fast's and final's read photon maps and volumes the banded frame reuses from the whole
 * one (the same inputs), so they are bit for bit too. One row a stage; the shade row's paths
 * and rays are the whole frame's, its bands 3.
 */
PF_TEST(every_split_preset_renders_in_bands_what_it_renders_whole)
{
    static const pf_quality presets[3] = {PF_QUALITY_REFERENCE, PF_QUALITY_FAST,
                                          PF_QUALITY_FINAL};
    static const uint32_t samples[3] = {4, 2, 2};
    for (int p = 0; p < 3; p++) {
        pf_render_settings settings = settings_of(presets[p], samples[p]);
        pf_frame_report whole, banded;
        double difference = whole_against_bands(&settings, &whole, &banded);
        const char *name = pf_quality_name(presets[p]);
        printf("  %s: largest difference %.3g, shade rays %.0f whole, %.0f in bands\n", name,
               difference, ref_stage_counter(&whole, "shade", "rays"),
               ref_stage_counter(&banded, "shade", "rays"));
        PF_CHECK_MSG(difference == 0.0, "%s: %.3g", name, difference);
        PF_CHECK_MSG(ref_stage_counter(&banded, "shade", "bands") == 3.0, "%s", name);
        PF_CHECK_MSG(ref_stage_counter(&banded, "shade", "band_rows") == 10.0, "%s", name);
        PF_CHECK_MSG(isnan(ref_stage_counter(&whole, "shade", "bands")), "%s", name);
        PF_CHECK_MSG(ref_stage_counter(&banded, "shade", "paths") ==
                         ref_stage_counter(&whole, "shade", "paths"),
                     "%s", name);
        PF_CHECK_MSG(ref_stage_counter(&banded, "shade", "rays") ==
                         ref_stage_counter(&whole, "shade", "rays"),
                     "%s", name);
        for (uint32_t i = 0; i < banded.stage_count; i++)
            PF_CHECK_MSG(rows_named(&banded, banded.stages[i].stage) == 1, "%s: %u %s rows",
                         name, rows_named(&banded, banded.stages[i].stage),
                         banded.stages[i].stage);
        PF_CHECK_MSG(banded.stage_count == whole.stage_count, "%s: %u rows against %u", name,
                     banded.stage_count, whole.stage_count);
        const pf_stage_timing *shade = ref_row(&banded, "shade");
        PF_CHECK_MSG(shade && strstr(shade->reason, "3 bands of 10 rows"), "%s: %s", name,
                     shade ? shade->reason : "no shade row");
    }
}

/* Renders settings in bands of BAND_BYTES; 0 after failing the test. */
static int render_in_bands(const pf_render_settings *settings, pf_image *image,
                           pf_frame_report *report)
{
    pf_error err = {0};
    memset(report, 0, sizeof *report);
    pf_renderer_set_band_bytes(renderer, BAND_BYTES);
    pf_status status = pf_render_frame(renderer, &cornell, settings, image, report, &err);
    pf_renderer_set_band_bytes(renderer, 0);
    PF_CHECK_OK(status, &err);
    return status == PF_OK && ref_stage_counter(report, "shade", "bands") == 3.0;
}

/* A band of the frame whose photon maps the first band traced: the later bands trace none. */
PF_TEST(later_bands_reuse_the_first_bands_photon_maps)
{
    pf_render_settings settings = settings_of(PF_QUALITY_FINAL, 2);
    settings.seed = 8; /* maps no earlier frame kept */
    pf_image image = {0};
    pf_frame_report report;
    PF_REQUIRE(render_in_bands(&settings, &image, &report));
    /* The first band traced both passes; the row is its own (the others reused them). */
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "traced_passes") == 2.0);
    PF_CHECK(ref_stage_counter(&report, "photon_trace", "reused_passes") == 0.0);
    PF_CHECK(ref_stage_counter(&report, "shade", "paths") == (double)WIDTH * HEIGHT * 2.0);
    pf_image_free(&image);
}

/* A time budget every first pass exceeds: each band renders the one pass the first did, so
 * that no band has more samples than another. */
PF_TEST(a_time_budget_gives_every_band_the_first_bands_passes)
{
    pf_render_settings settings = settings_of(PF_QUALITY_FINAL, 8);
    settings.time_budget_ms = 1e-6;
    pf_image image = {0};
    pf_frame_report report;
    PF_REQUIRE(render_in_bands(&settings, &image, &report));
    PF_CHECK(ref_stage_counter(&report, "shade", "samples_per_pixel") == 1.0);
    PF_CHECK(ref_stage_counter(&report, "shade", "paths") == (double)WIDTH * HEIGHT);
    pf_image_free(&image);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer) || !ref_load_cornell(&cornell_scene, &cornell))
        return 1;
    PF_RUN(every_split_preset_renders_in_bands_what_it_renders_whole);
    PF_RUN(later_bands_reuse_the_first_bands_photon_maps);
    PF_RUN(a_time_budget_gives_every_band_the_first_bands_passes);
    pf_scene_frame_free(&cornell);
    pf_scene_destroy(cornell_scene);
    return render_test_finish(ctx, renderer);
}
