/*
 * The BIH build's GPU radix sort as a reusable recorder (pf_bih_sort_record
 * in pf_bih.h): the same three shaders and pass order as bih_gpu_build.c's
 * Morton-code sort, for any (key, value) arrays.
 */
#include "bih_internal.h"

#include <stdlib.h>

/* bih_radix_*.comp: 256 invocations per workgroup, one 8-bit digit each. */
#define SORT_GROUP_SIZE 256u
#define SORT_DIGIT_BITS 8u
#define SORT_BINS (1u << SORT_DIGIT_BITS)

enum { SORT_HISTOGRAM, SORT_SCAN, SORT_SCATTER, SORT_PASSES };

static const struct {
    const char *shader;
    uint32_t buffers;
    uint32_t push_bytes;
} sort_pass[SORT_PASSES] = {
    {"bih_radix_histogram", 2, 12},
    {"prefix_sum", 1, 8},
    {"bih_radix_scatter", 5, 12},
};

struct pf_bih_sorter {
    pf_vk_context *ctx;
    pf_vk_pipeline *pipelines[SORT_PASSES];
};

pf_status pf_bih_sorter_create(pf_vk_context *ctx, pf_bih_sorter **out, pf_error *err)
{
    *out = NULL;
    pf_bih_sorter *sorter = calloc(1, sizeof *sorter);
    if (!sorter)
        return pf_error_set(err, PF_ERR_NOMEM, "GPU radix sorter: out of memory");
    sorter->ctx = ctx;
    for (int i = 0; i < SORT_PASSES; i++) {
        pf_status status = pf_vk_pipeline_create_named(ctx, sort_pass[i].shader,
                                                       sort_pass[i].buffers,
                                                       sort_pass[i].push_bytes, NULL, 0,
                                                       &sorter->pipelines[i], err);
        if (status != PF_OK) {
            pf_bih_sorter_destroy(sorter);
            return status;
        }
    }
    *out = sorter;
    return PF_OK;
}

void pf_bih_sorter_destroy(pf_bih_sorter *sorter)
{
    if (!sorter)
        return;
    for (int i = 0; i < SORT_PASSES; i++) {
        if (sorter->pipelines[i])
            pf_vk_pipeline_destroy(sorter->ctx, sorter->pipelines[i]);
    }
    free(sorter);
}

static uint32_t sort_groups(uint32_t count)
{
    return (count + SORT_GROUP_SIZE - 1) / SORT_GROUP_SIZE;
}

uint64_t pf_bih_sort_histogram_bytes(uint32_t count)
{
    /* One count per (digit, workgroup), and the prefix sum's total and block sums. */
    uint32_t groups = sort_groups(count);
    return 4 * pf_bih_prefix_sum_words(SORT_BINS * (groups ? groups : 1));
}

pf_status pf_bih_sort_record(pf_bih_sorter *sorter, pf_vk_commands *cmds, pf_vk_buffer *keys[2],
                             pf_vk_buffer *values[2], pf_vk_buffer *histogram, uint32_t count,
                             uint32_t key_bits, pf_error *err)
{
    if (key_bits == 0 || key_bits > 32)
        return pf_error_set(err, PF_ERR_INVALID, "GPU radix sort: %u key bits (1..32)", key_bits);
    uint32_t groups = sort_groups(count);
    const pf_vk_device_info *info = pf_vk_info(sorter->ctx);
    if (groups > info->max_workgroup_count[0])
        return pf_error_set(err, PF_ERR_LIMIT,
                            "GPU radix sort: %u keys need %u workgroups; device '%s' allows %u",
                            count, groups, info->name, info->max_workgroup_count[0]);
    if (count == 0)
        return PF_OK;
    uint32_t passes = (key_bits + SORT_DIGIT_BITS - 1) / SORT_DIGIT_BITS;
    passes += passes % 2; /* even: the result lands back in keys[0] / values[0] */
    pf_status status = PF_OK;
    for (uint32_t pass = 0; status == PF_OK && pass < passes; pass++) {
        pf_vk_cmd_barrier(cmds);
        int from = (int)(pass % 2);
        uint32_t push[3] = {count, pass * SORT_DIGIT_BITS, groups};
        pf_vk_buffer *histogram_buffers[] = {keys[from], histogram};
        status = pf_vk_cmd_dispatch(cmds, sorter->pipelines[SORT_HISTOGRAM], histogram_buffers, 2,
                                    push, sizeof push, groups, 1, 1, err);
        if (status == PF_OK)
            status = pf_bih_prefix_sum_record(cmds, sorter->pipelines[SORT_SCAN], histogram,
                                              SORT_BINS * groups, err);
        pf_vk_buffer *scatter_buffers[] = {keys[from], values[from], keys[1 - from],
                                           values[1 - from], histogram};
        if (status == PF_OK)
            status = pf_vk_cmd_dispatch(cmds, sorter->pipelines[SORT_SCATTER], scatter_buffers, 5,
                                        push, sizeof push, groups, 1, 1, err);
    }
    pf_vk_cmd_barrier(cmds);
    return status;
}
