#version 460
#extension GL_GOOGLE_include_directive : require
// Photon grid build, pass 1 of the counting sort: each photon's cell key,
// and its rank among its cell's photons (the count of its key before it,
// an atomic: the order within a cell is whichever the invocations took,
// which no estimate depends on beyond float rounding). A record without a
// photon (photon_record_present) gets key push.table_size, past every cell:
// it is placed behind them all and photon_grid_finish.comp gives it no range.

layout(local_size_x = 256) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Photons { uint photon_words[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 2) writeonly buffer Ranks { uint ranks[]; };
layout(std430, set = 0, binding = 3) buffer Counts { uint counts[]; }; // table_size + 2, zeroed

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.count)
        return;
    uint base = PHOTON_WORDS * i;
    vec3 position = vec3(uintBitsToFloat(photon_words[base]), uintBitsToFloat(photon_words[base + 1u]),
                         uintBitsToFloat(photon_words[base + 2u]));
    PhotonGrid grid = photon_grid_from_push();
    uint key = photon_record_present(photon_words[base + 4u])
                   ? photon_grid_key(photon_grid_cell(position, grid), grid)
                   : push.table_size;
    keys[i] = key;
    ranks[i] = atomicAdd(counts[key], 1u);
}
