/*
 * Task and job state transitions shared by several calls: a counted failed
 * attempt (fail, reap) and deriving a job's status from its tasks.
 */
#include "queue_internal.h"

#include <string.h>

/* Doubling stops mattering long before 2^40: the cap is reached first. */
#define QUEUE_BACKOFF_MAX_DOUBLINGS 40

static int64_t backoff_ms(const pf_queue_options *options, int attempt)
{
    int doublings = attempt > 1 ? attempt - 1 : 0;
    if (doublings >= QUEUE_BACKOFF_MAX_DOUBLINGS)
        return options->backoff_cap_ms;
    int64_t delay = options->backoff_base_ms;
    for (int i = 0; i < doublings && delay < options->backoff_cap_ms; i++)
        delay *= 2;
    return delay < options->backoff_cap_ms ? delay : options->backoff_cap_ms;
}

pf_status queue_job_require(pf_queue *queue, int64_t job_id, char *status_text,
                            size_t status_size, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, "SELECT status FROM jobs WHERE id = ?", &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    int rc = queue_step(stmt);
    if (rc == QUEUE_ROW) {
        if (status_text)
            queue_copy_text(status_text, status_size, queue_column_text(stmt, 0));
    } else if (rc == QUEUE_DONE) {
        status = pf_error_set(err, PF_ERR_INVALID, "%s: no job %lld", queue->path,
                              (long long)job_id);
    } else {
        status = queue_db_error(queue, err, "looking up a job");
    }
    queue_finalize(stmt);
    return status;
}

/* A refresh that loses its compare-and-set to a concurrent one reads again; on
 * SQLite (one writer) it never loses. */
#define QUEUE_REFRESH_TRIES 8

pf_status queue_job_refresh(pf_queue *queue, int64_t job_id, pf_error *err)
{
    return queue_job_refresh_with(queue, job_id, NULL, err);
}

pf_status queue_job_refresh_with(pf_queue *queue, int64_t job_id, bool *dependents,
                                 pf_error *err)
{
    /* EXISTS probes on (job_id, status) instead of counting every task: this
     * runs after each completion and failure, and a job may have 100,000 tasks.
     * The order of the cases is the precedence of the states. */
    static const char derive_sql[] =
        "SELECT j.status, CASE"
        "  WHEN j.status = 'canceled' THEN 'canceled'"
        "  WHEN EXISTS (SELECT 1 FROM tasks t WHERE t.job_id = j.id)"
        "   AND NOT EXISTS (SELECT 1 FROM tasks t WHERE t.job_id = j.id"
        "                   AND t.status IN ('queued', 'running', 'failed', 'canceled'))"
        "   THEN 'done'"
        "  WHEN j.status = 'paused' THEN 'paused'"
        "  WHEN EXISTS (SELECT 1 FROM tasks t WHERE t.job_id = j.id AND t.status = 'failed')"
        "   AND NOT EXISTS (SELECT 1 FROM tasks t WHERE t.job_id = j.id"
        "                   AND t.status IN ('queued', 'running'))"
        "   THEN 'failed'"
        "  WHEN j.started_at IS NOT NULL THEN 'running'"
        "  ELSE 'queued' END, j.dependents "
        "FROM jobs j WHERE j.id = ?";
    for (int attempt = 0; attempt < QUEUE_REFRESH_TRIES; attempt++) {
        queue_stmt *stmt;
        pf_status status = queue_prepare(queue, derive_sql, &stmt, err);
        if (status != PF_OK)
            return status;
        queue_bind_int64(stmt, 1, job_id);
        if (queue_step(stmt) != QUEUE_ROW) {
            status = queue_db_error(queue, err, "deriving a job's status");
            queue_finalize(stmt);
            return status;
        }
        char current[16], next[16];
        queue_copy_text(current, sizeof current, queue_column_text(stmt, 0));
        queue_copy_text(next, sizeof next, queue_column_text(stmt, 1));
        if (dependents)
            *dependents = queue_column_int64(stmt, 2) != 0;
        queue_finalize(stmt);
        if (!strcmp(current, next))
            return PF_OK;

        /* Only from the status read: on PostgreSQL a concurrent completion may
         * have changed it since, and then its view is the newer one to derive from. */
        status = queue_prepare(queue,
                               "UPDATE jobs SET status = ?, updated_at = ? "
                               "WHERE id = ? AND status = ?",
                               &stmt, err);
        if (status != PF_OK)
            return status;
        queue_bind_text(stmt, 1, next);
        queue_bind_int64(stmt, 2, pf_queue_now(queue));
        queue_bind_int64(stmt, 3, job_id);
        queue_bind_text(stmt, 4, current);
        status = queue_step_done(queue, stmt, "updating a job's status", err);
        if (status != PF_OK || queue_changes(queue) > 0)
            return status;
    }
    return pf_error_set(err, PF_ERR_IO,
                        "%s: job %lld's status kept changing under %d tries to derive it",
                        queue->path, (long long)job_id, QUEUE_REFRESH_TRIES);
}

/* Blocks worker_id for job_id once it has failed block_after_failures
 * distinct tasks of the job since the job's last retry. */
static pf_status apply_blocklist(pf_queue *queue, int64_t job_id, int64_t worker_id,
                                 pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "INSERT INTO worker_blocks (job_id, worker_id, blocked_at) "
        "SELECT ?1, ?2, ?3 WHERE ("
        "  SELECT count(DISTINCT f.task_id) FROM task_failures f"
        "  JOIN tasks t ON t.id = f.task_id JOIN jobs j ON j.id = t.job_id"
        "  WHERE t.job_id = ?1 AND f.worker_id = ?2 AND f.id > j.block_failures_after"
        "  AND f.job_fault = 0) >= ?4 ON CONFLICT DO NOTHING",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    queue_bind_int64(stmt, 2, worker_id);
    queue_bind_int64(stmt, 3, pf_queue_now(queue));
    queue_bind_int64(stmt, 4, queue->options.block_after_failures);
    return queue_step_done(queue, stmt, "blocking a worker for a job", err);
}

/* What a failing task's row says about it: its attempt, job, worker and the job's limit. */
typedef struct failing_task {
    int attempt, max_attempts;
    int64_t job_id, worker_id;
    bool has_worker;
    char worker_name[PF_QUEUE_NAME_MAX];
} failing_task;

/* Reads task_id's row and adds its task_failures row (job_fault: the job's, not the worker's). */
static pf_status record_failure(pf_queue *queue, int64_t task_id, const char *error_text,
                                bool job_fault, failing_task *task, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT t.attempt, t.job_id, t.worker_id, coalesce(w.name, ''), j.max_attempts "
        "FROM tasks t JOIN jobs j ON j.id = t.job_id LEFT JOIN workers w ON w.id = t.worker_id "
        "WHERE t.id = ?",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, task_id);
    if (queue_step(stmt) != QUEUE_ROW) {
        status = queue_db_error(queue, err, "reading a failed task");
        queue_finalize(stmt);
        return status;
    }
    task->attempt = (int)queue_column_int64(stmt, 0);
    task->job_id = queue_column_int64(stmt, 1);
    task->has_worker = !queue_column_is_null(stmt, 2);
    task->worker_id = queue_column_int64(stmt, 2);
    queue_copy_text(task->worker_name, sizeof task->worker_name, queue_column_text(stmt, 3));
    task->max_attempts = (int)queue_column_int64(stmt, 4);
    queue_finalize(stmt);

    status = queue_prepare(queue,
                           "INSERT INTO task_failures (task_id, attempt, worker_id, worker_name, "
                           "error, failed_at, job_fault) VALUES (?, ?, ?, ?, ?, ?, ?)",
                           &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, task_id);
    queue_bind_int64(stmt, 2, task->attempt);
    if (task->has_worker)
        queue_bind_int64(stmt, 3, task->worker_id);
    queue_bind_text(stmt, 4, task->worker_name);
    queue_bind_text(stmt, 5, error_text);
    queue_bind_int64(stmt, 6, pf_queue_now(queue));
    queue_bind_int64(stmt, 7, job_fault);
    return queue_step_done(queue, stmt, "recording a task failure", err);
}

pf_status queue_clear_worker_task(pf_queue *queue, int64_t task_id, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue, "UPDATE workers SET current_task_id = NULL WHERE current_task_id = ?", &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, task_id);
    return queue_step_done(queue, stmt, "clearing a worker's task", err);
}

/*
 * Runs sql with ?1 = now (plus delay_ms when sql has ?4 = the delay), ?2 =
 * error_text, ?3 = id: every settling of a failed task and its job is one.
 */
static pf_status update_failed(pf_queue *queue, const char *sql, const char *error_text,
                               int64_t id, int64_t delay_ms, const char *what, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, sql, &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_text(stmt, 2, error_text);
    queue_bind_int64(stmt, 3, id);
    if (queue_bind_count(stmt) >= 4)
        queue_bind_int64(stmt, 4, delay_ms);
    return queue_step_done(queue, stmt, what, err);
}

/* The task is settled: no worker holds it; then the blocklist (worker_id > 0) and the job's status. */
static pf_status task_settled(pf_queue *queue, int64_t task_id, const failing_task *task,
                              bool count_against_worker, pf_error *err)
{
    pf_status status = queue_clear_worker_task(queue, task_id, err);
    if (status == PF_OK && count_against_worker && task->has_worker)
        status = apply_blocklist(queue, task->job_id, task->worker_id, err);
    if (status == PF_OK)
        status = queue_job_refresh(queue, task->job_id, err);
    return status;
}

#define SQL_TASK_FAILED                                                                         \
    "UPDATE tasks SET status = 'failed', lease_token = NULL, lease_expires = NULL, "          \
    "finished_at = ?1, last_error = ?2 WHERE id = ?3"

pf_status queue_task_job_fault(pf_queue *queue, int64_t task_id, const char *error_text,
                               pf_error *err)
{
    failing_task task;
    pf_status status = record_failure(queue, task_id, error_text, true, &task, err);
    /* Back in the queue as if never claimed: the attempt was not the task's to lose. */
    if (status == PF_OK)
        status = update_failed(queue,
                               "UPDATE tasks SET status = 'queued', "
                               "attempt = CASE WHEN attempt > 0 THEN attempt - 1 ELSE 0 END, "
                               "lease_token = NULL, lease_expires = NULL, worker_id = NULL, "
                               "started_at = NULL, eligible_at = ?1, last_error = ?2 "
                               "WHERE id = ?3",
                               error_text, task_id, 0, "requeueing a task", err);
    if (status == PF_OK)
        status = update_failed(queue,
                               "UPDATE jobs SET status = 'paused', updated_at = ?1,"
                               "  pause_reason = coalesce(pause_reason, ?2) "
                               "WHERE id = ?3 AND status IN ('queued', 'running', 'paused')",
                               error_text, task.job_id, 0, "pausing a job", err);
    if (status == PF_OK)
        status = task_settled(queue, task_id, &task, false, err);
    return status;
}

pf_status queue_task_reject(pf_queue *queue, int64_t task_id, const char *error_text,
                            pf_error *err)
{
    failing_task task;
    pf_status status = record_failure(queue, task_id, error_text, true, &task, err);
    if (status == PF_OK)
        status = update_failed(queue, SQL_TASK_FAILED, error_text, task_id, 0, "failing a task",
                               err);
    if (status == PF_OK)
        status = task_settled(queue, task_id, &task, false, err);
    return status;
}

pf_status queue_task_attempt_failed(pf_queue *queue, int64_t task_id, const char *error_text,
                                    pf_error *err)
{
    failing_task task;
    pf_status status = record_failure(queue, task_id, error_text, false, &task, err);
    if (status != PF_OK)
        return status;
    if (task.attempt >= task.max_attempts)
        status = update_failed(queue, SQL_TASK_FAILED, error_text, task_id, 0, "failing a task",
                               err);
    else
        status = update_failed(queue,
                               "UPDATE tasks SET status = 'queued', lease_token = NULL, "
                               "lease_expires = NULL, worker_id = NULL, eligible_at = ?1 + ?4, "
                               "last_error = ?2 WHERE id = ?3",
                               error_text, task_id, backoff_ms(&queue->options, task.attempt),
                               "requeueing a failed task", err);
    if (status == PF_OK)
        status = task_settled(queue, task_id, &task, true, err);
    return status;
}
