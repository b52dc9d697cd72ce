/*
 * LPV propagation on the device (shaders/lpv_propagate.comp): flux
 * conservation of one step in empty space, a constant field staying
 * constant, a wall in the geometry volume blocking the flux that crosses
 * it, cascades that stay bit-identical under sub-cell camera moves and
 * shift by a cell under one-cell moves (on the device and on the host), the
 * accumulation and far fields equal to the sums of the single steps, and the
 * host propagation (lpv_propagate_host.c) agreeing with the device's.
 */
#include "../vk/vk_test_util.h"
#include "lpv_host_internal.h"
#include "lpv_test_quad.h"
#include "pf_lpv.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

static pf_vk_context *ctx;
static pf_lpv *lpv;

static uint64_t cell_of(uint32_t size, uint32_t x, uint32_t y, uint32_t z)
{
    return ((uint64_t)z * size + y) * size + x;
}

/* Σ over cells of ∫ I dω per channel. */
static void total_flux(const float *grid, uint64_t cells, double flux[3])
{
    flux[0] = flux[1] = flux[2] = 0.0;
    for (uint64_t i = 0; i < cells; i++)
        for (int ch = 0; ch < 3; ch++)
            flux[ch] += pf_sh_integral(grid + i * PF_LPV_FLOATS_PER_CELL + 4 * ch);
}

PF_TEST(one_step_in_empty_space_conserves_flux)
{
    const uint32_t size = 8;
    uint64_t cells = (uint64_t)size * size * size;
    float *src = calloc(cells * PF_LPV_FLOATS_PER_CELL, sizeof *src);
    float *dst = calloc(cells * PF_LPV_FLOATS_PER_CELL, sizeof *dst);
    PF_REQUIRE(src && dst);
    /*
     * Two interior cells, each a VPL lobe plus isotropic light: the lobe's
     * expansion 1/4 + cos/2 dips below 0 behind it (where the kernel clamps,
     * which conserves nothing), the isotropic part keeps every direction ≥ 0.
     */
    float normal[3] = {0.48f, -0.6f, 0.64f}, lobe[4];
    pf_sh_cosine_lobe(normal, lobe);
    float *a = src + cell_of(size, 3, 4, 4) * PF_LPV_FLOATS_PER_CELL;
    float *b = src + cell_of(size, 4, 3, 3) * PF_LPV_FLOATS_PER_CELL;
    const float colour_a[3] = {1.0f, 0.5f, 0.25f}, colour_b[3] = {0.1f, 0.7f, 2.0f};
    for (int ch = 0; ch < 3; ch++) {
        for (int c = 0; c < 4; c++) {
            a[4 * ch + c] = colour_a[ch] * lobe[c];
            b[4 * ch + c] = colour_b[ch] * 0.5f * lobe[c];
        }
        a[4 * ch] += colour_a[ch] * 1.0f; /* + isotropic: c0 Y00 ≥ |c1| Y1 */
        b[4 * ch] += colour_b[ch] * 0.5f;
    }
    pf_error err = {0};
    PF_REQUIRE_OK(pf_lpv_propagate_once(lpv, size, src, NULL, dst, &err), &err);
    double before[3], after[3];
    total_flux(src, cells, before);
    total_flux(dst, cells, after);
    for (int ch = 0; ch < 3; ch++) {
        double relative = fabs(after[ch] - before[ch]) / before[ch];
        printf("  channel %d: flux %.9g -> %.9g (relative %.2e)\n", ch, before[ch], after[ch],
               relative);
        PF_CHECK(relative <= 1e-5);
    }
    /* The source cells are emptied: everything moved to the neighbours. */
    PF_CHECK(dst[cell_of(size, 3, 4, 4) * PF_LPV_FLOATS_PER_CELL] <
             1e-3f * a[0]);
    free(src);
    free(dst);
}

PF_TEST(a_constant_isotropic_field_stays_constant_inside)
{
    const uint32_t size = 8;
    uint64_t cells = (uint64_t)size * size * size;
    float *src = calloc(cells * PF_LPV_FLOATS_PER_CELL, sizeof *src);
    float *dst = calloc(cells * PF_LPV_FLOATS_PER_CELL, sizeof *dst);
    PF_REQUIRE(src && dst);
    const float value[3] = {0.75f, 1.5f, 3.0f};
    for (uint64_t i = 0; i < cells; i++)
        for (int ch = 0; ch < 3; ch++)
            src[i * PF_LPV_FLOATS_PER_CELL + 4 * ch] = value[ch];
    pf_error err = {0};
    PF_REQUIRE_OK(pf_lpv_propagate_once(lpv, size, src, NULL, dst, &err), &err);
    double worst = 0.0, worst_directional = 0.0;
    for (uint32_t z = 1; z + 1 < size; z++)
        for (uint32_t y = 1; y + 1 < size; y++)
            for (uint32_t x = 1; x + 1 < size; x++) {
                const float *cell = dst + cell_of(size, x, y, z) * PF_LPV_FLOATS_PER_CELL;
                for (int ch = 0; ch < 3; ch++) {
                    worst = fmax(worst, fabs(cell[4 * ch] - value[ch]) / value[ch]);
                    for (int c = 1; c < 4; c++)
                        worst_directional =
                            fmax(worst_directional, fabs(cell[4 * ch + c]) / value[ch]);
                }
            }
    printf("  interior: worst relative change %.2e, directional part %.2e\n", worst,
           worst_directional);
    PF_CHECK(worst <= 1e-5);
    PF_CHECK(worst_directional <= 1e-5);
    /* A boundary cell loses what its missing neighbours would have sent. */
    PF_CHECK(dst[0] < 0.95f * value[0]);
    free(src);
    free(dst);
}

/* Flux that crossed x >= crossing (in cells) in the accumulated volume of a 1-cascade layout. */
static double flux_beyond(const float *grid, uint32_t size, uint32_t crossing)
{
    double sum = 0.0;
    for (uint32_t z = 0; z < size; z++)
        for (uint32_t y = 0; y < size; y++)
            for (uint32_t x = crossing; x < size; x++)
                sum += pf_sh_integral(grid + cell_of(size, x, y, z) * PF_LPV_FLOATS_PER_CELL);
    return sum;
}

PF_TEST(a_wall_blocks_the_flux_crossing_it)
{
    /* 16³ cells of 0.25 m from the origin; a wall filling the plane x = 2 m (cell 8's face). */
    pf_lpv_settings settings = {.cascades = 1, .size = 16, .iterations = {12}};
    float focus[3] = {2.0f, 2.0f, 2.0f};
    pf_lpv_layout layout;
    pf_lpv_layout_make(&settings, focus, 0.25f, NULL, &layout);
    PF_REQUIRE(layout.cascades[0].origin[0] == 0.0f);
    quad_frame wall;
    quad_frame_init(&wall);
    /* Facing −x, towards the light (a surface blocks the light that reaches its front). */
    float p0[3] = {2, -1, -1}, p1[3] = {2, 5, -1}, p2[3] = {2, 5, 5}, p3[3] = {2, -1, 5};
    quad_frame_add(&wall, p0, p3, p2, p1);
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *injected = calloc(floats, sizeof *injected);
    float *gv = calloc(pf_lpv_volume_floats(&layout, PF_LPV_GV_FLOATS_PER_CELL), sizeof *gv);
    float *open = calloc(floats, sizeof *open), *walled = calloc(floats, sizeof *walled);
    PF_REQUIRE(injected && gv && open && walled);
    /* A light facing the wall from 1 m, and one facing along it. */
    pf_lpv_vpl vpls[2] = {{{1.0f, 2.0f, 2.0f}, {1, 0, 0}, {10, 10, 10}},
                          {{1.5f, 1.0f, 2.5f}, {0, 1, 0}, {10, 10, 10}}};
    pf_lpv_inject(&layout, vpls, 2, injected, NULL);
    pf_lpv_geometry_build(&layout, &wall.frame, gv);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_lpv_propagate(lpv, &layout, injected, NULL, NULL, &err), &err);
    PF_REQUIRE_OK(pf_lpv_download(lpv, open, floats, &err), &err);
    PF_REQUIRE_OK(pf_lpv_propagate(lpv, &layout, injected, gv, NULL, &err), &err);
    PF_REQUIRE_OK(pf_lpv_download(lpv, walled, floats, &err), &err);
    double crossing_open = flux_beyond(open, 16, 8), crossing_walled = flux_beyond(walled, 16, 8);
    double blocked = 1.0 - crossing_walled / crossing_open;
    printf("  flux beyond the wall: open %.6g, walled %.6g: %.1f%% blocked\n", crossing_open,
           crossing_walled, 100.0 * blocked);
    PF_CHECK(crossing_open > 0.0);
    PF_CHECK(blocked >= 0.90);
    /* Light on the lit side is not lost to the wall: it stays (nothing is reflected, but
     * the lit side keeps at least what it had without the wall minus what crossed). */
    PF_CHECK(flux_beyond(walled, 16, 0) - crossing_walled > 0.0);
    free(injected);
    free(gv);
    free(open);
    free(walled);
}

/* Injects, builds the GV and propagates at focus; the accumulated volume in *out (malloc'ed). */
static int run_at(const float focus[3], const quad_frame *scene, const pf_lpv_vpl *vpls,
                  uint32_t count, pf_lpv_site site, pf_lpv_layout *layout, float **out)
{
    pf_lpv_set_site(lpv, site);
    pf_lpv_settings settings = {.cascades = 2, .size = 16, .iterations = {4}};
    pf_lpv_layout_make(&settings, focus, 0.25f, &scene->frame, layout);
    uint64_t floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    float *injected = calloc(floats, sizeof *injected);
    float *gv = calloc(pf_lpv_volume_floats(layout, PF_LPV_GV_FLOATS_PER_CELL), sizeof *gv);
    *out = calloc(floats, sizeof **out);
    int ok = injected && gv && *out;
    pf_error err = {0};
    if (ok) {
        pf_lpv_inject(layout, vpls, count, injected, NULL);
        pf_lpv_geometry_build(layout, &scene->frame, gv);
        ok = pf_lpv_propagate(lpv, layout, injected, gv, NULL, &err) == PF_OK &&
             pf_lpv_download(lpv, *out, floats, &err) == PF_OK;
        if (!ok)
            fprintf(stderr, "run_at: %s\n", err.message);
    }
    free(injected);
    free(gv);
    pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
    return ok;
}

PF_TEST(camera_moves_below_a_cell_change_nothing_and_a_cell_shifts_by_one)
{
    quad_frame scene;
    quad_frame_init(&scene);
    float p0[3] = {0, 0, 0}, p1[3] = {2, 0, 0}, p2[3] = {2, 0, 2}, p3[3] = {0, 0, 2};
    quad_frame_add(&scene, p0, p3, p2, p1); /* a floor facing +y */
    float q0[3] = {1.5f, 0, 0}, q1[3] = {1.5f, 2, 0}, q2[3] = {1.5f, 2, 2}, q3[3] = {1.5f, 0, 2};
    quad_frame_add(&scene, q0, q1, q2, q3); /* a wall */
    pf_lpv_vpl vpls[3] = {{{0.5f, 0.0f, 0.5f}, {0, 1, 0}, {4, 2, 1}},
                          {{1.0f, 0.0f, 1.25f}, {0, 1, 0}, {1, 2, 4}},
                          {{1.5f, 0.75f, 1.0f}, {-1, 0, 0}, {3, 3, 3}}};
    float focus[3] = {1.0f, 0.5f, 1.0f};
    float nudged[3] = {1.0f + 0.1f, 0.5f + 0.2f, 1.0f + 0.24f}; /* same cell of 0.25 (and 0.5) */
    float shifted[3] = {1.0f + 0.5f, 0.5f, 1.0f};                /* one cell of the coarser */
    const pf_lpv_site sites[2] = {PF_LPV_SITE_DEVICE, PF_LPV_SITE_HOST};
    for (int site = 0; site < 2; site++) {
        pf_lpv_layout a, b, c;
        float *va = NULL, *vb = NULL, *vc = NULL;
        PF_REQUIRE(run_at(focus, &scene, vpls, 3, sites[site], &a, &va));
        PF_REQUIRE(run_at(nudged, &scene, vpls, 3, sites[site], &b, &vb));
        PF_REQUIRE(run_at(shifted, &scene, vpls, 3, sites[site], &c, &vc));
        uint64_t floats = pf_lpv_volume_floats(&a, PF_LPV_FLOATS_PER_CELL);
        PF_CHECK(!memcmp(a.cascades, b.cascades, sizeof a.cascades));
        PF_CHECK(!memcmp(va, vb, floats * sizeof(float)));
        /* Cascade 1 (cells of 0.5 m): origin one cell on, every value one cell over. */
        PF_CHECK(c.cascades[1].origin_cell[0] == a.cascades[1].origin_cell[0] + 1);
        uint64_t cells = 16u * 16u * 16u;
        uint32_t mismatched = 0, nonzero = 0;
        for (uint32_t z = 0; z < 16; z++)
            for (uint32_t y = 0; y < 16; y++)
                for (uint32_t x = 0; x + 1 < 16; x++) {
                    const float *before = va + (cells + cell_of(16, x + 1, y, z)) * 12;
                    const float *after = vc + (cells + cell_of(16, x, y, z)) * 12;
                    if (memcmp(before, after, 12 * sizeof(float)))
                        mismatched++;
                    if (before[0] != 0.0f)
                        nonzero++;
                }
        printf("  %s, one-cell shift: %u of the cells compared differ (%u lit)\n",
               site ? "host" : "device", mismatched, nonzero);
        PF_CHECK(nonzero > 100);
        PF_CHECK(mismatched == 0);
        free(va);
        free(vb);
        free(vc);
    }
}

/*
 * Random SH coefficients (c0 above the other coefficients' reach, so few
 * directions clamp at 0) and, when gv is not NULL, a sparse geometry volume.
 */
static void random_volumes(uint32_t seed, float *sh, float *gv, uint64_t floats)
{
    uint32_t state = seed;
    for (uint64_t i = 0; i < floats; i++) {
        state = state * 1664525u + 1013904223u;
        float r = (float)(state >> 8) / 16777216.0f;
        sh[i] = i % 4 == 0 ? 1.0f + r : r - 0.5f;
        if (!gv)
            continue;
        state = state * 1664525u + 1013904223u;
        /* A face in 5 blocks something, some of them fully (coefficients up to 2). */
        gv[i] = (state >> 8) % 5 == 0 ? 2.0f * (float)(state >> 8) / 16777216.0f : 0.0f;
    }
}

/*
 * pf_lpv_propagate adds to the accumulation every other iteration, two
 * results at a time (lpv_gpu.c). Whatever the parity of a cascade's
 * iteration count and snapshot, its accumulation must be the injection plus
 * each step's result added one by one in float, as single steps
 * (pf_lpv_propagate_once) summed on the host give them, and its far field
 * that minus the sum after the snapshot's steps: to the bit.
 */
PF_TEST(accumulation_and_snapshots_are_the_sum_of_the_single_steps)
{
    pf_lpv_layout layout;
    memset(&layout, 0, sizeof layout);
    layout.count = 5;
    layout.size = 8;
    /* One step; odd with an odd snapshot; even with an even one; the snapshot at the end;
     * no step (the far field of nothing: zeros). */
    const uint32_t iterations[5] = {1, 5, 6, 7, 0}, snapshot_at[5] = {0, 3, 2, 7, 0};
    for (uint32_t k = 0; k < layout.count; k++) {
        layout.cascades[k].iterations = iterations[k];
        layout.cascades[k].snapshot_iterations = snapshot_at[k];
    }
    uint64_t cell_floats = 8u * 8u * 8u * PF_LPV_FLOATS_PER_CELL;
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    PF_REQUIRE(floats == layout.count * cell_floats);
    float *injected = malloc(floats * sizeof *injected);
    float *expected = malloc(floats * sizeof *expected);
    float *expected_snapshot = malloc(floats * sizeof *expected_snapshot);
    float *got = malloc(floats * sizeof *got);
    float *got_snapshot = malloc(floats * sizeof *got_snapshot);
    float *step = malloc(cell_floats * sizeof *step);
    float *next = malloc(cell_floats * sizeof *next);
    PF_REQUIRE(injected && expected && expected_snapshot && got && got_snapshot && step && next);
    random_volumes(12345u, injected, NULL, floats);
    memcpy(expected, injected, floats * sizeof *expected);
    memcpy(expected_snapshot, injected, floats * sizeof *expected_snapshot);
    pf_error err = {0};
    for (uint32_t k = 0; k < layout.count; k++) {
        float *acc = expected + k * cell_floats;
        memcpy(step, injected + k * cell_floats, cell_floats * sizeof *step);
        for (uint32_t i = 1; i <= iterations[k]; i++) {
            PF_REQUIRE_OK(pf_lpv_propagate_once(lpv, layout.size, step, NULL, next, &err), &err);
            for (uint64_t f = 0; f < cell_floats; f++)
                acc[f] += next[f];
            if (i == snapshot_at[k])
                memcpy(expected_snapshot + k * cell_floats, acc, cell_floats * sizeof *acc);
            memcpy(step, next, cell_floats * sizeof *step);
        }
    }
    /* What the lookups read of the snapshot: the far field, accumulated − snapshot. */
    for (uint64_t f = 0; f < floats; f++)
        expected_snapshot[f] = expected[f] - expected_snapshot[f];
    PF_REQUIRE_OK(pf_lpv_propagate(lpv, &layout, injected, NULL, NULL, &err), &err);
    PF_REQUIRE_OK(pf_lpv_download(lpv, got, floats, &err), &err);
    PF_REQUIRE_OK(pf_vk_buffer_download(ctx, pf_lpv_far_fields(lpv), 0, got_snapshot,
                                        floats * sizeof *got_snapshot, &err),
                  &err);
    for (uint32_t k = 0; k < layout.count; k++) {
        uint64_t at = k * cell_floats;
        uint64_t differ = 0, snapshot_differ = 0;
        for (uint64_t f = 0; f < cell_floats; f++) {
            differ += memcmp(&got[at + f], &expected[at + f], sizeof(float)) != 0;
            snapshot_differ +=
                memcmp(&got_snapshot[at + f], &expected_snapshot[at + f], sizeof(float)) != 0;
        }
        printf("  cascade %u (%u iterations, snapshot after %u): %llu / %llu floats differ in "
               "the accumulation, %llu in the far field\n",
               k, iterations[k], snapshot_at[k], (unsigned long long)differ,
               (unsigned long long)cell_floats, (unsigned long long)snapshot_differ);
        PF_CHECK(differ == 0);
        PF_CHECK(snapshot_differ == 0);
    }
    /* The sum is no copy of the injection: the steps added light. */
    PF_CHECK(memcmp(expected, injected, floats * sizeof *expected) != 0);
    /* Far fields: some light (cascade 1's), none where the snapshot is the end (3) or no
     * step (4). */
    int lit = 0, dark = 1;
    for (uint64_t f = 0; f < cell_floats; f++) {
        lit |= got_snapshot[1 * cell_floats + f] != 0.0f;
        dark &= got_snapshot[3 * cell_floats + f] == 0.0f &&
                got_snapshot[4 * cell_floats + f] == 0.0f;
    }
    PF_CHECK(lit && dark);
    free(injected);
    free(expected);
    free(expected_snapshot);
    free(got);
    free(got_snapshot);
    free(step);
    free(next);
}

/* max |a − b| over max |b|: the difference against the volume's scale. */
static double relative_difference(const float *a, const float *b, uint64_t floats)
{
    double worst = 0.0, scale = 0.0;
    for (uint64_t i = 0; i < floats; i++) {
        worst = fmax(worst, fabs((double)a[i] - (double)b[i]));
        scale = fmax(scale, fabs((double)b[i]));
    }
    return scale > 0.0 ? worst / scale : worst;
}

/*
 * The host propagation against the device's, occlusion on and off: three
 * cascades of 8³ (two steps and a row run of 4 on the 8-wide step) with
 * iteration counts and snapshots of both parities. The same rule in a
 * different order of rounding (the device may fuse multiply-adds), so
 * equal to 10⁻⁵ of the volume's largest value; and every vector width of
 * the host step agrees with the others to the bit.
 */
PF_TEST(the_host_propagation_agrees_with_the_device)
{
    pf_lpv_layout layout;
    memset(&layout, 0, sizeof layout);
    layout.count = 3;
    layout.size = 12; /* 12 = 8 + 4: the 8-wide step's runs end in a partial one */
    const uint32_t iterations[3] = {3, 6, 5}, snapshot_at[3] = {0, 3, 2};
    for (uint32_t k = 0; k < layout.count; k++) {
        layout.cascades[k].iterations = iterations[k];
        layout.cascades[k].snapshot_iterations = snapshot_at[k];
    }
    uint64_t floats = pf_lpv_volume_floats(&layout, PF_LPV_FLOATS_PER_CELL);
    float *injected = malloc(floats * sizeof(float)), *gv = malloc(floats * sizeof(float));
    float *device = malloc(floats * sizeof(float)), *device_far = malloc(floats * sizeof(float));
    float *host = malloc(floats * sizeof(float)), *host_far = malloc(floats * sizeof(float));
    float *other = malloc(floats * sizeof(float)), *other_snapshot = malloc(floats * sizeof(float));
    PF_REQUIRE(injected && gv && device && device_far && host && host_far && other &&
               other_snapshot);
    random_volumes(7u, injected, gv, floats);
    pf_error err = {0};
    for (int occlusion = 0; occlusion < 2; occlusion++) {
        const float *geometry = occlusion ? gv : NULL;
        pf_lpv_propagate_stats stats;
        pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
        PF_REQUIRE_OK(pf_lpv_propagate(lpv, &layout, injected, geometry, &stats, &err), &err);
        PF_CHECK(!stats.on_host);
        /* Issue 44: each cascade's device time, from timestamps between the cascades in
         * the one submission, adds up to the propagation's. */
        double cascades = 0.0;
        for (uint32_t k = 0; k < layout.count; k++) {
            PF_CHECK_MSG(stats.cascade_gpu_ms[k] >= 0.0, "cascade %u: %g ms", k,
                         stats.cascade_gpu_ms[k]);
            cascades += stats.cascade_gpu_ms[k];
        }
        PF_CHECK_MSG(stats.gpu_ms >= 0.0 && fabs(cascades - stats.gpu_ms) <= 1e-6,
                     "cascades %g ms, propagation %g ms", cascades, stats.gpu_ms);
        PF_REQUIRE_OK(pf_lpv_download(lpv, device, floats, &err), &err);
        PF_REQUIRE_OK(pf_vk_buffer_download(ctx, pf_lpv_far_fields(lpv), 0, device_far,
                                            floats * sizeof(float), &err),
                      &err);
        /* The host path of pf_lpv_propagate leaves its results in the device's volumes. */
        pf_lpv_set_site(lpv, PF_LPV_SITE_HOST);
        PF_REQUIRE_OK(pf_lpv_propagate(lpv, &layout, injected, geometry, &stats, &err), &err);
        PF_CHECK(stats.on_host);
        PF_CHECK(stats.gpu_ms < 0.0);
        PF_CHECK(stats.cell_updates == 12u * 12u * 12u * (3u + 6u + 5u));
        PF_REQUIRE_OK(pf_lpv_download(lpv, host, floats, &err), &err);
        PF_REQUIRE_OK(pf_vk_buffer_download(ctx, pf_lpv_far_fields(lpv), 0, host_far,
                                            floats * sizeof(float), &err),
                      &err);
        pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
        double accumulation = relative_difference(host, device, floats);
        double far_fields = relative_difference(host_far, device_far, floats);
        printf("  occlusion %s: host against device %.3g (accumulation), %.3g (far fields)\n",
               occlusion ? "on" : "off", accumulation, far_fields);
        PF_CHECK(accumulation <= 1e-5);
        PF_CHECK(far_fields <= 1e-5);
        /* Light moved: the accumulation is not the injection. */
        PF_CHECK(relative_difference(host, injected, floats) > 0.01);
        for (uint32_t width = 4; width <= 8; width *= 2) {
            if (!pf_lpv_host_stepper(width))
                continue;
            PF_REQUIRE_OK(pf_lpv_propagate_host_width(&layout, injected, geometry, other,
                                                      other_snapshot, width, &err),
                          &err);
            printf("  %u-wide step: %s\n", width,
                   memcmp(other, host, floats * sizeof(float)) ? "differs" : "identical");
            PF_CHECK(!memcmp(other, host, floats * sizeof(float)));
            /* pf_lpv_propagate's far field is this width's accumulation minus its snapshot. */
            for (uint64_t f = 0; f < floats; f++)
                other_snapshot[f] = other[f] - other_snapshot[f];
            PF_CHECK(!memcmp(other_snapshot, host_far, floats * sizeof(float)));
        }
    }
    /*
     * A fresh pf_lpv on the host first, then on the device: the host path allocates only
     * the volumes the lookups read, and the device path then needs its own three
     * (the result must be the device's above, occlusion on).
     */
    pf_lpv *fresh = NULL;
    PF_REQUIRE_OK(pf_lpv_create(ctx, &fresh, &err), &err);
    pf_lpv_propagate_stats stats;
    pf_lpv_set_site(fresh, PF_LPV_SITE_HOST);
    PF_REQUIRE_OK(pf_lpv_propagate(fresh, &layout, injected, gv, &stats, &err), &err);
    PF_CHECK(stats.on_host);
    PF_REQUIRE_OK(pf_lpv_download(fresh, other, floats, &err), &err);
    PF_CHECK(!memcmp(other, host, floats * sizeof(float)));
    pf_lpv_set_site(fresh, PF_LPV_SITE_DEVICE);
    PF_REQUIRE_OK(pf_lpv_propagate(fresh, &layout, injected, gv, &stats, &err), &err);
    PF_CHECK(!stats.on_host);
    PF_REQUIRE_OK(pf_lpv_download(fresh, other, floats, &err), &err);
    PF_CHECK_MSG(!memcmp(other, device, floats * sizeof(float)),
                 "device after host: %.3g from the device's own",
                 relative_difference(other, device, floats));
    pf_lpv_destroy(fresh);
    PF_CHECK(pf_lpv_host_stepper(4) != NULL);
    PF_CHECK(pf_lpv_host_stepper(16) == NULL);
    free(injected);
    free(gv);
    free(device);
    free(device_far);
    free(host);
    free(host_far);
    free(other);
    free(other_snapshot);
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
    /* The kernel's own properties: on the device even where AUTO would use the host. */
    pf_lpv_set_site(lpv, PF_LPV_SITE_DEVICE);
    PF_RUN(one_step_in_empty_space_conserves_flux);
    PF_RUN(a_constant_isotropic_field_stays_constant_inside);
    PF_RUN(a_wall_blocks_the_flux_crossing_it);
    PF_RUN(camera_moves_below_a_cell_change_nothing_and_a_cell_shifts_by_one);
    PF_RUN(accumulation_and_snapshots_are_the_sum_of_the_single_steps);
    PF_RUN(the_host_propagation_agrees_with_the_device);
    pf_lpv_destroy(lpv);
    VK_TEST_FINISH(ctx);
    return pf_test_finish();
}
