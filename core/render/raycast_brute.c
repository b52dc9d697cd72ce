/*
 * The ray-casting oracle: pf_raycast_brute_force (every ray against every
 * triangle on the GPU, shaders/raycast_brute.comp) and its own oracle, the
 * same watertight test on the CPU.
 */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/*
 * Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1),
 * 2013, operation for operation as shaders/common/ray_triangle.glsl (same
 * axis choice on ties, same evaluation order), so GPU and CPU agree bit for
 * bit wherever the GPU's division is correctly rounded. Like the shader, it
 * skips the paper's double-precision recomputation of edge values that are
 * exactly 0 and counts 0 as inside: rays through a shared edge or vertex hit
 * at least one triangle (see ray_triangle.glsl for why). ISO C mode keeps GCC
 * from contracting a*b - c into an FMA (-ffp-contract=off), as `precise` does
 * in GLSL.
 */
/* ray_triangle.glsl: height within 16 ulps of the vertex coordinates. */
#define DEGENERATE_BOUND2 (2.0f * (16.0f / 16777216.0f) * (16.0f / 16777216.0f))

/* Same test, operation for operation, as triangle_is_degenerate in ray_triangle.glsl (why: see there). */
static int triangle_is_degenerate(const float v0[3], const float v1[3], const float v2[3])
{
    float largest = 0.0f;
    for (int k = 0; k < 3; k++)
        largest = fmaxf(largest, fmaxf(fabsf(v0[k]), fmaxf(fabsf(v1[k]), fabsf(v2[k]))));
    if (largest == 0.0f)
        return 1;
    int exponent;
    frexpf(largest, &exponent);
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = ldexpf(v1[k] - v0[k], -exponent);
        e2[k] = ldexpf(v2[k] - v0[k], -exponent);
    }
    float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                  e1[0] * e2[1] - e1[1] * e2[0]};
    float n2 = (n[0] * n[0] + n[1] * n[1]) + n[2] * n[2];
    float edges2 = ((e1[0] * e1[0] + e1[1] * e1[1]) + e1[2] * e1[2]) +
                   ((e2[0] * e2[0] + e2[1] * e2[1]) + e2[2] * e2[2]);
    return !(n2 > DEGENERATE_BOUND2 * edges2);
}

int pf_ray_triangle_watertight(const float origin[3], const float direction[3],
                               const float v0[3], const float v1[3], const float v2[3],
                               float tmin, float tmax, float *t, float *u, float *v)
{
    float ax_abs = fabsf(direction[0]), ay_abs = fabsf(direction[1]), az_abs = fabsf(direction[2]);
    int kz = ax_abs > ay_abs ? (ax_abs > az_abs ? 0 : 2) : (ay_abs > az_abs ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (direction[kz] < 0.0f) {
        int swap_axis = kx;
        kx = ky;
        ky = swap_axis;
    }
    if (direction[kz] == 0.0f)
        return 0;
    float dz = direction[kz];
    float sx = direction[kx] / dz;
    float sy = direction[ky] / dz;
    float sz = 1.0f / dz;

    float a[3], b[3], c[3];
    for (int i = 0; i < 3; i++) {
        a[i] = v0[i] - origin[i];
        b[i] = v1[i] - origin[i];
        c[i] = v2[i] - origin[i];
    }
    float ax = a[kx] - sx * a[kz];
    float ay = a[ky] - sy * a[kz];
    float bx = b[kx] - sx * b[kz];
    float by = b[ky] - sy * b[kz];
    float cx = c[kx] - sx * c[kz];
    float cy = c[ky] - sy * c[kz];
    float eu = cx * by - cy * bx;
    float ev = ax * cy - ay * cx;
    float ew = bx * ay - by * ax;
    if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f))
        return 0;
    float det = (eu + ev) + ew;
    if (det == 0.0f)
        return 0;
    float az = sz * a[kz];
    float bz = sz * b[kz];
    float cz = sz * c[kz];
    float scaled_t = (eu * az + ev * bz) + ew * cz;
    float rcp_det = 1.0f / det;
    float hit_t = scaled_t * rcp_det;
    if (!(hit_t > tmin && hit_t < tmax))
        return 0;
    if (triangle_is_degenerate(v0, v1, v2))
        return 0;
    *t = hit_t;
    *u = ev * rcp_det;
    *v = ew * rcp_det;
    return 1;
}

/* Workgroup size of raycast_brute.comp. */
#define RAYCAST_GROUP_SIZE 64u
/*
 * Rays per dispatch: keeps the ray buffer (32 B each) at 32 MiB, far below
 * lavapipe's 128 MiB maxStorageBufferRange, and the group count (16384) below
 * the 65535 every device allows.
 */
#define RAYCAST_BATCH_RAYS (1u << 20)

typedef struct raycast_push {
    uint32_t ray_count;
    uint32_t triangle_count;
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
    pf_status status = pf_gpu_scene_upload(ctx, frame, 0, &scene, err);
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
        raycast_push push = {count, frame->triangle_count};
        pf_vk_buffer *buffers[] = {scene.vertices, ray_buffer, hit_buffer};
        status = pf_vk_cmd_dispatch(cmds, any_hit ? renderer->raycast_any : renderer->raycast_closest, buffers, 3, &push,
                                    sizeof push, (count + RAYCAST_GROUP_SIZE - 1) / RAYCAST_GROUP_SIZE,
                                    1, 1, err);
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
