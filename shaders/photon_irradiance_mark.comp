#version 460
#extension GL_GOOGLE_include_directive : require
// Lists the irradiance points of a photon map, one invocation per photon:
// the photons photon_is_irradiance_point picks, appended to point_list for
// photon_irradiance_precompute.comp's estimates (which says why they are two
// modules). Bindings and Push as that kernel's, of which this one reads the
// map's records, the counts and the list.

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
    float radius;
} push;

layout(set = 0, binding = 0) uniform isamplerBuffer grid_records;
layout(set = 0, binding = 1) uniform isamplerBuffer grid_ranges; // photon_estimate.glsl's, unread
layout(set = 0, binding = 5) uniform usamplerBuffer grid_flux;    // photon_estimate.glsl's, unread
layout(std430, set = 0, binding = 3) buffer Counts {
    uint points;     // photons listed as points
    uint truncated;
} counts;
layout(std430, set = 0, binding = 4) buffer PointList { uint point_list[]; };

#include "photon_estimate.glsl" // photon_texel_record, photon_is_irradiance_point

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.photons)
        return;
    vec3 position = uintBitsToFloat(photon_texel_record(grid_records, i).xyz);
    // Past the capacity a point is counted, not listed: the host sees the count above it
    // and lists again with room for every photon (which the coin makes all but impossible).
    if (photon_is_irradiance_point(position)) {
        uint slot = atomicAdd(counts.points, 1u);
        if (slot < push.capacity)
            point_list[slot] = i;
    }
}
