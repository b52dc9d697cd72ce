// The `final` shade stage's gather (render_final.comp's header describes a
// sample's dispatches), the body of two modules:
//   final_gather.comp: push.gather_count of the sample's gather rays from
//     each pixel's D₁, their light at the first diffuse hit from the bound
//     global map's irradiance points, or, where no point is near, a request
//     for final_deferred.comp's estimate; past push.fallback_capacity the
//     ray is marked OVERFLOW_REQUEST and left to the retrace below.
//   final_gather_estimate.comp (FINAL_GATHER_ESTIMATES): the same rays with
//     the estimate from the photons run in place where no point is near:
//     the whole gather when the pass has no irradiance points
//     (push.fallback_capacity 0), and with push.gather_retrace the rays the
//     gather marked OVERFLOW_REQUEST, traced again (each ray's path is fixed
//     by its pixel, sample and index), only their estimate added.
// Two modules because llvmpipe runs a block that no lane enters all the
// same (both sides of every `if`, one pass of every loop): the estimate's
// code in final_gather.comp cost ~20 % of it at 640×480 on the Cornell box
// although no ray ran it (bench/RESULTS.md).
//
// Where the host traces the gather rays' first segments (host_rays.glsl's
// TRACE_STEP), WRITE_RAYS writes them and HITS_GIVEN gathers with their hits;
// the segments after a mirror or glass, few, are traced here. gather_start
// computes a ray's first segment for both steps.
#ifndef PF_FINAL_GATHER_GLSL
#define PF_FINAL_GATHER_GLSL

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"
#include "final_shared.glsl"

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "host_rays.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"
#include "direct_light.glsl" // emission_mis_weight
#include "kernel_guard.glsl"
#include "ray_count.glsl"

// Specular vertices a gather ray follows before it is dropped: enough for
// a glass sphere (in, out) and a mirror behind it.
const uint GATHER_MAX_SPECULAR = 4u;
// Gather rays draw from their own scrambled sequence (seed_lo xor this).
const uint GATHER_SEED_SALT = 0x9e3779b9u;

// Irradiance at a gather hit from the bound global map's precomputed
// points (fixed radius, cone filter): the nearest point's; false where none
// is near (a sparsely lit spot, or a corner whose points face elsewhere),
// and the caller estimates from the photons (global_irradiance_estimate).
bool global_irradiance_lookup(vec3 position, vec3 geometric_normal, out vec3 irradiance,
                              inout bool truncated)
{
    irradiance = vec3(0.0);
    if (push.grid_photons == 0u)
        return true;
    bool stopped = false;
    bool found = push.points_count > 0u &&
                 photon_irradiance_lookup(position, geometric_normal, push.radius, bound_points(),
                                          irradiance, stopped);
    truncated = truncated || stopped;
    return found;
}

// A gather ray's first segment from D₁, its sampler left after the draw.
struct GatherStart {
    Sampler samples;
    BsdfSample first;
    vec3 path;   // its weight; zero: the ray carries nothing and is not traced
    vec3 origin;
};

GatherStart gather_start(uint pixel_index, uint gather_index, Material d1_material,
                         vec3 d1_position, vec3 shading_normal, vec3 geometric_normal,
                         vec3 d1_throughput, vec3 wo)
{
    GatherStart s;
    s.samples = sampler_init(image_pixel_index(pixel_index),
                             push.sample_index * push.gather_total + gather_index,
                             params.seed_lo ^ GATHER_SEED_SALT, params.seed_hi);
    s.first = bsdf_sample(d1_material, wo, shading_normal, geometric_normal, true,
                          sampler_next_4d(s.samples).xyz, TRANSPORT_RADIANCE);
    s.path = d1_throughput * s.first.weight / float(push.gather_total);
    s.origin = d1_position + params.camera_right.w * geometric_normal;
    return s;
}

// The slot of gather ray gather_index of pixel_index among this dispatch's (host_rays.glsl).
uint gather_slot(uint pixel_index, uint gather_index)
{
    return (pixel_index - push.row_first * params.width) * push.gather_count +
           (gather_index - push.gather_first);
}

// Radiance arriving at D₁ along one gather ray, weighted by the ray's BSDF
// factor; emission hit straight from D₁ goes to direct (MIS), the rest to indirect.
void gather_ray(uint pixel_index, uint gather_index, Material d1_material, vec3 d1_position,
                vec3 shading_normal, vec3 geometric_normal, vec3 d1_throughput, vec3 wo,
                inout vec3 direct, inout vec3 indirect, inout uint request, inout bool valid,
                inout bool truncated, inout uint rays)
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    float ray_offset = params.camera_right.w;
    GatherStart start = gather_start(pixel_index, gather_index, d1_material, d1_position,
                                     shading_normal, geometric_normal, d1_throughput, wo);
    Sampler samples = start.samples;
    BsdfSample first = start.first;
    float gather_total = float(push.gather_total);
    vec3 path = start.path;
    if (!any(greaterThan(path, vec3(0.0))))
        return;
    vec3 origin = start.origin;
    vec3 direction = first.direction;
    // Absorption of the medium the gather ray travels in: D₁ is taken to lie
    // in clear space (a floor under absorbing water gathers unattenuated).
    vec3 medium = vec3(0.0);
    for (uint bounce = 0u; bounce <= GATHER_MAX_SPECULAR; bounce++) {
        BihHit hit;
        if (TRACE_STEP == HITS_GIVEN && bounce == 0u) {
            hit = trace_after(host_hit(gather_slot(pixel_index, gather_index)), origin,
                              direction, infinity, false, false); // traced and counted there
        } else {
            hit = trace(origin, direction, infinity, false);
            rays++;
        }
        if (hit.triangle == NO_HIT)
            return;
        path *= medium_transmittance(medium, hit.t);
        Surface surface = surface_at(hit, origin, direction);
        if (!surface.valid) {
            valid = false;
            return;
        }
        Material material = surface.material;
        if (bounce == 0u && material_emits(material, surface.front)) {
            direct += path * material.emission *
                      emission_mis_weight(surface.pick_emission, surface.face_normal, direction,
                                          hit.t, gather_total * first.pdf);
        }
        vec3 wo_hit = -direction;
        if (material.kind == MATERIAL_LAMBERT) {
            // Reflected radiance: albedo/π × irradiance, in watts by the map's flux
            // scale (the directional albedo of the rough lobes towards the gather ray).
            vec3 weight = path * (material_rough_albedo(material, wo_hit,
                                                        surface.shading_normal, surface.front) *
                                  (push.flux_scale / PI));
            vec3 irradiance;
            if (global_irradiance_lookup(surface.position, surface.geometric_normal, irradiance,
                                         truncated)) {
                indirect += weight * irradiance;
                return;
            }
#ifdef FINAL_GATHER_ESTIMATES
            indirect += weight * global_irradiance_estimate(surface.position,
                                                            surface.geometric_normal, truncated);
#else
            uint slot = atomicAdd(counters.fallback_requests, 1u);
            if (slot < push.fallback_capacity) {
                fallback_requests[3u * slot] = vec4(surface.position, 0.0);
                fallback_requests[3u * slot + 1u] = vec4(surface.geometric_normal, 0.0);
                fallback_requests[3u * slot + 2u] = vec4(weight, 0.0);
                request = slot;
            } else {
                request = OVERFLOW_REQUEST;
            }
#endif
            return;
        }
        if (bounce == GATHER_MAX_SPECULAR) {
            atomicAdd(counters.gather_dropped, 1u);
            return;
        }
        BsdfSample scattered = bsdf_sample(material, wo_hit, surface.shading_normal,
                                           surface.geometric_normal, surface.front,
                                           sampler_next_4d(samples).xyz, TRANSPORT_RADIANCE);
        path *= scattered.weight;
        if (!all_finite(path)) {
            valid = false;
            return;
        }
        if (!any(greaterThan(path, vec3(0.0))))
            return;
        origin = surface.position +
                 (scattered.transmitted ? -ray_offset : ray_offset) * surface.geometric_normal;
        direction = scattered.direction;
        if (scattered.transmitted)
            medium = medium_after_transmission(material, surface.front);
    }
}

void gather(uint pixel_index)
{
    uint base = 3u * pixel_index, weight_base = 2u * pixel_index;
    uint sample_base = 3u * pixel_index;
    vec4 d1 = texel_vec4(vertex_texels, base);
    bool valid = true, truncated = false;
    uint rays = 0u;
    uvec4 requests = push.gather_first == 0u && push.gather_retrace == 0u
                         ? uvec4(NO_REQUEST)
                         : texel_uvec4(pixel_fallback_texels, pixel_index);
    if (d1.w > 0.0) {
        vec4 sample_direct = texel_vec4(sample_sum_texels, sample_base);
        vec4 sample_indirect = texel_vec4(sample_sum_texels, sample_base + 1u);
        vec4 shading = texel_vec4(vertex_texels, base + 1u);
        vec3 direct = vec3(0.0), indirect = vec3(0.0);
        vec3 geometric_normal = texel_vec4(vertex_texels, base + 2u).xyz;
        vec4 throughput_u = texel_vec4(vertex_weight_texels, weight_base);
        vec4 wo_v = texel_vec4(vertex_weight_texels, weight_base + 1u);
        vec3 throughput = throughput_u.xyz;
        vec3 wo = wo_v.xyz;
        Material material =
            scene_coat_normal(scene_material_at(floatBitsToUint(shading.w), throughput_u.w, wo_v.w),
                              floatBitsToUint(shading.w), throughput_u.w, wo_v.w, geometric_normal);
        uint end = min(push.gather_first + push.gather_count, push.gather_total);
        for (uint g = push.gather_first; g < end; g++) {
#ifdef FINAL_GATHER_ESTIMATES
            // Retrace: only the rays the gather could not defer, their estimate alone (the
            // gather added the rest of their light and checked their paths).
            if (push.gather_retrace != 0u && requests[g] != OVERFLOW_REQUEST)
                continue;
            vec3 ray_direct = vec3(0.0);
            uint request = NO_REQUEST;
            gather_ray(pixel_index, g, material, d1.xyz, shading.xyz, geometric_normal,
                       throughput, wo, ray_direct, indirect, request, valid, truncated, rays);
            if (push.gather_retrace == 0u)
                direct += ray_direct;
            requests[g] = NO_REQUEST;
#else
            uint request = NO_REQUEST;
            gather_ray(pixel_index, g, material, d1.xyz, shading.xyz, geometric_normal,
                       throughput, wo, direct, indirect, request, valid, truncated, rays);
            requests[g] = request;
#endif
        }
        bool completed = loops_completed() && !truncated;
        if (!completed)
            atomicAdd(counters.loop_truncated, 1u);
        if (!completed || !valid || !all_finite(direct) || !all_finite(indirect)) {
            sample_indirect.w = 0.0;
            vertices[base].w = 0.0;
        }
        sample_direct.xyz += direct;
        sample_indirect.xyz += indirect;
        sample_sums[sample_base] = sample_direct;
        sample_sums[sample_base + 1u] = sample_indirect;
    }
    pixel_fallbacks[pixel_index] = requests;
    count_rays(push.gather_retrace != 0u ? 0u : rays); // a retrace's rays were counted
}

// WRITE_RAYS: the first segments of the dispatch's gather rays from pixel_index's D₁,
// for the host; every slot of the pixel is written, and one without a ray (no D₁, a dropped
// sample, a zero weight, past the sample's gather rays) is marked so.
void write_rays(uint pixel_index)
{
    uint base = 3u * pixel_index, weight_base = 2u * pixel_index;
    vec4 d1 = texel_vec4(vertex_texels, base);
    uint end = push.gather_first + push.gather_count;
    if (d1.w <= 0.0 || push.gather_first >= push.gather_total) {
        for (uint g = push.gather_first; g < end; g++)
            host_ray_write(gather_slot(pixel_index, g), false, vec3(0.0), vec3(0.0));
        return;
    }
    vec4 shading = texel_vec4(vertex_texels, base + 1u);
    vec3 geometric_normal = texel_vec4(vertex_texels, base + 2u).xyz;
    vec4 throughput_u = texel_vec4(vertex_weight_texels, weight_base);
    vec4 wo_v = texel_vec4(vertex_weight_texels, weight_base + 1u);
    Material material =
        scene_coat_normal(scene_material_at(floatBitsToUint(shading.w), throughput_u.w, wo_v.w),
                          floatBitsToUint(shading.w), throughput_u.w, wo_v.w, geometric_normal);
    for (uint g = push.gather_first; g < end; g++) {
        GatherStart start = gather_start(pixel_index, g, material, d1.xyz, shading.xyz,
                                         geometric_normal, throughput_u.xyz, wo_v.xyz);
        host_ray_write(gather_slot(pixel_index, g),
                       g < push.gather_total && any(greaterThan(start.path, vec3(0.0))),
                       start.origin, start.first.direction);
    }
}

void main()
{
    uvec2 pixel = band_pixel();
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
#ifdef FINAL_GATHER_RAYS_ONLY
    write_rays(pixel.y * params.width + pixel.x); // final_gather_rays.comp: no gather's code
#else
    if (TRACE_STEP == WRITE_RAYS)
        write_rays(pixel.y * params.width + pixel.x);
    else
        gather(pixel.y * params.width + pixel.x);
#endif
}

#endif
