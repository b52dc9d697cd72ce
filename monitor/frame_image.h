/* A rendered frame as the page shows it (frame_image.c): the EXR's beauty, exposed,
 * tone-mapped to sRGB and encoded as PNG. */
#ifndef PF_MONITOR_FRAME_IMAGE_H
#define PF_MONITOR_FRAME_IMAGE_H

#include "pf_common.h"

#include <stddef.h>

/* Frames larger than this many pixels are not turned into a preview (memory). */
#define PF_MONITOR_PREVIEW_MAX_PIXELS (8192u * 8192u)

/*
 * The EXR at path as a PNG (malloc'ed into *png, *size bytes): R, G, B scaled by
 * 2^exposure, clamped to [0, 1] and sRGB-encoded, 8 bits. Errors name the file: the
 * reader's (PF_ERR_IO, PF_ERR_FORMAT), PF_ERR_UNSUPPORTED without R, G and B, PF_ERR_LIMIT
 * above PF_MONITOR_PREVIEW_MAX_PIXELS.
 */
pf_status pf_monitor_frame_png(const char *path, double exposure, unsigned char **png,
                               size_t *size, pf_error *err);

#endif
