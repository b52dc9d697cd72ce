/* Storage buffers: creation against the device limits, upload and download. */
#include "pf_vk_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MIB (1024.0 * 1024.0)

static const VkMemoryPropertyFlags host_coherent =
    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;

/* First memory type allowed by type_bits that has all of required (and, if possible, preferred). */
static uint32_t find_memory_type(const pf_vk_context *ctx, uint32_t type_bits,
                                 VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred)
{
    const VkPhysicalDeviceMemoryProperties *memory = &ctx->memory_properties;
    for (int pass = 0; pass < 2; pass++) {
        VkMemoryPropertyFlags wanted = pass == 0 ? required | preferred : required;
        for (uint32_t type = 0; type < memory->memoryTypeCount; type++) {
            if ((type_bits & (1u << type)) &&
                (memory->memoryTypes[type].propertyFlags & wanted) == wanted)
                return type;
        }
    }
    return UINT32_MAX;
}

pf_vk_memory_use pf_vk_memory_use_of(pf_vk_context *ctx)
{
    return (pf_vk_memory_use){atomic_load(&ctx->memory_in_use), atomic_load(&ctx->memory_peak)};
}

void pf_vk_memory_peak_reset(pf_vk_context *ctx)
{
    atomic_store(&ctx->memory_peak, atomic_load(&ctx->memory_in_use));
}

void pf_vk_memory_held(pf_vk_context *ctx, uint64_t bytes)
{
    uint64_t now = atomic_fetch_add(&ctx->memory_in_use, bytes) + bytes;
    uint64_t peak = atomic_load(&ctx->memory_peak);
    while (peak < now && !atomic_compare_exchange_weak(&ctx->memory_peak, &peak, now))
        continue;
}

void pf_vk_memory_released(pf_vk_context *ctx, uint64_t bytes)
{
    atomic_fetch_sub(&ctx->memory_in_use, bytes);
}

/* Frees memory and stops counting its bytes (0: already not counted). */
static void memory_freed(pf_vk_context *ctx, VkDeviceMemory memory, uint64_t bytes)
{
    double start = pf_time_ms();
    vkFreeMemory(ctx->device, memory, NULL);
    pf_vk_time_add(&ctx->allocate_ns, start);
    pf_vk_memory_released(ctx, bytes);
}

/* A VkBuffer with bound memory of *bytes (counted as held until memory_freed);
 * *mapped is set when the memory is host-visible + coherent. */
static pf_status allocate(pf_vk_context *ctx, uint64_t size, VkBufferUsageFlags usage,
                          VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred,
                          const char *label, VkBuffer *buffer, VkDeviceMemory *memory,
                          void **mapped, uint64_t *bytes, pf_error *err)
{
    *bytes = 0;
    *buffer = VK_NULL_HANDLE;
    *memory = VK_NULL_HANDLE;
    *mapped = NULL;
    VkBufferCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = size,
        .usage = usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkResult result = vkCreateBuffer(ctx->device, &info, NULL, buffer);
    if (result != VK_SUCCESS) {
        *buffer = VK_NULL_HANDLE;
        return pf_error_set(err, PF_ERR_VULKAN, "buffer '%s': vkCreateBuffer(%llu bytes) failed: %s",
                            label, (unsigned long long)size, pf_vk_result_name(result));
    }
    VkMemoryRequirements requirements;
    vkGetBufferMemoryRequirements(ctx->device, *buffer, &requirements);
    uint32_t type = find_memory_type(ctx, requirements.memoryTypeBits, required, preferred);
    if (type == UINT32_MAX) {
        vkDestroyBuffer(ctx->device, *buffer, NULL);
        *buffer = VK_NULL_HANDLE;
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "buffer '%s': device '%s' has no memory type with flags 0x%x",
                            label, ctx->info.name, (unsigned)required);
    }
    VkMemoryAllocateInfo allocation = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .allocationSize = requirements.size,
        .memoryTypeIndex = type,
    };
    double start = pf_time_ms();
    result = vkAllocateMemory(ctx->device, &allocation, NULL, memory);
    if ((result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY) &&
        pf_vk_kept_release(ctx) > 0) /* what is kept for reuse goes first (kept.c) */
        result = vkAllocateMemory(ctx->device, &allocation, NULL, memory);
    if (result != VK_SUCCESS) {
        *memory = VK_NULL_HANDLE; /* a failed call leaves its output undefined */
    } else {
        *bytes = requirements.size;
        pf_vk_memory_held(ctx, *bytes);
        result = vkBindBufferMemory(ctx->device, *buffer, *memory, 0);
    }
    VkMemoryPropertyFlags flags = ctx->memory_properties.memoryTypes[type].propertyFlags;
    if (result == VK_SUCCESS && (flags & host_coherent) == host_coherent &&
        !(ctx->force_staging && (usage & VK_BUFFER_USAGE_STORAGE_BUFFER_BIT)))
        result = vkMapMemory(ctx->device, *memory, 0, VK_WHOLE_SIZE, 0, mapped);
    pf_vk_time_add(&ctx->allocate_ns, start);
    if (result != VK_SUCCESS) {
        if (*memory)
            memory_freed(ctx, *memory, *bytes);
        *bytes = 0;
        vkDestroyBuffer(ctx->device, *buffer, NULL);
        *buffer = VK_NULL_HANDLE;
        *memory = VK_NULL_HANDLE;
        *mapped = NULL;
        int out_of_memory = result == VK_ERROR_OUT_OF_DEVICE_MEMORY ||
                            result == VK_ERROR_OUT_OF_HOST_MEMORY;
        return pf_error_set(err, out_of_memory ? PF_ERR_NOMEM : PF_ERR_VULKAN,
                            "buffer '%s': allocating %llu bytes on '%s' failed: %s", label,
                            (unsigned long long)requirements.size, ctx->info.name,
                            pf_vk_result_name(result));
    }
    return PF_OK;
}

/*
 * llvmpipe (Mesa 22.x) compiles a compute shader once per variant, and a
 * variant's key holds two bits per bound texel buffer taken from sizes:
 * whether the buffer's byte size is a power of two (`pot_width`) and bits
 * 8..15 of the view's byte range (read through the sampler-view union as
 * `last_level`, giving `level_zero_only`). A kernel that reads scene-sized
 * buffers through texel views would be compiled again (20-35 s for a
 * render kernel on 2 cores) whenever a new scene or frame flipped one of
 * those bits. So every buffer gets a size for which both are constant:
 * under 256 bytes, a multiple of 16 that is no power of two (range bits
 * 8..15 are 0); else a multiple of 64 KiB that is no power of two (the same
 * bits are 0). Views span the whole allocation. The cost: at most 192 KiB
 * per buffer, on every device (the padding is never read).
 */
static int is_power_of_two(uint64_t x) { return x && !(x & (x - 1)); }

uint64_t pf_vk_buffer_allocation_size(uint64_t size, uint64_t limit)
{
    const uint64_t small_step = 16, small_end = 256, step = 64 * 1024;
    uint64_t padded;
    if (size < small_end - small_step) {
        padded = (size + small_step - 1) / small_step * small_step;
        while (padded == 0 || is_power_of_two(padded))
            padded += small_step;
    } else {
        padded = (size + step - 1) / step * step;
        while (is_power_of_two(padded))
            padded += step;
    }
    return padded <= limit ? padded : size;
}

pf_status pf_vk_buffer_create(pf_vk_context *ctx, uint64_t size, const char *label,
                              pf_vk_buffer **out, pf_error *err)
{
    *out = NULL;
    if (!label)
        label = "unnamed";
    if (size == 0)
        return pf_error_set(err, PF_ERR_INVALID, "buffer '%s': size 0 (Vulkan buffers need >= 1 byte)",
                            label);
    if (size > ctx->info.max_storage_buffer_range)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "buffer '%s': %llu bytes (%.1f MiB) exceeds maxStorageBufferRange "
                            "%llu bytes (%.1f MiB) of device '%s'; split the data into "
                            "several buffers",
                            label, (unsigned long long)size, (double)size / MIB,
                            (unsigned long long)ctx->info.max_storage_buffer_range,
                            (double)ctx->info.max_storage_buffer_range / MIB, ctx->info.name);
    uint64_t allocated = pf_vk_buffer_allocation_size(size, ctx->info.max_storage_buffer_range);
    pf_vk_buffer *buffer = pf_vk_kept_buffer_take(ctx, allocated); /* kept.c */
    if (buffer) {
        snprintf(buffer->label, sizeof buffer->label, "%s", label);
        buffer->size = size;
        *out = buffer;
        return PF_OK;
    }
    buffer = calloc(1, sizeof *buffer);
    if (!buffer)
        return pf_error_set(err, PF_ERR_NOMEM, "buffer '%s': out of host memory", label);
    snprintf(buffer->label, sizeof buffer->label, "%s", label);
    buffer->size = size;
    buffer->allocated = allocated;
    pf_status status = allocate(
        ctx, buffer->allocated,
        VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
            VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
            VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
        VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, buffer->label, &buffer->buffer, &buffer->memory,
        &buffer->mapped, &buffer->memory_bytes, err);
    if (status != PF_OK) {
        free(buffer);
        return status;
    }
    /* Vulkan promises nothing of new memory's contents: with validation on (the tests),
     * mapped buffers start as NaN bytes, so that a kernel reading what nothing wrote fails
     * on lavapipe as it could on a GPU (whose driver zeroes new memory, and whose kept
     * buffers hold the last frame's data). */
    if (ctx->validation && buffer->mapped)
        memset(buffer->mapped, 0xff, buffer->allocated);
    *out = buffer;
    return PF_OK;
}

void pf_vk_buffer_free(pf_vk_context *ctx, pf_vk_buffer *buffer, int counted)
{
    if (buffer->mapped)
        vkUnmapMemory(ctx->device, buffer->memory);
    for (int kind = 0; kind < PF_VK_BINDING_KINDS; kind++)
        if (buffer->views[kind])
            vkDestroyBufferView(ctx->device, buffer->views[kind], NULL);
    vkDestroyBuffer(ctx->device, buffer->buffer, NULL);
    memory_freed(ctx, buffer->memory, counted ? buffer->memory_bytes : 0);
    free(buffer);
}

void pf_vk_buffer_destroy(pf_vk_context *ctx, pf_vk_buffer *buffer)
{
    if (buffer && !pf_vk_kept_buffer_put(ctx, buffer)) /* kept.c */
        pf_vk_buffer_free(ctx, buffer, 1);
}

uint64_t pf_vk_buffer_size(const pf_vk_buffer *buffer) { return buffer->size; }

void *pf_vk_buffer_host_memory(pf_vk_buffer *buffer) { return buffer->mapped; }

pf_status pf_vk_buffer_texel_view(pf_vk_context *ctx, pf_vk_buffer *buffer, int kind,
                                  VkBufferView *view, pf_error *err)
{
    const VkFormat format = kind == PF_VK_BINDING_TEXEL_UINT  ? VK_FORMAT_R32_UINT
                            : kind == PF_VK_BINDING_TEXEL_INT4 ? VK_FORMAT_R32G32B32A32_SINT
                                                               : VK_FORMAT_R32G32B32A32_SFLOAT;
    const uint64_t texel_bytes = kind == PF_VK_BINDING_TEXEL_UINT ? 4 : 16;
    /* The whole allocation where it fits the device (a stable variant key, above). */
    uint64_t texels = buffer->allocated / texel_bytes;
    if (texels > ctx->max_texel_buffer_elements)
        texels = buffer->size / texel_bytes;
    if (texels == 0 || texels > ctx->max_texel_buffer_elements)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "buffer '%s': %llu bytes are %llu texels of %llu bytes, outside "
                            "1..maxTexelBufferElements %u of device '%s'",
                            buffer->label, (unsigned long long)buffer->size,
                            (unsigned long long)texels, (unsigned long long)texel_bytes,
                            ctx->max_texel_buffer_elements, ctx->info.name);
    pthread_mutex_lock(&ctx->view_lock);
    VkResult result = VK_SUCCESS;
    if (!buffer->views[kind]) {
        VkBufferViewCreateInfo info = {
            .sType = VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO,
            .buffer = buffer->buffer,
            .format = format,
            .range = texels * texel_bytes,
        };
        VkBufferView made;
        result = vkCreateBufferView(ctx->device, &info, NULL, &made);
        if (result == VK_SUCCESS)
            buffer->views[kind] = made;
    }
    *view = buffer->views[kind];
    pthread_mutex_unlock(&ctx->view_lock);
    if (result != VK_SUCCESS)
        return pf_error_set(err, PF_ERR_VULKAN, "buffer '%s': vkCreateBufferView failed: %s",
                            buffer->label, pf_vk_result_name(result));
    return PF_OK;
}

pf_status pf_vk_buffer_range_check(const pf_vk_buffer *buffer, uint64_t offset,
                                   const void *data, uint64_t size, const char *what,
                                   pf_error *err)
{
    if (size > 0 && !data)
        return pf_error_set(err, PF_ERR_INVALID, "buffer '%s': %s of %llu bytes with no host data",
                            buffer->label, what, (unsigned long long)size);
    if (offset > buffer->size || size > buffer->size - offset)
        return pf_error_set(err, PF_ERR_INVALID,
                            "buffer '%s': %s of %llu bytes at offset %llu is outside its "
                            "%llu bytes",
                            buffer->label, what, (unsigned long long)size,
                            (unsigned long long)offset, (unsigned long long)buffer->size);
    return PF_OK;
}

pf_status pf_vk_staging_create(pf_vk_context *ctx, uint64_t size, int to_device,
                               const char *label, pf_vk_staging *out, pf_error *err)
{
    if (pf_vk_kept_staging_take(ctx, size, to_device, out)) /* kept.c */
        return PF_OK;
    out->to_device = to_device;
    out->capacity = size;
    return allocate(ctx, size,
                    to_device ? VK_BUFFER_USAGE_TRANSFER_SRC_BIT : VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                    host_coherent, to_device ? 0 : VK_MEMORY_PROPERTY_HOST_CACHED_BIT, label,
                    &out->buffer, &out->memory, &out->mapped, &out->bytes, err);
}

void pf_vk_staging_free(pf_vk_context *ctx, const pf_vk_staging *staging, int counted)
{
    if (staging->memory)
        vkUnmapMemory(ctx->device, staging->memory);
    if (staging->buffer)
        vkDestroyBuffer(ctx->device, staging->buffer, NULL);
    if (staging->memory)
        memory_freed(ctx, staging->memory, counted ? staging->bytes : 0);
}

void pf_vk_staging_destroy(pf_vk_context *ctx, pf_vk_staging *staging)
{
    if (!pf_vk_kept_staging_put(ctx, staging)) /* kept.c */
        pf_vk_staging_free(ctx, staging, 1);
    memset(staging, 0, sizeof *staging);
}

/*
 * One blocking copy between the device buffer and a host-visible staging
 * buffer. The leading barrier orders it after every earlier submission's
 * writes; the trailing one makes a download's result visible to the host.
 */
static pf_status staged_copy(pf_vk_context *ctx, pf_vk_buffer *buffer, uint64_t offset,
                             void *host, uint64_t size, int to_device, pf_error *err)
{
    pf_vk_staging staging;
    pf_status status = pf_vk_staging_create(ctx, size, to_device, buffer->label, &staging, err);
    if (status != PF_OK)
        return status;
    if (to_device)
        pf_vk_copy(ctx, staging.mapped, host, size);

    VkCommandBuffer command = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
    VkResult result = VK_SUCCESS;
    const char *failed_call = NULL;
    pthread_mutex_lock(&ctx->queue_lock);
    VkCommandBufferAllocateInfo allocation = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = ctx->transfer_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    result = vkAllocateCommandBuffers(ctx->device, &allocation, &command);
    failed_call = "vkAllocateCommandBuffers";
    if (result == VK_SUCCESS) {
        VkFenceCreateInfo fence_info = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        result = vkCreateFence(ctx->device, &fence_info, NULL, &fence);
        failed_call = "vkCreateFence";
    }
    if (result == VK_SUCCESS) {
        VkCommandBufferBeginInfo begin = {
            .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
            .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
        };
        result = vkBeginCommandBuffer(command, &begin);
        failed_call = "vkBeginCommandBuffer";
    }
    if (result == VK_SUCCESS) {
        VkMemoryBarrier before = {
            .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
            .srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT,
            .dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT,
        };
        vkCmdPipelineBarrier(command, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                             VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before, 0, NULL, 0, NULL);
        VkBufferCopy region = {
            .srcOffset = to_device ? 0 : offset,
            .dstOffset = to_device ? offset : 0,
            .size = size,
        };
        vkCmdCopyBuffer(command, to_device ? staging.buffer : buffer->buffer,
                        to_device ? buffer->buffer : staging.buffer, 1, &region);
        VkMemoryBarrier after = {
            .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
            .srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT,
            .dstAccessMask = VK_ACCESS_HOST_READ_BIT,
        };
        vkCmdPipelineBarrier(command, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT,
                             0, 1, &after, 0, NULL, 0, NULL);
        result = vkEndCommandBuffer(command);
        failed_call = "vkEndCommandBuffer";
    }
    if (result == VK_SUCCESS) {
        VkSubmitInfo submit = {
            .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
            .commandBufferCount = 1,
            .pCommandBuffers = &command,
        };
        result = vkQueueSubmit(ctx->queue, 1, &submit, fence);
        failed_call = "vkQueueSubmit";
        atomic_fetch_add(&ctx->submits, 1);
    }
    /* The wait holds no lock: other threads' submissions (the EXR writer's, a motion
     * overlap's) go on meanwhile; the pool is locked again to free the command buffer. */
    pthread_mutex_unlock(&ctx->queue_lock);
    if (result == VK_SUCCESS) {
        double wait_start = pf_time_ms();
        result = vkWaitForFences(ctx->device, 1, &fence, VK_TRUE, UINT64_MAX);
        pf_vk_time_add(&ctx->wait_ns, wait_start);
        failed_call = "vkWaitForFences";
        atomic_fetch_add(&ctx->host_waits, 1);
        if (atomic_load(&ctx->in_flight) > 0) /* it queued behind that submission */
            atomic_fetch_add(&ctx->waits_behind, 1);
    }
    if (fence)
        vkDestroyFence(ctx->device, fence, NULL);
    if (command) {
        pthread_mutex_lock(&ctx->queue_lock);
        vkFreeCommandBuffers(ctx->device, ctx->transfer_pool, 1, &command);
        pthread_mutex_unlock(&ctx->queue_lock);
    }

    if (result == VK_SUCCESS && !to_device)
        pf_vk_copy(ctx, host, staging.mapped, size);
    pf_vk_staging_destroy(ctx, &staging);
    if (result != VK_SUCCESS)
        return pf_error_set(err, PF_ERR_VULKAN,
                            "buffer '%s': %s of %llu bytes: %s failed: %s", buffer->label,
                            to_device ? "upload" : "download", (unsigned long long)size,
                            failed_call, pf_vk_result_name(result));
    return PF_OK;
}

pf_status pf_vk_buffer_upload(pf_vk_context *ctx, pf_vk_buffer *buffer, uint64_t offset,
                              const void *data, uint64_t size, pf_error *err)
{
    pf_status status = pf_vk_buffer_range_check(buffer, offset, data, size, "upload", err);
    if (status != PF_OK || size == 0)
        return status;
    pf_vk_count_copy(ctx, size, 1);
    if (buffer->mapped) {
        pf_vk_copy(ctx, (char *)buffer->mapped + offset, data, size);
        return PF_OK;
    }
    return staged_copy(ctx, buffer, offset, (void *)data, size, 1, err);
}

pf_status pf_vk_buffer_download(pf_vk_context *ctx, pf_vk_buffer *buffer, uint64_t offset,
                                void *data, uint64_t size, pf_error *err)
{
    pf_status status = pf_vk_buffer_range_check(buffer, offset, data, size, "download", err);
    if (status != PF_OK || size == 0)
        return status;
    pf_vk_count_copy(ctx, size, 0);
    if (buffer->mapped) {
        pf_vk_copy(ctx, data, (const char *)buffer->mapped + offset, size);
        return PF_OK;
    }
    return staged_copy(ctx, buffer, offset, data, size, 0, err);
}
