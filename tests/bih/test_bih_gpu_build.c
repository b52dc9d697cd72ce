/*
 * The GPU BIH build (pf_bih_build_gpu): for every hard case and every shared
 * scene the downloaded tree passes pf_bih_check, its statistics agree with
 * pf_bih_quality_measure, and the GPU traversal over it matches the GPU
 * brute-force oracle (pf_raycast_brute_force) by the rule of test_bih_gpu.c.
 * The SAH cost of the GPU and CPU trees is printed, not asserted beyond
 * sanity. Over-deep trees fall back to the CPU build. Validation stays silent.
 */
#include "bih_test_util.h"
#include "pf_render.h"

#define CASE_RAYS 2000u
#define SCENE_RAYS 2000u
/* A soup big enough that its Morton tree needs more than FALLBACK_DEPTH levels. */
#define FALLBACK_TRIANGLES 2000u
#define FALLBACK_DEPTH 3u

static pf_vk_context *ctx;
static pf_renderer *renderer;
static pf_bih_gpu *gpu;
static pf_bih_gpu_builder *builder;

static void check_gpu_build(const char *label, const pf_scene_frame *frame, int which,
                            uint32_t seed, uint32_t ray_count)
{
    pf_error err = {0};
    pf_bih bih, cpu;
    pf_bih_gpu_build_report report;
    PF_REQUIRE_OK(pf_bih_build_gpu(builder, frame, NULL, &bih, &report, &err), &err);
    PF_REQUIRE_OK(pf_bih_build_cpu(frame, NULL, &cpu, &err), &err);
    PF_CHECK_OK(pf_bih_check(&bih, frame, &err), &err);
    PF_CHECK_MSG(report.path == (frame->triangle_count > PF_BIH_DEFAULT_LEAF_SIZE
                                     ? PF_BIH_BUILT_ON_GPU
                                     : PF_BIH_BUILT_SMALL_ON_CPU),
                 "%s: build path %d", label, (int)report.path);
    PF_CHECK(bih.largest_leaf <= PF_BIH_DEFAULT_LEAF_SIZE);
    pf_bih_quality quality, cpu_quality;
    pf_bih_quality_measure(&bih, &quality);
    pf_bih_quality_measure(&cpu, &cpu_quality);
    if (frame->triangle_count > 0)
        PF_CHECK_MSG(quality.depth == bih.depth && quality.leaf_count == bih.leaf_count &&
                         quality.largest_leaf == bih.largest_leaf,
                     "%s: measured depth %u leaves %u largest %u, built %u %u %u", label,
                     quality.depth, quality.leaf_count, quality.largest_leaf, bih.depth,
                     bih.leaf_count, bih.largest_leaf);
    if (frame->triangle_count > 0)
        PF_CHECK_MSG(quality.sah_cost >= 1.0 && isfinite(quality.sah_cost), "%s: SAH %g", label,
                     quality.sah_cost);
    pf_ray *rays = malloc(ray_count * sizeof *rays);
    pf_hit *oracle = malloc(ray_count * sizeof *oracle);
    pf_hit *got = malloc(ray_count * sizeof *got);
    pf_hit *any = malloc(ray_count * sizeof *any);
    if (rays && oracle && got && any) {
        uint32_t aimed = bih_case_rays(which, frame, &bih, seed, rays, ray_count);
        PF_CHECK_OK(pf_bih_gpu_upload(gpu, &bih, &err), &err);
        PF_CHECK_OK(pf_raycast_brute_force(renderer, frame, rays, ray_count, oracle, &err), &err);
        PF_CHECK_OK(pf_bih_raycast(gpu, rays, ray_count, 0, got, &err), &err);
        PF_CHECK_OK(pf_bih_raycast(gpu, rays, ray_count, 1, any, &err), &err);
        uint32_t mismatches = bih_compare_closest(label, frame, rays, oracle, got, ray_count, 0);
        PF_CHECK_MSG(mismatches == 0, "%s: %u of %u closest hits over the GPU-built BIH differ",
                     label, mismatches, ray_count);
        mismatches = bih_compare_any(label, frame, rays, oracle, any, ray_count);
        PF_CHECK_MSG(mismatches == 0, "%s: %u of %u any hits over the GPU-built BIH wrong",
                     label, mismatches, ray_count);
        uint32_t hits = 0;
        for (uint32_t r = 0; r < ray_count; r++)
            hits += oracle[r].triangle != PF_NO_HIT;
        if (frame->triangle_count > 0)
            PF_CHECK_MSG(hits > ray_count / 20, "%s: only %u hits: the rays test little", label, hits);
        if (bih_case_is_cube(which)) {
            uint32_t leaks = 0;
            for (uint32_t r = aimed; r < 3 * ray_count / 4; r++)
                leaks += got[r].triangle == PF_NO_HIT || any[r].triangle == PF_NO_HIT;
            PF_CHECK_MSG(leaks == 0, "%s: %u rays through shared edges/vertices leaked out", label,
                         leaks);
        }
        printf("%-16s %6u triangles: GPU depth %2u leaves %6u SAH %9.2f | CPU depth %2u leaves %6u SAH %9.2f\n",
               label, frame->triangle_count, bih.depth, bih.leaf_count, quality.sah_cost, cpu.depth,
               cpu.leaf_count, cpu_quality.sah_cost);
    } else {
        PF_CHECK(!"out of memory");
    }
    free(rays), free(oracle), free(got), free(any);
    pf_bih_free(&bih);
    pf_bih_free(&cpu);
}

PF_TEST(hard_cases_gpu_build)
{
    for (int which = 0; which < BIH_CASE_COUNT; which++) {
        pf_scene_frame frame;
        const char *name;
        PF_REQUIRE(bih_make_case(which, &frame, &name));
        check_gpu_build(name, &frame, which, 3000 + (uint32_t)which, CASE_RAYS);
        bih_frame_free(&frame);
    }
}

PF_TEST(shared_scenes_gpu_build)
{
    char names[16][64];
    uint32_t scene_count = bih_shared_scene_names(names, 16);
    PF_REQUIRE(scene_count > 0);
    for (uint32_t i = 0; i < scene_count; i++) {
        char path[1024];
        pf_scene *scene = NULL;
        pf_error err = {0};
        PF_CHECK_OK(pf_scene_load(pf_test_shared_scene(names[i], path, sizeof path), &scene, &err), &err);
        if (!scene)
            continue;
        const pf_scene_info *info = pf_scene_get_info(scene);
        /* The last frame: animated scenes have moved from their rest pose. */
        pf_scene_frame frame = {0};
        PF_CHECK_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, info->frame_count), &frame, &err),
                    &err);
        if (frame.triangle_count > 0)
            check_gpu_build(names[i], &frame, BIH_CASE_SOUP, 91 + i, SCENE_RAYS);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

/* Leaf size K is honoured for other K than the default. */
PF_TEST(leaf_size_option)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 500, 23));
    const uint32_t sizes[] = {1, 2, 8};
    for (uint32_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        pf_bih_build_options options = {sizes[s], 0};
        pf_bih bih;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_bih_build_gpu(builder, &frame, &options, &bih, NULL, &err), &err);
        PF_CHECK_OK(pf_bih_check(&bih, &frame, &err), &err);
        PF_CHECK_MSG(bih.largest_leaf <= sizes[s], "K = %u: a leaf of %u", sizes[s],
                     bih.largest_leaf);
        if (sizes[s] == 1)
            PF_CHECK(bih.leaf_count == frame.triangle_count &&
                     bih.node_count == 2 * frame.triangle_count - 1);
        pf_bih_free(&bih);
    }
    bih_frame_free(&frame);
}

/* A tree deeper than max_depth is never returned: the CPU build replaces it. */
PF_TEST(too_deep_falls_back_to_cpu)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, FALLBACK_TRIANGLES, 29));
    pf_bih_build_options options = {0, FALLBACK_DEPTH};
    pf_bih bih;
    pf_bih_gpu_build_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_build_gpu(builder, &frame, &options, &bih, &report, &err), &err);
    PF_CHECK(report.path == PF_BIH_BUILT_CPU_FALLBACK);
    PF_CHECK(report.gpu_depth > FALLBACK_DEPTH);
    PF_CHECK(bih.depth <= FALLBACK_DEPTH);
    PF_CHECK_OK(pf_bih_check(&bih, &frame, &err), &err);
    pf_bih_free(&bih);
    bih_frame_free(&frame);
}

PF_TEST(bad_input_is_refused)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 50, 31));
    frame.vertices[3 * 17 + 1][2] = NAN;
    pf_bih bih;
    pf_error err = {0};
    PF_CHECK(pf_bih_build_gpu(builder, &frame, NULL, &bih, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "triangle 17") != NULL);
    PF_CHECK(bih.nodes == NULL && bih.node_count == 0);
    bih_frame_free(&frame);
}

int main(void)
{
    pf_error err = {0};
    pf_vk_options options = {NULL, -1};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK ||
        pf_bih_gpu_create(ctx, &gpu, &err) != PF_OK ||
        pf_bih_gpu_builder_create(ctx, &builder, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(hard_cases_gpu_build);
    PF_RUN(shared_scenes_gpu_build);
    PF_RUN(leaf_size_option);
    PF_RUN(too_deep_falls_back_to_cpu);
    PF_RUN(bad_input_is_refused);
    pf_bih_gpu_builder_destroy(builder);
    pf_bih_gpu_destroy(gpu);
    pf_renderer_destroy(renderer);
    uint32_t messages = pf_vk_validation_message_count(ctx);
    pf_vk_destroy(ctx);
    PF_CHECK_MSG(messages == 0, "%u validation messages", messages);
    return pf_test_finish();
}
