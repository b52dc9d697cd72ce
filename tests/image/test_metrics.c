/* pf_image_compare and pf_image_flicker on constructed images whose metrics are known in
 * closed form. */
#include "pf_image.h"
#include "pf_test.h"

static const char *const rgba[] = {"R", "G", "B", "A"};

static void fill(pf_image *image, float value)
{
    size_t count = (size_t)image->width * image->height * image->channel_count;
    for (size_t i = 0; i < count; i++)
        image->pixels[i] = value;
}

PF_TEST(identical_images_have_zero_error)
{
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, 13, 9, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 13, 9, 4, rgba, &err), &err);
    for (size_t i = 0; i < 13 * 9 * 4; i++)
        a.pixels[i] = b.pixels[i] = (float)(i % 17) * 0.25f;
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK(metrics.rmse == 0.0 && metrics.relmse == 0.0 && metrics.max_abs_error == 0.0);
    PF_CHECK(metrics.channel_count == 4);
    for (uint32_t c = 0; c < 4; c++)
        PF_CHECK(metrics.mean_a[c] == metrics.mean_b[c]);
    pf_image_free(&a);
    pf_image_free(&b);
}

PF_TEST(constant_offset)
{
    const float reference = 0.5f, offset = 0.125f; /* exact in binary */
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, 7, 5, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 7, 5, 4, rgba, &err), &err);
    fill(&b, reference);
    fill(&a, reference + offset);
    /* Alpha is outside the error channels: a wild alpha must not move RMSE. */
    for (size_t p = 0; p < 35; p++)
        a.pixels[p * 4 + 3] = 100.0f;
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK_NEAR(metrics.rmse, offset, 1e-12);
    PF_CHECK_NEAR(metrics.relmse,
                  (double)offset * offset / ((double)reference * reference + PF_RELMSE_EPSILON),
                  1e-12);
    PF_CHECK_NEAR(metrics.max_abs_error, offset, 1e-12);
    PF_CHECK_NEAR(metrics.mean_a[0], reference + offset, 1e-12);
    PF_CHECK_NEAR(metrics.mean_b[0], reference, 1e-12);
    PF_CHECK_NEAR(metrics.mean_a[3], 100.0, 1e-12);
    PF_CHECK_NEAR(metrics.mean_b[3], reference, 1e-12);
    pf_image_free(&a);
    pf_image_free(&b);
}

PF_TEST(single_differing_pixel)
{
    const uint32_t width = 10, height = 4, pixels = width * height;
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, width, height, 3, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, width, height, 3, rgba, &err), &err);
    fill(&a, 1.0f);
    fill(&b, 1.0f);
    a.pixels[(2 * width + 3) * 3 + 1] = 4.0f; /* G of pixel (3, 2): off by 3 */
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    double samples = pixels * 3.0;
    PF_CHECK_NEAR(metrics.rmse, sqrt(9.0 / samples), 1e-12);
    PF_CHECK_NEAR(metrics.relmse, 9.0 / (1.0 + PF_RELMSE_EPSILON) / samples, 1e-12);
    PF_CHECK_NEAR(metrics.max_abs_error, 3.0, 0.0);
    PF_CHECK_NEAR(metrics.mean_a[1], 1.0 + 3.0 / pixels, 1e-12);
    PF_CHECK_NEAR(metrics.mean_a[0], 1.0, 0.0);
    PF_CHECK_NEAR(metrics.mean_b[1], 1.0, 0.0);
    pf_image_free(&a);
    pf_image_free(&b);
}

/* Channels match by name: a reference stored in another order gives the same answer. */
PF_TEST(channels_match_by_name)
{
    static const char *const reordered[] = {"A", "B", "G", "R"};
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, 2, 2, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 2, 2, 4, reordered, &err), &err);
    for (size_t p = 0; p < 4; p++) {
        for (int c = 0; c < 4; c++) {
            a.pixels[p * 4 + c] = (float)(c + 1);
            b.pixels[p * 4 + (3 - c)] = (float)(c + 1);
        }
    }
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK(metrics.rmse == 0.0 && metrics.max_abs_error == 0.0);
    for (int c = 0; c < 4; c++) {
        PF_CHECK_NEAR(metrics.mean_a[c], c + 1, 0.0);
        PF_CHECK_NEAR(metrics.mean_b[c], c + 1, 0.0); /* in a's channel order */
    }
    pf_image_free(&a);
    pf_image_free(&b);
}

PF_TEST(without_rgb_every_channel_counts)
{
    static const char *const depth[] = {"depth.Z", "normal.X"};
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, 4, 1, 2, depth, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 4, 1, 2, depth, &err), &err);
    a.pixels[0] = 2.0f; /* one of 8 samples off by 2 */
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK_NEAR(metrics.rmse, sqrt(4.0 / 8.0), 1e-12);
    PF_CHECK_NEAR(metrics.relmse, 4.0 / PF_RELMSE_EPSILON / 8.0, 1e-9);
    PF_CHECK_NEAR(metrics.max_abs_error, 2.0, 0.0);
    pf_image_free(&a);
    pf_image_free(&b);
}

PF_TEST(nan_propagates)
{
    pf_error err = {0};
    pf_image a, b;
    PF_REQUIRE_OK(pf_image_create(&a, 3, 1, 3, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 3, 1, 3, rgba, &err), &err);
    a.pixels[0] = NAN;
    a.pixels[4] = 5.0f; /* a larger finite error after the NaN must not hide it */
    pf_image_metrics metrics;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK(isnan(metrics.rmse) && isnan(metrics.relmse) && isnan(metrics.max_abs_error));
    a.pixels[0] = INFINITY;
    PF_REQUIRE_OK(pf_image_compare(&a, &b, &metrics, &err), &err);
    PF_CHECK(isinf(metrics.rmse) && isinf(metrics.max_abs_error));
    pf_image_free(&a);
    pf_image_free(&b);
}

PF_TEST(mismatches_are_invalid)
{
    pf_error err = {0};
    pf_image a, b, c, d;
    PF_REQUIRE_OK(pf_image_create(&a, 640, 480, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 320, 240, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&c, 640, 480, 3, rgba, &err), &err);
    static const char *const other[] = {"R", "G", "B", "Z"};
    PF_REQUIRE_OK(pf_image_create(&d, 640, 480, 4, other, &err), &err);
    pf_image_metrics metrics;
    PF_CHECK(pf_image_compare(&a, &b, &metrics, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "640x480") && strstr(err.message, "320x240"), "%s",
                 err.message);
    PF_CHECK(pf_image_compare(&a, &c, &metrics, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "'A'") != NULL, "%s", err.message);
    PF_CHECK(pf_image_compare(&c, &a, &metrics, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "'A'") != NULL, "%s", err.message);
    PF_CHECK(pf_image_compare(&a, &d, &metrics, &err) == PF_ERR_INVALID);
    PF_CHECK_MSG(strstr(err.message, "'A'") != NULL, "%s", err.message);
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&c);
    pf_image_free(&d);
}

/* pf_image_append_channels: the old channels copied, the new ones zero, a taken name refused. */
PF_TEST(appended_channels_follow_the_old_ones)
{
    pf_error err = {0};
    pf_image a, grown;
    PF_REQUIRE_OK(pf_image_create(&a, 5, 3, 4, rgba, &err), &err);
    for (size_t i = 0; i < 5 * 3 * 4; i++)
        a.pixels[i] = (float)i;
    static const char *const added[] = {"motion.X", "motion.Y"};
    PF_REQUIRE_OK(pf_image_append_channels(&a, added, 2, &grown, &err), &err);
    PF_CHECK(grown.channel_count == 6 && pf_image_channel(&grown, "motion.Y") == 5);
    for (size_t p = 0; p < 15; p++) {
        for (int c = 0; c < 4; c++)
            PF_CHECK(grown.pixels[p * 6 + c] == a.pixels[p * 4 + c]);
        PF_CHECK(grown.pixels[p * 6 + 4] == 0.0f && grown.pixels[p * 6 + 5] == 0.0f);
    }
    pf_image_free(&grown);
    static const char *const taken[] = {"G"};
    PF_CHECK(pf_image_append_channels(&a, taken, 1, &grown, &err) == PF_ERR_INVALID);
    pf_image_free(&a);
}

/* Flicker: two frames 0.1 apart over a reference of 1 (channels in another order in b), and
 * what it refuses. */
PF_TEST(flicker_is_the_difference_over_the_reference)
{
    static const char *const reordered[] = {"A", "B", "G", "R"};
    pf_image a = {0}, b = {0}, reference = {0}, small = {0};
    pf_error err = {0};
    PF_REQUIRE_OK(pf_image_create(&a, 5, 3, 4, rgba, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&b, 5, 3, 4, reordered, &err), &err);
    PF_REQUIRE_OK(pf_image_create(&reference, 5, 3, 4, rgba, &err), &err);
    fill(&a, 1.1f);
    fill(&b, 1.0f);
    fill(&reference, 1.0f);
    double flicker = -1.0;
    PF_CHECK_OK(pf_image_flicker(&a, &b, &reference, &flicker, &err), &err);
    /* 0.1² / (1 + 0.01) */
    PF_CHECK_NEAR(flicker, 0.01 / 1.01, 1e-6);
    PF_CHECK_OK(pf_image_flicker(&a, &a, &reference, &flicker, &err), &err);
    PF_CHECK(flicker == 0.0);
    PF_REQUIRE_OK(pf_image_create(&small, 4, 3, 4, rgba, &err), &err);
    PF_CHECK(pf_image_flicker(&a, &b, &small, &flicker, &err) == PF_ERR_INVALID);
    pf_image_free(&a);
    pf_image_free(&b);
    pf_image_free(&reference);
    pf_image_free(&small);
}

int main(void)
{
    PF_RUN(identical_images_have_zero_error);
    PF_RUN(appended_channels_follow_the_old_ones);
    PF_RUN(constant_offset);
    PF_RUN(single_differing_pixel);
    PF_RUN(channels_match_by_name);
    PF_RUN(without_rgb_every_channel_counts);
    PF_RUN(nan_propagates);
    PF_RUN(mismatches_are_invalid);
    PF_RUN(flicker_is_the_difference_over_the_reference);
    return pf_test_finish();
}
