#version 460
#extension GL_GOOGLE_include_directive : require
// GPU BIH build, pass 4: collapse and compact into the device's node texels.
// Inner nodes with more than K triangles are kept; rank[i] (the exclusive
// scan of bih_clip.comp's kept flags) numbers them, and kept node i gets its
// two children at 1 + 2 * rank[i] and 1 + 2 * rank[i] + 1 — adjacent, as the
// node word requires. Its own slot follows from its parent's rank (the root,
// node 0, is slot 0). A child with at most K triangles becomes a leaf over
// its contiguous sorted range, which is the leaf order. With write_boxes, each
// slot's box (bih_clip.comp's, of the same subtree) goes to slot_boxes too: a
// tree kept on the device is measured from them (core/bih/bih_gpu_refit.c).

#include "bih_build.glsl"

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;          // sorted triangles n (>= 2)
    uint max_leaf_size;  // K
    uint write_boxes;    // 1: slot_boxes[slot] = boxes[node] for every slot written
} push;

struct Box {
    vec4 lo;
    vec4 hi;
};

layout(std430, set = 0, binding = 0) readonly buffer Inner { BihInner inner[]; };
layout(std430, set = 0, binding = 1) readonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 2) readonly buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 3) readonly buffer Clips { vec2 clips[]; };
layout(std430, set = 0, binding = 4) readonly buffer Rank { uint rank[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Nodes { uint nodes[]; };
layout(std430, set = 0, binding = 6) readonly buffer Boxes { Box boxes[]; };
layout(std430, set = 0, binding = 7) writeonly buffer SlotBoxes { Box slot_boxes[]; };

const uint LEAF_WORD = 3u;

// Raw words: a leaf's fields are uint bits (small values are float
// denormals, which must not pass through float arithmetic). One 16-byte
// texel per node, the layout traversal reads (pf_bih_gpu_upload's): the
// tree stays on the device as built (issue 44).
void write_node(uint slot, uint field0, uint field1, uint word)
{
    nodes[4 * slot] = field0;
    nodes[4 * slot + 1] = field1;
    nodes[4 * slot + 2] = word;
    nodes[4 * slot + 3] = 0u;
}

void main()
{
    uint node = gl_GlobalInvocationID.x;
    if (node + 1u >= push.count || counts[node] <= push.max_leaf_size)
        return;
    uint slot = 0u;
    if (node != 0u) {
        uint parent = parents[node];
        slot = 1u + 2u * rank[parent] + (inner[parent].right == node ? 1u : 0u);
    }
    BihInner record = inner[node];
    uint base = 1u + 2u * rank[node];
    write_node(slot, floatBitsToUint(clips[node].x), floatBitsToUint(clips[node].y), (base << 2) | record.axis);
    if (push.write_boxes != 0u)
        slot_boxes[slot] = boxes[node];
    uint leaf_base = push.count - 1u;
    uint children[2] = uint[2](record.left, record.right);
    for (uint k = 0u; k < 2u; k++) {
        uint child = children[k];
        if (child >= leaf_base || counts[child] <= push.max_leaf_size) {
            uint first = child >= leaf_base ? child - leaf_base : inner[child].first;
            write_node(base + k, first, counts[child], LEAF_WORD);
            if (push.write_boxes != 0u)
                slot_boxes[base + k] = boxes[child];
        }
    }
}
