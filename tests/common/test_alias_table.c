/*
 * pf_alias_table_build: every index is picked with exactly its weight's
 * share (computed from the table, not sampled), including zero weights,
 * one entry and very uneven weights; bad weights are refused.
 */
#include "pf_common.h"
#include "pf_test.h"

#include <math.h>
#include <stdlib.h>

/* P(i) from the table: (1/n) Σ_c [c = i]·threshold_c + [alias_c = i]·(1 − threshold_c). */
static double max_probability_error(const double *weights, uint32_t count)
{
    float *threshold = malloc(count * sizeof *threshold);
    uint32_t *alias = malloc(count * sizeof *alias);
    double *picked = calloc(count, sizeof *picked);
    pf_error err = {0};
    double worst = INFINITY;
    if (pf_alias_table_build(weights, count, threshold, alias, &err) == PF_OK) {
        double total = 0.0;
        for (uint32_t i = 0; i < count; i++)
            total += weights[i];
        for (uint32_t c = 0; c < count; c++) {
            picked[c] += threshold[c] / count;
            picked[alias[c]] += (1.0 - threshold[c]) / count;
        }
        worst = 0.0;
        for (uint32_t i = 0; i < count; i++)
            worst = fmax(worst, fabs(picked[i] - weights[i] / total));
    }
    free(threshold);
    free(alias);
    free(picked);
    return worst;
}

PF_TEST(alias_table_probabilities_equal_the_weights)
{
    const double one[] = {3.0};
    PF_CHECK(max_probability_error(one, 1) < 1e-7);
    const double with_zeros[] = {0.0, 1.0, 0.0, 3.0, 0.0};
    PF_CHECK(max_probability_error(with_zeros, 5) < 1e-7);
    enum { MANY = 10000 };
    double *weights = malloc(MANY * sizeof *weights);
    uint32_t state = 1u;
    for (int i = 0; i < MANY; i++) {
        state = state * 1664525u + 1013904223u;
        /* Weights over 12 orders of magnitude (a sun next to tiny emissive triangles). */
        weights[i] = pow(10.0, (double)(state >> 8) / 16777216.0 * 12.0 - 6.0);
    }
    double worst = max_probability_error(weights, MANY);
    PF_CHECK_MSG(worst < 1e-7, "worst probability error %g", worst);
    free(weights);
}

PF_TEST(bad_weights_are_refused)
{
    float threshold[3];
    uint32_t alias[3];
    pf_error err = {0};
    const double negative[] = {1.0, -1.0, 1.0};
    PF_CHECK(pf_alias_table_build(negative, 3, threshold, alias, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "weight 1") != NULL);
    const double nan_weight[] = {1.0, 1.0, NAN};
    PF_CHECK(pf_alias_table_build(nan_weight, 3, threshold, alias, &err) == PF_ERR_INVALID);
    const double zeros[] = {0.0, 0.0, 0.0};
    PF_CHECK(pf_alias_table_build(zeros, 3, threshold, alias, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_alias_table_build(zeros, 0, threshold, alias, &err) == PF_ERR_INVALID);
}

int main(void)
{
    PF_RUN(alias_table_probabilities_equal_the_weights);
    PF_RUN(bad_weights_are_refused);
    return pf_test_finish();
}
