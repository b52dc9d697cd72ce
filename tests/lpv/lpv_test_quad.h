/* A one-material scene frame of quads for the LPV tests (geometry volumes). */
#ifndef LPV_TEST_QUAD_H
#define LPV_TEST_QUAD_H

#include "pf_scene.h"

#include <math.h>
#include <string.h>

#define LPV_TEST_MAX_QUADS 4

typedef struct quad_frame {
    pf_scene_frame frame;
    float vertices[6 * LPV_TEST_MAX_QUADS][4];
    float normals[6 * LPV_TEST_MAX_QUADS][4];
    uint32_t triangle_material[2 * LPV_TEST_MAX_QUADS];
    pf_material material;
} quad_frame;

static inline void quad_frame_init(quad_frame *q)
{
    memset(q, 0, sizeof *q);
    q->material.albedo[0] = q->material.albedo[1] = q->material.albedo[2] = 0.5f;
    q->frame.vertices = q->vertices;
    q->frame.normals = q->normals;
    q->frame.triangle_material = q->triangle_material;
    q->frame.material_count = 1;
    q->frame.materials = &q->material;
    for (int i = 0; i < 3; i++) {
        q->frame.bounds_min[i] = INFINITY;
        q->frame.bounds_max[i] = -INFINITY;
    }
}

/* Adds the quad p0 p1 p2 p3 (counter-clockwise seen from its front). */
static inline void quad_frame_add(quad_frame *q, const float p0[3], const float p1[3],
                                  const float p2[3], const float p3[3])
{
    const float *corners[6] = {p0, p1, p2, p0, p2, p3};
    uint32_t first = 3 * q->frame.triangle_count;
    for (int i = 0; i < 6; i++) {
        memcpy(q->vertices[first + i], corners[i], 3 * sizeof(float));
        for (int k = 0; k < 3; k++) {
            q->frame.bounds_min[k] = fminf(q->frame.bounds_min[k], corners[i][k]);
            q->frame.bounds_max[k] = fmaxf(q->frame.bounds_max[k], corners[i][k]);
        }
    }
    q->frame.triangle_count += 2;
}

#endif
