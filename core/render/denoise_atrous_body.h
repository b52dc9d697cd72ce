/*
 * One à-trous pass over rows of the denoiser's planes (denoise.c's filter, on the host), and
 * the variance estimate before the passes,
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
#if !defined(ATROUS_WIDTH) || !defined(ATROUS_NAME) || !defined(VARIANCE_NAME)
#error "define ATROUS_WIDTH, ATROUS_NAME and VARIANCE_NAME before including denoise_atrous_body.h"
#endif

#include "denoise_internal.h"

#include <math.h>
#include <string.h>

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
    return every_lane((float)PF_LUMINANCE_R) * r + every_lane((float)PF_LUMINANCE_G) * g +
           every_lane((float)PF_LUMINANCE_B) * b;
}

/* Rows [row_begin, row_end) of one à-trous pass of spread `step`, from planes->lighting and
 * variance into planes->scratch (4 floats a pixel: lighting, variance). */
/* denoise.c's geometry_weight for a run: the normal and depth guides of taps (zq, nq) at
 * distance offset from pixels (zp, step_p, np); both see nothing: 1, one does: 0. */
static inline __attribute__((always_inline)) lanes_f
geometry_lanes(lanes_f zp, lanes_f step_p, const lanes_f np[3], lanes_f zq, const lanes_f nq[3],
               float offset)
{
    const lanes_f zero = every_lane(0.0f);
    lanes_f cosine = np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2];
    lanes_f w_normal = select_lanes(cosine > zero, cosine, zero);
    for (int k = 0; k < DENOISE_NORMAL_SQUARINGS; k++)
        w_normal *= w_normal;
    lanes_f w_depth =
        vector_exp(-abs_lanes(zp - zq) / (step_p * every_lane(offset) + every_lane(1e-3f) * zp));
    lanes_f geometry = w_normal * w_depth;
    lanes_i p_surface = zp > zero, q_surface = zq > zero;
    geometry = select_lanes(p_surface, geometry, select_lanes(q_surface, zero, every_lane(1.0f)));
    geometry = select_lanes(p_surface & ~q_surface, zero, geometry);
    return select_lanes(p_surface & (w_normal == zero), zero, geometry);
}

/* ATROUS_WIDTH floats of a plane from index at: the run's own, or its neighbours'. */
static inline lanes_f load_lanes(const float *plane, size_t at)
{
    lanes_f v;
    memcpy(&v, plane + at, sizeof v);
    return v;
}

/* The same where some of the run's lanes fall outside the row: each lane's column clamped
 * into it (the caller gives those lanes no weight). */
static inline lanes_f load_clamped(const float *plane, size_t row_start, int first, int w)
{
    lanes_f v;
    for (int l = 0; l < ATROUS_WIDTH; l++) {
        int x = first + l;
        v[l] = plane[row_start + (x < 0 ? 0 : x >= w ? w - 1 : x)];
    }
    return v;
}

/* The lanes of the run at x0 whose tap at column first + lane lies inside the row (and
 * whose own pixel does: lanes past the row's end take no taps). */
static inline lanes_i taps_inside(int first, int x0, int w)
{
    lanes_i inside;
    for (int l = 0; l < ATROUS_WIDTH; l++)
        inside[l] = first + l >= 0 && first + l < w && x0 + l < w ? -1 : 0;
    return inside;
}

/* A tap's values for the run: one load where every lane's tap lies inside the row. */
static inline lanes_f tap_load(const float *plane, int inside_all, size_t tap_row, int first,
                               int w)
{
    return inside_all ? load_lanes(plane, tap_row + first)
                      : load_clamped(plane, tap_row, first, w);
}

void ATROUS_NAME(denoise_planes *planes, int step, int row_begin, int row_end)
{
    static const float b3[5] = {1.0f / 16.0f, 1.0f / 4.0f, 3.0f / 8.0f, 1.0f / 4.0f,
                                1.0f / 16.0f};
    int w = (int)planes->width, h = (int)planes->height;
    size_t pixels = (size_t)w * h;
    const float *planar = planes->planar;
    const float *red = planar + PLANAR_R * pixels, *green = planar + PLANAR_G * pixels;
    const float *blue = planar + PLANAR_B * pixels, *scales = planar + PLANAR_SCALE * pixels;
    const float *normal[3] = {planar + PLANAR_NX * pixels, planar + PLANAR_NY * pixels,
                              planar + PLANAR_NZ * pixels};
    const float *depth = planes->depth, *variance = planes->variance;
    const lanes_f zero = every_lane(0.0f);
    for (int y = row_begin; y < row_end; y++)
        for (int x0 = 0; x0 < w; x0 += ATROUS_WIDTH) {
            size_t row = (size_t)y * w;
            /* The run's pixels; lanes past the row's end repeat its last pixel. */
            int whole = x0 + ATROUS_WIDTH <= w;
#define RUN_LOAD(plane) tap_load(plane, whole, row, x0, w)
            lanes_f lp = luminance_lanes(RUN_LOAD(red), RUN_LOAD(green), RUN_LOAD(blue));
            lanes_f scale = RUN_LOAD(scales), zp = RUN_LOAD(depth);
            lanes_f step_p = RUN_LOAD(planes->depth_step);
            lanes_f np[3] = {RUN_LOAD(normal[0]), RUN_LOAD(normal[1]), RUN_LOAD(normal[2])};
#undef RUN_LOAD
            lanes_f sum_r = zero, sum_g = zero, sum_b = zero, var_sum = zero, weights = zero;
            for (int j = -2; j <= 2; j++) {
                int qy = y + j * step;
                if (qy < 0 || qy >= h)
                    continue;
                size_t tap_row = (size_t)qy * w;
                for (int i = -2; i <= 2; i++) {
                    int first = x0 + i * step;
                    int inside_all = whole && first >= 0 && first + ATROUS_WIDTH <= w;
                    lanes_i inside = taps_inside(first, x0, w);
#define TAP_LOAD(plane) tap_load(plane, inside_all, tap_row, first, w)
                    lanes_f q_r = TAP_LOAD(red), q_g = TAP_LOAD(green), q_b = TAP_LOAD(blue);
                    lanes_f vq = TAP_LOAD(variance);
                    lanes_f weight = every_lane(b3[i + 2] * b3[j + 2]);
                    if (i != 0 || j != 0) {
                        lanes_f zq = TAP_LOAD(depth);
                        lanes_f nq[3] = {TAP_LOAD(normal[0]), TAP_LOAD(normal[1]),
                                         TAP_LOAD(normal[2])};
                        lanes_f geometry = geometry_lanes(
                            zp, step_p, np, zq, nq, (float)step * sqrtf((float)(i * i + j * j)));
                        lanes_f lq = luminance_lanes(q_r, q_g, q_b);
                        lanes_f luma = vector_exp(-abs_lanes(lp - lq) / scale);
                        weight *= select_lanes(geometry == zero, zero, geometry * luma);
                    }
#undef TAP_LOAD
                    weight = select_lanes(inside, weight, zero);
                    sum_r += weight * q_r;
                    sum_g += weight * q_g;
                    sum_b += weight * q_b;
                    var_sum += weight * weight * vq;
                    weights += weight;
                }
            }
            for (int l = 0; l < ATROUS_WIDTH && x0 + l < w; l++) {
                float *out = planes->scratch + 4 * (row + x0 + l);
                out[0] = sum_r[l] / weights[l];
                out[1] = sum_g[l] / weights[l];
                out[2] = sum_b[l] / weights[l];
                out[3] = var_sum[l] / (weights[l] * weights[l]);
            }
        }
}

/*
 * Rows [row_begin, row_end) of the variance estimate (denoise.c's header: the smallest of the
 * guided variances of the four 4×4 quadrants that have the pixel in a corner), a run of
 * pixels a vector, from planes->planar's lighting and normals (before the temporal blend:
 * this frame's own) into planes->variance.
 */
void VARIANCE_NAME(denoise_planes *planes, int row_begin, int row_end)
{
    int w = (int)planes->width, h = (int)planes->height;
    size_t pixels = (size_t)w * h;
    const float *planar = planes->planar;
    const float *red = planar + PLANAR_R * pixels, *green = planar + PLANAR_G * pixels;
    const float *blue = planar + PLANAR_B * pixels;
    const float *normal[3] = {planar + PLANAR_NX * pixels, planar + PLANAR_NY * pixels,
                              planar + PLANAR_NZ * pixels};
    const float *depth = planes->depth;
    const lanes_f zero = every_lane(0.0f), one = every_lane(1.0f);
    for (int y = row_begin; y < row_end; y++)
        for (int x0 = 0; x0 < w; x0 += ATROUS_WIDTH) {
            size_t row = (size_t)y * w;
            int whole = x0 + ATROUS_WIDTH <= w;
#define RUN_LOAD(plane) tap_load(plane, whole, row, x0, w)
            lanes_f zp = RUN_LOAD(depth), step_p = RUN_LOAD(planes->depth_step);
            lanes_f np[3] = {RUN_LOAD(normal[0]), RUN_LOAD(normal[1]), RUN_LOAD(normal[2])};
#undef RUN_LOAD
            lanes_f smallest = every_lane(INFINITY);
            for (int quadrant = 0; quadrant < 4; quadrant++) {
                int sx = quadrant & 1 ? 1 : -1, sy = quadrant & 2 ? 1 : -1;
                lanes_f sum = zero, sum2 = zero, weights = zero, taps = zero;
                for (int j = 0; j <= DENOISE_VARIANCE_RADIUS; j++) {
                    int qy = y + sy * j;
                    if (qy < 0 || qy >= h)
                        continue;
                    size_t tap_row = (size_t)qy * w;
                    for (int i = 0; i <= DENOISE_VARIANCE_RADIUS; i++) {
                        int first = x0 + sx * i;
                        int inside_all = whole && first >= 0 && first + ATROUS_WIDTH <= w;
                        lanes_i inside = taps_inside(first, x0, w);
#define TAP_LOAD(plane) tap_load(plane, inside_all, tap_row, first, w)
                        lanes_f weight = one;
                        if (i != 0 || j != 0) {
                            lanes_f nq[3] = {TAP_LOAD(normal[0]), TAP_LOAD(normal[1]),
                                             TAP_LOAD(normal[2])};
                            weight = geometry_lanes(zp, step_p, np, TAP_LOAD(depth), nq,
                                                    sqrtf((float)(i * i + j * j)));
                        }
                        weight = select_lanes(inside, weight, zero);
                        lanes_f l = luminance_lanes(TAP_LOAD(red), TAP_LOAD(green), TAP_LOAD(blue));
#undef TAP_LOAD
                        sum += weight * l;
                        sum2 += weight * l * l;
                        weights += weight;
                        taps += select_lanes(weight > every_lane(0.5f), one, zero);
                    }
                }
                /* A quadrant cut off by the border or the geometry says little. */
                lanes_f mean = sum / weights;
                lanes_f spread = sum2 / weights - mean * mean;
                spread = select_lanes(spread > zero, spread, zero);
                lanes_i counted = taps >= every_lane(4.0f);
                smallest = select_lanes(counted & (spread < smallest), spread, smallest);
            }
            for (int l = 0; l < ATROUS_WIDTH && x0 + l < w; l++)
                planes->variance[row + x0 + l] = isfinite(smallest[l]) ? smallest[l] : 0.0f;
        }
}
