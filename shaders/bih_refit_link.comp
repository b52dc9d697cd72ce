#version 460
// BIH fit on the device (core/bih/bih_gpu_refit.c: a refit, or the statistics of
// a tree just built), pass 1: each node's parent from the tree's own node texels
// (any build's layout: an inner node's children are first_child and first_child +
// 1), and the arrival counters of the bounds pass and the statistics of the SAH
// pass zeroed. Every node but the root is the child of exactly one inner node, so
// every entry is written.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint node_bound;  // invocations: the nodes, or a bound on them (2n - 1 after a build)
    uint kept_index;  // NO_KEPT: node_bound nodes; else 1 + 2 * kept[kept_index] (a build's
                      // count of kept inner nodes, bih_collapse.comp's ranks)
} push;

// pf_bih_gpu's node texels: clip0 bits, clip1 bits, word, 0 (pf_bih.h).
layout(std430, set = 0, binding = 0) readonly buffer Nodes { uvec4 nodes[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Arrivals { uint arrivals[]; };
// x, y, z: bih_refit_sah.comp's statistics, zeroed here; w: the node count, which the
// later passes read.
layout(std430, set = 0, binding = 3) writeonly buffer Stats { uvec4 stats; };
layout(std430, set = 0, binding = 4) readonly buffer Kept { uint kept[]; };

const uint NO_PARENT = 0xFFFFFFFFu;
const uint NO_KEPT = 0xFFFFFFFFu;
const uint LEAF = 3u; // PF_BIH_LEAF

void main()
{
    uint node = gl_GlobalInvocationID.x;
    uint node_count = push.kept_index == NO_KEPT ? push.node_bound
                                                 : min(1u + 2u * kept[push.kept_index], push.node_bound);
    if (node >= node_count)
        return;
    arrivals[node] = 0u;
    if (node == 0u) {
        parents[0] = NO_PARENT;
        stats = uvec4(0u, 0u, 0u, node_count);
    }
    uint word = nodes[node].z;
    if ((word & 3u) != LEAF) {
        uint child = word >> 2u;
        parents[child] = node;
        parents[child + 1u] = node;
    }
}
