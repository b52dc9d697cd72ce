/*
 * The reference path tracer (--quality reference) against closed forms, in
 * scenes where a single bounce is all there is (one plane, black background;
 * an emitter of albedo 0 over a receiver), so the direct layer must equal the
 * analytic value and the indirect and caustic layers must be exactly zero.
 *
 * - Point, spot (inside its inner cone) and directional light over a Lambert
 *   plane: L = albedo/π · E with E = I cosθ / d² (E = E⊥ cosθ), pixel by pixel;
 *   and under a KHR_materials_sheen (its Charlie lobe over the albedo-scaled base:
 *   ref_sheen_f_cos, from the spec's formulas), where the view angle changes the
 *   radiance from pixel to pixel.
 *   Light from a punctual source through NEE carries no noise, so each pixel
 *   must lie within the range the exact value takes over the pixel filter's
 *   footprint.
 * - A square emitter parallel to a Lambert square: L = albedo · Le · F with F
 *   the configuration factor of a differential area to a parallel rectangle,
 *   compared with the sample-count-derived noise.
 * - The emitter seen by the camera: its radiance, in the direct layer, from
 *   its front face only.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>

#define PI 3.14159265358979323846

static pf_vk_context *ctx;
static pf_renderer *renderer;

/* Footprint of the filter sampled on a (2k+1)² grid of film offsets one pixel apart. */
#define FOOTPRINT_STEPS 2
/* Float rounding on the GPU: single-precision geometry and accumulation. */
#define FLOAT_RELATIVE_SLACK 1e-4
/* Standard errors allowed for Monte Carlo estimates (fixed seed, so no flakiness). */
#define NOISE_SIGMAS 4.0

/* Exact radiance (per channel) of the point of a scene's plane seen along a film position. */
typedef int (*radiance_fn)(const void *setup, const pf_camera *camera, uint32_t width,
                           uint32_t height, double film_x, double film_y, double radiance[3]);

/* Plane z = 0 (Lambert, front face +z; a sheen over it where sheen is not 0) and one
 * punctual light. */
typedef struct plane_setup {
    double albedo[3];
    pf_light light;
    double sheen[3], sheen_roughness;
} plane_setup;

/* Hit point of the camera ray with the plane z = 0; 0 when the ray misses it. */
static int hit_plane(const pf_camera *camera, uint32_t width, uint32_t height, double film_x,
                     double film_y, double point[3])
{
    double direction[3];
    ref_camera_ray(camera, width, height, film_x, film_y, direction);
    if (!(direction[2] < 0.0) || camera->position[2] <= 0.0f)
        return 0;
    double t = -camera->position[2] / direction[2];
    for (int k = 0; k < 3; k++)
        point[k] = camera->position[k] + t * direction[k];
    point[2] = 0.0;
    return 1;
}

/* Cosine between the spot's axis and the direction from the light to point. */
static double spot_cosine(const pf_light *light, const double point[3])
{
    double to_point[3], length = 0.0;
    for (int k = 0; k < 3; k++) {
        to_point[k] = point[k] - light->position[k];
        length += to_point[k] * to_point[k];
    }
    length = sqrt(length);
    return (to_point[0] * light->direction[0] + to_point[1] * light->direction[1] +
            to_point[2] * light->direction[2]) /
           length;
}

static int plane_radiance(const void *opaque, const pf_camera *camera, uint32_t width,
                          uint32_t height, double film_x, double film_y, double radiance[3])
{
    radiance[0] = radiance[1] = radiance[2] = 0.0; /* also on a miss */
    const plane_setup *setup = opaque;
    const pf_light *light = &setup->light;
    double point[3];
    if (!hit_plane(camera, width, height, film_x, film_y, point))
        return 0;
    double irradiance_scale, wi[3];
    if (light->kind == PF_LIGHT_DIRECTIONAL) {
        /* The light travels along direction; the plane's normal is +z. */
        irradiance_scale = fmax(0.0, -(double)light->direction[2]);
        for (int k = 0; k < 3; k++)
            wi[k] = -(double)light->direction[k];
    } else {
        double to_light[3], d2 = 0.0;
        for (int k = 0; k < 3; k++) {
            to_light[k] = light->position[k] - point[k];
            d2 += to_light[k] * to_light[k];
        }
        irradiance_scale = fmax(0.0, to_light[2] / sqrt(d2)) / d2;
        for (int k = 0; k < 3; k++)
            wi[k] = to_light[k] / sqrt(d2);
    }
    double sheen_max = fmax(setup->sheen[0], fmax(setup->sheen[1], setup->sheen[2]));
    if (sheen_max > 0.0) {
        /* f·cos_i of the sheen over the base, times what the light delivers (I / d², or E⊥). */
        double wo[3], h[3], hl = 0.0;
        ref_camera_ray(camera, width, height, film_x, film_y, wo);
        for (int k = 0; k < 3; k++) {
            h[k] = wi[k] - wo[k];
            hl += h[k] * h[k];
        }
        double falloff = wi[2] > 0.0 ? irradiance_scale / wi[2] : 0.0;
        for (int c = 0; c < 3; c++)
            radiance[c] = light->intensity[c] * falloff *
                          ref_sheen_f_cos(setup->sheen[c], sheen_max, setup->sheen_roughness,
                                          setup->albedo[c], -wo[2], wi[2], h[2] / sqrt(hl));
        return 1;
    }
    for (int c = 0; c < 3; c++)
        radiance[c] = setup->albedo[c] / PI * light->intensity[c] * irradiance_scale;
    return 1;
}

/*
 * Range of the exact radiance over the filter footprint of pixel (x, y):
 * 0 when some point of the footprint misses the plane.
 */
static int footprint_range(radiance_fn radiance, const void *setup, const pf_camera *camera,
                           uint32_t width, uint32_t height, uint32_t x, uint32_t y,
                           double low[3], double high[3])
{
    const double step = REF_FILTER_RADIUS_PIXELS / FOOTPRINT_STEPS;
    for (int c = 0; c < 3; c++) {
        low[c] = INFINITY;
        high[c] = -INFINITY;
    }
    for (int j = -FOOTPRINT_STEPS; j <= FOOTPRINT_STEPS; j++) {
        for (int i = -FOOTPRINT_STEPS; i <= FOOTPRINT_STEPS; i++) {
            double value[3];
            if (!radiance(setup, camera, width, height, x + 0.5 + i * step, y + 0.5 + j * step,
                          value))
                return 0;
            for (int c = 0; c < 3; c++) {
                low[c] = fmin(low[c], value[c]);
                high[c] = fmax(high[c], value[c]);
            }
        }
    }
    return 1;
}

/*
 * Bias a symmetric pixel filter can add to the exact radiance at pixel (x, y)'s
 * centre: filtering pairs each offset o with −o, so the linear part cancels and
 * what remains is at most max |f(o) + f(−o) − 2 f(0)| / 2 over the footprint.
 */
static void footprint_curvature(radiance_fn radiance, const void *setup, const pf_camera *camera,
                                uint32_t width, uint32_t height, uint32_t x, uint32_t y,
                                double bound[3])
{
    const double step = REF_FILTER_RADIUS_PIXELS / FOOTPRINT_STEPS;
    double centre[3];
    radiance(setup, camera, width, height, x + 0.5, y + 0.5, centre);
    for (int c = 0; c < 3; c++)
        bound[c] = 0.0;
    for (int j = -FOOTPRINT_STEPS; j <= FOOTPRINT_STEPS; j++) {
        for (int i = -FOOTPRINT_STEPS; i <= FOOTPRINT_STEPS; i++) {
            double plus[3], minus[3];
            radiance(setup, camera, width, height, x + 0.5 + i * step, y + 0.5 + j * step, plus);
            radiance(setup, camera, width, height, x + 0.5 - i * step, y + 0.5 - j * step, minus);
            for (int c = 0; c < 3; c++)
                bound[c] = fmax(bound[c], 0.5 * fabs(plus[c] + minus[c] - 2.0 * centre[c]));
        }
    }
}

typedef struct layer_channels {
    int beauty[3], direct[3], indirect[3], caustic[3], alpha;
} layer_channels;

static int find_layers(const pf_image *image, layer_channels *layers)
{
    static const char *const names[4][3] = {{"R", "G", "B"},
                                            {"direct.R", "direct.G", "direct.B"},
                                            {"indirect.R", "indirect.G", "indirect.B"},
                                            {"caustic.R", "caustic.G", "caustic.B"}};
    int found = 1;
    for (int c = 0; c < 3; c++) {
        layers->beauty[c] = pf_image_channel(image, names[0][c]);
        layers->direct[c] = pf_image_channel(image, names[1][c]);
        layers->indirect[c] = pf_image_channel(image, names[2][c]);
        layers->caustic[c] = pf_image_channel(image, names[3][c]);
        found &= layers->beauty[c] >= 0 && layers->direct[c] >= 0 && layers->indirect[c] >= 0 &&
                 layers->caustic[c] >= 0;
    }
    layers->alpha = pf_image_channel(image, "A");
    return found && layers->alpha >= 0;
}

/*
 * Every pixel: beauty = direct, indirect = caustic = 0 exactly, alpha as
 * given (negative: not checked), nothing non-finite. Returns the failures.
 */
static uint32_t check_single_bounce_layers(const char *what, const pf_image *image,
                                           const layer_channels *layers, double alpha)
{
    uint32_t failures = 0;
    for (uint32_t y = 0; y < image->height; y++) {
        for (uint32_t x = 0; x < image->width; x++) {
            int bad = alpha >= 0.0 && ref_pixel(image, layers->alpha, x, y) != alpha;
            for (int c = 0; c < 3; c++) {
                double beauty = ref_pixel(image, layers->beauty[c], x, y);
                double direct = ref_pixel(image, layers->direct[c], x, y);
                bad |= !(fabs(beauty - direct) <= FLOAT_RELATIVE_SLACK * fabs(beauty) + 1e-9);
                bad |= ref_pixel(image, layers->indirect[c], x, y) != 0.0;
                bad |= ref_pixel(image, layers->caustic[c], x, y) != 0.0;
            }
            if (bad && failures++ < 3)
                fprintf(stderr,
                        "%s: pixel (%u, %u): R %g direct.R %g indirect.R %g caustic.R %g A %g\n",
                        what, x, y, ref_pixel(image, layers->beauty[0], x, y),
                        ref_pixel(image, layers->direct[0], x, y),
                        ref_pixel(image, layers->indirect[0], x, y),
                        ref_pixel(image, layers->caustic[0], x, y),
                        ref_pixel(image, layers->alpha, x, y));
        }
    }
    PF_CHECK_MSG(failures == 0, "%s: %u pixels break R = direct, indirect = caustic = 0", what,
                 failures);
    return failures;
}

/* A 40 m × 40 m Lambert plane at z = 0 facing +z, seen obliquely (every pixel on it). */
static void plane_scene(ref_scene *scene, const plane_setup *setup)
{
    ref_scene_init(scene);
    pf_material material = ref_material(PF_MATERIAL_LAMBERT, (float)setup->albedo[0],
                                        (float)setup->albedo[1], (float)setup->albedo[2]);
    for (int c = 0; c < 3; c++)
        material.sheen_color[c] = (float)setup->sheen[c];
    material.sheen_roughness = (float)setup->sheen_roughness;
    uint32_t plane = ref_scene_add_material(scene, material);
    const float centre[3] = {0, 0, 0}, half_u[3] = {20, 0, 0}, half_v[3] = {0, 20, 0};
    ref_scene_add_quad(scene, centre, half_u, half_v, plane);
    ref_scene_add_light(scene, setup->light);
    const float eye[3] = {0.2f, -3.0f, 2.5f}, target[3] = {0.0f, 0.5f, 0.0f},
                up_hint[3] = {0, 0, 1};
    ref_scene_look_at(scene, eye, target, up_hint, 0.8f);
}

#define PLANE_EDGE 96u
/* Punctual lights through NEE are noiseless: a few samples only cover the filter. */
#define PLANE_SPP 4u
/* Pixels whose filter bias bound is at most this fraction of the radiance enter the mean check. */
#define SMOOTH_RELATIVE_CURVATURE 2e-3

/* Whether pixel (x, y)'s whole footprint lies where the closed form applies. */
typedef int (*pixel_select_fn)(const plane_setup *setup, const pf_camera *camera, uint32_t x,
                               uint32_t y);

/*
 * Renders the plane under setup's light; every pixel that passes `select`
 * (NULL: all) must lie within its footprint's range of exact radiance, and
 * over the pixels where the radiance is smooth the mean relative error must
 * vanish within noise and filter bias. Returns how many pixels were compared.
 */
static uint32_t check_plane(const char *what, const plane_setup *setup, pixel_select_fn select)
{
    ref_scene scene;
    plane_scene(&scene, setup);
    pf_render_settings settings = ref_settings(PLANE_EDGE, PLANE_EDGE, PLANE_SPP, 11, 0);
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    uint32_t compared = 0, outside = 0;
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", what, err.message);
        ref_scene_free(&scene);
        return 0;
    }
    layer_channels layers;
    if (!find_layers(&image, &layers)) {
        PF_CHECK_MSG(0, "%s: direct/indirect/caustic layers missing", what);
        goto done;
    }
    PF_CHECK(ref_image_non_finite(&image) == 0);
    PF_CHECK(report.discarded_samples == 0);
    check_single_bounce_layers(what, &image, &layers, 1.0);
    double worst_excess = 0.0;
    /* Relative residuals (direct − exact at the centre) / exact, and their filter bias bound. */
    static double relative_residual[3][PLANE_EDGE * PLANE_EDGE];
    double relative_bias[3] = {0, 0, 0};
    uint32_t smooth = 0;
    for (uint32_t y = 0; y < PLANE_EDGE; y++) {
        for (uint32_t x = 0; x < PLANE_EDGE; x++) {
            double low[3], high[3], exact[3], curvature[3];
            if ((select && !select(setup, &scene.frame.camera, x, y)) ||
                !footprint_range(plane_radiance, setup, &scene.frame.camera, PLANE_EDGE,
                                 PLANE_EDGE, x, y, low, high))
                continue;
            plane_radiance(setup, &scene.frame.camera, PLANE_EDGE, PLANE_EDGE, x + 0.5, y + 0.5,
                           exact);
            footprint_curvature(plane_radiance, setup, &scene.frame.camera, PLANE_EDGE,
                                PLANE_EDGE, x, y, curvature);
            /* The mean check uses the pixels where the filter's bias bound is small. */
            if (curvature[0] <= SMOOTH_RELATIVE_CURVATURE * exact[0]) {
                for (int c = 0; c < 3; c++) {
                    relative_residual[c][smooth] =
                        (ref_pixel(&image, layers.direct[c], x, y) - exact[c]) / exact[c];
                    relative_bias[c] += curvature[c] / exact[c];
                }
                smooth++;
            }
            compared++;
            int bad = 0;
            for (int c = 0; c < 3; c++) {
                /* A filter with negative lobes may overshoot the range a little. */
                double slack = 0.25 * (high[c] - low[c]) + FLOAT_RELATIVE_SLACK * high[c];
                double value = ref_pixel(&image, layers.direct[c], x, y);
                double excess = fmax(low[c] - slack - value, value - high[c] - slack);
                if (excess > 0.0) {
                    bad = 1;
                    worst_excess = fmax(worst_excess, excess / high[c]);
                }
            }
            if (bad && outside++ < 3)
                fprintf(stderr,
                        "%s: pixel (%u, %u): direct.R %.6g, exact over footprint [%.6g, %.6g]\n",
                        what, x, y, ref_pixel(&image, layers.direct[0], x, y), low[0], high[0]);
        }
    }
    PF_CHECK_MSG(outside == 0, "%s: %u of %u pixels off the analytic radiance (worst by %.3g%%)",
                 what, outside, compared, 100.0 * worst_excess);
    /* Over all compared pixels the filter's jitter averages out: a scale error of a
     * fraction of a percent (a wrong π, cosine or falloff) shows here. */
    PF_CHECK_MSG(smooth >= 100, "%s: only %u of %u pixels where the radiance is smooth",
                 what, smooth, compared);
    for (int c = 0; c < 3 && smooth > 1; c++) {
        ref_stats stats = ref_stats_of(relative_residual[c], smooth);
        double tolerance = NOISE_SIGMAS * stats.standard_error + relative_bias[c] / smooth +
                           FLOAT_RELATIVE_SLACK;
        PF_CHECK_MSG(fabs(stats.mean) <= tolerance,
                     "%s, channel %d: mean relative error %.3g%% (tolerance %.3g%%)", what, c,
                     100.0 * stats.mean, 100.0 * tolerance);
        if (c == 0)
            printf("  %s: %u pixels against the closed form; over %u smooth ones, mean "
                   "relative error %.2g%% (tolerance %.2g%%)\n",
                   what, compared, smooth, 100.0 * stats.mean, 100.0 * tolerance);
    }
done:
    pf_image_free(&image);
    ref_scene_free(&scene);
    return compared;
}

PF_TEST(point_light_over_a_plane_matches_inverse_square_cosine)
{
    plane_setup setup = {{0.8, 0.5, 0.3},
                         (pf_light){{0.3f, 0.4f, 3.0f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                    {5.0f, 10.0f, 20.0f}, 1, 1}};
    PF_CHECK(check_plane("point light", &setup, NULL) == PLANE_EDGE * PLANE_EDGE);
}

/* Margin (radians) from a cone's edge: the footprint is sampled, not bounded. */
#define CONE_MARGIN 0.02

static int footprint_spot_cosines(const plane_setup *setup, const pf_camera *camera, uint32_t x,
                                  uint32_t y, double *low, double *high)
{
    const double step = REF_FILTER_RADIUS_PIXELS / FOOTPRINT_STEPS;
    *low = INFINITY;
    *high = -INFINITY;
    for (int j = -FOOTPRINT_STEPS; j <= FOOTPRINT_STEPS; j++) {
        for (int i = -FOOTPRINT_STEPS; i <= FOOTPRINT_STEPS; i++) {
            double point[3];
            if (!hit_plane(camera, PLANE_EDGE, PLANE_EDGE, x + 0.5 + i * step, y + 0.5 + j * step,
                           point))
                return 0;
            double cosine = spot_cosine(&setup->light, point);
            *low = fmin(*low, cosine);
            *high = fmax(*high, cosine);
        }
    }
    return 1;
}

static int inside_inner_cone(const plane_setup *setup, const pf_camera *camera, uint32_t x,
                             uint32_t y)
{
    double low, high;
    return footprint_spot_cosines(setup, camera, x, y, &low, &high) &&
           low >= cos(acos(setup->light.cos_inner_cone) - CONE_MARGIN);
}

PF_TEST(spot_light_inside_its_inner_cone_matches_a_point_light)
{
    /* Tilted spot 2 m above the plane; its inner cone covers the middle of the view. */
    double axis[3] = {0.25, 0.3, -1.0};
    double length = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    plane_setup setup = {{0.4, 0.7, 0.6},
                         (pf_light){{-0.2f, 0.2f, 3.0f}, PF_LIGHT_SPOT,
                                    {(float)(axis[0] / length), (float)(axis[1] / length),
                                     (float)(axis[2] / length)},
                                    0, {8.0f, 6.0f, 4.0f}, cosf(0.6f), cosf(0.8f)}};
    uint32_t compared = check_plane("spot light", &setup, inside_inner_cone);
    PF_CHECK_MSG(compared >= 200, "only %u pixels inside the inner cone", compared);

    /* Outside the outer cone nothing arrives: exactly black. */
    ref_scene scene;
    plane_scene(&scene, &setup);
    pf_render_settings settings = ref_settings(PLANE_EDGE, PLANE_EDGE, PLANE_SPP, 12, 0);
    pf_image image = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err) == PF_OK) {
        uint32_t dark = 0, lit = 0;
        for (uint32_t y = 0; y < PLANE_EDGE; y++) {
            for (uint32_t x = 0; x < PLANE_EDGE; x++) {
                double low, high;
                if (!footprint_spot_cosines(&setup, &scene.frame.camera, x, y, &low, &high) ||
                    high > cos(acos(setup.light.cos_outer_cone) + CONE_MARGIN))
                    continue;
                dark++;
                lit += ref_pixel(&image, 0, x, y) != 0.0 || ref_pixel(&image, 1, x, y) != 0.0 ||
                       ref_pixel(&image, 2, x, y) != 0.0;
            }
        }
        PF_CHECK_MSG(dark >= 200, "only %u pixels outside the outer cone", dark);
        PF_CHECK_MSG(lit == 0, "%u of %u pixels outside the outer cone are lit", lit, dark);
    } else {
        PF_CHECK_MSG(0, "%s", err.message);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(directional_light_over_a_plane_matches_cosine_law)
{
    /* 3 W/m² along (0.6, 0, -0.8): cosθ = 0.8 everywhere. */
    plane_setup setup = {{0.9, 0.6, 0.2},
                         (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.6f, 0.0f, -0.8f}, 0,
                                    {3.0f, 3.0f, 3.0f}, 1, 1}};
    PF_CHECK(check_plane("directional light", &setup, NULL) == PLANE_EDGE * PLANE_EDGE);
}

PF_TEST(sheen_over_a_plane_matches_its_lobe_over_the_scaled_base)
{
    /* 3 W/m² along (0.8, 0, -0.6): light at 53° from the normal, views from 40° to 70°. */
    plane_setup setup = {{0.5, 0.5, 0.5},
                         (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.8f, 0.0f, -0.6f}, 0,
                                    {3.0f, 3.0f, 3.0f}, 1, 1},
                         {0.9, 0.5, 0.2},
                         0.5};
    PF_CHECK(check_plane("sheen, directional light", &setup, NULL) == PLANE_EDGE * PLANE_EDGE);
    /* A point light over a rougher, whiter sheen. */
    setup = (plane_setup){{0.2, 0.4, 0.6},
                          (pf_light){{0.5f, 1.0f, 1.5f}, PF_LIGHT_POINT, {0, 0, -1}, 0,
                                     {4.0f, 4.0f, 4.0f}, 1, 1},
                          {1.0, 1.0, 1.0},
                          0.9};
    PF_CHECK(check_plane("sheen, point light", &setup, NULL) > PLANE_EDGE * PLANE_EDGE / 2);
}

/* Point lights over the plane, more than direct light visits one by one. */
#define PLANE_MANY_LIGHTS 24u
#define PLANE_MANY_LIGHTS_SPP 64u

typedef struct many_lights_setup {
    plane_setup each[PLANE_MANY_LIGHTS]; /* the plane with one light each */
} many_lights_setup;

/* The lights' radiances summed (linearity: plane_radiance light by light). */
static int many_lights_radiance(const void *opaque, const pf_camera *camera, uint32_t width,
                                uint32_t height, double film_x, double film_y,
                                double radiance[3])
{
    const many_lights_setup *setup = opaque;
    radiance[0] = radiance[1] = radiance[2] = 0.0;
    for (uint32_t i = 0; i < PLANE_MANY_LIGHTS; i++) {
        double one[3];
        if (!plane_radiance(&setup->each[i], camera, width, height, film_x, film_y, one))
            return 0;
        for (int c = 0; c < 3; c++)
            radiance[c] += one[c];
    }
    return 1;
}

PF_TEST(many_point_lights_over_a_plane_average_to_their_sum)
{
    /* Past PF_DIRECT_LIGHTS_EVERY_MAX punctual lights a vertex resamples a few of them
     * (direct_light.glsl), so the light carries noise: it must carry no bias. 23 point
     * lights of unequal colours and powers, 0.3-3 m over the plane, some far to the side, and
     * a sun. */
    PF_REQUIRE(PLANE_MANY_LIGHTS > PF_DIRECT_LIGHTS_EVERY_MAX);
    static many_lights_setup setup;
    pf_light lights[PLANE_MANY_LIGHTS];
    for (uint32_t i = 0; i < PLANE_MANY_LIGHTS; i++) {
        double angle = 2.399963 * i; /* the golden angle: a spiral */
        double radius = 0.4 + 0.35 * i;
        float power = 0.5f + 4.0f * (float)((i * 7u) % 11u) / 10.0f;
        lights[i] = (pf_light){{(float)(radius * cos(angle)), (float)(radius * sin(angle)),
                                0.3f + 0.12f * (float)((i * 5u) % 23u)},
                               PF_LIGHT_POINT,
                               {0, 0, -1},
                               0,
                               {power, power * (0.5f + 0.02f * (float)i), power * 0.8f},
                               1,
                               1};
        setup.each[i] = (plane_setup){{0.6, 0.5, 0.4}, lights[i]};
    }
    /* One a sun: picked by its power over the scene's disc (pf_photon_light_power). */
    lights[PLANE_MANY_LIGHTS - 1] = (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL,
                                               {0.36f, 0.0f, -0.933f}, 0, {0.3f, 0.25f, 0.2f},
                                               1, 1};
    setup.each[PLANE_MANY_LIGHTS - 1].light = lights[PLANE_MANY_LIGHTS - 1];
    ref_scene scene;
    plane_scene(&scene, &setup.each[0]);
    scene.frame.lights = lights;
    scene.frame.light_count = PLANE_MANY_LIGHTS;
    pf_render_settings settings = ref_settings(PLANE_EDGE, PLANE_EDGE, PLANE_MANY_LIGHTS_SPP, 13,
                                               0);
    pf_image image = {0};
    pf_error err = {0};
    layer_channels layers;
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s", err.message);
    } else if (!find_layers(&image, &layers)) {
        PF_CHECK_MSG(0, "direct/indirect/caustic layers missing");
    } else {
        PF_CHECK(ref_image_non_finite(&image) == 0);
        check_single_bounce_layers("many lights", &image, &layers, 1.0);
        static double residual[PLANE_EDGE * PLANE_EDGE];
        double bias = 0.0, squares = 0.0;
        uint32_t smooth = 0, compared = 0;
        for (uint32_t y = 0; y < PLANE_EDGE; y++) {
            for (uint32_t x = 0; x < PLANE_EDGE; x++) {
                double exact[3], curvature[3];
                if (!many_lights_radiance(&setup, &scene.frame.camera, PLANE_EDGE, PLANE_EDGE,
                                          x + 0.5, y + 0.5, exact))
                    continue;
                double relative = (ref_pixel(&image, layers.direct[0], x, y) - exact[0]) /
                                  exact[0];
                squares += relative * relative;
                compared++;
                footprint_curvature(many_lights_radiance, &setup, &scene.frame.camera,
                                    PLANE_EDGE, PLANE_EDGE, x, y, curvature);
                if (curvature[0] <= SMOOTH_RELATIVE_CURVATURE * exact[0]) {
                    residual[smooth++] = relative;
                    bias += curvature[0] / exact[0];
                }
            }
        }
        PF_CHECK_MSG(smooth >= 100, "only %u of %u pixels where the radiance is smooth", smooth,
                     compared);
        if (smooth > 1) {
            ref_stats stats = ref_stats_of(residual, smooth);
            double tolerance = NOISE_SIGMAS * stats.standard_error + bias / smooth +
                               FLOAT_RELATIVE_SLACK;
            double rms = sqrt(squares / compared);
            printf("  many lights: %u pixels against the sum of %u closed forms; over %u smooth "
                   "ones, mean relative error %.2g%% (tolerance %.2g%%); a pixel's RMS %.2g%%\n",
                   compared, PLANE_MANY_LIGHTS, smooth, 100.0 * stats.mean, 100.0 * tolerance,
                   100.0 * rms);
            PF_CHECK_MSG(fabs(stats.mean) <= tolerance,
                         "mean relative error %.3g%% (tolerance %.3g%%)", 100.0 * stats.mean,
                         100.0 * tolerance);
            /* Sampled, not visited: noise (the exact sum carries none). */
            PF_CHECK_MSG(stats.standard_error > FLOAT_RELATIVE_SLACK,
                         "standard error %.3g: were the lights sampled?", stats.standard_error);
        }
    }
    pf_image_free(&image);
    scene.frame.lights = scene.lights;
    scene.frame.light_count = 1;
    ref_scene_free(&scene);
}

/*
 * Configuration factor from a differential area to a parallel rectangle whose
 * corner lies on the area's normal, the rectangle's sides a and b (signed) at
 * distance c: J. R. Howell, "A Catalog of Radiation Heat Transfer
 * Configuration Factors", factor B-3:
 *   F = 1/(2π) [ A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²)) ],
 *   A = a/c, B = b/c.
 * It is odd in A and in B, so any rectangle follows by superposition.
 */
static double corner_form_factor(double a, double b, double c)
{
    double A = a / c, B = b / c;
    double root_a = sqrt(1.0 + A * A), root_b = sqrt(1.0 + B * B);
    return (A / root_a * atan(B / root_a) + B / root_b * atan(A / root_b)) / (2.0 * PI);
}

/* Configuration factor from (px, py, 0), normal +z, to [x0, x1] × [y0, y1] at height c. */
static double rectangle_form_factor(double px, double py, double x0, double x1, double y0,
                                    double y1, double c)
{
    return corner_form_factor(x1 - px, y1 - py, c) - corner_form_factor(x0 - px, y1 - py, c) -
           corner_form_factor(x1 - px, y0 - py, c) + corner_form_factor(x0 - px, y0 - py, c);
}

/* Emitter [-h, h]² at height `height` facing -z over a Lambert receiver at z = 0;
 * back_face_double_sided: its front faces +z instead, away from the receiver,
 * and its material is double-sided, so the receiver sees the emitting back face. */
typedef struct square_setup {
    double emitter_half;
    double height;
    double emission[3];
    double albedo[3];
    int back_face_double_sided;
} square_setup;

static int square_radiance(const void *opaque, const pf_camera *camera, uint32_t width,
                           uint32_t height, double film_x, double film_y, double radiance[3])
{
    radiance[0] = radiance[1] = radiance[2] = 0.0; /* also on a miss */
    const square_setup *setup = opaque;
    double point[3];
    if (!hit_plane(camera, width, height, film_x, film_y, point))
        return 0;
    double h = setup->emitter_half;
    /* E = π Le F, L = albedo/π E. */
    double factor = rectangle_form_factor(point[0], point[1], -h, h, -h, h, setup->height);
    for (int c = 0; c < 3; c++)
        radiance[c] = setup->albedo[c] * setup->emission[c] * factor;
    return 1;
}

static void square_scene(ref_scene *scene, const square_setup *setup)
{
    ref_scene_init(scene);
    uint32_t receiver = ref_scene_add_material(
        scene, ref_material(PF_MATERIAL_LAMBERT, (float)setup->albedo[0], (float)setup->albedo[1],
                            (float)setup->albedo[2]));
    pf_material emitter_material = ref_material_emitter(
        (float)setup->emission[0], (float)setup->emission[1], (float)setup->emission[2]);
    if (setup->back_face_double_sided)
        emitter_material.flags |= PF_MATERIAL_DOUBLE_SIDED;
    uint32_t emitter = ref_scene_add_material(scene, emitter_material);
    const float receiver_centre[3] = {0, 0, 0}, receiver_u[3] = {1, 0, 0},
                receiver_v[3] = {0, 1, 0};
    ref_scene_add_quad(scene, receiver_centre, receiver_u, receiver_v, receiver);
    /* half_u × half_v = -z: the front face looks down at the receiver (+z: up). */
    float h = (float)setup->emitter_half;
    float v_sign = setup->back_face_double_sided ? 1.0f : -1.0f;
    const float emitter_centre[3] = {0, 0, (float)setup->height}, emitter_u[3] = {h, 0, 0},
                emitter_v[3] = {0, v_sign * h, 0};
    ref_scene_add_quad(scene, emitter_centre, emitter_u, emitter_v, emitter);
}

#define SQUARE_EDGE 32u
#define SQUARE_SPP 64u
/* Tiles for the standard error: 4 px ≥ twice REF_FILTER_RADIUS_PIXELS. */
#define SQUARE_BLOCK 4u

static void check_square_area_light(const square_setup setup, const char *label)
{
    ref_scene scene;
    square_scene(&scene, &setup);
    /* The camera between the squares looks straight down at |x|, |y| ≤ 0.4 of the
     * receiver; the emitter, behind it, is out of view. */
    const float eye[3] = {0, 0, 0.5f}, target[3] = {0, 0, 0}, up_hint[3] = {0, 1, 0};
    ref_scene_look_at(&scene, eye, target, up_hint, (float)(2.0 * atan(0.8)));
    pf_render_settings settings = ref_settings(SQUARE_EDGE, SQUARE_EDGE, SQUARE_SPP, 21, 0);
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s", err.message);
        ref_scene_free(&scene);
        return;
    }
    layer_channels layers;
    PF_REQUIRE(find_layers(&image, &layers));
    PF_CHECK(ref_image_non_finite(&image) == 0);
    PF_CHECK(report.discarded_samples == 0);
    /* The emitter has albedo 0 and the receiver is flat: nothing bounces twice. */
    check_single_bounce_layers("area light", &image, &layers, 1.0);

    /* Residual direct − exact per pixel, in a scratch image with the same layout. */
    pf_image residual = {0};
    const char *names[3] = {"R", "G", "B"};
    PF_REQUIRE_OK(pf_image_create(&residual, SQUARE_EDGE, SQUARE_EDGE, 3, names, &err), &err);
    double bias[3] = {0, 0, 0}, exact_mean[3] = {0, 0, 0};
    for (uint32_t y = 0; y < SQUARE_EDGE; y++) {
        for (uint32_t x = 0; x < SQUARE_EDGE; x++) {
            double exact[3], curvature[3];
            square_radiance(&setup, &scene.frame.camera, SQUARE_EDGE, SQUARE_EDGE, x + 0.5,
                            y + 0.5, exact);
            footprint_curvature(square_radiance, &setup, &scene.frame.camera, SQUARE_EDGE,
                                SQUARE_EDGE, x, y, curvature);
            for (int c = 0; c < 3; c++) {
                residual.pixels[((size_t)y * SQUARE_EDGE + x) * 3 + c] =
                    (float)(ref_pixel(&image, layers.direct[c], x, y) - exact[c]);
                bias[c] += curvature[c] / (SQUARE_EDGE * SQUARE_EDGE);
                exact_mean[c] += exact[c] / (SQUARE_EDGE * SQUARE_EDGE);
            }
        }
    }
    const ref_region whole = {0, 0, SQUARE_EDGE, SQUARE_EDGE};
    /* The 4×4 pixels around the receiver's centre, where F is that of the centre. */
    const uint32_t c0 = SQUARE_EDGE / 2 - SQUARE_BLOCK / 2;
    const ref_region centre = {c0, c0, c0 + SQUARE_BLOCK, c0 + SQUARE_BLOCK};
    double centre_exact[3], direct_centre[3];
    square_radiance(&setup, &scene.frame.camera, SQUARE_EDGE, SQUARE_EDGE, SQUARE_EDGE / 2.0,
                    SQUARE_EDGE / 2.0, centre_exact);
    ref_region_means(&image, "direct", centre, direct_centre);
    for (int c = 0; c < 3; c++) {
        ref_stats stats = ref_region_block_stats(&residual, c, whole, SQUARE_BLOCK);
        double tolerance = NOISE_SIGMAS * stats.standard_error + bias[c] +
                           FLOAT_RELATIVE_SLACK * exact_mean[c];
        PF_CHECK_MSG(fabs(stats.mean) <= tolerance,
                     "channel %d: mean direct − exact = %.5g (exact mean %.5g), tolerance %.3g "
                     "(standard error %.3g, filter bias %.3g)",
                     c, stats.mean, exact_mean[c], tolerance, stats.standard_error, bias[c]);
        /* The test must be able to fail: its tolerance is a few percent at most. */
        PF_CHECK_MSG(tolerance <= 0.03 * exact_mean[c], "channel %d: tolerance %.3g too loose",
                     c, tolerance);
        /* One tile at the centre: the noise of one tile is the tiles' deviation. */
        double centre_tolerance = NOISE_SIGMAS * stats.deviation + bias[c] +
                                  FLOAT_RELATIVE_SLACK * centre_exact[c];
        PF_CHECK_NEAR(direct_centre[c], centre_exact[c], centre_tolerance);
        printf("  %s, channel %d: centre %.5g vs exact %.5g (F = %.5f); mean residual "
               "%.3g ± %.3g (tolerance %.3g)\n",
               label, c, direct_centre[c], centre_exact[c],
               rectangle_form_factor(0, 0, -0.5, 0.5, -0.5, 0.5, 1.0), stats.mean,
               stats.standard_error, tolerance);
    }
    PF_CHECK(ref_stage_counter(&report, "shade", "samples_per_pixel") == SQUARE_SPP);
    PF_CHECK(ref_stage_counter(&report, "shade", "paths") ==
             (double)SQUARE_EDGE * SQUARE_EDGE * SQUARE_SPP);
    PF_CHECK(ref_stage_counter(&report, "shade", "rays") >=
             ref_stage_counter(&report, "shade", "paths"));
    PF_CHECK(ref_stage_counter(&report, "shade", "discarded_samples") == 0);
    pf_image_free(&residual);
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(area_light_over_a_parallel_square_matches_the_form_factor)
{
    const square_setup setup = {0.5, 1.0, {2.0, 3.0, 4.0}, {0.7, 0.6, 0.5}, 0};
    check_square_area_light(setup, "area light");
}

/* glTF doubleSided (Blender's default): the same light from the emitter's back
 * face, through light sampling and emission hits alike. */
PF_TEST(double_sided_emitter_lights_from_its_back_face_too)
{
    const square_setup setup = {0.5, 1.0, {2.0, 3.0, 4.0}, {0.7, 0.6, 0.5}, 1};
    check_square_area_light(setup, "back face of a double-sided light");
}

PF_TEST(visible_emitter_is_direct_light_from_its_emitting_faces_only)
{
    const square_setup setup = {0.5, 1.0, {2.0, 3.0, 4.0}, {0.7, 0.6, 0.5}, 0};
    ref_scene scene;
    square_scene(&scene, &setup);
    /* From below, looking up: the emitting face fills the view. */
    const float eye[3] = {0, 0, 0.5f}, target[3] = {0, 0, 1}, up_hint[3] = {0, 1, 0};
    ref_scene_look_at(&scene, eye, target, up_hint, 1.0f);
    pf_render_settings settings = ref_settings(16, 16, 4, 31, 0);
    pf_image image = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err), &err);
    layer_channels layers;
    PF_REQUIRE(find_layers(&image, &layers));
    /* Black background beyond, nothing between: what the camera sees is Le, all of it direct. */
    check_single_bounce_layers("emitter front", &image, &layers, 1.0);
    uint32_t off = 0;
    for (uint32_t y = 0; y < 16; y++)
        for (uint32_t x = 0; x < 16; x++)
            for (int c = 0; c < 3; c++)
                off += !(fabs(ref_pixel(&image, layers.beauty[c], x, y) - setup.emission[c]) <=
                         FLOAT_RELATIVE_SLACK * setup.emission[c]);
    PF_CHECK_MSG(off == 0, "%u pixel values differ from the emitted radiance", off);
    pf_image_free(&image);

    /* From above, the view is filled by the emitter's back face (albedo 0): it
     * emits nothing and reflects nothing, so the image is black yet covered. */
    const float eye_above[3] = {0, 0, 1.5f}, target_below[3] = {0, 0, 0};
    ref_scene_look_at(&scene, eye_above, target_below, up_hint, 0.5f);
    PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err), &err);
    PF_REQUIRE(find_layers(&image, &layers));
    const ref_region middle = {4, 4, 12, 12};
    double means[3];
    ref_region_means(&image, "", middle, means);
    for (int c = 0; c < 3; c++)
        PF_CHECK(means[c] == 0.0);
    PF_CHECK(ref_region_stats(&image, layers.alpha, middle).mean == 1.0);
    pf_image_free(&image);

    /* The same view of a double-sided emitter: its back face shows Le. */
    for (uint32_t m = 0; m < scene.frame.material_count; m++)
        if (scene.frame.materials[m].emission[0] > 0.0f)
            scene.frame.materials[m].flags |= PF_MATERIAL_DOUBLE_SIDED;
    PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err), &err);
    PF_REQUIRE(find_layers(&image, &layers));
    ref_region_means(&image, "", middle, means);
    for (int c = 0; c < 3; c++)
        PF_CHECK_MSG(fabs(means[c] - setup.emission[c]) <= FLOAT_RELATIVE_SLACK * setup.emission[c],
                     "double-sided back face, channel %d: %.5g, emitted %.5g", c, means[c],
                     setup.emission[c]);
    pf_image_free(&image);
    ref_scene_free(&scene);
}

/*
 * KHR_materials_volume: an emitter of radiance Le seen at normal incidence
 * through a glass slab (ior 1.5, F = 0.04 at each face) 0.5 m thick whose
 * volume absorbs σ = (0.5, 1, 2) per metre. Every path crosses the slab with
 * the Beer-Lambert factor e^(−σd) per crossing and bounces between the faces
 * any number of times: L = Le (1 − F)² e^(−σd) / (1 − F² e^(−2σd)) (the
 * (η_i/η_t)² of entering and leaving cancel). The same slab without
 * absorption gives Le (1 − F)² / (1 − F²).
 */
PF_TEST(absorbing_slab_attenuates_by_beer_lambert)
{
    const double le = 2.0, thickness = 0.5, f = 0.04;
    const double sigma[3] = {0.5, 1.0, 2.0};
    for (int absorbing = 0; absorbing < 2; absorbing++) {
        ref_scene scene;
        ref_scene_init(&scene);
        pf_material glass = pf_material_glass(1.5f, 1, 1, 1);
        for (int c = 0; c < 3; c++)
            glass.absorption[c] = absorbing ? (float)sigma[c] : 0.0f;
        uint32_t slab = ref_scene_add_material(&scene, glass);
        uint32_t emitter = ref_scene_add_material(&scene, ref_material_emitter(2, 2, 2));
        /* Front face +z towards the camera; the back face's front looks at the emitter. */
        const float front_centre[3] = {0, 0, 0.5f}, back_centre[3] = {0, 0, 0},
                    emitter_centre[3] = {0, 0, -0.5f};
        const float u[3] = {4, 0, 0}, v_up[3] = {0, 4, 0}, v_down[3] = {0, -4, 0};
        ref_scene_add_quad(&scene, front_centre, u, v_up, slab);
        ref_scene_add_quad(&scene, back_centre, u, v_down, slab);
        ref_scene_add_quad(&scene, emitter_centre, u, v_up, emitter);
        const float eye[3] = {0, 0, 2}, target[3] = {0, 0, 0}, up_hint[3] = {0, 1, 0};
        ref_scene_look_at(&scene, eye, target, up_hint, 0.1f);
        pf_render_settings settings = ref_settings(16, 16, 64, 41, 0);
        pf_image image = {0};
        pf_error err = {0};
        PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err),
                      &err);
        const ref_region whole = {0, 0, 16, 16};
        double means[3];
        ref_region_means(&image, "", whole, means);
        for (int c = 0; c < 3; c++) {
            double t = absorbing ? exp(-sigma[c] * thickness) : 1.0;
            double expected = le * (1 - f) * (1 - f) * t / (1 - f * f * t * t);
            /* 16,384 paths, ~8 % of them reflected away: a standard error near 0.2 %. */
            PF_CHECK_MSG(fabs(means[c] - expected) <= 0.015 * expected,
                         "%s slab, channel %d: %.5f, Beer-Lambert %.5f",
                         absorbing ? "absorbing" : "clear", c, means[c], expected);
            printf("  %s slab, channel %d: %.5f vs %.5f\n", absorbing ? "absorbing" : "clear",
                   c, means[c], expected);
        }
        pf_image_free(&image);
        ref_scene_free(&scene);
    }
}

/*
 * An orthographic camera (glTF's: parallel rays over ymag half extents, world units): a
 * 1 × 1 quad 2 m in front of it, seen with ymag 1 in a 32 × 24 image (1 m spans the longer
 * side, so the half extents are 1 and 0.75), covers exactly the 16 × 16 pixels of
 * [8, 24) × [4, 20), whatever its distance, each at
 * depth 2 (a pinhole would see the quad's middle nearer than its corners). Every preset's
 * camera rays (the box filter: a sample stays in its pixel).
 */
PF_TEST(orthographic_camera_sees_a_quad_at_one_depth_in_every_preset)
{
    ref_scene scene;
    ref_scene_init(&scene);
    uint32_t white = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_LAMBERT, 0.8f, 0.8f,
                                                                 0.8f));
    const float centre[3] = {0.0f, 0.0f, -2.0f}, half_u[3] = {0.5f, 0.0f, 0.0f},
                half_v[3] = {0.0f, 0.5f, 0.0f};
    ref_scene_add_quad(&scene, centre, half_u, half_v, white);
    ref_scene_add_light(&scene, (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0.0f, 0.0f, -1.0f},
                                           0, {1.0f, 1.0f, 1.0f}});
    scene.frame.camera.orthographic = 1;
    scene.frame.camera.ymag = 1.0f;
    static const pf_quality presets[4] = {PF_QUALITY_PREVIEW, PF_QUALITY_FAST,
                                          PF_QUALITY_FINAL, PF_QUALITY_REFERENCE};
    for (int q = 0; q < 4; q++) {
        pf_render_settings settings = ref_settings(32, 24, 2, 5, 1);
        settings.quality = presets[q];
        settings.pixel_filter = PF_FILTER_BOX;
        settings.photons_per_pass = 4000;
        pf_image image = {0};
        pf_error err = {0};
        PF_REQUIRE_OK(pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err),
                      &err);
        int depth = pf_image_channel(&image, "depth.Z");
        PF_REQUIRE(depth >= 0);
        uint32_t seen = 0, wrong = 0;
        for (uint32_t y = 0; y < 24; y++)
            for (uint32_t x = 0; x < 32; x++) {
                double z = image.pixels[(y * 32 + x) * image.channel_count + depth];
                int inside = x >= 8 && x < 24 && y >= 4 && y < 20;
                seen += z > 0.0;
                wrong += inside ? !(fabs(z - 2.0) <= 1e-5) : z != 0.0;
            }
        PF_CHECK_MSG(seen == 256 && wrong == 0, "%s: %u pixels see the quad, %u wrong",
                     pf_quality_name(presets[q]), seen, wrong);
        pf_image_free(&image);
    }
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(point_light_over_a_plane_matches_inverse_square_cosine);
    PF_RUN(spot_light_inside_its_inner_cone_matches_a_point_light);
    PF_RUN(directional_light_over_a_plane_matches_cosine_law);
    PF_RUN(sheen_over_a_plane_matches_its_lobe_over_the_scaled_base);
    PF_RUN(many_point_lights_over_a_plane_average_to_their_sum);
    PF_RUN(area_light_over_a_parallel_square_matches_the_form_factor);
    PF_RUN(double_sided_emitter_lights_from_its_back_face_too);
    PF_RUN(visible_emitter_is_direct_light_from_its_emitting_faces_only);
    PF_RUN(absorbing_slab_attenuates_by_beer_lambert);
    PF_RUN(orthographic_camera_sees_a_quad_at_one_depth_in_every_preset);
    return render_test_finish(ctx, renderer);
}
