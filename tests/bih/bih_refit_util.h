/*
 * What the refit tests share (test_bih_refit.c on the host, test_bih_gpu_refit.c on the
 * device): frames moved in six ways, and trees copied and compared byte for byte.
 */
#ifndef BIH_REFIT_UTIL_H
#define BIH_REFIT_UTIL_H

#include "bih_test_util.h"

typedef enum motion {
    MOTION_TRANSLATE, /* rigid: every vertex + (0.31, -0.17, 0.05) × extent */
    MOTION_ROTATE,    /* rigid: 0.4 rad about a tilted axis through the centre */
    MOTION_DEFORM,    /* smooth warp: x += 0.2 sin(3y) × extent, scale z by 1.3 */
    MOTION_JITTER,    /* every vertex moved at random by up to 5% of the extent */
    MOTION_SCATTER,   /* every triangle moved rigidly by a random offset of up to the extent */
    MOTION_COLLAPSE,  /* every other triangle collapsed to one point */
    MOTION_COUNT
} motion;

static const char *const motion_names[MOTION_COUNT] = {"translate", "rotate", "deform",
                                                 "jitter",    "scatter", "collapse"};

static inline float frame_extent(const pf_scene_frame *frame)
{
    float extent = 0.0f;
    for (int k = 0; k < 3; k++)
        extent = fmaxf(extent, frame->bounds_max[k] - frame->bounds_min[k]);
    return extent > 0.0f ? extent : 1.0f;
}

/* Copies from into a new frame moved by how (free with bih_frame_free). */
static inline int moved_copy(const pf_scene_frame *from, motion how, pf_scene_frame *to)
{
    if (!bih_frame_alloc(to, from->triangle_count))
        return 0;
    memcpy(to->vertices, from->vertices, 3 * (size_t)from->triangle_count * sizeof *to->vertices);
    float extent = frame_extent(from), centre[3];
    for (int k = 0; k < 3; k++)
        centre[k] = 0.5f * from->bounds_min[k] + 0.5f * from->bounds_max[k];
    uint32_t state = 4242 + (uint32_t)how;
    float axis[3] = {0.36f, 0.48f, 0.8f}; /* unit length */
    float angle = 0.4f, s = sinf(angle), c = cosf(angle);
    for (uint32_t t = 0; t < to->triangle_count; t++) {
        float offset[3];
        for (int k = 0; k < 3; k++)
            offset[k] = bih_uniform(&state, -0.5f, 0.5f) * extent;
        for (int corner = 0; corner < 3; corner++) {
            float *v = to->vertices[3 * t + corner];
            float p[3] = {v[0] - centre[0], v[1] - centre[1], v[2] - centre[2]};
            switch (how) {
            case MOTION_TRANSLATE:
                v[0] += 0.31f * extent, v[1] -= 0.17f * extent, v[2] += 0.05f * extent;
                break;
            case MOTION_ROTATE: {
                /* Rodrigues: p cos + (axis × p) sin + axis (axis · p)(1 - cos). */
                float cross[3] = {axis[1] * p[2] - axis[2] * p[1], axis[2] * p[0] - axis[0] * p[2],
                                  axis[0] * p[1] - axis[1] * p[0]};
                float dot = axis[0] * p[0] + axis[1] * p[1] + axis[2] * p[2];
                for (int k = 0; k < 3; k++)
                    v[k] = centre[k] + p[k] * c + cross[k] * s + axis[k] * dot * (1.0f - c);
                break;
            }
            case MOTION_DEFORM:
                v[0] += 0.2f * extent * sinf(3.0f * p[1] / extent);
                v[2] = centre[2] + 1.3f * p[2];
                break;
            case MOTION_JITTER:
                for (int k = 0; k < 3; k++)
                    v[k] += bih_uniform(&state, -0.05f, 0.05f) * extent;
                break;
            case MOTION_SCATTER:
                for (int k = 0; k < 3; k++)
                    v[k] += offset[k];
                break;
            case MOTION_COLLAPSE:
                /* Odd ones: BIH_CASE_DEGENERATE's real triangles and a lone triangle stay. */
                if (t % 2 == 1)
                    for (int k = 0; k < 3; k++)
                        v[k] = centre[k];
                break;
            default:
                break;
            }
        }
    }
    bih_frame_bounds(to);
    return 1;
}

/* A byte-for-byte copy of a tree (free with pf_bih_free). */
static inline int copy_tree(const pf_bih *from, pf_bih *to)
{
    *to = *from;
    size_t n = from->triangle_count;
    to->nodes = malloc(from->node_count * sizeof *to->nodes);
    to->vertices = malloc((n ? 3 * n : 1) * sizeof *to->vertices);
    to->triangle_index = malloc((n ? n : 1) * sizeof *to->triangle_index);
    if (!to->nodes || !to->vertices || !to->triangle_index) {
        free(to->nodes), free(to->vertices), free(to->triangle_index);
        memset(to, 0, sizeof *to);
        return 0;
    }
    memcpy(to->nodes, from->nodes, from->node_count * sizeof *to->nodes);
    memcpy(to->vertices, from->vertices, 3 * n * sizeof *to->vertices);
    memcpy(to->triangle_index, from->triangle_index, n * sizeof *to->triangle_index);
    return 1;
}

static inline int same_tree(const pf_bih *a, const pf_bih *b)
{
    size_t n = a->triangle_count;
    return a->node_count == b->node_count && a->triangle_count == b->triangle_count &&
           !memcmp(a->nodes, b->nodes, a->node_count * sizeof *a->nodes) &&
           !memcmp(a->vertices, b->vertices, 3 * n * sizeof *a->vertices) &&
           !memcmp(a->triangle_index, b->triangle_index, n * sizeof *a->triangle_index) &&
           !memcmp(a->bounds_min, b->bounds_min, sizeof a->bounds_min) &&
           !memcmp(a->bounds_max, b->bounds_max, sizeof a->bounds_max);
}

#endif
