/*
 * photonfarm worker: pulls frames from the queue and renders them until told
 * to stop (DESIGN.md §7; the loop itself is worker_loop.c).
 */
#include "cli_queue.h"
#include "pf_cli.h"
#include "worker_loop.h"

#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <string.h>

#define COMMAND "worker"
/* Default lease: pf_queue's own default (30 s), long enough for a slow frame
 * between two heartbeats at a third of it. */
#define DEFAULT_LEASE_SECONDS 30
#define MAX_LEASE_SECONDS 86400
/* Idle-exit bound: a day; "forever" is the default (no --idle-exit). */
#define MAX_IDLE_EXIT_SECONDS 86400

/* --name: 1..PF_QUEUE_NAME_MAX-1 characters (the queue's column). */
static int store_name(const char *command, const pf_cli_option *option, const char *value)
{
    if (!*value || strlen(value) >= PF_QUEUE_NAME_MAX)
        return pf_cli_fail(command, 2, "--name '%s': expected 1..%d characters", value,
                           PF_QUEUE_NAME_MAX - 1);
    *(const char **)option->target = value;
    return 0;
}

int pf_cli_worker(int argc, char **argv)
{
    pf_worker_config config = {0};
    const char *db = NULL, *cache_option = NULL;
    int create_db = 0, once = 0;
    int64_t max_frames = 0, idle_exit = -1, lease_seconds = DEFAULT_LEASE_SECONDS;
    pf_storage storage;
    pf_storage_init(&storage);
    pf_cli_tags tags = {""};
    char lease_default[32];
    snprintf(lease_default, sizeof lease_default, "%d", DEFAULT_LEASE_SECONDS);
    const pf_cli_option options[] = {
        pf_cli_db_option(&db),
        {"--once", NULL, NULL, "exit as soon as no frame is eligible", "run until signalled",
         pf_cli_store_flag, &once, 0, 0, NULL},
        {"--create-db", NULL, NULL, "create the queue database when it does not exist",
         "refused, so a misspelt --db is not a new queue", pf_cli_store_flag, &create_db, 0, 0,
         NULL},
        {"--max-frames", NULL, "N", "exit after rendering N frames", "no limit",
         pf_cli_store_int, &max_frames, 1, INT64_MAX, NULL},
        {"--idle-exit", NULL, "SECONDS", "exit after SECONDS without work", "never",
         pf_cli_store_int, &idle_exit, 0, MAX_IDLE_EXIT_SECONDS, NULL},
        {"--device", NULL, "D", "device index or name substring (see photonfarm devices)",
         "$PHOTONFARM_DEVICE, else a GPU, else lavapipe", pf_cli_store_text, &config.device, 0,
         0, NULL},
        {"--cache-dir", NULL, "DIR",
         "compiled-shader cache shared by this machine's processes\n(none: off)",
         "$PHOTONFARM_CACHE_DIR, else ~/.cache/photonfarm", pf_cli_store_text, &cache_option, 0,
         0, NULL},
        {"--name", NULL, "NAME", "worker name, 1..127 characters",
         "$PHOTONFARM_WORKER_NAME, else <host>-<pid>",
         store_name, &config.name, 0, 0, NULL},
        {"--lease-seconds", NULL, "S", "lease length; renewed every S/3", lease_default,
         pf_cli_store_int, &lease_seconds, 1, MAX_LEASE_SECONDS, NULL},
        {"--tag", NULL, "NAME",
         "a tag jobs can require (repeatable; letters, digits, . _ -)",
         "$PHOTONFARM_WORKER_TAGS (comma-separated), else none", pf_cli_store_tag, &tags, 0, 0, NULL},
        pf_roots_option(&storage.scene),
        pf_roots_option(&storage.output),
    };
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "[options]",
        .description = "Claims frames from the queue and renders them, one at a time, until\n"
                       "SIGINT/SIGTERM (finish the current frame, then exit 0; a second\n"
                       "signal releases it to the queue and exits).",
        .epilogue = "Log: one line per event on stderr (ts=... level=... event=... job=...\n"
                    "frame=...); a progress bar too when stderr is a terminal.",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
    };
    int help = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    code = pf_storage_finish(COMMAND, &storage);
    if (code)
        return code;
    config.name = pf_cli_worker_name(config.name);
    if (config.name && strlen(config.name) >= PF_QUEUE_NAME_MAX)
        return pf_cli_fail(COMMAND, 2, "$PHOTONFARM_WORKER_NAME: expected 1..%d characters",
                           PF_QUEUE_NAME_MAX - 1);
    /* The tags: --tag's, else $PHOTONFARM_WORKER_TAGS; stored sorted and distinct. */
    const char *tag_text = tags.text[0] ? tags.text : getenv("PHOTONFARM_WORKER_TAGS");
    char normalized[PF_QUEUE_TAGS_MAX];
    pf_error err = {0};
    if (pf_queue_tags_normalize(tag_text, normalized, sizeof normalized, &err) != PF_OK)
        return pf_cli_fail(COMMAND, 2, "%s%s", tags.text[0] ? "--tag: " : "$PHOTONFARM_WORKER_TAGS: ",
                           err.message);
    config.tags = normalized;
    config.storage = &storage;
    config.once = once;
    config.max_frames = max_frames;
    config.idle_exit_seconds = (double)idle_exit;
    config.lease_seconds = (double)lease_seconds;
    char cache_dir[PF_CLI_PATH_MAX];
    config.db_path = pf_cli_db_path(db);
    /* A misspelt --db must not become an empty queue this worker then waits on forever. */
    struct stat info;
    if (!create_db && !pf_queue_is_url(config.db_path) && stat(config.db_path, &info) != 0)
        return pf_cli_fail(COMMAND, 2,
                           "no queue database at %s (photonfarm enqueue creates one; "
                           "--create-db starts an empty one)",
                           config.db_path);
    config.cache_dir = pf_cli_cache_dir(COMMAND, cache_option, cache_dir, sizeof cache_dir);
    return pf_worker_run(&config);
}
