#version 460
#extension GL_GOOGLE_include_directive : require
// GPU BIH build, pass 2: the radix tree of Karras 2012 ("Maximizing
// Parallelism in the Construction of BVHs, Octrees, and k-d Trees"), one
// invocation per inner node i over the sorted codes. Keys compare as
// (code, sorted position), so equal codes still give a binary tree. The split
// axis is the axis of the highest bit in which the node's first and last codes
// differ (x, y, z interleaved from the top, as bih_morton.comp writes them).
// Also clears the node's arrival counter for bih_clip.comp.

#include "bih_build.glsl"

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;   // sorted triangles n (>= 2): inner nodes 0..n-2
} push;

layout(std430, set = 0, binding = 0) readonly buffer Codes { uint codes[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Inner { BihInner inner[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Parents { uint parents[]; };
layout(std430, set = 0, binding = 3) writeonly buffer Arrivals { uint arrivals[]; };

// Common prefix length of keys i and j, -1 when j is outside the array.
int delta(int i, int j)
{
    if (j < 0 || j >= int(push.count))
        return -1;
    uint a = codes[i], b = codes[j];
    if (a != b)
        return 31 - findMSB(a ^ b);
    return 32 + 31 - findMSB(uint(i ^ j));
}

void main()
{
    uint node = gl_GlobalInvocationID.x;
    if (node + 1u >= push.count)
        return;
    int i = int(node);
    int d = delta(i, i + 1) - delta(i, i - 1) >= 0 ? 1 : -1;
    int delta_min = delta(i, i - d);
    int length_max = 2;
    while (delta(i, i + length_max * d) > delta_min)
        length_max *= 2;
    int length = 0;
    for (int t = length_max / 2; t >= 1; t /= 2)
        if (delta(i, i + (length + t) * d) > delta_min)
            length += t;
    int j = i + length * d;
    int delta_node = delta(i, j);
    int split = 0;
    int step = length;
    do {
        step = (step + 1) >> 1;
        if (delta(i, i + (split + step) * d) > delta_node)
            split += step;
    } while (step > 1);
    int gamma = i + split * d + min(d, 0);
    uint first = uint(min(i, j)), last = uint(max(i, j));
    uint leaf_base = push.count - 1u;
    uint left = first == uint(gamma) ? leaf_base + uint(gamma) : uint(gamma);
    uint right = last == uint(gamma) + 1u ? leaf_base + uint(gamma) + 1u : uint(gamma) + 1u;
    uint differ = codes[first] ^ codes[last];
    uint axis = BIH_BUILD_AXIS_UNDECIDED;
    if (differ != 0u)
        axis = 2u - uint(findMSB(differ)) % 3u;
    inner[node] = BihInner(left, right, first, axis);
    parents[left] = node;
    parents[right] = node;
    if (node == 0u)
        parents[0] = BIH_BUILD_NO_PARENT;
    arrivals[node] = 0u;
}
