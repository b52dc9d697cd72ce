/*
 * photonfarm serve [--listen ADDRESS:PORT] [--token-file PATH] [--db ...]: the farm monitor
 * in a browser (monitor/pf_monitor.h, issue 41). Read-only unless started with an action
 * token; a non-loopback address without one is refused.
 */
#include "cli_queue.h"
#include "pf_cli.h"
#include "pf_monitor.h"
#include "pf_render.h"
#include "storage_roots.h"

#include <errno.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define COMMAND "serve"
#define DEFAULT_LISTEN "127.0.0.1:8080"
/* A token is a line of printable text, at most this long. */
#define TOKEN_MAX 256
#define TOKEN_MIN 16

static volatile sig_atomic_t stop_requested;

static void on_stop(int signal_number)
{
    (void)signal_number;
    stop_requested = 1;
}

/* What the monitor's callbacks need. */
typedef struct serve_context {
    const char *address;
    const pf_storage *storage;
} serve_context;

static void report_listening(uint16_t port, void *user)
{
    const serve_context *context = user;
    printf("photonfarm serve: listening on http://%s:%u/\n", context->address, (unsigned)port);
    fflush(stdout);
}

/* A job's frame file as a worker of this farm would write it, refused outside the output
 * roots (after symbolic links) as the worker refuses it. */
static int frame_path(const char *pattern, int64_t frame, char *out, size_t size, void *user)
{
    const serve_context *context = user;
    char resolved[PATH_MAX];
    pf_error err = {0};
    return pf_roots_output_resolve(&context->storage->output, pattern, resolved,
                                   sizeof resolved, &err) == PF_OK &&
           pf_frame_output_path(resolved, frame, out, size) &&
           pf_roots_check_output_file(&context->storage->output, out, &err) == PF_OK;
}

/* The token: the file's first line, without its newline; 0, or 2 after printing why. */
static int read_token(const char *path, char *token, size_t size)
{
    FILE *file = fopen(path, "r");
    if (!file)
        return pf_cli_fail(COMMAND, 2, "--token-file %s: %s", path, strerror(errno));
    int read = fgets(token, (int)size, file) != NULL;
    fclose(file);
    token[read ? strcspn(token, "\r\n") : 0] = '\0';
    size_t length = strlen(token);
    for (size_t i = 0; i < length; i++)
        if (token[i] < 0x21 || token[i] > 0x7e)
            return pf_cli_fail(COMMAND, 2, "--token-file %s: the token must be printable "
                               "ASCII without spaces", path);
    if (length < TOKEN_MIN || length + 1 >= size)
        return pf_cli_fail(COMMAND, 2, "--token-file %s: the token must be %d to %zu "
                           "characters on the file's first line",
                           path, TOKEN_MIN, size - 2);
    return 0;
}

/* "ADDRESS:PORT" into address (the numeric part) and port; 0, or 2 after printing why. */
static int parse_listen(const char *text, char *address, size_t size, uint16_t *port)
{
    const char *colon = strrchr(text, ':');
    int64_t number = -1;
    if (!colon || colon == text || (size_t)(colon - text) >= size ||
        !pf_cli_parse_int(colon + 1, 0, 65535, &number))
        return pf_cli_fail(COMMAND, 2, "--listen '%s': expected ADDRESS:PORT, e.g. %s", text,
                           DEFAULT_LISTEN);
    memcpy(address, text, (size_t)(colon - text));
    address[colon - text] = '\0';
    *port = (uint16_t)number;
    return 0;
}

int pf_cli_serve(int argc, char **argv)
{
    const char *db = NULL, *listen = DEFAULT_LISTEN, *token_file = NULL;
    int64_t poll_ms = PF_MONITOR_DEFAULT_POLL_MS, rate = PF_MONITOR_DEFAULT_RATE;
    pf_storage storage;
    pf_storage_init(&storage);
    const pf_cli_option options[] = {
        {"--listen", NULL, "ADDRESS:PORT",
         "where to serve (port 0: any free one); an address\nother than loopback needs "
         "--token-file",
         DEFAULT_LISTEN, pf_cli_store_text, &listen, 0, 0, NULL},
        {"--token-file", NULL, "PATH",
         "allow actions (pause, resume, cancel, retry, priority)\nto requests that send this file's "
         "first line in the\nX-Photonfarm-Token header",
         "read-only", pf_cli_store_text, &token_file, 0, 0, NULL},
        {"--poll-ms", NULL, "MS", "how often the queue is read for every client", "500",
         pf_cli_store_int, &poll_ms, 50, 60000, NULL},
        {"--rate-limit", NULL, "N",
         "requests per second from one client address (2 s\nworth at once); beyond it 429 "
         "with Retry-After;\n0: no limit",
         "100", pf_cli_store_int, &rate, 0, 1000000, NULL},
        pf_cli_db_option(&db), pf_roots_option(&storage.scene), pf_roots_option(&storage.output)};
    pf_cli_command command = {
        .name = COMMAND,
        .synopsis = "[options]",
        .description = "Serves the farm monitor: jobs, frames, workers and stage timings,\n"
                       "live in a browser, and the same as JSON under /api/ (README). One\n"
                       "read of the queue per poll serves every client.",
        .options = options,
        .option_count = sizeof options / sizeof options[0],
    };
    int help = 0;
    int code = pf_cli_parse(&command, argc, argv, &help);
    if (code || help)
        return code;
    char address[64], token[TOKEN_MAX + 2];
    uint16_t port = 0;
    code = pf_storage_finish(COMMAND, &storage);
    if (!code)
        code = parse_listen(listen, address, sizeof address, &port);
    if (!code && token_file)
        code = read_token(token_file, token, sizeof token);
    if (code)
        return code;
    /* The queue must exist: a monitor never creates an empty one. */
    pf_queue *queue = NULL;
    const char *db_path = pf_cli_db_path(db);
    code = pf_cli_open_queue(COMMAND, db_path, 1, &queue);
    pf_queue_close(queue);
    if (code)
        return code;
    signal(SIGINT, on_stop);
    signal(SIGTERM, on_stop);
    signal(SIGPIPE, SIG_IGN);
    serve_context context = {address, &storage};
    pf_monitor_config config = {.db_path = db_path,
                                .address = address,
                                .port = port,
                                .token = token_file ? token : NULL,
                                .poll_ms = (int)poll_ms,
                                .rate_per_second = (double)rate,
                                .listening = report_listening,
                                .user = &context,
                                .frame_path = frame_path};
    pf_error err = {0};
    pf_status status = pf_monitor_run(&config, &stop_requested, &err);
    memset(token, 0, sizeof token);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    return 0;
}
