/*
 * What the frame's BIH costs and saves in rendering: renders one frame of
 * each scene given with pf_render_frame (the path `photonfarm render` and the
 * worker take) and prints the bih_build row of the first render and the best
 * shade row (wall and GPU ms) of `repeats` renders; the later renders reuse
 * the tree, so they time shading alone. Figures in bench/RESULTS.md (BIH).
 *
 * usage: bih_render_bench SCENES_DIR [WxH] [quality] [repeats] [scene...]
 *   defaults: 320x240, preview, 3 repeats, cornell-anim caustic-anim staircase2
 */
#include "pf_render.h"
#include "pf_image.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The scenes of the render-time comparison in bench/RESULTS.md (BIH, SAH tree for rendering). */
static const char *const default_scenes[] = {"cornell-anim", "caustic-anim", "staircase2"};
#define DEFAULT_SCENE_COUNT (sizeof default_scenes / sizeof default_scenes[0])
#define DEFAULT_REPEATS 3u

static const pf_stage_timing *find_row(const pf_frame_report *report, const char *stage)
{
    for (uint32_t i = 0; i < report->stage_count; i++)
        if (strcmp(report->stages[i].stage, stage) == 0)
            return &report->stages[i];
    return NULL;
}

static int bench_scene(pf_renderer *renderer, const char *root, const char *name,
                       const pf_render_settings *settings, uint32_t repeats)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s/%s.gltf", root, name, name);
    pf_error err = {0};
    pf_scene *scene = NULL;
    pf_scene_frame frame = {0};
    if (pf_scene_load(path, &scene, &err) != PF_OK ||
        pf_scene_eval(scene, pf_scene_frame_time(scene, 1), &frame, &err) != PF_OK) {
        fprintf(stderr, "%s: %s\n", name, err.message);
        pf_scene_destroy(scene);
        return 0;
    }
    double best_wall = -1.0, best_gpu = -1.0, build_ms = -1.0;
    char build_reason[PF_STAGE_REASON_MAX] = "";
    int ok = 1;
    for (uint32_t r = 0; r < repeats && ok; r++) {
        pf_image image = {0};
        pf_frame_report report = {0};
        ok = pf_render_frame(renderer, &frame, settings, &image, &report, &err) == PF_OK;
        pf_image_free(&image);
        if (!ok) {
            fprintf(stderr, "%s: %s\n", name, err.message);
            break;
        }
        const pf_stage_timing *build = find_row(&report, "bih_build");
        const pf_stage_timing *shade = find_row(&report, "shade");
        if (r == 0 && build) {
            build_ms = build->wall_ms;
            snprintf(build_reason, sizeof build_reason, "%s", build->reason);
        }
        if (shade && (best_wall < 0.0 || shade->wall_ms < best_wall)) {
            best_wall = shade->wall_ms;
            best_gpu = shade->gpu_ms;
        }
    }
    if (ok)
        printf("%-14s %7u tris  bih_build %8.2f ms (%s)  shade best of %u: %8.1f ms wall, %8.1f ms GPU\n",
               name, frame.triangle_count, build_ms, build_reason, repeats, best_wall, best_gpu);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
    return ok;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: %s SCENES_DIR [WxH] [quality] [repeats] [scene...]\n", argv[0]);
        return 2;
    }
    pf_render_settings settings = {320, 240, PF_QUALITY_PREVIEW, 0, 0, 0, 0.0};
    if (argc > 2 && sscanf(argv[2], "%ux%u", &settings.width, &settings.height) != 2) {
        fprintf(stderr, "bad size '%s' (expected WxH)\n", argv[2]);
        return 2;
    }
    if (argc > 3) {
        int quality = pf_quality_parse(argv[3]);
        if (quality < 0) {
            fprintf(stderr, "unknown quality '%s'\n", argv[3]);
            return 2;
        }
        settings.quality = (pf_quality)quality;
    }
    uint32_t repeats = argc > 4 ? (uint32_t)strtoul(argv[4], NULL, 10) : DEFAULT_REPEATS;
    if (repeats == 0)
        repeats = 1;
    pf_error err = {0};
    pf_vk_options options = {NULL, 0};
    pf_vk_context *ctx = NULL;
    pf_renderer *renderer = NULL;
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_renderer_create(ctx, &renderer, &err) != PF_OK) {
        fprintf(stderr, "setup: %s\n", err.message);
        pf_vk_destroy(ctx);
        return 1;
    }
    printf("device: %s (%s), %ux%u %s\n", pf_vk_info(ctx)->name, pf_vk_info(ctx)->type,
           settings.width, settings.height, pf_quality_name(settings.quality));
    int ok = 1;
    if (argc > 5) {
        for (int i = 5; i < argc; i++)
            ok &= bench_scene(renderer, argv[1], argv[i], &settings, repeats);
    } else {
        for (size_t i = 0; i < DEFAULT_SCENE_COUNT; i++)
            ok &= bench_scene(renderer, argv[1], default_scenes[i], &settings, repeats);
    }
    pf_renderer_destroy(renderer);
    pf_vk_destroy(ctx);
    return ok ? 0 : 1;
}
