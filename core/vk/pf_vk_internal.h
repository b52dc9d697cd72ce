/*
 * core/vk private state shared by its files (instance.c, device.c, memory.c,
 * pipeline.c, commands.c). Nothing outside core/vk includes this, except the
 * core/vk tests that reach the staging path on devices whose memory is all
 * host-visible.
 */
#ifndef PF_VK_INTERNAL_H
#define PF_VK_INTERNAL_H

#include "pf_vk.h"

#include <pthread.h>
#include <stdatomic.h>
#include <vulkan/vulkan.h>

#define PF_VK_VALIDATION_LAYER "VK_LAYER_KHRONOS_validation"
/* DESIGN.md §3: Vulkan 1.2 core is the floor. */
#define PF_VK_MIN_API_VERSION VK_API_VERSION_1_2

typedef struct pf_vk_staging {
    VkBuffer buffer;
    VkDeviceMemory memory;
    void *mapped;
    uint64_t bytes;    /* the memory's size (it may exceed the buffer's) */
    uint64_t capacity; /* the buffer's size: the largest copy it takes */
    int to_device;
} pf_vk_staging;

/* Staging buffers a context keeps for reuse, at most, and their bytes at most; the same
 * for device-local storage buffers. */
#define PF_VK_STAGING_KEPT 32
#define PF_VK_STAGING_KEPT_BYTES (1024ull * 1024 * 1024)
#define PF_VK_BUFFERS_KEPT 256
#define PF_VK_BUFFERS_KEPT_BYTES (4096ull * 1024 * 1024) /* and a quarter of the device's */

struct pf_vk_context {
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    int validation;
    atomic_uint validation_messages;

    VkPhysicalDevice physical_device;
    pf_vk_device_info info;
    VkPhysicalDeviceMemoryProperties memory_properties;
    VkDevice device;
    uint32_t queue_family;
    VkQueue queue;
    /* Vulkan requires external synchronization of a queue and a command pool. */
    pthread_mutex_t queue_lock;
    VkCommandPool transfer_pool; /* staging copies; guarded by queue_lock */
    int force_staging;           /* tests: never map buffers directly */
    int has_creation_feedback;   /* VK_EXT_pipeline_creation_feedback enabled */
    /* The device's shader `/` rounds as IEEE does (llvmpipe: LLVM's fdiv): every pipeline
     * gets PF_VK_SPEC_DIVIDE_REFINE = 0, so divide_exact skips its refinement. */
    int exact_division;
    uint32_t max_texel_buffer_elements;
    pthread_mutex_t view_lock; /* a buffer's texel views are made on first use, from any thread */
    /* Buffers kept for reuse (kept.c says why), oldest first. */
    pthread_mutex_t kept_lock;
    pf_vk_staging staging_kept[PF_VK_STAGING_KEPT];
    uint32_t staging_kept_count;
    struct pf_vk_buffer *buffers_kept[PF_VK_BUFFERS_KEPT];
    uint32_t buffers_kept_count;
    /* Device memory held by buffers now, and the most held since creation or the last
     * pf_vk_memory_peak_reset (bytes; buffers are made from any thread). */
    _Atomic uint64_t memory_in_use, memory_peak;
    /* pf_vk_traffic's counters (any thread). */
    _Atomic uint64_t submits, host_waits, readback_bytes, upload_bytes;
    /* pf_vk_traffic's times, in nanoseconds (pf_vk_time_add). */
    _Atomic uint64_t wait_ns, allocate_ns, copy_ns;
    /* Submissions made with pf_vk_commands_submit_async not yet waited for, and the waits
     * for other commands made meanwhile (pf_vk_waits_behind). */
    _Atomic uint64_t in_flight, waits_behind;

    struct {
        VkPipelineCache handle; /* the file is stats.path ("" without a directory) */
        uint32_t vendor_id, device_id;
        uint8_t uuid[VK_UUID_SIZE];
        pthread_mutex_t lock; /* stats and dirty: pipelines are created from any thread */
        int dirty;            /* pipelines created since the last write */
        pf_vk_cache_stats stats;
    } cache;
};

/* How a pipeline's binding is bound (spirv_bindings.c finds the texel ones). */
enum {
    PF_VK_BINDING_STORAGE = 0,    /* storage buffer */
    PF_VK_BINDING_TEXEL_UINT = 1, /* usamplerBuffer: the buffer viewed as R32_UINT words */
    PF_VK_BINDING_TEXEL_FLOAT = 2, /* samplerBuffer: the buffer viewed as RGBA32 float texels */
    /* isamplerBuffer: the buffer viewed as RGBA32_SINT texels, i.e. 16-byte records of 4
     * words that a shader reads in one fetch (as uvec4 of the ivec4). Signed because the
     * SPIR-V of a sampled buffer carries no format: the sampled type is what tells the two
     * uint views apart. Integer, not float: a float view may flush or canonicalise bits. */
    PF_VK_BINDING_TEXEL_INT4 = 3,
    PF_VK_BINDING_KINDS = 4,
    /* No variable of the module has the binding (spirv-opt removed one the kernel never
     * reads): out of the pipeline's layout, and the dispatch writes no descriptor for it. */
    PF_VK_BINDING_ABSENT = 0xff
};

struct pf_vk_buffer {
    VkBuffer buffer;
    VkDeviceMemory memory;
    uint64_t size;      /* what the caller asked for: uploads, downloads and views check it */
    uint64_t allocated; /* the VkBuffer's size: pf_vk_buffer_allocation_size(size) */
    VkBufferView views[PF_VK_BINDING_KINDS]; /* by PF_VK_BINDING_TEXEL_*, made on first use */
    void *mapped; /* non-NULL when the memory is host-visible + coherent */
    uint64_t memory_bytes; /* the allocation's size, counted in memory_in_use */
    char label[64];
};

/*
 * The VkBuffer size for a buffer of `size` bytes on a device whose storage
 * range is at most `limit`: sizes that keep llvmpipe's shader variants
 * stable (memory.c says why), `size` itself where the padded size would pass
 * the limit.
 */
uint64_t pf_vk_buffer_allocation_size(uint64_t size, uint64_t limit);

struct pf_vk_pipeline {
    char name[64];
    VkShaderModule module;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkPipeline pipeline;
    uint32_t buffer_count;
    uint32_t push_constant_bytes;
    uint8_t *binding_kinds; /* buffer_count entries, PF_VK_BINDING_* */
};

/* SPIR-V specification §2.3: the first word of every module, and the header's
 * words (magic, version, generator, bound, schema) before the first instruction. */
#define PF_SPIRV_MAGIC 0x07230203u
#define PF_SPIRV_HEADER_WORDS 5u

/*
 * The word count of the instruction at words[at] of a module of count words:
 * PF_ERR_FORMAT (naming the word) when it is 0 or runs past the end. The one
 * bounds check of the module walks in spirv_denormals.c and spirv_bindings.c.
 */
static inline pf_status pf_vk_spirv_instruction_words(const uint32_t *words, size_t count,
                                                      size_t at, uint32_t *n, pf_error *err)
{
    *n = words[at] >> 16;
    if (*n == 0 || at + *n > count)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "SPIR-V module: instruction at word %zu runs past the end", at);
    return PF_OK;
}

/*
 * A copy of the SPIR-V module words[0..count) that declares DenormPreserve for
 * 32-bit floats on each entry point (and the capability, and the extension
 * before SPIR-V 1.4). *out is malloc'd; PF_ERR_FORMAT for a malformed module.
 */
pf_status pf_vk_spirv_preserve_denormals(const uint32_t *words, size_t count, uint32_t **out,
                                         size_t *out_count, pf_error *err);

/*
 * kinds[b] (b < binding_count) := PF_VK_BINDING_TEXEL_UINT / _FLOAT / _INT4 where the
 * module declares a uniform texel buffer (usamplerBuffer / samplerBuffer / isamplerBuffer) at
 * set 0, binding b; PF_VK_BINDING_STORAGE where it declares any other variable there;
 * PF_VK_BINDING_ABSENT where it declares none. PF_ERR_FORMAT for a
 * malformed module, PF_ERR_INVALID for a binding >= binding_count.
 */
pf_status pf_vk_spirv_binding_kinds(const uint32_t *words, size_t count, uint8_t *kinds,
                                    uint32_t binding_count, pf_error *err);

/* The descriptor type of a binding kind (PF_VK_BINDING_*). */
static inline VkDescriptorType pf_vk_descriptor_type(int kind)
{
    return kind == PF_VK_BINDING_STORAGE ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER
                                         : VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
}

/* The buffer's texel view for kind (PF_VK_BINDING_TEXEL_*), made on first use. */
pf_status pf_vk_buffer_texel_view(pf_vk_context *ctx, pf_vk_buffer *buffer, int kind,
                                  VkBufferView *view, pf_error *err);

/* "vkFoo failed: VK_ERROR_... (-n)" style text for a VkResult. */
const char *pf_vk_result_name(VkResult result);

/* Fills info from a physical device (instance.c / device.c). */
void pf_vk_describe_device(VkPhysicalDevice physical_device, uint32_t index,
                           pf_vk_device_info *info, uint32_t *compute_family);

/*
 * Instance creation shared by pf_vk_create and pf_vk_enumerate. With validation
 * on, ctx (which must outlive the instance) receives the messenger's counts.
 */
pf_status pf_vk_instance_create(pf_vk_context *ctx, int validation, pf_error *err);
void pf_vk_instance_destroy(pf_vk_context *ctx);

/* Picks and opens the device (device.c). */
pf_status pf_vk_device_open(pf_vk_context *ctx, const char *selector, pf_error *err);
void pf_vk_device_close(pf_vk_context *ctx);

/* pipeline_cache.c: opened after the device, closed (saved) before it. */
pf_status pf_vk_pipeline_cache_open(pf_vk_context *ctx, const char *dir, pf_error *err);
void pf_vk_pipeline_cache_close(pf_vk_context *ctx);
/* Counts one created pipeline; cache_hit from its creation feedback. */
void pf_vk_pipeline_cache_note(pf_vk_context *ctx, int cache_hit);

/*
 * Tests only: with on != 0, buffers created afterwards are never mapped, so
 * uploads and downloads take the staging path that discrete GPUs use.
 */
void pf_vk_force_staging(pf_vk_context *ctx, int on);

/* A host-visible, coherent buffer for one copy to (to_device) or from a device buffer
 * (memory.c; commands.c's recorded copies and the blocking ones). */
pf_status pf_vk_staging_create(pf_vk_context *ctx, uint64_t size, int to_device,
                               const char *label, pf_vk_staging *out, pf_error *err);
/* Hands staging back: kept for a later pf_vk_staging_create of its direction, or freed. */
void pf_vk_staging_destroy(pf_vk_context *ctx, pf_vk_staging *staging);
/* Frees a staging or storage buffer; counted: whether its bytes are in memory_in_use. */
void pf_vk_staging_free(pf_vk_context *ctx, const pf_vk_staging *staging, int counted);
void pf_vk_buffer_free(pf_vk_context *ctx, pf_vk_buffer *buffer, int counted);
/* memory_in_use += bytes (raising the peak), and -= bytes. */
void pf_vk_memory_held(pf_vk_context *ctx, uint64_t bytes);
void pf_vk_memory_released(pf_vk_context *ctx, uint64_t bytes);

/* Buffers kept for reuse (kept.c): take one that serves the request (NULL / 0: none), put
 * one back (0: not kept, the caller frees it), free all that are kept (returns how many;
 * before the device goes, and where it runs out of memory), and count them (tests). */
pf_vk_buffer *pf_vk_kept_buffer_take(pf_vk_context *ctx, uint64_t allocated);
int pf_vk_kept_buffer_put(pf_vk_context *ctx, pf_vk_buffer *buffer);
int pf_vk_kept_staging_take(pf_vk_context *ctx, uint64_t size, int to_device,
                            pf_vk_staging *out);
int pf_vk_kept_staging_put(pf_vk_context *ctx, const pf_vk_staging *staging);
uint32_t pf_vk_kept_release(pf_vk_context *ctx);
void pf_vk_kept_counts(pf_vk_context *ctx, uint32_t *buffers, uint32_t *staging);

/* A copy's range within buffer and its host data (PF_ERR_INVALID naming them when not). */
pf_status pf_vk_buffer_range_check(const pf_vk_buffer *buffer, uint64_t offset,
                                   const void *data, uint64_t size, const char *what,
                                   pf_error *err);
/* traffic.c. Adds the time since start_ms (pf_time_ms) to one of pf_vk_traffic's times. */
void pf_vk_time_add(_Atomic uint64_t *total_ns, double start_ms);
/* memcpy that counts its time in pf_vk_traffic's copy_ms, on several cores when large. */
void pf_vk_copy(pf_vk_context *ctx, void *to, const void *from, uint64_t size);
/* Counts bytes copied to (upload) or from the device in pf_vk_traffic. */
void pf_vk_count_copy(pf_vk_context *ctx, uint64_t bytes, int upload);

#endif
