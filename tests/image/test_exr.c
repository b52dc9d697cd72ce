/*
 * EXR write/read: round trips (bit-exact float, half precision), NaN/Inf,
 * metadata, AOV channel order, odd sizes, atomic replacement under real write
 * failures, damaged and foreign files. Files that pf_exr_write cannot produce
 * (tiled, UINT, offset data window, multi-part) are written here with
 * OpenEXRCore directly so the reader's claims are tested too.
 */
#include "pf_image.h"
#include "pf_test.h"

#include <dirent.h>
#include <errno.h>
#include <openexr.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

static char tmp_dir[512];

static const char *tmp_path(char *buffer, size_t size, const char *name)
{
    snprintf(buffer, size, "%s/%s", tmp_dir, name);
    return buffer;
}

/* xorshift32: deterministic test data without global rand() state. */
static uint32_t next_random(uint32_t *state)
{
    uint32_t x = *state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    return *state = x;
}

static float float_from_bits(uint32_t bits)
{
    float value;
    memcpy(&value, &bits, sizeof value);
    return value;
}

static uint32_t bits_of(float value)
{
    uint32_t bits;
    memcpy(&bits, &value, sizeof bits);
    return bits;
}

/* Number of "<prefix>*.tmp-*" entries left in tmp_dir. */
static int count_temporaries(void)
{
    int count = 0;
    DIR *dir = opendir(tmp_dir);
    if (!dir)
        return -1;
    struct dirent *entry;
    while ((entry = readdir(dir)))
        count += strstr(entry->d_name, ".tmp-") != NULL;
    closedir(dir);
    return count;
}

static int read_whole_file(const char *path, char **data, size_t *size)
{
    FILE *file = fopen(path, "rb");
    if (!file)
        return 0;
    fseek(file, 0, SEEK_END);
    long length = ftell(file);
    fseek(file, 0, SEEK_SET);
    *data = malloc(length > 0 ? (size_t)length : 1);
    *size = fread(*data, 1, (size_t)length, file);
    fclose(file);
    return *size == (size_t)length;
}

static const char *const rgba[] = {"R", "G", "B", "A"};

/* Random finite floats of every magnitude: negatives, denormals, near FLT_MAX. */
static void fill_random_finite(pf_image *image, uint32_t seed)
{
    size_t count = (size_t)image->width * image->height * image->channel_count;
    for (size_t i = 0; i < count; i++) {
        uint32_t bits;
        do
            bits = next_random(&seed);
        while ((bits & 0x7f800000u) == 0x7f800000u);
        image->pixels[i] = float_from_bits(bits);
    }
}

PF_TEST(float_round_trip_is_bit_exact)
{
    static const uint32_t sizes[][2] = {{1, 1}, {3, 7}, {641, 479}};
    for (size_t s = 0; s < sizeof sizes / sizeof *sizes; s++) {
        pf_error err = {0};
        pf_image image, back;
        PF_REQUIRE_OK(pf_image_create(&image, sizes[s][0], sizes[s][1], 4, rgba, &err), &err);
        fill_random_finite(&image, 12345u + (uint32_t)s);
        /* The named edge cases, where they fit. */
        const float edges[] = {-1.5f, float_from_bits(1u), -float_from_bits(0x007fffffu),
                               3.4028235e38f, -3.4028235e38f, 65504.0f, 1e-45f, -0.0f};
        size_t total = (size_t)image.width * image.height * 4;
        for (size_t e = 0; e < sizeof edges / sizeof *edges && e < total; e++)
            image.pixels[e] = edges[e];
        char path[600];
        tmp_path(path, sizeof path, "float.exr");
        PF_REQUIRE_OK(pf_exr_write(path, &image, PF_EXR_FLOAT, NULL, 0, &err), &err);
        PF_REQUIRE_OK(pf_exr_read(path, &back, NULL, NULL, &err), &err);
        PF_CHECK(back.width == image.width && back.height == image.height);
        PF_REQUIRE(back.channel_count == 4);
        PF_CHECK(!memcmp(back.pixels, image.pixels, total * sizeof(float)));
        for (uint32_t c = 0; c < 4; c++)
            PF_CHECK(!strcmp(back.channel_names[c], rgba[c]));
        pf_image_free(&image);
        pf_image_free(&back);
    }
}

/*
 * The chunks are compressed on several threads and written by one: whatever
 * thread finishes first, the file must hold them in increasing y (the line
 * order the header declares), be the same bytes on every write, and read back
 * exactly. Each 16-line chunk differs, so a swapped chunk shows.
 */
PF_TEST(parallel_compression_writes_chunks_in_order)
{
    pf_error err = {0};
    pf_image image, back;
    PF_REQUIRE_OK(pf_image_create(&image, 97, 1003, 4, rgba, &err), &err);
    size_t total = (size_t)image.width * image.height * 4;
    uint32_t seed = 99u;
    for (size_t i = 0; i < total; i++) {
        size_t row = i / ((size_t)image.width * 4), channel = i % 4;
        /* R is the row (distinct in every chunk), the others sparse eighths: compressible,
         * and exact in half as in float. */
        image.pixels[i] = channel == 0 ? (float)row
                                       : (float)channel * 0.25f +
                                             (next_random(&seed) % 8 == 0 ? 0.125f : 0.0f);
    }
    const pf_exr_pixel_type types[] = {PF_EXR_FLOAT, PF_EXR_HALF};
    for (size_t t = 0; t < 2; t++) {
        char path[600];
        char *first = NULL, *again = NULL;
        size_t first_size = 0, again_size = 0;
        tmp_path(path, sizeof path, "chunks.exr");
        PF_REQUIRE_OK(pf_exr_write(path, &image, types[t], NULL, 0, &err), &err);
        PF_REQUIRE(read_whole_file(path, &first, &first_size));
        for (int repeat = 0; repeat < 3; repeat++) {
            PF_REQUIRE_OK(pf_exr_write(path, &image, types[t], NULL, 0, &err), &err);
            PF_REQUIRE(read_whole_file(path, &again, &again_size));
            PF_CHECK_MSG(again_size == first_size && !memcmp(first, again, first_size),
                         "write %d of the same image gave other bytes", repeat + 2);
            free(again);
        }
        free(first);

        exr_context_t context = NULL;
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        PF_REQUIRE(exr_start_read(&context, path, &init) == EXR_ERR_SUCCESS);
        int32_t lines = 0;
        PF_CHECK(exr_get_scanlines_per_chunk(context, 0, &lines) == EXR_ERR_SUCCESS);
        PF_REQUIRE(lines > 0 && (uint32_t)lines < image.height / 8); /* many chunks */
        uint64_t previous_end = 0;
        int out_of_order = 0;
        for (int32_t y = 0; y < (int32_t)image.height; y += lines) {
            exr_chunk_info_t chunk;
            PF_REQUIRE(exr_read_scanline_chunk_info(context, 0, y, &chunk) == EXR_ERR_SUCCESS);
            out_of_order += chunk.data_offset < previous_end;
            previous_end = chunk.data_offset + chunk.packed_size;
        }
        exr_finish(&context);
        PF_CHECK_MSG(out_of_order == 0, "%d chunks stored before the one above them",
                     out_of_order);

        PF_REQUIRE_OK(pf_exr_read(path, &back, NULL, NULL, &err), &err);
        int wrong_rows = 0;
        for (uint32_t y = 0; y < image.height; y++) {
            size_t at = (size_t)y * image.width * 4;
            wrong_rows += memcmp(&back.pixels[at], &image.pixels[at],
                                 (size_t)image.width * 4 * sizeof(float)) != 0;
        }
        PF_CHECK_MSG(wrong_rows == 0, "%d rows read back wrong", wrong_rows);
        pf_image_free(&back);
    }
    pf_image_free(&image);
}

PF_TEST(half_round_trip_within_half_precision)
{
    static const uint32_t sizes[][2] = {{1, 1}, {3, 7}, {641, 479}};
    for (size_t s = 0; s < sizeof sizes / sizeof *sizes; s++) {
        pf_error err = {0};
        pf_image image, back;
        PF_REQUIRE_OK(pf_image_create(&image, sizes[s][0], sizes[s][1], 3, rgba, &err), &err);
        size_t total = (size_t)image.width * image.height * 3;
        uint32_t seed = 777u + (uint32_t)s;
        for (size_t i = 0; i < total; i++) {
            /* Alternate: arbitrary values over the normal half range, and exact halves. */
            if (i % 2) {
                float unit = (float)(next_random(&seed) >> 8) / 16777216.0f;
                float magnitude = ldexpf(1.0f + unit, (int)(next_random(&seed) % 30) - 14);
                image.pixels[i] = (next_random(&seed) & 1) ? -magnitude : magnitude;
                if (fabsf(image.pixels[i]) > 65504.0f)
                    image.pixels[i] = 65504.0f;
            } else {
                uint16_t half;
                do
                    half = (uint16_t)next_random(&seed);
                while ((half & 0x7c00u) == 0x7c00u);
                image.pixels[i] = pf_half_to_float(half);
            }
        }
        char path[600];
        tmp_path(path, sizeof path, "half.exr");
        PF_REQUIRE_OK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err), &err);
        PF_REQUIRE_OK(pf_exr_read(path, &back, NULL, NULL, &err), &err);
        PF_REQUIRE(back.width == image.width && back.height == image.height &&
                   back.channel_count == 3);
        int inexact_half = 0, too_far = 0;
        for (size_t i = 0; i < total; i++) {
            float written = image.pixels[i], read = back.pixels[i];
            if (i % 2 == 0) {
                inexact_half += bits_of(read) != bits_of(written);
            } else if (fabsf(read - written) > fabsf(written) * ldexpf(1.0f, -11)) {
                too_far++;
            }
        }
        PF_CHECK_MSG(inexact_half == 0, "%d representable halves changed", inexact_half);
        PF_CHECK_MSG(too_far == 0, "%d values beyond 2^-11 relative error", too_far);
        pf_image_free(&image);
        pf_image_free(&back);
    }
}

PF_TEST(nan_and_inf_round_trip)
{
    const pf_exr_pixel_type types[] = {PF_EXR_HALF, PF_EXR_FLOAT};
    for (size_t t = 0; t < 2; t++) {
        pf_error err = {0};
        pf_image image, back;
        PF_REQUIRE_OK(pf_image_create(&image, 2, 2, 1, (const char *const[]){"Y"}, &err), &err);
        image.pixels[0] = NAN;
        image.pixels[1] = INFINITY;
        image.pixels[2] = -INFINITY;
        image.pixels[3] = 1e6f; /* above the half range: inf in a half file */
        char path[600];
        tmp_path(path, sizeof path, "special.exr");
        PF_REQUIRE_OK(pf_exr_write(path, &image, types[t], NULL, 0, &err), &err);
        PF_REQUIRE_OK(pf_exr_read(path, &back, NULL, NULL, &err), &err);
        PF_CHECK(isnan(back.pixels[0]));
        PF_CHECK(isinf(back.pixels[1]) && back.pixels[1] > 0);
        PF_CHECK(isinf(back.pixels[2]) && back.pixels[2] < 0);
        if (types[t] == PF_EXR_HALF)
            PF_CHECK(isinf(back.pixels[3]) && back.pixels[3] > 0);
        else
            PF_CHECK(back.pixels[3] == 1e6f);
        pf_image_free(&image);
        pf_image_free(&back);
    }
}

static pf_image_attribute make_attribute(const char *key, const char *value)
{
    pf_image_attribute attribute;
    memset(&attribute, 0, sizeof attribute);
    snprintf(attribute.key, sizeof attribute.key, "%s", key);
    snprintf(attribute.value, sizeof attribute.value, "%s", value);
    return attribute;
}

PF_TEST(metadata_reads_back_exactly)
{
    pf_error err = {0};
    pf_image image, back;
    PF_REQUIRE_OK(pf_image_create(&image, 5, 3, 4, rgba, &err), &err);
    char long_value[512];
    for (size_t i = 0; i < sizeof long_value - 1; i++)
        long_value[i] = (char)('a' + i % 26);
    long_value[sizeof long_value - 1] = '\0';
    pf_image_attribute written[] = {
        make_attribute("photonfarm/scene", "/work/shared/scenes/cornell/cornell.gltf"),
        make_attribute("photonfarm/frame", "12"),
        make_attribute("photonfarm/preset", "final"),
        make_attribute("photonfarm/settings", "{\"photons\": 200000, \"spp\": 4}\nline two"),
        make_attribute("photonfarm/renderTime", "1234.5"),
        make_attribute("photonfarm/device", "llvmpipe (LLVM 15.0.6, 256 bits) \xc3\xa9"),
        make_attribute("photonfarm/a-key-longer-than-thirty-one-chars", "long name"),
        make_attribute("photonfarm/empty", ""),
        make_attribute("photonfarm/long", long_value),
    };
    const uint32_t count = sizeof written / sizeof *written;
    char path[600];
    tmp_path(path, sizeof path, "metadata.exr");
    PF_REQUIRE_OK(pf_exr_write(path, &image, PF_EXR_HALF, written, count, &err), &err);
    pf_image_attribute *read = NULL;
    uint32_t read_count = 0;
    PF_REQUIRE_OK(pf_exr_read(path, &back, &read, &read_count, &err), &err);
    /* Only our strings come back: the channel order is a string vector, not a string. */
    PF_CHECK(read_count == count);
    for (uint32_t i = 0; i < count; i++) {
        int found = 0;
        for (uint32_t j = 0; j < read_count; j++) {
            if (!strcmp(read[j].key, written[i].key)) {
                found = 1;
                PF_CHECK_MSG(!strcmp(read[j].value, written[i].value), "attribute %s",
                             written[i].key);
            }
        }
        PF_CHECK_MSG(found, "attribute %s not read back", written[i].key);
    }
    free(read);
    pf_image_free(&back);

    /* Bad keys are refused before anything is written. */
    pf_image_attribute bad[] = {make_attribute("", "x")};
    PF_CHECK(pf_exr_write(path, &image, PF_EXR_HALF, bad, 1, &err) == PF_ERR_INVALID);
    bad[0] = make_attribute("compression", "none");
    PF_CHECK(pf_exr_write(path, &image, PF_EXR_HALF, bad, 1, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "compression") != NULL);
    pf_image_attribute twice[] = {make_attribute("k", "1"), make_attribute("k", "2")};
    PF_CHECK(pf_exr_write(path, &image, PF_EXR_HALF, twice, 2, &err) == PF_ERR_INVALID);
    pf_image_free(&image);
}

PF_TEST(aov_channels_keep_the_image_order)
{
    static const char *const names[] = {"R",        "G",        "B",        "A",
                                        "albedo.R", "albedo.G", "albedo.B", "normal.X",
                                        "normal.Y", "normal.Z", "depth.Z"};
    const uint32_t count = sizeof names / sizeof *names;
    pf_error err = {0};
    pf_image image, back;
    PF_REQUIRE_OK(pf_image_create(&image, 3, 7, count, names, &err), &err);
    /* Channel c holds 100 c + pixel index: a channel read into the wrong slot shows. */
    for (uint32_t p = 0; p < 21; p++)
        for (uint32_t c = 0; c < count; c++)
            image.pixels[p * count + c] = (float)(100 * c + p);
    char path[600];
    tmp_path(path, sizeof path, "aov.exr");
    PF_REQUIRE_OK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err), &err);
    PF_REQUIRE_OK(pf_exr_read(path, &back, NULL, NULL, &err), &err);
    PF_REQUIRE(back.channel_count == count);
    for (uint32_t c = 0; c < count; c++)
        PF_CHECK_MSG(!strcmp(back.channel_names[c], names[c]), "channel %u is %s, expected %s",
                     c, back.channel_names[c], names[c]);
    PF_CHECK(!memcmp(back.pixels, image.pixels, 21 * count * sizeof(float)));
    PF_CHECK(pf_image_channel(&back, "normal.Y") == 8);
    PF_CHECK(pf_image_channel(&back, "normal.W") == -1);
    pf_image_free(&image);
    pf_image_free(&back);
}

PF_TEST(invalid_images_are_refused)
{
    pf_error err = {0};
    pf_image image;
    PF_CHECK(pf_image_create(&image, 0, 4, 4, rgba, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_image_create(&image, 4, 4, 2, (const char *const[]){"R", "R"}, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "'R'") != NULL);
    PF_CHECK(pf_image_create(&image, 4, 4, 1, (const char *const[]){""}, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_image_create(&image, 4, 4, 1,
                             (const char *const[]){"a-channel-name-of-thirty-two-chars"},
                             &err) == PF_ERR_INVALID);
    pf_image empty = {0};
    char path[600];
    tmp_path(path, sizeof path, "empty.exr");
    PF_CHECK(pf_exr_write(path, &empty, PF_EXR_HALF, NULL, 0, &err) == PF_ERR_INVALID);
    PF_CHECK(access(path, F_OK) != 0);
}

PF_TEST(success_leaves_no_temporaries)
{
    pf_error err = {0};
    pf_image image;
    PF_REQUIRE_OK(pf_image_create(&image, 8, 8, 4, rgba, &err), &err);
    char path[600];
    tmp_path(path, sizeof path, "clean.exr");
    for (int i = 0; i < 3; i++) /* the second and third replace the first */
        PF_CHECK_OK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err), &err);
    PF_CHECK(access(path, F_OK) == 0);
    PF_CHECK(count_temporaries() == 0);
    pf_image_free(&image);
}

PF_TEST(unwritable_directory_fails_cleanly)
{
    pf_error err = {0};
    pf_image image;
    PF_REQUIRE_OK(pf_image_create(&image, 8, 8, 4, rgba, &err), &err);
    char path[600];
    tmp_path(path, sizeof path, "no-such-directory/frame.exr");
    PF_CHECK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err) == PF_ERR_IO);
    PF_CHECK_MSG(strstr(err.message, path) != NULL, "message: %s", err.message);
    PF_CHECK_MSG(strstr(err.message, strerror(ENOENT)) != NULL, "message: %s", err.message);
    PF_CHECK(count_temporaries() == 0);

    /* Permissions do not bind root, so the read-only case only runs unprivileged. */
    if (geteuid() != 0) {
        char locked[600];
        tmp_path(locked, sizeof locked, "read-only");
        mkdir(locked, 0755);
        PF_REQUIRE(chmod(locked, 0555) == 0);
        tmp_path(path, sizeof path, "read-only/frame.exr");
        PF_CHECK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err) == PF_ERR_IO);
        PF_CHECK_MSG(strstr(err.message, strerror(EACCES)) != NULL, "message: %s", err.message);
        chmod(locked, 0755);
        DIR *dir = opendir(locked);
        int entries = 0;
        for (struct dirent *entry; dir && (entry = readdir(dir));)
            entries += entry->d_name[0] != '.';
        if (dir)
            closedir(dir);
        PF_CHECK(entries == 0);
    }
    pf_image_free(&image);
}

/*
 * A write that fails part-way (the file-size limit, as on a full disk: write(2)
 * returns EFBIG once the temporary reaches it) must leave the old frame intact.
 */
PF_TEST(failed_write_keeps_the_old_file)
{
    pf_error err = {0};
    pf_image old_image, new_image;
    PF_REQUIRE_OK(pf_image_create(&old_image, 4, 4, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&new_image, 641, 479, 4, rgba, &err), &err);
    fill_random_finite(&new_image, 99u); /* incompressible: far larger than the limit */
    char path[600];
    tmp_path(path, sizeof path, "keep.exr");
    PF_REQUIRE_OK(pf_exr_write(path, &old_image, PF_EXR_FLOAT, NULL, 0, &err), &err);
    char *before = NULL, *after = NULL;
    size_t before_size = 0, after_size = 0;
    PF_REQUIRE(read_whole_file(path, &before, &before_size));

    /* 64 KiB: the pixels fail; 0: the very first write, inside exr_write_header
     * (where OpenEXR holds its context lock while it reports the error, which
     * once deadlocked the writer). */
    static const rlim_t limits[] = {64 * 1024, 0};
    for (size_t i = 0; i < sizeof limits / sizeof *limits; i++) {
        struct rlimit saved;
        PF_REQUIRE(getrlimit(RLIMIT_FSIZE, &saved) == 0);
        struct rlimit limited = saved;
        limited.rlim_cur = limits[i];
        void (*previous)(int) = signal(SIGXFSZ, SIG_IGN);
        PF_REQUIRE(setrlimit(RLIMIT_FSIZE, &limited) == 0);
        pf_status status = pf_exr_write(path, &new_image, PF_EXR_FLOAT, NULL, 0, &err);
        setrlimit(RLIMIT_FSIZE, &saved);
        signal(SIGXFSZ, previous);

        PF_CHECK(status == PF_ERR_IO);
        PF_CHECK_MSG(strstr(err.message, path) != NULL && strstr(err.message, strerror(EFBIG)),
                     "limit %llu: message: %s", (unsigned long long)limits[i], err.message);
        PF_CHECK(read_whole_file(path, &after, &after_size));
        PF_CHECK(after_size == before_size && !memcmp(before, after, before_size));
        PF_CHECK(count_temporaries() == 0);
        free(after);
        after = NULL;
    }
    free(before);

    /* The rename itself fails: a non-empty directory sits at the output path. */
    char blocked[600], inner[700];
    tmp_path(blocked, sizeof blocked, "blocked.exr");
    mkdir(blocked, 0755);
    snprintf(inner, sizeof inner, "%s/keep", blocked);
    FILE *marker = fopen(inner, "w");
    PF_REQUIRE(marker != NULL);
    fclose(marker);
    PF_CHECK(pf_exr_write(blocked, &old_image, PF_EXR_HALF, NULL, 0, &err) == PF_ERR_IO);
    PF_CHECK_MSG(strstr(err.message, "rename") != NULL, "message: %s", err.message);
    PF_CHECK(access(inner, F_OK) == 0);
    PF_CHECK(count_temporaries() == 0);
    pf_image_free(&old_image);
    pf_image_free(&new_image);
}

PF_TEST(damaged_and_foreign_files_are_errors)
{
    pf_error err = {0};
    pf_image image, back;
    PF_REQUIRE_OK(pf_image_create(&image, 641, 479, 4, rgba, &err), &err);
    fill_random_finite(&image, 5u);
    char path[600], truncated[600];
    tmp_path(path, sizeof path, "whole.exr");
    tmp_path(truncated, sizeof truncated, "truncated.exr");
    PF_REQUIRE_OK(pf_exr_write(path, &image, PF_EXR_HALF, NULL, 0, &err), &err);
    char *data = NULL;
    size_t size = 0;
    PF_REQUIRE(read_whole_file(path, &data, &size));
    /* Cut in the header, the offset table and the pixel data; half is the named case. */
    const size_t cuts[] = {size / 2, 0, 3, 40, 200, 400, size / 8, size - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof *cuts; i++) {
        FILE *file = fopen(truncated, "wb");
        PF_REQUIRE(file != NULL);
        fwrite(data, 1, cuts[i], file);
        fclose(file);
        pf_status status = pf_exr_read(truncated, &back, NULL, NULL, &err);
        PF_CHECK_MSG(status == PF_ERR_FORMAT || status == PF_ERR_IO,
                     "cut at %zu of %zu: status %d", cuts[i], size, (int)status);
        PF_CHECK_MSG(strstr(err.message, truncated) != NULL, "cut at %zu: %s", cuts[i],
                     err.message);
        PF_CHECK(back.pixels == NULL);
    }
    free(data);

    char text[600];
    tmp_path(text, sizeof text, "not-an-exr.exr");
    FILE *file = fopen(text, "w");
    PF_REQUIRE(file != NULL);
    fputs("this is a text file, not an image\n", file);
    fclose(file);
    PF_CHECK(pf_exr_read(text, &back, NULL, NULL, &err) == PF_ERR_FORMAT);
    PF_CHECK_MSG(strstr(err.message, text) != NULL, "message: %s", err.message);

    char missing[600];
    tmp_path(missing, sizeof missing, "missing.exr");
    PF_CHECK(pf_exr_read(missing, &back, NULL, NULL, &err) == PF_ERR_IO);
    PF_CHECK(strstr(err.message, missing) != NULL && strstr(err.message, strerror(ENOENT)));
    PF_CHECK(pf_exr_read(tmp_dir, &back, NULL, NULL, &err) == PF_ERR_IO);
    pf_image_free(&image);
}

/* Writes with OpenEXRCore directly: a tiled part (or two scanline parts) with a
 * UINT, a HALF and a FLOAT channel over a data window that starts at (-2, 5). */
enum { FOREIGN_W = 37, FOREIGN_H = 23, FOREIGN_X0 = -2, FOREIGN_Y0 = 5 };

static float foreign_value(int channel, int x, int y)
{
    return (float)(channel * 1000 + y * FOREIGN_W + x) * (channel == 1 ? 0.5f : 1.0f);
}

static int write_foreign(const char *path, int tiled, int part_count)
{
    exr_context_t context = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    if (exr_start_write(&context, path, EXR_WRITE_FILE_DIRECTLY, &init) != EXR_ERR_SUCCESS)
        return 0;
    exr_attr_box2i_t window;
    window.min.x = FOREIGN_X0;
    window.min.y = FOREIGN_Y0;
    window.max.x = FOREIGN_X0 + FOREIGN_W - 1;
    window.max.y = FOREIGN_Y0 + FOREIGN_H - 1;
    exr_attr_v2f_t center;
    center.x = center.y = 0.0f;
    const char *names[] = {"count", "H", "F"};
    const exr_pixel_type_t types[] = {EXR_PIXEL_UINT, EXR_PIXEL_HALF, EXR_PIXEL_FLOAT};
    int ok = 1;
    for (int p = 0; p < part_count && ok; p++) {
        int part = 0;
        char part_name[16];
        snprintf(part_name, sizeof part_name, "part%d", p);
        ok = exr_add_part(context, part_count > 1 ? part_name : NULL,
                          tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part) == 0 &&
             exr_initialize_required_attr(context, part, &window, &window, 1.0f, &center, 1.0f,
                                          EXR_LINEORDER_INCREASING_Y, EXR_COMPRESSION_PIZ) == 0;
        if (ok && tiled)
            ok = exr_set_tile_descriptor(context, part, 16, 8, EXR_TILE_ONE_LEVEL,
                                         EXR_TILE_ROUND_DOWN) == 0;
        for (int c = 0; c < 3 && ok; c++)
            ok = exr_add_channel(context, part, names[c], types[c], EXR_PERCEPTUALLY_LINEAR, 1,
                                 1) == 0;
    }
    ok = ok && exr_write_header(context) == 0;
    /* Planar source for the whole image, in each channel's own type. */
    uint32_t counts[FOREIGN_W * FOREIGN_H];
    uint16_t halves[FOREIGN_W * FOREIGN_H];
    float floats[FOREIGN_W * FOREIGN_H];
    for (int y = 0; y < FOREIGN_H; y++)
        for (int x = 0; x < FOREIGN_W; x++) {
            counts[y * FOREIGN_W + x] = (uint32_t)foreign_value(0, x, y);
            halves[y * FOREIGN_W + x] = pf_float_to_half(foreign_value(1, x, y));
            floats[y * FOREIGN_W + x] = foreign_value(2, x, y);
        }
    const uint8_t *planes[] = {(const uint8_t *)counts, (const uint8_t *)halves,
                               (const uint8_t *)floats};
    const int sizes[] = {4, 2, 4};
    for (int part = 0; part < part_count && ok; part++) {
        exr_encode_pipeline_t encoder = EXR_ENCODE_PIPELINE_INITIALIZER;
        int lines = 0;
        int chunk_count = tiled ? ((FOREIGN_W + 15) / 16) * ((FOREIGN_H + 7) / 8) : 0;
        if (!tiled) {
            ok = exr_get_scanlines_per_chunk(context, part, &lines) == 0;
            chunk_count = (FOREIGN_H + lines - 1) / lines;
        }
        for (int index = 0; index < chunk_count && ok; index++) {
            exr_chunk_info_t chunk;
            int x0 = 0, y0;
            if (tiled) {
                int tx = index % ((FOREIGN_W + 15) / 16), ty = index / ((FOREIGN_W + 15) / 16);
                x0 = tx * 16;
                y0 = ty * 8;
                ok = exr_write_tile_chunk_info(context, part, tx, ty, 0, 0, &chunk) == 0;
            } else {
                y0 = index * lines;
                ok = exr_write_scanline_chunk_info(context, part, FOREIGN_Y0 + y0, &chunk) == 0;
            }
            ok = ok && (index == 0 ? exr_encoding_initialize(context, part, &chunk, &encoder)
                                   : exr_encoding_update(context, part, &chunk, &encoder)) == 0;
            for (int i = 0; i < encoder.channel_count && ok; i++) {
                exr_coding_channel_info_t *info = &encoder.channels[i];
                int c = !strcmp(info->channel_name, "count") ? 0
                        : !strcmp(info->channel_name, "H")   ? 1
                                                             : 2;
                info->user_bytes_per_element = (int16_t)sizes[c];
                info->user_data_type = (uint16_t)types[c];
                info->user_pixel_stride = sizes[c];
                info->user_line_stride = FOREIGN_W * sizes[c];
                info->encode_from_ptr = planes[c] + ((size_t)y0 * FOREIGN_W + x0) * sizes[c];
            }
            if (ok && index == 0)
                ok = exr_encoding_choose_default_routines(context, part, &encoder) == 0;
            ok = ok && exr_encoding_run(context, part, &encoder) == 0;
        }
        exr_encoding_destroy(context, &encoder);
    }
    return exr_finish(&context) == 0 && ok;
}

PF_TEST(reads_tiled_uint_and_offset_windows)
{
    const int tiled_modes[] = {1, 0};
    for (size_t m = 0; m < 2; m++) {
        char path[600];
        tmp_path(path, sizeof path, tiled_modes[m] ? "foreign-tiled.exr" : "foreign-scan.exr");
        PF_REQUIRE(write_foreign(path, tiled_modes[m], 1));
        pf_error err = {0};
        pf_image image;
        PF_REQUIRE_OK(pf_exr_read(path, &image, NULL, NULL, &err), &err);
        PF_CHECK(image.width == FOREIGN_W && image.height == FOREIGN_H);
        PF_REQUIRE(image.channel_count == 3);
        /* No channel order attribute: the file's (sorted) order. */
        PF_CHECK(!strcmp(image.channel_names[0], "F") && !strcmp(image.channel_names[1], "H") &&
                 !strcmp(image.channel_names[2], "count"));
        int wrong = 0;
        const int file_channel[] = {2, 1, 0}; /* F, H, count */
        for (int y = 0; y < FOREIGN_H; y++)
            for (int x = 0; x < FOREIGN_W; x++)
                for (int c = 0; c < 3; c++)
                    wrong += image.pixels[((size_t)y * FOREIGN_W + x) * 3 + c] !=
                             foreign_value(file_channel[c], x, y);
        PF_CHECK_MSG(wrong == 0, "%s: %d samples wrong", path, wrong);
        pf_image_free(&image);
    }
}

PF_TEST(multi_part_is_unsupported)
{
    char path[600];
    tmp_path(path, sizeof path, "two-parts.exr");
    PF_REQUIRE(write_foreign(path, 0, 2));
    pf_error err = {0};
    pf_image image;
    PF_CHECK(pf_exr_read(path, &image, NULL, NULL, &err) == PF_ERR_UNSUPPORTED);
    PF_CHECK_MSG(strstr(err.message, path) && strstr(err.message, "multi-part"), "message: %s",
                 err.message);
    PF_CHECK(image.pixels == NULL);
}

int main(void)
{
    pf_test_tmpdir(tmp_dir, sizeof tmp_dir);
    PF_RUN(float_round_trip_is_bit_exact);
    PF_RUN(half_round_trip_within_half_precision);
    PF_RUN(parallel_compression_writes_chunks_in_order);
    PF_RUN(nan_and_inf_round_trip);
    PF_RUN(metadata_reads_back_exactly);
    PF_RUN(aov_channels_keep_the_image_order);
    PF_RUN(invalid_images_are_refused);
    PF_RUN(success_leaves_no_temporaries);
    PF_RUN(unwritable_directory_fails_cleanly);
    PF_RUN(failed_write_keeps_the_old_file);
    PF_RUN(damaged_and_foreign_files_are_errors);
    PF_RUN(reads_tiled_uint_and_offset_windows);
    PF_RUN(multi_part_is_unsupported);
    return pf_test_finish();
}
