/* Command recording: dispatches with their descriptors, barriers, timestamps, fenced submit. */
#include "pf_vk_internal.h"

#include <stdlib.h>
#include <string.h>

/* Timestamp slots per pf_vk_commands: a frame has ~8 stages with two stamps each. */
#define TIMESTAMP_SLOTS 128u
/* Descriptor pools are created in chunks of this many sets (and 8 buffers per set). */
#define SETS_PER_POOL 64u
#define BUFFERS_PER_POOL (SETS_PER_POOL * 8u)

/* IN_FLIGHT: submitted, not yet waited for (pf_vk_commands_submit_async). */
typedef enum commands_state { RECORDING, IN_FLIGHT, SUBMITTED, BROKEN } commands_state;

typedef struct descriptor_pool {
    VkDescriptorPool pool;
    uint32_t sets_left;
    uint32_t buffers_left;
} descriptor_pool;

/* A copy recorded with the commands (pf_vk_cmd_upload / _download). */
typedef struct recorded_copy {
    pf_vk_staging staging; /* empty where the device buffer is mapped */
    void *host;            /* a download's destination, filled once the fence signals */
    const void *source;    /* a download's mapped or staging source */
    uint64_t size;
} recorded_copy;

struct pf_vk_commands {
    pf_vk_context *ctx;
    recorded_copy *copies;
    uint32_t copy_count, copy_capacity;
    uint32_t device_work; /* dispatches, staged copies and timestamps recorded */
    /* A dispatch was recorded since the last barrier: the next dispatch gets one first. */
    int unordered;
    /* The buffers the recorded dispatches use: an upload to one of them must be ordered
     * after those dispatches, so it is staged even where the buffer is mapped. */
    const pf_vk_buffer **bound;
    uint32_t bound_count, bound_capacity;
    commands_state state;
    VkCommandPool command_pool;
    VkCommandBuffer command;
    VkFence fence;
    VkQueryPool query_pool; /* VK_NULL_HANDLE when the queue has no timestamps */
    uint32_t timestamps_written;
    uint64_t timestamps[TIMESTAMP_SLOTS];
    descriptor_pool *descriptor_pools;
    uint32_t descriptor_pool_count;
};

static pf_status vulkan_error(pf_vk_commands *cmds, const char *call, VkResult result,
                              pf_error *err)
{
    return pf_error_set(err, result == VK_ERROR_OUT_OF_DEVICE_MEMORY ||
                                     result == VK_ERROR_OUT_OF_HOST_MEMORY
                                 ? PF_ERR_NOMEM
                                 : PF_ERR_VULKAN,
                        "%s failed on '%s': %s (%d)", call, cmds->ctx->info.name,
                        pf_vk_result_name(result), (int)result);
}

/* Orders everything before it (earlier submissions included) before everything after it. */
static void full_barrier(VkCommandBuffer command, VkPipelineStageFlags dst_stages,
                         VkAccessFlags dst_access)
{
    VkMemoryBarrier barrier = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT,
        .dstAccessMask = dst_access,
    };
    vkCmdPipelineBarrier(command, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, dst_stages, 0, 1, &barrier,
                         0, NULL, 0, NULL);
}

pf_status pf_vk_commands_begin(pf_vk_context *ctx, pf_vk_commands **out, pf_error *err)
{
    *out = NULL;
    pf_vk_commands *cmds = calloc(1, sizeof *cmds);
    if (!cmds)
        return pf_error_set(err, PF_ERR_NOMEM, "out of host memory for a command buffer");
    cmds->ctx = ctx;
    cmds->state = BROKEN;
    /* A pool per recording keeps recordings on different threads independent. */
    VkCommandPoolCreateInfo pool_info = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
        .queueFamilyIndex = ctx->queue_family,
    };
    VkCommandPool command_pool;
    VkResult result = vkCreateCommandPool(ctx->device, &pool_info, NULL, &command_pool);
    if (result != VK_SUCCESS) {
        free(cmds);
        return pf_error_set(err, PF_ERR_VULKAN, "vkCreateCommandPool failed on '%s': %s",
                            ctx->info.name, pf_vk_result_name(result));
    }
    cmds->command_pool = command_pool;

    const char *call = "vkAllocateCommandBuffers";
    VkCommandBufferAllocateInfo allocation = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = cmds->command_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VkCommandBuffer command;
    result = vkAllocateCommandBuffers(ctx->device, &allocation, &command);
    if (result == VK_SUCCESS) {
        cmds->command = command;
        call = "vkCreateFence";
        VkFenceCreateInfo fence_info = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        VkFence fence;
        result = vkCreateFence(ctx->device, &fence_info, NULL, &fence);
        if (result == VK_SUCCESS)
            cmds->fence = fence;
    }
    if (result == VK_SUCCESS && ctx->info.timestamp_valid_bits > 0) {
        call = "vkCreateQueryPool";
        VkQueryPoolCreateInfo query_info = {
            .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
            .queryType = VK_QUERY_TYPE_TIMESTAMP,
            .queryCount = TIMESTAMP_SLOTS,
        };
        VkQueryPool query_pool;
        result = vkCreateQueryPool(ctx->device, &query_info, NULL, &query_pool);
        if (result == VK_SUCCESS)
            cmds->query_pool = query_pool;
    }
    if (result == VK_SUCCESS) {
        call = "vkBeginCommandBuffer";
        VkCommandBufferBeginInfo begin = {
            .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
            .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
        };
        result = vkBeginCommandBuffer(cmds->command, &begin);
    }
    if (result != VK_SUCCESS) {
        pf_status status = vulkan_error(cmds, call, result, err);
        pf_vk_commands_destroy(cmds);
        return status;
    }
    if (cmds->query_pool)
        vkCmdResetQueryPool(cmds->command, cmds->query_pool, 0, TIMESTAMP_SLOTS);
    /* Staging copies from earlier submissions must land before any shader reads them. */
    full_barrier(cmds->command,
                 VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                     VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
    cmds->state = RECORDING;
    *out = cmds;
    return PF_OK;
}

/* A descriptor set for pipeline's layout, from a pool with room (a new chunk when full). */
static pf_status allocate_set(pf_vk_commands *cmds, const pf_vk_pipeline *pipeline,
                              VkDescriptorSet *set, pf_error *err)
{
    VkDevice device = cmds->ctx->device;
    descriptor_pool *current =
        cmds->descriptor_pool_count ? &cmds->descriptor_pools[cmds->descriptor_pool_count - 1]
                                    : NULL;
    if (!current || current->sets_left == 0 || current->buffers_left < pipeline->buffer_count) {
        descriptor_pool *grown = realloc(cmds->descriptor_pools,
                                         (cmds->descriptor_pool_count + 1) * sizeof *grown);
        if (!grown)
            return pf_error_set(err, PF_ERR_NOMEM, "out of host memory for descriptor pools");
        cmds->descriptor_pools = grown;
        uint32_t buffers = pipeline->buffer_count > BUFFERS_PER_POOL ? pipeline->buffer_count
                                                                     : BUFFERS_PER_POOL;
        /* Either kind may take every binding: the total left bounds both. */
        VkDescriptorPoolSize sizes[2] = {
            {.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = buffers},
            {.type = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, .descriptorCount = buffers},
        };
        VkDescriptorPoolCreateInfo info = {
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
            .maxSets = SETS_PER_POOL,
            .poolSizeCount = 2,
            .pPoolSizes = sizes,
        };
        VkDescriptorPool pool;
        VkResult result = vkCreateDescriptorPool(device, &info, NULL, &pool);
        if (result != VK_SUCCESS)
            return vulkan_error(cmds, "vkCreateDescriptorPool", result, err);
        current = &cmds->descriptor_pools[cmds->descriptor_pool_count++];
        *current = (descriptor_pool){pool, SETS_PER_POOL, buffers};
    }
    VkDescriptorSetAllocateInfo info = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
        .descriptorPool = current->pool,
        .descriptorSetCount = 1,
        .pSetLayouts = &pipeline->set_layout,
    };
    VkResult result = vkAllocateDescriptorSets(device, &info, set);
    if (result != VK_SUCCESS)
        return vulkan_error(cmds, "vkAllocateDescriptorSets", result, err);
    current->sets_left--;
    current->buffers_left -= pipeline->buffer_count;
    return PF_OK;
}

static pf_status check_dispatch(const pf_vk_commands *cmds, const pf_vk_pipeline *pipeline,
                                pf_vk_buffer *const *buffers, uint32_t buffer_count,
                                const void *push_constants, uint32_t push_constant_bytes,
                                const uint32_t groups[3], pf_error *err)
{
    const pf_vk_device_info *info = &cmds->ctx->info;
    if (cmds->state != RECORDING)
        return pf_error_set(err, PF_ERR_INVALID,
                            "shader '%s': dispatch recorded into commands that were already "
                            "submitted or failed",
                            pipeline->name);
    if (buffer_count != pipeline->buffer_count)
        return pf_error_set(err, PF_ERR_INVALID, "shader '%s': dispatch with %u buffers, the "
                            "pipeline was created for %u",
                            pipeline->name, buffer_count, pipeline->buffer_count);
    for (uint32_t i = 0; i < buffer_count; i++) {
        if (!buffers || !buffers[i])
            return pf_error_set(err, PF_ERR_INVALID, "shader '%s': buffer for binding %u is NULL",
                                pipeline->name, i);
    }
    if (push_constant_bytes != pipeline->push_constant_bytes ||
        (push_constant_bytes && !push_constants))
        return pf_error_set(err, PF_ERR_INVALID,
                            "shader '%s': dispatch with %u push-constant bytes%s, the pipeline "
                            "was created for %u",
                            pipeline->name, push_constant_bytes,
                            push_constants ? "" : " (no data)", pipeline->push_constant_bytes);
    for (int axis = 0; axis < 3; axis++) {
        if (groups[axis] > info->max_workgroup_count[axis])
            return pf_error_set(err, PF_ERR_LIMIT,
                                "shader '%s': dispatch of (%u, %u, %u) workgroups exceeds "
                                "maxComputeWorkGroupCount (%u, %u, %u) of device '%s' on "
                                "axis %c; split the dispatch",
                                pipeline->name, groups[0], groups[1], groups[2],
                                info->max_workgroup_count[0], info->max_workgroup_count[1],
                                info->max_workgroup_count[2], info->name, "xyz"[axis]);
    }
    return PF_OK;
}

static int is_bound(const pf_vk_commands *cmds, const pf_vk_buffer *buffer)
{
    for (uint32_t i = 0; i < cmds->bound_count; i++)
        if (cmds->bound[i] == buffer)
            return 1;
    return 0;
}

/* Remembers that a recorded dispatch uses buffer; 0 when out of memory. */
static int note_bound(pf_vk_commands *cmds, const pf_vk_buffer *buffer)
{
    if (is_bound(cmds, buffer))
        return 1;
    if (cmds->bound_count == cmds->bound_capacity) {
        uint32_t capacity = cmds->bound_capacity ? 2 * cmds->bound_capacity : 16;
        const pf_vk_buffer **grown = realloc(cmds->bound, capacity * sizeof *grown);
        if (!grown)
            return 0;
        cmds->bound = grown;
        cmds->bound_capacity = capacity;
    }
    cmds->bound[cmds->bound_count++] = buffer;
    return 1;
}

/* Binds pipeline, its buffers and push constants for a dispatch recorded next. */
static pf_status bind_for_dispatch(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                                   pf_vk_buffer *const *buffers, uint32_t buffer_count,
                                   const void *push_constants, uint32_t push_constant_bytes,
                                   pf_error *err)
{
    pf_status status = PF_OK;
    /* Every dispatch runs after the ones recorded before it and sees their writes: a GPU
     * overlaps dispatches that have no barrier between them (lavapipe runs them in order,
     * so a missing barrier showed only on GPUs: final's resolve read the gather's sums
     * before it wrote them). */
    if (cmds->unordered)
        pf_vk_cmd_barrier(cmds);
    vkCmdBindPipeline(cmds->command, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline->pipeline);
    if (buffer_count > 0) {
        VkDescriptorSet set;
        status = allocate_set(cmds, pipeline, &set, err);
        if (status != PF_OK) {
            pf_error_prefix(err, "shader '%s'", pipeline->name);
            return status;
        }
        VkDescriptorBufferInfo *infos = calloc(buffer_count, sizeof *infos);
        VkBufferView *views = calloc(buffer_count, sizeof *views);
        VkWriteDescriptorSet *writes = calloc(buffer_count, sizeof *writes);
        if (!infos || !views || !writes) {
            free(infos);
            free(views);
            free(writes);
            return pf_error_set(err, PF_ERR_NOMEM, "shader '%s': out of host memory",
                                pipeline->name);
        }
        uint32_t write_count = 0;
        for (uint32_t i = 0; i < buffer_count && status == PF_OK; i++) {
            int kind = pipeline->binding_kinds[i];
            if (kind == PF_VK_BINDING_ABSENT)
                continue; /* not in the layout: the kernel never reads it */
            VkWriteDescriptorSet *write = &writes[write_count++];
            *write = (VkWriteDescriptorSet){
                .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
                .dstSet = set,
                .dstBinding = i,
                .descriptorCount = 1,
                .descriptorType = pf_vk_descriptor_type(kind),
            };
            if (kind == PF_VK_BINDING_STORAGE) {
                infos[i] = (VkDescriptorBufferInfo){buffers[i]->buffer, 0, VK_WHOLE_SIZE};
                write->pBufferInfo = &infos[i];
            } else {
                status = pf_vk_buffer_texel_view(cmds->ctx, buffers[i], kind, &views[i], err);
                write->pTexelBufferView = &views[i];
            }
        }
        if (status == PF_OK && write_count > 0)
            vkUpdateDescriptorSets(cmds->ctx->device, write_count, writes, 0, NULL);
        free(infos);
        free(views);
        free(writes);
        if (status != PF_OK) {
            pf_error_prefix(err, "shader '%s'", pipeline->name);
            return status;
        }
        vkCmdBindDescriptorSets(cmds->command, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline->layout,
                                0, 1, &set, 0, NULL);
    }
    if (push_constant_bytes > 0)
        vkCmdPushConstants(cmds->command, pipeline->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0,
                           push_constant_bytes, push_constants);
    for (uint32_t i = 0; i < buffer_count; i++)
        if (!note_bound(cmds, buffers[i]))
            return pf_error_set(err, PF_ERR_NOMEM, "out of host memory recording a dispatch");
    return PF_OK;
}

pf_status pf_vk_cmd_dispatch(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                             pf_vk_buffer *const *buffers, uint32_t buffer_count,
                             const void *push_constants, uint32_t push_constant_bytes,
                             uint32_t groups_x, uint32_t groups_y, uint32_t groups_z,
                             pf_error *err)
{
    const uint32_t groups[3] = {groups_x, groups_y, groups_z};
    pf_status status = check_dispatch(cmds, pipeline, buffers, buffer_count, push_constants,
                                      push_constant_bytes, groups, err);
    if (status == PF_OK)
        status = bind_for_dispatch(cmds, pipeline, buffers, buffer_count, push_constants,
                                   push_constant_bytes, err);
    if (status != PF_OK)
        return status;
    vkCmdDispatch(cmds->command, groups_x, groups_y, groups_z);
    cmds->device_work++;
    cmds->unordered = 1;
    return PF_OK;
}

pf_status pf_vk_cmd_dispatch_indirect(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                                      pf_vk_buffer *const *buffers, uint32_t buffer_count,
                                      const void *push_constants, uint32_t push_constant_bytes,
                                      pf_vk_buffer *groups, uint64_t offset, pf_error *err)
{
    const uint32_t none[3] = {0, 0, 0};
    pf_status status = check_dispatch(cmds, pipeline, buffers, buffer_count, push_constants,
                                      push_constant_bytes, none, err);
    if (status == PF_OK && (!groups || offset % 4 != 0 || offset + 12 > groups->size))
        status = pf_error_set(err, PF_ERR_INVALID,
                              "shader '%s': indirect dispatch at byte %llu of a %llu-byte buffer",
                              pipeline->name, (unsigned long long)offset,
                              (unsigned long long)(groups ? groups->size : 0));
    if (status == PF_OK)
        status = bind_for_dispatch(cmds, pipeline, buffers, buffer_count, push_constants,
                                   push_constant_bytes, err);
    if (status == PF_OK && !note_bound(cmds, groups))
        status = pf_error_set(err, PF_ERR_NOMEM, "out of host memory recording a dispatch");
    if (status != PF_OK)
        return status;
    vkCmdDispatchIndirect(cmds->command, groups->buffer, offset);
    cmds->device_work++;
    cmds->unordered = 1;
    return PF_OK;
}

void pf_vk_cmd_barrier(pf_vk_commands *cmds)
{
    if (cmds->state != RECORDING)
        return;
    cmds->unordered = 0;
    /* An indirect dispatch's group counts are read at the draw-indirect stage. */
    VkMemoryBarrier barrier = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER,
        .srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT,
        .dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                         VK_ACCESS_INDIRECT_COMMAND_READ_BIT,
    };
    vkCmdPipelineBarrier(cmds->command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT |
                             VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
                         0, 1, &barrier, 0, NULL, 0, NULL);
}

/* Every earlier command's writes before the copies and dispatches after. */
static void copy_barrier(VkCommandBuffer command)
{
    full_barrier(command, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                 VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                     VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT);
}

/* Room for one more recorded copy, zeroed; NULL when out of memory. */
static recorded_copy *add_copy(pf_vk_commands *cmds)
{
    if (cmds->copy_count == cmds->copy_capacity) {
        uint32_t capacity = cmds->copy_capacity ? 2 * cmds->copy_capacity : 8;
        recorded_copy *grown = realloc(cmds->copies, capacity * sizeof *grown);
        if (!grown)
            return NULL;
        cmds->copies = grown;
        cmds->copy_capacity = capacity;
    }
    recorded_copy *copy = &cmds->copies[cmds->copy_count++];
    memset(copy, 0, sizeof *copy);
    return copy;
}

static pf_status record_copy(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t offset,
                             void *host, uint64_t size, int to_device, pf_error *err)
{
    if (cmds->state != RECORDING)
        return pf_error_set(err, PF_ERR_INVALID, "commands already submitted");
    pf_status status = pf_vk_buffer_range_check(buffer, offset, host, size,
                                                to_device ? "upload" : "download", err);
    if (status != PF_OK || size == 0)
        return status;
    pf_vk_context *ctx = cmds->ctx;
    pf_vk_count_copy(ctx, size, to_device);
    /* A mapped buffer no recorded dispatch uses yet: written now, before any command
     * runs, which is where the upload stands. One a recorded dispatch uses is staged, so
     * that the copy lands between that dispatch and the ones after, as on a GPU. */
    int staged = !buffer->mapped || (to_device && is_bound(cmds, buffer));
    if (!staged && to_device) {
        pf_vk_copy(ctx, (char *)buffer->mapped + offset, host, size);
        return PF_OK;
    }
    recorded_copy *copy = add_copy(cmds);
    if (!copy)
        return pf_error_set(err, PF_ERR_NOMEM, "out of host memory recording a copy");
    copy->size = size;
    if (!staged) { /* a download from mapped memory: read once the fence signals */
        copy->host = host;
        copy->source = (const char *)buffer->mapped + offset;
        return PF_OK;
    }
    status = pf_vk_staging_create(ctx, size, to_device, buffer->label, &copy->staging, err);
    if (status != PF_OK) {
        cmds->copy_count--;
        return status;
    }
    if (to_device) {
        pf_vk_copy(ctx, copy->staging.mapped, host, size);
    } else {
        copy->host = host;
        copy->source = copy->staging.mapped;
    }
    VkBufferCopy region = {to_device ? 0 : offset, to_device ? offset : 0, size};
    cmds->device_work++;
    copy_barrier(cmds->command);
    vkCmdCopyBuffer(cmds->command, to_device ? copy->staging.buffer : buffer->buffer,
                    to_device ? buffer->buffer : copy->staging.buffer, 1, &region);
    copy_barrier(cmds->command);
    cmds->unordered = 0;
    return PF_OK;
}

pf_status pf_vk_cmd_upload(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t offset,
                           const void *data, uint64_t size, pf_error *err)
{
    return record_copy(cmds, buffer, offset, (void *)data, size, 1, err);
}

pf_status pf_vk_cmd_download(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t offset,
                             void *data, uint64_t size, pf_error *err)
{
    return record_copy(cmds, buffer, offset, data, size, 0, err);
}

int pf_vk_cmd_timestamp(pf_vk_commands *cmds)
{
    if (cmds->state != RECORDING || !cmds->query_pool ||
        cmds->timestamps_written >= TIMESTAMP_SLOTS)
        return -1;
    uint32_t slot = cmds->timestamps_written++;
    cmds->device_work++;
    /* Bottom of pipe: the stamp is taken once all earlier commands have finished. */
    vkCmdWriteTimestamp(cmds->command, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, cmds->query_pool,
                        slot);
    return (int)slot;
}

pf_status pf_vk_commands_submit_async(pf_vk_commands *cmds, pf_error *err)
{
    if (cmds->state != RECORDING)
        return pf_error_set(err, PF_ERR_INVALID,
                            "commands submitted twice or after a failure (they are single-use)");
    cmds->state = BROKEN;
    pf_vk_context *ctx = cmds->ctx;
    if (cmds->device_work == 0) {
        /* Only mapped copies (lavapipe): nothing for the device to do, no submission; the
         * wait makes the copies. */
        cmds->state = IN_FLIGHT;
        return PF_OK;
    }
    /* Downloads may read mapped memory right after the fence: make writes host-visible. */
    full_barrier(cmds->command, VK_PIPELINE_STAGE_HOST_BIT, VK_ACCESS_HOST_READ_BIT);
    VkResult result = vkEndCommandBuffer(cmds->command);
    if (result != VK_SUCCESS)
        return vulkan_error(cmds, "vkEndCommandBuffer", result, err);
    VkSubmitInfo submit = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO,
        .commandBufferCount = 1,
        .pCommandBuffers = &cmds->command,
    };
    pthread_mutex_lock(&ctx->queue_lock);
    result = vkQueueSubmit(ctx->queue, 1, &submit, cmds->fence);
    pthread_mutex_unlock(&ctx->queue_lock);
    atomic_fetch_add(&ctx->submits, 1);
    if (result != VK_SUCCESS)
        return vulkan_error(cmds, "vkQueueSubmit", result, err);
    cmds->state = IN_FLIGHT;
    atomic_fetch_add(&ctx->in_flight, 1);
    return PF_OK;
}

pf_status pf_vk_commands_wait(pf_vk_commands *cmds, pf_error *err)
{
    if (cmds->state != IN_FLIGHT)
        return pf_error_set(err, PF_ERR_INVALID, "commands waited for before their submission");
    cmds->state = BROKEN;
    pf_vk_context *ctx = cmds->ctx;
    if (cmds->device_work > 0) {
        atomic_fetch_add(&ctx->host_waits, 1);
        /* Not counting itself: another submission still in flight is what this one
         * queued behind. */
        if (atomic_fetch_sub(&ctx->in_flight, 1) > 1)
            atomic_fetch_add(&ctx->waits_behind, 1);
        double wait_start = pf_time_ms();
        VkResult result = vkWaitForFences(ctx->device, 1, &cmds->fence, VK_TRUE, UINT64_MAX);
        pf_vk_time_add(&ctx->wait_ns, wait_start);
        if (result != VK_SUCCESS)
            return vulkan_error(cmds, "vkWaitForFences", result, err);
        if (cmds->timestamps_written > 0) {
            result = vkGetQueryPoolResults(ctx->device, cmds->query_pool, 0,
                                           cmds->timestamps_written, sizeof cmds->timestamps,
                                           cmds->timestamps, sizeof cmds->timestamps[0],
                                           VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
            if (result != VK_SUCCESS)
                return vulkan_error(cmds, "vkGetQueryPoolResults", result, err);
        }
    }
    for (uint32_t i = 0; i < cmds->copy_count; i++)
        if (cmds->copies[i].host)
            pf_vk_copy(ctx, cmds->copies[i].host, cmds->copies[i].source,
                       cmds->copies[i].size);
    cmds->state = SUBMITTED;
    return PF_OK;
}

pf_status pf_vk_commands_submit(pf_vk_commands *cmds, pf_error *err)
{
    pf_status status = pf_vk_commands_submit_async(cmds, err);
    return status == PF_OK ? pf_vk_commands_wait(cmds, err) : status;
}

double pf_vk_commands_elapsed_ms(const pf_vk_commands *cmds, int slot_begin, int slot_end)
{
    if (cmds->state != SUBMITTED || slot_begin < 0 || slot_end < 0 ||
        (uint32_t)slot_begin >= cmds->timestamps_written ||
        (uint32_t)slot_end >= cmds->timestamps_written)
        return -1.0;
    uint32_t valid_bits = cmds->ctx->info.timestamp_valid_bits;
    uint64_t mask = valid_bits >= 64 ? UINT64_MAX : (UINT64_C(1) << valid_bits) - 1;
    /* Masked subtraction stays right when the counter wrapped between the stamps. */
    uint64_t ticks = (cmds->timestamps[slot_end] - cmds->timestamps[slot_begin]) & mask;
    return (double)ticks * (double)cmds->ctx->info.timestamp_period_ns / 1e6;
}

void pf_vk_commands_destroy(pf_vk_commands *cmds)
{
    if (!cmds)
        return;
    VkDevice device = cmds->ctx->device;
    /* Submitted and never waited for (an error between the halves): the device may still
     * run them, and their pool and fence must outlive that. */
    if (cmds->state == IN_FLIGHT && cmds->device_work > 0) {
        vkWaitForFences(device, 1, &cmds->fence, VK_TRUE, UINT64_MAX);
        atomic_fetch_sub(&cmds->ctx->in_flight, 1);
    }
    for (uint32_t i = 0; i < cmds->copy_count; i++)
        pf_vk_staging_destroy(cmds->ctx, &cmds->copies[i].staging);
    free(cmds->copies);
    free(cmds->bound);
    for (uint32_t i = 0; i < cmds->descriptor_pool_count; i++)
        vkDestroyDescriptorPool(device, cmds->descriptor_pools[i].pool, NULL);
    free(cmds->descriptor_pools);
    if (cmds->query_pool)
        vkDestroyQueryPool(device, cmds->query_pool, NULL);
    if (cmds->fence)
        vkDestroyFence(device, cmds->fence, NULL);
    /* Destroying the pool frees its command buffer. */
    vkDestroyCommandPool(device, cmds->command_pool, NULL);
    free(cmds);
}
