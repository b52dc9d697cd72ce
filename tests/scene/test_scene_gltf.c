/* glTF features, one small generated scene each, and animation sampling. */
#include "pf_scene.h"
#include "pf_test.h"
#include "scene_test_util.h"

#include <cjson/cJSON.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define QUAD_NODE_MESH "{\"mesh\":0}"

/* Vertex c (0..2) of triangle t at time. */
static void eval_vertex(const pf_scene *scene, double time, uint32_t t, int c, float out[3])
{
    pf_scene_frame frame;
    pf_error err;
    out[0] = out[1] = out[2] = NAN;
    PF_CHECK_OK(pf_scene_eval(scene, time, &frame, &err), &err);
    if (t < frame.triangle_count)
        memcpy(out, frame.vertices[3 * t + c], 3 * sizeof(float));
    pf_scene_frame_free(&frame);
}

PF_TEST(static_quad_basics)
{
    char path[512];
    st_gltf spec = {.name = "quad", .nodes = "[" QUAD_NODE_MESH "]"};
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->triangle_count == 2);
    PF_CHECK(info->node_count == 1 && info->mesh_count == 1);
    PF_CHECK(info->frame_count == 1);
    PF_CHECK_NEAR(info->fps, 24, 0);
    PF_CHECK(info->has_camera == 0);
    PF_CHECK(!info->geometry_animated && !info->lights_animated && !info->camera_animated);
    pf_scene_frame frame;
    pf_error err;
    PF_CHECK_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_CHECK(frame.triangle_count == 2);
    st_check_vec3(frame.vertices[0], 0, 0, 0, 0);
    st_check_vec3(frame.vertices[1], 1, 0, 0, 0);
    st_check_vec3(frame.vertices[2], 1, 1, 0, 0);
    st_check_vec3(frame.vertices[5], 0, 1, 0, 0);
    PF_CHECK(frame.vertices[1][3] == 0.0f);
    st_check_vec3(frame.normals[4], 0, 0, 1, 1e-6);
    st_check_vec3(frame.bounds_min, 0, 0, 0, 0);
    st_check_vec3(frame.bounds_max, 1, 1, 0, 0);
    PF_CHECK(frame.triangle_node[1] == 0);
    /* No material in the file: the documented grey default. */
    PF_CHECK(frame.material_count == 1);
    PF_CHECK(frame.materials[frame.triangle_material[0]].kind == PF_MATERIAL_LAMBERT);
    PF_CHECK_NEAR(frame.materials[frame.triangle_material[0]].albedo[1], 0.8, 1e-6);
    /* Default camera: looks down -Z at the quad from in front of it, which fits the fov. */
    st_check_vec3(frame.camera.forward, 0, 0, -1, 1e-6);
    st_check_vec3(frame.camera.up, 0, 1, 0, 1e-6);
    st_check_vec3(frame.camera.right, 1, 0, 0, 1e-6);
    PF_CHECK_NEAR(frame.camera.position[0], 0.5, 1e-6);
    PF_CHECK_NEAR(frame.camera.position[1], 0.5, 1e-6);
    float distance = frame.camera.position[2];
    PF_CHECK(distance > 0 && tanf(frame.camera.yfov / 2) * distance >= 0.5f);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* KHR_mesh_quantization (what gltfpack -cc writes): positions as SHORT under a node scale that
 * dequantizes them, normals as normalized BYTE, texture coordinates as normalized UNSIGNED
 * SHORT, indices as UNSIGNED_BYTE, vertex attributes at 4-byte strides as the spec has
 * them: the frame holds the unit quad in floats. Without the extension listed, the file
 * still says it needs it, and loads the same. */
PF_TEST(quantized_mesh_loads_as_its_floats)
{
    unsigned char bin[72] = {0};
    const int16_t positions[4][4] = {{0, 0, 0, 0}, {100, 0, 0, 0}, {100, 100, 0, 0},
                                     {0, 100, 0, 0}};
    const int8_t normals[4][4] = {{0, 0, 127, 0}, {0, 0, 127, 0}, {0, 0, 127, 0},
                                  {0, 0, 127, 0}};
    const uint16_t uvs[4][2] = {{0, 65535}, {65535, 65535}, {65535, 0}, {0, 0}};
    const uint8_t indices[6] = {0, 1, 2, 0, 2, 3};
    memcpy(bin, positions, 32);
    memcpy(bin + 32, normals, 16);
    memcpy(bin + 48, uvs, 16);
    memcpy(bin + 64, indices, 6);
    char path[512], bin_path[512];
    PF_REQUIRE(st_write(st_path(bin_path, sizeof bin_path, "quantized.bin"), bin, sizeof bin) ==
               0);
    const char *json =
        "{\"asset\":{\"version\":\"2.0\"},\"extensionsUsed\":[\"KHR_mesh_quantization\"],"
        "\"extensionsRequired\":[\"KHR_mesh_quantization\"],\"scene\":0,"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"scale\":[0.01,0.01,0.01]}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,"
        "\"TEXCOORD_0\":2},\"indices\":3}]}],"
        "\"buffers\":[{\"uri\":\"quantized.bin\",\"byteLength\":72}],"
        "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":32,\"byteStride\":8},"
        "{\"buffer\":0,\"byteOffset\":32,\"byteLength\":16,\"byteStride\":4},"
        "{\"buffer\":0,\"byteOffset\":48,\"byteLength\":16,\"byteStride\":4},"
        "{\"buffer\":0,\"byteOffset\":64,\"byteLength\":6}],"
        "\"accessors\":[{\"bufferView\":0,\"componentType\":5122,\"count\":4,"
        "\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[100,100,0]},"
        "{\"bufferView\":1,\"componentType\":5120,\"normalized\":true,\"count\":4,"
        "\"type\":\"VEC3\"},"
        "{\"bufferView\":2,\"componentType\":5123,\"normalized\":true,\"count\":4,"
        "\"type\":\"VEC2\"},"
        "{\"bufferView\":3,\"componentType\":5121,\"count\":6,\"type\":\"SCALAR\"}]}";
    PF_REQUIRE(st_write_text(st_path(path, sizeof path, "quantized.gltf"), json) == 0);
    pf_scene *scene = st_load_ok(path);
    PF_REQUIRE(scene);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_CHECK(frame.triangle_count == 2);
    st_check_vec3(frame.vertices[0], 0, 0, 0, 1e-6);
    st_check_vec3(frame.vertices[1], 1, 0, 0, 1e-6);
    st_check_vec3(frame.vertices[2], 1, 1, 0, 1e-6);
    st_check_vec3(frame.vertices[5], 0, 1, 0, 1e-6);
    st_check_vec3(frame.normals[4], 0, 0, 1, 1e-6);
    st_check_vec3(frame.bounds_max, 1, 1, 0, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* Runs draco_transcoder (Debian's draco, which ./bootstrap.sh installs) on in, writing out
 * with positions quantized to `bits`; 0 on success. */
static int draco_transcode(const char *in, const char *out, int bits)
{
    char command[1200];
    snprintf(command, sizeof command, "draco_transcoder -i '%s' -o '%s' -qp %d > /dev/null 2>&1",
             in, out, bits);
    return system(command);
}

/* Whether corner c of triangle t of frame a is a corner of triangle u of frame b: position
 * within tolerance, normal within 0.01. */
static int corner_in(const pf_scene_frame *a, uint32_t t, uint32_t c, const pf_scene_frame *b,
                     uint32_t u, float tolerance)
{
    for (uint32_t d = 0; d < 3; d++) {
        const float *p = a->vertices[3 * t + c], *q = b->vertices[3 * u + d];
        const float *n = a->normals[3 * t + c], *m = b->normals[3 * u + d];
        int same = 1;
        for (int k = 0; k < 3; k++)
            same &= fabsf(p[k] - q[k]) < tolerance && fabsf(n[k] - m[k]) < 1e-2f;
        if (same)
            return 1;
    }
    return 0;
}

/* Every triangle of plain's frame 0 is among compressed's (corner positions within
 * tolerance): how many are not. */
static uint32_t triangles_missing(pf_scene *plain, pf_scene *compressed, float tolerance)
{
    pf_scene_frame a, b;
    pf_error err;
    if (pf_scene_eval(plain, 0.0, &a, &err) != PF_OK)
        return UINT32_MAX;
    if (pf_scene_eval(compressed, 0.0, &b, &err) != PF_OK) {
        pf_scene_frame_free(&a);
        return UINT32_MAX;
    }
    uint32_t missing = a.triangle_count == b.triangle_count ? 0 : UINT32_MAX;
    for (uint32_t t = 0; missing != UINT32_MAX && t < a.triangle_count; t++) {
        int found = 0;
        for (uint32_t u = 0; !found && u < b.triangle_count; u++)
            found = corner_in(&a, t, 0, &b, u, tolerance) &&
                    corner_in(&a, t, 1, &b, u, tolerance) && corner_in(&a, t, 2, &b, u, tolerance);
        missing += !found;
    }
    pf_scene_frame_free(&a);
    pf_scene_frame_free(&b);
    return missing;
}

/* The test meshes of the compressed files: two primitives, the quad and the quad moved up 1
 * and turned about x (written to draco_source.gltf and .bin). */
static const char *two_quads(char *path, size_t size)
{
    st_gltf spec = {.name = "draco_source",
                    .nodes = "[{\"mesh\":0},{\"mesh\":1,\"translation\":[0,0,1],"
                             "\"rotation\":[0.7071068,0,0,0.7071068]}]",
                    .scenes = "[{\"nodes\":[0,1]}]",
                    .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,"
                              "\"NORMAL\":1},\"indices\":2}]},{\"primitives\":[{"
                              "\"attributes\":{\"POSITION\":0,\"NORMAL\":1},"
                              "\"indices\":2}]}]"};
    return st_write_gltf(&spec, path, size);
}

/* EXT_meshopt_compression: the two quads packed by gltfpack -cc (meshoptimizer's vertex and
 * index codecs, octahedral normals, quantized positions) load as the plain file does, every
 * triangle matched within the quantization; a stream of zeros is refused, naming the view. */
PF_TEST(meshopt_compressed_buffers_load_as_uncompressed)
{
    char path[512], packed[512], command[1200];
    two_quads(path, sizeof path);
    st_path(packed, sizeof packed, "meshopt.gltf");
    snprintf(command, sizeof command, "gltfpack -i '%s' -o '%s' -cc > /dev/null 2>&1", path,
             packed);
    PF_REQUIRE_MSG(system(command) == 0, "gltfpack (Debian's gltfpack package) failed or is "
                                         "missing; ./bootstrap.sh test installs it");
    pf_scene *plain = st_load_ok(path), *scene = st_load_ok(packed);
    PF_REQUIRE(plain && scene);
    PF_CHECK(triangles_missing(plain, scene, 5e-4f) == 0);
    pf_scene_destroy(plain);
    pf_scene_destroy(scene);
    /* Its buffer of streams, zeroed. */
    char bin[512];
    st_path(bin, sizeof bin, "meshopt.bin");
    FILE *f = fopen(bin, "r+b");
    PF_REQUIRE(f);
    fseek(f, 0, SEEK_END);
    long length = ftell(f);
    fseek(f, 0, SEEK_SET);
    for (long k = 0; k < length; k++)
        fputc(0, f);
    fclose(f);
    st_expect_error(packed, PF_ERR_FORMAT, "EXT_meshopt_compression", "does not decode");
}

/* KHR_draco_mesh_compression: a mesh of two primitives (the quad, and the quad moved up 1 and
 * turned about x) compressed by Draco's own transcoder loads as the uncompressed file does:
 * the same triangles (Draco reorders faces and vertices, so each triangle is matched as a
 * set of corners among the other file's) within the 14-bit quantization of its positions,
 * the same normals; the file requires the extension, as Blender's exporter writes it. A
 * stream cut short is refused, naming the extension and the primitive. */
PF_TEST(draco_compressed_mesh_loads_as_uncompressed)
{
    char path[512], compressed[512];
    two_quads(path, sizeof path);
    st_path(compressed, sizeof compressed, "draco.gltf");
    PF_REQUIRE_MSG(draco_transcode(path, compressed, 14) == 0,
                   "draco_transcoder (Debian's draco package) failed or is missing; "
                   "./bootstrap.sh test installs it");
    pf_scene *plain = st_load_ok(path), *scene = st_load_ok(compressed);
    PF_REQUIRE(plain && scene);
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 4);
    PF_CHECK(triangles_missing(plain, scene, 2e-4f) == 0);
    pf_scene_destroy(plain);
    pf_scene_destroy(scene);

    /* The same file with its stream cut to 8 bytes. */
    char bin[512];
    PF_REQUIRE(st_write(st_path(bin, sizeof bin, "draco.bin"), "DRACO\2\2\1", 8) == 0);
    char *json = NULL;
    FILE *f = fopen(compressed, "rb");
    PF_REQUIRE(f);
    fseek(f, 0, SEEK_END);
    long length = ftell(f);
    fseek(f, 0, SEEK_SET);
    json = calloc((size_t)length + 1, 1);
    PF_REQUIRE(json && fread(json, 1, (size_t)length, f) == (size_t)length);
    fclose(f);
    cJSON *root = cJSON_Parse(json);
    free(json);
    PF_REQUIRE(root);
    /* Every bufferView of the stream and the buffer now 8 bytes long. */
    cJSON *view;
    cJSON_ArrayForEach(view, cJSON_GetObjectItem(root, "bufferViews"))
    {
        cJSON_ReplaceItemInObject(view, "byteOffset", cJSON_CreateNumber(0));
        cJSON_ReplaceItemInObject(view, "byteLength", cJSON_CreateNumber(8));
    }
    cJSON_ReplaceItemInObject(cJSON_GetArrayItem(cJSON_GetObjectItem(root, "buffers"), 0),
                              "byteLength", cJSON_CreateNumber(8));
    char *text = cJSON_PrintUnformatted(root);
    cJSON_Delete(root);
    PF_REQUIRE(text && st_write_text(compressed, text) == 0);
    free(text);
    st_expect_error(compressed, PF_ERR_FORMAT, "KHR_draco_mesh_compression", "not a Draco mesh");
}

PF_TEST(hierarchy_trs_and_matrix)
{
    /* Parent: T (10,0,0), R 90° about Z, S 2; child: matrix translating (0,1,0).
     * Quad vertex (1,0,0) → child (1,1,0) → S (2,2,0) → Rz (-2,2,0) → T (8,2,0). */
    char path[512];
    st_gltf spec = {
        .name = "hierarchy",
        .nodes = "[{\"children\":[1],\"translation\":[10,0,0],"
                 "\"rotation\":[0,0,0.70710678,0.70710678],\"scale\":[2,2,2]},"
                 "{\"mesh\":0,\"matrix\":[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,0,1]},"
                 "{\"mesh\":0,\"scale\":[-1,1,1],\"translation\":[0,0,-5]}]",
        .scenes = "[{\"nodes\":[0,2]}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 4);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    st_check_vec3(frame.vertices[0], 10 - 2, 0, 0, 1e-5); /* (0,0,0) → child (0,1,0) → (8,0,0) */
    st_check_vec3(frame.vertices[1], 8, 2, 0, 1e-5);
    st_check_vec3(frame.normals[1], 0, 0, 1, 1e-5);
    PF_CHECK(frame.triangle_node[0] == 1 && frame.triangle_node[2] == 2);
    /* Mirrored node (scale -1 in x): winding is swapped so the face normal from
     * the vertex order still agrees with the shading normal (+Z). */
    const float *v0 = frame.vertices[6], *v1 = frame.vertices[7], *v2 = frame.vertices[8];
    float e1[3] = {v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]};
    float e2[3] = {v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]};
    float face_z = e1[0] * e2[1] - e1[1] * e2[0];
    PF_CHECK(face_z > 0);
    st_check_vec3(frame.normals[6], 0, 0, 1, 1e-5);
    st_check_vec3(frame.vertices[6], 0, 0, -5, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(lights_converted)
{
    char path[512];
    st_gltf spec = {
        .name = "lights",
        .nodes = "[{\"mesh\":0},"
                 "{\"translation\":[1,2,3],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
                 "{\"translation\":[0,4,0],\"rotation\":[-0.70710678,0,0,0.70710678],"
                 "\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},"
                 "{\"rotation\":[-0.70710678,0,0,0.70710678],"
                 "\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}}]",
        .scenes = "[{\"nodes\":[0,1,2,3]}]",
        .extensions = "{\"KHR_lights_punctual\":{\"lights\":["
                      /* 8 W/sr in candela (× 683 lm/W), as Blender's exporter writes it. */
                      "{\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":5464,"
                      "\"range\":5},"
                      /* Written radiometric: taken as it is. */
                      "{\"type\":\"spot\",\"intensity\":3,\"spot\":{\"innerConeAngle\":0.2,"
                      "\"outerConeAngle\":0.5},"
                      "\"extras\":{\"photonfarm\":{\"intensityUnits\":\"W/sr\"}}},"
                      /* 2 W/m² in lux; "lux" said outright is the default. */
                      "{\"type\":\"directional\",\"color\":[0.5,0.5,1],\"intensity\":1366,"
                      "\"extras\":{\"photonfarm\":{\"intensityUnits\":\"lux\"}}}]}}",
        .extensions_used = "[\"KHR_lights_punctual\"]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->light_count == 3);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_REQUIRE(frame.light_count == 3);
    const pf_light *point = &frame.lights[0], *spot = &frame.lights[1],
                   *directional = &frame.lights[2];
    PF_CHECK(point->kind == PF_LIGHT_POINT);
    st_check_vec3(point->position, 1, 2, 3, 1e-6);
    st_check_vec3(point->intensity, 8, 4, 2, 1e-5);
    PF_CHECK_NEAR(point->range, 5, 0);
    PF_CHECK(spot->kind == PF_LIGHT_SPOT);
    st_check_vec3(spot->position, 0, 4, 0, 1e-6);
    st_check_vec3(spot->direction, 0, -1, 0, 1e-6); /* node -Z turned -90° about X */
    st_check_vec3(spot->intensity, 3, 3, 3, 1e-6);
    PF_CHECK_NEAR(spot->cos_inner_cone, cos(0.2), 1e-6);
    PF_CHECK_NEAR(spot->cos_outer_cone, cos(0.5), 1e-6);
    PF_CHECK_NEAR(spot->range, 0, 0);
    PF_CHECK(directional->kind == PF_LIGHT_DIRECTIONAL);
    st_check_vec3(directional->direction, 0, -1, 0, 1e-6);
    st_check_vec3(directional->intensity, 1, 1, 2, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* KHR_materials_volume: the Beer-Lambert coefficient -ln(attenuationColor) /
 * attenuationDistance where thicknessFactor makes the mesh a volume, none where
 * it is thin-walled (thicknessFactor 0, the default). */
PF_TEST(volume_absorption)
{
    char path[512];
    st_gltf spec = {
        .name = "volume",
        .nodes = "[" QUAD_NODE_MESH "]",
        .materials = "[{\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
                     "\"KHR_materials_volume\":{\"thicknessFactor\":0.1,"
                     "\"attenuationColor\":[0.5,1,0.25],\"attenuationDistance\":2}}}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    st_check_vec3(frame.materials[frame.triangle_material[0]].absorption, log(2.0) / 2, 0,
               log(4.0) / 2, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);

    spec.name = "thin";
    spec.materials = "[{\"extensions\":{\"KHR_materials_volume\":{"
                     "\"attenuationColor\":[0.5,0.5,0.5],\"attenuationDistance\":2}}}]";
    scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    st_check_vec3(frame.materials[frame.triangle_material[0]].absorption, 0, 0, 0, 0);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* Writes the quad with `materials` (a JSON array) as <name>.gltf, loads it and evaluates its
 * frame 0: the quad's material, or NULL after a failed check. The caller frees the frame and
 * the scene (quad_material_free). */
static const pf_material *quad_material(const char *name, const char *materials,
                                        pf_scene **scene, pf_scene_frame *frame)
{
    char path[512];
    st_gltf spec = {.name = name, .nodes = "[" QUAD_NODE_MESH "]", .materials = materials};
    *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    pf_error err;
    if (!*scene)
        return NULL;
    if (pf_scene_eval(*scene, 0.0, frame, &err) != PF_OK) {
        PF_CHECK_MSG(0, "%s: %s", name, err.message);
        pf_scene_destroy(*scene);
        *scene = NULL;
        return NULL;
    }
    return &frame->materials[frame->triangle_material[0]];
}

static void quad_material_free(pf_scene *scene, pf_scene_frame *frame)
{
    pf_scene_frame_free(frame);
    pf_scene_destroy(scene);
}

/* KHR_materials_clearcoat: its factors (0 without the extension, as the spec's defaults). */
PF_TEST(clearcoat_factors)
{
    pf_scene *scene;
    pf_scene_frame frame;
    const pf_material *m =
        quad_material("clearcoat",
                      "[{\"extensions\":{\"KHR_materials_clearcoat\":{\"clearcoatFactor\":0.75,"
                      "\"clearcoatRoughnessFactor\":0.125}}}]",
                      &scene, &frame);
    PF_REQUIRE(m);
    PF_CHECK(m->clearcoat == 0.75f && m->clearcoat_roughness == 0.125f);
    PF_CHECK(m->clearcoat_texture == PF_NO_TEXTURE &&
             m->clearcoat_roughness_texture == PF_NO_TEXTURE);
    PF_CHECK((pf_scene_frame_surface_features(&frame) & PF_SURFACE_NO_CLEARCOAT) == 0);
    quad_material_free(scene, &frame);

    m = quad_material("no_clearcoat", "[{\"extensions\":{\"KHR_materials_clearcoat\":{}}}]",
                      &scene, &frame);
    PF_REQUIRE(m);
    PF_CHECK(m->clearcoat == 0.0f && m->clearcoat_roughness == 0.0f);
    PF_CHECK((pf_scene_frame_surface_features(&frame) & PF_SURFACE_NO_CLEARCOAT) != 0);
    quad_material_free(scene, &frame);
}

/* KHR_materials_sheen: its factors (none without the extension: the frame lacks a sheen);
 * factors outside [0, 1] are format errors naming the field. */
PF_TEST(sheen_factors)
{
    pf_scene *scene;
    pf_scene_frame frame;
    const pf_material *m =
        quad_material("sheen",
                      "[{\"extensions\":{\"KHR_materials_sheen\":{\"sheenColorFactor\":"
                      "[0.5,0.25,1],\"sheenRoughnessFactor\":0.75}}}]",
                      &scene, &frame);
    PF_REQUIRE(m);
    PF_CHECK(m->sheen_color[0] == 0.5f && m->sheen_color[1] == 0.25f &&
             m->sheen_color[2] == 1.0f && m->sheen_roughness == 0.75f);
    PF_CHECK(m->sheen_color_texture == PF_NO_TEXTURE &&
             m->sheen_roughness_texture == PF_NO_TEXTURE);
    PF_CHECK((pf_scene_frame_surface_features(&frame) & PF_SURFACE_NO_SHEEN) == 0);
    quad_material_free(scene, &frame);

    m = quad_material("no_sheen", "[{\"extensions\":{\"KHR_materials_sheen\":{}}}]", &scene,
                      &frame);
    PF_REQUIRE(m);
    PF_CHECK(m->sheen_color[0] == 0.0f && m->sheen_roughness == 0.0f);
    PF_CHECK((pf_scene_frame_surface_features(&frame) & PF_SURFACE_NO_SHEEN) != 0);
    quad_material_free(scene, &frame);

    char path[512];
    st_gltf spec = {.name = "sheen_bad",
                    .nodes = "[" QUAD_NODE_MESH "]",
                    .materials = "[{\"extensions\":{\"KHR_materials_sheen\":{"
                                 "\"sheenRoughnessFactor\":1.5}}}]"};
    st_expect_error(st_write_gltf(&spec, path, sizeof path), PF_ERR_FORMAT,
                    "KHR_materials_sheen", "sheenRoughnessFactor 1.5 is outside [0, 1]");
}

/* KHR_materials_unlit: the flag and the base colour, the other lobes zeroed as the spec has
 * them ignored (no emission, metal, transmission, coat or sheen); the frame is alpha-tested
 * (only camera rays see it). A value that is not an object is a format error. */
PF_TEST(unlit_keeps_its_base_colour_only)
{
    pf_scene *scene;
    pf_scene_frame frame;
    const pf_material *m = quad_material(
        "unlit",
        "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.25,0.5,0.75,1],"
        "\"metallicFactor\":1},\"emissiveFactor\":[1,1,1],\"extensions\":{"
        "\"KHR_materials_unlit\":{},\"KHR_materials_transmission\":{"
        "\"transmissionFactor\":1},\"KHR_materials_clearcoat\":{\"clearcoatFactor\":1},"
        "\"KHR_materials_sheen\":{\"sheenColorFactor\":[1,1,1]}}}]",
        &scene, &frame);
    PF_REQUIRE(m);
    PF_CHECK((m->flags & PF_MATERIAL_UNLIT) != 0);
    PF_CHECK(m->albedo[0] == 0.25f && m->albedo[1] == 0.5f && m->albedo[2] == 0.75f);
    PF_CHECK(m->emission[0] == 0.0f && m->metallic == 0.0f && m->transmission == 0.0f &&
             m->clearcoat == 0.0f && m->specular == 0.0f && m->sheen_color[0] == 0.0f);
    PF_CHECK(m->kind == PF_MATERIAL_LAMBERT);
    uint32_t features = pf_scene_frame_surface_features(&frame);
    PF_CHECK((features & PF_SURFACE_ALPHA) != 0);
    /* Nothing emits light into the scene: its emission is the camera's alone. */
    PF_CHECK((features & PF_SURFACE_NO_EMISSION) != 0);
    quad_material_free(scene, &frame);

    char path[512];
    st_gltf spec = {.name = "unlit_bad",
                    .nodes = "[" QUAD_NODE_MESH "]",
                    .materials = "[{\"extensions\":{\"KHR_materials_unlit\":true}}]"};
    st_expect_error(st_write_gltf(&spec, path, sizeof path), PF_ERR_FORMAT, "materials[0]",
                    "KHR_materials_unlit must be an object");
}

/* EXT_mesh_gpu_instancing: the quad drawn once per instance (three TRANSLATIONs, the second
 * instance turned a quarter about z and scaled 2), each under the node's own translation;
 * the node itself draws no quad of its own. Mismatched instance counts are refused. */
PF_TEST(gpu_instancing_draws_the_mesh_once_per_instance)
{
    /* accessors[3]: 3 translations; [4]: 3 rotations; [5]: 3 scales. */
    static const float data[30] = {0, 0, 0, 5, 0, 0, 0, 5, 0,
                                   0, 0, 0, 1, 0, 0, 0.70710678f, 0.70710678f, 0, 0, 0, 1,
                                   1, 1, 1, 2, 2, 2, 1, 1, 1};
    char path[512];
    st_gltf spec = {
        .name = "instanced",
        .nodes = "[{\"mesh\":0,\"translation\":[0,0,1],\"extensions\":{\"EXT_mesh_gpu_instancing\":"
                 "{\"attributes\":{\"TRANSLATION\":3,\"ROTATION\":4,\"SCALE\":5}}}}]",
        .extra = data,
        .extra_floats = 30,
        .extra_accessors = ",{\"bufferView\":3,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                           "{\"bufferView\":3,\"byteOffset\":36,\"componentType\":5126,\"count\":3,"
                           "\"type\":\"VEC4\"},"
                           "{\"bufferView\":3,\"byteOffset\":84,\"componentType\":5126,\"count\":3,"
                           "\"type\":\"VEC3\"}",
        .extensions_used = "[\"EXT_mesh_gpu_instancing\"]",
        .extensions_required = "[\"EXT_mesh_gpu_instancing\"]",
    };
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 6);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_REQUIRE(frame.triangle_count == 6);
    /* Instance 0: the quad at z 1; instance 1: at x 5, turned a quarter (x → y) and
     * doubled, so its corner (1, 0, 0) lands at (5, 2, 1); instance 2: at y 5. */
    st_check_vec3(frame.vertices[0], 0, 0, 1, 1e-6);
    st_check_vec3(frame.vertices[1], 1, 0, 1, 1e-6);
    st_check_vec3(frame.vertices[6], 5, 0, 1, 1e-5);
    st_check_vec3(frame.vertices[7], 5, 2, 1, 1e-5);
    st_check_vec3(frame.vertices[13], 1, 5, 1, 1e-6);
    PF_CHECK(pf_log_warning_count() - warnings_before <= 1); /* the missing camera's */
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);

    spec.name = "instanced_mismatch";
    spec.extra_accessors = ",{\"bufferView\":3,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
                           "{\"bufferView\":3,\"byteOffset\":36,\"componentType\":5126,\"count\":2,"
                           "\"type\":\"VEC4\"},"
                           "{\"bufferView\":3,\"byteOffset\":84,\"componentType\":5126,\"count\":3,"
                           "\"type\":\"VEC3\"}";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "EXT_mesh_gpu_instancing", "instances");
}

PF_TEST(camera_values)
{
    char path[512];
    st_gltf spec = {
        .name = "camera",
        .nodes = "[{\"mesh\":0},{\"camera\":0,\"translation\":[0,1,5]}]",
        .scenes = "[{\"nodes\":[0,1]}]",
        .cameras = "[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.6,"
                   "\"aspectRatio\":1.0,\"znear\":0.05,\"zfar\":50}}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->has_camera == 1);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    const pf_camera *camera = &frame.camera;
    st_check_vec3(camera->position, 0, 1, 5, 1e-6);
    st_check_vec3(camera->forward, 0, 0, -1, 1e-6);
    st_check_vec3(camera->up, 0, 1, 0, 1e-6);
    st_check_vec3(camera->right, 1, 0, 0, 1e-6);
    PF_CHECK_NEAR(camera->yfov, 0.6, 1e-7);
    PF_CHECK_NEAR(camera->aspect, 1.0, 0);
    PF_CHECK_NEAR(camera->znear, 0.05, 1e-7);
    PF_CHECK_NEAR(camera->zfar, 50, 0);
    /* The file says 1:1, the image is 16:9: yfov is kept, the image's aspect wins. */
    float tan_x, tan_y;
    pf_camera_image_plane(camera, 1280, 720, &tan_x, &tan_y);
    PF_CHECK_NEAR(tan_y, tan(0.3), 1e-6);
    PF_CHECK_NEAR(tan_x, tan(0.3) * 16 / 9, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/*
 * KHR_materials_variants: the quad wears material 0 of its own, material 1 in variant "red"
 * and material 2 in "blue"; the variant is chosen by name or index at load, and one the file
 * lacks, or a mapping that names a variant the file lacks, is refused naming it.
 */
#define VARIANT_MATERIALS                                                                     \
    "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1],\"metallicFactor\":0}}," \
    "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.1,0.1,1],\"metallicFactor\":0}},"  \
    "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.1,0.1,0.8,1],\"metallicFactor\":0}}]"
#define VARIANT_MESH(mappings)                                                                  \
    "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,"        \
    "\"material\":0,\"extensions\":{\"KHR_materials_variants\":{\"mappings\":" mappings "}}}]}]"

static void check_variant(const char *path, const char *choice, int32_t index, float red)
{
    pf_scene_load_options options = {.material_variant = choice};
    pf_scene *scene = NULL;
    pf_scene_frame frame;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_scene_load_with(path, &options, &scene, &err), &err);
    PF_CHECK(pf_scene_get_info(scene)->material_variant_count == 2);
    PF_CHECK_MSG(pf_scene_get_info(scene)->material_variant == index, "%s: variant %d",
                 choice ? choice : "none", pf_scene_get_info(scene)->material_variant);
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    for (uint32_t t = 0; t < frame.triangle_count; t++)
        PF_CHECK_MSG(fabsf(frame.materials[frame.triangle_material[t]].albedo[0] - red) < 1e-6f,
                     "%s: triangle %u of red %g", choice ? choice : "none", t,
                     frame.materials[frame.triangle_material[t]].albedo[0]);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(material_variants_dress_the_primitives)
{
    char path[512];
    st_gltf spec = {
        .name = "variants",
        .nodes = "[" QUAD_NODE_MESH "]",
        .materials = VARIANT_MATERIALS,
        .meshes = VARIANT_MESH("[{\"material\":1,\"variants\":[0]},"
                               "{\"material\":2,\"variants\":[1]}]"),
        .extensions = "{\"KHR_materials_variants\":{\"variants\":[{\"name\":\"red\"},"
                      "{\"name\":\"blue\"}]}}",
        .extensions_used = "[\"KHR_materials_variants\"]",
    };
    st_write_gltf(&spec, path, sizeof path);
    uint32_t warnings_before = pf_log_warning_count();
    check_variant(path, NULL, -1, 0.5f); /* baseColorFactor is linear: as written */
    PF_CHECK(pf_log_warning_count() - warnings_before == 1); /* the missing camera only */
    check_variant(path, "blue", 1, 0.1f);
    check_variant(path, "0", 0, 0.8f);
    pf_scene_load_options options = {.material_variant = "green"};
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_CHECK(pf_scene_load_with(path, &options, &scene, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "'green'") && strstr(err.message, "0 'red', 1 'blue'"),
                 "%s", err.message);
    options.material_variant = "2";
    PF_CHECK(pf_scene_load_with(path, &options, &scene, &err) == PF_ERR_INVALID);

    spec.name = "variants_bad";
    spec.meshes = VARIANT_MESH("[{\"material\":1,\"variants\":[0,5]}]");
    st_expect_error(st_write_gltf(&spec, path, sizeof path), PF_ERR_FORMAT,
                    "primitives[0].extensions.KHR_materials_variants.mappings[0]",
                    "variants[1]: not one of the file's 2 variants");
    spec.meshes = VARIANT_MESH("[{\"variants\":[0]}]");
    st_expect_error(st_write_gltf(&spec, path, sizeof path), PF_ERR_FORMAT, "mappings[0]",
                    "material: missing");
}

PF_TEST(materials_mapped)
{
    char path[512];
    const char *primitive = "{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,"
                            "\"material\":%d}";
    char meshes[4096] = "[{\"primitives\":[";
    for (int m = 0; m < 8; m++) {
        char one[256];
        snprintf(one, sizeof one, primitive, m);
        strcat(meshes, one);
        strcat(meshes, ",");
    }
    strcat(meshes, "{\"attributes\":{\"POSITION\":0},\"indices\":2}]}]");
    st_gltf spec = {
        .name = "materials",
        .nodes = "[" QUAD_NODE_MESH "]",
        .meshes = meshes,
        .materials =
            "[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.2,0.4,0.6,1],\"metallicFactor\":0}},"
            "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.9,0.8,0.7,1],\"roughnessFactor\":0}},"
            "{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":0},"
            "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1},"
            "\"KHR_materials_ior\":{\"ior\":1.33}}},"
            "{\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":1}}},"
            "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.5,0.5,1],\"metallicFactor\":1}},"
            "{},"
            "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.3,0.3,0.3,1],\"metallicFactor\":0}},"
            "{\"emissiveFactor\":[1,0.5,0.25],\"pbrMetallicRoughness\":{\"metallicFactor\":0},"
            "\"doubleSided\":true,"
            "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->triangle_count == 18);
    PF_CHECK(info->material_count == 9); /* 8 from the file + the default */
    PF_CHECK(info->has_specular == 1);
    PF_CHECK(info->has_emissive == 1);
    PF_CHECK(info->emissive_triangle_count == 2);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    PF_REQUIRE(frame.triangle_count == 18 && frame.emissive_triangle_count == 2);
    const pf_material *m[9];
    for (int k = 0; k < 9; k++)
        m[k] = &frame.materials[frame.triangle_material[2 * k]];
    PF_CHECK(m[0]->kind == PF_MATERIAL_LAMBERT);
    st_check_vec3(m[0]->albedo, 0.2f, 0.4f, 0.6f, 1e-6);
    PF_CHECK(m[1]->kind == PF_MATERIAL_MIRROR); /* metallic defaults to 1 */
    st_check_vec3(m[1]->albedo, 0.9f, 0.8f, 0.7f, 1e-6);
    PF_CHECK(m[2]->kind == PF_MATERIAL_GLASS);
    PF_CHECK_NEAR(m[2]->ior, 1.33, 1e-6);
    /* Transmission under glTF's default metallicFactor 1: the metal wins (spec
     * Appendix B mixes by metallic), a rough white metal. */
    PF_CHECK(m[3]->kind == PF_MATERIAL_LAMBERT);
    PF_CHECK(m[3]->metallic == 1 && m[3]->roughness == 1 && m[3]->transmission == 1);
    PF_CHECK_NEAR(m[3]->ior, 1.5, 0);
    PF_CHECK(m[4]->kind == PF_MATERIAL_LAMBERT); /* a rough metal: a glossy lobe */
    PF_CHECK(m[4]->metallic == 1 && m[4]->roughness == 1);
    st_check_vec3(m[4]->albedo, 0.5f, 0.5f, 0.5f, 1e-6);
    PF_CHECK(m[5]->kind == PF_MATERIAL_LAMBERT); /* glTF defaults: white, metallic, rough */
    st_check_vec3(m[5]->albedo, 1, 1, 1, 0);
    /* A dielectric's specular layer is on by default (KHR_materials_specular's 1). */
    PF_CHECK(m[6]->metallic == 0 && m[6]->specular == 1);
    st_check_vec3(m[6]->specular_color, 1, 1, 1, 0);
    /* The grey default for primitives without a material is a pure Lambert. */
    PF_CHECK(m[8]->specular == 0 && m[8]->metallic == 0);
    PF_CHECK(m[6]->kind == PF_MATERIAL_LAMBERT); /* texture ignored, factor kept */
    st_check_vec3(m[6]->albedo, 0.3f, 0.3f, 0.3f, 1e-6);
    st_check_vec3(m[7]->emission, 4, 2, 1, 1e-6);   /* emissiveFactor × strength */
    PF_CHECK(m[7]->flags == PF_MATERIAL_DOUBLE_SIDED && m[0]->flags == 0);
    st_check_vec3(m[0]->emission, 0, 0, 0, 0);
    PF_CHECK(m[8]->kind == PF_MATERIAL_LAMBERT); /* no material: grey default */
    st_check_vec3(m[8]->albedo, 0.8f, 0.8f, 0.8f, 1e-6);
    /* A primitive without NORMAL gets the geometric normal. */
    st_check_vec3(frame.normals[3 * 16], 0, 0, 1, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* The quad under one animated node; accessors[3] = times, [4] = values. */
static pf_scene *animated_quad(const char *name, const float *data, uint32_t floats,
                               uint32_t keys, const char *path_name, const char *type,
                               const char *interpolation, uint32_t values, const char *extras)
{
    static char accessors[1024], animations[512];
    snprintf(accessors, sizeof accessors,
             ",{\"bufferView\":3,\"componentType\":5126,\"count\":%u,\"type\":\"SCALAR\"},"
             "{\"bufferView\":3,\"byteOffset\":%u,\"componentType\":5126,\"count\":%u,"
             "\"type\":\"%s\"}",
             keys, keys * 4, values, type);
    snprintf(animations, sizeof animations,
             "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"%s\"}}],"
             "\"samplers\":[{\"input\":3,\"output\":4,\"interpolation\":\"%s\"}]}]",
             path_name, interpolation);
    char path[512];
    st_gltf spec = {.name = name,
                    .nodes = "[" QUAD_NODE_MESH "]",
                    .extra = data,
                    .extra_floats = floats,
                    .extra_accessors = accessors,
                    .animations = animations,
                    .asset_extras = extras};
    return st_load_ok(st_write_gltf(&spec, path, sizeof path));
}

PF_TEST(linear_translation_and_clamping)
{
    const float data[] = {0, 2, /* values */ 0, 0, 0, 4, 0, 0};
    pf_scene *scene = animated_quad("anim_linear", data, 8, 2, "translation", "VEC3", "LINEAR",
                                    2, NULL);
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->geometry_animated == 1);
    PF_CHECK(info->animation_count == 1);
    PF_CHECK_NEAR(info->duration_seconds, 2, 0);
    PF_CHECK(info->frame_count == 49); /* round(2 s × 24) + 1 */
    PF_CHECK_NEAR(pf_scene_frame_time(scene, 1), 0, 0);
    PF_CHECK_NEAR(pf_scene_frame_time(scene, 25), 1, 1e-12);
    float v[3];
    eval_vertex(scene, 1.0, 0, 0, v);
    st_check_vec3(v, 2, 0, 0, 1e-6);
    eval_vertex(scene, 0.5, 0, 1, v); /* vertex (1,0,0) + (1,0,0) */
    st_check_vec3(v, 2, 0, 0, 1e-6);
    eval_vertex(scene, -3.0, 0, 0, v);
    st_check_vec3(v, 0, 0, 0, 0);
    eval_vertex(scene, 10.0, 0, 0, v);
    st_check_vec3(v, 4, 0, 0, 0);
    pf_scene_destroy(scene);
}

PF_TEST(linear_rotation_slerp)
{
    /* 0° → 90° about Y over 1 s: at 0.5 s vertex (1,0,0) turns 45° to (c, 0, -c). */
    const float c = 0.70710678f;
    const float data[] = {0, 1, /* values */ 0, 0, 0, 1, 0, c, 0, c};
    pf_scene *scene = animated_quad("anim_rotation", data, 10, 2, "rotation", "VEC4", "LINEAR",
                                    2, "{\"fps\":10,\"frames\":11}");
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK_NEAR(info->fps, 10, 0);
    PF_CHECK(info->frame_count == 11);
    float v[3];
    eval_vertex(scene, pf_scene_frame_time(scene, 6), 0, 1, v);
    st_check_vec3(v, c, 0, -c, 1e-5);
    eval_vertex(scene, 1.0, 0, 1, v);
    st_check_vec3(v, 0, 0, -1, 1e-5);
    pf_scene_destroy(scene);
}

PF_TEST(rotation_shortest_path_in_file)
{
    /* The second key is the 90° rotation stored negated: still 45° at midpoint. */
    const float c = 0.70710678f;
    const float data[] = {0, 1, 0, 0, 0, 1, 0, -c, 0, -c};
    pf_scene *scene = animated_quad("anim_short", data, 10, 2, "rotation", "VEC4", "LINEAR", 2,
                                    NULL);
    PF_REQUIRE(scene);
    float v[3];
    eval_vertex(scene, 0.5, 0, 1, v);
    st_check_vec3(v, c, 0, -c, 1e-5);
    pf_scene_destroy(scene);
}

PF_TEST(step_holds_earlier_value)
{
    const float data[] = {0, 1, 0, 0, 0, 5, 0, 0};
    pf_scene *scene = animated_quad("anim_step", data, 8, 2, "translation", "VEC3", "STEP", 2,
                                    NULL);
    PF_REQUIRE(scene);
    float v[3];
    eval_vertex(scene, 0.99, 0, 0, v);
    st_check_vec3(v, 0, 0, 0, 0);
    eval_vertex(scene, 1.0, 0, 0, v);
    st_check_vec3(v, 5, 0, 0, 0);
    pf_scene_destroy(scene);
}

PF_TEST(cubicspline_hermite)
{
    /* Keys at 1 s and 3 s (dt = 2), x: in 0, value 1, out 2 | in -1, value 3, out 0.
     * At 1.5 s, s = 0.25: 1.96875 (see test_scene_math). y has tangents too:
     * value 0 → 0 with out 1, in 1: 0.140625·2·1 + (-0.046875)·2·1 = 0.1875. */
    const float data[] = {1, 3,
                          /* key 0: in, value, out */ 0, 0, 0, 1, 0, 0, 2, 1, 0,
                          /* key 1 */ -1, 1, 0, 3, 0, 0, 0, 0, 0};
    pf_scene *scene = animated_quad("anim_cubic", data, 20, 2, "translation", "VEC3",
                                    "CUBICSPLINE", 6, NULL);
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->frame_count == 73); /* round(3 × 24) + 1 */
    float v[3];
    eval_vertex(scene, 1.5, 0, 0, v);
    st_check_vec3(v, 1.96875f, 0.1875f, 0, 1e-5);
    eval_vertex(scene, 0.0, 0, 0, v); /* before the first key: its value */
    st_check_vec3(v, 1, 0, 0, 0);
    eval_vertex(scene, 3.5, 0, 0, v);
    st_check_vec3(v, 3, 0, 0, 0);
    pf_scene_destroy(scene);
}

PF_TEST(glb_and_data_uri)
{
    const char *lights = "[{\"mesh\":0,\"translation\":[0,0,2]}]";
    char path[512];
    st_gltf spec = {.name = "binary", .nodes = lights, .glb = 1};
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 2);
    float v[3];
    eval_vertex(scene, 0, 1, 1, v); /* triangle 1 = (0, 2, 3): vertex 2 = (1,1,0) */
    st_check_vec3(v, 1, 1, 2, 0);
    pf_scene_destroy(scene);

    st_gltf embedded = {.name = "embedded", .nodes = lights, .data_uri = 1};
    scene = st_load_ok(st_write_gltf(&embedded, path, sizeof path));
    PF_REQUIRE(scene);
    eval_vertex(scene, 0, 1, 2, v);
    st_check_vec3(v, 0, 1, 2, 0);
    pf_scene_destroy(scene);
}

PF_TEST(degenerate_triangles_kept_and_modes)
{
    /* Strip over 4 vertices → 2 triangles, both facing +Z; a zero-area fan
     * triangle (0,0,0) repeated is kept. accessors[3]: u16 indices in the extra view. */
    const uint16_t strip[4] = {0, 1, 3, 2};
    const uint16_t degenerate[4] = {0, 0, 0, 0};
    float extra[4];
    memcpy(extra, strip, sizeof strip);
    memcpy(extra + 2, degenerate, sizeof degenerate);
    char path[512];
    st_gltf spec = {
        .name = "modes",
        .nodes = "[" QUAD_NODE_MESH "]",
        .extra = extra,
        .extra_floats = 4,
        .extra_accessors = ",{\"bufferView\":3,\"componentType\":5123,\"count\":4,\"type\":\"SCALAR\"},"
                           "{\"bufferView\":3,\"byteOffset\":8,\"componentType\":5123,\"count\":3,"
                           "\"type\":\"SCALAR\"}",
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":3,\"mode\":5},"
                  "{\"attributes\":{\"POSITION\":0},\"indices\":4},"
                  "{\"attributes\":{\"POSITION\":0},\"mode\":1}]}]",
    };
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_log_warning_count() > warnings_before); /* lines skipped */
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 3);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    for (uint32_t t = 0; t < 2; t++) {
        const float *a = frame.vertices[3 * t], *b = frame.vertices[3 * t + 1],
                    *c = frame.vertices[3 * t + 2];
        float z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        PF_CHECK_NEAR(z, 1, 1e-6); /* unit quad halves: area 0.5, CCW */
    }
    for (int k = 0; k < 3; k++)
        PF_CHECK(isfinite(frame.normals[6 + k][0]) && isfinite(frame.normals[6 + k][2]));
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(unsupported_extension_used_warns_once)
{
    char path[512];
    st_gltf spec = {
        .name = "ext_used",
        .nodes = "[" QUAD_NODE_MESH "]",
        .materials = "[{\"extensions\":{\"KHR_materials_iridescence\":{"
                     "\"iridescenceFactor\":1}},\"pbrMetallicRoughness\":{\"metallicFactor\":0}},"
                     "{\"extensions\":{\"KHR_materials_iridescence\":{"
                     "\"iridescenceFactor\":1}},\"pbrMetallicRoughness\":{\"metallicFactor\":0}}]",
        .extensions_used = "[\"KHR_materials_iridescence\"]",
    };
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    /* One for the extension (listed in extensionsUsed and used by two materials)
     * and one for the missing camera. */
    PF_CHECK(pf_log_warning_count() - warnings_before == 2);
    pf_scene_destroy(scene);
}

PF_TEST(sparse_accessor)
{
    /* accessors[3]: the quad's positions with vertex 2 replaced by (2,2,0);
     * accessors[4]: no bufferView (all zeros) with the same replacement. */
    const uint16_t sparse_index[2] = {2, 0};
    float extra[4] = {0, 2, 2, 0};
    memcpy(extra, sparse_index, sizeof sparse_index);
    char path[512];
    st_gltf spec = {
        .name = "sparse",
        .nodes = "[" QUAD_NODE_MESH "]",
        .extra = extra,
        .extra_floats = 4,
        .extra_accessors =
            ",{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
            "\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":3,\"componentType\":5123},"
            "\"values\":{\"bufferView\":3,\"byteOffset\":4}}},"
            "{\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
            "\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":3,\"componentType\":5123},"
            "\"values\":{\"bufferView\":3,\"byteOffset\":4}}}",
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":3},\"indices\":2},"
                  "{\"attributes\":{\"POSITION\":4},\"indices\":2}]}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    PF_REQUIRE(frame.triangle_count == 4);
    st_check_vec3(frame.vertices[1], 1, 0, 0, 0);
    st_check_vec3(frame.vertices[2], 2, 2, 0, 0);
    st_check_vec3(frame.vertices[6], 0, 0, 0, 0);
    st_check_vec3(frame.vertices[8], 2, 2, 0, 0);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* An orthographic camera: parallel rays over xmag × ymag half extents (world units), read
 * without a warning; the larger magnification spans the image's longer side (Blender's
 * importer's reading), the image's aspect the other; its rays start on the view's plane, all
 * along forward. Magnifications of 0 are refused. */
PF_TEST(orthographic_camera_renders_parallel_rays)
{
    char path[512];
    st_gltf spec = {
        .name = "ortho",
        .nodes = "[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,3]}]",
        .scenes = "[{\"nodes\":[0,1]}]",
        .cameras = "[{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":2,\"ymag\":1,"
                   "\"znear\":0.1,\"zfar\":10}}]",
    };
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_log_warning_count() - warnings_before == 0);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    PF_CHECK(frame.camera.orthographic == 1);
    PF_CHECK_NEAR(frame.camera.aspect, 2, 0);
    PF_CHECK_NEAR(frame.camera.ymag, 1, 0);
    PF_CHECK_NEAR(frame.camera.znear, 0.1, 1e-7);
    PF_CHECK_NEAR(frame.camera.position[2], 3, 0);
    float half_x, half_y;
    pf_camera_image_plane(&frame.camera, 300, 100, &half_x, &half_y);
    /* xmag 2 spans the image's longer side; the image's aspect, 3, gives the other. */
    PF_CHECK(half_x == 2.0f && fabsf(half_y - 2.0f / 3.0f) < 1e-6f);
    pf_camera_image_plane(&frame.camera, 100, 300, &half_x, &half_y);
    PF_CHECK(half_y == 2.0f && fabsf(half_x - 2.0f / 3.0f) < 1e-6f);
    pf_camera_image_plane(&frame.camera, 300, 100, &half_x, &half_y);
    double origin[3], direction[3];
    pf_camera_ray(&frame.camera, half_x, half_y, 1.0, -0.75, origin, direction);
    PF_CHECK_NEAR(origin[0], 2, 1e-6);
    PF_CHECK_NEAR(origin[1], -0.5, 1e-6);
    PF_CHECK_NEAR(origin[2], 3, 1e-6);
    PF_CHECK(direction[0] == 0 && direction[1] == 0 && direction[2] == -1);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);

    spec.name = "ortho_zero";
    spec.cameras = "[{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":0,\"ymag\":1,"
                   "\"znear\":0.1,\"zfar\":10}}]";
    st_write_gltf(&spec, path, sizeof path);
    st_expect_error(path, PF_ERR_FORMAT, "cameras[0].orthographic", "xmag");
}

PF_TEST(animated_ancestor_marks_descendants)
{
    /* Node 0 (no mesh) is animated; its child node 1 carries the mesh. */
    const float data[] = {0, 1, 0, 0, 0, 0, 3, 0};
    char path[512];
    st_gltf spec = {
        .name = "anim_parent",
        .nodes = "[{\"children\":[1]},{\"mesh\":0,\"translation\":[1,0,0]}]",
        .extra = data,
        .extra_floats = 8,
        .extra_accessors =
            ",{\"bufferView\":3,\"componentType\":5126,\"count\":2,\"type\":\"SCALAR\"},"
            "{\"bufferView\":3,\"byteOffset\":8,\"componentType\":5126,\"count\":2,"
            "\"type\":\"VEC3\"}",
        .animations = "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":"
                      "\"translation\"}}],\"samplers\":[{\"input\":3,\"output\":4}]}]",
    };
    pf_scene *scene = st_load_ok(st_write_gltf(&spec, path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(pf_scene_get_info(scene)->geometry_animated == 1);
    float v[3];
    eval_vertex(scene, 0.5, 0, 0, v);
    st_check_vec3(v, 1, 1.5f, 0, 1e-6);
    pf_scene_destroy(scene);
}

int main(void)
{
    pf_log_set_level(PF_LOG_ERROR);
    PF_RUN(static_quad_basics);
    PF_RUN(quantized_mesh_loads_as_its_floats);
    PF_RUN(draco_compressed_mesh_loads_as_uncompressed);
    PF_RUN(meshopt_compressed_buffers_load_as_uncompressed);
    PF_RUN(hierarchy_trs_and_matrix);
    PF_RUN(lights_converted);
    PF_RUN(camera_values);
    PF_RUN(volume_absorption);
    PF_RUN(clearcoat_factors);
    PF_RUN(sheen_factors);
    PF_RUN(unlit_keeps_its_base_colour_only);
    PF_RUN(gpu_instancing_draws_the_mesh_once_per_instance);
    PF_RUN(materials_mapped);
    PF_RUN(material_variants_dress_the_primitives);
    PF_RUN(linear_translation_and_clamping);
    PF_RUN(linear_rotation_slerp);
    PF_RUN(rotation_shortest_path_in_file);
    PF_RUN(step_holds_earlier_value);
    PF_RUN(cubicspline_hermite);
    PF_RUN(glb_and_data_uri);
    PF_RUN(degenerate_triangles_kept_and_modes);
    PF_RUN(unsupported_extension_used_warns_once);
    PF_RUN(animated_ancestor_marks_descendants);
    PF_RUN(sparse_accessor);
    PF_RUN(orthographic_camera_renders_parallel_rays);
    return pf_test_finish();
}
