/* Error capture and attribute naming shared by the EXR reader and writer (exr_internal.h). */
#include "exr_internal.h"

#include <stdio.h>
#include <string.h>

/*
 * Attribute names the OpenEXR file layout ("Header Attributes") gives a fixed
 * type and meaning: a user string under one of these names would corrupt the
 * header or be rejected by readers.
 */
static const char *const reserved_attribute_names[] = {
    "channels",   "compression",        "dataWindow",         "displayWindow",
    "lineOrder",  "pixelAspectRatio",   "screenWindowCenter", "screenWindowWidth",
    "tiles",      "type",               "name",               "version",
    "chunkCount", "maxSamplesPerPixel", PF_EXR_CHANNEL_ORDER_ATTRIBUTE,
};

/*
 * The stream of the EXR read or write in progress on this thread. The error
 * handler cannot ask the context for its user data: OpenEXR 3.1 calls the
 * handler with the context's mutex held, and exr_get_user_data takes that
 * (non-recursive) mutex again. A failed write(2) — a full disk — deadlocked
 * the writer that way, and a worker sat on its frame forever with its lease
 * still renewed (issue 14, test_worker_faults).
 */
static _Thread_local pf_exr_stream *active_stream;

void pf_exr_stream_activate(pf_exr_stream *stream)
{
    active_stream = stream;
}

void pf_exr_capture_error(exr_const_context_t context, exr_result_t code, const char *message)
{
    (void)context;
    pf_exr_stream *stream = active_stream;
    if (!stream)
        return; /* the caller still gets the code and reports its default text */
    snprintf(stream->last_message, sizeof stream->last_message, "%s",
             message ? message : exr_get_default_error_message(code));
}

const char *pf_exr_message(const pf_exr_stream *stream, exr_result_t code)
{
    if (stream->last_message[0])
        return stream->last_message;
    return exr_get_default_error_message(code);
}

int pf_exr_reserved_attribute(const char *name)
{
    for (size_t i = 0; i < sizeof reserved_attribute_names / sizeof *reserved_attribute_names; i++) {
        if (!strcmp(name, reserved_attribute_names[i]))
            return 1;
    }
    return 0;
}
