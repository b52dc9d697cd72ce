/*
 * photonfarm status [JOB]: every job (or one) with a progress bar, its running
 * frames and their workers, its failures with their errors, and why a job
 * cannot progress (the queue's "no eligible worker" note).
 */
#include "cli_queue.h"
#include "pf_cli.h"
#include "progress.h"
#include "storage_roots.h"
#include "job_extras.h"

#include <inttypes.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define COMMAND "status"
/* --watch's longest interval: an hour. */
#define MAX_WATCH_SECONDS 3600
#define BAR_CELLS 30
/* Failures listed per job; the rest are counted ("... and N more"). */
#define FAILURES_SHOWN 10

/* A stored path and, when roots map it elsewhere, what it resolves to here. */
static const char *shown_path(const pf_roots *roots, const char *stored, int output, char *out,
                              size_t size)
{
    char resolved[PATH_MAX], printable[2][PF_CLI_PATH_MAX / 2 - 4]; /* both fit in out */
    pf_error err = {0};
    pf_status status = output ? pf_roots_output_resolve(roots, stored, resolved, sizeof resolved,
                                                        &err)
                              : pf_roots_resolve(roots, stored, resolved, sizeof resolved, &err);
    pf_cli_printable(stored, printable[0], sizeof printable[0]);
    /* Truncation is fine here: a display line. */
    int written = status == PF_OK && strcmp(resolved, stored) != 0
                      ? snprintf(out, size, "%s (%s)", printable[0],
                                 pf_cli_printable(resolved, printable[1], sizeof printable[1]))
                      : snprintf(out, size, "%s", printable[0]);
    (void)written;
    return out;
}

/* A job whose frames ran out of memory: what its finished frames took (the largest of
 * the peaks `timings` reports), and the requirements that would keep it off smaller
 * workers (issue 42). Read only for such a job. */
static void print_memory_advice(pf_queue *queue, const pf_queue_job *job)
{
    if (job->memory_failures == 0)
        return;
    printf("  memory: %" PRId64 " failure%s ran out of memory", job->memory_failures,
           job->memory_failures == 1 ? "" : "s");
    pf_queue_timings timings;
    pf_error err = {0};
    if (pf_queue_timings_get(queue, job->job_id, 0, &timings, &err) != PF_OK) {
        printf("; its frames' peaks cannot be read: %s\n", err.message);
        return;
    }
    int64_t peak_rss = (int64_t)timings.peak_rss.max;
    int64_t peak_device = (int64_t)timings.peak_device_memory.max;
    pf_queue_timings_free(&timings);
    if (peak_rss <= 0 && peak_device <= 0) {
        printf("; no frame of it has finished to measure\n");
        return;
    }
    char peaks[2][32], suggested[2][32];
    pf_cli_format_bytes(peak_rss, peaks[0], sizeof peaks[0]);
    pf_cli_format_bytes(peak_device, peaks[1], sizeof peaks[1]);
    printf("; its finished frames peaked at %s of memory and %s of device memory\n", peaks[0],
           peaks[1]);
    printf("  suggestion: enqueue it again with");
    if (peak_rss > 0) {
        pf_queue_suggested_requirement(peak_rss, suggested[0], sizeof suggested[0]);
        printf(" --min-memory %s", suggested[0]);
    }
    if (peak_device > 0) {
        pf_queue_suggested_requirement(peak_device, suggested[1], sizeof suggested[1]);
        printf(" --min-device-memory %s", suggested[1]);
    }
    printf(" (%.0f%% over those peaks), so that smaller workers do not claim it\n",
           (PF_QUEUE_SUGGESTED_HEADROOM - 1.0) * 100.0);
}

static void print_job(pf_queue *queue, const pf_queue_job *job, int64_t now,
                      const pf_storage *storage)
{
    char bar[320], name[128], shown[4][PF_CLI_PATH_MAX];
    pf_progress_bar(bar, sizeof bar, job->frames_done, job->frames_total, BAR_CELLS);
    pf_job_name(job->parameters_json, name, sizeof name);
    printf("job %" PRId64 "%s%s%s  %-8s %s  priority %d\n", job->job_id, name[0] ? " (" : "",
           pf_cli_printable(name, shown[0], sizeof shown[0]), name[0] ? ")" : "", job->status,
           bar, job->priority);
    /* What the job loads besides the file: the animation it plays, the variant it wears. */
    char animation[128], variant[128], loads[2][160] = {"", ""}, shown_load[128];
    if (pf_job_animation(job->parameters_json, animation, sizeof animation))
        snprintf(loads[0], sizeof loads[0], "  animation '%s'",
                 pf_cli_printable(animation, shown_load, sizeof shown_load));
    if (pf_job_material_variant(job->parameters_json, variant, sizeof variant))
        snprintf(loads[1], sizeof loads[1], "  variant '%s'",
                 pf_cli_printable(variant, shown_load, sizeof shown_load));
    printf("  scene %s%s%s  frames %s  -> %s\n",
           shown_path(&storage->scene, job->scene_path, 0, shown[1], sizeof shown[1]), loads[0],
           loads[1], pf_cli_printable(job->frame_range, shown[2], sizeof shown[2]),
           shown_path(&storage->output, job->output_pattern, 1, shown[3], sizeof shown[3]));
    printf("  tasks: %" PRId64 " queued, %" PRId64 " running, %" PRId64 " done, %" PRId64
           " failed, %" PRId64 " canceled\n",
           job->tasks_queued, job->tasks_running, job->tasks_done, job->tasks_failed,
           job->tasks_canceled);
    if (job->requires_device[0] || job->min_device_memory > 0 || job->min_host_memory > 0 ||
        job->required_tags[0]) {
        char needs[PF_QUEUE_TAGS_MAX + 160];
        pf_queue_requirements_text(job->requires_device, job->min_device_memory,
                                   job->min_host_memory, job->required_tags, needs,
                                   sizeof needs);
        printf("  requires: %s (%d live worker%s qualif%s)\n",
               pf_cli_printable(needs, shown[0], sizeof shown[0]), job->qualified_live_workers,
               job->qualified_live_workers == 1 ? "" : "s",
               job->qualified_live_workers == 1 ? "ies" : "y");
    }
    if (job->prerequisites[0])
        printf("  after: job %s\n", job->prerequisites);
    if (job->note[0])
        printf("  note: %s\n", pf_cli_printable(job->note, shown[0], sizeof shown[0]));
    print_memory_advice(queue, job);

    pf_error err = {0};
    pf_queue_task_info *tasks = NULL;
    size_t task_count = 0;
    if (pf_queue_task_list(queue, job->job_id, &tasks, &task_count, &err) == PF_OK) {
        for (size_t i = 0; i < task_count; i++) {
            if (strcmp(tasks[i].status, "running") != 0)
                continue;
            printf("  running: frame %d", tasks[i].first_frame);
            if (tasks[i].frame_count > 1)
                printf("-%d", tasks[i].last_frame);
            printf(" on %s (attempt %d, lease %.1f s left)\n",
                   pf_cli_printable(tasks[i].worker_name, shown[0], sizeof shown[0]),
                   tasks[i].attempt, (double)(tasks[i].lease_expires - now) / 1000.0);
        }
        free(tasks);
    }
    pf_queue_failure *failures = NULL;
    size_t failure_count = 0;
    if (pf_queue_failure_list(queue, job->job_id, &failures, &failure_count, &err) == PF_OK) {
        if (failure_count > 0)
            printf("  failures (%zu):\n", failure_count);
        for (size_t i = 0; i < failure_count && i < FAILURES_SHOWN; i++)
            printf("    frame %d attempt %d on %s: %s\n", failures[i].first_frame,
                   failures[i].attempt,
                   pf_cli_printable(failures[i].worker_name, shown[0], sizeof shown[0]),
                   pf_cli_printable(failures[i].error, shown[1], sizeof shown[1]));
        if (failure_count > FAILURES_SHOWN)
            printf("    ... and %zu more\n", failure_count - FAILURES_SHOWN);
        free(failures);
    }
}

/* Whether a job has ended: nothing of it will change any more unless someone acts (a
 * blocked job waits for a retry of the job that blocks it, as a failed one does). */
static int job_ended(const pf_queue_job *job)
{
    return !strcmp(job->status, "done") || !strcmp(job->status, "failed") ||
           !strcmp(job->status, "canceled") || !strcmp(job->status, "blocked");
}

/* One report of the job (or every job); *active says whether any shown job has not ended. */
static int print_status(pf_queue *queue, int64_t job_id, const pf_storage *storage, int *active)
{
    pf_error err = {0};
    int64_t now = pf_queue_now(queue);
    int code = 0;
    *active = 0;
    if (job_id) {
        pf_queue_job job = {0};
        pf_status status = pf_queue_job_get(queue, job_id, &job, &err);
        if (status == PF_OK) {
            print_job(queue, &job, now, storage);
            *active = !job_ended(&job);
        } else {
            code = pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
        }
        pf_queue_job_clear(&job);
        return code;
    }
    pf_queue_job *jobs = NULL;
    size_t count = 0;
    pf_status status = pf_queue_job_list(queue, &jobs, &count, &err);
    if (status != PF_OK) {
        code = pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    } else if (count == 0) {
        printf("no jobs\n");
    } else {
        for (size_t i = 0; i < count; i++) {
            print_job(queue, &jobs[i], now, storage);
            *active |= !job_ended(&jobs[i]);
        }
    }
    pf_queue_job_list_free(jobs, count);
    return code;
}

static volatile sig_atomic_t interrupted;

static void on_interrupt(int signal_number)
{
    (void)signal_number;
    interrupted = 1;
}

int pf_cli_status(int argc, char **argv)
{
    const char *db = NULL, *job_text = NULL;
    int64_t watch = 0;
    pf_storage storage;
    pf_storage_init(&storage);
    const pf_cli_option options[] = {
        pf_cli_db_option(&db),
        {"--watch", NULL, "SECONDS",
         "report again every SECONDS until every job shown has ended\n(done, failed, "
         "canceled, or blocked by one that did) or Ctrl-C;\non a terminal in place",
         "once", pf_cli_store_int, &watch, 1, MAX_WATCH_SECONDS, NULL},
        pf_roots_option(&storage.scene), pf_roots_option(&storage.output)};
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "[JOB] [options]",
        .description = "Lists jobs with a progress bar, running frames with their workers,\n"
                       "failures with their errors and why a job cannot progress (blocked\n"
                       "workers, a pause for its storage or scene). With JOB, that job only.",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
        .positional = &job_text,
        .positional_max = 1,
    };
    int help = 0;
    int64_t job_id = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    code = pf_cli_job_id(COMMAND, job_text, 0, &job_id);
    if (!code)
        code = pf_storage_finish(COMMAND, &storage);
    if (code)
        return code;
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(COMMAND, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    int active = 0;
    code = print_status(queue, job_id, &storage, &active);
    if (watch > 0) {
        /* A terminal is redrawn from its top-left corner; anything else gets one report after
         * another, each ended by a blank line. */
        int terminal = isatty(STDOUT_FILENO);
        signal(SIGINT, on_interrupt);
        while (!code && active && !interrupted) {
            fflush(stdout);
            for (int64_t slept = 0; slept < watch * 10 && !interrupted; slept++)
                nanosleep(&(struct timespec){0, 100000000L}, NULL);
            if (interrupted)
                break;
            printf(terminal ? "\033[H\033[J" : "\n");
            code = print_status(queue, job_id, &storage, &active);
        }
    }
    pf_queue_close(queue);
    return code;
}
