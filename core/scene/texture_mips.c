/*
 * A texture's mip chain, built once at load: each level averages 2×2 texels
 * of the one above (a box filter; an odd edge's last texel is counted in the
 * pair it closes), in linear light. An sRGB slot's texels are decoded before
 * averaging and encoded again after, as a GPU's sRGB formats do: averaging
 * the encoded values would darken every level below the first (the mean of
 * 0 and 1 encoded is 0.5, i.e. 0.21 linear, not 0.5).
 * Alpha is always linear.
 */
#include "scene_internal.h"

#include <math.h>
#include <stdlib.h>

float scene_srgb_to_linear(float c)
{
    return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
}

float scene_linear_to_srgb(float c)
{
    return c <= 0.0031308f ? 12.92f * c : 1.055f * powf(c, 1.0f / 2.4f) - 0.055f;
}

uint32_t scene_mip_levels(uint32_t width, uint32_t height)
{
    uint32_t edge = width > height ? width : height, levels = 1;
    while (edge > 1) {
        edge >>= 1;
        levels++;
    }
    return levels;
}

uint64_t scene_mip_chain_texels(uint32_t width, uint32_t height, uint32_t levels)
{
    uint64_t total = 0;
    for (uint32_t k = 0; k < levels; k++) {
        uint32_t w = width >> k ? width >> k : 1, h = height >> k ? height >> k : 1;
        total += (uint64_t)w * h;
    }
    return total;
}

static uint32_t pack(const float rgba[4], int srgb)
{
    uint32_t word = 0;
    for (int c = 0; c < 4; c++) {
        float v = srgb && c < 3 ? scene_linear_to_srgb(rgba[c]) : rgba[c];
        v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
        word |= (uint32_t)lrintf(v * 255.0f) << (8 * c);
    }
    return word;
}

pf_status scene_mip_chain_build(const uint8_t *rgba, uint32_t width, uint32_t height,
                                uint32_t levels, int srgb, uint32_t *out, pf_error *err)
{
    float table[256];
    for (int i = 0; i < 256; i++)
        table[i] = srgb ? scene_srgb_to_linear(i / 255.0f) : i / 255.0f;
    size_t count = (size_t)width * height;
    /* Level 0 as given; the linear copy the next levels average. */
    float(*linear)[4] = malloc(count * sizeof *linear);
    if (!linear)
        return pf_error_set(err, PF_ERR_NOMEM, "mip chain of a %ux%u texture: out of memory",
                            width, height);
    for (size_t i = 0; i < count; i++) {
        out[i] = (uint32_t)rgba[4 * i] | (uint32_t)rgba[4 * i + 1] << 8 |
                 (uint32_t)rgba[4 * i + 2] << 16 | (uint32_t)rgba[4 * i + 3] << 24;
        for (int c = 0; c < 4; c++)
            linear[i][c] = c < 3 ? table[rgba[4 * i + c]] : rgba[4 * i + c] / 255.0f;
    }
    uint32_t *level_out = out + count;
    uint32_t w = width, h = height;
    for (uint32_t k = 1; k < levels; k++) {
        uint32_t nw = w > 1 ? w / 2 : 1, nh = h > 1 ? h / 2 : 1;
        /* In place: texel (x, y) of the new level reads rows 2y.. and columns 2x.. of the old,
         * which no earlier new texel has overwritten (its index is at most theirs). */
        for (uint32_t y = 0; y < nh; y++) {
            uint32_t y0 = h > 1 ? 2 * y : 0, y1 = y == nh - 1 ? h : y0 + (h > 1 ? 2 : 1);
            for (uint32_t x = 0; x < nw; x++) {
                uint32_t x0 = w > 1 ? 2 * x : 0, x1 = x == nw - 1 ? w : x0 + (w > 1 ? 2 : 1);
                float sum[4] = {0, 0, 0, 0};
                for (uint32_t yy = y0; yy < y1; yy++)
                    for (uint32_t xx = x0; xx < x1; xx++)
                        for (int c = 0; c < 4; c++)
                            sum[c] += linear[(size_t)yy * w + xx][c];
                float n = (float)((y1 - y0) * (x1 - x0));
                for (int c = 0; c < 4; c++)
                    sum[c] /= n;
                size_t at = (size_t)y * nw + x;
                for (int c = 0; c < 4; c++)
                    linear[at][c] = sum[c];
                level_out[at] = pack(sum, srgb);
            }
        }
        level_out += (size_t)nw * nh;
        w = nw;
        h = nh;
    }
    free(linear);
    return PF_OK;
}
