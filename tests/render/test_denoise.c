/*
 * The denoise stage (issue 40): on images made here, a constant image and a
 * noise-free one come out unchanged, the mean is kept, a checker texture under
 * flat light keeps its edges while the noise drops, a NaN pixel does not
 * spread; on the Cornell box at 4 spp the error against a 512-spp reference
 * drops by a stated factor.
 */
#include "denoise_internal.h" /* the host's à-trous pass, against its scalar formula */
#include "pf_test.h"
#include "reference_test_util.h"
#include "render_test_env.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define SIZE 48u

static pf_vk_context *ctx;
static pf_renderer *renderer;

static const char *const split_names[] = {
    "R",          "G",          "B",         "A",         "direct.R",   "direct.G",
    "direct.B",   "indirect.R", "indirect.G", "indirect.B", "caustic.R", "caustic.G",
    "caustic.B",  "albedo.R",   "albedo.G",  "albedo.B",  "normal.X",   "normal.Y",
    "normal.Z",   "depth.Z"};
enum { R = 0, A = 3, DIRECT = 4, INDIRECT = 7, CAUSTIC = 10, ALBEDO = 13, NORMAL = 16, DEPTH = 19 };

/* A deterministic uniform number in [0, 1) (xorshift). */
static double uniform(uint64_t *state)
{
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    return (double)(*state >> 11) / 9007199254740992.0;
}

/*
 * A flat wall facing the camera at depth 2: albedo a checker of 8-pixel cells (0.8 and
 * 0.2) when checker, else 0.5; indirect light = albedo × (1 + noise · (u - 0.5)), direct
 * 0.1 × albedo, caustic 0; beauty = direct + indirect. truth: the same without noise.
 */
static void make_wall(pf_image *image, pf_image *truth, int checker, double noise, uint64_t seed)
{
    pf_error err = {0};
    PF_CHECK_OK(pf_image_create(image, SIZE, SIZE, 20, split_names, &err), &err);
    PF_CHECK_OK(pf_image_create(truth, SIZE, SIZE, 20, split_names, &err), &err);
    uint64_t state = seed * 2654435761u + 1;
    for (uint32_t y = 0; y < SIZE; y++)
        for (uint32_t x = 0; x < SIZE; x++) {
            float albedo = checker ? (((x / 8) + (y / 8)) % 2 ? 0.8f : 0.2f) : 0.5f;
            float factor = (float)(1.0 + noise * (uniform(&state) - 0.5));
            for (int which = 0; which < 2; which++) {
                pf_image *target = which ? truth : image;
                float *texel = target->pixels + ((size_t)y * SIZE + x) * 20;
                float lit = which ? 1.0f : factor;
                for (int c = 0; c < 3; c++) {
                    texel[DIRECT + c] = 0.1f * albedo;
                    texel[INDIRECT + c] = albedo * lit;
                    texel[R + c] = texel[DIRECT + c] + texel[INDIRECT + c];
                    texel[ALBEDO + c] = albedo;
                }
                texel[A] = 1.0f;
                texel[NORMAL + 2] = 1.0f;
                texel[DEPTH] = 2.0f;
            }
        }
}

static double beauty_relmse(const pf_image *image, const pf_image *truth)
{
    return ref_layer_relmse(image, truth, REF_CH_RGB);
}

static double beauty_mean(const pf_image *image)
{
    return ref_layer_mean(image, REF_CH_RGB);
}

PF_TEST(a_constant_image_is_unchanged)
{
    pf_image image, truth;
    make_wall(&image, &truth, 0, 0.0, 1);
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_image(&image, 0, NULL, NULL, &err), &err);
    double largest = 0.0;
    for (size_t k = 0; k < (size_t)SIZE * SIZE * 20; k++)
        largest = fmax(largest, fabs(image.pixels[k] - truth.pixels[k]));
    PF_CHECK_MSG(largest <= 1e-6, "a constant image moved by %g", largest);
    pf_image_free(&image);
    pf_image_free(&truth);
}

PF_TEST(a_checker_keeps_its_edges_and_loses_its_noise)
{
    pf_image image, truth;
    make_wall(&image, &truth, 1, 0.6, 2);
    double before = beauty_relmse(&image, &truth), mean_before = beauty_mean(&image);
    pf_error err = {0};
    pf_frame_report report = {0};
    PF_REQUIRE_OK(pf_denoise_image(&image, 1, NULL, &report, &err), &err);
    double after = beauty_relmse(&image, &truth), mean_after = beauty_mean(&image);
    /* Noise of ±30 % of the light: relMSE 0.0075; the filter takes it below a quarter. */
    PF_CHECK_MSG(after < 0.25 * before, "relMSE %g before, %g after", before, after);
    /* The mean is kept within 0.5 %. */
    PF_CHECK_MSG(fabs(mean_after / mean_before - 1.0) < 0.005, "mean %g before, %g after",
                 mean_before, mean_after);
    /* The checker's edges stay: on each side of a cell border the pixels keep their own
     * albedo's level (within 10 % of the truth), not a blend of the two. */
    int blurred = 0;
    for (uint32_t y = 0; y < SIZE; y++)
        for (uint32_t x = 7; x < SIZE - 1; x += 8)
            for (uint32_t side = 0; side < 2; side++) {
                double got = ref_pixel(&image, R + 1, x + side, y);
                double want = ref_pixel(&truth, R + 1, x + side, y);
                blurred += fabs(got / want - 1.0) > 0.10;
            }
    PF_CHECK_MSG(blurred == 0, "%d pixels beside a checker edge off by more than 10 %%", blurred);
    /* The raw beauty and the variance estimate are kept as layers, and the row says so. */
    PF_CHECK(pf_image_channel(&image, "noisy.R") == 20 && pf_image_channel(&image, "variance.Y") == 23);
    PF_CHECK(ref_row(&report, "denoise") != NULL);
    /* beauty = direct + indirect still. */
    for (uint32_t p = 0; p < SIZE * SIZE; p += 37) {
        const float *texel = image.pixels + (size_t)p * image.channel_count;
        PF_CHECK_NEAR(texel[R], texel[DIRECT] + texel[INDIRECT], 1e-6);
    }
    pf_image_free(&image);
    pf_image_free(&truth);
}

PF_TEST(a_bad_pixel_does_not_spread)
{
    pf_image image, truth;
    make_wall(&image, &truth, 0, 0.2, 3);
    float *bad = image.pixels + ((size_t)20 * SIZE + 20) * 20;
    bad[INDIRECT] = NAN;
    bad[INDIRECT + 1] = INFINITY;
    bad[R] = NAN;
    bad[ALBEDO + 2] = NAN;
    bad[DEPTH] = INFINITY;
    pf_error err = {0};
    PF_REQUIRE_OK(pf_denoise_image(&image, 1, NULL, NULL, &err), &err);
    /* What the stage writes is finite: beauty, indirect, noisy.* and variance.Y (the albedo
     * and depth layers are the renderer's, passed on as they are). */
    static const uint32_t written[] = {R, R + 1, R + 2, INDIRECT, INDIRECT + 1, INDIRECT + 2,
                                       20, 21, 22, 23};
    size_t bad_values = 0;
    for (size_t p = 0; p < (size_t)SIZE * SIZE; p++)
        for (size_t k = 0; k < sizeof written / sizeof written[0]; k++)
            bad_values += !isfinite(image.pixels[p * image.channel_count + written[k]]);
    PF_CHECK_MSG(bad_values == 0, "%zu non-finite values written", bad_values);
    /* Away from it the wall is the truth within the noise's filtered spread. */
    PF_CHECK_NEAR(ref_pixel(&image, R + 1, 30, 30), ref_pixel(&truth, R + 1, 30, 30), 0.05);
    pf_image_free(&image);
    pf_image_free(&truth);
}

PF_TEST(the_cornell_box_at_4_spp_gets_closer_to_512_spp)
{
    pf_scene *scene = NULL;
    pf_scene_frame frame;
    PF_REQUIRE(ref_load_cornell(&scene, &frame));
    pf_error err = {0};
    pf_image converged = {0}, noisy = {0};
    pf_render_settings reference = ref_settings(40, 30, 512, 1, 1);
    pf_render_settings low = ref_settings(40, 30, 4, 7, 1);
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &reference, &converged, NULL, &err), &err);
    PF_REQUIRE_OK(pf_render_frame(renderer, &frame, &low, &noisy, NULL, &err), &err);
    double before = ref_layer_relmse(&noisy, &converged, REF_CH_INDIRECT);
    double beauty_before = beauty_relmse(&noisy, &converged), mean_before = beauty_mean(&noisy);
    PF_REQUIRE_OK(pf_denoise_image(&noisy, 0, NULL, NULL, &err), &err);
    double after = ref_layer_relmse(&noisy, &converged, REF_CH_INDIRECT);
    double beauty_after = beauty_relmse(&noisy, &converged), mean_after = beauty_mean(&noisy);
    printf("  cornell 40x30, 4 spp against 512: indirect relMSE %.4f raw, %.4f denoised; "
           "beauty %.4f, %.4f; mean %.4f -> %.4f (512 spp %.4f)\n",
           before, after, beauty_before, beauty_after, mean_before, mean_after,
           beauty_mean(&converged));
    /* The indirect light is what the stage filters: its error at least halves. */
    PF_CHECK_MSG(after < 0.5 * before, "indirect relMSE %g raw, %g denoised", before, after);
    PF_CHECK_MSG(beauty_after < beauty_before, "beauty relMSE %g raw, %g denoised",
                 beauty_before, beauty_after);
    PF_CHECK_MSG(fabs(mean_after / mean_before - 1.0) < 0.02, "mean %g -> %g", mean_before,
                 mean_after);
    /* A converged image stays as it is: the filter's own error floor. */
    pf_image filtered = {0};
    static const char *const all[] = {"R", "G", "B", "A", "direct.R", "direct.G", "direct.B",
                                      "indirect.R", "indirect.G", "indirect.B", "caustic.R",
                                      "caustic.G", "caustic.B", "albedo.R", "albedo.G",
                                      "albedo.B", "normal.X", "normal.Y", "normal.Z", "depth.Z"};
    PF_REQUIRE_OK(pf_image_select(&converged, all, 20, &filtered, &err), &err);
    PF_REQUIRE_OK(pf_denoise_image(&filtered, 0, NULL, NULL, &err), &err);
    double floor_error = beauty_relmse(&filtered, &converged);
    printf("  cornell 40x30 at 512 spp: relMSE %.6f after denoising\n", floor_error);
    PF_CHECK_MSG(floor_error < 0.002, "a converged image moved by relMSE %g", floor_error);
    pf_image_free(&filtered);
    pf_image_free(&converged);
    pf_image_free(&noisy);
    pf_scene_frame_free(&frame);
    pf_scene_destroy(scene);
}

/* One output pixel of an à-trous pass as denoise.c's header states it, tap by tap with
 * expf: the oracle of the vector pass. */
static void atrous_pixel(const denoise_planes *planes, int step, int x, int y, double out[4])
{
    static const double b3[5] = {1.0 / 16, 1.0 / 4, 3.0 / 8, 1.0 / 4, 1.0 / 16};
    int w = (int)planes->width, h = (int)planes->height;
    size_t p = (size_t)y * w + x;
    const float *L = planes->lighting;
#define LUMA(q) (0.2126 * L[3 * (q)] + 0.7152 * L[3 * (q) + 1] + 0.0722 * L[3 * (q) + 2])
    double blurred = 0.0, blur_weights = 0.0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
            if (x + dx >= 0 && y + dy >= 0 && x + dx < w && y + dy < h) {
                double k = (abs(dx) + abs(dy)) == 0 ? 0.25 : abs(dx) + abs(dy) == 1 ? 0.125 : 0.0625;
                blurred += k * planes->variance[(size_t)(y + dy) * w + x + dx];
                blur_weights += k;
            }
    double scale = DENOISE_SIGMA_LUMINANCE * sqrt(blurred / blur_weights) + 1e-6;
    double sum[3] = {0}, var = 0.0, weights = 0.0;
    for (int j = -2; j <= 2; j++)
        for (int i = -2; i <= 2; i++) {
            int qx = x + i * step, qy = y + j * step;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                continue;
            size_t q = (size_t)qy * w + qx;
            double weight = b3[i + 2] * b3[j + 2];
            if (q != p) {
                double zp = planes->depth[p], zq = planes->depth[q], geometry;
                if ((zp > 0) != (zq > 0))
                    geometry = 0.0;
                else if (zp == 0)
                    geometry = 1.0;
                else {
                    const float *np = planes->normal + 3 * p, *nq = planes->normal + 3 * q;
                    double c = np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2];
                    double offset = step * sqrt((double)(i * i + j * j));
                    geometry = pow(c > 0 ? c : 0, 128) *
                               exp(-fabs(zp - zq) / (planes->depth_step[p] * offset + 1e-3 * zp));
                }
                weight *= geometry * exp(-fabs(LUMA(p) - LUMA(q)) / scale);
            }
            for (int c = 0; c < 3; c++)
                sum[c] += weight * L[3 * q + c];
            var += weight * weight * planes->variance[q];
            weights += weight;
        }
#undef LUMA
    for (int c = 0; c < 3; c++)
        out[c] = sum[c] / weights;
    out[3] = var / (weights * weights);
}

/* The variance estimate at one pixel as denoise.c's header states it (the smallest guided
 * variance of the four quadrants with 4 or more taps of weight > 0.5), in doubles. */
static double variance_pixel(const denoise_planes *planes, int x, int y)
{
    int w = (int)planes->width, h = (int)planes->height;
    size_t p = (size_t)y * w + x;
    const float *L = planes->lighting;
    double smallest = INFINITY;
    for (int quadrant = 0; quadrant < 4; quadrant++) {
        int sx = quadrant & 1 ? 1 : -1, sy = quadrant & 2 ? 1 : -1;
        double sum = 0, sum2 = 0, weights = 0;
        int taps = 0;
        for (int j = 0; j <= DENOISE_VARIANCE_RADIUS; j++)
            for (int i = 0; i <= DENOISE_VARIANCE_RADIUS; i++) {
                int qx = x + sx * i, qy = y + sy * j;
                if (qx < 0 || qy < 0 || qx >= w || qy >= h)
                    continue;
                size_t q = (size_t)qy * w + qx;
                double weight = 1.0, zp = planes->depth[p], zq = planes->depth[q];
                if (q != p) {
                    if ((zp > 0) != (zq > 0))
                        weight = 0.0;
                    else if (zp > 0) {
                        const float *np = planes->normal + 3 * p, *nq = planes->normal + 3 * q;
                        double c = np[0] * nq[0] + np[1] * nq[1] + np[2] * nq[2];
                        weight = pow(c > 0 ? c : 0, 128) *
                                 exp(-fabs(zp - zq) / (planes->depth_step[p] *
                                                           sqrt((double)(i * i + j * j)) +
                                                       1e-3 * zp));
                    }
                }
                double l = 0.2126 * L[3 * q] + 0.7152 * L[3 * q + 1] + 0.0722 * L[3 * q + 2];
                sum += weight * l;
                sum2 += weight * l * l;
                weights += weight;
                taps += weight > 0.5;
            }
        if (taps >= 4) {
            double mean = sum / weights;
            smallest = fmin(smallest, fmax(0.0, sum2 / weights - mean * mean));
        }
    }
    return isfinite(smallest) ? smallest : 0.0;
}

/*
 * The host's variance estimate and à-trous pass (denoise_atrous_body.h, a run of pixels a
 * vector): 4 wide and as dispatched (8 wide with AVX2) give the same floats, and both the
 * formula's value within float rounding, on odd-sized planes (runs cut by the row's end) with background pixels,
 * surfaces at different depths and normals, for every spread the filter uses.
 */
PF_TEST(the_host_filter_is_the_formula_at_every_width)
{
    enum { W = 37, H = 23 };
    size_t n = (size_t)W * H;
    denoise_planes planes;
    memset(&planes, 0, sizeof planes);
    planes.width = W;
    planes.height = H;
    float *lighting = malloc(3 * n * sizeof(float)), *normal = malloc(3 * n * sizeof(float));
    float *depth = malloc(n * sizeof(float)), *depth_step = malloc(n * sizeof(float));
    float *variance = malloc(n * sizeof(float));
    float *out4 = malloc(4 * n * sizeof(float)), *out = malloc(4 * n * sizeof(float));
    float *planar = malloc(PLANAR_COUNT * n * sizeof(float));
    PF_REQUIRE(lighting && normal && depth && depth_step && variance && out4 && out && planar);
    uint64_t state = 99;
    for (size_t p = 0; p < n; p++) {
        for (int c = 0; c < 3; c++)
            lighting[3 * p + c] = (float)(2.0 * uniform(&state));
        /* Background in a corner block, two depths elsewhere; normals a few degrees apart. */
        int x = (int)(p % W), y = (int)(p / W);
        depth[p] = x < 6 && y < 5 ? 0.0f : (float)(x < W / 2 ? 2.0 : 2.6 + 0.01 * y);
        depth_step[p] = depth[p] > 0.0f ? (float)(0.01 + 0.02 * uniform(&state)) : 0.0f;
        double tilt = 0.05 * uniform(&state) + (y > H / 2 ? 0.3 : 0.0);
        normal[3 * p] = (float)sin(tilt);
        normal[3 * p + 1] = 0.0f;
        normal[3 * p + 2] = (float)cos(tilt);
        variance[p] = (float)(0.05 * uniform(&state));
    }
    planes.lighting = lighting;
    planes.normal = normal;
    planes.depth = depth;
    planes.depth_step = depth_step;
    planes.variance = variance;
    planes.planar = planar;
    /* The variance estimate: 4 wide, as dispatched, and the formula (absolute: the spread
     * of a quadrant is a difference of nearly equal sums). */
    float *variance4 = malloc(n * sizeof(float));
    PF_REQUIRE(variance4);
    pf_denoise_atrous_prepare(&planes, 0, H, 0);
    planes.variance = variance4;
    pf_denoise_variance_rows_4(&planes, 0, H);
    planes.variance = variance;
    pf_denoise_variance_rows(&planes, 0, H / 2);
    pf_denoise_variance_rows(&planes, H / 2, H);
    PF_CHECK_MSG(memcmp(variance4, variance, n * sizeof(float)) == 0,
                 "the 4-wide and the dispatched variance estimates differ");
    double worst_variance = 0.0, largest = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double expected = variance_pixel(&planes, x, y);
            largest = fmax(largest, expected);
            worst_variance = fmax(worst_variance, fabs(variance[(size_t)y * W + x] - expected));
        }
    printf("  host variance estimate: largest difference from the formula %.2e (largest "
           "variance %.3f)\n",
           worst_variance, largest);
    PF_CHECK(largest > 0.01 && worst_variance < 1e-5 * largest);
    free(variance4);
    pf_denoise_atrous_prepare(&planes, 0, H, 1);
    for (int step = 1; step <= 16; step *= 2) {
        planes.scratch = out4;
        pf_denoise_atrous_rows_4(&planes, step, 0, H);
        planes.scratch = out;
        pf_denoise_atrous_rows(&planes, step, 0, H / 3);
        pf_denoise_atrous_rows(&planes, step, H / 3, H);
        PF_CHECK_MSG(memcmp(out4, out, 4 * n * sizeof(float)) == 0,
                     "spread %d: the 4-wide and the dispatched pass differ", step);
        double worst = 0.0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double expected[4];
                atrous_pixel(&planes, step, x, y, expected);
                for (int c = 0; c < 4; c++) {
                    double got = out[4 * ((size_t)y * W + x) + c];
                    worst = fmax(worst, fabs(got - expected[c]) / fmax(fabs(expected[c]), 1e-6));
                }
            }
        PF_CHECK_MSG(worst < 1e-4, "spread %d: %g from the formula", step, worst);
        if (step == 16)
            printf("  host à-trous pass: largest relative difference from the formula %.2e\n",
                   worst);
    }
    free(lighting);
    free(normal);
    free(depth);
    free(depth_step);
    free(variance);
    free(out4);
    free(out);
    free(planar);
}

int main(void)
{
    PF_RUN(the_host_filter_is_the_formula_at_every_width);
    PF_RUN(a_constant_image_is_unchanged);
    PF_RUN(a_checker_keeps_its_edges_and_loses_its_noise);
    PF_RUN(a_bad_pixel_does_not_spread);
    if (!render_test_setup(&ctx, &renderer))
        return 1;
    PF_RUN(the_cornell_box_at_4_spp_gets_closer_to_512_spp);
    return render_test_finish(ctx, renderer);
}
