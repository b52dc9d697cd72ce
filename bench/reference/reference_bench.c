/*
 * reference_bench: speed and convergence of the reference path tracer
 * (--quality reference), as issue 5's Benchmark section asks. On the Cornell
 * box it renders a long image of itself (seed 1), then renders at 1, 2, 4, ...
 * samples per pixel with another seed (2) and prints, per row: wall time of
 * pf_render_frame, paths/s (the shade row's `paths` over the wall time), and
 * RMSE/relMSE against the long render (pf_image_compare over R, G, B). Then
 * the time to reach relMSE 0.01 and 0.001: the first row at or below the
 * target, and the time interpolated on the log-log line between the rows
 * around it (relMSE ∝ 1/spp for an unbiased estimator).
 *
 * The long render (M spp) has its own error: for two independent renders the
 * measured relMSE ≈ c/N + c/M. The program fits c by least squares over the
 * rows and also prints, for each target T, the estimated samples (c/T) and
 * time (at the largest row's seconds per spp) to reach T against the exact
 * image — the only figure available when T is below the long render's own
 * floor c/M, which on a 2-core lavapipe it is for any long render that
 * finishes in minutes at 640×480.
 *
 * Usage: reference_bench [scene.gltf [width height [long_spp [max_spp]]]]
 * (defaults: $PF_SOURCE_DIR/scenes/cornell/cornell.gltf, else
 * scenes/cornell/cornell.gltf; 640 480; 32; 4). Figures are reports, never
 * pass/fail. Run with LP_NUM_THREADS=2 on lavapipe.
 */
#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The image size. */
#define BENCH_WIDTH 640u
#define BENCH_HEIGHT 480u
/*
 * Defaults sized for a 2-core VM on lavapipe (~2·10⁴ paths/s, ~14 s per spp
 * at 640×480) to finish in about 10 minutes: 32 + 1 + 2 + 4 spp in all.
 * On a GPU pass larger counts on the command line.
 */
#define DEFAULT_LONG_SPP 32u
#define DEFAULT_MAX_SPP 4u
#define LONG_SEED 1u
#define SHORT_SEED 2u
/* The convergence targets. */
static const double relmse_targets[] = {0.01, 0.001};
#define TARGET_COUNT (sizeof relmse_targets / sizeof relmse_targets[0])
#define MAX_ROWS 32u

typedef struct bench_row {
    uint32_t spp;
    double wall_ms;
    double paths;
    pf_image_metrics metrics;
} bench_row;

static double stage_counter(const pf_frame_report *report, const char *stage, const char *name)
{
    for (uint32_t s = 0; s < report->stage_count; s++) {
        if (strcmp(report->stages[s].stage, stage) != 0)
            continue;
        for (uint32_t c = 0; c < report->stages[s].counter_count; c++)
            if (!strcmp(report->stages[s].counters[c].name, name))
                return report->stages[s].counters[c].value;
    }
    return NAN;
}

static pf_status render(pf_renderer *renderer, const pf_scene_frame *frame, uint32_t width,
                        uint32_t height, uint32_t spp, uint64_t seed, pf_image *image,
                        double *wall_ms, double *paths, pf_error *err)
{
    pf_render_settings settings = {.width = width,
                                   .height = height,
                                   .quality = PF_QUALITY_REFERENCE,
                                   .samples_per_pixel = spp,
                                   .seed = seed,
                                   .aovs = 0};
    pf_frame_report report = {0};
    double start = pf_time_ms();
    pf_status status = pf_render_frame(renderer, frame, &settings, image, &report, err);
    *wall_ms = pf_time_ms() - start;
    *paths = stage_counter(&report, "shade", "paths");
    if (status == PF_OK && report.discarded_samples)
        printf("  (%u spp: %llu samples discarded as NaN/Inf)\n", spp,
               (unsigned long long)report.discarded_samples);
    return status;
}

/* Parses a positive 32-bit count; 0 when malformed. */
static uint32_t parse_count(const char *text)
{
    char *end = NULL;
    unsigned long value = strtoul(text, &end, 10);
    return (end && *end == '\0' && value > 0 && value <= UINT32_MAX) ? (uint32_t)value : 0;
}

int main(int argc, char **argv)
{
    char default_path[1024];
    const char *source_dir = getenv("PF_SOURCE_DIR");
    snprintf(default_path, sizeof default_path, "%s/scenes/cornell/cornell.gltf",
             source_dir ? source_dir : ".");
    const char *path = argc > 1 ? argv[1] : default_path;
    uint32_t width = argc > 3 ? parse_count(argv[2]) : BENCH_WIDTH;
    uint32_t height = argc > 3 ? parse_count(argv[3]) : BENCH_HEIGHT;
    uint32_t long_spp = argc > 4 ? parse_count(argv[4]) : DEFAULT_LONG_SPP;
    uint32_t max_spp = argc > 5 ? parse_count(argv[5]) : DEFAULT_MAX_SPP;
    if (!width || !height || !long_spp || !max_spp || argc > 6 || argc == 3) {
        fprintf(stderr, "usage: %s [scene.gltf [width height [long_spp [max_spp]]]]\n", argv[0]);
        return 2;
    }

    pf_error err = {0};
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_image reference = {0};
    int exit_code = 1;
    if (pf_scene_load(path, &scene, &err) != PF_OK ||
        pf_scene_eval(scene, 0.0, &frame, &err) != PF_OK) {
        fprintf(stderr, "%s\n", err.message);
        goto done;
    }
    pf_vk_options options = {NULL, 0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        goto done;
    }
    printf("reference_bench: %s, %u triangles (%u emissive), %u lights, %ux%u, device %s (%s)\n",
           path, frame.triangle_count, frame.emissive_triangle_count, frame.light_count, width,
           height, pf_vk_info(ctx)->name, pf_vk_info(ctx)->type);

    double long_ms = 0.0, long_paths = 0.0;
    if (render(renderer, &frame, width, height, long_spp, LONG_SEED, &reference, &long_ms,
               &long_paths, &err) != PF_OK) {
        fprintf(stderr, "long render: %s\n", err.message);
        goto done;
    }
    printf("long render: %u spp, seed %u: %.1f s, %.3g paths/s\n\n", long_spp, LONG_SEED,
           long_ms / 1000.0, long_paths / (long_ms / 1000.0));

    bench_row rows[MAX_ROWS];
    uint32_t row_count = 0;
    printf("| spp | time (s) | paths/s | RMSE | relMSE |\n|---:|---:|---:|---:|---:|\n");
    for (uint32_t spp = 1; spp <= max_spp && row_count < MAX_ROWS; spp *= 2) {
        bench_row *row = &rows[row_count];
        pf_image image = {0};
        row->spp = spp;
        if (render(renderer, &frame, width, height, spp, SHORT_SEED, &image, &row->wall_ms,
                   &row->paths, &err) != PF_OK ||
            pf_image_compare(&image, &reference, &row->metrics, &err) != PF_OK) {
            fprintf(stderr, "%u spp: %s\n", spp, err.message);
            pf_image_free(&image);
            goto done;
        }
        pf_image_free(&image);
        printf("| %u | %.2f | %.3g | %.4g | %.4g |\n", spp, row->wall_ms / 1000.0,
               row->paths / (row->wall_ms / 1000.0), row->metrics.rmse, row->metrics.relmse);
        fflush(stdout);
        row_count++;
        if (spp > UINT32_MAX / 2)
            break;
    }

    /* measured relMSE ≈ c (1/N + 1/M): c from the least-squares fit through the origin. */
    double numerator = 0.0, denominator = 0.0;
    for (uint32_t r = 0; r < row_count; r++) {
        double x = 1.0 / rows[r].spp + 1.0 / long_spp;
        numerator += x * rows[r].metrics.relmse;
        denominator += x * x;
    }
    double constant = denominator > 0 ? numerator / denominator : NAN;
    const bench_row *last = &rows[row_count - 1];
    double ms_per_spp = last->wall_ms / last->spp;
    printf("\nfit: relMSE against the exact image ≈ %.4g / spp; the long render's own ≈ %.3g\n",
           constant, constant / long_spp);

    for (size_t t = 0; t < TARGET_COUNT; t++) {
        double target = relmse_targets[t];
        uint32_t hit = row_count;
        for (uint32_t r = 0; r < row_count && hit == row_count; r++)
            if (rows[r].metrics.relmse <= target)
                hit = r;
        double spp_needed = constant / target;
        printf("relMSE %g: estimated %.0f spp, %.1f s against the exact image", target,
               spp_needed, ms_per_spp * spp_needed / 1000.0);
        if (hit == row_count) {
            printf("; against the long render not reached by %u spp (relMSE %.4g)%s\n",
                   last->spp, last->metrics.relmse,
                   target <= constant / long_spp ? ", below its own floor" : "");
            continue;
        }
        double interpolated = rows[hit].wall_ms;
        if (hit > 0) {
            /* Log-log interpolation between the rows either side of the target. */
            const bench_row *a = &rows[hit - 1], *b = &rows[hit];
            double f = log(a->metrics.relmse / target) / log(a->metrics.relmse / b->metrics.relmse);
            interpolated = exp(log(a->wall_ms) + f * (log(b->wall_ms) - log(a->wall_ms)));
        }
        printf("; against the long render reached at %u spp in %.2f s (interpolated %.2f s)\n",
               rows[hit].spp, rows[hit].wall_ms / 1000.0, interpolated / 1000.0);
    }
    exit_code = 0;
done:
    pf_image_free(&reference);
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
    return exit_code;
}
