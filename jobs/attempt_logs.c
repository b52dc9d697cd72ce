/*
 * Each attempt's log (issue 41): the lines a worker logged while it held a task, stored
 * when it lets the task go (done, failed, released), so that the monitor and `photonfarm
 * log` show a frame's log lines beside its failures. A worker killed outright stores
 * none: its lease expiry is what the queue records.
 */
#include "queue_internal.h"

#include <stdlib.h>
#include <string.h>

/* Length of the valid UTF-8 sequence at text (1 to 4), or 0 where it is not one. */
static size_t utf8_sequence(const unsigned char *text)
{
    unsigned char lead = text[0];
    size_t length;
    unsigned min;
    unsigned value;
    if (lead < 0x80)
        return 1;
    if (lead >= 0xc2 && lead <= 0xdf) {
        length = 2, value = lead & 0x1f, min = 0x80;
    } else if (lead >= 0xe0 && lead <= 0xef) {
        length = 3, value = lead & 0x0f, min = 0x800;
    } else if (lead >= 0xf0 && lead <= 0xf4) {
        length = 4, value = lead & 0x07, min = 0x10000;
    } else {
        return 0;
    }
    for (size_t i = 1; i < length; i++) {
        if ((text[i] & 0xc0) != 0x80)
            return 0;
        value = value << 6 | (text[i] & 0x3f);
    }
    if (value < min || value > 0x10ffff || (value >= 0xd800 && value <= 0xdfff))
        return 0;
    return length;
}

/* text with every byte that is not part of valid UTF-8 replaced by '?' (PostgreSQL's TEXT
 * refuses such bytes; a log line may quote a path in any encoding). malloc'ed. */
static char *valid_utf8(const char *text, size_t length)
{
    char *copy = malloc(length + 1);
    if (!copy)
        return NULL;
    memcpy(copy, text, length);
    copy[length] = '\0';
    for (size_t i = 0; i < length;) {
        size_t step = utf8_sequence((const unsigned char *)copy + i);
        if (step == 0) {
            copy[i] = '?';
            step = 1;
        }
        i += step;
    }
    return copy;
}

typedef struct store_context {
    int64_t task_id, worker_id;
    int attempt;
    const char *text;
} store_context;

static pf_status store_body(pf_queue *queue, void *context, pf_error *err)
{
    store_context *ctx = context;
    int64_t attempts = -1; /* -1: no such task */
    pf_status status = queue_read_int64(
        queue, "SELECT coalesce(max(attempt), -1) FROM tasks WHERE id = ?", &ctx->task_id, 1,
        "reading a task's attempts", &attempts, err);
    if (status != PF_OK)
        return status;
    if (attempts < 0)
        return pf_error_set(err, PF_ERR_INVALID, "%s: no task %lld", queue->path,
                            (long long)ctx->task_id);
    if (ctx->attempt < 1 || ctx->attempt > attempts)
        return pf_error_set(err, PF_ERR_INVALID, "%s: task %lld has no attempt %d", queue->path,
                            (long long)ctx->task_id, ctx->attempt);
    queue_stmt *stmt;
    status = queue_prepare(
        queue,
        "INSERT INTO attempt_logs (task_id, attempt, worker_id, written_at, log) "
        "VALUES (?1, ?2, ?3, ?4, ?5) ON CONFLICT (task_id, attempt) DO UPDATE SET "
        "worker_id = excluded.worker_id, written_at = excluded.written_at, log = excluded.log",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->task_id);
    queue_bind_int64(stmt, 2, ctx->attempt);
    if (ctx->worker_id > 0)
        queue_bind_int64(stmt, 3, ctx->worker_id);
    queue_bind_int64(stmt, 4, pf_queue_now(queue));
    queue_bind_text(stmt, 5, ctx->text);
    queue_commit_with_next(queue);
    return queue_step_done(queue, stmt, "storing an attempt's log", err);
}

pf_status pf_queue_attempt_log_store(pf_queue *queue, int64_t task_id, int attempt,
                                     int64_t worker_id, const char *text, pf_error *err)
{
    size_t length = text ? strlen(text) : 0;
    if (length > PF_QUEUE_LOG_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "%s: an attempt's log of %zu bytes (at most %d)",
                            queue->path, length, PF_QUEUE_LOG_MAX);
    char *valid = valid_utf8(text ? text : "", length);
    if (!valid)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory storing a log", queue->path);
    store_context ctx = {task_id, worker_id, attempt, valid};
    pf_status status = queue_write_lease(queue, "storing an attempt's log", store_body, &ctx, err);
    free(valid);
    return status;
}

/* ---- a frame's logs ---- */

void pf_queue_attempt_logs_free(pf_queue_attempt_log *logs, size_t count)
{
    for (size_t i = 0; logs && i < count; i++)
        free(logs[i].text);
    free(logs);
}

typedef struct logs_context {
    int64_t job_id;
    int32_t frame;
    queue_records rows;
} logs_context;

static pf_status logs_body(pf_queue *queue, void *context, pf_error *err)
{
    logs_context *ctx = context;
    pf_status status = queue_job_require(queue, ctx->job_id, NULL, 0, err);
    queue_stmt *stmt;
    if (status == PF_OK)
        status = queue_prepare(
            queue,
            "SELECT l.task_id, t.first_frame, t.last_frame, l.attempt, w.name, l.written_at,"
            "  l.log FROM attempt_logs l JOIN tasks t ON t.id = l.task_id "
            "LEFT JOIN workers w ON w.id = l.worker_id "
            "WHERE t.job_id = ?1 AND t.first_frame <= ?2 AND t.last_frame >= ?2 "
            "ORDER BY l.written_at, l.task_id, l.attempt",
            &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    queue_bind_int64(stmt, 2, ctx->frame);
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_attempt_log *log = queue_records_append(&ctx->rows);
        char *text = log ? strdup(queue_column_text(stmt, 6)) : NULL;
        if (!text) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading logs",
                                  queue->path);
            break;
        }
        log->task_id = queue_column_int64(stmt, 0);
        log->first_frame = (int32_t)queue_column_int64(stmt, 1);
        log->last_frame = (int32_t)queue_column_int64(stmt, 2);
        log->attempt = (int)queue_column_int64(stmt, 3);
        queue_copy_text(log->worker_name, sizeof log->worker_name, queue_column_text(stmt, 4));
        log->written_at = queue_column_int64(stmt, 5);
        log->text = text;
    }
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "reading logs");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_attempt_logs(pf_queue *queue, int64_t job_id, int32_t frame,
                                pf_queue_attempt_log **logs, size_t *count, pf_error *err)
{
    logs_context ctx = {job_id, frame, {NULL, 0, 0, sizeof **logs}};
    pf_status status = queue_read(queue, "reading logs", logs_body, &ctx, err);
    if (status != PF_OK) {
        pf_queue_attempt_logs_free(ctx.rows.items, ctx.rows.count);
        ctx.rows.items = NULL;
        ctx.rows.count = 0;
    }
    *logs = ctx.rows.items;
    *count = ctx.rows.count;
    return status;
}
