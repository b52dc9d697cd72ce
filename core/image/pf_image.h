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

/* Allocates a zeroed image with the given channel names. PF_ERR_INVALID for a zero
 * size or a channel name that is empty, longer than 31 characters or repeated. */
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
 * Half pixels are converted with pf_float_to_half (so |x| >= 65520 becomes inf).
 * EXR stores channels sorted by name; the image's order is kept in a string-vector
 * attribute "photonfarm/channelOrder" that pf_exr_read restores.
 * The 16-line chunks are compressed on up to one thread per online CPU (at most
 * 16, started and joined within the call) and written in order by the caller's
 * thread: the file's bytes do not depend on the thread count. zlib compresses at
 * PF_EXR_ZIP_LEVEL, not the library's default 6: a 640x480 frame of 26 half channels in
 * 98 ms instead of 166 on 2 cores, its file 5 % larger (bench/RESULTS.md); readers need
 * nothing, the level is not in the file.
 * Errors: PF_ERR_INVALID for an empty image, an empty/unterminated/duplicate key or
 * a reserved EXR header name ("channels", "type", ...), nothing written;
 * PF_ERR_IO naming path and strerror when the temporary cannot be created, written,
 * fsynced or renamed. A failed directory fsync is reported after the rename (the
 * complete file is then already at path).
 */
#define PF_EXR_ZIP_LEVEL 3
pf_status pf_exr_write(const char *path, const pf_image *image, pf_exr_pixel_type pixel_type,
                       const pf_image_attribute *attributes, uint32_t attribute_count,
                       pf_error *err);

/*
 * Reads any scanline or tiled single-part EXR into float channels. If attributes
 * is non-NULL, string attributes are returned in a malloc'ed array (free()).
 * HALF, FLOAT and UINT channels (UINT exact up to 2^24); tiled files give level 0;
 * the data window's corner becomes pixel (0, 0). Channel order: the writer's order
 * when the file has photonfarm/channelOrder, else R, G, B, A first and then the
 * file's sorted order. Standard header attributes ("type", "name", ...) are not
 * returned; values longer than 511 characters are cut with a warning.
 * Errors name the file: PF_ERR_IO (missing, unreadable, not a regular file),
 * PF_ERR_FORMAT (not an EXR, truncated, corrupt), PF_ERR_UNSUPPORTED (multi-part,
 * deep, subsampled channels). On failure *out is empty and nothing is allocated.
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
 * Channels are matched by name (the order may differ). The error channels are R, G, B
 * when a has all three, else every channel. mean_b[c] is b's mean of a's channel c.
 */
pf_status pf_image_compare(const pf_image *a, const pf_image *b, pf_image_metrics *out,
                           pf_error *err);

/*
 * The flicker between two frames a and b of a still shot: the mean over R, G, B of
 * (a − b)² / (r² + PF_RELMSE_EPSILON), r the reference's value. It is a relMSE with the two
 * frames' difference in place of one frame's error, on the scale of either frame's relMSE,
 * and defined where a noisy frame reads 0. The three images must have the same size and
 * R, G, B channels (else PF_ERR_INVALID).
 */
pf_status pf_image_flicker(const pf_image *a, const pf_image *b, const pf_image *reference,
                           double *out, pf_error *err);

/*
 * A new image of in's channels names[0..count) in that order (compare two
 * images on the channels both have: a preview's RGB against a reference's).
 * PF_ERR_INVALID naming a missing channel.
 */
pf_status pf_image_select(const pf_image *in, const char *const *names, uint32_t count,
                          pf_image *out, pf_error *err);

/* The value of key among count attributes (as pf_exr_read returns them), or NULL. */
const char *pf_image_attribute_value(const pf_image_attribute *attributes, uint32_t count,
                                     const char *key);

/*
 * A new image of in's channels followed by count new ones named names[0..count), zero
 * (AOV stages add their layers to a finished image: motion.*, noisy.*). PF_ERR_INVALID
 * when a name is taken or more than PF_IMAGE_METRIC_CHANNELS_MAX channels would result.
 */
pf_status pf_image_append_channels(const pf_image *in, const char *const *names, uint32_t count,
                                   pf_image *out, pf_error *err);

/*
 * IEEE half conversion (round to nearest even), shared with GPU readback code.
 * Magnitudes above 65504 round to it up to 65520 (the midpoint to 2^16) and become
 * inf from there; at or below 2^-25 they become (signed) zero; NaN stays a (quiet) NaN.
 */
uint16_t pf_float_to_half(float value);
float pf_half_to_float(uint16_t value);

#endif
