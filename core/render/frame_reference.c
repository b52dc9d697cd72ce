/*
 * The reference integrator: uploads the frame's scene, adds whole-image
 * passes of one sample per pixel to a film that stays on the device until
 * the sample count or the time budget is reached, reads the film back into
 * the pf_image and reports the `shade` stage. A pass is one dispatch of the
 * megakernel (shaders/render_reference.comp), or, where the plan has the
 * host trace the rays, the wavefront's dispatches (frame_reference_wave.c).
 * Channel meanings: pf_render.h.
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/*
 * Bound on the vertices of one path. Russian roulette ends paths long before
 * (the truncated energy is below albedo^64 of the last throughput: 6e-7 of
 * the white furnace's sum at albedo 0.8); it only bounds the loop.
 */
#define REFERENCE_MAX_PATH_DEPTH 64u
/* Workgroup edge of render_reference.comp (local_size 8×8). */
#define REFERENCE_GROUP_EDGE 8u
/*
 * Passes per submission: the first submission runs one pass to measure its
 * time; later ones aim at REFERENCE_BATCH_TARGET_MS, so the time budget is
 * checked a few times a second without a submission per pass, and never
 * exceed REFERENCE_BATCH_MAX_PASSES.
 */
#define REFERENCE_BATCH_TARGET_MS 250.0
#define REFERENCE_BATCH_MAX_PASSES 64u
/* A frame fails when more than this fraction of its samples met llvmpipe's loop cap (as
 * final's and fast's): each such sample is dropped, a bias towards short paths. */
#define REFERENCE_TRUNCATED_LIMIT 0.01

/* render_reference.comp's bindings: the scene's (PF_SCENE_BINDINGS), 2 films, counters,
 * 3 BIH buffers. */
#define REFERENCE_BUFFERS (PF_SCENE_BINDING_COUNT + 6u)
#define REFERENCE_FILM_BINDING PF_SCENE_BINDING_COUNT
#define REFERENCE_AOV_BINDING (PF_SCENE_BINDING_COUNT + 1u)
#define REFERENCE_COUNTER_BINDING (PF_SCENE_BINDING_COUNT + 2u)


typedef struct reference_push {
    uint32_t sample_index;
    uint32_t loop_sentinel; /* 1: kernel_guard.glsl's proof loop */
} reference_push;

typedef struct reference_counters {
    uint32_t discarded_samples;
    uint32_t traversal_failures; /* rays whose BIH traversal overflowed its stack */
    uint32_t rays_low;
    uint32_t rays_high;
    uint32_t loop_truncated; /* samples whose invocation met llvmpipe's loop cap (discarded) */
} reference_counters;

/* Adds the kernels' counters, read back, to progress. */
static void progress_add_counters(pf_reference_progress *progress,
                                  const reference_counters *counters)
{
    progress->rays += ((uint64_t)counters->rays_high << 32) | counters->rays_low;
    progress->discarded += counters->discarded_samples;
    progress->failures += counters->traversal_failures;
    progress->truncated += counters->loop_truncated;
}

/*
 * Runs passes [progress->passes, progress->passes + count) in one submission
 * and adds their counters to progress. With image (the frame's last passes), the film's
 * split into it goes in the same submission (issue 44: no submission of its own).
 */
static pf_status run_passes(pf_renderer *renderer, pf_vk_pipeline *pipeline,
                            pf_vk_buffer *const *buffers, const pf_render_settings *settings,
                            uint32_t count, pf_vk_commands *setup, pf_image *image,
                            pf_reference_progress *progress, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    static const reference_counters zero = {0, 0, 0, 0, 0};
    /* The counters zeroed, the passes and the counters' readback: one submission, the
     * frame's setup (setup: the scene's and parameters' uploads) in the first. */
    pf_vk_commands *cmds = setup;
    pf_status status = cmds ? PF_OK : pf_vk_commands_begin(ctx, &cmds, err);
    if (status != PF_OK)
        return status;
    status = pf_vk_cmd_upload(cmds, buffers[REFERENCE_COUNTER_BINDING], 0, &zero, sizeof zero,
                              err);
    int begin = pf_vk_cmd_timestamp(cmds);
    for (uint32_t pass = 0; status == PF_OK && pass < count; pass++) {
        reference_push push = {progress->passes + pass, 1};
        if (push.sample_index > 0)
            pf_vk_cmd_barrier(cmds); /* the previous pass's film sums are read */
        status = pf_vk_cmd_dispatch(
            cmds, pipeline, buffers, REFERENCE_BUFFERS, &push, sizeof push,
            (settings->width + REFERENCE_GROUP_EDGE - 1) / REFERENCE_GROUP_EDGE,
            (settings->height + REFERENCE_GROUP_EDGE - 1) / REFERENCE_GROUP_EDGE, 1, err);
    }
    int end = pf_vk_cmd_timestamp(cmds);
    reference_counters counters;
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buffers[REFERENCE_COUNTER_BINDING], 0, &counters,
                                    sizeof counters, err);
    pf_split_film_readback readback = {0};
    if (status == PF_OK && image)
        status = pf_split_film_record_read(renderer, cmds, buffers[REFERENCE_FILM_BINDING],
                                           buffers[REFERENCE_AOV_BINDING], settings->aovs,
                                           0, image, &readback, err);
    if (status == PF_OK)
        status = pf_split_film_submit(renderer, cmds, &readback, err);
    if (status == PF_OK)
        pf_gpu_ms_add(&progress->gpu_ms, pf_commands_gpu_ms(cmds, begin, end));
    pf_vk_commands_destroy(cmds);
    pf_split_film_finish_read(&readback);
    if (status == PF_OK) {
        progress->passes += count;
        progress_add_counters(progress, &counters);
    }
    return status;
}

/*
 * Passes for the next submission: 1 to start, then as many as fit
 * REFERENCE_BATCH_TARGET_MS and what is left of the budget at the measured
 * pass time; 0 when done (spp reached, or budget spent after >= 1 pass).
 */
static uint32_t next_batch(const pf_render_settings *settings, uint32_t spp, uint32_t done,
                           double frame_start, double pass_ms)
{
    if (done >= spp)
        return 0;
    if (done == 0)
        return 1;
    double elapsed = pf_time_ms() - frame_start;
    double window = REFERENCE_BATCH_TARGET_MS;
    if (settings->time_budget_ms > 0.0) {
        if (elapsed >= settings->time_budget_ms)
            return 0;
        if (settings->time_budget_ms - elapsed < window)
            window = settings->time_budget_ms - elapsed;
    }
    double fitting = pass_ms > 0.0 ? window / pass_ms : REFERENCE_BATCH_MAX_PASSES;
    uint32_t batch = fitting < 1.0 ? 1u
                     : fitting > REFERENCE_BATCH_MAX_PASSES ? REFERENCE_BATCH_MAX_PASSES
                                                              : (uint32_t)fitting;
    return batch < spp - done ? batch : spp - done;
}

/* Device buffers of one frame; every pointer NULL or owned. */
typedef struct reference_buffers {
    pf_vk_buffer *params, *film, *film_aov, *counters;
} reference_buffers;

static void reference_buffers_release(pf_vk_context *ctx, reference_buffers *buffers)
{
    pf_render_buffer_release(ctx, &buffers->params);
    pf_render_buffer_release(ctx, &buffers->film);
    pf_render_buffer_release(ctx, &buffers->film_aov);
    pf_render_buffer_release(ctx, &buffers->counters);
}

/* Renders the passes and reads the film back into image. */
static pf_status shade(pf_renderer *renderer, const pf_scene_frame *frame,
                       const pf_render_settings *settings, uint32_t spp,
                       const pf_stage_plan *plan,
                       double frame_start, pf_image *image, pf_reference_progress *progress,
                       uint32_t *trace_threads, pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    pf_bih_gpu_view bih;
    pf_status status = pf_bih_gpu_view_get(renderer->bih_gpu, &bih, err);
    if (status != PF_OK)
        return status;
    /* The scene's and the parameters' uploads go with the first passes (issue 44). */
    pf_vk_commands *setup = NULL;
    status = pf_vk_commands_begin(ctx, &setup, err);
    if (status != PF_OK)
        return status;
    pf_gpu_scene scene;
    status = pf_gpu_scene_record(ctx, setup, frame, 1, &renderer->textures, &scene, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(setup);
        return status;
    }
    pf_frame_params params;
    pf_frame_params_fill(frame, settings, spp, &scene, &bih, &params);
    params.max_path_depth = REFERENCE_MAX_PATH_DEPTH;
    reference_buffers owned = {0};
    status = pf_render_buffer_recorded(ctx, setup, "frame parameters", &params, sizeof params,
                                       sizeof params, &owned.params, err);
    if (status == PF_OK)
        status = pf_split_film_create(ctx, settings, settings->aovs, "reference", &owned.film,
                                      &owned.film_aov, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof(reference_counters), "reference counters",
                                     &owned.counters, err);
    pf_vk_buffer *own[] = {owned.film, owned.film_aov, owned.counters,
                           bih.nodes,  bih.vertices,   bih.triangle_index};
    pf_vk_buffer *buffers[REFERENCE_BUFFERS];
    pf_gpu_scene_bindings(&scene, owned.params, own, sizeof own / sizeof *own, buffers);
    pf_vk_pipeline *pipeline = NULL;
    pf_reference_wave *wave = NULL;
    if (status == PF_OK && plan->host_traces)
        status = pf_reference_wave_create(renderer, settings, frame->light_count,
                                          plan->wave_tail_paths, &wave, err);
    else if (status == PF_OK)
        status = pf_renderer_pipeline(
            renderer, settings->aovs ? PF_PIPELINE_REFERENCE : PF_PIPELINE_REFERENCE_RGB,
            &pipeline, err);
    if (status == PF_OK && wave) {
        *trace_threads = pf_reference_wave_threads(wave);
        /* The counters: the wavefront's kernels add discarded samples, its tail the rays it
         * traces and its traversals' failures. */
        static const reference_counters zero = {0, 0, 0, 0, 0};
        status = pf_vk_cmd_upload(setup, owned.counters, 0, &zero, sizeof zero, err);
    }
    double pass_ms = 0.0;
    int image_read = 0;
    for (uint32_t batch = next_batch(settings, spp, 0, frame_start, 0.0);
         status == PF_OK && batch > 0;
         batch = next_batch(settings, spp, progress->passes, frame_start, pass_ms)) {
        double batch_start = pf_time_ms();
        if (wave)
            status = pf_reference_wave_passes(wave, buffers, REFERENCE_BUFFERS, settings, batch,
                                              setup, progress, err);
        else {
            /* The frame's last passes read the film back with them. */
            image_read = progress->passes + batch >= spp;
            status = run_passes(renderer, pipeline, buffers, settings, batch, setup,
                                image_read ? image : NULL, progress, err);
        }
        setup = NULL; /* run_passes took it */
        pass_ms = (pf_time_ms() - batch_start) / batch;
    }
    pf_vk_commands_destroy(setup); /* not taken: a failure before the first passes */
    if (status == PF_OK && wave) {
        reference_counters counters;
        status = pf_vk_buffer_download(ctx, owned.counters, 0, &counters, sizeof counters, err);
        if (status == PF_OK)
            progress_add_counters(progress, &counters);
    }
    pf_reference_wave_destroy(wave);
    if (status == PF_OK && !image_read) /* the wavefront's, or a budget's early end */
        status = pf_split_film_read(renderer, owned.film, owned.film_aov, settings->aovs, 0,
                                    image, err);
    reference_buffers_release(ctx, &owned);
    pf_gpu_scene_release(ctx, &scene);
    return status;
}

/*
 * The `caustics` row says whether this image holds the scene's caustics
 * (issue 16): a path tracer finds caustics of emitting surfaces (a BSDF
 * sample from a diffuse point through mirrors and glass that hits one, the
 * caustic layer), but never those of punctual lights (points, spots, the
 * sun): a delta light behind a delta interface has no path it can sample.
 * Then the reference is no ground truth for the scene's caustics and the
 * row says to render them with final (its caustic map). Run (0 ms) when
 * the caustics are there.
 */
static void report_caustics(pf_frame_report *report, const pf_scene_frame *frame)
{
    uint32_t punctual = 0;
    for (uint32_t i = 0; i < frame->light_count; i++)
        punctual += frame->lights[i].kind == PF_LIGHT_POINT ||
                    frame->lights[i].kind == PF_LIGHT_SPOT ||
                    frame->lights[i].kind == PF_LIGHT_DIRECTIONAL;
    int specular = pf_scene_frame_has_specular(frame);
    pf_stage_timing *row = pf_frame_report_row(
        report, "caustics",
        !specular     ? "no specular or refractive material → no caustics"
        : punctual > 0 ? "punctual lights meet mirrors or glass: a path tracer cannot find their "
                         "caustics, this image lacks them (final renders them)"
                       : NULL,
        0.0, -1.0);
    pf_stage_add_counter(row, "punctual_lights", punctual);
}

/* reference's one stage after the BIH: shade passes until its samples or its time budget. */
static pf_status reference_run(pf_frame_run *run, pf_stage_id stage, uint32_t pass,
                               pf_error *err)
{
    (void)pass;
    if (stage != PF_STAGE_SHADE)
        return pf_error_set(err, PF_ERR_INTERNAL, "reference has no stage %s",
                            pf_stage_name(stage));
    pf_renderer *renderer = run->renderer;
    const pf_scene_frame *frame = run->frame;
    const pf_render_settings *settings = run->settings;
    const pf_stage_plan *plan = run->plan;
    pf_image *image = run->image;
    pf_frame_report *report = run->report;
    double frame_start = run->start_ms;
    uint32_t spp = plan->samples;
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    pf_status status =
        pf_split_image_create(image, settings->width, settings->height, settings->aovs,
                              settings->later_layers, err);
    if (status != PF_OK)
        return status;
    double shade_start = pf_time_ms();
    pf_reference_progress progress = {0, 0, 0, 0, 0, -1.0, 0, 0.0, 0};
    uint32_t trace_threads = 0;
    if (status == PF_OK)
        status = shade(renderer, frame, settings, spp, plan, frame_start, image,
                       &progress, &trace_threads, err);
    if (status == PF_OK)
        status = pf_render_check_traversal(renderer, progress.failures, err);
    if (status == PF_OK && (double)progress.truncated >
                               REFERENCE_TRUNCATED_LIMIT * (double)pixels * progress.passes)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%llu of %llu samples stopped at the loop cap (%s: this device "
                              "ends an invocation's loops after 65,535 iterations: long paths, or "
                              "rays that test thousands of overlapping triangles)",
                              (unsigned long long)progress.truncated,
                              (unsigned long long)(pixels * progress.passes),
                              plan->host_traces ? "the wavefront's tail traces on the device"
                                                : "the device traces every path");
    if (status == PF_OK)
        renderer->wave_tails += plan->wave_tails; /* what the tail's compilation weighs */
    if (status != PF_OK) {
        pf_image_free(image);
        pf_error_prefix(err, "reference render (%ux%u, %u spp, %u triangles)", settings->width,
                        settings->height, spp, frame->triangle_count);
        return status;
    }
    if (report) {
        report->discarded_samples += progress.discarded;
        pf_stage_timing *row = pf_frame_report_add(report, "shade");
        if (row) {
            snprintf(row->reason, sizeof row->reason, "%s", plan->stages[PF_STAGE_SHADE].reason);
            row->wall_ms = pf_time_ms() - shade_start;
            row->gpu_ms = progress.gpu_ms;
            pf_stage_add_counter(row, "samples_per_pixel", progress.passes);
            pf_stage_add_counter(row, "paths", (double)pixels * progress.passes);
            pf_stage_add_counter(row, "rays", (double)progress.rays);
            pf_stage_add_light_samples(row, frame->light_count, PF_DIRECT_LIGHT_SAMPLES);
            pf_stage_add_counter(row, "discarded_samples", (double)progress.discarded);
            pf_stage_add_counter(row, "loop_truncated", (double)progress.truncated);
            pf_stage_add_counter(row, "triangles", frame->triangle_count);
            if (plan->host_traces) {
                pf_stage_add_counter(row, "waves", progress.waves);
                pf_stage_add_counter(row, "host_trace_ms", progress.host_trace_ms);
                pf_stage_add_counter(row, "trace_threads", trace_threads);
                pf_stage_add_counter(row, "tail_paths", (double)progress.tail_paths);
            }
        }
        report_caustics(report, frame);
    }
    return PF_OK;
}

/* reference: one stage after the BIH (its passes are inside shade: a batch per dispatch). */
const pf_integrator pf_integrator_reference = {0, NULL, reference_run, NULL};

void pf_renderer_set_trace_site(pf_renderer *renderer, pf_trace_site site)
{
    if (site != renderer->trace_site) {
        pf_stage_forget(&renderer->stage_memory[PF_QUALITY_FAST]);
        pf_stage_forget(&renderer->stage_memory[PF_QUALITY_FINAL]);
    }
    renderer->trace_site = site;
}
