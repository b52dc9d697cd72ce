/*
 * One `photonfarm worker` at a time on tiny frames: a job rendered to EXRs
 * with one set of stage rows per task (the static scene's BIH built once,
 * then reused: skipped rows with their reason) and `timings` in every
 * format, decisions included; frames that fail on the worker (too large for
 * its memory: every attempt recorded, max attempts, the per-job blocklist
 * and its status note) and frames that fail for the job (a vanished scene,
 * an output path that cannot be committed: the job paused, nobody blamed);
 * SIGTERM while rendering (drain: the frame is done) and twice (released:
 * queued, no file); and a worker whose lease was taken over, which must not
 * touch the new owner's output.
 */
#include "pf_test.h"
#include "pf_image.h"
#include "worker_test_util.h"

#include <sys/stat.h>

#include <cjson/cJSON.h>
#include <signal.h>
#include <sqlite3.h>
#include <unistd.h>

#define WORKER_TIMEOUT_MS 60000
/* How long a held worker keeps its frame's temporary EXR before handing it
 * back (wt_fault_environment: fault_inject.c preloaded, no fault). */
#define HOLD_MS 4000

static char dir[WT_PATH_MAX], scene[WT_PATH_MAX + 32], log_path[WT_PATH_MAX + 32];

/* Enqueues; returns the job id (0 on failure). */
static int64_t enqueue(const char *db, const char *scene_path, const char *frames,
                       const char *pattern, const char *extra)
{
    char args[8 * WT_PATH_MAX];
    /* preview: these tests are about the worker and the queue, not an integrator's cost. */
    wt_format(args, sizeof args,
              "'%s' --frames %s --out '%s' --size 16x16 --quality preview --db '%s' %s",
              scene_path, frames, pattern, db, extra ? extra : "");
    return wt_enqueue(args, log_path);
}

static pf_queue_task_info first_task(const char *db, int64_t job_id)
{
    pf_queue_task_info info = {0};
    pf_queue *queue = wt_open_queue(db);
    pf_queue_task_info *tasks = NULL;
    size_t count = 0;
    pf_error err = {0};
    if (queue && pf_queue_task_list(queue, job_id, &tasks, &count, &err) == PF_OK && count > 0)
        info = tasks[0];
    free(tasks);
    pf_queue_close(queue);
    return info;
}

/* Polls until the job's first task is running (or timeout); 1 if it is. */
static int wait_running(const char *db, int64_t job_id, int timeout_ms)
{
    for (int waited = 0; waited < timeout_ms; waited += 50) {
        if (!strcmp(first_task(db, job_id).status, "running"))
            return 1;
        wt_sleep_ms(50);
    }
    return 0;
}

/*
 * The job's bih_build rows, frame by frame: one worker renders the static tiny
 * scene, so frame 1 builds the BIH and frames 2 and 3 (the second task too:
 * the renderer outlives tasks) reuse it, skipped with the reason stored.
 */
static void check_bih_decisions(const char *db_path, int64_t job_id)
{
    sqlite3 *db = NULL;
    sqlite3_stmt *statement = NULL;
    PF_REQUIRE(sqlite3_open_v2(db_path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK);
    int rc = sqlite3_prepare_v2(db,
                                "SELECT s.frame, s.skipped, s.reason, json_extract(s.counters, "
                                "'$.decision') FROM stage_timings s JOIN tasks t ON t.id = "
                                "s.task_id WHERE t.job_id = ? AND s.stage = 'bih_build' "
                                "ORDER BY s.frame",
                                -1, &statement, NULL);
    PF_CHECK_MSG(rc == SQLITE_OK, "%s", sqlite3_errmsg(db));
    if (rc == SQLITE_OK)
        sqlite3_bind_int64(statement, 1, job_id);
    int rows = 0;
    while (rc == SQLITE_OK && sqlite3_step(statement) == SQLITE_ROW) {
        int frame = sqlite3_column_int(statement, 0), skipped = sqlite3_column_int(statement, 1);
        const char *reason = (const char *)sqlite3_column_text(statement, 2);
        int decision = sqlite3_column_int(statement, 3);
        rows++;
        if (frame == 1)
            PF_CHECK_MSG(!skipped && decision == 3 && reason && !strcmp(reason, "built: first frame"),
                         "frame 1: skipped %d, decision %d, reason %s", skipped, decision,
                         reason ? reason : "NULL");
        else
            PF_CHECK_MSG(skipped && decision == 0 && reason &&
                             !strcmp(reason, "geometry unchanged → BIH reused"),
                         "frame %d: skipped %d, decision %d, reason %s", frame, skipped, decision,
                         reason ? reason : "NULL");
    }
    PF_CHECK_MSG(rows == 3, "%d bih_build rows", rows);
    sqlite3_finalize(statement);
    sqlite3_close(db);
}

/*
 * A budgeted `auto` job of two frames on one worker: the first frame's pilot renders build
 * the BIH and trace photons through the worker's renderer, but the stored rows of frame 1
 * claim no work from an earlier frame; frame 2 reuses the tree (issue 45).
 */
PF_TEST(a_budgeted_auto_job_stores_reuse_only_from_real_frames)
{
    char out[WT_PATH_MAX + 32], db_path[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        args[8 * WT_PATH_MAX];
    wt_fresh_dir("auto-out", out, sizeof out);
    wt_format(db_path, sizeof db_path, "%s/auto.db", dir);
    unlink(db_path);
    wt_format(pattern, sizeof pattern, "%s/a.####.exr", out);
    wt_format(args, sizeof args,
              "'%s' --frames 1-2 --out '%s' --size 16x16 --quality auto --budget-ms 500 "
              "--db '%s'",
              scene, pattern, db_path);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db_path);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    sqlite3 *db = NULL;
    sqlite3_stmt *statement = NULL;
    PF_REQUIRE(sqlite3_open_v2(db_path, &db, SQLITE_OPEN_READONLY, NULL) == SQLITE_OK);
    int rc = sqlite3_prepare_v2(db,
                                "SELECT s.frame, s.stage, s.reason FROM stage_timings s JOIN "
                                "tasks t ON t.id = s.task_id WHERE t.job_id = ? ORDER BY s.frame",
                                -1, &statement, NULL);
    PF_CHECK_MSG(rc == SQLITE_OK, "%s", sqlite3_errmsg(db));
    if (rc == SQLITE_OK)
        sqlite3_bind_int64(statement, 1, job_id);
    int rows[3] = {0, 0, 0}, calibrated = 0, reused_tree = 0;
    while (rc == SQLITE_OK && sqlite3_step(statement) == SQLITE_ROW) {
        int frame = sqlite3_column_int(statement, 0);
        const char *stage = (const char *)sqlite3_column_text(statement, 1);
        const char *reason = (const char *)sqlite3_column_text(statement, 2);
        reason = reason ? reason : "";
        if (frame < 1 || frame > 2)
            continue;
        rows[frame]++;
        if (frame == 1) {
            PF_CHECK_MSG(!strstr(reason, "reused") && !strstr(reason, "kept from") &&
                             !strstr(reason, "refit"),
                         "frame 1, %s: %s", stage, reason);
            calibrated |= !strcmp(stage, "plan") && strstr(reason, "pilot") != NULL;
        } else if (!strcmp(stage, "bih_build")) {
            reused_tree = !strcmp(reason, "geometry unchanged → BIH reused");
        }
    }
    PF_CHECK_MSG(rows[1] > 0 && rows[2] > 0, "rows: frame 1 %d, frame 2 %d", rows[1], rows[2]);
    PF_CHECK_MSG(calibrated, "frame 1 has no plan row from a pilot");
    PF_CHECK_MSG(reused_tree, "frame 2 did not reuse the tree");
    sqlite3_finalize(statement);
    sqlite3_close(db);
}

/*
 * A worker registers its capabilities (issue 42): the device's type and memory, the host's
 * memory and cores, and its tags, from --tag or $PHOTONFARM_WORKER_TAGS, sorted and
 * distinct; `workers` shows them. A bad tag is bad input (exit 2) naming it.
 */
PF_TEST(workers_show_the_capabilities_a_worker_registered)
{
    char db[WT_PATH_MAX + 32], args[4 * WT_PATH_MAX];
    wt_format(db, sizeof db, "%s/capabilities.db", dir);
    unlink(db);
    wt_format(args, sizeof args,
              "worker --once --create-db --db '%s' --name tagged --tag show-a --tag night,show-a",
              db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "tags=\"night,show-a\""));
    wt_format(args, sizeof args, "workers --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "night,show-a"));
    PF_CHECK(wt_file_contains(log_path, " cpu ")); /* lavapipe */
    PF_CHECK(wt_file_contains(log_path, "GiB"));   /* the host's memory, at least */
    wt_format(args, sizeof args,
              "worker --once --db '%s' --name bad --tag 'ok,no/slash'", db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "no/slash"));
}

PF_TEST(worker_renders_a_job_and_timings_report_every_stage)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX], args[8 * WT_PATH_MAX];
    wt_fresh_dir("render-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/render.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/f.####.exr", out);
    int64_t job_id = enqueue(db, scene, "1-3", pattern, "--frames-per-task 2");
    PF_REQUIRE(job_id > 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "event=completed"));

    for (int frame = 1; frame <= 3; frame++) {
        char path[3 * WT_PATH_MAX];
        wt_format(path, sizeof path, "%s/f.%04d.exr", out, frame);
        PF_CHECK_MSG(wt_exr_frame(path) == frame, "%s: wrong or missing frame", path);
    }
    PF_CHECK(wt_count_files(out, "") == 3);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK(!strcmp(job.status, "done") && job.frames_done == 3);
    pf_queue_job_clear(&job);
    pf_queue_task_info *tasks = NULL;
    size_t task_count = 0;
    PF_CHECK_OK(pf_queue_task_list(queue, job_id, &tasks, &task_count, &err), &err);
    pf_queue_close(queue);
    PF_CHECK(task_count == 2);
    for (size_t i = 0; i < task_count; i++) {
        const char *stages[] = {"scene_eval", "bih_build", "shade", "exr_write"};
        for (int s = 0; s < 4; s++)
            PF_CHECK_MSG(wt_stage_rows_for_task(db, tasks[i].task_id, stages[s]) ==
                             tasks[i].frame_count,
                         "task %lld stage %s", (long long)tasks[i].task_id, stages[s]);
    }
    free(tasks);

    /* Each attempt's log lines, stored by the worker (issue 41): frames 1-2 were one task,
     * the first, which loaded the scene; frame 3's task found it loaded. */
    wt_format(args, sizeof args, "log %lld 2 --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_in_file(log_path, "attempt 1 on ") == 1);
    PF_CHECK(wt_count_in_file(log_path, "event=claimed") == 1);
    PF_CHECK(wt_count_in_file(log_path, "event=scene_loaded") == 1);
    PF_CHECK(wt_count_in_file(log_path, "event=rendered") == 2);
    PF_CHECK(wt_file_contains(log_path, "frame=2 worker="));
    wt_format(args, sizeof args, "log %lld 3 --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_in_file(log_path, "event=scene_loaded") == 0);
    PF_CHECK(wt_count_in_file(log_path, "event=rendered job=") == 1);

    wt_format(args, sizeof args, "timings %lld --format csv --db '%s'", (long long)job_id, db);
    char csv_path[WT_PATH_MAX + 32];
    wt_format(csv_path, sizeof csv_path, "%s/timings.csv", dir);
    PF_REQUIRE(wt_run(args, csv_path) == 0);
    char *csv = wt_read_file(csv_path, NULL);
    PF_REQUIRE(csv != NULL);
    int rows = 0, header_columns = 0;
    for (char *line = strtok(csv, "\n"); line; line = strtok(NULL, "\n")) {
        int columns = 1;
        for (char *c = line; *c; c++)
            columns += *c == ',';
        if (!header_columns) {
            header_columns = columns;
            PF_CHECK(!strncmp(line, "stage,count,skipped", 19));
            continue;
        }
        PF_CHECK_MSG(columns == header_columns, "csv row '%s'", line);
        /* The tiny scene is static: bih_build ran for frame 1 and was skipped for 2 and 3. */
        if (!strncmp(line, "scene_eval,3,0,", 15) || !strncmp(line, "bih_build,1,2,", 14) ||
            !strncmp(line, "shade,3,0,", 10) || !strncmp(line, "exr_write,3,0,", 14))
            rows++;
    }
    free(csv);
    PF_CHECK_MSG(rows == 4, "%d of 4 stage rows with the expected counts in the CSV", rows);
    check_bih_decisions(db, job_id);

    wt_format(args, sizeof args, "timings %lld --format json --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, csv_path) == 0);
    char *json = wt_read_file(csv_path, NULL);
    cJSON *root = cJSON_Parse(json);
    free(json);
    PF_REQUIRE(root != NULL);
    const cJSON *stages = cJSON_GetObjectItem(root, "stages");
    int found = 0;
    const cJSON *stage;
    cJSON_ArrayForEach(stage, stages)
    {
        const cJSON *name = cJSON_GetObjectItem(stage, "stage");
        const cJSON *count = cJSON_GetObjectItem(stage, "count");
        const cJSON *skipped = cJSON_GetObjectItem(stage, "skipped");
        const cJSON *wall = cJSON_GetObjectItem(stage, "wall");
        int reused = cJSON_IsString(name) && !strcmp(name->valuestring, "bih_build");
        if (cJSON_IsString(name) && cJSON_IsNumber(count) && cJSON_IsNumber(skipped) &&
            count->valueint == (reused ? 1 : 3) && skipped->valueint == (reused ? 2 : 0) &&
            cJSON_IsObject(wall) && cJSON_GetObjectItem(wall, "p95_ms"))
            found++;
    }
    /* scene_eval, bih_build, shade, motion and exr_write. */
    PF_CHECK_MSG(found == 5, "%d stages with the expected counts in the JSON", found);
    PF_CHECK(cJSON_GetArraySize(cJSON_GetObjectItem(root, "slowest_frames")) == 3);
    /* Every frame's resources (issue 42): its peak memory and the bytes it wrote. */
    const cJSON *per_frame = cJSON_GetObjectItem(root, "per_frame_bytes");
    const char *const resources[] = {"peak_rss", "peak_device_memory", "bytes_written"};
    for (int r = 0; r < 3; r++) {
        const cJSON *stat = cJSON_GetObjectItem(per_frame, resources[r]);
        PF_CHECK_MSG(cJSON_GetNumberValue(cJSON_GetObjectItem(stat, "frames")) == 3 &&
                         cJSON_GetNumberValue(cJSON_GetObjectItem(stat, "min")) > 0,
                     "%s: %g frames, min %g", resources[r],
                     cJSON_GetNumberValue(cJSON_GetObjectItem(stat, "frames")),
                     cJSON_GetNumberValue(cJSON_GetObjectItem(stat, "min")));
    }
    /* The decisions the rows record: bih_build built once, reused twice; shade's samples 3 times;
     * textures and deform skipped 3 times (the tiny scene has neither); motion found no pixel
     * moving 3 times. */
    int built = 0, reused = 0, shaded = 0, untextured = 0, undeformed = 0, still = 0;
    int decision_rows = 0;
    const cJSON *decision;
    cJSON_ArrayForEach(decision, cJSON_GetObjectItem(root, "decisions"))
    {
        const char *stage_name = cJSON_GetStringValue(cJSON_GetObjectItem(decision, "stage"));
        const char *what = cJSON_GetStringValue(cJSON_GetObjectItem(decision, "decision"));
        const cJSON *count = cJSON_GetObjectItem(decision, "count");
        decision_rows++;
        if (!stage_name || !what || !cJSON_IsNumber(count))
            continue;
        if (!strcmp(stage_name, "shade"))
            shaded += !strcmp(what, "camera samples") ? count->valueint : 0;
        if (!strcmp(stage_name, "textures"))
            untextured += !strcmp(what, "no textures") ? count->valueint : 0;
        if (!strcmp(stage_name, "deform"))
            undeformed += !strcmp(what, "no skins or morph targets") ? count->valueint : 0;
        /* A static shot: no pixel moves. */
        if (!strcmp(stage_name, "motion"))
            still += strstr(what, "; 0 of ") ? count->valueint : 0;
        if (strcmp(stage_name, "bih_build"))
            continue;
        built += !strcmp(what, "built") ? count->valueint : 0;
        reused += !strcmp(what, "geometry unchanged → BIH reused") ? count->valueint : 0;
    }
    PF_CHECK_MSG(built == 1 && reused == 2 && shaded == 3 && untextured == 3 &&
                     undeformed == 3 && still == 3 && decision_rows == 6,
                 "decisions: %d built, %d reused, %d shaded, %d untextured, %d undeformed, "
                 "%d still in %d rows",
                 built, reused, shaded, untextured, undeformed, still, decision_rows);
    /* Every frame's rows carry the build that rendered them: `photonfarm version`'s. */
    char version_path[WT_PATH_MAX + 32];
    wt_format(version_path, sizeof version_path, "%s/version.txt", dir);
    PF_REQUIRE(wt_run("version", version_path) == 0);
    char *version_text = wt_read_file(version_path, NULL);
    PF_REQUIRE(version_text && !strncmp(version_text, "photonfarm ", 11));
    version_text[strcspn(version_text, "\n")] = '\0';
    const char *version = version_text + 11;
    const cJSON *builds = cJSON_GetObjectItem(root, "builds");
    const cJSON *first_build = cJSON_GetArrayItem(builds, 0);
    const char *build = cJSON_GetStringValue(cJSON_GetObjectItem(first_build, "build"));
    PF_CHECK_MSG(cJSON_GetArraySize(builds) == 1 && build && !strcmp(build, version) &&
                     cJSON_GetNumberValue(cJSON_GetObjectItem(first_build, "frames")) == 3,
                 "builds in the timings: expected 3 frames of %s, got %s", version,
                 build ? build : "none");
    free(version_text);
    cJSON_Delete(root);

    wt_format(args, sizeof args, "timings %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "slowest frames"));
    PF_CHECK(wt_file_contains(log_path, "geometry unchanged → BIH reused"));
    PF_CHECK(wt_file_contains(log_path, "peak rss"));

    /* --frames: each frame with its worker, attempt, stages, peaks and decisions. */
    wt_format(args, sizeof args, "timings %lld --frames --format json --db '%s'",
              (long long)job_id, db);
    PF_REQUIRE(wt_run(args, csv_path) == 0);
    json = wt_read_file(csv_path, NULL);
    root = cJSON_Parse(json);
    free(json);
    PF_REQUIRE(root != NULL);
    const cJSON *frames = cJSON_GetObjectItem(root, "frames");
    PF_CHECK(cJSON_GetArraySize(frames) == 3);
    int listed = 0;
    const cJSON *frame;
    cJSON_ArrayForEach(frame, frames)
    {
        const char *worker = cJSON_GetStringValue(cJSON_GetObjectItem(frame, "worker"));
        const cJSON *frame_stages = cJSON_GetObjectItem(frame, "stages");
        const cJSON *bih = NULL, *item;
        cJSON_ArrayForEach(item, frame_stages)
            if (!strcmp(cJSON_GetStringValue(cJSON_GetObjectItem(item, "stage")), "bih_build"))
                bih = item;
        const char *bih_decision = cJSON_GetStringValue(cJSON_GetObjectItem(bih, "decision"));
        int number = (int)cJSON_GetNumberValue(cJSON_GetObjectItem(frame, "frame"));
        PF_CHECK_MSG(worker && worker[0] &&
                         cJSON_GetNumberValue(cJSON_GetObjectItem(frame, "attempt")) == 1 &&
                         cJSON_GetArraySize(frame_stages) >= 4 &&
                         cJSON_GetNumberValue(cJSON_GetObjectItem(frame, "peak_rss_bytes")) > 0 &&
                         cJSON_GetNumberValue(cJSON_GetObjectItem(frame, "peak_device_bytes")) >
                             0 &&
                         cJSON_GetNumberValue(cJSON_GetObjectItem(frame, "bytes_written")) > 0 &&
                         bih_decision && !strcmp(bih_decision, number == 1 ? "built"
                                                                   : "geometry unchanged → BIH "
                                                                     "reused"),
                     "frame %d", number);
        listed += number == listed + 1;
    }
    PF_CHECK(listed == 3);
    cJSON_Delete(root);
    wt_format(args, sizeof args, "timings %lld --frames --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "bih_build=built"));
    PF_CHECK(wt_file_contains(log_path, "3 frame(s)"));
}

/* The peak memory a frame records (issue 42) grows with the frame: a 320x320 frame's is
 * above a 16x16 frame's, on the device and in the worker's resident memory. fast, whose
 * film lives on the device whole (preview renders through one 64x64 tile whatever the
 * size). The small job has two frames, the first warming up what every frame shares
 * (pipelines, the scene). */
PF_TEST(a_larger_frame_records_more_peak_memory)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        args[8 * WT_PATH_MAX];
    wt_fresh_dir("peaks-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/peaks.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/small.####.exr", out);
    int64_t small =
        enqueue(db, scene, "1-2", pattern, "--priority 1 --quality fast --photons 1000 --spp 1");
    wt_format(pattern, sizeof pattern, "%s/large.####.exr", out);
    int64_t large =
        enqueue(db, scene, "1", pattern, "--size 320x320 --quality fast --photons 1000 --spp 1");
    PF_REQUIRE(small > 0 && large > 0);
    wt_format(args, sizeof args, "worker --once --max-frames 3 --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_frame_details details[2];
    pf_error err = {0};
    PF_REQUIRE_OK(pf_queue_frame_details_get(queue, small, &details[0], &err), &err);
    PF_REQUIRE_OK(pf_queue_frame_details_get(queue, large, &details[1], &err), &err);
    pf_queue_close(queue);
    PF_REQUIRE(details[0].frame_count == 2 && details[1].frame_count == 1);
    const pf_queue_frame_detail *a = &details[0].frames[1], *b = &details[1].frames[0];
    printf("  peak rss %lld -> %lld bytes, device %lld -> %lld, written %lld -> %lld\n",
           (long long)a->peak_rss, (long long)b->peak_rss, (long long)a->peak_device_memory,
           (long long)b->peak_device_memory, (long long)a->bytes_written,
           (long long)b->bytes_written);
    PF_CHECK(a->peak_rss > 0 && b->peak_rss > a->peak_rss);
    PF_CHECK(a->peak_device_memory > 0 && b->peak_device_memory > a->peak_device_memory);
    PF_CHECK(a->bytes_written > 0 && b->bytes_written > a->bytes_written);
    pf_queue_frame_details_free(&details[0]);
    pf_queue_frame_details_free(&details[1]);
}

/*
 * A failure of the worker's own: a frame too large for this machine's memory
 * (pf_frame_memory_check refuses it before anything renders; another worker
 * with more memory could render it). NULL when this machine has the memory
 * for the largest size enqueue accepts: the tests that need such a failure
 * say so and skip.
 */
static const char *worker_fault_size(void)
{
    double half_memory = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGESIZE) / 2.0;
    if (16384.0 * 16384.0 * 88.0 <= half_memory) {
        printf("skipped: %.0f GiB of memory fits a 16384x16384 frame; no worker fault to "
               "provoke\n", 2.0 * half_memory / (1u << 30));
        return NULL;
    }
    return "--size 16384x16384";
}

PF_TEST(failing_frames_record_each_attempt_and_stop_at_max_attempts)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        args[8 * WT_PATH_MAX], extra[64];
    const char *size = worker_fault_size();
    if (!size)
        return;
    wt_fresh_dir("fail-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/fail.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/d.####.exr", out);
    wt_format(extra, sizeof extra, "--max-attempts 2 %s", size);
    int64_t job_id = enqueue(db, scene, "1-2", pattern, extra);
    PF_REQUIRE(job_id > 0);
    /* Attempt 2 becomes eligible after the queue's 2 s backoff. */
    wt_format(args, sizeof args, "worker --idle-exit 3 --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "event=failed"));

    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    PF_CHECK_MSG(count == 4, "%zu failures, expected 2 frames x 2 attempts", count);
    for (size_t i = 0; i < count; i++)
        PF_CHECK_MSG(strstr(failures[i].error, "16384x16384") != NULL && !failures[i].job_fault,
                     "error: %s", failures[i].error);
    free(failures);
    pf_queue_job job = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(!strcmp(job.status, "failed") && job.tasks_failed == 2, "job %s, %lld failed",
                 job.status, (long long)job.tasks_failed);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    PF_CHECK(wt_count_files(out, "") == 0);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "failed"));
    PF_CHECK(wt_file_contains(log_path, "failures (4)"));
    PF_CHECK(wt_file_contains(log_path, "16384x16384"));
    /* Both attempts at frame 1 stored their lines, the failure among them (issue 41). */
    wt_format(args, sizeof args, "log %lld 1 --format json --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_in_file(log_path, "\"attempt\":\t1") == 1);
    PF_CHECK(wt_count_in_file(log_path, "\"attempt\":\t2") == 1);
    PF_CHECK(wt_count_in_file(log_path, "event=render_failed") == 2);
}

PF_TEST(a_worker_failing_a_jobs_frames_is_blocked_and_status_says_so)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        args[8 * WT_PATH_MAX], worker_log[WT_PATH_MAX + 32], extra[64];
    const char *size = worker_fault_size();
    if (!size)
        return;
    wt_fresh_dir("block-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/block.db", dir);
    wt_format(worker_log, sizeof worker_log, "%s/block-worker.log", dir);
    unlink(db);
    unlink(worker_log);
    wt_format(pattern, sizeof pattern, "%s/b.####.exr", out);
    wt_format(extra, sizeof extra, "--max-attempts 5 %s", size);
    int64_t job_id = enqueue(db, scene, "1-3", pattern, extra);
    PF_REQUIRE(job_id > 0);
    const char *worker_args[] = {"worker", "--idle-exit", "3", "--db", db, NULL};
    pid_t pid = wt_spawn(worker_args, worker_log, NULL);
    int blocked = 0;
    for (int waited = 0; waited < 20000 && !blocked; waited += 100) {
        wt_sleep_ms(100);
        pf_queue *queue = wt_open_queue(db);
        pf_queue_job job = {0};
        pf_error err = {0};
        if (queue && pf_queue_job_get(queue, job_id, &job, &err) == PF_OK)
            blocked = job.note[0] != '\0';
        pf_queue_job_clear(&job);
        pf_queue_close(queue);
    }
    PF_CHECK_MSG(blocked, "the job never reported that no worker is eligible");
    wt_format(args, sizeof args, "status --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "no eligible worker"));
    PF_CHECK(wt_wait(pid, WORKER_TIMEOUT_MS) == 0);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    PF_CHECK_MSG(count == 3, "%zu failures: blocked after 3 distinct frames", count);
    free(failures);
    pf_queue_close(queue);
}

/*
 * A scene that vanished after enqueue is the job's fault, not the worker's:
 * the job pauses with the scene named in `status`, the failure is recorded
 * without counting an attempt and no worker is blocked; once the scene is
 * back, `resume` and the same worker finish the job (max attempts 1).
 */
PF_TEST(a_vanished_scene_pauses_its_job_and_blames_no_worker)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], doomed[WT_PATH_MAX + 32],
        pattern[2 * WT_PATH_MAX], args[8 * WT_PATH_MAX];
    wt_fresh_dir("vanish-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/vanish.db", dir);
    wt_format(doomed, sizeof doomed, "%s/vanishing.gltf", dir);
    unlink(db);
    wt_write_tiny_scene(doomed, 3);
    wt_format(pattern, sizeof pattern, "%s/v.####.exr", out);
    int64_t job_id = enqueue(db, doomed, "1-3", pattern, "--max-attempts 1");
    PF_REQUIRE(job_id > 0);
    unlink(doomed);
    wt_format(args, sizeof args, "worker --idle-exit 1 --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "event=job_fault"));
    PF_CHECK(wt_file_contains(log_path, "fault=scene"));
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(!strcmp(job.status, "paused") && job.tasks_queued == 3 &&
                     job.blocked_live_workers == 0,
                 "job %s, %lld queued", job.status, (long long)job.tasks_queued);
    PF_CHECK_MSG(strstr(job.note, "paused: scene: ") && strstr(job.note, "vanishing.gltf"),
                 "note: %s", job.note);
    pf_queue_job_clear(&job);
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    PF_CHECK_MSG(count == 1 && failures[0].job_fault, "%zu failures", count);
    free(failures);
    pf_queue_close(queue);

    wt_write_tiny_scene(doomed, 3);
    wt_format(args, sizeof args, "resume %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_files(out, ".exr") == 3);
    PF_CHECK(!strcmp(first_task(db, job_id).status, "done"));
}

/*
 * A scene whose material library lies outside its directory: enqueue refuses
 * it (exit 2, naming the reference and the option that permits it) unless
 * --allow-outside-scene-dir, which the job carries to the worker.
 */
PF_TEST(a_scene_reaching_outside_its_directory_renders_only_when_the_job_allows_it)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], sub[WT_PATH_MAX + 32],
        obj[WT_PATH_MAX + 64], mtl[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        args[8 * WT_PATH_MAX];
    wt_fresh_dir("outside-out", out, sizeof out);
    wt_fresh_dir("outside-scene", sub, sizeof sub);
    wt_format(db, sizeof db, "%s/outside.db", dir);
    wt_format(obj, sizeof obj, "%s/tri.obj", sub);
    wt_format(mtl, sizeof mtl, "%s/outside.mtl", dir);
    wt_format(pattern, sizeof pattern, "%s/o.####.exr", out);
    unlink(db);
    FILE *file = fopen(mtl, "w");
    PF_REQUIRE(file != NULL);
    fputs("newmtl red\nKd 1 0 0\n", file);
    fclose(file);
    file = fopen(obj, "w");
    PF_REQUIRE(file != NULL);
    fputs("mtllib ../outside.mtl\nv -1 -1 -3\nv 1 -1 -3\nv 0 1 -3\nusemtl red\nf 1 2 3\n", file);
    fclose(file);
    wt_format(args, sizeof args,
              "enqueue '%s' --frames 1 --out '%s' --size 16x16 --quality preview --db '%s'", obj,
              pattern, db);
    PF_CHECK(wt_run(args, log_path) == 2);
    PF_CHECK(wt_file_contains(log_path, "../outside.mtl"));
    PF_CHECK(wt_file_contains(log_path, "--allow-outside-scene-dir"));
    int64_t job_id = enqueue(db, obj, "1", pattern, "--allow-outside-scene-dir");
    PF_REQUIRE(job_id > 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    /* A container names its worker by the environment. */
    setenv("PHOTONFARM_WORKER_NAME", "named-by-env", 1);
    PF_CHECK(wt_run(args, log_path) == 0);
    unsetenv("PHOTONFARM_WORKER_NAME");
    PF_CHECK(wt_file_contains(log_path, "worker=named-by-env"));
    PF_CHECK(!strcmp(first_task(db, job_id).status, "done"));
    PF_CHECK(wt_count_files(out, ".exr") == 1);
    /* Core's own warning (an OBJ has no camera) reaches the worker's log in its format. */
    PF_CHECK(wt_file_contains(log_path, "level=warn event=core message=\""));
    PF_CHECK(wt_file_contains(log_path, "no camera"));
}

/* Starts a held worker on a one-frame job, signals it (once or twice) mid-frame. */
static void signal_mid_frame(int signal_count)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        worker_log[WT_PATH_MAX + 32], path[3 * WT_PATH_MAX];
    wt_fresh_dir(signal_count == 1 ? "sigterm-out" : "sigterm2-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/sigterm%d.db", dir, signal_count);
    wt_format(worker_log, sizeof worker_log, "%s/sigterm%d.log", dir, signal_count);
    unlink(db);
    unlink(worker_log);
    wt_format(pattern, sizeof pattern, "%s/s.####.exr", out);
    wt_format(path, sizeof path, "%s/s.0001.exr", out);
    int64_t job_id = enqueue(db, scene, "1", pattern, NULL);
    PF_REQUIRE(job_id > 0);
    const char *worker_args[] = {"worker", "--name", "held", "--db", db, NULL};
    char env[8 * WT_PATH_MAX];
    wt_fault_environment(env, sizeof env, out, NULL, NULL, HOLD_MS);
    pid_t pid = wt_spawn(worker_args, worker_log, env);
    PF_REQUIRE(wait_running(db, job_id, 20000));
    char check[8 * WT_PATH_MAX];
    wt_format(check, sizeof check, "workers --check held --db '%s'", db);
    /* The container HEALTHCHECK's question: alive while it renders. */
    PF_CHECK(wt_run(check, log_path) == 0 && wt_file_contains(log_path, "held alive"));
    if (signal_count == 1) {
        /* While it renders, status and workers show who has which frame. */
        char args[8 * WT_PATH_MAX];
        wt_format(args, sizeof args, "status --db '%s'", db);
        PF_CHECK(wt_run(args, log_path) == 0);
        PF_CHECK(wt_file_contains(log_path, "running: frame 1 on "));
        wt_format(args, sizeof args, "workers --db '%s'", db);
        PF_CHECK(wt_run(args, log_path) == 0);
        PF_CHECK(wt_file_contains(log_path, "alive"));
        PF_CHECK(wt_file_contains(log_path, "frame 1"));
    }
    wt_sleep_ms(300);
    for (int i = 0; i < signal_count; i++) {
        kill(pid, SIGTERM);
        wt_sleep_ms(100);
    }
    int code = wt_wait(pid, WORKER_TIMEOUT_MS);
    PF_CHECK_MSG(code == 0, "worker exited %d after SIGTERM x%d", code, signal_count);
    pf_queue_task_info task = first_task(db, job_id);
    int done = !strcmp(task.status, "done") && wt_exr_frame(path) == 1;
    int released = !strcmp(task.status, "queued") && wt_count_files(out, "") == 0;
    PF_CHECK_MSG(done || released, "task %s with %d file(s) in the output", task.status,
                 wt_count_files(out, ""));
    /* One signal drains (the frame finishes); two release it. */
    PF_CHECK(signal_count == 1 ? done : released);
    PF_CHECK(wt_count_files(out, "partial") == 0);
    PF_CHECK(wt_file_contains(worker_log, signal_count == 1 ? "event=draining" : "event=released"));
    /* Gone: stopped, and a name nobody registered is not healthy either. */
    PF_CHECK(wt_run(check, log_path) == 1 && wt_file_contains(log_path, "held stopped"));
    wt_format(check, sizeof check, "workers --check nobody --db '%s'", db);
    PF_CHECK(wt_run(check, log_path) == 1 && wt_file_contains(log_path, "nobody unknown"));
}

PF_TEST(sigterm_drains_the_current_frame)
{
    signal_mid_frame(1);
}

PF_TEST(a_second_sigterm_releases_the_frame)
{
    signal_mid_frame(2);
}

static int64_t fixed_clock(void *user)
{
    return *(const int64_t *)user;
}

/*
 * An hour later by the queue's clock (kept in *later), the running task's
 * lease has expired: reaps it and claims the frame as a new owner. Returns
 * the open queue with the new owner's task in *task; NULL if it was not
 * claimed.
 */
static pf_queue *take_over_lease(const char *db, int64_t *later, pf_queue_task *task)
{
    pf_queue *queue = wt_open_queue(db);
    if (!queue)
        return NULL;
    *later = pf_queue_now(queue) + 3600 * 1000;
    pf_queue_set_clock(queue, fixed_clock, later);
    pf_error err = {0};
    int64_t reaped = 0;
    PF_CHECK_OK(pf_queue_reap(queue, &reaped, &err), &err);
    PF_CHECK(reaped == 1);
    *later += 60 * 1000; /* past the failure backoff */
    pf_queue_worker_spec thief = {"new-owner", "test", 1, "none"};
    int64_t thief_id = 0;
    PF_CHECK_OK(pf_queue_worker_register(queue, &thief, &thief_id, &err), &err);
    bool claimed = false;
    PF_CHECK_OK(pf_queue_claim(queue, thief_id, 0, 0, task, &claimed, &err), &err);
    if (!claimed) {
        pf_queue_close(queue);
        return NULL;
    }
    return queue;
}

PF_TEST(a_worker_whose_lease_was_taken_over_never_writes)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        worker_log[WT_PATH_MAX + 32], path[3 * WT_PATH_MAX];
    wt_fresh_dir("lease-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/lease.db", dir);
    wt_format(worker_log, sizeof worker_log, "%s/lease.log", dir);
    unlink(db);
    unlink(worker_log);
    wt_format(pattern, sizeof pattern, "%s/l.####.exr", out);
    wt_format(path, sizeof path, "%s/l.0001.exr", out);
    int64_t job_id = enqueue(db, scene, "1", pattern, NULL);
    PF_REQUIRE(job_id > 0);
    const char *worker_args[] = {"worker", "--once", "--lease-seconds", "3", "--db", db, NULL};
    char env[8 * WT_PATH_MAX];
    wt_fault_environment(env, sizeof env, out, NULL, NULL, HOLD_MS);
    pid_t pid = wt_spawn(worker_args, worker_log, env);
    PF_REQUIRE(wait_running(db, job_id, 20000));

    /* The new owner writes its own output. */
    int64_t later = 0;
    pf_queue_task task = {0};
    pf_queue *queue = take_over_lease(db, &later, &task);
    PF_REQUIRE(queue != NULL);
    pf_error err = {0};
    const char marker[] = "the new owner's output";
    FILE *file = fopen(path, "wb");
    PF_REQUIRE(file != NULL);
    fputs(marker, file);
    fclose(file);
    PF_CHECK_OK(pf_queue_complete(queue, task.lease_token, NULL, 0, NULL, &err), &err);
    pf_queue_close(queue);

    int code = wt_wait(pid, WORKER_TIMEOUT_MS);
    PF_CHECK_MSG(code == 0, "worker exited %d", code);
    PF_CHECK(wt_file_contains(worker_log, "event=lease_lost"));
    char *content = wt_read_file(path, NULL);
    PF_CHECK_MSG(content && !strcmp(content, marker), "the new owner's output was overwritten");
    free(content);
    PF_CHECK(wt_count_files(out, "") == 1);
    PF_CHECK(wt_stage_rows_for_task(db, task.task_id, "shade") == 0);
}

/*
 * A frame that renders but cannot be committed (here a directory sits at its
 * path, so the rename is refused) is settled at once, not left `running` on
 * a live worker until its lease (300 s here) expires; the refusal is the
 * output's, so the job pauses with the cause and the worker exits 0. With
 * the obstacle gone, `resume` finishes it.
 */
/*
 * The lease lapses while the worker is inside the commit's rename, after the
 * renewal that precedes it (a rename slower than what was left of the
 * lease): the queue refuses the completion. That is a lost lease, not a
 * failure of the worker: it says so, records nothing for the task, gives
 * nothing back, and exits 0; the task stays with its new owner.
 */
PF_TEST(a_lease_lost_inside_the_commit_is_left_to_the_new_owner)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        worker_log[WT_PATH_MAX + 32], mark[WT_PATH_MAX + 32];
    wt_fresh_dir("lapse-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/lapse.db", dir);
    wt_format(worker_log, sizeof worker_log, "%s/lapse.log", dir);
    wt_format(mark, sizeof mark, "%s/lapse.held", dir);
    unlink(db);
    unlink(worker_log);
    unlink(mark);
    wt_format(pattern, sizeof pattern, "%s/c.####.exr", out);
    int64_t job_id = enqueue(db, scene, "1", pattern, NULL);
    PF_REQUIRE(job_id > 0);
    const char *worker_args[] = {"worker", "--once", "--lease-seconds", "3", "--db", db, NULL};
    char env[8 * WT_PATH_MAX], faults[7 * WT_PATH_MAX];
    wt_fault_environment(faults, sizeof faults, out, NULL, NULL, HOLD_MS);
    wt_format(env, sizeof env, "%s\nPF_FAULT_HELD_MARK=%s", faults, mark);
    pid_t pid = wt_spawn(worker_args, worker_log, env);
    int held = 0;
    for (int waited = 0; waited < WORKER_TIMEOUT_MS && !held; waited += 20) {
        held = access(mark, F_OK) == 0;
        if (!held)
            usleep(20 * 1000);
    }
    PF_REQUIRE(held);

    /* Inside the rename. */
    int64_t later = 0;
    pf_queue_task task = {0};
    pf_queue *queue = take_over_lease(db, &later, &task);
    PF_REQUIRE(queue != NULL);
    pf_error err = {0};

    int code = wt_wait(pid, WORKER_TIMEOUT_MS);
    PF_CHECK_MSG(code == 0, "worker exited %d", code);
    PF_CHECK(wt_file_contains(worker_log, "event=lease_lost"));
    PF_CHECK(wt_file_contains(worker_log, "action=left_to_new_owner"));
    PF_CHECK(!wt_file_contains(worker_log, "event=db_error"));
    /* Nothing recorded for the task by the old owner, and it is still the new owner's. */
    PF_CHECK(wt_stage_rows_for_task(db, task.task_id, "shade") == 0);
    PF_CHECK_OK(pf_queue_heartbeat(queue, task.lease_token, NULL, &err), &err);
    PF_CHECK_OK(pf_queue_complete(queue, task.lease_token, NULL, 0, NULL, &err), &err);
    pf_queue_close(queue);
}

PF_TEST(a_frame_that_cannot_be_committed_pauses_its_job_at_once)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], blocker[2 * WT_PATH_MAX],
        pattern[2 * WT_PATH_MAX], args[8 * WT_PATH_MAX];
    wt_fresh_dir("commit-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/commit.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/c.####.exr", out);
    int64_t job_id = enqueue(db, scene, "1", pattern, "--max-attempts 1");
    PF_REQUIRE(job_id > 0);
    wt_format(blocker, sizeof blocker, "%s/c.0001.exr", out);
    rmdir(blocker); /* an earlier run's (wt_fresh_dir empties files, not folders) */
    PF_REQUIRE(mkdir(blocker, 0777) == 0);
    wt_format(args, sizeof args, "worker --once --lease-seconds 300 --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "event=job_fault"));
    PF_CHECK(wt_file_contains(log_path, "fault=output"));
    pf_queue_task_info task = first_task(db, job_id);
    PF_CHECK_MSG(!strcmp(task.status, "queued"), "task %s, not settled at once", task.status);
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_failure *failures = NULL;
    size_t count = 0;
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_failure_list(queue, job_id, &failures, &count, &err), &err);
    PF_CHECK_MSG(count == 1 && failures[0].job_fault &&
                     strstr(failures[0].error, "committing the frame") &&
                     strstr(failures[0].error, "c.0001.exr"),
                 "%zu failures: %s", count, count ? failures[0].error : "");
    free(failures);
    pf_queue_job job = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(!strcmp(job.status, "paused"), "job %s", job.status);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    PF_CHECK(wt_count_files(out, "partial") == 0);

    PF_REQUIRE(rmdir(blocker) == 0);
    wt_format(args, sizeof args, "resume %lld --db '%s'", (long long)job_id, db);
    PF_CHECK(wt_run(args, log_path) == 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_CHECK(wt_run(args, log_path) == 0);
    PF_CHECK(!strcmp(first_task(db, job_id).status, "done"));
}

/* scenes/character/character.gltf: the skinned and morphed scene Blender exported (issue 39). */
static const char *character_scene(char *out, size_t size)
{
    const char *source = getenv("PF_SOURCE_DIR");
    wt_format(out, size, "%s/scenes/character/character.gltf", source ? source : ".");
    return out;
}

/*
 * Issue 39: `render --frames` on the Blender-exported character bends the arm and bulges
 * the sheet every frame: each frame has a deform row naming what it deformed, and the tree
 * is refit (or rebuilt when the refit loses its SAH), never reused, after the first frame.
 * A jump from the rest pose to the arm bent 80° (frames 1, 24) shows the SAH check.
 */
PF_TEST(render_frames_deforms_a_blender_character_and_refits_its_tree)
{
    char character[WT_PATH_MAX + 64], args[4 * WT_PATH_MAX];
    character_scene(character, sizeof character);
    wt_format(args, sizeof args,
              "render '%s' --frames 1-3,24 --size 16x16 --quality preview --timings "
              "-o '%s/character.####.exr'",
              character, dir);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_in_file(log_path, "1 skinned mesh, 1 morphed, ") == 4);
    PF_CHECK(wt_count_in_file(log_path, "skinned_meshes=1 morphed_meshes=1") == 4);
    PF_CHECK(wt_count_in_file(log_path, "built: first frame") == 1);
    int refit = wt_count_in_file(log_path, "refit: SAH");
    int rebuilt = wt_count_in_file(log_path, "rebuilt: refit SAH");
    PF_CHECK_MSG(refit + rebuilt == 3, "%d refit, %d rebuilt of 3 frames", refit, rebuilt);
    PF_CHECK(wt_count_in_file(log_path, "BIH reused") == 0);
    /* Consecutive frames move the arm a few degrees: the refit tree holds. */
    PF_CHECK_MSG(refit >= 2, "%d refit", refit);
    for (int frame = 1; frame <= 3; frame++) {
        char path[2 * WT_PATH_MAX];
        wt_format(path, sizeof path, "%s/character.%04d.exr", dir, frame);
        PF_CHECK_MSG(wt_exr_frame(path) == frame, "%s: wrong or missing frame", path);
    }
}

/* Whether the stored parameters of job_id hold text: 1 or 0, -1 (after a failed check) when
 * the job cannot be read. */
static int job_parameters_hold(const char *db, int64_t job_id, const char *text)
{
    pf_queue *queue = wt_open_queue(db);
    pf_queue_job job = {0};
    pf_error err = {0};
    int held = -1;
    if (queue && pf_queue_job_get(queue, job_id, &job, &err) == PF_OK && job.parameters_json) {
        held = strstr(job.parameters_json, text) != NULL;
    } else {
        PF_CHECK_MSG(0, "job %lld: %s", (long long)job_id, queue ? err.message : "no queue");
    }
    pf_queue_job_clear(&job);
    if (queue)
        pf_queue_close(queue);
    return held;
}

/* Issue 39: a job over the character renders every frame deformed; `timings` shows deform;
 * --animation is stored in the job. */
PF_TEST(a_job_over_a_skinned_scene_reports_its_deform_rows)
{
    char character[WT_PATH_MAX + 64], out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32];
    char pattern[2 * WT_PATH_MAX], args[8 * WT_PATH_MAX];
    character_scene(character, sizeof character);
    wt_fresh_dir("character-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/character.db", dir);
    unlink(db);
    wt_format(pattern, sizeof pattern, "%s/c.####.exr", out);
    /* Only the sheet's animation plays: the job stores the choice and its worker honours it
     * (the arm stays put, still skinned; the sheet bulges, so the tree is refit). */
    int64_t job_id = enqueue(db, character, "1-2", pattern,
                             "--frames-per-task 2 --animation KeyAction");
    PF_REQUIRE(job_id > 0);
    PF_CHECK(job_parameters_hold(db, job_id, "\"animation\":\"KeyAction\"") == 1);
    wt_format(args, sizeof args, "status %lld --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "  animation 'KeyAction'  frames 1-2"));
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_files(out, "") == 2);
    wt_format(args, sizeof args, "timings %lld --format csv --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    /* Two frames deformed (none skipped); bih_build ran for both (built, then refit). */
    PF_CHECK(wt_file_contains(log_path, "\ndeform,2,0,"));
    PF_CHECK(wt_file_contains(log_path, "\nbih_build,2,0,"));
    wt_format(args, sizeof args, "timings %lld --format json --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "1 skinned mesh, 1 morphed, "));
}

/* KHR_materials_variants: --variant is stored in the job, and its worker loads the scene
 * dressed in it (the triangle blue at the image's centre, red in the file's own material). */
PF_TEST(a_job_renders_the_material_variant_it_names)
{
    char scene_path[WT_PATH_MAX + 32], out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32];
    char pattern[2 * WT_PATH_MAX], args[8 * WT_PATH_MAX];
    wt_format(scene_path, sizeof scene_path, "%s/variants.gltf", dir);
    wt_write_variant_scene(scene_path);
    wt_fresh_dir("variant-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/variant.db", dir);
    unlink(db);
    const char *variants[2] = {"", "--variant blue"};
    for (int v = 0; v < 2; v++) {
        wt_format(pattern, sizeof pattern, "%s/v%d.####.exr", out, v);
        int64_t job_id = enqueue(db, scene_path, "1", pattern, variants[v]);
        PF_REQUIRE(job_id > 0);
        PF_CHECK(job_parameters_hold(db, job_id, "\"material_variant\":\"blue\"") == v);
    }
    /* status shows what each job wears. */
    wt_format(args, sizeof args, "status --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "variants.gltf  frames 1"));
    PF_CHECK(wt_file_contains(log_path, "variants.gltf  variant 'blue'  frames 1"));
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    for (int v = 0; v < 2; v++) {
        char path[2 * WT_PATH_MAX];
        wt_format(path, sizeof path, "%s/v%d.0001.exr", out, v);
        pf_image image = {0};
        pf_error err = {0};
        PF_REQUIRE_OK(pf_exr_read(path, &image, NULL, NULL, &err), &err);
        const float *centre =
            &image.pixels[((size_t)image.height / 2 * image.width + image.width / 2) *
                          image.channel_count];
        PF_CHECK_MSG(v == 0 ? centre[0] > 10 * centre[2] : centre[2] > 10 * centre[0],
                     "%s: centre %g %g %g", path, centre[0], centre[1], centre[2]);
        pf_image_free(&image);
    }
}

/* Issue 40: a task of consecutive frames on one worker reuses each frame's denoised light in
 * the next; `timings` shows the temporal rows (the first skipped, the others run). The
 * project's own animated character (its lights and materials still, as reuse needs), so
 * that the test runs where ../shared/scenes is not (the container image's build runs this
 * suite). */
PF_TEST(a_task_of_consecutive_frames_reuses_the_frame_before)
{
    char scene_path[WT_PATH_MAX], out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32];
    char args[8 * WT_PATH_MAX];
    character_scene(scene_path, sizeof scene_path);
    wt_fresh_dir("temporal-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/temporal.db", dir);
    unlink(db);
    wt_format(args, sizeof args,
              "'%s' --frames 1-3 --out '%s/t.####.exr' --size 16x12 --quality reference --spp 1 "
              "--frames-per-task 3 --db '%s'",
              scene_path, out, db);
    int64_t job_id = wt_enqueue(args, log_path);
    PF_REQUIRE(job_id > 0);
    wt_format(args, sizeof args, "worker --once --db '%s'", db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_count_files(out, "") == 3);
    wt_format(args, sizeof args, "timings %lld --format csv --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "\ntemporal,2,1,")); /* run twice, skipped once */
    PF_CHECK(wt_file_contains(log_path, "\ndenoise,3,0,"));
    wt_format(args, sizeof args, "timings %lld --format json --db '%s'", (long long)job_id, db);
    PF_REQUIRE(wt_run(args, log_path) == 0);
    PF_CHECK(wt_file_contains(log_path, "previous frame (2) on this worker"));
}

/* The job's exr_write rows whose counters say they were written behind the next render. */
static int rows_written_behind(const char *db_path, int64_t job_id)
{
    return wt_count_query(db_path,
                          "SELECT count(*) FROM stage_timings s JOIN tasks t ON t.id = "
                          "s.task_id WHERE t.job_id = ?1 AND s.stage = ?2 AND "
                          "json_extract(s.counters, '$.behind') = 1",
                          job_id, "exr_write");
}

/* Where text first occurs in the file at path (-1: nowhere). */
static long offset_in_file(const char *path, const char *text)
{
    char *content = wt_read_file(path, NULL);
    const char *at = content ? strstr(content, text) : NULL;
    long offset = at ? (long)(at - content) : -1;
    free(content);
    return offset;
}

/*
 * Issue 43: a frame is written behind the render. Frame 1's EXR write is held (its rename
 * onto the temporary waits for a file the test makes); meanwhile the worker renders frame
 * 2, claimed ahead as the next task or as the next frame of a chunk. A serial worker would
 * never render frame 2 while frame 1's write waits, and this test would fail after its
 * timeout. With tasks of one frame the write is then held past the lease (3 s): the
 * written task's lease is renewed meanwhile, so both tasks complete.
 */
static void frame_2_renders_while_frame_1_is_written(int frames_per_task)
{
    char out[WT_PATH_MAX + 32], db[WT_PATH_MAX + 32], pattern[2 * WT_PATH_MAX],
        worker_log[WT_PATH_MAX + 32], release[WT_PATH_MAX + 32], extra[64];
    wt_fresh_dir(frames_per_task == 1 ? "behind-out" : "behind-chunk-out", out, sizeof out);
    wt_format(db, sizeof db, "%s/behind%d.db", dir, frames_per_task);
    wt_format(worker_log, sizeof worker_log, "%s/behind%d.log", dir, frames_per_task);
    wt_format(release, sizeof release, "%s/behind%d.release", dir, frames_per_task);
    unlink(db);
    unlink(worker_log);
    unlink(release);
    wt_format(pattern, sizeof pattern, "%s/b.####.exr", out);
    wt_format(extra, sizeof extra, "--frames-per-task %d", frames_per_task);
    int64_t job_id = enqueue(db, scene, "1-2", pattern, extra);
    PF_REQUIRE(job_id > 0);
    const char *worker_args[] = {"worker", "--once", "--lease-seconds", "3", "--db", db, NULL};
    char env[9 * WT_PATH_MAX], faults[8 * WT_PATH_MAX];
    wt_fault_environment(faults, sizeof faults, out, NULL, NULL, 0);
    wt_format(env, sizeof env, "%s\nPF_FAULT_RELEASE=%s", faults, release);
    pid_t pid = wt_spawn(worker_args, worker_log, env);
    int rendered_meanwhile = 0;
    for (int waited = 0; waited < WORKER_TIMEOUT_MS && !rendered_meanwhile; waited += 20) {
        rendered_meanwhile = wt_file_contains(worker_log, "event=rendered job=1 frame=2 ");
        if (!rendered_meanwhile)
            wt_sleep_ms(20);
    }
    PF_CHECK_MSG(rendered_meanwhile, "frame 2 did not render while frame 1's write was held");
    if (frames_per_task == 1)
        wt_sleep_ms(4000); /* past the 3 s lease */
    FILE *file = fopen(release, "w");
    PF_REQUIRE(file != NULL);
    fclose(file);
    int code = wt_wait(pid, WORKER_TIMEOUT_MS);
    PF_CHECK_MSG(code == 0, "worker exited %d", code);
    /* Frame 1 was written after frame 2 rendered, and each write only then. */
    long written_1 = offset_in_file(worker_log, "event=written job=1 frame=1 ");
    long rendered_2 = offset_in_file(worker_log, "event=rendered job=1 frame=2 ");
    PF_CHECK_MSG(written_1 > rendered_2 && rendered_2 >= 0, "written 1 at %ld, rendered 2 at %ld",
                 written_1, rendered_2);
    PF_CHECK(wt_count_in_file(worker_log, "event=written ") == 2);
    PF_CHECK(wt_count_in_file(worker_log, "event=completed ") == (frames_per_task == 1 ? 2 : 1));
    PF_CHECK(!wt_file_contains(worker_log, "event=lease_lost"));
    PF_CHECK(!wt_file_contains(worker_log, "event=db_error"));
    pf_queue *queue = wt_open_queue(db);
    PF_REQUIRE(queue != NULL);
    pf_queue_job job = {0};
    pf_error err = {0};
    PF_CHECK_OK(pf_queue_job_get(queue, job_id, &job, &err), &err);
    PF_CHECK_MSG(!strcmp(job.status, "done") && job.frames_done == 2, "job %s, %lld frames done",
                 job.status, (long long)job.frames_done);
    pf_queue_job_clear(&job);
    pf_queue_close(queue);
    for (int frame = 1; frame <= 2; frame++) {
        char path[3 * WT_PATH_MAX];
        wt_format(path, sizeof path, "%s/b.%04d.exr", out, frame);
        PF_CHECK_MSG(wt_exr_frame(path) == frame, "%s", path);
    }
    PF_CHECK(wt_count_files(out, "partial") == 0);
    PF_CHECK_MSG(rows_written_behind(db, job_id) == 2, "%d exr_write rows behind",
                 rows_written_behind(db, job_id));
    /* Each frame's `written` line is in its own task's attempt log, also frame 1's, written
     * while task 2 rendered: not in task 2's. */
    static const char *const logs_with =
        "SELECT count(*) FROM attempt_logs l JOIN tasks t ON t.id = l.task_id "
        "WHERE t.job_id = ?1 AND instr(l.log, ?2) > 0 AND t.first_frame = %d";
    for (int frame = 1; frame <= 2; frame++) {
        char sql[512], line[64];
        wt_format(sql, sizeof sql, logs_with, frames_per_task == 1 ? frame : 1);
        wt_format(line, sizeof line, "event=written job=1 frame=%d ", frame);
        int own = wt_count_query(db, sql, job_id, line);
        wt_format(sql, sizeof sql, logs_with, frames_per_task == 1 ? 3 - frame : 0);
        int other = wt_count_query(db, sql, job_id, line);
        PF_CHECK_MSG(own == 1 && other == 0,
                     "frame %d's written line: in %d logs of its task, %d of the other", frame,
                     own, other);
    }
}

PF_TEST(the_next_frame_renders_while_the_last_is_written)
{
    frame_2_renders_while_frame_1_is_written(1);
    frame_2_renders_while_frame_1_is_written(2);
}

int main(void)
{
    pf_test_tmpdir(dir, sizeof dir);
    wt_format(scene, sizeof scene, "%s/tiny.gltf", dir);
    wt_format(log_path, sizeof log_path, "%s/run.log", dir);
    wt_write_tiny_scene(scene, 3);
    PF_RUN(workers_show_the_capabilities_a_worker_registered);
    PF_RUN(worker_renders_a_job_and_timings_report_every_stage);
    PF_RUN(a_larger_frame_records_more_peak_memory);
    PF_RUN(a_budgeted_auto_job_stores_reuse_only_from_real_frames);
    PF_RUN(failing_frames_record_each_attempt_and_stop_at_max_attempts);
    PF_RUN(a_worker_failing_a_jobs_frames_is_blocked_and_status_says_so);
    PF_RUN(a_vanished_scene_pauses_its_job_and_blames_no_worker);
    PF_RUN(a_scene_reaching_outside_its_directory_renders_only_when_the_job_allows_it);
    PF_RUN(sigterm_drains_the_current_frame);
    PF_RUN(a_second_sigterm_releases_the_frame);
    PF_RUN(a_worker_whose_lease_was_taken_over_never_writes);
    PF_RUN(a_lease_lost_inside_the_commit_is_left_to_the_new_owner);
    PF_RUN(a_frame_that_cannot_be_committed_pauses_its_job_at_once);
    PF_RUN(render_frames_deforms_a_blender_character_and_refits_its_tree);
    PF_RUN(a_job_over_a_skinned_scene_reports_its_deform_rows);
    PF_RUN(a_job_renders_the_material_variant_it_names);
    PF_RUN(a_task_of_consecutive_frames_reuses_the_frame_before);
    PF_RUN(the_next_frame_renders_while_the_last_is_written);
    return pf_test_finish();
}
