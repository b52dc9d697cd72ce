#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Photon tracing's flat loop (PHOTON_TRACED_HERE; photon_path.glsl says the
// whole): an invocation traces its photons in turn, every ray traced here.

#include "photon_path.glsl"

// PHOTON_TRACED_HERE: photons in turn, in one flat loop of bounces.
void trace_here()
{
    // The current photon; alive = false: start the next one.
    bool alive = false;
    uint next = gl_GlobalInvocationID.x; // within this dispatch
    PhotonPath p;
    p.direction = vec3(0.0, 0.0, 1.0);
    while (true) {
        if (!alive) {
            if (next >= push.photon_count)
                break;
            uint index = push.first_photon + next;
            next += push.photon_stride;
            p = photon_start(index);
            // On into its first bounce in this same step: a lane never idles a step to start.
            alive = params.max_depth > 0u;
            if (!alive)
                continue;
        }
        bool failed;
        BihHit hit = trace_bih_surfaces(p.origin, p.direction, 0.0, uintBitsToFloat(0x7f800000u),
                                        false, false, params.bih_bounds_min.xyz,
                                        params.bih_bounds_max.xyz, params.triangle_count,
                                        params.bih_node_count, failed);
        if (failed) {
            atomicAdd(counters.traversal_failures, 1u);
            alive = false;
            continue;
        }
        alive = photon_bounce(p, hit);
    }
}

void main()
{
    if (params.emitter_count == 0u)
        return;
    trace_here();
    if (!loops_completed())
        atomicAdd(counters.loop_truncated, 1u);
}
