/*
 * Skins and morph targets (issue 39): a two-bone skin against the closed form
 * of linear blend skinning, morph targets at weights 0, 0.5 and 1 against
 * base + w·delta (sparse targets, node and mesh weights, LINEAR and
 * CUBICSPLINE weight channels), the skinned node's ignored transform, the two
 * halves of pf_scene_eval, and malformed skins naming their accessor.
 */
#include "pf_scene.h"
#include "pf_test.h"
#include "scene_test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- a two-bone skin ------------------------------------------------------ */

/*
 * The quad (vertices (0,0,0) (1,0,0) (1,1,0) (0,1,0), normal +Z) skinned to two
 * bones: bone0 at the origin, bone1 its child at (0, 0.5, 0), rotated about X by
 * an animation from 0 (t = 0) to 60° (t = 1). Vertices 0 and 1 follow bone0, vertex 2
 * blends 0.25 bone0 + 0.75 bone1 (in JOINTS_0 order 1, 0 to test the order), vertex 3
 * follows bone1. The skinned node sits at (5, 0, 0), which glTF says to ignore.
 * Extra floats: joints (u16 ×16 = 8 floats), weights (16), inverse binds (32),
 * times (2), rotations (8), then TANGENT (0, 1, 0, +1) and COLOR_0 (white) for every
 * vertex (16 each): a colour gives the frame its corners, where the tangents are.
 */
#define SKIN_FLOATS 98
static const char *write_two_bone(const char *name, const uint16_t joints[16],
                                  const float weights[16], char *path, size_t size)
{
    static float extra[SKIN_FLOATS];
    memset(extra, 0, sizeof extra);
    memcpy(extra, joints, 16 * sizeof(uint16_t));
    memcpy(extra + 8, weights, 16 * sizeof(float));
    float *inverse_bind = extra + 24;
    for (int m = 0; m < 2; m++)
        for (int k = 0; k < 4; k++)
            inverse_bind[16 * m + 5 * k] = 1.0f;
    inverse_bind[16 + 13] = -0.5f; /* bone1 bound at y = 0.5 */
    extra[56] = 0.0f;
    extra[57] = 1.0f;
    float half = 0.5f * 60.0f * 3.14159265f / 180.0f;
    float *rotations = extra + 58;
    rotations[3] = 1.0f;
    rotations[4] = sinf(half);
    rotations[7] = cosf(half);
    for (int v = 0; v < 4; v++) {
        float *tangent = extra + 66 + 4 * v, *colour = extra + 82 + 4 * v;
        tangent[1] = tangent[3] = 1.0f;
        colour[0] = colour[1] = colour[2] = colour[3] = 1.0f;
    }
    st_gltf spec = {
        .name = name,
        .extra = extra,
        .extra_floats = SKIN_FLOATS,
        .nodes = "[{\"mesh\":0,\"skin\":0,\"translation\":[5,0,0]},"
                 "{\"children\":[2]},{\"translation\":[0,0.5,0]}]",
        .scenes = "[{\"nodes\":[0,1]}]",
        .meshes = "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,"
                  "\"JOINTS_0\":3,\"WEIGHTS_0\":4,\"TANGENT\":8,\"COLOR_0\":9},\"indices\":2}]}]",
        .skins = "[{\"joints\":[1,2],\"inverseBindMatrices\":5}]",
        .extra_accessors =
            ",{\"bufferView\":3,\"componentType\":5123,\"count\":4,\"type\":\"VEC4\"}"
            ",{\"bufferView\":3,\"byteOffset\":32,\"componentType\":5126,\"count\":4,"
            "\"type\":\"VEC4\"}"
            ",{\"bufferView\":3,\"byteOffset\":96,\"componentType\":5126,\"count\":2,"
            "\"type\":\"MAT4\"}"
            ",{\"bufferView\":3,\"byteOffset\":224,\"componentType\":5126,\"count\":2,"
            "\"type\":\"SCALAR\"}"
            ",{\"bufferView\":3,\"byteOffset\":232,\"componentType\":5126,\"count\":2,"
            "\"type\":\"VEC4\"}"
            ",{\"bufferView\":3,\"byteOffset\":264,\"componentType\":5126,\"count\":4,"
            "\"type\":\"VEC4\"}"
            ",{\"bufferView\":3,\"byteOffset\":328,\"componentType\":5126,\"count\":4,"
            "\"type\":\"VEC4\"}",
        .animations = "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":2,"
                      "\"path\":\"rotation\"}}],"
                      "\"samplers\":[{\"input\":6,\"output\":7}]}]",
    };
    return st_write_gltf(&spec, path, size);
}

static const uint16_t good_joints[16] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
static const float good_weights[16] = {1, 0, 0, 0, 1, 0, 0, 0, 0.75f, 0.25f, 0, 0, 1, 0, 0, 0};

/* Closed form at angle theta: bone1's matrix is a rotation about X through (0, 0.5, 0). */
static void bone1_apply(double theta, const double p[3], double out[3])
{
    double y = p[1] - 0.5, z = p[2];
    out[0] = p[0];
    out[1] = 0.5 + y * cos(theta) - z * sin(theta);
    out[2] = y * sin(theta) + z * cos(theta);
}

static void check_skin_at(const pf_scene *scene, double time, double theta)
{
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, time, &frame, &err), &err);
    PF_REQUIRE(frame.triangle_count == 2);
    /* Triangle 0 is vertices 0 1 2, triangle 1 is 0 2 3. */
    st_check_vec3(frame.vertices[0], 0, 0, 0, 1e-6);
    st_check_vec3(frame.vertices[1], 1, 0, 0, 1e-6);
    st_check_vec3(frame.normals[1], 0, 0, 1, 1e-6);
    /* Vertex 3 rides bone1 rigidly: (0, 0.5 + 0.5 cos, 0.5 sin), normal (0, -sin, cos). */
    st_check_vec3(frame.vertices[5], 0, 0.5 + 0.5 * cos(theta), 0.5 * sin(theta), 1e-5);
    st_check_vec3(frame.normals[5], 0, -sin(theta), cos(theta), 1e-5);
    /* Vertex 2: 0.25 p + 0.75 bone1(p); its normal is the blended matrix's inverse
     * transpose on +Z: with a = 0.25 + 0.75 cos, b = 0.75 sin, (0, -b, a)/|.|. */
    const double p2[3] = {1, 1, 0};
    double moved[3];
    bone1_apply(theta, p2, moved);
    st_check_vec3(frame.vertices[2], 0.25 * 1 + 0.75 * moved[0], 0.25 * 1 + 0.75 * moved[1],
               0.75 * moved[2], 1e-5);
    double a = 0.25 + 0.75 * cos(theta), b = 0.75 * sin(theta), length = sqrt(a * a + b * b);
    st_check_vec3(frame.normals[2], 0, -b / length, a / length, 1e-5);
    st_check_vec3(frame.vertices[4], frame.vertices[2][0], frame.vertices[2][1],
               frame.vertices[2][2], 0);
    /* Tangents (0, 1, 0) turn with the blended matrix's 3×3: vertex 3's to (0, cos, sin),
     * vertex 2's to (0, a, b)/|.|; the handedness stays +1. */
    PF_REQUIRE(frame.corners != NULL);
    const float *tangent3 = frame.corners[(3 * 1 + 2) * PF_CORNER_TEXELS + 2];
    const float *tangent2 = frame.corners[(3 * 0 + 2) * PF_CORNER_TEXELS + 2];
    st_check_vec3(tangent3, 0, cos(theta), sin(theta), 1e-5);
    st_check_vec3(tangent2, 0, a / length, b / length, 1e-5);
    PF_CHECK(tangent3[3] == 1.0f && tangent2[3] == 1.0f);
    pf_scene_frame_free(&frame);
}

PF_TEST(two_bone_skin_matches_linear_blend_skinning)
{
    char path[512];
    pf_scene *scene = st_load_ok(write_two_bone("skin", good_joints, good_weights, path,
                                             sizeof path));
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->skin_count == 1);
    PF_CHECK(info->deformed_node_count == 1);
    PF_CHECK(info->deformed_vertex_count == 4);
    PF_CHECK(info->deformation_animated && info->geometry_animated);
    /* The node's translation (5, 0, 0) is ignored: at rest the quad is where it was bound. */
    check_skin_at(scene, 0.0, 0.0);
    check_skin_at(scene, 1.0, 60.0 * 3.14159265358979 / 180.0);
    /* Halfway the rotation is slerped to 30°. */
    check_skin_at(scene, 0.5, 30.0 * 3.14159265358979 / 180.0);
    pf_scene_destroy(scene);
}

PF_TEST(eval_in_two_halves_equals_eval)
{
    char path[512];
    pf_scene *scene = st_load_ok(write_two_bone("skin_halves", good_joints, good_weights, path,
                                             sizeof path));
    PF_REQUIRE(scene);
    pf_scene_frame whole, halves;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.75, &whole, &err), &err);
    PF_REQUIRE_OK(pf_scene_eval_rigid(scene, 0.75, &halves, &err), &err);
    /* Everything deforms here: the rigid half leaves the box inverted and the vertices 0. */
    PF_CHECK(halves.bounds_min[0] > halves.bounds_max[0]);
    PF_CHECK(halves.vertices[2][1] == 0.0f);
    pf_deform_report report;
    PF_REQUIRE_OK(pf_scene_deform(scene, 0.75, &halves, &report, &err), &err);
    PF_CHECK(report.skinned_meshes == 1 && report.morphed_meshes == 0);
    PF_CHECK(report.vertices == 4);
    PF_CHECK(memcmp(whole.vertices, halves.vertices, 6 * sizeof whole.vertices[0]) == 0);
    PF_CHECK(memcmp(whole.normals, halves.normals, 6 * sizeof whole.normals[0]) == 0);
    PF_CHECK(memcmp(whole.bounds_min, halves.bounds_min, sizeof whole.bounds_min) == 0);
    PF_CHECK(memcmp(whole.bounds_max, halves.bounds_max, sizeof whole.bounds_max) == 0);
    st_check_vec3(whole.bounds_min, 0, 0, 0, 1e-6);
    PF_CHECK(whole.bounds_max[2] > 0.1f);
    pf_scene_frame_free(&whole);
    pf_scene_frame_free(&halves);
    pf_scene_destroy(scene);
}

PF_TEST(unnormalised_weights_are_normalised)
{
    /* Vertex 2 with weights 1.5 and 0.5 (sum 2) blends as 0.75 and 0.25. */
    float weights[16];
    memcpy(weights, good_weights, sizeof weights);
    weights[8] = 1.5f;
    weights[9] = 0.5f;
    char path[512];
    pf_scene *scene = st_load_ok(write_two_bone("skin_sum", good_joints, weights, path,
                                             sizeof path));
    PF_REQUIRE(scene);
    check_skin_at(scene, 1.0, 60.0 * 3.14159265358979 / 180.0);
    pf_scene_destroy(scene);
}

PF_TEST(malformed_skins_name_their_accessor)
{
    char path[512];
    /* A joint index past the skin's two joints, with weight. */
    uint16_t joints[16];
    memcpy(joints, good_joints, sizeof joints);
    joints[12] = 2;
    st_expect_error(write_two_bone("skin_joint", joints, good_weights, path, sizeof path),
                    PF_ERR_FORMAT, "JOINTS_0 (accessors[3])", "joint 2 is outside skins[0]");
    /* A negative weight. */
    float weights[16];
    memcpy(weights, good_weights, sizeof weights);
    weights[9] = -0.25f;
    st_expect_error(write_two_bone("skin_negative", good_joints, weights, path, sizeof path),
                    PF_ERR_FORMAT, "WEIGHTS_0 (accessors[4])", "vertex 2 weight 1 is negative");
    /* A NaN weight. */
    memcpy(weights, good_weights, sizeof weights);
    weights[0] = NAN;
    st_expect_error(write_two_bone("skin_nan", good_joints, weights, path, sizeof path),
                    PF_ERR_FORMAT, "WEIGHTS_0", "not finite");
}

/* ---- morph targets -------------------------------------------------------- */

/*
 * The quad with two targets: target 0 moves vertex 2 by (0, 0, 1) (a dense
 * accessor), target 1 moves vertex 3 by (0, 0, 2) and vertex 0 by (0, 0, -1)
 * (a sparse accessor without a bufferView). Extra floats: target 0 (12), the
 * sparse indices (u16 ×2 = 1 float) and values (6), then the test's animation
 * data from float 19.
 */
#define MORPH_FLOATS 19
static const char *morph_generator; /* asset.generator of the next write_morph, or NULL */
static const char *morph_target0 = ""; /* more attributes of target 0, or "" */
static const char *write_morph(const char *name, const char *mesh_weights,
                               const char *node_extra, const float *animation_data,
                               uint32_t animation_floats, const char *accessors,
                               const char *animations, char *path, size_t size)
{
    static float extra[64];
    memset(extra, 0, sizeof extra);
    extra[2 * 3 + 2] = 1.0f;
    const uint16_t sparse_indices[2] = {3, 0};
    memcpy(extra + 12, sparse_indices, sizeof sparse_indices);
    extra[13 + 2] = 2.0f;
    extra[13 + 5] = -1.0f;
    if (animation_floats)
        memcpy(extra + MORPH_FLOATS, animation_data, animation_floats * sizeof(float));
    static char meshes[512], nodes[256], all_accessors[1024];
    snprintf(meshes, sizeof meshes,
             "[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},\"indices\":2,"
             "\"targets\":[{\"POSITION\":3%s},{\"POSITION\":4}]}]%s%s}]",
             morph_target0,
             mesh_weights ? ",\"weights\":" : "", mesh_weights ? mesh_weights : "");
    snprintf(nodes, sizeof nodes, "[{\"mesh\":0%s}]", node_extra ? node_extra : "");
    snprintf(all_accessors, sizeof all_accessors,
             ",{\"bufferView\":3,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\"}"
             ",{\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
             "\"sparse\":{\"count\":2,\"indices\":{\"bufferView\":3,\"byteOffset\":48,"
             "\"componentType\":5123},\"values\":{\"bufferView\":3,\"byteOffset\":52}}}%s",
             accessors ? accessors : "");
    st_gltf spec = {.name = name,
                    .extra = extra,
                    .extra_floats = MORPH_FLOATS + animation_floats,
                    .nodes = nodes,
                    .meshes = meshes,
                    .extra_accessors = all_accessors,
                    .animations = animations,
                    .generator = morph_generator};
    return st_write_gltf(&spec, path, size);
}

/* The quad's vertex v moved by w0 · target 0 + w1 · target 1 (triangle 0: 0 1 2, 1: 0 2 3). */
static void check_morph(const pf_scene_frame *frame, double w0, double w1, double tolerance)
{
    st_check_vec3(frame->vertices[0], 0, 0, -1 * w1, tolerance);
    st_check_vec3(frame->vertices[1], 1, 0, 0, tolerance);
    st_check_vec3(frame->vertices[2], 1, 1, w0, tolerance);
    st_check_vec3(frame->vertices[5], 0, 1, 2 * w1, tolerance);
}

PF_TEST(morph_targets_blend_base_plus_weighted_deltas)
{
    /* weights channel, LINEAR: (0, 0) at t = 0, (0.5, 0.5) at 1, (1, 1) at 2. */
    const float data[] = {0, 1, 2, /* values */ 0, 0, 0.5f, 0.5f, 1, 1};
    char path[512];
    pf_scene *scene = st_load_ok(write_morph(
        "morph", NULL, NULL, data, 9,
        ",{\"bufferView\":3,\"byteOffset\":76,\"componentType\":5126,\"count\":3,"
        "\"type\":\"SCALAR\"},{\"bufferView\":3,\"byteOffset\":88,\"componentType\":5126,"
        "\"count\":6,\"type\":\"SCALAR\"}",
        "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"weights\"}}],"
        "\"samplers\":[{\"input\":5,\"output\":6}]}]",
        path, sizeof path));
    PF_REQUIRE(scene);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->deformed_node_count == 1 && info->skin_count == 0);
    PF_CHECK(info->deformation_animated && info->geometry_animated);
    PF_CHECK(info->frame_count == 49); /* 2 s at 24 fps */
    static const double times[] = {0.0, 1.0, 2.0, 0.5};
    static const double weights[] = {0.0, 0.5, 1.0, 0.25};
    for (int k = 0; k < 4; k++) {
        pf_scene_frame frame;
        pf_error err;
        PF_REQUIRE_OK(pf_scene_eval(scene, times[k], &frame, &err), &err);
        check_morph(&frame, weights[k], weights[k], 1e-6);
        /* Vertex 2 lifted: its triangle's normal follows the file's (+Z, no NORMAL target). */
        st_check_vec3(frame.normals[2], 0, 0, 1, 1e-6);
        pf_scene_frame_free(&frame);
    }
    pf_scene_destroy(scene);
}

PF_TEST(morph_weights_from_the_node_then_the_mesh)
{
    char path[512];
    pf_scene *scene = st_load_ok(write_morph("morph_mesh", "[0.5,0.25]", NULL, NULL, 0, NULL, NULL,
                                          path, sizeof path));
    PF_REQUIRE(scene);
    PF_CHECK(!pf_scene_get_info(scene)->deformation_animated);
    pf_scene_frame frame;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    check_morph(&frame, 0.5, 0.25, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);

    scene = st_load_ok(write_morph("morph_node", "[0.5,0.25]", ",\"weights\":[1,0]", NULL, 0, NULL,
                                NULL, path, sizeof path));
    PF_REQUIRE(scene);
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    check_morph(&frame, 1.0, 0.0, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);

    /* A morphed (not skinned) mesh keeps its node's transform. */
    scene = st_load_ok(write_morph("morph_moved", "[1,1]", ",\"translation\":[0,0,10]", NULL, 0,
                                NULL, NULL, path, sizeof path));
    PF_REQUIRE(scene);
    PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
    st_check_vec3(frame.vertices[5], 0, 1, 12, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(cubicspline_weights)
{
    /* Two keys (t = 0, 2), each in-tangent, value, out-tangent for both targets:
     * target 0 goes 0 → 1 with out-tangent 0.5/s and in-tangent 2/s. */
    const float data[] = {0, 2,
                          /* key 0: in */ 0, 0, /* value */ 0, 0, /* out */ 0.5f, 0,
                          /* key 1: in */ 2, 0, /* value */ 1, 0, /* out */ 0, 0};
    char path[512];
    pf_scene *scene = st_load_ok(write_morph(
        "morph_cubic", NULL, NULL, data, 14,
        ",{\"bufferView\":3,\"byteOffset\":76,\"componentType\":5126,\"count\":2,"
        "\"type\":\"SCALAR\"},{\"bufferView\":3,\"byteOffset\":84,\"componentType\":5126,"
        "\"count\":12,\"type\":\"SCALAR\"}",
        "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"weights\"}}],"
        "\"samplers\":[{\"input\":5,\"output\":6,\"interpolation\":\"CUBICSPLINE\"}]}]",
        path, sizeof path));
    PF_REQUIRE(scene);
    static const double times[] = {0.5, 1.0, 1.5};
    for (int k = 0; k < 3; k++) {
        pf_scene_frame frame;
        pf_error err;
        PF_REQUIRE_OK(pf_scene_eval(scene, times[k], &frame, &err), &err);
        double u = times[k] / 2.0;
        double expected = pf_cubic_hermite(0, 0.5f, 1, 2, 2.0f, (float)u);
        /* By hand: h10 = u³ - 2u² + u, h01 = -2u³ + 3u², h11 = u³ - u². */
        double by_hand = (u * u * u - 2 * u * u + u) * 2 * 0.5 +
                         (-2 * u * u * u + 3 * u * u) * 1 + (u * u * u - u * u) * 2 * 2;
        PF_CHECK_NEAR(expected, by_hand, 1e-6);
        check_morph(&frame, by_hand, 0.0, 1e-5);
        pf_scene_frame_free(&frame);
    }
    pf_scene_destroy(scene);
}

PF_TEST(malformed_morphs_are_refused)
{
    char path[512];
    st_expect_error(write_morph("morph_bad_weights", "[1]", NULL, NULL, 0, NULL, NULL, path,
                                sizeof path),
                    PF_ERR_FORMAT, "meshes[0]", "1 values for 2 morph targets");
    st_expect_error(write_morph("morph_bad_node", NULL, ",\"weights\":[1,2,3]", NULL, 0, NULL,
                                NULL, path, sizeof path),
                    PF_ERR_FORMAT, "nodes[0]", "3 values for 2 morph targets");
    /* A weights channel with 3 values for 2 keys × 2 targets. */
    const float data[] = {0, 1, 0, 0, 1};
    st_expect_error(write_morph(
                        "morph_bad_channel", NULL, NULL, data, 5,
                        ",{\"bufferView\":3,\"byteOffset\":76,\"componentType\":5126,\"count\":2,"
                        "\"type\":\"SCALAR\"},{\"bufferView\":3,\"byteOffset\":84,"
                        "\"componentType\":5126,\"count\":3,\"type\":\"SCALAR\"}",
                        "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,"
                        "\"path\":\"weights\"}}],\"samplers\":[{\"input\":5,\"output\":6}]}]",
                        path, sizeof path),
                    PF_ERR_FORMAT, "animations[0].samplers[0].output",
                    "one per morph target");
}

PF_TEST(blender_files_put_frame_f_at_f_over_fps)
{
    /* Blender's exporter writes frame f at f / 24 s: a clip of frames 1-24 has keys at
     * 1/24 .. 1 s, and frame 24 must sample 1 s, the pose Blender showed for it. */
    const float data[] = {1.0f / 24.0f, 1.0f, 0, 0, 1, 1};
    static const char accessors[] =
        ",{\"bufferView\":3,\"byteOffset\":76,\"componentType\":5126,\"count\":2,"
        "\"type\":\"SCALAR\"},{\"bufferView\":3,\"byteOffset\":84,\"componentType\":5126,"
        "\"count\":4,\"type\":\"SCALAR\"}";
    static const char animations[] =
        "[{\"channels\":[{\"sampler\":0,\"target\":{\"node\":0,\"path\":\"weights\"}}],"
        "\"samplers\":[{\"input\":5,\"output\":6}]}]";
    static const char *const generators[2] = {"some other exporter",
                                              "Khronos glTF Blender I/O v3.4.50"};
    for (int blender = 0; blender < 2; blender++) {
        char path[512];
        morph_generator = generators[blender];
        pf_scene *scene = st_load_ok(write_morph(blender ? "morph_blender" : "morph_other", NULL,
                                              NULL, data, 6, accessors, animations, path,
                                              sizeof path));
        morph_generator = NULL;
        PF_REQUIRE(scene);
        const pf_scene_info *info = pf_scene_get_info(scene);
        PF_CHECK(info->frame_offset == (uint32_t)blender);
        /* Frames 1-25 at (f - 1) / 24 s; Blender's 1-24 at f / 24 s. */
        PF_CHECK(info->frame_count == (blender ? 24u : 25u));
        PF_CHECK_NEAR(pf_scene_frame_time(scene, 24), blender ? 1.0 : 23.0 / 24.0, 1e-12);
        pf_scene_frame frame;
        pf_error err;
        PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 24), &frame, &err), &err);
        double w = blender ? 1.0 : (23.0 / 24.0 - 1.0 / 24.0) / (1.0 - 1.0 / 24.0);
        check_morph(&frame, w, w, 1e-5);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

/* The largest distance a vertex of node's triangles moves between two frames. */
static double node_motion(const pf_scene_frame *a, const pf_scene_frame *b, uint32_t node)
{
    double most = 0.0;
    for (uint32_t t = 0; t < a->triangle_count; t++) {
        if (a->triangle_node[t] != node)
            continue;
        for (int c = 0; c < 3; c++)
            for (int k = 0; k < 3; k++)
                most = fmax(most, fabs(a->vertices[3 * t + c][k] - b->vertices[3 * t + c][k]));
    }
    return most;
}

/*
 * Blender writes one animation per object: scenes/character has the armature's
 * (index 0, "armatureAction") and the sheet's shape keys ("KeyAction"). Both play
 * unless one is chosen, by name or index; a name the file lacks is refused naming
 * the file's animations.
 */
PF_TEST(every_animation_plays_unless_one_is_chosen)
{
    const char *source = getenv("PF_SOURCE_DIR");
    char path[1024];
    snprintf(path, sizeof path, "%s/scenes/character/character.gltf", source ? source : ".");
    enum { ARM_NODE = 5, SHEET_NODE = 7 };
    static const char *const choices[] = {NULL, "armatureAction", "1"};
    for (int k = 0; k < 3; k++) {
        pf_scene_load_options options = {0, choices[k]};
        pf_scene *scene = NULL;
        pf_error err = {0};
        PF_REQUIRE_OK(pf_scene_load_with(path, &options, &scene, &err), &err);
        const pf_scene_info *info = pf_scene_get_info(scene);
        PF_CHECK(info->animation_count == 2);
        PF_CHECK(info->animation == (k == 0 ? -1 : k == 1 ? 0 : 1));
        PF_CHECK(info->frame_count == 24 && info->frame_offset == 1);
        pf_scene_frame first, last;
        PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 1), &first, &err), &err);
        PF_REQUIRE_OK(pf_scene_eval(scene, pf_scene_frame_time(scene, 24), &last, &err), &err);
        double arm = node_motion(&first, &last, ARM_NODE);
        double sheet = node_motion(&first, &last, SHEET_NODE);
        /* The arm's upper bone turns 80°: its top moves by ~1.3 m; the bulge is 0.4 m. */
        PF_CHECK_MSG(k == 2 ? arm == 0.0 : arm > 1.0, "choice %d: arm moved %g", k, arm);
        PF_CHECK_MSG(k == 1 ? sheet == 0.0 : fabs(sheet - 0.4) < 0.05, "choice %d: sheet %g", k,
                     sheet);
        pf_scene_frame_free(&first);
        pf_scene_frame_free(&last);
        pf_scene_destroy(scene);
    }
    pf_scene_load_options options = {0, "walk"};
    pf_scene *scene = NULL;
    pf_error err = {0};
    PF_CHECK(pf_scene_load_with(path, &options, &scene, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "--animation 'walk'") &&
                     strstr(err.message, "0 'armatureAction', 1 'KeyAction'"),
                 "%s", err.message);
    options.animation = "2";
    PF_CHECK(pf_scene_load_with(path, &options, &scene, &err) == PF_ERR_INVALID);
    PF_CHECK(scene == NULL);
}

PF_TEST(morphed_normals_add_their_deltas)
{
    /* Target 0 also tilts vertex 2's normal by (0.5, 0, 0): at weight 1 it is
     * (0.5, 0, 1)/|.|, at weight 0.5 (0.25, 0, 1)/|.|; the other normals stay +Z. */
    float deltas[12] = {0};
    deltas[2 * 3] = 0.5f;
    static const char accessors[] =
        ",{\"bufferView\":3,\"byteOffset\":76,\"componentType\":5126,\"count\":4,"
        "\"type\":\"VEC3\"}";
    static const char *const weights[2] = {"[1,0]", "[0.5,0]"};
    for (int k = 0; k < 2; k++) {
        char path[512];
        morph_target0 = ",\"NORMAL\":5";
        pf_scene *scene = st_load_ok(write_morph(k ? "morph_normal_half" : "morph_normal",
                                                 weights[k], NULL, deltas, 12, accessors, NULL,
                                                 path, sizeof path));
        morph_target0 = "";
        PF_REQUIRE(scene);
        pf_scene_frame frame;
        pf_error err;
        PF_REQUIRE_OK(pf_scene_eval(scene, 0.0, &frame, &err), &err);
        double x = k ? 0.25 : 0.5, length = sqrt(x * x + 1.0);
        st_check_vec3(frame.normals[2], x / length, 0, 1 / length, 1e-6);
        st_check_vec3(frame.normals[1], 0, 0, 1, 1e-6);
        pf_scene_frame_free(&frame);
        pf_scene_destroy(scene);
    }
}

int main(void)
{
    PF_RUN(two_bone_skin_matches_linear_blend_skinning);
    PF_RUN(eval_in_two_halves_equals_eval);
    PF_RUN(unnormalised_weights_are_normalised);
    PF_RUN(malformed_skins_name_their_accessor);
    PF_RUN(morph_targets_blend_base_plus_weighted_deltas);
    PF_RUN(morph_weights_from_the_node_then_the_mesh);
    PF_RUN(cubicspline_weights);
    PF_RUN(malformed_morphs_are_refused);
    PF_RUN(blender_files_put_frame_f_at_f_over_fps);
    PF_RUN(every_animation_plays_unless_one_is_chosen);
    PF_RUN(morphed_normals_add_their_deltas);
    return pf_test_finish();
}
