/*
 * monitor: the farm in a browser (issue 41). An HTTP server (libmicrohttpd) over the same
 * queue as every other command: a page embedded in the binary, the queue's state as JSON
 * under /api/..., live updates by Server-Sent Events, and job actions for whoever holds
 * the server's action token.
 *
 * One thread polls the queue and keeps a snapshot (jobs, workers) that every client is
 * served from, so N open pages cost the database what one does; a job's details are read
 * once per change of the snapshot, whoever asks. Every string from the database reaches
 * the page as JSON text and is shown as text (the page never parses it as HTML).
 */
#ifndef PF_MONITOR_H
#define PF_MONITOR_H

#include "pf_common.h"

#include <signal.h>
#include <stdint.h>

/* The monitor's default poll of the queue: well inside issue 41's "within 1 s". */
#define PF_MONITOR_DEFAULT_POLL_MS 500
/* Requests per second from one client address, and the burst above it: an open page asks
 * for at most ~8 resources per change, so this lets a dozen pages behind one address
 * follow a busy farm while a runaway script is answered 429. */
#define PF_MONITOR_DEFAULT_RATE 100
#define PF_MONITOR_BURST_SECONDS 2

typedef struct pf_monitor_config {
    const char *db_path; /* a queue file or a postgresql:// URL */
    const char *address; /* numeric IPv4 address to listen on, e.g. "127.0.0.1" */
    uint16_t port;       /* 0: any free port (reported through listening) */
    const char *token;   /* the action token; NULL: read-only, every action refused */
    int poll_ms;         /* 0: PF_MONITOR_DEFAULT_POLL_MS */
    /* Requests per second per client address (PF_MONITOR_BURST_SECONDS' worth at once);
     * beyond it 429 with Retry-After. 0: no limit. */
    double rate_per_second;
    /* Called once the server listens, with the port it got. */
    void (*listening)(uint16_t port, void *user);
    void *user;
    /* The file of frame of a job whose output pattern is stored as pattern, resolved
     * within the storage roots (0 when it is outside them or does not fit out); NULL: no
     * frame previews. */
    int (*frame_path)(const char *pattern, int64_t frame, char *out, size_t size, void *user);
} pf_monitor_config;

/* Whether address (numeric IPv4) is a loopback one (127.0.0.0/8). */
int pf_monitor_address_is_loopback(const char *address);

/*
 * Serves until *stop becomes non-zero (a signal handler sets it). Refused before anything
 * listens, PF_ERR_INVALID naming the cause: an address that is not numeric IPv4, or one
 * that is not loopback without a token (anyone who can reach it could act on the farm).
 * A queue that cannot be opened, or a port that cannot be bound, is that error.
 */
pf_status pf_monitor_run(const pf_monitor_config *config, volatile sig_atomic_t *stop,
                         pf_error *err);

#endif
