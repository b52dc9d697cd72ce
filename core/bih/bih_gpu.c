/*
 * The BIH on the GPU: upload of a built tree and ray casting through it
 * (shaders/bih_raycast.comp, which includes shaders/common/bih_traverse.glsl).
 */
#include "bih_internal.h"

#include <stdlib.h>

/* Workgroup size of bih_raycast.comp. */
#define RAYCAST_GROUP_SIZE 64u
/*
 * Rays per dispatch: the ray buffer (32 B each) stays at 32 MiB, far below
 * lavapipe's 128 MiB maxStorageBufferRange, and the group count (16384) below
 * the 65535 every device allows.
 */
#define RAYCAST_BATCH_RAYS (1u << 20)
/* bih_raycast.comp: nodes, vertices, triangle_index, rays, hits, failures. */
#define RAYCAST_BUFFERS 6u
#define RAYCAST_SPEC_ANY_HIT 0u
/* Vulkan buffers cannot be empty: an empty tree still gets one element. */
#define MIN_BUFFER_BYTES 16u

/* Push constants of bih_raycast.comp (std430, 48 bytes). */
typedef struct raycast_push {
    float bounds_min[4];
    float bounds_max[4];
    uint32_t ray_count;
    uint32_t triangle_count;
    uint32_t node_count;
    uint32_t padding;
} raycast_push;

struct pf_bih_gpu {
    pf_vk_context *ctx;
    pf_vk_pipeline *raycast_closest;
    pf_vk_pipeline *raycast_any;
    pf_vk_buffer *nodes;
    pf_vk_buffer *vertices;
    pf_vk_buffer *triangle_index;
    pf_vk_buffer *failures;
    uint32_t node_count;
    uint32_t triangle_count;
    float bounds_min[3], bounds_max[3];
    int uploaded;
};

static void release_buffer(pf_vk_context *ctx, pf_vk_buffer **buffer)
{
    if (*buffer)
        pf_vk_buffer_destroy(ctx, *buffer);
    *buffer = NULL;
}

static void release_tree(pf_bih_gpu *gpu)
{
    release_buffer(gpu->ctx, &gpu->nodes);
    release_buffer(gpu->ctx, &gpu->vertices);
    release_buffer(gpu->ctx, &gpu->triangle_index);
    gpu->uploaded = 0;
}

pf_status pf_bih_gpu_create(pf_vk_context *ctx, pf_bih_gpu **out, pf_error *err)
{
    *out = NULL;
    pf_bih_gpu *gpu = calloc(1, sizeof *gpu);
    if (!gpu)
        return pf_error_set(err, PF_ERR_NOMEM, "pf_bih_gpu_create");
    gpu->ctx = ctx;
    pf_status status = pf_vk_buffer_create(ctx, MIN_BUFFER_BYTES, "BIH traversal failures",
                                           &gpu->failures, err);
    if (status != PF_OK) {
        pf_bih_gpu_destroy(gpu);
        return status;
    }
    *out = gpu;
    return PF_OK;
}

void pf_bih_gpu_destroy(pf_bih_gpu *gpu)
{
    if (!gpu)
        return;
    release_tree(gpu);
    release_buffer(gpu->ctx, &gpu->failures);
    if (gpu->raycast_closest)
        pf_vk_pipeline_destroy(gpu->ctx, gpu->raycast_closest);
    if (gpu->raycast_any)
        pf_vk_pipeline_destroy(gpu->ctx, gpu->raycast_any);
    free(gpu);
}

/* A buffer of at least MIN_BUFFER_BYTES with data's upload recorded in cmds. */
static pf_status upload_array(pf_vk_context *ctx, pf_vk_commands *cmds, const void *data,
                              uint64_t bytes, const char *label, pf_vk_buffer **out,
                              pf_error *err)
{
    pf_status status = pf_vk_buffer_create(ctx, bytes > MIN_BUFFER_BYTES ? bytes : MIN_BUFFER_BYTES,
                                           label, out, err);
    if (status == PF_OK && bytes > 0)
        status = pf_vk_cmd_upload(cmds, *out, 0, data, bytes, err);
    return status;
}

pf_status pf_bih_gpu_upload(pf_bih_gpu *gpu, const pf_bih *bih, pf_error *err)
{
    if (!gpu || !bih || bih->node_count == 0)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_gpu_upload: NULL argument or no nodes");
    release_tree(gpu);
    /* One 16-byte texel per node (pf_bih.h): bih_traverse.glsl reads a node in one fetch. */
    uint32_t (*texels)[4] = malloc((size_t)bih->node_count * sizeof *texels);
    if (!texels)
        return pf_error_set(err, PF_ERR_NOMEM, "BIH upload: %u nodes", bih->node_count);
    for (uint32_t i = 0; i < bih->node_count; i++) {
        texels[i][0] = pf_bih_float_to_bits(bih->nodes[i].clip[0]);
        texels[i][1] = pf_bih_float_to_bits(bih->nodes[i].clip[1]);
        texels[i][2] = bih->nodes[i].word;
        texels[i][3] = 0;
    }
    /* The three arrays in one submission (issue 44: a refit tree is uploaded so). */
    pf_vk_commands *cmds = NULL;
    pf_status status = pf_vk_commands_begin(gpu->ctx, &cmds, err);
    if (status == PF_OK)
        status = upload_array(gpu->ctx, cmds, texels, (uint64_t)bih->node_count * sizeof *texels,
                              "BIH nodes", &gpu->nodes, err);
    free(texels);
    if (status == PF_OK)
        status = upload_array(gpu->ctx, cmds, bih->vertices,
                              (uint64_t)bih->triangle_count * 3 * sizeof bih->vertices[0],
                              "BIH vertices", &gpu->vertices, err);
    if (status == PF_OK)
        status = upload_array(gpu->ctx, cmds, bih->triangle_index,
                              (uint64_t)bih->triangle_count * sizeof(uint32_t),
                              "BIH triangle index", &gpu->triangle_index, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    if (status != PF_OK) {
        release_tree(gpu);
        pf_error_prefix(err, "BIH upload (%u nodes, %u triangles)", bih->node_count,
                        bih->triangle_count);
        return status;
    }
    gpu->node_count = bih->node_count;
    gpu->triangle_count = bih->triangle_count;
    memcpy(gpu->bounds_min, bih->bounds_min, sizeof gpu->bounds_min);
    memcpy(gpu->bounds_max, bih->bounds_max, sizeof gpu->bounds_max);
    gpu->uploaded = 1;
    return PF_OK;
}

void pf_bih_gpu_adopt(pf_bih_gpu *gpu, const pf_bih *bih, pf_vk_buffer *tree[3])
{
    release_tree(gpu);
    gpu->nodes = tree[0];
    gpu->vertices = tree[1];
    gpu->triangle_index = tree[2];
    gpu->node_count = bih->node_count;
    gpu->triangle_count = bih->triangle_count;
    memcpy(gpu->bounds_min, bih->bounds_min, sizeof gpu->bounds_min);
    memcpy(gpu->bounds_max, bih->bounds_max, sizeof gpu->bounds_max);
    gpu->uploaded = 1;
}

void pf_bih_gpu_set_bounds(pf_bih_gpu *device, const float lo[3], const float hi[3])
{
    memcpy(device->bounds_min, lo, sizeof device->bounds_min);
    memcpy(device->bounds_max, hi, sizeof device->bounds_max);
}

pf_status pf_bih_gpu_download_nodes(pf_bih_gpu *device, pf_bih *bih, pf_error *err)
{
    if (!device || !bih || !device->uploaded || bih->nodes ||
        device->node_count != bih->node_count || device->triangle_count != bih->triangle_count)
        return pf_error_set(err, PF_ERR_INVALID,
                            "BIH nodes download: the device's tree is not the host copy's, or "
                            "the host has its nodes");
    uint32_t (*texels)[4] = malloc((size_t)bih->node_count * sizeof *texels);
    pf_bih_node *nodes = malloc((size_t)bih->node_count * sizeof *nodes);
    pf_status status = PF_OK;
    if (!texels || !nodes)
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH nodes download: %u nodes", bih->node_count);
    if (status == PF_OK)
        status = pf_vk_buffer_download(device->ctx, device->nodes, 0, texels,
                                       (uint64_t)bih->node_count * sizeof *texels, err);
    if (status == PF_OK)
        pf_bih_nodes_from_texels((const uint32_t(*)[4])texels, bih->node_count, nodes);
    free(texels);
    /* Walked on a copy of the statistics, so that a malformed tree leaves bih as it was. */
    pf_bih walked = *bih;
    walked.nodes = nodes;
    if (status == PF_OK)
        status = pf_bih_measure_walk(&walked, err);
    if (status != PF_OK) {
        free(nodes);
        pf_error_prefix(err, "BIH nodes download (%u nodes)", bih->node_count);
        return status;
    }
    *bih = walked;
    return PF_OK;
}

pf_status pf_bih_gpu_view_get(const pf_bih_gpu *gpu, pf_bih_gpu_view *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    if (!gpu || !gpu->uploaded)
        return pf_error_set(err, PF_ERR_INVALID, "BIH view: no BIH uploaded");
    out->nodes = gpu->nodes;
    out->vertices = gpu->vertices;
    out->triangle_index = gpu->triangle_index;
    out->node_count = gpu->node_count;
    out->triangle_count = gpu->triangle_count;
    memcpy(out->bounds_min, gpu->bounds_min, sizeof out->bounds_min);
    memcpy(out->bounds_max, gpu->bounds_max, sizeof out->bounds_max);
    return PF_OK;
}

/*
 * The raycast kernel of one kind (closest or any hit), made at its first use: the
 * renderer uploads a tree for its own kernels and never casts through this one, and
 * each pipeline costs a process ~25 ms on lavapipe even from a warm cache (its
 * SPIR-V translated to NIR), more on a cold one (bench/RESULTS.md, "Process start").
 */
static pf_status raycast_pipeline(pf_bih_gpu *gpu, int any_hit, pf_vk_pipeline **out,
                                  pf_error *err)
{
    pf_vk_pipeline **pipeline = any_hit ? &gpu->raycast_any : &gpu->raycast_closest;
    if (!*pipeline) {
        pf_vk_spec_constant kind = {RAYCAST_SPEC_ANY_HIT, any_hit ? 1u : 0u};
        pf_status status = pf_vk_pipeline_create_named(gpu->ctx, "bih_raycast", RAYCAST_BUFFERS,
                                                       sizeof(raycast_push), &kind, 1, pipeline,
                                                       err);
        if (status != PF_OK)
            return status;
    }
    *out = *pipeline;
    return PF_OK;
}

pf_status pf_bih_raycast(pf_bih_gpu *gpu, const pf_ray *rays, uint32_t ray_count, int any_hit,
                         pf_hit *hits, pf_error *err)
{
    if (!gpu || (ray_count > 0 && (!rays || !hits)))
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_raycast: NULL argument");
    if (!gpu->uploaded)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_raycast: no BIH uploaded");
    if (ray_count == 0)
        return PF_OK;
    pf_vk_context *ctx = gpu->ctx;
    uint32_t batch = ray_count < RAYCAST_BATCH_RAYS ? ray_count : RAYCAST_BATCH_RAYS;
    pf_vk_buffer *ray_buffer = NULL, *hit_buffer = NULL;
    const uint32_t zero[MIN_BUFFER_BYTES / sizeof(uint32_t)] = {0};
    uint32_t failures[MIN_BUFFER_BYTES / sizeof(uint32_t)] = {0};
    pf_vk_pipeline *pipeline = NULL;
    pf_status status = raycast_pipeline(gpu, any_hit, &pipeline, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)batch * sizeof(pf_ray), "BIH rays",
                                     &ray_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)batch * sizeof(pf_hit), "BIH hits",
                                     &hit_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_upload(ctx, gpu->failures, 0, zero, sizeof zero, err);
    for (uint32_t first = 0; status == PF_OK && first < ray_count; first += batch) {
        uint32_t count = ray_count - first < batch ? ray_count - first : batch;
        status = pf_vk_buffer_upload(ctx, ray_buffer, 0, rays + first,
                                     (uint64_t)count * sizeof(pf_ray), err);
        if (status != PF_OK)
            break;
        pf_vk_commands *cmds = NULL;
        status = pf_vk_commands_begin(ctx, &cmds, err);
        if (status != PF_OK)
            break;
        raycast_push push = {
            {gpu->bounds_min[0], gpu->bounds_min[1], gpu->bounds_min[2], 0.0f},
            {gpu->bounds_max[0], gpu->bounds_max[1], gpu->bounds_max[2], 0.0f},
            count, gpu->triangle_count, gpu->node_count, 0};
        pf_vk_buffer *buffers[RAYCAST_BUFFERS] = {gpu->nodes,  gpu->vertices, gpu->triangle_index,
                                                  ray_buffer, hit_buffer,    gpu->failures};
        status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, RAYCAST_BUFFERS, &push, sizeof push,
                                    (count + RAYCAST_GROUP_SIZE - 1) / RAYCAST_GROUP_SIZE, 1, 1,
                                    err);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, err);
        pf_vk_commands_destroy(cmds);
        if (status == PF_OK)
            status = pf_vk_buffer_download(ctx, hit_buffer, 0, hits + first,
                                           (uint64_t)count * sizeof(pf_hit), err);
    }
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, gpu->failures, 0, failures, sizeof failures, err);
    if (status == PF_OK && failures[0] > 0)
        status = pf_error_set(err, PF_ERR_LIMIT,
                              "%u rays failed their traversal: the %u-entry stack overflowed or the tree is malformed (their hits are misses)",
                              failures[0], PF_BIH_STACK_SIZE);
    release_buffer(ctx, &hit_buffer);
    release_buffer(ctx, &ray_buffer);
    if (status != PF_OK)
        pf_error_prefix(err, "BIH %s ray casting (%u rays, %u triangles)",
                        any_hit ? "any-hit" : "closest-hit", ray_count, gpu->triangle_count);
    return status;
}
