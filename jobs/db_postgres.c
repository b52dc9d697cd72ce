/*
 * The PostgreSQL engine behind jobs/' statement calls (db.c dispatches here
 * when the queue was opened from a postgres:// URL; issue 13).
 *
 * Statements are the queue's SQLite-shaped SQL: "?", "?N" and ":name"
 * parameters become $N (string literals left alone), parameters travel as
 * text with their type (int8, float8, text; unbound = NULL), and the result
 * of PQexecParams is walked row by row by queue_step. Booleans read as
 * integers ('t' = 1), as SQLite's comparisons do.
 *
 * Transactions: a write transaction takes a transaction-level advisory lock
 * first, so writers are serialised exactly as SQLite's BEGIN IMMEDIATE
 * serialises them and the queue's logic (reap, enqueue, job control) keeps
 * the one-writer semantics it was written for. The lease traffic (claim,
 * heartbeat, completion, a worker's own row) takes the same lock shared:
 * those run side by side, each holding the rows it changes, and are written
 * for it (claim.c); readers run at REPEATABLE READ (one snapshot) and never
 * wait. A connection found dead when a transaction
 * begins is re-established with backoff (a restarted server), and the
 * transaction runs then; one that dies inside a transaction fails it (rolled
 * back by the server) and the caller's retry policy applies, so nothing is
 * applied twice.
 */
#include "queue_internal.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* PostgreSQL's own limit on a statement's parameters; named ones are few. */
#define PG_MAX_PARAMS 65535
#define PG_MAX_NAMED 32
/* Statements with more parameters are one-off bulk inserts: never prepared. */
#define PG_PREPARED_MAX_PARAMS 64
#define PG_MAX_NAME 32
/* Type OIDs (pg_type.h): int8, float8, text. */
#define PG_INT8 20u
#define PG_FLOAT8 701u
#define PG_TEXT 25u
/* The advisory lock every write transaction takes: "pf" in ASCII (0x7066), an arbitrary key. */
#define PG_WRITE_LOCK_TEXT "28774"
#define PG_LOCK_SHARED "SELECT pg_advisory_xact_lock_shared(" PG_WRITE_LOCK_TEXT ")"
#define PG_LOCK_EXCLUSIVE "SELECT pg_advisory_xact_lock(" PG_WRITE_LOCK_TEXT ")"
/* A writer's BEGIN pieces (begin_pieces): the lock is the third. */
#define PG_LOCK_PIECE 2
#define PG_LOCK_RETRIES 4
#define PG_LOCK_PAUSE_MS 20
#define PG_RECONNECT_TRIES 6
#define PG_RECONNECT_FIRST_MS 100

/*
 * Statements the connection has prepared, by their text and parameter
 * types: the queue runs a few dozen statements over and over, and a
 * prepared one is parsed and planned once per connection instead of at
 * every call. A reconnect forgets them (the server did).
 */
#define PG_PREPARED_MAX 64

struct queue_pg_prepared {
    int count;
    struct {
        char *key;   /* SQL, then the parameter types */
        char name[16];
    } entries[PG_PREPARED_MAX];
};

static void forget_prepared(pf_queue *queue)
{
    struct queue_pg_prepared *cache = queue->pg_prepared;
    if (!cache)
        return;
    for (int i = 0; i < cache->count; i++)
        free(cache->entries[i].key);
    cache->count = 0;
}

void queue_pg_close(pf_queue *queue)
{
    forget_prepared(queue);
    free(queue->pg_prepared);
    queue->pg_prepared = NULL;
    if (queue->pg)
        PQfinish(queue->pg);
    queue->pg = NULL;
}

struct queue_pg_stmt {
    char *sql;
    int param_count;
    char names[PG_MAX_NAMED][PG_MAX_NAME]; /* ":name" of each named parameter, "" otherwise */
    char **values;                          /* param_count of them */
    Oid *types;
    PGresult *result;
    int row, rows, executed;
};

/* The password a URL carries ("user:secret@" or "password=secret"), "" when none. */
static void password_of(const char *url, char *out, size_t size)
{
    out[0] = '\0';
    const char *scheme_end = strstr(url, "://");
    const char *at = scheme_end ? strchr(scheme_end + 3, '@') : NULL;
    const char *colon = at ? memchr(scheme_end + 3, ':', (size_t)(at - scheme_end - 3)) : NULL;
    if (colon)
        snprintf(out, size, "%.*s", (int)(at - colon - 1), colon + 1);
    const char *param = strstr(url, "password=");
    if (param && !out[0])
        snprintf(out, size, "%.*s", (int)strcspn(param + 9, "&"), param + 9);
}

/* Replaces every occurrence of secret in text (in place) with "***" (no longer than it). */
static void scrub(char *text, const char *secret)
{
    size_t length = strlen(secret);
    if (length == 0)
        return;
    for (char *hit = strstr(text, secret); hit; hit = strstr(hit, secret)) {
        if (length >= 3) {
            memcpy(hit, "***", 3);
            memmove(hit + 3, hit + length, strlen(hit + length) + 1);
            hit += 3;
        } else {
            memset(hit, '*', length);
            hit += length;
        }
    }
}

/* Appends text to out (capacity checked by the caller's sizing). */
static void put(char **out, const char *text, size_t length)
{
    memcpy(*out, text, length);
    *out += length;
}

/* Rewrites SQLite parameters as $N, numbered as SQLite does; 0 when the statement has too many. */
static int translate(const char *sql, queue_pg_stmt *stmt)
{
    size_t length = strlen(sql);
    stmt->sql = malloc(length * 6 + 16); /* "?" → "$65535" at most */
    if (!stmt->sql)
        return 0;
    char *out = stmt->sql;
    for (const char *p = sql; *p;) {
        if (*p == '\'') { /* a string literal, '' inside it */
            const char *end = p + 1;
            while (*end && !(*end == '\'' && end[1] != '\''))
                end += *end == '\'' ? 2 : 1;
            if (*end)
                end++;
            put(&out, p, (size_t)(end - p));
            p = end;
            continue;
        }
        int index = 0;
        if (*p == '?') {
            p++;
            /* As SQLite numbers them: "?" is one past the largest number so far. */
            if (isdigit((unsigned char)*p)) {
                index = (int)strtol(p, (char **)&p, 10);
            } else {
                index = stmt->param_count + 1;
            }
        } else if (*p == ':' && (isalpha((unsigned char)p[1]) || p[1] == '_') &&
                   (p == sql || p[-1] != ':')) {
            const char *name = p;
            p++;
            while (isalnum((unsigned char)*p) || *p == '_')
                p++;
            size_t name_length = (size_t)(p - name);
            for (int i = 0; i < stmt->param_count && i < PG_MAX_NAMED && !index; i++)
                if (strlen(stmt->names[i]) == name_length &&
                    !strncmp(stmt->names[i], name, name_length))
                    index = i + 1;
            if (!index) {
                index = stmt->param_count + 1;
                if (index > PG_MAX_NAMED || name_length >= PG_MAX_NAME)
                    return 0;
                snprintf(stmt->names[index - 1], PG_MAX_NAME, "%.*s", (int)name_length, name);
            }
        } else {
            put(&out, p, 1);
            p++;
            continue;
        }
        if (index < 1 || index > PG_MAX_PARAMS)
            return 0;
        if (index > stmt->param_count)
            stmt->param_count = index;
        out += sprintf(out, "$%d", index);
    }
    *out = '\0';
    stmt->values = calloc((size_t)stmt->param_count + 1, sizeof *stmt->values);
    stmt->types = calloc((size_t)stmt->param_count + 1, sizeof *stmt->types);
    return stmt->values && stmt->types;
}

pf_status queue_pg_prepare(pf_queue *queue, const char *sql, queue_pg_stmt **out, pf_error *err)
{
    queue_pg_stmt *stmt = calloc(1, sizeof *stmt);
    if (!stmt || !translate(sql, stmt)) {
        queue_pg_finalize(stmt);
        *out = NULL;
        return pf_error_set(err, PF_ERR_INTERNAL, "%s: cannot prepare a statement of %zu bytes",
                            queue->path, strlen(sql));
    }
    *out = stmt;
    return PF_OK;
}

static void set_value(queue_pg_stmt *stmt, int index, const char *text, Oid type)
{
    if (index < 1 || index > stmt->param_count)
        return;
    free(stmt->values[index - 1]);
    stmt->values[index - 1] = text ? strdup(text) : NULL;
    stmt->types[index - 1] = type;
}

void queue_pg_bind_int64(queue_pg_stmt *stmt, int index, int64_t value)
{
    char text[32];
    snprintf(text, sizeof text, "%lld", (long long)value);
    set_value(stmt, index, text, PG_INT8);
}

void queue_pg_bind_double(queue_pg_stmt *stmt, int index, double value)
{
    char text[40];
    snprintf(text, sizeof text, "%.17g", value);
    set_value(stmt, index, text, PG_FLOAT8);
}

void queue_pg_bind_text(queue_pg_stmt *stmt, int index, const char *text)
{
    set_value(stmt, index, text, PG_TEXT);
}

int queue_pg_bind_index(queue_pg_stmt *stmt, const char *name)
{
    for (int i = 0; i < stmt->param_count && i < PG_MAX_NAMED; i++)
        if (!strcmp(stmt->names[i], name))
            return i + 1;
    return 0;
}

int queue_pg_bind_count(queue_pg_stmt *stmt) { return stmt->param_count; }

/*
 * The cache's entry for the statement: found, or prepared now (NULL when the
 * statement is not cached: a one-off bulk insert, a full cache). A failed
 * PQprepare hands back its result in *failed, which is the statement's
 * error: inside a transaction nothing after it would say what went wrong.
 */
static const char *prepared_name(pf_queue *queue, const queue_pg_stmt *stmt, PGresult **failed)
{
    struct queue_pg_prepared *cache = queue->pg_prepared;
    *failed = NULL;
    if (!cache || stmt->param_count > PG_PREPARED_MAX_PARAMS || cache->count == PG_PREPARED_MAX)
        return NULL;
    char *key = malloc(strlen(stmt->sql) + 2 + (size_t)stmt->param_count * 12);
    if (!key)
        return NULL;
    char *end = key + sprintf(key, "%s\x1f", stmt->sql);
    for (int i = 0; i < stmt->param_count; i++)
        end += sprintf(end, "%u,", stmt->types[i]);
    for (int i = 0; i < cache->count; i++) {
        if (!strcmp(cache->entries[i].key, key)) {
            free(key);
            return cache->entries[i].name;
        }
    }
    int slot = cache->count;
    snprintf(cache->entries[slot].name, sizeof cache->entries[slot].name, "pf_%d", slot);
    PGresult *result = PQprepare(queue->pg, cache->entries[slot].name, stmt->sql,
                                 stmt->param_count, stmt->types);
    if (PQresultStatus(result) != PGRES_COMMAND_OK) {
        free(key);
        *failed = result;
        return NULL;
    }
    PQclear(result);
    cache->entries[slot].key = key;
    cache->count++;
    return cache->entries[slot].name;
}

static int send_statement(pf_queue *queue, const queue_pg_stmt *stmt, const char *name)
{
    if (name)
        return PQsendQueryPrepared(queue->pg, name, stmt->param_count,
                                   (const char *const *)stmt->values, NULL, NULL, 0);
    return PQsendQueryParams(queue->pg, stmt->sql, stmt->param_count, stmt->types,
                             (const char *const *)stmt->values, NULL, NULL, 0);
}

/* The first result of the pipeline's next query (the rest, and its NULL, dropped). */
static PGresult *next_query_result(PGconn *pg)
{
    PGresult *first = PQgetResult(pg);
    for (PGresult *more = first ? PQgetResult(pg) : NULL; more; more = PQgetResult(pg))
        PQclear(more);
    return first;
}

static int relock(pf_queue *queue);
static pf_status flush_pending(pf_queue *queue, pf_error *err);

/* Whether piece `piece` of a writer's BEGIN pieces failed on lock_timeout (SQLSTATE 55P03). */
static bool lock_timed_out(const PGresult *failure, int piece, int pieces)
{
    const char *code = PQresultErrorField(failure, PG_DIAG_SQLSTATE);
    return pieces > PG_LOCK_PIECE && piece == PG_LOCK_PIECE && code && !strcmp(code, "55P03");
}

/* A dead connection where BEGIN was pending: the transaction may run again (queue_pg_transaction). */
static void note_lost_at_begin(pf_queue *queue)
{
    if (queue->pg_pending_kind >= 0 && PQstatus(queue->pg) != CONNECTION_OK)
        queue->pg_lost_at_begin = 1;
}
static PGresult *execute(pf_queue *queue, const queue_pg_stmt *stmt);

/*
 * The pending transaction control, the statement and, after
 * queue_commit_with_next, COMMIT in one round trip (libpq's pipeline mode):
 * the statement's result, or the first failure (a failed statement skips
 * the COMMIT; the transaction is then rolled back as after any failure).
 * A lock not granted in lock_timeout is waited for again (relock), then the
 * statement runs on its own (with its COMMIT).
 */
static PGresult *execute_pipelined(pf_queue *queue, const queue_pg_stmt *stmt, const char *name)
{
    PGconn *pg = queue->pg;
    int pieces = queue->pg_pending_count;
    bool commit = queue->pg_commit_next;
    queue->pg_pending_count = 0;
    queue->pg_commit_next = 0;
    int sent = PQenterPipelineMode(pg);
    for (int i = 0; sent && i < pieces; i++)
        sent = PQsendQueryParams(pg, queue->pg_pending[i], 0, NULL, NULL, NULL, NULL, 0);
    sent = sent && send_statement(queue, stmt, name);
    if (sent && commit)
        sent = PQsendQueryParams(pg, "COMMIT", 0, NULL, NULL, NULL, NULL, 0);
    sent = sent && PQpipelineSync(pg);
    if (!sent) {
        queue_pg_note_error(queue, NULL);
        PQexitPipelineMode(pg);
        note_lost_at_begin(queue);
        return NULL;
    }
    PGresult *failure = NULL, *result = NULL;
    int failed_piece = -1;
    for (int i = 0; i <= pieces + (commit ? 1 : 0); i++) {
        PGresult *got = next_query_result(pg);
        ExecStatusType state = PQresultStatus(got);
        bool ok = state == PGRES_COMMAND_OK || state == PGRES_TUPLES_OK;
        if (i == pieces && ok && !failure) {
            result = got;
        } else if (!failure && !ok) {
            failure = got;
            failed_piece = i;
        } else {
            PQclear(got);
        }
    }
    PGresult *sync = PQgetResult(pg);
    PQclear(sync);
    PQexitPipelineMode(pg);
    if (!failure) {
        queue->pg_committed = commit;
        return result;
    }
    note_lost_at_begin(queue);
    PQclear(result);
    /* The write lock (BEGIN, SAVEPOINT, lock) timed out: wait again, then run alone. */
    if (!lock_timed_out(failure, failed_piece, pieces))
        return failure;
    PQclear(failure);
    if (!relock(queue))
        return NULL; /* relock said why */
    queue->pg_commit_next = commit;
    return execute(queue, stmt);
}

static PGresult *execute(pf_queue *queue, const queue_pg_stmt *stmt)
{
    PGresult *failed;
    const char *name = prepared_name(queue, stmt, &failed);
    if (failed) {
        if (queue->pg_pending_count)
            note_lost_at_begin(queue);
        queue->pg_commit_next = 0;
        return failed;
    }
    if (queue->pg_pending_count || queue->pg_commit_next)
        return execute_pipelined(queue, stmt, name);
    PGresult *result = send_statement(queue, stmt, name) ? next_query_result(queue->pg) : NULL;
    if (!result)
        queue_pg_note_error(queue, NULL);
    return result;
}

int queue_pg_step(pf_queue *queue, queue_pg_stmt *stmt)
{
    if (!stmt->executed) {
        stmt->executed = 1;
        stmt->result = execute(queue, stmt);
        ExecStatusType state = PQresultStatus(stmt->result);
        queue->pg_changes = 0;
        if (state == PGRES_COMMAND_OK || state == PGRES_TUPLES_OK) {
            queue->pg_changes = strtoll(PQcmdTuples(stmt->result), NULL, 10);
            stmt->rows = state == PGRES_TUPLES_OK ? PQntuples(stmt->result) : 0;
            stmt->row = -1;
        } else {
            if (stmt->result) /* no result: execute noted why */
                queue_pg_note_error(queue, stmt->result);
            const char *code = PQresultErrorField(stmt->result, PG_DIAG_SQLSTATE);
            /* Integrity violations (class 23) and malformed JSON for a json column. */
            return code && (!strncmp(code, "23", 2) || !strcmp(code, "22P02"))
                       ? QUEUE_CONSTRAINT
                       : QUEUE_ERROR;
        }
    }
    if (!stmt->result)
        return QUEUE_ERROR;
    stmt->row++;
    return stmt->row < stmt->rows ? QUEUE_ROW : QUEUE_DONE;
}

void queue_pg_reset(queue_pg_stmt *stmt)
{
    PQclear(stmt->result);
    stmt->result = NULL;
    stmt->executed = 0;
    for (int i = 0; stmt->values && i < stmt->param_count; i++) {
        free(stmt->values[i]);
        stmt->values[i] = NULL;
        stmt->types[i] = 0;
    }
}

/* The current row's value, NULL for SQL NULL or no row. */
static const char *value_of(queue_pg_stmt *stmt, int column)
{
    if (!stmt->result || stmt->row < 0 || stmt->row >= stmt->rows ||
        column >= PQnfields(stmt->result) || PQgetisnull(stmt->result, stmt->row, column))
        return NULL;
    return PQgetvalue(stmt->result, stmt->row, column);
}

int64_t queue_pg_column_int64(queue_pg_stmt *stmt, int column)
{
    const char *value = value_of(stmt, column);
    if (!value)
        return 0;
    if (!strcmp(value, "t") || !strcmp(value, "f"))
        return value[0] == 't';
    return strtoll(value, NULL, 10);
}

double queue_pg_column_double(queue_pg_stmt *stmt, int column)
{
    const char *value = value_of(stmt, column);
    return value ? strtod(value, NULL) : 0.0;
}

const char *queue_pg_column_text(queue_pg_stmt *stmt, int column)
{
    const char *value = value_of(stmt, column);
    return value ? value : "";
}

int queue_pg_column_is_null(queue_pg_stmt *stmt, int column) { return !value_of(stmt, column); }

void queue_pg_finalize(queue_pg_stmt *stmt)
{
    if (!stmt)
        return;
    queue_pg_reset(stmt);
    free(stmt->values);
    free(stmt->types);
    free(stmt->sql);
    free(stmt);
}

void queue_pg_note_error(pf_queue *queue, const PGresult *result)
{
    const char *message = result ? PQresultErrorMessage(result) : PQerrorMessage(queue->pg);
    if (!message || !*message)
        message = PQerrorMessage(queue->pg);
    snprintf(queue->pg_error, sizeof queue->pg_error, "%s", message ? message : "");
    scrub(queue->pg_error, queue->pg_secret);
    size_t length = strlen(queue->pg_error);
    while (length > 0 && (queue->pg_error[length - 1] == '\n' || queue->pg_error[length - 1] == ' '))
        queue->pg_error[--length] = '\0';
}

pf_status queue_pg_exec(pf_queue *queue, const char *sql, pf_error *err)
{
    if (queue->pg_pending_count) {
        pf_status status = flush_pending(queue, err);
        if (status != PF_OK)
            return status;
    }
    PGresult *result = PQexec(queue->pg, sql);
    ExecStatusType state = PQresultStatus(result);
    pf_status status = PF_OK;
    if (state != PGRES_COMMAND_OK && state != PGRES_TUPLES_OK) {
        queue_pg_note_error(queue, result);
        status = queue_db_error(queue, err, sql);
    }
    PQclear(result);
    return status;
}

static void pause_ms(int ms)
{
    struct timespec pause = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&pause, NULL);
}

/* Per-session settings, lost with the connection: set at connect and after every reconnect. */
static pf_status apply_session(pf_queue *queue, pf_error *err)
{
    /* No NOTICE chatter on stderr; a writer waits for the write lock as long as SQLite's
     * busy_timeout, then the transaction is retried or reported as locked. */
    char settings[128];
    snprintf(settings, sizeof settings, "SET client_min_messages = warning; SET lock_timeout = %d",
             queue->options.busy_timeout_ms);
    return queue_pg_exec(queue, settings, err);
}

/* A dead connection is re-established, waiting 0.1, 0.2, 0.4 ... s between tries. */
static pf_status ensure_connected(pf_queue *queue, const char *what, pf_error *err)
{
    if (PQstatus(queue->pg) == CONNECTION_OK)
        return PF_OK;
    int wait_ms = PG_RECONNECT_FIRST_MS;
    for (int attempt = 0; PQstatus(queue->pg) != CONNECTION_OK; attempt++) {
        if (attempt == PG_RECONNECT_TRIES) {
            queue_pg_note_error(queue, NULL);
            return pf_error_set(err, PF_ERR_IO, "%s: %s: connection lost and not regained after "
                                "%d tries: %s", queue->path, what, PG_RECONNECT_TRIES,
                                queue->pg_error);
        }
        if (attempt > 0) {
            pause_ms(wait_ms);
            wait_ms *= 2;
        }
        forget_prepared(queue);
        PQreset(queue->pg);
    }
    return apply_session(queue, err);
}


/*
 * BEGIN and, for a writer, its lock, as separate statements: they travel
 * with the transaction's first statement (execute_pipelined). The lock
 * is taken after a savepoint so that a lock_timeout can be rolled back and
 * the lock waited for again.
 */
static int begin_pieces(queue_pg_tx kind, const char *pieces[3])
{
    switch (kind) {
    case QUEUE_PG_WRITE:
    case QUEUE_PG_LEASE:
        pieces[0] = "BEGIN ISOLATION LEVEL READ COMMITTED";
        pieces[1] = "SAVEPOINT locking";
        pieces[PG_LOCK_PIECE] = kind == QUEUE_PG_LEASE ? PG_LOCK_SHARED : PG_LOCK_EXCLUSIVE;
        return 3;
    case QUEUE_PG_READ:
        pieces[0] = "BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY";
        return 1;
    }
    return 0;
}

/* A writer waits lock_timeout (busy_timeout) per try, like SQLite's BEGIN IMMEDIATE. */
static int relock(pf_queue *queue)
{
    const char *again = queue->pg_pending_kind == QUEUE_PG_LEASE
                            ? "ROLLBACK TO SAVEPOINT locking; " PG_LOCK_SHARED
                            : "ROLLBACK TO SAVEPOINT locking; " PG_LOCK_EXCLUSIVE;
    for (int attempt = 0; attempt < PG_LOCK_RETRIES; attempt++) {
        if (PQstatus(queue->pg) != CONNECTION_OK ||
            PQtransactionStatus(queue->pg) != PQTRANS_INERROR)
            break;
        pause_ms(PG_LOCK_PAUSE_MS);
        PGresult *result = PQexec(queue->pg, again);
        bool locked = PQresultStatus(result) == PGRES_TUPLES_OK;
        if (!locked)
            queue_pg_note_error(queue, result);
        PQclear(result);
        if (locked)
            return 1;
    }
    if (PQstatus(queue->pg) == CONNECTION_OK)
        snprintf(queue->pg_error, sizeof queue->pg_error,
                 "database still locked by another connection after %d waits of %d ms",
                 PG_LOCK_RETRIES + 1, queue->options.busy_timeout_ms);
    return 0;
}

/* Sends pending transaction control on its own (before a statement that cannot carry it). */
static pf_status flush_pending(pf_queue *queue, pf_error *err)
{
    int pieces = queue->pg_pending_count;
    queue->pg_pending_count = 0;
    for (int i = 0; i < pieces; i++) {
        PGresult *result = PQexec(queue->pg, queue->pg_pending[i]);
        ExecStatusType state = PQresultStatus(result);
        bool ok = state == PGRES_COMMAND_OK || state == PGRES_TUPLES_OK;
        bool lock_timeout = !ok && lock_timed_out(result, i, pieces);
        if (!ok)
            queue_pg_note_error(queue, result);
        PQclear(result);
        if (!ok)
            note_lost_at_begin(queue);
        if (!ok && !(lock_timeout && relock(queue)))
            return queue_db_error(queue, err, queue->pg_pending[i]);
    }
    return PF_OK;
}

/*
 * Writers share one advisory lock: queue_write's take it exclusively (one
 * writer, as on SQLite), the lease traffic's take it shared, so claims and
 * completions run side by side while the reaper, enqueue and job control
 * wait for them, and they for those.
 *
 * Round trips: BEGIN (and the lock) goes with the body's first statement,
 * COMMIT with its last after queue_commit_with_next, else with settle's
 * first. A connection found dead when the transaction
 * begins is re-established (a restarted server), and the transaction runs
 * again on the new one, once: nothing of the first reached the server.
 */
pf_status queue_pg_transaction(pf_queue *queue, queue_pg_tx kind, const char *what,
                               queue_tx_body body, queue_tx_body settle, void *context,
                               pf_error *err)
{
    pf_status status = PF_OK;
    for (int attempt = 0; attempt < 2; attempt++) {
        status = ensure_connected(queue, what, err);
        if (status != PF_OK)
            return status;
        queue->pg_pending_kind = kind;
        queue->pg_pending_count = begin_pieces(kind, queue->pg_pending);
        queue->pg_lost_at_begin = 0;
        queue->pg_commit_next = 0;
        queue->pg_committed = 0;
        status = body(queue, context, err);
        bool began = queue->pg_pending_count == 0;
        queue->pg_pending_count = 0;
        queue->pg_commit_next = 0;
        /* Found dead with BEGIN, nothing of the transaction reached the server:
         * once more on a new connection. Lost later, it failed (and the server
         * rolled it back). */
        if (status != PF_OK && queue->pg_lost_at_begin && attempt == 0)
            continue;
        if (!began)
            return status; /* no statement ran: nothing to end */
        break;
    }
    if (status != PF_OK) {
        if (PQstatus(queue->pg) == CONNECTION_OK && !queue->pg_committed) {
            PGresult *result = PQexec(queue->pg, "ROLLBACK");
            PQclear(result);
        }
        return status;
    }
    if (queue->pg_committed)
        return settle ? settle(queue, context, err) : PF_OK;
    if (!settle) {
        status = queue_pg_exec(queue, "COMMIT", err);
        if (status != PF_OK)
            pf_error_prefix(err, "%s", what);
        return status;
    }
    queue->pg_pending[0] = "COMMIT";
    queue->pg_pending_count = 1;
    queue->pg_pending_kind = -1;
    status = settle(queue, context, err);
    if (queue->pg_pending_count) /* settle ran no statement */
        status = flush_pending(queue, err);
    return status;
}

int pf_queue_is_url(const char *db)
{
    return db && (!strncmp(db, "postgres://", 11) || !strncmp(db, "postgresql://", 13));
}

pf_status queue_pg_connect(pf_queue *queue, const char *url, pf_error *err)
{
    /* The password never reaches a message: not in the URL shown, not in libpq's words. */
    password_of(url, queue->pg_secret, sizeof queue->pg_secret);
    char shown[1024];
    snprintf(shown, sizeof shown, "%s", url);
    scrub(shown, queue->pg_secret);
    free(queue->path);
    queue->path = strdup(shown);
    if (!queue->path)
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory opening the queue");
    queue->pg_prepared = calloc(1, sizeof *queue->pg_prepared);
    queue->pg = PQconnectdb(url);
    if (!queue->pg || !queue->pg_prepared)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory connecting", shown);
    if (PQstatus(queue->pg) != CONNECTION_OK) {
        queue_pg_note_error(queue, NULL);
        return pf_error_set(err, PF_ERR_INVALID, "%s: cannot connect to the queue database: %s",
                            shown, queue->pg_error);
    }
    return apply_session(queue, err);
}
