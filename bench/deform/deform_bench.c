/*
 * Issue 39's figures (bench/RESULTS.md, "Skins and morph targets"):
 *
 *   deform_bench cost SCENE FRAME...
 *     per frame: scene_eval and deform on the host (ms, median of 5), then the
 *     tree: a refit of frame FRAME[0]'s SAH tree against a fresh SAH build of
 *     this frame (ms and SAH cost of each), as bih_build decides between them.
 *   deform_bench sites SCENE FRAME...
 *     per frame: the deform stage (pf_render_deform) on the host's loop and on the device
 *     (shaders/deform.comp), wall ms (median of 5, after a warm-up that compiles the kernel
 *     and sends the rest poses) and the device's GPU ms: where each measures faster.
 *   deform_bench vectors CYCLES.exr PHOTONFARM.exr
 *     how photonfarm's motion.X/Y agree with Cycles' Vector pass (multilayer
 *     EXR, ViewLayer.Vector.X/Y) on the pixels Cycles says move.
 *
 * A benchmark: it prints figures and fails only on bad input.
 */
#include "pf_bih.h"
#include "pf_image.h"
#include "pf_render.h"
#include "pf_scene.h"
#include "pf_vk.h"
#include "../bench_stats.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define REPEATS 5

static double sah(const pf_bih *bih)
{
    pf_bih_quality quality;
    pf_bih_quality_measure(bih, &quality);
    return quality.sah_cost;
}

static int cost(const char *path, int frame_count, char **frames)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    if (pf_scene_load(path, &scene, &err) != PF_OK) {
        fprintf(stderr, "deform_bench: %s\n", err.message);
        return 2;
    }
    const pf_scene_info *info = pf_scene_get_info(scene);
    printf("scene %s: %u triangles, %u deformed nodes, %llu deformed vertices\n", path,
           info->triangle_count, info->deformed_node_count,
           (unsigned long long)info->deformed_vertex_count);
    printf("%6s %10s %10s %12s %10s %10s %10s %10s\n", "frame", "eval_ms", "deform_ms",
           "vertices", "refit_ms", "refit_sah", "build_ms", "build_sah");
    pf_bih_build_options options = {.heuristic = PF_BIH_HEURISTIC_SAH};
    pf_bih first = {0};
    int status = 0;
    for (int f = 0; f < frame_count && !status; f++) {
        int64_t frame = atoll(frames[f]);
        double time = pf_scene_frame_time(scene, frame);
        double eval_ms[REPEATS], deform_ms[REPEATS];
        pf_scene_frame evaluated = {0};
        pf_deform_report report = {0};
        for (int r = 0; r < REPEATS && !status; r++) {
            pf_scene_frame_free(&evaluated);
            double start = pf_time_ms();
            status = pf_scene_eval_rigid(scene, time, &evaluated, &err) != PF_OK;
            double middle = pf_time_ms();
            if (!status)
                status = pf_scene_deform(scene, time, &evaluated, &report, &err) != PF_OK;
            eval_ms[r] = middle - start;
            deform_ms[r] = pf_time_ms() - middle;
        }
        pf_bih fresh = {0};
        double build_start = pf_time_ms();
        if (!status)
            status = pf_bih_build_cpu(&evaluated, &options, &fresh, &err) != PF_OK;
        double build_ms = pf_time_ms() - build_start;
        if (!status && f == 0) {
            first = fresh;
            memset(&fresh, 0, sizeof fresh);
            status = pf_bih_build_cpu(&evaluated, &options, &fresh, &err) != PF_OK;
        }
        double refit_start = pf_time_ms();
        if (!status)
            status = pf_bih_refit(&first, &evaluated, &err) != PF_OK;
        double refit_ms = pf_time_ms() - refit_start;
        if (!status)
            printf("%6lld %10.3f %10.3f %12llu %10.3f %10.2f %10.3f %10.2f\n", (long long)frame,
                   bench_median(eval_ms, REPEATS), bench_median(deform_ms, REPEATS),
                   (unsigned long long)report.vertices, refit_ms, sah(&first), build_ms,
                   sah(&fresh));
        pf_bih_free(&fresh);
        pf_scene_frame_free(&evaluated);
    }
    if (status)
        fprintf(stderr, "deform_bench: %s\n", err.message);
    pf_bih_free(&first);
    pf_scene_destroy(scene);
    return status ? 2 : 0;
}

/* One deform stage at site: wall ms, and the row's GPU ms into *gpu_ms. */
static double deform_at(pf_renderer *renderer, const pf_scene *scene, double time,
                        pf_deform_site site, double *gpu_ms, pf_error *err)
{
    pf_scene_frame frame = {0};
    pf_frame_report report = {0};
    pf_renderer_set_deform_site(renderer, site);
    if (pf_scene_eval_rigid(scene, time, &frame, err) != PF_OK)
        return -1.0;
    double start = pf_time_ms();
    pf_status status = pf_render_deform(renderer, scene, time, &frame, &report, err);
    double wall = pf_time_ms() - start;
    *gpu_ms = report.stage_count ? report.stages[0].gpu_ms : -1.0;
    pf_scene_frame_free(&frame);
    return status == PF_OK ? wall : -1.0;
}

static int sites(const char *path, int frame_count, char **frames)
{
    pf_scene *scene = NULL;
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    pf_error err = {0};
    pf_vk_options options = {NULL, 0};
    if (pf_scene_load(path, &scene, &err) != PF_OK || pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "deform_bench: %s\n", err.message);
        pf_renderer_destroy(renderer);
        pf_vk_destroy(ctx);
        pf_scene_destroy(scene);
        return 2;
    }
    printf("scene %s: %llu deformed vertices, device %s\n", path,
           (unsigned long long)pf_scene_get_info(scene)->deformed_vertex_count,
           pf_vk_info(ctx)->name);
    printf("%6s %10s %12s %12s %8s\n", "frame", "host_ms", "device_ms", "device_gpu", "host/dev");
    double gpu = 0.0;
    int status = deform_at(renderer, scene, 0.0, PF_DEFORM_DEVICE, &gpu, &err) < 0.0;
    for (int f = 0; f < frame_count && !status; f++) {
        double time = pf_scene_frame_time(scene, atoll(frames[f]));
        double host[REPEATS], device[REPEATS], device_gpu[REPEATS];
        for (int r = 0; r < REPEATS && !status; r++) {
            host[r] = deform_at(renderer, scene, time, PF_DEFORM_HOST, &gpu, &err);
            device[r] = deform_at(renderer, scene, time, PF_DEFORM_DEVICE, &device_gpu[r], &err);
            status = host[r] < 0.0 || device[r] < 0.0;
        }
        if (!status) {
            double h = bench_median(host, REPEATS), d = bench_median(device, REPEATS);
            printf("%6s %10.3f %12.3f %12.3f %8.2f\n", frames[f], h, d,
                   bench_median(device_gpu, REPEATS), h / d);
        }
    }
    if (status)
        fprintf(stderr, "deform_bench: %s\n", err.message);
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    pf_scene_destroy(scene);
    return status ? 2 : 0;
}

static int vectors(const char *cycles_path, const char *ours_path)
{
    pf_image cycles = {0}, ours = {0};
    pf_image_attribute *attributes = NULL;
    uint32_t attribute_count = 0;
    pf_error err = {0};
    if (pf_exr_read(cycles_path, &cycles, &attributes, &attribute_count, &err) != PF_OK ||
        (free(attributes), attributes = NULL,
         pf_exr_read(ours_path, &ours, &attributes, &attribute_count, &err) != PF_OK)) {
        fprintf(stderr, "deform_bench: %s\n", err.message);
        return 2;
    }
    free(attributes);
    int cx = pf_image_channel(&cycles, "ViewLayer.Vector.X");
    int cy = pf_image_channel(&cycles, "ViewLayer.Vector.Y");
    int ox = pf_image_channel(&ours, "motion.X"), oy = pf_image_channel(&ours, "motion.Y");
    if (cx < 0 || cy < 0 || ox < 0 || oy < 0 || cycles.width != ours.width ||
        cycles.height != ours.height) {
        fprintf(stderr, "deform_bench: the images need ViewLayer.Vector.X/Y and motion.X/Y "
                        "and the same size\n");
        pf_image_free(&cycles);
        pf_image_free(&ours);
        return 2;
    }
    size_t pixels = (size_t)cycles.width * cycles.height, moving = 0, agree = 0;
    double largest = 0.0, error_sum = 0.0;
    for (size_t p = 0; p < pixels; p++) {
        double vx = cycles.pixels[p * cycles.channel_count + (size_t)cx];
        double vy = cycles.pixels[p * cycles.channel_count + (size_t)cy];
        double mx = ours.pixels[p * ours.channel_count + (size_t)ox];
        double my = ours.pixels[p * ours.channel_count + (size_t)oy];
        double length = hypot(vx, vy), error = hypot(vx - mx, vy - my);
        largest = fmax(largest, length);
        if (length <= 0.2)
            continue;
        moving++;
        error_sum += error;
        agree += error <= 0.1 * length + 0.05;
    }
    printf("pixels moving > 0.2 px in Cycles: %zu of %zu (largest %.2f px)\n", moving, pixels,
           largest);
    printf("agreeing within 10 %% + 0.05 px: %zu; mean error %.3f px\n", agree,
           moving ? error_sum / (double)moving : 0.0);
    pf_image_free(&cycles);
    pf_image_free(&ours);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc >= 4 && strcmp(argv[1], "cost") == 0)
        return cost(argv[2], argc - 3, argv + 3);
    if (argc >= 4 && strcmp(argv[1], "sites") == 0)
        return sites(argv[2], argc - 3, argv + 3);
    if (argc == 4 && strcmp(argv[1], "vectors") == 0)
        return vectors(argv[2], argv[3]);
    fprintf(stderr, "usage: deform_bench cost SCENE FRAME...\n"
                    "       deform_bench sites SCENE FRAME...\n"
                    "       deform_bench vectors CYCLES.exr PHOTONFARM.exr\n");
    return 2;
}
