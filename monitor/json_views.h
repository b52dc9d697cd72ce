/* The queue's records as JSON (json_views.c): the monitor's, and the timings command's;
 * each call returns a new cJSON item owned by the caller. */
#ifndef PF_MONITOR_JSON_VIEWS_H
#define PF_MONITOR_JSON_VIEWS_H

#include "pf_queue.h"

#include <cjson/cJSON.h>
#include <stdint.h>

cJSON *pf_monitor_job_json(const pf_queue_job *job);
cJSON *pf_monitor_worker_json(const pf_queue_worker_info *worker);
cJSON *pf_monitor_worker_stats_json(const pf_queue_worker_stats *stats, size_t count);
cJSON *pf_monitor_tasks_json(const pf_queue_task_info *tasks, size_t count);
cJSON *pf_monitor_failures_json(const pf_queue_failure *failures, size_t count);
/* status's advice for a job whose frames ran out of memory: the largest peaks its finished
 * frames recorded (0: none) and the requirements that would keep it off smaller workers
 * ("" where nothing was measured). */
cJSON *pf_monitor_memory_advice_json(const pf_queue_timings *timings);
/* A frame's attempts' logs (`log JOB FRAME --format json`, /api/jobs/N/frames/F/log). */
cJSON *pf_monitor_logs_json(int64_t job_id, int32_t frame, const pf_queue_attempt_log *logs,
                            size_t count);
/* `timings JOB --format json`: stage statistics, per-frame bytes, builds, decisions,
 * slowest frames. */
cJSON *pf_monitor_timings_json(int64_t job_id, const pf_queue_timings *timings);
/* `timings JOB --frames --format json`: at most limit frames, with the total count. */
cJSON *pf_monitor_frames_json(int64_t job_id, const pf_queue_frame_details *details,
                              size_t limit);

#endif
