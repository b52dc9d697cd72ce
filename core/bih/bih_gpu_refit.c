/*
 * The BIH fitted on the device (issue 44): pf_bih_refit_gpu (pf_bih.h), and the statistics
 * of a tree the GPU build keeps on the device (bih_gpu_build.c), through one set of passes
 * recorded into the caller's submission: parents, zeroed arrival counters and statistics
 * (bih_refit_link), clip values and boxes bottom up (bih_refit_bounds), the SAH cost with
 * the depth, leaf count and largest leaf (bih_refit_sah, bih_refit_sum). What comes back
 * is the cost, the root box and the statistics: 52 bytes, never the tree.
 *
 * A refit: the host gathers the frame's triangles into the tree's leaf order (it needs
 * them anyway: the stage planner compares the next frame against them), and one
 * submission uploads them and fits the device's copy. The host's clip values are fitted
 * later, only where the host traces the tree (pf_bih_refit_bounds).
 */
#include "bih_internal.h"

#include <stdlib.h>

/* local_size_x of every bih_refit_*.comp. */
#define REFIT_GROUP_SIZE 256u
/* A node's box on the device: two vec4. */
#define BOX_BYTES 32u
/* bih_refit_link.comp's kept_index when the node count is known. */
#define NO_KEPT 0xFFFFFFFFu

enum { PIPE_LINK, PIPE_BOUNDS, PIPE_SAH, PIPE_SUM };

static const struct {
    const char *shader;
    uint32_t buffers;
    uint32_t push_bytes;
} pipe_desc[PF_BIH_REFIT_PIPELINES] = {
    [PIPE_LINK] = {"bih_refit_link", 5, 8},
    [PIPE_BOUNDS] = {"bih_refit_bounds", 6, 8},
    [PIPE_SAH] = {"bih_refit_sah", 5, 4},
    [PIPE_SUM] = {"bih_refit_sum", 2, 4},
};

const char *pf_bih_refit_pass_name(pf_bih_refit_pass pass)
{
    static const char *const names[PF_BIH_REFIT_PASSES] = {"link", "bounds", "sah"};
    return (unsigned)pass < PF_BIH_REFIT_PASSES ? names[pass] : "?";
}

/* The fit's kernels, made at the first fit: a renderer that never fits on the device
 * (lavapipe: the host builds and refits) never compiles them. */
static pf_status fit_pipelines(pf_bih_gpu_builder *builder, pf_error *err)
{
    for (int p = 0; p < PF_BIH_REFIT_PIPELINES; p++) {
        if (builder->refit[p])
            continue;
        pf_status status = pf_vk_pipeline_create_named(builder->ctx, pipe_desc[p].shader,
                                                       pipe_desc[p].buffers,
                                                       pipe_desc[p].push_bytes, NULL, 0,
                                                       &builder->refit[p], err);
        if (status != PF_OK)
            return status;
    }
    return PF_OK;
}

pf_status pf_bih_fit_check(pf_bih_gpu_builder *builder, uint32_t node_bound, pf_error *err)
{
    const pf_vk_device_info *info = pf_vk_info(builder->ctx);
    uint64_t box_bytes = (uint64_t)BOX_BYTES * node_bound;
    uint32_t groups = (node_bound + REFIT_GROUP_SIZE - 1) / REFIT_GROUP_SIZE;
    if (box_bytes > info->max_storage_buffer_range || groups > info->max_workgroup_count[0])
        return pf_error_set(err, PF_ERR_LIMIT,
                            "BIH fit on the device: %u nodes need %llu bytes of boxes and %u "
                            "workgroups; device '%s' allows %llu and %u",
                            node_bound, (unsigned long long)box_bytes, groups, info->name,
                            (unsigned long long)info->max_storage_buffer_range,
                            info->max_workgroup_count[0]);
    return fit_pipelines(builder, err);
}

pf_status pf_bih_fit_create(pf_bih_gpu_builder *b, uint32_t node_bound, pf_bih_fit *fit,
                            pf_error *err)
{
    memset(fit, 0, sizeof *fit);
    for (int p = 0; p <= PF_BIH_REFIT_PASSES; p++)
        fit->stamps[p] = -1;
    fit->node_bound = node_bound;
    uint32_t groups = (node_bound + REFIT_GROUP_SIZE - 1) / REFIT_GROUP_SIZE;
    const uint64_t sizes[PF_BIH_FIT_BUFFERS] = {
        [PF_BIH_FIT_PARENTS] = 4 * (uint64_t)node_bound,
        [PF_BIH_FIT_ARRIVALS] = 4 * (uint64_t)node_bound,
        [PF_BIH_FIT_BOXES] = (uint64_t)BOX_BYTES * node_bound,
        [PF_BIH_FIT_PARTIALS] = 4 * (uint64_t)groups,
        [PF_BIH_FIT_COST] = 16,
        [PF_BIH_FIT_STATS] = 16,
    };
    static const char *const labels[PF_BIH_FIT_BUFFERS] = {
        "BIH fit parents",      "BIH fit arrivals", "BIH fit boxes",
        "BIH fit partial sums", "BIH fit cost",     "BIH fit statistics"};
    pf_status status = PF_OK;
    for (int i = 0; status == PF_OK && i < PF_BIH_FIT_BUFFERS; i++)
        status = pf_vk_buffer_create(b->ctx, sizes[i], labels[i], &fit->buffers[i], err);
    if (status != PF_OK)
        pf_bih_fit_release(b->ctx, fit);
    return status;
}

pf_status pf_bih_fit_record(pf_bih_gpu_builder *b, pf_vk_commands *cmds, pf_vk_buffer *nodes,
                            pf_vk_buffer *vertices, uint32_t node_bound, pf_vk_buffer *kept,
                            uint32_t kept_index, uint32_t levels, pf_bih_fit *fit,
                            pf_error *err)
{
    if (fit->node_bound != node_bound || !fit->buffers[0])
        return pf_error_set(err, PF_ERR_INTERNAL, "BIH fit: buffers for %u nodes, not %u",
                            fit->node_bound, node_bound);
    uint32_t groups = (node_bound + REFIT_GROUP_SIZE - 1) / REFIT_GROUP_SIZE;
    pf_vk_buffer **buf = fit->buffers;
    int *stamps = fit->stamps;
    pf_status status;
    stamps[0] = pf_vk_cmd_timestamp(cmds);
    uint32_t link_push[2] = {node_bound, kept ? kept_index : NO_KEPT};
    pf_vk_buffer *link[] = {nodes, buf[PF_BIH_FIT_PARENTS], buf[PF_BIH_FIT_ARRIVALS],
                            buf[PF_BIH_FIT_STATS], kept ? kept : buf[PF_BIH_FIT_STATS]};
    status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_LINK], link, 5, link_push, sizeof link_push,
                                groups, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_LINK] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    /* levels 0: the boxes are there already (a build's collapse wrote them), no bounds. */
    /* The climb runs in lockstep for as many rounds as the deepest leaf needs; no build
     * makes a tree deeper than the traversal's stack. */
    uint32_t bounds_push[2] = {node_bound, levels < PF_BIH_STACK_SIZE + 1 ? levels
                                                                           : PF_BIH_STACK_SIZE + 1};
    pf_vk_buffer *bounds[] = {nodes, vertices, buf[PF_BIH_FIT_PARENTS], buf[PF_BIH_FIT_ARRIVALS],
                              buf[PF_BIH_FIT_BOXES], buf[PF_BIH_FIT_STATS]};
    if (status == PF_OK && levels > 0)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_BOUNDS], bounds, 6, bounds_push,
                                    sizeof bounds_push, groups, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_BOUNDS] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *sah[] = {nodes, buf[PF_BIH_FIT_PARENTS], buf[PF_BIH_FIT_BOXES],
                           buf[PF_BIH_FIT_PARTIALS], buf[PF_BIH_FIT_STATS]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_SAH], sah, 5, &node_bound,
                                    sizeof node_bound, groups, 1, 1, err);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *sum[] = {buf[PF_BIH_FIT_PARTIALS], buf[PF_BIH_FIT_COST]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_SUM], sum, 2, &groups, sizeof groups,
                                    1, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_SAH] = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[PF_BIH_FIT_COST], 0, &fit->cost, sizeof fit->cost,
                                    err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[PF_BIH_FIT_BOXES], 0, fit->root, sizeof fit->root,
                                    err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[PF_BIH_FIT_STATS], 0, fit->stats,
                                    sizeof fit->stats, err);
    return status;
}

void pf_bih_fit_times(const pf_bih_fit *fit, const pf_vk_commands *cmds,
                      double pass_ms[PF_BIH_REFIT_PASSES], double *gpu_ms)
{
    for (int p = 0; p < PF_BIH_REFIT_PASSES; p++)
        pass_ms[p] = pf_vk_commands_elapsed_ms(cmds, fit->stamps[p], fit->stamps[p + 1]);
    *gpu_ms = pf_vk_commands_elapsed_ms(cmds, fit->stamps[0], fit->stamps[PF_BIH_REFIT_PASSES]);
}

void pf_bih_fit_release(pf_vk_context *ctx, pf_bih_fit *fit)
{
    for (int i = 0; i < PF_BIH_FIT_BUFFERS; i++)
        if (fit->buffers[i])
            pf_vk_buffer_destroy(ctx, fit->buffers[i]);
    memset(fit->buffers, 0, sizeof fit->buffers);
}

pf_status pf_bih_refit_gpu(pf_bih_gpu_builder *builder, pf_bih_gpu *device, pf_bih *bih,
                           const pf_scene_frame *frame, pf_bih_gpu_refit_report *report,
                           pf_error *err)
{
    if (!builder || !device || !bih || !frame)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_refit_gpu: NULL argument");
    pf_bih_gpu_refit_report local;
    if (!report)
        report = &local;
    report->sah_cost = 0.0;
    report->gpu_ms = -1.0;
    for (int p = 0; p < PF_BIH_REFIT_PASSES; p++)
        report->pass_ms[p] = -1.0;
    pf_bih_gpu_view tree;
    pf_status status = pf_bih_gpu_view_get(device, &tree, err);
    if (status != PF_OK)
        return status;
    if (tree.node_count != bih->node_count || tree.triangle_count != bih->triangle_count)
        return pf_error_set(err, PF_ERR_INVALID,
                            "BIH device refit: the device holds %u nodes over %u triangles, "
                            "the host's tree %u over %u",
                            tree.node_count, tree.triangle_count, bih->node_count,
                            bih->triangle_count);
    status = pf_bih_fit_check(builder, tree.node_count, err);
    if (status == PF_OK)
        status = pf_bih_refit_vertices(bih, frame, err);
    if (status != PF_OK)
        return status;
    /* One submission and one wait: the vertices' upload, the passes, the 52-byte readback. */
    pf_vk_commands *cmds = NULL;
    pf_bih_fit fit = {0};
    status = pf_vk_commands_begin(builder->ctx, &cmds, err);
    if (status == PF_OK && bih->triangle_count > 0)
        status = pf_vk_cmd_upload(cmds, tree.vertices, 0, bih->vertices,
                                  3 * (uint64_t)bih->triangle_count * sizeof bih->vertices[0],
                                  err);
    if (status == PF_OK)
        status = pf_bih_fit_create(builder, tree.node_count, &fit, err);
    if (status == PF_OK)
        status = pf_bih_fit_record(builder, cmds, tree.nodes, tree.vertices, tree.node_count,
                                   NULL, 0, bih->depth + 1, &fit, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK)
        pf_bih_fit_times(&fit, cmds, report->pass_ms, &report->gpu_ms);
    pf_vk_commands_destroy(cmds);
    pf_bih_fit_release(builder->ctx, &fit);
    if (status != PF_OK) {
        pf_error_prefix(err, "BIH device refit (%u nodes, %u triangles)", tree.node_count,
                        tree.triangle_count);
        return status;
    }
    /* The build's convention: an empty tree has a zero box (pf_bih_refit's). */
    for (int k = 0; k < 3; k++) {
        bih->bounds_min[k] = bih->triangle_count > 0 ? fit.root[k] : 0.0f;
        bih->bounds_max[k] = bih->triangle_count > 0 ? fit.root[4 + k] : 0.0f;
    }
    pf_bih_gpu_set_bounds(device, bih->bounds_min, bih->bounds_max);
    report->sah_cost = fit.cost;
    return PF_OK;
}
