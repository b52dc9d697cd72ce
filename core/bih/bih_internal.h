/*
 * core/bih internals shared by its .c files: the leaf fields' bit casts, the
 * node word decoding and the traversals' float rules (GLSL mirror in
 * shaders/common/bih_traverse.glsl).
 */
#ifndef PF_BIH_INTERNAL_H
#define PF_BIH_INTERNAL_H

#include "pf_bih.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* A leaf keeps uint32 bits in its float fields (see the node format in pf_bih.h). */
static inline float pf_bih_bits_to_float(uint32_t bits)
{
    float value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static inline uint32_t pf_bih_float_to_bits(float value)
{
    uint32_t bits;
    memcpy(&bits, &value, sizeof bits);
    return bits;
}

static inline int pf_bih_is_leaf(const pf_bih_node *node)
{
    return (node->word & 3u) == PF_BIH_LEAF;
}

static inline uint32_t pf_bih_leaf_first(const pf_bih_node *node)
{
    return pf_bih_float_to_bits(node->clip[0]);
}

static inline uint32_t pf_bih_leaf_count(const pf_bih_node *node)
{
    return pf_bih_float_to_bits(node->clip[1]);
}

static inline uint32_t pf_bih_axis(const pf_bih_node *node)
{
    return node->word & 3u;
}

static inline uint32_t pf_bih_first_child(const pf_bih_node *node)
{
    return node->word >> 2;
}

/*
 * An axis-aligned box, for the build, the check, the refit and the wide view.
 * The empty box (lo = +inf, hi = -inf) merges as nothing: boxes merge side
 * by side, never corner by corner.
 */
typedef struct pf_bih_box {
    float lo[3], hi[3];
} pf_bih_box;

static inline pf_bih_box pf_bih_box_empty(void)
{
    return (pf_bih_box){{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
}

static inline int pf_bih_box_is_empty(const pf_bih_box *box)
{
    return !(box->lo[0] <= box->hi[0]);
}

/*
 * box grown to hold [lo, hi] (a point: lo = hi). Written out per axis: GCC -O2
 * kept small per-axis loops as loops over arrays in memory, and the build's hot
 * loops merge once or three times per triangle per level.
 */
static inline void pf_bih_box_merge(pf_bih_box *box, const float lo[3], const float hi[3])
{
    box->lo[0] = lo[0] < box->lo[0] ? lo[0] : box->lo[0];
    box->lo[1] = lo[1] < box->lo[1] ? lo[1] : box->lo[1];
    box->lo[2] = lo[2] < box->lo[2] ? lo[2] : box->lo[2];
    box->hi[0] = hi[0] > box->hi[0] ? hi[0] : box->hi[0];
    box->hi[1] = hi[1] > box->hi[1] ? hi[1] : box->hi[1];
    box->hi[2] = hi[2] > box->hi[2] ? hi[2] : box->hi[2];
}

/* Half the surface area; an empty axis counts as 0 wide. */
static inline float pf_bih_box_half_area(const pf_bih_box *box)
{
    float ex = box->hi[0] > box->lo[0] ? box->hi[0] - box->lo[0] : 0.0f;
    float ey = box->hi[1] > box->lo[1] ? box->hi[1] - box->lo[1] : 0.0f;
    float ez = box->hi[2] > box->lo[2] ? box->hi[2] - box->lo[2] : 0.0f;
    return ex * ey + ey * ez + ez * ex;
}

/* What every traversal reports for a ray that hits nothing (pf_bih.h: t = -1, PF_NO_HIT). */
#define PF_BIH_MISS ((pf_hit){-1.0f, PF_NO_HIT, 0.0f, 0.0f})

/*
 * min/max by comparison, inlined (fminf/fmaxf are libm calls at -O2): the
 * second argument where it is smaller (larger). No NaN reaches them: a
 * parallel axis never divides, and clip values are finite or ±inf against a
 * finite origin.
 */
static inline float pf_bih_min(float a, float b)
{
    return b < a ? b : a;
}

static inline float pf_bih_max(float a, float b)
{
    return b > a ? b : a;
}

/* ray_triangle.glsl: edge values and hit distances below this (2^-40) are evaluated again. */
#define PF_BIH_WATERTIGHT_RESCALE_BELOW 9.094947017729282e-13f

/* 2γ(3) for ε = 2^-24: 6ε / (1 − 3ε) (Ize 2013; bih_cpu_traverse.c). */
#define PF_BIH_TWO_GAMMA3 (6.0f * 0x1p-24f / (1.0f - 3.0f * 0x1p-24f))

/* A far distance widened by 2γ(3)·|t|; ±inf (and NaN) kept as they are, as bih_widen_far does. */
static inline float pf_bih_widen_far(float t)
{
    float widened = t + fabsf(t) * PF_BIH_TWO_GAMMA3;
    return t >= -FLT_MAX ? widened : t;
}

/*
 * The next float above a finite t (for letting an equal t through a strict
 * test), by its bits as in the GLSL include: nextafterf is a libm call.
 */
static inline float pf_bih_next_up(float t)
{
    if (!isfinite(t))
        return t;
    if (t == 0.0f)
        return pf_bih_bits_to_float(1u);
    uint32_t bits = pf_bih_float_to_bits(t);
    return pf_bih_bits_to_float(t > 0.0f ? bits + 1u : bits - 1u);
}

/*
 * Frame triangle t's vertices into leaf (its 3 leaf-order vertices), w = 0:
 * the build and the refit copy every leaf triangle so, then set the
 * degenerate flags with pf_bih_flag_degenerate (pf_bih.h), which
 * pf_bih_check expects.
 */
static inline void pf_bih_copy_leaf_triangle(float (*leaf)[4], const pf_scene_frame *frame,
                                             uint32_t t)
{
    for (int v = 0; v < 3; v++) {
        memcpy(leaf[v], frame->vertices[3 * (size_t)t + v], 3 * sizeof(float));
        leaf[v][3] = 0.0f;
    }
}

/*
 * frame's triangles into bih's leaf order (bih->vertices from bih->triangle_index, every
 * index below frame's count), with their degenerate flags: the refit's gather, and a kept
 * GPU build's copy of what the device holds (bih_refit.c).
 */
void pf_bih_gather_leaf_vertices(pf_bih *bih, const pf_scene_frame *frame);

/* count nodes from the device's 16-byte texels (clip0 bits, clip1 bits, word, 0), as
 * pf_bih_gpu_upload writes them: the GPU build's readback and the nodes' download. */
static inline void pf_bih_nodes_from_texels(const uint32_t (*texels)[4], uint32_t count,
                                            pf_bih_node *nodes)
{
    for (uint32_t i = 0; i < count; i++)
        nodes[i] = (pf_bih_node){{pf_bih_bits_to_float(texels[i][0]),
                                  pf_bih_bits_to_float(texels[i][1])},
                                 texels[i][2]};
}

/*
 * The refit's first half (pf_bih_refit without the bounds): frame checked as
 * pf_bih_refit checks it (PF_ERR_INVALID, the tree unchanged), then its
 * triangles gathered into the leaf order with their degenerate flags. The clip
 * values and the root box are left as they were: pf_bih_refit_bounds, or the
 * device's refit (bih_gpu_refit.c), fits them.
 */
pf_status pf_bih_refit_vertices(pf_bih *bih, const pf_scene_frame *frame, pf_error *err);

/* The GPU builder: the build's passes (bih_gpu_build.c) and the refit's
 * (bih_gpu_refit.c), the latter made at the first refit. */
#define PF_BIH_BUILD_PIPELINES 7
#define PF_BIH_REFIT_PIPELINES 4
struct pf_bih_gpu_builder {
    pf_vk_context *ctx;
    pf_vk_pipeline *pipelines[PF_BIH_BUILD_PIPELINES];
    pf_vk_pipeline *refit[PF_BIH_REFIT_PIPELINES];
};

/*
 * A tree fitted on the device (bih_gpu_refit.c): pf_bih_fit_check (PF_ERR_LIMIT where the
 * device cannot hold the boxes; the kernels made), pf_bih_fit_create (the buffers, for
 * node_bound nodes), then pf_bih_fit_record: the passes of pf_bih_refit_gpu recorded into
 * cmds over the node texels and leaf-order vertices of a tree of node_bound nodes (or,
 * with kept, 1 + 2 × kept[kept_index]: a build's count on the device, node_bound its
 * bound). levels: the climb's rounds, the tree's depth + 1; 0 skips the bounds pass where
 * the boxes buffer holds every node's box already (the build's collapse wrote them). After
 * the submission fit holds the SAH cost, the root box and the statistics; release its
 * buffers then.
 */
enum {
    PF_BIH_FIT_PARENTS,
    PF_BIH_FIT_ARRIVALS,
    PF_BIH_FIT_BOXES,
    PF_BIH_FIT_PARTIALS,
    PF_BIH_FIT_COST,
    PF_BIH_FIT_STATS,
    PF_BIH_FIT_BUFFERS
};
typedef struct pf_bih_fit {
    pf_vk_buffer *buffers[PF_BIH_FIT_BUFFERS];
    uint32_t node_bound;
    int stamps[PF_BIH_REFIT_PASSES + 1];
    float cost;
    float root[8];       /* lo xyz, 0, hi xyz, 0 */
    uint32_t stats[4];   /* depth (> PF_BIH_STACK_SIZE: deeper), leaves, largest leaf, nodes */
} pf_bih_fit;
pf_status pf_bih_fit_check(pf_bih_gpu_builder *builder, uint32_t node_bound, pf_error *err);
pf_status pf_bih_fit_create(pf_bih_gpu_builder *builder, uint32_t node_bound, pf_bih_fit *fit,
                            pf_error *err);
pf_status pf_bih_fit_record(pf_bih_gpu_builder *builder, pf_vk_commands *cmds,
                            pf_vk_buffer *nodes, pf_vk_buffer *vertices, uint32_t node_bound,
                            pf_vk_buffer *kept, uint32_t kept_index, uint32_t levels,
                            pf_bih_fit *fit, pf_error *err);
void pf_bih_fit_times(const pf_bih_fit *fit, const pf_vk_commands *cmds,
                      double pass_ms[PF_BIH_REFIT_PASSES], double *gpu_ms);
void pf_bih_fit_release(pf_vk_context *ctx, pf_bih_fit *fit);

/*
 * Walks a downloaded tree once (bih_gpu_build.c): every child index in range, every node
 * reached once (PF_ERR_INTERNAL otherwise, so the walk ends on any input), and the depth
 * and leaf statistics set from it.
 */
pf_status pf_bih_measure_walk(pf_bih *bih, pf_error *err);

/* The root box of the tree device holds, after the device changed it (a refit). */
void pf_bih_gpu_set_bounds(pf_bih_gpu *device, const float lo[3], const float hi[3]);

/*
 * The one-ray traversal in parts, for bih_cpu_packet_body.h to hand a ray left
 * alone in its packet to: a ray's per-ray setup; its interval in the scene
 * box (0: it misses the box); and the walk of the subtree at node from the
 * interval [t_near, t_far], with the ray's best hit so far in *closest and
 * *hit (both updated). pf_bih_trace_cpu is these three from the root.
 */
typedef struct pf_bih_ray {
    float inv[3];
    int parallel[3];
    pf_ray_shear shear;
} pf_bih_ray;

/*
 * The watertight test's per-ray part (pf_ray_triangle_sheared's pf_ray_shear,
 * ray_triangle.glsl's RayShear): inline here because the traversals set it up once a ray,
 * and as a call into another file it was ~3 % of a wavefront frame's host time.
 */
static inline void pf_bih_shear_setup(const float direction[3], pf_ray_shear *s)
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
    s->kx = kx;
    s->ky = ky;
    s->kz = kz;
    s->valid = direction[kz] != 0.0f;
    float dz = direction[kz];
    s->sx = s->valid ? direction[kx] / dz : 0.0f;
    s->sy = s->valid ? direction[ky] / dz : 0.0f;
    s->sz = s->valid ? 1.0f / dz : 0.0f;
}

static inline void pf_bih_ray_prepare(const pf_ray *ray, pf_bih_ray *prepared)
{
    for (int k = 0; k < 3; k++) {
        prepared->parallel[k] = !(fabsf(ray->direction[k]) >= FLT_MIN);
        prepared->inv[k] = prepared->parallel[k] ? 0.0f : 1.0f / ray->direction[k];
    }
    pf_bih_shear_setup(ray->direction, &prepared->shear);
}
int pf_bih_ray_enter(const pf_bih *bih, const pf_ray *ray, const pf_bih_ray *prepared,
                     float *t_near, float *t_far);
pf_status pf_bih_walk(const pf_bih *bih, const pf_ray *ray, const pf_bih_ray *prepared,
                      uint32_t node, float t_near, float t_far, int any_hit, float *closest,
                      pf_hit *hit, pf_bih_trace_counts *counts, pf_error *err);

/*
 * The packet traversal (pf_bih_trace_cpu_packet's contract, count at most
 * PF_BIH_PACKET_RAYS, checked by the caller) at a vector width: 4 lanes a
 * vector (bih_cpu_packet_sse.c) and 8 (bih_cpu_packet_avx2.c, -mavx2).
 * pf_bih_packet_tracer gives the one of that width when it was built and the
 * CPU runs it, else NULL; pf_bih_trace_cpu_packet takes the widest. Both
 * give the same answers, bit for bit; the tests run each.
 */
typedef pf_status (*pf_bih_packet_trace_fn)(const pf_bih *bih, const pf_ray *rays,
                                            uint32_t count, int any_hit, pf_hit *hits,
                                            pf_error *err);
pf_status pf_bih_trace_packet_4(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                int any_hit, pf_hit *hits, pf_error *err);
pf_status pf_bih_trace_packet_8(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                int any_hit, pf_hit *hits, pf_error *err);
pf_bih_packet_trace_fn pf_bih_packet_tracer(uint32_t width);

/*
 * A block of at least 64-byte alignment for an array of many megabytes,
 * on transparent huge pages where the kernel offers them (bih_cpu_build.c
 * says why); free() frees it. NULL when out of memory.
 */
void *pf_bih_alloc_large(size_t bytes);

/*
 * The wide view's node (pf_bih.h, pf_bih_wide): up to 8 children, each with
 * the box of its triangles, stored axis by axis so one AVX load reads one
 * bound of all 8. child[i] is a wide node's index, or PF_BIH_WIDE_LEAF | the
 * first of the BIH leaf's blocks (pf_bih_wide_block) with count[i] triangles.
 * An unused slot has the empty box (lo = +inf, hi = -inf), which no ray
 * enters.
 */
#define PF_BIH_WIDE_SLOTS 8u
#define PF_BIH_WIDE_LEAF 0x80000000u
struct pf_bih_wide_node {
    _Alignas(64) float lo[3][PF_BIH_WIDE_SLOTS];
    float hi[3][PF_BIH_WIDE_SLOTS];
    uint32_t child[PF_BIH_WIDE_SLOTS];
    uint32_t count[PF_BIH_WIDE_SLOTS];
};

/*
 * Up to 4 consecutive triangles of one leaf, lane by lane, so one ray's
 * watertight test runs on 4 of them at once: v[vertex][axis][lane], the
 * leaf-order position of each lane's triangle (PF_NO_HIT past the leaf's
 * end), and the lanes to test (not degenerate, not past the end).
 */
#define PF_BIH_WIDE_LANES 4u
struct pf_bih_wide_block {
    _Alignas(16) float v[3][3][PF_BIH_WIDE_LANES];
    uint32_t position[PF_BIH_WIDE_LANES];
    uint32_t live;
};

/* The wide traversal with AVX2 (bih_wide_traverse_avx2.c), where it was built. */
pf_status pf_bih_wide_trace_avx2(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                                 uint32_t count, int any_hit, pf_hit *hits, pf_error *err);

/* device takes the build's device buffers (nodes as 16-byte texels, leaf-order vertices,
 * triangle index; bih_gpu_build.c) for bih, as pf_bih_gpu_upload(device, bih) would have
 * made them, releasing the tree it held. */
void pf_bih_gpu_adopt(pf_bih_gpu *device, const pf_bih *bih, pf_vk_buffer *tree[3]);

#endif
