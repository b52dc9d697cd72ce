#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The reference wavefront's path vertex (reference_wave.glsl says the whole):
// WAVE_SHADE, a vertex of each active path a dispatch.

#include "reference_wave.glsl"

void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uint invocation = gl_GlobalInvocationID.x;
    if (invocation >= push.count)
        return;
    uint p = texelFetch(active_paths, int(push.first_active + invocation)).x;
    uvec2 pixel = pixel_of(p);
    wave_shadow_base = p * direct_light_slots();
    bool waits = path_resume(p, pixel);
    bool more = waits && path_vertex(traced_hit(p));
    if (cut_at_loop_cap()) {
        more = false;
        wave_shadow_count = 0u;
    }
    if (more)
        rays[p] = Ray(vec4(path_origin, 0.0), vec4(path_direction, infinity));
    path_store(p);
    queue[p] = (more ? 1u : 0u) | wave_shadow_count << 1u |
               (more || wave_shadow_count > 0u ? 0u : QUEUE_PENDING);
}
