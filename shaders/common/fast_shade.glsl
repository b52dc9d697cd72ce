#ifndef PF_FAST_SHADE_GLSL
#define PF_FAST_SHADE_GLSL

// The `fast` integrator's `shade` stage (core/render/frame_fast.c drives
// it): one camera sample per pixel per dispatch, added to the split film of
// the reference and final integrators.
//
// A camera ray through the pixel filter (pixel_filter.glsl) follows mirrors
// and glass, smooth or rough (bsdf_sample), to the first vertex D₁ estimated
// there (a diffuse base, a rough lobe or a sharp metal:
// material_estimated_at_d1), at most params.max_specular_depth specular
// vertices.
// Emission seen on the way and direct light by next-event estimation
// (direct_light.glsl, the one estimator reference and final use) at D₁ and
// at the chain's non-delta vertices go to `direct`; where the lobe is sharp,
// the light sample is MIS-weighted against the next ray (at D₁ one that only
// looks for an emitter), else it has full weight. Indirect light at D₁
// is albedo/π × the LPV irradiance (lpv_lookup.glsl: light that left a
// diffuse surface at least once, the photon VPLs propagated through the
// cascades; scaled to the photons' energy, lpv_energy_scale_facing) plus, when a caustic map is bound, albedo/π × its k-nearest
// irradiance estimate (L S+ D₁), which also goes to `caustic`. So, as in
// the other integrators, R,G,B = direct + indirect and caustic ⊆ indirect.
//
// Two modules of this body: render_fast.comp for frames without caustic
// photons and render_fast_caustic.comp (FAST_CAUSTICS) with the estimate:
// llvmpipe runs code that no lane enters all the same, and the estimate's
// k-NN loop cost ~8 % of a Cornell box frame's shading that had no caustic
// map (bench/RESULTS.md).
//
// Loop cap: one camera path and one bounded photon estimate per
// invocation; kernel_guard.glsl's loops_completed() proves the loops ran
// whole, else the sample is dropped and counted (counters.loop_truncated).

layout(local_size_x = 8, local_size_y = 8) in;

layout(push_constant) uniform Push {
    vec3 grid_origin;
    float grid_inv_cell;
    uvec3 grid_dims;
    uint grid_hashed;
    uint grid_table_size;
    uint grid_photons;   // photons in the caustic grid (0: no caustic map)
    uint sample_index;   // 0 starts the film's sums
    uint cascade_count;  // LPV cascades (0: no indirect from the LPV)
    uint lpv_size;       // cells per axis
    float radius;        // the caustic estimate's largest radius
    float flux_scale;    // W per unit of the caustic map's stored flux
    uint loop_sentinel;  // 1 (kernel_guard.glsl)
    uint lpv_damping;    // 1: lpv_lookup.glsl's light-bleeding dampening
    uint energy_samples; // render_fast_energy.comp's surface points (0: the LPV is not scaled)
    float energy_weight; // area each point stands for over the map's flux unit (m² / W)
} push;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"

layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer FilmAov { vec4 film_aov[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 2) buffer Counters {
    uint discarded_samples; // non-finite or loop-truncated samples kept off the film
    uint traversal_failures;
    uint rays_low;
    uint rays_high;
    uint loop_truncated;
    uint lpv_outside;       // D₁ vertices no cascade held (no LPV light there)
} counters;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 6) uniform samplerBuffer lpv_cell_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 7) uniform samplerBuffer lpv_cascade_texels;
// The caustic map (photon_estimate.glsl: texel buffers).
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 8) uniform isamplerBuffer grid_records;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 9) uniform isamplerBuffer grid_ranges;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 10) uniform samplerBuffer lpv_far_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 11) uniform samplerBuffer lpv_geometry_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 12) uniform usamplerBuffer grid_flux;
// By the direction the surfaces face (d = 2 × axis + (component < 0), each point or
// arrival split by the squares of its normal's components): the photons' arrival flux (map
// units, the host's: pf_photon_maps.arrival_direction_flux) and the energy the LPV delivers
// to the points, in LPV_ENERGY_UNITS of the map's flux unit (a 64-bit sum in two words, low
// at 2d: integer sums do not depend on the order of the additions).
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 13) buffer LpvEnergy {
    float arrivals[8]; // 6 used
    uint delivered[2u * 6u];
} lpv_energy;
// The points (pf_lpv_energy_samples): xyz and 1 where double-sided; the face's normal and
// the triangle (its bits); the barycentrics u, v.
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 14) readonly buffer LpvSamples {
    vec4 lpv_samples[];
};

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "camera_sample.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"
// One estimate per invocation: most of the 65,535 loop iterations are its.
#define PHOTON_ESTIMATE_MAX_ITERATIONS 32768u
// The k-NN keeps no more neighbours than the one k asked for, CAUSTIC_NEAREST.
#define PHOTON_KNN_MAX 16u
#include "photon_estimate.glsl"
#include "lpv_sh.glsl"
#include "lpv_geometry.glsl"
#include "lpv_lookup.glsl"
#include "kernel_guard.glsl"
#include "ray_count.glsl"

// The caustic estimate's k (one photon set, no progressive passes to
// average: more neighbours than final's 8 keep the single estimate quiet).
const uint CAUSTIC_NEAREST = PHOTON_KNN_MAX;


#include "direct_light.glsl"

vec3 caustic_irradiance(vec3 position, vec3 geometric_normal, inout bool truncated)
{
#ifndef FAST_CAUSTICS
    return vec3(0.0);
#else
    if (push.grid_photons == 0u)
        return vec3(0.0);
    PhotonGrid grid = PhotonGrid(push.grid_origin, push.grid_inv_cell, push.grid_dims,
                                 push.grid_hashed, push.grid_table_size);
    bool stopped;
    float radius_used;
    vec3 irradiance = photon_irradiance_knn(position, geometric_normal, CAUSTIC_NEAREST,
                                            push.radius, grid, radius_used, stopped);
    truncated = truncated || stopped;
    return push.flux_scale * irradiance;
#endif
}

// lpv_energy's unit, 2^-8 of the map's flux unit: a point stands for about the photons'
// arrivals over the point count (each photon carries about 1 unit), and a bright point up
// to 2^24 units of the map (3 × 10^4 times the mean with 10^7 photons) still fits one add.
const float LPV_ENERGY_UNITS = 256.0;

// The scale takes light off, never adds it: where the LPV delivers less than the photons
// (a closed room, whose propagation loses some light), what it delivers is where it
// should be only in places, and making up the total brightened the walls it already lit
// right (the demo's Cornell box: indirect relMSE 0.025 unscaled, 0.038 scaled up to 4×,
// 0.024 capped at 1; bench/RESULTS.md).
const float LPV_ENERGY_SCALE_MAX = 1.0;

// The LPV's energy scale (frame_fast.c): the photons' arrival flux in the cascades over the
// flux the LPV's irradiance delivers to the surfaces there (render_fast_energy.comp), by
// the direction the surfaces face, at most 1. The propagation spreads light like a
// diffusion, and light that leaves an open floor comes back to it (an infinite lit plane
// gets a third to a half of its own light back, where the truth is none): the scale is
// below 1 in an open scene and about 1 in a closed one. By direction, a floor's own light
// is taken off the floor and not off the walls it lights (bench/RESULTS.md: indirect
// relMSE against the references, unscaled → scaled, Blender's open room 0.20 → 0.021,
// staircase2 0.086 → 0.081, the shared Cornell box 0.015 → 0.0093).
float lpv_delivered(uint d)
{
    return (float(lpv_energy.delivered[2u * d + 1u]) * 4294967296.0 +
            float(lpv_energy.delivered[2u * d])) /
           LPV_ENERGY_UNITS;
}

// The scale of the whole scene: 1 where it is not weighed or the LPV delivers nothing.
float lpv_energy_scale()
{
    if (push.energy_samples == 0u)
        return 1.0;
    float arrivals = 0.0, delivered = 0.0;
    for (uint d = 0u; d < 6u; d++) {
        arrivals += lpv_energy.arrivals[d];
        delivered += lpv_delivered(d);
    }
    return delivered > 0.0 ? min(arrivals / delivered, LPV_ENERGY_SCALE_MAX) : 1.0;
}

// The scale of a surface facing `facing`: each direction's own, weighted by the squares of
// the normal's components (whole: the scene's, for a direction the LPV delivers nothing to).
float lpv_energy_scale_facing(vec3 facing, float whole)
{
    if (push.energy_samples == 0u)
        return 1.0;
    float scale = 0.0;
    for (uint axis = 0u; axis < 3u; axis++) {
        uint d = 2u * axis + (facing[axis] < 0.0 ? 1u : 0u);
        float delivered = lpv_delivered(d);
        scale += facing[axis] * facing[axis] *
                 (delivered > 0.0 ? min(lpv_energy.arrivals[d] / delivered, LPV_ENERGY_SCALE_MAX)
                                  : whole);
    }
    return scale;
}

#ifdef FAST_ENERGY
// render_fast_energy.comp: invocation i adds the LPV's irradiance at point i, in luminance,
// times the area the point stands for, to lpv_energy, split over the directions by the
// squares of the face's normal: the flux the LPV delivers to the diffuse surfaces its
// cascades hold. A double-sided surface counts its brighter face, with that face's normal,
// as a photon's arrival counts the face it reached: the LPV's light that leaks through a
// wall to its unlit face, where no photon arrives, is not counted as delivered (summing
// both faces put staircase2's indirect light at 0.82 of the reference, the brighter face at
// 1.00), and a wall whose normal faces away from its light, which a double-sided material
// hides in exported files, still counts the face that is lit.
void main()
{
    uint i = gl_WorkGroupID.x * (gl_WorkGroupSize.x * gl_WorkGroupSize.y) +
             gl_LocalInvocationIndex;
    if (i >= push.energy_samples)
        return;
    vec4 point = lpv_samples[3u * i];
    vec4 face = lpv_samples[3u * i + 1u];
    vec2 barycentrics = lpv_samples[3u * i + 2u].xy;
    vec3 normal = face.xyz;
    // Where an alpha test cuts the surface away photons pass and arrive nowhere, and the
    // LPV's light there is not delivered either (leaves of a masked texture count their
    // opaque part); the ray the test hashes is the point's own, along its normal.
#ifdef PF_SURFACE_TEXTURES
    if (SCENE_HAS_ALPHA && !scene_alpha_passes(floatBitsToUint(face.w), barycentrics.x,
                                               barycentrics.y, point.xyz, normal, false))
        return;
#endif
    bool covered;
    vec3 irradiance = lpv_irradiance(point.xyz, normal, push.cascade_count, push.lpv_size,
                                     push.lpv_damping != 0u, covered);
    if (point.w != 0.0) {
        vec3 back = lpv_irradiance(point.xyz, -normal, push.cascade_count, push.lpv_size,
                                   push.lpv_damping != 0u, covered);
        if (light_luminance(back) > light_luminance(irradiance)) {
            irradiance = back;
            normal = -normal;
        }
    }
    float flux = min(light_luminance(irradiance) * push.energy_weight, 16777215.0);
    if (!(flux > 0.0))
        return;
    for (uint axis = 0u; axis < 3u; axis++) {
        uint units = uint(flux * normal[axis] * normal[axis] * LPV_ENERGY_UNITS + 0.5);
        uint d = 2u * axis + (normal[axis] < 0.0 ? 1u : 0u);
        if (units == 0u)
            continue;
        uint before = atomicAdd(lpv_energy.delivered[2u * d], units);
        if (before + units < before) // the low word wrapped: carry
            atomicAdd(lpv_energy.delivered[2u * d + 1u], 1u);
    }
}
#else
void main()
{
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    uint pixel_index = pixel.y * params.width + pixel.x;
    const float infinity = uintBitsToFloat(0x7f800000u);
    float ray_offset = params.camera_right.w;
    Sampler samples;
    CameraRay ray = camera_sample_ray(pixel, push.sample_index, samples);
    vec3 origin = ray.origin;
    vec3 direction = ray.direction;
    vec3 throughput = vec3(1.0);
    vec3 direct = vec3(0.0), indirect = vec3(0.0), caustic = vec3(0.0);
    float coverage = 0.0, depth_aov = 0.0;
    vec3 albedo_aov = vec3(0.0), normal_aov = vec3(0.0);
    bool valid = true, truncated = false;
    uint rays = 0u;

    vec3 medium = vec3(0.0); // absorption of the medium the ray travels in
    // The camera's ray cone along its specular chain (camera.glsl).
    vec2 cone = camera_cone(params.camera_forward.w, params.image_height, camera_orthographic());
    float cone_distance = 0.0;
    // The BSDF half of the direct light's MIS where a vertex's lobe is sharp (below): the
    // pdf of the ray the loop traces next (0: a delta choice, or no light sampled at the
    // vertex, so emission it finds has full weight). At a glossy D₁ that ray only looks
    // for an emitter (emitter_probe), so no trace call is added.
    float bsdf_pdf = 0.0;
    bool emitter_probe = false;
    bool aov_recorded = false;
    float lpv_scale = push.cascade_count > 0u ? lpv_energy_scale() : 1.0;
    for (uint depth = 0u; depth <= params.max_specular_depth; depth++) {
        BihHit hit = trace_seen(origin, direction, infinity, false, depth == 0u);
        rays++;
        if (hit.triangle == NO_HIT)
            break;
        throughput *= medium_transmittance(medium, hit.t);
        cone_distance += hit.t;
        Surface surface =
            surface_at_cone(hit, origin, direction, cone.x + cone_distance * cone.y);
        if (!surface.valid) {
            valid = !emitter_probe && valid;
            break;
        }
        Material material = surface.material;
        if (depth == 0u) {
            coverage = 1.0;
            depth_aov = hit.t;
        }
        if (material_emits(material, surface.front))
            direct += throughput * material.emission *
                      (bsdf_pdf > 0.0 ? emission_mis_weight(surface.pick_emission,
                                                            surface.face_normal, direction,
                                                            hit.t, bsdf_pdf)
                                      : 1.0);
        if (emitter_probe)
            break;
        vec3 wo = -direction;
        // Estimated here: a diffuse base, a rough lobe or a sharp metal (its highlights by
        // the light sampling's MIS below, its caustic photons, and the LPV's diffuse light
        // times its directional albedo, as documented: following one ray through it a
        // sample, as `final`'s gather rays do many, left the Blender room's gold and chrome
        // with single-pixel reflections of the lamp at 2 spp, relMSE against Cycles 0.109
        // where this gives 0.064). Mirrors and glass, smooth or rough, are passed through by
        // sampling, with the direct light of any non-delta lobe.
        bool estimated = material_estimated_at_d1(material);
        bool lit = estimated || material_has_rough_lobe(material);
        if (lit && !aov_recorded) {
            aov_recorded = true;
            albedo_aov = material.albedo;
            normal_aov = surface.shading_normal;
        }
        // Next-event estimation, with MIS against the next BSDF ray where the lobe is sharp:
        // light sampling alone through a lobe of roughness 0.05 leaves fireflies thousands
        // of times the pixel's value (bench/RESULTS.md, "Textures"). A diffuse or rough
        // surface keeps NEE alone (a BSDF ray more per sample changed the Cornell box's
        // error by less than 0.1%). At the last vertex no ray follows: NEE alone.
        bool sharp = !estimated || (material.roughness < GLOSSY_ROUGHNESS &&
                                    (material.metallic > 0.0 || material.specular > 0.0));
        bool mis = params.emissive_count > 0u && depth < params.max_specular_depth && sharp;
        vec3 surface_origin = surface.position + ray_offset * surface.geometric_normal;
        if (lit)
            direct += direct_light(material, surface.position, surface_origin, wo,
                                   surface.shading_normal, surface.geometric_normal,
                                   surface.front, throughput, sampler_next_4d(samples),
                                   mis ? 1.0 : 0.0, DIRECT_LIGHT_PIXEL_SAMPLES, rays);
        vec4 bsdf_xi = sampler_next_4d(samples);
        if (estimated) {
            vec3 reflectance = throughput *
                               material_rough_albedo(material, wo, surface.shading_normal,
                                                     surface.front) / PI;
            if (push.cascade_count > 0u) {
                bool covered;
                indirect += lpv_energy_scale_facing(surface.geometric_normal, lpv_scale) *
                            reflectance *
                            lpv_irradiance(surface.position, surface.shading_normal,
                                           push.cascade_count, push.lpv_size,
                                           push.lpv_damping != 0u, covered);
                if (!covered)
                    atomicAdd(counters.lpv_outside, 1u);
            }
            caustic = reflectance * caustic_irradiance(surface.position, surface.geometric_normal,
                                                       truncated);
            indirect += caustic;
            if (!mis)
                break;
        }
        BsdfSample scattered = bsdf_sample(material, wo, surface.shading_normal,
                                           surface.geometric_normal, surface.front,
                                           bsdf_xi.xyz, TRANSPORT_RADIANCE);
        // A delta choice has no MIS partner: its light is not light-sampled either.
        bsdf_pdf = mis && !scattered.specular ? scattered.pdf : 0.0;
        if (estimated) {
            // The probe: only the emission of the glossy lobe's direction.
            if (!(bsdf_pdf > 0.0) || scattered.transmitted)
                break;
            emitter_probe = true;
        }
        throughput *= scattered.weight;
        if (!all_finite(throughput)) {
            valid = false;
            break;
        }
        if (!any(greaterThan(throughput, vec3(0.0))))
            break;
        origin = surface.position +
                 (scattered.transmitted ? -ray_offset : ray_offset) * surface.geometric_normal;
        if (scattered.transmitted)
            medium = medium_after_transmission(material, surface.front);
        direction = scattered.direction;
    }

    bool completed = loops_completed() && !truncated;
    if (!completed)
        atomicAdd(counters.loop_truncated, 1u);
    bool kept = completed && valid && all_finite(direct) && all_finite(indirect);
    uint film_base = 3u * pixel_index;
    vec4 direct_sum = kept ? vec4(direct, coverage) : vec4(0.0);
    vec4 indirect_sum = kept ? vec4(indirect, 1.0) : vec4(0.0);
    vec4 caustic_sum = kept ? vec4(caustic, 0.0) : vec4(0.0);
    bool aov_kept = kept && all_finite(albedo_aov) && all_finite(normal_aov) &&
                    !isnan(depth_aov) && !isinf(depth_aov);
    vec4 albedo_depth = aov_kept ? vec4(albedo_aov, depth_aov) : vec4(0.0);
    vec4 normal_sum = aov_kept ? vec4(normal_aov, 1.0) : vec4(0.0);
    uint aov_index = 2u * pixel_index;
    if (push.sample_index > 0u) {
        direct_sum += film[film_base];
        indirect_sum += film[film_base + 1u];
        caustic_sum += film[film_base + 2u];
        albedo_depth += film_aov[aov_index];
        normal_sum += film_aov[aov_index + 1u];
    }
    film[film_base] = direct_sum;
    film[film_base + 1u] = indirect_sum;
    film[film_base + 2u] = caustic_sum;
    film_aov[aov_index] = albedo_depth;
    film_aov[aov_index + 1u] = normal_sum;
    if (!kept)
        atomicAdd(counters.discarded_samples, 1u);
    count_rays(rays);
}
#endif

#endif
