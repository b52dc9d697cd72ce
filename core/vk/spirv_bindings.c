/*
 * What each binding of a compute module is: a uniform texel buffer, a storage
 * buffer, or absent. A shader that reads a buffer through `usamplerBuffer` /
 * `samplerBuffer` gets the texel descriptor without the caller saying so. Why
 * texel buffers at all: llvmpipe (Mesa 22.x) loads a storage-buffer word lane
 * by lane in a branchy loop (~11 ns a word on this project's 2-core hosts),
 * where a texel fetch is one vector gather (~1 ns); the BIH traversal reads
 * three node words per step. Absent bindings exist because the build runs
 * spirv-opt, which removes the variables a kernel never reads: they are left
 * out of the pipeline's layout, so that a kernel is held to the device's
 * descriptor limits by what it uses, not by the shared binding numbers.
 */
#include "pf_vk_internal.h"

#include <stdlib.h>
#include <string.h>

/* SPIR-V specification §3 (opcodes, decorations, enumerants). */
#define OP_TYPE_INT 21u
#define OP_TYPE_FLOAT 22u
#define OP_TYPE_IMAGE 25u
#define OP_TYPE_SAMPLED_IMAGE 27u
#define OP_TYPE_POINTER 32u
#define OP_VARIABLE 59u
#define OP_DECORATE 71u
#define DECORATION_BINDING 33u
#define DECORATION_DESCRIPTOR_SET 34u
#define DIM_BUFFER 5u
#define STORAGE_UNIFORM_CONSTANT 0u

/* Per result id: what the walk needs of it. */
typedef struct id_info {
    uint8_t op;        /* the defining opcode's low byte, 0 if none seen */
    uint8_t texel;     /* image types: PF_VK_BINDING_TEXEL_* of a sampled buffer image */
    uint8_t is_signed; /* integer types: the Signedness operand */
    uint32_t target;   /* sampled image: its image; pointer: its pointee */
    int32_t binding;   /* variables: Binding, -1 if undecorated */
    int32_t set;       /* variables: DescriptorSet, 0 if undecorated */
} id_info;

pf_status pf_vk_spirv_binding_kinds(const uint32_t *words, size_t count, uint8_t *kinds,
                                    uint32_t binding_count, pf_error *err)
{
    memset(kinds, PF_VK_BINDING_ABSENT, binding_count);
    if (count < PF_SPIRV_HEADER_WORDS || words[0] != PF_SPIRV_MAGIC)
        return pf_error_set(err, PF_ERR_FORMAT, "not a SPIR-V module (%zu words)", count);
    uint32_t bound = words[3];
    id_info *ids = calloc(bound ? bound : 1, sizeof *ids);
    if (!ids)
        return pf_error_set(err, PF_ERR_NOMEM, "SPIR-V module: %u ids", bound);
    for (uint32_t i = 0; i < bound; i++)
        ids[i].binding = -1;
    uint32_t *variables = calloc(bound ? bound : 1, sizeof *variables);
    uint32_t variable_count = 0;
    pf_status status = variables ? PF_OK
                                 : pf_error_set(err, PF_ERR_NOMEM, "SPIR-V module: %u ids",
                                                bound);
    for (size_t at = PF_SPIRV_HEADER_WORDS; status == PF_OK && at < count;) {
        uint32_t op = words[at] & 0xffffu, n;
        if ((status = pf_vk_spirv_instruction_words(words, count, at, &n, err)) != PF_OK)
            break;
        const uint32_t *w = &words[at];
        /* Result ids of the instructions read here; a bad one is a malformed module. */
        uint32_t result = op == OP_VARIABLE && n >= 4   ? w[2]
                          : (op == OP_TYPE_INT || op == OP_TYPE_FLOAT || op == OP_TYPE_IMAGE ||
                             op == OP_TYPE_SAMPLED_IMAGE || op == OP_TYPE_POINTER) && n >= 2
                              ? w[1]
                              : 0;
        if (result >= bound || (op == OP_DECORATE && n >= 4 && w[1] >= bound)) {
            status = pf_error_set(err, PF_ERR_FORMAT, "SPIR-V module: id beyond the bound %u",
                                  bound);
            break;
        }
        switch (op) {
        case OP_TYPE_INT:
        case OP_TYPE_FLOAT:
            ids[result].op = (uint8_t)op;
            /* %r = OpTypeInt width signedness */
            ids[result].is_signed = op == OP_TYPE_INT && n >= 4 && w[3] == 1u;
            break;
        case OP_TYPE_IMAGE:
            ids[result].op = (uint8_t)op;
            /* %r = OpTypeImage %sampled_type Dim Depth Arrayed MS Sampled Format */
            if (n >= 9 && w[3] == DIM_BUFFER && w[7] == 1u && w[2] < bound)
                ids[result].texel = ids[w[2]].op != OP_TYPE_INT ? PF_VK_BINDING_TEXEL_FLOAT
                                    : ids[w[2]].is_signed  ? PF_VK_BINDING_TEXEL_INT4
                                                           : PF_VK_BINDING_TEXEL_UINT;
            break;
        case OP_TYPE_SAMPLED_IMAGE:
        case OP_TYPE_POINTER:
            ids[result].op = (uint8_t)op;
            ids[result].target = op == OP_TYPE_POINTER && n >= 4 ? w[3] : n >= 3 ? w[2] : 0;
            if (op == OP_TYPE_POINTER && (n < 4 || w[2] != STORAGE_UNIFORM_CONSTANT))
                ids[result].target = 0;
            break;
        case OP_VARIABLE:
            ids[result].op = (uint8_t)op;
            ids[result].target = w[1];
            variables[variable_count++] = result;
            break;
        case OP_DECORATE:
            if (n >= 4 && w[2] == DECORATION_BINDING)
                ids[w[1]].binding = (int32_t)w[3];
            else if (n >= 4 && w[2] == DECORATION_DESCRIPTOR_SET)
                ids[w[1]].set = (int32_t)w[3];
            break;
        default:
            break;
        }
        at += n;
    }
    for (uint32_t v = 0; status == PF_OK && v < variable_count; v++) {
        const id_info *variable = &ids[variables[v]];
        uint32_t pointer = variable->target;
        if (pointer >= bound || ids[pointer].op != OP_TYPE_POINTER || variable->set != 0 ||
            variable->binding < 0)
            continue;
        uint8_t kind = PF_VK_BINDING_STORAGE;
        uint32_t sampled = ids[pointer].target;
        if (sampled < bound && ids[sampled].op == OP_TYPE_SAMPLED_IMAGE &&
            ids[sampled].target < bound)
            kind = ids[ids[sampled].target].texel;
        if ((uint32_t)variable->binding >= binding_count) {
            status = pf_error_set(err, PF_ERR_INVALID,
                                  "%s buffer at binding %d, but the pipeline has %u bindings",
                                  kind == PF_VK_BINDING_STORAGE ? "storage" : "texel",
                                  variable->binding, binding_count);
            break;
        }
        kinds[variable->binding] = kind;
    }
    free(variables);
    free(ids);
    return status;
}
