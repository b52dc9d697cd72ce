// Direct light at a diffuse vertex by next-event estimation: the one
// estimator the reference path tracer and the final-gather integrator share
// (pbrt-v4 SampleLd, with the light set of this project).
//
// One emissive triangle picked by power (area_lights.glsl) with a
// power-heuristic MIS weight against bsdf_sample_count BSDF-sampled rays
// that may hit the same light (Veach 1997, multi-sample form: weights
// (n_i p_i)² / Σ (n_k p_k)²); bsdf_sample_count 0 means no BSDF ray looks
// for emission, so the light sample carries full weight. Every punctual
// light is added without MIS (a delta light is reachable only this way).
// Past DIRECT_LIGHTS_EVERY_MAX punctual lights, the vertex instead resamples
// light_samples of them (light_resample), so that its work does not grow with
// the lights.
// Each candidate with a non-zero contribution casts one any-hit shadow ray;
// where the including shader defines PF_DEFERRED_SHADOWS (the wavefront), it
// hands the ray and its contribution to
//   void shadow_ray_defer(vec3 origin, vec3 direction, float tmax, vec3 contribution)
// instead, to be traced later, and the returned sum leaves them out.
//
// The including shader declares params (FrameParams), the scene arrays that
// area_lights.glsl and lights.glsl read, and
//   BihHit trace(vec3 origin, vec3 direction, float tmax, bool any_hit)
// and includes area_lights.glsl, lights.glsl and materials.glsl first.
#ifndef PF_DIRECT_LIGHT_GLSL
#define PF_DIRECT_LIGHT_GLSL

#include "rng.glsl"

// pf_scene.h's PF_DIRECT_LIGHTS_EVERY_MAX, PF_DIRECT_LIGHT_SAMPLES,
// PF_DIRECT_LIGHT_PIXEL_SAMPLES and PF_DIRECT_LIGHT_CANDIDATES (the wavefront's shadow
// slots a path follow them; the shade rows' light_samples report them).
// A path tracer's vertex (reference: many samples a pixel) resamples
// DIRECT_LIGHT_SAMPLES lights; a pixel whose direct light is estimated once a
// pass (final's, fast's and preview's first vertices) DIRECT_LIGHT_PIXEL_SAMPLES,
// its direct layer being what the denoiser leaves as it is (bench/RESULTS.md, "Thirteenth
// stop": final's error × time 0.018 with 16, 0.024 with 4; reference gained nothing from 8).
const uint DIRECT_LIGHTS_EVERY_MAX = 8u;
const uint DIRECT_LIGHT_SAMPLES = 4u;
const uint DIRECT_LIGHT_PIXEL_SAMPLES = 16u;
const uint DIRECT_LIGHT_CANDIDATES = 8u;

// Whether direct_light samples the frame's punctual lights rather than visiting each.
bool direct_light_samples_lights()
{
    return SCENE_HAS_LIGHTS && SCENE_HAS_MANY_LIGHTS &&
           params.light_count > DIRECT_LIGHTS_EVERY_MAX;
}

// direct_light's candidates (shadow rays) at most with DIRECT_LIGHT_SAMPLES: the emissive
// sample, then a punctual light each or the sampled ones (pf_direct_light_slots on the host).
uint direct_light_slots()
{
    return 1u + (direct_light_samples_lights() ? DIRECT_LIGHT_SAMPLES
                 : SCENE_HAS_LIGHTS             ? params.light_count
                                                : 0u);
}

// One punctual light by resampled importance sampling (Talbot et al. 2005, "Importance
// Resampling for Global Illumination"; ReSTIR's streaming form, Bitterli et al. 2020):
// DIRECT_LIGHT_CANDIDATES lights picked by power (the lights' alias table), one kept in
// proportion to w = p̂ / p_pick, with p̂ the luminance of the light it would reflect towards
// wo unoccluded (its irradiance times the BSDF and cosine: zero exactly where the light
// adds nothing, so the estimate stays unbiased; without the BSDF, a glossy highlight of one
// of many lights came out as rare fireflies). Returns the kept light's weight,
// (Σw / M) / p̂(kept) / samples, its contribution's factor in one of the vertex's samples,
// with the kept light's sample and the light it would reflect (irradiance × BSDF × cosine:
// its contribution but for throughput and weight); 0 when no candidate adds anything.
float light_resample(Material material, vec3 position, vec3 wo, vec3 shading_normal,
                     vec3 geometric_normal, bool front, uint samples, inout uint rng,
                     out LightSample kept, out vec3 kept_reflected)
{
    uint count = params.light_count;
    float weight_sum = 0.0;
    float kept_target = 0.0;
    kept = LightSample(vec3(0.0, 0.0, 1.0), 0.0, vec3(0.0));
    kept_reflected = vec3(0.0);
    for (uint m = 0u; m < DIRECT_LIGHT_CANDIDATES; m++) {
        uint column = min(uint(rng_float(rng) * float(count)), count - 1u);
        uint index = rng_float(rng) < lights[column].pick_threshold ? column
                                                                     : lights[column].pick_alias;
        float select = rng_float(rng);
        float pick_pdf = lights[index].pick_pdf;
        LightSample light = light_sample(lights[index], position);
        vec3 reflected = light.irradiance * bsdf_eval_cos(material, wo, light.to_light,
                                                          shading_normal, geometric_normal,
                                                          front);
        float target = light_luminance(reflected);
        float weight = pick_pdf > 0.0 ? target / pick_pdf : 0.0;
        weight_sum += weight;
        if (weight > 0.0 && select * weight_sum < weight) {
            kept = light;
            kept_reflected = reflected;
            kept_target = target;
        }
    }
    return kept_target > 0.0
               ? weight_sum / (float(DIRECT_LIGHT_CANDIDATES * samples) * kept_target)
               : 0.0;
}

// Power heuristic, β = 2 (Veach 1997); pdfs already multiplied by their sample counts.
float mis_power(float pdf_this, float pdf_other)
{
    float a = pdf_this * pdf_this;
    float b = pdf_other * pdf_other;
    return a > 0.0 ? a / (a + b) : 0.0;
}

// The BSDF half of the direct-light MIS: the weight of emission Le that a
// BSDF-sampled ray (solid-angle pdf bsdf_pdf, already times its sample
// count) found on an emitting face (either side) of unit normal face_normal at
// distance t along direction, against the light sampling of direct_light.
float emission_mis_weight(vec3 emission, vec3 face_normal, vec3 direction, float t,
                          float bsdf_pdf)
{
    float cos_light = abs(dot(face_normal, direction));
    float light_pdf = emissive_pdf_area(emission, params.emissive_weight_total) * t * t / cos_light;
    return mis_power(bsdf_pdf, light_pdf);
}

// Light reflected towards wo at position, times throughput; rays counts the
// shadow rays cast. surface_origin is position moved off the surface on wo's side.
// light_samples: the lights resampled where there are too many to visit
// (DIRECT_LIGHT_SAMPLES or DIRECT_LIGHT_PIXEL_SAMPLES; the wavefront's slots
// hold DIRECT_LIGHT_SAMPLES).
// One loop over the candidates (the emissive sample first, then each
// punctual light) with a single trace call: every call site of trace_bih is
// inlined, and llvmpipe's compile time grows with each.
vec3 direct_light(Material material, vec3 position, vec3 surface_origin, vec3 wo,
                  vec3 shading_normal, vec3 geometric_normal, bool front, vec3 throughput,
                  vec4 light_xi,
                  float bsdf_sample_count, uint light_samples, inout uint rays)
{
    float ray_offset = params.camera_right.w;
    vec3 sum = vec3(0.0);
    vec3 area_contribution = vec3(0.0);
    vec3 area_direction = vec3(0.0, 0.0, 1.0);
    float area_tmax = 0.0;
    if (SCENE_HAS_EMITTERS && params.emissive_count > 0u) {
        AreaLightSample light = emissive_sample(position, light_xi, params.emissive_count,
                                                params.emissive_weight_total);
        float reflected_pdf;
        vec3 reflected = bsdf_eval_cos_pdf(material, wo, light.to_light, shading_normal,
                                           geometric_normal, front, reflected_pdf);
        if (light.pdf_solid_angle > 0.0) {
            float weight = bsdf_sample_count > 0.0
                               ? mis_power(light.pdf_solid_angle,
                                           bsdf_sample_count * reflected_pdf)
                               : 1.0;
            area_contribution = throughput * reflected * light.radiance *
                                (weight / light.pdf_solid_angle);
        }
        area_direction = light.to_light;
        area_tmax = light.distance - 2.0 * ray_offset;
    }
    // Candidate 0 is the emissive sample, candidate i > 0 punctual light i - 1, or the i-th
    // light resampled (none compiled in for a frame without them: llvmpipe would run the
    // light's code masked). The resampling's random numbers hash the vertex's light_xi.
    uint light_count = SCENE_HAS_LIGHTS ? params.light_count : 0u;
    bool sampled = direct_light_samples_lights();
    uint rng = sampled ? pcg_hash(floatBitsToUint(light_xi.x) ^
                                  pcg_hash(floatBitsToUint(light_xi.y) ^
                                           pcg_hash(floatBitsToUint(light_xi.z) ^
                                                    pcg_hash(floatBitsToUint(light_xi.w)))))
                       : 0u;
    uint candidates = sampled ? light_samples : light_count;
    for (uint candidate = 0u; candidate <= candidates; candidate++) {
        vec3 contribution = area_contribution;
        vec3 to_light = area_direction;
        float tmax = area_tmax;
        if (SCENE_HAS_LIGHTS && candidate > 0u) {
            LightSample light;
            if (sampled) {
                vec3 reflected;
                float weight = light_resample(material, position, wo, shading_normal,
                                              geometric_normal, front, light_samples, rng, light,
                                              reflected);
                contribution = throughput * reflected * weight;
            } else {
                light = light_sample(lights[candidate - 1u], position);
                contribution = throughput * light.irradiance *
                               bsdf_eval_cos(material, wo, light.to_light, shading_normal,
                                             geometric_normal, front);
            }
            to_light = light.to_light;
            tmax = light.distance - ray_offset;
        }
        if (any(greaterThan(contribution, vec3(0.0)))) {
            rays++;
#ifdef PF_DEFERRED_SHADOWS
            shadow_ray_defer(surface_origin, to_light, tmax, contribution);
#else
            if (trace(surface_origin, to_light, tmax, true).triangle == NO_HIT)
                sum += contribution;
#endif
        }
    }
    return sum;
}

#endif
