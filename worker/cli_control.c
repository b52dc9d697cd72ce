/*
 * photonfarm cancel | pause | resume | retry JOB: job control. Cancel revokes
 * running leases (their workers discard the frame), pause stops new claims,
 * resume undoes it, retry requeues failed and canceled frames with fresh
 * attempts and lifts the job's worker blocks.
 */
#include "cli_queue.h"
#include "frame_pipeline.h"
#include "pf_cli.h"

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

static int control(const char *command, int argc, char **argv)
{
    const char *db = NULL;
    int64_t job_id = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: photonfarm %s JOB [--db PATH]\n", command);
            return 0;
        } else if (!strcmp(argv[i], "--db")) {
            if (i + 1 >= argc)
                return pf_cli_fail(command, 2, "--db needs a value");
            db = argv[++i];
        } else if (job_id == 0 && pf_cli_parse_int(argv[i], 1, INT64_MAX, &job_id)) {
            continue;
        } else {
            return pf_cli_fail(command, 2, "unexpected argument '%s' (expected a job id)",
                               argv[i]);
        }
    }
    if (!job_id)
        return pf_cli_fail(command, 2, "no job id given (see photonfarm status)");
    pf_queue *queue = NULL;
    int code = pf_cli_open_queue(command, pf_cli_db_path(db), 1, &queue);
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
