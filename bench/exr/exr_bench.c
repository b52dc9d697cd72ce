/*
 * EXR write benchmark: pf_exr_write (ZIP chunks compressed on one thread per
 * CPU, written in order) against OpenEXRCore's plain one-thread encode loop on
 * the same half-float image, in the same run. The image is a frame's
 * (argument 1: an EXR photonfarm wrote, every AOV layer) or, without one, a
 * synthetic 640x480 frame of 20 smooth, noisy channels. Both writers' files
 * must decode to the same pixels; the figures are best and median of N writes
 * (argument 2, default 9), fsync included in ours (it is part of every frame).
 */
#include "pf_image.h"
#include "../bench_stats.h"

#include <openexr.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec / 1e6;
}

/* 20 channels as a frame has them: beauty, AOV layers, smooth with speckle. */
static int synthetic_frame(pf_image *image, pf_error *err)
{
    static const char *const names[] = {
        "R", "G", "B", "A", "albedo.R", "albedo.G", "albedo.B", "caustic.R", "caustic.G",
        "caustic.B", "depth.Z", "direct.R", "direct.G", "direct.B", "indirect.R", "indirect.G",
        "indirect.B", "normal.X", "normal.Y", "normal.Z"};
    const uint32_t channels = sizeof names / sizeof *names;
    if (pf_image_create(image, 640, 480, channels, names, err) != PF_OK)
        return 0;
    uint32_t state = 12345u;
    for (uint32_t y = 0; y < image->height; y++)
        for (uint32_t x = 0; x < image->width; x++)
            for (uint32_t c = 0; c < channels; c++) {
                state = state * 1664525u + 1013904223u;
                float noise = (float)(state >> 8) / 16777216.0f;
                float smooth = 0.5f + 0.4f * sinf(0.01f * (float)(x + 3 * c)) *
                                          cosf(0.013f * (float)y);
                image->pixels[((size_t)y * image->width + x) * channels + c] =
                    smooth * (0.9f + 0.2f * noise);
            }
    return 1;
}

/* The peer: OpenEXRCore's default pipeline, one chunk after another on this thread. */
static int write_one_thread(const char *path, const pf_image *image)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t context = NULL;
    if (exr_start_write(&context, path, EXR_WRITE_FILE_DIRECTLY, &init) != EXR_ERR_SUCCESS)
        return 0;
    int part = 0, ok = 1;
    ok = exr_add_part(context, NULL, EXR_STORAGE_SCANLINE, &part) == EXR_ERR_SUCCESS &&
         exr_initialize_required_attr_simple(context, part, (int32_t)image->width,
                                             (int32_t)image->height,
                                             EXR_COMPRESSION_ZIP) == EXR_ERR_SUCCESS &&
         /* the same level as pf_exr_write's: the comparison is of the threads */
         exr_set_zip_compression_level(context, part, PF_EXR_ZIP_LEVEL) == EXR_ERR_SUCCESS;
    for (uint32_t c = 0; ok && c < image->channel_count; c++)
        ok = exr_add_channel(context, part, image->channel_names[c], EXR_PIXEL_HALF,
                             EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1) == EXR_ERR_SUCCESS;
    ok = ok && exr_write_header(context) == EXR_ERR_SUCCESS;
    int32_t lines = 0;
    ok = ok && exr_get_scanlines_per_chunk(context, part, &lines) == EXR_ERR_SUCCESS;
    const size_t width = image->width, channels = image->channel_count;
    uint16_t *half_rows = ok ? malloc((size_t)lines * width * channels * sizeof *half_rows) : NULL;
    ok = ok && half_rows;
    exr_encode_pipeline_t encoder = EXR_ENCODE_PIPELINE_INITIALIZER;
    for (uint32_t y = 0; ok && y < image->height; y += (uint32_t)lines) {
        exr_chunk_info_t chunk;
        ok = exr_write_scanline_chunk_info(context, part, (int)y, &chunk) == EXR_ERR_SUCCESS &&
             (y ? exr_encoding_update(context, part, &chunk, &encoder)
                : exr_encoding_initialize(context, part, &chunk, &encoder)) == EXR_ERR_SUCCESS;
        if (!ok)
            break;
        const float *rows = image->pixels + (size_t)y * width * channels;
        for (size_t i = 0; i < (size_t)chunk.height * width * channels; i++)
            half_rows[i] = pf_float_to_half(rows[i]);
        for (int16_t i = 0; i < encoder.channel_count; i++) {
            exr_coding_channel_info_t *info = &encoder.channels[i];
            int c = pf_image_channel(image, info->channel_name);
            info->user_bytes_per_element = 2;
            info->user_data_type = EXR_PIXEL_HALF;
            info->user_pixel_stride = (int32_t)(channels * 2);
            info->user_line_stride = (int32_t)(width * channels * 2);
            info->encode_from_ptr = (const uint8_t *)(half_rows + c);
        }
        if (y == 0)
            ok = exr_encoding_choose_default_routines(context, part, &encoder) == EXR_ERR_SUCCESS;
        ok = ok && exr_encoding_run(context, part, &encoder) == EXR_ERR_SUCCESS;
    }
    exr_encoding_destroy(context, &encoder);
    free(half_rows);
    return exr_finish(&context) == EXR_ERR_SUCCESS && ok;
}

static int same_pixels(const char *a, const char *b)
{
    pf_error err = {0};
    pf_image first, second;
    if (pf_exr_read(a, &first, NULL, NULL, &err) != PF_OK)
        return 0;
    if (pf_exr_read(b, &second, NULL, NULL, &err) != PF_OK) {
        pf_image_free(&first);
        return 0;
    }
    int same = first.width == second.width && first.height == second.height &&
               first.channel_count == second.channel_count;
    for (uint32_t c = 0; same && c < first.channel_count; c++) {
        int other = pf_image_channel(&second, first.channel_names[c]);
        for (size_t p = 0; same && other >= 0 && p < (size_t)first.width * first.height; p++)
            same = !memcmp(&first.pixels[p * first.channel_count + c],
                           &second.pixels[p * second.channel_count + (uint32_t)other],
                           sizeof(float));
        same = same && other >= 0;
    }
    pf_image_free(&first);
    pf_image_free(&second);
    return same;
}

static long file_size(const char *path)
{
    FILE *file = fopen(path, "rb");
    if (!file)
        return -1;
    fseek(file, 0, SEEK_END);
    long size = ftell(file);
    fclose(file);
    return size;
}

int main(int argc, char **argv)
{
    pf_error err = {0};
    pf_image image;
    int repeats = argc > 2 ? atoi(argv[2]) : 9;
    if (repeats < 1 || repeats > 1000) {
        fprintf(stderr, "usage: exr_bench [frame.exr] [repeats 1..1000]\n");
        return 2;
    }
    if (argc > 1 && strcmp(argv[1], "-") != 0) {
        if (pf_exr_read(argv[1], &image, NULL, NULL, &err) != PF_OK) {
            fprintf(stderr, "exr_bench: %s\n", err.message);
            return 2;
        }
    } else if (!synthetic_frame(&image, &err)) {
        fprintf(stderr, "exr_bench: %s\n", err.message);
        return 2;
    }
    const char *tmp = getenv("TMPDIR") && *getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
    char ours[1024], peer[1024];
    snprintf(ours, sizeof ours, "%s/exr_bench-%ld-ours.exr", tmp, (long)getpid());
    snprintf(peer, sizeof peer, "%s/exr_bench-%ld-peer.exr", tmp, (long)getpid());

    double *ours_ms = calloc((size_t)repeats, sizeof *ours_ms);
    double *peer_ms = calloc((size_t)repeats, sizeof *peer_ms);
    if (!ours_ms || !peer_ms)
        return 2;
    /* Interleaved, so a busy spell of the machine hits both alike. */
    for (int i = 0; i < repeats; i++) {
        double start = now_ms();
        if (pf_exr_write(ours, &image, PF_EXR_HALF, NULL, 0, &err) != PF_OK) {
            fprintf(stderr, "exr_bench: %s\n", err.message);
            return 2;
        }
        ours_ms[i] = now_ms() - start;
        start = now_ms();
        if (!write_one_thread(peer, &image)) {
            fprintf(stderr, "exr_bench: OpenEXRCore one-thread write of %s failed\n", peer);
            return 2;
        }
        peer_ms[i] = now_ms() - start;
    }
    bench_sort(ours_ms, repeats);
    bench_sort(peer_ms, repeats);
    int same = same_pixels(ours, peer);
    printf("image %ux%u, %u half channels, %d writes each, %ld online CPUs\n", image.width,
           image.height, image.channel_count, repeats, sysconf(_SC_NPROCESSORS_ONLN));
    printf("pf_exr_write (parallel ZIP, fsync)   best %8.1f ms  median %8.1f ms  %ld bytes\n",
           ours_ms[0], ours_ms[repeats / 2], file_size(ours));
    printf("OpenEXRCore one thread (no fsync)    best %8.1f ms  median %8.1f ms  %ld bytes\n",
           peer_ms[0], peer_ms[repeats / 2], file_size(peer));
    printf("speed-up best %.2fx median %.2fx; pixels %s\n", peer_ms[0] / ours_ms[0],
           peer_ms[repeats / 2] / ours_ms[repeats / 2], same ? "identical" : "DIFFER");
    unlink(ours);
    unlink(peer);
    free(ours_ms);
    free(peer_ms);
    pf_image_free(&image);
    return same ? 0 : 1;
}
