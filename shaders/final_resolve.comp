#version 460
#extension GL_GOOGLE_include_directive : require
// pf-variant: surfaces PF_SURFACE_TEXTURES
// The `final` shade stage's last dispatch of a pixel sample (the header of
// render_final.comp describes them all): each pixel's deferred estimates
// (final_deferred.comp wrote them over their requests) and its sample into
// the film. A module of its own, not a specialisation of final_deferred's:
// lavapipe translates a pipeline's whole module, the estimates' code
// included, whatever a specialisation leaves out. Push block and buffers:
// final_shared.glsl.

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_bindings.glsl"
#include "photon_types.glsl"
#include "photon_grid.glsl"
#include "final_shared.glsl"
#include "materials.glsl"

// The sample's deferred estimates into its indirect light, then the sample
// into the film (kept only if every part of it is).
void resolve(uint pixel_index)
{
    uint sample_base = 3u * pixel_index;
    vec4 sample_direct = texel_vec4(sample_sum_texels, sample_base);
    vec4 sample_indirect = texel_vec4(sample_sum_texels, sample_base + 1u);
    uvec4 requests = texel_uvec4(pixel_fallback_texels, pixel_index);
    for (uint g = 0u; g < push.gather_total; g++) {
        // NO_REQUEST, or (never left by a retrace) anything that is not a slot.
        if (requests[g] >= push.fallback_capacity)
            continue;
        vec4 estimate = texel_vec4(fallback_request_texels, 3u * requests[g] + 2u);
        sample_indirect.xyz += estimate.xyz;
        if (estimate.w != 0.0)
            sample_indirect.w = 0.0;
    }
    bool kept = sample_indirect.w > 0.0 && all_finite(sample_direct.xyz) &&
                all_finite(sample_indirect.xyz);
    vec4 direct_sum = kept ? sample_direct : vec4(0.0);
    vec4 indirect_sum = kept ? sample_indirect : vec4(0.0);
    vec4 caustic_sum = kept ? texel_vec4(sample_sum_texels, sample_base + 2u) : vec4(0.0);
    if (push.sample_index > 0u) {
        direct_sum += texel_vec4(film_texels, sample_base);
        indirect_sum += texel_vec4(film_texels, sample_base + 1u);
        caustic_sum += texel_vec4(film_texels, sample_base + 2u);
    }
    film[sample_base] = direct_sum;
    film[sample_base + 1u] = indirect_sum;
    film[sample_base + 2u] = caustic_sum;
    if (!kept)
        atomicAdd(counters.discarded_samples, 1u);
}

void main()
{
    uvec2 pixel = gl_GlobalInvocationID.xy;
    if (pixel.x >= params.width || pixel.y >= params.height)
        return;
    resolve(pixel.y * params.width + pixel.x);
}
