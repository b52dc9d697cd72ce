/* One writer thread behind the render (frame_writer.h). */
#include "frame_writer.h"

#include <stdlib.h>
#include <uv.h>

struct pf_frame_writer {
    uv_thread_t thread;
    uv_mutex_t mutex;
    uv_cond_t changed;     /* a frame was handed over, written, or the end was asked */
    pf_frame_written_fn written;
    pf_frame_output *frame; /* handed over and not yet written; NULL: none */
    void *user;
    int stopping;
};

static void write_frames(void *argument)
{
    pf_frame_writer *writer = argument;
    uv_mutex_lock(&writer->mutex);
    for (;;) {
        while (!writer->frame && !writer->stopping)
            uv_cond_wait(&writer->changed, &writer->mutex);
        if (!writer->frame)
            break; /* stopping, and nothing left */
        pf_frame_output *frame = writer->frame;
        void *user = writer->user;
        uv_mutex_unlock(&writer->mutex);
        pf_error err = {0};
        pf_status status = pf_frame_write(frame, &err);
        writer->written(user, frame, status, &err);
        uv_mutex_lock(&writer->mutex);
        writer->frame = NULL;
        uv_cond_broadcast(&writer->changed);
    }
    uv_mutex_unlock(&writer->mutex);
}

pf_status pf_frame_writer_start(pf_frame_written_fn written, pf_frame_writer **out,
                                pf_error *err)
{
    *out = NULL;
    pf_frame_writer *writer = calloc(1, sizeof *writer);
    if (!writer)
        return pf_error_set(err, PF_ERR_NOMEM, "frame writer: out of memory");
    writer->written = written;
    if (uv_mutex_init(&writer->mutex) != 0) {
        free(writer);
        return pf_error_set(err, PF_ERR_INTERNAL, "frame writer: no mutex");
    }
    if (uv_cond_init(&writer->changed) != 0) {
        uv_mutex_destroy(&writer->mutex);
        free(writer);
        return pf_error_set(err, PF_ERR_INTERNAL, "frame writer: no condition variable");
    }
    if (uv_thread_create(&writer->thread, write_frames, writer) != 0) {
        uv_cond_destroy(&writer->changed);
        uv_mutex_destroy(&writer->mutex);
        free(writer);
        return pf_error_set(err, PF_ERR_INTERNAL, "frame writer: no thread");
    }
    *out = writer;
    return PF_OK;
}

void pf_frame_writer_hand(pf_frame_writer *writer, pf_frame_output *frame, void *user)
{
    uv_mutex_lock(&writer->mutex);
    while (writer->frame)
        uv_cond_wait(&writer->changed, &writer->mutex);
    writer->frame = frame;
    writer->user = user;
    uv_cond_broadcast(&writer->changed);
    uv_mutex_unlock(&writer->mutex);
}

void pf_frame_writer_stop(pf_frame_writer *writer)
{
    if (!writer)
        return;
    uv_mutex_lock(&writer->mutex);
    writer->stopping = 1;
    uv_cond_broadcast(&writer->changed);
    uv_mutex_unlock(&writer->mutex);
    uv_thread_join(&writer->thread);
    uv_cond_destroy(&writer->changed);
    uv_mutex_destroy(&writer->mutex);
    free(writer);
}
