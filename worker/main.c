#include "pf_cli.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

typedef struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} command;

static const command commands[] = {
    {"render", pf_cli_render, "render one frame of a scene to EXR (no queue)"},
    {"compare", pf_cli_compare, "RMSE / relMSE / max error between two EXR images"},
    {"devices", pf_cli_devices, "list Vulkan devices and their key limits"},
    {"enqueue", pf_cli_enqueue, "add a render job (frames of a scene) to the queue"},
    {"worker", pf_cli_worker, "claim and render queued frames until stopped"},
    {"status", pf_cli_status, "jobs, progress bars, running frames, failures"},
    {"timings", pf_cli_timings, "per-stage timing statistics of a job"},
    {"log", pf_cli_log, "what a frame's attempts logged on their workers"},
    {"cancel", pf_cli_cancel, "cancel a job (running frames are discarded)"},
    {"pause", pf_cli_pause, "stop claiming a job's frames"},
    {"resume", pf_cli_resume, "resume a paused job"},
    {"retry", pf_cli_retry, "requeue a job's failed and canceled frames"},
    {"priority", pf_cli_priority, "change a job's priority (higher runs first)"},
    {"depend", pf_cli_depend, "make a job wait for other jobs (or their frames)"},
    {"serve", pf_cli_serve, "the farm monitor in a browser (and JSON under /api/)"},
    {"workers", pf_cli_workers, "registered workers: alive or dead, current frame"},
    {"version", NULL, "the version and git revision of this build (also --version)"},
};

static void usage(FILE *out)
{
    fprintf(out, "usage: photonfarm <command> [options]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-10s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\n'photonfarm <command> --help' describes a command.\n");
}

int pf_cli_fail(const char *command_name, int exit_code, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    fprintf(stderr, "photonfarm %s: ", command_name);
    vfprintf(stderr, format, args);
    fputc('\n', stderr);
    va_end(args);
    return exit_code;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "version")) {
        printf("photonfarm %s\n", pf_version_string());
        return fflush(stdout) == 0 ? 0 : 1;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        if (commands[i].run && !strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    }
    fprintf(stderr, "photonfarm: unknown command '%s'\n\n", argv[1]);
    usage(stderr);
    return 2;
}
