/*
 * What each frame took (issue 42): the worker's and its device's peak memory and the bytes
 * written, stored with a completion beside its stage rows, summarised with a job's stage
 * statistics, and listed frame by frame with each frame's stages and decisions.
 */
#include "queue_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RESOURCE_COLUMNS 6

pf_status queue_frame_resources_store(pf_queue *queue, int64_t task_id, int attempt,
                                      int32_t first_frame, int32_t last_frame, int32_t frame_step,
                                      const pf_queue_frame_resources *frames, size_t count,
                                      pf_error *err)
{
    for (size_t i = 0; i < count; i++) {
        const pf_queue_frame_resources *frame = &frames[i];
        if (frame->frame < first_frame || frame->frame > last_frame ||
            (frame->frame - first_frame) % frame_step != 0)
            return pf_error_set(err, PF_ERR_INVALID,
                                "%s: resources of frame %d: not one of task %lld's frames",
                                queue->path, frame->frame, (long long)task_id);
        for (size_t k = 0; k < i; k++)
            if (frames[k].frame == frame->frame)
                return pf_error_set(err, PF_ERR_INVALID,
                                    "%s: resources of frame %d are given twice", queue->path,
                                    frame->frame);
        if (frame->peak_rss < -1 || frame->peak_device_memory < -1 || frame->bytes_written < -1)
            return pf_error_set(err, PF_ERR_INVALID,
                                "%s: resources of frame %d: a negative size", queue->path,
                                frame->frame);
    }
    queue_stmt *stmt;
    pf_status status = queue_prepare_rows(queue,
                                          "INSERT INTO frame_resources (task_id, attempt, frame, "
                                          "peak_rss, peak_device_memory, bytes_written) VALUES ",
                                          "(?, ?, ?, ?, ?, ?)", count, "", &stmt, err);
    if (status != PF_OK)
        return status;
    for (size_t i = 0; i < count; i++) {
        int base = (int)i * RESOURCE_COLUMNS;
        queue_bind_int64(stmt, base + 1, task_id);
        queue_bind_int64(stmt, base + 2, attempt);
        queue_bind_int64(stmt, base + 3, frames[i].frame);
        queue_bind_int64(stmt, base + 4, frames[i].peak_rss);
        queue_bind_int64(stmt, base + 5, frames[i].peak_device_memory);
        queue_bind_int64(stmt, base + 6, frames[i].bytes_written);
    }
    return queue_step_done(queue, stmt, "storing the frames' resources", err);
}

/* ---- every frame of a job ---- */

void pf_queue_frame_details_free(pf_queue_frame_details *details)
{
    free(details->frames);
    free(details->stages);
    memset(details, 0, sizeof *details);
}

/* A stage row's decision: its reason up to the first ':' (pf_queue_decision_count's rule). */
static void decision_of(const char *reason, char *out, size_t size)
{
    size_t length = strcspn(reason, ":");
    if (length >= size)
        length = size - 1;
    memcpy(out, reason, length);
    out[length] = '\0';
}

typedef struct details_context {
    int64_t job_id;
    queue_records frames, stages;
} details_context;

static pf_status details_body(pf_queue *queue, void *context, pf_error *err)
{
    details_context *ctx = context;
    pf_status status = queue_job_require(queue, ctx->job_id, NULL, 0, err);
    queue_stmt *stmt;
    if (status == PF_OK)
        status = queue_prepare(
            queue,
            "SELECT s.task_id, s.frame, s.attempt, coalesce(w.name, ''),"
            "  coalesce(r.peak_rss, -1), coalesce(r.peak_device_memory, -1),"
            "  coalesce(r.bytes_written, -1), s.stage, s.wall_ms, s.skipped,"
            "  coalesce(s.reason, '') "
            "FROM stage_timings s JOIN tasks t ON t.id = s.task_id"
            " LEFT JOIN workers w ON w.id = t.worker_id"
            " LEFT JOIN frame_resources r ON r.task_id = s.task_id AND r.frame = s.frame "
            "WHERE t.job_id = ? ORDER BY s.frame, s.task_id, s.id",
            &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, ctx->job_id);
    pf_queue_frame_detail *frame = NULL;
    int rc;
    while ((rc = queue_step(stmt)) == QUEUE_ROW) {
        int64_t task_id = queue_column_int64(stmt, 0);
        int32_t number = (int32_t)queue_column_int64(stmt, 1);
        if (!frame || frame->task_id != task_id || frame->frame != number) {
            if (!(frame = queue_records_append(&ctx->frames)))
                break;
            frame->task_id = task_id;
            frame->frame = number;
            frame->attempt = (int)queue_column_int64(stmt, 2);
            queue_copy_text(frame->worker_name, sizeof frame->worker_name,
                            queue_column_text(stmt, 3));
            frame->peak_rss = queue_column_int64(stmt, 4);
            frame->peak_device_memory = queue_column_int64(stmt, 5);
            frame->bytes_written = queue_column_int64(stmt, 6);
            frame->first_stage = ctx->stages.count;
        }
        pf_queue_frame_stage *stage = queue_records_append(&ctx->stages);
        if (!stage) {
            frame = NULL;
            break;
        }
        queue_copy_text(stage->stage, sizeof stage->stage, queue_column_text(stmt, 7));
        stage->wall_ms = queue_column_double(stmt, 8);
        stage->skipped = queue_column_int64(stmt, 9) != 0;
        decision_of(queue_column_text(stmt, 10), stage->decision, sizeof stage->decision);
        frame->stage_count++;
        if (!stage->skipped)
            frame->wall_ms += stage->wall_ms;
    }
    if (rc == QUEUE_ROW) /* an append failed */
        status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory listing frames", queue->path);
    else if (rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "listing frames");
    queue_finalize(stmt);
    return status;
}

pf_status pf_queue_frame_details_get(pf_queue *queue, int64_t job_id,
                                     pf_queue_frame_details *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    details_context ctx = {job_id,
                           {NULL, 0, 0, sizeof(pf_queue_frame_detail)},
                           {NULL, 0, 0, sizeof(pf_queue_frame_stage)}};
    pf_status status = queue_read(queue, "listing frames", details_body, &ctx, err);
    out->frames = ctx.frames.items;
    out->frame_count = ctx.frames.count;
    out->stages = ctx.stages.items;
    out->stage_count = ctx.stages.count;
    if (status != PF_OK)
        pf_queue_frame_details_free(out);
    return status;
}
