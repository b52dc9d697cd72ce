#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Photon tracing's waves, a bounce (PHOTON_BOUNCE; photon_path.glsl says the
// whole): invocation i takes photon active[i], whose ray the host traced and
// hit a surface: one bounce (store, scatter, roulette), then its next ray, or
// its end (queue 0).

#include "photon_path.glsl"

void main()
{
    if (params.emitter_count == 0u)
        return;
    uint i = gl_GlobalInvocationID.x;
    if (i < push.photon_count) {
        uint slot = texelFetch(wave_active, int(i)).x;
        int at = int(4u * slot);
        BihHit hit = BihHit(uintBitsToFloat(texelFetch(wave_hits, at).x),
                            texelFetch(wave_hits, at + 1).x,
                            uintBitsToFloat(texelFetch(wave_hits, at + 2).x),
                            uintBitsToFloat(texelFetch(wave_hits, at + 3).x));
        PhotonPath p = wave_load(slot);
        // On past alpha-tested triangles whose hits do not count (the host has no
        // textures), as the flat loop's trace_bih_surfaces goes.
        bool failed;
        hit = trace_bih_surfaces_after(hit, p.origin, p.direction, 0.0,
                                       uintBitsToFloat(0x7f800000u), false, false,
                                       params.bih_bounds_min.xyz, params.bih_bounds_max.xyz,
                                       params.triangle_count, params.bih_node_count, failed);
        if (failed)
            atomicAdd(counters.traversal_failures, 1u);
        bool alive = !failed && photon_bounce(p, hit);
        wave_store(slot, p, alive);
    }
    if (!loops_completed())
        atomicAdd(counters.loop_truncated, 1u);
}
