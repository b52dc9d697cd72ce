/*
 * auto's pilot renders leave nothing for the real frame (render_internal.h,
 * pf_pilot_history). They run through the renderer the job's frames use, so
 * they build the BIH, upload the textures and trace photon passes that the
 * renderer then keeps. Had the real frame reused them, its rows would have
 * claimed work "from the previous frame" on the first frame of a job, and the
 * stored timings would have left the work out of every frame. The pilot's
 * time is the `plan` row's; the real frame builds, uploads and traces again.
 */
#include "render_internal.h"

#include <string.h>

void pf_pilot_begin(pf_renderer *renderer, pf_pilot_history *saved)
{
    for (int q = 0; q < PF_QUALITY_AUTO; q++)
        saved->frames[q] = renderer->stage_memory[q].frames;
    saved->bih_frames = renderer->bih_frames;
    saved->texture_set = renderer->textures.texture_set;
    /* The host work meant to overlap the real frame's last submission waits for it. */
    saved->overlap = renderer->overlap;
    saved->overlap_arg = renderer->overlap_arg;
    renderer->overlap = NULL;
}

void pf_pilot_end(pf_renderer *renderer, const pf_pilot_history *saved)
{
    renderer->overlap = saved->overlap;
    renderer->overlap_arg = saved->overlap_arg;
    /* Every kept stage output may be the pilot's now: none is reused. */
    for (int q = 0; q < PF_QUALITY_AUTO; q++) {
        pf_stage_memory *memory = &renderer->stage_memory[q];
        int touched = memory->frames != saved->frames[q];
        if (touched) {
            pf_stage_forget(memory);
            memory->frames = saved->frames[q];
            memory->pilot_replaced = saved->frames[q] > 0;
        }
    }
    if (renderer->bih_frames != saved->bih_frames) {
        if (renderer->bih_valid)
            pf_bih_free(&renderer->bih);
        renderer->bih_valid = 0;
        pf_renderer_bih_wide_drop(renderer);
        renderer->bih_frames = saved->bih_frames;
        renderer->bih_pilot_replaced = saved->bih_frames > 0;
    }
    /* Textures the pilot uploaded (a previous real frame's stay: they were its work). */
    pf_texture_cache *cache = &renderer->textures;
    if (cache->texture_set != saved->texture_set) {
        pf_render_buffer_release(renderer->ctx, &cache->textures);
        pf_render_buffer_release(renderer->ctx, &cache->texels);
        cache->texture_set = 0;
    }
}
