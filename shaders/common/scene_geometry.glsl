// The scene's triangles, materials and textures (core/render/scene_upload.c's
// buffers at the bindings scene_binding_numbers.glsl names), read through uniform texel buffers: llvmpipe loads a
// storage-buffer word lane by lane in a branchy loop, a texel fetch is one
// vector gather (bench/RESULTS.md, "The storage-buffer loads"), and a hit's
// surface reads 27 words at addresses that differ from lane to lane. core/vk
// views each buffer by the declared type (spirv_bindings.c).
//   scene_vertices           3 RGBA32F texels per triangle (xyz, w unused)
//   scene_normals            3 RGBA32F texels per triangle (shading normals)
//   scene_triangle_materials one word per triangle: its material
//   scene_materials          the sheen's albedo tables (SHEEN_ALBEDO_TEXELS), then 11 texels
//                            per material (pf_material, 176 bytes)
//   scene_corners            PF_CORNER_TEXELS texels per triangle corner (uv0, uv1;
//                            colour; tangent), when the scene has textures or colours
//   scene_textures           3 texels per TextureRef
//   scene_texels             RGBA8 words: every texture's mip chain
#ifndef PF_SCENE_GEOMETRY_GLSL
#define PF_SCENE_GEOMETRY_GLSL

#include "scene_binding_numbers.glsl"
#include "scene_types.glsl"

layout(set = 0, binding = PF_SCENE_BINDING_VERTICES) uniform samplerBuffer scene_vertices;
layout(set = 0, binding = PF_SCENE_BINDING_NORMALS) uniform samplerBuffer scene_normals;
layout(set = 0, binding = PF_SCENE_BINDING_TRIANGLE_MATERIALS) uniform usamplerBuffer scene_triangle_materials;
// Signed RGBA32 texels, read as bits: a material's uint kind stays an integer
// (as a float texel it would be a subnormal, which a device may flush).
layout(set = 0, binding = PF_SCENE_BINDING_MATERIALS) uniform isamplerBuffer scene_materials;

// Vertex (or shading normal) k of 3 of triangle t is element 3t + k.
vec3 scene_vertex(uint element)
{
    return texelFetch(scene_vertices, int(element)).xyz;
}

vec3 scene_normal(uint element)
{
    return texelFetch(scene_normals, int(element)).xyz;
}

// A triangle's material word: the index, and TRIANGLE_ALPHA_TESTED where its material's
// alphaMode is MASK or BLEND or it is unlit (scene_upload.c), so the traversal tests alpha
// only there.
const uint TRIANGLE_ALPHA_TESTED = 0x80000000u;

uint scene_triangle_material(uint triangle)
{
    return texelFetch(scene_triangle_materials, int(triangle)).x & ~TRIANGLE_ALPHA_TESTED;
}

// The materials buffer's first texels: KHR_materials_sheen's two 32 × 32 tables
// (core/scene/pf_scene.h pf_sheen_albedo, pf_materials_buffer_write).
const int SHEEN_ALBEDO_TEXELS = 512;

// Entry at of the sheen's albedo table (materials.glsl sheen_albedo).
float sheen_albedo_entry(int at)
{
    return intBitsToFloat(texelFetch(scene_materials, at >> 2)[at & 3]);
}

Material scene_material(uint index)
{
    int first = SHEEN_ALBEDO_TEXELS + int(11u * index);
    uvec4 t0 = uvec4(texelFetch(scene_materials, first));
    uvec4 t1 = uvec4(texelFetch(scene_materials, first + 1));
    vec4 t2 = uintBitsToFloat(uvec4(texelFetch(scene_materials, first + 2)));
    uvec4 t3 = uvec4(texelFetch(scene_materials, first + 3));
    vec4 t4 = uintBitsToFloat(uvec4(texelFetch(scene_materials, first + 4)));
    uvec4 t5 = uvec4(texelFetch(scene_materials, first + 5));
    uvec4 t6 = uvec4(texelFetch(scene_materials, first + 6));
    uvec4 t7 = uvec4(texelFetch(scene_materials, first + 7));
    uvec4 t8 = uvec4(texelFetch(scene_materials, first + 8));
    uvec4 t9 = uvec4(texelFetch(scene_materials, first + 9));
    vec4 t10 = SCENE_HAS_SHEEN ? uintBitsToFloat(uvec4(texelFetch(scene_materials, first + 10)))
                               : vec4(0.0);
    // transmission, emission, the coat and the sheen: 0 in a frame without a transmissive,
    // an emissive, a coated or a sheen material, the kind Lambert in one without a specular
    // material, so that their code is compiled out (SCENE_HAS_TRANSMISSION,
    // SCENE_HAS_EMITTERS, SCENE_HAS_CLEARCOAT, SCENE_HAS_SHEEN, SCENE_HAS_SPECULAR).
    return Material(uintBitsToFloat(t0.xyz), SCENE_HAS_SPECULAR ? t0.w : MATERIAL_LAMBERT,
                    SCENE_HAS_EMITTERS ? uintBitsToFloat(t1.xyz) : vec3(0.0),
                    uintBitsToFloat(t1.w), t2.x, t2.y, SCENE_HAS_TRANSMISSION ? t2.z : 0.0, t2.w,
                    uintBitsToFloat(t3.xyz), t3.w,
                    t4.xyz, t4.w, t5.x, t5.y, t5.z, t5.w, t6.x, uintBitsToFloat(t6.y),
                    uintBitsToFloat(t6.z),
                    SCENE_HAS_CLEARCOAT ? uintBitsToFloat(t6.w) : 0.0, uintBitsToFloat(t7.x),
                    SCENE_HAS_CLEARCOAT ? t7.y : NO_TEXTURE, t7.z, t7.w, t8.x, 0.0, 0.0, 0.0,
                    SCENE_HAS_CLEARCOAT ? t9.x : NO_TEXTURE, uintBitsToFloat(t9.y),
                    SCENE_HAS_SHEEN ? t9.z : NO_TEXTURE, SCENE_HAS_SHEEN ? t9.w : NO_TEXTURE,
                    t10.xyz, t10.w);
}

#ifdef PF_SURFACE_TEXTURES
// The kernels' "_surfaces" variant (pf_scene.h PF_SURFACE_*): textures, COLOR_0, normal
// maps and alpha tests. The plain variant, for frames without them, has none of this code.
#include "rng.glsl"            // pcg_hash
#include "scene_textures.glsl" // the textures and corners; scene_material_textured

// The material of triangle at barycentrics (u, v) with its textures at the finest level: what
// surface_at gave the kernel that recorded the hit (final's deferred passes).
Material scene_material_at(uint triangle, float u, float v)
{
    return scene_material_textured(scene_material(scene_triangle_material(triangle)), triangle,
                                   u, v, 0.0, 1.0, vec3(0.0), vec3(0.0), vec3(0.0));
}

// Whether a ray's hit on triangle at barycentrics (u, v) counts (bih_traverse.glsl asks for
// each hit closer than the best so far): always, but for alphaMode MASK where the alpha
// (baseColorFactor × COLOR_0 × baseColorTexture, level 0) is below alphaCutoff, and BLEND,
// where it counts with probability alpha: stochastic transparency, decided by a hash of
// the ray and the triangle, so camera, shadow, photon and gather rays all see the same
// coverage on average (a masked leaf casts a leaf-shaped shadow). An unlit surface's hit
// counts for camera rays only (camera: the ray leaves the camera), as Blender's importer
// has Cycles render KHR_materials_unlit: other rays pass it (pf_scene.h PF_MATERIAL_UNLIT).
bool scene_alpha_passes(uint triangle, float u, float v, vec3 origin, vec3 direction,
                        bool camera)
{
    uint word = texelFetch(scene_triangle_materials, int(triangle)).x;
    if ((word & TRIANGLE_ALPHA_TESTED) == 0u)
        return true;
    Material m = scene_material(word & ~TRIANGLE_ALPHA_TESTED);
    if ((m.flags & MATERIAL_UNLIT) != 0u && !camera)
        return false;
    if (m.alpha_mode == ALPHA_OPAQUE)
        return true;
    float alpha = m.alpha;
    if (scene_has_corners()) {
        alpha *= scene_corner(triangle, 1u, u, v).a;
        if (m.base_color_texture != NO_TEXTURE)
            alpha *= scene_slot_sample(m.base_color_texture,
                                       scene_surface_uv(triangle, u, v, 0.0, 1.0, vec3(0.0),
                                                        vec3(0.0), vec3(0.0)))
                         .a;
    }
    if (m.alpha_mode == ALPHA_MASK)
        return alpha >= m.alpha_cutoff;
    uvec3 o = floatBitsToUint(origin), d = floatBitsToUint(direction);
    uint h = pcg_hash(triangle ^ pcg_hash(o.x ^ pcg_hash(o.y ^ pcg_hash(o.z ^ pcg_hash(
                 d.x ^ pcg_hash(d.y ^ pcg_hash(d.z ^ floatBitsToUint(u))))))));
    return float(h >> 8) * (1.0 / 16777216.0) < alpha;
}

// KHR_materials_clearcoat's normal where a normal map tilts the base's or the coat's: the
// mesh's at (u, v) of triangle, as the spec's coat keeps it under a base normal map, tilted by
// the coat's own clearcoatNormalTexture where it has one (its finest level), on
// geometric_normal's side, in m's coat_normal; left 0 elsewhere, where the coat follows the
// shading normal (the mesh's itself without a map).
Material scene_coat_normal(Material m, uint triangle, float u, float v, vec3 geometric_normal)
{
    if (!SCENE_HAS_CLEARCOAT || !(m.clearcoat > 0.0) || !scene_has_corners() ||
        (m.normal_texture == NO_TEXTURE && m.clearcoat_normal_texture == NO_TEXTURE))
        return m;
    uint first = 3u * triangle;
    vec3 n = (1.0 - u - v) * scene_normal(first) + u * scene_normal(first + 1u) +
             v * scene_normal(first + 2u);
    n = dot(n, n) > 0.0 ? normalize(n) : geometric_normal;
    if (m.clearcoat_normal_texture != NO_TEXTURE) {
        Material coat_map = m;
        coat_map.normal_texture = m.clearcoat_normal_texture;
        coat_map.normal_scale = m.clearcoat_normal_scale;
        n = scene_normal_mapped(coat_map, triangle, u, v, n, 0.0, 1.0, vec3(0.0), vec3(0.0),
                                vec3(0.0));
    }
    n = dot(n, geometric_normal) < 0.0 ? -n : n;
    m.coat_normal_x = n.x;
    m.coat_normal_y = n.y;
    m.coat_normal_z = n.z;
    return m;
}
#else
// The plain variant: the materials' factors, the mesh's normals, every hit counts.
Material scene_material_textured(Material m, uint triangle, float u, float v, float cone_width,
                                 float cos_arrival, vec3 p0, vec3 p1, vec3 p2)
{
    return m;
}

vec3 scene_normal_mapped(Material m, uint triangle, float u, float v, vec3 n, float cone_width,
                         float cos_arrival, vec3 p0, vec3 p1, vec3 p2)
{
    return n;
}

Material scene_material_at(uint triangle, float u, float v)
{
    return scene_material(scene_triangle_material(triangle));
}

Material scene_coat_normal(Material m, uint triangle, float u, float v, vec3 geometric_normal)
{
    return m;
}
#endif

// A uniform point on the triangle (a, b, c) from xi in [0,1)² (pbrt-v4 SampleUniformTriangle,
// square-root form), with its barycentrics of b and c (a texture's lookup there): area
// lights' samples and photons' origins.
vec3 triangle_uniform_point(vec3 a, vec3 b, vec3 c, vec2 xi, out vec2 barycentrics)
{
    float root = sqrt(xi.x);
    barycentrics = vec2(root * (1.0 - xi.y), root * xi.y);
    return (1.0 - root) * a + barycentrics.x * b + barycentrics.y * c;
}

#endif
