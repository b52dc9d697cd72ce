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

// pf_material_probe_query, 176 bytes.
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
    float padding0, padding1, padding2;
};

layout(std430, set = 0, binding = 0) readonly buffer Queries { ProbeQuery queries[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Results { ProbeResult results[]; };

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
    result.padding0 = 0.0;
    result.padding1 = 0.0;
    result.padding2 = 0.0;
    results[index] = result;
}
