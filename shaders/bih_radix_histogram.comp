#version 460
// GPU BIH build, radix sort pass A: each workgroup counts the 8-bit digits
// (key >> shift) of its 256 keys and writes its counts digit-major,
// histogram[digit * group_count + group], so that one exclusive scan of the
// whole array (prefix_sum.comp) gives every (digit, group) its first output slot.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;
    uint shift;
    uint group_count;
} push;

layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Histogram { uint histogram[]; };

shared uint bins[256];

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint i = gl_GlobalInvocationID.x;
    bins[lid] = 0u;
    barrier();
    if (i < push.count)
        atomicAdd(bins[(keys[i] >> push.shift) & 255u], 1u);
    barrier();
    histogram[lid * push.group_count + gl_WorkGroupID.x] = bins[lid];
}
