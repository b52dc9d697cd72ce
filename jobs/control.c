/* Job control from the user: cancel, pause, resume, retry, priority. */
#include "queue_internal.h"

#include <string.h>

typedef struct control_context {
    int64_t job_id;
    int64_t requeued; /* retry: tasks requeued */
    int priority;     /* priority: the new one */
} control_context;

static pf_status run_job_sql(pf_queue *queue, const char *sql, int64_t job_id, const char *what,
                             pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, sql, &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    if (queue_bind_count(stmt) >= 2)
        queue_bind_int64(stmt, 2, pf_queue_now(queue));
    return queue_step_done(queue, stmt, what, err);
}

static pf_status cancel_body(pf_queue *queue, void *context, pf_error *err)
{
    control_context *ctx = context;
    char current[16];
    pf_status status = queue_job_require(queue, ctx->job_id, current, sizeof current, err);
    if (status != PF_OK || !strcmp(current, "canceled"))
        return status;
    if (!strcmp(current, "done"))
        return pf_error_set(err, PF_ERR_INVALID, "%s: job %lld is already done", queue->path,
                            (long long)ctx->job_id);
    status = run_job_sql(queue,
                         "UPDATE workers SET current_task_id = NULL WHERE current_task_id IN "
                         "(SELECT id FROM tasks WHERE job_id = ?1 AND status = 'running')",
                         ctx->job_id, "canceling a job", err);
    /* Revoking the token is what stops running workers: their next heartbeat
     * or completion finds no lease. */
    if (status == PF_OK)
        status = run_job_sql(queue,
                             "UPDATE tasks SET status = 'canceled', lease_token = NULL, "
                             "lease_expires = NULL, finished_at = ?2 "
                             "WHERE job_id = ?1 AND status IN ('queued', 'running')",
                             ctx->job_id, "canceling a job", err);
    if (status == PF_OK)
        status = run_job_sql(queue,
                             "UPDATE jobs SET status = 'canceled', updated_at = ?2 WHERE id = ?1",
                             ctx->job_id, "canceling a job", err);
    return status;
}

static pf_status pause_body(pf_queue *queue, void *context, pf_error *err)
{
    control_context *ctx = context;
    char current[16];
    pf_status status = queue_job_require(queue, ctx->job_id, current, sizeof current, err);
    if (status != PF_OK)
        return status;
    if (strcmp(current, "queued") && strcmp(current, "running"))
        return pf_error_set(err, PF_ERR_INVALID, "%s: job %lld is %s; only a queued or running "
                            "job can be paused",
                            queue->path, (long long)ctx->job_id, current);
    return run_job_sql(queue, "UPDATE jobs SET status = 'paused', updated_at = ?2 WHERE id = ?1",
                       ctx->job_id, "pausing a job", err);
}

static pf_status resume_body(pf_queue *queue, void *context, pf_error *err)
{
    control_context *ctx = context;
    char current[16];
    pf_status status = queue_job_require(queue, ctx->job_id, current, sizeof current, err);
    if (status != PF_OK)
        return status;
    if (strcmp(current, "paused"))
        return pf_error_set(err, PF_ERR_INVALID, "%s: job %lld is %s, not paused", queue->path,
                            (long long)ctx->job_id, current);
    /* 'queued' is only a starting point: the refresh derives the real status. */
    status = run_job_sql(queue,
                         "UPDATE jobs SET status = 'queued', pause_reason = NULL, updated_at = ?2 "
                         "WHERE id = ?1",
                         ctx->job_id, "resuming a job", err);
    if (status == PF_OK)
        status = queue_job_refresh(queue, ctx->job_id, err);
    return status;
}

static pf_status retry_body(pf_queue *queue, void *context, pf_error *err)
{
    control_context *ctx = context;
    char current[16];
    pf_status status = queue_job_require(queue, ctx->job_id, current, sizeof current, err);
    if (status != PF_OK)
        return status;
    status = run_job_sql(queue,
                         "UPDATE tasks SET status = 'queued', attempt = 0, eligible_at = ?2, "
                         "worker_id = NULL, lease_token = NULL, lease_expires = NULL, "
                         "started_at = NULL, finished_at = NULL "
                         "WHERE job_id = ?1 AND status IN ('failed', 'canceled')",
                         ctx->job_id, "retrying a job", err);
    if (status != PF_OK)
        return status;
    ctx->requeued = queue_changes(queue);
    status = run_job_sql(queue, "DELETE FROM worker_blocks WHERE job_id = ?1",
                         ctx->job_id, "retrying a job", err);
    /* Failures so far stay on record but stop counting towards new blocks. */
    if (status == PF_OK)
        status = run_job_sql(
            queue,
            "UPDATE jobs SET updated_at = ?2, status = CASE status WHEN 'paused' THEN 'paused' "
            "ELSE 'queued' END, block_failures_after = (SELECT coalesce(max(id), 0) FROM "
            "task_failures) WHERE id = ?1",
            ctx->job_id, "retrying a job", err);
    /* Requeued tasks of a job that waits for others wait again until those are done. */
    if (status == PF_OK)
        status = queue_dependencies_hold(queue, ctx->job_id, err);
    if (status == PF_OK)
        status = queue_job_refresh(queue, ctx->job_id, err);
    return status;
}

pf_status pf_queue_cancel(pf_queue *queue, int64_t job_id, pf_error *err)
{
    control_context ctx = {job_id, 0};
    return queue_write(queue, "canceling a job", cancel_body, &ctx, err);
}

pf_status pf_queue_pause(pf_queue *queue, int64_t job_id, pf_error *err)
{
    control_context ctx = {job_id, 0};
    return queue_write(queue, "pausing a job", pause_body, &ctx, err);
}

pf_status pf_queue_resume(pf_queue *queue, int64_t job_id, pf_error *err)
{
    control_context ctx = {job_id, 0};
    return queue_write(queue, "resuming a job", resume_body, &ctx, err);
}

pf_status pf_queue_retry(pf_queue *queue, int64_t job_id, int64_t *requeued, pf_error *err)
{
    control_context ctx = {job_id, 0};
    pf_status status = queue_write(queue, "retrying a job", retry_body, &ctx, err);
    if (requeued)
        *requeued = status == PF_OK ? ctx.requeued : 0;
    return status;
}

static pf_status priority_body(pf_queue *queue, void *context, pf_error *err)
{
    control_context *ctx = context;
    pf_status status = queue_job_require(queue, ctx->job_id, NULL, 0, err);
    queue_stmt *stmt;
    if (status == PF_OK)
        status = queue_prepare(queue, "UPDATE jobs SET priority = ?, updated_at = ? WHERE id = ?",
                               &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->priority);
    queue_bind_int64(stmt, 2, pf_queue_now(queue));
    queue_bind_int64(stmt, 3, ctx->job_id);
    return queue_step_done(queue, stmt, "setting a job's priority", err);
}

pf_status pf_queue_set_priority(pf_queue *queue, int64_t job_id, int priority, pf_error *err)
{
    if (priority < -PF_QUEUE_PRIORITY_MAX || priority > PF_QUEUE_PRIORITY_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "priority %d: expected %d to %d", priority,
                            -PF_QUEUE_PRIORITY_MAX, PF_QUEUE_PRIORITY_MAX);
    control_context ctx = {.job_id = job_id, .priority = priority};
    return queue_write(queue, "setting a job's priority", priority_body, &ctx, err);
}
