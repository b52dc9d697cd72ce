/*
 * What a frame's outcome means for the queue (issue 14, issue 45): whose
 * fault a failure is, and the tag a task's attempt gives its temporaries.
 * core/render reports where a frame failed (pf_frame_failure); the worker
 * decides from it, and from its own checks before the render, whether the
 * task fails under the retry policy or the job is paused.
 */
#ifndef PF_FRAME_FAULT_H
#define PF_FRAME_FAULT_H

#include "pf_render.h"

#include <stddef.h>
#include <stdint.h>

/*
 * The queue worker fails the task under the retry policy (and may block itself
 * for the job) only for its own faults; the others are the job's, which every
 * worker would hit alike, so the job is paused with the reason instead.
 */
typedef enum pf_frame_fault {
    PF_FRAME_FAULT_WORKER = 0, /* rendering failed here: device, memory, limits */
    PF_FRAME_FAULT_SCENE,      /* the job's scene cannot be read or evaluated */
    PF_FRAME_FAULT_SETTINGS,   /* the job's stored settings cannot be parsed */
    PF_FRAME_FAULT_OUTPUT,     /* the job's output storage refused the frame */
    PF_FRAME_FAULT_REFUSED     /* the job asks for what this farm refuses (a path outside
                                  the storage roots): the task fails for good */
} pf_frame_fault;

/* "worker", "scene", "settings", "output", "refused". */
const char *pf_frame_fault_name(pf_frame_fault fault);

/* Whose fault a frame that failed where failed says is. */
pf_frame_fault pf_frame_fault_of(pf_frame_failure failed);

/* The temporary-file tag of a queue task's attempt: "t<task_id>-<lease token>". */
void pf_frame_task_tag(int64_t task_id, const char *lease_token, char *out, size_t size);

/*
 * Removes the leftovers of earlier attempts of one queue task at output_path:
 * "<output_path>.partial-t<task_id>-*". Another task's temporary (another job
 * writing the same path under --force, a frame in flight) is never touched.
 * Returns how many files were removed.
 */
int pf_frame_remove_stale(const char *output_path, int64_t task_id);

#endif
