/*
 * Measures of an evaluated frame that the planner and the integrators size
 * their work by (pf_scene.h): whether photons can make caustics, the
 * surface area, the box's diagonal and the coordinates' magnitude.
 */
#include "pf_scene.h"

#include <math.h>

int pf_scene_frame_has_specular(const pf_scene_frame *frame)
{
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        uint32_t m = frame->triangle_material[t];
        if (m < frame->material_count && frame->materials[m].kind != PF_MATERIAL_LAMBERT)
            return 1;
    }
    return 0;
}

double pf_scene_frame_area(const pf_scene_frame *frame)
{
    double area = 0.0;
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        const float *a = frame->vertices[3 * t], *b = frame->vertices[3 * t + 1],
                    *c = frame->vertices[3 * t + 2];
        double u[3], v[3];
        for (int k = 0; k < 3; k++) {
            u[k] = (double)b[k] - a[k];
            v[k] = (double)c[k] - a[k];
        }
        double x = u[1] * v[2] - u[2] * v[1], y = u[2] * v[0] - u[0] * v[2],
               z = u[0] * v[1] - u[1] * v[0];
        area += 0.5 * sqrt(x * x + y * y + z * z);
    }
    return area;
}

double pf_scene_frame_diagonal(const pf_scene_frame *frame)
{
    double sum = 0.0;
    for (int k = 0; k < 3; k++) {
        double extent = (double)frame->bounds_max[k] - frame->bounds_min[k];
        sum += extent * extent;
    }
    return sqrt(sum);
}

float pf_scene_frame_magnitude(const pf_scene_frame *frame)
{
    float magnitude = 1.0f;
    for (int i = 0; i < 3; i++) {
        float extent = frame->bounds_max[i] - frame->bounds_min[i];
        float largest = fmaxf(fabsf(frame->bounds_min[i]), fabsf(frame->bounds_max[i]));
        magnitude = fmaxf(magnitude, fmaxf(extent, largest));
    }
    return magnitude;
}

