/*
 * The BIH refit on the device (pf_bih_refit_gpu, issue 44): for the hard cases, trees of
 * the three builds (GPU, CPU global, CPU SAH with its empty leaves) refit to six motions
 * hold on the device bit for bit what pf_bih_refit makes on the host (node texels, leaf
 * vertices, root box); the cost read back is pf_bih_quality_measure's SAH to float
 * rounding; pf_bih_refit_bounds then makes the host's copy the same tree. One submission
 * and one wait, 52 bytes read back; refused input changes neither copy.
 */
#include "bih_refit_util.h"
#include "bih_test_gpu.h"
#include "pf_vk_internal.h" /* pf_vk_force_staging */

/* Enough nodes for more workgroup sums (256 nodes each) than bih_refit_sum.comp has lanes. */
#define LARGE_TRIANGLES 120000u

static bih_gpu_env env;

typedef enum build_kind { BUILD_GPU, BUILD_CPU_GLOBAL, BUILD_CPU_SAH, BUILD_KINDS } build_kind;
static const char *const build_names[BUILD_KINDS] = {"GPU", "CPU global", "CPU SAH"};

static double sah_of(const pf_bih *bih)
{
    pf_bih_quality quality;
    pf_bih_quality_measure(bih, &quality);
    return quality.sah_cost;
}

/* frame's tree of kind in out, and on the device (env.gpu) as built or uploaded. */
static int build_on_device(build_kind kind, const pf_scene_frame *frame, pf_bih *out)
{
    pf_error err = {0};
    if (kind == BUILD_GPU) {
        pf_bih_gpu_build_report report;
        PF_CHECK_OK(pf_bih_build_gpu_resident(env.builder, frame, NULL, out, env.gpu, &report,
                                              &err),
                    &err);
        if (err.status != PF_OK)
            return 0;
        if (report.resident)
            return 1;
    } else {
        pf_bih_build_options options = {0, 0,
                                        kind == BUILD_CPU_SAH ? PF_BIH_HEURISTIC_SAH
                                                              : PF_BIH_HEURISTIC_GLOBAL,
                                        0};
        PF_CHECK_OK(pf_bih_build_cpu(frame, &options, out, &err), &err);
        if (err.status != PF_OK)
            return 0;
    }
    PF_CHECK_OK(pf_bih_gpu_upload(env.gpu, out, &err), &err);
    return err.status == PF_OK;
}

/* The device's node texels and leaf vertices against expected's, bit for bit: the number
 * of differing values. */
static size_t device_differs(const pf_bih *expected)
{
    pf_bih_gpu_view view;
    pf_error err = {0};
    PF_CHECK_OK(pf_bih_gpu_view_get(env.gpu, &view, &err), &err);
    if (err.status != PF_OK)
        return 1;
    size_t nodes = expected->node_count, n = expected->triangle_count, differ = 0;
    uint32_t (*texels)[4] = malloc(nodes * sizeof *texels);
    float(*vertices)[4] = malloc((n ? 3 * n : 1) * sizeof *vertices);
    if (!texels || !vertices) {
        free(texels);
        free(vertices);
        PF_CHECK_MSG(0, "out of memory for %zu nodes", nodes);
        return 1;
    }
    PF_CHECK_OK(pf_vk_buffer_download(env.ctx, view.nodes, 0, texels, nodes * sizeof *texels,
                                      &err),
                &err);
    if (n > 0)
        PF_CHECK_OK(pf_vk_buffer_download(env.ctx, view.vertices, 0, vertices,
                                          3 * n * sizeof *vertices, &err),
                    &err);
    for (size_t i = 0; i < nodes; i++) {
        uint32_t want[3];
        memcpy(&want[0], &expected->nodes[i].clip[0], 4);
        memcpy(&want[1], &expected->nodes[i].clip[1], 4);
        want[2] = expected->nodes[i].word;
        differ += memcmp(texels[i], want, sizeof want) != 0;
    }
    for (size_t v = 0; v < 3 * n; v++)
        differ += memcmp(vertices[v], expected->vertices[v], sizeof vertices[v]) != 0;
    free(texels);
    free(vertices);
    return differ;
}

/* Refits built (on the device too) to moved both ways and compares everything. */
static void refit_both_ways(const char *label, const pf_bih *built, const pf_scene_frame *moved)
{
    pf_error err = {0};
    pf_bih on_host, from_device;
    PF_REQUIRE(copy_tree(built, &on_host) && copy_tree(built, &from_device));
    PF_CHECK_OK(pf_bih_refit(&on_host, moved, &err), &err);
    pf_bih_gpu_refit_report report;
    PF_CHECK_OK(pf_bih_refit_gpu(env.builder, env.gpu, &from_device, moved, &report, &err), &err);
    size_t differ = device_differs(&on_host);
    PF_CHECK_MSG(differ == 0, "%s: %zu node texels or vertices differ from the host's refit",
                 label, differ);
    /* The host's copy: vertices and box current at once, its clips after the second half. */
    size_t n = on_host.triangle_count;
    PF_CHECK_MSG(!memcmp(from_device.vertices, on_host.vertices,
                         3 * n * sizeof *on_host.vertices) &&
                     !memcmp(from_device.bounds_min, on_host.bounds_min,
                             sizeof on_host.bounds_min) &&
                     !memcmp(from_device.bounds_max, on_host.bounds_max,
                             sizeof on_host.bounds_max),
                 "%s: the host's vertices or box differ", label);
    double sah = sah_of(&on_host);
    PF_CHECK_MSG(fabs(report.sah_cost - sah) <= 1e-4 * sah + 1e-6,
                 "%s: device SAH %.7g, host %.7g", label, report.sah_cost, sah);
    PF_CHECK_OK(pf_bih_refit_bounds(&from_device, &err), &err);
    PF_CHECK_MSG(same_tree(&from_device, &on_host), "%s: host copy differs after its bounds",
                 label);
    pf_bih_free(&on_host);
    pf_bih_free(&from_device);
}

PF_TEST(device_refits_are_the_hosts_bit_for_bit)
{
    const int cases[] = {BIH_CASE_SOUP,        BIH_CASE_CUBE,      BIH_CASE_CUBE_LARGE,
                         BIH_CASE_SOUP_OFFSET, BIH_CASE_FLAT,      BIH_CASE_COPLANAR,
                         BIH_CASE_DEGENERATE,  BIH_CASE_CLUSTERED, BIH_CASE_ONE,
                         BIH_CASE_ZERO};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        pf_scene_frame original;
        const char *name;
        PF_REQUIRE(bih_make_case(cases[i], &original, &name));
        for (int kind = 0; kind < BUILD_KINDS; kind++) {
            pf_bih built;
            if (!build_on_device((build_kind)kind, &original, &built))
                continue;
            for (int how = 0; how < MOTION_COUNT; how++) {
                pf_scene_frame moved;
                PF_REQUIRE(moved_copy(&original, (motion)how, &moved));
                /* The device holds built again: each motion refits the tree as built. */
                if (how > 0) {
                    pf_error err = {0};
                    PF_CHECK_OK(pf_bih_gpu_upload(env.gpu, &built, &err), &err);
                }
                char label[96];
                snprintf(label, sizeof label, "%s, %s build, %s", name, build_names[kind],
                         motion_names[how]);
                refit_both_ways(label, &built, &moved);
                bih_frame_free(&moved);
            }
            pf_bih_free(&built);
        }
        bih_frame_free(&original);
    }
}

/* A tree of more nodes than the sum's lanes have groups, refit twice in a row on the device. */
PF_TEST(a_large_tree_refits_twice)
{
    pf_scene_frame original;
    PF_REQUIRE(bih_make_bumpy_sphere(&original, LARGE_TRIANGLES));
    pf_bih built;
    PF_REQUIRE(build_on_device(BUILD_GPU, &original, &built));
    printf("  %u triangles, %u nodes\n", original.triangle_count, built.node_count);
    PF_CHECK(built.node_count > 256u * 256u);
    pf_scene_frame jittered, deformed;
    PF_REQUIRE(moved_copy(&original, MOTION_JITTER, &jittered));
    PF_REQUIRE(moved_copy(&original, MOTION_DEFORM, &deformed));
    pf_error err = {0};
    /* The host's copy follows the device's refits as the renderer keeps it. */
    pf_bih device_copy;
    PF_REQUIRE(copy_tree(&built, &device_copy));
    PF_CHECK_OK(pf_bih_refit_gpu(env.builder, env.gpu, &device_copy, &jittered, NULL, &err),
                &err);
    refit_both_ways("bumpy sphere, jitter then deform", &built, &deformed);
    pf_bih_free(&device_copy);
    pf_bih_free(&built);
    bih_frame_free(&jittered);
    bih_frame_free(&deformed);
    bih_frame_free(&original);
}

/* Issue 44: the vertices' upload, the passes and the readback of the cost and the root
 * box are one submission and one wait, mapped (lavapipe) or staged (a GPU). */
PF_TEST(the_device_refit_is_one_submission)
{
    pf_scene_frame original, moved;
    PF_REQUIRE(bih_make_soup(&original, 5000, 37));
    PF_REQUIRE(moved_copy(&original, MOTION_JITTER, &moved));
    uint64_t n = original.triangle_count;
    pf_bih built;
    PF_REQUIRE(build_on_device(BUILD_GPU, &original, &built));
    for (int staged = 0; staged < 2; staged++) {
        pf_vk_force_staging(env.ctx, staged);
        pf_error err = {0};
        pf_bih_gpu_refit_report report;
        pf_vk_traffic before = pf_vk_traffic_of(env.ctx);
        PF_CHECK_OK(pf_bih_refit_gpu(env.builder, env.gpu, &built, staged ? &original : &moved,
                                     &report, &err),
                    &err);
        pf_vk_traffic used = pf_vk_traffic_since(env.ctx, before);
        PF_CHECK_MSG(used.submits == 1 && used.host_waits == 1 && used.readback_bytes == 52 &&
                         used.upload_bytes == 3 * n * 16,
                     "%s: %llu submits, %llu waits, %llu B back, %llu B up",
                     staged ? "staged" : "mapped", (unsigned long long)used.submits,
                     (unsigned long long)used.host_waits,
                     (unsigned long long)used.readback_bytes,
                     (unsigned long long)used.upload_bytes);
        /* Its passes' device times add up to the whole. */
        if (report.gpu_ms >= 0.0) {
            double passes = 0.0;
            for (int p = 0; p < PF_BIH_REFIT_PASSES; p++)
                passes += report.pass_ms[p];
            PF_CHECK_NEAR(passes, report.gpu_ms, 1e-6 + 1e-9 * passes);
        }
    }
    pf_vk_force_staging(env.ctx, 0);
    pf_bih_free(&built);
    bih_frame_free(&original);
    bih_frame_free(&moved);
}

PF_TEST(refused_input_changes_neither_copy)
{
    pf_scene_frame original, bad;
    PF_REQUIRE(bih_make_soup(&original, 500, 5));
    PF_REQUIRE(moved_copy(&original, MOTION_JITTER, &bad));
    bad.vertices[3 * 123 + 2][1] = INFINITY;
    pf_bih built, tree;
    PF_REQUIRE(build_on_device(BUILD_GPU, &original, &built));
    PF_REQUIRE(copy_tree(&built, &tree));
    pf_error err = {0};
    PF_CHECK(pf_bih_refit_gpu(env.builder, env.gpu, &tree, &bad, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "triangle 123") != NULL, "%s", err.message);
    PF_CHECK(same_tree(&tree, &built) && device_differs(&built) == 0);
    /* A host tree that is not the device's: refused by its counts. */
    pf_scene_frame other;
    PF_REQUIRE(bih_make_soup(&other, 700, 6));
    pf_bih other_tree;
    PF_REQUIRE_OK(pf_bih_build_cpu(&other, NULL, &other_tree, &err), &err);
    err = (pf_error){0};
    PF_CHECK(pf_bih_refit_gpu(env.builder, env.gpu, &other_tree, &other, NULL, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(device_differs(&built) == 0);
    pf_bih_free(&other_tree);
    pf_bih_free(&tree);
    pf_bih_free(&built);
    bih_frame_free(&other);
    bih_frame_free(&bad);
    bih_frame_free(&original);
}

int main(void)
{
    if (!bih_gpu_env_create(&env))
        return 1;
    PF_RUN(device_refits_are_the_hosts_bit_for_bit);
    PF_RUN(a_large_tree_refits_twice);
    PF_RUN(the_device_refit_is_one_submission);
    PF_RUN(refused_input_changes_neither_copy);
    bih_gpu_env_destroy(&env);
    return pf_test_finish();
}
