#ifndef PF_REFERENCE_WAVE_GLSL
#define PF_REFERENCE_WAVE_GLSL

// The reference path tracer as a wavefront: what its three modules share
// (render_reference_wave.comp: WAVE_SHADE, the path vertex;
// render_reference_wave_tail.comp: WAVE_TAIL; render_reference_wave_ends.comp:
// WAVE_GENERATE and WAVE_FINISH, a pass's first and last dispatches, without
// the vertex's code: llvmpipe builds each pipeline from its whole module
// before specialising it, 0.1-0.5 s a module).
//
// The reference path tracer as a wavefront (issue 43; Laine, Karras & Aila
// 2013): the paths of one pass advance one vertex per dispatch, and the rays
// between two dispatches are traced by whoever traces them best. Where the
// device is the CPU that is the host (core/bih/bih_wave_trace.c, the wide BIH
// traversal on every core, reading and writing these buffers in place); the
// kernel itself traces only past a hit on an alpha-tested triangle that does
// not count (the host's traversal has no textures: traced_hit,
// shadow_unoccluded), and in WAVE_TAIL. The paths are reference_path.glsl's, as the
// megakernel's (render_reference.comp): the same random numbers, the same
// estimator, the same image but for ties between equally distant triangles.
//
// WAVE_MODE (constant_id 0):
//   WAVE_GENERATE    invocation i starts pixel i's path: its camera ray.
//   WAVE_SHADE       invocation i advances path active_paths[first_active + i],
//                    whose ray hit a surface: it adds the light of the previous
//                    vertex's unoccluded shadow rays, then the vertex at the
//                    hit, which defers its shadow rays and writes the next
//                    ray. A path left with nothing to trace is stored marked
//                    QUEUE_PENDING (the host traces nothing for it and drops it).
//   WAVE_TAIL        once few paths are left (frame_reference_wave.c): each lane
//                    takes the next path of active_paths[first_active...] from
//                    tail.next, shades it as WAVE_SHADE does, then traces its
//                    rays itself (the device's GLSL traversal, the megakernel's
//                    trace), its shadow rays as they are made, vertex by vertex
//                    to the path's end, and takes the next path; the paths are
//                    stored ended, nothing left to trace. A wave of a few hundred
//                    paths costs its submission and dispatch more than its
//                    work: the tail's paths end in one dispatch, not one a
//                    vertex, and a lane whose path ended takes another (up to
//                    a bound, render_reference_wave_tail.comp), so the lanes stay busy until the
//                    list runs out.
//   WAVE_FINISH(_RGB) once a pass's waves are done, invocation i finishes
//                    pixel i's path, ended in whichever wave: the light of its
//                    last shadow rays (their hits stay in the slot, which no
//                    other path uses in the pass), then the film (WAVE_FINISH
//                    writes the AOV film too). One dispatch a pass, not one a
//                    wave (each a submission's worth of llvmpipe's thread
//                    handoffs), in its own module without the vertex's code,
//                    and the only one with the film's: llvmpipe runs every line
//                    of a module for every invocation, masked where no lane
//                    takes it (bench/RESULTS.md, "Code that no lane runs").
// The paths of one dispatch are a slice of the image's pixels (push.first_pixel
// on), so the buffers stay bounded at any size.
// Per path p, what the host reads back: queue[p] = ray live (bit 0) | shadow
// rays << 1 | QUEUE_PENDING (pf_bih.h's PF_BIH_WAVE_*), the ray rays[p] and the
// shadow rays shadow_rays[p·K + k] (K = direct_light_slots(),
// direct_light.glsl's candidates); what it writes: hits[p] and
// shadow_hits[p·K + k]. The host keeps only the paths whose ray hit a surface
// in the next dispatch's active list.


layout(local_size_x = 64) in;

const uint WAVE_SHADE = 0u;
const uint WAVE_GENERATE = 1u;
const uint WAVE_FINISH_RGB = 2u;
const uint WAVE_FINISH = 3u;
const uint WAVE_TAIL = 4u;
layout(constant_id = 0) const uint WAVE_MODE = WAVE_SHADE;
const bool FINISHING = WAVE_MODE == WAVE_FINISH || WAVE_MODE == WAVE_FINISH_RGB;
// The film is written only where paths finish; WAVE_SHADE's AOV paths finish in WAVE_FINISH.
const bool WRITE_AOVS = WAVE_MODE == WAVE_FINISH;
// The queue word (pf_bih.h PF_BIH_WAVE_SHADOW_MAX, PF_BIH_WAVE_PENDING).
const uint QUEUE_SHADOWS = 0x3FFFFFFFu;
const uint QUEUE_PENDING = 0x80000000u;

layout(push_constant) uniform Push {
    uint sample_index; // 0 starts the film's sums
    uint count;        // invocations: pixels (generate) or active paths
    uint first_pixel;  // path p is pixel first_pixel + p (the image goes in slices of paths)
    uint first_active; // where this dispatch's paths start in active_paths
    uint loop_sentinel; // 1; kernel_guard.glsl's proof loop
} push;

#include "scene_bindings.glsl"
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer FilmAov { vec4 film_aov[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 2) buffer Counters {
    uint discarded_samples;
    uint traversal_failures; // bih_traverse.glsl's; the host counts its own
    uint rays_low;           // the tail's rays (the host counts those it traces)
    uint rays_high;
    uint loop_truncated;     // paths whose invocation met the loop cap (dropped)
} counters;

// The megakernel's bindings up to here (the BIH's three are declared and bound,
// never read), so one set of buffers serves both; the wavefront's follow.
#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 3)
#include "scene_trace.glsl"
#include "ray_types.glsl"

#define WAVE_BINDING (PF_SCENE_BINDING_COUNT + 6)
// One path's state (reference_path.glsl's globals), 9 vec4.
struct WavePath {
    vec4 origin_pdf;             // path_origin, path_previous_pdf
    vec4 direction_cone;         // path_direction, path_cone_distance
    vec4 throughput_coverage;    // path_throughput, path_coverage
    vec4 medium_depth_aov;       // path_medium, path_depth_aov
    vec4 direct_flags;           // path_direct, the bools' bits
    vec4 indirect_depth;         // path_indirect, path_depth
    vec4 caustic_regions;        // path_caustic, path_region | path_shadow_region << 8
    vec4 albedo_group;           // path_albedo_aov, path_samples.group
    vec4 normal;                 // path_normal_aov
};
layout(std430, set = 0, binding = WAVE_BINDING + 0) writeonly buffer Paths { WavePath paths[]; };
layout(std430, set = 0, binding = WAVE_BINDING + 1) writeonly buffer Rays { Ray rays[]; };
layout(set = 0, binding = WAVE_BINDING + 2) uniform usamplerBuffer hits;          // HitRecord: 4 words
// Read where a shadow ray's host hit is on an alpha-tested triangle (shadow_unoccluded).
layout(std430, set = 0, binding = WAVE_BINDING + 3) buffer ShadowRays { Ray shadow_rays[]; };
layout(std430, set = 0, binding = WAVE_BINDING + 4) writeonly buffer ShadowLightOut { vec4 shadow_light_out[]; };
layout(set = 0, binding = WAVE_BINDING + 5) uniform usamplerBuffer shadow_hits;   // HitRecord: 4 words
layout(std430, set = 0, binding = WAVE_BINDING + 6) writeonly buffer Queue { uint queue[]; };
layout(set = 0, binding = WAVE_BINDING + 7) uniform usamplerBuffer active_paths;
// What this dispatch reads of what the previous one wrote, through texel views of the
// same buffers: llvmpipe loads a storage buffer word lane by lane, a texel in one gather
// (bih_traverse.glsl), and the state is most of what a wave moves.
layout(set = 0, binding = WAVE_BINDING + 8) uniform samplerBuffer paths_in;        // WavePath: 9 texels
layout(set = 0, binding = WAVE_BINDING + 9) uniform usamplerBuffer queue_in;
layout(set = 0, binding = WAVE_BINDING + 10) uniform samplerBuffer shadow_light;   // vec4 a slot
// WAVE_TAIL's next path to take (the host zeroes it before the dispatch).
layout(std430, set = 0, binding = WAVE_BINDING + 11) buffer TailCursor { uint next; } tail;

// This invocation's shadow rays: the first slot and how many so far.
uint wave_shadow_base = 0u;
uint wave_shadow_count = 0u;

// WAVE_TAIL's light samples of this vertex whose shadow rays were unoccluded.
vec3 tail_unoccluded = vec3(0.0);

void shadow_ray_defer(vec3 origin, vec3 direction, float tmax, vec3 contribution)
{
    if (WAVE_MODE == WAVE_TAIL) { // traced now, as the megakernel's direct_light does
        if (trace(origin, direction, tmax, true).triangle == NO_HIT)
            tail_unoccluded += contribution;
        return;
    }
    uint slot = wave_shadow_base + wave_shadow_count;
    wave_shadow_count++;
    shadow_rays[slot] = Ray(vec4(origin, 0.0), vec4(direction, tmax));
    shadow_light_out[slot] = vec4(contribution, 0.0);
}

#define PF_DEFERRED_SHADOWS
#include "camera_sample.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "sampler.glsl"
#include "reference_path.glsl"
#include "ray_count.glsl"
#include "kernel_guard.glsl"

// A path whose invocation met llvmpipe's loop cap (kernel_guard.glsl) went on from a cut
// loop: it is dropped (its sample discarded by path_finish, as a non-finite one) and
// counted; the host fails a frame with more than a few (frame_reference.c).
bool cut_at_loop_cap()
{
    if (loops_completed())
        return false;
    path_valid = false;
    atomicAdd(counters.loop_truncated, 1u);
    return true;
}

const uint FLAG_VALID = 1u, FLAG_CAUSTIC_CHAIN = 2u, FLAG_PREVIOUS_SPECULAR = 4u,
           FLAG_ON_CAMERA_CONE = 8u, FLAG_AOV_RECORDED = 16u;

void path_load(uint p, uvec2 pixel)
{
    uint at = 9u * p;
    WavePath w = WavePath(texelFetch(paths_in, int(at)), texelFetch(paths_in, int(at + 1u)),
                          texelFetch(paths_in, int(at + 2u)), texelFetch(paths_in, int(at + 3u)),
                          texelFetch(paths_in, int(at + 4u)), texelFetch(paths_in, int(at + 5u)),
                          texelFetch(paths_in, int(at + 6u)), texelFetch(paths_in, int(at + 7u)),
                          texelFetch(paths_in, int(at + 8u)));
    path_origin = w.origin_pdf.xyz;
    path_previous_pdf = w.origin_pdf.w;
    path_direction = w.direction_cone.xyz;
    path_cone_distance = w.direction_cone.w;
    path_throughput = w.throughput_coverage.xyz;
    path_coverage = w.throughput_coverage.w;
    path_medium = w.medium_depth_aov.xyz;
    path_depth_aov = w.medium_depth_aov.w;
    path_direct = w.direct_flags.xyz;
    uint flags = floatBitsToUint(w.direct_flags.w);
    path_valid = (flags & FLAG_VALID) != 0u;
    path_caustic_chain = (flags & FLAG_CAUSTIC_CHAIN) != 0u;
    path_previous_specular = (flags & FLAG_PREVIOUS_SPECULAR) != 0u;
    path_on_camera_cone = (flags & FLAG_ON_CAMERA_CONE) != 0u;
    path_aov_recorded = (flags & FLAG_AOV_RECORDED) != 0u;
    path_indirect = w.indirect_depth.xyz;
    path_depth = floatBitsToUint(w.indirect_depth.w);
    path_caustic = w.caustic_regions.xyz;
    uint regions = floatBitsToUint(w.caustic_regions.w);
    path_region = regions & 0xFFu;
    path_shadow_region = regions >> 8u;
    path_albedo_aov = w.albedo_group.xyz;
    path_normal_aov = w.normal.xyz;
    path_samples = sampler_init(image_pixel_index(pixel.y * params.width + pixel.x),
                                push.sample_index, params.seed_lo, params.seed_hi); // as path_begin's
    path_samples.group = floatBitsToUint(w.albedo_group.w);
    path_rays = 0u;
}

void path_store(uint p)
{
    uint flags = (path_valid ? FLAG_VALID : 0u) | (path_caustic_chain ? FLAG_CAUSTIC_CHAIN : 0u) |
                 (path_previous_specular ? FLAG_PREVIOUS_SPECULAR : 0u) |
                 (path_on_camera_cone ? FLAG_ON_CAMERA_CONE : 0u) |
                 (path_aov_recorded ? FLAG_AOV_RECORDED : 0u);
    paths[p] = WavePath(vec4(path_origin, path_previous_pdf),
                        vec4(path_direction, path_cone_distance),
                        vec4(path_throughput, path_coverage), vec4(path_medium, path_depth_aov),
                        vec4(path_direct, uintBitsToFloat(flags)),
                        vec4(path_indirect, uintBitsToFloat(path_depth)),
                        vec4(path_caustic, uintBitsToFloat(path_region | path_shadow_region << 8u)),
                        vec4(path_albedo_aov, uintBitsToFloat(path_samples.group)),
                        vec4(path_normal_aov, 0.0));
}

// Whether the shadow ray in slot is unoccluded: the host's any-hit query found nothing, or
// (alpha-tested triangles) what it found does not count and nothing past it does.
bool shadow_unoccluded(uint slot)
{
    int at = int(4u * slot);
    uint triangle = texelFetch(shadow_hits, at + 1).x;
    if (triangle == NO_HIT || !SCENE_HAS_ALPHA)
        return triangle == NO_HIT;
    BihHit hit = BihHit(uintBitsToFloat(texelFetch(shadow_hits, at).x), triangle,
                        uintBitsToFloat(texelFetch(shadow_hits, at + 2).x),
                        uintBitsToFloat(texelFetch(shadow_hits, at + 3).x));
    Ray ray = shadow_rays[slot];
    return trace_after(hit, ray.origin_tmin.xyz, ray.direction_tmax.xyz, ray.direction_tmax.w,
                       true, false).triangle == NO_HIT;
}

// Loads path p (pixel's) and adds the light of its previous vertex's unoccluded shadow
// rays, in the megakernel's order: before this vertex's emission. Returns whether its
// ray waits for a hit.
bool path_resume(uint p, uvec2 pixel)
{
    path_load(p, pixel);
    uint waiting = texelFetch(queue_in, int(p)).x;
    vec3 unoccluded = vec3(0.0);
    for (uint k = 0u; k < ((waiting >> 1u) & QUEUE_SHADOWS); k++)
        if (shadow_unoccluded(wave_shadow_base + k))
            unoccluded += texelFetch(shadow_light, int(wave_shadow_base + k)).xyz;
    path_add(unoccluded, path_shadow_region, false);
    return (waiting & 1u) != 0u;
}

// The hit that counts of path p's ray (path_origin, path_direction, loaded), from the host's.
BihHit traced_hit(uint p)
{
    int at = int(4u * p);
    BihHit hit = BihHit(uintBitsToFloat(texelFetch(hits, at).x), texelFetch(hits, at + 1).x,
                        uintBitsToFloat(texelFetch(hits, at + 2).x),
                        uintBitsToFloat(texelFetch(hits, at + 3).x));
    return trace_after(hit, path_origin, path_direction, uintBitsToFloat(0x7f800000u), false,
                       path_depth == 0u);
}

uvec2 pixel_of(uint p)
{
    uint pixel_index = push.first_pixel + p;
    return uvec2(pixel_index % params.width, pixel_index / params.width);
}

#endif
