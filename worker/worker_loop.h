/*
 * The queue worker (DESIGN.md §7): a libuv loop that claims tasks, renders
 * them one at a time off the loop thread, writes each frame's EXR on a writer
 * thread while the next frame renders (frame_writer.h: the next task is
 * claimed as soon as the last has rendered, so at most two are held), renews
 * their leases by a heartbeat timer, completes or fails them fenced by the
 * lease token, reaps expired leases of dead workers, and drains on
 * SIGINT/SIGTERM. Every database call
 * runs on libuv's thread pool, serialized by one mutex around the one
 * connection. Core's log messages are routed into the worker's log
 * (event=core) while it runs. Tests hold a worker mid-frame from outside
 * (tests/worker/fault_inject.c), never through a hook in this code.
 */
#ifndef PF_WORKER_LOOP_H
#define PF_WORKER_LOOP_H

#include "storage_roots.h"

#include <stdint.h>

/* Idle poll backoff: 100 ms after work, doubling to 2 s while the queue is empty. */
#define PF_WORKER_POLL_MIN_MS 100
#define PF_WORKER_POLL_MAX_MS 2000

typedef struct pf_worker_config {
    const char *db_path;
    const char *name;          /* NULL: "<host>-<pid>" */
    const char *device;        /* NULL: automatic ($PHOTONFARM_DEVICE) */
    const char *tags;          /* "a,b" (pf_queue_tags_normalize'd); NULL or "": none */
    const char *cache_dir;     /* compiled-shader cache (pf_cli_cache_dir); NULL: none */
    const pf_storage *storage;  /* storage_roots.h: the roots (none: anywhere) */
    int once;                  /* exit as soon as a claim finds nothing eligible */
    int64_t max_frames;        /* 0: unlimited; else exit after this many frames */
    double idle_exit_seconds;  /* < 0: never; else exit after this long without work */
    double lease_seconds;      /* lease length; heartbeats renew it every third */
} pf_worker_config;

/* Runs the worker until it is told to stop; returns the process exit code
 * (0 clean, 1 runtime failure, 2 bad input such as a corrupt database). */
int pf_worker_run(const pf_worker_config *config);

#endif
