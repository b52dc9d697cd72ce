// The scene every integrator kernel (render_direct, render_reference,
// render_final, render_fast) reads, at the same bindings 0..6 in all of them
// (core/render/scene_upload.c's buffers, bound first in that order).
#ifndef PF_SCENE_BINDINGS_GLSL
#define PF_SCENE_BINDINGS_GLSL

#include "scene_types.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Params { FrameParams params; };
#include "scene_geometry.glsl" // bindings 1..4
layout(std430, set = 0, binding = 5) readonly buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = 6) readonly buffer Emissive { EmissiveEntry emissive[]; };

#endif
