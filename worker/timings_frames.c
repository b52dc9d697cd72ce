/*
 * timings JOB --frames: every completed frame of a job (pf_queue_frame_details) as a
 * table, CSV (one line per frame and stage, for a spreadsheet's pivot) or JSON.
 */
#include "timings_frames.h"

#include "cli_options.h"
#include "json_views.h"
#include "pf_cli.h"

#include <cjson/cJSON.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdint.h>
#include <string.h>

#define COMMAND "timings"

/* "scene_eval 1.2, bih_build -, shade 812.0" and "bih_build=built, plan=final". */
static void frame_stages(const pf_queue_frame_details *details, const pf_queue_frame_detail *frame,
                         char *walls, size_t walls_size, char *decisions, size_t decisions_size)
{
    size_t walls_used = 0, decisions_used = 0;
    walls[0] = decisions[0] = '\0';
    for (size_t s = 0; s < frame->stage_count; s++) {
        const pf_queue_frame_stage *stage = &details->stages[frame->first_stage + s];
        char printable[2][PF_QUEUE_DECISION_MAX * 4 + 1];
        pf_cli_printable(stage->stage, printable[0], sizeof printable[0]);
        int n = stage->skipped ? snprintf(walls + walls_used, walls_size - walls_used, "%s%s -",
                                          s ? ", " : "", printable[0])
                               : snprintf(walls + walls_used, walls_size - walls_used,
                                          "%s%s %.1f", s ? ", " : "", printable[0],
                                          stage->wall_ms);
        if (n > 0 && (size_t)n < walls_size - walls_used)
            walls_used += (size_t)n;
        if (!stage->decision[0])
            continue;
        n = snprintf(decisions + decisions_used, decisions_size - decisions_used, "%s%s=%s",
                     decisions_used ? ", " : "", printable[0],
                     pf_cli_printable(stage->decision, printable[1], sizeof printable[1]));
        if (n > 0 && (size_t)n < decisions_size - decisions_used)
            decisions_used += (size_t)n;
    }
}

static void print_table(const pf_queue_frame_details *details)
{
    printf("%6s %6s %3s %-16s %10s %10s %10s %10s  %s\n", "frame", "task", "try", "worker",
           "wall ms", "peak rss", "peak dev", "written", "stages (ms; - skipped) | decisions");
    for (size_t i = 0; i < details->frame_count; i++) {
        const pf_queue_frame_detail *frame = &details->frames[i];
        char worker[PF_QUEUE_NAME_MAX * 4 + 1], sizes[3][32], walls[1024], decisions[1024];
        pf_cli_format_bytes(frame->peak_rss, sizes[0], sizeof sizes[0]);
        pf_cli_format_bytes(frame->peak_device_memory, sizes[1], sizeof sizes[1]);
        pf_cli_format_bytes(frame->bytes_written, sizes[2], sizeof sizes[2]);
        frame_stages(details, frame, walls, sizeof walls, decisions, sizeof decisions);
        printf("%6d %6" PRId64 " %3d %-16s %10.1f %10s %10s %10s  %s | %s\n", frame->frame,
               frame->task_id, frame->attempt,
               frame->worker_name[0] ? pf_cli_printable(frame->worker_name, worker, sizeof worker)
                                     : "-",
               frame->wall_ms, sizes[0], sizes[1], sizes[2], walls, decisions);
    }
    printf("%zu frame(s)\n", details->frame_count);
}

/* CSV text: quoted when it holds a comma, quote or line break (RFC 4180). */
static void print_csv_text(const char *text)
{
    if (!strpbrk(text, ",\"\r\n")) {
        fputs(text, stdout);
        return;
    }
    putchar('"');
    for (const char *c = text; *c; c++) {
        if (*c == '"')
            putchar('"');
        putchar(*c);
    }
    putchar('"');
}

static void print_csv(const pf_queue_frame_details *details)
{
    printf("frame,task,attempt,worker,peak_rss_bytes,peak_device_bytes,bytes_written,stage,"
           "wall_ms,skipped,decision\n");
    for (size_t i = 0; i < details->frame_count; i++) {
        const pf_queue_frame_detail *frame = &details->frames[i];
        for (size_t s = 0; s < frame->stage_count; s++) {
            const pf_queue_frame_stage *stage = &details->stages[frame->first_stage + s];
            printf("%d,%" PRId64 ",%d,", frame->frame, frame->task_id, frame->attempt);
            print_csv_text(frame->worker_name);
            printf(",%" PRId64 ",%" PRId64 ",%" PRId64 ",", frame->peak_rss,
                   frame->peak_device_memory, frame->bytes_written);
            print_csv_text(stage->stage);
            printf(",%.4f,%d,", stage->wall_ms, stage->skipped ? 1 : 0);
            print_csv_text(stage->decision);
            putchar('\n');
        }
    }
}

int pf_timings_print_json(cJSON *root)
{
    char *text = root ? cJSON_Print(root) : NULL;
    cJSON_Delete(root);
    if (!text)
        return pf_cli_fail(COMMAND, 1, "out of memory formatting JSON");
    printf("%s\n", text);
    cJSON_free(text);
    return 0;
}

int pf_timings_print_frames(pf_queue *queue, int64_t job_id, const char *format)
{
    pf_queue_frame_details details;
    pf_error err = {0};
    pf_status status = pf_queue_frame_details_get(queue, job_id, &details, &err);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    int code = 0;
    if (!strcmp(format, "csv"))
        print_csv(&details);
    else if (!strcmp(format, "json"))
        code = pf_timings_print_json(pf_monitor_frames_json(job_id, &details, SIZE_MAX));
    else
        print_table(&details);
    pf_queue_frame_details_free(&details);
    return code;
}
