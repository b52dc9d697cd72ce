/*
 * The CPU traversal: the definition of the algorithm that
 * shaders/common/bih_traverse.glsl implements, step for step (same order of
 * children, same interval arithmetic, same tie rule), so tests can pin the GPU
 * to it.
 *
 * Robustness (REFERENCE.md, BIH):
 * - every far distance (a box's or child's exit, and the best hit used as a
 *   culling bound) is widened by 2γ(3), γ(n) = nε/(1−nε), ε = 2^-24 (Ize,
 *   "Robust BVH Ray Traversal", JCGT 2(2), 2013), so rounding in the slab
 *   distances can never cull a node the ray really enters;
 * - a child's interval is the parent's interval intersected with the slab
 *   (never overwritten);
 * - an axis whose direction component is below the smallest normal float
 *   counts as parallel: its slab is decided by the origin alone, so no 0·∞
 *   (NaN) arises and CPU and GPU (which may flush denormals) agree;
 * - popped entries whose entry distance lies beyond the best hit are skipped.
 */
#include "bih_internal.h"

typedef struct stack_entry {
    uint32_t node;
    float t_near, t_far;
} stack_entry;

int pf_bih_ray_enter(const pf_bih *bih, const pf_ray *ray, const pf_bih_ray *prepared,
                     float *t_near_out, float *t_far_out)
{
    const float *origin = ray->origin;
    const int *parallel = prepared->parallel;
    const float *inv = prepared->inv;
    if (bih->triangle_count == 0 || (parallel[0] && parallel[1] && parallel[2]))
        return 0;
    float t_near = ray->tmin, t_far = ray->tmax;
    for (int k = 0; k < 3; k++) {
        if (parallel[k]) {
            if (origin[k] < bih->bounds_min[k] || origin[k] > bih->bounds_max[k])
                return 0;
            continue;
        }
        float t0 = (bih->bounds_min[k] - origin[k]) * inv[k];
        float t1 = (bih->bounds_max[k] - origin[k]) * inv[k];
        if (inv[k] < 0.0f) {
            float swap = t0;
            t0 = t1;
            t1 = swap;
        }
        t_near = pf_bih_max(t_near, t0);
        t_far = pf_bih_min(t_far, pf_bih_widen_far(t1));
    }
    *t_near_out = t_near;
    *t_far_out = t_far;
    return t_near <= t_far;
}

pf_status pf_bih_walk(const pf_bih *bih, const pf_ray *ray, const pf_bih_ray *prepared,
                      uint32_t node, float t_near, float t_far, int any_hit, float *closest_io,
                      pf_hit *hit, pf_bih_trace_counts *counts, pf_error *err)
{
    const float *origin = ray->origin;
    const int *parallel = prepared->parallel;
    const float *inv = prepared->inv;
    const pf_ray_shear shear = prepared->shear;
    float closest = *closest_io;
    stack_entry stack[PF_BIH_STACK_SIZE];
    uint32_t stack_size = 0;
    /* A ray enters each node at most once, so node_count visits bound the loop. */
    for (uint32_t visit = 0; visit < bih->node_count; visit++) {
        const pf_bih_node *n = &bih->nodes[node];
        int descend = 0;
        if (counts && pf_bih_is_leaf(n))
            counts->leaves++;
        else if (counts)
            counts->inner_nodes++;
        if (!pf_bih_is_leaf(n)) {
            uint32_t axis = pf_bih_axis(n), child = pf_bih_first_child(n);
            float far_limit = pf_bih_min(t_far, pf_bih_widen_far(closest));
            float left_near = t_near, left_far = far_limit;
            float right_near = t_near, right_far = far_limit;
            int left_first = 1;
            int left_open = 1, right_open = 1;
            if (parallel[axis]) {
                left_open = origin[axis] <= n->clip[0];
                right_open = origin[axis] >= n->clip[1];
            } else {
                float t_left = (n->clip[0] - origin[axis]) * inv[axis];
                float t_right = (n->clip[1] - origin[axis]) * inv[axis];
                if (inv[axis] > 0.0f) {
                    left_far = pf_bih_min(left_far, pf_bih_widen_far(t_left));
                    right_near = pf_bih_max(right_near, t_right);
                } else {
                    left_first = 0;
                    right_far = pf_bih_min(right_far, pf_bih_widen_far(t_right));
                    left_near = pf_bih_max(left_near, t_left);
                }
            }
            int visit_left = left_open && left_near <= left_far;
            int visit_right = right_open && right_near <= right_far;
            uint32_t near_child = left_first ? child : child + 1;
            uint32_t far_child = left_first ? child + 1 : child;
            int visit_near = left_first ? visit_left : visit_right;
            int visit_far = left_first ? visit_right : visit_left;
            if (visit_near && visit_far) {
                if (stack_size == PF_BIH_STACK_SIZE) {
                    *hit = PF_BIH_MISS;
                    return pf_error_set(err, PF_ERR_LIMIT,
                                        "BIH traversal: stack of %u entries overflowed at node %u",
                                        PF_BIH_STACK_SIZE, node);
                }
                if (counts && stack_size + 1 > counts->max_stack)
                    counts->max_stack = stack_size + 1;
                stack[stack_size++] = (stack_entry){
                    far_child, left_first ? right_near : left_near,
                    left_first ? right_far : left_far};
            }
            if (visit_near || visit_far) {
                node = visit_near ? near_child : far_child;
                t_near = visit_near ? (left_first ? left_near : right_near)
                                    : (left_first ? right_near : left_near);
                t_far = visit_near ? (left_first ? left_far : right_far)
                                   : (left_first ? right_far : left_far);
                descend = 1;
            }
        } else {
            uint32_t first = pf_bih_leaf_first(n), count = pf_bih_leaf_count(n);
            if (counts)
                counts->triangle_tests += count;
            for (uint32_t p = first; p < first + count; p++) {
                float t, u, v;
                const float(*leaf)[4] = &bih->vertices[3 * p];
                /* A degenerate triangle never hits (its flag: pf_bih.h). */
                if (leaf[0][3] != 0.0f ||
                    !pf_ray_triangle_sheared(origin, &shear, leaf[0], leaf[1], leaf[2], ray->tmin,
                                             pf_bih_next_up(closest), &t, &u, &v))
                    continue;
                uint32_t original = bih->triangle_index[p];
                /* Equal t: the lower original index wins, as in the brute-force oracle. */
                if (t < closest ||
                    (t == closest && hit->triangle != PF_NO_HIT && original < hit->triangle)) {
                    closest = t;
                    *closest_io = t;
                    *hit = (pf_hit){t, original, u, v};
                    if (any_hit)
                        return PF_OK;
                }
            }
        }
        if (descend)
            continue;
        int resumed = 0;
        while (stack_size > 0) {
            stack_entry entry = stack[--stack_size];
            float far_limit = pf_bih_min(entry.t_far, pf_bih_widen_far(closest));
            if (counts)
                counts->pops++;
            if (entry.t_near <= far_limit) {
                node = entry.node;
                t_near = entry.t_near;
                t_far = far_limit;
                resumed = 1;
                break;
            }
        }
        if (!resumed)
            return PF_OK;
    }
    *hit = PF_BIH_MISS;
    return pf_error_set(err, PF_ERR_INTERNAL,
                        "BIH traversal: more than %u node visits (a malformed tree)",
                        bih->node_count);
}

/* The traversal; counts (may be NULL) receives what it did. */
static pf_status trace(const pf_bih *bih, const pf_ray *ray, int any_hit, pf_hit *hit,
                       pf_bih_trace_counts *counts, pf_error *err)
{
    *hit = PF_BIH_MISS;
    pf_bih_ray prepared;
    pf_bih_ray_prepare(ray, &prepared);
    float t_near, t_far;
    if (!pf_bih_ray_enter(bih, ray, &prepared, &t_near, &t_far))
        return PF_OK;
    float closest = ray->tmax;
    return pf_bih_walk(bih, ray, &prepared, 0, t_near, t_far, any_hit, &closest, hit, counts,
                       err);
}

pf_status pf_bih_trace_cpu(const pf_bih *bih, const pf_ray *ray, int any_hit, pf_hit *hit,
                           pf_error *err)
{
    return trace(bih, ray, any_hit, hit, NULL, err);
}

pf_status pf_bih_trace_cpu_counted(const pf_bih *bih, const pf_ray *ray, int any_hit,
                                   pf_hit *hit, pf_bih_trace_counts *counts, pf_error *err)
{
    *counts = (pf_bih_trace_counts){0};
    return trace(bih, ray, any_hit, hit, counts, err);
}
