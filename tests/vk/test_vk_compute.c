/* core/vk compute path: upload, dispatch with push + spec constants, barriers, timestamps. */
#include "vk_test_util.h"

#include "pf_vk_internal.h"

#include <stdint.h>
#include <stdlib.h>

/* shaders/vk_selftest.comp: spec constant 0 = workgroup size, 1 = multiplier. */
#define SELFTEST_WORKGROUP 64u
#define SELFTEST_MULTIPLIER 3u

typedef struct selftest_push {
    uint32_t count;
    uint32_t addend;
} selftest_push;

static uint32_t expected_value(uint32_t input, uint32_t index, uint32_t addend)
{
    return input * SELFTEST_MULTIPLIER + addend + index / SELFTEST_WORKGROUP;
}

static pf_vk_pipeline *selftest_pipeline(pf_vk_context *ctx, pf_error *err)
{
    const pf_vk_spec_constant spec[] = {{0, SELFTEST_WORKGROUP}, {1, SELFTEST_MULTIPLIER}};
    pf_vk_pipeline *pipeline = NULL;
    PF_CHECK_OK(pf_vk_pipeline_create_named(ctx, "vk_selftest", 2, sizeof(selftest_push), spec,
                                            2, &pipeline, err),
                err);
    return pipeline;
}

/* One upload → dispatch → download round trip over several workgroups; recorded: the
 * copies recorded with the dispatch (pf_vk_cmd_upload / _download), one submission and
 * one wait in all (issue 44). */
static void round_trip(pf_vk_context *ctx, uint32_t count, int recorded)
{
    pf_error err = {0};
    pf_vk_pipeline *pipeline = selftest_pipeline(ctx, &err);
    PF_REQUIRE(pipeline);
    uint32_t *input = malloc(count * sizeof *input);
    uint32_t *output = malloc(count * sizeof *output);
    PF_REQUIRE(input && output);
    for (uint32_t i = 0; i < count; i++) {
        input[i] = i * 2654435761u; /* Knuth's multiplicative hash: varied bit patterns */
        output[i] = 0xdeadbeefu;
    }
    /* One extra word after the data must stay untouched (the shader checks count). */
    pf_vk_buffer *in_buffer = NULL, *out_buffer = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, count * 4ull, "selftest in", &in_buffer, &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, (count + 1) * 4ull, "selftest out", &out_buffer, &err),
                &err);
    if (in_buffer && out_buffer) {
        const uint32_t sentinel = 0x5eed5eedu;
        pf_vk_traffic before = pf_vk_traffic_of(ctx);
        pf_vk_commands *cmds = NULL;
        if (!recorded) {
            PF_CHECK_OK(pf_vk_buffer_upload(ctx, in_buffer, 0, input, count * 4ull, &err), &err);
            PF_CHECK_OK(pf_vk_buffer_upload(ctx, out_buffer, count * 4ull, &sentinel, 4, &err),
                        &err);
        }
        PF_CHECK_OK(pf_vk_commands_begin(ctx, &cmds, &err), &err);
        if (cmds) {
            if (recorded) {
                PF_CHECK_OK(pf_vk_cmd_upload(cmds, in_buffer, 0, input, count * 4ull, &err),
                            &err);
                PF_CHECK_OK(pf_vk_cmd_upload(cmds, out_buffer, count * 4ull, &sentinel, 4, &err),
                            &err);
            }
            selftest_push push = {count, 17};
            pf_vk_buffer *buffers[] = {in_buffer, out_buffer};
            uint32_t groups = (count + SELFTEST_WORKGROUP - 1) / SELFTEST_WORKGROUP;
            PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, sizeof push,
                                           groups, 1, 1, &err),
                        &err);
            if (recorded)
                PF_CHECK_OK(pf_vk_cmd_download(cmds, out_buffer, 0, output, count * 4ull, &err),
                            &err);
            PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
            pf_vk_commands_destroy(cmds);
            if (!recorded)
                PF_CHECK_OK(pf_vk_buffer_download(ctx, out_buffer, 0, output, count * 4ull, &err),
                            &err);
            pf_vk_traffic used = pf_vk_traffic_since(ctx, before);
            /* Staged blocking copies are a submission and a wait each; mapped ones none. */
            uint64_t copies = recorded || pf_vk_storage_is_host_memory(ctx) ? 0 : 3;
            PF_CHECK_MSG(used.submits == 1 + copies && used.host_waits == 1 + copies &&
                             used.upload_bytes == count * 4ull + 4 &&
                             used.readback_bytes == count * 4ull,
                         "%llu submits, %llu waits, %llu bytes up, %llu down",
                         (unsigned long long)used.submits, (unsigned long long)used.host_waits,
                         (unsigned long long)used.upload_bytes,
                         (unsigned long long)used.readback_bytes);
            uint32_t mismatches = 0;
            for (uint32_t i = 0; i < count; i++) {
                if (output[i] != expected_value(input[i], i, 17) && mismatches++ < 5)
                    fprintf(stderr, "  [%u] = %u, expected %u\n", i, output[i],
                            expected_value(input[i], i, 17));
            }
            PF_CHECK_MSG(mismatches == 0, "%u of %u values differ", mismatches, count);
            uint32_t tail = 0;
            PF_CHECK_OK(pf_vk_buffer_download(ctx, out_buffer, count * 4ull, &tail, 4, &err),
                        &err);
            PF_CHECK(tail == sentinel);
        }
    }
    pf_vk_buffer_destroy(ctx, in_buffer);
    pf_vk_buffer_destroy(ctx, out_buffer);
    pf_vk_pipeline_destroy(ctx, pipeline);
    free(input);
    free(output);
}

PF_TEST(compute_round_trip)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    /* Not a multiple of the workgroup size: the last group is partial. */
    round_trip(ctx, 10 * SELFTEST_WORKGROUP + 13, 0);
    round_trip(ctx, 10 * SELFTEST_WORKGROUP + 13, 1);
    VK_TEST_FINISH(ctx);
}

/* The path discrete GPUs take (device-local memory is not mappable there). */
PF_TEST(compute_round_trip_through_staging)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_force_staging(ctx, 1);
    round_trip(ctx, 7 * SELFTEST_WORKGROUP + 1, 0);
    round_trip(ctx, 7 * SELFTEST_WORKGROUP + 1, 1);
    VK_TEST_FINISH(ctx);
}

/* An upload recorded between two dispatches that read its buffer lands between them, on
 * a mapped buffer (lavapipe) as on a staged one: the first sees the old values, the
 * second the new (issue 44's recorded copies). */
static void upload_between_dispatches(pf_vk_context *ctx)
{
    enum { COUNT = 256 };
    pf_error err = {0};
    pf_vk_pipeline *pipeline = selftest_pipeline(ctx, &err);
    pf_vk_buffer *in = NULL, *first = NULL, *second = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, COUNT * 4, "between in", &in, &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, (COUNT + 1) * 4, "between first", &first, &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, (COUNT + 1) * 4, "between second", &second, &err),
                &err);
    pf_vk_commands *cmds = NULL;
    if (pipeline && in && first && second)
        PF_CHECK_OK(pf_vk_commands_begin(ctx, &cmds, &err), &err);
    if (cmds) {
        static uint32_t old_values[COUNT], new_values[COUNT], out_first[COUNT], out_second[COUNT];
        for (uint32_t i = 0; i < COUNT; i++) {
            old_values[i] = i;
            new_values[i] = 1000 + i;
        }
        uint32_t groups = (COUNT + SELFTEST_WORKGROUP - 1) / SELFTEST_WORKGROUP;
        selftest_push push = {COUNT, 0};
        pf_vk_buffer *reads_first[2] = {in, first}, *reads_second[2] = {in, second};
        PF_CHECK_OK(pf_vk_cmd_upload(cmds, in, 0, old_values, sizeof old_values, &err), &err);
        PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, reads_first, 2, &push, sizeof push, groups,
                                       1, 1, &err),
                    &err);
        PF_CHECK_OK(pf_vk_cmd_upload(cmds, in, 0, new_values, sizeof new_values, &err), &err);
        PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, reads_second, 2, &push, sizeof push,
                                       groups, 1, 1, &err),
                    &err);
        PF_CHECK_OK(pf_vk_cmd_download(cmds, first, 0, out_first, sizeof out_first, &err), &err);
        PF_CHECK_OK(pf_vk_cmd_download(cmds, second, 0, out_second, sizeof out_second, &err),
                    &err);
        PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
        pf_vk_commands_destroy(cmds);
        uint32_t wrong = 0;
        for (uint32_t i = 0; i < COUNT; i++)
            wrong += out_first[i] != expected_value(old_values[i], i, 0) ||
                     out_second[i] != expected_value(new_values[i], i, 0);
        PF_CHECK_MSG(wrong == 0, "%u of %u values read the wrong upload", wrong, COUNT);
    }
    pf_vk_buffer_destroy(ctx, in);
    pf_vk_buffer_destroy(ctx, first);
    pf_vk_buffer_destroy(ctx, second);
    pf_vk_pipeline_destroy(ctx, pipeline);
}

PF_TEST(an_upload_between_dispatches_lands_between_them)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    upload_between_dispatches(ctx); /* mapped on lavapipe */
    pf_vk_force_staging(ctx, 1);
    upload_between_dispatches(ctx);
    VK_TEST_FINISH(ctx);
}

/*
 * a → b → a → b, each pass reading what the one before wrote, recorded in one command
 * buffer with the upload before and the download after; caller_barriers: the caller
 * records a barrier after each dispatch (else pf_vk_cmd_dispatch's own must order them).
 * Checks the values and, with single_use, that the submitted commands take no more.
 */
static void dispatch_chain(pf_vk_context *ctx, int caller_barriers, int single_use)
{
    pf_error err = {0};
    enum { COUNT = 1000, PASSES = 4 };
    pf_vk_pipeline *pipeline = selftest_pipeline(ctx, &err);
    pf_vk_buffer *a = NULL, *b = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, COUNT * 4, "chain a", &a, &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, COUNT * 4, "chain b", &b, &err), &err);
    pf_vk_commands *cmds = NULL;
    if (pipeline && a && b)
        PF_CHECK_OK(pf_vk_commands_begin(ctx, &cmds, &err), &err);
    if (cmds) {
        static uint32_t values[COUNT], result[COUNT];
        for (uint32_t i = 0; i < COUNT; i++)
            values[i] = 7 * i;
        PF_CHECK_OK(pf_vk_cmd_upload(cmds, a, 0, values, sizeof values, &err), &err);
        uint32_t groups = (COUNT + SELFTEST_WORKGROUP - 1) / SELFTEST_WORKGROUP;
        for (uint32_t pass = 0; pass < PASSES; pass++) {
            selftest_push push = {COUNT, pass + 1};
            pf_vk_buffer *buffers[2] = {pass % 2 ? b : a, pass % 2 ? a : b};
            PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, sizeof push,
                                           groups, 1, 1, &err),
                        &err);
            if (caller_barriers)
                pf_vk_cmd_barrier(cmds);
        }
        /* PASSES is even, so the last pass wrote a. */
        PF_CHECK_OK(pf_vk_cmd_download(cmds, a, 0, result, sizeof result, &err), &err);
        PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
        for (uint32_t pass = 0; pass < PASSES; pass++) {
            for (uint32_t i = 0; i < COUNT; i++)
                values[i] = expected_value(values[i], i, pass + 1);
        }
        PF_CHECK(memcmp(result, values, sizeof values) == 0);
        if (single_use && pipeline) {
            /* Recording after submit is refused: commands are single-use. */
            selftest_push push = {COUNT, 0};
            pf_vk_buffer *buffers[2] = {a, b};
            PF_CHECK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, sizeof push, 1, 1,
                                        1, &err) == PF_ERR_INVALID);
            PF_CHECK(pf_vk_commands_submit(cmds, &err) == PF_ERR_INVALID);
        }
        pf_vk_commands_destroy(cmds);
    }
    pf_vk_buffer_destroy(ctx, a);
    pf_vk_buffer_destroy(ctx, b);
    pf_vk_pipeline_destroy(ctx, pipeline);
}

PF_TEST(dispatch_chain_with_barriers)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    dispatch_chain(ctx, 1, 1);
    VK_TEST_FINISH(ctx);
}

/*
 * The same chain without a barrier recorded by the caller: each dispatch still reads what
 * the one before it wrote (pf_vk_cmd_dispatch orders it), checked by the validation layer's
 * synchronization validation, which reports a read after a write with no barrier between
 * on any device. lavapipe runs dispatches in order whatever is recorded, so the values alone
 * could not show a missing barrier: on a GPU it let final's resolve read the gather's sums
 * before they were written.
 */
PF_TEST(dispatches_see_the_writes_of_those_before_them)
{
    pf_error err = {0};
    pf_vk_options options = vk_test_options();
    if (!options.validation) {
        printf("  skipped: needs the validation layer (PF_VK_VALIDATION=1)\n");
        return;
    }
#ifdef __SANITIZE_ADDRESS__
    /* Debian 12's layer (1.3.239) leaks its synchronization state at vkDestroyInstance:
     * every allocation LeakSanitizer lists is the layer's own. The plain build checks it. */
    printf("  skipped under AddressSanitizer: the layer's synchronization validation leaks\n");
    return;
#endif
    options.validation = PF_VK_VALIDATION_SYNC;
    pf_vk_context *ctx = NULL;
    PF_REQUIRE_OK(pf_vk_create(&options, &ctx, &err), &err);
    dispatch_chain(ctx, 0, 0);
    VK_TEST_FINISH(ctx);
}

static uint32_t staging_kept(pf_vk_context *ctx)
{
    uint32_t buffers, staging;
    pf_vk_kept_counts(ctx, &buffers, &staging);
    return staging;
}

static uint32_t buffers_kept(pf_vk_context *ctx)
{
    uint32_t buffers, staging;
    pf_vk_kept_counts(ctx, &buffers, &staging);
    return buffers;
}

/*
 * Staging buffers are kept for the next copy of their direction that needs at least half of
 * one (a frame's readbacks repeat their sizes; allocating pinned host memory each time cost
 * most of a 1080p frame's host time on an H200), at most PF_VK_STAGING_KEPT of them.
 */
PF_TEST(staging_buffers_are_kept_for_the_next_copy_of_their_size)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    const uint64_t mib = 1024 * 1024;
    pf_vk_staging first, again, upload, small;
    uint64_t in_use = pf_vk_memory_use_of(ctx).current;
    PF_REQUIRE_OK(pf_vk_staging_create(ctx, mib, 0, "kept", &first, &err), &err);
    VkBuffer first_buffer = first.buffer;
    pf_vk_staging_destroy(ctx, &first);
    /* Kept, and no longer counted as memory in use (the frames' memory rows). */
    PF_CHECK(staging_kept(ctx) == 1);
    PF_CHECK(pf_vk_memory_use_of(ctx).current == in_use);
    PF_REQUIRE_OK(pf_vk_staging_create(ctx, mib - 4096, 0, "kept", &again, &err), &err);
    PF_CHECK(again.buffer == first_buffer && staging_kept(ctx) == 0);
    pf_vk_staging_destroy(ctx, &again);
    /* The other direction, and a copy that would use less than half of it: new buffers. */
    PF_REQUIRE_OK(pf_vk_staging_create(ctx, mib, 1, "kept", &upload, &err), &err);
    PF_REQUIRE_OK(pf_vk_staging_create(ctx, mib / 4, 0, "kept", &small, &err), &err);
    PF_CHECK(upload.buffer != first_buffer && small.buffer != first_buffer);
    PF_CHECK(staging_kept(ctx) == 1);
    pf_vk_staging_destroy(ctx, &upload);
    pf_vk_staging_destroy(ctx, &small);
    enum { MANY = PF_VK_STAGING_KEPT + 3 };
    pf_vk_staging many[MANY];
    for (int i = 0; i < MANY; i++)
        PF_REQUIRE_OK(pf_vk_staging_create(ctx, 4096u * (i + 1), i % 2, "kept", &many[i], &err),
                      &err);
    for (int i = 0; i < MANY; i++)
        pf_vk_staging_destroy(ctx, &many[i]);
    PF_CHECK(staging_kept(ctx) == PF_VK_STAGING_KEPT);
    /* A kept buffer takes copies up to its own size, not its memory's (which the driver
     * rounds up: on an H200 a 4-byte buffer's memory took a 16-byte copy, which the layer
     * refused): staged copies of growing sizes, each checked. */
    pf_vk_force_staging(ctx, 1);
    pf_vk_buffer *buffer = NULL;
    PF_REQUIRE_OK(pf_vk_buffer_create(ctx, 256, "kept copies", &buffer, &err), &err);
    for (uint32_t size = 4; size <= 256; size *= 2) {
        uint8_t sent[256], back[256];
        for (uint32_t i = 0; i < size; i++)
            sent[i] = (uint8_t)(size + 7 * i);
        PF_CHECK_OK(pf_vk_buffer_upload(ctx, buffer, 0, sent, size, &err), &err);
        PF_CHECK_OK(pf_vk_buffer_download(ctx, buffer, 0, back, size, &err), &err);
        PF_CHECK_MSG(memcmp(sent, back, size) == 0, "a staged copy of %u bytes", size);
    }
    pf_vk_buffer_destroy(ctx, buffer);
    VK_TEST_FINISH(ctx); /* frees what is kept (LeakSanitizer and the layer would say) */
}

/*
 * Device-local buffers are kept too, for a request of their allocated size (a GPU driver
 * clears each new allocation: some 700 MB a 1080p frame). Mapped buffers (lavapipe's) are
 * not: the tests force staging to make them device-local here.
 */
PF_TEST(device_buffers_are_kept_for_the_next_buffer_of_their_size)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_buffer *mapped = NULL;
    PF_REQUIRE_OK(pf_vk_buffer_create(ctx, 1000, "mapped", &mapped, &err), &err);
    int host_memory = pf_vk_buffer_host_memory(mapped) != NULL;
    pf_vk_buffer_destroy(ctx, mapped);
    PF_CHECK(buffers_kept(ctx) == (host_memory ? 0u : 1u));
    pf_vk_force_staging(ctx, 1);
    uint64_t in_use = pf_vk_memory_use_of(ctx).current;
    uint32_t kept = buffers_kept(ctx);
    pf_vk_buffer *first = NULL, *again = NULL, *other = NULL;
    PF_REQUIRE_OK(pf_vk_buffer_create(ctx, 3 * 65536 + 5, "first", &first, &err), &err);
    VkBuffer first_handle = first->buffer;
    uint32_t values[4] = {1, 2, 3, 4}, back[4] = {0};
    PF_CHECK_OK(pf_vk_buffer_upload(ctx, first, 0, values, sizeof values, &err), &err);
    pf_vk_buffer_destroy(ctx, first);
    PF_CHECK(buffers_kept(ctx) == kept + 1);
    PF_CHECK(pf_vk_memory_use_of(ctx).current == in_use);
    /* The same allocated size (pf_vk_buffer_allocation_size), another caller's label and
     * size: the kept buffer, with its size and label, and its old contents. */
    PF_REQUIRE_OK(pf_vk_buffer_create(ctx, 3 * 65536 + 100, "again", &again, &err), &err);
    PF_CHECK(again->buffer == first_handle && pf_vk_buffer_size(again) == 3 * 65536 + 100);
    PF_CHECK(strcmp(again->label, "again") == 0);
    PF_CHECK_OK(pf_vk_buffer_download(ctx, again, 0, back, sizeof back, &err), &err);
    PF_CHECK(memcmp(values, back, sizeof values) == 0);
    PF_REQUIRE_OK(pf_vk_buffer_create(ctx, 5 * 65536, "other", &other, &err), &err);
    PF_CHECK(other->buffer != first_handle);
    pf_vk_buffer_destroy(ctx, again);
    pf_vk_buffer_destroy(ctx, other);
    PF_CHECK(buffers_kept(ctx) == kept + 2);
    VK_TEST_FINISH(ctx); /* frees what is kept (LeakSanitizer and the layer would say) */
}

PF_TEST(timestamps_measure_elapsed_time)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    enum { COUNT = 4096 };
    pf_vk_pipeline *pipeline = selftest_pipeline(ctx, &err);
    pf_vk_buffer *a = NULL, *b = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, COUNT * 4, "timed a", &a, &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, COUNT * 4, "timed b", &b, &err), &err);
    pf_vk_commands *cmds = NULL;
    if (pipeline && a && b)
        PF_CHECK_OK(pf_vk_commands_begin(ctx, &cmds, &err), &err);
    if (cmds) {
        int begin = pf_vk_cmd_timestamp(cmds);
        selftest_push push = {COUNT, 1};
        pf_vk_buffer *buffers[2] = {a, b};
        PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, sizeof push,
                                       COUNT / SELFTEST_WORKGROUP, 1, 1, &err),
                    &err);
        int end = pf_vk_cmd_timestamp(cmds);
        /* Before submit there is nothing to read. */
        PF_CHECK(pf_vk_commands_elapsed_ms(cmds, begin, end) < 0);
        PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
        if (pf_vk_info(ctx)->timestamp_valid_bits == 0) {
            PF_CHECK(begin < 0 && end < 0);
            PF_CHECK(pf_vk_commands_elapsed_ms(cmds, begin, end) < 0);
        } else {
            PF_CHECK(begin == 0 && end == 1);
            double elapsed = pf_vk_commands_elapsed_ms(cmds, begin, end);
            PF_CHECK_MSG(elapsed >= 0 && isfinite(elapsed), "elapsed %g ms", elapsed);
            /* Slots never written read as unavailable. */
            PF_CHECK(pf_vk_commands_elapsed_ms(cmds, begin, 7) < 0);
            PF_CHECK(pf_vk_commands_elapsed_ms(cmds, -1, end) < 0);
        }
        pf_vk_commands_destroy(cmds);
    }
    pf_vk_buffer_destroy(ctx, a);
    pf_vk_buffer_destroy(ctx, b);
    pf_vk_pipeline_destroy(ctx, pipeline);
    VK_TEST_FINISH(ctx);
}

/* Misuse of dispatch is refused before anything reaches Vulkan. */
/*
 * A SPIR-V module of count storage-buffer variables at set 0, bindings 0..count-1, and
 * nothing else: as far as core/vk reads a module before the driver sees it (its bindings).
 * *words_count its length; malloc'd, NULL when out of memory.
 */
static uint32_t *storage_buffers_module(uint32_t count, uint32_t *words_count)
{
    enum { HEADER = 5, OP_DECORATE = 71, OP_TYPE_INT = 21, OP_TYPE_POINTER = 32,
           OP_VARIABLE = 59, BINDING = 33, DESCRIPTOR_SET = 34, STORAGE_BUFFER = 12 };
    const uint32_t uint_id = 1, pointer_id = 2, first_variable = 3;
    *words_count = HEADER + count * 8 + 4 + 4 + count * 4;
    uint32_t *w = malloc(*words_count * sizeof *w), at = 0;
    if (!w)
        return NULL;
    const uint32_t header[HEADER] = {0x07230203u, 0x00010500u, 0, first_variable + count, 0};
    for (; at < HEADER; at++)
        w[at] = header[at];
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t decorations[8] = {4u << 16 | OP_DECORATE, first_variable + i, BINDING, i,
                                         4u << 16 | OP_DECORATE, first_variable + i,
                                         DESCRIPTOR_SET, 0};
        for (int k = 0; k < 8; k++)
            w[at++] = decorations[k];
    }
    const uint32_t types[8] = {4u << 16 | OP_TYPE_INT, uint_id, 32, 0,
                               4u << 16 | OP_TYPE_POINTER, pointer_id, STORAGE_BUFFER, uint_id};
    for (int k = 0; k < 8; k++)
        w[at++] = types[k];
    for (uint32_t i = 0; i < count; i++) {
        const uint32_t variable[4] = {4u << 16 | OP_VARIABLE, pointer_id, first_variable + i,
                                      STORAGE_BUFFER};
        for (int k = 0; k < 4; k++)
            w[at++] = variable[k];
    }
    return w;
}

PF_TEST(dispatch_arguments_are_checked)
{
    pf_error err = {0};
    pf_vk_context *ctx = vk_test_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_pipeline *pipeline = selftest_pipeline(ctx, &err);
    pf_vk_buffer *a = NULL;
    PF_CHECK_OK(pf_vk_buffer_create(ctx, 256, "checked", &a, &err), &err);
    pf_vk_commands *cmds = NULL;
    if (pipeline && a)
        PF_CHECK_OK(pf_vk_commands_begin(ctx, &cmds, &err), &err);
    if (cmds) {
        selftest_push push = {64, 0};
        pf_vk_buffer *buffers[2] = {a, a};
        uint32_t too_many = pf_vk_info(ctx)->max_workgroup_count[0] + 1u;
        if (too_many != 0) { /* the limit can be UINT32_MAX; then no count exceeds it */
            PF_CHECK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, sizeof push,
                                        too_many, 1, 1, &err) == PF_ERR_LIMIT);
            PF_CHECK(strstr(err.message, "maxComputeWorkGroupCount") != NULL);
            PF_CHECK(strstr(err.message, "vk_selftest") != NULL);
        }
        PF_CHECK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 1, &push, sizeof push, 1, 1, 1,
                                    &err) == PF_ERR_INVALID);
        PF_CHECK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, &push, 4, 1, 1, 1, &err) ==
                 PF_ERR_INVALID);
        pf_vk_buffer *missing[2] = {a, NULL};
        PF_CHECK(pf_vk_cmd_dispatch(cmds, pipeline, missing, 2, &push, sizeof push, 1, 1, 1,
                                    &err) == PF_ERR_INVALID);
        /* The recording survives refused calls and still submits cleanly. */
        PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
        pf_vk_commands_destroy(cmds);
    }
    pf_vk_pipeline *unknown = NULL;
    PF_CHECK(pf_vk_pipeline_create_named(ctx, "no_such_shader", 1, 0, NULL, 0, &unknown, &err) ==
             PF_ERR_INVALID);
    PF_CHECK(strstr(err.message, "no_such_shader") != NULL);
    /* Bindings a module declares count against the device's limits, those it lacks against
     * none (they stay out of the layout): a module of one more storage buffer than the device
     * allows is refused naming the limit, before the driver sees it (texel buffers count
     * against another one); vk_selftest in as many bindings is made. */
    uint32_t storage_limit = 0;
    {
        VkPhysicalDeviceProperties properties;
        vkGetPhysicalDeviceProperties(ctx->physical_device, &properties);
        storage_limit = properties.limits.maxPerStageDescriptorStorageBuffers;
    }
    if (storage_limit < 4096) {
        uint32_t variables = storage_limit + 1, words_count = 0;
        uint32_t *words = storage_buffers_module(variables, &words_count);
        PF_REQUIRE(words != NULL);
        pf_vk_pipeline_desc wide = {.name = "wide", .spirv = words, .spirv_bytes = words_count * 4,
                                    .buffer_count = variables};
        PF_CHECK(pf_vk_pipeline_create(ctx, &wide, &unknown, &err) == PF_ERR_LIMIT);
        PF_CHECK(strstr(err.message, "maxPerStageDescriptorStorageBuffers") != NULL);
        free(words);
        pf_vk_pipeline *sparse = NULL;
        PF_CHECK_OK(pf_vk_pipeline_create_named(ctx, "vk_selftest", variables, 8, NULL, 0,
                                                &sparse, &err),
                    &err);
        pf_vk_pipeline_destroy(ctx, sparse);
    }
    const uint32_t not_spirv[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    pf_vk_pipeline_desc bad = {.name = "garbage", .spirv = not_spirv,
                               .spirv_bytes = sizeof not_spirv, .buffer_count = 1};
    PF_CHECK(pf_vk_pipeline_create(ctx, &bad, &unknown, &err) == PF_ERR_FORMAT);
    PF_CHECK(strstr(err.message, "garbage") != NULL);
    pf_vk_buffer_destroy(ctx, a);
    pf_vk_pipeline_destroy(ctx, pipeline);
    VK_TEST_FINISH(ctx);
}

int main(void)
{
    PF_RUN(compute_round_trip);
    PF_RUN(compute_round_trip_through_staging);
    PF_RUN(an_upload_between_dispatches_lands_between_them);
    PF_RUN(dispatch_chain_with_barriers);
    PF_RUN(dispatches_see_the_writes_of_those_before_them);
    PF_RUN(staging_buffers_are_kept_for_the_next_copy_of_their_size);
    PF_RUN(device_buffers_are_kept_for_the_next_buffer_of_their_size);
    PF_RUN(timestamps_measure_elapsed_time);
    PF_RUN(dispatch_arguments_are_checked);
    return pf_test_finish();
}
