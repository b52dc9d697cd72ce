/*
 * The `bih_build` stage: a BIH over the frame's triangles for every kernel
 * that casts rays, kept in the renderer between frames.
 *
 * Where it is built: on the device when the device is a GPU; on the CPU when
 * the Vulkan device is the CPU itself (lavapipe), because there the GPU build
 * runs the same cores through a chain of dispatches and measured 50-235×
 * slower than the CPU build (bench/RESULTS.md, BIH). $PHOTONFARM_BIH_BUILD =
 * gpu | cpu overrides the choice (tests use it to cover both paths).
 */
#include "render_internal.h"

#include <stdlib.h>
#include <string.h>

typedef enum bih_build_site { BUILD_ON_CPU, BUILD_ON_GPU } bih_build_site;

static pf_status choose_build_site(const pf_renderer *renderer, bih_build_site *site,
                                   pf_error *err)
{
    const char *forced = getenv("PHOTONFARM_BIH_BUILD");
    if (forced && forced[0]) {
        if (strcmp(forced, "gpu") == 0) {
            *site = BUILD_ON_GPU;
            return PF_OK;
        }
        if (strcmp(forced, "cpu") == 0) {
            *site = BUILD_ON_CPU;
            return PF_OK;
        }
        return pf_error_set(err, PF_ERR_INVALID,
                            "PHOTONFARM_BIH_BUILD='%s': expected 'gpu' or 'cpu'", forced);
    }
    *site = strcmp(pf_vk_info(renderer->ctx)->type, "cpu") == 0 ? BUILD_ON_CPU : BUILD_ON_GPU;
    return PF_OK;
}

static pf_status build_tree(pf_renderer *renderer, const pf_scene_frame *frame,
                            bih_build_site site, pf_bih *out, int *built_on_gpu, pf_error *err)
{
    pf_bih_build_options options = {0, 0};
    *built_on_gpu = 0;
    if (site == BUILD_ON_CPU)
        return pf_bih_build_cpu(frame, &options, out, err);
    if (!renderer->bih_builder) {
        pf_status status = pf_bih_gpu_builder_create(renderer->ctx, &renderer->bih_builder, err);
        if (status != PF_OK)
            return status;
    }
    pf_bih_gpu_build_report build_report;
    pf_status status =
        pf_bih_build_gpu(renderer->bih_builder, frame, &options, out, &build_report, err);
    *built_on_gpu = status == PF_OK && build_report.path == PF_BIH_BUILT_ON_GPU;
    return status;
}

pf_status pf_render_prepare_bih(pf_renderer *renderer, const pf_scene_frame *frame,
                                pf_frame_report *report, pf_error *err)
{
    double start = pf_time_ms();
    bih_build_site site = BUILD_ON_CPU;
    pf_status status = choose_build_site(renderer, &site, err);
    if (status != PF_OK)
        return status;
    if (!renderer->bih_gpu) {
        status = pf_bih_gpu_create(renderer->ctx, &renderer->bih_gpu, err);
        if (status != PF_OK)
            return status;
    }
    if (renderer->bih_valid) {
        pf_bih_free(&renderer->bih);
        renderer->bih_valid = 0;
    }
    int built_on_gpu = 0;
    status = build_tree(renderer, frame, site, &renderer->bih, &built_on_gpu, err);
    if (status == PF_OK) {
        renderer->bih_valid = 1;
        status = pf_bih_gpu_upload(renderer->bih_gpu, &renderer->bih, err);
    }
    if (status != PF_OK) {
        if (renderer->bih_valid)
            pf_bih_free(&renderer->bih);
        renderer->bih_valid = 0;
        pf_error_prefix(err, "bih_build (%u triangles)", frame->triangle_count);
        return status;
    }
    pf_stage_timing *row = report ? pf_frame_report_add(report, "bih_build") : NULL;
    if (row) {
        row->wall_ms = pf_time_ms() - start;
        row->gpu_ms = -1.0;
        pf_stage_add_counter(row, "triangles", frame->triangle_count);
        pf_stage_add_counter(row, "nodes", renderer->bih.node_count);
        pf_stage_add_counter(row, "depth", renderer->bih.depth);
        pf_stage_add_counter(row, "built_on_gpu", built_on_gpu);
    }
    return PF_OK;
}
