/*
 * core/image: float images with named channels, OpenEXR write/read (OpenEXR's
 * C API), and the error metrics every accuracy test and benchmark uses.
 *
 * Channel naming follows EXR conventions: "R","G","B","A" for the beauty pass;
 * AOV layers as "<layer>.<channel>": albedo.R/G/B, normal.X/Y/Z, depth.Z, and
 * later direct.R/G/B, indirect.R/G/B, caustic.R/G/B.
 */
#ifndef PF_IMAGE_H
#define PF_IMAGE_H

#include "pf_common.h"

#include <stdint.h>

#define PF_IMAGE_CHANNEL_NAME_MAX 32

/* Interleaved float pixels: pixels[(y * width + x) * channel_count + c]. Row 0 is the top. */
typedef struct pf_image {
    uint32_t width, height;
    uint32_t channel_count;
    char (*channel_names)[PF_IMAGE_CHANNEL_NAME_MAX];
    float *pixels;
} pf_image;

/* Allocates a zeroed image with the given channel names. */
pf_status pf_image_create(pf_image *image, uint32_t width, uint32_t height,
                          uint32_t channel_count, const char *const *channel_names,
                          pf_error *err);
void pf_image_free(pf_image *image);
/* Index of the named channel, or -1. */
int pf_image_channel(const pf_image *image, const char *name);

typedef struct pf_image_attribute {
    char key[64];
    char value[512];
} pf_image_attribute;

typedef enum pf_exr_pixel_type {
    PF_EXR_HALF = 0,
    PF_EXR_FLOAT = 1
} pf_exr_pixel_type;

/*
 * Writes an EXR (ZIP compression) with every channel of image in pixel_type and
 * the attributes as string metadata. Written to "<path>.tmp-<pid>-<n>", fsynced,
 * renamed over path, directory fsynced: a reader never sees a partial file, and
 * on failure the temporary is removed and an existing file at path is untouched.
 */
pf_status pf_exr_write(const char *path, const pf_image *image, pf_exr_pixel_type pixel_type,
                       const pf_image_attribute *attributes, uint32_t attribute_count,
                       pf_error *err);

/*
 * Reads any scanline or tiled single-part EXR into float channels. If attributes
 * is non-NULL, string attributes are returned in a malloc'ed array (free()).
 */
pf_status pf_exr_read(const char *path, pf_image *out, pf_image_attribute **attributes,
                      uint32_t *attribute_count, pf_error *err);

#define PF_IMAGE_METRIC_CHANNELS_MAX 64

typedef struct pf_image_metrics {
    double rmse;           /* over R, G, B */
    double relmse;         /* mean (x - r)^2 / (r^2 + epsilon) over R, G, B */
    double max_abs_error;  /* over R, G, B */
    uint32_t channel_count;
    double mean_a[PF_IMAGE_METRIC_CHANNELS_MAX]; /* per channel, in a's channel order */
    double mean_b[PF_IMAGE_METRIC_CHANNELS_MAX];
} pf_image_metrics;

#define PF_RELMSE_EPSILON 0.01 /* REFERENCE.md, Image error */

/*
 * Compares test image a with reference b. Sizes and channel sets must match
 * (else PF_ERR_INVALID naming the mismatch); NaN/Inf pixels make the metrics NaN/Inf.
 */
pf_status pf_image_compare(const pf_image *a, const pf_image *b, pf_image_metrics *out,
                           pf_error *err);

/* IEEE half conversion (round to nearest even), shared with GPU readback code. */
uint16_t pf_float_to_half(float value);
float pf_half_to_float(uint16_t value);

#endif
