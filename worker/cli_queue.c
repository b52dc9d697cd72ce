/* Shared pieces of the queue commands (see cli_queue.h). */
#include "cli_queue.h"
#include "pf_cli.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <stdlib.h>
#include <sys/stat.h>

const char *pf_cli_db_path(const char *given)
{
    if (given)
        return given;
    const char *environment = getenv("PHOTONFARM_DB");
    return environment && *environment ? environment : PF_CLI_DEFAULT_DB;
}

int pf_cli_open_queue(const char *command, const char *path, int must_exist, pf_queue **out)
{
    struct stat info;
    pf_error err = {0};
    if (pf_queue_is_url(path)) { /* PostgreSQL: the server says what exists */
        pf_status status = pf_queue_open(path, NULL, out, &err);
        return status == PF_OK ? 0 : pf_cli_fail(command, 2, "%s", err.message);
    }
    if (must_exist && stat(path, &info) != 0)
        return pf_cli_fail(command, 2,
                           "no queue database at %s (photonfarm enqueue creates one; --db or "
                           "$PHOTONFARM_DB choose another)",
                           path);
    /* A queue is created only inside a directory that exists: a typo in its path is bad
     * input (exit 2) for every command alike, not an I/O failure. */
    char dir[4096];
    const char *slash = strrchr(path, '/');
    snprintf(dir, sizeof dir, "%.*s", slash ? (int)(slash == path ? 1 : slash - path) : 1,
             slash ? path : ".");
    if (stat(dir, &info) != 0 || !S_ISDIR(info.st_mode))
        return pf_cli_fail(command, 2, "queue database %s: directory %s does not exist", path,
                           dir);
    pf_status status = pf_queue_open(path, NULL, out, &err);
    if (status != PF_OK)
        return pf_cli_fail(command, status == PF_ERR_IO ? 1 : 2, "%s", err.message);
    return 0;
}

int pf_cli_parse_int(const char *text, int64_t min, int64_t max, int64_t *out)
{
    if (!text || !*text)
        return 0;
    errno = 0;
    char *end = NULL;
    long long value = strtoll(text, &end, 10);
    if (errno || *end || value < min || value > max)
        return 0;
    *out = value;
    return 1;
}
