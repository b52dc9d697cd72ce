/*
 * lpv_bench: issue 11's benchmark for the `fast` preset (cascaded light
 * propagation volumes). Prints figures, never pass/fail.
 *
 * Part 1, the LPV stages: on the Cornell box, 4 cascades of 32³ and 64³
 * cells at 8 and 16 iterations: lpv_geometry and lpv_inject (CPU, wall ms)
 * and lpv_propagate (GPU ms from timestamps; wall ms where it ran on the
 * host, the row's on_host counter), per cascade (the row's total
 * divided by the cascade count), read from the frame's stage rows. A
 * configuration is rendered twice with different seeds: the first frame's
 * geometry row (the second reuses the geometry volume) and the second
 * frame's injection and propagation (after the propagation kernel's first
 * dispatch compiled it).
 *
 * Part 2, the presets: per scene, a long reference render (LONG_SPP spp at
 * the error size, cached in the working directory as
 * lpv-bench-<scene>-<w>x<h>-<spp>.exr) is the ground truth; preview, fast,
 * final and the reference given fast's wall time are rendered at the error
 * size and compared on R, G, B (relMSE, pf_image_compare), each with 4
 * seeds (mean, smallest and largest relMSE). Then the frame
 * time of preview, fast and final at the timing size (640×480), each after
 * a warm-up frame of the same preset (pipelines compiled), and fast's
 * second frame of the unchanged scene (photons and LPV reused).
 *
 * Part 3, the injection offset: the Cornell box's fast indirect layer
 * against the reference's at offsets of half a cell and a whole cell.
 *
 * caustic-anim is lit by a point light, which the reference cannot render
 * caustics of: as in bench/final, the light is replaced by an equal-power
 * 5 cm sphere in the evaluated frame for every preset.
 *
 * Part 4, the energy scale (also alone: `lpv_bench energy [SHARED_SCENES_DIR [W H [SPP]]]`):
 * per scene, fast's indirect layer against the reference's, the LPV scaled to the photons'
 * energy and not (lpv.unscaled), with shade's lpv_energy_scale.
 *
 * Part 0 alone, `lpv_bench sites`: the propagation on the device
 * (lpv_propagate.comp) against the host (pf_lpv_propagate_host), the same
 * volumes in 7 alternating rounds: 4 cascades of 32³ and of 64³, 8
 * iterations, occlusion on; random SH and geometry (neither path branches
 * on the data). Medians of wall ms (and the device's GPU ms), and how far
 * apart the two accumulations are.
 *
 * Usage: lpv_bench [energy] [SHARED_SCENES_DIR [ERROR_W ERROR_H [LONG_SPP]]] | lpv_bench sites
 * (defaults: $PF_SHARED_SCENES or ../shared/scenes, 160 120, 512). The
 * Cornell box is the project's scenes/cornell ($PF_SOURCE_DIR or .). Run
 * with LP_NUM_THREADS=2 on lavapipe.
 */
#include "pf_common.h"
#include "pf_image.h"
#include "pf_lpv.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"
#include "../bench_stats.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_ERROR_WIDTH 160u
#define DEFAULT_ERROR_HEIGHT 120u
#define DEFAULT_LONG_SPP 512u
#define TIMING_WIDTH 640u
#define TIMING_HEIGHT 480u
#define SPHERE_LIGHT_RADIUS 0.05f
#define SPHERE_LIGHT_SEGMENTS 16u
#define SPHERE_LIGHT_RINGS 8u

typedef struct bench_scene {
    const char *name;
    char path[1024];
    pf_scene *scene;
    pf_scene_frame frame;
} bench_scene;

static int fail(const char *what, const pf_error *err)
{
    fprintf(stderr, "lpv_bench: %s: %s\n", what, err ? err->message : "out of memory");
    return 1;
}

static const pf_stage_timing *row_named(const pf_frame_report *report, const char *stage)
{
    for (uint32_t i = 0; i < report->stage_count; i++) {
        if (!strcmp(report->stages[i].stage, stage))
            return &report->stages[i];
    }
    return NULL;
}

static pf_render_settings preset(pf_quality quality, uint32_t width, uint32_t height)
{
    pf_render_settings settings = {width, height, quality, 0, 2, 0, 0.0, 0};
    return settings;
}

/* relMSE on R, G, B of a against reference b. */
static int rgb_relmse(const pf_image *a, const pf_image *b, double *relmse, pf_error *err)
{
    static const char *const rgb[3] = {"R", "G", "B"};
    pf_image x, y;
    pf_image_metrics metrics;
    pf_status status = pf_image_select(a, rgb, 3, &x, err);
    if (status == PF_OK)
        status = pf_image_select(b, rgb, 3, &y, err);
    if (status == PF_OK)
        status = pf_image_compare(&x, &y, &metrics, err);
    pf_image_free(&x);
    pf_image_free(&y);
    *relmse = status == PF_OK ? metrics.relmse : NAN;
    return status == PF_OK;
}

/* relMSE of a's "indirect" layer against b's, and a's mean over b's. */
static int indirect_error(const pf_image *a, const pf_image *b, double *relmse, double *ratio,
                          pf_error *err)
{
    static const char *const layer[3] = {"indirect.R", "indirect.G", "indirect.B"};
    pf_image x, y;
    pf_image_metrics metrics;
    pf_status status = pf_image_select(a, layer, 3, &x, err);
    if (status == PF_OK)
        status = pf_image_select(b, layer, 3, &y, err);
    if (status == PF_OK)
        status = pf_image_compare(&x, &y, &metrics, err);
    pf_image_free(&x);
    pf_image_free(&y);
    if (status != PF_OK)
        return 0;
    *relmse = metrics.relmse;
    double sum_a = 0.0, sum_b = 0.0;
    for (int c = 0; c < 3; c++) {
        sum_a += metrics.mean_a[c];
        sum_b += metrics.mean_b[c];
    }
    *ratio = sum_a / sum_b;
    return 1;
}

#define SITE_ROUNDS 7

static int part_sites(pf_vk_context *ctx)
{
    printf("== LPV propagation: device against host (4 cascades, 8 iterations, occlusion on, "
           "%d alternating rounds, medians)\n", SITE_ROUNDS);
    printf("%6s %16s %16s %14s %10s %16s\n", "size", "device wall ms", "device GPU ms",
           "host wall ms", "speed-up", "max difference");
    pf_error err = {0};
    pf_lpv *lpv = NULL;
    if (pf_lpv_create(ctx, &lpv, &err) != PF_OK)
        return fail("LPV", &err);
    const uint32_t sizes[2] = {32, 64};
    for (int s = 0; s < 2; s++) {
        pf_lpv_layout layout;
        memset(&layout, 0, sizeof layout);
        layout.count = 4;
        layout.size = sizes[s];
        for (uint32_t k = 0; k < layout.count; k++) {
            layout.cascades[k].iterations = 8;
            layout.cascades[k].snapshot_iterations = k ? 4 : 0;
        }
        uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
        float *injected = malloc(floats * sizeof(float)), *gv = malloc(floats * sizeof(float));
        float *device = malloc(floats * sizeof(float)), *host = malloc(floats * sizeof(float));
        if (!injected || !gv || !device || !host)
            return fail("LPV volumes", NULL);
        uint32_t state = 1u;
        for (uint64_t i = 0; i < floats; i++) {
            state = state * 1664525u + 1013904223u;
            float r = (float)(state >> 8) / 16777216.0f;
            injected[i] = i % 4 == 0 ? 1.0f + r : r - 0.5f;
            state = state * 1664525u + 1013904223u;
            gv[i] = (state >> 8) % 5 == 0 ? (float)(state >> 8) / 16777216.0f : 0.0f;
        }
        double device_wall[SITE_ROUNDS], device_gpu[SITE_ROUNDS], host_wall[SITE_ROUNDS];
        pf_status status = PF_OK;
        /* A first device run compiles the pipelines. */
        pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
        status = pf_lpv_propagate(lpv, &layout, injected, gv, NULL, &err);
        for (int r = 0; status == PF_OK && r < SITE_ROUNDS; r++) {
            pf_lpv_propagate_stats stats;
            pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
            double start = pf_time_ms();
            status = pf_lpv_propagate(lpv, &layout, injected, gv, &stats, &err);
            device_wall[r] = pf_time_ms() - start;
            device_gpu[r] = stats.gpu_ms;
            if (status == PF_OK && r == 0)
                status = pf_lpv_download(lpv, device, floats, &err);
            pf_lpv_set_site(lpv, PF_LPV_SITE_HOST);
            start = pf_time_ms();
            if (status == PF_OK)
                status = pf_lpv_propagate(lpv, &layout, injected, gv, &stats, &err);
            host_wall[r] = pf_time_ms() - start;
            if (status == PF_OK && r == 0)
                status = pf_lpv_download(lpv, host, floats, &err);
        }
        if (status != PF_OK)
            return fail("LPV propagation", &err);
        double worst = 0.0, scale = 0.0;
        for (uint64_t i = 0; i < floats; i++) {
            worst = fmax(worst, fabs((double)host[i] - (double)device[i]));
            scale = fmax(scale, fabs((double)device[i]));
        }
        double dw = bench_median(device_wall, SITE_ROUNDS);
        double dg = bench_median(device_gpu, SITE_ROUNDS);
        double hw = bench_median(host_wall, SITE_ROUNDS);
        printf("%4u³ %16.1f %16.1f %14.1f %9.2f× %16.2g\n", sizes[s], dw, dg, hw, dw / hw,
               worst / scale);
        free(injected);
        free(gv);
        free(device);
        free(host);
    }
    pf_lpv_destroy(lpv);
    printf("(host: the cascades on up to one thread per online CPU; max difference: the largest "
           "|host − device| over the largest |device|)\n");
    return 0;
}

static int part_stages(pf_vk_context *ctx, const pf_scene_frame *frame)
{
    printf("== LPV stages (Cornell box, 4 cascades, per cascade)\n");
    printf("%6s %10s %14s %12s %16s %12s\n", "size", "iterations", "geometry ms", "inject ms",
           "propagate ms", "vpls");
    const uint32_t sizes[2] = {32, 64}, iterations[2] = {8, 16};
    for (int s = 0; s < 2; s++) {
        for (int i = 0; i < 2; i++) {
            pf_renderer *renderer = NULL;
            pf_error err = {0};
            if (pf_renderer_create(ctx, &renderer, &err) != PF_OK)
                return fail("renderer", &err);
            pf_render_settings settings = preset(PF_QUALITY_FAST, 64, 48);
            settings.lpv.size = sizes[s];
            settings.lpv.iterations[0] = iterations[i];
            pf_frame_report first = {0}, second = {0};
            pf_image image;
            pf_status status = pf_render_frame(renderer, frame, &settings, &image, &first, &err);
            if (status == PF_OK) {
                pf_image_free(&image);
                settings.seed = 3;
                status = pf_render_frame(renderer, frame, &settings, &image, &second, &err);
            }
            if (status != PF_OK) {
                pf_renderer_destroy(renderer);
                return fail("fast render", &err);
            }
            pf_image_free(&image);
            const pf_stage_timing *geometry = row_named(&first, "lpv_geometry");
            const pf_stage_timing *inject = row_named(&second, "lpv_inject");
            const pf_stage_timing *propagate = row_named(&second, "lpv_propagate");
            double vpls = 0.0, on_host = 0.0;
            for (uint32_t c = 0; inject && c < inject->counter_count; c++)
                if (!strcmp(inject->counters[c].name, "vpls"))
                    vpls = inject->counters[c].value;
            for (uint32_t c = 0; propagate && c < propagate->counter_count; c++)
                if (!strcmp(propagate->counters[c].name, "on_host"))
                    on_host = propagate->counters[c].value;
            double propagate_ms = !propagate ? NAN
                                  : on_host  ? propagate->wall_ms
                                             : propagate->gpu_ms;
            printf("%4u³ %10u %14.2f %12.2f %11.2f %-4s %12.0f\n", sizes[s], iterations[i],
                   geometry ? geometry->wall_ms / 4.0 : NAN, inject ? inject->wall_ms / 4.0 : NAN,
                   propagate_ms / 4.0, on_host ? "host" : "GPU", vpls);
            pf_renderer_destroy(renderer);
        }
    }
    printf("(seed thesis, R9 Fury: 4 cascades of 32³, 8 iterations, propagation 2.9 ms in all)\n");
    return 0;
}

/* Loads the long reference from the cache file or renders and writes it. */
static int long_reference(pf_renderer *renderer, const bench_scene *scene, uint32_t width,
                          uint32_t height, uint32_t spp, pf_image *out)
{
    char cache[512];
    snprintf(cache, sizeof cache, "lpv-bench-%s-%ux%u-%u.exr", scene->name, width, height, spp);
    pf_error err = {0};
    if (pf_exr_read(cache, out, NULL, NULL, &err) == PF_OK && out->width == width &&
        out->height == height)
        return 0;
    pf_image_free(out);
    pf_render_settings settings = preset(PF_QUALITY_REFERENCE, width, height);
    settings.samples_per_pixel = spp;
    settings.seed = 1;
    double start = pf_time_ms();
    if (pf_render_frame(renderer, &scene->frame, &settings, out, NULL, &err) != PF_OK)
        return fail("long reference", &err);
    printf("  (%s: long reference %u spp rendered in %.0f s, cached as %s)\n", scene->name, spp,
           (pf_time_ms() - start) / 1000.0, cache);
    if (pf_exr_write(cache, out, PF_EXR_FLOAT, NULL, 0, &err) != PF_OK)
        fprintf(stderr, "lpv_bench: cache %s not written: %s\n", cache, err.message);
    return 0;
}

/*
 * Renders one preset at the error size with ERROR_SEEDS seeds; prints the
 * mean seconds and the mean, smallest and largest relMSE. Several seeds
 * because a few pixels decide the error at low sample counts: a bright
 * emitter seen through the tail of the pixel filter (the Cornell light at
 * 2 spp: relMSE 0.015 to 0.2 by seed).
 */
#define ERROR_SEEDS 4u
static int error_row(pf_renderer *renderer, const bench_scene *scene, pf_render_settings settings,
                     const char *label, const pf_image *truth, double *seconds_out)
{
    double seconds = 0.0, sum = 0.0, low = INFINITY, high = 0.0;
    for (uint32_t seed = 0; seed < ERROR_SEEDS; seed++) {
        pf_error err = {0};
        pf_image image;
        settings.seed = 11 + seed;
        double start = pf_time_ms();
        if (pf_render_frame(renderer, &scene->frame, &settings, &image, NULL, &err) != PF_OK)
            return fail(label, &err);
        seconds += (pf_time_ms() - start) / 1000.0 / ERROR_SEEDS;
        double relmse = NAN;
        rgb_relmse(&image, truth, &relmse, &err);
        sum += relmse / ERROR_SEEDS;
        low = fmin(low, relmse);
        high = fmax(high, relmse);
        pf_image_free(&image);
    }
    printf("  %-12s %-24s %8.2f s  relMSE %.5f (%.5f to %.5f over %u seeds)\n", scene->name,
           label, seconds, sum, low, high, ERROR_SEEDS);
    if (seconds_out)
        *seconds_out = seconds;
    return 0;
}

/* Frame time at the timing size after a warm-up frame (second: the same frame again). */
static int timing_row(pf_vk_context *ctx, const bench_scene *scene, pf_quality quality)
{
    pf_renderer *renderer = NULL;
    pf_error err = {0};
    if (pf_renderer_create(ctx, &renderer, &err) != PF_OK)
        return fail("renderer", &err);
    pf_render_settings settings = preset(quality, TIMING_WIDTH, TIMING_HEIGHT);
    pf_image image;
    double ms[3] = {0, 0, 0};
    for (int run = 0; run < 3; run++) {
        /* Run 0 warms up (compiles); run 1 changes the seed (a fresh frame); run 2 repeats it. */
        settings.seed = run == 0 ? 7 : 8;
        pf_frame_report report = {0};
        double start = pf_time_ms();
        if (pf_render_frame(renderer, &scene->frame, &settings, &image, &report, &err) != PF_OK) {
            pf_renderer_destroy(renderer);
            return fail("timing render", &err);
        }
        ms[run] = pf_time_ms() - start;
        pf_image_free(&image);
    }
    printf("  %-12s %-10s %ux%u: %.3f s per frame", scene->name, pf_quality_name(quality),
           TIMING_WIDTH, TIMING_HEIGHT, ms[1] / 1000.0);
    if (quality == PF_QUALITY_FAST || quality == PF_QUALITY_FINAL)
        printf(", unchanged second frame %.3f s (%.2fx)", ms[2] / 1000.0, ms[1] / ms[2]);
    printf("\n");
    pf_renderer_destroy(renderer);
    return 0;
}

/* Part 4: fast's indirect light scaled to the photons' energy and not, against the truth. */
static int part_energy(pf_renderer *renderer, const bench_scene *scene, const pf_image *truth,
                       uint32_t width, uint32_t height)
{
    for (int unscaled = 0; unscaled < 2; unscaled++) {
        pf_render_settings settings = preset(PF_QUALITY_FAST, width, height);
        settings.samples_per_pixel = 8;
        settings.seed = 11;
        settings.lpv.unscaled = unscaled;
        pf_image image;
        pf_frame_report report = {0};
        pf_error err = {0};
        if (pf_render_frame(renderer, &scene->frame, &settings, &image, &report, &err) != PF_OK)
            return fail("energy render", &err);
        double relmse = NAN, ratio = NAN, scale = NAN;
        indirect_error(&image, truth, &relmse, &ratio, &err);
        const pf_stage_timing *shade = row_named(&report, "shade");
        for (uint32_t c = 0; shade && c < shade->counter_count; c++)
            if (!strcmp(shade->counters[c].name, "lpv_energy_scale"))
                scale = shade->counters[c].value;
        printf("  %-12s %-9s scale %.3f: indirect relMSE %.5f, mean %.3f of the reference's\n",
               scene->name, unscaled ? "unscaled" : "scaled", scale, relmse, ratio);
        pf_image_free(&image);
    }
    return 0;
}

static int load_scene(bench_scene *scene, const char *name, const char *path)
{
    pf_error err = {0};
    scene->name = name;
    snprintf(scene->path, sizeof scene->path, "%s", path);
    if (pf_scene_load(path, &scene->scene, &err) != PF_OK ||
        pf_scene_eval(scene->scene, 0.0, &scene->frame, &err) != PF_OK)
        return fail(path, &err);
    for (uint32_t l = scene->frame.light_count; !strcmp(name, "caustic-anim") && l-- > 0;)
        if (scene->frame.lights[l].kind == PF_LIGHT_POINT &&
            pf_scene_frame_point_light_to_sphere(&scene->frame, l, SPHERE_LIGHT_RADIUS,
                                                 SPHERE_LIGHT_SEGMENTS, SPHERE_LIGHT_RINGS,
                                                 &err) != PF_OK)
            return fail("point light to sphere", &err);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 2 && !strcmp(argv[1], "sites")) {
        pf_error err = {0};
        pf_vk_context *ctx = NULL;
        pf_vk_options options = {NULL, 0};
        if (pf_vk_create(&options, &ctx, &err) != PF_OK)
            return fail("vulkan", &err);
        printf("device: %s\n", pf_vk_info(ctx)->name);
        int failed = part_sites(ctx);
        pf_vk_destroy(ctx);
        return failed;
    }
    int energy_only = argc > 1 && !strcmp(argv[1], "energy");
    if (energy_only) { /* the rest as for the whole run */
        argc--;
        argv++;
    }
    const char *shared = argc > 1 ? argv[1] : getenv("PF_SHARED_SCENES");
    if (!shared)
        shared = "../shared/scenes";
    uint32_t width = argc > 3 ? (uint32_t)atoi(argv[2]) : DEFAULT_ERROR_WIDTH;
    uint32_t height = argc > 3 ? (uint32_t)atoi(argv[3]) : DEFAULT_ERROR_HEIGHT;
    uint32_t long_spp = argc > 4 ? (uint32_t)atoi(argv[4]) : DEFAULT_LONG_SPP;
    const char *source = getenv("PF_SOURCE_DIR");
    char path[1024];
    bench_scene scenes[3];
    memset(scenes, 0, sizeof scenes);
    snprintf(path, sizeof path, "%s/scenes/cornell/cornell.gltf", source ? source : ".");
    if (load_scene(&scenes[0], "cornell", path))
        return 1;
    snprintf(path, sizeof path, "%s/staircase2/staircase2.gltf", shared);
    if (load_scene(&scenes[1], "staircase2", path))
        return 1;
    snprintf(path, sizeof path, "%s/caustic-anim/caustic-anim.gltf", shared);
    if (load_scene(&scenes[2], "caustic-anim", path))
        return 1;
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_vk_options options = {NULL, 0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK)
        return fail("vulkan", &err);
    setvbuf(stdout, NULL, _IOLBF, 0);
    printf("device: %s\n", pf_vk_info(ctx)->name);
    if (energy_only) {
        printf("== the LPV's energy scale (fast, 8 spp, indirect layer at %ux%u against %u-spp "
               "references)\n",
               width, height, long_spp);
        pf_renderer *renderer = NULL;
        if (pf_renderer_create(ctx, &renderer, &err) != PF_OK)
            return fail("renderer", &err);
        for (int s = 0; s < 3; s++) {
            pf_image truth;
            if (long_reference(renderer, &scenes[s], width, height, long_spp, &truth) ||
                part_energy(renderer, &scenes[s], &truth, width, height))
                return 1;
            pf_image_free(&truth);
            pf_scene_frame_free(&scenes[s].frame);
            pf_scene_destroy(scenes[s].scene);
        }
        pf_renderer_destroy(renderer);
        pf_vk_destroy(ctx);
        return 0;
    }
    if (part_stages(ctx, &scenes[0].frame))
        return 1;

    printf("== presets: relMSE (R, G, B) at %ux%u against %u-spp references\n", width, height,
           long_spp);
    pf_renderer *renderer = NULL;
    if (pf_renderer_create(ctx, &renderer, &err) != PF_OK)
        return fail("renderer", &err);
    pf_image truths[3];
    for (int s = 0; s < 3; s++) {
        if (long_reference(renderer, &scenes[s], width, height, long_spp, &truths[s]))
            return 1;
        double fast_seconds = 0.0;
        /* A warm-up of every preset so that no row pays a pipeline compile. */
        const pf_quality all[3] = {PF_QUALITY_PREVIEW, PF_QUALITY_FAST, PF_QUALITY_FINAL};
        for (int q = 0; q < 3; q++) {
            pf_render_settings warm = preset(all[q], 16, 12);
            pf_image image;
            if (pf_render_frame(renderer, &scenes[s].frame, &warm, &image, NULL, &err) == PF_OK)
                pf_image_free(&image);
        }
        if (error_row(renderer, &scenes[s], preset(PF_QUALITY_PREVIEW, width, height), "preview",
                      &truths[s], NULL) ||
            error_row(renderer, &scenes[s], preset(PF_QUALITY_FAST, width, height), "fast",
                      &truths[s], &fast_seconds) ||
            error_row(renderer, &scenes[s], preset(PF_QUALITY_FINAL, width, height), "final",
                      &truths[s], NULL))
            return 1;
        pf_render_settings equal = preset(PF_QUALITY_REFERENCE, width, height);
        equal.samples_per_pixel = 1000000;
        equal.time_budget_ms = fast_seconds * 1000.0;
        if (error_row(renderer, &scenes[s], equal, "reference (fast's time)", &truths[s], NULL))
            return 1;
    }
    printf("== frame time at %ux%u (after a warm-up frame)\n", TIMING_WIDTH, TIMING_HEIGHT);
    for (int s = 0; s < 3; s++) {
        const pf_quality timed[3] = {PF_QUALITY_PREVIEW, PF_QUALITY_FAST, PF_QUALITY_FINAL};
        for (int q = 0; q < 3; q++)
            if (timing_row(ctx, &scenes[s], timed[q]))
                return 1;
    }

    printf("== injection offset (Cornell box, fast's indirect layer against the reference's)\n");
    const float offsets[2] = {0.5f, 1.0f};
    for (int o = 0; o < 2; o++) {
        pf_render_settings settings = preset(PF_QUALITY_FAST, width, height);
        settings.samples_per_pixel = 8;
        settings.lpv.offset_cells = offsets[o];
        pf_image image;
        if (pf_render_frame(renderer, &scenes[0].frame, &settings, &image, NULL, &err) != PF_OK)
            return fail("offset render", &err);
        double relmse = NAN, ratio = NAN;
        indirect_error(&image, &truths[0], &relmse, &ratio, &err);
        printf("  offset %.1f cell: indirect relMSE %.5f, mean %.3f of the reference's\n",
               offsets[o], relmse, ratio);
        pf_image_free(&image);
    }
    printf("== the LPV's energy scale (fast, 8 spp, indirect layer against the references)\n");
    for (int s = 0; s < 3; s++)
        if (part_energy(renderer, &scenes[s], &truths[s], width, height))
            return 1;
    for (int s = 0; s < 3; s++) {
        pf_image_free(&truths[s]);
        pf_scene_frame_free(&scenes[s].frame);
        pf_scene_destroy(scenes[s].scene);
    }
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    return 0;
}
