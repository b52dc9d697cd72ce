/* Progress bars and the worker's live progress line (see progress.h). */
#include "progress.h"

#include <string.h>
#include <unistd.h>

/* Bar width of the worker's live line: fits an 80-column terminal with the label. */
#define LIVE_BAR_CELLS 30

void pf_progress_bar(char *out, size_t size, int64_t done, int64_t total, int bar_width)
{
    char cells[256];
    if (bar_width > (int)sizeof cells - 1)
        bar_width = (int)sizeof cells - 1;
    int filled = total > 0 ? (int)((done * bar_width) / total) : 0;
    for (int i = 0; i < bar_width; i++)
        cells[i] = i < filled ? '#' : '.';
    cells[bar_width] = '\0';
    int percent = total > 0 ? (int)((done * 100) / total) : 0;
    snprintf(out, size, "[%s] %lld/%lld %3d%%", cells, (long long)done, (long long)total,
             percent);
}

void pf_progress_init(pf_progress *progress, FILE *stream)
{
    memset(progress, 0, sizeof *progress);
    progress->stream = stream;
    progress->is_tty = isatty(fileno(stream));
}

void pf_progress_update(pf_progress *progress, const char *label, int64_t done, int64_t total)
{
    char bar[320];
    pf_progress_bar(bar, sizeof bar, done, total, LIVE_BAR_CELLS);
    snprintf(progress->line, sizeof progress->line, "%s %s", label, bar);
    if (progress->is_tty) {
        fprintf(progress->stream, "\r\033[K%s", progress->line);
        progress->shown = 1;
    } else {
        fprintf(progress->stream, "%s\n", progress->line);
    }
    fflush(progress->stream);
}

void pf_progress_clear(pf_progress *progress)
{
    if (progress->is_tty && progress->shown) {
        fputs("\r\033[K", progress->stream);
        fflush(progress->stream);
        progress->shown = 0;
    }
}

void pf_progress_redraw(pf_progress *progress)
{
    if (progress->is_tty && progress->line[0] && !progress->shown) {
        fprintf(progress->stream, "\r\033[K%s", progress->line);
        fflush(progress->stream);
        progress->shown = 1;
    }
}

void pf_progress_finish(pf_progress *progress)
{
    if (progress->is_tty && progress->shown) {
        fputc('\n', progress->stream);
        fflush(progress->stream);
    }
    progress->shown = 0;
    progress->line[0] = '\0';
}
