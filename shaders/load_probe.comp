#version 460
// bench/vk/load_bench: dependent reads of 3 words per step (a BIH node's
// worth) through a storage buffer or through a uniform texel buffer of the
// same words, so the two read paths of a device can be timed against each
// other (llvmpipe 22.x: a lane-by-lane loop against a vector gather).
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;
// 0: storage buffer, 1: R32 uint texels, 2: RGBA32 texels.
layout(constant_id = 0) const uint READ_PATH = 0u;

layout(std430, set = 0, binding = 0) readonly buffer Words { uint words[]; };
layout(set = 0, binding = 1) uniform usamplerBuffer texel_words;
layout(std430, set = 0, binding = 2) writeonly buffer Sums { uint sums[]; };
layout(set = 0, binding = 3) uniform isamplerBuffer texel_nodes; // 16-byte records (RGBA32_SINT)

layout(push_constant) uniform Push {
    uint nodes; // 4 words each: next, two payload words, padding
    uint steps;
} push;

uint word_at(uint index)
{
    return READ_PATH == 1u ? texelFetch(texel_words, int(index)).x : words[index];
}

void main()
{
    uint node = gl_GlobalInvocationID.x % push.nodes;
    uint sum = 0u;
    for (uint i = 0u; i < push.steps; i++) {
        uvec3 node_words;
        if (READ_PATH == 2u)
            node_words = uvec3(texelFetch(texel_nodes, int(node)).xyz);
        else
            node_words = uvec3(word_at(4u * node), word_at(4u * node + 1u), word_at(4u * node + 2u));
        sum += node_words.y ^ node_words.z;
        node = node_words.x;
    }
    sums[gl_GlobalInvocationID.x] = sum;
}
