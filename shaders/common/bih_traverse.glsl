// BIH traversal: the one copy every kernel that casts rays uses. It follows
// core/bih/bih_cpu_traverse.c step for step (that file explains the
// robustness rules: Ize 2013 far-distance widening, interval intersection,
// parallel axes decided by the origin, skipping popped entries beyond the best
// hit); node format in core/bih/pf_bih.h.
//
// The including shader defines BIH_BINDING, the first of the tree's three
// bindings (set 0), which this file declares as uniform texel buffers:
//   BIH_BINDING      bih_nodes           one 16-byte texel per node: clip0, clip1 (float bits),
//                                        word, 0 (pf_bih_gpu_upload pads the 12-byte nodes)
//   BIH_BINDING + 1  bih_vertices        3 vec4 per triangle, leaf order
//   BIH_BINDING + 2  bih_triangle_index  leaf order -> frame triangle
// Texel buffers, not storage buffers: llvmpipe (Mesa 22.x) loads a storage
// buffer word lane by lane in a branchy loop, ~11 ns a word on a 2-core host,
// and a texel fetch is one vector gather, ~1 ns (bench/RESULTS.md). core/vk
// binds them from the module's declarations (spirv_bindings.c).
#ifndef PF_BIH_TRAVERSE_GLSL
#define PF_BIH_TRAVERSE_GLSL

#include "ray_triangle.glsl"

#ifndef BIH_BINDING
#error "define BIH_BINDING (the first of the BIH's three bindings) before bih_traverse.glsl"
#endif
layout(set = 0, binding = BIH_BINDING) uniform isamplerBuffer bih_nodes;
layout(set = 0, binding = BIH_BINDING + 1) uniform samplerBuffer bih_vertices;
layout(set = 0, binding = BIH_BINDING + 2) uniform usamplerBuffer bih_triangle_index;

// Node index's clip0, clip1 (float bits) and word: one fetch, where three words
// cost three (llvmpipe: a texel fetch's cost barely depends on its width, bench/vk).
uvec3 bih_node(uint index)
{
    return uvec3(texelFetch(bih_nodes, int(index)).xyz);
}

// xyz, and w: the degenerate flag on a triangle's first vertex (pf_bih.h).
vec4 bih_vertex(uint index)
{
    return texelFetch(bih_vertices, int(index));
}

const uint BIH_STACK_SIZE = 64u; // PF_BIH_STACK_SIZE
const uint BIH_LEAF = 3u;        // PF_BIH_LEAF
const uint BIH_NO_HIT = 0xFFFFFFFFu;
// 2γ(3) for ε = 2^-24: 6ε / (1 − 3ε), as BIH_TWO_GAMMA3 in bih_cpu_traverse.c.
const float BIH_TWO_GAMMA3 = 6.0 * 5.9604644775390625e-8 / (1.0 - 3.0 * 5.9604644775390625e-8);
const float BIH_FLT_MIN = 1.17549435e-38; // smallest normal float

// A stack entry's interval in one word: near rounded down and far rounded up to
// their 16 high bits (sign, exponent, 7 bits of mantissa). Looser bounds only cull
// less, so the hits stay exact; the entry is two words instead of three, and llvmpipe
// stores and loads a private array's word lane by lane (bench/RESULTS.md, "The stack
// entry in two words").
uint bih_pack_interval(float near, float far)
{
    // Away from zero (a larger magnitude) where that is the outward direction, and
    // then to at least the smallest normal magnitude, so that a device flushing
    // subnormals cannot turn the rounded value back towards zero.
    uint near_bits = floatBitsToUint(near);
    near_bits = near < 0.0 ? max(near_bits + 0xFFFFu, floatBitsToUint(-BIH_FLT_MIN)) : near_bits;
    uint far_bits = floatBitsToUint(far);
    far_bits = far > 0.0 ? max(far_bits + 0xFFFFu, floatBitsToUint(BIH_FLT_MIN)) : far_bits;
    return (far_bits & 0xFFFF0000u) | (near_bits >> 16u);
}

vec2 bih_unpack_interval(uint word)
{
    return vec2(uintBitsToFloat(word << 16u), uintBitsToFloat(word & 0xFFFF0000u));
}

struct BihHit {
    float t;        // -1 on a miss
    uint triangle;  // frame index, BIH_NO_HIT on a miss
    float u, v;     // barycentrics of vertices 1 and 2
};

// min and max as compare-and-select, as pf_bih_min/max on the CPU: GLSL's min and
// max return the other operand for a NaN, which llvmpipe pays with an unordered
// compare and a blend per call; the traversal's operands are never NaN.
float bih_min(float a, float b)
{
    return b < a ? b : a;
}

float bih_max(float a, float b)
{
    return b > a ? b : a;
}

float bih_widen_far(float t)
{
    // precise: no FMA, so the bound rounds as on the CPU.
    precise float widened = t + abs(t) * BIH_TWO_GAMMA3;
    return isinf(t) ? t : widened;
}

float bih_next_up(float t)
{
    if (isinf(t) || isnan(t))
        return t;
    if (t == 0.0)
        return uintBitsToFloat(1u);
    uint bits = floatBitsToUint(t);
    return uintBitsToFloat(t > 0.0 ? bits + 1u : bits - 1u);
}

// Closest hit in (tmin, tmax), or with any_hit the first hit found. failed
// is set (and a miss returned) when the stack would overflow, or when more
// than node_count nodes are visited (a malformed tree): never silent.
BihHit trace_bih(vec3 origin, vec3 direction, float tmin, float tmax, bool any_hit,
                 vec3 bounds_min, vec3 bounds_max, uint triangle_count, uint node_count,
                 out bool failed)
{
    BihHit hit = BihHit(-1.0, BIH_NO_HIT, 0.0, 0.0);
    failed = false;
    if (triangle_count == 0u)
        return hit;
    bvec3 parallel = not(greaterThanEqual(abs(direction), vec3(BIH_FLT_MIN)));
    // divide_exact (ray_triangle.glsl): the CPU's reciprocals, so the node intervals are too.
    vec3 inv = vec3(parallel.x ? 0.0 : divide_exact(1.0, direction.x),
                    parallel.y ? 0.0 : divide_exact(1.0, direction.y),
                    parallel.z ? 0.0 : divide_exact(1.0, direction.z));
    if (all(parallel))
        return hit;
    RayShear shear = ray_shear_setup(direction);

    float t_near = tmin, t_far = tmax;
    for (int k = 0; k < 3; k++) {
        if (parallel[k]) {
            if (origin[k] < bounds_min[k] || origin[k] > bounds_max[k])
                return hit;
            continue;
        }
        float t0 = (bounds_min[k] - origin[k]) * inv[k];
        float t1 = (bounds_max[k] - origin[k]) * inv[k];
        if (inv[k] < 0.0) {
            float swap_t = t0;
            t0 = t1;
            t1 = swap_t;
        }
        t_near = bih_max(t_near, t0);
        t_far = bih_min(t_far, bih_widen_far(t1));
    }
    if (!(t_near <= t_far))
        return hit;

    float closest = tmax;
    uint stack_node[BIH_STACK_SIZE];
    uint stack_interval[BIH_STACK_SIZE];
    uint stack_size = 0u;
    uint node = 0u;
    // "While-while" (Aila & Laine 2009): inner nodes in one loop until this ray
    // stands at a leaf, then the leaf's triangles, so the lanes of a SIMD
    // device (lavapipe runs 8 rays per vector) test triangles together instead
    // of paying the triangle loop at every step in which any lane is at a leaf.
    // The nodes are visited in the same order as before (and as on the CPU).
    // A ray enters each node at most once, so node_count visits bound the work.
    uint visits = 0u;
    while (true) {
        bool at_leaf = false;
        while (!at_leaf) {
            if (visits++ >= node_count) {
                failed = true;
                return BihHit(-1.0, BIH_NO_HIT, 0.0, 0.0);
            }
            uvec3 fields = bih_node(node);
            uint word = fields.z;
            if ((word & 3u) == BIH_LEAF) {
                at_leaf = true;
                break;
            }
            uint axis = word & 3u, child = word >> 2u;
            float clip_left = uintBitsToFloat(fields.x);
            float clip_right = uintBitsToFloat(fields.y);
            float far_limit = bih_min(t_far, bih_widen_far(closest));
            float left_near = t_near, left_far = far_limit;
            float right_near = t_near, right_far = far_limit;
            bool left_first = true;
            bool left_open = true, right_open = true;
            if (parallel[axis]) {
                left_open = origin[axis] <= clip_left;
                right_open = origin[axis] >= clip_right;
            } else {
                float t_left = (clip_left - origin[axis]) * inv[axis];
                float t_right = (clip_right - origin[axis]) * inv[axis];
                if (inv[axis] > 0.0) {
                    left_far = bih_min(left_far, bih_widen_far(t_left));
                    right_near = bih_max(right_near, t_right);
                } else {
                    left_first = false;
                    right_far = bih_min(right_far, bih_widen_far(t_right));
                    left_near = bih_max(left_near, t_left);
                }
            }
            bool visit_left = left_open && left_near <= left_far;
            bool visit_right = right_open && right_near <= right_far;
            uint near_child = left_first ? child : child + 1u;
            uint far_child = left_first ? child + 1u : child;
            bool visit_near = left_first ? visit_left : visit_right;
            bool visit_far = left_first ? visit_right : visit_left;
            vec2 near_interval = left_first ? vec2(left_near, left_far) : vec2(right_near, right_far);
            vec2 far_interval = left_first ? vec2(right_near, right_far) : vec2(left_near, left_far);
            if (visit_near && visit_far) {
                if (stack_size == BIH_STACK_SIZE) {
                    failed = true;
                    return BihHit(-1.0, BIH_NO_HIT, 0.0, 0.0);
                }
                stack_node[stack_size] = far_child;
                stack_interval[stack_size] = bih_pack_interval(far_interval.x, far_interval.y);
                stack_size++;
            }
            if (visit_near || visit_far) {
                node = visit_near ? near_child : far_child;
                vec2 interval = visit_near ? near_interval : far_interval;
                t_near = interval.x;
                t_far = interval.y;
                continue;
            }
            // Neither child: the next entry of the stack that can still hold a closer hit.
            // Popped here and again after a leaf, on purpose: a lane that pops inside the
            // inner loop goes on descending with the others. One pop site after the leaf
            // (leave the inner loop, pop, re-enter) measured 10 % slower on diffuse rays
            // (bench/RESULTS.md, while-while).
            bool resumed = false;
            while (stack_size > 0u) {
                stack_size--;
                vec2 entry = bih_unpack_interval(stack_interval[stack_size]);
                float limit = bih_min(entry.y, bih_widen_far(closest));
                if (entry.x <= limit) {
                    node = stack_node[stack_size];
                    t_near = entry.x;
                    t_far = limit;
                    resumed = true;
                    break;
                }
            }
            if (!resumed)
                return hit;
        }
        uvec3 leaf = bih_node(node);
        uint first = leaf.x;
        uint count = leaf.y;
        for (uint p = first; p < first + count; p++) {
            float t, u, v;
            vec4 v0 = bih_vertex(3u * p);
            // A degenerate triangle never hits; its flag saves the test (pf_bih.h).
            if (v0.w != 0.0 ||
                !ray_triangle_sheared(origin, shear, v0.xyz, bih_vertex(3u * p + 1u).xyz,
                                      bih_vertex(3u * p + 2u).xyz, tmin, bih_next_up(closest), t,
                                      u, v))
                continue;
            uint original = texelFetch(bih_triangle_index, int(p)).x;
            // Equal t: the lower original index wins, as in the brute-force oracle.
            if (t < closest || (t == closest && hit.triangle != BIH_NO_HIT && original < hit.triangle)) {
                closest = t;
                hit = BihHit(t, original, u, v);
                if (any_hit)
                    return hit;
            }
        }
        bool resumed = false;
        while (stack_size > 0u) {
            stack_size--;
            vec2 entry = bih_unpack_interval(stack_interval[stack_size]);
            float limit = bih_min(entry.y, bih_widen_far(closest));
            if (entry.x <= limit) {
                node = stack_node[stack_size];
                t_near = entry.x;
                t_far = limit;
                resumed = true;
                break;
            }
        }
        if (!resumed)
            return hit;
    }
    return hit;
}

// The hit that counts where the scene's surfaces are bound (scene_textures.glsl): an
// alpha-masked or blended triangle's hit is tested after the traversal, and where it
// does not count the ray goes on past it, up to BIH_ALPHA_LAYERS times. Testing after
// the traversal, not inside its leaf loop, keeps the loop as small as a scene without
// alpha has it: in the loop, the test doubled llvmpipe's traversal time even where it
// never ran (bench/RESULTS.md, "Textures"). An any-hit query whose hit does not count
// goes on as closest-hit queries, which need no order to be right. Past the bound the
// last hit counts (no light leaks through a dense stack of cut-out cards).
const uint BIH_ALPHA_LAYERS = 32u;

#ifdef PF_SCENE_TEXTURES_GLSL
// trace_bih_surfaces's loop, and trace_bih_surfaces_after's: traced says that hit is the
// first traversal's already (layer 0 is not traced here). One traversal in the loop
// (llvmpipe inlines each call site's copy).
BihHit trace_bih_surfaces_from(bool traced, BihHit hit, vec3 origin, vec3 direction,
                               float tmin, float tmax, bool any_hit, bool camera,
                               vec3 bounds_min, vec3 bounds_max, uint triangle_count,
                               uint node_count, out bool failed)
{
    failed = false;
    float from = tmin;
    bool any = any_hit;
    for (uint layer = 0u; layer <= BIH_ALPHA_LAYERS; layer++) {
        if (layer > 0u || !traced)
            hit = trace_bih(origin, direction, from, tmax, any, bounds_min, bounds_max,
                            triangle_count, node_count, failed);
        if (!SCENE_HAS_ALPHA || failed || hit.triangle == BIH_NO_HIT ||
            layer == BIH_ALPHA_LAYERS ||
            scene_alpha_passes(hit.triangle, hit.u, hit.v, origin, direction, camera))
            break;
        // On past this hit; after an any-hit query's, from the start as closest-hit ones.
        from = any ? from : hit.t;
        any = false;
    }
    return hit;
}
#endif

// camera: the ray leaves the camera, the only rays that see unlit surfaces
// (scene_alpha_passes).
BihHit trace_bih_surfaces(vec3 origin, vec3 direction, float tmin, float tmax, bool any_hit,
                          bool camera, vec3 bounds_min, vec3 bounds_max, uint triangle_count,
                          uint node_count, out bool failed)
{
#ifdef PF_SCENE_TEXTURES_GLSL
    return trace_bih_surfaces_from(false, BihHit(-1.0, BIH_NO_HIT, 0.0, 0.0), origin, direction,
                                   tmin, tmax, any_hit, camera, bounds_min, bounds_max,
                                   triangle_count, node_count, failed);
#else
    // The plain variant: no loop around the traversal.
    return trace_bih(origin, direction, tmin, tmax, any_hit, bounds_min, bounds_max,
                     triangle_count, node_count, failed);
#endif
}

// trace_bih_surfaces for a ray whose first traversal ran elsewhere, without the alpha test
// (the host's, core/bih: it has no textures): hit is what that traversal found. Where the
// hit does not count, the ray goes on past it here, as trace_bih_surfaces would have gone
// on from the same first hit, so the hit that counts is the same either way (an any-hit
// query's first hit may be another triangle than this device's traversal would have
// found, but after one that does not count the query goes on as closest-hit queries, and
// the answer, occluded or not, is the same). Most rays hit an opaque triangle first and
// trace nothing here; without alpha, nothing is compiled.
BihHit trace_bih_surfaces_after(BihHit hit, vec3 origin, vec3 direction, float tmin,
                                float tmax, bool any_hit, bool camera, vec3 bounds_min,
                                vec3 bounds_max, uint triangle_count, uint node_count,
                                out bool failed)
{
#ifdef PF_SCENE_TEXTURES_GLSL
    return trace_bih_surfaces_from(true, hit, origin, direction, tmin, tmax, any_hit, camera,
                                   bounds_min, bounds_max, triangle_count, node_count, failed);
#else
    failed = false;
    return hit;
#endif
}

#endif
