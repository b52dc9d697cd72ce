/*
 * Four floats or ints in GCC's vector extension (one SSE register on
 * x86-64's baseline, one NEON register on arm64), for the CPU build's passes
 * and the degenerate flags. Each lane's arithmetic is IEEE single precision,
 * the same as the scalar code's (ISO C mode: no FMA), so the answers are.
 */
#ifndef PF_BIH_LANES4_H
#define PF_BIH_LANES4_H

#include <stdint.h>
#include <string.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

typedef float lanes4_f __attribute__((vector_size(16)));
typedef int32_t lanes4_i __attribute__((vector_size(16)));

/* Per lane: mask (all ones or zero) ? a : b. */
static inline lanes4_f lanes4_select(lanes4_i mask, lanes4_f a, lanes4_f b)
{
    return (lanes4_f)((mask & (lanes4_i)a) | (~mask & (lanes4_i)b));
}

/*
 * pf_bih_min and pf_bih_max per lane: b where it is smaller (larger), else a.
 * SSE's minps(x, y) is x < y ? x : y, so minps(b, a) is exactly that, NaN
 * included: one instruction where the select takes four.
 */
static inline lanes4_f lanes4_min(lanes4_f a, lanes4_f b)
{
#if defined(__SSE__)
    return (lanes4_f)_mm_min_ps((__m128)b, (__m128)a);
#else
    return lanes4_select(b < a, b, a);
#endif
}

static inline lanes4_f lanes4_max(lanes4_f a, lanes4_f b)
{
#if defined(__SSE__)
    return (lanes4_f)_mm_max_ps((__m128)b, (__m128)a);
#else
    return lanes4_select(b > a, b, a);
#endif
}

static inline lanes4_f lanes4_abs(lanes4_f x)
{
    return (lanes4_f)((lanes4_i)x & INT32_MAX);
}

/* Bit i set where lane i of mask is set. */
static inline unsigned lanes4_bits(lanes4_i mask)
{
#if defined(__SSE__)
    return (unsigned)_mm_movemask_ps((__m128)mask);
#else
    unsigned bits = 0;
    for (int i = 0; i < 4; i++)
        bits |= (unsigned)(mask[i] & 1) << i;
    return bits;
#endif
}

/* 4 floats from p, which need not be aligned. */
static inline lanes4_f lanes4_load(const float *p)
{
    lanes4_f v;
    memcpy(&v, p, sizeof v);
    return v;
}

#endif
