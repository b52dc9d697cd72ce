/* pf_image storage (create/free/channel lookup) and IEEE binary16 conversion. */
#include "pf_image.h"

#include <stdlib.h>
#include <string.h>

pf_status pf_image_create(pf_image *image, uint32_t width, uint32_t height,
                          uint32_t channel_count, const char *const *channel_names,
                          pf_error *err)
{
    memset(image, 0, sizeof *image);
    if (width == 0 || height == 0 || channel_count == 0)
        return pf_error_set(err, PF_ERR_INVALID,
                            "image size %ux%u with %u channels: width, height and channel "
                            "count must all be at least 1",
                            width, height, channel_count);
    for (uint32_t c = 0; c < channel_count; c++) {
        const char *name = channel_names[c];
        size_t length = name ? strlen(name) : 0;
        if (length == 0 || length >= PF_IMAGE_CHANNEL_NAME_MAX)
            return pf_error_set(err, PF_ERR_INVALID,
                                "image channel %u: name must be 1 to %d characters, got %zu",
                                c, PF_IMAGE_CHANNEL_NAME_MAX - 1, length);
        for (uint32_t previous = 0; previous < c; previous++) {
            if (!strcmp(channel_names[previous], name))
                return pf_error_set(err, PF_ERR_INVALID,
                                    "image channel %u: name '%s' repeats channel %u", c, name,
                                    previous);
        }
    }
    /* Guard width * height * channels against size_t overflow before allocating. */
    size_t pixel_count = (size_t)width * height;
    if (pixel_count > SIZE_MAX / sizeof(float) / channel_count)
        return pf_error_set(err, PF_ERR_LIMIT, "image %ux%u with %u channels is too large",
                            width, height, channel_count);

    image->channel_names = calloc(channel_count, sizeof *image->channel_names);
    image->pixels = calloc(pixel_count * channel_count, sizeof(float));
    if (!image->channel_names || !image->pixels) {
        pf_image_free(image);
        return pf_error_set(err, PF_ERR_NOMEM, "image %ux%u with %u channels: out of memory",
                            width, height, channel_count);
    }
    for (uint32_t c = 0; c < channel_count; c++)
        memcpy(image->channel_names[c], channel_names[c], strlen(channel_names[c]) + 1);
    image->width = width;
    image->height = height;
    image->channel_count = channel_count;
    return PF_OK;
}

void pf_image_free(pf_image *image)
{
    if (!image)
        return;
    free(image->channel_names);
    free(image->pixels);
    memset(image, 0, sizeof *image);
}

int pf_image_channel(const pf_image *image, const char *name)
{
    for (uint32_t c = 0; c < image->channel_count; c++) {
        if (!strcmp(image->channel_names[c], name))
            return (int)c;
    }
    return -1;
}

/*
 * binary32 -> binary16 bit patterns (IEEE 754-2008 §3.6). Biases: 127 and 15, so
 * the exponent shift between them is 112 = 0x38000000 >> 23. 0x477ff000 is 65520,
 * halfway between the largest half (65504) and 2^16: ties go to the even pattern,
 * which is inf, so everything from 65520 up overflows.
 */
#define F32_EXPONENT_REBIAS 0x38000000u
#define F32_HALF_OVERFLOW 0x477ff000u
#define F32_HALF_MIN_NORMAL 0x38800000u /* 2^-14 */
#define F32_HALF_MIN_TIE 0x33000000u    /* 2^-25: half of the smallest half subnormal */
#define F32_INF 0x7f800000u
#define HALF_INF 0x7c00u
#define HALF_QUIET_BIT 0x0200u

uint16_t pf_float_to_half(float value)
{
    uint32_t bits;
    memcpy(&bits, &value, sizeof bits);
    uint32_t sign = (bits >> 16) & 0x8000u;
    uint32_t magnitude = bits & 0x7fffffffu;

    if (magnitude > F32_INF) /* NaN: keep the top payload bits, force quiet so it stays NaN */
        return (uint16_t)(sign | HALF_INF | HALF_QUIET_BIT | ((magnitude >> 13) & 0x3ffu));
    if (magnitude >= F32_HALF_OVERFLOW)
        return (uint16_t)(sign | HALF_INF);
    if (magnitude >= F32_HALF_MIN_NORMAL) {
        uint32_t half = (magnitude - F32_EXPONENT_REBIAS) >> 13;
        uint32_t remainder = magnitude & 0x1fffu;
        if (remainder > 0x1000u || (remainder == 0x1000u && (half & 1u)))
            half++; /* a carry into the exponent is the correct rounding */
        return (uint16_t)(sign | half);
    }
    if (magnitude <= F32_HALF_MIN_TIE)
        return (uint16_t)sign;
    /* Subnormal half: value / 2^-24, i.e. the 24-bit significand shifted right. */
    uint32_t exponent = magnitude >> 23;
    uint32_t significand = (magnitude & 0x7fffffu) | 0x800000u;
    uint32_t shift = 126u - exponent; /* 14..24 here */
    uint32_t half = significand >> shift;
    uint32_t remainder = significand & ((1u << shift) - 1u);
    uint32_t halfway = 1u << (shift - 1u);
    if (remainder > halfway || (remainder == halfway && (half & 1u)))
        half++;
    return (uint16_t)(sign | half);
}

float pf_half_to_float(uint16_t value)
{
    uint32_t sign = (uint32_t)(value & 0x8000u) << 16;
    uint32_t exponent = (value >> 10) & 0x1fu;
    uint32_t mantissa = value & 0x3ffu;
    uint32_t bits;
    if (exponent == 0x1fu) {
        bits = sign | F32_INF | (mantissa << 13);
    } else if (exponent != 0) {
        bits = sign | ((exponent + 112u) << 23) | (mantissa << 13);
    } else if (mantissa == 0) {
        bits = sign;
    } else {
        /* Subnormal half: normalise; 113 is the float exponent of 2^-14. */
        uint32_t float_exponent = 113u;
        while (!(mantissa & 0x400u)) {
            mantissa <<= 1;
            float_exponent--;
        }
        bits = sign | (float_exponent << 23) | ((mantissa & 0x3ffu) << 13);
    }
    float result;
    memcpy(&result, &bits, sizeof result);
    return result;
}

pf_status pf_image_select(const pf_image *in, const char *const *names, uint32_t count,
                          pf_image *out, pf_error *err)
{
    int index[PF_IMAGE_METRIC_CHANNELS_MAX];
    memset(out, 0, sizeof *out);
    if (count == 0 || count > PF_IMAGE_METRIC_CHANNELS_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "image select: %u channels (1..%u)", count,
                            PF_IMAGE_METRIC_CHANNELS_MAX);
    for (uint32_t c = 0; c < count; c++) {
        index[c] = pf_image_channel(in, names[c]);
        if (index[c] < 0)
            return pf_error_set(err, PF_ERR_INVALID, "image has no channel '%s'", names[c]);
    }
    pf_status status = pf_image_create(out, in->width, in->height, count, names, err);
    if (status != PF_OK)
        return status;
    uint64_t pixels = (uint64_t)in->width * in->height;
    for (uint64_t p = 0; p < pixels; p++)
        for (uint32_t c = 0; c < count; c++)
            out->pixels[p * count + c] = in->pixels[p * in->channel_count + (uint32_t)index[c]];
    return PF_OK;
}

pf_status pf_image_append_channels(const pf_image *in, const char *const *names, uint32_t count,
                                   pf_image *out, pf_error *err)
{
    const char *all[PF_IMAGE_METRIC_CHANNELS_MAX];
    uint32_t total = in->channel_count + count;
    memset(out, 0, sizeof *out);
    if (total > PF_IMAGE_METRIC_CHANNELS_MAX)
        return pf_error_set(err, PF_ERR_INVALID, "image: %u channels and %u more exceed %u",
                            in->channel_count, count, PF_IMAGE_METRIC_CHANNELS_MAX);
    for (uint32_t c = 0; c < in->channel_count; c++)
        all[c] = in->channel_names[c];
    for (uint32_t c = 0; c < count; c++)
        all[in->channel_count + c] = names[c];
    pf_status status = pf_image_create(out, in->width, in->height, total, all, err);
    if (status != PF_OK)
        return status;
    uint64_t pixels = (uint64_t)in->width * in->height;
    for (uint64_t p = 0; p < pixels; p++)
        memcpy(out->pixels + p * total, in->pixels + p * in->channel_count,
               in->channel_count * sizeof *in->pixels);
    return PF_OK;
}

const char *pf_image_attribute_value(const pf_image_attribute *attributes, uint32_t count,
                                     const char *key)
{
    for (uint32_t i = 0; i < count; i++)
        if (!strcmp(attributes[i].key, key))
            return attributes[i].value;
    return NULL;
}
