#include "photon_test_box.h"

#include <stdlib.h>
#include <string.h>

void box_add_quad(box_scene *s, const float a[3], const float b[3], const float c[3],
                  const float d[3], uint32_t material)
{
    const float *corners[6] = {a, b, c, a, c, d};
    uint32_t t = s->frame.triangle_count;
    for (int i = 0; i < 6; i++) {
        for (int k = 0; k < 3; k++)
            s->vertices[3 * t + i][k] = corners[i][k];
        s->vertices[3 * t + i][3] = 0.0f;
    }
    s->triangle_material[t] = s->triangle_material[t + 1] = material;
    s->frame.triangle_count += 2;
}

void box_init(box_scene *s, float albedo)
{
    memset(s, 0, sizeof *s);
    s->frame.vertices = s->vertices;
    s->frame.normals = s->normals; /* all zero: the face normal is used */
    s->frame.triangle_material = s->triangle_material;
    s->frame.materials = s->materials;
    s->frame.material_count = 2;
    s->frame.lights = s->lights;
    s->materials[0] = pf_material_lambert(albedo, albedo, albedo);
    s->materials[1] = pf_material_mirror(1, 1, 1);
    const float p[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                           {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    const int faces[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                             {3, 2, 6, 7}, {0, 3, 7, 4}, {1, 5, 6, 2}};
    for (int f = 0; f < 6; f++)
        box_add_quad(s, p[faces[f][0]], p[faces[f][1]], p[faces[f][2]], p[faces[f][3]], 0);
    for (int k = 0; k < 3; k++) {
        s->frame.bounds_min[k] = -1.0f;
        s->frame.bounds_max[k] = 1.0f;
    }
}

pf_status box_trace(box_tracer *t, const box_scene *s, const pf_photon_trace_settings *settings,
                    pf_photon_maps *maps, pf_photon **global, pf_photon **caustic, pf_error *err)
{
    pf_vk_context *ctx = t->ctx;
    const pf_scene_frame *frame = &s->frame;
    pf_vk_buffer *buffers[5] = {0};
    /* The materials buffer as the kernels read it: the sheen's tables first. */
    uint32_t material_count = sizeof s->materials / sizeof s->materials[0];
    uint64_t material_bytes = pf_materials_buffer_bytes(material_count);
    void *materials = malloc(material_bytes);
    if (!materials)
        return pf_error_set(err, PF_ERR_NOMEM, "test scene: out of memory");
    pf_materials_buffer_write(s->materials, material_count, materials);
    const void *data[5] = {frame->vertices, frame->normals, frame->triangle_material, materials,
                           frame->lights};
    uint64_t sizes[5] = {(uint64_t)frame->triangle_count * 48, (uint64_t)frame->triangle_count * 48,
                         (uint64_t)frame->triangle_count * 4, material_bytes, sizeof s->lights};
    pf_status status = PF_OK;
    for (int i = 0; status == PF_OK && i < 5; i++) {
        status = pf_vk_buffer_create(ctx, sizes[i], "test scene", &buffers[i], err);
        if (status == PF_OK)
            status = pf_vk_buffer_upload(ctx, buffers[i], 0, data[i], sizes[i], err);
    }
    free(materials);
    pf_bih bih;
    pf_bih_build_options options = {0};
    if (status == PF_OK)
        status = pf_bih_build_cpu(frame, &options, &bih, err);
    int built = status == PF_OK;
    if (status == PF_OK)
        status = pf_bih_gpu_upload(t->bih_gpu, &bih, err);
    pf_photon_scene scene = {buffers[0], buffers[1], buffers[2], buffers[3], buffers[4],
                             frame->triangle_count, {0}, 1e-4f};
    if (status == PF_OK)
        status = pf_bih_gpu_view_get(t->bih_gpu, &scene.bih, err);
    pf_photon_emitters emitters = {0};
    if (status == PF_OK)
        status = pf_photon_emitters_build(frame, &emitters, err);
    pf_photon_trace_settings traced = *settings;
    if (t->host_traces)
        traced.host_tree = &bih;
    if (status == PF_OK)
        status = pf_photon_trace(t->tracer, &scene, &emitters, &traced, maps, err);
    if (built)
        pf_bih_free(&bih);
    if (status == PF_OK && global)
        status = pf_photon_map_download(ctx, maps->global, maps->global_count, global, err);
    if (status == PF_OK && caustic)
        status = pf_photon_map_download(ctx, maps->caustic, maps->caustic_count, caustic, err);
    pf_photon_emitters_free(&emitters);
    for (int i = 0; i < 5; i++) {
        if (buffers[i])
            pf_vk_buffer_destroy(ctx, buffers[i]);
    }
    return status;
}

void box_flux_sum(const pf_photon *photons, uint32_t count, double scale, double sum[3])
{
    sum[0] = sum[1] = sum[2] = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        float position[3], flux[3], incoming[3], normal[3];
        pf_photon_unpack(&photons[i], position, flux, incoming, normal);
        for (int c = 0; c < 3; c++)
            sum[c] += flux[c] * scale;
    }
}
