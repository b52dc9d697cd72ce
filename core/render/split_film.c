/*
 * The film both progressive integrators (reference, final) accumulate and
 * the image it becomes: the channel layout pf_render.h promises for them
 * (beauty = direct + indirect, caustic ⊆ indirect, optional AOVs).
 */
#include "render_internal.h"

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
