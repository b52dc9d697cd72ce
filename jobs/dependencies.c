/*
 * Job dependencies (issue 42): which jobs a job waits for, checked when added (no unknown
 * job, no cycle); its tasks held until what they wait for is done and released by the
 * completions that finish it (queue_internal.h says how); and what they make of a job's
 * status when read (waiting, blocked). The claim itself tests nothing: a test in its
 * statement, even one PostgreSQL never ran, cost 14 % of its claims at 16 processes
 * (bench/RESULTS.md).
 */
#include "queue_internal.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Refuses one prerequisite of job_id (the i-th of after) with the reason, or PF_OK. */
static pf_status check_one(pf_queue *queue, int64_t job_id, const pf_queue_dependency *after,
                           size_t i, pf_error *err)
{
    int64_t prerequisite = after[i].job_id;
    if (prerequisite == job_id)
        return pf_error_set(err, PF_ERR_INVALID, "job %" PRId64 " cannot wait for itself",
                            job_id);
    for (size_t k = 0; k < i; k++)
        if (after[k].job_id == prerequisite)
            return pf_error_set(err, PF_ERR_INVALID, "job %" PRId64 " is named twice",
                                prerequisite);
    pf_status status = queue_job_require(queue, prerequisite, NULL, 0, err);
    if (status != PF_OK)
        return status;
    int64_t count = 0;
    status = queue_read_int64(
        queue, "SELECT count(*) FROM job_dependencies WHERE job_id = ? AND after_job = ?",
        (int64_t[]){job_id, prerequisite}, 2, "reading job dependencies", &count, err);
    if (status == PF_OK && count > 0)
        return pf_error_set(err, PF_ERR_INVALID, "job %" PRId64 " already waits for job %" PRId64,
                            job_id, prerequisite);
    /* A cycle: job_id is among the jobs the prerequisite waits for, directly or not. */
    if (status == PF_OK)
        status = queue_read_int64(queue,
                                  "WITH RECURSIVE upstream (id) AS (SELECT CAST(?1 AS BIGINT) "
                                  "  UNION SELECT d.after_job FROM job_dependencies d"
                                  "  JOIN upstream u ON d.job_id = u.id) "
                                  "SELECT count(*) FROM upstream WHERE id = ?2",
                                  (int64_t[]){prerequisite, job_id}, 2,
                                  "reading job dependencies", &count, err);
    if (status == PF_OK && count > 0)
        return pf_error_set(err, PF_ERR_INVALID,
                            "job %" PRId64 " waits for job %" PRId64
                            " (directly or through others): waiting for it would be a cycle",
                            prerequisite, job_id);
    return status;
}

pf_status queue_dependencies_add(pf_queue *queue, int64_t job_id,
                                 const pf_queue_dependency *after, size_t count, pf_error *err)
{
    if (count > PF_QUEUE_DEPENDENCIES_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "%zu prerequisites: at most %d", count,
                            PF_QUEUE_DEPENDENCIES_MAX);
    pf_status status = PF_OK;
    for (size_t i = 0; i < count && status == PF_OK; i++) {
        status = check_one(queue, job_id, after, i, err);
        queue_stmt *stmt;
        if (status == PF_OK)
            status = queue_prepare(queue,
                                   "INSERT INTO job_dependencies (job_id, after_job, per_frame) "
                                   "VALUES (?, ?, ?)",
                                   &stmt, err);
        if (status != PF_OK)
            break;
        queue_bind_int64(stmt, 1, job_id);
        queue_bind_int64(stmt, 2, after[i].job_id);
        queue_bind_int64(stmt, 3, after[i].per_frame ? 1 : 0);
        status = queue_step_done(queue, stmt, "adding a job dependency", err);
        /* Its completions look for tasks to release from now on. */
        if (status == PF_OK)
            status = queue_prepare(queue, "UPDATE jobs SET dependents = 1 WHERE id = ?", &stmt,
                                   err);
        if (status != PF_OK)
            break;
        queue_bind_int64(stmt, 1, after[i].job_id);
        status = queue_step_done(queue, stmt, "marking a prerequisite", err);
    }
    return status == PF_OK && count > 0 ? queue_dependencies_hold(queue, job_id, err) : status;
}

/*
 * SQL: held task row T may be released: every job its job waits for as a whole is done,
 * and no task overlapping T's frames of a job it waits for frame by frame is unfinished
 * (statuses listed, so that the probe seeks the (job_id, status, first_frame) index).
 */
#define TASK_RELEASABLE(T)                                                                     \
    "NOT EXISTS (SELECT 1 FROM job_dependencies d JOIN jobs p ON p.id = d.after_job"         \
    "  WHERE d.job_id = " T ".job_id AND d.per_frame = 0 AND p.status <> 'done')"            \
    " AND NOT EXISTS (SELECT 1 FROM job_dependencies d JOIN tasks p"                         \
    "  ON p.job_id = d.after_job WHERE d.job_id = " T ".job_id AND d.per_frame = 1"          \
    "  AND p.status IN ('queued', 'running', 'failed', 'canceled')"                          \
    "  AND p.first_frame <= " T ".last_frame AND p.last_frame >= " T ".first_frame)"

pf_status queue_dependencies_hold(pf_queue *queue, int64_t job_id, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "UPDATE tasks SET eligible_at = " QUEUE_HELD_AT_SQL " "
                                     "WHERE job_id = ? AND status = 'queued' AND EXISTS "
                                     "(SELECT 1 FROM job_dependencies d WHERE d.job_id = "
                                     "tasks.job_id)",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    status = queue_step_done(queue, stmt, "holding a job's tasks", err);
    if (status == PF_OK)
        status = queue_prepare(queue,
                               "UPDATE tasks SET eligible_at = 0 WHERE job_id = ? AND "
                               "status = 'queued' AND eligible_at = " QUEUE_HELD_AT_SQL
                               " AND " TASK_RELEASABLE("tasks"),
                               &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    return queue_step_done(queue, stmt, "releasing a job's tasks", err);
}

pf_status queue_dependents_release(pf_queue *queue, int64_t job_id, int32_t first_frame,
                                   int32_t last_frame, pf_error *err)
{
    /* Only the tasks this completion can have freed: those overlapping its frames, or
     * all of them once the whole job is done. They become eligible at the time this
     * completion finished (the done task at first_frame), not at 0: a claim that read its clock before that completion
     * committed cannot take them with a start time before the finish it waited for (the
     * order the rows record is the order that happened; a worker on a host whose clock is
     * behind waits out the difference). */
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "UPDATE tasks SET eligible_at = coalesce((SELECT p.finished_at FROM tasks p"
        "  WHERE p.job_id = ?1 AND p.status = 'done' AND p.first_frame = ?2), 0)"
        " WHERE status = 'queued' AND eligible_at = "
        QUEUE_HELD_AT_SQL " AND job_id IN (SELECT d.job_id FROM job_dependencies d"
        "  WHERE d.after_job = ?1)"
        " AND ((SELECT j.status FROM jobs j WHERE j.id = ?1) = 'done'"
        "      OR (first_frame <= ?3 AND last_frame >= ?2))"
        " AND " TASK_RELEASABLE("tasks"),
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    queue_bind_int64(stmt, 2, first_frame);
    queue_bind_int64(stmt, 3, last_frame);
    return queue_step_done(queue, stmt, "releasing the tasks that waited for a frame", err);
}

typedef struct add_context {
    int64_t job_id;
    const pf_queue_dependency *after;
    size_t count;
} add_context;

static pf_status add_body(pf_queue *queue, void *context, pf_error *err)
{
    const add_context *add = context;
    char state[16];
    pf_status status = queue_job_require(queue, add->job_id, state, sizeof state, err);
    if (status == PF_OK && (!strcmp(state, "done") || !strcmp(state, "failed") ||
                            !strcmp(state, "canceled")))
        return pf_error_set(err, PF_ERR_INVALID,
                            "job %" PRId64 " has ended (%s): it has nothing left to wait with",
                            add->job_id, state);
    return status == PF_OK
               ? queue_dependencies_add(queue, add->job_id, add->after, add->count, err)
               : status;
}

pf_status pf_queue_add_dependencies(pf_queue *queue, int64_t job_id,
                                    const pf_queue_dependency *after, size_t count,
                                    pf_error *err)
{
    add_context add = {job_id, after, count};
    return queue_write(queue, "adding job dependencies", add_body, &add, err);
}

/* ---- what they make of a job's status ---- */

static int compare_job_id(const void *key, const void *item)
{
    int64_t id = *(const int64_t *)key, other = ((const pf_queue_job *)item)->job_id;
    return (id > other) - (id < other);
}

static pf_queue_job *find_job(pf_queue_job *jobs, size_t count, int64_t job_id)
{
    return bsearch(&job_id, jobs, count, sizeof *jobs, compare_job_id);
}

/* Whether a job's stored status lets its prerequisites hold it up. */
static bool may_wait(const pf_queue_job *job)
{
    return !strcmp(job->status, "queued") || !strcmp(job->status, "running");
}

/* Each job's direct prerequisites: the text, and "waiting" while one it waits for as a
 * whole has not finished and nothing of it has been claimed. */
static pf_status describe_direct(pf_queue *queue, int64_t job_id, pf_queue_job *jobs,
                                 size_t count, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "SELECT d.job_id, d.after_job, d.per_frame, p.status "
                                     "FROM job_dependencies d JOIN jobs p ON p.id = d.after_job "
                                     "WHERE ?1 = 0 OR d.job_id = ?1 ORDER BY d.job_id, d.after_job",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    int64_t noted = 0; /* the job whose note names its first unfinished prerequisite */
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_job *job = find_job(jobs, count, queue_column_int64(stmt, 0));
        if (!job)
            continue;
        int64_t prerequisite = queue_column_int64(stmt, 1);
        bool per_frame = queue_column_int64(stmt, 2) != 0;
        const char *state = queue_column_text(stmt, 3);
        size_t used = strlen(job->prerequisites);
        snprintf(job->prerequisites + used, sizeof job->prerequisites - used,
                 "%s%" PRId64 "%s (%s)", used ? ", " : "", prerequisite,
                 per_frame ? " frame by frame" : "", state);
        /* Before the requirements' note: no worker could take it yet anyway. */
        if (strcmp(state, "done") != 0 && !strcmp(job->status, "queued") &&
            noted != job->job_id) {
            noted = job->job_id;
            snprintf(job->note, sizeof job->note, "%s job %" PRId64 " (%s)",
                     per_frame ? "frame by frame after" : "waiting for", prerequisite, state);
            if (!per_frame)
                snprintf(job->status, sizeof job->status, "waiting");
        }
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "reading job dependencies");
    queue_finalize(stmt);
    return status;
}

/* "blocked" for each job that waits, directly or through unfinished jobs, for one that
 * failed or was canceled: it cannot finish until that one is retried. */
static pf_status describe_blocked(pf_queue *queue, int64_t job_id, pf_queue_job *jobs,
                                  size_t count, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "WITH RECURSIVE upstream (root, id, direct) AS ("
        "  SELECT d.job_id, d.after_job, 1 FROM job_dependencies d WHERE ?1 = 0 OR d.job_id = ?1"
        "  UNION"
        "  SELECT u.root, d.after_job, 0 FROM upstream u JOIN jobs p ON p.id = u.id"
        "  JOIN job_dependencies d ON d.job_id = u.id WHERE p.status <> 'done') "
        "SELECT u.root, u.id, max(u.direct), p.status FROM upstream u JOIN jobs p ON p.id = u.id "
        "WHERE p.status IN ('failed', 'canceled') GROUP BY u.root, u.id, p.status "
        "ORDER BY u.root, max(u.direct) DESC, u.id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_job *job = find_job(jobs, count, queue_column_int64(stmt, 0));
        /* The first row of a job names its nearest cause; the rest find it blocked. */
        if (!job || !(may_wait(job) || !strcmp(job->status, "waiting")))
            continue;
        int64_t cause = queue_column_int64(stmt, 1);
        bool direct = queue_column_int64(stmt, 2) != 0;
        const char *state = queue_column_text(stmt, 3);
        snprintf(job->status, sizeof job->status, "blocked");
        snprintf(job->note, sizeof job->note,
                 "blocked: job %" PRId64 ", which it waits for%s, %s; retry that job, or "
                 "cancel this one",
                 cause, direct ? "" : " through others", state);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "reading job dependencies");
    queue_finalize(stmt);
    return status;
}

pf_status queue_dependencies_describe(pf_queue *queue, int64_t job_id, pf_queue_job *jobs,
                                      size_t count, pf_error *err)
{
    pf_status status = describe_direct(queue, job_id, jobs, count, err);
    return status == PF_OK ? describe_blocked(queue, job_id, jobs, count, err) : status;
}
