/*
 * The BIH refit on the device (pf_bih_refit_gpu in pf_bih.h, issue 44): the
 * host gathers the frame's triangles into the tree's leaf order (it needs them
 * anyway: the stage planner compares the next frame against them), and one
 * submission uploads them and fits the device's copy: parents and zeroed
 * arrival counters (bih_refit_link), clip values and boxes bottom up
 * (bih_refit_bounds), and the SAH cost that decides whether the refit tree is
 * kept (bih_refit_sah, bih_refit_sum). The host reads back 36 bytes: the cost
 * and the root box. The host's clip values are fitted later only where the
 * host traces the tree (pf_bih_refit_bounds).
 */
#include "bih_internal.h"

#include <stdlib.h>

/* local_size_x of every bih_refit_*.comp. */
#define REFIT_GROUP_SIZE 256u
/* A node's box on the device: two vec4. */
#define BOX_BYTES 32u

enum { PIPE_LINK, PIPE_BOUNDS, PIPE_SAH, PIPE_SUM };

static const struct {
    const char *shader;
    uint32_t buffers;
    uint32_t push_bytes;
} pipe_desc[PF_BIH_REFIT_PIPELINES] = {
    [PIPE_LINK] = {"bih_refit_link", 3, 4},
    [PIPE_BOUNDS] = {"bih_refit_bounds", 5, 8},
    [PIPE_SAH] = {"bih_refit_sah", 4, 4},
    [PIPE_SUM] = {"bih_refit_sum", 2, 4},
};

enum { BUF_PARENTS, BUF_ARRIVALS, BUF_BOXES, BUF_PARTIALS, BUF_COST, BUF_COUNT };

const char *pf_bih_refit_pass_name(pf_bih_refit_pass pass)
{
    static const char *const names[PF_BIH_REFIT_PASSES] = {"link", "bounds", "sah"};
    return (unsigned)pass < PF_BIH_REFIT_PASSES ? names[pass] : "?";
}

/* The refit's kernels, made at the first refit: a renderer that never refits on the
 * device (lavapipe: the host refits) never compiles them. */
static pf_status refit_pipelines(pf_bih_gpu_builder *builder, pf_error *err)
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

/* The passes, timestamps around each: stamps[0] before the first, stamps[p + 1] after
 * pass p (pf_bih_refit_pass). */
static pf_status record_refit(pf_bih_gpu_builder *b, pf_vk_commands *cmds,
                              const pf_bih_gpu_view *tree, uint32_t depth, pf_vk_buffer **buf,
                              uint32_t groups, int stamps[PF_BIH_REFIT_PASSES + 1],
                              pf_error *err)
{
    uint32_t nodes = tree->node_count;
    /* The bounds pass climbs in lockstep for as many rounds as the deepest leaf needs (no
     * build makes a tree deeper than the traversal's stack). */
    uint32_t bounds_push[2] = {nodes, (depth < PF_BIH_STACK_SIZE ? depth : PF_BIH_STACK_SIZE) + 1};
    stamps[0] = pf_vk_cmd_timestamp(cmds);
    pf_vk_buffer *link[] = {tree->nodes, buf[BUF_PARENTS], buf[BUF_ARRIVALS]};
    pf_status status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_LINK], link, 3, &nodes,
                                          sizeof nodes, groups, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_LINK] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *bounds[] = {tree->nodes, tree->vertices, buf[BUF_PARENTS], buf[BUF_ARRIVALS],
                              buf[BUF_BOXES]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_BOUNDS], bounds, 5, bounds_push,
                                    sizeof bounds_push, groups, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_BOUNDS] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *sah[] = {tree->nodes, buf[BUF_PARENTS], buf[BUF_BOXES], buf[BUF_PARTIALS]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_SAH], sah, 4, &nodes, sizeof nodes,
                                    groups, 1, 1, err);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *sum[] = {buf[BUF_PARTIALS], buf[BUF_COST]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->refit[PIPE_SUM], sum, 2, &groups, sizeof groups,
                                    1, 1, 1, err);
    stamps[1 + PF_BIH_REFIT_PASS_SAH] = pf_vk_cmd_timestamp(cmds);
    return status;
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
    const pf_vk_device_info *info = pf_vk_info(builder->ctx);
    uint64_t box_bytes = (uint64_t)BOX_BYTES * tree.node_count;
    uint32_t groups = (tree.node_count + REFIT_GROUP_SIZE - 1) / REFIT_GROUP_SIZE;
    if (box_bytes > info->max_storage_buffer_range || groups > info->max_workgroup_count[0])
        return pf_error_set(err, PF_ERR_LIMIT,
                            "BIH device refit: %u nodes need %llu bytes of boxes and %u "
                            "workgroups; device '%s' allows %llu and %u",
                            tree.node_count, (unsigned long long)box_bytes, groups, info->name,
                            (unsigned long long)info->max_storage_buffer_range,
                            info->max_workgroup_count[0]);
    status = refit_pipelines(builder, err);
    if (status == PF_OK)
        status = pf_bih_refit_vertices(bih, frame, err);
    if (status != PF_OK)
        return status;
    const uint64_t sizes[BUF_COUNT] = {
        [BUF_PARENTS] = 4 * (uint64_t)tree.node_count,
        [BUF_ARRIVALS] = 4 * (uint64_t)tree.node_count,
        [BUF_BOXES] = box_bytes,
        [BUF_PARTIALS] = 4 * (uint64_t)groups,
        [BUF_COST] = 16,
    };
    static const char *const labels[BUF_COUNT] = {"BIH refit parents", "BIH refit arrivals",
                                                  "BIH refit boxes", "BIH refit partial sums",
                                                  "BIH refit cost"};
    pf_vk_buffer *buf[BUF_COUNT] = {0};
    for (int i = 0; status == PF_OK && i < BUF_COUNT; i++)
        status = pf_vk_buffer_create(builder->ctx, sizes[i], labels[i], &buf[i], err);
    /* One submission and one wait: the vertices' upload, the passes, the 36-byte readback. */
    pf_vk_commands *cmds = NULL;
    int stamps[PF_BIH_REFIT_PASSES + 1];
    float cost = 0.0f, root[8] = {0};
    if (status == PF_OK)
        status = pf_vk_commands_begin(builder->ctx, &cmds, err);
    if (status == PF_OK && bih->triangle_count > 0)
        status = pf_vk_cmd_upload(cmds, tree.vertices, 0, bih->vertices,
                                  3 * (uint64_t)bih->triangle_count * sizeof bih->vertices[0],
                                  err);
    if (status == PF_OK)
        status = record_refit(builder, cmds, &tree, bih->depth, buf, groups, stamps, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[BUF_COST], 0, &cost, sizeof cost, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[BUF_BOXES], 0, root, sizeof root, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    for (int p = 0; status == PF_OK && p < PF_BIH_REFIT_PASSES; p++)
        report->pass_ms[p] = pf_vk_commands_elapsed_ms(cmds, stamps[p], stamps[p + 1]);
    if (status == PF_OK)
        report->gpu_ms =
            pf_vk_commands_elapsed_ms(cmds, stamps[0], stamps[PF_BIH_REFIT_PASSES]);
    pf_vk_commands_destroy(cmds);
    for (int i = 0; i < BUF_COUNT; i++)
        if (buf[i])
            pf_vk_buffer_destroy(builder->ctx, buf[i]);
    if (status != PF_OK) {
        pf_error_prefix(err, "BIH device refit (%u nodes, %u triangles)", tree.node_count,
                        tree.triangle_count);
        return status;
    }
    /* The build's convention: an empty tree has a zero box (pf_bih_refit's). */
    for (int k = 0; k < 3; k++) {
        bih->bounds_min[k] = bih->triangle_count > 0 ? root[k] : 0.0f;
        bih->bounds_max[k] = bih->triangle_count > 0 ? root[4 + k] : 0.0f;
    }
    pf_bih_gpu_set_bounds(device, bih->bounds_min, bih->bounds_max);
    report->sah_cost = cost;
    return PF_OK;
}
