/* pf_renderer lifetime: the compute pipelines every frame uses. */
#include "render_internal.h"

#include <stdlib.h>

/* raycast_brute.comp: constant_id 0 selects the any-hit (shadow) variant. */
#define RAYCAST_SPEC_ANY_HIT 0u
#define RAYCAST_BUFFERS 3u
/* raycast_brute.comp's Push: ray count, triangle range begin/end, carry flag. */
#define RAYCAST_PUSH_BYTES 16u
#define RENDER_DIRECT_BUFFERS 12u
#define RENDER_DIRECT_PUSH_BYTES 20u
/* render_reference.comp: constant_id 0 says whether the AOV film is written. */
#define REFERENCE_SPEC_AOVS 0u
#define RENDER_REFERENCE_BUFFERS 13u
#define RENDER_REFERENCE_PUSH_BYTES 4u
/* render_final.comp: constant_id 0 is MODE (0 primary, 1 gather); 18 buffers, 76-byte Push. */
#define FINAL_SPEC_MODE 0u
#define RENDER_FINAL_BUFFERS 18u
#define RENDER_FINAL_PUSH_BYTES 76u
#define MATERIAL_PROBE_BUFFERS 2u
#define MATERIAL_PROBE_PUSH_BYTES 4u

pf_status pf_renderer_create(pf_vk_context *ctx, pf_renderer **out, pf_error *err)
{
    *out = NULL;
    pf_renderer *renderer = calloc(1, sizeof *renderer);
    if (!renderer)
        return pf_error_set(err, PF_ERR_NOMEM, "renderer: out of memory");
    renderer->ctx = ctx;
    pf_vk_spec_constant closest = {RAYCAST_SPEC_ANY_HIT, 0};
    pf_vk_spec_constant any = {RAYCAST_SPEC_ANY_HIT, 1};
    pf_status status = pf_vk_pipeline_create_named(ctx, "raycast_brute", RAYCAST_BUFFERS,
                                                   RAYCAST_PUSH_BYTES, &closest, 1,
                                                   &renderer->raycast_closest, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "raycast_brute", RAYCAST_BUFFERS,
                                             RAYCAST_PUSH_BYTES, &any, 1, &renderer->raycast_any,
                                             err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "render_direct", RENDER_DIRECT_BUFFERS,
                                             RENDER_DIRECT_PUSH_BYTES, NULL, 0,
                                             &renderer->render_direct, err);
    pf_vk_spec_constant with_aovs = {REFERENCE_SPEC_AOVS, 1};
    pf_vk_spec_constant without_aovs = {REFERENCE_SPEC_AOVS, 0};
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "render_reference", RENDER_REFERENCE_BUFFERS,
                                             RENDER_REFERENCE_PUSH_BYTES, &with_aovs, 1,
                                             &renderer->render_reference, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "render_reference", RENDER_REFERENCE_BUFFERS,
                                             RENDER_REFERENCE_PUSH_BYTES, &without_aovs, 1,
                                             &renderer->render_reference_rgb, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "material_probe", MATERIAL_PROBE_BUFFERS,
                                             MATERIAL_PROBE_PUSH_BYTES, NULL, 0,
                                             &renderer->material_probe, err);
    pf_vk_spec_constant final_primary = {FINAL_SPEC_MODE, 0};
    pf_vk_spec_constant final_gather = {FINAL_SPEC_MODE, 1};
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "render_final", RENDER_FINAL_BUFFERS,
                                             RENDER_FINAL_PUSH_BYTES, &final_primary, 1,
                                             &renderer->render_final_primary, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_create_named(ctx, "render_final", RENDER_FINAL_BUFFERS,
                                             RENDER_FINAL_PUSH_BYTES, &final_gather, 1,
                                             &renderer->render_final_gather, err);
    if (status != PF_OK) {
        pf_renderer_destroy(renderer);
        return status;
    }
    *out = renderer;
    return PF_OK;
}

void pf_renderer_destroy(pf_renderer *renderer)
{
    if (!renderer)
        return;
    pf_vk_pipeline *pipelines[] = {renderer->raycast_closest, renderer->raycast_any,
                                   renderer->render_direct, renderer->render_reference,
                                   renderer->render_reference_rgb, renderer->material_probe,
                                   renderer->render_final_primary, renderer->render_final_gather,
                                   renderer->render_fast};
    for (size_t i = 0; i < sizeof pipelines / sizeof pipelines[0]; i++) {
        if (pipelines[i])
            pf_vk_pipeline_destroy(renderer->ctx, pipelines[i]);
    }
    pf_final_cache_destroy(renderer->final_cache);
    pf_fast_cache_destroy(renderer->ctx, renderer->fast_cache);
    pf_photon_tracer_destroy(renderer->photon_tracer);
    pf_bih_gpu_destroy(renderer->bih_gpu);
    pf_bih_gpu_builder_destroy(renderer->bih_builder);
    if (renderer->bih_valid)
        pf_bih_free(&renderer->bih);
    free(renderer);
}
