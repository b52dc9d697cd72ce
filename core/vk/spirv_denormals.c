/*
 * DenormPreserve for 32-bit floats, added to a compute module at load time.
 *
 * Vulkan lets a device flush subnormal results to zero unless the shader
 * declares SPIR-V's DenormPreserve execution mode (Vulkan 1.2 float controls),
 * and NVIDIA's does: the ray/triangle edge functions of rays near the origin
 * (|x| ~ 1e-35) then come out 0 and hits differ from the CPU's. An execution
 * mode cannot be specialised, and a module that declares it is invalid on a
 * device without shaderDenormPreserveFloat32 (lavapipe 22.x has none; its
 * float code keeps subnormals anyway), so the build embeds one module per
 * shader and core/vk adds the mode where the device offers it.
 */
#include "pf_vk_internal.h"

#include <stdlib.h>
#include <string.h>

/* SPIR-V specification §2.3 and §3 (opcodes and enumerants, unified 1.6). */
#define SPIRV_VERSION_1_4 0x00010400u
#define OP_EXTENSION 10u
#define OP_MEMORY_MODEL 14u
#define OP_ENTRY_POINT 15u
#define OP_EXECUTION_MODE 16u
#define OP_CAPABILITY 17u
#define OP_EXECUTION_MODE_ID 331u
#define CAPABILITY_DENORM_PRESERVE 4464u
#define MODE_DENORM_PRESERVE 4459u
#define MODE_DENORM_FLUSH_TO_ZERO 4460u
/* Float controls are core from SPIR-V 1.4; older modules need the extension. */
static const char FLOAT_CONTROLS_EXTENSION[] = "SPV_KHR_float_controls";

static uint32_t opcode(uint32_t word) { return word & 0xffffu; }

/* What the patch needs to know of a module's leading sections. */
typedef struct module_layout {
    size_t after_capabilities; /* word index where the capabilities end */
    size_t after_entry_points; /* word index where the entry points end */
    int has_capability;
    int has_extension;
    uint32_t entry_ids[8];
    uint32_t entry_count;
    int entry_has_mode[8]; /* a 32-bit denormal mode is declared already */
} module_layout;

static int index_of_entry(const module_layout *layout, uint32_t id)
{
    for (uint32_t i = 0; i < layout->entry_count; i++)
        if (layout->entry_ids[i] == id)
            return (int)i;
    return -1;
}

static pf_status read_layout(const uint32_t *words, size_t count, module_layout *layout,
                             pf_error *err)
{
    memset(layout, 0, sizeof *layout);
    size_t at = PF_SPIRV_HEADER_WORDS;
    while (at < count) {
        uint32_t op = opcode(words[at]), n;
        pf_status status = pf_vk_spirv_instruction_words(words, count, at, &n, err);
        if (status != PF_OK)
            return status;
        if (op == OP_CAPABILITY) {
            layout->after_capabilities = at + n;
            layout->has_capability |= n == 2 && words[at + 1] == CAPABILITY_DENORM_PRESERVE;
        } else if (op == OP_EXTENSION) {
            layout->has_extension |=
                strncmp((const char *)&words[at + 1], FLOAT_CONTROLS_EXTENSION,
                        (n - 1) * sizeof *words) == 0;
        } else if (op == OP_ENTRY_POINT && n >= 3) {
            if (layout->entry_count == sizeof layout->entry_ids / sizeof *layout->entry_ids)
                return pf_error_set(err, PF_ERR_UNSUPPORTED,
                                    "SPIR-V module: more than %zu entry points",
                                    sizeof layout->entry_ids / sizeof *layout->entry_ids);
            layout->entry_ids[layout->entry_count++] = words[at + 2];
            layout->after_entry_points = at + n;
        } else if (op == OP_EXECUTION_MODE && n == 4 &&
                   (words[at + 2] == MODE_DENORM_PRESERVE ||
                    words[at + 2] == MODE_DENORM_FLUSH_TO_ZERO) &&
                   words[at + 3] == 32) {
            int entry = index_of_entry(layout, words[at + 1]);
            if (entry >= 0)
                layout->entry_has_mode[entry] = 1;
        } else if (op != OP_MEMORY_MODEL && op != OP_EXECUTION_MODE &&
                   op != OP_EXECUTION_MODE_ID && layout->entry_count) {
            break; /* past the execution modes: debug names, annotations, types */
        }
        at += n;
    }
    if (!layout->after_capabilities || !layout->entry_count)
        return pf_error_set(err, PF_ERR_FORMAT,
                            "SPIR-V module: no OpCapability or no OpEntryPoint");
    return PF_OK;
}

pf_status pf_vk_spirv_preserve_denormals(const uint32_t *words, size_t count, uint32_t **out,
                                         size_t *out_count, pf_error *err)
{
    *out = NULL;
    *out_count = 0;
    if (count < PF_SPIRV_HEADER_WORDS || words[0] != PF_SPIRV_MAGIC)
        return pf_error_set(err, PF_ERR_FORMAT, "not a SPIR-V module (%zu words)", count);
    module_layout layout;
    pf_status status = read_layout(words, count, &layout, err);
    if (status != PF_OK)
        return status;

    const size_t extension_words = 1 + (sizeof FLOAT_CONTROLS_EXTENSION + 3) / 4;
    int add_extension = words[1] < SPIRV_VERSION_1_4 && !layout.has_extension;
    size_t extra = (layout.has_capability ? 0 : 2) + (add_extension ? extension_words : 0) +
                   4 * layout.entry_count;
    uint32_t *patched = calloc(count + extra, sizeof *patched);
    if (!patched)
        return pf_error_set(err, PF_ERR_NOMEM, "SPIR-V module: out of host memory");

    size_t w = 0;
    memcpy(patched, words, layout.after_capabilities * sizeof *words);
    w = layout.after_capabilities;
    if (!layout.has_capability) {
        patched[w++] = 2u << 16 | OP_CAPABILITY;
        patched[w++] = CAPABILITY_DENORM_PRESERVE;
    }
    if (add_extension) {
        patched[w++] = (uint32_t)extension_words << 16 | OP_EXTENSION;
        memcpy(&patched[w], FLOAT_CONTROLS_EXTENSION, sizeof FLOAT_CONTROLS_EXTENSION);
        w += extension_words - 1; /* calloc'd: the string's padding is zero */
    }
    size_t middle = layout.after_entry_points - layout.after_capabilities;
    memcpy(&patched[w], &words[layout.after_capabilities], middle * sizeof *words);
    w += middle;
    for (uint32_t i = 0; i < layout.entry_count; i++) {
        if (layout.entry_has_mode[i])
            continue; /* the shader chose its 32-bit denormal behaviour itself */
        patched[w++] = 4u << 16 | OP_EXECUTION_MODE;
        patched[w++] = layout.entry_ids[i];
        patched[w++] = MODE_DENORM_PRESERVE;
        patched[w++] = 32;
    }
    size_t rest = count - layout.after_entry_points;
    memcpy(&patched[w], &words[layout.after_entry_points], rest * sizeof *words);
    w += rest;
    *out = patched;
    *out_count = w;
    return PF_OK;
}
