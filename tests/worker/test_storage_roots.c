/*
 * Scene and output roots (issue 18): escape attempts through "..", absolute
 * paths, symbolic links to directories and a symbolic link at an output file,
 * at enqueue (exit 2 naming the root) and at the worker (a job row written
 * straight into the queue: the task fails with the reason, nobody is
 * blocked); paths stored relative to the roots, so a job follows its storage
 * to another mount point; and the one warning of a worker without roots.
 */
#include "pf_test.h"
#include "worker_test_util.h"

#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[WT_PATH_MAX], log_path[WT_PATH_MAX + 32];

/* T/name/{scenes,out} with tiny.gltf in scenes; fills the three paths. */
static void make_storage(const char *name, char *storage, char *scenes, char *out, size_t size)
{
    wt_format(storage, size, "%s/%s", dir, name);
    mkdir(storage, 0755);
    wt_format(scenes, size, "%s/scenes", storage);
    wt_format(out, size, "%s/out", storage);
    mkdir(scenes, 0755);
    mkdir(out, 0755);
    char scene[WT_PATH_MAX + 64];
    wt_format(scene, sizeof scene, "%s/tiny.gltf", scenes);
    wt_write_tiny_scene(scene, 2);
}

/* T/name holding tiny.gltf, a directory outside any root; fills both paths. */
static void make_outside(const char *name, char *outside, size_t outside_size, char *scene,
                         size_t scene_size)
{
    wt_format(outside, outside_size, "%s/%s", dir, name);
    mkdir(outside, 0755);
    wt_format(scene, scene_size, "%s/tiny.gltf", outside);
    wt_write_tiny_scene(scene, 2);
}

/* photonfarm ARGS must exit 2 with every one of the texts in its output. */
static void expect_refused(const char *args, const char *text1, const char *text2)
{
    int code = wt_run(args, log_path);
    PF_CHECK_MSG(code == 2, "exit %d for: %s", code, args);
    PF_CHECK(wt_file_contains(log_path, text1));
    if (text2)
        PF_CHECK(wt_file_contains(log_path, text2));
}

PF_TEST(enqueue_refuses_paths_outside_the_roots_and_stores_them_relative)
{
    char storage[WT_PATH_MAX], scenes[WT_PATH_MAX + 16], out[WT_PATH_MAX + 16],
        outside[WT_PATH_MAX + 16], link[WT_PATH_MAX + 64], db[WT_PATH_MAX + 16],
        roots[4 * WT_PATH_MAX], args[16 * WT_PATH_MAX], target[WT_PATH_MAX + 64];
    make_storage("enqueue-storage", storage, scenes, out, sizeof storage);
    make_outside("enqueue-outside", outside, sizeof outside, target, sizeof target);
    wt_format(db, sizeof db, "%s/enqueue.db", dir);
    unlink(db);
    wt_format(roots, sizeof roots, "--scene-root '%s' --output-root '%s' --db '%s' --frames 1",
              scenes, out, db);

    /* The scene: through "..", absolute, through a linked directory. */
    wt_format(args, sizeof args, "enqueue '%s/../../enqueue-outside/tiny.gltf' --out '%s/f.####.exr' %s",
              scenes, out, roots);
    expect_refused(args, "outside the scene roots", scenes);
    wt_format(args, sizeof args, "enqueue '%s' --out '%s/f.####.exr' %s", target, out, roots);
    expect_refused(args, "outside the scene roots", NULL);
    wt_format(link, sizeof link, "%s/linked", scenes);
    unlink(link);
    PF_REQUIRE(symlink(outside, link) == 0);
    wt_format(args, sizeof args, "enqueue '%s/tiny.gltf' --out '%s/f.####.exr' %s", link, out,
              roots);
    expect_refused(args, "outside the scene roots", NULL);

    /* The output: through "..", through a linked directory, onto a linked file. */
    wt_format(args, sizeof args, "enqueue '%s/tiny.gltf' --out '%s/../../enqueue-outside/f.####.exr' %s",
              scenes, out, roots);
    expect_refused(args, "outside the output roots", out);
    wt_format(link, sizeof link, "%s/linked", out);
    unlink(link);
    PF_REQUIRE(symlink(outside, link) == 0);
    wt_format(args, sizeof args, "enqueue '%s/tiny.gltf' --out '%s/f.####.exr' %s", scenes, link,
              roots);
    expect_refused(args, "outside the output roots", NULL);
    wt_format(link, sizeof link, "%s/f.0001.exr", out);
    unlink(link);
    wt_format(target, sizeof target, "%s/stolen.exr", outside);
    PF_REQUIRE(symlink(target, link) == 0);
    wt_format(args, sizeof args, "enqueue '%s/tiny.gltf' --out '%s/f.####.exr' %s", scenes, out,
              roots);
    expect_refused(args, "symbolic link", NULL);
    unlink(link);

    /* Roots from the environment work the same. */
    setenv("PHOTONFARM_SCENE_ROOTS", scenes, 1);
    wt_format(args, sizeof args, "enqueue '%s/tiny.gltf' --out '%s/f.####.exr' --db '%s' --frames 1",
              outside, out, db);
    expect_refused(args, "outside the scene roots", NULL);
    unsetenv("PHOTONFARM_SCENE_ROOTS");

    /* A missing output directory: made inside the roots, as Blender does; refused, and not
     * made, outside them. */
    wt_format(args, sizeof args,
              "enqueue '%s/tiny.gltf' --out '%s/../../enqueue-outside/new/f.####.exr' %s", scenes,
              out, roots);
    expect_refused(args, "outside the output roots", NULL);
    wt_format(target, sizeof target, "%s/new", outside);
    PF_CHECK_MSG(access(target, F_OK) != 0, "%s was made outside the roots", target);
    wt_format(target, sizeof target, "%s/made/here", out);
    rmdir(target); /* an earlier run's */
    wt_format(target, sizeof target, "%s/made", out);
    rmdir(target);
    wt_format(args, sizeof args, "'%s/tiny.gltf' --out '%s/made/here/f.####.exr' %s", scenes,
              out, roots);
    PF_CHECK(wt_enqueue(args, log_path) > 0);
    PF_CHECK(wt_file_contains(log_path, "created the output directory"));
    wt_format(target, sizeof target, "%s/made/here", out);
    PF_CHECK_MSG(access(target, F_OK) == 0, "%s was not made", target);

    /* Inside: accepted, stored relative to the root that holds each path. */
    wt_format(args, sizeof args, "'%s/tiny.gltf' --out '%s/f.####.exr' %s", scenes, out, roots);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(job.scene_path && !strcmp(job.scene_path, "tiny.gltf"), "scene stored as %s",
                 job.scene_path);
    PF_CHECK_MSG(job.output_pattern && !strcmp(job.output_pattern, "./f.####.exr"),
                 "output stored as %s", job.output_pattern);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
}

/* Inserts a job row as an older client or a hand-written one would: no checks. */
static int64_t insert_directly(const char *db, const char *scene, const char *pattern)
{
    pf_queue *queue = wt_open_queue(db);
    pf_queue_job_spec spec = {.scene_path = scene,
                              .parameters_json = "{\"width\":16,\"height\":16,\"quality\":\"preview\"}",
                              .frame_range = "1",
                              .output_pattern = pattern,
                              .max_attempts = 3};
    int64_t job_id = 0;
    pf_error err = {0};
    if (queue)
        PF_CHECK_OK(pf_queue_enqueue(queue, &spec, &job_id, &err), &err);
    pf_queue_close(queue);
    return job_id;
}

PF_TEST(a_worker_refuses_job_rows_that_escape_its_roots)
{
    char storage[WT_PATH_MAX], scenes[WT_PATH_MAX + 16], out[WT_PATH_MAX + 16],
        outside[WT_PATH_MAX + 16], db[WT_PATH_MAX + 16], path[2 * WT_PATH_MAX],
        pattern[2 * WT_PATH_MAX], args[16 * WT_PATH_MAX];
    make_storage("worker-storage", storage, scenes, out, sizeof storage);
    make_outside("worker-outside", outside, sizeof outside, path, sizeof path);
    wt_format(db, sizeof db, "%s/worker.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/f.####.exr", out);
    /* A scene outside, absolute; a scene climbing out of a relative path; an output outside. */
    int64_t absolute_scene = insert_directly(db, path, pattern);
    int64_t climbing_scene = insert_directly(db, "../../worker-outside/tiny.gltf", pattern);
    wt_format(pattern, sizeof pattern, "%s/f.####.exr", outside);
    int64_t outside_output = insert_directly(db, "tiny.gltf", pattern);
    /* Inside the roots but missing: the scene's fault (the job pauses), not a refusal. */
    wt_format(pattern, sizeof pattern, "%s/m.####.exr", out);
    int64_t missing_scene = insert_directly(db, "missing.gltf", pattern);
    PF_REQUIRE(absolute_scene > 0 && climbing_scene > 0 && outside_output > 0 &&
               missing_scene > 0);

    wt_format(args, sizeof args, "worker --once --scene-root '%s' --output-root '%s' --db '%s'",
              scenes, out, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "event=rejected"));
    PF_CHECK(wt_file_contains(log_path, "event=roots"));
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue);
    const int64_t jobs[] = {absolute_scene, climbing_scene, outside_output};
    const char *reasons[] = {"outside the scene roots", "outside the scene roots",
                             "outside the output roots"};
    for (int i = 0; i < 3; i++) {
        pf_queue_job job = {0};
        pf_error err = {0};
        PF_CHECK_OK(pf_queue_job_get(queue, jobs[i], &job, &err), &err);
        PF_CHECK_MSG(!strcmp(job.status, "failed") && job.tasks_failed == 1 &&
                         job.blocked_live_workers == 0,
                     "job %lld: %s, %lld failed, %d blocked", (long long)jobs[i], job.status,
                     (long long)job.tasks_failed, job.blocked_live_workers);
        pf_queue_job_clear(&job);
        pf_queue_failure *failures = NULL;
        size_t count = 0;
        PF_CHECK_OK(pf_queue_failure_list(queue, jobs[i], &failures, &count, &err), &err);
        PF_CHECK_MSG(count == 1 && failures[0].job_fault && strstr(failures[0].error, reasons[i]),
                     "job %lld: %zu failures: %s", (long long)jobs[i], count,
                     count ? failures[0].error : "");
        free(failures);
    }
    pf_queue_job paused = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, missing_scene, &paused, &err), &err);
    PF_CHECK_MSG(!strcmp(paused.status, "paused") && strstr(paused.note, "paused: scene: ") &&
                     strstr(paused.note, "missing.gltf"),
                 "missing scene: job %s, note %s", paused.status, paused.note);
    pf_queue_job_clear(&paused);
    pf_queue_close(queue);
    PF_CHECK(wt_count_files(outside, ".exr") == 0);
    PF_CHECK(wt_count_files(out, ".exr") == 0);
}

PF_TEST(a_job_follows_its_storage_to_another_mount_point)
{
    char storage[WT_PATH_MAX], scenes[WT_PATH_MAX + 16], out[WT_PATH_MAX + 16],
        moved[WT_PATH_MAX], db[WT_PATH_MAX + 16], args[16 * WT_PATH_MAX];
    wt_format(moved, sizeof moved, "%s/mount-b", dir);
    wt_format(args, sizeof args, "rm -rf '%s' '%s/mount-a'", moved, dir);
    PF_REQUIRE(system(args) == 0);
    make_storage("mount-a", storage, scenes, out, sizeof storage);
    wt_format(db, sizeof db, "%s/mount.db", dir);
    unlink(db);
    wt_format(args, sizeof args,
              "'%s/tiny.gltf' --frames 1-2 --out '%s/f.####.exr' --size 16x16 --quality preview "
              "--scene-root '%s' --output-root '%s' --db '%s'",
              scenes, out, scenes, out, db);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    /* The storage is now mounted elsewhere: no absolute path of the old place remains. */
    PF_REQUIRE(rename(storage, moved) == 0);
    wt_format(scenes, sizeof scenes, "%s/scenes", moved);
    wt_format(out, sizeof out, "%s/out", moved);
    wt_format(args, sizeof args, "worker --once --scene-root '%s' --output-root '%s' --db '%s'",
              scenes, out, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK_MSG(wt_count_files(out, ".exr") == 2, "%d frames in %s", wt_count_files(out, ".exr"),
                 out);
    /* status shows the stored path and what it resolves to here. */
    wt_format(args, sizeof args, "status %lld --scene-root '%s' --output-root '%s' --db '%s'",
              (long long)job_id, scenes, out, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "done"));
    char resolved[2 * WT_PATH_MAX];
    wt_format(resolved, sizeof resolved, "tiny.gltf (%s/tiny.gltf)", scenes);
    PF_CHECK(wt_file_contains(log_path, resolved));
}

PF_TEST(a_worker_without_roots_warns_once)
{
    char db[WT_PATH_MAX + 16], args[4 * WT_PATH_MAX];
    wt_format(db, sizeof db, "%s/mount.db", dir); /* done: nothing to claim */
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK_MSG(wt_count_in_file(log_path, "event=unconfined") == 1, "%d warnings",
                 wt_count_in_file(log_path, "event=unconfined"));
    PF_CHECK(wt_file_contains(log_path, "kinds=scene,output"));
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(log_path, sizeof log_path, "%s/run.log", dir);
    PF_RUN(enqueue_refuses_paths_outside_the_roots_and_stores_them_relative);
    PF_RUN(a_worker_refuses_job_rows_that_escape_its_roots);
    PF_RUN(a_job_follows_its_storage_to_another_mount_point);
    PF_RUN(a_worker_without_roots_warns_once);
    return pf_test_finish();
}
