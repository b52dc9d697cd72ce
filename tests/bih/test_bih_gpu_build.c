/*
 * The GPU BIH build (pf_bih_build_gpu): for every hard case, every shared
 * scene and a generated 1M-triangle closed mesh the downloaded tree passes
 * pf_bih_check, its statistics agree with pf_bih_quality_measure, and both
 * the GPU and the CPU traversal over it (closest and any hit) match the GPU
 * brute-force oracle (pf_raycast_brute_force) by the rule of test_bih_gpu.c
 * (the 1M mesh: the sampled CPU oracle, see million_triangles_gpu_build).
 * The SAH cost of the GPU and CPU trees is printed, not asserted beyond
 * sanity. Over-deep trees fall back to the CPU build, and the build's radix
 * sort is stable. Validation stays silent.
 */
#include "bih_test_gpu.h"
#include "pf_vk_internal.h" /* pf_vk_force_staging */

#define CASE_RAYS 2000u
#define SCENE_RAYS 2000u
/* The benchmark mesh size: malformed GPU trees were once seen only this big. */
#define MILLION_TRIANGLES 1000000u
/*
 * Its rays: all held to the CPU-built tree's CPU traversal, every
 * MILLION_ORACLE_STRIDE-th also to the CPU brute force (1M triangle tests
 * each). The GPU oracle is exact at this size too but no cheaper per ray on
 * lavapipe (test_bih_large.c), so the exact CPU sample stays.
 */
#define MILLION_RAYS 2000u
#define MILLION_ORACLE_STRIDE 20u
/* A soup big enough that its Morton tree needs more than FALLBACK_DEPTH levels. */
#define FALLBACK_TRIANGLES 2000u
#define FALLBACK_DEPTH 3u

static bih_gpu_env env;

/* The GPU build with the default options: invariants, build path, leaf size, statistics. */
static int build_on_gpu(const char *label, const pf_scene_frame *frame, pf_bih *bih,
                        pf_bih_quality *quality)
{
    pf_error err = {0};
    pf_bih_gpu_build_report report;
    PF_CHECK_OK(pf_bih_build_gpu(env.builder, frame, NULL, bih, &report, &err), &err);
    if (err.status != PF_OK)
        return 0;
    PF_CHECK_OK(pf_bih_check(bih, frame, &err), &err);
    PF_CHECK_MSG(report.path == (frame->triangle_count > PF_BIH_DEFAULT_LEAF_SIZE
                                     ? PF_BIH_BUILT_ON_GPU
                                     : PF_BIH_BUILT_SMALL_ON_CPU),
                 "%s: build path %d", label, (int)report.path);
    PF_CHECK(bih->largest_leaf <= PF_BIH_DEFAULT_LEAF_SIZE);
    pf_bih_quality_measure(bih, quality);
    if (frame->triangle_count > 0) {
        PF_CHECK_MSG(quality->depth == bih->depth && quality->leaf_count == bih->leaf_count &&
                         quality->largest_leaf == bih->largest_leaf,
                     "%s: measured depth %u leaves %u largest %u, built %u %u %u", label,
                     quality->depth, quality->leaf_count, quality->largest_leaf, bih->depth,
                     bih->leaf_count, bih->largest_leaf);
        PF_CHECK_MSG(quality->sah_cost >= 1.0 && isfinite(quality->sah_cost), "%s: SAH %g",
                     label, quality->sah_cost);
    }
    return 1;
}

/* The GPU and the CPU traversal over the GPU-built tree, closest and any hit, against set->oracle. */
static void check_traversals(const char *label, const pf_scene_frame *frame, bih_expect expect,
                             const pf_bih *bih, bih_ray_set *set)
{
    char pair[128];
    bih_trace_gpu_both(&env, bih, set);
    snprintf(pair, sizeof pair, "%s (GPU build, GPU traversal)", label);
    bih_check_answers(pair, frame, expect, set, 0);
    snprintf(pair, sizeof pair, "%s (GPU build, CPU traversal)", label);
    bih_trace_cpu_both(pair, bih, set);
    bih_check_answers(pair, frame, expect, set, 0);
}

static void print_sah(const char *label, const pf_scene_frame *frame, const pf_bih *bih,
                      const pf_bih_quality *quality, const pf_bih *cpu)
{
    pf_bih_quality cpu_quality;
    pf_bih_quality_measure(cpu, &cpu_quality);
    printf("%-16s %7u triangles: GPU depth %2u leaves %6u SAH %9.2f | CPU depth %2u leaves %6u SAH %9.2f\n",
           label, frame->triangle_count, bih->depth, bih->leaf_count, quality->sah_cost,
           cpu->depth, cpu->leaf_count, cpu_quality.sah_cost);
}

/*
 * One frame: the GPU build, then both traversals over it against the GPU
 * oracle, with rays whose clip-plane origins come from the GPU-built tree.
 */
static void check_gpu_build(const char *label, const pf_scene_frame *frame, bih_expect expect,
                            uint32_t seed, uint32_t ray_count)
{
    pf_error err = {0};
    pf_bih bih, cpu;
    pf_bih_quality quality;
    if (!build_on_gpu(label, frame, &bih, &quality))
        return;
    bih_ray_set set;
    if (bih_ray_set_alloc(&set, ray_count)) {
        set.aimed = bih_case_rays(expect.inside, frame, &bih, seed, set.rays, ray_count);
        bih_oracle_gpu(&env, frame, &set);
        check_traversals(label, frame, expect, &bih, &set);
    } else {
        PF_CHECK(!"out of memory");
    }
    bih_ray_set_free(&set);
    PF_CHECK_OK(pf_bih_build_cpu(frame, NULL, &cpu, &err), &err);
    if (err.status == PF_OK) {
        print_sah(label, frame, &bih, &quality, &cpu);
        pf_bih_free(&cpu);
    }
    pf_bih_free(&bih);
}

PF_TEST(hard_cases_gpu_build)
{
    bih_for_each_case(check_gpu_build, 3000, CASE_RAYS);
}

PF_TEST(shared_scenes_gpu_build)
{
    bih_for_each_shared_scene(check_gpu_build, 91, SCENE_RAYS);
}

/*
 * The benchmark's 1M-triangle size, closed so rays from inside must hit.
 * The GPU brute-force oracle silently stops early at this size on lavapipe
 * (gallivm ends every shader invocation's loops after 65535 iterations in
 * all), so the oracle is the CPU-built tree sampled against the CPU brute
 * force (bih_oracle_sampled).
 */
PF_TEST(million_triangles_gpu_build)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_bumpy_sphere(&frame, MILLION_TRIANGLES));
    PF_CHECK(frame.triangle_count >= MILLION_TRIANGLES);
    const char *label = "bumpy sphere 1M";
    bih_expect expect = {BIH_SPHERE_INSIDE, 0};
    pf_error err = {0};
    pf_bih bih, cpu;
    pf_bih_quality quality;
    bih_ray_set set;
    if (build_on_gpu(label, &frame, &bih, &quality)) {
        PF_CHECK_OK(pf_bih_build_cpu(&frame, NULL, &cpu, &err), &err);
        if (err.status == PF_OK) {
            PF_CHECK_OK(pf_bih_check(&cpu, &frame, &err), &err);
            if (bih_ray_set_alloc(&set, MILLION_RAYS)) {
                set.aimed = bih_case_rays(expect.inside, &frame, &bih, 4000, set.rays, set.count);
                bih_oracle_sampled(label, &frame, &cpu, &set, MILLION_ORACLE_STRIDE);
                check_traversals(label, &frame, expect, &bih, &set);
            } else {
                PF_CHECK(!"out of memory");
            }
            bih_ray_set_free(&set);
            print_sah(label, &frame, &bih, &quality, &cpu);
            pf_bih_free(&cpu);
        }
        pf_bih_free(&bih);
    }
    bih_frame_free(&frame);
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
        PF_REQUIRE_OK(pf_bih_build_gpu(env.builder, &frame, &options, &bih, NULL, &err), &err);
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

/* A tree deeper than max_depth is never returned: the CPU build replaces it, with its
 * nodes on the host also where they would have stayed on the device (pf_bih_build_gpu_kept,
 * which measures the depth there). */
PF_TEST(too_deep_falls_back_to_cpu)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, FALLBACK_TRIANGLES, 29));
    pf_bih_build_options options = {0, FALLBACK_DEPTH};
    for (int kept = 0; kept < 2; kept++) {
        pf_bih bih;
        pf_bih_gpu_build_report report;
        pf_error err = {0};
        PF_REQUIRE_OK(kept ? pf_bih_build_gpu_kept(env.builder, &frame, &options, &bih, env.gpu,
                                                   &report, &err)
                           : pf_bih_build_gpu(env.builder, &frame, &options, &bih, &report, &err),
                      &err);
        PF_CHECK(report.path == PF_BIH_BUILT_CPU_FALLBACK && !report.resident && bih.nodes);
        PF_CHECK(report.gpu_depth > FALLBACK_DEPTH);
        PF_CHECK(bih.depth <= FALLBACK_DEPTH);
        PF_CHECK_OK(pf_bih_check(&bih, &frame, &err), &err);
        pf_bih_free(&bih);
    }
    bih_frame_free(&frame);
}

/* Issue 44: the GPU build is one submission and one wait, the vertices' upload and the
 * readbacks included, whether the buffers are mapped (lavapipe) or staged (a GPU's
 * device-local memory, forced here); it reads back the node bound, 2n - 1. */
PF_TEST(the_gpu_build_is_one_submission)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 5000, 37));
    uint64_t n = frame.triangle_count;
    for (int staged = 0; staged < 2; staged++) {
        pf_vk_force_staging(env.ctx, staged);
        pf_bih bih;
        pf_bih_gpu_build_report report;
        pf_error err = {0};
        pf_vk_traffic before = pf_vk_traffic_of(env.ctx);
        PF_REQUIRE_OK(pf_bih_build_gpu(env.builder, &frame, NULL, &bih, &report, &err), &err);
        pf_vk_traffic used = pf_vk_traffic_since(env.ctx, before);
        PF_CHECK(report.path == PF_BIH_BUILT_ON_GPU);
        PF_CHECK_MSG(used.submits == 1 && used.host_waits == 1,
                     "%s buffers: %llu submits, %llu waits", staged ? "staged" : "mapped",
                     (unsigned long long)used.submits, (unsigned long long)used.host_waits);
        /* kept count, node texels (16 bytes, as traversal reads them), vertices, index. */
        uint64_t readback = 4 + (2 * n - 1) * 16 + 3 * n * 16 + 4 * n;
        PF_CHECK_MSG(used.readback_bytes == readback && used.upload_bytes == 3 * n * 16,
                     "read back %llu bytes (expected %llu), uploaded %llu",
                     (unsigned long long)used.readback_bytes, (unsigned long long)readback,
                     (unsigned long long)used.upload_bytes);
        PF_CHECK_OK(pf_bih_check(&bih, &frame, &err), &err);
        pf_bih_free(&bih);
    }
    pf_vk_force_staging(env.ctx, 0);
    bih_frame_free(&frame);
}

/*
 * pf_bih_build_gpu_kept (issue 44): the nodes stay on the device. The host's copy holds
 * what the downloaded build holds but the nodes (counts, depth, leaves, vertices, index,
 * box), the device's SAH is the host's measure to float rounding, 4n + 56 bytes come back
 * in one submission, and the nodes downloaded afterwards are the build's, bit for bit.
 */
PF_TEST(a_tree_kept_on_the_device_is_the_downloaded_one)
{
    const int cases[] = {BIH_CASE_SOUP, BIH_CASE_CUBE, BIH_CASE_CUBE_OFFSET, BIH_CASE_FLAT,
                         BIH_CASE_COPLANAR, BIH_CASE_DEGENERATE, BIH_CASE_CLUSTERED};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        pf_scene_frame frame;
        const char *name;
        PF_REQUIRE(bih_make_case(cases[c], &frame, &name));
        for (int staged = 0; staged < 2; staged++) {
            pf_vk_force_staging(env.ctx, staged);
            pf_bih full, kept;
            pf_bih_gpu_build_report report;
            pf_error err = {0};
            PF_REQUIRE_OK(pf_bih_build_gpu(env.builder, &frame, NULL, &full, NULL, &err), &err);
            pf_vk_traffic before = pf_vk_traffic_of(env.ctx);
            PF_REQUIRE_OK(pf_bih_build_gpu_kept(env.builder, &frame, NULL, &kept, env.gpu,
                                                &report, &err),
                          &err);
            pf_vk_traffic used = pf_vk_traffic_since(env.ctx, before);
            uint64_t n = frame.triangle_count;
            PF_CHECK_MSG(report.path == PF_BIH_BUILT_ON_GPU && report.resident &&
                             kept.nodes == NULL,
                         "%s: path %d, resident %d", name, (int)report.path, report.resident);
            PF_CHECK_MSG(used.submits == 1 && used.host_waits == 1 &&
                             used.readback_bytes == 4 * n + 56,
                         "%s: %llu submits, %llu waits, %llu bytes back", name,
                         (unsigned long long)used.submits, (unsigned long long)used.host_waits,
                         (unsigned long long)used.readback_bytes);
            PF_CHECK_MSG(kept.node_count == full.node_count && kept.depth == full.depth &&
                             kept.leaf_count == full.leaf_count &&
                             kept.largest_leaf == full.largest_leaf,
                         "%s: nodes %u/%u depth %u/%u leaves %u/%u largest %u/%u", name,
                         kept.node_count, full.node_count, kept.depth, full.depth,
                         kept.leaf_count, full.leaf_count, kept.largest_leaf, full.largest_leaf);
            PF_CHECK(!memcmp(kept.vertices, full.vertices, 3 * n * sizeof *full.vertices) &&
                     !memcmp(kept.triangle_index, full.triangle_index,
                             n * sizeof *full.triangle_index) &&
                     !memcmp(kept.bounds_min, full.bounds_min, sizeof full.bounds_min) &&
                     !memcmp(kept.bounds_max, full.bounds_max, sizeof full.bounds_max));
            pf_bih_quality quality;
            pf_bih_quality_measure(&full, &quality);
            PF_CHECK_MSG(fabs(report.sah_cost - quality.sah_cost) <= 1e-4 * quality.sah_cost,
                         "%s: device SAH %.7g, host %.7g", name, report.sah_cost,
                         quality.sah_cost);
            if (report.gpu_ms >= 0.0)
                PF_CHECK(report.pass_ms[PF_BIH_GPU_PASS_FIT] >= 0.0);
            PF_CHECK_OK(pf_bih_gpu_download_nodes(env.gpu, &kept, &err), &err);
            PF_CHECK_MSG(kept.nodes && !memcmp(kept.nodes, full.nodes,
                                               full.node_count * sizeof *full.nodes),
                         "%s: the downloaded nodes differ from the build's", name);
            PF_CHECK_OK(pf_bih_check(&kept, &frame, &err), &err);
            pf_bih_free(&kept);
            pf_bih_free(&full);
        }
        pf_vk_force_staging(env.ctx, 0);
        bih_frame_free(&frame);
    }
}

PF_TEST(bad_input_is_refused)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_soup(&frame, 50, 31));
    frame.vertices[3 * 17 + 1][2] = NAN;
    pf_bih bih;
    pf_error err = {0};
    PF_CHECK(pf_bih_build_gpu(env.builder, &frame, NULL, &bih, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "triangle 17") != NULL);
    PF_CHECK(bih.nodes == NULL && bih.node_count == 0);
    bih_frame_free(&frame);
}

/* xorshift32: the sort test's keys. */
static uint32_t sort_random(uint32_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    return *state;
}

/*
 * The one GPU prefix sum (pf_bih_prefix_sum_record: blocks of 4096 entries, their sums,
 * then each block from its sum) against the host's, at the block edges and past them:
 * every entry the exclusive sum, the total after the last, none for an empty array.
 */
PF_TEST(prefix_sum_matches_the_hosts_at_block_edges)
{
    static const uint32_t counts[] = {0, 1, 255, 4095, 4096, 4097, 8192, 70001, 1048577};
    pf_error err = {0};
    pf_vk_pipeline *pipeline = NULL;
    PF_REQUIRE_OK(pf_bih_prefix_sum_pipeline(env.ctx, &pipeline, &err), &err);
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        uint32_t count = counts[c];
        uint64_t words = pf_bih_prefix_sum_words(count);
        uint32_t *data = malloc(words * 4), *back = malloc(words * 4);
        PF_REQUIRE(data && back);
        uint32_t rng = 7u + count;
        for (uint64_t i = 0; i < words; i++) /* past count too: the scan must not read it */
            data[i] = i < count ? sort_random(&rng) % 1000u : 0xdeadbeefu;
        pf_vk_buffer *buffer = NULL;
        pf_vk_commands *cmds = NULL;
        pf_status status = pf_vk_buffer_create(env.ctx, words * 4, "prefix sum", &buffer, &err);
        if (status == PF_OK)
            status = pf_vk_buffer_upload(env.ctx, buffer, 0, data, words * 4, &err);
        if (status == PF_OK)
            status = pf_vk_commands_begin(env.ctx, &cmds, &err);
        if (status == PF_OK)
            status = pf_bih_prefix_sum_record(cmds, pipeline, buffer, count, &err);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, &err);
        pf_vk_commands_destroy(cmds);
        if (status == PF_OK)
            status = pf_vk_buffer_download(env.ctx, buffer, 0, back, words * 4, &err);
        PF_CHECK_OK(status, &err);
        uint32_t running = 0, wrong = 0;
        for (uint32_t i = 0; status == PF_OK && i < count; i++) {
            wrong += back[i] != running;
            running += data[i];
        }
        PF_CHECK_MSG(status != PF_OK || (wrong == 0 && back[count] == running),
                     "%u entries: %u wrong, total %u against %u", count, wrong, back[count],
                     running);
        pf_vk_buffer_destroy(env.ctx, buffer);
        free(data);
        free(back);
    }
    /* A buffer without room for the block sums is refused before anything is recorded. */
    pf_vk_buffer *small = NULL;
    pf_vk_commands *cmds = NULL;
    PF_REQUIRE_OK(pf_vk_buffer_create(env.ctx, 4 * 5000, "too small", &small, &err), &err);
    PF_REQUIRE_OK(pf_vk_commands_begin(env.ctx, &cmds, &err), &err);
    PF_CHECK(pf_bih_prefix_sum_record(cmds, pipeline, small, 4999, &err) == PF_ERR_INVALID);
    pf_vk_commands_destroy(cmds);
    pf_vk_buffer_destroy(env.ctx, small);
    pf_vk_pipeline_destroy(env.ctx, pipeline);
}

PF_TEST(radix_sort_is_stable)
{
    /*
     * The build's radix sort (Morton codes), whose scatter ranks keys in two
     * levels (shaders/bih_radix_scatter.comp). Keys with many
     * duplicates within and across workgroups (and a partial last group),
     * values = input index: sorted keys must be nondecreasing, equal keys in
     * input order, and the values a permutation.
     */
    enum { COUNT = 100003 };
    const uint32_t key_bits = 12;
    pf_error err = {0};
    uint32_t *keys = malloc(COUNT * sizeof *keys), *values = malloc(COUNT * sizeof *values);
    uint8_t *seen = calloc(COUNT, 1);
    PF_REQUIRE(keys && values && seen);
    uint32_t rng = 5u;
    for (uint32_t i = 0; i < COUNT; i++) {
        /* Many equal keys; bits above the sorted 16 (12 rounded up to 2 passes) are ignored. */
        keys[i] = (i % 7 == 0 ? 42u : sort_random(&rng) % 300u) | (sort_random(&rng) << 16);
        values[i] = i;
    }
    pf_bih_sorter *sorter = NULL;
    pf_vk_buffer *key_buffers[2] = {NULL, NULL}, *value_buffers[2] = {NULL, NULL},
                 *histogram = NULL;
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_bih_sorter_create(env.ctx, &sorter, &err);
    for (int b = 0; status == PF_OK && b < 2; b++) {
        status = pf_vk_buffer_create(env.ctx, COUNT * 4, "sort keys", &key_buffers[b], &err);
        if (status == PF_OK)
            status = pf_vk_buffer_create(env.ctx, COUNT * 4, "sort values", &value_buffers[b], &err);
    }
    if (status == PF_OK)
        status = pf_vk_buffer_create(env.ctx, pf_bih_sort_histogram_bytes(COUNT), "sort histogram",
                                     &histogram, &err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(env.ctx, key_buffers[0], 0, keys, COUNT * 4, &err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(env.ctx, value_buffers[0], 0, values, COUNT * 4, &err);
    if (status == PF_OK)
        status = pf_vk_commands_begin(env.ctx, &cmds, &err);
    if (status == PF_OK)
        status = pf_bih_sort_record(sorter, cmds, key_buffers, value_buffers, histogram, COUNT,
                                    key_bits, &err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, &err);
    pf_vk_commands_destroy(cmds);
    uint32_t *sorted_keys = malloc(COUNT * sizeof *sorted_keys);
    uint32_t *sorted_values = malloc(COUNT * sizeof *sorted_values);
    if (status == PF_OK)
        status = pf_vk_buffer_download(env.ctx, key_buffers[0], 0, sorted_keys, COUNT * 4, &err);
    if (status == PF_OK)
        status = pf_vk_buffer_download(env.ctx, value_buffers[0], 0, sorted_values, COUNT * 4, &err);
    PF_CHECK_OK(status, &err);
    uint32_t out_of_order = 0, unstable = 0, not_permutation = 0;
    const uint32_t mask = 0xFFFFu;
    for (uint32_t i = 0; status == PF_OK && i < COUNT; i++) {
        uint32_t v = sorted_values[i];
        if (v >= COUNT || seen[v] || sorted_keys[i] != keys[v]) {
            not_permutation++;
            continue;
        }
        seen[v] = 1;
        if (i > 0) {
            uint32_t previous = sorted_keys[i - 1] & mask, current = sorted_keys[i] & mask;
            out_of_order += previous > current;
            unstable += previous == current && sorted_values[i - 1] > v;
        }
    }
    printf("  radix sort of %u pairs by %u bits: %u out of order, %u unstable, %u not a permutation\n",
           COUNT, key_bits, out_of_order, unstable, not_permutation);
    PF_CHECK(status == PF_OK && out_of_order == 0 && unstable == 0 && not_permutation == 0);
    for (int b = 0; b < 2; b++) {
        if (key_buffers[b])
            pf_vk_buffer_destroy(env.ctx, key_buffers[b]);
        if (value_buffers[b])
            pf_vk_buffer_destroy(env.ctx, value_buffers[b]);
    }
    if (histogram)
        pf_vk_buffer_destroy(env.ctx, histogram);
    pf_bih_sorter_destroy(sorter);
    free(sorted_keys);
    free(sorted_values);
    free(seen);
    free(keys);
    free(values);
}

int main(void)
{
    if (!bih_gpu_env_create(&env))
        return 1;
    PF_RUN(hard_cases_gpu_build);
    PF_RUN(shared_scenes_gpu_build);
    PF_RUN(million_triangles_gpu_build);
    PF_RUN(leaf_size_option);
    PF_RUN(too_deep_falls_back_to_cpu);
    PF_RUN(the_gpu_build_is_one_submission);
    PF_RUN(a_tree_kept_on_the_device_is_the_downloaded_one);
    PF_RUN(bad_input_is_refused);
    PF_RUN(prefix_sum_matches_the_hosts_at_block_edges);
    PF_RUN(radix_sort_is_stable);
    bih_gpu_env_destroy(&env);
    return pf_test_finish();
}
