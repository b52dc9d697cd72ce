#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Photon tracing's waves, their first step (PHOTON_EMIT; photon_path.glsl says
// the whole): invocation i emits photon first_photon + i of a batch, its state
// and first ray into the wave buffers.

#include "photon_path.glsl"

void main()
{
    if (params.emitter_count == 0u)
        return;
    uint i = gl_GlobalInvocationID.x;
    if (i < push.photon_count)
        wave_store(i, photon_start(push.first_photon + i), params.max_depth > 0u);
    if (!loops_completed())
        atomicAdd(counters.loop_truncated, 1u);
}
