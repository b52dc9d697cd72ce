/*
 * What the queue commands (enqueue, worker, status, timings, cancel, pause,
 * resume, retry, workers) share: the database path rule (--db, else
 * $PHOTONFARM_DB, else ./farm.db; DESIGN.md §1), opening it with the queue's
 * own error message, and strict integer options.
 */
#ifndef PF_CLI_QUEUE_H
#define PF_CLI_QUEUE_H

#include "pf_lpv.h"
#include "pf_render.h"
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

/* Strict decimal integer in [min, max] (no trailing text). 1 on success. */
int pf_cli_parse_int(const char *text, int64_t min, int64_t max, int64_t *out);

/* Longest --time-budget accepted: a week, in seconds. */
#define PF_CLI_MAX_TIME_BUDGET_S 604800.0

/*
 * Parses a --time-budget value: seconds, more than 0 and at most
 * PF_CLI_MAX_TIME_BUDGET_S, into milliseconds. 1 on success, 0 otherwise.
 */
int pf_cli_parse_time_budget(const char *text, double *milliseconds);

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
 * --filter, --max-bounces, --budget-ms and --target-relmse of render and
 * enqueue (cli_sampling.c): -1 when arg is none of them, 0 when stored into
 * *settings, 2 after printing why the value is bad.
 */
int pf_cli_sampling_option(const char *command, const char *arg, const char *value,
                           pf_render_settings *settings);
/* Most photons per frame (fast) or pass (final) accepted by --photons. */
#define PF_CLI_MAX_PHOTONS 100000000ll
/* What enqueue checks against: the maxStorageBufferRange every Vulkan device guarantees. */
#define PF_CLI_GUARANTEED_BUFFER_BYTES (128ull << 20)

#endif
