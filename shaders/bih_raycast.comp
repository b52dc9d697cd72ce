#version 460
#extension GL_GOOGLE_include_directive : require
// pf_bih_raycast: one invocation per ray through the BIH (bih_traverse.glsl).
// Rays are pf_ray (origin + tmin, direction + tmax), hits pf_hit; ANY_HIT
// selects the shadow-ray query. Rays whose traversal fails (stack overflow)
// are counted in failures[0] so the host reports them.

#include "ray_types.glsl"

layout(local_size_x = 64) in;
layout(constant_id = 0) const bool ANY_HIT = false;

layout(push_constant) uniform Push {
    vec4 bounds_min; // xyz: the BIH's root box
    vec4 bounds_max;
    uint ray_count;  // rays in this dispatch (the host splits big batches)
    uint triangle_count;
    uint node_count;
    uint padding;
} push;

layout(std430, set = 0, binding = 3) readonly buffer Rays { Ray rays[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Hits { HitRecord hits[]; };
layout(std430, set = 0, binding = 5) buffer Failures { uint failures[]; };

#define BIH_BINDING 0 // nodes, vertices, triangle index at bindings 0, 1, 2
#include "bih_traverse.glsl"

void main()
{
    uint index = gl_GlobalInvocationID.x;
    if (index >= push.ray_count)
        return;
    Ray ray = rays[index];
    bool failed;
    BihHit hit = trace_bih(ray.origin_tmin.xyz, ray.direction_tmax.xyz, ray.origin_tmin.w,
                           ray.direction_tmax.w, ANY_HIT, push.bounds_min.xyz,
                           push.bounds_max.xyz, push.triangle_count, push.node_count, failed);
    if (failed)
        atomicAdd(failures[0], 1u);
    hits[index] = HitRecord(hit.t, hit.triangle, hit.u, hit.v);
}
