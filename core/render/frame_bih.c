/*
 * The `bih_build` stage: a BIH over the frame's triangles for every kernel
 * that casts rays, kept in the renderer between frames and reused when it can
 * be (issue 3, item 4). Each frame takes one decision, reported on the stage
 * row as its reason and its `decision` counter. The stage planner takes it
 * before the frame (pf_bih_plan: reuse, build, or refit); the execution
 * turns a refit into a rebuild when the refit tree loses its SAH:
 *   0 reused:  same triangle count and bitwise-equal vertices (compared with
 *              the tree's own leaf-order copy through triangle_index, so no
 *              extra copy is kept) → nothing built or uploaded; the row is
 *              `skipped` ("geometry unchanged → BIH reused");
 *   1 refit:   same count, moved vertices → pf_bih_refit, kept while its SAH
 *              cost stays within 10% of the last fresh build's (update_tree
 *              says why that build is the yardstick);
 *   2 rebuilt: the refit tree's SAH was worse than that → a fresh build;
 *   3 built:   first frame, or the triangle count changed.
 * Identity is by content, so a renderer that switches to another scene (a
 * worker changing jobs) never keeps a tree that does not fit it.
 *
 * Where a fresh tree is built: on the device when the device is a GPU; on the
 * CPU when the Vulkan device is the CPU itself (lavapipe), because there the
 * GPU build runs the same cores through a chain of dispatches and measured
 * 50-235× slower than the CPU build (bench/RESULTS.md, BIH). The CPU build
 * uses the SAH heuristic (binned SAH + empty-space cuts), not the global one:
 * 3.5-4× the build time, but the preview's shade time fell 2.1-7.4× on the
 * shared scenes (bench/RESULTS.md, "SAH tree for rendering"); the GPU build
 * stays the Morton tree.
 * pf_renderer_set_bih_build overrides the choice (tests use it to cover
 * both paths). A refit runs where a fresh tree would be built. On the CPU it
 * is one O(n) pass over the copy every build leaves in the renderer. On the
 * device (issue 44) the host gathers the moved triangles into that copy's
 * leaf order (the next frame's reuse check reads them), and one submission
 * uploads them and fits the device's tree, its SAH cost read back for the
 * keep-or-rebuild decision: the tree itself is not read back, and the host's
 * copy gets its clip values only when the host traces it
 * (pf_renderer_bih_host). A tree built on the device stays there the same way:
 * the device measures it (SAH, depth, leaves), the host reads back its triangle
 * index and gathers the leaf-order vertices itself, and fetches the nodes only
 * to trace them (motion vectors; the host traces on a CPU device, which builds
 * on the host).
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* PF_BIH_BUILD_CPU or PF_BIH_BUILD_GPU: the forced site, else the device's own. */
pf_bih_build_site pf_renderer_bih_site(const pf_renderer *renderer)
{
    if (renderer->bih_build_site != PF_BIH_BUILD_AUTO)
        return renderer->bih_build_site;
    return pf_vk_device_is_cpu(renderer->ctx) ? PF_BIH_BUILD_CPU : PF_BIH_BUILD_GPU;
}

void pf_renderer_set_bih_build(pf_renderer *renderer, pf_bih_build_site site)
{
    renderer->bih_build_site = site;
}

/* A fresh tree in out; built on the GPU, it stays in renderer->bih_gpu as built (*resident,
 * issue 44: nothing to upload). */
static pf_status build_tree(pf_renderer *renderer, const pf_scene_frame *frame,
                            pf_bih_build_site site, pf_bih *out, int *built_on_gpu, int *resident,
                            pf_error *err)
{
    pf_bih_build_options options = {0};
    *built_on_gpu = 0;
    *resident = 0;
    if (site == PF_BIH_BUILD_CPU) {
        pf_bih_build_options cpu_options = {.heuristic = PF_BIH_HEURISTIC_SAH};
        return pf_bih_build_cpu(frame, &cpu_options, out, err);
    }
    if (!renderer->bih_builder) {
        pf_status status = pf_bih_gpu_builder_create(renderer->ctx, &renderer->bih_builder, err);
        if (status != PF_OK)
            return status;
    }
    pf_bih_gpu_build_report *build_report = &renderer->bih_gpu_report;
    pf_status status = pf_bih_build_gpu_kept(renderer->bih_builder, frame, &options, out,
                                             renderer->bih_gpu, build_report, err);
    *built_on_gpu = status == PF_OK && build_report->path == PF_BIH_BUILT_ON_GPU;
    *resident = status == PF_OK && build_report->resident;
    return status;
}

/* 0 reused, 1 refit, 2 rebuilt, 3 built: the `decision` counter on the row. */
typedef enum bih_decision {
    BIH_REUSED = 0,
    BIH_REFIT = 1,
    BIH_REBUILT = 2,
    BIH_BUILT = 3
} bih_decision;

/*
 * A refit tree is kept while its SAH cost is at most this many times the
 * last fresh build's (issue 3, item 4: "within 10% of a fresh build").
 */
#define BIH_REFIT_SAH_TOLERANCE 1.10

static double sah_of(const pf_bih *bih)
{
    pf_bih_quality quality;
    pf_bih_quality_measure(bih, &quality);
    return quality.sah_cost;
}

/* Replaces renderer->bih with a fresh build and makes it the refit yardstick. */
static pf_status build_fresh(pf_renderer *renderer, const pf_scene_frame *frame,
                             pf_bih_build_site site, int *built_on_gpu, int *resident,
                             pf_error *err)
{
    if (renderer->bih_valid) {
        pf_bih_free(&renderer->bih);
        renderer->bih_valid = 0;
    }
    pf_status status =
        build_tree(renderer, frame, site, &renderer->bih, built_on_gpu, resident, err);
    if (status != PF_OK)
        return status;
    renderer->bih_valid = 1;
    /* Kept on the device, the tree was measured there; the host fetches its nodes when it
     * traces it. */
    renderer->bih_host = *resident ? PF_BIH_HOST_NO_NODES : PF_BIH_HOST_COMPLETE;
    renderer->bih_sah =
        *resident ? renderer->bih_gpu_report.sah_cost : sah_of(&renderer->bih);
    renderer->bih_fresh_sah = renderer->bih_sah;
    return PF_OK;
}

/*
 * renderer->bih refit to frame where site says, with its SAH cost in *sah: on the
 * device, the tree the device holds (every decision leaves it the host's tree) and
 * the host's clip values left for pf_renderer_bih_host; on the CPU, or where the
 * device's limits refuse the refit, on the host.
 */
static pf_status refit_tree(pf_renderer *renderer, const pf_scene_frame *frame,
                            pf_bih_build_site site, double *sah, int *on_gpu, pf_error *err)
{
    *on_gpu = 0;
    if (site == PF_BIH_BUILD_GPU) {
        pf_status status = PF_OK;
        if (!renderer->bih_builder)
            status = pf_bih_gpu_builder_create(renderer->ctx, &renderer->bih_builder, err);
        if (status != PF_OK)
            return status;
        pf_error refused = {0};
        pf_bih_gpu_refit_report *report = &renderer->bih_refit_report;
        status = pf_bih_refit_gpu(renderer->bih_builder, renderer->bih_gpu, &renderer->bih,
                                  frame, report, &refused);
        if (status == PF_OK) {
            if (renderer->bih_host == PF_BIH_HOST_COMPLETE)
                renderer->bih_host = PF_BIH_HOST_UNFITTED;
            *sah = report->sah_cost;
            *on_gpu = 1;
            return PF_OK;
        }
        if (status != PF_ERR_LIMIT) {
            *err = refused;
            return status;
        }
        pf_log(PF_LOG_WARN, "%s; refit on the host instead", refused.message);
    }
    const pf_bih *complete = NULL; /* the host refits the nodes it has: fetch them first */
    pf_status status = pf_renderer_bih_host(renderer, &complete, err);
    if (status == PF_OK)
        status = pf_bih_refit(&renderer->bih, frame, err);
    if (status != PF_OK)
        return status;
    *sah = sah_of(&renderer->bih);
    return PF_OK;
}

/*
 * Brings renderer->bih up to frame as planned (reuse, refit, or a fresh
 * build) and writes the decision taken and its reason: a planned refit
 * becomes a rebuild when the refit tree loses its SAH. Every decision but a
 * reuse leaves a tree the GPU copy does not have yet. On failure the tree
 * may be gone.
 */
static pf_status update_tree(pf_renderer *renderer, const pf_scene_frame *frame,
                             const pf_stage_decision *planned, pf_bih_build_site site,
                             bih_decision *decision, char *reason, size_t reason_size,
                             int *built_on_gpu, int *refit_on_gpu, int *resident, pf_error *err)
{
    *built_on_gpu = 0;
    *refit_on_gpu = 0;
    *resident = 0;
    snprintf(reason, reason_size, "%s", planned->reason);
    if (planned->action == PF_STAGE_REUSE) {
        *decision = BIH_REUSED;
        return PF_OK;
    }
    if (!renderer->bih_valid || renderer->bih.triangle_count != frame->triangle_count) {
        *decision = BIH_BUILT;
        return build_fresh(renderer, frame, site, built_on_gpu, resident, err);
    }
    double refit_sah = 0.0;
    pf_status status = refit_tree(renderer, frame, site, &refit_sah, refit_on_gpu, err);
    if (status != PF_OK)
        return status;
    *resident = *refit_on_gpu;
    /*
     * The yardstick is the last fresh build's SAH, not a fresh build of this
     * frame: building one every frame to compare against would cost the very
     * build the refit saves. The normalised SAH (pf_bih_quality_measure)
     * divides by the root box's area, so it is scale-invariant and comparable
     * across frames. It is an estimate: when the scene box changes shape the
     * fresh build's figure moves too (a bigger, emptier box lowers it), so a
     * refit a few percent worse than a fresh build of this frame can pass,
     * while a torn-apart tree (leaves spanning far-apart triangles) does not:
     * tests/render/test_bih_reuse.c shows refit SAH 55-77 against 11.
     */
    if (refit_sah <= BIH_REFIT_SAH_TOLERANCE * renderer->bih_fresh_sah) {
        snprintf(reason, reason_size, "refit: SAH %.1f within 10%% of last build's %.1f",
                 refit_sah, renderer->bih_fresh_sah);
        renderer->bih_sah = refit_sah;
        *decision = BIH_REFIT;
        return PF_OK;
    }
    snprintf(reason, reason_size, "rebuilt: refit SAH %.1f > %.2f × %.1f", refit_sah,
             BIH_REFIT_SAH_TOLERANCE, renderer->bih_fresh_sah);
    *decision = BIH_REBUILT;
    return build_fresh(renderer, frame, site, built_on_gpu, resident, err);
}

pf_status pf_render_prepare_bih(pf_renderer *renderer, const pf_scene_frame *frame,
                                const pf_stage_decision *planned, pf_frame_report *report,
                                pf_error *err)
{
    double start = pf_time_ms();
    pf_bih_build_site site = pf_renderer_bih_site(renderer);
    pf_status status = PF_OK;
    if (!renderer->bih_gpu) {
        status = pf_bih_gpu_create(renderer->ctx, &renderer->bih_gpu, err);
        if (status != PF_OK)
            return status;
    }
    bih_decision decision = BIH_BUILT;
    char reason[PF_STAGE_REASON_MAX];
    int built_on_gpu = 0, refit_on_gpu = 0, resident = 0;
    status = update_tree(renderer, frame, planned, site, &decision, reason, sizeof reason,
                         &built_on_gpu, &refit_on_gpu, &resident, err);
    /* A tree built or refit (or lost to a failure): its wide view is another. */
    if (status != PF_OK || decision != BIH_REUSED)
        pf_renderer_bih_wide_drop(renderer);
    if (status == PF_OK && decision != BIH_REUSED && !resident)
        status = pf_bih_gpu_upload(renderer->bih_gpu, &renderer->bih, err);
    if (status != PF_OK) {
        /* The CPU tree and the GPU copy may no longer match: start over next frame. */
        if (renderer->bih_valid)
            pf_bih_free(&renderer->bih);
        renderer->bih_valid = 0;
        renderer->bih_frames++;
        pf_error_prefix(err, "bih_build (%u triangles)", frame->triangle_count);
        return status;
    }
    renderer->bih_frames++;
    renderer->bih_pilot_replaced = 0;
    pf_stage_timing *row = report ? pf_frame_report_add(report, "bih_build") : NULL;
    if (row) {
        row->wall_ms = pf_time_ms() - start;
        row->gpu_ms = -1.0;
        row->skipped = decision == BIH_REUSED;
        snprintf(row->reason, sizeof row->reason, "%s", reason);
        pf_stage_add_counter(row, "triangles", frame->triangle_count);
        pf_stage_add_counter(row, "nodes", renderer->bih.node_count);
        pf_stage_add_counter(row, "depth", renderer->bih.depth);
        pf_stage_add_counter(row, "sah", renderer->bih_sah);
        pf_stage_add_counter(row, "built_on_gpu", built_on_gpu);
        pf_stage_add_counter(row, "refit_on_gpu", refit_on_gpu);
        pf_stage_add_counter(row, "decision", decision);
        /* Where the GPU build's device time went, from its timestamps (issue 44). */
        const pf_bih_gpu_build_report *gpu = &renderer->bih_gpu_report;
        if (built_on_gpu && gpu->gpu_ms >= 0.0) {
            row->gpu_ms = gpu->gpu_ms;
            for (int p = 0; p < PF_BIH_GPU_PASSES; p++) {
                char name[32];
                snprintf(name, sizeof name, "gpu_ms_%s", pf_bih_gpu_pass_name((pf_bih_gpu_pass)p));
                pf_stage_add_counter(row, name, gpu->pass_ms[p]);
            }
        }
        /* A device refit's too; a rebuild after it adds both. */
        const pf_bih_gpu_refit_report *refit = &renderer->bih_refit_report;
        if (refit_on_gpu && refit->gpu_ms >= 0.0) {
            pf_gpu_ms_add(&row->gpu_ms, refit->gpu_ms);
            for (int p = 0; p < PF_BIH_REFIT_PASSES; p++) {
                char name[32];
                snprintf(name, sizeof name, "gpu_ms_%s",
                         pf_bih_refit_pass_name((pf_bih_refit_pass)p));
                pf_stage_add_counter(row, name, refit->pass_ms[p]);
            }
        }
    }
    return PF_OK;
}

pf_status pf_renderer_bih_host(pf_renderer *renderer, const pf_bih **out, pf_error *err)
{
    *out = NULL;
    if (!renderer->bih_valid)
        return pf_error_set(err, PF_ERR_INTERNAL, "no BIH for the host to trace");
    pf_status status = PF_OK;
    if (renderer->bih_host == PF_BIH_HOST_NO_NODES)
        status = pf_bih_gpu_download_nodes(renderer->bih_gpu, &renderer->bih, err);
    else if (renderer->bih_host == PF_BIH_HOST_UNFITTED)
        status = pf_bih_refit_bounds(&renderer->bih, err);
    if (status != PF_OK)
        return status;
    renderer->bih_host = PF_BIH_HOST_COMPLETE;
    *out = &renderer->bih;
    return PF_OK;
}

pf_status pf_renderer_bih_wide(pf_renderer *renderer, const pf_bih_wide **out, pf_error *err)
{
    *out = NULL;
    const pf_bih *tree = NULL;
    pf_status status = pf_renderer_bih_host(renderer, &tree, err);
    if (status != PF_OK)
        return status;
    if (!renderer->bih_wide_valid) {
        status = pf_bih_wide_build(tree, &renderer->bih_wide, err);
        if (status != PF_OK)
            return status;
        renderer->bih_wide_valid = 1;
    }
    *out = &renderer->bih_wide;
    return PF_OK;
}

pf_status pf_renderer_wave_tracer_create(pf_renderer *renderer, uint32_t paths,
                                         uint32_t shadow_slots, pf_bih_wave_tracer **out,
                                         pf_error *err)
{
    *out = NULL;
    const pf_bih_wide *wide = NULL;
    pf_status status = pf_renderer_bih_wide(renderer, &wide, err);
    if (status == PF_OK)
        status = pf_bih_wave_tracer_create(&renderer->bih, wide, paths, shadow_slots, out, err);
    return status;
}

void pf_renderer_bih_wide_drop(pf_renderer *renderer)
{
    if (renderer->bih_wide_valid)
        pf_bih_wide_free(&renderer->bih_wide);
    renderer->bih_wide_valid = 0;
}

pf_status pf_render_check_traversal(const pf_renderer *renderer, uint64_t failures,
                                    pf_error *err)
{
    if (failures == 0)
        return PF_OK;
    return pf_error_set(err, PF_ERR_LIMIT,
                        "%llu rays overflowed the %u-entry BIH traversal stack (tree depth %u)",
                        (unsigned long long)failures, PF_BIH_STACK_SIZE, renderer->bih.depth);
}
