// The scene's bindings (set 0), by name: every kernel that reads the scene
// has them at these numbers and numbers its own bindings from
// PF_SCENE_BINDING_COUNT on, so a new scene buffer renumbers no kernel.
// core/scene/pf_scene.h's pf_scene_binding mirrors the numbers, and
// pf_gpu_scene_bindings (core/render/scene_upload.c) fills them on the host.
#ifndef PF_SCENE_BINDING_NUMBERS_GLSL
#define PF_SCENE_BINDING_NUMBERS_GLSL

#define PF_SCENE_BINDING_PARAMS 0             // the kernel's parameters
#define PF_SCENE_BINDING_VERTICES 1
#define PF_SCENE_BINDING_NORMALS 2
#define PF_SCENE_BINDING_TRIANGLE_MATERIALS 3
#define PF_SCENE_BINDING_MATERIALS 4
#define PF_SCENE_BINDING_LIGHTS 5
#define PF_SCENE_BINDING_EMISSIVE 6           // photon_trace: its emitters
#define PF_SCENE_BINDING_CORNERS 7            // texture coordinates, colours, tangents
#define PF_SCENE_BINDING_TEXTURES 8           // the texture table
#define PF_SCENE_BINDING_TEXELS 9             // every texture's mip chain
#define PF_SCENE_BINDING_COUNT 10

// What the frame's surfaces use, as specialisation constants (render_internal.h
// PF_SPEC_SCENE_*): a pipeline made for a scene without alpha-tested materials,
// or without textures and colours, has that code removed when it is compiled,
// so such a scene pays neither its compile time nor its run time. Both default
// to false: a pipeline made without them reads no corner buffer it was not given.
layout(constant_id = 1001) const bool SCENE_HAS_ALPHA = false;
layout(constant_id = 1002) const bool SCENE_HAS_CORNERS = false;
// Punctual lights (direct_light.glsl's loop over them), transmissive materials (the
// transmission lobes: scene_material reads transmission as 0 without) and emissive ones
// (the emitters' sampling and MIS: scene_material reads emission as 0 without): true unless
// the pipeline says the frame has none, so a pipeline made without the constants is complete.
layout(constant_id = 1003) const bool SCENE_HAS_LIGHTS = true;
layout(constant_id = 1004) const bool SCENE_HAS_TRANSMISSION = true;
layout(constant_id = 1005) const bool SCENE_HAS_EMITTERS = true;
// Specular materials (pf_material_kind MIRROR or GLASS, passed through by sampling): without
// them every material reads as MATERIAL_LAMBERT, and the kernels' specular chains (their
// in-kernel traversal after a mirror or glass) are compiled out.
layout(constant_id = 1006) const bool SCENE_HAS_SPECULAR = true;
// More than PF_DIRECT_LIGHTS_EVERY_MAX punctual lights: direct_light.glsl resamples a few
// instead of visiting each (true unless the pipeline says otherwise: the light count decides
// at run time as well).
layout(constant_id = 1008) const bool SCENE_HAS_MANY_LIGHTS = true;
// Clear-coated materials (KHR_materials_clearcoat): without them scene_material reads every
// coat as 0 and the coat's lobe is compiled out of materials.glsl.
layout(constant_id = 1009) const bool SCENE_HAS_CLEARCOAT = true;
// Sheen materials (KHR_materials_sheen): without them scene_material reads every sheen colour
// as 0 and the sheen's lobe is compiled out of materials.glsl.
layout(constant_id = 1010) const bool SCENE_HAS_SHEEN = true;

#endif
