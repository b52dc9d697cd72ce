/*
 * The shared GPU material code (shaders/common/materials.glsl), run through
 * pf_material_probe: Fresnel reflectance of glass against tabulated values
 * (including Brewster's angle and total internal reflection beyond the
 * critical angle), exact mirror reflection, glass choosing reflection with
 * probability F and transmitting along Snell's law with weights exactly 1,
 * and Lambert sampling whose reported pdf is the density it samples with.
 * Validation must stay silent.
 */
#include "pf_test.h"
#include "render_internal.h"
#include "render_test_env.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846
#define DEGREES (PI_D / 180.0)

static pf_vk_context *ctx;
static pf_renderer *renderer;

static const pf_material glass = {{1, 1, 1}, PF_MATERIAL_GLASS, {0, 0, 0}, 1.5f};
static const pf_material mirror = {{0.9f, 0.6f, 0.3f}, PF_MATERIAL_MIRROR, {0, 0, 0}, 1.5f};
static const pf_material lambert = {{0.7f, 0.5f, 0.2f}, PF_MATERIAL_LAMBERT, {0, 0, 0}, 1.5f};

/* A query with normal +z, wo at polar angle theta in the xz plane. */
static pf_material_probe_query query_at(const pf_material *material, double theta, int front,
                                        float xi_choice, uint32_t transport)
{
    pf_material_probe_query q;
    memset(&q, 0, sizeof q);
    q.material = *material;
    q.wo[0] = (float)sin(theta);
    q.wo[2] = (float)cos(theta);
    q.front = (front ? PF_PROBE_FRONT : 0u) | transport;
    q.normal[2] = 1.0f;
    q.xi[0] = 0.5f;
    q.xi[1] = 0.5f;
    q.xi[2] = xi_choice;
    q.fresnel_cos = (float)cos(theta);
    q.fresnel_eta = front ? material->ior : 1.0f / material->ior;
    return q;
}

/*
 * Unpolarized reflectance of glass (n = 1.5) in air, tabulated from Fresnel's
 * equations in the sine/tangent form (Hecht, Optics, 5th ed., eqs. 4.42-4.43:
 * R_s = sin²(θi − θt)/sin²(θi + θt), R_p = tan²(θi − θt)/tan²(θi + θt)),
 * a different form from the cosine one the shader evaluates.
 */
static const struct {
    double degrees;
    int from_outside;
    double reflectance;
    double tolerance; /* near the critical angle R changes fast with the float angle */
} fresnel_table[] = {
    {0.0, 1, 0.040000, 1e-5},   {30.0, 1, 0.041523, 1e-5},  {45.0, 1, 0.050240, 1e-5},
    {60.0, 1, 0.089187, 1e-5},  {80.0, 1, 0.387704, 1e-4},  {89.0, 1, 0.904185, 1e-3},
    {56.309932, 1, 0.073964, 1e-5}, /* Brewster: atan(1.5); R_p = 0, so R = R_s/2 */
    {0.0, 0, 0.040000, 1e-5},   {20.0, 0, 0.041729, 1e-5},  {35.0, 0, 0.086138, 1e-5},
    {41.0, 0, 0.379751, 1e-3},  /* just inside the critical angle asin(1/1.5) = 41.81° */
    {42.0, 0, 1.0, 0.0},        {60.0, 0, 1.0, 0.0},        {89.0, 0, 1.0, 0.0},
};

PF_TEST(fresnel_matches_tabulated_values)
{
    size_t count = sizeof fresnel_table / sizeof fresnel_table[0];
    pf_material_probe_query queries[sizeof fresnel_table / sizeof fresnel_table[0]];
    pf_material_probe_result results[sizeof fresnel_table / sizeof fresnel_table[0]];
    for (size_t i = 0; i < count; i++)
        queries[i] = query_at(&glass, fresnel_table[i].degrees * DEGREES,
                              fresnel_table[i].from_outside, 0.5f, 0);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_material_probe(renderer, queries, (uint32_t)count, results, &err), &err);
    for (size_t i = 0; i < count; i++) {
        PF_CHECK_MSG(fabs(results[i].fresnel - fresnel_table[i].reflectance) <=
                         fresnel_table[i].tolerance + 1e-6,
                     "%s at %.4f°: F = %.6f, expected %.6f",
                     fresnel_table[i].from_outside ? "outside" : "inside",
                     fresnel_table[i].degrees, results[i].fresnel, fresnel_table[i].reflectance);
    }
    /* Beyond the critical angle every sample reflects, whatever the random number. */
    pf_material_probe_query tir = query_at(&glass, 50.0 * DEGREES, 0, 0.999f, 0);
    pf_material_probe_result r;
    PF_REQUIRE_OK(pf_material_probe(renderer, &tir, 1, &r, &err), &err);
    PF_CHECK(!(r.flags & PF_PROBE_TRANSMITTED));
    PF_CHECK_NEAR(r.direction[0], -sin(50.0 * DEGREES), 1e-6);
    PF_CHECK_NEAR(r.direction[2], cos(50.0 * DEGREES), 1e-6);
}

PF_TEST(mirror_reflects_exactly_tinted_by_its_colour)
{
    pf_material_probe_query q = query_at(&mirror, 30.0 * DEGREES, 1, 0.3f, 0);
    pf_material_probe_result r;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_material_probe(renderer, &q, 1, &r, &err), &err);
    PF_CHECK(r.flags == PF_PROBE_SPECULAR);
    PF_CHECK_NEAR(r.direction[0], -q.wo[0], 1e-7);
    PF_CHECK_NEAR(r.direction[1], 0.0, 1e-7);
    PF_CHECK_NEAR(r.direction[2], q.wo[2], 1e-7);
    for (int c = 0; c < 3; c++) {
        PF_CHECK(r.weight[c] == mirror.albedo[c]);
        PF_CHECK(r.eval_cos[c] == 0.0f); /* a delta lobe has no density to evaluate */
    }
    PF_CHECK(r.pdf == 0.0f && r.eval_pdf == 0.0f);
}

/*
 * Glass with albedo 1, sampled for a photon (importance transport): reflection
 * exactly when xi < F with weight 1, else transmission along Snell's law with
 * weight 1, so reflect + transmit = 1: flux is conserved. Swept over xi at
 * normal incidence the reflected fraction is F = 0.04. Sampled for a camera
 * path (radiance), transmission also carries (η_i/η_t)²: 1/1.5² entering,
 * 1.5² leaving.
 */
#define GLASS_SWEEP 1000u

PF_TEST(glass_splits_energy_by_fresnel_and_refracts_by_snell)
{
    pf_material_probe_query *queries = calloc(GLASS_SWEEP, sizeof *queries);
    pf_material_probe_result *results = calloc(GLASS_SWEEP, sizeof *results);
    PF_REQUIRE(queries && results);
    for (uint32_t i = 0; i < GLASS_SWEEP; i++)
        queries[i] = query_at(&glass, 0.0, 1, (i + 0.5f) / GLASS_SWEEP, PF_PROBE_IMPORTANCE);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_material_probe(renderer, queries, GLASS_SWEEP, results, &err), &err);
    double reflected = 0.0, energy = 0.0;
    uint32_t wrong = 0;
    for (uint32_t i = 0; i < GLASS_SWEEP; i++) {
        const pf_material_probe_result *r = &results[i];
        int transmitted = (r->flags & PF_PROBE_TRANSMITTED) != 0;
        reflected += !transmitted;
        energy += r->weight[0];
        /* Straight through at normal incidence, straight back on reflection. */
        float expected_z = transmitted ? -1.0f : 1.0f;
        wrong += fabsf(r->direction[2] - expected_z) > 1e-6f || !(r->flags & PF_PROBE_SPECULAR) ||
                 r->weight[0] != 1.0f || r->weight[1] != 1.0f || r->weight[2] != 1.0f;
    }
    PF_CHECK_MSG(wrong == 0, "%u samples with a wrong direction or weight", wrong);
    PF_CHECK_NEAR(reflected / GLASS_SWEEP, 0.04, 1.0 / GLASS_SWEEP);
    PF_CHECK_NEAR(energy / GLASS_SWEEP, 1.0, 1e-12);

    /* Entering at 45°: sin θt = sin 45° / 1.5; leaving at that angle gives 45° back. */
    pf_material_probe_query in = query_at(&glass, 45.0 * DEGREES, 1, 0.999f, 0);
    double inside = asin(sin(45.0 * DEGREES) / 1.5);
    pf_material_probe_query out = query_at(&glass, inside, 0, 0.999f, 0);
    pf_material_probe_result r[2];
    pf_material_probe_query pair[2] = {in, out};
    PF_REQUIRE_OK(pf_material_probe(renderer, pair, 2, r, &err), &err);
    PF_CHECK(r[0].flags == (PF_PROBE_SPECULAR | PF_PROBE_TRANSMITTED));
    PF_CHECK_NEAR(r[0].direction[0], -sin(inside), 1e-6);
    PF_CHECK_NEAR(r[0].direction[2], -cos(inside), 1e-6);
    PF_CHECK(r[1].flags == (PF_PROBE_SPECULAR | PF_PROBE_TRANSMITTED));
    PF_CHECK_NEAR(r[1].direction[0], -sin(45.0 * DEGREES), 1e-6);
    PF_CHECK_NEAR(r[1].direction[2], -cos(45.0 * DEGREES), 1e-6);
    /* Radiance transport: (η_i/η_t)² on the way in and out, reflection untouched. */
    PF_CHECK_NEAR(r[0].weight[0], 1.0 / (1.5 * 1.5), 1e-6);
    PF_CHECK_NEAR(r[1].weight[2], 1.5 * 1.5, 1e-5);
    pf_material_probe_query bounced = query_at(&glass, 45.0 * DEGREES, 1, 0.0f, 0);
    PF_REQUIRE_OK(pf_material_probe(renderer, &bounced, 1, r, &err), &err);
    PF_CHECK(!(r[0].flags & PF_PROBE_TRANSMITTED) && r[0].weight[0] == 1.0f);

    /* A tinted glass tints transmission only (glTF base colour of a transmissive material). */
    pf_material tinted = glass;
    tinted.albedo[1] = 0.5f;
    pf_material_probe_query t[2] = {query_at(&tinted, 0.0, 1, 0.01f, PF_PROBE_IMPORTANCE),
                                    query_at(&tinted, 0.0, 1, 0.5f, PF_PROBE_IMPORTANCE)};
    PF_REQUIRE_OK(pf_material_probe(renderer, t, 2, r, &err), &err);
    PF_CHECK(r[0].weight[1] == 1.0f && !(r[0].flags & PF_PROBE_TRANSMITTED));
    PF_CHECK(r[1].weight[1] == 0.5f && (r[1].flags & PF_PROBE_TRANSMITTED));
    free(queries);
    free(results);
}

/* Kolmogorov-Smirnov distance of values (sorted here) from the uniform distribution on [0, 1]. */
static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double ks_uniform(double *values, uint32_t count)
{
    qsort(values, count, sizeof *values, compare_doubles);
    double worst = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        double below = values[i] - (double)i / count, above = (double)(i + 1) / count - values[i];
        worst = fmax(worst, fmax(below, above));
    }
    return worst;
}

/* splitmix64 (Steele et al. 2014): deterministic uniform numbers in [0, 1). */
static double next_uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 40) / (double)(1ull << 24);
}

/*
 * Lambert from independent uniform xi: every direction above the surface,
 * weight = albedo = eval_cos/eval_pdf, reported pdf = cos θ/π. Where the
 * directions really are cosine-distributed, cos²θ and the azimuth/2π are
 * uniform on [0, 1]: a Kolmogorov-Smirnov test at α = 0.001 (critical
 * distance 1.95/√n) checks both, so the density sampled is the cos θ/π
 * reported, which integrates to 1 over the hemisphere.
 */
#define LAMBERT_SAMPLES 20000u
#define KS_CRITICAL_0_001 1.95

PF_TEST(lambert_samples_the_cosine_density_it_reports)
{
    uint32_t count = LAMBERT_SAMPLES;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    double *cos2 = calloc(count, sizeof *cos2);
    double *azimuth = calloc(count, sizeof *azimuth);
    PF_REQUIRE(queries && results && cos2 && azimuth);
    uint64_t state = 42;
    for (uint32_t i = 0; i < count; i++) {
        queries[i] = query_at(&lambert, 20.0 * DEGREES, 1, 0.0f, 0);
        queries[i].xi[0] = (float)next_uniform(&state);
        queries[i].xi[1] = (float)next_uniform(&state);
    }
    pf_error err = {0};
    PF_REQUIRE_OK(pf_material_probe(renderer, queries, count, results, &err), &err);
    uint32_t wrong = 0;
    for (uint32_t i = 0; i < count; i++) {
        const pf_material_probe_result *r = &results[i];
        double cos_theta = r->direction[2];
        double length = sqrt((double)r->direction[0] * r->direction[0] +
                             (double)r->direction[1] * r->direction[1] + cos_theta * cos_theta);
        wrong += !(cos_theta > 0.0) || fabs(length - 1.0) > 1e-5 || r->flags != 0 ||
                 fabs(r->pdf - cos_theta / PI_D) > 1e-5 || r->pdf != r->eval_pdf;
        for (int c = 0; c < 3; c++)
            wrong += r->weight[c] != lambert.albedo[c] ||
                     fabs(r->eval_cos[c] / r->eval_pdf - lambert.albedo[c]) > 1e-5;
        cos2[i] = cos_theta * cos_theta;
        azimuth[i] = (atan2(r->direction[1], r->direction[0]) + PI_D) / (2.0 * PI_D);
    }
    PF_CHECK_MSG(wrong == 0, "%u samples with a wrong direction, pdf or weight", wrong);
    double critical = KS_CRITICAL_0_001 / sqrt((double)count);
    double d_cos2 = ks_uniform(cos2, count), d_azimuth = ks_uniform(azimuth, count);
    PF_CHECK_MSG(d_cos2 < critical, "cos²θ: KS distance %.4f, critical %.4f", d_cos2, critical);
    PF_CHECK_MSG(d_azimuth < critical, "azimuth: KS distance %.4f, critical %.4f", d_azimuth,
                 critical);
    free(queries);
    free(results);
    free(cos2);
    free(azimuth);
}

/*
 * The emissive alias table (pf_emissive_table_build): only emitting
 * triangles with area, each picked with probability area·luminance / total,
 * which the columns' thresholds and aliases reproduce exactly.
 */
PF_TEST(emissive_alias_table_picks_by_power)
{
    float vertices[5 * 3][4] = {
        {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, /* area 0.5, emits 1 */
        {0, 0, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, /* area 2, emits 1 */
        {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, /* area 0.5, emits 8 */
        {0, 0, 0, 0}, {1, 0, 0, 0}, {2, 0, 0, 0}, /* zero area: left out */
        {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, /* does not emit */
    };
    uint32_t triangle_material[5] = {0, 0, 1, 0, 2};
    pf_material materials[3] = {
        {{0, 0, 0}, PF_MATERIAL_LAMBERT, {1, 1, 1}, 1.5f},
        {{0, 0, 0}, PF_MATERIAL_LAMBERT, {8, 8, 8}, 1.5f},
        {{0.5f, 0.5f, 0.5f}, PF_MATERIAL_LAMBERT, {0, 0, 0}, 1.5f},
    };
    pf_scene_frame frame = {0};
    frame.triangle_count = 5;
    frame.vertices = vertices;
    frame.triangle_material = triangle_material;
    frame.material_count = 3;
    frame.materials = materials;
    pf_emissive_entry *table = NULL;
    uint32_t count = 0;
    double total = 0.0;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_emissive_table_build(&frame, &table, &count, &total, &err), &err);
    PF_REQUIRE(count == 3 && table);
    /* Rec. 709 luminance of grey radiance L is L: weights 0.5, 2 and 4. */
    const double expected[3] = {0.5 / 6.5, 2.0 / 6.5, 4.0 / 6.5};
    PF_CHECK_NEAR(total, 6.5, 1e-5);
    double implied[3] = {0, 0, 0};
    for (uint32_t i = 0; i < count; i++) {
        PF_CHECK(table[i].triangle == i);
        PF_REQUIRE(table[i].alias < count);
        implied[i] += table[i].alias_threshold / count;
        implied[table[i].alias] += (1.0 - table[i].alias_threshold) / count;
    }
    for (uint32_t i = 0; i < count; i++) {
        PF_CHECK_NEAR(implied[i], expected[i], 1e-6);
        PF_CHECK_NEAR(table[i].pick_pdf, expected[i], 1e-6);
    }
    free(table);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(fresnel_matches_tabulated_values);
    PF_RUN(mirror_reflects_exactly_tinted_by_its_colour);
    PF_RUN(glass_splits_energy_by_fresnel_and_refracts_by_snell);
    PF_RUN(lambert_samples_the_cosine_density_it_reports);
    PF_RUN(emissive_alias_table_picks_by_power);
    return render_test_finish(ctx, renderer);
}
