#version 460
#extension GL_GOOGLE_include_directive : require
// pf_photon_grid_irradiance: the cone-filtered irradiance estimate
// (photon_estimate.glsl) at query points, for tests against closed forms.

layout(local_size_x = 64) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

layout(std430, set = 0, binding = 0) readonly buffer SortedPhotons { uint grid_words[]; };
layout(std430, set = 0, binding = 1) readonly buffer Ranges { uvec2 grid_ranges[]; };
layout(std430, set = 0, binding = 2) readonly buffer Queries { vec4 queries[]; };  // xyz, radius
layout(std430, set = 0, binding = 3) readonly buffer Normals { vec4 normals[]; };  // xyz
layout(std430, set = 0, binding = 4) writeonly buffer Results { vec4 results[]; }; // rgb

#include "photon_estimate.glsl"

void main()
{
    uint q = gl_GlobalInvocationID.x;
    if (q >= push.count)
        return;
    results[q] = vec4(photon_irradiance(queries[q].xyz, normals[q].xyz, queries[q].w,
                                        photon_grid_from_push()),
                      0.0);
}
