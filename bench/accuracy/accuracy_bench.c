/*
 * accuracy_bench: issue 16's benchmark, the hard cases of
 * tests/accuracy/hard_cases.h. Prints figures, never pass/fail.
 *
 * Per case, a converged image is the ground truth: the reference path
 * tracer at CONVERGED_SPP, except `water`, whose caustic through the surface
 * no path tracer finds (a directional light behind a dielectric): there
 * `final` at CONVERGED_PASSES passes of CONVERGED_PHOTONS photons, whose
 * mean tests/accuracy/test_water_slab.c checks against the closed form. The
 * converged images are cached in the working directory as
 * accuracy-bench-<case>-<w>x<h>.exr (delete them after changing a scene).
 *
 * Then `final` at 1, 4 and 16 passes (default photons per pass) and the
 * reference given each of those wall times (--time-budget's mechanism: it
 * stops after the pass in flight), and `fast` at its defaults; for each:
 * seconds, relMSE on R, G, B (pf_image_compare, ε = 0.01), the mean over
 * R, G, B as a ratio to the converged image's, and the brightest pixel
 * over the converged image's brightest (fireflies). The same program built
 * at an earlier commit measures "before" (bench/RESULTS.md).
 *
 * Usage: accuracy_bench [WIDTH HEIGHT] (default 48 36). Run with
 * LP_NUM_THREADS=2 on lavapipe.
 */
#include "../../tests/accuracy/hard_cases.h"
#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_vk.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CONVERGED_SPP 1024u
#define CONVERGED_PASSES 256u
#define CONVERGED_PHOTONS 200000u

static int fail(const char *what, const pf_error *err)
{
    fprintf(stderr, "accuracy_bench: %s: %s\n", what, err->message);
    return 1;
}

static pf_render_settings settings_for(pf_quality quality, uint32_t width, uint32_t height,
                                       uint32_t samples, uint64_t seed)
{
    pf_render_settings s;
    memset(&s, 0, sizeof s);
    s.width = width;
    s.height = height;
    s.quality = quality;
    s.samples_per_pixel = samples;
    s.seed = seed;
    return s;
}

static int converged(pf_renderer *renderer, hard_case which, const ref_scene *scene,
                     uint32_t width, uint32_t height, pf_image *out)
{
    char cache[256];
    snprintf(cache, sizeof cache, "accuracy-bench-%s-%ux%u.exr", hard_case_name(which), width,
             height);
    pf_error err = {0};
    if (pf_exr_read(cache, out, NULL, NULL, &err) == PF_OK && out->width == width &&
        out->height == height)
        return 0;
    pf_image_free(out);
    pf_render_settings s = settings_for(PF_QUALITY_REFERENCE, width, height, CONVERGED_SPP, 1);
    if (which == HARD_WATER) {
        s = settings_for(PF_QUALITY_FINAL, width, height, CONVERGED_PASSES, 1);
        s.photons_per_pass = CONVERGED_PHOTONS;
    }
    double start = pf_time_ms();
    if (pf_render_frame(renderer, &scene->frame, &s, out, NULL, &err) != PF_OK)
        return fail("converged image", &err);
    printf("  (%s: converged image rendered in %.0f s, cached as %s)\n", hard_case_name(which),
           (pf_time_ms() - start) / 1000.0, cache);
    if (pf_exr_write(cache, out, PF_EXR_FLOAT, NULL, 0, &err) != PF_OK)
        fprintf(stderr, "accuracy_bench: cache %s not written: %s\n", cache, err.message);
    return 0;
}

/* Mean and brightest of R, G, B over the image. */
static void mean_max(const pf_image *image, double *mean, double *max)
{
    double sum = 0.0, best = 0.0;
    size_t pixels = (size_t)image->width * image->height;
    for (size_t p = 0; p < pixels; p++) {
        for (int c = 0; c < 3; c++) {
            double v = image->pixels[p * image->channel_count + (size_t)c];
            sum += v;
            best = v > best ? v : best;
        }
    }
    *mean = sum / (3.0 * (double)pixels);
    *max = best;
}

/* Renders settings, prints one row; seconds in *seconds. */
static int measure(pf_renderer *renderer, const ref_scene *scene, const pf_render_settings *s,
                   const char *label, const pf_image *truth, double *seconds)
{
    pf_image image = {0};
    pf_error err = {0};
    pf_frame_report report = {0};
    double start = pf_time_ms();
    if (pf_render_frame(renderer, &scene->frame, s, &image, &report, &err) != PF_OK)
        return fail(label, &err);
    *seconds = (pf_time_ms() - start) / 1000.0;
    static const char *const rgb[3] = {"R", "G", "B"};
    pf_image a = {0}, b = {0};
    pf_image_metrics metrics;
    if (pf_image_select(&image, rgb, 3, &a, &err) != PF_OK ||
        pf_image_select(truth, rgb, 3, &b, &err) != PF_OK ||
        pf_image_compare(&a, &b, &metrics, &err) != PF_OK)
        return fail("compare", &err);
    double mean, max, truth_mean, truth_max;
    mean_max(&image, &mean, &max);
    mean_max(truth, &truth_mean, &truth_max);
    double samples = NAN;
    for (uint32_t r = 0; r < report.stage_count; r++) {
        const pf_stage_timing *row = &report.stages[r];
        if (strcmp(row->stage, "shade") != 0)
            continue;
        for (uint32_t c = 0; c < row->counter_count; c++) {
            if (!strcmp(row->counters[c].name, "samples_per_pixel") ||
                !strcmp(row->counters[c].name, "passes"))
                samples = row->counters[c].value;
        }
    }
    printf("  %-28s %8.2f %8.0f %12.5f %10.3f %10.2f\n", label, *seconds, samples,
           metrics.relmse, mean / truth_mean, max / truth_max);
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&image);
    return 0;
}

int main(int argc, char **argv)
{
    uint32_t width = argc > 2 ? (uint32_t)atoi(argv[1]) : 48u;
    uint32_t height = argc > 2 ? (uint32_t)atoi(argv[2]) : 36u;
    if (width == 0 || height == 0 || width > 4096 || height > 4096) {
        fprintf(stderr, "usage: accuracy_bench [WIDTH HEIGHT]\n");
        return 2;
    }
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {NULL, 0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK)
        return fail("vulkan", &err);
    pf_renderer *renderer = NULL;
    if (pf_renderer_create(ctx, &renderer, &err) != PF_OK)
        return fail("renderer", &err);
    setvbuf(stdout, NULL, _IOLBF, 0);
    printf("device: %s; %ux%u; truth: reference %u spp (water: final %u passes × %u photons)\n",
           pf_vk_info(ctx)->name, width, height, CONVERGED_SPP, CONVERGED_PASSES,
           CONVERGED_PHOTONS);
    int status = 0;
    for (int which = 0; which < HARD_CASE_COUNT && status == 0; which++) {
        ref_scene scene;
        hard_case_build((hard_case)which, &scene);
        pf_image truth = {0};
        status = converged(renderer, (hard_case)which, &scene, width, height, &truth);
        if (status == 0) {
            printf("== %s\n  %-28s %8s %8s %12s %10s %10s\n", hard_case_name((hard_case)which),
                   "render", "seconds", "spp", "relMSE", "mean", "max");
            /* Warm-up: the first render of each integrator compiles its pipelines. */
            double seconds;
            if (which == 0) {
                pf_render_settings warm = settings_for(PF_QUALITY_FINAL, width, height, 1, 99);
                pf_image image = {0};
                pf_render_frame(renderer, &scene.frame, &warm, &image, NULL, &err);
                pf_image_free(&image);
                warm.quality = PF_QUALITY_FAST;
                pf_render_frame(renderer, &scene.frame, &warm, &image, NULL, &err);
                pf_image_free(&image);
            }
            static const uint32_t passes[] = {1, 4, 16};
            for (size_t i = 0; i < 3 && status == 0; i++) {
                char label[64];
                snprintf(label, sizeof label, "final %u passes", passes[i]);
                pf_render_settings s = settings_for(PF_QUALITY_FINAL, width, height, passes[i], 7);
                status = measure(renderer, &scene, &s, label, &truth, &seconds);
                if (status != 0 || which == HARD_WATER)
                    continue;
                snprintf(label, sizeof label, "reference in %.1f s", seconds);
                s = settings_for(PF_QUALITY_REFERENCE, width, height, 65536, 7);
                s.time_budget_ms = seconds * 1000.0;
                status = measure(renderer, &scene, &s, label, &truth, &seconds);
            }
            if (status == 0) {
                pf_render_settings s = settings_for(PF_QUALITY_FAST, width, height, 0, 7);
                status = measure(renderer, &scene, &s, "fast", &truth, &seconds);
            }
        }
        pf_image_free(&truth);
        ref_scene_free(&scene);
    }
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    return status;
}
