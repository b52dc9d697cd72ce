/* Worker registration and liveness. Each writes only the worker's own row, so
 * on PostgreSQL they run beside the claims (queue_write_lease) instead of
 * stopping every claim of the farm while a worker starts or stops. */
#include "queue_internal.h"

#include <stdio.h>
#include <stdlib.h>
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
        "INSERT INTO workers (name, host, pid, device, heartbeat_at, started_at, lease_ms, "
        "device_type, device_memory, host_memory, cores, tags) "
        "VALUES (?1, ?2, ?3, ?4, ?5, ?5, ?6, ?7, ?8, ?9, ?10, ?11) ON CONFLICT (name) DO UPDATE "
        "SET host = ?2, pid = ?3, device = ?4, heartbeat_at = ?5, started_at = ?5, "
        "stopped_at = NULL, lease_ms = ?6, device_type = ?7, device_memory = ?8, "
        "host_memory = ?9, cores = ?10, tags = ?11 RETURNING id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_text(stmt, 1, ctx->spec->name);
    queue_bind_text(stmt, 2, ctx->spec->host ? ctx->spec->host : "");
    queue_bind_int64(stmt, 3, ctx->spec->pid);
    queue_bind_text(stmt, 4, ctx->spec->device ? ctx->spec->device : "");
    queue_bind_int64(stmt, 5, now);
    queue_bind_int64(stmt, 6, ctx->spec->lease_ms > 0 ? ctx->spec->lease_ms : 0);
    queue_bind_text(stmt, 7, ctx->spec->device_type ? ctx->spec->device_type : "");
    queue_bind_int64(stmt, 8, ctx->spec->device_memory > 0 ? ctx->spec->device_memory : 0);
    queue_bind_int64(stmt, 9, ctx->spec->host_memory > 0 ? ctx->spec->host_memory : 0);
    queue_bind_int64(stmt, 10, ctx->spec->cores > 0 ? ctx->spec->cores : 0);
    queue_bind_text(stmt, 11, ctx->spec->tags ? ctx->spec->tags : "");
    if (queue_step(stmt) == QUEUE_ROW)
        ctx->worker_id = queue_column_int64(stmt, 0);
    else
        status = queue_db_error(queue, err, "registering a worker");
    queue_finalize(stmt);
    return status;
}

/* One tag's characters: letters, digits, '.', '_', '-'. */
static int tag_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           c == '.' || c == '_' || c == '-';
}

static int compare_tags(const void *a, const void *b) { return strcmp(a, b); }

pf_status pf_queue_tags_normalize(const char *text, char *out, size_t size, pf_error *err)
{
    char tags[PF_QUEUE_TAGS_MAX / 2][PF_QUEUE_TAG_MAX];
    size_t count = 0;
    for (const char *p = text ? text : ""; *p;) {
        if (*p == ',' || *p == ' ') {
            p++;
            continue;
        }
        size_t length = 0;
        while (p[length] && p[length] != ',' && p[length] != ' ')
            length++;
        for (size_t i = 0; i < length; i++)
            if (!tag_char(p[i]))
                return pf_error_set(err, PF_ERR_INVALID,
                                    "tag \"%.*s\": only letters, digits, '.', '_' and '-'",
                                    (int)(length < 64 ? length : 64), p);
        if (length >= PF_QUEUE_TAG_MAX || count == sizeof tags / sizeof *tags)
            return pf_error_set(err, PF_ERR_INVALID,
                                "tag \"%.*s\": tags are 1 to %d bytes, at most %zu of them",
                                (int)(length < 64 ? length : 64), p, PF_QUEUE_TAG_MAX - 1,
                                sizeof tags / sizeof *tags);
        for (size_t i = 0; i < length; i++) /* case-insensitive: stored lower case */
            tags[count][i] = (char)((p[i] >= 'A' && p[i] <= 'Z') ? p[i] - 'A' + 'a' : p[i]);
        tags[count++][length] = '\0';
        p += length;
    }
    qsort(tags, count, sizeof *tags, compare_tags);
    size_t used = 0;
    out[0] = '\0';
    for (size_t i = 0; i < count; i++) {
        if (i > 0 && !strcmp(tags[i], tags[i - 1]))
            continue;
        int written = snprintf(out + used, size - used, "%s%s", used ? "," : "", tags[i]);
        if (written < 0 || (size_t)written >= size - used || used + written >= PF_QUEUE_TAGS_MAX)
            return pf_error_set(err, PF_ERR_INVALID, "tags \"%.60s...\": over %d bytes", text,
                                PF_QUEUE_TAGS_MAX - 1);
        used += (size_t)written;
    }
    return PF_OK;
}

pf_status pf_queue_worker_register(pf_queue *queue, const pf_queue_worker_spec *spec,
                                   int64_t *worker_id, pf_error *err)
{
    if (!spec->name || !*spec->name || strlen(spec->name) >= PF_QUEUE_NAME_MAX)
        return pf_error_set(err, PF_ERR_INVALID,
                            "worker name must be 1 to %d bytes (got \"%.40s\")",
                            PF_QUEUE_NAME_MAX - 1, spec->name ? spec->name : "");
    if (spec->tags && strlen(spec->tags) >= PF_QUEUE_TAGS_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "worker tags: over %d bytes",
                            PF_QUEUE_TAGS_MAX - 1);
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

typedef struct meeting_context {
    const pf_queue_job_spec *spec;
    const char *tags; /* normalised */
    int64_t count;
} meeting_context;

static pf_status meeting_body(pf_queue *queue, void *context, pf_error *err)
{
    meeting_context *ctx = context;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT count(*) FROM workers w, (SELECT CAST(?1 AS TEXT) AS requires_device,"
        "  CAST(?2 AS BIGINT) AS min_device_memory, CAST(?3 AS BIGINT) AS min_host_memory,"
        "  CAST(?4 AS TEXT) AS required_tags) j WHERE " QUEUE_WORKER_MEETS("j", "w"),
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_text(stmt, 1, ctx->spec->requires_device ? ctx->spec->requires_device : "");
    queue_bind_int64(stmt, 2, ctx->spec->min_device_memory);
    queue_bind_int64(stmt, 3, ctx->spec->min_host_memory);
    queue_bind_text(stmt, 4, ctx->tags);
    if (queue_step(stmt) == QUEUE_ROW)
        ctx->count = queue_column_int64(stmt, 0);
    else
        status = queue_db_error(queue, err, "counting the workers that meet a job's needs");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_workers_meeting(pf_queue *queue, const pf_queue_job_spec *spec,
                                   int64_t *count, pf_error *err)
{
    char tags[PF_QUEUE_TAGS_MAX];
    pf_status status = pf_queue_tags_normalize(spec->required_tags, tags, sizeof tags, err);
    if (status != PF_OK)
        return status;
    meeting_context ctx = {spec, tags, 0};
    status = queue_read(queue, "counting workers", meeting_body, &ctx, err);
    if (status == PF_OK)
        *count = ctx.count;
    return status;
}

void pf_queue_requirements_text(const char *device, int64_t min_device_memory,
                                int64_t min_host_memory, const char *tags, char *out,
                                size_t size)
{
    int used = snprintf(out, size, "%s", device && *device ? (!strcmp(device, "gpu") ? "a gpu"
                                                                                   : "a cpu")
                                                          : "any device");
    if (min_device_memory > 0 && used >= 0 && (size_t)used < size)
        used += snprintf(out + used, size - used, " with >= %.1f GiB of device memory",
                         (double)min_device_memory / (double)(1ll << 30));
    if (min_host_memory > 0 && used >= 0 && (size_t)used < size)
        used += snprintf(out + used, size - used, ", >= %.1f GiB of memory",
                         (double)min_host_memory / (double)(1ll << 30));
    if (tags && *tags && used >= 0 && (size_t)used < size)
        snprintf(out + used, size - used, " and the tag%s %s", strchr(tags, ',') ? "s" : "",
                 tags);
}

void pf_queue_suggested_requirement(int64_t peak, char *out, size_t size)
{
    int64_t steps =
        (int64_t)((double)peak * PF_QUEUE_SUGGESTED_HEADROOM / (double)PF_QUEUE_SUGGESTED_STEP) + 1;
    int64_t mib = steps * (PF_QUEUE_SUGGESTED_STEP >> 20);
    if (mib % 1024 == 0)
        snprintf(out, size, "%lldG", (long long)(mib / 1024));
    else
        snprintf(out, size, "%lldM", (long long)mib);
}
