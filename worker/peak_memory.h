/*
 * The worker process's peak resident memory per frame (issue 42): the kernel's high-water
 * mark (VmHWM) reset before each frame, so each frame's row says what the host needed for
 * it, device memory that lives in host memory (lavapipe) included.
 */
#ifndef PF_PEAK_MEMORY_H
#define PF_PEAK_MEMORY_H

#include <stdint.h>

/* Starts a new peak from what the process holds now (/proc/self/clear_refs "5", Linux 4.0
 * and later). 1 when reset; 0 when not possible, and the peak then counts from the
 * process's start. */
int pf_peak_rss_reset(void);

/* The process's peak resident memory in bytes since the last reset; -1 when unknown. */
int64_t pf_peak_rss(void);

#endif
