/*
 * The photon record's packing: RGB9E5 flux (rounding, range, clamping, no
 * bias in sums) and 8-bit octahedral directions (error bound, exact axes).
 */
#include "pf_photon.h"
#include "pf_test.h"

#include <math.h>
#include <stdint.h>

static uint32_t next_random(uint32_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    return *state;
}

static float uniform01(uint32_t *state)
{
    return (float)(next_random(state) >> 8) / 16777216.0f;
}

PF_TEST(rgb9e5_round_trip_error_is_within_half_a_step)
{
    uint32_t rng = 12345u;
    int bad = 0;
    for (int i = 0; i < 100000; i++) {
        float scale = powf(10.0f, -4.0f + 8.0f * uniform01(&rng));
        float rgb[3] = {scale * uniform01(&rng), scale * uniform01(&rng), scale * uniform01(&rng)};
        float back[3];
        pf_rgb9e5_unpack(pf_rgb9e5_pack(rgb), back);
        float largest = fmaxf(rgb[0], fmaxf(rgb[1], rgb[2]));
        /*
         * A step is 2^-8 of the largest's power of two 2^e <= largest, or
         * 2^-7 when rounding carried into the next exponent: half a step is
         * at most largest / 256; below 2^-16 the exponent stops at its
         * minimum and the step stays 2^-24.
         */
        float bound = fmaxf(largest / 256.0f, 0x1p-25f);
        for (int c = 0; c < 3; c++) {
            if (!(fabsf(back[c] - rgb[c]) <= bound) && bad++ < 3)
                fprintf(stderr, "(%g %g %g) channel %d -> %g\n", (double)rgb[0], (double)rgb[1],
                        (double)rgb[2], c, (double)back[c]);
        }
    }
    PF_CHECK_MSG(bad == 0, "%d channels beyond half a step", bad);
}

PF_TEST(rgb9e5_exact_values_clamping_and_invalid_input)
{
    float one[3] = {1.0f, 0.5f, 0.25f}, back[3];
    pf_rgb9e5_unpack(pf_rgb9e5_pack(one), back);
    PF_CHECK(back[0] == 1.0f && back[1] == 0.5f && back[2] == 0.25f);
    float big[3] = {1e9f, PF_RGB9E5_MAX, 3.0f};
    pf_rgb9e5_unpack(pf_rgb9e5_pack(big), back);
    PF_CHECK(back[0] == PF_RGB9E5_MAX && back[1] == PF_RGB9E5_MAX);
    float invalid[3] = {-1.0f, NAN, 0.0f};
    PF_CHECK(pf_rgb9e5_pack(invalid) == 0);
    /* 511.75 rounds up to 512: the exponent must carry (else the mantissa overflows 9 bits). */
    float carry[3] = {511.75f, 0.0f, 0.0f};
    pf_rgb9e5_unpack(pf_rgb9e5_pack(carry), back);
    PF_CHECK_MSG(back[0] == 512.0f, "511.75 -> %g", (double)back[0]);
}

PF_TEST(rgb9e5_sums_are_unbiased)
{
    /* Round to nearest: the error of a sum of many photons averages out. */
    uint32_t rng = 99u;
    double exact = 0.0, packed = 0.0;
    for (int i = 0; i < 200000; i++) {
        float rgb[3] = {0.5f + uniform01(&rng), 0.2f * uniform01(&rng), uniform01(&rng)};
        float back[3];
        pf_rgb9e5_unpack(pf_rgb9e5_pack(rgb), back);
        exact += rgb[1];
        packed += back[1];
    }
    PF_CHECK_MSG(fabs(packed / exact - 1.0) < 1e-4, "sum ratio %.6f", packed / exact);
}

PF_TEST(octahedral_directions_within_a_degree_and_axes_exact)
{
    uint32_t rng = 7u;
    double worst = 0.0;
    for (int i = 0; i < 100000; i++) {
        float z = 2.0f * uniform01(&rng) - 1.0f;
        float phi = 6.2831853f * uniform01(&rng);
        float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
        float d[3] = {r * cosf(phi), r * sinf(phi), z}, back[3];
        pf_octahedral_unpack8(pf_octahedral_pack8(d), back);
        double dot = (double)d[0] * back[0] + (double)d[1] * back[1] + (double)d[2] * back[2];
        double angle = acos(fmin(1.0, dot)) * 180.0 / 3.14159265358979;
        worst = angle > worst ? angle : worst;
    }
    PF_CHECK_MSG(worst < 1.0, "worst angular error %.3f degrees", worst);
    printf("  octahedral 8+8: worst error %.3f degrees\n", worst);
    const float axes[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (int a = 0; a < 6; a++) {
        float back[3];
        pf_octahedral_unpack8(pf_octahedral_pack8(axes[a]), back);
        PF_CHECK_MSG(back[0] == axes[a][0] && back[1] == axes[a][1] && back[2] == axes[a][2],
                     "axis %d -> (%g, %g, %g)", a, (double)back[0], (double)back[1],
                     (double)back[2]);
    }
    float zero[3] = {0, 0, 0}, back[3];
    pf_octahedral_unpack8(pf_octahedral_pack8(zero), back);
    PF_CHECK(back[2] == 1.0f);
}

PF_TEST(photon_record_round_trip)
{
    float position[3] = {1.5f, -2.25f, 1e5f}, flux[3] = {0.75f, 1.0f, 0.125f};
    float incoming[3] = {0.0f, -1.0f, 0.0f}, normal[3] = {0.0f, 1.0f, 0.0f};
    pf_photon photon;
    pf_photon_pack(position, flux, incoming, normal, &photon);
    float p[3], f[3], in[3], n[3];
    pf_photon_unpack(&photon, p, f, in, n);
    PF_CHECK(p[0] == position[0] && p[1] == position[1] && p[2] == position[2]);
    PF_CHECK(f[0] == 0.75f && f[1] == 1.0f && f[2] == 0.125f);
    PF_CHECK(in[1] == -1.0f && n[1] == 1.0f);
}

int main(void)
{
    PF_RUN(rgb9e5_round_trip_error_is_within_half_a_step);
    PF_RUN(rgb9e5_exact_values_clamping_and_invalid_input);
    PF_RUN(rgb9e5_sums_are_unbiased);
    PF_RUN(octahedral_directions_within_a_degree_and_axes_exact);
    PF_RUN(photon_record_round_trip);
    return pf_test_finish();
}
