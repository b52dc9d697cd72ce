/*
 * GPU photon tracing: energy (in a closed diffuse box the first-bounce
 * photons carry the emitted power × albedo, within 1%), the storage rules
 * (no caustic map without specular surfaces; caustic photons behind a
 * mirror), colour kept through roulette, the same photons however many an
 * invocation traces, and the hard cases: a light
 * touching a wall, a zero-power light, a map budget beyond one buffer.
 */
#include "../vk/vk_test_util.h"
#include "photon_test_box.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static box_tracer bt;

PF_TEST(first_bounce_flux_equals_power_times_albedo)
{
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.1f, 0.2f, -0.3f}, .kind = PF_LIGHT_POINT,
                             .intensity = {2.0f, 1.0f, 0.5f}};
    /* Two hits: photons are stored only at their second hit (the first bounce). */
    pf_photon_trace_settings settings = {.photon_count = 1000000, .seed = 7, .max_depth = 2};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    double sum[3];
    box_flux_sum(global, maps.global_count, maps.flux_scale, sum);
    const double power[3] = {4 * M_PI * 2.0, 4 * M_PI * 1.0, 4 * M_PI * 0.5};
    for (int c = 0; c < 3; c++)
        PF_CHECK_MSG(fabs(sum[c] / (0.5 * power[c]) - 1.0) < 0.01,
                     "channel %d: stored %.4f W, expected %.4f W", c, sum[c], 0.5 * power[c]);
    printf("  stored %u photons (of %u emitted): %.4f %.4f %.4f W, expected %.4f %.4f %.4f\n",
           maps.global_count, maps.emitted, sum[0], sum[1], sum[2], 0.5 * power[0],
           0.5 * power[1], 0.5 * power[2]);
    PF_CHECK(maps.caustic_count == 0 && maps.caustic_offered == 0);
    PF_CHECK(maps.global_offered == maps.global_count);
    PF_CHECK(maps.non_finite == 0);
    /* Every photon lies on the box's surface. */
    uint32_t off_surface = 0;
    for (uint32_t i = 0; i < maps.global_count; i++) {
        float m = fmaxf(fabsf(global[i].position[0]),
                        fmaxf(fabsf(global[i].position[1]), fabsf(global[i].position[2])));
        off_surface += fabsf(m - 1.0f) > 1e-3f;
    }
    PF_CHECK_MSG(off_surface == 0, "%u photons off the walls", off_surface);
    free(global);
    free(caustic);
    pf_photon_maps_release(bt.ctx, &maps);
}

PF_TEST(all_bounces_converge_to_the_closed_box_total)
{
    /*
     * A closed box with albedo a: the stored flux of all bounces after the
     * first sums to Φ (a + a² + …) = Φ a / (1 − a), truncated at max_depth
     * hits: Φ Σ_{k=1}^{depth-1} a^k.
     */
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.0f, 0.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 200000, .seed = 11, .max_depth = 8};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    double sum[3];
    box_flux_sum(global, maps.global_count, maps.flux_scale, sum);
    double expected = 0.0;
    for (int k = 1; k < 8; k++)
        expected += pow(0.5, k);
    expected *= 4 * M_PI;
    PF_CHECK_MSG(fabs(sum[1] / expected - 1.0) < 0.01, "stored %.4f W, expected %.4f W", sum[1],
                 expected);
    free(global);
    free(caustic);
    pf_photon_maps_release(bt.ctx, &maps);
}

/* A mirror quad 1 m wide on the plane y = -0.9 of a box of albedo `albedo`, under a spot
 * 1.4 m above it aimed straight down with the given cone: L S D photons reach the floor. */
static void mirror_under_spot(box_scene *s, float albedo, float cos_inner, float cos_outer)
{
    box_init(s, albedo);
    const float a[3] = {-0.5f, -0.9f, -0.5f}, b[3] = {0.5f, -0.9f, -0.5f},
                c[3] = {0.5f, -0.9f, 0.5f}, d[3] = {-0.5f, -0.9f, 0.5f};
    box_add_quad(s, a, d, c, b, 1);
    s->frame.light_count = 1;
    s->lights[0] = (pf_light){.position = {0.0f, 0.5f, 0.0f}, .kind = PF_LIGHT_SPOT,
                              .direction = {0.0f, -1.0f, 0.0f}, .intensity = {1.0f, 1.0f, 1.0f},
                              .cos_inner_cone = cos_inner, .cos_outer_cone = cos_outer};
}

PF_TEST(caustic_photons_need_a_specular_bounce)
{
    /* A mirror quad inside the box under a spot aimed at it: L S D photons go to the caustic map. */
    box_scene s;
    mirror_under_spot(&s, 0.8f, 0.95f, 0.9f);
    pf_photon_trace_settings settings = {.photon_count = 100000, .seed = 3, .max_depth = 2};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    /*
     * The cone (half-angle 25.8°) from 1.4 m above the mirror covers a disk
     * of radius 0.68 m, most of it on the 1 m mirror. With two hits only
     * first-bounce photons are stored: L S D ones (off the mirror, so above
     * its plane) in both maps, L D D ones (off the floor) in the global map.
     */
    PF_CHECK_MSG(maps.caustic_count > settings.photon_count * 2 / 5, "%u caustic photons",
                 maps.caustic_count);
    PF_CHECK(maps.global_count > maps.caustic_count);
    uint32_t below_mirror = 0;
    for (uint32_t i = 0; i < maps.caustic_count; i++)
        below_mirror += caustic[i].position[1] < -0.9f;
    PF_CHECK_MSG(below_mirror == 0, "%u caustic photons below the mirror", below_mirror);
    free(global);
    free(caustic);
    pf_photon_maps_release(bt.ctx, &maps);
}

PF_TEST(hard_cases_light_on_a_wall_zero_power_and_a_budget_beyond_memory)
{
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.light_count = 1;
    /* Exactly on the floor: half the photons start below it, nothing crashes, loops stay bounded. */
    s.lights[0] = (pf_light){.position = {0.0f, -1.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 50000, .seed = 5};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_CHECK_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    PF_CHECK(maps.non_finite == 0);
    free(global);
    free(caustic);
    pf_photon_maps_release(bt.ctx, &maps);

    s.lights[0].intensity[0] = s.lights[0].intensity[1] = s.lights[0].intensity[2] = 0.0f;
    PF_CHECK_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    PF_CHECK(maps.emitted == 0 && maps.global_count == 0 && maps.caustic_count == 0);
    pf_photon_maps_release(bt.ctx, &maps);

    s.lights[0].intensity[0] = 1.0f;
    settings.global_capacity = (uint32_t)(pf_vk_info(bt.ctx)->max_storage_buffer_range / 20) + 1;
    PF_CHECK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err) == PF_ERR_LIMIT);
    PF_CHECK_MSG(strstr(err.message, "fit") != NULL, "%s", err.message);

    /*
     * A budget far beyond memory (10^15 photons, up to 15 stores each: 300 PB
     * of records) is split into passes that each fit one buffer; one beyond
     * UINT32_MAX passes is refused with the figures.
     */
    pf_photon_pass_plan plan;
    uint64_t fits = pf_vk_info(bt.ctx)->max_storage_buffer_range / sizeof(pf_photon);
    PF_CHECK_OK(pf_photon_plan_passes(bt.ctx, 1000000000000000ull, 15, &plan, &err), &err);
    PF_CHECK(plan.capacity <= fits && plan.capacity == plan.photons_per_pass * 15u);
    PF_CHECK((uint64_t)(plan.passes - 1) * plan.photons_per_pass + plan.last_pass_photons ==
             1000000000000000ull);
    PF_CHECK(pf_photon_plan_passes(bt.ctx, UINT64_MAX, 15, &plan, &err) == PF_ERR_LIMIT);
    PF_CHECK_MSG(strstr(err.message, "passes") != NULL, "%s", err.message);
    PF_CHECK(pf_photon_plan_passes(bt.ctx, 1000, (uint32_t)fits + 1, &plan, &err) == PF_ERR_LIMIT);
    PF_CHECK(pf_photon_plan_passes(bt.ctx, 0, 1, &plan, &err) == PF_ERR_INVALID);
    /* A small budget is one pass of itself. */
    PF_CHECK_OK(pf_photon_plan_passes(bt.ctx, 1000, 0, &plan, &err), &err);
    PF_CHECK(plan.passes == 1 && plan.photons_per_pass == 1000 && plan.last_pass_photons == 1000);
}

PF_TEST(irradiance_under_a_point_light_matches_the_closed_form)
{
    /* A plane 1 m below a point light: E = I h / d³; photons stored at their first hit. */
    box_scene s;
    box_init(&s, 0.5f);
    s.frame.triangle_count = 0;
    const float a[3] = {-4, 0, -4}, b[3] = {4, 0, -4}, c[3] = {4, 0, 4}, d[3] = {-4, 0, 4};
    box_add_quad(&s, a, b, c, d, 0);
    for (int k = 0; k < 3; k++) {
        s.frame.bounds_min[k] = k == 1 ? 0.0f : -4.0f;
        s.frame.bounds_max[k] = k == 1 ? 0.0f : 4.0f;
    }
    s.frame.light_count = 1;
    s.lights[0] = (pf_light){.position = {0.0f, 1.0f, 0.0f}, .kind = PF_LIGHT_POINT,
                             .intensity = {1.0f, 1.0f, 1.0f}};
    pf_photon_trace_settings settings = {.photon_count = 4000000, .seed = 21, .max_depth = 1,
                                         .store_direct = 1};
    pf_photon_maps maps;
    pf_photon *global = NULL, *caustic = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, &caustic, &err), &err);
    pf_photon_grid *grid = NULL;
    const float radius = 0.1f;
    PF_REQUIRE_OK(pf_photon_grid_create(bt.ctx, &grid, &err), &err);
    PF_REQUIRE_OK(pf_photon_grid_build_device(grid, maps.global, maps.global_count,
                                              s.frame.bounds_min, s.frame.bounds_max, radius, &err),
                  &err);
    /* The centre, and 8 points on a ring of radius 0.5 m (same closed form, independent photons). */
    enum { RING = 8 };
    float queries[1 + RING][4], normals[1 + RING][4], irradiance[1 + RING][4];
    for (int q = 0; q <= RING; q++) {
        float angle = 6.2831853f * (float)q / RING;
        float rho = q == 0 ? 0.0f : 0.5f;
        queries[q][0] = rho * cosf(angle);
        queries[q][1] = 0.0f;
        queries[q][2] = rho * sinf(angle);
        queries[q][3] = radius;
        normals[q][0] = normals[q][2] = normals[q][3] = 0.0f;
        normals[q][1] = 1.0f;
    }
    PF_REQUIRE_OK(pf_photon_grid_irradiance(grid, queries, normals, 1 + RING, irradiance, &err),
                  &err);
    double centre = irradiance[0][1] * maps.flux_scale;
    double ring = 0.0;
    for (int q = 1; q <= RING; q++)
        ring += irradiance[q][1] * maps.flux_scale / RING;
    double ring_expected = 1.0 / pow(1.25, 1.5);
    printf("  irradiance: centre %.4f (closed form 1), ring %.4f (closed form %.4f), %u photons\n",
           centre, ring, ring_expected, maps.global_count);
    PF_CHECK_MSG(fabs(centre - 1.0) < 0.02, "centre %.4f W/m², closed form 1", centre);
    PF_CHECK_MSG(fabs(ring / ring_expected - 1.0) < 0.02, "ring %.4f, closed form %.4f", ring,
                 ring_expected);
    /*
     * The k-nearest estimate (k = 64) on three rings of 160 queries each,
     * against each ring's closed form I h / (h² + ρ²)^1.5. One k-NN estimate
     * has a relative deviation of about 1/√(k − 2) = 13% (π r_k² λ is
     * Gamma(k) distributed) and a bias of +0.37% (the k-th photon's cone
     * weight over the k − 1 inside); the disks (r_k ≈ 1 cm) barely overlap,
     * so the mean ratio of 480 queries deviates by about 0.6%.
     */
    enum { KNN_RINGS = 3, KNN_PER_RING = 160, KNN_QUERIES = KNN_RINGS * KNN_PER_RING };
    const uint32_t knn_k = 64;
    float (*knn_queries)[4] = malloc(KNN_QUERIES * sizeof *knn_queries);
    float (*knn_normals)[4] = malloc(KNN_QUERIES * sizeof *knn_normals);
    float (*knn_result)[4] = malloc(KNN_QUERIES * sizeof *knn_result);
    PF_REQUIRE(knn_queries && knn_normals && knn_result);
    for (int q = 0; q < KNN_QUERIES; q++) {
        float rho = 0.25f * (float)(1 + q / KNN_PER_RING);
        float angle = 6.2831853f * (float)(q % KNN_PER_RING) / KNN_PER_RING;
        knn_queries[q][0] = rho * cosf(angle);
        knn_queries[q][1] = 0.0f;
        knn_queries[q][2] = rho * sinf(angle);
        knn_queries[q][3] = radius;
        knn_normals[q][0] = knn_normals[q][2] = knn_normals[q][3] = 0.0f;
        knn_normals[q][1] = 1.0f;
    }
    PF_REQUIRE_OK(pf_photon_grid_irradiance_knn(grid, knn_queries, knn_normals, KNN_QUERIES, knn_k,
                                                knn_result, &err),
                  &err);
    double knn_ratio = 0.0;
    uint32_t short_of_k = 0;
    for (int q = 0; q < KNN_QUERIES; q++) {
        double rho = 0.25 * (1 + q / KNN_PER_RING);
        knn_ratio += knn_result[q][1] * maps.flux_scale * pow(1.0 + rho * rho, 1.5) / KNN_QUERIES;
        short_of_k += knn_result[q][3] >= radius;
    }
    printf("  k-NN (k = %u): mean ratio to the closed form %.4f over %d queries, radius %.4f m at the first\n",
           knn_k, knn_ratio, KNN_QUERIES, (double)knn_result[0][3]);
    PF_CHECK_MSG(fabs(knn_ratio - 1.0) < 0.02, "k-NN mean ratio %.4f", knn_ratio);
    PF_CHECK_MSG(short_of_k == 0, "%u queries found fewer than k photons", short_of_k);
    free(knn_queries);
    free(knn_normals);
    free(knn_result);
    /* Seen from below (normal -y) the plane's photons arrived from the other side: none count. */
    for (int q = 0; q <= RING; q++)
        normals[q][1] = -1.0f;
    PF_REQUIRE_OK(pf_photon_grid_irradiance(grid, queries, normals, 1 + RING, irradiance, &err),
                  &err);
    PF_CHECK(irradiance[0][0] == 0.0f && irradiance[1][1] == 0.0f);
    pf_photon_grid_destroy(grid);
    free(global);
    free(caustic);
    pf_photon_maps_release(bt.ctx, &maps);
}

/* Byte order of two photon records, to compare maps as sets. */
static int photon_order(const void *a, const void *b)
{
    return memcmp(a, b, sizeof(pf_photon));
}

/* Two traces' maps hold the same records (sorted, byte for byte); frees them. */
static void check_same_photons(pf_photon_maps maps[2], pf_photon *global[2],
                               pf_photon *caustic[2])
{
    PF_CHECK(maps[0].global_count == maps[1].global_count &&
             maps[0].caustic_count == maps[1].caustic_count);
    if (maps[0].global_count == maps[1].global_count)
        PF_CHECK(memcmp(global[0], global[1], maps[0].global_count * sizeof(pf_photon)) == 0);
    if (maps[0].caustic_count == maps[1].caustic_count)
        PF_CHECK(memcmp(caustic[0], caustic[1], maps[0].caustic_count * sizeof(pf_photon)) == 0);
    for (int run = 0; run < 2; run++) {
        free(global[run]);
        free(caustic[run]);
        pf_photon_maps_release(bt.ctx, &maps[run]);
    }
}

PF_TEST(photons_shared_by_an_invocation_are_the_same_photons)
{
    /* photon_trace.comp traces several photons per invocation, a lane starting its next photon
     * where the last ended; photon i's path depends on i alone, so one per invocation stores
     * the same records, the caustic ones included (a mirror under the spot), in another order. */
    box_scene s;
    mirror_under_spot(&s, 0.7f, 0.7f, 0.5f);
    pf_photon_maps maps[2];
    pf_photon *global[2] = {NULL, NULL}, *caustic[2] = {NULL, NULL};
    for (int run = 0; run < 2; run++) {
        /* 70,001: not a multiple of the photons per invocation nor of a workgroup's. */
        pf_photon_trace_settings settings = {
            .photon_count = 70001, .seed = 9,
            .per_invocation = run == 0 ? 1u : PF_PHOTON_TRACE_PER_INVOCATION};
        pf_error err = {0};
        PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps[run], &global[run], &caustic[run], &err),
                      &err);
        qsort(global[run], maps[run].global_count, sizeof(pf_photon), photon_order);
        qsort(caustic[run], maps[run].caustic_count, sizeof(pf_photon), photon_order);
    }
    PF_CHECK(maps[0].per_invocation == 1 && maps[1].per_invocation == PF_PHOTON_TRACE_PER_INVOCATION);
    printf("  %u global and %u caustic photons, 1 and %u per invocation\n", maps[0].global_count,
           maps[0].caustic_count, maps[1].per_invocation);
    PF_CHECK(maps[0].global_count > 70001 && maps[0].caustic_count > 1000);
    check_same_photons(maps, global, caustic);
}

PF_TEST(photons_traced_in_waves_by_the_host_are_the_same_photons)
{
    /* Issue 43: where the device is the CPU the host traces the photons' rays between waves of
     * one bounce each (photon_trace_wave.c); photon_start and photon_bounce are the flat
     * loop's, so the maps hold the same records, in another order. 70,001 photons in waves of
     * at most 2^18: one batch; a second run of 300,001 takes two. */
    if (!pf_vk_device_is_cpu(bt.ctx) || !pf_bih_wide_available()) {
        printf("  skipped: the host traces only where the device is the CPU, with AVX2\n");
        return;
    }
    box_scene s;
    mirror_under_spot(&s, 0.7f, 0.7f, 0.5f);
    const uint32_t counts[2] = {70001, 300001};
    for (int c = 0; c < 2; c++) {
        pf_photon_maps maps[2];
        pf_photon *global[2] = {NULL, NULL}, *caustic[2] = {NULL, NULL};
        int traced = 1;
        for (int run = 0; run < 2 && traced; run++) {
            pf_photon_trace_settings settings = {.photon_count = counts[c], .seed = 9};
            pf_error err = {0};
            bt.host_traces = run;
            pf_status status = box_trace(&bt, &s, &settings, &maps[run], &global[run],
                                         &caustic[run], &err);
            bt.host_traces = 0;
            PF_CHECK_MSG(status == PF_OK, "%s", err.message);
            traced = status == PF_OK;
            if (traced) {
                qsort(global[run], maps[run].global_count, sizeof(pf_photon), photon_order);
                qsort(caustic[run], maps[run].caustic_count, sizeof(pf_photon), photon_order);
            }
        }
        if (!traced)
            return;
        printf("  %u photons: %u global and %u caustic photons; %u waves, host trace %.1f ms\n",
               counts[c], maps[1].global_count, maps[1].caustic_count, maps[1].waves,
               maps[1].host_trace_ms);
        PF_CHECK(maps[0].waves == 0 && maps[1].waves >= 2);
        PF_CHECK(maps[0].global_count > counts[c] && maps[0].caustic_count > 1000);
        check_same_photons(maps, global, caustic);
    }
}

int main(void)
{
    pf_error err = {0};
    bt.ctx = vk_test_context(&err);
    if (!bt.ctx || pf_photon_tracer_create(bt.ctx, &bt.tracer, &err) != PF_OK ||
        pf_bih_gpu_create(bt.ctx, &bt.bih_gpu, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(first_bounce_flux_equals_power_times_albedo);
    PF_RUN(all_bounces_converge_to_the_closed_box_total);
    PF_RUN(caustic_photons_need_a_specular_bounce);
    PF_RUN(photons_shared_by_an_invocation_are_the_same_photons);
    PF_RUN(photons_traced_in_waves_by_the_host_are_the_same_photons);
    PF_RUN(hard_cases_light_on_a_wall_zero_power_and_a_budget_beyond_memory);
    PF_RUN(irradiance_under_a_point_light_matches_the_closed_form);
    pf_bih_gpu_destroy(bt.bih_gpu);
    pf_photon_tracer_destroy(bt.tracer);
    VK_TEST_FINISH(bt.ctx);
    return pf_test_finish();
}
