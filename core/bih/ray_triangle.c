/*
 * The CPU watertight ray/triangle test: the reference for
 * shaders/common/ray_triangle.glsl, used by the CPU BIH traversal and the
 * tests of the GPU oracle.
 */
#include "pf_bih.h"

#include <math.h>

/*
 * Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1),
 * 2013, operation for operation as shaders/common/ray_triangle.glsl (same
 * axis choice on ties, same evaluation order), so GPU and CPU agree bit for
 * bit wherever the GPU's division is correctly rounded. Like the shader, it
 * skips the paper's double-precision recomputation of edge values that are
 * exactly 0 and counts 0 as inside: rays through a shared edge or vertex hit
 * at least one triangle (see ray_triangle.glsl for why). ISO C mode keeps GCC
 * from contracting a*b - c into an FMA (-ffp-contract=off), as `precise` does
 * in GLSL.
 */
/* ray_triangle.glsl: height within 16 ulps of the vertex coordinates. */
#define DEGENERATE_BOUND2 (2.0f * (16.0f / 16777216.0f) * (16.0f / 16777216.0f))

/* Same test, operation for operation, as triangle_is_degenerate in ray_triangle.glsl (why: see there). */
static int triangle_is_degenerate(const float v0[3], const float v1[3], const float v2[3])
{
    float largest = 0.0f;
    for (int k = 0; k < 3; k++)
        largest = fmaxf(largest, fmaxf(fabsf(v0[k]), fmaxf(fabsf(v1[k]), fabsf(v2[k]))));
    if (largest == 0.0f)
        return 1;
    int exponent;
    frexpf(largest, &exponent);
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = ldexpf(v1[k] - v0[k], -exponent);
        e2[k] = ldexpf(v2[k] - v0[k], -exponent);
    }
    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                  e1[0] * e2[1] - e1[1] * e2[0]};
    float n2 = (n[0] * n[0] + n[1] * n[1]) + n[2] * n[2];
    float edges2 = ((e1[0] * e1[0] + e1[1] * e1[1]) + e1[2] * e1[2]) +
                   ((e2[0] * e2[0] + e2[1] * e2[1]) + e2[2] * e2[2]);
    return !(n2 > DEGENERATE_BOUND2 * edges2);
}

int pf_ray_triangle_watertight(const float origin[3], const float direction[3],
                               const float v0[3], const float v1[3], const float v2[3],
                               float tmin, float tmax, float *t, float *u, float *v)
{
    float ax_abs = fabsf(direction[0]), ay_abs = fabsf(direction[1]), az_abs = fabsf(direction[2]);
    int kz = ax_abs > ay_abs ? (ax_abs > az_abs ? 0 : 2) : (ay_abs > az_abs ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (direction[kz] < 0.0f) {
        int swap_axis = kx;
        kx = ky;
        ky = swap_axis;
    }
    if (direction[kz] == 0.0f)
        return 0;
    float dz = direction[kz];
    float sx = direction[kx] / dz;
    float sy = direction[ky] / dz;
    float sz = 1.0f / dz;

    float a[3], b[3], c[3];
    for (int i = 0; i < 3; i++) {
        a[i] = v0[i] - origin[i];
        b[i] = v1[i] - origin[i];
        c[i] = v2[i] - origin[i];
    }
    float ax = a[kx] - sx * a[kz];
    float ay = a[ky] - sy * a[kz];
    float bx = b[kx] - sx * b[kz];
    float by = b[ky] - sy * b[kz];
    float cx = c[kx] - sx * c[kz];
    float cy = c[ky] - sy * c[kz];
    float eu = cx * by - cy * bx;
    float ev = ax * cy - ay * cx;
    float ew = bx * ay - by * ax;
    if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f))
        return 0;
    float det = (eu + ev) + ew;
    if (det == 0.0f)
        return 0;
    float az = sz * a[kz];
    float bz = sz * b[kz];
    float cz = sz * c[kz];
    float scaled_t = (eu * az + ev * bz) + ew * cz;
    float rcp_det = 1.0f / det;
    float hit_t = scaled_t * rcp_det;
    if (!(hit_t > tmin && hit_t < tmax))
        return 0;
    if (triangle_is_degenerate(v0, v1, v2))
        return 0;
    *t = hit_t;
    *u = ev * rcp_det;
    *v = ew * rcp_det;
    return 1;
}
