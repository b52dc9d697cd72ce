#version 460
#extension GL_GOOGLE_include_directive : require
// GPU BIH build, pass 3: bottom up. One invocation per sorted triangle j
// copies its vertices into leaf order, writes its leaf's box, then walks
// towards the root: at each inner node a uint atomic arrival counter stops
// the first child's invocation; the second one (both children's boxes are
// written by then) computes the node's box, triangle count and clip values
// (left child's max and right child's min along the split axis) and goes on.
// Each node is finished exactly once, so the walk is O(n) in total (Apetrei /
// Karras), not O(n * depth) as with per-leaf float atomics.

#include "bih_build.glsl"
#include "ray_triangle.glsl" // triangle_is_degenerate: the leaf-order vertices carry it

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;          // sorted triangles n (>= 2)
    uint max_leaf_size;  // K: an inner node with more triangles is kept
} push;

struct Box {
    vec4 lo;
    vec4 hi;
};

layout(std430, set = 0, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, set = 0, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 2) coherent buffer Inner { BihInner inner[]; };
layout(std430, set = 0, binding = 3) coherent buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 4) coherent buffer Boxes { Box boxes[]; };
layout(std430, set = 0, binding = 5) coherent buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 6) buffer Arrivals { uint arrivals[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Clips { vec2 clips[]; };
layout(std430, set = 0, binding = 8) writeonly buffer Kept { uint kept[]; };
layout(std430, set = 0, binding = 9) writeonly buffer LeafVertices { vec4 leaf_vertices[]; };
layout(std430, set = 0, binding = 10) writeonly buffer TriangleIndex { uint triangle_index[]; };

void main()
{
    uint j = gl_GlobalInvocationID.x;
    bool in_range = j < push.count;
    uint parent = BIH_BUILD_NO_PARENT;
    if (in_range) {
        uint triangle = values[j];
        vec4 a = vertices[3 * triangle], b = vertices[3 * triangle + 1], c = vertices[3 * triangle + 2];
        // w = 0, but a degenerate triangle's flag on its first vertex, as pf_bih.h defines it.
        leaf_vertices[3 * j] = vec4(a.xyz, triangle_is_degenerate(a.xyz, b.xyz, c.xyz) ? 1.0 : 0.0);
        leaf_vertices[3 * j + 1] = vec4(b.xyz, 0.0);
        leaf_vertices[3 * j + 2] = vec4(c.xyz, 0.0);
        triangle_index[j] = triangle;
        uint node = push.count - 1u + j;
        boxes[node] = Box(vec4(min(min(a.xyz, b.xyz), c.xyz), 0.0), vec4(max(max(a.xyz, b.xyz), c.xyz), 0.0));
        counts[node] = 1u;
        parent = parents[node];
    }
    memoryBarrierBuffer();
    bool climbing = true;
    for (uint level = 0u; level < BIH_BUILD_LEVELS; level++) {
        if (climbing && parent != BIH_BUILD_NO_PARENT) {
            climbing = atomicAdd(arrivals[parent], 1u) != 0u;
        } else {
            climbing = false;
        }
        memoryBarrierBuffer();
        if (climbing) {
            BihInner record = inner[parent];
            Box left = boxes[record.left], right = boxes[record.right];
            vec3 lo = min(left.lo.xyz, right.lo.xyz), hi = max(left.hi.xyz, right.hi.xyz);
            uint axis = record.axis;
            if (axis == BIH_BUILD_AXIS_UNDECIDED) {
                vec3 extent = hi - lo;
                axis = extent.x >= extent.y && extent.x >= extent.z ? 0u : (extent.y >= extent.z ? 1u : 2u);
                inner[parent].axis = axis;
            }
            clips[parent] = vec2(left.hi[axis], right.lo[axis]);
            uint count = counts[record.left] + counts[record.right];
            boxes[parent] = Box(vec4(lo, 0.0), vec4(hi, 0.0));
            counts[parent] = count;
            kept[parent] = count > push.max_leaf_size ? 1u : 0u;
            parent = parents[parent];
        }
        memoryBarrierBuffer();
    }
}
