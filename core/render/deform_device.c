/*
 * The `deform` stage (issue 39): skins and morph targets of the frame's deforming mesh
 * nodes, their per-vertex half on the device (shaders/deform.comp) or on the host's vector
 * code (pf_deform_vertices_host), and the host gathering the triangles either way
 * (pf_scene_deform_with). Where the device is the CPU the host's loop is the faster one
 * (bench/RESULTS.md, "Skins and morph targets"), as for lpv_propagate; elsewhere the
 * device. A node's rest pose, targets and influences go to the device once and stay there
 * while frames of the same scene load come (pf_deform_node.scene_load; the first node of
 * another load releases them, as the texture cache does); a frame sends its
 * weights and matrices, one dispatch and the results' readback, in one submission a node.
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* deform.comp's bindings: 7 kept inputs, 2 a frame, 4 results. */
enum {
    DEFORM_REST_POSITIONS,
    DEFORM_REST_NORMALS,
    DEFORM_TARGET_POSITIONS,
    DEFORM_TARGET_NORMALS,
    DEFORM_TARGET_TANGENTS,
    DEFORM_JOINTS,
    DEFORM_JOINT_WEIGHTS,
    DEFORM_WEIGHTS,
    DEFORM_MATRICES,
    DEFORM_OUT_POSITION,
    DEFORM_OUT_NORMAL,
    DEFORM_OUT_TANGENT,
    DEFORM_OUT_MATRIX,
    DEFORM_BUFFER_COUNT
};
#define DEFORM_GROUP_SIZE 64u

typedef struct deform_push {
    uint32_t vertex_count, target_count, influences, deltas;
} deform_push;

/* One node's buffers on the device. */
typedef struct deform_entry {
    uint32_t node;
    uint32_t vertex_count, target_count, influences, matrix_count;
    pf_vk_buffer *buffers[DEFORM_BUFFER_COUNT];
} deform_entry;

/* The nodes of one scene load. */
struct pf_deform_cache {
    uint64_t scene_load;
    deform_entry *entries;
    uint32_t count, capacity;
};

static void entry_release(pf_vk_context *ctx, deform_entry *entry)
{
    for (int b = 0; b < DEFORM_BUFFER_COUNT; b++)
        pf_render_buffer_release(ctx, &entry->buffers[b]);
}

void pf_deform_cache_destroy(pf_vk_context *ctx, pf_deform_cache *cache)
{
    if (!cache)
        return;
    for (uint32_t e = 0; e < cache->count; e++)
        entry_release(ctx, &cache->entries[e]);
    free(cache->entries);
    free(cache);
}

void pf_renderer_set_deform_site(pf_renderer *renderer, pf_deform_site site)
{
    renderer->deform_site = site;
}

/* What a frame's device deformation did, for the row. */
typedef struct deform_device_run {
    pf_renderer *renderer;
    pf_vk_pipeline *pipeline;
    double gpu_ms;
    uint32_t uploaded_nodes; /* nodes whose rest pose went to the device this frame */
} deform_device_run;

/* The node's entry, created with its kept inputs recorded into cmds on first use. */
static pf_status entry_for(deform_device_run *run, pf_vk_commands *cmds,
                           const pf_deform_node *node, deform_entry **out, pf_error *err)
{
    pf_renderer *renderer = run->renderer;
    if (!renderer->deform_cache && !(renderer->deform_cache = calloc(1, sizeof(pf_deform_cache))))
        return pf_error_set(err, PF_ERR_NOMEM, "deform: out of memory");
    pf_deform_cache *cache = renderer->deform_cache;
    if (cache->scene_load != node->scene_load) {
        /* Another scene: what the last one left is not needed again (a worker's next job). */
        for (uint32_t e = 0; e < cache->count; e++)
            entry_release(renderer->ctx, &cache->entries[e]);
        cache->count = 0;
        cache->scene_load = node->scene_load;
    }
    for (uint32_t e = 0; e < cache->count; e++) {
        deform_entry *entry = &cache->entries[e];
        if (entry->node == node->node && entry->vertex_count == node->vertex_count &&
            entry->target_count == node->target_count && entry->influences == node->influences &&
            entry->matrix_count >= node->matrix_count) {
            *out = entry;
            return PF_OK;
        }
    }
    if (cache->count == cache->capacity) {
        uint32_t capacity = cache->capacity ? 2 * cache->capacity : 8;
        deform_entry *grown = realloc(cache->entries, capacity * sizeof *grown);
        if (!grown)
            return pf_error_set(err, PF_ERR_NOMEM, "deform: out of memory");
        cache->entries = grown;
        cache->capacity = capacity;
    }
    deform_entry *entry = &cache->entries[cache->count];
    memset(entry, 0, sizeof *entry);
    entry->node = node->node;
    entry->vertex_count = node->vertex_count;
    entry->target_count = node->target_count;
    entry->influences = node->influences;
    entry->matrix_count = node->matrix_count;
    pf_vk_context *ctx = renderer->ctx;
    uint64_t vertices = node->vertex_count, vec3s = 3u * vertices * sizeof(float);
    uint64_t deltas = vertices * node->target_count * 3u * sizeof(float);
    uint64_t influences = vertices * node->influences;
    uint32_t *joints = malloc((influences + 1) * sizeof *joints);
    float *joint_weights = malloc((influences + 1) * sizeof *joint_weights);
    pf_status status = joints && joint_weights
                           ? PF_OK
                           : pf_error_set(err, PF_ERR_NOMEM, "deform: out of memory");
    for (uint64_t v = 0; status == PF_OK && v < vertices; v++)
        for (uint32_t i = 0; i < node->influences; i++) {
            joints[v * node->influences + i] = node->joints[v][i];
            joint_weights[v * node->influences + i] = node->joint_weights[v][i];
        }
    struct {
        const char *label;
        const void *data;
        uint64_t size;
    } inputs[DEFORM_BUFFER_COUNT] = {
        {"deform rest positions", node->positions, vec3s},
        {"deform rest normals", node->normals, vec3s},
        {"deform target positions", node->target_positions, node->target_positions ? deltas : 0},
        {"deform target normals", node->target_normals, node->target_normals ? deltas : 0},
        {"deform target tangents", node->target_tangents, node->target_tangents ? deltas : 0},
        {"deform joints", joints, influences * sizeof *joints},
        {"deform joint weights", joint_weights, influences * sizeof *joint_weights},
        {"deform weights", NULL, node->target_count * sizeof(float)},
        {"deform matrices", NULL, (uint64_t)node->matrix_count * 12u * sizeof(float)},
        {"deform positions", NULL, vec3s},
        {"deform normals", NULL, vec3s},
        {"deform tangents", NULL, node->target_tangents ? vec3s : 0},
        {"deform matrices per vertex", NULL, vertices * 12u * sizeof(float)},
    };
    /* Every buffer at least a word; those a frame or the kernel fills start zeroed. */
    for (int b = 0; status == PF_OK && b < DEFORM_BUFFER_COUNT; b++)
        status = pf_render_buffer_recorded(ctx, cmds, inputs[b].label, inputs[b].data,
                                           inputs[b].data ? inputs[b].size : 0,
                                           inputs[b].size > 4 ? inputs[b].size : 4,
                                           &entry->buffers[b], err);
    free(joints);
    free(joint_weights);
    if (status != PF_OK) {
        entry_release(ctx, entry);
        return status;
    }
    cache->count++;
    run->uploaded_nodes++;
    *out = entry;
    return PF_OK;
}

/* pf_deform_fn on the device: one submission for the node. */
static pf_status device_vertices(void *user, const pf_deform_node *node,
                                 const pf_deform_vertices *out, pf_error *err)
{
    deform_device_run *run = user;
    pf_vk_context *ctx = run->renderer->ctx;
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status != PF_OK)
        return status;
    deform_entry *entry = NULL;
    status = entry_for(run, cmds, node, &entry, err);
    if (status == PF_OK && node->target_count > 0)
        status = pf_vk_cmd_upload(cmds, entry->buffers[DEFORM_WEIGHTS], 0, node->weights,
                                  node->target_count * sizeof(float), err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, entry->buffers[DEFORM_MATRICES], 0, node->matrices,
                                  (uint64_t)node->matrix_count * 12u * sizeof(float), err);
    deform_push push = {node->vertex_count, node->target_count, node->influences,
                        (node->target_positions ? 1u : 0u) | (node->target_normals ? 2u : 0u) |
                            (node->target_tangents ? 4u : 0u)};
    int begin = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, run->pipeline, entry->buffers, DEFORM_BUFFER_COUNT,
                                    &push, sizeof push,
                                    (node->vertex_count + DEFORM_GROUP_SIZE - 1) /
                                        DEFORM_GROUP_SIZE,
                                    1, 1, err);
    int end = pf_vk_cmd_timestamp(cmds);
    uint64_t vec3s = 3u * (uint64_t)node->vertex_count * sizeof(float);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, entry->buffers[DEFORM_OUT_POSITION], 0, out->position,
                                    vec3s, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, entry->buffers[DEFORM_OUT_NORMAL], 0, out->normal,
                                    vec3s, err);
    if (status == PF_OK && node->target_tangents)
        status = pf_vk_cmd_download(cmds, entry->buffers[DEFORM_OUT_TANGENT], 0, out->tangent,
                                    vec3s, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, entry->buffers[DEFORM_OUT_MATRIX], 0, out->matrix,
                                    4u * vec3s, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK)
        pf_gpu_ms_add(&run->gpu_ms, pf_commands_gpu_ms(cmds, begin, end));
    pf_vk_commands_destroy(cmds);
    return status;
}

pf_status pf_render_deform(pf_renderer *renderer, const pf_scene *scene, double time_seconds,
                           pf_scene_frame *frame, pf_frame_report *report, pf_error *err)
{
    if (pf_scene_get_info(scene)->deformed_node_count == 0) {
        pf_frame_report_row(report, "deform", "no skins or morph targets", 0.0, -1.0);
        return PF_OK;
    }
    double start = pf_time_ms();
    int cpu = pf_vk_device_is_cpu(renderer->ctx);
    int on_device = renderer->deform_site == PF_DEFORM_DEVICE ||
                    (renderer->deform_site == PF_DEFORM_AUTO && !cpu);
    const char *why = renderer->deform_site != PF_DEFORM_AUTO ? "forced"
                      : cpu ? "the device is the CPU, where the host's loop is faster"
                            : "a GPU";
    deform_device_run run = {renderer, NULL, -1.0, 0};
    pf_status status = PF_OK;
    if (on_device)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_DEFORM, &run.pipeline, err);
    pf_deform_report deformed;
    pf_vk_traffic before = pf_vk_traffic_of(renderer->ctx);
    if (status == PF_OK)
        status = pf_scene_deform_with(scene, time_seconds, frame,
                                      on_device ? device_vertices : NULL, &run, &deformed, err);
    if (status != PF_OK)
        return status;
    pf_vk_traffic traffic = pf_vk_traffic_since(renderer->ctx, before);
    pf_stage_timing *row =
        pf_frame_report_row(report, "deform", NULL, pf_time_ms() - start, run.gpu_ms);
    if (row) {
        snprintf(row->reason, sizeof row->reason,
                 "%u skinned mesh%s, %u morphed, %llu vertices, on the %s (%s)",
                 deformed.skinned_meshes, deformed.skinned_meshes == 1 ? "" : "es",
                 deformed.morphed_meshes, (unsigned long long)deformed.vertices,
                 on_device ? "device" : "host", why);
        pf_stage_add_counter(row, "skinned_meshes", deformed.skinned_meshes);
        pf_stage_add_counter(row, "morphed_meshes", deformed.morphed_meshes);
        pf_stage_add_counter(row, "vertices", (double)deformed.vertices);
        pf_stage_add_counter(row, "on_device", on_device);
        if (on_device) {
            pf_stage_add_counter(row, "rest_poses_uploaded", run.uploaded_nodes);
            pf_stage_add_counter(row, "submits", (double)traffic.submits);
        }
    }
    return PF_OK;
}
