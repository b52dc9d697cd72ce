/*
 * The queue worker's libuv loop (see worker_loop.h). Everything below runs on
 * the loop thread except the *_work functions, which libuv runs on its thread
 * pool: database work (each under queue_mutex, as a pf_queue is one
 * connection) and the render of the current task; and the frame writer's
 * thread, which writes the rendered frames and wakes the loop (written_async).
 * The state machine makes sure the loop thread does not touch what a running
 * *_work function or a write in flight owns.
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
#include "frame_writer.h"

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

/* What the worker is doing about its next task (the runs below have their own states). */
typedef enum front_state {
    FRONT_NONE,      /* nothing: go_on decides what comes next */
    FRONT_POLLING,   /* the idle poll timer is armed */
    FRONT_CLAIMING,  /* a claim is in flight */
    FRONT_RENDERING, /* render work is in flight */
    FRONT_STOPPING   /* worker_stop in flight or done; handles closing */
} front_state;

/* Where a claimed task is. */
typedef enum run_state {
    RUN_FREE,      /* the slot holds no task */
    RUN_RENDERING, /* render work in flight */
    RUN_WRITING,   /* rendered: its frames' writes may still be in flight */
    RUN_SETTLING   /* complete / fail / release in flight */
} run_state;

typedef struct worker worker;

/*
 * A claimed task and what rendering it made. Two slots: one task renders while
 * the frames of the one before it are written and committed (issue 43), each
 * under its own lease.
 */
typedef struct task_run {
    worker *owner;
    run_state state;
    pf_queue_task task;
    pf_queue_job job;
    atomic_int abort;        /* the render stops at its next stage boundary */
    int lease_lost;
    int heartbeat_in_flight;
    char *log;               /* the attempt's log, from the claim to the render's end */
    pf_wlog_late late_log;   /* lines about it logged after that, until its log is stored */

    /* The render's (render work owns them until render_after). */
    pf_frame_output *outputs;
    int64_t *output_peak_rss; /* each output's peak resident memory (bytes; -1: unknown) */
    size_t output_count;      /* frames rendered, successfully or not */
    size_t handed;            /* of them, handed to the writer */
    pf_status render_status;
    pf_error render_err;
    pf_frame_fault render_fault; /* whose fault a failed render is */

    /* The writer's (under worker.written_mutex). */
    size_t written;
    atomic_int write_failed; /* the render stops handing over frames of this task */
    pf_status write_status;  /* the first failed write's */
    pf_error write_err;
    int64_t write_failed_frame;
} task_run;

#define RUN_SLOTS 2

/* A database operation on the thread pool. */
typedef struct db_op {
    uv_work_t request;
    worker *owner;
    task_run *run;                  /* the task it is about; NULL: none */
    void (*run_fn)(struct db_op *op); /* thread pool, under queue_mutex */
    void (*done)(struct db_op *op); /* loop thread */
    pf_status status;
    pf_error err;
    char token[PF_QUEUE_TOKEN_CHARS + 1]; /* the task's lease when submitted */
    bool flag;          /* claim: claimed; finish: lease lost */
    bool committed;     /* finish: the lease was lost after the frame was renamed into place */
    bool job_fault;     /* finish: the commit failed on the job's output (the job is paused) */
    bool locks_itself;  /* run_fn takes queue_mutex itself, only around its database calls */
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
    uv_async_t written_async; /* the writer wrote a frame */
    int signals_seen;
    int exiting;              /* --once or the idle limit: stop once the runs settle */
    front_state front;
    int64_t poll_delay_ms;
    double idle_since_ms;
    int64_t frames_processed;
    int maintenance_in_flight;
    int exit_code;

    task_run runs[RUN_SLOTS];
    /* A job whose output or scene failed a task here, until the queue has paused it and no
     * claim from before that is in flight: its other tasks claimed meanwhile are given
     * back, not failed one by one (frame_writer.h's claim ahead). */
    int64_t faulted_job_id;
    int fault_settled;
    int64_t last_job_id; /* the last rendered task's: the claim prefers its next frame */
    int32_t last_frame;

    task_run *rendering; /* the run render work renders (NULL: none) */
    /* Render work's own state: the scene cache. */
    int64_t scene_job_id;
    pf_scene *scene;
    uv_work_t render_request;

    pf_frame_writer *writer;
    uv_mutex_t written_mutex;

    pf_progress progress;
    int show_progress;
    const task_run *progress_run; /* the run update_progress reports */
};

static void begin_shutdown(worker *w);
static void claim_next(worker *w);
static void arm_poll(worker *w);
static void go_on(worker *w);
static void finish_run(struct db_op *op);

/* ---- database operations ------------------------------------------------- */

static void db_op_work(uv_work_t *request)
{
    db_op *op = request->data;
    if (op->locks_itself) {
        op->run_fn(op);
        return;
    }
    uv_mutex_lock(&op->owner->queue_mutex);
    op->run_fn(op);
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

/* Runs run_fn on the thread pool, then done on the loop thread; about run's task (NULL:
 * none), whose lease token it copies now. */
static void db_submit(worker *w, task_run *run, void (*run_fn)(db_op *),
                      void (*done)(db_op *))
{
    db_op *op = calloc(1, sizeof *op);
    if (!op) {
        pf_wlog(PF_LOG_ERROR, "out_of_memory", "worker=%s", w->name);
        w->exit_code = 1;
        return;
    }
    op->owner = w;
    op->run = run;
    op->run_fn = run_fn;
    op->done = done;
    op->locks_itself = run_fn == finish_run;
    op->request.data = op;
    if (run)
        memcpy(op->token, run->task.lease_token, sizeof op->token);
    uv_queue_work(&w->loop, &op->request, db_op_work, db_op_after);
}

static void log_db_error(worker *w, const char *what, const db_op *op)
{
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    pf_wlog(PF_LOG_ERROR, "db_error", "worker=%s op=%s error=%s", w->name, what,
            pf_wlog_quote(op->err.message, quoted, sizeof quoted));
}

/*
 * A line about run's attempt: in its own log (its capture while it renders, its late lines
 * while its frames are written), never in the attempt of the task claimed meanwhile.
 */
#define RUN_LOG(run, level, event, ...) \
    pf_wlog_about((run), &(run)->late_log, (level), (event), __VA_ARGS__)

/* Stores the lines logged from the claim to the render's end, and those about it logged
 * since (its frames' writes), as this attempt's log (issue 41), first thing when the task
 * is let go, whatever the outcome. On the thread
 * pool, under queue_mutex. A log the queue refuses is reported, and the task is settled
 * all the same. */
static void store_attempt_log(worker *w, task_run *run)
{
    char *text = run->log, *late = pf_wlog_late_take(&run->late_log);
    run->log = NULL;
    if (text && late) { /* the lines about it logged while its frames were written */
        size_t length = strlen(text);
        char *both = realloc(text, length + strlen(late) + 1);
        if (both) {
            strcpy(both + length, late);
            text = both;
        }
    }
    free(late);
    if (!text)
        return;
    pf_error err = {0};
    if (pf_queue_attempt_log_store(w->queue, run->task.task_id, run->task.attempt,
                                   w->worker_id, text, &err) != PF_OK) {
        char quoted[PF_ERROR_MESSAGE_MAX + 8];
        RUN_LOG(run, PF_LOG_WARN, "log_not_stored", "job=%" PRId64 " task=%" PRId64 " worker=%s "
                "error=%s", run->task.job_id, run->task.task_id, w->name,
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

static void discard_outputs(task_run *run)
{
    for (size_t i = 0; i < run->output_count; i++)
        pf_frame_discard(&run->outputs[i]);
    free(run->outputs);
    run->outputs = NULL;
    free(run->output_peak_rss);
    run->output_peak_rss = NULL;
    run->output_count = 0;
}

static task_run *free_run(worker *w)
{
    for (int i = 0; i < RUN_SLOTS; i++)
        if (w->runs[i].state == RUN_FREE)
            return &w->runs[i];
    return NULL;
}

/* Frames of the tasks this worker holds (rendering, writing or settling). */
static int64_t frames_held(const worker *w)
{
    int64_t frames = 0;
    for (int i = 0; i < RUN_SLOTS; i++)
        if (w->runs[i].state != RUN_FREE)
            frames += w->runs[i].task.frame_count;
    return frames;
}

/* run's task is settled (done, failed, released or lost): its slot is free again. */
static void run_settled(worker *w, task_run *run)
{
    discard_outputs(run);
    free(run->log);
    run->log = NULL;
    free(pf_wlog_late_take(&run->late_log));
    w->frames_processed += run->task.frame_count;
    pf_queue_job_clear(&run->job);
    run->state = RUN_FREE;
    w->idle_since_ms = pf_time_ms();
    w->poll_delay_ms = PF_WORKER_POLL_MIN_MS;
    go_on(w);
}

/*
 * What comes next, whenever the front is free or a run settles: claim the next task
 * while a slot is free (also while the last task's frames are still being written:
 * they are under its own lease), or stop once nothing is held and the worker was told
 * to (a signal, --once, the idle limit, --max-frames).
 */
static void go_on(worker *w)
{
    if (w->front != FRONT_NONE)
        return;
    int max_reached = w->config.max_frames > 0 &&
                      w->frames_processed + frames_held(w) >= w->config.max_frames;
    if (w->signals_seen > 0 || w->exiting || max_reached) {
        if (frames_held(w) > 0)
            return; /* the held tasks settle first */
        if (max_reached && !w->signals_seen && !w->exiting)
            pf_wlog(PF_LOG_INFO, "max_frames_reached", "worker=%s frames=%" PRId64, w->name,
                    w->frames_processed);
        begin_shutdown(w);
        return;
    }
    if (free_run(w))
        claim_next(w);
}

/*
 * run failed for its job's sake (its output or scene): the job is, or is about to be,
 * paused. Another task of the job held here is given back once its render or writes
 * stop (abort releases), and so is one a claim in flight returns. settled: the queue has
 * paused the job already.
 */
static void note_job_fault(worker *w, const task_run *run, int settled)
{
    w->faulted_job_id = run->task.job_id;
    w->fault_settled = settled;
    for (int i = 0; i < RUN_SLOTS; i++) {
        task_run *other = &w->runs[i];
        if (other != run && other->task.job_id == run->task.job_id &&
            (other->state == RUN_RENDERING || other->state == RUN_WRITING))
            atomic_store(&other->abort, 1);
    }
    if (settled && w->front != FRONT_CLAIMING)
        w->faulted_job_id = 0;
}

/* ---- release ------------------------------------------------------------- */

static void release_run(db_op *op)
{
    store_attempt_log(op->owner, op->run);
    op->status = pf_queue_release(op->owner->queue, op->token, &op->err);
}

static void release_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    if (op->status == PF_OK)
        RUN_LOG(run, PF_LOG_INFO, "released", "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s",
                run->task.job_id, run->task.first_frame, run->task.task_id, w->name);
    else if (op->status != PF_ERR_INVALID)
        log_db_error(w, "release", op);
    run_settled(w, run);
}

/* ---- fail ---------------------------------------------------------------- */

static void fail_run(db_op *op)
{
    task_run *run = op->run;
    store_attempt_log(op->owner, run);
    op->status = pf_queue_fail(op->owner->queue, op->token, run->render_err.message, &op->err);
}

static void log_lease_lost(worker *w, task_run *run, const char *action)
{
    RUN_LOG(run, PF_LOG_WARN, "lease_lost", "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s%s%s",
            run->task.job_id, run->task.first_frame, run->task.task_id, w->name,
            action ? " action=" : "", action ? action : "");
}

static void fail_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    RUN_LOG(run, PF_LOG_WARN, "failed",
            "job=%" PRId64 " frame=%d task=%" PRId64 " attempt=%d worker=%s error=%s",
            run->task.job_id, run->task.first_frame, run->task.task_id, run->task.attempt,
            w->name, pf_wlog_quote(run->render_err.message, quoted, sizeof quoted));
    if (op->status == PF_ERR_INVALID)
        log_lease_lost(w, run, NULL);
    else if (op->status != PF_OK)
        log_db_error(w, "fail", op);
    run_settled(w, run);
}

/* ---- the job's fault: its output or scene, not this worker ---------------- */

static void fail_job_run(db_op *op)
{
    task_run *run = op->run;
    store_attempt_log(op->owner, run);
    char reason[sizeof run->render_err.message + 32];
    snprintf(reason, sizeof reason, "%s: %s", pf_frame_fault_name(run->render_fault),
             run->render_err.message);
    op->status = pf_queue_fail_job(op->owner->queue, op->token, reason, &op->err);
}

/* Logs a failure that is the job's: the job is paused, this worker stays eligible. */
static void log_job_fault(worker *w, task_run *run, pf_frame_fault fault,
                          const char *message)
{
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    RUN_LOG(run, PF_LOG_WARN, "job_fault",
            "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s fault=%s action=job_paused "
            "error=%s",
            run->task.job_id, run->task.first_frame, run->task.task_id, w->name,
            pf_frame_fault_name(fault), pf_wlog_quote(message, quoted, sizeof quoted));
}

static void fail_job_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    note_job_fault(w, run, 1);
    if (op->status == PF_OK)
        log_job_fault(w, run, run->render_fault, run->render_err.message);
    else if (op->status == PF_ERR_INVALID)
        log_lease_lost(w, run, NULL);
    else
        log_db_error(w, "fail_job", op);
    run_settled(w, run);
}

/* ---- refused: the job asks for what this farm does not allow ------------- */

static void reject_run(db_op *op)
{
    task_run *run = op->run;
    store_attempt_log(op->owner, run);
    op->status = pf_queue_reject(op->owner->queue, op->token, run->render_err.message, &op->err);
}

static void reject_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    if (op->status == PF_OK)
        RUN_LOG(run, PF_LOG_WARN, "rejected",
                "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=task_failed error=%s",
                run->task.job_id, run->task.first_frame, run->task.task_id, w->name,
                pf_wlog_quote(run->render_err.message, quoted, sizeof quoted));
    else if (op->status != PF_ERR_INVALID)
        log_db_error(w, "reject", op);
    run_settled(w, run);
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

/*
 * Renews the lease, renames the frames into place, completes: the database calls under
 * queue_mutex, the renames (and their fsyncs, slow on some volumes) outside it, so that
 * the heartbeats of the task rendering meanwhile are not held up behind them.
 */
static void finish_run(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    uv_mutex_lock(&w->queue_mutex);
    /* Renew first: a rename with a lease about to lapse could race the reaper. */
    op->status = pf_queue_heartbeat(w->queue, op->token, NULL, &op->err);
    store_attempt_log(w, run);
    uv_mutex_unlock(&w->queue_mutex);
    if (op->status == PF_ERR_INVALID) {
        op->flag = true;
        discard_outputs(run);
        return;
    }
    if (op->status != PF_OK)
        return;
    size_t row_capacity = 0;
    for (size_t i = 0; i < run->output_count; i++)
        row_capacity += run->outputs[i].report.stage_count;
    pf_queue_stage_row *rows = calloc(row_capacity ? row_capacity : 1, sizeof *rows);
    char **counters = calloc(row_capacity ? row_capacity : 1, sizeof *counters);
    if (!rows || !counters) {
        free(rows);
        free(counters);
        op->status = pf_error_set(&op->err, PF_ERR_NOMEM, "stage rows");
        return;
    }
    size_t row_count = 0;
    pf_queue_frame_resources *resources = calloc(run->output_count ? run->output_count : 1,
                                                 sizeof *resources);
    if (!resources) {
        free(rows);
        free(counters);
        op->status = pf_error_set(&op->err, PF_ERR_NOMEM, "frame resources");
        return;
    }
    for (size_t i = 0; i < run->output_count; i++) {
        const pf_frame_report *report = &run->outputs[i].report;
        int32_t frame = run->task.first_frame + (int32_t)i * run->task.frame_step;
        resources[i] = (pf_queue_frame_resources){frame, run->output_peak_rss[i],
                                                  (int64_t)run->outputs[i].peak_device_bytes,
                                                  (int64_t)run->outputs[i].bytes_written};
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
    for (size_t i = 0; i < run->output_count && op->status == PF_OK; i++) {
        op->status = pf_frame_commit(&run->outputs[i], &op->err);
        op->job_fault = op->status != PF_OK &&
                        pf_frame_fault_of(run->outputs[i].failed) != PF_FRAME_FAULT_WORKER;
    }
    uv_mutex_lock(&w->queue_mutex);
    if (op->status == PF_OK) {
        op->status = pf_queue_complete_frames(w->queue, op->token, rows, row_count, resources,
                                              run->output_count, NULL, &op->err);
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
        pf_queue_job_clear(&run->job);
        pf_error ignored;
        pf_queue_job_get(w->queue, run->task.job_id, &run->job, &ignored);
    }
    uv_mutex_unlock(&w->queue_mutex);
    for (size_t i = 0; i < row_count; i++)
        free(counters[i]);
    free(counters);
    free(rows);
    free(resources);
}

static void update_progress(void *user)
{
    worker *w = user;
    const task_run *run = w->progress_run;
    char label[64];
    snprintf(label, sizeof label, "job %" PRId64, run->task.job_id);
    pf_progress_update(&w->progress, label, run->job.frames_done, run->job.frames_total);
}

static void finish_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    if (op->flag) {
        log_lease_lost(w, run, op->committed ? "left_to_new_owner" : "discarded");
    } else if (op->status != PF_OK && op->job_fault) {
        note_job_fault(w, run, 1);
        if (op->count)
            log_job_fault(w, run, PF_FRAME_FAULT_OUTPUT, op->err.message);
        else
            log_db_error(w, "complete", op);
    } else if (op->status != PF_OK) {
        log_db_error(w, "complete", op);
        if (op->count)
            RUN_LOG(run, PF_LOG_WARN, "commit_failed",
                    "job=%" PRId64 " frame=%d task=%" PRId64 " worker=%s action=failed_for_retry",
                    run->task.job_id, run->task.first_frame, run->task.task_id, w->name);
        w->exit_code = 1;
    } else {
        double total_ms = 0;
        for (size_t i = 0; i < run->output_count; i++)
            total_ms += run->outputs[i].total_ms;
        RUN_LOG(run, PF_LOG_INFO, "completed",
                "job=%" PRId64 " frame=%d frames=%d task=%" PRId64 " worker=%s ms=%.1f "
                "job_frames_done=%" PRId64 " job_frames=%" PRId64 " job_status=%s",
                run->task.job_id, run->task.first_frame, run->task.frame_count,
                run->task.task_id, w->name, total_ms, run->job.frames_done,
                run->job.frames_total, run->job.status);
        if (w->show_progress) {
            w->progress_run = run;
            pf_wlog_exclusive(update_progress, w);
        }
    }
    run_settled(w, run);
}

/* ---- writes: the frames of a rendered task, on the writer's thread ------------ */

/* The writer's thread: counts the write, keeps the first failure, wakes the loop. */
static void frame_written(void *user, pf_frame_output *frame, pf_status status,
                          const pf_error *err)
{
    task_run *run = user;
    worker *w = run->owner;
    int64_t index = frame - run->outputs;
    if (status == PF_OK)
        RUN_LOG(run, PF_LOG_INFO, "written",
                "job=%" PRId64 " frame=%" PRId64 " worker=%s ms=%.1f bytes=%" PRIu64,
                run->task.job_id, run->task.first_frame + index * run->task.frame_step,
                w->name, frame->report.stage_count
                             ? frame->report.stages[frame->report.stage_count - 1].wall_ms
                             : 0.0,
                frame->bytes_written);
    uv_mutex_lock(&w->written_mutex);
    if (status != PF_OK && run->write_status == PF_OK) {
        run->write_status = status;
        run->write_err = *err;
        run->write_failed_frame = run->task.first_frame + index * run->task.frame_step;
        atomic_store(&run->write_failed, 1);
    }
    run->written++;
    uv_mutex_unlock(&w->written_mutex);
    uv_async_send(&w->written_async);
}

/*
 * A rendered task whose every handed-over frame is written: settle it by what
 * happened. A lost lease writes nothing more and gives nothing back; an abort
 * releases; a failed render or write fails the task (whose fault decides how);
 * otherwise the frames are committed.
 */
static void run_written(worker *w, task_run *run)
{
    run->state = RUN_SETTLING;
    if (run->lease_lost) {
        discard_outputs(run);
        log_lease_lost(w, run, "discarded");
        run_settled(w, run);
        return;
    }
    if (run->render_status == PF_OK && run->write_status != PF_OK) {
        /* The first failed write is the task's failure, as a failed render is. */
        run->render_status = run->write_status;
        run->render_err = run->write_err;
        run->render_fault = pf_frame_fault_of(PF_FRAME_FAILED_OUTPUT);
        char quoted[PF_ERROR_MESSAGE_MAX + 8];
        RUN_LOG(run, PF_LOG_WARN, "render_failed",
                "job=%" PRId64 " frame=%" PRId64 " task=%" PRId64 " worker=%s fault=%s error=%s",
                run->task.job_id, run->write_failed_frame, run->task.task_id, w->name,
                pf_frame_fault_name(run->render_fault),
                pf_wlog_quote(run->render_err.message, quoted, sizeof quoted));
    }
    if (atomic_load(&run->abort)) {
        discard_outputs(run);
        db_submit(w, run, release_run, release_done);
    } else if (run->render_status != PF_OK) {
        discard_outputs(run);
        if (run->render_fault == PF_FRAME_FAULT_REFUSED)
            db_submit(w, run, reject_run, reject_done);
        else if (run->render_fault == PF_FRAME_FAULT_WORKER)
            db_submit(w, run, fail_run, fail_done);
        else {
            note_job_fault(w, run, 0);
            db_submit(w, run, fail_job_run, fail_job_done);
        }
    } else {
        db_submit(w, run, finish_run, finish_done);
    }
}

/* Settles each rendered task whose writes are all done. */
static void settle_written(worker *w)
{
    for (int i = 0; i < RUN_SLOTS; i++) {
        task_run *run = &w->runs[i];
        if (run->state != RUN_WRITING)
            continue;
        uv_mutex_lock(&w->written_mutex);
        int done = run->written == run->handed;
        uv_mutex_unlock(&w->written_mutex);
        if (done)
            run_written(w, run);
    }
}

static void on_written(uv_async_t *handle)
{
    settle_written(handle->data);
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
static void log_rendered(worker *w, const task_run *run, int64_t frame,
                         const pf_frame_output *output)
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
            run->job.job_id, frame, w->name, output->total_ms,
            pf_quality_name(output->report.quality), output->width, output->height,
            ran[0] ? ran : "-", skipped[0] ? skipped : "-");
}

/* The render of one task, on the thread pool: each frame is rendered and handed to the
 * writer, which writes it while the next frame renders. */
static void render_task(worker *w, task_run *run)
{
    run->render_status = PF_OK;
    run->render_fault = PF_FRAME_FAULT_WORKER;
    memset(&run->render_err, 0, sizeof run->render_err);
    /* Paths through this worker's roots: outside them the task is refused for good;
     * one that does not exist inside them is its scene's or output's fault. */
    char scene_path[PATH_MAX], pattern[PATH_MAX];
    run->render_status = pf_roots_resolve(&w->config.storage->scene, run->job.scene_path,
                                          scene_path, sizeof scene_path, &run->render_err);
    pf_frame_fault missing = PF_FRAME_FAULT_SCENE;
    if (run->render_status == PF_OK) {
        run->render_status = pf_roots_output_resolve(&w->config.storage->output,
                                                     run->job.output_pattern, pattern,
                                                     sizeof pattern, &run->render_err);
        missing = PF_FRAME_FAULT_OUTPUT;
    }
    if (run->render_status != PF_OK) {
        run->render_fault = run->render_status == PF_ERR_INVALID ? PF_FRAME_FAULT_REFUSED
                                                                 : missing;
        return;
    }
    /* A full, read-only or missing output volume is found before any work, and
     * again at every claim: the job pauses until someone fixes the storage. */
    char absolute[PF_FRAME_PATH_MAX];
    run->render_status = pf_frame_output_check(pattern, absolute, sizeof absolute,
                                               &run->render_err);
    if (run->render_status != PF_OK) {
        run->render_fault = PF_FRAME_FAULT_OUTPUT;
        return;
    }
    if (w->scene_job_id != run->job.job_id || !w->scene) {
        pf_scene_destroy(w->scene);
        w->scene = NULL;
        w->scene_job_id = 0;
        char animation[256], variant[256];
        pf_scene_load_options load = {pf_job_allow_outside(run->job.parameters_json), NULL, NULL};
        if (pf_job_animation(run->job.parameters_json, animation, sizeof animation))
            load.animation = animation;
        if (pf_job_material_variant(run->job.parameters_json, variant, sizeof variant))
            load.material_variant = variant;
        run->render_status = pf_scene_load_with(scene_path, &load, &w->scene,
                                                &run->render_err);
        if (run->render_status != PF_OK) {
            run->render_fault = PF_FRAME_FAULT_SCENE;
            return;
        }
        w->scene_job_id = run->job.job_id;
        pf_wlog(PF_LOG_INFO, "scene_loaded", "job=%" PRId64 " worker=%s triangles=%u",
                run->job.job_id, w->name, pf_scene_get_info(w->scene)->triangle_count);
    }
    pf_render_settings settings;
    run->render_status = pf_settings_parse(run->job.parameters_json, &settings,
                                           &run->render_err);
    if (run->render_status != PF_OK) {
        run->render_fault = PF_FRAME_FAULT_SETTINGS;
        return;
    }
    run->outputs = calloc((size_t)run->task.frame_count, sizeof *run->outputs);
    run->output_peak_rss = calloc((size_t)run->task.frame_count, sizeof *run->output_peak_rss);
    if (!run->outputs || !run->output_peak_rss) {
        run->render_status = pf_error_set(&run->render_err, PF_ERR_NOMEM, "frame outputs");
        return;
    }
    for (int32_t i = 0; i < run->task.frame_count && !atomic_load(&run->abort) &&
                        !atomic_load(&run->write_failed);
         i++) {
        int64_t frame = run->task.first_frame + (int64_t)i * run->task.frame_step;
        char path[PF_FRAME_PATH_MAX];
        if (!pf_frame_output_path(pattern, frame, path, sizeof path)) {
            run->render_status = pf_error_set(&run->render_err, PF_ERR_INVALID,
                                              "output path too long: %s", pattern);
            run->render_fault = PF_FRAME_FAULT_OUTPUT;
            return;
        }
        run->render_status = pf_roots_check_output_file(&w->config.storage->output, path,
                                                        &run->render_err);
        if (run->render_status != PF_OK) {
            run->render_fault = PF_FRAME_FAULT_REFUSED;
            return;
        }
        int stale = pf_frame_remove_stale(path, run->task.task_id);
        if (stale > 0)
            pf_wlog(PF_LOG_INFO, "stale_removed", "job=%" PRId64 " frame=%" PRId64 " files=%d",
                    run->job.job_id, frame, stale);
        char tag[96];
        pf_frame_task_tag(run->task.task_id, run->task.lease_token, tag, sizeof tag);
        /* The task's frames after this one, when they follow it one by one. */
        uint32_t following =
            run->task.frame_step == 1 ? (uint32_t)(run->task.frame_count - 1 - i) : 0u;
        pf_frame_request frame_request = {w->scene, scene_path, frame,          settings,
                                          path,     tag,        w->device_name, &run->abort,
                                          following, 1};
        int peak_from_frame = pf_peak_rss_reset();
        run->render_status = pf_frame_render(w->renderer, &frame_request, &run->outputs[i],
                                             &run->render_err);
        /* Without a reset the high-water mark is the process's, not the frame's. */
        run->output_peak_rss[i] = peak_from_frame ? pf_peak_rss() : -1;
        run->output_count = (size_t)i + 1;
        if (run->render_status != PF_OK) {
            run->render_fault = pf_frame_fault_of(run->outputs[i].failed);
            char quoted[PF_ERROR_MESSAGE_MAX + 8];
            RUN_LOG(run, PF_LOG_WARN, "render_failed",
                    "job=%" PRId64 " frame=%" PRId64 " worker=%s fault=%s error=%s",
                    run->job.job_id, frame, w->name, pf_frame_fault_name(run->render_fault),
                    pf_wlog_quote(run->render_err.message, quoted, sizeof quoted));
            return;
        }
        if (run->outputs[i].aborted)
            return;
        log_rendered(w, run, frame, &run->outputs[i]);
        save_pipeline_cache(w);
        run->handed = (size_t)i + 1;
        pf_frame_writer_hand(w->writer, &run->outputs[i], run);
    }
}

static void render_work(uv_work_t *request)
{
    worker *w = request->data;
    render_task(w, w->rendering);
}

static void render_after(uv_work_t *request, int uv_status)
{
    worker *w = request->data;
    task_run *run = w->rendering;
    w->rendering = NULL;
    (void)uv_status;
    /* The attempt's log: what was logged from its claim to here. */
    run->log = pf_wlog_capture_end();
    w->last_job_id = run->task.job_id;
    w->last_frame = run->task.last_frame;
    run->state = RUN_WRITING;
    w->front = FRONT_NONE;
    settle_written(w); /* at once if its writes are done */
    go_on(w);
}

/* ---- lease heartbeat ------------------------------------------------------ */

static void heartbeat_run(db_op *op)
{
    op->status = pf_queue_heartbeat(op->owner->queue, op->token, NULL, &op->err);
}

static void heartbeat_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    run->heartbeat_in_flight = 0;
    bool current = strcmp(op->token, run->task.lease_token) == 0;
    if (op->status == PF_ERR_INVALID && current &&
        (run->state == RUN_RENDERING || run->state == RUN_WRITING)) {
        /* Someone else may own the frame now: stop and write nothing more. */
        run->lease_lost = 1;
        atomic_store(&run->abort, 1);
    } else if (op->status != PF_OK && op->status != PF_ERR_INVALID) {
        log_db_error(w, "heartbeat", op);
    }
}

/* Renews the lease of each task rendering or being written. */
static void lease_tick(uv_timer_t *timer)
{
    worker *w = timer->data;
    for (int i = 0; i < RUN_SLOTS; i++) {
        task_run *run = &w->runs[i];
        if ((run->state != RUN_RENDERING && run->state != RUN_WRITING) ||
            run->heartbeat_in_flight || run->lease_lost)
            continue;
        run->heartbeat_in_flight = 1;
        db_submit(w, run, heartbeat_run, heartbeat_done);
    }
}

/* ---- claim ------------------------------------------------------------------ */

static void claim_run(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    op->status = pf_queue_claim(w->queue, w->worker_id, w->last_job_id, w->last_frame,
                                &run->task, &op->flag, &op->err);
    if (op->status == PF_OK && op->flag) {
        pf_queue_job_clear(&run->job);
        op->status = pf_queue_job_get(w->queue, run->task.job_id, &run->job, &op->err);
    }
}

static void start_render(worker *w, task_run *run)
{
    w->front = FRONT_RENDERING;
    run->state = RUN_RENDERING;
    run->lease_lost = 0;
    run->heartbeat_in_flight = 0;
    run->handed = 0;
    run->written = 0;
    run->write_status = PF_OK;
    memset(&run->write_err, 0, sizeof run->write_err);
    atomic_store(&run->abort, 0);
    atomic_store(&run->write_failed, 0);
    /* Set before the work is queued and read by it: the render never looks at the other
     * slot, whose state the loop thread changes meanwhile. */
    w->rendering = run;
    w->render_request.data = w;
    uv_queue_work(&w->loop, &w->render_request, render_work, render_after);
}

static void claim_done(db_op *op)
{
    worker *w = op->owner;
    task_run *run = op->run;
    w->front = FRONT_NONE;
    if (op->status != PF_OK) {
        log_db_error(w, "claim", op);
        if (op->flag) {
            /* Claimed but the job could not be read: give the task back. */
            run->state = RUN_SETTLING;
            db_submit(w, run, release_run, release_done);
            return;
        }
    } else if (op->flag) {
        int faulted = run->task.job_id == w->faulted_job_id;
        if (w->fault_settled)
            w->faulted_job_id = 0;
        if (w->signals_seen > 0 || faulted) {
            run->state = RUN_SETTLING;
            db_submit(w, run, release_run, release_done);
            return;
        }
        pf_wlog_capture_begin(run);
        pf_wlog(PF_LOG_INFO, "claimed",
                "job=%" PRId64 " frame=%d frames=%d task=%" PRId64 " attempt=%d worker=%s",
                run->task.job_id, run->task.first_frame, run->task.frame_count,
                run->task.task_id, run->task.attempt, w->name);
        start_render(w, run);
        return;
    }
    /* --once: nothing eligible now (a task still being written settles first); the idle
     * limit: nothing eligible, nothing held, for that long. */
    double idle_ms = pf_time_ms() - w->idle_since_ms;
    int idle_out = frames_held(w) == 0 && w->config.idle_exit_seconds >= 0 &&
                   idle_ms >= w->config.idle_exit_seconds * 1000.0;
    if (w->signals_seen == 0 && (w->config.once || idle_out)) {
        pf_wlog(PF_LOG_INFO, "idle_exit", "worker=%s idle_ms=%.0f", w->name, idle_ms);
        w->exiting = 1;
    }
    if (w->signals_seen > 0 || w->exiting) {
        go_on(w);
        return;
    }
    w->front = FRONT_POLLING;
    arm_poll(w);
}

static void poll_tick(uv_timer_t *timer)
{
    worker *w = timer->data;
    w->front = FRONT_NONE;
    go_on(w);
}

static void claim_next(worker *w)
{
    w->front = FRONT_CLAIMING;
    db_submit(w, free_run(w), claim_run, claim_done);
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
    if (w->maintenance_in_flight || w->front == FRONT_STOPPING)
        return;
    w->maintenance_in_flight = 1;
    db_submit(w, NULL, maintenance_run, maintenance_done);
}

/* ---- signals and shutdown ------------------------------------------------- */

static void on_signal(uv_signal_t *handle, int signal_number)
{
    worker *w = handle->data;
    w->signals_seen++;
    const char *name = signal_number == SIGINT ? "SIGINT" : "SIGTERM";
    if (w->signals_seen == 1) {
        pf_wlog(PF_LOG_INFO, "draining", "worker=%s signal=%s state=%s", w->name, name,
                frames_held(w) > 0 ? "rendering" : "idle");
        if (w->front == FRONT_POLLING) {
            uv_timer_stop(&w->poll_timer);
            w->front = FRONT_NONE;
            go_on(w);
        }
    } else {
        pf_wlog(PF_LOG_WARN, "aborting", "worker=%s signal=%s", w->name, name);
        /* The render stops at its next stage boundary, and a task whose frames are still
         * being written is released once they are, instead of committed. */
        for (int i = 0; i < RUN_SLOTS; i++)
            if (w->runs[i].state == RUN_RENDERING || w->runs[i].state == RUN_WRITING)
                atomic_store(&w->runs[i].abort, 1);
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
    close_handle((uv_handle_t *)&w->written_async);
}

static void begin_shutdown(worker *w)
{
    if (w->front == FRONT_STOPPING)
        return;
    w->front = FRONT_STOPPING;
    uv_timer_stop(&w->poll_timer);
    uv_timer_stop(&w->lease_timer);
    uv_timer_stop(&w->maintenance_timer);
    db_submit(w, NULL, stop_run, stop_done);
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
    if (status == PF_OK)
        status = pf_frame_writer_start(frame_written, &w->writer, &err);
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
    pf_frame_writer_stop(w->writer);
    for (int i = 0; i < RUN_SLOTS; i++) {
        discard_outputs(&w->runs[i]);
        free(w->runs[i].log);
        pf_queue_job_clear(&w->runs[i].job);
    }
    pf_scene_destroy(w->scene);
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
    uv_mutex_init(&w->written_mutex);
    int code = open_everything(w);
    if (code != 0) {
        close_everything(w);
        uv_mutex_destroy(&w->written_mutex);
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
    uv_async_init(&w->loop, &w->written_async, on_written);
    w->written_async.data = w;
    for (int i = 0; i < RUN_SLOTS; i++)
        w->runs[i].owner = w;
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
    int64_t lease_period = w->lease_ms / 3 > 0 ? w->lease_ms / 3 : 1;
    uv_timer_start(&w->lease_timer, lease_tick, (uint64_t)lease_period, (uint64_t)lease_period);

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
    uv_mutex_destroy(&w->written_mutex);
    code = w->exit_code;
    free(w);
    pf_log_set_sink(NULL, NULL);
    return code;
}
