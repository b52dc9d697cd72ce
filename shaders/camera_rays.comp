#version 460
#extension GL_GOOGLE_include_directive : require
// A band's camera rays for the host to trace (host_rays.glsl's WRITE_RAYS for
// final's primary, whose first segments they are): the ray of each pixel's
// sample push.sample_index, in slot camera_slot. Its own small module, not a
// specialisation of the primary's: llvmpipe compiles a pipeline's whole
// module before specialisation removes anything, ~0.5 s a pipeline of that
// large one in every process. The primary computes the same rays
// (camera_sample.glsl) when it shades the hits.
// Bindings: the scene's (params), then the queue.
layout(local_size_x = 8, local_size_y = 8) in;

layout(push_constant) uniform Push {
    uint sample_index;
    uint row_first; // the band's first row
} push;

#include "scene_bindings.glsl"
#define HOST_RAYS_BINDING PF_SCENE_BINDING_COUNT
#include "host_rays.glsl"
#include "camera_sample.glsl"

void main()
{
    uvec2 pixel = band_pixel();
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    Sampler samples;
    CameraRay ray = camera_sample_ray(pixel, push.sample_index, samples);
    host_ray_write(camera_slot(pixel.y * params.width + pixel.x), true, ray.origin,
                   ray.direction);
}
