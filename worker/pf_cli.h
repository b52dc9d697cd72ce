/*
 * worker: the `photonfarm` executable. Each subcommand lives in its own
 * cli_<name>.c and returns a process exit code: 0 ok, 1 runtime failure,
 * 2 bad usage or bad input (DESIGN.md §1).
 */
#ifndef PF_CLI_H
#define PF_CLI_H

#include "pf_vk.h"

#include <stddef.h>

int pf_cli_devices(int argc, char **argv);
int pf_cli_render(int argc, char **argv);
int pf_cli_compare(int argc, char **argv);
int pf_cli_enqueue(int argc, char **argv);
int pf_cli_worker(int argc, char **argv);
int pf_cli_status(int argc, char **argv);
int pf_cli_timings(int argc, char **argv);
int pf_cli_log(int argc, char **argv);
int pf_cli_cancel(int argc, char **argv);
int pf_cli_pause(int argc, char **argv);
int pf_cli_resume(int argc, char **argv);
int pf_cli_retry(int argc, char **argv);
int pf_cli_depend(int argc, char **argv);
int pf_cli_priority(int argc, char **argv);
int pf_cli_serve(int argc, char **argv);
int pf_cli_workers(int argc, char **argv);

/* Prints "photonfarm <command>: <message>" to stderr and returns exit_code. */
int pf_cli_fail(const char *command, int exit_code, const char *format, ...)
    __attribute__((format(printf, 3, 4)));

/*
 * "<version>+<git revision>" of this build ("0.1.0+3f2a9c1d0b4e", "-dirty"
 * when built from a tree with uncommitted changes, "unknown" outside git):
 * printed by --version, logged by the worker, stored with every stage row.
 */
const char *pf_version_string(void);

#define PF_CLI_PATH_MAX 4096

/*
 * text with control characters escaped (printable.c): C0 and DEL as \xNN, C1
 * as \u00NN; cut to fit size. Every human-readable line that shows queue text
 * (job names, paths, worker names, errors) goes through it. Returns buffer.
 */
const char *pf_cli_printable(const char *text, char *buffer, size_t size);

/*
 * The shader cache directory (cache_dir.c) for a command's --cache-dir value
 * (NULL: not given): that, else $PHOTONFARM_CACHE_DIR, else
 * $XDG_CACHE_HOME/photonfarm, else $HOME/.cache/photonfarm; "none" or "" turns
 * it off. Creates it, points $MESA_SHADER_CACHE_DIR there unless already set,
 * and returns buffer; NULL (after a warning when creation failed) for none.
 */
const char *pf_cli_cache_dir(const char *command, const char *option, char *buffer, size_t size);

/*
 * A command's Vulkan options (cli_environment.c): device_option (NULL: not
 * given, then $PHOTONFARM_DEVICE, else automatic), validation from
 * $PF_VK_VALIDATION, the pipeline cache in cache_dir (NULL: none).
 */
pf_vk_options pf_cli_vk_options(const char *device_option, const char *cache_dir);

/* The worker's name: --name, else $PHOTONFARM_WORKER_NAME, else NULL (the default <host>-<pid>). */
const char *pf_cli_worker_name(const char *name_option);

#endif
