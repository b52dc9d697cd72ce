/*
 * The machine's compiled-shader cache directory, shared by every photonfarm
 * process on it so that pipelines are compiled once per machine, not once per
 * process (a cold lavapipe process spends ~25 s compiling before its first
 * frame; a warm one under 3 s).
 *
 * It holds two caches: core/vk's VkPipelineCache file (what GPU drivers reuse)
 * and Mesa's own shader cache, which is where lavapipe keeps its compiled code
 * (its VkPipelineCache stores nothing in Mesa 22.x). Pointing Mesa's at the
 * same directory makes one volume in a container image carry both.
 */
#include "pf_cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* mkdir -p: each missing component of path, mode 0777 less the umask. */
static int make_directories(const char *path)
{
    char partial[PF_CLI_PATH_MAX];
    size_t length = strlen(path);
    if (length == 0 || length >= sizeof partial)
        return -1;
    memcpy(partial, path, length + 1);
    for (char *slash = partial + 1;; slash++) {
        char saved = *slash;
        if (saved != '/' && saved != '\0')
            continue;
        *slash = '\0';
        if (mkdir(partial, 0777) != 0 && errno != EEXIST)
            return -1;
        *slash = saved;
        if (saved == '\0')
            break;
    }
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -1;
}

const char *pf_cli_cache_dir(const char *command, const char *option, char *buffer, size_t size)
{
    const char *chosen = option;
    const char *source = "--cache-dir";
    if (!chosen && (chosen = getenv("PHOTONFARM_CACHE_DIR")))
        source = "$PHOTONFARM_CACHE_DIR";
    if (chosen && (!chosen[0] || !strcmp(chosen, "none")))
        return NULL;
    if (chosen) {
        snprintf(buffer, size, "%s", chosen);
    } else {
        const char *xdg = getenv("XDG_CACHE_HOME");
        const char *home = getenv("HOME");
        if (xdg && xdg[0] == '/')
            snprintf(buffer, size, "%s/photonfarm", xdg);
        else if (home && home[0] == '/')
            snprintf(buffer, size, "%s/.cache/photonfarm", home);
        else
            return NULL; /* no home (a bare container user): nothing to share */
        source = "the default";
    }
    if (make_directories(buffer) != 0) {
        fprintf(stderr,
                "photonfarm %s: warning: shader cache directory %s (%s) cannot be created: %s; "
                "shaders compile anew in every process\n",
                command, buffer, source, strerror(errno));
        return NULL;
    }
    /* Mesa reads this when the Vulkan instance is created; a user's own setting wins. */
    if (!getenv("MESA_SHADER_CACHE_DIR"))
        setenv("MESA_SHADER_CACHE_DIR", buffer, 1);
    return buffer;
}
