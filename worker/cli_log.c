/*
 * photonfarm log JOB FRAME [--format text|json]: the lines each attempt at the frame
 * logged on its worker (issue 41), as the worker stored them when it let the task go:
 * which scene it loaded, the importer's and the device's warnings, what went wrong. A
 * worker killed outright stored none; `status JOB` shows its lease expiry instead.
 */
#include "cli_queue.h"
#include "json_views.h"
#include "pf_cli.h"
#include "timings_frames.h"

#include <inttypes.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#define COMMAND "log"

/* Each line escaped (printable.c): anyone who can enqueue chooses text that lands here. */
static void print_lines(const char *text)
{
    char line[4096], shown[4 * sizeof line];
    while (*text) {
        size_t length = strcspn(text, "\n");
        size_t kept = length < sizeof line ? length : sizeof line - 1;
        memcpy(line, text, kept);
        line[kept] = '\0';
        printf("  %s\n", pf_cli_printable(line, shown, sizeof shown));
        text += length + (text[length] == '\n');
    }
}

static void print_text(int64_t job_id, int32_t frame, const pf_queue_attempt_log *logs,
                       size_t count)
{
    if (count == 0)
        printf("job %" PRId64 " frame %d: no log stored (not rendered yet, or its worker was "
               "killed)\n", job_id, frame);
    char name[PF_QUEUE_NAME_MAX * 4];
    for (size_t i = 0; i < count; i++) {
        time_t seconds = (time_t)(logs[i].written_at / 1000);
        struct tm utc;
        char when[32] = "?";
        if (gmtime_r(&seconds, &utc))
            strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &utc);
        printf("%sjob %" PRId64 " frame %d, task %" PRId64 " (frames %d-%d), attempt %d on %s, "
               "stored %s:\n", i ? "\n" : "", job_id, frame, logs[i].task_id,
               logs[i].first_frame, logs[i].last_frame, logs[i].attempt,
               logs[i].worker_name[0] ? pf_cli_printable(logs[i].worker_name, name, sizeof name)
                                      : "an unknown worker",
               when);
        print_lines(logs[i].text);
    }
}

int pf_cli_log(int argc, char **argv)
{
    const char *db = NULL, *format = "text", *positional[2] = {NULL, NULL};
    const pf_cli_option options[] = {
        {"--format", NULL, "F", "text or json", "text", pf_cli_store_choice, &format, 0, 0,
         "text|json"},
        pf_cli_db_option(&db),
    };
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "JOB FRAME [options]",
        .description = "The lines each attempt at FRAME logged on its worker, oldest first:\n"
                       "the claim, the scene it loaded, the importer's and the device's\n"
                       "warnings, and what failed. A worker stores them when it lets the\n"
                       "frame go; one killed outright stores none.",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
        .positional = positional,
        .positional_max = 2,
    };
    int help = 0;
    int64_t job_id = 0, frame = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    code = pf_cli_job_id(COMMAND, positional[0], 1, &job_id);
    if (code)
        return code;
    if (!positional[1] || !pf_cli_parse_int(positional[1], INT32_MIN, INT32_MAX, &frame))
        return pf_cli_fail(COMMAND, 2, "FRAME '%s': expected a frame number",
                           positional[1] ? positional[1] : "");
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(COMMAND, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    pf_error err = {0};
    pf_queue_attempt_log *logs = NULL;
    size_t count = 0;
    pf_status status = pf_queue_attempt_logs(queue, job_id, (int32_t)frame, &logs, &count, &err);
    pf_queue_close(queue);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    if (!strcmp(format, "json"))
        code = pf_timings_print_json(pf_monitor_logs_json(job_id, (int32_t)frame, logs, count));
    else
        print_text(job_id, (int32_t)frame, logs, count);
    pf_queue_attempt_logs_free(logs, count);
    return code;
}
