/*
 * The queue's records as the JSON the monitor serves (README "The monitor"): the same
 * fields `status`, `workers` and `timings` show. cJSON escapes every string; the page
 * shows them as text.
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

static cJSON *stat_json(const pf_queue_stat *stat)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "count", (double)stat->count);
    cJSON_AddNumberToObject(object, "min", stat->min);
    cJSON_AddNumberToObject(object, "median", stat->median);
    cJSON_AddNumberToObject(object, "p95", stat->p95);
    cJSON_AddNumberToObject(object, "max", stat->max);
    cJSON_AddNumberToObject(object, "total", stat->total);
    return object;
}

cJSON *pf_monitor_timings_json(const pf_queue_timings *timings)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "frames", (double)timings->frames);
    cJSON *stages = cJSON_AddArrayToObject(object, "stages");
    for (size_t i = 0; i < timings->stage_count; i++) {
        const pf_queue_stage_stats *stage = &timings->stages[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "stage", stage->stage);
        cJSON_AddNumberToObject(row, "count", (double)stage->count);
        cJSON_AddNumberToObject(row, "skipped", (double)stage->skipped);
        cJSON_AddItemToObject(row, "wall_ms", stat_json(&stage->wall));
        cJSON_AddItemToObject(row, "gpu_ms", stat_json(&stage->gpu));
        cJSON_AddItemToArray(stages, row);
    }
    cJSON *per_frame = cJSON_AddObjectToObject(object, "per_frame_bytes");
    cJSON_AddItemToObject(per_frame, "peak_rss", stat_json(&timings->peak_rss));
    cJSON_AddItemToObject(per_frame, "peak_device_memory",
                          stat_json(&timings->peak_device_memory));
    cJSON_AddItemToObject(per_frame, "bytes_written", stat_json(&timings->bytes_written));
    cJSON *decisions = cJSON_AddArrayToObject(object, "decisions");
    for (size_t i = 0; i < timings->decision_count; i++) {
        cJSON *row = cJSON_CreateObject();
        cJSON_AddStringToObject(row, "stage", timings->decisions[i].stage);
        cJSON_AddStringToObject(row, "decision", timings->decisions[i].decision);
        cJSON_AddNumberToObject(row, "count", (double)timings->decisions[i].count);
        cJSON_AddItemToArray(decisions, row);
    }
    return object;
}

cJSON *pf_monitor_frames_json(const pf_queue_frame_details *details, size_t limit)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "count", (double)details->frame_count);
    cJSON *frames = cJSON_AddArrayToObject(object, "frames");
    for (size_t i = 0; i < details->frame_count && i < limit; i++) {
        const pf_queue_frame_detail *frame = &details->frames[i];
        cJSON *row = cJSON_CreateObject();
        cJSON_AddNumberToObject(row, "frame", frame->frame);
        cJSON_AddNumberToObject(row, "attempt", frame->attempt);
        cJSON_AddStringToObject(row, "worker", frame->worker_name);
        cJSON_AddNumberToObject(row, "wall_ms", frame->wall_ms);
        cJSON_AddNumberToObject(row, "peak_rss", (double)frame->peak_rss);
        cJSON_AddNumberToObject(row, "peak_device_memory", (double)frame->peak_device_memory);
        cJSON_AddNumberToObject(row, "bytes_written", (double)frame->bytes_written);
        cJSON *stages = cJSON_AddArrayToObject(row, "stages");
        for (size_t s = 0; s < frame->stage_count; s++) {
            const pf_queue_frame_stage *stage = &details->stages[frame->first_stage + s];
            cJSON *item = cJSON_CreateObject();
            cJSON_AddStringToObject(item, "stage", stage->stage);
            cJSON_AddNumberToObject(item, "wall_ms", stage->wall_ms);
            cJSON_AddBoolToObject(item, "skipped", stage->skipped);
            cJSON_AddStringToObject(item, "decision", stage->decision);
            cJSON_AddItemToArray(stages, item);
        }
        cJSON_AddItemToArray(frames, row);
    }
    return object;
}
