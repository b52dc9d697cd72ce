/*
 * The planner of `auto` (pf_render.h): which preset renders a frame and with
 * how many samples, decided from the scene and the request, recorded with
 * its reason in the frame's `plan` row.
 *
 *   no lights or emissive surfaces     → preview (every preset is black)
 *   neither budget_ms nor target_relmse → fast: global illumination at the
 *                                        LPV's cost, the farm's default
 *   budget_ms                          → a pilot (below) predicts each
 *       preset's time at the full size; final when at least
 *       PLAN_MIN_FINAL_PASSES passes fit, with as many passes as fit
 *       (≤ PLAN_MAX_PASSES); else fast when it fits; else preview
 *   target_relmse                      → the pilot also renders a
 *       higher-sample estimate (final, PLAN_ESTIMATE_PASSES passes) and
 *       measures fast's and one final pass's relMSE against it: fast when
 *       it meets the target, else final with the passes its error needs
 *       under relMSE ∝ passes^(−2/3) (progressive photon mapping at α = 2/3)
 *
 * The pilot renders at a quarter of the size each way (at least
 * PLAN_PILOT_MIN_EDGE), after a tiny warm-up render of each preset so that
 * no pipeline compilation is timed. Its prediction comes from the pilot's
 * own stage rows: the shade row scales with the pixel count, the photon,
 * grid and LPV rows do not; final's rows are per pass. The decision is
 * kept on the renderer (the job's first frame calibrates; later frames of
 * the same scene and request reuse it), so the frames of a job render
 * with one preset and do not flicker between presets. What the pilot
 * renders built or traced is dropped after them (pilot.c): the real frame
 * does its own work, and the pilot's time is the plan row's.
 */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PLAN_MIN_FINAL_PASSES 4u
#define PLAN_MAX_PASSES 256u
#define PLAN_ESTIMATE_PASSES 16u
#define PLAN_PILOT_DIVISOR 4u
#define PLAN_PILOT_MIN_EDGE 16u
#define PLAN_WARMUP_EDGE 8u
/* The denoised error curve's second point, and the flattest slope it is taken to have. */
#define PLAN_SLOPE_PASSES 4u
#define PLAN_MIN_SLOPE 0.25

/* What a pilot render of one preset cost: scalable (shade) and fixed parts, ms. */
typedef struct pilot_cost {
    double scaled_ms, fixed_ms;
} pilot_cost;

static pilot_cost cost_of(const pf_frame_report *report)
{
    pilot_cost cost = {0.0, 0.0};
    for (uint32_t i = 0; i < report->stage_count; i++) {
        const pf_stage_timing *row = &report->stages[i];
        if (row->skipped || !strcmp(row->stage, "bih_build") || !strcmp(row->stage, "denoise"))
            continue; /* the BIH is built once per frame whatever the preset; denoise_ms_of */
        if (!strcmp(row->stage, "shade"))
            cost.scaled_ms += row->wall_ms;
        else
            cost.fixed_ms += row->wall_ms;
    }
    return cost;
}

static double predict(pilot_cost cost, double scale, double repeats)
{
    return repeats * (cost.fixed_ms + cost.scaled_ms * scale);
}

static int same_request(const struct pf_plan_cache *cache, const pf_scene_frame *frame,
                        const pf_render_settings *settings)
{
    return cache->valid && cache->triangle_count == frame->triangle_count &&
           cache->light_count == frame->light_count &&
           cache->material_count == frame->material_count &&
           cache->width == settings->width && cache->height == settings->height &&
           cache->budget_ms == settings->budget_ms &&
           cache->target_relmse == settings->target_relmse && cache->denoise == settings->denoise;
}

/*
 * Renders the pilot of quality at the pilot size; its report in *report, image kept in *image.
 * denoise: then the denoise stage too, as the frame will be (its row in the report).
 */
static pf_status pilot_render(pf_renderer *renderer, const pf_scene_frame *frame,
                              const pf_render_settings *base, pf_quality quality,
                              uint32_t samples, int denoise, pf_image *image,
                              pf_frame_report *report, pf_error *err)
{
    pf_render_settings s = *base;
    s.quality = quality;
    s.samples_per_pixel = samples;
    s.aovs = denoise; /* the denoiser's guides */
    s.time_budget_ms = 0.0;
    memset(report, 0, sizeof *report);
    pf_status status = pf_render_preset(renderer, frame, &s, image, report, err);
    if (status == PF_OK && denoise)
        status = pf_denoise_image(image, 0, NULL, report, err);
    return status;
}

/* The denoise row's time in report (0 without one): it scales with the pixels, once a frame. */
static double denoise_ms_of(const pf_frame_report *report)
{
    for (uint32_t i = 0; i < report->stage_count; i++)
        if (!strcmp(report->stages[i].stage, "denoise"))
            return report->stages[i].wall_ms;
    return 0.0;
}

/* A pilot's side: a quarter of the frame's, at least PLAN_PILOT_MIN_EDGE (or the whole side). */
static uint32_t pilot_edge(uint32_t edge)
{
    uint32_t quarter = edge / PLAN_PILOT_DIVISOR;
    if (quarter > PLAN_PILOT_MIN_EDGE)
        return quarter;
    return edge < PLAN_PILOT_MIN_EDGE ? edge : PLAN_PILOT_MIN_EDGE;
}

/* relMSE over R, G, B of a against b (pf_image_compare's, on those channels alone: a
 * denoised pilot has its AOVs, the estimate not). */
static pf_status relmse_of(const pf_image *a, const pf_image *b, double *relmse, pf_error *err)
{
    static const char *const rgb[3] = {"R", "G", "B"};
    pf_image a_rgb = {0}, b_rgb = {0};
    pf_image_metrics metrics;
    pf_status status = pf_image_select(a, rgb, 3, &a_rgb, err);
    if (status == PF_OK)
        status = pf_image_select(b, rgb, 3, &b_rgb, err);
    if (status == PF_OK)
        status = pf_image_compare(&a_rgb, &b_rgb, &metrics, err);
    *relmse = status == PF_OK ? metrics.relmse : NAN;
    pf_image_free(&a_rgb);
    pf_image_free(&b_rgb);
    return status;
}

/* The pilot and the decision for a budget or an error target. */
static pf_status calibrate(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_render_settings *settings, struct pf_plan_cache *plan,
                           pf_error *err)
{
    pf_render_settings base = *settings;
    base.width = pilot_edge(base.width);
    base.height = pilot_edge(base.height);
    double scale = ((double)settings->width * settings->height) / ((double)base.width * base.height);
    pf_frame_report report;
    pf_image image = {0};
    pf_pilot_history history;
    pf_pilot_begin(renderer, &history);
    /* Warm-up: pipelines compile on their first dispatch on some drivers (lavapipe). */
    pf_render_settings warm = base;
    warm.width = warm.height = PLAN_WARMUP_EDGE;
    /* What the frame will denoise, the pilot denoises: its time and its error count. */
    int fast_denoised = pf_denoise_applies(settings->denoise, PF_QUALITY_FAST);
    int final_denoised = pf_denoise_applies(settings->denoise, PF_QUALITY_FINAL);
    pf_status status = pilot_render(renderer, frame, &warm, PF_QUALITY_FAST, 1, 0, &image,
                                    &report, err);
    pf_image_free(&image);
    if (status == PF_OK)
        status = pilot_render(renderer, frame, &warm, PF_QUALITY_FINAL, 1, 0, &image, &report,
                              err);
    pf_image_free(&image);
    pf_image fast_image = {0}, final_image = {0}, estimate = {0};
    pilot_cost fast = {0, 0}, final_pass = {0, 0};
    double fast_denoise_ms = 0.0, final_denoise_ms = 0.0;
    if (status == PF_OK)
        status = pilot_render(renderer, frame, &base, PF_QUALITY_FAST, 0, fast_denoised,
                              &fast_image, &report, err);
    if (status == PF_OK) {
        fast = cost_of(&report);
        fast_denoise_ms = denoise_ms_of(&report) * scale;
        status = pilot_render(renderer, frame, &base, PF_QUALITY_FINAL, 1, final_denoised,
                              &final_image, &report, err);
    }
    if (status == PF_OK) {
        final_pass = cost_of(&report);
        final_denoise_ms = denoise_ms_of(&report) * scale;
    }
    double fast_ms = predict(fast, scale, 1.0) + fast_denoise_ms;
    double pass_ms = predict(final_pass, scale, 1.0);
    plan->fast_ms = fast_ms;
    plan->pass_ms = pass_ms;
    plan->denoise_ms = final_denoise_ms;
    plan->denoised = final_denoised;
    if (status == PF_OK && settings->target_relmse > 0.0) {
        status = pilot_render(renderer, frame, &base, PF_QUALITY_FINAL, PLAN_ESTIMATE_PASSES, 0,
                              &estimate, &report, err);
        if (status == PF_OK)
            status = relmse_of(&fast_image, &estimate, &plan->fast_relmse, err);
        if (status == PF_OK)
            status = relmse_of(&final_image, &estimate, &plan->pass_relmse, err);
        /*
         * Denoised, the error does not fall as passes^-2/3: the filter takes noise and leaves
         * bias, more of one than the other at each pass count. A second denoised pilot at
         * PLAN_SLOPE_PASSES passes measures how it falls, error ∝ passes^-slope, and the
         * passes are counted from that point: beyond it with the slope within
         * [PLAN_MIN_SLOPE, 2/3] (never faster than raw; a flat curve asks for many
         * passes), short of it with the slope as measured (at least PLAN_MIN_SLOPE).
         */
        plan->slope = 2.0 / 3.0;
        plan->anchor_passes = 1;
        plan->anchor_relmse = plan->pass_relmse;
        if (status == PF_OK && final_denoised) {
            pf_image more = {0};
            status = pilot_render(renderer, frame, &base, PF_QUALITY_FINAL, PLAN_SLOPE_PASSES,
                                  1, &more, &report, err);
            if (status == PF_OK)
                status = relmse_of(&more, &estimate, &plan->slope_relmse, err);
            pf_image_free(&more);
            double slope = plan->slope_relmse > 0.0 && plan->pass_relmse > 0.0
                               ? log(plan->pass_relmse / plan->slope_relmse) /
                                     log((double)PLAN_SLOPE_PASSES)
                               : 0.0;
            int beyond = plan->slope_relmse > settings->target_relmse;
            plan->slope = slope < PLAN_MIN_SLOPE          ? PLAN_MIN_SLOPE
                          : beyond && slope > 2.0 / 3.0 ? 2.0 / 3.0
                                                        : slope;
            plan->anchor_passes = PLAN_SLOPE_PASSES;
            plan->anchor_relmse = plan->slope_relmse;
        }
        if (status == PF_OK) {
            if (plan->fast_relmse <= settings->target_relmse) {
                plan->quality = PF_QUALITY_FAST;
                plan->passes = 0;
                plan->predicted_ms = fast_ms;
                snprintf(plan->reason, sizeof plan->reason,
                         "auto → fast: its pilot relMSE %.4g meets the target %.4g",
                         plan->fast_relmse, settings->target_relmse);
            } else {
                double passes = plan->anchor_passes *
                                pow(plan->anchor_relmse / settings->target_relmse,
                                    1.0 / plan->slope);
                plan->quality = PF_QUALITY_FINAL;
                plan->passes = passes >= PLAN_MAX_PASSES ? PLAN_MAX_PASSES
                               : passes < 1.0            ? 1u
                                                         : (uint32_t)ceil(passes);
                plan->predicted_ms = pass_ms * plan->passes + plan->denoise_ms;
                if (final_denoised)
                    snprintf(plan->reason, sizeof plan->reason,
                             "auto → final, %u passes: fast's pilot relMSE %.3g misses %.3g; "
                             "denoised, 1 pass %.3g, %u passes %.3g: passes^-%.2g",
                             plan->passes, plan->fast_relmse, settings->target_relmse,
                             plan->pass_relmse, PLAN_SLOPE_PASSES, plan->slope_relmse,
                             plan->slope);
                else
                    snprintf(plan->reason, sizeof plan->reason,
                             "auto → final, %u passes: fast's pilot relMSE %.4g misses the "
                             "target %.4g, one pass's %.4g falls as passes^-2/3",
                             plan->passes, plan->fast_relmse, settings->target_relmse,
                             plan->pass_relmse);
            }
        }
    } else if (status == PF_OK) {
        /* The denoise stage runs once a frame: what is left of the budget buys passes. */
        double fit = (settings->budget_ms - plan->denoise_ms) / (pass_ms > 0.0 ? pass_ms : 1e-3);
        if (fit >= PLAN_MIN_FINAL_PASSES) {
            plan->quality = PF_QUALITY_FINAL;
            plan->passes = fit >= PLAN_MAX_PASSES ? PLAN_MAX_PASSES : (uint32_t)floor(fit);
            plan->predicted_ms = pass_ms * plan->passes + plan->denoise_ms;
            if (final_denoised)
                snprintf(plan->reason, sizeof plan->reason,
                         "auto → final, %u passes: a pass ≈ %.0f ms and denoising ≈ %.0f ms "
                         "(pilot), budget %.0f ms",
                         plan->passes, pass_ms, plan->denoise_ms, settings->budget_ms);
            else
                snprintf(plan->reason, sizeof plan->reason,
                         "auto → final, %u passes: a pass ≈ %.0f ms (pilot), budget %.0f ms",
                         plan->passes, pass_ms, settings->budget_ms);
        } else if (fast_ms <= settings->budget_ms) {
            plan->quality = PF_QUALITY_FAST;
            plan->passes = 0;
            plan->predicted_ms = fast_ms;
            snprintf(plan->reason, sizeof plan->reason,
                     "auto → fast: ≈ %.0f ms (pilot); %u final passes need %.0f ms, budget %.0f ms",
                     fast_ms, PLAN_MIN_FINAL_PASSES, PLAN_MIN_FINAL_PASSES * pass_ms,
                     settings->budget_ms);
        } else {
            plan->quality = PF_QUALITY_PREVIEW;
            plan->passes = 0;
            plan->predicted_ms = 0.0;
            snprintf(plan->reason, sizeof plan->reason,
                     "auto → preview: fast needs ≈ %.0f ms (pilot), budget %.0f ms", fast_ms,
                     settings->budget_ms);
        }
    }
    pf_image_free(&fast_image);
    pf_image_free(&final_image);
    pf_image_free(&estimate);
    pf_pilot_end(renderer, &history);
    return status;
}

pf_status pf_plan_frame(pf_renderer *renderer, const pf_scene_frame *frame,
                        const pf_render_settings *settings, pf_render_settings *chosen,
                        pf_frame_report *report, pf_error *err)
{
    *chosen = *settings;
    double start = pf_time_ms();
    pf_vk_traffic before = pf_vk_traffic_of(renderer->ctx); /* the pilot's, when it runs */
    struct pf_plan_cache *plan = &renderer->plan;
    int has_emitters = frame->light_count > 0 || frame->emissive_triangle_count > 0;
    int calibrated = 0;
    if (!has_emitters) {
        memset(plan, 0, sizeof *plan);
        plan->quality = PF_QUALITY_PREVIEW;
        snprintf(plan->reason, sizeof plan->reason,
                 "auto → preview: no lights or emissive surfaces (every preset is black)");
    } else if (!(settings->budget_ms > 0.0) && !(settings->target_relmse > 0.0)) {
        memset(plan, 0, sizeof *plan);
        plan->quality = PF_QUALITY_FAST;
        snprintf(plan->reason, sizeof plan->reason,
                 "auto → fast: no --budget-ms or --target-relmse (global illumination by LPV, "
                 "the farm default)");
    } else if (!same_request(plan, frame, settings)) {
        memset(plan, 0, sizeof *plan);
        pf_status status = calibrate(renderer, frame, settings, plan, err);
        if (status != PF_OK) {
            memset(plan, 0, sizeof *plan);
            return pf_error_prefix(err, "auto's pilot render"), status;
        }
        plan->valid = 1;
        plan->triangle_count = frame->triangle_count;
        plan->light_count = frame->light_count;
        plan->material_count = frame->material_count;
        plan->width = settings->width;
        plan->height = settings->height;
        plan->budget_ms = settings->budget_ms;
        plan->target_relmse = settings->target_relmse;
        plan->denoise = settings->denoise;
        calibrated = 1;
    }
    chosen->quality = plan->quality;
    chosen->samples_per_pixel = plan->quality == PF_QUALITY_FINAL ? plan->passes
                                : plan->quality == PF_QUALITY_FAST ? settings->samples_per_pixel
                                                                   : 0;
    pf_stage_timing *row = pf_frame_report_add(report, "plan");
    if (row) {
        row->wall_ms = pf_time_ms() - start;
        snprintf(row->reason, sizeof row->reason, "%s", plan->reason);
        pf_stage_add_traffic(row, pf_vk_traffic_since(renderer->ctx, before));
        pf_stage_add_counter(row, "calibrated", calibrated);
        if (plan->valid) {
            pf_stage_add_counter(row, "budget_ms", settings->budget_ms);
            pf_stage_add_counter(row, "predicted_ms", plan->predicted_ms);
            pf_stage_add_counter(row, "fast_ms", plan->fast_ms);
            pf_stage_add_counter(row, "final_pass_ms", plan->pass_ms);
            pf_stage_add_counter(row, "passes", plan->passes);
            pf_stage_add_counter(row, "denoised", plan->denoised);
            pf_stage_add_counter(row, "denoise_ms", plan->denoise_ms);
            if (settings->target_relmse > 0.0) {
                pf_stage_add_counter(row, "fast_relmse", plan->fast_relmse);
                pf_stage_add_counter(row, "final_pass_relmse", plan->pass_relmse);
                pf_stage_add_counter(row, "final_slope_relmse", plan->slope_relmse);
                pf_stage_add_counter(row, "error_slope", plan->slope);
            }
        }
    }
    return PF_OK;
}
