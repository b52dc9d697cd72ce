#version 460
#extension GL_GOOGLE_include_directive : require
// Evaluates the shared material code (materials.glsl) for host-given inputs,
// one invocation per query, so tests can check it against tabulated values
// (pf_material_probe in core/render/render_internal.h).

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint query_count;
} push;

#include "materials.glsl"

// pf_material_probe_query, 240 bytes.
struct ProbeQuery {
    Material material;
    vec3 wo;          // unit, away from the surface
    uint front;       // bit 0: arriving at the front face; bit 1: importance transport (photons)
    vec3 normal;      // unit shading normal
    float fresnel_cos;
    vec3 xi;          // bsdf_sample's random numbers
    float fresnel_eta;
    vec3 geometric_normal; // unit, on wo's side
    float padding;
};

// pf_material_probe_result, 64 bytes.
struct ProbeResult {
    vec3 direction;
    float pdf;
    vec3 weight;
    uint flags;       // 1: specular, 2: transmitted
    vec3 eval_cos;    // bsdf_eval_cos at direction
    float eval_pdf;   // bsdf_pdf at direction
    float fresnel;    // fresnel_dielectric(fresnel_cos, fresnel_eta)
    float rough_albedo_r, rough_albedo_g, rough_albedo_b; // material_rough_albedo(wo)
};

layout(std430, set = 0, binding = 0) readonly buffer Queries { ProbeQuery queries[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Results { ProbeResult results[]; };
// KHR_materials_sheen's albedo tables (core/scene/pf_scene.h pf_sheen_albedo), as the scene's
// materials buffer begins with them.
layout(set = 0, binding = 2) uniform samplerBuffer sheen_tables;

float sheen_albedo_entry(int at)
{
    return texelFetch(sheen_tables, at >> 2)[at & 3];
}

void main()
{
    uint index = gl_GlobalInvocationID.x;
    if (index >= push.query_count)
        return;
    ProbeQuery query = queries[index];
    BsdfSample s = bsdf_sample(query.material, query.wo, query.normal, query.geometric_normal,
                               (query.front & 1u) != 0u, query.xi,
                               (query.front & 2u) != 0u ? TRANSPORT_IMPORTANCE : TRANSPORT_RADIANCE);
    ProbeResult result;
    result.direction = s.direction;
    result.pdf = s.pdf;
    result.weight = s.weight;
    result.flags = (s.specular ? 1u : 0u) | (s.transmitted ? 2u : 0u);
    bool front = (query.front & 1u) != 0u;
    result.eval_cos = bsdf_eval_cos(query.material, query.wo, s.direction, query.normal,
                                    query.geometric_normal, front);
    result.eval_pdf = bsdf_pdf(query.material, query.wo, s.direction, query.normal,
                               query.geometric_normal, front);
    result.fresnel = fresnel_dielectric(query.fresnel_cos, query.fresnel_eta);
    vec3 rough_albedo = material_rough_albedo(query.material, query.wo, query.normal, front);
    result.rough_albedo_r = rough_albedo.r;
    result.rough_albedo_g = rough_albedo.g;
    result.rough_albedo_b = rough_albedo.b;
    results[index] = result;
}
