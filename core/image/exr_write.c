/*
 * pf_exr_write: single-part scanline EXR, ZIP compression, written through our
 * own stream so the file is a temporary that we fsync and rename ourselves
 * (OpenEXR's own temp-file mode neither fsyncs nor lets us pick the name).
 */
#include "exr_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Short attribute names are limited to 31 characters (OpenEXR file layout, "Header"). */
#define EXR_SHORT_NAME_MAX 31

/* Distinguishes temporaries of concurrent writes from one process. */
static atomic_uint temporary_counter;

static int64_t stream_write(exr_const_context_t context, void *user_data, const void *buffer,
                            uint64_t size, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    pf_exr_stream *stream = user_data;
    const char *bytes = buffer;
    uint64_t done = 0;
    while (done < size) {
        ssize_t written = pwrite(stream->fd, bytes + done, (size_t)(size - done),
                                 (off_t)(offset + done));
        if (written < 0 && errno == EINTR)
            continue;
        if (written <= 0) {
            int saved = written < 0 ? errno : EIO;
            if (!stream->saved_errno)
                stream->saved_errno = saved;
            error_cb(context, EXR_ERR_WRITE_IO, "write of %llu bytes at offset %llu: %s",
                     (unsigned long long)size, (unsigned long long)offset, strerror(saved));
            return -1;
        }
        done += (uint64_t)written;
    }
    return (int64_t)done;
}

static pf_status validate_attributes(const char *path, const pf_image_attribute *attributes,
                                     uint32_t attribute_count, pf_error *err)
{
    for (uint32_t i = 0; i < attribute_count; i++) {
        const pf_image_attribute *attribute = &attributes[i];
        size_t key_length = strnlen(attribute->key, sizeof attribute->key);
        if (key_length == 0)
            return pf_error_set(err, PF_ERR_INVALID, "%s: attribute %u has an empty key", path, i);
        if (key_length == sizeof attribute->key)
            return pf_error_set(err, PF_ERR_INVALID, "%s: attribute %u: key is not terminated",
                                path, i);
        if (strnlen(attribute->value, sizeof attribute->value) == sizeof attribute->value)
            return pf_error_set(err, PF_ERR_INVALID,
                                "%s: attribute '%s': value is not terminated", path,
                                attribute->key);
        if (pf_exr_reserved_attribute(attribute->key))
            return pf_error_set(err, PF_ERR_INVALID,
                                "%s: attribute '%s' is a reserved EXR header name", path,
                                attribute->key);
        for (uint32_t previous = 0; previous < i; previous++) {
            if (!strcmp(attributes[previous].key, attribute->key))
                return pf_error_set(err, PF_ERR_INVALID,
                                    "%s: attribute '%s' is given twice (%u and %u)", path,
                                    attribute->key, previous, i);
        }
    }
    return PF_OK;
}

static pf_status validate_image(const char *path, const pf_image *image, pf_error *err)
{
    if (image->width == 0 || image->height == 0 || image->channel_count == 0 || !image->pixels)
        return pf_error_set(err, PF_ERR_INVALID, "%s: image is empty (%ux%u, %u channels)", path,
                            image->width, image->height, image->channel_count);
    if (image->width > INT32_MAX || image->height > INT32_MAX)
        return pf_error_set(err, PF_ERR_LIMIT, "%s: image %ux%u exceeds the EXR size limit",
                            path, image->width, image->height);
    for (uint32_t c = 0; c < image->channel_count; c++) {
        size_t length = strnlen(image->channel_names[c], PF_IMAGE_CHANNEL_NAME_MAX);
        if (length == 0 || length == PF_IMAGE_CHANNEL_NAME_MAX)
            return pf_error_set(err, PF_ERR_INVALID, "%s: channel %u has an invalid name", path,
                                c);
        if (pf_image_channel(image, image->channel_names[c]) != (int)c)
            return pf_error_set(err, PF_ERR_INVALID, "%s: channel name '%s' appears twice", path,
                                image->channel_names[c]);
    }
    return PF_OK;
}

/* Declares the part: required attributes, channels, channel order, user metadata. */
static pf_status define_header(exr_context_t context, const char *path, const pf_image *image,
                               pf_exr_pixel_type pixel_type,
                               const pf_image_attribute *attributes, uint32_t attribute_count,
                               pf_exr_stream *stream, pf_error *err)
{
    int part = 0;
    exr_result_t rc = exr_add_part(context, NULL, EXR_STORAGE_SCANLINE, &part);
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_initialize_required_attr_simple(context, part, (int32_t)image->width,
                                                 (int32_t)image->height, EXR_COMPRESSION_ZIP);
    /* pf_image.h says why not the library's default level. */
    if (rc == EXR_ERR_SUCCESS)
        rc = exr_set_zip_compression_level(context, part, PF_EXR_ZIP_LEVEL);
    if (rc != EXR_ERR_SUCCESS)
        return pf_error_set(err, PF_ERR_INTERNAL, "%s: EXR header: %s", path,
                            pf_exr_message(stream, rc));

    exr_pixel_type_t exr_type = pixel_type == PF_EXR_FLOAT ? EXR_PIXEL_FLOAT : EXR_PIXEL_HALF;
    const char **order = malloc(image->channel_count * sizeof *order);
    if (!order)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", path);
    for (uint32_t c = 0; c < image->channel_count; c++) {
        order[c] = image->channel_names[c];
        /* The perceptual hint only steers lossy codecs; ZIP ignores it. */
        rc = exr_add_channel(context, part, image->channel_names[c], exr_type,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
        if (rc != EXR_ERR_SUCCESS) {
            free(order);
            return pf_error_set(err, PF_ERR_INVALID, "%s: channel '%s': %s", path,
                                image->channel_names[c], pf_exr_message(stream, rc));
        }
    }
    rc = exr_attr_set_string_vector(context, part, PF_EXR_CHANNEL_ORDER_ATTRIBUTE,
                                    (int32_t)image->channel_count, order);
    free(order);
    if (rc != EXR_ERR_SUCCESS)
        return pf_error_set(err, PF_ERR_INTERNAL, "%s: channel order attribute: %s", path,
                            pf_exr_message(stream, rc));

    for (uint32_t i = 0; i < attribute_count; i++) {
        if (strlen(attributes[i].key) > EXR_SHORT_NAME_MAX) {
            rc = exr_set_longname_support(context, 1);
            if (rc != EXR_ERR_SUCCESS)
                return pf_error_set(err, PF_ERR_INTERNAL, "%s: long attribute names: %s", path,
                                    pf_exr_message(stream, rc));
        }
        rc = exr_attr_set_string(context, part, attributes[i].key, attributes[i].value);
        if (rc != EXR_ERR_SUCCESS)
            return pf_error_set(err, PF_ERR_INVALID, "%s: attribute '%s': %s", path,
                                attributes[i].key, pf_exr_message(stream, rc));
    }
    return PF_OK;
}

/* Most threads one write compresses on: ZIP chunks of 16 lines, ~30 per 640x480 frame. */
#define ENCODE_MAX_THREADS 16u

typedef struct encoded_chunk {
    uint8_t *bytes; /* malloc'd: what goes into the file for this chunk */
    size_t size;
} encoded_chunk;

/* The chunks of one write, claimed in turn by the threads that compress them. */
typedef struct encode_job {
    exr_context_t context;
    const char *path;
    const pf_image *image;
    pf_exr_pixel_type pixel_type;
    int32_t lines_per_chunk;
    uint32_t chunk_count;
    encoded_chunk *chunks;
    atomic_uint next_chunk;
    atomic_int failed;
    pthread_mutex_t failure_lock; /* the first failure's report */
    pf_error failure;
} encode_job;

static void record_failure(encode_job *job, const pf_error *failure)
{
    pthread_mutex_lock(&job->failure_lock);
    if (!atomic_load(&job->failed))
        job->failure = *failure;
    atomic_store(&job->failed, 1);
    pthread_mutex_unlock(&job->failure_lock);
}

/* The pipeline's last step: keep the compressed chunk for the in-order write. */
static exr_result_t keep_chunk(exr_encode_pipeline_t *encoder)
{
    encode_job *job = encoder->encoding_user_data;
    if (encoder->chunk.idx < 0 || (uint32_t)encoder->chunk.idx >= job->chunk_count)
        return EXR_ERR_INVALID_ARGUMENT;
    encoded_chunk *chunk = &job->chunks[encoder->chunk.idx];
    chunk->bytes = malloc(encoder->compressed_bytes ? encoder->compressed_bytes : 1);
    if (!chunk->bytes)
        return EXR_ERR_OUT_OF_MEMORY;
    memcpy(chunk->bytes, encoder->compressed_buffer, encoder->compressed_bytes);
    chunk->size = encoder->compressed_bytes;
    return EXR_ERR_SUCCESS;
}

/* Points the encoder's channels at chunk rows of the image (or of its half copy). */
static pf_status bind_channels(encode_job *job, exr_encode_pipeline_t *encoder, const float *rows,
                               const uint16_t *half_rows, pf_error *err)
{
    const pf_image *image = job->image;
    const size_t width = image->width, channels = image->channel_count;
    for (int16_t i = 0; i < encoder->channel_count; i++) {
        exr_coding_channel_info_t *info = &encoder->channels[i];
        int c = pf_image_channel(image, info->channel_name);
        if (c < 0)
            return pf_error_set(err, PF_ERR_INTERNAL, "%s: encoder channel '%s' unknown",
                                job->path, info->channel_name);
        size_t element = half_rows ? sizeof(uint16_t) : sizeof(float);
        info->user_bytes_per_element = (int16_t)element;
        info->user_data_type = (uint16_t)(half_rows ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT);
        info->user_pixel_stride = (int32_t)(channels * element);
        info->user_line_stride = (int32_t)(width * channels * element);
        info->encode_from_ptr = half_rows ? (const uint8_t *)(half_rows + c)
                                          : (const uint8_t *)(rows + c);
    }
    return PF_OK;
}

/*
 * One thread's share: claims chunks until none is left, packs and compresses
 * each with its own pipeline (OpenEXRCore's encode pipelines are per thread;
 * the context locks itself). Half pixels are converted here (pf_float_to_half)
 * so the file holds exactly what the GPU readback path would produce.
 */
static void *encode_chunks(void *argument)
{
    encode_job *job = argument;
    const int part = 0;
    const pf_image *image = job->image;
    const size_t width = image->width, channels = image->channel_count;
    /* This thread's own message buffer for the library's error handler. */
    pf_exr_stream messages = {.fd = -1};
    pf_exr_stream_activate(&messages);
    pf_error err = {0};
    uint16_t *half_rows = NULL;
    if (job->pixel_type == PF_EXR_HALF) {
        half_rows = malloc((size_t)job->lines_per_chunk * width * channels * sizeof *half_rows);
        if (!half_rows) {
            pf_error_set(&err, PF_ERR_NOMEM, "%s: out of memory", job->path);
            record_failure(job, &err);
        }
    }
    exr_encode_pipeline_t encoder = EXR_ENCODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    while (!atomic_load(&job->failed)) {
        uint32_t index = atomic_fetch_add(&job->next_chunk, 1u);
        if (index >= job->chunk_count)
            break;
        uint32_t y = index * (uint32_t)job->lines_per_chunk;
        exr_chunk_info_t chunk;
        exr_result_t rc = exr_write_scanline_chunk_info(job->context, part, (int)y, &chunk);
        if (rc == EXR_ERR_SUCCESS)
            rc = initialized ? exr_encoding_update(job->context, part, &chunk, &encoder)
                             : exr_encoding_initialize(job->context, part, &chunk, &encoder);
        if (rc != EXR_ERR_SUCCESS) {
            pf_error_set(&err, PF_ERR_INTERNAL, "%s: scanline %u: %s", job->path, y,
                         pf_exr_message(&messages, rc));
            record_failure(job, &err);
            break;
        }
        initialized = 1;

        const float *rows = image->pixels + (size_t)y * width * channels;
        if (half_rows) {
            size_t chunk_values = (size_t)chunk.height * width * channels;
            for (size_t i = 0; i < chunk_values; i++)
                half_rows[i] = pf_float_to_half(rows[i]);
        }
        if (bind_channels(job, &encoder, rows, half_rows, &err) != PF_OK) {
            record_failure(job, &err);
            break;
        }
        if (!encoder.write_fn) {
            rc = exr_encoding_choose_default_routines(job->context, part, &encoder);
            /* No waiting for a turn: keep_chunk only stores, the caller writes in order. */
            encoder.yield_until_ready_fn = NULL;
            encoder.write_fn = keep_chunk;
            encoder.encoding_user_data = job;
        }
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_encoding_run(job->context, part, &encoder);
        if (rc != EXR_ERR_SUCCESS) {
            pf_error_set(&err, rc == EXR_ERR_OUT_OF_MEMORY ? PF_ERR_NOMEM : PF_ERR_INTERNAL,
                         "%s: scanline %u: %s", job->path, y, pf_exr_message(&messages, rc));
            record_failure(job, &err);
            break;
        }
    }
    if (initialized)
        exr_encoding_destroy(job->context, &encoder);
    free(half_rows);
    pf_exr_stream_activate(NULL);
    return NULL;
}

static uint32_t encode_thread_count(uint32_t chunk_count)
{
    uint32_t threads = pf_cpu_cores(ENCODE_MAX_THREADS);
    return threads < chunk_count ? threads : chunk_count;
}

/*
 * Compresses the chunks on up to one thread per CPU (ZIP is most of a write's
 * time), then writes them in order on the calling thread, whose stream
 * records a failed write(2). The file is the same for any thread count.
 */
static pf_status write_pixels(exr_context_t context, const char *path, const pf_image *image,
                              pf_exr_pixel_type pixel_type, pf_exr_stream *stream, pf_error *err)
{
    const int part = 0;
    int32_t lines_per_chunk = 0;
    exr_result_t rc = exr_get_scanlines_per_chunk(context, part, &lines_per_chunk);
    if (rc != EXR_ERR_SUCCESS || lines_per_chunk <= 0)
        return pf_error_set(err, PF_ERR_INTERNAL, "%s: scanlines per chunk: %s", path,
                            pf_exr_message(stream, rc));

    encode_job job = {
        .context = context,
        .path = path,
        .image = image,
        .pixel_type = pixel_type,
        .lines_per_chunk = lines_per_chunk,
        .chunk_count = (image->height + (uint32_t)lines_per_chunk - 1) / (uint32_t)lines_per_chunk,
    };
    job.chunks = calloc(job.chunk_count, sizeof *job.chunks);
    if (!job.chunks)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", path);
    pthread_mutex_init(&job.failure_lock, NULL);

    pthread_t threads[ENCODE_MAX_THREADS];
    uint32_t started = 0, wanted = encode_thread_count(job.chunk_count);
    while (started + 1 < wanted &&
           pthread_create(&threads[started], NULL, encode_chunks, &job) == 0)
        started++;
    encode_chunks(&job); /* the calling thread takes a share too */
    for (uint32_t i = 0; i < started; i++)
        pthread_join(threads[i], NULL);
    pf_exr_stream_activate(stream); /* encode_chunks left this thread without one */

    pf_status status = PF_OK;
    if (atomic_load(&job.failed)) {
        *err = job.failure;
        status = job.failure.status;
    }
    for (uint32_t i = 0; i < job.chunk_count && status == PF_OK; i++) {
        uint32_t y = i * (uint32_t)lines_per_chunk;
        rc = exr_write_scanline_chunk(context, part, (int)y, job.chunks[i].bytes,
                                      job.chunks[i].size);
        if (rc != EXR_ERR_SUCCESS)
            status = pf_error_set(err, stream->saved_errno ? PF_ERR_IO : PF_ERR_INTERNAL,
                                  "%s: scanline %u: %s", path, y, pf_exr_message(stream, rc));
    }
    for (uint32_t i = 0; i < job.chunk_count; i++)
        free(job.chunks[i].bytes);
    free(job.chunks);
    pthread_mutex_destroy(&job.failure_lock);
    return status;
}

/* fsync of the containing directory makes the rename itself durable. */
static pf_status sync_directory(const char *path, pf_error *err)
{
    char directory[PATH_MAX];
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(directory, sizeof directory, ".");
    else if (slash == path)
        snprintf(directory, sizeof directory, "/");
    else
        snprintf(directory, sizeof directory, "%.*s", (int)(slash - path), path);
    int fd = open(directory, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return pf_error_set(err, PF_ERR_IO, "%s: cannot open directory %s to sync it: %s", path,
                            directory, strerror(errno));
    /* Some filesystems cannot sync a directory (EINVAL): nothing more we can do there. */
    int failed = fsync(fd) != 0 && errno != EINVAL;
    int saved = errno;
    close(fd);
    if (failed)
        return pf_error_set(err, PF_ERR_IO, "%s: fsync of directory %s: %s", path, directory,
                            strerror(saved));
    return PF_OK;
}

static pf_status write_file(const char *path, const pf_image *image, pf_exr_pixel_type pixel_type,
                            const pf_image_attribute *attributes, uint32_t attribute_count,
                            pf_exr_stream *stream, pf_error *err);

pf_status pf_exr_write(const char *path, const pf_image *image, pf_exr_pixel_type pixel_type,
                       const pf_image_attribute *attributes, uint32_t attribute_count,
                       pf_error *err)
{
    pf_exr_stream stream = {.fd = -1};
    pf_exr_stream_activate(&stream);
    pf_status status = write_file(path, image, pixel_type, attributes, attribute_count, &stream,
                                  err);
    pf_exr_stream_activate(NULL);
    return status;
}

static pf_status write_file(const char *path, const pf_image *image, pf_exr_pixel_type pixel_type,
                            const pf_image_attribute *attributes, uint32_t attribute_count,
                            pf_exr_stream *stream, pf_error *err)
{
    if (!path || !path[0])
        return pf_error_set(err, PF_ERR_INVALID, "EXR write: empty output path");
    if (pixel_type != PF_EXR_HALF && pixel_type != PF_EXR_FLOAT)
        return pf_error_set(err, PF_ERR_INVALID, "%s: unknown pixel type %d", path,
                            (int)pixel_type);
    pf_status status = validate_image(path, image, err);
    if (status == PF_OK)
        status = validate_attributes(path, attributes, attribute_count, err);
    if (status != PF_OK)
        return status;

    char temporary[PATH_MAX];
    int length = snprintf(temporary, sizeof temporary, "%s.tmp-%ld-%u", path, (long)getpid(),
                          atomic_fetch_add(&temporary_counter, 1u));
    if (length < 0 || (size_t)length >= sizeof temporary)
        return pf_error_set(err, PF_ERR_INVALID, "%s: path too long", path);

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = pf_exr_capture_error;
    init.user_data = stream;
    init.write_fn = stream_write;
    exr_context_t context = NULL;
    /* With a custom write_fn the library opens nothing: the name is only for its messages. */
    exr_result_t rc = exr_start_write(&context, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (rc != EXR_ERR_SUCCESS)
        return pf_error_set(err, rc == EXR_ERR_OUT_OF_MEMORY ? PF_ERR_NOMEM : PF_ERR_INTERNAL,
                            "%s: cannot start EXR write: %s", path,
                            pf_exr_message(stream, rc));

    status = define_header(context, path, image, pixel_type, attributes, attribute_count,
                           stream, err);
    if (status == PF_OK) {
        stream->fd = open(temporary, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (stream->fd < 0)
            status = pf_error_set(err, PF_ERR_IO, "%s: cannot create %s: %s", path, temporary,
                                  strerror(errno));
    }
    if (status == PF_OK) {
        rc = exr_write_header(context);
        if (rc != EXR_ERR_SUCCESS)
            status = pf_error_set(err, stream->saved_errno ? PF_ERR_IO : PF_ERR_INTERNAL,
                                  "%s: EXR header: %s", path, pf_exr_message(stream, rc));
    }
    if (status == PF_OK)
        status = write_pixels(context, path, image, pixel_type, stream, err);
    /* exr_finish writes the chunk offset table, so its failure is a failed write. */
    rc = exr_finish(&context);
    if (status == PF_OK && rc != EXR_ERR_SUCCESS)
        status = pf_error_set(err, stream->saved_errno ? PF_ERR_IO : PF_ERR_INTERNAL,
                              "%s: finishing EXR: %s", path, pf_exr_message(stream, rc));
    /* A failed write(2) is the root cause whatever step noticed it first. */
    if (stream->saved_errno && status != PF_OK)
        status = pf_error_set(err, PF_ERR_IO, "%s: cannot write: %s", path,
                              strerror(stream->saved_errno));

    if (stream->fd >= 0) {
        if (status == PF_OK && fsync(stream->fd) != 0)
            status = pf_error_set(err, PF_ERR_IO, "%s: fsync: %s", path, strerror(errno));
        if (close(stream->fd) != 0 && status == PF_OK)
            status = pf_error_set(err, PF_ERR_IO, "%s: close: %s", path, strerror(errno));
        if (status == PF_OK && rename(temporary, path) != 0)
            status = pf_error_set(err, PF_ERR_IO, "%s: cannot rename %s over it: %s", path,
                                  temporary, strerror(errno));
        if (status != PF_OK)
            unlink(temporary);
    }
    if (status == PF_OK)
        status = sync_directory(path, err);
    return status;
}
