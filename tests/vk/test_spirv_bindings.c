/*
 * spirv_bindings.c: the descriptor kind core/vk gives each binding, read from
 * the module: uniform texel buffers where a shader declares usamplerBuffer (R32
 * words), samplerBuffer (RGBA32 float) or isamplerBuffer (16-byte records),
 * storage buffers for the other variables, absent where the (optimized) module has
 * none. The kernels' declarations decide it, so these are checked
 * on the embedded shaders themselves (the pipelines' layouts must match what
 * the dispatches bind: the VULKAN tests run with the validation layer).
 */
#include "pf_test.h"
#include "pf_scene.h"
#include "pf_vk_internal.h"

#include "pf_shaders.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void kinds_of(const char *shader, uint8_t *kinds, uint32_t count)
{
    const pf_shader_blob *blob = pf_shader_find(shader);
    PF_REQUIRE(blob != NULL);
    pf_error err = {0};
    PF_CHECK_OK(pf_vk_spirv_binding_kinds(blob->words, blob->bytes / 4, kinds, count, &err),
                &err);
}

PF_TEST(traversal_reads_the_tree_through_texel_buffers)
{
    uint8_t kinds[6];
    kinds_of("bih_raycast", kinds, 6);
    PF_CHECK(kinds[0] == PF_VK_BINDING_TEXEL_INT4);  /* nodes: one 16-byte texel each */
    PF_CHECK(kinds[1] == PF_VK_BINDING_TEXEL_FLOAT); /* vertices: vec4 */
    PF_CHECK(kinds[2] == PF_VK_BINDING_TEXEL_UINT);  /* triangle index */
    for (int b = 3; b < 6; b++)
        PF_CHECK_MSG(kinds[b] == PF_VK_BINDING_STORAGE, "binding %d: kind %d", b, kinds[b]);
}

PF_TEST(integrators_read_the_tree_and_photon_maps_through_texel_buffers)
{
    /* What each kernel reads (the build's spirv-opt removes every variable a kernel never
     * reads: its binding is absent, and left out of the layout). Every kernel that traces
     * reads the tree as 1 records, 1 float and 1 uint view; fast adds the LPV's four float
     * arrays (cells, cascades, far fields, geometry; lpv_lookup.glsl), its caustic kernel the
     * caustic map (records, ranges) and its flux (words); final's kernels read the photon map,
     * the irradiance points and the per-pixel buffers of the passes before them as records and
     * the fluxes as words, the primary and the gathers the hits the host traced for them
     * (words). Counted from the kernel's own bindings on (after PF_SCENE_BINDING_COUNT). */
    static const struct {
        const char *name;
        uint32_t texel_uint, texel_records, texel_float;
        int reads_textures; /* its "_surfaces" variant reads the texture bindings */
    } integrators[] = {{"render_direct", 1, 1, 1, 1},         {"render_fast", 1, 1, 5, 1},
                       {"render_final", 2, 2, 1, 1},          {"final_gather", 3, 7, 1, 1},
                       {"render_reference", 1, 1, 1, 1},      {"final_deferred", 1, 3, 0, 0},
                       {"final_caustic", 1, 5, 0, 1},         {"final_resolve", 0, 4, 0, 0},
                       {"final_gather_estimate", 4, 9, 1, 1}, {"render_fast_caustic", 2, 3, 5, 1}};
    /* The scene's bindings where a kernel reads them: the parameters, lights and emissive table
     * storage; vertices and normals float texels, a triangle's material a word, the materials
     * 16-byte records; corners float texels, the texture table records, the texels words. */
    static const uint8_t scene_kinds[PF_SCENE_BINDING_COUNT] = {
        [PF_SCENE_BINDING_PARAMS] = PF_VK_BINDING_STORAGE,
        [PF_SCENE_BINDING_VERTICES] = PF_VK_BINDING_TEXEL_FLOAT,
        [PF_SCENE_BINDING_NORMALS] = PF_VK_BINDING_TEXEL_FLOAT,
        [PF_SCENE_BINDING_TRIANGLE_MATERIALS] = PF_VK_BINDING_TEXEL_UINT,
        [PF_SCENE_BINDING_MATERIALS] = PF_VK_BINDING_TEXEL_INT4,
        [PF_SCENE_BINDING_LIGHTS] = PF_VK_BINDING_STORAGE,
        [PF_SCENE_BINDING_EMISSIVE] = PF_VK_BINDING_STORAGE,
        [PF_SCENE_BINDING_CORNERS] = PF_VK_BINDING_TEXEL_FLOAT,
        [PF_SCENE_BINDING_TEXTURES] = PF_VK_BINDING_TEXEL_INT4,
        [PF_SCENE_BINDING_TEXELS] = PF_VK_BINDING_TEXEL_UINT};
    /* final's kernels have the most bindings (PF_FINAL_BUFFERS: the scene's and 28). */
    enum { S = PF_SCENE_BINDING_COUNT, ALL = PF_SCENE_BINDING_COUNT + 28 };
    for (size_t i = 0; i < sizeof integrators / sizeof *integrators; i++) {
        uint8_t kinds[ALL];
        kinds_of(integrators[i].name, kinds, ALL);
        uint32_t texel_uint = 0, texel_float = 0, texel_records = 0;
        for (int b = S; b < ALL; b++) {
            texel_uint += kinds[b] == PF_VK_BINDING_TEXEL_UINT;
            texel_float += kinds[b] == PF_VK_BINDING_TEXEL_FLOAT;
            texel_records += kinds[b] == PF_VK_BINDING_TEXEL_INT4;
        }
        PF_CHECK_MSG(texel_uint == integrators[i].texel_uint &&
                         texel_float == integrators[i].texel_float &&
                         texel_records == integrators[i].texel_records,
                     "%s: %u uint, %u float and %u records texel", integrators[i].name,
                     texel_uint, texel_float, texel_records);
        PF_CHECK_MSG(kinds[PF_SCENE_BINDING_PARAMS] == PF_VK_BINDING_STORAGE,
                     "%s: no parameters", integrators[i].name);
        for (int b = 0; b < S; b++)
            PF_CHECK_MSG(kinds[b] == scene_kinds[b] || kinds[b] == PF_VK_BINDING_ABSENT,
                         "%s: scene binding %d of kind %d", integrators[i].name, b, kinds[b]);
        /* The plain variant reads no texture. */
        PF_CHECK(kinds[PF_SCENE_BINDING_CORNERS] == PF_VK_BINDING_ABSENT &&
                 kinds[PF_SCENE_BINDING_TEXTURES] == PF_VK_BINDING_ABSENT &&
                 kinds[PF_SCENE_BINDING_TEXELS] == PF_VK_BINDING_ABSENT);
        /* The "_surfaces" variant reads what the plain one does (and may read more of the
         * scene: normals for a normal map), and the textures where it shades surfaces. */
        char surfaces[64];
        snprintf(surfaces, sizeof surfaces, "%s_surfaces", integrators[i].name);
        uint8_t variant[ALL];
        kinds_of(surfaces, variant, ALL);
        for (int b = 0; b < ALL; b++)
            if (b < PF_SCENE_BINDING_CORNERS || b > PF_SCENE_BINDING_TEXELS)
                PF_CHECK_MSG(variant[b] == kinds[b] || (kinds[b] == PF_VK_BINDING_ABSENT &&
                                                        b < S && variant[b] == scene_kinds[b]),
                             "%s: binding %d of kind %d, plain %d", surfaces, b, variant[b],
                             kinds[b]);
        for (int b = PF_SCENE_BINDING_CORNERS; b <= PF_SCENE_BINDING_TEXELS; b++)
            PF_CHECK_MSG(variant[b] == (integrators[i].reads_textures ? scene_kinds[b]
                                                                      : PF_VK_BINDING_ABSENT),
                         "%s: texture binding %d of kind %d", surfaces, b, variant[b]);
    }
    uint8_t kinds[ALL];
    kinds_of("render_final", kinds, ALL);
    PF_CHECK(kinds[S + 3] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 4] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 5] == PF_VK_BINDING_TEXEL_UINT); /* BIH_BINDING */
    kinds_of("final_gather_estimate", kinds, ALL);
    /* Records and ranges of the map (S+8, S+9) and the points (S+11, S+12); their flux. */
    PF_CHECK(kinds[S + 8] == PF_VK_BINDING_TEXEL_INT4 && kinds[S + 9] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 11] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 12] == PF_VK_BINDING_TEXEL_INT4);
    PF_CHECK(kinds[S + 15] == PF_VK_BINDING_TEXEL_UINT && kinds[S + 16] == PF_VK_BINDING_TEXEL_UINT);
    PF_CHECK(kinds[S + 6] == PF_VK_BINDING_STORAGE); /* the vertices it writes */
    for (int b = S + 17; b < S + 23; b++) /* per-pixel buffers' texel views, for reading */
        PF_CHECK(kinds[b] == PF_VK_BINDING_TEXEL_INT4 || kinds[b] == PF_VK_BINDING_ABSENT);
    /* The rays the host traces (host_rays.glsl): rays and queue written, hits read as
     * words. */
    PF_CHECK(kinds[S + 23] == PF_VK_BINDING_STORAGE && kinds[S + 24] == PF_VK_BINDING_TEXEL_UINT &&
             kinds[S + 25] == PF_VK_BINDING_STORAGE);
    kinds_of("photon_trace", kinds, S + 13);
    PF_CHECK(kinds[1] == PF_VK_BINDING_TEXEL_FLOAT && kinds[4] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[6] == PF_VK_BINDING_STORAGE); /* scene_geometry.glsl; the emitters */
    PF_CHECK(kinds[S] == PF_VK_BINDING_TEXEL_INT4 && kinds[S + 1] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 2] == PF_VK_BINDING_TEXEL_UINT); /* BIH_BINDING */
    /* The waves (photon_trace_wave.c, photon_wave_bounce.comp): state, rays and queue written;
     * the hits and the active photons read as words, the state and rays as float texels. */
    kinds_of("photon_wave_bounce", kinds, S + 13);
    PF_CHECK(kinds[S + 6] == PF_VK_BINDING_STORAGE && kinds[S + 7] == PF_VK_BINDING_STORAGE &&
             kinds[S + 8] == PF_VK_BINDING_TEXEL_UINT && kinds[S + 9] == PF_VK_BINDING_STORAGE &&
             kinds[S + 10] == PF_VK_BINDING_TEXEL_UINT &&
             kinds[S + 11] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 12] == PF_VK_BINDING_TEXEL_FLOAT);
    kinds_of("render_fast", kinds, S + 15); /* PF_FAST_BUFFERS */
    PF_CHECK(kinds[S + 6] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 7] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 10] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 11] == PF_VK_BINDING_TEXEL_FLOAT); /* LPV cells, cascades, far fields,
                                                           * geometry */
    /* The propagation reads its source, the geometry and (through second bindings of the
     * same buffers) the accumulation and the snapshot as texels, and writes storage. */
    kinds_of("lpv_propagate", kinds, 7);
    PF_CHECK(kinds[0] == PF_VK_BINDING_TEXEL_FLOAT && kinds[3] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[5] == PF_VK_BINDING_TEXEL_FLOAT && kinds[6] == PF_VK_BINDING_TEXEL_FLOAT);
    PF_CHECK(kinds[1] == PF_VK_BINDING_STORAGE && kinds[2] == PF_VK_BINDING_STORAGE &&
             kinds[4] == PF_VK_BINDING_STORAGE);
    kinds_of("photon_irradiance_precompute", kinds, 6);
    PF_CHECK(kinds[0] == PF_VK_BINDING_TEXEL_INT4 && kinds[1] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[5] == PF_VK_BINDING_TEXEL_UINT &&
             kinds[2] == PF_VK_BINDING_STORAGE); /* the map read, the points written */
}

PF_TEST(storage_only_shaders_stay_storage)
{
    uint8_t kinds[2] = {99, 99};
    kinds_of("vk_selftest", kinds, 2);
    PF_CHECK(kinds[0] == PF_VK_BINDING_STORAGE && kinds[1] == PF_VK_BINDING_STORAGE);
}

PF_TEST(bad_modules_and_too_few_bindings_are_refused)
{
    const pf_shader_blob *blob = pf_shader_find("bih_raycast");
    PF_REQUIRE(blob != NULL);
    pf_error err = {0};
    uint8_t kinds[6];
    /* The tree's texel buffers sit at bindings 0..2: a pipeline of 2 bindings cannot hold them. */
    PF_CHECK(pf_vk_spirv_binding_kinds(blob->words, blob->bytes / 4, kinds, 2, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "texel buffer at binding 2") != NULL);
    /* Nor a storage buffer (the vertex count at 3) in 3 bindings. */
    PF_CHECK(pf_vk_spirv_binding_kinds(blob->words, blob->bytes / 4, kinds, 3, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "storage buffer at binding") != NULL);
    uint32_t *copy = malloc(blob->bytes);
    PF_REQUIRE(copy != NULL);
    memcpy(copy, blob->words, blob->bytes);
    copy[5] = 0xffffu << 16 | (copy[5] & 0xffffu);
    PF_CHECK(pf_vk_spirv_binding_kinds(copy, blob->bytes / 4, kinds, 6, &err) == PF_ERR_FORMAT);
    copy[0] = 0;
    PF_CHECK(pf_vk_spirv_binding_kinds(copy, blob->bytes / 4, kinds, 6, &err) == PF_ERR_FORMAT);
    free(copy);
}

int main(void)
{
    PF_RUN(traversal_reads_the_tree_through_texel_buffers);
    PF_RUN(integrators_read_the_tree_and_photon_maps_through_texel_buffers);
    PF_RUN(storage_only_shaders_stay_storage);
    PF_RUN(bad_modules_and_too_few_bindings_are_refused);
    return pf_test_finish();
}
