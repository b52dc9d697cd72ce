/*
 * BIH refit (pf_bih_refit): the tree of an earlier frame made valid for the
 * moved triangles of this one without rebuilding it. The topology and the
 * leaf assignment stay; the leaf-order vertices are replaced and every clip
 * value is recomputed bottom up from the triangles under it, so the refit
 * tree satisfies the same invariants (pf_bih_check) as a fresh build and
 * traversal returns the same closest hits. Only its quality can suffer: when
 * triangles move far, subtrees overlap — the caller measures the SAH cost and
 * decides whether to rebuild (core/render/frame_bih.c).
 *
 * An empty leaf (the empty side of an SAH build's empty-space cut) keeps an
 * empty box, so its parent's clip value on that side comes out -inf (left)
 * or +inf (right) again: it still bounds nothing.
 *
 * Iterative: the nodes are listed top down (breadth first, every node once)
 * and processed in reverse, so each inner node sees both children finished;
 * no recursion and no stack whatever the depth. O(nodes + triangles).
 */
#include "bih_internal.h"

#include <math.h>
#include <stdlib.h>


/*
 * Lists the nodes reachable from the root, parents before children, in order
 * (node_count entries at most). Fails with PF_ERR_INVALID on a node word,
 * child index or leaf range that a build cannot produce, or when a node is
 * reached more than once (the list would overflow): the tree is not a BIH.
 */
static pf_status list_top_down(const pf_bih *bih, uint32_t *order, uint32_t *listed,
                               pf_error *err)
{
    uint32_t filled = 1;
    order[0] = 0;
    for (uint32_t head = 0; head < filled; head++) {
        uint32_t node = order[head];
        const pf_bih_node *n = &bih->nodes[node];
        if (pf_bih_is_leaf(n)) {
            uint64_t first = pf_bih_leaf_first(n), count = pf_bih_leaf_count(n);
            if (n->word != PF_BIH_LEAF || first + count > bih->triangle_count)
                return pf_error_set(err, PF_ERR_INVALID,
                                    "BIH refit: leaf %u: triangles %llu..%llu beyond %u", node,
                                    (unsigned long long)first,
                                    (unsigned long long)(first + count), bih->triangle_count);
            continue;
        }
        uint32_t child = pf_bih_first_child(n);
        if (child == 0 || child + 1 >= bih->node_count || filled + 2 > bih->node_count)
            return pf_error_set(err, PF_ERR_INVALID,
                                "BIH refit: node %u: children %u, %u out of range or shared "
                                "(%u nodes)",
                                node, child, child + 1, bih->node_count);
        order[filled++] = child;
        order[filled++] = child + 1;
    }
    *listed = filled;
    return PF_OK;
}

/* A tree (its nodes may be on the device alone), the same count, finite vertices: else
 * PF_ERR_INVALID, nothing changed. */
static pf_status check_frame(const pf_bih *bih, const pf_scene_frame *frame, pf_error *err)
{
    if (!bih || !frame)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_refit: NULL argument");
    if (bih->node_count == 0)
        return pf_error_set(err, PF_ERR_INVALID, "BIH refit: the tree has no nodes");
    if (bih->triangle_count != frame->triangle_count)
        return pf_error_set(err, PF_ERR_INVALID,
                            "BIH refit: the tree holds %u triangles, the frame %u (a refit "
                            "keeps the triangles: build a new tree)",
                            bih->triangle_count, frame->triangle_count);
    for (uint32_t t = 0; t < frame->triangle_count; t++)
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                if (!isfinite(frame->vertices[3 * t + c][k]))
                    return pf_error_set(err, PF_ERR_INVALID,
                                        "BIH refit: triangle %u vertex %d: non-finite coordinate",
                                        t, c);
    return PF_OK;
}

void pf_bih_gather_leaf_vertices(pf_bih *bih, const pf_scene_frame *frame)
{
    for (uint32_t p = 0; p < bih->triangle_count; p++)
        pf_bih_copy_leaf_triangle(&bih->vertices[3 * (size_t)p], frame, bih->triangle_index[p]);
    pf_bih_flag_degenerate(bih->vertices, bih->triangle_count);
}

/* Every clip value and the root box from the leaf-order vertices, bottom up (order: listed
 * nodes, parents first); boxes holds node_count. */
static void fit_bounds(pf_bih *bih, const uint32_t *order, uint32_t listed, pf_bih_box *boxes)
{
    for (uint32_t i = listed; i-- > 0;) {
        uint32_t node = order[i];
        pf_bih_node *current = &bih->nodes[node];
        pf_bih_box *box = &boxes[node];
        *box = pf_bih_box_empty();
        if (pf_bih_is_leaf(current)) {
            uint32_t first = pf_bih_leaf_first(current);
            for (uint32_t p = first; p < first + pf_bih_leaf_count(current); p++)
                for (int c = 0; c < 3; c++)
                    pf_bih_box_merge(box, bih->vertices[3 * p + c], bih->vertices[3 * p + c]);
            continue;
        }
        uint32_t child = pf_bih_first_child(current), axis = pf_bih_axis(current);
        current->clip[0] = boxes[child].hi[axis];
        current->clip[1] = boxes[child + 1].lo[axis];
        pf_bih_box_merge(box, boxes[child].lo, boxes[child].hi);
        pf_bih_box_merge(box, boxes[child + 1].lo, boxes[child + 1].hi);
    }
    /* The build's convention: an empty tree has a zero box. */
    for (int k = 0; k < 3; k++) {
        bih->bounds_min[k] = bih->triangle_count > 0 ? boxes[0].lo[k] : 0.0f;
        bih->bounds_max[k] = bih->triangle_count > 0 ? boxes[0].hi[k] : 0.0f;
    }
}

/* Lists (so validates) the tree, gathers frame's triangles when frame is given, then fits
 * every clip value and the root box. */
static pf_status refit_with(pf_bih *bih, const pf_scene_frame *frame, pf_error *err)
{
    uint32_t *order = malloc(bih->node_count * sizeof *order);
    pf_bih_box *boxes = malloc(bih->node_count * sizeof *boxes);
    pf_status status = PF_OK;
    uint32_t listed = 0;
    if (!order || !boxes)
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH refit: %u nodes", bih->node_count);
    if (status == PF_OK)
        status = list_top_down(bih, order, &listed, err);
    if (status == PF_OK) {
        if (frame)
            pf_bih_gather_leaf_vertices(bih, frame);
        fit_bounds(bih, order, listed, boxes);
    }
    free(order);
    free(boxes);
    return status;
}

pf_status pf_bih_refit(pf_bih *bih, const pf_scene_frame *frame, pf_error *err)
{
    /* Checked before anything changes, so a refused frame leaves the tree as it was. */
    if (bih && !bih->nodes)
        return pf_error_set(err, PF_ERR_INVALID, "BIH refit: the tree has no nodes");
    pf_status status = check_frame(bih, frame, err);
    return status == PF_OK ? refit_with(bih, frame, err) : status;
}

pf_status pf_bih_refit_vertices(pf_bih *bih, const pf_scene_frame *frame, pf_error *err)
{
    pf_status status = check_frame(bih, frame, err);
    if (status == PF_OK)
        pf_bih_gather_leaf_vertices(bih, frame);
    return status;
}

pf_status pf_bih_refit_bounds(pf_bih *bih, pf_error *err)
{
    if (!bih || !bih->nodes || bih->node_count == 0)
        return pf_error_set(err, PF_ERR_INVALID, "BIH refit: the tree has no nodes");
    return refit_with(bih, NULL, err);
}
