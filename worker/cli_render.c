/*
 * photonfarm render: renders frames of a scene to EXR files without the
 * queue (DESIGN.md §1). The scene is loaded once; each frame goes through
 * the same frame pipeline as the worker's (pf_render.h): evaluated,
 * rendered, written to a temporary and renamed into place.
 */
#include "cli_queue.h"
#include "pf_render.h"
#include "pf_cli.h"
#include "pf_image.h"
#include "pf_scene.h"
#include "pf_vk.h"
#include "frame_writer.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define COMMAND "render"
#define DEFAULT_OUTPUT "render.####.exr"
#define MAX_PATH_BYTES PF_FRAME_PATH_MAX

typedef struct render_options {
    pf_cli_scene scene;
    const char *frame_text;  /* --frame */
    const char *frames_text; /* --frames */
    const char *output;
    const char *device;
    const char *cache_dir;   /* --cache-dir */
    int timings;
    pf_render_settings settings; /* cli_settings.c: the options enqueue takes too */
} render_options;

/* 0 ok, else the exit code (2) after printing why; *help after printing the help. */
static int parse_options(int argc, char **argv, render_options *options, int *help)
{
    memset(options, 0, sizeof *options);
    options->output = DEFAULT_OUTPUT;
    options->settings = pf_render_settings_default();
    const pf_cli_option own[] = {
        {"--frame", NULL, "N", "one frame (frames start at 1)", NULL, pf_cli_store_text,
         &options->frame_text, 0, 0, NULL},
        {"--frames", NULL, "RANGE", "e.g. 1-48, 1-48x2 (every 2nd), 1,5,9-12", NULL,
         pf_cli_store_text, &options->frames_text, 0, 0, NULL},
        {"--output", "-o", "OUT",
         "output path; a run of # is replaced by the zero-padded\nframe number", DEFAULT_OUTPUT,
         pf_cli_store_text, &options->output, 0, 0, NULL},
        {"--timings", NULL, NULL, "print each frame's stage rows (run or skipped, and why)", NULL,
         pf_cli_store_flag, &options->timings, 0, 0, NULL},
        {"--device", NULL, "D", "device index or name substring (see photonfarm devices)",
         "$PHOTONFARM_DEVICE, else a GPU, else lavapipe", pf_cli_store_text, &options->device, 0,
         0, NULL},
        {"--cache-dir", NULL, "DIR",
         "compiled-shader cache shared by this machine's processes\n(none: off)",
         "$PHOTONFARM_CACHE_DIR, else ~/.cache/photonfarm", pf_cli_store_text,
         &options->cache_dir, 0, 0, NULL},
    };
    int code = pf_cli_parse_job(COMMAND, "SCENE (--frame N | --frames RANGE) [options]",
                                "Renders frames of SCENE (.gltf, .glb, .obj) to OpenEXR files,\n"
                                "no queue.",
                                own, sizeof own / sizeof own[0], &options->settings,
                                &options->scene, argc, argv, help);
    if (code || *help)
        return code;
    if (!options->frame_text == !options->frames_text)
        return pf_cli_fail(COMMAND, 2, "give exactly one of --frame N or --frames RANGE");
    return 0;
}

/* --timings: one line per stage row of the frame. */
static void print_stage_rows(const pf_frame_report *report)
{
    for (uint32_t i = 0; i < report->stage_count; i++) {
        const pf_stage_timing *row = &report->stages[i];
        if (row->skipped)
            printf("  %-14s skipped: %s\n", row->stage, row->reason);
        else if (row->gpu_ms >= 0.0)
            printf("  %-14s %9.2f ms (GPU %.2f ms)", row->stage, row->wall_ms, row->gpu_ms);
        else
            printf("  %-14s %9.2f ms", row->stage, row->wall_ms);
        for (uint32_t c = 0; !row->skipped && c < row->counter_count; c++) {
            double value = row->counters[c].value;
            /* Counts (bytes, rays) in full; measures to 6 digits. */
            if (value == floor(value) && fabs(value) < 1e15)
                printf("%s%s=%.0f", c ? " " : "  ", row->counters[c].name, value);
            else
                printf("%s%s=%.6g", c ? " " : "  ", row->counters[c].name, value);
        }
        if (!row->skipped && row->reason[0])
            printf("\n  %-14s %s", "", row->reason); /* a decision (the planner's) */
        if (!row->skipped)
            printf("\n");
    }
}

typedef struct render_session {
    pf_scene *scene;
    pf_vk_context *ctx;
    pf_renderer *renderer;
} render_session;

static void session_close(render_session *session)
{
    pf_renderer_destroy(session->renderer);
    if (session->ctx)
        pf_vk_destroy(session->ctx);
    pf_scene_destroy(session->scene);
}

/*
 * The frames of one run, each rendered and then written behind the render (frame_writer.h,
 * as the worker does): frame i is written, committed and reported on the writer's thread
 * while frame i + 1 renders. Two outputs suffice, as a handover waits for the write before it.
 */
typedef struct render_run {
    const render_options *options;
    size_t frame_count;
    pf_frame_output outputs[2];
    size_t indices[2];           /* the frame list's index of what each output holds */
    int64_t frame_numbers[2];
    char failure[PF_ERROR_MESSAGE_MAX]; /* the first failed write or commit ("": none) */
    int failure_code;
    atomic_int failed;
} render_run;

/* The writer's thread: commits a written frame and reports it, or keeps the failure. */
static void frame_written(void *user, pf_frame_output *output, pf_status status,
                          const pf_error *err)
{
    render_run *run = user;
    int slot = output == &run->outputs[1];
    pf_error commit_err = {0};
    if (status == PF_OK)
        status = pf_frame_commit(output, &commit_err);
    else
        commit_err = *err;
    if (status != PF_OK) {
        pf_frame_discard(output);
        if (!atomic_load(&run->failed)) {
            snprintf(run->failure, sizeof run->failure, "%s", commit_err.message);
            run->failure_code = pf_status_exit_code(status);
            atomic_store(&run->failed, 1);
        }
        return;
    }
    if (run->options->timings)
        print_stage_rows(&output->report);
    /* The total is the render and its EXR write; the write ran on this thread while the
     * next frame rendered, so a run's frames follow each other at about the render's time. */
    double write_ms = 0.0;
    for (uint32_t i = 0; i < output->report.stage_count; i++)
        if (!strcmp(output->report.stages[i].stage, "exr_write"))
            write_ms = output->report.stages[i].wall_ms;
    printf("[%zu/%zu] frame %" PRId64 "  %.1f ms (render %.1f, write %.1f behind)  %s\n",
           run->indices[slot] + 1, run->frame_count, run->frame_numbers[slot],
           output->total_ms, output->total_ms - write_ms, write_ms, output->final_path);
    fflush(stdout);
}

/* Renders one frame (pf_render.h, shared with the worker) into output and hands it to the
 * writer; 0 or an exit code after printing why. */
static int render_one(const render_options *options, render_session *session,
                      pf_frame_writer *writer, render_run *run, size_t index,
                      int64_t frame_number, uint32_t following, const char *path)
{
    char temp_tag[32];
    snprintf(temp_tag, sizeof temp_tag, "render-%ld", (long)getpid());
    pf_frame_request request = {session->scene,
                                options->scene.path,
                                frame_number,
                                options->settings,
                                path,
                                temp_tag,
                                pf_vk_info(session->ctx)->name,
                                NULL,
                                following,
                                1};
    int slot = (int)(index % 2);
    pf_frame_output *output = &run->outputs[slot];
    pf_error err = {0};
    pf_status status = pf_frame_render(session->renderer, &request, output, &err);
    if (status != PF_OK) {
        pf_frame_discard(output);
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    }
    /* Compiled pipelines are kept for the next process as soon as they exist. */
    pf_error cache_err = {0};
    if (pf_vk_pipeline_cache_save(session->ctx, &cache_err) != PF_OK)
        fprintf(stderr, "photonfarm render: warning: %s\n", cache_err.message);
    if (output->report.discarded_samples > 0)
        fprintf(stderr, "photonfarm render: frame %" PRId64 ": %" PRIu64
                        " NaN/Inf samples discarded\n",
                frame_number, output->report.discarded_samples);
    run->indices[slot] = index;
    run->frame_numbers[slot] = frame_number;
    pf_frame_writer_hand(writer, output, run);
    return 0;
}

int pf_cli_render(int argc, char **argv)
{
    render_options options;
    int help = 0;
    int code = parse_options(argc, argv, &options, &help);
    if (code || help)
        return code;
    /* One frame-range grammar: the queue's (pf_queue.h), --frame being a range of one. */
    pf_frame_list frames = {0};
    pf_error err = {0};
    int64_t single;
    if (options.frame_text &&
        !pf_cli_parse_int(options.frame_text, 0, PF_FRAME_NUMBER_MAX, &single))
        return pf_cli_fail(COMMAND, 2, "--frame '%s': expected a frame number",
                           options.frame_text);
    if (pf_frame_range_parse(options.frame_text ? options.frame_text : options.frames_text,
                             &frames, &err) != PF_OK)
        return pf_cli_fail(COMMAND, 2, "%s: %s", options.frame_text ? "--frame" : "--frames",
                           err.message);
    if (frames.count > 1 && !strchr(options.output, '#')) {
        pf_frame_list_free(&frames);
        return pf_cli_fail(COMMAND, 2,
                           "-o '%s' has no # for the frame number, but %zu frames were asked for",
                           options.output, frames.count);
    }

    /* An image too large for this machine is refused before anything loads. */
    if (options.settings.width &&
        pf_frame_memory_check(options.settings.width, options.settings.height, 0, &err) != PF_OK) {
        pf_frame_list_free(&frames);
        return pf_cli_fail(COMMAND, 2, "--size: %s", err.message);
    }
    /* An unwritable output is found now, not after the first frame has rendered. */
    char absolute_output[PF_FRAME_PATH_MAX];
    if (pf_frame_output_check(options.output, absolute_output, sizeof absolute_output, &err) !=
        PF_OK) {
        pf_frame_list_free(&frames);
        return pf_cli_fail(COMMAND, 2, "-o '%s': %s", options.output, err.message);
    }

    render_session session = {0};
    pf_status status = pf_scene_load_with(options.scene.path, &options.scene.load, &session.scene, &err);
    if (status != PF_OK) {
        pf_frame_list_free(&frames);
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    }
    const pf_scene_info *info = pf_scene_get_info(session.scene);
    for (size_t i = 0; i < frames.count; i++) {
        if (frames.frames[i] < 1 || (uint32_t)frames.frames[i] > info->frame_count) {
            code = pf_cli_fail(COMMAND, 2, "frame %" PRId32 " is outside %s's frames 1-%u",
                               frames.frames[i], options.scene.path, info->frame_count);
            pf_frame_list_free(&frames);
            session_close(&session);
            return code;
        }
    }
    char cache_dir[PF_CLI_PATH_MAX];
    pf_vk_options vk_options = pf_cli_vk_options(
        options.device, pf_cli_cache_dir(COMMAND, options.cache_dir, cache_dir, sizeof cache_dir));
    status = pf_vk_create(&vk_options, &session.ctx, &err);
    if (status == PF_OK)
        status = pf_renderer_create(session.ctx, &session.renderer, &err);
    if (status != PF_OK) {
        pf_frame_list_free(&frames);
        session_close(&session);
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    }
    /* Volumes beyond this device's buffers: refused before anything is rendered or written. */
    code = pf_cli_lpv_check(COMMAND, &options.settings.lpv,
                            pf_vk_info(session.ctx)->max_storage_buffer_range);
    if (code) {
        pf_frame_list_free(&frames);
        session_close(&session);
        return code;
    }

    render_run *run = calloc(1, sizeof *run);
    pf_frame_writer *writer = NULL;
    status = run ? pf_frame_writer_start(frame_written, &writer, &err)
                 : pf_error_set(&err, PF_ERR_NOMEM, "out of memory");
    if (status != PF_OK) {
        free(run);
        pf_frame_list_free(&frames);
        session_close(&session);
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    }
    run->options = &options;
    run->frame_count = frames.count;
    size_t run_end = 0; /* one past the last frame of the run of consecutive frames i is in */
    for (size_t i = 0; i < frames.count && code == 0 && !atomic_load(&run->failed); i++) {
        char path[MAX_PATH_BYTES];
        if (!pf_frame_output_path(options.output, frames.frames[i], path, sizeof path)) {
            code = pf_cli_fail(COMMAND, 2, "-o '%s': output path too long", options.output);
            break;
        }
        /* The frames after this one that follow it one by one (a run the denoiser reuses),
         * found once a run. */
        if (run_end <= i)
            for (run_end = i + 1;
                 run_end < frames.count && frames.frames[run_end] == frames.frames[run_end - 1] + 1;
                 run_end++)
                ;
        uint32_t following = (uint32_t)(run_end - i - 1);
        code = render_one(&options, &session, writer, run, i, frames.frames[i], following, path);
    }
    pf_frame_writer_stop(writer);
    if (atomic_load(&run->failed) && code == 0)
        code = pf_cli_fail(COMMAND, run->failure_code, "%s", run->failure);
    free(run);
    if (pf_vk_validation_enabled(session.ctx)) {
        uint32_t messages = pf_vk_validation_message_count(session.ctx);
        if (messages > 0 && code == 0)
            code = pf_cli_fail(COMMAND, 1, "%u Vulkan validation message(s) (see above)", messages);
    }
    pf_frame_list_free(&frames);
    session_close(&session);
    return code;
}
