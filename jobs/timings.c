/*
 * Stage timing statistics of a job: per stage order statistics, slowest
 * frames, and the decisions recorded in the rows' reasons.
 */
#include "queue_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define TIMING_MEDIAN 0.5
#define TIMING_P95 0.95

/* Linear interpolation between closest ranks (numpy's default "linear"). */
static double percentile(const double *sorted, size_t count, double p)
{
    double rank = p * (double)(count - 1);
    size_t low = (size_t)floor(rank), high = (size_t)ceil(rank);
    return sorted[low] + (sorted[high] - sorted[low]) * (rank - (double)low);
}

/* Reads one column of doubles (already sorted by the query) into a stat; the query's ?1 is
 * job_id, its ?2 stage (when not NULL). */
static pf_status sample_stat(pf_queue *queue, const char *sql, int64_t job_id, const char *stage,
                             pf_queue_stat *stat, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, sql, &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, job_id);
    if (stage)
        queue_bind_text(stmt, 2, stage);
    queue_records records = {NULL, 0, 0, sizeof(double)};
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        double *value = queue_records_append(&records);
        if (!value) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading timings",
                                  queue->path);
            break;
        }
        *value = queue_column_double(stmt, 0);
    }
    double *values = records.items;
    size_t count = records.count;
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "reading stage timings");
    queue_finalize(stmt);
    memset(stat, 0, sizeof *stat);
    if (status == PF_OK && count > 0) {
        stat->count = (int64_t)count;
        stat->min = values[0];
        stat->max = values[count - 1];
        stat->median = percentile(values, count, TIMING_MEDIAN);
        stat->p95 = percentile(values, count, TIMING_P95);
        for (size_t i = 0; i < count; i++)
            stat->total += values[i];
    }
    free(values);
    return status;
}

typedef struct timings_context {
    int64_t job_id;
    size_t slowest_n;
    pf_queue_timings *out;
} timings_context;

static pf_status stage_list(pf_queue *queue, timings_context *ctx, pf_error *err)
{
    pf_queue_timings *out = ctx->out;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT s.stage, sum(CASE WHEN s.skipped = 0 THEN 1 ELSE 0 END), "
        "sum(CASE WHEN s.skipped != 0 THEN 1 ELSE 0 END) "
        "FROM stage_timings s JOIN tasks t ON t.id = s.task_id WHERE t.job_id = ? "
        "GROUP BY s.stage ORDER BY min(s.id)",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    queue_records stages = {NULL, 0, 0, sizeof(pf_queue_stage_stats)};
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_stage_stats *stage = queue_records_append(&stages);
        if (!stage) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading timings",
                                  queue->path);
            break;
        }
        queue_copy_text(stage->stage, sizeof stage->stage, queue_column_text(stmt, 0));
        stage->count = queue_column_int64(stmt, 1);
        stage->skipped = queue_column_int64(stmt, 2);
    }
    out->stages = stages.items;
    out->stage_count = stages.count;
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "listing stages");
    queue_finalize(stmt);
    return status;
}

static pf_status slowest_frames(pf_queue *queue, timings_context *ctx, pf_error *err)
{
    pf_queue_timings *out = ctx->out;
    if (ctx->slowest_n == 0)
        return PF_OK;
    out->slowest = calloc(ctx->slowest_n, sizeof *out->slowest);
    if (!out->slowest)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading timings", queue->path);
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT s.task_id, s.frame, coalesce(sum(CASE WHEN s.skipped = 0 THEN s.wall_ms END), 0.0) AS wall "
        "FROM stage_timings s JOIN tasks t ON t.id = s.task_id WHERE t.job_id = ? "
        "GROUP BY s.task_id, s.frame ORDER BY wall DESC, s.frame LIMIT ?",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    queue_bind_int64(stmt, 2, (int64_t)ctx->slowest_n);
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_slow_frame *frame = &out->slowest[out->slowest_count++];
        frame->task_id = queue_column_int64(stmt, 0);
        frame->frame = (int)queue_column_int64(stmt, 1);
        frame->wall_ms = queue_column_double(stmt, 2);
    }
    if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "finding the slowest frames");
    queue_finalize(stmt);
    return status;
}

/* Counts the rows with a reason by stage and decision (pf_queue_decision_count). */
static pf_status decision_counts(pf_queue *queue, timings_context *ctx, pf_error *err)
{
    pf_queue_timings *out = ctx->out;
    queue_stmt *stmt;
    /* The decision is the reason up to its first ':' (instr is SQLite's, strpos PostgreSQL's). */
    pf_status status = queue_prepare(
        queue,
        queue_sql(queue,
                  "SELECT s.stage, CASE WHEN instr(s.reason, ':') > 0 THEN substr(s.reason, 1, "
                  "instr(s.reason, ':') - 1) ELSE s.reason END AS decision, count(*) "
                  "FROM stage_timings s JOIN tasks t ON t.id = s.task_id WHERE t.job_id = ? "
                  "AND s.reason IS NOT NULL AND s.reason != '' "
                  "GROUP BY s.stage, decision ORDER BY min(s.id)",
                  "SELECT s.stage, CASE WHEN strpos(s.reason, ':') > 0 THEN substr(s.reason, 1, "
                  "strpos(s.reason, ':') - 1) ELSE s.reason END AS decision, count(*) "
                  "FROM stage_timings s JOIN tasks t ON t.id = s.task_id WHERE t.job_id = ? "
                  "AND s.reason IS NOT NULL AND s.reason != '' "
                  "GROUP BY s.stage, decision ORDER BY min(s.id)"),
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    queue_records decisions = {NULL, 0, 0, sizeof(pf_queue_decision_count)};
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_decision_count *row = queue_records_append(&decisions);
        if (!row) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading timings",
                                  queue->path);
            break;
        }
        queue_copy_text(row->stage, sizeof row->stage, queue_column_text(stmt, 0));
        queue_copy_text(row->decision, sizeof row->decision, queue_column_text(stmt, 1));
        row->count = queue_column_int64(stmt, 2);
    }
    out->decisions = decisions.items;
    out->decision_count = decisions.count;
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "counting stage decisions");
    queue_finalize(stmt);
    return status;
}

/* Counts the job's frames per build that recorded their rows (pf_queue_build_count). */
static pf_status build_counts(pf_queue *queue, timings_context *ctx, pf_error *err)
{
    pf_queue_timings *out = ctx->out;
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue,
        "SELECT coalesce(s.build, 'unknown') AS b, count(DISTINCT s.frame) "
        "FROM stage_timings s JOIN tasks t ON t.id = s.task_id WHERE t.job_id = ? "
        "GROUP BY b ORDER BY min(s.id)",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    queue_records builds = {NULL, 0, 0, sizeof(pf_queue_build_count)};
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_build_count *row = queue_records_append(&builds);
        if (!row) {
            status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory reading timings",
                                  queue->path);
            break;
        }
        queue_copy_text(row->build, sizeof row->build, queue_column_text(stmt, 0));
        row->frames = queue_column_int64(stmt, 1);
    }
    out->builds = builds.items;
    out->build_count = builds.count;
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "counting the builds that rendered");
    queue_finalize(stmt);
    return status;
}

static pf_status timings_body(pf_queue *queue, void *context, pf_error *err)
{
    timings_context *ctx = context;
    pf_queue_timings *out = ctx->out;
    pf_status status = queue_job_require(queue, ctx->job_id, NULL, 0, err);
    if (status == PF_OK)
        status = stage_list(queue, ctx, err);
    for (size_t i = 0; status == PF_OK && i < out->stage_count; i++) {
        pf_queue_stage_stats *stage = &out->stages[i];
        status = sample_stat(queue,
                             "SELECT s.wall_ms FROM stage_timings s JOIN tasks t ON t.id = "
                             "s.task_id WHERE t.job_id = ?1 AND s.stage = ?2 AND s.skipped = 0 "
                             "ORDER BY s.wall_ms",
                             ctx->job_id, stage->stage, &stage->wall, err);
        if (status == PF_OK)
            status = sample_stat(queue,
                                 "SELECT s.gpu_ms FROM stage_timings s JOIN tasks t ON t.id = "
                                 "s.task_id WHERE t.job_id = ?1 AND s.stage = ?2 AND "
                                 "s.skipped = 0 AND s.gpu_ms IS NOT NULL ORDER BY s.gpu_ms",
                                 ctx->job_id, stage->stage, &stage->gpu, err);
        out->total_wall_ms += stage->wall.total;
        out->total_gpu_ms += stage->gpu.total;
    }
    if (status == PF_OK) {
        queue_stmt *stmt;
        status = queue_prepare(queue,
                               "SELECT count(DISTINCT s.frame) FROM stage_timings s JOIN tasks t "
                               "ON t.id = s.task_id WHERE t.job_id = ?",
                               &stmt, err);
        if (status == PF_OK) {
            queue_bind_int64(stmt, 1, ctx->job_id);
            if (queue_step(stmt) == QUEUE_ROW)
                out->frames = queue_column_int64(stmt, 0);
            else
                status = queue_db_error(queue, err, "counting timed frames");
            queue_finalize(stmt);
        }
    }
    if (status == PF_OK)
        status = slowest_frames(queue, ctx, err);
    if (status == PF_OK)
        status = decision_counts(queue, ctx, err);
    if (status == PF_OK)
        status = build_counts(queue, ctx, err);
    if (status == PF_OK)
        status = sample_stat(queue,
                             "SELECT r.peak_rss FROM frame_resources r JOIN tasks t ON t.id = "
                             "r.task_id WHERE t.job_id = ?1 AND r.peak_rss >= 0 ORDER BY 1",
                             ctx->job_id, NULL, &out->peak_rss, err);
    if (status == PF_OK)
        status = sample_stat(queue,
                             "SELECT r.peak_device_memory FROM frame_resources r JOIN tasks t ON "
                             "t.id = r.task_id WHERE t.job_id = ?1 AND r.peak_device_memory >= 0 "
                             "ORDER BY 1",
                             ctx->job_id, NULL, &out->peak_device_memory, err);
    if (status == PF_OK)
        status = sample_stat(queue,
                             "SELECT r.bytes_written FROM frame_resources r JOIN tasks t ON "
                             "t.id = r.task_id WHERE t.job_id = ?1 AND r.bytes_written >= 0 "
                             "ORDER BY 1",
                             ctx->job_id, NULL, &out->bytes_written, err);
    return status;
}

void pf_queue_timings_free(pf_queue_timings *timings)
{
    free(timings->stages);
    free(timings->slowest);
    free(timings->decisions);
    free(timings->builds);
    memset(timings, 0, sizeof *timings);
}

pf_status pf_queue_timings_get(pf_queue *queue, int64_t job_id, size_t slowest_n,
                               pf_queue_timings *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    timings_context ctx = {job_id, slowest_n, out};
    pf_status status = queue_read(queue, "reading stage timings", timings_body, &ctx, err);
    if (status != PF_OK)
        pf_queue_timings_free(out);
    return status;
}
