/*
 * pf_image_compare: the error metrics of DESIGN.md §8. The error channels are
 * R, G, B when the test image has all three; otherwise (a depth-only or
 * otherwise named image) every channel, so the numbers still mean something.
 * Channels are matched by name, so the two images may order them differently.
 */
#include "pf_image.h"

#include <math.h>
#include <string.h>

pf_status pf_image_compare(const pf_image *a, const pf_image *b, pf_image_metrics *out,
                           pf_error *err)
{
    memset(out, 0, sizeof *out);
    if (a->width != b->width || a->height != b->height)
        return pf_error_set(err, PF_ERR_INVALID,
                            "image sizes differ: %ux%u (test) vs %ux%u (reference)", a->width,
                            a->height, b->width, b->height);
    if (a->channel_count > PF_IMAGE_METRIC_CHANNELS_MAX)
        return pf_error_set(err, PF_ERR_LIMIT, "%u channels; at most %d can be compared",
                            a->channel_count, PF_IMAGE_METRIC_CHANNELS_MAX);

    int b_channel[PF_IMAGE_METRIC_CHANNELS_MAX];
    for (uint32_t c = 0; c < a->channel_count; c++) {
        b_channel[c] = pf_image_channel(b, a->channel_names[c]);
        if (b_channel[c] < 0)
            return pf_error_set(err, PF_ERR_INVALID,
                                "channel '%s' of the test image is missing from the reference",
                                a->channel_names[c]);
    }
    /* Same count and every name of a found in b (names are unique): same set. */
    if (b->channel_count != a->channel_count) {
        for (uint32_t c = 0; c < b->channel_count; c++) {
            if (pf_image_channel(a, b->channel_names[c]) < 0)
                return pf_error_set(err, PF_ERR_INVALID,
                                    "channel '%s' of the reference is missing from the test image",
                                    b->channel_names[c]);
        }
        return pf_error_set(err, PF_ERR_INVALID, "channel counts differ: %u vs %u",
                            a->channel_count, b->channel_count);
    }

    int error_channels[PF_IMAGE_METRIC_CHANNELS_MAX];
    uint32_t error_count = 0;
    static const char *const rgb[] = {"R", "G", "B"};
    for (size_t i = 0; i < 3; i++) {
        int c = pf_image_channel(a, rgb[i]);
        if (c >= 0)
            error_channels[error_count++] = c;
    }
    if (error_count != 3) {
        error_count = a->channel_count;
        for (uint32_t c = 0; c < error_count; c++)
            error_channels[c] = (int)c;
    }

    const size_t pixel_count = (size_t)a->width * a->height;
    double squared_sum = 0.0, relative_sum = 0.0, max_error = 0.0;
    double sum_a[PF_IMAGE_METRIC_CHANNELS_MAX] = {0}, sum_b[PF_IMAGE_METRIC_CHANNELS_MAX] = {0};
    for (size_t p = 0; p < pixel_count; p++) {
        const float *pa = a->pixels + p * a->channel_count;
        const float *pb = b->pixels + p * b->channel_count;
        for (uint32_t c = 0; c < a->channel_count; c++) {
            sum_a[c] += pa[c];
            sum_b[c] += pb[b_channel[c]];
        }
        for (uint32_t e = 0; e < error_count; e++) {
            double test = pa[error_channels[e]];
            double reference = pb[b_channel[error_channels[e]]];
            double difference = test - reference;
            double squared = difference * difference;
            squared_sum += squared;
            relative_sum += squared / (reference * reference + PF_RELMSE_EPSILON);
            double magnitude = fabs(difference);
            /* Once NaN, the maximum stays NaN (a plain > would drop it). */
            if (isnan(magnitude) || magnitude > max_error)
                max_error = magnitude;
        }
    }
    const double samples = (double)pixel_count * error_count;
    out->rmse = sqrt(squared_sum / samples);
    out->relmse = relative_sum / samples;
    out->max_abs_error = max_error;
    out->channel_count = a->channel_count;
    for (uint32_t c = 0; c < a->channel_count; c++) {
        out->mean_a[c] = sum_a[c] / (double)pixel_count;
        out->mean_b[c] = sum_b[c] / (double)pixel_count;
    }
    return PF_OK;
}

pf_status pf_image_flicker(const pf_image *a, const pf_image *b, const pf_image *reference,
                           double *out, pf_error *err)
{
    static const char *const rgb[3] = {"R", "G", "B"};
    const pf_image *images[3] = {a, b, reference};
    int at[3][3];
    *out = NAN;
    for (int i = 0; i < 3; i++) {
        if (images[i]->width != a->width || images[i]->height != a->height)
            return pf_error_set(err, PF_ERR_INVALID, "flicker: sizes %ux%u and %ux%u differ",
                                a->width, a->height, images[i]->width, images[i]->height);
        for (int c = 0; c < 3; c++) {
            at[i][c] = pf_image_channel(images[i], rgb[c]);
            if (at[i][c] < 0)
                return pf_error_set(err, PF_ERR_INVALID, "flicker: an image has no %s channel",
                                    rgb[c]);
        }
    }
    double sum = 0.0;
    size_t pixels = (size_t)a->width * a->height;
    for (size_t p = 0; p < pixels; p++)
        for (int c = 0; c < 3; c++) {
            double d = (double)a->pixels[p * a->channel_count + at[0][c]] -
                       b->pixels[p * b->channel_count + at[1][c]];
            double r = reference->pixels[p * reference->channel_count + at[2][c]];
            sum += d * d / (r * r + PF_RELMSE_EPSILON);
        }
    *out = pixels ? sum / (3.0 * (double)pixels) : 0.0;
    return PF_OK;
}
