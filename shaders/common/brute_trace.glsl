// Brute-force ray casting: one ray against every triangle, the oracle the BIH
// is tested against and the preview renderer's only traversal for now.
//
// The including shader declares, before including this file:
//   buffer ... { vec4 triangle_vertices[]; };   // 3 per triangle, xyz (+ w)
// (and see trace_subgroup for its extra requirements).
#ifndef PF_BRUTE_TRACE_GLSL
#define PF_BRUTE_TRACE_GLSL

#include "ray_triangle.glsl"
#include "scene_types.glsl"

struct TraceHit {
    float t;        // -1 on a miss
    uint triangle;  // NO_HIT on a miss
    float u, v;     // barycentrics of vertices 1 and 2
};

// Closest hit in (tmin, tmax), or with any_hit the first hit found (shadow
// rays). Triangles are tested in index order, so equal t: the lower triangle
// index wins, as on the CPU.
//
// Each triangle is read from memory once per subgroup instead of once per
// ray: lane i loads triangle base + i and subgroupShuffle hands it to every
// lane. On lavapipe (Mesa 22.3), where every storage-buffer load is a per-lane
// gather, this is ~5× faster than each ray reading every triangle itself
// (staircase2, 3072 rays: 0.75 s against 3.6 s); staging tiles through shared
// memory with barriers was slower still (5.5 s), so that is not done.
//
// The including shader enables GL_KHR_shader_subgroup_basic, _vote and
// _shuffle. Every lane of the subgroup must call
// trace_subgroup together (subgroup-uniform control flow, same
// triangle_count); a lane with nothing to trace passes enabled = false.
//
// lavapipe 22.3 is fragile with cross-lane operations inside nested loops:
// called from a loop over pixel samples it returned wrong closest hits for
// later samples, a per-ray variant in the same loops lost whole subgroups'
// hits, and a shared-memory variant with barriers did too. So callers keep
// one sample per dispatch (render_direct.comp), and tests/render checks every
// camera ray's depth against the CPU.
TraceHit trace_subgroup(vec3 origin, vec3 direction, float tmin, float tmax, bool any_hit,
                        bool enabled, uint triangle_count)
{
    TraceHit hit = TraceHit(-1.0, NO_HIT, 0.0, 0.0);
    RayShear shear = ray_shear_setup(direction);
    bool searching = enabled && shear.valid;
    float closest = tmax;
    uint width = gl_SubgroupSize;
    for (uint base = 0u; base < triangle_count; base += width) {
        if (!subgroupAny(searching))
            break; // every lane's any-hit query is answered
        uint mine = min(base + gl_SubgroupInvocationID, triangle_count - 1u);
        vec4 p0 = triangle_vertices[3u * mine];
        vec4 p1 = triangle_vertices[3u * mine + 1u];
        vec4 p2 = triangle_vertices[3u * mine + 2u];
        uint batch = min(width, triangle_count - base);
        for (uint j = 0u; j < batch; j++) {
            vec3 v0 = subgroupShuffle(p0, j).xyz;
            vec3 v1 = subgroupShuffle(p1, j).xyz;
            vec3 v2 = subgroupShuffle(p2, j).xyz;
            float t, u, v;
            if (searching &&
                ray_triangle_watertight(origin, shear, v0, v1, v2, tmin, closest, t, u, v)) {
                closest = t;
                hit = TraceHit(t, base + j, u, v);
                searching = !any_hit;
            }
        }
    }
    return hit;
}

#endif
