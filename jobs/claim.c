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

static pf_status claim_body(pf_queue *queue, void *context, pf_error *err)
{
    claim_context *ctx = context;
    int64_t now = pf_queue_now(queue);
    queue_stmt *stmt;
    pf_status status =
        queue_prepare(queue, "UPDATE workers SET heartbeat_at = ? WHERE id = ?", &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, now);
    queue_bind_int64(stmt, 2, ctx->worker_id);
    status = queue_step_done(queue, stmt, "claiming a task", err);
    if (status != PF_OK)
        return status;
    if (queue_changes(queue) == 0)
        return pf_error_set(err, PF_ERR_INVALID, "%s: no worker %lld (register it first)",
                            queue->path, (long long)ctx->worker_id);

    char token[PF_QUEUE_TOKEN_CHARS + 1];
    status = new_token(queue, token, err);
    if (status != PF_OK)
        return status;
    status = queue_prepare(
        queue,
        "UPDATE tasks SET status = 'running', attempt = attempt + 1, worker_id = :worker,"
        "  lease_token = :token, lease_expires = :now + :lease, started_at = :now,"
        "  finished_at = NULL "
        "WHERE id = ("
        /* The job first (few rows), then its first eligible task after the
         * affinity frame, else its first eligible task: both walk the
         * (job_id, status, first_frame) index instead of sorting every task. */
        "  WITH chosen (job_id, after_frame) AS ("
        "    SELECT j.id, CASE WHEN j.id = :job THEN :frame ELSE -1 END FROM jobs j"
        "    WHERE j.status IN ('queued', 'running')"
        "      AND NOT EXISTS (SELECT 1 FROM worker_blocks b"
        "                      WHERE b.job_id = j.id AND b.worker_id = :worker)"
        "      AND EXISTS (SELECT 1 FROM tasks e WHERE e.job_id = j.id"
        "                  AND e.status = 'queued' AND e.eligible_at <= :now)"
        "    ORDER BY j.priority DESC, j.id = :job DESC, j.id LIMIT 1)"
        "  SELECT coalesce("
        "    (SELECT t.id FROM chosen c JOIN tasks t ON t.job_id = c.job_id"
        "     WHERE t.status = 'queued' AND t.first_frame > c.after_frame"
        "       AND t.eligible_at <= :now ORDER BY t.first_frame LIMIT 1),"
        "    (SELECT t.id FROM chosen c JOIN tasks t ON t.job_id = c.job_id"
        "     WHERE t.status = 'queued' AND t.eligible_at <= :now"
        "     ORDER BY t.first_frame LIMIT 1))) "
        "RETURNING id, job_id, first_frame, last_frame, frame_step, frame_count, attempt,"
        "  lease_expires",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, queue_bind_index(stmt, ":worker"), ctx->worker_id);
    queue_bind_text(stmt, queue_bind_index(stmt, ":token"), token);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":now"), now);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":lease"),
                       queue->options.lease_ms);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":job"), ctx->preferred_job);
    queue_bind_int64(stmt, queue_bind_index(stmt, ":frame"), ctx->after_frame);
    int rc = queue_step(stmt);
    pf_queue_task task = {0};
    if (rc == QUEUE_ROW) {
        task.task_id = queue_column_int64(stmt, 0);
        task.job_id = queue_column_int64(stmt, 1);
        task.first_frame = (int)queue_column_int64(stmt, 2);
        task.last_frame = (int)queue_column_int64(stmt, 3);
        task.frame_step = (int)queue_column_int64(stmt, 4);
        task.frame_count = (int)queue_column_int64(stmt, 5);
        task.attempt = (int)queue_column_int64(stmt, 6);
        task.lease_expires = queue_column_int64(stmt, 7);
        memcpy(task.lease_token, token, sizeof token);
        rc = queue_step(stmt);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "claiming a task");
    queue_finalize(stmt);
    if (status != PF_OK || task.task_id == 0)
        return status;

    status = queue_prepare(queue, "UPDATE workers SET current_task_id = ? WHERE id = ?", &stmt,
                           err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, task.task_id);
    queue_bind_int64(stmt, 2, ctx->worker_id);
    status = queue_step_done(queue, stmt, "recording a worker's task", err);
    if (status == PF_OK)
        status = queue_prepare(
            queue, "UPDATE jobs SET started_at = coalesce(started_at, ?) WHERE id = ?", &stmt,
            err);
    if (status == PF_OK) {
        queue_bind_int64(stmt, 1, now);
        queue_bind_int64(stmt, 2, task.job_id);
        status = queue_step_done(queue, stmt, "marking a job started", err);
    }
    if (status == PF_OK)
        status = queue_job_refresh(queue, task.job_id, err);
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
    pf_status status = queue_write(queue, "claiming a task", claim_body, &ctx, err);
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
    bool repeated;
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
    pf_status status = queue_write(queue, "renewing a lease", heartbeat_body, &ctx, err);
    if (status == PF_OK && lease_expires)
        *lease_expires = ctx.lease_expires;
    return status;
}

/* ---- complete ---- */

static pf_status check_stage_row(pf_queue *queue, const leased_task *task,
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
    if (!row->stage || !*row->stage || strlen(row->stage) >= PF_QUEUE_STAGE_NAME_MAX)
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu: stage name must be 1 to %d bytes", queue->path,
                            index, PF_QUEUE_STAGE_NAME_MAX - 1);
    if (!(row->wall_ms >= 0) || !isfinite(row->wall_ms) || !isfinite(row->gpu_ms))
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s: stage row %zu (%s): wall time %g ms / gpu time %g ms is not a "
                            "valid duration",
                            queue->path, index, row->stage, row->wall_ms, row->gpu_ms);
    return PF_OK;
}

/* Parameters per stage row of the completion's INSERT. */
#define STAGE_COLUMNS 10

static pf_status complete_body(pf_queue *queue, void *context, pf_error *err)
{
    token_context *ctx = context;
    leased_task task;
    pf_status status = find_lease(queue, ctx->token, &task, err);
    if (status != PF_OK)
        return status;
    if (task.found && !strcmp(task.status, "done")) {
        ctx->repeated = true;
        return PF_OK;
    }
    if (!task.found || strcmp(task.status, "running") != 0)
        return lease_lost(queue, ctx->token, err);

    /* Every row checked first, then all of them in one statement (one round trip). */
    for (size_t i = 0; i < ctx->row_count && status == PF_OK; i++) {
        const pf_queue_stage_row *row = &ctx->rows[i];
        status = check_stage_row(queue, &task, row, i, err);
        cJSON *counters = status == PF_OK && row->counters_json
                              ? cJSON_ParseWithOpts(row->counters_json, NULL, 1)
                              : NULL;
        if (status == PF_OK && row->counters_json && !counters)
            status = pf_error_set(err, PF_ERR_INVALID,
                                  "%s: stage row %zu (%s): counters are not valid JSON: %s",
                                  queue->path, i, row->stage, row->counters_json);
        cJSON_Delete(counters);
    }
    queue_stmt *stmt = NULL;
    bool rows = ctx->row_count > 0;
    if (status == PF_OK && rows)
        status = queue_prepare_rows(queue,
                                    "INSERT INTO stage_timings (task_id, attempt, frame, stage, "
                                    "wall_ms, gpu_ms, counters, skipped, reason, build) VALUES ",
                                    "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", ctx->row_count, &stmt, err);
    for (size_t i = 0; status == PF_OK && rows && i < ctx->row_count; i++) {
        const pf_queue_stage_row *row = &ctx->rows[i];
        int base = (int)(i * STAGE_COLUMNS);
        queue_bind_int64(stmt, base + 1, task.task_id);
        queue_bind_int64(stmt, base + 2, task.attempt);
        queue_bind_int64(stmt, base + 3, row->frame);
        queue_bind_text(stmt, base + 4, row->stage);
        queue_bind_double(stmt, base + 5, row->wall_ms);
        if (row->gpu_ms >= 0)
            queue_bind_double(stmt, base + 6, row->gpu_ms);
        queue_bind_text(stmt, base + 7, row->counters_json);
        queue_bind_int64(stmt, base + 8, row->skipped);
        queue_bind_text(stmt, base + 9, row->reason);
        queue_bind_text(stmt, base + 10, row->build);
    }
    if (status == PF_OK && rows)
        status = queue_step_done(queue, stmt, "inserting the stage rows", err);
    if (status != PF_OK)
        return status;

    status = queue_prepare(queue,
                           "UPDATE tasks SET status = 'done', lease_expires = NULL, "
                           "finished_at = ? WHERE id = ?",
                           &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_int64(stmt, 2, task.task_id);
    status = queue_step_done(queue, stmt, "completing a task", err);
    if (status == PF_OK)
        status = queue_clear_worker_task(queue, task.task_id, err);
    if (status == PF_OK)
        status = queue_job_refresh(queue, task.job_id, err);
    return status;
}

pf_status pf_queue_complete(pf_queue *queue, const char *token, const pf_queue_stage_row *rows,
                            size_t row_count, bool *repeated, pf_error *err)
{
    token_context ctx = {.token = token, .rows = rows, .row_count = row_count};
    pf_status status = queue_write(queue, "completing a task", complete_body, &ctx, err);
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
