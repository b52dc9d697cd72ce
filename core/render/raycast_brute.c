/*
 * The ray-casting oracle: pf_raycast_brute_force (every ray against every
 * triangle on the GPU, shaders/raycast_brute.comp). Its own oracle, the same
 * watertight test on the CPU, is pf_ray_triangle_watertight (core/bih).
 */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Workgroup size of raycast_brute.comp. */
#define RAYCAST_GROUP_SIZE 64u
/*
 * Rays per dispatch: keeps the ray buffer (32 B each) at 32 MiB, far below
 * lavapipe's 128 MiB maxStorageBufferRange, and the group count (16384) below
 * the 65535 every device allows.
 */
#define RAYCAST_BATCH_RAYS (1u << 20)
/*
 * Triangles per dispatch. llvmpipe (Mesa 22.3) silently ends an invocation's
 * loops after 65,535 iterations in all, and trace_subgroup runs about
 * (1 + 1/subgroup size) iterations per triangle (≤ 18,432 here with
 * lavapipe's 8 lanes), so one dispatch over every triangle ignored all past
 * ~58k. Each dispatch carries the rays' answers over the earlier ranges in
 * the hit buffer, so the result is the same as one pass.
 */
#define RAYCAST_CHUNK_TRIANGLES 16384u

/* raycast_brute.comp's Push (16 bytes, RAYCAST_PUSH_BYTES in renderer.c). */
typedef struct raycast_push {
    uint32_t ray_count;
    uint32_t triangle_begin;
    uint32_t triangle_end;
    uint32_t carry;
} raycast_push;

pf_status pf_raycast_brute_force(pf_renderer *renderer, const pf_scene_frame *frame,
                                 const pf_ray *rays, uint32_t ray_count, pf_hit *hits,
                                 pf_error *err)
{
    return pf_raycast_brute(renderer, frame, rays, ray_count, 0, hits, err);
}

pf_status pf_raycast_brute(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_ray *rays, uint32_t ray_count, int any_hit, pf_hit *hits,
                           pf_error *err)
{
    if (!renderer || !frame || (ray_count > 0 && (!rays || !hits)))
        return pf_error_set(err, PF_ERR_INVALID, "pf_raycast_brute_force: NULL argument");
    if (ray_count == 0)
        return PF_OK;
    pf_vk_context *ctx = renderer->ctx;
    pf_gpu_scene scene;
    pf_status status = pf_gpu_scene_upload(ctx, frame, 0, NULL, &scene, err);
    if (status != PF_OK)
        return status;
    uint32_t batch = ray_count < RAYCAST_BATCH_RAYS ? ray_count : RAYCAST_BATCH_RAYS;
    pf_vk_buffer *ray_buffer = NULL, *hit_buffer = NULL;
    status = pf_vk_buffer_create(ctx, (uint64_t)batch * sizeof(pf_ray), "raycast rays",
                                 &ray_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, (uint64_t)batch * sizeof(pf_hit), "raycast hits",
                                     &hit_buffer, err);
    for (uint32_t first = 0; status == PF_OK && first < ray_count; first += batch) {
        uint32_t count = ray_count - first < batch ? ray_count - first : batch;
        status = pf_vk_buffer_upload(ctx, ray_buffer, 0, rays + first, (uint64_t)count * sizeof(pf_ray),
                                     err);
        if (status != PF_OK)
            break;
        pf_vk_commands *cmds = NULL;
        status = pf_vk_commands_begin(ctx, &cmds, err);
        if (status != PF_OK)
            break;
        pf_vk_buffer *buffers[] = {scene.vertices, ray_buffer, hit_buffer};
        pf_vk_pipeline *pipeline = NULL;
        status = pf_renderer_pipeline(
            renderer, any_hit ? PF_PIPELINE_RAYCAST_ANY : PF_PIPELINE_RAYCAST_CLOSEST, &pipeline,
            err);
        if (status != PF_OK) {
            pf_vk_commands_destroy(cmds);
            break;
        }
        /* One dispatch even for zero triangles: it writes the misses. */
        uint32_t begin = 0;
        do {
            uint32_t end = frame->triangle_count - begin > RAYCAST_CHUNK_TRIANGLES
                               ? begin + RAYCAST_CHUNK_TRIANGLES
                               : frame->triangle_count;
            raycast_push push = {count, begin, end, begin > 0};
            if (begin > 0)
                pf_vk_cmd_barrier(cmds);
            status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, 3, &push, sizeof push,
                                        (count + RAYCAST_GROUP_SIZE - 1) / RAYCAST_GROUP_SIZE, 1,
                                        1, err);
            begin = end;
        } while (status == PF_OK && begin < frame->triangle_count);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, err);
        pf_vk_commands_destroy(cmds);
        if (status == PF_OK)
            status = pf_vk_buffer_download(ctx, hit_buffer, 0, hits + first,
                                           (uint64_t)count * sizeof(pf_hit), err);
    }
    pf_render_buffer_release(ctx, &hit_buffer);
    pf_render_buffer_release(ctx, &ray_buffer);
    pf_gpu_scene_release(ctx, &scene);
    if (status != PF_OK)
        pf_error_prefix(err, "brute-force %s ray casting (%u rays, %u triangles)",
                        any_hit ? "any-hit" : "closest-hit", ray_count,
                        frame->triangle_count);
    return status;
}
