#version 460
#extension GL_GOOGLE_include_directive : require
// One LPV propagation iteration of one cascade (core/lpv/pf_lpv.h explains
// the scheme), gather form: one invocation per destination cell reads its 6
// neighbours and writes its own cell only, so no atomics. For the
// neighbour q = d − a (light flowing along +a into d), the destination's
// face opposite q (outward normal a) and its 4 side faces (outward normal
// b ⊥ a) receive Δω_f × I_q(ω_f) × (1 − B(ω_f)), ω_f the direction from
// q's centre to the face's centre (a, or (2a + b)/√5), I_q clamped at 0, B
// the geometry volume's one-sided blocking (lpv_sh.glsl) at the face shared
// by q and d (bilinear over the 4 half-offset GV cells that meet there,
// lpv_geometry.glsl). Each face
// flux Φ_f is re-emitted as (Φ_f/π) × the clamped-cosine lobe about the
// face's outward normal. ACCUMULATE adds the result to the accumulation
// volume too (and the source, when the iteration before did not), and
// SNAPSHOT also copies the new accumulated value into
// the snapshot volume (the far-field split of lpv_lookup.glsl: a cascade's
// accumulation after the iterations that reach as far as the next finer
// cascade's whole propagation), which the last iteration (FAR_FIELD) turns
// into the far field, the final accumulation minus the snapshot.

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

// ACCUMULATE: 0 leaves the accumulation alone, 1 adds this iteration's result, 2 adds
// the source (the previous iteration's result, which it left out) and then the result.
// Accumulating every other iteration in pairs halves the accumulation's stores, which
// llvmpipe runs lane by lane and word by word; (a + source) + result rounds as the two
// iterations' additions did, so the accumulation is the same to the bit (core/lpv/lpv_gpu.c).
layout(constant_id = 0) const uint ACCUMULATE = 1u;
// A specialisation, not a push constant: llvmpipe runs the code of an `if` whose
// condition is false for every lane anyway (its stores as per-lane loops), so the
// snapshot's stores exist only in the pipeline of the iteration that takes it.
layout(constant_id = 1) const bool SNAPSHOT = false;
// FAR_FIELD: the cascade's last iteration, which turns the snapshot volume into the far
// field the lookups read, accumulated − snapshot (one volume to fetch instead of two).
layout(constant_id = 2) const bool FAR_FIELD = false;

layout(push_constant) uniform Push {
    uint size;       // cells per axis
    uint base;       // first cell of this cascade in every volume
    uint occlusion;  // 1: apply the geometry volume
} push;

// Source and geometry as texel buffers (RGBA32F): llvmpipe fetches a texel for all lanes
// at once, where it loads a storage buffer lane by lane (bench/RESULTS.md).
layout(set = 0, binding = 0) uniform samplerBuffer source_texels;
layout(std430, set = 0, binding = 1) writeonly buffer Destination { vec4 destination[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Accumulated { vec4 accumulated[]; };
layout(set = 0, binding = 3) uniform samplerBuffer lpv_geometry_texels;
layout(std430, set = 0, binding = 4) writeonly buffer Snapshot { vec4 snapshot[]; };
// The accumulation read through a texel view of the same buffer (bound again here): each
// invocation reads its own cell before writing it, and no other invocation touches it.
layout(set = 0, binding = 5) uniform samplerBuffer accumulated_texels;
// The snapshot likewise, for FAR_FIELD.
layout(set = 0, binding = 6) uniform samplerBuffer snapshot_texels;

#include "lpv_sh.glsl"

// Solid angles Δω of the front face (0.40066968465) and of a side face
// (0.42343135440) seen from the neighbour's centre, and the side directions
// (2a + b)/√5, are folded into the tables below.
// The 30 transfers of one propagation step, (neighbour n, face f) at 5n + f,
// evaluated once from the rule above with lpv_sh.glsl's constants instead of
// at every cell of every iteration: the SH basis of the direction from the
// neighbour's centre to the face, the basis of its reverse (the geometry
// volume's blocking), the clamped-cosine lobe about the face's outward
// normal, and Δω_f / π. On lavapipe this took the propagation from 284–319
// to 202–231 ms per frame (bench/RESULTS.md); test_lpv_propagate checks the
// result against core/lpv's CPU propagation, which applies the rule itself.
const ivec3 NEIGHBOUR_STEP[6] = ivec3[](ivec3(-1, 0, 0), ivec3(1, 0, 0), ivec3(0, -1, 0), ivec3(0, 1, 0), ivec3(0, 0, -1), ivec3(0, 0, 1));
const vec4 TRANSFER_BASIS[30] = vec4[](
    vec4(0.28209479177387814, -0, 0, 0.48860251190291992),
    vec4(0.28209479177387814, -0.21850968611841581, 0, 0.43701937223683163),
    vec4(0.28209479177387814, 0.21850968611841581, 0, 0.43701937223683163),
    vec4(0.28209479177387814, -0, 0.21850968611841581, 0.43701937223683163),
    vec4(0.28209479177387814, -0, -0.21850968611841581, 0.43701937223683163),
    vec4(0.28209479177387814, -0, 0, -0.48860251190291992),
    vec4(0.28209479177387814, -0.21850968611841581, 0, -0.43701937223683163),
    vec4(0.28209479177387814, 0.21850968611841581, 0, -0.43701937223683163),
    vec4(0.28209479177387814, -0, 0.21850968611841581, -0.43701937223683163),
    vec4(0.28209479177387814, -0, -0.21850968611841581, -0.43701937223683163),
    vec4(0.28209479177387814, 0.48860251190291992, 0, -0),
    vec4(0.28209479177387814, 0.43701937223683163, 0.21850968611841581, -0),
    vec4(0.28209479177387814, 0.43701937223683163, -0.21850968611841581, -0),
    vec4(0.28209479177387814, 0.43701937223683163, 0, -0.21850968611841581),
    vec4(0.28209479177387814, 0.43701937223683163, 0, 0.21850968611841581),
    vec4(0.28209479177387814, -0.48860251190291992, 0, -0),
    vec4(0.28209479177387814, -0.43701937223683163, 0.21850968611841581, -0),
    vec4(0.28209479177387814, -0.43701937223683163, -0.21850968611841581, -0),
    vec4(0.28209479177387814, -0.43701937223683163, 0, -0.21850968611841581),
    vec4(0.28209479177387814, -0.43701937223683163, 0, 0.21850968611841581),
    vec4(0.28209479177387814, -0, -0.48860251190291992, -0),
    vec4(0.28209479177387814, -0, -0.43701937223683163, -0.21850968611841581),
    vec4(0.28209479177387814, -0, -0.43701937223683163, 0.21850968611841581),
    vec4(0.28209479177387814, -0.21850968611841581, -0.43701937223683163, -0),
    vec4(0.28209479177387814, 0.21850968611841581, -0.43701937223683163, -0),
    vec4(0.28209479177387814, -0, 0.48860251190291992, -0),
    vec4(0.28209479177387814, -0, 0.43701937223683163, -0.21850968611841581),
    vec4(0.28209479177387814, -0, 0.43701937223683163, 0.21850968611841581),
    vec4(0.28209479177387814, -0.21850968611841581, 0.43701937223683163, -0),
    vec4(0.28209479177387814, 0.21850968611841581, 0.43701937223683163, -0));
const vec4 TRANSFER_BLOCKING[30] = vec4[](
    vec4(0.28209479177387814, -0, 0, -0.48860251190291992),
    vec4(0.28209479177387814, 0.21850968611841581, -0, -0.43701937223683163),
    vec4(0.28209479177387814, -0.21850968611841581, -0, -0.43701937223683163),
    vec4(0.28209479177387814, 0, -0.21850968611841581, -0.43701937223683163),
    vec4(0.28209479177387814, 0, 0.21850968611841581, -0.43701937223683163),
    vec4(0.28209479177387814, -0, 0, 0.48860251190291992),
    vec4(0.28209479177387814, 0.21850968611841581, -0, 0.43701937223683163),
    vec4(0.28209479177387814, -0.21850968611841581, -0, 0.43701937223683163),
    vec4(0.28209479177387814, 0, -0.21850968611841581, 0.43701937223683163),
    vec4(0.28209479177387814, 0, 0.21850968611841581, 0.43701937223683163),
    vec4(0.28209479177387814, -0.48860251190291992, 0, -0),
    vec4(0.28209479177387814, -0.43701937223683163, -0.21850968611841581, 0),
    vec4(0.28209479177387814, -0.43701937223683163, 0.21850968611841581, 0),
    vec4(0.28209479177387814, -0.43701937223683163, -0, 0.21850968611841581),
    vec4(0.28209479177387814, -0.43701937223683163, -0, -0.21850968611841581),
    vec4(0.28209479177387814, 0.48860251190291992, 0, -0),
    vec4(0.28209479177387814, 0.43701937223683163, -0.21850968611841581, 0),
    vec4(0.28209479177387814, 0.43701937223683163, 0.21850968611841581, 0),
    vec4(0.28209479177387814, 0.43701937223683163, -0, 0.21850968611841581),
    vec4(0.28209479177387814, 0.43701937223683163, -0, -0.21850968611841581),
    vec4(0.28209479177387814, -0, 0.48860251190291992, -0),
    vec4(0.28209479177387814, 0, 0.43701937223683163, 0.21850968611841581),
    vec4(0.28209479177387814, 0, 0.43701937223683163, -0.21850968611841581),
    vec4(0.28209479177387814, 0.21850968611841581, 0.43701937223683163, 0),
    vec4(0.28209479177387814, -0.21850968611841581, 0.43701937223683163, 0),
    vec4(0.28209479177387814, -0, -0.48860251190291992, -0),
    vec4(0.28209479177387814, 0, -0.43701937223683163, 0.21850968611841581),
    vec4(0.28209479177387814, 0, -0.43701937223683163, -0.21850968611841581),
    vec4(0.28209479177387814, 0.21850968611841581, -0.43701937223683163, 0),
    vec4(0.28209479177387814, -0.21850968611841581, -0.43701937223683163, 0));
const vec4 TRANSFER_LOBE[30] = vec4[](
    vec4(0.88622692545275805, -0, 0, 1.0233267079464885),
    vec4(0.88622692545275805, -1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, 1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, -0, 1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, -1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, 0, -1.0233267079464885),
    vec4(0.88622692545275805, -1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, 1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, -0, 1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, -1.0233267079464885, -0),
    vec4(0.88622692545275805, 1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, -0, 1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, -1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, 0, -1.0233267079464885),
    vec4(0.88622692545275805, -0, 0, 1.0233267079464885),
    vec4(0.88622692545275805, -1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, -0, 1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, -1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, 0, -1.0233267079464885),
    vec4(0.88622692545275805, -0, 0, 1.0233267079464885),
    vec4(0.88622692545275805, -0, -1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, 0, -1.0233267079464885),
    vec4(0.88622692545275805, -0, 0, 1.0233267079464885),
    vec4(0.88622692545275805, -1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, 1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, -0, 1.0233267079464885, -0),
    vec4(0.88622692545275805, -0, 0, -1.0233267079464885),
    vec4(0.88622692545275805, -0, 0, 1.0233267079464885),
    vec4(0.88622692545275805, -1.0233267079464885, 0, -0),
    vec4(0.88622692545275805, 1.0233267079464885, 0, -0));
const float TRANSFER_SCALE[30] = float[](0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.12753712171823681, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234, 0.13478238622571234);

uint cell_index(ivec3 c)
{
    return push.base + (uint(c.z) * push.size + uint(c.y)) * push.size + uint(c.x);
}

bool inside(ivec3 c)
{
    return all(greaterThanEqual(c, ivec3(0))) && all(lessThan(c, ivec3(push.size)));
}

#include "lpv_geometry.glsl"

void main()
{
    ivec3 d = ivec3(gl_GlobalInvocationID);
    if (!inside(d))
        return;
    vec4 out_r = vec4(0.0), out_g = vec4(0.0), out_b = vec4(0.0);
    // Neighbour n = 2k + (s > 0) is q = d − s·e_k; faces 0 (opposite q) and 1..4 (the sides).
    for (int n = 0; n < 6; n++) {
        ivec3 q = d - NEIGHBOUR_STEP[n];
        if (!inside(q))
            continue;
        uint qi = 3u * cell_index(q);
        vec4 q_r = texelFetch(source_texels, int(qi));
        vec4 q_g = texelFetch(source_texels, int(qi + 1u));
        vec4 q_b = texelFetch(source_texels, int(qi + 2u));
        vec4 gv = push.occlusion != 0u
                      ? lpv_face_geometry(d, n / 2, (n & 1) != 0 ? 1 : -1, push.base, push.size)
                      : vec4(0.0);
        for (int f = 0; f < 5; f++) {
            int t = 5 * n + f;
            vec4 basis = TRANSFER_BASIS[t];
            vec3 intensity = max(vec3(dot(q_r, basis), dot(q_g, basis), dot(q_b, basis)),
                                 vec3(0.0));
            float open = push.occlusion != 0u
                             ? 1.0 - clamp(dot(gv, TRANSFER_BLOCKING[t]), 0.0, 1.0)
                             : 1.0;
            vec3 flux = TRANSFER_SCALE[t] * open * intensity;
            vec4 lobe = TRANSFER_LOBE[t];
            out_r += flux.r * lobe;
            out_g += flux.g * lobe;
            out_b += flux.b * lobe;
        }
    }
    uint di = 3u * cell_index(d);
    destination[di] = out_r;
    destination[di + 1u] = out_g;
    destination[di + 2u] = out_b;
    if (ACCUMULATE != 0u) {
        vec4 r = texelFetch(accumulated_texels, int(di));
        vec4 g = texelFetch(accumulated_texels, int(di + 1u));
        vec4 b = texelFetch(accumulated_texels, int(di + 2u));
        if (ACCUMULATE == 2u) {
            r += texelFetch(source_texels, int(di));
            g += texelFetch(source_texels, int(di + 1u));
            b += texelFetch(source_texels, int(di + 2u));
        }
        r += out_r;
        g += out_g;
        b += out_b;
        accumulated[di] = r;
        accumulated[di + 1u] = g;
        accumulated[di + 2u] = b;
        if (FAR_FIELD) {
            // A snapshot taken in this same iteration is the accumulation: no far field.
            vec4 snapshot_r = SNAPSHOT ? r : texelFetch(snapshot_texels, int(di));
            vec4 snapshot_g = SNAPSHOT ? g : texelFetch(snapshot_texels, int(di + 1u));
            vec4 snapshot_b = SNAPSHOT ? b : texelFetch(snapshot_texels, int(di + 2u));
            snapshot[di] = r - snapshot_r;
            snapshot[di + 1u] = g - snapshot_g;
            snapshot[di + 2u] = b - snapshot_b;
        } else if (SNAPSHOT) {
            snapshot[di] = r;
            snapshot[di + 1u] = g;
            snapshot[di + 2u] = b;
        }
    }
}
