#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Reference integrator (the `shade` stage of the reference preset): an
// unbiased unidirectional path tracer. One dispatch adds one sample to every
// pixel of the image (a progressive pass); the host divides the sums.
//
// Per sample: a camera ray through a point drawn from the pixel filter
// (params.pixel_filter, pixel_filter.glsl), then at every vertex
//   - emission of a hit emitter (material_emits), weighted by MIS against light sampling
//     (power heuristic) unless the previous vertex was specular or the camera;
//   - at vertices with a rough (non-delta) lobe, next-event estimation
//     through the full BSDF: one emissive triangle picked
//     by power (MIS-weighted) and every punctual light (no MIS: a delta
//     light is reachable only this way), each with an any-hit shadow ray;
//   - a direction from bsdf_sample (materials.glsl); Russian roulette from the
//     RR_START_DEPTH-th bounce on, survival from the throughput (below);
//   - inside a transmissive material's volume (KHR_materials_volume), each
//     segment's Beer-Lambert transmittance;
//   - at most params.max_path_depth vertices, and light of at most
//     params.max_bounces bounces after the first surface (--max-bounces).
// Random numbers: shuffled Owen-scrambled Sobol, two 4D groups per vertex
// (light sample; BSDF direction, glass choice, roulette) after one for the
// camera.
//
// Light is split by path (E camera, S specular vertex, D diffuse vertex,
// L light; a vertex is S or D by the lobe its path sampled there, delta or
// not), counting vertices from the camera; D₁ is the first diffuse vertex:
//   direct    L S* E, and L D₁ S* E: emission seen directly or through
//             specular chains, and light arriving at D₁ straight from a light
//   indirect  everything else: light that scattered at least once more after
//             leaving the light before reaching D₁
//   caustic   the part of indirect with only specular vertices between the
//             light and D₁: L S+ D₁ S* E (caustics from punctual lights have
//             zero probability for a path tracer; only area lights make them)
// so beauty = direct + indirect and caustic ⊆ indirect.
//
// Film (sums over the samples so far), per pixel:
//   film[3p]       (direct RGB, coverage)
//   film[3p + 1]   (indirect RGB, kept samples)
//   film[3p + 2]   (caustic RGB, 0)
//   film_aov[2p]   (albedo RGB of the first diffuse hit, camera-ray depth)
//   film_aov[2p+1] (normal XYZ there, facing the camera ray, 0)
// A sample whose values are not all finite (or whose path met a non-finite
// shading normal) adds nothing anywhere and is counted in
// counters.discarded_samples; the pixel averages over its kept samples.

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool WRITE_AOVS = true;

layout(push_constant) uniform Push {
    uint sample_index; // 0 starts the film's sums
} push;

#include "scene_bindings.glsl"
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer FilmAov { vec4 film_aov[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 2) buffer Counters {
    uint discarded_samples;
    uint traversal_failures; // rays whose BIH traversal overflowed: the host fails the frame
    uint rays_low;           // rays traced, a 64-bit count in two words
    uint rays_high;
} counters;

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "camera.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"

// Russian roulette starts after this many bounces (issue 5), and then only
// once the path throughput (including earlier roulette divisions) falls
// below RR_THRESHOLD: survival = min(1, max component / RR_THRESHOLD), so a
// surviving path continues with throughput about RR_THRESHOLD instead of
// about 1. With a threshold of 1 (pbrt-v4) a bright closed scene pays for
// every termination with a full unit of variance (white furnace at albedo
// 0.8: per-sample σ ≈ 0.46·L); at 0.1 the tail's variance is 100× smaller
// for a few more vertices per path.
const uint RR_START_DEPTH = 3u;
const float RR_THRESHOLD = 0.1;

// Where the path stands relative to its first diffuse vertex D₁ (above).
const uint REGION_BEFORE_DIFFUSE = 0u; // no diffuse vertex yet
const uint REGION_AT_DIFFUSE = 1u;     // the last vertex is D₁
const uint REGION_BEYOND = 2u;         // past D₁


#include "direct_light.glsl"

struct Radiance {
    vec3 direct;
    vec3 indirect;
    vec3 caustic;
};

void radiance_add(inout Radiance radiance, vec3 value, uint region, bool caustic_chain)
{
    if (region != REGION_BEYOND) {
        radiance.direct += value;
    } else {
        radiance.indirect += value;
        if (caustic_chain)
            radiance.caustic += value;
    }
}

void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    uint pixel_index = pixel.y * params.width + pixel.x;
    float ray_offset = params.camera_right.w;
    Sampler samples = sampler_init(pixel_index, push.sample_index, params.seed_lo, params.seed_hi);

    vec4 camera_xi = sampler_next_4d(samples);
    vec2 film_position = vec2(pixel) + 0.5 + filter_sample(params.pixel_filter, camera_xi.xy);
    vec3 origin = params.camera_position.xyz;
    vec3 direction = camera_ray_direction(params.camera_forward.xyz, params.camera_right.xyz,
                                          params.camera_up.xyz, params.camera_position.w,
                                          params.camera_forward.w, film_position,
                                          vec2(params.width, params.height));

    Radiance radiance = Radiance(vec3(0.0), vec3(0.0), vec3(0.0));
    vec3 throughput = vec3(1.0);
    bool valid = true;
    uint region = REGION_BEFORE_DIFFUSE;
    bool caustic_chain = false;
    bool previous_specular = true; // the camera: emission it sees is not light-sampled
    // The camera's ray cone while the path has bounced only specularly (camera.glsl);
    // after a rough bounce the textures are read at their finest level.
    float cone_spread = camera_cone_spread(params.camera_forward.w, params.height);
    float cone_distance = 0.0;
    bool on_camera_cone = true;
    vec3 medium = vec3(0.0);       // absorption of the medium the ray is in (camera's: clear)
    float previous_pdf = 0.0;
    float coverage = 0.0, depth_aov = 0.0;
    vec3 albedo_aov = vec3(0.0), normal_aov = vec3(0.0);
    bool aov_recorded = false;
    uint rays = 0u;

    for (uint depth = 0u; depth < params.max_path_depth; depth++) {
        BihHit hit = trace(origin, direction, infinity, false);
        rays++;
        if (hit.triangle == NO_HIT)
            break;
        throughput *= medium_transmittance(medium, hit.t);
        cone_distance += hit.t;
        Surface surface = surface_at_cone(hit, origin, direction,
                                          on_camera_cone ? cone_distance * cone_spread : 0.0);
        // A non-finite shading normal poisons the sample (discarded and
        // counted, never silently repaired).
        if (!surface.valid) {
            valid = false;
            break;
        }
        Material material = surface.material;
        vec3 face_normal = surface.face_normal;
        bool front = surface.front;
        vec3 geometric_normal = surface.geometric_normal;
        vec3 shading_normal = surface.shading_normal;
        vec3 position = surface.position;
        if (depth == 0u) {
            coverage = 1.0;
            depth_aov = hit.t;
        }

        if (material_emits(material, front)) {
            float weight = 1.0;
            if (!previous_specular)
                weight = emission_mis_weight(surface.pick_emission, face_normal, direction, hit.t,
                                             previous_pdf);
            radiance_add(radiance, throughput * material.emission * weight, region,
                         caustic_chain);
        }

        // Light reaching vertex `depth` scattered `depth` times after the first
        // surface (vertex 0): past params.max_bounces only the emission just
        // added (the BSDF half of the previous vertex's light sample) counts.
        if (depth > params.max_bounces)
            break;

        // A vertex with a rough lobe estimates direct light as a D vertex; the
        // lobe the path then samples decides whether it continues as D or S.
        bool rough = material_has_rough_lobe(material);
        uint diffuse_region = region == REGION_BEFORE_DIFFUSE ? REGION_AT_DIFFUSE : REGION_BEYOND;
        if (rough && !aov_recorded) {
            aov_recorded = true;
            albedo_aov = material.albedo;
            normal_aov = shading_normal;
        }

        vec3 wo = -direction;
        vec3 surface_origin = position + ray_offset * geometric_normal;
        vec4 light_xi = sampler_next_4d(samples);
        if (rough)
            radiance_add(radiance,
                         direct_light(material, position, surface_origin, wo, shading_normal,
                                      geometric_normal, front, throughput, light_xi, 1.0,
                                      rays),
                         diffuse_region, false);

        vec4 bsdf_xi = sampler_next_4d(samples);
        BsdfSample scattered = bsdf_sample(material, wo, shading_normal, geometric_normal, front,
                                           bsdf_xi.xyz, TRANSPORT_RADIANCE);
        if (!scattered.specular) {
            region = diffuse_region;
            caustic_chain = false;
        } else if (region != REGION_BEFORE_DIFFUSE) {
            caustic_chain = region == REGION_AT_DIFFUSE ? true : caustic_chain;
            region = REGION_BEYOND;
        }
        throughput *= scattered.weight;
        if (!all_finite(throughput)) {
            valid = false;
            break;
        }
        if (!any(greaterThan(throughput, vec3(0.0))))
            break;
        previous_specular = scattered.specular;
        on_camera_cone = on_camera_cone && scattered.specular;
        previous_pdf = scattered.pdf;
        origin = position + (scattered.transmitted ? -ray_offset : ray_offset) * geometric_normal;
        direction = scattered.direction;
        if (scattered.transmitted)
            medium = medium_after_transmission(material, front);
        if (depth + 1u >= RR_START_DEPTH) {
            float survival =
                min(1.0, max(throughput.r, max(throughput.g, throughput.b)) / RR_THRESHOLD);
            if (bsdf_xi.w >= survival)
                break;
            throughput /= survival;
        }
    }

    bool kept = valid && all_finite(radiance.direct) && all_finite(radiance.indirect) &&
                all_finite(radiance.caustic) && all_finite(albedo_aov) &&
                all_finite(normal_aov) && !isnan(depth_aov) && !isinf(depth_aov);
    uint main_index = 3u * pixel_index;
    vec4 direct_sum = kept ? vec4(radiance.direct, coverage) : vec4(0.0);
    vec4 indirect_sum = kept ? vec4(radiance.indirect, 1.0) : vec4(0.0);
    vec4 caustic_sum = kept ? vec4(radiance.caustic, 0.0) : vec4(0.0);
    if (push.sample_index > 0u) {
        direct_sum += film[main_index];
        indirect_sum += film[main_index + 1u];
        caustic_sum += film[main_index + 2u];
    }
    film[main_index] = direct_sum;
    film[main_index + 1u] = indirect_sum;
    film[main_index + 2u] = caustic_sum;
    if (WRITE_AOVS) {
        uint aov_index = 2u * pixel_index;
        vec4 albedo_depth = kept ? vec4(albedo_aov, depth_aov) : vec4(0.0);
        vec4 normal_sum = kept ? vec4(normal_aov, 0.0) : vec4(0.0);
        if (push.sample_index > 0u) {
            albedo_depth += film_aov[aov_index];
            normal_sum += film_aov[aov_index + 1u];
        }
        film_aov[aov_index] = albedo_depth;
        film_aov[aov_index + 1u] = normal_sum;
    }
    if (!kept)
        atomicAdd(counters.discarded_samples, 1u);
    uint previous_low = atomicAdd(counters.rays_low, rays);
    if (previous_low + rays < previous_low)
        atomicAdd(counters.rays_high, 1u);
}
