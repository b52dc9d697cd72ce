/* The statement calls (SQLite behind them) and the transaction runners of every jobs/ call. */
#include "queue_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* BEGIN IMMEDIATE waits busy_timeout inside SQLite; past that we try again a
 * few times with a short, pid-dependent pause so that several processes that
 * all timed out do not collide again in lockstep. */
#define QUEUE_BEGIN_RETRIES 4
#define QUEUE_RETRY_PAUSE_MS 20

pf_status queue_db_error(pf_queue *queue, pf_error *err, const char *what)
{
    if (queue->pg)
        return pf_error_set(err, PF_ERR_IO, "%s: %s: %s", queue->path, what, queue->pg_error);
    return pf_error_set(err, PF_ERR_IO, "%s: %s: %s (sqlite error %d)", queue->path, what,
                        sqlite3_errmsg(queue->db), sqlite3_extended_errcode(queue->db));
}

/* The engine's statement behind the neutral handle: one of the two is set. */
struct queue_stmt {
    pf_queue *queue;
    sqlite3_stmt *sqlite;
    queue_pg_stmt *pg;
    int cache_slot; /* SQLite: its entry in the statement cache, -1 when not cached */
};

/*
 * SQLite statements kept prepared, by their text: as on PostgreSQL
 * (db_postgres.c), the queue runs a few dozen statements over and over, and
 * parsing and code generation took most of a claim's CPU time. A cached
 * statement is reset and unbound when finalized, and kept; one already in use
 * (prepared again while it runs) is prepared anew, and so is one with more
 * parameters than a few rows' worth (a one-off bulk insert) or past a full
 * cache.
 */
#define QUEUE_SQLITE_CACHE_MAX 64
#define QUEUE_SQLITE_CACHE_MAX_PARAMS 64

struct queue_sqlite_cache {
    int count;
    struct {
        char *sql;
        sqlite3_stmt *stmt;
        int in_use;
    } entries[QUEUE_SQLITE_CACHE_MAX];
};

void queue_sqlite_forget_statements(pf_queue *queue)
{
    struct queue_sqlite_cache *cache = queue->sqlite_cache;
    if (!cache)
        return;
    for (int i = 0; i < cache->count; i++) {
        sqlite3_finalize(cache->entries[i].stmt);
        free(cache->entries[i].sql);
    }
    free(cache);
    queue->sqlite_cache = NULL;
}

static pf_status sqlite_prepare(pf_queue *queue, const char *sql, queue_stmt *stmt,
                                pf_error *err)
{
    struct queue_sqlite_cache *cache = queue->sqlite_cache;
    if (!cache)
        cache = queue->sqlite_cache = calloc(1, sizeof *cache);
    for (int i = 0; cache && i < cache->count; i++) {
        if (!cache->entries[i].in_use && !strcmp(cache->entries[i].sql, sql)) {
            cache->entries[i].in_use = 1;
            stmt->sqlite = cache->entries[i].stmt;
            stmt->cache_slot = i;
            return PF_OK;
        }
    }
    if (sqlite3_prepare_v2(queue->db, sql, -1, &stmt->sqlite, NULL) != SQLITE_OK) {
        sqlite3_finalize(stmt->sqlite);
        return queue_db_error(queue, err, "preparing a statement");
    }
    bool keep = cache && cache->count < QUEUE_SQLITE_CACHE_MAX &&
                sqlite3_bind_parameter_count(stmt->sqlite) <= QUEUE_SQLITE_CACHE_MAX_PARAMS;
    char *copy = keep ? strdup(sql) : NULL;
    if (copy) {
        int slot = cache->count++;
        cache->entries[slot].sql = copy;
        cache->entries[slot].stmt = stmt->sqlite;
        cache->entries[slot].in_use = 1;
        stmt->cache_slot = slot;
    }
    return PF_OK;
}

pf_status queue_prepare(pf_queue *queue, const char *sql, queue_stmt **stmt, pf_error *err)
{
    *stmt = malloc(sizeof **stmt);
    if (!*stmt)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory preparing a statement",
                            queue->path);
    (*stmt)->queue = queue;
    (*stmt)->sqlite = NULL;
    (*stmt)->pg = NULL;
    (*stmt)->cache_slot = -1;
    pf_status status = queue->pg ? queue_pg_prepare(queue, sql, &(*stmt)->pg, err)
                                 : sqlite_prepare(queue, sql, *stmt, err);
    if (status != PF_OK) {
        free(*stmt);
        *stmt = NULL;
    }
    return status;
}

void queue_bind_int64(queue_stmt *stmt, int index, int64_t value)
{
    if (stmt->pg) {
        queue_pg_bind_int64(stmt->pg, index, value);
        return;
    }
    sqlite3_bind_int64(stmt->sqlite, index, value);
}

void queue_bind_double(queue_stmt *stmt, int index, double value)
{
    if (stmt->pg) {
        queue_pg_bind_double(stmt->pg, index, value);
        return;
    }
    sqlite3_bind_double(stmt->sqlite, index, value);
}

void queue_bind_text(queue_stmt *stmt, int index, const char *text)
{
    if (stmt->pg) {
        queue_pg_bind_text(stmt->pg, index, text);
        return;
    }
    if (text)
        sqlite3_bind_text(stmt->sqlite, index, text, -1, SQLITE_STATIC);
    else
        sqlite3_bind_null(stmt->sqlite, index);
}

int queue_bind_index(queue_stmt *stmt, const char *name)
{
    if (stmt->pg)
        return queue_pg_bind_index(stmt->pg, name);
    return sqlite3_bind_parameter_index(stmt->sqlite, name);
}

int queue_bind_count(queue_stmt *stmt)
{
    return stmt->pg ? queue_pg_bind_count(stmt->pg) : sqlite3_bind_parameter_count(stmt->sqlite);
}

int queue_step(queue_stmt *stmt)
{
    if (stmt->pg)
        return queue_pg_step(stmt->queue, stmt->pg);
    int rc = sqlite3_step(stmt->sqlite);
    if (rc == SQLITE_ROW)
        return QUEUE_ROW;
    if (rc == SQLITE_DONE)
        return QUEUE_DONE;
    return rc == SQLITE_CONSTRAINT_CHECK ? QUEUE_CONSTRAINT : QUEUE_ERROR;
}

void queue_reset(queue_stmt *stmt)
{
    if (stmt->pg) {
        queue_pg_reset(stmt->pg);
        return;
    }
    sqlite3_reset(stmt->sqlite);
    sqlite3_clear_bindings(stmt->sqlite);
}

int64_t queue_column_int64(queue_stmt *stmt, int column)
{
    if (stmt->pg)
        return queue_pg_column_int64(stmt->pg, column);
    return sqlite3_column_int64(stmt->sqlite, column);
}

double queue_column_double(queue_stmt *stmt, int column)
{
    if (stmt->pg)
        return queue_pg_column_double(stmt->pg, column);
    return sqlite3_column_double(stmt->sqlite, column);
}

const char *queue_column_text(queue_stmt *stmt, int column)
{
    if (stmt->pg)
        return queue_pg_column_text(stmt->pg, column);
    const unsigned char *text = sqlite3_column_text(stmt->sqlite, column);
    return text ? (const char *)text : "";
}

int queue_column_is_null(queue_stmt *stmt, int column)
{
    if (stmt->pg)
        return queue_pg_column_is_null(stmt->pg, column);
    return sqlite3_column_type(stmt->sqlite, column) == SQLITE_NULL;
}

void queue_finalize(queue_stmt *stmt)
{
    if (!stmt)
        return;
    if (stmt->pg) {
        queue_pg_finalize(stmt->pg);
    } else if (stmt->cache_slot >= 0) {
        sqlite3_reset(stmt->sqlite);
        sqlite3_clear_bindings(stmt->sqlite);
        stmt->queue->sqlite_cache->entries[stmt->cache_slot].in_use = 0;
    } else {
        sqlite3_finalize(stmt->sqlite);
    }
    free(stmt);
}

void queue_commit_with_next(pf_queue *queue)
{
    if (queue->pg)
        queue->pg_commit_next = 1;
}

const char *queue_sql(pf_queue *queue, const char *sqlite_sql, const char *postgres_sql)
{
    return queue->pg ? postgres_sql : sqlite_sql;
}

int64_t queue_changes(pf_queue *queue)
{
    return queue->pg ? queue->pg_changes : sqlite3_changes(queue->db);
}

pf_status queue_prepare_rows(pf_queue *queue, const char *head, const char *row, size_t count,
                             const char *tail, queue_stmt **stmt, pf_error *err)
{
    size_t head_length = strlen(head), row_length = strlen(row), tail_length = strlen(tail);
    char *sql = malloc(head_length + count * (row_length + 1) + tail_length + 1);
    if (!sql)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for an insert of %zu rows",
                            queue->path, count);
    char *end = sql;
    memcpy(end, head, head_length);
    end += head_length;
    for (size_t i = 0; i < count; i++) {
        if (i > 0)
            *end++ = ',';
        memcpy(end, row, row_length);
        end += row_length;
    }
    memcpy(end, tail, tail_length);
    end += tail_length;
    *end = '\0';
    pf_status status = queue_prepare(queue, sql, stmt, err);
    free(sql);
    return status;
}

pf_status queue_exec(pf_queue *queue, const char *sql, pf_error *err)
{
    if (queue->pg)
        return queue_pg_exec(queue, sql, err);
    if (sqlite3_exec(queue->db, sql, NULL, NULL, NULL) != SQLITE_OK)
        return queue_db_error(queue, err, sql);
    return PF_OK;
}

pf_status queue_step_done(pf_queue *queue, queue_stmt *stmt, const char *what, pf_error *err)
{
    pf_status status = PF_OK;
    if (queue_step(stmt) != QUEUE_DONE)
        status = queue_db_error(queue, err, what);
    queue_finalize(stmt);
    return status;
}

pf_status queue_read_int64(pf_queue *queue, const char *sql, const int64_t *binds,
                           int bind_count, const char *what, int64_t *value, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(queue, sql, &stmt, err);
    if (status != PF_OK)
        return status;
    for (int i = 0; i < bind_count; i++)
        queue_bind_int64(stmt, i + 1, binds[i]);
    if (queue_step(stmt) == QUEUE_ROW)
        *value = queue_column_int64(stmt, 0);
    else
        status = queue_db_error(queue, err, what);
    queue_finalize(stmt);
    return status;
}

static void pause_ms(int ms)
{
    struct timespec pause = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&pause, NULL);
}

/* SQLite: body, then settle, in one transaction (SQLite has one writer at a time). */
static pf_status run_transaction(pf_queue *queue, const char *begin_sql, const char *what,
                                 queue_tx_body body, queue_tx_body settle, void *context,
                                 pf_error *err)
{
    int rc = SQLITE_BUSY;
    for (int attempt = 0; attempt <= QUEUE_BEGIN_RETRIES; attempt++) {
        rc = sqlite3_exec(queue->db, begin_sql, NULL, NULL, NULL);
        if (rc != SQLITE_BUSY && rc != SQLITE_LOCKED)
            break;
        pause_ms(QUEUE_RETRY_PAUSE_MS + (int)(getpid() % QUEUE_RETRY_PAUSE_MS));
    }
    if (rc == SQLITE_BUSY || rc == SQLITE_LOCKED)
        return pf_error_set(err, PF_ERR_IO,
                            "%s: %s: database still locked by another connection after %d "
                            "waits of %d ms",
                            queue->path, what, QUEUE_BEGIN_RETRIES + 1,
                            queue->options.busy_timeout_ms);
    if (rc != SQLITE_OK)
        return queue_db_error(queue, err, what);

    pf_status status = body(queue, context, err);
    if (status == PF_OK && settle)
        status = settle(queue, context, err);
    if (status == PF_OK) {
        rc = sqlite3_exec(queue->db, "COMMIT", NULL, NULL, NULL);
        for (int attempt = 0; rc == SQLITE_BUSY && attempt < QUEUE_BEGIN_RETRIES; attempt++) {
            pause_ms(QUEUE_RETRY_PAUSE_MS);
            rc = sqlite3_exec(queue->db, "COMMIT", NULL, NULL, NULL);
        }
        if (rc == SQLITE_OK)
            return PF_OK;
        status = queue_db_error(queue, err, what);
    }
    if (!sqlite3_get_autocommit(queue->db))
        sqlite3_exec(queue->db, "ROLLBACK", NULL, NULL, NULL);
    return status;
}

pf_status queue_write(pf_queue *queue, const char *what, queue_tx_body body, void *context,
                      pf_error *err)
{
    if (queue->pg)
        return queue_pg_transaction(queue, QUEUE_PG_WRITE, what, body, NULL, context, err);
    return run_transaction(queue, "BEGIN IMMEDIATE", what, body, NULL, context, err);
}

pf_status queue_write_lease(pf_queue *queue, const char *what, queue_tx_body body,
                            void *context, pf_error *err)
{
    return queue_write_lease_settled(queue, what, body, NULL, context, err);
}

pf_status queue_write_lease_settled(pf_queue *queue, const char *what, queue_tx_body body,
                                    queue_tx_body settle, void *context, pf_error *err)
{
    if (queue->pg)
        return queue_pg_transaction(queue, QUEUE_PG_LEASE, what, body, settle, context, err);
    return run_transaction(queue, "BEGIN IMMEDIATE", what, body, settle, context, err);
}

pf_status queue_read(pf_queue *queue, const char *what, queue_tx_body body, void *context,
                     pf_error *err)
{
    if (queue->pg)
        return queue_pg_transaction(queue, QUEUE_PG_READ, what, body, NULL, context, err);
    return run_transaction(queue, "BEGIN", what, body, NULL, context, err);
}

void queue_copy_text(char *buffer, size_t size, const char *text)
{
    snprintf(buffer, size, "%s", text ? text : "");
}

void *queue_records_append(queue_records *records)
{
    if (records->count == records->capacity) {
        size_t capacity = records->capacity ? records->capacity * 2 : 16;
        void *grown = realloc(records->items, capacity * records->item_size);
        if (!grown)
            return NULL;
        records->items = grown;
        records->capacity = capacity;
    }
    void *item = (char *)records->items + records->count++ * records->item_size;
    memset(item, 0, records->item_size);
    return item;
}
