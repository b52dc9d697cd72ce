/*
 * The film the split integrators (reference, final, fast) accumulate and
 * the image it becomes: the channel layout pf_render.h promises for them
 * (beauty = direct + indirect, caustic ⊆ indirect, optional AOVs).
 */
#include "render_internal.h"

#include <stdio.h>
#include <stdlib.h>

static const char *const split_channels[] = {
    "R",          "G",          "B",         "A",         "direct.R",   "direct.G",
    "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
    "caustic.B",  "albedo.R",   "albedo.G",  "albedo.B",  "normal.X",   "normal.Y",
    "normal.Z",   "depth.Z"};
/* Channels without AOVs: everything before albedo.R. */
#define SPLIT_BEAUTY_CHANNELS 13u

pf_status pf_split_image_create(pf_image *image, uint32_t width, uint32_t height, int aovs,
                                pf_error *err)
{
    return pf_image_create(image, width, height,
                           aovs ? sizeof split_channels / sizeof split_channels[0]
                                : SPLIT_BEAUTY_CHANNELS,
                           split_channels, err);
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

pf_status pf_split_film_record_read(pf_vk_commands *cmds, pf_vk_buffer *film,
                                    pf_vk_buffer *film_aov, int aovs, const pf_image *image,
                                    pf_split_film_readback *out, pf_error *err)
{
    uint64_t pixels = (uint64_t)image->width * image->height;
    uint64_t film_bytes = pixels * PF_SPLIT_FILM_VEC4_PER_PIXEL * 16;
    uint64_t aov_bytes = aovs ? pixels * PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL * 16 : 16;
    out->aovs = aovs;
    out->film = malloc(film_bytes);
    out->film_aov = malloc(aov_bytes);
    pf_status status = out->film && out->film_aov
                           ? PF_OK
                           : pf_error_set(err, PF_ERR_NOMEM, "film: out of memory (%llu bytes)",
                                          (unsigned long long)(film_bytes + aov_bytes));
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, film, 0, out->film, film_bytes, err);
    if (status == PF_OK && aovs)
        status = pf_vk_cmd_download(cmds, film_aov, 0, out->film_aov, aov_bytes, err);
    if (status != PF_OK)
        pf_split_film_readback_free(out);
    return status;
}

void pf_split_film_finish_read(pf_split_film_readback *readback, int aov_own_count,
                               pf_image *image)
{
    pf_split_film_to_image(readback->film, readback->film_aov, readback->aovs, aov_own_count,
                           image);
    pf_split_film_readback_free(readback);
}

void pf_split_film_readback_free(pf_split_film_readback *readback)
{
    free(readback->film);
    free(readback->film_aov);
    readback->film = readback->film_aov = NULL;
}

pf_status pf_split_film_read(pf_vk_context *ctx, pf_vk_buffer *film, pf_vk_buffer *film_aov,
                             int aovs, int aov_own_count, pf_image *image, pf_error *err)
{
    pf_vk_commands *cmds = NULL;
    pf_split_film_readback readback = {0};
    pf_status status = pf_vk_commands_begin(ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_split_film_record_read(cmds, film, film_aov, aovs, image, &readback, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    if (status == PF_OK)
        pf_split_film_finish_read(&readback, aov_own_count, image);
    else
        pf_split_film_readback_free(&readback);
    return status;
}
