/* Leases: claim, heartbeat, complete, fail, release — each fenced by the token. */
#include "queue_internal.h"

#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/random.h>
#include <unistd.h>

#define TOKEN_BYTES (PF_QUEUE_TOKEN_CHARS / 2)

/* 128 bits from the kernel: per-process PRNGs (SQLite's randomblob included)
 * may repeat across fork(), and two leases must never share a token. */
static pf_status new_token(pf_queue *queue, char token[PF_QUEUE_TOKEN_CHARS + 1], pf_error *err)
{
    unsigned char bytes[TOKEN_BYTES];
    size_t got = 0;
    while (got < sizeof bytes) {
        ssize_t n = getrandom(bytes + got, sizeof bytes - got, 0);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return pf_error_set(err, PF_ERR_IO, "%s: no random bytes for a lease token: %s",
                                queue->path, strerror(errno));
        got += (size_t)n;
    }
    for (size_t i = 0; i < sizeof bytes; i++)
        snprintf(token + 2 * i, 3, "%02x", bytes[i]);
    return PF_OK;
}

static pf_status lease_lost(pf_queue *queue, const char *token, pf_error *err)
{
    return pf_error_set(err, PF_ERR_INVALID,
                        "%s: lease lost: token %.8s... is not the lease of a running task "
                        "(expired and reaped, canceled, or taken over)",
                        queue->path, token ? token : "");
}

/* The task a token leases, whatever its status. */
typedef struct leased_task {
    bool found;
    int64_t task_id, job_id;
    char status[16];
    int attempt;
    int32_t first_frame, last_frame, frame_step;
} leased_task;

static pf_status find_lease(pf_queue *queue, const char *token, leased_task *task, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "SELECT id, job_id, status, attempt, first_frame, "
                                     "last_frame, frame_step FROM tasks WHERE lease_token = ?",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_text(stmt, 1, token ? token : "");
    int rc = queue_step(stmt);
    task->found = rc == QUEUE_ROW;
    if (task->found) {
        task->task_id = queue_column_int64(stmt, 0);
        task->job_id = queue_column_int64(stmt, 1);
        queue_copy_text(task->status, sizeof task->status, queue_column_text(stmt, 2));
        task->attempt = (int)queue_column_int64(stmt, 3);
        task->first_frame = (int)queue_column_int64(stmt, 4);
        task->last_frame = (int)queue_column_int64(stmt, 5);
        task->frame_step = (int)queue_column_int64(stmt, 6);
    } else if (rc != QUEUE_DONE) {
        status = queue_db_error(queue, err, "looking up a lease");
    }
    queue_finalize(stmt);
    return status;
}

static pf_status find_running_lease(pf_queue *queue, const char *token, leased_task *task,
                                    pf_error *err)
{
    pf_status status = find_lease(queue, token, task, err);
    if (status == PF_OK && (!task->found || strcmp(task->status, "running") != 0))
        status = lease_lost(queue, token, err);
    return status;
}

/* ---- claim ---- */

typedef struct claim_context {
    int64_t worker_id, preferred_job;
    int32_t after_frame;
    pf_queue_task *out;
    bool claimed;
} claim_context;

/*
 * The claim: the highest-priority job this worker may render (not blocked for
 * it, and whose requirements its registered capabilities meet:
 * QUEUE_WORKER_MEETS), then its first eligible task after the affinity frame
 * (a task that waits for other jobs is not eligible: dependencies.c holds it),
 * else its first eligible task. The
 * job is picked once (the CTE) and reaches the task picks as scalars, so each
 * is a walk of the (job_id, status, first_frame) index that stops at its first
 * row; joining the CTE instead made PostgreSQL fetch and sort every queued
 * task of the job on each claim. For the same reason the job's test for an
 * eligible task is an ordered LIMIT 1, not an EXISTS: PostgreSQL planned the
 * EXISTS as a scan of every 'queued' entry of the status index, dead ones of
 * claimed tasks included until a vacuum. An unregistered worker claims
 * nothing (and is told so by its caller). LOCK is empty on SQLite (one writer
 * at a time); on PostgreSQL claims run side by side, and each takes the first
 * task no other claim holds.
 */
#define CLAIM_UPDATE(LOCK)                                                                      \
    "UPDATE tasks SET status = 'running', attempt = attempt + 1, worker_id = :worker,"         \
    "  lease_token = :token, lease_expires = :now + :lease, started_at = :now,"                \
    "  finished_at = NULL "                                                                    \
    "WHERE EXISTS (SELECT 1 FROM workers w WHERE w.id = :worker) AND id = ("                   \
    "  WITH chosen (job_id, after_frame) AS ("                                                 \
    "    SELECT j.id, CASE WHEN j.id = :job THEN :frame ELSE -1 END FROM jobs j"               \
    "    JOIN workers w ON w.id = :worker"                                                     \
    "    WHERE j.status IN ('queued', 'running') AND " QUEUE_WORKER_MEETS("j", "w")            \
    "      AND NOT EXISTS (SELECT 1 FROM worker_blocks b"                                      \
    "                      WHERE b.job_id = j.id AND b.worker_id = :worker)"                   \
    "      AND (SELECT e.first_frame FROM tasks e WHERE e.job_id = j.id"                       \
    "           AND e.status = 'queued' AND e.eligible_at <= :now"                             \
    "           ORDER BY e.first_frame LIMIT 1) IS NOT NULL"                                   \
    "    ORDER BY j.priority DESC, j.id = :job DESC, j.id LIMIT 1)"                            \
    "  SELECT coalesce("                                                                       \
    "    (SELECT t.id FROM tasks t WHERE t.job_id = (SELECT job_id FROM chosen)"               \
    "       AND t.status = 'queued' AND t.first_frame > (SELECT after_frame FROM chosen)"      \
    "       AND t.eligible_at <= :now ORDER BY t.first_frame LIMIT 1" LOCK "),"                \
    "    (SELECT t.id FROM tasks t WHERE t.job_id = (SELECT job_id FROM chosen)"               \
    "       AND t.status = 'queued' AND t.eligible_at <= :now"                                 \
    "     ORDER BY t.first_frame LIMIT 1" LOCK "))) "                                          \
    "RETURNING id, job_id, first_frame, last_frame, frame_step, frame_count, attempt,"         \
    "  lease_expires"

/*
 * SQLite: the claim returns whether the job starts with it; the worker's
 * heartbeat and the job's start follow in the same (exclusive) transaction.
 */
#define CLAIM_SQLITE                                                                            \
    CLAIM_UPDATE("") ", (SELECT j.started_at IS NULL OR j.status <> 'running'"                 \
                     "   FROM jobs j WHERE j.id = tasks.job_id)"

/*
 * PostgreSQL: the claim, the worker's heartbeat and the job's start in one
 * statement (data-modifying CTEs, which SQLite lacks), sent with BEGIN and
 * COMMIT in one round trip: a claim holds its task's row lock only while the
 * server runs it, never while its client waits for the CPU. One row always;
 * its last column counts the worker rows updated (0: no such worker).
 */
#define CLAIM_POSTGRES                                                                          \
    "WITH claimed AS (" CLAIM_UPDATE(" FOR UPDATE OF t SKIP LOCKED") "),"                      \
    "  beat AS (UPDATE workers SET heartbeat_at = :now,"                                       \
    "    current_task_id = coalesce((SELECT id FROM claimed), current_task_id)"                \
    "    WHERE id = :worker RETURNING id),"                                                    \
    "  started AS (UPDATE jobs SET started_at = coalesce(started_at, :now),"                   \
    "    status = 'running', updated_at = :now WHERE id = (SELECT job_id FROM claimed)"        \
    "    AND (started_at IS NULL OR status <> 'running') RETURNING id) "                       \
    "SELECT c.id, c.job_id, c.first_frame, c.last_frame, c.frame_step, c.frame_count,"         \
    "  c.attempt, c.lease_expires, (SELECT count(*) FROM beat) "                               \
    "FROM (SELECT 1) AS one LEFT JOIN claimed c ON true"

/* The claim statement: the task (task_id 0 when none was free), and column 8
 * as the engine's variant says. */
static pf_status claim_task(pf_queue *queue, const claim_context *ctx, int64_t now,
                            pf_queue_task *task, int64_t *extra, pf_error *err)
{
    char token[PF_QUEUE_TOKEN_CHARS + 1];
    pf_status status = new_token(queue, token, err);
    if (status != PF_OK)
        return status;
    queue_stmt *stmt;
    status = queue_prepare(queue, queue_sql(queue, CLAIM_SQLITE, CLAIM_POSTGRES), &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, queue_bind_index(stmt, ":worker"), ctx->worker_id);
    queue_bind_text(stmt, queue_bind_index(stmt, ":token"), token);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":now"), now);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":lease"), queue->options.lease_ms);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":job"), ctx->preferred_job);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":frame"), ctx->after_frame);
    int rc = queue_step(stmt);
    if (rc == QUEUE_ROW) {
        task->task_id = queue_column_int64(stmt, 0); /* NULL (0) on PostgreSQL when none */
        task->job_id = queue_column_int64(stmt, 1);
        task->first_frame = (int)queue_column_int64(stmt, 2);
        task->last_frame = (int)queue_column_int64(stmt, 3);
        task->frame_step = (int)queue_column_int64(stmt, 4);
        task->frame_count = (int)queue_column_int64(stmt, 5);
        task->attempt = (int)queue_column_int64(stmt, 6);
        task->lease_expires = queue_column_int64(stmt, 7);
        *extra = queue_column_int64(stmt, 8);
        memcpy(task->lease_token, token, sizeof token);
        rc = queue_step(stmt);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "claiming a task");
    queue_finalize(stmt);
    return status;
}

static pf_status no_worker(pf_queue *queue, int64_t worker_id, pf_error *err)
{
    return pf_error_set(err, PF_ERR_INVALID, "%s: no worker %lld (register it first)",
                        queue->path, (long long)worker_id);
}

static pf_status claim_body_postgres(pf_queue *queue, void *context, pf_error *err)
{
    claim_context *ctx = context;
    pf_queue_task task = {0};
    int64_t workers = 0;
    /* Nothing to roll back after it: without its worker row the claim takes
     * no task, so a missing worker commits nothing. */
    queue_commit_with_next(queue);
    pf_status status = claim_task(queue, ctx, pf_queue_now(queue), &task, &workers, err);
    if (status == PF_OK && workers == 0)
        status = no_worker(queue, ctx->worker_id, err);
    if (status == PF_OK && task.task_id != 0) {
        *ctx->out = task;
        ctx->claimed = true;
    }
    return status;
}

static pf_status claim_body_sqlite(pf_queue *queue, void *context, pf_error *err)
{
    claim_context *ctx = context;
    int64_t now = pf_queue_now(queue);
    pf_queue_task task = {0};
    int64_t job_starts = 0;
    pf_status status = claim_task(queue, ctx, now, &task, &job_starts, err);
    if (status != PF_OK)
        return status;

    /* The worker's heartbeat, and its task when it got one. A worker that is
     * not registered rolls the claim back. */
    queue_stmt *stmt;
    status = queue_prepare(queue,
                           "UPDATE workers SET heartbeat_at = ?1,"
                           "  current_task_id = CASE WHEN ?2 > 0 THEN ?2 ELSE current_task_id END "
                           "WHERE id = ?3",
                           &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, now);
    queue_bind_int64(stmt, 2, task.task_id);
    queue_bind_int64(stmt, 3, ctx->worker_id);
    status = queue_step_done(queue, stmt, "claiming a task", err);
    if (status == PF_OK && queue_changes(queue) == 0)
        status = no_worker(queue, ctx->worker_id, err);
    if (status != PF_OK || task.task_id == 0)
        return status;
    if (job_starts) {
        /* A job with a task just claimed is running: the claim only picks
         * queued or running jobs, and one of its tasks now runs
         * (queue_job_refresh's rules). */
        status = queue_prepare(queue,
                               "UPDATE jobs SET started_at = coalesce(started_at, ?1),"
                               "  status = 'running', updated_at = ?1 WHERE id = ?2",
                               &stmt, err);
        if (status != PF_OK)
            return status;
        queue_bind_int64(stmt, 1, now);
        queue_bind_int64(stmt, 2, task.job_id);
        status = queue_step_done(queue, stmt, "marking a job started", err);
    }
    if (status == PF_OK) {
        *ctx->out = task;
        ctx->claimed = true;
    }
    return status;
}

pf_status pf_queue_claim(pf_queue *queue, int64_t worker_id, int64_t preferred_job,
                         int32_t after_frame, pf_queue_task *out, bool *claimed, pf_error *err)
{
    claim_context ctx = {worker_id, preferred_job, after_frame, out, false};
    *claimed = false;
    pf_status status = queue_write_lease(
        queue, "claiming a task", queue->pg ? claim_body_postgres : claim_body_sqlite, &ctx, err);
    if (status == PF_OK)
        *claimed = ctx.claimed;
    return status;
}

/* ---- heartbeat ---- */

typedef struct token_context {
    const char *token;
    int64_t lease_expires;
    const char *error_text;
    /* fail, fail_job, reject: what becomes of the failed task (lifecycle.c). */
    pf_status (*settle)(pf_queue *queue, int64_t task_id, const char *error_text, pf_error *err);
    const pf_queue_stage_row *rows;
    size_t row_count;
    const pf_queue_frame_resources *frames; /* complete: each frame's resources */
    size_t frame_count;
    bool repeated;
    int64_t job_id; /* complete: the task's job */
    int32_t first_frame, last_frame; /* complete: the task's frames */
} token_context;

static pf_status heartbeat_body(pf_queue *queue, void *context, pf_error *err)
{
    token_context *ctx = context;
    int64_t now = pf_queue_now(queue);
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "UPDATE tasks SET lease_expires = ?1 + ?2 "
                                     "WHERE lease_token = ?3 AND status = 'running' "
                                     "RETURNING worker_id, lease_expires",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, now);
    queue_bind_int64(stmt, 2, queue->options.lease_ms);
    queue_bind_text(stmt, 3, ctx->token);
    int rc = queue_step(stmt);
    bool renewed = rc == QUEUE_ROW;
    int64_t worker_id = renewed ? queue_column_int64(stmt, 0) : 0;
    if (renewed) {
        ctx->lease_expires = queue_column_int64(stmt, 1);
        rc = queue_step(stmt);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "renewing a lease");
    queue_finalize(stmt);
    if (status != PF_OK)
        return status;
    if (!renewed)
        return lease_lost(queue, ctx->token, err);

    status = queue_prepare(queue, "UPDATE workers SET heartbeat_at = ? WHERE id = ?", &stmt,
                           err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, now);
    queue_bind_int64(stmt, 2, worker_id);
    return queue_step_done(queue, stmt, "recording a worker heartbeat", err);
}

pf_status pf_queue_heartbeat(pf_queue *queue, const char *token, int64_t *lease_expires,
                             pf_error *err)
{
    token_context ctx = {.token = token};
    pf_status status = queue_write_lease(queue, "renewing a lease", heartbeat_body, &ctx, err);
    if (status == PF_OK && lease_expires)
        *lease_expires = ctx.lease_expires;
    return status;
}

/* ---- complete ---- */

/* What a stage row must be whatever its task: checked before any statement. */
static pf_status check_stage_values(pf_queue *queue, const pf_queue_stage_row *row, size_t index,
                                    pf_error *err)
{
    if (!row->stage || !*row->stage || strlen(row->stage) >= PF_QUEUE_STAGE_NAME_MAX)
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu: stage name must be 1 to %d bytes", queue->path,
                            index, PF_QUEUE_STAGE_NAME_MAX - 1);
    if (!(row->wall_ms >= 0) || !isfinite(row->wall_ms) || !isfinite(row->gpu_ms))
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu (%s): wall time %g ms / gpu time %g ms is not a "
                            "valid duration",
                            queue->path, index, row->stage, row->wall_ms, row->gpu_ms);
    cJSON *counters = row->counters_json ? cJSON_ParseWithOpts(row->counters_json, NULL, 1) : NULL;
    bool bad_json = row->counters_json && !counters;
    cJSON_Delete(counters);
    if (bad_json)
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu (%s): counters are not valid JSON: %s",
                            queue->path, index, row->stage, row->counters_json);
    return PF_OK;
}

/* A stage row's frame must be one of its task's. */
static pf_status check_stage_frame(pf_queue *queue, const leased_task *task,
                                   const pf_queue_stage_row *row, size_t index, pf_error *err)
{
    bool in_task = row->frame >= task->first_frame && row->frame <= task->last_frame &&
                   (row->frame - task->first_frame) % task->frame_step == 0;
    if (!in_task)
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu: frame %d is not one of task %lld's frames "
                            "(%d-%d step %d)",
                            queue->path, index, row->frame, (long long)task->task_id,
                            task->first_frame, task->last_frame, task->frame_step);
    return PF_OK;
}

/*
 * The completion's statement: marks the token's running task done (first,
 * so that on PostgreSQL it holds the task's row from the start). On
 * PostgreSQL the same statement clears the worker's task and writes the
 * stage rows whose frames are the task's (one round trip for all three);
 * SQLite, without data-modifying CTEs, runs those in complete_body.
 */
#define FINISH_UPDATE                                                                           \
    "UPDATE tasks SET status = 'done', lease_expires = NULL, finished_at = ?1 "                \
    "WHERE lease_token = ?2 AND status = 'running' "                                           \
    "RETURNING id, job_id, attempt, first_frame, last_frame, frame_step"
#define FINISH_POSTGRES_HEAD                                                                    \
    "WITH finished AS (" FINISH_UPDATE "),"                                                    \
    "  idle AS (UPDATE workers SET current_task_id = NULL"                                     \
    "    WHERE current_task_id = (SELECT id FROM finished))"
#define FINISH_POSTGRES_NO_ROWS FINISH_POSTGRES_HEAD " SELECT *, 0 FROM finished"
#define FINISH_POSTGRES_ROWS_HEAD                                                               \
    FINISH_POSTGRES_HEAD ","                                                                   \
    "  stages AS (INSERT INTO stage_timings (task_id, attempt, frame, stage, wall_ms, gpu_ms,"  \
    "    counters, skipped, reason, build)"                                                    \
    "    SELECT f.id, f.attempt, v.frame, v.stage, v.wall_ms, v.gpu_ms, v.counters,"           \
    "      v.skipped, v.reason, v.build FROM finished f, (VALUES "
/* Typed: a VALUES list would otherwise type an all-NULL column as text. */
#define FINISH_POSTGRES_ROW                                                                     \
    "(?::integer, ?::text, ?::double precision, ?::double precision, ?::text, ?::integer,"     \
    " ?::text, ?::text)"
#define FINISH_POSTGRES_ROWS_TAIL                                                               \
    ") AS v (frame, stage, wall_ms, gpu_ms, counters, skipped, reason, build)"                 \
    "    WHERE v.frame BETWEEN f.first_frame AND f.last_frame"                                 \
    "      AND (v.frame - f.first_frame) % f.frame_step = 0 RETURNING 1) "                     \
    "SELECT *, (SELECT count(*) FROM stages) FROM finished"
/* Parameters per stage row: of the PostgreSQL VALUES row, of SQLite's INSERT row. */
#define FINISH_ROW_COLUMNS 8
#define STAGE_COLUMNS 10

static void bind_stage_values(queue_stmt *stmt, int base, const pf_queue_stage_row *row)
{
    queue_bind_int64(stmt, base + 1, row->frame);
    queue_bind_text(stmt, base + 2, row->stage);
    queue_bind_double(stmt, base + 3, row->wall_ms);
    if (row->gpu_ms >= 0)
        queue_bind_double(stmt, base + 4, row->gpu_ms);
    queue_bind_text(stmt, base + 5, row->counters_json);
    queue_bind_int64(stmt, base + 6, row->skipped);
    queue_bind_text(stmt, base + 7, row->reason);
    queue_bind_text(stmt, base + 8, row->build);
}

/* *stored: the stage rows the statement wrote (always 0 on SQLite). */
static pf_status finish_lease(pf_queue *queue, const token_context *ctx, leased_task *task,
                              int64_t *stored, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status;
    bool rows_here = queue->pg && ctx->row_count > 0;
    if (rows_here)
        status = queue_prepare_rows(queue, FINISH_POSTGRES_ROWS_HEAD, FINISH_POSTGRES_ROW,
                                    ctx->row_count, FINISH_POSTGRES_ROWS_TAIL, &stmt, err);
    else
        status = queue_prepare(queue, queue_sql(queue, FINISH_UPDATE, FINISH_POSTGRES_NO_ROWS),
                               &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_text(stmt, 2, ctx->token);
    for (size_t i = 0; rows_here && i < ctx->row_count; i++)
        bind_stage_values(stmt, 2 + (int)i * FINISH_ROW_COLUMNS, &ctx->rows[i]);
    int rc = queue_step(stmt);
    task->found = rc == QUEUE_ROW;
    *stored = 0;
    if (task->found) {
        task->task_id = queue_column_int64(stmt, 0);
        task->job_id = queue_column_int64(stmt, 1);
        task->attempt = (int)queue_column_int64(stmt, 2);
        task->first_frame = (int)queue_column_int64(stmt, 3);
        task->last_frame = (int)queue_column_int64(stmt, 4);
        task->frame_step = (int)queue_column_int64(stmt, 5);
        if (queue->pg)
            *stored = queue_column_int64(stmt, 6);
        rc = queue_step(stmt);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "completing a task");
    queue_finalize(stmt);
    return status;
}

/* SQLite: the stage rows in one INSERT, then the worker's task cleared. */
static pf_status store_stage_rows(pf_queue *queue, const token_context *ctx,
                                  const leased_task *task, pf_error *err)
{
    pf_status status = PF_OK;
    if (ctx->row_count > 0) {
        queue_stmt *stmt;
        status = queue_prepare_rows(queue,
                                    "INSERT INTO stage_timings (task_id, attempt, frame, stage, "
                                    "wall_ms, gpu_ms, counters, skipped, reason, build) VALUES ",
                                    "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", ctx->row_count, "", &stmt,
                                    err);
        for (size_t i = 0; status == PF_OK && i < ctx->row_count; i++) {
            int base = (int)i * STAGE_COLUMNS;
            queue_bind_int64(stmt, base + 1, task->task_id);
            queue_bind_int64(stmt, base + 2, task->attempt);
            bind_stage_values(stmt, base + 2, &ctx->rows[i]);
        }
        if (status == PF_OK)
            status = queue_step_done(queue, stmt, "inserting the stage rows", err);
    }
    if (status == PF_OK)
        status = queue_clear_worker_task(queue, task->task_id, err);
    return status;
}

static pf_status complete_body(pf_queue *queue, void *context, pf_error *err)
{
    token_context *ctx = context;
    /* Every row checked (a bad one rolls the completion back), then all of
     * them in one statement (one round trip). */
    pf_status status = PF_OK;
    for (size_t i = 0; i < ctx->row_count && status == PF_OK; i++)
        status = check_stage_values(queue, &ctx->rows[i], i, err);
    if (status != PF_OK)
        return status;
    leased_task task;
    int64_t stored = 0;
    status = finish_lease(queue, ctx, &task, &stored, err);
    if (status != PF_OK)
        return status;
    if (!task.found) {
        /* Done already (a retried completion whose commit went through), or lost. */
        status = find_lease(queue, ctx->token, &task, err);
        if (status != PF_OK)
            return status;
        ctx->job_id = task.job_id;
        ctx->first_frame = task.first_frame;
        ctx->last_frame = task.last_frame;
        if (task.found && !strcmp(task.status, "done")) {
            ctx->repeated = true;
            return PF_OK;
        }
        return lease_lost(queue, ctx->token, err);
    }
    ctx->job_id = task.job_id;
    ctx->first_frame = task.first_frame;
    ctx->last_frame = task.last_frame;
    for (size_t i = 0; i < ctx->row_count && status == PF_OK; i++)
        status = check_stage_frame(queue, &task, &ctx->rows[i], i, err);
    if (status == PF_OK && ctx->frame_count > 0)
        status = queue_frame_resources_store(queue, task.task_id, task.attempt, task.first_frame,
                                             task.last_frame, task.frame_step, ctx->frames,
                                             ctx->frame_count, err);
    if (status != PF_OK)
        return status;
    if (!queue->pg)
        return store_stage_rows(queue, ctx, &task, err);
    if (stored != (int64_t)ctx->row_count) /* the frames were checked: cannot happen */
        return pf_error_set(err, PF_ERR_IO, "%s: completing a task: %lld of %zu stage rows stored",
                            queue->path, (long long)stored, ctx->row_count);
    return PF_OK;
}

/* The completed task's job: its status derived from its tasks; then, when jobs wait for
 * it, their tasks this completion unblocked released (after the status: a job that has
 * just become done releases its dependents' tasks). */
static pf_status complete_settle(pf_queue *queue, void *context, pf_error *err)
{
    const token_context *ctx = context;
    bool dependents = false;
    pf_status status = queue_job_refresh_with(queue, ctx->job_id, &dependents, err);
    if (status == PF_OK && dependents)
        status = queue_dependents_release(queue, ctx->job_id, ctx->first_frame,
                                          ctx->last_frame, err);
    return status;
}

pf_status pf_queue_complete(pf_queue *queue, const char *token, const pf_queue_stage_row *rows,
                            size_t row_count, bool *repeated, pf_error *err)
{
    return pf_queue_complete_frames(queue, token, rows, row_count, NULL, 0, repeated, err);
}

pf_status pf_queue_complete_frames(pf_queue *queue, const char *token,
                                   const pf_queue_stage_row *rows, size_t row_count,
                                   const pf_queue_frame_resources *frames, size_t frame_count,
                                   bool *repeated, pf_error *err)
{
    token_context ctx = {.token = token, .rows = rows, .row_count = row_count,
                         .frames = frames, .frame_count = frame_count};
    /*
     * Completions running side by side (PostgreSQL) would each derive the
     * job's status without seeing the others' uncommitted tasks: the last two
     * of a job would each leave it running. So the status is derived as the
     * completion settles, after its commit there; the one that commits last
     * then sees every task finished. A retried completion (repeated) settles
     * too, in case the first lost its connection between the two.
     */
    pf_status status = queue_write_lease_settled(queue, "completing a task", complete_body,
                                                 complete_settle, &ctx, err);
    if (repeated)
        *repeated = status == PF_OK && ctx.repeated;
    return status;
}

/* ---- fail, fail_job, reject ---- */

static pf_status failure_body(pf_queue *queue, void *context, pf_error *err)
{
    token_context *ctx = context;
    leased_task task;
    pf_status status = find_running_lease(queue, ctx->token, &task, err);
    if (status == PF_OK)
        status = ctx->settle(queue, task.task_id, ctx->error_text, err);
    return status;
}

static pf_status record_task_failure(pf_queue *queue, const char *token, const char *error_text,
                                     pf_status (*settle)(pf_queue *, int64_t, const char *,
                                                         pf_error *),
                                     const char *what, pf_error *err)
{
    token_context ctx = {.token = token,
                         .error_text = error_text && *error_text ? error_text : "(no message)",
                         .settle = settle};
    return queue_write(queue, what, failure_body, &ctx, err);
}

pf_status pf_queue_fail(pf_queue *queue, const char *token, const char *error_text,
                        pf_error *err)
{
    return record_task_failure(queue, token, error_text, queue_task_attempt_failed,
                               "recording a task failure", err);
}

pf_status pf_queue_fail_job(pf_queue *queue, const char *token, const char *error_text,
                            pf_error *err)
{
    return record_task_failure(queue, token, error_text, queue_task_job_fault,
                               "recording the job's failure", err);
}

pf_status pf_queue_reject(pf_queue *queue, const char *token, const char *error_text,
                          pf_error *err)
{
    return record_task_failure(queue, token, error_text, queue_task_reject, "rejecting a task",
                               err);
}

/* ---- release ---- */

static pf_status release_body(pf_queue *queue, void *context, pf_error *err)
{
    token_context *ctx = context;
    leased_task task;
    pf_status status = find_running_lease(queue, ctx->token, &task, err);
    if (status != PF_OK)
        return status;
    queue_stmt *stmt;
    status = queue_prepare(queue,
                           "UPDATE tasks SET status = 'queued', attempt = attempt - 1, "
                           "lease_token = NULL, lease_expires = NULL, worker_id = NULL, "
                           "started_at = NULL, eligible_at = ? WHERE id = ?",
                           &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_int64(stmt, 2, task.task_id);
    status = queue_step_done(queue, stmt, "releasing a task", err);
    if (status == PF_OK)
        status = queue_clear_worker_task(queue, task.task_id, err);
    if (status == PF_OK)
        status = queue_job_refresh(queue, task.job_id, err);
    return status;
}

pf_status pf_queue_release(pf_queue *queue, const char *token, pf_error *err)
{
    token_context ctx = {.token = token};
    return queue_write(queue, "releasing a task", release_body, &ctx, err);
}
