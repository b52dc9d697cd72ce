/*
 * Scene files refer to other files (glTF buffers, OBJ material libraries).
 * Those references are confined to the scene file's directory: a scene from a
 * farm's shared storage must not make a worker read what lies beside it
 * ("../", absolute-looking names, symbolic links out; issue 14).
 */
#include "scene_internal.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Whether a relative name's ".." components ever climb above where it starts. */
static int climbs_out(const char *relative)
{
    int depth = 0;
    while (*relative) {
        size_t length = strcspn(relative, "/");
        if (length == 2 && relative[0] == '.' && relative[1] == '.')
            depth--;
        else if (length > 0 && !(length == 1 && relative[0] == '.'))
            depth++;
        if (depth < 0)
            return 1;
        relative += length + (relative[length] == '/');
    }
    return 0;
}

static int path_inside(const char *scene_file, const char *path)
{
    char scene_dir[PATH_MAX], target_dir[PATH_MAX], resolved[PATH_MAX], buffer[PATH_MAX];
    const char *slash = strrchr(scene_file, '/');
    snprintf(buffer, sizeof buffer, "%.*s", slash ? (int)(slash - scene_file) + 1 : 2,
             slash ? scene_file : "./");
    if (!realpath(buffer, scene_dir))
        return 0;
    size_t prefix = slash ? (size_t)(slash - scene_file) + 1 : 0;
    slash = strrchr(path, '/');
    snprintf(buffer, sizeof buffer, "%.*s", slash ? (int)(slash - path) + 1 : 2,
             slash ? path : "./");
    if (!realpath(buffer, target_dir)) {
        /* A directory that does not exist: decide on the name alone (a typo inside is
         * then reported by the reader; nothing outside is probed). */
        if (strncmp(path, scene_file, prefix) != 0)
            return 0;
        return !climbs_out(path + prefix);
    }
    const char *check = target_dir;
    if (realpath(path, resolved))
        check = resolved; /* the file exists: where its links end is what counts */
    size_t length = strlen(scene_dir);
    if (length == 1) /* the scene lies in / */
        return 1;
    return strncmp(check, scene_dir, length) == 0 && (check[length] == '/' || !check[length]);
}


int scene_path_allowed(const pf_scene *scene, const char *path)
{
    return scene->allow_outside_dir || path_inside(scene->path, path);
}
