/*
 * The host's à-trous pass 4 pixels a vector (denoise_atrous_body.h), for any target, and
 * the choice between it and the 8-wide AVX2 build (denoise_atrous_avx2.c) where the CPU runs
 * that.
 */
#define ATROUS_WIDTH 4
#define ATROUS_NAME pf_denoise_atrous_rows_4
#include "denoise_atrous_body.h"

void pf_denoise_atrous_rows(denoise_planes *planes, int step, int row_begin, int row_end)
{
#if defined(PF_DENOISE_AVX2)
    if (__builtin_cpu_supports("avx2")) {
        pf_denoise_atrous_rows_8(planes, step, row_begin, row_end);
        return;
    }
#endif
    pf_denoise_atrous_rows_4(planes, step, row_begin, row_end);
}
