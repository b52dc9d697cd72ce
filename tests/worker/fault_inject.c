/*
 * Storage faults for worker tests, preloaded into a photonfarm process
 * (LD_PRELOAD): files under one directory behave as on a read-only or a full
 * volume while a switch file exists, so a test can break the "disk" mid-job
 * and mend it again without root, mounts or a tmpfs, and nothing in the
 * worker knows it is being tested.
 *
 *   PF_FAULT_DIR     the directory (absolute; prefix match on the path given)
 *   PF_FAULT_SWITCH  faults are on while this file exists
 *   PF_FAULT_KIND    "read-only" (default): opening for writing and renaming
 *                    into the directory fail with EROFS;
 *                    "full": opening works, every write to a file there
 *                    fails with ENOSPC (what a full disk does)
 *   PF_FAULT_HOLD_MS each rename of a frame's temporary in the directory
 *                    (a name holding ".partial-") first waits this long, so
 *                    a test can signal, kill or take the lease of a worker
 *                    that is provably mid-frame with its temporary on disk
 *                    (switch or not)
 *   PF_FAULT_HELD_MARK a file created when such a hold begins for the rename
 *                    onto the frame's own name (the commit; the EXR writer's
 *                    rename onto the temporary is held too, unmarked): the
 *                    worker renewed its lease just before, so a test can take
 *                    the lease at exactly that point
 *   PF_FAULT_RELEASE   the EXR writer's rename onto a frame's temporary in the
 *                    directory waits until this file exists (at most 120 s), so
 *                    a test holds a frame's write for as long as it takes to see
 *                    what the worker does meanwhile, whatever the machine's speed
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <unistd.h>

typedef enum fault_kind { FAULT_NONE, FAULT_READ_ONLY, FAULT_FULL } fault_kind;

/* The fault in force now for path (NULL: the kind alone, whatever the path). */
static fault_kind active_fault(const char *path)
{
    const char *dir = getenv("PF_FAULT_DIR"), *flip = getenv("PF_FAULT_SWITCH");
    if (!dir || !*dir || !flip || access(flip, F_OK) != 0)
        return FAULT_NONE;
    if (path && strncmp(path, dir, strlen(dir)) != 0)
        return FAULT_NONE;
    const char *kind = getenv("PF_FAULT_KIND");
    return kind && !strcmp(kind, "full") ? FAULT_FULL : FAULT_READ_ONLY;
}

static int opens_for_writing(int flags)
{
    return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC)) != 0;
}

/* Where fd points, "" when unknown. */
static void fd_path(int fd, char *out, size_t size)
{
    char link[64];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    ssize_t length = readlink(link, out, size - 1);
    out[length > 0 ? length : 0] = '\0';
}

static int refused_open(const char *path, int flags)
{
    if (opens_for_writing(flags) && active_fault(path) == FAULT_READ_ONLY) {
        errno = EROFS;
        return 1;
    }
    return 0;
}

#define NEXT(type, name) ((type)dlsym(RTLD_NEXT, name))
typedef int (*open_fn)(const char *, int, ...);
typedef int (*openat_fn)(int, const char *, int, ...);

static mode_t mode_argument(int flags, va_list args)
{
    return (flags & O_CREAT) || (flags & O_TMPFILE) == O_TMPFILE ? (mode_t)va_arg(args, int) : 0;
}

/* The real open named symbol after the fault check (mode as the caller gave it). */
static int checked_open(const char *symbol, const char *path, int flags, mode_t mode)
{
    if (refused_open(path, flags))
        return -1;
    return NEXT(open_fn, symbol)(path, flags, mode);
}

int open(const char *path, int flags, ...)
{
    va_list args;
    va_start(args, flags);
    mode_t mode = mode_argument(flags, args);
    va_end(args);
    return checked_open("open", path, flags, mode);
}

int open64(const char *path, int flags, ...)
{
    va_list args;
    va_start(args, flags);
    mode_t mode = mode_argument(flags, args);
    va_end(args);
    return checked_open("open64", path, flags, mode);
}

int openat(int dirfd, const char *path, int flags, ...)
{
    va_list args;
    va_start(args, flags);
    mode_t mode = mode_argument(flags, args);
    va_end(args);
    if (refused_open(path, flags))
        return -1;
    return NEXT(openat_fn, "openat")(dirfd, path, flags, mode);
}

/* PF_FAULT_HOLD_MS before the rename of a frame's temporary under PF_FAULT_DIR, and the
 * wait for PF_FAULT_RELEASE before the writer's rename onto it. */
static void hold_frame(const char *from, const char *to)
{
    const char *dir = getenv("PF_FAULT_DIR"), *hold = getenv("PF_FAULT_HOLD_MS");
    if (!dir || !*dir || strncmp(from, dir, strlen(dir)) != 0 || !strstr(from, ".partial-"))
        return;
    const char *release = getenv("PF_FAULT_RELEASE");
    if (release && *release && strstr(to, ".partial-"))
        for (int waited = 0; waited < 120000 && access(release, F_OK) != 0; waited += 10)
            usleep(10 * 1000);
    if (!hold)
        return;
    long ms = atol(hold);
    const char *mark = getenv("PF_FAULT_HELD_MARK");
    if (ms > 0 && mark && *mark && !strstr(to, ".partial-")) {
        int fd = NEXT(open_fn, "open")(mark, O_WRONLY | O_CREAT, 0644);
        if (fd >= 0)
            close(fd);
    }
    if (ms > 0)
        usleep((useconds_t)ms * 1000u);
}

int rename(const char *from, const char *to)
{
    hold_frame(from, to);
    if (active_fault(to) == FAULT_READ_ONLY) {
        errno = EROFS;
        return -1;
    }
    return NEXT(int (*)(const char *, const char *), "rename")(from, to);
}

/* Whether a write to fd must fail as on a full disk (sets errno). */
static int disk_full(int fd)
{
    if (fd <= 2 || active_fault(NULL) != FAULT_FULL)
        return 0;
    char path[PATH_MAX];
    fd_path(fd, path, sizeof path);
    if (active_fault(path) != FAULT_FULL)
        return 0;
    errno = ENOSPC;
    return 1;
}

ssize_t write(int fd, const void *buffer, size_t size)
{
    if (disk_full(fd))
        return -1;
    return NEXT(ssize_t (*)(int, const void *, size_t), "write")(fd, buffer, size);
}

ssize_t pwrite(int fd, const void *buffer, size_t size, off_t offset)
{
    if (disk_full(fd))
        return -1;
    return NEXT(ssize_t (*)(int, const void *, size_t, off_t), "pwrite")(fd, buffer, size,
                                                                          offset);
}

ssize_t pwrite64(int fd, const void *buffer, size_t size, off_t offset)
{
    if (disk_full(fd))
        return -1;
    return NEXT(ssize_t (*)(int, const void *, size_t, off_t), "pwrite64")(fd, buffer, size,
                                                                            offset);
}
