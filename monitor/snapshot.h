/*
 * The monitor's shared view of the queue (snapshot.c): one thread reads the jobs and the
 * workers and keeps their JSON; a generation number counts the changes, and clients wait
 * on it for the next one (Server-Sent Events). Each poll first asks the queue whether
 * anything was committed since the last read (pf_queue_change_mark, one small query), and
 * reads it all only then, or after PF_SNAPSHOT_REFRESH_MS without a read: whether a
 * worker is alive depends on the clock as well as on the queue.
 */
#ifndef PF_MONITOR_SNAPSHOT_H
#define PF_MONITOR_SNAPSHOT_H

#include "pf_common.h"
#include "pf_queue.h"

#include <pthread.h>
#include <stdint.h>

#define PF_SNAPSHOT_REFRESH_MS 5000

typedef struct pf_snapshot {
    pthread_mutex_t lock;
    pthread_cond_t changed;    /* broadcast at every new generation, poke and stop */
    uint64_t generation;       /* 1 after the first read; +1 whenever the JSON changes */
    char *jobs_json;           /* owned, under lock */
    char *workers_json;
    int64_t reads;             /* full reads of the queue so far (bench: they do not grow
                                  with clients) */
    int64_t checks;            /* polls that found nothing committed since, and read no more */
    char mark[PF_QUEUE_MARK_MAX]; /* the poller's connection's mark before its last read */
    double read_at_ms;         /* when it was taken (pf_time_ms) */
    char error[PF_ERROR_MESSAGE_MAX]; /* the last read's failure, "" when it succeeded */
    int stopping, poked;
    int poll_ms;
    char *db_path;
    pthread_t thread;
} pf_snapshot;

/* Opens the queue, reads it once (so the first client has data) and starts the poller. */
pf_status pf_snapshot_start(pf_snapshot *snapshot, const char *db_path, int poll_ms,
                            pf_error *err);
/* Stops the poller; waits return at once from then on (pf_snapshot_wait gives 0), and
 * the last view can still be read. */
void pf_snapshot_stop(pf_snapshot *snapshot);
/* Frees everything, once nobody reads it any more. */
void pf_snapshot_free(pf_snapshot *snapshot);
/* A copy of the jobs' (jobs != 0) or workers' JSON (malloc'ed; NULL when out of memory)
 * and its generation. */
char *pf_snapshot_copy(pf_snapshot *snapshot, int jobs, uint64_t *generation);
/* Waits until the generation passes seen, at most timeout_ms; returns the current one (0
 * once stopping). */
uint64_t pf_snapshot_wait(pf_snapshot *snapshot, uint64_t seen, int timeout_ms);
/* Reads the queue now instead of at the next poll (after an action). */
void pf_snapshot_poke(pf_snapshot *snapshot);
/* The current generation. */
uint64_t pf_snapshot_generation(pf_snapshot *snapshot);

#endif
