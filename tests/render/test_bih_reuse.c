/*
 * The bih_build stage's frame reuse (core/render/frame_bih.c): unchanged
 * geometry → the tree is reused and the row skipped; small motion → refit;
 * a refit image is bit-identical to a fresh renderer's (closest hits do not
 * depend on the tree); scattered geometry → rebuilt; a changed triangle count
 * or another scene with the same count → never reused. Checked on
 * scenes/cornell-moving and on hand-built frames, with CPU and GPU builds.
 * Validation must stay silent.
 */
#include "../vk/vk_test_util.h"
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The bih_build row's `decision` counter (core/render/frame_bih.c). */
enum { DECISION_REUSED = 0, DECISION_REFIT = 1, DECISION_REBUILT = 2, DECISION_BUILT = 3 };
static const char *decision_prefix[] = {"geometry unchanged", "refit:", "rebuilt:", "built:"};

#define IMAGE_WIDTH 32u
#define IMAGE_HEIGHT 24u
/* The refit yardstick of frame_bih.c (issue 3, item 4). */
#define REFIT_SAH_TOLERANCE 1.10

static pf_vk_context *ctx;
/* The build site the renderers of the current test are forced to (AUTO: none). */
static pf_bih_build_site forced_build = PF_BIH_BUILD_AUTO;

static double counter(const pf_stage_timing *row, const char *name)
{
    for (uint32_t i = 0; i < row->counter_count; i++)
        if (!strcmp(row->counters[i].name, name))
            return row->counters[i].value;
    return -1.0;
}

static const pf_stage_timing *bih_row(const pf_frame_report *report)
{
    for (uint32_t i = 0; i < report->stage_count; i++)
        if (!strcmp(report->stages[i].stage, "bih_build"))
            return &report->stages[i];
    return NULL;
}

typedef struct rendered {
    int decision;
    int skipped;
    int refit_on_gpu;
    double sah;
    char reason[PF_STAGE_REASON_MAX];
} rendered;

/* Renders frame with renderer; returns the bih_build decision (-1 on failure). */
static rendered render(pf_renderer *renderer, const pf_scene_frame *frame, pf_image *image)
{
    pf_render_settings settings = {IMAGE_WIDTH, IMAGE_HEIGHT, PF_QUALITY_PREVIEW, 1, 7, 1};
    pf_frame_report report = {0};
    pf_error err = {0};
    rendered result = {-1, -1, -1, -1.0, ""};
    PF_CHECK_OK(pf_render_frame(renderer, frame, &settings, image, &report, &err), &err);
    const pf_stage_timing *row = bih_row(&report);
    PF_CHECK(row != NULL);
    if (err.status != PF_OK || !row)
        return result;
    result.decision = (int)counter(row, "decision");
    result.skipped = row->skipped;
    result.refit_on_gpu = (int)counter(row, "refit_on_gpu");
    result.sah = counter(row, "sah");
    snprintf(result.reason, sizeof result.reason, "%s", row->reason);
    PF_CHECK(counter(row, "triangles") == frame->triangle_count);
    if (result.decision >= DECISION_REUSED && result.decision <= DECISION_BUILT)
        PF_CHECK_MSG(!strncmp(row->reason, decision_prefix[result.decision],
                              strlen(decision_prefix[result.decision])),
                     "decision %d with reason '%s'", result.decision, row->reason);
    else
        PF_CHECK_MSG(0, "decision counter %g", counter(row, "decision"));
    PF_CHECK_MSG(row->skipped == (result.decision == DECISION_REUSED), "skipped %d, reason '%s'",
                 row->skipped, row->reason);
    return result;
}

static int same_image(const pf_image *a, const pf_image *b)
{
    return a->width == b->width && a->height == b->height && a->channel_count == b->channel_count &&
           a->pixels && b->pixels &&
           !memcmp(a->pixels, b->pixels,
                   (size_t)a->width * a->height * a->channel_count * sizeof *a->pixels);
}

/*
 * image must equal what a renderer that never saw another frame renders (a
 * fresh build); prints the SAH of that fresh build beside the decision's.
 */
static void check_matches_fresh_renderer(const char *label, const pf_scene_frame *frame,
                                         const pf_image *image, const rendered *result)
{
    pf_renderer *fresh = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_renderer_create(ctx, &fresh, &err), &err);
    pf_renderer_set_bih_build(fresh, forced_build);
    pf_image expected = {0};
    rendered first = render(fresh, frame, &expected);
    PF_CHECK(first.decision == DECISION_BUILT);
    PF_CHECK_MSG(same_image(image, &expected), "%s: image differs from a fresh renderer's", label);
    printf("  %s: %s (fresh build's SAH %.2f)\n", label, result->reason, first.sah);
    pf_image_free(&expected);
    pf_renderer_destroy(fresh);
}

static int same_vertices(const pf_scene_frame *a, const pf_scene_frame *b)
{
    return a->triangle_count == b->triangle_count &&
           !memcmp(a->vertices, b->vertices, 3 * (size_t)a->triangle_count * sizeof *a->vertices);
}

PF_TEST(cornell_moving_reuses_refits_and_matches_fresh_builds)
{
    char path[1024];
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(ref_load_project_scene("scenes/cornell-moving/cornell-moving.gltf", path,
                                         sizeof path, &scene, &err),
                  &err);
    uint32_t frame_count = pf_scene_get_info(scene)->frame_count;
    PF_CHECK(pf_scene_get_info(scene)->geometry_animated);
    pf_renderer *renderer = NULL;
    PF_REQUIRE_OK(pf_renderer_create(ctx, &renderer, &err), &err);
    pf_scene_frame previous = {0};
    uint32_t counts[4] = {0, 0, 0, 0}, fresh_checks = 0;
    double fresh_sah = -1.0;
    /* Every frame, then the last one again: a re-render of a frame is a static frame. */
    for (uint32_t i = 0; i <= frame_count; i++) {
        int64_t number = i < frame_count ? (int64_t)i : (int64_t)frame_count - 1;
        pf_scene_frame frame = {0};
        PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, number), &frame, &err), &err);
        pf_image image = {0};
        rendered result = render(renderer, &frame, &image);
        char label[64];
        snprintf(label, sizeof label, "cornell-moving frame %lld", (long long)number);
        if (i == 0) {
            PF_CHECK_MSG(result.decision == DECISION_BUILT &&
                             !strcmp(result.reason, "built: first frame"),
                         "%s: %s", label, result.reason);
        } else if (same_vertices(&frame, &previous)) {
            PF_CHECK_MSG(result.decision == DECISION_REUSED, "%s: %s", label, result.reason);
            PF_CHECK(!strcmp(result.reason, "geometry unchanged → BIH reused"));
        } else {
            /* The moving block keeps its triangles: refit, or rebuilt when the SAH says so. */
            PF_CHECK_MSG(result.decision == DECISION_REFIT || result.decision == DECISION_REBUILT,
                         "%s: %s", label, result.reason);
            if (result.decision == DECISION_REFIT)
                PF_CHECK_MSG(result.sah <= REFIT_SAH_TOLERANCE * fresh_sah,
                             "%s: refit SAH %g kept against %g", label, result.sah, fresh_sah);
        }
        if (result.decision == DECISION_BUILT || result.decision == DECISION_REBUILT)
            fresh_sah = result.sah;
        if (result.decision >= 0 && result.decision <= DECISION_BUILT)
            counts[result.decision]++;
        /* The first refit, one in the middle and the last frame against fresh builds. */
        if (result.decision == DECISION_REFIT &&
            (counts[DECISION_REFIT] == 1 || i == frame_count / 2 || i == frame_count - 1)) {
            check_matches_fresh_renderer(label, &frame, &image, &result);
            fresh_checks++;
        }
        pf_image_free(&image);
        pf_scene_frame_free(&previous);
        previous = frame;
    }
    pf_scene_frame_free(&previous);
    printf("  cornell-moving, %u frames + 1 repeat: %u reused, %u refit, %u rebuilt, %u built\n",
           frame_count, counts[DECISION_REUSED], counts[DECISION_REFIT], counts[DECISION_REBUILT],
           counts[DECISION_BUILT]);
    PF_CHECK(counts[DECISION_BUILT] == 1);
    PF_CHECK(counts[DECISION_REUSED] >= 1);
    /* The block moves a few centimetres a frame: far below what would spoil the tree. */
    PF_CHECK_MSG(counts[DECISION_REFIT] >= frame_count / 2, "%u refits", counts[DECISION_REFIT]);
    PF_CHECK(fresh_checks >= 1);
    pf_renderer_destroy(renderer);
    pf_scene_destroy(scene);
}

/*
 * A hand-built frame: a floor and a grid of small cubes (12 triangles each),
 * a point light, a camera looking down at them.
 */
#define GRID 4
#define CUBE_TRIANGLES 12
#define MAX_TRIANGLES (2 + GRID * GRID * CUBE_TRIANGLES)

typedef struct hand_frame {
    pf_scene_frame frame;
    float vertices[3 * MAX_TRIANGLES][4];
    float normals[3 * MAX_TRIANGLES][4];
    uint32_t triangle_material[MAX_TRIANGLES];
    pf_material materials[2];
    pf_light light;
} hand_frame;

static void add_triangle(hand_frame *scene, const float a[3], const float b[3], const float c[3],
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
    for (int corner = 0; corner < 3; corner++)
        for (int k = 0; k < 3; k++) {
            scene->vertices[3 * t + corner][k] = corners[corner][k];
            scene->normals[3 * t + corner][k] = length > 0 ? n[k] / length : 0.0f;
        }
    scene->triangle_material[t] = material;
}

static void add_cube(hand_frame *scene, const float centre[3], float half)
{
    /* Each face: the quad of the corners whose coordinate along axis is side. */
    for (int axis = 0; axis < 3; axis++)
        for (int side = -1; side <= 1; side += 2) {
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            float p[4][3];
            for (int c = 0; c < 4; c++) {
                p[c][axis] = centre[axis] + side * half;
                p[c][u] = centre[u] + ((c == 1 || c == 2) ? half : -half);
                p[c][v] = centre[v] + (c >= 2 ? half : -half);
            }
            add_triangle(scene, p[0], p[1], p[2], 1);
            add_triangle(scene, p[0], p[2], p[3], 1);
        }
}

static void update_bounds(pf_scene_frame *frame)
{
    for (int k = 0; k < 3; k++) {
        frame->bounds_min[k] = INFINITY;
        frame->bounds_max[k] = -INFINITY;
    }
    for (uint32_t i = 0; i < 3 * frame->triangle_count; i++)
        for (int k = 0; k < 3; k++) {
            frame->bounds_min[k] = fminf(frame->bounds_min[k], frame->vertices[i][k]);
            frame->bounds_max[k] = fmaxf(frame->bounds_max[k], frame->vertices[i][k]);
        }
}

/* cubes of the GRID × GRID grid (in order), spaced by spacing, lifted by lift. */
static void make_hand_frame(hand_frame *scene, uint32_t cubes, float spacing, float lift)
{
    memset(scene, 0, sizeof *scene);
    pf_scene_frame *frame = &scene->frame;
    frame->vertices = scene->vertices;
    frame->normals = scene->normals;
    frame->triangle_material = scene->triangle_material;
    frame->materials = scene->materials;
    frame->material_count = 2;
    frame->lights = &scene->light;
    frame->light_count = 1;
    scene->materials[0] = (pf_material){{0.5f, 0.5f, 0.5f}, PF_MATERIAL_LAMBERT, {0, 0, 0}, 1.5f};
    scene->materials[1] = (pf_material){{0.8f, 0.3f, 0.2f}, PF_MATERIAL_LAMBERT, {0, 0, 0}, 1.5f};
    scene->light = (pf_light){{0.3f, 0.2f, 4}, PF_LIGHT_POINT, {0, 0, -1}, 0, {20, 20, 20}, 1, 1};
    float a[3] = {-4, -4, 0}, b[3] = {4, -4, 0}, c[3] = {4, 4, 0}, d[3] = {-4, 4, 0};
    add_triangle(scene, a, b, c, 0);
    add_triangle(scene, a, c, d, 0);
    for (uint32_t i = 0; i < cubes; i++) {
        float centre[3] = {((float)(i % GRID) - 1.5f) * spacing,
                           ((float)(i / GRID) - 1.5f) * spacing, 0.3f + lift};
        add_cube(scene, centre, 0.25f);
    }
    frame->camera = (pf_camera){{0, -1, 6}, {0, 0.164399f, -0.986394f}, {0, 0.986394f, 0.164399f},
                                {1, 0, 0}, 0.9f, 0, 0.01f, 0};
    update_bounds(frame);
}

/*
 * Tears the cubes apart: every cube triangle moves rigidly by its own random
 * offset of up to reach metres along x and y, so a leaf's triangles, once
 * neighbours, end up far apart.
 */
static void scatter(hand_frame *scene, float reach)
{
    pf_scene_frame *frame = &scene->frame;
    uint32_t state = 12345;
    for (uint32_t t = 2; t < frame->triangle_count; t++) {
        float offset[2];
        for (int k = 0; k < 2; k++) {
            state = state * 1664525u + 1013904223u; /* Numerical Recipes LCG */
            offset[k] = reach * ((float)(state >> 8) / 8388608.0f - 1.0f);
        }
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 2; k++)
                frame->vertices[3 * t + c][k] += offset[k];
    }
    update_bounds(frame);
}

static void hand_built_sequence(const char *build_site)
{
    forced_build = !strcmp(build_site, "gpu") ? PF_BIH_BUILD_GPU : PF_BIH_BUILD_CPU;
    pf_renderer *renderer = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_renderer_create(ctx, &renderer, &err), &err);
    pf_renderer_set_bih_build(renderer, forced_build);
    hand_frame *scene = malloc(sizeof *scene), *other = malloc(sizeof *other);
    PF_REQUIRE(scene && other);
    pf_image image = {0};
    rendered result;

    make_hand_frame(scene, GRID * GRID, 1.0f, 0.0f);
    result = render(renderer, &scene->frame, &image);
    PF_CHECK_MSG(result.decision == DECISION_BUILT && !strcmp(result.reason, "built: first frame"),
                 "%s: first frame: %s", build_site, result.reason);
    pf_image first_image = image;
    memset(&image, 0, sizeof image);

    /* The same triangles again, from freshly written arrays: reused, same image. */
    make_hand_frame(other, GRID * GRID, 1.0f, 0.0f);
    result = render(renderer, &other->frame, &image);
    PF_CHECK_MSG(result.decision == DECISION_REUSED && result.skipped == 1 &&
                     !strcmp(result.reason, "geometry unchanged → BIH reused"),
                 "%s: static frame: %s", build_site, result.reason);
    PF_CHECK(same_image(&image, &first_image));
    pf_image_free(&image);
    pf_image_free(&first_image);

    /* Small rigid motion (the cubes rise 5 cm): refit, and exactly a fresh build's image. */
    make_hand_frame(scene, GRID * GRID, 1.0f, 0.05f);
    result = render(renderer, &scene->frame, &image);
    PF_CHECK_MSG(result.decision == DECISION_REFIT, "%s: small motion: %s", build_site,
                 result.reason);
    /* A refit runs where a build would (issue 44: on the device, the tree not read back). */
    PF_CHECK_MSG(result.refit_on_gpu == (forced_build == PF_BIH_BUILD_GPU),
                 "%s: refit on the GPU %d", build_site, result.refit_on_gpu);
    check_matches_fresh_renderer("hand-built, refit", &scene->frame, &image, &result);
    pf_image refit_image = image;
    memset(&image, 0, sizeof image);
    /* The refit frame again: the host's copy holds its triangles, wherever it was fit. */
    result = render(renderer, &scene->frame, &image);
    PF_CHECK_MSG(result.decision == DECISION_REUSED, "%s: refit frame again: %s", build_site,
                 result.reason);
    PF_CHECK(same_image(&image, &refit_image));
    pf_image_free(&refit_image);
    pf_image_free(&image);

    /* Scattered triangles: the refit tree's SAH is far off, so it is rebuilt; within the
     * floor, and far beyond it (the scene box about 3× wider). */
    const float reaches[] = {3.0f, 12.0f};
    for (int i = 0; i < 2; i++) {
        make_hand_frame(scene, GRID * GRID, 1.0f, 0.0f);
        result = render(renderer, &scene->frame, &image);
        pf_image_free(&image);
        scatter(scene, reaches[i]);
        result = render(renderer, &scene->frame, &image);
        PF_CHECK_MSG(result.decision == DECISION_REBUILT, "%s: scattered %g m: %s", build_site,
                     reaches[i], result.reason);
        check_matches_fresh_renderer(i == 0 ? "hand-built, scattered 3 m"
                                            : "hand-built, scattered 12 m",
                                     &scene->frame, &image, &result);
        pf_image_free(&image);
    }

    /* One cube fewer: a different triangle count is always a fresh build. */
    make_hand_frame(scene, GRID * GRID - 1, 1.0f, 0.0f);
    result = render(renderer, &scene->frame, &image);
    PF_CHECK_MSG(result.decision == DECISION_BUILT &&
                     strstr(result.reason, "triangle count changed") != NULL,
                 "%s: fewer triangles: %s", build_site, result.reason);
    pf_image_free(&image);

    /* Another scene with the same triangle count (the cubes spread wider), as when a
     * worker switches jobs: not reused, and its image is its own. */
    make_hand_frame(other, GRID * GRID - 1, 1.6f, 0.0f);
    result = render(renderer, &other->frame, &image);
    PF_CHECK_MSG(result.decision != DECISION_REUSED, "%s: other scene: %s", build_site,
                 result.reason);
    check_matches_fresh_renderer("hand-built, other scene", &other->frame, &image,
                                 &result);
    pf_image_free(&image);

    pf_renderer_destroy(renderer);
    free(scene);
    free(other);
    forced_build = PF_BIH_BUILD_AUTO;
}

/*
 * A tree built on the device keeps its nodes there (issue 44); a renderer told to build on
 * the CPU from then on refits it on the host, which first fetches the nodes: the refit
 * frame's image is a fresh CPU-built renderer's. And back: the host's refit tree, uploaded,
 * refits on the device.
 */
PF_TEST(a_tree_kept_on_the_device_refits_on_the_host_when_the_site_changes)
{
    pf_renderer *renderer = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_renderer_create(ctx, &renderer, &err), &err);
    hand_frame *scene = malloc(sizeof *scene);
    PF_REQUIRE(scene);
    pf_image image = {0};
    const pf_bih_build_site sites[3] = {PF_BIH_BUILD_GPU, PF_BIH_BUILD_CPU, PF_BIH_BUILD_GPU};
    for (int step = 0; step < 3; step++) {
        forced_build = sites[step];
        pf_renderer_set_bih_build(renderer, forced_build);
        make_hand_frame(scene, GRID * GRID, 1.0f, 0.02f * (float)step);
        rendered result = render(renderer, &scene->frame, &image);
        PF_CHECK_MSG(result.decision == (step == 0 ? DECISION_BUILT : DECISION_REFIT) &&
                         result.refit_on_gpu == (step == 2),
                     "step %d: %s, refit on the GPU %d", step, result.reason,
                     result.refit_on_gpu);
        if (step > 0)
            check_matches_fresh_renderer(step == 1 ? "device tree refit on the host"
                                                   : "host tree refit on the device",
                                         &scene->frame, &image, &result);
        pf_image_free(&image);
    }
    forced_build = PF_BIH_BUILD_AUTO;
    pf_renderer_destroy(renderer);
    free(scene);
}

PF_TEST(hand_built_frames_with_cpu_builds)
{
    hand_built_sequence("cpu");
}

PF_TEST(hand_built_frames_with_gpu_builds)
{
    hand_built_sequence("gpu");
}

int main(void)
{
    pf_error err = {0};
    ctx = vk_test_context(&err);
    if (!ctx)
        return 1;
    PF_RUN(cornell_moving_reuses_refits_and_matches_fresh_builds);
    PF_RUN(hand_built_frames_with_cpu_builds);
    PF_RUN(hand_built_frames_with_gpu_builds);
    PF_RUN(a_tree_kept_on_the_device_refits_on_the_host_when_the_site_changes);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
