#version 460
#extension GL_GOOGLE_include_directive : require
// Photon grid build around the counting sort (photon_grid_keys.comp counts,
// prefix_sum.comp turns the counts into each key's first slot), one
// pass per dispatch, chosen by push.mode, each separated by a barrier:
//   MODE_CLEAR    every cell's range = [0, 0) (empty) and every count 0;
//   MODE_SCATTER  each photon to slot start[key] + rank, so a cell's photons
//                 are contiguous for the gather, and split: a 16-byte record
//                 (x, y, z, directions: what an estimate tests, one texel
//                 fetch) and the flux apart (photon_estimate.glsl); the
//                 cell's first photon (rank 0) writes its range. Records
//                 without a photon (key table_size) get none.

layout(local_size_x = 256) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

const uint MODE_CLEAR = 0u;
const uint MODE_SCATTER = 1u;

layout(std430, set = 0, binding = 0) readonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 1) readonly buffer Ranks { uint ranks[]; };
layout(std430, set = 0, binding = 2) readonly buffer Photons { uint photon_words[]; };
layout(std430, set = 0, binding = 3) writeonly buffer SortedRecords { uvec4 sorted_records[]; };
layout(std430, set = 0, binding = 4) buffer Ranges { uvec2 ranges[]; };
layout(std430, set = 0, binding = 5) writeonly buffer SortedFlux { uint sorted_flux[]; };
layout(std430, set = 0, binding = 6) buffer Starts { uint starts[]; }; // table_size + 2
layout(std430, set = 0, binding = 7) writeonly buffer Original { uint original[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (push.mode == MODE_CLEAR) {
        if (i < push.table_size)
            ranges[i] = uvec2(0u);
        if (i < push.table_size + 2u)
            starts[i] = 0u;
        return;
    }
    if (i >= push.count)
        return;
    uint key = keys[i];
    uint rank = ranks[i];
    uint slot = starts[key] + rank;
    uint from = PHOTON_WORDS * i;
    sorted_records[slot] = uvec4(photon_words[from], photon_words[from + 1u],
                                 photon_words[from + 2u], photon_words[from + 4u]);
    sorted_flux[slot] = photon_words[from + 3u];
    original[slot] = i;
    if (rank == 0u && key < push.table_size)
        ranges[key] = uvec2(starts[key], starts[key + 1u]);
}
