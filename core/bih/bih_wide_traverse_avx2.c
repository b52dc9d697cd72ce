/*
 * One ray at a time through the wide view (pf_bih.h, pf_bih_wide), 8 boxes a
 * step with AVX2 (built with -mavx2, no -mfma; bih_wide_build.c calls it only
 * where the CPU reports AVX2).
 *
 * The float rules are the one-ray traversal's (bih_cpu_traverse.c): a slab's
 * far distance, and the best hit used as a bound, widened by 2γ(3) (Ize
 * 2013), so rounding cannot cull a box the ray enters; an axis whose
 * direction is below the smallest normal float is decided by the origin
 * alone; the leaves' triangles through the same watertight test with the
 * same tie rule. A box holds all its triangles, so a triangle the one-ray
 * walk finds lies in boxes this walk enters, and the closest hit is the
 * same, but for a tie at exactly equal t between triangles in different
 * leaves, where whichever is found first may cull the other (as for the
 * packets).
 */
#include "bih_internal.h"
#include "bih_lanes4.h"

#include <immintrin.h>

/* At most 7 pushes a wide level, and a wide level is at least one BIH level. */
#define WIDE_STACK_SIZE (8u * PF_BIH_STACK_SIZE + 8u)

typedef struct wide_entry {
    uint32_t child, count;
    float t_near;
} wide_entry;

typedef struct wide_ray {
    __m256 origin[3], inv[3], t_min;
    __m256 parallel_mask[3]; /* all ones on an axis the ray is parallel to */
    /* Per axis: where the near and far bounds sit (lo for a positive direction). */
    uint32_t near_offset[3], far_offset[3];
    int any_parallel, parallel[3];
    pf_bih_ray prepared;
} wide_ray;

static void wide_ray_prepare(const pf_ray *ray, wide_ray *w)
{
    pf_bih_ray_prepare(ray, &w->prepared);
    w->any_parallel = 0;
    for (int k = 0; k < 3; k++) {
        w->origin[k] = _mm256_set1_ps(ray->origin[k]);
        w->inv[k] = _mm256_set1_ps(w->prepared.inv[k]);
        w->parallel[k] = w->prepared.parallel[k];
        w->any_parallel |= w->parallel[k];
        w->parallel_mask[k] = _mm256_castsi256_ps(_mm256_set1_epi32(w->parallel[k] ? -1 : 0));
        int positive = w->prepared.inv[k] >= 0.0f;
        /* Offsets in floats from the node's start: lo[k] at 8k, hi[k] at 24 + 8k. */
        w->near_offset[k] = positive ? 8u * (uint32_t)k : 24u + 8u * (uint32_t)k;
        w->far_offset[k] = positive ? 24u + 8u * (uint32_t)k : 8u * (uint32_t)k;
    }
    w->t_min = _mm256_set1_ps(ray->tmin);
}

/* The 8 slots' distances along the ray to the planes at bounds (one bound of axis k each). */
static inline __m256 slab_distances(const float *bounds, const wide_ray *w, int k)
{
    return _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(bounds), w->origin[k]), w->inv[k]);
}

/* All ones where axis k is not parallel or the slot's slab holds the origin. */
static __m256 slab_holds_origin(const float *base, const wide_ray *w, int k)
{
    __m256 inside = _mm256_and_ps(
        _mm256_cmp_ps(_mm256_load_ps(base + 8 * k), w->origin[k], _CMP_LE_OQ),
        _mm256_cmp_ps(w->origin[k], _mm256_load_ps(base + 24 + 8 * k), _CMP_LE_OQ));
    return _mm256_or_ps(inside, _mm256_xor_ps(w->parallel_mask[k],
                                              _mm256_castsi256_ps(_mm256_set1_epi32(-1))));
}

/*
 * The slots of node whose box the ray enters within [tmin, widened closest]:
 * a bit mask, and each slot's entry distance in t_near.
 */
static uint32_t wide_node_step(const pf_bih_wide_node *node, const wide_ray *w, float closest,
                               float t_near[8])
{
    const float *base = (const float *)node;
    /* Named per axis: as a loop over k into arrays, GCC -O2 kept the six vectors in memory. */
    __m256 near_x = slab_distances(base + w->near_offset[0], w, 0);
    __m256 near_y = slab_distances(base + w->near_offset[1], w, 1);
    __m256 near_z = slab_distances(base + w->near_offset[2], w, 2);
    __m256 far_x = slab_distances(base + w->far_offset[0], w, 0);
    __m256 far_y = slab_distances(base + w->far_offset[1], w, 1);
    __m256 far_z = slab_distances(base + w->far_offset[2], w, 2);
    __m256 open = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    if (w->any_parallel) {
        /* A parallel axis: inside the slab or not, whatever t; it adds no bound. */
        __m256 minus_inf = _mm256_set1_ps(-INFINITY), plus_inf = _mm256_set1_ps(INFINITY);
        open = _mm256_and_ps(open, slab_holds_origin(base, w, 0));
        open = _mm256_and_ps(open, slab_holds_origin(base, w, 1));
        open = _mm256_and_ps(open, slab_holds_origin(base, w, 2));
        near_x = _mm256_blendv_ps(near_x, minus_inf, w->parallel_mask[0]);
        near_y = _mm256_blendv_ps(near_y, minus_inf, w->parallel_mask[1]);
        near_z = _mm256_blendv_ps(near_z, minus_inf, w->parallel_mask[2]);
        far_x = _mm256_blendv_ps(far_x, plus_inf, w->parallel_mask[0]);
        far_y = _mm256_blendv_ps(far_y, plus_inf, w->parallel_mask[1]);
        far_z = _mm256_blendv_ps(far_z, plus_inf, w->parallel_mask[2]);
    }
    __m256 t_enter = _mm256_max_ps(_mm256_max_ps(near_x, near_y), _mm256_max_ps(near_z, w->t_min));
    __m256 t_exit = _mm256_min_ps(_mm256_min_ps(far_x, far_y),
                                  _mm256_min_ps(far_z, _mm256_set1_ps(closest)));
    /* Widened by 2γ(3)·|t| (pf_bih_widen_far); -inf (an empty slot) turns NaN: still shut. */
    __m256 magnitude = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), t_exit);
    t_exit = _mm256_add_ps(t_exit, _mm256_mul_ps(magnitude, _mm256_set1_ps(PF_BIH_TWO_GAMMA3)));
    open = _mm256_and_ps(open, _mm256_cmp_ps(t_enter, t_exit, _CMP_LE_OQ));
    _mm256_storeu_ps(t_near, t_enter);
    return (uint32_t)_mm256_movemask_ps(open);
}

#define WATERTIGHT_T lanes4_f
#define WATERTIGHT_EDGES wide_edges
#include "bih_watertight_edges.h"

/*
 * The leaf's triangles, 4 a block, as bih_cpu_traverse.c's walk tests them:
 * pf_ray_triangle_sheared's operations lane by lane (translation, the ray's
 * permutation, shear, edges, sign test, det, distance; ISO C mode: no FMA),
 * in (tmin, next_up(closest)). A lane whose edges or distance are small
 * enough for that test to evaluate again at a power-of-two scale goes to it.
 * Lanes are offered in leaf order, so the best hit and its tie rule come out
 * as the walk's one triangle after another. 1 on an any-hit stop.
 */
static int wide_leaf(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *ray,
                     const wide_ray *w, uint32_t first, uint32_t count, int any_hit,
                     float *closest, pf_hit *hit)
{
    const pf_ray_shear *shear = &w->prepared.shear;
    const int axes[3] = {shear->kx, shear->ky, shear->kz};
    const lanes4_f sx = {shear->sx, shear->sx, shear->sx, shear->sx};
    const lanes4_f sy = {shear->sy, shear->sy, shear->sy, shear->sy};
    const lanes4_f sz = {shear->sz, shear->sz, shear->sz, shear->sz};
    const float below = PF_BIH_WATERTIGHT_RESCALE_BELOW;
    for (uint32_t b = first; b < first + (count + PF_BIH_WIDE_LANES - 1) / PF_BIH_WIDE_LANES;
         b++) {
        const pf_bih_wide_block *block = &wide->blocks[b];
        if (!block->live)
            continue;
        lanes4_f a[3], bv[3], c[3];
        /* Unrolled, the three vertices' permuted coordinates stay in registers; as a loop,
         * GCC -O2 stored them to the stack and read them back for the edge functions
         * (bih_bench cornell-box: the wide traversal +18-20 % once unrolled). */
#pragma GCC unroll 3
        for (int i = 0; i < 3; i++) {
            int k = axes[i];
            lanes4_f o = {ray->origin[k], ray->origin[k], ray->origin[k], ray->origin[k]};
            a[i] = *(const lanes4_f *)block->v[0][k] - o;
            bv[i] = *(const lanes4_f *)block->v[1][k] - o;
            c[i] = *(const lanes4_f *)block->v[2][k] - o;
        }
        wide_edges_result e = wide_edges(a, bv, c, sx, sy, sz);
        lanes4_f eu = e.eu, ev = e.ev, ew = e.ew, det = e.det, scaled_t = e.scaled_t;
        lanes4_i small = (lanes4_abs(eu) < below) | (lanes4_abs(ev) < below) |
                        (lanes4_abs(ew) < below) | (lanes4_abs(scaled_t) < lanes4_abs(det) * below);
        lanes4_i mixed = ((eu < 0.0f) | (ev < 0.0f) | (ew < 0.0f)) &
                        ((eu > 0.0f) | (ev > 0.0f) | (ew > 0.0f));
        lanes4_f rcp_det = 1.0f / det;
        lanes4_f t = scaled_t * rcp_det;
        float up = pf_bih_next_up(*closest);
        lanes4_i in_range = (t > ray->tmin) & (t < up) & (t >= FLT_MIN);
        uint32_t live = block->live;
        uint32_t rescale = lanes4_bits(small) & live;
        uint32_t hits = lanes4_bits(~small & ~mixed & (det != 0.0f) & in_range) & live;
        for (uint32_t bits = hits | rescale; bits; bits &= bits - 1) {
            uint32_t lane = (uint32_t)__builtin_ctz(bits);
            uint32_t p = block->position[lane];
            float ht = t[lane], hu, hv;
            if (rescale & (1u << lane)) {
                const float(*leaf)[4] = &bih->vertices[3 * p];
                if (!pf_ray_triangle_sheared(ray->origin, shear, leaf[0], leaf[1], leaf[2],
                                             ray->tmin, pf_bih_next_up(*closest), &ht, &hu, &hv))
                    continue;
            } else {
                hu = ev[lane] * rcp_det[lane];
                hv = ew[lane] * rcp_det[lane];
            }
            uint32_t original = bih->triangle_index[p];
            if (ht < *closest ||
                (ht == *closest && hit->triangle != PF_NO_HIT && original < hit->triangle)) {
                *closest = ht;
                *hit = (pf_hit){ht, original, hu, hv};
                if (any_hit)
                    return 1;
            }
        }
    }
    return 0;
}

static pf_status wide_trace(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *ray,
                            int any_hit, pf_hit *hit, wide_entry *stack, pf_error *err)
{
    *hit = PF_BIH_MISS;
    wide_ray w;
    wide_ray_prepare(ray, &w);
    if (w.parallel[0] && w.parallel[1] && w.parallel[2])
        return PF_OK; /* a zero direction hits nothing */
    float closest = ray->tmax;
    uint32_t size = 0, child = 0, count = 0;
    /* Each wide node and leaf is entered at most once: that bounds the loop. */
    for (uint32_t step = 0; step <= wide->node_count + bih->leaf_count; step++) {
        if (child & PF_BIH_WIDE_LEAF) {
            if (wide_leaf(bih, wide, ray, &w, child & ~PF_BIH_WIDE_LEAF, count, any_hit,
                          &closest, hit))
                return PF_OK;
        } else {
            const pf_bih_wide_node *node = &wide->nodes[child];
            float t_near[8];
            uint32_t open = wide_node_step(node, &w, closest, t_near);
            if (open != 0) {
                /* The nearest open slot next, the others pushed farthest first. */
                uint32_t first = (uint32_t)__builtin_ctz(open);
                if ((open & (open - 1)) == 0) {
                    child = node->child[first];
                    count = node->count[first];
                    continue;
                }
                uint32_t base = size;
                if (size + 8u > WIDE_STACK_SIZE) {
                    *hit = PF_BIH_MISS;
                    return pf_error_set(err, PF_ERR_LIMIT,
                                        "BIH wide traversal: stack of %u entries overflowed",
                                        WIDE_STACK_SIZE);
                }
                for (uint32_t bits = open; bits; bits &= bits - 1) {
                    uint32_t i = (uint32_t)__builtin_ctz(bits);
                    wide_entry e = {node->child[i], node->count[i], t_near[i]};
                    /*
                     * Insertion by descending entry distance: the nearest ends on top. Any
                     * hit will do for an any-hit ray, so its slots stay in their order
                     * (shadow rays +2-14 %, bench/RESULTS.md).
                     */
                    uint32_t j = size++;
                    while (!any_hit && j > base && stack[j - 1].t_near < e.t_near) {
                        stack[j] = stack[j - 1];
                        j--;
                    }
                    stack[j] = e;
                }
                wide_entry top = stack[--size];
                child = top.child;
                count = top.count;
                continue;
            }
        }
        /* Next: the nearest pushed slot the best hit has not culled. */
        float bound = pf_bih_widen_far(closest);
        int resumed = 0;
        while (size > 0) {
            wide_entry e = stack[--size];
            if (e.t_near <= bound) {
                child = e.child;
                count = e.count;
                resumed = 1;
                break;
            }
        }
        if (!resumed)
            return PF_OK;
    }
    *hit = PF_BIH_MISS;
    return pf_error_set(err, PF_ERR_INTERNAL,
                        "BIH wide traversal: more steps than nodes and leaves (a malformed view)");
}

pf_status pf_bih_wide_trace_avx2(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                                 uint32_t count, int any_hit, pf_hit *hits, pf_error *err)
{
    wide_entry stack[WIDE_STACK_SIZE];
    for (uint32_t i = 0; i < count; i++) {
        pf_status status = wide_trace(bih, wide, &rays[i], any_hit, &hits[i], stack, err);
        if (status != PF_OK) {
            for (uint32_t j = i + 1; j < count; j++)
                hits[j] = PF_BIH_MISS;
            return status;
        }
    }
    return PF_OK;
}
