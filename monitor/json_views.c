/*
 * The queue's records as JSON (README "The monitor"): what the monitor serves, and the
 * one codec of `timings --format json` (with --frames too). cJSON escapes every string;
 * the page shows them as text.
 */
#include "json_views.h"

#include <stdlib.h>
#include <string.h>

/* A job's parameters as an object (its name, preset, size); an empty one if unreadable. */
static cJSON *parameters_object(const char *json)
{
    cJSON *parsed = json ? cJSON_Parse(json) : NULL;
    if (cJSON_IsObject(parsed))
        return parsed;
    cJSON_Delete(parsed);
    return cJSON_CreateObject();
}

cJSON *pf_monitor_job_json(const pf_queue_job *job)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "id", (double)job->job_id);
    cJSON_AddStringToObject(object, "status", job->status);
    cJSON_AddNumberToObject(object, "priority", job->priority);
    cJSON_AddItemToObject(object, "parameters", parameters_object(job->parameters_json));
    cJSON_AddStringToObject(object, "scene", job->scene_path ? job->scene_path : "");
    cJSON_AddStringToObject(object, "frame_range", job->frame_range ? job->frame_range : "");
    cJSON_AddStringToObject(object, "output", job->output_pattern ? job->output_pattern : "");
    cJSON_AddNumberToObject(object, "frames_total", (double)job->frames_total);
    cJSON_AddNumberToObject(object, "frames_done", (double)job->frames_done);
    cJSON *tasks = cJSON_AddObjectToObject(object, "tasks");
    cJSON_AddNumberToObject(tasks, "queued", (double)job->tasks_queued);
    cJSON_AddNumberToObject(tasks, "running", (double)job->tasks_running);
    cJSON_AddNumberToObject(tasks, "done", (double)job->tasks_done);
    cJSON_AddNumberToObject(tasks, "failed", (double)job->tasks_failed);
    cJSON_AddNumberToObject(tasks, "canceled", (double)job->tasks_canceled);
    /* Times, never ages: the snapshot changes only when the queue does (the page computes
     * ages and the ETA against the server's clock, its responses' Date). */
    cJSON_AddNumberToObject(object, "created_at", (double)job->created_at);
    cJSON_AddNumberToObject(object, "updated_at", (double)job->updated_at);
    cJSON_AddStringToObject(object, "note", job->note);
    cJSON_AddStringToObject(object, "prerequisites", job->prerequisites);
    char needs[PF_QUEUE_TAGS_MAX + 160] = "";
    if (job->requires_device[0] || job->min_device_memory > 0 || job->min_host_memory > 0 ||
        job->required_tags[0])
        pf_queue_requirements_text(job->requires_device, job->min_device_memory,
                                   job->min_host_memory, job->required_tags, needs,
                                   sizeof needs);
    cJSON_AddStringToObject(object, "requires", needs);
    cJSON_AddNumberToObject(object, "live_workers", job->live_workers);
    cJSON_AddNumberToObject(object, "qualified_live_workers", job->qualified_live_workers);
    cJSON_AddNumberToObject(object, "blocked_live_workers", job->blocked_live_workers);
    cJSON_AddNumberToObject(object, "memory_failures", (double)job->memory_failures);
    cJSON_AddStringToObject(object, "plan", job->plan);
    return object;
}

cJSON *pf_monitor_worker_json(const pf_queue_worker_info *worker)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "id", (double)worker->worker_id);
    cJSON_AddStringToObject(object, "name", worker->name);
    cJSON_AddStringToObject(object, "host", worker->host);
    cJSON_AddStringToObject(object, "device", worker->device);
    cJSON_AddStringToObject(object, "device_type", worker->device_type);
    cJSON_AddNumberToObject(object, "device_memory", (double)worker->device_memory);
    cJSON_AddNumberToObject(object, "host_memory", (double)worker->host_memory);
    cJSON_AddNumberToObject(object, "cores", (double)worker->cores);
    cJSON_AddStringToObject(object, "tags", worker->tags);
    cJSON_AddBoolToObject(object, "alive", worker->alive);
    cJSON_AddBoolToObject(object, "stopped", worker->stopped_at != 0);
    cJSON_AddNumberToObject(object, "heartbeat_at", (double)worker->heartbeat_at);
    if (worker->current_task_id) {
        cJSON_AddNumberToObject(object, "job", (double)worker->current_job_id);
        cJSON_AddNumberToObject(object, "frame", worker->current_frame);
    } else {
        cJSON_AddNullToObject(object, "job");
        cJSON_AddNullToObject(object, "frame");
    }
    return object;
}

cJSON *pf_monitor_worker_stats_json(const pf_queue_worker_stats *stats, size_t count)
{
    cJSON *array = cJSON_CreateArray();
    for (size_t i = 0; i < count; i++) {
        cJSON *object = cJSON_CreateObject();
        cJSON_AddNumberToObject(object, "id", (double)stats[i].worker_id);
        cJSON_AddNumberToObject(object, "frames_done", (double)stats[i].frames_done);
        cJSON_AddNumberToObject(object, "failures", (double)stats[i].failures);
        cJSON_AddStringToObject(object, "blocked_jobs", stats[i].blocked_jobs);
        cJSON_AddItemToArray(array, object);
    }
    return array;
}

cJSON *pf_monitor_tasks_json(const pf_queue_task_info *tasks, size_t count)
{
    cJSON *array = cJSON_CreateArray();
    for (size_t i = 0; i < count; i++) {
        const pf_queue_task_info *task = &tasks[i];
        cJSON *object = cJSON_CreateObject();
        cJSON_AddNumberToObject(object, "id", (double)task->task_id);
        cJSON_AddNumberToObject(object, "first_frame", task->first_frame);
        cJSON_AddNumberToObject(object, "last_frame", task->last_frame);
        cJSON_AddNumberToObject(object, "frame_step", task->frame_step);
        cJSON_AddStringToObject(object, "status", task->status);
        cJSON_AddNumberToObject(object, "attempt", task->attempt);
        cJSON_AddStringToObject(object, "worker", task->worker_name);
        cJSON_AddNumberToObject(object, "lease_expires", (double)task->lease_expires);
        cJSON_AddStringToObject(object, "last_error", task->last_error);
        cJSON_AddItemToArray(array, object);
    }
    return array;
}

cJSON *pf_monitor_failures_json(const pf_queue_failure *failures, size_t count)
{
    cJSON *array = cJSON_CreateArray();
    for (size_t i = 0; i < count; i++) {
        cJSON *object = cJSON_CreateObject();
        cJSON_AddNumberToObject(object, "frame", failures[i].first_frame);
        cJSON_AddNumberToObject(object, "attempt", failures[i].attempt);
        cJSON_AddStringToObject(object, "worker", failures[i].worker_name);
        cJSON_AddStringToObject(object, "error", failures[i].error);
        cJSON_AddNumberToObject(object, "failed_at", (double)failures[i].failed_at);
        cJSON_AddBoolToObject(object, "job_fault", failures[i].job_fault != 0);
        cJSON_AddItemToArray(array, object);
    }
    return array;
}

cJSON *pf_monitor_memory_advice_json(const pf_queue_timings *timings)
{
    cJSON *object = cJSON_CreateObject();
    int64_t peaks[2] = {(int64_t)timings->peak_rss.max, (int64_t)timings->peak_device_memory.max};
    const char *names[2][2] = {{"peak_rss", "min_memory"},
                               {"peak_device_memory", "min_device_memory"}};
    for (int i = 0; i < 2; i++) {
        char suggested[32] = "";
        if (peaks[i] > 0)
            pf_queue_suggested_requirement(peaks[i], suggested, sizeof suggested);
        cJSON_AddNumberToObject(object, names[i][0], (double)(peaks[i] > 0 ? peaks[i] : 0));
        cJSON_AddStringToObject(object, names[i][1], suggested);
    }
    cJSON_AddNumberToObject(object, "headroom_percent",
                            (PF_QUEUE_SUGGESTED_HEADROOM - 1.0) * 100.0);
    return object;
}

cJSON *pf_monitor_logs_json(int64_t job_id, int32_t frame, const pf_queue_attempt_log *logs,
                            size_t count)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "job", (double)job_id);
    cJSON_AddNumberToObject(object, "frame", frame);
    cJSON *array = cJSON_AddArrayToObject(object, "attempts");
    for (size_t i = 0; i < count; i++) {
        cJSON *log = cJSON_CreateObject();
        cJSON_AddNumberToObject(log, "task", (double)logs[i].task_id);
        cJSON_AddNumberToObject(log, "first_frame", logs[i].first_frame);
        cJSON_AddNumberToObject(log, "last_frame", logs[i].last_frame);
        cJSON_AddNumberToObject(log, "attempt", logs[i].attempt);
        cJSON_AddStringToObject(log, "worker", logs[i].worker_name);
        cJSON_AddNumberToObject(log, "written_at", (double)logs[i].written_at);
        cJSON_AddStringToObject(log, "log", logs[i].text);
        cJSON_AddItemToArray(array, log);
    }
    return object;
}

static cJSON *stat_json(const pf_queue_stat *stat)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "count", (double)stat->count);
    cJSON_AddNumberToObject(object, "min_ms", stat->min);
    cJSON_AddNumberToObject(object, "median_ms", stat->median);
    cJSON_AddNumberToObject(object, "p95_ms", stat->p95);
    cJSON_AddNumberToObject(object, "max_ms", stat->max);
    cJSON_AddNumberToObject(object, "total_ms", stat->total);
    return object;
}

/* A sample of bytes: the same statistics as stat_json, named for bytes. */
static cJSON *bytes_json(const pf_queue_stat *stat)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "frames", (double)stat->count);
    cJSON_AddNumberToObject(object, "min", stat->min);
    cJSON_AddNumberToObject(object, "median", stat->median);
    cJSON_AddNumberToObject(object, "p95", stat->p95);
    cJSON_AddNumberToObject(object, "max", stat->max);
    return object;
}

cJSON *pf_monitor_timings_json(int64_t job_id, const pf_queue_timings *timings)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "job", (double)job_id);
    cJSON_AddNumberToObject(root, "frames", (double)timings->frames);
    cJSON_AddNumberToObject(root, "total_wall_ms", timings->total_wall_ms);
    cJSON_AddNumberToObject(root, "total_gpu_ms", timings->total_gpu_ms);
    cJSON *stages = cJSON_AddArrayToObject(root, "stages");
    for (size_t i = 0; i < timings->stage_count; i++) {
        const pf_queue_stage_stats *stage = &timings->stages[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "stage", stage->stage);
        cJSON_AddNumberToObject(row, "count", (double)stage->count);
        cJSON_AddNumberToObject(row, "skipped", (double)stage->skipped);
        cJSON_AddItemToObject(row, "wall", stat_json(&stage->wall));
        cJSON_AddItemToObject(row, "gpu", stat_json(&stage->gpu));
        cJSON_AddItemToArray(stages, row);
    }
    cJSON *resources = cJSON_AddObjectToObject(root, "per_frame_bytes");
    cJSON_AddItemToObject(resources, "peak_rss", bytes_json(&timings->peak_rss));
    cJSON_AddItemToObject(resources, "peak_device_memory",
                          bytes_json(&timings->peak_device_memory));
    cJSON_AddItemToObject(resources, "bytes_written", bytes_json(&timings->bytes_written));
    cJSON *builds = cJSON_AddArrayToObject(root, "builds");
    for (size_t i = 0; i < timings->build_count; i++) {
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "build", timings->builds[i].build);
        cJSON_AddNumberToObject(row, "frames", (double)timings->builds[i].frames);
        cJSON_AddItemToArray(builds, row);
    }
    cJSON *decisions = cJSON_AddArrayToObject(root, "decisions");
    for (size_t i = 0; i < timings->decision_count; i++) {
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "stage", timings->decisions[i].stage);
        cJSON_AddStringToObject(row, "decision", timings->decisions[i].decision);
        cJSON_AddNumberToObject(row, "count", (double)timings->decisions[i].count);
        cJSON_AddItemToArray(decisions, row);
    }
    cJSON *slowest = cJSON_AddArrayToObject(root, "slowest_frames");
    for (size_t i = 0; i < timings->slowest_count; i++) {
        cJSON *row = cJSON_CreateObject();
        cJSON_AddNumberToObject(row, "frame", timings->slowest[i].frame);
        cJSON_AddNumberToObject(row, "task", (double)timings->slowest[i].task_id);
        cJSON_AddNumberToObject(row, "wall_ms", timings->slowest[i].wall_ms);
        cJSON_AddItemToArray(slowest, row);
    }
    return root;
}

cJSON *pf_monitor_frames_json(int64_t job_id, const pf_queue_frame_details *details,
                              size_t limit)
{
    cJSON *root = cJSON_CreateObject();
    cJSON_AddNumberToObject(root, "job", (double)job_id);
    cJSON_AddNumberToObject(root, "count", (double)details->frame_count);
    cJSON *frames = cJSON_AddArrayToObject(root, "frames");
    for (size_t i = 0; i < details->frame_count && i < limit; i++) {
        const pf_queue_frame_detail *frame = &details->frames[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddNumberToObject(row, "frame", frame->frame);
        cJSON_AddNumberToObject(row, "task", (double)frame->task_id);
        cJSON_AddNumberToObject(row, "attempt", frame->attempt);
        cJSON_AddStringToObject(row, "worker", frame->worker_name);
        cJSON_AddNumberToObject(row, "wall_ms", frame->wall_ms);
        /* null where the worker did not measure it */
        const struct {
            const char *name;
            int64_t value;
        } sizes[] = {{"peak_rss_bytes", frame->peak_rss},
                     {"peak_device_bytes", frame->peak_device_memory},
                     {"bytes_written", frame->bytes_written}};
        for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
            if (sizes[k].value >= 0)
                cJSON_AddNumberToObject(row, sizes[k].name, (double)sizes[k].value);
            else
                cJSON_AddNullToObject(row, sizes[k].name);
        }
        cJSON *stages = cJSON_AddArrayToObject(row, "stages");
        for (size_t s = 0; s < frame->stage_count; s++) {
            const pf_queue_frame_stage *stage = &details->stages[frame->first_stage + s];
            cJSON *item = cJSON_CreateObject();
            cJSON_AddStringToObject(item, "stage", stage->stage);
            cJSON_AddNumberToObject(item, "wall_ms", stage->wall_ms);
            cJSON_AddBoolToObject(item, "skipped", stage->skipped);
            /* Reused: skipped because the frame before made the same output; every reuse
             * reason the planner writes says "reused" (core/render/stage_plan.c). */
            cJSON_AddBoolToObject(item, "reused",
                                  stage->skipped && strstr(stage->decision, "reused") != NULL);
            cJSON_AddStringToObject(item, "decision", stage->decision);
            cJSON_AddItemToArray(stages, item);
        }
        cJSON_AddItemToArray(frames, row);
    }
    return root;
}
