/* Scene and output roots: confining and mapping a job's paths (storage_roots.h). */
#include "storage_roots.h"
#include "pf_render.h"
#include "pf_cli.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* Environment variable per kind, read only when no option named a root. */
static const char *environment_of(const pf_roots *roots)
{
    return !strcmp(roots->kind, "scene") ? "PHOTONFARM_SCENE_ROOTS" : "PHOTONFARM_OUTPUT_ROOTS";
}

static int store_root(const char *command, const pf_cli_option *option, const char *value)
{
    pf_roots *roots = option->target;
    if (roots->count >= PF_ROOTS_MAX)
        return pf_cli_fail(command, 2, "%s: at most %d roots", option->name, PF_ROOTS_MAX);
    roots->given[roots->count++] = value;
    return 0;
}

pf_cli_option pf_roots_option(pf_roots *roots)
{
    int scene = !strcmp(roots->kind, "scene");
    pf_cli_option option = {
        scene ? "--scene-root" : "--output-root",
        NULL,
        "DIR",
        scene ? "jobs read scenes only under DIR (repeatable); job paths\nare stored relative to it"
              : "jobs write frames only under DIR (repeatable); job paths\nare stored relative to it",
        scene ? "$PHOTONFARM_SCENE_ROOTS (colon-separated), else anywhere"
              : "$PHOTONFARM_OUTPUT_ROOTS (colon-separated), else anywhere",
        store_root,
        roots,
        0,
        0,
        NULL};
    return option;
}

void pf_storage_init(pf_storage *storage)
{
    memset(storage, 0, sizeof *storage);
    storage->scene.kind = "scene";
    storage->output.kind = "output";
}

static int roots_finish(const char *command, pf_roots *roots)
{
    if (roots->count == 0) {
        const char *list = getenv(environment_of(roots));
        if (list && *list) {
            snprintf(roots->environment, sizeof roots->environment, "%s", list);
            for (char *save = NULL, *piece = strtok_r(roots->environment, ":", &save);
                 piece && roots->count < PF_ROOTS_MAX; piece = strtok_r(NULL, ":", &save))
                roots->given[roots->count++] = piece;
        }
    }
    for (size_t i = 0; i < roots->count; i++) {
        struct stat info;
        errno = 0;
        if (!realpath(roots->given[i], roots->resolved[i]) ||
            stat(roots->resolved[i], &info) != 0 || !S_ISDIR(info.st_mode))
            return pf_cli_fail(command, 2, "%s root %s: %s", roots->kind, roots->given[i],
                               errno ? strerror(errno) : "not a directory");
    }
    return 0;
}

int pf_storage_finish(const char *command, pf_storage *storage)
{
    int code = roots_finish(command, &storage->scene);
    return code ? code : roots_finish(command, &storage->output);
}

const char *pf_roots_list(const pf_roots *roots, char *out, size_t size)
{
    size_t used = 0;
    out[0] = '\0';
    for (size_t i = 0; i < roots->count && used < size; i++)
        used += (size_t)snprintf(out + used, size - used, "%s%s", i ? ", " : "",
                                 roots->resolved[i]);
    return out;
}

/* Whether absolute (resolved) lies in root (resolved): root itself or below it. */
static int inside(const char *root, const char *absolute)
{
    size_t length = strlen(root);
    if (length == 1 && root[0] == '/')
        return absolute[0] == '/';
    return !strncmp(absolute, root, length) && (absolute[length] == '/' || !absolute[length]);
}

static pf_status outside_error(const pf_roots *roots, const char *path, pf_error *err)
{
    char list[PF_ROOTS_MAX * (PATH_MAX + 2)];
    return pf_error_set(err, PF_ERR_INVALID,
                        "%s resolves outside the %s roots (%s): refused", path, roots->kind,
                        pf_roots_list(roots, list, sizeof list));
}

pf_status pf_roots_relative(const pf_roots *roots, const char *absolute, char *out, size_t size,
                            pf_error *err)
{
    if (roots->count == 0) {
        if (snprintf(out, size, "%s", absolute) >= (int)size)
            return pf_error_set(err, PF_ERR_INVALID, "path too long: %s", absolute);
        return PF_OK;
    }
    for (size_t i = 0; i < roots->count; i++) {
        const char *root = roots->resolved[i];
        if (!inside(root, absolute))
            continue;
        const char *rest = absolute + strlen(root);
        if (*rest == '/')
            rest++;
        if (strlen(root) == 1) /* the root is "/" */
            rest = absolute + 1;
        if (snprintf(out, size, "%s", *rest ? rest : ".") >= (int)size)
            return pf_error_set(err, PF_ERR_INVALID, "path too long: %s", absolute);
        return PF_OK;
    }
    return outside_error(roots, absolute, err);
}

/*
 * path made absolute and resolved as far as it exists: realpath of the path,
 * or of its directory with the last name appended when only that is missing.
 * 0 when even the directory does not resolve.
 */
static int resolve_existing(const char *path, char *out)
{
    if (realpath(path, out))
        return 1;
    char directory[PATH_MAX], resolved[PATH_MAX];
    const char *slash = strrchr(path, '/');
    snprintf(directory, sizeof directory, "%.*s", slash ? (int)(slash - path) : 1,
             slash ? path : ".");
    if (slash == path)
        snprintf(directory, sizeof directory, "/");
    if (!realpath(directory, resolved))
        return 0;
    return snprintf(out, PATH_MAX, "%s/%s", strcmp(resolved, "/") ? resolved : "",
                    slash ? slash + 1 : path) < PATH_MAX;
}

pf_status pf_roots_resolve(const pf_roots *roots, const char *stored, char *out, size_t size,
                           pf_error *err)
{
    if (roots->count == 0) {
        if (snprintf(out, size, "%s", stored) >= (int)size)
            return pf_error_set(err, PF_ERR_INVALID, "path too long: %s", stored);
        return PF_OK;
    }
    char candidate[2 * PATH_MAX], resolved[PATH_MAX];
    if (stored[0] == '/') {
        if (!resolve_existing(stored, resolved))
            return pf_error_set(err, PF_ERR_IO, "%s: %s", stored, strerror(errno));
    } else {
        /* The first root where it exists; else the first root (the caller reports it missing). */
        size_t chosen = 0;
        for (size_t i = 0; i < roots->count; i++) {
            struct stat info;
            snprintf(candidate, sizeof candidate, "%s/%s", roots->resolved[i], stored);
            if (stat(candidate, &info) == 0) {
                chosen = i;
                break;
            }
        }
        snprintf(candidate, sizeof candidate, "%s/%s", roots->resolved[chosen], stored);
        if (!resolve_existing(candidate, resolved))
            return pf_error_set(err, PF_ERR_IO, "%s (under the %s root %s): %s", stored,
                                roots->kind, roots->resolved[chosen], strerror(errno));
    }
    for (size_t i = 0; i < roots->count; i++) {
        if (inside(roots->resolved[i], resolved)) {
            if (snprintf(out, size, "%s", resolved) >= (int)size)
                return pf_error_set(err, PF_ERR_INVALID, "path too long: %s", resolved);
            return PF_OK;
        }
    }
    return outside_error(roots, stored, err);
}

pf_status pf_roots_output_relative(const pf_roots *roots, const char *absolute_pattern, char *out,
                                   size_t size, pf_error *err)
{
    char directory[PATH_MAX], resolved[PATH_MAX], relative[PATH_MAX];
    const char *name;
    pf_frame_split_path(absolute_pattern, directory, sizeof directory, &name);
    if (!realpath(directory, resolved))
        return pf_error_set(err, PF_ERR_IO, "output directory %s: %s", directory,
                            strerror(errno));
    pf_status status = pf_roots_relative(roots, resolved, relative, sizeof relative, err);
    if (status != PF_OK)
        return status;
    if (roots->count == 0)
        return snprintf(out, size, "%s", absolute_pattern) < (int)size
                   ? PF_OK
                   : pf_error_set(err, PF_ERR_INVALID, "path too long");
    return snprintf(out, size, "%s/%s", relative, name) < (int)size
               ? PF_OK
               : pf_error_set(err, PF_ERR_INVALID, "path too long");
}

pf_status pf_roots_output_resolve(const pf_roots *roots, const char *stored_pattern, char *out,
                                  size_t size, pf_error *err)
{
    if (roots->count == 0)
        return snprintf(out, size, "%s", stored_pattern) < (int)size
                   ? PF_OK
                   : pf_error_set(err, PF_ERR_INVALID, "path too long");
    char directory[PATH_MAX], resolved[PATH_MAX];
    const char *name;
    pf_frame_split_path(stored_pattern, directory, sizeof directory, &name);
    pf_status status = pf_roots_resolve(roots, directory, resolved, sizeof resolved, err);
    if (status != PF_OK)
        return status;
    return snprintf(out, size, "%s/%s", strcmp(resolved, "/") ? resolved : "", name) <
                   (int)size
               ? PF_OK
               : pf_error_set(err, PF_ERR_INVALID, "path too long");
}

pf_status pf_roots_check_output_file(const pf_roots *roots, const char *path, pf_error *err)
{
    struct stat info;
    if (roots->count > 0 && lstat(path, &info) == 0 && S_ISLNK(info.st_mode))
        return pf_error_set(err, PF_ERR_INVALID,
                            "%s is a symbolic link: a frame is never written through one when "
                            "output roots are set",
                            path);
    return PF_OK;
}

pf_status pf_roots_make_output_directory(const pf_roots *roots, const char *pattern,
                                         int *created, pf_error *err)
{
    *created = 0;
    char directory[PATH_MAX];
    const char *base;
    if (strlen(pattern) >= sizeof directory)
        return PF_OK; /* too long to be a path: left to the output check */
    pf_frame_split_path(pattern, directory, sizeof directory, &base);
    struct stat info;
    if (stat(directory, &info) == 0 || strchr(directory, '#'))
        return PF_OK; /* exists ("." and "/" do), or pf_frame_output_check refuses it */
    /* The nearest existing ancestor, and the names below it that are missing. */
    char ancestor[PATH_MAX];
    snprintf(ancestor, sizeof ancestor, "%s", directory);
    char *cut;
    while ((cut = strrchr(ancestor, '/')) != NULL) {
        *cut = '\0';
        if (!ancestor[0] || stat(ancestor, &info) == 0)
            break;
    }
    const char *missing = directory + (cut ? strlen(ancestor) + 1 : 0);
    if (cut && !ancestor[0])
        snprintf(ancestor, sizeof ancestor, "/");
    else if (!cut)
        snprintf(ancestor, sizeof ancestor, ".");
    for (const char *name = missing; *name;) {
        size_t length = strcspn(name, "/");
        if ((length == 1 && name[0] == '.') || (length == 2 && name[0] == '.' && name[1] == '.'))
            return PF_OK; /* not made up of plain names: left to the output check */
        name += length;
        while (*name == '/')
            name++;
    }
    char resolved[PATH_MAX];
    if (!realpath(ancestor, resolved))
        return pf_error_set(err, PF_ERR_IO, "%s: %s", ancestor, strerror(errno));
    if (roots->count > 0) {
        int held = 0;
        for (size_t i = 0; i < roots->count; i++)
            held |= inside(roots->resolved[i], resolved);
        if (!held) {
            char list[PF_ROOTS_MAX * (PATH_MAX + 2)];
            return pf_error_set(err, PF_ERR_INVALID,
                                "%s does not exist and lies outside the %s roots (%s): not "
                                "created",
                                directory, roots->kind, pf_roots_list(roots, list, sizeof list));
        }
    }
    /* mkdir -p under the resolved ancestor, one name at a time. */
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s", resolved);
    for (const char *name = missing; *name;) {
        size_t length = strcspn(name, "/");
        size_t used = strlen(path);
        if (snprintf(path + used, sizeof path - used, "%s%.*s", used > 1 ? "/" : "",
                     (int)length, name) >= (int)(sizeof path - used))
            return pf_error_set(err, PF_ERR_INVALID, "path too long: %s", directory);
        if (mkdir(path, 0777) != 0 && errno != EEXIST)
            return pf_error_set(err, PF_ERR_IO, "cannot create %s: %s", path, strerror(errno));
        name += length;
        while (*name == '/')
            name++;
    }
    *created = 1;
    return PF_OK;
}
