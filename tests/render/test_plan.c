/*
 * The planner of `auto` (core/render/plan.c, issue 12's first step): the
 * preset it picks and the reason it records, asserted on the `plan` row's
 * counters and the report's preset, never on wall time.
 *   - no lights → preview;
 *   - no budget or target → fast, no pilot;
 *   - a budget on the Cornell box → final whose predicted time (pilot rows ×
 *     passes) is within the budget and above half of it, the shade row's
 *     passes equal to the plan's; the next frame reuses the decision
 *     (no second pilot, same preset and passes);
 *   - the first frame of a budgeted job on a fresh renderer: its rows claim no
 *     work from the pilot (bih_build "built: first frame", nothing reused);
 *     the second frame reuses the tree;
 *   - a budget below fast's predicted time → preview;
 *   - a loose error target → fast; a tighter one than fast's pilot error →
 *     final with ⌈(one pass's relMSE / target)^1.5⌉ passes;
 *   - negative budget or target → PF_ERR_INVALID.
 * Validation must stay silent.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;
static pf_scene *cornell_scene;
static pf_scene_frame cornell;

#define WIDTH 48u
#define HEIGHT 36u

/* --denoise of the requests below (auto: final is denoised, and its pilot with it). */
static pf_denoise_mode denoise_mode = PF_DENOISE_AUTO;

static pf_status render_auto(const pf_scene_frame *frame, double budget_ms, double target,
                             pf_frame_report *report, pf_error *err)
{
    pf_render_settings settings = ref_settings(WIDTH, HEIGHT, 0, 3, 0);
    settings.denoise = denoise_mode;
    settings.quality = PF_QUALITY_AUTO;
    settings.budget_ms = budget_ms;
    settings.target_relmse = target;
    settings.photons_per_pass = 10000; /* cheap final passes: the test's time */
    pf_image image = {0};
    memset(report, 0, sizeof *report);
    pf_status status = pf_render_frame(renderer, frame, &settings, &image, report, err);
    pf_image_free(&image);
    return status;
}

static const pf_stage_timing *plan_row(const pf_frame_report *report)
{
    return report->stage_count > 0 && !strcmp(report->stages[0].stage, "plan")
               ? &report->stages[0]
               : NULL;
}

PF_TEST(no_lights_plan_preview)
{
    ref_scene scene;
    ref_scene_init(&scene);
    uint32_t grey = ref_scene_add_material(&scene, ref_material(PF_MATERIAL_LAMBERT, 0.5f, 0.5f, 0.5f));
    const float c[3] = {0, 0, -2}, u[3] = {1, 0, 0}, v[3] = {0, 1, 0};
    ref_scene_add_quad(&scene, c, u, v, grey);
    pf_frame_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(render_auto(&scene.frame, 0.0, 0.0, &report, &err), &err);
    const pf_stage_timing *row = plan_row(&report);
    PF_CHECK(report.quality == PF_QUALITY_PREVIEW);
    PF_CHECK_MSG(row && !row->skipped && strstr(row->reason, "auto → preview: no lights"),
                 "plan: %s", row ? row->reason : "missing");
    ref_scene_free(&scene);
}

PF_TEST(no_budget_plans_fast_without_a_pilot)
{
    pf_frame_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(render_auto(&cornell, 0.0, 0.0, &report, &err), &err);
    const pf_stage_timing *row = plan_row(&report);
    PF_CHECK(report.quality == PF_QUALITY_FAST);
    PF_CHECK_MSG(row && strstr(row->reason, "auto → fast: no --budget-ms"), "plan: %s",
                 row ? row->reason : "missing");
    PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 0.0);
    PF_CHECK(ref_row(&report, "lpv_propagate") != NULL); /* fast's rows follow */
}

PF_TEST(budget_plans_final_passes_that_fit)
{
    /* Cornell at 48×36, 10,000 photons: a final pass is ~50 ms on lavapipe, less on a GPU. */
    const double budget = 1000.0;
    pf_frame_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(render_auto(&cornell, budget, 0.0, &report, &err), &err);
    const pf_stage_timing *row = plan_row(&report);
    PF_REQUIRE(row != NULL);
    double pass_ms = ref_stage_counter(&report, "plan", "final_pass_ms");
    double passes = ref_stage_counter(&report, "plan", "passes");
    double predicted = ref_stage_counter(&report, "plan", "predicted_ms");
    /* final is denoised (--denoise auto): the stage's predicted time comes off the budget. */
    double denoise_ms = ref_stage_counter(&report, "plan", "denoise_ms");
    printf("  budget %.0f ms: %s (pass %.1f ms, predicted %.0f ms)\n", budget, row->reason,
           pass_ms, predicted);
    PF_CHECK(ref_stage_counter(&report, "plan", "denoised") == 1.0 && denoise_ms >= 0.0);
    PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 1.0);
    PF_CHECK(pass_ms > 0.0);
    if (passes >= 256.0) {
        /* A device this fast hits the cap: the plan is the most passes, under the budget. */
        PF_CHECK(report.quality == PF_QUALITY_FINAL && predicted <= budget);
    } else if (report.quality == PF_QUALITY_FINAL) {
        PF_CHECK_MSG(predicted <= budget && predicted > budget / 2.0,
                     "predicted %g ms for a budget of %g ms", predicted, budget);
        PF_CHECK(passes >= 4.0);
    } else if (report.quality == PF_QUALITY_FAST) {
        /* A device too slow for 4 passes and the denoise stage in 1 s: fast, which the pilot
         * says fits. */
        PF_CHECK(4.0 * pass_ms + denoise_ms > budget &&
                 ref_stage_counter(&report, "plan", "fast_ms") <= budget);
    } else {
        /* Slower still (a loaded machine times the pilot too): preview, by the same rule
         * applied to the recorded pilot times, never to this test's own clock. */
        PF_CHECK(report.quality == PF_QUALITY_PREVIEW && 4.0 * pass_ms + denoise_ms > budget &&
                 ref_stage_counter(&report, "plan", "fast_ms") > budget);
    }
    if (report.quality == PF_QUALITY_FINAL)
        PF_CHECK(ref_stage_counter(&report, "shade", "samples_per_pixel") == passes);
    /* The next frame keeps the decision: no pilot, the same preset and passes. */
    pf_quality first = report.quality;
    PF_REQUIRE_OK(render_auto(&cornell, budget, 0.0, &report, &err), &err);
    PF_CHECK(report.quality == first);
    PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 0.0);
    PF_CHECK(ref_stage_counter(&report, "plan", "passes") == passes);
}

/* Whether a row's reason claims work an earlier frame did. */
static int claims_earlier_work(const pf_stage_timing *row)
{
    return strstr(row->reason, "reused") || strstr(row->reason, "kept from") ||
           strstr(row->reason, "refit") || strstr(row->reason, "on the device already");
}

/*
 * The first frame of a budgeted job on a fresh renderer: the pilot renders built the BIH and
 * traced photons through this renderer, but the frame's rows say what the frame did, built
 * and traced, "first frame"; only the second frame reuses (issue 45).
 */
PF_TEST(first_frame_rows_claim_nothing_from_the_pilot)
{
    pf_renderer *fresh = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_renderer_create(ctx, &fresh, &err), &err);
    pf_renderer *shared = renderer;
    renderer = fresh;
    pf_frame_report report;
    pf_status status = render_auto(&cornell, 1000.0, 0.0, &report, &err);
    PF_CHECK_MSG(status == PF_OK, "%s", err.message);
    if (status == PF_OK) {
        PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 1.0);
        const pf_stage_timing *bih = ref_row(&report, "bih_build");
        PF_CHECK_MSG(bih && !bih->skipped && !strcmp(bih->reason, "built: first frame"),
                     "bih_build: %s", bih ? bih->reason : "missing");
        for (uint32_t i = 0; i < report.stage_count; i++) {
            const pf_stage_timing *row = &report.stages[i];
            PF_CHECK_MSG(!claims_earlier_work(row), "frame 1, %s: %s", row->stage, row->reason);
            printf("  frame 1 %-14s %s\n", row->stage, row->reason);
        }
        const pf_stage_timing *trace = ref_row(&report, "photon_trace");
        if (report.quality == PF_QUALITY_FINAL || report.quality == PF_QUALITY_FAST)
            PF_CHECK_MSG(trace && !trace->skipped && strstr(trace->reason, "first frame"),
                         "photon_trace: %s", trace ? trace->reason : "missing");
        /* Frame 2, the same request: the decision is kept and the tree reused. */
        status = render_auto(&cornell, 1000.0, 0.0, &report, &err);
        PF_CHECK_MSG(status == PF_OK, "%s", err.message);
        bih = ref_row(&report, "bih_build");
        PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 0.0);
        PF_CHECK_MSG(bih && strstr(bih->reason, "BIH reused"), "frame 2 bih_build: %s",
                     bih ? bih->reason : "missing");
    }
    renderer = shared;
    pf_renderer_destroy(fresh);
}

PF_TEST(budget_below_fast_plans_preview)
{
    const double budget = 0.001;
    pf_frame_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(render_auto(&cornell, budget, 0.0, &report, &err), &err);
    const pf_stage_timing *row = plan_row(&report);
    PF_CHECK(report.quality == PF_QUALITY_PREVIEW);
    PF_CHECK(ref_stage_counter(&report, "plan", "fast_ms") > budget);
    PF_CHECK_MSG(row && strstr(row->reason, "auto → preview: fast needs"), "plan: %s",
                 row ? row->reason : "missing");
}

PF_TEST(error_targets_plan_fast_or_enough_final_passes)
{
    pf_frame_report report;
    pf_error err = {0};
    PF_REQUIRE_OK(render_auto(&cornell, 0.0, 50.0, &report, &err), &err);
    PF_CHECK(report.quality == PF_QUALITY_FAST);
    double fast_relmse = ref_stage_counter(&report, "plan", "fast_relmse");
    PF_CHECK(fast_relmse >= 0.0 && fast_relmse <= 50.0);
    /* Tighter than fast's pilot error (0.25 here) and one final pass's (0.8). */
    const double target = 0.1;
    PF_REQUIRE_OK(render_auto(&cornell, 0.0, target, &report, &err), &err);
    const pf_stage_timing *row = plan_row(&report);
    double passes = ref_stage_counter(&report, "plan", "passes");
    double pass_relmse = ref_stage_counter(&report, "plan", "final_pass_relmse");
    printf("  target %g: %s\n", target, row ? row->reason : "missing");
    PF_CHECK(ref_stage_counter(&report, "plan", "fast_relmse") > target);
    PF_CHECK(report.quality == PF_QUALITY_FINAL && passes >= 1.0 && passes <= 256.0);
    /* final is denoised (--denoise auto): the pilot's errors are the denoised images', the
     * slope measured between one pass and four (at least 0.25; at most 2/3 when four passes
     * miss the target), and passes = ⌈4 · (four passes' relMSE / target)^(1/slope)⌉. */
    double slope = ref_stage_counter(&report, "plan", "error_slope");
    double four = ref_stage_counter(&report, "plan", "final_slope_relmse");
    PF_CHECK(ref_stage_counter(&report, "plan", "denoised") == 1.0);
    PF_CHECK(row && strstr(row->reason, "denoised"));
    PF_CHECK_MSG(slope >= 0.25 && (four <= target || slope <= 2.0 / 3.0 + 1e-9), "slope %g",
                 slope);
    if (passes < 256.0)
        PF_CHECK(passes == fmax(1.0, ceil(4.0 * pow(four / target, 1.0 / slope))));
    /* The frame's own denoise row is what the plan counted on. */
    PF_CHECK(ref_row(&report, "shade") != NULL);
    /* Not denoised (--denoise off): the raw error, passes = ⌈(one pass's relMSE / target)^1.5⌉. */
    denoise_mode = PF_DENOISE_OFF;
    PF_REQUIRE_OK(render_auto(&cornell, 0.0, target, &report, &err), &err);
    denoise_mode = PF_DENOISE_AUTO;
    row = plan_row(&report);
    passes = ref_stage_counter(&report, "plan", "passes");
    pass_relmse = ref_stage_counter(&report, "plan", "final_pass_relmse");
    printf("  target %g, not denoised: %s\n", target, row ? row->reason : "missing");
    PF_CHECK(ref_stage_counter(&report, "plan", "calibrated") == 1.0); /* another request */
    PF_CHECK(ref_stage_counter(&report, "plan", "denoised") == 0.0);
    PF_CHECK(report.quality == PF_QUALITY_FINAL && passes > 1.0 && passes <= 256.0);
    PF_CHECK(passes == ceil(pow(pass_relmse / target, 1.5)));
}

PF_TEST(negative_budget_or_target_is_refused)
{
    pf_frame_report report;
    pf_error err = {0};
    PF_CHECK(render_auto(&cornell, -1.0, 0.0, &report, &err) == PF_ERR_INVALID);
    PF_CHECK(render_auto(&cornell, 0.0, NAN, &report, &err) == PF_ERR_INVALID);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    if (!ref_load_cornell(&cornell_scene, &cornell))
        return 1;
    PF_RUN(no_lights_plan_preview);
    PF_RUN(no_budget_plans_fast_without_a_pilot);
    PF_RUN(budget_plans_final_passes_that_fit);
    PF_RUN(first_frame_rows_claim_nothing_from_the_pilot);
    PF_RUN(budget_below_fast_plans_preview);
    PF_RUN(error_targets_plan_fast_or_enough_final_passes);
    PF_RUN(negative_budget_or_target_is_refused);
    pf_scene_frame_free(&cornell);
    pf_scene_destroy(cornell_scene);
    return render_test_finish(ctx, renderer);
}
