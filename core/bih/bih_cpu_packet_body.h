/*
 * The CPU traversal of up to PF_BIH_PACKET_RAYS rays together (the contract
 * in pf_bih.h at pf_bih_trace_cpu_packet), written once for a vector width:
 * the file that includes this one defines PACKET_WIDTH (lanes a vector: 4 or
 * 8) and PACKET_TRACE (the function's name). bih_cpu_packet_sse.c builds it
 * 4 wide for x86-64's SSE2 baseline (and any other target), and
 * bih_cpu_packet_avx2.c 8 wide with -mavx2; bih_cpu_packet.c picks one at run
 * time, since the build cannot assume AVX2 on the machines it runs on.
 *
 * Why: one ray at a time, the C traversal waits on memory or on its own
 * dependency chain at nearly every step and stays at 0.14-0.22x Embree's
 * single rays however its arithmetic is written (bench/RESULTS.md). Rays that
 * start together mostly walk the same nodes, so the packet loads each node
 * and leaf once for all of them (Wald et al., "Interactive Rendering with
 * Coherent Ray Tracing", 2001): one shared stack, each ray its own interval,
 * the node step and the triangle test on PACKET_WIDTH lanes at a time.
 *
 * Each ray's arithmetic is bih_cpu_traverse.c's, operation for operation: the
 * same interval intersection, widened far ends, parallel-axis rule, culling
 * by its own best hit, and the same triangle test on the same leaves. Only
 * the order differs: the packet takes the children of a node in the order
 * most of its rays would, so a ray whose direction disagrees finds its best
 * hit later and may test triangles its own traversal would have culled. The
 * closest hit is the same, but for a tie: two triangles at exactly the same
 * t in different nodes, where a node's entry distance and a triangle's t
 * round differently, so that whichever is found first can cull the other's
 * node (seen on the coplanar test case: 2 rays in 2,000 with 16-ray packets,
 * none with 8). An
 * any-hit ray reports a hit whenever its own traversal would, though not
 * always the same one.
 */
#if !defined(PACKET_WIDTH) || !defined(PACKET_TRACE)
#error "define PACKET_WIDTH and PACKET_TRACE before including bih_cpu_packet_body.h"
#endif

#include "bih_internal.h"

#include <math.h>
#if defined(__AVX__)
#include <immintrin.h>
#elif defined(__SSE__)
#include <xmmintrin.h>
#endif

#define LANES PF_BIH_PACKET_RAYS
/*
 * 16 rays a packet: on the shared scenes 16 measured best (cornell-anim's
 * primary rays 0.47x Embree with 8, 0.62x with 16, 0.49x with 32; the 1M
 * sphere's bounces 0.30x, 0.28x, 0.21x). count_lanes counts 16 bits.
 */
_Static_assert(PF_BIH_PACKET_RAYS == 16u, "count_lanes assumes 16 lanes");

_Static_assert(PACKET_WIDTH == 4 || PACKET_WIDTH == 8, "lanes come in vectors of 4 or 8");
#define WIDTH_MASK ((1u << PACKET_WIDTH) - 1u)

/*
 * PACKET_WIDTH floats or ints, in GCC's vector extension (4: one SSE register
 * on x86-64's baseline, one NEON register on arm64; 8: one AVX register): the
 * lane loop of a node step as whole-vector operations, LANES / PACKET_WIDTH
 * vectors a packet. Each lane's operations are IEEE single-precision ones,
 * the same as the scalar code's (ISO C mode: no contraction into FMA), so
 * the answers are too. GCC -O2 would not vectorise the same loop written per
 * lane: its selects between floating-point results are control flow it
 * keeps. (8-wide vectors without AVX were split into scalar code spilled to
 * the stack; with AVX2 they run 1.1-1.4x faster than 4 wide.)
 */
#define LANE_VECTORS (LANES / PACKET_WIDTH)
typedef float lane_float __attribute__((vector_size(4 * PACKET_WIDTH)));
typedef int32_t lane_int __attribute__((vector_size(4 * PACKET_WIDTH)));

/* The lanes set in bits (popcount without libgcc's call: no POPCNT on x86-64's baseline). */
static uint32_t count_lanes(uint32_t bits)
{
    bits = bits - ((bits >> 1) & 0x5555u);
    bits = (bits & 0x3333u) + ((bits >> 2) & 0x3333u);
    bits = (bits + (bits >> 4)) & 0x0f0fu;
    return (bits + (bits >> 8)) & 0x1fu;
}

/* Bit i set where lane i of mask is set (SSE or AVX: one movemask). */
static uint32_t lane_bits(lane_int mask)
{
#if PACKET_WIDTH == 8 && defined(__AVX__)
    return (uint32_t)_mm256_movemask_ps((__m256)mask);
#elif PACKET_WIDTH == 4 && defined(__SSE__)
    return (uint32_t)_mm_movemask_ps((__m128)mask);
#else
    uint32_t bits = 0;
    for (uint32_t i = 0; i < PACKET_WIDTH; i++)
        bits |= (uint32_t)(mask[i] & 1) << i;
    return bits;
#endif
}

/* Per lane: mask (all ones or zero) ? a : b. */
static lane_float select_f(lane_int mask, lane_float a, lane_float b)
{
    return (lane_float)((mask & (lane_int)a) | (~mask & (lane_int)b));
}

/*
 * pf_bih_min and pf_bih_max per lane: the second argument where it is smaller
 * (larger). SSE's minps(x, y) is x < y ? x : y (AVX's vminps the same), so
 * minps(b, a) is exactly that, NaN included: one instruction where the select
 * takes four.
 */
static lane_float lane_min(lane_float a, lane_float b)
{
#if PACKET_WIDTH == 8 && defined(__AVX__)
    return (lane_float)_mm256_min_ps((__m256)b, (__m256)a);
#elif PACKET_WIDTH == 4 && defined(__SSE__)
    return (lane_float)_mm_min_ps((__m128)b, (__m128)a);
#else
    return select_f(b < a, b, a);
#endif
}

static lane_float lane_max(lane_float a, lane_float b)
{
#if PACKET_WIDTH == 8 && defined(__AVX__)
    return (lane_float)_mm256_max_ps((__m256)b, (__m256)a);
#elif PACKET_WIDTH == 4 && defined(__SSE__)
    return (lane_float)_mm_max_ps((__m128)b, (__m128)a);
#else
    return select_f(b > a, b, a);
#endif
}

static lane_float lane_abs(lane_float t)
{
    return (lane_float)((lane_int)t & 0x7fffffff);
}

static lane_float lane_widen_far(lane_float t)
{
    lane_float magnitude = lane_abs(t);
    return select_f(t >= -FLT_MAX, t + magnitude * PF_BIH_TWO_GAMMA3, t);
}

/* Every ray of the packet a miss: the start, and the answer of a failed traversal. */
static void miss_all(pf_hit *hits, uint32_t count)
{
    for (uint32_t lane = 0; lane < count; lane++)
        hits[lane] = PF_BIH_MISS;
}

/* The lowest lane set in bits (not 0). */
static uint32_t lowest_lane(uint32_t bits)
{
    return (uint32_t)__builtin_ctz(bits);
}

/* A deferred child: its node and each ray's interval there; lanes: the rays that enter it. */
typedef struct packet_entry {
    lane_float t_near[LANE_VECTORS], t_far[LANE_VECTORS];
    uint32_t node, lanes;
} packet_entry;

typedef struct packet {
    const pf_ray *rays;
    int any_hit;
    lane_float origin[3][LANE_VECTORS], inv[3][LANE_VECTORS];
    lane_int parallel_lane[3][LANE_VECTORS]; /* all ones where the axis is parallel for the lane */
    uint32_t negative[3]; /* bit per lane: direction below zero (not parallel) */
    pf_bih_ray prepared[LANES]; /* bih_cpu_traverse.c's per-ray setup */
    /* The shears as lanes: masks of kx, ky, kz = 0 and = 1, sx, sy, sz, tmin, valid. */
    lane_int k_is_0[3][LANE_VECTORS], k_is_1[3][LANE_VECTORS];
    lane_float shear_s[3][LANE_VECTORS], tmin[LANE_VECTORS];
    lane_int shear_valid[LANE_VECTORS];
    /* Where the lanes of a vector share their permutation (coherent rays): its axes. */
    int same_axes[LANE_VECTORS], axes[LANE_VECTORS][3];
    float closest[LANES];
    /* pf_bih_widen_far(closest) and pf_bih_next_up(closest), as lanes. */
    lane_float closest_far[LANE_VECTORS], closest_up[LANE_VECTORS];
    uint32_t done; /* bit per lane: an any-hit ray that has its hit */
    pf_hit *hits;
} packet;

/* Each lane's component k (its mask pair k_is_0, k_is_1) of v. */
static lane_float permuted(lane_int is_0, lane_int is_1, const lane_float v[3])
{
    return select_f(is_0, v[0], select_f(is_1, v[1], v[2]));
}

#define WATERTIGHT_T lane_float
#define WATERTIGHT_EDGES lane_edges
#include "bih_watertight_edges.h"

/*
 * One triangle against a vector of lanes (vector h): pf_ray_triangle_sheared's
 * operations per lane (translation, permutation, shear, edges, sign test,
 * det, distance). Returns the bits of the lanes it hits in (tmin,
 * next_up(closest)), with t, u, v. A lane whose edges or distance fall below
 * PF_BIH_WATERTIGHT_RESCALE_BELOW, where the scalar test evaluates again at a
 * power-of-two scale, is left to that test: its bit in *rescale.
 */
static uint32_t triangle_lanes(const packet *p, uint32_t h, const float (*leaf)[4], lane_float *t,
                               lane_float *u, lane_float *v, uint32_t *rescale)
{
    lane_float a[3], b[3], c[3];
    if (p->same_axes[h]) {
        for (int i = 0; i < 3; i++) {
            int k = p->axes[h][i];
            a[i] = leaf[0][k] - p->origin[k][h];
            b[i] = leaf[1][k] - p->origin[k][h];
            c[i] = leaf[2][k] - p->origin[k][h];
        }
    } else {
        lane_float d[3][3]; /* vertex, translated axis */
        for (int vertex = 0; vertex < 3; vertex++)
            for (int k = 0; k < 3; k++)
                d[vertex][k] = leaf[vertex][k] - p->origin[k][h];
        for (int i = 0; i < 3; i++) {
            a[i] = permuted(p->k_is_0[i][h], p->k_is_1[i][h], d[0]);
            b[i] = permuted(p->k_is_0[i][h], p->k_is_1[i][h], d[1]);
            c[i] = permuted(p->k_is_0[i][h], p->k_is_1[i][h], d[2]);
        }
    }
    lane_edges_result e =
        lane_edges(a, b, c, p->shear_s[0][h], p->shear_s[1][h], p->shear_s[2][h]);
    lane_float eu = e.eu, ev = e.ev, ew = e.ew, det = e.det, scaled_t = e.scaled_t;
    lane_int valid = p->shear_valid[h];
    lane_int small = (lane_abs(eu) < PF_BIH_WATERTIGHT_RESCALE_BELOW) |
                     (lane_abs(ev) < PF_BIH_WATERTIGHT_RESCALE_BELOW) |
                     (lane_abs(ew) < PF_BIH_WATERTIGHT_RESCALE_BELOW) |
                     (lane_abs(scaled_t) < lane_abs(det) * PF_BIH_WATERTIGHT_RESCALE_BELOW);
    *rescale = lane_bits(small & valid);
    lane_int mixed = ((eu < 0.0f) | (ev < 0.0f) | (ew < 0.0f)) &
                     ((eu > 0.0f) | (ev > 0.0f) | (ew > 0.0f));
    lane_float rcp_det = 1.0f / det;
    *t = scaled_t * rcp_det;
    *u = ev * rcp_det;
    *v = ew * rcp_det;
    lane_int in_range = (*t > p->tmin[h]) & (*t < p->closest_up[h]) & (*t >= FLT_MIN);
    return lane_bits(valid & ~small & ~mixed & (det != 0.0f) & in_range);
}

/* A hit for lane: kept where it beats the lane's best (equal t: the lower frame index). */
static void offer_hit(packet *p, uint32_t lane, uint32_t original, float t, float u, float v)
{
    pf_hit *hit = &p->hits[lane];
    if (t < p->closest[lane] ||
        (t == p->closest[lane] && hit->triangle != PF_NO_HIT && original < hit->triangle)) {
        p->closest[lane] = t;
        p->closest_far[lane / PACKET_WIDTH][lane % PACKET_WIDTH] = pf_bih_widen_far(t);
        p->closest_up[lane / PACKET_WIDTH][lane % PACKET_WIDTH] = pf_bih_next_up(t);
        *hit = (pf_hit){t, original, u, v};
        if (p->any_hit)
            p->done |= 1u << lane;
    }
}

/* The leaf's triangles against each ray of lanes, as trace()'s leaf, a vector of lanes at a time. */
static void test_leaf(const pf_bih *bih, packet *p, const pf_bih_node *n, uint32_t lanes)
{
    uint32_t first = pf_bih_leaf_first(n), count = pf_bih_leaf_count(n);
    for (uint32_t p_index = first; p_index < first + count; p_index++) {
        const float(*leaf)[4] = &bih->vertices[3 * p_index];
        /* A degenerate triangle never hits (its flag: pf_bih.h). */
        if (leaf[0][3] != 0.0f)
            continue;
        uint32_t original = bih->triangle_index[p_index];
        for (uint32_t h = 0; h < LANE_VECTORS; h++) {
            uint32_t mine = ((lanes & ~p->done) >> (PACKET_WIDTH * h)) & WIDTH_MASK;
            if (!mine)
                continue;
            lane_float t, u, v;
            uint32_t rescale;
            uint32_t hits = triangle_lanes(p, h, leaf, &t, &u, &v, &rescale) & mine;
            for (uint32_t bits = hits; bits; bits &= bits - 1u) {
                uint32_t i = lowest_lane(bits);
                offer_hit(p, PACKET_WIDTH * h + i, original, t[i], u[i], v[i]);
            }
            for (uint32_t bits = rescale & mine; bits; bits &= bits - 1u) {
                uint32_t lane = PACKET_WIDTH * h + lowest_lane(bits);
                const pf_ray *ray = &p->rays[lane];
                float ts, us, vs;
                if (pf_ray_triangle_sheared(ray->origin, &p->prepared[lane].shear, leaf[0],
                                            leaf[1], leaf[2], ray->tmin,
                                            pf_bih_next_up(p->closest[lane]), &ts, &us, &vs))
                    offer_hit(p, lane, original, ts, us, vs);
            }
        }
    }
}

/*
 * One inner node for every lane at once: each ray's intervals in the two
 * children, as trace() in bih_cpu_traverse.c computes them (its if/else on
 * the parallel axis and the direction's sign as selects). A child's lanes:
 * the rays of lanes whose interval there is not empty.
 */
static void step_children(const packet *p, const packet_entry *current, uint32_t lanes,
                          uint32_t axis, float clip_left, float clip_right, packet_entry *left,
                          packet_entry *right)
{
    uint32_t left_lanes = 0, right_lanes = 0;
    for (uint32_t h = 0; h < LANE_VECTORS; h++) {
        lane_float origin = p->origin[axis][h], inv = p->inv[axis][h];
        lane_float t_near = current->t_near[h];
        lane_float far_limit = lane_min(current->t_far[h], p->closest_far[h]);
        lane_float t_left = (clip_left - origin) * inv;
        lane_float t_right = (clip_right - origin) * inv;
        lane_int parallel = p->parallel_lane[axis][h];
        lane_int positive = (inv > 0.0f) & ~parallel;
        lane_int negative = ~(inv > 0.0f) & ~parallel;
        lane_float left_near = select_f(negative, lane_max(t_near, t_left), t_near);
        lane_float left_far =
            select_f(positive, lane_min(far_limit, lane_widen_far(t_left)), far_limit);
        lane_float right_near = select_f(positive, lane_max(t_near, t_right), t_near);
        lane_float right_far =
            select_f(negative, lane_min(far_limit, lane_widen_far(t_right)), far_limit);
        lane_int visit_left = (~parallel | (origin <= clip_left)) & (left_near <= left_far);
        lane_int visit_right = (~parallel | (origin >= clip_right)) & (right_near <= right_far);
        left->t_near[h] = left_near;
        left->t_far[h] = left_far;
        right->t_near[h] = right_near;
        right->t_far[h] = right_far;
        left_lanes |= lane_bits(visit_left) << (PACKET_WIDTH * h);
        right_lanes |= lane_bits(visit_right) << (PACKET_WIDTH * h);
    }
    left->lanes = left_lanes & lanes;
    right->lanes = right_lanes & lanes;
}

pf_status PACKET_TRACE(const pf_bih *bih, const pf_ray *rays, uint32_t count, int any_hit,
                       pf_hit *hits, pf_error *err)
{
    packet p = {.rays = rays, .any_hit = any_hit, .hits = hits};
    miss_all(hits, count);
    if (bih->triangle_count == 0 || count == 0)
        return PF_OK;

    packet_entry current = {.node = 0, .lanes = 0};
    for (uint32_t lane = 0; lane < count; lane++) {
        uint32_t h = lane / PACKET_WIDTH, i = lane % PACKET_WIDTH;
        pf_bih_ray *prepared = &p.prepared[lane];
        pf_bih_ray_prepare(&rays[lane], prepared);
        for (int k = 0; k < 3; k++) {
            p.origin[k][h][i] = rays[lane].origin[k];
            p.inv[k][h][i] = prepared->inv[k];
            p.parallel_lane[k][h][i] = -(int32_t)(prepared->parallel[k] != 0);
            p.negative[k] |= (uint32_t)(!prepared->parallel[k] && prepared->inv[k] < 0.0f) << lane;
        }
        const pf_ray_shear *shear = &prepared->shear;
        const int axes[3] = {shear->kx, shear->ky, shear->kz};
        const float scale[3] = {shear->sx, shear->sy, shear->sz};
        for (int k = 0; k < 3; k++) {
            p.k_is_0[k][h][i] = -(int32_t)(axes[k] == 0);
            p.k_is_1[k][h][i] = -(int32_t)(axes[k] == 1);
            p.shear_s[k][h][i] = scale[k];
        }
        p.shear_valid[h][i] = -(int32_t)(shear->valid != 0);
        p.tmin[h][i] = rays[lane].tmin;
        p.closest[lane] = rays[lane].tmax;
        p.closest_far[h][i] = pf_bih_widen_far(rays[lane].tmax);
        p.closest_up[h][i] = pf_bih_next_up(rays[lane].tmax);
        float t_near = 0.0f, t_far = 0.0f;
        if (pf_bih_ray_enter(bih, &rays[lane], prepared, &t_near, &t_far))
            current.lanes |= 1u << lane;
        current.t_near[h][i] = t_near;
        current.t_far[h][i] = t_far;
    }

    for (uint32_t h = 0; h < LANE_VECTORS; h++) {
        uint32_t first_lane = PACKET_WIDTH * h;
        p.same_axes[h] = first_lane < count;
        for (uint32_t lane = first_lane; lane < first_lane + PACKET_WIDTH && lane < count; lane++)
            p.same_axes[h] &= p.prepared[lane].shear.kx == p.prepared[first_lane].shear.kx &&
                              p.prepared[lane].shear.ky == p.prepared[first_lane].shear.ky &&
                              p.prepared[lane].shear.kz == p.prepared[first_lane].shear.kz;
        if (p.same_axes[h]) {
            p.axes[h][0] = p.prepared[first_lane].shear.kx;
            p.axes[h][1] = p.prepared[first_lane].shear.ky;
            p.axes[h][2] = p.prepared[first_lane].shear.kz;
        }
    }

    packet_entry stack[PF_BIH_STACK_SIZE];
    uint32_t stack_size = 0;
    /* The packet enters each node at most once, so node_count visits bound the loop. */
    for (uint32_t visit = 0; visit < bih->node_count; visit++) {
        uint32_t lanes = current.lanes & ~p.done;
        const pf_bih_node *n = &bih->nodes[current.node];
        int descend = 0;
        if (lanes && (lanes & (lanes - 1u)) == 0 && !pf_bih_is_leaf(n)) {
            /* One ray left here: its own traversal of the subtree costs it less than the
             * packet's steps (bounces part ways within a few nodes). Handing off two or three
             * rays measured the same. */
            uint32_t lane = lowest_lane(lanes), h = lane / PACKET_WIDTH, i = lane % PACKET_WIDTH;
            pf_status status = pf_bih_walk(bih, &rays[lane], &p.prepared[lane], current.node,
                                           current.t_near[h][i], current.t_far[h][i], any_hit,
                                           &p.closest[lane], &hits[lane], NULL, err);
            if (status != PF_OK) {
                miss_all(hits, count);
                return status;
            }
            p.closest_far[h][i] = pf_bih_widen_far(p.closest[lane]);
            p.closest_up[h][i] = pf_bih_next_up(p.closest[lane]);
            if (any_hit && hits[lane].triangle != PF_NO_HIT)
                p.done |= 1u << lane;
        } else if (lanes && pf_bih_is_leaf(n)) {
            test_leaf(bih, &p, n, lanes);
        } else if (lanes) {
            uint32_t axis = pf_bih_axis(n), child = pf_bih_first_child(n);
            packet_entry left, right; /* filled by step_children */
            left.node = child;
            right.node = child + 1;
            step_children(&p, &current, lanes, axis, n->clip[0], n->clip[1], &left, &right);
            uint32_t both = left.lanes & right.lanes;
            uint32_t votes = count_lanes(both);
            uint32_t votes_right_first = count_lanes(both & p.negative[axis]);
            /* The order most of the rays that enter both children would take. */
            int right_first = 2 * votes_right_first > votes;
            packet_entry *near = right_first ? &right : &left;
            packet_entry *far = right_first ? &left : &right;
            if (near->lanes && far->lanes) {
                if (stack_size == PF_BIH_STACK_SIZE) {
                    miss_all(hits, count);
                    return pf_error_set(err, PF_ERR_LIMIT,
                                        "BIH traversal: stack of %u entries overflowed at node %u",
                                        PF_BIH_STACK_SIZE, current.node);
                }
                stack[stack_size++] = *far;
            }
            if (near->lanes || far->lanes) {
                current = near->lanes ? *near : *far;
                descend = 1;
            }
        }
        if (descend)
            continue;
        /* The next entry that can still hold a closer hit for one of its rays. */
        int resumed = 0;
        while (stack_size > 0 && !resumed) {
            packet_entry *entry = &stack[--stack_size];
            uint32_t open = 0;
            for (uint32_t bits = entry->lanes & ~p.done; bits; bits &= bits - 1u) {
                uint32_t lane = lowest_lane(bits), h = lane / PACKET_WIDTH, i = lane % PACKET_WIDTH;
                float far_limit = pf_bih_min(entry->t_far[h][i], p.closest_far[h][i]);
                entry->t_far[h][i] = far_limit;
                if (entry->t_near[h][i] <= far_limit)
                    open |= 1u << lane;
            }
            if (open) {
                current = *entry;
                current.lanes = open;
                resumed = 1;
            }
        }
        if (!resumed)
            return PF_OK;
    }
    miss_all(hits, count);
    return pf_error_set(err, PF_ERR_INTERNAL,
                        "BIH traversal: more than %u node visits (a malformed tree)",
                        bih->node_count);
}
