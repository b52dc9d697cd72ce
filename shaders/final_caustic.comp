#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` shade stage's caustic dispatch (render_final.comp's header
// describes a sample's dispatches), run after the primary only when the
// pass has a caustic map bound: the caustic estimate at each pixel's first
// diffuse vertex D₁ (albedo/π × caustic irradiance, at the pixel's
// progressive radius) into the sample's caustic and indirect light. A
// kernel of its own because llvmpipe's `if` masks lanes and never branches:
// in the primary, the k-NN estimate's straight-line code (its heap's sift
// steps) ran for every pixel of scenes with no caustic map at all, a
// quarter of the primary's time on the Cornell box.

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"
// The k-NN keeps no more neighbours than the one k asked for, CAUSTIC_NEAREST.
#define PHOTON_KNN_MAX 8u
#include "final_shared.glsl"
#include "materials.glsl"
#include "kernel_guard.glsl"

// Caustic radius per pixel, progressive (SPPM's per-pixel radius in the
// probabilistic form): the first pass picks each pixel's radius as the
// distance of its CAUSTIC_NEAREST-th nearest caustic photon (bounded by the
// pass radius), so it adapts to the caustic's density; every later pass i
// uses that radius × push.caustic_scale = r_i / r_1, the same α = 2/3
// reduction as the global radius, with the fixed-radius cone estimate.
// Re-choosing the k nearest in every pass instead would keep the estimate's
// bias (light smeared around a small bright caustic over the k-th distance)
// the same in every pass, so the average over passes would not converge.
// k = 8 rather than 32: a smaller first radius starts with less of that bias,
// and the passes average the extra noise away (on caustic-anim's caustic the
// block error after 16 passes was 0.006 at k = 8 against 0.028 at k = 32,
// tests/render/test_final_caustic.c's measure, 10,000 photons per pass).
const uint CAUSTIC_NEAREST = PHOTON_KNN_MAX;

// Radiance the surface reflects (directional albedo/π × irradiance, in watts by
// the map's flux scale) from the bound caustic map, at the pixel's
// progressive caustic radius (above); the first pass also records that radius.
vec3 caustic_radiance(Material material, vec3 wo, vec3 shading_normal, vec3 position,
                      vec3 geometric_normal, uint pixel_index, inout bool truncated)
{
    bool stopped;
    vec3 irradiance;
    if (push.sample_index == 0u) {
        float radius_used;
        irradiance = photon_irradiance_knn(position, geometric_normal, CAUSTIC_NEAREST,
                                           push.radius, bound_grid(), radius_used, stopped);
        caustic_radii[pixel_index] = radius_used;
    } else {
        float radius = min(caustic_radii[pixel_index] * push.caustic_scale, push.radius);
        irradiance = photon_irradiance_guarded(position, geometric_normal, radius, bound_grid(),
                                               stopped);
    }
    truncated = truncated || stopped;
    // The directional albedo of the rough lobes towards wo, as the gather's estimates.
    return material_rough_albedo(material, wo, shading_normal, true) * (push.flux_scale / PI) *
           irradiance;
}

// The pixel's caustic light at D₁, where the primary found one and kept the
// sample; a stopped or non-finite estimate drops the sample (as the primary
// would have), and the gather then skips it.
void caustic(uint pixel_index)
{
    uint base = 3u * pixel_index, weight_base = 2u * pixel_index;
    uint sample_base = 3u * pixel_index;
    vec4 d1 = texel_vec4(vertex_texels, base);
    vec4 geometric = texel_vec4(vertex_texels, base + 2u);
    vec4 sample_indirect = texel_vec4(sample_sum_texels, sample_base + 1u);
    if (geometric.w == 0.0 || sample_indirect.w == 0.0)
        return;
    vec4 throughput = texel_vec4(vertex_weight_texels, weight_base);
    vec4 shading = texel_vec4(vertex_texels, base + 1u);
    vec4 wo = texel_vec4(vertex_weight_texels, weight_base + 1u);
    Material material =
        scene_coat_normal(scene_material_at(floatBitsToUint(shading.w), throughput.w, wo.w),
                          floatBitsToUint(shading.w), throughput.w, wo.w, geometric.xyz);
    bool truncated = false;
    vec3 light = throughput.xyz *
                 caustic_radiance(material, wo.xyz, shading.xyz, d1.xyz, geometric.xyz,
                                  pixel_index, truncated);
    bool completed = loops_completed() && !truncated;
    if (!completed)
        atomicAdd(counters.loop_truncated, 1u);
    if (!completed || !all_finite(light)) {
        sample_sums[sample_base + 1u].w = 0.0;
        vertices[base].w = 0.0;
        return;
    }
    sample_sums[sample_base + 1u] = vec4(sample_indirect.xyz + light, sample_indirect.w);
    sample_sums[sample_base + 2u] = vec4(light, 0.0);
}

void main()
{
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    caustic(pixel.y * params.width + pixel.x);
}
