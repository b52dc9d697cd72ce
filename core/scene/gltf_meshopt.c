/*
 * EXT_meshopt_compression (gltfpack -c, and the web pipelines built on it): a bufferView's
 * bytes are a meshoptimizer stream in another buffer, decoded here at load with Debian's
 * libmeshoptimizer (its C API) into a block the view then reads from, so accessors, images
 * and Draco streams see plain bytes. The view's own buffer may be a "fallback" one without
 * data (gltf_accessors.c load_buffer), which only compressed views may refer to.
 *   mode ATTRIBUTES: meshopt_decodeVertexBuffer, byteStride a multiple of 4 up to 256;
 *   mode TRIANGLES and INDICES: meshopt_decodeIndexBuffer / IndexSequence, byteStride 2 or 4;
 *   filter OCTAHEDRAL, QUATERNION, EXPONENTIAL: the matching meshopt_decodeFilter* in place.
 * The decoded size, count × byteStride, must be the view's byteLength.
 */
#include "gltf_internal.h"

#include <math.h>
#include <meshoptimizer.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The decoded bytes of views[index] into out (count × stride bytes). */
static pf_status decode_view(gltf_context *ctx, const cJSON *view, int32_t index,
                             const cJSON *extension, gltf_view_data *out, pf_error *err)
{
    char element[128];
    snprintf(element, sizeof element, "bufferViews[%d].extensions.EXT_meshopt_compression",
             index);
    int32_t buffer_index;
    double offset, length, stride, count, view_length;
    pf_status status =
        gltf_index(ctx, extension, "buffer", ctx->buffer_count, &buffer_index, element, err);
    if (!status)
        status = gltf_number(ctx, extension, "byteOffset", 0, &offset, element, err);
    if (!status)
        status = gltf_number(ctx, extension, "byteLength", -1, &length, element, err);
    if (!status)
        status = gltf_number(ctx, extension, "byteStride", -1, &stride, element, err);
    if (!status)
        status = gltf_number(ctx, extension, "count", -1, &count, element, err);
    if (!status)
        status = gltf_number(ctx, view, "byteLength", -1, &view_length, element, err);
    if (status)
        return status;
    const cJSON *mode = cJSON_GetObjectItemCaseSensitive(extension, "mode");
    const cJSON *filter = cJSON_GetObjectItemCaseSensitive(extension, "filter");
    const char *mode_name = cJSON_IsString(mode) ? mode->valuestring : "";
    const char *filter_name = cJSON_IsString(filter) ? filter->valuestring : "NONE";
    if (buffer_index == SCENE_NONE || !(offset >= 0 && offset == floor(offset)) ||
        !(length >= 1 && length == floor(length)) || !(stride >= 1 && stride <= 256) ||
        stride != floor(stride) || !(count >= 1 && count <= (double)(UINT32_MAX / 16)) ||
        count != floor(count))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "buffer, byteLength, byteStride (1..256) and count are required "
                         "integers");
    const gltf_buffer *buffer = &ctx->buffers[buffer_index];
    if (!buffer->data || offset + length > (double)buffer->size)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "byteOffset %.0f + byteLength %.0f is not data of buffers[%d]", offset,
                         length, buffer_index);
    if (count * stride != view_length)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "count %.0f × byteStride %.0f is not the view's byteLength %.0f", count,
                         stride, view_length);
    size_t n = (size_t)count, size = (size_t)stride;
    const unsigned char *source = buffer->data + (size_t)offset;
    unsigned char *data = malloc(n * size);
    if (!data)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory for %zu bytes",
                         n * size);
    int result = -1;
    if (strcmp(mode_name, "ATTRIBUTES") == 0 && size % 4 == 0)
        result = meshopt_decodeVertexBuffer(data, n, size, source, (size_t)length);
    else if (strcmp(mode_name, "TRIANGLES") == 0 && (size == 2 || size == 4) && n % 3 == 0)
        result = meshopt_decodeIndexBuffer(data, n, size, source, (size_t)length);
    else if (strcmp(mode_name, "INDICES") == 0 && (size == 2 || size == 4))
        result = meshopt_decodeIndexSequence(data, n, size, source, (size_t)length);
    else {
        free(data);
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "mode \"%s\" with byteStride %zu is not ATTRIBUTES (a multiple of 4), "
                         "TRIANGLES or INDICES (2 or 4)", mode_name, size);
    }
    if (result != 0) {
        free(data);
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "the %s stream does not decode (meshoptimizer error %d)", mode_name,
                         result);
    }
    if (strcmp(filter_name, "OCTAHEDRAL") == 0 && (size == 4 || size == 8))
        meshopt_decodeFilterOct(data, n, size);
    else if (strcmp(filter_name, "QUATERNION") == 0 && size == 8)
        meshopt_decodeFilterQuat(data, n, size);
    else if (strcmp(filter_name, "EXPONENTIAL") == 0 && size % 4 == 0)
        meshopt_decodeFilterExp(data, n, size);
    else if (strcmp(filter_name, "NONE") != 0) {
        free(data);
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "filter \"%s\" with byteStride %zu is not NONE, OCTAHEDRAL (4 or 8), "
                         "QUATERNION (8) or EXPONENTIAL (a multiple of 4)", filter_name, size);
    }
    out->data = data;
    out->size = n * size;
    return PF_OK;
}

pf_status gltf_meshopt_decode_views(gltf_context *ctx, pf_error *err)
{
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews");
    uint32_t count = (uint32_t)cJSON_GetArraySize(views);
    for (uint32_t k = 0; k < count; k++) {
        const cJSON *view = cJSON_GetArrayItem(views, (int)k);
        const cJSON *extension = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(view, "extensions"), "EXT_meshopt_compression");
        if (!extension)
            continue;
        if (!ctx->view_data) {
            ctx->view_data = calloc(count, sizeof *ctx->view_data);
            if (!ctx->view_data)
                return gltf_fail(ctx, err, PF_ERR_NOMEM, "bufferViews", "out of memory");
            ctx->view_count = count;
        }
        pf_status status = decode_view(ctx, view, (int32_t)k, extension, &ctx->view_data[k], err);
        if (status)
            return status;
    }
    return PF_OK;
}

void gltf_meshopt_free(gltf_context *ctx)
{
    for (uint32_t k = 0; k < ctx->view_count; k++)
        free(ctx->view_data[k].data);
    free(ctx->view_data);
    ctx->view_data = NULL;
    ctx->view_count = 0;
}
