#version 460
#extension GL_GOOGLE_include_directive : require
// pf_photon_grid_irradiance, pf_photon_grid_irradiance_knn and
// pf_photon_grid_irradiance_lookup: the estimates of photon_estimate.glsl at
// query points, for tests against closed forms and brute force. push.mode
// picks the estimate, push.capacity is k.

layout(local_size_x = 64) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

// Modes (core/photon/photon_grid.c): fixed radius, or k nearest within it.
const uint ESTIMATE_FIXED = 0u;
const uint ESTIMATE_KNN = 1u;
const uint ESTIMATE_LOOKUP = 2u; // the bound grid holds precomputed irradiance points

// The map (photon_estimate.glsl: texel buffers).
layout(set = 0, binding = 0) uniform isamplerBuffer grid_records;
layout(set = 0, binding = 1) uniform isamplerBuffer grid_ranges;
layout(std430, set = 0, binding = 2) readonly buffer Queries { vec4 queries[]; };  // xyz, radius
layout(std430, set = 0, binding = 3) readonly buffer Normals { vec4 normals[]; };  // xyz
layout(std430, set = 0, binding = 4) writeonly buffer Results { vec4 results[]; }; // rgb, radius used (lookup: 1 found, 0 not)
layout(std430, set = 0, binding = 5) writeonly buffer Truncated { uint truncated_flags[]; };
layout(set = 0, binding = 6) uniform usamplerBuffer grid_flux;

// One estimate per invocation and no other long loop: most of llvmpipe's
// 65,535-iteration cap (PF_PHOTON_ESTIMATE_MAX_ITERATIONS in pf_photon.h).
#define PHOTON_ESTIMATE_MAX_ITERATIONS 60000u
#include "photon_estimate.glsl"

void main()
{
    uint q = gl_GlobalInvocationID.x;
    if (q >= push.count)
        return;
    vec3 x = queries[q].xyz;
    vec3 normal = normals[q].xyz;
    float radius = queries[q].w;
    float radius_used = radius;
    bool truncated;
    vec3 irradiance;
    if (push.mode == ESTIMATE_LOOKUP) {
        bool found = photon_irradiance_lookup(x, normal, radius, photon_grid_from_push(),
                                              irradiance, truncated);
        radius_used = found ? 1.0 : 0.0;
    } else if (push.mode == ESTIMATE_KNN) {
        irradiance = photon_irradiance_knn(x, normal, push.capacity, radius,
                                           photon_grid_from_push(), radius_used, truncated);
    } else {
        irradiance = photon_irradiance_guarded(x, normal, radius, photon_grid_from_push(),
                                               truncated);
    }
    results[q] = vec4(irradiance, radius_used);
    truncated_flags[q] = truncated ? 1u : 0u;
}
