/*
 * How textures should reach the kernels (issue 38: "measured on lavapipe and
 * documented"): the renderer's texel buffer with filtering in GLSL
 * (shaders/common/scene_textures.glsl) against a sampled image with the
 * sampler's own filtering and sRGB decode. An array of image descriptors
 * indexed per lane needs shaderSampledImageArrayNonUniformIndexing, which
 * lavapipe 22.3 does not offer (printed), so the images are the layers of one
 * array image, as a renderer would bin same-sized textures.
 *
 * 64 textures of EDGE² RGBA8 sRGB texels with their mip chains, the same
 * texels on both paths. Each of INVOCATIONS invocations takes 16 bilinear
 * samples at random uvs (repeat wrap) and levels 0-3, of a texture picked per
 * lane ("divergent": a ray's hits) or per workgroup ("coherent"). Prints the
 * best of REPEATS dispatches per path and pattern, ns per sample, the ratio,
 * and how far the two paths' sums differ (they must agree: the same texels,
 * the same filter).
 *
 * Its own Vulkan device: core/vk binds buffers only (DESIGN.md §3), and an
 * image path that only a benchmark uses does not belong there.
 *
 *   texture_fetch_bench [EDGE]   (default 256)
 */
#include "pf_shaders.h" /* pf_bench_texture_shaders: this directory's kernels */

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <vulkan/vulkan.h>

#define TEXTURES 64u
#define INVOCATIONS (64u * 8192u)
#define FETCHES 16u
#define REPEATS 5
#define PATHS 3

static const char *const path_labels[PATHS] = {"texel buffer, sRGB formula",
                                               "texel buffer, sRGB table",
                                               "array image, sampler"};

#define CHECK(call)                                                                          \
    do {                                                                                     \
        VkResult result_ = (call);                                                           \
        if (result_ != VK_SUCCESS) {                                                         \
            fprintf(stderr, "texture_fetch_bench: %s failed (%d)\n", #call, (int)result_);    \
            exit(1);                                                                         \
        }                                                                                    \
    } while (0)

typedef struct bench {
    VkInstance instance;
    VkPhysicalDevice physical;
    VkDevice device;
    VkQueue queue;
    uint32_t family;
    VkCommandPool pool;
    VkPhysicalDeviceMemoryProperties memory;
    VkBool32 nonuniform_images; /* an image array indexed per lane (descriptor indexing) */
} bench;

typedef struct push {
    uint32_t textures, edge, levels, divergent;
} push;

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

static uint32_t memory_type(const bench *b, uint32_t bits, VkMemoryPropertyFlags flags)
{
    for (uint32_t i = 0; i < b->memory.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (b->memory.memoryTypes[i].propertyFlags & flags) == flags)
            return i;
    fprintf(stderr, "texture_fetch_bench: no memory type with flags 0x%x\n", (unsigned)flags);
    exit(1);
}

static VkDeviceMemory allocate(const bench *b, VkMemoryRequirements req,
                               VkMemoryPropertyFlags flags)
{
    VkMemoryAllocateInfo info = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size,
                                 memory_type(b, req.memoryTypeBits, flags)};
    VkDeviceMemory memory;
    CHECK(vkAllocateMemory(b->device, &info, NULL, &memory));
    return memory;
}

/* A host-visible buffer (lavapipe's memory is all host memory; a GPU reads it over PCIe,
 * which this comparison of fetch paths does not need to be fair to). */
static VkBuffer host_buffer(const bench *b, VkDeviceSize size, VkBufferUsageFlags usage,
                            VkDeviceMemory *memory, void **mapped)
{
    VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage;
    VkBuffer buffer;
    CHECK(vkCreateBuffer(b->device, &info, NULL, &buffer));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(b->device, buffer, &req);
    *memory = allocate(b, req,
                       VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    CHECK(vkBindBufferMemory(b->device, buffer, *memory, 0));
    CHECK(vkMapMemory(b->device, *memory, 0, VK_WHOLE_SIZE, 0, mapped));
    return buffer;
}

static void bench_init(bench *b)
{
    memset(b, 0, sizeof *b);
    VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "texture_fetch_bench";
    app.apiVersion = VK_API_VERSION_1_2;
    VkInstanceCreateInfo instance = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    instance.pApplicationInfo = &app;
    CHECK(vkCreateInstance(&instance, NULL, &b->instance));
    uint32_t count = 1;
    VkResult result = vkEnumeratePhysicalDevices(b->instance, &count, &b->physical);
    if ((result != VK_SUCCESS && result != VK_INCOMPLETE) || count == 0) {
        fprintf(stderr, "texture_fetch_bench: no Vulkan device\n");
        exit(1);
    }
    vkGetPhysicalDeviceMemoryProperties(b->physical, &b->memory);
    VkQueueFamilyProperties families[16];
    count = 16;
    vkGetPhysicalDeviceQueueFamilyProperties(b->physical, &count, families);
    for (b->family = 0; b->family < count; b->family++)
        if (families[b->family].queueFlags & VK_QUEUE_COMPUTE_BIT)
            break;
    VkPhysicalDeviceVulkan12Features have12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceFeatures2 have = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &have12};
    vkGetPhysicalDeviceFeatures2(b->physical, &have);
    b->nonuniform_images = have12.shaderSampledImageArrayNonUniformIndexing;
    float priority = 1.0f;
    VkDeviceQueueCreateInfo queue = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queue.queueFamilyIndex = b->family;
    queue.queueCount = 1;
    queue.pQueuePriorities = &priority;
    VkDeviceCreateInfo device = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    device.queueCreateInfoCount = 1;
    device.pQueueCreateInfos = &queue;
    CHECK(vkCreateDevice(b->physical, &device, NULL, &b->device));
    vkGetDeviceQueue(b->device, b->family, 0, &b->queue);
    VkCommandPoolCreateInfo pool = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pool.queueFamilyIndex = b->family;
    CHECK(vkCreateCommandPool(b->device, &pool, NULL, &b->pool));
}

static VkCommandBuffer begin(const bench *b)
{
    VkCommandBufferAllocateInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    info.commandPool = b->pool;
    info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    info.commandBufferCount = 1;
    VkCommandBuffer cmd;
    CHECK(vkAllocateCommandBuffers(b->device, &info, &cmd));
    VkCommandBufferBeginInfo start = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    start.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    CHECK(vkBeginCommandBuffer(cmd, &start));
    return cmd;
}

static void submit(const bench *b, VkCommandBuffer cmd)
{
    CHECK(vkEndCommandBuffer(cmd));
    VkSubmitInfo info = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    info.commandBufferCount = 1;
    info.pCommandBuffers = &cmd;
    CHECK(vkQueueSubmit(b->queue, 1, &info, VK_NULL_HANDLE));
    CHECK(vkQueueWaitIdle(b->queue));
    vkFreeCommandBuffers(b->device, b->pool, 1, &cmd);
}

static void image_barrier(VkCommandBuffer cmd, VkImage image, uint32_t levels,
                          VkImageLayout from, VkImageLayout to, VkAccessFlags src,
                          VkAccessFlags dst, VkPipelineStageFlags src_stage,
                          VkPipelineStageFlags dst_stage)
{
    VkImageMemoryBarrier barrier = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    barrier.srcAccessMask = src;
    barrier.dstAccessMask = dst;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange =
        (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, TEXTURES};
    vkCmdPipelineBarrier(cmd, src_stage, dst_stage, 0, 0, NULL, 0, NULL, 1, &barrier);
}

static uint32_t mip_levels(uint32_t edge)
{
    uint32_t levels = 1;
    while (edge > 1) {
        edge /= 2;
        levels++;
    }
    return levels;
}

/* Every texture's chain, one after another: random sRGB bytes at level 0, each level
 * the 2×2 average of the one above (in the stored bytes: both paths read the same). */
static uint32_t *make_texels(uint32_t edge, uint32_t levels, uint64_t *chain_texels)
{
    uint64_t chain = 0;
    for (uint32_t k = 0, e = edge; k < levels; k++, e = e > 1 ? e / 2 : 1)
        chain += (uint64_t)e * e;
    uint32_t *texels = malloc(chain * TEXTURES * sizeof *texels);
    if (!texels)
        exit(1);
    uint32_t state = 12345u;
    for (uint32_t t = 0; t < TEXTURES; t++) {
        uint32_t *level = texels + t * chain;
        for (uint64_t i = 0; i < (uint64_t)edge * edge; i++) {
            state = state * 1664525u + 1013904223u;
            level[i] = state | 0xFF000000u;
        }
        for (uint32_t k = 1, e = edge; k < levels; k++) {
            uint32_t *next = level + (uint64_t)e * e;
            uint32_t n = e / 2;
            for (uint32_t y = 0; y < n; y++)
                for (uint32_t x = 0; x < n; x++) {
                    uint32_t word = 0;
                    for (int c = 0; c < 32; c += 8) {
                        uint32_t s = ((level[2 * y * e + 2 * x] >> c) & 255u) +
                                     ((level[2 * y * e + 2 * x + 1] >> c) & 255u) +
                                     ((level[(2 * y + 1) * e + 2 * x] >> c) & 255u) +
                                     ((level[(2 * y + 1) * e + 2 * x + 1] >> c) & 255u);
                        word |= ((s + 2) / 4) << c;
                    }
                    next[y * n + x] = word;
                }
            level = next;
            e = n;
        }
    }
    *chain_texels = chain;
    return texels;
}

static VkShaderModule shader(const bench *b, const char *name)
{
    const pf_shader_blob *blob = pf_shader_find(name);
    if (!blob) {
        fprintf(stderr, "texture_fetch_bench: no shader %s\n", name);
        exit(1);
    }
    VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = blob->bytes;
    info.pCode = blob->words;
    VkShaderModule module;
    CHECK(vkCreateShaderModule(b->device, &info, NULL, &module));
    return module;
}

/* A compute pipeline with binding 0 the sums (storage) and binding 1 of `type`. */
static VkPipeline pipeline(const bench *b, const char *name, VkDescriptorType type,
                           VkDescriptorSetLayout *set_layout, VkPipelineLayout *layout)
{
    VkDescriptorSetLayoutBinding bindings[2] = {
        {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL},
        {1, type, 1, VK_SHADER_STAGE_COMPUTE_BIT, NULL}};
    VkDescriptorSetLayoutCreateInfo set_info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    set_info.bindingCount = 2;
    set_info.pBindings = bindings;
    CHECK(vkCreateDescriptorSetLayout(b->device, &set_info, NULL, set_layout));
    VkPushConstantRange range = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push)};
    VkPipelineLayoutCreateInfo layout_info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = set_layout;
    layout_info.pushConstantRangeCount = 1;
    layout_info.pPushConstantRanges = &range;
    CHECK(vkCreatePipelineLayout(b->device, &layout_info, NULL, layout));
    VkComputePipelineCreateInfo info = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = shader(b, name);
    info.stage.pName = "main";
    info.layout = *layout;
    VkPipeline out;
    CHECK(vkCreateComputePipelines(b->device, VK_NULL_HANDLE, 1, &info, NULL, &out));
    vkDestroyShaderModule(b->device, info.stage.module, NULL);
    return out;
}

static VkDescriptorSet descriptor_set(const bench *b, VkDescriptorSetLayout layout,
                                      VkDescriptorType type)
{
    VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1}, {type, 1}};
    VkDescriptorPoolCreateInfo pool_info = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pool_info.maxSets = 1;
    pool_info.poolSizeCount = 2;
    pool_info.pPoolSizes = sizes;
    VkDescriptorPool pool;
    CHECK(vkCreateDescriptorPool(b->device, &pool_info, NULL, &pool));
    VkDescriptorSetAllocateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    info.descriptorPool = pool;
    info.descriptorSetCount = 1;
    info.pSetLayouts = &layout;
    VkDescriptorSet set;
    CHECK(vkAllocateDescriptorSets(b->device, &info, &set));
    return set;
}

/* Best of REPEATS (the first pays the shader's compile and is left out), in ms. */
static double run(const bench *b, VkPipeline pipe, VkPipelineLayout layout, VkDescriptorSet set,
                  const push *constants)
{
    double best = -1.0;
    for (int r = 0; r <= REPEATS; r++) {
        VkCommandBuffer cmd = begin(b);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipe);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, NULL);
        vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof *constants,
                           constants);
        vkCmdDispatch(cmd, INVOCATIONS / 64, 1, 1);
        double start = now_ms();
        submit(b, cmd);
        double ms = now_ms() - start;
        if (r > 0 && (best < 0.0 || ms < best))
            best = ms;
    }
    return best;
}

int main(int argc, char **argv)
{
    uint32_t edge = argc > 1 ? (uint32_t)strtoul(argv[1], NULL, 10) : 256u;
    if (edge < 2 || edge > 4096 || (edge & (edge - 1)) != 0) {
        fprintf(stderr, "usage: texture_fetch_bench [EDGE: a power of two, 2..4096]\n");
        return 2;
    }
    bench b;
    bench_init(&b);
    VkPhysicalDeviceProperties properties;
    vkGetPhysicalDeviceProperties(b.physical, &properties);
    uint32_t levels = mip_levels(edge);
    uint64_t chain;
    uint32_t *texels = make_texels(edge, levels, &chain);
    uint64_t texel_bytes = chain * TEXTURES * 4;
    printf("texture_fetch_bench: device %s, %u textures of %u² RGBA8 sRGB with %u levels "
           "(%.1f MB), %u invocations × %u bilinear samples; image arrays indexed per lane: "
           "%s\n",
           properties.deviceName, TEXTURES, edge, levels, texel_bytes / 1e6, INVOCATIONS,
           FETCHES, b.nonuniform_images ? "supported" : "not supported");

    /* The sums, one per invocation per path. */
    VkDeviceMemory sum_memory[PATHS];
    void *sum_mapped[PATHS];
    VkBuffer sums[PATHS];
    for (int p = 0; p < PATHS; p++)
        sums[p] = host_buffer(&b, (VkDeviceSize)INVOCATIONS * 16,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &sum_memory[p], &sum_mapped[p]);

    /* Path 0: the texel buffer. */
    VkDeviceMemory texel_memory;
    void *texel_mapped;
    VkBuffer texel_buffer = host_buffer(&b, texel_bytes,
                                        VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
                                            VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                        &texel_memory, &texel_mapped);
    memcpy(texel_mapped, texels, texel_bytes);
    VkBufferViewCreateInfo view_info = {VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
    view_info.buffer = texel_buffer;
    view_info.format = VK_FORMAT_R32_UINT;
    view_info.range = VK_WHOLE_SIZE;
    VkBufferView view;
    CHECK(vkCreateBufferView(b.device, &view_info, NULL, &view));

    /* Path 1: one array image, a layer per texture, copied from the same bytes. */
    VkImage image;
    VkImageView image_view;
    VkDeviceMemory image_memory;
    VkCommandBuffer cmd = begin(&b);
    VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = VK_FORMAT_R8G8B8A8_SRGB;
    info.extent = (VkExtent3D){edge, edge, 1};
    info.mipLevels = levels;
    info.arrayLayers = TEXTURES;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    CHECK(vkCreateImage(b.device, &info, NULL, &image));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(b.device, image, &req);
    image_memory = allocate(&b, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    CHECK(vkBindImageMemory(b.device, image, image_memory, 0));
    image_barrier(cmd, image, levels, VK_IMAGE_LAYOUT_UNDEFINED,
                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT);
    for (uint32_t t = 0; t < TEXTURES; t++) {
        VkBufferImageCopy copies[16];
        VkDeviceSize offset = (VkDeviceSize)t * chain * 4;
        for (uint32_t k = 0, e = edge; k < levels; k++, e = e > 1 ? e / 2 : 1) {
            copies[k] = (VkBufferImageCopy){offset, 0, 0, {VK_IMAGE_ASPECT_COLOR_BIT, k, t, 1},
                                            {0, 0, 0}, {e, e, 1}};
            offset += (VkDeviceSize)e * e * 4;
        }
        vkCmdCopyBufferToImage(cmd, texel_buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               levels, copies);
    }
    image_barrier(cmd, image, levels, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                  VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_ACCESS_TRANSFER_WRITE_BIT,
                  VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                  VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
    submit(&b, cmd);
    VkImageViewCreateInfo iv = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    iv.image = image;
    iv.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
    iv.format = VK_FORMAT_R8G8B8A8_SRGB;
    iv.subresourceRange =
        (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, TEXTURES};
    CHECK(vkCreateImageView(b.device, &iv, NULL, &image_view));
    VkSamplerCreateInfo sampler_info = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    sampler_info.magFilter = sampler_info.minFilter = VK_FILTER_LINEAR;
    sampler_info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    sampler_info.addressModeU = sampler_info.addressModeV = sampler_info.addressModeW =
        VK_SAMPLER_ADDRESS_MODE_REPEAT;
    sampler_info.maxLod = (float)levels;
    VkSampler sampler;
    CHECK(vkCreateSampler(b.device, &sampler_info, NULL, &sampler));

    VkDescriptorSetLayout set_layouts[PATHS];
    VkPipelineLayout layouts[PATHS];
    const VkDescriptorType types[PATHS] = {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER,
                                           VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER,
                                           VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER};
    const char *const names[PATHS] = {"texture_fetch_buffer", "texture_fetch_buffer_table",
                                      "texture_fetch_image"};
    VkPipeline pipes[PATHS];
    VkDescriptorSet sets[PATHS];
    for (int p = 0; p < PATHS; p++) {
        double start = now_ms();
        pipes[p] = pipeline(&b, names[p], types[p], &set_layouts[p], &layouts[p]);
        printf("  %-26s pipeline created in %.0f ms\n", path_labels[p], now_ms() - start);
        sets[p] = descriptor_set(&b, set_layouts[p], types[p]);
        VkDescriptorBufferInfo sum_info = {sums[p], 0, VK_WHOLE_SIZE};
        VkDescriptorImageInfo image_info = {sampler, image_view,
                                            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkWriteDescriptorSet writes[2] = {{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET},
                                          {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET}};
        writes[0].dstSet = writes[1].dstSet = sets[p];
        writes[0].dstBinding = 0;
        writes[0].descriptorCount = 1;
        writes[0].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        writes[0].pBufferInfo = &sum_info;
        writes[1].dstBinding = 1;
        writes[1].descriptorCount = 1;
        writes[1].descriptorType = types[p];
        if (types[p] == VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER)
            writes[1].pTexelBufferView = &view;
        else
            writes[1].pImageInfo = &image_info;
        vkUpdateDescriptorSets(b.device, 2, writes, 0, NULL);
    }

    int status = 0;
    double samples = (double)INVOCATIONS * FETCHES;
    for (uint32_t divergent = 0; divergent < 2; divergent++) {
        push constants = {TEXTURES, edge, levels, divergent};
        printf("  %s textures (%s):\n", divergent ? "divergent" : "coherent",
               divergent ? "each lane its own" : "one a workgroup");
        double base = 0.0;
        for (int p = 0; p < PATHS; p++) {
            double ms = run(&b, pipes[p], layouts[p], sets[p], &constants);
            if (p == 0)
                base = ms;
            /* Every path filters the same bytes: the sums agree but for rounding (the
             * sampler's 8-bit sub-texel weights against GLSL's float ones). */
            const float *a = sum_mapped[0], *c = sum_mapped[p];
            double difference = 0.0, total = 0.0;
            for (uint64_t i = 0; i < (uint64_t)INVOCATIONS * 4; i++) {
                difference += fabs((double)a[i] - c[i]);
                total += fabs((double)a[i]);
            }
            printf("    %-27s %7.1f ms  %5.1f ns a sample  %.2f× the formula's time;"
                   "  sums differ by %.3f%%\n",
                   path_labels[p], ms, ms * 1e6 / samples, ms / base, 100.0 * difference / total);
            if (!(difference <= 0.01 * total)) {
                fprintf(stderr, "texture_fetch_bench: %s disagrees\n", path_labels[p]);
                status = 1;
            }
        }
    }
    free(texels);
    vkDeviceWaitIdle(b.device);
    /* The process ends here; the driver frees what is left with the device. */
    vkDestroyDevice(b.device, NULL);
    vkDestroyInstance(b.instance, NULL);
    return status;
}
