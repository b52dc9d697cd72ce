#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` integrator's `shade` stage (core/render/frame_final.c drives
// it): direct light, caustics from the caustic map and indirect light by
// final gather into the global map. One pixel sample is four or five
// dispatches: this kernel's, final_caustic.comp's where the pass has a
// caustic map, final_gather.comp's, final_deferred.comp's and
// final_resolve.comp's (final_shared.glsl holds what they share). Each is a kernel of its own
// rather than a specialisation of one module: lavapipe translates and
// optimises a pipeline's whole SPIR-V module before specialisation removes
// anything, which cost every process ~0.5 s per pipeline of the module that
// held all four.
//
// Where the device is the CPU, the host traces the camera rays and the gather
// rays' first segments, band by band (host_rays.glsl's TRACE_STEP): per band,
// camera_rays.comp writes the camera rays, this kernel shades their hits
// (HITS_GIVEN); the gather writes its rays, then gathers with their hits.
//
// The primary (this kernel): a camera ray through the
//   pixel filter (pixel_filter.glsl), specular chain (bsdf_sample through
//   mirrors and glass, smooth or rough) to the first vertex D₁ estimated
//   there (a diffuse base, a rough lobe or a sharp metal:
//   material_estimated_at_d1), at most params.max_specular_depth specular
//   vertices; emission seen on the way and direct light at D₁
//   (direct_light.glsl, the reference's NEE, MIS-weighted against the gather
//   rays that may hit the same emitter) and at every non-delta vertex of the
//   chain (rough glass, MIS-weighted against the chain's next ray) go to
//   `direct`. D₁ is written to the vertex record for the caustic dispatch
//   and the gather.
// final_caustic.comp (caustic grid bound; only for passes with a caustic
//   map): the caustic estimate at D₁ (directional albedo/π × caustic
//   irradiance) into `caustic` and `indirect`.
// final_gather.comp (global grid bound): push.gather_count of the sample's
//   push.gather_total cosine-distributed gather rays from D₁ per dispatch.
//   At a gather ray's first diffuse hit x₂: albedo/π × global-map irradiance,
//   into `indirect`, read from the nearest precomputed irradiance point
//   (Christensen 1999; photon_irradiance_lookup) when one with an agreeing
//   normal lies within the radius, else estimated from the photons. The global map holds every diffuse hit, first hits
//   included (Jensen 2001, §9.3), so x₂'s direct light comes from photons
//   too: next-event estimation there had no MIS partner (nothing else
//   samples emitters from x₂), and its weight cos·cos·A/d² had no bound
//   where x₂ lies close to an emitter (a lamp against a wall), which put
//   single gather rays hundreds of times above the converged pixel (issue
//   16's fireflies); a density estimate over a fixed radius is bounded. Gather rays
//   follow mirrors and glass for at most GATHER_MAX_SPECULAR vertices and
//   are dropped (counted in counters.gather_dropped) beyond; emission a
//   gather ray sees after a specular vertex is left out (L S+ D₁ is the
//   caustic map's), emission it hits straight from D₁ is the BSDF half of
//   the direct-light MIS.
// final_deferred.comp (global grid bound): the estimates
//   from the photons that the gather deferred, one per invocation. A lookup
//   that finds no point (~5 % of them on the Cornell box) needs a full
//   estimate, ~20 times a lookup's work; done in the gather, every 8-lane
//   SIMD group with one such lane (a third of them) ran it for all 8. So
//   the gather appends them to fallback_requests and that dispatch runs
//   them with full lanes, writing each result over its request. Past
//   push.fallback_capacity the gather marks the ray OVERFLOW_REQUEST and
//   final_gather_estimate.comp traces it again with its estimate in place
//   (a dispatch only for samples that overflowed); when no points are bound
//   final_gather_estimate.comp is the gather (final_gather.glsl).
// final_resolve.comp (per pixel): adds the sample's
//   deferred estimates (pixel_fallbacks names them) and the sample to the
//   film.
//
// Loop cap (lavapipe): llvmpipe ends every loop of an invocation after
// 65,535 iterations in total, silently. Bounded by design: one camera path
// (at most params.max_specular_depth + 1 vertices) per primary invocation,
// one caustic estimate per caustic invocation, push.gather_count (4) gather rays per
// gather invocation, each estimate stopping itself after
// PHOTON_ESTIMATE_MAX_ITERATIONS (final_shared.glsl). Detected either way: an estimate
// that stopped says so (photon_irradiance_guarded/_knn), and each
// invocation proves its loops were not cut by running, at its very end,
// one iteration of a loop bounded by a push constant (push.loop_sentinel =
// 1): after the cap that loop runs zero times. Either drops the sample and
// counts it (counters.loop_truncated); the host reports it and fails the
// frame above 1% of samples, never a silent bias.
//
// Records (one per pixel, rewritten by every sample):
//   vertices[3p]      (D₁ position, gather from it: 0 no, 1 yes)
//   vertices[3p + 1]  (shading normal, triangle index bits)
//   vertices[3p + 2]  (geometric normal, D₁ found: 0 no, 1 yes)
//   vertex_weights[2p]     (throughput up to D₁, barycentric u)
//   vertex_weights[2p + 1] (wo at D₁, barycentric v)
// (two buffers, each no larger than the film, so that final renders every image size
// the other presets do where the device's storage-buffer range is small: a 1920x1080
// record of 5 vec4 a pixel is 158 MiB, past lavapipe's 128)
// (the triangle and barycentrics give the deferred passes D₁'s textured material:
// scene_material_at)
//   sample_sums[3p]   (direct, coverage), (indirect, kept 1/0), (caustic, 0)
// Film (sums over samples, reference layout): film[3p..3p+2] as the
// sample, film_aov[2p] (albedo, depth), film_aov[2p + 1] (normal, samples
// with an AOV).

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"
#include "final_shared.glsl"

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "host_rays.glsl"
#include "camera_sample.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"

#include "direct_light.glsl"

#include "kernel_guard.glsl"
#include "ray_count.glsl"

void primary(uint pixel_index, uvec2 pixel)
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    float ray_offset = params.camera_right.w;
    Sampler samples;
    CameraRay ray = camera_sample_ray(pixel, push.sample_index, samples);
    vec3 origin = ray.origin;
    vec3 direction = ray.direction;
    vec3 throughput = vec3(1.0);
    vec3 direct = vec3(0.0);
    float coverage = 0.0, depth_aov = 0.0;
    vec3 albedo_aov = vec3(0.0), normal_aov = vec3(0.0);
    bool valid = true;
    uint rays = 0u;
    uint base = 3u * pixel_index, weight_base = 2u * pixel_index;
    vertices[base] = vec4(0.0);
    vertices[base + 2u] = vec4(0.0);
    if (push.sample_index == 0u)
        caustic_radii[pixel_index] = push.radius; // no first diffuse vertex yet: the pass radius

    vec3 medium = vec3(0.0); // absorption of the medium the ray travels in
    // The camera's ray cone along its specular chain (camera.glsl).
    vec2 cone = camera_cone(params.camera_forward.w, params.image_height, camera_orthographic());
    float cone_distance = 0.0;
    // The BSDF half of the direct light's MIS at a sharp vertex passed through (below): the
    // pdf of the ray traced next (0: a delta choice, emission it finds has full weight).
    float bsdf_pdf = 0.0;
    bool aov_recorded = false;
    for (uint depth = 0u; depth <= params.max_specular_depth; depth++) {
        BihHit hit;
        if (TRACE_STEP == HITS_GIVEN && depth == 0u) {
            hit = trace_after(host_hit(camera_slot(pixel_index)), origin, direction, infinity,
                              false, true); // traced and counted there
        } else {
            hit = trace_seen(origin, direction, infinity, false, depth == 0u);
            rays++;
        }
        if (hit.triangle == NO_HIT)
            break;
        throughput *= medium_transmittance(medium, hit.t);
        cone_distance += hit.t;
        Surface surface =
            surface_at_cone(hit, origin, direction, cone.x + cone_distance * cone.y);
        if (!surface.valid) {
            valid = false;
            break;
        }
        Material material = surface.material;
        if (depth == 0u) {
            coverage = 1.0;
            depth_aov = hit.t;
        }
        // Seen from the camera or through delta vertices only, no light sampling reaches
        // it: full weight. Through a sharp lobe, the BSDF half of that vertex's MIS.
        if (material_emits(material, surface.front))
            direct += throughput * material.emission *
                      (bsdf_pdf > 0.0 ? emission_mis_weight(surface.pick_emission,
                                                            surface.face_normal, direction,
                                                            hit.t, bsdf_pdf)
                                      : 1.0);
        vec3 wo = -direction;
        // D₁: a surface with a diffuse base or a rough lobe, or a metal sharper than
        // GLOSSY_ROUGHNESS (pf_scene.h; material_estimated_at_d1), whose gather rays then
        // sample its lobe: many directions a sample where one camera ray would be one.
        // Mirrors and glass, smooth or rough, are passed through by sampling, with
        // next-event estimation at any non-delta lobe: one call site, which llvmpipe
        // inlines with its trace (direct_light.glsl).
        bool d1 = material_estimated_at_d1(material);
        bool lit = d1 || material_has_rough_lobe(material);
        if (lit && !aov_recorded) {
            aov_recorded = true;
            albedo_aov = material.albedo;
            normal_aov = surface.shading_normal;
        }
        // D₁'s MIS partners are its gather rays; a vertex passed through has the next ray
        // of this loop, where one follows.
        float bsdf_rays = d1 ? float(push.gather_total)
                             : (depth < params.max_specular_depth ? 1.0 : 0.0);
        vec3 surface_origin = surface.position + ray_offset * surface.geometric_normal;
        if (lit)
            direct += direct_light(material, surface.position, surface_origin, wo,
                                   surface.shading_normal, surface.geometric_normal,
                                   surface.front, throughput, sampler_next_4d(samples),
                                   bsdf_rays, DIRECT_LIGHT_PIXEL_SAMPLES, rays);
        if (d1) {
            vertices[base] = vec4(surface.position, push.gather_total > 0u ? 1.0 : 0.0);
            vertices[base + 1u] = vec4(surface.shading_normal, uintBitsToFloat(hit.triangle));
            vertices[base + 2u] = vec4(surface.geometric_normal, 1.0); // w: D₁ found
            vertex_weights[weight_base] = vec4(throughput, hit.u);
            vertex_weights[weight_base + 1u] = vec4(wo, hit.v);
            break;
        }
        BsdfSample scattered = bsdf_sample(material, wo, surface.shading_normal,
                                           surface.geometric_normal, surface.front,
                                           sampler_next_4d(samples).xyz, TRANSPORT_RADIANCE);
        bsdf_pdf = bsdf_rays > 0.0 && !scattered.specular ? scattered.pdf : 0.0;
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

    bool completed = loops_completed();
    if (!completed)
        atomicAdd(counters.loop_truncated, 1u);
    bool kept = completed && valid && all_finite(direct);
    uint sample_base = 3u * pixel_index;
    sample_sums[sample_base] = vec4(direct, coverage);
    // Caustic light (final_caustic.comp, where a caustic map is bound) adds to the next two.
    sample_sums[sample_base + 1u] = vec4(vec3(0.0), kept ? 1.0 : 0.0);
    sample_sums[sample_base + 2u] = vec4(0.0);
    if (!kept)
        vertices[base].w = 0.0;
    bool aov_kept = kept && all_finite(albedo_aov) && all_finite(normal_aov) &&
                    !isnan(depth_aov) && !isinf(depth_aov);
    uint aov_index = 2u * pixel_index;
    vec4 albedo_depth = aov_kept ? vec4(albedo_aov, depth_aov) : vec4(0.0);
    vec4 normal_sum = aov_kept ? vec4(normal_aov, 1.0) : vec4(0.0);
    if (push.sample_index > 0u) {
        albedo_depth += texel_vec4(film_aov_texels, aov_index);
        normal_sum += texel_vec4(film_aov_texels, aov_index + 1u);
    }
    film_aov[aov_index] = albedo_depth;
    film_aov[aov_index + 1u] = normal_sum;
    count_rays(rays);
}

void main()
{
    uvec2 pixel = band_pixel();
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    primary(pixel.y * params.width + pixel.x, pixel);
}
