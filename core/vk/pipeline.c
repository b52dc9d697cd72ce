/* Compute pipelines from SPIR-V: layout (storage buffers + push constants), spec constants. */
#include "pf_vk_internal.h"

#include "pf_shaders.h"

#include <stdio.h>
#include <stdlib.h>


static pf_status check_desc(const pf_vk_context *ctx, const pf_vk_pipeline_desc *desc,
                            pf_error *err)
{
    const char *name = desc->name;
    if (!desc->spirv || desc->spirv_bytes < PF_SPIRV_HEADER_WORDS * 4 || desc->spirv_bytes % 4 ||
        desc->spirv[0] != PF_SPIRV_MAGIC)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "shader '%s': %zu bytes are not a SPIR-V module (need a multiple "
                            "of 4 bytes starting with magic 0x%08x)",
                            name, desc->spirv_bytes, PF_SPIRV_MAGIC);
    if (desc->push_constant_bytes % 4 ||
        desc->push_constant_bytes > ctx->info.max_push_constant_bytes)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "shader '%s': %u push-constant bytes (must be a multiple of 4 "
                            "and at most maxPushConstantsSize %u of device '%s')",
                            name, desc->push_constant_bytes, ctx->info.max_push_constant_bytes,
                            ctx->info.name);
    if (desc->spec_constant_count && !desc->spec_constants)
        return pf_error_set(err, PF_ERR_INVALID, "shader '%s': %u spec constants but no array",
                            name, desc->spec_constant_count);
    return PF_OK;
}

/* The device's per-stage descriptor limits, checked once the module's binding kinds are known:
 * storage buffers and uniform texel buffers (sampled images) count against separate limits,
 * bindings the module does not read against none. */
static pf_status check_descriptor_limits(pf_vk_context *ctx, const char *name,
                                         const uint8_t *kinds, uint32_t count, pf_error *err)
{
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(ctx->physical_device, &properties);
    uint32_t storage = 0, texel = 0;
    for (uint32_t i = 0; i < count; i++) {
        if (kinds[i] == PF_VK_BINDING_STORAGE)
            storage++;
        else if (kinds[i] != PF_VK_BINDING_ABSENT)
            texel++;
    }
    const VkPhysicalDeviceLimits *limits = &properties.limits;
    if (storage > limits->maxPerStageDescriptorStorageBuffers)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "shader '%s': %u storage buffers exceed "
                            "maxPerStageDescriptorStorageBuffers %u of device '%s'",
                            name, storage, limits->maxPerStageDescriptorStorageBuffers,
                            ctx->info.name);
    if (texel > limits->maxPerStageDescriptorSampledImages)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "shader '%s': %u texel buffers exceed "
                            "maxPerStageDescriptorSampledImages %u of device '%s'",
                            name, texel, limits->maxPerStageDescriptorSampledImages,
                            ctx->info.name);
    if (storage + texel > limits->maxPerStageResources)
        return pf_error_set(err, PF_ERR_LIMIT,
                            "shader '%s': %u bindings exceed maxPerStageResources %u of device "
                            "'%s'",
                            name, storage + texel, limits->maxPerStageResources, ctx->info.name);
    return PF_OK;
}

pf_status pf_vk_pipeline_create(pf_vk_context *ctx, const pf_vk_pipeline_desc *desc,
                                pf_vk_pipeline **out, pf_error *err)
{
    *out = NULL;
    pf_vk_pipeline_desc checked = *desc;
    if (!checked.name)
        checked.name = "unnamed";
    pf_status status = check_desc(ctx, &checked, err);
    if (status != PF_OK)
        return status;
    pf_vk_pipeline *pipeline = calloc(1, sizeof *pipeline);
    VkDescriptorSetLayoutBinding *bindings =
        calloc(checked.buffer_count ? checked.buffer_count : 1, sizeof *bindings);
    /* The pipeline's own constants, then PF_VK_SPEC_DIVIDE_REFINE. */
    uint32_t constant_count = checked.spec_constant_count + 1;
    VkSpecializationMapEntry *entries = calloc(constant_count, sizeof *entries);
    uint32_t *values = calloc(constant_count, sizeof *values);
    if (!pipeline || !bindings || !entries || !values) {
        free(pipeline);
        free(bindings);
        free(entries);
        free(values);
        return pf_error_set(err, PF_ERR_NOMEM, "shader '%s': out of host memory", checked.name);
    }
    snprintf(pipeline->name, sizeof pipeline->name, "%s", checked.name);
    pipeline->buffer_count = checked.buffer_count;
    pipeline->push_constant_bytes = checked.push_constant_bytes;
    pipeline->binding_kinds = calloc(checked.buffer_count ? checked.buffer_count : 1, 1);
    status = pipeline->binding_kinds
                 ? pf_vk_spirv_binding_kinds(checked.spirv, checked.spirv_bytes / 4,
                                             pipeline->binding_kinds, checked.buffer_count, err)
                 : pf_error_set(err, PF_ERR_NOMEM, "shader '%s': out of host memory",
                                checked.name);
    if (status == PF_OK)
        status = check_descriptor_limits(ctx, checked.name, pipeline->binding_kinds,
                                         checked.buffer_count, err);
    if (status != PF_OK) {
        pf_error_prefix(err, "shader '%s'", checked.name);
        pf_vk_pipeline_destroy(ctx, pipeline);
        free(bindings);
        free(entries);
        free(values);
        return status;
    }

    /* Where the device can keep subnormals, every module asks it to (spirv_denormals.c). */
    uint32_t *patched = NULL;
    size_t patched_words = 0;
    if (ctx->info.has_denorm_preserve) {
        status = pf_vk_spirv_preserve_denormals(checked.spirv, checked.spirv_bytes / 4, &patched,
                                                &patched_words, err);
        if (status != PF_OK) {
            pf_vk_pipeline_destroy(ctx, pipeline);
            free(bindings);
            free(entries);
            free(values);
            return status;
        }
    }
    const char *failed_call = "vkCreateShaderModule";
    VkShaderModuleCreateInfo module_info = {
        .sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO,
        .codeSize = patched ? patched_words * 4 : checked.spirv_bytes,
        .pCode = patched ? patched : checked.spirv,
    };
    VkShaderModule module;
    VkResult result = vkCreateShaderModule(ctx->device, &module_info, NULL, &module);
    free(patched);
    /* Handles are stored only on success: a failed call leaves its output undefined. */
    if (result == VK_SUCCESS)
        pipeline->module = module;

    if (result == VK_SUCCESS) {
        uint32_t present = 0;
        for (uint32_t i = 0; i < checked.buffer_count; i++) {
            if (pipeline->binding_kinds[i] == PF_VK_BINDING_ABSENT)
                continue;
            bindings[present++] = (VkDescriptorSetLayoutBinding){
                .binding = i,
                .descriptorType = pf_vk_descriptor_type(pipeline->binding_kinds[i]),
                .descriptorCount = 1,
                .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT,
            };
        }
        VkDescriptorSetLayoutCreateInfo set_info = {
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
            .bindingCount = present,
            .pBindings = bindings,
        };
        failed_call = "vkCreateDescriptorSetLayout";
        VkDescriptorSetLayout set_layout;
        result = vkCreateDescriptorSetLayout(ctx->device, &set_info, NULL, &set_layout);
        if (result == VK_SUCCESS)
            pipeline->set_layout = set_layout;
    }
    if (result == VK_SUCCESS) {
        VkPushConstantRange push = {
            .stageFlags = VK_SHADER_STAGE_COMPUTE_BIT,
            .size = checked.push_constant_bytes,
        };
        VkPipelineLayoutCreateInfo layout_info = {
            .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
            .setLayoutCount = 1,
            .pSetLayouts = &pipeline->set_layout,
            .pushConstantRangeCount = checked.push_constant_bytes ? 1 : 0,
            .pPushConstantRanges = &push,
        };
        failed_call = "vkCreatePipelineLayout";
        VkPipelineLayout layout;
        result = vkCreatePipelineLayout(ctx->device, &layout_info, NULL, &layout);
        if (result == VK_SUCCESS)
            pipeline->layout = layout;
    }
    if (result == VK_SUCCESS) {
        for (uint32_t i = 0; i < constant_count; i++) {
            int own = i < checked.spec_constant_count;
            values[i] = own ? checked.spec_constants[i].value : !ctx->exact_division;
            entries[i] = (VkSpecializationMapEntry){
                .constantID = own ? checked.spec_constants[i].constant_id
                                  : PF_VK_SPEC_DIVIDE_REFINE,
                .offset = i * (uint32_t)sizeof *values,
                .size = sizeof *values,
            };
        }
        VkSpecializationInfo specialization = {
            .mapEntryCount = constant_count,
            .pMapEntries = entries,
            .dataSize = constant_count * sizeof *values,
            .pData = values,
        };
        VkComputePipelineCreateInfo pipeline_info = {
            .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
            .stage = {
                .sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                .module = pipeline->module,
                .pName = "main",
                .pSpecializationInfo = &specialization,
            },
            .layout = pipeline->layout,
        };
        VkPipelineCreationFeedback feedback = {0}, stage_feedback = {0};
        VkPipelineCreationFeedbackCreateInfo feedback_info = {
            .sType = VK_STRUCTURE_TYPE_PIPELINE_CREATION_FEEDBACK_CREATE_INFO,
            .pPipelineCreationFeedback = &feedback,
            .pipelineStageCreationFeedbackCount = 1,
            .pPipelineStageCreationFeedbacks = &stage_feedback,
        };
        if (ctx->has_creation_feedback)
            pipeline_info.pNext = &feedback_info;
        failed_call = "vkCreateComputePipelines";
        VkPipeline handle;
        result = vkCreateComputePipelines(ctx->device, ctx->cache.handle, 1, &pipeline_info, NULL,
                                          &handle);
        if (result == VK_SUCCESS) {
            pipeline->pipeline = handle;
            const VkPipelineCreationFeedbackFlags hit =
                VK_PIPELINE_CREATION_FEEDBACK_VALID_BIT |
                VK_PIPELINE_CREATION_FEEDBACK_APPLICATION_PIPELINE_CACHE_HIT_BIT;
            pf_vk_pipeline_cache_note(ctx, (feedback.flags & hit) == hit);
        }
    }
    free(bindings);
    free(entries);
    free(values);
    if (result != VK_SUCCESS) {
        pf_vk_pipeline_destroy(ctx, pipeline);
        return pf_error_set(err, PF_ERR_VULKAN, "shader '%s': %s failed on '%s': %s (%d)",
                            checked.name, failed_call, ctx->info.name, pf_vk_result_name(result),
                            (int)result);
    }
    *out = pipeline;
    return PF_OK;
}

pf_status pf_vk_pipeline_create_named(pf_vk_context *ctx, const char *shader_name,
                                      uint32_t buffer_count, uint32_t push_constant_bytes,
                                      const pf_vk_spec_constant *spec_constants,
                                      uint32_t spec_constant_count, pf_vk_pipeline **out,
                                      pf_error *err)
{
    *out = NULL;
    const pf_shader_blob *blob = pf_shader_find(shader_name);
    if (!blob)
        return pf_error_set(err, PF_ERR_INVALID,
                            "no embedded shader named '%s' (expected shaders/%s.comp)",
                            shader_name ? shader_name : "(null)",
                            shader_name ? shader_name : "(null)");
    pf_vk_pipeline_desc desc = {
        .name = blob->name,
        .spirv = blob->words,
        .spirv_bytes = blob->bytes,
        .buffer_count = buffer_count,
        .push_constant_bytes = push_constant_bytes,
        .spec_constants = spec_constants,
        .spec_constant_count = spec_constant_count,
    };
    return pf_vk_pipeline_create(ctx, &desc, out, err);
}

void pf_vk_pipeline_destroy(pf_vk_context *ctx, pf_vk_pipeline *pipeline)
{
    if (!pipeline)
        return;
    if (pipeline->pipeline)
        vkDestroyPipeline(ctx->device, pipeline->pipeline, NULL);
    if (pipeline->layout)
        vkDestroyPipelineLayout(ctx->device, pipeline->layout, NULL);
    if (pipeline->set_layout)
        vkDestroyDescriptorSetLayout(ctx->device, pipeline->set_layout, NULL);
    if (pipeline->module)
        vkDestroyShaderModule(ctx->device, pipeline->module, NULL);
    free(pipeline->binding_kinds);
    free(pipeline);
}
