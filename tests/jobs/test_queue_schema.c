/*
 * One queue schema for both engines (issue 45): jobs/schema.c keeps the SQLite
 * migrations and the PostgreSQL schema as two texts, so this test creates both
 * (a fresh SQLite file migrated from version 0, and the throwaway PostgreSQL
 * database of with_postgres.sh) and compares what the engines report of them,
 * table by table, in one canonical form:
 *   - each column: its type class (integer, real, text), NOT NULL (a primary
 *     key's columns count as NOT NULL on both), its default (a PostgreSQL
 *     "::type" cast and a serial's nextval are the engines' spelling, not a
 *     difference);
 *   - the primary key, UNIQUE constraints, foreign keys with their ON DELETE,
 *     the number of CHECK constraints, and the named indexes with their columns.
 * Every line one engine has and the other lacks is printed and fails the test.
 * Without $PF_TEST_POSTGRES_URL (run outside with_postgres.sh) it compares
 * the SQLite schema with itself read twice, which only checks the reading.
 */
#include "pf_test.h"
#include "queue_test_util.h"

#include <ctype.h>
#include <libpq-fe.h>
#include <sqlite3.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define SCHEMA_LINES_MAX 256
#define SCHEMA_LINE_MAX 256

typedef struct schema {
    char lines[SCHEMA_LINES_MAX][SCHEMA_LINE_MAX];
    size_t count;
} schema;

static void add_line(schema *s, const char *format, ...) __attribute__((format(printf, 2, 3)));

static void add_line(schema *s, const char *format, ...)
{
    if (s->count >= SCHEMA_LINES_MAX) {
        PF_CHECK_MSG(0, "more than %d schema lines", SCHEMA_LINES_MAX);
        return;
    }
    va_list args;
    va_start(args, format);
    vsnprintf(s->lines[s->count++], SCHEMA_LINE_MAX, format, args);
    va_end(args);
}

static int compare_lines(const void *a, const void *b) { return strcmp(a, b); }

static void sort_schema(schema *s) { qsort(s->lines, s->count, SCHEMA_LINE_MAX, compare_lines); }

/* integer, real or text, from either engine's type name. */
static const char *type_class(const char *type)
{
    char lower[64];
    size_t n = 0;
    for (; type[n] && n + 1 < sizeof lower; n++)
        lower[n] = (char)tolower((unsigned char)type[n]);
    lower[n] = '\0';
    if (strstr(lower, "int"))
        return "integer";
    if (strstr(lower, "real") || strstr(lower, "double") || strstr(lower, "float"))
        return "real";
    if (strstr(lower, "text") || strstr(lower, "char"))
        return "text";
    return lower[0] ? "other" : "none";
}

/* A default as both engines would write it: no "::type" cast; a serial's nextval is none. */
static void normalise_default(const char *value, char *out, size_t size)
{
    if (!value || strncmp(value, "nextval(", 8) == 0) {
        snprintf(out, size, "none");
        return;
    }
    snprintf(out, size, "%s", value);
    char *cast = strstr(out, "::");
    if (cast)
        *cast = '\0';
}

static void lower_in_place(char *text)
{
    for (; *text; text++)
        *text = (char)tolower((unsigned char)*text);
}

/* "(a, b)" or "a,b" → "a,b". */
static void column_list(const char *text, char *out, size_t size)
{
    size_t n = 0;
    for (; *text && n + 1 < size; text++)
        if (*text != ' ' && *text != '(' && *text != ')' && *text != '"')
            out[n++] = *text;
    out[n] = '\0';
}

static int count_occurrences(const char *haystack, const char *needle)
{
    int count = 0;
    for (const char *p = haystack; (p = strstr(p, needle)) != NULL; p += strlen(needle))
        count++;
    return count;
}

/* --- SQLite --------------------------------------------------------------------------- */

static void sqlite_index_columns(sqlite3 *db, const char *index, char *out, size_t size)
{
    sqlite3_stmt *stmt = NULL;
    out[0] = '\0';
    if (sqlite3_prepare_v2(db, "SELECT name FROM pragma_index_info(?) ORDER BY seqno", -1, &stmt,
                           NULL) != SQLITE_OK)
        return;
    sqlite3_bind_text(stmt, 1, index, -1, SQLITE_TRANSIENT);
    while (sqlite3_step(stmt) == SQLITE_ROW) {
        size_t used = strlen(out);
        snprintf(out + used, size - used, "%s%s", used ? "," : "",
                 (const char *)sqlite3_column_text(stmt, 0));
    }
    sqlite3_finalize(stmt);
}

static void read_sqlite(const char *path, schema *s)
{
    sqlite3 *db = NULL;
    PF_REQUIRE(sqlite3_open_v2(path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK);
    sqlite3_stmt *tables = NULL;
    PF_REQUIRE(sqlite3_prepare_v2(db,
                                  "SELECT name, sql FROM sqlite_schema WHERE type = 'table' AND "
                                  "name NOT LIKE 'sqlite_%' ORDER BY name",
                                  -1, &tables, NULL) == SQLITE_OK);
    while (sqlite3_step(tables) == SQLITE_ROW) {
        char table[64], sql[4096];
        snprintf(table, sizeof table, "%s", (const char *)sqlite3_column_text(tables, 0));
        snprintf(sql, sizeof sql, "%s", (const char *)sqlite3_column_text(tables, 1));
        add_line(s, "%s: checks %d", table, count_occurrences(sql, "CHECK"));
        sqlite3_stmt *stmt = NULL;
        char primary[256] = "";
        sqlite3_prepare_v2(db,
                           "SELECT name, type, \"notnull\", dflt_value, pk FROM "
                           "pragma_table_info(?) ORDER BY cid",
                           -1, &stmt, NULL);
        sqlite3_bind_text(stmt, 1, table, -1, SQLITE_TRANSIENT);
        /* pk holds each primary-key column's position in the key (1-based). */
        char key_columns[8][64] = {{0}};
        int key_count = 0;
        while (sqlite3_step(stmt) == SQLITE_ROW) {
            const char *column = (const char *)sqlite3_column_text(stmt, 0);
            int pk = sqlite3_column_int(stmt, 4);
            char fallback[128];
            normalise_default((const char *)sqlite3_column_text(stmt, 3), fallback,
                              sizeof fallback);
            add_line(s, "%s.%s: %s%s default %s", table, column,
                     type_class((const char *)sqlite3_column_text(stmt, 1)),
                     sqlite3_column_int(stmt, 2) || pk ? " not null" : "", fallback);
            if (pk > 0 && pk <= 8) {
                snprintf(key_columns[pk - 1], sizeof key_columns[0], "%s", column);
                key_count = pk > key_count ? pk : key_count;
            }
        }
        sqlite3_finalize(stmt);
        for (int k = 0; k < key_count; k++) {
            size_t used = strlen(primary);
            snprintf(primary + used, sizeof primary - used, "%s%s", k ? "," : "",
                     key_columns[k]);
        }
        add_line(s, "%s: primary key (%s)", table, primary);
        sqlite3_prepare_v2(db,
                           "SELECT \"table\", \"from\", \"to\", on_delete FROM "
                           "pragma_foreign_key_list(?)",
                           -1, &stmt, NULL);
        sqlite3_bind_text(stmt, 1, table, -1, SQLITE_TRANSIENT);
        while (sqlite3_step(stmt) == SQLITE_ROW) {
            char action[32];
            snprintf(action, sizeof action, "%s", (const char *)sqlite3_column_text(stmt, 3));
            lower_in_place(action);
            add_line(s, "%s.%s: references %s(%s) on delete %s", table,
                     (const char *)sqlite3_column_text(stmt, 1),
                     (const char *)sqlite3_column_text(stmt, 0),
                     (const char *)sqlite3_column_text(stmt, 2), action);
        }
        sqlite3_finalize(stmt);
        sqlite3_prepare_v2(db, "SELECT name, origin FROM pragma_index_list(?)", -1, &stmt, NULL);
        sqlite3_bind_text(stmt, 1, table, -1, SQLITE_TRANSIENT);
        while (sqlite3_step(stmt) == SQLITE_ROW) {
            const char *index = (const char *)sqlite3_column_text(stmt, 0);
            const char *origin = (const char *)sqlite3_column_text(stmt, 1);
            char columns[256];
            sqlite_index_columns(db, index, columns, sizeof columns);
            if (!strcmp(origin, "u"))
                add_line(s, "%s: unique (%s)", table, columns);
            else if (!strcmp(origin, "c"))
                add_line(s, "%s: index %s (%s)", table, index, columns);
        }
        sqlite3_finalize(stmt);
    }
    sqlite3_finalize(tables);
    sqlite3_close(db);
}

/* --- PostgreSQL ----------------------------------------------------------------------- */

static PGresult *pg_query(PGconn *conn, const char *sql, const char *table)
{
    const char *params[1] = {table};
    PGresult *result = PQexecParams(conn, sql, table ? 1 : 0, NULL, params, NULL, NULL, 0);
    if (PQresultStatus(result) != PGRES_TUPLES_OK) {
        PF_CHECK_MSG(0, "%s: %s", sql, PQerrorMessage(conn));
        PQclear(result);
        return NULL;
    }
    return result;
}

static void read_postgres(const char *url, schema *s)
{
    PGconn *conn = PQconnectdb(url);
    PF_REQUIRE(PQstatus(conn) == CONNECTION_OK);
    PGresult *tables = pg_query(conn,
                                "SELECT tablename FROM pg_tables WHERE schemaname = "
                                "current_schema() ORDER BY tablename",
                                NULL);
    for (int t = 0; tables && t < PQntuples(tables); t++) {
        const char *table = PQgetvalue(tables, t, 0);
        PGresult *columns = pg_query(
            conn,
            "SELECT column_name, data_type, is_nullable, column_default FROM "
            "information_schema.columns WHERE table_schema = current_schema() AND "
            "table_name = $1 ORDER BY ordinal_position",
            table);
        for (int c = 0; columns && c < PQntuples(columns); c++) {
            char fallback[128];
            normalise_default(PQgetisnull(columns, c, 3) ? NULL : PQgetvalue(columns, c, 3),
                              fallback, sizeof fallback);
            add_line(s, "%s.%s: %s%s default %s", table, PQgetvalue(columns, c, 0),
                     type_class(PQgetvalue(columns, c, 1)),
                     !strcmp(PQgetvalue(columns, c, 2), "NO") ? " not null" : "", fallback);
        }
        PQclear(columns);
        PGresult *constraints = pg_query(conn,
                                         "SELECT contype, pg_get_constraintdef(oid) FROM "
                                         "pg_constraint WHERE conrelid = $1::regclass",
                                         table);
        int checks = 0;
        for (int c = 0; constraints && c < PQntuples(constraints); c++) {
            char type = PQgetvalue(constraints, c, 0)[0];
            const char *definition = PQgetvalue(constraints, c, 1);
            char list[256];
            if (type == 'c') {
                checks++;
            } else if (type == 'p' || type == 'u') {
                column_list(strchr(definition, '('), list, sizeof list);
                add_line(s, "%s: %s (%s)", table, type == 'p' ? "primary key" : "unique", list);
            } else if (type == 'f') {
                /* FOREIGN KEY (a) REFERENCES t(b) [ON DELETE action] */
                char from[64] = "", target[64] = "", to[64] = "", action[32] = "no action";
                sscanf(definition, "FOREIGN KEY (%63[^)]) REFERENCES %63[^(](%63[^)])", from,
                       target, to);
                const char *on_delete = strstr(definition, "ON DELETE ");
                if (on_delete)
                    snprintf(action, sizeof action, "%s", on_delete + strlen("ON DELETE "));
                lower_in_place(action);
                add_line(s, "%s.%s: references %s(%s) on delete %s", table, from, target, to,
                         action);
            }
        }
        PQclear(constraints);
        add_line(s, "%s: checks %d", table, checks);
        /* Named indexes: those no constraint made (a constraint's index has its name). */
        PGresult *indexes = pg_query(conn,
                                     "SELECT indexname, indexdef FROM pg_indexes WHERE "
                                     "schemaname = current_schema() AND tablename = $1 AND "
                                     "indexname NOT IN (SELECT conname FROM pg_constraint)",
                                     table);
        for (int i = 0; indexes && i < PQntuples(indexes); i++) {
            char list[256];
            column_list(strrchr(PQgetvalue(indexes, i, 1), '('), list, sizeof list);
            add_line(s, "%s: index %s (%s)", table, PQgetvalue(indexes, i, 0), list);
        }
        PQclear(indexes);
    }
    PQclear(tables);
    PQfinish(conn);
}

/* Prints every line one side lacks; returns how many. */
static size_t report_differences(const schema *a, const char *a_name, const schema *b,
                                 const char *b_name)
{
    size_t missing = 0;
    for (size_t i = 0; i < a->count; i++)
        if (!bsearch(a->lines[i], b->lines, b->count, SCHEMA_LINE_MAX, compare_lines)) {
            printf("  only in %s: %s\n", a_name, a->lines[i]);
            missing++;
        }
    for (size_t i = 0; i < b->count; i++)
        if (!bsearch(b->lines[i], a->lines, a->count, SCHEMA_LINE_MAX, compare_lines)) {
            printf("  only in %s: %s\n", b_name, b->lines[i]);
            missing++;
        }
    return missing;
}

static schema sqlite_side, other_side;

PF_TEST(sqlite_migrations_and_the_postgres_schema_agree)
{
    char dir[1024], path[1200];
    snprintf(path, sizeof path, "%s/schema.db", pf_test_tmpdir(dir, sizeof dir));
    unlink(path);
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_queue_open(path, NULL, &queue, &err), &err);
    pf_queue_close(queue);
    read_sqlite(path, &sqlite_side);
    const char *url = queue_test_postgres();
    if (url) {
        char buffer[1024];
        fresh_db_path("unused", buffer, sizeof buffer); /* empties the database */
        PF_REQUIRE_OK(pf_queue_open(url, NULL, &queue, &err), &err);
        pf_queue_close(queue);
        read_postgres(url, &other_side);
    } else {
        printf("  no $PF_TEST_POSTGRES_URL: the SQLite schema against itself\n");
        read_sqlite(path, &other_side);
    }
    sort_schema(&sqlite_side);
    sort_schema(&other_side);
    size_t differences =
        report_differences(&sqlite_side, "SQLite", &other_side, url ? "PostgreSQL" : "SQLite");
    printf("  %zu schema lines on SQLite, %zu on the other side, %zu differences\n",
           sqlite_side.count, other_side.count, differences);
    PF_CHECK(differences == 0);
    /* The tables the queue needs are all there (a reading that found nothing agrees too). */
    static const char *const tables[] = {"jobs",          "workers",       "tasks",
                                         "task_failures", "worker_blocks", "stage_timings",
                                         "job_dependencies", "frame_resources",
                                         "schema_version"};
    for (size_t t = 0; t < sizeof tables / sizeof *tables; t++) {
        char line[SCHEMA_LINE_MAX];
        snprintf(line, sizeof line, "%s: primary key (", tables[t]);
        int found = 0;
        for (size_t i = 0; i < sqlite_side.count; i++)
            found |= strncmp(sqlite_side.lines[i], line, strlen(line)) == 0;
        PF_CHECK_MSG(found, "no primary key line for %s", tables[t]);
    }
}

/*
 * PostgreSQL only: a database made at version 4 (before the workers' capabilities, the
 * jobs' requirements, the job dependencies, the frames' resources and the attempts' logs)
 * climbs to the latest on open, and ends with the schema a fresh one has.
 */
PF_TEST(a_version_4_postgres_database_migrates_to_the_latest)
{
    const char *url = queue_test_postgres();
    if (!url) {
        printf("  no $PF_TEST_POSTGRES_URL: nothing to migrate\n");
        return;
    }
    char buffer[1024];
    fresh_db_path("unused", buffer, sizeof buffer);
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_queue_open(url, NULL, &queue, &err), &err);
    pf_queue_close(queue);
    /* Back to version 4 as PostgreSQL support began it: one row, version 4, no version 5
     * columns and no version 6 or 7 column or tables. */
    PGconn *conn = PQconnectdb(url);
    PF_REQUIRE(PQstatus(conn) == CONNECTION_OK);
    PGresult *result = PQexec(conn,
                              "ALTER TABLE workers DROP COLUMN device_type, DROP COLUMN "
                              "device_memory, DROP COLUMN host_memory, DROP COLUMN cores, "
                              "DROP COLUMN tags; ALTER TABLE jobs DROP COLUMN requires_device, "
                              "DROP COLUMN min_device_memory, DROP COLUMN min_host_memory, "
                              "DROP COLUMN required_tags, DROP COLUMN dependents; "
                              "DROP TABLE job_dependencies, frame_resources, attempt_logs; "
                              "DELETE FROM schema_version WHERE version >= 5; "
                              "INSERT INTO schema_version (version, applied_at) VALUES (4, 0) "
                              "ON CONFLICT DO NOTHING");
    PF_CHECK_MSG(PQresultStatus(result) == PGRES_COMMAND_OK, "%s", PQerrorMessage(conn));
    PQclear(result);
    PQfinish(conn);
    PF_REQUIRE_OK(pf_queue_open(url, NULL, &queue, &err), &err);
    int version = 0;
    PF_CHECK_OK(pf_queue_schema_version(queue, &version, &err), &err);
    PF_CHECK(version == PF_QUEUE_SCHEMA_VERSION);
    pf_queue_close(queue);
    schema migrated = {.count = 0};
    read_postgres(url, &migrated);
    sort_schema(&migrated);
    size_t differences = report_differences(&sqlite_side, "SQLite", &migrated, "migrated");
    printf("  version 4 → %d: %zu differences from SQLite's schema\n", PF_QUEUE_SCHEMA_VERSION,
           differences);
    PF_CHECK(differences == 0);
}

int main(void)
{
    PF_RUN(sqlite_migrations_and_the_postgres_schema_agree);
    PF_RUN(a_version_4_postgres_database_migrates_to_the_latest);
    return pf_test_finish();
}
