/*
 * photonfarm enqueue: validates a render job completely (the scene loads, the
 * frames exist, the output directory is writable, the options make sense)
 * and only then inserts it, so a bad job never reaches a worker
 * (DESIGN.md §1, §6). Prints the new job's id on stdout.
 */
#include "cli_queue.h"
#include "pf_render.h"
#include "pf_cli.h"
#include "pf_queue.h"
#include "pf_scene.h"
#include "storage_roots.h"
#include "job_extras.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define COMMAND "enqueue"
#define MAX_PRIORITY PF_QUEUE_PRIORITY_MAX
#define MAX_ATTEMPTS 100
#define MAX_FRAMES_PER_TASK 10000
#define PARAMETERS_MAX 1024
/* --min-device-memory, --min-memory: a pebibyte. */
#define MAX_MEMORY_BYTES (1ll << 50)

typedef struct enqueue_options {
    pf_cli_scene scene;
    const char *frames, *pattern, *db, *name;
    pf_render_settings settings;
    int64_t priority, max_attempts, frames_per_task;
    int force; /* --force: enqueue even when an unfinished job writes the same files */
    pf_storage storage; /* storage_roots.h */
    /* Requirements of the workers that may render it (issue 42). */
    const char *requires;
    int64_t min_device_memory, min_host_memory;
    pf_cli_tags tags;
    pf_cli_prerequisites after; /* --after, --after-frames */
} enqueue_options;

static int parse_options(int argc, char **argv, enqueue_options *options, int *help)
{
    memset(options, 0, sizeof *options);
    options->settings = pf_render_settings_default();
    options->max_attempts = 3;
    options->frames_per_task = 1;
    pf_storage_init(&options->storage);
    const pf_cli_option own[] = {
        {"--frames", NULL, "RANGE", "e.g. 1-48, 1-48x2 (every 2nd), 1,5,9-12", "required",
         pf_cli_store_text, &options->frames, 0, 0, NULL},
        {"--out", "-o", "PATTERN",
         "output EXR path; a run of # is the zero-padded frame\nnumber (required; one # run "
         "when there are several frames)",
         NULL, pf_cli_store_text, &options->pattern, 0, 0, NULL},
        {"--priority", NULL, "P", "higher runs first", "0", pf_cli_store_int, &options->priority,
         -MAX_PRIORITY, MAX_PRIORITY, NULL},
        {"--max-attempts", NULL, "N", "attempts per frame before it fails", "3",
         pf_cli_store_int, &options->max_attempts, 1, MAX_ATTEMPTS, NULL},
        {"--frames-per-task", NULL, "N", "frames a worker claims at once", "1", pf_cli_store_int,
         &options->frames_per_task, 1, MAX_FRAMES_PER_TASK, NULL},
        {"--name", NULL, "JOBNAME", "a label shown by status", "none", pf_cli_store_text,
         &options->name, 0, 0, NULL},
        {"--force", NULL, NULL,
         "enqueue even when an unfinished job writes the same\noutput files",
         "refused, naming that job", pf_cli_store_flag, &options->force, 0, 0, NULL},
        {"--requires", NULL, "gpu|cpu", "only workers with that kind of device render it",
         "any", pf_cli_store_choice, &options->requires, 0, 0, "gpu|cpu"},
        {"--min-device-memory", NULL, "SIZE",
         "only workers whose device has this much memory (24G, 512M)", "any",
         pf_cli_store_bytes, &options->min_device_memory, 0, MAX_MEMORY_BYTES, NULL},
        {"--min-memory", NULL, "SIZE", "only workers whose host has this much memory", "any",
         pf_cli_store_bytes, &options->min_host_memory, 0, MAX_MEMORY_BYTES, NULL},
        {"--tag", NULL, "NAME",
         "only workers with this tag (repeatable: all of them;\nworker --tag)", "none",
         pf_cli_store_tag, &options->tags, 0, 0, NULL},
        {"--after", NULL, "JOB[,JOB]",
         "its frames wait until these jobs are done (repeatable;\na failed one blocks it)",
         "none", pf_cli_store_after, &options->after, 0, 0, NULL},
        {"--after-frames", NULL, "JOB[,JOB]",
         "frame n waits for frame n of these jobs (repeatable)", "none",
         pf_cli_store_after_frames, &options->after, 0, 0, NULL},
        pf_cli_db_option(&options->db),
        pf_roots_option(&options->storage.scene),
        pf_roots_option(&options->storage.output),
    };
    int code = pf_cli_parse_job(COMMAND, "SCENE --frames RANGE --out PATTERN [options]",
                                "Adds a render job to the queue after checking it: the scene\n"
                                "loads, every frame is one of the scene's, the output directory\n"
                                "exists and is writable, no unfinished job writes the same\n"
                                "files. Prints the job id on stdout; bad input inserts nothing.",
                                own, sizeof own / sizeof own[0], &options->settings,
                                &options->scene, argc, argv, help);
    if (code || *help)
        return code;
    code = pf_storage_finish(COMMAND, &options->storage);
    if (code)
        return code;
    if (!options->frames)
        return pf_cli_fail(COMMAND, 2, "--frames RANGE is required (e.g. 1-48)");
    if (!options->pattern)
        return pf_cli_fail(COMMAND, 2, "--out PATTERN is required (e.g. 'out/frame.####.exr')");
    /* A volume every worker's device can hold: Vulkan guarantees 128 MiB buffers. */
    return pf_cli_lpv_check(COMMAND, &options->settings.lpv, PF_CLI_GUARANTEED_BUFFER_BYTES);
}

/* The output pattern made absolute, its directory proven writable (pf_render.h). */
static int check_output(const char *pattern, char *absolute, size_t size)
{
    pf_error err = {0};
    if (pf_frame_output_check(pattern, absolute, size, &err) != PF_OK)
        return pf_cli_fail(COMMAND, 2, "--out '%s': %s", pattern, err.message);
    return 0;
}

static int compare_paths(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The output files of a frame list under pattern, sorted (malloc'ed strings); NULL: no memory. */
static char **output_files(const char *pattern, const pf_frame_list *frames)
{
    char **paths = calloc(frames->count ? frames->count : 1, sizeof *paths);
    for (size_t i = 0; paths && i < frames->count; i++) {
        char path[PF_FRAME_PATH_MAX];
        if (!pf_frame_output_path(pattern, frames->frames[i], path, sizeof path) ||
            !(paths[i] = strdup(path))) {
            for (size_t k = 0; k < i; k++)
                free(paths[k]);
            free(paths);
            return NULL;
        }
    }
    if (paths)
        qsort(paths, frames->count, sizeof *paths, compare_paths);
    return paths;
}

static void free_files(char **paths, size_t count)
{
    for (size_t i = 0; paths && i < count; i++)
        free(paths[i]);
    free(paths);
}

/* This job's output files, sorted, for output_conflict, and the roots other jobs' paths are under. */
typedef struct our_files {
    char **paths;
    size_t count;
    const pf_roots *roots;
} our_files;

/*
 * pf_queue_conflict_fn: an unfinished job (queued, running or paused) that
 * writes one of the files this job would write; the two would overwrite each
 * other's frames. Asked by the queue inside the insert's transaction, so two
 * enqueues racing for the same files cannot both pass. Not asked with --force.
 */
static int output_conflict(const pf_queue_job *other, void *user, char *reason,
                           size_t reason_size)
{
    const our_files *ours = user;
    pf_frame_list theirs_frames = {0};
    pf_error err = {0};
    if (pf_frame_range_parse(other->frame_range, &theirs_frames, &err) != PF_OK)
        return 0; /* the queue validated it; nothing to compare if it cannot be read */
    /* A job stored relative to the output roots names its files through them. */
    char pattern[PATH_MAX];
    pf_error ignored = {0};
    if (pf_roots_output_resolve(ours->roots, other->output_pattern, pattern, sizeof pattern,
                                &ignored) != PF_OK)
        snprintf(pattern, sizeof pattern, "%s", other->output_pattern);
    char **theirs = output_files(pattern, &theirs_frames);
    int conflict = 0;
    for (size_t i = 0; theirs && i < ours->count && !conflict; i++) {
        if (bsearch(&ours->paths[i], theirs, theirs_frames.count, sizeof *theirs,
                    compare_paths)) {
            char name[128], shown[PF_CLI_PATH_MAX];
            pf_job_name(other->parameters_json, name, sizeof name);
            snprintf(reason, reason_size,
                     "--out: job %" PRId64 "%s%s%s (%s) already writes %s; --force enqueues "
                     "anyway",
                     other->job_id, name[0] ? " \"" : "",
                     pf_cli_printable(name, shown, sizeof shown), name[0] ? "\"" : "",
                     other->status, ours->paths[i]);
            conflict = 1;
        }
    }
    free_files(theirs, theirs_frames.count);
    pf_frame_list_free(&theirs_frames);
    return conflict;
}

/* Loads the scene (proving it renders) and checks every frame is one of its frames. */
static int check_scene(const enqueue_options *options, const pf_frame_list *frames,
                       char *absolute, size_t size)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    if (pf_scene_load_with(options->scene.path, &options->scene.load, &scene, &err) != PF_OK)
        return pf_cli_fail(COMMAND, 2, "scene: %s", err.message);
    uint32_t frame_count = pf_scene_get_info(scene)->frame_count;
    pf_scene_destroy(scene);
    for (size_t i = 0; i < frames->count; i++) {
        if (frames->frames[i] < 1 || (uint32_t)frames->frames[i] > frame_count)
            return pf_cli_fail(COMMAND, 2, "--frames '%s': frame %d is outside %s's frames 1-%u",
                               options->frames, frames->frames[i], options->scene.path,
                               frame_count);
    }
    char resolved[PATH_MAX];
    if (!realpath(options->scene.path, resolved) || strlen(resolved) >= size)
        return pf_cli_fail(COMMAND, 2, "scene %s: %s", options->scene.path, strerror(errno));
    memcpy(absolute, resolved, strlen(resolved) + 1);
    return 0;
}

int pf_cli_enqueue(int argc, char **argv)
{
    enqueue_options options;
    int help = 0;
    int code = parse_options(argc, argv, &options, &help);
    if (code || help)
        return code;
    pf_frame_list frames = {0};
    pf_error err = {0};
    if (pf_frame_range_parse(options.frames, &frames, &err) != PF_OK)
        return pf_cli_fail(COMMAND, 2, "--frames: %s", err.message);
    size_t frame_count = frames.count;
    char scene_path[PATH_MAX], pattern[PATH_MAX];
    if (frame_count > 1 && !strchr(options.pattern, '#'))
        code = pf_cli_fail(COMMAND, 2,
                           "--out '%s' has no #### for the frame number, but %zu frames were "
                           "asked for",
                           options.pattern, frame_count);
    /* A missing output directory is made, as Blender does; with roots, only inside them. */
    int created = 0;
    if (!code && pf_roots_make_output_directory(&options.storage.output, options.pattern,
                                                &created, &err) != PF_OK)
        code = pf_cli_fail(COMMAND, 2, "--out '%s': %s", options.pattern, err.message);
    if (!code && created)
        fprintf(stderr, "enqueue: created the output directory of %s\n", options.pattern);
    if (!code)
        code = check_output(options.pattern, pattern, sizeof pattern);
    if (!code)
        code = check_scene(&options, &frames, scene_path, sizeof scene_path);
    /* With roots: inside them, stored relative to the one that holds each. */
    char stored_scene[PATH_MAX], stored_pattern[PATH_MAX];
    if (!code && pf_roots_relative(&options.storage.scene, scene_path, stored_scene,
                                   sizeof stored_scene, &err) != PF_OK)
        code = pf_cli_fail(COMMAND, 2, "scene: %s", err.message);
    if (!code && pf_roots_output_relative(&options.storage.output, pattern, stored_pattern,
                                          sizeof stored_pattern, &err) != PF_OK)
        code = pf_cli_fail(COMMAND, 2, "--out: %s", err.message);
    /* The job's files, listed once: checked against the roots here, and against
     * the unfinished jobs' files inside the insert (output_conflict). */
    our_files ours = {NULL, frames.count, &options.storage.output};
    if (!code && !(ours.paths = output_files(pattern, &frames)))
        code = pf_cli_fail(COMMAND, 1, "out of memory listing output files");
    for (size_t i = 0; !code && i < ours.count; i++)
        if (pf_roots_check_output_file(&options.storage.output, ours.paths[i], &err) != PF_OK)
            code = pf_cli_fail(COMMAND, 2, "--out: %s", err.message);
    char parameters[PARAMETERS_MAX];
    pf_job_extras extras = {options.name, options.scene.load.allow_outside_scene_dir,
                            options.scene.load.animation, options.scene.load.material_variant};
    if (!code && !pf_job_parameters_format(&options.settings, &extras, parameters,
                                       sizeof parameters))
        code = pf_cli_fail(COMMAND, 2, "--name is too long");

    pf_queue *queue = NULL;
    const char *db_path = pf_cli_db_path(options.db);
    if (!code)
        code = pf_cli_open_queue(COMMAND, db_path, 0, &queue);
    pf_frame_list_free(&frames);
    if (code) {
        free_files(ours.paths, ours.count);
        if (queue)
            pf_queue_close(queue);
        return code;
    }
    pf_queue_job_spec spec = {stored_scene,
                              parameters,
                              options.frames,
                              stored_pattern,
                              (int)options.priority,
                              (int)options.max_attempts,
                              (int)options.frames_per_task,
                              options.force ? NULL : output_conflict,
                              &ours,
                              options.requires,
                              options.min_device_memory,
                              options.min_host_memory,
                              options.tags.text,
                              options.after.jobs,
                              options.after.count};
    int64_t job_id = 0;
    pf_status status = pf_queue_enqueue(queue, &spec, &job_id, &err);
    /* Requirements no worker has ever met: enqueued all the same (one may join), but said. */
    int64_t meeting = 1;
    int requires = (options.requires && *options.requires) || options.min_device_memory > 0 ||
                   options.min_host_memory > 0 || options.tags.text[0];
    pf_error count_err = {0};
    if (status == PF_OK && requires &&
        pf_queue_workers_meeting(queue, &spec, &meeting, &count_err) == PF_OK && meeting == 0) {
        char tags[PF_QUEUE_TAGS_MAX], needs[PF_QUEUE_TAGS_MAX + 160];
        if (pf_queue_tags_normalize(options.tags.text, tags, sizeof tags, &count_err) != PF_OK)
            tags[0] = '\0';
        pf_queue_requirements_text(options.requires, options.min_device_memory,
                                   options.min_host_memory, tags, needs, sizeof needs);
        fprintf(stderr,
                "photonfarm enqueue: warning: no worker registered with this queue has %s; "
                "the job waits until one does\n",
                needs);
    }
    pf_queue_close(queue);
    free_files(ours.paths, ours.count);
    if (status != PF_OK)
        return pf_cli_fail(COMMAND, pf_status_exit_code(status), "%s", err.message);
    printf("%" PRId64 "\n", job_id);
    fflush(stdout); /* the id comes first when stdout and stderr share a file */
    fprintf(stderr, "photonfarm enqueue: job %" PRId64 ": %zu frame(s) of %s -> %s (db %s)\n",
            job_id, frame_count, stored_scene, stored_pattern, db_path);
    return 0;
}
