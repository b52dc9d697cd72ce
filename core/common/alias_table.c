/*
 * pf_alias_table_build: the alias tables that pick emitters by power (area
 * lights in the integrators, every light in photon emission).
 */
#include "pf_common.h"

#include <math.h>
#include <stdlib.h>

pf_status pf_alias_table_build(const double *weights, uint32_t count, float *threshold,
                               uint32_t *alias, pf_error *err)
{
    double total = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        if (!isfinite(weights[i]) || weights[i] < 0.0)
            return pf_error_set(err, PF_ERR_INVALID, "alias table: weight %u is %g (finite, >= 0)",
                                i, weights[i]);
        total += weights[i];
    }
    if (!(total > 0.0) || !isfinite(total))
        return pf_error_set(err, PF_ERR_INVALID, "alias table: %u weights sum to %g (> 0 needed)",
                            count, total);
    double *scaled = malloc(count * sizeof *scaled);
    uint32_t *small = malloc(count * sizeof *small);
    uint32_t *large = malloc(count * sizeof *large);
    if (!scaled || !small || !large) {
        free(scaled);
        free(small);
        free(large);
        return pf_error_set(err, PF_ERR_NOMEM, "alias table: %u entries", count);
    }
    /*
     * Column i starts with n·p_i; a column under 1 ("small") is topped up by
     * one over 1 ("large"), which becomes its alias and gives up the
     * difference. Rounding leftovers keep threshold 1.
     */
    uint32_t small_count = 0, large_count = 0;
    for (uint32_t i = 0; i < count; i++) {
        scaled[i] = weights[i] / total * count;
        alias[i] = i;
        threshold[i] = 1.0f;
        if (scaled[i] < 1.0)
            small[small_count++] = i;
        else
            large[large_count++] = i;
    }
    while (small_count > 0 && large_count > 0) {
        uint32_t under = small[--small_count];
        uint32_t over = large[large_count - 1];
        threshold[under] = (float)scaled[under];
        alias[under] = over;
        scaled[over] -= 1.0 - scaled[under];
        if (scaled[over] < 1.0) {
            large_count--;
            small[small_count++] = over;
        }
    }
    free(scaled);
    free(small);
    free(large);
    return PF_OK;
}
