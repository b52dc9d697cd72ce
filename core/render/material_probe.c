/*
 * pf_material_probe: runs shaders/material_probe.comp, which calls the shared
 * material code (shaders/common/materials.glsl) on host-given inputs so that
 * tests check the very functions every integrator uses.
 */
#include "render_internal.h"

/* Workgroup size of material_probe.comp. */
#define PROBE_GROUP_SIZE 64u

pf_status pf_material_probe(pf_renderer *renderer, const pf_material_probe_query *queries,
                            uint32_t count, pf_material_probe_result *results, pf_error *err)
{
    if (!renderer || (count > 0 && (!queries || !results)))
        return pf_error_set(err, PF_ERR_INVALID, "pf_material_probe: NULL argument");
    if (count == 0)
        return PF_OK;
    pf_vk_context *ctx = renderer->ctx;
    pf_vk_buffer *buffers[3] = {NULL, NULL, NULL};
    uint64_t query_bytes = (uint64_t)count * sizeof *queries;
    uint64_t result_bytes = (uint64_t)count * sizeof *results;
    pf_status status = pf_render_buffer_with_data(ctx, "material probe queries", queries,
                                                  query_bytes, query_bytes, &buffers[0], err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(ctx, result_bytes, "material probe results", &buffers[1], err);
    if (status == PF_OK)
        status = pf_render_buffer_with_data(ctx, "sheen albedo", pf_sheen_albedo,
                                            sizeof pf_sheen_albedo, sizeof pf_sheen_albedo,
                                            &buffers[2], err);
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(ctx, &cmds, err);
    pf_vk_pipeline *probe = NULL;
    if (status == PF_OK)
        status = pf_renderer_pipeline(renderer, PF_PIPELINE_MATERIAL_PROBE, &probe, err);
    if (status == PF_OK) {
        status = pf_vk_cmd_dispatch(cmds, probe, buffers, 3, &count,
                                    sizeof count, (count + PROBE_GROUP_SIZE - 1) / PROBE_GROUP_SIZE,
                                    1, 1, err);
        if (status == PF_OK)
            status = pf_vk_commands_submit(cmds, err);
        pf_vk_commands_destroy(cmds);
    }
    if (status == PF_OK)
        status = pf_vk_buffer_download(ctx, buffers[1], 0, results, result_bytes, err);
    pf_render_buffer_release(ctx, &buffers[0]);
    pf_render_buffer_release(ctx, &buffers[1]);
    pf_render_buffer_release(ctx, &buffers[2]);
    if (status != PF_OK)
        pf_error_prefix(err, "material probe (%u queries)", count);
    return status;
}
