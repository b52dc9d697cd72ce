/* One frame: scene evaluation, render, EXR to a temporary, commit (pf_render.h). */
#include "render_internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <limits.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define PARTIAL_INFIX ".partial-"
#define ATTRIBUTE_COUNT 9

/* A rendered frame waiting for its write (pf_frame_request.write_behind): what the
 * file will hold, exactly as a write at once would have written it. */
struct pf_frame_pending {
    pf_image image; /* the channels written: the beauty alone without AOVs */
    pf_image_attribute attributes[ATTRIBUTE_COUNT];
    pf_exr_pixel_type pixel_type;
    int64_t frame;
    int behind; /* written behind the next frame's render (write_behind) */
};
typedef struct pf_frame_pending pf_frame_pending;

static pf_status frame_memory_check(uint32_t width, uint32_t height, uint32_t frames_held,
                                    uint64_t available_bytes, pf_error *err);

static int aborted(const pf_frame_request *request)
{
    return request->abort && atomic_load(request->abort);
}

int pf_frame_output_path(const char *pattern, int64_t frame, char *out, size_t size)
{
    const char *hashes = strchr(pattern, '#');
    if (!hashes)
        return snprintf(out, size, "%s", pattern) < (int)size;
    size_t run = strspn(hashes, "#");
    int written = snprintf(out, size, "%.*s%0*" PRId64 "%s", (int)(hashes - pattern), pattern,
                           (int)run, frame, hashes + run);
    return written >= 0 && (size_t)written < size;
}

void pf_frame_split_path(const char *path, char *dir, size_t dir_size, const char **base)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, dir_size, ".");
        *base = path;
    } else if (slash == path) {
        snprintf(dir, dir_size, "/");
        *base = slash + 1;
    } else {
        snprintf(dir, dir_size, "%.*s", (int)(slash - path), path);
        *base = slash + 1;
    }
}

int pf_frame_remove_partials(const char *output_path, const char *tag_prefix)
{
    char dir[PF_FRAME_PATH_MAX], prefix[PF_FRAME_PATH_MAX], path[2 * PF_FRAME_PATH_MAX];
    const char *base;
    pf_frame_split_path(output_path, dir, sizeof dir, &base);
    snprintf(prefix, sizeof prefix, "%s" PARTIAL_INFIX "%s", base, tag_prefix);
    size_t prefix_length = strlen(prefix);
    DIR *listing = opendir(dir);
    if (!listing)
        return 0;
    int removed = 0;
    struct dirent *entry;
    while ((entry = readdir(listing)) != NULL) {
        if (strncmp(entry->d_name, prefix, prefix_length) != 0)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, entry->d_name);
        if (unlink(path) == 0)
            removed++;
    }
    closedir(listing);
    return removed;
}

/* Image size for the request: the asked size, or the default width with the camera's aspect. */
static void resolve_size(const pf_render_settings *asked, const pf_scene_frame *frame,
                         pf_render_settings *settings)
{
    *settings = *asked;
    if (settings->width && settings->height)
        return;
    settings->width = PF_FRAME_DEFAULT_WIDTH;
    settings->height = frame->camera.aspect > 0.0f
                           ? (uint32_t)(PF_FRAME_DEFAULT_WIDTH / frame->camera.aspect + 0.5f)
                           : PF_FRAME_DEFAULT_HEIGHT;
    if (settings->height < 1)
        settings->height = 1;
    if (settings->height > PF_FRAME_MAX_EDGE)
        settings->height = PF_FRAME_MAX_EDGE;
}

static void fill_attributes(const pf_frame_request *request, const pf_render_settings *settings,
                            pf_quality preset, int denoised,
                            double render_ms, pf_image_attribute attributes[ATTRIBUTE_COUNT])
{
    static const char *const keys[ATTRIBUTE_COUNT] = {
        "photonfarm/scene",    "photonfarm/frame",      "photonfarm/preset",
        "photonfarm/settings", "photonfarm/renderTime", "photonfarm/device",
        "photonfarm/pixelFilter", "photonfarm/maxBounces", "photonfarm/denoise"};
    memset(attributes, 0, ATTRIBUTE_COUNT * sizeof *attributes);
    for (int i = 0; i < ATTRIBUTE_COUNT; i++)
        snprintf(attributes[i].key, sizeof attributes[i].key, "%s", keys[i]);
    snprintf(attributes[0].value, sizeof attributes[0].value, "%s", request->scene_path);
    snprintf(attributes[1].value, sizeof attributes[1].value, "%" PRId64, request->frame);
    /* The preset that rendered (auto resolved); the settings as the job's JSON codec writes them. */
    snprintf(attributes[2].value, sizeof attributes[2].value, "%s",
             pf_quality_name(preset));
    if (!pf_settings_format(settings, attributes[3].value, sizeof attributes[3].value))
        snprintf(attributes[3].value, sizeof attributes[3].value, "quality=%s",
                 pf_quality_name(settings->quality));
    snprintf(attributes[4].value, sizeof attributes[4].value, "%.3f", render_ms);
    snprintf(attributes[5].value, sizeof attributes[5].value, "%s",
             request->device_name ? request->device_name : "");
    /* Also inside the settings; alone here so `compare` and other tools need no JSON. */
    snprintf(attributes[6].value, sizeof attributes[6].value, "%s",
             pf_pixel_filter_name(settings->pixel_filter));
    if (settings->bounce_limit)
        snprintf(attributes[7].value, sizeof attributes[7].value, "%u",
                 settings->bounce_limit - 1);
    else
        snprintf(attributes[7].value, sizeof attributes[7].value, "default");
    /* Whether the beauty was denoised (the settings say what was asked). */
    snprintf(attributes[8].value, sizeof attributes[8].value, "%s", denoised ? "on" : "off");
}

/* The motion AOV: the scene one frame earlier (a pure function of the frame number, so any
 * worker computes the same vectors), its points found through this frame's tree, into a
 * field the image takes once it is read back. Run as the renderer's overlap, while the
 * device finishes the frame, or after the render where none ran (preview). */
typedef struct motion_overlap {
    pf_renderer *renderer;
    const pf_scene *scene;
    double time;
    const pf_scene_frame *frame;
    uint32_t width, height;
    int ran;
    pf_status status;
    pf_error err;
    pf_motion_field field;
} motion_overlap;

static void motion_overlap_run(void *argument, int phase)
{
    motion_overlap *m = argument;
    if (phase == PF_OVERLAP_PREPARE) {
        /* A tree kept on the device comes to the host now, before the device is busy:
         * asked for during the frame's last submission, the download would wait for it. */
        const pf_bih *tree = NULL;
        m->status = m->renderer->bih_valid ? pf_renderer_bih_host(m->renderer, &tree, &m->err)
                                           : PF_OK;
        return;
    }
    m->ran = 1;
    if (m->status != PF_OK)
        return;
    pf_scene_frame previous;
    double previous_time = m->time - 1.0 / pf_scene_get_info(m->scene)->fps;
    m->status = pf_scene_eval(m->scene, previous_time, &previous, &m->err);
    if (m->status == PF_OK)
        m->status = pf_motion_compute(m->renderer, m->frame, &previous, m->width, m->height,
                                      &m->field, &m->err);
    pf_scene_frame_free(&previous);
}

/* The sequence a frame belongs to: the scene's load (one job's, on one worker) and the job's
 * settings; 0 where the settings do not format. */
static uint64_t sequence_id(const pf_scene_frame *frame, const pf_render_settings *settings)
{
    char json[1024];
    if (!frame->texture_set || !pf_settings_format(settings, json, sizeof json))
        return 0;
    uint64_t h = pf_hash_bytes(PF_HASH_START, &frame->texture_set, sizeof frame->texture_set);
    return pf_hash_bytes(h, json, strlen(json)) | 1u;
}

/*
 * What the denoiser needs to know of a frame to reuse the one before it: frames of one
 * sequence share the scene's load (one job's, on one worker) and the job's settings; the
 * fingerprints say whether the light changed (no reuse) and whether anything moved (a
 * shorter memory). --denoise spatial keeps no history.
 */
static void sequence_of(pf_renderer *renderer, const pf_frame_request *request,
                        const pf_render_settings *settings, pf_quality preset,
                        const pf_scene_frame *frame, pf_denoise_sequence *sequence)
{
    memset(sequence, 0, sizeof *sequence);
    sequence->frame = request->frame;
    if (!pf_denoise_temporal(settings->denoise, preset))
        return; /* spatial: history NULL */
    sequence->history = pf_renderer_denoise_history(renderer);
    sequence->sequence = sequence_id(frame, settings);
    /* The planner's fingerprints of this frame (pf_render_frame has just planned it). */
    const uint64_t *inputs = renderer->frame_inputs;
    sequence->lighting = pf_hash_bytes(inputs[PF_INPUT_LIGHTS], &inputs[PF_INPUT_SURFACES],
                                       sizeof inputs[PF_INPUT_SURFACES]);
    sequence->geometry = inputs[PF_INPUT_GEOMETRY];
}

/*
 * PF_TEMPORAL_WARM_UP for the first frame of a run (more frames follow on this renderer)
 * that will be denoised with temporal reuse but has no previous frame to blend; else 1.
 * Its neighbour on another worker has a history of many frames, and the two would differ
 * by a whole frame's error where they meet (issue 40's seam). Not where a time budget or
 * auto's target governs the samples, nor for a frame alone (nothing follows to gain).
 */
static uint32_t warm_up_scale(pf_renderer *renderer, const pf_frame_request *request,
                              const pf_render_settings *settings, const pf_scene_frame *frame)
{
    /* auto without a budget or a target is fast (plan.c); with either, the planner counts. */
    pf_quality preset = settings->quality == PF_QUALITY_AUTO ? PF_QUALITY_FAST : settings->quality;
    if (request->following == 0 || !pf_denoise_temporal(settings->denoise, preset) ||
        settings->time_budget_ms > 0.0 || settings->budget_ms > 0.0 ||
        settings->target_relmse > 0.0)
        return 1;
    int continues = pf_denoise_history_continues(pf_renderer_denoise_history(renderer),
                                                 sequence_id(frame, settings), request->frame,
                                                 settings->width, settings->height);
    return continues ? 1 : PF_TEMPORAL_WARM_UP;
}

pf_status pf_frame_render(pf_renderer *renderer, const pf_frame_request *request,
                          pf_frame_output *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    double start = pf_time_ms();
    if (snprintf(out->final_path, sizeof out->final_path, "%s", request->output_path) >=
        (int)sizeof out->final_path) {
        out->failed = PF_FRAME_FAILED_OUTPUT;
        return pf_error_set(err, PF_ERR_INVALID, "output path too long: %s", request->output_path);
    }
    if (aborted(request)) {
        out->aborted = 1;
        return PF_OK;
    }

    pf_vk_memory_peak_reset(pf_renderer_context(renderer));
    pf_scene_frame frame = {0};
    double time = pf_scene_frame_time(request->scene, request->frame);
    pf_status status = pf_scene_eval_rigid(request->scene, time, &frame, err);
    if (status == PF_OK) {
        pf_stage_timing *eval_row = pf_frame_report_add(&out->report, "scene_eval");
        if (eval_row) {
            eval_row->wall_ms = pf_time_ms() - start;
            pf_stage_add_counter(eval_row, "triangles", frame.triangle_count);
            pf_stage_add_counter(eval_row, "lights", frame.light_count);
        }
        status = pf_render_deform(renderer, request->scene, time, &frame, &out->report, err);
    }
    if (status != PF_OK) {
        pf_scene_frame_free(&frame);
        out->failed = PF_FRAME_FAILED_SCENE;
        pf_error_prefix(err, "%s frame %" PRId64, request->scene_path, request->frame);
        return status;
    }
    if (aborted(request)) {
        pf_scene_frame_free(&frame);
        out->aborted = 1;
        return PF_OK;
    }

    pf_render_settings settings;
    resolve_size(&request->settings, &frame, &settings);
    out->width = settings.width;
    out->height = settings.height;
    status = frame_memory_check(settings.width, settings.height, request->write_behind ? 2 : 1,
                                0, err);
    if (status != PF_OK) {
        pf_scene_frame_free(&frame);
        return status;
    }
    pf_image image = {0};
    /* The denoiser is guided by the albedo, normal and depth layers: rendered whenever it
     * may run, and written only when asked for. */
    pf_render_settings rendered = settings;
    /* auto quality renders fast or final: final is the one that may be denoised. */
    rendered.aovs |= pf_denoise_applies(settings.denoise, settings.quality == PF_QUALITY_AUTO
                                                              ? PF_QUALITY_FINAL
                                                              : settings.quality);
    rendered.sample_salt = (uint64_t)request->frame;
    rendered.sample_scale = warm_up_scale(renderer, request, &settings, &frame);
    /* The layers the stages below add, where known before the render: motion whenever
     * the AOVs are written; the noisy beauty where they are and the denoiser will run
     * (auto's preset is only known once it rendered: its layers are appended). */
    if (settings.aovs)
        rendered.later_layers |= PF_LATER_LAYER_MOTION;
    if (settings.aovs && settings.quality != PF_QUALITY_AUTO &&
        pf_denoise_applies(settings.denoise, settings.quality))
        rendered.later_layers |= PF_LATER_LAYER_NOISY;
    /* With AOVs the motion vectors are wanted whatever the denoiser decides: computed while
     * the device renders the frame's last submission (the split integrators'), and written
     * into the image once it is back. */
    motion_overlap overlap = {renderer, request->scene, time, &frame, settings.width,
                              settings.height, 0, PF_OK, {0}, {0}};
    if (settings.aovs) {
        renderer->overlap = motion_overlap_run;
        renderer->overlap_arg = &overlap;
    }
    status = pf_render_frame(renderer, &frame, &rendered, &image, &out->report, err);
    renderer->overlap = NULL;
    renderer->overlap_arg = NULL;
    int overlapped = overlap.ran;
    out->peak_device_bytes = pf_vk_memory_use_of(pf_renderer_context(renderer)).peak;
    int denoised = status == PF_OK && pf_denoise_applies(settings.denoise, out->report.quality);
    pf_denoise_sequence sequence = {0};
    int reusing = 0;
    if (denoised) {
        sequence_of(renderer, request, &settings, out->report.quality, &frame, &sequence);
        sequence.first_length = rendered.sample_scale > 1 ? (float)rendered.sample_scale : 1.0f;
        reusing = pf_denoise_history_usable(sequence.history, &sequence, image.width,
                                            image.height, NULL, 0);
    }
    /* The motion vectors: an AOV, and what temporal reuse finds the previous frame by. */
    float *depth_change = NULL;
    if (status == PF_OK && reusing) {
        depth_change = malloc((size_t)image.width * image.height * sizeof *depth_change);
        if (!depth_change)
            status = pf_error_set(err, PF_ERR_NOMEM, "motion: out of memory");
    }
    if (status == PF_OK && (settings.aovs || reusing)) {
        if (!overlapped)
            motion_overlap_run(&overlap, PF_OVERLAP_RUN);
        status = overlap.status;
        if (status != PF_OK && err)
            *err = overlap.err;
    }
    if (status == PF_OK && (settings.aovs || reusing)) {
        status =
            pf_motion_apply(&overlap.field, &image, depth_change, overlapped, &out->report, err);
        /* The shade row's wall time holds the vectors' (computed during its last wait). */
        pf_stage_timing *shade = NULL;
        for (uint32_t s = 0; overlapped && s < out->report.stage_count; s++)
            if (!strcmp(out->report.stages[s].stage, "shade"))
                shade = &out->report.stages[s];
        if (shade)
            pf_stage_add_counter(shade, "overlap_ms", overlap.field.ms);
    }
    pf_motion_field_free(&overlap.field);
    sequence.depth_change = depth_change;
    if (status == PF_OK && denoised)
        status = pf_render_denoise(renderer, &image, settings.aovs, &sequence, &out->report, err);
    free(depth_change);
    pf_scene_frame_free(&frame);
    if (status != PF_OK) {
        pf_error_prefix(err, "%s frame %" PRId64, request->scene_path, request->frame);
        return status;
    }
    if (aborted(request)) {
        pf_image_free(&image);
        out->aborted = 1;
        return PF_OK;
    }

    double render_end = pf_time_ms();
    pf_frame_pending *pending = calloc(1, sizeof *pending);
    if (!pending) {
        pf_image_free(&image);
        out->failed = PF_FRAME_FAILED_RENDER;
        return pf_error_set(err, PF_ERR_NOMEM, "frame %" PRId64 ": out of memory", request->frame);
    }
    fill_attributes(request, &settings, out->report.quality, denoised, render_end - start,
                    pending->attributes);
    pending->pixel_type = settings.float_pixels ? PF_EXR_FLOAT : PF_EXR_HALF;
    pending->frame = request->frame;
    pending->behind = request->write_behind != 0;
    if (snprintf(out->temp_path, sizeof out->temp_path, "%s" PARTIAL_INFIX "%s",
                 request->output_path, request->temp_tag ? request->temp_tag : "0") >=
        (int)sizeof out->temp_path) {
        pf_image_free(&image);
        free(pending);
        out->temp_path[0] = '\0';
        out->failed = PF_FRAME_FAILED_OUTPUT;
        return pf_error_set(err, PF_ERR_INVALID, "output path too long: %s", request->output_path);
    }
    /* Without AOVs the file is the beauty alone: RGBA, which every EXR reader opens
     * as a plain image (the lighting split is an AOV too). What is kept is what is
     * written, so a frame held for write_behind holds no more than that. */
    static const char *const rgba[] = {"R", "G", "B", "A"};
    if (!settings.aovs && image.channel_count > 4) {
        status = pf_image_select(&image, rgba, 4, &pending->image, err);
        pf_image_free(&image);
    } else {
        pending->image = image;
    }
    out->pending = pending;
    out->total_ms = pf_time_ms() - start;
    if (status != PF_OK) {
        pf_frame_discard(out);
        out->failed = PF_FRAME_FAILED_RENDER;
        pf_error_prefix(err, "writing frame %" PRId64, request->frame);
        return status;
    }
    return request->write_behind ? PF_OK : pf_frame_write(out, err);
}

pf_status pf_frame_write(pf_frame_output *out, pf_error *err)
{
    pf_frame_pending *pending = out->pending;
    if (!pending || !out->temp_path[0])
        return pf_error_set(err, PF_ERR_INTERNAL, "no rendered frame to write for %s",
                            out->final_path);
    double write_start = pf_time_ms();
    const pf_image *written = &pending->image;
    pf_status status = pf_exr_write(out->temp_path, written, pending->pixel_type,
                                    pending->attributes, ATTRIBUTE_COUNT, err);
    int64_t frame = pending->frame;
    int behind = pending->behind;
    double pixels = (double)written->width * written->height;
    out->pending = NULL;
    pf_image_free(&pending->image);
    free(pending);
    if (status != PF_OK) {
        unlink(out->temp_path);
        out->temp_path[0] = '\0';
        out->failed = PF_FRAME_FAILED_OUTPUT;
        pf_error_prefix(err, "writing frame %" PRId64, frame);
        return status;
    }
    struct stat written_file;
    if (stat(out->temp_path, &written_file) == 0)
        out->bytes_written = (uint64_t)written_file.st_size;
    pf_stage_timing *write_row = pf_frame_report_add(&out->report, "exr_write");
    double write_ms = pf_time_ms() - write_start;
    if (write_row) {
        write_row->wall_ms = write_ms;
        write_row->gpu_ms = -1.0;
        pf_stage_add_counter(write_row, "pixels", pixels);
        pf_stage_add_counter(write_row, "bytes", (double)out->bytes_written);
        /* 1: on the writer's thread, while the next frame rendered; its wall time then
         * overlaps that frame's rows instead of adding to this worker's time. */
        pf_stage_add_counter(write_row, "behind", behind);
    }
    out->total_ms += write_ms;
    return PF_OK;
}

pf_status pf_frame_output_check(const char *pattern, char *absolute, size_t size, pf_error *err)
{
    char dir[PATH_MAX], resolved[PATH_MAX];
    const char *base;
    pf_frame_split_path(pattern, dir, sizeof dir, &base);
    if (!*base)
        return pf_error_set(err, PF_ERR_INVALID, "no file name after the directory");
    if (strchr(pattern, '#') && strchr(pattern, '#') < base)
        return pf_error_set(err, PF_ERR_INVALID, "# belongs in the file name, not the directory");
    if (!realpath(dir, resolved))
        return pf_error_set(err, PF_ERR_IO, "output directory %s: %s", dir, strerror(errno));
    /* Writable as this process: the one way to know is to write. */
    char probe[PATH_MAX + 64];
    snprintf(probe, sizeof probe, "%s/.photonfarm-probe-%ld", resolved, (long)getpid());
    int fd = open(probe, O_WRONLY | O_CREAT | O_EXCL, 0600);
    if (fd < 0)
        return pf_error_set(err, PF_ERR_IO, "output directory %s is not writable: %s", resolved,
                            strerror(errno));
    close(fd);
    unlink(probe);
    if (snprintf(absolute, size, "%s/%s", strcmp(resolved, "/") ? resolved : "", base) >=
        (int)size)
        return pf_error_set(err, PF_ERR_INVALID, "path too long");
    return PF_OK;
}

/* pf_frame_memory_check for frames_held frames of this size at once (write_behind holds
 * one while the next renders). */
static pf_status frame_memory_check(uint32_t width, uint32_t height, uint32_t frames_held,
                                    uint64_t available_bytes, pf_error *err)
{
    if (available_bytes == 0) {
        long pages = sysconf(_SC_PHYS_PAGES), page_size = sysconf(_SC_PAGESIZE);
        if (pages <= 0 || page_size <= 0)
            return PF_OK; /* unknown: nothing to compare against */
        available_bytes = (uint64_t)pages * (uint64_t)page_size / 2u;
    }
    uint64_t needed = (uint64_t)width * height * PF_FRAME_HOST_BYTES_PER_PIXEL * frames_held;
    if (needed > available_bytes)
        return pf_error_set(err, PF_ERR_INVALID,
                            "a %ux%u frame needs about %.1f GiB of memory%s; at most %.1f GiB "
                            "(half of this machine's) is allowed: render a smaller image",
                            width, height, (double)needed / (1u << 30),
                            frames_held > 1 ? " (one frame rendering while the last is written)"
                                            : "",
                            (double)available_bytes / (1u << 30));
    return PF_OK;
}

pf_status pf_frame_memory_check(uint32_t width, uint32_t height, uint64_t available_bytes,
                                pf_error *err)
{
    return frame_memory_check(width, height, 1, available_bytes, err);
}

pf_status pf_frame_commit(pf_frame_output *out, pf_error *err)
{
    if (!out->temp_path[0])
        return pf_error_set(err, PF_ERR_INTERNAL, "no rendered frame to commit for %s",
                            out->final_path);
    if (rename(out->temp_path, out->final_path) != 0) {
        pf_status status = pf_error_set(err, PF_ERR_IO, "renaming %s to %s: %s", out->temp_path,
                                        out->final_path, strerror(errno));
        pf_frame_discard(out);
        out->failed = PF_FRAME_FAILED_OUTPUT;
        return status;
    }
    out->temp_path[0] = '\0';
    /* The rename is durable only once the directory entry is on disk. */
    char dir[PF_FRAME_PATH_MAX];
    const char *base;
    pf_frame_split_path(out->final_path, dir, sizeof dir, &base);
    int fd = open(dir, O_RDONLY | O_DIRECTORY);
    if (fd >= 0) {
        int synced = fsync(fd);
        close(fd);
        if (synced != 0) {
            out->failed = PF_FRAME_FAILED_OUTPUT;
            return pf_error_set(err, PF_ERR_IO, "fsync of directory %s: %s", dir,
                                strerror(errno));
        }
    }
    return PF_OK;
}

void pf_frame_discard(pf_frame_output *out)
{
    if (out->pending) {
        pf_image_free(&out->pending->image);
        free(out->pending);
        out->pending = NULL;
    }
    if (out->temp_path[0]) {
        unlink(out->temp_path);
        out->temp_path[0] = '\0';
    }
}
