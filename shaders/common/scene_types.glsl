// std430 mirrors of the C structs uploaded by core/render (pf_scene.h:
// pf_material, pf_light; core/render/render_internal.h: pf_frame_params).
// A field added on one side must be added on the other.
#ifndef PF_SCENE_TYPES_GLSL
#define PF_SCENE_TYPES_GLSL

const uint MATERIAL_LAMBERT = 0u;
const uint MATERIAL_MIRROR = 1u; // smooth or sharp glossy metal (pf_scene.h)
const uint MATERIAL_GLASS = 2u;

// pf_material.flags (pf_scene.h): MATERIAL_DOUBLE_SIDED emits from both faces;
// MATERIAL_UNLIT (KHR_materials_unlit) is seen by camera rays only, as its base colour.
const uint MATERIAL_DOUBLE_SIDED = 1u;
const uint MATERIAL_UNLIT = 2u;

const uint LIGHT_POINT = 0u;
const uint LIGHT_SPOT = 1u;
const uint LIGHT_DIRECTIONAL = 2u;

const uint NO_HIT = 0xFFFFFFFFu;

// pf_material, 176 bytes (pf_scene.h: the glTF metallic-roughness parameters).
struct Material {
    vec3 albedo;          // glTF baseColor: diffuse colour, metal F0, transmission tint
    uint kind;            // pf_material_kind: a summary of the parameters below
    vec3 emission;        // W/(sr·m²), front face (both: MATERIAL_DOUBLE_SIDED)
    float ior;
    float metallic;
    float roughness;      // perceptual; GGX alpha = roughness²
    float transmission;
    float specular;       // KHR_materials_specular factor (0: diffuse base only)
    vec3 specular_color;  // KHR_materials_specular colour
    uint flags;           // MATERIAL_DOUBLE_SIDED, MATERIAL_UNLIT
    vec3 absorption;      // KHR_materials_volume: Beer-Lambert coefficient inside, 1/m
    float alpha;          // baseColorFactor's alpha (MASK, BLEND)
    // Texture slots: 1 + the TextureRef's index, 0 (NO_TEXTURE) if none. surface_at has
    // applied them: a Material a kernel shades with holds the values at the hit.
    uint base_color_texture;
    uint metallic_roughness_texture;
    uint normal_texture;
    uint emissive_texture;
    uint alpha_mode;      // ALPHA_OPAQUE, ALPHA_MASK, ALPHA_BLEND
    float alpha_cutoff;
    float normal_scale;
    float clearcoat;      // KHR_materials_clearcoat: the coat's strength (0: none)
    float clearcoat_roughness; // perceptual
    uint clearcoat_texture;    // R scales clearcoat
    uint clearcoat_roughness_texture; // G scales clearcoat_roughness
    uint specular_texture;       // KHR_materials_specular: A scales specular
    uint specular_color_texture; // RGB (sRGB) scales specular_color
    // The coat's normal at this hit where a normal map tilts the shading normal or the coat's
    // (scene_coat_normal: the mesh's, or its own map's); 0: the coat follows the shading normal.
    float coat_normal_x, coat_normal_y, coat_normal_z;
    uint clearcoat_normal_texture; // the coat's own normal map (tangent space)
    float clearcoat_normal_scale;
    uint sheen_color_texture;      // KHR_materials_sheen: RGB (sRGB) scales sheen_color
    uint sheen_roughness_texture;  // A scales sheen_roughness
    vec3 sheen_color;              // the fibres' colour (0: no sheen)
    float sheen_roughness;
};

// pf_scene.h PF_MATERIAL_DELTA_ROUGHNESS: at or below it the specular lobe is a mirror.
const float DELTA_ROUGHNESS = 0.02;
// pf_scene.h PF_MATERIAL_GLOSSY_ROUGHNESS: below it a glossy lobe is too sharp for an
// estimate (photon map, LPV, light sampling alone): traced, with MIS.
const float GLOSSY_ROUGHNESS = 0.5;

// pf_material_classify (core/scene/material.c), for a material its textures changed.
uint material_kind_of(Material m)
{
    bool rough_lobe = m.roughness >= GLOSSY_ROUGHNESS;
    bool has_diffuse = m.metallic < 1.0 && m.transmission < 1.0;
    if (has_diffuse || (rough_lobe && m.metallic > 0.0))
        return MATERIAL_LAMBERT;
    return m.metallic >= 1.0 ? MATERIAL_MIRROR : MATERIAL_GLASS;
}

const uint NO_TEXTURE = 0u;
const uint ALPHA_OPAQUE = 0u;
const uint ALPHA_MASK = 1u;
const uint ALPHA_BLEND = 2u;

// pf_texture_ref, 48 bytes: an image's mip chain in scene_texels and how a slot samples it.
struct TextureRef {
    uint first_texel;
    uint width, height;
    uint sampling;        // TEXTURE_* bits (pf_scene.h PF_TEXTURE_*)
    vec3 transform_u;     // u' = dot(transform_u, (u, v, 1))
    vec3 transform_v;
};

const uint TEXTURE_LEVELS_MASK = 0x1Fu;
const uint TEXTURE_WRAP_S_SHIFT = 5u;
const uint TEXTURE_WRAP_T_SHIFT = 7u;
const uint TEXTURE_WRAP_REPEAT = 0u;
const uint TEXTURE_WRAP_CLAMP = 1u;
const uint TEXTURE_WRAP_MIRROR = 2u;
const uint TEXTURE_MAG_NEAREST = 1u << 9;
const uint TEXTURE_MIN_NEAREST = 1u << 10;
const uint TEXTURE_NO_MIPS = 1u << 11;
const uint TEXTURE_SRGB = 1u << 12;
const uint TEXTURE_TEXCOORD_1 = 1u << 13;

// pf_light, 64 bytes.
struct Light {
    vec3 position;
    uint kind;
    vec3 direction; // the direction light travels
    float range;    // 0 = infinite
    vec3 intensity; // W/sr (point, spot), W/m² (directional)
    float cos_inner_cone;
    float cos_outer_cone;
    // The lights' alias table by power (pf_light.pick_*): column i keeps light i below
    // pick_threshold, else gives pick_alias; pick_pdf is light i's probability.
    float pick_threshold;
    uint pick_alias;
    float pick_pdf;
};

// One column of the emissive-triangle alias table (pf_emissive_entry, 32
// bytes; Vose 1991): a uniformly chosen column keeps its own triangle with
// probability alias_threshold, else gives its alias's.
struct EmissiveEntry {
    uint triangle;
    uint alias;            // column whose triangle is picked when the threshold test fails
    float alias_threshold;
    float pick_pdf;        // overall probability of picking this entry's triangle
    float area;
    uint padding0, padding1, padding2;
};

// pf_frame_params: what the integrators need besides the scene arrays (160 bytes).
struct FrameParams {
    vec4 camera_position; // w: tan(yfov/2)·aspect (half width of the image plane at distance 1)
    vec4 camera_forward;  // w: tan(yfov/2)
    vec4 camera_right;    // w: ray offset along the geometric normal, scene-scaled
    vec4 camera_up;       // w: 1 orthographic (the half extents are the view's, world units)
    uint width, height, samples_per_pixel, triangle_count;
    uint light_count, emissive_count, seed_lo, seed_hi;
    uint max_specular_depth, bih_node_count;
    uint pixel_filter;    // FILTER_* (sampler.glsl)
    uint max_bounces;     // reference: most bounces after the first surface (0xffffffff: none)
    vec4 bih_bounds_min; // xyz: the BIH root box (trace_bih's bounds)
    vec4 bih_bounds_max;
    // Appended for the reference integrator:
    float emissive_weight_total; // Σ area·luminance over the emissive table (light pick pdfs)
    uint max_path_depth;         // bound on the vertices of a path (reference)
    // The film's first row in the image, and the image's height (a band of a frame whose
    // film exceeds one buffer: render_bands.c; else 0 and height). The camera and the
    // samples' seeds are the image's (camera_sample.glsl), the film's pixels the band's.
    uint row_offset, image_height;
};

#endif
