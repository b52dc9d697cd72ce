/*
 * Issue 3's 2M-triangle hard case: "build and trace within lavapipe's
 * 128 MiB per buffer". A generated closed mesh of >= 2,000,000 triangles
 * (bih_make_bumpy_sphere): the CPU build and the GPU build both succeed, the
 * GPU one on the GPU path, and pass pf_bih_check; the uploaded trees' buffers
 * stay within the device's maxStorageBufferRange (pf_vk_buffer_create
 * refuses bigger ones, so the builds' success says the same of every build
 * buffer); and all four build/traversal pairs, closest and any hit, agree on
 * random, clip-plane and edge/vertex rays with an oracle sampled against the
 * CPU brute force (bih_oracle_sampled). Validation stays silent.
 *
 * Every other sampled ray is also cast through the GPU brute-force oracle
 * (pf_raycast_brute_force, exact at any size since it splits the triangles
 * across dispatches under llvmpipe's 65,535-iteration loop limit: 123
 * dispatches here), which must agree with the reference traversal by the GPU
 * rule (t within 1e-6 relative, or a tie). It does not replace the CPU
 * sample: on lavapipe it costs about as much per ray at 2M triangles (~35-50
 * ms against ~37-100 ms for the CPU brute force, 2 cores), and a brute-force
 * answer for every ray would take minutes on either side.
 */
#include "bih_test_gpu.h"

#define LARGE_TRIANGLES 2000000u
/* Rays per half (one half from each tree's clip planes), all checked between the four pairs. */
#define LARGE_RAYS 2000u
/*
 * Every stride-th ray also against the CPU brute force, ~45 ms a ray at 2M
 * triangles here: 2 × 125 rays plain. The sanitizer build (PF_TEST_SANITIZED,
 * set by tests/bih/CMakeLists.txt) runs the instrumented brute force ~2× slower.
 */
#define LARGE_ORACLE_STRIDE 16u
#define LARGE_ORACLE_STRIDE_SANITIZED 40u

/* A host frame this big (~190 MB) is the most the refusal test allocates. */
#define BEYOND_LIMIT_MAX_TRIANGLES 4000000u

static bih_gpu_env env;

/* The sampled rays (every stride-th) through the GPU oracle against the reference answers in set->oracle. */
static void check_gpu_oracle_sample(const char *label, const pf_scene_frame *frame,
                                    const bih_ray_set *set, uint32_t stride)
{
    uint32_t count = (set->count + stride - 1) / stride;
    pf_ray *rays = malloc(count * sizeof *rays);
    pf_hit *expected = malloc(count * sizeof *expected);
    pf_hit *brute = malloc(count * sizeof *brute);
    if (rays && expected && brute) {
        for (uint32_t i = 0; i < count; i++) {
            rays[i] = set->rays[i * stride];
            expected[i] = set->oracle[i * stride];
        }
        pf_error err = {0};
        double start = pf_time_ms();
        PF_CHECK_OK(pf_raycast_brute_force(env.renderer, frame, rays, count, brute, &err), &err);
        printf("%s: GPU oracle, %u rays: %.0f ms\n", label, count, pf_time_ms() - start);
        if (err.status == PF_OK) {
            uint32_t mismatches = bih_compare_closest(label, frame, rays, brute, expected, count, 0);
            PF_CHECK_MSG(mismatches == 0, "%s: %u of %u sampled hits differ from the GPU oracle",
                         label, mismatches, count);
        }
    } else {
        PF_CHECK(!"out of memory");
    }
    free(rays);
    free(expected);
    free(brute);
}

/* The uploaded tree's three buffers fit the device's storage buffer range. */
static void check_buffer_sizes(const char *label)
{
    pf_bih_gpu_view view;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_bih_gpu_view_get(env.gpu, &view, &err), &err);
    uint64_t limit = pf_vk_info(env.ctx)->max_storage_buffer_range;
    const pf_vk_buffer *buffers[3] = {view.nodes, view.vertices, view.triangle_index};
    const char *names[3] = {"nodes", "vertices", "triangle index"};
    for (int i = 0; i < 3; i++) {
        uint64_t size = pf_vk_buffer_size(buffers[i]);
        PF_CHECK_MSG(size <= limit, "%s: %s buffer %llu bytes > maxStorageBufferRange %llu", label,
                     names[i], (unsigned long long)size, (unsigned long long)limit);
        printf("%s: %s buffer %.1f MiB of %.1f MiB\n", label, names[i], size / 1048576.0,
               limit / 1048576.0);
    }
}

/* Both traversals over one tree, closest and any hit, against set->oracle. */
static void check_traversals(const char *build, const pf_scene_frame *frame, const pf_bih *bih,
                             bih_ray_set *set, int print_sizes)
{
    bih_expect expect = {BIH_SPHERE_INSIDE, 0};
    char label[96];
    snprintf(label, sizeof label, "2M, %s build, GPU traversal", build);
    bih_trace_gpu_both(&env, bih, set);
    if (print_sizes)
        check_buffer_sizes(label);
    bih_check_answers(label, frame, expect, set, 0);
    snprintf(label, sizeof label, "2M, %s build, CPU traversal", build);
    bih_trace_cpu_both(label, bih, set);
    bih_check_answers(label, frame, expect, set, 0);
    snprintf(label, sizeof label, "2M, %s build, CPU packets", build);
    bih_check_packets(label, frame, bih, set);
    snprintf(label, sizeof label, "2M, %s build, CPU wide view", build);
    bih_check_wide(label, frame, bih, set);
}

PF_TEST(two_million_triangles)
{
    pf_scene_frame frame;
    PF_REQUIRE(bih_make_bumpy_sphere(&frame, LARGE_TRIANGLES));
    PF_CHECK(frame.triangle_count >= LARGE_TRIANGLES);
    pf_error err = {0};
    pf_bih cpu = {0}, gpu = {0};
    double start = pf_time_ms();
    PF_CHECK_OK(pf_bih_build_cpu(&frame, NULL, &cpu, &err), &err);
    double cpu_ms = pf_time_ms() - start;
    pf_bih_gpu_build_report report = {0};
    start = pf_time_ms();
    PF_CHECK_OK(pf_bih_build_gpu(env.builder, &frame, NULL, &gpu, &report, &err), &err);
    double gpu_ms = pf_time_ms() - start;
    PF_CHECK_MSG(report.path == PF_BIH_BUILT_ON_GPU, "GPU build path %d (GPU depth %u)",
                 (int)report.path, report.gpu_depth);
    printf("%u triangles: CPU build %.0f ms, depth %u, %u leaves | GPU build %.0f ms, depth %u, %u leaves\n",
           frame.triangle_count, cpu_ms, cpu.depth, cpu.leaf_count, gpu_ms, gpu.depth,
           gpu.leaf_count);

    const char *sanitized = getenv("PF_TEST_SANITIZED");
    uint32_t stride = sanitized && *sanitized == '1' ? LARGE_ORACLE_STRIDE_SANITIZED
                                                     : LARGE_ORACLE_STRIDE;
    if (cpu.node_count > 0 && gpu.node_count > 0) {
        PF_CHECK_OK(pf_bih_check(&cpu, &frame, &err), &err);
        PF_CHECK_OK(pf_bih_check(&gpu, &frame, &err), &err);
        /* Half the rays start on the GPU tree's clip planes, half on the CPU tree's. */
        const pf_bih *planes[2] = {&gpu, &cpu};
        for (int half = 0; half < 2; half++) {
            bih_ray_set set;
            if (bih_ray_set_alloc(&set, LARGE_RAYS)) {
                set.aimed = bih_case_rays(BIH_SPHERE_INSIDE, &frame, planes[half],
                                          5000 + (uint32_t)half, set.rays, set.count);
                start = pf_time_ms();
                bih_oracle_sampled(half ? "2M, CPU clip planes" : "2M, GPU clip planes", &frame,
                                   &cpu, &set, stride);
                printf("oracle: %u rays, %u sampled against brute force: %.0f ms\n", set.count,
                       (set.count + stride - 1) / stride, pf_time_ms() - start);
                check_gpu_oracle_sample(half ? "2M, CPU clip planes" : "2M, GPU clip planes",
                                        &frame, &set, 2 * stride);
                check_traversals("GPU", &frame, &gpu, &set, half == 0);
                check_traversals("CPU", &frame, &cpu, &set, half == 0);
            } else {
                PF_CHECK(!"out of memory");
            }
            bih_ray_set_free(&set);
        }
    }
    pf_bih_free(&cpu);
    pf_bih_free(&gpu);
    bih_frame_free(&frame);
}

/*
 * Past the limit: one more triangle than one vertex buffer can hold (48 bytes
 * a triangle, the traversal's format) must be refused with PF_ERR_LIMIT by
 * the GPU build and by the upload, never built or traced half-way. Only on
 * devices whose range a host frame of that size can exceed cheaply.
 */
PF_TEST(beyond_the_buffer_range_is_refused)
{
    uint64_t limit = pf_vk_info(env.ctx)->max_storage_buffer_range;
    uint64_t vertex_bytes = 3 * sizeof(float[4]);
    if (limit / vertex_bytes >= BEYOND_LIMIT_MAX_TRIANGLES) {
        printf("skipped: maxStorageBufferRange %llu needs over %u triangles\n",
               (unsigned long long)limit, BEYOND_LIMIT_MAX_TRIANGLES);
        return;
    }
    pf_scene_frame frame;
    PF_REQUIRE(bih_frame_alloc(&frame, (uint32_t)(limit / vertex_bytes) + 1));
    for (uint32_t t = 0; t < frame.triangle_count; t++) {
        float x = (float)(t % 4096), y = (float)(t / 4096);
        float a[3] = {x, y, 0}, b[3] = {x + 1, y, 0}, c[3] = {x, y + 1, 0};
        bih_set_triangle(&frame, t, a, b, c);
    }
    bih_frame_bounds(&frame);
    pf_bih bih;
    pf_error err = {0};
    PF_CHECK(pf_bih_build_gpu(env.builder, &frame, NULL, &bih, NULL, &err) == PF_ERR_LIMIT);
    PF_CHECK_MSG(strstr(err.message, "allows") || strstr(err.message, "maxStorageBufferRange"),
                 "GPU build: %s", err.message);
    PF_CHECK(bih.nodes == NULL && bih.node_count == 0);
    /* A one-leaf tree over the same vertices: the upload must refuse the vertex buffer. */
    uint32_t leaf[2] = {0, frame.triangle_count};
    pf_bih_node root = {{0, 0}, PF_BIH_LEAF};
    memcpy(root.clip, leaf, sizeof leaf);
    pf_bih oversized = {0};
    oversized.node_count = 1;
    oversized.nodes = &root;
    oversized.triangle_count = frame.triangle_count;
    oversized.vertices = frame.vertices;
    oversized.triangle_index = calloc(frame.triangle_count, sizeof *oversized.triangle_index);
    PF_CHECK(oversized.triangle_index != NULL);
    if (oversized.triangle_index) {
        PF_CHECK(pf_bih_gpu_upload(env.gpu, &oversized, &err) == PF_ERR_LIMIT);
        PF_CHECK_MSG(strstr(err.message, "maxStorageBufferRange") != NULL, "upload: %s",
                     err.message);
    }
    free(oversized.triangle_index);
    bih_frame_free(&frame);
}

int main(void)
{
    if (!bih_gpu_env_create(&env))
        return 1;
    PF_RUN(two_million_triangles);
    PF_RUN(beyond_the_buffer_range_is_refused);
    bih_gpu_env_destroy(&env);
    return pf_test_finish();
}
