/*
 * Settings that let a render be matched to another renderer's (issue 16).
 *
 * Pixel filters: an emitter of radiance 1 fills the image right of a
 * vertical edge at film x = EDGE_X (the emitter's plane faces the camera, so
 * the edge is a straight film line). A pixel then holds the share of its
 * filter's mass right of the edge: for box (width 1) the overlap of the
 * pixel's square, for Blackman-Harris (width 3, i.e. Cycles' 1.5 px half-width;
 * separable) one minus its
 * 1-D CDF, for the Gaussian (radial, σ 0.5, truncated at 1.5) the 2-D
 * integral, computed here on a fine grid. Each filter's pixel row is
 * checked against its own profile, and pixels beyond a filter's reach are
 * exactly 0 or 1.
 *
 * Bounces: in a furnace (a closed sphere, every wall emitting Le with
 * albedo a) the camera sees Le + a Le + a² Le + …, the k-th term being light
 * of k − 1 bounces after the first surface. --max-bounces B keeps the
 * first B + 2 terms: Le (1 − a^{B+2}) / (1 − a); the reference must match
 * it for B = 0, 1, 3 and converge to Le/(1 − a) without a limit. `final`
 * with B = 0 has no indirect light and skips its caustic map and gather.
 */
#include "../render/reference_test_util.h"
#include "../render/render_test_env.h"
#include "pf_render.h"
#include "pf_test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define PI 3.14159265358979323846
#define FILTER_WIDTH_PX 32u
#define FILTER_HEIGHT_PX 16u
#define FILTER_SPP 1024u
#define EDGE_X 16.3
/* Per pixel the standard deviation is ≤ 0.5/√1024 ≈ 0.016; a column mean of 16 rows ≈ 0.004. */
#define PROFILE_TOLERANCE 0.015

/* Share of a box pixel centred at c right of the edge. */
static double box_share(double c)
{
    double share = c + 0.5 - EDGE_X;
    return share < 0.0 ? 0.0 : share > 1.0 ? 1.0 : share;
}

static double blackman_harris_cdf(double u)
{
    const double a0 = 0.35875, a1 = 0.48829, a2 = 0.14128, a3 = 0.01168;
    if (u <= 0.0)
        return 0.0;
    if (u >= 1.0)
        return 1.0;
    double t = 2.0 * PI * u;
    return (a0 * u - a1 * sin(t) / (2.0 * PI) + a2 * sin(2.0 * t) / (4.0 * PI) -
            a3 * sin(3.0 * t) / (6.0 * PI)) /
           a0;
}

static double blackman_harris_share(double c)
{
    return 1.0 - blackman_harris_cdf((EDGE_X - c) / 3.0 + 0.5);
}

/* The radial Gaussian (σ 0.5, truncated at r 1.5) integrated over x > EDGE_X, on a grid. */
static double gaussian_share(double c)
{
    const int steps = 600;
    const double radius = 1.5, sigma = 0.5, h = 2.0 * radius / steps;
    double inside = 0.0, total = 0.0;
    for (int i = 0; i < steps; i++) {
        double x = -radius + (i + 0.5) * h;
        for (int j = 0; j < steps; j++) {
            double y = -radius + (j + 0.5) * h;
            double r2 = x * x + y * y;
            if (r2 > radius * radius)
                continue;
            double w = exp(-r2 / (2.0 * sigma * sigma));
            total += w;
            if (c + x > EDGE_X)
                inside += w;
        }
    }
    return inside / total;
}

static void build_edge(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t emitter = ref_scene_add_material(scene, ref_material_emitter(1, 1, 1));
    const float eye[3] = {0, 0, 0}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 0.8f);
    double d[3];
    ref_camera_ray(&scene->frame.camera, FILTER_WIDTH_PX, FILTER_HEIGHT_PX, EDGE_X,
                   FILTER_HEIGHT_PX / 2.0, d);
    float edge = (float)(d[0] / -d[2]); /* world x of the edge on the plane z = -1 */
    /* From the edge to far right, facing +z (the camera): u × v = +z. */
    const float centre[3] = {edge + 5.0f, 0, -1}, u[3] = {5.0f, 0, 0}, v[3] = {0, 5.0f, 0};
    ref_scene_add_quad(scene, centre, u, v, emitter);
}

static void check_filter(pf_pixel_filter filter, double (*share)(double), double reach)
{
    const char *name = pf_pixel_filter_name(filter);
    ref_scene scene;
    build_edge(&scene);
    pf_render_settings settings = ref_settings(FILTER_WIDTH_PX, FILTER_HEIGHT_PX, FILTER_SPP, 5, 0);
    settings.pixel_filter = filter;
    pf_image image = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", name, err.message);
        ref_scene_free(&scene);
        return;
    }
    for (uint32_t x = 0; x < FILTER_WIDTH_PX; x++) {
        double c = x + 0.5, sum = 0.0;
        int exact = 1;
        for (uint32_t y = 0; y < FILTER_HEIGHT_PX; y++) {
            double value = ref_pixel(&image, 0, x, y);
            sum += value;
            exact = exact && (value == 0.0 || value == 1.0);
        }
        double mean = sum / FILTER_HEIGHT_PX, expected = share(c);
        if (fabs(c - EDGE_X) < 3.0)
            printf("  %s: column %u: %.4f (expected %.4f)\n", name, x, mean, expected);
        PF_CHECK_MSG(fabs(mean - expected) <= PROFILE_TOLERANCE,
                     "%s, column %u: %.4f, expected %.4f", name, x, mean, expected);
        if (fabs(c - EDGE_X) > reach)
            PF_CHECK_MSG(exact, "%s, column %u: beyond the filter's reach yet not 0 or 1", name, x);
        else if (fabs(c - EDGE_X) < reach - 0.2)
            PF_CHECK_MSG(!exact, "%s, column %u: inside the filter's reach yet all 0 or 1", name,
                         x);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(each_pixel_filter_has_its_own_edge_profile)
{
    check_filter(PF_FILTER_BOX, box_share, 0.5);
    check_filter(PF_FILTER_BLACKMAN_HARRIS, blackman_harris_share, 1.5);
    check_filter(PF_FILTER_GAUSSIAN, gaussian_share, 1.5);
}

PF_TEST(filter_names_round_trip)
{
    static const pf_pixel_filter all[] = {PF_FILTER_GAUSSIAN, PF_FILTER_BOX,
                                          PF_FILTER_BLACKMAN_HARRIS};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        PF_CHECK(pf_pixel_filter_parse(pf_pixel_filter_name(all[i])) == (int)all[i]);
    PF_CHECK(pf_pixel_filter_parse("mitchell") == -1);
    PF_CHECK(pf_pixel_filter_parse(NULL) == -1);
}

#define FURNACE_EDGE 16u
#define FURNACE_SPP 64u
#define FURNACE_ALBEDO 0.6
#define FURNACE_EMISSION 0.5

static void build_furnace(ref_scene *scene)
{
    ref_scene_init(scene);
    pf_material wall = {{FURNACE_ALBEDO, FURNACE_ALBEDO, FURNACE_ALBEDO},
                        PF_MATERIAL_LAMBERT,
                        {FURNACE_EMISSION, FURNACE_EMISSION, FURNACE_EMISSION},
                        1.5f};
    uint32_t material = ref_scene_add_material(scene, wall);
    const float centre[3] = {0, 0, 0};
    ref_scene_add_sphere(scene, centre, 1.0f, 24, 12, 1, material);
    const float eye[3] = {0, 0, 0}, target[3] = {0, 0, -1}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 1.0f);
}

PF_TEST(reference_keeps_the_bounces_it_is_given)
{
    ref_scene scene;
    build_furnace(&scene);
    const double a = FURNACE_ALBEDO, le = FURNACE_EMISSION;
    static const int bounces[] = {0, 1, 3, -1};
    for (size_t i = 0; i < sizeof bounces / sizeof bounces[0]; i++) {
        pf_render_settings settings =
            ref_settings(FURNACE_EDGE, FURNACE_EDGE, FURNACE_SPP, 9 + i, 0);
        settings.bounce_limit = bounces[i] >= 0 ? pf_bounce_limit((uint32_t)bounces[i]) : 0u;
        double expected = bounces[i] >= 0 ? le * (1.0 - pow(a, bounces[i] + 2)) / (1.0 - a)
                                          : le / (1.0 - a);
        pf_image image = {0};
        pf_error err = {0};
        if (pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err) != PF_OK) {
            PF_CHECK_MSG(0, "bounces %d: %s", bounces[i], err.message);
            continue;
        }
        double mean = ref_layer_mean(&image, REF_CH_RGB);
        double direct = ref_layer_mean(&image, REF_CH_DIRECT);
        double indirect = ref_layer_mean(&image, REF_CH_INDIRECT);
        printf("  max bounces %2d: %.5f (expected %.5f), direct %.5f, indirect %.5f\n",
               bounces[i], mean, expected, direct, indirect);
        PF_CHECK_MSG(fabs(mean / expected - 1.0) < 0.01, "bounces %d: %g, expected %g",
                     bounces[i], mean, expected);
        /* Direct light is Le + a Le whatever the limit; none of it is indirect at B = 0. */
        PF_CHECK_NEAR(direct / (le * (1.0 + a)), 1.0, 0.01);
        if (bounces[i] == 0)
            PF_CHECK(indirect == 0.0);
        pf_image_free(&image);
    }
    ref_scene_free(&scene);
}

PF_TEST(final_without_bounces_is_direct_light_only)
{
    ref_scene scene;
    build_furnace(&scene);
    /* A glass ball, so a caustic map would be built without the limit. */
    uint32_t glass = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    const float ball[3] = {0.3f, -0.3f, -0.5f};
    ref_scene_add_sphere(&scene, ball, 0.15f, 12, 6, 0, glass);
    pf_render_settings settings = ref_settings(FURNACE_EDGE, FURNACE_EDGE, 2, 4, 0);
    settings.quality = PF_QUALITY_FINAL;
    settings.photons_per_pass = 20000;
    settings.bounce_limit = pf_bounce_limit(0);
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err) == PF_OK) {
        PF_CHECK(ref_layer_mean(&image, REF_CH_INDIRECT) == 0.0);
        PF_CHECK(ref_layer_mean(&image, REF_CH_DIRECT) > 0.0);
        const pf_stage_timing *caustic = ref_row(&report, "caustic_map");
        PF_CHECK(caustic && caustic->skipped && strstr(caustic->reason, "--max-bounces 0"));
    } else {
        PF_CHECK_MSG(0, "final: %s", err.message);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(filter_names_round_trip);
    PF_RUN(each_pixel_filter_has_its_own_edge_profile);
    PF_RUN(reference_keeps_the_bounces_it_is_given);
    PF_RUN(final_without_bounces_is_direct_light_only);
    return render_test_finish(ctx, renderer);
}
