/*
 * Scenes, rays and comparisons shared by the BIH tests: the hard-case
 * geometry of issue 3 (generated here, small and exact), random rays, and the
 * CPU brute-force answer in the oracle's order (lower index wins ties).
 */
#ifndef BIH_TEST_UTIL_H
#define BIH_TEST_UTIL_H

#include "bih_internal.h" /* the packet traversal at each vector width */
#include "pf_bih.h"
#include "pf_test.h"

#include <dirent.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Relative t tolerance for GPU results: GPU division may be 2.5 ulp off (Vulkan precision rules). */
#define BIH_T_RELATIVE_TOLERANCE 1e-6

static inline uint32_t bih_next_random(uint32_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    return *state;
}

static inline float bih_uniform(uint32_t *state, float low, float high)
{
    return low + (high - low) * (float)(bih_next_random(state) >> 8) / 16777216.0f;
}

/* A frame owning only vertices (free with bih_frame_free); bounds from the vertices. */
static inline int bih_frame_alloc(pf_scene_frame *frame, uint32_t triangle_count)
{
    memset(frame, 0, sizeof *frame);
    frame->triangle_count = triangle_count;
    frame->vertices = calloc(3 * (size_t)(triangle_count ? triangle_count : 1), sizeof *frame->vertices);
    return frame->vertices != NULL;
}

static inline void bih_frame_bounds(pf_scene_frame *frame)
{
    for (int k = 0; k < 3; k++) {
        frame->bounds_min[k] = frame->triangle_count ? INFINITY : 0.0f;
        frame->bounds_max[k] = frame->triangle_count ? -INFINITY : 0.0f;
    }
    for (uint32_t i = 0; i < 3 * frame->triangle_count; i++)
        for (int k = 0; k < 3; k++) {
            frame->bounds_min[k] = fminf(frame->bounds_min[k], frame->vertices[i][k]);
            frame->bounds_max[k] = fmaxf(frame->bounds_max[k], frame->vertices[i][k]);
        }
}

static inline void bih_frame_free(pf_scene_frame *frame)
{
    free(frame->vertices);
    memset(frame, 0, sizeof *frame);
}

static inline void bih_set_triangle(pf_scene_frame *frame, uint32_t t, const float a[3],
                                    const float b[3], const float c[3])
{
    const float *corners[3] = {a, b, c};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k++)
            frame->vertices[3 * t + i][k] = corners[i][k];
        frame->vertices[3 * t + i][3] = 0.0f;
    }
}

/* Random triangles of size ~0.4 in [-1, 1]^3; a few exact duplicates make ties. */
static inline int bih_make_soup(pf_scene_frame *frame, uint32_t count, uint32_t seed)
{
    if (!bih_frame_alloc(frame, count))
        return 0;
    uint32_t state = seed;
    for (uint32_t i = 0; i < count; i++) {
        float centre[3] = {bih_uniform(&state, -1, 1), bih_uniform(&state, -1, 1),
                           bih_uniform(&state, -1, 1)};
        for (int corner = 0; corner < 3; corner++)
            for (int k = 0; k < 3; k++)
                frame->vertices[3 * i + corner][k] = centre[k] + bih_uniform(&state, -0.2f, 0.2f);
    }
    for (uint32_t i = 10; i + 7 < count; i += 97)
        memcpy(frame->vertices[3 * (i + 7)], frame->vertices[3 * i], 3 * sizeof *frame->vertices);
    bih_frame_bounds(frame);
    return 1;
}

/*
 * The closed surface of the cube [-1, 1]^3, each face a grid × grid grid of
 * quads split into two triangles: 12 · grid² triangles sharing edges and
 * vertices exactly (a grid point's coordinates are computed from its integer
 * position alone, so the faces meeting at an edge compute the same floats;
 * with BIH_CUBE_GRID they are multiples of 1/2, exact).
 */
#define BIH_CUBE_GRID 4
static inline int bih_make_closed_cube(pf_scene_frame *frame, int grid)
{
    if (!bih_frame_alloc(frame, 12u * (uint32_t)grid * (uint32_t)grid))
        return 0;
    uint32_t t = 0;
    for (int axis = 0; axis < 3; axis++)
        for (int side = -1; side <= 1; side += 2)
            for (int i = 0; i < grid; i++)
                for (int j = 0; j < grid; j++) {
                    int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
                    float p[4][3];
                    for (int c = 0; c < 4; c++) {
                        p[c][axis] = (float)side;
                        p[c][u_axis] = -1.0f + 2.0f * (float)(i + (c == 1 || c == 2)) / (float)grid;
                        p[c][v_axis] = -1.0f + 2.0f * (float)(j + (c >= 2)) / (float)grid;
                    }
                    bih_set_triangle(frame, t++, p[0], p[1], p[2]);
                    bih_set_triangle(frame, t++, p[0], p[2], p[3]);
                }
    bih_frame_bounds(frame);
    return 1;
}

/* Multiplies every coordinate by scale, then adds offset (exact for powers of two scales). */
static inline void bih_frame_transform(pf_scene_frame *frame, float scale, float offset)
{
    for (uint32_t i = 0; i < 3 * frame->triangle_count; i++)
        for (int k = 0; k < 3; k++)
            frame->vertices[i][k] = frame->vertices[i][k] * scale + offset;
    bih_frame_bounds(frame);
}

/* Bumpy sphere: radius 1 ± BIH_SPHERE_BUMP, so rays from within BIH_SPHERE_INSIDE of the box's half size start inside. */
#define BIH_SPHERE_BUMP 0.05
#define BIH_SPHERE_INSIDE 0.5f

/*
 * A closed mesh of at least min_triangles triangles: bih_make_closed_cube
 * with the smallest grid that reaches the count, every vertex pushed onto a
 * bumpy sphere (a radial displacement, so the surface stays closed). A
 * vertex is a function of its cube point alone, so shared edges and vertices
 * stay bit-identical and rays through them must not leak.
 */
static inline int bih_make_bumpy_sphere(pf_scene_frame *frame, uint32_t min_triangles)
{
    int grid = (int)ceil(sqrt(min_triangles / 12.0));
    if (!bih_make_closed_cube(frame, grid))
        return 0;
    for (uint32_t i = 0; i < 3 * frame->triangle_count; i++) {
        double p[3] = {frame->vertices[i][0], frame->vertices[i][1], frame->vertices[i][2]};
        double length = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        double radius = 1.0 + BIH_SPHERE_BUMP * sin(7.0 * p[0] + 1.0) * sin(5.0 * p[1] + 2.0) *
                                  sin(3.0 * p[2] + 3.0);
        for (int k = 0; k < 3; k++)
            frame->vertices[i][k] = (float)(p[k] / length * radius);
    }
    bih_frame_bounds(frame);
    return 1;
}

/* Random rays aimed into the frame's box from around it; every fourth has a finite tmax. */
static inline void bih_random_rays(uint32_t *state, const pf_scene_frame *frame, pf_ray *rays,
                                   uint32_t count)
{
    float extent = 0.0f;
    for (int k = 0; k < 3; k++)
        extent = fmaxf(extent, frame->bounds_max[k] - frame->bounds_min[k]);
    if (extent == 0.0f)
        extent = 1.0f;
    for (uint32_t r = 0; r < count; r++) {
        float target[3];
        for (int k = 0; k < 3; k++) {
            float lo = frame->bounds_min[k], hi = frame->bounds_max[k];
            float margin = 0.5f * extent;
            rays[r].origin[k] = bih_uniform(state, lo - margin, hi + margin);
            target[k] = bih_uniform(state, lo, hi);
            rays[r].direction[k] = target[k] - rays[r].origin[k];
        }
        rays[r].tmin = r % 8 == 1 ? 0.3f : 0.0f;
        rays[r].tmax = r % 4 == 0 ? bih_uniform(state, 0.2f, 1.5f) : INFINITY;
    }
}

/* Closest hit on the CPU, every triangle in index order (the oracle's rule). */
static inline pf_hit bih_brute_closest(const pf_scene_frame *frame, const pf_ray *ray)
{
    pf_hit hit = {-1.0f, PF_NO_HIT, 0, 0};
    float closest = ray->tmax;
    for (uint32_t i = 0; i < frame->triangle_count; i++) {
        float t, u, v;
        if (pf_ray_triangle_watertight(ray->origin, ray->direction, frame->vertices[3 * i],
                                       frame->vertices[3 * i + 1], frame->vertices[3 * i + 2],
                                       ray->tmin, closest, &t, &u, &v)) {
            closest = t;
            hit = (pf_hit){t, i, u, v};
        }
    }
    return hit;
}

static inline int bih_t_close(float a, float b)
{
    return fabs((double)a - b) <= BIH_T_RELATIVE_TOLERANCE * fmax(fabs(a), fabs(b));
}

/* The triangle really is hit by the ray at (about) t. */
static inline int bih_hit_is_real(const pf_scene_frame *frame, const pf_ray *ray, const pf_hit *hit)
{
    float t = 0, u, v;
    return hit->triangle < frame->triangle_count &&
           pf_ray_triangle_watertight(ray->origin, ray->direction,
                                      frame->vertices[3 * hit->triangle],
                                      frame->vertices[3 * hit->triangle + 1],
                                      frame->vertices[3 * hit->triangle + 2], ray->tmin, ray->tmax,
                                      &t, &u, &v) &&
           bih_t_close(t, hit->t);
}

/*
 * A BIH closest hit against the expected one: the same triangle with t
 * within tolerance (bit-equal when exact is set: the CPU runs the same test),
 * or, on a tie, another triangle really hit at an equal t (within tolerance:
 * the watertight t's rounding exceeds the slab test's, so among hits whose t
 * differ by rounding alone the BIH may meet another one first).
 * Prints the first few disagreements under label.
 */
static inline uint32_t bih_compare_closest(const char *label, const pf_scene_frame *frame,
                                           const pf_ray *rays, const pf_hit *expected,
                                           const pf_hit *got, uint32_t count, int exact)
{
    uint32_t mismatches = 0;
    for (uint32_t r = 0; r < count; r++) {
        int ok;
        if (expected[r].triangle == PF_NO_HIT)
            ok = got[r].triangle == PF_NO_HIT && got[r].t == -1.0f;
        else if (got[r].triangle == expected[r].triangle)
            ok = exact ? got[r].t == expected[r].t : bih_t_close(got[r].t, expected[r].t);
        else
            ok = bih_t_close(got[r].t, expected[r].t) && bih_hit_is_real(frame, &rays[r], &got[r]);
        if (!ok && mismatches++ < 5)
            fprintf(stderr, "%s: ray %u (o %.9g %.9g %.9g d %.9g %.9g %.9g [%g, %g]): got tri %u t %.9g, expected tri %u t %.9g\n",
                    label, r, rays[r].origin[0], rays[r].origin[1], rays[r].origin[2],
                    rays[r].direction[0], rays[r].direction[1], rays[r].direction[2],
                    rays[r].tmin, rays[r].tmax, got[r].triangle, got[r].t,
                    expected[r].triangle, expected[r].t);
    }
    return mismatches;
}

/* Any-hit: a hit exactly when the closest-hit answer has one, on a triangle really hit. */
static inline uint32_t bih_compare_any(const char *label, const pf_scene_frame *frame,
                                       const pf_ray *rays, const pf_hit *closest,
                                       const pf_hit *got, uint32_t count)
{
    uint32_t mismatches = 0;
    for (uint32_t r = 0; r < count; r++) {
        int ok = closest[r].triangle == PF_NO_HIT ? got[r].triangle == PF_NO_HIT
                                                  : bih_hit_is_real(frame, &rays[r], &got[r]);
        if (!ok && mismatches++ < 5)
            fprintf(stderr, "%s: any-hit ray %u: got tri %u t %.9g, closest tri %u\n", label, r,
                    got[r].triangle, got[r].t, closest[r].triangle);
    }
    return mismatches;
}

/* Names of the shared scenes (directories of $PF_SHARED_SCENES); returns how many (<= max). */
static inline uint32_t bih_shared_scene_names(char names[][64], uint32_t max)
{
    const char *root = getenv("PF_SHARED_SCENES");
    DIR *dir = opendir(root ? root : "../shared/scenes");
    uint32_t count = 0;
    if (!dir)
        return 0;
    struct dirent *entry;
    while ((entry = readdir(dir)) && count < max) {
        if (entry->d_name[0] == '.' || strlen(entry->d_name) >= 64)
            continue;
        strcpy(names[count++], entry->d_name);
    }
    closedir(dir);
    return count;
}

/* ---- The hard cases of issue 3, shared by the CPU and GPU tests. ---- */

typedef enum bih_case {
    BIH_CASE_SOUP,
    BIH_CASE_CUBE,          /* closed mesh: interior rays through edges/vertices must hit */
    BIH_CASE_CUBE_SMALL,    /* scaled by 1e-4 */
    BIH_CASE_CUBE_LARGE,    /* scaled by 1e4 */
    BIH_CASE_CUBE_OFFSET,   /* offset by 1e5 */
    BIH_CASE_SOUP_OFFSET,   /* soup offset by 1e5 */
    BIH_CASE_FLAT,          /* every triangle in the plane z = 0 */
    BIH_CASE_SAME_CENTRE,   /* every centroid and box centre at the origin */
    BIH_CASE_COPLANAR,      /* overlapping triangles in one plane, duplicates */
    BIH_CASE_DEGENERATE,    /* zero-area and collinear triangles among real ones */
    BIH_CASE_CLUSTERED,     /* triangles at x = 2^-i: the global heuristic would go 100 deep */
    BIH_CASE_ONE,
    BIH_CASE_ZERO,
    BIH_CASE_COUNT
} bih_case;

/*
 * BIH_CASE_DEGENERATE: index % 4 == 0 a real triangle, 1 a point, 2 a segment
 * (a repeated vertex), 3 three distinct collinear points (the middle one
 * rounded onto the line, so the edge functions are rounding noise).
 */
#define BIH_DEGENERATE_EVERY 4u

/* What a case's rays must show beyond agreeing with the oracle. */
typedef struct bih_expect {
    float inside;    /* > 0: a closed mesh; bih_case_rays' aimed rays start inside and must hit */
    int degenerate;  /* BIH_CASE_DEGENERATE's pattern: only its real triangles may be hit */
} bih_expect;

/* The cube's interior is its whole box: 0.9 of the half size keeps clear of the faces. */
#define BIH_CUBE_INSIDE 0.9f

static inline bih_expect bih_case_expect(int which)
{
    bih_expect expect = {0.0f, which == BIH_CASE_DEGENERATE};
    if (which >= BIH_CASE_CUBE && which <= BIH_CASE_CUBE_OFFSET)
        expect.inside = BIH_CUBE_INSIDE;
    return expect;
}

static inline int bih_make_case(int which, pf_scene_frame *frame, const char **name)
{
    static const char *names[BIH_CASE_COUNT] = {
        "soup", "closed cube", "cube x1e-4", "cube x1e4", "cube +1e5", "soup +1e5", "flat",
        "same centre", "coplanar", "degenerate", "clustered", "one triangle", "zero triangles"};
    *name = names[which];
    uint32_t state = 77 + (uint32_t)which;
    switch (which) {
    case BIH_CASE_SOUP:
        return bih_make_soup(frame, 600, 11);
    case BIH_CASE_CUBE:
        return bih_make_closed_cube(frame, BIH_CUBE_GRID);
    case BIH_CASE_CUBE_SMALL:
        if (!bih_make_closed_cube(frame, BIH_CUBE_GRID))
            return 0;
        bih_frame_transform(frame, 1e-4f, 0.0f);
        return 1;
    case BIH_CASE_CUBE_LARGE:
        if (!bih_make_closed_cube(frame, BIH_CUBE_GRID))
            return 0;
        bih_frame_transform(frame, 1e4f, 0.0f);
        return 1;
    case BIH_CASE_CUBE_OFFSET:
        if (!bih_make_closed_cube(frame, BIH_CUBE_GRID))
            return 0;
        bih_frame_transform(frame, 1.0f, 1e5f);
        return 1;
    case BIH_CASE_SOUP_OFFSET:
        if (!bih_make_soup(frame, 400, 12))
            return 0;
        bih_frame_transform(frame, 1.0f, 1e5f);
        return 1;
    case BIH_CASE_FLAT: {
        const int grid = 12;
        if (!bih_frame_alloc(frame, 2 * grid * grid))
            return 0;
        uint32_t t = 0;
        for (int i = 0; i < grid; i++)
            for (int j = 0; j < grid; j++) {
                float a[3] = {(float)i, (float)j, 0}, b[3] = {(float)i + 1, (float)j, 0};
                float c[3] = {(float)i + 1, (float)j + 1, 0}, d[3] = {(float)i, (float)j + 1, 0};
                bih_set_triangle(frame, t++, a, b, c);
                bih_set_triangle(frame, t++, a, c, d);
            }
        break;
    }
    case BIH_CASE_SAME_CENTRE: {
        /* Each axis takes the values {-s, 0, s} in some order: centroid = box centre = 0. */
        static const int orders[6][3] = {{-1, 0, 1}, {-1, 1, 0}, {0, -1, 1},
                                         {0, 1, -1}, {1, -1, 0}, {1, 0, -1}};
        if (!bih_frame_alloc(frame, 300))
            return 0;
        /* Some picks are collinear: degenerate triangles at the same centre too. */
        for (uint32_t t = 0; t < 300; t++) {
            float scale = bih_uniform(&state, 0.1f, 2.0f);
            for (int k = 0; k < 3; k++) {
                int pick = (int)(bih_next_random(&state) % 6);
                for (int c = 0; c < 3; c++)
                    frame->vertices[3 * t + c][k] = scale * (float)orders[pick][c];
            }
        }
        break;
    }
    case BIH_CASE_COPLANAR: {
        if (!bih_frame_alloc(frame, 200))
            return 0;
        for (uint32_t t = 0; t < 200; t++) {
            for (int c = 0; c < 3; c++) {
                frame->vertices[3 * t + c][0] = bih_uniform(&state, -1, 1);
                frame->vertices[3 * t + c][1] = bih_uniform(&state, -1, 1);
                frame->vertices[3 * t + c][2] = 0.5f;
            }
            if (t % 10 == 9)
                memcpy(frame->vertices[3 * t], frame->vertices[3 * (t - 1)], 3 * sizeof *frame->vertices);
        }
        break;
    }
    case BIH_CASE_DEGENERATE: {
        if (!bih_make_soup(frame, 300, 13))
            return 0;
        for (uint32_t t = 0; t < 300; t++) {
            float *v0 = frame->vertices[3 * t], *v1 = frame->vertices[3 * t + 1],
                  *v2 = frame->vertices[3 * t + 2];
            if (t % BIH_DEGENERATE_EVERY == 1) {
                memcpy(v1, v0, 3 * sizeof(float));
                memcpy(v2, v0, 3 * sizeof(float));
            } else if (t % BIH_DEGENERATE_EVERY == 2) {
                memcpy(v2, v1, 3 * sizeof(float));
            } else if (t % BIH_DEGENERATE_EVERY == 3) {
                for (int k = 0; k < 3; k++)
                    v1[k] = v0[k] + 0.37f * (v2[k] - v0[k]);
            }
        }
        break;
    }
    case BIH_CASE_CLUSTERED: {
        const uint32_t count = 120;
        if (!bih_frame_alloc(frame, count))
            return 0;
        for (uint32_t t = 0; t < count; t++) {
            float x = ldexpf(1.0f, -(int)t), size = 0.25f * x;
            float a[3] = {x, 0, 0}, b[3] = {x + size, 1, 0}, c[3] = {x, 0, 1};
            bih_set_triangle(frame, t, a, b, c);
        }
        break;
    }
    case BIH_CASE_ONE: {
        if (!bih_frame_alloc(frame, 1))
            return 0;
        float a[3] = {0, 0, 0}, b[3] = {1, 0, 0.5f}, c[3] = {0, 1, 0.25f};
        bih_set_triangle(frame, 0, a, b, c);
        break;
    }
    case BIH_CASE_ZERO:
        if (!bih_frame_alloc(frame, 0))
            return 0;
        break;
    default:
        return 0;
    }
    bih_frame_bounds(frame);
    return 1;
}

/*
 * Rays for a case: a quarter random, a quarter parallel to an axis with the
 * origin exactly on a clip plane of the tree (a clip value of one of its
 * inner nodes; a box face when the pick is a leaf), a quarter aimed exactly
 * at triangle vertices and edge midpoints, a quarter random again. With
 * inside > 0 (a closed mesh) the aimed rays start within that fraction of the
 * box's half size around its centre, inside the mesh, so they must hit.
 * Returns the index of the first aimed ray; aimed rays end at 3 count / 4.
 */
static inline uint32_t bih_case_rays(float inside, const pf_scene_frame *frame, const pf_bih *bih,
                                     uint32_t seed, pf_ray *rays, uint32_t count)
{
    uint32_t state = seed;
    bih_random_rays(&state, frame, rays, count);
    uint32_t n = frame->triangle_count;
    for (uint32_t r = count / 4; r < count / 2; r++) {
        pf_ray *ray = &rays[r];
        float p[3] = {0, 0, 0};
        if (n > 0) {
            uint32_t t = bih_next_random(&state) % n;
            for (int k = 0; k < 3; k++)
                p[k] = (frame->vertices[3 * t][k] + frame->vertices[3 * t + 1][k] +
                        frame->vertices[3 * t + 2][k]) / 3.0f;
        }
        uint32_t node = bih_next_random(&state) % bih->node_count;
        const pf_bih_node *inner = &bih->nodes[node];
        if ((inner->word & 3u) != PF_BIH_LEAF) {
            /* An empty-space cut's empty side is ±inf: its other side is the plane there. */
            uint32_t side = bih_next_random(&state) & 1u;
            float clip = inner->clip[side];
            p[inner->word & 3u] = isfinite(clip) ? clip : inner->clip[side ^ 1u];
        } else {
            int axis = (int)(bih_next_random(&state) % 3);
            p[axis] = bih_next_random(&state) & 1u ? frame->bounds_min[axis] : frame->bounds_max[axis];
        }
        uint32_t pick = bih_next_random(&state);
        int dir_axis = (int)(pick % 3);
        float zero = pick & 8u ? -0.0f : 0.0f;
        for (int k = 0; k < 3; k++) {
            ray->origin[k] = p[k];
            ray->direction[k] = zero;
        }
        ray->direction[dir_axis] = pick & 4u ? 1.0f : -1.0f;
        /* Half start back along the ray, so they cross the whole scene. */
        if (pick & 16u) {
            float extent = frame->bounds_max[dir_axis] - frame->bounds_min[dir_axis] + 1.0f;
            ray->origin[dir_axis] -= 2.0f * extent * ray->direction[dir_axis];
        }
        ray->tmin = 0.0f;
        ray->tmax = INFINITY;
    }
    for (uint32_t r = count / 2; n > 0 && r < 3 * count / 4; r++) {
        pf_ray *ray = &rays[r];
        uint32_t t = bih_next_random(&state) % n;
        uint32_t corner = bih_next_random(&state) % 3, other = (corner + 1) % 3;
        int midpoint = bih_next_random(&state) & 1u;
        float target[3];
        for (int k = 0; k < 3; k++) {
            float a = frame->vertices[3 * t + corner][k], b = frame->vertices[3 * t + other][k];
            target[k] = midpoint ? 0.5f * a + 0.5f * b : a;
            float lo = frame->bounds_min[k], hi = frame->bounds_max[k];
            float centre = 0.5f * lo + 0.5f * hi, half = 0.5f * hi - 0.5f * lo;
            ray->origin[k] = inside > 0.0f
                                 ? centre + bih_uniform(&state, -inside, inside) * half
                                 : bih_uniform(&state, lo - half - 1.0f, hi + half + 1.0f);
            ray->direction[k] = target[k] - ray->origin[k];
        }
        ray->tmin = 0.0f;
        ray->tmax = INFINITY;
    }
    return count / 2;
}

/* ---- Checking answers, and the loops over the cases and the shared scenes. ---- */

/* Rays of one case with the oracle's answer and a traversal's closest and any hits. */
typedef struct bih_ray_set {
    uint32_t count;
    uint32_t aimed;              /* first aimed ray (bih_case_rays) */
    pf_ray *rays;
    pf_hit *oracle, *closest, *any;
} bih_ray_set;

static inline int bih_ray_set_alloc(bih_ray_set *set, uint32_t count)
{
    memset(set, 0, sizeof *set);
    set->count = count;
    set->rays = malloc(count * sizeof *set->rays);
    set->oracle = malloc(count * sizeof *set->oracle);
    set->closest = malloc(count * sizeof *set->closest);
    set->any = malloc(count * sizeof *set->any);
    return set->rays && set->oracle && set->closest && set->any;
}

static inline void bih_ray_set_free(bih_ray_set *set)
{
    free(set->rays), free(set->oracle), free(set->closest), free(set->any);
    memset(set, 0, sizeof *set);
}

/* The CPU brute force (bih_brute_closest) into set->oracle. */
static inline void bih_oracle_cpu(const pf_scene_frame *frame, bih_ray_set *set)
{
    for (uint32_t r = 0; r < set->count; r++)
        set->oracle[r] = bih_brute_closest(frame, &set->rays[r]);
}

/*
 * The oracle for meshes too big to brute-force every ray in a fast test:
 * set->oracle gets the CPU traversal of reference (a tree pf_bih_check
 * accepted), and every stride-th ray of it must equal the CPU brute force
 * exactly (the same triangle test; strides sample every quarter of
 * bih_case_rays). The other trees and traversals are then held to it.
 */
static inline void bih_oracle_sampled(const char *label, const pf_scene_frame *frame,
                                      const pf_bih *reference, bih_ray_set *set, uint32_t stride)
{
    pf_error err = {0};
    uint32_t failures = 0, mismatches = 0, sampled = 0;
    for (uint32_t r = 0; r < set->count; r++)
        failures += pf_bih_trace_cpu(reference, &set->rays[r], 0, &set->oracle[r], &err) != PF_OK;
    PF_CHECK_MSG(failures == 0, "%s: %u reference traversals failed: %s", label, failures,
                 err.message);
    for (uint32_t r = 0; r < set->count; r += stride, sampled++) {
        char sample[160];
        snprintf(sample, sizeof sample, "%s, sampled ray %u", label, r);
        pf_hit brute = bih_brute_closest(frame, &set->rays[r]);
        mismatches += bih_compare_closest(sample, frame, &set->rays[r], &brute, &set->oracle[r], 1, 1);
    }
    PF_CHECK_MSG(mismatches == 0, "%s: %u of %u sampled reference hits differ from brute force",
                 label, mismatches, sampled);
}

/* The CPU traversal, closest and any hit, into set->closest and set->any; every ray must succeed. */
static inline void bih_trace_cpu_both(const char *label, const pf_bih *bih, bih_ray_set *set)
{
    pf_error err = {0};
    uint32_t failures = 0;
    for (uint32_t r = 0; r < set->count; r++) {
        failures += pf_bih_trace_cpu(bih, &set->rays[r], 0, &set->closest[r], &err) != PF_OK;
        failures += pf_bih_trace_cpu(bih, &set->rays[r], 1, &set->any[r], &err) != PF_OK;
    }
    PF_CHECK_MSG(failures == 0, "%s: %u CPU traversals failed: %s", label, failures, err.message);
}

/*
 * The packet traversal's closest hit against the one-ray traversal's: the
 * same hit bit for bit, or, where two triangles give exactly the same t, the
 * other one really hit at that t (pf_bih.h: the order of visits can decide
 * such a tie).
 */
static inline int bih_same_closest(const pf_scene_frame *frame, const pf_ray *ray,
                                   const pf_hit *expected, const pf_hit *got)
{
    if (got->triangle == expected->triangle)
        return memcmp(got, expected, sizeof *got) == 0;
    return expected->triangle != PF_NO_HIT && got->triangle != PF_NO_HIT &&
           got->t == expected->t && bih_hit_is_real(frame, ray, got);
}

/*
 * The packet traversal against the one-ray traversal on the same rays, in
 * packets of consecutive rays (mixed directions, some parallel to an axis,
 * the last packet partial): closest hits as bih_same_closest asks, any hits
 * whenever the ray is occluded (pf_bih.h: the triangle may differ). Each
 * vector width this machine runs (bih_internal.h: 4, and 8 with AVX2) is
 * checked, and the widths must agree bit for bit, any-hit triangles
 * included. Also pf_bih_trace_cpu_packet and pf_bih_trace_cpu_rays, which
 * pick a width. Needs set->closest and set->any from bih_trace_cpu_both.
 */
static inline void bih_check_packets(const char *label, const pf_scene_frame *frame,
                                     const pf_bih *bih, const bih_ray_set *set)
{
    static const uint32_t widths[] = {4, 8};
    enum { WIDTHS = sizeof widths / sizeof widths[0], CALLS = WIDTHS + 1 };
    uint32_t closest_differ[CALLS] = {0}, any_differ[CALLS] = {0}, failures = 0;
    uint32_t widths_differ = 0, widths_run = 0;
    pf_error err = {0};
    pf_hit *closest[CALLS], *any[CALLS];
    for (uint32_t c = 0; c < CALLS; c++) {
        closest[c] = malloc(set->count * sizeof(pf_hit));
        any[c] = malloc(set->count * sizeof(pf_hit));
        PF_REQUIRE(closest[c] && any[c]);
    }
    for (uint32_t c = 0; c < CALLS; c++) {
        /* c < WIDTHS: that width's function; c == WIDTHS: pf_bih_trace_cpu_packet. */
        pf_bih_packet_trace_fn trace =
            c < WIDTHS ? pf_bih_packet_tracer(widths[c]) : pf_bih_trace_cpu_packet;
        if (!trace) {
            printf("%s: no %u-wide packet traversal on this machine, not checked\n", label,
                   widths[c]);
            continue;
        }
        widths_run += c < WIDTHS;
        for (uint32_t r = 0; r < set->count; r += PF_BIH_PACKET_RAYS) {
            uint32_t n =
                set->count - r < PF_BIH_PACKET_RAYS ? set->count - r : PF_BIH_PACKET_RAYS;
            failures += trace(bih, &set->rays[r], n, 0, &closest[c][r], &err) != PF_OK;
            failures += trace(bih, &set->rays[r], n, 1, &any[c][r], &err) != PF_OK;
        }
        for (uint32_t r = 0; r < set->count; r++) {
            closest_differ[c] +=
                !bih_same_closest(frame, &set->rays[r], &set->closest[r], &closest[c][r]);
            any_differ[c] +=
                (any[c][r].triangle == PF_NO_HIT) != (set->any[r].triangle == PF_NO_HIT);
        }
        if (c > 0 && pf_bih_packet_tracer(widths[0]))
            widths_differ +=
                memcmp(closest[c], closest[0], set->count * sizeof(pf_hit)) != 0 ||
                memcmp(any[c], any[0], set->count * sizeof(pf_hit)) != 0;
    }
    /* The batch of all the rays: packets of consecutive ones, the last one partial. */
    pf_hit *batch = closest[0];
    failures += pf_bih_trace_cpu_rays(bih, set->rays, set->count, 0, batch, &err) != PF_OK;
    for (uint32_t r = 0; r < set->count; r++)
        closest_differ[WIDTHS] +=
            !bih_same_closest(frame, &set->rays[r], &set->closest[r], &batch[r]);
    failures += pf_bih_trace_cpu_rays(bih, set->rays, set->count, 1, batch, &err) != PF_OK;
    for (uint32_t r = 0; r < set->count; r++)
        any_differ[WIDTHS] += (batch[r].triangle == PF_NO_HIT) != (set->any[r].triangle == PF_NO_HIT);
    for (uint32_t c = 0; c < CALLS; c++) {
        free(closest[c]);
        free(any[c]);
    }
    PF_CHECK_MSG(widths_run >= 1, "%s: no packet width ran (the 4-wide one always should)", label);
    PF_CHECK_MSG(failures == 0, "%s: %u packet traversals failed: %s", label, failures,
                 err.message);
    for (uint32_t c = 0; c < CALLS; c++) {
        const char *what = c < WIDTHS ? "packet" : "pf_bih_trace_cpu_packet/rays";
        uint32_t width = c < WIDTHS ? widths[c] : 0;
        PF_CHECK_MSG(closest_differ[c] == 0,
                     "%s: %s (width %u; 0: picked): %u of %u closest hits differ from one ray's",
                     label, what, width, closest_differ[c], set->count);
        PF_CHECK_MSG(any_differ[c] == 0,
                     "%s: %s (width %u; 0: picked): %u of %u any-hit answers differ", label, what,
                     width, any_differ[c], set->count);
    }
    PF_CHECK_MSG(widths_differ == 0, "%s: the packet widths' hits differ (%u of them)", label,
                 widths_differ);
}

/*
 * The wide view's invariants: every BIH leaf with triangles in exactly one
 * slot, with its first triangle and count, and every slot's box holding
 * its subtree (a leaf's triangles, an inner slot's node's boxes); unused
 * slots empty. Returns the failures (each printed).
 */
static inline uint32_t bih_wide_structure_failures(const char *label, const pf_bih *bih,
                                                   const pf_bih_wide *wide)
{
    uint32_t failures = 0, leaves_seen = 0, triangles_seen = 0;
    uint8_t *seen = calloc(bih->triangle_count + 1, 1);
    if (!seen) {
        printf("%s: out of memory\n", label);
        return 1;
    }
    for (uint32_t n = 0; n < wide->node_count; n++) {
        const pf_bih_wide_node *node = &wide->nodes[n];
        for (uint32_t i = 0; i < PF_BIH_WIDE_SLOTS; i++) {
            int empty = node->lo[0][i] > node->hi[0][i];
            uint32_t child = node->child[i];
            if (empty) {
                failures += child != PF_BIH_WIDE_LEAF || node->count[i] != 0;
                continue;
            }
            if (child & PF_BIH_WIDE_LEAF) {
                uint32_t first = child & ~PF_BIH_WIDE_LEAF, count = node->count[i];
                uint32_t blocks = (count + PF_BIH_WIDE_LANES - 1) / PF_BIH_WIDE_LANES;
                leaves_seen++;
                if (count == 0 || first + blocks > wide->block_count) {
                    printf("%s: wide node %u slot %u: blocks %u+%u out of range\n", label, n, i,
                           first, blocks);
                    failures++;
                    continue;
                }
                uint32_t start = wide->blocks[first].position[0];
                for (uint32_t lane = 0; lane < PF_BIH_WIDE_LANES * blocks; lane++) {
                    const pf_bih_wide_block *block =
                        &wide->blocks[first + lane / PF_BIH_WIDE_LANES];
                    uint32_t l = lane % PF_BIH_WIDE_LANES, p = block->position[l];
                    /* The leaf's triangles in order, then unused lanes. */
                    if (lane >= count) {
                        failures += p != PF_NO_HIT || (block->live >> l & 1u);
                        continue;
                    }
                    if (p != start + lane || p >= bih->triangle_count) {
                        printf("%s: wide node %u slot %u: lane %u holds %u\n", label, n, i,
                               lane, p);
                        failures++;
                        continue;
                    }
                    failures += seen[p]++ != 0;
                    triangles_seen++;
                    failures += (block->live >> l & 1u) != (bih->vertices[3 * p][3] == 0.0f);
                    for (int v = 0; v < 3; v++)
                        for (int k = 0; k < 3; k++) {
                            float x = bih->vertices[3 * p + v][k];
                            failures += memcmp(&block->v[v][k][l], &x, sizeof x) != 0;
                            failures += !(x >= node->lo[k][i] && x <= node->hi[k][i]);
                        }
                }
            } else if (child <= n || child >= wide->node_count) {
                printf("%s: wide node %u slot %u: child %u out of order\n", label, n, i, child);
                failures++;
            } else {
                const pf_bih_wide_node *c = &wide->nodes[child];
                for (uint32_t j = 0; j < PF_BIH_WIDE_SLOTS; j++)
                    for (int k = 0; k < 3; k++)
                        failures += c->lo[k][j] <= c->hi[k][j] && !(c->lo[k][j] >= node->lo[k][i] &&
                                                                    c->hi[k][j] <= node->hi[k][i]);
            }
        }
    }
    uint32_t bih_leaves = 0;
    for (uint32_t n = 0; n < bih->node_count; n++)
        bih_leaves += pf_bih_is_leaf(&bih->nodes[n]) && pf_bih_leaf_count(&bih->nodes[n]) > 0;
    if (leaves_seen != bih_leaves || triangles_seen != bih->triangle_count) {
        printf("%s: wide view has %u leaves, %u triangles; the BIH %u, %u\n", label, leaves_seen,
               triangles_seen, bih_leaves, bih->triangle_count);
        failures++;
    }
    free(seen);
    return failures;
}

/*
 * The wide view (pf_bih_wide) against the one-ray traversal, as
 * bih_check_packets checks the packets: its structure, closest hits as
 * bih_same_closest asks, any hits whenever the ray is occluded. Where the
 * machine has no AVX2 the call is the packets', and says so.
 */
static inline void bih_check_wide(const char *label, const pf_scene_frame *frame,
                                  const pf_bih *bih, const bih_ray_set *set)
{
    pf_error err = {0};
    pf_bih_wide wide;
    PF_CHECK_OK(pf_bih_wide_build(bih, &wide, &err), &err);
    if (err.status != PF_OK)
        return;
    if (!pf_bih_wide_available())
        printf("%s: no AVX2 here: the wide traversal is the packets'\n", label);
    uint32_t structure = bih_wide_structure_failures(label, bih, &wide);
    PF_CHECK_MSG(structure == 0, "%s: %u wrong slots in the wide view", label, structure);
    pf_hit *closest = malloc(set->count * sizeof(pf_hit));
    pf_hit *any = malloc(set->count * sizeof(pf_hit));
    PF_REQUIRE(closest && any);
    PF_CHECK_OK(pf_bih_wide_trace_rays(bih, &wide, set->rays, set->count, 0, closest, &err), &err);
    PF_CHECK_OK(pf_bih_wide_trace_rays(bih, &wide, set->rays, set->count, 1, any, &err), &err);
    uint32_t closest_differ = 0, any_differ = 0;
    for (uint32_t r = 0; r < set->count; r++) {
        closest_differ += !bih_same_closest(frame, &set->rays[r], &set->closest[r], &closest[r]);
        any_differ += (any[r].triangle == PF_NO_HIT) != (set->any[r].triangle == PF_NO_HIT);
    }
    PF_CHECK_MSG(closest_differ == 0, "%s: wide view: %u of %u closest hits differ from one ray's",
                 label, closest_differ, set->count);
    PF_CHECK_MSG(any_differ == 0, "%s: wide view: %u of %u any-hit answers differ", label,
                 any_differ, set->count);
    free(closest);
    free(any);
    pf_bih_wide_free(&wide);
}

/*
 * Checks set->closest and set->any against set->oracle (bih_compare_closest
 * and bih_compare_any; exact: the CPU ran the oracle's very test), that the
 * rays hit something often enough to test anything, and what expect asks:
 * no aimed ray leaks out of a closed mesh, no degenerate triangle is hit.
 * label names the case and the build/traversal pair in every message.
 */
static inline void bih_check_answers(const char *label, const pf_scene_frame *frame,
                                     bih_expect expect, const bih_ray_set *set, int exact)
{
    uint32_t count = set->count;
    uint32_t mismatches = bih_compare_closest(label, frame, set->rays, set->oracle, set->closest,
                                              count, exact);
    PF_CHECK_MSG(mismatches == 0, "%s: %u of %u closest hits differ from brute force", label,
                 mismatches, count);
    mismatches = bih_compare_any(label, frame, set->rays, set->oracle, set->any, count);
    PF_CHECK_MSG(mismatches == 0, "%s: %u of %u any hits wrong", label, mismatches, count);
    uint32_t hits = 0;
    for (uint32_t r = 0; r < count; r++)
        hits += set->oracle[r].triangle != PF_NO_HIT;
    if (frame->triangle_count > 0)
        PF_CHECK_MSG(hits > count / 20, "%s: only %u hits: the rays test little", label, hits);
    if (expect.inside > 0.0f) {
        uint32_t leaks = 0;
        for (uint32_t r = set->aimed; r < 3 * count / 4; r++)
            leaks += set->closest[r].triangle == PF_NO_HIT || set->any[r].triangle == PF_NO_HIT;
        PF_CHECK_MSG(leaks == 0, "%s: %u rays through shared edges/vertices leaked out", label,
                     leaks);
    }
    if (expect.degenerate) {
        uint32_t degenerate = 0;
        for (uint32_t r = 0; r < count; r++) {
            uint32_t closest = set->closest[r].triangle, any = set->any[r].triangle;
            degenerate += (closest != PF_NO_HIT && closest % BIH_DEGENERATE_EVERY != 0) ||
                          (any != PF_NO_HIT && any % BIH_DEGENERATE_EVERY != 0);
        }
        PF_CHECK_MSG(degenerate == 0, "%s: %u rays hit a degenerate triangle", label, degenerate);
    }
}

/* What a test checks on one frame: label names it, seed and ray_count drive bih_case_rays. */
typedef void (*bih_frame_check)(const char *label, const pf_scene_frame *frame, bih_expect expect,
                                uint32_t seed, uint32_t ray_count);

/* check on every hard case (seeds seed_base + case). */
static inline void bih_for_each_case(bih_frame_check check, uint32_t seed_base, uint32_t ray_count)
{
    for (int which = 0; which < BIH_CASE_COUNT; which++) {
        pf_scene_frame frame;
        const char *name;
        PF_REQUIRE(bih_make_case(which, &frame, &name));
        check(name, &frame, bih_case_expect(which), seed_base + (uint32_t)which, ray_count);
        bih_frame_free(&frame);
    }
}

/*
 * check on the last frame of every scene in $PF_SHARED_SCENES (animated
 * scenes have moved from their rest pose there); seeds seed_base + scene.
 */
static inline void bih_for_each_shared_scene(bih_frame_check check, uint32_t seed_base,
                                             uint32_t ray_count)
{
    char names[16][64];
    uint32_t scene_count = bih_shared_scene_names(names, 16);
    PF_REQUIRE(scene_count > 0);
    for (uint32_t i = 0; i < scene_count; i++) {
        /*
         * pf_test_shared_scene's path, built here with its length checked:
         * inlined into several callers, its unchecked snprintf tripped gcc 12's
         * -Wformat-truncation.
         */
        char path[1024];
        const char *root = getenv("PF_SHARED_SCENES");
        int length = snprintf(path, sizeof path, "%s/%s/%s.gltf", root ? root : "../shared/scenes",
                              names[i], names[i]);
        PF_CHECK_MSG(length > 0 && (size_t)length < sizeof path, "scene path too long: %s", names[i]);
        pf_scene *scene = NULL;
        pf_error err = {0};
        PF_CHECK_OK(pf_scene_load(path, &scene, &err), &err);
        if (!scene)
            continue;
        const pf_scene_info *info = pf_scene_get_info(scene);
        pf_scene_frame frame = {0};
        PF_CHECK_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, info->frame_count), &frame,
                                  &err),
                    &err);
        PF_CHECK_MSG(frame.triangle_count > 0, "scene %s has no triangles", names[i]);
        if (frame.triangle_count > 0)
            check(names[i], &frame, (bih_expect){0.0f, 0}, seed_base + i, ray_count);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

#endif
