/*
 * photonfarm serve (issue 41), over HTTP on loopback: the API against the queue's state,
 * stored strings reaching the page only as JSON text, the action token, paths outside the
 * embedded files refused, a malformed request answered 4xx with the server still serving,
 * live events at a change, and a non-loopback address without a token refused.
 */
#include "worker_test_util.h"

#include "pf_image.h"
#include "pf_test.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#define EVIL_NAME "<script>alert(1)</script>"
#define TOKEN "a-long-enough-action-token"

static char dir[WT_PATH_MAX], db[WT_PATH_MAX + 32], log_path[WT_PATH_MAX + 32];

/* A running `serve` and its port. */
typedef struct served {
    pid_t pid;
    int port;
    char log[WT_PATH_MAX + 48];
} served;

/* serve, with --token-file when token_file is not NULL and --rate-limit when rate is. */
static served serve_limited(const char *name, const char *token_file, const char *rate)
{
    served server = {0};
    wt_format(server.log, sizeof server.log, "%s/%s.log", dir, name);
    unlink(server.log);
    const char *arguments[11] = {"serve", "--listen", "127.0.0.1:0", "--poll-ms", "100", "--db",
                                 db};
    size_t count = 7;
    if (token_file) {
        arguments[count++] = "--token-file";
        arguments[count++] = token_file;
    }
    if (rate) {
        arguments[count++] = "--rate-limit";
        arguments[count++] = rate;
    }
    server.pid = wt_spawn(arguments, server.log, NULL);
    for (int tries = 0; tries < 100 && !server.port; tries++) {
        wt_sleep_ms(50);
        char *text = wt_read_file(server.log, NULL);
        const char *at = text ? strstr(text, "listening on http://127.0.0.1:") : NULL;
        if (at)
            server.port = atoi(at + strlen("listening on http://127.0.0.1:"));
        free(text);
    }
    PF_CHECK_MSG(server.port > 0, "serve did not say where it listens");
    return server;
}

static served serve(const char *name, const char *token_file)
{
    return serve_limited(name, token_file, NULL);
}

static void stop(served *server)
{
    kill(server->pid, SIGTERM);
    PF_CHECK_MSG(wt_wait(server->pid, 10000) == 0, "serve did not stop cleanly on SIGTERM");
}

/* Sends request (raw) and reads the whole response, at most 2 s; malloc'ed, its length in
 * *length when not NULL. */
static char *exchange_sized(int port, const char *request, size_t *length_out)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in address = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
    struct timeval timeout = {2, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    if (connect(fd, (struct sockaddr *)&address, sizeof address) != 0) {
        close(fd);
        return strdup("");
    }
    size_t length = strlen(request);
    for (size_t sent = 0; sent < length;) {
        ssize_t n = write(fd, request + sent, length - sent);
        if (n <= 0)
            break;
        sent += (size_t)n;
    }
    size_t capacity = 1 << 16, used = 0;
    char *response = malloc(capacity);
    ssize_t n;
    while (response && (n = read(fd, response + used, capacity - used - 1)) > 0) {
        used += (size_t)n;
        if (used + 1 == capacity)
            response = realloc(response, capacity *= 2);
    }
    close(fd);
    if (response)
        response[used] = '\0';
    if (length_out)
        *length_out = used;
    return response;
}

static char *exchange(int port, const char *request)
{
    return exchange_sized(port, request, NULL);
}

/* GET path (or POST with an optional token header); the response's status code, and its
 * body in *body (malloc'ed) when body is not NULL. */
static int http(int port, const char *method, const char *path, const char *token, char **body)
{
    char request[1024];
    wt_format(request, sizeof request,
              "%s %s HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n%s%s%s%s\r\n", method,
              path, token ? "X-Photonfarm-Token: " : "", token ? token : "", token ? "\r\n" : "",
              strcmp(method, "POST") ? "" : "Content-Length: 0\r\n");
    char *response = exchange(port, request);
    int code = 0;
    if (response)
        sscanf(response, "HTTP/1.%*d %d", &code);
    if (body) {
        const char *start = response ? strstr(response, "\r\n\r\n") : NULL;
        *body = strdup(start ? start + 4 : "");
    }
    free(response);
    return code;
}

static cJSON *get_json(int port, const char *path)
{
    char *body = NULL;
    int code = http(port, "GET", path, NULL, &body);
    PF_CHECK_MSG(code == 200, "GET %s: %d", path, code);
    cJSON *parsed = cJSON_Parse(body);
    PF_CHECK_MSG(parsed != NULL, "GET %s: not JSON: %.200s", path, body);
    free(body);
    return parsed;
}

/* A queue with a queued job named EVIL_NAME, a failed frame, a done frame and a worker. */
static void fill_queue(int64_t *job_id)
{
    unlink(db);
    pf_queue *queue = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_queue_open(db, NULL, &queue, &err), &err);
    char pattern[WT_PATH_MAX + 32];
    wt_format(pattern, sizeof pattern, "%s/f_####.exr", dir);
    pf_queue_job_spec spec = {.scene_path = "scenes/box.gltf",
                              .parameters_json = "{\"name\": \"" EVIL_NAME "\", "
                                                 "\"quality\": \"final\"}",
                              .frame_range = "1-3", .output_pattern = pattern,
                              .max_attempts = 1};
    PF_REQUIRE_OK(pf_queue_enqueue(queue, &spec, job_id, &err), &err);
    pf_queue_worker_spec worker = {.name = "w-" EVIL_NAME, .host = "h", .pid = 1,
                                   .device = "lvp", .device_type = "cpu"};
    int64_t worker_id = 0;
    PF_REQUIRE_OK(pf_queue_worker_register(queue, &worker, &worker_id, &err), &err);
    pf_queue_task task;
    bool claimed = false;
    PF_REQUIRE_OK(pf_queue_claim(queue, worker_id, 0, 0, &task, &claimed, &err), &err);
    pf_queue_stage_row rows[3] = {
        {task.first_frame, "bih_build", 0.0, PF_QUEUE_NO_GPU_MS, NULL, true,
         "geometry unchanged → BIH reused", NULL},
        {task.first_frame, "plan", 0.0, PF_QUEUE_NO_GPU_MS, NULL, false,
         "auto → fast: no --budget-ms or --target-relmse", NULL},
        {task.first_frame, "shade", 12.5, PF_QUEUE_NO_GPU_MS, NULL, false, "camera samples",
         NULL}};
    PF_REQUIRE_OK(pf_queue_complete(queue, task.lease_token, rows, 3, NULL, &err), &err);
    PF_REQUIRE_OK(pf_queue_attempt_log_store(queue, task.task_id, 1, worker_id,
                                             "event=rendered " EVIL_NAME "\n", &err), &err);
    PF_REQUIRE_OK(pf_queue_claim(queue, worker_id, 0, 0, &task, &claimed, &err), &err);
    PF_REQUIRE_OK(pf_queue_fail(queue, task.lease_token, "error " EVIL_NAME, &err), &err);
    pf_queue_close(queue);
}

PF_TEST(the_api_shows_the_queue_and_stored_strings_stay_text)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    served server = serve("api", NULL);
    cJSON *jobs = get_json(server.port, "/api/jobs");
    const cJSON *job = cJSON_GetArrayItem(jobs, 0);
    PF_CHECK(cJSON_GetArraySize(jobs) == 1);
    const cJSON *parameters = cJSON_GetObjectItem(job, "parameters");
    PF_CHECK(!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(parameters, "name")), EVIL_NAME));
    PF_CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(job, "frames_done")) == 1 &&
             cJSON_GetNumberValue(cJSON_GetObjectItem(job, "frames_total")) == 3);
    PF_CHECK(!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(job, "plan")),
                     "auto → fast: no --budget-ms or --target-relmse"));
    const cJSON *tasks = cJSON_GetObjectItem(job, "tasks");
    PF_CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(tasks, "failed")) == 1 &&
             cJSON_GetNumberValue(cJSON_GetObjectItem(tasks, "queued")) == 1);
    cJSON_Delete(jobs);
    cJSON *workers = get_json(server.port, "/api/workers");
    PF_CHECK(!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(cJSON_GetArrayItem(workers, 0),
                                                              "name")),
                     "w-" EVIL_NAME));
    cJSON_Delete(workers);
    cJSON *stats = get_json(server.port, "/api/workers/stats");
    const cJSON *worker_stats = cJSON_GetArrayItem(stats, 0);
    PF_CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(worker_stats, "frames_done")) == 1 &&
             cJSON_GetNumberValue(cJSON_GetObjectItem(worker_stats, "failures")) == 1);
    cJSON_Delete(stats);
    char path[64];
    wt_format(path, sizeof path, "/api/jobs/%lld", (long long)job_id);
    cJSON *detail = get_json(server.port, path);
    PF_CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(detail, "task_list")) == 3);
    const cJSON *failure = cJSON_GetArrayItem(cJSON_GetObjectItem(detail, "failures"), 0);
    PF_CHECK(!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(failure, "error")),
                     "error " EVIL_NAME));
    cJSON_Delete(detail);
    wt_format(path, sizeof path, "/api/jobs/%lld/timings", (long long)job_id);
    cJSON *timings = get_json(server.port, path);
    const cJSON *stage = NULL, *each;
    cJSON_ArrayForEach(each, cJSON_GetObjectItem(timings, "stages"))
        if (!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(each, "stage")), "shade"))
            stage = each;
    PF_CHECK(stage &&
             cJSON_GetNumberValue(cJSON_GetObjectItem(cJSON_GetObjectItem(stage, "wall"),
                                                      "median_ms")) == 12.5);
    cJSON_Delete(timings);
    wt_format(path, sizeof path, "/api/jobs/%lld/frames", (long long)job_id);
    cJSON *frames = get_json(server.port, path);
    PF_CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(frames, "count")) == 1);
    /* A stage the frame reused is told apart from one it skipped (the page hatches it). */
    const cJSON *frame_stages = cJSON_GetObjectItem(cJSON_GetArrayItem(
                                                        cJSON_GetObjectItem(frames, "frames"), 0),
                                                    "stages");
    int reused = 0, run = 0;
    cJSON_ArrayForEach(each, frame_stages) {
        const char *name = cJSON_GetStringValue(cJSON_GetObjectItem(each, "stage"));
        reused += !strcmp(name, "bih_build") && cJSON_IsTrue(cJSON_GetObjectItem(each, "reused"));
        run += !strcmp(name, "shade") && cJSON_IsFalse(cJSON_GetObjectItem(each, "reused"));
    }
    PF_CHECK(reused == 1 && run == 1);
    cJSON_Delete(frames);
    /* Frame 1's log, as stored; frame 2 failed without one; a malformed frame is 404. */
    wt_format(path, sizeof path, "/api/jobs/%lld/frames/1/log", (long long)job_id);
    cJSON *log = get_json(server.port, path);
    const cJSON *attempt = cJSON_GetArrayItem(cJSON_GetObjectItem(log, "attempts"), 0);
    PF_CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(log, "attempts")) == 1 &&
             !strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(attempt, "log")),
                     "event=rendered " EVIL_NAME "\n") &&
             !strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(attempt, "worker")),
                     "w-" EVIL_NAME));
    cJSON_Delete(log);
    wt_format(path, sizeof path, "/api/jobs/%lld/frames/2/log", (long long)job_id);
    log = get_json(server.port, path);
    PF_CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(log, "attempts")) == 0);
    cJSON_Delete(log);
    const char *malformed[] = {"frames/x/log", "frames//log", "frames/1/log/", "frames/1",
                               "frames/99999999999/log"};
    for (size_t i = 0; i < sizeof malformed / sizeof malformed[0]; i++) {
        wt_format(path, sizeof path, "/api/jobs/%lld/%s", (long long)job_id, malformed[i]);
        PF_CHECK_MSG(http(server.port, "GET", path, NULL, NULL) == 404, "%s", path);
    }
    PF_CHECK(http(server.port, "GET", "/api/jobs/999/frames/1/log", NULL, NULL) == 404);
    PF_CHECK(http(server.port, "GET", "/api/jobs/999", NULL, NULL) == 404);
    PF_CHECK(http(server.port, "GET", "/api/jobs/x", NULL, NULL) == 404);

    /* JSON served as JSON only, and a page that never turns text into HTML. */
    char *response = exchange(server.port, "GET /api/jobs HTTP/1.1\r\nHost: x\r\n"
                                           "Connection: close\r\n\r\n");
    PF_CHECK(response && strstr(response, "Content-Type: application/json") &&
             strstr(response, "X-Content-Type-Options: nosniff"));
    free(response);
    char *script = NULL;
    PF_CHECK(http(server.port, "GET", "/monitor.js", NULL, &script) == 200);
    PF_CHECK(script && strstr(script, "textContent") && !strstr(script, "innerHTML") &&
             !strstr(script, "outerHTML") && !strstr(script, "insertAdjacentHTML") &&
             !strstr(script, "document.write") && !strstr(script, "eval("));
    free(script);
    char *page = NULL;
    PF_CHECK(http(server.port, "GET", "/", NULL, &page) == 200);
    PF_CHECK(page && strstr(page, "<script src=\"/monitor.js\"") && !strstr(page, EVIL_NAME));
    free(page);
    stop(&server);
}

PF_TEST(actions_need_the_token)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    char path[64];
    wt_format(path, sizeof path, "/api/jobs/%lld/pause", (long long)job_id);
    served read_only = serve("read-only", NULL);
    PF_CHECK(http(read_only.port, "POST", path, TOKEN, NULL) == 403);
    stop(&read_only);

    char token_file[WT_PATH_MAX + 32];
    wt_format(token_file, sizeof token_file, "%s/token", dir);
    FILE *file = fopen(token_file, "w");
    PF_REQUIRE(file);
    fprintf(file, "%s\n", TOKEN);
    fclose(file);
    served server = serve("token", token_file);
    PF_CHECK(http(server.port, "POST", path, NULL, NULL) == 403);
    PF_CHECK(http(server.port, "POST", path, "wrong-token-of-some-length", NULL) == 403);
    PF_CHECK(http(server.port, "GET", path, TOKEN, NULL) == 404); /* GET never acts */
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(strcmp(job.status, "paused") != 0, "paused without the token");
    pf_queue_job_clear(&job);
    PF_CHECK(http(server.port, "POST", path, TOKEN, NULL) == 200);
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(!strcmp(job.status, "paused"), "status %s after pause", job.status);
    pf_queue_job_clear(&job);
    PF_CHECK(http(server.port, "POST", path, TOKEN, NULL) == 409); /* paused already */
    wt_format(path, sizeof path, "/api/jobs/%lld/priority?value=7", (long long)job_id);
    PF_CHECK(http(server.port, "POST", path, TOKEN, NULL) == 200);
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(job.priority == 7, "priority %d", job.priority);
    pf_queue_job_clear(&job);
    wt_format(path, sizeof path, "/api/jobs/%lld/priority?value=seven", (long long)job_id);
    PF_CHECK(http(server.port, "POST", path, TOKEN, NULL) == 400);
    wt_format(path, sizeof path, "/api/jobs/%lld/explode", (long long)job_id);
    PF_CHECK(http(server.port, "POST", path, TOKEN, NULL) == 404);
    pf_queue_close(queue);
    stop(&server);
}

PF_TEST(bad_requests_and_paths_outside_the_page_are_refused)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    served server = serve("paths", NULL);
    static const char *const outside[] = {
        "/../../../../etc/passwd", "/%2e%2e/%2e%2e/etc/passwd", "/api/../../etc/passwd",
        "/monitor.js/../../../etc/passwd", "/etc/passwd", "/api/jobs/1/../../../etc/passwd"};
    for (size_t i = 0; i < sizeof outside / sizeof outside[0]; i++) {
        char *body = NULL;
        int code = http(server.port, "GET", outside[i], NULL, &body);
        PF_CHECK_MSG(code >= 400 && code < 500 && body && !strstr(body, "root:"), "%s: %d",
                     outside[i], code);
        free(body);
    }
    /* Malformed headers are 400; a request line that is no HTTP at all is closed unanswered
     * (libmicrohttpd's way); the server serves on after each. */
    static const char *const malformed[] = {
        "GET / HTTP/1.1\r\nHost: x\r\nBad Header\r\n\r\n",
        "GET / HTTP/1.1\r\nHost: x\r\nContent-Length: abc\r\n\r\n"};
    char *response = NULL;
    int code = 0;
    for (size_t i = 0; i < sizeof malformed / sizeof malformed[0]; i++) {
        response = exchange(server.port, malformed[i]);
        code = 0;
        if (response)
            sscanf(response, "HTTP/1.%*d %d", &code);
        PF_CHECK_MSG(code == 400, "malformed request %zu: %d", i, code);
        free(response);
    }
    response = exchange(server.port, "NONSENSE\r\n\r\n");
    PF_CHECK(response && !strstr(response, "200 OK"));
    free(response);
    /* An oversized request is refused too, and the server keeps serving. */
    char *huge = malloc(100 * 1024);
    PF_REQUIRE(huge);
    int used = snprintf(huge, 100 * 1024, "GET / HTTP/1.1\r\nHost: x\r\nX-Big: ");
    memset(huge + used, 'a', 90 * 1024);
    strcpy(huge + used + 90 * 1024, "\r\n\r\n");
    response = exchange(server.port, huge);
    code = 0;
    if (response && *response)
        sscanf(response, "HTTP/1.%*d %d", &code);
    PF_CHECK_MSG(code == 0 || (code >= 400 && code < 500), "an oversized request: %d", code);
    free(response);
    free(huge);
    PF_CHECK(http(server.port, "DELETE", "/api/jobs/1", NULL, NULL) == 405);
    PF_CHECK(http(server.port, "GET", "/healthz", NULL, NULL) == 200);
    stop(&server);
}

static int occurrences(const char *text, const char *word)
{
    int count = 0;
    for (const char *at = strstr(text, word); at; at = strstr(at + 1, word))
        count++;
    return count;
}

/* Big-endian 32 bits at bytes (PNG's IHDR fields). */
static uint32_t be32(const unsigned char *bytes)
{
    return (uint32_t)bytes[0] << 24 | (uint32_t)bytes[1] << 16 | (uint32_t)bytes[2] << 8 |
           bytes[3];
}

/* The latest finished frame as a PNG, at the frame's size, changing with the exposure. */
PF_TEST(the_latest_frame_is_served_as_a_png)
{
    int64_t job_id = 0;
    fill_queue(&job_id); /* frame 1 is done */
    char file[WT_PATH_MAX + 32];
    wt_format(file, sizeof file, "%s/f_0001.exr", dir);
    unlink(file); /* an earlier run's */
    served server = serve("preview", NULL);
    char path[96];
    wt_format(path, sizeof path, "/api/jobs/%lld/last.png", (long long)job_id);
    PF_CHECK(http(server.port, "GET", path, NULL, NULL) == 404); /* no file yet */
    static const char *const channels[] = {"R", "G", "B", "A"};
    pf_image image = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(pf_image_create(&image, 4, 3, 4, channels, &err), &err);
    for (uint32_t p = 0; p < 12; p++)
        for (int c = 0; c < 4; c++)
            image.pixels[p * 4 + (uint32_t)c] = c == 3 ? 1.0f : 0.05f * (float)(p + 1);
    PF_REQUIRE_OK(pf_exr_write(file, &image, PF_EXR_HALF, NULL, 0, &err), &err);
    pf_image_free(&image);
    char *response = NULL;
    char request[256];
    wt_format(request, sizeof request, "GET %s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
              path);
    response = exchange(server.port, request);
    PF_REQUIRE(response != NULL);
    PF_CHECK(strstr(response, "200 OK") && strstr(response, "Content-Type: image/png"));
    const char *body = strstr(response, "\r\n\r\n");
    PF_REQUIRE(body);
    const unsigned char *png = (const unsigned char *)body + 4;
    PF_CHECK(!memcmp(png, "\x89PNG\r\n\x1a\n", 8) && !memcmp(png + 12, "IHDR", 4));
    PF_CHECK_MSG(be32(png + 16) == 4 && be32(png + 20) == 3, "%ux%u", be32(png + 16),
                 be32(png + 20));
    free(response);
    /* Another exposure, another image: the PNG bodies differ (the headers' dates may not). */
    char *exposed[2];
    size_t sizes[2];
    for (int i = 0; i < 2; i++) {
        wt_format(request, sizeof request,
                  "GET %s?exposure=%d HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
                  path, i ? -3 : 2);
        exposed[i] = exchange_sized(server.port, request, &sizes[i]);
    }
    const char *bodies[2] = {exposed[0] ? strstr(exposed[0], "\r\n\r\n") : NULL,
                             exposed[1] ? strstr(exposed[1], "\r\n\r\n") : NULL};
    PF_CHECK(bodies[0] && bodies[1]);
    if (bodies[0] && bodies[1]) {
        size_t a = sizes[0] - (size_t)(bodies[0] - exposed[0]);
        size_t b = sizes[1] - (size_t)(bodies[1] - exposed[1]);
        PF_CHECK(a > 8 && b > 8 && (a != b || memcmp(bodies[0], bodies[1], a) != 0));
    }
    free(exposed[0]);
    free(exposed[1]);
    wt_format(request, sizeof request, "%s?exposure=lots", path);
    PF_CHECK(http(server.port, "GET", request, NULL, NULL) == 400);
    PF_CHECK(http(server.port, "GET", "/api/jobs/999/last.png", NULL, NULL) == 404);
    stop(&server);
}

/* The event stream says "update" when the queue changes, within the poll (100 ms here). */
PF_TEST(events_announce_a_change)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    served server = serve("events", NULL);
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in address = {.sin_family = AF_INET, .sin_port = htons((uint16_t)server.port)};
    inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
    struct timeval timeout = {3, 0};
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    PF_REQUIRE(connect(fd, (struct sockaddr *)&address, sizeof address) == 0);
    const char request[] = "GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n";
    PF_REQUIRE(write(fd, request, sizeof request - 1) == (ssize_t)(sizeof request - 1));
    char buffer[4096];
    size_t used = 0;
    int events = 0;
    /* The first event comes at once; pause the job, and a second must follow. */
    for (int reads = 0; reads < 20 && events < 2; reads++) {
        ssize_t n = read(fd, buffer + used, sizeof buffer - used - 1);
        if (n <= 0)
            break;
        used += (size_t)n;
        buffer[used] = '\0';
        events = occurrences(buffer, "event: update");
        if (events == 1) {
            pf_queue *queue = wt_open_queue(db);
            pf_error err = {0};
            if (queue && pf_queue_pause(queue, job_id, &err) != PF_OK)
                PF_CHECK_MSG(0, "%s", err.message);
            pf_queue_close(queue);
        }
    }
    close(fd);
    PF_CHECK_MSG(events >= 2, "%d update events: %s", events, buffer);
    stop(&server);
}

static double stat_of(int port, const char *name)
{
    cJSON *stats = get_json(port, "/api/stats");
    double value = cJSON_GetNumberValue(cJSON_GetObjectItem(stats, name));
    cJSON_Delete(stats);
    return value;
}

/* Polls of an unchanged queue ask whether anything was committed and read no more (a full
 * read at most every 5 s); a commit is read at the next poll. */
PF_TEST(an_idle_queue_is_checked_not_read)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    served server = serve("idle", NULL);
    wt_sleep_ms(300);
    double reads = stat_of(server.port, "snapshot_reads");
    double checks = stat_of(server.port, "change_checks");
    wt_sleep_ms(1000); /* ten polls at --poll-ms 100 */
    double reads_after = stat_of(server.port, "snapshot_reads");
    double checks_after = stat_of(server.port, "change_checks");
    PF_CHECK_MSG(reads_after - reads <= 1 && checks_after > checks,
                 "idle for 1 s: %.0f full reads, %.0f checks", reads_after - reads,
                 checks_after - checks);
    double generation = stat_of(server.port, "generation");
    pf_queue *queue = wt_open_queue(db);
    pf_error err = {0};
    if (queue)
        PF_CHECK_OK(pf_queue_pause(queue, job_id, &err), &err);
    pf_queue_close(queue);
    for (int tries = 0; tries < 100 && stat_of(server.port, "generation") == generation; tries++)
        wt_sleep_ms(50);
    PF_CHECK_MSG(stat_of(server.port, "generation") > generation,
                 "the pause was not seen within 5 s");
    stop(&server);
}

/* A job whose frames ran out of memory carries status's advice: the largest peak its
 * finished frames recorded and the requirement 25 % over it (3 GiB -> "4G"). */
PF_TEST(a_job_out_of_memory_carries_the_advice)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_error err = {0};
    pf_queue_worker_spec worker = {.name = "small", .host = "h", .pid = 2, .device = "lvp"};
    int64_t worker_id = 0;
    PF_REQUIRE_OK(pf_queue_worker_register(queue, &worker, &worker_id, &err), &err);
    pf_queue_task task;
    bool claimed = false;
    PF_REQUIRE_OK(pf_queue_claim(queue, worker_id, 0, 0, &task, &claimed, &err), &err);
    PF_REQUIRE(claimed);
    pf_queue_stage_row row = {task.first_frame, "shade", 1.0, PF_QUEUE_NO_GPU_MS, NULL, false,
                              NULL, NULL};
    pf_queue_frame_resources peak = {task.first_frame, 3ll << 30, -1, 1000};
    PF_REQUIRE_OK(pf_queue_complete_frames(queue, task.lease_token, &row, 1, &peak, 1, NULL, &err),
                  &err);
    pf_queue_resume(queue, job_id, &err);
    pf_queue_retry(queue, job_id, NULL, &err);
    PF_REQUIRE_OK(pf_queue_claim(queue, worker_id, 0, 0, &task, &claimed, &err), &err);
    PF_REQUIRE(claimed);
    PF_REQUIRE_OK(pf_queue_fail(queue, task.lease_token, "vkAllocateMemory: out of device memory",
                                &err), &err);
    pf_queue_close(queue);
    served server = serve("memory", NULL);
    char path[64];
    wt_format(path, sizeof path, "/api/jobs/%lld", (long long)job_id);
    cJSON *job = get_json(server.port, path);
    const cJSON *advice = cJSON_GetObjectItem(job, "memory_advice");
    PF_CHECK(cJSON_GetNumberValue(cJSON_GetObjectItem(job, "memory_failures")) == 1);
    PF_CHECK_MSG(advice && cJSON_GetNumberValue(cJSON_GetObjectItem(advice, "peak_rss")) ==
                               (double)(3ll << 30) &&
                     !strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(advice, "min_memory")), "4G") &&
                     !strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(advice, "min_device_memory")),
                             ""),
                 "advice: %s", advice ? cJSON_PrintUnformatted(advice) : "none");
    cJSON_Delete(job);
    stop(&server);
}

/* --rate-limit 2: a burst of 4, then 2 a second; the rest 429 with Retry-After, and the
 * address is served again once its bucket refills. Bounds from the elapsed time, so a
 * slow machine cannot fail it. */
PF_TEST(requests_beyond_the_rate_limit_get_429)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    served server = serve_limited("rate", NULL, "2");
    double start = pf_time_ms();
    int allowed = 0, refused = 0, retry_after = 0;
    for (int i = 0; i < 20; i++) {
        char *response = exchange(server.port, "GET /healthz HTTP/1.1\r\nHost: x\r\n"
                                               "Connection: close\r\n\r\n");
        int code = 0;
        if (response)
            sscanf(response, "HTTP/1.%*d %d", &code);
        allowed += code == 200;
        refused += code == 429;
        retry_after += code == 429 && strstr(response, "Retry-After: ") != NULL;
        free(response);
    }
    double elapsed_s = (pf_time_ms() - start) / 1000.0;
    PF_CHECK_MSG(allowed + refused == 20, "%d allowed, %d refused", allowed, refused);
    PF_CHECK_MSG(allowed <= 4 + 2 * elapsed_s + 1, "%d allowed in %.2f s", allowed, elapsed_s);
    if (elapsed_s < 7.0) /* 20 requests outrun 4 + 2/s */
        PF_CHECK_MSG(refused >= 1 && retry_after == refused, "%d refused, %d with Retry-After",
                     refused, retry_after);
    wt_sleep_ms(1100); /* at least two requests' worth back */
    PF_CHECK(stat_of(server.port, "rate_refused") == refused);
    stop(&server);
}

PF_TEST(a_public_address_needs_a_token)
{
    int64_t job_id = 0;
    fill_queue(&job_id);
    char args[2 * WT_PATH_MAX];
    wt_format(args, sizeof args, "serve --listen 0.0.0.0:0 --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "not a loopback address"));
    wt_format(args, sizeof args, "serve --listen localhost --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 2);
    wt_format(args, sizeof args, "serve --db '%s/missing.db'", dir);
    PF_CHECK(wt_run(args, log_path) == 2);
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(db, sizeof db, "%s/serve.db", dir);
    wt_format(log_path, sizeof log_path, "%s/serve-cli.log", dir);
    PF_RUN(the_api_shows_the_queue_and_stored_strings_stay_text);
    PF_RUN(actions_need_the_token);
    PF_RUN(bad_requests_and_paths_outside_the_page_are_refused);
    PF_RUN(the_latest_frame_is_served_as_a_png);
    PF_RUN(events_announce_a_change);
    PF_RUN(an_idle_queue_is_checked_not_read);
    PF_RUN(a_job_out_of_memory_carries_the_advice);
    PF_RUN(requests_beyond_the_rate_limit_get_429);
    PF_RUN(a_public_address_needs_a_token);
    return pf_test_finish();
}
