/*
 * Emitter powers and the alias table photon emission picks lights from
 * (pf_photon_emitters_build in pf_photon.h, which gives the formulas).
 */
#include "pf_photon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Rec. 709 luminance, as lights.glsl's light_luminance. */
static double luminance(const float rgb[3])
{
    return PF_LUMINANCE_R * rgb[0] + PF_LUMINANCE_G * rgb[1] + PF_LUMINANCE_B * rgb[2];
}

void pf_photon_light_power(const pf_light *light, float scene_radius, float power[3])
{
    double factor = 0.0;
    switch ((pf_light_kind)light->kind) {
    case PF_LIGHT_POINT:
        factor = 4.0 * PI;
        break;
    case PF_LIGHT_SPOT: {
        double inner = light->cos_inner_cone, outer = light->cos_outer_cone;
        /* lights.glsl spot_cone_integral: the squared ramp between the cones
         * integrates to a third of its band. */
        factor = inner > outer ? 2.0 * PI * ((1.0 - inner) + (inner - outer) / 3.0)
                               : 2.0 * PI * (1.0 - outer);
        break;
    }
    case PF_LIGHT_DIRECTIONAL:
        factor = PI * (double)scene_radius * scene_radius;
        break;
    }
    for (int c = 0; c < 3; c++)
        power[c] = (float)(factor * light->intensity[c]);
}

static double triangle_area(const float (*v)[4])
{
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)v[1][k] - v[0][k];
        e2[k] = (double)v[2][k] - v[0][k];
    }
    double cx = e1[1] * e2[2] - e1[2] * e2[1];
    double cy = e1[2] * e2[0] - e1[0] * e2[2];
    double cz = e1[0] * e2[1] - e1[1] * e2[0];
    return 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
}

void pf_photon_emitters_free(pf_photon_emitters *emitters)
{
    free(emitters->entries);
    memset(emitters, 0, sizeof *emitters);
}

/* Appends an emitter of positive luminance power; 0 when skipped. */
static int add_emitter(pf_photon_emitters *out, double *weights, uint32_t kind, uint32_t index,
                       const float power[3])
{
    double weight = luminance(power);
    if (!(weight > 0.0))
        return 0;
    pf_photon_emitter *e = &out->entries[out->count];
    memset(e, 0, sizeof *e);
    e->kind = kind;
    e->index = index;
    memcpy(e->power, power, sizeof e->power);
    weights[out->count++] = weight;
    for (int c = 0; c < 3; c++)
        out->total_power[c] += power[c];
    return 1;
}

pf_status pf_photon_emitters_build(const pf_scene_frame *frame, pf_photon_emitters *out,
                                   pf_error *err)
{
    memset(out, 0, sizeof *out);
    for (int k = 0; k < 3; k++)
        out->scene_center[k] = 0.5f * (frame->bounds_min[k] + frame->bounds_max[k]);
    out->scene_radius = (float)(0.5 * pf_scene_frame_diagonal(frame));
    uint32_t capacity = frame->light_count + frame->triangle_count;
    out->entries = malloc((capacity ? capacity : 1) * sizeof *out->entries);
    double *weights = malloc((capacity ? capacity : 1) * sizeof *weights);
    float *threshold = malloc((capacity ? capacity : 1) * sizeof *threshold);
    uint32_t *alias = malloc((capacity ? capacity : 1) * sizeof *alias);
    pf_status status = PF_OK;
    if (!out->entries || !weights || !threshold || !alias)
        status = pf_error_set(err, PF_ERR_NOMEM, "photon emitters: %u candidates", capacity);
    for (uint32_t i = 0; status == PF_OK && i < frame->light_count; i++) {
        float power[3];
        pf_photon_light_power(&frame->lights[i], out->scene_radius, power);
        if (!isfinite(power[0]) || !isfinite(power[1]) || !isfinite(power[2]))
            status = pf_error_set(err, PF_ERR_INVALID, "light %u: power is not finite", i);
        else
            add_emitter(out, weights, frame->lights[i].kind, i, power);
    }
    for (uint32_t t = 0; status == PF_OK && t < frame->triangle_count; t++) {
        const pf_material *material = &frame->materials[frame->triangle_material[t]];
        const float *emission = material->emission;
        if (emission[0] <= 0.0f && emission[1] <= 0.0f && emission[2] <= 0.0f)
            continue;
        double area = triangle_area(frame->vertices + 3 * (size_t)t);
        double faces = material->flags & PF_MATERIAL_DOUBLE_SIDED ? 2.0 : 1.0;
        float power[3];
        for (int c = 0; c < 3; c++)
            power[c] = (float)(faces * PI * area * fmax(emission[c], 0.0f));
        if (!isfinite(power[0]) || !isfinite(power[1]) || !isfinite(power[2]))
            status = pf_error_set(err, PF_ERR_INVALID, "emissive triangle %u: power is not finite",
                                  t);
        else
            add_emitter(out, weights, PF_EMITTER_TRIANGLE, t, power);
    }
    if (status == PF_OK && out->count > 0)
        status = pf_alias_table_build(weights, out->count, threshold, alias, err);
    if (status == PF_OK) {
        double total = 0.0;
        for (uint32_t i = 0; i < out->count; i++)
            total += weights[i];
        for (uint32_t i = 0; i < out->count; i++) {
            out->entries[i].alias_threshold = threshold[i];
            out->entries[i].alias = alias[i];
            out->entries[i].pick_probability = (float)(weights[i] / total);
        }
    }
    free(weights);
    free(threshold);
    free(alias);
    if (status != PF_OK)
        pf_photon_emitters_free(out);
    return status;
}
