/*
 * Energy conservation of the reference path tracer in furnaces: closed
 * inward-facing spheres whose every triangle emits Le and reflects with
 * albedo a (Lambert).
 *
 * The empty furnace (every pixel → Le/(1−a)) is test_reference.c's; here:
 * - Objects of every material inside (Lambert, mirror and glass, albedo 1, the
 *   largest allowed): a non-emitting surface of albedo ≤ 1 passes on at most
 *   what reaches it, so along any path the k-th wall hit still adds at most
 *   Le·a^k: no pixel may exceed Le/(1−a) beyond noise. Lossless objects keep
 *   the field uniform (L = Le/(1−a) everywhere still solves the rendering
 *   equation), so the image must also converge to the bound: a material that
 *   loses energy shows as well as one that creates it.
 * - Black enclosure (a = 0): every path ends at its first wall hit with Le, so
 *   a mirror and a glass slab of albedo 1 must be invisible (reflection plus
 *   transmission of a slab is exactly 1), every pixel Le.
 */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

#define FURNACE_EDGE 32u
/* Two renders of this many samples put the image mean within ~0.1% (standard error). */
#define FURNACE_SPP 32u
/* The black enclosure is noiseless for an exact Fresnel split: samples only cover the filter. */
#define BLACK_ENCLOSURE_SPP 8u
/* The enclosure: a UV sphere of radius 1 m around the origin, fine enough to be round-ish. */
#define FURNACE_SEGMENTS 32u
#define FURNACE_RINGS 16u
/* Standard errors / per-pixel deviations allowed (fixed seeds: a pass is reproducible). */
#define MEAN_SIGMAS 4.0
#define PIXEL_SIGMAS 5.0
/* Float accumulation over a path's bounces and the pixel's samples. */
#define FLOAT_RELATIVE_SLACK 1e-3
/* Tiles for standard errors: 4 px ≥ twice REF_FILTER_RADIUS_PIXELS. */
#define BLOCK 4u

static const ref_region whole = {0, 0, FURNACE_EDGE, FURNACE_EDGE};

/* A furnace of emission `emission` and albedo `albedo`; the camera at eye looks along -z. */
static void furnace_scene(ref_scene *scene, const float emission[3], const float albedo[3],
                          const float eye[3])
{
    ref_scene_init(scene);
    pf_material wall = {{albedo[0], albedo[1], albedo[2]},
                        PF_MATERIAL_LAMBERT,
                        {emission[0], emission[1], emission[2]},
                        1.5f};
    uint32_t material = ref_scene_add_material(scene, wall);
    const float centre[3] = {0, 0, 0};
    ref_scene_add_sphere(scene, centre, 1.0f, FURNACE_SEGMENTS, FURNACE_RINGS, 1, material);
    const float target[3] = {eye[0], eye[1], eye[2] - 1.0f}, up_hint[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up_hint, 1.0f);
}

/* Renders with spp samples and seed; checks the layer invariants and that nothing was discarded. */
static int render(const ref_scene *scene, uint32_t spp, uint64_t seed, pf_image *image,
                  const char *what)
{
    pf_render_settings settings = ref_settings(FURNACE_EDGE, FURNACE_EDGE, spp, seed, 0);
    pf_frame_report report = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &scene->frame, &settings, image, &report, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", what, err.message);
        return 0;
    }
    PF_CHECK_MSG(ref_layer_violations(image, what) == 0, "%s: layer invariants broken", what);
    PF_CHECK_MSG(report.discarded_samples == 0, "%s: %llu samples discarded", what,
                 (unsigned long long)report.discarded_samples);
    return 1;
}

/* Lambert sphere (top left), mirror box (top right), glass slab (bottom), all albedo 1. */
static void add_objects(ref_scene *scene)
{
    uint32_t lambert = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 1, 1, 1));
    uint32_t mirror = ref_scene_add_material(scene, ref_material(PF_MATERIAL_MIRROR, 1, 1, 1));
    uint32_t glass = ref_scene_add_material(scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    const float sphere_centre[3] = {-0.2f, 0.15f, -0.3f};
    ref_scene_add_sphere(scene, sphere_centre, 0.15f, 16, 8, 0, lambert);
    const float mirror_min[3] = {0.05f, 0.02f, -0.45f}, mirror_max[3] = {0.35f, 0.32f, -0.15f};
    ref_scene_add_box(scene, mirror_min, mirror_max, 0, mirror);
    const float glass_min[3] = {-0.3f, -0.35f, -0.25f}, glass_max[3] = {0.3f, -0.05f, -0.2f};
    ref_scene_add_box(scene, glass_min, glass_max, 0, glass);
}

PF_TEST(no_material_creates_energy_in_a_furnace)
{
    const float emission[3] = {1.0f, 0.8f, 0.6f}, albedo[3] = {0.5f, 0.5f, 0.5f};
    const float eye[3] = {0.0f, 0.0f, 0.6f};
    ref_scene scene;
    furnace_scene(&scene, emission, albedo, eye);
    add_objects(&scene);
    pf_image first = {0}, second = {0};
    if (render(&scene, FURNACE_SPP, 201, &first, "furnace with objects") &&
        render(&scene, FURNACE_SPP, 202, &second, "furnace with objects, second seed")) {
        for (int c = 0; c < 3; c++) {
            double bound = emission[c] / (1.0 - albedo[c]);
            /* Noise of the two renders' average, from their difference. */
            double noise = ref_pair_noise(&first, &second, c, whole) / sqrt(2.0);
            uint32_t above = 0;
            double highest = 0.0, sum = 0.0;
            for (uint32_t y = 0; y < FURNACE_EDGE; y++) {
                for (uint32_t x = 0; x < FURNACE_EDGE; x++) {
                    double value =
                        0.5 * (ref_pixel(&first, c, x, y) + ref_pixel(&second, c, x, y));
                    highest = fmax(highest, value);
                    sum += value;
                    above += value > bound * (1.0 + FLOAT_RELATIVE_SLACK) + PIXEL_SIGMAS * noise;
                }
            }
            double mean = sum / (FURNACE_EDGE * FURNACE_EDGE);
            PF_CHECK_MSG(above == 0, "channel %d: %u pixels above Le/(1-a) = %g + %g sigma "
                         "(sigma %.3g, highest %.5g)", c, above, bound, PIXEL_SIGMAS, noise,
                         highest);
            /* The field stays uniform: the image mean converges to the bound. The two
             * renders' pixels are independent; tiles absorb the filter's correlation. */
            ref_stats first_tiles = ref_region_block_stats(&first, c, whole, BLOCK);
            ref_stats second_tiles = ref_region_block_stats(&second, c, whole, BLOCK);
            double standard_error = 0.5 * hypot(first_tiles.standard_error,
                                                second_tiles.standard_error);
            PF_CHECK_NEAR(mean, bound, MEAN_SIGMAS * standard_error + FLOAT_RELATIVE_SLACK * bound);
            printf("  channel %d: mean %.5g ± %.2g, highest %.5g, Le/(1-a) = %.5g, pixel noise "
                   "%.3g\n", c, mean, standard_error, highest, bound, noise);
        }
    }
    pf_image_free(&first);
    pf_image_free(&second);
    ref_scene_free(&scene);
}

PF_TEST(black_enclosure_hides_albedo_one_mirror_and_glass)
{
    const float emission[3] = {1.0f, 2.0f, 3.0f}, albedo[3] = {0, 0, 0};
    const float eye[3] = {0.0f, 0.0f, 0.6f};
    ref_scene scene;
    furnace_scene(&scene, emission, albedo, eye);
    uint32_t mirror = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_MIRROR, 1, 1, 1));
    uint32_t glass = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_GLASS, 1, 1, 1));
    /* A glass slab across the view axis (the centre pixels look through it at
     * normal incidence) and a mirror tilted 30° on the left. */
    const float slab_min[3] = {-0.2f, -0.2f, -0.3f}, slab_max[3] = {0.2f, 0.2f, -0.22f};
    ref_scene_add_box(&scene, slab_min, slab_max, 0, glass);
    const float mirror_centre[3] = {-0.3f, 0.0f, -0.1f}, mirror_u[3] = {0.1299f, 0.0f, -0.075f},
                mirror_v[3] = {0.0f, 0.2f, 0.0f};
    ref_scene_add_quad(&scene, mirror_centre, mirror_u, mirror_v, mirror);
    pf_image first = {0}, second = {0};
    if (render(&scene, BLACK_ENCLOSURE_SPP, 301, &first, "black enclosure") &&
        render(&scene, BLACK_ENCLOSURE_SPP, 302, &second, "black enclosure, second seed")) {
        int alpha = pf_image_channel(&first, "A");
        PF_CHECK(ref_region_stats(&first, alpha, whole).mean == 1.0);
        for (int c = 0; c < 3; c++) {
            double noise = ref_pair_noise(&first, &second, c, whole);
            ref_stats tiles = ref_region_block_stats(&first, c, whole, BLOCK);
            PF_CHECK_NEAR(tiles.mean, emission[c],
                          MEAN_SIGMAS * tiles.standard_error + FLOAT_RELATIVE_SLACK * emission[c]);
            uint32_t off = 0;
            for (uint32_t y = 0; y < FURNACE_EDGE; y++)
                for (uint32_t x = 0; x < FURNACE_EDGE; x++)
                    off += !(fabs(ref_pixel(&first, c, x, y) - emission[c]) <=
                             FLOAT_RELATIVE_SLACK * emission[c] + PIXEL_SIGMAS * noise);
            PF_CHECK_MSG(off == 0, "channel %d: %u pixels differ from Le = %g (noise %.3g)", c,
                         off, emission[c], noise);
            /* Straight through the slab at normal incidence: R + T = 1. */
            double centre = 0.25 * (ref_pixel(&first, c, 15, 15) + ref_pixel(&first, c, 16, 15) +
                                    ref_pixel(&first, c, 15, 16) + ref_pixel(&first, c, 16, 16));
            PF_CHECK_NEAR(centre, emission[c],
                          FLOAT_RELATIVE_SLACK * emission[c] + PIXEL_SIGMAS * noise);
            printf("  channel %d: mean %.6g (Le %g), through the slab %.6g, noise %.3g\n", c,
                   tiles.mean, emission[c], centre, noise);
        }
    }
    pf_image_free(&first);
    pf_image_free(&second);
    ref_scene_free(&scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(no_material_creates_energy_in_a_furnace);
    PF_RUN(black_enclosure_hides_albedo_one_mirror_and_glass);
    return render_test_finish(ctx, renderer);
}
