/*
 * The farm's storage roots (issue 18): where jobs may read scenes from and
 * write frames to. A farm that several people enqueue into confines every
 * job to them, as Flamenco maps job paths onto its shared-storage root:
 *
 *   --scene-root DIR, --output-root DIR   (repeatable; else the colon-separated
 *   $PHOTONFARM_SCENE_ROOTS, $PHOTONFARM_OUTPUT_ROOTS; none: anywhere, as before)
 *
 * With roots, enqueue refuses a scene or an output directory that resolves
 * (after "..", and symbolic links) outside them, and stores the path relative
 * to the root that holds it; a worker resolves a stored relative path against
 * its own roots, so the same job renders on machines that mount the storage
 * at different places (a host path, a container's /data). A worker re-checks
 * every path before reading or writing, so a job written by an older client
 * or straight into the database cannot escape either. An absolute stored path
 * (no roots at enqueue) must still lie inside a worker's roots.
 */
#ifndef PF_STORAGE_ROOTS_H
#define PF_STORAGE_ROOTS_H

#include "cli_options.h"
#include "pf_common.h"

#include <limits.h>
#include <stddef.h>

#define PF_ROOTS_MAX 8

typedef struct pf_roots {
    const char *kind;                   /* "scene" or "output", for messages */
    const char *given[PF_ROOTS_MAX];    /* as the options or environment named them */
    char resolved[PF_ROOTS_MAX][PATH_MAX];
    size_t count;
    char environment[PF_ROOTS_MAX * 256]; /* the environment's list, split in place */
} pf_roots;

/* A command's two lists: where jobs read scenes, where they write frames. */
typedef struct pf_storage {
    pf_roots scene, output;
} pf_storage;

/* Both lists empty, each named by its kind. */
void pf_storage_init(pf_storage *storage);

/* The option row --scene-root or --output-root (by roots->kind), storing into roots. */
pf_cli_option pf_roots_option(pf_roots *roots);

/*
 * After parsing: resolves each root given by option (or, with none, by the
 * environment variable of its kind) with realpath, for both lists. 0, or 2
 * after printing which root does not exist.
 */
int pf_storage_finish(const char *command, pf_storage *storage);

/* "DIR1, DIR2" for messages. */
const char *pf_roots_list(const pf_roots *roots, char *out, size_t size);

/*
 * enqueue: absolute (an existing, realpath-resolved path) relative to the
 * root holding it into out ("" when it is the root itself: stored as "."),
 * or PF_ERR_INVALID naming the roots when none holds it. Without roots, out
 * is absolute unchanged.
 */
pf_status pf_roots_relative(const pf_roots *roots, const char *absolute, char *out, size_t size,
                            pf_error *err);

/*
 * worker (and status): a stored path to the absolute one it means here. A
 * relative path is looked up under each root in turn (the first where it
 * exists, else the first root); an absolute one is taken as it is. Either
 * way the result, resolved with realpath as far as it exists, must lie
 * inside one of the roots (PF_ERR_INVALID naming the stored path and the
 * roots otherwise). Without roots the path is used as it is.
 */
pf_status pf_roots_resolve(const pf_roots *roots, const char *stored, char *out, size_t size,
                           pf_error *err);

/*
 * An output pattern ("dir/f.####.exr") stored or checked as its directory,
 * which must exist, through pf_roots_relative or pf_roots_resolve, with the
 * file name kept.
 */
pf_status pf_roots_output_relative(const pf_roots *roots, const char *absolute_pattern, char *out,
                                   size_t size, pf_error *err);
pf_status pf_roots_output_resolve(const pf_roots *roots, const char *stored_pattern, char *out,
                                  size_t size, pf_error *err);

/*
 * enqueue: the output pattern's directory, created with its missing parents when it does
 * not exist yet, as Blender does (*created says so). With roots, only inside them: the
 * nearest existing ancestor, resolved, must lie in one (PF_ERR_INVALID naming the roots
 * otherwise, nothing created). A name "." or "..", or a '#', in the missing part is left
 * alone for pf_frame_output_check to refuse; a mkdir that fails is PF_ERR_IO naming it.
 */
pf_status pf_roots_make_output_directory(const pf_roots *roots, const char *pattern,
                                         int *created, pf_error *err);

/*
 * With roots, an output file that already exists as a symbolic link is
 * refused (PF_ERR_INVALID): the frame would land wherever it points.
 */
pf_status pf_roots_check_output_file(const pf_roots *roots, const char *path, pf_error *err);

#endif
