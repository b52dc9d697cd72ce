// The camera ray of a pixel's sample (the one home of reference's, final's
// and fast's): the pixel filter's offset (pixel_filter.glsl) and the pinhole's
// direction (camera.glsl) from the sample's first 4D draw, the sampler left
// after it. The ray starts at params.camera_position. The including kernel
// includes scene_bindings.glsl (params) first.
#ifndef PF_CAMERA_SAMPLE_GLSL
#define PF_CAMERA_SAMPLE_GLSL

#include "camera.glsl"
#include "sampler.glsl"

// pixel: the film's (a band's film starts params.row_offset rows down the image).
vec3 camera_sample_ray(uvec2 pixel, uint sample_index, out Sampler samples)
{
    samples = sampler_init(image_pixel_index(pixel.y * params.width + pixel.x), sample_index,
                           params.seed_lo, params.seed_hi);
    vec4 camera_xi = sampler_next_4d(samples);
    vec2 image_position = vec2(pixel.x, pixel.y + params.row_offset) + 0.5 +
                          filter_sample(params.pixel_filter, camera_xi.xy);
    return camera_ray_direction(params.camera_forward.xyz, params.camera_right.xyz,
                                params.camera_up.xyz, params.camera_position.w,
                                params.camera_forward.w, image_position,
                                vec2(params.width, params.image_height));
}

#endif
