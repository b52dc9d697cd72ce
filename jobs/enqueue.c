/* Enqueue: a job row and its tasks, chunked into arithmetic runs of frames. */
#include "queue_internal.h"

#include <cjson/cJSON.h>
#include <stdbool.h>
#include <string.h>

#define QUEUE_DEFAULT_MAX_ATTEMPTS 3

typedef struct enqueue_context {
    const pf_queue_job_spec *spec;
    const pf_frame_list *frames;
    int max_attempts;
    int frames_per_task;
    char required_tags[PF_QUEUE_TAGS_MAX]; /* normalised */
    int64_t job_id;
} enqueue_context;

/* Tasks per INSERT: one statement (one round trip on PostgreSQL) per this many tasks. */
#define TASK_BATCH 256
#define TASK_COLUMNS 5

/* One task: an arithmetic run of frames. */
typedef struct task_run {
    int32_t first, last, step, count;
} task_run;

/* Inserts runs[0..count) in one statement. */
static pf_status insert_tasks(pf_queue *queue, int64_t job_id, const task_run *runs, size_t count,
                              pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare_rows(queue,
                                          "INSERT INTO tasks (job_id, first_frame, last_frame, "
                                          "frame_step, frame_count, eligible_at) VALUES ",
                                          "(?, ?, ?, ?, ?, 0)", count, "", &stmt, err);
    if (status != PF_OK)
        return status;
    for (size_t i = 0; i < count; i++) {
        int base = (int)(i * TASK_COLUMNS);
        queue_bind_int64(stmt, base + 1, job_id);
        queue_bind_int64(stmt, base + 2, runs[i].first);
        queue_bind_int64(stmt, base + 3, runs[i].last);
        queue_bind_int64(stmt, base + 4, runs[i].step);
        queue_bind_int64(stmt, base + 5, runs[i].count);
    }
    return queue_step_done(queue, stmt, "inserting tasks", err);
}

/* Asks spec->conflicts about every unfinished job; the first conflict fails the enqueue. */
static pf_status check_conflicts(pf_queue *queue, const pf_queue_job_spec *spec, pf_error *err)
{
    if (!spec->conflicts)
        return PF_OK;
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue,
                                     "SELECT id, status, parameters, frame_range, output_pattern "
                                     "FROM jobs WHERE status IN ('queued', 'running', 'paused') "
                                     "ORDER BY id",
                                     &stmt, err);
    if (status != PF_OK)
        return status;
    int rc;
    while (status == PF_OK && (rc = queue_step(stmt)) == QUEUE_ROW) {
        pf_queue_job other = {0};
        other.job_id = queue_column_int64(stmt, 0);
        queue_copy_text(other.status, sizeof other.status, queue_column_text(stmt, 1));
        other.parameters_json = (char *)queue_column_text(stmt, 2);
        other.frame_range = (char *)queue_column_text(stmt, 3);
        other.output_pattern = (char *)queue_column_text(stmt, 4);
        char reason[PF_ERROR_MESSAGE_MAX];
        reason[0] = '\0';
        if (spec->conflicts(&other, spec->conflicts_user, reason, sizeof reason))
            status = pf_error_set(err, PF_ERR_INVALID, "%s",
                                  reason[0] ? reason : "conflicts with an unfinished job");
    }
    if (status == PF_OK && rc != QUEUE_DONE)
        status = queue_db_error(queue, err, "checking unfinished jobs");
    queue_finalize(stmt);
    return status;
}

static pf_status enqueue_body(pf_queue *queue, void *context, pf_error *err)
{
    enqueue_context *ctx = context;
    const pf_queue_job_spec *spec = ctx->spec;
    int64_t now = pf_queue_now(queue);
    queue_stmt *stmt;
    pf_status status = check_conflicts(queue, spec, err);
    if (status != PF_OK)
        return status;
    status = queue_prepare(
        queue,
        "INSERT INTO jobs (scene_path, parameters, frame_range, output_pattern, priority, "
        "max_attempts, frames_per_task, created_at, updated_at, requires_device, "
        "min_device_memory, min_host_memory, required_tags) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
        &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_text(stmt, 1, spec->scene_path);
    queue_bind_text(stmt, 2, spec->parameters_json ? spec->parameters_json : "{}");
    queue_bind_text(stmt, 3, spec->frame_range);
    queue_bind_text(stmt, 4, spec->output_pattern);
    queue_bind_int64(stmt, 5, spec->priority);
    queue_bind_int64(stmt, 6, ctx->max_attempts);
    queue_bind_int64(stmt, 7, ctx->frames_per_task);
    queue_bind_int64(stmt, 8, now);
    queue_bind_int64(stmt, 9, now);
    queue_bind_text(stmt, 10, spec->requires_device ? spec->requires_device : "");
    queue_bind_int64(stmt, 11, spec->min_device_memory);
    queue_bind_int64(stmt, 12, spec->min_host_memory);
    queue_bind_text(stmt, 13, ctx->required_tags);
    if (queue_step(stmt) == QUEUE_ROW)
        ctx->job_id = queue_column_int64(stmt, 0);
    else
        status = queue_db_error(queue, err, "inserting the job");
    queue_finalize(stmt);
    if (status != PF_OK)
        return status;

    const int32_t *frames = ctx->frames->frames;
    size_t count = ctx->frames->count, chunk_start = 0, batched = 0;
    task_run batch[TASK_BATCH];
    for (size_t i = 1; i <= count && status == PF_OK; i++) {
        size_t chunk_length = i - chunk_start;
        bool chunk_ends = i == count || chunk_length == (size_t)ctx->frames_per_task ||
                          (chunk_length >= 2 && frames[i] - frames[i - 1] !=
                                                    frames[chunk_start + 1] - frames[chunk_start]);
        if (!chunk_ends)
            continue;
        const int32_t *run = frames + chunk_start;
        batch[batched++] = (task_run){run[0], run[chunk_length - 1],
                                      chunk_length > 1 ? run[1] - run[0] : 1,
                                      (int32_t)chunk_length};
        chunk_start = i;
        if (batched == TASK_BATCH || i == count) {
            status = insert_tasks(queue, ctx->job_id, batch, batched, err);
            batched = 0;
        }
    }
    /* After the tasks: adding the dependencies holds those that must wait. */
    if (status == PF_OK && spec->after_count > 0)
        status = queue_dependencies_add(queue, ctx->job_id, spec->after, spec->after_count, err);
    return status;
}

pf_status pf_queue_enqueue(pf_queue *queue, const pf_queue_job_spec *spec, int64_t *job_id,
                           pf_error *err)
{
    if (!spec->scene_path || !*spec->scene_path)
        return pf_error_set(err, PF_ERR_INVALID, "enqueue: the scene path is empty");
    if (!spec->output_pattern || !*spec->output_pattern)
        return pf_error_set(err, PF_ERR_INVALID, "enqueue: the output pattern is empty");
    if (spec->max_attempts < 0 || spec->frames_per_task < 0)
        return pf_error_set(err, PF_ERR_INVALID,
                            "enqueue: max attempts (%d) and frames per task (%d) must be "
                            "positive",
                            spec->max_attempts, spec->frames_per_task);

    if (spec->requires_device && *spec->requires_device &&
        strcmp(spec->requires_device, "gpu") != 0 && strcmp(spec->requires_device, "cpu") != 0)
        return pf_error_set(err, PF_ERR_INVALID,
                            "enqueue: required device \"%.20s\": expected gpu or cpu",
                            spec->requires_device);
    if (spec->min_device_memory < 0 || spec->min_host_memory < 0)
        return pf_error_set(err, PF_ERR_INVALID, "enqueue: a memory requirement is negative");
    enqueue_context ctx = {
        .spec = spec,
        .max_attempts = spec->max_attempts ? spec->max_attempts : QUEUE_DEFAULT_MAX_ATTEMPTS,
        .frames_per_task = spec->frames_per_task ? spec->frames_per_task : 1,
    };
    if (spec->parameters_json) {
        /* Checked here, not by the engine, so that both engines refuse the same text. */
        cJSON *parsed = cJSON_ParseWithOpts(spec->parameters_json, NULL, 1);
        bool valid = parsed != NULL;
        cJSON_Delete(parsed);
        if (!valid)
            return pf_error_set(err, PF_ERR_INVALID, "enqueue: parameters are not valid JSON: %s",
                                spec->parameters_json);
    }
    pf_status status =
        pf_queue_tags_normalize(spec->required_tags, ctx.required_tags, sizeof ctx.required_tags,
                                err);
    if (status != PF_OK)
        return pf_error_prefix(err, "enqueue"), status;
    pf_frame_list frames;
    status = pf_frame_range_parse(spec->frame_range, &frames, err);
    if (status != PF_OK)
        return status;
    ctx.frames = &frames;
    status = queue_write(queue, "enqueueing a job", enqueue_body, &ctx, err);
    pf_frame_list_free(&frames);
    if (status == PF_OK)
        *job_id = ctx.job_id;
    return status;
}
