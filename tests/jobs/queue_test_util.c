#include "queue_test_util.h"

#include "pf_test.h"

#include <libpq-fe.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

int64_t test_clock_read(void *user) { return ((test_clock *)user)->now; }

const char *queue_test_postgres(void)
{
    const char *url = getenv("PF_TEST_POSTGRES_URL");
    return url && *url ? url : NULL;
}

/* Empties the PostgreSQL database the tests run on: the next open creates the schema anew. */
static void reset_postgres(const char *url)
{
    PGconn *conn = PQconnectdb(url);
    PGresult *result = PQstatus(conn) == CONNECTION_OK
                           ? PQexec(conn, "SET client_min_messages = warning; "
                                          "DROP SCHEMA public CASCADE; CREATE SCHEMA public")
                           : NULL;
    if (!result || PQresultStatus(result) != PGRES_COMMAND_OK) {
        fprintf(stderr, "cannot reset %s: %s\n", url, PQerrorMessage(conn));
        exit(1);
    }
    PQclear(result);
    PQfinish(conn);
}

const char *fresh_db_path(const char *name, char *buffer, size_t size)
{
    const char *url = queue_test_postgres();
    if (url) {
        reset_postgres(url);
        snprintf(buffer, size, "%s", url);
        return buffer;
    }
    char dir[1024];
    snprintf(buffer, size, "%s/%s", pf_test_tmpdir(dir, sizeof dir), name);
    static const char *const suffixes[] = {"", "-wal", "-shm", "-journal"};
    for (size_t i = 0; i < sizeof suffixes / sizeof *suffixes; i++) {
        char path[1200];
        snprintf(path, sizeof path, "%s%s", buffer, suffixes[i]);
        unlink(path);
    }
    return buffer;
}

int64_t queue_test_query_int(const char *db, const char *sql)
{
    int64_t value = -1;
    if (pf_queue_is_url(db)) {
        PGconn *conn = PQconnectdb(db);
        PGresult *result = PQstatus(conn) == CONNECTION_OK ? PQexec(conn, sql) : NULL;
        if (result && PQresultStatus(result) == PGRES_TUPLES_OK && PQntuples(result) == 1)
            value = strtoll(PQgetvalue(result, 0, 0), NULL, 10);
        PQclear(result);
        PQfinish(conn);
        return value;
    }
    sqlite3 *handle = NULL;
    sqlite3_stmt *stmt = NULL;
    if (sqlite3_open_v2(db, &handle, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK &&
        sqlite3_prepare_v2(handle, sql, -1, &stmt, NULL) == SQLITE_OK &&
        sqlite3_step(stmt) == SQLITE_ROW)
        value = sqlite3_column_int64(stmt, 0);
    sqlite3_finalize(stmt);
    sqlite3_close(handle);
    return value;
}

pf_status open_queue(const char *path, const pf_queue_options *options, test_clock *clock,
                     pf_queue **queue, pf_error *err)
{
    pf_queue_options with_clock = options ? *options : (pf_queue_options){0};
    if (clock) {
        with_clock.clock = test_clock_read;
        with_clock.clock_user = clock;
    }
    return pf_queue_open(path, &with_clock, queue, err);
}

int64_t register_worker(pf_queue *queue, const char *name)
{
    pf_error err = {0};
    int64_t worker_id = 0;
    pf_queue_worker_spec spec = {.name = name, .host = "test", .pid = 1, .device = "cpu"};
    PF_CHECK_OK(pf_queue_worker_register(queue, &spec, &worker_id, &err), &err);
    return worker_id;
}

unsigned char *read_file_bytes(const char *path, size_t *size)
{
    FILE *file = fopen(path, "rb");
    if (!file)
        return NULL;
    fseek(file, 0, SEEK_END);
    long length = ftell(file);
    fseek(file, 0, SEEK_SET);
    unsigned char *bytes = malloc(length > 0 ? (size_t)length : 1);
    if (bytes && fread(bytes, 1, (size_t)length, file) != (size_t)length) {
        free(bytes);
        bytes = NULL;
    }
    fclose(file);
    *size = (size_t)length;
    return bytes;
}

int write_file_bytes(const char *path, const void *bytes, size_t size)
{
    FILE *file = fopen(path, "wb");
    if (!file)
        return -1;
    size_t written = fwrite(bytes, 1, size, file);
    return fclose(file) == 0 && written == size ? 0 : -1;
}
