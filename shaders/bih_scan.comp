#version 460
// GPU BIH build: exclusive prefix sum of data[0..count) in place, in one
// workgroup (a separate dispatch, so no workgroup ever waits on another);
// data[count] receives the total. Each invocation sums a contiguous chunk,
// invocation 0 scans the 256 chunk sums, then each chunk is rewritten.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;
} push;

layout(std430, set = 0, binding = 0) buffer Data { uint data[]; };

shared uint sums[256];

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint chunk = (push.count + 255u) / 256u;
    uint begin = min(lid * chunk, push.count);
    uint end = min(begin + chunk, push.count);
    uint sum = 0u;
    for (uint i = begin; i < end; i++)
        sum += data[i];
    sums[lid] = sum;
    barrier();
    if (lid == 0u) {
        uint running = 0u;
        for (uint g = 0u; g < 256u; g++) {
            uint value = sums[g];
            sums[g] = running;
            running += value;
        }
        data[push.count] = running;
    }
    barrier();
    uint running = sums[lid];
    for (uint i = begin; i < end; i++) {
        uint value = data[i];
        data[i] = running;
        running += value;
    }
}
