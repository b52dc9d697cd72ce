/*
 * Shared internals of jobs/: the connection record, the statement calls
 * every query goes through, the write-transaction runner, and the task state transitions that several
 * public calls share (fail/reap, job status derivation).
 */
#ifndef PF_QUEUE_INTERNAL_H
#define PF_QUEUE_INTERNAL_H

#include "pf_queue.h"

#include <libpq-fe.h>
#include <sqlite3.h>

struct pf_queue {
    sqlite3 *db;             /* SQLite: the connection (NULL on PostgreSQL) */
    PGconn *pg;              /* PostgreSQL: the connection (NULL on SQLite) */
    char *path;              /* the file, or the URL with its password hidden: every message's */
    int64_t pg_changes;      /* PostgreSQL: rows the last statement changed */
    char pg_error[512];      /* PostgreSQL: the last error's message */
    char pg_secret[128];     /* PostgreSQL: the URL's password, scrubbed from every message */
    struct queue_pg_prepared *pg_prepared; /* PostgreSQL: statements prepared on the connection */
    struct queue_sqlite_cache *sqlite_cache; /* SQLite: statements kept prepared (db.c) */
    /* PostgreSQL: transaction control not sent yet (BEGIN and its lock, or
     * COMMIT), sent with the next statement in one round trip. */
    const char *pg_pending[3];
    int pg_pending_count;
    int pg_pending_kind;     /* the queue_pg_tx that BEGIN opens, -1 for COMMIT */
    int pg_lost_at_begin;    /* the connection was found dead sending BEGIN */
    int pg_commit_next;      /* queue_commit_with_next: COMMIT follows the next statement */
    int pg_committed;        /* ... and it did: the transaction is over */
    pf_queue_options options;
    pf_queue_clock clock;
    void *clock_user;
};

/* PF_ERR_IO "<path>: <what>: <engine message>" from the connection's last error. */
pf_status queue_db_error(pf_queue *queue, pf_error *err, const char *what);

/*
 * Statements, the one way jobs/ talks to its database engine (db.c). The
 * calls mirror SQLite's, so the queue's logic is written once; parameters
 * are numbered from 1 ("?", "?N") or named (":name", queue_bind_index), an
 * unbound parameter is NULL, columns are numbered from 0.
 */
typedef struct queue_stmt queue_stmt;
/* queue_step's results besides an engine error. */
enum { QUEUE_ROW = 1, QUEUE_DONE = 2, QUEUE_CONSTRAINT = 3, QUEUE_ERROR = 4 };
/* Prepares sql (or takes it prepared from the connection's cache); on
 * failure reports it via queue_db_error. */
pf_status queue_prepare(pf_queue *queue, const char *sql, queue_stmt **stmt, pf_error *err);
void queue_bind_int64(queue_stmt *stmt, int index, int64_t value);
void queue_bind_double(queue_stmt *stmt, int index, double value);
/* NULL text binds NULL. The text must live until the statement has run. */
void queue_bind_text(queue_stmt *stmt, int index, const char *text);
/* The index of a named parameter (":name"), 0 when the statement has none by that name. */
int queue_bind_index(queue_stmt *stmt, const char *name);
int queue_bind_count(queue_stmt *stmt);
/* QUEUE_ROW (a row to read), QUEUE_DONE, QUEUE_CONSTRAINT (a CHECK failed) or QUEUE_ERROR. */
int queue_step(queue_stmt *stmt);
/* Ready to run again with every parameter unbound. */
void queue_reset(queue_stmt *stmt);
int64_t queue_column_int64(queue_stmt *stmt, int column);
double queue_column_double(queue_stmt *stmt, int column);
/* Text of a column, "" for NULL. */
const char *queue_column_text(queue_stmt *stmt, int column);
int queue_column_is_null(queue_stmt *stmt, int column);
void queue_finalize(queue_stmt *stmt);
/* Rows the last statement changed. */
int64_t queue_changes(pf_queue *queue);
/* The engine's spelling of a statement, where SQLite and PostgreSQL differ. */
const char *queue_sql(pf_queue *queue, const char *sqlite_sql, const char *postgres_sql);
/*
 * Prepares head, count copies of row ("(?, ?, 0)") comma separated, then
 * tail: one statement of many rows, one round trip on PostgreSQL. Row i's
 * k-th parameter (1-based) is (parameters in head) + i * (parameters in
 * row) + k.
 */
pf_status queue_prepare_rows(pf_queue *queue, const char *head, const char *row, size_t count,
                             const char *tail, queue_stmt **stmt, pf_error *err);
/* Runs statements without results. */
pf_status queue_exec(pf_queue *queue, const char *sql, pf_error *err);
/* The first column of the first row of sql, its ?1..?bind_count bound to binds; no row is
 * an error naming what. */
pf_status queue_read_int64(pf_queue *queue, const char *sql, const int64_t *binds,
                           int bind_count, const char *what, int64_t *value, pf_error *err);
/* Steps a statement expected to finish (QUEUE_DONE) and finalizes it. */
pf_status queue_step_done(pf_queue *queue, queue_stmt *stmt, const char *what, pf_error *err);

/* The body of a write transaction; returning non-PF_OK rolls everything back. */
typedef pf_status (*queue_tx_body)(pf_queue *queue, void *context, pf_error *err);
/* Runs body inside BEGIN IMMEDIATE ... COMMIT, retrying BEGIN when the
 * database stays locked past busy_timeout. what names the operation in errors.
 * On PostgreSQL it is the only writer while it runs, as on SQLite. */
pf_status queue_write(pf_queue *queue, const char *what, queue_tx_body body, void *context,
                      pf_error *err);
/*
 * A write transaction of the lease traffic (claim, heartbeat, completion,
 * and a worker writing its own row):
 * on SQLite the same as queue_write. On PostgreSQL these run concurrently
 * with each other, each holding the rows it changes (a claim picks its task
 * with FOR UPDATE SKIP LOCKED), and wait for queue_write's writers, which
 * wait for them. Such a body must not rely on being the only writer.
 */
pf_status queue_write_lease(pf_queue *queue, const char *what, queue_tx_body body,
                            void *context, pf_error *err);
/*
 * queue_write_lease, then settle: what must see every lease writer's work
 * (deriving a job's status from its tasks). Where lease writers are
 * serialised (SQLite) settle ends the transaction; where they run side by
 * side (PostgreSQL) it runs after the commit, each statement its own
 * transaction (so settle must check its own reads), its first in the
 * commit's round trip. settle runs only when body succeeded.
 */
pf_status queue_write_lease_settled(pf_queue *queue, const char *what, queue_tx_body body,
                                    queue_tx_body settle, void *context, pf_error *err);
/*
 * Inside a write body: the next statement is the body's last, and on
 * PostgreSQL COMMIT travels with it (one round trip for the statement and
 * the commit, and its row locks held only while the server runs it). The
 * body must end successfully when that statement does: nothing after it can
 * roll it back. Nothing on SQLite, where the transaction ends as usual.
 */
void queue_commit_with_next(pf_queue *queue);
/* Finalizes the SQLite statements kept prepared: before the connection closes. */
void queue_sqlite_forget_statements(pf_queue *queue);
/* Runs body inside a read transaction (one consistent snapshot). */
pf_status queue_read(pf_queue *queue, const char *what, queue_tx_body body, void *context,
                     pf_error *err);

/* Copies text into a fixed buffer, truncating. */
void queue_copy_text(char *buffer, size_t size, const char *text);

/* A growable array of fixed-size records filled from a query ({NULL, 0, 0, size} to start). */
typedef struct queue_records {
    void *items;
    size_t count, capacity, item_size;
} queue_records;

/* Appends one zeroed record (capacity doubles from 16); NULL when out of memory. */
void *queue_records_append(queue_records *records);

/*
 * Counts a failed attempt of a running task (inside a write transaction):
 * records the failure, requeues after backoff or fails at max attempts,
 * clears the worker's current task, applies the per-job blocklist and
 * refreshes the job's status.
 */
pf_status queue_task_attempt_failed(pf_queue *queue, int64_t task_id, const char *error_text,
                                    pf_error *err);
/* No worker holds task_id as its current task any more (inside a write transaction). */
pf_status queue_clear_worker_task(pf_queue *queue, int64_t task_id, pf_error *err);
/*
 * pf_queue_fail_job's work on a running task (inside a write transaction):
 * the failure recorded as the job's, the task queued without counting the
 * attempt, the worker's current task cleared, the job paused with the reason.
 */
pf_status queue_task_job_fault(pf_queue *queue, int64_t task_id, const char *error_text,
                               pf_error *err);
/* pf_queue_reject's work on a running task (inside a write transaction). */
pf_status queue_task_reject(pf_queue *queue, int64_t task_id, const char *error_text,
                            pf_error *err);
/* Derives and stores the job's status from its tasks (inside a write transaction). */
pf_status queue_job_refresh(pf_queue *queue, int64_t job_id, pf_error *err);
/* The same, and *dependents tells whether some job waits for it (jobs.dependents), read
 * by the same statement. */
pf_status queue_job_refresh_with(pf_queue *queue, int64_t job_id, bool *dependents,
                                 pf_error *err);
/* Whether job_id exists (PF_ERR_INVALID naming it when not). */
pf_status queue_job_require(pf_queue *queue, int64_t job_id, char *status, size_t status_size,
                            pf_error *err);

/*
 * The PostgreSQL engine (db_postgres.c) behind the statement calls above,
 * which dispatch to it when queue->pg is set.
 */
typedef struct queue_pg_stmt queue_pg_stmt;
/* Connects queue to url (queue->path becomes the URL with its password hidden). */
pf_status queue_pg_connect(pf_queue *queue, const char *url, pf_error *err);
/* Closes the connection and forgets what it prepared. */
void queue_pg_close(pf_queue *queue);
pf_status queue_pg_prepare(pf_queue *queue, const char *sql, queue_pg_stmt **stmt, pf_error *err);
void queue_pg_bind_int64(queue_pg_stmt *stmt, int index, int64_t value);
void queue_pg_bind_double(queue_pg_stmt *stmt, int index, double value);
void queue_pg_bind_text(queue_pg_stmt *stmt, int index, const char *text);
int queue_pg_bind_index(queue_pg_stmt *stmt, const char *name);
int queue_pg_bind_count(queue_pg_stmt *stmt);
int queue_pg_step(pf_queue *queue, queue_pg_stmt *stmt);
void queue_pg_reset(queue_pg_stmt *stmt);
int64_t queue_pg_column_int64(queue_pg_stmt *stmt, int column);
double queue_pg_column_double(queue_pg_stmt *stmt, int column);
const char *queue_pg_column_text(queue_pg_stmt *stmt, int column);
int queue_pg_column_is_null(queue_pg_stmt *stmt, int column);
void queue_pg_finalize(queue_pg_stmt *stmt);
/* Keeps the message of result (or of the connection) for queue_db_error. */
void queue_pg_note_error(pf_queue *queue, const PGresult *result);
pf_status queue_pg_exec(pf_queue *queue, const char *sql, pf_error *err);
/* The kinds of transaction on PostgreSQL (db_postgres.c says how writers are serialised). */
typedef enum queue_pg_tx {
    QUEUE_PG_READ,       /* queue_read */
    QUEUE_PG_WRITE,      /* queue_write: the only writer */
    QUEUE_PG_LEASE       /* queue_write_lease: beside other lease writers */
} queue_pg_tx;
/* Runs body in a transaction of kind, then (when body succeeded and settle
 * is given) settle after the commit, each statement its own transaction. */
pf_status queue_pg_transaction(pf_queue *queue, queue_pg_tx kind, const char *what,
                               queue_tx_body body, queue_tx_body settle, void *context,
                               pf_error *err);

/*
 * SQL: worker row W meets the requirements of job row J (issue 42), on both engines. The
 * tags: J's sorted list "a,b" must be a subsequence of W's sorted list, matched as LIKE
 * '%,a,%,b,%' against ",a,,b,,c," (each of W's tags between its own commas; '_', a LIKE
 * wildcard that tags may hold, escaped; tags are lower case, so LIKE's case folding on
 * SQLite changes nothing).
 */
#define QUEUE_WORKER_MEETS(J, W)                                                              \
    "(" J ".requires_device = '' OR " J ".requires_device = " W ".device_type)"               \
    " AND " J ".min_device_memory <= " W ".device_memory"                                     \
    " AND " J ".min_host_memory <= " W ".host_memory"                                         \
    " AND (" J ".required_tags = '' OR ',' || replace(" W ".tags, ',', ',,') || ','"          \
    " LIKE '%,' || replace(replace(" J ".required_tags, '_', '\\_'), ',', ',%,') || ',%'"    \
    " ESCAPE '\\')"

/*
 * Job dependencies (dependencies.c, issue 42). A task that waits for another job is held:
 * its eligible_at is QUEUE_HELD_AT, past any clock, so the claim, which takes only tasks
 * whose eligible_at has passed, never sees it and tests no dependency itself. It is
 * released (eligible_at 0) when what it waits for is done: every job it waits for as a
 * whole, and the tasks overlapping its frames of every job it waits for frame by frame.
 */
#define QUEUE_HELD_AT INT64_C(9007199254740991) /* 2^53 - 1: exact as a double too */
#define QUEUE_HELD_AT_SQL "9007199254740991"

/* Holds job_id's queued tasks, then releases those whose prerequisites are done (inside a
 * write transaction: after its dependencies changed, or a retry requeued tasks). */
pf_status queue_dependencies_hold(pf_queue *queue, int64_t job_id, pf_error *err);
/* After a task of job_id covering first..last frames completed (and its job's status was
 * derived): releases the tasks of the jobs waiting for it that it unblocked. On PostgreSQL
 * a settle statement of its own (queue_write_lease_settled). */
pf_status queue_dependents_release(pf_queue *queue, int64_t job_id, int32_t first_frame,
                                   int32_t last_frame, pf_error *err);

/* Stores a completing task's frames' resources (inside its completion's transaction),
 * refusing a frame outside first..last by step, one listed twice, or a value below -1. */
pf_status queue_frame_resources_store(pf_queue *queue, int64_t task_id, int attempt,
                                      int32_t first_frame, int32_t last_frame, int32_t frame_step,
                                      const pf_queue_frame_resources *frames, size_t count,
                                      pf_error *err);

/* Adds job_id's prerequisites, checked as pf_queue_add_dependencies says (inside a write
 * transaction). */
pf_status queue_dependencies_add(pf_queue *queue, int64_t job_id,
                                 const pf_queue_dependency *after, size_t count, pf_error *err);
/* Fills each job's prerequisites, and its status and note where they make it waiting or
 * blocked (inside a read; jobs sorted by id, job_id 0: all of them). */
pf_status queue_dependencies_describe(pf_queue *queue, int64_t job_id, pf_queue_job *jobs,
                                      size_t count, pf_error *err);

#endif
