#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_vote : require
// pf_raycast_brute_force: every ray against every triangle (the BIH's test
// oracle). One invocation per ray; ANY_HIT selects the shadow-ray variant.
// Rays are pf_ray (origin + tmin, direction + tmax), hits pf_hit. One dispatch
// covers the triangle range [triangle_begin, triangle_end) and carries each
// ray's answer over the triangles before it in its hit record (see
// trace_subgroup for why the host splits the triangles).

#include "ray_types.glsl"

// A multiple of every subgroup size in use (8 lavapipe, 32 NVIDIA, 64 AMD), so
// no subgroup is partial.
layout(local_size_x = 64) in;
layout(constant_id = 0) const bool ANY_HIT = false;

layout(push_constant) uniform Push {
    uint ray_count;      // rays in this dispatch (the host splits big batches)
    uint triangle_begin; // this dispatch's triangles: [triangle_begin, triangle_end)
    uint triangle_end;
    uint carry;          // 0 on the first range (no earlier answer), else 1
} push;

layout(std430, set = 0, binding = 0) readonly buffer TriangleVertices { vec4 triangle_vertices[]; };
layout(std430, set = 0, binding = 1) readonly buffer Rays { Ray rays[]; };
layout(std430, set = 0, binding = 2) buffer Hits { HitRecord hits[]; };

#include "brute_trace.glsl"

void main()
{
    uint index = gl_GlobalInvocationID.x;
    bool enabled = index < push.ray_count;
    Ray ray = rays[enabled ? index : 0u];
    TraceHit carried = TraceHit(-1.0, NO_HIT, 0.0, 0.0);
    if (enabled && push.carry != 0u) {
        HitRecord earlier = hits[index];
        carried = TraceHit(earlier.t, earlier.triangle, earlier.u, earlier.v);
    }
    TraceHit hit = trace_subgroup(ray.origin_tmin.xyz, ray.direction_tmax.xyz, ray.origin_tmin.w,
                                  ray.direction_tmax.w, ANY_HIT, enabled, push.triangle_begin,
                                  push.triangle_end, carried);
    if (enabled)
        hits[index] = HitRecord(hit.t, hit.triangle, hit.u, hit.v);
}
