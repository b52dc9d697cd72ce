#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// Preview integrator (the `shade` stage of the preview preset): camera rays
// through the pixel centres (through the pixel filter when spp > 1), a bounded specular chain
// through mirrors and glass, then at the first diffuse hit direct light from
// every punctual light and one sample of the emissive triangles, all with hard
// shadows, by the next-event estimator every integrator shares
// (direct_light.glsl). Every ray goes through the frame's BIH (scene_trace.glsl).
//
// One dispatch renders one sample of every pixel of one tile and adds it to
// the film: three vec4 per pixel of the tile, (beauty RGB, coverage),
// (albedo RGB, depth), (normal XYZ, kept samples), sums over the samples so
// far; the host divides. Per pixel, averaged over its samples:
//   beauty  radiance; a NaN/Inf sample is dropped (counted in
//           counters.discarded_samples) and the rest are averaged
//   alpha   fraction of samples whose camera ray hit geometry
//   albedo  albedo of the first diffuse (non-specular) hit, 0 if none
//   normal  world shading normal there, turned to face the arriving ray
//   depth   distance along the camera ray to its first hit; 0 on a miss (not
//           inf, so that averages and image metrics stay finite; alpha tells
//           a miss apart)

layout(local_size_x = 8, local_size_y = 8) in;
const uint GROUP_EDGE = 8u;

layout(push_constant) uniform Push {
    uvec2 tile_origin; // first pixel of the tile in the image
    uvec2 tile_size;   // pixels in the tile; film rows are tile_size.x long
    uint sample_index; // 0 starts the film's sums
} push;

#include "scene_bindings.glsl"
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 0) buffer Film { vec4 film[]; };
layout(std430, set = 0, binding = PF_SCENE_BINDING_COUNT + 1) buffer Counters {
    uint discarded_samples;
    uint rays_traced;
    uint traversal_failures; // rays whose BIH traversal overflowed: the host fails the frame
} counters;

#define BIH_BINDING (PF_SCENE_BINDING_COUNT + 2)
#include "scene_trace.glsl"
#include "camera.glsl"
#include "area_lights.glsl"
#include "lights.glsl"
#include "materials.glsl"
#include "surface.glsl"
#include "rng.glsl"
#include "pixel_filter.glsl"
#include "direct_light.glsl"


// One camera path of one pixel sample: the current ray of the specular chain
// and, once it reaches a diffuse surface, that surface.
struct Path {
    vec3 origin;
    vec3 direction;
    vec3 throughput;
    vec3 radiance;
    bool tracing;      // the chain still has a ray to trace
    bool diffuse_hit;  // the chain ended on a diffuse surface (below)
    bool poisoned;     // a non-finite shading normal was met: the sample is discarded
    vec3 position;
    vec3 shading_normal;
    vec3 geometric_normal; // faces the incoming ray
    bool front;            // the ray arrived at the surface's front face
    vec3 medium;           // absorption of the medium the ray is in (medium_after_transmission)
    float cone_distance;   // the camera ray's length so far (its cone's width: camera.glsl)
    Material surface;
};

// What one pixel sample adds to the film.
struct PixelSums {
    vec3 beauty;
    uint kept_samples;
    uint discarded;
    uint rays;
    float coverage;
    float depth;
    vec3 albedo;
    vec3 normal;
};

// Applies the closest hit of the path's current ray: emission, AOVs of the
// camera hit, then either the end of the chain at a diffuse surface or the
// next specular ray.
void path_follow_hit(inout Path path, BihHit hit, uint depth, float ray_offset, inout uint rng,
                     inout PixelSums sums)
{
    if (hit.triangle == NO_HIT) {
        path.tracing = false;
        return;
    }
    path.throughput *= medium_transmittance(path.medium, hit.t);
    // The camera's ray cone along the specular chain (camera.glsl).
    path.cone_distance += hit.t;
    vec2 cone = camera_cone(params.camera_forward.w, params.image_height, params.camera_up.w != 0.0);
    Surface surface = surface_at_cone(hit, path.origin, path.direction,
                                      cone.x + path.cone_distance * cone.y);
    if (!surface.valid) {
        path.tracing = false;
        path.poisoned = true; // a non-finite normal: the sample is discarded, not repaired
        return;
    }
    Material material = surface.material;
    bool front = surface.front;
    path.geometric_normal = surface.geometric_normal;
    path.front = front;
    path.shading_normal = surface.shading_normal;
    path.position = surface.position;
    if (depth == 0u) {
        sums.coverage += 1.0;
        sums.depth += hit.t;
    }
    if (material_emits(material, front))
        path.radiance += path.throughput * material.emission;
    // Direct light through the full BSDF where the surface has a diffuse base or a glossy
    // reflection, sharp or not; mirrors and glass, smooth or rough, are passed through.
    if (material_estimated_at_d1(material)) {
        path.diffuse_hit = true;
        path.tracing = false;
        path.surface = material;
        sums.albedo += material.albedo;
        sums.normal += path.shading_normal;
        return;
    }
    if (depth == params.max_specular_depth) {
        path.tracing = false; // chain too long: contributes nothing more
        return;
    }
    // A delta lobe needs only the lobe choice; rough glass also a direction
    // (drawn only then, so smooth scenes keep their random sequence).
    vec3 xi = vec3(0.0, 0.0, rng_float(rng));
    if (!material_specular_is_delta(material))
        xi.xy = vec2(rng_float(rng), rng_float(rng));
    BsdfSample scattered = bsdf_sample(material, -path.direction, path.shading_normal,
                                       path.geometric_normal, front, xi, TRANSPORT_RADIANCE);
    path.throughput *= scattered.weight;
    path.direction = scattered.direction;
    path.origin = path.position +
                  (scattered.transmitted ? -ray_offset : ray_offset) * path.geometric_normal;
    if (scattered.transmitted)
        path.medium = medium_after_transmission(material, front);
}

void main()
{
    const float infinity = uintBitsToFloat(0x7f800000u);
    uvec2 local = gl_WorkGroupID.xy * GROUP_EDGE + gl_LocalInvocationID.xy;
    uvec2 pixel = push.tile_origin + local;
    if (any(greaterThanEqual(local, push.tile_size)))
        return;
    uint spp = params.samples_per_pixel;
    float ray_offset = params.camera_right.w;
    vec2 image_size = vec2(params.width, params.height);
    PixelSums sums = PixelSums(vec3(0.0), 0u, 0u, 0u, 0.0, 0.0, vec3(0.0), vec3(0.0));

    uint rng = rng_init(pixel.y * params.width + pixel.x, push.sample_index, params.seed_lo,
                        params.seed_hi);
    vec2 jitter = vec2(0.5);
    if (spp > 1u) {
        // Two statements: the order of side effects inside one expression is not
        // something to rely on across compilers.
        vec2 xi;
        xi.x = rng_float(rng);
        xi.y = rng_float(rng);
        jitter += filter_sample(params.pixel_filter, xi);
    }
    Path path;
    CameraRay ray = camera_ray(params.camera_position.xyz, params.camera_forward.xyz,
                               params.camera_right.xyz, params.camera_up.xyz,
                               params.camera_position.w, params.camera_forward.w,
                               params.camera_up.w != 0.0, vec2(pixel) + jitter, image_size);
    path.origin = ray.origin;
    path.direction = ray.direction;
    path.throughput = vec3(1.0);
    path.radiance = vec3(0.0);
    path.tracing = true;
    path.diffuse_hit = false;
    path.poisoned = false;
    path.position = vec3(0.0);
    path.shading_normal = vec3(0.0, 0.0, 1.0);
    path.geometric_normal = vec3(0.0, 0.0, 1.0);
    path.front = true;
    path.medium = vec3(0.0);
    path.cone_distance = 0.0;
    path.surface = Material(vec3(0.0), MATERIAL_LAMBERT, vec3(0.0), 1.0, 0.0, 1.0, 0.0, 0.0,
                            vec3(1.0), 0u, vec3(0.0), 1.0, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE,
                            NO_TEXTURE, ALPHA_OPAQUE, 0.5, 1.0, 0.0, 0.0, NO_TEXTURE,
                            NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, 0.0, 0.0, 0.0, NO_TEXTURE,
                            1.0, NO_TEXTURE, NO_TEXTURE, vec3(0.0), 0.0);

    // Camera ray, then the specular chain through mirrors and glass.
    for (uint depth = 0u; depth <= params.max_specular_depth && path.tracing; depth++) {
        BihHit hit = trace_seen(path.origin, path.direction, infinity, false, depth == 0u);
        sums.rays++;
        path_follow_hit(path, hit, depth, ray_offset, rng, sums);
    }

    // Direct light at the diffuse hit: the one next-event estimator every integrator
    // shares (direct_light.glsl), with no BSDF ray looking for emission here, so the
    // light sample carries full weight.
    if (path.diffuse_hit) {
        // Separate statements: the order of side effects inside one expression is not
        // something to rely on across compilers.
        vec4 xi;
        xi.x = rng_float(rng);
        xi.y = rng_float(rng);
        xi.z = rng_float(rng);
        xi.w = rng_float(rng);
        vec3 shadow_origin = path.position + ray_offset * path.geometric_normal;
        path.radiance += direct_light(path.surface, path.position, shadow_origin, -path.direction,
                                      path.shading_normal, path.geometric_normal, path.front,
                                      path.throughput, xi, 0.0, DIRECT_LIGHT_PIXEL_SAMPLES,
                                      sums.rays);
    }

    if (!path.poisoned && all_finite(path.radiance)) {
        sums.beauty = path.radiance;
        sums.kept_samples = 1u;
    } else {
        sums.discarded = 1u;
    }
    uint film_index = 3u * (local.y * push.tile_size.x + local.x);
    vec4 beauty = vec4(sums.beauty, sums.coverage);
    vec4 albedo_depth = vec4(sums.albedo, sums.depth);
    vec4 normal_kept = vec4(sums.normal, float(sums.kept_samples));
    if (push.sample_index > 0u) {
        beauty += film[film_index];
        albedo_depth += film[film_index + 1u];
        normal_kept += film[film_index + 2u];
    }
    film[film_index] = beauty;
    film[film_index + 1u] = albedo_depth;
    film[film_index + 2u] = normal_kept;
    if (sums.discarded > 0u)
        atomicAdd(counters.discarded_samples, sums.discarded);
    atomicAdd(counters.rays_traced, sums.rays);
}
