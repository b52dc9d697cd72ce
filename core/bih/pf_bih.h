/*
 * core/bih: the Bounding Interval Hierarchy (Wächter & Keller, "Instant Ray
 * Tracing: The Bounding Interval Hierarchy", EGSR 2006) over one frame's
 * triangles — a CPU reference builder, its invariants checker and SAH cost
 * report, a CPU traversal that defines the algorithm, and the GPU copy that
 * shaders/common/bih_traverse.glsl traverses (pf_bih_raycast).
 *
 * Node format (12 bytes; on the device, pf_bih_gpu_upload pads each node to a
 * 16-byte texel (clip[0], clip[1], word, 0) that shaders/common/bih_traverse.glsl
 * reads in one fetch):
 *   inner node: word = (first_child << 2) | axis (axis 0, 1, 2);
 *               the children are nodes first_child (left) and first_child + 1
 *               (right); clip[0] = the largest coordinate along axis of any
 *               triangle in the left subtree, clip[1] = the smallest of any
 *               triangle in the right subtree (the two may overlap).
 *   leaf:       word = PF_BIH_LEAF (low two bits 3, rest 0); the float fields
 *               hold raw uint32 bits: clip[0] = first triangle (leaf order),
 *               clip[1] = triangle count. Count 0 only for an empty tree's
 *               root and for the empty child of an empty-space cut (its
 *               parent's clip value on its side is -inf for a left child,
 *               +inf for a right one, so the child bounds nothing).
 * Node 0 is the root. Triangles are stored in leaf order (each leaf's range is
 * contiguous); triangle_index maps a leaf-order position to the frame's index.
 * The leaf-order vertices are the frame's, with w = 0 except the first
 * vertex of a degenerate triangle (pf_triangle_is_degenerate), whose w is
 * PF_BIH_DEGENERATE_W: a traversal skips it without testing the ray, where
 * the watertight test would evaluate the same ray-independent check at
 * every candidate hit (on lavapipe, where both sides of a branch run, at
 * every triangle test).
 *
 * Rays and hits are pf_ray / pf_hit (below): t = -1 and triangle =
 * PF_NO_HIT on a miss, triangle is the frame's (original) index. A closest-hit
 * query returns the same hit as the brute-force oracle: smallest t, and on an
 * exactly equal t the lowest original index.
 */
#ifndef PF_BIH_H
#define PF_BIH_H

#include "pf_common.h"
#include "pf_scene.h"
#include "pf_vk.h"

#include <stdint.h>

/*
 * A ray: origin xyz + tmin, direction xyz + tmax (std430 mirrors Ray and
 * HitRecord in shaders/common/ray_types.glsl). A hit: t (or -1 on a miss), the frame's
 * triangle index (PF_NO_HIT on a miss), barycentrics u, v.
 */
typedef struct pf_ray {
    float origin[3];
    float tmin;
    float direction[3];
    float tmax;
} pf_ray;

typedef struct pf_hit {
    float t;
    uint32_t triangle;
    float u, v;
} pf_hit;

#define PF_NO_HIT 0xFFFFFFFFu

/*
 * The watertight ray/triangle test (Woop, Benthin & Wald 2013) on the CPU,
 * operation for operation as shaders/common/ray_triangle.glsl. 1 and t, u, v
 * on a hit in (tmin, tmax) at t >= FLT_MIN; degenerate triangles never hit.
 * The answer does not depend on whether the CPU flushes subnormals (edge
 * values that could hide one are evaluated again at a scale without them).
 */
int pf_ray_triangle_watertight(const float origin[3], const float direction[3],
                               const float v0[3], const float v1[3], const float v2[3],
                               float tmin, float tmax, float *t, float *u, float *v);

/* The test in two parts, for a traversal: the ray's permutation and shear once per ray,
 * and the test of one triangle without the degeneracy check, which the BIH answers once per
 * triangle at build time (pf_bih.vertices' w). */
typedef struct pf_ray_shear {
    int kx, ky, kz;
    float sx, sy, sz;
    int valid; /* 0 for a zero direction: nothing hits */
} pf_ray_shear;
int pf_ray_triangle_sheared(const float origin[3], const pf_ray_shear *s, const float v0[3],
                            const float v1[3], const float v2[3], float tmin, float tmax, float *t,
                            float *u, float *v);
/* A zero-area or collinear triangle, within rounding of its coordinates (ray_triangle.glsl). */
int pf_triangle_is_degenerate(const float v0[3], const float v1[3], const float v2[3]);

/* The w of a degenerate triangle's first leaf-order vertex (pf_bih.vertices). */
#define PF_BIH_DEGENERATE_W 1.0f
/*
 * Sets the first vertex's w of each of count triangles in leaf format (3 float[4]
 * each) to PF_BIH_DEGENERATE_W where pf_triangle_is_degenerate, else 0; 4 at a time.
 */
void pf_bih_flag_degenerate(float (*vertices)[4], uint32_t count);

/* Traversal stack entries (GPU and CPU); the build bounds the depth by it. */

#define PF_BIH_STACK_SIZE 64u
#define PF_BIH_LEAF 3u
/* Wächter & Keller use leaves of a few triangles; 4 keeps leaves one cache line of vertices. */
#define PF_BIH_DEFAULT_LEAF_SIZE 4u
/* Child index field: 30 bits of the node word. */
#define PF_BIH_MAX_NODES (1u << 30)

typedef struct pf_bih_node {
    float clip[2];
    uint32_t word;
} pf_bih_node;

typedef struct pf_bih {
    uint32_t node_count;
    pf_bih_node *nodes;
    uint32_t triangle_count;
    float (*vertices)[4];        /* 3 per triangle, leaf order; w: PF_BIH_DEGENERATE_W */
    uint32_t *triangle_index;    /* leaf order -> frame triangle index */
    float bounds_min[3];         /* of all triangles: the root's box */
    float bounds_max[3];
    uint32_t depth;              /* inner levels on the longest root-to-leaf path */
    uint32_t leaf_count;
    uint32_t largest_leaf;       /* triangles in the biggest leaf */
} pf_bih;

/* pf_bih_build_options.heuristic (see pf_bih_build_cpu). */
#define PF_BIH_HEURISTIC_GLOBAL 0u   /* Wächter & Keller's global heuristic: the reference */
#define PF_BIH_HEURISTIC_SAH 1u      /* binned SAH splits + empty-space cuts: faster traversal */
/* The build budget is 2 threads; more are refused (a fixed-size table). */
#define PF_BIH_DEFAULT_BUILD_THREADS 2u
#define PF_BIH_MAX_BUILD_THREADS 16u

typedef struct pf_bih_build_options {
    uint32_t max_leaf_size;      /* K: 0 = PF_BIH_DEFAULT_LEAF_SIZE */
    uint32_t max_depth;          /* 0 = PF_BIH_STACK_SIZE; more is refused */
    uint32_t heuristic;          /* PF_BIH_HEURISTIC_*: 0 = GLOBAL */
    uint32_t thread_count;       /* CPU build threads: 0 = PF_BIH_DEFAULT_BUILD_THREADS */
} pf_bih_build_options;

typedef struct pf_bih_quality {
    double sah_cost;             /* see pf_bih_quality_measure */
    uint32_t inner_count, leaf_count, depth, largest_leaf;
    double mean_leaf_size;
    uint32_t bytes_per_node;
    double clip_sah_cost;        /* the same sum with A(n) from the clip planes alone */
} pf_bih_quality;

/*
 * Builds a BIH over frame's triangles on the CPU, top down. With the default
 * heuristic (PF_BIH_HEURISTIC_GLOBAL), Wächter &
 * Keller's global heuristic: a node's candidate box (the root's is the scene
 * box) is split in the middle of its longest axis; triangles go left or right
 * by the centre of their bounding box; when all fall on one side no node is
 * made and the candidate box is halved towards them (so split planes stay on
 * the global grid). When the candidate box can no longer separate them (equal
 * centres) or the remaining depth is only ~log2(count / K) levels, the node
 * splits at the median of the centres instead, so the depth stays within
 * max_depth and leaves hold at most K = max_leaf_size triangles (unless
 * max_depth is too small for that: then the deepest leaves hold the rest).
 * Child boxes: the halves of the candidate box (global split) or the
 * children's centre bounds (median split).
 * With PF_BIH_HEURISTIC_SAH: a node whose clip region (the scene box cut by
 * its ancestors' planes) leaves enough empty space around its triangles' box
 * first gets empty-space cuts (Wächter & Keller §3.3): an inner node whose
 * one child is an empty leaf (count 0) with clip value -inf (left) or +inf
 * (right), so no ray enters it, and whose other clip value is the triangles'
 * box side; then the split is a binned SAH over the centres (16 bins, 3 axes),
 * with the same median fallback and depth margin.
 * Both heuristics run on thread_count threads (the top levels on the caller's
 * thread, subtrees below 1/16 of the triangles on all threads); the tree is the
 * same whatever the thread count or timing.
 * out is filled on success (free with
 * pf_bih_free) and zeroed on failure. Zero triangles give one empty leaf.
 * Fails with PF_ERR_INVALID for NaN/Inf vertices or options out of range,
 * PF_ERR_LIMIT when the triangles or nodes exceed the node index field, PF_ERR_NOMEM.
 * leaf_count counts the leaves that hold triangles (1 for an empty tree).
 */
pf_status pf_bih_build_cpu(const pf_scene_frame *frame, const pf_bih_build_options *options,
                           pf_bih *out, pf_error *err);
void pf_bih_free(pf_bih *bih);

/*
 * Checks the BIH invariants against the frame it was built from: node words
 * well formed and in range, every frame triangle in exactly one leaf (through
 * triangle_index), the leaf-order vertices equal to the frame's, leaf ranges
 * contiguous and disjoint, every node reachable once, depth <= PF_BIH_STACK_SIZE,
 * and the clip values bound their subtrees (every triangle under the left
 * child has max[axis] <= clip[0], under the right child min[axis] >= clip[1]).
 * PF_OK or PF_ERR_INTERNAL naming the first node/triangle at fault.
 */
pf_status pf_bih_check(const pf_bih *bih, const pf_scene_frame *frame, pf_error *err);

/*
 * SAH cost with C_trav = C_isect = 1, normalised by the root area:
 *   cost = sum over inner nodes n of A(n) / A(root)
 *        + sum over leaves l of count(l) * A(l) / A(root)
 * where A(n) is the surface area of node n's box, defined for a BIH as the
 * box the clip planes of n's ancestors cut out of the scene box (the region a
 * ray must cross to reach n), intersected with the bounding box of n's own
 * triangles. The intersection makes the figure comparable with a BVH's SAH
 * (whose node box is its triangles' box) and never larger than what the clip
 * planes alone give; clip_sah_cost is the sum without the intersection,
 * what traversal pays (a BIH ray is clipped to the planes only). A(root) is
 * the scene box. When the scene box has zero
 * area (one segment or point), every node counts with probability 1.
 * Also fills the node statistics. quality is zeroed (but bytes_per_node) for
 * an empty tree. Requires a tree that passes pf_bih_check.
 */
void pf_bih_quality_measure(const pf_bih *bih, pf_bih_quality *quality);

/*
 * Traces one ray through the BIH on the CPU: the reference for the GPU
 * include, step for step. Closest hit, or with any_hit the first hit found.
 * Returns PF_OK, or PF_ERR_LIMIT when the traversal stack
 * (PF_BIH_STACK_SIZE entries) would overflow — *hit is then a miss, never a
 * silently wrong answer. A ray with a zero direction misses.
 */
pf_status pf_bih_trace_cpu(const pf_bih *bih, const pf_ray *ray, int any_hit, pf_hit *hit,
                           pf_error *err);

/*
 * What one traversal did: nodes entered (inner and leaf), ray-triangle tests,
 * stack pops (a popped entry beyond the best hit counts too) and the deepest
 * stack. The GLSL traversal (shaders/common/bih_traverse.glsl) takes the same
 * steps, so these are a ray's cost on the device too (bench/bih's profile).
 */
typedef struct pf_bih_trace_counts {
    uint32_t inner_nodes, leaves, triangle_tests, pops, max_stack;
} pf_bih_trace_counts;

/* pf_bih_trace_cpu, also counting what the traversal did into *counts. */
pf_status pf_bih_trace_cpu_counted(const pf_bih *bih, const pf_ray *ray, int any_hit,
                                   pf_hit *hit, pf_bih_trace_counts *counts, pf_error *err);

/*
 * Up to PF_BIH_PACKET_RAYS rays traced together on the CPU (one shared stack,
 * each ray its own interval): each node and leaf is loaded once for all the
 * rays that enter it, where one ray at a time waits on memory at nearly every
 * step. hits[i] is pf_bih_trace_cpu's closest hit for rays[i], bit for bit,
 * but for a tie: where two triangles give exactly the same t, the order of
 * visits can pick the other one (culling by the best hit so far, up to
 * rounding, decides which node is entered; the one-ray traversal depends on
 * its own order the same way). With any_hit, a hit whenever
 * pf_bih_trace_cpu finds one (maybe another triangle). Coherent rays
 * (primary, shadow) gain most. The rays go 8 to a vector on a CPU with AVX2,
 * else 4, with the same answers bit for bit. Same errors as
 * pf_bih_trace_cpu (all hits are then misses); PF_ERR_INVALID for more than
 * PF_BIH_PACKET_RAYS rays.
 */
#define PF_BIH_PACKET_RAYS 16u
pf_status pf_bih_trace_cpu_packet(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                  int any_hit, pf_hit *hits, pf_error *err);

/*
 * Any number of rays, in packets of PF_BIH_PACKET_RAYS consecutive ones:
 * rays in a coherent order (pixel order, and the bounces and shadow rays of
 * neighbouring pixels) make the packets pay. hits as
 * pf_bih_trace_cpu_packet's; stops at the first error.
 */
pf_status pf_bih_trace_cpu_rays(const pf_bih *bih, const pf_ray *rays, uint32_t count,
                                int any_hit, pf_hit *hits, pf_error *err);

/*
 * A wide view of a BIH for the CPU: up to 8 children a node, each with the
 * full box of its triangles, so that one ray at a time tests 8 boxes in one
 * AVX2 step. Incoherent rays (bounces) part ways within a few nodes of a
 * packet (pf_bih_trace_cpu_rays), and a binary node with one clip plane gives
 * a lone ray one test a load. Built from the BIH by collapsing its top
 * levels into each node (the child with the largest box opened first, as for
 * Embree's BVH8) over the BIH's own leaves, whose triangles it copies 4 to a
 * block so that one ray tests 4 at once. It is a view of bih at the time of
 * the call (build again after pf_bih_refit). out is zeroed on failure
 * (PF_ERR_NOMEM); free with pf_bih_wide_free.
 */
typedef struct pf_bih_wide_node pf_bih_wide_node;
typedef struct pf_bih_wide_block pf_bih_wide_block;
typedef struct pf_bih_wide {
    uint32_t node_count;
    pf_bih_wide_node *nodes;
    uint32_t block_count;        /* the leaves' triangles, 4 to a block */
    pf_bih_wide_block *blocks;
} pf_bih_wide;

pf_status pf_bih_wide_build(const pf_bih *bih, pf_bih_wide *out, pf_error *err);
void pf_bih_wide_free(pf_bih_wide *wide);

/*
 * Traces rays one at a time through wide (built from bih): hits as
 * pf_bih_trace_cpu_packet's, the same closest hit as pf_bih_trace_cpu but for
 * a tie at exactly equal t, any hit whenever it finds one. Where the CPU has
 * no AVX2 (or the build could not target it) it is pf_bih_trace_cpu_rays.
 * pf_bih_wide_available says which.
 */
pf_status pf_bih_wide_trace_rays(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                                 uint32_t count, int any_hit, pf_hit *hits, pf_error *err);
int pf_bih_wide_available(void);

/*
 * A BIH on the GPU and the pipelines that trace it. Created empty; filled by
 * pf_bih_gpu_upload. Owns its buffers; destroy before the context.
 */
typedef struct pf_bih_gpu pf_bih_gpu;

pf_status pf_bih_gpu_create(pf_vk_context *ctx, pf_bih_gpu **out, pf_error *err);
void pf_bih_gpu_destroy(pf_bih_gpu *gpu);
/* Replaces the GPU copy with bih (nodes, leaf-order vertices, triangle_index). */
pf_status pf_bih_gpu_upload(pf_bih_gpu *gpu, const pf_bih *bih, pf_error *err);

/*
 * What a kernel that includes shaders/common/bih_traverse.glsl binds: the
 * three tree buffers (owned by gpu, valid until the next upload or destroy)
 * and the arguments trace_bih takes. PF_ERR_INVALID before an upload.
 */
typedef struct pf_bih_gpu_view {
    pf_vk_buffer *nodes;          /* bih_nodes[]: 3 words per node */
    pf_vk_buffer *vertices;       /* bih_vertices[]: vec4 × 3 per triangle, leaf order */
    pf_vk_buffer *triangle_index; /* bih_triangle_index[]: leaf order -> frame index */
    uint32_t node_count;
    uint32_t triangle_count;
    float bounds_min[3], bounds_max[3];
} pf_bih_gpu_view;

pf_status pf_bih_gpu_view_get(const pf_bih_gpu *gpu, pf_bih_gpu_view *out, pf_error *err);

/*
 * Casts rays through the uploaded BIH on the GPU (shaders/bih_raycast.comp):
 * closest hit, or with any_hit any hit in (tmin, tmax). hits[i] answers
 * rays[i]. Fails with PF_ERR_INVALID before an upload, PF_ERR_LIMIT when some
 * ray overflowed the traversal stack (its hit is a miss), PF_ERR_VULKAN.
 */
pf_status pf_bih_raycast(pf_bih_gpu *gpu, const pf_ray *rays, uint32_t ray_count, int any_hit,
                         pf_hit *hits, pf_error *err);

/*
 * The GPU build (core/bih/bih_gpu_build.c): a linear BIH from Morton codes.
 * Passes, each a separate dispatch: 30-bit Morton codes of the triangles'
 * bounding-box centres in the scene box (shaders/bih_morton.comp); a stable
 * 8-bit LSD radix sort (per-workgroup histograms, one scan, a stable scatter;
 * the stable order makes the triangle index the codes' tie-break); Karras
 * 2012 emission, the split axis from the highest differing code bit
 * (bih_emit.comp); boxes, counts and clip values bottom up with uint arrival
 * counters (bih_clip.comp); subtrees of <= K triangles collapsed into leaves
 * and the kept nodes compacted by a prefix sum (bih_collapse.comp).
 * The builder owns the pipelines; destroy it before the context.
 */
typedef struct pf_bih_gpu_builder pf_bih_gpu_builder;

typedef enum pf_bih_build_path {
    PF_BIH_BUILT_ON_GPU = 0,
    PF_BIH_BUILT_SMALL_ON_CPU,   /* n <= K: one leaf, nothing to parallelise */
    PF_BIH_BUILT_CPU_FALLBACK    /* the GPU tree was deeper than max_depth */
} pf_bih_build_path;

/* The GPU build's passes as its timestamps split them (issue 44). */
typedef enum pf_bih_gpu_pass {
    PF_BIH_GPU_PASS_MORTON,   /* Morton codes */
    PF_BIH_GPU_PASS_SORT,     /* the 4 radix passes (histogram, scan, scatter) */
    PF_BIH_GPU_PASS_EMIT,     /* the hierarchy */
    PF_BIH_GPU_PASS_CLIP,     /* bounds, counts, clip planes, leaf layout, kept ranks */
    PF_BIH_GPU_PASS_COLLAPSE, /* compaction into node texels */
    PF_BIH_GPU_PASS_FIT,      /* pf_bih_build_gpu_kept: the tree measured on the device */
    PF_BIH_GPU_PASSES
} pf_bih_gpu_pass;
/* "morton", "sort", "emit", "clip", "collapse", "fit". */
const char *pf_bih_gpu_pass_name(pf_bih_gpu_pass pass);

typedef struct pf_bih_gpu_build_report {
    pf_bih_build_path path;
    uint32_t gpu_depth;          /* depth of the GPU tree (also when it was refused) */
    int resident;                /* pf_bih_build_gpu_resident: the tree stayed on the device */
    /* Device time of each pass and of them all, from timestamps inside the one submission
     * (also when the tree was then refused); -1 where the device has no timestamps or
     * nothing was built on it. */
    double pass_ms[PF_BIH_GPU_PASSES];
    double gpu_ms;
    /* pf_bih_build_gpu_kept: the tree's SAH cost as the device measured it (summed in float),
     * else 0. */
    double sah_cost;
} pf_bih_gpu_build_report;

pf_status pf_bih_gpu_builder_create(pf_vk_context *ctx, pf_bih_gpu_builder **out, pf_error *err);
void pf_bih_gpu_builder_destroy(pf_bih_gpu_builder *builder);

/*
 * Builds a BIH over frame's triangles on the GPU and downloads it into out,
 * in the same format pf_bih_build_cpu produces (free with pf_bih_free).
 * Leaves hold at most K = max_leaf_size triangles. When the tree is deeper
 * than max_depth (pathological clustering), it is dropped, out comes from
 * pf_bih_build_cpu with the same options, a warning is logged and
 * report->path says so: never an over-deep tree. report may be NULL. out is
 * zeroed on failure. Fails like pf_bih_build_cpu, plus PF_ERR_LIMIT when the
 * buffers exceed the device's limits, PF_ERR_VULKAN, and PF_ERR_INTERNAL when
 * the downloaded tree is malformed.
 */
pf_status pf_bih_build_gpu(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                           const pf_bih_build_options *options, pf_bih *out,
                           pf_bih_gpu_build_report *report, pf_error *err);
/*
 * The same, and the tree stays on the device as built (issue 44): device holds it
 * afterwards as pf_bih_gpu_upload(device, out) would, without the upload, when
 * report->resident says so (the GPU path, not a CPU build). The upload of the
 * vertices, every pass and the host copy's readback are one submission and one wait.
 * On failure device is left as it was.
 */
pf_status pf_bih_build_gpu_resident(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                                    const pf_bih_build_options *options, pf_bih *out,
                                    pf_bih_gpu *device, pf_bih_gpu_build_report *report,
                                    pf_error *err);

/*
 * The same, and the nodes stay on the device alone (issue 44): out gets the node count,
 * depth, leaf statistics, bounds, triangle index and the leaf-order vertices (the host
 * gathers them from frame through the index), but its nodes are NULL. The device measures
 * the tree (the refit's passes: report->sah_cost), and the host reads back 4n + 56 bytes
 * instead of 68n. Whoever traces or measures out on the host first fetches its nodes,
 * pf_bih_gpu_download_nodes. A CPU build's out (report->path says so) has its nodes.
 */
pf_status pf_bih_build_gpu_kept(pf_bih_gpu_builder *builder, const pf_scene_frame *frame,
                                const pf_bih_build_options *options, pf_bih *out,
                                pf_bih_gpu *device, pf_bih_gpu_build_report *report,
                                pf_error *err);

/*
 * The nodes of the tree device holds into bih, its host copy (node count and triangles
 * equal; bih's nodes NULL, as pf_bih_build_gpu_kept leaves them): one submission, the
 * tree walked once (every child in range, every node reached once: else PF_ERR_INTERNAL).
 */
pf_status pf_bih_gpu_download_nodes(pf_bih_gpu *device, pf_bih *bih, pf_error *err);

/*
 * Refits bih (from any build, or an earlier refit) to frame's triangles,
 * which must be the same triangles moved (same count and order): topology
 * and leaf assignment stay, the leaf-order vertices are replaced from frame,
 * and every inner node's clip values (left: the largest coordinate along its
 * axis in the left subtree, right: the smallest in the right subtree) and the
 * root box are recomputed bottom up. The result passes pf_bih_check against
 * frame and traversal returns the same closest hits as a fresh build; only
 * its SAH cost may grow (measure it: pf_bih_quality_measure). O(nodes +
 * triangles), iterative. Fails with PF_ERR_INVALID (tree unchanged) when the
 * triangle counts differ, a vertex is NaN/Inf, or the tree is malformed;
 * PF_ERR_NOMEM.
 */
pf_status pf_bih_refit(pf_bih *bih, const pf_scene_frame *frame, pf_error *err);
/*
 * The second half of a refit alone: bih's clip values and root box fitted bottom up to
 * the leaf-order vertices it holds, after pf_bih_refit_gpu left the host's fitting to
 * whoever traces the tree on the host. Fails as pf_bih_refit on a malformed tree.
 */
pf_status pf_bih_refit_bounds(pf_bih *bih, pf_error *err);

/*
 * The refit on the device (issue 44), for the tree device holds as bih's copy (built by
 * pf_bih_build_gpu_resident or uploaded by pf_bih_gpu_upload, refit since only through
 * this call). The host gathers frame's triangles into bih's leaf order (checked as
 * pf_bih_refit checks them: PF_ERR_INVALID leaves both copies as they were); one
 * submission uploads them and fits the device's clip values and root box bottom up
 * (shaders/bih_refit_link, _bounds: bit for bit pf_bih_refit's) and measures the refit
 * tree's SAH cost (bih_refit_sah, _sum: pf_bih_quality_measure's, summed in float),
 * and one wait reads back the cost, the root box and the statistics, 52 bytes. bih's vertices and
 * bounds are then current, but not its clip values: call pf_bih_refit_bounds before
 * tracing or checking bih on the host. PF_ERR_LIMIT where the device's buffers cannot
 * hold the tree's boxes (refit on the host instead); after any other failure the
 * device's tree is unusable until the next build or upload.
 */
typedef enum pf_bih_refit_pass {
    PF_BIH_REFIT_PASS_LINK,   /* parents, arrival counters */
    PF_BIH_REFIT_PASS_BOUNDS, /* clip values and boxes, bottom up */
    PF_BIH_REFIT_PASS_SAH,    /* the cost's terms and sum */
    PF_BIH_REFIT_PASSES
} pf_bih_refit_pass;
/* "link", "bounds", "sah". */
const char *pf_bih_refit_pass_name(pf_bih_refit_pass pass);

typedef struct pf_bih_gpu_refit_report {
    double sah_cost;
    /* Device time of each pass and of them all, from timestamps inside the submission;
     * -1 without timestamps. */
    double pass_ms[PF_BIH_REFIT_PASSES];
    double gpu_ms;
} pf_bih_gpu_refit_report;

pf_status pf_bih_refit_gpu(pf_bih_gpu_builder *builder, pf_bih_gpu *device, pf_bih *bih,
                           const pf_scene_frame *frame, pf_bih_gpu_refit_report *report,
                           pf_error *err);

/*
 * The one GPU prefix sum (gpu_prefix_sum.c, shaders/prefix_sum.comp): the exclusive prefix
 * sum of data[0..count) in place with its total at data[count], recorded into cmds as
 * three dispatches in blocks (each ordered after what came before, pf_vk_cmd_dispatch).
 * data holds pf_bih_prefix_sum_words(count) words: the sums of its blocks follow the
 * total. The BIH build's radix passes and node ranks, the radix sort below and the photon
 * grid's counting sort scan with it; callers make the pipeline once.
 */
uint64_t pf_bih_prefix_sum_words(uint32_t count);
pf_status pf_bih_prefix_sum_pipeline(pf_vk_context *ctx, pf_vk_pipeline **out, pf_error *err);
pf_status pf_bih_prefix_sum_record(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                                   pf_vk_buffer *data, uint32_t count, pf_error *err);

/*
 * The GPU radix sort of the BIH build (shaders/bih_radix_histogram.comp,
 * prefix_sum.comp, bih_radix_scatter.comp), for other modules that sort on the
 * GPU (the photon grid): a stable LSD sort of (uint key, uint value) pairs in
 * 8-bit digits, each pass a histogram per workgroup, one scan and a stable
 * scatter, recorded into the caller's command buffer (no spin-waits).
 */
typedef struct pf_bih_sorter pf_bih_sorter;

pf_status pf_bih_sorter_create(pf_vk_context *ctx, pf_bih_sorter **out, pf_error *err);
void pf_bih_sorter_destroy(pf_bih_sorter *sorter);

/* Bytes of the histogram buffer a sort of count pairs needs. */
uint64_t pf_bih_sort_histogram_bytes(uint32_t count);

/*
 * Records a sort of count pairs by the low key_bits bits of the keys (1..32,
 * rounded up to an even number of 8-bit passes, so the sorted pairs end in
 * keys[0] / values[0] again; keys[1] / values[1] are scratch of the same
 * size). A barrier precedes the first pass and follows the last. Fails with
 * PF_ERR_LIMIT when count needs more workgroups than the device allows.
 */
pf_status pf_bih_sort_record(pf_bih_sorter *sorter, pf_vk_commands *cmds, pf_vk_buffer *keys[2],
                             pf_vk_buffer *values[2], pf_vk_buffer *histogram, uint32_t count,
                             uint32_t key_bits, pf_error *err);

/*
 * The host's trace step of a wavefront (bih_wave_trace.c; issue 43): the queues a wave
 * kernel wrote, in the device's memory as the host sees it (where the device is the CPU),
 * traced with the wide traversal on every core. Per path p: queue[p] = its ray waits (bit
 * 0) | its shadow rays << 1 (at most PF_BIH_WAVE_SHADOW_MAX) | PF_BIH_WAVE_PENDING where it
 * has nothing to trace but is not done (its kernel finishes it next); rays[p] and hits[p];
 * shadow_rays and shadow_hits at p × shadow_slots + k.
 */
#define PF_BIH_WAVE_SHADOW_MAX 0x3FFFFFFFu
#define PF_BIH_WAVE_PENDING 0x80000000u
typedef struct pf_bih_wave_queues {
    const uint32_t *queue;
    const pf_ray *rays;
    pf_hit *hits;
    const pf_ray *shadow_rays;
    pf_hit *shadow_hits;
} pf_bih_wave_queues;

typedef struct pf_bih_wave_tracer pf_bih_wave_tracer;

/* A tracer for up to paths paths of shadow_slots shadow rays each, through bih and its wide
 * view wide (both kept by the caller while the tracer lives; wide NULL: the tracer builds
 * its own), with one scratch per core. */
pf_status pf_bih_wave_tracer_create(const pf_bih *bih, const pf_bih_wide *wide, uint32_t paths,
                                    uint32_t shadow_slots, pf_bih_wave_tracer **out,
                                    pf_error *err);
void pf_bih_wave_tracer_destroy(pf_bih_wave_tracer *tracer);
uint32_t pf_bih_wave_tracer_threads(const pf_bih_wave_tracer *tracer);
/*
 * Traces the waiting rays of the paths active[0..count): closest hits for their rays,
 * any hits for their shadow rays. Then rewrites active with the paths that waited (a path
 * whose queue word is 0 is done): first the *hit whose ray hit a surface, then those whose
 * ray missed or that had none (PF_BIH_WAVE_PENDING among them), each part in order;
 * *remaining is their total. Adds the
 * rays traced to *rays. A traversal failure fails the call (as the device's fails the
 * frame).
 */
pf_status pf_bih_wave_trace(pf_bih_wave_tracer *tracer, const pf_bih_wave_queues *queues,
                            uint32_t *active, uint32_t count, uint32_t *remaining, uint32_t *hit,
                            uint64_t *rays, pf_error *err);


#endif
