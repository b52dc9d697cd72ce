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
#include "../render/reference_test_util.h"
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
#define REFERENCE_SPP 1024u
#define FIREFLY_BOUND 2.0
#define MEAN_TOLERANCE 0.06
#define PHOTONS_PER_PASS 50000u

static void build_lamp_against_wall(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f));
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(20.0f, 20.0f, 20.0f));
    const float lo[3] = {-1, 0, -1}, hi[3] = {1, 2, 1};
    ref_scene_add_box(scene, lo, hi, 1, white);
    /* A panel facing down, its edge against the wall x = -1. */
    const float c[3] = {-0.8f, 1.5f, 0}, u[3] = {0, 0, 0.2f}, v[3] = {0.2f, 0, 0};
    ref_scene_add_quad(scene, c, v, u, lamp);
    const float eye[3] = {0.5f, 1.0f, 0.9f}, target[3] = {0.3f, 0, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 0.6f);
}

static void build_lamps_behind_glass(ref_scene *scene)
{
    ref_scene_init(scene);
    uint32_t white = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f));
    uint32_t wood = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.6f, 0.4f, 0.25f));
    uint32_t glass = ref_scene_add_material(scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(40.0f, 36.0f, 30.0f));
    const float room_lo[3] = {-2, 0, -2}, room_hi[3] = {2, 2.5f, 2};
    ref_scene_add_box(scene, room_lo, room_hi, 1, white);
    const float table_lo[3] = {-1, 0, -0.6f}, table_hi[3] = {1, 0.7f, 0.6f};
    ref_scene_add_box(scene, table_lo, table_hi, 0, wood);
    /* Emitters off the glass spheres' centres: the glass bends their light into caustics. */
    const float glass_centre[2][3] = {{-0.5f, 1.0f, 0.0f}, {0.5f, 1.0f, 0.0f}};
    const float lamp_centre[2][3] = {{-0.47f, 1.05f, 0.0f}, {0.53f, 1.05f, 0.02f}};
    for (int i = 0; i < 2; i++) {
        ref_scene_add_sphere(scene, glass_centre[i], 0.15f, 24, 12, 0, glass);
        ref_scene_add_sphere(scene, lamp_centre[i], 0.05f, 12, 6, 0, lamp);
    }
    const float eye[3] = {0, 1.3f, 1.9f}, target[3] = {0, 0.8f, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 1.0f);
}

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
    build_lamp_against_wall(&scene);
    check_final_against_reference("lamp against a wall", &scene);
    ref_scene_free(&scene);
}

PF_TEST(lamps_behind_glass_have_no_fireflies)
{
    ref_scene scene;
    build_lamps_behind_glass(&scene);
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
