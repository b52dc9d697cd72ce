/*
 * core/vk buffers: the device limit, size 0, and out-of-range copies are
 * refused; allocation sizes keep llvmpipe's shader variant key constant.
 */
#include "pf_vk_internal.h"
#include "vk_test_util.h"

#include <inttypes.h>

PF_TEST(buffer_over_the_storage_range_is_refused)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    const pf_vk_device_info *info = pf_vk_info(ctx);
    uint64_t too_big = info->max_storage_buffer_range + 1;
    pf_vk_buffer *buffer = (pf_vk_buffer *)&err; /* must be reset to NULL */
    PF_CHECK(pf_vk_buffer_create(ctx, too_big, "photon store", &buffer, &err) == PF_ERR_LIMIT);
    PF_CHECK(buffer == NULL);
    char number[32];
    snprintf(number, sizeof number, "%" PRIu64, too_big);
    PF_CHECK_MSG(strstr(err.message, number) != NULL, "no requested size in: %s", err.message);
    snprintf(number, sizeof number, "%" PRIu64, info->max_storage_buffer_range);
    PF_CHECK_MSG(strstr(err.message, number) != NULL, "no limit in: %s", err.message);
    PF_CHECK(strstr(err.message, "photon store") != NULL);
    PF_CHECK(strstr(err.message, "maxStorageBufferRange") != NULL);
    PF_CHECK(strstr(err.message, info->name) != NULL);

    /* Exactly at the limit is allowed (lavapipe: 128 MiB of host memory). */
    PF_CHECK_OK(pf_vk_buffer_create(ctx, info->max_storage_buffer_range, "at the limit",
                                    &buffer, &err),
                &err);
    if (buffer) {
        PF_CHECK(pf_vk_buffer_size(buffer) == info->max_storage_buffer_range);
        pf_vk_buffer_destroy(ctx, buffer);
    }
    VK_TEST_FINISH(ctx);
}

PF_TEST(buffer_of_size_zero_is_refused)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_buffer *buffer = NULL;
    PF_CHECK(pf_vk_buffer_create(ctx, 0, "empty grid", &buffer, &err) == PF_ERR_INVALID);
    PF_CHECK(buffer == NULL);
    PF_CHECK(strstr(err.message, "empty grid") != NULL);
    PF_CHECK(strstr(err.message, "size 0") != NULL);
    VK_TEST_FINISH(ctx);
}

PF_TEST(copies_outside_the_buffer_are_refused)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_buffer *buffer = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, 64, "small", &buffer, &err), &err);
    PF_REQUIRE(buffer);
    uint8_t data[128];
    for (int i = 0; i < 128; i++)
        data[i] = (uint8_t)i;
    PF_CHECK(pf_vk_buffer_upload(ctx, buffer, 0, data, 65, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "small") != NULL && strstr(err.message, "65") != NULL);
    PF_CHECK(pf_vk_buffer_upload(ctx, buffer, 60, data, 8, &err) == PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "offset 60") != NULL);
    /* offset + size would wrap around 2^64 */
    PF_CHECK(pf_vk_buffer_upload(ctx, buffer, UINT64_MAX - 2, data, 8, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_vk_buffer_download(ctx, buffer, 65, data, 1, &err) == PF_ERR_INVALID);
    PF_CHECK(pf_vk_buffer_upload(ctx, buffer, 0, NULL, 4, &err) == PF_ERR_INVALID);

    /* The edges themselves are fine, and a partial write leaves the rest alone. */
    PF_CHECK_OK(pf_vk_buffer_upload(ctx, buffer, 0, data, 64, &err), &err);
    uint8_t patch[4] = {200, 201, 202, 203};
    PF_CHECK_OK(pf_vk_buffer_upload(ctx, buffer, 60, patch, 4, &err), &err);
    uint8_t back[64];
    PF_CHECK_OK(pf_vk_buffer_download(ctx, buffer, 0, back, 64, &err), &err);
    PF_CHECK(memcmp(back, data, 60) == 0);
    PF_CHECK(memcmp(back + 60, patch, 4) == 0);
    pf_vk_buffer_destroy(ctx, buffer);
    VK_TEST_FINISH(ctx);
}

/*
 * llvmpipe keys a kernel's compiled variant on two size-derived bits per
 * texel buffer (memory.c): whether the buffer's size is a power of two, and
 * bits 8..15 of the view's range (the whole allocation). Both must be the
 * same for every size, or a new scene size recompiles the render kernels.
 */
PF_TEST(allocation_sizes_keep_the_variant_bits_constant)
{
    const uint64_t limit = 1ull << 31;
    uint64_t sizes[4096 + 64];
    size_t n = 0;
    for (uint64_t s = 1; s <= 4096; s++)
        sizes[n++] = s;
    for (uint64_t e = 12; e < 31; e++) { /* powers of two and their neighbours */
        sizes[n++] = (1ull << e) - 1;
        sizes[n++] = 1ull << e;
        sizes[n++] = (1ull << e) + 1;
    }
    for (size_t i = 0; i < n; i++) {
        uint64_t a = pf_vk_buffer_allocation_size(sizes[i], limit);
        PF_CHECK_MSG(a >= sizes[i], "%" PRIu64 " -> %" PRIu64, sizes[i], a);
        PF_CHECK_MSG(a % 16 == 0, "%" PRIu64 " -> %" PRIu64 " (whole texels)", sizes[i], a);
        PF_CHECK_MSG((a & (a - 1)) != 0, "%" PRIu64 " -> %" PRIu64 " (power of two)", sizes[i],
                     a);
        PF_CHECK_MSG(((a >> 8) & 0xff) == 0, "%" PRIu64 " -> %" PRIu64 " (range bits 8..15)",
                     sizes[i], a);
        PF_CHECK_MSG(a - sizes[i] <= 3 * 64 * 1024, "%" PRIu64 " -> %" PRIu64, sizes[i], a);
    }
    /* Where the padding would pass the device's range, the size stays as asked. */
    PF_CHECK(pf_vk_buffer_allocation_size(limit - 5, limit) == limit - 5);
    PF_CHECK(pf_vk_buffer_allocation_size(limit, limit) == limit);
}

int main(void)
{
    PF_RUN(buffer_over_the_storage_range_is_refused);
    PF_RUN(buffer_of_size_zero_is_refused);
    PF_RUN(copies_outside_the_buffer_are_refused);
    PF_RUN(allocation_sizes_keep_the_variant_bits_constant);
    return pf_test_finish();
}
