/*
 * The GPU photon grid: on random queries its gather returns exactly the
 * photon set of a brute-force gather (dense grid, hashed grid, photons on
 * cell borders, all photons in one spot, an empty map: the counting sort
 * places every photon in its cell), and bad input is refused with a clear
 * error.
 */
#include "../vk/vk_test_util.h"
#include "pf_photon.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

static pf_vk_context *ctx;
static pf_photon_grid *grid;

static uint32_t next_random(uint32_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    return *state;
}

static float uniform(uint32_t *state, float low, float high)
{
    return low + (high - low) * (float)(next_random(state) >> 8) / 16777216.0f;
}

static void make_photon(pf_photon *photon, float x, float y, float z)
{
    float position[3] = {x, y, z}, flux[3] = {1.0f, 1.0f, 1.0f};
    float incoming[3] = {0.0f, -1.0f, 0.0f}, normal[3] = {0.0f, 1.0f, 0.0f};
    pf_photon_pack(position, flux, incoming, normal, photon);
}

/* The brute-force answer, with the same float expression as photon_gather_probe.comp. */
static uint32_t brute_gather(const pf_photon *photons, uint32_t count, const float query[4],
                             uint32_t *found, uint32_t capacity)
{
    uint32_t n = 0;
    float radius2 = query[3] * query[3];
    for (uint32_t i = 0; i < count; i++) {
        float d[3] = {photons[i].position[0] - query[0], photons[i].position[1] - query[1],
                      photons[i].position[2] - query[2]};
        float distance2 = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2];
        if (distance2 <= radius2) {
            if (n < capacity)
                found[n] = i;
            n++;
        }
    }
    return n;
}

static int compare_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

/* Builds the grid and checks every query's set against brute force; returns mismatches. */
static int check_gather(const char *name, const pf_photon *photons, uint32_t count, float radius,
                        const float (*queries)[4], uint32_t query_count, uint32_t capacity,
                        pf_photon_grid_info *info_out)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_photon_grid_build(grid, photons, count, radius, &err), &err);
    if (err.status != PF_OK)
        return 1;
    uint32_t *counts = calloc(query_count, sizeof *counts);
    uint32_t *indices = calloc((size_t)query_count * capacity, sizeof *indices);
    uint32_t *expected = calloc(capacity, sizeof *expected);
    PF_CHECK_OK(pf_photon_grid_gather(grid, queries, query_count, capacity, counts, indices, &err),
                &err);
    int mismatches = 0;
    uint64_t total = 0;
    for (uint32_t q = 0; q < query_count; q++) {
        uint32_t n = brute_gather(photons, count, queries[q], expected, capacity);
        total += n;
        int same = counts[q] == n;
        if (same && n <= capacity) {
            uint32_t *got = indices + (size_t)q * capacity;
            qsort(got, n, sizeof *got, compare_u32);
            for (uint32_t i = 0; i < n && same; i++)
                same = got[i] == expected[i];
        }
        if (!same && mismatches++ < 3)
            fprintf(stderr, "%s: query %u (%g %g %g r %g): grid %u photons, brute force %u\n",
                    name, q, (double)queries[q][0], (double)queries[q][1], (double)queries[q][2],
                    (double)queries[q][3], counts[q], n);
    }
    pf_photon_grid_info info;
    PF_CHECK_OK(pf_photon_grid_stats(grid, &info, &err), &err);
    printf("  %s: %u photons, %s table of %u (%u occupied, largest %u), %u queries found %llu\n",
           name, count, info.hashed ? "hashed" : "dense", info.table_size, info.occupied,
           info.largest, query_count, (unsigned long long)total);
    if (info_out)
        *info_out = info;
    PF_CHECK_MSG(mismatches == 0, "%s: %d of %u queries differ from brute force", name,
                 mismatches, query_count);
    free(counts);
    free(indices);
    free(expected);
    return mismatches;
}

/* count queries of radius, each within spread of a random one of the photons on every axis. */
static void queries_near_photons(const pf_photon *photons, uint32_t photon_count, float spread,
                                 float radius, float (*queries)[4], uint32_t count, uint32_t *rng)
{
    for (uint32_t q = 0; q < count; q++) {
        const pf_photon *p = &photons[next_random(rng) % photon_count];
        for (int k = 0; k < 3; k++)
            queries[q][k] = p->position[k] + uniform(rng, -spread, spread);
        queries[q][3] = radius;
    }
}

PF_TEST(dense_grid_gathers_exactly_the_brute_force_set)
{
    enum { COUNT = 20000, QUERIES = 2000 };
    uint32_t rng = 1u;
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    for (uint32_t i = 0; i < COUNT; i++)
        make_photon(&photons[i], uniform(&rng, -1, 1), uniform(&rng, 0, 0.5f), uniform(&rng, -1, 1));
    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    for (uint32_t q = 0; q < QUERIES; q++) {
        /* Half at photon positions (distance 0 included), half anywhere (some outside). */
        if (q % 2 == 0) {
            const pf_photon *p = &photons[next_random(&rng) % COUNT];
            queries[q][0] = p->position[0];
            queries[q][1] = p->position[1];
            queries[q][2] = p->position[2];
        } else {
            queries[q][0] = uniform(&rng, -1.2f, 1.2f);
            queries[q][1] = uniform(&rng, -0.2f, 0.7f);
            queries[q][2] = uniform(&rng, -1.2f, 1.2f);
        }
        queries[q][3] = uniform(&rng, 0.01f, 0.1f); /* <= the build radius */
    }
    pf_photon_grid_info info;
    check_gather("uniform", photons, COUNT, 0.1f, queries, QUERIES, 256, &info);
    PF_CHECK(info.hashed == 0);
    free(queries);
    free(photons);
}

PF_TEST(hashed_grid_for_sparse_maps_gathers_exactly)
{
    /* Two small clusters 10 km apart: a dense grid would need ~10^8 cells per photon. */
    enum { COUNT = 4000, QUERIES = 1000 };
    uint32_t rng = 2u;
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    for (uint32_t i = 0; i < COUNT; i++) {
        float offset = i % 2 ? 1e4f : 0.0f;
        make_photon(&photons[i], offset + uniform(&rng, 0, 1), uniform(&rng, 0, 1),
                    uniform(&rng, -offset * 0.5f, -offset * 0.5f + 1));
    }
    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    queries_near_photons(photons, COUNT, 0.05f, 0.05f, queries, QUERIES, &rng);
    pf_photon_grid_info info;
    check_gather("two far clusters", photons, COUNT, 0.05f, queries, QUERIES, 512, &info);
    PF_CHECK(info.hashed == 1);
    free(queries);
    free(photons);
}

/*
 * A few photons far apart get a hash table of at most 8 buckets, where every
 * block's hash lands in the same bucket group and a query's 27 cells share at
 * most 8 keys: the estimates' key list must be de-duplicated there
 * (photon_grid_keys_may_repeat), or photons would be gathered more than once.
 */
PF_TEST(hashed_grid_whose_blocks_collide_gathers_each_photon_once)
{
    enum { QUERIES = 300 };
    static const uint32_t counts[] = {8, 3};
    static const uint32_t tables[] = {8, 4};
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        uint32_t count = counts[c], rng = 7u + (uint32_t)c;
        pf_photon photons[8];
        for (uint32_t i = 0; i < count; i++) {
            float offset = i % 2 ? 1e4f : 0.0f;
            make_photon(&photons[i], offset + uniform(&rng, 0, 0.1f), uniform(&rng, 0, 0.1f),
                        uniform(&rng, 0, 0.1f));
        }
        float (*queries)[4] = malloc(QUERIES * sizeof *queries);
        queries_near_photons(photons, count, 0.1f, 0.1f, queries, QUERIES, &rng);
        pf_photon_grid_info info = {0}; /* read below even if the build failed */
        check_gather(c == 0 ? "8 buckets" : "4 buckets", photons, count, 0.1f, queries, QUERIES,
                     16, &info);
        PF_CHECK_MSG(info.hashed == 1 && info.table_size == tables[c],
                     "%u photons: %s table of %u", count, info.hashed ? "hashed" : "dense",
                     info.table_size);
        free(queries);
    }
}

PF_TEST(photons_on_cell_borders_and_queries_at_full_radius)
{
    /*
     * Photons on a lattice whose spacing is the build radius: many sit
     * exactly on or next to cell borders, and queries at lattice points with
     * the full radius have neighbours at exactly distance r (included).
     */
    enum { EDGE = 24, COUNT = EDGE * EDGE * EDGE };
    const float radius = 0.125f; /* a power of two: lattice points are exact */
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    for (uint32_t i = 0; i < COUNT; i++)
        make_photon(&photons[i], (float)(i % EDGE) * radius, (float)(i / EDGE % EDGE) * radius,
                    (float)(i / EDGE / EDGE) * radius);
    enum { QUERIES = 1500 };
    uint32_t rng = 3u;
    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    for (uint32_t q = 0; q < QUERIES; q++) {
        const pf_photon *p = &photons[next_random(&rng) % COUNT];
        for (int k = 0; k < 3; k++)
            queries[q][k] = p->position[k] + (q % 3 == 0 ? 0.5f * radius : 0.0f);
        queries[q][3] = radius;
    }
    check_gather("lattice", photons, COUNT, radius, queries, QUERIES, 64, NULL);
    free(queries);
    free(photons);
}

PF_TEST(clustered_photons_and_an_empty_map)
{
    /* A light touching a wall: every photon in one spot. */
    enum { COUNT = 5000 };
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    uint32_t rng = 4u;
    for (uint32_t i = 0; i < COUNT; i++)
        make_photon(&photons[i], 1.0f + uniform(&rng, 0, 1e-6f), 2.0f, 3.0f);
    float queries[3][4] = {{1.0f, 2.0f, 3.0f, 0.01f}, {1.5f, 2.0f, 3.0f, 0.01f},
                           {1.0f, 2.0f, 3.0f, 1e-7f}};
    pf_photon_grid_info info;
    check_gather("one spot", photons, COUNT, 0.01f, queries, 3, COUNT, &info);
    PF_CHECK(info.occupied == 1 && info.largest == COUNT);
    check_gather("empty map", photons, 0, 0.01f, queries, 3, 4, &info);
    PF_CHECK(info.occupied == 0);
    free(photons);
}

PF_TEST(bad_input_is_refused_with_the_cause)
{
    pf_photon photons[2];
    make_photon(&photons[0], 0, 0, 0);
    make_photon(&photons[1], NAN, 0, 0);
    pf_error err = {0};
    PF_CHECK(pf_photon_grid_build(grid, photons, 1, 0.0f, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "radius") != NULL);
    PF_CHECK(pf_photon_grid_build(grid, photons, 2, 0.1f, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "photon 1") != NULL);
    float query[1][4] = {{0, 0, 0, 0.1f}};
    uint32_t count = 0;
    PF_CHECK(pf_photon_grid_gather(grid, query, 1, 0, &count, NULL, &err) == PF_ERR_INVALID);
    /* More photons than one 128 MiB buffer holds: refused before any allocation on the device. */
    uint32_t too_many = (uint32_t)(pf_vk_info(ctx)->max_storage_buffer_range / sizeof(pf_photon)) + 1;
    pf_photon *many = calloc(too_many, sizeof *many);
    PF_REQUIRE(many != NULL);
    PF_CHECK(pf_photon_grid_build(grid, many, too_many, 0.1f, &err) == PF_ERR_LIMIT);
    PF_CHECK_MSG(strstr(err.message, "allows") != NULL, "%s", err.message);
    free(many);
}

int main(void)
{
    pf_error err = {0};
    ctx = vk_test_context(&err);
    if (!ctx || pf_photon_grid_create(ctx, &grid, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(dense_grid_gathers_exactly_the_brute_force_set);
    PF_RUN(hashed_grid_for_sparse_maps_gathers_exactly);
    PF_RUN(hashed_grid_whose_blocks_collide_gathers_each_photon_once);
    PF_RUN(photons_on_cell_borders_and_queries_at_full_radius);
    PF_RUN(clustered_photons_and_an_empty_map);
    PF_RUN(bad_input_is_refused_with_the_cause);
    pf_photon_grid_destroy(grid);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
