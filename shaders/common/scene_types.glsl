// std430 mirrors of the C structs uploaded by core/render (pf_scene.h:
// pf_material, pf_light; core/render/render_internal.h: pf_frame_params).
// A field added on one side must be added on the other.
#ifndef PF_SCENE_TYPES_GLSL
#define PF_SCENE_TYPES_GLSL

const uint MATERIAL_LAMBERT = 0u;
const uint MATERIAL_MIRROR = 1u;
const uint MATERIAL_GLASS = 2u;

const uint LIGHT_POINT = 0u;
const uint LIGHT_SPOT = 1u;
const uint LIGHT_DIRECTIONAL = 2u;

const uint NO_HIT = 0xFFFFFFFFu;

// pf_material, 32 bytes.
struct Material {
    vec3 albedo;
    uint kind;
    vec3 emission; // W/(sr·m²), front face only
    float ior;
};

// pf_light, 64 bytes.
struct Light {
    vec3 position;
    uint kind;
    vec3 direction; // the direction light travels
    float range;    // 0 = infinite
    vec3 intensity; // W/sr (point, spot), W/m² (directional)
    float cos_inner_cone;
    float cos_outer_cone;
    float padding0, padding1, padding2;
};

// One emissive triangle in the light-picking table (pf_emissive_entry).
struct EmissiveEntry {
    uint triangle;
    float cdf;        // cumulative pick probability up to and including this entry
    float pick_pdf;   // probability of picking this entry
    float area;
};

// pf_frame_params: what render_direct needs besides the scene arrays.
struct FrameParams {
    vec4 camera_position; // w: tan(yfov/2)·aspect (half width of the image plane at distance 1)
    vec4 camera_forward;  // w: tan(yfov/2)
    vec4 camera_right;    // w: ray offset along the geometric normal, scene-scaled
    vec4 camera_up;       // w: unused
    uint width, height, samples_per_pixel, triangle_count;
    uint light_count, emissive_count, seed_lo, seed_hi;
    uint max_specular_depth, bih_node_count, padding0, padding1;
    vec4 bih_bounds_min; // xyz: the BIH root box (trace_bih's bounds)
    vec4 bih_bounds_max;
};

#endif
