/*
 * quality_bench: speed against error (issue 12, item 7). For one scene: a
 * converged image as ground truth (rendered once, cached by a hash of the
 * scene's files and the size), then every preset over a sweep of its
 * settings and Cycles over a sweep of sample counts, each image's relMSE and
 * RMSE against the same truth, computed the same way (pf_image_compare on
 * R, G, B, ε = 0.01). Writes PREFIX.csv and PREFIX.svg (relMSE against
 * seconds, log-log, one curve per renderer and preset) and prints the rows.
 *
 *   quality_bench SCENE.gltf WIDTH HEIGHT PREFIX [BLENDER|none] [THREADS]
 *
 * Times: photonfarm's are pf_render_frame's wall time in this process after
 * a warm-up frame of the same preset (no shader compilation, no scene
 * loading), each point with a seed of its own so that nothing is reused from
 * an earlier frame but the BIH of the static scene; Cycles' are bpy.ops.render.render's (bench/quality/
 * cycles_render.py: scene sync, BVH build and sampling; no start-up, import
 * or file write). Both get THREADS CPU threads (default 2; set LP_NUM_THREADS
 * to the same for lavapipe). Both use the Blackman-Harris 1.5 px pixel filter.
 *
 * The truth is Cycles at TRUTH_SPP (an independent renderer, and on 2 cores
 * ~17× faster per sample than photonfarm's reference on lavapipe), or with no
 * Blender photonfarm's reference at TRUTH_SPP. Cached as
 * PREFIX-truth-<hash>.exr.
 *
 * fast+dn, final+dn and reference+dn are those presets followed by the denoise
 * stage (issue 40), its time included.
 *
 * final+tr and reference+tr are a still shot of TEMPORAL_FRAMES frames denoised with
 * temporal reuse (each frame blends the one before, its camera samples salted by the frame
 * number, as a worker renders a job's consecutive frames): the point's seconds are the mean
 * time of a frame (render and denoise), its relMSE the last frame's. It is what a frame of a
 * still shot costs in steady state, not what one frame alone needs. Each also prints the
 * flicker between the last two frames (their difference over truth² + ε, the relMSE's
 * scale) and the seam: the last frame denoised without history (another worker's) against
 * the one before, with the samples asked and with the warm-up a run's first frame gets
 * (PF_TEMPORAL_WARM_UP× samples; the still shot's own first frame has it, in its time).
 *
 * PF_QUALITY_ONLY=label,label,...: only those curves ("cycles" for Cycles'); the truth is
 * rendered or read as always.
 *
 * PF_QUALITY_TRACE=device|host: reference's rays traced by the device (its megakernel) or
 * the host (the wavefront), instead of where the planner puts them (issue 43).
 *
 * PF_CYCLES_AS_IMPORTED=1: Cycles renders the file as Blender's importer reads
 * it (cycles_render.py), for users' files such as bench/materials'
 * room-textured.gltf, instead of with photonfarm's material model.
 */
#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"
#include "quality_plot.h"

#include <dirent.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define TRUTH_SPP 4096u
#define MAX_ROWS 64
#define TEMPORAL_FRAMES 8

typedef struct sweep {
    const char *label;   /* curve name */
    pf_quality quality;
    const char *knob;    /* what the values set */
    uint32_t values[8];  /* 0-terminated */
    int denoise;         /* the denoise stage after the render (issue 40), timed with it */
    int temporal;        /* a still shot of TEMPORAL_FRAMES frames with temporal reuse */
} sweep;

/* What each preset's cost and error are governed by. */
static const sweep sweeps[] = {
    {"preview", PF_QUALITY_PREVIEW, "spp", {1, 4, 16, 0}},
    {"fast", PF_QUALITY_FAST, "spp", {1, 2, 4, 8, 16, 0}},
    {"final", PF_QUALITY_FINAL, "passes", {1, 2, 4, 8, 16, 32, 0}},
    {"reference", PF_QUALITY_REFERENCE, "spp", {4, 16, 64, 256, 0}},
    {"fast+dn", PF_QUALITY_FAST, "spp", {1, 2, 4, 8, 16, 0}, 1},
    {"final+dn", PF_QUALITY_FINAL, "passes", {1, 2, 4, 8, 16, 32, 0}, 1},
    {"reference+dn", PF_QUALITY_REFERENCE, "spp", {4, 16, 64, 256, 0}, 1},
    {"final+tr", PF_QUALITY_FINAL, "passes", {1, 2, 4, 8, 0}, 1, 1},
    {"reference+tr", PF_QUALITY_REFERENCE, "spp", {1, 2, 4, 16, 64, 0}, 1, 1},
};

/* Whether PF_QUALITY_ONLY (a comma-separated list of curve labels) lets label run. */
static int selected(const char *label)
{
    const char *only = getenv("PF_QUALITY_ONLY");
    if (!only || !*only)
        return 1;
    size_t length = strlen(label);
    for (const char *at = only; (at = strstr(at, label)) != NULL; at += length)
        if ((at == only || at[-1] == ',') && (at[length] == ',' || at[length] == '\0'))
            return 1;
    return 0;
}
static const uint32_t cycles_spp[] = {4, 16, 64, 256, 1024, 0};

static uint64_t fnv1a(uint64_t hash, const void *data, size_t bytes)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < bytes; i++)
        hash = (hash ^ p[i]) * 0x100000001b3ull;
    return hash;
}

/* Hash of every regular file in the scene's directory (glTF, buffers, images), by name order. */
static uint64_t scene_hash(const char *scene_path)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", scene_path);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = '\0';
    else
        snprintf(dir, sizeof dir, ".");
    struct dirent **entries = NULL;
    int count = scandir(dir, &entries, NULL, alphasort);
    uint64_t hash = 0xcbf29ce484222325ull;
    for (int i = 0; i < count; i++) {
        char path[8192];
        snprintf(path, sizeof path, "%s/%s", dir, entries[i]->d_name);
        struct stat st;
        FILE *file = stat(path, &st) == 0 && S_ISREG(st.st_mode) ? fopen(path, "rb") : NULL;
        if (file) {
            hash = fnv1a(hash, entries[i]->d_name, strlen(entries[i]->d_name));
            char buffer[65536];
            size_t n;
            while ((n = fread(buffer, 1, sizeof buffer, file)) > 0)
                hash = fnv1a(hash, buffer, n);
            fclose(file);
        }
        free(entries[i]);
    }
    free(entries);
    return hash;
}

static int rgb_only(pf_image *image)
{
    static const char *const rgb[] = {"R", "G", "B"};
    pf_image selected = {0};
    pf_error err = {0};
    if (pf_image_select(image, rgb, 3, &selected, &err) != PF_OK) {
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 0;
    }
    pf_image_free(image);
    *image = selected;
    return 1;
}

/* Runs cycles_render.py; fills image (R, G, B) and seconds. 1 on success. */
static int render_cycles(const char *blender, const char *scene, uint32_t width, uint32_t height,
                         uint32_t spp, uint32_t seed, int threads, const char *out_path,
                         pf_image *image, double *seconds)
{
    const char *source = getenv("PF_SOURCE_DIR");
    char command[16384];
    snprintf(command, sizeof command,
             "'%s' -b --factory-startup -P '%s/bench/quality/cycles_render.py' -- '%s' '%s' "
             "%u %u %u %u %d 2>&1",
             blender, source ? source : ".", scene, out_path, width, height, spp, seed, threads);
    FILE *pipe = popen(command, "r");
    if (!pipe)
        return 0;
    char line[4096];
    *seconds = -1.0;
    while (fgets(line, sizeof line, pipe)) {
        if (!strncmp(line, "cycles_seconds ", 15))
            *seconds = atof(line + 15);
        else if (strstr(line, "Error") || strstr(line, "rror:"))
            fprintf(stderr, "  blender: %s", line);
    }
    int status = pclose(pipe);
    pf_error err = {0};
    if (status != 0 || *seconds < 0.0 ||
        pf_exr_read(out_path, image, NULL, NULL, &err) != PF_OK) {
        fprintf(stderr, "quality_bench: Cycles failed (%s)%s%s\n", command,
                err.message[0] ? ": " : "", err.message);
        return 0;
    }
    return rgb_only(image);
}

static pf_render_settings settings_for(pf_quality quality, uint32_t width, uint32_t height,
                                       uint32_t value, uint32_t seed, int denoise)
{
    pf_render_settings s = pf_render_settings_default();
    s.width = width;
    s.height = height;
    s.quality = quality;
    s.samples_per_pixel = value;
    s.seed = seed;
    s.aovs = denoise; /* the denoiser's guides */
    s.denoise = denoise ? PF_DENOISE_ON : PF_DENOISE_OFF;
    s.pixel_filter = PF_FILTER_BLACKMAN_HARRIS;
    return s;
}

static int render_ours(pf_renderer *renderer, const pf_scene_frame *frame,
                       const pf_render_settings *settings, pf_image *image, double *seconds)
{
    pf_error err = {0};
    double start = pf_time_ms();
    if (pf_render_frame(renderer, frame, settings, image, NULL, &err) != PF_OK ||
        (settings->denoise == PF_DENOISE_ON &&
         pf_denoise_image(image, 0, NULL, NULL, &err) != PF_OK)) {
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 0;
    }
    *seconds = (pf_time_ms() - start) / 1000.0;
    return rgb_only(image);
}

/*
 * A still shot of TEMPORAL_FRAMES frames with temporal reuse (see the top): fills image with
 * the last frame (R, G, B), seconds with the mean frame time, and prints the flicker and
 * the seam. 1 on success.
 */
static int render_still_shot(pf_renderer *renderer, const pf_scene_frame *frame,
                             const pf_render_settings *settings, uint64_t sequence_id,
                             const pf_image *truth, pf_image *image, double *seconds)
{
    pf_error err = {0};
    pf_denoise_history *history = NULL;
    if (pf_denoise_history_create(&history, &err) != PF_OK)
        return 0;
    pf_image previous = {0};
    double total_ms = 0.0, seam = 0.0, seam_warm = 0.0, last_flicker = 0.0;
    int ok = 1;
    for (int64_t number = 1; ok && number <= TEMPORAL_FRAMES; number++) {
        pf_render_settings s = *settings;
        s.sample_salt = (uint64_t)number;
        /* The run's first frame has nothing to blend: PF_TEMPORAL_WARM_UP× its samples, as
         * the frame pipeline renders it (its time is in the mean). */
        s.sample_scale = number == 1 ? PF_TEMPORAL_WARM_UP : 0;
        pf_image current = {0}, alone = {0}, warm = {0};
        double start = pf_time_ms();
        ok = pf_render_frame(renderer, frame, &s, &current, NULL, &err) == PF_OK;
        double rendered_ms = pf_time_ms() - start;
        if (ok && number == TEMPORAL_FRAMES) {
            /* Another worker's frame without history (not timed): this one's samples
             * denoised alone, and the warmed-up frame a run of it would start with. */
            pf_render_settings first = s;
            first.sample_scale = PF_TEMPORAL_WARM_UP;
            ok = pf_image_append_channels(&current, NULL, 0, &alone, &err) == PF_OK && /* a copy */
                 pf_denoise_image(&alone, 0, NULL, NULL, &err) == PF_OK &&
                 pf_render_frame(renderer, frame, &first, &warm, NULL, &err) == PF_OK &&
                 pf_denoise_image(&warm, 0, NULL, NULL, &err) == PF_OK;
        }
        pf_denoise_sequence sequence = {history, sequence_id, number, 1, 1, NULL,
                                        number == 1 ? (float)PF_TEMPORAL_WARM_UP : 1.0f};
        start = pf_time_ms();
        ok = ok && pf_denoise_image(&current, 0, &sequence, NULL, &err) == PF_OK;
        total_ms += rendered_ms + pf_time_ms() - start;
        if (ok && number == TEMPORAL_FRAMES)
            ok = pf_image_flicker(&alone, &previous, truth, &seam, &err) == PF_OK &&
                 pf_image_flicker(&warm, &previous, truth, &seam_warm, &err) == PF_OK &&
                 pf_image_flicker(&current, &previous, truth, &last_flicker, &err) == PF_OK;
        pf_image_free(&alone);
        pf_image_free(&warm);
        pf_image_free(&previous);
        previous = current;
    }
    pf_denoise_history_destroy(history);
    if (!ok) {
        pf_image_free(&previous);
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 0;
    }
    printf("  (still shot of %d frames: flicker %.6g between the last two; the last without "
           "history against the one before %.6g, warmed up (%ux samples) %.6g)\n",
           TEMPORAL_FRAMES, last_flicker, seam, PF_TEMPORAL_WARM_UP, seam_warm);
    *image = previous;
    *seconds = total_ms / TEMPORAL_FRAMES / 1000.0;
    return rgb_only(image);
}

/* One image's row: its error against the truth, into rows, the CSV and stdout. 1 on success. */
static int record(const char *renderer, const char *preset, const char *knob, uint32_t value,
                  double seconds, pf_image *image, const pf_image *truth, FILE *csv,
                  quality_row *rows, size_t *row_count)
{
    pf_image_metrics metrics;
    pf_error err = {0};
    pf_status status = pf_image_compare(image, truth, &metrics, &err);
    pf_image_free(image);
    if (status != PF_OK) {
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 0;
    }
    quality_row row = {renderer, preset, knob, value, seconds, metrics.relmse, metrics.rmse};
    if (*row_count < MAX_ROWS)
        rows[(*row_count)++] = row;
    fprintf(csv, "%s,%s,%s,%u,%.4f,%.6g,%.6g\n", row.renderer, row.preset, row.knob, row.value,
            row.seconds, row.relmse, row.rmse);
    printf("%-10s %-10s %-8s %6u %10.3f %12.6g %12.6g\n", row.renderer, row.preset, row.knob,
           row.value, row.seconds, row.relmse, row.rmse);
    fflush(stdout);
    return 1;
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: quality_bench SCENE WIDTH HEIGHT PREFIX [BLENDER|none] [THREADS]\n");
        return 2;
    }
    const char *scene_path = argv[1];
    uint32_t width = (uint32_t)atoi(argv[2]), height = (uint32_t)atoi(argv[3]);
    const char *prefix = argv[4];
    const char *blender = argc > 5 && strcmp(argv[5], "none") ? argv[5] : NULL;
    int threads = argc > 6 ? atoi(argv[6]) : 2;
    if (!width || !height || threads < 1) {
        fprintf(stderr, "quality_bench: bad size or thread count\n");
        return 2;
    }
    pf_error err = {0};
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    if (pf_scene_load(scene_path, &scene, &err) != PF_OK ||
        pf_scene_eval(scene, pf_scene_frame_time(scene, 1), &frame, &err) != PF_OK) {
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 2;
    }
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_vk_options options = {NULL, 0, NULL};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "quality_bench: %s\n", err.message);
        return 1;
    }
    /* PF_QUALITY_TRACE=device|host forces who traces the rays the host can trace (issue 43:
     * reference's wavefront, final's camera and gather rays, final's and fast's photons),
     * for their figures beside the device's. */
    const char *trace = getenv("PF_QUALITY_TRACE");
    if (trace && !strcmp(trace, "device"))
        pf_renderer_set_trace_site(renderer, PF_TRACE_DEVICE);
    else if (trace && !strcmp(trace, "host"))
        pf_renderer_set_trace_site(renderer, PF_TRACE_HOST);
    printf("quality_bench %s %ux%u, %d threads, device %s, the host-traceable rays traced "
           "by %s\n",
           scene_path, width, height, threads, pf_vk_info(ctx)->name,
           trace ? trace : "the planner's choice");

    /* The truth, cached by content. */
    char truth_path[4096], scratch[4096];
    snprintf(truth_path, sizeof truth_path, "%s-truth-%016" PRIx64 "-%ux%u-%s%u.exr", prefix,
             scene_hash(scene_path), width, height,
             !blender                    ? "reference"
             : getenv("PF_CYCLES_AS_IMPORTED") && !strcmp(getenv("PF_CYCLES_AS_IMPORTED"), "1")
                 ? "cycles-imported"
                 : "cycles",
             TRUTH_SPP);
    snprintf(scratch, sizeof scratch, "%s-cycles.exr", prefix);
    pf_image truth = {0};
    if (pf_exr_read(truth_path, &truth, NULL, NULL, &err) == PF_OK && rgb_only(&truth)) {
        printf("truth: %s (cached)\n", truth_path);
    } else {
        double seconds = 0.0;
        int ok;
        if (blender) {
            ok = render_cycles(blender, scene_path, width, height, TRUTH_SPP, 1000, threads,
                               truth_path, &truth, &seconds);
        } else {
            pf_render_settings s =
                settings_for(PF_QUALITY_REFERENCE, width, height, TRUTH_SPP, 1000, 0);
            ok = render_ours(renderer, &frame, &s, &truth, &seconds);
            ok = ok && pf_exr_write(truth_path, &truth, PF_EXR_FLOAT, NULL, 0, &err) == PF_OK;
        }
        if (!ok)
            return 1;
        printf("truth: %s (%s at %u spp, %.1f s)\n", truth_path, blender ? "Cycles" : "reference",
               TRUTH_SPP, seconds);
    }

    quality_row rows[MAX_ROWS];
    size_t row_count = 0;
    char csv_path[4096];
    snprintf(csv_path, sizeof csv_path, "%s.csv", prefix);
    FILE *csv = fopen(csv_path, "w");
    if (!csv) {
        fprintf(stderr, "quality_bench: cannot write %s\n", csv_path);
        return 1;
    }
    fprintf(csv, "renderer,preset,setting,value,seconds,relmse,rmse\n");
    printf("%-10s %-10s %-8s %6s %10s %12s %12s\n", "renderer", "preset", "setting", "value",
           "seconds", "relMSE", "RMSE");

    for (size_t s = 0; s < sizeof sweeps / sizeof sweeps[0]; s++) {
        if (!selected(sweeps[s].label))
            continue;
        pf_image image = {0};
        double seconds;
        /* Warm-up: pipelines compiled and the scene's BIH built before timing; reference's
         * with enough passes that its wavefront compiles the tail's kernel too, as a worker
         * has it after a few frames (PF_REFERENCE_WAVE_TAIL_MIN_TAILS, render_internal.h). */
        uint32_t warm_value = sweeps[s].quality == PF_QUALITY_REFERENCE ? 128u : 1u;
        pf_render_settings warm =
            settings_for(sweeps[s].quality, width, height, warm_value, 1, sweeps[s].denoise);
        if (!render_ours(renderer, &frame, &warm, &image, &seconds))
            return 1;
        pf_image_free(&image);
        for (const uint32_t *v = sweeps[s].values; *v; v++) {
            /* A seed of its own: the renderer reuses photons and LPVs across frames of
             * the same seed (a static scene), and each point must pay a whole frame. */
            pf_render_settings settings =
                settings_for(sweeps[s].quality, width, height, *v, 100 + (uint32_t)row_count,
                             sweeps[s].denoise);
            int rendered =
                sweeps[s].temporal
                    ? render_still_shot(renderer, &frame, &settings, 1000 + row_count, &truth,
                                        &image, &seconds)
                    : render_ours(renderer, &frame, &settings, &image, &seconds);
            if (!rendered ||
                !record("photonfarm", sweeps[s].label, sweeps[s].knob, *v, seconds, &image,
                        &truth, csv, rows, &row_count))
                return 1;
        }
    }
    for (const uint32_t *spp = cycles_spp; blender && selected("cycles") && *spp; spp++) {
        pf_image image = {0};
        double seconds;
        if (!render_cycles(blender, scene_path, width, height, *spp, 2, threads, scratch, &image,
                           &seconds) ||
            !record("cycles", "path", "spp", *spp, seconds, &image, &truth, csv, rows,
                    &row_count))
            return 1;
    }
    fclose(csv);
    remove(scratch);

    char svg_path[4096], title[4200];
    snprintf(svg_path, sizeof svg_path, "%s.svg", prefix);
    const char *name = strrchr(scene_path, '/');
    snprintf(title, sizeof title, "%s, %ux%u, %d threads: relMSE against seconds per frame",
             name ? name + 1 : scene_path, width, height, threads);
    if (!quality_plot_svg(svg_path, title, rows, row_count))
        fprintf(stderr, "quality_bench: cannot write %s\n", svg_path);
    quality_summary(rows, row_count, 0.01);
    quality_summary(rows, row_count, 0.002);
    printf("wrote %s and %s\n", csv_path, svg_path);

    pf_image_free(&truth);
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
    return 0;
}
