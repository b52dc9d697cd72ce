/*
 * Storage faults are the job's, not the workers' (issue 14): worker
 * processes run with fault_inject.c preloaded, which makes the output
 * directory read-only or full while a switch file exists.
 *
 *   - A full output disk: the frame renders, its EXR cannot be written, the
 *     job is paused with the cause in `status`, the worker is not blocked
 *     and no attempt is counted; once the disk has room, `resume` and the
 *     same worker finish the job.
 *   - Chaos: three workers, the output made read-only mid-job and mended,
 *     two workers killed with SIGKILL (one mid-frame, one while the job is
 *     paused); after `resume` the job finishes with every frame rendered
 *     exactly once (one completion and one set of stage rows per frame,
 *     every EXR readable, no partial file left).
 */
#include "pf_test.h"
#include "worker_test_util.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#define WAIT_MS 120000
/* Keeps each frame in flight long enough for a kill to land mid-frame. */
#define HOLD_MS 400
#define CHAOS_FRAMES 12

static char dir[WT_PATH_MAX], scene[WT_PATH_MAX + 32], log_path[WT_PATH_MAX + 32];

static pf_queue_job job_now(const char *db, int64_t job_id)
{
    pf_queue_job job = {0};
    pf_queue *queue = wt_open_queue(db);
    pf_error err = {0};
    if (queue)
        PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    pf_queue_close(queue);
    return job;
}

/* Polls until the job's status is `status` (or timeout); 1 if it is. */
static int wait_status(const char *db, int64_t job_id, const char *status, int timeout_ms)
{
    for (int waited = 0; waited < timeout_ms; waited += 100) {
        pf_queue_job job = job_now(db, job_id);
        int reached = !strcmp(job.status, status);
        pf_queue_job_clear(&job);
        if (reached)
            return 1;
        wt_sleep_ms(100);
    }
    return 0;
}

static int64_t frames_done(const char *db, int64_t job_id)
{
    pf_queue_job job = job_now(db, job_id);
    int64_t done = job.frames_done;
    pf_queue_job_clear(&job);
    return done;
}

static void touch(const char *path)
{
    FILE *file = fopen(path, "w");
    PF_REQUIRE(file != NULL);
    fclose(file);
}

/* Failures of the job: total and how many were the job's own. */
static void count_failures(const char *db, int64_t job_id, size_t *total, size_t *job_faults)
{
    pf_queue *queue = wt_open_queue(db);
    pf_queue_failure *failures = NULL;
    pf_error err = {0};
    *total = *job_faults = 0;
    if (queue)
        PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, total, &err), &err);
    for (size_t i = 0; i < *total; i++)
        *job_faults += failures[i].job_fault != 0;
    free(failures);
    pf_queue_close(queue);
}

/* Rows of one stage for the job (direct SQL). */
static int stage_rows(const char *db_path, int64_t job_id, const char *stage)
{
    return wt_count_query(db_path,
                          "SELECT count(*) FROM stage_timings s JOIN tasks t ON t.id = "
                          "s.task_id WHERE t.job_id = ?1 AND s.stage = ?2",
                          job_id, stage);
}

/* Every frame 1..count of pattern dir/f.####.exr opens and says it is that frame. */
static void check_frames(const char *out, int count)
{
    for (int frame = 1; frame <= count; frame++) {
        char path[WT_PATH_MAX + 64];
        wt_format(path, sizeof path, "%s/f.%04d.exr", out, frame);
        int recorded = wt_exr_frame(path);
        PF_CHECK_MSG(recorded == frame, "%s records frame %d", path, recorded);
    }
}

PF_TEST(a_full_output_disk_pauses_the_job_and_resume_finishes_it)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], flip[WT_PATH_MAX + 32],
        args[8 * WT_PATH_MAX], env[8 * WT_PATH_MAX], worker_log[WT_PATH_MAX + 32];
    wt_fresh_dir("full-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/full.db", dir);
    wt_format(flip, sizeof flip, "%s/full.switch", dir);
    wt_format(worker_log, sizeof worker_log, "%s/full-worker.log", dir);
    unlink(db);
    unlink(worker_log);
    wt_format(args, sizeof args,
              "'%s' --frames 1-3 --out '%s/f.####.exr' --size 16x16 --quality preview "
              "--max-attempts 1 --db '%s'",
              scene, out, db);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    touch(flip);
    wt_fault_environment(env, sizeof env, out, flip, "full", 0);
    const char *worker_args[] = {"worker", "--name", "w-full", "--idle-exit", "2", "--db", db,
                                 NULL};
    int code = wt_wait(wt_spawn(worker_args, worker_log, env), WAIT_MS);
    /* The worker did nothing wrong: it exits 0 and is blocked for nothing. */
    PF_CHECK_MSG(code == 0, "worker exited %d", code);
    PF_CHECK(wt_file_contains(worker_log, "event=job_fault"));
    PF_CHECK(wt_file_contains(worker_log, "fault=output"));
    pf_queue_job job = job_now(db, job_id);
    PF_CHECK_MSG(!strcmp(job.status, "paused"), "job %s", job.status);
    PF_CHECK(job.tasks_queued == 3 && job.tasks_failed == 0 && job.frames_done == 0);
    PF_CHECK_MSG(strstr(job.note, "No space left on device") != NULL, "note: %s", job.note);
    PF_CHECK(job.blocked_live_workers == 0);
    pf_queue_job_clear(&job);
    size_t failures = 0, job_faults = 0;
    count_failures(db, job_id, &failures, &job_faults);
    PF_CHECK_MSG(failures == 1 && job_faults == 1, "%zu failures, %zu the job's", failures,
                 job_faults);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "paused: output: "));
    PF_CHECK(wt_file_contains(log_path, "No space left on device"));
    PF_CHECK(wt_count_files(out, "") == 0);

    /* Room again: resume, and the same worker (max attempts 1) renders everything. */
    unlink(flip);
    wt_format(args, sizeof args, "resume %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    code = wt_wait(wt_spawn(worker_args, worker_log, env), WAIT_MS);
    PF_CHECK_MSG(code == 0, "worker exited %d", code);
    job = job_now(db, job_id);
    PF_CHECK_MSG(!strcmp(job.status, "done") && job.frames_done == 3, "job %s, %lld frames",
                 job.status, (long long)job.frames_done);
    PF_CHECK(job.note[0] == '\0');
    pf_queue_job_clear(&job);
    check_frames(out, 3);
    PF_CHECK(wt_count_files(out, "partial") == 0);
}

/* The chaos run with its three workers (pids), which the caller stops whatever happens. */
static void chaos(const char *out, const char *db, const char *flip, pid_t pids[3],
                  int alive[3])
{
    char args[8 * WT_PATH_MAX], env[8 * WT_PATH_MAX], logs[3][WT_PATH_MAX + 32], names[3][16];
    wt_format(args, sizeof args,
              "'%s' --frames 1-%d --out '%s/f.####.exr' --size 16x16 --quality preview "
              "--frames-per-task 1 --db '%s'",
              scene, CHAOS_FRAMES, out, db);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    wt_fault_environment(env, sizeof env, out, flip, "read-only", HOLD_MS);
    for (int i = 0; i < 3; i++) {
        wt_format(logs[i], sizeof logs[i], "%s/chaos-worker%d.log", dir, i);
        wt_format(names[i], sizeof names[i], "w%d", i);
        unlink(logs[i]);
        /* A 2 s lease: a killed worker's frame comes back soon. */
        const char *worker_args[] = {"worker", "--name", names[i], "--lease-seconds", "2",
                                     "--db", db, NULL};
        pids[i] = wt_spawn(worker_args, logs[i], env);
        alive[i] = 1;
    }
    for (int waited = 0; waited < WAIT_MS && frames_done(db, job_id) < 3; waited += 50)
        wt_sleep_ms(50);
    PF_REQUIRE_MSG(frames_done(db, job_id) >= 3, "the farm never got going");

    /* Worker 0 dies mid-frame (frames are held HOLD_MS in flight). */
    kill(pids[0], SIGKILL);
    alive[0] = 0;
    PF_CHECK(wt_wait(pids[0], WAIT_MS) == 128 + SIGKILL);
    /* The output volume turns read-only: the job pauses, nobody is blamed. */
    touch(flip);
    PF_REQUIRE_MSG(wait_status(db, job_id, "paused", WAIT_MS), "the job never paused");
    pf_queue_job job = job_now(db, job_id);
    PF_CHECK_MSG(strstr(job.note, "Read-only file system") != NULL, "note: %s", job.note);
    PF_CHECK(job.blocked_live_workers == 0 && job.tasks_failed == 0);
    pf_queue_job_clear(&job);
    for (int i = 1; i < 3; i++)
        PF_CHECK_MSG(waitpid(pids[i], NULL, WNOHANG) == 0, "worker %d exited", i);

    /* Worker 1 dies while the job is paused; the disk is mended; resume. */
    kill(pids[1], SIGKILL);
    alive[1] = 0;
    PF_CHECK(wt_wait(pids[1], WAIT_MS) == 128 + SIGKILL);
    unlink(flip);
    wt_format(args, sizeof args, "resume %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_REQUIRE_MSG(wait_status(db, job_id, "done", WAIT_MS), "the job never finished");
    kill(pids[2], SIGTERM);
    alive[2] = 0;
    PF_CHECK(wt_wait(pids[2], WAIT_MS) == 0);

    /* Exactly once: one completion and one set of rows per frame, every file whole. */
    job = job_now(db, job_id);
    PF_CHECK(job.tasks_done == CHAOS_FRAMES && job.frames_done == CHAOS_FRAMES);
    pf_queue_job_clear(&job);
    PF_CHECK_MSG(stage_rows(db, job_id, "exr_write") == CHAOS_FRAMES, "%d exr_write rows",
                 stage_rows(db, job_id, "exr_write"));
    PF_CHECK(stage_rows(db, job_id, "scene_eval") == CHAOS_FRAMES);
    check_frames(out, CHAOS_FRAMES);
    PF_CHECK_MSG(wt_count_files(out, "") == CHAOS_FRAMES, "%d files in the output",
                 wt_count_files(out, ""));
    size_t failures = 0, job_faults = 0;
    count_failures(db, job_id, &failures, &job_faults);
    PF_CHECK_MSG(job_faults >= 1, "%zu of %zu failures were the job's", job_faults, failures);
    PF_CHECK(wt_file_contains(logs[1], "event=job_fault") ||
             wt_file_contains(logs[2], "event=job_fault"));
}

PF_TEST(read_only_output_and_killed_workers_lose_and_repeat_nothing)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], flip[WT_PATH_MAX + 32];
    wt_fresh_dir("chaos-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/chaos.db", dir);
    wt_format(flip, sizeof flip, "%s/chaos.switch", dir);
    unlink(db);
    unlink(flip);
    pid_t pids[3] = {0};
    int alive[3] = {0};
    chaos(out, db, flip, pids, alive);
    for (int i = 0; i < 3; i++)
        if (alive[i])
            wt_wait((kill(pids[i], SIGKILL), pids[i]), WAIT_MS);
}

/*
 * `photonfarm render --frames` writes its frames behind the render too (frame_writer.h): a
 * write that fails on a full disk, on the writer's thread, still ends the run with exit 2
 * naming the cause, no frame after it, and no temporary left.
 */
PF_TEST(render_frames_on_a_full_disk_exits_2_and_leaves_nothing)
{
    char out[WT_PATH_MAX + 32], flip[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        env[8 * WT_PATH_MAX], render_log[WT_PATH_MAX + 32];
    wt_fresh_dir("render-full-out", out, sizeof out);
    wt_format(flip, sizeof flip, "%s/render-full.switch", dir);
    wt_format(render_log, sizeof render_log, "%s/render-full.log", dir);
    wt_format(pattern, sizeof pattern, "%s/r.####.exr", out);
    touch(flip);
    wt_fault_environment(env, sizeof env, out, flip, "full", 0);
    const char *render_args[] = {"render", scene,    "--frames", "1-3",       "--size", "16x16",
                                 "--quality", "preview", "-o",   pattern, NULL};
    int code = wt_wait(wt_spawn(render_args, render_log, env), WAIT_MS);
    unlink(flip);
    PF_CHECK_MSG(code == 2, "render exited %d", code);
    PF_CHECK(wt_file_contains(render_log, "writing frame 1"));
    PF_CHECK(wt_file_contains(render_log, "No space left on device"));
    PF_CHECK(!wt_file_contains(render_log, "] frame "));
    PF_CHECK_MSG(wt_count_files(out, "") == 0, "%d file(s) left", wt_count_files(out, ""));
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(scene, sizeof scene, "%s/tiny.gltf", dir);
    wt_format(log_path, sizeof log_path, "%s/run.log", dir);
    wt_write_tiny_scene(scene, CHAOS_FRAMES);
    PF_RUN(a_full_output_disk_pauses_the_job_and_resume_finishes_it);
    PF_RUN(read_only_output_and_killed_workers_lose_and_repeat_nothing);
    PF_RUN(render_frames_on_a_full_disk_exits_2_and_leaves_nothing);
    return pf_test_finish();
}
