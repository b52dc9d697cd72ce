/*
 * Textures at load (core/scene: gltf_textures.c, image_decode.c,
 * texture_mips.c): images encoded here by the same libraries (libspng,
 * TurboJPEG, libwebp) and referenced by a file, a data: URI and a buffer
 * view (a .glb's way); their texels, mip chains in linear light, sampler and
 * KHR_texture_transform bits, the per-corner attributes a frame carries, and
 * every malformed image (truncated, corrupt, bomb-sized, not an image,
 * missing, mutated at random) as an error naming the image and the material,
 * never a crash.
 */
#include "pf_test.h"
#include "scene_internal.h"
#include "scene_test_util.h"

#include <math.h>
#include <spng.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>
#include <webp/encode.h>

/* For the helpers that return a value (PF_REQUIRE returns from a void test). */
#define MUST(cond)                                                                                \
    do {                                                                                          \
        if (!(cond)) {                                                                            \
            fprintf(stderr, "%s:%d: %s failed\n", __FILE__, __LINE__, #cond);                     \
            abort();                                                                              \
        }                                                                                         \
    } while (0)

#define IMAGE_W 4
#define IMAGE_H 2

/* A 4×2 RGBA image: distinct texels, alpha varying. */
static void test_pixels(uint8_t *rgba)
{
    static const uint8_t values[IMAGE_W * IMAGE_H][4] = {
        {0, 0, 0, 255},       {255, 255, 255, 255}, {200, 100, 50, 128}, {10, 20, 30, 0},
        {255, 0, 0, 255},     {0, 255, 0, 255},     {0, 0, 255, 64},     {128, 128, 128, 255}};
    memcpy(rgba, values, sizeof values);
}

static unsigned char *encode_png(const uint8_t *rgba, uint32_t w, uint32_t h, size_t *size)
{
    spng_ctx *png = spng_ctx_new(SPNG_CTX_ENCODER);
    MUST(png != NULL);
    spng_set_option(png, SPNG_ENCODE_TO_BUFFER, 1);
    struct spng_ihdr header = {w, h, 8, SPNG_COLOR_TYPE_TRUECOLOR_ALPHA, 0, 0, 0};
    MUST(spng_set_ihdr(png, &header) == 0);
    MUST(spng_encode_image(png, rgba, (size_t)w * h * 4, SPNG_FMT_PNG,
                                 SPNG_ENCODE_FINALIZE) == 0);
    int error = 0;
    unsigned char *out = spng_get_png_buffer(png, size, &error);
    spng_ctx_free(png);
    MUST(out != NULL && error == 0);
    return out;
}

static unsigned char *encode_jpeg(const uint8_t *rgba, uint32_t w, uint32_t h, size_t *size)
{
    tjhandle jpeg = tjInitCompress();
    MUST(jpeg != NULL);
    unsigned char *buffer = NULL;
    unsigned long length = 0;
    MUST(tjCompress2(jpeg, rgba, (int)w, 0, (int)h, TJPF_RGBA, &buffer, &length, TJSAMP_444,
                           100, 0) == 0);
    tjDestroy(jpeg);
    unsigned char *out = malloc(length);
    memcpy(out, buffer, length);
    tjFree(buffer);
    *size = length;
    return out;
}

static unsigned char *encode_webp(const uint8_t *rgba, uint32_t w, uint32_t h, size_t *size)
{
    uint8_t *buffer = NULL;
    *size = WebPEncodeLosslessRGBA(rgba, (int)w, (int)h, (int)w * 4, &buffer);
    MUST(*size > 0);
    unsigned char *out = malloc(*size);
    memcpy(out, buffer, *size);
    WebPFree(buffer);
    return out;
}

static char *base64(const unsigned char *data, size_t size)
{
    static const char table[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char *out = malloc(4 * (size / 3 + 1) + 1), *at = out;
    for (size_t i = 0; i < size; i += 3) {
        uint32_t v = (uint32_t)data[i] << 16 | (i + 1 < size ? (uint32_t)data[i + 1] << 8 : 0) |
                     (i + 2 < size ? data[i + 2] : 0);
        *at++ = table[v >> 18 & 63];
        *at++ = table[v >> 12 & 63];
        *at++ = i + 1 < size ? table[v >> 6 & 63] : '=';
        *at++ = i + 2 < size ? table[v & 63] : '=';
    }
    *at = 0;
    return out;
}

/*
 * A quad (two triangles) with TEXCOORD_0 (and COLOR_0 when colour), one material whose
 * `material` JSON is given, and images/textures/samplers JSON; writes <name>.gltf + .bin.
 */
/* Image bytes write_textured_quad appends to the buffer as bufferViews[4] (a GLB's way), or
 * NULL. */
static const unsigned char *embedded_image;
static size_t embedded_size;

/* Root members write_textured_quad adds (",\"extensionsRequired\":[...]"), or "". */
static const char *extra_root = "";

static const char *write_textured_quad(const char *name, const char *material, const char *images,
                                       const char *textures, const char *samplers, int colour,
                                       char *path, size_t path_size)
{
    float data[4 * 3 + 4 * 2 + 4 * 4];
    static const float positions[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float uvs[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    static const float colours[16] = {1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 1};
    memcpy(data, positions, sizeof positions);
    memcpy(data + 12, uvs, sizeof uvs);
    memcpy(data + 20, colours, sizeof colours);
    uint16_t indices[6] = {0, 1, 2, 0, 2, 3};
    size_t head = sizeof data + sizeof indices, bin_size = head + embedded_size;
    unsigned char *bin = malloc(bin_size);
    MUST(bin != NULL);
    memcpy(bin, data, sizeof data);
    memcpy(bin + sizeof data, indices, sizeof indices);
    if (embedded_image)
        memcpy(bin + head, embedded_image, embedded_size);
    char bin_name[128], bin_path[512], image_view[96] = "";
    snprintf(bin_name, sizeof bin_name, "%s.bin", name);
    MUST(st_write(st_path(bin_path, sizeof bin_path, bin_name), bin, bin_size) == 0);
    free(bin);
    if (embedded_image)
        snprintf(image_view, sizeof image_view, ",{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
                 head, embedded_size);
    char gltf_name[128];
    snprintf(gltf_name, sizeof gltf_name, "%s.gltf", name);
    st_path(path, path_size, gltf_name);
    size_t capacity = 4096 + strlen(images) + strlen(material) + strlen(textures) +
                      strlen(samplers);
    char *json = malloc(capacity);
    snprintf(json, capacity,
             "{\"asset\":{\"version\":\"2.0\"}%s,\"scene\":0,\"scenes\":[{\"nodes\":[0]}],"
             "\"nodes\":[{\"mesh\":0}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1%s},"
             "\"indices\":3,\"material\":0}]}],"
             "\"materials\":[%s],\"images\":%s,\"textures\":%s,\"samplers\":%s,"
             "\"accessors\":["
             "{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"},"
             "{\"bufferView\":2,\"componentType\":5126,\"count\":4,\"type\":\"VEC4\"},"
             "{\"bufferView\":3,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"}],"
             "\"bufferViews\":["
             "{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48},"
             "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":32},"
             "{\"buffer\":0,\"byteOffset\":80,\"byteLength\":64},"
             "{\"buffer\":0,\"byteOffset\":144,\"byteLength\":12}%s],"
             "\"buffers\":[{\"uri\":\"%s\",\"byteLength\":%zu}]}",
             extra_root, colour ? ",\"COLOR_0\":2" : "", material, images, textures, samplers,
             image_view, bin_name, bin_size);
    MUST(st_write_text(path, json) == 0);
    free(json);
    return path;
}

/* An image file beside the scene: its uri JSON ("images" array text) in out. */
static void image_file(const char *file, const unsigned char *bytes, size_t size, char *out,
                       size_t out_size)
{
    char path[512];
    PF_REQUIRE(st_write(st_path(path, sizeof path, file), bytes, size) == 0);
    snprintf(out, out_size, "[{\"uri\":\"%s\"}]", file);
}

static const char *const BASE_COLOR_MATERIAL =
    "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"baseColorTexture\":{\"index\":0}}}";

static int channel(uint32_t word, int c)
{
    return (int)(word >> (8 * c) & 0xFF);
}

/* Level 1 texel x of a 4×2 image from level 0, averaged in linear light (sRGB) or not. */
static float expected_level1(const uint8_t *rgba, int x, int c, int srgb)
{
    float sum = 0.0f;
    for (int y = 0; y < 2; y++)
        for (int dx = 0; dx < 2; dx++) {
            float v = rgba[4 * (y * IMAGE_W + 2 * x + dx) + c] / 255.0f;
            sum += srgb && c < 3 ? scene_srgb_to_linear(v) : v;
        }
    sum /= 4.0f;
    return srgb && c < 3 ? scene_linear_to_srgb(sum) : sum;
}

PF_TEST(srgb_decoding_and_mip_levels)
{
    PF_CHECK_NEAR(scene_srgb_to_linear(0.0f), 0.0, 0);
    PF_CHECK_NEAR(scene_srgb_to_linear(1.0f), 1.0, 1e-6);
    PF_CHECK_NEAR(scene_srgb_to_linear(0.5f), 0.2140411, 1e-6);     /* IEC 61966-2-1 */
    PF_CHECK_NEAR(scene_srgb_to_linear(0.04045f), 0.0031308, 1e-6); /* the knee */
    PF_CHECK_NEAR(scene_linear_to_srgb(scene_srgb_to_linear(0.73f)), 0.73, 1e-6);
    PF_CHECK(scene_mip_levels(4, 2) == 3 && scene_mip_levels(1, 1) == 1);
    PF_CHECK(scene_mip_levels(1024, 3) == 11);
    PF_CHECK(scene_mip_chain_texels(4, 2, 3) == 8 + 2 + 1);
    PF_CHECK(scene_mip_chain_texels(5, 3, 3) == 15 + 2 + 1);
}

/* Each format, by file, data: URI and bufferView: level 0 as encoded, level 1 averaged. */
PF_TEST(png_jpeg_and_webp_decode_with_their_mip_chains)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    struct {
        const char *name, *file;
        unsigned char *(*encode)(const uint8_t *, uint32_t, uint32_t, size_t *);
        int tolerance; /* JPEG is lossy even at quality 100, and has no alpha */
        int data_uri; /* 0 a file, 1 a data: URI, 2 a buffer view (as in a .glb) */
    } formats[] = {{"tex_png", "tex_png.png", encode_png, 0, 0},
                   {"tex_jpeg", "tex_jpeg.jpg", encode_jpeg, 12, 2},
                   {"tex_webp", "tex_webp.webp", encode_webp, 0, 1}};
    for (size_t f = 0; f < sizeof formats / sizeof *formats; f++) {
        size_t size;
        unsigned char *bytes = formats[f].encode(rgba, IMAGE_W, IMAGE_H, &size);
        char images[8192], path[512];
        if (formats[f].data_uri == 2) { /* in the buffer, as a GLB carries its images */
            embedded_image = bytes;
            embedded_size = size;
            snprintf(images, sizeof images, "[{\"bufferView\":4,\"mimeType\":\"image/jpeg\"}]");
        } else if (formats[f].data_uri) {
            char *text = base64(bytes, size);
            snprintf(images, sizeof images, "[{\"uri\":\"data:image/webp;base64,%s\"}]", text);
            free(text);
        } else {
            image_file(formats[f].file, bytes, size, images, sizeof images);
        }
        write_textured_quad(formats[f].name, BASE_COLOR_MATERIAL, images,
                            "[{\"source\":0}]", "[]", 0, path, sizeof path);
        embedded_image = NULL;
        embedded_size = 0;
        free(bytes);
        pf_scene *scene = NULL;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
        const pf_scene_info *info = pf_scene_get_info(scene);
        PF_CHECK(info->texture_count == 1 && info->image_count == 1);
        PF_CHECK(info->texel_count == 11);
        pf_scene_frame frame;
        PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
        PF_REQUIRE(frame.texture_count == 1 && frame.texel_count == 11 && frame.corners);
        const pf_texture_ref *ref = &frame.textures[0];
        PF_CHECK(frame.materials[0].base_color_texture == 1); /* index 0 + 1 */
        PF_CHECK(ref->width == IMAGE_W && ref->height == IMAGE_H && ref->first_texel == 0);
        PF_CHECK((ref->sampling & PF_TEXTURE_LEVELS_MASK) == 2);
        PF_CHECK((ref->sampling & PF_TEXTURE_SRGB) != 0);
        /* glTF's default sampler: repeat, linear, mip-mapped. */
        PF_CHECK((ref->sampling & ~(PF_TEXTURE_LEVELS_MASK | PF_TEXTURE_SRGB)) == 0);
        int worst = 0;
        for (int i = 0; i < IMAGE_W * IMAGE_H; i++)
            for (int c = 0; c < (formats[f].tolerance ? 3 : 4); c++) {
                /* WebP's lossless encoder keeps no colour under alpha 0 (its `exact` off). */
                if (rgba[4 * i + 3] == 0 && c < 3)
                    continue;
                int d = abs(channel(frame.texels[i], c) - rgba[4 * i + c]);
                worst = d > worst ? d : worst;
            }
        PF_CHECK_MSG(worst <= formats[f].tolerance, "%s: level 0 off by %d", formats[f].name,
                     worst);
        if (formats[f].encode == encode_png) {
            for (int x = 0; x < 2; x++)
                for (int c = 0; c < 4; c++) {
                    float expected = expected_level1(rgba, x, c, 1);
                    PF_CHECK_MSG(abs(channel(frame.texels[8 + x], c) -
                                     (int)lrintf(expected * 255.0f)) <= 0,
                                 "%s: level 1 texel %d channel %d: %d, expected %g",
                                 formats[f].name, x, c, channel(frame.texels[8 + x], c),
                                 expected * 255.0);
                }
        }
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

/* The same image in a linear slot (metallicRoughness) averages the encoded values; a second
 * slot reusing it in sRGB gets a chain of its own, and the file is decoded once per space. */
PF_TEST(linear_and_srgb_slots_sampler_and_transform)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    size_t size;
    unsigned char *bytes = encode_png(rgba, IMAGE_W, IMAGE_H, &size);
    char images[256], path[512];
    image_file("shared.png", bytes, size, images, sizeof images);
    free(bytes);
    const char *material =
        "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},"
        "\"metallicRoughnessTexture\":{\"index\":1,\"texCoord\":1}},"
        "\"emissiveTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":"
        "{\"offset\":[0.5,0.25],\"rotation\":1.5707963,\"scale\":[2,3]}}},"
        "\"alphaMode\":\"MASK\",\"alphaCutoff\":0.3}";
    /* Both extensions are honoured: a file may require them. */
    extra_root = ",\"extensionsRequired\":[\"KHR_texture_transform\",\"EXT_texture_webp\"],"
                 "\"extensionsUsed\":[\"KHR_texture_transform\",\"EXT_texture_webp\"]";
    write_textured_quad("slots", material, images, "[{\"source\":0},{\"source\":0,\"sampler\":0}]",
                        "[{\"magFilter\":9728,\"minFilter\":9729,\"wrapS\":33071,"
                        "\"wrapT\":33648}]",
                        1, path, sizeof path);
    extra_root = "";
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->texture_count == 3);
    PF_CHECK(info->image_count == 2); /* one image, decoded for sRGB and for linear */
    PF_CHECK(info->texel_count == 22);
    PF_CHECK(info->has_alpha == 1);
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    const pf_material *m = &frame.materials[0];
    PF_CHECK(m->alpha_mode == PF_ALPHA_MASK);
    PF_CHECK_NEAR(m->alpha_cutoff, 0.3, 1e-7);
    PF_REQUIRE(m->base_color_texture == 1 && m->metallic_roughness_texture == 2 &&
               m->emissive_texture == 3);
    const pf_texture_ref *linear = &frame.textures[1], *emissive = &frame.textures[2];
    PF_CHECK((linear->sampling & PF_TEXTURE_SRGB) == 0);
    PF_CHECK((linear->sampling & PF_TEXTURE_TEXCOORD_1) != 0);
    PF_CHECK((linear->sampling & PF_TEXTURE_MAG_NEAREST) != 0);
    PF_CHECK((linear->sampling & PF_TEXTURE_MIN_NEAREST) == 0);
    PF_CHECK((linear->sampling & PF_TEXTURE_NO_MIPS) != 0);
    PF_CHECK((linear->sampling >> PF_TEXTURE_WRAP_S_SHIFT & 3u) == PF_TEXTURE_WRAP_CLAMP);
    PF_CHECK((linear->sampling >> PF_TEXTURE_WRAP_T_SHIFT & 3u) == PF_TEXTURE_WRAP_MIRROR);
    PF_CHECK(linear->first_texel == 11); /* after the sRGB chain */
    for (int c = 0; c < 4; c++)
        PF_CHECK(channel(frame.texels[11 + 8], c) ==
                 (int)lrintf(expected_level1(rgba, 0, c, 0) * 255.0f));
    /* The emissive slot reuses the sRGB chain. */
    PF_CHECK(emissive->first_texel == 0 && (emissive->sampling & PF_TEXTURE_SRGB) != 0);
    /* T · R · S: (cos·sx, sin·sy, ox; −sin·sx, cos·sy, oy) at rotation π/2. */
    const float expected[6] = {0, 3, 0.5f, -2, 0, 0.25f};
    for (int k = 0; k < 6; k++)
        PF_CHECK_NEAR(emissive->transform[k], expected[k], 1e-6);
    PF_CHECK_NEAR(frame.textures[0].transform[0], 1, 0);
    PF_CHECK_NEAR(frame.textures[0].transform[4], 1, 0);
    /* Corners: triangle 1 is vertices 0, 2, 3: uv (0,1), (1,0), (0,0); COLOR_0 red, blue,
     * white; no tangents. */
    PF_REQUIRE(frame.corners != NULL);
    const float(*corner)[4] = (const float(*)[4])frame.corners + 3 * PF_CORNER_TEXELS;
    PF_CHECK(corner[0][0] == 0 && corner[0][1] == 1);
    PF_CHECK(corner[PF_CORNER_TEXELS][0] == 1 && corner[PF_CORNER_TEXELS][1] == 0);
    PF_CHECK(corner[1][0] == 1 && corner[1][1] == 0 && corner[1][2] == 0);
    PF_CHECK(corner[PF_CORNER_TEXELS + 1][2] == 1 && corner[PF_CORNER_TEXELS + 1][0] == 0);
    PF_CHECK(corner[2][0] == 0 && corner[2][1] == 0 && corner[2][2] == 0);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}


/* KHR_materials_clearcoat's textures are linear slots of their own (R scales the coat, G its
 * roughness, its normal map with its scale): the same image as metallicRoughness shares its
 * chain; KHR_materials_specular's specularTexture is linear (A), its specularColorTexture sRGB
 * (a chain of its own). */
PF_TEST(clearcoat_and_specular_textures_are_slots)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    size_t size;
    unsigned char *bytes = encode_png(rgba, IMAGE_W, IMAGE_H, &size);
    char images[256], path[512];
    image_file("coat.png", bytes, size, images, sizeof images);
    free(bytes);
    const char *material =
        "{\"pbrMetallicRoughness\":{\"metallicRoughnessTexture\":{\"index\":0}},"
        "\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1,"
        "\"clearcoatTexture\":{\"index\":0},\"clearcoatRoughnessFactor\":0.5,"
        "\"clearcoatRoughnessTexture\":{\"index\":0,\"texCoord\":1},"
        "\"clearcoatNormalTexture\":{\"index\":0,\"scale\":0.5}},"
        "\"KHR_materials_specular\":{\"specularTexture\":{\"index\":0},"
        "\"specularColorTexture\":{\"index\":0}}}}";
    write_textured_quad("coat", material, images, "[{\"source\":0}]", "[]", 0, path,
                        sizeof path);
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    PF_CHECK(pf_scene_get_info(scene)->image_count == 2); /* decoded linear and sRGB */
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    const pf_material *m = &frame.materials[0];
    PF_CHECK(m->clearcoat == 1.0f && m->clearcoat_roughness == 0.5f);
    PF_REQUIRE(m->clearcoat_texture != PF_NO_TEXTURE &&
               m->clearcoat_roughness_texture != PF_NO_TEXTURE);
    const pf_texture_ref *coat = &frame.textures[m->clearcoat_texture - 1];
    const pf_texture_ref *coat_roughness = &frame.textures[m->clearcoat_roughness_texture - 1];
    PF_CHECK((coat->sampling & PF_TEXTURE_SRGB) == 0);
    PF_CHECK((coat->sampling & PF_TEXTURE_TEXCOORD_1) == 0);
    PF_CHECK((coat_roughness->sampling & PF_TEXTURE_TEXCOORD_1) != 0);
    PF_CHECK(coat->first_texel == frame.textures[m->metallic_roughness_texture - 1].first_texel);
    PF_REQUIRE(m->specular_texture != PF_NO_TEXTURE &&
               m->specular_color_texture != PF_NO_TEXTURE);
    const pf_texture_ref *specular = &frame.textures[m->specular_texture - 1];
    const pf_texture_ref *specular_color = &frame.textures[m->specular_color_texture - 1];
    PF_CHECK((specular->sampling & PF_TEXTURE_SRGB) == 0 &&
             specular->first_texel == coat->first_texel);
    PF_CHECK((specular_color->sampling & PF_TEXTURE_SRGB) != 0 &&
             specular_color->first_texel != coat->first_texel);
    /* The coat's normal map: linear, its scale read; the quad gets tangents for it (it has
     * no base normal map). */
    PF_REQUIRE(m->clearcoat_normal_texture != PF_NO_TEXTURE);
    PF_CHECK(m->clearcoat_normal_scale == 0.5f);
    PF_CHECK((frame.textures[m->clearcoat_normal_texture - 1].sampling & PF_TEXTURE_SRGB) == 0);
    const float *tangent = frame.corners[2]; /* corner 0's tangent texel */
    PF_CHECK(tangent[0] * tangent[0] + tangent[1] * tangent[1] + tangent[2] * tangent[2] > 0.5f);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}
/* Loads path expecting a failure with status; the message names the image and the slot. */
static void expect_image_error(const char *path, pf_status expected, const char *word)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    pf_status status = pf_scene_load(path, &scene, &err);
    PF_CHECK_MSG(status == expected, "%s: status %d (expected %d): %s", path, status, expected,
                 err.message);
    PF_CHECK_MSG(strstr(err.message, "images[0]") != NULL &&
                     strstr(err.message, "materials[0].pbrMetallicRoughness.baseColorTexture"),
                 "%s: message does not name the image and its material: %s", path, err.message);
    PF_CHECK_MSG(!word || strstr(err.message, word), "%s: message lacks '%s': %s", path, word,
                 err.message);
    if (status == PF_OK)
        pf_scene_destroy(scene);
}

static void write_image_scene(const char *name, const char *file, const unsigned char *bytes,
                              size_t size, char *path, size_t path_size)
{
    char images[256];
    image_file(file, bytes, size, images, sizeof images);
    write_textured_quad(name, BASE_COLOR_MATERIAL, images, "[{\"source\":0}]", "[]", 0, path,
                        path_size);
}

PF_TEST(malformed_images_are_named_errors)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    char path[512];
    size_t size;
    unsigned char *png = encode_png(rgba, IMAGE_W, IMAGE_H, &size);
    write_image_scene("truncated_png", "truncated.png", png, size - 20, path, sizeof path);
    expect_image_error(path, PF_ERR_FORMAT, "PNG");
    /* A bomb: a valid header claiming 100,000 × 100,000 pixels (CRC fixed up), no data. */
    unsigned char bomb[64];
    memcpy(bomb, png, 33);
    const uint32_t edge = 100000;
    for (int k = 0; k < 2; k++) {
        bomb[16 + 4 * k] = (unsigned char)(edge >> 24);
        bomb[17 + 4 * k] = (unsigned char)(edge >> 16);
        bomb[18 + 4 * k] = (unsigned char)(edge >> 8);
        bomb[19 + 4 * k] = (unsigned char)edge;
    }
    uint32_t crc = 0xFFFFFFFFu;
    for (int i = 12; i < 29; i++) {
        crc ^= bomb[i];
        for (int b = 0; b < 8; b++)
            crc = crc & 1u ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
    }
    crc ^= 0xFFFFFFFFu;
    bomb[29] = (unsigned char)(crc >> 24);
    bomb[30] = (unsigned char)(crc >> 16);
    bomb[31] = (unsigned char)(crc >> 8);
    bomb[32] = (unsigned char)crc;
    write_image_scene("bomb_png", "bomb.png", bomb, 33, path, sizeof path);
    pf_scene *scene = NULL;
    pf_error err = {0};
    pf_status status = pf_scene_load(path, &scene, &err);
    /* libspng refuses it against the image limits we set, or we do against ours. */
    PF_CHECK_MSG(status == PF_ERR_FORMAT || status == PF_ERR_LIMIT, "bomb: %d %s", status,
                 err.message);
    PF_CHECK(strstr(err.message, "images[0]") != NULL);
    free(png);

    unsigned char *jpeg = encode_jpeg(rgba, IMAGE_W, IMAGE_H, &size);
    write_image_scene("truncated_jpeg", "truncated.jpg", jpeg, size / 2, path, sizeof path);
    expect_image_error(path, PF_ERR_FORMAT, "JPEG");
    free(jpeg);
    unsigned char *webp = encode_webp(rgba, IMAGE_W, IMAGE_H, &size);
    write_image_scene("truncated_webp", "truncated.webp", webp, size - 8, path, sizeof path);
    expect_image_error(path, PF_ERR_FORMAT, "WebP");
    free(webp);
    static const unsigned char text[] = "not an image at all";
    write_image_scene("not_image", "not_image.png", text, sizeof text, path, sizeof path);
    expect_image_error(path, PF_ERR_FORMAT, "not a PNG, JPEG or WebP");
    write_textured_quad("missing_image", BASE_COLOR_MATERIAL, "[{\"uri\":\"no_such.png\"}]",
                        "[{\"source\":0}]", "[]", 0, path, sizeof path);
    expect_image_error(path, PF_ERR_IO, NULL);
    write_textured_quad("no_texture", BASE_COLOR_MATERIAL, "[]", "[]", "[]", 0, path,
                        sizeof path);
    PF_CHECK(pf_scene_load(path, &scene, &err) == PF_ERR_FORMAT);
    PF_CHECK(strstr(err.message, "baseColorTexture") != NULL);
    write_textured_quad("bad_sampler", BASE_COLOR_MATERIAL, "[{\"uri\":\"shared.png\"}]",
                        "[{\"source\":0,\"sampler\":0}]", "[{\"wrapS\":7}]", 0, path,
                        sizeof path);
    PF_CHECK(pf_scene_load(path, &scene, &err) == PF_ERR_FORMAT);
    PF_CHECK(strstr(err.message, "samplers[0]") != NULL);
}

/* Random byte mutations of each format: every load ends in PF_OK or an error (ASan/UBSan
 * builds check that nothing reads or writes out of bounds on the way). */
PF_TEST(mutated_images_never_crash)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    unsigned char *(*encoders[3])(const uint8_t *, uint32_t, uint32_t, size_t *) = {
        encode_png, encode_jpeg, encode_webp};
    uint32_t state = 12345u, loaded = 0, refused = 0;
    for (int f = 0; f < 3; f++) {
        size_t size;
        unsigned char *bytes = encoders[f](rgba, IMAGE_W, IMAGE_H, &size);
        for (int round = 0; round < 60; round++) {
            unsigned char *copy = malloc(size);
            memcpy(copy, bytes, size);
            for (int flips = 0; flips < 1 + round % 4; flips++) {
                state = state * 1664525u + 1013904223u;
                copy[(state >> 8) % size] ^= (unsigned char)(1u << (state >> 29));
            }
            char path[512];
            write_image_scene("mutated", "mutated.img", copy, size, path, sizeof path);
            free(copy);
            pf_scene *scene = NULL;
            pf_error err = {0};
            if (pf_scene_load(path, &scene, &err) == PF_OK) {
                loaded++;
                pf_scene_destroy(scene);
            } else {
                PF_CHECK_MSG(strstr(err.message, "images[0]") != NULL, "%s", err.message);
                refused++;
            }
        }
        free(bytes);
    }
    printf("  mutated images: %u loaded, %u refused\n", loaded, refused);
    PF_CHECK(loaded + refused == 180 && refused > 0);
}

/* A normal map on a primitive without TANGENT gets generated tangents: u runs along +x and v
 * along −y on the test quad (normal +z), so T = +x and the bitangent's handedness is −1. */
PF_TEST(normal_map_without_tangents_gets_them_generated)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    size_t size;
    unsigned char *bytes = encode_png(rgba, IMAGE_W, IMAGE_H, &size);
    char images[256], path[512];
    image_file("normal.png", bytes, size, images, sizeof images);
    free(bytes);
    write_textured_quad("normal_mapped",
                        "{\"normalTexture\":{\"index\":0,\"scale\":0.5},"
                        "\"pbrMetallicRoughness\":{\"metallicFactor\":0}}",
                        images, "[{\"source\":0}]", "[]", 0, path, sizeof path);
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_CHECK(frame.materials[0].normal_texture == 1);
    PF_CHECK_NEAR(frame.materials[0].normal_scale, 0.5, 0);
    PF_CHECK((frame.textures[0].sampling & PF_TEXTURE_SRGB) == 0); /* normals are linear */
    PF_REQUIRE(frame.corners != NULL);
    for (uint32_t k = 0; k < 3 * frame.triangle_count; k++) {
        const float *tangent = frame.corners[PF_CORNER_TEXELS * k + 2];
        PF_CHECK_MSG(fabsf(tangent[0] - 1.0f) < 1e-6f && fabsf(tangent[1]) < 1e-6f &&
                         fabsf(tangent[2]) < 1e-6f && tangent[3] == -1.0f,
                     "corner %u: tangent (%g, %g, %g, %g)", k, tangent[0], tangent[1],
                     tangent[2], tangent[3]);
    }
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* A UV chart and its mirror image sharing the seam's vertices (a symmetric model's halves):
 * u = |x| over a strip in the z = 0 plane, so the tangent (along +u) is −x on the left
 * half and +x on the right, with opposite handedness (n = +z, bitangent +y). One sum per
 * vertex over both halves would cancel on the seam and leave its corners without a frame. */
PF_TEST(mirrored_uv_charts_keep_a_frame_each_side_of_the_seam)
{
    const float positions[6 * 3] = {-1, 0, 0, 0, 0, 0, 1, 0, 0, -1, 1, 0, 0, 1, 0, 1, 1, 0};
    const float uvs[6 * 2] = {1, 0, 0, 0, 1, 0, 1, 1, 0, 1, 1, 1};
    const uint32_t corners[4 * 3] = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
    float *tangents = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(scene_generate_tangents(positions, NULL, uvs, 6, corners, 4, &tangents, &err),
                  &err);
    for (uint32_t k = 0; k < 12; k++) {
        float side = k < 6 ? -1.0f : 1.0f; /* the first two triangles are the left half */
        const float *t = tangents + 4 * k;
        PF_CHECK_MSG(fabsf(t[0] - side) < 1e-6f && fabsf(t[1]) < 1e-6f && fabsf(t[2]) < 1e-6f &&
                         t[3] == side,
                     "corner %u (vertex %u): tangent (%g, %g, %g, %g)", k, corners[k], t[0],
                     t[1], t[2], t[3]);
    }
    free(tangents);
}

/* EXT_texture_webp's source wins over the texture's fallback source. */
PF_TEST(webp_extension_source_is_preferred)
{
    uint8_t rgba[IMAGE_W * IMAGE_H * 4], black[IMAGE_W * IMAGE_H * 4];
    test_pixels(rgba);
    memset(black, 0, sizeof black);
    size_t png_size, webp_size;
    unsigned char *png = encode_png(black, IMAGE_W, IMAGE_H, &png_size);
    unsigned char *webp = encode_webp(rgba, IMAGE_W, IMAGE_H, &webp_size);
    char path[512];
    PF_REQUIRE(st_write(st_path(path, sizeof path, "fallback.png"), png, png_size) == 0);
    PF_REQUIRE(st_write(st_path(path, sizeof path, "preferred.webp"), webp, webp_size) == 0);
    free(png);
    free(webp);
    write_textured_quad("webp_preferred", BASE_COLOR_MATERIAL,
                        "[{\"uri\":\"fallback.png\"},{\"uri\":\"preferred.webp\"}]",
                        "[{\"source\":0,\"extensions\":{\"EXT_texture_webp\":{\"source\":1}}}]",
                        "[]", 0, path, sizeof path);
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_CHECK(frame.texel_count == 11 && frame.texels[1] == 0xFFFFFFFFu); /* texel 1: white */
    PF_CHECK(pf_scene_get_info(scene)->image_count == 1);                /* the PNG unread */
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(untextured_scene_has_no_corners)
{
    char path[512];
    write_textured_quad("untextured", "{\"pbrMetallicRoughness\":{\"metallicFactor\":0}}", "[]",
                        "[]", "[]", 0, path, sizeof path);
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_CHECK(frame.corners == NULL && frame.texture_count == 0 && frame.texel_count == 0);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

int main(void)
{
    PF_RUN(srgb_decoding_and_mip_levels);
    PF_RUN(png_jpeg_and_webp_decode_with_their_mip_chains);
    PF_RUN(linear_and_srgb_slots_sampler_and_transform);
    PF_RUN(clearcoat_and_specular_textures_are_slots);
    PF_RUN(malformed_images_are_named_errors);
    PF_RUN(mutated_images_never_crash);
    PF_RUN(normal_map_without_tangents_gets_them_generated);
    PF_RUN(mirrored_uv_charts_keep_a_frame_each_side_of_the_seam);
    PF_RUN(webp_extension_source_is_preferred);
    PF_RUN(untextured_scene_has_no_corners);
    return pf_test_finish();
}
