/*
 * photonfarm cancel | pause | resume | retry JOB, priority JOB P: job control.
 * Cancel revokes running leases (their workers discard the frame), pause stops
 * new claims, resume undoes it, retry requeues failed and canceled frames with
 * fresh attempts and lifts the job's worker blocks, priority changes which job
 * the next claims take.
 */
#include "cli_queue.h"
#include "pf_render.h"
#include "pf_cli.h"
#include "frame_fault.h"

#include <inttypes.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

/*
 * After cancel: the temporaries its tasks left ("<frame>.partial-t<task>-*"),
 * a killed worker's included, which no later attempt would clean since none
 * comes. A worker still rendering one loses its lease and discards it anyway.
 * Returns how many files were removed.
 */
static int remove_partials(pf_queue *queue, const pf_queue_job *job)
{
    pf_queue_task_info *tasks = NULL;
    size_t count = 0;
    pf_error err = {0};
    if (pf_queue_task_list(queue, job->job_id, &tasks, &count, &err) != PF_OK)
        return 0;
    int removed = 0;
    for (size_t t = 0; t < count; t++) {
        for (int32_t k = 0; k < tasks[t].frame_count; k++) {
            char path[PF_FRAME_PATH_MAX];
            int64_t frame = tasks[t].first_frame + (int64_t)k * tasks[t].frame_step;
            if (pf_frame_output_path(job->output_pattern, frame, path, sizeof path))
                removed += pf_frame_remove_stale(path, tasks[t].task_id);
        }
    }
    free(tasks);
    return removed;
}

static const char *description_of(const char *command)
{
    if (!strcmp(command, "cancel"))
        return "Cancels the job: its queued and running frames stop (running workers\n"
               "discard theirs), and its unfinished frame files are removed.";
    if (!strcmp(command, "pause"))
        return "Pauses the job: no new frame of it is claimed; running ones finish.";
    if (!strcmp(command, "resume"))
        return "Resumes a paused job, whether a user or the queue paused it (a storage\n"
               "or scene fault: fix that first).";
    return "Requeues the job's failed and canceled frames with fresh attempts and\n"
           "lifts its workers' blocks.";
}

static int control(const char *command, int argc, char **argv)
{
    const char *db = NULL, *job_text = NULL;
    const pf_cli_option options[] = {pf_cli_db_option(&db)};
    pf_cli_command parsed = {
        .name = command,
        .synopsis = "JOB [options]",
        .description = description_of(command),
        .options = options,
        .option_count = 1,
        .positional = &job_text,
        .positional_max = 1,
    };
    int help = 0;
    int64_t job_id = 0;
    int code = pf_cli_parse(&parsed, argc, argv, &help);
    if (code || help)
        return code;
    code = pf_cli_job_id(command, job_text, 1, &job_id);
    if (code)
        return code;
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(command, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    pf_error err = {0};
    pf_status status;
    int64_t requeued = 0;
    if (!strcmp(command, "cancel"))
        status = pf_queue_cancel(queue, job_id, &err);
    else if (!strcmp(command, "pause"))
        status = pf_queue_pause(queue, job_id, &err);
    else if (!strcmp(command, "resume"))
        status = pf_queue_resume(queue, job_id, &err);
    else
        status = pf_queue_retry(queue, job_id, &requeued, &err);
    pf_queue_job job = {0};
    if (status == PF_OK)
        status = pf_queue_job_get(queue, job_id, &job, &err);
    int removed = status == PF_OK && !strcmp(command, "cancel") ? remove_partials(queue, &job) : 0;
    pf_queue_close(queue);
    if (status != PF_OK) {
        pf_queue_job_clear(&job);
        return pf_cli_fail(command, pf_status_exit_code(status), "%s", err.message);
    }
    if (!strcmp(command, "retry"))
        printf("job %" PRId64 ": %" PRId64 " task(s) requeued, now %s\n", job_id, requeued,
               job.status);
    else if (removed > 0)
        printf("job %" PRId64 ": %s (%d unfinished frame file(s) removed)\n", job_id, job.status,
               removed);
    else
        printf("job %" PRId64 ": %s\n", job_id, job.status);
    pf_queue_job_clear(&job);
    return 0;
}

int pf_cli_cancel(int argc, char **argv) { return control("cancel", argc, argv); }
int pf_cli_pause(int argc, char **argv) { return control("pause", argc, argv); }
int pf_cli_resume(int argc, char **argv) { return control("resume", argc, argv); }
int pf_cli_retry(int argc, char **argv) { return control("retry", argc, argv); }

int pf_cli_priority(int argc, char **argv)
{
    const char *db = NULL, *positional[2] = {NULL, NULL};
    const pf_cli_option options[] = {pf_cli_db_option(&db)};
    pf_cli_command parsed = {
        .name = "priority",
        .synopsis = "JOB PRIORITY [options]",
        .description = "Sets the job's priority: higher runs first, from the next claim on\n"
                       "(running frames finish where they are).",
        .options = options,
        .option_count = 1,
        .positional = positional,
        .positional_max = 2,
    };
    int help = 0;
    int64_t job_id = 0, priority = 0;
    int code = pf_cli_parse(&parsed, argc, argv, &help);
    if (code || help)
        return code;
    code = pf_cli_job_id("priority", positional[0], 1, &job_id);
    if (code)
        return code;
    if (!positional[1] ||
        !pf_cli_parse_int(positional[1], -PF_QUEUE_PRIORITY_MAX, PF_QUEUE_PRIORITY_MAX, &priority))
        return pf_cli_fail("priority", 2, "PRIORITY '%s': expected an integer %d..%d",
                           positional[1] ? positional[1] : "", -PF_QUEUE_PRIORITY_MAX,
                           PF_QUEUE_PRIORITY_MAX);
    pf_queue *queue = NULL;
    code = pf_cli_open_queue("priority", pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    pf_error err = {0};
    pf_status status = pf_queue_set_priority(queue, job_id, (int)priority, &err);
    pf_queue_close(queue);
    if (status != PF_OK)
        return pf_cli_fail("priority", pf_status_exit_code(status), "%s", err.message);
    printf("job %" PRId64 ": priority %" PRId64 "\n", job_id, priority);
    return 0;
}
