/*
 * The watertight test's sheared edge functions and scaled hit distance (Woop,
 * Benthin & Wald 2013; ray_triangle.glsl's watertight_edges), written once
 * for any type with float arithmetic operators: float in ray_triangle.c, and
 * GCC float vectors in the packets (one triangle, a ray a lane) and the wide
 * view (one ray, a triangle a lane). Each lane's operations are then the
 * scalar test's, in the same order (ISO C mode: no contraction into FMA), so
 * every CPU traversal gets the same answers bit for bit.
 *
 * The includer defines WATERTIGHT_T (the type) and WATERTIGHT_EDGES (the
 * function's name; its result type is WATERTIGHT_EDGES##_result) and may
 * include this file once per type. a, b, c are the triangle's vertices
 * translated to the ray's origin and permuted to the ray's (kx, ky, kz).
 */
#if !defined(WATERTIGHT_T) || !defined(WATERTIGHT_EDGES)
#error "define WATERTIGHT_T and WATERTIGHT_EDGES before including bih_watertight_edges.h"
#endif

#define WATERTIGHT_CAT_(a, b) a##b
#define WATERTIGHT_CAT(a, b) WATERTIGHT_CAT_(a, b)
#define WATERTIGHT_RESULT WATERTIGHT_CAT(WATERTIGHT_EDGES, _result)

typedef struct WATERTIGHT_RESULT {
    WATERTIGHT_T eu, ev, ew, det, scaled_t;
} WATERTIGHT_RESULT;

static inline WATERTIGHT_RESULT WATERTIGHT_EDGES(const WATERTIGHT_T a[3], const WATERTIGHT_T b[3],
                                                 const WATERTIGHT_T c[3], WATERTIGHT_T sx,
                                                 WATERTIGHT_T sy, WATERTIGHT_T sz)
{
    WATERTIGHT_T ax = a[0] - sx * a[2];
    WATERTIGHT_T ay = a[1] - sy * a[2];
    WATERTIGHT_T bx = b[0] - sx * b[2];
    WATERTIGHT_T by = b[1] - sy * b[2];
    WATERTIGHT_T cx = c[0] - sx * c[2];
    WATERTIGHT_T cy = c[1] - sy * c[2];
    WATERTIGHT_RESULT e;
    e.eu = cx * by - cy * bx;
    e.ev = ax * cy - ay * cx;
    e.ew = bx * ay - by * ax;
    e.det = (e.eu + e.ev) + e.ew;
    WATERTIGHT_T az = sz * a[2];
    WATERTIGHT_T bz = sz * b[2];
    WATERTIGHT_T cz = sz * c[2];
    e.scaled_t = (e.eu * az + e.ev * bz) + e.ew * cz;
    return e;
}

#undef WATERTIGHT_RESULT
#undef WATERTIGHT_CAT
#undef WATERTIGHT_CAT_
#undef WATERTIGHT_EDGES
#undef WATERTIGHT_T
