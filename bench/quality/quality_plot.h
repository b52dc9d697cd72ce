/* bench/quality's report: the SVG plot and the time-to-error summary. */
#ifndef QUALITY_PLOT_H
#define QUALITY_PLOT_H

#include <stddef.h>
#include <stdint.h>

typedef struct quality_row {
    const char *renderer; /* "photonfarm", "cycles" */
    const char *preset;   /* a curve: rows with the same renderer and preset, in sweep order */
    const char *knob;     /* what value sets ("spp", "passes") */
    uint32_t value;
    double seconds;
    double relmse;
    double rmse;
} quality_row;

/* relMSE against seconds, log-log, one polyline per curve. 1 when written. */
int quality_plot_svg(const char *path, const char *title, const quality_row *rows, size_t count);

/*
 * Prints, per curve, the seconds at which it reaches relMSE target (log-log
 * interpolation between its two points around the target; "not reached"
 * otherwise), then the fastest photonfarm preset's speed-up over Cycles and
 * over photonfarm's reference.
 */
void quality_summary(const quality_row *rows, size_t count, double target);

#endif
