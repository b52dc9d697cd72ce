/*
 * core/render internals shared by its .c files: the renderer object, the GPU
 * copy of one frame's scene, and the std430 structs whose GLSL mirrors live in
 * shaders/common/scene_types.glsl (keep both in step).
 */
#ifndef PF_RENDER_INTERNAL_H
#define PF_RENDER_INTERNAL_H

#include "pf_render.h"

struct pf_renderer {
    pf_vk_context *ctx;
    /*
     * The current frame's BIH: the CPU tree (kept for reuse and refit across
     * frames), its GPU copy that the shading kernels traverse, and the GPU
     * builder (created on first use: only GPU builds need its pipelines).
     */
    pf_bih bih;
    int bih_valid;
    pf_bih_gpu *bih_gpu;
    pf_bih_gpu_builder *bih_builder;
    pf_vk_pipeline *raycast_closest; /* raycast_brute.comp, ANY_HIT = false */
    pf_vk_pipeline *raycast_any;     /* raycast_brute.comp, ANY_HIT = true */
    pf_vk_pipeline *render_direct;   /* render_direct.comp */
};

/* FrameParams in scene_types.glsl (std430, 144 bytes). */
typedef struct pf_frame_params {
    float camera_position[4]; /* w: half width of the image plane at distance 1 */
    float camera_forward[4];  /* w: half height of the image plane at distance 1 */
    float camera_right[4];    /* w: ray offset along the geometric normal */
    float camera_up[4];       /* w: unused */
    uint32_t width, height, samples_per_pixel, triangle_count;
    uint32_t light_count, emissive_count, seed_lo, seed_hi;
    uint32_t max_specular_depth, bih_node_count, padding[2];
    float bih_bounds_min[4];  /* the BIH root box (trace_bih's bounds); w unused */
    float bih_bounds_max[4];
} pf_frame_params;

/* EmissiveEntry in scene_types.glsl (16 bytes). */
typedef struct pf_emissive_entry {
    uint32_t triangle;
    float cdf;
    float pick_pdf;
    float area;
} pf_emissive_entry;

/* The GLSL mirrors assume these std430 sizes. */
_Static_assert(sizeof(pf_frame_params) == 144, "pf_frame_params must match FrameParams");
_Static_assert(sizeof(pf_emissive_entry) == 16, "pf_emissive_entry must match EmissiveEntry");
_Static_assert(sizeof(pf_material) == 32, "pf_material must match Material");
_Static_assert(sizeof(pf_light) == 64, "pf_light must match Light");
_Static_assert(sizeof(pf_ray) == 32, "pf_ray must match raycast_brute.comp's Ray");
_Static_assert(sizeof(pf_hit) == 16, "pf_hit must match raycast_brute.comp's HitRecord");

/*
 * One frame's scene on the GPU. Every buffer exists even when its array is
 * empty (one zeroed element), so descriptor sets are always complete; the
 * counts in pf_frame_params say how much of each is real.
 */
typedef struct pf_gpu_scene {
    pf_vk_buffer *vertices;          /* vec4 × 3 per triangle */
    pf_vk_buffer *normals;           /* vec4 × 3 per triangle */
    pf_vk_buffer *triangle_material; /* uint per triangle */
    pf_vk_buffer *materials;
    pf_vk_buffer *lights;
    pf_vk_buffer *emissive;          /* pf_emissive_entry table */
    uint32_t emissive_count;
} pf_gpu_scene;

/*
 * The `bih_build` stage: makes renderer->bih and its GPU copy hold a BIH over
 * frame's triangles (built on the device, or on the CPU where the device is
 * the CPU itself; see frame_bih.c) and appends the stage row to report
 * (which may be NULL).
 */
pf_status pf_render_prepare_bih(pf_renderer *renderer, const pf_scene_frame *frame,
                                pf_frame_report *report, pf_error *err);

/* Uploads only the vertex buffer (all the ray-casting oracle needs) when full is 0. */
pf_status pf_gpu_scene_upload(pf_vk_context *ctx, const pf_scene_frame *frame, int full,
                              pf_gpu_scene *out, pf_error *err);
void pf_gpu_scene_release(pf_vk_context *ctx, pf_gpu_scene *scene);

/*
 * Builds the emissive-triangle picking table (weight = area × luminance of the
 * emitted radiance, front face only). *entries is malloc'ed (NULL when none).
 */
pf_status pf_emissive_table_build(const pf_scene_frame *frame, pf_emissive_entry **entries,
                                  uint32_t *count, pf_error *err);

/*
 * pf_raycast_brute_force with a choice of variant: any_hit = 1 reports some
 * hit in (tmin, tmax) (shadow rays) instead of the closest. Candidate for
 * pf_render.h; the BIH's any-hit traversal will be tested against it.
 */
pf_status pf_raycast_brute(pf_renderer *renderer, const pf_scene_frame *frame,
                           const pf_ray *rays, uint32_t ray_count, int any_hit, pf_hit *hits,
                           pf_error *err);

/* Destroys *buffer if there is one and clears the pointer. */
void pf_render_buffer_release(pf_vk_context *ctx, pf_vk_buffer **buffer);

/* Creates a buffer of at least min_bytes and uploads size bytes of data (may be 0). */
pf_status pf_render_buffer_with_data(pf_vk_context *ctx, const char *label, const void *data,
                                     uint64_t size, uint64_t min_bytes, pf_vk_buffer **out,
                                     pf_error *err);

#endif
