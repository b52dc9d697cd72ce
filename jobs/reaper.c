/* The reaper: expired leases go back to the queue as counted failed attempts. */
#include "queue_internal.h"

#include <stdio.h>
#include <stdlib.h>

/* A running task of tasks t whose lease ended before ? (now). */
#define EXPIRED_LEASE "t.status = 'running' AND t.lease_expires < ?"

typedef struct expired_task {
    int64_t task_id;
    char worker_name[PF_QUEUE_NAME_MAX];
} expired_task;

typedef struct reap_context {
    int64_t reaped;
} reap_context;

static pf_status reap_body(pf_queue *queue, void *context, pf_error *err)
{
    reap_context *ctx = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT t.id, coalesce(w.name, '?') FROM tasks t LEFT JOIN workers w ON w.id = t.worker_id "
        "WHERE " EXPIRED_LEASE " ORDER BY t.id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    /* Collected first: each reap rewrites the rows the SELECT walks. */
    queue_records records = {NULL, 0, 0, sizeof(expired_task)};
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        expired_task *task = queue_records_append(&records);
        if (!task) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reaping leases",
                                  queue->path);
            break;
        }
        task->task_id = queue_column_int64(stmt, 0);
        queue_copy_text(task->worker_name, sizeof task->worker_name, queue_column_text(stmt, 1));
    }
    expired_task *expired = records.items;
    size_t count = records.count;
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "finding expired leases");
    queue_finalize(stmt);

    for (size_t i = 0; i < count && status == PF_OK; i++) {
        char reason[PF_QUEUE_NAME_MAX + 64];
        snprintf(reason, sizeof reason, "lease expired (worker %s stopped heartbeating)",
                 expired[i].worker_name);
        status = queue_task_attempt_failed(queue, expired[i].task_id, reason, err);
    }
    free(expired);
    if (status == PF_OK)
        ctx->reaped = (int64_t)count;
    return status;
}

/* context: a bool, set when some lease has expired. */
static pf_status probe_body(pf_queue *queue, void *context, pf_error *err)
{
    bool *any = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "SELECT 1 FROM tasks t WHERE " EXPIRED_LEASE " LIMIT 1",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    int rc = queue_step(stmt);
    *any = rc == QUEUE_ROW;
    if (rc != QUEUE_ROW && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "looking for expired leases");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_reap(pf_queue *queue, int64_t *reaped, pf_error *err)
{
    /* Every worker reaps on a timer; the reap is a whole-queue writer (on
     * PostgreSQL it waits for every claim in flight and holds new ones), so
     * it runs only when a read finds something to reap. */
    bool any = false;
    pf_status status = queue_read(queue, "looking for expired leases", probe_body, &any, err);
    if (reaped)
        *reaped = 0;
    if (status != PF_OK || !any)
        return status;
    reap_context ctx = {0};
    status = queue_write(queue, "reaping expired leases", reap_body, &ctx, err);
    if (reaped)
        *reaped = status == PF_OK ? ctx.reaped : 0;
    return status;
}
