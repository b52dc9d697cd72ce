// The scene's textures and per-corner attributes, and the one place a
// surface's material meets them (scene_material_at): baseColor × COLOR_0 ×
// baseColorTexture, metallicRoughness's G (roughness) and B (metallic),
// emissiveTexture, and the alpha that MASK and BLEND test after the traversal
// (bih_traverse.glsl trace_bih_surfaces).
//
// Textures are texel buffers, not sampled images: one R32_UINT view serves
// every texture of the scene, whatever its size, format and sampler. Measured
// on lavapipe (bench/textures, bench/RESULTS.md): an image array indexed per
// lane needs descriptor indexing that lavapipe 22.3 lacks; one layered image
// sampled by the sampler is 1.3-1.5x faster a sample than the filtering here,
// but holds textures of one size only, and the textures' whole share of the
// textured room's `shade` is ~15 %. Filtering is done here: bilinear within
// the level a ray cone picks (ray cones, Akenine-Möller et al. 2019), nearest
// where the sampler asks, wrap modes as glTF's samplers define them.
//
// The including file declares scene_triangle_materials and scene_materials
// (scene_geometry.glsl) first.
#ifndef PF_SCENE_TEXTURES_GLSL
#define PF_SCENE_TEXTURES_GLSL

#include "scene_binding_numbers.glsl"
#include "scene_types.glsl"

layout(set = 0, binding = PF_SCENE_BINDING_CORNERS) uniform samplerBuffer scene_corners;
layout(set = 0, binding = PF_SCENE_BINDING_TEXTURES) uniform isamplerBuffer scene_textures;
layout(set = 0, binding = PF_SCENE_BINDING_TEXELS) uniform usamplerBuffer scene_texels;

const uint CORNER_TEXELS = 3u; // PF_CORNER_TEXELS

// The frame has per-corner attributes (a texture or COLOR_0 somewhere), as the pipeline was
// specialised (pf_scene.h PF_SURFACE_CORNERS); else scene_corners is a placeholder. A
// constant, not the buffer's textureSize: a texel view may cover more than the bytes uploaded.
bool scene_has_corners()
{
    return SCENE_HAS_CORNERS;
}

TextureRef scene_texture(uint slot)
{
    int first = 3 * int(slot - 1u);
    uvec4 t0 = uvec4(texelFetch(scene_textures, first));
    vec4 t1 = intBitsToFloat(texelFetch(scene_textures, first + 1));
    vec4 t2 = intBitsToFloat(texelFetch(scene_textures, first + 2));
    return TextureRef(t0.x, t0.y, t0.z, t0.w, t1.xyz, vec3(t1.w, t2.xy));
}

float srgb_to_linear(float c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

// A texel coordinate on one axis of n texels, wrapped by the sampler's mode. In float:
// llvmpipe runs an integer division or modulo lane by lane, a float floor as one
// vector instruction (coordinates stay below 2^24, where both are exact).
int texture_wrap(int x, int n, uint mode)
{
    if (mode == TEXTURE_WRAP_CLAMP)
        return clamp(x, 0, n - 1);
    float fx = float(x), fn = float(n);
    if (mode == TEXTURE_WRAP_MIRROR) {
        float period = 2.0 * fn;
        int m = int(fx - period * floor(fx / period));
        return m < n ? m : 2 * n - 1 - m;
    }
    return clamp(int(fx - fn * floor(fx / fn)), 0, n - 1);
}

// Texel xy of a level that starts at first and is w texels wide, in linear light.
vec4 texture_texel(TextureRef ref, uint first, ivec2 size, ivec2 xy)
{
    int x = texture_wrap(xy.x, size.x, (ref.sampling >> TEXTURE_WRAP_S_SHIFT) & 3u);
    int y = texture_wrap(xy.y, size.y, (ref.sampling >> TEXTURE_WRAP_T_SHIFT) & 3u);
    vec4 c = unpackUnorm4x8(texelFetch(scene_texels, int(first) + y * size.x + x).x);
    if ((ref.sampling & TEXTURE_SRGB) != 0u)
        c.rgb = vec3(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b));
    return c;
}

// The mip level for a footprint of lod (log2 texels of level 0 per footprint); the
// nearest level, bounded by the chain.
uint texture_level(TextureRef ref, float lod)
{
    uint last = ref.sampling & TEXTURE_LEVELS_MASK;
    if ((ref.sampling & TEXTURE_NO_MIPS) != 0u || !(lod > 0.5))
        return 0u;
    return min(uint(lod + 0.5), last);
}

bool all_finite_vec2(vec2 v)
{
    return !any(isnan(v)) && !any(isinf(v));
}

// The texture at uv (before KHR_texture_transform), linear RGBA; lod as texture_level's.
vec4 texture_sample(TextureRef ref, vec2 uv, float lod)
{
    vec2 st = vec2(dot(ref.transform_u, vec3(uv, 1.0)), dot(ref.transform_v, vec3(uv, 1.0)));
    uint level = texture_level(ref, lod);
    uint first = ref.first_texel;
    ivec2 size = ivec2(ref.width, ref.height);
    for (uint k = 0u; k < level; k++) {
        first += uint(size.x * size.y);
        size = max(size / 2, ivec2(1));
    }
    bool nearest = lod > 0.0 ? (ref.sampling & TEXTURE_MIN_NEAREST) != 0u
                             : (ref.sampling & TEXTURE_MAG_NEAREST) != 0u;
    // Non-finite coordinates (a broken UV) read texel 0 rather than an undefined index;
    // huge ones are bounded so their int stays exact (wrapping is per texel).
    vec2 p = all_finite_vec2(st) ? st * vec2(size) : vec2(0.0);
    p = clamp(p, vec2(-1.0e6), vec2(1.0e6));
    if (nearest)
        return texture_texel(ref, first, size, ivec2(floor(p)));
    p -= 0.5;
    ivec2 i = ivec2(floor(p));
    vec2 f = p - floor(p);
    vec4 a = mix(texture_texel(ref, first, size, i), texture_texel(ref, first, size, i + ivec2(1, 0)),
                 f.x);
    vec4 b = mix(texture_texel(ref, first, size, i + ivec2(0, 1)),
                 texture_texel(ref, first, size, i + ivec2(1, 1)), f.x);
    return mix(a, b, f.y);
}

// Texel k (0 uvs, 1 colour, 2 tangent) of the corners of triangle, interpolated.
vec4 scene_corner(uint triangle, uint k, float u, float v)
{
    int first = int(3u * CORNER_TEXELS * triangle + k);
    return (1.0 - u - v) * texelFetch(scene_corners, first) +
           u * texelFetch(scene_corners, first + int(CORNER_TEXELS)) +
           v * texelFetch(scene_corners, first + int(2u * CORNER_TEXELS));
}

// What every slot of one hit shares: both UV sets at the hit and, for the ray cone's mip
// level, log2 of the UV area over the world area of the triangle per set (Akenine-Möller
// et al. 2019, eq. 34, before the texture's own texel count) plus log2 of the cone's width
// over |cos| of the arrival; level 0 when the cone is 0.
struct SurfaceUv {
    vec4 uvs;          // (TEXCOORD_0, TEXCOORD_1) at the hit
    vec2 lod_base;     // per set; -1e30: no cone (the finest level)
};

SurfaceUv scene_surface_uv(uint triangle, float u, float v, float cone_width, float cos_arrival,
                           vec3 p0, vec3 p1, vec3 p2)
{
    int first = int(3u * CORNER_TEXELS * triangle);
    vec4 a = texelFetch(scene_corners, first);
    vec4 b = texelFetch(scene_corners, first + int(CORNER_TEXELS));
    vec4 c = texelFetch(scene_corners, first + int(2u * CORNER_TEXELS));
    SurfaceUv s;
    s.uvs = (1.0 - u - v) * a + u * b + v * c;
    s.lod_base = vec2(-1.0e30);
    if (cone_width > 0.0) {
        vec4 e1 = b - a, e2 = c - a;
        vec2 uv_area = abs(vec2(e1.x * e2.y - e1.y * e2.x, e1.z * e2.w - e1.w * e2.z));
        float world_area = max(length(cross(p1 - p0, p2 - p0)), 1e-30);
        s.lod_base = 0.5 * log2(max(uv_area, vec2(1e-30)) / world_area) +
                     log2(cone_width / max(cos_arrival, 1e-4));
    }
    return s;
}

// One slot's value at the hit.
vec4 scene_slot_sample(uint slot, SurfaceUv surface_uv)
{
    TextureRef ref = scene_texture(slot);
    bool set1 = (ref.sampling & TEXTURE_TEXCOORD_1) != 0u;
    float lod = (set1 ? surface_uv.lod_base.y : surface_uv.lod_base.x) +
                0.5 * log2(float(ref.width) * float(ref.height));
    return texture_sample(ref, set1 ? surface_uv.uvs.zw : surface_uv.uvs.xy, lod);
}

// scene_material_textured's textures and COLOR_0.
Material scene_material_sampled(Material m, uint triangle, float u, float v, float cone_width,
                                float cos_arrival, vec3 p0, vec3 p1, vec3 p2)
{
    if (!scene_has_corners())
        return m;
    vec4 color = scene_corner(triangle, 1u, u, v);
    m.albedo *= color.rgb;
    m.alpha *= color.a;
    bool coat_textured = SCENE_HAS_CLEARCOAT && (m.clearcoat_texture != NO_TEXTURE ||
                                                 m.clearcoat_roughness_texture != NO_TEXTURE);
    bool sheen_textured = SCENE_HAS_SHEEN && (m.sheen_color_texture != NO_TEXTURE ||
                                              m.sheen_roughness_texture != NO_TEXTURE);
    if (m.base_color_texture == NO_TEXTURE && m.metallic_roughness_texture == NO_TEXTURE &&
        m.emissive_texture == NO_TEXTURE && !coat_textured && !sheen_textured &&
        m.specular_texture == NO_TEXTURE && m.specular_color_texture == NO_TEXTURE)
        return m;
    SurfaceUv surface_uv =
        scene_surface_uv(triangle, u, v, cone_width, cos_arrival, p0, p1, p2);
    if (m.base_color_texture != NO_TEXTURE) {
        vec4 t = scene_slot_sample(m.base_color_texture, surface_uv);
        m.albedo *= t.rgb;
        m.alpha *= t.a;
    }
    if (m.metallic_roughness_texture != NO_TEXTURE) {
        vec4 t = scene_slot_sample(m.metallic_roughness_texture, surface_uv);
        m.roughness *= t.g;
        m.metallic *= t.b;
        m.kind = SCENE_HAS_SPECULAR ? material_kind_of(m) : MATERIAL_LAMBERT;
    }
    if (m.emissive_texture != NO_TEXTURE)
        m.emission *= scene_slot_sample(m.emissive_texture, surface_uv).rgb;
    if (m.specular_texture != NO_TEXTURE)
        m.specular *= scene_slot_sample(m.specular_texture, surface_uv).a;
    if (m.specular_color_texture != NO_TEXTURE)
        m.specular_color *= scene_slot_sample(m.specular_color_texture, surface_uv).rgb;
    if (coat_textured && m.clearcoat_texture != NO_TEXTURE)
        m.clearcoat *= scene_slot_sample(m.clearcoat_texture, surface_uv).r;
    if (coat_textured && m.clearcoat_roughness_texture != NO_TEXTURE)
        m.clearcoat_roughness *= scene_slot_sample(m.clearcoat_roughness_texture, surface_uv).g;
    if (sheen_textured && m.sheen_color_texture != NO_TEXTURE)
        m.sheen_color *= scene_slot_sample(m.sheen_color_texture, surface_uv).rgb;
    if (sheen_textured && m.sheen_roughness_texture != NO_TEXTURE)
        m.sheen_roughness *= scene_slot_sample(m.sheen_roughness_texture, surface_uv).a;
    return m;
}

// The material of triangle at barycentrics (u, v) with its textures and COLOR_0 applied. An
// unlit one (KHR_materials_unlit) emits its base colour there and reflects nothing: only a
// camera ray reaches it (scene_alpha_passes), and the camera sees the colour as it is, from
// either face, as Cycles renders Blender's import of it (an emission shader, two-sided).
Material scene_material_textured(Material m, uint triangle, float u, float v, float cone_width,
                                 float cos_arrival, vec3 p0, vec3 p1, vec3 p2)
{
    m = scene_material_sampled(m, triangle, u, v, cone_width, cos_arrival, p0, p1, p2);
    if ((m.flags & MATERIAL_UNLIT) != 0u) {
        m.emission = m.albedo;
        m.albedo = vec3(0.0);
        m.flags |= MATERIAL_DOUBLE_SIDED;
    }
    return m;
}

// The shading normal n (unit, the mesh's, front side) tilted by the material's normal map
// (tangent space: T from the corners' tangents, B = cross(n, T)·w, scaled in x and y by
// normalTexture.scale as the spec asks); n itself without a map or a tangent.
vec3 scene_normal_mapped(Material m, uint triangle, float u, float v, vec3 n, float cone_width,
                         float cos_arrival, vec3 p0, vec3 p1, vec3 p2)
{
    if (m.normal_texture == NO_TEXTURE || !scene_has_corners())
        return n;
    vec4 tangent = scene_corner(triangle, 2u, u, v);
    vec3 t = tangent.xyz - n * dot(n, tangent.xyz);
    if (!(dot(t, t) > 1e-12))
        return n;
    t = normalize(t);
    vec3 b = cross(n, t) * (tangent.w < 0.0 ? -1.0 : 1.0);
    vec3 texel = scene_slot_sample(m.normal_texture, scene_surface_uv(triangle, u, v, cone_width,
                                                                      cos_arrival, p0, p1, p2))
                     .xyz;
    vec3 local = (2.0 * texel - 1.0) * vec3(m.normal_scale, m.normal_scale, 1.0);
    vec3 mapped = local.x * t + local.y * b + local.z * n;
    return dot(mapped, mapped) > 1e-12 ? normalize(mapped) : n;
}

#endif
