/*
 * photonfarm depend JOB --after JOB[,JOB] [--after-frames JOB[,JOB]]: makes a job that has
 * not ended wait for others, as enqueue --after does for a new one (issue 42). The queue
 * refuses an unknown job, a cycle and a prerequisite named twice, and adds nothing then.
 */
#include "cli_queue.h"
#include "pf_cli.h"

#include <inttypes.h>
#include <stdio.h>

#define COMMAND "depend"

int pf_cli_depend(int argc, char **argv)
{
    const char *db = NULL, *job_text = NULL;
    pf_cli_prerequisites after = {.count = 0};
    const pf_cli_option options[] = {
        {"--after", NULL, "JOB[,JOB]", "its frames wait until these jobs are done (repeatable)",
         NULL, pf_cli_store_after, &after, 0, 0, NULL},
        {"--after-frames", NULL, "JOB[,JOB]",
         "frame n waits for frame n of these jobs (repeatable)", NULL,
         pf_cli_store_after_frames, &after, 0, 0, NULL},
        pf_cli_db_option(&db)};
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "JOB --after JOB[,JOB] | --after-frames JOB[,JOB] [options]",
        .description = "Makes JOB, which has not ended, wait for other jobs: none of its\n"
                       "frames is claimed until they are done (--after), or frame n until\n"
                       "their frame n is (--after-frames). A prerequisite that fails or is\n"
                       "canceled leaves JOB blocked until it is retried. An unknown job or a\n"
                       "cycle is refused and nothing is added.",
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
    code = pf_cli_job_id(COMMAND, job_text, 1, &job_id);
    if (code)
        return code;
    if (after.count == 0)
        return pf_cli_fail(COMMAND, 2, "no prerequisite given (--after JOB or --after-frames JOB)");
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(COMMAND, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    pf_error err = {0};
    pf_queue_job job = {0};
    pf_status status = pf_queue_add_dependencies(queue, job_id, after.jobs, after.count, &err);
    if (status == PF_OK)
        status = pf_queue_job_get(queue, job_id, &job, &err);
    pf_queue_close(queue);
    if (status != PF_OK) {
        pf_queue_job_clear(&job);
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    }
    printf("job %" PRId64 ": %s, after %s\n", job_id, job.status, job.prerequisites);
    pf_queue_job_clear(&job);
    return 0;
}
