/*
 * core/vk: the Vulkan compute runtime — instance and device choice, storage
 * buffers, compute pipelines from SPIR-V, command recording with fences, and
 * GPU timestamp queries. Everything GPU-side in photonfarm goes through here.
 *
 * Device choice: a real GPU (discrete > integrated > virtual) when present, else
 * a CPU device (lavapipe). An explicit selector (the CLI's --device or
 * $PHOTONFARM_DEVICE) is either a decimal index into
 * pf_vk_enumerate()'s list or a case-insensitive substring of the device name.
 *
 * Validation: when enabled (the option; the CLI sets it from $PF_VK_VALIDATION) the Khronos
 * validation layer is loaded and every message it emits is printed to stderr
 * and counted; tests assert the count stays zero. Enabling it when the layer is
 * not installed is an error, never a silent downgrade.
 */
#ifndef PF_VK_H
#define PF_VK_H

#include "pf_common.h"

#include <stdint.h>

typedef struct pf_vk_context pf_vk_context;
typedef struct pf_vk_buffer pf_vk_buffer;
typedef struct pf_vk_pipeline pf_vk_pipeline;
typedef struct pf_vk_commands pf_vk_commands;

typedef struct pf_vk_device_info {
    uint32_t index;         /* position in pf_vk_enumerate()'s list */
    char name[256];
    char type[16];          /* "discrete", "integrated", "virtual", "cpu", "other" */
    char driver[256];       /* driver name + info, e.g. "llvmpipe" / "NVIDIA 550.x" */
    uint32_t vendor_id;
    uint32_t device_id;
    uint32_t api_version;   /* VK_MAKE_API_VERSION packed */
    uint64_t max_storage_buffer_range;   /* and 4 × maxTexelBufferElements; lavapipe: 128 MiB */
    uint64_t device_local_bytes;         /* largest device-local heap */
    uint32_t max_workgroup_invocations;
    uint32_t max_workgroup_size[3];
    uint32_t max_workgroup_count[3];
    uint32_t max_shared_memory_bytes;
    uint32_t max_push_constant_bytes;
    uint32_t subgroup_size;
    float timestamp_period_ns;           /* ns per timestamp tick */
    uint32_t timestamp_valid_bits;       /* 0: no compute timestamps */
    int has_int64;                       /* shaderInt64 */
    int has_int64_atomics;               /* shaderBufferInt64Atomics */
    /* shaderDenormPreserveFloat32, settable apart from other widths: every
     * pipeline's module then declares DenormPreserve (IEEE subnormals). */
    int has_denorm_preserve;
} pf_vk_device_info;

#define PF_VK_VALIDATION_SYNC 2

typedef struct pf_vk_options {
    const char *device_selector; /* NULL: the automatic choice */
    /* Non-zero: the Khronos validation layer on (must be installed); PF_VK_VALIDATION_SYNC:
     * its synchronization validation too (hazards between commands; it also reports a
     * dispatch that reads a buffer through a texel view and writes it through a storage
     * binding, which the renderer's kernels do per invocation, so only tests of ordering
     * ask for it). */
    int validation;
    /* Directory of the persistent pipeline cache (created if missing); NULL or
     * "": pipelines are cached in memory for this context only. */
    const char *pipeline_cache_dir;
} pf_vk_options;

/* Lists every physical device with its key limits. *devices is malloc'ed; free() it. */
pf_status pf_vk_enumerate(pf_vk_device_info **devices, uint32_t *count, pf_error *err);

/*
 * Creates an instance and a logical device with one compute queue on the chosen
 * device. On failure nothing is left allocated and err names the cause (no
 * Vulkan loader, no device, selector matching nothing, validation layer missing).
 */
pf_status pf_vk_create(const pf_vk_options *options, pf_vk_context **out, pf_error *err);
void pf_vk_destroy(pf_vk_context *ctx);
const pf_vk_device_info *pf_vk_info(const pf_vk_context *ctx);
/* Whether the device is the CPU (lavapipe): its memory is the host's, and stages that have a
 * host path of their own pick it there when it measures faster. */
int pf_vk_device_is_cpu(const pf_vk_context *ctx);
/* Whether the host reads and writes the storage buffers in place (pf_vk_buffer_host_memory):
 * the device is the CPU and no staging is forced (tests force it to count a GPU's copies). */
int pf_vk_storage_is_host_memory(const pf_vk_context *ctx);
int pf_vk_validation_enabled(const pf_vk_context *ctx);
/* Validation messages (warnings and errors) seen since creation. */
uint32_t pf_vk_validation_message_count(const pf_vk_context *ctx);

/*
 * Device memory the context's buffers hold now (current) and the most they held at once
 * since the context was made or pf_vk_memory_peak_reset (peak), in bytes as allocated:
 * padding and staging copies included. A frame's peak is what a device must have to
 * render it (issue 42's per-frame resources).
 */
typedef struct pf_vk_memory_use {
    uint64_t current, peak;
} pf_vk_memory_use;
pf_vk_memory_use pf_vk_memory_use_of(pf_vk_context *ctx);
/* Starts a new peak from what is held now. */
void pf_vk_memory_peak_reset(pf_vk_context *ctx);

/*
 * The host's traffic with the device since the context was made (issue 44): queue
 * submissions, times the host waited for the device (a fence), the bytes
 * pf_vk_buffer_upload and pf_vk_buffer_download copied (through a mapping or a staging
 * submission), and the host's time in each. A stage's share is the difference of two
 * reads (pf_vk_traffic_since); stages run one after another, so nothing else adds to it
 * meanwhile.
 */
typedef struct pf_vk_traffic {
    uint64_t submits, host_waits, readback_bytes, upload_bytes;
    /* Where a stage's host time went beside its own work (ms): blocked in fence waits
     * (the device's busy time and its latency), creating and freeing buffers' memory (a
     * GPU driver pins host memory page by page), and copying between the host's arrays and
     * mapped or staging memory. Wall time minus these is the stage's own host work. */
    double wait_ms, allocate_ms, copy_ms;
} pf_vk_traffic;
pf_vk_traffic pf_vk_traffic_of(pf_vk_context *ctx);
/* Host waits made while a submission of pf_vk_commands_submit_async was still in flight:
 * each stalled behind it on the one queue, the host's work meant to overlap the device's
 * included. 0 where the overlap fetched what it needed first. */
uint64_t pf_vk_waits_behind(pf_vk_context *ctx);
/* What was added since before (a read of pf_vk_traffic_of). */
pf_vk_traffic pf_vk_traffic_since(pf_vk_context *ctx, pf_vk_traffic before);

/*
 * A device-local storage buffer of size bytes (label names it in errors).
 * A size above maxStorageBufferRange is refused with PF_ERR_LIMIT and a message
 * giving both numbers, the label and the device: callers split big data.
 */
pf_status pf_vk_buffer_create(pf_vk_context *ctx, uint64_t size, const char *label,
                              pf_vk_buffer **out, pf_error *err);
void pf_vk_buffer_destroy(pf_vk_context *ctx, pf_vk_buffer *buffer);
uint64_t pf_vk_buffer_size(const pf_vk_buffer *buffer);
/*
 * The buffer's memory as the host sees it, where the device's memory is the host's
 * (host-visible and coherent: lavapipe), else NULL. The host may read what a finished
 * submission wrote and write what the next one reads, in place, but not while a
 * submission that uses the buffer runs.
 */
void *pf_vk_buffer_host_memory(pf_vk_buffer *buffer);
/* Blocking copies through a staging buffer; ranges are checked against the size. */
pf_status pf_vk_buffer_upload(pf_vk_context *ctx, pf_vk_buffer *buffer, uint64_t offset,
                              const void *data, uint64_t size, pf_error *err);
pf_status pf_vk_buffer_download(pf_vk_context *ctx, pf_vk_buffer *buffer, uint64_t offset,
                                void *data, uint64_t size, pf_error *err);

/*
 * A specialization constant every pipeline gets besides its own: 1 where the
 * device's shader division may be off by an ulp or more (Vulkan allows 2.5;
 * NVIDIA's is), so shaders/common/ray_triangle.glsl's divide_exact refines
 * it; 0 on llvmpipe, whose division is IEEE-rounded already.
 */
#define PF_VK_SPEC_DIVIDE_REFINE 1000u

typedef struct pf_vk_spec_constant {
    uint32_t constant_id;
    uint32_t value; /* 32-bit int/uint/float bits */
} pf_vk_spec_constant;

typedef struct pf_vk_pipeline_desc {
    const char *name;                 /* shader name, for errors and logs */
    const uint32_t *spirv;
    size_t spirv_bytes;
    /* Buffers at set 0, bindings 0..n-1: storage buffers, except where the module
     * declares a usamplerBuffer (bound as an R32_UINT texel view of the buffer) or
     * a samplerBuffer (an RGBA32F view); the dispatch binds pf_vk_buffers either way. */
    uint32_t buffer_count;
    uint32_t push_constant_bytes;     /* 0..128 */
    const pf_vk_spec_constant *spec_constants;
    uint32_t spec_constant_count;
} pf_vk_pipeline_desc;

pf_status pf_vk_pipeline_create(pf_vk_context *ctx, const pf_vk_pipeline_desc *desc,
                                pf_vk_pipeline **out, pf_error *err);
/* Convenience: pipeline from an embedded shader by name (see pf_shaders.h). */
pf_status pf_vk_pipeline_create_named(pf_vk_context *ctx, const char *shader_name,
                                      uint32_t buffer_count, uint32_t push_constant_bytes,
                                      const pf_vk_spec_constant *spec_constants,
                                      uint32_t spec_constant_count, pf_vk_pipeline **out,
                                      pf_error *err);
void pf_vk_pipeline_destroy(pf_vk_context *ctx, pf_vk_pipeline *pipeline);

/*
 * The persistent pipeline cache (options.pipeline_cache_dir). The file is
 * named by the device and driver identity and written atomically; one that is
 * corrupt, truncated or from another driver is ignored with a warning and
 * rewritten. pf_vk_destroy saves it; savers call pf_vk_pipeline_cache_save
 * earlier so that a process killed later still leaves its pipelines cached.
 * Drivers whose VkPipelineCache holds nothing but its header (Mesa's lavapipe
 * 22.x) keep compiled code in Mesa's own disk cache instead, which the worker
 * points at the same directory ($MESA_SHADER_CACHE_DIR).
 */
typedef struct pf_vk_cache_stats {
    char path[1024];        /* the cache file; "" without a directory */
    uint64_t loaded_bytes;  /* driver data read from the file at creation (0: none) */
    uint64_t saved_bytes;   /* driver data in the last write (0: none yet) */
    int rejected;           /* a file was present but ignored (warning logged) */
    uint32_t pipelines;     /* compute pipelines created through this context */
    uint32_t cache_hits;    /* of those, served from the cache per the driver's
                             * pipeline-creation feedback */
} pf_vk_cache_stats;

pf_status pf_vk_pipeline_cache_save(pf_vk_context *ctx, pf_error *err);
pf_vk_cache_stats pf_vk_pipeline_cache_stats(pf_vk_context *ctx);

/*
 * Command recording: begin, record dispatches/barriers/timestamps, submit (waits
 * on a fence), read timestamps, destroy. One pf_vk_commands is single-use.
 */
pf_status pf_vk_commands_begin(pf_vk_context *ctx, pf_vk_commands **out, pf_error *err);
pf_status pf_vk_cmd_dispatch(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                             pf_vk_buffer *const *buffers, uint32_t buffer_count,
                             const void *push_constants, uint32_t push_constant_bytes,
                             uint32_t groups_x, uint32_t groups_y, uint32_t groups_z,
                             pf_error *err);
/*
 * A dispatch whose workgroup counts the device reads from groups at offset (3 uint32: x, y,
 * z; 0 groups dispatch nothing), written by an earlier dispatch (the barrier every dispatch
 * gets covers the group counts): work that only the device knows it has, without a readback. The writer keeps the
 * counts within maxComputeWorkGroupCount (the host cannot check them).
 */
pf_status pf_vk_cmd_dispatch_indirect(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                                      pf_vk_buffer *const *buffers, uint32_t buffer_count,
                                      const void *push_constants, uint32_t push_constant_bytes,
                                      pf_vk_buffer *groups, uint64_t offset, pf_error *err);
/* Makes all earlier shader writes visible to later shader reads and writes, and to the
 * group counts of an indirect dispatch. Each dispatch records one itself where a dispatch
 * came before it since the last barrier or copy, so recorded dispatches run in order, each
 * seeing the writes of those before it, on every device; an explicit barrier is needed only
 * before work that is not a dispatch. */
void pf_vk_cmd_barrier(pf_vk_commands *cmds);
/* Writes a GPU timestamp; returns its slot (< 0 when timestamps are unsupported). */
int pf_vk_cmd_timestamp(pf_vk_commands *cmds);
/*
 * Copies recorded with the commands, so that a stage's uploads, passes and readbacks are
 * one submission and one wait (issue 44). An upload's data is copied now (it may be freed
 * after the call) and lands after the commands recorded before it and before those
 * recorded after it, on every device: a mapped buffer that no recorded dispatch uses yet
 * is written at once, one that a dispatch uses is staged. A download fills data when
 * pf_vk_commands_submit returns, with what the buffer holds after the commands recorded
 * before it; record none that writes the buffer after it (from a mapped buffer it is
 * read when every command has run). Ranges are checked as pf_vk_buffer_upload's; the
 * bytes count in pf_vk_traffic.
 */
pf_status pf_vk_cmd_upload(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t offset,
                           const void *data, uint64_t size, pf_error *err);
pf_status pf_vk_cmd_download(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t offset,
                             void *data, uint64_t size, pf_error *err);
/* Submits and waits. Commands with nothing for the device (no dispatch, timestamp or
 * staged copy: only copies to and from mapped buffers) are not submitted. */
pf_status pf_vk_commands_submit(pf_vk_commands *cmds, pf_error *err);
/* The same in two halves, so that the host works while the device runs them (issue 43's
 * readback in the background): submit_async returns once they are queued; wait waits for
 * them, then fills the downloads and the timestamps. pf_vk_commands_submit is both. The
 * buffers they use stay untouched by the host between the two. */
pf_status pf_vk_commands_submit_async(pf_vk_commands *cmds, pf_error *err);
pf_status pf_vk_commands_wait(pf_vk_commands *cmds, pf_error *err);
/* GPU milliseconds between two timestamp slots after submit; negative if unavailable. */
double pf_vk_commands_elapsed_ms(const pf_vk_commands *cmds, int slot_begin, int slot_end);
void pf_vk_commands_destroy(pf_vk_commands *cmds);

#endif
