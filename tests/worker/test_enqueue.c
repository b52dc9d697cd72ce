/*
 * `photonfarm enqueue` and the query/control commands without rendering:
 * good jobs go in with absolute paths, every kind of bad input exits 2 with
 * a message naming it and inserts nothing, and a corrupt or non-SQLite
 * database is refused with its bytes untouched.
 */
#include "pf_test.h"
#include "worker_test_util.h"

#include <fcntl.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static char dir[WT_PATH_MAX], db[WT_PATH_MAX + 32], scene[WT_PATH_MAX + 32],
    out_dir[WT_PATH_MAX + 32], log_path[WT_PATH_MAX + 32];

static int64_t job_count(void)
{
    pf_queue *queue = wt_open_queue(db);
    if (!queue)
        return -1;
    pf_queue_job *jobs = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_list(queue, &jobs, &count, &err), &err);
    pf_queue_job_list_free(jobs, count);
    pf_queue_close(queue);
    return (int64_t)count;
}

/* Runs "enqueue ..." (args start with it); the job id it printed, or 0 (the test has failed). */
static int64_t enqueue_job(const char *args)
{
    PF_CHECK(!strncmp(args, "enqueue ", 8));
    return wt_enqueue(args + 8, log_path);
}

PF_TEST(enqueue_inserts_a_validated_job_and_prints_its_id)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args,
             "enqueue '%s' --frames 1-3 --out '%s/f.####.exr' --size 16x12 --quality preview "
             "--priority 5 --max-attempts 4 --frames-per-task 2 --name tiny --time-budget 2.5 "
             "--db '%s'",
             scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    PF_CHECK(job_id >= 1);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK(job.priority == 5 && job.max_attempts == 4 && job.frames_per_task == 2);
    PF_CHECK(job.frames_total == 3 && job.tasks_total == 2);
    PF_CHECK_MSG(job.scene_path && job.scene_path[0] == '/', "scene stored as %s", job.scene_path);
    PF_CHECK_MSG(job.output_pattern && job.output_pattern[0] == '/' &&
                     strstr(job.output_pattern, "f.####.exr"),
                 "pattern stored as %s", job.output_pattern);
    PF_CHECK(job.parameters_json && strstr(job.parameters_json, "\"width\":16") &&
             strstr(job.parameters_json, "\"name\":\"tiny\"") &&
             strstr(job.parameters_json, "\"time_budget_ms\":2500"));
    pf_queue_job_clear(&job);
    pf_queue_close(queue);

    /* fast with its LPV settings: they travel in the job's JSON. */
    wt_format(args, sizeof args,
             "enqueue '%s' --frames 1 --out '%s/fast.exr' --size 16x12 --quality fast "
             "--lpv-cascades 3 --lpv-size 16 --lpv-iterations 6,6,12 --lpv-cell 0.125 "
             "--photons 5000 --filter blackman-harris --max-bounces 3 --budget-ms 2500 "
             "--target-relmse 0.02 --db '%s'",
             scene, out_dir, db);
    int64_t fast_id = enqueue_job(args);
    PF_REQUIRE(fast_id >= 1);
    queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    PF_CHECK_OK(pf_queue_job_get(queue, fast_id, &job, &err), &err);
    PF_CHECK_MSG(job.parameters_json &&
                     strstr(job.parameters_json, "\"quality\":\"fast\"") &&
                     strstr(job.parameters_json, "\"photons\":5000") &&
                     strstr(job.parameters_json, "\"filter\":\"blackman-harris\"") &&
                     strstr(job.parameters_json, "\"max_bounces\":3") &&
                     strstr(job.parameters_json, "\"budget_ms\":2500") &&
                     strstr(job.parameters_json, "\"target_relmse\":0.02") &&
                     strstr(job.parameters_json, "\"lpv\":{\"cascades\":3,\"size\":16,"
                                                 "\"iterations\":[6,6,12],\"cell\":0.125}"),
                 "parameters %s", job.parameters_json ? job.parameters_json : "(none)");
    pf_queue_job_clear(&job);
    pf_queue_close(queue);

    wt_format(args, sizeof args, "status --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "(tiny)"));
    PF_CHECK(wt_file_contains(log_path, "0/3"));
}

typedef struct bad_case {
    const char *what;
    const char *arguments; /* %1$s scene, %2$s output dir (positional via two passes) */
    const char *message;
} bad_case;

/* A job's requirements (issue 42): stored (tags normalised), shown by status, and a warning
 * when no worker registered with the queue has ever met them. */
PF_TEST(requirements_are_stored_shown_and_warned_about)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/req.exr' --size 16x12 --quality preview "
              "--requires gpu --min-device-memory 24G --min-memory 512M --tag Show-A --tag night "
              "--db '%s'",
              scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    PF_CHECK(wt_file_contains(log_path, "warning: no worker registered with this queue has a gpu"));
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK(!strcmp(job.requires_device, "gpu") && job.min_device_memory == (24ll << 30) &&
             job.min_host_memory == (512ll << 20) && !strcmp(job.required_tags, "night,show-a"));
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "requires: a gpu with >= 24.0 GiB of device memory, "
                                        ">= 0.5 GiB of memory and the tags night,show-a"));
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
}

/*
 * Job dependencies from the command line (issue 42): enqueue --after and depend store
 * them, status shows them and the waiting or blocked state, and an unknown job, a bad id
 * or a cycle is exit 2 with nothing added.
 */
PF_TEST(dependencies_are_stored_shown_and_checked)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/plate.exr' --size 16x12 --quality preview "
              "--db '%s'",
              scene, out_dir, db);
    int64_t plate = enqueue_job(args);
    PF_REQUIRE(plate >= 1);
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/comp.exr' --size 16x12 --quality preview "
              "--after %lld --db '%s'",
              scene, out_dir, (long long)plate, db);
    int64_t comp = enqueue_job(args);
    PF_REQUIRE(comp >= 1);
    char text[128];
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)comp, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "waiting"));
    wt_format(text, sizeof text, "after: job %lld (queued)", (long long)plate);
    PF_CHECK(wt_file_contains(log_path, text));
    wt_format(text, sizeof text, "note: waiting for job %lld (queued)", (long long)plate);
    PF_CHECK(wt_file_contains(log_path, text));

    int64_t jobs_before = job_count();
    static const char *const refused[][2] = {
        {"enqueue '%s' --frames 1 --out '%s/x.exr' --after 99999 --db '%s'", "no job 99999"},
        {"enqueue '%s' --frames 1 --out '%s/x.exr' --after 1,two --db '%s'",
         "'two' is not a job id"},
        {"enqueue '%s' --frames 1 --out '%s/x.exr' --after-frames 0 --db '%s'",
         "'0' is not a job id"},
    };
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; i++) {
        wt_format(args, sizeof args, refused[i][0], scene, out_dir, db);
        PF_CHECK_MSG(wt_run(args, log_path) == 2, "%s", refused[i][0]);
        PF_CHECK_MSG(wt_file_contains(log_path, refused[i][1]), "%s", refused[i][1]);
    }
    PF_CHECK(job_count() == jobs_before);
    /* The plate waiting for the comp would be a cycle. */
    wt_format(args, sizeof args, "depend %lld --after %lld --db '%s'", (long long)plate,
              (long long)comp, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "cycle"));
    wt_format(args, sizeof args, "depend %lld --db '%s'", (long long)plate, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "no prerequisite given"));
    /* A canceled plate blocks the comp, and a watch of it ends: nothing changes by itself. */
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)plate, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    wt_format(args, sizeof args, "status %lld --watch 1 --db '%s'", (long long)comp, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    wt_format(text, sizeof text, "blocked: job %lld, which it waits for, canceled",
              (long long)plate);
    PF_CHECK(wt_file_contains(log_path, text));
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)comp, db);
    PF_CHECK(wt_run(args, log_path) == 0);
}

/* A job whose frames ran out of memory: status shows the finished frames' peaks and
 * suggests the requirements that would keep it off smaller workers (issue 42). */
PF_TEST(status_suggests_memory_requirements_after_memory_failures)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1-2 --out '%s/oom.####.exr' --size 16x12 --quality preview "
              "--priority 1000 --db '%s'",
              scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_error err = {0};
    pf_queue_worker_spec spec = {.name = "small", .host = "h", .pid = 1};
    int64_t worker = 0;
    PF_REQUIRE_OK(pf_queue_worker_register(queue, &spec, &worker, &err), &err);
    pf_queue_task task;
    bool claimed = false;
    PF_REQUIRE_OK(pf_queue_claim(queue, worker, job_id, 0, &task, &claimed, &err), &err);
    PF_REQUIRE(claimed && task.job_id == job_id);
    /* 3 GiB of memory and 700 MiB of device memory at most: 3.75 GiB and 875 MiB with
     * headroom, rounded up to 256 MiB steps. */
    pf_queue_frame_resources took = {task.first_frame, 3ll << 30, 700ll << 20, 1000};
    PF_CHECK_OK(pf_queue_complete_frames(queue, task.lease_token, NULL, 0, &took, 1, NULL, &err),
                &err);
    PF_REQUIRE_OK(pf_queue_claim(queue, worker, job_id, 0, &task, &claimed, &err), &err);
    PF_REQUIRE(claimed && task.job_id == job_id);
    PF_CHECK_OK(pf_queue_fail(queue, task.lease_token, "scene: out of memory", &err), &err);
    pf_queue_close(queue);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "memory: 1 failure ran out of memory; its finished "
                                        "frames peaked at 3.0 GiB of memory and 700 MiB of "
                                        "device memory"));
    PF_CHECK(wt_file_contains(log_path, "--min-memory 4G --min-device-memory 1G"));
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
}

/* How many times text occurs in path's content. */
static int occurrences(const char *path, const char *text)
{
    char *content = wt_read_file(path, NULL);
    int found = 0;
    for (const char *p = content; p && (p = strstr(p, text)) != NULL; p += strlen(text))
        found++;
    free(content);
    return found;
}

/*
 * status --watch (issue 42): reports again until every job shown has ended. Decided by
 * events, never by how long a report took: the watch has printed the queued job, then the
 * job is canceled, then the watch must end by itself, its last report the canceled job.
 * An ended job's watch prints once and returns at once.
 */
PF_TEST(status_watch_reports_until_the_jobs_end)
{
    char args[8 * WT_PATH_MAX], watch_log[WT_PATH_MAX + 32];
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/watched.exr' --size 16x12 --quality preview "
              "--db '%s'",
              scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    wt_format(watch_log, sizeof watch_log, "%s/watch.log", dir);
    unlink(watch_log); /* an earlier run's would look like this run's first report */
    char job[32];
    snprintf(job, sizeof job, "%lld", (long long)job_id);
    fflush(NULL);
    pid_t child = fork();
    PF_REQUIRE(child >= 0);
    if (child == 0) {
        int out = open(watch_log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        dup2(out, STDOUT_FILENO);
        execl(getenv("PHOTONFARM"), "photonfarm", "status", job, "--watch", "1", "--db", db,
              (char *)NULL);
        _exit(127);
    }
    int printed = 0;
    for (int waited = 0; waited < 60000 && !printed; waited += 50) {
        printed = occurrences(watch_log, "queued") > 0;
        if (!printed)
            wt_sleep_ms(50);
    }
    PF_CHECK_MSG(printed, "the watch never printed the queued job");
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    int status = 0, ended = 0;
    for (int waited = 0; waited < 60000 && !ended; waited += 50) {
        ended = waitpid(child, &status, WNOHANG) == child;
        if (!ended)
            wt_sleep_ms(50);
    }
    if (!ended) {
        kill(child, SIGKILL);
        waitpid(child, &status, 0);
    }
    PF_CHECK_MSG(ended && WIFEXITED(status) && WEXITSTATUS(status) == 0,
                 "the watch did not end by itself (status %d)", status);
    /* At least two reports, the last one the canceled job's. */
    char *content = wt_read_file(watch_log, NULL);
    const char *last = content ? strstr(content, "canceled [") : NULL;
    PF_CHECK_MSG(occurrences(watch_log, "tasks:") >= 2 && last && !strstr(last, "queued ["),
                 "watch output:\n%s", content ? content : "(none)");
    free(content);
    /* Ended: one report, then exit. */
    wt_format(args, sizeof args, "status %lld --watch 1 --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(occurrences(log_path, "tasks:") == 1 && occurrences(log_path, "canceled [") == 1);
}

PF_TEST(bad_input_exits_2_and_inserts_nothing)
{
    char corrupt[WT_PATH_MAX + 32], readonly[WT_PATH_MAX + 32], args[8 * WT_PATH_MAX];
    wt_format(corrupt, sizeof corrupt, "%s/corrupt.gltf", dir);
    FILE *file = fopen(corrupt, "wb");
    PF_REQUIRE(file != NULL);
    fputs("{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [ {", file);
    fclose(file);
    wt_format(readonly, sizeof readonly, "%s/readonly", dir);
    mkdir(readonly, 0555);
    chmod(readonly, 0555);
    int64_t before = job_count();

    struct {
        char arguments[4 * WT_PATH_MAX];
        const char *message;
    } cases[40];
    int count = 0;
#define CASE(msg, ...)                                                                    \
    do {                                                                                  \
        wt_format(cases[count].arguments, sizeof cases[count].arguments, __VA_ARGS__);     \
        cases[count++].message = msg;                                                     \
    } while (0)
    CASE("missing.gltf", "enqueue '%s/missing.gltf' --frames 1 --out '%s/f.exr'", dir, out_dir);
    CASE("corrupt.gltf", "enqueue '%s' --frames 1 --out '%s/f.exr'", corrupt, out_dir);
    CASE("5-1", "enqueue '%s' --frames 5-1 --out '%s/f.####.exr'", scene, out_dir);
    CASE("outside", "enqueue '%s' --frames 1-5 --out '%s/f.####.exr'", scene, out_dir);
    CASE("frame 0 is outside", "enqueue '%s' --frames 0-2 --out '%s/f.####.exr'", scene, out_dir);
    CASE("####", "enqueue '%s' --frames 1-2 --out '%s/f.exr'", scene, out_dir);
    /* A missing directory is made (test_storage_roots); one that cannot be is refused. */
    CASE("no-such-dir", "enqueue '%s' --frames 1 --out '/proc/no-such-dir/f.exr'", scene);
    CASE("not writable", "enqueue '%s' --frames 1 --out '/proc/f.####.exr'", scene);
    if (geteuid() != 0)
        CASE("not writable", "enqueue '%s' --frames 1 --out '%s/f.exr'", scene, readonly);
    CASE("--size", "enqueue '%s' --frames 1 --out '%s/f.exr' --size 0x10", scene, out_dir);
    CASE("--quality", "enqueue '%s' --frames 1 --out '%s/f.exr' --quality best", scene, out_dir);
    CASE("--max-attempts", "enqueue '%s' --frames 1 --out '%s/f.exr' --max-attempts 0", scene,
         out_dir);
    CASE("--time-budget", "enqueue '%s' --frames 1 --out '%s/f.exr' --time-budget 0", scene,
         out_dir);
    /* LPV settings: zero, negative, non-numeric, beyond every device's guaranteed buffers. */
    CASE("--lpv-size", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-size 0", scene, out_dir);
    CASE("--lpv-size", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-size -4", scene, out_dir);
    CASE("--lpv-size", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-size big", scene, out_dir);
    CASE("--lpv-size", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-size 128", scene,
         out_dir);
    CASE("--lpv-iterations", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-iterations 0", scene,
         out_dir);
    CASE("--lpv-iterations", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-iterations 4,,4",
         scene, out_dir);
    CASE("--lpv-cascades", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-cascades 99", scene,
         out_dir);
    CASE("--lpv-cell", "enqueue '%s' --frames 1 --out '%s/f.exr' --lpv-cell 0", scene, out_dir);
    CASE("--filter", "enqueue '%s' --frames 1 --out '%s/f.exr' --filter mitchell", scene, out_dir);
    CASE("--max-bounces", "enqueue '%s' --frames 1 --out '%s/f.exr' --max-bounces -1", scene,
         out_dir);
    CASE("--max-bounces", "enqueue '%s' --frames 1 --out '%s/f.exr' --max-bounces 1025", scene,
         out_dir);
    CASE("--budget-ms", "enqueue '%s' --frames 1 --out '%s/f.exr' --budget-ms 0", scene, out_dir);
    CASE("--budget-ms", "enqueue '%s' --frames 1 --out '%s/f.exr' --budget-ms 5ms", scene,
         out_dir);
    CASE("--target-relmse", "enqueue '%s' --frames 1 --out '%s/f.exr' --target-relmse -0.1",
         scene, out_dir);
    /* A material variant the scene lacks (it has none), named with the file's (none). */
    CASE("--variant 'blue': no material variant of that name or index (the file's: none)",
         "enqueue '%s' --frames 1 --out '%s/f.exr' --variant blue", scene, out_dir);
    /* Requirements (issue 42). */
    CASE("gpu|cpu", "enqueue '%s' --frames 1 --out '%s/f.exr' --requires tpu", scene, out_dir);
    CASE("24X", "enqueue '%s' --frames 1 --out '%s/f.exr' --min-device-memory 24X", scene,
         out_dir);
    CASE("bad/tag", "enqueue '%s' --frames 1 --out '%s/f.exr' --tag ok --tag bad/tag", scene,
         out_dir);
#undef CASE
    PF_REQUIRE(count <= (int)(sizeof cases / sizeof *cases));
    for (int i = 0; i < count; i++) {
        wt_format(args, sizeof args, "%s --db '%s'", cases[i].arguments, db);
        int code = wt_run(args, log_path);
        PF_CHECK_MSG(code == 2, "'%s' exited %d", args, code);
        PF_CHECK(wt_file_contains(log_path, cases[i].message));
        PF_CHECK(wt_file_contains(log_path, "photonfarm enqueue:"));
    }
    PF_CHECK(job_count() == before);
    PF_CHECK(wt_count_files(out_dir, "probe") == 0);
    chmod(readonly, 0755);
}

/* Writes bytes to path; returns them for the later comparison. */
static void write_bytes(const char *path, const char *bytes, size_t size)
{
    FILE *file = fopen(path, "wb");
    if (file) {
        fwrite(bytes, 1, size, file);
        fclose(file);
    }
}

static int file_equals(const char *path, const char *bytes, size_t size)
{
    size_t got = 0;
    char *content = wt_read_file(path, &got);
    int same = content && got == size && memcmp(content, bytes, size) == 0;
    free(content);
    return same;
}

PF_TEST(corrupt_or_foreign_database_exits_2_and_is_untouched)
{
    char text_db[WT_PATH_MAX + 32], corrupt_db[WT_PATH_MAX + 32], args[8 * WT_PATH_MAX];
    wt_format(text_db, sizeof text_db, "%s/notes.txt", dir);
    wt_format(corrupt_db, sizeof corrupt_db, "%s/corrupt.db", dir);
    const char text[] = "this is not a database\n";
    char corrupt[4096];
    memset(corrupt, 0x5a, sizeof corrupt);
    memcpy(corrupt, "SQLite format 3", 16); /* a valid magic over a garbage header */
    write_bytes(text_db, text, sizeof text - 1);
    write_bytes(corrupt_db, corrupt, sizeof corrupt);
    const char *paths[] = {text_db, corrupt_db};
    for (int i = 0; i < 2; i++) {
        const char *commands[] = {"status", "workers", "timings 1", "cancel 1", "worker --once"};
        for (size_t c = 0; c < sizeof commands / sizeof commands[0]; c++) {
            wt_format(args, sizeof args, "%s --db '%s'", commands[c], paths[i]);
            int code = wt_run(args, log_path);
            PF_CHECK_MSG(code == 2, "'%s' exited %d", args, code);
            PF_CHECK(wt_file_contains(log_path, paths[i]));
        }
        wt_format(args, sizeof args, "enqueue '%s' --frames 1 --out '%s/f.exr' --db '%s'", scene,
                 out_dir, paths[i]);
        int code = wt_run(args, log_path);
        PF_CHECK_MSG(code == 2, "'%s' exited %d", args, code);
    }
    PF_CHECK(file_equals(text_db, text, sizeof text - 1));
    PF_CHECK(file_equals(corrupt_db, corrupt, sizeof corrupt));
}

PF_TEST(control_commands_change_job_state)
{
    char args[8 * WT_PATH_MAX];
    wt_format(args, sizeof args, "enqueue '%s' --frames 1-2 --out '%s/c.####.exr' --db '%s'",
             scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    const struct {
        const char *command;
        const char *status;
    } steps[] = {{"pause", "paused"}, {"resume", "queued"}, {"cancel", "canceled"},
                 {"retry", "queued"}};
    for (size_t i = 0; i < sizeof steps / sizeof steps[0]; i++) {
        wt_format(args, sizeof args, "%s %lld --db '%s'", steps[i].command, (long long)job_id, db);
        PF_CHECK(wt_run(args, log_path) == 0);
        PF_CHECK(wt_file_contains(log_path, steps[i].status));
    }
    wt_format(args, sizeof args, "pause 9999 --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 2);
    /* priority: stored, and a bad value or job is exit 2 */
    wt_format(args, sizeof args, "priority %lld -3 --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(job.priority == -3, "priority %d", job.priority);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    wt_format(args, sizeof args, "priority %lld high --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    wt_format(args, sizeof args, "priority %lld 2000000 --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    wt_format(args, sizeof args, "priority 9999 1 --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 2);
    wt_format(args, sizeof args, "status --db '%s/absent.db'", dir);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "no queue database"));
}

/* Text anyone can enqueue reaches operators' terminals escaped, never as control codes. */
PF_TEST(status_escapes_control_characters)
{
    char args[8 * WT_PATH_MAX];
    /* ESC [2J clears the screen, ESC ]0;…BEL retitles it, CSI (U+009B) restyles. */
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/e.####.exr' --db '%s' "
              "--name 'evil\033[2J\033]0;pwned\007\302\2332m'",
              scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id >= 1);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    size_t size = 0;
    char *shown = wt_read_file(log_path, &size);
    PF_REQUIRE(shown != NULL);
    int controls = 0;
    for (size_t i = 0; i < size; i++) {
        unsigned char c = (unsigned char)shown[i];
        controls += (c < 0x20 && c != '\n') || c == 0x7f ||
                    (c == 0xc2 && i + 1 < size && (unsigned char)shown[i + 1] >= 0x80 &&
                     (unsigned char)shown[i + 1] <= 0x9f);
    }
    PF_CHECK_MSG(controls == 0, "%d control characters reached the terminal", controls);
    PF_CHECK(strstr(shown, "evil\\x1b[2J\\x1b]0;pwned\\x07\\u009b2m") != NULL);
    free(shown);
}

/* A misspelt --db is not a new, empty queue for a worker to wait on: refused unless asked. */
PF_TEST(worker_refuses_a_database_that_does_not_exist)
{
    char args[8 * WT_PATH_MAX], typo[WT_PATH_MAX + 32];
    wt_format(typo, sizeof typo, "%s/frm.db", dir);
    unlink(typo);
    wt_format(args, sizeof args, "worker --once --db '%s'", typo);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "no queue database"));
    PF_CHECK(access(typo, F_OK) != 0); /* nothing created */
    wt_format(args, sizeof args, "worker --once --create-db --db '%s'", typo);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(access(typo, F_OK) == 0);
}

/* A --db whose directory does not exist is bad input for every command: exit 2. */
PF_TEST(database_in_a_missing_directory_exits_2_everywhere)
{
    const char *const commands[] = {"status", "workers", "timings 1", "cancel 1", "pause 1",
                                    "resume 1", "retry 1", "worker --once"};
    char args[8 * WT_PATH_MAX];
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        wt_format(args, sizeof args, "%s --db '%s/no-such-directory/farm.db'", commands[i], dir);
        int code = wt_run(args, log_path);
        PF_CHECK_MSG(code == 2, "%s: exit %d", commands[i], code);
        PF_CHECK_MSG(wt_file_contains(log_path, "no-such-directory"), "%s", commands[i]);
    }
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s/m.####.exr' --db '%s/no-such-directory/farm.db'",
              scene, out_dir, dir);
    PF_CHECK(wt_run(args, log_path) == 2);
}

/* Two unfinished jobs must not write the same files: refused at enqueue unless --force. */
PF_TEST(jobs_writing_the_same_files_are_refused)
{
    char args[8 * WT_PATH_MAX];
    int64_t before = job_count();
    /* Frame 3 of f.####.exr belongs to the first test's job, still queued. */
    wt_format(args, sizeof args, "enqueue '%s' --frames 2-3 --out '%s/f.####.exr' --db '%s'",
              scene, out_dir, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "job 1"));
    PF_CHECK(wt_file_contains(log_path, "f.0002.exr"));
    PF_CHECK(wt_file_contains(log_path, "--force"));
    /* The same file named without #. */
    wt_format(args, sizeof args, "enqueue '%s' --frames 2 --out '%s/f.0002.exr' --db '%s'", scene,
              out_dir, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(job_count() == before);
    /* Other files, or --force: accepted. */
    wt_format(args, sizeof args, "enqueue '%s' --frames 2-3 --out '%s/g.####.exr' --db '%s'",
              scene, out_dir, db);
    PF_CHECK(enqueue_job(args) > 0);
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 2-3 --out '%s/f.####.exr' --db '%s' --force", scene, out_dir,
              db);
    PF_CHECK(enqueue_job(args) > 0);
    PF_CHECK(job_count() == before + 2);
    /* A finished (here canceled) job no longer holds its files. */
    wt_format(args, sizeof args, "enqueue '%s' --frames 1 --out '%s/h.####.exr' --db '%s'", scene,
              out_dir, db);
    int64_t first = enqueue_job(args);
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)first, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    wt_format(args, sizeof args, "enqueue '%s' --frames 1 --out '%s/h.####.exr' --db '%s'", scene,
              out_dir, db);
    PF_CHECK(enqueue_job(args) > 0);
}

/* Every subcommand: --help from its option table (exit 0, defaults shown), and
 * the same error and exit status for an unknown option. */
PF_TEST(every_subcommand_shares_help_errors_and_exit_codes)
{
    static const char *const commands[] = {"render", "enqueue", "worker",  "status",
                                           "timings", "cancel", "pause",   "resume",
                                           "retry",  "workers", "devices", "compare",
                                           "depend", "priority", "serve"};
    char args[256];
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        wt_format(args, sizeof args, "%s --help", commands[i]);
        PF_CHECK_MSG(wt_run(args, log_path) == 0, "%s --help", commands[i]);
        PF_CHECK(wt_file_contains(log_path, "usage: photonfarm "));
        PF_CHECK(wt_file_contains(log_path, "(default: "));
        PF_CHECK(wt_file_contains(log_path, "Exit status: 0 ok, 1 runtime failure, 2 bad usage"));
        wt_format(args, sizeof args, "%s --no-such-option", commands[i]);
        PF_CHECK_MSG(wt_run(args, log_path) == 2, "%s --no-such-option", commands[i]);
        PF_CHECK(wt_file_contains(log_path, "unknown option '--no-such-option' (see --help)"));
    }
}

/*
 * Enqueues racing for the same files: the check runs inside the insert's
 * transaction, so exactly one of them gets in and the others exit 2.
 */
PF_TEST(racing_enqueues_of_the_same_files_admit_exactly_one)
{
    enum { RACERS = 6 };
    char pattern[WT_PATH_MAX + 64], logs[RACERS][WT_PATH_MAX + 32];
    wt_format(pattern, sizeof pattern, "%s/race.####.exr", out_dir);
    int64_t before = job_count();
    pid_t pids[RACERS];
    for (int i = 0; i < RACERS; i++) {
        wt_format(logs[i], sizeof logs[i], "%s/race%d.log", dir, i);
        unlink(logs[i]);
        const char *args[] = {"enqueue", scene, "--frames", "1-2", "--out", pattern, "--db", db,
                              NULL};
        pids[i] = wt_spawn(args, logs[i], NULL);
    }
    int admitted = 0, refused = 0;
    for (int i = 0; i < RACERS; i++) {
        int code = wt_wait(pids[i], 60000);
        admitted += code == 0;
        refused += code == 2 && wt_file_contains(logs[i], "already writes");
    }
    PF_CHECK_MSG(admitted == 1 && refused == RACERS - 1, "%d admitted, %d refused", admitted,
                 refused);
    PF_CHECK(job_count() == before + 1);
}

/* cancel removes what its tasks' killed workers left behind, and nothing else. */
PF_TEST(cancel_removes_the_jobs_unfinished_frame_files)
{
    char args[8 * WT_PATH_MAX], path[2 * WT_PATH_MAX];
    wt_format(args, sizeof args, "enqueue '%s' --frames 1-2 --out '%s/k.####.exr' --db '%s'",
              scene, out_dir, db);
    int64_t job_id = enqueue_job(args);
    PF_REQUIRE(job_id > 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_task_info *tasks = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_task_list(queue, job_id, &tasks, &count, &err), &err);
    pf_queue_close(queue);
    PF_REQUIRE(count == 2);
    /* As a worker killed mid-frame leaves them (pf_frame_task_tag), and a stranger's. */
    const int64_t owners[] = {tasks[0].task_id, tasks[1].task_id, 999999};
    const int frames[] = {1, 2, 1};
    for (int i = 0; i < 3; i++) {
        wt_format(path, sizeof path, "%s/k.%04d.exr.partial-t%lld-deadlease", out_dir, frames[i],
                  (long long)owners[i]);
        FILE *file = fopen(path, "wb");
        PF_REQUIRE(file != NULL);
        fclose(file);
    }
    free(tasks);
    wt_format(args, sizeof args, "cancel %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "2 unfinished frame file(s) removed"));
    PF_CHECK(wt_count_files(out_dir, "k.0001.exr.partial-t999999-") == 1);
    PF_CHECK(wt_count_files(out_dir, "k.") == 1);
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(db, sizeof db, "%s/farm.db", dir);
    wt_format(scene, sizeof scene, "%s/tiny.gltf", dir);
    wt_format(log_path, sizeof log_path, "%s/run.log", dir);
    unlink(db);
    wt_fresh_dir("out", out_dir, sizeof out_dir);
    wt_write_tiny_scene(scene, 3);
    PF_RUN(enqueue_inserts_a_validated_job_and_prints_its_id);
    PF_RUN(requirements_are_stored_shown_and_warned_about);
    PF_RUN(dependencies_are_stored_shown_and_checked);
    PF_RUN(status_suggests_memory_requirements_after_memory_failures);
    PF_RUN(status_watch_reports_until_the_jobs_end);
    PF_RUN(bad_input_exits_2_and_inserts_nothing);
    PF_RUN(corrupt_or_foreign_database_exits_2_and_is_untouched);
    PF_RUN(control_commands_change_job_state);
    PF_RUN(status_escapes_control_characters);
    PF_RUN(database_in_a_missing_directory_exits_2_everywhere);
    PF_RUN(worker_refuses_a_database_that_does_not_exist);
    PF_RUN(jobs_writing_the_same_files_are_refused);
    PF_RUN(racing_enqueues_of_the_same_files_admit_exactly_one);
    PF_RUN(every_subcommand_shares_help_errors_and_exit_codes);
    PF_RUN(cancel_removes_the_jobs_unfinished_frame_files);
    return pf_test_finish();
}
