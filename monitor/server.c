/*
 * The monitor's HTTP server (pf_monitor.h): libmicrohttpd, one thread per connection, so
 * a slow client holds only its own thread; limits on connections, request size, idle
 * time and requests per second per address (rate_limit.c). Routes:
 *
 *   GET  /, /monitor.js, /monitor.css   the page (embedded; no file is read from disk)
 *   GET  /healthz                  "ok" while the queue can be read
 *   GET  /api/jobs                 every job (the shared snapshot)
 *   GET  /api/workers              every worker (the shared snapshot)
 *   GET  /api/workers/stats        frames done, failures and blocks of every worker
 *   GET  /api/events               Server-Sent Events: "update" at each change
 *   GET  /api/stats                the queue reads so far (snapshot polls, job details)
 *   GET  /api/jobs/N               the job, its tasks and failures
 *   GET  /api/jobs/N/timings       its stage statistics (timings JOB)
 *   GET  /api/jobs/N/frames        its frames (timings JOB --frames; the first 2,000)
 *   GET  /api/jobs/N/frames/F/log  what each attempt at frame F logged (log JOB F)
 *   GET  /api/jobs/N/last.png      its latest finished frame, tone-mapped (?exposure=EV)
 *   POST /api/jobs/N/ACTION        pause, resume, cancel, retry, priority?value=P: with
 *                                  the token in X-Photonfarm-Token, else 403
 */
#include "pf_monitor.h"

#include "frame_image.h"
#include "json_views.h"
#include "pf_queue.h"
#include "rate_limit.h"
#include "snapshot.h"

#include <arpa/inet.h>
#include <inttypes.h>
#include <math.h>
#include <microhttpd.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

/* The page's files, embedded by monitor/CMakeLists.txt: the only files ever served. */
extern const unsigned char pf_monitor_page[], pf_monitor_script[], pf_monitor_style[];
extern const unsigned long pf_monitor_page_size, pf_monitor_script_size, pf_monitor_style_size;
static const struct {
    const char *path, *type;
    const unsigned char *data;
    const unsigned long *size;
} assets[] = {
    {"/", "text/html; charset=utf-8", pf_monitor_page, &pf_monitor_page_size},
    {"/index.html", "text/html; charset=utf-8", pf_monitor_page, &pf_monitor_page_size},
    {"/monitor.js", "text/javascript; charset=utf-8", pf_monitor_script, &pf_monitor_script_size},
    {"/monitor.css", "text/css; charset=utf-8", pf_monitor_style, &pf_monitor_style_size},
};

/* Connections at once (the benchmark: 100 clients), and per address. */
#define MAX_CONNECTIONS 512
#define MAX_CONNECTIONS_PER_ADDRESS 256
/* A connection silent this long is closed (an event stream sends every KEEPALIVE_MS). */
#define CONNECTION_TIMEOUT_S 30
#define KEEPALIVE_MS 10000
/* Bytes of a request, headers included: nothing the monitor serves needs more. */
#define REQUEST_MEMORY_LIMIT (32 * 1024)
/* An action's body is empty; anything longer is refused. */
#define MAX_BODY_BYTES 1024
/* Frames a job's page lists at most. */
#define FRAMES_SHOWN 2000
/* A job's details are kept until the snapshot changes, at most this many (every job's
 * page of a large farm, each kind). */
#define DETAIL_CACHE 4096
#define TOKEN_HEADER "X-Photonfarm-Token"

typedef enum detail_kind {
    DETAIL_JOB,
    DETAIL_TIMINGS,
    DETAIL_FRAMES,
    DETAIL_WORKER_STATS, /* every worker's, under job id 0 */
    DETAIL_LOG,          /* a frame's attempts' logs */
    DETAIL_KINDS
} detail_kind;

typedef struct detail_entry {
    int64_t job_id;
    detail_kind kind;
    int32_t frame; /* DETAIL_LOG's; 0 for the others */
    char *text;
} detail_entry;

/* Previews kept: a page asks for its job's latest frame at every change. */
#define PREVIEW_CACHE 8
/* Exposure the page may ask for, in stops either way. */
#define MAX_EXPOSURE 16.0

typedef struct preview_entry {
    char path[4096];
    double exposure;
    struct timespec modified;
    unsigned char *png;
    size_t size;
} preview_entry;

typedef struct server {
    const pf_monitor_config *config;
    pf_snapshot snapshot;
    /* Details and actions: one connection of their own, one request at a time. */
    pthread_mutex_t detail_lock;
    pf_queue *detail_queue;
    detail_entry *cache;        /* the generation's details read so far */
    size_t cache_count;
    uint64_t cache_generation;
    preview_entry previews[PREVIEW_CACHE];
    size_t preview_next;
    int64_t detail_reads; /* details read from the queue (cache misses), under detail_lock */
    pf_rate_limiter rate;
    /* Requests answered 429: counted without detail_lock, which a queue read may hold
     * while a flood is being refused. */
    atomic_llong rate_refused;
} server;

/* ---- responses ---- */

static enum MHD_Result respond(struct MHD_Connection *connection, unsigned int code,
                               const char *type, const char *body, size_t size, int copy)
{
    struct MHD_Response *response = MHD_create_response_from_buffer(
        size, (void *)body, copy ? MHD_RESPMEM_MUST_COPY : MHD_RESPMEM_MUST_FREE);
    if (!response)
        return MHD_NO;
    MHD_add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE, type);
    MHD_add_response_header(response, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    MHD_add_response_header(response, "X-Content-Type-Options", "nosniff");
    /* The page's own script and style only: no inline code, nothing from elsewhere. */
    MHD_add_response_header(response, "Content-Security-Policy",
                            "default-src 'self'; img-src 'self' data:; frame-ancestors 'none'");
    enum MHD_Result result = MHD_queue_response(connection, code, response);
    MHD_destroy_response(response);
    return result;
}

static enum MHD_Result respond_json(struct MHD_Connection *connection, unsigned int code,
                                    char *text)
{
    if (!text)
        return respond(connection, MHD_HTTP_INTERNAL_SERVER_ERROR, "text/plain",
                       "out of memory", 13, 1);
    return respond(connection, code, "application/json", text, strlen(text), 0);
}

static enum MHD_Result respond_error(struct MHD_Connection *connection, unsigned int code,
                                     const char *message)
{
    cJSON *object = cJSON_CreateObject();
    cJSON_AddStringToObject(object, "error", message);
    char *text = cJSON_PrintUnformatted(object);
    cJSON_Delete(object);
    return respond_json(connection, code, text);
}

/* The details' and actions' connection (the caller holds detail_lock), opened at first
 * use; the queue re-establishes a lost PostgreSQL connection itself. NULL with err set
 * when it cannot be opened. */
static pf_queue *detail_connection(server *srv, pf_error *err)
{
    if (!srv->detail_queue &&
        pf_queue_open(srv->config->db_path, NULL, &srv->detail_queue, err) != PF_OK)
        srv->detail_queue = NULL;
    return srv->detail_queue;
}

/* ---- a job's details, read once per snapshot generation ---- */

static cJSON *read_detail(pf_queue *queue, int64_t job_id, detail_kind kind, int32_t frame,
                          pf_error *err)
{
    cJSON *object = NULL;
    if (kind == DETAIL_JOB) {
        pf_queue_job job = {0};
        pf_queue_task_info *tasks = NULL;
        pf_queue_failure *failures = NULL;
        size_t task_count = 0, failure_count = 0;
        pf_status status = pf_queue_job_get(queue, job_id, &job, err);
        if (status == PF_OK)
            status = pf_queue_task_list(queue, job_id, &tasks, &task_count, err);
        if (status == PF_OK)
            status = pf_queue_failure_list(queue, job_id, &failures, &failure_count, err);
        /* status's memory advice: the timings' peaks, read only for such a job. */
        pf_queue_timings timings = {0};
        int advise = status == PF_OK && job.memory_failures > 0;
        if (advise)
            status = pf_queue_timings_get(queue, job_id, 0, &timings, err);
        if (status == PF_OK) {
            object = pf_monitor_job_json(&job);
            cJSON_AddItemToObject(object, "task_list", pf_monitor_tasks_json(tasks, task_count));
            cJSON_AddItemToObject(object, "failures",
                                  pf_monitor_failures_json(failures, failure_count));
            if (advise)
                cJSON_AddItemToObject(object, "memory_advice",
                                      pf_monitor_memory_advice_json(&timings));
        }
        if (advise)
            pf_queue_timings_free(&timings);
        pf_queue_job_clear(&job);
        free(tasks);
        free(failures);
    } else if (kind == DETAIL_TIMINGS) {
        pf_queue_timings timings;
        if (pf_queue_timings_get(queue, job_id, 0, &timings, err) == PF_OK) {
            object = pf_monitor_timings_json(job_id, &timings);
            pf_queue_timings_free(&timings);
        }
    } else if (kind == DETAIL_WORKER_STATS) {
        pf_queue_worker_stats *stats = NULL;
        size_t count = 0;
        if (pf_queue_worker_stats_list(queue, &stats, &count, err) == PF_OK)
            object = pf_monitor_worker_stats_json(stats, count);
        free(stats);
    } else if (kind == DETAIL_LOG) {
        pf_queue_attempt_log *logs = NULL;
        size_t count = 0;
        if (pf_queue_attempt_logs(queue, job_id, frame, &logs, &count, err) == PF_OK)
            object = pf_monitor_logs_json(job_id, frame, logs, count);
        pf_queue_attempt_logs_free(logs, count);
    } else {
        pf_queue_frame_details details;
        if (pf_queue_frame_details_get(queue, job_id, &details, err) == PF_OK) {
            object = pf_monitor_frames_json(job_id, &details, FRAMES_SHOWN);
            pf_queue_frame_details_free(&details);
        }
    }
    return object;
}

/* The detail's JSON (malloc'ed), from the cache when the snapshot has not changed since;
 * NULL with err set when the job is unknown or the queue failed. */
static char *detail_text(server *srv, int64_t job_id, detail_kind kind, int32_t frame,
                         pf_error *err)
{
    uint64_t generation = pf_snapshot_generation(&srv->snapshot);
    pthread_mutex_lock(&srv->detail_lock);
    if (generation != srv->cache_generation) { /* the queue changed: read anew */
        for (size_t i = 0; i < srv->cache_count; i++)
            free(srv->cache[i].text);
        srv->cache_count = 0;
        srv->cache_generation = generation;
    }
    char *text = NULL;
    for (size_t i = 0; i < srv->cache_count && !text; i++) {
        const detail_entry *entry = &srv->cache[i];
        if (entry->job_id == job_id && entry->kind == kind && entry->frame == frame)
            text = strdup(entry->text);
    }
    if (!text) {
        pf_queue *queue = detail_connection(srv, err);
        cJSON *object = queue ? read_detail(queue, job_id, kind, frame, err) : NULL;
        srv->detail_reads++;
        char *fresh = object ? cJSON_PrintUnformatted(object) : NULL;
        cJSON_Delete(object);
        if (fresh && !srv->cache) /* without it, served uncached */
            srv->cache = calloc(DETAIL_CACHE, sizeof *srv->cache);
        if (fresh && srv->cache && srv->cache_count < DETAIL_CACHE) {
            srv->cache[srv->cache_count++] = (detail_entry){job_id, kind, frame, fresh};
            text = strdup(fresh);
        } else {
            text = fresh;
        }
    }
    pthread_mutex_unlock(&srv->detail_lock);
    return text;
}

/* ---- a job's latest frame as an image ---- */

/* The latest finished frame's file (out), found with the detail connection (under its
 * lock); PF_ERR_INVALID when the job has none yet or it lies outside the roots. */
static pf_status latest_frame(server *srv, int64_t job_id, char *out, size_t size,
                              pf_error *err)
{
    pf_queue *queue = detail_connection(srv, err);
    pf_status status = queue ? PF_OK : err->status;
    pf_queue_job job = {0};
    pf_queue_task_info *tasks = NULL;
    size_t count = 0;
    if (status == PF_OK)
        status = pf_queue_job_get(queue, job_id, &job, err);
    if (status == PF_OK)
        status = pf_queue_task_list(queue, job_id, &tasks, &count, err);
    const pf_queue_task_info *latest = NULL;
    for (size_t i = 0; status == PF_OK && i < count; i++)
        if (!strcmp(tasks[i].status, "done") &&
            (!latest || tasks[i].finished_at > latest->finished_at))
            latest = &tasks[i];
    if (status == PF_OK && !latest)
        status = pf_error_set(err, PF_ERR_INVALID, "job %" PRId64 " has no finished frame yet",
                              job_id);
    if (status == PF_OK && !srv->config->frame_path(job.output_pattern, latest->last_frame, out,
                                                    size, srv->config->user))
        status = pf_error_set(err, PF_ERR_INVALID,
                              "job %" PRId64 "'s frames are outside this monitor's roots",
                              job_id);
    free(tasks);
    pf_queue_job_clear(&job);
    return status;
}

static enum MHD_Result respond_preview(server *srv, struct MHD_Connection *connection,
                                       int64_t job_id)
{
    if (!srv->config->frame_path)
        return respond_error(connection, MHD_HTTP_NOT_FOUND, "no frame previews here");
    const char *text = MHD_lookup_connection_value(connection, MHD_GET_ARGUMENT_KIND,
                                                   "exposure");
    char *end = NULL;
    double exposure = text ? strtod(text, &end) : 0.0;
    if (text && (end == text || *end || !isfinite(exposure) || fabs(exposure) > MAX_EXPOSURE))
        return respond_error(connection, MHD_HTTP_BAD_REQUEST, "exposure: -16 to 16 stops");
    pf_error err = {0};
    char path[sizeof ((preview_entry *)0)->path];
    unsigned char *png = NULL;
    size_t size = 0;
    pthread_mutex_lock(&srv->detail_lock);
    pf_status status = latest_frame(srv, job_id, path, sizeof path, &err);
    struct stat info;
    if (status == PF_OK && stat(path, &info) != 0)
        status = pf_error_set(&err, PF_ERR_INVALID,
                              "the latest frame's file is gone");
    /* The same file, unchanged since, at the same exposure: the PNG made then. */
    for (size_t i = 0; status == PF_OK && i < PREVIEW_CACHE && !png; i++) {
        const preview_entry *entry = &srv->previews[i];
        if (entry->png && !strcmp(entry->path, path) && entry->exposure == exposure &&
            entry->modified.tv_sec == info.st_mtim.tv_sec &&
            entry->modified.tv_nsec == info.st_mtim.tv_nsec && (png = malloc(entry->size))) {
            memcpy(png, entry->png, entry->size);
            size = entry->size;
        }
    }
    if (status == PF_OK && !png) {
        status = pf_monitor_frame_png(path, exposure, &png, &size, &err);
        preview_entry *entry = &srv->previews[srv->preview_next];
        unsigned char *kept = status == PF_OK ? malloc(size) : NULL;
        if (kept) {
            srv->preview_next = (srv->preview_next + 1) % PREVIEW_CACHE;
            free(entry->png);
            memcpy(kept, png, size);
            snprintf(entry->path, sizeof entry->path, "%s", path);
            entry->exposure = exposure;
            entry->modified = info.st_mtim;
            entry->png = kept;
            entry->size = size;
        }
    }
    pthread_mutex_unlock(&srv->detail_lock);
    if (status != PF_OK) {
        free(png);
        return respond_error(connection,
                             status == PF_ERR_INVALID || status == PF_ERR_IO
                                 ? MHD_HTTP_NOT_FOUND
                                 : MHD_HTTP_UNPROCESSABLE_CONTENT,
                             err.message);
    }
    return respond(connection, MHD_HTTP_OK, "image/png", (const char *)png, size, 0);
}

/* ---- actions ---- */

/* Compares in time independent of where they differ. */
static int same_token(const char *given, const char *token)
{
    size_t given_length = strlen(given), length = strlen(token);
    unsigned char difference = given_length != length;
    for (size_t i = 0; i < length; i++)
        difference |= (unsigned char)(token[i] ^ (i < given_length ? given[i] : 0));
    return difference == 0;
}

static enum MHD_Result act(server *srv, struct MHD_Connection *connection, int64_t job_id,
                           const char *action)
{
    if (!srv->config->token)
        return respond_error(connection, MHD_HTTP_FORBIDDEN,
                             "read-only monitor: start it with --token-file to allow actions");
    const char *given = MHD_lookup_connection_value(connection, MHD_HEADER_KIND, TOKEN_HEADER);
    if (!given || !same_token(given, srv->config->token))
        return respond_error(connection, MHD_HTTP_FORBIDDEN,
                             "missing or wrong " TOKEN_HEADER " header");
    pf_status (*const calls[])(pf_queue *, int64_t, pf_error *) = {
        pf_queue_pause, pf_queue_resume, pf_queue_cancel};
    const char *const names[] = {"pause", "resume", "cancel", "retry", "priority"};
    int which = -1;
    for (int i = 0; i < 5; i++)
        if (!strcmp(action, names[i]))
            which = i;
    if (which < 0)
        return respond_error(connection, MHD_HTTP_NOT_FOUND, "no such action");
    long priority = 0;
    if (which == 4) { /* ?value=P */
        const char *text = MHD_lookup_connection_value(connection, MHD_GET_ARGUMENT_KIND, "value");
        char *end = NULL;
        priority = text ? strtol(text, &end, 10) : 0;
        if (!text || end == text || *end || labs(priority) > PF_QUEUE_PRIORITY_MAX)
            return respond_error(connection, MHD_HTTP_BAD_REQUEST,
                                 "priority: ?value= an integer of at most 1000000 either way");
    }
    pf_error err = {0};
    pthread_mutex_lock(&srv->detail_lock);
    pf_queue *queue = detail_connection(srv, &err);
    pf_status status = queue ? PF_OK : err.status;
    if (status == PF_OK)
        status = which < 3    ? calls[which](queue, job_id, &err)
                 : which == 3 ? pf_queue_retry(queue, job_id, NULL, &err)
                              : pf_queue_set_priority(queue, job_id, (int)priority, &err);
    pthread_mutex_unlock(&srv->detail_lock);
    pf_snapshot_poke(&srv->snapshot);
    if (status != PF_OK)
        return respond_error(connection,
                             status == PF_ERR_INVALID ? MHD_HTTP_CONFLICT
                                                      : MHD_HTTP_SERVICE_UNAVAILABLE,
                             err.message);
    cJSON *object = cJSON_CreateObject();
    cJSON_AddNumberToObject(object, "job", (double)job_id);
    cJSON_AddStringToObject(object, "done", action);
    char *text = cJSON_PrintUnformatted(object);
    cJSON_Delete(object);
    return respond_json(connection, MHD_HTTP_OK, text);
}

/* ---- Server-Sent Events ---- */

typedef struct event_stream {
    server *srv;
    uint64_t seen;
} event_stream;

static ssize_t next_event(void *user, uint64_t position, char *buffer, size_t size)
{
    (void)position;
    event_stream *stream = user;
    uint64_t now;
    if (stream->seen == 0) /* the first event at once: a page fetches what it shows */
        now = pf_snapshot_generation(&stream->srv->snapshot);
    else
        now = pf_snapshot_wait(&stream->srv->snapshot, stream->seen, KEEPALIVE_MS);
    if (now == 0)
        return MHD_CONTENT_READER_END_OF_STREAM;
    int written = now != stream->seen
                      ? snprintf(buffer, size, "event: update\ndata: %" PRIu64 "\n\n", now)
                      : snprintf(buffer, size, ": keepalive\n\n");
    stream->seen = now;
    return written > 0 && (size_t)written < size ? written : MHD_CONTENT_READER_END_WITH_ERROR;
}

static enum MHD_Result respond_events(server *srv, struct MHD_Connection *connection)
{
    event_stream *stream = calloc(1, sizeof *stream);
    if (!stream)
        return MHD_NO;
    stream->srv = srv;
    struct MHD_Response *response =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 256, next_event, stream, free);
    if (!response) {
        free(stream);
        return MHD_NO;
    }
    MHD_add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE, "text/event-stream");
    MHD_add_response_header(response, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
    enum MHD_Result result = MHD_queue_response(connection, MHD_HTTP_OK, response);
    MHD_destroy_response(response);
    return result;
}

/* ---- routing ---- */

/* "/api/jobs/N" or "/api/jobs/N/REST": the job id and REST ("" for none); 0 when the
 * path is not one. */
static int64_t job_path(const char *url, const char **rest)
{
    static const char prefix[] = "/api/jobs/";
    if (strncmp(url, prefix, sizeof prefix - 1) != 0)
        return 0;
    const char *digits = url + sizeof prefix - 1;
    int64_t job_id = 0;
    const char *c = digits;
    for (; *c >= '0' && *c <= '9' && c - digits < 18; c++)
        job_id = job_id * 10 + (*c - '0');
    if (c == digits || (*c && *c != '/'))
        return 0;
    *rest = *c ? c + 1 : "";
    return job_id;
}

/* "frames/F/log" (F an integer, possibly negative): 1 with *frame set, else 0. */
static int frame_log_path(const char *rest, int32_t *frame)
{
    static const char prefix[] = "frames/";
    if (strncmp(rest, prefix, sizeof prefix - 1) != 0)
        return 0;
    const char *c = rest + sizeof prefix - 1;
    int negative = *c == '-';
    c += negative;
    const char *digits = c;
    int64_t value = 0;
    for (; *c >= '0' && *c <= '9' && c - digits < 10; c++)
        value = value * 10 + (*c - '0');
    if (c == digits || strcmp(c, "/log") != 0 || value > INT32_MAX)
        return 0;
    *frame = (int32_t)(negative ? -value : value);
    return 1;
}

static enum MHD_Result route_get(server *srv, struct MHD_Connection *connection,
                                 const char *url)
{
    for (size_t i = 0; i < sizeof assets / sizeof assets[0]; i++)
        if (!strcmp(url, assets[i].path))
            return respond(connection, MHD_HTTP_OK, assets[i].type,
                           (const char *)assets[i].data, *assets[i].size, 1);
    if (!strcmp(url, "/healthz")) {
        pthread_mutex_lock(&srv->snapshot.lock);
        int healthy = srv->snapshot.error[0] == '\0';
        pthread_mutex_unlock(&srv->snapshot.lock);
        return healthy ? respond(connection, MHD_HTTP_OK, "text/plain", "ok\n", 3, 1)
                       : respond_error(connection, MHD_HTTP_SERVICE_UNAVAILABLE,
                                       "the queue cannot be read");
    }
    if (!strcmp(url, "/api/jobs") || !strcmp(url, "/api/workers"))
        return respond_json(connection, MHD_HTTP_OK,
                            pf_snapshot_copy(&srv->snapshot, !strcmp(url, "/api/jobs"), NULL));
    if (!strcmp(url, "/api/events"))
        return respond_events(srv, connection);
    if (!strcmp(url, "/api/workers/stats")) {
        pf_error err = {0};
        char *text = detail_text(srv, 0, DETAIL_WORKER_STATS, 0, &err);
        return text ? respond_json(connection, MHD_HTTP_OK, text)
                    : respond_error(connection, MHD_HTTP_SERVICE_UNAVAILABLE,
                                    err.message[0] ? err.message : "out of memory");
    }
    if (!strcmp(url, "/api/stats")) { /* what the server has asked of the queue so far */
        cJSON *object = cJSON_CreateObject();
        pthread_mutex_lock(&srv->snapshot.lock);
        cJSON_AddNumberToObject(object, "snapshot_reads", (double)srv->snapshot.reads);
        cJSON_AddNumberToObject(object, "change_checks", (double)srv->snapshot.checks);
        cJSON_AddNumberToObject(object, "generation", (double)srv->snapshot.generation);
        pthread_mutex_unlock(&srv->snapshot.lock);
        pthread_mutex_lock(&srv->detail_lock);
        cJSON_AddNumberToObject(object, "detail_reads", (double)srv->detail_reads);
        pthread_mutex_unlock(&srv->detail_lock);
        cJSON_AddNumberToObject(object, "rate_refused",
                                (double)atomic_load(&srv->rate_refused));
        char *text = cJSON_PrintUnformatted(object);
        cJSON_Delete(object);
        return respond_json(connection, MHD_HTTP_OK, text);
    }
    const char *rest = NULL;
    int64_t job_id = job_path(url, &rest);
    int32_t frame = 0;
    detail_kind kind = !rest                       ? DETAIL_KINDS
                       : !*rest                    ? DETAIL_JOB
                       : !strcmp(rest, "timings")  ? DETAIL_TIMINGS
                       : !strcmp(rest, "frames")   ? DETAIL_FRAMES
                       : frame_log_path(rest, &frame) ? DETAIL_LOG
                                                   : DETAIL_KINDS;
    if (job_id > 0 && rest && !strcmp(rest, "last.png"))
        return respond_preview(srv, connection, job_id);
    if (job_id <= 0 || kind == DETAIL_KINDS)
        return respond_error(connection, MHD_HTTP_NOT_FOUND, "not found");
    pf_error err = {0};
    char *text = detail_text(srv, job_id, kind, frame, &err);
    if (text)
        return respond_json(connection, MHD_HTTP_OK, text);
    return respond_error(connection,
                         err.status == PF_ERR_INVALID ? MHD_HTTP_NOT_FOUND
                                                      : MHD_HTTP_SERVICE_UNAVAILABLE,
                         err.message[0] ? err.message : "out of memory");
}

/* 429: this address asked more often than --rate-limit allows. */
static enum MHD_Result respond_too_many(server *srv, struct MHD_Connection *connection,
                                        int retry_after_s)
{
    atomic_fetch_add(&srv->rate_refused, 1);
    static const char body[] = "{\"error\":\"too many requests from this address\"}";
    struct MHD_Response *response = MHD_create_response_from_buffer(
        sizeof body - 1, (void *)body, MHD_RESPMEM_PERSISTENT);
    if (!response)
        return MHD_NO;
    char retry[16];
    snprintf(retry, sizeof retry, "%d", retry_after_s);
    MHD_add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE, "application/json");
    MHD_add_response_header(response, MHD_HTTP_HEADER_RETRY_AFTER, retry);
    enum MHD_Result result =
        MHD_queue_response(connection, MHD_HTTP_TOO_MANY_REQUESTS, response);
    MHD_destroy_response(response);
    return result;
}

/* A request's body so far (actions have none; a longer one is refused). */
typedef struct request_state {
    size_t body_bytes;
} request_state;

static enum MHD_Result handle(void *user, struct MHD_Connection *connection, const char *url,
                              const char *method, const char *version, const char *upload_data,
                              size_t *upload_data_size, void **request_user)
{
    (void)version;
    (void)upload_data;
    server *srv = user;
    if (!*request_user) { /* the headers: the body, if any, comes in the next calls */
        const union MHD_ConnectionInfo *client =
            MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
        int retry_after = 1;
        if (!pf_rate_limit_take(&srv->rate, client ? client->client_addr : NULL,
                                pf_time_ms() / 1000.0, &retry_after))
            return respond_too_many(srv, connection, retry_after);
        request_state *state = calloc(1, sizeof *state);
        if (!state)
            return MHD_NO;
        *request_user = state;
        return MHD_YES;
    }
    request_state *state = *request_user;
    if (*upload_data_size > 0) {
        state->body_bytes += *upload_data_size;
        *upload_data_size = 0;
        return MHD_YES;
    }
    if (state->body_bytes > MAX_BODY_BYTES)
        return respond_error(connection, MHD_HTTP_CONTENT_TOO_LARGE, "request body too large");
    if (!strcmp(method, MHD_HTTP_METHOD_GET) || !strcmp(method, MHD_HTTP_METHOD_HEAD))
        return route_get(srv, connection, url);
    const char *rest = NULL;
    int64_t job_id = job_path(url, &rest);
    if (!strcmp(method, MHD_HTTP_METHOD_POST) && job_id > 0 && rest && *rest)
        return act(srv, connection, job_id, rest);
    return respond_error(connection, MHD_HTTP_METHOD_NOT_ALLOWED, "method not allowed");
}

static void request_done(void *user, struct MHD_Connection *connection, void **request_user,
                         enum MHD_RequestTerminationCode code)
{
    (void)user;
    (void)connection;
    (void)code;
    free(*request_user);
    *request_user = NULL;
}

/* ---- running ---- */

int pf_monitor_address_is_loopback(const char *address)
{
    struct in_addr parsed;
    return inet_pton(AF_INET, address, &parsed) == 1 && (ntohl(parsed.s_addr) >> 24) == 127;
}

pf_status pf_monitor_run(const pf_monitor_config *config, volatile sig_atomic_t *stop,
                         pf_error *err)
{
    struct sockaddr_in address = {.sin_family = AF_INET, .sin_port = htons(config->port)};
    if (inet_pton(AF_INET, config->address, &address.sin_addr) != 1)
        return pf_error_set(err, PF_ERR_INVALID,
                            "--listen %s: expected a numeric IPv4 address and port, e.g. "
                            "127.0.0.1:8080",
                            config->address);
    if (!pf_monitor_address_is_loopback(config->address) && !config->token)
        return pf_error_set(err, PF_ERR_INVALID,
                            "--listen %s is not a loopback address: give --token-file too, or "
                            "anyone who reaches it could act on the farm",
                            config->address);
    server *srv = calloc(1, sizeof *srv);
    if (!srv)
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory starting the monitor");
    srv->config = config;
    if (pf_rate_limiter_init(&srv->rate, config->rate_per_second,
                             config->rate_per_second * PF_MONITOR_BURST_SECONDS) != 0) {
        free(srv);
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory starting the monitor");
    }
    pthread_mutex_init(&srv->detail_lock, NULL);
    int poll_ms = config->poll_ms > 0 ? config->poll_ms : PF_MONITOR_DEFAULT_POLL_MS;
    pf_status status = pf_snapshot_start(&srv->snapshot, config->db_path, poll_ms, err);
    if (status != PF_OK) {
        pthread_mutex_destroy(&srv->detail_lock);
        pf_rate_limiter_free(&srv->rate);
        free(srv);
        return status;
    }
    struct MHD_Daemon *daemon = MHD_start_daemon(
        MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD, config->port, NULL,
        NULL, handle, srv, MHD_OPTION_SOCK_ADDR, (struct sockaddr *)&address,
        MHD_OPTION_CONNECTION_LIMIT, (unsigned int)MAX_CONNECTIONS,
        MHD_OPTION_PER_IP_CONNECTION_LIMIT, (unsigned int)MAX_CONNECTIONS_PER_ADDRESS,
        MHD_OPTION_CONNECTION_TIMEOUT, (unsigned int)CONNECTION_TIMEOUT_S,
        MHD_OPTION_CONNECTION_MEMORY_LIMIT, (size_t)REQUEST_MEMORY_LIMIT,
        MHD_OPTION_NOTIFY_COMPLETED, request_done, srv, MHD_OPTION_END);
    if (!daemon) {
        status = pf_error_set(err, PF_ERR_IO, "cannot listen on %s:%u (in use, or not this "
                              "host's address)",
                              config->address, (unsigned)config->port);
    } else {
        const union MHD_DaemonInfo *info = MHD_get_daemon_info(daemon, MHD_DAEMON_INFO_BIND_PORT);
        if (config->listening)
            config->listening(info ? info->port : config->port, config->user);
        while (!*stop)
            nanosleep(&(struct timespec){0, 100000000L}, NULL);
    }
    pf_snapshot_stop(&srv->snapshot); /* event streams end, so their threads do */
    if (daemon)
        MHD_stop_daemon(daemon);
    pf_snapshot_free(&srv->snapshot);
    for (size_t i = 0; i < srv->cache_count; i++)
        free(srv->cache[i].text);
    free(srv->cache);
    for (size_t i = 0; i < PREVIEW_CACHE; i++)
        free(srv->previews[i].png);
    pf_queue_close(srv->detail_queue);
    pthread_mutex_destroy(&srv->detail_lock);
    pf_rate_limiter_free(&srv->rate);
    free(srv);
    return status;
}
