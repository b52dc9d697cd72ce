#version 460
#extension GL_GOOGLE_include_directive : require
// Photon grid build: exclusive prefix sum of the per-key photon counts, in
// blocks of SCAN_BLOCK entries so that no invocation loops long (llvmpipe's
// 65,535-iteration cap) however large the table:
//   MODE_REDUCE   workgroup g sums its block into block_sums[g];
//   (bih_scan.comp then scans block_sums in one workgroup)
//   MODE_SCAN     workgroup g rewrites its block as the exclusive prefix
//                 sum, starting from block_sums[g].
// push.count is the number of entries (table_size + 2: the cells, the
// records without a photon, and the total, which the scan leaves last).

layout(local_size_x = 256) in;

#include "photon_grid_push.glsl"

const uint MODE_REDUCE = 0u;
const uint MODE_SCAN = 1u;
// Entries per invocation, and per workgroup (256 invocations).
const uint SCAN_RUN = 16u;
const uint SCAN_BLOCK = 256u * SCAN_RUN;

layout(std430, set = 0, binding = 0) buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 1) buffer BlockSums { uint block_sums[]; };

shared uint run_sums[256];

void main()
{
    uint lid = gl_LocalInvocationID.x;
    uint begin = gl_WorkGroupID.x * SCAN_BLOCK + lid * SCAN_RUN;
    uint end = min(begin + SCAN_RUN, push.count);
    uint sum = 0u;
    for (uint i = begin; i < end; i++)
        sum += counts[i];
    run_sums[lid] = sum;
    barrier();
    if (lid == 0u) {
        uint running = push.mode == MODE_SCAN ? block_sums[gl_WorkGroupID.x] : 0u;
        for (uint r = 0u; r < 256u; r++) {
            uint value = run_sums[r];
            run_sums[r] = running;
            running += value;
        }
        if (push.mode == MODE_REDUCE)
            block_sums[gl_WorkGroupID.x] = running;
    }
    barrier();
    if (push.mode != MODE_SCAN)
        return;
    uint running = run_sums[lid];
    for (uint i = begin; i < end; i++) {
        uint value = counts[i];
        counts[i] = running;
        running += value;
    }
}
