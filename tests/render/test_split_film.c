/*
 * The film's split into the image's channels on the device (split_film.comp, issue 43)
 * against the host's arithmetic it replaced (pf_split_film_to_image): random sums,
 * pixels with no kept sample, AOV films with and without their own count, with and
 * without AOVs, at a width that is no multiple of the kernel's 64-wide groups, and an
 * image larger than one storage buffer may hold.
 */
#include "pf_render.h"
#include "pf_test.h"
#include "render_internal.h"
#include "render_test_env.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_renderer *renderer;

static float next_value(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return (float)(*state >> 8) / (float)(1u << 24) * 40.0f - 4.0f;
}

/* Fills a film of vec4_per_pixel vec4s a pixel; every 7th pixel has no kept sample. */
static float *random_film(uint32_t pixels, uint32_t vec4_per_pixel, uint32_t count_slot,
                          uint32_t seed)
{
    float *film = malloc((size_t)pixels * vec4_per_pixel * 4 * sizeof *film);
    if (!film)
        return NULL;
    uint32_t state = seed;
    for (uint32_t i = 0; i < pixels * vec4_per_pixel * 4; i++)
        film[i] = next_value(&state);
    for (uint32_t p = 0; p < pixels; p++) {
        float *count = &film[(size_t)p * vec4_per_pixel * 4 + count_slot];
        *count = p % 7 == 0 ? 0.0f : (float)(1 + p % 13);
    }
    return film;
}

/* Splits the films on the device and on the host into images with the channels of
 * later_layers after the split's; the number of values that differ, or that are not zero
 * in those channels. */
static size_t split_both_ways(uint32_t width, uint32_t height, int aovs, int aov_own_count,
                              uint32_t later_layers)
{
    uint32_t pixels = width * height;
    /* The kept samples are the second vec4's w; the AOV film's own count likewise. */
    float *film = random_film(pixels, PF_SPLIT_FILM_VEC4_PER_PIXEL, 7, 11u + (uint32_t)aovs);
    float *film_aov = random_film(pixels, PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL, 7, 29u);
    if (!film || !film_aov) {
        free(film);
        free(film_aov);
        return (size_t)-1;
    }
    pf_render_settings settings = {0};
    settings.width = width;
    settings.height = height;
    pf_vk_buffer *film_buffer = NULL, *aov_buffer = NULL;
    pf_error err = {0};
    PF_CHECK_OK(pf_split_film_create(ctx, &settings, 1, "test", &film_buffer, &aov_buffer, &err),
                &err);
    PF_CHECK_OK(pf_vk_buffer_upload(ctx, film_buffer, 0, film,
                                    (uint64_t)pixels * PF_SPLIT_FILM_VEC4_PER_PIXEL * 16, &err),
                &err);
    PF_CHECK_OK(pf_vk_buffer_upload(ctx, aov_buffer, 0, film_aov,
                                    (uint64_t)pixels * PF_SPLIT_FILM_AOV_VEC4_PER_PIXEL * 16,
                                    &err),
                &err);
    pf_image device = {0}, host = {0};
    PF_CHECK_OK(pf_split_image_create(&device, width, height, aovs, later_layers, &err), &err);
    PF_CHECK_OK(pf_split_image_create(&host, width, height, aovs, later_layers, &err), &err);
    uint32_t split_channels = aovs ? 20u : 13u;
    uint32_t later = (later_layers & PF_LATER_LAYER_MOTION ? 2u : 0u) +
                     (later_layers & PF_LATER_LAYER_NOISY ? 4u : 0u);
    PF_CHECK_MSG(host.channel_count == split_channels + later, "%u channels, expected %u",
                 host.channel_count, split_channels + later);
    PF_CHECK_OK(pf_split_film_read(renderer, film_buffer, aov_buffer, aovs, aov_own_count,
                                   &device, &err),
                &err);
    pf_split_film_to_image(film, film_aov, aovs, aov_own_count, &host);
    size_t values = (size_t)pixels * host.channel_count, differing = 0;
    for (size_t i = 0; i < values; i++)
        differing += memcmp(&device.pixels[i], &host.pixels[i], sizeof(float)) != 0 ||
                     (i % host.channel_count >= split_channels && device.pixels[i] != 0.0f);
    /* Not a vacuous match: the host's image is not all zero. */
    size_t nonzero = 0;
    for (size_t i = 0; i < values; i++)
        nonzero += host.pixels[i] != 0.0f;
    PF_CHECK_MSG(nonzero > values / 2, "%zu of %zu values are non-zero", nonzero, values);
    pf_image_free(&device);
    pf_image_free(&host);
    pf_vk_buffer_destroy(ctx, film_buffer);
    pf_vk_buffer_destroy(ctx, aov_buffer);
    free(film);
    free(film_aov);
    return differing;
}

PF_TEST(the_device_splits_the_film_as_the_host_did)
{
    for (int aovs = 0; aovs <= 1; aovs++)
        for (int own = 0; own <= 1; own++) {
            size_t differing = split_both_ways(83, 21, aovs, own, 0);
            PF_CHECK_MSG(differing == 0, "aovs %d, own count %d: %zu values differ", aovs, own,
                         differing);
        }
    /* With the later stages' layers after the split's (the image's stride grows). */
    static const uint32_t layers[3] = {PF_LATER_LAYER_MOTION, PF_LATER_LAYER_NOISY,
                                       PF_LATER_LAYER_MOTION | PF_LATER_LAYER_NOISY};
    for (int aovs = 0; aovs <= 1; aovs++)
        for (int l = 0; l < 3; l++) {
            size_t differing = split_both_ways(83, 21, aovs, 1, layers[l]);
            PF_CHECK_MSG(differing == 0, "aovs %d, later layers %u: %zu values differ", aovs,
                         layers[l], differing);
        }
    /* 136 MB of channels: past lavapipe's 128 MiB storage-buffer range, so the image is
     * split in two bands of rows (the second one partial) where the device binds no more. */
    size_t differing = split_both_ways(1700, 1000, 1, 1, 0);
    PF_CHECK_MSG(differing == 0, "1700x1000 with AOVs: %zu values differ", differing);
}

int main(void)
{
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(the_device_splits_the_film_as_the_host_did);
    return render_test_finish(ctx, renderer);
}
