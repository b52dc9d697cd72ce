// Materials: the one definition of how a surface scatters light, shared by
// every integrator (preview, fast, final, reference, photon tracing). The
// model is the glTF metallic-roughness BSDF of the spec's Appendix B
// (pf_material's parameters, pf_scene.h):
//
//   metal       = F_schlick(F0 = baseColor) · D·V                 (specular)
//   dielectric  = (1 − s·max(F)) · [(1 − T) · baseColor/π + T · btdf]
//                 + s · F · D·V                                     (KHR_materials_specular:
//                                                                    s = specularFactor)
//   bsdf        = mix(dielectric, metal, metallic)
//
// with D the GGX (Trowbridge-Reitz) distribution, α = roughness², V the
// height-correlated Smith visibility G₂/(4|n·wo||n·wi|) (Heitz 2014), and F
// evaluated at the microfacet normal h. The dielectric's F is the exact
// unpolarized Fresnel reflectance of its index (pbrt-v4 FrDielectric; at
// normal incidence ((n−1)/(n+1))² = 0.04 at 1.5, the spec's F0), tinted by
// specularColor, so total internal reflection inside glass is right. T is
// KHR_materials_transmission; the btdf refracts by the index (a solid
// object's boundary, as Cycles renders Blender's transmissive materials;
// glTF's thin-walled reading without KHR_materials_volume is not modelled):
// the GGX microfacet BTDF of Walter et al. 2007 ("Microfacet Models for
// Refraction through Rough Surfaces", eq. 21) with the same D, G₂ and F,
// in pbrt-v4's form (DielectricBxDF::f), tinted by baseColor.
//
// Delta limits: at roughness <= DELTA_ROUGHNESS (pf_scene.h
// PF_MATERIAL_DELTA_ROUGHNESS) the specular reflection is a mirror and the
// transmission a smooth refraction.
// A smooth metal is the old "mirror", a smooth T = 1 dielectric the old
// "glass", a specular 0 dielectric exactly Lambert.
//
// Sampling picks one lobe (specular reflection, diffuse, transmission) by a
// Fresnel estimate at n·wo and the lobes' colours, then samples it: GGX
// visible normals (Heitz 2018, "Sampling the GGX Distribution of Visible
// Normals", JCGT 7(4)) for the glossy lobe, cosine-weighted for the diffuse
// one. The reported pdf of a non-delta direction is the lobe-choice-weighted
// sum over the non-delta lobes (one-sample MIS, balance heuristic), and the
// weight is f·cos/pdf of the whole non-delta BSDF, so bsdf_eval_cos and
// bsdf_pdf agree with bsdf_sample and next-event estimation can MIS against it.
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
// The clear coat (KHR_materials_clearcoat): a dielectric layer of index 1.5 over all of the
// above, of strength c = clearcoat and GGX α_c = clearcoatRoughness²:
//
//   coated      = (1 − c·F_c) · bsdf + c · F_c · D_c·V_c
//
// F_c the exact Fresnel of index 1.5 at the microfacet normal, as the dielectric layer's (the
// spec's fresnel_coat takes Schlick's at the coat normal·wo; both are 0.04 at normal
// incidence), a mirror at clearcoatRoughness ≤ DELTA_ROUGHNESS. The coat's lobe is built
// around the coat's own normal (material_coat_normal): the mesh's where a base normal map
// tilts the shading normal, as the spec asks, or its clearcoatNormalTexture's, so the coat's
// cosines travel beside the base's (coat_cos). Sampling
// picks the coat first along xi.z, with probability ∝ c·F_c(n_c·wo), the other lobes' choices
// scaled by 1 − c·F_c(n_c·wo). A frame without a coated material compiles all of it out
// (SCENE_HAS_CLEARCOAT): its images are bit for bit those before the coat.
//
// The sheen (KHR_materials_sheen): a layer of fibres between the coat and the base, of colour
// s = sheenColor and α_s = max(sheenRoughness, SHEEN_ROUGHNESS_MIN)², by the spec's
// albedo-scaling form:
//
//   sheened     = s · D_s·V_s + bsdf · min(1 − max(s)·E(n·wo), 1 − max(s)·E(n·wi))
//
// D_s and V_s the "Charlie" distribution and visibility (Conty Estevez and Kulla 2017,
// "Production Friendly Microfacet Sheen BRDF"), E their directional albedo (a table integrated
// by core/scene/sheen_albedo_gen.c: sheen_table), about the lobe normal. The coat covers it as
// it covers the rest. Sampling picks the sheen after the transmission with probability
// ∝ max(s)·E(n·wo), the other lobes' choices scaled by 1 − max(s)·E(n·wo), and samples the
// hemisphere uniformly (the lobe is broad, and brightest at grazing angles, where a cosine
// density would be thinnest). Without a sheen material it is compiled out (SCENE_HAS_SHEEN).
//
// Smooth transmission: reflection with probability ∝ F, else refraction.
// Reflection is untinted and transmission is tinted by baseColor, so glass
// with baseColor 1 has weights exactly 1 and throughput F + (1 − F) = 1 for
// photons. Paths that carry radiance (camera rays, gather rays) also take the
// (η_i/η_t)² factor of refraction (Veach 1997, §5.2; pbrt's
// TransportMode::Radiance): radiance inside a denser medium is η² times the
// radiance of the same flux outside. Photons carry flux (importance
// transport) and take no such factor. Leaving it out of camera paths cancels
// only on paths that enter and leave a medium; a camera path that ends inside
// one (a floor under water) meets photon estimates of physical irradiance
// there and came out η² too bright (issue 16).
#ifndef PF_MATERIALS_GLSL
#define PF_MATERIALS_GLSL

#include "divide_exact.glsl"
#include "scene_binding_numbers.glsl" // SCENE_HAS_TRANSMISSION
#include "scene_types.glsl"

// Entry at of KHR_materials_sheen's albedo tables (32 × 32 floats each, at n·ω = k/31 by row
// and sheen roughness j/31 by column: the lobe's E, then a Lambert base's share B under it,
// core/scene/sheen_albedo_table.c), from a buffer the including kernel binds:
// scene_geometry.glsl reads the materials buffer's first texels, material_probe.comp its own
// binding. (A const array in GLSL made llvmpipe copy the table into scratch at every look-up
// and compile for minutes.)
float sheen_albedo_entry(int at);

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

// A direction about n uniform over the hemisphere (density 1/(2π)) from xi in [0,1)².
vec3 material_uniform_direction(vec3 n, vec2 xi)
{
    float z = xi.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * xi.y;
    vec3 tangent, bitangent;
    material_basis(n, tangent, bitangent);
    return normalize(r * cos(phi) * tangent + r * sin(phi) * bitangent + z * n);
}

// Mirror direction of wo about the shading normal, or about the geometric
// normal when the former would leave below the surface.
vec3 material_reflect(vec3 wo, vec3 shading_normal, vec3 geometric_normal)
{
    vec3 reflected = reflect(-wo, shading_normal);
    return dot(reflected, geometric_normal) > 0.0 ? reflected : reflect(-wo, geometric_normal);
}

float material_max3(vec3 v)
{
    return max(v.x, max(v.y, v.z));
}

// Schlick's Fresnel (the spec's conductor_fresnel): f0 at normal incidence, 1 at grazing.
vec3 fresnel_schlick(vec3 f0, float cos_theta)
{
    float m = clamp(1.0 - cos_theta, 0.0, 1.0);
    float m2 = m * m;
    return f0 + (1.0 - f0) * (m2 * m2 * m);
}

// The dielectric layer's reflectance at the microfacet cosine cos_h:
// specularFactor · min(F_exact · specularColor, 1) (see the header).
vec3 dielectric_fresnel(Material material, float cos_h, float eta)
{
    float exact = fresnel_dielectric(cos_h, eta);
    return material.specular * min(exact * material.specular_color, vec3(1.0));
}

// The index ratio a dielectric's Fresnel sees: through a transmissive
// surface the side matters (inside glass, TIR), an opaque one looks the same
// from both sides.
float material_eta(Material material, bool front)
{
    return (material.transmission > 0.0 && !front) ? 1.0 / material.ior : material.ior;
}

// GGX normal distribution D(h) for cos_h = n·h (Trowbridge & Reitz 1975; Walter et al. 2007).
float ggx_d(float cos_h, float alpha)
{
    float a2 = alpha * alpha;
    float t = cos_h * cos_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * t * t);
}

// Smith's Λ for GGX at a direction of cosine cos_theta to the normal.
float ggx_lambda(float cos_theta, float alpha)
{
    float c2 = max(cos_theta * cos_theta, 1e-12);
    float tan2 = max(1.0 - c2, 0.0) / c2;
    return 0.5 * (sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

// Height-correlated Smith visibility V = G₂ / (4 |n·wo| |n·wi|) (the spec's
// V_GGX, Heitz 2014 eq. 99).
float ggx_visibility(float cos_o, float cos_i, float alpha)
{
    float a2 = alpha * alpha;
    float term_o = cos_i * sqrt(cos_o * cos_o * (1.0 - a2) + a2);
    float term_i = cos_o * sqrt(cos_i * cos_i * (1.0 - a2) + a2);
    float denominator = term_o + term_i;
    return denominator > 0.0 ? 0.5 / denominator : 0.0;
}

// A visible microfacet normal for wo (local frame, z = normal, wo.z > 0) from
// xi in [0,1)² (Heitz 2018, listing 1).
vec3 ggx_sample_visible_normal(vec3 wo_local, float alpha, vec2 xi)
{
    vec3 vh = normalize(vec3(alpha * wo_local.x, alpha * wo_local.y, wo_local.z));
    float length2 = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = length2 > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(length2) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(xi.x);
    float phi = 2.0 * PI * xi.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2;
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3(alpha * nh.x, alpha * nh.y, max(1e-6, nh.z)));
}

// Density of reflected directions that visible-normal sampling produces:
// G₁(wo) D(h) / (4 cos_o) (Heitz 2018, eq. 17 with the reflection Jacobian).
float ggx_reflection_pdf(float cos_o, float cos_h, float alpha)
{
    float g1 = 1.0 / (1.0 + ggx_lambda(cos_o, alpha));
    return g1 * ggx_d(cos_h, alpha) / (4.0 * cos_o);
}

bool material_specular_is_delta(Material material)
{
    return material.roughness <= DELTA_ROUGHNESS;
}

float material_alpha(Material material)
{
    return material.roughness * material.roughness;
}

// KHR_materials_clearcoat's index (the spec's fixed 1.5: F0 = 0.04).
const float COAT_IOR = 1.5;

bool material_has_coat(Material material)
{
    return SCENE_HAS_CLEARCOAT && material.clearcoat > 0.0;
}

bool material_coat_is_delta(Material material)
{
    return material.clearcoat_roughness <= DELTA_ROUGHNESS;
}

float material_coat_alpha(Material material)
{
    return material.clearcoat_roughness * material.clearcoat_roughness;
}

// c·F_c at the cosine cos (the coat's reflectance, and what it takes from the layers below).
float material_coat_fresnel(Material material, float cos_theta)
{
    return material.clearcoat * fresnel_dielectric(cos_theta, COAT_IOR);
}

// The least sheen roughness the lobe takes (α_s ≥ 0.0049): the spec allows 0, where the
// Charlie lobe is a sliver at grazing angles whose pow() no float can hold; the directional
// albedo at 0.07 is under 0.006 but for n·wo < 0.4 (core/scene/sheen_albedo_table.c).
const float SHEEN_ROUGHNESS_MIN = 0.07;

bool material_has_sheen(Material material)
{
    return SCENE_HAS_SHEEN && material_max3(material.sheen_color) > 0.0;
}

float material_sheen_alpha(Material material)
{
    float r = max(material.sheen_roughness, SHEEN_ROUGHNESS_MIN);
    return r * r;
}

// The Charlie distribution D_s(h) for cos_h = n·h (the spec's sheenDistribution).
float sheen_d(float cos_h, float alpha)
{
    float sin2 = max(1.0 - cos_h * cos_h, 0.0);
    return (2.0 + 1.0 / alpha) * pow(sin2, 0.5 / alpha) / (2.0 * PI);
}

// The Charlie visibility's fitted Λ (the spec's l() and lambdaSheen()).
float sheen_l(float x, float alpha)
{
    float t = (1.0 - alpha) * (1.0 - alpha);
    float a = mix(21.5473, 25.3245, t), b = mix(3.82987, 3.32435, t);
    float c = mix(0.19823, 0.16801, t), d = mix(-1.97760, -1.27393, t);
    float e = mix(-4.32054, -4.85967, t);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

float sheen_lambda(float cos_theta, float alpha)
{
    return cos_theta < 0.5 ? exp(sheen_l(cos_theta, alpha))
                           : exp(2.0 * sheen_l(0.5, alpha) - sheen_l(1.0 - cos_theta, alpha));
}

// D_s·V_s·cos_i of the sheen of colour 1 (V_s = 1 / ((1 + Λ_o + Λ_i)·4·cos_o·cos_i)).
float sheen_eval_cos(float cos_o, float cos_i, float cos_h, float alpha)
{
    return sheen_d(cos_h, alpha) /
           ((1.0 + sheen_lambda(cos_o, alpha) + sheen_lambda(cos_i, alpha)) * 4.0 * cos_o);
}

// Table `table` (0: E, 1: B) at (cos_theta, roughness), bilinear (sheen_albedo_entry).
float sheen_table(int table, float cos_theta, float roughness)
{
    float x = clamp(cos_theta, 0.0, 1.0) * 31.0, y = clamp(roughness, 0.0, 1.0) * 31.0;
    int i = min(int(x), 30), j = min(int(y), 30);
    float fx = x - float(i), fy = y - float(j);
    int at = 1024 * table + 32 * i + j;
    return mix(mix(sheen_albedo_entry(at), sheen_albedo_entry(at + 1), fy),
               mix(sheen_albedo_entry(at + 32), sheen_albedo_entry(at + 33), fy), fx);
}

// E(cos_theta, roughness): the lobe's directional albedo (sheen colour 1).
float sheen_albedo(float cos_theta, float roughness)
{
    return sheen_table(0, cos_theta, roughness);
}

// What a sheen leaves the layers below where it takes `share` of white light (its albedo E at
// one direction, or the base's mean share B): 1 − max(s)·share, at least 0.
float material_sheen_leaves(Material material, float share)
{
    return max(1.0 - material_max3(material.sheen_color) * share, 0.0);
}

// What the sheen leaves the layers below at a direction of cosine cos_theta: 1 − max(s)·E.
float material_sheen_base_scale(Material material, float cos_theta)
{
    return material_sheen_leaves(material, sheen_albedo(cos_theta, material.sheen_roughness));
}

// A rough (non-delta) transmission lobe: some transmission, not all metal, rough.
bool material_has_rough_transmission(Material material)
{
    return material.transmission > 0.0 && material.metallic < 1.0 &&
           !material_specular_is_delta(material);
}

// The least share of rough transmission's choice weight (any positive value
// keeps the one-sample estimate unbiased; a quarter keeps the light that
// microfacets let out past the critical angle from being a rare event).
const float ROUGH_TRANSMISSION_MIN_SHARE = 0.25;

// How the BSDF splits at wo: lobe choice probabilities (specular
// reflection, diffuse, transmission; they sum to 1, or all 0 for a black
// surface) from a Fresnel estimate at n·wo, and that estimate, which is also
// the smooth lobes' exact reflectance and base weight.
struct LobeChoice {
    float specular;
    float diffuse;
    float transmission;
    float coat;       // the clear coat's (0 without one)
    float sheen;      // the sheen's (0 without one)
    vec3 reflectance; // metal and dielectric Fresnel at n·wo, mixed by metallic (under a
                      // sheen: times 1 − max(s)·E at n·wo; under a coat: times 1 − c·F_c)
    float base;       // 1 − max(dielectric F) at n·wo: the base's and transmission's share
                      // (likewise)
    float coat_reflectance; // c·F_c at n·wo: a smooth coat's reflectance
};

// coat_cos_o: n·wo about the coat's normal (material_coat_normal).
LobeChoice material_lobe_choice(Material material, float cos_o, float coat_cos_o, float eta)
{
    // Largest channels, not luminance: white surfaces then split exactly by
    // F and 1 − F, so a white glass's weights are exactly 1.
    float dielectric = 1.0 - material.metallic;
    vec3 dielectric_f = dielectric_fresnel(material, cos_o, eta);
    vec3 metal_f = fresnel_schlick(material.albedo, cos_o);
    float fresnel = material_max3(dielectric_f);
    float albedo = material_max3(material.albedo);
    LobeChoice choice;
    choice.reflectance = mix(dielectric_f, metal_f, material.metallic);
    choice.base = 1.0 - fresnel;
    choice.specular = material.metallic * material_max3(metal_f) + dielectric * fresnel;
    choice.diffuse = dielectric * (1.0 - material.transmission) * choice.base * albedo;
    // Rough glass still transmits where the macro surface reflects totally
    // (leaving beyond the critical angle, its microfacets tilt): its choice
    // never drops below ROUGH_TRANSMISSION_MIN_SHARE, or sampling would miss
    // light that evaluation counts.
    float transmit_share = material_has_rough_transmission(material)
                               ? max(choice.base, ROUGH_TRANSMISSION_MIN_SHARE)
                               : choice.base;
    choice.transmission = dielectric * material.transmission * transmit_share * albedo;
    choice.coat = 0.0;
    choice.coat_reflectance = 0.0;
    choice.sheen = 0.0;
    if (material_has_sheen(material)) {
        // The sheen's albedo at wo, and what it leaves the lobes below.
        float albedo = sheen_albedo(cos_o, material.sheen_roughness);
        float below = material_sheen_leaves(material, albedo);
        choice.reflectance *= below;
        choice.base *= below;
        choice.specular *= below;
        choice.diffuse *= below;
        choice.transmission *= below;
        choice.sheen = material_max3(material.sheen_color) * albedo;
    }
    float total = choice.specular + choice.diffuse + choice.transmission + choice.sheen;
    if (material_has_coat(material)) {
        // What the coat reflects, the layers below do not receive.
        choice.coat_reflectance = material_coat_fresnel(material, coat_cos_o);
        float below = 1.0 - choice.coat_reflectance;
        choice.reflectance *= below;
        choice.base *= below;
        choice.specular *= below;
        choice.diffuse *= below;
        choice.transmission *= below;
        choice.sheen *= below;
        choice.coat = choice.coat_reflectance;
        total = choice.specular + choice.diffuse + choice.transmission + choice.sheen +
                choice.coat;
    }
    if (!(total > 0.0)) {
        choice.specular = choice.diffuse = choice.transmission = choice.coat = 0.0;
        choice.sheen = 0.0;
    } else if (total != 1.0) {
        // Rounded as the host divides (divide_exact.glsl), as are the smooth lobes' weights
        // below: a white glass's lobes then weigh exactly 1 on every device.
        choice.specular = divide_exact(choice.specular, total);
        choice.diffuse = divide_exact(choice.diffuse, total);
        choice.transmission = divide_exact(choice.transmission, total);
        if (material_has_coat(material))
            choice.coat = divide_exact(choice.coat, total);
        if (material_has_sheen(material))
            choice.sheen = divide_exact(choice.sheen, total);
    }
    return choice;
}

// The normal the lobes are built around: the shading normal, or the
// geometric one where wo lies below the shading normal's hemisphere (an
// interpolated normal at a smooth mesh's silhouette). Sampling, evaluation
// and pdf all use it, so next-event estimation sees what sampling does.
vec3 material_lobe_normal(vec3 wo, vec3 shading_normal, vec3 geometric_normal)
{
    return dot(wo, shading_normal) > 0.0 ? shading_normal : geometric_normal;
}

// The normal the coat's lobe is built around: its own where the hit set one (the mesh's under
// a base normal map: scene_coat_normal), turned to the geometric one as material_lobe_normal
// turns the shading normal; else the lobe normal (lobe_normal).
vec3 material_coat_normal(Material material, vec3 wo, vec3 lobe_normal, vec3 geometric_normal)
{
    vec3 n = vec3(material.coat_normal_x, material.coat_normal_y, material.coat_normal_z);
    if (!material_has_coat(material) || dot(n, n) == 0.0)
        return lobe_normal;
    return dot(wo, n) > 0.0 ? n : geometric_normal;
}

// f·cos of the non-delta lobes for wo and wi on the same side of the geometric surface
// (cos_o, cos_i against the lobe normal, the base's lobes where cos_i > 0; cos_h = n·h,
// cos_oh = wo·h; coat_cos: the same three cosines about the coat's normal, its lobe where
// coat_cos.y > 0).
vec3 material_reflection_eval(Material material, float cos_o, float cos_i, float cos_h,
                              float cos_oh, float eta, vec3 coat_cos)
{
    vec3 value = vec3(0.0);
    if (cos_i > 0.0) {
        vec3 dielectric_f = dielectric_fresnel(material, cos_oh, eta);
        float base = 1.0 - material_max3(dielectric_f);
        value = (1.0 - material.metallic) * (1.0 - material.transmission) * base *
                material.albedo * (cos_i / PI);
        if (!material_specular_is_delta(material)) {
            float alpha = material_alpha(material);
            vec3 fresnel = mix(dielectric_f, fresnel_schlick(material.albedo, cos_oh),
                               material.metallic);
            value +=
                fresnel * (ggx_d(cos_h, alpha) * ggx_visibility(cos_o, cos_i, alpha) * cos_i);
        }
        if (material_has_sheen(material)) {
            value *= min(material_sheen_base_scale(material, cos_o),
                         material_sheen_base_scale(material, cos_i));
            value += material.sheen_color *
                     sheen_eval_cos(cos_o, cos_i, cos_h, material_sheen_alpha(material));
        }
    }
    if (material_has_coat(material)) {
        float coat = material_coat_fresnel(material, cos_oh);
        value *= 1.0 - coat;
        if (!material_coat_is_delta(material) && coat_cos.y > 0.0) {
            float alpha = material_coat_alpha(material);
            value += vec3(coat * ggx_d(coat_cos.z, alpha) *
                          ggx_visibility(coat_cos.x, coat_cos.y, alpha) * coat_cos.y);
        }
    }
    return value;
}

// The rough BTDF's half vector for wo above and wi below the surface (eta =
// η_t/η_i): normalize(eta·wi + wo), turned to wo's side; false where a
// microfacet with that normal cannot refract wo into wi (it faces away from
// one of them).
bool ggx_refraction_half_vector(vec3 wo, vec3 wi, vec3 normal, float eta, out vec3 h)
{
    h = eta * wi + wo;
    if (!(dot(h, h) > 0.0))
        return false;
    h = normalize(h);
    h = dot(h, normal) < 0.0 ? -h : h;
    return dot(h, wo) > 0.0 && dot(h, wi) < 0.0;
}

// f·|cos_i| of the rough transmission lobe (Walter et al. 2007 in pbrt-v4's
// form) for wo above (cos_o > 0) and wi below (cos_i < 0) the lobe normal,
// half vector h from ggx_refraction_half_vector; radiance transport: the
// (η_i/η_t)² of refraction included (see the header).
vec3 material_transmission_eval(Material material, vec3 wo, vec3 wi, vec3 h, vec3 normal,
                                float eta, float coat_cos_o)
{
    float alpha = material_alpha(material);
    float cos_o = dot(wo, normal), cos_i = -dot(wi, normal);
    float cos_oh = dot(wo, h), cos_ih = -dot(wi, h);
    float fresnel = material_max3(dielectric_fresnel(material, cos_oh, eta));
    float g2 = ggx_visibility(cos_o, cos_i, alpha) * 4.0 * cos_o * cos_i;
    float denominator = -cos_ih + cos_oh / eta; // dot(wi, h) + dot(wo, h)/eta, < 0
    float btdf_cos = (1.0 - fresnel) * ggx_d(dot(h, normal), alpha) * g2 * cos_ih * cos_oh /
                     (cos_o * denominator * denominator * eta * eta);
    if (material_has_coat(material)) // through the coat, as the lobe choice weighs it
        btdf_cos *= 1.0 - material_coat_fresnel(material, coat_cos_o);
    return (1.0 - material.metallic) * material.transmission * material.albedo * btdf_cos;
}

// Density with which the transmission lobe's visible-normal sampling
// produces wi: the visible normals' density G₁(wo)·(wo·h)·D(h)/cos_o times
// the refraction's Jacobian |wi·h| / (wi·h + wo·h/eta)² (Walter 2007, eq. 17).
float ggx_transmission_pdf(vec3 wo, vec3 wi, vec3 h, vec3 normal, float eta, float alpha)
{
    float cos_o = dot(wo, normal);
    float cos_oh = dot(wo, h), cos_ih = dot(wi, h);
    float g1 = 1.0 / (1.0 + ggx_lambda(cos_o, alpha));
    float denominator = cos_ih + cos_oh / eta;
    return g1 * cos_oh * ggx_d(dot(h, normal), alpha) / cos_o * abs(cos_ih) /
           (denominator * denominator);
}

// pdf with which bsdf_sample returns wi among its non-delta lobes (the cosines as
// material_reflection_eval's).
float material_reflection_pdf(Material material, LobeChoice choice, float cos_o, float cos_i,
                              float cos_h, vec3 coat_cos)
{
    float pdf = 0.0;
    if (cos_i > 0.0) {
        pdf = choice.diffuse * cos_i / PI + choice.sheen / (2.0 * PI);
        if (!material_specular_is_delta(material))
            pdf += choice.specular * ggx_reflection_pdf(cos_o, cos_h, material_alpha(material));
    }
    if (material_has_coat(material) && !material_coat_is_delta(material) && coat_cos.y > 0.0)
        pdf += choice.coat *
               ggx_reflection_pdf(coat_cos.x, coat_cos.z, material_coat_alpha(material));
    return pdf;
}

// f·|cos(wi)| of the non-delta lobes for light arriving from wi (unit, away
// from the surface), and in pdf the solid-angle density with which bsdf_sample
// returns wi: 0 both for delta-only materials and for wi below the surface (or
// a direction sampling never returns). One walk for both: next-event
// estimation needs both for the same direction, and the two share the lobe
// normal, the half vector and the microfacet terms.
// front: the side wo lies on (transmissive materials' Fresnel depends on it).
vec3 bsdf_eval_cos_pdf(Material material, vec3 wo, vec3 wi, vec3 shading_normal,
                       vec3 geometric_normal, bool front, out float pdf)
{
    pdf = 0.0;
    vec3 normal = material_lobe_normal(wo, shading_normal, geometric_normal);
    vec3 coat_normal = material_coat_normal(material, wo, normal, geometric_normal);
    float cos_i = dot(wi, normal);
    float cos_o = max(dot(wo, normal), 1e-6);
    float coat_cos_o = max(dot(wo, coat_normal), 1e-6);
    float eta = material_eta(material, front);
    LobeChoice choice = material_lobe_choice(material, cos_o, coat_cos_o, eta);
    if (dot(wi, geometric_normal) < 0.0) {
        vec3 h;
        if (cos_i >= 0.0 || !material_has_rough_transmission(material) ||
            !ggx_refraction_half_vector(wo, wi, normal, eta, h))
            return vec3(0.0);
        pdf = choice.transmission *
              ggx_transmission_pdf(wo, wi, h, normal, eta, material_alpha(material));
        return material_transmission_eval(material, wo, wi, h, normal, eta, coat_cos_o);
    }
    float coat_cos_i = dot(wi, coat_normal);
    bool coat_side = material_has_coat(material) && coat_cos_i > 0.0;
    if ((cos_i <= 0.0 && !coat_side) || dot(wi, geometric_normal) == 0.0)
        return vec3(0.0);
    vec3 h = normalize(wo + wi);
    float cos_h = dot(h, normal);
    vec3 coat_cos = vec3(coat_cos_o, coat_cos_i, dot(h, coat_normal));
    pdf = material_reflection_pdf(material, choice, cos_o, cos_i, cos_h, coat_cos);
    return material_reflection_eval(material, cos_o, cos_i, cos_h, clamp(dot(wo, h), 0.0, 1.0),
                                    eta, coat_cos);
}

vec3 bsdf_eval_cos(Material material, vec3 wo, vec3 wi, vec3 shading_normal,
                   vec3 geometric_normal, bool front)
{
    float pdf; // unused: the compiler drops its terms
    return bsdf_eval_cos_pdf(material, wo, wi, shading_normal, geometric_normal, front, pdf);
}

float bsdf_pdf(Material material, vec3 wo, vec3 wi, vec3 shading_normal, vec3 geometric_normal,
               bool front)
{
    float pdf;
    bsdf_eval_cos_pdf(material, wo, wi, shading_normal, geometric_normal, front, pdf);
    return pdf;
}

// Whether the material has any non-delta lobe: where next-event estimation
// (and its MIS) applies. Rough glass has one, though it stores no photons.
bool material_has_rough_lobe(Material material)
{
    return material.kind == MATERIAL_LAMBERT || !material_specular_is_delta(material) ||
           (material_has_coat(material) && !material_coat_is_delta(material)) ||
           material_has_sheen(material);
}

// Whether light is estimated at the surface from stored photons, the LPV or
// the irradiance cache (multiplied by material_rough_albedo): surfaces with a
// diffuse base or a rough glossy reflection (pf_material_kind LAMBERT). Mirrors,
// metals sharper than GLOSSY_ROUGHNESS and glass, smooth or rough, are passed
// through by sampling bsdf_sample instead.
bool material_stores_photons(Material material)
{
    return material.kind == MATERIAL_LAMBERT;
}

// Where a camera path of `final` (and `preview`) ends its specular chain: at a
// surface estimated from photons, or at a metal too sharp for that, whose own
// lobe the gather rays (preview: the light samples) then sample. Photons reach
// it through caustic chains only (photon_path.glsl): light it receives from
// mirrors, glass and other sharp metals is estimated there from the caustic
// map, the rest is found by its gather rays.
bool material_estimated_at_d1(Material material)
{
    return material.kind == MATERIAL_LAMBERT ||
           (material.kind == MATERIAL_MIRROR && material_has_rough_lobe(material));
}

// The absorption coefficient (1/m) of the medium a path is in after it was
// transmitted through a surface of this material, arriving at its front face
// (entering) or back face (leaving into clear space: nested media are not
// tracked). KHR_materials_volume's Beer-Lambert attenuation.
vec3 medium_after_transmission(Material material, bool front)
{
    return front ? material.absorption : vec3(0.0);
}

// The fraction of light left after distance t in a medium of coefficient absorption.
// A medium is entered only through a transmissive surface: a frame without one has no
// exponentials here (llvmpipe would run them, masked, for every ray).
vec3 medium_transmittance(vec3 absorption, float t)
{
    if (!SCENE_HAS_TRANSMISSION)
        return vec3(1.0);
    return any(greaterThan(absorption, vec3(0.0))) ? exp(-absorption * t) : vec3(1.0);
}

// Whether the surface sends its emission towards a ray that arrived at its
// front face (front) or its back face: emitters are one-sided (the front,
// counter-clockwise face) unless their material is double-sided.
bool material_emits(Material material, bool front)
{
    return (front || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u) &&
           any(greaterThan(material.emission, vec3(0.0)));
}

// What a sampled path carries (see the header): radiance paths start at the
// camera, importance paths (photons) at a light.
const uint TRANSPORT_RADIANCE = 0u;
const uint TRANSPORT_IMPORTANCE = 1u;

// Samples a scattering direction from xi in [0,1)³ (xy: the direction,
// z: the lobe) for a path carrying `transport`.
BsdfSample bsdf_sample(Material material, vec3 wo, vec3 shading_normal, vec3 geometric_normal,
                       bool front, vec3 xi, uint transport)
{
    BsdfSample s = BsdfSample(vec3(0.0), vec3(0.0), 0.0, false, false);
    float eta = material_eta(material, front);
    vec3 normal = material_lobe_normal(wo, shading_normal, geometric_normal);
    vec3 coat_normal = material_coat_normal(material, wo, normal, geometric_normal);
    float cos_o = max(dot(wo, normal), 1e-6);
    float coat_cos_o = max(dot(wo, coat_normal), 1e-6);
    LobeChoice choice = material_lobe_choice(material, cos_o, coat_cos_o, eta);
    float pick = xi.z;
    bool delta_specular = material_specular_is_delta(material);
    bool coat_glossy = false;
    // The coat first along xi.z.
    if (material_has_coat(material)) {
        if (pick < choice.coat && material_coat_is_delta(material)) {
            s.direction = material_reflect(wo, coat_normal, geometric_normal);
            s.specular = true;
            s.weight = vec3(divide_exact(choice.coat_reflectance, choice.coat));
            return s;
        }
        coat_glossy = pick < choice.coat;
        pick -= choice.coat;
    }

    // Lobes in the order specular, transmission, diffuse along xi.z, so a
    // smooth glass reflects exactly when xi.z < F.
    if (!coat_glossy && pick < choice.specular && delta_specular) {
        s.direction = material_reflect(wo, normal, geometric_normal);
        s.specular = true;
        s.weight = vec3(divide_exact(choice.reflectance.r, choice.specular),
                        divide_exact(choice.reflectance.g, choice.specular),
                        divide_exact(choice.reflectance.b, choice.specular));
        return s;
    }
    bool glossy = !coat_glossy && pick < choice.specular;
    pick -= choice.specular;
    vec3 tangent, bitangent;
    material_basis(normal, tangent, bitangent);
    if (!coat_glossy && !glossy && pick < choice.transmission &&
        material_has_rough_transmission(material)) {
        vec3 wo_local = vec3(dot(wo, tangent), dot(wo, bitangent), cos_o);
        vec3 m_local = ggx_sample_visible_normal(wo_local, material_alpha(material), xi.xy);
        vec3 m = m_local.x * tangent + m_local.y * bitangent + m_local.z * normal;
        vec3 wi = refract(-wo, m, 1.0 / eta);
        vec3 h;
        if (wi == vec3(0.0) || dot(wi, normal) >= 0.0 || dot(wi, geometric_normal) >= 0.0)
            return s; // total internal reflection at that microfacet, or above the surface
        wi = normalize(wi);
        if (!ggx_refraction_half_vector(wo, wi, normal, eta, h))
            return s;
        s.direction = wi;
        s.transmitted = true;
        s.pdf = choice.transmission *
                ggx_transmission_pdf(wo, wi, h, normal, eta, material_alpha(material));
        if (!(s.pdf > 0.0))
            return s;
        // Photons carry flux: without radiance's (η_i/η_t)².
        float scale = transport == TRANSPORT_RADIANCE ? 1.0 : eta * eta;
        s.weight = material_transmission_eval(material, wo, wi, h, normal, eta, coat_cos_o) *
                   (scale / s.pdf);
        return s;
    }
    if (!coat_glossy && !glossy && pick < choice.transmission) {
        vec3 refracted = refract(-wo, normal, 1.0 / eta);
        if (refracted != vec3(0.0) && dot(refracted, geometric_normal) >= 0.0)
            refracted = refract(-wo, geometric_normal, 1.0 / eta);
        if (refracted == vec3(0.0))
            return s; // total internal reflection: F = 1 gave this lobe no weight
        s.direction = normalize(refracted);
        s.specular = true;
        s.transmitted = true;
        // eta = η_t/η_i: (η_i/η_t)² = 1/eta² for radiance.
        float scale = transport == TRANSPORT_RADIANCE ? 1.0 / (eta * eta) : 1.0;
        s.weight = material.albedo *
                   divide_exact((1.0 - material.metallic) * material.transmission *
                                    choice.base * scale,
                                choice.transmission);
        return s;
    }

    // The sheen after the transmission along xi.z, then the diffuse base.
    pick -= choice.transmission;
    bool sheen = !coat_glossy && !glossy && pick < choice.sheen;
    if (glossy || coat_glossy) {
        // The coat's lobe about its own normal (the lobe normal but under a base normal map).
        vec3 axis = coat_glossy ? coat_normal : normal;
        if (coat_glossy)
            material_basis(axis, tangent, bitangent);
        vec3 wo_local =
            vec3(dot(wo, tangent), dot(wo, bitangent), coat_glossy ? coat_cos_o : cos_o);
        float alpha = coat_glossy ? material_coat_alpha(material) : material_alpha(material);
        vec3 h_local = ggx_sample_visible_normal(wo_local, alpha, xi.xy);
        vec3 h = h_local.x * tangent + h_local.y * bitangent + h_local.z * axis;
        s.direction = reflect(-wo, h);
    } else if (sheen) {
        s.direction = material_uniform_direction(normal, xi.xy);
    } else if (choice.diffuse > 0.0) {
        s.direction = material_cosine_direction(normal, xi.xy);
    } else {
        return s;
    }
    float cos_i = dot(s.direction, normal);
    float coat_cos_i = dot(s.direction, coat_normal);
    bool coat_side = material_has_coat(material) && coat_cos_i > 0.0;
    if ((cos_i <= 0.0 && !coat_side) || dot(s.direction, geometric_normal) <= 0.0)
        return s; // below the surface: absorbed
    vec3 h = normalize(wo + s.direction);
    float cos_h = dot(h, normal);
    vec3 coat_cos = vec3(coat_cos_o, coat_cos_i, dot(h, coat_normal));
    s.pdf = material_reflection_pdf(material, choice, cos_o, cos_i, cos_h, coat_cos);
    if (!(s.pdf > 0.0))
        return s;
    s.weight = material_reflection_eval(material, cos_o, cos_i, cos_h, clamp(dot(wo, h), 0.0, 1.0),
                                        eta, coat_cos) / s.pdf;
    return s;
}

// Karis's fit of the GGX lobe's ∫ F·D·V·cos as F0's scale and F90's bias, at perceptual
// roughness and n·wo.
vec2 ggx_split_sum(float roughness, float cos_o)
{
    vec4 r = roughness * vec4(-1.0, -0.0275, -0.572, 0.022) + vec4(1.0, 0.0425, 1.04, -0.04);
    float a004 = min(r.x * r.x, exp2(-9.28 * cos_o)) * r.x + r.y;
    return vec2(-1.04, 1.04) * a004 + r.zw;
}

// The surface's directional albedo towards wo for its non-delta lobes: what a
// kernel multiplies an irradiance estimate by (over π) where it does not
// sample the BSDF (photon, LPV and gather lookups). Exact for a pure Lambert
// base. The base's 1 − F is taken at the half vector of wo and the normal
// (where the base reflects most: the spec's F(wo·h) is smallest there, and
// F at n·wo itself would darken grazing views ~10 % below the model); the
// glossy lobe's ∫ F·D·V·cos is the split-sum fit of Karis 2014 ("Physically
// Based Shading on Mobile", after Lazarov 2013); a sheen's is its table's E.
vec3 material_rough_albedo(Material material, vec3 wo, vec3 shading_normal, bool front)
{
    float cos_o = clamp(dot(wo, shading_normal), 1e-4, 1.0);
    float eta = material_eta(material, front);
    vec3 dielectric_f0 = dielectric_fresnel(material, 1.0, eta);
    float cos_half = sqrt(0.5 * (1.0 + cos_o));
    vec3 albedo = (1.0 - material.metallic) * (1.0 - material.transmission) *
                  (1.0 - material_max3(dielectric_fresnel(material, cos_half, eta))) *
                  material.albedo;
    if (!material_specular_is_delta(material)) {
        vec2 scale_bias = ggx_split_sum(material.roughness, cos_o);
        vec3 f0 = mix(dielectric_f0, material.albedo, material.metallic);
        vec3 f90 = vec3(mix(material.specular, 1.0, material.metallic));
        albedo = albedo + f0 * scale_bias.x + f90 * scale_bias.y;
    }
    if (material_has_sheen(material)) {
        // Under the sheen what it leaves (exact for a Lambert base: 1 − max(s)·B, the
        // scaling's min over every wi), and its own lobe's albedo, E.
        float e = sheen_albedo(cos_o, material.sheen_roughness);
        float share = sheen_table(1, cos_o, material.sheen_roughness);
        albedo = albedo * material_sheen_leaves(material, share) + material.sheen_color * e;
    }
    if (material_has_coat(material)) {
        // Below the coat what it lets through (at the half vector, as the base's 1 − F),
        // and its own lobe where rough (F0 0.04, F90 1), about the coat's normal.
        vec3 coat_normal = material_coat_normal(material, wo, shading_normal, shading_normal);
        float coat_cos_o = clamp(dot(wo, coat_normal), 1e-4, 1.0);
        albedo *= 1.0 - material_coat_fresnel(material, sqrt(0.5 * (1.0 + coat_cos_o)));
        if (!material_coat_is_delta(material)) {
            vec2 scale_bias = ggx_split_sum(material.clearcoat_roughness, coat_cos_o);
            float f0 = fresnel_dielectric(1.0, COAT_IOR);
            albedo += vec3(material.clearcoat * (f0 * scale_bias.x + scale_bias.y));
        }
    }
    return albedo;
}

#endif
