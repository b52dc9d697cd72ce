// Watertight ray/triangle intersection: Woop, Benthin & Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013. The one copy every shader uses
// (brute-force oracle now, BIH traversal later); core/render/raycast_brute.c
// holds the same algorithm, operation for operation, for the CPU.
//
// Precision decision (documented in pf_render.h): the paper recomputes the
// edge functions U, V, W in double precision when one of them is exactly 0.
// We do not (shaderFloat64 is optional and the runtime does not enable it);
// instead an edge value of exactly 0 counts as inside, and edge values too
// small to trust are evaluated again in float at a power-of-two scale where
// nothing is subnormal (ray_triangle_watertight says why). The float edge
// functions are exactly antisymmetric for a shared edge (fl(a*b - c*d) ==
// -fl(c*d - a*b)), so a ray through a shared edge or vertex always hits at
// least one of the triangles (never leaks) and may hit both, with the same t
// up to rounding. `precise` keeps the compiler from fusing a*b - c into an
// FMA, which would break bit-for-bit agreement with the CPU.
#ifndef PF_RAY_TRIANGLE_GLSL
#define PF_RAY_TRIANGLE_GLSL

#include "divide_exact.glsl"

// A triangle whose height is within rounding of its vertex coordinates is
// degenerate: |e1 x e2| <= K * eps * M * (|e1| + |e2|), M the largest vertex
// coordinate magnitude, K = 16 ulps (eps = 2^-24). Squared, without sqrt:
// |n|^2 <= 2 (K eps)^2 (|e1|^2 + |e2|^2) with everything scaled by 2^-exp(M).
const float DEGENERATE_BOUND2 = 2.0 * (16.0 / 16777216.0) * (16.0 / 16777216.0);

// Three distinct but collinear vertices: in exact arithmetic det == 0, but in
// floating point the edge functions of such a triangle are rounding noise that
// can share one sign, so det alone lets it "hit" far outside its extent. The
// check is geometric and ray-independent (the same answer for every ray), runs
// only for candidate hits, and scales by an exact power of two (frexp/ldexp)
// so the CPU twin in raycast_brute.c gets the same answer.
bool triangle_is_degenerate(vec3 v0, vec3 v1, vec3 v2)
{
    vec3 magnitude = max(max(abs(v0), abs(v1)), abs(v2));
    float largest = max(max(magnitude.x, magnitude.y), magnitude.z);
    if (largest == 0.0)
        return true;
    int exponent;
    frexp(largest, exponent);
    precise vec3 e1 = ldexp(v1 - v0, ivec3(-exponent));
    precise vec3 e2 = ldexp(v2 - v0, ivec3(-exponent));
    precise vec3 n = vec3(e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z,
                          e1.x * e2.y - e1.y * e2.x);
    precise float n2 = (n.x * n.x + n.y * n.y) + n.z * n.z;
    precise float edges2 = ((e1.x * e1.x + e1.y * e1.y) + e1.z * e1.z) +
                           ((e2.x * e2.x + e2.y * e2.y) + e2.z * e2.z);
    return !(n2 > DEGENERATE_BOUND2 * edges2);
}

// Per-ray setup of the watertight test: permutation and shear.
struct RayShear {
    int kx, ky, kz;
    float sx, sy, sz;
    bool valid; // false for a zero direction
};

RayShear ray_shear_setup(vec3 direction)
{
    RayShear s;
    vec3 a = abs(direction);
    // Largest component becomes z; ties resolve the same way as the C code.
    s.kz = a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    s.kx = s.kz == 2 ? 0 : s.kz + 1;
    s.ky = s.kx == 2 ? 0 : s.kx + 1;
    // Swapping x and y when the z component is negative keeps the winding.
    if (direction[s.kz] < 0.0) {
        int swap_axis = s.kx;
        s.kx = s.ky;
        s.ky = swap_axis;
    }
    s.valid = direction[s.kz] != 0.0;
    precise float dz = direction[s.kz];
    s.sx = divide_exact(direction[s.kx], dz);
    s.sy = divide_exact(direction[s.ky], dz);
    s.sz = divide_exact(1.0, dz);
    return s;
}

// Component k of v by selection: lanes of one SIMD group usually hold rays
// with different axes, and a select is far cheaper than a dynamic vector
// index there (llvmpipe scalarizes those). Exact, so it changes no result.
float component(vec3 v, int k)
{
    return k == 0 ? v.x : (k == 1 ? v.y : v.z);
}

// Below this (2^-40), an edge value or a hit distance may hide a subnormal
// term: a product or a shear term under 2^-126, which NVIDIA flushes to zero
// (it offers no DenormPreserve for 32-bit floats) and lavapipe and the CPU
// keep. Above it, such a term is far below half an ulp of the value and
// changes nothing.
const float WATERTIGHT_RESCALE_BELOW = 9.094947017729282e-13;
// The smallest normal float: nearer hits are not hits (a flushing device
// cannot tell them from t = 0).
const float WATERTIGHT_MIN_T = 1.17549435082228751e-38;

// The sheared edge functions of the permuted translated vertices (kx, ky,
// kz components) and the distance scaled by det.
struct WatertightEdges {
    float eu, ev, ew, det, scaled_t;
};

WatertightEdges watertight_edges(vec3 a, vec3 b, vec3 c, float sx, float sy, float sz)
{
    precise float ax = a.x - sx * a.z;
    precise float ay = a.y - sy * a.z;
    precise float bx = b.x - sx * b.z;
    precise float by = b.y - sy * b.z;
    precise float cx = c.x - sx * c.z;
    precise float cy = c.y - sy * c.z;
    WatertightEdges e;
    precise float eu = cx * by - cy * bx;
    precise float ev = ax * cy - ay * cx;
    precise float ew = bx * ay - by * ax;
    precise float det = (eu + ev) + ew;
    precise float az = sz * a.z;
    precise float bz = sz * b.z;
    precise float cz = sz * c.z;
    precise float scaled_t = (eu * az + ev * bz) + ew * cz;
    e.eu = eu;
    e.ev = ev;
    e.ew = ew;
    e.det = det;
    e.scaled_t = scaled_t;
    return e;
}

// frexp's exponent of each component's largest magnitude over a, b, c (0 where all are 0).
ivec3 column_exponents(vec3 a, vec3 b, vec3 c)
{
    vec3 largest = max(max(abs(a), abs(b)), abs(c));
    ivec3 exponents;
    frexp(largest, exponents);
    return mix(exponents, ivec3(0), equal(largest, vec3(0.0)));
}

// Hit strictly inside (tmin, tmax), at t >= WATERTIGHT_MIN_T: returns true
// and t and the barycentrics (u, v) of v1 and v2 (the hit point is
// (1-u-v)*v0 + u*v1 + v*v2). A zero-area or collinear triangle never hits
// (see triangle_is_degenerate): ray_triangle_watertight tests that too;
// ray_triangle_sheared leaves it to a caller that knows it (the BIH's
// leaf-order vertices carry it: core/bih/pf_bih.h).
//
// Where an edge value or the hit distance is below WATERTIGHT_RESCALE_BELOW
// (a ray through an edge or vertex, a hit at the ray's origin, or geometry
// at subnormal scales: triangles within 1e-30 of a ray's origin along an
// axis), the edges are evaluated again with each
// column of the translated vertices scaled by a power of two into
// [0.5, 1): edge values and det scale alike, so signs and barycentrics keep
// their meaning, t scales by the z column's factor (undone exactly), and
// no product is subnormal any more. Exact where nothing underflowed, so the
// answer is bit for bit the first evaluation's there; where something did,
// every device now gets the CPU's answer.
bool ray_triangle_sheared(vec3 origin, RayShear s, vec3 v0, vec3 v1, vec3 v2, float tmin,
                          float tmax, out float t, out float u, out float v)
{
    t = 0.0;
    u = 0.0;
    v = 0.0;
    if (!s.valid)
        return false;
    precise vec3 a = v0 - origin;
    precise vec3 b = v1 - origin;
    precise vec3 c = v2 - origin;
    vec3 ap = vec3(component(a, s.kx), component(a, s.ky), component(a, s.kz));
    vec3 bp = vec3(component(b, s.kx), component(b, s.ky), component(b, s.kz));
    vec3 cp = vec3(component(c, s.kx), component(c, s.ky), component(c, s.kz));
    WatertightEdges e = watertight_edges(ap, bp, cp, s.sx, s.sy, s.sz);
    int t_exponent = 0;
    if (min(abs(e.eu), min(abs(e.ev), abs(e.ew))) < WATERTIGHT_RESCALE_BELOW ||
        abs(e.scaled_t) < abs(e.det) * WATERTIGHT_RESCALE_BELOW) {
        ivec3 k = column_exponents(ap, bp, cp);
        e = watertight_edges(ldexp(ap, -k), ldexp(bp, -k), ldexp(cp, -k),
                             ldexp(s.sx, k.z - k.x), ldexp(s.sy, k.z - k.y), s.sz);
        t_exponent = k.z;
    }
    if ((e.eu < 0.0 || e.ev < 0.0 || e.ew < 0.0) && (e.eu > 0.0 || e.ev > 0.0 || e.ew > 0.0))
        return false;
    if (e.det == 0.0)
        return false;
    precise float rcp_det = divide_exact(1.0, e.det);
    precise float hit_t = ldexp(e.scaled_t * rcp_det, t_exponent);
    if (!(hit_t > tmin && hit_t < tmax && hit_t >= WATERTIGHT_MIN_T))
        return false;
    t = hit_t;
    u = e.ev * rcp_det;
    v = e.ew * rcp_det;
    return true;
}

bool ray_triangle_watertight(vec3 origin, RayShear s, vec3 v0, vec3 v1, vec3 v2, float tmin,
                             float tmax, out float t, out float u, out float v)
{
    float hit_t, hit_u, hit_v;
    bool hit = ray_triangle_sheared(origin, s, v0, v1, v2, tmin, tmax, hit_t, hit_u, hit_v) &&
               !triangle_is_degenerate(v0, v1, v2);
    t = hit ? hit_t : 0.0;
    u = hit ? hit_u : 0.0;
    v = hit ? hit_v : 0.0;
    return hit;
}

#endif
