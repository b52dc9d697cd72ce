/*
 * The film the split integrators (reference, final, fast) accumulate and
 * the image it becomes: the channel layout pf_render.h promises for them
 * (beauty = direct + indirect, caustic ⊆ indirect, optional AOVs).
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const split_channels[] = {
    "R",          "G",          "B",         "A",         "direct.R",   "direct.G",
    "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
    "caustic.B",  "albedo.R",   "albedo.G",  "albedo.B",  "normal.X",   "normal.Y",
    "normal.Z",   "depth.Z"};
/* Channels without AOVs: everything before albedo.R. */
#define SPLIT_BEAUTY_CHANNELS 13u

const char *const pf_motion_channels[2] = {"motion.X", "motion.Y"};
const char *const pf_noisy_channels[4] = {"noisy.R", "noisy.G", "noisy.B", "variance.Y"};

pf_status pf_split_image_create(pf_image *image, uint32_t width, uint32_t height, int aovs,
                                uint32_t later_layers, pf_error *err)
{
    const char *names[sizeof split_channels / sizeof split_channels[0] + 6];
    uint32_t count = aovs ? sizeof split_channels / sizeof split_channels[0]
                          : SPLIT_BEAUTY_CHANNELS;
    memcpy(names, split_channels, count * sizeof *names);
    /* In the order the stages run: motion, then denoise. */
    if (later_layers & PF_LATER_LAYER_MOTION)
        for (uint32_t c = 0; c < 2; c++)
            names[count++] = pf_motion_channels[c];
    if (later_layers & PF_LATER_LAYER_NOISY)
        for (uint32_t c = 0; c < 4; c++)
            names[count++] = pf_noisy_channels[c];
    return pf_image_create(image, width, height, count, names, err);
}

pf_status pf_image_later_layer(pf_image *image, const char *const *names, uint32_t count,
                               uint32_t *first, pf_error *err)
{
    int at = pf_image_channel(image, names[0]);
    int in_place = at >= 0;
    for (uint32_t c = 1; in_place && c < count; c++)
        in_place = pf_image_channel(image, names[c]) == at + (int)c;
    if (in_place) {
        *first = (uint32_t)at;
        return PF_OK;
    }
    pf_image grown = {0};
    pf_status status = pf_image_append_channels(image, names, count, &grown, err);
    if (status != PF_OK)
        return status;
    *first = image->channel_count;
    pf_image_free(image);
    *image = grown;
    return PF_OK;
}

void pf_split_film_to_image(const float *film, const float *film_aov, int aovs,
                            int aov_own_count, pf_image *image)
{
    size_t pixels = (size_t)image->width * image->height;
    for (size_t p = 0; p < pixels; p++) {
        const float *texel = film + 4 * PF_SPLIT_FILM_VEC4_PER_PIXEL * p;
        float *out = image->pixels + p * image->channel_count;
        float kept = texel[7];
        float inverse = kept > 0.0f ? 1.0f / kept : 0.0f;
        for (int c = 0; c < 3; c++) {
            float direct = texel[c] * inverse;
            float indirect = texel[4 + c] * inverse;
            out[c] = direct + indirect;
            out[4 + c] = direct;
            out[7 + c] = indirect;
            out[10 + c] = texel[8 + c] * inverse;
        }
        out[3] = texel[3] * inverse;
        if (aovs) {
            const float *aov = film_aov + 4 * PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL * p;
            float aov_inverse = !aov_own_count ? inverse
                                : aov[7] > 0.0f ? 1.0f / aov[7]
                                                : 0.0f;
            for (int c = 0; c < 3; c++) {
                out[13 + c] = aov[c] * aov_inverse;     /* albedo */
                out[16 + c] = aov[4 + c] * aov_inverse; /* normal */
            }
            out[19] = aov[3] * aov_inverse; /* depth */
        }
    }
}

pf_status pf_split_film_create(pf_vk_context *ctx, const pf_render_settings *settings,
                               int full_aov, const char *integrator, pf_vk_buffer **film,
                               pf_vk_buffer **film_aov, pf_error *err)
{
    uint64_t pixels = (uint64_t)settings->width * settings->height;
    uint64_t aov_bytes = full_aov ? pixels * PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL * 16 : 16;
    char label[64];
    snprintf(label, sizeof label, "%s film", integrator);
    pf_status status =
        pf_vk_buffer_create(ctx, pixels * PF_SPLIT_FILM_VEC4_PER_PIXEL * 16, label, film, err);
    snprintf(label, sizeof label, "%s AOV film", integrator);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, aov_bytes, label, film_aov, err);
    return status;
}

pf_status pf_split_film_record_read(pf_renderer *renderer, pf_vk_commands *cmds,
                                    pf_vk_buffer *film, pf_vk_buffer *film_aov, int aovs,
                                    int aov_own_count, pf_image *image,
                                    pf_split_film_readback *out, pf_error *err)
{
    *out = (pf_split_film_readback){renderer->ctx, NULL, 0};
    uint64_t row_bytes = (uint64_t)image->width * image->channel_count * sizeof *image->pixels;
    /* Bands of rows, each in a buffer of its own within the device's storage-buffer range
     * (a 1920x1080 image with AOVs is 158 MiB, lavapipe binds 128): each band's download
     * lands in its own rows of the image, even where downloads are copies made after the
     * submission (mapped memory). */
    uint64_t range = pf_vk_info(renderer->ctx)->max_storage_buffer_range;
    uint32_t band_rows = range / row_bytes < image->height ? (uint32_t)(range / row_bytes)
                                                           : image->height;
    if (band_rows == 0)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "an image row of %llu bytes exceeds the device's storage-buffer "
                            "range (%llu bytes)",
                            (unsigned long long)row_bytes, (unsigned long long)range);
    uint32_t band_count = (image->height + band_rows - 1) / band_rows;
    pf_vk_pipeline *split = NULL;
    pf_status status = pf_renderer_pipeline(renderer, PF_PIPELINE_SPLIT_FILM, &split, err);
    if (status != PF_OK)
        return status;
    out->bands = calloc(band_count, sizeof *out->bands);
    if (!out->bands)
        return pf_error_set(err, PF_ERR_NOMEM, "split image: out of memory");
    out->band_count = band_count;
    pf_vk_cmd_barrier(cmds); /* after the kernels that filled the film */
    for (uint32_t band = 0; band < band_count && status == PF_OK; band++) {
        uint32_t row_first = band * band_rows;
        uint32_t rows = image->height - row_first < band_rows ? image->height - row_first
                                                              : band_rows;
        status = pf_vk_buffer_create(renderer->ctx, rows * row_bytes, "split image band",
                                     &out->bands[band], err);
        struct {
            uint32_t width, height, aovs, aov_own_count, row_first, channels;
        } push = {image->width, rows,      aovs ? 1u : 0u, aov_own_count ? 1u : 0u,
                  row_first,   image->channel_count};
        pf_vk_buffer *buffers[3] = {film, film_aov, out->bands[band]};
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, split, buffers, 3, &push, sizeof push,
                                        (image->width + 63u) / 64u, rows, 1, err);
    }
    pf_vk_cmd_barrier(cmds);
    for (uint32_t band = 0; band < band_count && status == PF_OK; band++) {
        uint64_t row_first = (uint64_t)band * band_rows;
        uint64_t rows = image->height - row_first < band_rows ? image->height - row_first
                                                              : band_rows;
        status = pf_vk_cmd_download(cmds, out->bands[band], 0,
                                    image->pixels + row_first * row_bytes / sizeof *image->pixels,
                                    rows * row_bytes, err);
    }
    return status;
}

void pf_split_film_finish_read(pf_split_film_readback *readback)
{
    for (uint32_t band = 0; band < readback->band_count; band++)
        if (readback->bands[band])
            pf_vk_buffer_destroy(readback->ctx, readback->bands[band]);
    free(readback->bands);
    readback->bands = NULL;
    readback->band_count = 0;
}

pf_status pf_split_film_submit(pf_renderer *renderer, pf_vk_commands *cmds,
                               const pf_split_film_readback *readback, pf_error *err)
{
    void (*overlap)(void *, int) = readback->band_count > 0 ? renderer->overlap : NULL;
    if (overlap) {
        renderer->overlap = NULL;
        overlap(renderer->overlap_arg, PF_OVERLAP_PREPARE);
    }
    pf_status status = pf_vk_commands_submit_async(cmds, err);
    if (status == PF_OK && overlap)
        overlap(renderer->overlap_arg, PF_OVERLAP_RUN);
    return status == PF_OK ? pf_vk_commands_wait(cmds, err) : status;
}

pf_status pf_split_film_read(pf_renderer *renderer, pf_vk_buffer *film, pf_vk_buffer *film_aov,
                             int aovs, int aov_own_count, pf_image *image, pf_error *err)
{
    pf_vk_commands *cmds = NULL;
    pf_split_film_readback readback = {0};
    pf_status status = pf_vk_commands_begin(renderer->ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_split_film_record_read(renderer, cmds, film, film_aov, aovs, aov_own_count,
                                           image, &readback, err);
    if (status == PF_OK)
        status = pf_split_film_submit(renderer, cmds, &readback, err);
    pf_vk_commands_destroy(cmds);
    pf_split_film_finish_read(&readback);
    return status;
}
