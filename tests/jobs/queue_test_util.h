/* Helpers shared by the queue tests: scratch databases and a hand-driven clock. */
#ifndef QUEUE_TEST_UTIL_H
#define QUEUE_TEST_UTIL_H

#include "pf_queue.h"

#include <stddef.h>

/* A clock the test advances by hand (ms since the epoch). */
typedef struct test_clock {
    int64_t now;
} test_clock;

int64_t test_clock_read(void *user);

/*
 * "$PF_TEST_TMP/<name>" with any old database, -wal and -shm removed; or,
 * when $PF_TEST_POSTGRES_URL names a PostgreSQL database (the same tests on
 * the other backend), that URL with the database emptied.
 */
const char *fresh_db_path(const char *name, char *buffer, size_t size);
/* $PF_TEST_POSTGRES_URL, or NULL when the tests run on SQLite files. */
const char *queue_test_postgres(void);
/* The integer the query returns, read past the queue's API (either engine); -1 on failure. */
int64_t queue_test_query_int(const char *db, const char *sql);

/* Opens path with options (NULL: test defaults) on clock (NULL: wall clock). */
pf_status open_queue(const char *path, const pf_queue_options *options, test_clock *clock,
                     pf_queue **queue, pf_error *err);

/* Registers a worker called name (pid 1, host "test"). */
int64_t register_worker(pf_queue *queue, const char *name);

/* Reads a whole file into a malloc'ed buffer (NULL if unreadable). */
unsigned char *read_file_bytes(const char *path, size_t *size);
/* Writes bytes to path, replacing it. Returns 0 on success. */
int write_file_bytes(const char *path, const void *bytes, size_t size);

#endif
