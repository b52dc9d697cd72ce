/* pf_renderer's lifetime: what it holds across frames, freed with it. */
#include "render_internal.h"

#include <stdlib.h>

pf_status pf_renderer_create(pf_vk_context *ctx, pf_renderer **out, pf_error *err)
{
    *out = NULL;
    pf_renderer *renderer = calloc(1, sizeof *renderer);
    if (!renderer)
        return pf_error_set(err, PF_ERR_NOMEM, "renderer: out of memory");
    renderer->ctx = ctx;
    *out = renderer;
    return PF_OK;
}

pf_vk_context *pf_renderer_context(const pf_renderer *renderer) { return renderer->ctx; }

void pf_renderer_set_denoise_site(pf_renderer *renderer, pf_denoise_site site)
{
    renderer->denoise_site = site;
}

pf_denoise_history *pf_renderer_denoise_history(pf_renderer *renderer)
{
    /* Out of memory leaves it NULL: the frame is then denoised alone, which is still right. */
    if (!renderer->denoise_history)
        pf_denoise_history_create(&renderer->denoise_history, NULL);
    return renderer->denoise_history;
}

void pf_renderer_destroy(pf_renderer *renderer)
{
    if (!renderer)
        return;
    for (size_t f = 0; f < PF_PIXEL_FILTER_COUNT; f++)
        for (size_t v = 0; v < PF_SURFACE_VARIANTS; v++)
            for (size_t i = 0; i < PF_PIPELINE_COUNT; i++)
                if (renderer->pipelines[f][v][i])
                    pf_vk_pipeline_destroy(renderer->ctx, renderer->pipelines[f][v][i]);
    pf_final_cache_destroy(renderer->final_cache);
    pf_fast_cache_destroy(renderer->ctx, renderer->fast_cache);
    pf_photon_tracer_destroy(renderer->photon_tracer);
    pf_denoise_history_destroy(renderer->denoise_history);
    pf_deform_cache_destroy(renderer->ctx, renderer->deform_cache);
    pf_bih_gpu_destroy(renderer->bih_gpu);
    pf_render_buffer_release(renderer->ctx, &renderer->textures.textures);
    pf_render_buffer_release(renderer->ctx, &renderer->textures.texels);
    pf_bih_gpu_builder_destroy(renderer->bih_builder);
    if (renderer->bih_valid)
        pf_bih_free(&renderer->bih);
    pf_renderer_bih_wide_drop(renderer);
    free(renderer);
}
