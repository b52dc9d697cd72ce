/*
 * One host propagation iteration (lpv_host_internal.h), written once for a
 * vector width: the including file defines STEP_WIDTH (4 or 8 floats) and
 * STEP_NAME. Built 4 wide for any target (lpv_host_step_sse.c) and 8 wide
 * with -mavx2 but no -mfma (lpv_host_step_avx2.c), so both do the same IEEE
 * operations in the same order and agree bit for bit.
 *
 * Each run of STEP_WIDTH cells of a row gathers the flux of its 6
 * neighbours onto its 5 faces each, as lpv_propagate.comp does for one
 * cell: intensity_c = max(0, q_c · basis), weight = Δω/π × (1 − clamp(gv ·
 * blocking, 0, 1)), out_c += (weight × intensity_c) × lobe.
 */
#if !defined(STEP_WIDTH) || !defined(STEP_NAME)
#error "define STEP_WIDTH and STEP_NAME before including lpv_host_step_body.h"
#endif

#include "lpv_host_internal.h"

#include <string.h>

/* STEP_WIDTH floats: GCC/Clang vector extensions. */
typedef float lanes_f __attribute__((vector_size(STEP_WIDTH * sizeof(float))));
typedef int32_t lanes_i __attribute__((vector_size(STEP_WIDTH * sizeof(float))));

/* A transfer with each number in every lane: a load where a broadcast per use cost 15 %. */
typedef struct lanes_transfer {
    lanes_f basis[4], blocking[4], lobe[4], scale;
} lanes_transfer;

static inline lanes_f every_lane(float value)
{
    lanes_f v;
    for (int l = 0; l < STEP_WIDTH; l++)
        v[l] = value;
    return v;
}

static inline lanes_f load_lanes(const float *p)
{
    lanes_f v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* max(x, 0) and min(max(x, 0), 1) by masks: the vector extensions have no min/max. */
static inline lanes_f positive(lanes_f x)
{
    const lanes_f zero = {0};
    return (lanes_f)((lanes_i)x & (x > zero));
}

static inline lanes_f clamp_unit(lanes_f x)
{
    const lanes_f one = every_lane(1.0f);
    x = positive(x);
    lanes_i below = x < one;
    return (lanes_f)(((lanes_i)x & below) | ((lanes_i)one & ~below));
}

/*
 * count (≤ STEP_WIDTH) cells from index at on. step: the index offsets of
 * the x, y, z neighbours; plane: the offset from one plane's row to the
 * next's. The face between d and q = d − s·e_k is d's lower face along k
 * (s > 0) or that of d + e_k (s < 0): geometry planes 4k … 4k + 3.
 */
static inline void step_run(const lanes_transfer *t, const float *src, const float *gv,
                            float *dst, float *acc, size_t at, uint32_t count,
                            const ptrdiff_t step[3], size_t plane)
{
    /* Δω/π × (1 − B) per transfer, shared by the three channels. */
    lanes_f weight[PF_LPV_HOST_TRANSFERS];
    for (int n = 0; n < PF_LPV_HOST_NEIGHBOURS; n++) {
        int k = n / 2;
        const lanes_transfer *tn = &t[PF_LPV_HOST_FACES * n];
        lanes_f *wn = &weight[PF_LPV_HOST_FACES * n];
        if (!gv) {
            for (int f = 0; f < PF_LPV_HOST_FACES; f++)
                wn[f] = tn[f].scale;
            continue;
        }
        const float *face = gv + (ptrdiff_t)at + ((n & 1) ? 0 : step[k]) + 4u * (size_t)k * plane;
        lanes_f g0 = load_lanes(face), g1 = load_lanes(face + plane);
        lanes_f g2 = load_lanes(face + 2u * plane), g3 = load_lanes(face + 3u * plane);
        for (int f = 0; f < PF_LPV_HOST_FACES; f++) {
            lanes_f blocked = g0 * tn[f].blocking[0] + g1 * tn[f].blocking[1] +
                              g2 * tn[f].blocking[2] + g3 * tn[f].blocking[3];
            wn[f] = tn[f].scale * (every_lane(1.0f) - clamp_unit(blocked));
        }
    }
    for (uint32_t ch = 0; ch < 3; ch++) {
        lanes_f out0 = {0}, out1 = {0}, out2 = {0}, out3 = {0};
        /* Unrolled, the transfers' addresses are constants: 10 % at -O2. */
#pragma GCC unroll 6
        for (int n = 0; n < PF_LPV_HOST_NEIGHBOURS; n++) {
            int k = n / 2;
            const float *q = src + (ptrdiff_t)at + ((n & 1) ? -step[k] : step[k]) + 4u * ch * plane;
            lanes_f q0 = load_lanes(q), q1 = load_lanes(q + plane);
            lanes_f q2 = load_lanes(q + 2u * plane), q3 = load_lanes(q + 3u * plane);
            const lanes_transfer *tn = &t[PF_LPV_HOST_FACES * n];
#pragma GCC unroll 5
            for (int f = 0; f < PF_LPV_HOST_FACES; f++) {
                lanes_f intensity = q0 * tn[f].basis[0] + q1 * tn[f].basis[1] +
                                    q2 * tn[f].basis[2] + q3 * tn[f].basis[3];
                lanes_f flux = weight[PF_LPV_HOST_FACES * n + f] * positive(intensity);
                out0 += flux * tn[f].lobe[0];
                out1 += flux * tn[f].lobe[1];
                out2 += flux * tn[f].lobe[2];
                out3 += flux * tn[f].lobe[3];
            }
        }
        /* The result, and the accumulation while the run is at hand (one pass less over dst). */
        const lanes_f out[4] = {out0, out1, out2, out3};
        for (uint32_t c = 0; c < 4; c++) {
            size_t row = at + (4u * ch + c) * plane;
            lanes_f sum = load_lanes(acc + row) + out[c];
            memcpy(dst + row, &out[c], count * sizeof(float));
            memcpy(acc + row, &sum, count * sizeof(float));
        }
    }
}

void STEP_NAME(const pf_lpv_host_transfer *transfers, const float *src, const float *gv,
               float *dst, float *acc, uint32_t size)
{
    lanes_transfer t[PF_LPV_HOST_TRANSFERS];
    for (int i = 0; i < PF_LPV_HOST_TRANSFERS; i++) {
        for (int c = 0; c < 4; c++) {
            t[i].basis[c] = every_lane(transfers[i].basis[c]);
            t[i].blocking[c] = every_lane(transfers[i].blocking[c]);
            t[i].lobe[c] = every_lane(transfers[i].lobe[c]);
        }
        t[i].scale = every_lane(transfers[i].scale);
    }
    size_t plane = (size_t)size + 2u, row = PF_LPV_HOST_PLANES * plane;
    const ptrdiff_t step[3] = {1, (ptrdiff_t)row, (ptrdiff_t)(row * plane)};
    for (uint32_t z = 0; z < size; z++)
        for (uint32_t y = 0; y < size; y++)
            for (uint32_t x = 0; x < size; x += STEP_WIDTH) {
                uint32_t count = size - x < STEP_WIDTH ? size - x : STEP_WIDTH;
                step_run(t, src, gv, dst, acc, pf_lpv_host_index(size, x, y, z), count, step,
                         plane);
            }
}
