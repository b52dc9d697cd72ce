/*
 * pf_scene_frame_surface_features and pf_scene_spec_constants: each feature's bit is set by
 * what the frame has (punctual lights, a transmissive, an emissive, an alpha-tested material,
 * corners) and by nothing else, and each bit turns on its own specialisation constant only.
 * A bit missing where the frame has the feature would compile its code out of every kernel
 * (the light loop, the transmission lobes, the emitters' sampling).
 */
#include "pf_scene.h"
#include "pf_test.h"

#include <string.h>

static uint32_t features_of(uint32_t light_count, pf_material material, int corners)
{
    pf_scene_frame frame;
    memset(&frame, 0, sizeof frame);
    pf_material materials[2];
    memset(&materials[0], 0, sizeof materials[0]);
    materials[1] = material;
    materials[0].albedo[0] = materials[0].albedo[1] = materials[0].albedo[2] = 0.5f;
    frame.materials = materials;
    frame.material_count = 2;
    frame.light_count = light_count;
    float corner[4] = {0};
    frame.corners = corners ? &corner : NULL;
    return pf_scene_frame_surface_features(&frame);
}

PF_TEST(each_feature_sets_its_own_bit)
{
    pf_material plain;
    memset(&plain, 0, sizeof plain);
    plain.albedo[0] = 0.8f;
    PF_CHECK(features_of(0, plain, 0) == 0u);
    PF_CHECK(features_of(2, plain, 0) == PF_SURFACE_LIGHTS);
    pf_material glass = plain;
    glass.transmission = 0.5f;
    PF_CHECK(features_of(0, glass, 0) == PF_SURFACE_TRANSMISSION);
    pf_material lamp = plain;
    lamp.emission[2] = 3.0f; /* blue alone counts */
    PF_CHECK(features_of(0, lamp, 0) == PF_SURFACE_EMISSIVE);
    pf_material masked = plain;
    masked.alpha_mode = PF_ALPHA_MASK;
    PF_CHECK(features_of(0, masked, 0) == PF_SURFACE_ALPHA);
    PF_CHECK(features_of(0, plain, 1) == PF_SURFACE_CORNERS);
    pf_material all = lamp;
    all.transmission = 1.0f;
    all.alpha_mode = PF_ALPHA_BLEND;
    PF_CHECK(features_of(1, all, 1) == PF_SURFACE_VARIANTS - 1u);
}

PF_TEST(each_bit_turns_on_its_own_constant)
{
    static const struct {
        uint32_t bit, constant_id;
    } pairs[] = {{PF_SURFACE_ALPHA, PF_SPEC_SCENE_HAS_ALPHA},
                 {PF_SURFACE_CORNERS, PF_SPEC_SCENE_HAS_CORNERS},
                 {PF_SURFACE_LIGHTS, PF_SPEC_SCENE_HAS_LIGHTS},
                 {PF_SURFACE_TRANSMISSION, PF_SPEC_SCENE_HAS_TRANSMISSION},
                 {PF_SURFACE_EMISSIVE, PF_SPEC_SCENE_HAS_EMITTERS}};
    PF_REQUIRE(sizeof pairs / sizeof pairs[0] == PF_SCENE_SPEC_CONSTANTS);
    for (size_t p = 0; p < PF_SCENE_SPEC_CONSTANTS; p++) {
        uint32_t ids[PF_SCENE_SPEC_CONSTANTS], values[PF_SCENE_SPEC_CONSTANTS];
        pf_scene_spec_constants(pairs[p].bit, ids, values);
        for (size_t c = 0; c < PF_SCENE_SPEC_CONSTANTS; c++)
            PF_CHECK_MSG(values[c] == (ids[c] == pairs[p].constant_id ? 1u : 0u),
                         "bit %u: constant %u is %u", pairs[p].bit, ids[c], values[c]);
    }
}

int main(void)
{
    PF_RUN(each_feature_sets_its_own_bit);
    PF_RUN(each_bit_turns_on_its_own_constant);
    return pf_test_finish();
}
