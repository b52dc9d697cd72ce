/*
 * Tangents for a normal-mapped primitive that has none (glTF: "When tangents
 * are not specified, client implementations SHOULD calculate tangents using
 * default MikkTSpace algorithms").
 *
 * Per vertex, the UV-gradient tangent of each triangle that uses it is summed
 * weighted by the triangle's area (Lengyel 2001), made orthogonal to the
 * vertex normal (Gram-Schmidt), and w is the bitangent's handedness. This is
 * the frame MikkTSpace builds for a mesh whose UV charts have no seams inside
 * a vertex; MikkTSpace itself also splits vertices where the tangent frames
 * of the triangles around it disagree and weighs by corner angle, so on
 * meshes with mirrored UVs sharing vertices the two differ (not packaged in
 * Debian 12; a file that carries TANGENT is used as written).
 */
#include "scene_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

pf_status scene_generate_tangents(const float *positions, const float *normals, const float *uvs,
                                  uint32_t vertex_count, const uint32_t *corners,
                                  uint32_t triangle_count, float **out, pf_error *err)
{
    *out = NULL;
    float *sum_t = calloc((size_t)vertex_count * 3, sizeof *sum_t);
    float *sum_b = calloc((size_t)vertex_count * 3, sizeof *sum_b);
    float *sum_n = calloc((size_t)vertex_count * 3, sizeof *sum_n);
    float *tangents = calloc((size_t)vertex_count * 4 + 1, sizeof *tangents);
    if (!sum_t || !sum_b || !sum_n || !tangents) {
        free(sum_t);
        free(sum_b);
        free(sum_n);
        free(tangents);
        return pf_error_set(err, PF_ERR_NOMEM, "tangents of %u vertices: out of memory",
                            vertex_count);
    }
    for (uint32_t t = 0; t < triangle_count; t++) {
        const uint32_t *c = corners + 3 * (size_t)t;
        const float *p0 = positions + 3 * (size_t)c[0], *p1 = positions + 3 * (size_t)c[1],
                    *p2 = positions + 3 * (size_t)c[2];
        const float *w0 = uvs + 2 * (size_t)c[0], *w1 = uvs + 2 * (size_t)c[1],
                    *w2 = uvs + 2 * (size_t)c[2];
        float e1[3], e2[3], face[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = p1[k] - p0[k];
            e2[k] = p2[k] - p0[k];
        }
        scene_cross(e1, e2, face);
        float du1 = w1[0] - w0[0], dv1 = w1[1] - w0[1];
        float du2 = w2[0] - w0[0], dv2 = w2[1] - w0[1];
        float det = du1 * dv2 - du2 * dv1;
        /* Dividing by det would weigh a triangle by its UV area; e·(uv cofactors) with det's
         * sign keeps the direction and weighs by the triangle's area (|face|), as Lengyel's
         * sum does once normalised per triangle. */
        float tangent[3], bitangent[3];
        for (int k = 0; k < 3; k++) {
            tangent[k] = e1[k] * dv2 - e2[k] * dv1;
            bitangent[k] = e2[k] * du1 - e1[k] * du2;
        }
        if (!(fabsf(det) > 0.0f) || !isfinite(det))
            continue;
        float sign = det < 0.0f ? -1.0f : 1.0f;
        float lt = sqrtf(tangent[0] * tangent[0] + tangent[1] * tangent[1] +
                         tangent[2] * tangent[2]);
        float lb = sqrtf(bitangent[0] * bitangent[0] + bitangent[1] * bitangent[1] +
                         bitangent[2] * bitangent[2]);
        float area = 0.5f * sqrtf(face[0] * face[0] + face[1] * face[1] + face[2] * face[2]);
        if (!(lt > 0.0f) || !(lb > 0.0f) || !isfinite(lt) || !isfinite(lb))
            continue;
        for (int corner = 0; corner < 3; corner++)
            for (int k = 0; k < 3; k++) {
                sum_t[3 * (size_t)c[corner] + k] += sign * tangent[k] / lt * area;
                sum_b[3 * (size_t)c[corner] + k] += sign * bitangent[k] / lb * area;
                sum_n[3 * (size_t)c[corner] + k] += face[k];
            }
    }
    for (uint32_t v = 0; v < vertex_count; v++) {
        float n[3], t[3], b[3];
        memcpy(n, normals ? normals + 3 * (size_t)v : sum_n + 3 * (size_t)v, sizeof n);
        memcpy(t, sum_t + 3 * (size_t)v, sizeof t);
        memcpy(b, sum_b + 3 * (size_t)v, sizeof b);
        if (!(scene_vec3_normalize(n) > 0.0f))
            continue; /* no normal: no tangent (w 0 reads as "none") */
        float d = n[0] * t[0] + n[1] * t[1] + n[2] * t[2];
        for (int k = 0; k < 3; k++)
            t[k] -= d * n[k];
        float length = scene_vec3_normalize(t);
        if (!(length > 0.0f) || !isfinite(length))
            continue;
        float nt[3];
        scene_cross(n, t, nt);
        float handedness = nt[0] * b[0] + nt[1] * b[1] + nt[2] * b[2] < 0.0f ? -1.0f : 1.0f;
        memcpy(tangents + 4 * (size_t)v, t, sizeof t);
        tangents[4 * (size_t)v + 3] = handedness;
    }
    free(sum_t);
    free(sum_b);
    free(sum_n);
    *out = tangents;
    return PF_OK;
}
