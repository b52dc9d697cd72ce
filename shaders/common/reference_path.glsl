// The reference path tracer's one path, vertex by vertex: what
// render_reference.comp (the megakernel: each invocation traces its path to
// the end) and render_reference_wave.comp (the wavefront: one vertex per
// dispatch, the rays traced between dispatches, on the host where the device
// is the CPU) both run, so the two drivers compute the same paths from the
// same random numbers. The estimator is described in render_reference.comp.
//
// The including shader declares params (FrameParams), the scene arrays,
// `counters` with a uint discarded_samples, the films `film` and `film_aov`,
// the bool WRITE_AOVS, and includes area_lights, lights, materials, surface
// and sampler first; direct_light.glsl and camera_sample.glsl are included
// here (with PF_DEFERRED_SHADOWS defined, direct_light's shadow rays go to
// shadow_ray_defer).
#ifndef PF_REFERENCE_PATH_GLSL
#define PF_REFERENCE_PATH_GLSL

#include "camera_sample.glsl"
#include "direct_light.glsl"

// Russian roulette starts after this many bounces (issue 5), and then only
// once the path throughput (including earlier roulette divisions) falls
// below RR_THRESHOLD: survival = min(1, max component / RR_THRESHOLD), so a
// surviving path continues with throughput about RR_THRESHOLD instead of
// about 1. With a threshold of 1 (pbrt-v4) a bright closed scene pays for
// every termination with a full unit of variance (white furnace at albedo
// 0.8: per-sample σ ≈ 0.46·L); at 0.1 the tail's variance is 100× smaller
// for a few more vertices per path_
const uint RR_START_DEPTH = 3u;
const float RR_THRESHOLD = 0.1;

// Where the path stands relative to its first diffuse vertex D₁ (render_reference.comp).
const uint REGION_BEFORE_DIFFUSE = 0u; // no diffuse vertex yet
const uint REGION_AT_DIFFUSE = 1u;     // the last vertex is D₁
const uint REGION_BEYOND = 2u;         // past D₁

// Everything a path carries from one vertex to the next: the invocation's
// private globals, which the megakernel keeps in registers across its loop
// and the wavefront loads from and stores to its path buffer around a vertex.
vec3 path_origin, path_direction; // the ray to trace next
vec3 path_throughput;
vec3 path_medium;             // absorption of the medium the ray is in (camera's: clear)
vec3 path_direct, path_indirect, path_caustic;
vec3 path_albedo_aov, path_normal_aov;
float path_coverage, path_depth_aov;
float path_previous_pdf;
float path_cone_distance;     // along the camera's ray cone while on it (camera.glsl)
uint path_depth;              // the vertex the next hit is
uint path_region;
uint path_shadow_region;      // where this vertex's light samples count (deferred shadows)
bool path_valid;              // false: a non-finite value met; the sample is discarded
bool path_caustic_chain;
bool path_previous_specular;  // the camera counts: emission it sees is not light-sampled
bool path_on_camera_cone;     // only specular bounces so far: textures filtered by the cone
bool path_aov_recorded;
uint path_rays;               // rays this path cast (the megakernel's count)
Sampler path_samples;

void path_add(vec3 value, uint region, bool caustic_chain)
{
    if (region != REGION_BEYOND) {
        path_direct += value;
    } else {
        path_indirect += value;
        if (caustic_chain)
            path_caustic += value;
    }
}

// The camera ray of pixel's sample sample_index.
void path_begin(uvec2 pixel, uint sample_index)
{
    CameraRay ray = camera_sample_ray(pixel, sample_index, path_samples);
    path_origin = ray.origin;
    path_direction = ray.direction;
    path_throughput = vec3(1.0);
    path_medium = vec3(0.0);
    path_direct = vec3(0.0);
    path_indirect = vec3(0.0);
    path_caustic = vec3(0.0);
    path_albedo_aov = vec3(0.0);
    path_normal_aov = vec3(0.0);
    path_coverage = 0.0;
    path_depth_aov = 0.0;
    path_previous_pdf = 0.0;
    path_cone_distance = 0.0;
    path_depth = 0u;
    path_region = REGION_BEFORE_DIFFUSE;
    path_shadow_region = REGION_AT_DIFFUSE;
    path_valid = true;
    path_caustic_chain = false;
    path_previous_specular = true;
    path_on_camera_cone = true;
    path_aov_recorded = false;
    path_rays = 0u;
}

// The path's vertex at hit, the answer to path_origin + t path_direction:
// emission, next-event estimation, the next direction and roulette. Returns
// whether the path goes on (its next ray in path_origin, path_direction).
bool path_vertex(BihHit hit)
{
    if (hit.triangle == NO_HIT || path_depth >= params.max_path_depth)
        return false;
    float ray_offset = params.camera_right.w;
    vec3 direction = path_direction;
    path_throughput *= medium_transmittance(path_medium, hit.t);
    path_cone_distance += hit.t;
    vec2 cone = camera_cone(params.camera_forward.w, params.image_height, camera_orthographic());
    Surface surface = surface_at_cone(
        hit, path_origin, direction,
        path_on_camera_cone ? cone.x + path_cone_distance * cone.y : 0.0);
    // A non-finite shading normal poisons the sample (discarded and
    // counted, never silently repaired).
    if (!surface.valid) {
        path_valid = false;
        return false;
    }
    Material material = surface.material;
    vec3 geometric_normal = surface.geometric_normal;
    vec3 shading_normal = surface.shading_normal;
    vec3 position = surface.position;
    uint depth = path_depth;
    if (depth == 0u) {
        path_coverage = 1.0;
        path_depth_aov = hit.t;
    }

    if (material_emits(material, surface.front)) {
        float weight = 1.0;
        if (!path_previous_specular)
            weight = emission_mis_weight(surface.pick_emission, surface.face_normal, direction,
                                         hit.t, path_previous_pdf);
        path_add(path_throughput * material.emission * weight, path_region,
                 path_caustic_chain);
    }

    // Light reaching vertex `depth` scattered `depth` times after the first
    // surface (vertex 0): past params.max_bounces only the emission just
    // added (the BSDF half of the previous vertex's light sample) counts.
    if (depth > params.max_bounces)
        return false;

    // A vertex with a rough lobe estimates direct light as a D vertex; the
    // lobe the path then samples decides whether it continues as D or S.
    bool rough = material_has_rough_lobe(material);
    uint diffuse_region = path_region == REGION_BEFORE_DIFFUSE ? REGION_AT_DIFFUSE : REGION_BEYOND;
    if (rough && !path_aov_recorded) {
        path_aov_recorded = true;
        path_albedo_aov = material.albedo;
        path_normal_aov = shading_normal;
    }

    vec3 wo = -direction;
    vec3 surface_origin = position + ray_offset * geometric_normal;
    vec4 light_xi = sampler_next_4d(path_samples);
    path_shadow_region = diffuse_region;
    if (rough)
        path_add(direct_light(material, position, surface_origin, wo, shading_normal,
                              geometric_normal, surface.front, path_throughput, light_xi, 1.0,
                              DIRECT_LIGHT_SAMPLES, path_rays),
                 diffuse_region, false);

    vec4 bsdf_xi = sampler_next_4d(path_samples);
    BsdfSample scattered = bsdf_sample(material, wo, shading_normal, geometric_normal,
                                       surface.front, bsdf_xi.xyz, TRANSPORT_RADIANCE);
    if (!scattered.specular) {
        path_region = diffuse_region;
        path_caustic_chain = false;
    } else if (path_region != REGION_BEFORE_DIFFUSE) {
        path_caustic_chain = path_region == REGION_AT_DIFFUSE ? true : path_caustic_chain;
        path_region = REGION_BEYOND;
    }
    path_throughput *= scattered.weight;
    if (!all_finite(path_throughput)) {
        path_valid = false;
        return false;
    }
    if (!any(greaterThan(path_throughput, vec3(0.0))))
        return false;
    path_previous_specular = scattered.specular;
    path_on_camera_cone = path_on_camera_cone && scattered.specular;
    path_previous_pdf = scattered.pdf;
    path_origin =
        position + (scattered.transmitted ? -ray_offset : ray_offset) * geometric_normal;
    path_direction = scattered.direction;
    if (scattered.transmitted)
        path_medium = medium_after_transmission(material, surface.front);
    path_depth = depth + 1u;
    if (depth + 1u >= RR_START_DEPTH) {
        float survival =
            min(1.0, max(path_throughput.r, max(path_throughput.g, path_throughput.b)) /
                         RR_THRESHOLD);
        if (bsdf_xi.w >= survival)
            return false;
        path_throughput /= survival;
    }
    return path_depth < params.max_path_depth;
}

// Adds the finished path to the film's sums at pixel_index (sample_index 0
// starts them); a sample with a non-finite value adds nothing and is counted.
void path_finish(uint pixel_index, uint sample_index)
{
    bool kept = path_valid && all_finite(path_direct) && all_finite(path_indirect) &&
                all_finite(path_caustic) && all_finite(path_albedo_aov) &&
                all_finite(path_normal_aov) && !isnan(path_depth_aov) && !isinf(path_depth_aov);
    uint main_index = 3u * pixel_index;
    vec4 direct_sum = kept ? vec4(path_direct, path_coverage) : vec4(0.0);
    vec4 indirect_sum = kept ? vec4(path_indirect, 1.0) : vec4(0.0);
    vec4 caustic_sum = kept ? vec4(path_caustic, 0.0) : vec4(0.0);
    if (sample_index > 0u) {
        direct_sum += film[main_index];
        indirect_sum += film[main_index + 1u];
        caustic_sum += film[main_index + 2u];
    }
    film[main_index] = direct_sum;
    film[main_index + 1u] = indirect_sum;
    film[main_index + 2u] = caustic_sum;
    if (WRITE_AOVS) {
        uint aov_index = 2u * pixel_index;
        vec4 albedo_depth = kept ? vec4(path_albedo_aov, path_depth_aov) : vec4(0.0);
        vec4 normal_sum = kept ? vec4(path_normal_aov, 0.0) : vec4(0.0);
        if (sample_index > 0u) {
            albedo_depth += film_aov[aov_index];
            normal_sum += film_aov[aov_index + 1u];
        }
        film_aov[aov_index] = albedo_depth;
        film_aov[aov_index + 1u] = normal_sum;
    }
    if (!kept)
        atomicAdd(counters.discarded_samples, 1u);
}

#endif
