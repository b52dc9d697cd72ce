/* The queue's records as the monitor's JSON (json_views.c); each call returns a new
 * cJSON item owned by the caller. */
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
cJSON *pf_monitor_timings_json(const pf_queue_timings *timings);
/* At most limit frames (a page shows no more), with the total count. */
cJSON *pf_monitor_frames_json(const pf_queue_frame_details *details, size_t limit);

#endif
