/*
 * Monitor benchmark (issue 41): API latency of `photonfarm serve` with 1 and 100
 * concurrent clients on a queue of 100 jobs x 1,000 frames, and the server's reads of the
 * queue per second meanwhile (GET /api/stats), which must not grow with the clients.
 *
 *   monitor_bench PHOTONFARM DIR [SECONDS]
 *     PHOTONFARM: the binary; DIR: scratch directory for the queue; SECONDS: per client
 *     count (default 10)
 *
 * Each client loops over GET /api/jobs, /api/workers, /api/jobs/K and
 * /api/jobs/K/timings (K cycling over the jobs), one connection per request, and records
 * each request's latency. Prints figures; never pass/fail.
 */
#include "pf_queue.h"

#include <arpa/inet.h>
#include <cjson/cJSON.h>
#include <inttypes.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define JOBS 100
#define FRAMES_PER_JOB 1000
#define MAX_SAMPLES 2000000

static int port;
static double run_until;
static pthread_mutex_t samples_lock = PTHREAD_MUTEX_INITIALIZER;
static double *samples;
static size_t sample_count;
static int failures;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* One GET; the body (malloc'ed) or NULL when it did not answer 200. */
static char *get(const char *path)
{
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in address = {.sin_family = AF_INET, .sin_port = htons((uint16_t)port)};
    inet_pton(AF_INET, "127.0.0.1", &address.sin_addr);
    if (connect(fd, (struct sockaddr *)&address, sizeof address) != 0) {
        close(fd);
        return NULL;
    }
    char request[256];
    int length = snprintf(request, sizeof request,
                          "GET %s HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n", path);
    if (write(fd, request, (size_t)length) != length) {
        close(fd);
        return NULL;
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
    if (!response)
        return NULL;
    response[used] = '\0';
    const char *body = strstr(response, "\r\n\r\n");
    char *copy = !strncmp(response, "HTTP/1.1 200", 12) && body ? strdup(body + 4) : NULL;
    free(response);
    return copy;
}

static void *client(void *user)
{
    unsigned index = (unsigned)(uintptr_t)user;
    double local[4096];
    size_t count = 0;
    for (unsigned i = index; now_s() < run_until; i++) {
        char path[64];
        int job = (int)(i % JOBS) + 1;
        switch (i % 4) {
        case 0: snprintf(path, sizeof path, "/api/jobs"); break;
        case 1: snprintf(path, sizeof path, "/api/workers"); break;
        case 2: snprintf(path, sizeof path, "/api/jobs/%d", job); break;
        default: snprintf(path, sizeof path, "/api/jobs/%d/timings", job); break;
        }
        double start = now_s();
        char *body = get(path);
        double elapsed_ms = (now_s() - start) * 1000.0;
        pthread_mutex_lock(&samples_lock);
        failures += body == NULL;
        pthread_mutex_unlock(&samples_lock);
        free(body);
        local[count++] = elapsed_ms;
        if (count == sizeof local / sizeof local[0] || now_s() >= run_until) {
            pthread_mutex_lock(&samples_lock);
            for (size_t k = 0; k < count && sample_count < MAX_SAMPLES; k++)
                samples[sample_count++] = local[k];
            pthread_mutex_unlock(&samples_lock);
            count = 0;
        }
    }
    pthread_mutex_lock(&samples_lock);
    for (size_t k = 0; k < count && sample_count < MAX_SAMPLES; k++)
        samples[sample_count++] = local[k];
    pthread_mutex_unlock(&samples_lock);
    return NULL;
}

static int compare(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The server's reads of the queue so far (snapshot polls + job details). */
static double queue_reads(void)
{
    char *body = get("/api/stats");
    cJSON *stats = body ? cJSON_Parse(body) : NULL;
    double reads = cJSON_GetNumberValue(cJSON_GetObjectItem(stats, "snapshot_reads")) +
                   cJSON_GetNumberValue(cJSON_GetObjectItem(stats, "detail_reads"));
    cJSON_Delete(stats);
    free(body);
    return reads;
}

static void run(int clients, double seconds)
{
    sample_count = 0;
    failures = 0;
    double reads_before = queue_reads(), start = now_s();
    run_until = start + seconds;
    pthread_t threads[128];
    for (int i = 0; i < clients; i++)
        pthread_create(&threads[i], NULL, client, (void *)(uintptr_t)i);
    for (int i = 0; i < clients; i++)
        pthread_join(threads[i], NULL);
    double elapsed = now_s() - start;
    double reads = (queue_reads() - reads_before) / elapsed;
    qsort(samples, sample_count, sizeof *samples, compare);
    double p50 = sample_count ? samples[sample_count / 2] : 0;
    double p99 = sample_count ? samples[(size_t)((double)(sample_count - 1) * 0.99)] : 0;
    printf("%3d client(s): %7zu requests, %7.0f/s, p50 %6.2f ms, p99 %6.2f ms, max %7.2f ms, "
           "%d failed; queue reads %.1f/s\n",
           clients, sample_count, (double)sample_count / elapsed, p50, p99,
           sample_count ? samples[sample_count - 1] : 0, failures, reads);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: monitor_bench PHOTONFARM DIR [SECONDS]\n");
        return 2;
    }
    double seconds = argc > 3 ? atof(argv[3]) : 10.0;
    char db[1024];
    snprintf(db, sizeof db, "%s/monitor_bench.db", argv[2]);
    unlink(db);
    pf_queue *queue = NULL;
    pf_error err = {0};
    if (pf_queue_open(db, NULL, &queue, &err) != PF_OK) {
        fprintf(stderr, "monitor_bench: %s\n", err.message);
        return 1;
    }
    double start = now_s();
    char range[32];
    snprintf(range, sizeof range, "1-%d", FRAMES_PER_JOB);
    for (int j = 0; j < JOBS; j++) {
        char pattern[64], parameters[64];
        snprintf(pattern, sizeof pattern, "out/job%03d_####.exr", j);
        snprintf(parameters, sizeof parameters, "{\"name\":\"job %d\",\"quality\":\"fast\"}", j);
        pf_queue_job_spec spec = {.scene_path = "scene.gltf", .parameters_json = parameters,
                                  .frame_range = range, .output_pattern = pattern};
        int64_t id = 0;
        if (pf_queue_enqueue(queue, &spec, &id, &err) != PF_OK) {
            fprintf(stderr, "monitor_bench: %s\n", err.message);
            return 1;
        }
    }
    pf_queue_close(queue);
    printf("monitor_bench: %d jobs x %d frames enqueued in %.1f s (%s)\n", JOBS, FRAMES_PER_JOB,
           now_s() - start, db);

    int out[2];
    if (pipe(out) != 0)
        return 1;
    pid_t server = fork();
    if (server == 0) {
        dup2(out[1], 1);
        close(out[0]);
        execl(argv[1], argv[1], "serve", "--listen", "127.0.0.1:0", "--rate-limit", "0",
              "--db", db, (char *)NULL);
        _exit(127);
    }
    close(out[1]);
    FILE *lines = fdopen(out[0], "r");
    char line[256];
    while (!port && lines && fgets(line, sizeof line, lines)) {
        const char *at = strstr(line, "127.0.0.1:");
        if (at)
            port = atoi(at + strlen("127.0.0.1:"));
    }
    if (!port) {
        fprintf(stderr, "monitor_bench: the server did not start\n");
        return 1;
    }
    samples = malloc(MAX_SAMPLES * sizeof *samples);
    const int counts[] = {1, 100};
    for (size_t i = 0; i < sizeof counts / sizeof counts[0]; i++)
        run(counts[i], seconds);
    kill(server, SIGTERM);
    waitpid(server, NULL, 0);
    free(samples);
    return 0;
}
