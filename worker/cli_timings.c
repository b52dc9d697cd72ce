/*
 * photonfarm timings JOB [--frames] [--format table|csv|json]: per-stage
 * statistics of a job from its recorded stage rows — count, skipped count,
 * min / median / p95 / max and total of wall and GPU milliseconds — the job's
 * totals, the same statistics of its frames' peak memory and bytes written,
 * its slowest frames, and how often each stage took each decision its rows
 * record (bih_build: reused / refit / rebuilt / built; table and JSON). With
 * --frames, every frame instead (timings_frames.c).
 */
#include "cli_queue.h"
#include "pf_cli.h"
#include "json_views.h"
#include "timings_frames.h"

#include <cjson/cJSON.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define COMMAND "timings"
#define SLOWEST_FRAMES 5

/* Each frame's peak memory and bytes written: min / median / p95 / max over the frames. */
static void print_resources(const pf_queue_timings *timings)
{
    const struct {
        const char *what;
        const pf_queue_stat *stat;
    } rows[] = {{"peak rss", &timings->peak_rss},
                {"peak device", &timings->peak_device_memory},
                {"written", &timings->bytes_written}};
    if (timings->peak_rss.count + timings->peak_device_memory.count +
            timings->bytes_written.count == 0)
        return;
    printf("\nper frame      %6s | %10s %10s %10s %10s\n", "frames", "min", "median", "p95",
           "max");
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        char values[4][32];
        pf_cli_format_bytes((int64_t)rows[i].stat->min, values[0], sizeof values[0]);
        pf_cli_format_bytes((int64_t)rows[i].stat->median, values[1], sizeof values[1]);
        pf_cli_format_bytes((int64_t)rows[i].stat->p95, values[2], sizeof values[2]);
        pf_cli_format_bytes((int64_t)rows[i].stat->max, values[3], sizeof values[3]);
        printf("%-14s %6" PRId64 " | %10s %10s %10s %10s\n", rows[i].what, rows[i].stat->count,
               values[0], values[1], values[2], values[3]);
    }
}

static void print_table(int64_t job_id, const pf_queue_timings *timings)
{
    printf("job %" PRId64 ": %" PRId64 " frame(s) with timings\n\n", job_id, timings->frames);
    printf("%-14s %6s %7s | %9s %9s %9s %9s %11s | %9s %9s %9s %9s %11s\n", "stage", "count",
           "skipped", "wall min", "median", "p95", "max", "total", "gpu min", "median", "p95",
           "max", "total");
    for (size_t i = 0; i < timings->stage_count; i++) {
        const pf_queue_stage_stats *stage = &timings->stages[i];
        printf("%-14s %6" PRId64 " %7" PRId64 " | %9.2f %9.2f %9.2f %9.2f %11.2f |", stage->stage,
               stage->count, stage->skipped, stage->wall.min, stage->wall.median, stage->wall.p95,
               stage->wall.max, stage->wall.total);
        if (stage->gpu.count > 0)
            printf(" %9.2f %9.2f %9.2f %9.2f %11.2f\n", stage->gpu.min, stage->gpu.median,
                   stage->gpu.p95, stage->gpu.max, stage->gpu.total);
        else
            printf(" %9s %9s %9s %9s %11s\n", "-", "-", "-", "-", "-");
    }
    printf("\ntotal: wall %.2f ms, gpu %.2f ms\n", timings->total_wall_ms, timings->total_gpu_ms);
    print_resources(timings);
    if (timings->slowest_count > 0)
        printf("slowest frames:");
    for (size_t i = 0; i < timings->slowest_count; i++)
        printf(" %d (%.2f ms)%s", timings->slowest[i].frame, timings->slowest[i].wall_ms,
               i + 1 < timings->slowest_count ? "," : "\n");
    if (timings->build_count > 0)
        printf("\nrendered by (frames):\n");
    /* Rows any worker wrote, shown escaped (printable.c). */
    char shown[2][PF_CLI_PATH_MAX];
    for (size_t i = 0; i < timings->build_count; i++)
        printf("%6" PRId64 "  photonfarm %s\n", timings->builds[i].frames,
               pf_cli_printable(timings->builds[i].build, shown[0], sizeof shown[0]));
    if (timings->decision_count > 0)
        printf("\ndecisions (frames):\n");
    for (size_t i = 0; i < timings->decision_count; i++)
        printf("%-14s %6" PRId64 "  %s\n",
               pf_cli_printable(timings->decisions[i].stage, shown[0], sizeof shown[0]),
               timings->decisions[i].count,
               pf_cli_printable(timings->decisions[i].decision, shown[1], sizeof shown[1]));
}

static void print_csv(const pf_queue_timings *timings)
{
    printf("stage,count,skipped,wall_min_ms,wall_median_ms,wall_p95_ms,wall_max_ms,"
           "wall_total_ms,gpu_count,gpu_min_ms,gpu_median_ms,gpu_p95_ms,gpu_max_ms,"
           "gpu_total_ms\n");
    for (size_t i = 0; i < timings->stage_count; i++) {
        const pf_queue_stage_stats *stage = &timings->stages[i];
        printf("%s,%" PRId64 ",%" PRId64 ",%.4f,%.4f,%.4f,%.4f,%.4f,%" PRId64
               ",%.4f,%.4f,%.4f,%.4f,%.4f\n",
               stage->stage, stage->count, stage->skipped, stage->wall.min, stage->wall.median,
               stage->wall.p95, stage->wall.max, stage->wall.total, stage->gpu.count,
               stage->gpu.min, stage->gpu.median, stage->gpu.p95, stage->gpu.max,
               stage->gpu.total);
    }
}

int pf_cli_timings(int argc, char **argv)
{
    const char *db = NULL, *format = "table", *job_text = NULL;
    int frames = 0;
    const pf_cli_option options[] = {
        {"--format", NULL, "F", "table, csv or json", "table", pf_cli_store_choice, &format, 0, 0,
         "table|csv|json"},
        {"--frames", NULL, NULL,
         "every frame instead: worker, attempt, wall time per\nstage, peak memory, bytes "
         "written, decisions",
         "the statistics", pf_cli_store_flag, &frames, 0, 0, NULL},
        pf_cli_db_option(&db),
    };
    char description[512];
    snprintf(description, sizeof description,
             "Per stage: frames that ran it, frames that skipped it, min/median/p95/max\n"
             "and total of wall and GPU time in ms; then totals, the same statistics of\n"
             "each frame's peak memory (the worker's resident memory, its device's) and\n"
             "bytes written, the %d slowest frames and the decisions stages recorded\n"
             "(e.g. bih_build reused, refit, rebuilt).",
             SLOWEST_FRAMES);
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "JOB [options]",
        .description = description,
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
    pf_queue *queue = NULL;
    code = pf_cli_open_queue(COMMAND, pf_cli_db_path(db), 1, &queue);
    if (code)
        return code;
    if (frames) {
        code = pf_timings_print_frames(queue, job_id, format);
        pf_queue_close(queue);
        return code;
    }
    pf_error err = {0};
    pf_queue_timings timings = {0};
    pf_status status = pf_queue_timings_get(queue, job_id, SLOWEST_FRAMES, &timings, &err);
    pf_queue_close(queue);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    if (!strcmp(format, "csv"))
        print_csv(&timings);
    else if (!strcmp(format, "json"))
        code = pf_timings_print_json(pf_monitor_timings_json(job_id, &timings));
    else
        print_table(job_id, &timings);
    pf_queue_timings_free(&timings);
    return code;
}
