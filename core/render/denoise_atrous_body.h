/*
 * One à-trous pass over rows of the denoiser's planes (denoise.c's filter, on the host),
 * written once for a vector width: the including file defines ATROUS_WIDTH (4 or 8 floats)
 * and ATROUS_NAME. Built 4 wide for any target (denoise_atrous.c) and 8 wide with -mavx2
 * but no -mfma (denoise_atrous_avx2.c), so both do the same IEEE operations in the same
 * order and agree bit for bit.
 *
 * A run of ATROUS_WIDTH pixels of a row takes each of its 25 taps at once (the taps of
 * neighbouring pixels are neighbours), with the weights of denoise.c's header: the normal
 * and depth guides and the luminance edge-stopping function, whose exponentials are
 * vector_exp's (within 2 ulp of expf: the host's and the device's images agree within
 * float rounding as before). expf tap by tap was most of the stage's time.
 */
#if !defined(ATROUS_WIDTH) || !defined(ATROUS_NAME)
#error "define ATROUS_WIDTH and ATROUS_NAME before including denoise_atrous_body.h"
#endif

#include "denoise_internal.h"

#include <math.h>
#include <stdlib.h>

typedef float lanes_f __attribute__((vector_size(ATROUS_WIDTH * sizeof(float))));
typedef int32_t lanes_i __attribute__((vector_size(ATROUS_WIDTH * sizeof(float))));

static inline lanes_f every_lane(float value)
{
    lanes_f v;
    for (int l = 0; l < ATROUS_WIDTH; l++)
        v[l] = value;
    return v;
}

static inline lanes_i every_lane_i(int32_t value)
{
    lanes_i v;
    for (int l = 0; l < ATROUS_WIDTH; l++)
        v[l] = value;
    return v;
}

/* mask ? a : b, lane by lane (mask: a comparison's all-ones or zero lanes). */
static inline lanes_f select_lanes(lanes_i mask, lanes_f a, lanes_f b)
{
    return (lanes_f)(((lanes_i)a & mask) | ((lanes_i)b & ~mask));
}

static inline lanes_f abs_lanes(lanes_f x)
{
    return (lanes_f)((lanes_i)x & every_lane_i(0x7fffffff));
}

/*
 * e^x for x <= 0 (Cephes' expf: x = n ln 2 + r, |r| <= ln 2 / 2, a degree-6 polynomial in r,
 * times 2^n through the exponent bits); 0 below -87 (where expf is subnormal or 0), and 0 for
 * a NaN lane (the caller selects those away).
 */
static inline __attribute__((always_inline)) lanes_f vector_exp(lanes_f x)
{
    const lanes_f low = every_lane(-87.0f);
    x = select_lanes(x == x, x, low); /* NaN: its result is unused, and no NaN may reach the integer conversion */
    lanes_i underflow = x < low;
    x = select_lanes(underflow, low, x);
    lanes_f t = x * every_lane(1.44269504088896341f) + every_lane(0.5f);
    lanes_i n = __builtin_convertvector(t, lanes_i); /* toward zero: floor needs a step */
    n += (lanes_i)(__builtin_convertvector(n, lanes_f) > t);
    lanes_f fn = __builtin_convertvector(n, lanes_f);
    lanes_f r = x - fn * every_lane(0.693359375f) - fn * every_lane(-2.12194440e-4f);
    lanes_f p = every_lane(1.9875691500e-4f);
    p = p * r + every_lane(1.3981999507e-3f);
    p = p * r + every_lane(8.3334519073e-3f);
    p = p * r + every_lane(4.1665795894e-2f);
    p = p * r + every_lane(1.6666665459e-1f);
    p = p * r + every_lane(5.0000001201e-1f);
    lanes_f e = p * r * r + r + every_lane(1.0f);
    lanes_f scale = (lanes_f)((n + 127) << 23);
    return select_lanes(underflow, every_lane(0.0f), e * scale);
}

static inline lanes_f luminance_lanes(lanes_f r, lanes_f g, lanes_f b)
{
    return every_lane(0.2126f) * r + every_lane(0.7152f) * g + every_lane(0.0722f) * b;
}

/* The 3×3 Gaussian of the variance at (x, y) (SVGF: a steadier edge-stopping scale), as
 * denoise.c's blurred_variance. */
static float blurred_variance_at(const denoise_planes *planes, int x, int y)
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

/* Rows [row_begin, row_end) of one à-trous pass of spread `step`, from planes->lighting and
 * variance into planes->scratch (4 floats a pixel: lighting, variance). */
void ATROUS_NAME(denoise_planes *planes, int step, int row_begin, int row_end)
{
    static const float b3[5] = {1.0f / 16.0f, 1.0f / 4.0f, 3.0f / 8.0f, 1.0f / 4.0f,
                                1.0f / 16.0f};
    int w = (int)planes->width, h = (int)planes->height;
    const float *lighting = planes->lighting, *normal = planes->normal;
    const float *depth = planes->depth, *variance = planes->variance;
    for (int y = row_begin; y < row_end; y++)
        for (int x0 = 0; x0 < w; x0 += ATROUS_WIDTH) {
            /* The run's pixels; lanes past the row's end repeat its last pixel. */
            lanes_f lp, scale, zp, step_p, np[3];
            for (int l = 0; l < ATROUS_WIDTH; l++) {
                int x = x0 + l < w ? x0 + l : w - 1;
                size_t p = (size_t)y * w + x;
                const float *rgb = lighting + 3 * p;
                lp[l] = 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2];
                scale[l] = DENOISE_SIGMA_LUMINANCE * sqrtf(blurred_variance_at(planes, x, y)) +
                           1e-6f;
                zp[l] = depth[p];
                step_p[l] = planes->depth_step[p];
                for (int c = 0; c < 3; c++)
                    np[c][l] = normal[3 * p + c];
            }
            const lanes_f zero = every_lane(0.0f);
            lanes_i p_surface = zp > zero;
            lanes_f sum_r = zero, sum_g = zero, sum_b = zero, var_sum = zero, weights = zero;
            for (int j = -2; j <= 2; j++) {
                int qy = y + j * step;
                if (qy < 0 || qy >= h)
                    continue;
                for (int i = -2; i <= 2; i++) {
                    lanes_f q_r, q_g, q_b, zq, vq, nq[3];
                    lanes_i inside;
                    for (int l = 0; l < ATROUS_WIDTH; l++) {
                        int qx = x0 + l + i * step;
                        inside[l] = qx >= 0 && qx < w && x0 + l < w ? -1 : 0;
                        qx = qx < 0 ? 0 : qx >= w ? w - 1 : qx;
                        size_t q = (size_t)qy * w + qx;
                        q_r[l] = lighting[3 * q];
                        q_g[l] = lighting[3 * q + 1];
                        q_b[l] = lighting[3 * q + 2];
                        zq[l] = depth[q];
                        vq[l] = variance[q];
                        for (int c = 0; c < 3; c++)
                            nq[c][l] = normal[3 * q + c];
                    }
                    lanes_f weight = every_lane(b3[i + 2] * b3[j + 2]);
                    if (i != 0 || j != 0) {
                        /* geometry_weight: the normal and depth guides. */
                        float offset = (float)step * sqrtf((float)(i * i + j * j));
                        lanes_f cosine = np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2];
                        lanes_f w_normal = select_lanes(cosine > zero, cosine, zero);
                        for (int k = 0; k < DENOISE_NORMAL_SQUARINGS; k++)
                            w_normal *= w_normal;
                        lanes_f w_depth = vector_exp(-abs_lanes(zp - zq) /
                                                     (step_p * every_lane(offset) +
                                                      every_lane(1e-3f) * zp));
                        lanes_f geometry = w_normal * w_depth;
                        /* Both see nothing: 1; one does: 0; a normal weight of 0: 0. */
                        lanes_i q_surface = zq > zero;
                        geometry = select_lanes(p_surface, geometry,
                                                select_lanes(q_surface, zero, every_lane(1.0f)));
                        geometry = select_lanes(p_surface & ~q_surface, zero, geometry);
                        geometry = select_lanes(p_surface & (w_normal == zero), zero, geometry);
                        lanes_f lq = luminance_lanes(q_r, q_g, q_b);
                        lanes_f luma = vector_exp(-abs_lanes(lp - lq) / scale);
                        weight *= select_lanes(geometry == zero, zero, geometry * luma);
                    }
                    weight = select_lanes(inside, weight, zero);
                    sum_r += weight * q_r;
                    sum_g += weight * q_g;
                    sum_b += weight * q_b;
                    var_sum += weight * weight * vq;
                    weights += weight;
                }
            }
            for (int l = 0; l < ATROUS_WIDTH && x0 + l < w; l++) {
                float *out = planes->scratch + 4 * ((size_t)y * w + x0 + l);
                out[0] = sum_r[l] / weights[l];
                out[1] = sum_g[l] / weights[l];
                out[2] = sum_b[l] / weights[l];
                out[3] = var_sum[l] / (weights[l] * weights[l]);
            }
        }
}
