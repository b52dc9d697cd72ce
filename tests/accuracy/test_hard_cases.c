/*
 * Hard cases against their converged answers (issue 16): a small bright
 * light, a room lit only indirectly, light at grazing angles, a thin wall
 * between a lit and a dark half (hard_cases.h describes each scene). The
 * converged answer is the reference path tracer at REFERENCE_SPP (each case
 * converges under it: the lights are small but not tiny).
 *
 * For `final` (FINAL_PASSES passes) and `fast` (its defaults), per case:
 *   - no NaN, infinite or negative value in any channel;
 *   - the image's mean over R, G, B, as a ratio to the reference's, within
 *     the preset's bounds for the case, and its brightest pixel at most the
 *     preset's bound × the reference's brightest;
 *   - thin-wall: the dark half's mean at most DARK_LEAK_BOUND × the
 *     reference's there (light leaking through the wall).
 * final's bounds are tight (±5 %, ±8 % lit only indirectly; brightest ≤ 2×):
 * it matches the converged image on every case (measured 0.990–1.008× at
 * 8 passes of 30,000 photons against 512 spp; sizes chosen for the suite's
 * time under ASan on 2 cores).
 * fast's are what a 2-band LPV does here, measured (bench/RESULTS.md) and
 * kept as bounds so that it cannot get worse unseen: 0.95× with the small
 * light, 0.64× lit only indirectly (propagation loses light round the
 * partition), 1.38× with the thin wall and 4.3× at grazing light — an open
 * plane lights itself: the SH smear sends its own reflected light sideways
 * in the cells just above it, and the lookup reads that as irradiance,
 * which dwarfs the true (grazing, tiny) direct light. `fast` is not the
 * preset for such scenes; the docs say so.
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

#define WIDTH 32u
#define HEIGHT 24u
#define REFERENCE_SPP 512u
#define FINAL_PASSES 8u
#define FINAL_PHOTONS 30000u
#define DARK_LEAK_BOUND 2.0

typedef struct image_stats {
    double mean, max;
    size_t bad;
} image_stats;

static image_stats stats_of(const pf_image *image, uint32_t x0, uint32_t x1)
{
    image_stats s = {0.0, 0.0, 0};
    size_t count = 0;
    for (uint32_t y = 0; y < image->height; y++) {
        for (uint32_t x = x0; x < x1; x++) {
            for (int c = 0; c < 3; c++) {
                double v = ref_pixel(image, c, x, y);
                if (!isfinite(v) || v < 0.0) {
                    s.bad++;
                    continue;
                }
                s.mean += v;
                s.max = v > s.max ? v : s.max;
                count++;
            }
        }
    }
    s.mean /= count ? (double)count : 1.0;
    return s;
}

/* First image column whose centre ray meets the floor right of the thin wall. */
static uint32_t thin_wall_split(const ref_scene *scene)
{
    for (uint32_t x = 0; x < WIDTH; x++) {
        double d[3];
        ref_camera_ray(&scene->frame.camera, WIDTH, HEIGHT, x + 0.5, HEIGHT / 2.0, d);
        const float *eye = scene->frame.camera.position;
        double t = -eye[1] / d[1];
        if (eye[0] + t * d[0] > HARD_THIN_WALL_X + 0.1)
            return x;
    }
    return WIDTH;
}

/* A preset's bounds for one case: mean ratio in [low, high], brightest ≤ max × the reference's. */
typedef struct bounds {
    double low, high, max;
} bounds;

static const bounds final_tight = {0.95, 1.05, 2.0};

static void check_case(hard_case which, bounds final_bounds, bounds fast_bounds)
{
    const char *name = hard_case_name(which);
    ref_scene scene;
    hard_case_build(which, &scene);
    pf_error err = {0};
    pf_image reference = {0};
    pf_render_settings settings = ref_settings(WIDTH, HEIGHT, REFERENCE_SPP, 21, 0);
    if (pf_render_frame(renderer, &scene.frame, &settings, &reference, NULL, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: reference: %s", name, err.message);
        ref_scene_free(&scene);
        return;
    }
    uint32_t split = which == HARD_THIN_WALL ? thin_wall_split(&scene) : 0;
    image_stats ref = stats_of(&reference, 0, WIDTH);
    image_stats ref_dark = stats_of(&reference, 0, split);
    printf("  %s: reference mean %.5f, max %.3f\n", name, ref.mean, ref.max);
    static const pf_quality presets[] = {PF_QUALITY_FINAL, PF_QUALITY_FAST};
    for (size_t p = 0; p < 2; p++) {
        const char *preset = pf_quality_name(presets[p]);
        settings.quality = presets[p];
        settings.samples_per_pixel = presets[p] == PF_QUALITY_FINAL ? FINAL_PASSES : 0;
        settings.photons_per_pass = presets[p] == PF_QUALITY_FINAL ? FINAL_PHOTONS : 0;
        pf_image image = {0};
        if (pf_render_frame(renderer, &scene.frame, &settings, &image, NULL, &err) != PF_OK) {
            PF_CHECK_MSG(0, "%s: %s: %s", name, preset, err.message);
            continue;
        }
        image_stats s = stats_of(&image, 0, WIDTH);
        double ratio = s.mean / ref.mean;
        double relmse = ref_layer_relmse(&image, &reference, REF_CH_RGB);
        printf("  %s: %s mean %.3f× the reference's, max %.2f×, relMSE %.4f\n", name, preset,
               ratio, s.max / ref.max, relmse);
        bounds b = presets[p] == PF_QUALITY_FINAL ? final_bounds : fast_bounds;
        PF_CHECK_MSG(s.bad == 0, "%s, %s: %zu NaN, infinite or negative values", name, preset,
                     s.bad);
        PF_CHECK_MSG(ratio >= b.low && ratio <= b.high,
                     "%s, %s: mean %.4f× the reference's (bounds %g..%g)", name, preset, ratio,
                     b.low, b.high);
        PF_CHECK_MSG(s.max <= b.max * ref.max, "%s, %s: brightest %g, the reference's %g", name,
                     preset, s.max, ref.max);
        if (which == HARD_THIN_WALL) {
            image_stats dark = stats_of(&image, 0, split);
            printf("  %s: %s dark half %.5f, the reference's %.5f (%u columns)\n", name, preset,
                   dark.mean, ref_dark.mean, split);
            PF_CHECK_MSG(split > 4 && dark.mean <= DARK_LEAK_BOUND * ref_dark.mean,
                         "%s, %s: dark half %g, the reference's %g", name, preset, dark.mean,
                         ref_dark.mean);
        }
        pf_image_free(&image);
    }
    pf_image_free(&reference);
    ref_scene_free(&scene);
}

PF_TEST(small_bright_light)
{
    check_case(HARD_SMALL_LIGHT, final_tight, (bounds){0.9, 1.1, 2.0});
}

PF_TEST(lit_only_indirectly)
{
    check_case(HARD_INDIRECT_ONLY, (bounds){0.92, 1.08, 2.0}, (bounds){0.55, 1.1, 2.0});
}

PF_TEST(grazing_light)
{
    check_case(HARD_GRAZING, final_tight, (bounds){0.9, 5.0, 5.0});
}

PF_TEST(thin_wall_between_light_and_dark)
{
    check_case(HARD_THIN_WALL, final_tight, (bounds){0.9, 1.6, 2.0});
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(small_bright_light);
    PF_RUN(lit_only_indirectly);
    PF_RUN(grazing_light);
    PF_RUN(thin_wall_between_light_and_dark);
    return render_test_finish(ctx, renderer);
}
