/*
 * Points spread uniformly over the area of a frame's diffuse surfaces (pf_lpv.h,
 * pf_lpv_energy_samples): where `fast` measures the energy its volumes deliver to the
 * surfaces, to scale it to the energy the photons do.
 */
#include "pf_lpv.h"

#include <math.h>
#include <string.h>

/* A fixed sequence (splitmix64): the same surfaces give the same points in every frame, so a
 * still scene's scale does not flicker. */
static double next_uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

/* Triangle t's area and unit normal (pf_lpv_triangle_normal). */
static double triangle_frame(const pf_scene_frame *frame, uint32_t t, double normal[3])
{
    return pf_lpv_triangle_normal(frame->vertices[3 * t], frame->vertices[3 * t + 1],
                                  frame->vertices[3 * t + 2], normal);
}

/* The triangles the samples cover: those the LPV's light is estimated on (not unlit ones,
 * which photons pass and which shade no light). */
static int diffuse_triangle(const pf_scene_frame *frame, uint32_t t)
{
    uint32_t m = frame->triangle_material[t];
    return m < frame->material_count && frame->materials[m].kind == PF_MATERIAL_LAMBERT &&
           !(frame->materials[m].flags & PF_MATERIAL_UNLIT);
}

double pf_lpv_energy_samples(const pf_scene_frame *frame, uint32_t count, float *samples)
{
    double total = 0.0, normal[3];
    for (uint32_t t = 0; t < frame->triangle_count; t++)
        if (diffuse_triangle(frame, t))
            total += triangle_frame(frame, t, normal);
    memset(samples, 0, (size_t)count * PF_LPV_ENERGY_SAMPLE_FLOATS * sizeof *samples);
    if (!(total > 0.0) || count == 0)
        return 0.0;
    /* Sample i lies on the triangle that holds (i + ½) / count of the running sum of the
     * areas (the same sum, in the same order, as total: every sample finds its triangle),
     * uniformly within it. */
    uint64_t state = 0x5eed1a7e5ull;
    uint32_t i = 0;
    double before = 0.0; /* area of the triangles before t */
    for (uint32_t t = 0; t < frame->triangle_count && i < count; t++) {
        if (!diffuse_triangle(frame, t))
            continue;
        double area = triangle_frame(frame, t, normal);
        while (i < count && (i + 0.5) / count * total < before + area) {
            double r1 = sqrt(next_uniform(&state)), r2 = next_uniform(&state);
            const float *a = frame->vertices[3 * t], *b = frame->vertices[3 * t + 1],
                        *c = frame->vertices[3 * t + 2];
            float *out = samples + (size_t)i * PF_LPV_ENERGY_SAMPLE_FLOATS;
            double u = r1 * (1.0 - r2), v = r1 * r2;
            for (int k = 0; k < 3; k++) {
                out[k] = (float)((1.0 - u - v) * a[k] + u * b[k] + v * c[k]);
                out[4 + k] = (float)normal[k];
            }
            uint32_t m = frame->triangle_material[t];
            out[3] = (frame->materials[m].flags & PF_MATERIAL_DOUBLE_SIDED) ? 1.0f : 0.0f;
            memcpy(&out[7], &t, sizeof t);
            out[8] = (float)u;
            out[9] = (float)v;
            i++;
        }
        before += area;
    }
    return total;
}
