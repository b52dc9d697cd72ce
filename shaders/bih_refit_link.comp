#version 460
// BIH refit on the device (core/bih/bih_gpu_refit.c), pass 1: each node's parent
// from the tree's own node texels (any build's layout: an inner node's children
// are first_child and first_child + 1), and the arrival counters of the bounds
// pass zeroed. Every node but the root is the child of exactly one inner node,
// so every entry is written.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint node_count;
} push;

// pf_bih_gpu's node texels: clip0 bits, clip1 bits, word, 0 (pf_bih.h).
layout(std430, set = 0, binding = 0) readonly buffer Nodes { uvec4 nodes[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Arrivals { uint arrivals[]; };

const uint NO_PARENT = 0xFFFFFFFFu;
const uint LEAF = 3u; // PF_BIH_LEAF

void main()
{
    uint node = gl_GlobalInvocationID.x;
    if (node >= push.node_count)
        return;
    arrivals[node] = 0u;
    if (node == 0u)
        parents[0] = NO_PARENT;
    uint word = nodes[node].z;
    if ((word & 3u) != LEAF) {
        uint child = word >> 2u;
        parents[child] = node;
        parents[child + 1u] = node;
    }
}
