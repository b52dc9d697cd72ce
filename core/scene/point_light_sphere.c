/*
 * The point light's replacement by an equal-power spherical area light (see
 * pf_scene_frame_point_light_to_sphere in pf_scene.h). A UV sphere: rings of constant polar angle, the pole rows
 * one triangle per segment, vertices computed once and shared so the
 * polyhedron is watertight.
 */
#include "pf_scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Grows *array to count elements of size bytes; 0 on failure (the old array stays). */
static int grow(void **array, size_t count, size_t size)
{
    void *grown = realloc(*array, count * size);
    if (!grown)
        return 0;
    *array = grown;
    return 1;
}

static void sphere_vertex(const float centre[3], double radius, uint32_t ring, uint32_t rings,
                          uint32_t segment, uint32_t segments, float out[4])
{
    const double pi = acos(-1.0);
    /* Exact poles and an exact seam (segment == segments is segment 0): no cracks. */
    double sin_theta = (ring == 0 || ring == rings) ? 0.0 : sin(pi * ring / rings);
    double cos_theta = ring == 0 ? 1.0 : (ring == rings ? -1.0 : cos(pi * ring / rings));
    double phi = 2.0 * pi * (segment % segments) / segments;
    out[0] = centre[0] + (float)(radius * sin_theta * cos(phi));
    out[1] = centre[1] + (float)(radius * cos_theta);
    out[2] = centre[2] + (float)(radius * sin_theta * sin(phi));
    out[3] = 0.0f;
}

/*
 * Stores triangle (a, b, c) at index t, wound so that its front
 * (counter-clockwise) face looks away from the centre; returns its area.
 */
static double put_triangle(pf_scene_frame *frame, uint32_t t, const float centre[3],
                           const float *a, const float *b, const float *c)
{
    double e1[3], e2[3], normal[3], outward = 0.0, length = 0.0;
    for (int i = 0; i < 3; i++) {
        e1[i] = (double)b[i] - a[i];
        e2[i] = (double)c[i] - a[i];
    }
    normal[0] = e1[1] * e2[2] - e1[2] * e2[1];
    normal[1] = e1[2] * e2[0] - e1[0] * e2[2];
    normal[2] = e1[0] * e2[1] - e1[1] * e2[0];
    for (int i = 0; i < 3; i++) {
        outward += normal[i] * (((double)a[i] + b[i] + c[i]) / 3.0 - centre[i]);
        length += normal[i] * normal[i];
    }
    length = sqrt(length);
    double sign = outward < 0.0 ? -1.0 : 1.0;
    const float *corners[3] = {a, outward < 0.0 ? c : b, outward < 0.0 ? b : c};
    for (int k = 0; k < 3; k++) {
        memcpy(frame->vertices[3 * t + k], corners[k], 4 * sizeof(float));
        for (int i = 0; i < 3; i++)
            frame->normals[3 * t + k][i] = (float)(sign * normal[i] / length);
        frame->normals[3 * t + k][3] = 0.0f;
        for (int i = 0; i < 3; i++) {
            frame->bounds_min[i] = fminf(frame->bounds_min[i], corners[k][i]);
            frame->bounds_max[i] = fmaxf(frame->bounds_max[i], corners[k][i]);
        }
    }
    return 0.5 * length;
}

pf_status pf_scene_frame_point_light_to_sphere(pf_scene_frame *frame, uint32_t light,
                                              float radius, uint32_t segments,
                                              uint32_t rings, pf_error *err)
{
    if (light >= frame->light_count || frame->lights[light].kind != PF_LIGHT_POINT)
        return pf_error_set(err, PF_ERR_INVALID, "lights[%u]: not a point light of this frame",
                            light);
    if (!(radius > 0.0f) || segments < 3 || rings < 2)
        return pf_error_set(err, PF_ERR_INVALID,
                            "sphere light: radius %g, %u segments, %u rings (need > 0, ≥ 3, ≥ 2)",
                            (double)radius, segments, rings);
    /* Pole rows have one triangle per segment, the others two. */
    uint32_t added = 2u * segments * (rings - 1u);
    size_t total = (size_t)frame->triangle_count + added;
    if (!grow((void **)&frame->vertices, 3 * total, sizeof *frame->vertices) ||
        !grow((void **)&frame->normals, 3 * total, sizeof *frame->normals) ||
        !grow((void **)&frame->triangle_material, total, sizeof *frame->triangle_material) ||
        !grow((void **)&frame->triangle_node, total, sizeof *frame->triangle_node) ||
        !grow((void **)&frame->materials, frame->material_count + 1u, sizeof *frame->materials) ||
        (frame->corners &&
         !grow((void **)&frame->corners, 3 * PF_CORNER_TEXELS * total, sizeof *frame->corners)))
        return pf_error_set(err, PF_ERR_NOMEM, "sphere light: out of memory for %zu triangles",
                            total);
    pf_light point = frame->lights[light];
    uint32_t material = frame->material_count;
    if (frame->triangle_count == 0)
        for (int i = 0; i < 3; i++) {
            frame->bounds_min[i] = INFINITY;
            frame->bounds_max[i] = -INFINITY;
        }
    uint32_t t = frame->triangle_count;
    double area = 0.0;
    for (uint32_t r = 0; r < rings; r++) {
        for (uint32_t s = 0; s < segments; s++) {
            float top0[4], top1[4], bottom0[4], bottom1[4];
            sphere_vertex(point.position, radius, r, rings, s, segments, top0);
            sphere_vertex(point.position, radius, r, rings, s + 1, segments, top1);
            sphere_vertex(point.position, radius, r + 1, rings, s, segments, bottom0);
            sphere_vertex(point.position, radius, r + 1, rings, s + 1, segments, bottom1);
            if (r != rings - 1)
                area += put_triangle(frame, t++, point.position, top0, bottom0, bottom1);
            if (r != 0)
                area += put_triangle(frame, t++, point.position, top0, bottom1, top1);
        }
    }
    for (uint32_t i = frame->triangle_count; i < t; i++) {
        frame->triangle_material[i] = material;
        frame->triangle_node[i] = UINT32_MAX;
        /* Untextured corners: uv 0, white, no tangent. */
        for (uint32_t k = 0; frame->corners && k < 3 * PF_CORNER_TEXELS; k++) {
            float *texel = frame->corners[3 * PF_CORNER_TEXELS * (size_t)i + k];
            float value = k % PF_CORNER_TEXELS == 1 ? 1.0f : 0.0f;
            texel[0] = texel[1] = texel[2] = texel[3] = value;
        }
    }
    /* Power of an isotropic point light 4π·I = power of a Lambert emitter π·Le·A. */
    pf_material emitter = pf_material_lambert(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < 3; i++)
        emitter.emission[i] = (float)(4.0 * point.intensity[i] / area);
    frame->materials[material] = emitter;
    frame->material_count++;
    frame->triangle_count = t;
    frame->emissive_triangle_count += added;
    memmove(&frame->lights[light], &frame->lights[light + 1],
            (frame->light_count - light - 1) * sizeof *frame->lights);
    frame->light_count--;
    return PF_OK;
}
