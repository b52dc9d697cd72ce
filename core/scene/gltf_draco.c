/*
 * KHR_draco_mesh_compression (Blender's exporter writes it where "Compression" is ticked):
 * a primitive's attributes and indices in one Draco stream, in a bufferView, the
 * extension's "attributes" mapping glTF attribute names to the stream's unique ids. The
 * primitive's accessors keep their count, type and componentType (and min/max), without a
 * bufferView; their values are decoded here (draco_decode.h) and read through the same
 * accessor readers as any other (gltf_accessors.c decoded_values), so skins' JOINTS_0 and
 * WEIGHTS_0, colours and tangents need no path of their own. Morph targets are never
 * compressed (the extension's rule) and are read from their accessors.
 */
#include "draco_decode.h"
#include "gltf_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void gltf_draco_release(gltf_context *ctx)
{
    for (uint32_t k = 0; k < ctx->decoded_count; k++)
        free(ctx->decoded[k].values);
    free(ctx->decoded);
    ctx->decoded = NULL;
    ctx->decoded_count = 0;
}

/* The stream's attributes the extension names: their unique ids, and the primitive's
 * accessors they stand for (accessors[k] for wanted[k]). */
static pf_status wanted_attributes(gltf_context *ctx, const cJSON *primitive,
                                   const cJSON *mapping, const char *element,
                                   pf_draco_attribute **wanted, int32_t **accessors,
                                   uint32_t *count, pf_error *err)
{
    const cJSON *attributes = cJSON_GetObjectItemCaseSensitive(primitive, "attributes");
    uint32_t accessor_count = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"));
    uint32_t n = (uint32_t)cJSON_GetArraySize(mapping);
    *wanted = calloc(n ? n : 1, sizeof **wanted);
    *accessors = calloc(n ? n : 1, sizeof **accessors);
    *count = 0;
    if (!*wanted || !*accessors)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    const cJSON *item;
    cJSON_ArrayForEach(item, mapping)
    {
        double id = cJSON_IsNumber(item) ? item->valuedouble : -1.0;
        if (!(id >= 0) || id > (double)UINT32_MAX || id != (uint32_t)id)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "attributes.%s: expected a non-negative integer id", item->string);
        int32_t accessor;
        pf_status status =
            gltf_index(ctx, attributes, item->string, accessor_count, &accessor, element, err);
        if (status)
            return status;
        if (accessor == SCENE_NONE)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "attributes.%s is compressed but the primitive has no %s",
                             item->string, item->string);
        uint32_t components = gltf_accessor_components(ctx, accessor);
        if (components == 0 || components > 4)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "attributes.%s: accessors[%d] has no vector type", item->string,
                             accessor);
        (*wanted)[*count] = (pf_draco_attribute){(uint32_t)id, components, NULL};
        (*accessors)[*count] = accessor;
        (*count)++;
    }
    return PF_OK;
}

pf_status gltf_draco_decode_primitive(gltf_context *ctx, const cJSON *primitive,
                                      const char *element, pf_error *err)
{
    const cJSON *extension = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(primitive, "extensions"), "KHR_draco_mesh_compression");
    if (!extension)
        return PF_OK;
    char sub[192];
    snprintf(sub, sizeof sub, "%s.extensions.KHR_draco_mesh_compression", element);
    if (!cJSON_IsObject(extension))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "expected an object");
    uint32_t views = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews"));
    uint32_t accessor_count = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"));
    int32_t view, indices;
    pf_status status = gltf_index(ctx, extension, "bufferView", views, &view, sub, err);
    if (!status)
        status = gltf_index(ctx, primitive, "indices", accessor_count, &indices, element, err);
    if (status)
        return status;
    const cJSON *mapping = cJSON_GetObjectItemCaseSensitive(extension, "attributes");
    if (view == SCENE_NONE || !cJSON_IsObject(mapping))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "bufferView and attributes are required");
    /* The stream holds a triangle list: its faces are the primitive's indices. */
    if (indices == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "a compressed primitive needs indices");
    const unsigned char *bytes;
    size_t size;
    status = gltf_view_bytes(ctx, view, sub, &bytes, &size, err);
    pf_draco_attribute *wanted = NULL;
    int32_t *accessors = NULL;
    uint32_t count = 0;
    if (!status)
        status = wanted_attributes(ctx, primitive, mapping, sub, &wanted, &accessors, &count,
                                   err);
    pf_draco_mesh mesh = {0, 0, NULL};
    char message[256];
    if (!status && pf_draco_decode(bytes, size, wanted, count, &mesh, message, sizeof message))
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "%s", message);
    if (!status) {
        ctx->decoded = calloc((size_t)count + 1, sizeof *ctx->decoded);
        if (!ctx->decoded)
            status = gltf_fail(ctx, err, PF_ERR_NOMEM, sub, "out of memory");
    }
    if (!status) {
        double *index_values = malloc((mesh.index_count ? mesh.index_count : 1) *
                                      sizeof *index_values);
        if (!index_values)
            status = gltf_fail(ctx, err, PF_ERR_NOMEM, sub, "out of memory");
        for (uint32_t k = 0; index_values && k < mesh.index_count; k++)
            index_values[k] = mesh.indices[k];
        /* The decoded arrays now belong to ctx (gltf_draco_release). */
        for (uint32_t k = 0; k < count; k++) {
            ctx->decoded[k] =
                (gltf_decoded_accessor){accessors[k], mesh.point_count, wanted[k].components,
                                        wanted[k].values};
            wanted[k].values = NULL;
        }
        ctx->decoded_count = count;
        if (index_values)
            ctx->decoded[ctx->decoded_count++] =
                (gltf_decoded_accessor){indices, mesh.index_count, 1, index_values};
    }
    for (uint32_t k = 0; wanted && k < count; k++)
        free(wanted[k].values);
    free(wanted);
    free(accessors);
    free(mesh.indices);
    if (status)
        gltf_draco_release(ctx);
    return status;
}
