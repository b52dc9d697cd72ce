/*
 * Texture images to RGBA8 by the maintained decoders Debian packages:
 * libspng (PNG), libjpeg-turbo's TurboJPEG API (JPEG), libwebp (WebP).
 * Never a decoder of our own: these are fuzzed by their projects (OSS-Fuzz).
 *
 * The format comes from the bytes' signature, not the file name or the
 * mimeType (a .png that holds a JPEG decodes). Each image's size is read
 * from its header and checked against PF_IMAGE_MAX_EDGE and
 * PF_IMAGE_MAX_PIXELS before anything is allocated for it, so a
 * decompression bomb (a small file that claims 100,000 × 100,000 pixels) is
 * refused without decoding. Truncated or corrupt data is an error, never a
 * partly decoded image: TurboJPEG stops on warnings (a truncated JPEG is a
 * warning to libjpeg) and libspng checks every CRC.
 */
#include "scene_internal.h"

#include <spng.h>
#include <stdlib.h>
#include <string.h>
#include <turbojpeg.h>
#include <webp/decode.h>

/* The largest ancillary chunk libspng keeps (text, ICC profiles): 1 MiB, and 8 MiB in all. */
#define PNG_CHUNK_LIMIT (1u << 20)
#define PNG_CHUNK_CACHE_LIMIT (8u << 20)

static pf_status check_size(uint32_t width, uint32_t height, const char *format, pf_error *err)
{
    if (width == 0 || height == 0)
        return pf_error_set(err, PF_ERR_FORMAT, "%s image of %ux%u pixels", format, width,
                            height);
    if (width > PF_IMAGE_MAX_EDGE || height > PF_IMAGE_MAX_EDGE ||
        (uint64_t)width * height > PF_IMAGE_MAX_PIXELS)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "%s image of %ux%u pixels exceeds the limit (edges up to %u, %u "
                            "megapixels)",
                            format, width, height, PF_IMAGE_MAX_EDGE, PF_IMAGE_MAX_PIXELS >> 20);
    return PF_OK;
}

static pf_status decode_png(const unsigned char *data, size_t size, uint32_t *width,
                            uint32_t *height, uint8_t **rgba, pf_error *err)
{
    spng_ctx *png = spng_ctx_new(0);
    if (!png)
        return pf_error_set(err, PF_ERR_NOMEM, "PNG decoder: out of memory");
    struct spng_ihdr header;
    size_t bytes = 0;
    uint8_t *pixels = NULL;
    int code = spng_set_png_buffer(png, data, size);
    if (code == 0)
        code = spng_set_image_limits(png, PF_IMAGE_MAX_EDGE, PF_IMAGE_MAX_EDGE);
    if (code == 0)
        code = spng_set_chunk_limits(png, PNG_CHUNK_LIMIT, PNG_CHUNK_CACHE_LIMIT);
    if (code == 0)
        code = spng_get_ihdr(png, &header);
    pf_status status = code == 0 ? check_size(header.width, header.height, "PNG", err) : PF_OK;
    if (code == 0 && status == PF_OK)
        code = spng_decoded_image_size(png, SPNG_FMT_RGBA8, &bytes);
    if (code == 0 && status == PF_OK) {
        pixels = malloc(bytes);
        if (!pixels)
            status = pf_error_set(err, PF_ERR_NOMEM, "PNG image of %ux%u: out of memory",
                                  header.width, header.height);
    }
    if (code == 0 && status == PF_OK)
        code = spng_decode_image(png, pixels, bytes, SPNG_FMT_RGBA8, SPNG_DECODE_TRNS);
    if (code != 0 && status == PF_OK)
        status = pf_error_set(err, PF_ERR_FORMAT, "PNG: %s", spng_strerror(code));
    spng_ctx_free(png);
    if (status != PF_OK) {
        free(pixels);
        return status;
    }
    *width = header.width;
    *height = header.height;
    *rgba = pixels;
    return PF_OK;
}

static pf_status decode_jpeg(const unsigned char *data, size_t size, uint32_t *width,
                             uint32_t *height, uint8_t **rgba, pf_error *err)
{
    if (size > (size_t)0xFFFFFFFFu)
        return pf_error_set(err, PF_ERR_LIMIT, "JPEG of %zu bytes: too large", size);
    tjhandle jpeg = tjInitDecompress();
    if (!jpeg)
        return pf_error_set(err, PF_ERR_NOMEM, "JPEG decoder: %s", tjGetErrorStr2(NULL));
    int w = 0, h = 0, subsampling = 0, colorspace = 0;
    uint8_t *pixels = NULL;
    pf_status status = PF_OK;
    if (tjDecompressHeader3(jpeg, data, (unsigned long)size, &w, &h, &subsampling,
                            &colorspace) != 0)
        status = pf_error_set(err, PF_ERR_FORMAT, "JPEG: %s", tjGetErrorStr2(jpeg));
    if (status == PF_OK)
        status = check_size((uint32_t)w, (uint32_t)h, "JPEG", err);
    if (status == PF_OK) {
        pixels = malloc((size_t)w * (size_t)h * 4);
        if (!pixels)
            status = pf_error_set(err, PF_ERR_NOMEM, "JPEG image of %dx%d: out of memory", w, h);
    }
    /* STOPONWARNING: a truncated stream is only a warning to libjpeg, which would fill the
     * rest grey; LIMITSCANS: a progressive JPEG of thousands of scans is refused (CVE-class
     * slow decodes). */
    if (status == PF_OK &&
        tjDecompress2(jpeg, data, (unsigned long)size, pixels, w, 0, h, TJPF_RGBA,
                      TJFLAG_STOPONWARNING | TJFLAG_LIMITSCANS) != 0)
        status = pf_error_set(err, PF_ERR_FORMAT, "JPEG: %s", tjGetErrorStr2(jpeg));
    tjDestroy(jpeg);
    if (status != PF_OK) {
        free(pixels);
        return status;
    }
    *width = (uint32_t)w;
    *height = (uint32_t)h;
    *rgba = pixels;
    return PF_OK;
}

static pf_status decode_webp(const unsigned char *data, size_t size, uint32_t *width,
                             uint32_t *height, uint8_t **rgba, pf_error *err)
{
    int w = 0, h = 0;
    if (!WebPGetInfo(data, size, &w, &h))
        return pf_error_set(err, PF_ERR_FORMAT, "WebP: not a valid WebP bitstream");
    pf_status status = check_size((uint32_t)w, (uint32_t)h, "WebP", err);
    if (status != PF_OK)
        return status;
    size_t bytes = (size_t)w * (size_t)h * 4;
    uint8_t *pixels = malloc(bytes);
    if (!pixels)
        return pf_error_set(err, PF_ERR_NOMEM, "WebP image of %dx%d: out of memory", w, h);
    if (!WebPDecodeRGBAInto(data, size, pixels, bytes, w * 4)) {
        free(pixels);
        return pf_error_set(err, PF_ERR_FORMAT, "WebP: corrupt or truncated bitstream");
    }
    *width = (uint32_t)w;
    *height = (uint32_t)h;
    *rgba = pixels;
    return PF_OK;
}

pf_status scene_image_decode(const unsigned char *data, size_t size, uint32_t *width,
                             uint32_t *height, uint8_t **rgba, pf_error *err)
{
    static const unsigned char png_signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
    *rgba = NULL;
    if (size >= 8 && memcmp(data, png_signature, 8) == 0)
        return decode_png(data, size, width, height, rgba, err);
    if (size >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF)
        return decode_jpeg(data, size, width, height, rgba, err);
    if (size >= 12 && memcmp(data, "RIFF", 4) == 0 && memcmp(data + 8, "WEBP", 4) == 0)
        return decode_webp(data, size, width, height, rgba, err);
    return pf_error_set(err, PF_ERR_FORMAT,
                        "%zu bytes that are not a PNG, JPEG or WebP image (by their signature)",
                        size);
}
