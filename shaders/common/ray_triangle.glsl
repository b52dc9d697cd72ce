// Watertight ray/triangle intersection: Woop, Benthin & Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013. The one copy every shader uses
// (brute-force oracle now, BIH traversal later); core/render/raycast_brute.c
// holds the same algorithm, operation for operation, for the CPU.
//
// Precision decision (documented in pf_render.h): the paper recomputes the
// edge functions U, V, W in double precision when one of them is exactly 0.
// We do not (shaderFloat64 is optional and the runtime does not enable it);
// instead an edge value of exactly 0 counts as inside. The float edge
// functions are exactly antisymmetric for a shared edge (fl(a*b - c*d) ==
// -fl(c*d - a*b)), so a ray through a shared edge or vertex always hits at
// least one of the triangles (never leaks) and may hit both, with the same t
// up to rounding. `precise` keeps the compiler from fusing a*b - c into an
// FMA, which would break bit-for-bit agreement with the CPU.
#ifndef PF_RAY_TRIANGLE_GLSL
#define PF_RAY_TRIANGLE_GLSL

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

// 1 (the host's default for every device but llvmpipe, PF_VK_SPEC_DIVIDE_REFINE
// in core/vk/pf_vk.h): the device's division needs divide_exact's refinement.
layout(constant_id = 1000) const bool DIVIDE_REFINE = true;

// x / y rounded to nearest, as the CPU divides. Vulkan lets a shader's `/`
// be 2.5 ulp off; lavapipe's is exact, NVIDIA's is not (on an H200 the t of
// 1 in ~400 hits differed from the CPU's by 1-4 ulp, which moved hits at a
// ray's tmax across it). A Newton step from the device's quotient brings it
// within an ulp, and of it and its two neighbours the one whose exact
// remainder x - q y (one fma) is smallest is the rounded quotient (a
// quotient of floats is never a tie). Infinite, NaN or zero quotients are
// left as the device gives them. Skipped where the division is exact
// already (llvmpipe, whose fma() may also round its product, which would
// make the remainders inexact).
float divide_exact(float x, float y)
{
    precise float q = x / y;
    if (!DIVIDE_REFINE || isinf(q) || isnan(q) || q == 0.0)
        return q;
    precise float r = fma(-q, y, x);
    precise float step_q = fma(r, 1.0 / y, q);
    uint bits = floatBitsToUint(step_q);
    float below = uintBitsToFloat(bits - 1u), above = uintBitsToFloat(bits + 1u);
    precise float r_mid = abs(fma(-step_q, y, x));
    precise float r_below = abs(fma(-below, y, x));
    precise float r_above = abs(fma(-above, y, x));
    float best = r_below < r_mid ? below : step_q;
    return r_above < min(r_mid, r_below) ? above : best;
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

// Hit strictly inside (tmin, tmax): returns true and t and the barycentrics
// (u, v) of v1 and v2 (the hit point is (1-u-v)*v0 + u*v1 + v*v2).
// A zero-area or collinear triangle never hits (see triangle_is_degenerate).
bool ray_triangle_watertight(vec3 origin, RayShear s, vec3 v0, vec3 v1, vec3 v2, float tmin,
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
    precise float ax = ap.x - s.sx * ap.z;
    precise float ay = ap.y - s.sy * ap.z;
    precise float bx = bp.x - s.sx * bp.z;
    precise float by = bp.y - s.sy * bp.z;
    precise float cx = cp.x - s.sx * cp.z;
    precise float cy = cp.y - s.sy * cp.z;
    precise float eu = cx * by - cy * bx;
    precise float ev = ax * cy - ay * cx;
    precise float ew = bx * ay - by * ax;
    if ((eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0))
        return false;
    precise float det = (eu + ev) + ew;
    if (det == 0.0)
        return false;
    precise float az = s.sz * ap.z;
    precise float bz = s.sz * bp.z;
    precise float cz = s.sz * cp.z;
    precise float scaled_t = (eu * az + ev * bz) + ew * cz;
    precise float rcp_det = divide_exact(1.0, det);
    precise float hit_t = scaled_t * rcp_det;
    if (!(hit_t > tmin && hit_t < tmax))
        return false;
    if (triangle_is_degenerate(v0, v1, v2))
        return false;
    t = hit_t;
    u = ev * rcp_det;
    v = ew * rcp_det;
    return true;
}

#endif
