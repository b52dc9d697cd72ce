/*
 * The queue file: schema_version and migrations, and files that must be
 * refused — not SQLite, random bytes, truncated, damaged, someone else's
 * database, a newer schema — with a message naming the file and the file's
 * bytes unchanged.
 */
#include "queue_test_util.h"

#include "pf_test.h"

#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *scratch_path(const char *name, char *buffer, size_t size)
{
    return fresh_db_path(name, buffer, size);
}

static bool file_exists(const char *path)
{
    struct stat info;
    return stat(path, &info) == 0;
}

/* Opening path must fail with expected_status, name the file and mention
 * needle, and leave the file byte for byte as it was (and create no WAL). */
static void check_refused(const char *path, pf_status expected_status, const char *needle)
{
    size_t before_size = 0, after_size = 0;
    unsigned char *before = read_file_bytes(path, &before_size);
    PF_REQUIRE(before);
    pf_queue *queue = (pf_queue *)&before; /* must be reset to NULL */
    pf_error err = {0};
    pf_status status = pf_queue_open(path, NULL, &queue, &err);
    PF_CHECK_MSG(status == expected_status, "%s: status %d (%s), expected %d", path, status,
                 err.message, expected_status);
    PF_CHECK(queue == NULL);
    PF_CHECK_MSG(strstr(err.message, path) != NULL, "message does not name the file: %s",
                 err.message);
    PF_CHECK_MSG(strstr(err.message, needle) != NULL, "message \"%s\" lacks \"%s\"",
                 err.message, needle);
    unsigned char *after = read_file_bytes(path, &after_size);
    PF_CHECK(after && after_size == before_size && !memcmp(before, after, before_size));
    char wal[1200];
    snprintf(wal, sizeof wal, "%s-wal", path);
    PF_CHECK_MSG(!file_exists(wal), "%s was created", wal);
    free(before);
    free(after);
}

/* Deterministic noise (a 64-bit LCG, Knuth MMIX constants). */
static void fill_noise(unsigned char *bytes, size_t size, uint64_t seed)
{
    for (size_t i = 0; i < size; i++) {
        seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
        bytes[i] = (unsigned char)(seed >> 56);
    }
}

/* Builds a real queue with enough rows to span many pages; returns its size. */
static size_t make_real_queue(const char *path)
{
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_open(path, NULL, &queue, &err), &err);
    if (!queue)
        return 0;
    pf_queue_job_spec spec = {.scene_path = "scene.gltf", .frame_range = "1-3000",
                              .output_pattern = "f_####.exr"};
    int64_t job_id;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    pf_queue_close(queue);
    size_t size = 0;
    free(read_file_bytes(path, &size));
    return size;
}

static int64_t count_rows(const char *path, const char *sql)
{
    sqlite3 *db = NULL;
    int64_t value = -1;
    if (sqlite3_open_v2(path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK) {
        sqlite3_stmt *stmt;
        if (sqlite3_prepare_v2(db, sql, -1, &stmt, NULL) == SQLITE_OK) {
            if (sqlite3_step(stmt) == SQLITE_ROW)
                value = sqlite3_column_int64(stmt, 0);
            sqlite3_finalize(stmt);
        }
    }
    sqlite3_close(db);
    return value;
}

PF_TEST(schema_version_is_recorded_once)
{
    char path[1200];
    scratch_path("schema.db", path, sizeof path);
    test_clock clock = {1000};
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(open_queue(path, NULL, &clock, &queue, &err), &err);
    int version = 0;
    PF_CHECK_OK(pf_queue_schema_version(queue, &version, &err), &err);
    PF_CHECK(version == PF_QUEUE_SCHEMA_VERSION);
    pf_queue_job_spec spec = {.scene_path = "a.gltf", .frame_range = "1-3",
                              .output_pattern = "a_####.exr"};
    int64_t job_id = 0;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    pf_queue_close(queue);

    /* Migrations ran with the clock at 1000 ms; reopening later migrates
     * nothing (applied_at stays) and keeps the data. */
    for (int reopen = 0; reopen < 2; reopen++) {
        clock.now = 5000 + reopen;
        PF_REQUIRE_OK(open_queue(path, NULL, &clock, &queue, &err), &err);
        PF_CHECK_OK(pf_queue_schema_version(queue, &version, &err), &err);
        PF_CHECK(version == PF_QUEUE_SCHEMA_VERSION);
        pf_queue_job job;
        PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
        PF_CHECK(job.tasks_total == 3);
        pf_queue_job_clear(&job);
        pf_queue_close(queue);
    }
    PF_CHECK(count_rows(path, "SELECT count(*) FROM schema_version") == PF_QUEUE_SCHEMA_VERSION);
    PF_CHECK(count_rows(path, "SELECT min(applied_at) FROM schema_version") == 1000);
    PF_CHECK(count_rows(path, "SELECT max(applied_at) FROM schema_version") == 1000);
    /* WAL is a property of the file: visible to any connection. */
    sqlite3 *db = NULL;
    PF_REQUIRE(sqlite3_open_v2(path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK);
    sqlite3_stmt *stmt;
    PF_REQUIRE(sqlite3_prepare_v2(db, "PRAGMA journal_mode", -1, &stmt, NULL) == SQLITE_OK);
    PF_CHECK(sqlite3_step(stmt) == SQLITE_ROW &&
             !strcmp((const char *)sqlite3_column_text(stmt, 0), "wal"));
    sqlite3_finalize(stmt);
    sqlite3_close(db);
}

PF_TEST(text_file_is_refused_untouched)
{
    char path[1200];
    scratch_path("notes.txt", path, sizeof path);
    const char *text = "these are my notes, not a render queue\n";
    PF_REQUIRE(write_file_bytes(path, text, strlen(text)) == 0);
    check_refused(path, PF_ERR_FORMAT, "not an SQLite database");
}

PF_TEST(random_bytes_are_refused_untouched)
{
    char path[1200];
    unsigned char noise[8192];
    scratch_path("noise.db", path, sizeof path);
    fill_noise(noise, sizeof noise, 42);
    PF_REQUIRE(write_file_bytes(path, noise, sizeof noise) == 0);
    check_refused(path, PF_ERR_FORMAT, "not an SQLite database");

    /* The right magic followed by noise: the header itself is then corrupt. */
    memcpy(noise, "SQLite format 3", 16);
    PF_REQUIRE(write_file_bytes(path, noise, sizeof noise) == 0);
    check_refused(path, PF_ERR_FORMAT, "corrupt");
}

PF_TEST(truncated_database_is_refused_untouched)
{
    char path[1200];
    scratch_path("truncated.db", path, sizeof path);
    size_t size = make_real_queue(path);
    PF_REQUIRE(size >= 16 * 4096);
    size_t full_size = 0;
    unsigned char *full = read_file_bytes(path, &full_size);
    PF_REQUIRE(full);

    /* Cut at a page boundary (header page count disagrees) and mid-page. */
    PF_REQUIRE(write_file_bytes(path, full, 8 * 4096) == 0);
    check_refused(path, PF_ERR_FORMAT, "truncated");
    PF_REQUIRE(write_file_bytes(path, full, full_size / 2 + 100) == 0);
    check_refused(path, PF_ERR_FORMAT, "truncated");
    free(full);
}

PF_TEST(damaged_page_is_refused_untouched)
{
    char path[1200];
    scratch_path("damaged.db", path, sizeof path);
    size_t size = make_real_queue(path);
    PF_REQUIRE(size >= 16 * 4096);
    size_t full_size = 0;
    unsigned char *bytes = read_file_bytes(path, &full_size);
    PF_REQUIRE(bytes);
    /* Overwrite a b-tree page in the middle of the file with noise. */
    fill_noise(bytes + 6 * 4096, 4096, 7);
    PF_REQUIRE(write_file_bytes(path, bytes, full_size) == 0);
    check_refused(path, PF_ERR_FORMAT, "corrupt");
    free(bytes);
}

PF_TEST(foreign_and_newer_databases_are_refused)
{
    char path[1200];
    scratch_path("photos.db", path, sizeof path);
    sqlite3 *db = NULL;
    PF_REQUIRE(sqlite3_open(path, &db) == SQLITE_OK);
    PF_CHECK(sqlite3_exec(db, "CREATE TABLE photos (name TEXT); INSERT INTO photos VALUES ('x')",
                          NULL, NULL, NULL) == SQLITE_OK);
    sqlite3_close(db);
    check_refused(path, PF_ERR_FORMAT, "not a photonfarm queue");

    scratch_path("newer.db", path, sizeof path);
    PF_REQUIRE(make_real_queue(path) > 0);
    PF_REQUIRE(sqlite3_open(path, &db) == SQLITE_OK);
    PF_CHECK(sqlite3_exec(db, "INSERT INTO schema_version VALUES (99, 5)", NULL, NULL, NULL) ==
             SQLITE_OK);
    sqlite3_close(db);
    check_refused(path, PF_ERR_UNSUPPORTED, "newer");
}

PF_TEST(paths_that_are_not_files)
{
    char dir[1024], path[1200];
    pf_test_tmpdir(dir, sizeof dir);
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_CHECK(pf_queue_open(dir, NULL, &queue, &err) == PF_ERR_FORMAT);
    PF_CHECK(strstr(err.message, "not a regular file") != NULL);
    snprintf(path, sizeof path, "%s/no/such/dir/queue.db", dir);
    PF_CHECK(pf_queue_open(path, NULL, &queue, &err) == PF_ERR_IO);
    PF_CHECK(strstr(err.message, path) != NULL);
    PF_CHECK(queue == NULL);

    /* A zero-length file is an empty database to SQLite: it becomes a queue. */
    scratch_path("empty.db", path, sizeof path);
    PF_REQUIRE(write_file_bytes(path, "", 0) == 0);
    PF_CHECK_OK(pf_queue_open(path, NULL, &queue, &err), &err);
    pf_queue_close(queue);
}

int main(void)
{
    PF_RUN(schema_version_is_recorded_once);
    PF_RUN(text_file_is_refused_untouched);
    PF_RUN(random_bytes_are_refused_untouched);
    PF_RUN(truncated_database_is_refused_untouched);
    PF_RUN(damaged_page_is_refused_untouched);
    PF_RUN(foreign_and_newer_databases_are_refused);
    PF_RUN(paths_that_are_not_files);
    return pf_test_finish();
}
