#include "scene_test_util.h"

#include "pf_test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *st_path(char *buffer, size_t size, const char *name)
{
    char directory[512];
    int length = snprintf(buffer, size, "%s/%s", pf_test_tmpdir(directory, sizeof directory), name);
    if (length < 0 || (size_t)length >= size)
        fprintf(stderr, "st_path: %s/%s is too long\n", directory, name);
    return buffer;
}

int st_write(const char *path, const void *data, size_t size)
{
    FILE *file = fopen(path, "wb");
    if (!file)
        return -1;
    size_t written = size ? fwrite(data, 1, size, file) : 0;
    return fclose(file) == 0 && written == size ? 0 : -1;
}

int st_write_text(const char *path, const char *text) { return st_write(path, text, strlen(text)); }

unsigned char *st_quad_buffer(const float *extra, uint32_t extra_floats, size_t *size)
{
    static const float positions[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float normals[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const uint16_t indices[6] = {0, 1, 2, 0, 2, 3};
    *size = ST_QUAD_BYTES + extra_floats * sizeof(float);
    unsigned char *bytes = malloc(*size + 4);
    memcpy(bytes, positions, sizeof positions);
    memcpy(bytes + 48, normals, sizeof normals);
    memcpy(bytes + 96, indices, sizeof indices);
    if (extra_floats)
        memcpy(bytes + ST_QUAD_BYTES, extra, extra_floats * sizeof(float));
    return bytes;
}

static char *base64(const unsigned char *data, size_t size)
{
    static const char alphabet[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc((size + 2) / 3 * 4 + 1), *cursor = out;
    for (size_t k = 0; k < size; k += 3) {
        uint32_t chunk = (uint32_t)data[k] << 16;
        if (k + 1 < size)
            chunk |= (uint32_t)data[k + 1] << 8;
        if (k + 2 < size)
            chunk |= data[k + 2];
        *cursor++ = alphabet[chunk >> 18 & 63];
        *cursor++ = alphabet[chunk >> 12 & 63];
        *cursor++ = k + 1 < size ? alphabet[chunk >> 6 & 63] : '=';
        *cursor++ = k + 2 < size ? alphabet[chunk & 63] : '=';
    }
    *cursor = 0;
    return out;
}

static void put_u32(unsigned char *at, uint32_t value)
{
    for (int k = 0; k < 4; k++)
        at[k] = (unsigned char)(value >> (8 * k));
}

const char *st_write_gltf(const st_gltf *spec, char *path, size_t size)
{
    size_t bin_size;
    unsigned char *bin = st_quad_buffer(spec->extra, spec->extra_floats, &bin_size);
    char name[256], uri_storage[1024];
    char *uri_owned = NULL;
    const char *uri = "";
    if (spec->glb) {
        uri = NULL;
    } else if (spec->data_uri) {
        char *encoded = base64(bin, bin_size);
        uri_owned = malloc(strlen(encoded) + 64);
        sprintf(uri_owned, "data:application/octet-stream;base64,%s", encoded);
        free(encoded);
        uri = uri_owned;
    } else {
        snprintf(name, sizeof name, "%s.bin", spec->name);
        st_write(st_path(uri_storage, sizeof uri_storage, name), bin, bin_size);
        uri = name;
    }
    const char *default_mesh = spec->materials
        ? "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,"
          "\"material\":0}]}]"
        : "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2}]}]";
    size_t json_capacity = 65536 + (uri ? strlen(uri) : 0);
    char *json = malloc(json_capacity);
    char views[1024];
    snprintf(views, sizeof views,
             "[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},"
             "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":48},"
             "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":12}]");
    if (spec->extra_floats) {
        size_t length = strlen(views);
        snprintf(views + length - 1, sizeof views - length + 1,
                 ",{\"buffer\":0,\"byteOffset\":%u,\"byteLength\":%zu}]", ST_QUAD_BYTES,
                 spec->extra_floats * sizeof(float));
    }
    int written = snprintf(
        json, json_capacity,
        "{\"asset\":{\"version\":\"2.0\"%s%s%s%s%s},\"scene\":0,\"scenes\":%s,\"nodes\":%s,"
        "\"meshes\":%s,%s%s%s%s%s%s%s%s%s%s%s%s%s%s%s"
        "\"accessors\":["
        "{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
        "{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"},"
        "{\"bufferView\":2,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"}%s],"
        "\"bufferViews\":%s,\"buffers\":",
        spec->asset_extras ? ",\"extras\":" : "", spec->asset_extras ? spec->asset_extras : "",
        spec->generator ? ",\"generator\":\"" : "", spec->generator ? spec->generator : "",
        spec->generator ? "\"" : "",
        spec->scenes ? spec->scenes : "[{\"nodes\":[0]}]", spec->nodes,
        spec->meshes ? spec->meshes : default_mesh,
        spec->materials ? "\"materials\":" : "", spec->materials ? spec->materials : "",
        spec->materials ? "," : "",
        spec->cameras ? "\"cameras\":" : "", spec->cameras ? spec->cameras : "",
        spec->cameras ? "," : "",
        spec->animations ? "\"animations\":" : "", spec->animations ? spec->animations : "",
        spec->animations ? "," : "",
        spec->skins ? "\"skins\":" : "", spec->skins ? spec->skins : "", spec->skins ? "," : "",
        spec->extensions ? "\"extensions\":" : "", spec->extensions ? spec->extensions : "",
        spec->extensions ? "," : "",
        spec->extra_accessors ? spec->extra_accessors : "", views);
    if (uri)
        written += snprintf(json + written, json_capacity - (size_t)written,
                            "[{\"uri\":\"%s\",\"byteLength\":%zu}]", uri, bin_size);
    else
        written += snprintf(json + written, json_capacity - (size_t)written,
                            "[{\"byteLength\":%zu}]", bin_size);
    if (spec->extensions_used)
        written += snprintf(json + written, json_capacity - (size_t)written,
                            ",\"extensionsUsed\":%s", spec->extensions_used);
    if (spec->extensions_required)
        written += snprintf(json + written, json_capacity - (size_t)written,
                            ",\"extensionsRequired\":%s", spec->extensions_required);
    snprintf(json + written, json_capacity - (size_t)written, "}");

    snprintf(name, sizeof name, "%s.%s", spec->name, spec->glb ? "glb" : "gltf");
    st_path(path, size, name);
    if (spec->glb) {
        size_t json_length = strlen(json), json_padded = (json_length + 3) & ~(size_t)3;
        size_t bin_padded = (bin_size + 3) & ~(size_t)3;
        size_t total = 12 + 8 + json_padded + 8 + bin_padded;
        unsigned char *glb = calloc(1, total);
        put_u32(glb, 0x46546C67u);
        put_u32(glb + 4, 2);
        put_u32(glb + 8, (uint32_t)total);
        put_u32(glb + 12, (uint32_t)json_padded);
        put_u32(glb + 16, 0x4E4F534Au);
        memset(glb + 20, ' ', json_padded);
        memcpy(glb + 20, json, json_length);
        unsigned char *chunk = glb + 20 + json_padded;
        put_u32(chunk, (uint32_t)bin_padded);
        put_u32(chunk + 4, 0x004E4942u);
        memcpy(chunk + 8, bin, bin_size);
        st_write(path, glb, total);
        free(glb);
    } else {
        st_write_text(path, json);
    }
    free(json);
    free(uri_owned);
    free(bin);
    return path;
}

void st_expect_error(const char *path, pf_status status, const char *needle1,
                     const char *needle2)
{
    pf_scene *scene = (pf_scene *)1;
    pf_error err = {0};
    pf_status result = pf_scene_load(path, &scene, &err);
    PF_CHECK_MSG(result == status, "%s: status %d, expected %d (%s)", path, (int)result,
                 (int)status, err.message);
    PF_CHECK_MSG(scene == NULL, "%s: scene not NULL on failure", path);
    const char *slash = strrchr(path, '/');
    const char *file_name = slash ? slash + 1 : path;
    PF_CHECK_MSG(strstr(err.message, file_name) != NULL, "message \"%s\" does not name %s",
                 err.message, file_name);
    if (needle1)
        PF_CHECK_MSG(strstr(err.message, needle1) != NULL, "message \"%s\" lacks \"%s\"",
                     err.message, needle1);
    if (needle2)
        PF_CHECK_MSG(strstr(err.message, needle2) != NULL, "message \"%s\" lacks \"%s\"",
                     err.message, needle2);
    if (result == PF_OK)
        pf_scene_destroy(scene);
}

pf_scene *st_load_ok(const char *path)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    pf_status status = pf_scene_load(path, &scene, &err);
    PF_CHECK_MSG(status == PF_OK, "%s: %s", path, err.message);
    return status == PF_OK ? scene : NULL;
}

void st_check_vec3(const float *actual, double x, double y, double z, double tolerance)
{
    PF_CHECK_NEAR(actual[0], x, tolerance);
    PF_CHECK_NEAR(actual[1], y, tolerance);
    PF_CHECK_NEAR(actual[2], z, tolerance);
}
