#ifndef PF_PHOTON_PATH_GLSL
#define PF_PHOTON_PATH_GLSL

// Photon tracing: what its three modules share (photon_trace.comp, the flat
// loop; photon_wave_emit.comp and photon_wave_bounce.comp, the waves whose
// rays the host traces: each module holds only its own step's code, as
// llvmpipe builds a pipeline from its whole module before specialising it).
//
// Photon tracing (the photon_trace stage). An invocation traces several
// photons in turn (push.photon_stride apart): in one flat loop of bounces, a
// lane whose photon has ended starts its next one, so the lanes of a SIMD
// group stay busy until the group's photons are all done. With one photon
// per invocation a group ran until its longest Russian-roulette path ended:
// 43 % of the lanes' bounces did work on lavapipe (bench/RESULTS.md). Photon
// i's path depends on i alone (its own random sequence), not on the lane or
// the order in which it is traced.
//
// Emission: the photon's emitter comes from the alias table of
// pf_photon_emitters (every light and emissive triangle by power), with the
// column stratified over the pass ((index + ξ) / N); flux is in units of the
// map's flux scale (Σ luminance power / N), so every emitted photon starts
// with luminance 1 and its colour:
//   point        uniform direction on the sphere
//   spot         uniform direction in the outer cone, flux × falloff / pdf
//   directional  uniform point on a disk of the scene's bounding radius
//                facing the light, outside the scene
//   triangle     uniform point, cosine-weighted direction about the front face
//                (either face, half each, for a double-sided material)
// A punctual light's glTF range window scales the flux at the first hit, as
// the integrators' shadow rays apply it.
//
// Tracing (Jensen 2001; REFERENCE.md's fixes to the seed thesis): closest
// hits through the BIH; at a diffuse (Lambert) hit the photon is stored in
// the global map unless it came straight from the light (direct light comes
// from shadow rays), and in the caustic map when every earlier bounce was
// specular (L S+ D); nothing is stored on mirrors and glass, and on a metal
// sharper than GLOSSY_ROUGHNESS only caustic photons (L S+ G), which count it
// as specular on their way on. Then
// bsdf_sample (materials.glsl) scatters it and Russian roulette keeps it
// with P = min(1, max channel of the scattering weight), flux ⊙ weight / P,
// so the expected flux is exact and the colour survives. At most
// params.max_depth hits per photon.
//
// Who traces (PHOTON_STEP, constant_id 0; issue 43):
//   PHOTON_TRACED_HERE  the flat loop above, every ray traced here (a GPU's);
//   PHOTON_EMIT         invocation i emits photon first_photon + i of a batch:
//                       its state and first ray into the wave buffers;
//   PHOTON_BOUNCE       invocation i takes photon active[i], whose ray the host
//                       traced and hit a surface: one bounce (store, scatter,
//                       roulette), then its next ray, or its end (queue 0).
// Where the device is the CPU the host traces the rays between the waves
// (core/bih/bih_wave_trace.c: the wide traversal on every core, in place).
// Both drive photon_start and photon_bounce, so a photon's path is the same
// either way; only the maps' order differs.


layout(local_size_x = 64) in;

const uint PHOTON_TRACED_HERE = 0u;
const uint PHOTON_EMIT = 1u;
const uint PHOTON_BOUNCE = 2u;
layout(constant_id = 0) const uint PHOTON_STEP = PHOTON_TRACED_HERE;

// Big passes take several dispatches (the workgroup count is bounded).
layout(push_constant) uniform Push {
    uint first_photon;  // index of this dispatch's first photon within the pass
    uint photon_count;  // photons of this dispatch: first_photon + [0, photon_count)
                        // (PHOTON_BOUNCE: the photons of active[] it takes)
    uint photon_stride; // invocations of this dispatch: invocation i traces i, i + stride, ...
    uint loop_sentinel; // 1; kernel_guard.glsl's end-of-invocation proof loop
} push;

#include "scene_binding_numbers.glsl"
#include "scene_types.glsl"
#include "photon_types.glsl"

// PhotonTraceParams (C mirror photon_trace_params in core/photon/photon_trace.c).
struct PhotonTraceParams {
    vec4 bih_bounds_min;       // xyz
    vec4 bih_bounds_max;       // xyz
    vec4 scene_sphere;         // xyz centre, w radius (directional lights)
    uint photon_count;         // photons emitted in this pass (N)
    uint emitter_count;
    uint store_direct;         // 1: also store first hits in the global map (irradiance tests)
    uint triangle_count;
    uint bih_node_count;
    uint seed_lo, seed_hi;
    uint max_depth;
    uint global_capacity;      // photons the maps can hold; more are counted, not stored
    uint caustic_capacity;
    float ray_offset;          // secondary rays leave surfaces this far along the normal
    uint global_reflected;     // 1: the global map holds reflected flux (flux ⊙ albedo): VPLs
    // Arrivals counted inside this box (an empty box: none), below.
    vec4 arrival_box_min;      // xyz
    vec4 arrival_box_max;      // xyz
};

// PhotonEmitter: pf_photon_emitter (32 bytes).
struct PhotonEmitter {
    uint kind;
    uint index;
    float alias_threshold;
    uint alias;
    vec3 power;
    float pick_probability;
};

const uint EMITTER_POINT = 0u;
const uint EMITTER_SPOT = 1u;
const uint EMITTER_DIRECTIONAL = 2u;
const uint EMITTER_TRIANGLE = 3u;

layout(std430, set = 0, binding = PF_SCENE_BINDING_PARAMS) readonly buffer Params { PhotonTraceParams params; };
#include "scene_geometry.glsl" // the surfaces: triangles, materials, textures
layout(std430, set = 0, binding = PF_SCENE_BINDING_LIGHTS) readonly buffer Lights { Light lights[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_EMISSIVE) readonly buffer Emitters { PhotonEmitter emitters[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 3) buffer GlobalMap { uint global_words[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 4) buffer CausticMap { uint caustic_words[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 5) buffer Counters {
    uint global_stored;      // photons offered to the global map (stored while below capacity)
    uint caustic_stored;
    uint traversal_failures;
    uint non_finite;         // photons dropped for a non-finite flux or direction
    uint loop_truncated;     // invocations llvmpipe's loop cap stopped (their photons cut short)
    // The arrivals' luminance flux by the direction their surface faces (count_arrival), in
    // units of 2^-16 of the map's flux unit, each a 64-bit sum in two words (low at 2d):
    // integer sums do not depend on the order of the additions.
    uint arrivals[2u * 6u];
} counters;

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 0) // nodes, vertices, triangle index: its first three
#include "bih_traverse.glsl"
#include "ray_types.glsl"

// The waves' buffers (PHOTON_EMIT, PHOTON_BOUNCE), per photon p of the batch: its state
// (PhotonWave, 3 vec4), its next ray, the host's hit, queue[p] = 1 while a ray waits; the
// active photons; the state and rays read back through texel views (llvmpipe loads a texel
// in one gather, a storage word lane by lane).
struct PhotonWave {
    vec4 flux_range;
    vec4 medium_rng;       // w: the rng's bits
    vec4 depth_specular;   // x: depth's bits, y: specular_only
};
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 6) writeonly buffer WaveState { PhotonWave wave_state[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 7) writeonly buffer WaveRays { Ray wave_rays[]; };
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 8) uniform usamplerBuffer wave_hits; // HitRecord
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 9) writeonly buffer WaveQueue { uint wave_queue[]; };
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 10) uniform usamplerBuffer wave_active;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 11) uniform samplerBuffer wave_state_in;
layout(set = 0, binding = PF_SCENE_BINDING_COUNT + 12) uniform samplerBuffer wave_rays_in;
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "rng.glsl"
#include "kernel_guard.glsl"

// Uniform direction on the sphere (pbrt-v4 SampleUniformSphere).
vec3 uniform_sphere(vec2 xi)
{
    float z = 1.0 - 2.0 * xi.x;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * xi.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Uniform direction in the cone of half-angle acos(cos_max) about axis.
vec3 uniform_cone(vec3 axis, float cos_max, vec2 xi)
{
    float cos_theta = 1.0 - xi.x * (1.0 - cos_max);
    float sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    float phi = 2.0 * PI * xi.y;
    vec3 tangent, bitangent;
    material_basis(axis, tangent, bitangent);
    return normalize(sin_theta * cos(phi) * tangent + sin_theta * sin(phi) * bitangent +
                     cos_theta * axis);
}

// Where a photon starts: origin, direction, flux (flux-scale units), and the
// range of the light that must window it at the first hit (0: none).
struct Emission {
    vec3 origin;
    vec3 direction;
    vec3 flux;
    float range;
};

Emission emit(PhotonEmitter emitter, vec2 xi_position, vec2 xi_direction)
{
    // Normalised so that luminance(flux) = 1 on average over the pass:
    // power / pdf / (N · pick probability) / flux scale = power / luminance(power)
    // for an unweighted emission; sample weights (spot falloff) multiply it.
    vec3 unit_flux = emitter.power / light_luminance(emitter.power);
    Emission e = Emission(vec3(0.0), vec3(0.0, 0.0, 1.0), unit_flux, 0.0);
    if (emitter.kind == EMITTER_TRIANGLE) {
        uint first = 3u * emitter.index;
        vec3 a = scene_vertex(first);
        vec3 b = scene_vertex(first + 1u);
        vec3 c = scene_vertex(first + 2u);
        vec2 barycentrics;
        vec3 point = triangle_uniform_point(a, b, c, xi_position, barycentrics);
        vec3 normal = normalize(cross(b - a, c - a));
        Material material = scene_material(scene_triangle_material(emitter.index));
        // The emitter's power is its emissive factor's (pf_photon_emitters); an emissive
        // texture scales the photon by its value at the point over that factor, channel by
        // channel: unbiased, as the point is drawn uniformly over the area.
        if (material.emissive_texture != NO_TEXTURE) {
            vec3 textured = scene_material_textured(material, emitter.index, barycentrics.x,
                                                    barycentrics.y, 0.0, 1.0, a, b, c)
                                .emission;
            bvec3 lit = greaterThan(material.emission, vec3(0.0));
            e.flux *= mix(vec3(0.0), textured / max(material.emission, vec3(1e-30)), lit);
        }
        // A double-sided emitter's power is both faces' (pf_photon_emitters):
        // the direction's second number picks the face, half each, and is
        // stretched back over [0, 1) for the direction within that face.
        if ((material.flags & MATERIAL_DOUBLE_SIDED) != 0u) {
            bool back = xi_direction.y >= 0.5;
            xi_direction.y = fract(2.0 * xi_direction.y);
            normal = back ? -normal : normal;
        }
        e.origin = point + params.ray_offset * normal;
        e.direction = material_cosine_direction(normal, xi_direction);
        return e;
    }
    Light light = lights[emitter.index];
    if (emitter.kind == EMITTER_DIRECTIONAL) {
        // A disk of the scene's bounding radius, one radius behind the scene
        // along the light's direction, so every photon starts outside it.
        vec3 tangent, bitangent;
        material_basis(light.direction, tangent, bitangent);
        float r = params.scene_sphere.w * sqrt(xi_position.x);
        float phi = 2.0 * PI * xi_position.y;
        e.origin = params.scene_sphere.xyz - 2.0 * params.scene_sphere.w * light.direction +
                   r * cos(phi) * tangent + r * sin(phi) * bitangent;
        e.direction = light.direction;
        return e;
    }
    e.origin = light.position;
    e.range = light.range;
    if (emitter.kind == EMITTER_POINT) {
        e.direction = uniform_sphere(xi_direction);
        return e;
    }
    // Spot: uniform in the outer cone; the falloff over its mean over the
    // cone is the sample's weight, since the power already integrates it.
    float cos_outer = light.cos_outer_cone;
    float inner = light.cos_inner_cone;
    float mean_falloff = spot_cone_integral(inner, cos_outer) / (1.0 - cos_outer);
    e.direction = uniform_cone(light.direction, cos_outer, xi_direction);
    e.flux *= spot_falloff(dot(e.direction, light.direction), inner, cos_outer) / mean_falloff;
    return e;
}

// reflected: the global record's flux (flux ⊙ albedo with params.global_reflected).
void store(bool caustic, bool global, vec3 position, vec3 flux, vec3 reflected, vec3 incoming,
           vec3 normal)
{
    uint words[5] = uint[5](floatBitsToUint(position.x), floatBitsToUint(position.y),
                            floatBitsToUint(position.z), rgb9e5_pack(flux),
                            octahedral_pack8(incoming) | (octahedral_pack8(normal) << 16u));
    if (caustic) {
        uint slot = atomicAdd(counters.caustic_stored, 1u);
        if (slot < params.caustic_capacity) {
            for (uint w = 0u; w < PHOTON_WORDS; w++)
                caustic_words[PHOTON_WORDS * slot + w] = words[w];
        }
    }
    if (!global)
        return;
    words[3] = rgb9e5_pack(params.global_reflected != 0u ? reflected : flux);
    uint slot = atomicAdd(counters.global_stored, 1u);
    if (slot < params.global_capacity) {
        for (uint w = 0u; w < PHOTON_WORDS; w++)
            global_words[PHOTON_WORDS * slot + w] = words[w];
    }
}

// An arrival: light that left a diffuse surface reaching another one (or the same), on
// either face (a single-sided surface reflects from its back too), inside params' arrival
// box. Its luminance flux, summed over the pass, is the energy that `fast`'s light
// propagation volumes should deliver to surfaces there (frame_fast.c scales their
// irradiance to it), split over the six directions of the axes by the squares of the
// normal's components (facing: the side it arrived on): the directions d = 2 × axis +
// (component < 0), as fast_shade.glsl weighs the LPV's. (The 64-bit add with its carry is
// written out here and there: an atomic takes a buffer's member, not a parameter.)
void count_arrival(vec3 position, vec3 facing, vec3 flux)
{
    if (!all(greaterThan(position, params.arrival_box_min.xyz)) ||
        !all(lessThan(position, params.arrival_box_max.xyz)))
        return;
    float luminance = clamp(light_luminance(flux), 0.0, 65535.0);
    for (uint axis = 0u; axis < 3u; axis++) {
        uint units = uint(luminance * facing[axis] * facing[axis] * 65536.0 + 0.5);
        uint d = 2u * axis + (facing[axis] < 0.0 ? 1u : 0u);
        if (units == 0u)
            continue;
        uint before = atomicAdd(counters.arrivals[2u * d], units);
        if (before + units < before) // the low word wrapped: carry
            atomicAdd(counters.arrivals[2u * d + 1u], 1u);
    }
}

// A photon in flight.
struct PhotonPath {
    vec3 origin, direction, flux;
    float range;         // the light's range window, applied at the first hit (0: none)
    vec3 medium;         // absorption of the medium the photon travels in
    uint rng, depth;
    bool specular_only;  // every bounce so far was specular (caustic path)
};

// Photon index of the pass, emitted.
PhotonPath photon_start(uint index)
{
    PhotonPath p;
    p.rng = rng_init(index, 0x9e3779b9u, params.seed_lo, params.seed_hi);
    // Stratified emitter column: photon i takes (i + ξ) / N of the table.
    float stratum = (float(index) + rng_float(p.rng)) / float(params.photon_count);
    uint column = min(uint(stratum * float(params.emitter_count)), params.emitter_count - 1u);
    PhotonEmitter emitter = emitters[rng_float(p.rng) < emitters[column].alias_threshold
                                         ? column
                                         : emitters[column].alias];
    vec2 xi_position = vec2(rng_float(p.rng), rng_float(p.rng));
    vec2 xi_direction = vec2(rng_float(p.rng), rng_float(p.rng));
    Emission e = emit(emitter, xi_position, xi_direction);
    p.origin = e.origin;
    p.direction = e.direction;
    p.flux = e.flux;
    p.range = e.range;
    p.medium = vec3(0.0);
    p.specular_only = true;
    p.depth = 0u;
    return p;
}

// One bounce at the photon's hit: what it stores there, then whether it goes on (its next
// ray in origin and direction).
bool photon_bounce(inout PhotonPath p, BihHit hit)
{
    if (hit.triangle == NO_HIT)
        return false;
    if (p.depth == 0u)
        p.flux *= light_range_window(hit.t, p.range);
    p.flux *= medium_transmittance(p.medium, hit.t);
    Surface surface = surface_at(hit, p.origin, p.direction);
    if (!surface.valid || !all_finite(p.flux)) {
        atomicAdd(counters.non_finite, 1u);
        return false;
    }
    Material material = surface.material;
    bool front = surface.front;
    vec3 geometric_normal = surface.geometric_normal;
    vec3 shading_normal = surface.shading_normal;
    vec3 position = surface.position;
    // Stored where light is estimated (both maps), and on a metal too sharp for that
    // only when it arrives by a caustic chain: `final` estimates there, where the
    // camera sees it, the light its gather rays cannot find (material_estimated_at_d1).
    // Passing it, the photon stays on its caustic chain.
    bool diffuse = material_stores_photons(material);
    bool caustic = p.specular_only && p.depth > 0u;
    bool sharp_metal = !diffuse && material_estimated_at_d1(material);
    if ((diffuse && (p.depth > 0u || params.store_direct != 0u)) || (sharp_metal && caustic))
        store(caustic, diffuse, position, p.flux,
              p.flux * material_rough_albedo(material, -p.direction, shading_normal, front),
              p.direction, geometric_normal);
    if (diffuse && !p.specular_only)
        count_arrival(position, geometric_normal, p.flux);
    p.specular_only = p.specular_only && !diffuse;

    vec3 xi = vec3(rng_float(p.rng), rng_float(p.rng), rng_float(p.rng));
    BsdfSample scattered = bsdf_sample(material, -p.direction, shading_normal, geometric_normal,
                                       front, xi, TRANSPORT_IMPORTANCE);
    float survival = min(1.0, max(scattered.weight.r, max(scattered.weight.g, scattered.weight.b)));
    if (!(survival > 0.0) || rng_float(p.rng) >= survival)
        return false;
    p.flux *= scattered.weight / survival;
    p.origin = position +
               (scattered.transmitted ? -params.ray_offset : params.ray_offset) * geometric_normal;
    p.direction = scattered.direction;
    if (scattered.transmitted)
        p.medium = medium_after_transmission(material, front);
    return ++p.depth < params.max_depth;
}

// The waves: photon slot's state and next ray written (queue 1), or its end (queue 0).
void wave_store(uint slot, PhotonPath p, bool alive)
{
    if (alive) {
        wave_state[slot] = PhotonWave(vec4(p.flux, p.range), vec4(p.medium, uintBitsToFloat(p.rng)),
                                      vec4(uintBitsToFloat(p.depth), p.specular_only ? 1.0 : 0.0,
                                           0.0, 0.0));
        wave_rays[slot] = Ray(vec4(p.origin, 0.0), vec4(p.direction, uintBitsToFloat(0x7f800000u)));
    }
    wave_queue[slot] = alive ? 1u : 0u;
}

PhotonPath wave_load(uint slot)
{
    int at = int(3u * slot);
    vec4 flux_range = texelFetch(wave_state_in, at);
    vec4 medium_rng = texelFetch(wave_state_in, at + 1);
    vec4 depth_specular = texelFetch(wave_state_in, at + 2);
    PhotonPath p;
    p.origin = texelFetch(wave_rays_in, int(2u * slot)).xyz;
    p.direction = texelFetch(wave_rays_in, int(2u * slot + 1u)).xyz;
    p.flux = flux_range.xyz;
    p.range = flux_range.w;
    p.medium = medium_rng.xyz;
    p.rng = floatBitsToUint(medium_rng.w);
    p.depth = floatBitsToUint(depth_specular.x);
    p.specular_only = depth_specular.y != 0.0;
    return p;
}

#endif
