/*
 * glTF buffers and accessors: loads every buffer (external file, base64 data:
 * URI, or the .glb BIN chunk) and reads accessors with every bound checked
 * (bufferView inside its buffer, elements and stride inside the view, sparse
 * indices inside the accessor) before anything is allocated or read.
 */
#include "gltf_internal.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* glTF 2.0 §5.1.3 accessor.componentType. */
#define GLTF_BYTE 5120
#define GLTF_UNSIGNED_BYTE 5121
#define GLTF_SHORT 5122
#define GLTF_UNSIGNED_SHORT 5123
#define GLTF_UNSIGNED_INT 5125
#define GLTF_FLOAT 5126

/* An accessor without a bufferView is all zeros (plus sparse values): nothing in
 * the file bounds its count, so this does (2^24 elements, far above any scene
 * this renderer handles within lavapipe's 128 MiB buffers). */
#define GLTF_MAX_ZERO_ACCESSOR_COUNT (1u << 24)
/* ---- buffers ------------------------------------------------------------ */

static int base64_value(unsigned char c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '+' || c == '-')
        return 62;
    if (c == '/' || c == '_')
        return 63;
    return -1;
}

/* Decodes base64 text (padding optional); NULL on an invalid character. */
static unsigned char *base64_decode(const char *text, size_t *size)
{
    size_t length = strlen(text);
    unsigned char *out = malloc(length / 4 * 3 + 3);
    if (!out)
        return NULL;
    size_t written = 0;
    uint32_t accumulator = 0;
    int bits = 0;
    for (size_t k = 0; k < length; k++) {
        if (text[k] == '=')
            break;
        int value = base64_value((unsigned char)text[k]);
        if (value < 0) {
            free(out);
            return NULL;
        }
        accumulator = accumulator << 6 | (uint32_t)value;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out[written++] = (unsigned char)(accumulator >> bits);
        }
    }
    *size = written;
    return out;
}

/* Resolves a relative URI against the .gltf's directory, percent-decoding it. */
static char *resolve_uri(const char *gltf_path, const char *uri)
{
    const char *slash = strrchr(gltf_path, '/');
    size_t directory_length = slash ? (size_t)(slash - gltf_path) + 1 : 0;
    char *path = malloc(directory_length + strlen(uri) + 1);
    if (!path)
        return NULL;
    memcpy(path, gltf_path, directory_length);
    char *out = path + directory_length;
    for (const char *in = uri; *in; in++) {
        if (in[0] == '%' && isxdigit((unsigned char)in[1]) && isxdigit((unsigned char)in[2])) {
            char hex[3] = {in[1], in[2], 0};
            *out++ = (char)strtol(hex, NULL, 16);
            in += 2;
        } else {
            *out++ = *in;
        }
    }
    *out = 0;
    return path;
}

static pf_status load_buffer(gltf_context *ctx, uint32_t index, const cJSON *buffer,
                             gltf_buffer *out, pf_error *err)
{
    char element[64];
    snprintf(element, sizeof element, "buffers[%u]", index);
    double byte_length;
    const cJSON *length_item = cJSON_GetObjectItemCaseSensitive(buffer, "byteLength");
    if (!length_item)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "byteLength is missing");
    pf_status status = gltf_number(ctx, buffer, "byteLength", 0, &byte_length, element, err);
    if (status)
        return status;
    if (!(byte_length >= 1 && byte_length <= (double)SIZE_MAX / 2 && byte_length == floor(byte_length)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "byteLength %g is not a positive integer",
                         byte_length);
    out->size = (size_t)byte_length;
    const cJSON *uri = cJSON_GetObjectItemCaseSensitive(buffer, "uri");
    const cJSON *meshopt = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(buffer, "extensions"), "EXT_meshopt_compression");
    if (!uri && cJSON_IsTrue(cJSON_GetObjectItemCaseSensitive(meshopt, "fallback"))) {
        /* EXT_meshopt_compression's fallback: the size of the decoded views, no data. */
        out->data = NULL;
        out->owned = 0;
        return PF_OK;
    }
    if (!uri) {
        if (index != 0 || !ctx->glb_bin)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "no uri and no GLB binary chunk to refer to");
        if (out->size > ctx->glb_bin_size)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "byteLength %zu but the GLB binary chunk has %zu bytes", out->size,
                             ctx->glb_bin_size);
        out->data = (unsigned char *)ctx->glb_bin;
        out->owned = 0;
        return PF_OK;
    }
    size_t available = 0;
    status = gltf_read_uri(ctx, uri, element, &out->data, &available, err);
    if (status)
        return status;
    out->owned = 1;
    if (available < out->size)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "byteLength %zu but uri \"%s\" holds %zu bytes (truncated?)", out->size,
                         uri->valuestring, available);
    return PF_OK;
}

pf_status gltf_read_uri(gltf_context *ctx, const cJSON *uri, const char *element,
                        unsigned char **data, size_t *size, pf_error *err)
{
    *data = NULL;
    *size = 0;
    if (!cJSON_IsString(uri))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "uri: expected a string");
    const char *text = uri->valuestring;
    if (strncmp(text, "data:", 5) == 0) {
        const char *marker = strstr(text, ";base64,");
        if (!marker)
            return gltf_fail(ctx, err, PF_ERR_UNSUPPORTED, element,
                             "data: URI without base64 encoding");
        *data = base64_decode(marker + strlen(";base64,"), size);
        if (!*data)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "data: URI: invalid base64");
        return PF_OK;
    }
    if (strstr(text, "://") || text[0] == '/')
        return gltf_fail(ctx, err, PF_ERR_UNSUPPORTED, element,
                         "uri \"%s\": only relative file paths and data: URIs are supported", text);
    char *file_path = resolve_uri(ctx->path, text);
    if (!file_path)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    if (!scene_path_allowed(ctx->scene, file_path)) {
        /* Named by its URI only: nothing found outside is described. */
        free(file_path);
        return gltf_fail(ctx, err, PF_ERR_INVALID, element,
                         "uri \"%s\" leads outside the scene's directory (after resolving "
                         "symbolic links): refused (--allow-outside-scene-dir permits it)",
                         text);
    }
    char *bytes;
    pf_status status = scene_read_file(file_path, &bytes, size, err);
    free(file_path);
    if (status) {
        pf_error_prefix(err, "%s: %s", ctx->path, element);
        return status;
    }
    *data = (unsigned char *)bytes;
    return PF_OK;
}


pf_status gltf_load_buffers(gltf_context *ctx, pf_error *err)
{
    const cJSON *buffers;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "buffers", &buffers, &count, "", err);
    if (status || count == 0)
        return status;
    ctx->buffers = calloc(count, sizeof *ctx->buffers);
    if (!ctx->buffers)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "buffers", "out of memory");
    ctx->buffer_count = count;
    for (uint32_t k = 0; k < count; k++) {
        char element[64];
        snprintf(element, sizeof element, "buffers[%u]", k);
        const cJSON *buffer = cJSON_GetArrayItem(buffers, (int)k);
        if (!cJSON_IsObject(buffer))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
        status = load_buffer(ctx, k, buffer, &ctx->buffers[k], err);
        if (status)
            return status;
    }
    return PF_OK;
}

/* ---- accessors ---------------------------------------------------------- */

static uint32_t component_size(int component_type)
{
    switch (component_type) {
    case GLTF_BYTE:
    case GLTF_UNSIGNED_BYTE: return 1;
    case GLTF_SHORT:
    case GLTF_UNSIGNED_SHORT: return 2;
    case GLTF_UNSIGNED_INT:
    case GLTF_FLOAT: return 4;
    default: return 0;
    }
}

static uint32_t type_components(const char *type)
{
    static const struct {
        const char *name;
        uint32_t components;
    } types[] = {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                 {"MAT4", 16} /* float only here: skins' inverse binds, no column padding */};
    for (size_t k = 0; k < sizeof types / sizeof *types; k++)
        if (strcmp(type, types[k].name) == 0)
            return types[k].components;
    return 0;
}

/* glTF 2.0 §3.11 "Animations" normalization formulas (also used for attributes). */
/* A normalized integer component's value (glTF §3.11: the type's largest value maps to 1,
 * a signed one clamped at -1); floats and 32-bit integers are not normalized. */
static double normalized_value(double value, int component_type)
{
    double largest = component_type == GLTF_BYTE             ? 127.0
                     : component_type == GLTF_UNSIGNED_BYTE  ? 255.0
                     : component_type == GLTF_SHORT          ? 32767.0
                     : component_type == GLTF_UNSIGNED_SHORT ? 65535.0
                                                             : 0.0;
    return largest > 0.0 ? fmax(value / largest, -1.0) : value;
}

static double read_component(const unsigned char *at, int component_type, int normalized)
{
    switch (component_type) {
    case GLTF_BYTE: {
        int8_t value;
        memcpy(&value, at, 1);
        return normalized ? normalized_value(value, component_type) : value;
    }
    case GLTF_UNSIGNED_BYTE: return normalized ? normalized_value(at[0], component_type) : at[0];
    case GLTF_SHORT: {
        int16_t value;
        memcpy(&value, at, 2);
        return normalized ? normalized_value(value, component_type) : value;
    }
    case GLTF_UNSIGNED_SHORT: {
        uint16_t value;
        memcpy(&value, at, 2);
        return normalized ? normalized_value(value, component_type) : value;
    }
    case GLTF_UNSIGNED_INT: {
        uint32_t value;
        memcpy(&value, at, 4);
        return value;
    }
    default: {
        float value;
        memcpy(&value, at, 4);
        return value;
    }
    }
}

/* A validated view of count elements in a buffer: element k starts at base + k·stride. */
typedef struct strided_view {
    const unsigned char *base;
    size_t stride;
} strided_view;

/*
 * Resolves bufferView `view_index` + byte_offset for count elements of
 * element_size bytes, checking every bound (view inside buffer, elements inside
 * view, stride >= element size).
 */
static pf_status resolve_view(gltf_context *ctx, int32_t view_index, double byte_offset,
                              uint32_t count, size_t element_size, int allow_stride,
                              strided_view *out, const char *element, pf_error *err)
{
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews");
    char view_element[64];
    snprintf(view_element, sizeof view_element, "bufferViews[%d]", view_index);
    const cJSON *view = cJSON_GetArrayItem(views, view_index);
    if (!cJSON_IsObject(view))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element, "expected an object");
    int32_t buffer_index;
    double view_offset, view_length, stride;
    pf_status status =
        gltf_index(ctx, view, "buffer", ctx->buffer_count, &buffer_index, view_element, err);
    if (!status)
        status = gltf_number(ctx, view, "byteOffset", 0, &view_offset, view_element, err);
    if (!status)
        status = gltf_number(ctx, view, "byteLength", -1, &view_length, view_element, err);
    if (!status)
        status = gltf_number(ctx, view, "byteStride", 0, &stride, view_element, err);
    if (status)
        return status;
    if (buffer_index == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element, "buffer is missing");
    const gltf_buffer *buffer = &ctx->buffers[buffer_index];
    /* A view decoded from its EXT_meshopt_compression stream reads the decoded bytes. */
    const gltf_view_data *decoded = view_index < (int32_t)ctx->view_count &&
                                            ctx->view_data[view_index].data
                                        ? &ctx->view_data[view_index]
                                        : NULL;
    if (!decoded && !buffer->data)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element,
                         "buffers[%d] is a fallback without data, and the view is not "
                         "compressed", buffer_index);
    if (!(view_offset >= 0 && view_length >= 1 && view_offset == floor(view_offset) &&
          view_length == floor(view_length)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element,
                         "byteOffset/byteLength must be non-negative integers (byteLength >= 1)");
    if (!decoded && view_offset + view_length > (double)buffer->size)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element,
                         "byteOffset %.0f + byteLength %.0f runs past buffers[%d] (%zu bytes)",
                         view_offset, view_length, buffer_index, buffer->size);
    if (stride == 0 || !allow_stride)
        stride = (double)element_size;
    if (!(stride >= (double)element_size && stride == floor(stride)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, view_element,
                         "byteStride %.0f is smaller than the element (%zu bytes)", stride,
                         element_size);
    if (!(byte_offset >= 0 && byte_offset == floor(byte_offset)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "byteOffset must be a non-negative integer");
    double needed = byte_offset + stride * (double)(count - 1) + (double)element_size;
    if (needed > view_length)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "%u elements of %zu bytes (stride %.0f) from byteOffset %.0f need %.0f "
                         "bytes but bufferViews[%d] has %.0f",
                         count, element_size, stride, byte_offset, needed, view_index,
                         view_length);
    out->base = decoded ? decoded->data + (size_t)byte_offset
                        : buffer->data + (size_t)view_offset + (size_t)byte_offset;
    out->stride = (size_t)stride;
    return PF_OK;
}

/* Overwrites the sparse elements of values (count × components doubles). */
static pf_status apply_sparse(gltf_context *ctx, const cJSON *sparse, uint32_t count,
                              uint32_t components, int component_type, int normalized,
                              double *values, const char *element, pf_error *err)
{
    char sub[256];
    double sparse_count;
    pf_status status = gltf_number(ctx, sparse, "count", 0, &sparse_count, element, err);
    if (status)
        return status;
    if (!(sparse_count >= 1 && sparse_count <= count && sparse_count == floor(sparse_count)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "sparse.count %g must be in [1, %u]", sparse_count, count);
    const cJSON *indices = cJSON_GetObjectItemCaseSensitive(sparse, "indices");
    const cJSON *sparse_values = cJSON_GetObjectItemCaseSensitive(sparse, "values");
    if (!cJSON_IsObject(indices) || !cJSON_IsObject(sparse_values))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "sparse: indices and values objects are required");
    uint32_t views = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews"));
    int32_t index_view, value_view;
    double index_offset, value_offset, index_type;
    snprintf(sub, sizeof sub, "%s.sparse.indices", element);
    status = gltf_index(ctx, indices, "bufferView", views, &index_view, sub, err);
    if (!status)
        status = gltf_number(ctx, indices, "byteOffset", 0, &index_offset, sub, err);
    if (!status)
        status = gltf_number(ctx, indices, "componentType", 0, &index_type, sub, err);
    if (status)
        return status;
    int index_component = (int)index_type;
    if (index_view == SCENE_NONE ||
        (index_component != GLTF_UNSIGNED_BYTE && index_component != GLTF_UNSIGNED_SHORT &&
         index_component != GLTF_UNSIGNED_INT))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub,
                         "needs a bufferView and an unsigned componentType");
    strided_view index_data, value_data;
    uint32_t n = (uint32_t)sparse_count;
    status = resolve_view(ctx, index_view, index_offset, n, component_size(index_component), 0,
                          &index_data, sub, err);
    if (status)
        return status;
    snprintf(sub, sizeof sub, "%s.sparse.values", element);
    status = gltf_index(ctx, sparse_values, "bufferView", views, &value_view, sub, err);
    if (!status)
        status = gltf_number(ctx, sparse_values, "byteOffset", 0, &value_offset, sub, err);
    if (status)
        return status;
    if (value_view == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "bufferView is missing");
    size_t element_size = (size_t)component_size(component_type) * components;
    status = resolve_view(ctx, value_view, value_offset, n, element_size, 0, &value_data, sub,
                          err);
    if (status)
        return status;
    for (uint32_t k = 0; k < n; k++) {
        double target = read_component(index_data.base + k * index_data.stride, index_component, 0);
        if (target >= count)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "sparse index %.0f out of range (%u elements)", target, count);
        for (uint32_t c = 0; c < components; c++)
            values[(size_t)target * components + c] =
                read_component(value_data.base + k * value_data.stride +
                                   c * component_size(component_type),
                               component_type, normalized);
    }
    return PF_OK;
}

uint32_t gltf_accessor_components(gltf_context *ctx, int32_t index)
{
    const cJSON *accessor =
        cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"), index);
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(accessor, "type");
    return index >= 0 && cJSON_IsString(type) ? type_components(type->valuestring) : 0;
}

/* The accessor's values as the primitive's decoder produced them (gltf_decoded_accessor),
 * normalized as read_component would: *out NULL where it has none. */
static pf_status decoded_values(gltf_context *ctx, int32_t index, uint32_t count,
                                uint32_t components, int component_type, int normalized,
                                double **out, const char *element, pf_error *err)
{
    *out = NULL;
    const gltf_decoded_accessor *decoded = NULL;
    for (uint32_t k = 0; k < ctx->decoded_count; k++)
        if (ctx->decoded[k].accessor == index)
            decoded = &ctx->decoded[k];
    if (!decoded)
        return PF_OK;
    if (decoded->count != count || decoded->components != components)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "count %u, but its compressed stream decodes to %u", count,
                         decoded->count);
    double *values = malloc((size_t)count * components * sizeof *values);
    if (!values)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory for %u elements", count);
    for (size_t k = 0; k < (size_t)count * components; k++)
        values[k] = normalized ? normalized_value(decoded->values[k], component_type)
                               : decoded->values[k];
    *out = values;
    return PF_OK;
}

/*
 * Reads accessor `index` as doubles after checking its type against
 * `components` and (when integer_only) an index componentType.
 */
static pf_status read_accessor(gltf_context *ctx, int32_t index, uint32_t components,
                               int integer_only, double **out, uint32_t *out_count,
                               const char *referrer, pf_error *err)
{
    char element[160];
    snprintf(element, sizeof element, "%s (accessors[%d])", referrer, index);
    const cJSON *accessors = cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors");
    const cJSON *accessor = cJSON_GetArrayItem(accessors, index);
    if (index < 0 || !cJSON_IsObject(accessor))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, referrer, "accessor %d does not exist", index);
    double component_value, count_value, byte_offset;
    int32_t view_index;
    uint32_t views = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews"));
    pf_status status =
        gltf_number(ctx, accessor, "componentType", 0, &component_value, element, err);
    if (!status)
        status = gltf_number(ctx, accessor, "count", 0, &count_value, element, err);
    if (!status)
        status = gltf_number(ctx, accessor, "byteOffset", 0, &byte_offset, element, err);
    if (!status)
        status = gltf_index(ctx, accessor, "bufferView", views, &view_index, element, err);
    if (status)
        return status;
    int component_type = (int)component_value;
    const cJSON *type = cJSON_GetObjectItemCaseSensitive(accessor, "type");
    uint32_t type_count = cJSON_IsString(type) ? type_components(type->valuestring) : 0;
    if (component_size(component_type) == 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "componentType %d is not valid",
                         component_type);
    if (type_count != components)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "type %s, expected %u component(s)",
                         cJSON_IsString(type) ? type->valuestring : "(missing)", components);
    if (integer_only && component_type != GLTF_UNSIGNED_BYTE &&
        component_type != GLTF_UNSIGNED_SHORT && component_type != GLTF_UNSIGNED_INT)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "componentType %d: indices must be unsigned byte, short or int",
                         component_type);
    if (!(count_value >= 1 && count_value <= (double)(UINT32_MAX / 16) &&
          count_value == floor(count_value)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "count %g is not a positive integer",
                         count_value);
    const cJSON *normalized_item = cJSON_GetObjectItemCaseSensitive(accessor, "normalized");
    int normalized = cJSON_IsTrue(normalized_item);
    uint32_t count = (uint32_t)count_value;
    double *decoded;
    status = decoded_values(ctx, index, count, components, component_type, normalized, &decoded,
                            element, err);
    if (status || decoded) {
        *out = decoded;
        *out_count = count;
        return status;
    }
    /* Bounds are checked before allocating, so a corrupt count cannot ask for gigabytes. */
    strided_view view = {0};
    uint32_t size = component_size(component_type);
    if (view_index != SCENE_NONE) {
        status = resolve_view(ctx, view_index, byte_offset, count, (size_t)size * components, 1,
                              &view, element, err);
        if (status)
            return status;
    } else if (count > GLTF_MAX_ZERO_ACCESSOR_COUNT) {
        return gltf_fail(ctx, err, PF_ERR_LIMIT, element,
                         "count %u without a bufferView exceeds %u", count,
                         GLTF_MAX_ZERO_ACCESSOR_COUNT);
    }
    double *values = calloc((size_t)count * components, sizeof *values);
    if (!values)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory for %u elements", count);
    if (view_index != SCENE_NONE) {
        for (uint32_t k = 0; k < count; k++)
            for (uint32_t c = 0; c < components; c++)
                values[(size_t)k * components + c] = read_component(
                    view.base + k * view.stride + c * size, component_type, normalized);
    }
    const cJSON *sparse = cJSON_GetObjectItemCaseSensitive(accessor, "sparse");
    if (sparse) {
        status = apply_sparse(ctx, sparse, count, components, component_type, normalized,
                              values, element, err);
        if (status) {
            free(values);
            return status;
        }
    }
    *out = values;
    *out_count = count;
    return PF_OK;
}

pf_status gltf_read_floats(gltf_context *ctx, int32_t index, uint32_t components, float **out,
                           uint32_t *count, const char *element, pf_error *err)
{
    double *values;
    pf_status status = read_accessor(ctx, index, components, 0, &values, count, element, err);
    if (status)
        return status;
    size_t total = (size_t)*count * components;
    float *floats = malloc(total * sizeof *floats);
    if (!floats) {
        free(values);
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    for (size_t k = 0; k < total; k++) {
        floats[k] = (float)values[k];
        if (!isfinite(floats[k])) {
            uint32_t bad_element = (uint32_t)(k / components);
            double bad_value = values[k];
            free(values);
            free(floats);
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "element %u component %u is not finite (%g)", bad_element,
                             (uint32_t)(k % components), bad_value);
        }
    }
    free(values);
    *out = floats;
    return PF_OK;
}

pf_status gltf_read_uints(gltf_context *ctx, int32_t index, uint32_t components, uint32_t **out,
                          uint32_t *count, const char *element, pf_error *err)
{
    double *values;
    pf_status status = read_accessor(ctx, index, components, 1, &values, count, element, err);
    if (status)
        return status;
    size_t total = (size_t)*count * components;
    uint32_t *integers = malloc(total * sizeof *integers);
    if (!integers) {
        free(values);
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    for (size_t k = 0; k < total; k++)
        integers[k] = (uint32_t)values[k];
    free(values);
    *out = integers;
    return PF_OK;
}

pf_status gltf_read_indices(gltf_context *ctx, int32_t index, uint32_t **out, uint32_t *count,
                            const char *element, pf_error *err)
{
    return gltf_read_uints(ctx, index, 1, out, count, element, err);
}

pf_status gltf_view_bytes(gltf_context *ctx, int32_t view_index, const char *element,
                          const unsigned char **data, size_t *size, pf_error *err)
{
    const cJSON *views = cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews");
    const cJSON *view = cJSON_GetArrayItem(views, view_index);
    if (!cJSON_IsObject(view))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "bufferView %d: expected an object",
                         view_index);
    double length;
    pf_status status = gltf_number(ctx, view, "byteLength", -1, &length, element, err);
    if (status)
        return status;
    if (!(length >= 1 && length == floor(length)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "bufferViews[%d].byteLength must be a positive integer", view_index);
    strided_view strided;
    status = resolve_view(ctx, view_index, 0, (uint32_t)1, (size_t)length, 0, &strided, element,
                          err);
    if (status)
        return status;
    *data = strided.base;
    *size = (size_t)length;
    return PF_OK;
}
