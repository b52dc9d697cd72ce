/* Peak resident memory from /proc (peak_memory.h). */
#include "peak_memory.h"

#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

/* proc(5): writing 5 to clear_refs resets the peak resident set size to the current one. */
#define CLEAR_REFS_RESET_PEAK "5"

int pf_peak_rss_reset(void)
{
    int fd = open("/proc/self/clear_refs", O_WRONLY | O_CLOEXEC);
    if (fd < 0)
        return 0;
    int reset = write(fd, CLEAR_REFS_RESET_PEAK, 1) == 1;
    close(fd);
    return reset;
}

int64_t pf_peak_rss(void)
{
    FILE *status = fopen("/proc/self/status", "re");
    if (!status)
        return -1;
    char line[256];
    long long kib = -1;
    while (fgets(line, sizeof line, status))
        if (sscanf(line, "VmHWM: %lld kB", &kib) == 1)
            break;
    fclose(status);
    return kib < 0 ? -1 : (int64_t)kib * 1024;
}
