/*
 * The queue worker's libuv loop (see worker_loop.h). Everything below runs on
 * the loop thread except the *_work functions, which libuv runs on its thread
 * pool: database work (each under queue_mutex, as a pf_queue is one
 * connection) and the render of the current task. The state machine makes
 * sure the loop thread does not touch what a running *_work function owns.
 */
#include "worker_loop.h"

#include "pf_render.h"
#include "log.h"
#include "peak_memory.h"
#include "pf_cli.h"
#include "pf_queue.h"
#include "progress.h"
#include "frame_fault.h"
#include "job_extras.h"

#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <uv.h>

/* Reaper and idle worker heartbeat period bounds: often enough that a dead
 * worker's lease comes back soon after it expires, rarely enough to stay cheap. */
#define MAINTENANCE_MIN_MS 500
#define MAINTENANCE_MAX_MS 15000

typedef enum worker_state {
    STATE_IDLE,      /* poll timer armed */
    STATE_CLAIMING,  /* claim in flight */
    STATE_RENDERING, /* render work in flight */
    STATE_FINISHING, /* complete / fail / release in flight */
    STATE_STOPPING   /* worker_stop in flight or done; handles closing */
} worker_state;

typedef struct worker worker;

/* A database operation on the thread pool. */
typedef struct db_op {
    uv_work_t request;
    worker *owner;
    void (*run)(struct db_op *op);  /* thread pool, under queue_mutex */
    void (*done)(struct db_op *op); /* loop thread */
    pf_status status;
    pf_error err;
    char token[PF_QUEUE_TOKEN_CHARS + 1]; /* the task's lease when submitted */
    bool flag;          /* claim: claimed; finish: lease lost */
    bool committed;     /* finish: the lease was lost after the frame was renamed into place */
    bool job_fault;     /* finish: the commit failed on the job's output (the job is paused) */
    int64_t count;      /* reap: tasks reaped; finish: 1 when a failed commit was recorded */
} db_op;

struct worker {
    pf_worker_config config;
    uv_loop_t loop;
    uv_mutex_t queue_mutex;
    pf_queue *queue;
    pf_vk_context *vk;
    pf_renderer *renderer;
    char device_name[256];
    char name[PF_QUEUE_NAME_MAX];
    int64_t worker_id;
    int64_t lease_ms;

    uv_timer_t poll_timer, lease_timer, maintenance_timer;
    uv_signal_t sigint_handle, sigterm_handle;
    int signals_seen;
    worker_state state;
    int64_t poll_delay_ms;
    double idle_since_ms;
    int64_t frames_processed;
    int maintenance_in_flight, heartbeat_in_flight;
    int exit_code;

    /* The current task and its job (owned by the loop thread, read by work). */
    pf_queue_task task;
    pf_queue_job job;
    atomic_int abort;
    int lease_lost;
    int64_t last_job_id;
    int32_t last_frame;

    /* Render work's own state: the scene cache and the task's outputs. */
    int64_t scene_job_id;
    pf_scene *scene;
    uv_work_t render_request;
    pf_frame_output *outputs;
    int64_t *output_peak_rss; /* each output's peak resident memory (bytes; -1: unknown) */
    size_t output_count;
    pf_status render_status;
    pf_error render_err;
    pf_frame_fault render_fault; /* whose fault a failed render is */

    pf_progress progress;
    int show_progress;
};

static void begin_shutdown(worker *w);
static void claim_next(worker *w);
static void arm_poll(worker *w);

/* ---- database operations ------------------------------------------------- */

static void db_op_work(uv_work_t *request)
{
    db_op *op = request->data;
    uv_mutex_lock(&op->owner->queue_mutex);
    op->run(op);
    uv_mutex_unlock(&op->owner->queue_mutex);
}

static void db_op_after(uv_work_t *request, int uv_status)
{
    db_op *op = request->data;
    if (uv_status != 0 && op->status == PF_OK)
        op->status = pf_error_set(&op->err, PF_ERR_INTERNAL, "database work canceled");
    op->done(op);
    free(op);
}

static void db_submit(worker *w, void (*run)(db_op *), void (*done)(db_op *))
{
    db_op *op = calloc(1, sizeof *op);
    if (!op) {
        pf_wlog(PF_LOG_ERROR, "out_of_memory", "worker=%s", w->name);
        w->exit_code = 1;
        return;
    }
    op->owner = w;
    op->run = run;
    op->done = done;
    op->request.data = op;
    memcpy(op->token, w->task.lease_token, sizeof op->token);
    uv_queue_work(&w->loop, &op->request, db_op_work, db_op_after);
}

static void log_db_error(worker *w, const char *what, const db_op *op)
{
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    pf_wlog(PF_LOG_ERROR, "db_error", "worker=%s op=%s error=%s", w->name, what,
            pf_wlog_quote(op->err.message, quoted, sizeof quoted));
}

/* Stores the lines logged since the claim as this attempt's log (issue 41), first thing
 * when the task is let go, whatever the outcome. On the thread pool, under queue_mutex.
 * A log the queue refuses is reported, and the task is settled all the same. */
static void store_attempt_log(worker *w)
{
    char *text = pf_wlog_capture_end();
    if (!text)
        return;
    pf_error err = {0};
    if (pf_queue_attempt_log_store(w->queue, w->task.task_id, w->task.attempt, w->worker_id,
                                   text, &err) != PF_OK) {
        char quoted[PF_ERROR_MESSAGE_MAX + 8];
        pf_wlog(PF_LOG_WARN, "log_not_stored", "job=%" PRId64 " task=%" PRId64 " worker=%s "
                "error=%s", w->task.job_id, w->task.task_id, w->name,
                pf_wlog_quote(err.message, quoted, sizeof quoted));
    }
    free(text);
}

/* ---- progress ------------------------------------------------------------ */

static void progress_hook(int before, void *user)
{
    worker *w = user;
    if (before)
        pf_progress_clear(&w->progress);
    else
        pf_progress_redraw(&w->progress);
}

/* ---- task bookkeeping ---------------------------------------------------- */

static void discard_outputs(worker *w)
{
    for (size_t i = 0; i < w->output_count; i++)
        pf_frame_discard(&w->outputs[i]);
    free(w->outputs);
    w->outputs = NULL;
    free(w->output_peak_rss);
    w->output_peak_rss = NULL;
    w->output_count = 0;
}

/* The current task is settled (done, failed, released or lost): go on. */
static void task_finished(worker *w)
{
    discard_outputs(w);
    free(pf_wlog_capture_end()); /* a task let go without settling (its lease lost) */
    w->frames_processed += w->task.frame_count;
    w->last_job_id = w->task.job_id;
    w->last_frame = w->task.last_frame;
    uv_timer_stop(&w->lease_timer);
    w->idle_since_ms = pf_time_ms();
    w->poll_delay_ms = PF_WORKER_POLL_MIN_MS;
    if (w->signals_seen > 0) {
        begin_shutdown(w);
    } else if (w->config.max_frames > 0 && w->frames_processed >= w->config.max_frames) {
        pf_wlog(PF_LOG_INFO, "max_frames_reached", "worker=%s frames=%" PRId64, w->name,
                w->frames_processed);
        begin_shutdown(w);
    } else {
        claim_next(w);
    }
}

/* ---- release ------------------------------------------------------------- */

static void release_run(db_op *op)
{
    store_attempt_log(op->owner);
    op->status = pf_queue_release(op->owner->queue, op->token, &op->err);
}

static void release_done(db_op *op)
{
    worker *w = op->owner;
    if (op->status == PF_OK)
        pf_wlog(PF_LOG_INFO, "released", "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name);
    else if (op->status != PF_ERR_INVALID)
        log_db_error(w, "release", op);
    task_finished(w);
}

/* ---- fail ---------------------------------------------------------------- */

static void fail_run(db_op *op)
{
    worker *w = op->owner;
    store_attempt_log(w);
    op->status = pf_queue_fail(w->queue, op->token, w->render_err.message, &op->err);
}

static void fail_done(db_op *op)
{
    worker *w = op->owner;
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    pf_wlog(PF_LOG_WARN, "failed",
            "job=%" PRId64 " frame=%d task=%" PRId64 " attempt=%d worker=%s error=%s",
            w->task.job_id, w->task.first_frame, w->task.task_id, w->task.attempt, w->name,
            pf_wlog_quote(w->render_err.message, quoted, sizeof quoted));
    if (op->status == PF_ERR_INVALID)
        pf_wlog(PF_LOG_WARN, "lease_lost", "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name);
    else if (op->status != PF_OK)
        log_db_error(w, "fail", op);
    task_finished(w);
}

/* ---- the job's fault: its output or scene, not this worker ---------------- */

static void fail_job_run(db_op *op)
{
    worker *w = op->owner;
    store_attempt_log(w);
    char reason[sizeof w->render_err.message + 32];
    snprintf(reason, sizeof reason, "%s: %s", pf_frame_fault_name(w->render_fault),
             w->render_err.message);
    op->status = pf_queue_fail_job(w->queue, op->token, reason, &op->err);
}

/* Logs a failure that is the job's: the job is paused, this worker stays eligible. */
static void log_job_fault(worker *w, pf_frame_fault fault, const char *message)
{
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    pf_wlog(PF_LOG_WARN, "job_fault",
            "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s fault=%s action=job_paused "
            "error=%s",
            w->task.job_id, w->task.first_frame, w->task.task_id, w->name,
            pf_frame_fault_name(fault), pf_wlog_quote(message, quoted, sizeof quoted));
}

static void fail_job_done(db_op *op)
{
    worker *w = op->owner;
    if (op->status == PF_OK)
        log_job_fault(w, w->render_fault, w->render_err.message);
    else if (op->status == PF_ERR_INVALID)
        pf_wlog(PF_LOG_WARN, "lease_lost", "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name);
    else
        log_db_error(w, "fail_job", op);
    task_finished(w);
}

/* ---- refused: the job asks for what this farm does not allow ------------- */

static void reject_run(db_op *op)
{
    worker *w = op->owner;
    store_attempt_log(w);
    op->status = pf_queue_reject(w->queue, op->token, w->render_err.message, &op->err);
}

static void reject_done(db_op *op)
{
    worker *w = op->owner;
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    if (op->status == PF_OK)
        pf_wlog(PF_LOG_WARN, "rejected",
                "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=task_failed error=%s",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name,
                pf_wlog_quote(w->render_err.message, quoted, sizeof quoted));
    else if (op->status != PF_ERR_INVALID)
        log_db_error(w, "reject", op);
    task_finished(w);
}

/* ---- finish: re-check the lease, rename into place, complete --------------- */

static char *counters_json(const pf_stage_timing *stage)
{
    size_t size = 64 + stage->counter_count * 64;
    char *json = malloc(size);
    if (!json)
        return NULL;
    size_t used = (size_t)snprintf(json, size, "{");
    for (uint32_t i = 0; i < stage->counter_count && used < size; i++)
        used += (size_t)snprintf(json + used, size - used, "%s\"%s\":%.17g", i ? "," : "",
                                 stage->counters[i].name, stage->counters[i].value);
    if (used < size)
        snprintf(json + used, size - used, "}");
    return json;
}

static void finish_run(db_op *op)
{
    worker *w = op->owner;
    /* Renew first: a rename with a lease about to lapse could race the reaper. */
    op->status = pf_queue_heartbeat(w->queue, op->token, NULL, &op->err);
    store_attempt_log(w);
    if (op->status == PF_ERR_INVALID) {
        op->flag = true;
        discard_outputs(w);
        return;
    }
    if (op->status != PF_OK)
        return;
    size_t row_capacity = 0;
    for (size_t i = 0; i < w->output_count; i++)
        row_capacity += w->outputs[i].report.stage_count;
    pf_queue_stage_row *rows = calloc(row_capacity ? row_capacity : 1, sizeof *rows);
    char **counters = calloc(row_capacity ? row_capacity : 1, sizeof *counters);
    if (!rows || !counters) {
        free(rows);
        free(counters);
        op->status = pf_error_set(&op->err, PF_ERR_NOMEM, "stage rows");
        return;
    }
    size_t row_count = 0;
    pf_queue_frame_resources *resources = calloc(w->output_count ? w->output_count : 1,
                                                 sizeof *resources);
    if (!resources) {
        free(rows);
        free(counters);
        op->status = pf_error_set(&op->err, PF_ERR_NOMEM, "frame resources");
        return;
    }
    for (size_t i = 0; i < w->output_count; i++) {
        const pf_frame_report *report = &w->outputs[i].report;
        int32_t frame = w->task.first_frame + (int32_t)i * w->task.frame_step;
        resources[i] = (pf_queue_frame_resources){frame, w->output_peak_rss[i],
                                                  (int64_t)w->outputs[i].peak_device_bytes,
                                                  (int64_t)w->outputs[i].bytes_written};
        for (uint32_t s = 0; s < report->stage_count; s++) {
            const pf_stage_timing *stage = &report->stages[s];
            counters[row_count] = counters_json(stage);
            rows[row_count] = (pf_queue_stage_row){
                frame,           stage->stage,
                stage->wall_ms,  stage->gpu_ms < 0 ? PF_QUEUE_NO_GPU_MS : stage->gpu_ms,
                counters[row_count], stage->skipped != 0,
                stage->reason[0] ? stage->reason : NULL, pf_version_string()};
            row_count++;
        }
    }
    for (size_t i = 0; i < w->output_count && op->status == PF_OK; i++) {
        op->status = pf_frame_commit(&w->outputs[i], &op->err);
        op->job_fault = op->status != PF_OK &&
                        pf_frame_fault_of(w->outputs[i].failed) != PF_FRAME_FAULT_WORKER;
    }
    if (op->status == PF_OK) {
        op->status = pf_queue_complete_frames(w->queue, op->token, rows, row_count, resources,
                                              w->output_count, NULL, &op->err);
        /* The lease lapsed during the commit (a rename slower than what was left of the
         * lease) and the task was reaped: the frame on disk is whole, and whoever holds
         * the task now renders it again and replaces it. A lost lease, not a failure of
         * this worker, and nothing to give back. */
        if (op->status == PF_ERR_INVALID) {
            op->flag = true;
            op->committed = true;
        }
    }
    if (op->status != PF_OK && !op->flag) {
        /* Not committed: the task goes back now, with the cause, instead of staying
         * `running` on this live worker until its lease expires (issue 14). A rename
         * the output storage refused is the job's fault (paused, this worker not
         * blamed); a failing database is retried under the retry policy. */
        char cause[sizeof op->err.message + 48];
        snprintf(cause, sizeof cause, "%scommitting the frame: %s",
                 op->job_fault ? "output: " : "", op->err.message);
        pf_error fail_err = {0};
        op->count = (op->job_fault ? pf_queue_fail_job(w->queue, op->token, cause, &fail_err)
                                   : pf_queue_fail(w->queue, op->token, cause, &fail_err)) ==
                    PF_OK;
    }
    if (op->status == PF_OK) {
        pf_queue_job_clear(&w->job);
        pf_error ignored;
        pf_queue_job_get(w->queue, w->task.job_id, &w->job, &ignored);
    }
    for (size_t i = 0; i < row_count; i++)
        free(counters[i]);
    free(counters);
    free(rows);
    free(resources);
}

static void update_progress(void *user)
{
    worker *w = user;
    char label[64];
    snprintf(label, sizeof label, "job %" PRId64, w->task.job_id);
    pf_progress_update(&w->progress, label, w->job.frames_done, w->job.frames_total);
}

static void finish_done(db_op *op)
{
    worker *w = op->owner;
    if (op->flag) {
        pf_wlog(PF_LOG_WARN, "lease_lost",
                "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=%s",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name,
                op->committed ? "left_to_new_owner" : "discarded");
    } else if (op->status != PF_OK && op->job_fault) {
        if (op->count)
            log_job_fault(w, PF_FRAME_FAULT_OUTPUT, op->err.message);
        else
            log_db_error(w, "complete", op);
    } else if (op->status != PF_OK) {
        log_db_error(w, "complete", op);
        if (op->count)
            pf_wlog(PF_LOG_WARN, "commit_failed",
                    "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=failed_for_retry",
                    w->task.job_id, w->task.first_frame, w->task.task_id, w->name);
        w->exit_code = 1;
    } else {
        double total_ms = 0;
        for (size_t i = 0; i < w->output_count; i++)
            total_ms += w->outputs[i].total_ms;
        pf_wlog(PF_LOG_INFO, "completed",
                "job=%" PRId64 " frame=%d frames=%d task=%" PRId64 " worker=%s ms=%.1f "
                "job_frames_done=%" PRId64 " job_frames=%" PRId64 " job_status=%s",
                w->task.job_id, w->task.first_frame, w->task.frame_count, w->task.task_id,
                w->name, total_ms, w->job.frames_done, w->job.frames_total, w->job.status);
        if (w->show_progress)
            pf_wlog_exclusive(update_progress, w);
    }
    task_finished(w);
}

/* ---- render work ----------------------------------------------------------- */

/* Pipelines compiled for this frame are written out now, so that a worker
 * killed later still leaves them cached for the next process (a no-op when
 * nothing new was compiled). */
static void save_pipeline_cache(worker *w)
{
    pf_error err = {0};
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    if (pf_vk_pipeline_cache_save(w->vk, &err) != PF_OK)
        pf_wlog(PF_LOG_WARN, "pipeline_cache", "worker=%s error=%s", w->name,
                pf_wlog_quote(err.message, quoted, sizeof quoted));
}

/* One line per rendered frame, for the attempt's log and a shipper: how long, which
 * preset, which stages ran and which were skipped (their reasons are in the stage rows). */
static void log_rendered(worker *w, int64_t frame, const pf_frame_output *output)
{
    char ran[512] = "", skipped[512] = "";
    size_t ran_used = 0, skipped_used = 0;
    for (uint32_t s = 0; s < output->report.stage_count; s++) {
        const pf_stage_timing *stage = &output->report.stages[s];
        char *list = stage->skipped ? skipped : ran;
        size_t *used = stage->skipped ? &skipped_used : &ran_used;
        int n = snprintf(list + *used, sizeof ran - *used, "%s%s", *used ? "," : "",
                         stage->stage);
        if (n > 0 && *used + (size_t)n < sizeof ran)
            *used += (size_t)n;
    }
    pf_wlog(PF_LOG_INFO, "rendered",
            "job=%" PRId64 " frame=%" PRId64 " worker=%s ms=%.1f preset=%s size=%ux%u "
            "ran=%s skipped=%s",
            w->job.job_id, frame, w->name, output->total_ms,
            pf_quality_name(output->report.quality), output->width, output->height,
            ran[0] ? ran : "-", skipped[0] ? skipped : "-");
}

static void render_work(uv_work_t *request)
{
    worker *w = request->data;
    w->render_status = PF_OK;
    w->render_fault = PF_FRAME_FAULT_WORKER;
    memset(&w->render_err, 0, sizeof w->render_err);
    /* Paths through this worker's roots: outside them the task is refused for good;
     * one that does not exist inside them is its scene's or output's fault. */
    char scene_path[PATH_MAX], pattern[PATH_MAX];
    w->render_status = pf_roots_resolve(&w->config.storage->scene, w->job.scene_path, scene_path,
                                        sizeof scene_path, &w->render_err);
    pf_frame_fault missing = PF_FRAME_FAULT_SCENE;
    if (w->render_status == PF_OK) {
        w->render_status = pf_roots_output_resolve(&w->config.storage->output, w->job.output_pattern,
                                                   pattern, sizeof pattern, &w->render_err);
        missing = PF_FRAME_FAULT_OUTPUT;
    }
    if (w->render_status != PF_OK) {
        w->render_fault = w->render_status == PF_ERR_INVALID ? PF_FRAME_FAULT_REFUSED : missing;
        return;
    }
    /* A full, read-only or missing output volume is found before any work, and
     * again at every claim: the job pauses until someone fixes the storage. */
    char absolute[PF_FRAME_PATH_MAX];
    w->render_status = pf_frame_output_check(pattern, absolute, sizeof absolute, &w->render_err);
    if (w->render_status != PF_OK) {
        w->render_fault = PF_FRAME_FAULT_OUTPUT;
        return;
    }
    if (w->scene_job_id != w->job.job_id || !w->scene) {
        pf_scene_destroy(w->scene);
        w->scene = NULL;
        w->scene_job_id = 0;
        char animation[256];
        pf_scene_load_options load = {pf_job_allow_outside(w->job.parameters_json), NULL};
        if (pf_job_animation(w->job.parameters_json, animation, sizeof animation))
            load.animation = animation;
        w->render_status = pf_scene_load_with(scene_path, &load, &w->scene, &w->render_err);
        if (w->render_status != PF_OK) {
            w->render_fault = PF_FRAME_FAULT_SCENE;
            return;
        }
        w->scene_job_id = w->job.job_id;
        pf_wlog(PF_LOG_INFO, "scene_loaded", "job=%" PRId64 " worker=%s triangles=%u",
                w->job.job_id, w->name, pf_scene_get_info(w->scene)->triangle_count);
    }
    pf_render_settings settings;
    w->render_status = pf_settings_parse(w->job.parameters_json, &settings, &w->render_err);
    if (w->render_status != PF_OK) {
        w->render_fault = PF_FRAME_FAULT_SETTINGS;
        return;
    }
    w->outputs = calloc((size_t)w->task.frame_count, sizeof *w->outputs);
    w->output_peak_rss = calloc((size_t)w->task.frame_count, sizeof *w->output_peak_rss);
    if (!w->outputs || !w->output_peak_rss) {
        w->render_status = pf_error_set(&w->render_err, PF_ERR_NOMEM, "frame outputs");
        return;
    }
    for (int32_t i = 0; i < w->task.frame_count && !atomic_load(&w->abort); i++) {
        int64_t frame = w->task.first_frame + (int64_t)i * w->task.frame_step;
        char path[PF_FRAME_PATH_MAX];
        if (!pf_frame_output_path(pattern, frame, path, sizeof path)) {
            w->render_status = pf_error_set(&w->render_err, PF_ERR_INVALID,
                                            "output path too long: %s", pattern);
            w->render_fault = PF_FRAME_FAULT_OUTPUT;
            return;
        }
        w->render_status = pf_roots_check_output_file(&w->config.storage->output, path,
                                                      &w->render_err);
        if (w->render_status != PF_OK) {
            w->render_fault = PF_FRAME_FAULT_REFUSED;
            return;
        }
        int stale = pf_frame_remove_stale(path, w->task.task_id);
        if (stale > 0)
            pf_wlog(PF_LOG_INFO, "stale_removed", "job=%" PRId64 " frame=%" PRId64 " files=%d",
                    w->job.job_id, frame, stale);
        char tag[96];
        pf_frame_task_tag(w->task.task_id, w->task.lease_token, tag, sizeof tag);
        /* The task's frames after this one, when they follow it one by one. */
        uint32_t following =
            w->task.frame_step == 1 ? (uint32_t)(w->task.frame_count - 1 - i) : 0u;
        pf_frame_request frame_request = {w->scene, scene_path, frame,          settings,
                                          path,     tag,        w->device_name, &w->abort,
                                          following};
        int peak_from_frame = pf_peak_rss_reset();
        w->render_status = pf_frame_render(w->renderer, &frame_request, &w->outputs[i],
                                           &w->render_err);
        /* Without a reset the high-water mark is the process's, not the frame's. */
        w->output_peak_rss[i] = peak_from_frame ? pf_peak_rss() : -1;
        w->output_count = (size_t)i + 1;
        if (w->render_status != PF_OK) {
            w->render_fault = pf_frame_fault_of(w->outputs[i].failed);
            char quoted[PF_ERROR_MESSAGE_MAX + 8];
            pf_wlog(PF_LOG_WARN, "render_failed",
                    "job=%" PRId64 " frame=%" PRId64 " worker=%s fault=%s error=%s",
                    w->job.job_id, frame, w->name, pf_frame_fault_name(w->render_fault),
                    pf_wlog_quote(w->render_err.message, quoted, sizeof quoted));
            return;
        }
        log_rendered(w, frame, &w->outputs[i]);
        save_pipeline_cache(w);
    }
}

static void render_after(uv_work_t *request, int uv_status)
{
    worker *w = request->data;
    (void)uv_status;
    if (w->lease_lost) {
        pf_wlog(PF_LOG_WARN, "lease_lost",
                "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=discarded",
                w->task.job_id, w->task.first_frame, w->task.task_id, w->name);
        task_finished(w);
        return;
    }
    w->state = STATE_FINISHING;
    if (atomic_load(&w->abort)) {
        discard_outputs(w);
        db_submit(w, release_run, release_done);
    } else if (w->render_status != PF_OK) {
        discard_outputs(w);
        if (w->render_fault == PF_FRAME_FAULT_REFUSED)
            db_submit(w, reject_run, reject_done);
        else if (w->render_fault == PF_FRAME_FAULT_WORKER)
            db_submit(w, fail_run, fail_done);
        else
            db_submit(w, fail_job_run, fail_job_done);
    } else {
        db_submit(w, finish_run, finish_done);
    }
}

/* ---- lease heartbeat ------------------------------------------------------ */

static void heartbeat_run(db_op *op)
{
    op->status = pf_queue_heartbeat(op->owner->queue, op->token, NULL, &op->err);
}

static void heartbeat_done(db_op *op)
{
    worker *w = op->owner;
    w->heartbeat_in_flight = 0;
    bool current = strcmp(op->token, w->task.lease_token) == 0;
    if (op->status == PF_ERR_INVALID && current && w->state == STATE_RENDERING) {
        /* Someone else may own the frame now: stop and write nothing. */
        w->lease_lost = 1;
        atomic_store(&w->abort, 1);
        uv_timer_stop(&w->lease_timer);
    } else if (op->status != PF_OK && op->status != PF_ERR_INVALID) {
        log_db_error(w, "heartbeat", op);
    }
}

static void lease_tick(uv_timer_t *timer)
{
    worker *w = timer->data;
    if (w->state != STATE_RENDERING || w->heartbeat_in_flight)
        return;
    w->heartbeat_in_flight = 1;
    db_submit(w, heartbeat_run, heartbeat_done);
}

/* ---- claim ------------------------------------------------------------------ */

static void claim_run(db_op *op)
{
    worker *w = op->owner;
    op->status = pf_queue_claim(w->queue, w->worker_id, w->last_job_id, w->last_frame, &w->task,
                                &op->flag, &op->err);
    if (op->status == PF_OK && op->flag) {
        pf_queue_job_clear(&w->job);
        op->status = pf_queue_job_get(w->queue, w->task.job_id, &w->job, &op->err);
    }
}

static void start_render(worker *w)
{
    w->state = STATE_RENDERING;
    w->lease_lost = 0;
    atomic_store(&w->abort, 0);
    int64_t period = w->lease_ms / 3 > 0 ? w->lease_ms / 3 : 1;
    uv_timer_start(&w->lease_timer, lease_tick, (uint64_t)period, (uint64_t)period);
    w->render_request.data = w;
    uv_queue_work(&w->loop, &w->render_request, render_work, render_after);
}

static void claim_done(db_op *op)
{
    worker *w = op->owner;
    if (op->status != PF_OK) {
        log_db_error(w, "claim", op);
        if (op->flag) {
            /* Claimed but the job could not be read: give the task back. */
            w->state = STATE_FINISHING;
            db_submit(w, release_run, release_done);
            return;
        }
    } else if (op->flag) {
        if (w->signals_seen > 0) {
            w->state = STATE_FINISHING;
            db_submit(w, release_run, release_done);
            return;
        }
        pf_wlog_capture_begin();
        pf_wlog(PF_LOG_INFO, "claimed",
                "job=%" PRId64 " frame=%d frames=%d task=%" PRId64 " attempt=%d worker=%s",
                w->task.job_id, w->task.first_frame, w->task.frame_count, w->task.task_id,
                w->task.attempt, w->name);
        start_render(w);
        return;
    }
    if (w->signals_seen > 0) {
        begin_shutdown(w);
        return;
    }
    double idle_ms = pf_time_ms() - w->idle_since_ms;
    if (w->config.once ||
        (w->config.idle_exit_seconds >= 0 && idle_ms >= w->config.idle_exit_seconds * 1000.0)) {
        pf_wlog(PF_LOG_INFO, "idle_exit", "worker=%s idle_ms=%.0f", w->name, idle_ms);
        begin_shutdown(w);
        return;
    }
    w->state = STATE_IDLE;
    arm_poll(w);
}

static void poll_tick(uv_timer_t *timer)
{
    claim_next(timer->data);
}

static void claim_next(worker *w)
{
    w->state = STATE_CLAIMING;
    db_submit(w, claim_run, claim_done);
}

/* Arms the idle poll with backoff (after a claim found nothing). */
static void arm_poll(worker *w)
{
    uv_timer_start(&w->poll_timer, poll_tick, (uint64_t)w->poll_delay_ms, 0);
    w->poll_delay_ms *= 2;
    if (w->poll_delay_ms > PF_WORKER_POLL_MAX_MS)
        w->poll_delay_ms = PF_WORKER_POLL_MAX_MS;
}

/* ---- maintenance: reaper + idle worker heartbeat ------------------------- */

static void maintenance_run(db_op *op)
{
    worker *w = op->owner;
    op->status = pf_queue_reap(w->queue, &op->count, &op->err);
    if (op->status == PF_OK)
        op->status = pf_queue_worker_heartbeat(w->queue, w->worker_id, &op->err);
}

static void maintenance_done(db_op *op)
{
    worker *w = op->owner;
    w->maintenance_in_flight = 0;
    if (op->status != PF_OK)
        log_db_error(w, "reap", op);
    else if (op->count > 0)
        pf_wlog(PF_LOG_INFO, "reaped", "worker=%s tasks=%" PRId64, w->name, op->count);
}

static void maintenance_tick(uv_timer_t *timer)
{
    worker *w = timer->data;
    if (w->maintenance_in_flight || w->state == STATE_STOPPING)
        return;
    w->maintenance_in_flight = 1;
    db_submit(w, maintenance_run, maintenance_done);
}

/* ---- signals and shutdown ------------------------------------------------- */

static void on_signal(uv_signal_t *handle, int signal_number)
{
    worker *w = handle->data;
    w->signals_seen++;
    const char *name = signal_number == SIGINT ? "SIGINT" : "SIGTERM";
    if (w->signals_seen == 1) {
        pf_wlog(PF_LOG_INFO, "draining", "worker=%s signal=%s state=%s", w->name, name,
                w->state == STATE_RENDERING ? "rendering" : "idle");
        if (w->state == STATE_IDLE) {
            uv_timer_stop(&w->poll_timer);
            begin_shutdown(w);
        }
    } else {
        pf_wlog(PF_LOG_WARN, "aborting", "worker=%s signal=%s", w->name, name);
        /* The render work stops at its next stage boundary; render_after releases. */
        atomic_store(&w->abort, 1);
    }
}

static void close_handle(uv_handle_t *handle)
{
    if (!uv_is_closing(handle))
        uv_close(handle, NULL);
}

static void stop_run(db_op *op)
{
    op->status = pf_queue_worker_stop(op->owner->queue, op->owner->worker_id, &op->err);
}

static void stop_done(db_op *op)
{
    worker *w = op->owner;
    if (op->status != PF_OK)
        log_db_error(w, "stop", op);
    pf_wlog(PF_LOG_INFO, "stopped", "worker=%s frames=%" PRId64, w->name, w->frames_processed);
    if (w->show_progress) {
        pf_wlog_set_hook(NULL, NULL);
        pf_progress_finish(&w->progress);
    }
    close_handle((uv_handle_t *)&w->poll_timer);
    close_handle((uv_handle_t *)&w->lease_timer);
    close_handle((uv_handle_t *)&w->maintenance_timer);
    close_handle((uv_handle_t *)&w->sigint_handle);
    close_handle((uv_handle_t *)&w->sigterm_handle);
}

static void begin_shutdown(worker *w)
{
    if (w->state == STATE_STOPPING)
        return;
    w->state = STATE_STOPPING;
    uv_timer_stop(&w->poll_timer);
    uv_timer_stop(&w->lease_timer);
    uv_timer_stop(&w->maintenance_timer);
    db_submit(w, stop_run, stop_done);
}

/* ---- setup ------------------------------------------------------------------ */

static int open_everything(worker *w)
{
    pf_error err = {0};
    pf_queue_options options = {0};
    options.lease_ms = w->lease_ms;
    pf_status status = pf_queue_open(w->config.db_path, &options, &w->queue, &err);
    if (status != PF_OK) {
        fprintf(stderr, "photonfarm worker: %s\n", err.message);
        return pf_status_exit_code(status);
    }
    pf_vk_options vk_options = pf_cli_vk_options(w->config.device, w->config.cache_dir);
    status = pf_vk_create(&vk_options, &w->vk, &err);
    if (status == PF_OK)
        status = pf_renderer_create(w->vk, &w->renderer, &err);
    if (status != PF_OK) {
        fprintf(stderr, "photonfarm worker: %s\n", err.message);
        return pf_status_exit_code(status);
    }
    snprintf(w->device_name, sizeof w->device_name, "%s", pf_vk_info(w->vk)->name);

    char host[PF_QUEUE_NAME_MAX] = "localhost";
    gethostname(host, sizeof host - 1);
    if (w->config.name)
        snprintf(w->name, sizeof w->name, "%s", w->config.name);
    else
        snprintf(w->name, sizeof w->name, "%.100s-%ld", host, (long)getpid());
    /* Capabilities: the device's type and memory, the host's memory and cores, the tags. */
    const pf_vk_device_info *device = pf_vk_info(w->vk);
    long pages = sysconf(_SC_PHYS_PAGES), page_size = sysconf(_SC_PAGE_SIZE);
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    pf_queue_worker_spec spec = {
        .name = w->name,
        .host = host,
        .pid = (int64_t)getpid(),
        .device = w->device_name,
        .lease_ms = w->lease_ms,
        .device_type = strcmp(device->type, "cpu") == 0 ? "cpu" : "gpu",
        .device_memory = (int64_t)device->device_local_bytes,
        .host_memory = pages > 0 && page_size > 0 ? (int64_t)pages * page_size : 0,
        .cores = cores > 0 ? cores : 0,
        .tags = w->config.tags,
    };
    status = pf_queue_worker_register(w->queue, &spec, &w->worker_id, &err);
    if (status != PF_OK) {
        fprintf(stderr, "photonfarm worker: %s\n", err.message);
        return pf_status_exit_code(status);
    }
    return 0;
}

static void close_everything(worker *w)
{
    discard_outputs(w);
    pf_scene_destroy(w->scene);
    pf_queue_job_clear(&w->job);
    pf_renderer_destroy(w->renderer);
    if (w->vk) {
        if (pf_vk_validation_enabled(w->vk) && pf_vk_validation_message_count(w->vk) > 0) {
            fprintf(stderr, "photonfarm worker: %u Vulkan validation message(s) (see above)\n",
                    pf_vk_validation_message_count(w->vk));
            if (w->exit_code == 0)
                w->exit_code = 1;
        }
        pf_vk_destroy(w->vk);
    }
    pf_queue_close(w->queue);
}

/* The storage roots this worker confines jobs to, and one warning when it confines none. */
static void log_roots(worker *w)
{
    const pf_roots *kinds[2] = {&w->config.storage->scene, &w->config.storage->output};
    char unconfined[32] = "";
    for (int k = 0; k < 2; k++) {
        const pf_roots *roots = kinds[k];
        char list[PF_ROOTS_MAX * (PATH_MAX + 2)], quoted[sizeof list + 8];
        if (roots && roots->count > 0)
            pf_wlog(PF_LOG_INFO, "roots", "worker=%s kind=%s roots=%s", w->name, roots->kind,
                    pf_wlog_quote(pf_roots_list(roots, list, sizeof list), quoted,
                                  sizeof quoted));
        else
            snprintf(unconfined + strlen(unconfined), sizeof unconfined - strlen(unconfined),
                     "%s%s", unconfined[0] ? "," : "", k ? "output" : "scene");
    }
    if (unconfined[0])
        pf_wlog(PF_LOG_WARN, "unconfined",
                "worker=%s kinds=%s message=\"no --scene-root/--output-root: this worker "
                "reads and writes wherever a job's paths point\"",
                w->name, unconfined);
}

int pf_worker_run(const pf_worker_config *config)
{
    worker *w = calloc(1, sizeof *w);
    if (!w) {
        fprintf(stderr, "photonfarm worker: out of memory\n");
        return 1;
    }
    w->config = *config;
    w->lease_ms = (int64_t)(config->lease_seconds * 1000.0);
    pf_wlog_capture_core();
    int code = open_everything(w);
    if (code != 0) {
        close_everything(w);
        free(w);
        pf_log_set_sink(NULL, NULL);
        return code;
    }
    w->show_progress = isatty(fileno(stderr));
    if (w->show_progress) {
        pf_progress_init(&w->progress, stderr);
        pf_wlog_set_hook(progress_hook, w);
    }

    uv_loop_init(&w->loop);
    uv_mutex_init(&w->queue_mutex);
    uv_timer_init(&w->loop, &w->poll_timer);
    uv_timer_init(&w->loop, &w->lease_timer);
    uv_timer_init(&w->loop, &w->maintenance_timer);
    uv_signal_init(&w->loop, &w->sigint_handle);
    uv_signal_init(&w->loop, &w->sigterm_handle);
    w->poll_timer.data = w->lease_timer.data = w->maintenance_timer.data = w;
    w->sigint_handle.data = w->sigterm_handle.data = w;
    uv_signal_start(&w->sigint_handle, on_signal, SIGINT);
    uv_signal_start(&w->sigterm_handle, on_signal, SIGTERM);
    int64_t maintenance_ms = w->lease_ms / 2;
    if (maintenance_ms < MAINTENANCE_MIN_MS)
        maintenance_ms = MAINTENANCE_MIN_MS;
    if (maintenance_ms > MAINTENANCE_MAX_MS)
        maintenance_ms = MAINTENANCE_MAX_MS;
    uv_timer_start(&w->maintenance_timer, maintenance_tick, 0, (uint64_t)maintenance_ms);

    pf_wlog(PF_LOG_INFO, "started",
            "worker=%s worker_id=%" PRId64 " device=\"%s\" tags=\"%s\" db=%s lease_ms=%" PRId64
            " version=%s",
            w->name, w->worker_id, w->device_name, config->tags ? config->tags : "",
            config->db_path, w->lease_ms, pf_version_string());
    log_roots(w);
    if (!pf_peak_rss_reset())
        pf_wlog(PF_LOG_WARN, "peak_memory_unmeasured",
                "worker=%s reason=\"/proc/self/clear_refs is not writable: frames record no "
                "peak resident memory\"",
                w->name);
    w->poll_delay_ms = PF_WORKER_POLL_MIN_MS;
    w->idle_since_ms = pf_time_ms();
    claim_next(w);
    uv_run(&w->loop, UV_RUN_DEFAULT);
    uv_loop_close(&w->loop);
    uv_mutex_destroy(&w->queue_mutex);
    pf_wlog_set_hook(NULL, NULL);
    close_everything(w);
    code = w->exit_code;
    free(w);
    pf_log_set_sink(NULL, NULL);
    return code;
}
