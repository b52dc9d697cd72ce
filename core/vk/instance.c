/* Instance, validation layer and its message counter, context lifetime. */
#include "pf_vk_internal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *pf_vk_result_name(VkResult result)
{
    switch (result) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_INCOMPLETE: return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_FRAGMENTED_POOL: return "VK_ERROR_FRAGMENTED_POOL";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    case VK_ERROR_INVALID_SHADER_NV: return "VK_ERROR_INVALID_SHADER_NV";
    default: return "VkResult";
    }
}

static VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT *data, void *user)
{
    (void)types;
    pf_vk_context *ctx = user;
    atomic_fetch_add(&ctx->validation_messages, 1);
    int is_error = (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) != 0;
    pf_log(is_error ? PF_LOG_ERROR : PF_LOG_WARN, "vulkan validation %s [%s]: %s",
           is_error ? "error" : "warning",
           data->pMessageIdName ? data->pMessageIdName : "no id",
           data->pMessage ? data->pMessage : "");
    /* VK_FALSE: the call that triggered the message proceeds, as the spec requires. */
    return VK_FALSE;
}

static void messenger_info(pf_vk_context *ctx, VkDebugUtilsMessengerCreateInfoEXT *info)
{
    *info = (VkDebugUtilsMessengerCreateInfoEXT){
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
        .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
        .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
        .pfnUserCallback = on_validation_message,
        .pUserData = ctx,
    };
}

static int layer_installed(const char *name)
{
    uint32_t count = 0;
    if (vkEnumerateInstanceLayerProperties(&count, NULL) != VK_SUCCESS || count == 0)
        return 0;
    VkLayerProperties *layers = calloc(count, sizeof *layers);
    if (!layers)
        return 0;
    int found = 0;
    if (vkEnumerateInstanceLayerProperties(&count, layers) == VK_SUCCESS) {
        for (uint32_t i = 0; i < count && !found; i++)
            found = !strcmp(layers[i].layerName, name);
    }
    free(layers);
    return found;
}

pf_status pf_vk_instance_create(pf_vk_context *ctx, int validation, pf_error *err)
{
    uint32_t loader_version = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&loader_version) != VK_SUCCESS ||
        loader_version < PF_VK_MIN_API_VERSION)
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "the Vulkan loader supports API %u.%u; photonfarm needs 1.2",
                            VK_API_VERSION_MAJOR(loader_version),
                            VK_API_VERSION_MINOR(loader_version));
    if (validation && !layer_installed(PF_VK_VALIDATION_LAYER))
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "validation was requested but the layer %s is not installed "
                            "(Debian: apt-get install vulkan-validationlayers)",
                            PF_VK_VALIDATION_LAYER);

    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "photonfarm",
        .pEngineName = "photonfarm",
        .apiVersion = PF_VK_MIN_API_VERSION,
    };
    const char *layers[] = {PF_VK_VALIDATION_LAYER};
    const char *extensions[] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME,
                                VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME};
    int sync = validation == PF_VK_VALIDATION_SYNC;
    /* Chained so that instance creation and destruction are reported too. */
    VkDebugUtilsMessengerCreateInfoEXT messenger;
    messenger_info(ctx, &messenger);
    VkValidationFeatureEnableEXT sync_feature =
        VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
    VkValidationFeaturesEXT features = {
        .sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT,
        .pNext = &messenger,
        .enabledValidationFeatureCount = 1,
        .pEnabledValidationFeatures = &sync_feature,
    };
    VkInstanceCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pNext = sync ? (const void *)&features : validation ? (const void *)&messenger : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = validation ? 1 : 0,
        .ppEnabledLayerNames = layers,
        .enabledExtensionCount = sync ? 2 : validation ? 1 : 0,
        .ppEnabledExtensionNames = extensions,
    };
    VkResult result = vkCreateInstance(&info, NULL, &ctx->instance);
    if (result != VK_SUCCESS) {
        ctx->instance = VK_NULL_HANDLE;
        return pf_error_set(err, result == VK_ERROR_INCOMPATIBLE_DRIVER ? PF_ERR_UNSUPPORTED
                                                                        : PF_ERR_VULKAN,
                            "vkCreateInstance failed: %s (%d)%s", pf_vk_result_name(result),
                            (int)result,
                            result == VK_ERROR_INCOMPATIBLE_DRIVER
                                ? ": no Vulkan driver is installed (Debian: mesa-vulkan-drivers)"
                                : "");
    }
    ctx->validation = validation;
    if (validation) {
        PFN_vkCreateDebugUtilsMessengerEXT create_messenger =
            (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                ctx->instance, "vkCreateDebugUtilsMessengerEXT");
        result = create_messenger
                     ? create_messenger(ctx->instance, &messenger, NULL, &ctx->messenger)
                     : VK_ERROR_EXTENSION_NOT_PRESENT;
        if (result != VK_SUCCESS) {
            vkDestroyInstance(ctx->instance, NULL);
            ctx->instance = VK_NULL_HANDLE;
            return pf_error_set(err, PF_ERR_VULKAN,
                                "vkCreateDebugUtilsMessengerEXT failed: %s (%d)",
                                pf_vk_result_name(result), (int)result);
        }
    }
    return PF_OK;
}

void pf_vk_instance_destroy(pf_vk_context *ctx)
{
    if (ctx->messenger) {
        PFN_vkDestroyDebugUtilsMessengerEXT destroy_messenger =
            (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                ctx->instance, "vkDestroyDebugUtilsMessengerEXT");
        if (destroy_messenger)
            destroy_messenger(ctx->instance, ctx->messenger, NULL);
        ctx->messenger = VK_NULL_HANDLE;
    }
    if (ctx->instance)
        vkDestroyInstance(ctx->instance, NULL);
    ctx->instance = VK_NULL_HANDLE;
}

pf_status pf_vk_create(const pf_vk_options *options, pf_vk_context **out, pf_error *err)
{
    *out = NULL;
    /* Core reads no environment: the CLI maps $PHOTONFARM_DEVICE and
     * $PF_VK_VALIDATION to these options in one place (worker/cli_environment.c). */
    int validation = options ? options->validation : 0;
    const char *selector = options ? options->device_selector : NULL;

    pf_vk_context *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return pf_error_set(err, PF_ERR_NOMEM, "out of memory for the Vulkan context");
    atomic_init(&ctx->validation_messages, 0);
    if (pthread_mutex_init(&ctx->queue_lock, NULL) != 0) {
        free(ctx);
        return pf_error_set(err, PF_ERR_INTERNAL, "pthread_mutex_init failed");
    }
    if (pthread_mutex_init(&ctx->cache.lock, NULL) != 0) {
        pthread_mutex_destroy(&ctx->queue_lock);
        free(ctx);
        return pf_error_set(err, PF_ERR_INTERNAL, "pthread_mutex_init failed");
    }
    if (pthread_mutex_init(&ctx->view_lock, NULL) != 0) {
        pthread_mutex_destroy(&ctx->cache.lock);
        pthread_mutex_destroy(&ctx->queue_lock);
        free(ctx);
        return pf_error_set(err, PF_ERR_INTERNAL, "pthread_mutex_init failed");
    }
    if (pthread_mutex_init(&ctx->kept_lock, NULL) != 0) {
        pthread_mutex_destroy(&ctx->view_lock);
        pthread_mutex_destroy(&ctx->cache.lock);
        pthread_mutex_destroy(&ctx->queue_lock);
        free(ctx);
        return pf_error_set(err, PF_ERR_INTERNAL, "pthread_mutex_init failed");
    }
    pf_status status = pf_vk_instance_create(ctx, validation, err);
    if (status == PF_OK)
        status = pf_vk_device_open(ctx, selector, err);
    if (status == PF_OK)
        status = pf_vk_pipeline_cache_open(ctx, options ? options->pipeline_cache_dir : NULL, err);
    if (status != PF_OK) {
        pf_vk_destroy(ctx);
        return status;
    }
    *out = ctx;
    return PF_OK;
}

void pf_vk_destroy(pf_vk_context *ctx)
{
    if (!ctx)
        return;
    if (ctx->device)
        pf_vk_pipeline_cache_close(ctx);
    pf_vk_device_close(ctx);
    pf_vk_instance_destroy(ctx);
    pthread_mutex_destroy(&ctx->kept_lock);
    pthread_mutex_destroy(&ctx->view_lock);
    pthread_mutex_destroy(&ctx->cache.lock);
    pthread_mutex_destroy(&ctx->queue_lock);
    free(ctx);
}

const pf_vk_device_info *pf_vk_info(const pf_vk_context *ctx) { return &ctx->info; }

int pf_vk_device_is_cpu(const pf_vk_context *ctx) { return strcmp(ctx->info.type, "cpu") == 0; }

int pf_vk_storage_is_host_memory(const pf_vk_context *ctx)
{
    return pf_vk_device_is_cpu(ctx) && !ctx->force_staging;
}

int pf_vk_validation_enabled(const pf_vk_context *ctx) { return ctx->validation; }

uint32_t pf_vk_validation_message_count(const pf_vk_context *ctx)
{
    return atomic_load(&ctx->validation_messages);
}

void pf_vk_force_staging(pf_vk_context *ctx, int on) { ctx->force_staging = on; }
