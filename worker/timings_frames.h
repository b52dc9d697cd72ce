/* timings JOB --frames (issue 42): every completed frame of a job, one by one; and the
 * JSON printer both of timings' reports share. */
#ifndef PF_TIMINGS_FRAMES_H
#define PF_TIMINGS_FRAMES_H

#include "pf_queue.h"

#include <cjson/cJSON.h>

#include <stdint.h>

/* Prints the job's frames in format ("table", "csv" or "json"): each frame's worker,
 * attempt, wall time per stage, peak memory, bytes written and decisions. 0, or the exit
 * code after printing why. */
int pf_timings_print_frames(pf_queue *queue, int64_t job_id, const char *format);

/* Prints root as JSON on stdout and deletes it: 0, or 1 after printing why. */
int pf_timings_print_json(cJSON *root);

#endif
