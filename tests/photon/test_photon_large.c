/*
 * Photon maps at the size of a whole buffer (label "large"): 6M photons
 * traced, about 5.9M stored in one map (119 MB of lavapipe's 128 MiB buffer
 * limit) and gridded, checked by their stored flux and by gathers against
 * brute force; and a budget whose maps could overflow one buffer (15
 * stores per photon at the default depth), split by pf_photon_plan_passes
 * into passes traced and gridded one at a time whose combined flux is the
 * closed box's.
 */
#include "../vk/vk_test_util.h"
#include "photon_test_box.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static box_tracer bt;

#define LARGE_PHOTONS 6000000u
/* Nearly white walls: roulette keeps 99% of the photons for their second hit. */
#define LARGE_ALBEDO 0.99f
#define SPLIT_BUDGET 1000000u
#define SPLIT_ALBEDO 0.5f
/* Gathers checked against brute force over the whole map. */
#define GATHER_QUERIES 16u
#define GATHER_CAPACITY 8192u

static void box_with_light(box_scene *s, float albedo)
{
    box_init(s, albedo);
    s->frame.light_count = 1;
    s->lights[0] = (pf_light){.position = {0.1f, 0.2f, -0.3f}, .kind = PF_LIGHT_POINT,
                              .intensity = {1.0f, 1.0f, 1.0f}};
}

/* Grids a pass's global map on the device; checks a few gathers against brute force on photons. */
static void grid_and_gather(const pf_photon_maps *maps, const pf_photon *photons,
                            const box_scene *s)
{
    pf_error err = {0};
    pf_photon_grid *grid = NULL;
    const float radius = 0.05f;
    PF_REQUIRE_OK(pf_photon_grid_create(bt.ctx, &grid, &err), &err);
    PF_CHECK_OK(pf_photon_grid_build_device(grid, maps->global, maps->global_count,
                                            s->frame.bounds_min, s->frame.bounds_max, radius, &err),
                &err);
    pf_photon_grid_info info;
    PF_CHECK_OK(pf_photon_grid_stats(grid, &info, &err), &err);
    float queries[GATHER_QUERIES][4];
    uint32_t counts[GATHER_QUERIES];
    uint32_t *indices = malloc((size_t)GATHER_QUERIES * GATHER_CAPACITY * sizeof *indices);
    PF_REQUIRE(indices != NULL);
    for (uint32_t q = 0; q < GATHER_QUERIES; q++) {
        const pf_photon *p = &photons[(uint64_t)q * maps->global_count / GATHER_QUERIES];
        memcpy(queries[q], p->position, sizeof p->position);
        queries[q][3] = 0.02f;
    }
    PF_CHECK_OK(pf_photon_grid_gather(grid, queries, GATHER_QUERIES, GATHER_CAPACITY, counts,
                                      indices, &err),
                &err);
    uint32_t expected[GATHER_QUERIES] = {0};
    for (uint32_t i = 0; i < maps->global_count; i++) {
        for (uint32_t q = 0; q < GATHER_QUERIES; q++) {
            float d[3] = {photons[i].position[0] - queries[q][0],
                          photons[i].position[1] - queries[q][1],
                          photons[i].position[2] - queries[q][2]};
            expected[q] += (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2] <= queries[q][3] * queries[q][3];
        }
    }
    uint32_t differ = 0, found = 0;
    for (uint32_t q = 0; q < GATHER_QUERIES; q++) {
        differ += counts[q] != expected[q];
        found += counts[q];
    }
    printf("  grid over %u photons: %s table of %u (%u occupied, largest %u), build %.1f GPU ms; "
           "%u gathers found %u photons\n",
           info.photon_count, info.hashed ? "hashed" : "dense", info.table_size, info.occupied,
           info.largest, pf_photon_grid_gpu_ms(grid), GATHER_QUERIES, found);
    PF_CHECK(info.photon_count == maps->global_count && info.occupied > 0);
    PF_CHECK_MSG(differ == 0, "%u of %u gathers differ from brute force", differ, GATHER_QUERIES);
    free(indices);
    pf_photon_grid_destroy(grid);
}

PF_TEST(six_million_photons_in_one_buffer)
{
    /* Two hits: each emitted photon stores at most one (its first bounce): 6M fit one buffer. */
    pf_error err = {0};
    pf_photon_pass_plan plan;
    PF_REQUIRE_OK(pf_photon_plan_passes(bt.ctx, LARGE_PHOTONS, 1, &plan, &err), &err);
    PF_CHECK(plan.passes == 1 && plan.photons_per_pass == LARGE_PHOTONS &&
             plan.capacity == LARGE_PHOTONS);
    box_scene s;
    box_with_light(&s, LARGE_ALBEDO);
    pf_photon_trace_settings settings = {.photon_count = LARGE_PHOTONS, .seed = 31, .max_depth = 2,
                                         .global_capacity = plan.capacity, .caustic_capacity = 1};
    pf_photon_maps maps;
    pf_photon *global = NULL;
    PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, NULL, &err), &err);
    double sum[3];
    box_flux_sum(global, maps.global_count, maps.flux_scale, sum);
    double expected = LARGE_ALBEDO * 4.0 * M_PI;
    printf("  %u emitted, %u stored (%.1f MB), trace %.0f GPU ms: %.4f W, closed form %.4f W\n",
           maps.emitted, maps.global_count, maps.global_count * 20.0 / 1e6, maps.gpu_ms, sum[1],
           expected);
    PF_CHECK(maps.emitted == LARGE_PHOTONS && maps.global_offered == maps.global_count);
    PF_CHECK_MSG(maps.global_count > LARGE_PHOTONS * 0.98, "%u stored", maps.global_count);
    PF_CHECK_MSG(fabs(sum[1] / expected - 1.0) < 0.01, "stored %.4f W, expected %.4f W", sum[1],
                 expected);
    grid_and_gather(&maps, global, &s);
    free(global);
    pf_photon_maps_release(bt.ctx, &maps);
}

PF_TEST(a_budget_beyond_one_buffer_is_split_into_passes)
{
    /*
     * At the default depth (16 hits) a photon may store up to 15 records:
     * 1M photons could need 15M, beyond one buffer of lavapipe (128 MiB),
     * so the plan splits the budget into passes whose maps cannot overflow;
     * the passes' flux, weighted by their share, is the closed box's
     * Φ Σ_{k=1}^{15} a^k. A device with larger buffers (4 GiB on an H200)
     * gets a budget of 1.5 of its passes, so that it splits too.
     */
    pf_error err = {0};
    pf_photon_pass_plan plan;
    const uint32_t max_depth = PF_PHOTON_DEFAULT_MAX_DEPTH;
    uint64_t fits = pf_vk_info(bt.ctx)->max_storage_buffer_range / sizeof(pf_photon);
    uint64_t one_pass = fits / (max_depth - 1);
    const uint32_t budget = (uint32_t)(one_pass * 3 / 2 > SPLIT_BUDGET ? one_pass * 3 / 2
                                                                       : SPLIT_BUDGET);
    PF_REQUIRE_OK(pf_photon_plan_passes(bt.ctx, budget, max_depth - 1, &plan, &err), &err);
    printf("  plan: %u passes of %u photons (last %u), capacity %u (%llu fit one buffer)\n",
           plan.passes, plan.photons_per_pass, plan.last_pass_photons, plan.capacity,
           (unsigned long long)fits);
    PF_CHECK(plan.passes >= 2 && plan.capacity <= fits);
    PF_CHECK((uint64_t)(plan.passes - 1) * plan.photons_per_pass + plan.last_pass_photons ==
             budget);
    box_scene s;
    box_with_light(&s, SPLIT_ALBEDO);
    double total = 0.0;
    for (uint32_t p = 0; p < plan.passes; p++) {
        uint32_t photons = p + 1 == plan.passes ? plan.last_pass_photons : plan.photons_per_pass;
        pf_photon_trace_settings settings = {.photon_count = photons, .seed = 40 + p,
                                             .max_depth = max_depth,
                                             .global_capacity = plan.capacity,
                                             .caustic_capacity = 1};
        pf_photon_maps maps;
        pf_photon *global = NULL;
        PF_REQUIRE_OK(box_trace(&bt, &s, &settings, &maps, &global, NULL, &err), &err);
        PF_CHECK_MSG(maps.global_offered == maps.global_count, "pass %u: map overflowed", p);
        double sum[3];
        box_flux_sum(global, maps.global_count, maps.flux_scale, sum);
        total += (double)photons / budget * sum[1];
        if (p == 0)
            grid_and_gather(&maps, global, &s);
        free(global);
        pf_photon_maps_release(bt.ctx, &maps);
    }
    double expected = 4.0 * M_PI * (1.0 - pow(SPLIT_ALBEDO, max_depth - 1)) * SPLIT_ALBEDO /
                      (1.0 - SPLIT_ALBEDO);
    printf("  %u passes: %.4f W, closed form %.4f W\n", plan.passes, total, expected);
    PF_CHECK_MSG(fabs(total / expected - 1.0) < 0.01, "stored %.4f W, expected %.4f W", total,
                 expected);
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
    PF_RUN(six_million_photons_in_one_buffer);
    PF_RUN(a_budget_beyond_one_buffer_is_split_into_passes);
    pf_bih_gpu_destroy(bt.bih_gpu);
    pf_photon_tracer_destroy(bt.tracer);
    VK_TEST_FINISH(bt.ctx);
    return pf_test_finish();
}
