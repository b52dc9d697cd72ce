/*
 * What the final and fast integrators share about photons: the device
 * inputs of a frame's photon pass (pf_photon_frame) and the scene figures
 * both size their photon radii by.
 */
#include "render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

float pf_photon_radius_for_density(const pf_scene_frame *frame, double neighbours,
                                   uint32_t stored, double fallback_fraction)
{
    double area = pf_scene_frame_area(frame);
    double radius = stored > 0 && area > 0.0 ? sqrt(neighbours * area / (3.14159265358979323846 *
                                                                         stored))
                                             : fallback_fraction * pf_scene_frame_diagonal(frame);
    return radius > 0.0 ? (float)radius : 1e-3f;
}

pf_status pf_photon_frame_prepare(pf_renderer *renderer, const pf_scene_frame *frame,
                                  const pf_photon_emitters *emitters, pf_photon_frame *out,
                                  pf_error *err)
{
    memset(out, 0, sizeof *out);
    out->emitters = emitters;
    pf_status status = pf_bih_gpu_view_get(renderer->bih_gpu, &out->bih, err);
    if (status == PF_OK && !renderer->photon_tracer)
        status = pf_photon_tracer_create(renderer->ctx, &renderer->photon_tracer, err);
    if (status == PF_OK)
        status = pf_gpu_scene_upload(renderer->ctx, frame, 1, &renderer->textures, &out->scene,
                                     err);
    if (status != PF_OK)
        return status;
    out->photons = (pf_photon_scene){out->scene.vertices,  out->scene.normals,
                                     out->scene.triangle_material, out->scene.materials,
                                     out->scene.lights,    frame->triangle_count,
                                     out->bih,             pf_render_ray_offset(frame),
                                     out->scene.corners,   out->scene.textures,
                                     out->scene.texels,
                                     pf_scene_frame_surface_features(frame)};
    out->tracer = renderer->photon_tracer;
    return PF_OK;
}

void pf_photon_frame_release(pf_vk_context *ctx, pf_photon_frame *photon_frame)
{
    pf_gpu_scene_release(ctx, &photon_frame->scene);
}

pf_status pf_photon_frame_trace(pf_renderer *renderer, const pf_photon_frame *inputs,
                                const pf_stage_plan *plan, pf_photon_trace_settings *trace,
                                uint32_t count, pf_photon_maps *maps, pf_error *err)
{
    pf_status status = PF_OK;
    const pf_bih *tree = NULL;
    const pf_bih_wide *wide = NULL;
    if (plan->host_traces) {
        status = pf_renderer_bih_host(renderer, &tree, err);
        if (status == PF_OK)
            status = pf_renderer_bih_wide(renderer, &wide, err);
    }
    for (uint32_t i = 0; status == PF_OK && i < count; i++) {
        trace[i].host_tree = tree;
        trace[i].host_wide = wide;
    }
    if (status == PF_OK)
        status = pf_photon_trace_passes(inputs->tracer, &inputs->photons, inputs->emitters,
                                        trace, count, maps, err);
    return status;
}
