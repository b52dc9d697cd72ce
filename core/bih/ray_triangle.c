/*
 * The CPU watertight ray/triangle test: the reference for
 * shaders/common/ray_triangle.glsl, used by the CPU BIH traversal and the
 * tests of the GPU oracle.
 */
#include "bih_internal.h"
#include "bih_lanes4.h"

#include <float.h>
#include <math.h>
#include <stdint.h>

/*
 * Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1),
 * 2013, operation for operation as shaders/common/ray_triangle.glsl (same
 * axis choice on ties, same evaluation order), so GPU and CPU agree bit for
 * bit wherever the GPU's division is correctly rounded. Like the shader, it
 * skips the paper's double-precision recomputation of edge values that are
 * exactly 0 and counts 0 as inside, re-evaluating tiny edge values at a
 * power-of-two scale instead, where no product is subnormal (so a device
 * that flushes subnormals gets this answer too). Rays through a shared edge
 * or vertex hit at least one triangle (see ray_triangle.glsl for why). Hits
 * nearer than the smallest normal float are not hits. ISO C mode keeps GCC
 * from contracting a*b - c into an FMA (-ffp-contract=off), as `precise` does
 * in GLSL.
 */

/* ray_triangle.glsl: height within 16 ulps of the vertex coordinates. */
#define DEGENERATE_BOUND2 (2.0f * (16.0f / 16777216.0f) * (16.0f / 16777216.0f))

/* fmaxf's answer without its libm call (GCC keeps the call at -O2): NaN loses. */
static float max_ignoring_nan(float a, float b)
{
    return (a >= b || b != b) ? a : b;
}

/*
 * frexpf's exponent and ldexpf's scaling, from the bits where largest is a
 * normal float and the scale 2^-exponent is one too. Both libm calls showed in
 * the build's profile (the order pass tests every triangle); a product with an
 * exact power of two rounds as ldexpf does, so the answer is the same.
 */
static float power_of_two_scale(float largest, int *exponent)
{
    uint32_t biased = (pf_bih_float_to_bits(largest) >> 23) & 0xffu;
    if (biased == 0u || biased == 0xffu) {
        frexpf(largest, exponent);
        return 0.0f;
    }
    *exponent = (int)biased - 126;
    int scale_biased = 127 - *exponent;
    if (scale_biased < 1 || scale_biased > 254)
        return 0.0f;
    return pf_bih_bits_to_float((uint32_t)scale_biased << 23);
}

/* Same test, operation for operation, as triangle_is_degenerate in ray_triangle.glsl (why: see there). */
int pf_triangle_is_degenerate(const float v0[3], const float v1[3], const float v2[3])
{
    float largest = 0.0f;
    for (int k = 0; k < 3; k++)
        largest = max_ignoring_nan(
            largest,
            max_ignoring_nan(fabsf(v0[k]), max_ignoring_nan(fabsf(v1[k]), fabsf(v2[k]))));
    if (largest == 0.0f)
        return 1;
    int exponent;
    float scale = power_of_two_scale(largest, &exponent);
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = scale != 0.0f ? (v1[k] - v0[k]) * scale : ldexpf(v1[k] - v0[k], -exponent);
        e2[k] = scale != 0.0f ? (v2[k] - v0[k]) * scale : ldexpf(v2[k] - v0[k], -exponent);
    }
    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                  e1[0] * e2[1] - e1[1] * e2[0]};
    float n2 = (n[0] * n[0] + n[1] * n[1]) + n[2] * n[2];
    float edges2 = ((e1[0] * e1[0] + e1[1] * e1[1]) + e1[2] * e1[2]) +
                   ((e2[0] * e2[0] + e2[1] * e2[1]) + e2[2] * e2[2]);
    return !(n2 > DEGENERATE_BOUND2 * edges2);
}

/* max_ignoring_nan per lane: a where a >= b or b is NaN, else b. */
static lanes4_f lanes4_max_ignoring_nan(lanes4_f a, lanes4_f b)
{
    return lanes4_select((a >= b) | (b != b), a, b);
}

/* Coordinate k of vertex corner of the 4 triangles at tri (3 float[4] each). */
static lanes4_f lanes4_coordinate(const float (*tri)[4], int corner, int k)
{
    return (lanes4_f){tri[corner][k], tri[3 + corner][k], tri[6 + corner][k], tri[9 + corner][k]};
}

/*
 * pf_triangle_is_degenerate on 4 triangles at once, lane by lane the same
 * operations in the same order (no FMA: ISO C mode), for the build's and the
 * refit's leaf-order copy, which tests every triangle: one at a time the test
 * was ~12 % of the 1M-triangle build (bench/RESULTS.md). A lane whose largest
 * coordinate is 0, not a normal float, or too large for a normal 2^-exponent
 * sends the 4 to the scalar test, which covers those cases with frexpf and
 * ldexpf; it is exact for the rest, since scaling by a normal power of two
 * rounds as ldexpf does.
 *
 * Returns lane i's bit set where triangle i of the 4 at tri is degenerate.
 */
static unsigned degenerate_mask4(const float (*tri)[4])
{
    lanes4_f v0[3], v1[3], v2[3];
    lanes4_f largest = {0.0f, 0.0f, 0.0f, 0.0f};
    for (int k = 0; k < 3; k++) {
        v0[k] = lanes4_coordinate(tri, 0, k);
        v1[k] = lanes4_coordinate(tri, 1, k);
        v2[k] = lanes4_coordinate(tri, 2, k);
        largest = lanes4_max_ignoring_nan(
            largest, lanes4_max_ignoring_nan(lanes4_abs(v0[k]),
                                             lanes4_max_ignoring_nan(lanes4_abs(v1[k]),
                                                                     lanes4_abs(v2[k]))));
    }
    /* power_of_two_scale's normal case: biased exponent 1..252 (its scale's, 253 - biased, too). */
    lanes4_i biased = ((lanes4_i)largest >> 23) & 0xff;
    lanes4_i exact = (biased >= 1) & (biased <= 252);
    if (lanes4_bits(exact) != 0xfu) {
        unsigned mask = 0;
        for (int i = 0; i < 4; i++)
            mask |= (unsigned)pf_triangle_is_degenerate(tri[3 * i], tri[3 * i + 1], tri[3 * i + 2])
                    << i;
        return mask;
    }
    lanes4_f scale = (lanes4_f)((253 - biased) << 23);
    lanes4_f e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (v1[k] - v0[k]) * scale;
        e2[k] = (v2[k] - v0[k]) * scale;
    }
    lanes4_f n0 = e1[1] * e2[2] - e1[2] * e2[1];
    lanes4_f n1 = e1[2] * e2[0] - e1[0] * e2[2];
    lanes4_f n2 = e1[0] * e2[1] - e1[1] * e2[0];
    lanes4_f normal2 = (n0 * n0 + n1 * n1) + n2 * n2;
    lanes4_f edges2 = ((e1[0] * e1[0] + e1[1] * e1[1]) + e1[2] * e1[2]) +
                      ((e2[0] * e2[0] + e2[1] * e2[1]) + e2[2] * e2[2]);
    lanes4_i kept = normal2 > DEGENERATE_BOUND2 * edges2;
    return ~lanes4_bits(kept) & 0xfu;
}

void pf_bih_flag_degenerate(float (*vertices)[4], uint32_t count)
{
    uint32_t t = 0;
    for (; t + 4 <= count; t += 4) {
        float(*tri)[4] = &vertices[3 * (size_t)t];
        unsigned mask = degenerate_mask4((const float(*)[4])tri);
        for (int i = 0; i < 4; i++)
            tri[3 * i][3] = (mask >> i & 1u) ? PF_BIH_DEGENERATE_W : 0.0f;
    }
    for (; t < count; t++) {
        float(*tri)[4] = &vertices[3 * (size_t)t];
        tri[0][3] = pf_triangle_is_degenerate(tri[0], tri[1], tri[2]) ? PF_BIH_DEGENERATE_W : 0.0f;
    }
}

/* The sheared edge functions and the scaled distance (bih_watertight_edges.h). */
#define WATERTIGHT_T float
#define WATERTIGHT_EDGES watertight_edges
#include "bih_watertight_edges.h"

/* frexp's exponent of the largest of three magnitudes, 0 when all are 0. */
static int column_exponent(float a, float b, float c)
{
    float largest = fmaxf(fabsf(a), fmaxf(fabsf(b), fabsf(c)));
    int exponent = 0;
    if (largest != 0.0f)
        frexpf(largest, &exponent);
    return exponent;
}

int pf_ray_triangle_watertight(const float origin[3], const float direction[3],
                               const float v0[3], const float v1[3], const float v2[3],
                               float tmin, float tmax, float *t, float *u, float *v)
{
    pf_ray_shear s;
    pf_bih_shear_setup(direction, &s);
    float hit_t, hit_u, hit_v;
    if (!pf_ray_triangle_sheared(origin, &s, v0, v1, v2, tmin, tmax, &hit_t, &hit_u, &hit_v) ||
        pf_triangle_is_degenerate(v0, v1, v2))
        return 0;
    *t = hit_t;
    *u = hit_u;
    *v = hit_v;
    return 1;
}

int pf_ray_triangle_sheared(const float origin[3], const pf_ray_shear *s, const float v0[3],
                            const float v1[3], const float v2[3], float tmin, float tmax, float *t,
                            float *u, float *v)
{
    if (!s->valid)
        return 0;
    float sx = s->sx, sy = s->sy, sz = s->sz;
    /*
     * The translated vertices, permuted to (kx, ky, kz). Written out, not
     * looped over an axis array: GCC -O2 kept the loop and the arrays in
     * memory, and this test is most of the CPU traversal's leaf time.
     */
    const int kx = s->kx, ky = s->ky, kz = s->kz;
    float a[3] = {v0[kx] - origin[kx], v0[ky] - origin[ky], v0[kz] - origin[kz]};
    float b[3] = {v1[kx] - origin[kx], v1[ky] - origin[ky], v1[kz] - origin[kz]};
    float c[3] = {v2[kx] - origin[kx], v2[ky] - origin[ky], v2[kz] - origin[kz]};
    watertight_edges_result e = watertight_edges(a, b, c, sx, sy, sz);
    int t_exponent = 0;
    /* min(|eu|, |ev|, |ew|) < R as fminf answers it (NaN ignored), without its libm call. */
    const float below = PF_BIH_WATERTIGHT_RESCALE_BELOW;
    if (fabsf(e.eu) < below || fabsf(e.ev) < below || fabsf(e.ew) < below ||
        fabsf(e.scaled_t) < fabsf(e.det) * below) {
        /* ray_triangle.glsl: each column scaled to [0.5, 1) by a power of two. */
        int ex = column_exponent(a[0], b[0], c[0]);
        int ey = column_exponent(a[1], b[1], c[1]);
        int ez = column_exponent(a[2], b[2], c[2]);
        const int exponents[3] = {ex, ey, ez};
        for (int i = 0; i < 3; i++) {
            a[i] = ldexpf(a[i], -exponents[i]);
            b[i] = ldexpf(b[i], -exponents[i]);
            c[i] = ldexpf(c[i], -exponents[i]);
        }
        e = watertight_edges(a, b, c, ldexpf(sx, ez - ex), ldexpf(sy, ez - ey), sz);
        t_exponent = ez;
    }
    if ((e.eu < 0.0f || e.ev < 0.0f || e.ew < 0.0f) && (e.eu > 0.0f || e.ev > 0.0f || e.ew > 0.0f))
        return 0;
    if (e.det == 0.0f)
        return 0;
    float rcp_det = 1.0f / e.det;
    float hit_t = e.scaled_t * rcp_det;
    if (t_exponent != 0)
        hit_t = ldexpf(hit_t, t_exponent);
    if (!(hit_t > tmin && hit_t < tmax && hit_t >= FLT_MIN))
        return 0;
    *t = hit_t;
    *u = e.ev * rcp_det;
    *v = e.ew * rcp_det;
    return 1;
}
