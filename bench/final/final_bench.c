/*
 * final_bench: relMSE against time of `--quality final` (photon mapping)
 * versus `--quality reference` (the unbiased path tracer), issue 6's
 * Benchmark section. For each scene: a long reference render (seed 1) is
 * the ground truth; then final at 1, 4, 16, 64 progressive passes (seed 2)
 * and, for each, the reference given the same wall time (time_budget_ms =
 * final's measured time, seed 3). Each row prints method, setting, seconds
 * and relMSE against the long render, overall (R, G, B: pf_image_compare)
 * and per channel (direct, indirect, caustic: the same formula over that
 * layer's R, G, B). The long render's own error is c/M (c from
 * bench/RESULTS.md's reference fit, M its spp): rows at or below it measure
 * the long render, not the method; the program prints its estimate from the
 * two equal-time references it rendered (relMSE of an N-spp render ≈ c/N +
 * c/M).
 *
 * caustic-anim is lit by a point light, whose caustics a path tracer never
 * finds (REFERENCE.md): the point light is replaced, in the evaluated frame,
 * by an equal-power sphere of radius SPHERE_LIGHT_RADIUS (pf_scene_frame_point_light_to_sphere),
 * so that both integrators render the same scene and the reference is a fair
 * ground truth for the caustic too. The scene file is not changed.
 *
 * Usage: final_bench [cornell.gltf [caustic-anim.gltf [width height [long_spp]]]]
 * (defaults: $PF_SOURCE_DIR/scenes/cornell/cornell.gltf,
 * $PF_SHARED_SCENES/caustic-anim/caustic-anim.gltf, 96 72, 512). Figures
 * are reports, never pass/fail. Run with LP_NUM_THREADS=2 on lavapipe.
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

/*
 * Sized for a 2-core VM on lavapipe (≈ 4·10⁴ reference paths/s) so that
 * both scenes finish in about 12 minutes: the long renders dominate
 * (512 spp × 6912 pixels each).
 */
#define DEFAULT_WIDTH 96u
#define DEFAULT_HEIGHT 72u
#define DEFAULT_LONG_SPP 512u
/* final's photons per pass: the Cornell test's count (tests/render/test_final.c). */
#define FINAL_PHOTONS_PER_PASS 20000u
/* Equal-time references stop on their time budget, never on this count. */
#define EQUAL_TIME_SPP_CAP 1000000u
/* A few centimetres: small next to the 1 m glass sphere, large enough to be found by paths. */
#define SPHERE_LIGHT_RADIUS 0.05f
#define SPHERE_LIGHT_SEGMENTS 16u
#define SPHERE_LIGHT_RINGS 8u
#define LONG_SEED 1u
#define FINAL_SEED 2u
#define EQUAL_TIME_SEED 3u
static const uint32_t final_passes[] = {1, 4, 16, 64};
#define FINAL_ROWS (sizeof final_passes / sizeof final_passes[0])

static const char *const layers[] = {"direct", "indirect", "caustic"};
#define LAYER_COUNT 3u

typedef struct bench_row {
    double seconds;
    uint32_t reached; /* passes (final) or spp (reference) */
    double relmse;
    double layer_relmse[LAYER_COUNT];
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

/* pf_image_compare's relMSE over one layer's R, G, B (NaN when a channel is missing). */
static double layer_relmse(const pf_image *image, const pf_image *reference, const char *layer)
{
    static const char *const components[3] = {"R", "G", "B"};
    double sum = 0.0;
    size_t pixels = (size_t)image->width * image->height;
    for (int c = 0; c < 3; c++) {
        char name[64];
        snprintf(name, sizeof name, "%s.%s", layer, components[c]);
        int a = pf_image_channel(image, name), b = pf_image_channel(reference, name);
        if (a < 0 || b < 0)
            return NAN;
        for (size_t p = 0; p < pixels; p++) {
            double x = image->pixels[p * image->channel_count + (size_t)a];
            double r = reference->pixels[p * reference->channel_count + (size_t)b];
            sum += (x - r) * (x - r) / (r * r + PF_RELMSE_EPSILON);
        }
    }
    return sum / (3.0 * pixels);
}

/* Renders and measures one row against the long reference. */
static pf_status measure(pf_renderer *renderer, const pf_scene_frame *frame,
                         const pf_render_settings *settings, const pf_image *reference,
                         bench_row *row, pf_error *err)
{
    pf_image image = {0};
    pf_frame_report report = {0};
    double start = pf_time_ms();
    pf_status status = pf_render_frame(renderer, frame, settings, &image, &report, err);
    row->seconds = (pf_time_ms() - start) / 1000.0;
    pf_image_metrics metrics;
    if (status == PF_OK)
        status = pf_image_compare(&image, reference, &metrics, err);
    if (status == PF_OK) {
        row->relmse = metrics.relmse;
        row->reached = (uint32_t)stage_counter(&report, "shade", "samples_per_pixel");
        for (uint32_t l = 0; l < LAYER_COUNT; l++)
            row->layer_relmse[l] = layer_relmse(&image, reference, layers[l]);
    }
    pf_image_free(&image);
    return status;
}

static void print_row(const char *method, const char *unit, const bench_row *row)
{
    printf("| %s | %u %s | %.2f | %.4g | %.4g | %.4g | %.4g |\n", method, row->reached, unit,
           row->seconds, row->relmse, row->layer_relmse[0], row->layer_relmse[1],
           row->layer_relmse[2]);
    fflush(stdout);
}

static int bench_scene(pf_renderer *renderer, const char *path, int replace_point_light,
                       uint32_t width, uint32_t height, uint32_t long_spp)
{
    pf_error err = {0};
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    pf_image reference = {0};
    int ok = 0;
    if (pf_scene_load(path, &scene, &err) != PF_OK ||
        pf_scene_eval(scene, 0.0, &frame, &err) != PF_OK)
        goto done;
    for (uint32_t l = frame.light_count; replace_point_light && l-- > 0;)
        if (frame.lights[l].kind == PF_LIGHT_POINT &&
            pf_scene_frame_point_light_to_sphere(&frame, l, SPHERE_LIGHT_RADIUS, SPHERE_LIGHT_SEGMENTS,
                                          SPHERE_LIGHT_RINGS, &err) != PF_OK)
            goto done;
    printf("\n## %s%s: %u triangles (%u emissive), %u punctual lights, %ux%u\n\n", path,
           replace_point_light ? " (point lights → equal-power spheres of radius 5 cm)" : "",
           frame.triangle_count, frame.emissive_triangle_count, frame.light_count, width, height);
    pf_render_settings long_settings = {width, height, PF_QUALITY_REFERENCE, long_spp, LONG_SEED,
                                        0, 0.0, 0};
    double start = pf_time_ms();
    if (pf_render_frame(renderer, &frame, &long_settings, &reference, NULL, &err) != PF_OK)
        goto done;
    printf("long reference: %u spp, seed %u, %.1f s\n\n", long_spp, LONG_SEED,
           (pf_time_ms() - start) / 1000.0);
    printf("| method | setting | time (s) | relMSE | direct | indirect | caustic |\n"
           "|---|---:|---:|---:|---:|---:|---:|\n");
    bench_row final_rows[FINAL_ROWS], reference_rows[FINAL_ROWS];
    for (uint32_t r = 0; r < FINAL_ROWS; r++) {
        pf_render_settings final_settings = {width, height, PF_QUALITY_FINAL, final_passes[r],
                                             FINAL_SEED, 0, 0.0, FINAL_PHOTONS_PER_PASS};
        if (measure(renderer, &frame, &final_settings, &reference, &final_rows[r], &err) != PF_OK)
            goto done;
        print_row("final", "passes", &final_rows[r]);
        pf_render_settings equal_time = {width, height, PF_QUALITY_REFERENCE, EQUAL_TIME_SPP_CAP,
                                         EQUAL_TIME_SEED, 0, final_rows[r].seconds * 1000.0, 0};
        if (measure(renderer, &frame, &equal_time, &reference, &reference_rows[r], &err) !=
            PF_OK)
            goto done;
        print_row("reference", "spp", &reference_rows[r]);
    }
    /* relMSE(N spp) ≈ c/N + c/M: c from the equal-time rows, least squares through the origin. */
    double numerator = 0.0, denominator = 0.0;
    for (uint32_t r = 0; r < FINAL_ROWS; r++) {
        double x = 1.0 / reference_rows[r].reached + 1.0 / long_spp;
        numerator += x * reference_rows[r].relmse;
        denominator += x * x;
    }
    double constant = numerator / denominator;
    printf("\nreference fit: relMSE ≈ %.4g / spp; the long render's own relMSE ≈ %.3g "
           "(rows near it are at the ground truth's floor)\n",
           constant, constant / long_spp);
    printf("equal time, relMSE final / reference:");
    for (uint32_t r = 0; r < FINAL_ROWS; r++)
        printf(" %.2f s: %.3g", final_rows[r].seconds,
               final_rows[r].relmse / reference_rows[r].relmse);
    printf("\n");
    ok = 1;
done:
    if (!ok)
        fprintf(stderr, "%s: %s\n", path, err.message);
    pf_image_free(&reference);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
    return ok;
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
    char cornell[1024], caustic[1024];
    const char *source_dir = getenv("PF_SOURCE_DIR");
    const char *shared = getenv("PF_SHARED_SCENES");
    snprintf(cornell, sizeof cornell, "%s/scenes/cornell/cornell.gltf",
             source_dir ? source_dir : ".");
    snprintf(caustic, sizeof caustic, "%s/caustic-anim/caustic-anim.gltf",
             shared ? shared : "../shared/scenes");
    uint32_t width = argc > 4 ? parse_count(argv[3]) : DEFAULT_WIDTH;
    uint32_t height = argc > 4 ? parse_count(argv[4]) : DEFAULT_HEIGHT;
    uint32_t long_spp = argc > 5 ? parse_count(argv[5]) : DEFAULT_LONG_SPP;
    if (!width || !height || !long_spp || argc > 6 || argc == 4) {
        fprintf(stderr, "usage: %s [cornell.gltf [caustic-anim.gltf [width height [long_spp]]]]\n",
                argv[0]);
        return 2;
    }
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_vk_options options = {NULL, 0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        pf_vk_destroy(ctx);
        return 1;
    }
    printf("final_bench: device %s (%s), final: %u photons per pass, seeds: long %u, final %u, "
           "equal-time reference %u\n",
           pf_vk_info(ctx)->name, pf_vk_info(ctx)->type, FINAL_PHOTONS_PER_PASS, LONG_SEED,
           FINAL_SEED, EQUAL_TIME_SEED);
    int ok = bench_scene(renderer, argc > 1 ? argv[1] : cornell, 0, width, height, long_spp) &&
             bench_scene(renderer, argc > 2 ? argv[2] : caustic, 1, width, height, long_spp);
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    return ok ? 0 : 1;
}
