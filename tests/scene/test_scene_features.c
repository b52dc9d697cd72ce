/*
 * pf_scene_frame_surface_features and pf_scene_spec_constants: each feature's bit is set by
 * what the frame has (alpha-tested materials, corners) or lacks (punctual lights, a
 * transmissive, an emissive, a specular material) and by nothing else, and each bit sets its
 * own specialisation constant only; a word left 0 (a caller that never asked) compiles every
 * feature's code in but alpha tests and corners. A bit wrong where the frame has the feature
 * would compile its code out of every kernel (the light loop, the transmission lobes, the
 * emitters' sampling, the specular chains).
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

/* The bits of a frame that lacks everything the NO_ bits name. */
#define LACKS_ALL                                                                          \
    (PF_SURFACE_NO_LIGHTS | PF_SURFACE_NO_TRANSMISSION | PF_SURFACE_NO_EMISSION |         \
     PF_SURFACE_NO_SPECULAR | PF_SURFACE_NO_MANY_LIGHTS | PF_SURFACE_NO_CLEARCOAT |        \
     PF_SURFACE_NO_SHEEN)

PF_TEST(each_feature_sets_its_own_bit)
{
    pf_material plain;
    memset(&plain, 0, sizeof plain);
    plain.albedo[0] = 0.8f;
    PF_CHECK(features_of(0, plain, 0) == LACKS_ALL);
    PF_CHECK(features_of(2, plain, 0) == (LACKS_ALL & ~PF_SURFACE_NO_LIGHTS));
    PF_CHECK(features_of(PF_DIRECT_LIGHTS_EVERY_MAX, plain, 0) ==
             (LACKS_ALL & ~PF_SURFACE_NO_LIGHTS));
    /* One more, and direct light samples them. */
    PF_CHECK(features_of(PF_DIRECT_LIGHTS_EVERY_MAX + 1, plain, 0) ==
             (LACKS_ALL & ~(PF_SURFACE_NO_LIGHTS | PF_SURFACE_NO_MANY_LIGHTS)));
    pf_material glass = plain;
    glass.transmission = 0.5f;
    PF_CHECK(features_of(0, glass, 0) == (LACKS_ALL & ~PF_SURFACE_NO_TRANSMISSION));
    pf_material lamp = plain;
    lamp.emission[2] = 3.0f; /* blue alone counts */
    PF_CHECK(features_of(0, lamp, 0) == (LACKS_ALL & ~PF_SURFACE_NO_EMISSION));
    pf_material masked = plain;
    masked.alpha_mode = PF_ALPHA_MASK;
    PF_CHECK(features_of(0, masked, 0) == (LACKS_ALL | PF_SURFACE_ALPHA));
    PF_CHECK(features_of(0, plain, 1) == (LACKS_ALL | PF_SURFACE_CORNERS));
    pf_material mirror = plain;
    mirror.kind = PF_MATERIAL_MIRROR;
    PF_CHECK(features_of(0, mirror, 0) == (LACKS_ALL & ~PF_SURFACE_NO_SPECULAR));
    /* Lambert by its factors, but a texture may lower its roughness to a mirror's. */
    pf_material textured = plain;
    textured.metallic_roughness_texture = 1;
    PF_CHECK(features_of(0, textured, 0) == (LACKS_ALL & ~PF_SURFACE_NO_SPECULAR));
    pf_material coated = plain;
    coated.clearcoat = 0.25f;
    PF_CHECK(features_of(0, coated, 0) == (LACKS_ALL & ~PF_SURFACE_NO_CLEARCOAT));
    pf_material velvet = plain;
    velvet.sheen_color[1] = 0.5f; /* green alone counts */
    PF_CHECK(features_of(0, velvet, 0) == (LACKS_ALL & ~PF_SURFACE_NO_SHEEN));
    /* Unlit: tested as alpha is (camera rays only), and no emitter for the light sampling. */
    pf_material unlit = plain;
    unlit.flags = PF_MATERIAL_UNLIT;
    PF_CHECK(features_of(0, unlit, 0) == (LACKS_ALL | PF_SURFACE_ALPHA));
    pf_material all = lamp;
    all.clearcoat = 1.0f;
    all.sheen_color[0] = 1.0f;
    all.transmission = 1.0f;
    all.kind = PF_MATERIAL_GLASS;
    all.alpha_mode = PF_ALPHA_BLEND;
    PF_CHECK(features_of(1, all, 1) ==
             (PF_SURFACE_ALPHA | PF_SURFACE_CORNERS | PF_SURFACE_NO_MANY_LIGHTS));
}

PF_TEST(each_bit_sets_its_own_constant_and_none_leaves_everything_in)
{
    static const struct {
        uint32_t bit, constant_id, value; /* the constant's value with the bit set */
    } pairs[] = {{PF_SURFACE_ALPHA, PF_SPEC_SCENE_HAS_ALPHA, 1},
                 {PF_SURFACE_CORNERS, PF_SPEC_SCENE_HAS_CORNERS, 1},
                 {PF_SURFACE_NO_LIGHTS, PF_SPEC_SCENE_HAS_LIGHTS, 0},
                 {PF_SURFACE_NO_TRANSMISSION, PF_SPEC_SCENE_HAS_TRANSMISSION, 0},
                 {PF_SURFACE_NO_EMISSION, PF_SPEC_SCENE_HAS_EMITTERS, 0},
                 {PF_SURFACE_NO_SPECULAR, PF_SPEC_SCENE_HAS_SPECULAR, 0},
                 {PF_SURFACE_NO_MANY_LIGHTS, PF_SPEC_SCENE_HAS_MANY_LIGHTS, 0},
                 {PF_SURFACE_NO_CLEARCOAT, PF_SPEC_SCENE_HAS_CLEARCOAT, 0},
                 {PF_SURFACE_NO_SHEEN, PF_SPEC_SCENE_HAS_SHEEN, 0}};
    PF_REQUIRE(sizeof pairs / sizeof pairs[0] == PF_SCENE_SPEC_CONSTANTS);
    /* A word left 0: alpha tests and corners out (they read buffers not given), the rest in. */
    uint32_t ids[PF_SCENE_SPEC_CONSTANTS], none[PF_SCENE_SPEC_CONSTANTS];
    pf_scene_spec_constants(0, ids, none);
    for (size_t p = 0; p < PF_SCENE_SPEC_CONSTANTS; p++) {
        uint32_t values[PF_SCENE_SPEC_CONSTANTS];
        pf_scene_spec_constants(pairs[p].bit, ids, values);
        for (size_t c = 0; c < PF_SCENE_SPEC_CONSTANTS; c++) {
            int own = ids[c] == pairs[p].constant_id;
            PF_CHECK_MSG(values[c] == (own ? pairs[p].value : none[c]),
                         "bit %u: constant %u is %u", pairs[p].bit, ids[c], values[c]);
            if (own)
                PF_CHECK_MSG(none[c] == 1u - pairs[p].value,
                             "constant %u is %u in a word left 0", ids[c], none[c]);
        }
    }
}

int main(void)
{
    PF_RUN(each_feature_sets_its_own_bit);
    PF_RUN(each_bit_sets_its_own_constant_and_none_leaves_everything_in);
    return pf_test_finish();
}
