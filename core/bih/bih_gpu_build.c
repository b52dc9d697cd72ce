/*
 * The GPU BIH build (see pf_bih_build_gpu in pf_bih.h for the passes). The
 * host validates the vertices and computes the scene box (the Morton grid),
 * then records the vertices' upload, every pass (a barrier between passes)
 * and the readbacks of the compacted nodes (at their bound, 2n - 1), the
 * leaf-order vertices and the triangle index into one command buffer: one
 * submission and one wait (issue 44). It then measures the tree (depth,
 * leaves) while walking it once. Where the nodes stay on the device
 * (pf_bih_build_gpu_kept), the device measures the tree instead (the refit's
 * passes, bih_gpu_refit.c, over the boxes the collapse writes) and only the
 * triangle index and the measures come back; the host gathers the leaf-order
 * vertices itself.
 */
#include "bih_internal.h"

#include <math.h>
#include <stdlib.h>

/* local_size_x of every bih_*.comp build pass; the radix passes need 256 = one digit per invocation. */
#define BUILD_GROUP_SIZE 256u
/* 8-bit digits: 4 passes cover the 30-bit codes of bih_morton.comp. */
#define RADIX_BITS 8u
#define RADIX_PASSES 4u
#define RADIX_BINS (1u << RADIX_BITS)
/* bih_morton.comp quantises each axis to 10 bits (1024 cells). */
#define MORTON_CELLS 1024.0f
/* Largest element per node among the build buffers: a box (two vec4). */
#define BOX_BYTES 32u
/* A node as bih_collapse.comp writes it: pf_bih_gpu's 16-byte texel (clip, clip, word, 0). */
#define NODE_TEXEL_WORDS 4u

enum {
    PASS_MORTON,
    PASS_HISTOGRAM,
    PASS_SCAN,
    PASS_SCATTER,
    PASS_EMIT,
    PASS_CLIP,
    PASS_COLLAPSE,
    PASS_COUNT
};

static const struct {
    const char *shader;
    uint32_t buffers;
    uint32_t push_bytes;
} pass_desc[PASS_COUNT] = {
    {"bih_morton", 3, 36},
    {"bih_radix_histogram", 2, 12},
    {"prefix_sum", 1, 8},
    {"bih_radix_scatter", 5, 12},
    {"bih_emit", 4, 4},
    {"bih_clip", 11, 8},
    {"bih_collapse", 8, 12},
};

_Static_assert(PASS_COUNT == PF_BIH_BUILD_PIPELINES, "bih_internal.h sizes the builder's array");

enum {
    BUF_VERTICES,
    BUF_KEYS_A,
    BUF_VALUES_A,
    BUF_KEYS_B,
    BUF_VALUES_B,
    BUF_HISTOGRAM,
    BUF_INNER,
    BUF_PARENTS,
    BUF_ARRIVALS,
    BUF_BOXES,
    BUF_COUNTS,
    BUF_CLIPS,
    BUF_RANK,
    BUF_LEAF_VERTICES,
    BUF_TRIANGLE_INDEX,
    BUF_NODES,
    BUF_COUNT
};

pf_status pf_bih_gpu_builder_create(pf_vk_context *ctx, pf_bih_gpu_builder **out, pf_error *err)
{
    *out = NULL;
    pf_bih_gpu_builder *builder = calloc(1, sizeof *builder);
    if (!builder)
        return pf_error_set(err, PF_ERR_NOMEM, "pf_bih_gpu_builder_create");
    builder->ctx = ctx;
    for (int p = 0; p < PASS_COUNT; p++) {
        pf_status status = pf_vk_pipeline_create_named(ctx, pass_desc[p].shader,
                                                       pass_desc[p].buffers,
                                                       pass_desc[p].push_bytes, NULL, 0,
                                                       &builder->pipelines[p], err);
        if (status != PF_OK) {
            pf_bih_gpu_builder_destroy(builder);
            return status;
        }
    }
    *out = builder;
    return PF_OK;
}

void pf_bih_gpu_builder_destroy(pf_bih_gpu_builder *builder)
{
    if (!builder)
        return;
    for (int p = 0; p < PASS_COUNT; p++)
        if (builder->pipelines[p])
            pf_vk_pipeline_destroy(builder->ctx, builder->pipelines[p]);
    for (int p = 0; p < PF_BIH_REFIT_PIPELINES; p++)
        if (builder->refit[p])
            pf_vk_pipeline_destroy(builder->ctx, builder->refit[p]);
    free(builder);
}

/* Finite vertices (else PF_ERR_INVALID naming the triangle) and the scene box. */
static pf_status scene_box(const pf_scene_frame *frame, float lo[3], float hi[3], pf_error *err)
{
    for (uint32_t t = 0; t < frame->triangle_count; t++)
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++) {
                float v = frame->vertices[3 * t + c][k];
                if (!isfinite(v))
                    return pf_error_set(err, PF_ERR_INVALID,
                                        "BIH GPU build: triangle %u vertex %d: non-finite coordinate",
                                        t, c);
                lo[k] = (t == 0 && c == 0) || v < lo[k] ? v : lo[k];
                hi[k] = (t == 0 && c == 0) || v > hi[k] ? v : hi[k];
            }
    return PF_OK;
}

static uint32_t groups_for(uint32_t items)
{
    return (items + BUILD_GROUP_SIZE - 1) / BUILD_GROUP_SIZE;
}

const char *pf_bih_gpu_pass_name(pf_bih_gpu_pass pass)
{
    static const char *const names[PF_BIH_GPU_PASSES] = {"morton", "sort", "emit", "clip",
                                                         "collapse", "fit"};
    return (unsigned)pass < PF_BIH_GPU_PASSES ? names[pass] : "?";
}

/* Records all passes; the result is in BUF_NODES, BUF_RANK[n - 1] = kept inner nodes.
 * stamps[0] before the first pass and stamps[p + 1] after pass p (pf_bih_gpu_pass; -1
 * without timestamps). */
static pf_status record_build(pf_bih_gpu_builder *b, pf_vk_commands *cmds, pf_vk_buffer **buf,
                              uint32_t n, uint32_t leaf_size, const float lo[3],
                              const float hi[3], pf_vk_buffer *slot_boxes,
                              int stamps[PF_BIH_GPU_PASSES + 1], pf_error *err)
{
    stamps[0] = pf_vk_cmd_timestamp(cmds);
    uint32_t groups = groups_for(n);
    struct {
        float scene_min[4];
        float scale[4];
        uint32_t count;
    } morton = {{lo[0], lo[1], lo[2], 0.0f}, {0}, n};
    for (int k = 0; k < 3; k++)
        morton.scale[k] = hi[k] > lo[k] ? MORTON_CELLS / (hi[k] - lo[k]) : 0.0f;
    pf_vk_buffer *morton_buffers[] = {buf[BUF_VERTICES], buf[BUF_KEYS_A], buf[BUF_VALUES_A]};
    pf_status status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_MORTON], morton_buffers, 3,
                                          &morton, pass_desc[PASS_MORTON].push_bytes, groups, 1,
                                          1, err);
    stamps[1 + PF_BIH_GPU_PASS_MORTON] = pf_vk_cmd_timestamp(cmds);
    for (uint32_t pass = 0; status == PF_OK && pass < RADIX_PASSES; pass++) {
        pf_vk_cmd_barrier(cmds);
        int from_a = pass % 2 == 0;
        pf_vk_buffer *keys_in = buf[from_a ? BUF_KEYS_A : BUF_KEYS_B];
        pf_vk_buffer *values_in = buf[from_a ? BUF_VALUES_A : BUF_VALUES_B];
        pf_vk_buffer *keys_out = buf[from_a ? BUF_KEYS_B : BUF_KEYS_A];
        pf_vk_buffer *values_out = buf[from_a ? BUF_VALUES_B : BUF_VALUES_A];
        uint32_t radix_push[3] = {n, pass * RADIX_BITS, groups};
        pf_vk_buffer *histogram_buffers[] = {keys_in, buf[BUF_HISTOGRAM]};
        status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_HISTOGRAM], histogram_buffers, 2,
                                    radix_push, sizeof radix_push, groups, 1, 1, err);
        if (status == PF_OK)
            status = pf_bih_prefix_sum_record(cmds, b->pipelines[PASS_SCAN], buf[BUF_HISTOGRAM],
                                              RADIX_BINS * groups, err);
        pf_vk_buffer *scatter_buffers[] = {keys_in, values_in, keys_out, values_out,
                                           buf[BUF_HISTOGRAM]};
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_SCATTER], scatter_buffers, 5,
                                        radix_push, sizeof radix_push, groups, 1, 1, err);
    }
    stamps[1 + PF_BIH_GPU_PASS_SORT] = pf_vk_cmd_timestamp(cmds);
    /* An even number of passes leaves the sorted keys and values in the A buffers. */
    uint32_t inner_groups = groups_for(n - 1);
    pf_vk_cmd_barrier(cmds);
    pf_vk_buffer *emit_buffers[] = {buf[BUF_KEYS_A], buf[BUF_INNER], buf[BUF_PARENTS],
                                    buf[BUF_ARRIVALS]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_EMIT], emit_buffers, 4, &n, sizeof n,
                                    inner_groups, 1, 1, err);
    stamps[1 + PF_BIH_GPU_PASS_EMIT] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    uint32_t tree_push[2] = {n, leaf_size};
    pf_vk_buffer *clip_buffers[] = {buf[BUF_VERTICES], buf[BUF_VALUES_A], buf[BUF_INNER],
                                    buf[BUF_PARENTS], buf[BUF_BOXES], buf[BUF_COUNTS],
                                    buf[BUF_ARRIVALS], buf[BUF_CLIPS], buf[BUF_RANK],
                                    buf[BUF_LEAF_VERTICES], buf[BUF_TRIANGLE_INDEX]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_CLIP], clip_buffers, 11, tree_push,
                                    sizeof tree_push, groups, 1, 1, err);
    if (status == PF_OK)
        status = pf_bih_prefix_sum_record(cmds, b->pipelines[PASS_SCAN], buf[BUF_RANK], n - 1,
                                          err);
    stamps[1 + PF_BIH_GPU_PASS_CLIP] = pf_vk_cmd_timestamp(cmds);
    pf_vk_cmd_barrier(cmds);
    /* With slot_boxes, every slot's box too (a tree kept on the device is measured so). */
    uint32_t collapse_push[3] = {n, leaf_size, slot_boxes != NULL};
    pf_vk_buffer *collapse_buffers[] = {buf[BUF_INNER], buf[BUF_PARENTS], buf[BUF_COUNTS],
                                        buf[BUF_CLIPS], buf[BUF_RANK],    buf[BUF_NODES],
                                        buf[BUF_BOXES], slot_boxes ? slot_boxes : buf[BUF_BOXES]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, b->pipelines[PASS_COLLAPSE], collapse_buffers, 8,
                                    collapse_push, sizeof collapse_push, inner_groups, 1, 1,
                                    err);
    stamps[1 + PF_BIH_GPU_PASS_COLLAPSE] = pf_vk_cmd_timestamp(cmds);
    return status;
}

/*
 * Walks the downloaded tree once: every child index in range, every node
 * reached once (so the walk ends on any input), and the depth and leaf
 * statistics pf_bih carries.
 */
pf_status pf_bih_measure_walk(pf_bih *bih, pf_error *err)
{
    bih->depth = bih->leaf_count = bih->largest_leaf = 0;
    /* (node, depth) pairs; each node pushes its children once: <= 1 + 2 * node_count pushes. */
    uint32_t *stack = malloc(2 * (2 * (size_t)bih->node_count + 1) * sizeof *stack);
    uint32_t *seen = calloc(bih->node_count, sizeof *seen);
    pf_status status = PF_OK;
    if (!stack || !seen)
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH GPU build: %u nodes", bih->node_count);
    uint32_t top = 0;
    if (status == PF_OK) {
        stack[top++] = 0;
        stack[top++] = 0;
    }
    while (status == PF_OK && top > 0) {
        uint32_t depth = stack[--top];
        uint32_t node = stack[--top];
        const pf_bih_node *nd = &bih->nodes[node];
        if (seen[node]++) {
            status = pf_error_set(err, PF_ERR_INTERNAL, "BIH GPU build: node %u reached twice",
                                  node);
        } else if (pf_bih_is_leaf(nd)) {
            uint32_t count = pf_bih_leaf_count(nd);
            bih->leaf_count++;
            bih->largest_leaf = count > bih->largest_leaf ? count : bih->largest_leaf;
            bih->depth = depth > bih->depth ? depth : bih->depth;
        } else if (pf_bih_first_child(nd) + 1 >= bih->node_count || pf_bih_first_child(nd) == 0) {
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "BIH GPU build: node %u has children %u+1 outside the %u nodes",
                                  node, pf_bih_first_child(nd), bih->node_count);
        } else {
            stack[top++] = pf_bih_first_child(nd);
            stack[top++] = depth + 1;
            stack[top++] = pf_bih_first_child(nd) + 1;
            stack[top++] = depth + 1;
        }
    }
    free(stack);
    free(seen);
    return status;
}

/*
 * A tree whose nodes stay on the device: the host's copy gets the node count, the device's
 * statistics (checked against the count) and the leaf-order vertices, gathered here from
 * frame through the downloaded triangle index as the device copied them (pf_bih_check's
 * rule: the same degenerate flags); its nodes stay NULL (pf_bih_gpu_download_nodes).
 */
static pf_status adopt_measures(pf_bih *out, const pf_scene_frame *frame, uint32_t kept,
                                const pf_bih_fit *fit, pf_bih_gpu_build_report *report,
                                pf_error *err)
{
    out->node_count = 1 + 2 * kept;
    if (fit->stats[3] != out->node_count || fit->stats[1] != kept + 1 ||
        fit->stats[2] == 0)
        return pf_error_set(err, PF_ERR_INTERNAL,
                            "BIH GPU build: the device measured %u nodes, %u leaves (largest "
                            "%u) where %u inner nodes were kept",
                            fit->stats[3], fit->stats[1], fit->stats[2], kept);
    out->depth = fit->stats[0];
    out->leaf_count = fit->stats[1];
    out->largest_leaf = fit->stats[2];
    for (uint32_t p = 0; p < out->triangle_count; p++)
        if (out->triangle_index[p] >= frame->triangle_count)
            return pf_error_set(err, PF_ERR_INTERNAL,
                                "BIH GPU build: leaf position %u holds triangle %u of %u", p,
                                out->triangle_index[p], frame->triangle_count);
    pf_bih_gather_leaf_vertices(out, frame);
    report->sah_cost = fit->cost;
    return PF_OK;
}

/* The build; with tree non-NULL its nodes, leaf-order vertices and triangle index stay on
 * the device there (tree[0..2], the caller's to destroy or hand to a pf_bih_gpu), and with
 * nodes_stay (tree non-NULL) the host gets no nodes (adopt_measures). */
static pf_status run_gpu_build(pf_bih_gpu_builder *b, const pf_scene_frame *frame,
                               uint32_t leaf_size, const float lo[3], const float hi[3],
                               pf_bih *out, pf_vk_buffer *tree[3], int nodes_stay,
                               pf_bih_gpu_build_report *report, pf_error *err)
{
    pf_vk_context *ctx = b->ctx;
    uint32_t n = frame->triangle_count;
    const pf_vk_device_info *info = pf_vk_info(ctx);
    uint64_t largest = 2 * (uint64_t)n * BOX_BYTES;
    if (largest > info->max_storage_buffer_range || groups_for(n) > info->max_workgroup_count[0])
        return pf_error_set(err, PF_ERR_LIMIT,
                            "BIH GPU build: %u triangles need %llu-byte buffers and %u workgroups; device '%s' allows %llu and %u",
                            n, (unsigned long long)largest, groups_for(n), info->name,
                            (unsigned long long)info->max_storage_buffer_range,
                            info->max_workgroup_count[0]);
    uint64_t nodes = 2 * (uint64_t)n - 1, inner = (uint64_t)n - 1;
    const struct {
        uint64_t bytes;
        const char *label;
    } sizes[BUF_COUNT] = {
        [BUF_VERTICES] = {3 * (uint64_t)n * 16, "BIH build vertices"},
        [BUF_KEYS_A] = {4 * (uint64_t)n, "BIH build keys A"},
        [BUF_VALUES_A] = {4 * (uint64_t)n, "BIH build values A"},
        [BUF_KEYS_B] = {4 * (uint64_t)n, "BIH build keys B"},
        [BUF_VALUES_B] = {4 * (uint64_t)n, "BIH build values B"},
        [BUF_HISTOGRAM] = {4 * pf_bih_prefix_sum_words(RADIX_BINS * groups_for(n)),
                           "BIH build histogram"},
        [BUF_INNER] = {16 * inner, "BIH build inner nodes"},
        [BUF_PARENTS] = {4 * nodes, "BIH build parents"},
        [BUF_ARRIVALS] = {4 * inner, "BIH build arrivals"},
        [BUF_BOXES] = {BOX_BYTES * nodes, "BIH build boxes"},
        [BUF_COUNTS] = {4 * nodes, "BIH build counts"},
        [BUF_CLIPS] = {8 * inner, "BIH build clips"},
        [BUF_RANK] = {4 * pf_bih_prefix_sum_words((uint32_t)inner), "BIH build ranks"},
        [BUF_LEAF_VERTICES] = {3 * (uint64_t)n * 16, "BIH vertices"},
        [BUF_TRIANGLE_INDEX] = {4 * (uint64_t)n, "BIH triangle index"},
        [BUF_NODES] = {4 * NODE_TEXEL_WORDS * nodes, "BIH nodes"},
    };
    pf_vk_buffer *buf[BUF_COUNT] = {0};
    pf_status status = PF_OK;
    for (int i = 0; status == PF_OK && i < BUF_COUNT; i++)
        status = pf_vk_buffer_create(ctx, sizes[i].bytes, sizes[i].label, &buf[i], err);
    /* The host's copies, at their bounds: 2n - 1 node texels, of which 1 + 2 kept are read;
     * none where the nodes stay on the device, which measures the tree instead. */
    out->triangle_count = n;
    uint32_t (*texels)[NODE_TEXEL_WORDS] =
        nodes_stay ? NULL : malloc((size_t)nodes * sizeof *texels);
    out->nodes = nodes_stay ? NULL : malloc((size_t)nodes * sizeof *out->nodes);
    out->vertices = malloc(3 * (size_t)n * sizeof *out->vertices);
    out->triangle_index = malloc((size_t)n * sizeof *out->triangle_index);
    if (status == PF_OK &&
        ((!nodes_stay && (!texels || !out->nodes)) || !out->vertices || !out->triangle_index))
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH GPU build: %u triangles", n);
    if (status == PF_OK && nodes_stay)
        status = pf_bih_fit_check(b, (uint32_t)nodes, err);
    /* One submission and one wait (issue 44): the upload, every pass and the readbacks. */
    uint32_t kept = 0;
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, buf[BUF_VERTICES], 0, frame->vertices,
                                  sizes[BUF_VERTICES].bytes, err);
    int stamps[PF_BIH_GPU_PASSES + 1];
    pf_bih_fit fit = {0};
    if (status == PF_OK && nodes_stay)
        status = pf_bih_fit_create(b, (uint32_t)nodes, &fit, err);
    if (status == PF_OK)
        status = record_build(b, cmds, buf, n, leaf_size, lo, hi,
                              nodes_stay ? fit.buffers[PF_BIH_FIT_BOXES] : NULL, stamps, err);
    /* Kept on the device: its SAH, depth and leaves measured there (the refit's passes, but
     * the bounds: the collapse wrote the slots' boxes). */
    if (status == PF_OK && nodes_stay) {
        pf_vk_cmd_barrier(cmds);
        status = pf_bih_fit_record(b, cmds, buf[BUF_NODES], buf[BUF_LEAF_VERTICES],
                                   (uint32_t)nodes, buf[BUF_RANK], (uint32_t)inner, 0, &fit,
                                   err);
    }
    stamps[1 + PF_BIH_GPU_PASS_FIT] = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[BUF_RANK], 4 * inner, &kept, sizeof kept, err);
    if (status == PF_OK && !nodes_stay)
        status = pf_vk_cmd_download(cmds, buf[BUF_NODES], 0, texels, sizes[BUF_NODES].bytes,
                                    err);
    if (status == PF_OK && !nodes_stay)
        status = pf_vk_cmd_download(cmds, buf[BUF_LEAF_VERTICES], 0, out->vertices,
                                    sizes[BUF_LEAF_VERTICES].bytes, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buf[BUF_TRIANGLE_INDEX], 0, out->triangle_index,
                                    sizes[BUF_TRIANGLE_INDEX].bytes, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    for (int p = 0; status == PF_OK && p < PF_BIH_GPU_PASSES; p++)
        report->pass_ms[p] = pf_vk_commands_elapsed_ms(cmds, stamps[p], stamps[p + 1]);
    if (status == PF_OK)
        report->gpu_ms = pf_vk_commands_elapsed_ms(cmds, stamps[0], stamps[PF_BIH_GPU_PASSES]);
    pf_vk_commands_destroy(cmds);
    pf_bih_fit_release(ctx, &fit);
    if (status == PF_OK && (kept == 0 || kept > inner))
        status = pf_error_set(err, PF_ERR_INTERNAL,
                              "BIH GPU build: %u kept inner nodes of %u (n = %u > K = %u)", kept,
                              (uint32_t)inner, n, leaf_size);
    if (status == PF_OK && nodes_stay)
        status = adopt_measures(out, frame, kept, &fit, report, err);
    if (status == PF_OK && !nodes_stay) {
        out->node_count = 1 + 2 * kept;
        pf_bih_nodes_from_texels((const uint32_t(*)[4])texels, out->node_count, out->nodes);
        pf_bih_node *fitted = realloc(out->nodes, out->node_count * sizeof *out->nodes);
        out->nodes = fitted ? fitted : out->nodes;
    }
    free(texels);
    if (status == PF_OK) {
        memcpy(out->bounds_min, lo, sizeof out->bounds_min);
        memcpy(out->bounds_max, hi, sizeof out->bounds_max);
    }
    if (status == PF_OK && !nodes_stay)
        status = pf_bih_measure_walk(out, err);
    if (status == PF_OK && tree) { /* kept on the device, as built */
        const int kept_buffers[3] = {BUF_NODES, BUF_LEAF_VERTICES, BUF_TRIANGLE_INDEX};
        for (int i = 0; i < 3; i++) {
            tree[i] = buf[kept_buffers[i]];
            buf[kept_buffers[i]] = NULL;
        }
    }
    for (int i = 0; i < BUF_COUNT; i++)
        if (buf[i])
            pf_vk_buffer_destroy(ctx, buf[i]);
    return status;
}

pf_status pf_bih_build_gpu(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                           const pf_bih_build_options *options, pf_bih *out,
                           pf_bih_gpu_build_report *report, pf_error *err)
{
    return pf_bih_build_gpu_resident(builder, frame, options, out, NULL, report, err);
}

/* pf_bih_build_gpu_resident, or with nodes_stay pf_bih_build_gpu_kept. */
static pf_status build_on_device(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                                 const pf_bih_build_options *options, pf_bih *out,
                                 pf_bih_gpu *device, int nodes_stay,
                                 pf_bih_gpu_build_report *report, pf_error *err)
{
    if (!builder || !frame || !out || (nodes_stay && !device))
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_build_gpu: NULL argument");
    memset(out, 0, sizeof *out);
    pf_bih_gpu_build_report local;
    if (!report)
        report = &local;
    memset(report, 0, sizeof *report);
    report->gpu_ms = -1.0;
    for (int p = 0; p < PF_BIH_GPU_PASSES; p++)
        report->pass_ms[p] = -1.0;
    uint32_t leaf_size = options && options->max_leaf_size ? options->max_leaf_size
                                                           : PF_BIH_DEFAULT_LEAF_SIZE;
    uint32_t max_depth = options && options->max_depth ? options->max_depth : PF_BIH_STACK_SIZE;
    uint32_t n = frame->triangle_count;
    /* The CPU build validates what it needs; it also makes the one-leaf tree of n <= K. */
    if (max_depth > PF_BIH_STACK_SIZE || n <= leaf_size || n >= PF_BIH_MAX_NODES / 2 ||
        !frame->vertices) {
        report->path = PF_BIH_BUILT_SMALL_ON_CPU;
        return pf_bih_build_cpu(frame, options, out, err);
    }
    float lo[3], hi[3];
    pf_vk_buffer *tree[3] = {NULL, NULL, NULL};
    pf_status status = scene_box(frame, lo, hi, err);
    if (status == PF_OK)
        status = run_gpu_build(builder, frame, leaf_size, lo, hi, out, device ? tree : NULL,
                               nodes_stay, report, err);
    if (status != PF_OK) {
        pf_bih_free(out);
        memset(out, 0, sizeof *out);
        pf_error_prefix(err, "BIH GPU build (%u triangles)", n);
        return status;
    }
    report->gpu_depth = out->depth;
    if (out->depth <= max_depth && device) {
        pf_bih_gpu_adopt(device, out, tree);
        report->resident = 1;
    }
    for (int i = 0; i < 3; i++)
        if (tree[i] && !report->resident)
            pf_vk_buffer_destroy(builder->ctx, tree[i]);
    if (out->depth > max_depth) {
        pf_log(PF_LOG_WARN,
               "BIH GPU build: %u triangles gave depth %u > max_depth %u (clustered geometry); built on the CPU instead",
               n, out->depth, max_depth);
        pf_bih_free(out);
        report->path = PF_BIH_BUILT_CPU_FALLBACK;
        return pf_bih_build_cpu(frame, options, out, err);
    }
    report->path = PF_BIH_BUILT_ON_GPU;
    return PF_OK;
}

pf_status pf_bih_build_gpu_resident(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                                    const pf_bih_build_options *options, pf_bih *out,
                                    pf_bih_gpu *device, pf_bih_gpu_build_report *report,
                                    pf_error *err)
{
    return build_on_device(builder, frame, options, out, device, 0, report, err);
}

pf_status pf_bih_build_gpu_kept(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                                const pf_bih_build_options *options, pf_bih *out,
                                pf_bih_gpu *device, pf_bih_gpu_build_report *report,
                                pf_error *err)
{
    return build_on_device(builder, frame, options, out, device, 1, report, err);
}
