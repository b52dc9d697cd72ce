#version 460
#extension GL_GOOGLE_include_directive : require
// Precomputed irradiance points of a photon map (photon_estimate.glsl's
// photon_irradiance_lookup describes them; pf_photon_grid_build_irradiance
// in core/photon/photon_grid.c drives this). Record k of the output is the
// k-th point listed: a photon of the map made a point (its estimate from
// the other, non-point photons within the radius, at its position on its
// own surface), or, where that estimate stopped at the loop guard, a record
// without a photon (photon_types.glsl), which the grid build keeps out of
// every cell. The slots after the points hold records without a photon,
// which the points' grid sorts past every cell; its hash table is planned
// for the points alone (a quarter of the map's). Their order is the order of the list's atomic
// claims; nothing depends on it (the lookup breaks ties by position).

layout(local_size_x = 64) in;

#include "photon_types.glsl"
#include "photon_grid.glsl"

// C mirror: precompute_push in core/photon/photon_grid.c (48 bytes).
layout(push_constant) uniform Push {
    vec3 origin;
    float inv_cell;
    uvec3 dims;
    uint hashed;
    uint table_size;
    uint photons;  // photons in the map
    uint capacity; // slots of the point list and the output (core/photon/photon_grid.c)
    float radius;  // the estimate's radius (<= the map's build radius)
} push;

// After photon_irradiance_mark.comp listed the points, one invocation per
// slot of the output (push.capacity, a bound on the points the host sets
// without reading their count): the first ones, one per listed point, its
// record.
// Listing first keeps the SIMD lanes of the estimates full; with the coin
// tested in the estimate dispatch itself nearly every 8-lane group held a
// point and ran the whole loop. The listing is a module of its own: llvmpipe
// runs code that no lane enters all the same, so a listing dispatch in this
// module ran the estimate's code once for every 8 photons. A record's value
// depends on its photon alone, not on the order in which the points were
// listed.

// The map (photon_estimate.glsl: texel buffers).
layout(set = 0, binding = 0) uniform isamplerBuffer grid_records;
layout(set = 0, binding = 1) uniform isamplerBuffer grid_ranges;
layout(std430, set = 0, binding = 2) buffer Points { uint point_words[]; };
layout(std430, set = 0, binding = 3) buffer Counts {
    uint points;     // photons listed as points
    uint truncated;  // points dropped because their estimate stopped at the loop guard
} counts;
layout(std430, set = 0, binding = 4) buffer PointList { uint point_list[]; };
layout(set = 0, binding = 5) uniform usamplerBuffer grid_flux;

// One estimate per invocation and no other loop: most of llvmpipe's cap.
#define PHOTON_ESTIMATE_MAX_ITERATIONS 60000u
#include "photon_estimate.glsl"

// Record k: point_list[k]'s position and surface normal, and its estimate.
void estimate(uint k)
{
    uint i = point_list[k];
    uvec4 record = photon_texel_record(grid_records, i);
    Photon photon = grid_photon(i);
    PhotonGrid grid = PhotonGrid(push.origin, push.inv_cell, push.dims, push.hashed,
                                 push.table_size);
    bool stopped;
    // The non-points are (STRIDE - 1) / STRIDE of the photons: scaled back to all of them.
    vec3 sum = photon_irradiance_sum(photon.position, photon.normal, push.radius, grid, true,
                                     stopped) *
               (float(PHOTON_IRRADIANCE_STRIDE) / float(PHOTON_IRRADIANCE_STRIDE - 1u));
    uint directions = record.w;
    uint base = PHOTON_WORDS * k;
    point_words[base] = record.x;
    point_words[base + 1u] = record.y;
    point_words[base + 2u] = record.z;
    point_words[base + 3u] = rgb9e5_pack(sum);
    point_words[base + 4u] = stopped ? (directions & 0xFFFF0000u) | PHOTON_NO_RECORD : directions;
    if (stopped)
        atomicAdd(counts.truncated, 1u);
}

// Slot k past the listed points: a record without a photon, so that the points' grid can
// be built over every slot in the same submission without the host reading the count
// (core/photon/photon_grid.c's record_points; issue 44).
void empty_slot(uint k)
{
    uint base = PHOTON_WORDS * k;
    for (uint w = 0u; w < 4u; w++)
        point_words[base + w] = 0u;
    point_words[base + 4u] = PHOTON_NO_RECORD;
}

void main()
{
    uint k = gl_GlobalInvocationID.x;
    if (k < min(counts.points, push.capacity))
        estimate(k);
    else if (k < push.capacity)
        empty_slot(k);
}
