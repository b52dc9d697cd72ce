/*
 * The fast integrator (pf_render_frame, quality fast; issue 11): the
 * Cornell box's indirect layer against the reference path tracer's, a
 * closed diffuse box lit by a point light (furnace-style), an open floor (no light of its
 * own comes back: the LPV scaled to the photons' energy), stage rows and
 * reuse across frames, and the hard cases: a thin wall between a lit and a
 * dark room, light just outside the finest cascade, a scene larger than
 * the coarsest cascade, an empty scene, a scene of emitters only.
 * Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

/* Small images: the suite runs twice (plain, ASan) on 2 cores. */
#define CORNELL_WIDTH 32u
#define CORNELL_HEIGHT 24u
#define REFERENCE_SPP 512u

static pf_render_settings fast_settings(uint32_t width, uint32_t height, uint32_t spp,
                                        uint64_t seed)
{
    pf_render_settings settings = {width, height, PF_QUALITY_FAST, spp, seed, 0, 0.0, 0};
    return settings;
}

static int row_skipped_because(const pf_frame_report *report, const char *stage,
                               const char *reason_part)
{
    const pf_stage_timing *row = ref_row(report, stage);
    return row && row->skipped && strstr(row->reason, reason_part) != NULL;
}

static int row_ran(const pf_frame_report *report, const char *stage)
{
    const pf_stage_timing *row = ref_row(report, stage);
    return row && !row->skipped;
}

static pf_scene *cornell_scene;
static pf_scene_frame cornell_frame;
static pf_image cornell_reference;

PF_TEST(cornell_indirect_matches_reference)
{
    pf_error err = {0};
    pf_render_settings settings = fast_settings(CORNELL_WIDTH, CORNELL_HEIGHT, 8, 5);
    pf_image image, preview;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &image, &report, &err),
                  &err);
    PF_CHECK(ref_layer_violations(&image, "fast") == 0);
    double indirect = ref_layer_relmse(&image, &cornell_reference, REF_CH_INDIRECT);
    double indirect_mean = ref_layer_mean(&image, REF_CH_INDIRECT);
    double reference_mean = ref_layer_mean(&cornell_reference, REF_CH_INDIRECT);
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&image, &cornell_reference, &metrics, &err), &err);
    /* preview: direct light only, RGB alone against the reference's RGB. */
    pf_render_settings preview_settings = settings;
    preview_settings.quality = PF_QUALITY_PREVIEW;
    preview_settings.samples_per_pixel = 0;
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &preview_settings, &preview, NULL,
                                  &err),
                  &err);
    static const char *const rgb[3] = {"R", "G", "B"};
    pf_image preview_rgb, reference_rgb, fast_rgb;
    PF_REQUIRE_OK(pf_image_select(&preview, rgb, 3, &preview_rgb, &err), &err);
    PF_REQUIRE_OK(pf_image_select(&cornell_reference, rgb, 3, &reference_rgb, &err), &err);
    PF_REQUIRE_OK(pf_image_select(&image, rgb, 3, &fast_rgb, &err), &err);
    pf_image_metrics preview_metrics, fast_metrics;
    PF_REQUIRE_OK(pf_image_compare(&preview_rgb, &reference_rgb, &preview_metrics, &err), &err);
    PF_REQUIRE_OK(pf_image_compare(&fast_rgb, &reference_rgb, &fast_metrics, &err), &err);
    printf("  fast: relMSE %.5f, indirect relMSE %.5f, indirect mean %.5f vs %.5f (%.3f; LPV "
           "energy scale %.3f); preview relMSE %.5f (%.1f× fast's)\n",
           fast_metrics.relmse, indirect, indirect_mean, reference_mean,
           indirect_mean / reference_mean,
           ref_stage_counter(&report, "shade", "lpv_energy_scale"), preview_metrics.relmse,
           preview_metrics.relmse / fast_metrics.relmse);
    /*
     * Guards against regression (measured at 32×24, 8 spp: indirect relMSE
     * 0.0087, mean 0.90 of the reference's with the LPV scaled to the photons'
     * energy by the direction surfaces face, 0.0095 and 0.93 unscaled; the
     * image's relMSE 0.024 is mostly the direct light's sampling noise at 8 spp
     * against preview's 0.075): indirect relMSE below 0.015, indirect mean
     * within 20%, and at least 3× preview's error on the whole image.
     */
    PF_CHECK_MSG(indirect < 0.015, "indirect relMSE %.5f", indirect);
    PF_CHECK_MSG(fabs(indirect_mean / reference_mean - 1.0) < 0.20, "indirect mean ratio %.3f",
                 indirect_mean / reference_mean);
    PF_CHECK_MSG(preview_metrics.relmse > 3.0 * fast_metrics.relmse,
                 "preview %.5f vs fast %.5f", preview_metrics.relmse, fast_metrics.relmse);
    /* No specular material: no caustic map, caustic layer exactly 0. */
    PF_CHECK(row_skipped_because(&report, "caustic_map", "no specular"));
    PF_CHECK(ref_layer_mean(&image, REF_CH_CAUSTIC) == 0.0);
    PF_CHECK(ref_stage_counter(&report, "lpv_propagate", "cascades") == PF_LPV_DEFAULT_CASCADES);
    PF_CHECK(ref_stage_counter(&report, "lpv_propagate", "iterations_cascade0") ==
             PF_LPV_DEFAULT_ITERATIONS);
    /* On the host's CPUs exactly where the device is the CPU (lavapipe). */
    PF_CHECK(ref_stage_counter(&report, "lpv_propagate", "on_host") ==
             (strcmp(pf_vk_info(ctx)->type, "cpu") == 0 ? 1.0 : 0.0));
    PF_CHECK(ref_stage_counter(&report, "lpv_inject", "vpls") > 1000.0);
    PF_CHECK(ref_stage_counter(&report, "lpv_inject", "outside") == 0.0);
    PF_CHECK(ref_stage_counter(&report, "lpv_geometry", "scene_covered") == 1.0);
    PF_CHECK(ref_stage_counter(&report, "shade", "lpv_outside") == 0.0);
    pf_image_free(&image);
    pf_image_free(&preview);
    pf_image_free(&preview_rgb);
    pf_image_free(&reference_rgb);
    pf_image_free(&fast_rgb);
}

PF_TEST(second_frame_reuses_every_lpv_stage_and_matches)
{
    pf_error err = {0};
    pf_render_settings settings = fast_settings(CORNELL_WIDTH, CORNELL_HEIGHT, 2, 9);
    pf_image first, second;
    pf_frame_report report1 = {0}, report2 = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &first, &report1, &err),
                  &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &second, &report2, &err),
                  &err);
    PF_CHECK(row_ran(&report1, "photon_trace"));
    PF_CHECK(row_skipped_because(&report2, "photon_trace", "unchanged"));
    PF_CHECK(row_skipped_because(&report2, "lpv_geometry", "unchanged"));
    PF_CHECK(row_skipped_because(&report2, "lpv_inject", "unchanged"));
    PF_CHECK(row_skipped_because(&report2, "lpv_propagate", "unchanged"));
    PF_CHECK(row_ran(&report2, "shade"));
    size_t bytes = (size_t)first.width * first.height * first.channel_count * sizeof(float);
    PF_CHECK(first.channel_count == second.channel_count &&
             memcmp(first.pixels, second.pixels, bytes) == 0);
    /* A camera moved within the finest cell: cascades unchanged, the LPV reused. */
    pf_scene_frame moved = cornell_frame;
    float cell = (float)ref_stage_counter(&report1, "lpv_geometry", "finest_cell_m");
    PF_REQUIRE(cell > 0.0f);
    moved.camera.position[0] += 0.2f * cell;
    float snapped = floorf(cornell_frame.camera.position[0] / cell);
    if (floorf(moved.camera.position[0] / cell) != snapped)
        moved.camera.position[0] -= 0.4f * cell;
    pf_image third;
    pf_frame_report report3 = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &moved, &settings, &third, &report3, &err), &err);
    PF_CHECK(row_skipped_because(&report3, "lpv_propagate", "unchanged"));
    /* Only the camera moved: the tree and the photons are reused too, and say so. */
    PF_CHECK(row_skipped_because(&report3, "bih_build", "geometry unchanged"));
    PF_CHECK(row_skipped_because(&report3, "photon_trace", "unchanged"));
    PF_CHECK(row_ran(&report3, "shade"));
    /* A light that changes: photons, injection and propagation run again, geometry stays. */
    pf_scene_frame relit = cornell_frame;
    pf_material materials[64];
    PF_REQUIRE(cornell_frame.material_count <= 64);
    memcpy(materials, cornell_frame.materials, cornell_frame.material_count * sizeof *materials);
    for (uint32_t m = 0; m < cornell_frame.material_count; m++)
        for (int c = 0; c < 3; c++)
            materials[m].emission[c] *= 0.5f;
    relit.materials = materials;
    pf_image fourth;
    pf_frame_report report4 = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &relit, &settings, &fourth, &report4, &err), &err);
    PF_CHECK(row_ran(&report4, "photon_trace"));
    PF_CHECK(row_skipped_because(&report4, "lpv_geometry", "unchanged"));
    PF_CHECK(row_ran(&report4, "lpv_inject"));
    PF_CHECK(row_ran(&report4, "lpv_propagate"));
    double ratio = ref_layer_mean(&fourth, REF_CH_INDIRECT) / ref_layer_mean(&first, REF_CH_INDIRECT);
    printf("  half the light: indirect ratio %.4f\n", ratio);
    PF_CHECK_NEAR(ratio, 0.5, 0.03);
    pf_image_free(&first);
    pf_image_free(&second);
    pf_image_free(&third);
    pf_image_free(&fourth);
}

PF_TEST(other_presets_between_fast_frames_change_nothing)
{
    /* A renderer serving jobs of every preset: fast, then final and preview, then fast again. */
    pf_error err = {0};
    pf_render_settings settings = fast_settings(CORNELL_WIDTH, CORNELL_HEIGHT, 2, 21);
    pf_render_settings final = settings, small = settings;
    final.quality = PF_QUALITY_FINAL;
    final.photons_per_pass = 2000;
    small.width = small.height = 8;
    pf_image first, other, again;
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &small, &other, NULL, &err), &err);
    pf_image_free(&other);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &first, NULL, &err), &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &final, &other, NULL, &err), &err);
    pf_image_free(&other);
    settings.quality = PF_QUALITY_PREVIEW;
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &other, NULL, &err), &err);
    pf_image_free(&other);
    settings.quality = PF_QUALITY_FAST;
    PF_REQUIRE_OK(pf_render_frame(renderer, &cornell_frame, &settings, &again, NULL, &err), &err);
    double drift = ref_layer_relmse(&again, &first, REF_CH_RGB);
    printf("  fast after final and preview: relMSE %.3g against the first fast frame\n", drift);
    /* Photons are stored by atomics (order varies): equal to float rounding, not bit for bit. */
    PF_CHECK(drift < 1e-6);
    pf_image_free(&first);
    pf_image_free(&again);
}

/*
 * A closed box of albedo `albedo`, a point light at its centre, camera inside; its faces
 * inward, or (flipped) outward with a double-sided material, as exported files often have.
 */
static void lit_box_faces(ref_scene *scene, float albedo, int flipped)
{
    ref_scene_init(scene);
    pf_material material = ref_material(PF_MATERIAL_LAMBERT, albedo, albedo, albedo);
    if (flipped)
        material.flags |= PF_MATERIAL_DOUBLE_SIDED;
    uint32_t wall = ref_scene_add_material(scene, material);
    const float lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    ref_scene_add_box(scene, lo, hi, !flipped, wall);
    pf_light light = {.position = {0.0f, 0.3f, 0.0f}, .kind = PF_LIGHT_POINT,
                      .intensity = {2.0f, 2.0f, 2.0f}};
    ref_scene_add_light(scene, light);
    const float eye[3] = {0.0f, 0.0f, 0.9f}, target[3] = {0.0f, -0.2f, -1.0f},
                up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(scene, eye, target, up, 1.3f);
}

static void lit_box(ref_scene *scene, float albedo)
{
    lit_box_faces(scene, albedo, 0);
}

/*
 * A variant of the closed box that must render as the box itself: the scale counter named
 * and the indirect mean within 5 % of the box's (box_report, box_mean; exact: the
 * reference's mean, printed).
 */
static void check_like_the_box(const ref_scene *variant, const pf_render_settings *settings,
                               const char *what, const char *scale_counter,
                               const pf_frame_report *box_report, double box_mean, double exact)
{
    pf_error err = {0};
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &variant->frame, settings, &image, &report, &err),
                  &err);
    double scale = ref_stage_counter(&report, "shade", scale_counter);
    double box_scale = ref_stage_counter(box_report, "shade", scale_counter);
    double mean = ref_layer_mean(&image, REF_CH_INDIRECT);
    printf("  %s: indirect mean %.5f (%.3f), %s %.3f (the box's %.3f)\n", what, mean,
           mean / exact, scale_counter, scale, box_scale);
    PF_CHECK_MSG(fabs(scale / box_scale - 1.0) < 0.05, "%s: scale %.3f vs %.3f", what, scale,
                 box_scale);
    PF_CHECK_MSG(fabs(mean / box_mean - 1.0) < 0.05, "%s: mean %.5f vs %.5f", what, mean,
                 box_mean);
    pf_image_free(&image);
}

PF_TEST(closed_box_indirect_matches_reference)
{
    pf_error err = {0};
    ref_scene box;
    lit_box(&box, 0.5f);
    pf_render_settings reference = ref_settings(24, 24, 256, 3, 0);
    pf_render_settings settings = fast_settings(24, 24, 4, 3);
    pf_image expected, image;
    PF_REQUIRE_OK(pf_render_frame(renderer, &box.frame, &reference, &expected, NULL, &err), &err);
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &box.frame, &settings, &image, &report, &err), &err);
    double fast = ref_layer_mean(&image, REF_CH_INDIRECT), exact = ref_layer_mean(&expected, REF_CH_INDIRECT);
    double relmse = ref_layer_relmse(&image, &expected, REF_CH_INDIRECT);
    double scale = ref_stage_counter(&report, "shade", "lpv_energy_scale");
    printf("  closed box (albedo 0.5): indirect mean %.5f vs reference %.5f (%.3f), relMSE "
           "%.5f, LPV energy scale %.3f\n",
           fast, exact, fast / exact, relmse, scale);
    /* No light leaves a closed box: the photons' arrivals exceed the LPV's delivery (it loses
     * some in the propagation), and the scale, which only takes light off, is 1. */
    PF_CHECK_MSG(scale == 1.0, "scale %.3f", scale);
    /* Faces outward, double-sided: the photons arrive on the back faces and the LPV's light
     * is weighed on the brighter face, so the scale and the light stay those of the box
     * (weighing front faces only, the scale was near 0 and so was the light). */
    ref_scene flipped;
    lit_box_faces(&flipped, 0.5f, 1);
    check_like_the_box(&flipped, &settings, "the same box facing outward, double-sided",
                       "lpv_energy_scale", &report, fast, exact);
    ref_scene_free(&flipped);
    /* A shelf across the box that an alpha mask cuts away whole: photons pass it, and so
     * must the LPV's light (the geometry volume) and its weighing (the points on it). */
    ref_scene shelved;
    lit_box(&shelved, 0.5f);
    pf_material cut = ref_material(PF_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f);
    cut.alpha = 0.2f;
    cut.alpha_mode = PF_ALPHA_MASK;
    cut.alpha_cutoff = 0.5f;
    uint32_t shelf = ref_scene_add_material(&shelved, cut);
    const float shelf_centre[3] = {0.0f, -0.5f, 0.0f}, along_z[3] = {0, 0, 1},
                along_x[3] = {1, 0, 0};
    ref_scene_add_quad(&shelved, shelf_centre, along_z, along_x, shelf); /* faces +y */
    check_like_the_box(&shelved, &settings, "with a shelf cut away by its alpha", "lpv_scale_py",
                       &report, fast, exact);
    ref_scene_free(&shelved);
    /*
     * Every bounce is in the VPLs, but the propagation loses some of it
     * (measured 0.79 of the reference's mean: 2-band lobes spread light
     * sideways, and light crossing the box diagonally runs out of
     * iterations; scaling up to the photons' energy would give 1.01, but in
     * the demo's Cornell box it brightened walls the LPV had right, so the
     * scale stops at 1); guard the mean within 25% and the relMSE below 0.06.
     */
    PF_CHECK_MSG(fabs(fast / exact - 1.0) < 0.25, "ratio %.3f", fast / exact);
    PF_CHECK_MSG(relmse < 0.06, "relMSE %.5f", relmse);
    PF_CHECK(ref_layer_violations(&image, "box") == 0);
    pf_image_free(&expected);
    pf_image_free(&image);
    ref_scene_free(&box);
}

/*
 * A lit floor and nothing else: the light it reflects leaves and never comes back, so its
 * indirect light is exactly 0. The LPV's propagation spreads light like a diffusion and
 * brings some of it back down (measured half the direct light unscaled); scaled to the
 * photons' energy, none of them arrive anywhere, and the scale is 0.
 */
PF_TEST(open_floor_gets_none_of_its_own_light_back)
{
    pf_error err = {0};
    ref_scene floor;
    ref_scene_init(&floor);
    uint32_t grey = ref_scene_add_material(&floor, ref_material(PF_MATERIAL_LAMBERT, 0.8f, 0.8f,
                                                                0.8f));
    const float centre[3] = {0, 0, 0}, half_z[3] = {0, 0, 20}, half_x[3] = {20, 0, 0};
    ref_scene_add_quad(&floor, centre, half_z, half_x, grey); /* faces +y */
    pf_light light = {.position = {0.0f, 2.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                      .intensity = {20.0f, 20.0f, 20.0f}};
    ref_scene_add_light(&floor, light);
    const float eye[3] = {0.0f, 1.5f, 3.0f}, target[3] = {0.0f, 0.0f, -1.0f},
                up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(&floor, eye, target, up, 1.2f);
    pf_render_settings settings = fast_settings(24, 24, 2, 1);
    pf_render_settings unscaled = settings;
    unscaled.lpv.unscaled = 1;
    pf_image image, raw;
    pf_frame_report report = {0}, raw_report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &floor.frame, &settings, &image, &report, &err),
                  &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &floor.frame, &unscaled, &raw, &raw_report, &err),
                  &err);
    double direct = ref_layer_mean(&image, REF_CH_DIRECT);
    double raw_indirect = ref_layer_mean(&raw, REF_CH_INDIRECT);
    printf("  open floor: direct %.5f, indirect %.5f (unscaled %.5f, %.2f of direct)\n", direct,
           ref_layer_mean(&image, REF_CH_INDIRECT), raw_indirect, raw_indirect / direct);
    PF_CHECK(direct > 0.0);
    PF_CHECK(ref_layer_mean(&image, REF_CH_INDIRECT) == 0.0);
    PF_CHECK(ref_stage_counter(&report, "shade", "lpv_energy_scale") == 0.0);
    /* What the scale removes: the LPV's own light, there without it. */
    PF_CHECK_MSG(raw_indirect > 0.2 * direct, "unscaled indirect %.5f", raw_indirect);
    PF_CHECK(ref_stage_counter(&raw_report, "shade", "lpv_energy_scale") == 1.0);
    PF_CHECK(ref_layer_mean(&image, REF_CH_DIRECT) == ref_layer_mean(&raw, REF_CH_DIRECT));
    pf_image_free(&image);
    pf_image_free(&raw);
    ref_scene_free(&floor);
}

/*
 * Two rooms [-1, 0] and [0, 1] along x (each 1 m deep and high) sharing a
 * zero-thickness wall at x = 0 (two quads back to back, one facing each
 * room); a point light in the left room. The right room is exactly dark.
 */
static void two_rooms(ref_scene *scene, int look_left)
{
    ref_scene_init(scene);
    uint32_t wall = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.7f,
                                                               0.7f));
    const float lo[3] = {-1, 0, 0}, hi[3] = {1, 1, 1};
    ref_scene_add_box(scene, lo, hi, 1, wall);
    const float centre[3] = {0.0f, 0.5f, 0.5f}, half_y[3] = {0, 0.5f, 0}, half_z[3] = {0, 0, 0.5f};
    ref_scene_add_quad(scene, centre, half_y, half_z, wall);  /* faces +x: the right room */
    ref_scene_add_quad(scene, centre, half_z, half_y, wall);  /* faces −x: the left room */
    pf_light light = {.position = {-0.5f, 0.5f, 0.5f}, .kind = PF_LIGHT_POINT,
                      .intensity = {1.0f, 1.0f, 1.0f}};
    ref_scene_add_light(scene, light);
    float eye[3] = {look_left ? -0.95f : 0.95f, 0.5f, 0.5f};
    float target[3] = {0.0f, 0.3f, 0.5f};
    const float up[3] = {0.0f, 1.0f, 0.0f};
    ref_scene_look_at(scene, eye, target, up, 1.2f);
}

PF_TEST(thin_wall_leaks_little_light_into_the_dark_room)
{
    pf_error err = {0};
    ref_scene lit, dark;
    two_rooms(&lit, 1);
    two_rooms(&dark, 0);
    pf_render_settings settings = fast_settings(24, 24, 2, 1);
    pf_image lit_image, dark_image;
    PF_REQUIRE_OK(pf_render_frame(renderer, &lit.frame, &settings, &lit_image, NULL, &err), &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &dark.frame, &settings, &dark_image, NULL, &err),
                  &err);
    double lit_indirect = ref_layer_mean(&lit_image, REF_CH_INDIRECT);
    double leak = ref_layer_mean(&dark_image, REF_CH_RGB);
    printf("  lit room indirect %.5f, dark room %.6f: leak %.2f%%\n", lit_indirect, leak,
           100.0 * leak / lit_indirect);
    PF_CHECK(lit_indirect > 0.0);
    /* The dark room sees no direct light at all; what it shows is LPV light through the wall. */
    PF_CHECK(ref_layer_mean(&dark_image, REF_CH_DIRECT) == 0.0);
    /* Measured 4.3% (face-exact geometry volume, no interpolation across it); bound 6%. */
    PF_CHECK_MSG(leak < 0.06 * lit_indirect, "leak %.6f vs lit indirect %.5f", leak,
                 lit_indirect);
    pf_image_free(&lit_image);
    pf_image_free(&dark_image);
    ref_scene_free(&lit);
    ref_scene_free(&dark);
}

PF_TEST(light_outside_the_finest_cascade_still_arrives)
{
    /* A long lit room: the finest cascade around the far end, the light's VPLs outside it. */
    pf_error err = {0};
    ref_scene hall;
    ref_scene_init(&hall);
    uint32_t wall = ref_scene_add_material(&hall, ref_material(PF_MATERIAL_LAMBERT, 0.6f, 0.6f,
                                                               0.6f));
    const float lo[3] = {0, 0, 0}, hi[3] = {8, 1, 1};
    ref_scene_add_box(&hall, lo, hi, 1, wall);
    pf_light light = {.position = {0.5f, 0.5f, 0.5f}, .kind = PF_LIGHT_POINT,
                      .intensity = {4.0f, 4.0f, 4.0f}};
    ref_scene_add_light(&hall, light);
    const float eye[3] = {4.5f, 0.5f, 0.5f}, target[3] = {7.0f, 0.4f, 0.5f},
                up[3] = {0, 1, 0};
    ref_scene_look_at(&hall, eye, target, up, 1.0f);
    pf_render_settings cascaded = fast_settings(24, 24, 2, 1);
    cascaded.lpv.cell_size = 1.0f / 16.0f; /* finest 2 m around the camera; coarsest 16 m */
    pf_render_settings single = cascaded;
    single.lpv.cascades = 1;
    single.lpv.cell_size = 0.5f;           /* the coarsest cascade alone */
    pf_image a, b;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &hall.frame, &cascaded, &a, &report, &err), &err);
    double finest_vpls = ref_stage_counter(&report, "lpv_inject", "vpls_cascade0");
    double all_vpls = ref_stage_counter(&report, "lpv_inject", "vpls");
    PF_REQUIRE_OK(pf_render_frame(renderer, &hall.frame, &single, &b, NULL, &err), &err);
    double ratio = ref_layer_mean(&a, REF_CH_INDIRECT) / ref_layer_mean(&b, REF_CH_INDIRECT);
    printf("  finest cascade holds %.0f of %.0f VPLs; indirect 4 cascades / coarsest alone %.3f\n",
           finest_vpls, all_vpls, ratio);
    PF_CHECK(finest_vpls < 0.5 * all_vpls);
    /*
     * The coarser cascades' far field brings the light the finest one cannot
     * hold (measured 0.81 of the coarsest cascade alone, whose coarse cells
     * blur the light over the hall's walls; without the far field the finest
     * cascade's 8 iterations of 6 cm would see almost none of it).
     */
    PF_CHECK_MSG(ratio > 0.7 && ratio < 1.3, "ratio %.3f", ratio);
    PF_CHECK(ref_image_non_finite(&a) == 0);
    pf_image_free(&a);
    pf_image_free(&b);
    ref_scene_free(&hall);
}

PF_TEST(scene_larger_than_the_coarsest_cascade_falls_back)
{
    pf_error err = {0};
    ref_scene box;
    lit_box(&box, 0.5f);
    pf_render_settings settings = fast_settings(24, 24, 1, 1);
    settings.lpv.cascades = 1;
    settings.lpv.size = 8;
    settings.lpv.cell_size = 1.0f / 64.0f; /* 12.5 cm of cascade in a 2 m box */
    uint32_t warnings = pf_log_warning_count();
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &box.frame, &settings, &image, &report, &err), &err);
    PF_CHECK(ref_stage_counter(&report, "lpv_geometry", "scene_covered") == 0.0);
    PF_CHECK(ref_stage_counter(&report, "lpv_inject", "outside") > 0.0);
    PF_CHECK(ref_stage_counter(&report, "shade", "lpv_outside") > 0.0);
    PF_CHECK(pf_log_warning_count() > warnings);
    PF_CHECK(ref_layer_violations(&image, "uncovered") == 0);
    PF_CHECK(ref_layer_mean(&image, REF_CH_DIRECT) > 0.0);
    pf_image_free(&image);
    ref_scene_free(&box);
}

PF_TEST(empty_scene_and_emitters_only)
{
    pf_error err = {0};
    ref_scene empty;
    ref_scene_init(&empty);
    pf_render_settings settings = fast_settings(16, 16, 1, 1);
    pf_image image;
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &empty.frame, &settings, &image, &report, &err),
                  &err);
    PF_CHECK(ref_layer_violations(&image, "empty") == 0);
    PF_CHECK(ref_layer_mean(&image, REF_CH_RGB) == 0.0);
    PF_CHECK(row_skipped_because(&report, "photon_trace", "no lights"));
    PF_CHECK(ref_stage_counter(&report, "lpv_inject", "vpls") == 0.0);
    pf_image_free(&image);
    ref_scene_free(&empty);

    /* One emitting quad facing the camera: its radiance directly, nothing indirect. */
    ref_scene glow;
    ref_scene_init(&glow);
    uint32_t emitter = ref_scene_add_material(&glow, ref_material_emitter(2.0f, 1.0f, 0.5f));
    const float centre[3] = {0, 0, -2}, half_u[3] = {3, 0, 0}, half_v[3] = {0, 3, 0};
    ref_scene_add_quad(&glow, centre, half_u, half_v, emitter);
    pf_frame_report glow_report = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &glow.frame, &settings, &image, &glow_report, &err),
                  &err);
    PF_CHECK(ref_layer_violations(&image, "emitters only") == 0);
    PF_CHECK_NEAR(ref_pixel(&image, 0, 8, 8), 2.0, 1e-6);
    PF_CHECK(ref_layer_mean(&image, REF_CH_INDIRECT) == 0.0);
    PF_CHECK(ref_stage_counter(&glow_report, "lpv_inject", "vpls") == 0.0);
    pf_image_free(&image);
    ref_scene_free(&glow);
}

PF_TEST(bad_lpv_settings_are_refused)
{
    pf_error err = {0};
    pf_render_settings settings = fast_settings(8, 8, 1, 1);
    settings.lpv.size = 256; /* 4 × 256³ cells × 48 bytes: past any 128 MiB buffer */
    pf_image image;
    pf_status status = pf_render_frame(renderer, &cornell_frame, &settings, &image, NULL, &err);
    if (pf_vk_info(ctx)->max_storage_buffer_range < (3ull << 30)) {
        PF_CHECK(status == PF_ERR_LIMIT);
        PF_CHECK_MSG(strstr(err.message, "cascade size 256") != NULL, "%s", err.message);
    }
    if (status == PF_OK)
        pf_image_free(&image);
    settings.lpv.size = 30;
    PF_CHECK(pf_render_frame(renderer, &cornell_frame, &settings, &image, NULL, &err) ==
             PF_ERR_INVALID);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    pf_error err = {0};
    if (!ref_load_cornell(&cornell_scene, &cornell_frame))
        return 1;
    pf_render_settings reference = ref_settings(CORNELL_WIDTH, CORNELL_HEIGHT, REFERENCE_SPP, 1, 0);
    if (pf_render_frame(renderer, &cornell_frame, &reference, &cornell_reference, NULL, &err) !=
        PF_OK) {
        fprintf(stderr, "cornell reference: %s\n", err.message);
        return 1;
    }
    PF_RUN(cornell_indirect_matches_reference);
    PF_RUN(second_frame_reuses_every_lpv_stage_and_matches);
    PF_RUN(other_presets_between_fast_frames_change_nothing);
    PF_RUN(closed_box_indirect_matches_reference);
    PF_RUN(open_floor_gets_none_of_its_own_light_back);
    PF_RUN(thin_wall_leaks_little_light_into_the_dark_room);
    PF_RUN(light_outside_the_finest_cascade_still_arrives);
    PF_RUN(scene_larger_than_the_coarsest_cascade_falls_back);
    PF_RUN(empty_scene_and_emitters_only);
    PF_RUN(bad_lpv_settings_are_refused);
    pf_image_free(&cornell_reference);
    pf_scene_frame_free(&cornell_frame);
    pf_scene_destroy(cornell_scene);
    return render_test_finish(ctx, renderer);
}
