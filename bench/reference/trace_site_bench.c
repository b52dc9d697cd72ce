/*
 * trace_site_bench: reference's samples per second with its rays traced on
 * the device (the megakernel, GLSL traversal) against the host (the
 * wavefront, wide AVX2 BIH traversal on every core), issue 43, and as the
 * planner has it (auto: where the device is the CPU, the wavefront with its
 * tails, each slice's last paths run to their ends on the device, as in a
 * worker's frames once the tail's kernel is compiled: a warm-up frame of 128
 * passes, PF_REFERENCE_WAVE_TAIL_MIN_TAILS, compiles it first); with
 * --quality final, final's shade with its camera rays and gather rays' first
 * segments traced on the device (inside its kernels) against the host, and its
 * photon_trace stage likewise. For each
 * scene it renders the same frame (same seed and spp) both ways, in
 * alternating rounds, and prints per round the shade row's wall and GPU
 * time, the host's trace time, the waves, paths/s and rays/s, and once the
 * two images' difference (they should agree but for ties between equally
 * distant triangles). Figures are reports, never pass/fail.
 *
 * Usage: trace_site_bench [--quality reference|final] WIDTHxHEIGHT SPP ROUNDS scene.gltf...
 * (final: SPP is its passes, each traced again by every render, as a change of site
 * forgets the kept passes.)
 * Run with LP_NUM_THREADS=2 on lavapipe.
 */
#include "pf_common.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double counter(const pf_frame_report *report, const char *stage, const char *name)
{
    for (uint32_t s = 0; s < report->stage_count; s++) {
        if (strcmp(report->stages[s].stage, stage) != 0)
            continue;
        if (!strcmp(name, "wall"))
            return report->stages[s].wall_ms;
        if (!strcmp(name, "gpu"))
            return report->stages[s].gpu_ms;
        for (uint32_t c = 0; c < report->stages[s].counter_count; c++)
            if (!strcmp(report->stages[s].counters[c].name, name))
                return report->stages[s].counters[c].value;
    }
    return 0.0;
}

typedef struct site_result {
    double best_wall, best_paths_per_s, best_rays_per_s, gpu, host, waves, rays;
} site_result;

static pf_quality quality = PF_QUALITY_REFERENCE;

static int render(pf_renderer *renderer, const pf_scene_frame *frame, uint32_t width,
                  uint32_t height, uint32_t spp, pf_trace_site site, pf_image *image,
                  site_result *result)
{
    pf_renderer_set_trace_site(renderer, site);
    pf_render_settings settings = {.width = width,
                                   .height = height,
                                   .quality = quality,
                                   .samples_per_pixel = spp,
                                   .seed = 7,
                                   .aovs = 0};
    pf_frame_report report = {0};
    pf_error err = {0};
    pf_image_free(image);
    if (pf_render_frame(renderer, frame, &settings, image, &report, &err) != PF_OK) {
        fprintf(stderr, "render: %s\n", err.message);
        return 0;
    }
    double wall = counter(&report, "shade", "wall");
    double paths = counter(&report, "shade", "paths");
    double rays = counter(&report, "shade", "rays");
    printf("    %-6s shade %9.1f ms  GPU %9.1f ms  host trace %8.1f ms  waves %5.0f  "
           "%.3g paths/s  %.3g rays/s",
           site == PF_TRACE_HOST ? "host" : site == PF_TRACE_AUTO ? "auto" : "device", wall,
           counter(&report, "shade", "gpu"),
           counter(&report, "shade", "host_trace_ms"),
           counter(&report, "shade", quality == PF_QUALITY_FINAL ? "host_traces" : "waves"),
           paths / (wall / 1000.0), rays / (wall / 1000.0));
    /* final: its photon passes too (a change of site traces them again). */
    if (quality == PF_QUALITY_FINAL)
        printf("  photon_trace %8.1f ms (GPU %.1f, host trace %.1f)",
               counter(&report, "photon_trace", "wall"), counter(&report, "photon_trace", "gpu"),
               counter(&report, "photon_trace", "host_trace_ms"));
    printf("\n");
    if (result->best_wall == 0.0 || wall < result->best_wall) {
        result->best_wall = wall;
        result->best_paths_per_s = paths / (wall / 1000.0);
        result->best_rays_per_s = rays / (wall / 1000.0);
        result->gpu = counter(&report, "shade", "gpu");
        result->host = counter(&report, "shade", "host_trace_ms");
        result->waves = counter(&report, "shade", "waves");
        result->rays = rays;
    }
    return 1;
}

int main(int argc, char **argv)
{
    unsigned width = 0, height = 0, spp = 0, rounds = 0;
    if (argc > 2 && !strcmp(argv[1], "--quality")) {
        if (!strcmp(argv[2], "final")) {
            quality = PF_QUALITY_FINAL;
        } else if (strcmp(argv[2], "reference") != 0) {
            fprintf(stderr, "--quality: reference or final, not %s\n", argv[2]);
            return 2;
        }
        argv += 2;
        argc -= 2;
    }
    if (argc < 5 || sscanf(argv[1], "%ux%u", &width, &height) != 2 || !width || !height ||
        sscanf(argv[2], "%u", &spp) != 1 || !spp || sscanf(argv[3], "%u", &rounds) != 1 ||
        !rounds) {
        fprintf(stderr,
                "usage: trace_site_bench [--quality reference|final] WIDTHxHEIGHT SPP ROUNDS "
                "scene.gltf...\n");
        return 2;
    }
    pf_error err = {0};
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_vk_options options = {NULL, 0};
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        return 1;
    }
    printf("trace_site_bench: %s, device %s (%s), %ux%u, %u spp, %u rounds (best of them "
           "below)\n",
           pf_quality_name(quality), pf_vk_info(ctx)->name, pf_vk_info(ctx)->type, width, height,
           spp, rounds);
    int failed = 0;
    for (int s = 4; s < argc && !failed; s++) {
        pf_scene *scene = NULL;
        pf_scene_frame frame = {0};
        if (pf_scene_load(argv[s], &scene, &err) != PF_OK ||
            pf_scene_eval(scene, 0.0, &frame, &err) != PF_OK) {
            fprintf(stderr, "%s\n", err.message);
            failed = 1;
            pf_scene_destroy(scene);
            break;
        }
        printf("\n%s: %u triangles, %u lights\n", argv[s], frame.triangle_count,
               frame.light_count);
        pf_image device_image = {0}, host_image = {0}, auto_image = {0};
        site_result device = {0}, host = {0}, automatic = {0};
        /* final's planner puts its rays where `host` does on a CPU, `device` elsewhere. */
        int with_auto = quality == PF_QUALITY_REFERENCE;
        if (with_auto) /* the tail's kernel compiled, as a worker has it after a few frames */
            failed = !render(renderer, &frame, 16, 16, 128, PF_TRACE_AUTO, &auto_image,
                             &(site_result){0});
        for (unsigned r = 0; r < rounds && !failed; r++)
            failed = !render(renderer, &frame, width, height, spp, PF_TRACE_DEVICE,
                             &device_image, &device) ||
                     !render(renderer, &frame, width, height, spp, PF_TRACE_HOST, &host_image,
                             &host) ||
                     (with_auto && !render(renderer, &frame, width, height, spp, PF_TRACE_AUTO,
                                           &auto_image, &automatic));
        if (!failed) {
            pf_image_metrics metrics;
            if (pf_image_compare(&host_image, &device_image, &metrics, &err) != PF_OK)
                memset(&metrics, 0, sizeof metrics);
            /* final's host traces only some of its rays: no rays/s of them. */
            printf("  best: device %.1f ms (%.3g paths/s), host %.1f ms (%.3g paths/s): "
                   "host/device %.2fx; host's trace step %.3g rays/s; images: RMSE %.3g, "
                   "max abs %.3g\n",
                   device.best_wall, device.best_paths_per_s, host.best_wall,
                   host.best_paths_per_s, host.best_paths_per_s / device.best_paths_per_s,
                   quality == PF_QUALITY_FINAL ? NAN : host.rays / (host.host / 1000.0),
                   metrics.rmse, metrics.max_abs_error);
            if (with_auto &&
                pf_image_compare(&auto_image, &device_image, &metrics, &err) == PF_OK)
                printf("  best: auto %.1f ms (%.3g paths/s): auto/device %.2fx, auto/host "
                       "%.2fx; images: RMSE %.3g, max abs %.3g against device's\n",
                       automatic.best_wall, automatic.best_paths_per_s,
                       automatic.best_paths_per_s / device.best_paths_per_s,
                       automatic.best_paths_per_s / host.best_paths_per_s, metrics.rmse,
                       metrics.max_abs_error);
        }
        pf_image_free(&device_image);
        pf_image_free(&host_image);
        pf_image_free(&auto_image);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    return failed;
}
