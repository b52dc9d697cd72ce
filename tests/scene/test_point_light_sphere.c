/*
 * pf_scene_frame_point_light_to_sphere: the stand-in sphere emits exactly the
 * point light's power, is closed and faces outward, the other lights stay,
 * and refused input leaves the frame unchanged.
 */
#include "pf_scene.h"
#include "pf_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* A frame with one floor triangle and a point light plus a spot light, all malloc'ed. */
static void make_frame(pf_scene_frame *frame)
{
    memset(frame, 0, sizeof *frame);
    frame->triangle_count = 1;
    frame->vertices = calloc(3, sizeof *frame->vertices);
    frame->normals = calloc(3, sizeof *frame->normals);
    frame->triangle_material = calloc(1, sizeof *frame->triangle_material);
    frame->triangle_node = calloc(1, sizeof *frame->triangle_node);
    frame->vertices[1][0] = 1.0f;
    frame->vertices[2][2] = 1.0f;
    frame->material_count = 1;
    frame->materials = calloc(1, sizeof *frame->materials);
    frame->materials[0].albedo[0] = 0.5f;
    frame->light_count = 2;
    frame->lights = calloc(2, sizeof *frame->lights);
    frame->lights[0] = (pf_light){.position = {0.25f, 1.0f, 0.25f}, .kind = PF_LIGHT_POINT,
                                  .intensity = {2.0f, 1.0f, 0.5f}};
    frame->lights[1] = (pf_light){.position = {0.0f, 2.0f, 0.0f}, .kind = PF_LIGHT_SPOT,
                                  .direction = {0.0f, -1.0f, 0.0f}, .intensity = {1, 1, 1},
                                  .cos_inner_cone = 0.9f, .cos_outer_cone = 0.8f};
    frame->bounds_max[0] = frame->bounds_max[2] = 1.0f;
}

static void edge_of(const float (*v)[4], int a, int b, float out[6])
{
    /* Order the two endpoints so an edge compares equal from either triangle. */
    int swap = memcmp(v[a], v[b], 3 * sizeof(float)) > 0;
    memcpy(out, v[swap ? b : a], 3 * sizeof(float));
    memcpy(out + 3, v[swap ? a : b], 3 * sizeof(float));
}

PF_TEST(sphere_has_the_point_lights_power_and_is_closed_and_outward)
{
    pf_scene_frame frame;
    make_frame(&frame);
    pf_error err = {0};
    const float radius = 0.05f, centre[3] = {0.25f, 1.0f, 0.25f};
    PF_REQUIRE_OK(pf_scene_frame_point_light_to_sphere(&frame, 0, radius, 12, 6, &err), &err);
    PF_CHECK(frame.light_count == 1 && frame.lights[0].kind == PF_LIGHT_SPOT);
    PF_REQUIRE(frame.triangle_count > 1);
    double power[3] = {0, 0, 0};
    uint32_t inward = 0, first = 1, count = frame.triangle_count - first;
    for (uint32_t t = first; t < frame.triangle_count; t++) {
        const float (*v)[4] = frame.vertices + 3 * t;
        const pf_material *m = &frame.materials[frame.triangle_material[t]];
        double e1[3], e2[3], n[3], c[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)v[1][k] - v[0][k];
            e2[k] = (double)v[2][k] - v[0][k];
            c[k] = ((double)v[0][k] + v[1][k] + v[2][k]) / 3.0 - centre[k];
        }
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double area = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        inward += n[0] * c[0] + n[1] * c[1] + n[2] * c[2] <= 0.0;
        for (int k = 0; k < 3; k++)
            power[k] += PI * m->emission[k] * area;
    }
    const double expected[3] = {4 * PI * 2.0, 4 * PI * 1.0, 4 * PI * 0.5};
    for (int k = 0; k < 3; k++)
        PF_CHECK_MSG(fabs(power[k] / expected[k] - 1.0) < 1e-5, "channel %d: %.6f W vs %.6f W", k,
                     power[k], expected[k]);
    PF_CHECK_MSG(inward == 0, "%u of %u triangles face inward", inward, count);
    /* Closed: every edge of the sphere is shared by exactly two of its triangles. */
    uint32_t open_edges = 0;
    for (uint32_t t = first; t < frame.triangle_count; t++) {
        for (int e = 0; e < 3; e++) {
            float edge[6];
            edge_of(frame.vertices + 3 * t, e, (e + 1) % 3, edge);
            uint32_t shared = 0;
            for (uint32_t u = first; u < frame.triangle_count; u++) {
                for (int f = 0; f < 3; f++) {
                    float other[6];
                    edge_of(frame.vertices + 3 * u, f, (f + 1) % 3, other);
                    shared += memcmp(edge, other, sizeof edge) == 0;
                }
            }
            open_edges += shared != 2;
        }
    }
    PF_CHECK_MSG(open_edges == 0, "%u edges not shared by exactly two triangles", open_edges);
    PF_CHECK(frame.emissive_triangle_count == count);
    pf_scene_frame_free(&frame);
}

PF_TEST(refused_input_leaves_the_frame_unchanged)
{
    pf_scene_frame frame;
    make_frame(&frame);
    pf_error err = {0};
    PF_CHECK(pf_scene_frame_point_light_to_sphere(&frame, 1, 0.05f, 12, 6, &err) ==
             PF_ERR_INVALID); /* a spot light */
    PF_CHECK(pf_scene_frame_point_light_to_sphere(&frame, 2, 0.05f, 12, 6, &err) ==
             PF_ERR_INVALID); /* out of range */
    PF_CHECK(pf_scene_frame_point_light_to_sphere(&frame, 0, 0.0f, 12, 6, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(pf_scene_frame_point_light_to_sphere(&frame, 0, 0.05f, 2, 6, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(frame.triangle_count == 1 && frame.light_count == 2 && frame.material_count == 1);
    pf_scene_frame_free(&frame);
}

int main(void)
{
    PF_RUN(sphere_has_the_point_lights_power_and_is_closed_and_outward);
    PF_RUN(refused_input_leaves_the_frame_unchanged);
    return pf_test_finish();
}
