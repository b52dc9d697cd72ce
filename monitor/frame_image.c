/* The monitor's preview of a rendered frame (frame_image.h): OpenEXR in, PNG out (spng). */
#include "frame_image.h"

#include "pf_image.h"

#include <math.h>
#include <spng.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* IEC 61966-2-1: linear [0, 1] to the sRGB curve, as 8 bits. */
static uint8_t srgb8(float linear)
{
    float v = linear > 0.0f ? (linear < 1.0f ? linear : 1.0f) : 0.0f;
    float encoded = v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
    return (uint8_t)lrintf(encoded * 255.0f);
}

pf_status pf_monitor_frame_png(const char *path, double exposure, unsigned char **png,
                               size_t *size, pf_error *err)
{
    *png = NULL;
    *size = 0;
    pf_image image = {0};
    pf_status status = pf_exr_read(path, &image, NULL, NULL, err);
    if (status != PF_OK)
        return status;
    int channel[3] = {pf_image_channel(&image, "R"), pf_image_channel(&image, "G"),
                      pf_image_channel(&image, "B")};
    uint64_t pixels = (uint64_t)image.width * image.height;
    if (channel[0] < 0 || channel[1] < 0 || channel[2] < 0)
        status = pf_error_set(err, PF_ERR_UNSUPPORTED, "%s: no R, G and B channels", path);
    else if (pixels > PF_MONITOR_PREVIEW_MAX_PIXELS)
        status = pf_error_set(err, PF_ERR_LIMIT, "%s: %ux%u is too large to preview", path,
                              image.width, image.height);
    uint8_t *rgb = status == PF_OK ? malloc(pixels * 3) : NULL;
    if (status == PF_OK && !rgb)
        status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for a preview", path);
    float scale = (float)exp2(exposure);
    for (uint64_t p = 0; rgb && p < pixels; p++)
        for (int c = 0; c < 3; c++)
            rgb[p * 3 + (uint64_t)c] =
                srgb8(image.pixels[p * image.channel_count + (uint64_t)channel[c]] * scale);
    spng_ctx *encoder = rgb ? spng_ctx_new(SPNG_CTX_ENCODER) : NULL;
    if (rgb && !encoder)
        status = pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory for a PNG encoder", path);
    if (encoder) {
        struct spng_ihdr header = {.width = image.width, .height = image.height,
                                   .bit_depth = 8, .color_type = SPNG_COLOR_TYPE_TRUECOLOR};
        int error = spng_set_option(encoder, SPNG_ENCODE_TO_BUFFER, 1);
        if (!error)
            error = spng_set_ihdr(encoder, &header);
        if (!error)
            error = spng_encode_image(encoder, rgb, pixels * 3, SPNG_FMT_PNG,
                                      SPNG_ENCODE_FINALIZE);
        if (!error)
            *png = spng_get_png_buffer(encoder, size, &error);
        if (error || !*png)
            status = pf_error_set(err, PF_ERR_IO, "%s: PNG encoding failed: %s", path,
                                  spng_strerror(error));
        spng_ctx_free(encoder);
    }
    free(rgb);
    pf_image_free(&image);
    return status;
}
