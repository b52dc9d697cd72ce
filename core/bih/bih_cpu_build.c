/*
 * The CPU builder (see pf_bih_build_cpu in pf_bih.h for the contract): top
 * down, with either Wächter & Keller's global heuristic (the reference) or a
 * binned SAH with empty-space cuts.
 *
 * Speed: each triangle's box is computed once into an array of build_prim
 * (box + frame index) that the build partitions in place, so every pass reads
 * memory in order. The root's partition runs in two pieces on two threads
 * (partition_in_parts), and its two children on a thread each (FORK_DEPTH);
 * the top of the tree is built so until the subtrees are small enough
 * (PARALLEL_SUBTREE_FRACTION of the triangles). Those subtrees are then built
 * by the worker threads, each into its own node buffer, and stitched (also on
 * the threads) in subtree order. Which subtrees exist depends only on
 * the triangles and options, never on the thread count or timing, so the tree
 * is the same on every run.
 */
#include "bih_internal.h"
#include "bih_lanes4.h"

#include <math.h>
#include <pthread.h>
#include <stddef.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

/*
 * A float box halves at most ~280 times per axis before its midpoint stops
 * moving (2^128 down to one ulp of 2^-126), so 3 × 300 halvings cover any
 * box; the loop also stops as soon as the midpoint makes no progress.
 */
#define MAX_CANDIDATE_HALVINGS 900u
/* Binned SAH: 16 bins per axis is within 1 % of a full sweep (Wald, "On fast
 * Construction of SAH-based Bounding Volume Hierarchies", RT 2007). */
#define SAH_BINS 16
/*
 * Empty-space cut (Wächter & Keller 2006, §3.3): a node with one empty child
 * that moves one side of the clip region onto the triangles' box. With
 * C_trav = C_isect = 1 it pays when A(cut) + n·A(cut) < n·A(region) for a
 * leaf-like cost of n; the ratio is capped so that a subtree of many triangles
 * is not cut for a sliver (each cut is one more level of the bounded depth).
 */
#define EMPTY_CUT_MAX_AREA_RATIO 0.8f
/* Subtrees of at most this fraction of the triangles go to the worker threads
 * (1/16: enough subtrees for 2 threads to balance). */
#define PARALLEL_SUBTREE_FRACTION 16u
/* Below this many triangles a thread costs more than it saves. */
#define PARALLEL_MIN_TRIANGLES 8192u
/* The top tree's nodes down to this depth build their right child on a
 * second thread while the left one builds here (depth 0: the root's two
 * halves), so the top levels' partitions, one pass over all triangles each,
 * are not all on one thread. Decided by the triangle count, not the threads:
 * with one thread the right child builds after the left, with the same tree. */
#define FORK_DEPTH 1u

/*
 * The build's arrays of many megabytes (prims, leaf-order vertices, nodes) on
 * transparent huge pages where the kernel offers them on request: the build
 * writes each array once, fresh from mmap, and on this project's VMs a 4 KiB
 * page fault costs ~3 µs, so 1M triangles' ~130 MB paid ~18 % of the build's
 * CPU time in faults; 2 MiB pages cut that share by half (bench/RESULTS.md).
 * Smaller blocks are 64-byte aligned (a cache line, and AVX loads). Freed
 * with free() like any malloc'd block.
 */
#define LARGE_ALLOCATION_BYTES (4u << 20)
#define HUGE_PAGE_BYTES (2u << 20)

void *pf_bih_alloc_large(size_t bytes)
{
    void *block = NULL;
#ifdef MADV_HUGEPAGE
    if (bytes >= LARGE_ALLOCATION_BYTES) {
        if (posix_memalign(&block, HUGE_PAGE_BYTES, bytes) != 0)
            return NULL;
        /* Only a hint: without huge pages the block works the same. */
        (void)madvise(block, bytes, MADV_HUGEPAGE);
        return block;
    }
#endif
    return posix_memalign(&block, 64, bytes) == 0 ? block : NULL;
}

typedef struct build_prim {
    float lo[3], hi[3];  /* the triangle's bounding box */
    uint32_t triangle;   /* frame index */
} build_prim;

typedef struct build_config {
    build_prim *prims;
    uint32_t leaf_size;
    uint32_t max_depth;
    uint32_t heuristic;
    uint32_t defer_below; /* subtrees of at most this many triangles become tasks; 0 = none */
    uint32_t threads;     /* the build's threads (a fork runs on a thread of its own when > 1) */
} build_config;

typedef struct subtree_task {
    uint32_t node;        /* placeholder in the top tree */
    uint32_t first, count, depth;
    pf_bih_box region, bounds, centres;
    /* Filled by the worker: */
    pf_bih_node *nodes;   /* node 0 = the subtree root */
    uint32_t node_count;
    uint32_t depth_reached, leaf_count, largest_leaf;
    pf_status status;
    pf_error err;
    uint32_t base;        /* where its nodes after the root go in the tree */
} subtree_task;

/* One thread's build of one (sub)tree into its own growable node buffer. */
typedef struct subtree_builder {
    const build_config *cfg;
    pf_bih_node *nodes;
    uint32_t node_count, node_capacity;
    uint32_t depth, leaf_count, largest_leaf;
    subtree_task *tasks;  /* top tree only: subtrees deferred to the workers */
    uint32_t task_count, task_capacity;
    pf_error *err;
} subtree_builder;

static float prim_centre(const build_prim *p, int axis)
{
    return 0.5f * p->lo[axis] + 0.5f * p->hi[axis];
}

static uint32_t ceil_log2(uint32_t value)
{
    uint32_t bits = 0;
    while (bits < 32 && (1ull << bits) < value)
        bits++;
    return bits;
}

static int longest_axis(const pf_bih_box *box)
{
    int a = 0;
    for (int k = 1; k < 3; k++)
        if (box->hi[k] - box->lo[k] > box->hi[a] - box->lo[a])
            a = k;
    return a;
}

/* Triangle box and centre bounds of prims[first, first + count). */
static void prim_bounds(const build_prim *prims, uint32_t first, uint32_t count,
                        pf_bih_box *bounds, pf_bih_box *centres)
{
    *bounds = pf_bih_box_empty();
    *centres = pf_bih_box_empty();
    for (uint32_t i = first; i < first + count; i++) {
        float c[3] = {prim_centre(&prims[i], 0), prim_centre(&prims[i], 1),
                      prim_centre(&prims[i], 2)};
        pf_bih_box_merge(bounds, prims[i].lo, prims[i].hi);
        pf_bih_box_merge(centres, c, c);
    }
}

/*
 * How a split sends a triangle left: its centre along axis at most plane
 * (global heuristic), or, with bins, its bin at most last_bin (SAH).
 */
typedef struct split_rule {
    int axis, use_bins, last_bin;
    float plane, bin_lo, bin_scale;
} split_rule;

static int bin_of(float centre, float lo, float scale);

/*
 * A prim's box corners as vectors (lane 3 zero), and its centre on all three
 * axes in one vector: each corner read as 4 floats (lo with hi[0], hi with the
 * triangle index), the extra lane cleared before the arithmetic, since an index
 * read as a float is subnormal, which the multiply would take a slow path for.
 * Lane by lane the centre is prim_centre's.
 */
static inline void prim_corners4(const build_prim *p, lanes4_f *lo, lanes4_f *hi)
{
    const lanes4_i xyz = {-1, -1, -1, 0};
    *lo = (lanes4_f)((lanes4_i)lanes4_load(p->lo) & xyz);
    *hi = (lanes4_f)((lanes4_i)lanes4_load(p->hi) & xyz);
}
_Static_assert(offsetof(build_prim, hi) + 4 * sizeof(float) <= sizeof(build_prim),
               "prim_corners4 reads 4 floats at hi");

static inline lanes4_f corners_centre4(lanes4_f lo, lanes4_f hi)
{
    return 0.5f * lo + 0.5f * hi;
}

static inline lanes4_f prim_centre4(const build_prim *p)
{
    lanes4_f lo, hi;
    prim_corners4(p, &lo, &hi);
    return corners_centre4(lo, hi);
}

/* One side's running bounds in partition: its centres, and its clip value along the axis. */
typedef struct side_bounds {
    lanes4_f lo, hi;
    float clip; /* left: largest max, right: smallest min */
} side_bounds;

static inline void side_merge_centre(side_bounds *side, lanes4_f centre)
{
    side->lo = lanes4_min(side->lo, centre);
    side->hi = lanes4_max(side->hi, centre);
}

/* p counted on the left side: its centre, and its max along the axis into the clip. */
static inline void side_take_left(side_bounds *left, const build_prim *p, lanes4_f centre, int axis)
{
    side_merge_centre(left, centre);
    left->clip = pf_bih_max(left->clip, p->hi[axis]);
}

/* p counted on the right side: its centre, and its min along the axis into the clip. */
static inline void side_take_right(side_bounds *right, const build_prim *p, lanes4_f centre,
                                   int axis)
{
    side_merge_centre(right, centre);
    right->clip = pf_bih_min(right->clip, p->lo[axis]);
}

static inline int goes_left(const build_prim *p, lanes4_f centre, const split_rule *rule,
                            lanes4_f plane, unsigned axis_bit, int use_bins)
{
    if (use_bins)
        return bin_of(prim_centre(p, rule->axis), rule->bin_lo, rule->bin_scale) <= rule->last_bin;
    return (lanes4_bits(centre <= plane) & axis_bit) != 0;
}

static pf_bih_box side_centre_box(const side_bounds *side)
{
    return (pf_bih_box){{side->lo[0], side->lo[1], side->lo[2]},
                        {side->hi[0], side->hi[1], side->hi[2]}};
}

/*
 * Partitions prims[first, first + count) in place, left side first, and in
 * the same pass gathers each side's centre bounds and clip value along the
 * axis (left: largest max, right: smallest min). Returns the left count.
 *
 * Hoare's scheme: a scan up to the first right prim, a scan down to the first
 * left one, then one swap, so each prim is read once and only misplaced pairs
 * move. The earlier one-ended form swapped every right prim with the top and
 * read it back at once, and that read waited on the store it had just made
 * (a quarter of the pass's samples on one instruction). The centres and their
 * bounds are 4-lane vectors (one multiply-add and one min and max a prim
 * instead of three each), and the pass is compiled once per rule kind
 * (use_bins a constant), so the global heuristic's plane test is one compare.
 */
static inline __attribute__((always_inline)) uint32_t
partition_pass(build_prim *prims, uint32_t first, uint32_t count, const split_rule *rule,
               pf_bih_box *left_centres, pf_bih_box *right_centres, float *left_clip,
               float *right_clip, const int use_bins)
{
    const int axis = rule->axis;
    const lanes4_f plane = {rule->plane, rule->plane, rule->plane, rule->plane};
    const unsigned axis_bit = 1u << axis;
    const lanes4_f empty_lo = {INFINITY, INFINITY, INFINITY, INFINITY};
    const lanes4_f empty_hi = -empty_lo;
    side_bounds left = {empty_lo, empty_hi, -INFINITY};
    side_bounds right = {empty_lo, empty_hi, INFINITY};
    /* [first, lo): left; [hi, first + count): right; [lo, hi): not yet read. */
    uint32_t lo = first, hi = first + count;
    for (;;) {
        lanes4_f centre = {0};
        while (lo < hi) {
            centre = prim_centre4(&prims[lo]);
            if (!goes_left(&prims[lo], centre, rule, plane, axis_bit, use_bins))
                break;
            side_take_left(&left, &prims[lo++], centre, axis);
        }
        if (lo == hi)
            break;
        /* prims[lo] goes right; look for a left one above it to swap with. */
        side_take_right(&right, &prims[lo], centre, axis);
        int found = 0;
        while (--hi > lo) {
            lanes4_f above = prim_centre4(&prims[hi]);
            if (goes_left(&prims[hi], above, rule, plane, axis_bit, use_bins)) {
                side_take_left(&left, &prims[hi], above, axis);
                found = 1;
                break;
            }
            side_take_right(&right, &prims[hi], above, axis);
        }
        if (!found)
            break;
        build_prim swap = prims[lo];
        prims[lo] = prims[hi];
        prims[hi] = swap;
        lo++;
    }
    *left_centres = side_centre_box(&left);
    *right_centres = side_centre_box(&right);
    *left_clip = left.clip;
    *right_clip = right.clip;
    return lo - first;
}

static uint32_t partition(build_prim *prims, uint32_t first, uint32_t count,
                          const split_rule *rule, pf_bih_box *left_centres,
                          pf_bih_box *right_centres, float *left_clip, float *right_clip)
{
    if (rule->use_bins)
        return partition_pass(prims, first, count, rule, left_centres, right_centres, left_clip,
                              right_clip, 1);
    return partition_pass(prims, first, count, rule, left_centres, right_centres, left_clip,
                          right_clip, 0);
}

static void parallel_run(void (*run)(void *, uint32_t, uint32_t), void *context, uint32_t parts);

/*
 * The root's partition in ROOT_PARTITION_PARTS pieces, one per thread: each
 * piece is partitioned on its own (partition above), then the left prims of
 * the later pieces are swapped past the right prims of the earlier ones.
 * Without it the root's pass over all triangles ran on one thread while the
 * others waited. The pieces are fixed, not the threads, so the prims' order,
 * like the tree, is the same for any thread count.
 */
#define ROOT_PARTITION_PARTS 2u

typedef struct parts_context {
    build_prim *prims;
    uint32_t first, count;
    const split_rule *rule;
    uint32_t left_count[ROOT_PARTITION_PARTS];
    pf_bih_box left_centres[ROOT_PARTITION_PARTS], right_centres[ROOT_PARTITION_PARTS];
    float left_clip[ROOT_PARTITION_PARTS], right_clip[ROOT_PARTITION_PARTS];
    /* The swap: prims[swap_a + i] with prims[swap_b + i] for i < swap_count. */
    uint32_t swap_a, swap_b, swap_count;
} parts_context;

static uint32_t part_begin(uint32_t first, uint32_t count, uint32_t part, uint32_t parts)
{
    return first + (uint32_t)((uint64_t)count * part / parts);
}

static void partition_part(void *arg, uint32_t part, uint32_t parts)
{
    parts_context *c = arg;
    uint32_t begin = part_begin(c->first, c->count, part, parts);
    uint32_t end = part_begin(c->first, c->count, part + 1, parts);
    c->left_count[part] = partition(c->prims, begin, end - begin, c->rule, &c->left_centres[part],
                                    &c->right_centres[part], &c->left_clip[part],
                                    &c->right_clip[part]);
}

static void swap_part(void *arg, uint32_t part, uint32_t parts)
{
    parts_context *c = arg;
    uint32_t begin = part_begin(0, c->swap_count, part, parts);
    uint32_t end = part_begin(0, c->swap_count, part + 1, parts);
    for (uint32_t i = begin; i < end; i++) {
        build_prim swap = c->prims[c->swap_a + i];
        c->prims[c->swap_a + i] = c->prims[c->swap_b + i];
        c->prims[c->swap_b + i] = swap;
    }
}

/* run over parts pieces: one thread each when there are threads enough, else in turn here. */
static void run_parts(void (*run)(void *, uint32_t, uint32_t), void *context, uint32_t parts,
                      uint32_t threads)
{
    if (threads >= parts) {
        parallel_run(run, context, parts);
        return;
    }
    for (uint32_t part = 0; part < parts; part++)
        run(context, part, parts);
}

static uint32_t partition_in_parts(build_prim *prims, uint32_t first, uint32_t count,
                                   const split_rule *rule, uint32_t threads,
                                   pf_bih_box *left_centres, pf_bih_box *right_centres,
                                   float *left_clip, float *right_clip)
{
    parts_context c = {.prims = prims, .first = first, .count = count, .rule = rule};
    uint32_t parts = ROOT_PARTITION_PARTS;
    run_parts(partition_part, &c, parts, threads);
    /* [left 0 | right 0] [left 1 | right 1] ... folded into one left run, piece by piece. */
    *left_centres = c.left_centres[0];
    *right_centres = c.right_centres[0];
    *left_clip = c.left_clip[0];
    *right_clip = c.right_clip[0];
    uint32_t left_end = first + c.left_count[0];
    for (uint32_t part = 1; part < parts; part++) {
        uint32_t begin = part_begin(first, count, part, parts);
        uint32_t right_before = begin - left_end, left_here = c.left_count[part];
        c.swap_count = right_before < left_here ? right_before : left_here;
        c.swap_a = left_end;
        c.swap_b = begin + left_here - c.swap_count;
        run_parts(swap_part, &c, parts, threads);
        left_end += left_here;
        pf_bih_box_merge(left_centres, c.left_centres[part].lo, c.left_centres[part].hi);
        pf_bih_box_merge(right_centres, c.right_centres[part].lo, c.right_centres[part].hi);
        *left_clip = pf_bih_max(*left_clip, c.left_clip[part]);
        *right_clip = pf_bih_min(*right_clip, c.right_clip[part]);
    }
    return left_end - first;
}

/* Room for extra more nodes in b's buffer (doubling), within the node index field. */
static pf_status reserve_nodes(subtree_builder *b, uint32_t extra)
{
    uint64_t needed = (uint64_t)b->node_count + extra;
    if (needed <= b->node_capacity)
        return PF_OK;
    uint64_t capacity = b->node_capacity ? 2 * (uint64_t)b->node_capacity : 64;
    while (capacity < needed)
        capacity *= 2;
    if (capacity > PF_BIH_MAX_NODES)
        capacity = PF_BIH_MAX_NODES;
    if (needed > capacity)
        return pf_error_set(b->err, PF_ERR_LIMIT,
                            "BIH build: more than %u nodes (the node index field)",
                            PF_BIH_MAX_NODES);
    pf_bih_node *grown = realloc(b->nodes, (size_t)capacity * sizeof *grown);
    if (!grown)
        return pf_error_set(b->err, PF_ERR_NOMEM, "BIH build: %u nodes", (uint32_t)capacity);
    b->nodes = grown;
    b->node_capacity = (uint32_t)capacity;
    return PF_OK;
}

/* Appends two nodes (a sibling pair) and returns the first one's index. */
static pf_status alloc_pair(subtree_builder *b, uint32_t *index)
{
    pf_status status = reserve_nodes(b, 2);
    if (status != PF_OK)
        return status;
    *index = b->node_count;
    b->node_count += 2;
    return PF_OK;
}

static void make_leaf(subtree_builder *b, uint32_t node, uint32_t first, uint32_t count,
                      uint32_t depth)
{
    b->nodes[node].clip[0] = pf_bih_bits_to_float(first);
    b->nodes[node].clip[1] = pf_bih_bits_to_float(count);
    b->nodes[node].word = PF_BIH_LEAF;
    if (count > 0)
        b->leaf_count++;
    if (count > b->largest_leaf)
        b->largest_leaf = count;
    if (depth > b->depth)
        b->depth = depth;
}

/*
 * The global heuristic: halve the candidate box along its longest axis until
 * the midpoint separates the centres (returns 1 with *axis, *plane) or can no
 * longer move (returns 0). cand is narrowed in place to the box that split.
 */
static int global_split(pf_bih_box *cand, const pf_bih_box *centres, int *axis, float *plane)
{
    for (uint32_t step = 0; step < MAX_CANDIDATE_HALVINGS; step++) {
        int a = longest_axis(cand);
        /* Halves then sums, so huge coordinates cannot overflow. */
        float mid = 0.5f * cand->lo[a] + 0.5f * cand->hi[a];
        if (!(mid > cand->lo[a] && mid < cand->hi[a]))
            return 0;
        if (centres->hi[a] <= mid) {
            cand->hi[a] = mid;
        } else if (centres->lo[a] > mid) {
            cand->lo[a] = mid;
        } else {
            *axis = a;
            *plane = mid;
            return 1;
        }
    }
    return 0;
}

typedef struct keyed_prim {
    float key;           /* centre along the median axis */
    uint32_t triangle;   /* tie-break */
    uint32_t position;   /* where the prim is now */
} keyed_prim;

static int compare_keyed(const void *a, const void *b)
{
    const keyed_prim *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return x->triangle < y->triangle ? -1 : x->triangle > y->triangle;
}

/* Sorts by centre along the centres' widest axis, ties by triangle index; -1 when out of memory. */
static int median_split(build_prim *prims, uint32_t first, uint32_t count,
                        const pf_bih_box *centres)
{
    int a = longest_axis(centres);
    keyed_prim *keyed = malloc((size_t)count * sizeof *keyed);
    build_prim *sorted = malloc((size_t)count * sizeof *sorted);
    if (!keyed || !sorted) {
        free(keyed);
        free(sorted);
        return -1;
    }
    for (uint32_t i = 0; i < count; i++)
        keyed[i] = (keyed_prim){prim_centre(&prims[first + i], a), prims[first + i].triangle,
                                first + i};
    qsort(keyed, count, sizeof *keyed, compare_keyed);
    for (uint32_t i = 0; i < count; i++)
        sorted[i] = prims[keyed[i].position];
    memcpy(prims + first, sorted, (size_t)count * sizeof *sorted);
    free(keyed);
    free(sorted);
    return a;
}

typedef struct sah_bin {
    pf_bih_box bounds;
    uint32_t count;
} sah_bin;

static int bin_of(float centre, float lo, float scale)
{
    int bin = (int)((centre - lo) * scale);
    return bin < 0 ? 0 : (bin >= SAH_BINS ? SAH_BINS - 1 : bin);
}

/*
 * The binning pass of sah_split: each prim's box into its centre's bin on all
 * three axes. The centre, its three bins and the boxes' merges are 4-lane
 * vectors (prim_corners4; the bins' boxes as lo and hi vectors): the same
 * values as bin_of and pf_bih_box_merge one axis at a time, which made this
 * pass half of the SAH build's time.
 */
static void bin_prims(const build_prim *prims, uint32_t first, uint32_t count,
                      const pf_bih_box *centres, const float scale[3],
                      sah_bin bins[3][SAH_BINS])
{
    struct {
        lanes4_f lo, hi;
    } boxes[3][SAH_BINS];
    uint32_t counts[3][SAH_BINS] = {{0}};
    const lanes4_f empty_lo = {INFINITY, INFINITY, INFINITY, INFINITY};
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < SAH_BINS; i++) {
            boxes[k][i].lo = empty_lo;
            boxes[k][i].hi = -empty_lo;
        }
    const lanes4_f centre_lo = {centres->lo[0], centres->lo[1], centres->lo[2], 0.0f};
    const lanes4_f bin_scale = {scale[0], scale[1], scale[2], 0.0f};
    const lanes4_i last_bin = {SAH_BINS - 1, SAH_BINS - 1, SAH_BINS - 1, SAH_BINS - 1};
    for (uint32_t i = first; i < first + count; i++) {
        lanes4_f lo, hi;
        prim_corners4(&prims[i], &lo, &hi);
        /* bin_of on three axes: truncation as (int), then clamped to [0, SAH_BINS - 1]. */
        lanes4_i bin =
            __builtin_convertvector((corners_centre4(lo, hi) - centre_lo) * bin_scale, lanes4_i);
        bin &= ~(bin < 0);
        bin = (bin & ~(bin > last_bin)) | (last_bin & (bin > last_bin));
        for (int k = 0; k < 3; k++) {
            int b = bin[k];
            boxes[k][b].lo = lanes4_min(boxes[k][b].lo, lo);
            boxes[k][b].hi = lanes4_max(boxes[k][b].hi, hi);
            counts[k][b]++;
        }
    }
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < SAH_BINS; i++)
            bins[k][i] = (sah_bin){{{boxes[k][i].lo[0], boxes[k][i].lo[1], boxes[k][i].lo[2]},
                                    {boxes[k][i].hi[0], boxes[k][i].hi[1], boxes[k][i].hi[2]}},
                                   counts[k][i]};
}

typedef struct sah_choice {
    int axis, last_left_bin;
    float scale;
    pf_bih_box left_bounds, right_bounds;
} sah_choice;

/*
 * Binned SAH over the centres (all three axes in one pass): the split
 * minimising n_L·A(L) + n_R·A(R), A the half area of each side's triangle box.
 * Returns 0 when the centres coincide (no axis to bin).
 */
static int sah_split(const build_prim *prims, uint32_t first, uint32_t count,
                     const pf_bih_box *centres, sah_choice *choice)
{
    sah_bin bins[3][SAH_BINS];
    float scale[3];
    for (int k = 0; k < 3; k++) {
        float extent = centres->hi[k] - centres->lo[k];
        scale[k] = extent > 0.0f ? (float)SAH_BINS / extent : 0.0f;
    }
    bin_prims(prims, first, count, centres, scale, bins);
    float best_cost = INFINITY;
    int found = 0;
    for (int k = 0; k < 3; k++) {
        if (scale[k] == 0.0f)
            continue;
        /*
         * An empty bin leaves a side's box and count as they were, so its term is the
         * previous one: small nodes, most of whose bins are empty, skip most of the
         * sweep's merges and areas.
         */
        float right_cost[SAH_BINS];
        pf_bih_box right = pf_bih_box_empty();
        uint32_t right_count = 0;
        float right_term = INFINITY; /* no triangle on the right yet */
        for (int i = SAH_BINS - 1; i > 0; i--) {
            if (bins[k][i].count) {
                pf_bih_box_merge(&right, bins[k][i].bounds.lo, bins[k][i].bounds.hi);
                right_count += bins[k][i].count;
                right_term = (float)right_count * pf_bih_box_half_area(&right);
            }
            right_cost[i] = right_term;
        }
        pf_bih_box left = pf_bih_box_empty();
        uint32_t left_count = 0;
        float left_term = 0.0f;
        for (int i = 0; i < SAH_BINS - 1; i++) {
            if (bins[k][i].count) {
                pf_bih_box_merge(&left, bins[k][i].bounds.lo, bins[k][i].bounds.hi);
                left_count += bins[k][i].count;
                left_term = (float)left_count * pf_bih_box_half_area(&left);
            }
            if (!left_count)
                continue;
            float cost = left_term + right_cost[i + 1];
            if (cost < best_cost) {
                best_cost = cost;
                choice->axis = k;
                choice->last_left_bin = i;
                found = 1;
            }
        }
    }
    if (!found)
        return 0;
    int k = choice->axis;
    choice->scale = scale[k];
    choice->left_bounds = choice->right_bounds = pf_bih_box_empty();
    for (int i = 0; i < SAH_BINS; i++)
        pf_bih_box_merge(i <= choice->last_left_bin ? &choice->left_bounds : &choice->right_bounds,
                  bins[k][i].bounds.lo, bins[k][i].bounds.hi);
    return 1;
}

/*
 * The best empty-space cut of region down to bounds: the side whose move
 * shrinks the region's area most, when the smaller area pays for the extra
 * node (see EMPTY_CUT_MAX_AREA_RATIO). Returns 0 for no cut; else *axis and
 * *high (1: the region's upper side moves down to bounds).
 */
static int empty_cut(const pf_bih_box *region, const pf_bih_box *bounds, uint32_t count, int *axis,
                     int *high)
{
    float area = pf_bih_box_half_area(region);
    float limit = 1.0f - 1.0f / (float)count;
    if (limit > EMPTY_CUT_MAX_AREA_RATIO)
        limit = EMPTY_CUT_MAX_AREA_RATIO;
    float best = limit * area;
    int found = 0;
    for (int k = 0; k < 3; k++)
        for (int side = 0; side < 2; side++) {
            pf_bih_box cut = *region;
            if (side)
                cut.hi[k] = bounds->hi[k];
            else
                cut.lo[k] = bounds->lo[k];
            float cut_area = pf_bih_box_half_area(&cut);
            if (cut_area < best) {
                best = cut_area;
                *axis = k;
                *high = side;
                found = 1;
            }
        }
    return found;
}

/* Room for extra more deferred subtrees in b's list (doubling). */
static pf_status reserve_tasks(subtree_builder *b, uint32_t extra)
{
    if (b->task_count + extra <= b->task_capacity)
        return PF_OK;
    uint32_t capacity = b->task_capacity ? 2 * b->task_capacity : 64;
    while (capacity < b->task_count + extra)
        capacity *= 2;
    subtree_task *grown = realloc(b->tasks, capacity * sizeof *grown);
    if (!grown)
        return pf_error_set(b->err, PF_ERR_NOMEM, "BIH build: %u subtrees", capacity);
    b->tasks = grown;
    b->task_capacity = capacity;
    return PF_OK;
}

static pf_status defer_subtree(subtree_builder *b, uint32_t node, uint32_t first, uint32_t count,
                               const pf_bih_box *region, const pf_bih_box *bounds,
                               const pf_bih_box *centres, uint32_t depth)
{
    pf_status status = reserve_tasks(b, 1);
    if (status != PF_OK)
        return status;
    b->tasks[b->task_count++] = (subtree_task){node, first, count, depth, *region, *bounds,
                                               *centres, NULL, 0, 0, 0, 0, PF_OK, {0}, 0};
    return PF_OK;
}

static pf_status build_node(subtree_builder *b, uint32_t node, uint32_t first, uint32_t count,
                            pf_bih_box region, const pf_bih_box *bounds,
                            const pf_bih_box *centres, uint32_t depth);

/* Moves a subtree's nodes (root at node 0) into the tree: root to node, the rest from base on. */
static void stitch(pf_bih_node *nodes, uint32_t node, uint32_t base, const pf_bih_node *subtree,
                   uint32_t subtree_nodes)
{
    for (uint32_t i = 0; i < subtree_nodes; i++) {
        pf_bih_node n = subtree[i];
        if (!pf_bih_is_leaf(&n))
            n.word = ((pf_bih_first_child(&n) - 1 + base) << 2) | pf_bih_axis(&n);
        nodes[i == 0 ? node : base + i - 1] = n;
    }
}

/* A child of a top node built by its own builder (fork_child), maybe on a thread of its own. */
typedef struct fork_job {
    subtree_builder builder; /* node 0 = the child */
    pf_error err;
    uint32_t first, count, depth;
    pf_bih_box region, bounds, centres;
    pf_status status;
} fork_job;

static void *fork_entry(void *arg)
{
    fork_job *job = arg;
    job->status = build_node(&job->builder, 0, job->first, job->count, job->region,
                             &job->bounds, &job->centres, job->depth);
    return NULL;
}

/*
 * Moves a fork's nodes into b: its node 0 to node, the rest appended; its
 * deferred subtrees renumbered the same way and appended to b's, after b's
 * own, so the tree and the subtrees' order do not depend on the threads.
 */
static pf_status join_fork(subtree_builder *b, uint32_t node, fork_job *job)
{
    subtree_builder *f = &job->builder;
    pf_status status = job->status;
    if (status != PF_OK && b->err)
        *b->err = job->err;
    if (status == PF_OK)
        status = reserve_nodes(b, f->node_count - 1);
    if (status == PF_OK)
        status = reserve_tasks(b, f->task_count);
    uint32_t base = b->node_count;
    if (status == PF_OK) {
        stitch(b->nodes, node, base, f->nodes, f->node_count);
        b->node_count = base + (f->node_count - 1);
        for (uint32_t i = 0; i < f->task_count; i++) {
            subtree_task task = f->tasks[i];
            task.node = task.node == 0 ? node : base + task.node - 1;
            b->tasks[b->task_count++] = task;
        }
        if (f->depth > b->depth)
            b->depth = f->depth;
        b->leaf_count += f->leaf_count;
        if (f->largest_leaf > b->largest_leaf)
            b->largest_leaf = f->largest_leaf;
    }
    free(f->nodes);
    free(f->tasks);
    return status;
}

/* A node's partition: in pieces at the root of a build that has subtree tasks, else in one pass. */
static uint32_t split(const build_config *cfg, uint32_t depth, uint32_t first, uint32_t count,
                      const split_rule *rule, pf_bih_box *left_centres, pf_bih_box *right_centres,
                      float *left_clip, float *right_clip)
{
    if (depth == 0 && cfg->defer_below)
        return partition_in_parts(cfg->prims, first, count, rule, cfg->threads, left_centres,
                                  right_centres, left_clip, right_clip);
    return partition(cfg->prims, first, count, rule, left_centres, right_centres, left_clip,
                     right_clip);
}

/*
 * Builds the subtree of prims[first, first + count) at node. region: the box
 * the ancestors' clip planes leave (for the global heuristic, the candidate
 * box of W&K, which holds the centres); bounds, centres: the triangles' box
 * and centre bounds. depth: inner nodes above this one.
 */
static pf_status build_node(subtree_builder *b, uint32_t node, uint32_t first, uint32_t count,
                            pf_bih_box region, const pf_bih_box *bounds,
                            const pf_bih_box *centres, uint32_t depth)
{
    const build_config *cfg = b->cfg;
    if (count <= cfg->leaf_size || depth >= cfg->max_depth) {
        make_leaf(b, node, first, count, depth);
        return PF_OK;
    }
    if (cfg->defer_below && count <= cfg->defer_below)
        return defer_subtree(b, node, first, count, &region, bounds, centres, depth);
    uint32_t levels_needed = ceil_log2((count + cfg->leaf_size - 1) / cfg->leaf_size);
    /* Keep a margin of levels so the median split can still reach leaves of K. */
    int levels_to_spare = levels_needed + 1 < cfg->max_depth - depth;
    int sah = cfg->heuristic == PF_BIH_HEURISTIC_SAH;
    build_prim *prims = cfg->prims;
    uint32_t child;
    pf_status status;

    int cut_axis, cut_high;
    if (sah && levels_needed + 2 < cfg->max_depth - depth &&
        empty_cut(&region, bounds, count, &cut_axis, &cut_high)) {
        if ((status = alloc_pair(b, &child)) != PF_OK)
            return status;
        b->nodes[node].word = (child << 2) | (uint32_t)cut_axis;
        b->nodes[node].clip[0] = cut_high ? bounds->hi[cut_axis] : -INFINITY;
        b->nodes[node].clip[1] = cut_high ? INFINITY : bounds->lo[cut_axis];
        if (cut_high)
            region.hi[cut_axis] = bounds->hi[cut_axis];
        else
            region.lo[cut_axis] = bounds->lo[cut_axis];
        make_leaf(b, cut_high ? child + 1 : child, first, 0, depth + 1);
        return build_node(b, cut_high ? child : child + 1, first, count, region, bounds, centres,
                          depth + 1);
    }

    int axis = 0;
    uint32_t left_count = 0;
    pf_bih_box left_region = region, right_region = region;
    pf_bih_box left_bounds, right_bounds, left_centres, right_centres;
    sah_choice choice;
    float plane = 0.0f;
    float left_clip, right_clip;
    if (sah && levels_to_spare && sah_split(prims, first, count, centres, &choice)) {
        axis = choice.axis;
        split_rule rule = {axis, 1, choice.last_left_bin, 0.0f, centres->lo[axis], choice.scale};
        left_count = split(cfg, depth, first, count, &rule, &left_centres, &right_centres,
                           &left_clip, &right_clip);
        left_bounds = choice.left_bounds;
        right_bounds = choice.right_bounds;
    } else if (!sah && levels_to_spare && global_split(&region, centres, &axis, &plane)) {
        split_rule rule = {axis, 0, 0, plane, 0.0f, 0.0f};
        left_count = split(cfg, depth, first, count, &rule, &left_centres, &right_centres,
                           &left_clip, &right_clip);
        left_region = right_region = region;
        left_region.hi[axis] = plane;
        right_region.lo[axis] = plane;
        /* The global heuristic needs only the clip values of the children's boxes. */
        left_bounds = right_bounds = pf_bih_box_empty();
        left_bounds.hi[axis] = left_clip;
        right_bounds.lo[axis] = right_clip;
    } else {
        axis = median_split(prims, first, count, centres);
        if (axis < 0)
            return pf_error_set(b->err, PF_ERR_NOMEM, "BIH build: median split of %u triangles",
                                count);
        left_count = count / 2;
        prim_bounds(prims, first, left_count, &left_bounds, &left_centres);
        prim_bounds(prims, first + left_count, count - left_count, &right_bounds, &right_centres);
        if (!sah) {
            /* W&K's candidate boxes hold the centres. */
            left_region = left_centres;
            right_region = right_centres;
        }
    }
    if (sah) {
        left_region.hi[axis] = left_bounds.hi[axis];
        right_region.lo[axis] = right_bounds.lo[axis];
    }
    if ((status = alloc_pair(b, &child)) != PF_OK)
        return status;
    b->nodes[node].clip[0] = left_bounds.hi[axis];
    b->nodes[node].clip[1] = right_bounds.lo[axis];
    b->nodes[node].word = (child << 2) | (uint32_t)axis;
    uint32_t right_count = count - left_count;
    /* defer_below is set only while the top tree builds: the subtrees never fork. */
    if (!(cfg->defer_below && depth < FORK_DEPTH && right_count > cfg->defer_below)) {
        status = build_node(b, child, first, left_count, left_region, &left_bounds,
                            &left_centres, depth + 1);
        if (status == PF_OK)
            status = build_node(b, child + 1, first + left_count, right_count, right_region,
                                &right_bounds, &right_centres, depth + 1);
        return status;
    }
    /* The right child on its own builder (and thread), the left one here. */
    fork_job *job = calloc(1, sizeof *job);
    if (!job)
        return pf_error_set(b->err, PF_ERR_NOMEM, "BIH build: a subtree of %u triangles",
                            right_count);
    job->builder = (subtree_builder){.cfg = cfg, .err = &job->err};
    job->builder.node_capacity = 2 * right_count + 1;
    job->builder.nodes = pf_bih_alloc_large((size_t)job->builder.node_capacity * sizeof(pf_bih_node));
    job->builder.node_count = 1;
    job->first = first + left_count;
    job->count = right_count;
    job->depth = depth + 1;
    job->region = right_region;
    job->bounds = right_bounds;
    job->centres = right_centres;
    job->status = job->builder.nodes ? PF_OK
                                     : pf_error_set(&job->err, PF_ERR_NOMEM,
                                                    "BIH build: a subtree of %u triangles",
                                                    right_count);
    pthread_t thread;
    int threaded = job->status == PF_OK && cfg->threads > 1 &&
                   pthread_create(&thread, NULL, fork_entry, job) == 0;
    status = build_node(b, child, first, left_count, left_region, &left_bounds, &left_centres,
                        depth + 1);
    if (threaded)
        pthread_join(thread, NULL);
    else if (job->status == PF_OK)
        fork_entry(job);
    pf_status joined = join_fork(b, child + 1, job);
    free(job);
    return status != PF_OK ? status : joined;
}

/* ---------- threads ---------- */

typedef struct parallel_job {
    void (*run)(void *context, uint32_t part, uint32_t parts);
    void *context;
    uint32_t part, parts;
} parallel_job;

static void *parallel_entry(void *arg)
{
    parallel_job *job = arg;
    job->run(job->context, job->part, job->parts);
    return NULL;
}

/*
 * Runs run(context, part, parts) for part = 0 .. parts-1, part 0 on the
 * calling thread. A thread that cannot start runs its part here afterwards:
 * the parts, not the threads, decide the result.
 */
static void parallel_run(void (*run)(void *, uint32_t, uint32_t), void *context, uint32_t parts)
{
    pthread_t threads[PF_BIH_MAX_BUILD_THREADS];
    parallel_job jobs[PF_BIH_MAX_BUILD_THREADS];
    int started[PF_BIH_MAX_BUILD_THREADS] = {0};
    for (uint32_t i = 1; i < parts; i++) {
        jobs[i] = (parallel_job){run, context, i, parts};
        started[i] = pthread_create(&threads[i], NULL, parallel_entry, &jobs[i]) == 0;
    }
    run(context, 0, parts);
    for (uint32_t i = 1; i < parts; i++) {
        if (started[i])
            pthread_join(threads[i], NULL);
        else
            run(context, i, parts);
    }
}

typedef struct setup_context {
    const pf_scene_frame *frame;
    build_prim *prims;
    pf_bih_box bounds[PF_BIH_MAX_BUILD_THREADS], centres[PF_BIH_MAX_BUILD_THREADS];
    uint32_t bad_triangle[PF_BIH_MAX_BUILD_THREADS]; /* first non-finite one, or UINT32_MAX */
} setup_context;

static void setup_part(void *arg, uint32_t part, uint32_t parts)
{
    setup_context *c = arg;
    uint32_t n = c->frame->triangle_count;
    uint32_t begin = (uint32_t)((uint64_t)n * part / parts);
    uint32_t end = (uint32_t)((uint64_t)n * (part + 1) / parts);
    pf_bih_box bounds = pf_bih_box_empty(), centres = pf_bih_box_empty();
    c->bad_triangle[part] = UINT32_MAX;
    for (uint32_t t = begin; t < end; t++) {
        build_prim *p = &c->prims[t];
        const float(*v)[4] = &c->frame->vertices[3 * (size_t)t];
        int finite = 1;
        for (int k = 0; k < 3; k++) {
            p->lo[k] = pf_bih_min(pf_bih_min(v[0][k], v[1][k]), v[2][k]);
            p->hi[k] = pf_bih_max(pf_bih_max(v[0][k], v[1][k]), v[2][k]);
            finite &= isfinite(v[0][k]) && isfinite(v[1][k]) && isfinite(v[2][k]);
        }
        if (!finite) {
            c->bad_triangle[part] = t;
            return;
        }
        p->triangle = t;
        float centre[3];
        for (int k = 0; k < 3; k++)
            centre[k] = prim_centre(p, k);
        pf_bih_box_merge(&bounds, p->lo, p->hi);
        pf_bih_box_merge(&centres, centre, centre);
    }
    c->bounds[part] = bounds;
    c->centres[part] = centres;
}

typedef struct task_context {
    const build_config *cfg;
    subtree_task *tasks;
    uint32_t task_count;
    atomic_uint next;
} task_context;

static void task_part(void *arg, uint32_t part, uint32_t parts)
{
    (void)part;
    (void)parts;
    task_context *c = arg;
    for (;;) {
        uint32_t i = atomic_fetch_add(&c->next, 1u);
        if (i >= c->task_count)
            return;
        subtree_task *task = &c->tasks[i];
        subtree_builder b = {.cfg = c->cfg, .err = &task->err};
        /* Node 0 is the root; pairs follow from 1 on. */
        b.node_capacity = 2 * task->count + 1;
        b.nodes = pf_bih_alloc_large((size_t)b.node_capacity * sizeof *b.nodes);
        b.node_count = 1;
        if (!b.nodes) {
            task->status = pf_error_set(&task->err, PF_ERR_NOMEM, "BIH build: subtree of %u triangles",
                                        task->count);
            continue;
        }
        task->status = build_node(&b, 0, task->first, task->count, task->region, &task->bounds,
                                  &task->centres, task->depth);
        task->nodes = b.nodes;
        task->node_count = b.node_count;
        task->depth_reached = b.depth;
        task->leaf_count = b.leaf_count;
        task->largest_leaf = b.largest_leaf;
    }
}

/* The subtrees' nodes copied into the tree, the tasks shared out among the threads. */
typedef struct stitch_context {
    pf_bih_node *nodes;
    const subtree_task *tasks;
    uint32_t task_count;
} stitch_context;

static void stitch_part(void *arg, uint32_t part, uint32_t parts)
{
    stitch_context *c = arg;
    for (uint32_t i = part; i < c->task_count; i += parts)
        stitch(c->nodes, c->tasks[i].node, c->tasks[i].base, c->tasks[i].nodes,
               c->tasks[i].node_count);
}

typedef struct order_context {
    const pf_scene_frame *frame;
    const build_prim *prims;
    pf_bih *out;
} order_context;

/*
 * The order pass reads the frame's triangles in leaf order, a gather that
 * misses the cache at about every triangle. Asking for the triangle this many
 * steps ahead overlaps the misses (1M triangles: the pass 45-55 -> 24-45 ms).
 */
#define ORDER_PREFETCH_DISTANCE 16u
/* The degenerate flags are set a block at a time, while the block's copy is in L1 (3 KiB). */
#define ORDER_FLAG_BLOCK 64u

static void prefetch_triangle(const pf_scene_frame *frame, uint32_t t)
{
#if defined(__GNUC__)
    const char *first = (const char *)frame->vertices[3 * (size_t)t];
    __builtin_prefetch(first);
    __builtin_prefetch(first + 3 * sizeof frame->vertices[0] - 1);
#else
    (void)frame;
    (void)t;
#endif
}

static void order_part(void *arg, uint32_t part, uint32_t parts)
{
    order_context *c = arg;
    uint32_t n = c->frame->triangle_count;
    uint32_t begin = (uint32_t)((uint64_t)n * part / parts);
    uint32_t end = (uint32_t)((uint64_t)n * (part + 1) / parts);
    for (uint32_t block = begin; block < end; block += ORDER_FLAG_BLOCK) {
        uint32_t block_end = end - block > ORDER_FLAG_BLOCK ? block + ORDER_FLAG_BLOCK : end;
        for (uint32_t i = block; i < block_end; i++) {
            if (i + ORDER_PREFETCH_DISTANCE < end)
                prefetch_triangle(c->frame, c->prims[i + ORDER_PREFETCH_DISTANCE].triangle);
            uint32_t t = c->prims[i].triangle;
            c->out->triangle_index[i] = t;
            pf_bih_copy_leaf_triangle(&c->out->vertices[3 * (size_t)i], c->frame, t);
        }
        pf_bih_flag_degenerate(&c->out->vertices[3 * (size_t)block], block_end - block);
    }
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
    uint32_t heuristic = options ? options->heuristic : PF_BIH_HEURISTIC_GLOBAL;
    uint32_t threads = options && options->thread_count ? options->thread_count
                                                        : PF_BIH_DEFAULT_BUILD_THREADS;
    if (max_depth > PF_BIH_STACK_SIZE)
        return pf_error_set(err, PF_ERR_INVALID,
                            "BIH build: max_depth %u exceeds the traversal stack (%u entries)",
                            max_depth, PF_BIH_STACK_SIZE);
    if (heuristic != PF_BIH_HEURISTIC_GLOBAL && heuristic != PF_BIH_HEURISTIC_SAH)
        return pf_error_set(err, PF_ERR_INVALID, "BIH build: unknown heuristic %u", heuristic);
    if (threads > PF_BIH_MAX_BUILD_THREADS)
        return pf_error_set(err, PF_ERR_INVALID, "BIH build: %u threads (at most %u)", threads,
                            PF_BIH_MAX_BUILD_THREADS);
    uint32_t n = frame->triangle_count;
    if (n > 0 && !frame->vertices)
        return pf_error_set(err, PF_ERR_INVALID, "BIH build: %u triangles but no vertices", n);
    if (n >= PF_BIH_MAX_NODES / 2)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "BIH build: %u triangles exceed the node index field (%u nodes)", n,
                            PF_BIH_MAX_NODES);
    if (n < PARALLEL_MIN_TRIANGLES)
        threads = 1;
    build_config cfg = {.leaf_size = leaf_size, .max_depth = max_depth, .heuristic = heuristic,
                        .threads = threads};
    cfg.prims = pf_bih_alloc_large((n ? n : 1) * sizeof *cfg.prims);
    subtree_builder top = {.cfg = &cfg, .err = err};
    top.node_capacity = n > 0 ? 2 * n - 1 : 1;
    top.nodes = pf_bih_alloc_large((size_t)top.node_capacity * sizeof *top.nodes);
    top.node_count = 1;
    out->vertices = pf_bih_alloc_large((n ? 3 * (size_t)n : 1) * sizeof *out->vertices);
    out->triangle_index = pf_bih_alloc_large((n ? n : 1) * sizeof *out->triangle_index);
    pf_status status = PF_OK;
    if (!cfg.prims || !top.nodes || !out->vertices || !out->triangle_index)
        status = pf_error_set(err, PF_ERR_NOMEM, "BIH build: %u triangles", n);

    setup_context setup = {.frame = frame, .prims = cfg.prims};
    pf_bih_box bounds = pf_bih_box_empty(), centres = pf_bih_box_empty();
    if (status == PF_OK && n > 0) {
        parallel_run(setup_part, &setup, threads);
        for (uint32_t i = 0; i < threads && status == PF_OK; i++) {
            if (setup.bad_triangle[i] != UINT32_MAX)
                status = pf_error_set(err, PF_ERR_INVALID,
                                      "BIH build: triangle %u: non-finite vertex coordinate",
                                      setup.bad_triangle[i]);
            pf_bih_box_merge(&bounds, setup.bounds[i].lo, setup.bounds[i].hi);
            pf_bih_box_merge(&centres, setup.centres[i].lo, setup.centres[i].hi);
        }
    }
    /* The decomposition into subtrees depends on n only, not on threads. */
    if (n >= PARALLEL_MIN_TRIANGLES)
        cfg.defer_below = n / PARALLEL_SUBTREE_FRACTION;
    if (status == PF_OK)
        status = build_node(&top, 0, 0, n, bounds, &bounds, &centres, 0);

    task_context tasks = {.cfg = &cfg, .tasks = top.tasks, .task_count = top.task_count};
    atomic_init(&tasks.next, 0u);
    if (status == PF_OK && top.task_count > 0) {
        cfg.defer_below = 0;
        parallel_run(task_part, &tasks, threads);
    }
    uint64_t node_count = top.node_count;
    for (uint32_t i = 0; i < top.task_count; i++) {
        const subtree_task *task = &top.tasks[i];
        if (status == PF_OK && task->status != PF_OK) {
            status = task->status;
            if (err)
                *err = task->err;
        }
        node_count += task->node_count ? task->node_count - 1 : 0;
    }
    if (status == PF_OK && node_count > PF_BIH_MAX_NODES)
        status = pf_error_set(err, PF_ERR_LIMIT, "BIH build: %llu nodes exceed the index field (%u)",
                              (unsigned long long)node_count, PF_BIH_MAX_NODES);
    pf_bih_node *nodes = NULL;
    if (status == PF_OK) {
        nodes = top.task_count ? pf_bih_alloc_large((size_t)node_count * sizeof *nodes) : top.nodes;
        if (!nodes)
            status = pf_error_set(err, PF_ERR_NOMEM, "BIH build: %llu nodes",
                                  (unsigned long long)node_count);
    }
    if (status == PF_OK && top.task_count) {
        memcpy(nodes, top.nodes, (size_t)top.node_count * sizeof *nodes);
        uint32_t base = top.node_count;
        for (uint32_t i = 0; i < top.task_count; i++) {
            subtree_task *task = &top.tasks[i];
            task->base = base;
            base += task->node_count - 1;
            if (task->depth_reached > top.depth)
                top.depth = task->depth_reached;
            top.leaf_count += task->leaf_count;
            if (task->largest_leaf > top.largest_leaf)
                top.largest_leaf = task->largest_leaf;
        }
        stitch_context stitching = {nodes, top.tasks, top.task_count};
        parallel_run(stitch_part, &stitching, threads);
        free(top.nodes);
    }
    if (status == PF_OK) {
        order_context order = {frame, cfg.prims, out};
        parallel_run(order_part, &order, threads);
        out->nodes = nodes;
        out->node_count = (uint32_t)node_count;
        out->triangle_count = n;
        for (int k = 0; k < 3; k++) {
            out->bounds_min[k] = n ? bounds.lo[k] : 0.0f;
            out->bounds_max[k] = n ? bounds.hi[k] : 0.0f;
        }
        out->depth = top.depth;
        out->leaf_count = n ? top.leaf_count : 1;
        out->largest_leaf = top.largest_leaf;
    } else {
        free(top.nodes);
        free(out->vertices);
        free(out->triangle_index);
        memset(out, 0, sizeof *out);
    }
    for (uint32_t i = 0; i < top.task_count; i++)
        free(top.tasks[i].nodes);
    free(top.tasks);
    free(cfg.prims);
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
