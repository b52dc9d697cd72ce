/*
 * The one GPU prefix sum (shaders/prefix_sum.comp, pf_bih.h): three dispatches over one
 * buffer whose words after the data hold the blocks' sums, so that every workgroup of the
 * device takes part however long the array (one workgroup scanning alone was most of an
 * H200's 8.7 ms BIH build of 1M triangles).
 */
#include "bih_internal.h"

/* prefix_sum.comp's entries per workgroup (256 invocations of 16) and modes. */
#define PREFIX_SUM_BLOCK 4096u
enum { PREFIX_SUM_REDUCE, PREFIX_SUM_BLOCK_SUMS, PREFIX_SUM_SCAN };

/* One block at least: count 0 still writes its total. */
static uint32_t blocks_for(uint32_t count)
{
    uint32_t blocks = (uint32_t)(((uint64_t)count + PREFIX_SUM_BLOCK - 1) / PREFIX_SUM_BLOCK);
    return blocks ? blocks : 1;
}

uint64_t pf_bih_prefix_sum_words(uint32_t count)
{
    return (uint64_t)count + 1 + blocks_for(count);
}

pf_status pf_bih_prefix_sum_pipeline(pf_vk_context *ctx, pf_vk_pipeline **out, pf_error *err)
{
    return pf_vk_pipeline_create_named(ctx, "prefix_sum", 1, 2 * sizeof(uint32_t), NULL, 0, out,
                                       err);
}

pf_status pf_bih_prefix_sum_record(pf_vk_commands *cmds, pf_vk_pipeline *pipeline,
                                   pf_vk_buffer *data, uint32_t count, pf_error *err)
{
    uint64_t words = pf_bih_prefix_sum_words(count);
    if (pf_vk_buffer_size(data) < 4 * words)
        return pf_error_set(err, PF_ERR_INVALID,
                            "prefix sum of %u entries: the buffer holds %llu bytes, it needs "
                            "%llu (pf_bih_prefix_sum_words)",
                            count, (unsigned long long)pf_vk_buffer_size(data),
                            (unsigned long long)(4 * words));
    uint32_t blocks = blocks_for(count);
    uint32_t push[2] = {count, PREFIX_SUM_REDUCE};
    pf_status status = pf_vk_cmd_dispatch(cmds, pipeline, &data, 1, push, sizeof push, blocks,
                                          1, 1, err);
    push[1] = PREFIX_SUM_BLOCK_SUMS;
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, pipeline, &data, 1, push, sizeof push, 1, 1, 1, err);
    push[1] = PREFIX_SUM_SCAN;
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, pipeline, &data, 1, push, sizeof push, blocks, 1, 1,
                                    err);
    return status;
}
