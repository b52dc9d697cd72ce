#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// VPL injection on the device (core/lpv/lpv_inject_device.c; pf_lpv_inject in
// core/lpv/lpv_inject.c is its reference on the host): each photon record of the
// global map is a VPL of reflected flux Φ leaving its surface along the stored
// normal, and adds (Φ/π) × the clamped-cosine lobe of that normal to the cell of
// every cascade that holds its position moved offset_cells along the normal.
//
// Many VPLs land in one cell, so the sums are atomics. Float atomics would add in
// whichever order the invocations run, and the volume would differ from run to run
// in its last bits; the sums are instead 64-bit integers in units of 2^-24 of the
// map's flux unit (FIXED_ONE). Integer addition does not depend on the order, so the
// volume is the same to the bit on every run and every device. A record's flux is
// rgb9e5 (at most 65,408) times a lobe coefficient over π (under 0.33), so one VPL
// adds under 2^39 units and 2^24 VPLs in one cell cannot overflow; the step 2^-24
// is below the rounding of the host's float sums for any flux unit above 2^-24.
//
// PASS (a specialisation, one pipeline each): 0 zeroes the sums and the counters,
// 1 adds the VPLs, 2 turns the sums into floats (× flux_scale / FIXED_ONE) in the
// injected volume and, with push.all_targets, the accumulation and the snapshot
// (a propagation starts from all three equal, core/lpv/lpv_gpu.c).

layout(local_size_x = 64) in;
layout(constant_id = 0) const uint PASS = 0u;

const uint PASS_CLEAR = 0u;
const uint PASS_INJECT = 1u;
const uint PASS_RESOLVE = 2u;
const uint MAX_CASCADES = 8u;   // PF_LPV_MAX_CASCADES
const uint FLOATS_PER_CELL = 12u; // PF_LPV_FLOATS_PER_CELL: 4 SH coefficients × RGB
const float FIXED_ONE = 16777216.0; // 2^24
const float INV_PI = 0.31830988618379067;

layout(push_constant) uniform Push {
    uint vpl_count;
    uint cascade_count;
    uint size;          // cells per axis in every cascade
    uint all_targets;   // PASS_RESOLVE: write the accumulation and the snapshot too
    uint float_count;   // floats of one volume, all cascades
    uint stride;        // invocations in the dispatch: each takes every stride-th item
    float offset_cells; // pf_lpv_layout.offset_cells
    float resolve_scale; // flux_scale / FIXED_ONE
} push;

#include "lpv_sh.glsl"
#include "photon_types.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Photons { uint photon_words[]; };
// xyz: the cascade's origin, w: its cell size.
layout(std430, set = 0, binding = 1) readonly buffer Cascades { vec4 cascades[MAX_CASCADES]; };
layout(std430, set = 0, binding = 2) buffer Sums { int64_t sums[]; };
// pf_lpv_inject_stats: VPLs in each cascade, outside every cascade, rejected.
layout(std430, set = 0, binding = 3) buffer Counters {
    uint injected[MAX_CASCADES];
    uint outside;
    uint rejected;
} counters;
layout(std430, set = 0, binding = 4) writeonly buffer Injected { float injected_out[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Accumulated { float accumulated_out[]; };
layout(std430, set = 0, binding = 6) writeonly buffer Snapshot { float snapshot_out[]; };

bool finite3(vec3 v)
{
    return !any(isnan(v)) && !any(isinf(v));
}

void inject(uint v)
{
    uint base = PHOTON_WORDS * v;
    vec3 position = vec3(uintBitsToFloat(photon_words[base]), uintBitsToFloat(photon_words[base + 1u]),
                         uintBitsToFloat(photon_words[base + 2u]));
    vec3 flux = rgb9e5_unpack(photon_words[base + 3u]);
    uint directions = photon_words[base + 4u];
    vec3 normal = octahedral_unpack8(directions >> 16u);
    if (!photon_record_present(directions) || !finite3(position) || !finite3(normal)) {
        atomicAdd(counters.rejected, 1u);
        return;
    }
    vec4 lobe = sh_cosine_lobe(normal);
    // Each coefficient's addition in fixed point, the same for every cascade.
    int64_t add[FLOATS_PER_CELL];
    for (uint channel = 0u; channel < 3u; channel++)
        for (uint c = 0u; c < 4u; c++)
            add[4u * channel + c] = int64_t(floor(flux[channel] * INV_PI * lobe[c] * FIXED_ONE + 0.5));
    bool landed = false;
    uint cells = push.size * push.size * push.size;
    for (uint k = 0u; k < push.cascade_count; k++) {
        vec3 p = position + normal * (push.offset_cells * cascades[k].w);
        vec3 cell = floor((p - cascades[k].xyz) / cascades[k].w);
        if (any(lessThan(cell, vec3(0.0))) || any(greaterThanEqual(cell, vec3(float(push.size)))))
            continue;
        landed = true;
        atomicAdd(counters.injected[k], 1u);
        uvec3 c = uvec3(cell);
        uint index = k * cells + (c.z * push.size + c.y) * push.size + c.x;
        for (uint f = 0u; f < FLOATS_PER_CELL; f++)
            if (add[f] != 0l)
                atomicAdd(sums[index * FLOATS_PER_CELL + f], add[f]);
    }
    if (!landed)
        atomicAdd(counters.outside, 1u);
}

void main()
{
    uint first = gl_GlobalInvocationID.x;
    if (PASS == PASS_CLEAR) {
        for (uint i = first; i < push.float_count; i += push.stride)
            sums[i] = 0l;
        if (first < MAX_CASCADES)
            counters.injected[first] = 0u;
        if (first == 0u) {
            counters.outside = 0u;
            counters.rejected = 0u;
        }
    } else if (PASS == PASS_INJECT) {
        for (uint v = first; v < push.vpl_count; v += push.stride)
            inject(v);
    } else {
        for (uint i = first; i < push.float_count; i += push.stride) {
            float value = float(sums[i]) * push.resolve_scale;
            injected_out[i] = value;
            if (push.all_targets != 0u) {
                accumulated_out[i] = value;
                snapshot_out[i] = value;
            }
        }
    }
}
