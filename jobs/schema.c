/*
 * Opening a queue: a read-only sanity check of an existing file, connection
 * settings, and schema migrations recorded in schema_version.
 */
#include "queue_internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

/* https://sqlite.org/fileformat.html §1.3: the 100-byte database header. */
#define SQLITE_HEADER_SIZE 100
#define SQLITE_HEADER_MAGIC "SQLite format 3"   /* 16 bytes with its NUL */
#define SQLITE_HEADER_PAGE_SIZE 16              /* 2 bytes; 1 means 65536 */
#define SQLITE_HEADER_CHANGE_COUNTER 24
#define SQLITE_HEADER_PAGE_COUNT 28
#define SQLITE_HEADER_VERSION_VALID_FOR 92

#define QUEUE_DEFAULT_BUSY_TIMEOUT_MS 5000
#define QUEUE_DEFAULT_LEASE_MS 30000
#define QUEUE_DEFAULT_BACKOFF_BASE_MS 2000
#define QUEUE_DEFAULT_BACKOFF_CAP_MS 300000
#define QUEUE_DEFAULT_BLOCK_AFTER 3
#define QUEUE_DEFAULT_WORKER_ALIVE_MS 90000 /* three default leases */

/* Version 5's columns, on either engine (its integer type): the workers' capabilities and
 * the jobs' requirements (issue 42). */
#define WORKER_CAPABILITIES(integer)                                                        \
    "ALTER TABLE workers ADD COLUMN device_type TEXT NOT NULL DEFAULT '';"                   \
    "ALTER TABLE workers ADD COLUMN device_memory " integer " NOT NULL DEFAULT 0;"           \
    "ALTER TABLE workers ADD COLUMN host_memory " integer " NOT NULL DEFAULT 0;"             \
    "ALTER TABLE workers ADD COLUMN cores " integer " NOT NULL DEFAULT 0;"                   \
    "ALTER TABLE workers ADD COLUMN tags TEXT NOT NULL DEFAULT '';"                          \
    "ALTER TABLE jobs ADD COLUMN requires_device TEXT NOT NULL DEFAULT '' CHECK"            \
    "  (requires_device IN ('', 'gpu', 'cpu'));"                                             \
    "ALTER TABLE jobs ADD COLUMN min_device_memory " integer " NOT NULL DEFAULT 0;"          \
    "ALTER TABLE jobs ADD COLUMN min_host_memory " integer " NOT NULL DEFAULT 0;"            \
    "ALTER TABLE jobs ADD COLUMN required_tags TEXT NOT NULL DEFAULT '';"

/* Version 6's tables, on either engine (its integer type), both issue 42's. Which jobs a
 * job waits for: per_frame 0, every frame of after_job done; 1, frame n waits for
 * after_job's tasks whose frames overlap it (no job is ever deleted, so after_job needs
 * no cascade); jobs.dependents is 1 once some job waits for it, so that a completion
 * looks for tasks to release (dependencies.c) only then. What each completed frame took: the worker's peak resident memory and its
 * device's peak memory during the frame, and the bytes of the frame's file (bytes; -1:
 * not measured). */
#define JOB_DEPENDENCIES(integer)                                                           \
    "ALTER TABLE jobs ADD COLUMN dependents INTEGER NOT NULL DEFAULT 0;"                     \
    "CREATE TABLE job_dependencies ("                                                        \
    "  job_id " integer " NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,"                  \
    "  after_job " integer " NOT NULL REFERENCES jobs(id),"                                  \
    "  per_frame INTEGER NOT NULL DEFAULT 0 CHECK (per_frame IN (0, 1)),"                    \
    "  PRIMARY KEY (job_id, after_job));"                                                    \
    "CREATE INDEX job_dependencies_after ON job_dependencies(after_job);"                    \
    "CREATE TABLE frame_resources ("                                                         \
    "  task_id " integer " NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"                \
    "  attempt INTEGER NOT NULL,"                                                            \
    "  frame INTEGER NOT NULL,"                                                              \
    "  peak_rss " integer " NOT NULL,"                                                       \
    "  peak_device_memory " integer " NOT NULL,"                                             \
    "  bytes_written " integer " NOT NULL,"                                                  \
    "  PRIMARY KEY (task_id, frame));"

/* Version 7's table, on either engine (its integer type): each attempt's log lines
 * (issue 41; attempt_logs.c). */
#define ATTEMPT_LOGS(integer)                                                               \
    "CREATE TABLE attempt_logs ("                                                            \
    "  task_id " integer " NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"                \
    "  attempt INTEGER NOT NULL,"                                                            \
    "  worker_id " integer " REFERENCES workers(id) ON DELETE SET NULL,"                    \
    "  written_at " integer " NOT NULL,"                                                     \
    "  log TEXT NOT NULL,"                                                                   \
    "  PRIMARY KEY (task_id, attempt));"

/* Migration N (1-based) brings the schema from version N-1 to N. */
static const char *const migrations[PF_QUEUE_SCHEMA_VERSION] = {
    "CREATE TABLE jobs ("
    "  id INTEGER PRIMARY KEY,"
    "  scene_path TEXT NOT NULL,"
    "  parameters TEXT NOT NULL DEFAULT '{}' CHECK (json_valid(parameters)),"
    "  frame_range TEXT NOT NULL,"
    "  output_pattern TEXT NOT NULL,"
    "  priority INTEGER NOT NULL DEFAULT 0,"
    "  status TEXT NOT NULL DEFAULT 'queued' CHECK (status IN"
    "    ('queued','running','paused','done','failed','canceled')),"
    "  max_attempts INTEGER NOT NULL CHECK (max_attempts >= 1),"
    "  frames_per_task INTEGER NOT NULL CHECK (frames_per_task >= 1),"
    /* Failures up to this task_failures id no longer count towards blocking
     * (set by retry, which lifts the blocks they caused). */
    "  block_failures_after INTEGER NOT NULL DEFAULT 0,"
    "  created_at INTEGER NOT NULL,"
    "  started_at INTEGER,"
    "  updated_at INTEGER NOT NULL);"
    "CREATE TABLE workers ("
    "  id INTEGER PRIMARY KEY,"
    "  name TEXT NOT NULL UNIQUE,"
    "  host TEXT NOT NULL DEFAULT '',"
    "  pid INTEGER NOT NULL DEFAULT 0,"
    "  device TEXT NOT NULL DEFAULT '',"
    "  heartbeat_at INTEGER NOT NULL,"
    "  started_at INTEGER NOT NULL,"
    "  stopped_at INTEGER,"
    "  current_task_id INTEGER REFERENCES tasks(id) ON DELETE SET NULL);"
    "CREATE TABLE tasks ("
    "  id INTEGER PRIMARY KEY,"
    "  job_id INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,"
    "  first_frame INTEGER NOT NULL,"
    "  last_frame INTEGER NOT NULL,"
    "  frame_step INTEGER NOT NULL CHECK (frame_step >= 1),"
    "  frame_count INTEGER NOT NULL CHECK (frame_count >= 1),"
    "  status TEXT NOT NULL DEFAULT 'queued' CHECK (status IN"
    "    ('queued','running','done','failed','canceled')),"
    "  attempt INTEGER NOT NULL DEFAULT 0,"
    "  worker_id INTEGER REFERENCES workers(id) ON DELETE SET NULL,"
    "  lease_token TEXT UNIQUE,"
    "  lease_expires INTEGER,"
    "  eligible_at INTEGER NOT NULL DEFAULT 0,"
    "  started_at INTEGER,"
    "  finished_at INTEGER,"
    "  last_error TEXT);"
    /* Claim walks one job's queued tasks in frame order; status derivation
     * and the per-job EXISTS probes seek by (job, status). */
    "CREATE INDEX tasks_job_status_frame ON tasks(job_id, status, first_frame);"
    /* The reaper finds running tasks by lease expiry. */
    "CREATE INDEX tasks_status_lease ON tasks(status, lease_expires);"
    "CREATE TABLE task_failures ("
    "  id INTEGER PRIMARY KEY,"
    "  task_id INTEGER NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"
    "  attempt INTEGER NOT NULL,"
    "  worker_id INTEGER REFERENCES workers(id) ON DELETE SET NULL,"
    "  worker_name TEXT NOT NULL,"
    "  error TEXT NOT NULL,"
    "  failed_at INTEGER NOT NULL);"
    "CREATE INDEX task_failures_task ON task_failures(task_id);"
    "CREATE TABLE worker_blocks ("
    "  job_id INTEGER NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,"
    "  worker_id INTEGER NOT NULL REFERENCES workers(id) ON DELETE CASCADE,"
    "  blocked_at INTEGER NOT NULL,"
    "  PRIMARY KEY (job_id, worker_id));"
    "CREATE TABLE stage_timings ("
    "  id INTEGER PRIMARY KEY,"
    "  task_id INTEGER NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"
    "  attempt INTEGER NOT NULL,"
    "  frame INTEGER NOT NULL,"
    "  stage TEXT NOT NULL,"
    "  wall_ms REAL NOT NULL,"
    "  gpu_ms REAL,"
    "  counters TEXT CHECK (counters IS NULL OR json_valid(counters)),"
    "  skipped INTEGER NOT NULL DEFAULT 0,"
    "  reason TEXT);"
    "CREATE INDEX stage_timings_task ON stage_timings(task_id);",
    /* 2: the build (version + git revision) that recorded each stage row. */
    "ALTER TABLE stage_timings ADD COLUMN build TEXT;",
    /* 3: each worker's lease, so that it counts as dead once silent for its own lease
     * (0: registered by an older client; the queue's worker_alive_ms applies). */
    "ALTER TABLE workers ADD COLUMN lease_ms INTEGER NOT NULL DEFAULT 0;",
    /* 4: failures that are the job's (its output storage, its scene), which pause the
     * job with their reason instead of counting against the worker (issue 14). */
    "ALTER TABLE jobs ADD COLUMN pause_reason TEXT;"
    "ALTER TABLE task_failures ADD COLUMN job_fault INTEGER NOT NULL DEFAULT 0;",
    /* 5: each worker's capabilities (issue 42): its device's type and memory, the host's
     * memory and cores, and its tags ("a,b"); each job's requirements of them. */
    WORKER_CAPABILITIES("INTEGER"),
    /* 6: job dependencies and per-frame resources (issue 42). */
    JOB_DEPENDENCIES("INTEGER"),
    /* 7: each attempt's log lines (issue 41). */
    ATTEMPT_LOGS("INTEGER"),
};

/*
 * PostgreSQL: the latest schema in one go (PostgreSQL support began at
 * version 4; a database made then climbs pg_migrations below). The same tables
 * as the SQLite migrations above; times are BIGINT (ms since the epoch), a
 * JSON column is checked by a jsonb cast, and workers' reference to tasks is
 * added once both tables exist.
 */
static const char pg_schema[] =
    "CREATE TABLE schema_version ("
    "  version INTEGER PRIMARY KEY,"
    "  applied_at BIGINT NOT NULL);"
    "CREATE TABLE jobs ("
    "  id BIGSERIAL PRIMARY KEY,"
    "  scene_path TEXT NOT NULL,"
    "  parameters TEXT NOT NULL DEFAULT '{}' CHECK (parameters::jsonb IS NOT NULL),"
    "  frame_range TEXT NOT NULL,"
    "  output_pattern TEXT NOT NULL,"
    "  priority INTEGER NOT NULL DEFAULT 0,"
    "  status TEXT NOT NULL DEFAULT 'queued' CHECK (status IN"
    "    ('queued','running','paused','done','failed','canceled')),"
    "  max_attempts INTEGER NOT NULL CHECK (max_attempts >= 1),"
    "  frames_per_task INTEGER NOT NULL CHECK (frames_per_task >= 1),"
    "  block_failures_after BIGINT NOT NULL DEFAULT 0,"
    "  created_at BIGINT NOT NULL,"
    "  started_at BIGINT,"
    "  updated_at BIGINT NOT NULL,"
    "  pause_reason TEXT);"
    "CREATE TABLE workers ("
    "  id BIGSERIAL PRIMARY KEY,"
    "  name TEXT NOT NULL UNIQUE,"
    "  host TEXT NOT NULL DEFAULT '',"
    "  pid BIGINT NOT NULL DEFAULT 0,"
    "  device TEXT NOT NULL DEFAULT '',"
    "  heartbeat_at BIGINT NOT NULL,"
    "  started_at BIGINT NOT NULL,"
    "  stopped_at BIGINT,"
    "  current_task_id BIGINT,"
    "  lease_ms BIGINT NOT NULL DEFAULT 0);"
    "CREATE TABLE tasks ("
    "  id BIGSERIAL PRIMARY KEY,"
    "  job_id BIGINT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,"
    "  first_frame INTEGER NOT NULL,"
    "  last_frame INTEGER NOT NULL,"
    "  frame_step INTEGER NOT NULL CHECK (frame_step >= 1),"
    "  frame_count INTEGER NOT NULL CHECK (frame_count >= 1),"
    "  status TEXT NOT NULL DEFAULT 'queued' CHECK (status IN"
    "    ('queued','running','done','failed','canceled')),"
    "  attempt INTEGER NOT NULL DEFAULT 0,"
    "  worker_id BIGINT REFERENCES workers(id) ON DELETE SET NULL,"
    "  lease_token TEXT UNIQUE,"
    "  lease_expires BIGINT,"
    "  eligible_at BIGINT NOT NULL DEFAULT 0,"
    "  started_at BIGINT,"
    "  finished_at BIGINT,"
    "  last_error TEXT);"
    "ALTER TABLE workers ADD FOREIGN KEY (current_task_id) REFERENCES tasks(id)"
    "  ON DELETE SET NULL;"
    "CREATE INDEX tasks_job_status_frame ON tasks(job_id, status, first_frame);"
    "CREATE INDEX tasks_status_lease ON tasks(status, lease_expires);"
    "CREATE TABLE task_failures ("
    "  id BIGSERIAL PRIMARY KEY,"
    "  task_id BIGINT NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"
    "  attempt INTEGER NOT NULL,"
    "  worker_id BIGINT REFERENCES workers(id) ON DELETE SET NULL,"
    "  worker_name TEXT NOT NULL,"
    "  error TEXT NOT NULL,"
    "  failed_at BIGINT NOT NULL,"
    "  job_fault INTEGER NOT NULL DEFAULT 0);"
    "CREATE INDEX task_failures_task ON task_failures(task_id);"
    "CREATE TABLE worker_blocks ("
    "  job_id BIGINT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,"
    "  worker_id BIGINT NOT NULL REFERENCES workers(id) ON DELETE CASCADE,"
    "  blocked_at BIGINT NOT NULL,"
    "  PRIMARY KEY (job_id, worker_id));"
    "CREATE TABLE stage_timings ("
    "  id BIGSERIAL PRIMARY KEY,"
    "  task_id BIGINT NOT NULL REFERENCES tasks(id) ON DELETE CASCADE,"
    "  attempt INTEGER NOT NULL,"
    "  frame INTEGER NOT NULL,"
    "  stage TEXT NOT NULL,"
    "  wall_ms DOUBLE PRECISION NOT NULL,"
    "  gpu_ms DOUBLE PRECISION,"
    "  counters TEXT CHECK (counters IS NULL OR counters::jsonb IS NOT NULL),"
    "  skipped INTEGER NOT NULL DEFAULT 0,"
    "  reason TEXT,"
    "  build TEXT);"
    "CREATE INDEX stage_timings_task ON stage_timings(task_id);"
    WORKER_CAPABILITIES("BIGINT") JOB_DEPENDENCIES("BIGINT") ATTEMPT_LOGS("BIGINT");

/* PostgreSQL from version N-1 to N, for N after PF_QUEUE_PG_FIRST_VERSION (the schema
 * above is the latest; a database created at an older version climbs these). */
#define PF_QUEUE_PG_FIRST_VERSION 4
static const char *const pg_migrations[PF_QUEUE_SCHEMA_VERSION + 1] = {
    [5] = WORKER_CAPABILITIES("BIGINT"),
    [6] = JOB_DEPENDENCIES("BIGINT"),
    [7] = ATTEMPT_LOGS("BIGINT"),
};

static int64_t wall_clock_ms(void *user)
{
    (void)user;
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    return (int64_t)now.tv_sec * 1000 + now.tv_nsec / 1000000;
}

void pf_queue_set_clock(pf_queue *queue, pf_queue_clock clock, void *user)
{
    queue->clock = clock ? clock : wall_clock_ms;
    queue->clock_user = clock ? user : NULL;
}

int64_t pf_queue_now(pf_queue *queue) { return queue->clock(queue->clock_user); }

static uint32_t read_be(const unsigned char *bytes, int count)
{
    uint32_t value = 0;
    for (int i = 0; i < count; i++)
        value = value << 8 | bytes[i];
    return value;
}

/* Checks an existing file's SQLite header and size by reading only. */
static pf_status check_header(const char *path, off_t file_size, pf_error *err)
{
    unsigned char header[SQLITE_HEADER_SIZE];
    FILE *file = fopen(path, "rb");
    if (!file)
        return pf_error_set(err, PF_ERR_IO, "%s: cannot read queue database: %s", path,
                            strerror(errno));
    size_t got = fread(header, 1, sizeof header, file);
    fclose(file);
    if (got < sizeof header || memcmp(header, SQLITE_HEADER_MAGIC, sizeof SQLITE_HEADER_MAGIC))
        return pf_error_set(err, PF_ERR_FORMAT,
                            "%s: not an SQLite database (no \"" SQLITE_HEADER_MAGIC
                            "\" header); refusing to use it as a queue",
                            path);
    uint32_t page_size = read_be(header + SQLITE_HEADER_PAGE_SIZE, 2);
    if (page_size == 1)
        page_size = 65536;
    if (page_size < 512 || page_size > 65536 || (page_size & (page_size - 1)))
        return pf_error_set(err, PF_ERR_FORMAT, "%s: corrupt SQLite header (page size %u)",
                            path, page_size);
    if (file_size % page_size)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "%s: truncated or corrupt database (%lld bytes is not a whole "
                            "number of %u-byte pages)",
                            path, (long long)file_size, page_size);
    uint32_t page_count = read_be(header + SQLITE_HEADER_PAGE_COUNT, 4);
    bool count_valid = page_count != 0 && read_be(header + SQLITE_HEADER_CHANGE_COUNTER, 4) ==
                                              read_be(header + SQLITE_HEADER_VERSION_VALID_FOR, 4);
    if (count_valid && (uint64_t)page_count * page_size > (uint64_t)file_size)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "%s: truncated database (header says %u pages of %u bytes, file "
                            "has %lld bytes)",
                            path, page_count, page_size, (long long)file_size);
    return PF_OK;
}

static pf_status single_int(pf_queue *queue, const char *sql, int64_t *value, pf_error *err)
{
    return queue_read_int64(queue, sql, NULL, 0, sql, value, err);
}

/* Read-only checks of an existing database: integrity, and that it is ours. */
static pf_status check_contents(pf_queue *queue, pf_error *err)
{
    queue_stmt *stmt;
    pf_error prepare_err = {0};
    if (queue_prepare(queue, "PRAGMA quick_check(1)", &stmt, &prepare_err) != PF_OK)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: corrupt database: %s", queue->path,
                            sqlite3_errmsg(queue->db));
    int rc = queue_step(stmt);
    char verdict[256];
    queue_copy_text(verdict, sizeof verdict,
                    rc == QUEUE_ROW ? queue_column_text(stmt, 0) : sqlite3_errmsg(queue->db));
    queue_finalize(stmt);
    if (rc != QUEUE_ROW || strcmp(verdict, "ok") != 0)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: corrupt database: %s", queue->path,
                            verdict);

    int64_t objects = 0, ours = 0;
    pf_status status = single_int(queue, "SELECT count(*) FROM sqlite_schema", &objects, err);
    if (status == PF_OK)
        status = single_int(queue,
                            "SELECT count(*) FROM sqlite_schema WHERE type = 'table' AND "
                            "name = 'schema_version'",
                            &ours, err);
    if (status != PF_OK)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: corrupt database: %s", queue->path,
                            err ? err->message : "");
    if (objects > 0 && !ours)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "%s: an SQLite database but not a photonfarm queue (no "
                            "schema_version table); refusing to modify it",
                            queue->path);
    if (ours) {
        int64_t version = 0;
        status = single_int(queue, "SELECT coalesce(max(version), 0) FROM schema_version",
                            &version, err);
        if (status != PF_OK)
            return status;
        if (version > PF_QUEUE_SCHEMA_VERSION)
            return pf_error_set(err, PF_ERR_UNSUPPORTED,
                                "%s: queue schema version %lld is newer than this photonfarm "
                                "(%d); upgrade photonfarm",
                                queue->path, (long long)version, PF_QUEUE_SCHEMA_VERSION);
    }
    return PF_OK;
}

/* Records that the schema is now at version. */
static pf_status record_version(pf_queue *queue, int64_t version, pf_error *err)
{
    queue_stmt *stmt;
    pf_status status = queue_prepare(
        queue, "INSERT INTO schema_version (version, applied_at) VALUES (?, ?)", &stmt, err);
    if (status != PF_OK)
        return status;
    queue_bind_int64(stmt, 1, version);
    queue_bind_int64(stmt, 2, pf_queue_now(queue));
    return queue_step_done(queue, stmt, "recording the schema version", err);
}

static pf_status migrate(pf_queue *queue, void *context, pf_error *err)
{
    (void)context;
    pf_status status = queue_exec(queue,
                                  "CREATE TABLE IF NOT EXISTS schema_version ("
                                  "  version INTEGER PRIMARY KEY,"
                                  "  applied_at INTEGER NOT NULL)",
                                  err);
    int64_t version = 0;
    if (status == PF_OK)
        status = single_int(queue, "SELECT coalesce(max(version), 0) FROM schema_version",
                            &version, err);
    for (int64_t next = version + 1; status == PF_OK && next <= PF_QUEUE_SCHEMA_VERSION; next++) {
        status = queue_exec(queue, migrations[next - 1], err);
        if (status == PF_OK)
            status = record_version(queue, next, err);
        if (status != PF_OK)
            pf_error_prefix(err, "migrating the queue schema to version %lld", (long long)next);
    }
    return status;
}

static void apply_defaults(pf_queue_options *options)
{
    if (options->busy_timeout_ms <= 0)
        options->busy_timeout_ms = QUEUE_DEFAULT_BUSY_TIMEOUT_MS;
    if (options->lease_ms <= 0)
        options->lease_ms = QUEUE_DEFAULT_LEASE_MS;
    if (options->backoff_base_ms <= 0)
        options->backoff_base_ms = QUEUE_DEFAULT_BACKOFF_BASE_MS;
    if (options->backoff_cap_ms <= 0)
        options->backoff_cap_ms = QUEUE_DEFAULT_BACKOFF_CAP_MS;
    if (options->block_after_failures <= 0)
        options->block_after_failures = QUEUE_DEFAULT_BLOCK_AFTER;
    if (options->worker_alive_ms <= 0)
        options->worker_alive_ms = QUEUE_DEFAULT_WORKER_ALIVE_MS;
}

/* PostgreSQL: creates the schema on first use; refuses one newer than this build. */
static pf_status pg_migrate(pf_queue *queue, void *context, pf_error *err)
{
    (void)context;
    int64_t exists = 0, version = 0;
    pf_status status = single_int(queue,
                                  "SELECT count(*) FROM pg_tables WHERE schemaname = "
                                  "current_schema() AND tablename = 'schema_version'",
                                  &exists, err);
    if (status == PF_OK && !exists) {
        status = queue_exec(queue, pg_schema, err);
        return status == PF_OK ? record_version(queue, PF_QUEUE_SCHEMA_VERSION, err) : status;
    }
    if (status == PF_OK)
        status = single_int(queue, "SELECT coalesce(max(version), 0) FROM schema_version",
                            &version, err);
    if (status == PF_OK && version > PF_QUEUE_SCHEMA_VERSION)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "%s: queue schema version %lld is newer than this photonfarm (%d); "
                            "upgrade photonfarm",
                            queue->path, (long long)version, PF_QUEUE_SCHEMA_VERSION);
    if (status == PF_OK && version < PF_QUEUE_PG_FIRST_VERSION)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "%s: queue schema version %lld predates PostgreSQL support (%d)",
                            queue->path, (long long)version, PF_QUEUE_PG_FIRST_VERSION);
    for (int64_t next = version + 1; status == PF_OK && next <= PF_QUEUE_SCHEMA_VERSION; next++) {
        status = queue_exec(queue, pg_migrations[next], err);
        if (status == PF_OK)
            status = record_version(queue, next, err);
        if (status != PF_OK)
            pf_error_prefix(err, "migrating the queue schema to version %lld", (long long)next);
    }
    return status;
}

/* A queue record with options (defaults filled in) and its clock; NULL when out of memory. */
static pf_queue *new_queue(const pf_queue_options *options)
{
    pf_queue *queue = calloc(1, sizeof *queue);
    if (!queue)
        return NULL;
    if (options)
        queue->options = *options;
    apply_defaults(&queue->options);
    pf_queue_set_clock(queue, queue->options.clock, queue->options.clock_user);
    return queue;
}

/* Brings the schema up to date (when status is still PF_OK) and hands the queue out, or
 * closes it. */
static pf_status finish_open(pf_queue *queue, pf_status status, const char *what,
                             queue_tx_body schema, pf_queue **out, pf_error *err)
{
    if (status == PF_OK)
        status = queue_write(queue, what, schema, NULL, err);
    if (status != PF_OK) {
        pf_queue_close(queue);
        return status;
    }
    *out = queue;
    return PF_OK;
}

static pf_status open_postgres(const char *url, const pf_queue_options *options,
                               pf_queue **out, pf_error *err)
{
    pf_queue *queue = new_queue(options);
    if (!queue)
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory opening the queue");
    pf_status status = queue_pg_connect(queue, url, err);
    return finish_open(queue, status, "creating the queue schema", pg_migrate, out, err);
}

pf_status pf_queue_open(const char *path, const pf_queue_options *options, pf_queue **out,
                        pf_error *err)
{
    *out = NULL;
    if (!path || !*path)
        return pf_error_set(err, PF_ERR_INVALID, "queue database path is empty");
    if (pf_queue_is_url(path))
        return open_postgres(path, options, out, err);

    struct stat info;
    bool exists = stat(path, &info) == 0;
    if (exists && !S_ISREG(info.st_mode))
        return pf_error_set(err, PF_ERR_FORMAT, "%s: not a regular file", path);
    /* A zero-length file is what SQLite itself treats as an empty database. */
    bool existing_database = exists && info.st_size > 0;
    if (existing_database) {
        pf_status status = check_header(path, info.st_size, err);
        if (status != PF_OK)
            return status;
    }

    pf_queue *queue = new_queue(options);
    if (!queue || !(queue->path = strdup(path))) {
        free(queue);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory opening the queue", path);
    }

    /* An existing file is opened without SQLITE_OPEN_CREATE so a file that
     * vanished meanwhile is an error rather than a fresh empty queue. */
    int flags = SQLITE_OPEN_READWRITE | (exists ? 0 : SQLITE_OPEN_CREATE);
    pf_status status = PF_OK;
    if (sqlite3_open_v2(path, &queue->db, flags, NULL) != SQLITE_OK) {
        status = pf_error_set(err, PF_ERR_IO, "%s: cannot open queue database: %s", path,
                              queue->db ? sqlite3_errmsg(queue->db) : "out of memory");
        pf_queue_close(queue);
        return status;
    }
    sqlite3_busy_timeout(queue->db, queue->options.busy_timeout_ms);
    sqlite3_extended_result_codes(queue->db, 1);

    if (existing_database)
        status = check_contents(queue, err);
    /* journal_mode=WAL is persistent in the file; the others are per connection. */
    if (status == PF_OK)
        status = queue_exec(queue, "PRAGMA foreign_keys = ON", err);
    /* In WAL mode NORMAL syncs at checkpoints, not at every commit: a killed
     * process loses nothing, a power cut at most the last commits of the
     * host the database lives on, whose workers died with them (a lost claim
     * is a task queued again, a lost completion a frame rendered again: the
     * queue stays consistent). Checkpoints every 8,000 pages (32 MB of WAL)
     * instead of 1,000 write the queue's few hot pages back less often. On a
     * slow virtual disk the two took 16 processes from 550-630 to ~915
     * claims/s (bench/RESULTS.md). */
    if (status == PF_OK)
        status = queue_exec(queue, "PRAGMA synchronous = NORMAL; PRAGMA wal_autocheckpoint = 8000",
                            err);
    if (status == PF_OK) {
        queue_stmt *stmt;
        status = queue_prepare(queue, "PRAGMA journal_mode = WAL", &stmt, err);
        if (status == PF_OK) {
            int rc = queue_step(stmt);
            if (rc != QUEUE_ROW || strcmp(queue_column_text(stmt, 0), "wal") != 0)
                status = pf_error_set(err, PF_ERR_IO, "%s: cannot switch to WAL journaling: %s",
                                      path, sqlite3_errmsg(queue->db));
            queue_finalize(stmt);
        }
    }
    return finish_open(queue, status, "migrating the queue schema", migrate, out, err);
}

void pf_queue_close(pf_queue *queue)
{
    if (!queue)
        return;
    queue_pg_close(queue);
    queue_sqlite_forget_statements(queue);
    sqlite3_close(queue->db);
    free(queue->path);
    free(queue);
}

pf_status pf_queue_schema_version(pf_queue *queue, int *version, pf_error *err)
{
    int64_t value = 0;
    pf_status status =
        single_int(queue, "SELECT coalesce(max(version), 0) FROM schema_version", &value, err);
    if (status == PF_OK)
        *version = (int)value;
    return status;
}
