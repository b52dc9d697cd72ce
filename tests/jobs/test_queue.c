/*
 * Queue semantics on one connection with a hand-driven clock: enqueue and
 * chunking, claim order and affinity, leases (heartbeat, expiry, reaping,
 * fencing), failures with backoff and the per-job blocklist, release, job
 * control, and timing statistics against hand-computed values.
 */
#include "queue_test_util.h"

#include "pf_test.h"

#include <sqlite3.h>
#include <stdlib.h>

#define START_MS 1000000000000LL
#define LEASE_MS 10000
#define BACKOFF_BASE_MS 1000
#define BACKOFF_CAP_MS 8000

static const pf_queue_options test_options = {
    .lease_ms = LEASE_MS,
    .backoff_base_ms = BACKOFF_BASE_MS,
    .backoff_cap_ms = BACKOFF_CAP_MS,
    .block_after_failures = 3,
    .worker_alive_ms = 60000,
};

static test_clock clock_now;

static pf_queue *open_fresh(const char *name)
{
    char path[1200];
    pf_error err = {0};
    pf_queue *queue = NULL;
    clock_now.now = START_MS;
    PF_CHECK_OK(open_queue(fresh_db_path(name, path, sizeof path), &test_options, &clock_now,
                           &queue, &err),
                &err);
    return queue;
}

/* Where open_fresh(name) put the queue, without emptying it again: for a
 * second connection or a query past the queue's API. */
static const char *opened_path(const char *name, char *buffer, size_t size)
{
    char dir[1024];
    if (queue_test_postgres())
        snprintf(buffer, size, "%s", queue_test_postgres());
    else
        snprintf(buffer, size, "%s/%s", pf_test_tmpdir(dir, sizeof dir), name);
    return buffer;
}

static int64_t enqueue(pf_queue *queue, const char *range, int priority, int frames_per_task,
                       int max_attempts)
{
    pf_queue_job_spec spec = {.scene_path = "scenes/box.gltf",
                              .parameters_json = "{\"spp\": 4, \"size\": [64, 64]}",
                              .frame_range = range,
                              .output_pattern = "out/f_####.exr",
                              .priority = priority,
                              .max_attempts = max_attempts,
                              .frames_per_task = frames_per_task};
    pf_error err = {0};
    int64_t job_id = 0;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    return job_id;
}

/* Claims and returns the task (task_id 0 when nothing was claimable). */
static pf_queue_task claim(pf_queue *queue, int64_t worker, int64_t preferred_job,
                           int32_t after_frame)
{
    pf_queue_task task = {0};
    bool claimed = false;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_claim(queue, worker, preferred_job, after_frame, &task, &claimed, &err),
                &err);
    PF_CHECK(claimed == (task.task_id != 0));
    return task;
}

static pf_queue_job job_get(pf_queue *queue, int64_t job_id)
{
    pf_queue_job job;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    return job;
}

static void check_job_status(pf_queue *queue, int64_t job_id, const char *expected)
{
    pf_queue_job job = job_get(queue, job_id);
    PF_CHECK_MSG(!strcmp(job.status, expected), "job %lld is %s, expected %s",
                 (long long)job_id, job.status, expected);
    pf_queue_job_clear(&job);
}

static void complete_plain(pf_queue *queue, const pf_queue_task *task)
{
    pf_error err = {0};
    bool repeated = true;
    PF_CHECK_OK(pf_queue_complete(queue, task->lease_token, NULL, 0, &repeated, &err), &err);
    PF_CHECK(!repeated);
}

static size_t failure_count(pf_queue *queue, int64_t job_id)
{
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    free(failures);
    return count;
}

PF_TEST(enqueue_chunks_frames_into_tasks)
{
    pf_queue *queue = open_fresh("enqueue.db");
    PF_REQUIRE(queue);
    pf_error err = {0};

    int64_t single = enqueue(queue, "1-10", 0, 1, 0);
    int64_t chunked = enqueue(queue, "1-10", 0, 4, 0);
    int64_t mixed = enqueue(queue, "1,5,9-12", 0, 2, 0);
    int64_t stepped = enqueue(queue, "1-48x2", 0, 5, 0);

    pf_queue_job job = job_get(queue, single);
    PF_CHECK(job.tasks_total == 10 && job.frames_total == 10 && job.tasks_queued == 10);
    PF_CHECK(!strcmp(job.status, "queued"));
    PF_CHECK(job.max_attempts == 3); /* the default */
    PF_CHECK(!strcmp(job.parameters_json, "{\"spp\": 4, \"size\": [64, 64]}"));
    PF_CHECK(!strcmp(job.frame_range, "1-10"));
    pf_queue_job_clear(&job);

    struct {
        int64_t job;
        size_t count;
        int32_t first[5], last[5], step[5], frames[5];
    } expected[] = {
        {chunked, 3, {1, 5, 9}, {4, 8, 10}, {1, 1, 1}, {4, 4, 2}},
        /* A chunk is an arithmetic run: 1 and 5 share a task (step 4), 9 cannot join it. */
        {mixed, 3, {1, 9, 11}, {5, 10, 12}, {4, 1, 1}, {2, 2, 2}},
        {stepped, 5, {1, 11, 21, 31, 41}, {9, 19, 29, 39, 47}, {2, 2, 2, 2, 2}, {5, 5, 5, 5, 4}},
    };
    for (size_t e = 0; e < sizeof expected / sizeof *expected; e++) {
        pf_queue_task_info *tasks = NULL;
        size_t count = 0;
        PF_CHECK_OK(pf_queue_task_list(queue, expected[e].job, &tasks, &count, &err), &err);
        PF_CHECK_MSG(count == expected[e].count, "job %lld: %zu tasks",
                     (long long)expected[e].job, count);
        for (size_t i = 0; i < count && i < expected[e].count; i++) {
            PF_CHECK(tasks[i].first_frame == expected[e].first[i]);
            PF_CHECK(tasks[i].last_frame == expected[e].last[i]);
            PF_CHECK(tasks[i].frame_step == expected[e].step[i]);
            PF_CHECK(tasks[i].frame_count == expected[e].frames[i]);
            PF_CHECK(!strcmp(tasks[i].status, "queued") && tasks[i].attempt == 0);
        }
        free(tasks);
    }

    /* Bad specs insert nothing. */
    pf_queue_job_spec bad = {.scene_path = "s.gltf", .frame_range = "5-1",
                             .output_pattern = "o_####.exr"};
    int64_t job_id = 0;
    PF_CHECK(pf_queue_enqueue(queue, &bad, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "reversed") != NULL);
    bad.frame_range = "1-5";
    bad.parameters_json = "{spp: 4";
    PF_CHECK(pf_queue_enqueue(queue, &bad, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "JSON") != NULL);
    bad.parameters_json = NULL;
    bad.output_pattern = "";
    PF_CHECK(pf_queue_enqueue(queue, &bad, &job_id, &err) == PF_ERR_INVALID);
    pf_queue_job *jobs = NULL;
    size_t job_count = 0;
    PF_CHECK_OK(pf_queue_job_list(queue, &jobs, &job_count, &err), &err);
    PF_CHECK(job_count == 4);
    pf_queue_job_list_free(jobs, job_count);
    pf_queue_close(queue);
}

PF_TEST(claim_order_priority_job_frame)
{
    pf_queue *queue = open_fresh("order.db");
    PF_REQUIRE(queue);
    int64_t low_a = enqueue(queue, "1-3", 0, 1, 0);
    int64_t high = enqueue(queue, "10-11", 5, 1, 0);
    int64_t low_b = enqueue(queue, "1-2", 0, 1, 0);
    int64_t worker = register_worker(queue, "w1");

    struct {
        int64_t job;
        int32_t frame;
    } expected[] = {{high, 10}, {high, 11}, {low_a, 1}, {low_a, 2},
                    {low_a, 3}, {low_b, 1}, {low_b, 2}};
    for (size_t i = 0; i < sizeof expected / sizeof *expected; i++) {
        pf_queue_task task = claim(queue, worker, 0, 0);
        PF_CHECK_MSG(task.job_id == expected[i].job && task.first_frame == expected[i].frame,
                     "claim %zu: job %lld frame %d, expected job %lld frame %d", i,
                     (long long)task.job_id, task.first_frame, (long long)expected[i].job,
                     expected[i].frame);
        PF_CHECK(task.attempt == 1 && strlen(task.lease_token) == PF_QUEUE_TOKEN_CHARS);
        PF_CHECK(task.lease_expires == START_MS + LEASE_MS);
    }
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    check_job_status(queue, high, "running");

    /* Unknown worker: refused, not silently ignored. */
    pf_queue_task task;
    bool claimed;
    pf_error err = {0};
    PF_CHECK(pf_queue_claim(queue, 999, 0, 0, &task, &claimed, &err) == PF_ERR_INVALID);
    pf_queue_close(queue);
}

PF_TEST(claim_prefers_next_frame_of_loaded_job)
{
    pf_queue *queue = open_fresh("affinity.db");
    PF_REQUIRE(queue);
    int64_t job_a = enqueue(queue, "1-5", 0, 1, 0);
    int64_t job_b = enqueue(queue, "1-5", 0, 1, 0);
    int64_t worker = register_worker(queue, "w1");

    pf_queue_task task = claim(queue, worker, job_b, 2);
    PF_CHECK(task.job_id == job_b && task.first_frame == 3);
    task = claim(queue, worker, job_b, 3);
    PF_CHECK(task.job_id == job_b && task.first_frame == 4);
    task = claim(queue, worker, job_b, 4);
    PF_CHECK(task.job_id == job_b && task.first_frame == 5);
    /* Past the end of the job: wrap round to its earlier frames before another job. */
    task = claim(queue, worker, job_b, 5);
    PF_CHECK(task.job_id == job_b && task.first_frame == 1);
    /* No preference: lowest job id first. */
    task = claim(queue, worker, 0, 0);
    PF_CHECK(task.job_id == job_a && task.first_frame == 1);
    /* Priority outranks affinity. */
    int64_t urgent = enqueue(queue, "7", 1, 1, 0);
    task = claim(queue, worker, job_b, 1);
    PF_CHECK(task.job_id == urgent && task.first_frame == 7);
    task = claim(queue, worker, job_b, 1);
    PF_CHECK(task.job_id == job_b && task.first_frame == 2);
    pf_queue_close(queue);
}

PF_TEST(claims_start_the_job_once_and_need_a_registered_worker)
{
    pf_queue *queue = open_fresh("claim_start.db");
    PF_REQUIRE(queue);
    char path[1200];
    opened_path("claim_start.db", path, sizeof path);
    const char *started_sql = "SELECT coalesce(started_at, -1) FROM jobs";
    int64_t job = enqueue(queue, "1-2", 0, 1, 0);
    pf_error err = {0};

    /* An unregistered worker is refused, and its claim takes nothing. */
    pf_queue_task task = {0};
    bool claimed = true;
    PF_CHECK(pf_queue_claim(queue, 4242, 0, 0, &task, &claimed, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "no worker 4242") != NULL, "%s", err.message);
    PF_CHECK(!claimed);
    check_job_status(queue, job, "queued");
    PF_CHECK(queue_test_query_int(path, started_sql) == -1);

    /* The first claim starts the job; a later one leaves its start alone. */
    int64_t worker = register_worker(queue, "w1");
    int64_t first_claim_at = clock_now.now;
    task = claim(queue, worker, 0, 0);
    PF_CHECK(task.first_frame == 1 && task.attempt == 1);
    check_job_status(queue, job, "running");
    PF_CHECK(queue_test_query_int(path, started_sql) == first_claim_at);
    clock_now.now += 500;
    task = claim(queue, worker, job, 1);
    PF_CHECK(task.first_frame == 2 && task.attempt == 1);
    check_job_status(queue, job, "running");
    PF_CHECK(queue_test_query_int(path, started_sql) == first_claim_at);
    pf_queue_close(queue);
}

PF_TEST(heartbeat_renews_only_the_current_lease)
{
    pf_queue *queue = open_fresh("heartbeat.db");
    PF_REQUIRE(queue);
    enqueue(queue, "1", 0, 1, 0);
    int64_t worker = register_worker(queue, "w1");
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.task_id);
    pf_error err = {0};

    clock_now.now += 6000;
    int64_t expires = 0;
    PF_CHECK_OK(pf_queue_heartbeat(queue, task.lease_token, &expires, &err), &err);
    PF_CHECK(expires == clock_now.now + LEASE_MS);
    /* Renewed: not expired where the original lease would have been. */
    clock_now.now += 6000;
    int64_t reaped = -1;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 0);

    char stale[PF_QUEUE_TOKEN_CHARS + 1];
    memset(stale, '0', PF_QUEUE_TOKEN_CHARS);
    stale[PF_QUEUE_TOKEN_CHARS] = '\0';
    PF_CHECK(pf_queue_heartbeat(queue, stale, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "lease lost") != NULL);
    pf_queue_close(queue);
}

PF_TEST(expired_lease_is_reaped_and_old_owner_fenced)
{
    pf_queue *queue = open_fresh("reap.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1", 0, 1, 0);
    int64_t first = register_worker(queue, "first");
    int64_t second = register_worker(queue, "second");
    pf_error err = {0};

    pf_queue_task old_lease = claim(queue, first, 0, 0);
    PF_REQUIRE(old_lease.task_id);
    clock_now.now += LEASE_MS; /* expiry instant: still held */
    int64_t reaped = -1;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 0);
    clock_now.now += 1;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 1);

    pf_queue_failure *failures = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_failure_list(queue, job, &failures, &count, &err), &err);
    PF_CHECK(count == 1);
    if (count == 1) {
        PF_CHECK(!strcmp(failures[0].error, "lease expired (worker first stopped heartbeating)"));
        PF_CHECK(failures[0].attempt == 1 && !strcmp(failures[0].worker_name, "first"));
    }
    free(failures);

    /* Backoff after a counted attempt, then the other worker gets it. */
    PF_CHECK(claim(queue, second, 0, 0).task_id == 0);
    clock_now.now += BACKOFF_BASE_MS;
    pf_queue_task new_lease = claim(queue, second, 0, 0);
    PF_CHECK(new_lease.task_id == old_lease.task_id && new_lease.attempt == 2);
    PF_CHECK(strcmp(new_lease.lease_token, old_lease.lease_token) != 0);

    /* The old owner can neither renew nor complete, and writes no stage rows. */
    pf_queue_stage_row row = {.frame = 1, .stage = "render", .wall_ms = 5, .gpu_ms = 4};
    PF_CHECK(pf_queue_heartbeat(queue, old_lease.lease_token, NULL, &err) == PF_ERR_INVALID);
    bool repeated = true;
    PF_CHECK(pf_queue_complete(queue, old_lease.lease_token, &row, 1, &repeated, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "lease lost") != NULL);
    PF_CHECK(!repeated);
    PF_CHECK(pf_queue_fail(queue, old_lease.lease_token, "late", &err) == PF_ERR_INVALID);
    PF_CHECK(pf_queue_release(queue, old_lease.lease_token, &err) == PF_ERR_INVALID);
    pf_queue_timings timings;
    PF_CHECK_OK(pf_queue_timings_get(queue, job, 4, &timings, &err), &err);
    PF_CHECK(timings.stage_count == 0 && timings.frames == 0);
    pf_queue_timings_free(&timings);
    PF_CHECK(failure_count(queue, job) == 1);

    /* The new owner completes; repeating it is harmless and adds nothing. */
    PF_CHECK_OK(pf_queue_complete(queue, new_lease.lease_token, &row, 1, &repeated, &err), &err);
    PF_CHECK(!repeated);
    PF_CHECK_OK(pf_queue_complete(queue, new_lease.lease_token, &row, 1, &repeated, &err), &err);
    PF_CHECK(repeated);
    PF_CHECK_OK(pf_queue_timings_get(queue, job, 4, &timings, &err), &err);
    PF_CHECK(timings.stage_count == 1 && timings.frames == 1 &&
             timings.stages[0].count == 1);
    pf_queue_timings_free(&timings);
    check_job_status(queue, job, "done");
    pf_queue_close(queue);
}

PF_TEST(failures_back_off_then_fail_at_max_attempts)
{
    pf_queue *queue = open_fresh("backoff.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1", 0, 1, 6);
    int64_t worker = register_worker(queue, "w1");
    pf_error err = {0};
    /* base * 2^(attempt-1), capped at 8000. */
    const int64_t delays[] = {1000, 2000, 4000, 8000, 8000};
    const char *errors[] = {"e1", "e2", "e3", "e4", "e5", "e6"};

    for (int attempt = 1; attempt <= 6; attempt++) {
        pf_queue_task task = claim(queue, worker, 0, 0);
        PF_REQUIRE(task.task_id);
        PF_CHECK(task.attempt == attempt);
        PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, errors[attempt - 1], &err), &err);
        pf_queue_task_info *tasks = NULL;
        size_t count = 0;
        PF_CHECK_OK(pf_queue_task_list(queue, job, &tasks, &count, &err), &err);
        PF_REQUIRE(count == 1);
        PF_CHECK(!strcmp(tasks[0].last_error, errors[attempt - 1]));
        if (attempt < 6) {
            PF_CHECK(!strcmp(tasks[0].status, "queued"));
            PF_CHECK_MSG(tasks[0].eligible_at == clock_now.now + delays[attempt - 1],
                         "attempt %d: eligible after %lld ms", attempt,
                         (long long)(tasks[0].eligible_at - clock_now.now));
            check_job_status(queue, job, "running");
            clock_now.now += delays[attempt - 1] - 1;
            PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
            clock_now.now += 1;
        } else {
            PF_CHECK(!strcmp(tasks[0].status, "failed"));
        }
        free(tasks);
    }
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    check_job_status(queue, job, "failed");

    pf_queue_failure *failures = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_failure_list(queue, job, &failures, &count, &err), &err);
    PF_CHECK(count == 6);
    for (size_t i = 0; i < count && i < 6; i++) {
        PF_CHECK(!strcmp(failures[i].error, errors[i]));
        PF_CHECK(failures[i].attempt == (int)i + 1);
        PF_CHECK(!strcmp(failures[i].worker_name, "w1"));
    }
    free(failures);
    pf_queue_close(queue);
}

/* Claims a task of job for worker and fails it. */
static void claim_and_fail(pf_queue *queue, int64_t worker, int64_t job, const char *error)
{
    pf_queue_task task = claim(queue, worker, job, 0);
    PF_CHECK_MSG(task.job_id == job, "worker %lld got job %lld, expected job %lld",
                 (long long)worker, (long long)task.job_id, (long long)job);
    pf_error err = {0};
    if (task.task_id)
        PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, error, &err), &err);
}

PF_TEST(blocklist_after_repeated_failures)
{
    pf_queue *queue = open_fresh("blocklist.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-6", 0, 1, 5);
    int64_t bad = register_worker(queue, "bad");
    int64_t good = register_worker(queue, "good");
    pf_error err = {0};

    /* Two distinct tasks failed: not yet blocked. */
    claim_and_fail(queue, bad, job, "crash 1");
    claim_and_fail(queue, bad, job, "crash 2");
    pf_queue_task task = claim(queue, bad, job, 0);
    PF_CHECK(task.job_id == job);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "crash 3", &err), &err);
    /* Three distinct tasks: blocked, although tasks of the job are waiting. */
    clock_now.now += BACKOFF_CAP_MS;
    PF_CHECK(claim(queue, bad, job, 0).task_id == 0);
    pf_queue_job status = job_get(queue, job);
    PF_CHECK(status.live_workers == 2 && status.blocked_live_workers == 1);
    PF_CHECK(status.note[0] == '\0');
    pf_queue_job_clear(&status);
    /* The monitor's worker table lists the block, and the failures behind it. */
    pf_queue_worker_stats *stats = NULL;
    size_t stats_count = 0;
    pf_error stats_err = {0};
    PF_CHECK_OK(pf_queue_worker_stats_list(queue, &stats, &stats_count, &stats_err), &stats_err);
    char blocked[32];
    snprintf(blocked, sizeof blocked, "%lld", (long long)job);
    PF_CHECK(stats_count == 2 && stats[0].worker_id == bad && stats[0].failures == 3 &&
             !strcmp(stats[0].blocked_jobs, blocked) && !stats[1].blocked_jobs[0]);
    free(stats);

    /* The block is per job: another job is still served to the bad worker. */
    int64_t other = enqueue(queue, "1", 0, 1, 0);
    task = claim(queue, bad, 0, 0);
    PF_CHECK(task.job_id == other);
    complete_plain(queue, &task);

    /* Once every live worker is blocked, the job says so. */
    claim_and_fail(queue, good, job, "good 1");
    claim_and_fail(queue, good, job, "good 2");
    claim_and_fail(queue, good, job, "good 3");
    clock_now.now += BACKOFF_CAP_MS;
    PF_CHECK(claim(queue, good, job, 0).task_id == 0);
    status = job_get(queue, job);
    PF_CHECK(status.blocked_live_workers == 2 && status.tasks_queued > 0);
    PF_CHECK_MSG(!strcmp(status.note, "no eligible worker: all 2 live workers are blocked for "
                                      "this job"),
                 "note: \"%s\"", status.note);
    pf_queue_job_clear(&status);

    /* Stopped and silent workers are not live and do not change the verdict. */
    int64_t stopped = register_worker(queue, "stopped");
    PF_CHECK_OK(pf_queue_worker_stop(queue, stopped, &err), &err);
    register_worker(queue, "silent");
    clock_now.now += 30000;
    PF_CHECK_OK(pf_queue_worker_heartbeat(queue, bad, &err), &err);
    PF_CHECK_OK(pf_queue_worker_heartbeat(queue, good, &err), &err);
    clock_now.now += 31000; /* "silent" last heard 61 s ago, alive window 60 s */
    status = job_get(queue, job);
    PF_CHECK(status.live_workers == 2 && status.blocked_live_workers == 2);
    PF_CHECK(status.note[0] != '\0');
    pf_queue_job_clear(&status);
    pf_queue_worker_info *workers = NULL;
    size_t worker_count = 0;
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &worker_count, &err), &err);
    PF_CHECK(worker_count == 4);
    for (size_t i = 0; i < worker_count; i++)
        PF_CHECK_MSG(workers[i].alive == (workers[i].worker_id == bad ||
                                          workers[i].worker_id == good),
                     "worker %s alive=%d", workers[i].name, workers[i].alive);
    free(workers);

    /* A fresh worker can take the job, and the note goes away. */
    int64_t fresh = register_worker(queue, "fresh");
    status = job_get(queue, job);
    PF_CHECK(status.live_workers == 3 && status.note[0] == '\0');
    pf_queue_job_clear(&status);
    task = claim(queue, fresh, job, 0);
    PF_CHECK(task.job_id == job);
    PF_CHECK_OK(pf_queue_release(queue, task.lease_token, &err), &err);

    /* Retry lifts the blocks, and old failures no longer count towards new ones. */
    int64_t requeued = -1;
    PF_CHECK_OK(pf_queue_retry(queue, job, &requeued, &err), &err);
    PF_CHECK(requeued == 0); /* nothing had failed for good: max attempts is 5 */
    task = claim(queue, bad, job, 0);
    PF_CHECK(task.job_id == job);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "after retry", &err), &err);
    clock_now.now += BACKOFF_CAP_MS;
    PF_CHECK(claim(queue, bad, job, 0).job_id == job);
    pf_queue_close(queue);
}

PF_TEST(release_does_not_count_an_attempt)
{
    pf_queue *queue = open_fresh("release.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1", 0, 1, 1);
    int64_t worker = register_worker(queue, "w1");
    pf_error err = {0};
    for (int round = 0; round < 3; round++) {
        pf_queue_task task = claim(queue, worker, 0, 0);
        PF_REQUIRE(task.task_id);
        PF_CHECK(task.attempt == 1);
        PF_CHECK_OK(pf_queue_release(queue, task.lease_token, &err), &err);
        PF_CHECK(pf_queue_release(queue, task.lease_token, &err) == PF_ERR_INVALID);
        check_job_status(queue, job, "running"); /* claimed once: started */
    }
    PF_CHECK(failure_count(queue, job) == 0);
    /* max_attempts 1 still allows the one real attempt. */
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_CHECK(task.attempt == 1);
    complete_plain(queue, &task);
    check_job_status(queue, job, "done");
    pf_queue_close(queue);
}

/*
 * A job's fault (its output storage refused a frame, its scene is unreadable)
 * pauses the job with the reason, requeues the task without counting the
 * attempt and never blocks the worker, however often it happens; a worker's
 * own failure afterwards still counts. Resume clears the reason.
 */
PF_TEST(job_faults_pause_the_job_and_spare_the_worker)
{
    pf_queue *queue = open_fresh("job-fault.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-4", 0, 1, 1);
    int64_t worker = register_worker(queue, "w1");
    pf_error err = {0};
    for (int round = 0; round < 5; round++) {
        pf_queue_task task = claim(queue, worker, job, 0);
        PF_CHECK_MSG(task.job_id == job, "round %d: nothing claimed", round);
        PF_REQUIRE(task.task_id != 0);
        PF_CHECK(task.attempt == 1); /* never counted: max_attempts 1 still allows it */
        char reason[64];
        snprintf(reason, sizeof reason, "output directory out: Read-only file system (%d)",
                 round);
        PF_CHECK_OK(pf_queue_fail_job(queue, task.lease_token, reason, &err), &err);
        PF_CHECK(pf_queue_fail_job(queue, task.lease_token, reason, &err) == PF_ERR_INVALID);
        pf_queue_job status = job_get(queue, job);
        PF_CHECK_MSG(!strcmp(status.status, "paused"), "job %s", status.status);
        PF_CHECK(status.tasks_queued == 4 && status.tasks_failed == 0);
        PF_CHECK(status.blocked_live_workers == 0);
        PF_CHECK_MSG(!strcmp(status.pause_reason, reason), "reason: %s", status.pause_reason);
        PF_CHECK_MSG(strstr(status.note, "paused: output directory out: Read-only") != NULL,
                     "note: %s", status.note);
        pf_queue_job_clear(&status);
        /* Paused: nothing of the job is claimed until it resumes. */
        PF_CHECK(claim(queue, worker, job, 0).task_id == 0);
        if (round < 4)
            PF_CHECK_OK(pf_queue_resume(queue, job, &err), &err);
    }
    /* Two frames in flight when the disk fills: the first reason stays, the one
     * that paused the job; the second frame still goes back to the queue. */
    PF_CHECK_OK(pf_queue_resume(queue, job, &err), &err);
    int64_t other = register_worker(queue, "w2");
    pf_queue_task first = claim(queue, worker, job, 0), second = claim(queue, other, job, 0);
    PF_REQUIRE(first.task_id && second.task_id);
    PF_CHECK_OK(pf_queue_fail_job(queue, first.lease_token, "disk full", &err), &err);
    PF_CHECK_OK(pf_queue_fail_job(queue, second.lease_token, "disk still full", &err), &err);
    pf_queue_job paused = job_get(queue, job);
    PF_CHECK(!strcmp(paused.pause_reason, "disk full") && paused.tasks_queued == 4);
    pf_queue_job_clear(&paused);
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_failure_list(queue, job, &failures, &count, &err), &err);
    PF_CHECK(count == 7);
    for (size_t i = 0; i < count; i++)
        PF_CHECK(failures[i].job_fault == 1);
    free(failures);

    PF_CHECK_OK(pf_queue_resume(queue, job, &err), &err);
    pf_queue_job status = job_get(queue, job);
    PF_CHECK(status.pause_reason[0] == '\0' && status.note[0] == '\0');
    PF_CHECK(strcmp(status.status, "paused") != 0);
    pf_queue_job_clear(&status);
    /* The worker's own failures still count: with max_attempts 1 the task fails. */
    pf_queue_task task = claim(queue, worker, job, 0);
    PF_REQUIRE(task.task_id);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "device lost", &err), &err);
    status = job_get(queue, job);
    PF_CHECK(status.tasks_failed == 1 && status.tasks_queued == 3);
    pf_queue_job_clear(&status);
    /* A user's pause has no reason and so no note. */
    PF_CHECK_OK(pf_queue_pause(queue, job, &err), &err);
    status = job_get(queue, job);
    PF_CHECK(!strcmp(status.status, "paused") && status.note[0] == '\0');
    pf_queue_job_clear(&status);
    pf_queue_close(queue);
}

PF_TEST(pause_resume_cancel_retry)
{
    pf_queue *queue = open_fresh("control.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-3", 0, 1, 1);
    int64_t worker = register_worker(queue, "w1");
    pf_error err = {0};

    /* Pause stops new claims; the running frame may finish. */
    pf_queue_task running = claim(queue, worker, 0, 0);
    PF_CHECK_OK(pf_queue_pause(queue, job, &err), &err);
    check_job_status(queue, job, "paused");
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    PF_CHECK_OK(pf_queue_heartbeat(queue, running.lease_token, NULL, &err), &err);
    complete_plain(queue, &running);
    check_job_status(queue, job, "paused");
    PF_CHECK(pf_queue_pause(queue, job, &err) == PF_ERR_INVALID);
    PF_CHECK_OK(pf_queue_resume(queue, job, &err), &err);
    check_job_status(queue, job, "running");
    PF_CHECK(pf_queue_resume(queue, job, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "not paused") != NULL);

    /* Cancel revokes the running lease and every queued task. */
    running = claim(queue, worker, job, 1);
    PF_CHECK(running.first_frame == 2);
    PF_CHECK_OK(pf_queue_cancel(queue, job, &err), &err);
    check_job_status(queue, job, "canceled");
    PF_CHECK(pf_queue_heartbeat(queue, running.lease_token, NULL, &err) == PF_ERR_INVALID);
    pf_queue_stage_row row = {.frame = 2, .stage = "render", .wall_ms = 1, .gpu_ms = -1};
    PF_CHECK(pf_queue_complete(queue, running.lease_token, &row, 1, NULL, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    pf_queue_job status = job_get(queue, job);
    PF_CHECK(status.tasks_done == 1 && status.tasks_canceled == 2 && status.frames_done == 1);
    pf_queue_job_clear(&status);
    PF_CHECK_OK(pf_queue_cancel(queue, job, &err), &err); /* idempotent */
    PF_CHECK(pf_queue_pause(queue, job, &err) == PF_ERR_INVALID);

    /* Retry revives the canceled tasks with attempts reset. */
    int64_t requeued = 0;
    PF_CHECK_OK(pf_queue_retry(queue, job, &requeued, &err), &err);
    PF_CHECK(requeued == 2);
    check_job_status(queue, job, "running"); /* one frame already done */
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_CHECK(task.first_frame == 2 && task.attempt == 1);

    /* A failed task (max_attempts 1) fails the job once nothing else can run. */
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "boom", &err), &err);
    check_job_status(queue, job, "running");
    task = claim(queue, worker, 0, 0);
    PF_CHECK(task.first_frame == 3);
    complete_plain(queue, &task);
    check_job_status(queue, job, "failed");
    PF_CHECK_OK(pf_queue_retry(queue, job, &requeued, &err), &err);
    PF_CHECK(requeued == 1);
    check_job_status(queue, job, "running");
    task = claim(queue, worker, 0, 0);
    PF_CHECK(task.first_frame == 2 && task.attempt == 1);
    complete_plain(queue, &task);
    check_job_status(queue, job, "done");
    PF_CHECK(pf_queue_cancel(queue, job, &err) == PF_ERR_INVALID);

    /* Unknown jobs are named. */
    PF_CHECK(pf_queue_cancel(queue, 4242, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "no job 4242") != NULL);
    PF_CHECK(pf_queue_pause(queue, 4242, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_queue_resume(queue, 4242, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_queue_retry(queue, 4242, NULL, &err) == PF_ERR_INVALID);
    pf_queue_job missing;
    PF_CHECK(pf_queue_job_get(queue, 4242, &missing, &err) == PF_ERR_INVALID);
    pf_queue_close(queue);
}

PF_TEST(stage_rows_are_validated_all_or_nothing)
{
    pf_queue *queue = open_fresh("rows.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-5x2", 0, 3, 0); /* one task: 1, 3, 5 */
    int64_t worker = register_worker(queue, "w1");
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.frame_count == 3);
    pf_error err = {0};

    pf_queue_stage_row rows[] = {
        {.frame = 1, .stage = "render", .wall_ms = 1, .gpu_ms = -1},
        {.frame = 2, .stage = "render", .wall_ms = 1, .gpu_ms = -1}, /* not in the task */
    };
    PF_CHECK(pf_queue_complete(queue, task.lease_token, rows, 2, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "stage row 1") && strstr(err.message, "frame 2"));
    rows[1].frame = 3;
    rows[1].counters_json = "{not json";
    PF_CHECK(pf_queue_complete(queue, task.lease_token, rows, 2, NULL, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "JSON") != NULL);
    rows[1].counters_json = "{\"rays\": 1000}";
    rows[1].wall_ms = -3;
    PF_CHECK(pf_queue_complete(queue, task.lease_token, rows, 2, NULL, &err) == PF_ERR_INVALID);
    rows[1].wall_ms = 2;
    rows[1].stage = "";
    PF_CHECK(pf_queue_complete(queue, task.lease_token, rows, 2, NULL, &err) == PF_ERR_INVALID);

    pf_queue_timings timings;
    PF_CHECK_OK(pf_queue_timings_get(queue, job, 3, &timings, &err), &err);
    PF_CHECK(timings.stage_count == 0);
    pf_queue_timings_free(&timings);
    check_job_status(queue, job, "running");

    rows[1].stage = "render";
    PF_CHECK_OK(pf_queue_complete(queue, task.lease_token, rows, 2, NULL, &err), &err);
    PF_CHECK_OK(pf_queue_timings_get(queue, job, 3, &timings, &err), &err);
    PF_CHECK(timings.stage_count == 1 && timings.stages[0].count == 2 && timings.frames == 2);
    pf_queue_timings_free(&timings);
    check_job_status(queue, job, "done");
    pf_queue_close(queue);
}

PF_TEST(timing_statistics_match_hand_computed_values)
{
    pf_queue *queue = open_fresh("timings.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-4", 0, 2, 0);
    int64_t worker = register_worker(queue, "w1");
    pf_error err = {0};
    const double none = PF_QUEUE_NO_GPU_MS;
    pf_queue_stage_row first_rows[] = {
        {1, "parse", 1, none, NULL, false, NULL},
        {1, "render", 10, 8, "{\"rays\": 10}", false, NULL},
        {1, "denoise", 0, none, NULL, true, "disabled"},
        {2, "parse", 2, none, NULL, false, NULL},
        {2, "render", 20, 16, NULL, false, NULL},
        {2, "denoise", 0, none, NULL, true, "disabled"},
    };
    pf_queue_stage_row second_rows[] = {
        {3, "parse", 3, none, NULL, false, NULL},
        {3, "render", 30, 24, NULL, false, NULL},
        {3, "denoise", 5, 4, NULL, false, NULL},
        {4, "parse", 4, none, NULL, false, NULL},
        {4, "render", 100, none, NULL, false, NULL},
        {4, "denoise", 0, none, NULL, true, "disabled"},
    };
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_CHECK_OK(pf_queue_complete(queue, task.lease_token, first_rows, 6, NULL, &err), &err);
    task = claim(queue, worker, 0, 0);
    PF_CHECK_OK(pf_queue_complete(queue, task.lease_token, second_rows, 6, NULL, &err), &err);

    pf_queue_timings t;
    PF_REQUIRE_OK(pf_queue_timings_get(queue, job, 3, &t, &err), &err);
    PF_REQUIRE(t.stage_count == 3);
    PF_CHECK(!strcmp(t.stages[0].stage, "parse") && !strcmp(t.stages[1].stage, "render") &&
             !strcmp(t.stages[2].stage, "denoise"));
    const double tol = 1e-9;
    /* parse: wall 1,2,3,4; no GPU. p95 rank 0.95*3 = 2.85 → 3 + 0.85*(4-3). */
    const pf_queue_stage_stats *parse = &t.stages[0];
    PF_CHECK(parse->count == 4 && parse->skipped == 0 && parse->gpu.count == 0);
    PF_CHECK_NEAR(parse->wall.min, 1, tol);
    PF_CHECK_NEAR(parse->wall.median, 2.5, tol);
    PF_CHECK_NEAR(parse->wall.p95, 3.85, tol);
    PF_CHECK_NEAR(parse->wall.max, 4, tol);
    PF_CHECK_NEAR(parse->wall.total, 10, tol);
    /* render: wall 10,20,30,100 → median 25, p95 30 + 0.85*70 = 89.5;
     * GPU 8,16,24 (frame 4 has none) → median 16, p95 rank 1.9 → 16 + 0.9*8 = 23.2. */
    const pf_queue_stage_stats *render = &t.stages[1];
    PF_CHECK(render->count == 4 && render->skipped == 0 && render->gpu.count == 3);
    PF_CHECK_NEAR(render->wall.min, 10, tol);
    PF_CHECK_NEAR(render->wall.median, 25, tol);
    PF_CHECK_NEAR(render->wall.p95, 89.5, tol);
    PF_CHECK_NEAR(render->wall.max, 100, tol);
    PF_CHECK_NEAR(render->wall.total, 160, tol);
    PF_CHECK_NEAR(render->gpu.min, 8, tol);
    PF_CHECK_NEAR(render->gpu.median, 16, tol);
    PF_CHECK_NEAR(render->gpu.p95, 23.2, tol);
    PF_CHECK_NEAR(render->gpu.max, 24, tol);
    PF_CHECK_NEAR(render->gpu.total, 48, tol);
    /* denoise: ran once (5 ms, GPU 4 ms), skipped three times. */
    const pf_queue_stage_stats *denoise = &t.stages[2];
    PF_CHECK(denoise->count == 1 && denoise->skipped == 3 && denoise->gpu.count == 1);
    PF_CHECK_NEAR(denoise->wall.median, 5, tol);
    PF_CHECK_NEAR(denoise->wall.p95, 5, tol);
    PF_CHECK_NEAR(denoise->gpu.max, 4, tol);

    PF_CHECK(t.frames == 4);
    PF_CHECK_NEAR(t.total_wall_ms, 175, tol);
    PF_CHECK_NEAR(t.total_gpu_ms, 52, tol);
    /* Per frame: 1 → 11, 2 → 22, 3 → 38, 4 → 104. */
    PF_REQUIRE(t.slowest_count == 3);
    PF_CHECK(t.slowest[0].frame == 4 && t.slowest[1].frame == 3 && t.slowest[2].frame == 2);
    PF_CHECK_NEAR(t.slowest[0].wall_ms, 104, tol);
    PF_CHECK_NEAR(t.slowest[1].wall_ms, 38, tol);
    PF_CHECK_NEAR(t.slowest[2].wall_ms, 22, tol);
    pf_queue_timings_free(&t);

    PF_CHECK(pf_queue_timings_get(queue, 99, 3, &t, &err) == PF_ERR_INVALID);
    pf_queue_close(queue);
}

PF_TEST(reaping_counts_attempts_and_blocks_the_silent_worker)
{
    pf_queue *queue = open_fresh("reap_block.db");
    PF_REQUIRE(queue);
    int64_t job = enqueue(queue, "1-4", 0, 1, 2);
    int64_t silent = register_worker(queue, "silent");
    int64_t other = register_worker(queue, "other");
    pf_error err = {0};

    /* The silent worker holds three leases and stops heartbeating. */
    for (int i = 0; i < 3; i++)
        PF_CHECK(claim(queue, silent, 0, 0).task_id != 0);
    clock_now.now += LEASE_MS + 1;
    int64_t reaped = 0;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 3);
    PF_CHECK(failure_count(queue, job) == 3);
    clock_now.now += BACKOFF_BASE_MS;
    PF_CHECK(claim(queue, silent, job, 0).task_id == 0); /* blocked after 3 distinct tasks */
    pf_queue_worker_info *workers = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &count, &err), &err);
    PF_CHECK(count == 2 && workers[0].current_task_id == 0);
    free(workers);

    /* Reaped at max attempts (2): the task fails for good. */
    pf_queue_task task = claim(queue, other, 0, 0);
    PF_CHECK(task.attempt == 2);
    clock_now.now += LEASE_MS + 1;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 1);
    pf_queue_job status = job_get(queue, job);
    PF_CHECK(status.tasks_failed == 1 && status.tasks_queued == 3);
    PF_CHECK(!strcmp(status.status, "running"));
    pf_queue_job_clear(&status);
    pf_queue_close(queue);
}

PF_TEST(locked_database_is_retried_then_reported)
{
    if (queue_test_postgres()) { /* SQLite's file lock; PostgreSQL's write lock: the next test */
        printf("  (SQLite only)\n");
        return;
    }
    char path[1200];
    pf_error err = {0};
    pf_queue *queue = NULL;
    pf_queue_options options = test_options;
    options.busy_timeout_ms = 20;
    clock_now.now = START_MS;
    PF_REQUIRE_OK(open_queue(fresh_db_path("locked.db", path, sizeof path), &options,
                             &clock_now, &queue, &err),
                  &err);
    enqueue(queue, "1", 0, 1, 0);
    int64_t worker = register_worker(queue, "w1");

    /* Another connection holds the write lock past every wait and retry. */
    sqlite3 *holder = NULL;
    PF_REQUIRE(sqlite3_open(path, &holder) == SQLITE_OK);
    PF_REQUIRE(sqlite3_exec(holder, "BEGIN IMMEDIATE", NULL, NULL, NULL) == SQLITE_OK);
    pf_queue_task task;
    bool claimed = true;
    PF_CHECK(pf_queue_claim(queue, worker, 0, 0, &task, &claimed, &err) == PF_ERR_IO);
    PF_CHECK(!claimed);
    PF_CHECK_MSG(strstr(err.message, path) && strstr(err.message, "locked"), "%s", err.message);
    /* Reads still work under a writer (WAL). */
    pf_queue_job job = job_get(queue, 1);
    PF_CHECK(job.tasks_queued == 1);
    pf_queue_job_clear(&job);

    sqlite3_exec(holder, "COMMIT", NULL, NULL, NULL);
    sqlite3_close(holder);
    task = claim(queue, worker, 0, 0);
    PF_CHECK(task.task_id != 0 && task.attempt == 1);
    pf_queue_close(queue);
}

/* What conflict_probe saw and did. */
typedef struct conflict_probe_state {
    pf_queue *other_connection;
    int calls;
    int64_t last_seen;
    pf_status other_status;
    int refuse;
    int64_t claimer;          /* a worker that also tries to claim on the other connection */
    pf_status claim_status;
    bool claimed;
} conflict_probe_state;

/* Tries an enqueue (and a claim, with claimer) on another connection from
 * inside the first one's check. */
static int conflict_probe(const pf_queue_job *other, void *user, char *reason, size_t size)
{
    conflict_probe_state *state = user;
    state->calls++;
    state->last_seen = other->job_id;
    pf_queue_job_spec spec = {.scene_path = "s.gltf", .frame_range = "1",
                              .output_pattern = "elsewhere.exr"};
    int64_t job_id = 0;
    pf_error err = {0};
    state->other_status = pf_queue_enqueue(state->other_connection, &spec, &job_id, &err);
    if (state->claimer) {
        pf_queue_task task;
        state->claim_status = pf_queue_claim(state->other_connection, state->claimer, 0, 0, &task,
                                             &state->claimed, &err);
    }
    snprintf(reason, size, "job %lld writes %s", (long long)other->job_id,
             other->output_pattern);
    return state->refuse;
}

/* A second connection to path that waits for the write lock only 20 ms a try. */
static pf_queue *open_impatient(const char *path)
{
    pf_error err = {0};
    pf_queue *other = NULL;
    pf_queue_options options = test_options;
    options.busy_timeout_ms = 20;
    PF_CHECK_OK(open_queue(path, &options, &clock_now, &other, &err), &err);
    return other;
}

/* Enqueues frame 2 of out/f_####.exr on queue, conflict_probe checking with state. */
static pf_status enqueue_probed(pf_queue *queue, conflict_probe_state *state, int64_t *job_id,
                                pf_error *err)
{
    pf_queue_job_spec spec = {.scene_path = "s.gltf", .frame_range = "2",
                              .output_pattern = "out/f_####.exr", .conflicts = conflict_probe,
                              .conflicts_user = state};
    *job_id = 0;
    return pf_queue_enqueue(queue, &spec, job_id, err);
}

/*
 * The conflict check of an enqueue runs inside its write transaction: while
 * it runs no other connection can insert a job (so two enqueues racing for
 * the same files cannot both pass), a refusal inserts nothing, and only
 * unfinished jobs are asked about.
 */
PF_TEST(enqueue_conflicts_are_decided_under_the_write_lock)
{
    pf_queue *queue = open_fresh("conflict.db");
    PF_REQUIRE(queue);
    char path[1200];
    pf_error err = {0};
    pf_queue *other = open_impatient(opened_path("conflict.db", path, sizeof path));
    PF_REQUIRE(other);
    int64_t first = enqueue(queue, "1-2", 0, 1, 0);
    int64_t canceled = enqueue(queue, "1", 0, 1, 0);
    PF_CHECK_OK(pf_queue_cancel(queue, canceled, &err), &err);
    int64_t worker = register_worker(queue, "w1");
    conflict_probe_state state = {other, 0, 0, PF_OK, 1, worker, PF_OK, true};
    int64_t job_id = 0;
    PF_CHECK(enqueue_probed(queue, &state, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(!strcmp(err.message, "job 1 writes out/f_####.exr"), "%s", err.message);
    PF_CHECK_MSG(state.calls == 1 && state.last_seen == first, "%d calls, last job %lld",
                 state.calls, (long long)state.last_seen);
    PF_CHECK_MSG(state.other_status == PF_ERR_IO, "the other connection's enqueue: %d",
                 state.other_status);
    /* Claims wait for the whole-queue writer too; the one that gave up took
     * nothing, and its connection claims normally afterwards. */
    PF_CHECK_MSG(state.claim_status == PF_ERR_IO && !state.claimed,
                 "the other connection's claim: %d", state.claim_status);
    state.claimer = 0;
    pf_queue_task task = claim(other, worker, 0, 0);
    PF_CHECK(task.job_id == first && task.first_frame == 1 && task.attempt == 1);
    pf_queue_job *jobs = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_job_list(queue, &jobs, &count, &err), &err);
    PF_CHECK_MSG(count == 2, "%zu jobs", count);
    pf_queue_job_list_free(jobs, count);
    /* No conflict: inserted (and the other connection, no longer locked out, too). */
    state.refuse = 0;
    PF_CHECK_OK(enqueue_probed(queue, &state, &job_id, &err), &err);
    PF_CHECK(job_id > canceled);
    PF_CHECK_OK(pf_queue_job_list(queue, &jobs, &count, &err), &err);
    PF_CHECK_MSG(count == 3, "%zu jobs", count);
    pf_queue_job_list_free(jobs, count);
    pf_queue_close(other);
    pf_queue_close(queue);
}

/* A worker is dead once silent for its own lease, not a fixed window (issue 14). */
PF_TEST(workers_are_dead_after_their_own_lease)
{
    pf_queue *queue = open_fresh("worker-leases");
    PF_REQUIRE(queue);
    pf_error err = {0};
    int64_t ids[3];
    const struct {
        const char *name;
        int64_t lease_ms;
    } specs[] = {{"short-lease", 5000}, {"long-lease", 120000}, {"no-lease", 0}};
    for (int i = 0; i < 3; i++) {
        pf_queue_worker_spec spec = {specs[i].name, "test", 1, "cpu", specs[i].lease_ms};
        PF_CHECK_OK(pf_queue_worker_register(queue, &spec, &ids[i], &err), &err);
    }
    /* 6 s: short-lease is past its lease; the others are within theirs (no-lease: the
     * queue's 60 s window). */
    clock_now.now += 6000;
    pf_queue_worker_info *workers = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &count, &err), &err);
    PF_REQUIRE(count == 3);
    for (size_t i = 0; i < count; i++)
        PF_CHECK_MSG(workers[i].alive == (workers[i].worker_id != ids[0]), "%s alive=%d at 6 s",
                     workers[i].name, workers[i].alive);
    free(workers);
    /* 61 s: only long-lease is alive; a heartbeat brings short-lease back. */
    clock_now.now += 55000;
    PF_CHECK_OK(pf_queue_worker_heartbeat(queue, ids[0], &err), &err);
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &count, &err), &err);
    for (size_t i = 0; i < count; i++)
        PF_CHECK_MSG(workers[i].alive == (workers[i].worker_id != ids[2]), "%s alive=%d at 61 s",
                     workers[i].name, workers[i].alive);
    free(workers);
    int64_t job = enqueue(queue, "1", 0, 1, 1);
    pf_queue_job status = job_get(queue, job);
    PF_CHECK_MSG(status.live_workers == 2, "%lld live", (long long)status.live_workers);
    pf_queue_job_clear(&status);
    pf_queue_close(queue);
}

/* A worker's capabilities (issue 42) as registered, re-registered and listed; tags normalised. */
PF_TEST(workers_record_their_capabilities)
{
    pf_queue *queue = open_fresh("worker-capabilities");
    PF_REQUIRE(queue);
    pf_error err = {0};
    char tags[PF_QUEUE_TAGS_MAX];
    PF_CHECK_OK(pf_queue_tags_normalize("show-a, night,show-a  gpu.big", tags, sizeof tags, &err),
                &err);
    PF_CHECK_MSG(!strcmp(tags, "gpu.big,night,show-a"), "normalised: %s", tags);
    PF_CHECK(pf_queue_tags_normalize("ok,no/slash", tags, sizeof tags, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "no/slash") != NULL);
    PF_CHECK_OK(pf_queue_tags_normalize(NULL, tags, sizeof tags, &err), &err);
    PF_CHECK(tags[0] == '\0');
    pf_queue_worker_spec spec = {.name = "gpu-node", .host = "h", .pid = 2, .device = "H200",
                                 .lease_ms = 30000, .device_type = "gpu",
                                 .device_memory = 150000000000ll, .host_memory = 2ll << 40,
                                 .cores = 96, .tags = "night,show-a"};
    int64_t id = 0;
    PF_CHECK_OK(pf_queue_worker_register(queue, &spec, &id, &err), &err);
    pf_queue_worker_info *workers = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &count, &err), &err);
    PF_REQUIRE(count == 1);
    PF_CHECK(!strcmp(workers[0].device_type, "gpu") && workers[0].device_memory == 150000000000ll &&
             workers[0].host_memory == (2ll << 40) && workers[0].cores == 96 &&
             !strcmp(workers[0].tags, "night,show-a"));
    free(workers);
    /* Restarted on other hardware: the row says what it has now. */
    spec.device_type = "cpu";
    spec.device_memory = 0;
    spec.tags = NULL;
    PF_CHECK_OK(pf_queue_worker_register(queue, &spec, &id, &err), &err);
    PF_CHECK_OK(pf_queue_worker_list(queue, &workers, &count, &err), &err);
    PF_REQUIRE(count == 1);
    PF_CHECK(!strcmp(workers[0].device_type, "cpu") && workers[0].device_memory == 0 &&
             workers[0].tags[0] == '\0' && workers[0].cores == 96);
    free(workers);
    pf_queue_close(queue);
}

/* A job with requirements (issue 42), one frame. */
static int64_t enqueue_requiring(pf_queue *queue, const char *device, int64_t device_memory,
                                 int64_t host_memory, const char *tags)
{
    pf_queue_job_spec spec = {.scene_path = "scenes/box.gltf",
                              .frame_range = "1",
                              .output_pattern = "out/f_####.exr",
                              .requires_device = device,
                              .min_device_memory = device_memory,
                              .min_host_memory = host_memory,
                              .required_tags = tags};
    pf_error err = {0};
    int64_t job_id = 0;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    return job_id;
}

/*
 * Claims take only jobs whose requirements the worker meets (issue 42): device type,
 * device and host memory, every tag (matched whole, '_' literally); a job no live worker
 * meets says so in its note; pf_queue_workers_meeting counts who could.
 */
PF_TEST(claims_follow_the_jobs_requirements)
{
    pf_queue *queue = open_fresh("requirements");
    PF_REQUIRE(queue);
    pf_error err = {0};
    const int64_t gib = 1ll << 30;
    pf_queue_worker_spec cpu_spec = {.name = "laptop", .host = "a", .pid = 1, .device = "lvp",
                                     .device_type = "cpu", .device_memory = 2 * gib,
                                     .host_memory = 16 * gib, .cores = 8, .tags = "a_b"};
    pf_queue_worker_spec gpu_spec = {.name = "h200", .host = "b", .pid = 2, .device = "H200",
                                     .device_type = "gpu", .device_memory = 140 * gib,
                                     .host_memory = 256 * gib, .cores = 64,
                                     .tags = "night,show-a"};
    int64_t cpu = 0, gpu = 0;
    PF_CHECK_OK(pf_queue_worker_register(queue, &cpu_spec, &cpu, &err), &err);
    PF_CHECK_OK(pf_queue_worker_register(queue, &gpu_spec, &gpu, &err), &err);
    /* In priority order of insertion (all priority 0: oldest first). */
    int64_t needs_gpu = enqueue_requiring(queue, "gpu", 0, 0, NULL);
    int64_t needs_memory = enqueue_requiring(queue, NULL, 24 * gib, 64 * gib, NULL);
    int64_t needs_tags = enqueue_requiring(queue, NULL, 0, 0, "show-a,NIGHT");
    int64_t needs_other_show = enqueue_requiring(queue, NULL, 0, 0, "night,show-b");
    int64_t needs_axb = enqueue_requiring(queue, NULL, 0, 0, "axb"); /* '_' is not a wildcard */
    int64_t needs_cpu_tag = enqueue_requiring(queue, "cpu", 0, 0, "a_b");
    int64_t anyone = enqueue_requiring(queue, NULL, 0, 0, NULL);
    /* The laptop: only the job for a cpu tagged a_b, then the one for anyone. */
    pf_queue_task task = claim(queue, cpu, 0, 0);
    PF_CHECK_MSG(task.job_id == needs_cpu_tag, "laptop claimed job %lld", (long long)task.job_id);
    task = claim(queue, cpu, 0, 0);
    PF_CHECK_MSG(task.job_id == anyone, "laptop claimed job %lld", (long long)task.job_id);
    PF_CHECK(claim(queue, cpu, 0, 0).task_id == 0);
    /* The H200: the gpu job, the memory job, the tagged job; never the others. */
    const int64_t expected[3] = {needs_gpu, needs_memory, needs_tags};
    for (int i = 0; i < 3; i++) {
        task = claim(queue, gpu, 0, 0);
        PF_CHECK_MSG(task.job_id == expected[i], "h200 claim %d: job %lld", i,
                     (long long)task.job_id);
    }
    PF_CHECK(claim(queue, gpu, 0, 0).task_id == 0);
    /* Nobody live meets the two left: their notes say what is missing. */
    pf_queue_job job = job_get(queue, needs_other_show);
    PF_CHECK_MSG(strstr(job.note, "waiting: no live worker has any device and the tags "
                                  "night,show-b"),
                 "note: %s", job.note);
    PF_CHECK(job.qualified_live_workers == 0 && !strcmp(job.required_tags, "night,show-b"));
    pf_queue_job_clear(&job);
    job = job_get(queue, needs_axb);
    PF_CHECK_MSG(strstr(job.note, "waiting: no live worker") != NULL, "note: %s", job.note);
    pf_queue_job_clear(&job);
    job = job_get(queue, needs_gpu);
    PF_CHECK(!strcmp(job.requires_device, "gpu") && job.qualified_live_workers == 1);
    pf_queue_job_clear(&job);
    /* Who could ever take a job: enqueue's warning. */
    int64_t count = -1;
    pf_queue_job_spec spec = {.requires_device = "gpu", .min_device_memory = 100 * gib};
    PF_CHECK_OK(pf_queue_workers_meeting(queue, &spec, &count, &err), &err);
    PF_CHECK(count == 1);
    spec.min_device_memory = 200 * gib;
    PF_CHECK_OK(pf_queue_workers_meeting(queue, &spec, &count, &err), &err);
    PF_CHECK(count == 0);
    /* Bad requirements are refused, nothing inserted. */
    pf_queue_job_spec bad = {.scene_path = "s.gltf", .frame_range = "1", .output_pattern = "o",
                             .requires_device = "tpu"};
    int64_t job_id = 0;
    PF_CHECK(pf_queue_enqueue(queue, &bad, &job_id, &err) == PF_ERR_INVALID);
    bad.requires_device = NULL;
    bad.required_tags = "ok,not/ok";
    PF_CHECK(pf_queue_enqueue(queue, &bad, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "not/ok") != NULL);
    pf_queue_close(queue);
}

static int64_t enqueue_after(pf_queue *queue, const char *range, int priority,
                             const pf_queue_dependency *after, size_t after_count)
{
    pf_queue_job_spec spec = {.scene_path = "scenes/box.gltf",
                              .frame_range = range,
                              .output_pattern = "out/g_####.exr",
                              .priority = priority,
                              .max_attempts = 1,
                              .after = after,
                              .after_count = after_count};
    pf_error err = {0};
    int64_t job_id = 0;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    return job_id;
}

static void check_note(pf_queue *queue, int64_t job_id, const char *status, const char *note)
{
    pf_queue_job job = job_get(queue, job_id);
    PF_CHECK_MSG(!strcmp(job.status, status) && strstr(job.note, note),
                 "job %lld: %s, note \"%s\"; expected %s, \"%s\"", (long long)job_id, job.status,
                 job.note, status, note);
    pf_queue_job_clear(&job);
}

/*
 * --after (issue 42): a job waits, whatever its priority, until its prerequisite is done,
 * its status saying so, and then runs.
 */
PF_TEST(a_dependent_job_waits_then_runs)
{
    pf_queue *queue = open_fresh("dependent");
    PF_REQUIRE(queue);
    int64_t worker = register_worker(queue, "w");
    int64_t plates = enqueue_after(queue, "1-2", 0, NULL, 0);
    pf_queue_dependency after = {plates, false};
    int64_t comp = enqueue_after(queue, "1-2", 10, &after, 1);
    char waiting[64];
    snprintf(waiting, sizeof waiting, "waiting for job %lld (queued)", (long long)plates);
    check_note(queue, comp, "waiting", waiting);
    pf_queue_task first = claim(queue, worker, 0, 0);
    PF_CHECK_MSG(first.job_id == plates, "claimed job %lld", (long long)first.job_id);
    pf_queue_task second = claim(queue, worker, 0, 0);
    PF_CHECK_MSG(second.job_id == plates, "claimed job %lld", (long long)second.job_id);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0); /* comp waits */
    snprintf(waiting, sizeof waiting, "waiting for job %lld (running)", (long long)plates);
    check_note(queue, comp, "waiting", waiting);
    complete_plain(queue, &first);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0); /* one frame of plates is not enough */
    complete_plain(queue, &second);
    check_job_status(queue, plates, "done");
    pf_queue_job job = job_get(queue, comp);
    PF_CHECK_MSG(!strcmp(job.status, "queued") && !job.note[0], "%s, %s", job.status, job.note);
    char prerequisites[64];
    snprintf(prerequisites, sizeof prerequisites, "%lld (done)", (long long)plates);
    PF_CHECK_MSG(!strcmp(job.prerequisites, prerequisites), "%s", job.prerequisites);
    pf_queue_job_clear(&job);
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_CHECK_MSG(task.job_id == comp, "claimed job %lld", (long long)task.job_id);
    pf_queue_close(queue);
}

/*
 * A failed or canceled prerequisite blocks its dependents, directly or through others,
 * with the reason; a retry of it lifts the block.
 */
PF_TEST(a_failed_prerequisite_blocks_its_dependents)
{
    pf_queue *queue = open_fresh("blocked");
    PF_REQUIRE(queue);
    pf_error err = {0};
    int64_t worker = register_worker(queue, "w");
    int64_t first = enqueue_after(queue, "1", 0, NULL, 0);
    pf_queue_dependency after = {first, false};
    int64_t second = enqueue_after(queue, "1", 0, &after, 1);
    after.job_id = second;
    int64_t third = enqueue_after(queue, "1-2", 0, &after, 1);
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.job_id == first);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "out of memory", &err), &err);
    check_job_status(queue, first, "failed");
    char reason[128];
    snprintf(reason, sizeof reason, "blocked: job %lld, which it waits for, failed",
             (long long)first);
    check_note(queue, second, "blocked", reason);
    snprintf(reason, sizeof reason, "blocked: job %lld, which it waits for through others, "
             "failed", (long long)first);
    check_note(queue, third, "blocked", reason);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    /* A retry makes them wait again, and a cancel blocks them with that reason. */
    PF_CHECK_OK(pf_queue_retry(queue, first, NULL, &err), &err);
    check_job_status(queue, second, "waiting");
    check_job_status(queue, third, "waiting");
    PF_CHECK_OK(pf_queue_cancel(queue, first, &err), &err);
    snprintf(reason, sizeof reason, "job %lld, which it waits for, canceled", (long long)first);
    check_note(queue, second, "blocked", reason);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0);
    /* The blocked job itself can still be canceled. */
    PF_CHECK_OK(pf_queue_cancel(queue, third, &err), &err);
    check_job_status(queue, third, "canceled");
    pf_queue_close(queue);
}

/* --after-frames: frame n of the dependent is claimable once frame n of the other is done. */
PF_TEST(after_frames_releases_frame_n_after_frame_n)
{
    pf_queue *queue = open_fresh("after_frames");
    PF_REQUIRE(queue);
    int64_t worker = register_worker(queue, "w");
    int64_t plates = enqueue_after(queue, "1-3", 0, NULL, 0);
    pf_queue_dependency after = {plates, true};
    /* Two frames a task: 1-2 waits for plates' 1 and 2, 3 for plates' 3. */
    pf_queue_job_spec spec = {.scene_path = "scenes/box.gltf",
                              .frame_range = "1-3",
                              .output_pattern = "out/g_####.exr",
                              .priority = 10,
                              .frames_per_task = 2,
                              .after = &after,
                              .after_count = 1};
    pf_error err = {0};
    int64_t comp = 0;
    PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &comp, &err), &err);
    check_job_status(queue, comp, "queued"); /* frame by frame: not waiting as a whole */
    pf_queue_task plate[3];
    for (int i = 0; i < 3; i++) {
        plate[i] = claim(queue, worker, 0, 0);
        PF_CHECK_MSG(plate[i].job_id == plates && plate[i].first_frame == i + 1,
                     "claim %d: job %lld frame %d", i, (long long)plate[i].job_id,
                     plate[i].first_frame);
    }
    complete_plain(queue, &plate[2]); /* plates' frame 3: comp's 3 is free, 1-2 are not */
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_CHECK_MSG(task.job_id == comp && task.first_frame == 3, "job %lld frame %d",
                 (long long)task.job_id, task.first_frame);
    complete_plain(queue, &plate[0]);
    PF_CHECK(claim(queue, worker, 0, 0).task_id == 0); /* 1-2 still waits for plates' 2 */
    complete_plain(queue, &plate[1]);
    task = claim(queue, worker, 0, 0);
    PF_CHECK_MSG(task.job_id == comp && task.first_frame == 1 && task.frame_count == 2,
                 "job %lld frame %d", (long long)task.job_id, task.first_frame);
    pf_queue_close(queue);
}

static size_t job_count(pf_queue *queue)
{
    pf_queue_job *jobs = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_list(queue, &jobs, &count, &err), &err);
    pf_queue_job_list_free(jobs, count);
    return count;
}

/* Cycles, unknown jobs, repeats and ended jobs are refused, and nothing is added. */
PF_TEST(dependency_cycles_and_unknown_jobs_are_refused)
{
    pf_queue *queue = open_fresh("cycles");
    PF_REQUIRE(queue);
    pf_error err = {0};
    int64_t a = enqueue_after(queue, "1", 0, NULL, 0);
    pf_queue_dependency after = {a, false};
    int64_t b = enqueue_after(queue, "1", 0, &after, 1);
    after.job_id = b;
    int64_t c = enqueue_after(queue, "1", 0, &after, 1);
    pf_queue_dependency back = {b, false};
    PF_CHECK(pf_queue_add_dependencies(queue, a, &back, 1, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "cycle") != NULL, "%s", err.message);
    back.job_id = c; /* a ← b ← c ← a, through b */
    PF_CHECK(pf_queue_add_dependencies(queue, a, &back, 1, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "cycle") != NULL, "%s", err.message);
    back.job_id = a;
    PF_CHECK(pf_queue_add_dependencies(queue, a, &back, 1, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "itself") != NULL, "%s", err.message);
    PF_CHECK(pf_queue_add_dependencies(queue, b, &back, 1, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "already waits") != NULL, "%s", err.message);
    /* Two prerequisites, the second unknown: neither is added. */
    pf_queue_dependency two[2] = {{a, false}, {999, true}};
    PF_CHECK(pf_queue_add_dependencies(queue, c, two, 2, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "no job 999") != NULL, "%s", err.message);
    pf_queue_job job = job_get(queue, c);
    char expected[32];
    snprintf(expected, sizeof expected, "%lld (queued)", (long long)b);
    PF_CHECK_MSG(!strcmp(job.prerequisites, expected), "%s", job.prerequisites);
    pf_queue_job_clear(&job);
    /* An enqueue after an unknown job, or after one named twice, inserts nothing. */
    size_t jobs_before = job_count(queue);
    pf_queue_job_spec spec = {.scene_path = "s.gltf", .frame_range = "1",
                              .output_pattern = "o", .after = two, .after_count = 2};
    int64_t job_id = 0;
    PF_CHECK(pf_queue_enqueue(queue, &spec, &job_id, &err) == PF_ERR_INVALID);
    two[1].job_id = a;
    PF_CHECK(pf_queue_enqueue(queue, &spec, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "twice") != NULL, "%s", err.message);
    PF_CHECK(job_count(queue) == jobs_before);
    /* A job that has ended waits for nothing. */
    PF_CHECK_OK(pf_queue_cancel(queue, c, &err), &err);
    after.job_id = a;
    PF_CHECK(pf_queue_add_dependencies(queue, c, &after, 1, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "has ended") != NULL, "%s", err.message);
    /* A later dependency that makes no cycle is taken: a waits for a new job d. */
    int64_t d = enqueue_after(queue, "1", 0, NULL, 0);
    after.job_id = d;
    PF_CHECK_OK(pf_queue_add_dependencies(queue, a, &after, 1, &err), &err);
    check_job_status(queue, a, "waiting");
    pf_queue_close(queue);
}

/*
 * Per-frame resources (issue 42): stored with the completion beside the stage rows, bad
 * ones refused with nothing written, summarised in the timings (min/median/p95/max), listed
 * per frame with worker, attempt, stages and decisions, and behind status's memory advice.
 */
PF_TEST(attempt_logs_are_stored_per_attempt_and_listed_per_frame)
{
    pf_queue *queue = open_fresh("attempt_logs");
    PF_REQUIRE(queue);
    pf_error err = {0};
    int64_t worker = register_worker(queue, "log-worker");
    int64_t job = enqueue(queue, "1-4", 0, 2, 3); /* tasks {1,2} and {3,4} */
    pf_queue_task task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.first_frame == 1);
    /* Attempt 1 fails; its log is stored without a lease (the task is back in the queue). */
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "device lost", &err), &err);
    PF_CHECK_OK(pf_queue_attempt_log_store(queue, task.task_id, 1, worker,
                                           "claimed\nbad byte \xff here\n", &err), &err);
    /* No attempt 2 yet, no task 999, and a log over the limit: refused, nothing stored. */
    PF_CHECK(pf_queue_attempt_log_store(queue, task.task_id, 2, worker, "x", &err) ==
             PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "attempt 2") != NULL, "%s", err.message);
    PF_CHECK(pf_queue_attempt_log_store(queue, 999, 1, worker, "x", &err) == PF_ERR_INVALID);
    char *huge = malloc(PF_QUEUE_LOG_MAX + 2);
    PF_REQUIRE(huge);
    memset(huge, 'a', PF_QUEUE_LOG_MAX + 1);
    huge[PF_QUEUE_LOG_MAX + 1] = '\0';
    PF_CHECK(pf_queue_attempt_log_store(queue, task.task_id, 1, worker, huge, &err) ==
             PF_ERR_INVALID);
    free(huge);

    clock_now.now += 60000; /* past the backoff */
    task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.first_frame == 1 && task.attempt == 2);
    PF_CHECK_OK(pf_queue_attempt_log_store(queue, task.task_id, 2, worker, "first\n", &err), &err);
    /* The same attempt again replaces its log. */
    PF_CHECK_OK(pf_queue_attempt_log_store(queue, task.task_id, 2, 0, "rendered\n", &err), &err);

    pf_queue_attempt_log *logs = NULL;
    size_t count = 0;
    PF_REQUIRE_OK(pf_queue_attempt_logs(queue, job, 2, &logs, &count, &err), &err);
    PF_REQUIRE(count == 2);
    PF_CHECK(logs[0].attempt == 1 && logs[0].first_frame == 1 && logs[0].last_frame == 2 &&
             !strcmp(logs[0].worker_name, "log-worker"));
    PF_CHECK_MSG(!strcmp(logs[0].text, "claimed\nbad byte ? here\n"), "%s", logs[0].text);
    PF_CHECK(logs[1].attempt == 2 && !strcmp(logs[1].text, "rendered\n") &&
             !logs[1].worker_name[0] && logs[1].written_at >= logs[0].written_at);
    pf_queue_attempt_logs_free(logs, count);
    /* Frame 3's task logged nothing; an unknown job is an error. */
    PF_CHECK_OK(pf_queue_attempt_logs(queue, job, 3, &logs, &count, &err), &err);
    PF_CHECK(count == 0);
    pf_queue_attempt_logs_free(logs, count);
    PF_CHECK(pf_queue_attempt_logs(queue, job + 100, 1, &logs, &count, &err) == PF_ERR_INVALID);
    pf_queue_close(queue);
}

/* The monitor's poll: the mark stays while nobody commits, and moves when another
 * connection does (one retry on PostgreSQL, where another database's transaction on the
 * same cluster may move the snapshot too). */
PF_TEST(the_change_mark_moves_only_with_a_commit)
{
    pf_queue *queue = open_fresh("change_mark");
    PF_REQUIRE(queue);
    char path[1200];
    opened_path("change_mark", path, sizeof path);
    pf_queue *other = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(open_queue(path, &test_options, &clock_now, &other, &err), &err);
    char first[PF_QUEUE_MARK_MAX], second[PF_QUEUE_MARK_MAX], third[PF_QUEUE_MARK_MAX];
    PF_CHECK_OK(pf_queue_change_mark(queue, first, sizeof first, &err), &err);
    PF_CHECK_OK(pf_queue_change_mark(queue, second, sizeof second, &err), &err);
    PF_CHECK_OK(pf_queue_change_mark(queue, third, sizeof third, &err), &err);
    PF_CHECK_MSG(first[0] && (!strcmp(first, second) || !strcmp(second, third)),
                 "%s, %s, %s without a commit", first, second, third);
    enqueue(other, "1-2", 0, 1, 3);
    PF_CHECK_OK(pf_queue_change_mark(queue, first, sizeof first, &err), &err);
    PF_CHECK_MSG(strcmp(first, third) != 0, "%s after another connection's commit", first);
    pf_queue_close(other);
    pf_queue_close(queue);
}

PF_TEST(frame_resources_are_stored_summarised_and_listed)
{
    pf_queue *queue = open_fresh("resources");
    PF_REQUIRE(queue);
    pf_error err = {0};
    int64_t worker = register_worker(queue, "big-worker");
    int64_t job = enqueue(queue, "1-4", 0, 2, 3); /* tasks {1,2} and {3,4} */
    const int64_t mib = 1 << 20;
    pf_queue_task task = claim(queue, worker, 0, 0);
    pf_queue_stage_row rows[3] = {
        {1, "bih_build", 2.0, PF_QUEUE_NO_GPU_MS, NULL, false, "built: 12 nodes", NULL},
        {1, "shade", 10.0, 8.0, NULL, false, NULL, NULL},
        {2, "bih_build", 0.0, PF_QUEUE_NO_GPU_MS, NULL, true, "geometry unchanged", NULL}};
    /* A frame outside the task, or given twice, or a negative size: nothing written. */
    pf_queue_frame_resources bad[2] = {{1, 100 * mib, 10 * mib, 5000}, {3, 1, 1, 1}};
    PF_CHECK(pf_queue_complete_frames(queue, task.lease_token, rows, 3, bad, 2, NULL, &err) ==
             PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "frame 3") != NULL, "%s", err.message);
    bad[1].frame = 1;
    PF_CHECK(pf_queue_complete_frames(queue, task.lease_token, rows, 3, bad, 2, NULL, &err) ==
             PF_ERR_INVALID);
    bad[1] = (pf_queue_frame_resources){2, -5, 1, 1};
    PF_CHECK(pf_queue_complete_frames(queue, task.lease_token, rows, 3, bad, 2, NULL, &err) ==
             PF_ERR_INVALID);
    pf_queue_task_info *tasks = NULL;
    size_t task_count = 0;
    PF_CHECK_OK(pf_queue_task_list(queue, job, &tasks, &task_count, &err), &err);
    PF_CHECK(task_count == 2 && !strcmp(tasks[0].status, "running"));
    free(tasks);
    pf_queue_frame_resources first[2] = {{1, 100 * mib, 10 * mib, 5000},
                                         {2, 300 * mib, -1, 7000}};
    PF_CHECK_OK(pf_queue_complete_frames(queue, task.lease_token, rows, 3, first, 2, NULL, &err),
                &err);
    task = claim(queue, worker, 0, 0);
    pf_queue_stage_row later[2] = {{3, "shade", 20.0, 15.0, NULL, false, NULL, NULL},
                                   {4, "shade", 30.0, 25.0, NULL, false, NULL, NULL}};
    pf_queue_frame_resources second[2] = {{3, 200 * mib, 30 * mib, 6000},
                                          {4, 400 * mib, 20 * mib, 8000}};
    PF_CHECK_OK(pf_queue_complete_frames(queue, task.lease_token, later, 2, second, 2, NULL, &err),
                &err);

    pf_queue_timings timings;
    PF_REQUIRE_OK(pf_queue_timings_get(queue, job, 3, &timings, &err), &err);
    /* rss 100, 200, 300, 400 MiB: median 250, p95 385 (rank 2.85); device without frame 2. */
    PF_CHECK(timings.peak_rss.count == 4 && timings.peak_rss.min == 100.0 * mib &&
             timings.peak_rss.median == 250.0 * mib && timings.peak_rss.p95 == 385.0 * mib &&
             timings.peak_rss.max == 400.0 * mib);
    PF_CHECK(timings.peak_device_memory.count == 3 &&
             timings.peak_device_memory.median == 20.0 * mib &&
             timings.peak_device_memory.max == 30.0 * mib);
    PF_CHECK(timings.bytes_written.count == 4 && timings.bytes_written.total == 26000.0);
    pf_queue_timings_free(&timings);

    pf_queue_frame_details details;
    PF_REQUIRE_OK(pf_queue_frame_details_get(queue, job, &details, &err), &err);
    PF_REQUIRE(details.frame_count == 4 && details.stage_count == 5);
    const pf_queue_frame_detail *one = &details.frames[0], *two = &details.frames[1];
    PF_CHECK(one->frame == 1 && one->attempt == 1 && !strcmp(one->worker_name, "big-worker") &&
             one->peak_rss == 100 * mib && one->bytes_written == 5000 && one->stage_count == 2 &&
             one->wall_ms == 12.0);
    PF_CHECK(!strcmp(details.stages[one->first_stage].decision, "built") &&
             !details.stages[one->first_stage + 1].decision[0]);
    PF_CHECK(two->frame == 2 && two->peak_device_memory == -1 && two->stage_count == 1 &&
             details.stages[two->first_stage].skipped && two->wall_ms == 0.0 &&
             !strcmp(details.stages[two->first_stage].decision, "geometry unchanged"));
    PF_CHECK(details.frames[3].frame == 4 && details.frames[3].peak_rss == 400 * mib);
    pf_queue_frame_details_free(&details);

    /* Memory failures: counted for status's advice, beside the largest peaks measured. */
    int64_t other = enqueue(queue, "1-2", 5, 1, 3);
    task = claim(queue, worker, 0, 0);
    PF_REQUIRE(task.job_id == other);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token,
                              "buffer 'film': allocating 9 bytes on 'x' failed: "
                              "VK_ERROR_OUT_OF_DEVICE_MEMORY",
                              &err),
                &err);
    pf_queue_job info = job_get(queue, other);
    PF_CHECK(info.memory_failures == 1);
    pf_queue_job_clear(&info);
    PF_REQUIRE_OK(pf_queue_timings_get(queue, other, 0, &timings, &err), &err);
    PF_CHECK(timings.peak_rss.count == 0 && timings.peak_rss.max == 0.0); /* none finished */
    pf_queue_timings_free(&timings);
    info = job_get(queue, job);
    PF_CHECK(info.memory_failures == 0);
    pf_queue_job_clear(&info);
    /* The worker's record (the monitor's worker table): 4 frames done, 1 failure. */
    pf_queue_worker_stats *stats = NULL;
    size_t stats_count = 0;
    PF_CHECK_OK(pf_queue_worker_stats_list(queue, &stats, &stats_count, &err), &err);
    PF_CHECK_MSG(stats_count == 1 && stats[0].worker_id == worker && stats[0].frames_done == 4 &&
                     stats[0].failures == 1 && !stats[0].blocked_jobs[0],
                 "%zu workers, %lld frames, %lld failures", stats_count,
                 stats_count ? (long long)stats[0].frames_done : -1LL,
                 stats_count ? (long long)stats[0].failures : -1LL);
    free(stats);
    pf_queue_close(queue);
}

/*
 * PostgreSQL only: a URL that cannot be used is bad input naming the cause
 * and never the password; a schema from a newer photonfarm is refused.
 */
PF_TEST(postgres_bad_urls_and_newer_schema_are_refused)
{
    const char *url = queue_test_postgres();
    if (!url) {
        printf("  (PostgreSQL only)\n");
        return;
    }
    static const char *const bad[] = {
        "postgresql://someone:s3cret-pw@127.0.0.1:1/photonfarm",       /* nothing listens */
        "postgresql://someone:s3cret-pw@[::1/photonfarm",             /* malformed */
        "postgres://no-such-host.invalid:5432/x?connect_timeout=2",  /* unreachable */
    };
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        pf_error err = {0};
        pf_queue *queue = NULL;
        pf_status status = pf_queue_open(bad[i], NULL, &queue, &err);
        PF_CHECK_MSG(status == PF_ERR_INVALID && !queue, "%s: status %d", bad[i], status);
        PF_CHECK_MSG(strstr(err.message, "cannot connect") && !strstr(err.message, "s3cret"),
                     "%s", err.message);
    }
    /* Credentials the server refuses: a role that does not exist. */
    char wrong_user[1200];
    const char *at = strchr(url, '@');
    PF_REQUIRE(at);
    snprintf(wrong_user, sizeof wrong_user, "postgresql://intruder:s3cret-pw%s", at);
    pf_error err = {0};
    pf_queue *queue = NULL;
    PF_CHECK(pf_queue_open(wrong_user, NULL, &queue, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "intruder") && strstr(err.message, "***") &&
                     !strstr(err.message, "s3cret"),
                 "%s", err.message);
    /* A schema from a newer photonfarm. */
    queue = open_fresh("newer");
    PF_REQUIRE(queue);
    pf_queue_close(queue);
    PF_REQUIRE(queue_test_query_int(url, "WITH v AS (INSERT INTO schema_version VALUES (99, 0) "
                                         "RETURNING version) SELECT version FROM v") == 99);
    queue = NULL;
    PF_CHECK(pf_queue_open(url, NULL, &queue, &err) == PF_ERR_UNSUPPORTED && !queue);
    PF_CHECK_MSG(strstr(err.message, "newer than this photonfarm"), "%s", err.message);
}

/*
 * PostgreSQL only: a connection re-established after the server restarted
 * keeps its session settings. Here the write lock's timeout (busy_timeout):
 * without it, the reconnected connection would wait for the lock forever,
 * and this test (which waits for it on the thread holding the lock) would hang.
 */
PF_TEST(postgres_reconnect_keeps_the_lock_timeout)
{
    const char *url = queue_test_postgres(), *cluster = getenv("PF_TEST_POSTGRES_DIR");
    if (!url || !cluster) {
        printf("  (PostgreSQL only)\n");
        return;
    }
    pf_queue *queue = open_fresh("reconnect");
    PF_REQUIRE(queue);
    pf_error err = {0};
    pf_queue *other = open_impatient(url);
    PF_REQUIRE(other);
    int64_t first = enqueue(queue, "1-2", 0, 1, 0);
    char command[2400];
    snprintf(command, sizeof command, "'%s/tests/jobs/pg_throwaway.sh' restart '%s'",
             getenv("PF_SOURCE_DIR"), cluster);
    PF_REQUIRE(system(command) == 0);
    /* Both connections are dead now; the next transaction of each reconnects. */
    pf_queue_job *jobs = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_job_list(other, &jobs, &count, &err), &err);
    pf_queue_job_list_free(jobs, count);
    conflict_probe_state state = {other, 0, 0, PF_OK, 1};
    int64_t job_id = 0;
    PF_CHECK(enqueue_probed(queue, &state, &job_id, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(state.calls == 1 && state.last_seen == first, "%d calls", state.calls);
    PF_CHECK_MSG(state.other_status == PF_ERR_IO, "the reconnected connection's enqueue: %d",
                 state.other_status);
    pf_queue_close(other);
    pf_queue_close(queue);
}

int main(void)
{
    PF_RUN(enqueue_chunks_frames_into_tasks);
    PF_RUN(claim_order_priority_job_frame);
    PF_RUN(claim_prefers_next_frame_of_loaded_job);
    PF_RUN(claims_start_the_job_once_and_need_a_registered_worker);
    PF_RUN(heartbeat_renews_only_the_current_lease);
    PF_RUN(expired_lease_is_reaped_and_old_owner_fenced);
    PF_RUN(failures_back_off_then_fail_at_max_attempts);
    PF_RUN(blocklist_after_repeated_failures);
    PF_RUN(release_does_not_count_an_attempt);
    PF_RUN(job_faults_pause_the_job_and_spare_the_worker);
    PF_RUN(pause_resume_cancel_retry);
    PF_RUN(stage_rows_are_validated_all_or_nothing);
    PF_RUN(timing_statistics_match_hand_computed_values);
    PF_RUN(reaping_counts_attempts_and_blocks_the_silent_worker);
    PF_RUN(locked_database_is_retried_then_reported);
    PF_RUN(workers_are_dead_after_their_own_lease);
    PF_RUN(workers_record_their_capabilities);
    PF_RUN(claims_follow_the_jobs_requirements);
    PF_RUN(a_dependent_job_waits_then_runs);
    PF_RUN(a_failed_prerequisite_blocks_its_dependents);
    PF_RUN(after_frames_releases_frame_n_after_frame_n);
    PF_RUN(dependency_cycles_and_unknown_jobs_are_refused);
    PF_RUN(frame_resources_are_stored_summarised_and_listed);
    PF_RUN(attempt_logs_are_stored_per_attempt_and_listed_per_frame);
    PF_RUN(the_change_mark_moves_only_with_a_commit);
    PF_RUN(enqueue_conflicts_are_decided_under_the_write_lock);
    PF_RUN(postgres_bad_urls_and_newer_schema_are_refused);
    PF_RUN(postgres_reconnect_keeps_the_lock_timeout);
    return pf_test_finish();
}
