/*
 * glTF textures -> the scene's texture table (pf_texture_ref) and texels.
 *
 * A material slot's textureInfo names textures[i], which names an image
 * (source, or EXT_texture_webp's source, preferred when present) and a
 * sampler (filters and wrap modes; absent: LINEAR_MIPMAP_LINEAR, REPEAT).
 * The image comes from a uri (file beside the scene or data: URI) or a
 * bufferView (.glb), is decoded by image_decode.c and gets its mip chain
 * here, once per colour space it is used in: baseColor and emissive are sRGB,
 * metallicRoughness and normal linear. KHR_texture_transform (offset,
 * rotation, scale, texCoord) becomes the slot's 2×3 matrix, as the
 * extension's spec composes it: T · R · S.
 *
 * Every failure names the image, its index and the slot that uses it, and
 * is a load error (exit 2): there is no frame with a missing texture.
 */
#include "gltf_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* OpenGL enumerants glTF's samplers use. */
#define GL_NEAREST 9728
#define GL_LINEAR 9729
#define GL_NEAREST_MIPMAP_NEAREST 9984
#define GL_LINEAR_MIPMAP_LINEAR 9987
#define GL_CLAMP_TO_EDGE 33071
#define GL_MIRRORED_REPEAT 33648
#define GL_REPEAT 10497

void gltf_textures_free(gltf_context *ctx)
{
    free(ctx->image_chain);
    free(ctx->image_size);
    ctx->image_chain = NULL;
    ctx->image_size = NULL;
}

static pf_status wrap_mode(gltf_context *ctx, const cJSON *sampler, const char *key,
                           uint32_t *out, const char *element, pf_error *err)
{
    double value;
    pf_status status = gltf_number(ctx, sampler, key, GL_REPEAT, &value, element, err);
    if (status)
        return status;
    if (value == GL_REPEAT)
        *out = PF_TEXTURE_WRAP_REPEAT;
    else if (value == GL_CLAMP_TO_EDGE)
        *out = PF_TEXTURE_WRAP_CLAMP;
    else if (value == GL_MIRRORED_REPEAT)
        *out = PF_TEXTURE_WRAP_MIRROR;
    else
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "%s %g is not a glTF wrap mode", key,
                         value);
    return PF_OK;
}

/* The sampler's bits of pf_texture_ref.sampling. */
static pf_status sampler_bits(gltf_context *ctx, int32_t index, uint32_t *bits, pf_error *err)
{
    *bits = 0;
    if (index == SCENE_NONE)
        return PF_OK;
    char element[64];
    snprintf(element, sizeof element, "samplers[%d]", index);
    const cJSON *sampler =
        cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(ctx->root, "samplers"), index);
    if (!cJSON_IsObject(sampler))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
    double mag, min;
    uint32_t wrap_s = PF_TEXTURE_WRAP_REPEAT, wrap_t = PF_TEXTURE_WRAP_REPEAT;
    pf_status status = gltf_number(ctx, sampler, "magFilter", GL_LINEAR, &mag, element, err);
    if (!status)
        status = gltf_number(ctx, sampler, "minFilter", GL_LINEAR_MIPMAP_LINEAR, &min, element,
                             err);
    if (!status)
        status = wrap_mode(ctx, sampler, "wrapS", &wrap_s, element, err);
    if (!status)
        status = wrap_mode(ctx, sampler, "wrapT", &wrap_t, element, err);
    if (status)
        return status;
    if (mag != GL_NEAREST && mag != GL_LINEAR)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "magFilter %g is not a glTF filter",
                         mag);
    if (min != GL_NEAREST && min != GL_LINEAR &&
        !(min >= GL_NEAREST_MIPMAP_NEAREST && min <= GL_LINEAR_MIPMAP_LINEAR && min == floor(min)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "minFilter %g is not a glTF filter",
                         min);
    *bits = wrap_s << PF_TEXTURE_WRAP_S_SHIFT | wrap_t << PF_TEXTURE_WRAP_T_SHIFT;
    if (mag == GL_NEAREST)
        *bits |= PF_TEXTURE_MAG_NEAREST;
    /* NEAREST_MIPMAP_* (9984, 9986) and NEAREST sample a level's nearest texel. */
    if (min == GL_NEAREST || min == 9984 || min == 9986)
        *bits |= PF_TEXTURE_MIN_NEAREST;
    if (min == GL_NEAREST || min == GL_LINEAR)
        *bits |= PF_TEXTURE_NO_MIPS;
    return PF_OK;
}

/* The encoded bytes of images[index]: *owned is set when *data must be freed. */
static pf_status image_bytes(gltf_context *ctx, const cJSON *image, const char *element,
                             const unsigned char **data, size_t *size, unsigned char **owned,
                             pf_error *err)
{
    *owned = NULL;
    const cJSON *uri = cJSON_GetObjectItemCaseSensitive(image, "uri");
    if (uri) {
        pf_status status = gltf_read_uri(ctx, uri, element, owned, size, err);
        *data = *owned;
        return status;
    }
    int32_t view;
    uint32_t view_count = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "bufferViews"));
    pf_status status = gltf_index(ctx, image, "bufferView", view_count, &view, element, err);
    if (status)
        return status;
    if (view == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "neither uri nor bufferView");
    return gltf_view_bytes(ctx, view, element, data, size, err);
}

/* Decodes images[index] and appends its mip chain in colour space srgb (once). */
static pf_status image_chain(gltf_context *ctx, int32_t index, int srgb, const char *used_by,
                             pf_error *err)
{
    if (ctx->image_chain[index][srgb] != 0)
        return PF_OK;
    pf_scene *scene = ctx->scene;
    char element[256];
    snprintf(element, sizeof element, "images[%d] (used by %s)", index, used_by);
    const cJSON *image =
        cJSON_GetArrayItem(cJSON_GetObjectItemCaseSensitive(ctx->root, "images"), index);
    if (!cJSON_IsObject(image))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
    const unsigned char *data = NULL;
    unsigned char *owned = NULL;
    size_t size = 0;
    uint8_t *rgba = NULL;
    uint32_t width = 0, height = 0;
    double start = pf_time_ms();
    pf_status status = image_bytes(ctx, image, element, &data, &size, &owned, err);
    if (!status) {
        status = scene_image_decode(data, size, &width, &height, &rgba, err);
        if (status)
            pf_error_prefix(err, "%s: %s", ctx->path, element);
    }
    free(owned);
    if (status)
        return status;
    uint32_t levels = scene_mip_levels(width, height);
    uint64_t texels = scene_mip_chain_texels(width, height, levels);
    if (scene->texel_count + texels > PF_SCENE_TEXEL_BUDGET) {
        free(rgba);
        return gltf_fail(ctx, err, PF_ERR_LIMIT, element,
                         "%ux%u pixels: the scene's textures would need %llu MiB with their mip "
                         "chains, over the %u MiB texture budget",
                         width, height,
                         (unsigned long long)(((scene->texel_count + texels) * 4) >> 20),
                         (PF_SCENE_TEXEL_BUDGET * 4u) >> 20);
    }
    uint32_t *grown = realloc(scene->texels, (size_t)(scene->texel_count + texels) * 4);
    if (!grown) {
        free(rgba);
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    scene->texels = grown;
    status = scene_mip_chain_build(rgba, width, height, levels, srgb,
                                   scene->texels + scene->texel_count, err);
    free(rgba);
    if (status) {
        pf_error_prefix(err, "%s: %s", ctx->path, element);
        return status;
    }
    ctx->image_chain[index][srgb] = scene->texel_count + 1;
    ctx->image_size[index][0] = width;
    ctx->image_size[index][1] = height;
    ctx->image_size[index][2] = levels;
    scene->texel_count += texels;
    scene->info.image_count++;
    scene->info.decode_ms += pf_time_ms() - start;
    return PF_OK;
}

/* KHR_texture_transform as the slot's matrix; may replace texCoord. */
static pf_status texture_transform(gltf_context *ctx, const cJSON *info, const char *element,
                                   float transform[6], double *tex_coord, pf_error *err)
{
    float offset[2] = {0, 0}, scale[2] = {1, 1};
    double rotation = 0;
    const cJSON *ext = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(info, "extensions"), "KHR_texture_transform");
    char ext_element[256];
    snprintf(ext_element, sizeof ext_element, "%s.extensions.KHR_texture_transform", element);
    pf_status status = PF_OK;
    if (ext) {
        status = gltf_floats(ctx, ext, "offset", 2, offset, ext_element, err);
        if (!status)
            status = gltf_floats(ctx, ext, "scale", 2, scale, ext_element, err);
        if (!status)
            status = gltf_number(ctx, ext, "rotation", 0, &rotation, ext_element, err);
        if (!status)
            status = gltf_number(ctx, ext, "texCoord", *tex_coord, tex_coord, ext_element, err);
    }
    double c = cos(rotation), s = sin(rotation);
    transform[0] = (float)(c * scale[0]);
    transform[1] = (float)(s * scale[1]);
    transform[2] = offset[0];
    transform[3] = (float)(-s * scale[0]);
    transform[4] = (float)(c * scale[1]);
    transform[5] = offset[1];
    return status;
}

pf_status gltf_texture_slot(gltf_context *ctx, const cJSON *info, int srgb, const char *element,
                            uint32_t *slot, float *scale, pf_error *err)
{
    *slot = PF_NO_TEXTURE;
    if (!info)
        return PF_OK;
    pf_scene *scene = ctx->scene;
    if (!cJSON_IsObject(info))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "expected an object");
    const cJSON *textures = cJSON_GetObjectItemCaseSensitive(ctx->root, "textures");
    uint32_t texture_count = (uint32_t)cJSON_GetArraySize(textures);
    uint32_t images = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "images"));
    uint32_t samplers = (uint32_t)cJSON_GetArraySize(
        cJSON_GetObjectItemCaseSensitive(ctx->root, "samplers"));
    int32_t texture_index, source = SCENE_NONE, webp_source = SCENE_NONE, sampler = SCENE_NONE;
    double tex_coord = 0, scale_value = 1;
    pf_status status = gltf_index(ctx, info, "index", texture_count, &texture_index, element, err);
    if (!status && texture_index == SCENE_NONE)
        status = gltf_fail(ctx, err, PF_ERR_FORMAT, element, "index is missing");
    if (!status)
        status = gltf_number(ctx, info, "texCoord", 0, &tex_coord, element, err);
    /* normalTexture.scale (occlusion's strength is not read: occlusion is not used). */
    if (!status && scale)
        status = gltf_number(ctx, info, "scale", 1, &scale_value, element, err);
    pf_texture_ref ref;
    memset(&ref, 0, sizeof ref);
    if (!status)
        status = texture_transform(ctx, info, element, ref.transform, &tex_coord, err);
    if (status)
        return status;
    char texture_element[64];
    snprintf(texture_element, sizeof texture_element, "textures[%d]", texture_index);
    const cJSON *texture = cJSON_GetArrayItem(textures, texture_index);
    if (!cJSON_IsObject(texture))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, texture_element, "expected an object");
    status = gltf_index(ctx, texture, "source", images, &source, texture_element, err);
    if (!status)
        status = gltf_index(ctx, texture, "sampler", samplers, &sampler, texture_element, err);
    const cJSON *webp = cJSON_GetObjectItemCaseSensitive(
        cJSON_GetObjectItemCaseSensitive(texture, "extensions"), "EXT_texture_webp");
    if (!status && webp)
        status = gltf_index(ctx, webp, "source", images, &webp_source, texture_element, err);
    if (status)
        return status;
    if (webp_source != SCENE_NONE)
        source = webp_source;
    if (source == SCENE_NONE)
        return gltf_fail(ctx, err, PF_ERR_FORMAT, texture_element, "has no image (source)");
    if (!(tex_coord >= 0 && tex_coord == floor(tex_coord)))
        return gltf_fail(ctx, err, PF_ERR_FORMAT, element, "texCoord %g is not a set index",
                         tex_coord);
    if (tex_coord > 1) {
        scene_warn_once(scene, "texcoord",
                        "%s: %s: TEXCOORD_%g is not supported (sets 0 and 1 are): using "
                        "TEXCOORD_0",
                        ctx->path, element, tex_coord);
        tex_coord = 0;
    }
    uint32_t bits = 0;
    status = sampler_bits(ctx, sampler, &bits, err);
    if (!status && !ctx->image_chain) {
        ctx->image_count = images;
        ctx->image_chain = calloc(images, sizeof *ctx->image_chain);
        ctx->image_size = calloc(images, sizeof *ctx->image_size);
        if (!ctx->image_chain || !ctx->image_size)
            status = gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    }
    if (!status)
        status = image_chain(ctx, source, srgb, element, err);
    if (status)
        return status;
    pf_texture_ref *grown =
        realloc(scene->textures, (scene->texture_count + 1) * sizeof *scene->textures);
    if (!grown)
        return gltf_fail(ctx, err, PF_ERR_NOMEM, element, "out of memory");
    scene->textures = grown;
    ref.first_texel = (uint32_t)(ctx->image_chain[source][srgb] - 1);
    ref.width = ctx->image_size[source][0];
    ref.height = ctx->image_size[source][1];
    ref.sampling = bits | ((ctx->image_size[source][2] - 1) & PF_TEXTURE_LEVELS_MASK);
    if (srgb)
        ref.sampling |= PF_TEXTURE_SRGB;
    if (tex_coord == 1)
        ref.sampling |= PF_TEXTURE_TEXCOORD_1;
    scene->textures[scene->texture_count] = ref;
    scene->texture_count++;
    *slot = scene->texture_count; /* index + 1 */
    if (scale)
        *scale = (float)scale_value;
    return PF_OK;
}
