/* Read-only views for status displays: jobs with progress, tasks, failures, workers. */
#include "queue_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char *dup_column(queue_stmt *stmt, int column)
{
    return strdup(queue_column_text(stmt, column));
}

void pf_queue_job_clear(pf_queue_job *job)
{
    free(job->scene_path);
    free(job->parameters_json);
    free(job->frame_range);
    free(job->output_pattern);
    job->scene_path = job->parameters_json = job->frame_range = job->output_pattern = NULL;
}

void pf_queue_job_list_free(pf_queue_job *jobs, size_t count)
{
    for (size_t i = 0; jobs && i < count; i++)
        pf_queue_job_clear(&jobs[i]);
    free(jobs);
}

typedef struct job_query {
    int64_t job_id; /* 0: every job */
    queue_records jobs;
} job_query;

static pf_status read_job_row(pf_queue *queue, queue_stmt *stmt, pf_queue_job *job,
                              pf_error *err)
{
    job->job_id = queue_column_int64(stmt, 0);
    queue_copy_text(job->status, sizeof job->status, queue_column_text(stmt, 1));
    job->priority = (int)queue_column_int64(stmt, 2);
    job->max_attempts = (int)queue_column_int64(stmt, 3);
    job->frames_per_task = (int)queue_column_int64(stmt, 4);
    job->scene_path = dup_column(stmt, 5);
    job->parameters_json = dup_column(stmt, 6);
    job->frame_range = dup_column(stmt, 7);
    job->output_pattern = dup_column(stmt, 8);
    job->created_at = queue_column_int64(stmt, 9);
    job->updated_at = queue_column_int64(stmt, 10);
    job->tasks_total = queue_column_int64(stmt, 11);
    job->tasks_queued = queue_column_int64(stmt, 12);
    job->tasks_running = queue_column_int64(stmt, 13);
    job->tasks_done = queue_column_int64(stmt, 14);
    job->tasks_failed = queue_column_int64(stmt, 15);
    job->tasks_canceled = queue_column_int64(stmt, 16);
    job->frames_total = queue_column_int64(stmt, 17);
    job->frames_done = queue_column_int64(stmt, 18);
    job->live_workers = (int)queue_column_int64(stmt, 19);
    job->blocked_live_workers = (int)queue_column_int64(stmt, 20);
    queue_copy_text(job->pause_reason, sizeof job->pause_reason, queue_column_text(stmt, 21));
    queue_copy_text(job->requires_device, sizeof job->requires_device,
                    queue_column_text(stmt, 22));
    job->min_device_memory = queue_column_int64(stmt, 23);
    job->min_host_memory = queue_column_int64(stmt, 24);
    queue_copy_text(job->required_tags, sizeof job->required_tags, queue_column_text(stmt, 25));
    job->qualified_live_workers = (int)queue_column_int64(stmt, 26);
    job->memory_failures = queue_column_int64(stmt, 27);
    queue_copy_text(job->plan, sizeof job->plan, queue_column_text(stmt, 28));
    if (!job->scene_path || !job->parameters_json || !job->frame_range || !job->output_pattern)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading job %lld",
                            queue->path, (long long)job->job_id);
    bool waiting = job->tasks_queued > 0 &&
                   (!strcmp(job->status, "queued") || !strcmp(job->status, "running"));
    bool requires = job->requires_device[0] || job->min_device_memory > 0 ||
                    job->min_host_memory > 0 || job->required_tags[0];
    if (waiting && requires && job->qualified_live_workers == 0) {
        char needs[PF_QUEUE_TAGS_MAX + 160];
        pf_queue_requirements_text(job->requires_device, job->min_device_memory,
                                   job->min_host_memory, job->required_tags, needs,
                                   sizeof needs);
        snprintf(job->note, sizeof job->note, "waiting: no live worker has %s", needs);
    } else if (waiting && job->live_workers > 0 &&
               job->blocked_live_workers == job->live_workers)
        snprintf(job->note, sizeof job->note,
                 "no eligible worker: all %d live workers are blocked for this job",
                 job->live_workers);
    else if (!strcmp(job->status, "paused") && job->pause_reason[0])
        snprintf(job->note, sizeof job->note, "paused: %s (resume once fixed)",
                 job->pause_reason);
    return PF_OK;
}

static pf_status job_query_body(pf_queue *queue, void *context, pf_error *err)
{
    job_query *query = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "WITH live AS (SELECT * FROM workers WHERE stopped_at IS NULL AND heartbeat_at >= "
        "  ?2 - CASE WHEN lease_ms > 0 THEN lease_ms ELSE ?3 END) "
        "SELECT j.id, j.status, j.priority, j.max_attempts, j.frames_per_task, j.scene_path,"
        "  j.parameters, j.frame_range, j.output_pattern, j.created_at, j.updated_at,"
        "  count(t.id),"
        "  coalesce(sum(CASE WHEN t.status = 'queued' THEN 1 ELSE 0 END), 0),"
        "  coalesce(sum(CASE WHEN t.status = 'running' THEN 1 ELSE 0 END), 0),"
        "  coalesce(sum(CASE WHEN t.status = 'done' THEN 1 ELSE 0 END), 0),"
        "  coalesce(sum(CASE WHEN t.status = 'failed' THEN 1 ELSE 0 END), 0),"
        "  coalesce(sum(CASE WHEN t.status = 'canceled' THEN 1 ELSE 0 END), 0),"
        "  coalesce(sum(t.frame_count), 0),"
        "  coalesce(sum(CASE WHEN t.status = 'done' THEN t.frame_count END), 0),"
        "  (SELECT count(*) FROM live),"
        "  (SELECT count(*) FROM live JOIN worker_blocks b ON b.worker_id = live.id"
        "   WHERE b.job_id = j.id), j.pause_reason, j.requires_device, j.min_device_memory,"
        "  j.min_host_memory, j.required_tags,"
        "  (SELECT count(*) FROM live w WHERE " QUEUE_WORKER_MEETS("j", "w") "),"
        /* '_' is LIKE's one-character wildcard: "out of host memory" and
         * "VK_ERROR_OUT_OF_DEVICE_MEMORY" both match. */
        "  (SELECT count(*) FROM task_failures f JOIN tasks u ON u.id = f.task_id"
        "   WHERE u.job_id = j.id AND lower(f.error) LIKE '%out_of%memory%'),"
        /* What auto chose for its highest finished frame, and why: two index probes. */
        "  (SELECT s.reason FROM stage_timings s WHERE s.stage = 'plan' AND s.task_id = "
        "   (SELECT d.id FROM tasks d WHERE d.job_id = j.id AND d.status = 'done' "
        "    ORDER BY d.first_frame DESC LIMIT 1) ORDER BY s.id DESC LIMIT 1) "
        "FROM jobs j LEFT JOIN tasks t ON t.job_id = j.id "
        "WHERE ?1 = 0 OR j.id = ?1 GROUP BY j.id ORDER BY j.id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, query->job_id);
    queue_bind_int64(stmt, 2, pf_queue_now(queue));
    queue_bind_int64(stmt, 3, queue->options.worker_alive_ms);
    int rc;
    while (status == PF_OK && (rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_job *job = queue_records_append(&query->jobs);
        if (!job)
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory listing jobs",
                                  queue->path);
        else
            status = read_job_row(queue, stmt, job, err);
    }
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "listing jobs");
    queue_finalize(stmt);
    return status == PF_OK ? queue_dependencies_describe(queue, query->job_id, query->jobs.items,
                                                         query->jobs.count, err)
                           : status;
}

static pf_status run_job_query(pf_queue *queue, job_query *query, pf_error *err)
{
    query->jobs.item_size = sizeof(pf_queue_job);
    pf_status status = queue_read(queue, "listing jobs", job_query_body, query, err);
    if (status != PF_OK) {
        pf_queue_job_list_free(query->jobs.items, query->jobs.count);
        query->jobs.items = NULL;
        query->jobs.count = 0;
    }
    return status;
}

pf_status pf_queue_job_get(pf_queue *queue, int64_t job_id, pf_queue_job *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    if (job_id <= 0)
        return pf_error_set(err, PF_ERR_INVALID, "%s: no job %lld", queue->path,
                            (long long)job_id);
    job_query query = {.job_id = job_id};
    pf_status status = run_job_query(queue, &query, err);
    if (status != PF_OK)
        return status;
    if (query.jobs.count == 0) {
        free(query.jobs.items);
        return pf_error_set(err, PF_ERR_INVALID, "%s: no job %lld", queue->path,
                            (long long)job_id);
    }
    *out = *(pf_queue_job *)query.jobs.items;
    free(query.jobs.items);
    return PF_OK;
}

pf_status pf_queue_job_list(pf_queue *queue, pf_queue_job **jobs, size_t *count, pf_error *err)
{
    job_query query = {0};
    pf_status status = run_job_query(queue, &query, err);
    *jobs = query.jobs.items;
    *count = query.jobs.count;
    return status;
}

/* ---- tasks, failures, workers ---- */

typedef struct list_query {
    int64_t job_id;
    queue_records rows;
} list_query;

/* Steps stmt, handing each row to read; collects results into query->rows. */
static pf_status collect(pf_queue *queue, queue_stmt *stmt, list_query *query,
                         void (*read)(queue_stmt *stmt, void *row), const char *what,
                         pf_error *err)
{
    pf_status status = PF_OK;
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        void *row = queue_records_append(&query->rows);
        if (!row) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory %s", queue->path, what);
            break;
        }
        read(stmt, row);
    }
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, what);
    queue_finalize(stmt);
    return status;
}

static void read_task(queue_stmt *stmt, void *row)
{
    pf_queue_task_info *task = row;
    task->task_id = queue_column_int64(stmt, 0);
    task->first_frame = (int)queue_column_int64(stmt, 1);
    task->last_frame = (int)queue_column_int64(stmt, 2);
    task->frame_step = (int)queue_column_int64(stmt, 3);
    task->frame_count = (int)queue_column_int64(stmt, 4);
    queue_copy_text(task->status, sizeof task->status, queue_column_text(stmt, 5));
    task->attempt = (int)queue_column_int64(stmt, 6);
    task->worker_id = queue_column_int64(stmt, 7);
    queue_copy_text(task->worker_name, sizeof task->worker_name, queue_column_text(stmt, 8));
    task->lease_expires = queue_column_int64(stmt, 9);
    task->eligible_at = queue_column_int64(stmt, 10);
    task->started_at = queue_column_int64(stmt, 11);
    task->finished_at = queue_column_int64(stmt, 12);
    queue_copy_text(task->last_error, sizeof task->last_error, queue_column_text(stmt, 13));
}

static pf_status task_list_body(pf_queue *queue, void *context, pf_error *err)
{
    list_query *query = context;
    pf_status status = queue_job_require(queue, query->job_id, NULL, 0, err);
    queue_stmt *stmt;
    if (status == PF_OK)
        status = queue_prepare(
            queue,
            "SELECT t.id, t.first_frame, t.last_frame, t.frame_step, t.frame_count, t.status,"
            "  t.attempt, t.worker_id, w.name, t.lease_expires, t.eligible_at, t.started_at,"
            "  t.finished_at, t.last_error "
            "FROM tasks t LEFT JOIN workers w ON w.id = t.worker_id "
            "WHERE t.job_id = ? ORDER BY t.first_frame",
            &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, query->job_id);
    return collect(queue, stmt, query, read_task, "listing tasks", err);
}

static pf_status run_list(pf_queue *queue, list_query *query, size_t item_size,
                          queue_tx_body body, void **rows, size_t *count, pf_error *err)
{
    query->rows.item_size = item_size;
    pf_status status = queue_read(queue, "listing", body, query, err);
    if (status != PF_OK) {
        free(query->rows.items);
        query->rows.items = NULL;
        query->rows.count = 0;
    }
    *rows = query->rows.items;
    *count = query->rows.count;
    return status;
}

pf_status pf_queue_task_list(pf_queue *queue, int64_t job_id, pf_queue_task_info **tasks,
                             size_t *count, pf_error *err)
{
    list_query query = {.job_id = job_id};
    void *rows;
    pf_status status =
        run_list(queue, &query, sizeof **tasks, task_list_body, &rows, count, err);
    *tasks = rows;
    return status;
}

static void read_failure(queue_stmt *stmt, void *row)
{
    pf_queue_failure *failure = row;
    failure->task_id = queue_column_int64(stmt, 0);
    failure->first_frame = (int)queue_column_int64(stmt, 1);
    failure->attempt = (int)queue_column_int64(stmt, 2);
    queue_copy_text(failure->worker_name, sizeof failure->worker_name,
                    queue_column_text(stmt, 3));
    queue_copy_text(failure->error, sizeof failure->error, queue_column_text(stmt, 4));
    failure->failed_at = queue_column_int64(stmt, 5);
    failure->job_fault = (int)queue_column_int64(stmt, 6);
}

static pf_status failure_list_body(pf_queue *queue, void *context, pf_error *err)
{
    list_query *query = context;
    pf_status status = queue_job_require(queue, query->job_id, NULL, 0, err);
    queue_stmt *stmt;
    if (status == PF_OK)
        status = queue_prepare(queue,
                               "SELECT f.task_id, t.first_frame, f.attempt, f.worker_name, "
                               "f.error, f.failed_at, f.job_fault FROM task_failures f "
                               "JOIN tasks t ON t.id = f.task_id WHERE t.job_id = ? ORDER BY f.id",
                               &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, query->job_id);
    return collect(queue, stmt, query, read_failure, "listing failures", err);
}

pf_status pf_queue_failure_list(pf_queue *queue, int64_t job_id, pf_queue_failure **failures,
                                size_t *count, pf_error *err)
{
    list_query query = {.job_id = job_id};
    void *rows;
    pf_status status =
        run_list(queue, &query, sizeof **failures, failure_list_body, &rows, count, err);
    *failures = rows;
    return status;
}

static void read_worker(queue_stmt *stmt, void *row)
{
    pf_queue_worker_info *worker = row;
    worker->worker_id = queue_column_int64(stmt, 0);
    queue_copy_text(worker->name, sizeof worker->name, queue_column_text(stmt, 1));
    queue_copy_text(worker->host, sizeof worker->host, queue_column_text(stmt, 2));
    queue_copy_text(worker->device, sizeof worker->device, queue_column_text(stmt, 3));
    worker->pid = queue_column_int64(stmt, 4);
    worker->heartbeat_at = queue_column_int64(stmt, 5);
    worker->started_at = queue_column_int64(stmt, 6);
    worker->stopped_at = queue_column_int64(stmt, 7);
    worker->alive = (int)queue_column_int64(stmt, 8) != 0;
    worker->current_task_id = queue_column_int64(stmt, 9);
    worker->current_job_id = queue_column_int64(stmt, 10);
    worker->current_frame = (int)queue_column_int64(stmt, 11);
    queue_copy_text(worker->device_type, sizeof worker->device_type, queue_column_text(stmt, 12));
    worker->device_memory = queue_column_int64(stmt, 13);
    worker->host_memory = queue_column_int64(stmt, 14);
    worker->cores = queue_column_int64(stmt, 15);
    queue_copy_text(worker->tags, sizeof worker->tags, queue_column_text(stmt, 16));
}

static pf_status worker_list_body(pf_queue *queue, void *context, pf_error *err)
{
    (void)context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT w.id, w.name, w.host, w.device, w.pid, w.heartbeat_at, w.started_at,"
        "  w.stopped_at, w.stopped_at IS NULL AND w.heartbeat_at >= "
        "  ?1 - CASE WHEN w.lease_ms > 0 THEN w.lease_ms ELSE ?2 END, w.current_task_id,"
        "  t.job_id, t.first_frame, w.device_type, w.device_memory, w.host_memory, w.cores,"
        "  w.tags "
        "FROM workers w LEFT JOIN tasks t ON t.id = w.current_task_id ORDER BY w.id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_int64(stmt, 2, queue->options.worker_alive_ms);
    return collect(queue, stmt, context, read_worker, "listing workers", err);
}

pf_status pf_queue_worker_list(pf_queue *queue, pf_queue_worker_info **workers, size_t *count,
                               pf_error *err)
{
    list_query query = {0};
    void *rows;
    pf_status status =
        run_list(queue, &query, sizeof **workers, worker_list_body, &rows, count, err);
    *workers = rows;
    return status;
}

static void read_worker_stats(queue_stmt *stmt, void *row)
{
    pf_queue_worker_stats *stats = row;
    stats->worker_id = queue_column_int64(stmt, 0);
    stats->frames_done = queue_column_int64(stmt, 1);
    stats->failures = queue_column_int64(stmt, 2);
}

static pf_status worker_stats_body(pf_queue *queue, void *context, pf_error *err)
{
    list_query *query = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT w.id, coalesce(d.frames, 0), coalesce(f.failures, 0) FROM workers w"
        " LEFT JOIN (SELECT worker_id, sum(frame_count) AS frames FROM tasks"
        "   WHERE status = 'done' GROUP BY worker_id) d ON d.worker_id = w.id"
        " LEFT JOIN (SELECT worker_id, count(*) AS failures FROM task_failures"
        "   GROUP BY worker_id) f ON f.worker_id = w.id "
        "ORDER BY w.id",
        &stmt, err);
    if (status == PF_OK)
        status = collect(queue, stmt, query, read_worker_stats, "reading worker stats", err);
    if (status != PF_OK)
        return status;
    /* The jobs each is blocked for, appended to its row. */
    status = queue_prepare(queue,
                           "SELECT worker_id, job_id FROM worker_blocks ORDER BY worker_id, job_id",
                           &stmt, err);
    if (status != PF_OK)
        return status;
    pf_queue_worker_stats *rows = query->rows.items;
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        int64_t worker_id = queue_column_int64(stmt, 0);
        for (size_t i = 0; i < query->rows.count; i++) {
            if (rows[i].worker_id != worker_id)
                continue;
            size_t used = strlen(rows[i].blocked_jobs);
            snprintf(rows[i].blocked_jobs + used, sizeof rows[i].blocked_jobs - used,
                     "%s%lld", used ? "," : "", (long long)queue_column_int64(stmt, 1));
        }
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "reading worker blocks");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_worker_stats_list(pf_queue *queue, pf_queue_worker_stats **stats,
                                     size_t *count, pf_error *err)
{
    list_query query = {0};
    void *rows;
    pf_status status =
        run_list(queue, &query, sizeof **stats, worker_stats_body, &rows, count, err);
    *stats = rows;
    return status;
}

/* ---- has anything changed? ---- */

typedef struct mark_context {
    char *mark;
    size_t size;
} mark_context;

static pf_status change_mark_body(pf_queue *queue, void *context, pf_error *err)
{
    mark_context *ctx = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue, queue_sql(queue, "PRAGMA data_version", "SELECT md5(pg_current_snapshot()::text)"),
        &stmt, err);
    if (status != PF_OK)
        return status;
    if (queue_step(stmt) == QUEUE_ROW)
        queue_copy_text(ctx->mark, ctx->size, queue_column_text(stmt, 0));
    else
        status = queue_db_error(queue, err, "reading the queue's change mark");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_change_mark(pf_queue *queue, char *mark, size_t size, pf_error *err)
{
    mark_context ctx = {mark, size};
    return queue_read(queue, "reading the queue's change mark", change_mark_body, &ctx, err);
}
