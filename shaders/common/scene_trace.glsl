// trace(): the integrators' one ray query through the frame's BIH, and the
// BIH's three buffers. The including kernel defines BIH_BINDING (the first of
// the three bindings: they follow its film and counters) and declares
// `counters` with a uint traversal_failures, which a failed traversal
// increments (the host then fails the frame: a stack overflow must never pass
// as a miss).
#ifndef PF_SCENE_TRACE_GLSL
#define PF_SCENE_TRACE_GLSL

#include "bih_traverse.glsl" // declares the three bindings from BIH_BINDING

// Closest (or with any_hit, any) hit; a failed traversal counts as a miss
// here and is reported to the host. camera: the ray leaves the camera (a path's
// first segment), the only rays that see unlit surfaces (scene_alpha_passes).
BihHit trace_seen(vec3 origin, vec3 direction, float tmax, bool any_hit, bool camera)
{
    bool failed;
    BihHit hit = trace_bih_surfaces(origin, direction, 0.0, tmax, any_hit, camera,
                                    params.bih_bounds_min.xyz, params.bih_bounds_max.xyz,
                                    params.triangle_count, params.bih_node_count, failed);
    if (failed)
        atomicAdd(counters.traversal_failures, 1u);
    return hit;
}

// trace_seen for a ray that does not leave the camera (shadow, gather, bounce rays).
BihHit trace(vec3 origin, vec3 direction, float tmax, bool any_hit)
{
    return trace_seen(origin, direction, tmax, any_hit, false);
}

// The hit that counts of a ray the host traced (hit: its closest, or with any_hit any, hit
// of the ray from origin up to tmax), going on past alpha-tested triangles whose hits do not
// count (bih_traverse.glsl trace_bih_surfaces_after): what trace_seen() would have returned.
BihHit trace_after(BihHit hit, vec3 origin, vec3 direction, float tmax, bool any_hit,
                   bool camera)
{
    bool failed;
    hit = trace_bih_surfaces_after(hit, origin, direction, 0.0, tmax, any_hit, camera,
                                   params.bih_bounds_min.xyz, params.bih_bounds_max.xyz,
                                   params.triangle_count, params.bih_node_count, failed);
    if (failed)
        atomicAdd(counters.traversal_failures, 1u);
    return hit;
}

#endif
