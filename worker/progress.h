/*
 * Progress display (DESIGN.md §1: progress on a terminal, plain lines
 * otherwise). pf_progress_bar formats a bar into a string (used by `status`);
 * a pf_progress keeps one live line on a TTY, redrawn in place and kept below
 * the log lines, and on anything else prints a plain line per update.
 */
#ifndef PF_WORKER_PROGRESS_H
#define PF_WORKER_PROGRESS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Writes "[#######.............]  12/48  25%" (bar_width cells) into out. */
void pf_progress_bar(char *out, size_t size, int64_t done, int64_t total, int bar_width);

typedef struct pf_progress {
    FILE *stream;
    int is_tty;
    int shown;          /* a live line is on screen (TTY only) */
    char line[512];     /* the current live line */
} pf_progress;

/* Binds progress to stream (a TTY gets a live line). */
void pf_progress_init(pf_progress *progress, FILE *stream);
/* Shows "label [bar] done/total pct" (TTY: redraws in place; else one plain line). */
void pf_progress_update(pf_progress *progress, const char *label, int64_t done, int64_t total);
/* Removes the live line (TTY) before other output, or for good at exit. */
void pf_progress_clear(pf_progress *progress);
/* Leaves the live line on screen for good (ends it with a newline). */
void pf_progress_finish(pf_progress *progress);
/* Draws the live line again after other output. */
void pf_progress_redraw(pf_progress *progress);

#endif
