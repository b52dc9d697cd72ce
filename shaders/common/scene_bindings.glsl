// The scene every integrator kernel (render_direct, render_reference,
// render_final, render_fast) reads, at the bindings scene_binding_numbers.glsl
// names (core/render/scene_upload.c's buffers, bound by pf_gpu_scene_bindings).
#ifndef PF_SCENE_BINDINGS_GLSL
#define PF_SCENE_BINDINGS_GLSL

#include "scene_binding_numbers.glsl"
#include "scene_types.glsl"

layout(std430, set = 0, binding = PF_SCENE_BINDING_PARAMS) readonly buffer Params { FrameParams params; };

// A film pixel's index in the whole image, which seeds its samples: a band's film starts
// params.row_offset rows down the image, and renders the rows the whole image would.
uint image_pixel_index(uint film_pixel_index)
{
    return film_pixel_index + params.row_offset * params.width;
}
#include "scene_geometry.glsl" // the surfaces: triangles, materials, textures
layout(std430, set = 0, binding = PF_SCENE_BINDING_LIGHTS) readonly buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_EMISSIVE) readonly buffer Emissive { EmissiveEntry emissive[]; };

#endif
