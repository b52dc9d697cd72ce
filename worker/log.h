/*
 * Structured worker log: one line per event, key=value pairs, so a log
 * shipper (or grep) can follow a frame across workers:
 *   ts=2026-11-21T06:54:52.123Z level=info event=claimed job=3 frame=12 worker=host-123
 * Lines go to stderr in one write each, so lines of several threads never mix.
 */
#ifndef PF_WORKER_LOG_H
#define PF_WORKER_LOG_H

#include "pf_common.h"

/* Hook called before and after each line (the progress bar clears and redraws
 * itself around log lines on a terminal). NULL: none. */
typedef void (*pf_wlog_hook)(int before, void *user);
void pf_wlog_set_hook(pf_wlog_hook hook, void *user);

/* Runs fn(user) under the log's lock, so output it writes (the progress line)
 * never interleaves with a log line written from another thread. */
void pf_wlog_exclusive(void (*fn)(void *user), void *user);

/*
 * Writes "ts=... level=LEVEL event=EVENT " followed by the formatted fields.
 * Field values that may hold spaces should be quoted by the caller with
 * pf_wlog_quote. Thread-safe.
 */
void pf_wlog(pf_log_level level, const char *event, const char *format, ...)
    __attribute__((format(printf, 3, 4)));

/*
 * Routes core's pf_log messages (scene warnings, Vulkan validation, pipeline
 * cache notices) into this log as event=core lines with the message quoted,
 * so the worker's log is one format a shipper can parse. The worker installs
 * it at start.
 */
void pf_wlog_capture_core(void);

/*
 * Keeps a copy of every line logged from now on (any thread) until pf_wlog_capture_end:
 * the worker captures the lines of each task attempt and stores them in the queue
 * (issue 41). At most PF_WLOG_CAPTURE_MAX bytes are kept: the first lines and the last,
 * with a line in between saying how many were left out. A capture already running is
 * discarded.
 */
#define PF_WLOG_CAPTURE_MAX (64 * 1024)
/* owner: the attempt the capture is for (pf_wlog_about's), NULL for none in particular. */
void pf_wlog_capture_begin(const void *owner);
/* Ends the capture: its text (malloc'ed), or NULL when none ran or out of memory. */
char *pf_wlog_capture_end(void);

/*
 * Lines about an attempt logged while its capture is not running (the worker renders the
 * next task while the last one's frames are written): kept here, under the log's lock, for
 * its log, at most PF_WLOG_LATE_MAX bytes (later ones are counted). Zero-initialised.
 */
#define PF_WLOG_LATE_MAX (8 * 1024)
typedef struct pf_wlog_late {
    char *text;
    size_t used;
    long dropped;
} pf_wlog_late;
/*
 * pf_wlog for a line about owner's attempt: into the capture while it is owner's, else
 * into late (when not NULL), never into another attempt's capture.
 */
void pf_wlog_about(const void *owner, pf_wlog_late *late, pf_log_level level,
                   const char *event, const char *format, ...)
    __attribute__((format(printf, 5, 6)));
/* late's lines (malloc'ed, with a line saying how many were left out; NULL for none), and
 * late emptied. */
char *pf_wlog_late_take(pf_wlog_late *late);

/* Writes text into out as a double-quoted value with '"', '\\' and control
 * characters escaped, truncating to fit; returns out. */
const char *pf_wlog_quote(const char *text, char *out, size_t size);

#endif
