#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The reference wavefront's first and last dispatches of a pass
// (reference_wave.glsl says the whole): WAVE_GENERATE starts every path of a
// slice with its camera ray; WAVE_FINISH(_RGB) adds each path's last shadow
// rays' light and its sample to the film.

#include "reference_wave.glsl"

void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uint p = gl_GlobalInvocationID.x;
    if (p >= push.count)
        return;
    uint pixel_index = push.first_pixel + p;
    uvec2 pixel = pixel_of(p);
    wave_shadow_base = p * direct_light_slots();
    bool more = false;
    if (WAVE_MODE == WAVE_GENERATE) {
        path_begin(pixel, push.sample_index);
        more = true;
    } else {
        path_resume(p, pixel);
    }
    if (cut_at_loop_cap())
        more = false;
    if (FINISHING) {
        path_finish(pixel_index, push.sample_index); // the next pass's generate rewrites queue[p]
    } else {
        if (more)
            rays[p] = Ray(vec4(path_origin, 0.0), vec4(path_direction, infinity));
        path_store(p);
        queue[p] = more ? 1u : QUEUE_PENDING;
    }
}
