/*
 * VPL injection on the device (pf_lpv_inject_photons, shaders/lpv_inject.comp):
 * the volume and counts of the host's reference (pf_lpv_inject) from the same
 * photon records, sums that do not depend on the order of the records, and a
 * propagation from the injection kept on the device equal to one from the
 * volume uploaded.
 */
#include "../vk/vk_test_util.h"
#include "lpv_test_quad.h"
#include "pf_lpv.h"
#include "pf_photon.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define VPLS 6000u
#define FLUX_SCALE 0.0375f

static pf_vk_context *ctx;
static pf_lpv *lpv;
static quad_frame scene;
static pf_lpv_layout layout;
static pf_photon records[VPLS];

static uint32_t next_random(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return *state >> 8;
}

static float uniform(uint32_t *state, float lo, float hi)
{
    return lo + (hi - lo) * (float)next_random(state) / 16777216.0f;
}

/* Records over a box a little larger than the coarsest cascade (some land outside every
 * cascade), unit normals in every direction, flux over three decades; the last one has
 * a NaN position (rejected). */
static void make_records(void)
{
    uint32_t state = 12345u;
    for (uint32_t v = 0; v < VPLS; v++) {
        float position[3], normal[3], flux[3], incoming[3] = {0.0f, -1.0f, 0.0f};
        for (int i = 0; i < 3; i++) {
            position[i] = uniform(&state, -3.5f, 5.5f);
            normal[i] = uniform(&state, -1.0f, 1.0f);
            flux[i] = powf(10.0f, uniform(&state, -1.5f, 1.5f));
        }
        float length = sqrtf(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
        for (int i = 0; i < 3; i++)
            normal[i] = length > 1e-3f ? normal[i] / length : (i == 1);
        if (v + 1 == VPLS)
            position[0] = NAN;
        pf_photon_pack(position, flux, incoming, normal, &records[v]);
    }
}

/* The host's reference: the records unpacked as the fast integrator's host path does. */
static void host_reference(float *grid, pf_lpv_inject_stats *stats)
{
    static pf_lpv_vpl vpls[VPLS];
    for (uint32_t v = 0; v < VPLS; v++) {
        float incoming[3];
        pf_photon_unpack(&records[v], vpls[v].position, vpls[v].flux, incoming, vpls[v].normal);
        for (int c = 0; c < 3; c++)
            vpls[v].flux[c] *= FLUX_SCALE;
    }
    pf_lpv_inject(&layout, vpls, VPLS, grid, stats);
}

/* The records (in the order given) injected on the device and read back. */
static int device_injection(const pf_photon *photons, uint32_t count, float *grid,
                            pf_lpv_inject_stats *stats)
{
    pf_error err = {0};
    pf_vk_buffer *buffer = NULL;
    double gpu_ms = 0.0;
    pf_status status = pf_vk_buffer_create(ctx, (count ? count : 1) * sizeof(pf_photon),
                                           "test photons", &buffer, &err);
    if (status == PF_OK && count > 0)
        status = pf_vk_buffer_upload(ctx, buffer, 0, photons, count * sizeof(pf_photon), &err);
    if (status == PF_OK)
        status = pf_lpv_inject_photons(lpv, &layout, buffer, count, FLUX_SCALE, grid, stats,
                                       &gpu_ms, &err);
    if (buffer)
        pf_vk_buffer_destroy(ctx, buffer);
    if (status != PF_OK)
        fprintf(stderr, "device injection: %s\n", err.message);
    return status == PF_OK;
}

PF_TEST(the_device_injects_what_the_host_reference_does)
{
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *host = calloc(floats, sizeof *host), *device = calloc(floats, sizeof *device);
    PF_REQUIRE(host && device);
    pf_lpv_inject_stats host_stats, device_stats;
    host_reference(host, &host_stats);
    PF_REQUIRE(device_injection(records, VPLS, device, &device_stats));
    /* Counts: a VPL within float rounding of a cell face may fall on either side (the host
     * finds the cell in double): at most a few in 6,000. */
    printf("  host: rejected %u, outside %u; device: rejected %u, outside %u\n",
           host_stats.rejected, host_stats.outside, device_stats.rejected, device_stats.outside);
    PF_CHECK(device_stats.rejected == 1 && host_stats.rejected == 1);
    PF_CHECK(abs((int)device_stats.outside - (int)host_stats.outside) <= 2);
    PF_CHECK(host_stats.outside > 100 && host_stats.outside < VPLS / 2);
    for (uint32_t k = 0; k < layout.count; k++) {
        printf("  cascade %u: host %u VPLs, device %u\n", k, host_stats.injected[k],
               device_stats.injected[k]);
        PF_CHECK(abs((int)device_stats.injected[k] - (int)host_stats.injected[k]) <= 2);
    }
    /* Values: each cell within 1e-5 of the cascade's largest value (the host's float sums
     * round; the device's fixed point does not), but for the cells of such border VPLs. */
    uint64_t cell_floats = (uint64_t)layout.size * layout.size * layout.size *
                           PF_LPV_FLOATS_PER_CELL;
    uint32_t off_cells = 0;
    for (uint32_t k = 0; k < layout.count; k++) {
        double largest = 0.0;
        for (uint64_t i = k * cell_floats; i < (k + 1) * cell_floats; i++)
            largest = fmax(largest, fabs(host[i]));
        PF_CHECK(largest > 0.0);
        for (uint64_t cell = k * cell_floats; cell < (k + 1) * cell_floats;
             cell += PF_LPV_FLOATS_PER_CELL) {
            int off = 0;
            for (uint32_t f = 0; f < PF_LPV_FLOATS_PER_CELL; f++)
                off |= fabs((double)host[cell + f] - device[cell + f]) > 1e-5 * largest;
            off_cells += off;
        }
    }
    printf("  cells off by more than 1e-5 of their cascade's largest value: %u\n", off_cells);
    PF_CHECK(off_cells <= 4);
    free(host);
    free(device);
}

PF_TEST(the_sums_do_not_depend_on_the_order_of_the_records)
{
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *forward = calloc(floats, sizeof *forward), *backward = calloc(floats, sizeof *backward);
    static pf_photon reversed[VPLS];
    PF_REQUIRE(forward && backward);
    for (uint32_t v = 0; v < VPLS; v++)
        reversed[v] = records[VPLS - 1 - v];
    pf_lpv_inject_stats a, b;
    PF_REQUIRE(device_injection(records, VPLS, forward, &a));
    PF_REQUIRE(device_injection(reversed, VPLS, backward, &b));
    PF_CHECK(!memcmp(&a, &b, sizeof a));
    PF_CHECK(!memcmp(forward, backward, floats * sizeof(float)));
    /* No records: an empty volume, every count 0. */
    PF_REQUIRE(device_injection(NULL, 0, backward, &b));
    size_t nonzero = 0;
    for (uint64_t i = 0; i < floats; i++)
        nonzero += backward[i] != 0.0f;
    PF_CHECK(nonzero == 0 && b.outside == 0 && b.rejected == 0 && b.injected[0] == 0);
    free(forward);
    free(backward);
}

PF_TEST(a_propagation_from_the_kept_injection_equals_one_from_the_uploaded_volume)
{
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *injected = calloc(floats, sizeof *injected);
    float *kept = calloc(floats, sizeof *kept), *uploaded = calloc(floats, sizeof *uploaded);
    float *gv = calloc(pf_lpv_volume_floats(&layout, PF_LPV_GV_FLOATS_PER_CELL), sizeof *gv);
    PF_REQUIRE(injected && kept && uploaded && gv);
    pf_lpv_geometry_build(&layout, &scene.frame, gv);
    pf_lpv_inject_stats stats;
    pf_error err = {0};
    PF_REQUIRE(device_injection(records, VPLS, injected, &stats));
    /* Twice from the kept sums (a frame that reuses the injection and propagates again),
     * then from the read-back volume: the same accumulation to the bit. */
    for (int run = 0; run < 2; run++) {
        PF_CHECK_OK(pf_lpv_propagate(lpv, &layout, NULL, gv, NULL, &err), &err);
        PF_CHECK_OK(pf_lpv_download(lpv, kept, floats, &err), &err);
    }
    PF_CHECK_OK(pf_lpv_propagate(lpv, &layout, injected, gv, NULL, &err), &err);
    PF_CHECK_OK(pf_lpv_download(lpv, uploaded, floats, &err), &err);
    PF_CHECK(!memcmp(kept, uploaded, floats * sizeof(float)));
    /* A layout of another size has no kept injection; the host's propagation needs the
     * volume on the host. */
    pf_lpv_layout other = layout;
    other.size = layout.size / 2;
    PF_CHECK(pf_lpv_propagate(lpv, &other, NULL, NULL, NULL, &err) == PF_ERR_INVALID);
    pf_lpv_set_site(lpv, PF_LPV_SITE_HOST);
    PF_CHECK(pf_lpv_propagate(lpv, &layout, NULL, gv, NULL, &err) == PF_ERR_INVALID);
    pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
    free(injected);
    free(kept);
    free(uploaded);
    free(gv);
}

int main(void)
{
    pf_error err = {0};
    ctx = vk_test_context(&err);
    if (!ctx)
        return 1;
    if (pf_lpv_create(ctx, &lpv, &err) != PF_OK) {
        fprintf(stderr, "pf_lpv_create: %s\n", err.message);
        pf_vk_destroy(ctx);
        return 1;
    }
    pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
    quad_frame_init(&scene);
    float p0[3] = {0, 0, 0}, p1[3] = {2, 0, 0}, p2[3] = {2, 0, 2}, p3[3] = {0, 0, 2};
    quad_frame_add(&scene, p0, p3, p2, p1); /* a floor facing +y */
    pf_lpv_settings settings = {.cascades = 3, .size = 16, .iterations = {4}};
    float focus[3] = {1.0f, 0.5f, 1.0f};
    pf_lpv_layout_make(&settings, focus, 0.125f, &scene.frame, &layout);
    make_records();
    if (!pf_lpv_injects_on_device(lpv, &layout)) {
        printf("SKIP: '%s' has no 64-bit buffer atomics (the host injects there)\n",
               pf_vk_info(ctx)->name);
    } else {
        PF_RUN(the_device_injects_what_the_host_reference_does);
        PF_RUN(the_sums_do_not_depend_on_the_order_of_the_records);
        PF_RUN(a_propagation_from_the_kept_injection_equals_one_from_the_uploaded_volume);
    }
    pf_lpv_destroy(lpv);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
