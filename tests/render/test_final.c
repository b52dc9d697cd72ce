/*
 * The final integrator (pf_render_frame, quality final; issue 6): against the
 * reference path tracer on the Cornell box (whole image and channel by
 * channel), convergence as progressive passes grow (log-log slope of relMSE
 * against passes), stage rows (caustic map skipped without specular
 * materials, photon stages skipped without lights, maps reused on an
 * unchanged frame), determinism. Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_internal.h" /* pf_renderer.final_deferred_cap */
#include "render_test_env.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

/* Loads and evaluates a scene at time 0 (path relative to the env variable's directory). */
static pf_status scene_frame(const char *env, const char *relative, pf_scene **scene,
                             pf_scene_frame *frame, pf_error *err)
{
    const char *root = getenv(env);
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", root ? root : ".", relative);
    memset(frame, 0, sizeof *frame);
    pf_status status = pf_scene_load(path, scene, err);
    if (status == PF_OK)
        status = pf_scene_eval(*scene, 0.0, frame, err);
    return status;
}

static double counter_of(const pf_stage_timing *row, const char *name)
{
    for (uint32_t i = 0; row && i < row->counter_count; i++) {
        if (strcmp(row->counters[i].name, name) == 0)
            return row->counters[i].value;
    }
    return -1.0;
}

/* Small images: the suite runs twice (plain, ASan) on 2 cores. */
#define CORNELL_WIDTH 32u
#define CORNELL_HEIGHT 24u
/*
 * The reference the Cornell tests compare against: 512 spp. Its own relMSE
 * against the exact image is ≈ 0.128/512 = 2.5·10⁻⁴ (bench/RESULTS.md fit,
 * reference path tracer), below every bound and every convergence point here.
 */
#define REFERENCE_SPP 512u
/*
 * Two unbiased estimates of the same image with N and M samples differ by
 * relMSE ≈ c/N + c/M, c ≈ 0.128 on the Cornell box (bench/RESULTS.md). The
 * direct channels share the estimator, so final's direct after N passes
 * (one camera sample each) must be within twice that of the reference's.
 */
#define CORNELL_NOISE_C 0.128
#define CORNELL_PASSES 8u
#define CORNELL_PHOTONS 20000u

static pf_scene *cornell_scene;
static pf_scene_frame cornell_frame;
static pf_image cornell_reference;

static pf_render_settings final_settings(uint32_t width, uint32_t height, uint32_t passes,
                                         uint64_t seed, uint32_t photons)
{
    pf_render_settings settings = {width, height, PF_QUALITY_FINAL, passes, seed, 0, 0.0,
                                   photons};
    return settings;
}

PF_TEST(cornell_matches_reference_channel_by_channel)
{
    pf_error err = {0};
    pf_render_settings settings =
        final_settings(CORNELL_WIDTH, CORNELL_HEIGHT, CORNELL_PASSES, 3, CORNELL_PHOTONS);
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, &report, &err),
                  &err);
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&image, &cornell_reference, &metrics, &err), &err);
    double direct = ref_layer_relmse(&image, &cornell_reference, REF_CH_DIRECT);
    double indirect = ref_layer_relmse(&image, &cornell_reference, REF_CH_INDIRECT);
    double noise = CORNELL_NOISE_C / CORNELL_PASSES + CORNELL_NOISE_C / REFERENCE_SPP;
    double indirect_mean = ref_layer_mean(&image, REF_CH_INDIRECT);
    double reference_indirect_mean = ref_layer_mean(&cornell_reference, REF_CH_INDIRECT);
    printf("  relMSE %.5f (direct %.5f, noise bound %.5f; indirect %.5f), indirect mean %.5f "
           "vs %.5f\n",
           metrics.relmse, direct, 2.0 * noise, indirect, indirect_mean, reference_indirect_mean);
    /* Same estimator: only sampling noise separates the direct channels. */
    PF_CHECK_MSG(direct < 2.0 * noise, "direct relMSE %.5f above 2 × %.5f", direct, noise);
    /*
     * Indirect light comes from the photon maps (biased, consistent): at
     * 8 passes of 2·10⁴ photons the radius is 2-3 cm in a 55 cm box, and
     * the density estimate loses light within a radius of the box's edges
     * (measured: mean −1.5%, relMSE 0.0022). Bound the mean to 10% and the
     * relMSE to 0.01.
     */
    PF_CHECK_MSG(fabs(indirect_mean / reference_indirect_mean - 1.0) < 0.10,
                 "indirect mean %.5f vs reference %.5f", indirect_mean, reference_indirect_mean);
    PF_CHECK_MSG(indirect < 0.01, "indirect relMSE %.5f", indirect);
    PF_CHECK_MSG(metrics.relmse < 2.0 * noise + 0.01, "relMSE %.5f", metrics.relmse);
    /* No caustic paths in the Cornell box (no specular material): both are exactly 0. */
    PF_CHECK(ref_layer_mean(&image, REF_CH_CAUSTIC) == 0.0);
    const pf_stage_timing *shade = ref_row(&report, "shade");
    PF_CHECK(shade && counter_of(shade, "samples_per_pixel") == CORNELL_PASSES);
    PF_CHECK(shade && counter_of(shade, "loop_truncated") == 0.0);
    /* 3072 gather rays per pass against ~37,000 stored photons: no precomputed irradiance. */
    PF_CHECK(shade && counter_of(shade, "lookup_passes") == 0.0);
    PF_CHECK(counter_of(ref_row(&report, "photon_grid"), "irradiance_points") == 0.0);
    PF_CHECK(report.discarded_samples == 0);
    pf_image_free(&image);
}

/*
 * With few photons per pass beside the gather rays (3072 rays, ~1,100 stored
 * photons) the gather reads precomputed irradiance (frame_final.c's rule):
 * every pass does, and the grid stage says how many points it made. So few
 * photons need a radius of ~9 cm in the 55 cm box, whose edges then lose
 * light: measured, the indirect mean is 0.858 of the reference's with
 * lookups, 0.846 with estimates (the rule's ratio raised to disable them),
 * relMSE 0.0033 and 0.0034. Bounds: the mean to 20 %, relMSE to 0.01.
 */
#define LOOKUP_PHOTONS 600u

PF_TEST(cornell_with_precomputed_irradiance_matches_reference)
{
    pf_error err = {0};
    pf_render_settings settings =
        final_settings(CORNELL_WIDTH, CORNELL_HEIGHT, CORNELL_PASSES, 3, LOOKUP_PHOTONS);
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, &report, &err),
                  &err);
    const pf_stage_timing *shade = ref_row(&report, "shade");
    const pf_stage_timing *grid = ref_row(&report, "photon_grid");
    PF_REQUIRE(shade && grid);
    double stored = counter_of(grid, "stored"), points = counter_of(grid, "irradiance_points");
    double indirect = ref_layer_relmse(&image, &cornell_reference, REF_CH_INDIRECT);
    double ratio = ref_layer_mean(&image, REF_CH_INDIRECT) /
                   ref_layer_mean(&cornell_reference, REF_CH_INDIRECT);
    printf("  %g stored photons, %g irradiance points; indirect relMSE %.5f, mean %.4f of the "
           "reference's\n",
           stored, points, indirect, ratio);
    PF_CHECK(counter_of(shade, "lookup_passes") == CORNELL_PASSES);
    /* A coin of 1 in 4 per stored photon. */
    PF_CHECK(points > 0.2 * stored && points < 0.3 * stored);
    PF_CHECK(counter_of(grid, "irradiance_points_skipped") == 0.0);
    PF_CHECK_MSG(fabs(ratio - 1.0) < 0.20, "indirect mean %.4f of the reference's", ratio);
    PF_CHECK_MSG(indirect < 0.01, "indirect relMSE %.5f", indirect);
    PF_CHECK(report.discarded_samples == 0);
    /* Beyond FINAL_LOOKUP_MAX_PASSES passes the photon maps' bias shows: estimates again. */
    pf_image_free(&image);
    /* Its first 8 passes are the kept ones above, gridded with points: gathered by estimates. */
    settings.samples_per_pixel = 17;
    pf_frame_report longer = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, &longer, &err),
                  &err);
    PF_CHECK(counter_of(ref_row(&longer, "shade"), "lookup_passes") == 0.0);
    PF_CHECK(counter_of(ref_row(&longer, "photon_trace"), "reused_passes") == CORNELL_PASSES);
    pf_image_free(&image);
}

/*
 * The gather defers the estimates of the lookups that find no point to a
 * dispatch of their own (final_deferred.comp); past the
 * buffer's capacity (here capped at 1 per sample) it runs them at once. Both
 * give the same light: only the order of the sums differs. Both where the host
 * traces the rays (it reads the counters to decide the retrace) and where the
 * device does (final_retrace_args.comp decides it in the sample's one
 * submission).
 */
static void deferred_estimates_at(pf_trace_site site)
{
    pf_renderer_set_trace_site(renderer, site);
    pf_error err = {0};
    pf_render_settings settings =
        final_settings(CORNELL_WIDTH, CORNELL_HEIGHT, CORNELL_PASSES, 3, LOOKUP_PHOTONS);
    pf_image deferred, at_once;
    pf_frame_report deferred_report = {0}, at_once_report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &deferred,
                                  &deferred_report, &err),
                  &err);
    renderer->final_deferred_cap = 1;
    pf_status status = pf_render_frame(renderer, &cornell_frame, &settings, &at_once,
                                       &at_once_report, &err);
    renderer->final_deferred_cap = 0;
    PF_REQUIRE_OK(status, &err);
    const pf_stage_timing *shade = ref_row(&deferred_report, "shade");
    const pf_stage_timing *capped = ref_row(&at_once_report, "shade");
    double rays = (double)CORNELL_WIDTH * CORNELL_HEIGHT * CORNELL_PASSES * 4;
    double deferred_count = counter_of(shade, "deferred_estimates");
    double overflow = counter_of(capped, "deferred_overflow");
    double rgb = ref_layer_relmse(&at_once, &deferred, REF_CH_RGB);
    double indirect = ref_layer_relmse(&at_once, &deferred, REF_CH_INDIRECT);
    printf("  %g of %g gather rays deferred their estimate (%g past a cap of 1 per sample); "
           "relMSE between the two: RGB %.3g, indirect %.3g\n",
           deferred_count, rays, overflow, rgb, indirect);
    PF_CHECK(counter_of(shade, "lookup_passes") == CORNELL_PASSES);
    PF_CHECK(counter_of(capped, "lookup_passes") == CORNELL_PASSES);
    PF_CHECK(deferred_count > 0.0 && deferred_count < 0.5 * rays);
    PF_CHECK(counter_of(shade, "deferred_overflow") == 0.0);
    PF_CHECK(counter_of(capped, "deferred_estimates") == CORNELL_PASSES);
    PF_CHECK(overflow == deferred_count - CORNELL_PASSES);
    PF_CHECK_MSG(rgb < 1e-9 && indirect < 1e-9, "RGB relMSE %.3g, indirect %.3g", rgb, indirect);
    PF_CHECK(deferred_report.discarded_samples == 0 && at_once_report.discarded_samples == 0);
    /* The shade's submissions: the device's retrace adds none. */
    printf("  %s traces: shade %g submissions, %g with the cap\n",
           site == PF_TRACE_DEVICE ? "the device" : "the host", counter_of(shade, "submits"),
           counter_of(capped, "submits"));
    if (site == PF_TRACE_DEVICE)
        PF_CHECK(counter_of(capped, "submits") == counter_of(shade, "submits"));
    pf_image_free(&deferred);
    pf_image_free(&at_once);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
}

PF_TEST(deferred_estimates_match_those_run_in_the_gather)
{
    deferred_estimates_at(PF_TRACE_HOST);
    deferred_estimates_at(PF_TRACE_DEVICE);
}

/*
 * Least-squares slope of log relMSE against log passes of the indirect
 * channel (the photon-mapped part: caustic map + final gather into the
 * global map). Probabilistic PPM with α = 2/3 converges with MSE ∝ N^-2/3
 * where the photon density estimate dominates, and the gather's own noise
 * falls as N^-1: the issue asks for a slope between −0.5 and −0.9. Few
 * photons per pass so that the photon estimate matters at these pass counts
 * (measured with 4 gather rays per sample: −0.79, −0.73, −0.77 for seeds
 * 11, 12, 13; −0.85 at 2000 photons per pass).
 */
#define CONVERGENCE_PHOTONS 1000u
#define CONVERGENCE_POINTS 3u

PF_TEST(cornell_converges_over_passes_with_ppm_slope)
{
    pf_error err = {0};
    /*
     * From 4 passes on: at one pass the gather rays' sampling noise (∝ 1/N)
     * dominates the photon maps' error (measured slope ≈ −1 from 1 to 16).
     */
    const uint32_t passes[CONVERGENCE_POINTS] = {4, 16, 64};
    double x[CONVERGENCE_POINTS], y[CONVERGENCE_POINTS], full[CONVERGENCE_POINTS];
    for (uint32_t i = 0; i < CONVERGENCE_POINTS; i++) {
        pf_render_settings settings =
            final_settings(CORNELL_WIDTH, CORNELL_HEIGHT, passes[i], 11, CONVERGENCE_PHOTONS);
        pf_image image;
        PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, NULL, &err),
                      &err);
        pf_image_metrics metrics;
        PF_REQUIRE_OK(pf_image_compare(&image, &cornell_reference, &metrics, &err), &err);
        x[i] = log((double)passes[i]);
        y[i] = log(ref_layer_relmse(&image, &cornell_reference, REF_CH_INDIRECT));
        full[i] = metrics.relmse;
        printf("  %2u passes: indirect relMSE %.5f, image relMSE %.5f\n", passes[i], exp(y[i]),
               full[i]);
        pf_image_free(&image);
    }
    double mx = 0.0, my = 0.0;
    for (uint32_t i = 0; i < CONVERGENCE_POINTS; i++) {
        mx += x[i] / CONVERGENCE_POINTS;
        my += y[i] / CONVERGENCE_POINTS;
    }
    double sxy = 0.0, sxx = 0.0;
    for (uint32_t i = 0; i < CONVERGENCE_POINTS; i++) {
        sxy += (x[i] - mx) * (y[i] - my);
        sxx += (x[i] - mx) * (x[i] - mx);
    }
    double slope = sxy / sxx;
    printf("  log-log slope of the indirect relMSE: %.3f\n", slope);
    PF_CHECK_MSG(slope >= -0.9 && slope <= -0.5, "slope %.3f outside [-0.9, -0.5]", slope);
    for (uint32_t i = 1; i < CONVERGENCE_POINTS; i++)
        PF_CHECK_MSG(full[i] < full[i - 1], "image relMSE did not fall: %.5f then %.5f",
                     full[i - 1], full[i]);
}

/*
 * Stage rows: the Cornell box has no specular material (caustic_map skipped
 * with its reason); an unchanged second frame reuses the photon maps
 * (photon_trace and photon_grid skipped) and gives the identical image; the
 * same seed rendered fresh gives it too, another seed does not.
 */
PF_TEST(rows_reuse_and_determinism)
{
    pf_error err = {0};
    uint32_t w = 16, h = 12;
    pf_render_settings settings = final_settings(w, h, 2, 21, 5000);
    pf_render_settings other = final_settings(w, h, 2, 22, 5000);
    pf_image first, second, fresh, different;
    pf_frame_report report_first = {0}, report_second = {0}, report_fresh = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &other, &different, NULL, &err), &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &first, &report_first,
                                  &err),
                  &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &second, &report_second,
                                  &err),
                  &err);
    /* Only the camera moves: the tree and the photon maps are reused, with their reasons. */
    pf_scene_frame moved = cornell_frame;
    moved.camera.position[0] += 0.05f;
    pf_image moved_image;
    pf_frame_report report_moved = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &moved, &settings, &moved_image, &report_moved,
                                  &err),
                  &err);
    const pf_stage_timing *bih_moved = ref_row(&report_moved, "bih_build");
    const pf_stage_timing *trace_moved = ref_row(&report_moved, "photon_trace");
    PF_CHECK(bih_moved && bih_moved->skipped && strstr(bih_moved->reason, "geometry unchanged"));
    PF_CHECK(trace_moved && trace_moved->skipped &&
             strstr(trace_moved->reason, "photon maps reused"));
    pf_image_free(&moved_image);
    /* A different seed in between: nothing to reuse, so this one is traced afresh. */
    pf_image scratch;
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &other, &scratch, NULL, &err), &err);
    pf_image_free(&scratch);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &fresh, &report_fresh,
                                  &err),
                  &err);
    size_t bytes = (size_t)w * h * first.channel_count * sizeof(float);
    const pf_stage_timing *trace_first = ref_row(&report_first, "photon_trace");
    const pf_stage_timing *trace_second = ref_row(&report_second, "photon_trace");
    const pf_stage_timing *grid_second = ref_row(&report_second, "photon_grid");
    const pf_stage_timing *trace_fresh = ref_row(&report_fresh, "photon_trace");
    const pf_stage_timing *caustic = ref_row(&report_first, "caustic_map");
    PF_REQUIRE(trace_first && trace_second && grid_second && trace_fresh && caustic);
    PF_CHECK(!trace_first->skipped && counter_of(trace_first, "traced_passes") == 2.0);
    PF_CHECK(counter_of(trace_first, "photons") == 2.0 * 5000);
    PF_CHECK(trace_second->skipped &&
             strcmp(trace_second->reason, "lights and geometry unchanged → photon maps reused") ==
                 0);
    PF_CHECK(grid_second->skipped && counter_of(trace_second, "reused_passes") == 2.0);
    PF_CHECK(!trace_fresh->skipped);
    PF_CHECK(caustic->skipped &&
             strcmp(caustic->reason, "no specular or refractive material → no caustic map") == 0);
    /* caustic_scene_builds_the_caustic_map ran first: its caustic grids are not gathered from. */
    PF_CHECK(ref_layer_mean(&first, REF_CH_CAUSTIC) == 0.0 && ref_layer_mean(&different, REF_CH_CAUSTIC) == 0.0);
    PF_CHECK_MSG(memcmp(first.pixels, second.pixels, bytes) == 0, "reused maps changed the image");
    /*
     * Traced afresh, the same seed gives the same photons, but their order in
     * a map (and so in a grid cell) follows the tracing threads' atomic slot
     * claims, so estimates sum in another order: equal to float rounding
     * (bit-identity needs a content-ordered grid in core/photon).
     */
    double largest_difference = 0.0;
    for (size_t i = 0; i < bytes / sizeof(float); i++) {
        double a = first.pixels[i], b = fresh.pixels[i];
        double difference = fabs(a - b) / (fabs(a) + fabs(b) + 1e-6);
        largest_difference = difference > largest_difference ? difference : largest_difference;
    }
    printf("  fresh render of the same seed: largest relative difference %.3g\n",
           largest_difference);
    PF_CHECK_MSG(largest_difference < 1e-4, "same seed, other image (relative difference %.3g)",
                 largest_difference);
    PF_CHECK_MSG(memcmp(first.pixels, different.pixels, bytes) != 0, "other seed, same image");
    /* A changed light (the emissive material) is not reused. */
    pf_scene_frame changed = cornell_frame;
    pf_material *materials = malloc(changed.material_count * sizeof *materials);
    PF_REQUIRE(materials);
    memcpy(materials, changed.materials, changed.material_count * sizeof *materials);
    for (uint32_t m = 0; m < changed.material_count; m++)
        materials[m].emission[0] *= 0.5f;
    changed.materials = materials;
    pf_image dimmer;
    pf_frame_report report_dimmer = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &changed, &settings, &dimmer, &report_dimmer, &err),
                  &err);
    const pf_stage_timing *trace_dimmer = ref_row(&report_dimmer, "photon_trace");
    PF_CHECK(trace_dimmer && !trace_dimmer->skipped);
    free(materials);
    pf_image_free(&dimmer);
    pf_image_free(&first);
    pf_image_free(&second);
    pf_image_free(&fresh);
    pf_image_free(&different);
}

/* Without lights or emission nothing is traced: the photon rows say why, the image is black. */
PF_TEST(no_lights_skips_photon_stages)
{
    pf_error err = {0};
    pf_scene_frame dark = cornell_frame;
    pf_material *materials = malloc(dark.material_count * sizeof *materials);
    PF_REQUIRE(materials);
    memcpy(materials, dark.materials, dark.material_count * sizeof *materials);
    for (uint32_t m = 0; m < dark.material_count; m++)
        memset(materials[m].emission, 0, sizeof materials[m].emission);
    dark.materials = materials;
    dark.light_count = 0;
    dark.emissive_triangle_count = 0;
    pf_render_settings settings = final_settings(8, 6, 1, 1, 1000);
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &dark, &settings, &image, &report, &err), &err);
    const char *stages[] = {"photon_trace", "photon_grid", "caustic_map"};
    for (int i = 0; i < 3; i++) {
        const pf_stage_timing *row = ref_row(&report, stages[i]);
        PF_CHECK_MSG(row && row->skipped &&
                         strcmp(row->reason, "no lights or emissive surfaces → no photons") == 0,
                     "%s row", stages[i]);
    }
    PF_CHECK(ref_layer_mean(&image, REF_CH_RGB) == 0.0);
    free(materials);
    pf_image_free(&image);
}

/*
 * The caustic of caustic-anim (glass sphere and mirror torus under a point
 * light): the caustic map is built (row not skipped, photons stored) and the
 * caustic channel is lit where the sphere focuses light on the floor, and
 * is part of indirect. (The reference cannot render the caustics of a point
 * light, so this scene is not compared against it.)
 */
PF_TEST(caustic_scene_builds_the_caustic_map)
{
    pf_scene *scene = NULL;
    pf_scene_frame frame;
    pf_error err = {0};
    PF_REQUIRE_OK(scene_frame("PF_SHARED_SCENES", "caustic-anim/caustic-anim.gltf", &scene,
                              &frame, &err),
                  &err);
    pf_render_settings settings = final_settings(24, 18, 1, 5, 20000);
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &settings, &image, &report, &err), &err);
    const pf_stage_timing *caustic = ref_row(&report, "caustic_map");
    PF_REQUIRE(caustic);
    PF_CHECK_MSG(!caustic->skipped, "caustic_map skipped: %s", caustic->reason);
    PF_CHECK(counter_of(caustic, "photons") > 0.0);
    double caustic_mean = ref_layer_mean(&image, REF_CH_CAUSTIC);
    PF_CHECK_MSG(caustic_mean > 0.0, "caustic channel is black");
    size_t pixels = (size_t)image.width * image.height;
    int subset = 1;
    for (size_t p = 0; p < pixels; p++)
        for (uint32_t c = 0; c < 3; c++)
            subset = subset && image.pixels[p * image.channel_count + REF_CH_CAUSTIC + c] <=
                                   image.pixels[p * image.channel_count + REF_CH_INDIRECT + c] *
                                           (1.0f + 1e-5f) +
                                       1e-7f;
    PF_CHECK_MSG(subset, "caustic is not part of indirect");
    printf("  caustic photons %.0f, caustic mean %.5f\n", counter_of(caustic, "photons"),
           caustic_mean);
    pf_image_free(&image);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}


/*
 * The loop cap, never silent: a point light shut in a 10 cm white box
 * inside a 200 m scene. r_1 follows the mean photon density over the whole
 * scene's area (metres), but every photon stays in the box, so each gather
 * estimate would visit all of them: the estimates stop at their iteration
 * guard, and the frame fails saying so instead of rendering a silently
 * darker image.
 */
PF_TEST(clustered_photons_fail_the_frame_at_the_loop_cap)
{
    ref_scene scene;
    ref_scene_init(&scene);
    uint32_t white = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_LAMBERT, 0.9f, 0.9f,
                                                                 0.9f));
    const float floor_centre[3] = {0.0f, -10.0f, 0.0f}, floor_u[3] = {0.0f, 0.0f, 100.0f},
                floor_v[3] = {100.0f, 0.0f, 0.0f};
    ref_scene_add_quad(&scene, floor_centre, floor_u, floor_v, white);
    const float box_min[3] = {-0.05f, -0.05f, -0.05f}, box_max[3] = {0.05f, 0.05f, 0.05f};
    ref_scene_add_box(&scene, box_min, box_max, 1, white);
    ref_scene_add_light(&scene, (pf_light){.kind = PF_LIGHT_POINT, .intensity = {1.0f, 1.0f, 1.0f}});
    const float eye[3] = {0.0f, 0.0f, 0.03f}, target[3] = {0.0f, 0.0f, -0.05f},
                up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(&scene, eye, target, up, 1.0f);
    pf_render_settings settings = final_settings(8, 6, 1, 1, 20000);
    pf_image image;
    pf_frame_report report = {0};
    pf_error err = {0};
    pf_status status = pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err);
    printf("  status %d: %s\n", (int)status, err.message);
    PF_CHECK(status == PF_ERR_LIMIT);
    PF_CHECK(strstr(err.message, "loop cap") != NULL);
    PF_CHECK(image.pixels == NULL);
    ref_scene_free(&scene);
}

/* The time budget ends the passes early, after at least one. */
PF_TEST(time_budget_stops_after_at_least_one_pass)
{
    pf_error err = {0};
    pf_render_settings settings = final_settings(8, 6, 1000, 1, 1000);
    /* A nanosecond: every first pass exceeds it on any machine, loaded or not. */
    settings.time_budget_ms = 1e-6;
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, &report, &err),
                  &err);
    PF_CHECK(counter_of(ref_row(&report, "shade"), "samples_per_pixel") == 1.0);
    PF_CHECK(counter_of(ref_row(&report, "photon_trace"), "passes") == 1.0);
    pf_image_free(&image);
}

/*
 * final renders every size its film fits in one device buffer in one band, as reference and
 * fast do: its record of each pixel's D₁ is split in two buffers, neither larger than the
 * film (in one buffer of 5 vec4 a pixel, 1920x1080 needed 158 MiB, past lavapipe's 128 MiB
 * range). The smallest frame 1920 wide that one buffer could not hold renders; one row more
 * than the film allows renders in two bands (test_render_bands checks their image against the
 * whole one's). The camera looks away from the box, so the frame's rays all miss and it stays
 * cheap.
 */
PF_TEST(a_frame_as_large_as_its_film_allows_renders_and_one_row_more_in_bands)
{
    uint64_t limit = pf_vk_info(ctx)->max_storage_buffer_range;
    const uint64_t film_bytes_per_pixel = 3 * 16, one_record_bytes_per_pixel = 5 * 16;
    uint32_t width = 1920;
    uint64_t film_rows = limit / film_bytes_per_pixel / width;
    uint64_t rows = limit / one_record_bytes_per_pixel / width + 1;
    if (film_rows > 2048) {
        printf("  skipped: this device's %llu-byte buffers hold a film far past a testable size\n",
               (unsigned long long)limit);
        return;
    }
    PF_REQUIRE(rows <= film_rows && (uint64_t)width * rows * one_record_bytes_per_pixel > limit);
    pf_scene_frame away = cornell_frame;
    for (int k = 0; k < 3; k++) {
        away.camera.forward[k] = -cornell_frame.camera.forward[k];
        away.camera.right[k] = -cornell_frame.camera.right[k];
    }
    away.camera.aspect = 0.0f;
    pf_error err = {0};
    pf_render_settings settings = final_settings(width, (uint32_t)rows, 1, 1, 1000);
    pf_image image = {0};
    pf_frame_report report = {0};
    /* The device traces its missing rays: inside llvmpipe, not through the host's
     * traversal, which the sanitizer build slows down for 1.7 million rays. */
    pf_renderer_set_trace_site(renderer, PF_TRACE_DEVICE);
    double start = pf_time_ms();
    pf_status rendered = pf_render_frame(renderer, &away, &settings, &image, &report, &err);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
    PF_REQUIRE_OK(rendered, &err);
    printf("  final %ux%u (its D1 record %.0f MiB in one buffer, the device allows %.0f): %.0f ms\n",
           width, (unsigned)rows, (double)width * rows * one_record_bytes_per_pixel / 1048576.0,
           (double)limit / 1048576.0, pf_time_ms() - start);
    PF_CHECK(image.width == width && image.height == rows);
    PF_CHECK(counter_of(ref_row(&report, "shade"), "paths") == (double)width * rows);
    pf_image_free(&image);
    /* One row more than the film allows: the frame renders in two bands (render_bands.c),
     * the image whole. */
    settings.height = (uint32_t)film_rows + 1;
    memset(&report, 0, sizeof report);
    pf_renderer_set_trace_site(renderer, PF_TRACE_DEVICE);
    start = pf_time_ms();
    rendered = pf_render_frame(renderer, &away, &settings, &image, &report, &err);
    pf_renderer_set_trace_site(renderer, PF_TRACE_AUTO);
    PF_REQUIRE_OK(rendered, &err);
    printf("  final %ux%u (its film %.1f MiB, the device allows %.0f): %.0f ms in %.0f bands\n",
           width, settings.height,
           (double)width * settings.height * film_bytes_per_pixel / 1048576.0,
           (double)limit / 1048576.0, pf_time_ms() - start,
           counter_of(ref_row(&report, "shade"), "bands"));
    PF_CHECK(image.width == width && image.height == settings.height);
    PF_CHECK(counter_of(ref_row(&report, "shade"), "bands") == 2.0);
    PF_CHECK(counter_of(ref_row(&report, "shade"), "paths") == (double)width * settings.height);
    pf_image_free(&image);
}

int main(void)
{
    pf_error err = {0};
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    pf_render_settings reference = {CORNELL_WIDTH, CORNELL_HEIGHT, PF_QUALITY_REFERENCE,
                                    REFERENCE_SPP, 1, 0, 0.0, 0};
    if (scene_frame("PF_SOURCE_DIR", "scenes/cornell/cornell.gltf", &cornell_scene,
                    &cornell_frame, &err) != PF_OK ||
        pf_render_frame(renderer, &cornell_frame, &reference, &cornell_reference, NULL, &err) !=
            PF_OK) {
        fprintf(stderr, "Cornell reference: %s\n", err.message);
        return 1;
    }
    PF_RUN(cornell_matches_reference_channel_by_channel);
    PF_RUN(cornell_with_precomputed_irradiance_matches_reference);
    PF_RUN(deferred_estimates_match_those_run_in_the_gather);
    PF_RUN(cornell_converges_over_passes_with_ppm_slope);
    PF_RUN(caustic_scene_builds_the_caustic_map);
    PF_RUN(rows_reuse_and_determinism);
    PF_RUN(no_lights_skips_photon_stages);
    PF_RUN(time_budget_stops_after_at_least_one_pass);
    PF_RUN(clustered_photons_fail_the_frame_at_the_loop_cap);
    PF_RUN(a_frame_as_large_as_its_film_allows_renders_and_one_row_more_in_bands);
    pf_image_free(&cornell_reference);
    pf_scene_frame_free(&cornell_frame);
    pf_scene_destroy(cornell_scene);
    return render_test_finish(ctx, renderer);
}
