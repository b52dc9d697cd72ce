/*
 * pf_render_frame (pf_render.h): auto's planner (plan.c) picks the preset,
 * its pilot renders included, above the preset's frame (render_frame.c), so
 * neither calls the other back.
 */
#include "render_internal.h"

#include <string.h>

pf_status pf_render_frame(pf_renderer *renderer, const pf_scene_frame *frame,
                          const pf_render_settings *settings, pf_image *image,
                          pf_frame_report *report, pf_error *err)
{
    if (!renderer || !frame || !settings || !image)
        return pf_error_set(err, PF_ERR_INVALID, "pf_render_frame: NULL argument");
    if (settings->quality != PF_QUALITY_AUTO) /* it checks the settings itself */
        return pf_render_preset(renderer, frame, settings, image, report, err);
    /* auto's request is checked before any pilot renders. */
    memset(image, 0, sizeof *image);
    pf_status status = pf_render_settings_check(settings, err);
    if (status != PF_OK)
        return status;
    pf_render_settings chosen;
    pf_frame_report own = {0};
    status = pf_plan_frame(renderer, frame, settings, &chosen, report ? report : &own, err);
    if (status != PF_OK)
        return status;
    return pf_render_preset(renderer, frame, &chosen, image, report, err);
}
