/*
 * Several worker processes on one queue file: 4 workers and 200 one-frame
 * tasks — every frame rendered exactly once (one claim, one set of stage
 * rows, one EXR), none lost; and a worker killed with SIGKILL mid-frame —
 * once its lease expires another worker reaps it, renders the frame, and no
 * partial or temporary file is left.
 */
#include "pf_image.h"
#include "pf_test.h"
#include "worker_test_util.h"

#include <signal.h>
#include <unistd.h>

#define WORKERS 4
#define FRAMES 200
#define WORKER_TIMEOUT_MS 100000

static char dir[WT_PATH_MAX], scene[WT_PATH_MAX + 32], log_path[WT_PATH_MAX + 32];

static int64_t enqueue(const char *db, const char *frames, const char *pattern)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args,
              "'%s' --frames %s --out '%s' --size 16x16 --frames-per-task 1 "
              "--quality preview --db '%s'",
              scene, frames, pattern, db);
    return wt_enqueue(args, log_path);
}

PF_TEST(four_workers_render_every_frame_exactly_once)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX], range[32];
    char logs[WORKERS][WT_PATH_MAX + 32];
    wt_fresh_dir("many-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/many.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/m.####.exr", out);
    wt_format(range, sizeof range, "1-%d", FRAMES);
    int64_t job_id = enqueue(db, range, pattern);
    PF_REQUIRE(job_id > 0);
    pid_t pids[WORKERS];
    for (int i = 0; i < WORKERS; i++) {
        wt_format(logs[i], sizeof logs[i], "%s/many-worker%d.log", dir, i);
        unlink(logs[i]);
        const char *arguments[] = {"worker", "--idle-exit", "2", "--db", db, NULL};
        pids[i] = wt_spawn(arguments, logs[i], NULL);
    }
    int claimed = 0, completed = 0, busy_workers = 0;
    for (int i = 0; i < WORKERS; i++) {
        int code = wt_wait(pids[i], WORKER_TIMEOUT_MS);
        PF_CHECK_MSG(code == 0, "worker %d exited %d (log %s)", i, code, logs[i]);
        int worker_completed = wt_count_in_file(logs[i], "event=completed");
        claimed += wt_count_in_file(logs[i], "event=claimed");
        completed += worker_completed;
        busy_workers += worker_completed > 0;
    }
    PF_CHECK_MSG(claimed == FRAMES && completed == FRAMES, "%d claims, %d completions", claimed,
                 completed);
    /* Not a timing assertion: with 200 frames every worker gets some. */
    PF_CHECK_MSG(busy_workers == WORKERS, "only %d workers rendered", busy_workers);
    PF_CHECK(wt_count_files(out, ".exr") == FRAMES);
    PF_CHECK(wt_count_files(out, "") == FRAMES);

    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK(!strcmp(job.status, "done") && job.frames_done == FRAMES);
    pf_queue_job_clear(&job);
    pf_queue_task_info *tasks = NULL;
    size_t task_count = 0;
    PF_CHECK_OK(pf_queue_task_list(queue, job_id, &tasks, &task_count, &err), &err);
    pf_queue_close(queue);
    PF_CHECK(task_count == FRAMES);
    int wrong = 0;
    for (size_t i = 0; i < task_count; i++) {
        if (strcmp(tasks[i].status, "done") || tasks[i].attempt != 1 ||
            wt_stage_rows_for_task(db, tasks[i].task_id, "shade") != 1 ||
            wt_stage_rows_for_task(db, tasks[i].task_id, "scene_eval") != 1 ||
            wt_stage_rows_for_task(db, tasks[i].task_id, "exr_write") != 1) {
            if (wrong++ < 5)
                fprintf(stderr, "task %lld (frame %d): %s, attempt %d\n",
                        (long long)tasks[i].task_id, tasks[i].first_frame, tasks[i].status,
                        tasks[i].attempt);
        }
    }
    free(tasks);
    PF_CHECK_MSG(wrong == 0, "%d tasks not rendered exactly once", wrong);
}

PF_TEST(a_killed_workers_frame_is_rendered_by_another_after_its_lease_expires)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        victim_log[WT_PATH_MAX + 32], rescuer_log[WT_PATH_MAX + 32], path[3 * WT_PATH_MAX];
    wt_fresh_dir("crash-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/crash.db", dir);
    wt_format(victim_log, sizeof victim_log, "%s/crash-victim.log", dir);
    wt_format(rescuer_log, sizeof rescuer_log, "%s/crash-rescuer.log", dir);
    unlink(db);
    unlink(victim_log);
    unlink(rescuer_log);
    wt_format(pattern, sizeof pattern, "%s/c.####.exr", out);
    wt_format(path, sizeof path, "%s/c.0002.exr", out);
    int64_t job_id = enqueue(db, "2", pattern);
    PF_REQUIRE(job_id > 0);
    const char *victim_args[] = {"worker", "--lease-seconds", "2", "--name", "victim",
                                 "--db", db, NULL};
    char env[8 * WT_PATH_MAX];
    wt_fault_environment(env, sizeof env, out, NULL, NULL, 60000);
    pid_t victim = wt_spawn(victim_args, victim_log, env);
    /* Mid-frame: its temporary EXR is on disk, the frame not yet handed back. */
    int partial = 0;
    for (int waited = 0; waited < 20000 && !partial; waited += 50) {
        wt_sleep_ms(50);
        partial = wt_count_files(out, ".partial-") > 0;
    }
    PF_CHECK_MSG(partial, "the victim never wrote its temporary");
    kill(victim, SIGKILL);
    PF_CHECK(wt_wait(victim, 10000) == 128 + SIGKILL);

    const char *rescuer_args[] = {"worker", "--lease-seconds", "2", "--max-frames", "1",
                                  "--idle-exit", "20", "--name", "rescuer", "--db", db, NULL};
    pid_t rescuer = wt_spawn(rescuer_args, rescuer_log, NULL);
    int code = wt_wait(rescuer, WORKER_TIMEOUT_MS);
    PF_CHECK_MSG(code == 0, "rescuer exited %d", code);
    PF_CHECK(wt_file_contains(rescuer_log, "event=reaped"));
    PF_CHECK(wt_file_contains(rescuer_log, "event=completed"));

    pf_image image = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_exr_read(path, &image, NULL, NULL, &err), &err);
    pf_image_free(&image);
    PF_CHECK_MSG(wt_count_files(out, "") == 1, "%d files in the output, expected only the frame",
                 wt_count_files(out, ""));
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_task_info *tasks = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_task_list(queue, job_id, &tasks, &count, &err), &err);
    PF_REQUIRE(count == 1);
    PF_CHECK(!strcmp(tasks[0].status, "done") && tasks[0].attempt == 2 &&
             !strcmp(tasks[0].worker_name, "rescuer"));
    free(tasks);
    pf_queue_failure *failures = NULL;
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    PF_CHECK(count == 1 && strstr(failures[0].error, "lease expired") &&
             !strcmp(failures[0].worker_name, "victim"));
    free(failures);
    pf_queue_close(queue);
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(scene, sizeof scene, "%s/tiny.gltf", dir);
    wt_format(log_path, sizeof log_path, "%s/run.log", dir);
    wt_write_tiny_scene(scene, FRAMES);
    PF_RUN(four_workers_render_every_frame_exactly_once);
    PF_RUN(a_killed_workers_frame_is_rendered_by_another_after_its_lease_expires);
    return pf_test_finish();
}
