/* OBJ/MTL: objects → nodes, polygons triangulated, negative indices, and the
 * Kd / Ke / Ks / illum / Ni / d / Tf mapping onto the three material kinds. */
#include "pf_scene.h"
#include "pf_test.h"
#include "scene_test_util.h"

#include <string.h>

static const char *const test_mtl =
    "# materials\n"
    "newmtl red\nKd 0.8 0.1 0.1\nillum 2\n"
    "newmtl light\nKd 0 0 0\nKe 10 8 6\n"
    "newmtl glass\nNi 1.45\nillum 7\nTf 0.9 1 0.9\n"
    "newmtl mirror\nKs 0.9 0.85 0.8\nillum 3\n"
    "newmtl faded\nKd 0.5 0.5 0.5\nd 0.5\nmap_Kd texture.png\n";

static const char *const test_obj =
    "# two objects\n"
    "mtllib test.mtl\n"
    "o first\n"
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "vn 0 0.6 0.8\n"
    "vt 0 0\n"
    "usemtl red\n"
    "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
    "o second\n"
    "v 0 0 1\r\nv 1 0 1\nv 1 1 1\nv 0 1 1\nv 0.5 1.5 1\n"
    "usemtl light\n"
    "f -5 -4 -3 -2 -1\n"
    "usemtl glass\n"
    "f 1 2 3\n"
    "usemtl mirror\n"
    "f 1 3 4\n"
    "usemtl faded\n"
    "f 1 2 4\n"
    "usemtl nonexistent\n"
    "f 1 2 4\n"
    "l 1 2\n";

static void check_vec3(const float *actual, float x, float y, float z, double tolerance)
{
    PF_CHECK_NEAR(actual[0], x, tolerance);
    PF_CHECK_NEAR(actual[1], y, tolerance);
    PF_CHECK_NEAR(actual[2], z, tolerance);
}

PF_TEST(obj_with_mtl)
{
    char path[512], mtl[512];
    st_write_text(st_path(mtl, sizeof mtl, "test.mtl"), test_mtl);
    st_write_text(st_path(path, sizeof path, "test.OBJ"), test_obj);
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = NULL;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    /* texture map, unknown usemtl, line element, no camera */
    PF_CHECK(pf_log_warning_count() - warnings_before == 4);
    const pf_scene_info *info = pf_scene_get_info(scene);
    PF_CHECK(info->node_count == 2);
    PF_CHECK(info->triangle_count == 9);
    PF_CHECK(info->emissive_triangle_count == 3);
    PF_CHECK(info->has_specular && info->has_emissive && !info->has_camera);
    PF_CHECK(info->frame_count == 1);
    pf_scene_frame frame;
    PF_REQUIRE_OK(pf_scene_eval(scene, 0, &frame, &err), &err);
    PF_REQUIRE(frame.triangle_count == 9);
    PF_CHECK(frame.triangle_node[0] == 0 && frame.triangle_node[1] == 0);
    PF_CHECK(frame.triangle_node[2] == 1 && frame.triangle_node[8] == 1);
    /* Quad fan: (1,2,3), (1,3,4); normals from vn (unit already). */
    check_vec3(frame.vertices[3], 0, 0, 0, 0);
    check_vec3(frame.vertices[4], 1, 1, 0, 0);
    check_vec3(frame.vertices[5], 0, 1, 0, 0);
    check_vec3(frame.normals[4], 0, 0.6f, 0.8f, 1e-6);
    /* Pentagon from negative indices: v5..v9, fan from v5. */
    check_vec3(frame.vertices[6], 0, 0, 1, 0);
    check_vec3(frame.vertices[7], 1, 0, 1, 0);
    check_vec3(frame.vertices[8], 1, 1, 1, 0);
    check_vec3(frame.vertices[14], 0.5f, 1.5f, 1, 0);
    check_vec3(frame.normals[6], 0, 0, 1, 1e-6); /* geometric: no vn on this face */
    const pf_material *red = &frame.materials[frame.triangle_material[0]];
    const pf_material *light = &frame.materials[frame.triangle_material[2]];
    const pf_material *glass = &frame.materials[frame.triangle_material[5]];
    const pf_material *mirror = &frame.materials[frame.triangle_material[6]];
    const pf_material *faded = &frame.materials[frame.triangle_material[7]];
    const pf_material *fallback = &frame.materials[frame.triangle_material[8]];
    PF_CHECK(red->kind == PF_MATERIAL_LAMBERT);
    check_vec3(red->albedo, 0.8f, 0.1f, 0.1f, 1e-6);
    check_vec3(red->emission, 0, 0, 0, 0);
    PF_CHECK(light->kind == PF_MATERIAL_LAMBERT);
    check_vec3(light->emission, 10, 8, 6, 0);
    PF_CHECK(glass->kind == PF_MATERIAL_GLASS);
    PF_CHECK_NEAR(glass->ior, 1.45, 1e-6);
    check_vec3(glass->albedo, 0.9f, 1, 0.9f, 1e-6);
    PF_CHECK(mirror->kind == PF_MATERIAL_MIRROR);
    check_vec3(mirror->albedo, 0.9f, 0.85f, 0.8f, 1e-6);
    PF_CHECK(faded->kind == PF_MATERIAL_GLASS); /* d < 1 */
    PF_CHECK_NEAR(faded->ior, 1.5, 0);
    PF_CHECK(fallback->kind == PF_MATERIAL_LAMBERT);
    check_vec3(fallback->albedo, 0.8f, 0.8f, 0.8f, 1e-6);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

PF_TEST(obj_without_mtl_file)
{
    char path[512];
    st_write_text(st_path(path, sizeof path, "nomtl.obj"),
                  "mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    uint32_t warnings_before = pf_log_warning_count();
    pf_scene *scene = NULL;
    pf_error err;
    PF_REQUIRE_OK(pf_scene_load(path, &scene, &err), &err);
    PF_CHECK(pf_log_warning_count() - warnings_before == 2); /* mtllib, no camera */
    PF_CHECK(pf_scene_get_info(scene)->triangle_count == 1);
    PF_CHECK(pf_scene_get_info(scene)->node_count == 1);
    pf_scene_destroy(scene);
}

PF_TEST(obj_bad_files)
{
    char path[512];
    st_write_text(st_path(path, sizeof path, "badindex.obj"),
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 4", "vertex index 9 out of range (3 vertices)");
    st_write_text(st_path(path, sizeof path, "badnegative.obj"),
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 4", "vertex index -4");
    st_write_text(st_path(path, sizeof path, "zeroindex.obj"),
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 4", "vertex index 0");
    st_write_text(st_path(path, sizeof path, "nanvertex.obj"),
                  "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 2", "not finite");
    st_write_text(st_path(path, sizeof path, "shortface.obj"), "v 0 0 0\nv 1 0 0\nf 1 2\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 3", "need 3");
    st_write_text(st_path(path, sizeof path, "badnormal.obj"),
                  "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n");
    st_expect_error(path, PF_ERR_FORMAT, "line 5", "normal index 2");
    st_write_text(st_path(path, sizeof path, "novertices.obj"), "# nothing\nv 0 0 0\n");
    st_expect_error(path, PF_ERR_FORMAT, "no triangles", NULL);
    st_write_text(st_path(path, sizeof path, "badmtl.mtl"), "newmtl x\nKd 0.5 oops\n");
    st_write_text(st_path(path, sizeof path, "badmtl.obj"),
                  "mtllib badmtl.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    st_expect_error(path, PF_ERR_FORMAT, "badmtl.mtl: line 2", "Kd");
}

int main(void)
{
    pf_log_set_level(PF_LOG_ERROR);
    PF_RUN(obj_with_mtl);
    PF_RUN(obj_without_mtl_file);
    PF_RUN(obj_bad_files);
    return pf_test_finish();
}
