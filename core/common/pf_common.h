/*
 * core/common: what every photonfarm module shares — status codes, the error
 * record that carries a message naming the file/element/row at fault, warning
 * and log output, and a monotonic clock. Nothing here touches Vulkan, SQLite
 * or libuv.
 */
#ifndef PF_COMMON_H
#define PF_COMMON_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

/* Every fallible call returns a pf_status: 0 on success, negative on failure. */
typedef enum pf_status {
    PF_OK = 0,
    PF_ERR_IO = -1,          /* file missing, unreadable, unwritable */
    PF_ERR_FORMAT = -2,      /* file exists but its content is malformed */
    PF_ERR_INVALID = -3,     /* bad argument or value from the caller/user */
    PF_ERR_VULKAN = -4,      /* a Vulkan call failed */
    PF_ERR_NOMEM = -5,       /* allocation failed */
    PF_ERR_LIMIT = -6,       /* a device or format limit would be exceeded */
    PF_ERR_UNSUPPORTED = -7, /* valid input we cannot handle */
    PF_ERR_INTERNAL = -8     /* a bug: an invariant did not hold */
} pf_status;

#define PF_ERROR_MESSAGE_MAX 1024

/* Rec. 709 luminance weights: what picks lights by power, weighs photons and stops the
 * denoiser's edges (the shaders' light_luminance and denoise_luminance hold the same). A
 * float use casts them (each cast is the float literal's value). */
#define PF_LUMINANCE_R 0.2126
#define PF_LUMINANCE_G 0.7152
#define PF_LUMINANCE_B 0.0722

/* Filled by a failing call; the message names the cause (file, element, row). */
typedef struct pf_error {
    pf_status status;
    char message[PF_ERROR_MESSAGE_MAX];
} pf_error;

/* Short name of a status ("io", "format", ...). Never NULL. */
const char *pf_status_name(pf_status status);

/*
 * Records status and a printf-style message in err (err may be NULL) and
 * returns status, so callers can write `return pf_error_set(err, ...)`.
 */
pf_status pf_error_set(pf_error *err, pf_status status, const char *format, ...)
    __attribute__((format(printf, 3, 4)));

/* Prefixes err->message with "prefix: " (context added by an outer caller). */
void pf_error_prefix(pf_error *err, const char *format, ...)
    __attribute__((format(printf, 2, 3)));

/* Process exit code for a status: 0 ok, 2 bad usage/input, 1 anything else. */
int pf_status_exit_code(pf_status status);

typedef enum pf_log_level {
    PF_LOG_DEBUG = 0,
    PF_LOG_INFO = 1,
    PF_LOG_WARN = 2,
    PF_LOG_ERROR = 3
} pf_log_level;

/* Where log lines go. The default sink writes "level: message" to stderr. */
typedef void (*pf_log_sink)(pf_log_level level, const char *message, void *user);

/* Replaces the sink (NULL restores the default). Not thread-safe against logging. */
void pf_log_set_sink(pf_log_sink sink, void *user);
/* Lines below min_level are dropped. Default: PF_LOG_INFO. */
void pf_log_set_level(pf_log_level min_level);
void pf_log(pf_log_level level, const char *format, ...) __attribute__((format(printf, 2, 3)));
/* Number of PF_LOG_WARN lines emitted so far (tests assert warnings happened). */
uint32_t pf_log_warning_count(void);

/* Monotonic clock in milliseconds. */
double pf_time_ms(void);

/* The cores online, 1..most: how many slices pf_run_parallel is worth given. */
uint32_t pf_cpu_cores(uint32_t most);
/*
 * Runs fn(items + i·item_size) for every i in [0, count): item 0 on the calling thread,
 * each other on a thread of its own (the caller runs an item whose thread could not
 * start), and returns when all are done. Items that write disjoint memory need no locks.
 */
void pf_run_parallel(void *items, size_t item_size, uint32_t count, void (*fn)(void *item));
/*
 * Calls fn(context, begin, end) over [0, count) in contiguous slices, one a thread as
 * pf_run_parallel runs them: as many slices as there are cores, at most `most` (and
 * PF_RUN_RANGES_MAX), each at least min_length long where count allows (a small range
 * runs whole on the calling thread). For loops whose iterations write disjoint memory: a
 * frame's pixels, a copy's bytes.
 */
#define PF_RUN_RANGES_MAX 64u
void pf_run_ranges(uint64_t count, uint32_t most, uint64_t min_length,
                   void (*fn)(void *context, uint64_t begin, uint64_t end), void *context);

/*
 * Vose's alias method (Vose 1991, "A linear algorithm for generating random
 * numbers with a given distribution"; pbrt-v4 AliasTable): picks index i
 * with probability weights[i] / sum in O(1). To sample: column c uniform in
 * [0, count), then keep c if a second uniform is < threshold[c], else take
 * alias[c]. Weights must be finite and >= 0 with a positive sum
 * (PF_ERR_INVALID naming the first bad weight otherwise); PF_ERR_NOMEM.
 */
pf_status pf_alias_table_build(const double *weights, uint32_t count, float *threshold,
                               uint32_t *alias, pf_error *err);

#endif
