/*
 * BIH invariants (pf_bih_check) and the quality report (pf_bih_quality_measure),
 * for any BIH: the CPU build's and, downloaded, the GPU build's.
 */
#include "bih_internal.h"

#include <math.h>
#include <stdlib.h>

typedef struct check_state {
    const pf_bih *bih;
    uint8_t *node_seen;
    uint8_t *position_seen;
    pf_error *err;
} check_state;

/*
 * Validates the subtree at node and returns its triangles' box. unreachable:
 * the parent's clip value on this child's side is -inf (left) or +inf
 * (right), so no ray enters it: the only place an empty leaf may be (the
 * empty child of an empty-space cut), besides an empty tree's root.
 */
static pf_status check_node(check_state *s, uint32_t node, uint32_t depth, int unreachable,
                            pf_bih_box *bounds)
{
    const pf_bih *bih = s->bih;
    if (node >= bih->node_count)
        return pf_error_set(s->err, PF_ERR_INTERNAL, "BIH: child index %u out of range (%u nodes)",
                            node, bih->node_count);
    if (s->node_seen[node]++)
        return pf_error_set(s->err, PF_ERR_INTERNAL, "BIH node %u: reached twice", node);
    const pf_bih_node *n = &bih->nodes[node];
    *bounds = pf_bih_box_empty();
    if (pf_bih_is_leaf(n)) {
        if (n->word != PF_BIH_LEAF)
            return pf_error_set(s->err, PF_ERR_INTERNAL, "BIH node %u: leaf word 0x%x has stray bits",
                                node, n->word);
        uint64_t first = pf_bih_leaf_first(n), count = pf_bih_leaf_count(n);
        if (first + count > bih->triangle_count)
            return pf_error_set(s->err, PF_ERR_INTERNAL,
                                "BIH leaf %u: triangles %llu..%llu beyond %u", node,
                                (unsigned long long)first,
                                (unsigned long long)(first + count), bih->triangle_count);
        if (count == 0 && !unreachable && !(node == 0 && bih->triangle_count == 0))
            return pf_error_set(s->err, PF_ERR_INTERNAL,
                                "BIH leaf %u: empty, but its parent's clip value lets rays in",
                                node);
        for (uint64_t p = first; p < first + count; p++) {
            if (s->position_seen[p]++)
                return pf_error_set(s->err, PF_ERR_INTERNAL,
                                    "BIH leaf %u: triangle position %llu in two leaves", node,
                                    (unsigned long long)p);
            for (int c = 0; c < 3; c++)
                pf_bih_box_merge(bounds, bih->vertices[3 * p + c], bih->vertices[3 * p + c]);
        }
        return PF_OK;
    }
    if (depth >= PF_BIH_STACK_SIZE)
        return pf_error_set(s->err, PF_ERR_INTERNAL,
                            "BIH node %u: inner node at depth %u (the stack holds %u)", node,
                            depth, PF_BIH_STACK_SIZE);
    uint32_t child = pf_bih_first_child(n), axis = pf_bih_axis(n);
    if (child == 0 || child + 1 >= bih->node_count)
        return pf_error_set(s->err, PF_ERR_INTERNAL, "BIH node %u: children %u, %u out of range",
                            node, child, child + 1);
    pf_bih_box left, right;
    pf_status status = check_node(s, child, depth + 1, n->clip[0] == -INFINITY, &left);
    if (status == PF_OK)
        status = check_node(s, child + 1, depth + 1, n->clip[1] == INFINITY, &right);
    if (status != PF_OK)
        return status;
    if (!(left.hi[axis] <= n->clip[0]))
        return pf_error_set(s->err, PF_ERR_INTERNAL,
                            "BIH node %u: left subtree reaches %.9g along axis %u, beyond its clip %.9g",
                            node, left.hi[axis], axis, n->clip[0]);
    if (!(right.lo[axis] >= n->clip[1]))
        return pf_error_set(s->err, PF_ERR_INTERNAL,
                            "BIH node %u: right subtree reaches %.9g along axis %u, below its clip %.9g",
                            node, right.lo[axis], axis, n->clip[1]);
    *bounds = left;
    pf_bih_box_merge(bounds, right.lo, right.hi);
    return PF_OK;
}

pf_status pf_bih_check(const pf_bih *bih, const pf_scene_frame *frame, pf_error *err)
{
    if (!bih || !frame)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_check: NULL argument");
    if (bih->triangle_count != frame->triangle_count)
        return pf_error_set(err, PF_ERR_INTERNAL, "BIH holds %u triangles, the frame %u",
                            bih->triangle_count, frame->triangle_count);
    if (bih->node_count == 0 || !bih->nodes)
        return pf_error_set(err, PF_ERR_INTERNAL, "BIH has no root node");
    uint32_t n = bih->triangle_count;
    check_state s = {bih, calloc(bih->node_count, 1), calloc(n ? n : 1, 1), err};
    uint8_t *original_seen = calloc(n ? n : 1, 1);
    pf_status status = PF_OK;
    if (!s.node_seen || !s.position_seen || !original_seen)
        status = pf_error_set(err, PF_ERR_NOMEM, "pf_bih_check: %u nodes", bih->node_count);
    for (uint32_t p = 0; status == PF_OK && p < n; p++) {
        uint32_t t = bih->triangle_index[p];
        if (t >= n || original_seen[t]++) {
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "BIH position %u: triangle %u out of range or listed twice", p, t);
            break;
        }
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                if (bih->vertices[3 * p + c][k] != frame->vertices[3 * t + c][k])
                    status = pf_error_set(err, PF_ERR_INTERNAL,
                                          "BIH position %u: vertices differ from triangle %u's", p, t);
        const float(*leaf)[4] = &bih->vertices[3 * p];
        float degenerate_w =
            pf_triangle_is_degenerate(leaf[0], leaf[1], leaf[2]) ? PF_BIH_DEGENERATE_W : 0.0f;
        if (status == PF_OK &&
            (leaf[0][3] != degenerate_w || leaf[1][3] != 0.0f || leaf[2][3] != 0.0f))
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "BIH position %u: vertex w %g %g %g, expected %g 0 0 "
                                  "(degenerate flag)",
                                  p, (double)leaf[0][3], (double)leaf[1][3], (double)leaf[2][3],
                                  (double)degenerate_w);
    }
    pf_bih_box root;
    if (status == PF_OK)
        status = check_node(&s, 0, 0, 0, &root);
    for (uint32_t p = 0; status == PF_OK && p < n; p++)
        if (!s.position_seen[p])
            status = pf_error_set(err, PF_ERR_INTERNAL,
                                  "BIH: triangle %u (position %u) is in no leaf",
                                  bih->triangle_index[p], p);
    for (uint32_t node = 0; status == PF_OK && node < bih->node_count; node++)
        if (!s.node_seen[node])
            status = pf_error_set(err, PF_ERR_INTERNAL, "BIH node %u: unreachable", node);
    for (int k = 0; status == PF_OK && n > 0 && k < 3; k++)
        if (root.lo[k] < bih->bounds_min[k] || root.hi[k] > bih->bounds_max[k])
            status = pf_error_set(err, PF_ERR_INTERNAL, "BIH: bounds miss triangles along axis %d", k);
    free(s.node_seen);
    free(s.position_seen);
    free(original_seen);
    return status;
}

static double box_area(const pf_bih_box *box)
{
    double e[3];
    for (int k = 0; k < 3; k++) {
        e[k] = (double)box->hi[k] - box->lo[k];
        if (!(e[k] >= 0.0))
            return 0.0;
    }
    return 2.0 * (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]);
}

typedef struct quality_state {
    const pf_bih *bih;
    double root_area;
    double weighted_inner, weighted_leaf;
    double clip_weighted;        /* the same sum with the clip region's area alone */
    pf_bih_quality *q;
} quality_state;

/* Returns the subtree's triangle box; clip is the box the ancestors' planes cut out. */
static pf_bih_box measure_node(quality_state *s, uint32_t node, const pf_bih_box *clip,
                                 uint32_t depth)
{
    const pf_bih_node *n = &s->bih->nodes[node];
    pf_bih_box bounds = pf_bih_box_empty();
    double count = 0;
    if (pf_bih_is_leaf(n)) {
        uint32_t first = pf_bih_leaf_first(n);
        count = pf_bih_leaf_count(n);
        for (uint32_t p = first; p < first + pf_bih_leaf_count(n); p++)
            for (int c = 0; c < 3; c++) {
                const float *vertex = s->bih->vertices[3 * p + c];
                pf_bih_box_merge(&bounds, vertex, vertex);
            }
        s->q->leaf_count += count > 0;
        if (pf_bih_leaf_count(n) > s->q->largest_leaf)
            s->q->largest_leaf = pf_bih_leaf_count(n);
        if (depth > s->q->depth)
            s->q->depth = depth;
    } else {
        uint32_t child = pf_bih_first_child(n), axis = pf_bih_axis(n);
        pf_bih_box left_clip = *clip, right_clip = *clip;
        left_clip.hi[axis] = fminf(left_clip.hi[axis], n->clip[0]);
        right_clip.lo[axis] = fmaxf(right_clip.lo[axis], n->clip[1]);
        bounds = measure_node(s, child, &left_clip, depth + 1);
        pf_bih_box right = measure_node(s, child + 1, &right_clip, depth + 1);
        pf_bih_box_merge(&bounds, right.lo, right.hi);
        s->q->inner_count++;
    }
    pf_bih_box region = bounds;
    for (int k = 0; k < 3; k++) {
        region.lo[k] = fmaxf(region.lo[k], clip->lo[k]);
        region.hi[k] = fminf(region.hi[k], clip->hi[k]);
    }
    double probability = s->root_area > 0.0 ? box_area(&region) / s->root_area : 1.0;
    double clip_probability = s->root_area > 0.0 ? box_area(clip) / s->root_area : 1.0;
    if (pf_bih_is_leaf(n)) {
        s->weighted_leaf += probability * count;
        s->clip_weighted += clip_probability * count;
    } else {
        s->weighted_inner += probability;
        s->clip_weighted += clip_probability;
    }
    return bounds;
}

void pf_bih_quality_measure(const pf_bih *bih, pf_bih_quality *quality)
{
    memset(quality, 0, sizeof *quality);
    quality->bytes_per_node = sizeof(pf_bih_node);
    if (!bih || bih->triangle_count == 0 || bih->node_count == 0)
        return;
    pf_bih_box root;
    memcpy(root.lo, bih->bounds_min, sizeof root.lo);
    memcpy(root.hi, bih->bounds_max, sizeof root.hi);
    quality_state s = {bih, box_area(&root), 0.0, 0.0, 0.0, quality};
    measure_node(&s, 0, &root, 0);
    quality->sah_cost = s.weighted_inner + s.weighted_leaf;
    quality->clip_sah_cost = s.clip_weighted;
    quality->mean_leaf_size = (double)bih->triangle_count / quality->leaf_count;
}
