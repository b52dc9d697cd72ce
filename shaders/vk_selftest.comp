#version 460
// core/vk's own test shader (tests/vk): exercises a specialization constant
// (workgroup size and multiplier), push constants and two storage buffers.
// values_out[i] = values_in[i] * MULTIPLIER + addend + workgroup index, so a
// wrong workgroup size, spec constant or push constant all change the result.

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint MULTIPLIER = 1u;

layout(push_constant) uniform Push {
    uint count;
    uint addend;
} push;

layout(std430, set = 0, binding = 0) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, set = 0, binding = 1) writeonly buffer ValuesOut { uint values_out[]; };

void main()
{
    uint index = gl_GlobalInvocationID.x;
    if (index >= push.count)
        return;
    values_out[index] = values_in[index] * MULTIPLIER + push.addend + gl_WorkGroupID.x;
}
