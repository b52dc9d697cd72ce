/*
 * The GPU BIH traversal (shaders/common/bih_traverse.glsl through
 * pf_bih_raycast) over the CPU-built tree, against the GPU brute-force oracle
 * (pf_raycast_brute_force): same triangle and t within 1e-6 relative, or a
 * tie. Every hard case and every shared scene; closest and any hit; a stack
 * overflow must be reported. Validation must stay silent.
 */
#include "bih_test_util.h"
#include "pf_render.h"

#define CASE_RAYS 2000u
#define SCENE_RAYS 2000u
#define CHAIN_DEPTH (PF_BIH_STACK_SIZE + 6u)

static pf_vk_context *ctx;
static pf_renderer *renderer;
static pf_bih_gpu *gpu;

static void check_gpu(const char *label, const pf_scene_frame *frame, int which, uint32_t seed,
                      uint32_t ray_count)
{
    pf_error err = {0};
    pf_bih bih;
    PF_REQUIRE_OK(pf_bih_build_cpu(frame, NULL, &bih, &err), &err);
    PF_CHECK_OK(pf_bih_check(&bih, frame, &err), &err);
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
        PF_CHECK_MSG(mismatches == 0, "%s: %u of %u GPU BIH closest hits differ from the oracle",
                     label, mismatches, ray_count);
        mismatches = bih_compare_any(label, frame, rays, oracle, any, ray_count);
        PF_CHECK_MSG(mismatches == 0, "%s: %u of %u GPU BIH any hits wrong", label, mismatches,
                     ray_count);
        uint32_t hits = 0, same = 0;
        for (uint32_t r = 0; r < ray_count; r++) {
            hits += oracle[r].triangle != PF_NO_HIT;
            same += oracle[r].triangle == got[r].triangle;
        }
        if (frame->triangle_count > 0)
            PF_CHECK_MSG(hits > ray_count / 20, "%s: only %u hits: the rays test little", label, hits);
        if (bih_case_is_cube(which)) {
            uint32_t leaks = 0;
            for (uint32_t r = aimed; r < 3 * ray_count / 4; r++)
                leaks += got[r].triangle == PF_NO_HIT || any[r].triangle == PF_NO_HIT;
            PF_CHECK_MSG(leaks == 0, "%s: %u rays through shared edges/vertices leaked out", label,
                         leaks);
        }
        if (which == BIH_CASE_DEGENERATE)
            for (uint32_t r = 0; r < ray_count; r++)
                PF_CHECK(got[r].triangle == PF_NO_HIT || got[r].triangle % BIH_DEGENERATE_EVERY == 0);
        printf("%-16s %6u triangles: %u/%u hits, %u same triangle as the oracle\n", label,
               frame->triangle_count, hits, ray_count, same);
    } else {
        PF_CHECK(!"out of memory");
    }
    free(rays), free(oracle), free(got), free(any);
    pf_bih_free(&bih);
}

PF_TEST(hard_cases_match_oracle)
{
    for (int which = 0; which < BIH_CASE_COUNT; which++) {
        pf_scene_frame frame;
        const char *name;
        PF_REQUIRE(bih_make_case(which, &frame, &name));
        check_gpu(name, &frame, which, 2000 + (uint32_t)which, CASE_RAYS);
        bih_frame_free(&frame);
    }
}

PF_TEST(shared_scenes_match_oracle)
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
            check_gpu(names[i], &frame, BIH_CASE_SOUP, 71 + i, SCENE_RAYS);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

PF_TEST(raycast_needs_an_upload)
{
    pf_bih_gpu *fresh = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_gpu_create(ctx, &fresh, &err), &err);
    pf_ray ray = {{0, 0, -1}, 0, {0, 0, 1}, INFINITY};
    pf_hit hit;
    PF_CHECK(pf_bih_raycast(fresh, &ray, 1, 0, &hit, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "upload") != NULL);
    pf_bih_gpu_destroy(fresh);
}

/* The chain of test_bih_cpu.c's stack_overflow_is_reported, on the GPU. */
PF_TEST(stack_overflow_is_reported)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 1, 5));
    pf_bih bih = {0};
    bih.triangle_count = 1;
    bih.vertices = frame.vertices;
    uint32_t index = 0;
    bih.triangle_index = &index;
    for (int k = 0; k < 3; k++) {
        bih.bounds_min[k] = -10.0f;
        bih.bounds_max[k] = 10.0f;
    }
    pf_bih_node nodes[2 * CHAIN_DEPTH + 1];
    uint32_t leaf_bits[2] = {0, 1};
    for (uint32_t level = 0; level <= CHAIN_DEPTH; level++) {
        if (level < CHAIN_DEPTH)
            nodes[2 * level] = (pf_bih_node){{INFINITY, -INFINITY}, (2 * level + 1) << 2};
        uint32_t leaf = level < CHAIN_DEPTH ? 2 * level + 1 : 2 * CHAIN_DEPTH;
        memcpy(nodes[leaf].clip, leaf_bits, sizeof leaf_bits);
        nodes[leaf].word = PF_BIH_LEAF;
    }
    bih.nodes = nodes;
    bih.node_count = 2 * CHAIN_DEPTH + 1;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_gpu_upload(gpu, &bih, &err), &err);
    pf_ray rays[2] = {{{2.0f, 0.0f, 0.0f}, 0.0f, {-1.0f, 0.01f, 0.02f}, INFINITY},
                      {{2.0f, 0.0f, 0.0f}, 0.0f, {-1.0f, 0.02f, 0.01f}, INFINITY}};
    pf_hit hits[2];
    PF_CHECK(pf_bih_raycast(gpu, rays, 2, 0, hits, &err) == PF_ERR_LIMIT);
    PF_CHECK(strstr(err.message, "2 rays failed") != NULL);
    PF_CHECK(hits[0].triangle == PF_NO_HIT && hits[1].triangle == PF_NO_HIT);
    bih_frame_free(&frame);
}

int main(void)
{
    pf_error err = {0};
    pf_vk_options options = {NULL, -1};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK ||
        pf_bih_gpu_create(ctx, &gpu, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(hard_cases_match_oracle);
    PF_RUN(shared_scenes_match_oracle);
    PF_RUN(raycast_needs_an_upload);
    PF_RUN(stack_overflow_is_reported);
    pf_bih_gpu_destroy(gpu);
    pf_renderer_destroy(renderer);
    uint32_t messages = pf_vk_validation_message_count(ctx);
    pf_vk_destroy(ctx);
    PF_CHECK_MSG(messages == 0, "%u validation messages", messages);
    return pf_test_finish();
}
