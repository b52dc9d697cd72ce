/*
 * The preview integrator (shaders/render_direct.comp): uploads the frame's
 * scene, renders the image tile by tile, reads each tile back into the
 * pf_image and reports the `shade` stage.
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/*
 * Pixels per tile edge. One submission per tile (a dispatch per sample) keeps
 * each submission short on a slow CPU device (lavapipe) and the film buffer
 * small (64×64×48 B = 192 KiB) whatever the image size.
 */
#define RENDER_TILE_EDGE 64u
/* Workgroup edge of render_direct.comp (local_size 8×8). */
#define RENDER_GROUP_EDGE 8u
/* vec4 per pixel in the film: beauty+coverage, albedo+depth, normal+kept samples (sums). */
#define FILM_VEC4_PER_PIXEL 3u
/* Longest mirror/glass chain a camera ray follows before giving up. */
#define MAX_SPECULAR_DEPTH 8u

static const char *const beauty_channels[] = {"R", "G", "B", "A"};
static const char *const aov_channels[] = {"R",        "G",        "B",        "A",
                                           "albedo.R", "albedo.G", "albedo.B", "normal.X",
                                           "normal.Y", "normal.Z", "depth.Z"};

typedef struct render_push {
    uint32_t tile_origin[2];
    uint32_t tile_size[2];
    uint32_t sample_index;
} render_push;

typedef struct render_counters {
    uint32_t discarded_samples;
    uint32_t rays_traced;
    uint32_t traversal_failures; /* rays whose BIH traversal overflowed its stack */
    uint32_t padding;
} render_counters;

/* render_direct.comp's bindings: params, 6 scene arrays, film, counters, 3 BIH buffers. */
#define RENDER_BUFFERS (PF_SCENE_BINDING_COUNT + 5u)

/*
 * Turns one tile of film sums into pixel values: beauty averaged over the
 * kept (finite) samples, alpha and the AOVs over all samples.
 */
static void film_to_image(const float *film, const render_push *tile, uint32_t spp, int aovs,
                          pf_image *image)
{
    float inverse_spp = 1.0f / (float)spp;
    for (uint32_t y = 0; y < tile->tile_size[1]; y++) {
        for (uint32_t x = 0; x < tile->tile_size[0]; x++) {
            const float *texel = film + 4 * FILM_VEC4_PER_PIXEL * (y * tile->tile_size[0] + x);
            size_t pixel = (size_t)(tile->tile_origin[1] + y) * image->width + tile->tile_origin[0] + x;
            float *out = image->pixels + pixel * image->channel_count;
            float kept = texel[11];
            for (int c = 0; c < 3; c++)
                out[c] = kept > 0.0f ? texel[c] / kept : 0.0f;
            out[3] = texel[3] * inverse_spp;
            if (aovs) {
                for (int c = 0; c < 3; c++) {
                    out[4 + c] = texel[4 + c] * inverse_spp; /* albedo */
                    out[7 + c] = texel[8 + c] * inverse_spp; /* normal */
                }
                out[10] = texel[7] * inverse_spp; /* depth */
            }
        }
    }
}

/*
 * Renders one tile: one dispatch per sample (each adds to the film) and the
 * readbacks, one submission and one wait. Adds its GPU time to *gpu_ms.
 */
static pf_status render_tile(pf_renderer *renderer, pf_vk_buffer *const *buffers,
                             const render_push *tile, uint32_t spp, pf_vk_commands *setup,
                             float *film, render_counters *counters, double *gpu_ms,
                             pf_error *err)
{
    pf_vk_context *ctx = renderer->ctx;
    static const render_counters zero = {0, 0, 0, 0};
    /* The counters zeroed, the samples and the readbacks: one submission (issue 44), the
     * frame's setup (setup: the scene's and parameters' uploads, taken) in the first. */
    pf_vk_commands *cmds = setup;
    pf_vk_pipeline *pipeline = NULL;
    pf_status status = pf_renderer_pipeline(renderer, PF_PIPELINE_DIRECT, &pipeline, err);
    if (status == PF_OK && !cmds)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(cmds);
        return status;
    }
    status = pf_vk_cmd_upload(cmds, buffers[PF_SCENE_BINDING_COUNT + 1], 0, &zero, sizeof zero,
                              err);
    int begin = pf_vk_cmd_timestamp(cmds);
    for (uint32_t sample = 0; status == PF_OK && sample < spp; sample++) {
        render_push push = *tile;
        push.sample_index = sample;
        if (sample > 0)
            pf_vk_cmd_barrier(cmds); /* the previous sample's film sums are read */
        status = pf_vk_cmd_dispatch(
            cmds, pipeline, buffers, RENDER_BUFFERS, &push, sizeof push,
            (tile->tile_size[0] + RENDER_GROUP_EDGE - 1) / RENDER_GROUP_EDGE,
            (tile->tile_size[1] + RENDER_GROUP_EDGE - 1) / RENDER_GROUP_EDGE, 1, err);
    }
    int end = pf_vk_cmd_timestamp(cmds);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buffers[PF_SCENE_BINDING_COUNT], 0, film,
                                    (uint64_t)tile->tile_size[0] * tile->tile_size[1] *
                                        FILM_VEC4_PER_PIXEL * 4 * sizeof(float),
                                    err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, buffers[PF_SCENE_BINDING_COUNT + 1], 0, counters,
                                    sizeof *counters, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK)
        pf_gpu_ms_add(gpu_ms, pf_commands_gpu_ms(cmds, begin, end));
    pf_vk_commands_destroy(cmds);
    return status;
}

/* preview's one stage after the BIH: shade, tile by tile, into the image. */
static pf_status preview_run(pf_frame_run *run, pf_stage_id stage, uint32_t pass, pf_error *err)
{
    (void)pass;
    if (stage != PF_STAGE_SHADE)
        return pf_error_set(err, PF_ERR_INTERNAL, "preview has no stage %s",
                            pf_stage_name(stage));
    pf_renderer *renderer = run->renderer;
    const pf_scene_frame *frame = run->frame;
    const pf_render_settings *settings = run->settings;
    const pf_stage_plan *plan = run->plan;
    pf_image *image = run->image;
    pf_frame_report *report = run->report;
    pf_status status;
    uint32_t spp = plan->samples;
    pf_vk_context *ctx = renderer->ctx;

    status = settings->aovs
                 ? pf_image_create(image, settings->width, settings->height,
                                   sizeof aov_channels / sizeof aov_channels[0], aov_channels, err)
                 : pf_image_create(image, settings->width, settings->height,
                                   sizeof beauty_channels / sizeof beauty_channels[0],
                                   beauty_channels, err);
    if (status != PF_OK)
        return status;

    double shade_start = pf_time_ms();
    pf_bih_gpu_view bih;
    status = pf_bih_gpu_view_get(renderer->bih_gpu, &bih, err);
    if (status != PF_OK) {
        pf_image_free(image);
        return status;
    }

    pf_gpu_scene scene;
    pf_vk_buffer *params_buffer = NULL, *film_buffer = NULL, *counter_buffer = NULL;
    const uint64_t film_bytes =
        (uint64_t)RENDER_TILE_EDGE * RENDER_TILE_EDGE * FILM_VEC4_PER_PIXEL * 4 * sizeof(float);
    float *film = malloc(film_bytes);
    pf_frame_params params;
    uint64_t rays = 0, discarded = 0, failures = 0;
    double gpu_ms = -1.0;

    /* The scene's and the parameters' uploads go with the first tile (issue 44). */
    pf_vk_commands *setup = NULL;
    status = film ? pf_vk_commands_begin(ctx, &setup, err)
                  : pf_error_set(err, PF_ERR_NOMEM, "film tile: out of memory");
    if (status == PF_OK)
        status = pf_gpu_scene_record(ctx, setup, frame, 1, &renderer->textures, &scene, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(setup);
        free(film);
        pf_image_free(image);
        return status;
    }
    pf_frame_params_fill(frame, settings, spp, &scene, &bih, &params);
    params.max_specular_depth = MAX_SPECULAR_DEPTH;
    status = pf_render_buffer_recorded(ctx, setup, "frame parameters", &params, sizeof params,
                                       sizeof params, &params_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, film_bytes, "film tile", &film_buffer, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, sizeof(render_counters), "render counters",
                                     &counter_buffer, err);
    pf_vk_buffer *own[] = {film_buffer, counter_buffer, bih.nodes, bih.vertices,
                           bih.triangle_index};
    pf_vk_buffer *buffers[RENDER_BUFFERS];
    pf_gpu_scene_bindings(&scene, params_buffer, own, sizeof own / sizeof *own, buffers);
    for (uint32_t y = 0; status == PF_OK && y < settings->height; y += RENDER_TILE_EDGE) {
        for (uint32_t x = 0; status == PF_OK && x < settings->width; x += RENDER_TILE_EDGE) {
            render_push tile = {{x, y},
                                {settings->width - x < RENDER_TILE_EDGE ? settings->width - x
                                                                        : RENDER_TILE_EDGE,
                                 settings->height - y < RENDER_TILE_EDGE ? settings->height - y
                                                                         : RENDER_TILE_EDGE},
                                0};
            render_counters counters;
            status = render_tile(renderer, buffers, &tile, spp, setup, film, &counters, &gpu_ms,
                                 err);
            setup = NULL; /* render_tile took it */
            if (status == PF_OK) {
                film_to_image(film, &tile, spp, settings->aovs, image);
                rays += counters.rays_traced;
                discarded += counters.discarded_samples;
                failures += counters.traversal_failures;
            }
        }
    }
    pf_vk_commands_destroy(setup); /* not taken: a failure before the first tile */
    free(film);
    pf_render_buffer_release(ctx, &counter_buffer);
    pf_render_buffer_release(ctx, &film_buffer);
    pf_render_buffer_release(ctx, &params_buffer);
    pf_gpu_scene_release(ctx, &scene);
    if (status == PF_OK)
        status = pf_render_check_traversal(renderer, failures, err);
    if (status != PF_OK) {
        pf_image_free(image);
        pf_error_prefix(err, "render (%ux%u, %u spp, %u triangles)", settings->width,
                        settings->height, spp, frame->triangle_count);
        return status;
    }
    if (report) {
        report->discarded_samples += discarded;
        pf_stage_timing *row = pf_frame_report_add(report, "shade");
        if (row) {
            snprintf(row->reason, sizeof row->reason, "%s", plan->stages[PF_STAGE_SHADE].reason);
            row->wall_ms = pf_time_ms() - shade_start;
            row->gpu_ms = gpu_ms;
            pf_stage_add_counter(row, "rays", (double)rays);
            pf_stage_add_light_samples(row, frame->light_count, PF_DIRECT_LIGHT_PIXEL_SAMPLES);
            pf_stage_add_counter(row, "triangles", frame->triangle_count);
            pf_stage_add_counter(row, "samples_per_pixel", spp);
            pf_stage_add_counter(row, "discarded_samples", (double)discarded);
        }
    }
    return PF_OK;
}

/* preview: one stage after the BIH, which readies, shades and reports by itself. */
const pf_integrator pf_integrator_preview = {0, NULL, preview_run, NULL};
