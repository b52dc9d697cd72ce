#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` shade stage's deferred estimates (the header of
// render_final.comp describes a sample's dispatches): the estimates the
// gather deferred, one per invocation (invocation index = pixel index; the
// host sizes the request buffer at most one per pixel). final_resolve.comp
// then adds them to their pixels. Push block and buffers: final_shared.glsl.

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"
#include "final_shared.glsl"
#include "materials.glsl"
#include "kernel_guard.glsl"

// A deferred estimate (invocation `request`).
void fallback(uint request)
{
    if (request >= min(counters.fallback_requests, push.fallback_capacity))
        return;
    uint base = 3u * request;
    bool truncated = false;
    vec3 irradiance = global_irradiance_estimate(texel_vec4(fallback_request_texels, base).xyz,
                                                 texel_vec4(fallback_request_texels, base + 1u).xyz,
                                                 truncated);
    bool completed = loops_completed() && !truncated;
    if (!completed)
        atomicAdd(counters.loop_truncated, 1u);
    vec3 weight = texel_vec4(fallback_request_texels, base + 2u).xyz;
    fallback_requests[base + 2u] = vec4(weight * irradiance, completed ? 0.0 : 1.0);
}

void main()
{
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    fallback(pixel.y * params.width + pixel.x);
}
