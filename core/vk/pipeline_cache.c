/*
 * The on-disk pipeline cache: one VkPipelineCache per context, filled from a
 * file in the caller's cache directory when one is given, passed to every
 * vkCreateComputePipelines, and written back atomically when new pipelines
 * were created since the last write.
 *
 * The file name carries the device's identity (vendor, device, driver version,
 * pipelineCacheUUID and a hash of the driver's name and info string, since
 * some drivers — lavapipe among them — keep one UUID across releases), so
 * machines and drivers never read each other's data. The driver's blob is
 * wrapped in our own header with its size and checksum: a truncated or garbage
 * file is detected before the driver sees it, ignored with a warning, and
 * replaced on the next write.
 */
#include "pf_vk_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define CACHE_MAGIC 0x43504650u /* "PFPC" little-endian */
#define CACHE_FORMAT_VERSION 1u
/* Larger files are not ours to load (drivers' caches stay well below). */
#define CACHE_MAX_BYTES (512u << 20)

typedef struct cache_file_header {
    uint32_t magic;
    uint32_t format_version;
    uint64_t data_bytes;
    uint64_t data_checksum; /* FNV-1a 64 of the driver's blob */
} cache_file_header;

/* Vulkan spec, VkPipelineCacheHeaderVersionOne: what every driver's blob starts with. */
typedef struct driver_header {
    uint32_t header_bytes;
    uint32_t header_version;
    uint32_t vendor_id;
    uint32_t device_id;
    uint8_t uuid[VK_UUID_SIZE];
} driver_header;

static uint64_t fnv1a64(const void *data, size_t bytes, uint64_t hash)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < bytes; i++) {
        hash ^= p[i];
        hash *= 0x100000001b3ull;
    }
    return hash;
}
#define FNV_OFFSET 0xcbf29ce484222325ull

static void set_cache_path(pf_vk_context *ctx, const char *dir)
{
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(ctx->physical_device, &properties);
    char uuid[2 * VK_UUID_SIZE + 1];
    for (unsigned i = 0; i < VK_UUID_SIZE; i++)
        snprintf(uuid + 2 * i, 3, "%02x", properties.pipelineCacheUUID[i]);
    uint64_t driver_hash = fnv1a64(ctx->info.driver, strlen(ctx->info.driver), FNV_OFFSET);
    driver_hash = fnv1a64(ctx->info.name, strlen(ctx->info.name), driver_hash);
    snprintf(ctx->cache.stats.path, sizeof ctx->cache.stats.path,
             "%s/pipelines-%04x-%04x-%08x-%s-%016" PRIx64 ".vkcache", dir,
             properties.vendorID, properties.deviceID, properties.driverVersion, uuid,
             driver_hash);
    memcpy(ctx->cache.uuid, properties.pipelineCacheUUID, VK_UUID_SIZE);
    ctx->cache.vendor_id = properties.vendorID;
    ctx->cache.device_id = properties.deviceID;
}

/*
 * Reads and checks the file. Returns the driver's blob (malloc'ed) or NULL;
 * *why says why a present file was not accepted (NULL when absent).
 */
static void *read_cache_file(pf_vk_context *ctx, size_t *bytes, const char **why)
{
    *bytes = 0;
    *why = NULL;
    FILE *file = fopen(ctx->cache.stats.path, "rb");
    if (!file) {
        if (errno != ENOENT)
            *why = "unreadable";
        return NULL;
    }
    cache_file_header header;
    void *data = NULL;
    if (fread(&header, sizeof header, 1, file) != 1)
        *why = "shorter than its header";
    else if (header.magic != CACHE_MAGIC || header.format_version != CACHE_FORMAT_VERSION)
        *why = "not a photonfarm pipeline cache of this version";
    else if (header.data_bytes < sizeof(driver_header) || header.data_bytes > CACHE_MAX_BYTES)
        *why = "implausible data size";
    else if (!(data = malloc(header.data_bytes)))
        *why = "out of memory";
    else if (fread(data, 1, header.data_bytes, file) != header.data_bytes)
        *why = "truncated";
    else if (fgetc(file) != EOF)
        *why = "longer than its header says";
    else if (fnv1a64(data, header.data_bytes, FNV_OFFSET) != header.data_checksum)
        *why = "checksum mismatch";
    else {
        driver_header driver;
        memcpy(&driver, data, sizeof driver);
        if (driver.header_version != VK_PIPELINE_CACHE_HEADER_VERSION_ONE ||
            driver.vendor_id != ctx->cache.vendor_id ||
            driver.device_id != ctx->cache.device_id ||
            memcmp(driver.uuid, ctx->cache.uuid, VK_UUID_SIZE) != 0)
            *why = "written by another device or driver";
    }
    fclose(file);
    if (*why) {
        free(data);
        return NULL;
    }
    *bytes = header.data_bytes;
    return data;
}

pf_status pf_vk_pipeline_cache_open(pf_vk_context *ctx, const char *dir, pf_error *err)
{
    void *data = NULL;
    size_t bytes = 0;
    if (dir && dir[0]) {
        if (mkdir(dir, 0777) != 0 && errno != EEXIST)
            pf_log(PF_LOG_WARN, "pipeline cache directory %s cannot be created (%s): "
                                "shaders compile anew in every process",
                   dir, strerror(errno));
        else {
            set_cache_path(ctx, dir);
            const char *why;
            data = read_cache_file(ctx, &bytes, &why);
            if (data)
                ctx->cache.stats.loaded_bytes = bytes;
            else if (why) {
                ctx->cache.stats.rejected = 1;
                pf_log(PF_LOG_WARN, "pipeline cache %s ignored (%s); it will be rewritten",
                       ctx->cache.stats.path, why);
            }
        }
    }
    VkPipelineCacheCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO,
        .initialDataSize = bytes,
        .pInitialData = data,
    };
    VkResult result = vkCreatePipelineCache(ctx->device, &info, NULL, &ctx->cache.handle);
    free(data);
    if (result != VK_SUCCESS) {
        ctx->cache.handle = VK_NULL_HANDLE;
        return pf_error_set(err, PF_ERR_VULKAN, "vkCreatePipelineCache failed on '%s': %s (%d)",
                            ctx->info.name, pf_vk_result_name(result), (int)result);
    }
    return PF_OK;
}

void pf_vk_pipeline_cache_note(pf_vk_context *ctx, int cache_hit)
{
    pthread_mutex_lock(&ctx->cache.lock);
    ctx->cache.stats.pipelines++;
    ctx->cache.stats.cache_hits += cache_hit != 0;
    ctx->cache.dirty |= !cache_hit; /* hits add nothing to write */
    pthread_mutex_unlock(&ctx->cache.lock);
}

/* write to a temporary sibling, fsync, rename: a reader sees the old file or the new one. */
static pf_status write_atomically(const char *path, const void *a, size_t a_bytes, const void *b,
                                  size_t b_bytes, pf_error *err)
{
    char temp[sizeof((pf_vk_cache_stats *)0)->path + 32];
    snprintf(temp, sizeof temp, "%s.tmp-%ld", path, (long)getpid());
    int fd = open(temp, O_WRONLY | O_CREAT | O_TRUNC, 0666);
    if (fd < 0)
        return pf_error_set(err, PF_ERR_IO, "pipeline cache %s: cannot create: %s", temp,
                            strerror(errno));
    int ok = write(fd, a, a_bytes) == (ssize_t)a_bytes && write(fd, b, b_bytes) == (ssize_t)b_bytes;
    int saved_errno = errno;
    ok = ok && fsync(fd) == 0;
    if (!ok)
        saved_errno = errno;
    ok = close(fd) == 0 && ok;
    if (ok && rename(temp, path) != 0) {
        saved_errno = errno;
        ok = 0;
    }
    if (!ok) {
        unlink(temp);
        return pf_error_set(err, PF_ERR_IO, "pipeline cache %s: cannot write: %s", path,
                            strerror(saved_errno ? saved_errno : EIO));
    }
    return PF_OK;
}

pf_status pf_vk_pipeline_cache_save(pf_vk_context *ctx, pf_error *err)
{
    if (!ctx->cache.handle || !ctx->cache.stats.path[0])
        return PF_OK;
    pthread_mutex_lock(&ctx->cache.lock);
    int dirty = ctx->cache.dirty || ctx->cache.stats.rejected;
    pthread_mutex_unlock(&ctx->cache.lock);
    if (!dirty)
        return PF_OK;
    size_t bytes = 0;
    VkResult result = vkGetPipelineCacheData(ctx->device, ctx->cache.handle, &bytes, NULL);
    void *data = result == VK_SUCCESS && bytes ? malloc(bytes) : NULL;
    if (data)
        result = vkGetPipelineCacheData(ctx->device, ctx->cache.handle, &bytes, data);
    if (result != VK_SUCCESS || !data || bytes < sizeof(driver_header)) {
        free(data);
        return pf_error_set(err, PF_ERR_VULKAN,
                            "vkGetPipelineCacheData on '%s' returned %zu bytes: %s (%d)",
                            ctx->info.name, bytes, pf_vk_result_name(result), (int)result);
    }
    cache_file_header header = {
        .magic = CACHE_MAGIC,
        .format_version = CACHE_FORMAT_VERSION,
        .data_bytes = bytes,
        .data_checksum = fnv1a64(data, bytes, FNV_OFFSET),
    };
    pf_status status =
        write_atomically(ctx->cache.stats.path, &header, sizeof header, data, bytes, err);
    free(data);
    if (status == PF_OK) {
        pthread_mutex_lock(&ctx->cache.lock);
        ctx->cache.dirty = 0;
        ctx->cache.stats.rejected = 0;
        ctx->cache.stats.saved_bytes = bytes;
        pthread_mutex_unlock(&ctx->cache.lock);
    }
    return status;
}

void pf_vk_pipeline_cache_close(pf_vk_context *ctx)
{
    if (!ctx->cache.handle)
        return;
    pf_error err = {0};
    if (pf_vk_pipeline_cache_save(ctx, &err) != PF_OK)
        pf_log(PF_LOG_WARN, "%s", err.message);
    vkDestroyPipelineCache(ctx->device, ctx->cache.handle, NULL);
    ctx->cache.handle = VK_NULL_HANDLE;
}

pf_vk_cache_stats pf_vk_pipeline_cache_stats(pf_vk_context *ctx)
{
    pthread_mutex_lock(&ctx->cache.lock);
    pf_vk_cache_stats stats = ctx->cache.stats;
    pthread_mutex_unlock(&ctx->cache.lock);
    return stats;
}
