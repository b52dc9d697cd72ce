/*
 * Helpers for the worker/queue CLI tests: run photonfarm and capture its
 * output, start worker processes in the background, write a tiny scene,
 * inspect output directories and the queue.
 */
#ifndef WORKER_TEST_UTIL_H
#define WORKER_TEST_UTIL_H

#include "pf_queue.h"

#include <stddef.h>
#include <sys/types.h>

#define WT_PATH_MAX 2048

/* Runs "photonfarm ARGS" (ARGS shell-quoted by the caller) with stdout+stderr
 * in output_path (NULL: $PF_TEST_TMP/last-run.log); returns its exit code
 * (-1 if it did not exit normally). */
int wt_run(const char *arguments, const char *output_path);

/* Runs "photonfarm enqueue ARGS" (output in log_path, as wt_run) and returns
 * the job id it printed; 0 (and the calling test fails) when it did not exit 0. */
int64_t wt_enqueue(const char *arguments, const char *log_path);

/* Occurrences of text in the file at path (0 when it cannot be read). */
int wt_count_in_file(const char *path, const char *text);
/* The photonfarm/frame attribute of the EXR at path; -1 when it cannot be read or has none. */
int wt_exr_frame(const char *path);

/* Whether file contains text (prints the file when it does not). */
int wt_file_contains(const char *path, const char *text);
/* Reads a whole file into a malloc'ed NUL-terminated buffer (NULL if missing). */
char *wt_read_file(const char *path, size_t *size);

/* Starts "photonfarm ARGS..." (argv-style, NULL-terminated) in the background
 * with stdout+stderr appended to log_path and extra environment, one
 * "KEY=VALUE" per line (NULL for none); returns its pid. */
pid_t wt_spawn(const char *const *arguments, const char *log_path, const char *environment);
/*
 * The environment (for wt_spawn) of a worker run with fault_inject.c
 * preloaded after whatever is preloaded already: files under dir fail as on
 * a read-only (kind "read-only") or full ("full") volume while flip exists
 * (NULL: never), and each frame's temporary waits hold_ms before its rename.
 * Needs $PF_FAULT_INJECT_LIB (set by CMake for the tests that use it).
 */
void wt_fault_environment(char *out, size_t size, const char *dir, const char *flip,
                          const char *kind, int hold_ms);

/* Waits up to timeout_ms for pid; returns its exit code, 128+signal when
 * killed, or -1 on timeout (the process is then killed). */
int wt_wait(pid_t pid, int timeout_ms);

/* Writes a one-triangle glTF lit by a point light, with asset.extras.frames =
 * frame_count, to path. */
void wt_write_tiny_scene(const char *path, int frame_count);
/* The tiny scene's triangle, unlit (its colour to the camera, whatever the light), red, and
 * blue in its KHR_materials_variants variant "blue" (index 1; "red" is index 0). */
void wt_write_variant_scene(const char *path);

/* Creates (if needed) and empties directory $PF_TEST_TMP/name; fills out. */
const char *wt_fresh_dir(const char *name, char *out, size_t size);
/* Number of entries in dir whose name contains text ("" counts every file). */
int wt_count_files(const char *dir, const char *text);

/* Opens the queue at path (a failed open fails the calling test). */
pf_queue *wt_open_queue(const char *path);
/* The count a query of the queue file gives (direct SQL, read-only): sql's ?1 is id, its
 * ?2 text (NULL: none); -1 if it cannot be run. */
int wt_count_query(const char *db_path, const char *sql, int64_t id, const char *text);
/* Number of stage rows for task_id in the queue file (direct SQL). */
int wt_stage_rows_for_task(const char *db_path, int64_t task_id, const char *stage);
/* snprintf that reports truncation by failing the current test (paths in
 * tests are short; a silent cut would test the wrong file). */
void wt_format(char *out, size_t size, const char *format, ...)
    __attribute__((format(printf, 3, 4)));
/* Sleeps ms milliseconds. */
void wt_sleep_ms(int ms);

#endif
