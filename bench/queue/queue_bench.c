/*
 * Queue benchmark (issue 4): claim+complete throughput in tasks/s with 1, 4
 * and 16 worker processes sharing one SQLite file, on tasks that render
 * nothing (each completion writes the 3 stage rows of a frame, as a worker
 * does), and the time to enqueue one 100,000-frame job.
 *
 *   queue_bench [DIR|URL] [TASKS [PROCESSES...]]
 *     DIR: scratch directory for SQLite files (default /tmp); a postgresql://
 *     URL runs the same on PostgreSQL (its database is emptied before each
 *     run); TASKS: tasks per throughput run (default 4000); PROCESSES: the
 *     worker process counts to run (default 1 4 16; naming any skips the
 *     100,000-frame enqueue, for profiling one count)
 *
 * With PF_BENCH_REQUIREMENTS=1 every job requires a GPU with 24 GiB, 64 GiB
 * of host memory and a tag, and every worker registers capabilities that meet
 * them (issue 42: what the requirements cost a claim).
 *
 * Prints figures; never pass/fail.
 */
#include "pf_queue.h"

#include <inttypes.h>
#include <libpq-fe.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#define DEFAULT_TASKS 4000
#define BIG_JOB_FRAMES 100000
#define STAGES_PER_FRAME 3

/* PF_BENCH_REQUIREMENTS=1: jobs with requirements, workers that meet them. */
static int with_requirements(void)
{
    const char *value = getenv("PF_BENCH_REQUIREMENTS");
    return value && !strcmp(value, "1");
}

#define GIB (1ll << 30)

static void die(const char *what, const pf_error *err)
{
    fprintf(stderr, "queue_bench: %s: %s\n", what, err->message);
    exit(1);
}

/* A PostgreSQL database emptied: the next open creates the schema anew. */
static void fresh_postgres(const char *url)
{
    PGconn *conn = PQconnectdb(url);
    PGresult *result = PQexec(conn, "SET client_min_messages = warning; "
                                    "DROP SCHEMA public CASCADE; CREATE SCHEMA public");
    if (PQresultStatus(result) != PGRES_COMMAND_OK) {
        fprintf(stderr, "queue_bench: cannot empty %s: %s\n", url, PQerrorMessage(conn));
        exit(1);
    }
    PQclear(result);
    PQfinish(conn);
}

static void fresh_db(const char *path)
{
    if (pf_queue_is_url(path)) {
        fresh_postgres(path);
        return;
    }
    char side[4200];
    unlink(path);
    snprintf(side, sizeof side, "%s-wal", path);
    unlink(side);
    snprintf(side, sizeof side, "%s-shm", path);
    unlink(side);
}

/* One worker process: claim and complete until nothing is left. */
static int worker_process(const char *db_path, int index)
{
    pf_queue *queue = NULL;
    pf_error err = {0};
    if (pf_queue_open(db_path, NULL, &queue, &err) != PF_OK)
        die("open", &err);
    char name[64];
    snprintf(name, sizeof name, "bench-%d", index);
    pf_queue_worker_spec spec = {name, "bench", getpid(), "none"};
    if (with_requirements()) {
        spec.device_type = "gpu";
        spec.device_memory = 80 * GIB;
        spec.host_memory = 512 * GIB;
        spec.cores = 64;
        spec.tags = "farm-a,night,show-b";
    }
    int64_t worker_id = 0;
    if (pf_queue_worker_register(queue, &spec, &worker_id, &err) != PF_OK)
        die("register", &err);
    static const char *const stages[STAGES_PER_FRAME] = {"scene_eval", "shade", "exr_write"};
    int64_t last_job = 0;
    int32_t last_frame = 0;
    int done = 0;
    for (;;) {
        pf_queue_task task;
        bool claimed = false;
        if (pf_queue_claim(queue, worker_id, last_job, last_frame, &task, &claimed, &err) != PF_OK)
            die("claim", &err);
        if (!claimed)
            break;
        pf_queue_stage_row rows[STAGES_PER_FRAME];
        for (int s = 0; s < STAGES_PER_FRAME; s++)
            rows[s] = (pf_queue_stage_row){task.first_frame, stages[s], 1.0 + s, 0.5,
                                           "{\"rays\":256}", false, NULL};
        if (pf_queue_complete(queue, task.lease_token, rows, STAGES_PER_FRAME, NULL, &err) !=
            PF_OK)
            die("complete", &err);
        last_job = task.job_id;
        last_frame = task.last_frame;
        done++;
    }
    pf_queue_worker_stop(queue, worker_id, &err);
    pf_queue_close(queue);
    return done;
}

static double throughput(const char *dir, int processes, int tasks)
{
    char db_path[4096], range[32];
    if (pf_queue_is_url(dir))
        snprintf(db_path, sizeof db_path, "%s", dir);
    else
        snprintf(db_path, sizeof db_path, "%s/queue_bench_%d.db", dir, processes);
    fresh_db(db_path);
    pf_queue *queue = NULL;
    pf_error err = {0};
    if (pf_queue_open(db_path, NULL, &queue, &err) != PF_OK)
        die("open", &err);
    snprintf(range, sizeof range, "1-%d", tasks);
    pf_queue_job_spec spec = {"bench.gltf", NULL, range, "out/f.####.exr", 0, 0, 1};
    if (with_requirements()) {
        spec.requires_device = "gpu";
        spec.min_device_memory = 24 * GIB;
        spec.min_host_memory = 64 * GIB;
        spec.required_tags = "farm-a,show-b";
    }
    int64_t job_id;
    if (pf_queue_enqueue(queue, &spec, &job_id, &err) != PF_OK)
        die("enqueue", &err);
    double start = pf_time_ms();
    for (int i = 0; i < processes; i++) {
        pid_t pid = fork();
        if (pid == 0) {
            int done = worker_process(db_path, i);
            _exit(done > 255 ? 255 : done > 0 ? 1 : 0);
        }
    }
    for (int i = 0; i < processes; i++)
        wait(NULL);
    double elapsed_ms = pf_time_ms() - start;
    pf_queue_job job = {0};
    if (pf_queue_job_get(queue, job_id, &job, &err) != PF_OK)
        die("job", &err);
    if (job.tasks_done != tasks)
        fprintf(stderr, "queue_bench: only %" PRId64 " of %d tasks done\n", job.tasks_done, tasks);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    fresh_db(db_path);
    return tasks / (elapsed_ms / 1000.0);
}

static double enqueue_big(const char *dir)
{
    char db_path[4096], range[32];
    if (pf_queue_is_url(dir))
        snprintf(db_path, sizeof db_path, "%s", dir);
    else
        snprintf(db_path, sizeof db_path, "%s/queue_bench_big.db", dir);
    fresh_db(db_path);
    pf_queue *queue = NULL;
    pf_error err = {0};
    if (pf_queue_open(db_path, NULL, &queue, &err) != PF_OK)
        die("open", &err);
    snprintf(range, sizeof range, "1-%d", BIG_JOB_FRAMES);
    pf_queue_job_spec spec = {"bench.gltf", NULL, range, "out/f.######.exr", 0, 0, 1};
    int64_t job_id;
    double start = pf_time_ms();
    if (pf_queue_enqueue(queue, &spec, &job_id, &err) != PF_OK)
        die("enqueue", &err);
    double elapsed_ms = pf_time_ms() - start;
    pf_queue_close(queue);
    fresh_db(db_path);
    return elapsed_ms;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : "/tmp";
    int tasks = argc > 2 ? atoi(argv[2]) : DEFAULT_TASKS;
    int process_counts[16] = {1, 4, 16};
    size_t runs = 3;
    if (argc > 3) {
        runs = 0;
        for (int i = 3; i < argc && runs < sizeof process_counts / sizeof process_counts[0]; i++)
            process_counts[runs++] = atoi(argv[i]);
    }
    bool counts_ok = true;
    for (size_t i = 0; i < runs; i++)
        counts_ok = counts_ok && process_counts[i] >= 1 && process_counts[i] <= 256;
    if (tasks < 1 || !counts_ok) {
        fprintf(stderr, "usage: queue_bench [DIR|URL] [TASKS [PROCESSES...]] "
                        "(TASKS >= 1, PROCESSES 1-256)\n");
        return 2;
    }
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    printf("queue_bench: %d tasks per run, %d stage rows per completion, %ld cores, db in %s%s\n",
           tasks, STAGES_PER_FRAME, cores, dir,
           with_requirements() ? ", jobs with requirements" : "");
    for (size_t i = 0; i < runs; i++)
        printf("claim+complete, %2d process(es): %8.0f tasks/s\n", process_counts[i],
               throughput(dir, process_counts[i], tasks));
    if (argc <= 3)
        printf("enqueue a %d-frame job: %.0f ms\n", BIG_JOB_FRAMES, enqueue_big(dir));
    return 0;
}
