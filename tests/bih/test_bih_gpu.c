/*
 * The GPU BIH traversal (shaders/common/bih_traverse.glsl through
 * pf_bih_raycast) over the CPU-built tree, against the GPU brute-force oracle
 * (pf_raycast_brute_force): same triangle and t within 1e-6 relative, or a
 * tie. Every hard case and every shared scene, trees of both heuristics
 * (global; SAH with empty-space cuts, whose ±inf clip values the GPU must
 * handle); closest and any hit; a stack overflow must be reported.
 * Validation must stay silent.
 */
#include "bih_test_gpu.h"

#define CASE_RAYS 2000u
#define SCENE_RAYS 2000u
#define CHAIN_DEPTH (PF_BIH_STACK_SIZE + 6u)

static bih_gpu_env env;

/* One frame: the CPU-built tree (heuristic) traced on the GPU against the GPU oracle. */
static void check_gpu_heuristic(const char *label, const pf_scene_frame *frame,
                                bih_expect expect, uint32_t seed, uint32_t ray_count,
                                uint32_t heuristic)
{
    pf_error err = {0};
    pf_bih_build_options options = {.heuristic = heuristic};
    char full_label[96];
    snprintf(full_label, sizeof full_label, "%s (%s)", label,
             heuristic == PF_BIH_HEURISTIC_SAH ? "SAH" : "global");
    label = full_label;
    pf_bih bih;
    PF_REQUIRE_OK(pf_bih_build_cpu(frame, &options, &bih, &err), &err);
    PF_CHECK_OK(pf_bih_check(&bih, frame, &err), &err);
    bih_ray_set set;
    if (bih_ray_set_alloc(&set, ray_count)) {
        set.aimed = bih_case_rays(expect.inside, frame, &bih, seed, set.rays, ray_count);
        bih_oracle_gpu(&env, frame, &set);
        bih_trace_gpu_both(&env, &bih, &set);
        bih_check_answers(label, frame, expect, &set, 0);
        uint32_t hits = 0, same = 0;
        for (uint32_t r = 0; r < ray_count; r++) {
            hits += set.oracle[r].triangle != PF_NO_HIT;
            same += set.oracle[r].triangle == set.closest[r].triangle;
        }
        printf("%-26s %6u triangles: %u/%u hits, %u same triangle as the oracle\n", label,
               frame->triangle_count, hits, ray_count, same);
    } else {
        PF_CHECK(!"out of memory");
    }
    bih_ray_set_free(&set);
    pf_bih_free(&bih);
}

static void check_gpu(const char *label, const pf_scene_frame *frame, bih_expect expect,
                      uint32_t seed, uint32_t ray_count)
{
    check_gpu_heuristic(label, frame, expect, seed, ray_count, PF_BIH_HEURISTIC_GLOBAL);
}

static void check_gpu_sah(const char *label, const pf_scene_frame *frame, bih_expect expect,
                          uint32_t seed, uint32_t ray_count)
{
    check_gpu_heuristic(label, frame, expect, seed, ray_count, PF_BIH_HEURISTIC_SAH);
}

PF_TEST(hard_cases_match_oracle)
{
    bih_for_each_case(check_gpu, 2000, CASE_RAYS);
}

PF_TEST(shared_scenes_match_oracle)
{
    bih_for_each_shared_scene(check_gpu, 71, SCENE_RAYS);
}

PF_TEST(sah_tree_hard_cases_match_oracle)
{
    bih_for_each_case(check_gpu_sah, 2000, CASE_RAYS);
}

PF_TEST(sah_tree_shared_scenes_match_oracle)
{
    bih_for_each_shared_scene(check_gpu_sah, 71, SCENE_RAYS);
}

PF_TEST(raycast_needs_an_upload)
{
    pf_bih_gpu *fresh = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_gpu_create(env.ctx, &fresh, &err), &err);
    pf_ray ray = {{0, 0, -1}, 0, {0, 0, 1}, INFINITY};
    pf_hit hit;
    PF_CHECK(pf_bih_raycast(fresh, &ray, 1, 0, &hit, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "upload") != NULL);
    pf_bih_gpu_destroy(fresh);
}

/*
 * The raycast kernels are made at their first cast, one per kind: a renderer
 * uploads trees for its own kernels and must not pay for these.
 */
PF_TEST(raycast_pipelines_are_made_at_first_use)
{
    pf_bih_gpu *gpu = NULL;
    pf_error err = {0};
    uint32_t before = pf_vk_pipeline_cache_stats(env.ctx).pipelines;
    PF_REQUIRE_OK(pf_bih_gpu_create(env.ctx, &gpu, &err), &err);
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 50, 9));
    pf_bih bih;
    PF_REQUIRE_OK(pf_bih_build_cpu(&frame, NULL, &bih, &err), &err);
    PF_CHECK_OK(pf_bih_gpu_upload(gpu, &bih, &err), &err);
    PF_CHECK(pf_vk_pipeline_cache_stats(env.ctx).pipelines == before);
    pf_ray ray = {{0.0f, 0.0f, -10.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
    pf_hit hit;
    static const struct {
        int any_hit;
        uint32_t made; /* pipelines made since before, after this cast */
    } casts[] = {{0, 1}, {0, 1}, {1, 2}, {1, 2}, {0, 2}};
    for (size_t i = 0; i < sizeof casts / sizeof casts[0]; i++) {
        PF_CHECK_OK(pf_bih_raycast(gpu, &ray, 1, casts[i].any_hit, &hit, &err), &err);
        uint32_t made = pf_vk_pipeline_cache_stats(env.ctx).pipelines - before;
        PF_CHECK_MSG(made == casts[i].made, "cast %zu: %u pipelines made, expected %u", i, made,
                     casts[i].made);
    }
    pf_bih_gpu_destroy(gpu);
    pf_bih_free(&bih);
    bih_frame_free(&frame);
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
    PF_REQUIRE_OK(pf_bih_gpu_upload(env.gpu, &bih, &err), &err);
    pf_ray rays[2] = {{{2.0f, 0.0f, 0.0f}, 0.0f, {-1.0f, 0.01f, 0.02f}, INFINITY},
                      {{2.0f, 0.0f, 0.0f}, 0.0f, {-1.0f, 0.02f, 0.01f}, INFINITY}};
    pf_hit hits[2];
    PF_CHECK(pf_bih_raycast(env.gpu, rays, 2, 0, hits, &err) == PF_ERR_LIMIT);
    PF_CHECK(strstr(err.message, "2 rays failed") != NULL);
    PF_CHECK(hits[0].triangle == PF_NO_HIT && hits[1].triangle == PF_NO_HIT);
    bih_frame_free(&frame);
}

int main(void)
{
    if (!bih_gpu_env_create(&env))
        return 1;
    PF_RUN(hard_cases_match_oracle);
    PF_RUN(shared_scenes_match_oracle);
    PF_RUN(sah_tree_hard_cases_match_oracle);
    PF_RUN(sah_tree_shared_scenes_match_oracle);
    PF_RUN(raycast_needs_an_upload);
    PF_RUN(raycast_pipelines_are_made_at_first_use);
    PF_RUN(stack_overflow_is_reported);
    bih_gpu_env_destroy(&env);
    return pf_test_finish();
}
