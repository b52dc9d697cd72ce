/*
 * pf_render_frame: checks the settings, lets auto's planner pick the preset
 * (plan.c), plans the frame's stages (stage_plan.c) and runs them in one
 * loop (run_stages) through the preset's integrator (preview:
 * frame_direct.c; reference: frame_reference.c; final: frame_final.c;
 * fast: frame_fast.c). Also the FrameParams the integrators upload.
 */
#include "render_internal.h"

#include <math.h>
#include <string.h>

/*
 * Secondary rays start this far (relative to the scene's magnitude) off the
 * surface along its geometric normal: ~800 float ulps at the largest
 * coordinate, safely past self-intersection, far below any feature size of
 * the shipped scenes.
 */
#define RAY_OFFSET_RELATIVE 1e-4f
/* Largest image side accepted: pixel indices (y * width + x) stay well inside 32 bits. */
#define RENDER_MAX_EDGE 16384u

/* Largest coordinate magnitude or extent of the scene, at least 1 (meters). */
static float scene_magnitude(const pf_scene_frame *frame)
{
    float magnitude = 1.0f;
    for (int i = 0; i < 3; i++) {
        float extent = frame->bounds_max[i] - frame->bounds_min[i];
        float largest = fmaxf(fabsf(frame->bounds_min[i]), fabsf(frame->bounds_max[i]));
        magnitude = fmaxf(magnitude, fmaxf(extent, largest));
    }
    return magnitude;
}

float pf_render_ray_offset(const pf_scene_frame *frame)
{
    return RAY_OFFSET_RELATIVE * scene_magnitude(frame);
}

void pf_frame_params_fill(const pf_scene_frame *frame, const pf_render_settings *settings,
                          uint32_t spp, const pf_gpu_scene *scene, const pf_bih_gpu_view *bih,
                          pf_frame_params *params)
{
    memset(params, 0, sizeof *params);
    const pf_camera *camera = &frame->camera;
    float tan_half_x = 0.0f, tan_half_y = 0.0f;
    pf_camera_image_plane(camera, settings->width, settings->height, &tan_half_x, &tan_half_y);
    for (int i = 0; i < 3; i++) {
        params->camera_position[i] = camera->position[i];
        params->camera_forward[i] = camera->forward[i];
        params->camera_right[i] = camera->right[i];
        params->camera_up[i] = camera->up[i];
    }
    params->camera_position[3] = tan_half_x;
    params->camera_forward[3] = tan_half_y;
    params->camera_right[3] = pf_render_ray_offset(frame);
    params->width = settings->width;
    params->height = settings->height;
    params->samples_per_pixel = spp;
    params->triangle_count = frame->triangle_count;
    params->light_count = frame->light_count;
    params->emissive_count = scene->emissive_count;
    params->emissive_weight_total = scene->emissive_weight_total;
    params->seed_lo = (uint32_t)settings->seed;
    params->seed_hi = (uint32_t)(settings->seed >> 32);
    params->pixel_filter = (uint32_t)settings->pixel_filter;
    params->max_bounces = settings->bounce_limit ? settings->bounce_limit - 1u : 0xffffffffu;
    params->bih_node_count = bih->node_count;
    for (int i = 0; i < 3; i++) {
        params->bih_bounds_min[i] = bih->bounds_min[i];
        params->bih_bounds_max[i] = bih->bounds_max[i];
    }
}

/* Whether stage runs in this pass loop or once. */
static int per_pass(const pf_integrator *integrator, int stage)
{
    return (integrator->per_pass >> stage) & 1u;
}

/*
 * The one stage loop: bih_build, then the integrator's stages in
 * pf_stage_id order as planned: the once-per-frame ones when the plan runs
 * them, then the per-pass ones (final's progressive passes) once per pass
 * unless the plan skips them; the time budget ends the passes after the
 * first. Rows: textures and bih_build here, the rest at the integrator's end.
 */
static pf_status run_stages(const pf_integrator *integrator, pf_frame_run *run, pf_error *err)
{
    const pf_stage_plan *plan = run->plan;
    pf_status status = pf_render_prepare_textures(run->renderer, run->frame, run->report, err);
    if (status == PF_OK)
        status = pf_render_prepare_bih(run->renderer, run->frame,
                                       &plan->stages[PF_STAGE_BIH_BUILD], run->report, err);
    if (status == PF_OK && integrator->begin)
        status = integrator->begin(run, err);
    if (status != PF_OK)
        return status;
    for (int stage = PF_STAGE_BIH_BUILD + 1; status == PF_OK && stage < PF_STAGE_COUNT; stage++)
        if (!per_pass(integrator, stage) && plan->stages[stage].action == PF_STAGE_RUN)
            status = integrator->run(run, (pf_stage_id)stage, 0, err);
    double budget = run->settings->time_budget_ms;
    for (uint32_t pass = 0; integrator->per_pass && status == PF_OK && pass < plan->samples;
         pass++) {
        if (pass > 0 && budget > 0.0 && pf_time_ms() - run->start_ms >= budget)
            break;
        for (int stage = 0; status == PF_OK && stage < PF_STAGE_COUNT; stage++)
            if (per_pass(integrator, stage) && (plan->stages[stage].action == PF_STAGE_RUN ||
                                                plan->stages[stage].action == PF_STAGE_REUSE))
                status = integrator->run(run, (pf_stage_id)stage, pass, err);
    }
    return integrator->end ? integrator->end(run, status, err) : status;
}

pf_status pf_render_frame(pf_renderer *renderer, const pf_scene_frame *frame,
                          const pf_render_settings *settings, pf_image *image,
                          pf_frame_report *report, pf_error *err)
{
    double start_ms = pf_time_ms();
    if (!renderer || !frame || !settings || !image)
        return pf_error_set(err, PF_ERR_INVALID, "pf_render_frame: NULL argument");
    memset(image, 0, sizeof *image);
    if (settings->width == 0 || settings->height == 0 || settings->width > RENDER_MAX_EDGE ||
        settings->height > RENDER_MAX_EDGE)
        return pf_error_set(err, PF_ERR_INVALID, "image size %ux%u: each side must be 1..%u",
                            settings->width, settings->height, RENDER_MAX_EDGE);
    if (!(settings->time_budget_ms >= 0.0))
        return pf_error_set(err, PF_ERR_INVALID,
                            "time budget %g ms: expected 0 (none) or a positive number",
                            settings->time_budget_ms);
    if (!(settings->budget_ms >= 0.0) || !(settings->target_relmse >= 0.0))
        return pf_error_set(err, PF_ERR_INVALID,
                            "auto's budget %g ms / target relMSE %g: expected 0 (none) or a "
                            "positive number",
                            settings->budget_ms, settings->target_relmse);
    if (settings->quality == PF_QUALITY_AUTO) {
        pf_render_settings chosen;
        pf_frame_report own = {0};
        pf_status status =
            pf_plan_frame(renderer, frame, settings, &chosen, report ? report : &own, err);
        if (status != PF_OK)
            return status;
        return pf_render_frame(renderer, frame, &chosen, image, report, err);
    }
    if ((unsigned)settings->quality > PF_QUALITY_REFERENCE)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "quality '%s' is not available (available: preview, fast, final, "
                            "reference, auto)",
                            pf_quality_name(settings->quality));
    if (report)
        report->quality = settings->quality;
    /* The planner decides every stage before any runs; the loop carries the plan out. */
    pf_stage_plan plan;
    pf_status status = pf_plan_stages(renderer, frame, settings, &plan, err);
    if (status != PF_OK)
        return status;
    renderer->stage_memory[settings->quality].frames++;
    renderer->stage_memory[settings->quality].pilot_replaced = 0; /* said in this plan */
    static const pf_integrator *const integrators[] = {
        [PF_QUALITY_PREVIEW] = &pf_integrator_preview,
        [PF_QUALITY_FAST] = &pf_integrator_fast,
        [PF_QUALITY_FINAL] = &pf_integrator_final,
        [PF_QUALITY_REFERENCE] = &pf_integrator_reference};
    pf_frame_run run = {renderer, frame, settings, &plan, image, report, start_ms, NULL};
    status = run_stages(integrators[settings->quality], &run, err);
    pf_stage_plan_release(&plan);
    return status;
}
