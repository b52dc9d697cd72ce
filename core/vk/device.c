/* Physical device description, enumeration, choice, logical device + compute queue. */
#include "pf_vk_internal.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *type_name(VkPhysicalDeviceType type)
{
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
    }
}

/* Automatic choice: a real GPU first (discrete > integrated > virtual), then the CPU. */
static int type_rank(const char *type)
{
    static const char *const preference[] = {"discrete", "integrated", "virtual", "cpu"};
    int count = (int)(sizeof preference / sizeof preference[0]);
    for (int i = 0; i < count; i++) {
        if (!strcmp(type, preference[i]))
            return count - i;
    }
    return 0;
}

void pf_vk_describe_device(VkPhysicalDevice physical_device, uint32_t index,
                           pf_vk_device_info *info, uint32_t *compute_family)
{
    memset(info, 0, sizeof *info);
    VkPhysicalDeviceProperties basic;
    vkGetPhysicalDeviceProperties(physical_device, &basic);
    int is_1_2 = basic.apiVersion >= PF_VK_MIN_API_VERSION;

    /* Vulkan 1.1 structures are always valid here; the 1.2 ones only on a 1.2 device. */
    VkPhysicalDeviceVulkan12Properties properties12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_PROPERTIES};
    VkPhysicalDeviceDriverProperties driver = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES, .pNext = &properties12};
    VkPhysicalDeviceSubgroupProperties subgroup = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES,
        .pNext = is_1_2 ? &driver : NULL};
    VkPhysicalDeviceProperties2 properties = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &subgroup};
    vkGetPhysicalDeviceProperties2(physical_device, &properties);

    VkPhysicalDeviceVulkan12Features features12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceFeatures2 features = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                          .pNext = is_1_2 ? &features12 : NULL};
    vkGetPhysicalDeviceFeatures2(physical_device, &features);

    const VkPhysicalDeviceLimits *limits = &properties.properties.limits;
    info->index = index;
    snprintf(info->name, sizeof info->name, "%s", properties.properties.deviceName);
    snprintf(info->type, sizeof info->type, "%s", type_name(properties.properties.deviceType));
    if (is_1_2)
        /* Both halves bounded so that "name info" always fits the 256-byte field. */
        snprintf(info->driver, sizeof info->driver, "%.127s %.127s", driver.driverName,
                 driver.driverInfo);
    else
        snprintf(info->driver, sizeof info->driver, "unknown (driver version 0x%x)",
                 properties.properties.driverVersion);
    info->vendor_id = properties.properties.vendorID;
    info->device_id = properties.properties.deviceID;
    info->api_version = properties.properties.apiVersion;
    /* Every buffer may also be bound as an R32 texel view (spirv_bindings.c),
     * so the usable range is the lesser of the two limits: where a driver
     * allows 4 GiB storage buffers but 2^27 texels, 512 MiB; on lavapipe
     * the storage limit, 128 MiB. */
    uint64_t texel_bytes = 4ull * limits->maxTexelBufferElements;
    info->max_storage_buffer_range = limits->maxStorageBufferRange < texel_bytes
                                         ? limits->maxStorageBufferRange
                                         : texel_bytes;
    info->max_workgroup_invocations = limits->maxComputeWorkGroupInvocations;
    for (int axis = 0; axis < 3; axis++) {
        info->max_workgroup_size[axis] = limits->maxComputeWorkGroupSize[axis];
        info->max_workgroup_count[axis] = limits->maxComputeWorkGroupCount[axis];
    }
    info->max_shared_memory_bytes = limits->maxComputeSharedMemorySize;
    info->max_push_constant_bytes = limits->maxPushConstantsSize;
    info->subgroup_size = subgroup.subgroupSize;
    info->timestamp_period_ns = limits->timestampPeriod;
    info->has_int64 = features.features.shaderInt64 != VK_FALSE;
    info->has_int64_atomics = is_1_2 && features12.shaderBufferInt64Atomics != VK_FALSE;
    info->has_denorm_preserve =
        is_1_2 && properties12.shaderDenormPreserveFloat32 != VK_FALSE &&
        properties12.denormBehaviorIndependence != VK_SHADER_FLOAT_CONTROLS_INDEPENDENCE_NONE;

    VkPhysicalDeviceMemoryProperties memory;
    vkGetPhysicalDeviceMemoryProperties(physical_device, &memory);
    for (uint32_t heap = 0; heap < memory.memoryHeapCount; heap++) {
        if ((memory.memoryHeaps[heap].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) &&
            memory.memoryHeaps[heap].size > info->device_local_bytes)
            info->device_local_bytes = memory.memoryHeaps[heap].size;
    }

    /* The first compute-capable family: on GPUs the universal queue, whose
     * timestamps are the most widely supported. */
    uint32_t family_count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical_device, &family_count, NULL);
    VkQueueFamilyProperties *families = calloc(family_count ? family_count : 1, sizeof *families);
    *compute_family = UINT32_MAX;
    if (families) {
        vkGetPhysicalDeviceQueueFamilyProperties(physical_device, &family_count, families);
        for (uint32_t family = 0; family < family_count; family++) {
            if (families[family].queueFlags & VK_QUEUE_COMPUTE_BIT) {
                *compute_family = family;
                info->timestamp_valid_bits = families[family].timestampValidBits;
                break;
            }
        }
        free(families);
    }
}

static int has_device_extension(VkPhysicalDevice physical_device, const char *name)
{
    uint32_t count = 0;
    if (vkEnumerateDeviceExtensionProperties(physical_device, NULL, &count, NULL) != VK_SUCCESS)
        return 0;
    VkExtensionProperties *properties = calloc(count ? count : 1, sizeof *properties);
    int found = 0;
    if (properties &&
        vkEnumerateDeviceExtensionProperties(physical_device, NULL, &count, properties) ==
            VK_SUCCESS) {
        for (uint32_t i = 0; i < count && !found; i++)
            found = strcmp(properties[i].extensionName, name) == 0;
    }
    free(properties);
    return found;
}

/* Physical devices of ctx->instance with their descriptions; *handles and *infos are malloc'ed. */
static pf_status list_devices(VkInstance instance, VkPhysicalDevice **handles,
                              pf_vk_device_info **infos, uint32_t **families, uint32_t *count,
                              pf_error *err)
{
    *handles = NULL;
    *infos = NULL;
    *families = NULL;
    *count = 0;
    uint32_t device_count = 0;
    VkResult result = vkEnumeratePhysicalDevices(instance, &device_count, NULL);
    if (result != VK_SUCCESS)
        return pf_error_set(err, PF_ERR_VULKAN, "vkEnumeratePhysicalDevices failed: %s (%d)",
                            pf_vk_result_name(result), (int)result);
    if (device_count == 0)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "no Vulkan device found (Debian: mesa-vulkan-drivers provides "
                            "the CPU device lavapipe)");
    VkPhysicalDevice *device_handles = calloc(device_count, sizeof *device_handles);
    pf_vk_device_info *device_infos = calloc(device_count, sizeof *device_infos);
    uint32_t *device_families = calloc(device_count, sizeof *device_families);
    if (!device_handles || !device_infos || !device_families) {
        free(device_handles);
        free(device_infos);
        free(device_families);
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory listing %u Vulkan devices",
                            device_count);
    }
    result = vkEnumeratePhysicalDevices(instance, &device_count, device_handles);
    if (result != VK_SUCCESS && result != VK_INCOMPLETE) {
        free(device_handles);
        free(device_infos);
        free(device_families);
        return pf_error_set(err, PF_ERR_VULKAN, "vkEnumeratePhysicalDevices failed: %s (%d)",
                            pf_vk_result_name(result), (int)result);
    }
    for (uint32_t i = 0; i < device_count; i++)
        pf_vk_describe_device(device_handles[i], i, &device_infos[i], &device_families[i]);
    *handles = device_handles;
    *infos = device_infos;
    *families = device_families;
    *count = device_count;
    return PF_OK;
}

pf_status pf_vk_enumerate(pf_vk_device_info **devices, uint32_t *count, pf_error *err)
{
    *devices = NULL;
    *count = 0;
    /* A throwaway instance without validation: listing devices is a pure query. */
    pf_vk_context scratch;
    memset(&scratch, 0, sizeof scratch);
    pf_status status = pf_vk_instance_create(&scratch, 0, err);
    if (status != PF_OK)
        return status;
    VkPhysicalDevice *handles;
    uint32_t *families;
    status = list_devices(scratch.instance, &handles, devices, &families, count, err);
    if (status == PF_OK) {
        free(handles);
        free(families);
    }
    pf_vk_instance_destroy(&scratch);
    return status;
}

static int usable(const pf_vk_device_info *info, uint32_t compute_family)
{
    return info->api_version >= PF_VK_MIN_API_VERSION && compute_family != UINT32_MAX;
}

static int contains_ignoring_case(const char *haystack, const char *needle)
{
    size_t needle_length = strlen(needle);
    for (const char *start = haystack; *start; start++) {
        size_t i = 0;
        while (i < needle_length && start[i] &&
               tolower((unsigned char)start[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == needle_length)
            return 1;
    }
    return 0;
}

static int is_decimal(const char *text)
{
    if (!*text)
        return 0;
    for (; *text; text++) {
        if (!isdigit((unsigned char)*text))
            return 0;
    }
    return 1;
}

static void append_device_list(pf_error *err, const pf_vk_device_info *infos, uint32_t count)
{
    if (!err)
        return;
    size_t used = strlen(err->message);
    for (uint32_t i = 0; i < count && used < sizeof err->message; i++) {
        int written = snprintf(err->message + used, sizeof err->message - used, "%s%u: %s (%s)",
                               i ? ", " : "; available devices: ", infos[i].index,
                               infos[i].name, infos[i].type);
        if (written < 0)
            break;
        used += (size_t)written;
    }
}

/* Index into infos of the device selector names, or of the automatic choice. */
static pf_status choose(const char *selector, const pf_vk_device_info *infos,
                        const uint32_t *families, uint32_t count, uint32_t *chosen,
                        pf_error *err)
{
    if (!selector || !*selector) {
        int best_rank = -1;
        for (uint32_t i = 0; i < count; i++) {
            if (usable(&infos[i], families[i]) && type_rank(infos[i].type) > best_rank) {
                best_rank = type_rank(infos[i].type);
                *chosen = i;
            }
        }
        if (best_rank < 0) {
            pf_error_set(err, PF_ERR_UNSUPPORTED,
                         "no Vulkan device offers API 1.2 and a compute queue");
            append_device_list(err, infos, count);
            return PF_ERR_UNSUPPORTED;
        }
        return PF_OK;
    }

    int found = 0;
    if (is_decimal(selector)) {
        unsigned long index = strtoul(selector, NULL, 10);
        if (index < count) {
            *chosen = (uint32_t)index;
            found = 1;
        }
    } else {
        /* The first match in list order: an index picks among identical GPUs. */
        for (uint32_t i = 0; i < count && !found; i++) {
            if (contains_ignoring_case(infos[i].name, selector)) {
                *chosen = i;
                found = 1;
            }
        }
    }
    if (!found) {
        pf_error_set(err, PF_ERR_INVALID,
                     "device selector '%s' (an index or a case-insensitive name substring) "
                     "matches no Vulkan device",
                     selector);
        append_device_list(err, infos, count);
        return PF_ERR_INVALID;
    }
    if (!usable(&infos[*chosen], families[*chosen]))
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "device %u '%s' has Vulkan %u.%u%s; photonfarm needs 1.2 and a "
                            "compute queue",
                            *chosen, infos[*chosen].name,
                            VK_API_VERSION_MAJOR(infos[*chosen].api_version),
                            VK_API_VERSION_MINOR(infos[*chosen].api_version),
                            families[*chosen] == UINT32_MAX ? " and no compute queue" : "");
    return PF_OK;
}

pf_status pf_vk_device_open(pf_vk_context *ctx, const char *selector, pf_error *err)
{
    VkPhysicalDevice *handles;
    pf_vk_device_info *infos;
    uint32_t *families;
    uint32_t count;
    pf_status status = list_devices(ctx->instance, &handles, &infos, &families, &count, err);
    if (status != PF_OK)
        return status;
    uint32_t chosen = 0;
    status = choose(selector, infos, families, count, &chosen, err);
    if (status == PF_OK) {
        ctx->physical_device = handles[chosen];
        ctx->info = infos[chosen];
        ctx->queue_family = families[chosen];
        ctx->exact_division = strncmp(ctx->info.driver, "llvmpipe", 8) == 0;
    }
    free(handles);
    free(infos);
    free(families);
    if (status != PF_OK)
        return status;
    vkGetPhysicalDeviceMemoryProperties(ctx->physical_device, &ctx->memory_properties);
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(ctx->physical_device, &properties);
    ctx->max_texel_buffer_elements = properties.limits.maxTexelBufferElements;

    /* Features later stages rely on, enabled whenever the device has them. */
    VkPhysicalDeviceVulkan12Features features12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
        .shaderBufferInt64Atomics = ctx->info.has_int64_atomics ? VK_TRUE : VK_FALSE,
    };
    VkPhysicalDeviceFeatures2 features = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
        .pNext = &features12,
        .features = {.shaderInt64 = ctx->info.has_int64 ? VK_TRUE : VK_FALSE},
    };
    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
        .queueFamilyIndex = ctx->queue_family,
        .queueCount = 1,
        .pQueuePriorities = &priority,
    };
    /* Pipeline-creation feedback tells whether a pipeline came from the cache. */
    const char *extensions[1];
    uint32_t extension_count = 0;
    if (has_device_extension(ctx->physical_device, VK_EXT_PIPELINE_CREATION_FEEDBACK_EXTENSION_NAME)) {
        extensions[extension_count++] = VK_EXT_PIPELINE_CREATION_FEEDBACK_EXTENSION_NAME;
        ctx->has_creation_feedback = 1;
    }
    VkDeviceCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .pNext = &features,
        .queueCreateInfoCount = 1,
        .pQueueCreateInfos = &queue,
        .enabledExtensionCount = extension_count,
        .ppEnabledExtensionNames = extensions,
    };
    VkResult result = vkCreateDevice(ctx->physical_device, &info, NULL, &ctx->device);
    if (result != VK_SUCCESS) {
        ctx->device = VK_NULL_HANDLE;
        return pf_error_set(err, PF_ERR_VULKAN, "vkCreateDevice on '%s' failed: %s (%d)",
                            ctx->info.name, pf_vk_result_name(result), (int)result);
    }
    vkGetDeviceQueue(ctx->device, ctx->queue_family, 0, &ctx->queue);

    VkCommandPoolCreateInfo pool = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT,
        .queueFamilyIndex = ctx->queue_family,
    };
    result = vkCreateCommandPool(ctx->device, &pool, NULL, &ctx->transfer_pool);
    if (result != VK_SUCCESS) {
        ctx->transfer_pool = VK_NULL_HANDLE;
        return pf_error_set(err, PF_ERR_VULKAN, "vkCreateCommandPool on '%s' failed: %s (%d)",
                            ctx->info.name, pf_vk_result_name(result), (int)result);
    }
    pf_log(PF_LOG_DEBUG, "vulkan: using device %u '%s' (%s, %s)%s", ctx->info.index,
           ctx->info.name, ctx->info.type, ctx->info.driver,
           ctx->validation ? " with validation" : "");
    return PF_OK;
}

void pf_vk_device_close(pf_vk_context *ctx)
{
    if (!ctx->device)
        return;
    vkDeviceWaitIdle(ctx->device);
    pf_vk_kept_release(ctx);
    if (ctx->transfer_pool)
        vkDestroyCommandPool(ctx->device, ctx->transfer_pool, NULL);
    ctx->transfer_pool = VK_NULL_HANDLE;
    vkDestroyDevice(ctx->device, NULL);
    ctx->device = VK_NULL_HANDLE;
}
