/*
 * One frame from an evaluated scene to a finished EXR, shared by `photonfarm
 * render` and the queue worker so the frame code exists once (DESIGN.md §4):
 *
 *   pf_scene_eval            → stage row "scene_eval"
 *   pf_render_frame          → the renderer's GPU stage rows
 *   pf_exr_write to a temporary name beside the output → stage row "exr_write"
 *
 * pf_frame_render stops there and hands the temporary back, so the caller can
 * re-check its lease before pf_frame_commit renames it into place (or
 * pf_frame_discard deletes it). Temporaries are named "<output>.partial-<tag>"
 * (and pf_exr_write's own "<that>.tmp-<pid>-<n>"), so every leftover of a
 * crashed worker for one output starts with "<output>.partial-" and
 * pf_frame_remove_stale can find it.
 */
#ifndef PF_FRAME_PIPELINE_H
#define PF_FRAME_PIPELINE_H

#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"

#include <stdatomic.h>
#include <stdint.h>

#define PF_FRAME_PATH_MAX 4096
/* Default image width when none is asked for (the height follows the camera). */
#define PF_FRAME_DEFAULT_WIDTH 640u
#define PF_FRAME_DEFAULT_HEIGHT 480u
/* Largest image side (pf_render_frame's own limit). */
#define PF_FRAME_MAX_EDGE 16384u

typedef struct pf_frame_request {
    const pf_scene *scene;
    const char *scene_path;        /* recorded as metadata */
    int64_t frame;                 /* 1-based */
    pf_render_settings settings;   /* width 0: PF_FRAME_DEFAULT_WIDTH, height from the camera */
    const char *output_path;       /* final path of the EXR */
    const char *temp_tag;          /* makes the temporary name unique (a lease token, a pid) */
    const char *device_name;       /* recorded as metadata */
    /* Checked between stages; non-zero stops the frame (NULL: never). Set
     * from another thread, e.g. when a lease is lost. */
    const atomic_int *abort;
} pf_frame_request;

/*
 * Whose fault a failed frame is. The queue worker fails the task under the
 * retry policy (and may block itself for the job) only for its own; the
 * others are the job's, which every worker would hit alike, so the job is
 * paused with the reason instead (issue 14).
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

typedef struct pf_frame_output {
    char final_path[PF_FRAME_PATH_MAX];
    char temp_path[PF_FRAME_PATH_MAX]; /* "" when no temporary exists */
    pf_frame_report report;            /* scene_eval, GPU stages, exr_write */
    uint32_t width, height;            /* as rendered */
    double total_ms;
    int aborted;                       /* the abort flag stopped it; nothing on disk */
    pf_frame_fault fault;              /* after a failure: whose it is */
} pf_frame_output;

/*
 * Renders request->frame to the temporary beside output_path and fills out.
 * On success the complete EXR (fsynced) lies at out->temp_path, unless
 * out->aborted (the abort flag was seen between stages: nothing is left on
 * disk). On failure nothing is left on disk, err names the scene/frame or
 * the file and out->fault says whose fault it is (scene evaluation: scene;
 * writing the EXR: output; rendering: worker).
 */
pf_status pf_frame_render(pf_renderer *renderer, const pf_frame_request *request,
                          pf_frame_output *out, pf_error *err);

/* Renames the temporary into place and fsyncs the directory. On failure the
 * temporary is removed, err names both paths and out->fault is output. */
pf_status pf_frame_commit(pf_frame_output *out, pf_error *err);

/*
 * Before anything renders: the output pattern's directory exists and this
 * process can create files in it (a probe file is made and removed), and a #
 * run lies in the file name. Fills absolute with the pattern made absolute
 * (workers may run elsewhere). PF_ERR_IO/PF_ERR_INVALID naming the directory.
 */
pf_status pf_frame_output_check(const char *pattern, char *absolute, size_t size, pf_error *err);

/* Host bytes per pixel a frame holds at once: the rendered image (11 float
 * channels: RGBA and the AOV layers) and the EXR writer's copy of it. */
#define PF_FRAME_HOST_BYTES_PER_PIXEL (2u * 11u * 4u)

/*
 * Whether a width x height frame fits in available_bytes of host memory
 * (0: half of this machine's physical memory), by PF_FRAME_HOST_BYTES_PER_PIXEL.
 * PF_ERR_INVALID naming the size, the estimate and the memory otherwise, so
 * that 16384x16384 (24 GB) is refused at once instead of rendering for
 * minutes and then running out of memory.
 */
pf_status pf_frame_memory_check(uint32_t width, uint32_t height, uint64_t available_bytes,
                                pf_error *err);

/* Deletes the temporary, if any (a lost lease, an error). */
void pf_frame_discard(pf_frame_output *out);

/*
 * Removes the leftovers of earlier attempts of one queue task at output_path:
 * "<output_path>.partial-t<task_id>-*" (the worker's temporaries are tagged
 * "t<task_id>-<lease token>", pf_frame_task_tag). Another task's temporary —
 * another job writing the same path under --force, a frame in flight — is
 * never touched. Returns how many files were removed.
 */
int pf_frame_remove_stale(const char *output_path, int64_t task_id);
/* The temporary-file tag of a queue task's attempt: "t<task_id>-<lease token>". */
void pf_frame_task_tag(int64_t task_id, const char *lease_token, char *out, size_t size);

/* Splits path into its directory ("." when none, "/" at the root) and its file name. */
void pf_frame_split_path(const char *path, char *dir, size_t dir_size, const char **base);

/* Replaces the first run of '#' in pattern with the zero-padded frame number
 * (a pattern without '#' is used as is). 0 if the result does not fit. */
int pf_frame_output_path(const char *pattern, int64_t frame, char *out, size_t size);

#endif
