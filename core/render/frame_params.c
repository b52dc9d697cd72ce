/*
 * The FrameParams every integrator uploads (render_internal.h), and the ray
 * offset they and the photon tracer start secondary rays with.
 */
#include "render_internal.h"

#include <string.h>

/*
 * Secondary rays start this far (relative to the scene's magnitude) off the
 * surface along its geometric normal: ~800 float ulps at the largest
 * coordinate, safely past self-intersection, far below any feature size of
 * the shipped scenes.
 */
#define RAY_OFFSET_RELATIVE 1e-4f

float pf_render_ray_offset(const pf_scene_frame *frame)
{
    return RAY_OFFSET_RELATIVE * pf_scene_frame_magnitude(frame);
}

uint64_t pf_seed_mix(uint64_t seed, uint64_t index)
{
    uint64_t z = seed + 0x9e3779b97f4a7c15ull * (index + 1ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

void pf_frame_params_fill(const pf_scene_frame *frame, const pf_render_settings *settings,
                          uint32_t spp, const pf_gpu_scene *scene, const pf_bih_gpu_view *bih,
                          pf_frame_params *params)
{
    memset(params, 0, sizeof *params);
    const pf_camera *camera = &frame->camera;
    float tan_half_x = 0.0f, tan_half_y = 0.0f;
    uint32_t image_height = pf_render_image_height(settings);
    pf_camera_image_plane(camera, settings->width, image_height, &tan_half_x, &tan_half_y);
    for (int i = 0; i < 3; i++) {
        params->camera_position[i] = camera->position[i];
        params->camera_forward[i] = camera->forward[i];
        params->camera_right[i] = camera->right[i];
        params->camera_up[i] = camera->up[i];
    }
    params->camera_position[3] = tan_half_x;
    params->camera_forward[3] = tan_half_y;
    params->camera_right[3] = pf_render_ray_offset(frame);
    params->camera_up[3] = camera->orthographic ? 1.0f : 0.0f;
    params->width = settings->width;
    params->height = settings->height;
    params->row_offset = settings->band_row_first;
    params->image_height = image_height;
    params->samples_per_pixel = spp;
    params->triangle_count = frame->triangle_count;
    params->light_count = frame->light_count;
    params->emissive_count = scene->emissive_count;
    params->emissive_weight_total = scene->emissive_weight_total;
    uint64_t seed = settings->seed;
    if (settings->sample_salt && pf_denoise_temporal(settings->denoise, settings->quality))
        seed = pf_seed_mix(seed, settings->sample_salt);
    params->seed_lo = (uint32_t)seed;
    params->seed_hi = (uint32_t)(seed >> 32);
    params->pixel_filter = (uint32_t)settings->pixel_filter;
    params->max_bounces = settings->bounce_limit ? settings->bounce_limit - 1u : 0xffffffffu;
    params->bih_node_count = bih->node_count;
    for (int i = 0; i < 3; i++) {
        params->bih_bounds_min[i] = bih->bounds_min[i];
        params->bih_bounds_max[i] = bih->bounds_max[i];
    }
}

