/*
 * denoise_floor: the denoiser's own error floor (issue 40, item 4). A converged image has
 * no noise left to take away, so whatever the denoise stage moves it is the filter's own
 * error: renders SCENE with `reference` at SPP (4,096 by default) with its AOVs, denoises
 * it alone and again as the next frame of a still shot (temporal reuse of itself), and
 * prints how far each moved it (relMSE against the image as rendered, R, G, B) and how far
 * its mean moved. Then times the filter on the host and on the device (pf_render_denoise with
 * each site forced; the median of TIMING_RUNS, wall and the kernels' GPU time).
 *
 *   denoise_floor SCENE.gltf WIDTH HEIGHT [SPP]
 */
#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include "../bench_stats.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TIMING_RUNS 5

static double mean_rgb(const pf_image *image)
{
    double sum = 0.0;
    size_t pixels = (size_t)image->width * image->height;
    for (size_t p = 0; p < pixels; p++)
        for (int c = 0; c < 3; c++)
            sum += image->pixels[p * image->channel_count + c];
    return sum / (3.0 * (double)pixels);
}

/* The median wall and GPU ms of the denoise stage on rendered with the filter at site. */
static int time_site(pf_renderer *renderer, const pf_image *rendered, pf_denoise_site site,
                     double *wall_ms, double *gpu_ms)
{
    double walls[TIMING_RUNS], gpus[TIMING_RUNS];
    pf_renderer_set_denoise_site(renderer, site);
    for (int run = 0; run < TIMING_RUNS; run++) {
        pf_image copy = {0};
        pf_frame_report report = {0};
        pf_error err = {0};
        if (pf_image_append_channels(rendered, NULL, 0, &copy, &err) != PF_OK ||
            pf_render_denoise(renderer, &copy, 0, NULL, &report, &err) != PF_OK) {
            fprintf(stderr, "denoise_floor: %s\n", err.message);
            pf_image_free(&copy);
            return 0;
        }
        for (uint32_t i = 0; i < report.stage_count; i++)
            if (!strcmp(report.stages[i].stage, "denoise")) {
                walls[run] = report.stages[i].wall_ms;
                gpus[run] = report.stages[i].gpu_ms;
            }
        pf_image_free(&copy);
    }
    *wall_ms = bench_median(walls, TIMING_RUNS);
    *gpu_ms = bench_median(gpus, TIMING_RUNS);
    return 1;
}

/* relMSE of a's R, G, B against b's (the same channels in both). */
static double moved(const pf_image *a, const pf_image *b)
{
    pf_image_metrics metrics;
    pf_error err = {0};
    return pf_image_compare(a, b, &metrics, &err) == PF_OK ? metrics.relmse : NAN;
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: denoise_floor SCENE WIDTH HEIGHT [SPP]\n");
        return 2;
    }
    uint32_t width = (uint32_t)atoi(argv[2]), height = (uint32_t)atoi(argv[3]);
    uint32_t spp = argc > 4 ? (uint32_t)atoi(argv[4]) : 4096u;
    pf_error err = {0};
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_vk_options options = {NULL, 0, NULL};
    pf_denoise_history *history = NULL;
    pf_render_settings settings = pf_render_settings_default();
    settings.width = width;
    settings.height = height;
    settings.quality = PF_QUALITY_REFERENCE;
    settings.samples_per_pixel = spp;
    settings.seed = 1;
    settings.denoise = PF_DENOISE_ON;
    pf_image rendered = {0}, alone = {0}, twice = {0};
    double start = pf_time_ms();
    if (!width || !height || !spp || pf_scene_load(argv[1], &scene, &err) != PF_OK ||
        pf_scene_eval(scene, pf_scene_frame_time(scene, 1), &frame, &err) != PF_OK ||
        pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK ||
        pf_denoise_history_create(&history, &err) != PF_OK ||
        pf_render_frame(renderer, &frame, &settings, &rendered, NULL, &err) != PF_OK) {
        fprintf(stderr, "denoise_floor: %s\n", err.message[0] ? err.message : "bad arguments");
        return 2;
    }
    double render_s = (pf_time_ms() - start) / 1000.0;
    /* The same converged image denoised alone, and as frames 1 and 2 of a still shot. */
    pf_denoise_sequence first = {history, 1, 1, 1, 1, NULL}, second = {history, 1, 2, 1, 1, NULL};
    if (pf_image_append_channels(&rendered, NULL, 0, &alone, &err) != PF_OK ||
        pf_image_append_channels(&rendered, NULL, 0, &twice, &err) != PF_OK ||
        pf_denoise_image(&alone, 0, NULL, NULL, &err) != PF_OK ||
        pf_denoise_image(&twice, 0, &first, NULL, &err) != PF_OK) {
        fprintf(stderr, "denoise_floor: %s\n", err.message);
        return 1;
    }
    pf_image_free(&twice);
    if (pf_image_append_channels(&rendered, NULL, 0, &twice, &err) != PF_OK ||
        pf_denoise_image(&twice, 0, &second, NULL, &err) != PF_OK) {
        fprintf(stderr, "denoise_floor: %s\n", err.message);
        return 1;
    }
    printf("denoise_floor %s %ux%u, reference at %u spp (%.1f s), device %s\n", argv[1], width,
           height, spp, render_s, pf_vk_info(ctx)->name);
    printf("  spatial:  relMSE %.6g against the image as rendered, mean %+.3f %%\n",
           moved(&alone, &rendered), 100.0 * (mean_rgb(&alone) / mean_rgb(&rendered) - 1.0));
    printf("  temporal: relMSE %.6g (the image blended with itself, then filtered), mean "
           "%+.3f %%\n",
           moved(&twice, &rendered), 100.0 * (mean_rgb(&twice) / mean_rgb(&rendered) - 1.0));
    double host_ms, host_gpu, device_ms, device_gpu;
    if (!time_site(renderer, &rendered, PF_DENOISE_SITE_HOST, &host_ms, &host_gpu) ||
        !time_site(renderer, &rendered, PF_DENOISE_SITE_DEVICE, &device_ms, &device_gpu))
        return 1;
    printf("  filter:   host %.1f ms, device %.1f ms wall (kernels %.1f ms GPU), median of %d\n",
           host_ms, device_ms, device_gpu, TIMING_RUNS);
    pf_image_free(&rendered);
    pf_image_free(&alone);
    pf_image_free(&twice);
    pf_denoise_history_destroy(history);
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
    return 0;
}
