#version 460
// Exclusive prefix sum of data[0..count) in place, the total left at data[count]: the one
// scan of every GPU counting step (the BIH build's radix passes and node ranks, the GPU
// radix sort, the photon grid's counting sort), recorded by pf_bih_prefix_sum_record as
// three dispatches over one buffer, whose words after data[count] hold one sum per block:
//   MODE_REDUCE      workgroup g sums its block of SCAN_BLOCK entries into
//                    data[count + 1 + g];
//   MODE_BLOCK_SUMS  one workgroup turns the block sums into their exclusive prefix sum;
//   MODE_SCAN        workgroup g rewrites its block as the exclusive prefix sum from its
//                    block's sum; the last block writes the total at data[count].
// There is always one block at least (count 0 leaves data[0] = 0).
// Blocks keep every workgroup's loop short (llvmpipe stops a loop at 65,535 iterations)
// and spread the work over the device: one workgroup scanning a 1M-entry histogram alone
// was most of an H200's 8.7 ms BIH build of 1M triangles.

layout(local_size_x = 256) in;

layout(push_constant) uniform Push {
    uint count;
    uint mode;
} push;

layout(std430, set = 0, binding = 0) buffer Data { uint data[]; };

const uint MODE_REDUCE = 0u;
const uint MODE_BLOCK_SUMS = 1u;
const uint MODE_SCAN = 2u;
// Entries per invocation, and per workgroup (256 invocations).
const uint SCAN_RUN = 16u;
const uint SCAN_BLOCK = 256u * SCAN_RUN;

shared uint run_sums[256];

// run_sums becomes its exclusive prefix sum from start; invocation 0 gets the total.
uint scan_run_sums(uint lid, uint start)
{
    barrier();
    uint total = 0u;
    if (lid == 0u) {
        uint running = start;
        for (uint r = 0u; r < 256u; r++) {
            uint value = run_sums[r];
            run_sums[r] = running;
            running += value;
        }
        total = running;
    }
    barrier();
    return total;
}

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint sums = push.count + 1u; // the block sums' first word
    uint blocks = max((push.count + SCAN_BLOCK - 1u) / SCAN_BLOCK, 1u); // one for count 0
    if (push.mode == MODE_BLOCK_SUMS) {
        // One workgroup: each invocation a contiguous chunk of the block sums.
        uint chunk = (blocks + 255u) / 256u;
        uint begin = min(lid * chunk, blocks), end = min(begin + chunk, blocks);
        uint sum = 0u;
        for (uint i = begin; i < end; i++)
            sum += data[sums + i];
        run_sums[lid] = sum;
        scan_run_sums(lid, 0u);
        uint running = run_sums[lid];
        for (uint i = begin; i < end; i++) {
            uint value = data[sums + i];
            data[sums + i] = running;
            running += value;
        }
        return;
    }
    uint group = gl_WorkGroupID.x;
    uint begin = min(group * SCAN_BLOCK + lid * SCAN_RUN, push.count);
    uint end = min(begin + SCAN_RUN, push.count);
    uint sum = 0u;
    for (uint i = begin; i < end; i++)
        sum += data[i];
    run_sums[lid] = sum;
    uint total = scan_run_sums(lid, push.mode == MODE_SCAN ? data[sums + group] : 0u);
    if (lid == 0u && push.mode == MODE_REDUCE)
        data[sums + group] = total;
    if (lid == 0u && push.mode == MODE_SCAN && group == blocks - 1u)
        data[push.count] = total;
    if (push.mode == MODE_REDUCE)
        return;
    uint running = run_sums[lid];
    for (uint i = begin; i < end; i++) {
        uint value = data[i];
        data[i] = running;
        running += value;
    }
}
