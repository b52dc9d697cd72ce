// The `final` integrator's shade kernels' common interface: render_final.comp
// (the primary), final_caustic.comp, final_gather.comp and
// final_gather_estimate.comp (final_gather.glsl), final_deferred.comp (the
// gather's deferred estimates) and final_resolve.comp share one Push block
// (core/render/frame_final.c's final_push), one buffer layout (the host binds
// the same PF_FINAL_BUFFERS buffers to all) and the estimate from the bound
// global map. The including kernel includes
// scene_bindings.glsl, photon_types.glsl and photon_grid.glsl first.
#ifndef PF_FINAL_SHARED_GLSL
#define PF_FINAL_SHARED_GLSL


layout(push_constant) uniform Push {
    vec3 grid_origin;
    float grid_inv_cell;
    uvec3 grid_dims;
    uint grid_hashed;
    uint grid_table_size;
    uint grid_photons;  // photons in the bound grid (0: no estimate)
    uint sample_index;  // 0 starts the film's sums
    uint gather_first;
    uint gather_count;  // gather rays in this dispatch
    uint gather_total;  // gather rays per sample
    uint fallback_capacity; // gather: requests fallback_requests holds (0: estimate at once)
    uint loop_sentinel; // 1; the end-of-invocation proof loop runs this many times
    float radius;       // gather radius of the bound grid
    float flux_scale;   // W per unit of the bound map's stored flux
    float caustic_scale; // this pass's radius over the first pass's (caustic radii shrink with it)
    // The bound global map's precomputed irradiance points (gather only; 0: none).
    uint points_count;
    vec3 points_origin;
    float points_inv_cell;
    uvec3 points_dims;
    uint points_hashed;
    uint points_table_size;
    uint gather_retrace; // final_gather_estimate.comp: trace only the OVERFLOW_REQUEST rays
    uint row_first;     // primary, gather: the first image row of this dispatch (a band of rows)
} push;

layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer FilmAov { vec4 film_aov[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 2) buffer Counters {
    uint discarded_samples; // non-finite or loop-truncated samples kept off the film
    uint traversal_failures;
    uint rays_low;
    uint rays_high;
    uint loop_truncated;    // invocations the loop cap cut short
    uint gather_dropped;    // gather rays past GATHER_MAX_SPECULAR specular vertices
    uint fallback_requests; // estimates the gather deferred (those past the capacity ran at once)
} counters;
// host_rays.glsl's queue, where the primary and the gather include it.
#define HOST_RAYS_BINDING (PF_SCENE_BINDING_COUNT + 23)
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 6) buffer Vertices { vec4 vertices[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 7) buffer SampleSums { vec4 sample_sums[]; };
// The bound map (photon_estimate.glsl: texel buffers; its flux at grid_flux below).
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 8) uniform isamplerBuffer grid_records;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 9) uniform isamplerBuffer grid_ranges;
// Per pixel: the caustic radius chosen in the first pass (see caustic_radiance).
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 10) buffer CausticRadii { float caustic_radii[]; };
// The global map's precomputed irradiance points (photon_estimate.glsl's
// lookup; their flux at points_flux below).
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 11) uniform isamplerBuffer points_records;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 12) uniform isamplerBuffer points_ranges;
#define PHOTON_LOOKUP_RECORDS points_records
#define PHOTON_LOOKUP_FLUX points_flux
#define PHOTON_LOOKUP_RANGES points_ranges
// Deferred estimates, 3 vec4 each: (position, 0), (geometric normal, 0),
// (weight, 0) from the gather; (weight × irradiance, 1 if the estimate
// stopped at the loop guard) after final_deferred.comp.
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 13) buffer FallbackRequests { vec4 fallback_requests[]; };
// Per pixel: the request of each of the sample's gather rays, or NO_REQUEST.
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 14) buffer PixelFallbacks { uvec4 pixel_fallbacks[]; };
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 15) uniform usamplerBuffer grid_flux;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 16) uniform usamplerBuffer points_flux;
const uint NO_REQUEST = 0xFFFFFFFFu;
// A gather ray whose request found fallback_requests full: its estimate is
// left to final_gather_estimate.comp's retrace, before the resolve.
const uint OVERFLOW_REQUEST = 0xFFFFFFFEu;
// The same buffers as film, film_aov, vertices, sample_sums,
// fallback_requests and pixel_fallbacks, bound a second time
// as 16-byte texel views for the reads: llvmpipe loads a storage buffer lane
// by lane in a branchy loop and a texel fetch is one vector gather
// (bench/RESULTS.md). Signed-integer texels, read as bits, so that what a
// float slot holds (a material index's bits, a flag, a NaN) comes back as
// written. A kernel reads a texel only where an earlier dispatch wrote it,
// or its own invocation before writing it.
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 17) uniform isamplerBuffer film_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 18) uniform isamplerBuffer film_aov_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 19) uniform isamplerBuffer vertex_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 20) uniform isamplerBuffer sample_sum_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 21) uniform isamplerBuffer fallback_request_texels;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 22) uniform isamplerBuffer pixel_fallback_texels;
// 23..25: host_rays.glsl's queue. The second part of each pixel's D₁ record
// (render_final.comp), and its texel view.
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 26) buffer VertexWeights { vec4 vertex_weights[]; };
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 27) uniform isamplerBuffer vertex_weight_texels;

vec4 texel_vec4(isamplerBuffer texels, uint index)
{
    return intBitsToFloat(texelFetch(texels, int(index)));
}

uvec4 texel_uvec4(isamplerBuffer texels, uint index)
{
    return uvec4(texelFetch(texels, int(index)));
}

// Each estimate stops after this many iterations (photon_estimate.glsl):
// with FINAL_GATHER_RAYS_PER_DISPATCH = 4 estimates per invocation (the
// host's figure) that is 32,768 of the 65,535, leaving the rest to the
// traversals and light loops; a stopped estimate drops the sample (counted).
#define PHOTON_ESTIMATE_MAX_ITERATIONS 8192u
#include "photon_estimate.glsl"

PhotonGrid bound_grid()
{
    return PhotonGrid(push.grid_origin, push.grid_inv_cell, push.grid_dims, push.grid_hashed,
                      push.grid_table_size);
}

PhotonGrid bound_points()
{
    return PhotonGrid(push.points_origin, push.points_inv_cell, push.points_dims,
                      push.points_hashed, push.points_table_size);
}

// The estimate from the global map's photons, truncated as
// photon_irradiance_guarded.
vec3 global_irradiance_estimate(vec3 position, vec3 geometric_normal, inout bool truncated)
{
    bool stopped;
    vec3 irradiance = photon_irradiance_guarded(position, geometric_normal, push.radius,
                                                bound_grid(), stopped);
    truncated = truncated || stopped;
    return irradiance;
}

#endif
