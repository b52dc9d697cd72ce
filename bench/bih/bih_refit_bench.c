/*
 * The BIH refit on the host against the refit on the device (issue 44), on lavapipe or a
 * GPU: a wavy sheet of n triangles, its tree built on the device, then frames of a moving
 * wave refit both ways. The host's way is what bih_build did before: pf_bih_refit, the SAH
 * measured on the host, and the tree uploaded (nodes, leaf vertices, index). The device's
 * is pf_bih_refit_gpu: the host gathers the leaf vertices, one submission uploads them and
 * fits the tree, 36 bytes come back. Prints the median wall time of each, the bytes each
 * moves, and the two SAH figures (they must agree to float rounding). Then the build
 * itself both ways: the tree read back for the host's copy (pf_bih_build_gpu_resident, as
 * bih_build did before) against its nodes kept on the device (pf_bih_build_gpu_kept).
 *
 *   bih_refit_bench [triangles ...]   (default 100000 1000000)
 */
#include "../bench_stats.h"
#include "pf_bih.h"
#include "pf_common.h"
#include "pf_vk.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FRAMES 5

/* A grid of quads (2 triangles each) over [-1, 1]², its height a travelling wave of phase. */
static void wavy_sheet(pf_scene_frame *frame, uint32_t side, float phase)
{
    uint32_t t = 0;
    for (uint32_t y = 0; y < side; y++)
        for (uint32_t x = 0; x < side; x++) {
            float p[4][3];
            for (int c = 0; c < 4; c++) {
                float u = -1.0f + 2.0f * (float)(x + (c == 1 || c == 2)) / (float)side;
                float v = -1.0f + 2.0f * (float)(y + (c >= 2)) / (float)side;
                p[c][0] = u;
                p[c][1] = v;
                p[c][2] = 0.1f * sinf(6.0f * u + phase) * cosf(4.0f * v - 0.5f * phase);
            }
            const int corners[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int h = 0; h < 2; h++, t++)
                for (int c = 0; c < 3; c++) {
                    memcpy(frame->vertices[3 * t + c], p[corners[h][c]], sizeof p[0]);
                    frame->vertices[3 * t + c][3] = 0.0f;
                }
        }
    frame->triangle_count = t;
}

static double sah_of(const pf_bih *bih)
{
    pf_bih_quality quality;
    pf_bih_quality_measure(bih, &quality);
    return quality.sah_cost;
}

static int run(pf_vk_context *ctx, pf_bih_gpu_builder *builder, uint32_t wanted)
{
    uint32_t side = (uint32_t)ceil(sqrt(wanted / 2.0));
    uint32_t n = 2 * side * side;
    pf_scene_frame frame = {0};
    frame.vertices = malloc(3 * (size_t)n * sizeof *frame.vertices);
    pf_bih_gpu *device = NULL, *uploaded = NULL;
    pf_error err = {0};
    if (!frame.vertices || pf_bih_gpu_create(ctx, &device, &err) != PF_OK ||
        pf_bih_gpu_create(ctx, &uploaded, &err) != PF_OK) {
        fprintf(stderr, "bih_refit_bench: %s\n", err.message[0] ? err.message : "out of memory");
        return 1;
    }
    wavy_sheet(&frame, side, 0.0f);
    pf_bih on_device = {0}, on_host = {0};
    pf_bih_gpu_build_report built;
    int failed = pf_bih_build_gpu_resident(builder, &frame, NULL, &on_device, device, &built,
                                           &err) != PF_OK ||
                 !built.resident ||
                 pf_bih_build_gpu(builder, &frame, NULL, &on_host, NULL, &err) != PF_OK;
    double host_ms[FRAMES], device_ms[FRAMES], host_sah = 0.0, device_sah = 0.0;
    double pass_ms[PF_BIH_REFIT_PASSES][FRAMES], refit_gpu[FRAMES];
    pf_vk_traffic host_traffic = {0}, device_traffic = {0};
    for (int f = 0; !failed && f < FRAMES; f++) {
        wavy_sheet(&frame, side, 0.4f * (float)(f + 1));
        pf_vk_traffic before = pf_vk_traffic_of(ctx);
        double start = pf_time_ms();
        failed = pf_bih_refit(&on_host, &frame, &err) != PF_OK;
        host_sah = sah_of(&on_host);
        failed = failed || pf_bih_gpu_upload(uploaded, &on_host, &err) != PF_OK;
        host_ms[f] = pf_time_ms() - start;
        host_traffic = pf_vk_traffic_since(ctx, before);
        pf_bih_gpu_refit_report report;
        before = pf_vk_traffic_of(ctx);
        start = pf_time_ms();
        failed = failed ||
                 pf_bih_refit_gpu(builder, device, &on_device, &frame, &report, &err) != PF_OK;
        device_ms[f] = pf_time_ms() - start;
        device_traffic = pf_vk_traffic_since(ctx, before);
        device_sah = report.sah_cost;
        for (int p = 0; p < PF_BIH_REFIT_PASSES; p++)
            pass_ms[p][f] = report.pass_ms[p];
        refit_gpu[f] = report.gpu_ms;
    }
    if (failed) {
        fprintf(stderr, "bih_refit_bench: %u triangles: %s\n", n, err.message);
    } else {
        printf("%9u triangles %8u nodes | host refit + upload %8.1f ms, %5.1f MB up, %llu "
               "submits, SAH %.4f | device refit %8.1f ms, %5.1f MB up, %llu B back, %llu "
               "submits, SAH %.4f\n",
               n, on_host.node_count, bench_median(host_ms, FRAMES),
               host_traffic.upload_bytes / 1e6, (unsigned long long)host_traffic.submits,
               host_sah, bench_median(device_ms, FRAMES), device_traffic.upload_bytes / 1e6,
               (unsigned long long)device_traffic.readback_bytes,
               (unsigned long long)device_traffic.submits, device_sah);
        printf("%9s device refit GPU %.2f ms; passes (GPU ms, median):", "",
               bench_median(refit_gpu, FRAMES));
        for (int p = 0; p < PF_BIH_REFIT_PASSES; p++)
            printf(" %s %.1f", pf_bih_refit_pass_name((pf_bih_refit_pass)p),
                   bench_median(pass_ms[p], FRAMES));
        printf("\n");
    }
    /* The build: read back, against kept on the device (the frame as the last refit's). */
    double read_ms[FRAMES], kept_ms[FRAMES], read_gpu[FRAMES], kept_gpu[FRAMES];
    double build_pass_ms[PF_BIH_GPU_PASSES][FRAMES];
    pf_vk_traffic read_traffic = {0}, kept_traffic = {0};
    for (int f = 0; !failed && f < FRAMES; f++) {
        for (int keep = 0; keep < 2 && !failed; keep++) {
            pf_bih tree = {0};
            pf_vk_traffic before = pf_vk_traffic_of(ctx);
            double start = pf_time_ms();
            failed = (keep ? pf_bih_build_gpu_kept(builder, &frame, NULL, &tree, device, &built,
                                                   &err)
                           : pf_bih_build_gpu_resident(builder, &frame, NULL, &tree, device,
                                                       &built, &err)) != PF_OK;
            (keep ? kept_ms : read_ms)[f] = pf_time_ms() - start;
            (keep ? kept_gpu : read_gpu)[f] = built.gpu_ms;
            if (keep)
                for (int p = 0; p < PF_BIH_GPU_PASSES; p++)
                    build_pass_ms[p][f] = built.pass_ms[p];
            *(keep ? &kept_traffic : &read_traffic) = pf_vk_traffic_since(ctx, before);
            pf_bih_free(&tree);
        }
    }
    if (failed)
        fprintf(stderr, "bih_refit_bench: %u triangles: %s\n", n, err.message);
    else
        printf("%9s GPU build, tree read back %8.1f ms (GPU %.2f), %6.1f MB back | nodes kept "
               "on the device %8.1f ms (GPU %.2f), %6.1f MB back\n",
               "", bench_median(read_ms, FRAMES), bench_median(read_gpu, FRAMES),
               read_traffic.readback_bytes / 1e6, bench_median(kept_ms, FRAMES),
               bench_median(kept_gpu, FRAMES), kept_traffic.readback_bytes / 1e6);
    if (!failed) {
        printf("%9s GPU build kept, passes (GPU ms, median):", "");
        for (int p = 0; p < PF_BIH_GPU_PASSES; p++)
            printf(" %s %.2f", pf_bih_gpu_pass_name((pf_bih_gpu_pass)p),
                   bench_median(build_pass_ms[p], FRAMES));
        printf("\n");
    }
    pf_bih_free(&on_device);
    pf_bih_free(&on_host);
    pf_bih_gpu_destroy(device);
    pf_bih_gpu_destroy(uploaded);
    free(frame.vertices);
    return failed;
}

int main(int argc, char **argv)
{
    pf_vk_context *ctx = NULL;
    pf_error err = {0};
    pf_vk_options options = {NULL, 0};
    pf_bih_gpu_builder *builder = NULL;
    if (pf_vk_create(&options, &ctx, &err) != PF_OK ||
        pf_bih_gpu_builder_create(ctx, &builder, &err) != PF_OK) {
        fprintf(stderr, "bih_refit_bench: %s\n", err.message);
        pf_vk_destroy(ctx);
        return 1;
    }
    printf("bih_refit_bench: device %s, a wavy sheet's GPU-built tree refit to %d frames "
           "each way, median wall time\n",
           pf_vk_info(ctx)->name, FRAMES);
    int failures = 0;
    if (argc > 1)
        for (int a = 1; a < argc; a++)
            failures += run(ctx, builder, (uint32_t)strtoul(argv[a], NULL, 10));
    else
        failures += run(ctx, builder, 100000) + run(ctx, builder, 1000000);
    pf_bih_gpu_builder_destroy(builder);
    pf_vk_destroy(ctx);
    return failures ? 1 : 0;
}
