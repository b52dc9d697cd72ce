/*
 * The radiance estimates of shaders/common/photon_estimate.glsl against a
 * brute-force CPU estimate over the same photons: the fixed-radius cone
 * estimate and the k-nearest one (the same photon set and the same radius
 * within float tolerance; at ties any of the tied photons may be kept), on
 * random photon sets with rejected photons, on a lattice whose photons sit
 * on cell borders at exactly the query radius, and on a clustered map (a
 * light touching a wall) where the loop guard must stop the gather and say so;
 * and the precomputed irradiance points (pf_photon_grid_build_irradiance)
 * against the fixed-radius estimate they stand in for.
 */
#include "../vk/vk_test_util.h"
#include "pf_photon.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_photon_grid *grid;

/* photon_estimate.glsl's constants. */
#define NORMAL_AGREEMENT 0.9063f
#define CONE_K 1.1
#define CONE_NORMALISATION (1.0 - 2.0 / (3.0 * CONE_K))
/* Relative agreement of GPU and CPU estimates (float sums in another order). */
#define ESTIMATE_TOLERANCE 1e-3
/* A lookup's value went through RGB9E5: 2^-9 of its largest channel, and the sum's order. */
#define LOOKUP_TOLERANCE 4e-3
/* Lookups checked one by one against the CPU (each a pass over every photon). */
#define CPU_POINT_CHECKS 400u

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

static void make_photon(pf_photon *photon, const float position[3], const float flux[3],
                        const float incoming[3], const float normal[3])
{
    pf_photon_pack(position, flux, incoming, normal, photon);
}

/*
 * count photons on the plane y = 0 (y within ±half_thickness) of [-1, 1]², lit
 * from above with coloured flux; every 5th (from 1) arrives from below and
 * every 10th (from 2) lies on a surface tilted 45°: estimates reject both.
 */
static void plane_photons(pf_photon *photons, uint32_t count, float half_thickness,
                          uint32_t *rng)
{
    for (uint32_t i = 0; i < count; i++) {
        float position[3] = {uniform(rng, -1, 1), uniform(rng, -half_thickness, half_thickness),
                             uniform(rng, -1, 1)};
        float flux[3] = {uniform(rng, 0.5f, 1.5f), uniform(rng, 0.5f, 1.5f),
                         uniform(rng, 0.5f, 1.5f)};
        float incoming[3] = {uniform(rng, -0.7f, 0.7f), -1.0f, uniform(rng, -0.7f, 0.7f)};
        float normal[3] = {0.0f, 1.0f, 0.0f};
        if (i % 5 == 1)
            incoming[1] = 1.0f;
        if (i % 10 == 2)
            normal[0] = 1.0f;
        make_photon(&photons[i], position, flux, incoming, normal);
    }
}

typedef struct candidate {
    double distance2;
    double flux[3];
} candidate;

static int by_distance(const void *a, const void *b)
{
    double x = ((const candidate *)a)->distance2, y = ((const candidate *)b)->distance2;
    return (x > y) - (x < y);
}

/*
 * The CPU estimate from the unpacked photons: k = 0 for the fixed radius,
 * else the k nearest within it. result: rgb and the radius used.
 */
static void brute_estimate(const pf_photon *photons, uint32_t count, const float query[4],
                           const float normal[3], uint32_t k, candidate *scratch,
                           double result[4])
{
    uint32_t found = 0;
    double max_radius = query[3];
    for (uint32_t i = 0; i < count; i++) {
        float position[3], flux[3], incoming[3], photon_normal[3];
        pf_photon_unpack(&photons[i], position, flux, incoming, photon_normal);
        float d[3] = {position[0] - query[0], position[1] - query[1], position[2] - query[2]};
        double distance2 = (double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2];
        float facing = incoming[0] * normal[0] + incoming[1] * normal[1] + incoming[2] * normal[2];
        float agreement = photon_normal[0] * normal[0] + photon_normal[1] * normal[1] +
                          photon_normal[2] * normal[2];
        if (distance2 > max_radius * max_radius || !(facing < 0.0f) ||
            !(agreement >= NORMAL_AGREEMENT))
            continue;
        scratch[found].distance2 = distance2;
        for (int c = 0; c < 3; c++)
            scratch[found].flux[c] = flux[c];
        found++;
    }
    double radius = max_radius;
    uint32_t used = found;
    if (k > 0) {
        qsort(scratch, found, sizeof *scratch, by_distance);
        if (found >= k) {
            radius = sqrt(scratch[k - 1].distance2);
            used = k;
        }
        radius = fmax(radius, PF_PHOTON_KNN_MIN_RADIUS_FRACTION * max_radius);
    }
    for (int c = 0; c < 3; c++)
        result[c] = 0.0;
    for (uint32_t i = 0; i < used; i++) {
        double weight = 1.0 - sqrt(scratch[i].distance2) / (CONE_K * radius);
        for (int c = 0; c < 3; c++)
            result[c] += scratch[i].flux[c] * weight;
    }
    for (int c = 0; c < 3; c++)
        result[c] /= CONE_NORMALISATION * M_PI * radius * radius;
    result[3] = radius;
}

/*
 * Builds the grid, runs the fixed (k = 0) or k-NN estimate on the GPU and
 * compares each query with brute force.
 */
static void check_estimates(const char *name, const pf_photon *photons, uint32_t count,
                           float build_radius, const float (*queries)[4],
                           const float (*normals)[4], const uint32_t *ks, uint32_t query_count)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_photon_grid_build(grid, photons, count, build_radius, &err), &err);
    if (err.status != PF_OK)
        return;
    float (*fixed)[4] = malloc(query_count * sizeof *fixed);
    float (*knn)[4] = malloc(query_count * sizeof *knn);
    candidate *scratch = malloc((count ? count : 1) * sizeof *scratch);
    PF_REQUIRE(fixed && knn && scratch);
    PF_CHECK_OK(pf_photon_grid_irradiance(grid, queries, normals, query_count, fixed, &err), &err);
    /* One dispatch per distinct k (the probe takes k as a push constant). */
    for (uint32_t q = 0; q < query_count; q++) {
        int first = 1;
        for (uint32_t p = 0; p < q && first; p++)
            first = ks[p] != ks[q];
        if (!first)
            continue;
        uint32_t n = 0;
        float (*subset)[4] = malloc(query_count * sizeof *subset);
        float (*subset_normals)[4] = malloc(query_count * sizeof *subset_normals);
        float (*subset_result)[4] = malloc(query_count * sizeof *subset_result);
        for (uint32_t p = 0; p < query_count; p++) {
            if (ks[p] == ks[q]) {
                memcpy(subset[n], queries[p], sizeof subset[n]);
                memcpy(subset_normals[n++], normals[p], sizeof subset_normals[0]);
            }
        }
        PF_CHECK_OK(pf_photon_grid_irradiance_knn(grid, subset, subset_normals, n, ks[q],
                                                  subset_result, &err),
                    &err);
        n = 0;
        for (uint32_t p = 0; p < query_count; p++) {
            if (ks[p] == ks[q])
                memcpy(knn[p], subset_result[n++], sizeof knn[p]);
        }
        free(subset);
        free(subset_normals);
        free(subset_result);
    }
    int mismatches = 0;
    uint32_t short_of_k = 0;
    double total = 0.0;
    for (uint32_t q = 0; q < query_count; q++) {
        for (int mode = 0; mode < 2; mode++) {
            double expected[4];
            brute_estimate(photons, count, queries[q], normals[q], mode ? ks[q] : 0, scratch,
                           expected);
            const float *got = mode ? knn[q] : fixed[q];
            double scale = fmax(fmax(expected[0], expected[1]), expected[2]);
            int same = fabs(got[3] - expected[3]) <= 1e-5 * expected[3];
            for (int c = 0; c < 3; c++)
                same = same && fabs(got[c] - expected[c]) <= ESTIMATE_TOLERANCE * scale + 1e-9;
            if (mode) {
                short_of_k += expected[3] >= queries[q][3];
                total += expected[1];
            }
            if (!same && mismatches++ < 3)
                fprintf(stderr,
                        "%s: query %u (%g %g %g r %g) %s k %u: GPU %g %g %g r %g, CPU %g %g %g r %g\n",
                        name, q, (double)queries[q][0], (double)queries[q][1],
                        (double)queries[q][2], (double)queries[q][3], mode ? "k-NN" : "fixed",
                        ks[q], (double)got[0], (double)got[1], (double)got[2], (double)got[3],
                        expected[0], expected[1], expected[2], expected[3]);
        }
    }
    printf("  %s: %u photons, %u queries (%u with fewer than k in reach), mean k-NN E %.4g\n",
           name, count, query_count, short_of_k, total / query_count);
    PF_CHECK_MSG(mismatches == 0, "%s: %d estimates differ from brute force", name, mismatches);
    free(fixed);
    free(knn);
    free(scratch);
}

PF_TEST(estimates_match_brute_force_on_random_photons)
{
    /*
     * Photons on the plane y = 0 (±5 mm) lit from above, with coloured flux;
     * a fifth arrive from below and a tenth lie on a surface tilted 45°:
     * both must be rejected. 5000 photons/m²: a query of radius 5 cm holds
     * about 39 photons, so k = 64 often falls back to the maximum radius.
     */
    enum { COUNT = 20000, QUERIES = 1200 };
    static const uint32_t k_values[] = {1, 7, 32, 64};
    uint32_t rng = 11u;
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    plane_photons(photons, COUNT, 0.005f, &rng);
    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    float (*normals)[4] = malloc(QUERIES * sizeof *normals);
    uint32_t *ks = malloc(QUERIES * sizeof *ks);
    for (uint32_t q = 0; q < QUERIES; q++) {
        queries[q][0] = uniform(&rng, -1.05f, 1.05f);
        queries[q][1] = 0.0f;
        queries[q][2] = uniform(&rng, -1.05f, 1.05f);
        queries[q][3] = uniform(&rng, 0.02f, 0.1f);
        normals[q][0] = normals[q][2] = normals[q][3] = 0.0f;
        normals[q][1] = 1.0f;
        ks[q] = k_values[q % 4];
    }
    check_estimates("random plane", photons, COUNT, 0.1f, queries, normals, ks, QUERIES);
    free(ks);
    free(normals);
    free(queries);
    free(photons);
}

PF_TEST(estimates_with_photons_on_cell_borders)
{
    /*
     * A lattice whose spacing is the build radius (a power of two, so every
     * coordinate is exact): photons lie on cell borders, and a query at a
     * lattice point with the full radius has 6 neighbours at exactly r
     * (included) — k = 7 then ties all six for the 7th place and r_k = r.
     */
    enum { EDGE = 16, COUNT = EDGE * EDGE * EDGE, QUERIES = 600 };
    const float radius = 0.125f;
    const float flux[3] = {1.0f, 0.5f, 0.25f}, incoming[3] = {0.0f, -1.0f, 0.0f},
                normal[3] = {0.0f, 1.0f, 0.0f};
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    for (uint32_t i = 0; i < COUNT; i++) {
        float position[3] = {(float)(i % EDGE) * radius, (float)(i / EDGE % EDGE) * radius,
                             (float)(i / EDGE / EDGE) * radius};
        make_photon(&photons[i], position, flux, incoming, normal);
    }
    static const uint32_t k_values[] = {1, 7, 19, 64};
    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    float (*normals)[4] = malloc(QUERIES * sizeof *normals);
    uint32_t *ks = malloc(QUERIES * sizeof *ks);
    uint32_t rng = 12u;
    for (uint32_t q = 0; q < QUERIES; q++) {
        const pf_photon *p = &photons[next_random(&rng) % COUNT];
        for (int k = 0; k < 3; k++)
            queries[q][k] = p->position[k] + (q % 3 == 0 ? 0.5f * radius : 0.0f);
        queries[q][3] = radius;
        normals[q][0] = normals[q][2] = normals[q][3] = 0.0f;
        normals[q][1] = 1.0f;
        ks[q] = k_values[q % 4];
    }
    check_estimates("lattice", photons, COUNT, radius, queries, normals, ks, QUERIES);
    free(ks);
    free(normals);
    free(queries);
    free(photons);
}

PF_TEST(clustered_photons_stop_at_the_loop_guard_and_say_so)
{
    /*
     * A light touching a wall: every photon within 1 µm, so one cell holds
     * them all. Below the guard the estimates match brute force (the k-NN
     * radius at its floor); above it the gather stops, the call fails with
     * PF_ERR_LIMIT naming the guard, and the values stay finite.
     */
    enum { FEW = 5000, MANY = 3 * PF_PHOTON_ESTIMATE_MAX_ITERATIONS };
    const float flux[3] = {1.0f, 1.0f, 1.0f}, incoming[3] = {0.0f, -1.0f, 0.0f},
                normal[3] = {0.0f, 1.0f, 0.0f};
    pf_photon *photons = malloc(MANY * sizeof *photons);
    uint32_t rng = 13u;
    for (uint32_t i = 0; i < MANY; i++) {
        float position[3] = {1.0f + uniform(&rng, 0, 1e-6f), 2.0f, 3.0f};
        make_photon(&photons[i], position, flux, incoming, normal);
    }
    float queries[2][4] = {{1.0f, 2.0f, 3.0f, 0.01f}, {1.5f, 2.0f, 3.0f, 0.01f}};
    float normals[2][4] = {{0, 1, 0, 0}, {0, 1, 0, 0}};
    const uint32_t ks[2] = {64, 64};
    check_estimates("one spot, below the guard", photons, FEW, 0.01f, queries, normals, ks, 2);

    pf_error err = {0};
    float result[2][4];
    PF_REQUIRE_OK(pf_photon_grid_build(grid, photons, MANY, 0.01f, &err), &err);
    for (int mode = 0; mode < 2; mode++) {
        pf_status status = mode ? pf_photon_grid_irradiance_knn(grid, queries, normals, 2, 64,
                                                                result, &err)
                                : pf_photon_grid_irradiance(grid, queries, normals, 2, result, &err);
        PF_CHECK_MSG(status == PF_ERR_LIMIT, "%s: status %d", mode ? "k-NN" : "fixed", status);
        PF_CHECK_MSG(strstr(err.message, "of 2 queries") && strstr(err.message, "loop guard"),
                     "%s", err.message);
        printf("  %s over %u photons in one spot: %s\n", mode ? "k-NN" : "fixed", MANY,
               err.message);
        PF_CHECK(isfinite(result[0][1]) && result[0][1] > 0.0f);
        PF_CHECK(result[1][1] == 0.0f);
    }
    free(photons);
}

PF_TEST(k_outside_its_bounds_is_refused)
{
    pf_photon photon;
    const float position[3] = {0, 0, 0}, flux[3] = {1, 1, 1}, incoming[3] = {0, -1, 0},
                normal[3] = {0, 1, 0};
    make_photon(&photon, position, flux, incoming, normal);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_photon_grid_build(grid, &photon, 1, 0.1f, &err), &err);
    float query[1][4] = {{0, 0, 0, 0.1f}}, query_normal[1][4] = {{0, 1, 0, 0}}, result[1][4];
    PF_CHECK(pf_photon_grid_irradiance_knn(grid, query, query_normal, 1, 0, result, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(pf_photon_grid_irradiance_knn(grid, query, query_normal, 1, PF_PHOTON_KNN_MAX + 1,
                                           result, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "k = 65") != NULL, "%s", err.message);
    PF_CHECK_OK(pf_photon_grid_irradiance_knn(grid, query, query_normal, 1, 1, result, &err),
                &err);
    /* One photon at distance 0: r_1 = 0 is floored, the estimate finite. */
    PF_CHECK_NEAR(result[0][3], PF_PHOTON_KNN_MIN_RADIUS_FRACTION * 0.1f, 1e-9);
    PF_CHECK(isfinite(result[0][0]) && result[0][0] > 0.0f);
}

/* photon_estimate.glsl's photon_is_irradiance_point: the coin of a photon record's position. */
static int is_irradiance_point(const pf_photon *photon)
{
    uint32_t bits[3];
    memcpy(bits, photon->position, sizeof bits);
    uint32_t value = (bits[0] * 73856093u) ^ (bits[1] * 19349663u) ^ (bits[2] * 83492791u);
    uint32_t state = value * 747796405u + 2891336453u; /* rng.glsl's pcg_hash */
    uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return ((word >> 22u) ^ word) % PF_PHOTON_IRRADIANCE_STRIDE == 0;
}

/* The nearest irradiance point to query (xyz, radius in w) whose normal agrees, or -1. */
static int32_t nearest_point(const pf_photon *photons, uint32_t count, const float query[4],
                             const float normal[3], float *distance2)
{
    int32_t best = -1;
    float best2 = query[3] * query[3];
    for (uint32_t i = 0; i < count; i++) {
        if (!is_irradiance_point(&photons[i]))
            continue;
        float position[3], flux[3], incoming[3], photon_normal[3];
        pf_photon_unpack(&photons[i], position, flux, incoming, photon_normal);
        float d[3] = {position[0] - query[0], position[1] - query[1], position[2] - query[2]};
        float d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        float agreement = photon_normal[0] * normal[0] + photon_normal[1] * normal[1] +
                          photon_normal[2] * normal[2];
        if (d2 <= best2 && agreement >= NORMAL_AGREEMENT) {
            best2 = d2;
            best = (int32_t)i;
        }
    }
    *distance2 = best2;
    return best;
}

PF_TEST(irradiance_lookups_average_to_the_estimate)
{
    /*
     * Photons as in the random-plane test (a fifth from below, a tenth on a
     * tilted surface) but on the plane itself (the ±5 mm slab there shrinks
     * a disc around a point off its middle by ~2 %), at the density the
     * renderer's passes run at: ~14
     * photons in a disc, where the lookup's two former biases were +15 %
     * (each point counting itself) and -6 % (the nearest point to a query
     * tends to sit in a sparse patch). Over many queries the mean of what
     * the renderer reads (the lookup, or where it finds no point the
     * estimate, as render_final.comp's global_radiance) must equal the mean
     * fixed-radius estimate at the same queries; each value is noisy
     * (~30 %), the mean of 4000 is good to ~1 % (seeds 22-24: 0.987-0.994).
     * And each lookup whose nearest point lies within half a cell (so that
     * its 8 cells surely hold it) equals that point's estimate from the
     * non-points, computed here.
     */
    enum { COUNT = 20000, QUERIES = 4000 };
    const float radius = 0.03f;
    uint32_t rng = 22u;
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    PF_REQUIRE(photons);
    float lo[3] = {-1.0f, 0.0f, -1.0f}, hi[3] = {1.0f, 0.0f, 1.0f};
    plane_photons(photons, COUNT, hi[1], &rng);
    pf_error err = {0};
    pf_photon_grid *points = NULL;
    PF_REQUIRE_OK(pf_photon_grid_build(grid, photons, COUNT, radius, &err), &err);
    PF_REQUIRE_OK(pf_photon_grid_create(ctx, &points, &err), &err);
    pf_photon_irradiance_counts counts;
    PF_REQUIRE_OK(pf_photon_grid_build_irradiance(points, grid, radius, lo, hi, &counts, &err),
                  &err);
    /* A coin of 1 in PF_PHOTON_IRRADIANCE_STRIDE per photon: 5000 ± 61 expected. */
    printf("  %u photons: %u irradiance points, %u truncated\n", COUNT, counts.points,
           counts.truncated);
    PF_CHECK(counts.points > COUNT / PF_PHOTON_IRRADIANCE_STRIDE * 9 / 10 &&
             counts.points < COUNT / PF_PHOTON_IRRADIANCE_STRIDE * 11 / 10);
    PF_CHECK(counts.truncated == 0);
    PF_CHECK(pf_photon_grid_get_info(points).photon_count == counts.points);

    float (*queries)[4] = malloc(QUERIES * sizeof *queries);
    float (*normals)[4] = malloc(QUERIES * sizeof *normals);
    float (*estimate)[4] = malloc(QUERIES * sizeof *estimate);
    float (*lookup)[4] = malloc(QUERIES * sizeof *lookup);
    PF_REQUIRE(queries && normals && estimate && lookup);
    for (uint32_t q = 0; q < QUERIES; q++) {
        queries[q][0] = uniform(&rng, -0.95f, 0.95f);
        queries[q][1] = 0.0f;
        queries[q][2] = uniform(&rng, -0.95f, 0.95f);
        queries[q][3] = radius;
        normals[q][0] = normals[q][2] = normals[q][3] = 0.0f;
        normals[q][1] = 1.0f;
    }
    PF_CHECK_OK(pf_photon_grid_irradiance(grid, queries, normals, QUERIES, estimate, &err), &err);
    PF_CHECK_OK(pf_photon_grid_irradiance_lookup(points, queries, normals, QUERIES, lookup, &err),
                &err);
    double mean_estimate[3] = {0, 0, 0}, mean_lookup[3] = {0, 0, 0};
    uint32_t found = 0;
    for (uint32_t q = 0; q < QUERIES; q++) {
        int hit = lookup[q][3] == 1.0f;
        found += hit;
        for (int c = 0; c < 3; c++) {
            mean_estimate[c] += estimate[q][c] / QUERIES;
            mean_lookup[c] += (hit ? lookup[q][c] : estimate[q][c]) / QUERIES;
        }
    }
    /* Each lookup against its definition, computed here: CPU_POINT_CHECKS queries. */
    uint32_t wrong = 0, checked = 0;
    candidate *scratch = malloc(COUNT * sizeof *scratch);
    pf_photon *others = malloc(COUNT * sizeof *others);
    PF_REQUIRE(scratch && others);
    uint32_t other_count = 0;
    for (uint32_t i = 0; i < COUNT; i++) {
        if (!is_irradiance_point(&photons[i]))
            others[other_count++] = photons[i];
    }
    for (uint32_t q = 0; q < CPU_POINT_CHECKS; q++) {
        double expected[4];
        float nearest2 = 0.0f;
        int32_t point = nearest_point(photons, COUNT, queries[q], normals[q], &nearest2);
        /* Visited for sure when within half a cell; beyond, the GPU may find another point. */
        if (point < 0 || nearest2 > 0.25f * radius * radius)
            continue;
        float centre[4] = {photons[point].position[0], photons[point].position[1],
                           photons[point].position[2], radius};
        float unused[3], point_normal[4] = {0, 0, 0, 0};
        pf_photon_unpack(&photons[point], unused, unused, unused, point_normal);
        brute_estimate(others, other_count, centre, point_normal, 0, scratch, expected);
        double scale = (double)PF_PHOTON_IRRADIANCE_STRIDE / (PF_PHOTON_IRRADIANCE_STRIDE - 1);
        int same = lookup[q][3] == 1.0f;
        for (int c = 0; c < 3; c++)
            same = same && fabs(lookup[q][c] - scale * expected[c]) <=
                               LOOKUP_TOLERANCE * scale * expected[c] + 1e-6;
        if (!same && wrong++ < 3)
            fprintf(stderr, "query %u: lookup %g %g %g (found %g), CPU %g %g %g\n", q,
                    (double)lookup[q][0], (double)lookup[q][1], (double)lookup[q][2],
                    (double)lookup[q][3], scale * expected[0], scale * expected[1],
                    scale * expected[2]);
        checked++;
    }
    printf("  %u lookups checked against the CPU's nearest point and its estimate\n", checked);
    PF_CHECK(checked > CPU_POINT_CHECKS / 2);
    PF_CHECK_MSG(wrong == 0, "%u of %u lookups differ from their definition", wrong, checked);
    free(others);
    free(scratch);
    printf("  mean E: estimate %.5g %.5g %.5g, lookup %.5g %.5g %.5g (%u of %u found)\n",
           mean_estimate[0], mean_estimate[1], mean_estimate[2], mean_lookup[0], mean_lookup[1],
           mean_lookup[2], found, QUERIES);
    /* About 3.5 points in a disc: a lookup finds one almost everywhere. */
    PF_CHECK(found > QUERIES * 9 / 10);
    for (int c = 0; c < 3; c++)
        PF_CHECK_NEAR(mean_lookup[c] / mean_estimate[c], 1.0, 0.03);

    /* A normal no point shares, or a point far off the plane: nothing found, 0 returned. */
    for (uint32_t q = 0; q < QUERIES; q++) {
        if (q % 2) {
            normals[q][1] = 0.0f;
            normals[q][2] = 1.0f;
        } else {
            queries[q][1] = 0.5f;
        }
    }
    PF_CHECK_OK(pf_photon_grid_irradiance_lookup(points, queries, normals, QUERIES, lookup, &err),
                &err);
    uint32_t stray = 0;
    for (uint32_t q = 0; q < QUERIES; q++)
        stray += lookup[q][3] != 0.0f || lookup[q][0] != 0.0f;
    PF_CHECK_MSG(stray == 0, "%u of %u lookups found a point they must not", stray, QUERIES);

    /* The points' radius must fit the map's cells. */
    PF_CHECK(pf_photon_grid_build_irradiance(points, grid, 2.0f * radius, lo, hi, &counts, &err) ==
             PF_ERR_INVALID);
    pf_photon_grid_destroy(points);
    free(lookup);
    free(estimate);
    free(normals);
    free(queries);
    free(photons);
}

/* A map whose every photon is a point (far above the bound record_points lists without
 * reading the count): found all the same, the points listed again with room for each. */
PF_TEST(more_points_than_the_bound_are_listed_again)
{
    enum { COUNT = 24000 };
    const float radius = 0.03f;
    uint32_t rng = 5u;
    pf_photon *photons = malloc(COUNT * sizeof *photons);
    PF_REQUIRE(photons);
    float lo[3] = {-1.0f, 0.0f, -1.0f}, hi[3] = {1.0f, 0.0f, 1.0f};
    plane_photons(photons, COUNT, hi[1], &rng);
    uint32_t kept = 0;
    for (uint32_t i = 0; i < COUNT; i++)
        if (is_irradiance_point(&photons[i]))
            photons[kept++] = photons[i];
    PF_REQUIRE(kept > 2000);
    pf_error err = {0};
    pf_photon_grid *points = NULL;
    PF_REQUIRE_OK(pf_photon_grid_build(grid, photons, kept, radius, &err), &err);
    PF_REQUIRE_OK(pf_photon_grid_create(ctx, &points, &err), &err);
    pf_photon_irradiance_counts counts;
    PF_CHECK_OK(pf_photon_grid_build_irradiance(points, grid, radius, lo, hi, &counts, &err),
                &err);
    printf("  %u photons, every one a point: %u points\n", kept, counts.points);
    PF_CHECK(counts.points == kept);
    PF_CHECK(pf_photon_grid_get_info(points).photon_count == kept);
    pf_photon_grid_destroy(points);
    free(photons);
}

int main(void)
{
    pf_error err = {0};
    ctx = vk_test_context(&err);
    if (!ctx || pf_photon_grid_create(ctx, &grid, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    PF_RUN(estimates_match_brute_force_on_random_photons);
    PF_RUN(estimates_with_photons_on_cell_borders);
    PF_RUN(clustered_photons_stop_at_the_loop_guard_and_say_so);
    PF_RUN(k_outside_its_bounds_is_refused);
    PF_RUN(irradiance_lookups_average_to_the_estimate);
    PF_RUN(more_points_than_the_bound_are_listed_again);
    pf_photon_grid_destroy(grid);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
