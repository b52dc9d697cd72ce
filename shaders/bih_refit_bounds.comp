#version 460
// BIH refit on the device (core/bih/bih_gpu_refit.c), pass 2: bottom up, as
// bih_clip.comp does for a fresh tree. One invocation per node; a leaf's
// writes its box from its leaf-order triangles and climbs: at each inner node
// a uint arrival counter stops the first child's invocation, and the second
// (both children's boxes written by then) sets the node's clip values (the
// left child's max and the right child's min along its axis) and box. The
// arithmetic is pf_bih_refit's (core/bih/bih_refit.c): the same compare-and-
// select merge in the same order, so every clip value and the root box come
// out bit for bit as the host's refit makes them; an empty leaf's box stays
// empty (+inf, -inf), so its parent's clip on that side is -inf or +inf again.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint node_bound; // invocations (the node count is stats.w)
    uint levels;     // the tree's depth + 1: no climb is longer
} push;

struct Box {
    vec4 lo;
    vec4 hi;
};

layout(std430, set = 0, binding = 0) coherent buffer Nodes { uvec4 nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, set = 0, binding = 2) readonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 3) buffer Arrivals { uint arrivals[]; };
layout(std430, set = 0, binding = 4) coherent buffer Boxes { Box boxes[]; };
layout(std430, set = 0, binding = 5) readonly buffer Stats { uvec4 stats; };

const uint NO_PARENT = 0xFFFFFFFFu;
const uint LEAF = 3u;           // PF_BIH_LEAF

// pf_bih_box_merge: a coordinate replaces the box's only where it is strictly beyond.
void merge(inout Box box, vec3 lo, vec3 hi)
{
    box.lo.xyz = mix(box.lo.xyz, lo, lessThan(lo, box.lo.xyz));
    box.hi.xyz = mix(box.hi.xyz, hi, greaterThan(hi, box.hi.xyz));
}

Box empty_box()
{
    float inf = uintBitsToFloat(0x7F800000u);
    return Box(vec4(vec3(inf), 0.0), vec4(vec3(-inf), 0.0));
}

// Every invocation runs the loop to its end, climbing or not, as bih_clip.comp's
// does: written with an early return and a break, or with a break once no
// invocation of the subgroup climbs, the climb stopped short on llvmpipe (Mesa
// 22.3): 169 of a 600-triangle tree's 216 inner nodes were reached. The loop runs
// the tree's depth + 1 rounds, not the deepest tree's 65.
void main()
{
    uint node = gl_GlobalInvocationID.x;
    bool climbing = false;
    if (node < stats.w) {
        uvec4 texel = nodes[node];
        if ((texel.z & 3u) == LEAF) {
            Box box = empty_box();
            for (uint p = texel.x; p < texel.x + texel.y; p++)
                for (uint c = 0u; c < 3u; c++) {
                    vec3 v = vertices[3u * p + c].xyz;
                    merge(box, v, v);
                }
            boxes[node] = box;
            climbing = true;
        }
    }
    memoryBarrierBuffer();
    for (uint level = 0u; level < push.levels; level++) {
        uint parent = climbing ? parents[node] : NO_PARENT;
        climbing = parent != NO_PARENT && atomicAdd(arrivals[parent], 1u) != 0u;
        memoryBarrierBuffer();
        if (climbing) {
            uint word = nodes[parent].z;
            uint child = word >> 2u, axis = word & 3u;
            Box left = boxes[child], right = boxes[child + 1u];
            nodes[parent].xy = uvec2(floatBitsToUint(left.hi[axis]), floatBitsToUint(right.lo[axis]));
            Box merged = empty_box();
            merge(merged, left.lo.xyz, left.hi.xyz);
            merge(merged, right.lo.xyz, right.hi.xyz);
            boxes[parent] = merged;
            node = parent;
        }
        memoryBarrierBuffer();
    }
}
