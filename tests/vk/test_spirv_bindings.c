/*
 * spirv_bindings.c: the descriptor kind core/vk gives each binding, read from
 * the module: uniform texel buffers where a shader declares usamplerBuffer (R32
 * words), samplerBuffer (RGBA32 float) or isamplerBuffer (16-byte records),
 * storage buffers everywhere else. The kernels' declarations decide it, so these are checked
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
    /* The tree is 1 records view (its nodes), 1 uint and 1 float texel buffer in every
     * integrator; a photon map adds 2 records views (its records, its ranges) and 1 uint (its
     * flux): fast's caustic map,
     * final's bound map and its irradiance points, and final's kernels 7 more records views
     * of their per-pixel buffers; the primary and the gathers 1 uint view of the hits the host
     * traced for them. Each kernel's own bindings follow the scene's
     * (PF_SCENE_BINDING_COUNT of them). The scene's triangles, materials and textures
     * (scene_geometry.glsl, scene_textures.glsl) are texel buffers in all of them and counted
     * apart.
     * Float texels: the tree's vertices where there is a tree, and fast's four LPV arrays (cells,
     * cascades, far fields, geometry; lpv_lookup.glsl). */
    static const struct {
        const char *name;
        uint32_t texel_uint, texel_records, texel_float;
    } integrators[] = {{"render_direct", 1, 1, 1},    {"render_fast", 2, 3, 5},
                       {"render_final", 4, 12, 1},    {"final_gather", 4, 12, 1},
                       {"render_reference", 1, 1, 1}, {"final_deferred", 2, 11, 0},
                       {"final_caustic", 2, 11, 0},   {"final_resolve", 2, 11, 0},
                       {"final_gather_estimate", 4, 12, 1}, {"render_fast_caustic", 2, 3, 5}};
    /* final's kernels have the most bindings (PF_FINAL_BUFFERS: the scene's and 28); the
     * others read as storage past their own. */
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
        /* final_deferred, final_caustic and final_resolve have final_shared.glsl's maps and no
         * tree; the two gathers have both. */
        PF_CHECK_MSG(texel_uint == integrators[i].texel_uint &&
                         texel_float == integrators[i].texel_float &&
                         texel_records == integrators[i].texel_records,
                     "%s: %u uint, %u float and %u records texel", integrators[i].name,
                     texel_uint, texel_float, texel_records);
        /* Vertices and normals as float texels, a triangle's material as a word, the materials
         * as 16-byte records; the frame parameters, lights and emissive table stay storage. */
        PF_CHECK_MSG(kinds[1] == PF_VK_BINDING_TEXEL_FLOAT &&
                         kinds[2] == PF_VK_BINDING_TEXEL_FLOAT &&
                         kinds[3] == PF_VK_BINDING_TEXEL_UINT &&
                         kinds[4] == PF_VK_BINDING_TEXEL_INT4,
                     "%s: scene bindings 1..4 of kinds %d %d %d %d", integrators[i].name, kinds[1],
                     kinds[2], kinds[3], kinds[4]);
        PF_CHECK(kinds[0] == PF_VK_BINDING_STORAGE && kinds[5] == PF_VK_BINDING_STORAGE &&
                 kinds[6] == PF_VK_BINDING_STORAGE);
        /* The plain variant reads no texture; the "_surfaces" one has the same bindings
         * otherwise, and corners as float texels, the texture table as records, the texels
         * as words (pf_scene.h PF_SURFACE_*). */
        PF_CHECK(kinds[PF_SCENE_BINDING_CORNERS] == PF_VK_BINDING_STORAGE &&
                 kinds[PF_SCENE_BINDING_TEXTURES] == PF_VK_BINDING_STORAGE &&
                 kinds[PF_SCENE_BINDING_TEXELS] == PF_VK_BINDING_STORAGE);
        char surfaces[64];
        snprintf(surfaces, sizeof surfaces, "%s_surfaces", integrators[i].name);
        uint8_t variant[ALL];
        kinds_of(surfaces, variant, ALL);
        for (int b = 0; b < ALL; b++)
            if (b < PF_SCENE_BINDING_CORNERS || b > PF_SCENE_BINDING_TEXELS)
                PF_CHECK_MSG(variant[b] == kinds[b], "%s: binding %d of kind %d, plain %d",
                             surfaces, b, variant[b], kinds[b]);
        PF_CHECK_MSG(variant[PF_SCENE_BINDING_CORNERS] == PF_VK_BINDING_TEXEL_FLOAT &&
                         variant[PF_SCENE_BINDING_TEXTURES] == PF_VK_BINDING_TEXEL_INT4 &&
                         variant[PF_SCENE_BINDING_TEXELS] == PF_VK_BINDING_TEXEL_UINT,
                     "%s: texture bindings of kinds %d %d %d", surfaces,
                     variant[PF_SCENE_BINDING_CORNERS], variant[PF_SCENE_BINDING_TEXTURES],
                     variant[PF_SCENE_BINDING_TEXELS]);
    }
    uint8_t kinds[ALL];
    kinds_of("render_final", kinds, ALL);
    PF_CHECK(kinds[S + 3] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 4] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 5] == PF_VK_BINDING_TEXEL_UINT); /* BIH_BINDING */
    /* Records and ranges of the map (S+8, S+9) and the points (S+11, S+12); their flux. */
    PF_CHECK(kinds[S + 8] == PF_VK_BINDING_TEXEL_INT4 && kinds[S + 9] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 11] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[S + 12] == PF_VK_BINDING_TEXEL_INT4);
    PF_CHECK(kinds[S + 15] == PF_VK_BINDING_TEXEL_UINT && kinds[S + 16] == PF_VK_BINDING_TEXEL_UINT);
    PF_CHECK(kinds[S] == PF_VK_BINDING_STORAGE && kinds[S + 6] == PF_VK_BINDING_STORAGE &&
             kinds[S + 13] == PF_VK_BINDING_STORAGE); /* film, vertices, deferred estimates */
    for (int b = S + 17; b < S + 23; b++) /* the same buffers' texel views, for reading */
        PF_CHECK(kinds[b] == PF_VK_BINDING_TEXEL_INT4);
    /* The rays the host traces (host_rays.glsl): rays and queue written, hits read as
     * words. */
    PF_CHECK(kinds[S + 23] == PF_VK_BINDING_STORAGE && kinds[S + 24] == PF_VK_BINDING_TEXEL_UINT &&
             kinds[S + 25] == PF_VK_BINDING_STORAGE);
    kinds_of("photon_trace", kinds, S + 13);
    PF_CHECK(kinds[1] == PF_VK_BINDING_TEXEL_FLOAT && kinds[4] == PF_VK_BINDING_TEXEL_INT4 &&
             kinds[6] == PF_VK_BINDING_STORAGE); /* scene_geometry.glsl; the emitters */
    PF_CHECK(kinds[S] == PF_VK_BINDING_TEXEL_INT4 && kinds[S + 1] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 2] == PF_VK_BINDING_TEXEL_UINT); /* BIH_BINDING */
    /* The waves (photon_trace_wave.c): state, rays and queue written; the hits and the active
     * photons read as words, the state and rays as float texels. */
    PF_CHECK(kinds[S + 6] == PF_VK_BINDING_STORAGE && kinds[S + 7] == PF_VK_BINDING_STORAGE &&
             kinds[S + 8] == PF_VK_BINDING_TEXEL_UINT && kinds[S + 9] == PF_VK_BINDING_STORAGE &&
             kinds[S + 10] == PF_VK_BINDING_TEXEL_UINT &&
             kinds[S + 11] == PF_VK_BINDING_TEXEL_FLOAT &&
             kinds[S + 12] == PF_VK_BINDING_TEXEL_FLOAT);
    kinds_of("render_fast", kinds, S + 13);
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
