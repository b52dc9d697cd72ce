#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Reference integrator (the `shade` stage of the reference preset): an
// unbiased unidirectional path tracer. One dispatch adds one sample to every
// pixel of the image (a progressive pass); the host divides the sums. This is
// the megakernel: each invocation traces its pixel's path to its end. The
// path's vertices are reference_path.glsl's, which render_reference_wave.comp
// (the wavefront, one vertex a dispatch) runs too.
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
// counters.discarded_samples; the pixel averages over its kept samples. So
// does one whose invocation met llvmpipe's loop cap (kernel_guard.glsl: a long
// path, or rays through thousands of overlapping triangles), counted in counters.loop_truncated
// too: the host fails a frame with more than a few (frame_reference.c).

layout(local_size_x = 8, local_size_y = 8) in;

layout(constant_id = 0) const bool WRITE_AOVS = true;

layout(push_constant) uniform Push {
    uint sample_index;  // 0 starts the film's sums
    uint loop_sentinel; // 1; kernel_guard.glsl's end-of-invocation proof loop
} push;

#include "scene_bindings.glsl"
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer FilmAov { vec4 film_aov[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 2) buffer Counters {
    uint discarded_samples;
    uint traversal_failures; // rays whose BIH traversal overflowed: the host fails the frame
    uint rays_low;           // rays traced, a 64-bit count in two words
    uint rays_high;
    uint loop_truncated;     // samples whose invocation met the loop cap (also discarded)
} counters;

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "camera_sample.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"

#include "reference_path.glsl"
#include "ray_count.glsl"
#include "kernel_guard.glsl"

void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    path_begin(pixel, push.sample_index);
    for (uint depth = 0u; depth < params.max_path_depth; depth++) {
        BihHit hit = trace_seen(path_origin, path_direction, infinity, false,
                                path_depth == 0u);
        path_rays++;
        if (!path_vertex(hit))
            break;
    }
    if (!loops_completed()) {
        path_valid = false;
        atomicAdd(counters.loop_truncated, 1u);
    }
    path_finish(pixel.y * params.width + pixel.x, push.sample_index);
    count_rays(path_rays);
}
