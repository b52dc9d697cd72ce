#version 460
// GPU BIH build, radix sort pass C: stable scatter. A key's slot is its
// (digit, group) base from the scanned histogram plus the number of keys
// before it in its workgroup with the same digit — so equal digits keep their
// input order and the sort stays stable across passes.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;
    uint shift;
    uint group_count;
} push;

layout(std430, set = 0, binding = 0) readonly buffer KeysIn { uint keys_in[]; };
layout(std430, set = 0, binding = 1) readonly buffer ValuesIn { uint values_in[]; };
layout(std430, set = 0, binding = 2) writeonly buffer KeysOut { uint keys_out[]; };
layout(std430, set = 0, binding = 3) writeonly buffer ValuesOut { uint values_out[]; };
layout(std430, set = 0, binding = 4) readonly buffer Histogram { uint histogram[]; };

// 256 marks a slot past the end: it matches no digit.
const uint NO_DIGIT = 256u;
shared uint digits[256];

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint i = gl_GlobalInvocationID.x;
    uint key = i < push.count ? keys_in[i] : 0u;
    uint digit = (key >> push.shift) & 255u;
    digits[lid] = i < push.count ? digit : NO_DIGIT;
    barrier();
    if (i >= push.count)
        return;
    uint rank = 0u;
    for (uint j = 0u; j < lid; j++)
        rank += digits[j] == digit ? 1u : 0u;
    uint slot = histogram[digit * push.group_count + gl_WorkGroupID.x] + rank;
    keys_out[slot] = key;
    values_out[slot] = values_in[i];
}
