// The camera ray of a pixel's sample (the one home of reference's, final's
// and fast's): the pixel filter's offset (pixel_filter.glsl) and the camera's
// ray (camera.glsl) from the sample's first 4D draw, the sampler left after it. The
// including kernel includes scene_bindings.glsl (params) first.
#ifndef PF_CAMERA_SAMPLE_GLSL
#define PF_CAMERA_SAMPLE_GLSL

#include "camera.glsl"
#include "sampler.glsl"

// Whether the frame's camera is orthographic (FrameParams' camera_up.w).
bool camera_orthographic()
{
    return params.camera_up.w != 0.0;
}

// pixel: the film's (a band's film starts params.row_offset rows down the image).
CameraRay camera_sample_ray(uvec2 pixel, uint sample_index, out Sampler samples)
{
    samples = sampler_init(image_pixel_index(pixel.y * params.width + pixel.x), sample_index,
                           params.seed_lo, params.seed_hi);
    vec4 camera_xi = sampler_next_4d(samples);
    vec2 image_position = vec2(pixel.x, pixel.y + params.row_offset) + 0.5 +
                          filter_sample(params.pixel_filter, camera_xi.xy);
    return camera_ray(params.camera_position.xyz, params.camera_forward.xyz,
                      params.camera_right.xyz, params.camera_up.xyz, params.camera_position.w,
                      params.camera_forward.w, camera_orthographic(), image_position,
                      vec2(params.width, params.image_height));
}

#endif
