#version 460
// bench/vk/sampler_bench: the reference sampler's 4D groups (sampler.glsl's
// sampler_next_4d, two a path vertex and one a camera ray), GROUPS an
// invocation, so the device's cost of one can be timed; each invocation
// writes its draws' bits folded into one word, which the bench sums so that
// two builds' samplers can be checked for the same numbers.
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;
const uint GROUPS = 16u;

layout(std430, set = 0, binding = 0) writeonly buffer Words { uint words[]; };

layout(push_constant) uniform Push {
    uint invocations;
    uint sample_index;
} push;

#include "sampler.glsl"

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.invocations)
        return;
    Sampler state = sampler_init(i, push.sample_index + i / 4096u, 0x1234u, 0x5678u);
    uint folded = 0u;
    for (uint g = 0u; g < GROUPS; g++) {
        uvec4 bits = floatBitsToUint(sampler_next_4d(state));
        folded = (folded * 0x01000193u) ^ bits.x ^ (bits.y << 7u) ^ (bits.z << 13u) ^
                 (bits.w << 19u);
    }
    words[i] = folded;
}
