/*
 * The CPU reference builder: Wächter & Keller's top-down BIH with the global
 * heuristic (see pf_bih_build_cpu in pf_bih.h for the contract).
 */
#include "bih_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/*
 * A float box halves at most ~280 times per axis before its midpoint stops
 * moving (2^128 down to one ulp of 2^-126), so 3 × 300 halvings cover any
 * box; the loop also stops as soon as the midpoint makes no progress.
 */
#define MAX_CANDIDATE_HALVINGS 900u

typedef struct build_state {
    float (*tri_min)[3];     /* per frame triangle: bounding box */
    float (*tri_max)[3];
    float (*centre)[3];      /* bounding-box centre: what the heuristic classifies */
    uint32_t *order;         /* leaf-order position -> frame triangle (being partitioned) */
    pf_bih_node *nodes;
    uint32_t node_count;
    uint32_t leaf_size;
    uint32_t max_depth;
    uint32_t depth, leaf_count, largest_leaf;
} build_state;

typedef struct keyed_triangle {
    float key;
    uint32_t triangle;
} keyed_triangle;

static int compare_keyed(const void *a, const void *b)
{
    const keyed_triangle *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->triangle < y->triangle ? -1 : x->triangle > y->triangle;
}

static uint32_t ceil_log2(uint32_t value)
{
    uint32_t bits = 0;
    while (bits < 32 && (1ull << bits) < value)
        bits++;
    return bits;
}

static void make_leaf(build_state *s, uint32_t node, uint32_t first, uint32_t count,
                      uint32_t depth)
{
    s->nodes[node].clip[0] = pf_bih_bits_to_float(first);
    s->nodes[node].clip[1] = pf_bih_bits_to_float(count);
    s->nodes[node].word = PF_BIH_LEAF;
    s->leaf_count++;
    if (count > s->largest_leaf)
        s->largest_leaf = count;
    if (depth > s->depth)
        s->depth = depth;
}

/*
 * The global heuristic: halve the candidate box along its longest axis until
 * the midpoint separates the centres (returns 1 with *axis, *plane) or can no
 * longer move (returns 0). cand is narrowed in place to the box that split.
 */
static int global_split(float cand_min[3], float cand_max[3], const float centre_min[3],
                        const float centre_max[3], int *axis, float *plane)
{
    for (uint32_t step = 0; step < MAX_CANDIDATE_HALVINGS; step++) {
        int a = 0;
        for (int k = 1; k < 3; k++)
            if (cand_max[k] - cand_min[k] > cand_max[a] - cand_min[a])
                a = k;
        /* Halves then sums, so huge coordinates cannot overflow. */
        float mid = 0.5f * cand_min[a] + 0.5f * cand_max[a];
        if (!(mid > cand_min[a] && mid < cand_max[a]))
            return 0;
        if (centre_max[a] <= mid) {
            cand_max[a] = mid;
        } else if (centre_min[a] > mid) {
            cand_min[a] = mid;
        } else {
            *axis = a;
            *plane = mid;
            return 1;
        }
    }
    return 0;
}

/* Median of the centres along their widest axis; ties by triangle index. */
static pf_status median_split(build_state *s, uint32_t first, uint32_t count,
                              const float centre_min[3], const float centre_max[3], int *axis,
                              pf_error *err)
{
    int a = 0;
    for (int k = 1; k < 3; k++)
        if (centre_max[k] - centre_min[k] > centre_max[a] - centre_min[a])
            a = k;
    keyed_triangle *keyed = malloc((size_t)count * sizeof *keyed);
    if (!keyed)
        return pf_error_set(err, PF_ERR_NOMEM, "BIH build: median split of %u triangles", count);
    for (uint32_t i = 0; i < count; i++)
        keyed[i] = (keyed_triangle){s->centre[s->order[first + i]][a], s->order[first + i]};
    qsort(keyed, count, sizeof *keyed, compare_keyed);
    for (uint32_t i = 0; i < count; i++)
        s->order[first + i] = keyed[i].triangle;
    free(keyed);
    *axis = a;
    return PF_OK;
}

static void centre_bounds(const build_state *s, uint32_t first, uint32_t count, float lo[3],
                          float hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = INFINITY;
        hi[k] = -INFINITY;
    }
    for (uint32_t i = first; i < first + count; i++)
        for (int k = 0; k < 3; k++) {
            float c = s->centre[s->order[i]][k];
            lo[k] = c < lo[k] ? c : lo[k];
            hi[k] = c > hi[k] ? c : hi[k];
        }
}

/* depth: inner nodes above this one. cand: the candidate box holding the centres. */
static pf_status build_node(build_state *s, uint32_t node, uint32_t first, uint32_t count,
                            float cand_min[3], float cand_max[3], uint32_t depth, pf_error *err)
{
    uint32_t levels_needed = ceil_log2((count + s->leaf_size - 1) / s->leaf_size);
    if (count <= s->leaf_size || depth >= s->max_depth) {
        make_leaf(s, node, first, count, depth);
        return PF_OK;
    }
    float centre_min[3], centre_max[3];
    centre_bounds(s, first, count, centre_min, centre_max);
    int axis = 0;
    float plane = 0;
    uint32_t left_count = 0;
    float left_min[3], left_max[3], right_min[3], right_max[3];
    /* Keep a margin of levels so the median split can still reach leaves of K. */
    int use_global = levels_needed + 1 < s->max_depth - depth &&
                     global_split(cand_min, cand_max, centre_min, centre_max, &axis, &plane);
    if (use_global) {
        uint32_t lo = first, hi = first + count;
        while (lo < hi) {
            if (s->centre[s->order[lo]][axis] <= plane) {
                lo++;
            } else {
                hi--;
                uint32_t swap = s->order[lo];
                s->order[lo] = s->order[hi];
                s->order[hi] = swap;
            }
        }
        left_count = lo - first;
        memcpy(left_min, cand_min, sizeof left_min);
        memcpy(left_max, cand_max, sizeof left_max);
        memcpy(right_min, cand_min, sizeof right_min);
        memcpy(right_max, cand_max, sizeof right_max);
        left_max[axis] = plane;
        right_min[axis] = plane;
    } else {
        pf_status status = median_split(s, first, count, centre_min, centre_max, &axis, err);
        if (status != PF_OK)
            return status;
        left_count = count / 2;
        centre_bounds(s, first, left_count, left_min, left_max);
        centre_bounds(s, first + left_count, count - left_count, right_min, right_max);
    }
    float left_clip = -INFINITY, right_clip = INFINITY;
    for (uint32_t i = first; i < first + left_count; i++) {
        float v = s->tri_max[s->order[i]][axis];
        left_clip = v > left_clip ? v : left_clip;
    }
    for (uint32_t i = first + left_count; i < first + count; i++) {
        float v = s->tri_min[s->order[i]][axis];
        right_clip = v < right_clip ? v : right_clip;
    }
    uint32_t child = s->node_count;
    s->node_count += 2;
    s->nodes[node].clip[0] = left_clip;
    s->nodes[node].clip[1] = right_clip;
    s->nodes[node].word = (child << 2) | (uint32_t)axis;
    pf_status status = build_node(s, child, first, left_count, left_min, left_max, depth + 1, err);
    if (status == PF_OK)
        status = build_node(s, child + 1, first + left_count, count - left_count, right_min,
                            right_max, depth + 1, err);
    return status;
}

pf_status pf_bih_build_cpu(const pf_scene_frame *frame, const pf_bih_build_options *options,
                           pf_bih *out, pf_error *err)
{
    if (!frame || !out)
        return pf_error_set(err, PF_ERR_INVALID, "pf_bih_build_cpu: NULL argument");
    memset(out, 0, sizeof *out);
    uint32_t leaf_size = options && options->max_leaf_size ? options->max_leaf_size
                                                           : PF_BIH_DEFAULT_LEAF_SIZE;
    uint32_t max_depth = options && options->max_depth ? options->max_depth : PF_BIH_STACK_SIZE;
    if (max_depth > PF_BIH_STACK_SIZE)
        return pf_error_set(err, PF_ERR_INVALID,
                            "BIH build: max_depth %u exceeds the traversal stack (%u entries)",
                            max_depth, PF_BIH_STACK_SIZE);
    uint32_t n = frame->triangle_count;
    if (n > 0 && !frame->vertices)
        return pf_error_set(err, PF_ERR_INVALID, "BIH build: %u triangles but no vertices", n);
    if (n >= PF_BIH_MAX_NODES / 2)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "BIH build: %u triangles exceed the node index field (%u nodes)", n,
                            PF_BIH_MAX_NODES);
    build_state s = {0};
    s.leaf_size = leaf_size;
    s.max_depth = max_depth;
    size_t node_capacity = n > 0 ? 2 * (size_t)n - 1 : 1;
    s.nodes = calloc(node_capacity, sizeof *s.nodes);
    s.order = malloc((n ? n : 1) * sizeof *s.order);
    s.tri_min = malloc((n ? n : 1) * sizeof *s.tri_min);
    s.tri_max = malloc((n ? n : 1) * sizeof *s.tri_max);
    s.centre = malloc((n ? n : 1) * sizeof *s.centre);
    out->vertices = malloc((n ? 3 * (size_t)n : 1) * sizeof *out->vertices);
    pf_status status = PF_OK;
    if (!s.nodes || !s.order || !s.tri_min || !s.tri_max || !s.centre || !out->vertices)
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH build: %u triangles", n);
    float scene_min[3] = {0, 0, 0}, scene_max[3] = {0, 0, 0};
    for (uint32_t t = 0; status == PF_OK && t < n; t++) {
        for (int k = 0; k < 3; k++) {
            float lo = INFINITY, hi = -INFINITY;
            for (int c = 0; c < 3; c++) {
                float v = frame->vertices[3 * t + c][k];
                if (!isfinite(v)) {
                    status = pf_error_set(err, PF_ERR_INVALID,
                                          "BIH build: triangle %u vertex %d: non-finite coordinate",
                                          t, c);
                    break;
                }
                lo = v < lo ? v : lo;
                hi = v > hi ? v : hi;
            }
            s.tri_min[t][k] = lo;
            s.tri_max[t][k] = hi;
            s.centre[t][k] = 0.5f * lo + 0.5f * hi;
            scene_min[k] = t == 0 || lo < scene_min[k] ? lo : scene_min[k];
            scene_max[k] = t == 0 || hi > scene_max[k] ? hi : scene_max[k];
        }
        s.order[t] = t;
    }
    if (status == PF_OK) {
        s.node_count = 1;
        float cand_min[3], cand_max[3];
        memcpy(cand_min, scene_min, sizeof cand_min);
        memcpy(cand_max, scene_max, sizeof cand_max);
        status = build_node(&s, 0, 0, n, cand_min, cand_max, 0, err);
    }
    if (status == PF_OK) {
        for (uint32_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++) {
                memcpy(out->vertices[3 * i + c], frame->vertices[3 * s.order[i] + c],
                       3 * sizeof(float));
                out->vertices[3 * i + c][3] = 0.0f;
            }
        out->nodes = s.nodes;
        out->node_count = s.node_count;
        out->triangle_count = n;
        out->triangle_index = s.order;
        memcpy(out->bounds_min, scene_min, sizeof scene_min);
        memcpy(out->bounds_max, scene_max, sizeof scene_max);
        out->depth = s.depth;
        out->leaf_count = s.leaf_count;
        out->largest_leaf = s.largest_leaf;
    } else {
        free(s.nodes);
        free(s.order);
        free(out->vertices);
        memset(out, 0, sizeof *out);
    }
    free(s.tri_min);
    free(s.tri_max);
    free(s.centre);
    return status;
}

void pf_bih_free(pf_bih *bih)
{
    if (!bih)
        return;
    free(bih->nodes);
    free(bih->vertices);
    free(bih->triangle_index);
    memset(bih, 0, sizeof *bih);
}
