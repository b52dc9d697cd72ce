#version 460
#extension GL_GOOGLE_include_directive : require
// Photon grid build, after the sort (one pass per dispatch, chosen by
// push.mode, each separated by a barrier):
//   MODE_CLEAR    every cell's range = [0, 0) (empty);
//   MODE_RANGES   where the sorted key changes, the cell's start and end
//                 (records without a photon, key table_size, get none);
//   MODE_REORDER  photons copied into key order, so a cell's photons are
//                 contiguous for the gather, and split: a 16-byte record
//                 (x, y, z, directions: what an estimate tests, one texel
//                 fetch) and the flux apart (photon_estimate.glsl).

layout(local_size_x = 256) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

const uint MODE_CLEAR = 0u;
const uint MODE_RANGES = 1u;
const uint MODE_REORDER = 2u;

layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Values { uint values[]; };
layout(std430, set = 0, binding = 2) readonly buffer Photons { uint photon_words[]; };
layout(std430, set = 0, binding = 3) writeonly buffer SortedRecords { uvec4 sorted_records[]; };
layout(std430, set = 0, binding = 4) buffer Ranges { uvec2 ranges[]; };
layout(std430, set = 0, binding = 5) writeonly buffer SortedFlux { uint sorted_flux[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (push.mode == MODE_CLEAR) {
        if (i < push.table_size)
            ranges[i] = uvec2(0u);
        return;
    }
    if (i >= push.count)
        return;
    if (push.mode == MODE_RANGES) {
        uint key = keys[i];
        if (key >= push.table_size)
            return;
        if (i == 0u || keys[i - 1u] != key)
            ranges[key].x = i;
        if (i + 1u == push.count || keys[i + 1u] != key)
            ranges[key].y = i + 1u;
        return;
    }
    uint from = PHOTON_WORDS * values[i];
    sorted_records[i] = uvec4(photon_words[from], photon_words[from + 1u],
                              photon_words[from + 2u], photon_words[from + 4u]);
    sorted_flux[i] = photon_words[from + 3u];
}
