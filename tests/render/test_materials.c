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
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_D 3.14159265358979323846
#define DEGREES (PI_D / 180.0)

static pf_vk_context *ctx;
static pf_renderer *renderer;

static pf_material glass, mirror, lambert;

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
    q.geometric_normal[2] = 1.0f;
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

/*
 * A smooth metal (roughness 0: the GGX lobe's delta limit) reflects exactly,
 * tinted by Schlick's Fresnel with F0 = its base colour: F0 itself at normal
 * incidence (the conductor's F0), F0 + (1 − F0)(1 − cos θ)⁵ at 30° and 80°.
 */
PF_TEST(mirror_reflects_exactly_tinted_by_its_colour)
{
    const double angles[3] = {0.0, 30.0, 80.0};
    for (int a = 0; a < 3; a++) {
        double theta = angles[a] * DEGREES;
        pf_material_probe_query q = query_at(&mirror, theta, 1, 0.3f, 0);
        pf_material_probe_result r;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_material_probe(renderer, &q, 1, &r, &err), &err);
        PF_CHECK(r.flags == PF_PROBE_SPECULAR);
        PF_CHECK_NEAR(r.direction[0], -q.wo[0], 1e-7);
        PF_CHECK_NEAR(r.direction[1], 0.0, 1e-7);
        PF_CHECK_NEAR(r.direction[2], q.wo[2], 1e-7);
        double schlick = pow(1.0 - cos(theta), 5.0);
        for (int c = 0; c < 3; c++) {
            double f0 = mirror.albedo[c];
            if (a == 0)
                PF_CHECK_MSG(r.weight[c] == mirror.albedo[c], "F0 %g, weight %g", f0,
                             r.weight[c]);
            PF_CHECK_NEAR(r.weight[c], f0 + (1.0 - f0) * schlick, 1e-6);
            PF_CHECK(r.eval_cos[c] == 0.0f); /* a delta lobe has no density to evaluate */
        }
        PF_CHECK(r.pdf == 0.0f && r.eval_pdf == 0.0f);
    }
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
            wrong += fabs(r->weight[c] - lambert.albedo[c]) > 1e-6 ||
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
 * The glTF BSDF's directional albedo ∫ f·cos dωi for wo at polar angle
 * theta_o, by midpoint quadrature over the hemisphere in doubles: the oracle
 * of the white furnace below, written from the spec's Appendix B formulas
 * (GGX D, height-correlated V, Schlick F for the metal, exact Fresnel times
 * specular for the dielectric over a (1 − max F) Lambert base, and the clear coat's layer
 * over all of it: materials.glsl's header), not from the shader.
 */
static double oracle_albedo(const pf_material *m, double theta_o, int channel)
{
    const int steps_theta = 512, steps_phi = 512;
    double alpha = (double)m->roughness * m->roughness, a2 = alpha * alpha;
    double wo[3] = {sin(theta_o), 0.0, cos(theta_o)};
    double sum = 0.0;
    for (int i = 0; i < steps_theta; i++) {
        double theta = (i + 0.5) * (PI_D / 2) / steps_theta;
        for (int j = 0; j < steps_phi; j++) {
            double phi = (j + 0.5) * 2 * PI_D / steps_phi;
            double wi[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)};
            double h[3] = {wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]};
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            double cos_h = h[2] / hl, cos_oh = (wo[0] * h[0] + wo[2] * h[2]) / hl;
            double co = wo[2], ci = wi[2];
            double t = cos_h * cos_h * (a2 - 1) + 1;
            double d = a2 / (PI_D * t * t);
            double v = 0.5 / (ci * sqrt(co * co * (1 - a2) + a2) +
                              co * sqrt(ci * ci * (1 - a2) + a2));
            double base = m->albedo[channel];
            double metal_f = base + (1 - base) * pow(1 - cos_oh, 5);
            double dielectric_f = m->specular * fmin(ref_fresnel_dielectric(cos_oh, m->ior) *
                                                         m->specular_color[channel], 1.0);
            double f = m->metallic * metal_f * d * v +
                       (1 - m->metallic) *
                           (dielectric_f * d * v + (1 - dielectric_f) * base / PI_D);
            if (m->clearcoat > 0.0f) { /* KHR_materials_clearcoat over all of it */
                double coat_f = m->clearcoat * ref_fresnel_dielectric(cos_oh, 1.5);
                f *= 1 - coat_f;
                if (m->clearcoat_roughness > PF_MATERIAL_DELTA_ROUGHNESS) {
                    double ac = (double)m->clearcoat_roughness * m->clearcoat_roughness;
                    double ac2 = ac * ac, tc = cos_h * cos_h * (ac2 - 1) + 1;
                    double vc = 0.5 / (ci * sqrt(co * co * (1 - ac2) + ac2) +
                                       co * sqrt(ci * ci * (1 - ac2) + ac2));
                    f += coat_f * ac2 / (PI_D * tc * tc) * vc;
                }
            }
            double solid_angle = sin(theta) * (PI_D / 2 / steps_theta) * (2 * PI_D / steps_phi);
            sum += f * ci * solid_angle;
        }
    }
    /* A smooth coat's mirror reflection. */
    if (m->clearcoat > 0.0f && m->clearcoat_roughness <= PF_MATERIAL_DELTA_ROUGHNESS)
        sum += m->clearcoat * ref_fresnel_dielectric(cos(theta_o), 1.5);
    return sum;
}

/*
 * White furnace of the GGX lobes: a white metal (F0 = 1) and a white rough
 * dielectric (ior 1.5 over a white base) at several roughnesses and angles,
 * sampled from 64×64 stratified random numbers. The mean weight (what a path
 * carries on) matches the oracle's directional albedo. For the metal that is
 * the single-scattering energy: less than 1 (the light that would scatter
 * more than once among the microfacets is lost, more with roughness), and the
 * lobe never gains beyond the estimate's noise. The dielectric is the spec's
 * fresnel_mix, whose Lambert base is weighted by 1 − F at the half vector of
 * each (wo, wi): the model itself reflects more than it receives at grazing
 * angles (the oracle's +17 % at 75°, roughness 0.2), so for it the test
 * checks agreement with the model, not conservation. Each sample's weight is
 * its eval_cos/eval_pdf and its pdf is bsdf_pdf's.
 */
#define FURNACE_EDGE 64u

/* Query i of FURNACE_EDGE² takes a jittered point of its cell of the
 * FURNACE_EDGE × FURNACE_EDGE grid for the direction and a uniform lobe choice. */
static void stratified_xi(pf_material_probe_query *query, uint32_t i, uint64_t *state)
{
    query->xi[0] = (float)(((i % FURNACE_EDGE) + next_uniform(state)) / FURNACE_EDGE);
    query->xi[1] = (float)(((i / FURNACE_EDGE) + next_uniform(state)) / FURNACE_EDGE);
    query->xi[2] = (float)next_uniform(state);
}

/* A non-delta sample whose pdf is not bsdf_pdf's or whose weight is not
 * eval_cos/eval_pdf, within relative tolerance; 0 for delta and absorbed ones. */
static int sample_inconsistent(const pf_material_probe_result *s, double tolerance)
{
    if (!(s->pdf > 0.0f))
        return 0;
    return fabs(s->pdf - s->eval_pdf) > tolerance * s->pdf ||
           fabs(s->weight[0] - s->eval_cos[0] / s->eval_pdf) > tolerance * (1.0 + s->weight[0]);
}

/* What FURNACE_EDGE² stratified samples of material at polar angle theta carry (seeded by
 * seed; the samples left in results; shading normal: NULL for the geometric one, z): the mean
 * weight (red) and its standard error, the non-delta samples whose weight is not eval/pdf, and
 * the delta samples with a weight. */
typedef struct furnace_stats {
    double mean, sigma;
    uint32_t inconsistent, deltas;
} furnace_stats;

static furnace_stats furnace_run(const pf_material *material, double theta, uint64_t seed,
                                 const float *shading_normal, pf_material_probe_query *queries,
                                 pf_material_probe_result *results)
{
    furnace_stats stats = {0};
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    uint64_t state = seed;
    for (uint32_t i = 0; i < count; i++) {
        queries[i] = query_at(material, theta, 1, 0.0f, 0);
        if (shading_normal)
            memcpy(queries[i].normal, shading_normal, sizeof queries[i].normal);
        stratified_xi(&queries[i], i, &state);
    }
    pf_error err = {0};
    PF_CHECK_OK(pf_material_probe(renderer, queries, count, results, &err), &err);
    double mean_square = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        const pf_material_probe_result *r = &results[i];
        stats.mean += r->weight[0] / count;
        mean_square += (double)r->weight[0] * r->weight[0] / count;
        if (r->pdf > 0.0f)
            stats.inconsistent += sample_inconsistent(r, 1e-4);
        else
            stats.deltas += r->weight[0] != 0.0f;
    }
    stats.sigma = sqrt(fmax(mean_square - stats.mean * stats.mean, 0.0) / count);
    return stats;
}

PF_TEST(ggx_white_furnace_loses_what_single_scattering_predicts)
{
    const float roughnesses[4] = {0.25f, 0.5f, 0.75f, 1.0f};
    const double angles[3] = {0.0, 45.0, 75.0};
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    for (int kind = 0; kind < 2; kind++) {
        for (int r = 0; r < 4; r++) {
            pf_material material =
                kind == 0 ? pf_material_mirror(1, 1, 1) : pf_material_lambert(1, 1, 1);
            material.roughness = roughnesses[r];
            material.specular = 1.0f; /* the dielectric: a white base under its coat */
            pf_material_classify(&material);
            for (int a = 0; a < 3; a++) {
                double theta = angles[a] * DEGREES;
                furnace_stats stats =
                    furnace_run(&material, theta, 7 + (uint64_t)(r * 3 + a), NULL, queries,
                                results);
                double mean = stats.mean, sigma = stats.sigma;
                /* No delta lobe when rough. */
                uint32_t inconsistent = stats.inconsistent + stats.deltas;
                double expected = oracle_albedo(&material, theta, 0);
                const char *name = kind == 0 ? "metal" : "dielectric";
                PF_CHECK_MSG(inconsistent == 0, "%s r %.2f at %.0f°: %u samples whose weight is "
                             "not eval/pdf", name, roughnesses[r], angles[a], inconsistent);
                PF_CHECK_MSG(fabs(mean - expected) <= 0.01 + 4 * sigma,
                             "%s r %.2f at %.0f°: mean weight %.4f, single scattering %.4f",
                             name, roughnesses[r], angles[a], mean, expected);
                if (kind == 0) {
                    PF_CHECK_MSG(mean <= 1.0 + 4 * sigma, "metal r %.2f at %.0f°: gains energy "
                                 "(%.4f)", roughnesses[r], angles[a], mean);
                    PF_CHECK_MSG(expected < 1.0, "metal r %.2f: oracle %.4f", roughnesses[r],
                                 expected);
                }
                printf("furnace %-10s roughness %.2f at %2.0f°: mean %.4f ± %.4f, oracle %.4f\n",
                       name, roughnesses[r], angles[a], mean, sigma, expected);
            }
        }
    }
    free(queries);
    free(results);
}


/*
 * KHR_materials_clearcoat: a coat over a white Lambert base, a grey rough metal and a black
 * base (the coat alone), rough and smooth, at several angles, sampled as the furnace above.
 * The mean weight matches the oracle's directional albedo (the coat's lobe over what it lets
 * through), every rough sample's weight is eval/pdf, and a smooth coat's mirror sample
 * carries c·F_c at n·wo over its choice. The coat adds reflection where the base has little:
 * over black it is the dielectric's (0.04 at normal incidence for a smooth coat).
 */
PF_TEST(a_clear_coat_reflects_over_its_base_as_the_oracle_says)
{
    const float coat_roughness[2] = {0.3f, 0.0f};
    const double angles[3] = {0.0, 45.0, 75.0};
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    for (int base = 0; base < 3; base++) {
        for (int r = 0; r < 2; r++) {
            pf_material material = base == 1 ? pf_material_mirror(0.5f, 0.5f, 0.5f)
                                             : pf_material_lambert(base == 0 ? 1.0f : 0.0f,
                                                                   base == 0 ? 1.0f : 0.0f,
                                                                   base == 0 ? 1.0f : 0.0f);
            if (base == 1)
                material.roughness = 0.6f;
            material.clearcoat = base == 2 ? 1.0f : 0.7f;
            material.clearcoat_roughness = coat_roughness[r];
            pf_material_classify(&material);
            for (int a = 0; a < 3; a++) {
                double theta = angles[a] * DEGREES;
                furnace_stats stats =
                    furnace_run(&material, theta, 91 + (uint64_t)(base * 6 + r * 3 + a), NULL,
                                queries, results);
                double mean = stats.mean, sigma = stats.sigma;
                uint32_t inconsistent = stats.inconsistent, mirrored = stats.deltas;
                double coat_f = material.clearcoat * ref_fresnel_dielectric(cos(theta), 1.5);
                /* Only a smooth coat has a delta lobe here: the mirror of wo. */
                for (uint32_t i = 0; i < count; i++)
                    if (!(results[i].pdf > 0.0f) && results[i].weight[0] != 0.0f)
                        inconsistent += r == 0 || fabs(results[i].direction[2] - cos(theta)) > 1e-4;
                double expected = oracle_albedo(&material, theta, 0);
                static const char *const names[3] = {"white Lambert", "grey metal", "black"};
                PF_CHECK_MSG(inconsistent == 0, "coat %.1f over %s at %.0f°: %u inconsistent "
                             "samples", coat_roughness[r], names[base], angles[a], inconsistent);
                PF_CHECK_MSG(fabs(mean - expected) <= 0.01 + 4 * sigma,
                             "coat %.1f over %s at %.0f°: mean weight %.4f, oracle %.4f",
                             coat_roughness[r], names[base], angles[a], mean, expected);
                PF_CHECK_MSG(r == 1 ? mirrored > 0 : mirrored == 0, "coat %.1f over %s: %u "
                             "mirror samples", coat_roughness[r], names[base], mirrored);
                if (base == 2)
                    PF_CHECK_MSG(expected >= coat_f * 0.5 && expected <= coat_f * 1.5 + 0.01,
                                 "the coat alone at %.0f°: %.4f against F %.4f", angles[a],
                                 expected, coat_f);
                printf("coat %.1f over %-13s at %2.0f°: mean %.4f ± %.4f, oracle %.4f\n",
                       coat_roughness[r], names[base], angles[a], mean, sigma, expected);
            }
        }
    }
    free(queries);
    free(results);
}
/*
 * KHR_materials_sheen's oracle (ref_sheen_f_cos: the spec's formulas in doubles, E bilinear in
 * the albedo table that test_sheen_albedo_table keeps the generator's) over a white sheen and
 * a Lambert base of albedo base, integrated by midpoint quadrature over the hemisphere. The
 * lobe's own albedo (base 0) is E itself, so the furnace below also checks the table against
 * the shader's lobe.
 */
static double sheen_oracle(double roughness, double base, double theta_o)
{
    const int steps_theta = 512, steps_phi = 128;
    double wo[3] = {sin(theta_o), 0.0, cos(theta_o)}, sum = 0.0;
    for (int i = 0; i < steps_theta; i++) {
        double theta = (i + 0.5) * (PI_D / 2) / steps_theta, ci = cos(theta);
        for (int j = 0; j < steps_phi; j++) {
            double phi = (j + 0.5) * PI_D / steps_phi; /* half the circle, twice */
            double h[3] = {wo[0] + sin(theta) * cos(phi), sin(theta) * sin(phi), wo[2] + ci};
            double cos_h = h[2] / sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            sum += ref_sheen_f_cos(1.0, 1.0, roughness, base, wo[2], ci, cos_h) * sin(theta) *
                   (PI_D / 2 / steps_theta) * (2 * PI_D / steps_phi);
        }
    }
    return sum;
}

/*
 * KHR_materials_sheen: a white sheen over black (the lobe alone) and over a white Lambert
 * base, at sheen roughness 0.3, 0.6 and 1 and three angles, sampled as the furnace above.
 * The mean weight matches the oracle and every sample's weight is eval/pdf; over the white
 * base the albedo scaling keeps the sum at or below 1 (the base gives up what the sheen
 * takes). The rough albedo (what estimates multiply irradiance by) matches the oracle within
 * 2 %: alone it is the table's E at n·wo; over the base, the base keeps 1 − B (the table's
 * scaling over every wi; 1 − E at n·wo alone read 1.000 where the oracle has 0.864).
 * Without the scaling the white base under a sheen would reflect 1 + E.
 */
PF_TEST(a_sheen_reflects_its_lobe_over_the_base_it_scales)
{
    const float roughnesses[3] = {0.3f, 0.6f, 1.0f};
    const double angles[3] = {0.0, 45.0, 75.0};
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    for (int base = 0; base < 2; base++) {
        for (int r = 0; r < 3; r++) {
            pf_material material = pf_material_lambert((float)base, (float)base, (float)base);
            material.sheen_color[0] = material.sheen_color[1] = material.sheen_color[2] = 1.0f;
            material.sheen_roughness = roughnesses[r];
            for (int a = 0; a < 3; a++) {
                double theta = angles[a] * DEGREES;
                furnace_stats stats =
                    furnace_run(&material, theta, 301 + (uint64_t)(base * 9 + r * 3 + a), NULL,
                                queries, results);
                double expected = sheen_oracle(roughnesses[r], base, theta);
                double rough_albedo = results[0].rough_albedo[0];
                const char *name = base ? "white Lambert" : "black";
                PF_CHECK_MSG(stats.inconsistent == 0 && stats.deltas == 0,
                             "sheen %.1f over %s at %.0f°: %u inconsistent, %u delta samples",
                             roughnesses[r], name, angles[a], stats.inconsistent, stats.deltas);
                PF_CHECK_MSG(fabs(stats.mean - expected) <= 0.01 + 4 * stats.sigma,
                             "sheen %.1f over %s at %.0f°: mean weight %.4f, oracle %.4f",
                             roughnesses[r], name, angles[a], stats.mean, expected);
                if (base)
                    PF_CHECK_MSG(expected <= 1.0 && stats.mean <= 1.0 + 4 * stats.sigma,
                                 "sheen %.1f over white at %.0f°: gains energy (%.4f, oracle "
                                 "%.4f)", roughnesses[r], angles[a], stats.mean, expected);
                else
                    PF_CHECK_MSG(fabs(rough_albedo - ref_sheen_table(0, cos(theta), roughnesses[r])) <
                                     1e-5,
                                 "sheen %.1f alone at %.0f°: rough albedo %.4f, E %.4f",
                                 roughnesses[r], angles[a], rough_albedo,
                                 ref_sheen_table(0, cos(theta), roughnesses[r]));
                PF_CHECK_MSG(fabs(rough_albedo - expected) <= 0.02 * expected + 0.002,
                             "sheen %.1f over %s at %.0f°: rough albedo %.4f, oracle %.4f",
                             roughnesses[r], name, angles[a], rough_albedo, expected);
                printf("sheen %.1f over %-13s at %2.0f°: mean %.4f ± %.4f, oracle %.4f, rough "
                       "albedo %.4f\n",
                       roughnesses[r], name, angles[a], stats.mean, stats.sigma, expected,
                       rough_albedo);
            }
        }
    }
    free(queries);
    free(results);
}

/*
 * Rough glass's directional albedo for flux (importance transport): the
 * reflection F·D·V·cos over the upper hemisphere plus Walter et al.'s BTDF
 * (1 − F)·D·G₂·|wi·h|(wo·h)/(cos_o (wi·h + wo·h/η)²) over the lower one, by
 * midpoint quadrature over the sphere in doubles.
 */
static double rough_glass_albedo(double roughness, double eta, double theta_o)
{
    const int steps_theta = 1024, steps_phi = 512;
    double alpha = roughness * roughness, a2 = alpha * alpha;
    double wo[3] = {sin(theta_o), 0.0, cos(theta_o)}, co = wo[2];
    double lambda_o = 0.5 * (sqrt(1.0 + a2 * (1.0 - co * co) / (co * co)) - 1.0);
    double sum = 0.0;
    for (int i = 0; i < steps_theta; i++) {
        double theta = (i + 0.5) * PI_D / steps_theta;
        for (int j = 0; j < steps_phi; j++) {
            double phi = (j + 0.5) * 2 * PI_D / steps_phi;
            double wi[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)};
            double solid_angle = sin(theta) * (PI_D / steps_theta) * (2 * PI_D / steps_phi);
            double ci = fabs(wi[2]);
            double lambda_i = 0.5 * (sqrt(1.0 + a2 * (1.0 - ci * ci) / (ci * ci)) - 1.0);
            double g2 = 1.0 / (1.0 + lambda_o + lambda_i);
            double h[3];
            double scale = wi[2] > 0 ? 1.0 : eta;
            for (int k = 0; k < 3; k++)
                h[k] = scale * wi[k] + wo[k];
            double hl = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
            double sign = h[2] < 0 ? -1.0 : 1.0;
            for (int k = 0; k < 3; k++)
                h[k] *= sign / hl;
            double oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            double ih = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
            double t = h[2] * h[2] * (a2 - 1) + 1;
            double d = a2 / (PI_D * t * t);
            double f = ref_fresnel_dielectric(fmin(fmax(oh, 0.0), 1.0), eta);
            if (wi[2] > 0) {
                sum += f * d * g2 / (4 * co * ci) * ci * solid_angle;
            } else if (oh > 0 && ih < 0) {
                double denominator = ih + oh / eta;
                sum += (1 - f) * d * g2 * fabs(ih) * oh / (co * denominator * denominator) *
                       solid_angle;
            }
        }
    }
    return sum;
}


/*
 * A base normal map does not tilt the coat (KHR_materials_clearcoat: without a
 * clearcoatNormalTexture the coat keeps the mesh's normal): a black base under a coat, its
 * shading normal tilted 30° by a map and the coat's normal the mesh's (z, as surface_at sets
 * it), reflects what the untilted coat does at every angle (the oracle's coat alone), and a
 * smooth coat mirrors wo about z, not about the tilted normal.
 */
PF_TEST(a_base_normal_map_does_not_tilt_the_coat)
{
    const float coat_roughness[2] = {0.3f, 0.0f};
    const double angles[3] = {0.0, 45.0, 75.0};
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    const float tilted[3] = {(float)sin(30.0 * DEGREES), 0.0f, (float)cos(30.0 * DEGREES)};
    for (int r = 0; r < 2; r++) {
        pf_material material = pf_material_lambert(0.0f, 0.0f, 0.0f);
        material.clearcoat = 1.0f;
        material.clearcoat_roughness = coat_roughness[r];
        pf_material_classify(&material);
        pf_material coated = material;
        coated.coat_normal[2] = 1.0f;
        for (int a = 0; a < 3; a++) {
            double theta = angles[a] * DEGREES;
            furnace_stats stats = furnace_run(&coated, theta, 131 + (uint64_t)(r * 3 + a),
                                              tilted, queries, results);
            uint32_t inconsistent = stats.inconsistent;
            for (uint32_t i = 0; i < count; i++) /* a delta sample: the mirror of wo about z */
                if (!(results[i].pdf > 0.0f) && results[i].weight[0] != 0.0f)
                    inconsistent += fabs(results[i].direction[0] + sin(theta)) > 1e-4 ||
                                    fabs(results[i].direction[2] - cos(theta)) > 1e-4;
            double expected = oracle_albedo(&material, theta, 0);
            printf("coat %.1f under a 30° normal map at %2.0f°: mean %.4f ± %.4f, untilted "
                   "oracle %.4f\n",
                   coat_roughness[r], angles[a], stats.mean, stats.sigma, expected);
            PF_CHECK_MSG(inconsistent == 0, "coat %.1f at %.0f°: %u inconsistent samples",
                         coat_roughness[r], angles[a], inconsistent);
            PF_CHECK_MSG(fabs(stats.mean - expected) <= 0.002 + 4 * stats.sigma,
                         "coat %.1f at %.0f°: mean %.4f, the untilted coat %.4f",
                         coat_roughness[r], angles[a], stats.mean, expected);
        }
    }
    free(queries);
    free(results);
}
/*
 * Rough glass (KHR_materials_transmission 1 at roughness 0.3 and 0.6, ior
 * 1.5), entering and leaving: the mean flux weight of 64×64 stratified
 * samples matches the quadrature above (so the BTDF's sampling, pdf and
 * weight agree with Walter et al.'s formula), stays within 1 (the single-
 * scattering loss, never a gain), and every radiance sample's weight is its
 * eval_cos/eval_pdf, transmitted ones included: next-event estimation sees
 * light through rough glass as sampling does.
 */
PF_TEST(rough_glass_transmits_by_walters_btdf)
{
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    const float roughnesses[2] = {0.3f, 0.6f};
    const double angles[2] = {20.0, 60.0};
    for (int r = 0; r < 2; r++) {
        pf_material material = pf_material_glass(1.5f, 1, 1, 1);
        material.roughness = roughnesses[r];
        pf_material_classify(&material);
        PF_CHECK(material.kind == PF_MATERIAL_GLASS);
        for (int side = 0; side < 2; side++) {
            for (int a = 0; a < 2; a++) {
                double theta = angles[a] * DEGREES;
                for (uint32_t transport = 0; transport < 2; transport++) {
                    uint64_t state = 5 + (uint64_t)(r * 8 + side * 4 + a * 2 + (int)transport);
                    for (uint32_t i = 0; i < count; i++) {
                        queries[i] = query_at(&material, theta, side == 0, 0.0f,
                                              transport ? PF_PROBE_IMPORTANCE : 0);
                        stratified_xi(&queries[i], i, &state);
                    }
                    pf_error err = {0};
                    PF_REQUIRE_OK(pf_material_probe(renderer, queries, count, results, &err),
                                  &err);
                    double mean = 0.0, mean_square = 0.0;
                    uint32_t inconsistent = 0, transmitted = 0;
                    for (uint32_t i = 0; i < count; i++) {
                        const pf_material_probe_result *s = &results[i];
                        mean += s->weight[0] / count;
                        mean_square += (double)s->weight[0] * s->weight[0] / count;
                        transmitted += (s->flags & PF_PROBE_TRANSMITTED) != 0;
                        if (transport == 0)
                            inconsistent += sample_inconsistent(s, 1e-3);
                        inconsistent += (s->flags & PF_PROBE_SPECULAR) != 0;
                    }
                    const char *where = side == 0 ? "entering" : "leaving";
                    PF_CHECK_MSG(inconsistent == 0, "r %.1f %s at %.0f°: %u inconsistent samples",
                                 roughnesses[r], where, angles[a], inconsistent);
                    /* Leaving past the critical angle (41.8°), only microfacets tilted
                     * towards wo let light out: few samples, but some. */
                    uint32_t least = side == 1 && angles[a] > 41.8 ? 1 : count / 4;
                    PF_CHECK_MSG(transmitted >= least, "r %.1f %s at %.0f°: %u transmitted",
                                 roughnesses[r], where, angles[a], transmitted);
                    if (transport == 0)
                        continue;
                    double eta = side == 0 ? 1.5 : 1.0 / 1.5;
                    double expected = rough_glass_albedo(roughnesses[r], eta, theta);
                    double sigma = sqrt(fmax(mean_square - mean * mean, 0.0) / count);
                    PF_CHECK_MSG(fabs(mean - expected) <= 0.01 + 4 * sigma,
                                 "r %.1f %s at %.0f°: mean flux weight %.4f, quadrature %.4f",
                                 roughnesses[r], where, angles[a], mean, expected);
                    PF_CHECK_MSG(mean <= 1.0 + 4 * sigma && expected < 1.0,
                                 "r %.1f %s at %.0f°: gains energy (%.4f, quadrature %.4f)",
                                 roughnesses[r], where, angles[a], mean, expected);
                    printf("rough glass r %.1f %-8s at %2.0f°: flux %.4f ± %.4f, quadrature "
                           "%.4f, %u of %u transmitted\n",
                           roughnesses[r], where, angles[a], mean, sigma, expected, transmitted,
                           count);
                }
            }
        }
    }
    free(queries);
    free(results);
}

/*
 * At a smooth mesh's silhouette the interpolated normal can face away from
 * wo while the face itself faces it: here the shading normal leans 60°
 * towards −x and wo arrives at 70° from +x, 130° from the shading normal.
 * Lambert, rough metal and rough dielectric then build their lobes around
 * the geometric normal in sampling, evaluation and pdf alike: every sample
 * keeps weight = eval_cos/eval_pdf and pdf = eval_pdf (so next-event
 * estimation and MIS see what sampling does), and light is not lost there.
 */
PF_TEST(lobes_agree_where_the_shading_normal_faces_away)
{
    uint32_t count = FURNACE_EDGE * FURNACE_EDGE;
    pf_material_probe_query *queries = calloc(count, sizeof *queries);
    pf_material_probe_result *results = calloc(count, sizeof *results);
    PF_REQUIRE(queries && results);
    pf_material materials[3] = {pf_material_lambert(0.8f, 0.8f, 0.8f),
                                pf_material_mirror(0.9f, 0.9f, 0.9f),
                                pf_material_lambert(0.8f, 0.8f, 0.8f)};
    materials[1].roughness = 0.5f;
    materials[2].roughness = 0.5f;
    materials[2].specular = 1.0f;
    const char *names[3] = {"lambert", "rough metal", "rough dielectric"};
    for (int k = 0; k < 3; k++) {
        pf_material_classify(&materials[k]);
        uint64_t state = 99 + (uint64_t)k;
        for (uint32_t i = 0; i < count; i++) {
            queries[i] = query_at(&materials[k], 70.0 * DEGREES, 1, 0.0f, 0);
            queries[i].normal[0] = (float)-sin(60.0 * DEGREES);
            queries[i].normal[2] = (float)cos(60.0 * DEGREES);
            queries[i].xi[0] = (float)next_uniform(&state);
            queries[i].xi[1] = (float)next_uniform(&state);
            queries[i].xi[2] = (float)next_uniform(&state);
        }
        pf_error err = {0};
        PF_REQUIRE_OK(pf_material_probe(renderer, queries, count, results, &err), &err);
        uint32_t inconsistent = 0, kept = 0;
        double mean = 0.0;
        for (uint32_t i = 0; i < count; i++) {
            const pf_material_probe_result *s = &results[i];
            mean += s->weight[0] / count;
            if (!(s->pdf > 0.0f))
                continue;
            kept++;
            inconsistent += sample_inconsistent(s, 1e-4);
        }
        PF_CHECK_MSG(inconsistent == 0, "%s: %u of %u samples whose eval/pdf disagree with "
                     "sampling", names[k], inconsistent, kept);
        PF_CHECK_MSG(kept > count / 2 && mean > 0.5, "%s: %u samples kept, mean weight %.3f",
                     names[k], kept, mean);
    }
    free(queries);
    free(results);
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
    pf_material materials[3] = {pf_material_lambert(0, 0, 0), pf_material_lambert(0, 0, 0),
                                pf_material_lambert(0.5f, 0.5f, 0.5f)};
    materials[0].emission[0] = materials[0].emission[1] = materials[0].emission[2] = 1;
    materials[1].emission[0] = materials[1].emission[1] = materials[1].emission[2] = 8;
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
    glass = pf_material_glass(1.5f, 1, 1, 1);
    mirror = pf_material_mirror(0.9f, 0.6f, 0.3f);
    lambert = pf_material_lambert(0.7f, 0.5f, 0.2f);
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(fresnel_matches_tabulated_values);
    PF_RUN(mirror_reflects_exactly_tinted_by_its_colour);
    PF_RUN(glass_splits_energy_by_fresnel_and_refracts_by_snell);
    PF_RUN(lambert_samples_the_cosine_density_it_reports);
    PF_RUN(ggx_white_furnace_loses_what_single_scattering_predicts);
    PF_RUN(a_clear_coat_reflects_over_its_base_as_the_oracle_says);
    PF_RUN(a_sheen_reflects_its_lobe_over_the_base_it_scales);
    PF_RUN(a_base_normal_map_does_not_tilt_the_coat);
    PF_RUN(lobes_agree_where_the_shading_normal_faces_away);
    PF_RUN(rough_glass_transmits_by_walters_btdf);
    PF_RUN(emissive_alias_table_picks_by_power);
    return render_test_finish(ctx, renderer);
}
