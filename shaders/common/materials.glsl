// Materials (pf_material_kind): the one definition of how each material
// scatters light, shared by every integrator (preview, reference path
// tracing, photon tracing, final gather).
//
// Conventions of every function here:
//   wo               unit direction from the surface back along the arriving
//                    ray (-ray.direction)
//   shading_normal   unit, on wo's side of the surface
//   geometric_normal unit face normal, on wo's side of the surface
//   front            the ray arrived at the triangle's front face (for glass:
//                    the ray enters the medium)
// A direction that leaves on the wrong side of the geometric surface (which
// shading normals can produce) is never returned: the geometric normal
// decides reflection and transmission, so no light leaks through a surface.
//
// Lambert: f = albedo/π, cosine-weighted sampling (weight = albedo).
// Mirror (ideal, specular): reflection tinted by albedo (the metal's colour).
// Glass (smooth dielectric, specular): reflection with probability F (exact
//   Fresnel, 1 under total internal reflection), else refraction. Reflection
//   is untinted and transmission is tinted by albedo (glTF base colour of a
//   transmissive material), so with albedo 1 the two weights are exactly 1
//   and the expected throughput is exactly F + (1 − F) = 1 for photons.
//   Paths that carry radiance (camera rays, gather rays) also take the
//   (η_i/η_t)² factor of refraction (Veach 1997, §5.2; pbrt's
//   TransportMode::Radiance): radiance inside a denser medium is η² times
//   the radiance of the same flux outside. Photons carry flux (importance
//   transport) and take no such factor. Leaving it out of camera paths
//   cancels only on paths that enter and leave a medium; a camera path that
//   ends inside one (a floor under water) meets photon estimates of
//   physical irradiance there and came out η² too bright (issue 16).
#ifndef PF_MATERIALS_GLSL
#define PF_MATERIALS_GLSL

#include "scene_types.glsl"

const float PI = 3.14159265358979323846;

// No NaN or infinity in any component (the NaN/Inf guards of every kernel).
bool all_finite(vec3 value)
{
    return !any(isnan(value)) && !any(isinf(value));
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

// One sampled scattering direction.
struct BsdfSample {
    vec3 direction;   // unit, away from the surface
    vec3 weight;      // f·|cos|/pdf: what the path throughput is multiplied by; 0 = absorbed
    float pdf;        // solid-angle density of direction; 0 for a specular (delta) lobe
    bool specular;    // delta lobe: no light sampling, no MIS
    bool transmitted; // direction is below the geometric surface
};

// An orthonormal basis around unit n (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited", JCGT 6(1)).
void material_basis(vec3 n, out vec3 tangent, out vec3 bitangent)
{
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float b = n.x * n.y * a;
    tangent = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * b, -sign_z * n.x);
    bitangent = vec3(b, sign_z + n.y * n.y * a, -n.y);
}

// Cosine-weighted direction about n from xi in [0,1)² through the concentric
// disk map (Shirley & Chiu 1997), which keeps the strata of low-discrepancy
// points.
vec3 material_cosine_direction(vec3 n, vec2 xi)
{
    vec2 square = 2.0 * xi - 1.0;
    vec2 disk = vec2(0.0);
    if (square.x != 0.0 || square.y != 0.0) {
        float radius, angle;
        if (abs(square.x) > abs(square.y)) {
            radius = square.x;
            angle = (PI / 4.0) * (square.y / square.x);
        } else {
            radius = square.y;
            angle = PI / 2.0 - (PI / 4.0) * (square.x / square.y);
        }
        disk = radius * vec2(cos(angle), sin(angle));
    }
    float height = sqrt(max(0.0, 1.0 - dot(disk, disk)));
    vec3 tangent, bitangent;
    material_basis(n, tangent, bitangent);
    return normalize(disk.x * tangent + disk.y * bitangent + height * n);
}

// Mirror direction of wo about the shading normal, or about the geometric
// normal when the former would leave below the surface.
vec3 material_reflect(vec3 wo, vec3 shading_normal, vec3 geometric_normal)
{
    vec3 reflected = reflect(-wo, shading_normal);
    return dot(reflected, geometric_normal) > 0.0 ? reflected : reflect(-wo, geometric_normal);
}

// f·|cos(wi)| of the non-specular lobes for light arriving from wi (unit,
// away from the surface); 0 for specular materials and for wi below the
// surface.
vec3 bsdf_eval_cos(Material material, vec3 wo, vec3 wi, vec3 shading_normal,
                   vec3 geometric_normal)
{
    if (material.kind != MATERIAL_LAMBERT)
        return vec3(0.0);
    float cos_shading = dot(wi, shading_normal);
    if (cos_shading <= 0.0 || dot(wi, geometric_normal) <= 0.0)
        return vec3(0.0);
    return material.albedo * (cos_shading / PI);
}

// Solid-angle density with which bsdf_sample returns wi (non-specular lobes;
// 0 for specular materials and for directions it never returns).
float bsdf_pdf(Material material, vec3 wo, vec3 wi, vec3 shading_normal, vec3 geometric_normal)
{
    if (material.kind != MATERIAL_LAMBERT)
        return 0.0;
    float cos_shading = dot(wi, shading_normal);
    if (cos_shading <= 0.0 || dot(wi, geometric_normal) <= 0.0)
        return 0.0;
    return cos_shading / PI;
}

// What a sampled path carries (see the header): radiance paths start at the
// camera, importance paths (photons) at a light.
const uint TRANSPORT_RADIANCE = 0u;
const uint TRANSPORT_IMPORTANCE = 1u;

// Samples a scattering direction from xi in [0,1)³ (xy: the direction,
// z: the reflect/refract choice of glass) for a path carrying `transport`.
BsdfSample bsdf_sample(Material material, vec3 wo, vec3 shading_normal, vec3 geometric_normal,
                       bool front, vec3 xi, uint transport)
{
    BsdfSample s = BsdfSample(vec3(0.0), vec3(0.0), 0.0, false, false);
    if (material.kind == MATERIAL_LAMBERT) {
        s.direction = material_cosine_direction(shading_normal, xi.xy);
        s.pdf = bsdf_pdf(material, wo, s.direction, shading_normal, geometric_normal);
        // Below the geometric surface (a shading normal tilted past it): absorbed.
        s.weight = s.pdf > 0.0 ? material.albedo : vec3(0.0);
        return s;
    }
    s.specular = true;
    if (material.kind == MATERIAL_MIRROR) {
        s.direction = material_reflect(wo, shading_normal, geometric_normal);
        s.weight = material.albedo;
        return s;
    }
    float eta = front ? material.ior : 1.0 / material.ior;
    float reflectance = fresnel_dielectric(dot(wo, shading_normal), eta);
    vec3 refracted = refract(-wo, shading_normal, 1.0 / eta);
    if (refracted != vec3(0.0) && dot(refracted, geometric_normal) >= 0.0)
        refracted = refract(-wo, geometric_normal, 1.0 / eta);
    if (xi.z < reflectance || refracted == vec3(0.0)) {
        s.direction = material_reflect(wo, shading_normal, geometric_normal);
        s.weight = vec3(1.0);
        return s;
    }
    s.direction = normalize(refracted);
    // eta = η_t/η_i: (η_i/η_t)² = 1/eta² for radiance.
    s.weight = transport == TRANSPORT_RADIANCE ? material.albedo / (eta * eta) : material.albedo;
    s.transmitted = true;
    return s;
}

#endif
