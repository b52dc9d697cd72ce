/*
 * pf_render_frame (preview) on every shared scene: finite, not black, AOVs
 * present, deterministic per seed; unsupported presets refused. Validation
 * must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "render_test_env.h"

#include <dirent.h>
#include <stdint.h>

#define TEST_WIDTH 40u
#define TEST_HEIGHT 30u

static pf_vk_context *ctx;
static pf_renderer *renderer;

static pf_status render_scene(const char *name, int64_t frame_number, const pf_render_settings *settings,
                              pf_image *image, pf_frame_report *report, uint32_t *triangles,
                              pf_error *err)
{
    char path[1024];
    pf_scene *scene = NULL;
    pf_status status = pf_scene_load(pf_test_shared_scene(name, path, sizeof path), &scene, err);
    if (status != PF_OK)
        return status;
    pf_scene_frame frame = {0};
    status = pf_scene_eval(scene, pf_scene_frame_time(scene, frame_number), &frame, err);
    if (status == PF_OK) {
        *triangles = frame.triangle_count;
        status = pf_render_frame(renderer, &frame, settings, image, report, err);
        pf_scene_frame_free(&frame);
    }
    pf_scene_destroy(scene);
    return status;
}

static void check_scene(const char *name)
{
    pf_render_settings settings = {TEST_WIDTH, TEST_HEIGHT, PF_QUALITY_PREVIEW, 1, 1, 1};
    pf_image image = {0};
    pf_frame_report report = {0};
    pf_error err = {0};
    uint32_t triangles = 0;
    PF_REQUIRE_OK(render_scene(name, 1, &settings, &image, &report, &triangles, &err), &err);
    PF_CHECK(image.width == TEST_WIDTH && image.height == TEST_HEIGHT);
    PF_REQUIRE(image.channel_count == 11);
    const char *aovs[] = {"R", "G", "B", "A", "albedo.R", "albedo.G", "albedo.B",
                          "normal.X", "normal.Y", "normal.Z", "depth.Z"};
    for (size_t i = 0; i < sizeof aovs / sizeof aovs[0]; i++)
        PF_CHECK_MSG(pf_image_channel(&image, aovs[i]) >= 0, "%s: no channel %s", name, aovs[i]);
    int alpha = pf_image_channel(&image, "A");
    int depth = pf_image_channel(&image, "depth.Z");
    double rgb_sum = 0.0;
    uint32_t non_finite = 0, covered = 0, bad_pixels = 0;
    for (size_t p = 0; p < (size_t)image.width * image.height; p++) {
        const float *pixel = image.pixels + p * image.channel_count;
        for (uint32_t c = 0; c < image.channel_count; c++)
            non_finite += !isfinite(pixel[c]);
        rgb_sum += (double)pixel[0] + pixel[1] + pixel[2];
        /* 1 spp: alpha all or nothing, and a depth exactly where it is 1. */
        if (!(pixel[0] >= 0 && pixel[1] >= 0 && pixel[2] >= 0) ||
            !(pixel[alpha] == 0.0f || pixel[alpha] == 1.0f) ||
            (pixel[alpha] > 0) != (pixel[depth] > 0)) {
            if (bad_pixels++ < 3)
                fprintf(stderr, "%s: pixel (%zu, %zu): RGBA %g %g %g %g depth %g\n", name,
                        p % image.width, p / image.width, pixel[0], pixel[1], pixel[2],
                        pixel[alpha], pixel[depth]);
        }
        covered += pixel[alpha] > 0;
    }
    PF_CHECK_MSG(bad_pixels == 0, "%s: %u pixels with negative RGB or inconsistent alpha/depth",
                 name, bad_pixels);
    PF_CHECK_MSG(non_finite == 0, "%s: %u non-finite values", name, non_finite);
    PF_CHECK_MSG(rgb_sum > 0.0, "%s: black image", name);
    PF_CHECK_MSG(covered > 0, "%s: no pixel hit geometry", name);
    PF_REQUIRE(report.stage_count == 3);
    PF_CHECK(!strcmp(report.stages[0].stage, "textures"));
    PF_CHECK(!strcmp(report.stages[1].stage, "bih_build"));
    PF_CHECK(!strcmp(report.stages[2].stage, "shade"));
    PF_CHECK(report.stages[2].wall_ms > 0);
    PF_CHECK(report.discarded_samples == 0);
    double rays = -1, reported_triangles = -1;
    for (uint32_t c = 0; c < report.stages[2].counter_count; c++) {
        if (!strcmp(report.stages[2].counters[c].name, "rays"))
            rays = report.stages[2].counters[c].value;
        if (!strcmp(report.stages[2].counters[c].name, "triangles"))
            reported_triangles = report.stages[2].counters[c].value;
    }
    /* At least one camera ray per pixel. */
    PF_CHECK_MSG(rays >= TEST_WIDTH * TEST_HEIGHT, "%s: %g rays", name, rays);
    PF_CHECK(reported_triangles == triangles);
    printf("  %s: %u triangles, mean RGB %.4g, coverage %u/%u, %.0f ms\n", name, triangles,
           rgb_sum / (3.0 * TEST_WIDTH * TEST_HEIGHT), covered, TEST_WIDTH * TEST_HEIGHT,
           report.stages[2].wall_ms);
    pf_image_free(&image);
}

/* A hand-built scene: the caller fills triangles, materials and lights. */
typedef struct test_scene {
    pf_scene_frame frame;
    float vertices[64][4];
    float normals[64][4];
    uint32_t triangle_material[24];
    pf_material materials[4];
    pf_light lights[2];
} test_scene;

static void add_triangle(test_scene *scene, const float a[3], const float b[3], const float c[3],
                         uint32_t material)
{
    uint32_t t = scene->frame.triangle_count++;
    const float *corners[3] = {a, b, c};
    float e1[3], e2[3], n[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
    }
    n[0] = e1[1] * e2[2] - e1[2] * e2[1];
    n[1] = e1[2] * e2[0] - e1[0] * e2[2];
    n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    float length = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int corner = 0; corner < 3; corner++) {
        for (int k = 0; k < 3; k++) {
            scene->vertices[3 * t + corner][k] = corners[corner][k];
            scene->normals[3 * t + corner][k] = n[k] / length;
            if (corners[corner][k] < scene->frame.bounds_min[k])
                scene->frame.bounds_min[k] = corners[corner][k];
            if (corners[corner][k] > scene->frame.bounds_max[k])
                scene->frame.bounds_max[k] = corners[corner][k];
        }
    }
    scene->triangle_material[t] = material;
    if (scene->materials[material].emission[0] > 0)
        scene->frame.emissive_triangle_count++;
}

/*
 * A 20 m × 20 m Lambert floor (albedo 0.5) at z = 0 facing +z, and a camera
 * at height camera_z looking along -z (or +z from below when camera_z < 0).
 */
static void floor_scene(test_scene *scene, float camera_z)
{
    memset(scene, 0, sizeof *scene);
    scene->frame.vertices = scene->vertices;
    scene->frame.normals = scene->normals;
    scene->frame.triangle_material = scene->triangle_material;
    scene->frame.materials = scene->materials;
    scene->frame.lights = scene->lights;
    scene->frame.material_count = 4;
    scene->materials[0] = (pf_material){{0.5f, 0.5f, 0.5f}, PF_MATERIAL_LAMBERT, {0, 0, 0}, 1.5f};
    float a[3] = {-10, -10, 0}, b[3] = {10, -10, 0}, c[3] = {10, 10, 0}, d[3] = {-10, 10, 0};
    add_triangle(scene, a, b, c, 0);
    add_triangle(scene, a, c, d, 0);
    float direction = camera_z > 0 ? -1.0f : 1.0f;
    scene->frame.camera = (pf_camera){{0, 0, camera_z}, {0, 0, direction}, {0, 1, 0},
                                      {-direction, 0, 0}, 0.5f, 0, 0.01f, 0};
}

/* RGB of the centre pixel of a 3×3 render (its ray runs exactly along the view axis). */
static void render_centre(const test_scene *scene, float rgb[3], float *alpha)
{
    pf_render_settings settings = {3, 3, PF_QUALITY_PREVIEW, 1, 1, 0};
    pf_image image = {0};
    pf_error err = {0};
    rgb[0] = rgb[1] = rgb[2] = -1;
    *alpha = -1;
    PF_REQUIRE_OK(pf_render_frame(renderer, &scene->frame, &settings, &image, NULL, &err), &err);
    const float *pixel = image.pixels + 4 * 4;
    memcpy(rgb, pixel, 3 * sizeof(float));
    *alpha = pixel[3];
    pf_image_free(&image);
}

#define PI_F 3.14159265f
#define RADIANCE_TOLERANCE 1e-4

PF_TEST(direct_light_matches_closed_forms)
{
    test_scene scene;
    float rgb[3], alpha;

    /* Point light 2 m above the hit point: L = albedo/π · I / r². */
    floor_scene(&scene, 5.0f);
    scene.lights[0] = (pf_light){{0, 0, 2}, PF_LIGHT_POINT, {0, 0, -1}, 0, {4, 8, 12}, 1, 1};
    scene.frame.light_count = 1;
    render_centre(&scene, rgb, &alpha);
    for (int k = 0; k < 3; k++)
        PF_CHECK_NEAR(rgb[k], 0.5 / PI_F * (4.0 * (k + 1)) / 4.0, RADIANCE_TOLERANCE);
    PF_CHECK(alpha == 1.0f);

    /* Seen at 45° the same point has the same radiance (Lambert)... */
    scene.frame.camera = (pf_camera){{3, 0, 3}, {-0.70710678f, 0, -0.70710678f},
                                     {-0.70710678f, 0, 0.70710678f}, {0, 1, 0}, 0.5f, 0, 0.01f, 0};
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[0], 0.5 / PI_F * 4.0 / 4.0, RADIANCE_TOLERANCE);
    /* ...and none behind a triangle between it and the light (the view ray passes
     * beside the occluder: at z = 1 it is at x = 1). */
    float o1[3] = {-0.5f, -0.5f, 1}, o2[3] = {0.5f, -0.5f, 1}, o3[3] = {0, 0.5f, 1};
    add_triangle(&scene, o1, o2, o3, 0);
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[0], 0.0, RADIANCE_TOLERANCE);
    PF_CHECK(alpha == 1.0f);

    /* Directional light straight down, 2 W/m²: L = albedo/π · E. */
    floor_scene(&scene, 5.0f);
    scene.lights[0] = (pf_light){{0, 0, 0}, PF_LIGHT_DIRECTIONAL, {0, 0, -1}, 0, {2, 2, 2}, 1, 1};
    scene.frame.light_count = 1;
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[1], 0.5 / PI_F * 2.0, RADIANCE_TOLERANCE);

    /* Spot light: full inside the inner cone, nothing when it points away. */
    scene.lights[0] = (pf_light){{0, 0, 2}, PF_LIGHT_SPOT, {0, 0, -1}, 0, {4, 4, 4},
                                 cosf(0.2f), cosf(0.3f)};
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[2], 0.5 / PI_F, RADIANCE_TOLERANCE);
    scene.lights[0].direction[0] = 1;
    scene.lights[0].direction[2] = 0;
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[2], 0.0, RADIANCE_TOLERANCE);
}

PF_TEST(emissive_triangles_light_from_the_front_only)
{
    test_scene scene;
    float rgb[3], alpha;
    /* A 2 cm² emitter 1 m above the floor, facing down: nearly a point source, so
     * one light sample gives E = Le · A · cos · cos / d² within a percent. */
    floor_scene(&scene, 5.0f);
    scene.materials[1] = (pf_material){{0, 0, 0}, PF_MATERIAL_LAMBERT, {1e4f, 2e4f, 3e4f}, 1.5f};
    float h = 0.01f / sqrtf(2.0f);
    float e1[3] = {-h, -h, 1}, e2[3] = {h, h, 1}, e3[3] = {h, -h, 1}, e4[3] = {-h, h, 1};
    add_triangle(&scene, e1, e2, e3, 1); /* clockwise seen from above: faces down */
    add_triangle(&scene, e1, e4, e2, 1);
    /* Floor point (0.5, 0, 0), beside the emitter: d² = 1.25, both cosines 1/sqrt(1.25). */
    scene.frame.camera.position[0] = 0.5f;
    render_centre(&scene, rgb, &alpha);
    double area = 4.0 * h * h;
    for (int k = 0; k < 3; k++) {
        double expected = 0.5 / PI_F * (1e4 * (k + 1)) * area / (1.25 * 1.25);
        PF_CHECK_NEAR(rgb[k], expected, 0.02 * expected);
    }
    /* Wound the other way the emitter faces up: it lights nothing below it... */
    test_scene flipped;
    floor_scene(&flipped, 5.0f);
    flipped.materials[1] = scene.materials[1];
    add_triangle(&flipped, e1, e3, e2, 1);
    add_triangle(&flipped, e1, e2, e4, 1);
    flipped.frame.camera.position[0] = 0.5f;
    render_centre(&flipped, rgb, &alpha);
    PF_CHECK_NEAR(rgb[0], 0.0, RADIANCE_TOLERANCE);
    /* ...and seen from above, its front face shows the emitted radiance. */
    flipped.frame.camera.position[0] = 0.0f;
    render_centre(&flipped, rgb, &alpha);
    PF_CHECK_NEAR(rgb[0], 1e4, 1.0);
    PF_CHECK_NEAR(rgb[2], 3e4, 3.0);
    /* From above the original emitter shows its back: black, but still covering the pixel. */
    scene.frame.camera.position[0] = 0.0f;
    render_centre(&scene, rgb, &alpha);
    PF_CHECK(rgb[0] == 0.0f && alpha == 1.0f);
}

PF_TEST(mirror_reflects_the_emitter_tinted)
{
    /* Mirror floor (albedo 0.9), an emitter 2 m up facing down, the camera between
     * them looking down: the specular chain reaches the emitter's front face. */
    test_scene scene;
    float rgb[3], alpha;
    floor_scene(&scene, 1.0f);
    scene.materials[0] = pf_material_mirror(0.9f, 0.8f, 0.7f);
    scene.materials[1] = (pf_material){{0, 0, 0}, PF_MATERIAL_LAMBERT, {10, 10, 10}, 1.5f};
    float e1[3] = {-5, -5, 2}, e2[3] = {5, 5, 2}, e3[3] = {5, -5, 2}, e4[3] = {-5, 5, 2};
    add_triangle(&scene, e1, e2, e3, 1);
    add_triangle(&scene, e1, e4, e2, 1);
    render_centre(&scene, rgb, &alpha);
    PF_CHECK_NEAR(rgb[0], 9.0, 1e-4);
    PF_CHECK_NEAR(rgb[1], 8.0, 1e-4);
    PF_CHECK_NEAR(rgb[2], 7.0, 1e-4);
    PF_CHECK(alpha == 1.0f);
}

/* shaders/common/rng.glsl, replicated to rebuild the jittered camera rays. */
static uint32_t pcg_hash(uint32_t value)
{
    uint32_t state = value * 747796405u + 2891336453u;
    uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

static float rng_float(uint32_t *state)
{
    *state = pcg_hash(*state);
    return (float)(*state >> 8) * (1.0f / 16777216.0f);
}

/*
 * The depth AOV is the mean camera-ray hit distance over the samples: rebuild
 * every jittered camera ray on the CPU, cast it with pf_ray_triangle_watertight
 * against every triangle, and compare. Catches a GPU traversal that loses
 * triangles or whole subgroups (lavapipe did, with other shader structures).
 */
static void check_depth_against_cpu(const char *name, int64_t frame_number)
{
    enum { WIDTH = 40, HEIGHT = 30, SPP = 2 };
    const uint64_t seed = 0x123456789ull;
    char path[1024];
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(pf_test_shared_scene(name, path, sizeof path), &scene, &err), &err);
    pf_scene_frame frame = {0};
    PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, frame_number), &frame, &err),
                  &err);
    pf_render_settings settings = {WIDTH, HEIGHT, PF_QUALITY_PREVIEW, SPP, seed, 1};
    /* The box filter: a sample lands at the pixel's corner + its two random numbers. */
    settings.pixel_filter = PF_FILTER_BOX;
    pf_image image = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &settings, &image, NULL, &err), &err);
    int depth = pf_image_channel(&image, "depth.Z");
    PF_REQUIRE(depth >= 0);
    float tan_x, tan_y;
    pf_camera_image_plane(&frame.camera, WIDTH, HEIGHT, &tan_x, &tan_y);
    const pf_camera *camera = &frame.camera;
    uint32_t mismatches = 0;
    for (uint32_t y = 0; y < HEIGHT; y++) {
        for (uint32_t x = 0; x < WIDTH; x++) {
            double sum = 0.0;
            for (uint32_t sample = 0; sample < SPP; sample++) {
                uint32_t state = pcg_hash(
                    (y * WIDTH + x) ^
                    pcg_hash(sample ^ pcg_hash((uint32_t)seed ^ pcg_hash((uint32_t)(seed >> 32)))));
                float jitter_x = rng_float(&state);
                float jitter_y = rng_float(&state);
                float ndc_x = 2.0f * ((float)x + jitter_x) / WIDTH - 1.0f;
                float ndc_y = 1.0f - 2.0f * ((float)y + jitter_y) / HEIGHT;
                float direction[3], length2 = 0.0f;
                for (int k = 0; k < 3; k++) {
                    direction[k] = camera->forward[k] + (ndc_x * tan_x) * camera->right[k] +
                                   (ndc_y * tan_y) * camera->up[k];
                    length2 += direction[k] * direction[k];
                }
                for (int k = 0; k < 3; k++)
                    direction[k] /= sqrtf(length2);
                float closest = INFINITY;
                for (uint32_t t = 0; t < frame.triangle_count; t++) {
                    float hit_t, u, v;
                    if (pf_ray_triangle_watertight(camera->position, direction,
                                                   frame.vertices[3 * t], frame.vertices[3 * t + 1],
                                                   frame.vertices[3 * t + 2], 0.0f, closest,
                                                   &hit_t, &u, &v))
                        closest = hit_t;
                }
                sum += isinf(closest) ? 0.0 : closest;
            }
            double expected = sum / SPP;
            double actual = image.pixels[(y * WIDTH + x) * image.channel_count + depth];
            if (!(fabs(actual - expected) <= 1e-4 * expected + 1e-6) && mismatches++ < 5)
                fprintf(stderr, "%s: pixel (%u, %u) depth %.7g, CPU %.7g\n", name, x, y, actual,
                        expected);
        }
    }
    /* Rays grazing a silhouette may round differently on the GPU: a pixel or two, never a
     * subgroup's row of 8. */
    PF_CHECK_MSG(mismatches <= 2, "%s: %u of %u pixels' depth differ from the CPU", name,
                 mismatches, WIDTH * HEIGHT);
    pf_image_free(&image);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(camera_ray_depth_matches_cpu)
{
    check_depth_against_cpu("caustic-anim", 5);
    check_depth_against_cpu("cornell-anim", 30);
}

PF_TEST(every_shared_scene_renders)
{
    const char *root = getenv("PF_SHARED_SCENES");
    PF_REQUIRE(root != NULL);
    DIR *dir = opendir(root);
    PF_REQUIRE(dir != NULL);
    int scenes = 0;
    struct dirent *entry;
    while ((entry = readdir(dir)) != NULL) {
        if (entry->d_name[0] == '.')
            continue;
        char path[1024];
        FILE *probe = fopen(pf_test_shared_scene(entry->d_name, path, sizeof path), "rb");
        if (!probe)
            continue;
        fclose(probe);
        check_scene(entry->d_name);
        scenes++;
    }
    closedir(dir);
    PF_CHECK_MSG(scenes >= 4, "only %d shared scenes found in %s", scenes, root);
}

PF_TEST(same_seed_same_pixels)
{
    /* Two samples: jittered camera rays and area-light samples depend on the seed. */
    pf_render_settings settings = {32, 24, PF_QUALITY_PREVIEW, 2, 7, 0};
    pf_image first = {0}, second = {0}, other = {0};
    pf_error err = {0};
    uint32_t triangles;
    PF_REQUIRE_OK(render_scene("cornell-box", 1, &settings, &first, NULL, &triangles, &err), &err);
    PF_REQUIRE_OK(render_scene("cornell-box", 1, &settings, &second, NULL, &triangles, &err), &err);
    settings.seed = 8;
    PF_REQUIRE_OK(render_scene("cornell-box", 1, &settings, &other, NULL, &triangles, &err), &err);
    PF_REQUIRE(first.channel_count == 4 && second.channel_count == 4);
    size_t bytes = (size_t)first.width * first.height * first.channel_count * sizeof(float);
    PF_CHECK(!memcmp(first.pixels, second.pixels, bytes));
    PF_CHECK(memcmp(first.pixels, other.pixels, bytes) != 0);
    pf_image_free(&first);
    pf_image_free(&second);
    pf_image_free(&other);
}

PF_TEST(unavailable_presets_and_bad_sizes_are_refused)
{
    pf_scene_frame frame = {0};
    pf_image image = {0};
    pf_error err = {0};
    pf_quality refused[] = {(pf_quality)42};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        pf_render_settings settings = {8, 8, refused[i], 1, 1, 0};
        PF_CHECK(pf_render_frame(renderer, &frame, &settings, &image, NULL, &err) ==
                 PF_ERR_UNSUPPORTED);
        PF_CHECK(strstr(err.message, "not available") != NULL);
        PF_CHECK(image.pixels == NULL);
    }
    pf_render_settings empty = {0, 8, PF_QUALITY_PREVIEW, 1, 1, 0};
    PF_CHECK(pf_render_frame(renderer, &frame, &empty, &image, NULL, &err) == PF_ERR_INVALID);
}

PF_TEST(empty_scene_renders_black_and_transparent)
{
    pf_scene_frame frame = {0};
    frame.camera = (pf_camera){{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, {1, 0, 0}, 0.8f, 0, 0.01f, 0};
    pf_render_settings settings = {16, 8, PF_QUALITY_PREVIEW, 1, 1, 1};
    pf_image image = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &settings, &image, NULL, &err), &err);
    for (size_t i = 0; i < (size_t)16 * 8 * image.channel_count; i++)
        PF_CHECK(image.pixels[i] == 0.0f);
    pf_image_free(&image);
}

/*
 * A renderer builds only the pipelines the frames it renders need: none at
 * creation, and the preset's own at its first frame (issue 12: the test
 * oracles and the other presets' kernels cost nothing in production).
 */
PF_TEST(pipelines_are_made_at_first_use)
{
    pf_error err = {0};
    pf_renderer *fresh = NULL;
    uint32_t before = pf_vk_pipeline_cache_stats(ctx).pipelines;
    PF_REQUIRE_OK(pf_renderer_create(ctx, &fresh, &err), &err);
    PF_CHECK_MSG(pf_vk_pipeline_cache_stats(ctx).pipelines == before,
                 "%u pipelines made by pf_renderer_create",
                 pf_vk_pipeline_cache_stats(ctx).pipelines - before);
    pf_renderer_destroy(fresh);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(pipelines_are_made_at_first_use);
    PF_RUN(direct_light_matches_closed_forms);
    PF_RUN(emissive_triangles_light_from_the_front_only);
    PF_RUN(mirror_reflects_the_emitter_tinted);
    PF_RUN(camera_ray_depth_matches_cpu);
    PF_RUN(every_shared_scene_renders);
    PF_RUN(same_seed_same_pixels);
    PF_RUN(unavailable_presets_and_bad_sizes_are_refused);
    PF_RUN(empty_scene_renders_black_and_transparent);
    return render_test_finish(ctx, renderer);
}
