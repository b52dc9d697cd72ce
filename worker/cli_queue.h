/*
 * What the queue commands (enqueue, worker, status, timings, cancel, pause,
 * resume, retry, workers) share: the database path rule (--db, else
 * $PHOTONFARM_DB, else ./farm.db; DESIGN.md §1), opening it with the queue's
 * own error message, and strict integer options.
 */
#ifndef PF_CLI_QUEUE_H
#define PF_CLI_QUEUE_H

#include "cli_options.h"
#include "pf_lpv.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_queue.h"

#include <stdint.h>

#define PF_CLI_DEFAULT_DB "farm.db"

/* given if non-NULL, else $PHOTONFARM_DB if set and non-empty, else "farm.db". */
const char *pf_cli_db_path(const char *given);

/*
 * Opens the queue at path for command. must_exist: a missing file is an error
 * (exit 2, "no queue database at PATH") instead of being created — query and
 * control commands never create an empty queue. Returns 0 with *out open, or
 * the exit code after printing the queue's message (a corrupt or non-SQLite
 * file → 2, and pf_queue_open leaves it untouched).
 */
int pf_cli_open_queue(const char *command, const char *path, int must_exist, pf_queue **out);

/*
 * --after JOB[,JOB] and --after-frames JOB[,JOB], repeatable (enqueue, depend): the jobs
 * a job waits for, as a whole (pf_cli_store_after) or frame by frame
 * (pf_cli_store_after_frames). A word that is not a job id, or more than
 * PF_QUEUE_DEPENDENCIES_MAX, is exit 2 naming it.
 */
typedef struct pf_cli_prerequisites {
    pf_queue_dependency jobs[PF_QUEUE_DEPENDENCIES_MAX];
    size_t count;
} pf_cli_prerequisites;
int pf_cli_store_after(const char *command, const pf_cli_option *option, const char *value);
int pf_cli_store_after_frames(const char *command, const pf_cli_option *option,
                              const char *value);

/* Strict decimal integer in [min, max] (no trailing text). 1 on success. */
int pf_cli_parse_int(const char *text, int64_t min, int64_t max, int64_t *out);

/*
 * The LPV options of render and enqueue (cli_lpv.c): -1 when arg is not one
 * of them, 0 when value was stored into *lpv, 2 after printing why it is
 * bad (naming the option and the accepted range).
 */
int pf_cli_lpv_option(const char *command, const char *arg, const char *value,
                      pf_lpv_settings *lpv);
/* 0 when the LPV settings fit buffers of max_buffer_bytes, else 2 after naming the option. */
int pf_cli_lpv_check(const char *command, const pf_lpv_settings *lpv, uint64_t max_buffer_bytes);
/*
 * Every render-settings option, one parser for render and enqueue
 * (cli_settings.c): --size, --quality, --spp, --seed, --photons,
 * --time-budget, --float, --no-aovs, --filter, --max-bounces, --budget-ms,
 * --target-relmse and the --lpv-* options. value is the next argument (NULL
 * at the end); *used_value says whether it was consumed (not for the flags).
 * Returns -1 when arg is none of them, 0 when stored into *settings, 2 after
 * printing why (naming the option and the accepted range).
 */
int pf_cli_settings_option(const char *command, const char *arg, const char *value,
                           pf_render_settings *settings, int *used_value);
/* The scene a job renders and how it is loaded. */
typedef struct pf_cli_scene {
    const char *path;
    pf_scene_load_options load; /* --allow-outside-scene-dir, --animation, --variant */
} pf_cli_scene;

/*
 * What render and enqueue parse alike, as rows of the one option table
 * (cli_options.h): every settings option above, stored into *settings by
 * pf_cli_settings_option, and --allow-outside-scene-dir, --animation and --variant into
 * *scene.
 */
#define PF_CLI_SETTINGS_OPTIONS 20
/* The settings rows that store into the pf_cli_scene, last in the table. */
#define PF_CLI_SCENE_OPTIONS 3
size_t pf_cli_settings_table(pf_render_settings *settings, pf_cli_scene *scene,
                             pf_cli_option rows[PF_CLI_SETTINGS_OPTIONS]);
/*
 * render's and enqueue's command line: own rows, then the settings rows, and
 * SCENE, the one positional argument (required). pf_cli_parse's returns.
 */
int pf_cli_parse_job(const char *name, const char *synopsis, const char *description,
                     const pf_cli_option *own, size_t own_count, pf_render_settings *settings,
                     pf_cli_scene *scene, int argc, char **argv, int *help);
/* What enqueue checks against: the maxStorageBufferRange every Vulkan device guarantees. */
#define PF_CLI_GUARANTEED_BUFFER_BYTES (128ull << 20)

#endif
