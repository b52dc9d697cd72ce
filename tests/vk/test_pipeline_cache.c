/*
 * The persistent pipeline cache: a second context on the same directory gets
 * its pipelines from the cache, and a damaged cache file is ignored with a
 * warning and rewritten. Hits are what the driver reports: Vulkan's
 * pipeline-creation feedback where the driver's VkPipelineCache holds code,
 * and for Mesa drivers whose VkPipelineCache is header-only (lavapipe 22.x)
 * the absence of new entries in Mesa's shader cache, which sits in the same
 * directory.
 */
#include "vk_test_util.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* Vulkan spec: VkPipelineCacheHeaderVersionOne is 16 bytes + a 16-byte UUID. */
#define DRIVER_HEADER_BYTES 32u
#define MESA_VENDOR_ID 0x10005u

static char cache_dir[1024];

static pf_vk_context *cached_context(pf_error *err)
{
    pf_vk_context *ctx = NULL;
    pf_vk_options options = vk_test_options();
    options.pipeline_cache_dir = cache_dir;
    if (pf_vk_create(&options, &ctx, err) != PF_OK) {
        fprintf(stderr, "pf_vk_create failed: %s\n", err->message);
        return NULL;
    }
    return ctx;
}

/*
 * Two distinct pipelines (one shader, two specializations), each dispatched
 * once: llvmpipe compiles a compute shader at its first dispatch, not at
 * pipeline creation, so that is when Mesa's cache is read or written.
 */
static void create_pipelines(pf_vk_context *ctx)
{
    pf_error err = {0};
    pf_vk_buffer *buffers[2] = {NULL, NULL};
    PF_CHECK_OK(pf_vk_buffer_create(ctx, 256, "cache test in", &buffers[0], &err), &err);
    PF_CHECK_OK(pf_vk_buffer_create(ctx, 256, "cache test out", &buffers[1], &err), &err);
    for (uint32_t multiplier = 2; multiplier <= 3; multiplier++) {
        const pf_vk_spec_constant spec[] = {{0, 64}, {1, multiplier}};
        pf_vk_pipeline *pipeline = NULL;
        PF_CHECK_OK(pf_vk_pipeline_create_named(ctx, "vk_selftest", 2, 8, spec, 2, &pipeline,
                                                &err),
                    &err);
        pf_vk_commands *cmds = NULL;
        if (pipeline && buffers[0] && buffers[1] &&
            pf_vk_commands_begin(ctx, &cmds, &err) == PF_OK) {
            const uint32_t push[2] = {64, 1}; /* count, addend */
            PF_CHECK_OK(pf_vk_cmd_dispatch(cmds, pipeline, buffers, 2, push, sizeof push, 1, 1,
                                           1, &err),
                        &err);
            PF_CHECK_OK(pf_vk_commands_submit(cmds, &err), &err);
            pf_vk_commands_destroy(cmds);
        }
        pf_vk_pipeline_destroy(ctx, pipeline);
    }
    pf_vk_buffer_destroy(ctx, buffers[0]);
    pf_vk_buffer_destroy(ctx, buffers[1]);
}

/* Entries of Mesa's shader cache under cache_dir (files in its 2-hex-digit folders). */
static int mesa_cache_entries(void)
{
    char root[1200];
    snprintf(root, sizeof root, "%s/mesa_shader_cache", cache_dir);
    DIR *dir = opendir(root);
    if (!dir)
        return 0;
    int count = 0;
    struct dirent *bucket;
    while ((bucket = readdir(dir))) {
        if (strlen(bucket->d_name) != 2 || bucket->d_name[0] == '.')
            continue;
        char path[1500];
        snprintf(path, sizeof path, "%s/%s", root, bucket->d_name);
        DIR *inner = opendir(path);
        struct dirent *entry;
        while (inner && (entry = readdir(inner)))
            count += entry->d_name[0] != '.';
        if (inner)
            closedir(inner);
    }
    closedir(dir);
    return count;
}

static long file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (long)st.st_size : -1;
}

PF_TEST(second_context_creates_pipelines_from_the_cache)
{
    pf_error err = {0};
    pf_vk_context *first = cached_context(&err);
    PF_REQUIRE(first);
    int mesa = pf_vk_info(first)->vendor_id == MESA_VENDOR_ID;
    create_pipelines(first);
    pf_vk_cache_stats stats = pf_vk_pipeline_cache_stats(first);
    PF_CHECK(stats.pipelines == 2);
    PF_CHECK(stats.loaded_bytes == 0 && !stats.rejected);
    PF_CHECK_OK(pf_vk_pipeline_cache_save(first, &err), &err);
    stats = pf_vk_pipeline_cache_stats(first);
    PF_CHECK_MSG(stats.saved_bytes >= DRIVER_HEADER_BYTES, "saved %llu bytes",
                 (unsigned long long)stats.saved_bytes);
    PF_CHECK_MSG(file_size(stats.path) > (long)stats.saved_bytes, "%s: %ld bytes", stats.path,
                 file_size(stats.path));
    uint64_t saved = stats.saved_bytes;
    VK_TEST_FINISH(first); /* Mesa finishes writing its cache when the device goes */
    int entries_after_first = mesa_cache_entries();

    pf_vk_context *second = cached_context(&err);
    PF_REQUIRE(second);
    create_pipelines(second);
    stats = pf_vk_pipeline_cache_stats(second);
    PF_CHECK_MSG(stats.loaded_bytes == saved, "loaded %llu of %llu bytes",
                 (unsigned long long)stats.loaded_bytes, (unsigned long long)saved);
    PF_CHECK(!stats.rejected && stats.pipelines == 2);
    VK_TEST_FINISH(second);
    if (saved > DRIVER_HEADER_BYTES) {
        /* The driver's cache holds code: its feedback must report both as hits. */
        PF_CHECK_MSG(stats.cache_hits == 2, "%u of 2 pipelines from the cache",
                     stats.cache_hits);
    } else if (mesa) {
        /* Header-only VkPipelineCache: the compiled code lives in Mesa's cache. */
        PF_CHECK_MSG(entries_after_first > 0, "no Mesa cache entries under %s", cache_dir);
        PF_CHECK_MSG(mesa_cache_entries() == entries_after_first,
                     "the second context compiled anew: %d Mesa cache entries, %d before",
                     mesa_cache_entries(), entries_after_first);
    } else {
        fprintf(stderr, "note: device '%s' caches nothing in VkPipelineCache; hits unchecked\n",
                stats.path);
    }
}

/* Overwrites the cache file's bytes from offset with text (truncating there when asked). */
static void damage(const char *path, long offset, const char *text, int truncate_after)
{
    FILE *file = fopen(path, "r+b");
    PF_REQUIRE(file);
    PF_REQUIRE(fseek(file, offset, SEEK_SET) == 0);
    fwrite(text, 1, strlen(text), file);
    fclose(file);
    if (truncate_after)
        PF_REQUIRE(truncate(path, offset + (long)strlen(text)) == 0);
}

static void expect_ignored_then_rewritten(const char *what)
{
    pf_error err = {0};
    uint32_t warnings = pf_log_warning_count();
    pf_vk_context *ctx = cached_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_cache_stats stats = pf_vk_pipeline_cache_stats(ctx);
    PF_CHECK_MSG(stats.rejected && stats.loaded_bytes == 0, "%s: rejected %d, loaded %llu",
                 what, stats.rejected, (unsigned long long)stats.loaded_bytes);
    PF_CHECK_MSG(pf_log_warning_count() == warnings + 1, "%s: %u warnings", what,
                 pf_log_warning_count() - warnings);
    create_pipelines(ctx);
    VK_TEST_FINISH(ctx); /* saves */

    ctx = cached_context(&err);
    PF_REQUIRE(ctx);
    stats = pf_vk_pipeline_cache_stats(ctx);
    PF_CHECK_MSG(!stats.rejected && stats.loaded_bytes >= DRIVER_HEADER_BYTES,
                 "%s: the rewritten file was not accepted", what);
    pf_vk_destroy(ctx);
}

PF_TEST(damaged_cache_files_are_ignored_and_rewritten)
{
    pf_error err = {0};
    pf_vk_context *ctx = cached_context(&err);
    PF_REQUIRE(ctx);
    pf_vk_cache_stats stats = pf_vk_pipeline_cache_stats(ctx);
    pf_vk_destroy(ctx);
    PF_REQUIRE(file_size(stats.path) > 40);

    damage(stats.path, 30, "", 1); /* truncated inside the driver's header */
    expect_ignored_then_rewritten("truncated");
    damage(stats.path, 28, "garbage", 0); /* same size, checksum no longer matches */
    expect_ignored_then_rewritten("garbage");
    damage(stats.path, 0, "not a cache at all", 1);
    expect_ignored_then_rewritten("foreign file");
}

int main(void)
{
    char tmp[900];
    snprintf(cache_dir, sizeof cache_dir, "%s/pipeline-cache",
             pf_test_tmpdir(tmp, sizeof tmp));
    char command[1200];
    snprintf(command, sizeof command, "rm -rf '%s'", cache_dir);
    if (system(command) != 0)
        return 1;
    /* What the worker does (pf_cli_cache_dir): Mesa's cache in the same place. */
    setenv("MESA_SHADER_CACHE_DIR", cache_dir, 1);
    unsetenv("MESA_SHADER_CACHE_DISABLE");
    PF_RUN(second_context_creates_pipelines_from_the_cache);
    PF_RUN(damaged_cache_files_are_ignored_and_rewritten);
    return pf_test_finish();
}
