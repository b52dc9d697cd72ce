/*
 * The motion vectors AOV (issue 39) against the projected closed form: a wall
 * at distance Z facing a pinhole camera, then (1) the camera slides sideways,
 * (2) a quad in front of the wall moves right and up. A sideways shift c of
 * the camera moves a point at depth Z by c / (Z tan_x) · W/2 pixels; Cycles'
 * convention stores previous minus current, x right, y up.
 */
#include "pf_test.h"
#include "pf_vk_internal.h" /* pf_vk_force_staging */
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>

#define WIDTH 48u
#define HEIGHT 32u
#define WALL_Z (-4.0f)
#define YFOV 0.8f

static pf_vk_context *ctx;
static pf_renderer *renderer;

/* A grey wall at z = WALL_Z (facing +z), or in its place a grid of tiles × tiles small
 * quads, a quad at z = -2 offset by (dx, dy), lit by a point light; the camera at (cx, 0, 0)
 * looking along -z. */
static void build_tiled(ref_scene *scene, float cx, float dx, float dy, int tiles)
{
    ref_scene_init(scene);
    uint32_t grey = ref_scene_add_material(scene, ref_material(PF_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f));
    const float wall[3] = {0, 0, WALL_Z}, wall_u[3] = {20, 0, 0}, wall_v[3] = {0, 20, 0};
    if (tiles == 0)
        ref_scene_add_quad(scene, wall, wall_u, wall_v, grey);
    for (int t = 0; t < tiles * tiles; t++) {
        const float tile[3] = {-2.0f + 4.0f * (float)(t % tiles) / (float)(tiles - 1),
                               -1.5f + 3.0f * (float)(t / tiles) / (float)(tiles - 1), WALL_Z};
        const float tile_u[3] = {0.2f, 0, 0}, tile_v[3] = {0, 0.2f, 0};
        ref_scene_add_quad(scene, tile, tile_u, tile_v, grey);
    }
    const float quad[3] = {dx, dy, -2.0f}, quad_u[3] = {0.3f, 0, 0}, quad_v[3] = {0, 0.3f, 0};
    ref_scene_add_quad(scene, quad, quad_u, quad_v, grey);
    pf_light light = {.position = {0, 0, 2}, .kind = PF_LIGHT_POINT, .intensity = {5, 5, 5}};
    ref_scene_add_light(scene, light);
    const float eye[3] = {cx, 0, 0}, target[3] = {cx, 0, -1}, up[3] = {0, 1, 0};
    ref_scene_look_at(scene, eye, target, up, YFOV);
}

static void build(ref_scene *scene, float cx, float dx, float dy)
{
    build_tiled(scene, cx, dx, dy, 0);
}

/* Renders `now` (preview, AOVs on) and its motion from `before`. */
static int render_motion_report(const ref_scene *now, const ref_scene *before, pf_image *image,
                                pf_frame_report *report);

static int render_motion(const ref_scene *now, const ref_scene *before, pf_image *image)
{
    pf_frame_report report = {0};
    return render_motion_report(now, before, image, &report);
}

/* A still shot: every vector 0, and nothing traced for it. */
PF_TEST(a_still_shot_reads_zero_without_tracing)
{
    ref_scene scene;
    build(&scene, 0.0f, 0.1f, 0.05f);
    pf_image image = {0};
    pf_frame_report report = {0};
    int mx = render_motion_report(&scene, &scene, &image, &report);
    PF_REQUIRE(mx >= 0);
    size_t nonzero = 0;
    for (uint32_t y = 0; y < HEIGHT; y++)
        for (uint32_t x = 0; x < WIDTH; x++)
            nonzero += ref_pixel(&image, mx, x, y) != 0.0 || ref_pixel(&image, mx + 1, x, y) != 0.0;
    PF_CHECK_MSG(nonzero == 0, "%zu pixels moved in a still shot", nonzero);
    PF_CHECK(ref_stage_counter(&report, "motion", "traced") == 0.0);
    pf_image_free(&image);
    ref_scene_free(&scene);
}

/* preview at WIDTH × HEIGHT, AOVs on. */
static pf_render_settings motion_settings(void)
{
    pf_render_settings settings = pf_render_settings_default();
    settings.quality = PF_QUALITY_PREVIEW;
    settings.width = WIDTH;
    settings.height = HEIGHT;
    return settings;
}

static int render_motion_report(const ref_scene *now, const ref_scene *before, pf_image *image,
                                pf_frame_report *out)
{
    pf_render_settings settings = motion_settings();
    pf_frame_report report = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_render_frame(renderer, &now->frame, &settings, image, &report, &err), &err);
    PF_CHECK_OK(pf_render_motion(renderer, &now->frame, &before->frame, image, NULL, &report, &err),
                &err);
    const pf_stage_timing *row = ref_row(&report, "motion");
    PF_CHECK(row != NULL);
    *out = report;
    return pf_image_channel(image, "motion.X");
}

PF_TEST(a_sliding_camera_moves_the_wall_by_the_closed_form)
{
    /* The camera moves 0.2 m right from the previous frame: the wall's points were further
     * right on the previous film by 0.2 / (4 tan_x) · W/2. */
    ref_scene before, now;
    build(&before, 0.0f, 100.0f, 0.0f); /* the quad far out of view */
    build(&now, 0.2f, 100.0f, 0.0f);
    pf_image image = {0};
    pf_frame_report report = {0};
    int mx = render_motion_report(&now, &before, &image, &report);
    PF_REQUIRE(mx >= 0);
    double tan_y = tan(0.5 * YFOV), tan_x = tan_y * WIDTH / HEIGHT;
    double expected = 0.2 / (4.0 * tan_x) * WIDTH / 2.0;
    int checked = 0;
    for (uint32_t y = 0; y < HEIGHT; y += 3)
        for (uint32_t x = 0; x < WIDTH; x += 3) {
            PF_CHECK_NEAR(ref_pixel(&image, mx, x, y), expected, 1e-3);
            PF_CHECK_NEAR(ref_pixel(&image, mx + 1, x, y), 0.0, 1e-3);
            checked++;
        }
    PF_CHECK(checked > 100);
    PF_CHECK(ref_stage_counter(&report, "motion", "traced") == 1.0);
    pf_image_free(&image);
    ref_scene_free(&before);
    ref_scene_free(&now);
}

PF_TEST(a_moving_object_moves_by_the_closed_form_and_the_still_wall_reads_zero)
{
    /* The quad at z = -2 moves 0.1 m right and 0.05 m up: on its pixels the previous point
     * was 0.1 / (2 tan_x) · W/2 px left and 0.05 / (2 tan_y) · H/2 px lower (y up). */
    ref_scene before, now;
    build(&before, 0.0f, 0.0f, 0.0f);
    build(&now, 0.0f, 0.1f, 0.05f);
    pf_image image = {0};
    int mx = render_motion(&now, &before, &image);
    PF_REQUIRE(mx >= 0);
    double tan_y = tan(0.5 * YFOV), tan_x = tan_y * WIDTH / HEIGHT;
    double expected_x = -0.1 / (2.0 * tan_x) * WIDTH / 2.0;
    double expected_y = -0.05 / (2.0 * tan_y) * HEIGHT / 2.0;
    /* The quad's centre (0.1, 0.05, -2) projects to this pixel. */
    uint32_t cx = (uint32_t)((0.1 / (2.0 * tan_x) + 1.0) * 0.5 * WIDTH);
    uint32_t cy = (uint32_t)((1.0 - 0.05 / (2.0 * tan_y)) * 0.5 * HEIGHT);
    PF_CHECK_NEAR(ref_pixel(&image, mx, cx, cy), expected_x, 1e-3);
    PF_CHECK_NEAR(ref_pixel(&image, mx + 1, cx, cy), expected_y, 1e-3);
    /* The wall did not move and neither did the camera: exactly 0 in the corners. */
    PF_CHECK(ref_pixel(&image, mx, 0, 0) == 0.0 && ref_pixel(&image, mx + 1, 0, 0) == 0.0);
    PF_CHECK(ref_pixel(&image, mx, WIDTH - 1, HEIGHT - 1) == 0.0);
    pf_image_free(&image);
    ref_scene_free(&before);
    ref_scene_free(&now);
}

/*
 * Under an orthographic camera (ymag 1: the view 2 m wide, its longer side) a sliding camera
 * moves every point by the same pixels, near or far: 0.2 m right is 0.2 / 2 · W px, on the
 * wall 5 m away as on the quad 2 m away (a pinhole's would differ by 2.5×).
 */
PF_TEST(an_orthographic_camera_moves_near_and_far_alike)
{
    ref_scene before, now;
    build(&before, 0.0f, 0.0f, 0.0f);
    build(&now, 0.2f, 0.2f, 0.0f); /* the quad moves with the camera: it reads 0 */
    for (int k = 0; k < 2; k++) {
        ref_scene *scene = k == 0 ? &before : &now;
        scene->frame.camera.orthographic = 1;
        scene->frame.camera.ymag = 1.0f;
    }
    pf_image image = {0};
    int mx = render_motion(&now, &before, &image);
    PF_REQUIRE(mx >= 0);
    double half_x = 1.0; /* ymag spans the longer side, the width */
    double expected = 0.2 / (2.0 * half_x) * WIDTH;
    /* The wall in a corner, the quad (0.6 m wide about the view's centre) in the middle. */
    PF_CHECK_NEAR(ref_pixel(&image, mx, 1, 1), expected, 1e-3);
    PF_CHECK_NEAR(ref_pixel(&image, mx + 1, 1, 1), 0.0, 1e-3);
    PF_CHECK_NEAR(ref_pixel(&image, mx, WIDTH / 2, HEIGHT / 2), 0.0, 1e-3);
    pf_image_free(&image);
    ref_scene_free(&before);
    ref_scene_free(&now);
}

/*
 * A renderer that builds and refits its tree on the device (issue 44) traces the motion
 * through the host's copy, whose clip values the device refit left for it to fit: the same
 * vectors, bit for bit, as a renderer whose host refit the tree. Small tiles instead of
 * the wall, whose triangles would span every node's clip planes: an unfitted clip cuts
 * the moved quad's new edge away (the test fails so when pf_renderer_bih_host skips the
 * fit).
 */
PF_TEST(a_tree_refit_on_the_device_traces_the_same_motion)
{
    ref_scene before, now;
    build_tiled(&before, 0.0f, 0.0f, 0.0f, 4);
    build_tiled(&now, 0.0f, 0.3f, 0.2f, 4);
    const pf_bih_build_site sites[2] = {PF_BIH_BUILD_CPU, PF_BIH_BUILD_GPU};
    pf_image images[2] = {{0}};
    int channel[2] = {-1, -1};
    for (int s = 0; s < 2; s++) {
        pf_renderer *own = NULL;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_renderer_create(ctx, &own, &err), &err);
        pf_renderer_set_bih_build(own, sites[s]);
        pf_render_settings settings = motion_settings();
        pf_image first = {0};
        pf_frame_report report = {0};
        PF_CHECK_OK(pf_render_frame(own, &before.frame, &settings, &first, &report, &err), &err);
        pf_image_free(&first);
        report = (pf_frame_report){0};
        PF_CHECK_OK(pf_render_frame(own, &now.frame, &settings, &images[s], &report, &err),
                    &err);
        PF_CHECK_MSG(ref_stage_counter(&report, "bih_build", "decision") == 1.0 &&
                         ref_stage_counter(&report, "bih_build", "refit_on_gpu") == (double)s,
                     "site %d: decision %g (%s), refit on the GPU %g", s,
                     ref_stage_counter(&report, "bih_build", "decision"),
                     ref_row(&report, "bih_build") ? ref_row(&report, "bih_build")->reason : "",
                     ref_stage_counter(&report, "bih_build", "refit_on_gpu"));
        PF_CHECK_OK(pf_render_motion(own, &now.frame, &before.frame, &images[s], NULL, &report,
                                     &err),
                    &err);
        channel[s] = pf_image_channel(&images[s], "motion.X");
        pf_renderer_destroy(own);
    }
    PF_REQUIRE(channel[0] >= 0 && channel[0] == channel[1]);
    size_t differ = 0, moving = 0;
    for (uint32_t y = 0; y < HEIGHT; y++)
        for (uint32_t x = 0; x < WIDTH; x++)
            for (int k = 0; k < 2; k++) {
                double a = ref_pixel(&images[0], channel[0] + k, x, y);
                differ += a != ref_pixel(&images[1], channel[1] + k, x, y);
                moving += k == 0 && a != 0.0;
            }
    PF_CHECK_MSG(differ == 0 && moving > 0, "%zu motion values differ (%zu pixels move)", differ,
                 moving);
    pf_image_free(&images[0]);
    pf_image_free(&images[1]);
    ref_scene_free(&before);
    ref_scene_free(&now);
}

/*
 * pf_frame_render computes the vectors while the device renders the frame's last submission
 * (the one that reads its film back); a tree kept on the device (the GPU build) is fetched
 * to the host in the overlap's prepare phase, just before that submission, so no wait
 * queues behind it (pf_vk_waits_behind). For a tree built on the CPU and one kept on the
 * device, the vectors in the file equal those pf_render_motion traces afterwards through
 * the same renderer's tree, bit for bit, and the rows say they were computed during the
 * device's work.
 */
PF_TEST(vectors_computed_during_the_last_submission_match_those_after_it)
{
    char path[1024];
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(ref_load_project_scene("scenes/cornell-moving/cornell-moving.gltf", path,
                                         sizeof path, &scene, &err),
                  &err);
    char dir[1024];
    pf_test_tmpdir(dir, sizeof dir);
    /* As on a GPU, every copy a submission (lavapipe reads its mapped memory without one). */
    pf_vk_force_staging(ctx, 1);
    const pf_bih_build_site sites[2] = {PF_BIH_BUILD_CPU, PF_BIH_BUILD_GPU};
    for (int s = 0; s < 2; s++) {
        pf_renderer *own = NULL;
        PF_REQUIRE_OK(pf_renderer_create(ctx, &own, &err), &err);
        pf_renderer_set_bih_build(own, sites[s]);
        char output[1200];
        snprintf(output, sizeof output, "%s/overlap-%d.exr", dir, s);
        pf_render_settings settings = pf_render_settings_default();
        settings.width = WIDTH;
        settings.height = HEIGHT;
        settings.quality = PF_QUALITY_REFERENCE;
        settings.samples_per_pixel = 1;
        settings.seed = 1;
        settings.float_pixels = 1;
        settings.denoise = PF_DENOISE_OFF;
        pf_frame_request request = {scene, path, 2, settings, output, "t", "test", NULL, 0, 0};
        pf_frame_output out;
        uint64_t behind = pf_vk_waits_behind(ctx);
        PF_REQUIRE_OK(pf_frame_render(own, &request, &out, &err), &err);
        /* Nothing the vectors needed waited behind the submission they overlapped: the
         * device-kept tree came to the host before it. */
        PF_CHECK_MSG(pf_vk_waits_behind(ctx) == behind, "site %d: %llu waits behind in-flight work",
                     s, (unsigned long long)(pf_vk_waits_behind(ctx) - behind));
        PF_CHECK_MSG(ref_stage_counter(&out.report, "motion", "overlapped") == 1.0 &&
                         ref_stage_counter(&out.report, "shade", "overlap_ms") > 0.0 &&
                         ref_stage_counter(&out.report, "bih_build", "built_on_gpu") == (double)s,
                     "site %d: overlapped %g, overlap_ms %g, built on the GPU %g", s,
                     ref_stage_counter(&out.report, "motion", "overlapped"),
                     ref_stage_counter(&out.report, "shade", "overlap_ms"),
                     ref_stage_counter(&out.report, "bih_build", "built_on_gpu"));
        pf_image written = {0};
        PF_CHECK_OK(pf_exr_read(out.temp_path, &written, NULL, NULL, &err), &err);
        /* The same frame and the one before it, traced again through the renderer's tree. */
        double time = pf_scene_frame_time(scene, 2);
        pf_scene_frame now, before;
        PF_REQUIRE_OK(pf_scene_eval(scene, time, &now, &err), &err);
        PF_REQUIRE_OK(pf_scene_eval(scene, time - 1.0 / pf_scene_get_info(scene)->fps, &before,
                                    &err),
                      &err);
        static const char *const beauty[1] = {"R"};
        pf_image traced = {0};
        PF_REQUIRE_OK(pf_image_create(&traced, WIDTH, HEIGHT, 1, beauty, &err), &err);
        PF_CHECK_OK(pf_render_motion(own, &now, &before, &traced, NULL, NULL, &err), &err);
        size_t differ = 0, moving = 0;
        for (int k = 0; k < 2; k++) {
            const char *name = k ? "motion.Y" : "motion.X";
            int a = pf_image_channel(&written, name), b = pf_image_channel(&traced, name);
            PF_REQUIRE(a >= 0 && b >= 0);
            for (uint32_t y = 0; y < HEIGHT; y++)
                for (uint32_t x = 0; x < WIDTH; x++) {
                    double value = ref_pixel(&written, a, x, y);
                    differ += value != ref_pixel(&traced, b, x, y);
                    moving += value != 0.0;
                }
        }
        PF_CHECK_MSG(differ == 0 && moving > 0, "site %d: %zu motion values differ (%zu move)",
                     s, differ, moving);
        pf_image_free(&written);
        pf_image_free(&traced);
        pf_scene_frame_free(&now);
        pf_scene_frame_free(&before);
        pf_frame_discard(&out);
        pf_renderer_destroy(own);
    }
    pf_vk_force_staging(ctx, 0);
    pf_scene_destroy(scene);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(a_still_shot_reads_zero_without_tracing);
    PF_RUN(a_sliding_camera_moves_the_wall_by_the_closed_form);
    PF_RUN(a_moving_object_moves_by_the_closed_form_and_the_still_wall_reads_zero);
    PF_RUN(an_orthographic_camera_moves_near_and_far_alike);
    PF_RUN(a_tree_refit_on_the_device_traces_the_same_motion);
    PF_RUN(vectors_computed_during_the_last_submission_match_those_after_it);
    return render_test_finish(ctx, renderer);
}
