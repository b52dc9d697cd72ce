/*
 * The wide view of a BIH (pf_bih.h, pf_bih_wide): each BIH node's box from
 * its triangles, then the tree collapsed into nodes of up to 8 children, and
 * the entry point that picks the AVX2 traversal where the CPU runs it.
 */
#include "bih_internal.h"

#include <stdlib.h>

typedef struct collapse {
    const pf_bih *bih;
    pf_bih_box *boxes;            /* per BIH node */
    uint32_t *leaf_block;  /* per BIH leaf: its first block */
    pf_bih_wide_node *nodes;
    uint32_t count;
    pf_bih_wide_block *blocks;
    uint32_t block_count;
} collapse;

static uint32_t blocks_for(uint32_t triangles)
{
    return (triangles + PF_BIH_WIDE_LANES - 1) / PF_BIH_WIDE_LANES;
}

/* The leaf's triangles into blocks of 4 lanes; returns the first block's index. */
static uint32_t copy_leaf(collapse *c, uint32_t first, uint32_t count)
{
    uint32_t index = c->block_count;
    for (uint32_t b = 0; b < blocks_for(count); b++) {
        pf_bih_wide_block *block = &c->blocks[c->block_count++];
        *block = (pf_bih_wide_block){0};
        for (uint32_t lane = 0; lane < PF_BIH_WIDE_LANES; lane++) {
            uint32_t p = first + PF_BIH_WIDE_LANES * b + lane;
            block->position[lane] = p < first + count ? p : PF_NO_HIT;
            if (p >= first + count)
                continue;
            const float(*leaf)[4] = &c->bih->vertices[3 * p];
            for (int v = 0; v < 3; v++)
                for (int k = 0; k < 3; k++)
                    block->v[v][k][lane] = leaf[v][k];
            /* A degenerate triangle never hits (its flag: pf_bih.h). */
            if (leaf[0][3] == 0.0f)
                block->live |= 1u << lane;
        }
    }
    return index;
}

/*
 * Node n's box from its triangles' vertices (the degenerate ones too: they
 * are in the leaf, never hit, and widen the box only where the leaf is
 * anyway), and each leaf's triangles copied into blocks on the way: the
 * walk reads the leaf-order vertices in about the order the build wrote
 * them, where copying them in the collapse's order missed the cache.
 * Recursive: the tree's depth is at most PF_BIH_STACK_SIZE (pf_bih_check).
 */
static pf_bih_box node_boxes(collapse *c, uint32_t n)
{
    const pf_bih *bih = c->bih;
    const pf_bih_node *node = &bih->nodes[n];
    pf_bih_box b = pf_bih_box_empty();
    if (pf_bih_is_leaf(node)) {
        uint32_t first = pf_bih_leaf_first(node), count = pf_bih_leaf_count(node);
        for (uint32_t v = 3 * first; v < 3 * (first + count); v++)
            pf_bih_box_merge(&b, bih->vertices[v], bih->vertices[v]);
        c->leaf_block[n] = copy_leaf(c, first, count);
    } else {
        uint32_t child = pf_bih_first_child(node);
        pf_bih_box left = node_boxes(c, child), right = node_boxes(c, child + 1);
        b = left;
        pf_bih_box_merge(&b, right.lo, right.hi);
    }
    c->boxes[n] = b;
    return b;
}

/*
 * Wide node for the BIH subtree at n (returns its index): n's children, then
 * the inner child with the largest box replaced by its two children until 8
 * slots are taken or only leaves are left. Empty subtrees are dropped. The
 * node is numbered before its children, so a walk reads nodes forwards.
 */
static uint32_t collapse_node(collapse *c, uint32_t n)
{
    const pf_bih *bih = c->bih;
    uint32_t slots[PF_BIH_WIDE_SLOTS], used = 0;
    if (pf_bih_is_leaf(&bih->nodes[n])) {
        slots[used++] = n;
    } else {
        slots[used++] = pf_bih_first_child(&bih->nodes[n]);
        slots[used++] = slots[0] + 1;
    }
    while (used < PF_BIH_WIDE_SLOTS) {
        int widest = -1;
        float widest_area = -1.0f;
        for (uint32_t i = 0; i < used; i++) {
            const pf_bih_box *b = &c->boxes[slots[i]];
            float area = pf_bih_box_half_area(b);
            if (!pf_bih_is_leaf(&bih->nodes[slots[i]]) && !pf_bih_box_is_empty(b) &&
                area > widest_area) {
                widest = (int)i;
                widest_area = area;
            }
        }
        /* An inner node with an empty box (only empty leaves below) is dropped below. */
        if (widest < 0)
            break;
        uint32_t child = pf_bih_first_child(&bih->nodes[slots[widest]]);
        slots[widest] = child;
        slots[used++] = child + 1;
    }
    uint32_t index = c->count++;
    pf_bih_wide_node *node = &c->nodes[index];
    uint32_t filled = 0;
    for (uint32_t i = 0; i < PF_BIH_WIDE_SLOTS; i++) {
        for (int k = 0; k < 3; k++) {
            node->lo[k][i] = INFINITY;
            node->hi[k][i] = -INFINITY;
        }
        node->child[i] = PF_BIH_WIDE_LEAF;
        node->count[i] = 0;
    }
    for (uint32_t i = 0; i < used; i++) {
        const pf_bih_box *b = &c->boxes[slots[i]];
        if (pf_bih_box_is_empty(b))
            continue; /* no triangle below: no ray needs it */
        for (int k = 0; k < 3; k++) {
            node->lo[k][filled] = b->lo[k];
            node->hi[k][filled] = b->hi[k];
        }
        const pf_bih_node *bn = &bih->nodes[slots[i]];
        if (pf_bih_is_leaf(bn)) {
            node->child[filled] = PF_BIH_WIDE_LEAF | c->leaf_block[slots[i]];
            node->count[filled] = pf_bih_leaf_count(bn);
        }
        filled++;
    }
    /* The children after the slots are written: c->nodes does not move (capacity is fixed). */
    filled = 0;
    for (uint32_t i = 0; i < used; i++) {
        if (pf_bih_box_is_empty(&c->boxes[slots[i]]))
            continue;
        if (!pf_bih_is_leaf(&bih->nodes[slots[i]])) {
            uint32_t child = collapse_node(c, slots[i]);
            c->nodes[index].child[filled] = child;
        }
        filled++;
    }
    return index;
}

pf_status pf_bih_wide_build(const pf_bih *bih, pf_bih_wide *out, pf_error *err)
{
    *out = (pf_bih_wide){0};
    /* Every wide node but the root takes an inner BIH node, so node_count bounds them. */
    uint32_t capacity = bih->node_count + 1, block_capacity = 0;
    for (uint32_t n = 0; n < bih->node_count; n++)
        if (pf_bih_is_leaf(&bih->nodes[n]))
            block_capacity += blocks_for(pf_bih_leaf_count(&bih->nodes[n]));
    pf_bih_box *boxes = malloc((size_t)bih->node_count * sizeof *boxes);
    uint32_t *leaf_block = malloc((size_t)bih->node_count * sizeof *leaf_block);
    pf_bih_wide_node *nodes = pf_bih_alloc_large((size_t)capacity * sizeof *nodes);
    pf_bih_wide_block *blocks =
        pf_bih_alloc_large(((size_t)block_capacity + 1) * sizeof *blocks);
    if (!boxes || !leaf_block || !nodes || !blocks) {
        free(blocks);
        free(nodes);
        free(leaf_block);
        free(boxes);
        return pf_error_set(err, PF_ERR_NOMEM,
                            "BIH wide view: out of memory for %u nodes and %u blocks", capacity,
                            block_capacity);
    }
    collapse c = {bih, boxes, leaf_block, nodes, 0, blocks, 0};
    node_boxes(&c, 0);
    collapse_node(&c, 0);
    free(leaf_block);
    free(boxes);
    *out = (pf_bih_wide){c.count, nodes, c.block_count, blocks};
    return PF_OK;
}

void pf_bih_wide_free(pf_bih_wide *wide)
{
    free(wide->nodes);
    free(wide->blocks);
    *wide = (pf_bih_wide){0};
}

int pf_bih_wide_available(void)
{
#if defined(PF_BIH_AVX2_WIDE)
    return __builtin_cpu_supports("avx2");
#else
    return 0;
#endif
}

pf_status pf_bih_wide_trace_rays(const pf_bih *bih, const pf_bih_wide *wide, const pf_ray *rays,
                                 uint32_t count, int any_hit, pf_hit *hits, pf_error *err)
{
#if defined(PF_BIH_AVX2_WIDE)
    if (pf_bih_wide_available())
        return pf_bih_wide_trace_avx2(bih, wide, rays, count, any_hit, hits, err);
#endif
    (void)wide;
    return pf_bih_trace_cpu_rays(bih, rays, count, any_hit, hits, err);
}
