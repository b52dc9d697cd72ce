/* Structured event lines for the worker (see log.h). */
#include "log.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <time.h>

#define LINE_MAX_BYTES 2048

static pthread_mutex_t log_mutex = PTHREAD_MUTEX_INITIALIZER;
static pf_wlog_hook log_hook;
static void *log_hook_user;

/* The capture (under log_mutex): the first lines in head, then the last ones in a ring of
 * lines whose bytes stay within TAIL_BYTES; what falls out of the ring is counted. The
 * marker line between them takes at most MARKER_BYTES. */
#define HEAD_BYTES (PF_WLOG_CAPTURE_MAX / 4)
#define MARKER_BYTES 64
#define TAIL_BYTES (PF_WLOG_CAPTURE_MAX - HEAD_BYTES - MARKER_BYTES - 1)
#define TAIL_LINES 2048
static struct {
    int active;
    const void *owner; /* pf_wlog_capture_begin's */
    char head[HEAD_BYTES];
    size_t head_used;
    int head_full; /* a line did not fit: every later line goes to the tail */
    char *tail[TAIL_LINES];
    size_t tail_first, tail_count, tail_bytes;
    long dropped;
} capture;

static void capture_reset(void)
{
    for (size_t i = 0; i < capture.tail_count; i++)
        free(capture.tail[(capture.tail_first + i) % TAIL_LINES]);
    memset(&capture, 0, sizeof capture);
}

static void capture_drop_oldest(void)
{
    char **oldest = &capture.tail[capture.tail_first];
    capture.tail_bytes -= strlen(*oldest);
    free(*oldest);
    *oldest = NULL;
    capture.tail_first = (capture.tail_first + 1) % TAIL_LINES;
    capture.tail_count--;
    capture.dropped++;
}

static void capture_line(const char *line, size_t length)
{
    if (!capture.head_full && capture.head_used + length <= HEAD_BYTES) {
        memcpy(capture.head + capture.head_used, line, length);
        capture.head_used += length;
        return;
    }
    capture.head_full = 1;
    if (length > TAIL_BYTES) {
        capture.dropped++;
        return;
    }
    while (capture.tail_count > 0 &&
           (capture.tail_count == TAIL_LINES || capture.tail_bytes + length > TAIL_BYTES))
        capture_drop_oldest();
    char *copy = strdup(line);
    if (!copy) {
        capture.dropped++;
        return;
    }
    capture.tail[(capture.tail_first + capture.tail_count) % TAIL_LINES] = copy;
    capture.tail_count++;
    capture.tail_bytes += length;
}

void pf_wlog_capture_begin(const void *owner)
{
    pthread_mutex_lock(&log_mutex);
    capture_reset();
    capture.active = 1;
    capture.owner = owner;
    pthread_mutex_unlock(&log_mutex);
}

/* Under log_mutex: line at the end of late, within PF_WLOG_LATE_MAX. */
static void late_line(pf_wlog_late *late, const char *line, size_t length)
{
    char *grown = late->used + length <= PF_WLOG_LATE_MAX
                      ? realloc(late->text, late->used + length + 1)
                      : NULL;
    if (!grown) {
        late->dropped++;
        return;
    }
    memcpy(grown + late->used, line, length + 1);
    late->text = grown;
    late->used += length;
}

char *pf_wlog_late_take(pf_wlog_late *late)
{
    pthread_mutex_lock(&log_mutex);
    char *text = late->text;
    size_t used = late->used;
    long dropped = late->dropped;
    *late = (pf_wlog_late){0};
    pthread_mutex_unlock(&log_mutex);
    if (dropped > 0) {
        char *grown = realloc(text, used + MARKER_BYTES);
        if (grown) {
            snprintf(grown + used, MARKER_BYTES, "... %ld lines left out ...\n", dropped);
            text = grown;
        }
    }
    return text;
}

char *pf_wlog_capture_end(void)
{
    pthread_mutex_lock(&log_mutex);
    char *text = NULL;
    if (capture.active &&
        (text = malloc(capture.head_used + MARKER_BYTES + capture.tail_bytes + 1))) {
        size_t used = capture.head_used;
        memcpy(text, capture.head, used);
        if (capture.dropped > 0)
            used += (size_t)snprintf(text + used, MARKER_BYTES, "... %ld lines left out ...\n",
                                     capture.dropped);
        for (size_t i = 0; i < capture.tail_count; i++) {
            const char *line = capture.tail[(capture.tail_first + i) % TAIL_LINES];
            size_t length = strlen(line);
            memcpy(text + used, line, length);
            used += length;
        }
        text[used] = '\0';
    }
    capture_reset();
    pthread_mutex_unlock(&log_mutex);
    return text;
}

void pf_wlog_set_hook(pf_wlog_hook hook, void *user)
{
    pthread_mutex_lock(&log_mutex);
    log_hook = hook;
    log_hook_user = user;
    pthread_mutex_unlock(&log_mutex);
}

void pf_wlog_exclusive(void (*fn)(void *user), void *user)
{
    pthread_mutex_lock(&log_mutex);
    fn(user);
    pthread_mutex_unlock(&log_mutex);
}

static const char *level_name(pf_log_level level)
{
    switch (level) {
    case PF_LOG_DEBUG: return "debug";
    case PF_LOG_INFO: return "info";
    case PF_LOG_WARN: return "warn";
    default: return "error";
    }
}

/* A line's routes: every capture (pf_wlog), or only owner's with late for the rest. */
typedef struct line_route {
    int about; /* pf_wlog_about */
    const void *owner;
    pf_wlog_late *late;
} line_route;

static void log_line(line_route route, pf_log_level level, const char *event,
                     const char *format, va_list args)
{
    char line[LINE_MAX_BYTES];
    struct timeval now;
    gettimeofday(&now, NULL);
    struct tm utc;
    gmtime_r(&now.tv_sec, &utc);
    size_t length = strftime(line, sizeof line, "ts=%Y-%m-%dT%H:%M:%S", &utc);
    int written = snprintf(line + length, sizeof line - length, ".%03ldZ level=%s event=%s",
                           (long)(now.tv_usec / 1000), level_name(level), event);
    length += written > 0 ? (size_t)written : 0;
    if (format && *format && length + 1 < sizeof line) {
        line[length++] = ' ';
        written = vsnprintf(line + length, sizeof line - length, format, args);
        length += written > 0 ? (size_t)written : 0;
    }
    if (length > sizeof line - 2)
        length = sizeof line - 2;
    line[length++] = '\n';
    line[length] = '\0';
    pthread_mutex_lock(&log_mutex);
    if (log_hook)
        log_hook(1, log_hook_user);
    fputs(line, stderr);
    fflush(stderr);
    int captured = capture.active && (!route.about || capture.owner == route.owner);
    if (captured)
        capture_line(line, length);
    else if (route.about && route.late)
        late_line(route.late, line, length);
    if (log_hook)
        log_hook(0, log_hook_user);
    pthread_mutex_unlock(&log_mutex);
}

void pf_wlog(pf_log_level level, const char *event, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    log_line((line_route){0, NULL, NULL}, level, event, format, args);
    va_end(args);
}

void pf_wlog_about(const void *owner, pf_wlog_late *late, pf_log_level level,
                   const char *event, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    log_line((line_route){1, owner, late}, level, event, format, args);
    va_end(args);
}

const char *pf_wlog_quote(const char *text, char *out, size_t size)
{
    size_t used = 0;
    if (size < 3) {
        if (size)
            out[0] = '\0';
        return out;
    }
    out[used++] = '"';
    for (const char *c = text ? text : ""; *c && used + 4 < size; c++) {
        unsigned char ch = (unsigned char)*c;
        if (ch == '"' || ch == '\\') {
            out[used++] = '\\';
            out[used++] = (char)ch;
        } else if (ch < 0x20) {
            out[used++] = ' ';
        } else {
            out[used++] = (char)ch;
        }
    }
    out[used++] = '"';
    out[used] = '\0';
    return out;
}

static void core_sink(pf_log_level level, const char *message, void *user)
{
    (void)user;
    char quoted[PF_ERROR_MESSAGE_MAX + 8];
    pf_wlog(level, "core", "message=%s", pf_wlog_quote(message, quoted, sizeof quoted));
}

void pf_wlog_capture_core(void)
{
    pf_log_set_sink(core_sink, NULL);
}
