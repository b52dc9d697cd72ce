/* Every bad-file case: a clear status and a message naming the file and the
 * element, never a crash (and, under ASan, never a leak). */
#include "pf_scene.h"
#include "pf_test.h"
#include "scene_test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define QUAD_NODE "[{\"mesh\":0}]"
/* GLB header (12) + JSON chunk header (8) + a little of the JSON. */
#define GLB_HEADERS_BYTES 40

static unsigned char *read_all(const char *path, size_t *size)
{
    FILE *file = fopen(path, "rb");
    if (!file)
        return NULL;
    fseek(file, 0, SEEK_END);
    *size = (size_t)ftell(file);
    fseek(file, 0, SEEK_SET);
    unsigned char *data = malloc(*size + 1);
    if (fread(data, 1, *size, file) != *size)
        *size = 0;
    fclose(file);
    return data;
}

static void put_u32(unsigned char *at, uint32_t value)
{
    for (int k = 0; k < 4; k++)
        at[k] = (unsigned char)(value >> (8 * k));
}

PF_TEST(missing_file)
{
    char path[512];
    st_expect_error(st_path(path, sizeof path, "does-not-exist.gltf"), PF_ERR_IO, "cannot open",
                    NULL);
    st_expect_error(st_path(path, sizeof path, "does-not-exist.obj"), PF_ERR_IO, "cannot open",
                    NULL);
}

PF_TEST(unknown_extension)
{
    char path[512];
    st_write_text(st_path(path, sizeof path, "scene.fbx"), "whatever");
    st_expect_error(path, PF_ERR_UNSUPPORTED, "extension", NULL);
}

PF_TEST(empty_and_truncated_json)
{
    char path[512], truncated[512];
    st_write_text(st_path(path, sizeof path, "empty.gltf"), "");
    st_expect_error(path, PF_ERR_FORMAT, "empty", NULL);

    st_gltf spec = {.name = "whole", .nodes = QUAD_NODE};
    size_t size;
    unsigned char *whole = read_all(st_write_gltf(&spec, path, sizeof path), &size);
    PF_REQUIRE(whole);
    st_write(st_path(truncated, sizeof truncated, "halfway.gltf"), whole, size / 2);
    st_expect_error(truncated, PF_ERR_FORMAT, "invalid JSON at byte", "(truncated?)");
    free(whole);

    st_write_text(path, "{\"asset\":{\"version\":\"2.0\"},\n\"nodes\":[{]}");
    st_expect_error(path, PF_ERR_FORMAT, "line 2", NULL);
}

PF_TEST(wrong_type)
{
    char path[512];
    static const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13};
    st_write(st_path(path, sizeof path, "image.gltf"), png, sizeof png);
    st_expect_error(path, PF_ERR_FORMAT, "PNG", NULL);
    st_write_text(st_path(path, sizeof path, "notes.gltf"), "These are my notes.\n");
    st_expect_error(path, PF_ERR_FORMAT, "invalid JSON", NULL);
    st_write_text(st_path(path, sizeof path, "other.gltf"), "{\"name\":\"not gltf\"}");
    st_expect_error(path, PF_ERR_FORMAT, "asset.version", NULL);
    st_write_text(st_path(path, sizeof path, "old.gltf"), "{\"asset\":{\"version\":\"1.0\"}}");
    st_expect_error(path, PF_ERR_UNSUPPORTED, "asset.version", NULL);
    st_write_text(st_path(path, sizeof path, "text.glb"), "{\"asset\":{\"version\":\"2.0\"}}");
    st_expect_error(path, PF_ERR_FORMAT, "glb header", "magic");
    st_write_text(st_path(path, sizeof path, "notes.obj"), "v 0 0 0\nv 1 0 0\n\x01\x02");
    st_write(path, "v 0 0 0\n\0\0binary", 17);
    st_expect_error(path, PF_ERR_FORMAT, "binary", NULL);
}

PF_TEST(buffer_problems)
{
    char path[512], bin[512];
    st_gltf spec = {.name = "shortbin", .nodes = QUAD_NODE};
    st_write_gltf(&spec, path, sizeof path);
    st_write(st_path(bin, sizeof bin, "shortbin.bin"), "0123456789", 10);
    st_expect_error(path, PF_ERR_FORMAT, "buffers[0]", "truncated");

    spec.name = "nobin";
    st_write_gltf(&spec, path, sizeof path);
    unlink(st_path(bin, sizeof bin, "nobin.bin"));
    st_expect_error(path, PF_ERR_IO, "buffers[0]", "nobin.bin");

    /* Hand-written: a bufferView past its buffer, an accessor past its view. */
    size_t size;
    unsigned char *quad = st_quad_buffer(NULL, 0, &size);
    st_write(st_path(bin, sizeof bin, "views.bin"), quad, size);
    free(quad);
    st_write_text(st_path(path, sizeof path, "view_past_buffer.gltf"),
                  "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
                  "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                  "{\"POSITION\":0}}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
                  "\"count\":3,\"type\":\"VEC3\"}],\"bufferViews\":[{\"buffer\":0,"
                  "\"byteOffset\":100,\"byteLength\":36}],\"buffers\":[{\"uri\":\"views.bin\","
                  "\"byteLength\":108}]}");
    st_expect_error(path, PF_ERR_FORMAT, "bufferViews[0]", "runs past buffers[0]");
    st_write_text(st_path(path, sizeof path, "accessor_past_view.gltf"),
                  "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
                  "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                  "{\"POSITION\":0}}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
                  "\"count\":5,\"type\":\"VEC3\"}],\"bufferViews\":[{\"buffer\":0,"
                  "\"byteLength\":48}],\"buffers\":[{\"uri\":\"views.bin\",\"byteLength\":108}]}");
    st_expect_error(path, PF_ERR_FORMAT, "meshes[0].primitives[0].attributes.POSITION",
                    "accessors[0]");
    st_write_text(st_path(path, sizeof path, "stride_past_view.gltf"),
                  "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
                  "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
                  "{\"POSITION\":0}}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
                  "\"count\":3,\"type\":\"VEC3\"}],\"bufferViews\":[{\"buffer\":0,"
                  "\"byteLength\":48,\"byteStride\":24}],\"buffers\":[{\"uri\":\"views.bin\","
                  "\"byteLength\":108}]}");
    st_expect_error(path, PF_ERR_FORMAT, "accessors[0]", "stride 24");
    st_write_text(st_path(path, sizeof path, "bad_base64.gltf"),
                  "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":"
                  "\"data:application/octet-stream;base64,AAA*\",\"byteLength\":3}]}");
    st_expect_error(path, PF_ERR_FORMAT, "buffers[0]", "base64");
}

PF_TEST(glb_container)
{
    char path[512], bad[512];
    st_gltf spec = {.name = "glbbase", .nodes = QUAD_NODE, .glb = 1};
    size_t size;
    unsigned char *glb = read_all(st_write_gltf(&spec, path, sizeof path), &size);
    PF_REQUIRE(glb && size > 40);
    unsigned char *copy = malloc(size);

    memcpy(copy, glb, size);
    copy[0] = 'x';
    st_write(st_path(bad, sizeof bad, "magic.glb"), copy, size);
    st_expect_error(bad, PF_ERR_FORMAT, "glb header", "magic");

    memcpy(copy, glb, size);
    put_u32(copy + 4, 1);
    st_write(st_path(bad, sizeof bad, "version.glb"), copy, size);
    st_expect_error(bad, PF_ERR_UNSUPPORTED, "glb header", "version 1");

    st_write(st_path(bad, sizeof bad, "short.glb"), glb, size - 10);
    st_expect_error(bad, PF_ERR_FORMAT, "glb header", "truncated");

    memcpy(copy, glb, size);
    put_u32(copy + 12, (uint32_t)size); /* JSON chunk longer than the file */
    st_write(st_path(bad, sizeof bad, "chunk.glb"), copy, size);
    st_expect_error(bad, PF_ERR_FORMAT, "glb chunk", "past the end");

    memcpy(copy, glb, size);
    put_u32(copy + 16, 0x12345678u); /* first chunk is not JSON */
    st_write(st_path(bad, sizeof bad, "chunktype.glb"), copy, size);
    st_expect_error(bad, PF_ERR_FORMAT, "glb chunk", "JSON");

    /* A .glb whose binary chunk is missing: header length fixed up. */
    uint32_t json_length = (uint32_t)glb[12] | (uint32_t)glb[13] << 8 | (uint32_t)glb[14] << 16;
    size_t without_bin = 20 + json_length;
    memcpy(copy, glb, without_bin);
    put_u32(copy + 8, (uint32_t)without_bin);
    st_write(st_path(bad, sizeof bad, "nobin.glb"), copy, without_bin);
    st_expect_error(bad, PF_ERR_FORMAT, "buffers[0]", "binary chunk");
    free(copy);
    free(glb);
}

PF_TEST(non_finite_values)
{
    char path[512], bin[512];
    st_gltf spec = {.name = "nanpos", .nodes = QUAD_NODE};
    st_write_gltf(&spec, path, sizeof path);
    size_t size;
    unsigned char *quad = st_quad_buffer(NULL, 0, &size);
    float nan_value = NAN;
    memcpy(quad + 4 * sizeof(float), &nan_value, sizeof nan_value); /* vertex 1, y */
    st_write(st_path(bin, sizeof bin, "nanpos.bin"), quad, size);
    free(quad);
    st_expect_error(path, PF_ERR_FORMAT, "attributes.POSITION", "element 1 component 1 is not finite");

    spec.name = "infnode";
    spec.nodes = "[{\"mesh\":0,\"translation\":[1e999,0,0]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "nodes[0]", "translation");

    const float animation[] = {0, 1, 0, 0, 0, INFINITY, 0, 0};
    spec.name = "infanim";
    spec.nodes = QUAD_NODE;
    spec.extra = animation;
    spec.extra_floats = 8;
    spec.extra_accessors =
        ",{\"bufferView\":3,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\"},"
        "{\"bufferView\":3,\"byteOffset\":8,\"componentType\":5126,\"count\":2,\"type\":\"VEC3\"}";
    spec.animations = "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":"
                      "\"translation\"}}],\"samplers\":[{\"input\":3,\"output\":4}]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "animations[0].samplers[0].output", "not finite");
}

PF_TEST(indices_out_of_range)
{
    char path[512];
    const uint16_t indices[4] = {0, 1, 90, 0};
    float extra[2];
    memcpy(extra, indices, sizeof indices);
    st_gltf spec = {
        .name = "badindex",
        .nodes = QUAD_NODE,
        .extra = extra,
        .extra_floats = 2,
        .extra_accessors = ",{\"bufferView\":3,\"componentType\":5123,\"count\":3,"
                           "\"type\":\"SCALAR\"}",
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":3}]}]",
    };
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "meshes[0].primitives[0].indices",
                    "index 90 (entry 2) out of range (4 vertices)");
    spec.name = "floatindex";
    spec.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":0}]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "meshes[0].primitives[0].indices", "VEC3");
    spec.name = "badref";
    spec.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":7}}]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "meshes[0].primitives[0].attributes", "POSITION");
}

PF_TEST(no_triangles)
{
    char path[512];
    st_gltf spec = {.name = "nomesh", .nodes = "[{\"translation\":[1,2,3]}]"};
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "no triangles", NULL);
    spec.name = "points";
    spec.nodes = QUAD_NODE;
    spec.meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"mode\":0}]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "no triangles", NULL);
}

PF_TEST(no_camera_is_a_warning)
{
    char path[512];
    st_gltf spec = {.name = "nocamera", .nodes = QUAD_NODE};
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = NULL;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_load(st_write_gltf(&spec, path, sizeof path), &scene, &err), &err);
    PF_CHECK(pf_log_warning_count() == warnings_before + 1);
    PF_CHECK(pf_scene_get_info(scene)->has_camera == 0);
    pf_scene_destroy(scene);
}

PF_TEST(required_extension_unsupported)
{
    char path[512];
    st_gltf spec = {.name = "basisu",
                    .nodes = QUAD_NODE,
                    .extensions_used = "[\"KHR_texture_basisu\"]",
                    .extensions_required = "[\"KHR_texture_basisu\"]"};
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_UNSUPPORTED, "extensionsRequired", "KHR_texture_basisu");
    /* The supported ones may be required. */
    spec.name = "required_ok";
    spec.extensions_required = "[\"KHR_lights_punctual\",\"KHR_materials_emissive_strength\","
                               "\"KHR_materials_transmission\",\"KHR_materials_ior\","
                               "\"KHR_materials_clearcoat\",\"KHR_materials_unlit\","
                               "\"KHR_materials_sheen\",\"KHR_mesh_quantization\","
                               "\"KHR_draco_mesh_compression\",\"EXT_meshopt_compression\"]";
    spec.extensions_used = spec.extensions_required;
    pf_scene *scene = NULL;
    pf_error err;
    PF_CHECK_OK(pf_scene_load(st_write_gltf(&spec, path, sizeof path), &scene, &err), &err);
    pf_scene_destroy(scene);
}

PF_TEST(malformed_structure)
{
    char path[512];
    st_gltf spec = {.name = "twoparents",
                    .nodes = "[{\"children\":[2]},{\"children\":[2]},{\"mesh\":0}]",
                    .scenes = "[{\"nodes\":[0,1]}]"};
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "nodes[1]", "already has a parent");

    spec.name = "selfparent";
    spec.nodes = "[{\"mesh\":0,\"children\":[0]}]";
    spec.scenes = NULL;
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "nodes[0]", "children[0]");

    spec.name = "badmesh";
    spec.nodes = "[{\"mesh\":3}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "nodes[0]", "mesh");

    spec.name = "badlight";
    spec.nodes = QUAD_NODE;
    spec.extensions = "{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"area\"}]}}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_lights_punctual.lights[0]", "area");

    /* Radiometric units are "W/sr" for a point light; "W/m2" is a directional's. */
    spec.name = "badlightunits";
    spec.extensions = "{\"KHR_lights_punctual\":{\"lights\":[{\"type\":\"point\","
                      "\"extras\":{\"photonfarm\":{\"intensityUnits\":\"W/m2\"}}}]}}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_lights_punctual.lights[0]", "intensityUnits");

    spec.name = "badvolume";
    spec.extensions = NULL;
    spec.materials = "[{\"extensions\":{\"KHR_materials_volume\":{\"thicknessFactor\":1,"
                     "\"attenuationDistance\":0}}}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_volume", "attenuationDistance");
    spec.materials = "[{\"extensions\":{\"KHR_materials_volume\":{\"thicknessFactor\":1,"
                     "\"attenuationColor\":[2,0,0]}}}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_volume", "attenuationColor");

    spec.name = "badclearcoat";
    spec.materials = "[{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1.5}}}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_clearcoat", "clearcoatFactor");

    spec.name = "baddoublesided";
    spec.extensions = NULL;
    spec.materials = "[{\"doubleSided\":1}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "materials[0]", "doubleSided");
    spec.materials = NULL;

    /* KHR_materials_variants, checked whether a variant is chosen or not. */
    spec.name = "badvariants";
    spec.materials = "[{},{}]";
    spec.extensions = "{\"KHR_materials_variants\":{\"variants\":{\"name\":\"red\"}}}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_variants", "variants");
    spec.extensions = "{\"KHR_materials_variants\":{\"variants\":[{\"title\":\"red\"}]}}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_variants.variants[0]", "name");
    spec.extensions = "{\"KHR_materials_variants\":{\"variants\":[{\"name\":\"red\"}]}}";
    static const struct {
        const char *mappings, *needle;
    } bad_mappings[] = {
        {"[3]", "mappings[0]"},
        {"[{\"material\":5,\"variants\":[0]}]", "material"},
        {"[{\"material\":1,\"variants\":[\"red\"]}]", "not one of the file's 1 variants"},
        {"[{\"material\":1,\"variants\":[0.5]}]", "not one of the file's 1 variants"},
        {"{\"material\":1}", "mappings"},
    };
    for (size_t k = 0; k < sizeof bad_mappings / sizeof *bad_mappings; k++) {
        char meshes[512];
        snprintf(meshes, sizeof meshes,
                 "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},"
                 "\"indices\":2,\"material\":0,\"extensions\":{\"KHR_materials_variants\":"
                 "{\"mappings\":%s}}}]}]",
                 bad_mappings[k].mappings);
        spec.meshes = meshes;
        st_write_gltf(&spec, path, sizeof path);
        st_expect_error(path, PF_ERR_FORMAT, "KHR_materials_variants", bad_mappings[k].needle);
    }
    spec.meshes = NULL;
    spec.materials = NULL;

    spec.name = "badcamera";
    spec.extensions = NULL;
    spec.cameras = "[{\"type\":\"perspective\",\"perspective\":{\"znear\":0.1}}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "cameras[0].perspective", "yfov is missing");

    const float animation[] = {0, 1, 0, 0, 0};
    spec.name = "badsampler";
    spec.cameras = NULL;
    spec.extra = animation;
    spec.extra_floats = 5;
    spec.extra_accessors =
        ",{\"bufferView\":3,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\"},"
        "{\"bufferView\":3,\"byteOffset\":8,\"componentType\":5126,\"count\":1,\"type\":\"VEC3\"}";
    spec.animations = "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":"
                      "\"translation\"}}],\"samplers\":[{\"input\":3,\"output\":4}]}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "animations[0].samplers[0].output", "1 values for 2 keys");

    spec.name = "matrixanim";
    spec.nodes = "[{\"mesh\":0,\"matrix\":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}]";
    spec.extra_accessors =
        ",{\"bufferView\":3,\"componentType\":5126,\"count\":1,\"type\":\"SCALAR\"},"
        "{\"bufferView\":3,\"byteOffset\":4,\"componentType\":5126,\"count\":1,\"type\":\"VEC3\"}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "animations[0].channels[0].target", "matrix");
}

/* Loads path; any status is acceptable but a failure must carry a message and
 * leave *out NULL. Returns 1 if it loaded. */
static int load_any(const char *path)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    pf_status status = pf_scene_load(path, &scene, &err);
    if (status == PF_OK) {
        pf_scene_frame frame;
        PF_CHECK_OK(pf_scene_eval(scene, 0.5, &frame, &err), &err);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
        return 1;
    }
    PF_CHECK(scene == NULL && err.message[0] != 0);
    return 0;
}

PF_TEST(every_truncation_and_corruption)
{
    /* Every prefix of a .glb and of a .gltf, and every single-byte corruption of
     * the .gltf's JSON, is either loaded or refused with a message: never a crash
     * (and no leak under ASan). */
    const float animation[] = {0, 1, 0, 0, 0, 1, 0, 0};
    st_gltf spec = {
        .name = "fuzzbase",
        .nodes = "[{\"mesh\":0,\"children\":[1]},{\"camera\":0}]",
        .cameras = "[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1}}]",
        .extra = animation,
        .extra_floats = 8,
        .extra_accessors =
            ",{\"bufferView\":3,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\"},"
            "{\"bufferView\":3,\"byteOffset\":8,\"componentType\":5126,\"count\":2,"
            "\"type\":\"VEC3\"}",
        .animations = "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":"
                      "\"translation\"}}],\"samplers\":[{\"input\":3,\"output\":4}]}]",
        .glb = 1,
    };
    char path[512], variant[512];
    size_t size;
    unsigned char *glb = read_all(st_write_gltf(&spec, path, sizeof path), &size);
    PF_REQUIRE(glb);
    PF_CHECK(load_any(path));
    st_path(variant, sizeof variant, "fuzz.glb");
    int loaded = 0;
    /* Every cut through the headers, then a sample (the rest is the same check). */
    for (size_t length = 0; length < size; length += length < GLB_HEADERS_BYTES ? 1 : 13) {
        st_write(variant, glb, length);
        loaded += load_any(variant);
    }
    PF_CHECK(loaded == 0); /* the header length always disagrees with a prefix */
    free(glb);

    spec.glb = 0;
    unsigned char *json = read_all(st_write_gltf(&spec, path, sizeof path), &size);
    PF_REQUIRE(json);
    PF_CHECK(load_any(path));
    st_path(variant, sizeof variant, "fuzz.gltf");
    for (size_t length = 0; length < size; length++) {
        st_write(variant, json, length);
        load_any(variant);
    }
    static const char replacements[] = {'9', '-', '"', '}', ']', 'e', '0'};
    for (size_t position = 0; position < size; position++) {
        unsigned char original = json[position];
        json[position] = (unsigned char)replacements[position % sizeof replacements];
        st_write(variant, json, size);
        load_any(variant);
        json[position] = original;
    }
    free(json);
}

/* A one-quad glTF in the directory dir whose buffer is uri; its path into path. */
static const char *quad_with_uri(const char *dir, const char *name, const char *uri, char *path,
                                 size_t size)
{
    char text[2048];
    snprintf(path, size, "%s/%s", dir, name);
    snprintf(text, sizeof text,
             "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
             "\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[{\"attributes\":"
             "{\"POSITION\":0}}]}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,"
             "\"count\":3,\"type\":\"VEC3\"}],\"bufferViews\":[{\"buffer\":0,"
             "\"byteLength\":36}],\"buffers\":[{\"uri\":\"%s\",\"byteLength\":100}]}",
             uri);
    PF_CHECK(st_write_text(path, text) == 0);
    return path;
}

/* Refused, the message naming the URI and never what lies outside (its size: 108 bytes). */
static void expect_confined(const char *path, const char *uri)
{
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_CHECK_MSG(pf_scene_load(path, &scene, &err) == PF_ERR_INVALID, "%s: %s", uri,
                 err.message);
    PF_CHECK_MSG(strstr(err.message, uri) && strstr(err.message, "outside"), "%s: %s", uri,
                 err.message);
    PF_CHECK_MSG(!strstr(err.message, "108"), "%s discloses the outside file: %s", uri,
                 err.message);
    pf_scene_destroy(scene);
}

PF_TEST(referenced_files_stay_inside_the_scene_directory)
{
    char root[512], dir[600], secret[700], link[700], path[800];
    st_path(root, sizeof root, "");
    snprintf(dir, sizeof dir, "%s/confined", root);
    mkdir(dir, 0777);
    /* A valid buffer outside: were it read, the scene would load. */
    size_t size;
    unsigned char *quad = st_quad_buffer(NULL, 0, &size);
    snprintf(secret, sizeof secret, "%s/secret.bin", root);
    PF_REQUIRE(st_write(secret, quad, size) == 0);
    snprintf(path, sizeof path, "%s/inside.bin", dir);
    PF_REQUIRE(st_write(path, quad, size) == 0);
    free(quad);

    expect_confined(quad_with_uri(dir, "up.gltf", "../secret.bin", path, sizeof path),
                    "../secret.bin");
    expect_confined(quad_with_uri(dir, "up_encoded.gltf", "%2e%2e/secret.bin", path,
                                  sizeof path),
                    "%2e%2e/secret.bin");
    expect_confined(quad_with_uri(dir, "deep.gltf", "nowhere/../../secret.bin", path,
                                  sizeof path),
                    "nowhere/../../secret.bin");
    snprintf(link, sizeof link, "%s/link.bin", dir);
    unlink(link);
    PF_REQUIRE(symlink(secret, link) == 0);
    expect_confined(quad_with_uri(dir, "link.gltf", "link.bin", path, sizeof path), "link.bin");
    snprintf(link, sizeof link, "%s/linked-dir", dir);
    unlink(link);
    PF_REQUIRE(symlink(root, link) == 0);
    expect_confined(quad_with_uri(dir, "linkdir.gltf", "linked-dir/secret.bin", path,
                                  sizeof path),
                    "linked-dir/secret.bin");

    /* Inside stays allowed, ".." included; a missing file inside is an I/O error as ever. */
    pf_scene *scene = NULL;
    pf_error err = {0};
    snprintf(link, sizeof link, "%s/sub", dir);
    mkdir(link, 0777);
    quad_with_uri(dir, "inside.gltf", "./sub/../inside.bin", path, sizeof path);
    PF_CHECK_OK(pf_scene_load(path, &scene, &err), &err);
    pf_scene_destroy(scene);
    st_expect_error(quad_with_uri(dir, "typo.gltf", "nodir/inside.bin", path, sizeof path),
                    PF_ERR_IO, "buffers[0]", "nodir/inside.bin");

    /* OBJ material libraries alike. */
    snprintf(path, sizeof path, "%s/secret.mtl", root);
    PF_REQUIRE(st_write_text(path, "newmtl red\nKd 1 0 0\n") == 0);
    snprintf(path, sizeof path, "%s/mtl.obj", dir);
    PF_REQUIRE(st_write_text(path, "mtllib ../secret.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                   "usemtl red\nf 1 2 3\n") == 0);
    scene = NULL;
    PF_CHECK(pf_scene_load(path, &scene, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "../secret.mtl") && strstr(err.message, "outside"), "%s",
                 err.message);
    pf_scene_destroy(scene);

    /* Asked for explicitly (--allow-outside-scene-dir), both load. */
    pf_scene_load_options allow = {.allow_outside_scene_dir = 1};
    scene = NULL;
    PF_CHECK_OK(pf_scene_load_with(path, &allow, &scene, &err), &err);
    PF_CHECK(scene && pf_scene_get_info(scene)->triangle_count == 1);
    pf_scene_destroy(scene);
    scene = NULL;
    quad_with_uri(dir, "up.gltf", "../secret.bin", path, sizeof path);
    PF_CHECK_OK(pf_scene_load_with(path, &allow, &scene, &err), &err);
    pf_scene_destroy(scene);
    scene = NULL;
    PF_CHECK(pf_scene_load_with(path, NULL, &scene, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "--allow-outside-scene-dir") != NULL, "%s", err.message);
    pf_scene_destroy(scene);
}

int main(void)
{
    pf_log_set_level(PF_LOG_ERROR);
    PF_RUN(missing_file);
    PF_RUN(unknown_extension);
    PF_RUN(empty_and_truncated_json);
    PF_RUN(wrong_type);
    PF_RUN(buffer_problems);
    PF_RUN(glb_container);
    PF_RUN(non_finite_values);
    PF_RUN(indices_out_of_range);
    PF_RUN(no_triangles);
    PF_RUN(no_camera_is_a_warning);
    PF_RUN(required_extension_unsupported);
    PF_RUN(malformed_structure);
    PF_RUN(every_truncation_and_corruption);
    PF_RUN(referenced_files_stay_inside_the_scene_directory);
    return pf_test_finish();
}
