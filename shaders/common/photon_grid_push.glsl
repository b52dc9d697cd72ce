// Push constants of the photon grid passes (C mirror photon_grid_push in
// core/photon/photon_grid.c, 48 bytes).
#ifndef PF_PHOTON_GRID_PUSH_GLSL
#define PF_PHOTON_GRID_PUSH_GLSL

#include "photon_grid.glsl"

layout(push_constant) uniform Push {
    vec3 origin;
    float inv_cell;
    uvec3 dims;
    uint hashed;
    uint table_size;
    uint count;     // photons (build passes) or queries (gather)
    uint capacity;  // gather: indices kept per query
    uint mode;      // photon_grid_finish.comp: which pass
} push;

PhotonGrid photon_grid_from_push()
{
    return PhotonGrid(push.origin, push.inv_cell, push.dims, push.hashed, push.table_size);
}

#endif
