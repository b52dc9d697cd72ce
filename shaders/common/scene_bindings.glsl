// The scene every integrator kernel (render_direct, render_reference,
// render_final, render_fast) reads, at the bindings scene_binding_numbers.glsl
// names (core/render/scene_upload.c's buffers, bound by pf_gpu_scene_bindings).
#ifndef PF_SCENE_BINDINGS_GLSL
#define PF_SCENE_BINDINGS_GLSL

#include "scene_binding_numbers.glsl"
#include "scene_types.glsl"

layout(std430, set = 0, binding = PF_SCENE_BINDING_PARAMS) readonly buffer Params { FrameParams params; };
#include "scene_geometry.glsl" // the surfaces: triangles, materials, textures
layout(std430, set = 0, binding = PF_SCENE_BINDING_LIGHTS) readonly buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_EMISSIVE) readonly buffer Emissive { EmissiveEntry emissive[]; };

#endif
