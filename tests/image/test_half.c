/*
 * IEEE binary16 conversion: every half pattern round-trips, rounding is to
 * nearest with ties to even (checked at every midpoint between adjacent halves,
 * not against another implementation), overflow and underflow edges.
 */
#include "pf_image.h"
#include "pf_test.h"

#include <stdint.h>

static float float_from_bits(uint32_t bits)
{
    float value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static int half_is_nan(uint16_t half) { return (half & 0x7c00u) == 0x7c00u && (half & 0x3ffu); }

PF_TEST(every_half_round_trips)
{
    int mismatches = 0;
    for (uint32_t pattern = 0; pattern <= 0xffffu; pattern++) {
        uint16_t half = (uint16_t)pattern;
        float value = pf_half_to_float(half);
        uint16_t back = pf_float_to_half(value);
        if (half_is_nan(half)) {
            if (!isnan(value) || !half_is_nan(back) || (back & 0x8000u) != (half & 0x8000u))
                mismatches++;
        } else if (back != half) {
            mismatches++;
        }
    }
    PF_CHECK_MSG(mismatches == 0, "%d half patterns did not round-trip", mismatches);
}

PF_TEST(known_values)
{
    PF_CHECK(pf_float_to_half(1.0f) == 0x3c00u);
    PF_CHECK(pf_float_to_half(-2.0f) == 0xc000u);
    PF_CHECK(pf_float_to_half(65504.0f) == 0x7bffu);
    PF_CHECK(pf_float_to_half(0.0f) == 0x0000u);
    PF_CHECK(pf_float_to_half(-0.0f) == 0x8000u);
    PF_CHECK(pf_half_to_float(0x0001u) == ldexpf(1.0f, -24)); /* smallest subnormal */
    PF_CHECK(pf_half_to_float(0x0400u) == ldexpf(1.0f, -14)); /* smallest normal */
    PF_CHECK(pf_half_to_float(0x3555u) == 0.333251953125f);
    PF_CHECK(isinf(pf_half_to_float(0xfc00u)) && pf_half_to_float(0xfc00u) < 0);
}

/* Midpoints between adjacent finite halves go to the even one; one float ulp
 * either side goes to the nearer one. */
PF_TEST(rounds_to_nearest_even)
{
    int wrong = 0;
    for (uint32_t low = 0; low < 0x7bffu; low++) {
        uint16_t high = (uint16_t)(low + 1);
        float a = pf_half_to_float((uint16_t)low), b = pf_half_to_float(high);
        float midpoint = (a + b) * 0.5f; /* exact: halves have 11 significant bits */
        uint16_t even = (low & 1u) ? high : (uint16_t)low;
        if (pf_float_to_half(midpoint) != even)
            wrong++;
        if (pf_float_to_half(nextafterf(midpoint, 0.0f)) != low)
            wrong++;
        if (pf_float_to_half(nextafterf(midpoint, INFINITY)) != high)
            wrong++;
        if (pf_float_to_half(-midpoint) != (uint16_t)(even | 0x8000u))
            wrong++;
    }
    PF_CHECK_MSG(wrong == 0, "%d roundings wrong", wrong);
}

PF_TEST(overflow_and_underflow)
{
    /* 65520 is the midpoint between 65504 and 2^16: ties to even give inf. */
    PF_CHECK(pf_float_to_half(65519.996f) == 0x7bffu);
    PF_CHECK(pf_float_to_half(65520.0f) == 0x7c00u);
    PF_CHECK(pf_float_to_half(1e10f) == 0x7c00u);
    PF_CHECK(pf_float_to_half(-3.4e38f) == 0xfc00u);
    PF_CHECK(pf_float_to_half(INFINITY) == 0x7c00u);
    PF_CHECK(pf_float_to_half(-INFINITY) == 0xfc00u);
    float tie = ldexpf(1.0f, -25); /* half of the smallest subnormal: ties to 0 */
    PF_CHECK(pf_float_to_half(tie) == 0x0000u);
    PF_CHECK(pf_float_to_half(nextafterf(tie, 1.0f)) == 0x0001u);
    PF_CHECK(pf_float_to_half(-nextafterf(tie, 1.0f)) == 0x8001u);
    PF_CHECK(pf_float_to_half(1e-30f) == 0x0000u);
    PF_CHECK(pf_float_to_half(float_from_bits(0x00000001u)) == 0x0000u); /* float denormal */
    PF_CHECK(pf_float_to_half(1.5f * ldexpf(1.0f, -24)) == 0x0002u); /* tie to even: 2 */
    PF_CHECK(pf_float_to_half(2.5f * ldexpf(1.0f, -24)) == 0x0002u);
}

PF_TEST(nan_stays_nan)
{
    uint32_t patterns[] = {0x7fc00000u, 0xffc00000u, 0x7f800001u, 0x7fbfffffu, 0x7f802000u};
    for (size_t i = 0; i < sizeof patterns / sizeof *patterns; i++) {
        uint16_t half = pf_float_to_half(float_from_bits(patterns[i]));
        PF_CHECK_MSG(half_is_nan(half), "float 0x%08x -> half 0x%04x", patterns[i], half);
        PF_CHECK(((half >> 15) & 1u) == (patterns[i] >> 31));
    }
}

int main(void)
{
    PF_RUN(every_half_round_trips);
    PF_RUN(known_values);
    PF_RUN(rounds_to_nearest_even);
    PF_RUN(overflow_and_underflow);
    PF_RUN(nan_stays_nan);
    return pf_test_finish();
}
