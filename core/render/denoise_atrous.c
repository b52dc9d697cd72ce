/*
 * The host's variance estimate and à-trous pass 4 pixels a vector (denoise_atrous_body.h),
 * for any target, the choice between them and the 8-wide AVX2 build (denoise_atrous_avx2.c)
 * where the CPU runs that, and their inputs as planes (pf_denoise_atrous_prepare).
 */
#define ATROUS_WIDTH 4
#define ATROUS_NAME pf_denoise_atrous_rows_4
#define VARIANCE_NAME pf_denoise_variance_rows_4
#include "denoise_atrous_body.h"

#include <stdlib.h>

/* The 3×3 Gaussian of the variance at (x, y) (SVGF: a steadier edge-stopping scale). */
static float blurred_variance(const denoise_planes *planes, int x, int y)
{
    static const float g[3] = {0.25f, 0.125f, 0.0625f}; /* centre, edges, corners */
    int w = (int)planes->width, h = (int)planes->height;
    float sum = 0.0f, weights = 0.0f;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                continue;
            float k = g[abs(dx) + abs(dy)];
            sum += k * planes->variance[(size_t)qy * w + qx];
            weights += k;
        }
    return sum / weights;
}

void pf_denoise_atrous_prepare(denoise_planes *planes, int row_begin, int row_end, int pass)
{
    size_t pixels = (size_t)planes->width * planes->height;
    float *planar = planes->planar;
    for (int y = row_begin; y < row_end; y++)
        for (int x = 0; x < (int)planes->width; x++) {
            size_t p = (size_t)y * planes->width + x;
            for (int c = 0; c < 3; c++)
                planar[(PLANAR_R + c) * pixels + p] = planes->lighting[3 * p + c];
            if (!pass) /* the normals never change: once, with the guides */
                for (int c = 0; c < 3; c++)
                    planar[(PLANAR_NX + c) * pixels + p] = planes->normal[3 * p + c];
            else
                planar[PLANAR_SCALE * pixels + p] =
                    DENOISE_SIGMA_LUMINANCE * sqrtf(blurred_variance(planes, x, y)) + 1e-6f;
        }
}

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

void pf_denoise_variance_rows(denoise_planes *planes, int row_begin, int row_end)
{
#if defined(PF_DENOISE_AVX2)
    if (__builtin_cpu_supports("avx2")) {
        pf_denoise_variance_rows_8(planes, row_begin, row_end);
        return;
    }
#endif
    pf_denoise_variance_rows_4(planes, row_begin, row_end);
}
