#include "pf_common.h"

#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

const char *pf_status_name(pf_status status)
{
    switch (status) {
    case PF_OK: return "ok";
    case PF_ERR_IO: return "io";
    case PF_ERR_FORMAT: return "format";
    case PF_ERR_INVALID: return "invalid";
    case PF_ERR_VULKAN: return "vulkan";
    case PF_ERR_NOMEM: return "out of memory";
    case PF_ERR_LIMIT: return "limit";
    case PF_ERR_UNSUPPORTED: return "unsupported";
    case PF_ERR_INTERNAL: return "internal";
    }
    return "unknown";
}

pf_status pf_error_set(pf_error *err, pf_status status, const char *format, ...)
{
    if (err) {
        va_list args;
        va_start(args, format);
        err->status = status;
        vsnprintf(err->message, sizeof err->message, format, args);
        va_end(args);
    }
    return status;
}

void pf_error_prefix(pf_error *err, const char *format, ...)
{
    if (!err)
        return;
    char prefix[PF_ERROR_MESSAGE_MAX];
    va_list args;
    va_start(args, format);
    int written = vsnprintf(prefix, sizeof prefix, format, args);
    va_end(args);
    if (written < 0)
        return;
    /* Shift the message right and put "prefix: " in front; the tail is cut if long. */
    size_t prefix_length = strlen(prefix);
    size_t message_length = strlen(err->message);
    size_t room = sizeof err->message - 1;
    size_t head = prefix_length + 2 < room ? prefix_length + 2 : room;
    size_t kept = message_length < room - head ? message_length : room - head;
    memmove(err->message + head, err->message, kept);
    err->message[head + kept] = '\0';
    memcpy(err->message, prefix, head < prefix_length ? head : prefix_length);
    if (head == prefix_length + 2) {
        err->message[prefix_length] = ':';
        err->message[prefix_length + 1] = ' ';
    }
}

int pf_status_exit_code(pf_status status)
{
    switch (status) {
    case PF_OK: return 0;
    case PF_ERR_IO:
    case PF_ERR_FORMAT:
    case PF_ERR_INVALID:
    case PF_ERR_UNSUPPORTED: return 2;
    default: return 1;
    }
}

static void default_sink(pf_log_level level, const char *message, void *user)
{
    (void)user;
    static const char *names[] = {"debug", "info", "warning", "error"};
    fprintf(stderr, "%s: %s\n", names[level], message);
}

static pf_log_sink log_sink = default_sink;
static void *log_user;
static pf_log_level log_min_level = PF_LOG_INFO;
static atomic_uint warning_count;

void pf_log_set_sink(pf_log_sink sink, void *user)
{
    log_sink = sink ? sink : default_sink;
    log_user = sink ? user : NULL;
}

void pf_log_set_level(pf_log_level min_level) { log_min_level = min_level; }

void pf_log(pf_log_level level, const char *format, ...)
{
    if (level == PF_LOG_WARN)
        atomic_fetch_add(&warning_count, 1);
    if (level < log_min_level)
        return;
    char message[2048];
    va_list args;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    log_sink(level, message, log_user);
}

uint32_t pf_log_warning_count(void) { return atomic_load(&warning_count); }

double pf_time_ms(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec * 1e3 + (double)now.tv_nsec * 1e-6;
}
