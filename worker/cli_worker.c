/*
 * photonfarm worker: pulls frames from the queue and renders them until told
 * to stop (DESIGN.md §7; the loop itself is worker_loop.c).
 */
#include "cli_queue.h"
#include "pf_cli.h"
#include "worker_loop.h"

#include <stdio.h>
#include <sys/stat.h>
#include <string.h>

#define COMMAND "worker"
/* Default lease: pf_queue's own default (30 s), long enough for a slow frame
 * between two heartbeats at a third of it. */
#define DEFAULT_LEASE_SECONDS 30
#define MAX_LEASE_SECONDS 86400
/* Idle-exit bound: a day; "forever" is the default (no --idle-exit). */
#define MAX_IDLE_EXIT_SECONDS 86400

static void usage(FILE *out)
{
    fprintf(out,
            "usage: photonfarm worker [options]\n"
            "\n"
            "Claims frames from the queue and renders them, one at a time, until\n"
            "SIGINT/SIGTERM (finish the current frame, then exit 0; a second signal\n"
            "releases it to the queue and exits).\n"
            "\n"
            "  --db PATH            queue database (default $PHOTONFARM_DB, else " PF_CLI_DEFAULT_DB ")\n"
            "  --once               exit as soon as no frame is eligible\n"
            "  --create-db          create the queue database when it does not exist\n"
            "                       (default: refused, so a misspelt --db is not a new queue)\n"
            "  --max-frames N       exit after rendering N frames\n"
            "  --idle-exit SECONDS  exit after SECONDS without work\n"
            "  --device D           device index or name substring (see photonfarm devices)\n"
            "  --cache-dir DIR      compiled-shader cache shared by this machine's processes\n"
            "                       (default $PHOTONFARM_CACHE_DIR, else ~/.cache/photonfarm;\n"
            "                       none: off)\n"
            "  --name NAME          worker name (default <host>-<pid>)\n"
            "  --lease-seconds S    lease length (default %d); renewed every S/3\n"
            "  --help               this text\n"
            "\n"
            "Log: one line per event on stderr (ts=... level=... event=... job=... frame=...);\n"
            "a progress bar too when stderr is a terminal.\n"
            "Exit status: 0 ok, 1 runtime failure, 2 bad usage or input.\n",
            DEFAULT_LEASE_SECONDS);
}

int pf_cli_worker(int argc, char **argv)
{
    pf_worker_config config = {0};
    config.idle_exit_seconds = -1;
    config.lease_seconds = DEFAULT_LEASE_SECONDS;
    const char *db = NULL;
    int create_db = 0;
    const char *cache_option = NULL;
    char cache_dir[PF_CLI_PATH_MAX];
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        const char *value = i + 1 < argc ? argv[i + 1] : NULL;
        int64_t number;
        if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(arg, "--once")) {
            config.once = 1;
            continue;
        } else if (!strcmp(arg, "--create-db")) {
            create_db = 1;
            continue;
        } else if (strncmp(arg, "--", 2) != 0) {
            return pf_cli_fail(COMMAND, 2, "unexpected argument '%s' (see --help)", arg);
        } else if (!value) {
            return pf_cli_fail(COMMAND, 2, "%s needs a value (see --help)", arg);
        } else if (!strcmp(arg, "--db")) {
            db = value;
        } else if (!strcmp(arg, "--device")) {
            config.device = value;
        } else if (!strcmp(arg, "--cache-dir")) {
            cache_option = value;
        } else if (!strcmp(arg, "--name")) {
            if (!*value || strlen(value) >= PF_QUEUE_NAME_MAX)
                return pf_cli_fail(COMMAND, 2, "--name '%s': expected 1..%d characters", value,
                                   PF_QUEUE_NAME_MAX - 1);
            config.name = value;
        } else if (!strcmp(arg, "--max-frames")) {
            if (!pf_cli_parse_int(value, 1, INT64_MAX, &number))
                return pf_cli_fail(COMMAND, 2, "--max-frames '%s': expected a positive integer",
                                   value);
            config.max_frames = number;
        } else if (!strcmp(arg, "--idle-exit")) {
            if (!pf_cli_parse_int(value, 0, MAX_IDLE_EXIT_SECONDS, &number))
                return pf_cli_fail(COMMAND, 2, "--idle-exit '%s': expected seconds 0..%d", value,
                                   MAX_IDLE_EXIT_SECONDS);
            config.idle_exit_seconds = (double)number;
        } else if (!strcmp(arg, "--lease-seconds")) {
            if (!pf_cli_parse_int(value, 1, MAX_LEASE_SECONDS, &number))
                return pf_cli_fail(COMMAND, 2, "--lease-seconds '%s': expected 1..%d", value,
                                   MAX_LEASE_SECONDS);
            config.lease_seconds = (double)number;
        } else {
            return pf_cli_fail(COMMAND, 2, "unknown option '%s' (see --help)", arg);
        }
        i++;
    }
    config.db_path = pf_cli_db_path(db);
    /* A misspelt --db must not become an empty queue this worker then waits on forever. */
    struct stat info;
    if (!create_db && stat(config.db_path, &info) != 0)
        return pf_cli_fail(COMMAND, 2,
                           "no queue database at %s (photonfarm enqueue creates one; "
                           "--create-db starts an empty one)",
                           config.db_path);
    config.cache_dir = pf_cli_cache_dir(COMMAND, cache_option, cache_dir, sizeof cache_dir);
    return pf_worker_run(&config);
}
