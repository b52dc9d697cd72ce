// The scene's triangles and materials (core/render/scene_upload.c's buffers
// at bindings 1..4), read through uniform texel buffers: llvmpipe loads a
// storage-buffer word lane by lane in a branchy loop, a texel fetch is one
// vector gather (bench/RESULTS.md, "The storage-buffer loads"), and a hit's
// surface reads 27 words at addresses that differ from lane to lane. core/vk
// views each buffer by the declared type (spirv_bindings.c).
//   binding 1  scene_vertices           3 RGBA32F texels per triangle (xyz, w unused)
//   binding 2  scene_normals            3 RGBA32F texels per triangle (shading normals)
//   binding 3  scene_triangle_materials one word per triangle: its material
//   binding 4  scene_materials          5 texels per material (pf_material, 80 bytes)
#ifndef PF_SCENE_GEOMETRY_GLSL
#define PF_SCENE_GEOMETRY_GLSL

#include "scene_types.glsl"

layout(set = 0, binding = 1) uniform samplerBuffer scene_vertices;
layout(set = 0, binding = 2) uniform samplerBuffer scene_normals;
layout(set = 0, binding = 3) uniform usamplerBuffer scene_triangle_materials;
// Signed RGBA32 texels, read as bits: a material's uint kind stays an integer
// (as a float texel it would be a subnormal, which a device may flush).
layout(set = 0, binding = 4) uniform isamplerBuffer scene_materials;

// Vertex (or shading normal) k of 3 of triangle t is element 3t + k.
vec3 scene_vertex(uint element)
{
    return texelFetch(scene_vertices, int(element)).xyz;
}

vec3 scene_normal(uint element)
{
    return texelFetch(scene_normals, int(element)).xyz;
}

uint scene_triangle_material(uint triangle)
{
    return texelFetch(scene_triangle_materials, int(triangle)).x;
}

Material scene_material(uint index)
{
    int first = int(5u * index);
    uvec4 t0 = uvec4(texelFetch(scene_materials, first));
    uvec4 t1 = uvec4(texelFetch(scene_materials, first + 1));
    vec4 t2 = uintBitsToFloat(uvec4(texelFetch(scene_materials, first + 2)));
    uvec4 t3 = uvec4(texelFetch(scene_materials, first + 3));
    vec4 t4 = uintBitsToFloat(uvec4(texelFetch(scene_materials, first + 4)));
    return Material(uintBitsToFloat(t0.xyz), t0.w, uintBitsToFloat(t1.xyz),
                    uintBitsToFloat(t1.w), t2.x, t2.y, t2.z, t2.w, uintBitsToFloat(t3.xyz), t3.w,
                    t4.xyz, t4.w);
}

#endif
