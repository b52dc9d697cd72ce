// Material evaluation shared by every integrator (pf_material_kind): Lambert
// BRDF, ideal mirror, smooth dielectric with exact Fresnel.
#ifndef PF_MATERIALS_GLSL
#define PF_MATERIALS_GLSL

#include "scene_types.glsl"

const float PI = 3.14159265358979323846;

vec3 lambert_brdf(Material material)
{
    return material.albedo * (1.0 / PI);
}

// Unpolarized Fresnel reflectance of a smooth dielectric (pbrt-v4
// FrDielectric). cos_incident > 0 on the side the light comes from; eta is
// the transmitted-side index over the incident-side index. 1 on total
// internal reflection.
float fresnel_dielectric(float cos_incident, float eta)
{
    cos_incident = clamp(cos_incident, 0.0, 1.0);
    float sin2_incident = 1.0 - cos_incident * cos_incident;
    float sin2_transmitted = sin2_incident / (eta * eta);
    if (sin2_transmitted >= 1.0)
        return 1.0;
    float cos_transmitted = sqrt(1.0 - sin2_transmitted);
    float r_parallel = (eta * cos_incident - cos_transmitted) / (eta * cos_incident + cos_transmitted);
    float r_perpendicular = (cos_incident - eta * cos_transmitted) / (cos_incident + eta * cos_transmitted);
    return 0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
}

// Next direction of a specular chain through glass: reflection with
// probability F, else refraction (the choice is the Monte Carlo estimate of
// the Fresnel-weighted sum, so the throughput is unchanged except for the
// tint on transmission). normal faces the incoming ray (dot(normal, direction) < 0).
vec3 glass_scatter(Material material, vec3 direction, vec3 normal, bool entering, float xi,
                   inout vec3 throughput, out bool transmitted)
{
    float eta = entering ? material.ior : 1.0 / material.ior;
    float cos_incident = -dot(direction, normal);
    float reflectance = fresnel_dielectric(cos_incident, eta);
    transmitted = xi >= reflectance;
    if (!transmitted)
        return reflect(direction, normal);
    throughput *= material.albedo;
    return refract(direction, normal, 1.0 / eta);
}

#endif
