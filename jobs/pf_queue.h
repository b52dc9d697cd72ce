/*
 * jobs: the render queue on one SQLite file (DESIGN.md §6). Jobs are split
 * into tasks (one frame or a chunk of frames); workers claim a task under a
 * lease with a random token, renew it by heartbeat, and complete, fail or
 * release it fenced by that token. A reaper returns expired leases; failures
 * back off exponentially, stop at max attempts, and a worker that keeps
 * failing one job's tasks is blocked for that job.
 *
 * Concurrency: many processes may share one file. A pf_queue is one SQLite
 * connection: use it from one thread at a time, and never across fork() (the
 * child opens its own). Every write is one short BEGIN IMMEDIATE transaction.
 *
 * Times are integer milliseconds since the Unix epoch from the queue's clock
 * (wall clock by default, replaceable with pf_queue_set_clock so tests control
 * time). Wall clock, not monotonic: leases are compared across processes.
 *
 * Status conventions beyond pf_common.h: PF_ERR_IO is a database failure
 * (busy past every retry, disk full, ...); PF_ERR_INVALID from heartbeat,
 * complete, fail or release means exactly "lease lost": the token is not the
 * current lease of a running task (reaped, canceled, or taken over), and the
 * caller must stop that work and write nothing.
 */
#ifndef PF_QUEUE_H
#define PF_QUEUE_H

#include "pf_common.h"

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- Frame ranges -------------------------------------------------------- */

/* Bound on frames in one range, so a typo ("1-1000000000") fails fast instead
 * of allocating gigabytes; 10x the 100,000-frame job of the issue's benchmark. */
#define PF_FRAME_RANGE_MAX_FRAMES 1000000
/* Largest frame number accepted (fits the 4-digit..9-digit "####" patterns). */
#define PF_FRAME_NUMBER_MAX 999999999

/* A parsed frame range: distinct frame numbers in ascending order. */
typedef struct pf_frame_list {
    int32_t *frames;
    size_t count;
} pf_frame_list;

/*
 * Parses a comma-separated list of items "A" or "A-B" or "A-BxS" (S = step)
 * with 0 <= A <= B <= PF_FRAME_NUMBER_MAX and S >= 1, e.g. "1-48", "1-48x2",
 * "1,5,9-12". Spaces around items are allowed. On success out holds the frames
 * sorted ascending (free with pf_frame_list_free). Fails with PF_ERR_INVALID,
 * naming the offending item, for: empty text or item, non-numeric text,
 * reversed range, zero/negative step, a frame listed twice (overlapping
 * items), more than PF_FRAME_RANGE_MAX_FRAMES frames; out is then empty.
 */
pf_status pf_frame_range_parse(const char *text, pf_frame_list *out, pf_error *err);
/* Frees out->frames and empties out (safe on an empty or zeroed list). */
void pf_frame_list_free(pf_frame_list *list);

/* ---- Opening ------------------------------------------------------------- */

typedef struct pf_queue pf_queue;

/* A clock in ms since the epoch; user is passed through. */
typedef int64_t (*pf_queue_clock)(void *user);

/* Zero in any field selects the default named beside it. */
typedef struct pf_queue_options {
    int busy_timeout_ms;        /* 5000: SQLite's own wait for a lock */
    int64_t lease_ms;           /* 30000: lease length from claim/heartbeat */
    int64_t backoff_base_ms;    /* 2000: delay after a first failure */
    int64_t backoff_cap_ms;     /* 300000: ceiling of the doubling delay */
    int block_after_failures;   /* 3: distinct tasks of one job a worker may fail */
    int64_t worker_alive_ms;    /* 90000: a worker that registered no lease and was heard
                                 * from within this is live */
    pf_queue_clock clock;       /* NULL: the wall clock (tests inject their own) */
    void *clock_user;
} pf_queue_options;

/*
 * Opens (creating if missing) the queue database at path, migrating its
 * schema to the current version, with WAL, busy_timeout and foreign keys on.
 * options may be NULL (all defaults). An existing file is first checked
 * without writing: if it is not an SQLite database, is truncated or corrupt,
 * or is an SQLite database of something other than a photonfarm queue, open
 * fails with PF_ERR_FORMAT naming the file, and the file is left byte for
 * byte as it was. A queue from a newer photonfarm → PF_ERR_UNSUPPORTED.
 * Other failures (unwritable directory, ...) → PF_ERR_IO. *out is NULL on
 * failure.
 *
 * A "postgres://" or "postgresql://" URL (libpq's syntax) opens the queue
 * on PostgreSQL instead, with the same semantics: the schema is created on
 * first use, a newer one is PF_ERR_UNSUPPORTED, and a server that cannot be
 * reached, a malformed URL or refused credentials are PF_ERR_INVALID naming
 * the cause; messages show the URL with its password hidden.
 */
pf_status pf_queue_open(const char *path, const pf_queue_options *options, pf_queue **out,
                        pf_error *err);
/* Closes the connection (NULL is a no-op). */
void pf_queue_close(pf_queue *queue);
/* 1 when db names a PostgreSQL queue (a postgres:// or postgresql:// URL), 0 for a file. */
int pf_queue_is_url(const char *db);

/* Schema version this build creates and understands. */
#define PF_QUEUE_SCHEMA_VERSION 7

/* Current schema version recorded in the file (fills *version). */
pf_status pf_queue_schema_version(pf_queue *queue, int *version, pf_error *err);

/* Replaces the queue's clock (NULL restores the wall clock). */
void pf_queue_set_clock(pf_queue *queue, pf_queue_clock clock, void *user);
/* The queue's current time in ms. */
int64_t pf_queue_now(pf_queue *queue);

/* ---- Enqueue ------------------------------------------------------------- */

typedef struct pf_queue_job pf_queue_job;

/*
 * Whether the job being enqueued conflicts with other, an unfinished job
 * (queued, running or paused; only job_id, status, parameters_json,
 * frame_range and output_pattern are filled): nonzero refuses it, with
 * reason (NUL-terminated, at most reason_size bytes) as the error message.
 */
typedef int (*pf_queue_conflict_fn)(const pf_queue_job *other, void *user, char *reason,
                                    size_t reason_size);

/* A job a job waits for (issue 42). */
typedef struct pf_queue_dependency {
    int64_t job_id; /* the prerequisite */
    bool per_frame; /* frame n waits for frame n of it (its tasks whose frames overlap the
                       task's: conservative where the two jobs step differently); false:
                       every frame waits until the whole prerequisite is done */
} pf_queue_dependency;

/* Prerequisites one call may name. */
#define PF_QUEUE_DEPENDENCIES_MAX 64

typedef struct pf_queue_job_spec {
    const char *scene_path;      /* required; stored as given */
    const char *parameters_json; /* opaque JSON text (size, quality, spp, seed...); NULL → "{}" */
    const char *frame_range;     /* pf_frame_range_parse syntax */
    const char *output_pattern;  /* required, e.g. "out/frame_####.exr" */
    int priority;                /* higher is claimed first */
    int max_attempts;            /* 0 → 3 */
    int frames_per_task;         /* 0 → 1 */
    /* NULL: no check. Run inside the insert's own write transaction, so two
     * enqueues racing each other cannot both pass it (e.g. two jobs writing
     * the same files). */
    pf_queue_conflict_fn conflicts;
    void *conflicts_user;
    /* Requirements (issue 42): a claim takes the job's tasks only for a worker that meets
     * them all. NULL, "" or 0: none. */
    const char *requires_device;  /* "gpu" or "cpu" */
    int64_t min_device_memory;    /* bytes */
    int64_t min_host_memory;      /* bytes */
    const char *required_tags;    /* every one (pf_queue_tags_normalize syntax) */
    /* The jobs it waits for (pf_queue_add_dependencies' rules); after_count 0: none. */
    const pf_queue_dependency *after;
    size_t after_count;
} pf_queue_job_spec;

/* Headroom over the largest measured peak in a suggested memory requirement (status's and
 * the monitor's advice for a job that ran out of memory), and its step. */
#define PF_QUEUE_SUGGESTED_HEADROOM 1.25
#define PF_QUEUE_SUGGESTED_STEP (256ll << 20)
/* peak (bytes) with headroom, rounded up to a step, as --min-memory reads it ("6G",
 * "768M"). */
void pf_queue_suggested_requirement(int64_t peak, char *out, size_t size);

/* "a gpu with >= 24.0 GiB of device memory, >= 64.0 GiB of memory and the tags a,b", for
 * messages ("any device" when nothing is required of it). */
void pf_queue_requirements_text(const char *device, int64_t min_device_memory,
                                int64_t min_host_memory, const char *tags, char *out,
                                size_t size);

/* How many registered workers, alive or not, meet spec's requirements (the other fields
 * are not read): enqueue warns when none ever has. */
pf_status pf_queue_workers_meeting(pf_queue *queue, const pf_queue_job_spec *spec,
                                   int64_t *count, pf_error *err);

/*
 * Inserts a job and its tasks in one transaction. Consecutive frames of the
 * range are grouped into tasks of up to frames_per_task frames; a task covers
 * an arithmetic run first..last by step, so "1,5,9-12" with 2 per task gives
 * {1,5}, {9,10}, {11,12}. Invalid spec (missing field, bad range, parameters
 * that are not JSON, max_attempts or frames_per_task < 0, a prerequisite that
 * is unknown or named twice) → PF_ERR_INVALID and nothing inserted; a conflict
 * (spec->conflicts) → PF_ERR_INVALID with its reason and nothing inserted.
 * Fills *job_id.
 */
pf_status pf_queue_enqueue(pf_queue *queue, const pf_queue_job_spec *spec, int64_t *job_id,
                           pf_error *err);

/*
 * Makes job_id wait for the jobs in after[0..count), in one transaction: a claim takes
 * none of its tasks until each prerequisite is done (per_frame: until the prerequisite's
 * tasks overlapping the task's frames are). A prerequisite that fails or is canceled
 * leaves the job blocked (pf_queue_job.status) until it is retried. Refused with
 * PF_ERR_INVALID naming the cause, nothing added: an unknown job or prerequisite, a job
 * that has ended (done, failed, canceled), a prerequisite named twice or already waited
 * for, the job itself, or a cycle (the prerequisite waits for job_id, directly or through
 * others).
 */
pf_status pf_queue_add_dependencies(pf_queue *queue, int64_t job_id,
                                    const pf_queue_dependency *after, size_t count,
                                    pf_error *err);

/* ---- Workers ------------------------------------------------------------- */

#define PF_QUEUE_NAME_MAX 128

typedef struct pf_queue_worker_spec {
    const char *name;   /* unique per queue, 1..PF_QUEUE_NAME_MAX-1 bytes */
    const char *host;   /* NULL → "" */
    int64_t pid;
    const char *device; /* NULL → "" */
    int64_t lease_ms;   /* its lease: silent for this long, it counts as dead (0: the
                         * queue's worker_alive_ms) */
    /* Capabilities (issue 42), detected by the worker at start; 0 or NULL: unknown. */
    const char *device_type; /* "gpu" or "cpu" */
    int64_t device_memory;   /* bytes of the device's largest device-local heap */
    int64_t host_memory;     /* bytes of RAM */
    int64_t cores;           /* online CPU cores */
    const char *tags;        /* "a,b": sorted, distinct (pf_queue_tags_normalize) */
} pf_queue_worker_spec;

#define PF_QUEUE_TAGS_MAX 256 /* bytes of a worker's tag list, with its terminator */
#define PF_QUEUE_TAG_MAX 64   /* bytes of one tag, with its terminator */

/*
 * Tags as stored: every comma- or space-separated word of text (letters, digits,
 * '.', '_', '-'; 1..PF_QUEUE_TAG_MAX-1 bytes), sorted and distinct, joined by ','.
 * A bad word, or a list over PF_QUEUE_TAGS_MAX, is PF_ERR_INVALID naming it.
 */
pf_status pf_queue_tags_normalize(const char *text, char *out, size_t size, pf_error *err);

/*
 * Registers a worker, or re-registers one of the same name (a restart: host,
 * pid, device and start time are replaced, it becomes live again, and its
 * blocks stay). Fills *worker_id. Bad name → PF_ERR_INVALID.
 */
pf_status pf_queue_worker_register(pf_queue *queue, const pf_queue_worker_spec *spec,
                                   int64_t *worker_id, pf_error *err);
/* Records that the worker is alive while idle (claims and lease heartbeats
 * also do). Unknown worker → PF_ERR_INVALID. */
pf_status pf_queue_worker_heartbeat(pf_queue *queue, int64_t worker_id, pf_error *err);
/* Marks a worker stopped (clean exit): no longer counted as live. */
pf_status pf_queue_worker_stop(pf_queue *queue, int64_t worker_id, pf_error *err);

/* ---- Claim and lease ----------------------------------------------------- */

#define PF_QUEUE_TOKEN_CHARS 32 /* 128 random bits in lowercase hex */

typedef struct pf_queue_task {
    int64_t task_id;
    int64_t job_id;
    int32_t first_frame, last_frame, frame_step, frame_count;
    int attempt;                /* 1 for the first counted attempt */
    int64_t lease_expires;
    char lease_token[PF_QUEUE_TOKEN_CHARS + 1];
} pf_queue_task;

/*
 * Claims one task for worker_id under a fresh lease (lease_ms) in one
 * UPDATE ... RETURNING, so two claimers can never get the same task. Only
 * queued tasks whose backoff has passed and that wait for no other job
 * (pf_queue_add_dependencies), of queued/running jobs, for which the worker is
 * not blocked and whose requirements it meets, are candidates. Order: job priority (highest
 * first), then frame affinity — the job preferred_job (0: none) and within it
 * the first task after after_frame, wrapping round to its earlier tasks —
 * then lower job id, then lower first frame. The job becomes running at its
 * first claim and stays so (a release does not make it queued again). Priority comes before affinity
 * so raising a job's priority takes effect at the next claim rather than when
 * every worker has finished its current job. *claimed tells whether a task
 * was taken (false: nothing eligible, out untouched). Unknown worker →
 * PF_ERR_INVALID.
 */
pf_status pf_queue_claim(pf_queue *queue, int64_t worker_id, int64_t preferred_job,
                         int32_t after_frame, pf_queue_task *out, bool *claimed, pf_error *err);

/*
 * Renews the lease of the running task holding token for lease_ms from now
 * (and the worker's heartbeat). Lease lost → PF_ERR_INVALID "lease lost",
 * nothing changed; the caller must abandon the task. Fills *lease_expires if
 * non-NULL.
 */
pf_status pf_queue_heartbeat(pf_queue *queue, const char *token, int64_t *lease_expires,
                             pf_error *err);

typedef struct pf_queue_stage_row {
    int32_t frame;             /* one of the task's frames */
    const char *stage;         /* 1..63 bytes, e.g. "bih_build" */
    double wall_ms;            /* >= 0 */
    double gpu_ms;             /* < 0 (PF_QUEUE_NO_GPU_MS): no GPU time → stored NULL */
    const char *counters_json; /* NULL or JSON text */
    bool skipped;
    const char *reason;        /* why skipped, or the decision a stage that ran took
                                  (bih_build: "refit: ..."); NULL when none */
    const char *build;         /* the renderer's version ("0.1.0+<git revision>"), so a
                                  frame can be traced to the build that rendered it;
                                  NULL when unknown */
} pf_queue_stage_row;

#define PF_QUEUE_NO_GPU_MS (-1.0)
#define PF_QUEUE_STAGE_NAME_MAX 64

/*
 * Marks the task holding token done and inserts all its stage rows, in one
 * transaction guarded by the token: either all of it happens or none. A
 * repeat with the same token after success changes nothing and returns PF_OK
 * with *repeated = true (repeated may be NULL). Lease lost → PF_ERR_INVALID,
 * nothing written. A row for a frame outside the task, a bad stage name,
 * negative wall time or counters that are not JSON → PF_ERR_INVALID naming
 * the row, nothing written. Updates the job's status (done when every task is).
 */
pf_status pf_queue_complete(pf_queue *queue, const char *token, const pf_queue_stage_row *rows,
                            size_t row_count, bool *repeated, pf_error *err);

/* What one frame took (issue 42), in bytes; -1: not measured. */
typedef struct pf_queue_frame_resources {
    int32_t frame;              /* one of the task's frames, at most one entry each */
    int64_t peak_rss;           /* the worker's peak resident memory during the frame */
    int64_t peak_device_memory; /* its device's peak memory during the frame */
    int64_t bytes_written;      /* the frame's file */
} pf_queue_frame_resources;

/*
 * pf_queue_complete, and each frame's resources stored beside its stage rows in the same
 * transaction. A frame outside the task or listed twice, or a value below -1, is
 * PF_ERR_INVALID naming it, nothing written.
 */
pf_status pf_queue_complete_frames(pf_queue *queue, const char *token,
                                   const pf_queue_stage_row *rows, size_t row_count,
                                   const pf_queue_frame_resources *frames, size_t frame_count,
                                   bool *repeated, pf_error *err);

/*
 * Records a failure of the task holding token (a task_failures row with the
 * attempt, worker and error text) and either requeues it eligible after
 * backoff_base_ms * 2^(attempt-1), capped at backoff_cap_ms, or marks it
 * failed when attempt has reached the job's max_attempts. If the worker has
 * now failed block_after_failures distinct tasks of the job, it is blocked
 * for that job. Lease lost → PF_ERR_INVALID, nothing recorded.
 */
pf_status pf_queue_fail(pf_queue *queue, const char *token, const char *error_text,
                        pf_error *err);

/*
 * The task holding token failed for a reason that is its job's, not the
 * worker's: the job's output storage refused the frame (read-only, full,
 * missing) or its scene cannot be read, so every worker would fail it alike.
 * In one transaction: the failure is recorded (pf_queue_failure.job_fault),
 * the task goes back queued without counting the attempt, no worker is
 * blocked, and a queued or running job is paused with error_text as its
 * pause reason (pf_queue_job.pause_reason and note; a job already paused
 * keeps its first reason). pf_queue_resume continues it once the cause is
 * fixed. Lease lost → PF_ERR_INVALID, nothing recorded.
 */
pf_status pf_queue_fail_job(pf_queue *queue, const char *token, const char *error_text,
                            pf_error *err);

/*
 * The task holding token can never render: its job asks for something this
 * farm refuses (a path outside the storage roots). The task fails at once,
 * without retries; the failure is recorded as the job's (job_fault) and no
 * worker is blocked. Lease lost → PF_ERR_INVALID, nothing recorded.
 */
pf_status pf_queue_reject(pf_queue *queue, const char *token, const char *error_text,
                          pf_error *err);

/*
 * Gives the task holding token back, queued and immediately eligible, without
 * counting the attempt (a draining worker). Lease lost → PF_ERR_INVALID.
 */
pf_status pf_queue_release(pf_queue *queue, const char *token, pf_error *err);

/*
 * Returns every running task whose lease expired before now to the queue as
 * fail() would — counting the attempt, recording the failure "lease expired
 * (worker NAME stopped heartbeating)", backing off or failing at max attempts,
 * applying the blocklist — all in one transaction. Fills *reaped (may be NULL)
 * with the number of tasks reaped.
 */
pf_status pf_queue_reap(pf_queue *queue, int64_t *reaped, pf_error *err);

/* ---- Job control --------------------------------------------------------- */

/*
 * Cancel: the job becomes canceled; its queued and running tasks become
 * canceled and running leases are revoked (their workers' next heartbeat or
 * completion reports lease lost). Done and failed tasks keep their status.
 * Canceling a canceled job is a no-op; a done job → PF_ERR_INVALID.
 * Unknown job → PF_ERR_INVALID for all four calls.
 */
pf_status pf_queue_cancel(pf_queue *queue, int64_t job_id, pf_error *err);
/* Pause: no new task of the job is claimed; running tasks finish normally.
 * Only a queued or running job can be paused (else PF_ERR_INVALID). */
pf_status pf_queue_pause(pf_queue *queue, int64_t job_id, pf_error *err);
/* Resume a paused job (else PF_ERR_INVALID); its status is derived again and
 * its pause reason cleared. */
pf_status pf_queue_resume(pf_queue *queue, int64_t job_id, pf_error *err);
/*
 * Requeues the job's failed tasks (and canceled ones, reviving a canceled
 * job) with attempts reset to 0 and no backoff, and lifts the job's worker
 * blocks. Fills *requeued (may be NULL). Retrying a paused job keeps it
 * paused.
 */
pf_status pf_queue_retry(pf_queue *queue, int64_t job_id, int64_t *requeued, pf_error *err);

/* Priorities are small integers in practice; the bound keeps typos visible. */
#define PF_QUEUE_PRIORITY_MAX 1000000
/* Sets the job's priority (whatever its state), |priority| <= PF_QUEUE_PRIORITY_MAX; the
 * next claims follow it (pf_queue_claim: priority before affinity). */
pf_status pf_queue_set_priority(pf_queue *queue, int64_t job_id, int priority, pf_error *err);

/* ---- Queries ------------------------------------------------------------- */

struct pf_queue_job {
    int64_t job_id;
    /* queued running paused done failed canceled as stored, or as its prerequisites make
     * it: "waiting" (queued, and a job it waits for as a whole has not finished) or
     * "blocked" (queued or running, and a job it waits for, directly or through others
     * that have not finished, failed or was canceled; note says which) */
    char status[16];
    int priority;
    int max_attempts;
    int frames_per_task;
    char *scene_path;      /* owned: pf_queue_job_clear */
    char *parameters_json; /* owned */
    char *frame_range;     /* owned */
    char *output_pattern;  /* owned */
    int64_t created_at, updated_at;
    int64_t tasks_total, tasks_queued, tasks_running, tasks_done, tasks_failed, tasks_canceled;
    int64_t frames_total, frames_done;
    int live_workers;          /* live registered workers */
    int blocked_live_workers;  /* of those, blocked for this job */
    /* Why the queue paused the job (pf_queue_fail_job); "" when it did not. */
    char pause_reason[512];
    /* Its requirements ("" and 0: none) and the live workers that meet them. */
    char requires_device[8];
    int64_t min_device_memory, min_host_memory;
    char required_tags[PF_QUEUE_TAGS_MAX];
    int qualified_live_workers;
    /* The jobs it waits for with their status, "3 (done), 5 frame by frame (running)";
     * "" when none. */
    char prerequisites[256];
    /* Its failures that ran out of memory (host or device: the error says "out of ...
     * memory"); status then suggests --min-memory from the frames' peaks
     * (pf_queue_timings). */
    int64_t memory_failures;
    /* The plan row of its highest finished frame: the preset auto chose and why ("auto →
     * fast: no --budget-ms or --target-relmse ..."); "" before any. */
    char plan[256];
    /* "" or why the job cannot progress, e.g. "no eligible worker: all 2 live
     * workers are blocked for this job", "waiting: no live worker has a gpu with
     * >= 24.0 GiB of device memory", "waiting for job 3 (running)", "blocked: job 3,
     * which it waits for, failed ...", or "paused: <pause reason>". */
    char note[640];
};

/* Fills *out with job_id's row and progress. Unknown job → PF_ERR_INVALID. */
pf_status pf_queue_job_get(pf_queue *queue, int64_t job_id, pf_queue_job *out, pf_error *err);
/* Frees the strings of *job (safe on a zeroed struct). */
void pf_queue_job_clear(pf_queue_job *job);
/* All jobs, oldest first, in a malloc'ed array (pf_queue_job_list_free). */
pf_status pf_queue_job_list(pf_queue *queue, pf_queue_job **jobs, size_t *count, pf_error *err);
void pf_queue_job_list_free(pf_queue_job *jobs, size_t count);

typedef struct pf_queue_task_info {
    int64_t task_id;
    int32_t first_frame, last_frame, frame_step, frame_count;
    char status[16];
    int attempt;
    int64_t worker_id;                  /* 0 when none */
    char worker_name[PF_QUEUE_NAME_MAX]; /* "" when none */
    int64_t lease_expires, eligible_at, started_at, finished_at; /* 0 when unset;
                                           eligible_at 2^53 - 1 while it waits for another job */
    char last_error[512];               /* truncated; "" when none */
} pf_queue_task_info;

/* The job's tasks by first frame (malloc'ed array, free()). */
pf_status pf_queue_task_list(pf_queue *queue, int64_t job_id, pf_queue_task_info **tasks,
                             size_t *count, pf_error *err);

typedef struct pf_queue_failure {
    int64_t task_id;
    int32_t first_frame;
    int attempt;
    char worker_name[PF_QUEUE_NAME_MAX];
    char error[512]; /* truncated */
    int64_t failed_at;
    int job_fault;   /* 1: the job's fault (pf_queue_fail_job), not counted against the worker */
} pf_queue_failure;

/* The job's failures in the order they happened (malloc'ed array, free()). */
pf_status pf_queue_failure_list(pf_queue *queue, int64_t job_id, pf_queue_failure **failures,
                                size_t *count, pf_error *err);

/*
 * A mark of what this connection sees committed (for pollers such as the monitor): equal
 * marks read through the same connection mean that nothing was committed by anyone in
 * between, so a read made after the first mark still holds. A change may also be
 * reported without a commit (a transaction started writing, or ended without changes).
 * SQLite: PRAGMA data_version (other connections' commits). PostgreSQL: the md5 of the
 * transaction snapshot, pg_current_snapshot() (equal snapshots see the same transactions
 * as committed, however many are in progress). Read at the cost of one query.
 */
#define PF_QUEUE_MARK_MAX 64
pf_status pf_queue_change_mark(pf_queue *queue, char *mark, size_t size, pf_error *err);

/* Bytes of one attempt's log at most (the worker keeps its first and last lines within it). */
#define PF_QUEUE_LOG_MAX (64 * 1024)

/*
 * Stores the lines a worker logged during attempt `attempt` of task task_id (issue 41),
 * replacing what that attempt stored before. Bytes that are not UTF-8 are stored as '?'.
 * worker_id 0: unknown. An unknown task or attempt, or text over PF_QUEUE_LOG_MAX, is
 * PF_ERR_INVALID, nothing stored. Needs no lease: a worker that lost its lease still
 * tells what happened.
 */
pf_status pf_queue_attempt_log_store(pf_queue *queue, int64_t task_id, int attempt,
                                     int64_t worker_id, const char *text, pf_error *err);

typedef struct pf_queue_attempt_log {
    int64_t task_id;
    int32_t first_frame, last_frame; /* the task's frames */
    int attempt;
    char worker_name[PF_QUEUE_NAME_MAX]; /* "" when unknown */
    int64_t written_at;
    char *text; /* the lines, '\n'-terminated (malloc'ed) */
} pf_queue_attempt_log;

/* The logs of every attempt of the job's task(s) holding frame, oldest first (malloc'ed
 * array; pf_queue_attempt_logs_free). An unknown job is PF_ERR_INVALID. */
pf_status pf_queue_attempt_logs(pf_queue *queue, int64_t job_id, int32_t frame,
                                pf_queue_attempt_log **logs, size_t *count, pf_error *err);
void pf_queue_attempt_logs_free(pf_queue_attempt_log *logs, size_t count);

typedef struct pf_queue_worker_info {
    int64_t worker_id;
    char name[PF_QUEUE_NAME_MAX];
    char host[PF_QUEUE_NAME_MAX];
    char device[PF_QUEUE_NAME_MAX];
    int64_t pid;
    int64_t heartbeat_at, started_at, stopped_at; /* stopped_at 0 while running */
    bool alive; /* not stopped and heard from within its lease (else worker_alive_ms) */
    int64_t current_task_id;  /* 0 when idle */
    int64_t current_job_id;   /* 0 when idle */
    int32_t current_frame;    /* first frame of the current task */
    char device_type[8];      /* its capabilities as registered ("" and 0: unknown) */
    int64_t device_memory, host_memory, cores;
    char tags[PF_QUEUE_TAGS_MAX];
} pf_queue_worker_info;

/* Every registered worker by id (malloc'ed array, free()). */
pf_status pf_queue_worker_list(pf_queue *queue, pf_queue_worker_info **workers, size_t *count,
                               pf_error *err);

/* What a worker has done (the monitor's worker table): frames it completed, failures it
 * recorded, and the jobs it is blocked for ("3,7"). One scan of the tasks and failures
 * for every worker: not for a hot path. */
typedef struct pf_queue_worker_stats {
    int64_t worker_id;
    int64_t frames_done, failures;
    char blocked_jobs[256]; /* cut to fit */
} pf_queue_worker_stats;

/* Every registered worker's stats, by id (malloc'ed array, free()). */
pf_status pf_queue_worker_stats_list(pf_queue *queue, pf_queue_worker_stats **stats,
                                     size_t *count, pf_error *err);

/* ---- Stage timings ------------------------------------------------------- */

/* Order statistics of a sample; median and p95 interpolate linearly between
 * the closest ranks (p at rank p*(count-1), as numpy's default). All 0 when
 * count is 0. */
typedef struct pf_queue_stat {
    int64_t count;
    double min, median, p95, max, total;
} pf_queue_stat;

typedef struct pf_queue_stage_stats {
    char stage[PF_QUEUE_STAGE_NAME_MAX];
    int64_t count;   /* rows that ran (not skipped) */
    int64_t skipped; /* rows skipped */
    pf_queue_stat wall; /* over rows that ran */
    pf_queue_stat gpu;  /* over rows that ran with a GPU time */
} pf_queue_stage_stats;

typedef struct pf_queue_slow_frame {
    int64_t task_id;
    int32_t frame;
    double wall_ms; /* sum of the frame's stages that ran */
} pf_queue_slow_frame;

/*
 * How many of a stage's rows took one decision: the rows' reason up to its
 * first ':' ("refit: SAH 16.2 ..." → "refit"), or the whole reason when it
 * has none ("geometry unchanged → BIH reused"), cut to fit.
 */
#define PF_QUEUE_DECISION_MAX 64
typedef struct pf_queue_decision_count {
    char stage[PF_QUEUE_STAGE_NAME_MAX];
    char decision[PF_QUEUE_DECISION_MAX];
    int64_t count;
} pf_queue_decision_count;

/* Frames of a job per build that rendered them (pf_queue_stage_row.build). */
#define PF_QUEUE_BUILD_MAX 64
typedef struct pf_queue_build_count {
    char build[PF_QUEUE_BUILD_MAX]; /* "unknown" for rows recorded without one */
    int64_t frames;
} pf_queue_build_count;

typedef struct pf_queue_timings {
    pf_queue_stage_stats *stages; /* in pipeline order (first recorded first) */
    size_t stage_count;
    pf_queue_slow_frame *slowest; /* slowest first; ties by lower frame */
    size_t slowest_count;
    int64_t frames;        /* distinct frames with stage rows */
    double total_wall_ms;  /* over every stage row that ran */
    double total_gpu_ms;
    pf_queue_decision_count *decisions; /* rows with a reason, by stage then decision,
                                           first recorded first */
    size_t decision_count;
    pf_queue_build_count *builds;       /* first recorded first */
    size_t build_count;
    /* Per frame, over the frames whose resources were recorded (pf_queue_complete_frames;
     * a value not measured left out), in bytes. */
    pf_queue_stat peak_rss, peak_device_memory, bytes_written;
} pf_queue_timings;

/*
 * Computes the job's per-stage statistics, its slowest_n slowest frames and
 * the decisions its stage rows' reasons record, from the recorded stage rows
 * (only completed tasks have any). Unknown job →
 * PF_ERR_INVALID. Free with pf_queue_timings_free.
 */
pf_status pf_queue_timings_get(pf_queue *queue, int64_t job_id, size_t slowest_n,
                               pf_queue_timings *out, pf_error *err);
void pf_queue_timings_free(pf_queue_timings *timings);

/* One stage row of a frame (pf_queue_frame_details). */
typedef struct pf_queue_frame_stage {
    char stage[PF_QUEUE_STAGE_NAME_MAX];
    double wall_ms;
    bool skipped;
    char decision[PF_QUEUE_DECISION_MAX]; /* its reason up to the first ':'; "" when none */
} pf_queue_frame_stage;

/* One completed frame: who rendered it, what it took, its stage rows. */
typedef struct pf_queue_frame_detail {
    int64_t task_id;
    int32_t frame;
    int attempt;                         /* the attempt that completed it */
    char worker_name[PF_QUEUE_NAME_MAX]; /* "" when unknown */
    int64_t peak_rss, peak_device_memory, bytes_written; /* bytes; -1: not recorded */
    double wall_ms;                      /* its stages that ran */
    size_t first_stage, stage_count;     /* its rows in pf_queue_frame_details.stages */
} pf_queue_frame_detail;

typedef struct pf_queue_frame_details {
    pf_queue_frame_detail *frames; /* by frame, then task */
    size_t frame_count;
    pf_queue_frame_stage *stages;  /* in the order each frame recorded them */
    size_t stage_count;
} pf_queue_frame_details;

/* Every completed frame of the job (timings --frames). Unknown job → PF_ERR_INVALID. Free
 * with pf_queue_frame_details_free. */
pf_status pf_queue_frame_details_get(pf_queue *queue, int64_t job_id,
                                     pf_queue_frame_details *out, pf_error *err);
void pf_queue_frame_details_free(pf_queue_frame_details *details);

#endif
