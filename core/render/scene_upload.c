/* One frame's scene on the GPU (pf_gpu_scene) and the emissive picking table. */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Rec. 709 luminance weights (pf_common.h), in floats, for picking lights by power. */
#define LUMINANCE_R ((float)PF_LUMINANCE_R)
#define LUMINANCE_G ((float)PF_LUMINANCE_G)
#define LUMINANCE_B ((float)PF_LUMINANCE_B)

/* Stand-in contents for an empty array (every GPU struct here is at most 64 bytes). */
#define EMPTY_ARRAY_BYTES 64u

/* A buffer of at least min_bytes with data uploaded, blocking (cmds NULL) or recorded. */
static pf_status buffer_with_data(pf_vk_context *ctx, pf_vk_commands *cmds, const char *label,
                                  const void *data, uint64_t size, uint64_t min_bytes,
                                  pf_vk_buffer **out, pf_error *err)
{
    static const unsigned char zeros[EMPTY_ARRAY_BYTES];
    uint64_t bytes = size > min_bytes ? size : min_bytes;
    pf_status status = pf_vk_buffer_create(ctx, bytes, label, out, err);
    if (status != PF_OK)
        return status;
    if (size == 0) {
        data = zeros;
        size = min_bytes < EMPTY_ARRAY_BYTES ? min_bytes : EMPTY_ARRAY_BYTES;
    }
    status = cmds ? pf_vk_cmd_upload(cmds, *out, 0, data, size, err)
                  : pf_vk_buffer_upload(ctx, *out, 0, data, size, err);
    if (status != PF_OK)
        pf_render_buffer_release(ctx, out);
    return status;
}

pf_status pf_render_buffer_with_data(pf_vk_context *ctx, const char *label, const void *data,
                                     uint64_t size, uint64_t min_bytes, pf_vk_buffer **out,
                                     pf_error *err)
{
    return buffer_with_data(ctx, NULL, label, data, size, min_bytes, out, err);
}

pf_status pf_render_buffer_recorded(pf_vk_context *ctx, pf_vk_commands *cmds, const char *label,
                                    const void *data, uint64_t size, uint64_t min_bytes,
                                    pf_vk_buffer **out, pf_error *err)
{
    return buffer_with_data(ctx, cmds, label, data, size, min_bytes, out, err);
}

static float triangle_area(const float (*vertices)[4])
{
    float e1[3], e2[3];
    for (int i = 0; i < 3; i++) {
        e1[i] = vertices[1][i] - vertices[0][i];
        e2[i] = vertices[2][i] - vertices[0][i];
    }
    float cx = e1[1] * e2[2] - e1[2] * e2[1];
    float cy = e1[2] * e2[0] - e1[0] * e2[2];
    float cz = e1[0] * e2[1] - e1[1] * e2[0];
    return 0.5f * sqrtf(cx * cx + cy * cy + cz * cz);
}

/* The alias columns of weights (pf_alias_table_build, core/common) in *threshold and *alias,
 * malloc'ed (the caller frees both, also on failure); what names the table in errors. */
static pf_status alias_columns(const double *weights, uint32_t count, const char *what,
                               float **threshold, uint32_t **alias, pf_error *err)
{
    *threshold = malloc(count * sizeof **threshold);
    *alias = malloc(count * sizeof **alias);
    return *threshold && *alias
               ? pf_alias_table_build(weights, count, *threshold, *alias, err)
               : pf_error_set(err, PF_ERR_NOMEM, "%s: %u entries", what, count);
}

/* Fills the alias columns of table from weights. */
static pf_status alias_table_fill(pf_emissive_entry *table, const double *weights, uint32_t count,
                                  double total, pf_error *err)
{
    float *threshold;
    uint32_t *alias;
    pf_status status =
        alias_columns(weights, count, "emissive alias table", &threshold, &alias, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        table[i].alias_threshold = threshold[i];
        table[i].alias = alias[i];
        table[i].pick_pdf = (float)(weights[i] / total);
    }
    free(threshold);
    free(alias);
    return status;
}

/*
 * The frame's lights as the kernels read them: with their alias table by power
 * (pf_light.pick_*), which direct_light.glsl samples from past PF_DIRECT_LIGHTS_EVERY_MAX
 * lights. A light of no (or no finite) power is never picked: it lights nothing. NULL with
 * PF_OK for a frame without lights.
 */
static pf_status lights_with_picks(const pf_scene_frame *frame, pf_light **out, pf_error *err)
{
    *out = NULL;
    uint32_t count = frame->light_count;
    if (count == 0)
        return PF_OK;
    pf_light *lights = malloc(count * sizeof *lights);
    double *weights = malloc(count * sizeof *weights);
    float *threshold = NULL;
    uint32_t *alias = NULL;
    pf_status status = lights && weights
                           ? PF_OK
                           : pf_error_set(err, PF_ERR_NOMEM, "light table: %u lights", count);
    /* Directional lights' power is over the scene's bounding disc, as photon emission's. */
    float radius = (float)(0.5 * pf_scene_frame_diagonal(frame));
    double total = 0.0;
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        lights[i] = frame->lights[i];
        float power[3];
        pf_photon_light_power(&lights[i], radius, power);
        double weight = PF_LUMINANCE_R * power[0] + PF_LUMINANCE_G * power[1] +
                        PF_LUMINANCE_B * power[2];
        weights[i] = weight > 0.0 && isfinite(weight) ? weight : 0.0;
        total += weights[i];
    }
    int table = status == PF_OK && total > 0.0 && isfinite(total);
    if (table)
        status = alias_columns(weights, count, "light table", &threshold, &alias, err);
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        lights[i].pick_threshold = table ? threshold[i] : 0.0f;
        lights[i].pick_alias = table ? alias[i] : i;
        lights[i].pick_pdf = table ? (float)(weights[i] / total) : 0.0f;
    }
    free(weights);
    free(threshold);
    free(alias);
    if (status != PF_OK) {
        free(lights);
        return status;
    }
    *out = lights;
    return PF_OK;
}

pf_status pf_emissive_table_build(const pf_scene_frame *frame, pf_emissive_entry **entries,
                                  uint32_t *count, double *weight_total, pf_error *err)
{
    *entries = NULL;
    *count = 0;
    if (weight_total)
        *weight_total = 0.0;
    uint32_t candidates = 0;
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        const float *e = frame->materials[frame->triangle_material[t]].emission;
        if (LUMINANCE_R * e[0] + LUMINANCE_G * e[1] + LUMINANCE_B * e[2] > 0.0f)
            candidates++;
    }
    if (candidates == 0)
        return PF_OK;
    pf_emissive_entry *table = calloc(candidates, sizeof *table);
    double *weights = malloc(candidates * sizeof *weights);
    if (!table || !weights) {
        free(table);
        free(weights);
        return pf_error_set(err, PF_ERR_NOMEM, "emissive table: %u entries", candidates);
    }
    double total = 0.0;
    uint32_t used = 0;
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        const float *e = frame->materials[frame->triangle_material[t]].emission;
        float luminance = LUMINANCE_R * e[0] + LUMINANCE_G * e[1] + LUMINANCE_B * e[2];
        float area = triangle_area(&frame->vertices[3 * (size_t)t]);
        if (!(luminance > 0.0f) || !(area > 0.0f) || !isfinite(luminance) || !isfinite(area))
            continue;
        table[used].triangle = t;
        table[used].area = area;
        weights[used] = (double)area * luminance;
        total += weights[used];
        used++;
    }
    pf_status status = PF_OK;
    if (used > 0 && total > 0.0 && isfinite(total))
        status = alias_table_fill(table, weights, used, total, err);
    free(weights);
    if (used == 0 || !(total > 0.0) || !isfinite(total) || status != PF_OK) {
        free(table);
        return status;
    }
    *entries = table;
    *count = used;
    if (weight_total)
        *weight_total = total;
    return PF_OK;
}

void pf_render_buffer_release(pf_vk_context *ctx, pf_vk_buffer **buffer)
{
    if (*buffer)
        pf_vk_buffer_destroy(ctx, *buffer);
    *buffer = NULL;
}

void pf_gpu_scene_release(pf_vk_context *ctx, pf_gpu_scene *scene)
{
    pf_render_buffer_release(ctx, &scene->vertices);
    pf_render_buffer_release(ctx, &scene->normals);
    pf_render_buffer_release(ctx, &scene->triangle_material);
    pf_render_buffer_release(ctx, &scene->materials);
    pf_render_buffer_release(ctx, &scene->lights);
    pf_render_buffer_release(ctx, &scene->emissive);
    pf_render_buffer_release(ctx, &scene->corners);
    if (!scene->textures_borrowed) {
        pf_render_buffer_release(ctx, &scene->textures);
        pf_render_buffer_release(ctx, &scene->texels);
    }
    scene->textures = scene->texels = NULL;
    scene->textures_borrowed = 0;
    scene->emissive_count = 0;
}

uint32_t pf_gpu_scene_bindings(const pf_gpu_scene *scene, pf_vk_buffer *params,
                               pf_vk_buffer *const *own, uint32_t own_count,
                               pf_vk_buffer **bindings)
{
    bindings[PF_SCENE_BINDING_PARAMS] = params;
    bindings[PF_SCENE_BINDING_VERTICES] = scene->vertices;
    bindings[PF_SCENE_BINDING_NORMALS] = scene->normals;
    bindings[PF_SCENE_BINDING_TRIANGLE_MATERIALS] = scene->triangle_material;
    bindings[PF_SCENE_BINDING_MATERIALS] = scene->materials;
    bindings[PF_SCENE_BINDING_LIGHTS] = scene->lights;
    bindings[PF_SCENE_BINDING_EMISSIVE] = scene->emissive;
    bindings[PF_SCENE_BINDING_CORNERS] = scene->corners;
    bindings[PF_SCENE_BINDING_TEXTURES] = scene->textures;
    bindings[PF_SCENE_BINDING_TEXELS] = scene->texels;
    for (uint32_t i = 0; i < own_count; i++)
        bindings[PF_SCENE_BINDING_COUNT + i] = own[i];
    return PF_SCENE_BINDING_COUNT + own_count;
}

/*
 * The triangle material words with TRIANGLE_ALPHA_TESTED (scene_geometry.glsl) set where the
 * material's alphaMode is MASK or BLEND, or it is unlit (seen by camera rays only); *words
 * NULL when no material is (the frame's array is uploaded as it is).
 */
#define TRIANGLE_ALPHA_TESTED 0x80000000u
static pf_status triangle_material_words(const pf_scene_frame *frame, uint32_t **words,
                                         pf_error *err)
{
    *words = NULL;
    if (!(pf_scene_frame_surface_features(frame) & PF_SURFACE_ALPHA))
        return PF_OK;
    if (frame->material_count >= TRIANGLE_ALPHA_TESTED)
        return pf_error_set(err, PF_ERR_LIMIT, "%u materials: too many", frame->material_count);
    *words = malloc((size_t)frame->triangle_count * sizeof **words + 1);
    if (!*words)
        return pf_error_set(err, PF_ERR_NOMEM, "triangle materials: out of memory");
    for (uint32_t t = 0; t < frame->triangle_count; t++) {
        uint32_t m = frame->triangle_material[t];
        const pf_material *material = &frame->materials[m];
        (*words)[t] = m | (material->alpha_mode != PF_ALPHA_OPAQUE ||
                                   (material->flags & PF_MATERIAL_UNLIT)
                               ? TRIANGLE_ALPHA_TESTED
                               : 0u);
    }
    return PF_OK;
}

/* The materials buffer (pf_materials_buffer_write: the sheen's tables, then the materials). */
static pf_status materials_upload(pf_vk_context *ctx, pf_vk_commands *cmds,
                                  const pf_scene_frame *frame, pf_vk_buffer **out, pf_error *err)
{
    uint64_t bytes = pf_materials_buffer_bytes(frame->material_count);
    void *data = malloc(bytes);
    if (!data)
        return pf_error_set(err, PF_ERR_NOMEM, "materials: out of memory");
    pf_materials_buffer_write(frame->materials, frame->material_count, data);
    pf_status status = buffer_with_data(ctx, cmds, "materials", data, bytes, bytes, out, err);
    free(data);
    return status;
}

/* The frame's texture table and texels in two new buffers (16-byte placeholders if none). */
static pf_status texture_upload(pf_vk_context *ctx, pf_vk_commands *cmds,
                                const pf_scene_frame *frame, pf_vk_buffer **textures,
                                pf_vk_buffer **texels, pf_error *err)
{
    pf_status status = buffer_with_data(ctx, cmds, "textures", frame->textures,
                                        frame->texture_count * sizeof(pf_texture_ref), 16,
                                        textures, err);
    if (status == PF_OK)
        status = buffer_with_data(ctx, cmds, "texels", frame->texels,
                                  frame->texel_count * sizeof(uint32_t), 16, texels, err);
    if (status != PF_OK)
        pf_render_buffer_release(ctx, textures);
    return status;
}

pf_status pf_render_prepare_textures(pf_renderer *renderer, const pf_scene_frame *frame,
                                     pf_frame_report *report, pf_error *err)
{
    double start = pf_time_ms();
    pf_texture_cache *cache = &renderer->textures;
    /* The surface features the frame's kernels are specialised for (render_internal.h). */
    renderer->surface_features = pf_scene_frame_surface_features(frame);
    if (frame->texture_count == 0) {
        pf_frame_report_row(report, "textures", "no textures", 0.0, -1.0);
        return PF_OK;
    }
    double megabytes = (double)(frame->texel_count * sizeof(uint32_t) +
                                frame->texture_count * sizeof(pf_texture_ref)) /
                       (1024.0 * 1024.0);
    int uploaded = 0;
    if (frame->texture_set == 0 || cache->texture_set != frame->texture_set) {
        pf_render_buffer_release(renderer->ctx, &cache->textures);
        pf_render_buffer_release(renderer->ctx, &cache->texels);
        cache->texture_set = 0;
        pf_status status =
            texture_upload(renderer->ctx, NULL, frame, &cache->textures, &cache->texels, err);
        if (status != PF_OK) {
            pf_error_prefix(err, "textures (%u, %.1f MiB)", frame->texture_count, megabytes);
            return status;
        }
        cache->texture_set = frame->texture_set;
        uploaded = 1;
    }
    pf_stage_timing *row = pf_frame_report_row(
        report, "textures",
        uploaded ? NULL : "the scene's textures are on the device already → reused", pf_time_ms() - start,
        -1.0);
    pf_stage_add_counter(row, "textures", frame->texture_count);
    pf_stage_add_counter(row, "megabytes", megabytes);
    pf_stage_add_counter(row, "uploaded", uploaded);
    return PF_OK;
}

pf_status pf_gpu_scene_upload(pf_vk_context *ctx, const pf_scene_frame *frame, int full,
                              const pf_texture_cache *cache, pf_gpu_scene *out, pf_error *err)
{
    /* Every upload recorded, then one submission and one wait (issue 44). */
    pf_vk_commands *cmds = NULL;
    memset(out, 0, sizeof *out);
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_gpu_scene_record(ctx, cmds, frame, full, cache, out, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    if (status != PF_OK)
        pf_gpu_scene_release(ctx, out);
    return status;
}

/* The recording's end: on failure the scene is released (the caller's commands stay). */
static pf_status finish_scene_record(pf_vk_context *ctx, pf_status status, pf_gpu_scene *out)
{
    if (status != PF_OK)
        pf_gpu_scene_release(ctx, out);
    return status;
}

pf_status pf_gpu_scene_record(pf_vk_context *ctx, pf_vk_commands *cmds,
                              const pf_scene_frame *frame, int full,
                              const pf_texture_cache *cache, pf_gpu_scene *out, pf_error *err)
{
    memset(out, 0, sizeof *out);
    for (uint32_t t = 0; full && t < frame->triangle_count; t++)
        if (frame->triangle_material[t] >= frame->material_count)
            return pf_error_set(err, PF_ERR_INVALID,
                                "triangle %u: material %u out of range (%u materials)", t,
                                frame->triangle_material[t], frame->material_count);
    pf_status status = PF_OK;
    uint64_t triangles = frame->triangle_count;
    uint64_t vertex_bytes = triangles * 3 * sizeof(float[4]);
    status = buffer_with_data(ctx, cmds, "triangle vertices", frame->vertices, vertex_bytes,
                              3 * sizeof(float[4]), &out->vertices, err);
    if (status != PF_OK || !full)
        return finish_scene_record(ctx, status, out);
    pf_emissive_entry *table = NULL;
    double weight_total = 0.0;
    uint32_t *material_words = NULL;
    status = buffer_with_data(ctx, cmds, "triangle normals", frame->normals, vertex_bytes,
                              3 * sizeof(float[4]), &out->normals, err);
    if (status == PF_OK)
        status = triangle_material_words(frame, &material_words, err);
    if (status == PF_OK)
        status = buffer_with_data(
            ctx, cmds, "triangle materials",
            material_words ? material_words : frame->triangle_material,
            triangles * sizeof(uint32_t), sizeof(uint32_t), &out->triangle_material, err);
    free(material_words);
    if (status == PF_OK)
        status = materials_upload(ctx, cmds, frame, &out->materials, err);
    pf_light *lights = NULL;
    if (status == PF_OK)
        status = lights_with_picks(frame, &lights, err);
    if (status == PF_OK)
        status = buffer_with_data(ctx, cmds, "lights", lights,
                                  frame->light_count * sizeof(pf_light), sizeof(pf_light),
                                  &out->lights, err);
    free(lights);
    if (status == PF_OK)
        status = pf_emissive_table_build(frame, &table, &out->emissive_count, &weight_total, err);
    if (status == PF_OK)
        status = buffer_with_data(ctx, cmds, "emissive triangles", table,
                                  out->emissive_count * sizeof(pf_emissive_entry),
                                  sizeof(pf_emissive_entry), &out->emissive, err);
    free(table);
    /* Without corners a placeholder: the kernels' variant reads none (pf_scene.h PF_SURFACE_*). */
    if (status == PF_OK)
        status = buffer_with_data(
            ctx, cmds, "triangle corners", frame->corners,
            frame->corners ? triangles * 3 * PF_CORNER_TEXELS * sizeof(float[4]) : 0, 16,
            &out->corners, err);
    if (status == PF_OK && cache && frame->texture_set != 0 &&
        cache->texture_set == frame->texture_set) {
        out->textures = cache->textures;
        out->texels = cache->texels;
        out->textures_borrowed = 1;
    } else if (status == PF_OK) {
        status = texture_upload(ctx, cmds, frame, &out->textures, &out->texels, err);
    }
    out->emissive_weight_total = (float)weight_total;
    return finish_scene_record(ctx, status, out);
}
