/*
 * Photon emitters: each light's power against its closed form (the spot's
 * falloff cone against numerical integration of the falloff lights.glsl
 * applies), emissive triangles π·Le·A, zero-power lights left out, and pick
 * probabilities proportional to luminance power.
 */
#include "pf_photon.h"
#include "pf_test.h"

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

/* lights.glsl spot_falloff, in doubles. */
static double spot_falloff(double cos_angle, double cos_inner, double cos_outer)
{
    if (cos_inner <= cos_outer)
        return cos_angle >= cos_outer ? 1.0 : 0.0;
    double x = fmin(fmax((cos_angle - cos_outer) / (cos_inner - cos_outer), 0.0), 1.0);
    return x * x;
}

PF_TEST(light_powers_match_closed_forms)
{
    pf_light point = {.kind = PF_LIGHT_POINT, .intensity = {1.0f, 2.0f, 3.0f}};
    float power[3];
    pf_photon_light_power(&point, 1.0f, power);
    PF_CHECK_NEAR(power[2], 3.0 * 4.0 * PI, 1e-4);

    pf_light spot = {.kind = PF_LIGHT_SPOT, .intensity = {10.0f, 10.0f, 10.0f},
                     .cos_inner_cone = 0.9f, .cos_outer_cone = 0.7f};
    /* ∫ falloff dω = 2π ∫ falloff(c) dc over c in [-1, 1], midpoint rule. */
    double integral = 0.0;
    const int steps = 200000;
    for (int i = 0; i < steps; i++) {
        double c = -1.0 + (i + 0.5) * 2.0 / steps;
        integral += spot_falloff(c, spot.cos_inner_cone, spot.cos_outer_cone) * 2.0 / steps;
    }
    pf_photon_light_power(&spot, 1.0f, power);
    PF_CHECK_NEAR(power[0], 10.0 * 2.0 * PI * integral, 1e-3);

    pf_light hard = spot;
    hard.cos_inner_cone = hard.cos_outer_cone = 0.5f;
    pf_photon_light_power(&hard, 1.0f, power);
    PF_CHECK_NEAR(power[0], 10.0 * 2.0 * PI * 0.5, 1e-4);

    pf_light sun = {.kind = PF_LIGHT_DIRECTIONAL, .intensity = {2.0f, 2.0f, 2.0f},
                    .direction = {0.0f, -1.0f, 0.0f}};
    pf_photon_light_power(&sun, 3.0f, power);
    PF_CHECK_NEAR(power[1], 2.0 * PI * 9.0, 1e-4);
}

PF_TEST(emitters_list_lights_and_triangles_by_power)
{
    float vertices[6][4] = {{0, 0, 0, 0}, {2, 0, 0, 0}, {0, 1, 0, 0},   /* area 1 */
                            {0, 0, 1, 0}, {1, 0, 1, 0}, {0, 1, 1, 0}}; /* area 0.5 */
    uint32_t triangle_material[2] = {0, 1};
    pf_material materials[2] = {{.kind = PF_MATERIAL_LAMBERT, .emission = {1.0f, 1.0f, 1.0f}},
                                {.kind = PF_MATERIAL_LAMBERT}};
    pf_light lights[2] = {{.kind = PF_LIGHT_POINT, .intensity = {1.0f, 1.0f, 1.0f}},
                          {.kind = PF_LIGHT_POINT}}; /* zero power: left out */
    pf_scene_frame frame;
    memset(&frame, 0, sizeof frame);
    frame.triangle_count = 2;
    frame.vertices = vertices;
    frame.triangle_material = triangle_material;
    frame.material_count = 2;
    frame.materials = materials;
    frame.light_count = 2;
    frame.lights = lights;
    frame.bounds_max[0] = 2.0f;
    frame.bounds_max[1] = 1.0f;
    frame.bounds_max[2] = 1.0f;
    pf_photon_emitters emitters;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_photon_emitters_build(&frame, &emitters, &err), &err);
    PF_REQUIRE(emitters.count == 2);
    PF_CHECK(emitters.entries[0].kind == PF_EMITTER_POINT && emitters.entries[0].index == 0);
    PF_CHECK(emitters.entries[1].kind == PF_EMITTER_TRIANGLE && emitters.entries[1].index == 0);
    PF_CHECK_NEAR(emitters.entries[1].power[0], PI, 1e-5);
    double total = 4.0 * PI + PI;
    PF_CHECK_NEAR(emitters.total_power[0], total, 1e-4);
    PF_CHECK_NEAR(emitters.entries[0].pick_probability, 4.0 * PI / total, 1e-6);
    PF_CHECK_NEAR(emitters.entries[1].pick_probability, PI / total, 1e-6);
    PF_CHECK_NEAR(emitters.scene_radius, sqrt(1.0 + 0.25 + 0.25), 1e-6);
    pf_photon_emitters_free(&emitters);

    /* A double-sided emitter (glTF doubleSided) emits π Le A from each face. */
    materials[0].flags = PF_MATERIAL_DOUBLE_SIDED;
    PF_REQUIRE_OK(pf_photon_emitters_build(&frame, &emitters, &err), &err);
    PF_REQUIRE(emitters.count == 2);
    PF_CHECK_NEAR(emitters.entries[1].power[0], 2.0 * PI, 1e-5);
    PF_CHECK_NEAR(emitters.total_power[0], 4.0 * PI + 2.0 * PI, 1e-4);
    pf_photon_emitters_free(&emitters);
    materials[0].flags = 0;

    /* No power anywhere: nothing to emit, not an error. */
    materials[0].emission[0] = materials[0].emission[1] = materials[0].emission[2] = 0.0f;
    lights[0].intensity[0] = lights[0].intensity[1] = lights[0].intensity[2] = 0.0f;
    PF_REQUIRE_OK(pf_photon_emitters_build(&frame, &emitters, &err), &err);
    PF_CHECK(emitters.count == 0);
    pf_photon_emitters_free(&emitters);

    lights[0].intensity[1] = INFINITY;
    PF_CHECK(pf_photon_emitters_build(&frame, &emitters, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "light 0") != NULL);
}

int main(void)
{
    PF_RUN(light_powers_match_closed_forms);
    PF_RUN(emitters_list_lights_and_triangles_by_power);
    return pf_test_finish();
}
