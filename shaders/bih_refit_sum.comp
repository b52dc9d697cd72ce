#version 460
// BIH refit on the device (core/bih/bih_gpu_refit.c), pass 4: one workgroup
// adds bih_refit_sah.comp's per-group sums into the tree's SAH cost.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint partial_count;
} push;

layout(std430, set = 0, binding = 0) readonly buffer Partials { float partials[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Result { float sah_cost; };

shared float sums[256];

void main()
{
    uint lane = gl_LocalInvocationID.x;
    float sum = 0.0;
    for (uint i = lane; i < push.partial_count; i += 256u)
        sum += partials[i];
    sums[lane] = sum;
    barrier();
    for (uint half_size = 128u; half_size > 0u; half_size >>= 1u) {
        if (lane < half_size)
            sums[lane] += sums[lane + half_size];
        barrier();
    }
    if (lane == 0u)
        sah_cost = sums[0];
}
