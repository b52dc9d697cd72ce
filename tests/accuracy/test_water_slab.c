/*
 * Energy through refractive interfaces (issue 16, hard case 1), against
 * closed forms. A directional light of irradiance E (perpendicular to it)
 * at θ = 30° from the vertical, a grey Lambert floor (albedo a), a
 * dielectric of index η = 1.8, a camera straight above looking down:
 *
 * Floor under water: the floor lies inside a closed dielectric box (the
 * water), as the floor of a pool does. Light crosses one interface:
 *   E_d = E cos θ (1 − F(θ))                    (caustic: L S D)
 * and the floor's diffusely reflected light comes back to it from the
 * surface with the internal diffuse reflectance R_i = 1 − (1 − R_e)/η²
 * (R_e the external one, Fresnel averaged over the cosine-weighted
 * hemisphere; reciprocity), so over a layer much wider than deep
 *   E_total = E_d / (1 − a R_i).
 * The camera sees the floor's radiance a/π E through the surface: the
 * radiance entering air from the denser medium is (1 − F(0))/η² of it.
 * The renderer used to leave the 1/η² out of camera paths (it "cancels on
 * paths that enter and leave a medium"), and its image was η² = 3.24×
 * too bright here: the bias of the water scene.
 *
 * Slab above the floor: a floating slab transmits (1 − F)/(1 + F) of the
 * flux at each angle (two interfaces, every internal reflection summed:
 * (1 − F)² Σ F²ᵏ), and the camera sees the floor through it with the same
 * factor at its own angle. The caustic layer (light that reached the floor
 * through the slab only) has a closed form for both presets that build a
 * caustic map; the light reflected between floor and slab is indirect.
 *
 * Checked for `final` (photon mapping) and `fast` (the caustic layer: the
 * LPV is not built for light trapped in a thin layer, so fast's indirect
 * is only required to be finite and non-negative). The reference path
 * tracer cannot find the caustics of a directional light (a delta light
 * behind a delta interface), so it is no ground truth here: the closed
 * forms are.
 */
#include "hard_cases.h"
#include "../render/render_test_env.h"
#include "pf_render.h"
#include "pf_test.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define EDGE 32u
#define PI 3.14159265358979323846
#define ETA HARD_WATER_ETA
#define ALBEDO HARD_WATER_ALBEDO
#define IRRADIANCE HARD_WATER_IRRADIANCE
#define THETA_DEG HARD_WATER_THETA_DEG

/* External diffuse reflectance: ∫ F(θ) 2 cos θ sin θ dθ over the hemisphere (midpoint rule). */
static double external_diffuse_reflectance(double eta)
{
    const int steps = 20000;
    double sum = 0.0;
    for (int i = 0; i < steps; i++) {
        double theta = (i + 0.5) * (PI / 2.0) / steps;
        sum += ref_fresnel_dielectric(cos(theta), eta) * 2.0 * cos(theta) * sin(theta);
    }
    return sum * (PI / 2.0) / steps;
}

static pf_status render(const ref_scene *scene, pf_quality quality, uint32_t samples,
                        pf_image *image, pf_error *err)
{
    pf_render_settings settings = ref_settings(EDGE, EDGE, samples, 11, 0);
    settings.quality = quality;
    /* fast's one photon pass: 4× its default, so ~300 caustic photons land in view. */
    if (quality == PF_QUALITY_FAST)
        settings.photons_per_pass = 131072;
    memset(image, 0, sizeof *image);
    return pf_render_frame(renderer, &scene->frame, &settings, image, NULL, err);
}

/* Mean of the layer's R, G, B over the image; checks every pixel finite, ≥ 0 and ≤ bound. */
static double checked_mean(const pf_image *image, uint32_t first, double bound, const char *what)
{
    double sum = 0.0;
    size_t bad = 0, over = 0;
    for (uint32_t y = 0; y < image->height; y++) {
        for (uint32_t x = 0; x < image->width; x++) {
            for (uint32_t c = first; c < first + 3; c++) {
                double value = ref_pixel(image, (int)c, x, y);
                bad += !isfinite(value) || value < 0.0;
                over += value > bound;
                sum += value;
            }
        }
    }
    PF_CHECK_MSG(bad == 0, "%s: %zu values NaN, infinite or negative", what, bad);
    PF_CHECK_MSG(over == 0, "%s: %zu values above %g", what, over, bound);
    return sum / (3.0 * image->width * image->height);
}

PF_TEST(floor_under_water_matches_the_analytic_radiance)
{
    ref_scene scene;
    hard_case_build(HARD_WATER, &scene);
    double theta = THETA_DEG * PI / 180.0;
    double seen = (1.0 - ref_fresnel_dielectric(1.0, ETA)) / (ETA * ETA);
    double e_direct =
        IRRADIANCE * cos(theta) * (1.0 - ref_fresnel_dielectric(cos(theta), ETA));
    double r_internal = 1.0 - (1.0 - external_diffuse_reflectance(ETA)) / (ETA * ETA);
    double e_total = e_direct / (1.0 - ALBEDO * r_internal);
    double caustic = seen * ALBEDO / PI * e_direct, beauty = seen * ALBEDO / PI * e_total;
    printf("  analytic: caustic %.5f, beauty %.5f (R_i %.4f)\n", caustic, beauty, r_internal);

    pf_image image;
    pf_error err = {0};
    if (render(&scene, PF_QUALITY_FINAL, 4, &image, &err) == PF_OK) {
        double b = checked_mean(&image, REF_CH_RGB, 4.0 * beauty, "final beauty");
        double k = checked_mean(&image, REF_CH_CAUSTIC, 4.0 * beauty, "final caustic");
        double d = checked_mean(&image, REF_CH_DIRECT, 4.0 * beauty, "final direct");
        printf("  final: beauty %.5f (%.3f×), caustic %.5f (%.3f×), direct %.5f\n", b,
               b / beauty, k, k / caustic, d);
        PF_CHECK_NEAR(b / beauty, 1.0, 0.08);
        PF_CHECK_NEAR(k / caustic, 1.0, 0.08);
        PF_CHECK(d == 0.0); /* the water blocks shadow rays */
    } else {
        PF_CHECK_MSG(0, "final: %s", err.message);
    }
    pf_image_free(&image);
    if (render(&scene, PF_QUALITY_FAST, 4, &image, &err) == PF_OK) {
        double k = checked_mean(&image, REF_CH_CAUSTIC, 4.0 * beauty, "fast caustic");
        checked_mean(&image, REF_CH_RGB, 4.0 * beauty, "fast beauty");
        printf("  fast: caustic %.5f (%.3f×)\n", k, k / caustic);
        PF_CHECK_NEAR(k / caustic, 1.0, 0.12);
    } else {
        PF_CHECK_MSG(0, "fast: %s", err.message);
    }
    pf_image_free(&image);
    /* The reference cannot find this caustic (a directional light behind water) and says so. */
    pf_render_settings settings = ref_settings(EDGE, EDGE, 1, 11, 0);
    pf_frame_report report = {0};
    if (pf_render_frame(renderer, &scene.frame, &settings, &image, &report, &err) == PF_OK) {
        const pf_stage_timing *row = ref_row(&report, "caustics");
        PF_CHECK_MSG(row && row->skipped && strstr(row->reason, "final renders them"),
                     "reference's caustics row: %s", row ? row->reason : "missing");
    } else {
        PF_CHECK_MSG(0, "reference: %s", err.message);
    }
    pf_image_free(&image);
    ref_scene_free(&scene);
}

PF_TEST(slab_above_the_floor_transmits_one_minus_f_over_one_plus_f)
{
    ref_scene scene;
    hard_case_build_water(&scene, 0.05f, 0.12f);
    double theta = THETA_DEG * PI / 180.0;
    double f_light = ref_fresnel_dielectric(cos(theta), ETA);
    double f_view = ref_fresnel_dielectric(1.0, ETA);
    double through_light = (1.0 - f_light) / (1.0 + f_light);
    double through_view = (1.0 - f_view) / (1.0 + f_view);
    double caustic = through_view * ALBEDO / PI * IRRADIANCE * cos(theta) * through_light;
    printf("  analytic caustic %.5f\n", caustic);
    pf_image image;
    pf_error err = {0};
    if (render(&scene, PF_QUALITY_FINAL, 4, &image, &err) == PF_OK) {
        double k = checked_mean(&image, REF_CH_CAUSTIC, 4.0 * caustic, "final caustic");
        double b = checked_mean(&image, REF_CH_RGB, 8.0 * caustic, "final beauty");
        printf("  final: caustic %.5f (%.3f×), beauty %.5f\n", k, k / caustic, b);
        PF_CHECK_NEAR(k / caustic, 1.0, 0.08);
        PF_CHECK(b >= k);
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
    PF_RUN(floor_under_water_matches_the_analytic_radiance);
    PF_RUN(slab_above_the_floor_transmits_one_minus_f_over_one_plus_f);
    return render_test_finish(ctx, renderer);
}
