/*
 * glTF 2.0 loader: .gltf (external .bin files and base64 data: URIs) and .glb,
 * JSON parsed by cJSON, glTF semantics implemented here.
 *
 * Why not a glTF library: assimp 5.2.5 (the Debian package) drops
 * KHR_materials_emissive_strength (the Cornell box light would be 17× too
 * dark), reports a wrong vertical fov for non-square cameras (mHorizontalFOV /
 * mAspect), and its errors do not name the element at fault; cgltf is not
 * packaged in Debian. The subset DESIGN.md §5 needs is small enough to own,
 * and owning it lets every message say "file: meshes[2].primitives[0].indices:
 * ...".
 *
 * Everything is validated at load (accessor bounds, strides, types, finite
 * values, index ranges) so that pf_scene_eval never touches the JSON or the
 * buffers again.
 */
#include "gltf_internal.h"

#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* glTF 2.0 §4.4 "GLB File Format Specification". */
#define GLB_MAGIC 0x46546C67u      /* "glTF" */
#define GLB_VERSION 2u
#define GLB_HEADER_SIZE 12u
#define GLB_CHUNK_HEADER_SIZE 8u
#define GLB_CHUNK_JSON 0x4E4F534Au /* "JSON" */
#define GLB_CHUNK_BIN 0x004E4942u  /* "BIN\0" */

/* glTF 2.0 §5.24.4 mesh.primitive.mode. */
#define GLTF_MODE_POINTS 0
#define GLTF_MODE_TRIANGLES 4
#define GLTF_MODE_TRIANGLE_STRIP 5
#define GLTF_MODE_TRIANGLE_FAN 6

/* KHR_lights_punctual spot.outerConeAngle default: π/4. */
#define GLTF_SPOT_OUTER_DEFAULT 0.78539816
#define GLTF_PI 3.141592653589793
/* KHR_lights_punctual: point and spot intensity in candela (lm/sr), directional
 * in lux (lm/m²); the spec's (and Blender's exporter's) luminous efficacy turns
 * them into W/sr and W/m². */
#define GLTF_LUMENS_PER_WATT 683.0
#define GLTF_HALF_PI 1.5707963267948966
/* asset.generator of Blender's glTF exporter ("Khronos glTF Blender I/O v3.4.50"). */
#define GLTF_BLENDER_GENERATOR "Khronos glTF Blender I/O"

static const char *const supported_extensions[] = {
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_unlit",
    "KHR_materials_sheen",
    "KHR_materials_variants",
    "EXT_mesh_gpu_instancing",
    /* Integer positions, normals, tangents and texture coordinates (gltfpack -cc): every
     * attribute is read through gltf_read_floats, which converts any component type. */
    "KHR_mesh_quantization",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_texture_transform",
    "EXT_texture_webp",
};

pf_status gltf_fail(gltf_context *ctx, pf_error *err, pf_status status, const char *element,
                    const char *format, ...)
{
    char detail[PF_ERROR_MESSAGE_MAX];
    va_list args;
    va_start(args, format);
    vsnprintf(detail, sizeof detail, format, args);
    va_end(args);
    if (element && *element)
        return pf_error_set(err, status, "%s: %s: %s", ctx->path, element, detail);
    return pf_error_set(err, status, "%s: %s", ctx->path, detail);
}

pf_status gltf_number(gltf_context *ctx, const cJSON *object, const char *key, double fallback,
                      double *out, const char *element, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(object, key);
    /* Written on every path, errors included: callers read it only on success,
     * but GCC's -O3 cannot see that and warns "may be used uninitialized". */
    *out = fallback;
    if (!item)
        return PF_OK;
    if (!cJSON_IsNumber(item) || !isfinite(item->valuedouble))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s: expected a finite number", key);
    *out = item->valuedouble;
    return PF_OK;
}

pf_status gltf_index(gltf_context *ctx, const cJSON *object, const char *key, uint32_t count,
                     int32_t *out, const char *element, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(object, key);
    *out = SCENE_NONE;
    if (!item)
        return PF_OK;
    double value = cJSON_IsNumber(item) ? item->valuedouble : -1.0;
    if (!cJSON_IsNumber(item))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s: expected an index, not %s", key,
                         cJSON_IsString(item) ? "a string" : "a non-number");
    if (!(value >= 0.0 && value < (double)count && value == floor(value)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                         "%s: %g is not an index in [0, %u)", key, value, count);
    *out = (int32_t)value;
    return PF_OK;
}

pf_status gltf_floats(gltf_context *ctx, const cJSON *object, const char *key, int n,
                      float *out, const char *element, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(object, key);
    if (!item)
        return PF_OK;
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != n)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s: expected an array of %d numbers",
                         key, n);
    int k = 0;
    const cJSON *value;
    cJSON_ArrayForEach(value, item)
    {
        if (!cJSON_IsNumber(value) || !isfinite(value->valuedouble) ||
            !isfinite((float)value->valuedouble))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "%s[%d]: expected a finite number", key, k);
        out[k++] = (float)value->valuedouble;
    }
    return PF_OK;
}

pf_status gltf_array(gltf_context *ctx, const cJSON *object, const char *key,
                     const cJSON **out, uint32_t *count, const char *element, pf_error *err)
{
    const cJSON *item = cJSON_GetObjectItemCaseSensitive(object, key);
    *out = item;
    *count = 0;
    if (!item)
        return PF_OK;
    if (!cJSON_IsArray(item))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s: expected an array", key);
    *count = (uint32_t)cJSON_GetArraySize(item);
    return PF_OK;
}

int32_t gltf_named_entry(const cJSON *array, uint32_t count, const char *choice, char *names,
                         size_t size)
{
    int32_t named = SCENE_NONE;
    size_t used = 0;
    snprintf(names, size, "%s", count ? "" : "none");
    for (uint32_t k = 0; k < count; k++) {
        const cJSON *name =
            cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(array, (int)k), "name");
        const char *text = cJSON_IsString(name) ? name->valuestring : "";
        if (named == SCENE_NONE && choice && *text && strcmp(text, choice) == 0)
            named = (int32_t)k;
        if (used < size) {
            int wrote = snprintf(names + used, size - used, "%s%u '%s'", k ? ", " : "", k, text);
            used += wrote > 0 ? (size_t)wrote : 0;
        }
    }
    char *end = NULL;
    unsigned long index = choice ? strtoul(choice, &end, 10) : 0;
    if (named == SCENE_NONE && choice && *choice >= '0' && *choice <= '9' && end && !*end &&
        index < count)
        named = (int32_t)index;
    return named;
}

/* Object entry i of a top-level array such as "meshes"; error if not an object. */
static pf_status array_object(gltf_context *ctx, const cJSON *array, uint32_t i,
                              const cJSON **out, const char *element, pf_error *err)
{
    *out = cJSON_GetArrayItem(array, (int)i);
    if (!cJSON_IsObject(*out))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
    return PF_OK;
}

/* ---- file container ---------------------------------------------------- */

uint32_t gltf_read_u32le(const unsigned char *bytes)
{
    return (uint32_t)bytes[0] | (uint32_t)bytes[1] << 8 | (uint32_t)bytes[2] << 16 |
           (uint32_t)bytes[3] << 24;
}

/* Splits a .glb into its JSON text (returned, in place) and BIN chunk. */
static pf_status parse_glb(gltf_context *ctx, const char **json, size_t *json_size,
                           pf_error *err)
{
    const unsigned char *bytes = (const unsigned char *)ctx->file_data;
    size_t size = ctx->file_size;
    if (size < GLB_HEADER_SIZE || gltf_read_u32le(bytes) != GLB_MAGIC)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb header",
                         "bad magic (not a binary glTF file)");
    uint32_t version = gltf_read_u32le(bytes + 4);
    if (version != GLB_VERSION)
        return gltf_fail(ctx, err, PF_ERR_UNSUPPORTED, "glb header",
                         "version %u (only 2 is supported)", version);
    uint32_t length = gltf_read_u32le(bytes + 8);
    if (length != size)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb header",
                         "length %u but the file has %zu bytes (truncated?)", length, size);
    size_t offset = GLB_HEADER_SIZE;
    int chunk_index = 0;
    *json = NULL;
    while (offset < size) {
        if (size - offset < GLB_CHUNK_HEADER_SIZE)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb chunk",
                             "chunk %d header truncated at byte %zu", chunk_index, offset);
        uint32_t chunk_length = gltf_read_u32le(bytes + offset);
        uint32_t chunk_type = gltf_read_u32le(bytes + offset + 4);
        offset += GLB_CHUNK_HEADER_SIZE;
        if (chunk_length > size - offset)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb chunk",
                             "chunk %d length %u runs past the end of the file", chunk_index,
                             chunk_length);
        if (chunk_index == 0) {
            if (chunk_type != GLB_CHUNK_JSON)
                return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb chunk",
                                 "first chunk must be JSON (type 0x%08x)", chunk_type);
            *json = (const char *)bytes + offset;
            *json_size = chunk_length;
        } else if (chunk_index == 1 && chunk_type == GLB_CHUNK_BIN) {
            ctx->glb_bin = bytes + offset;
            ctx->glb_bin_size = chunk_length;
        }
        /* Other chunk types are to be ignored (§4.4.3.1). */
        offset += chunk_length;
        chunk_index++;
    }
    if (!*json)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, "glb chunk", "no JSON chunk");
    return PF_OK;
}

/* True when brackets or a string are still open at the end of the text. */
static int json_ends_early(const char *json, size_t size)
{
    long depth = 0;
    int in_string = 0, escaped = 0;
    for (size_t k = 0; k < size; k++) {
        char c = json[k];
        if (in_string) {
            if (escaped)
                escaped = 0;
            else if (c == '\\')
                escaped = 1;
            else if (c == '"')
                in_string = 0;
        } else if (c == '"') {
            in_string = 1;
        } else if (c == '{' || c == '[') {
            depth++;
        } else if (c == '}' || c == ']') {
            depth--;
        }
    }
    return in_string || depth > 0;
}

static pf_status parse_json(gltf_context *ctx, const char *json, size_t json_size, pf_error *err)
{
    static const unsigned char png_signature[4] = {0x89, 'P', 'N', 'G'};
    if (json_size == 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, NULL, "empty file (expected glTF JSON)");
    if (json_size >= 4 && memcmp(json, png_signature, 4) == 0)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, NULL,
                         "not a glTF file (it is a PNG image)");
    const char *end = NULL;
    ctx->root = cJSON_ParseWithLengthOpts(json, json_size, &end, 0);
    if (!ctx->root) {
        size_t position = end && end >= json ? (size_t)(end - json) : 0;
        if (position > json_size)
            position = json_size;
        size_t line = 1, column = 1;
        for (size_t k = 0; k < position; k++) {
            if (json[k] == '\n') {
                line++;
                column = 1;
            } else {
                column++;
            }
        }
        return gltf_fail(ctx, err, PF_ERR_FORMAT, NULL,
                         "invalid JSON at byte %zu (line %zu, column %zu)%s", position, line,
                         column,
                         json_ends_early(json, json_size) ? ": the file ends inside an object, "
                                                            "array or string (truncated?)"
                                                          : "");
    }
    if (!cJSON_IsObject(ctx->root))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, NULL, "top level is not a JSON object");
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(ctx->root, "asset");
    const cJSON *version = cJSON_GetObjectItemCaseSensitive(asset, "version");
    if (!cJSON_IsObject(asset) || !cJSON_IsString(version))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, "asset.version",
                         "missing (not a glTF 2.0 file?)");
    if (strncmp(version->valuestring, "2.", 2) != 0)
        return gltf_fail(ctx, err, PF_ERR_UNSUPPORTED, "asset.version",
                         "\"%s\" (only glTF 2.x is supported)", version->valuestring);
    return PF_OK;
}

static int extension_supported(const char *name)
{
    for (size_t k = 0; k < sizeof supported_extensions / sizeof *supported_extensions; k++)
        if (strcmp(name, supported_extensions[k]) == 0)
            return 1;
    return 0;
}

static pf_status check_extensions(gltf_context *ctx, pf_error *err)
{
    const cJSON *list;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "extensionsRequired", &list, &count, "", err);
    if (status)
        return status;
    for (uint32_t k = 0; k < count; k++) {
        const cJSON *name = cJSON_GetArrayItem(list, (int)k);
        if (!cJSON_IsString(name))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "extensionsRequired",
                             "entry %u is not a string", k);
        if (!extension_supported(name->valuestring))
            return gltf_fail(ctx, err, PF_ERR_UNSUPPORTED, "extensionsRequired",
                             "extension %s is required but not supported", name->valuestring);
    }
    status = gltf_array(ctx, ctx->root, "extensionsUsed", &list, &count, "", err);
    if (status)
        return status;
    for (uint32_t k = 0; k < count; k++) {
        const cJSON *name = cJSON_GetArrayItem(list, (int)k);
        if (cJSON_IsString(name) && !extension_supported(name->valuestring)) {
            char key[256];
            snprintf(key, sizeof key, "extension %s", name->valuestring);
            scene_warn_once(ctx->scene, key, "%s: extension %s is not supported: ignored",
                            ctx->path, name->valuestring);
        }
    }
    return PF_OK;
}

static pf_status read_asset_extras(gltf_context *ctx, pf_error *err)
{
    const cJSON *asset = cJSON_GetObjectItemCaseSensitive(ctx->root, "asset");
    const cJSON *extras = cJSON_GetObjectItemCaseSensitive(asset, "extras");
    double fps = SCENE_DEFAULT_FPS, frames = 0.0;
    if (cJSON_IsObject(extras)) {
        pf_status status = gltf_number(ctx, extras, "fps", SCENE_DEFAULT_FPS, &fps,
                                       "asset.extras", err);
        if (!status)
            status = gltf_number(ctx, extras, "frames", 0.0, &frames, "asset.extras", err);
        if (status)
            return status;
        if (!(fps > 0.0))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "asset.extras.fps",
                             "%g is not a positive frame rate", fps);
        if (frames != 0.0 && !(frames >= 1.0 && frames <= (double)INT32_MAX && frames == floor(frames)))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, "asset.extras.frames",
                             "%g is not a positive whole number", frames);
    }
    ctx->scene->fps = fps;
    ctx->scene->file_frame_count = (uint32_t)frames;
    /* Blender's exporter writes frame f's keys at time f / fps (and its importer reads them
     * back there), so for its files frame f is sampled there: the pose Blender showed for
     * frame f, not the one before it. */
    const cJSON *generator = cJSON_GetObjectItemCaseSensitive(asset, "generator");
    if (cJSON_IsString(generator) &&
        strncmp(generator->valuestring, GLTF_BLENDER_GENERATOR,
                strlen(GLTF_BLENDER_GENERATOR)) == 0)
        ctx->scene->frame_offset = 1;
    return PF_OK;
}

/* ---- meshes ------------------------------------------------------------- */

static int32_t default_material(gltf_context *ctx)
{
    if (ctx->default_material != SCENE_NONE)
        return ctx->default_material;
    pf_scene *scene = ctx->scene;
    pf_material *grown =
        realloc(scene->materials, (scene->material_count + 1) * sizeof *scene->materials);
    if (!grown)
        return SCENE_NONE;
    scene->materials = grown;
    /* glTF's default material is white (1.0); 0.8 grey is used instead because a
     * white Lambert surface conserves all energy and makes GI slow to converge and
     * unlike any real surface (pbrt and Blender default to 0.5–0.8 as well). */
    pf_material *material = &grown[scene->material_count];
    *material = pf_material_lambert(0.8f, 0.8f, 0.8f);
    ctx->default_material = (int32_t)scene->material_count++;
    return ctx->default_material;
}

/* A primitive's optional per-vertex attributes (NULL where absent). */
typedef struct vertex_attributes {
    float *uv[2];
    float *color;
    uint32_t color_components; /* 3 or 4 */
    float *tangent;
    float *corner_tangent; /* generated: per triangle corner (tangents.c), over tangent */
} vertex_attributes;

static void vertex_attributes_free(vertex_attributes *a)
{
    free(a->uv[0]);
    free(a->uv[1]);
    free(a->color);
    free(a->tangent);
    free(a->corner_tangent);
}

void scene_corner_defaults(float corner[SCENE_CORNER_FLOATS])
{
    memset(corner, 0, SCENE_CORNER_FLOATS * sizeof *corner);
    for (int c = 4; c < 8; c++)
        corner[c] = 1.0f;
}

/* Corner k (triangle k / 3) from vertex v's attributes. */
static void fill_corner(const vertex_attributes *a, uint32_t v, size_t k, float *corner)
{
    scene_corner_defaults(corner);
    for (int set = 0; set < 2; set++)
        if (a->uv[set])
            memcpy(corner + 2 * set, a->uv[set] + 2 * (size_t)v, 2 * sizeof *corner);
    if (a->color)
        memcpy(corner + 4, a->color + (size_t)a->color_components * v,
               a->color_components * sizeof *corner);
    if (a->corner_tangent)
        memcpy(corner + 8, a->corner_tangent + 4 * k, 4 * sizeof *corner);
    else if (a->tangent)
        memcpy(corner + 8, a->tangent + 4 * (size_t)v, 4 * sizeof *corner);
}

/* Reads the optional attributes a material's textures and COLOR_0 need. */
static pf_status read_vertex_attributes(gltf_context *ctx, const cJSON *attributes,
                                        uint32_t accessor_count, uint32_t vertex_count,
                                        const char *element, vertex_attributes *out,
                                        pf_error *err)
{
    static const char *const names[] = {"TEXCOORD_0", "TEXCOORD_1", "COLOR_0", "TANGENT"};
    memset(out, 0, sizeof *out);
    pf_status status = PF_OK;
    for (int k = 0; k < 4 && !status; k++) {
        int32_t index;
        char sub[224];
        snprintf(sub, sizeof sub, "%s.attributes.%s", element, names[k]);
        status = gltf_index(ctx, attributes, names[k], accessor_count, &index, sub, err);
        if (status || index == SCENE_NONE)
            continue;
        uint32_t components = k < 2 ? 2 : 4, count = 0;
        if (k == 2) {
            const cJSON *accessor = cJSON_GetArrayItem(
                cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"), index);
            const cJSON *type = cJSON_GetObjectItemCaseSensitive(accessor, "type");
            components = cJSON_IsString(type) && strcmp(type->valuestring, "VEC3") == 0 ? 3 : 4;
            out->color_components = components;
        }
        float *data = NULL;
        status = gltf_read_floats(ctx, index, components, &data, &count, sub, err);
        if (!status && count != vertex_count)
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "%u values for %u positions", count,
                               vertex_count);
        float **slot = k < 2 ? &out->uv[k] : k == 2 ? &out->color : &out->tangent;
        *slot = data;
    }
    if (status)
        vertex_attributes_free(out);
    return status;
}

/* Appends the primitive's triangles (corner vertex indices in corners) to mesh. */
static pf_status append_triangles(gltf_context *ctx, scene_mesh *mesh, const uint32_t *corners,
                                  uint32_t triangle_count, const float *positions,
                                  const float *normals, const vertex_attributes *attributes,
                                  uint32_t material, pf_error *err)
{
    int has_attributes = attributes->uv[0] || attributes->uv[1] || attributes->color ||
                         attributes->tangent || attributes->corner_tangent;
    if (has_attributes || mesh->corners) {
        uint32_t before = mesh->corners ? mesh->triangle_count : 0;
        float(*grown)[3 * SCENE_CORNER_FLOATS] =
            realloc(mesh->corners,
                    ((size_t)mesh->triangle_count + triangle_count) * sizeof *mesh->corners);
        if (!grown)
            return gltf_fail(ctx, err, PF_ERR_NOMEM, "meshes", "out of memory");
        mesh->corners = grown;
        mesh->has_color |= attributes->color != NULL;
        /* Earlier primitives without attributes get the defaults. */
        for (uint32_t t = before; t < mesh->triangle_count; t++)
            for (int c = 0; c < 3; c++)
                scene_corner_defaults(mesh->corners[t] + SCENE_CORNER_FLOATS * c);
        for (uint32_t t = 0; t < triangle_count; t++)
            for (int c = 0; c < 3; c++)
                fill_corner(attributes, corners[3 * t + c], 3 * (size_t)t + c,
                            mesh->corners[mesh->triangle_count + t] + SCENE_CORNER_FLOATS * c);
    }
    uint32_t total = mesh->triangle_count + triangle_count;
    float(*grown_positions)[9] = realloc(mesh->positions, (size_t)total * sizeof *mesh->positions);
    if (grown_positions)
        mesh->positions = grown_positions;
    float(*grown_normals)[9] = realloc(mesh->normals, (size_t)total * sizeof *mesh->normals);
    if (grown_normals)
        mesh->normals = grown_normals;
    uint32_t *grown_materials = realloc(mesh->materials, (size_t)total * sizeof *mesh->materials);
    if (grown_materials)
        mesh->materials = grown_materials;
    if (!grown_positions || !grown_normals || !grown_materials)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "meshes", "out of memory");
    for (uint32_t t = 0; t < triangle_count; t++) {
        float *p = mesh->positions[mesh->triangle_count + t];
        float *n = mesh->normals[mesh->triangle_count + t];
        for (int corner = 0; corner < 3; corner++)
            memcpy(p + 3 * corner, positions + 3 * (size_t)corners[3 * t + corner],
                   3 * sizeof *p);
        if (normals) {
            for (int corner = 0; corner < 3; corner++)
                memcpy(n + 3 * corner, normals + 3 * (size_t)corners[3 * t + corner],
                       3 * sizeof *n);
        } else {
            scene_face_normals(p, n);
        }
        mesh->materials[mesh->triangle_count + t] = material;
    }
    mesh->triangle_count = total;
    return PF_OK;
}

/* Builds triangle corner lists for TRIANGLES / STRIP / FAN from the index list. */
static uint32_t *triangulate(int mode, const uint32_t *indices, uint32_t count,
                             uint32_t *triangle_count)
{
    uint32_t triangles = 0;
    if (mode == GLTF_MODE_TRIANGLES)
        triangles = count / 3;
    else if (count >= 3)
        triangles = count - 2;
    uint32_t *corners = malloc(((size_t)triangles * 3 + 1) * sizeof *corners);
    if (!corners)
        return NULL;
    for (uint32_t t = 0; t < triangles; t++) {
        uint32_t *c = corners + 3 * t;
        if (mode == GLTF_MODE_TRIANGLES) {
            c[0] = indices[3 * t];
            c[1] = indices[3 * t + 1];
            c[2] = indices[3 * t + 2];
        } else if (mode == GLTF_MODE_TRIANGLE_STRIP) {
            /* glTF §3.7.2.1: odd strip triangles swap their first two vertices so
             * every triangle keeps the strip's winding. */
            c[0] = indices[t + (t % 2)];
            c[1] = indices[t + 1 - (t % 2)];
            c[2] = indices[t + 2];
        } else {
            c[0] = indices[t + 1];
            c[1] = indices[t + 2];
            c[2] = indices[0];
        }
    }
    *triangle_count = triangles;
    return corners;
}

static pf_status load_primitive(gltf_context *ctx, scene_mesh *mesh, const cJSON *primitive,
                                int deforms, const char *element, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    double mode_value;
    int32_t material, indices_index = SCENE_NONE;
    uint32_t accessor_count = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors"));
    pf_status status = gltf_number(ctx, primitive, "mode", GLTF_MODE_TRIANGLES, &mode_value,
                                   element, err);
    if (!status)
        status = gltf_index(ctx, primitive, "material", ctx->file_material_count, &material,
                            element, err);
    if (!status)
        status = gltf_primitive_variant(ctx, primitive, element, &material, err);
    if (!status)
        status = gltf_index(ctx, primitive, "indices", accessor_count, &indices_index, element,
                            err);
    if (status)
        return status;
    int mode = (int)mode_value;
    if (mode < GLTF_MODE_POINTS || mode > GLTF_MODE_TRIANGLE_FAN || mode != mode_value)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "mode %g is not valid", mode_value);
    if (mode < GLTF_MODE_TRIANGLES) {
        scene_warn_once(scene, "points and lines",
                        "%s: %s: points/lines primitives (mode %d) are not supported: skipped",
                        ctx->path, element, mode);
        return PF_OK;
    }
    const cJSON *attributes = cJSON_GetObjectItemCaseSensitive(primitive, "attributes");
    if (!cJSON_IsObject(attributes))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "attributes: expected an object");
    char attribute_element[160];
    snprintf(attribute_element, sizeof attribute_element, "%s.attributes", element);
    int32_t position_index, normal_index;
    status = gltf_index(ctx, attributes, "POSITION", accessor_count, &position_index,
                        attribute_element, err);
    if (!status)
        status = gltf_index(ctx, attributes, "NORMAL", accessor_count, &normal_index,
                            attribute_element, err);
    if (status)
        return status;
    if (position_index == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, attribute_element, "POSITION is missing");

    float *positions = NULL, *normals = NULL;
    vertex_attributes extra = {{NULL, NULL}, NULL, 0, NULL};
    uint32_t *indices = NULL, *corners = NULL;
    uint32_t vertex_count = 0, normal_count = 0, index_count = 0, triangle_count = 0;
    char sub[192];
    snprintf(sub, sizeof sub, "%s.attributes.POSITION", element);
    status = gltf_read_floats(ctx, position_index, 3, &positions, &vertex_count, sub, err);
    if (!status && normal_index != SCENE_NONE) {
        snprintf(sub, sizeof sub, "%s.attributes.NORMAL", element);
        status = gltf_read_floats(ctx, normal_index, 3, &normals, &normal_count, sub, err);
        if (!status && normal_count != vertex_count)
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub, "%u normals for %u positions",
                               normal_count, vertex_count);
    }
    if (!status)
        status = read_vertex_attributes(ctx, attributes, accessor_count, vertex_count, element,
                                        &extra, err);
    if (!status) {
        snprintf(sub, sizeof sub, "%s.indices", element);
        if (indices_index != SCENE_NONE) {
            status = gltf_read_indices(ctx, indices_index, &indices, &index_count, sub, err);
        } else {
            index_count = vertex_count;
            indices = malloc((size_t)index_count * sizeof *indices);
            if (!indices)
                status = gltf_fail(ctx, err, PF_ERR_NOMEM, sub, "out of memory");
            for (uint32_t k = 0; indices && k < index_count; k++)
                indices[k] = k;
        }
    }
    for (uint32_t k = 0; !status && k < index_count; k++)
        if (indices[k] >= vertex_count)
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, sub,
                               "index %u (entry %u) out of range (%u vertices)", indices[k], k,
                               vertex_count);
    if (!status && mode == GLTF_MODE_TRIANGLES && index_count % 3 != 0)
        scene_warn_once(scene, "index count", "%s: %s: %u indices is not a multiple of 3: "
                        "the last %u ignored", ctx->path, sub, index_count, index_count % 3);
    if (!status) {
        corners = triangulate(mode, indices, index_count, &triangle_count);
        if (!corners)
            status = gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    if (!status && material == SCENE_NONE) {
        material = default_material(ctx);
        if (material == SCENE_NONE)
            status = gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    /* A normal map (the base's, else the coat's) needs tangents: the file's, else generated
     * from its UV set. */
    uint32_t normal_slot = PF_NO_TEXTURE;
    if (!status) {
        const pf_material *m = &scene->materials[material];
        normal_slot = m->normal_texture != PF_NO_TEXTURE ? m->normal_texture
                                                          : m->clearcoat_normal_texture;
    }
    if (!status && normal_slot != PF_NO_TEXTURE && !extra.tangent) {
        int set = (scene->textures[normal_slot - 1].sampling & PF_TEXTURE_TEXCOORD_1) ? 1 : 0;
        if (extra.uv[set])
            status = scene_generate_tangents(positions, normals, extra.uv[set], vertex_count,
                                             corners, triangle_count, &extra.corner_tangent,
                                             err);
        else
            scene_warn_once(scene, "normal map without uvs",
                            "%s: %s: normalTexture reads TEXCOORD_%d, which the primitive "
                            "lacks: its normal map is not applied",
                            ctx->path, element, set);
    }
    if (!status)
        status = append_triangles(ctx, mesh, corners, triangle_count, positions, normals, &extra,
                                  (uint32_t)material, err);
    if (!status && deforms)
        status = gltf_append_deform_vertices(ctx, mesh, primitive, element, positions, normals,
                                             vertex_count, corners, triangle_count, err);
    vertex_attributes_free(&extra);
    free(positions);
    free(normals);
    free(indices);
    free(corners);
    return status;
}

static pf_status load_meshes(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *meshes;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "meshes", &meshes, &count, "", err);
    if (status || count == 0)
        return status;
    scene->meshes = calloc(count, sizeof *scene->meshes);
    if (!scene->meshes)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "meshes", "out of memory");
    scene->mesh_count = count;
    for (uint32_t m = 0; m < count; m++) {
        char element[64];
        snprintf(element, sizeof element, "meshes[%u]", m);
        const cJSON *mesh, *primitives;
        uint32_t primitive_count;
        status = array_object(ctx, meshes, m, &mesh, element, err);
        if (!status)
            status = gltf_array(ctx, mesh, "primitives", &primitives, &primitive_count, element,
                                err);
        int deforms = !status && gltf_mesh_deforms(mesh);
        for (uint32_t p = 0; !status && p < primitive_count; p++) {
            char primitive_element[96];
            snprintf(primitive_element, sizeof primitive_element, "meshes[%u].primitives[%u]", m,
                     p);
            const cJSON *primitive;
            status = array_object(ctx, primitives, p, &primitive, primitive_element, err);
            if (!status)
                status = gltf_draco_decode_primitive(ctx, primitive, primitive_element, err);
            if (!status)
                status = load_primitive(ctx, &scene->meshes[m], primitive, deforms,
                                        primitive_element, err);
            gltf_draco_release(ctx);
        }
        if (!status)
            status = gltf_load_mesh_weights(ctx, mesh, &scene->meshes[m], element, err);
        if (status)
            return status;
    }
    return PF_OK;
}

/* ---- cameras and lights ------------------------------------------------- */

static pf_status load_cameras(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *cameras;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "cameras", &cameras, &count, "", err);
    if (status || count == 0)
        return status;
    scene->cameras = calloc(count, sizeof *scene->cameras);
    if (!scene->cameras)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "cameras", "out of memory");
    scene->camera_def_count = count;
    for (uint32_t k = 0; k < count; k++) {
        char element[64];
        snprintf(element, sizeof element, "cameras[%u]", k);
        const cJSON *camera;
        status = array_object(ctx, cameras, k, &camera, element, err);
        if (status)
            return status;
        scene_camera_def *def = &scene->cameras[k];
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(camera, "type");
        const char *type_name = cJSON_IsString(type) ? type->valuestring : "";
        double yfov = 0, aspect, znear, zfar, ymag = 0;
        if (strcmp(type_name, "perspective") == 0) {
            snprintf(element, sizeof element, "cameras[%u].perspective", k);
            const cJSON *perspective = cJSON_GetObjectItemCaseSensitive(camera, "perspective");
            if (!cJSON_IsObject(perspective))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "missing");
            status = gltf_number(ctx, perspective, "yfov", -1, &yfov, element, err);
            if (!status)
                status = gltf_number(ctx, perspective, "aspectRatio", 0, &aspect, element, err);
            if (!status)
                status = gltf_number(ctx, perspective, "znear", NAN, &znear, element, err);
            if (!status)
                status = gltf_number(ctx, perspective, "zfar", 0, &zfar, element, err);
            if (status)
                return status;
            if (!cJSON_GetObjectItemCaseSensitive(perspective, "yfov"))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "yfov is missing");
            if (!(yfov > 0 && yfov < GLTF_PI))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                                 "yfov %g must be in (0, pi) radians", yfov);
        } else if (strcmp(type_name, "orthographic") == 0) {
            /* Parallel rays over a view xmag × ymag half extents (world units), which the
             * image's aspect stretches in x as it does a perspective camera's. */
            snprintf(element, sizeof element, "cameras[%u].orthographic", k);
            const cJSON *orthographic = cJSON_GetObjectItemCaseSensitive(camera, "orthographic");
            double xmag;
            if (!cJSON_IsObject(orthographic))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "missing");
            status = gltf_number(ctx, orthographic, "xmag", NAN, &xmag, element, err);
            if (!status)
                status = gltf_number(ctx, orthographic, "ymag", NAN, &ymag, element, err);
            if (!status)
                status = gltf_number(ctx, orthographic, "znear", 0.01, &znear, element, err);
            if (!status)
                status = gltf_number(ctx, orthographic, "zfar", 0, &zfar, element, err);
            if (status)
                return status;
            /* The spec asks for non-zero magnifications; a negative one would mirror the
             * image, which no exporter means. */
            if (!(xmag > 0 && ymag > 0))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                                 "xmag %g and ymag %g must be given and > 0", xmag, ymag);
            aspect = xmag / ymag;
            /* znear 0 is allowed for a parallel projection; rays start on the view plane. */
            if (!(znear > 0))
                znear = 0.01;
            def->orthographic = 1;
        } else {
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "type \"%s\" is not perspective or orthographic", type_name);
        }
        if (!(znear > 0))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "znear %s",
                             isnan(znear) ? "is missing" : "must be > 0");
        if (aspect < 0)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "aspectRatio %g must be > 0",
                             aspect);
        if (zfar != 0 && !(zfar > znear))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "zfar %g must exceed znear %g",
                             zfar, znear);
        def->yfov = (float)yfov;
        def->ymag = (float)ymag;
        def->aspect = (float)aspect;
        def->znear = (float)znear;
        def->zfar = (float)zfar;
    }
    return PF_OK;
}

/*
 * What one unit of a light's "intensity" is in watts: 1/683 for the spec's
 * photometric units (candela for point and spot, lux for directional), 1 for
 * a light whose extras.photonfarm.intensityUnits says it was written
 * radiometric ("W/sr" for point and spot, "W/m2" for directional). Any other
 * value there is a format error naming it, not a guess.
 */
static pf_status light_units(gltf_context *ctx, const cJSON *light, pf_light_kind kind,
                             const char *element, double *watts_per_unit, pf_error *err)
{
    *watts_per_unit = 1.0 / GLTF_LUMENS_PER_WATT;
    const cJSON *extras = cJSON_GetObjectItemCaseSensitive(light, "extras");
    const cJSON *ours = cJSON_GetObjectItemCaseSensitive(extras, "photonfarm");
    const cJSON *units = cJSON_GetObjectItemCaseSensitive(ours, "intensityUnits");
    if (!units)
        return PF_OK;
    const char *photometric = kind == PF_LIGHT_DIRECTIONAL ? "lux" : "cd";
    const char *radiometric = kind == PF_LIGHT_DIRECTIONAL ? "W/m2" : "W/sr";
    if (cJSON_IsString(units) && strcmp(units->valuestring, radiometric) == 0) {
        *watts_per_unit = 1.0;
        return PF_OK;
    }
    if (cJSON_IsString(units) && strcmp(units->valuestring, photometric) == 0)
        return PF_OK;
    return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                     "extras.photonfarm.intensityUnits must be \"%s\" or \"%s\" for a %s "
                     "light", photometric, radiometric,
                     kind == PF_LIGHT_DIRECTIONAL ? "directional"
                                                  : kind == PF_LIGHT_SPOT ? "spot" : "point");
}

static pf_status load_lights(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *extensions = cJSON_GetObjectItemCaseSensitive(ctx->root, "extensions");
    const cJSON *punctual = cJSON_GetObjectItemCaseSensitive(extensions, "KHR_lights_punctual");
    if (!punctual)
        return PF_OK;
    const cJSON *lights;
    uint32_t count;
    pf_status status = gltf_array(ctx, punctual, "lights", &lights, &count,
                                  "extensions.KHR_lights_punctual", err);
    if (status || count == 0)
        return status;
    scene->lights = calloc(count, sizeof *scene->lights);
    if (!scene->lights)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "lights", "out of memory");
    scene->light_def_count = count;
    for (uint32_t k = 0; k < count; k++) {
        char element[96];
        snprintf(element, sizeof element, "extensions.KHR_lights_punctual.lights[%u]", k);
        const cJSON *light;
        status = array_object(ctx, lights, k, &light, element, err);
        if (status)
            return status;
        scene_light_def *def = &scene->lights[k];
        const cJSON *type = cJSON_GetObjectItemCaseSensitive(light, "type");
        const char *type_name = cJSON_IsString(type) ? type->valuestring : "";
        if (strcmp(type_name, "point") == 0)
            def->kind = PF_LIGHT_POINT;
        else if (strcmp(type_name, "spot") == 0)
            def->kind = PF_LIGHT_SPOT;
        else if (strcmp(type_name, "directional") == 0)
            def->kind = PF_LIGHT_DIRECTIONAL;
        else
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "type \"%s\" is not point, spot or directional", type_name);
        float color[3] = {1, 1, 1};
        double intensity, range;
        status = gltf_floats(ctx, light, "color", 3, color, element, err);
        if (!status)
            status = gltf_number(ctx, light, "intensity", 1, &intensity, element, err);
        if (!status)
            status = gltf_number(ctx, light, "range", 0, &range, element, err);
        if (status)
            return status;
        if (intensity < 0 || range < 0 || color[0] < 0 || color[1] < 0 || color[2] < 0)
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                             "color, intensity and range must be non-negative");
        double watts_per_unit;
        status = light_units(ctx, light, def->kind, element, &watts_per_unit, err);
        if (status)
            return status;
        for (int c = 0; c < 3; c++)
            def->intensity[c] = (float)(color[c] * intensity * watts_per_unit);
        def->range = def->kind == PF_LIGHT_DIRECTIONAL ? 0.0f : (float)range;
        double inner = 0, outer = GLTF_SPOT_OUTER_DEFAULT;
        if (def->kind == PF_LIGHT_SPOT) {
            char spot_element[112];
            snprintf(spot_element, sizeof spot_element, "%s.spot", element);
            const cJSON *spot = cJSON_GetObjectItemCaseSensitive(light, "spot");
            status = gltf_number(ctx, spot, "innerConeAngle", 0, &inner, spot_element, err);
            if (!status)
                status = gltf_number(ctx, spot, "outerConeAngle", GLTF_SPOT_OUTER_DEFAULT, &outer,
                                     spot_element, err);
            if (status)
                return status;
            if (!(inner >= 0 && inner <= outer && outer > 0 && outer <= GLTF_HALF_PI + 1e-6))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, spot_element,
                                 "cone angles inner %g, outer %g must satisfy 0 <= inner <= "
                                 "outer <= pi/2",
                                 inner, outer);
        }
        def->cos_inner_cone = (float)cos(inner);
        def->cos_outer_cone = (float)cos(outer);
    }
    return PF_OK;
}

/* ---- nodes and the scene ------------------------------------------------ */

/* A node's transform before the file's: the identity (TRS with unit rotation and scale). */
static void node_identity(scene_node *node)
{
    node->rotation[3] = 1.0f;
    node->scale[0] = node->scale[1] = node->scale[2] = 1.0f;
}

/* Normalises a node's (or an instance's) rotation; a zero quaternion is refused with what,
 * naming element. */
static pf_status unit_rotation(gltf_context *ctx, float rotation[4], const char *element,
                               const char *what, pf_error *err)
{
    float length_squared = 0;
    for (int k = 0; k < 4; k++)
        length_squared += rotation[k] * rotation[k];
    if (!(length_squared > 1e-12f))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s is a zero quaternion", what);
    scene_quat_normalize(rotation);
    return PF_OK;
}

static pf_status load_node(gltf_context *ctx, uint32_t index, const cJSON *node,
                           scene_node *out, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    char element[64];
    snprintf(element, sizeof element, "nodes[%u]", index);
    node_identity(out);
    pf_status status = gltf_floats(ctx, node, "translation", 3, out->translation, element, err);
    if (!status)
        status = gltf_floats(ctx, node, "rotation", 4, out->rotation, element, err);
    if (!status)
        status = gltf_floats(ctx, node, "scale", 3, out->scale, element, err);
    if (!status)
        status = gltf_index(ctx, node, "mesh", scene->mesh_count, &out->mesh, element, err);
    if (!status)
        status = gltf_index(ctx, node, "camera", scene->camera_def_count, &out->camera, element,
                            err);
    if (!status)
        status = gltf_index(ctx, node, "skin",
                            (uint32_t)cJSON_GetArraySize(
                                cJSON_GetObjectItemCaseSensitive(ctx->root, "skins")),
                            &out->skin, element, err);
    if (!status)
        status = unit_rotation(ctx, out->rotation, element, "rotation", err);
    if (status)
        return status;
    if (cJSON_GetObjectItemCaseSensitive(node, "matrix")) {
        status = gltf_floats(ctx, node, "matrix", 16, out->matrix, element, err);
        if (status)
            return status;
        out->has_matrix = 1;
    }
    const cJSON *extensions = cJSON_GetObjectItemCaseSensitive(node, "extensions");
    const cJSON *punctual = cJSON_GetObjectItemCaseSensitive(extensions, "KHR_lights_punctual");
    out->light = SCENE_NONE;
    if (punctual) {
        char light_element[112];
        snprintf(light_element, sizeof light_element, "%s.extensions.KHR_lights_punctual", element);
        status = gltf_index(ctx, punctual, "light", scene->light_def_count, &out->light,
                            light_element, err);
        if (status)
            return status;
    }
    return PF_OK;
}

/*
 * EXT_mesh_gpu_instancing: a node whose mesh is drawn once per instance, each under the
 * instance's TRANSLATION, ROTATION and SCALE (accessors of one element an instance; any may be
 * absent) in the node's space. Each instance becomes a node of its own after the file's, a
 * child of the node carrying its mesh (the node itself then carries none), so animation of
 * the node moves every instance and the rest of the loader sees plain nodes. A skin or morph
 * weights of the node are not carried to its instances (the extension leaves them undefined:
 * one warning).
 */
static pf_status expand_instances(gltf_context *ctx, const cJSON *nodes, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    uint32_t file_nodes = scene->node_count;
    static const char *const names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
    static const uint32_t components[3] = {3, 4, 3};
    for (uint32_t k = 0; k < file_nodes; k++) {
        const cJSON *instancing = cJSON_GetObjectItemCaseSensitive(
            cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(nodes, (int)k), "extensions"),
            "EXT_mesh_gpu_instancing");
        if (!instancing)
            continue;
        char element[96];
        snprintf(element, sizeof element, "nodes[%u].extensions.EXT_mesh_gpu_instancing", k);
        const cJSON *attributes = cJSON_GetObjectItemCaseSensitive(instancing, "attributes");
        if (!cJSON_IsObject(attributes))
            return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "attributes missing");
        float *values[3] = {NULL, NULL, NULL};
        uint32_t count = 0;
        int has_count = 0;
        pf_status status = PF_OK;
        for (int a = 0; a < 3 && !status; a++) {
            int32_t index;
            status = gltf_index(ctx, attributes, names[a],
                                (uint32_t)cJSON_GetArraySize(
                                    cJSON_GetObjectItemCaseSensitive(ctx->root, "accessors")),
                                &index, element, err);
            uint32_t n = 0;
            if (!status && index != SCENE_NONE)
                status = gltf_read_floats(ctx, index, components[a], &values[a], &n, element,
                                          err);
            if (!status && index != SCENE_NONE) {
                if (has_count && n != count)
                    status = gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                                       "%s has %u instances, another attribute %u", names[a],
                                       n, count);
                count = n;
                has_count = 1;
            }
        }
        if (!status && (!has_count || count == 0))
            status = gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                               "no TRANSLATION, ROTATION or SCALE instances");
        scene_node *grown = NULL;
        if (!status) {
            grown = realloc(scene->nodes, ((size_t)scene->node_count + count) * sizeof *grown);
            if (!grown)
                status = gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
        }
        if (!status) {
            scene->nodes = grown;
            scene_node *node = &scene->nodes[k];
            if (node->skin != SCENE_NONE || node->weights)
                scene_warn_once(scene, "instanced skin",
                                "%s: %s: a skin or morph weights of an instanced node are not "
                                "carried to its instances",
                                ctx->path, element);
            node->first_instance = scene->node_count;
            node->instance_count = count;
            for (uint32_t i = 0; i < count && !status; i++) {
                scene_node *instance = &scene->nodes[scene->node_count + i];
                memset(instance, 0, sizeof *instance);
                instance->parent = (int32_t)k;
                instance->mesh = node->mesh;
                instance->camera = instance->light = instance->skin = SCENE_NONE;
                node_identity(instance);
                if (values[0])
                    memcpy(instance->translation, values[0] + 3 * (size_t)i, 3 * sizeof(float));
                if (values[1])
                    memcpy(instance->rotation, values[1] + 4 * (size_t)i, 4 * sizeof(float));
                if (values[2])
                    memcpy(instance->scale, values[2] + 3 * (size_t)i, 3 * sizeof(float));
                char what[48];
                snprintf(what, sizeof what, "ROTATION of instance %u", i);
                status = unit_rotation(ctx, instance->rotation, element, what, err);
            }
            node->mesh = SCENE_NONE;
            scene->node_count += count;
        }
        for (int a = 0; a < 3; a++)
            free(values[a]);
        if (status)
            return status;
    }
    return PF_OK;
}

/*
 * Depth-first walk from the scene's root nodes: records parents and the order
 * (parents before children, children in file order) that eval composes in.
 */
static pf_status walk_hierarchy(gltf_context *ctx, const cJSON *roots, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *nodes = cJSON_GetObjectItemCaseSensitive(ctx->root, "nodes");
    uint32_t *stack = malloc(((size_t)scene->node_count + 1) * sizeof *stack);
    scene->order = malloc(((size_t)scene->node_count + 1) * sizeof *scene->order);
    if (!stack || !scene->order) {
        free(stack);
        return gltf_fail(ctx, err, PF_ERR_NOMEM, "nodes", "out of memory");
    }
    pf_status status = PF_OK;
    uint32_t root_count = roots ? (uint32_t)cJSON_GetArraySize(roots) : scene->node_count;
    for (uint32_t r = 0; r < root_count && !status; r++) {
        uint32_t root;
        if (roots) {
            const cJSON *item = cJSON_GetArrayItem(roots, (int)r);
            double value = cJSON_IsNumber(item) ? item->valuedouble : -1;
            if (!(value >= 0 && value < scene->node_count && value == floor(value))) {
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, "scene",
                                   "nodes[%u]: not a valid node index", r);
                break;
            }
            root = (uint32_t)value;
            if (scene->nodes[root].parent != SCENE_NONE) {
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, "scene",
                                   "root node %u is a child of node %d", root,
                                   scene->nodes[root].parent);
                break;
            }
        } else {
            root = r;
            if (scene->nodes[root].parent != SCENE_NONE)
                continue;
        }
        uint32_t depth = 0;
        stack[depth++] = root;
        while (depth > 0 && !status) {
            uint32_t current = stack[--depth];
            if (scene->nodes[current].in_scene) {
                status = gltf_fail(ctx, err, PF_ERR_FORMAT, "scene",
                                   "node %u is listed twice as a root", current);
                break;
            }
            scene->nodes[current].in_scene = 1;
            scene->order[scene->order_count++] = current;
            const cJSON *children = cJSON_GetObjectItemCaseSensitive(
                cJSON_GetArrayItem(nodes, (int)current), "children");
            /* Pushed in reverse so the first child is visited first; a node's instances
             * (expand_instances) after its children. */
            const scene_node *walked = &scene->nodes[current];
            for (uint32_t i = walked->instance_count; i > 0; i--)
                stack[depth++] = walked->first_instance + i - 1;
            if (current < (uint32_t)cJSON_GetArraySize(nodes))
                for (int c = cJSON_GetArraySize(children) - 1; c >= 0; c--)
                    stack[depth++] = (uint32_t)cJSON_GetArrayItem(children, c)->valuedouble;
        }
    }
    free(stack);
    return status;
}

static pf_status load_nodes(gltf_context *ctx, pf_error *err)
{
    pf_scene *scene = ctx->scene;
    const cJSON *nodes;
    uint32_t count;
    pf_status status = gltf_array(ctx, ctx->root, "nodes", &nodes, &count, "", err);
    if (status)
        return status;
    if (count > 0) {
        scene->nodes = calloc(count, sizeof *scene->nodes);
        if (!scene->nodes)
            return gltf_fail(ctx, err, PF_ERR_NOMEM, "nodes", "out of memory");
    }
    scene->node_count = count;
    for (uint32_t k = 0; k < count; k++)
        scene->nodes[k].parent = SCENE_NONE;
    for (uint32_t k = 0; k < count; k++) {
        char element[64];
        snprintf(element, sizeof element, "nodes[%u]", k);
        const cJSON *node, *children;
        uint32_t child_count;
        status = array_object(ctx, nodes, k, &node, element, err);
        if (!status)
            status = load_node(ctx, k, node, &scene->nodes[k], err);
        if (!status)
            status = gltf_array(ctx, node, "children", &children, &child_count, element, err);
        if (status)
            return status;
        for (uint32_t c = 0; c < child_count; c++) {
            const cJSON *item = cJSON_GetArrayItem(children, (int)c);
            double value = cJSON_IsNumber(item) ? item->valuedouble : -1;
            if (!(value >= 0 && value < count && value == floor(value)))
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                                 "children[%u]: not a valid node index", c);
            uint32_t child = (uint32_t)value;
            if (child == k || scene->nodes[child].parent != SCENE_NONE)
                return gltf_fail(ctx, err, PF_ERR_FORMAT, element,
                                 "children[%u]: node %u already has a parent (or is itself): "
                                 "the hierarchy must be a tree",
                                 c, child);
            scene->nodes[child].parent = (int32_t)k;
        }
    }
    status = expand_instances(ctx, nodes, err);
    if (status)
        return status;

    const cJSON *scenes;
    uint32_t scene_count;
    int32_t scene_index;
    status = gltf_array(ctx, ctx->root, "scenes", &scenes, &scene_count, "", err);
    if (!status)
        status = gltf_index(ctx, ctx->root, "scene", scene_count, &scene_index, "", err);
    if (status)
        return status;
    if (scene_index == SCENE_NONE && scene_count > 0)
        scene_index = 0;
    const cJSON *roots = NULL;
    if (scene_index != SCENE_NONE) {
        char element[64];
        snprintf(element, sizeof element, "scenes[%d]", scene_index);
        const cJSON *chosen;
        uint32_t root_count;
        status = array_object(ctx, scenes, (uint32_t)scene_index, &chosen, element, err);
        if (!status)
            status = gltf_array(ctx, chosen, "nodes", &roots, &root_count, element, err);
        if (status)
            return status;
    } else if (count > 0) {
        scene_warn_once(scene, "no scenes",
                        "%s: no scenes defined: rendering every root node", ctx->path);
    }
    if (scene_index != SCENE_NONE && !roots)
        return PF_OK; /* an empty scene: "no triangles" is reported by scene_finalize */
    return walk_hierarchy(ctx, roots, err);
}

static void context_free(gltf_context *ctx)
{
    for (uint32_t k = 0; k < ctx->buffer_count; k++)
        if (ctx->buffers[k].owned)
            free(ctx->buffers[k].data);
    free(ctx->buffers);
    gltf_meshopt_free(ctx);
    gltf_textures_free(ctx);
    cJSON_Delete(ctx->root);
    free(ctx->file_data);
}

pf_status scene_load_gltf(pf_scene *scene, int binary_hint, pf_error *err)
{
    gltf_context ctx = {.scene = scene, .path = scene->path, .default_material = SCENE_NONE};
    pf_status status = scene_read_file(scene->path, &ctx.file_data, &ctx.file_size, err);
    if (status)
        return status;
    const char *json = ctx.file_data;
    size_t json_size = ctx.file_size;
    int is_glb = ctx.file_size >= 4 &&
                 gltf_read_u32le((const unsigned char *)ctx.file_data) == GLB_MAGIC;
    if (is_glb || binary_hint)
        status = parse_glb(&ctx, &json, &json_size, err);
    if (!status)
        status = parse_json(&ctx, json, json_size, err);
    if (!status)
        status = check_extensions(&ctx, err);
    if (!status)
        status = read_asset_extras(&ctx, err);
    if (!status)
        status = gltf_load_buffers(&ctx, err);
    if (!status)
        status = gltf_meshopt_decode_views(&ctx, err);
    if (!status)
        status = gltf_load_materials(&ctx, err);
    if (!status)
        status = gltf_load_material_variants(&ctx, err);
    if (!status)
        status = load_meshes(&ctx, err);
    if (!status)
        status = load_cameras(&ctx, err);
    if (!status)
        status = load_lights(&ctx, err);
    if (!status)
        status = load_nodes(&ctx, err);
    if (!status)
        status = gltf_load_skins(&ctx, err);
    if (!status)
        status = gltf_load_animations(&ctx, err);
    context_free(&ctx);
    return status;
}
