/*
 * Bounded photon estimates (issue 16, hard case 2: fireflies in `final`).
 *
 * Lamp against a wall: an emitting panel whose edge touches a wall. `final`
 * used to add next-event estimation at each gather ray's diffuse hit x₂
 * with no MIS partner; where x₂ lies on the wall next to the panel the
 * light sample's weight cos·cos·A/d² has no bound, and single gather rays
 * put pixels several times above anything in the converged image (4
 * passes: 3.3× the reference's brightest pixel; 16 passes: 2.3×). x₂ now
 * takes its direct light from the global map, which holds first hits too
 * (a density estimate over a fixed radius is bounded).
 *
 * Lamps behind glass (after Veach's bidirectional test scene): a room lit
 * only by two small emitters inside glass spheres, so every photon reaching
 * the room went through glass first and much of the light is caustic.
 *
 * Asserted at 1, 4 and 16 passes against a reference render (a path tracer
 * converges on both: the emitters are small but not tiny): no NaN,
 * infinite or negative value; from 4 passes on, the brightest pixel at most
 * FIREFLY_BOUND × the reference's brightest (one pass is one camera sample
 * per pixel, whose direct light alone may exceed it at an emitter's edge);
 * the mean over R, G, B within MEAN_TOLERANCE of the reference's; relMSE
 * against the reference falling from 1 to 16 passes.
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
#define FIREFLY_BOUND 2.0
#define MEAN_TOLERANCE 0.06
#define PHOTONS_PER_PASS 30000u

/* Brightest R, G or B value; counts NaN, infinite and negative values. */
static double brightest(const pf_image *image, size_t *bad)
{
    double best = 0.0;
    *bad = 0;
    for (uint32_t y = 0; y < image->height; y++) {
        for (uint32_t x = 0; x < image->width; x++) {
            for (int c = 0; c < 3; c++) {
                double v = ref_pixel(image, c, x, y);
                if (!isfinite(v) || v < 0.0)
                    (*bad)++;
                else if (v > best)
                    best = v;
            }
        }
    }
    return best;
}

static void check_final_against_reference(const char *name, const ref_scene *scene)
{
    pf_error err = {0};
    pf_image reference = {0};
    pf_render_settings settings = ref_settings(WIDTH, HEIGHT, REFERENCE_SPP, 3, 0);
    if (pf_render_frame(renderer, &scene->frame, &settings, &reference, NULL, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: reference: %s", name, err.message);
        return;
    }
    size_t bad;
    double reference_max = brightest(&reference, &bad);
    double reference_mean = ref_layer_mean(&reference, REF_CH_RGB);
    printf("  %s: reference max %.3f, mean %.5f\n", name, reference_max, reference_mean);
    static const uint32_t passes[] = {1, 4, 16};
    double first_relmse = 0.0;
    for (size_t i = 0; i < sizeof passes / sizeof passes[0]; i++) {
        pf_image image = {0};
        settings.quality = PF_QUALITY_FINAL;
        settings.samples_per_pixel = passes[i];
        settings.photons_per_pass = PHOTONS_PER_PASS;
        if (pf_render_frame(renderer, &scene->frame, &settings, &image, NULL, &err) != PF_OK) {
            PF_CHECK_MSG(0, "%s: final %u passes: %s", name, passes[i], err.message);
            continue;
        }
        double max = brightest(&image, &bad);
        double mean = ref_layer_mean(&image, REF_CH_RGB);
        double relmse = ref_layer_relmse(&image, &reference, REF_CH_RGB);
        printf("  %s: final %2u passes: max %.3f (%.2f× the reference's), mean %.3f×, relMSE %.4f\n",
               name, passes[i], max, max / reference_max, mean / reference_mean, relmse);
        PF_CHECK_MSG(bad == 0, "%s, %u passes: %zu NaN, infinite or negative values", name,
                     passes[i], bad);
        PF_CHECK_MSG(passes[i] < 4 || max <= FIREFLY_BOUND * reference_max,
                     "%s, %u passes: a pixel of %g against the reference's brightest %g", name,
                     passes[i], max, reference_max);
        PF_CHECK_MSG(fabs(mean / reference_mean - 1.0) <= MEAN_TOLERANCE,
                     "%s, %u passes: mean %g against the reference's %g", name, passes[i], mean,
                     reference_mean);
        if (i == 0)
            first_relmse = relmse;
        else if (passes[i] == 16)
            PF_CHECK_MSG(relmse < first_relmse, "%s: relMSE %g at 16 passes, %g at 1", name,
                         relmse, first_relmse);
        pf_image_free(&image);
    }
    pf_image_free(&reference);
}

PF_TEST(lamp_against_a_wall_has_no_fireflies)
{
    ref_scene scene;
    hard_case_build(HARD_LAMP_WALL, &scene);
    check_final_against_reference("lamp against a wall", &scene);
    ref_scene_free(&scene);
}

PF_TEST(lamps_behind_glass_have_no_fireflies)
{
    ref_scene scene;
    hard_case_build(HARD_LAMPS_GLASS, &scene);
    check_final_against_reference("lamps behind glass", &scene);
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(lamp_against_a_wall_has_no_fireflies);
    PF_RUN(lamps_behind_glass_have_no_fireflies);
    return render_test_finish(ctx, renderer);
}
