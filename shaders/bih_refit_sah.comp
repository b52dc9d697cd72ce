#version 460
// BIH fit on the device (core/bih/bih_gpu_refit.c), pass 3: the tree's SAH cost
// as pf_bih_quality_measure defines it (core/bih/bih_check.c), for the
// renderer's keep-or-rebuild decision without the tree's readback, and the
// statistics pf_bih carries (depth, leaves, largest leaf) from the same walks. Each
// node's term is the area of its box cut by its ancestors' clip planes over the
// root's, times its triangles for a leaf, 1 for an inner node; the clip box is
// made walking up (min and max commute, so the order of the planes does not
// matter). Sums in float, per workgroup here and over the groups in
// bih_refit_sum.comp: the host's measure sums in double, so the two agree to
// float rounding, not bit for bit.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint node_bound; // invocations (the node count is stats.w)
} push;

struct Box {
    vec4 lo;
    vec4 hi;
};

layout(std430, set = 0, binding = 0) readonly buffer Nodes { uvec4 nodes[]; };
layout(std430, set = 0, binding = 1) readonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 2) readonly buffer Boxes { Box boxes[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Partials { float partials[]; };
// x: the deepest leaf's inner levels (MOST_LEVELS + 1: deeper than any build may
// make), y: leaves, z: the largest leaf's triangles (bih_refit_link zeroes them);
// w: the node count.
layout(std430, set = 0, binding = 4) buffer Stats { uvec4 stats; };

const uint NO_PARENT = 0xFFFFFFFFu;
const uint LEAF = 3u;           // PF_BIH_LEAF
const uint MOST_LEVELS = 64u;   // PF_BIH_STACK_SIZE

shared float sums[256];

// box_area in bih_check.c: 0 for a box empty along any axis.
float area(vec3 lo, vec3 hi)
{
    vec3 e = hi - lo;
    if (!(e.x >= 0.0 && e.y >= 0.0 && e.z >= 0.0))
        return 0.0;
    return 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
}

float term(uint node)
{
    Box root = boxes[0];
    vec3 clip_lo = root.lo.xyz, clip_hi = root.hi.xyz;
    uint child = node, depth = 0u;
    for (; depth <= MOST_LEVELS; depth++) {
        uint parent = parents[child];
        if (parent == NO_PARENT)
            break;
        uvec4 texel = nodes[parent];
        uint axis = texel.z & 3u;
        if (child == texel.z >> 2u)
            clip_hi[axis] = min(clip_hi[axis], uintBitsToFloat(texel.x));
        else
            clip_lo[axis] = max(clip_lo[axis], uintBitsToFloat(texel.y));
        child = parent;
    }
    Box box = boxes[node];
    float root_area = area(root.lo.xyz, root.hi.xyz);
    float probability = root_area > 0.0
                            ? area(max(box.lo.xyz, clip_lo), min(box.hi.xyz, clip_hi)) / root_area
                            : 1.0;
    uvec4 texel = nodes[node];
    if ((texel.z & 3u) != LEAF)
        return probability;
    atomicMax(stats.x, depth);
    atomicAdd(stats.y, 1u);
    atomicMax(stats.z, texel.y);
    return probability * float(texel.y);
}

void main()
{
    uint node = gl_GlobalInvocationID.x, lane = gl_LocalInvocationID.x;
    sums[lane] = node < stats.w ? term(node) : 0.0;
    barrier();
    for (uint half_size = 128u; half_size > 0u; half_size >>= 1u) {
        if (lane < half_size)
            sums[lane] += sums[lane + half_size];
        barrier();
    }
    if (lane == 0u)
        partials[gl_WorkGroupID.x] = sums[0];
}
