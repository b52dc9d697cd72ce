/* The SVG plot and the summary of bench/quality (quality_plot.h). */
#include "quality_plot.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define PLOT_W 720.0
#define PLOT_H 480.0
#define MARGIN_L 80.0
#define MARGIN_R 170.0
#define MARGIN_T 40.0
#define MARGIN_B 60.0

static const char *const colours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                      "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

static int same_curve(const quality_row *a, const quality_row *b)
{
    return !strcmp(a->renderer, b->renderer) && !strcmp(a->preset, b->preset);
}

/* Index of the first row of each curve into firsts; returns the number of curves. */
static size_t curves(const quality_row *rows, size_t count, size_t *firsts, size_t max)
{
    size_t n = 0;
    for (size_t i = 0; i < count && n < max; i++) {
        int seen = 0;
        for (size_t c = 0; c < n && !seen; c++)
            seen = same_curve(&rows[firsts[c]], &rows[i]);
        if (!seen)
            firsts[n++] = i;
    }
    return n;
}

int quality_plot_svg(const char *path, const char *title, const quality_row *rows, size_t count)
{
    double t_min = INFINITY, t_max = 0, e_min = INFINITY, e_max = 0;
    for (size_t i = 0; i < count; i++) {
        if (!(rows[i].seconds > 0) || !(rows[i].relmse > 0))
            continue;
        t_min = fmin(t_min, rows[i].seconds);
        t_max = fmax(t_max, rows[i].seconds);
        e_min = fmin(e_min, rows[i].relmse);
        e_max = fmax(e_max, rows[i].relmse);
    }
    if (!(t_max > 0))
        return 0;
    /* Whole decades on both axes. */
    double x0 = floor(log10(t_min)), x1 = ceil(log10(t_max));
    double y0 = floor(log10(fmin(e_min, 0.01))), y1 = ceil(log10(e_max));
    if (x1 <= x0)
        x1 = x0 + 1;
    if (y1 <= y0)
        y1 = y0 + 1;
    FILE *svg = fopen(path, "w");
    if (!svg)
        return 0;
    double pw = PLOT_W - MARGIN_L - MARGIN_R, ph = PLOT_H - MARGIN_T - MARGIN_B;
#define PX(t) (MARGIN_L + (log10(t) - x0) / (x1 - x0) * pw)
#define PY(e) (MARGIN_T + (y1 - log10(e)) / (y1 - y0) * ph)
    fprintf(svg,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
            "font-family=\"sans-serif\" font-size=\"12\">\n"
            "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
            "<text x=\"%.0f\" y=\"22\" font-size=\"14\">%s</text>\n",
            PLOT_W, PLOT_H, MARGIN_L, title);
    for (double d = x0; d <= x1 + 1e-9; d++) {
        double x = MARGIN_L + (d - x0) / (x1 - x0) * pw;
        fprintf(svg,
                "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>\n"
                "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%g</text>\n",
                x, MARGIN_T, x, MARGIN_T + ph, x, MARGIN_T + ph + 18, pow(10, d));
    }
    for (double d = y0; d <= y1 + 1e-9; d++) {
        double y = MARGIN_T + (y1 - d) / (y1 - y0) * ph;
        fprintf(svg,
                "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>\n"
                "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%g</text>\n",
                MARGIN_L, y, MARGIN_L + pw, y, MARGIN_L - 6, y + 4, pow(10, d));
    }
    /* The goal line: relMSE 0.01. */
    fprintf(svg,
            "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#999\" "
            "stroke-dasharray=\"6 4\"/>\n",
            MARGIN_L, PY(0.01), MARGIN_L + pw, PY(0.01));
    fprintf(svg,
            "<rect x=\"%.0f\" y=\"%.0f\" width=\"%.0f\" height=\"%.0f\" fill=\"none\" "
            "stroke=\"black\"/>\n"
            "<text x=\"%.0f\" y=\"%.0f\" text-anchor=\"middle\">seconds per frame</text>\n"
            "<text transform=\"translate(18 %.0f) rotate(-90)\" text-anchor=\"middle\">relMSE "
            "(R, G, B; ε = 0.01)</text>\n",
            MARGIN_L, MARGIN_T, pw, ph, MARGIN_L + pw / 2, PLOT_H - 14, MARGIN_T + ph / 2);
    size_t firsts[16];
    size_t n = curves(rows, count, firsts, 16);
    for (size_t c = 0; c < n; c++) {
        const char *colour = colours[c % (sizeof colours / sizeof colours[0])];
        fprintf(svg, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"", colour);
        for (size_t i = firsts[c]; i < count; i++) {
            if (same_curve(&rows[i], &rows[firsts[c]]) && rows[i].seconds > 0 &&
                rows[i].relmse > 0)
                fprintf(svg, "%.1f,%.1f ", PX(rows[i].seconds), PY(rows[i].relmse));
        }
        fprintf(svg, "\"/>\n");
        for (size_t i = firsts[c]; i < count; i++) {
            if (same_curve(&rows[i], &rows[firsts[c]]) && rows[i].seconds > 0 &&
                rows[i].relmse > 0)
                fprintf(svg, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"><title>%s %s "
                             "%s=%u: %.3g s, relMSE %.3g</title></circle>\n",
                        PX(rows[i].seconds), PY(rows[i].relmse), colour, rows[i].renderer,
                        rows[i].preset, rows[i].knob, rows[i].value, rows[i].seconds,
                        rows[i].relmse);
        }
        double ly = MARGIN_T + 16 + 20.0 * (double)c;
        fprintf(svg,
                "<line x1=\"%.0f\" y1=\"%.0f\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"%s\" "
                "stroke-width=\"2\"/>\n<text x=\"%.0f\" y=\"%.0f\">%s %s (%s)</text>\n",
                MARGIN_L + pw + 12, ly, MARGIN_L + pw + 32, ly, colour, MARGIN_L + pw + 38,
                ly + 4, rows[firsts[c]].renderer, rows[firsts[c]].preset, rows[firsts[c]].knob);
    }
#undef PX
#undef PY
    fprintf(svg, "</svg>\n");
    return fclose(svg) == 0;
}

/* Seconds at which the curve starting at first reaches target; negative if never. */
static double time_to(const quality_row *rows, size_t count, size_t first, double target)
{
    const quality_row *previous = NULL;
    for (size_t i = first; i < count; i++) {
        if (!same_curve(&rows[i], &rows[first]))
            continue;
        if (rows[i].relmse <= target) {
            if (!previous || previous->relmse <= target)
                return rows[i].seconds;
            double f = (log(previous->relmse) - log(target)) /
                       (log(previous->relmse) - log(rows[i].relmse));
            return exp(log(previous->seconds) + f * (log(rows[i].seconds) - log(previous->seconds)));
        }
        previous = &rows[i];
    }
    return -1.0;
}

void quality_summary(const quality_row *rows, size_t count, double target)
{
    size_t firsts[16];
    size_t n = curves(rows, count, firsts, 16);
    double best = -1, cycles = -1, reference = -1;
    const char *best_name = "";
    printf("\nseconds to relMSE %g:\n", target);
    for (size_t c = 0; c < n; c++) {
        const quality_row *row = &rows[firsts[c]];
        double t = time_to(rows, count, firsts[c], target);
        if (t > 0)
            printf("  %-10s %-10s %10.3f s\n", row->renderer, row->preset, t);
        else
            printf("  %-10s %-10s not reached\n", row->renderer, row->preset);
        if (t <= 0)
            continue;
        if (!strcmp(row->renderer, "cycles"))
            cycles = t;
        else if (!strcmp(row->preset, "reference"))
            reference = t;
        if (!strcmp(row->renderer, "photonfarm") && (best < 0 || t < best)) {
            best = t;
            best_name = row->preset;
        }
    }
    if (best > 0 && cycles > 0)
        printf("  photonfarm %s is %.2fx as fast as Cycles\n", best_name, cycles / best);
    if (best > 0 && reference > 0 && strcmp(best_name, "reference"))
        printf("  photonfarm %s is %.2fx as fast as photonfarm reference\n", best_name,
               reference / best);
}
