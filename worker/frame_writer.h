/*
 * Frames written behind the render (issue 43): one thread writes each frame the
 * render hands over (pf_frame_write), in the order handed over, while the render
 * thread goes on with the next frame, so the device is not left idle while the
 * host compresses an EXR. At most one frame waits or is being written at a time:
 * a handover blocks until the frame before it is written, so a worker holds at
 * most two frames' images (the one written and the one rendering).
 */
#ifndef PF_FRAME_WRITER_H
#define PF_FRAME_WRITER_H

#include "pf_render.h"

typedef struct pf_frame_writer pf_frame_writer;

/* Called on the writer's thread after each write, with its outcome (err only on failure). */
typedef void (*pf_frame_written_fn)(void *user, pf_frame_output *frame, pf_status status,
                                    const pf_error *err);

pf_status pf_frame_writer_start(pf_frame_written_fn written, pf_frame_writer **out,
                                pf_error *err);

/* Hands frame (rendered with write_behind) to the writer; returns once the writer has
 * taken it, that is once the frame handed before it is written. */
void pf_frame_writer_hand(pf_frame_writer *writer, pf_frame_output *frame, void *user);

/* Writes what was handed over, then ends the thread (NULL: nothing). */
void pf_frame_writer_stop(pf_frame_writer *writer);

#endif
