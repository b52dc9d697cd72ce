/*
 * Temporal stability (issue 12, item 6): two frames of a static room in which
 * only a small block moves, on the right side of the view. On the left third
 * of the image, far from the block, the two frames must differ by less than
 * half the single-frame noise there — the noise measured as the difference
 * between two renders of the first frame with different seeds. A job's
 * frames share the job's seed, so camera samples, photon paths and VPLs that
 * do not meet the block repeat exactly from frame to frame; only light that
 * touched the block may change, which is the change the scene asks for.
 * Checked for fast and final.
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

#define WIDTH 48u
#define HEIGHT 36u

static void build(ref_scene *scene, float block_z)
{
    ref_scene_init(scene);
    uint32_t white = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.7f, 0.7f));
    uint32_t red = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.7f, 0.1f, 0.1f));
    uint32_t lamp = ref_scene_add_material(scene, ref_material_emitter(15, 15, 15));
    const float lo[3] = {-2, 0, -2}, hi[3] = {2, 2, 2};
    ref_scene_add_box(scene, lo, hi, 1, white);
    const float c[3] = {-1.0f, 1.99f, 0}, u[3] = {0.3f, 0, 0}, v[3] = {0, 0, 0.3f};
    ref_scene_add_quad(scene, c, u, v, lamp); /* u × v = -y: facing down */
    /* The moving block: right of the view, 15 cm wide. */
    const float block_lo[3] = {1.5f, 0, block_z}, block_hi[3] = {1.65f, 0.15f, block_z + 0.15f};
    ref_scene_add_box(scene, block_lo, block_hi, 0, red);
    const float eye[3] = {0, 1.0f, 1.9f}, target[3] = {0, 0.6f, 0}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, 1.2f);
}

/* Root mean square difference of R, G, B over the left third. */
static double left_rms(const pf_image *a, const pf_image *b)
{
    double sum = 0.0;
    size_t count = 0;
    for (uint32_t y = 0; y < a->height; y++) {
        for (uint32_t x = 0; x < a->width / 3; x++) {
            for (int c = 0; c < 3; c++) {
                double d = ref_pixel(a, c, x, y) - ref_pixel(b, c, x, y);
                sum += d * d;
                count++;
            }
        }
    }
    return sqrt(sum / (double)count);
}

static void check_preset(pf_quality quality)
{
    const char *name = pf_quality_name(quality);
    ref_scene first, second;
    build(&first, -0.5f);
    build(&second, 0.3f);
    pf_render_settings settings = ref_settings(WIDTH, HEIGHT, 0, 17, 0);
    settings.quality = quality;
    settings.photons_per_pass = quality == PF_QUALITY_FINAL ? 20000 : 0;
    pf_image a = {0}, b = {0}, noise = {0};
    pf_error err = {0};
    if (pf_render_frame(renderer, &first.frame, &settings, &a, NULL, &err) != PF_OK ||
        pf_render_frame(renderer, &second.frame, &settings, &b, NULL, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", name, err.message);
    } else {
        settings.seed = 18;
        if (pf_render_frame(renderer, &first.frame, &settings, &noise, NULL, &err) != PF_OK) {
            PF_CHECK_MSG(0, "%s: %s", name, err.message);
        } else {
            double change = left_rms(&a, &b), single = left_rms(&a, &noise);
            printf("  %s: left third changes by %.5f between frames; single-frame noise %.5f\n",
                   name, change, single);
            PF_CHECK_MSG(single > 0.0, "%s: two seeds gave the same image", name);
            PF_CHECK_MSG(change < 0.5 * single,
                         "%s: the static region flickers (%g between frames, noise %g)", name,
                         change, single);
        }
    }
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&noise);
    ref_scene_free(&first);
    ref_scene_free(&second);
}

PF_TEST(fast_static_region_does_not_flicker) { check_preset(PF_QUALITY_FAST); }
PF_TEST(final_static_region_does_not_flicker) { check_preset(PF_QUALITY_FINAL); }

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(fast_static_region_does_not_flicker);
    PF_RUN(final_static_region_does_not_flicker);
    return render_test_finish(ctx, renderer);
}
