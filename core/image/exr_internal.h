/*
 * Shared by exr_write.c and exr_read.c (not part of the module interface):
 * the stream state behind an OpenEXR context, so the library's own error text
 * and the errno of a failed read/write can go into a pf_error.
 */
#ifndef PF_EXR_INTERNAL_H
#define PF_EXR_INTERNAL_H

#include "pf_image.h"

#include <openexr.h>

/* Attribute naming the channels in the writer's order (EXR stores them sorted). */
#define PF_EXR_CHANNEL_ORDER_ATTRIBUTE "photonfarm/channelOrder"

typedef struct pf_exr_stream {
    int fd;
    int saved_errno;        /* errno of the first failed read/write, 0 if none */
    char last_message[512]; /* last message the library reported */
} pf_exr_stream;

/*
 * Makes stream the one this thread's error handler fills (NULL: none), for
 * the span of one pf_exr_read or pf_exr_write (see exr_stream.c for why the
 * handler cannot use the context's user data).
 */
void pf_exr_stream_activate(pf_exr_stream *stream);

/* Error handler for exr_context_initializer_t: keeps the message in the active stream. */
void pf_exr_capture_error(exr_const_context_t context, exr_result_t code, const char *message);

/* The library's message for a failed call: the captured one, else the code's default text. */
const char *pf_exr_message(const pf_exr_stream *stream, exr_result_t code);

/* 1 if name is a standard EXR header attribute or ours: not user metadata. */
int pf_exr_reserved_attribute(const char *name);

#endif
