/* photonfarm workers: every registered worker, alive or dead, its heartbeat
 * age and what it is rendering; --check NAME answers one worker's health by
 * exit status (a container's HEALTHCHECK: alive means heard from within its
 * own lease). */
#include "cli_queue.h"
#include "pf_cli.h"

#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define COMMAND "workers"

int pf_cli_workers(int argc, char **argv)
{
    const char *db = NULL, *check = NULL;
    const pf_cli_option options[] = {
        pf_cli_db_option(&db),
        {"--check", NULL, "NAME",
         "print nothing but NAME's state; exit 0 when it is alive\n(heard from within its lease), "
         "1 when dead, stopped or unknown",
         "list every worker", pf_cli_store_text, &check, 0, 0, NULL},
    };
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "[options]",
        .description = "Lists every registered worker: alive (heard from within its lease),\n"
                       "dead or stopped, its heartbeat age, device, capabilities (device\n"
                       "type and memory, host memory and cores, tags) and current frame.",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
    };
    int help = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(COMMAND, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    pf_error err = {0};
    pf_queue_worker_info *workers = NULL;
    size_t count = 0;
    int64_t now = pf_queue_now(queue);
    pf_status status = pf_queue_worker_list(queue, &workers, &count, &err);
    pf_queue_close(queue);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    if (check) {
        const char *state = "unknown";
        for (size_t i = 0; i < count; i++)
            if (!strcmp(workers[i].name, check))
                state = workers[i].stopped_at ? "stopped" : workers[i].alive ? "alive" : "dead";
        char shown[256];
        printf("%s %s\n", pf_cli_printable(check, shown, sizeof shown), state);
        free(workers);
        return strcmp(state, "alive") != 0;
    }
    if (count == 0)
        printf("no workers\n");
    else
        printf("%-24s %-8s %-10s %-28s %-4s %8s %8s %5s %-16s %s\n", "name", "state",
               "heartbeat", "device", "type", "dev mem", "host mem", "cores", "tags", "current");
    for (size_t i = 0; i < count; i++) {
        const pf_queue_worker_info *worker = &workers[i];
        const char *state = worker->stopped_at ? "stopped" : worker->alive ? "alive" : "dead";
        char age[32], current[64];
        snprintf(age, sizeof age, "%.1fs ago", (double)(now - worker->heartbeat_at) / 1000.0);
        if (worker->current_task_id)
            snprintf(current, sizeof current, "job %" PRId64 " frame %d", worker->current_job_id,
                     worker->current_frame);
        else
            snprintf(current, sizeof current, "-");
        char name[256], device[256], tags[PF_QUEUE_TAGS_MAX + 8], device_memory[32],
            host_memory[32];
        pf_cli_format_bytes(worker->device_memory, device_memory, sizeof device_memory);
        pf_cli_format_bytes(worker->host_memory, host_memory, sizeof host_memory);
        pf_cli_printable(worker->tags[0] ? worker->tags : "-", tags, sizeof tags);
        printf("%-24s %-8s %-10s %-28.28s %-4s %8s %8s %5" PRId64 " %-16s %s\n",
               pf_cli_printable(worker->name, name, sizeof name), state, age,
               pf_cli_printable(worker->device, device, sizeof device),
               worker->device_type[0] ? worker->device_type : "-", device_memory, host_memory,
               worker->cores, tags, current);
    }
    free(workers);
    return 0;
}
