/*
 * Tangents for a normal-mapped primitive that has none (glTF: "When tangents
 * are not specified, client implementations SHOULD calculate tangents using
 * default MikkTSpace algorithms"). MikkTSpace is not packaged in Debian 12, so
 * this follows its rules rather than its code:
 *
 * - a triangle's tangent is its UV gradient along u (Lengyel 2001), and its
 *   handedness the sign of its UV area: a mirrored UV chart has the other;
 * - the corners of a vertex share one tangent per handedness: the triangles
 *   around the vertex that agree on it are summed, each triangle's tangent
 *   first projected onto the vertex normal's plane and weighted by its angle
 *   at that corner (MikkTSpace's weights), then made orthogonal to the normal;
 * - so a vertex on the seam between a chart and its mirror image (a
 *   character's symmetric halves share the centre line's vertices) keeps a
 *   frame for each side, where one sum over both would cancel.
 *
 * MikkTSpace also splits a vertex's triangles of one handedness into groups
 * that are not connected around it, and gives degenerate triangles their
 * neighbours' frame; here they share the vertex's sum, and a triangle with no
 * UV area takes the vertex's other handedness where it has one.
 */
#include "scene_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Sums per vertex and handedness (0: positive UV area, 1: negative). */
typedef struct tangent_sums {
    float tangent[2][3];
    float bitangent[2][3];
    float face_normal[3];
} tangent_sums;

static float corner_angle(const float *at, const float *a, const float *b)
{
    float u[3], v[3];
    for (int k = 0; k < 3; k++) {
        u[k] = a[k] - at[k];
        v[k] = b[k] - at[k];
    }
    float lu = scene_vec3_normalize(u), lv = scene_vec3_normalize(v);
    if (!(lu > 0.0f) || !(lv > 0.0f))
        return 0.0f;
    float c = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    return acosf(c < -1.0f ? -1.0f : c > 1.0f ? 1.0f : c);
}

/* v minus its component along unit n, normalised; 0 when nothing is left. */
static float project_normalize(float v[3], const float n[3])
{
    float d = n[0] * v[0] + n[1] * v[1] + n[2] * v[2];
    for (int k = 0; k < 3; k++)
        v[k] -= d * n[k];
    float length = scene_vec3_normalize(v);
    return length > 0.0f && isfinite(length) ? length : 0.0f;
}

/* Triangle t's UV-gradient tangent and bitangent (unnormalised) and its handedness group;
 * -1 where its UV area is zero. */
static int triangle_frame(const float *p[3], const float *w[3], float tangent[3],
                          float bitangent[3])
{
    float e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = p[1][k] - p[0][k];
        e2[k] = p[2][k] - p[0][k];
    }
    float du1 = w[1][0] - w[0][0], dv1 = w[1][1] - w[0][1];
    float du2 = w[2][0] - w[0][0], dv2 = w[2][1] - w[0][1];
    float det = du1 * dv2 - du2 * dv1;
    if (!(fabsf(det) > 0.0f) || !isfinite(det))
        return -1;
    /* e·(uv cofactors) with det's sign: the gradients' directions without dividing by det. */
    float sign = det < 0.0f ? -1.0f : 1.0f;
    for (int k = 0; k < 3; k++) {
        tangent[k] = sign * (e1[k] * dv2 - e2[k] * dv1);
        bitangent[k] = sign * (e2[k] * du1 - e1[k] * du2);
    }
    return det < 0.0f;
}

static const float *vertex_normal(const float *normals, const tangent_sums *sums, uint32_t v,
                                  float n[3])
{
    memcpy(n, normals ? normals + 3 * (size_t)v : sums[v].face_normal, 3 * sizeof *n);
    return scene_vec3_normalize(n) > 0.0f ? n : NULL;
}

pf_status scene_generate_tangents(const float *positions, const float *normals, const float *uvs,
                                  uint32_t vertex_count, const uint32_t *corners,
                                  uint32_t triangle_count, float **out, pf_error *err)
{
    *out = NULL;
    tangent_sums *sums = calloc((size_t)vertex_count + 1, sizeof *sums);
    int8_t *group = malloc((size_t)triangle_count + 1);
    float *tangents = calloc((size_t)triangle_count * 12 + 1, sizeof *tangents);
    if (!sums || !group || !tangents) {
        free(sums);
        free(group);
        free(tangents);
        return pf_error_set(err, PF_ERR_NOMEM, "tangents of %u triangles: out of memory",
                            triangle_count);
    }
    /* Face normals first: the vertex normal where the file has none. */
    for (uint32_t t = 0; t < triangle_count; t++) {
        const uint32_t *c = corners + 3 * (size_t)t;
        float e1[3], e2[3], face[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = positions[3 * (size_t)c[1] + k] - positions[3 * (size_t)c[0] + k];
            e2[k] = positions[3 * (size_t)c[2] + k] - positions[3 * (size_t)c[0] + k];
        }
        scene_cross(e1, e2, face);
        for (int corner = 0; corner < 3; corner++)
            for (int k = 0; k < 3; k++)
                sums[c[corner]].face_normal[k] += face[k];
    }
    for (uint32_t t = 0; t < triangle_count; t++) {
        const uint32_t *c = corners + 3 * (size_t)t;
        const float *p[3], *w[3];
        for (int corner = 0; corner < 3; corner++) {
            p[corner] = positions + 3 * (size_t)c[corner];
            w[corner] = uvs + 2 * (size_t)c[corner];
        }
        float tangent[3], bitangent[3];
        group[t] = (int8_t)triangle_frame(p, w, tangent, bitangent);
        if (group[t] < 0)
            continue;
        for (int corner = 0; corner < 3; corner++) {
            float n[3], ct[3], cb[3];
            if (!vertex_normal(normals, sums, c[corner], n))
                continue;
            memcpy(ct, tangent, sizeof ct);
            memcpy(cb, bitangent, sizeof cb);
            if (!project_normalize(ct, n) || !project_normalize(cb, n))
                continue;
            float angle = corner_angle(p[corner], p[(corner + 1) % 3], p[(corner + 2) % 3]);
            tangent_sums *s = &sums[c[corner]];
            for (int k = 0; k < 3; k++) {
                s->tangent[group[t]][k] += angle * ct[k];
                s->bitangent[group[t]][k] += angle * cb[k];
            }
        }
    }
    for (uint32_t t = 0; t < triangle_count; t++) {
        for (int corner = 0; corner < 3; corner++) {
            uint32_t v = corners[3 * (size_t)t + corner];
            float n[3];
            if (!vertex_normal(normals, sums, v, n))
                continue; /* no normal: no tangent (w 0 reads as "none") */
            /* The triangle's own handedness; without UV area, the one the vertex has. */
            int first = group[t] >= 0 ? group[t] : 0, last = group[t] >= 0 ? group[t] : 1;
            float t3[3] = {0.0f, 0.0f, 0.0f}, b3[3] = {0.0f, 0.0f, 0.0f};
            int found = 0;
            for (int g = first; g <= last && !found; g++) {
                memcpy(t3, sums[v].tangent[g], sizeof t3);
                memcpy(b3, sums[v].bitangent[g], sizeof b3);
                found = project_normalize(t3, n) > 0.0f;
            }
            if (!found)
                continue;
            float nt[3];
            scene_cross(n, t3, nt);
            float *o = tangents + 12 * (size_t)t + 4 * corner;
            memcpy(o, t3, sizeof t3);
            o[3] = nt[0] * b3[0] + nt[1] * b3[1] + nt[2] * b3[2] < 0.0f ? -1.0f : 1.0f;
        }
    }
    free(sums);
    free(group);
    *out = tangents;
    return PF_OK;
}
