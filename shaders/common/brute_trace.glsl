// Brute-force ray casting: one ray against every triangle, the oracle the BIH
// is tested against.
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

// Closest hit in (tmin, tmax) among triangles [begin, end), continuing from
// an earlier answer over the triangles before begin (carried: a miss on the
// first range), or with any_hit the first hit found (shadow rays; a carried
// hit is final). Triangles are tested in index order and a hit must be
// strictly nearer than the best so far, so on an equal t the lower triangle
// index wins, as on the CPU, across ranges too.
//
// Why ranges: llvmpipe ends every loop of an invocation once it has run
// 65,535 iterations in total (Mesa 22.3's loop limiter, no error), and this
// search runs ~(1 + 1/subgroup size) iterations per triangle, so one call
// over more than ~58k triangles silently ignored the rest. The host
// (core/render/raycast_brute.c) keeps each range far below that.
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
// begin and end); a lane with nothing to trace passes enabled = false.
//
// lavapipe 22.3 is fragile with cross-lane operations inside nested loops:
// called from a loop over pixel samples it returned wrong closest hits for
// later samples, a per-ray variant in the same loops lost whole subgroups'
// hits, and a shared-memory variant with barriers did too. So callers keep
// one call per dispatch, and tests/render checks the answers against the CPU.
TraceHit trace_subgroup(vec3 origin, vec3 direction, float tmin, float tmax, bool any_hit,
                        bool enabled, uint begin, uint end, TraceHit carried)
{
    TraceHit hit = carried;
    RayShear shear = ray_shear_setup(direction);
    bool found = carried.triangle != NO_HIT;
    bool searching = enabled && shear.valid && !(any_hit && found);
    float closest = found ? carried.t : tmax;
    uint width = gl_SubgroupSize;
    for (uint base = begin; base < end; base += width) {
        if (!subgroupAny(searching))
            break; // every lane's any-hit query is answered
        uint mine = min(base + gl_SubgroupInvocationID, end - 1u);
        vec4 p0 = triangle_vertices[3u * mine];
        vec4 p1 = triangle_vertices[3u * mine + 1u];
        vec4 p2 = triangle_vertices[3u * mine + 2u];
        uint batch = min(width, end - base);
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
