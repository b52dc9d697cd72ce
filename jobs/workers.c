/* Worker registration and liveness. Each writes only the worker's own row, so
 * on PostgreSQL they run beside the claims (queue_write_lease) instead of
 * stopping every claim of the farm while a worker starts or stops. */
#include "queue_internal.h"

#include <string.h>

typedef struct register_context {
    const pf_queue_worker_spec *spec;
    int64_t worker_id;
} register_context;

static pf_status register_body(pf_queue *queue, void *context, pf_error *err)
{
    register_context *ctx = context;
    int64_t now = pf_queue_now(queue);
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "INSERT INTO workers (name, host, pid, device, heartbeat_at, started_at, lease_ms) "
        "VALUES (?1, ?2, ?3, ?4, ?5, ?5, ?6) ON CONFLICT (name) DO UPDATE SET host = ?2, "
        "pid = ?3, device = ?4, heartbeat_at = ?5, started_at = ?5, stopped_at = NULL, "
        "lease_ms = ?6 RETURNING id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_text(stmt, 1, ctx->spec->name);
    queue_bind_text(stmt, 2, ctx->spec->host ? ctx->spec->host : "");
    queue_bind_int64(stmt, 3, ctx->spec->pid);
    queue_bind_text(stmt, 4, ctx->spec->device ? ctx->spec->device : "");
    queue_bind_int64(stmt, 5, now);
    queue_bind_int64(stmt, 6, ctx->spec->lease_ms > 0 ? ctx->spec->lease_ms : 0);
    if (queue_step(stmt) == QUEUE_ROW)
        ctx->worker_id = queue_column_int64(stmt, 0);
    else
        status = queue_db_error(queue, err, "registering a worker");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_worker_register(pf_queue *queue, const pf_queue_worker_spec *spec,
                                   int64_t *worker_id, pf_error *err)
{
    if (!spec->name || !*spec->name || strlen(spec->name) >= PF_QUEUE_NAME_MAX)
        return pf_error_set(err, PF_ERR_INVALID,
                            "worker name must be 1 to %d bytes (got \"%.40s\")",
                            PF_QUEUE_NAME_MAX - 1, spec->name ? spec->name : "");
    register_context ctx = {.spec = spec};
    pf_status status = queue_write_lease(queue, "registering a worker", register_body, &ctx, err);
    if (status == PF_OK)
        *worker_id = ctx.worker_id;
    return status;
}

typedef struct worker_update_context {
    int64_t worker_id;
    const char *sql;
} worker_update_context;

static pf_status worker_update_body(pf_queue *queue, void *context, pf_error *err)
{
    worker_update_context *ctx = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, ctx->sql, &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, pf_queue_now(queue));
    queue_bind_int64(stmt, 2, ctx->worker_id);
    status = queue_step_done(queue, stmt, "updating a worker", err);
    if (status == PF_OK && queue_changes(queue) == 0)
        status = pf_error_set(err, PF_ERR_INVALID, "%s: no worker %lld", queue->path,
                              (long long)ctx->worker_id);
    return status;
}

pf_status pf_queue_worker_heartbeat(pf_queue *queue, int64_t worker_id, pf_error *err)
{
    worker_update_context ctx = {
        worker_id, "UPDATE workers SET heartbeat_at = ?1 WHERE id = ?2"};
    return queue_write_lease(queue, "worker heartbeat", worker_update_body, &ctx, err);
}

pf_status pf_queue_worker_stop(pf_queue *queue, int64_t worker_id, pf_error *err)
{
    worker_update_context ctx = {
        worker_id,
        "UPDATE workers SET stopped_at = ?1, heartbeat_at = ?1, current_task_id = NULL "
        "WHERE id = ?2"};
    return queue_write_lease(queue, "stopping a worker", worker_update_body, &ctx, err);
}
