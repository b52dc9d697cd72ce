#version 460
#extension GL_GOOGLE_include_directive : require
// pf_photon_grid_gather: for each query (xyz, radius in w) the original
// indices of the photons within the radius, found through the grid exactly
// as a radiance estimate finds them (photon_grid.glsl). Tests compare the
// sets with a brute-force gather.

layout(local_size_x = 64) in;

#include "photon_grid_push.glsl"
#include "photon_types.glsl"

// Cell order, photon_grid_finish.comp's layout: x, y, z bits, directions.
layout(std430, set = 0, binding = 0) readonly buffer SortedRecords { uvec4 grid_records[]; };
layout(std430, set = 0, binding = 1) readonly buffer Original { uint original_index[]; };
layout(std430, set = 0, binding = 2) readonly buffer Ranges { uvec2 grid_ranges[]; };
layout(std430, set = 0, binding = 3) readonly buffer Queries { vec4 queries[]; };
layout(std430, set = 0, binding = 4) writeonly buffer Counts { uint counts[]; };
layout(std430, set = 0, binding = 5) writeonly buffer Indices { uint indices[]; };

void main()
{
    uint q = gl_GlobalInvocationID.x;
    if (q >= push.count)
        return;
    vec3 x = queries[q].xyz;
    float radius = queries[q].w;
    PhotonGrid grid = photon_grid_from_push();
    PhotonCellWalk walk = photon_cell_walk(x, radius, grid);
    precise float radius2 = radius * radius;
    uint found = 0u;
    uint key;
    bool fresh;
    while (photon_cell_walk_next(walk, grid, key, fresh)) {
        if (!fresh)
            continue;
        uvec2 range = grid_ranges[key];
        for (uint i = range.x; i < range.y; i++) {
            vec3 p = uintBitsToFloat(grid_records[i].xyz);
            precise vec3 d = p - x;
            precise float distance2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
            if (distance2 <= radius2) {
                if (found < push.capacity)
                    indices[q * push.capacity + found] = original_index[i];
                found++;
            }
        }
    }
    counts[q] = found;
}
