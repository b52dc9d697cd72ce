/*
 * pf_exr_read: any single-part scanline or tiled EXR (HALF/FLOAT/UINT channels,
 * any compression OpenEXRCore decodes) into a float pf_image. The file is read
 * through our own descriptor so open errors carry errno and a truncated file is
 * judged against its real size.
 */
#include "exr_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

typedef struct reader {
    const char *path;
    exr_context_t context;
    pf_exr_stream stream;
    int32_t origin_x, origin_y; /* data window minimum: pixel (0,0) of the image */
    uint8_t *chunk_buffer;      /* one decoded chunk, planar, in the file's types */
} reader;

static int64_t stream_read(exr_const_context_t context, void *user_data, void *buffer,
                           uint64_t size, uint64_t offset, exr_stream_error_func_ptr_t error_cb)
{
    pf_exr_stream *stream = user_data;
    char *bytes = buffer;
    uint64_t done = 0;
    while (done < size) {
        ssize_t got = pread(stream->fd, bytes + done, (size_t)(size - done), (off_t)(offset + done));
        if (got < 0 && errno == EINTR)
            continue;
        if (got < 0) {
            if (!stream->saved_errno)
                stream->saved_errno = errno;
            error_cb(context, EXR_ERR_READ_IO, "read at offset %llu: %s",
                     (unsigned long long)offset, strerror(errno));
            return -1;
        }
        if (got == 0) /* end of file: the library reports the short read itself */
            break;
        done += (uint64_t)got;
    }
    return (int64_t)done;
}

static int64_t stream_size(exr_const_context_t context, void *user_data)
{
    (void)context;
    pf_exr_stream *stream = user_data;
    struct stat info;
    return fstat(stream->fd, &info) == 0 ? (int64_t)info.st_size : -1;
}

/* Status for a failed library call: I/O if read(2) failed, else malformed content. */
static pf_status read_failure(reader *r, pf_error *err, const char *what, exr_result_t rc)
{
    if (r->stream.saved_errno)
        return pf_error_set(err, PF_ERR_IO, "%s: %s: %s", r->path, what,
                            strerror(r->stream.saved_errno));
    if (rc == EXR_ERR_OUT_OF_MEMORY)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: %s: out of memory", r->path, what);
    return pf_error_set(err, PF_ERR_FORMAT, "%s: %s: %s", r->path, what,
                        pf_exr_message(&r->stream, rc));
}

static int name_in_list(const char *name, const char *const *names, int count)
{
    for (int i = 0; i < count; i++) {
        if (!strcmp(name, names[i]))
            return 1;
    }
    return 0;
}

/*
 * Output channel order: the writer's order when the file carries our channel
 * order attribute and it names exactly the file's channels; otherwise (files
 * from other tools) R, G, B, A first, then the rest in the file's sorted order.
 */
static void choose_channel_order(reader *r, const exr_attr_chlist_t *list, const char **order)
{
    const int count = list->num_channels;
    const exr_attribute_t *attribute = NULL;
    if (exr_get_attribute_by_name(r->context, 0, PF_EXR_CHANNEL_ORDER_ATTRIBUTE, &attribute) ==
            EXR_ERR_SUCCESS &&
        attribute->type == EXR_ATTR_STRING_VECTOR && attribute->stringvector->n_strings == count) {
        int valid = 1;
        for (int i = 0; i < count && valid; i++) {
            const exr_attr_string_t *entry = &attribute->stringvector->strings[i];
            order[i] = NULL;
            for (int c = 0; c < count; c++) {
                const exr_attr_string_t *channel = &list->entries[c].name;
                if (channel->length == entry->length &&
                    !memcmp(channel->str, entry->str, (size_t)entry->length))
                    order[i] = channel->str;
            }
            valid = order[i] && !name_in_list(order[i], order, i);
        }
        if (valid)
            return;
        pf_log(PF_LOG_DEBUG, "%s: channel order attribute does not match the channels; ignored",
               r->path);
    }
    static const char *const beauty[] = {"R", "G", "B", "A"};
    int placed = 0;
    for (size_t b = 0; b < sizeof beauty / sizeof *beauty; b++) {
        for (int c = 0; c < count; c++) {
            if (!strcmp(list->entries[c].name.str, beauty[b]))
                order[placed++] = list->entries[c].name.str;
        }
    }
    for (int c = 0; c < count; c++) {
        if (!name_in_list(list->entries[c].name.str, order, placed))
            order[placed++] = list->entries[c].name.str;
    }
}

static pf_status create_image(reader *r, pf_image *out, pf_error *err)
{
    exr_storage_t storage;
    int part_count = 0;
    exr_result_t rc = exr_get_count(r->context, &part_count);
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "part count", rc);
    if (part_count != 1)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "%s: multi-part EXR (%d parts); only single-part files are read",
                            r->path, part_count);
    rc = exr_get_storage(r->context, 0, &storage);
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "storage type", rc);
    if (storage != EXR_STORAGE_SCANLINE && storage != EXR_STORAGE_TILED)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "%s: deep EXR data; only flat scanline or tiled files are read",
                            r->path);

    exr_attr_box2i_t window;
    rc = exr_get_data_window(r->context, 0, &window);
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "dataWindow", rc);
    int64_t width = (int64_t)window.max.x - window.min.x + 1;
    int64_t height = (int64_t)window.max.y - window.min.y + 1;
    if (width <= 0 || height <= 0 || width > UINT32_MAX || height > UINT32_MAX)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: dataWindow (%d,%d)-(%d,%d) is empty",
                            r->path, window.min.x, window.min.y, window.max.x, window.max.y);
    r->origin_x = window.min.x;
    r->origin_y = window.min.y;

    const exr_attr_chlist_t *list = NULL;
    rc = exr_get_channels(r->context, 0, &list);
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "channels", rc);
    if (list->num_channels <= 0)
        return pf_error_set(err, PF_ERR_FORMAT, "%s: no channels", r->path);
    for (int c = 0; c < list->num_channels; c++) {
        const exr_attr_chlist_entry_t *entry = &list->entries[c];
        if (entry->x_sampling != 1 || entry->y_sampling != 1)
            return pf_error_set(err, PF_ERR_UNSUPPORTED,
                                "%s: channel '%s' is subsampled (%dx%d); only full-resolution "
                                "channels are read",
                                r->path, entry->name.str, entry->x_sampling, entry->y_sampling);
        if (entry->name.length >= PF_IMAGE_CHANNEL_NAME_MAX)
            return pf_error_set(err, PF_ERR_UNSUPPORTED,
                                "%s: channel name '%s' is longer than %d characters", r->path,
                                entry->name.str, PF_IMAGE_CHANNEL_NAME_MAX - 1);
    }

    const char **order = malloc((size_t)list->num_channels * sizeof *order);
    if (!order)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", r->path);
    choose_channel_order(r, list, order);
    pf_status status = pf_image_create(out, (uint32_t)width, (uint32_t)height,
                                       (uint32_t)list->num_channels, order, err);
    free(order);
    if (status != PF_OK)
        pf_error_prefix(err, "%s", r->path);
    return status;
}

/* Converts one decoded planar chunk into the interleaved float image. */
static void store_chunk(const exr_decode_pipeline_t *decoder, pf_image *image,
                        const int *image_channel, uint32_t x0, uint32_t y0)
{
    for (int16_t i = 0; i < decoder->channel_count; i++) {
        const exr_coding_channel_info_t *info = &decoder->channels[i];
        const uint8_t *plane = info->decode_to_ptr;
        for (int32_t y = 0; y < info->height; y++) {
            float *row = image->pixels +
                         ((size_t)(y0 + (uint32_t)y) * image->width + x0) * image->channel_count +
                         image_channel[i];
            const uint8_t *source = plane + (size_t)y * (size_t)info->user_line_stride;
            for (int32_t x = 0; x < info->width; x++) {
                float value;
                if (info->data_type == EXR_PIXEL_HALF) {
                    uint16_t half;
                    memcpy(&half, source + (size_t)x * 2, sizeof half);
                    value = pf_half_to_float(half);
                } else if (info->data_type == EXR_PIXEL_FLOAT) {
                    memcpy(&value, source + (size_t)x * 4, sizeof value);
                } else {
                    uint32_t integer; /* exact up to 2^24, then rounded */
                    memcpy(&integer, source + (size_t)x * 4, sizeof integer);
                    value = (float)integer;
                }
                row[(size_t)x * image->channel_count] = value;
            }
        }
    }
}

/* Points each decoder channel at its plane of chunk_buffer, in the file's own type. */
static pf_status bind_channels(reader *r, exr_decode_pipeline_t *decoder, const pf_image *image,
                               int *image_channel, pf_error *err)
{
    size_t offset = 0;
    for (int16_t i = 0; i < decoder->channel_count; i++) {
        exr_coding_channel_info_t *info = &decoder->channels[i];
        image_channel[i] = pf_image_channel(image, info->channel_name);
        if (image_channel[i] < 0)
            return pf_error_set(err, PF_ERR_INTERNAL, "%s: decoder channel '%s' unknown",
                                r->path, info->channel_name);
        info->user_bytes_per_element = info->bytes_per_element;
        info->user_data_type = info->data_type;
        info->user_pixel_stride = info->bytes_per_element;
        info->user_line_stride = info->width * info->bytes_per_element;
        info->decode_to_ptr = r->chunk_buffer + offset;
        offset += (size_t)info->height * (size_t)info->user_line_stride;
    }
    return PF_OK;
}

typedef struct chunk_list {
    int32_t count;
    int32_t tiles_x;           /* tiled parts: tiles per row at level 0 */
    int32_t tile_w, tile_h;    /* tiled parts: tile size */
    int32_t lines_per_chunk;   /* scanline parts */
} chunk_list;

static pf_status read_pixels(reader *r, pf_image *image, pf_error *err)
{
    exr_storage_t storage;
    exr_result_t rc = exr_get_storage(r->context, 0, &storage);
    chunk_list chunks = {0};
    if (rc == EXR_ERR_SUCCESS && storage == EXR_STORAGE_TILED) {
        /* Level 0 is the full-resolution image of a mipmapped or ripmapped file. */
        rc = exr_get_tile_sizes(r->context, 0, 0, 0, &chunks.tile_w, &chunks.tile_h);
        if (rc == EXR_ERR_SUCCESS && (chunks.tile_w <= 0 || chunks.tile_h <= 0))
            rc = EXR_ERR_INVALID_ATTR;
        if (rc == EXR_ERR_SUCCESS) {
            chunks.tiles_x = (int32_t)((image->width + (uint32_t)chunks.tile_w - 1) /
                                       (uint32_t)chunks.tile_w);
            chunks.count = chunks.tiles_x * (int32_t)((image->height + (uint32_t)chunks.tile_h - 1) /
                                                      (uint32_t)chunks.tile_h);
        }
    } else if (rc == EXR_ERR_SUCCESS) {
        rc = exr_get_scanlines_per_chunk(r->context, 0, &chunks.lines_per_chunk);
        if (rc == EXR_ERR_SUCCESS && chunks.lines_per_chunk <= 0)
            rc = EXR_ERR_INVALID_ATTR;
        if (rc == EXR_ERR_SUCCESS)
            chunks.count = (int32_t)((image->height + (uint32_t)chunks.lines_per_chunk - 1) /
                                     (uint32_t)chunks.lines_per_chunk);
    }
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "chunk layout", rc);

    size_t max_pixels = storage == EXR_STORAGE_TILED
                            ? (size_t)chunks.tile_w * (size_t)chunks.tile_h
                            : (size_t)chunks.lines_per_chunk * image->width;
    /* 4 bytes is the widest EXR sample (FLOAT, UINT). */
    r->chunk_buffer = malloc(max_pixels * image->channel_count * 4);
    int *image_channel = malloc(image->channel_count * sizeof *image_channel);
    if (!r->chunk_buffer || !image_channel) {
        free(image_channel);
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", r->path);
    }

    exr_decode_pipeline_t decoder = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialized = 0;
    pf_status status = PF_OK;
    for (int32_t index = 0; index < chunks.count && status == PF_OK; index++) {
        exr_chunk_info_t chunk;
        uint32_t x0 = 0, y0 = 0;
        char where[64];
        if (storage == EXR_STORAGE_TILED) {
            int32_t tile_x = index % chunks.tiles_x, tile_y = index / chunks.tiles_x;
            x0 = (uint32_t)(tile_x * chunks.tile_w);
            y0 = (uint32_t)(tile_y * chunks.tile_h);
            snprintf(where, sizeof where, "tile (%d, %d)", tile_x, tile_y);
            rc = exr_read_tile_chunk_info(r->context, 0, tile_x, tile_y, 0, 0, &chunk);
        } else {
            y0 = (uint32_t)(index * chunks.lines_per_chunk);
            snprintf(where, sizeof where, "scanline %d", r->origin_y + (int32_t)y0);
            rc = exr_read_scanline_chunk_info(r->context, 0, r->origin_y + (int32_t)y0, &chunk);
        }
        if (rc == EXR_ERR_SUCCESS)
            rc = initialized ? exr_decoding_update(r->context, 0, &chunk, &decoder)
                             : exr_decoding_initialize(r->context, 0, &chunk, &decoder);
        if (rc != EXR_ERR_SUCCESS) {
            status = read_failure(r, err, where, rc);
            break;
        }
        initialized = 1;
        if ((uint64_t)chunk.width * (uint64_t)chunk.height > max_pixels ||
            x0 + (uint32_t)chunk.width > image->width || y0 + (uint32_t)chunk.height > image->height) {
            status = pf_error_set(err, PF_ERR_FORMAT, "%s: %s: chunk %dx%d lies outside the image",
                                  r->path, where, chunk.width, chunk.height);
            break;
        }
        status = bind_channels(r, &decoder, image, image_channel, err);
        if (status != PF_OK)
            break;
        if (index == 0)
            rc = exr_decoding_choose_default_routines(r->context, 0, &decoder);
        if (rc == EXR_ERR_SUCCESS)
            rc = exr_decoding_run(r->context, 0, &decoder);
        if (rc != EXR_ERR_SUCCESS)
            status = read_failure(r, err, where, rc);
        else
            store_chunk(&decoder, image, image_channel, x0, y0);
    }
    if (initialized)
        exr_decoding_destroy(r->context, &decoder);
    free(image_channel);
    return status;
}

/* Copies the part's string attributes (file order), except the standard header
 * ones (pf_exr_reserved_attribute). Longer values than the
 * struct holds are cut, with a warning: losing a comment must not fail a read. */
static pf_status read_attributes(reader *r, pf_image_attribute **attributes, uint32_t *count,
                                 pf_error *err)
{
    int32_t total = 0;
    exr_result_t rc = exr_get_attribute_count(r->context, 0, &total);
    if (rc != EXR_ERR_SUCCESS)
        return read_failure(r, err, "attribute count", rc);
    pf_image_attribute *list = total > 0 ? calloc((size_t)total, sizeof *list) : NULL;
    if (total > 0 && !list)
        return pf_error_set(err, PF_ERR_NOMEM, "%s: out of memory", r->path);
    uint32_t kept = 0;
    for (int32_t i = 0; i < total; i++) {
        const exr_attribute_t *attribute = NULL;
        rc = exr_get_attribute_by_index(r->context, 0, EXR_ATTR_LIST_FILE_ORDER, i, &attribute);
        if (rc != EXR_ERR_SUCCESS) {
            free(list);
            return read_failure(r, err, "attribute", rc);
        }
        /* The library itself writes "type" into single-part files: not user metadata. */
        if (attribute->type != EXR_ATTR_STRING || pf_exr_reserved_attribute(attribute->name))
            continue;
        pf_image_attribute *entry = &list[kept];
        if (attribute->name_length >= sizeof entry->key) {
            pf_log(PF_LOG_WARN, "%s: attribute name '%s' is longer than %zu characters; skipped",
                   r->path, attribute->name, sizeof entry->key - 1);
            continue;
        }
        memcpy(entry->key, attribute->name, attribute->name_length);
        const exr_attr_string_t *value = attribute->string;
        size_t length = value->length > 0 ? (size_t)value->length : 0;
        if (length >= sizeof entry->value) {
            pf_log(PF_LOG_WARN, "%s: attribute '%s' is %zu characters; cut to %zu", r->path,
                   entry->key, length, sizeof entry->value - 1);
            length = sizeof entry->value - 1;
        }
        if (length)
            memcpy(entry->value, value->str, length);
        kept++;
    }
    if (kept == 0) {
        free(list);
        list = NULL;
    }
    *attributes = list;
    *count = kept;
    return PF_OK;
}

pf_status pf_exr_read(const char *path, pf_image *out, pf_image_attribute **attributes,
                      uint32_t *attribute_count, pf_error *err)
{
    memset(out, 0, sizeof *out);
    if (attributes)
        *attributes = NULL;
    if (attribute_count)
        *attribute_count = 0;
    reader r = {.path = path, .stream = {.fd = -1}};
    r.stream.fd = open(path, O_RDONLY | O_CLOEXEC);
    if (r.stream.fd < 0)
        return pf_error_set(err, PF_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat info;
    if (fstat(r.stream.fd, &info) != 0) {
        int saved = errno;
        close(r.stream.fd);
        return pf_error_set(err, PF_ERR_IO, "%s: cannot stat: %s", path, strerror(saved));
    }
    if (!S_ISREG(info.st_mode)) {
        close(r.stream.fd);
        return pf_error_set(err, PF_ERR_IO, "%s: not a regular file", path);
    }

    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = pf_exr_capture_error;
    init.user_data = &r.stream;
    init.read_fn = stream_read;
    init.size_fn = stream_size;
    /* A truncated or damaged file is an error, not a partly reconstructed image. */
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    pf_exr_stream_activate(&r.stream);
    exr_result_t rc = exr_start_read(&r.context, path, &init);
    pf_status status = PF_OK;
    if (rc != EXR_ERR_SUCCESS) {
        status = rc == EXR_ERR_FILE_BAD_HEADER && !r.stream.saved_errno
                     ? pf_error_set(err, PF_ERR_FORMAT, "%s: not a valid OpenEXR file: %s", path,
                                    pf_exr_message(&r.stream, rc))
                     : read_failure(&r, err, "header", rc);
    }
    if (status == PF_OK)
        status = create_image(&r, out, err);
    if (status == PF_OK)
        status = read_pixels(&r, out, err);
    if (status == PF_OK && attributes && attribute_count)
        status = read_attributes(&r, attributes, attribute_count, err);
    if (r.context)
        exr_finish(&r.context);
    pf_exr_stream_activate(NULL);
    free(r.chunk_buffer);
    close(r.stream.fd);
    if (status != PF_OK)
        pf_image_free(out);
    return status;
}
