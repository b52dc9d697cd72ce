/*
 * Text from the queue (job names, paths, worker names, error messages) is
 * written to terminals by status, workers and timings. Anyone who can enqueue
 * chooses that text, so control characters are shown escaped, never sent: an
 * ESC or CSI in a job name must not move the cursor or restyle an
 * operator's terminal.
 */
#include "pf_cli.h"

#include <stdio.h>

const char *pf_cli_printable(const char *text, char *buffer, size_t size)
{
    size_t used = 0;
    if (size == 0)
        return "";
    for (const unsigned char *p = (const unsigned char *)(text ? text : ""); *p; p++) {
        char escaped[8];
        size_t length;
        /* C0 controls and DEL; C1 controls as UTF-8 (U+0080..U+009F = C2 80..C2 9F). */
        if (*p < 0x20 || *p == 0x7f) {
            length = (size_t)snprintf(escaped, sizeof escaped, "\\x%02x", *p);
        } else if (*p == 0xc2 && p[1] >= 0x80 && p[1] <= 0x9f) {
            length = (size_t)snprintf(escaped, sizeof escaped, "\\u%04x", p[1]);
            p++;
        } else {
            escaped[0] = (char)*p;
            length = 1;
        }
        if (used + length >= size)
            break;
        for (size_t i = 0; i < length; i++)
            buffer[used++] = escaped[i];
    }
    buffer[used] = '\0';
    return buffer;
}
