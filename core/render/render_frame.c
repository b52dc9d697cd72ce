/*
 * One frame of a preset (pf_render_preset, under pf_render_frame and auto's
 * pilot): checks the settings, plans the frame's stages (stage_plan.c) and
 * runs them in one loop (run_stages) through the preset's integrator
 * (preview: frame_direct.c; reference: frame_reference.c; final:
 * frame_final.c; fast: frame_fast.c).
 */
#include "render_internal.h"

#include <string.h>

/* Largest image side accepted: pixel indices (y * width + x) stay well inside 32 bits. */
#define RENDER_MAX_EDGE 16384u

/* Whether stage runs in this pass loop or once. */
static int per_pass(const pf_integrator *integrator, int stage)
{
    return (integrator->per_pass >> stage) & 1u;
}

/* The metered traffic as counters of the rows the stage loop's calls wrote (from
 * first_row on); rows of skipped stages have none. */
static void add_traffic_counters(const pf_frame_run *run, uint32_t first_row)
{
    for (uint32_t i = first_row; run->report && i < run->report->stage_count; i++) {
        pf_stage_timing *row = &run->report->stages[i];
        if (row->skipped)
            continue;
        if (!strcmp(row->stage, "textures"))
            pf_stage_add_traffic(row, run->textures_traffic);
        for (int stage = 0; stage < PF_STAGE_COUNT; stage++)
            if (!strcmp(row->stage, pf_stage_name((pf_stage_id)stage)))
                pf_stage_add_traffic(row, run->traffic[stage]);
    }
}

/* Adds the device traffic since *mark to *to and moves the mark: charged in turn, the
 * stages share every submission of the frame between them. */
static void charge(pf_vk_context *ctx, pf_vk_traffic *mark, pf_vk_traffic *to)
{
    pf_traffic_add(to, pf_vk_traffic_since(ctx, *mark));
    *mark = pf_vk_traffic_of(ctx); /* the frame's stages run on one thread: nothing between */
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
    pf_vk_context *ctx = pf_renderer_context(run->renderer);
    pf_vk_traffic *shade = &run->traffic[PF_STAGE_SHADE];
    uint32_t first_row = run->report ? run->report->stage_count : 0;
    pf_vk_traffic mark = pf_vk_traffic_of(ctx);
    /* The filter the frame's camera kernels are specialised for (pf_renderer_pipeline). */
    run->renderer->pixel_filter = (uint32_t)run->settings->pixel_filter % PF_PIXEL_FILTER_COUNT;
    pf_status status = pf_render_prepare_textures(run->renderer, run->frame, run->report, err);
    charge(ctx, &mark, &run->textures_traffic);
    if (status == PF_OK)
        status = pf_render_prepare_bih(run->renderer, run->frame,
                                       &plan->stages[PF_STAGE_BIH_BUILD], run->report, err);
    charge(ctx, &mark, &run->traffic[PF_STAGE_BIH_BUILD]);
    if (status == PF_OK && integrator->begin)
        status = integrator->begin(run, err);
    charge(ctx, &mark, shade);
    if (status != PF_OK)
        return status;
    for (int stage = PF_STAGE_BIH_BUILD + 1; status == PF_OK && stage < PF_STAGE_COUNT; stage++)
        if (!per_pass(integrator, stage) && plan->stages[stage].action == PF_STAGE_RUN) {
            status = integrator->run(run, (pf_stage_id)stage, 0, err);
            charge(ctx, &mark, &run->traffic[stage]);
        }
    double budget = run->settings->time_budget_ms;
    for (uint32_t pass = 0; integrator->per_pass && status == PF_OK && pass < plan->samples;
         pass++) {
        if (pass > 0 && budget > 0.0 && pf_time_ms() - run->start_ms >= budget) {
            run->passes = pass;
            break;
        }
        for (int stage = 0; status == PF_OK && stage < PF_STAGE_COUNT; stage++)
            if (per_pass(integrator, stage) && (plan->stages[stage].action == PF_STAGE_RUN ||
                                                plan->stages[stage].action == PF_STAGE_REUSE)) {
                status = integrator->run(run, (pf_stage_id)stage, pass, err);
                charge(ctx, &mark, &run->traffic[stage]);
            }
    }
    status = integrator->end ? integrator->end(run, status, err) : status;
    charge(ctx, &mark, shade);
    add_traffic_counters(run, first_row);
    return status;
}

pf_status pf_render_settings_check(const pf_render_settings *settings, pf_error *err)
{
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
    return PF_OK;
}

pf_status pf_render_band(pf_renderer *renderer, const pf_scene_frame *frame,
                         const pf_render_settings *settings, pf_image *image,
                         pf_frame_report *report, uint32_t *samples, pf_error *err)
{
    double start_ms = pf_time_ms();
    /* The planner decides every stage before any runs; the loop carries the plan out. */
    pf_stage_plan plan;
    pf_stage_previous previous = pf_stage_previous_of(renderer, settings->quality);
    pf_status status = pf_plan_stages(frame, settings, &previous, &plan, err);
    if (status != PF_OK)
        return status;
    memcpy(renderer->frame_inputs, plan.inputs, sizeof plan.inputs);
    renderer->stage_memory[settings->quality].frames++;
    renderer->stage_memory[settings->quality].pilot_replaced = 0; /* said in this plan */
    static const pf_integrator *const integrators[] = {
        [PF_QUALITY_PREVIEW] = &pf_integrator_preview,
        [PF_QUALITY_FAST] = &pf_integrator_fast,
        [PF_QUALITY_FINAL] = &pf_integrator_final,
        [PF_QUALITY_REFERENCE] = &pf_integrator_reference};
    pf_frame_run run = {renderer, frame, settings, &plan, image, report, start_ms, NULL};
    run.passes = plan.samples;
    status = run_stages(integrators[settings->quality], &run, err);
    if (samples)
        *samples = run.passes;
    pf_stage_plan_release(&plan);
    return status;
}

pf_status pf_render_preset(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_render_settings *settings, pf_image *image,
                           pf_frame_report *report, pf_error *err)
{
    memset(image, 0, sizeof *image);
    pf_status status = pf_render_settings_check(settings, err);
    if (status != PF_OK)
        return status;
    if ((unsigned)settings->quality > PF_QUALITY_REFERENCE)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "quality '%s' is not available (available: preview, fast, final, "
                            "reference, auto)",
                            pf_quality_name(settings->quality));
    if (report)
        report->quality = settings->quality;
    /* A film past one device buffer: the frame in bands of rows (render_bands.c). */
    uint32_t band_rows = pf_render_band_rows(renderer, settings);
    if (band_rows < settings->height)
        return pf_render_bands(renderer, frame, settings, band_rows, image, report, err);
    return pf_render_band(renderer, frame, settings, image, report, NULL, err);
}
