/*
 * The geometry volume (pf_lpv.h): each non-glass triangle clipped exactly
 * against the face cells it touches (Sutherland–Hodgman against the six
 * planes of the cell), its clipped area A adding (A / s²) / 0.75 × the
 * clamped-cosine lobe of its face normal, times the part of it an alpha
 * factor leaves opaque (opaque_fraction).
 */
#include "pf_lpv.h"

#include <math.h>
#include <string.h>

/* A triangle clipped by 6 planes has at most 9 vertices. */
#define MAX_POLYGON 12
/* The clamped-cosine lobe's value at its peak (Y00 c0 + Y1 c1 = 0.25 + 0.5). */
#define LOBE_PEAK 0.75

typedef struct polygon {
    int count;
    double v[MAX_POLYGON][3];
} polygon;

/*
 * Keeps the part of in with sign × (x[axis] − plane) ≥ 0 (> 0 when strict):
 * the cells are half-open, so a triangle lying exactly in a boundary plane
 * counts in one cell, not two.
 */
static void clip(const polygon *in, int axis, double plane, double sign, int strict, polygon *out)
{
    out->count = 0;
    for (int i = 0; i < in->count; i++) {
        const double *a = in->v[i], *b = in->v[(i + 1) % in->count];
        double da = sign * (a[axis] - plane), db = sign * (b[axis] - plane);
        int a_in = strict ? da > 0.0 : da >= 0.0, b_in = strict ? db > 0.0 : db >= 0.0;
        if (a_in && out->count < MAX_POLYGON)
            memcpy(out->v[out->count++], a, sizeof out->v[0]);
        if (a_in != b_in && da != db && out->count < MAX_POLYGON) {
            double t = da / (da - db);
            for (int k = 0; k < 3; k++)
                out->v[out->count][k] = a[k] + t * (b[k] - a[k]);
            out->v[out->count][axis] = plane; /* exactly on the plane */
            out->count++;
        }
    }
}

static double polygon_area(const polygon *p)
{
    double sum[3] = {0.0, 0.0, 0.0};
    for (int i = 1; i + 1 < p->count; i++) {
        double u[3], w[3];
        for (int k = 0; k < 3; k++) {
            u[k] = p->v[i][k] - p->v[0][k];
            w[k] = p->v[i + 1][k] - p->v[0][k];
        }
        sum[0] += u[1] * w[2] - u[2] * w[1];
        sum[1] += u[2] * w[0] - u[0] * w[2];
        sum[2] += u[0] * w[1] - u[1] * w[0];
    }
    return 0.5 * sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
}

/* strict_max: the box is half-open [min, max) (else closed). */
static double clipped_area(const float a[3], const float b[3], const float c[3],
                           const float box_min[3], const float box_max[3], int strict_max)
{
    polygon p = {3, {{a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {c[0], c[1], c[2]}}}, q;
    for (int axis = 0; axis < 3 && p.count >= 3; axis++) {
        clip(&p, axis, box_min[axis], 1.0, 0, &q);
        clip(&q, axis, box_max[axis], -1.0, strict_max, &p);
    }
    return p.count >= 3 ? polygon_area(&p) : 0.0;
}

double pf_lpv_clipped_area(const float a[3], const float b[3], const float c[3],
                           const float box_min[3], const float box_max[3])
{
    return clipped_area(a, b, c, box_min, box_max, 1);
}

/*
 * The area a face cell gets of a triangle: a triangle lying exactly in one
 * of the cell's boundary planes (a floor on a row of faces' edge) is shared
 * half and half with the cell on the other side of that plane, so that
 * neither side alone takes the whole of it; any other triangle clips
 * half-open (every point in exactly one cell).
 */
static double face_cell_area(const float *v[3], const float box_min[3], const float box_max[3])
{
    for (int i = 0; i < 3; i++) {
        if (v[0][i] == v[1][i] && v[1][i] == v[2][i] &&
            (v[0][i] == box_min[i] || v[0][i] == box_max[i]))
            return 0.5 * clipped_area(v[0], v[1], v[2], box_min, box_max, 0);
    }
    return clipped_area(v[0], v[1], v[2], box_min, box_max, 1);
}

/*
 * How much of a triangle of material m blocks light, as the traversal's alpha test
 * (scene_geometry.glsl) lets rays through it by its factors: glass and unlit surfaces (which
 * only camera rays see) none, a MASK whose
 * baseColorFactor alpha is below its cutoff none, a BLEND its alpha; the rest all
 * (a texture's alpha, per point, is not seen here).
 */
static double opaque_fraction(const pf_material *m)
{
    if (m->kind == PF_MATERIAL_GLASS || (m->flags & PF_MATERIAL_UNLIT))
        return 0.0;
    if (m->alpha_mode == PF_ALPHA_MASK)
        return m->alpha >= m->alpha_cutoff ? 1.0 : 0.0;
    if (m->alpha_mode == PF_ALPHA_BLEND)
        return m->alpha < 0.0f ? 0.0 : m->alpha > 1.0f ? 1.0 : m->alpha;
    return 1.0;
}

double pf_lpv_triangle_normal(const float a[3], const float b[3], const float c[3],
                              double normal[3])
{
    double u[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = (double)b[k] - a[k];
        w[k] = (double)c[k] - a[k];
    }
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                   u[0] * w[1] - u[1] * w[0]};
    double length = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(length > 0.0) || !isfinite(length))
        return 0.0;
    for (int k = 0; k < 3; k++)
        normal[k] = n[k] / length;
    return 0.5 * length;
}

uint64_t pf_lpv_geometry_build(const pf_lpv_layout *layout, const pf_scene_frame *frame,
                               float *gv)
{
    uint64_t cells = (uint64_t)layout->size * layout->size * layout->size;
    memset(gv, 0, pf_lpv_volume_floats(layout, PF_LPV_GV_FLOATS_PER_CELL) * sizeof *gv);
    uint64_t pieces = 0;
    int32_t size = (int32_t)layout->size;
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        uint32_t m = frame->triangle_material[t];
        double coverage = m < frame->material_count ? opaque_fraction(&frame->materials[m]) : 1.0;
        if (!(coverage > 0.0))
            continue;
        const float *v[3] = {frame->vertices[3 * t], frame->vertices[3 * t + 1],
                             frame->vertices[3 * t + 2]};
        double face[3];
        if (!(pf_lpv_triangle_normal(v[0], v[1], v[2], face) > 0.0))
            continue;
        float normal[3] = {(float)face[0], (float)face[1], (float)face[2]}, lobe[4];
        pf_sh_cosine_lobe(normal, lobe);
        for (uint32_t k = 0; k < layout->count; k++) {
            const pf_lpv_cascade *cascade = &layout->cascades[k];
            float s = cascade->cell_size;
            /*
             * Face volume `axis`, cell g: the slab of LPV cell g's lower face
             * normal to axis, [g − ½, g + ½] cells along it and [g, g + 1]
             * along the other two axes (the face's own rectangle).
             */
            for (int axis = 0; axis < 3; axis++) {
                int32_t lo[3], hi[3];
                int empty = 0;
                for (int i = 0; i < 3; i++) {
                    float shift = i == axis ? 0.5f : 0.0f;
                    float mn = fminf(v[0][i], fminf(v[1][i], v[2][i]));
                    float mx = fmaxf(v[0][i], fmaxf(v[1][i], v[2][i]));
                    double u0 = ((double)mn - cascade->origin[i]) / s + shift;
                    double g0 = floor(u0);
                    double g1 = floor(((double)mx - cascade->origin[i]) / s + shift);
                    if (g0 == u0)
                        g0 -= 1.0; /* on a boundary: the cell below may share it */
                    if (g1 < 0.0 || g0 >= size) {
                        empty = 1;
                        break;
                    }
                    lo[i] = g0 < 0.0 ? 0 : (int32_t)g0;
                    hi[i] = g1 >= size ? size - 1 : (int32_t)g1;
                }
                if (empty)
                    continue;
                for (int32_t z = lo[2]; z <= hi[2]; z++)
                    for (int32_t y = lo[1]; y <= hi[1]; y++)
                        for (int32_t x = lo[0]; x <= hi[0]; x++) {
                            int32_t g[3] = {x, y, z};
                            float box_min[3], box_max[3];
                            for (int i = 0; i < 3; i++) {
                                float shift = i == axis ? 0.5f : 0.0f;
                                box_min[i] = cascade->origin[i] + ((float)g[i] - shift) * s;
                                box_max[i] = box_min[i] + s;
                            }
                            double area = face_cell_area(v, box_min, box_max);
                            if (!(area > 0.0))
                                continue;
                            pieces++;
                            float weight =
                                (float)(coverage * area / ((double)s * s) / LOBE_PEAK);
                            float *out =
                                gv + (k * cells + ((uint64_t)z * size + y) * size + x) *
                                         PF_LPV_GV_FLOATS_PER_CELL +
                                4 * axis;
                            for (int c = 0; c < 4; c++)
                                out[c] += weight * lobe[c];
                        }
            }
        }
    }
    return pieces;
}
