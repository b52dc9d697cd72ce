/*
 * VPL injection on the device (pf_lpv_inject_photons in pf_lpv.h; the passes are
 * shaders/lpv_inject.comp's): the photon map's records go into 64-bit fixed-point sums
 * that stay on the device, and a propagation turns them into its starting volumes in
 * its own submission (pf_lpv_record_resolve). The photons are never read back.
 */
#include "lpv_gpu_internal.h"

#include <stdlib.h>
#include <string.h>

#define INJECT_BUFFERS 7u
#define GROUP_SIZE 64u
/* Workgroups of a pass at most: each invocation then loops over its share. */
#define MAX_GROUPS 4096u
#define PASS_CLEAR 0u
#define PASS_INJECT 1u
#define PASS_RESOLVE 2u
/* lpv_inject.comp's FIXED_ONE: the sums count units of 2^-24 of the map's flux unit. */
#define FIXED_ONE 16777216.0f

/* lpv_inject.comp's Push. */
typedef struct inject_push {
    uint32_t vpl_count, cascade_count, size, all_targets, float_count, stride;
    float offset_cells, resolve_scale;
} inject_push;

/* lpv_inject.comp's Counters (pf_lpv_inject_stats' figures). */
typedef struct inject_counters {
    uint32_t injected[PF_LPV_MAX_CASCADES];
    uint32_t outside, rejected;
} inject_counters;

void pf_lpv_inject_release(pf_lpv *lpv)
{
    pf_vk_buffer **all[] = {&lpv->sums, &lpv->inject_cascades, &lpv->inject_counters};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) {
        if (*all[i])
            pf_vk_buffer_destroy(lpv->ctx, *all[i]);
        *all[i] = NULL;
    }
    for (uint32_t pass = 0; pass < PF_LPV_INJECT_PASSES; pass++) {
        if (lpv->inject[pass])
            pf_vk_pipeline_destroy(lpv->ctx, lpv->inject[pass]);
        lpv->inject[pass] = NULL;
    }
    lpv->sums_floats = lpv->summed_floats = 0;
}

int pf_lpv_injects_on_device(const pf_lpv *lpv, const pf_lpv_layout *layout)
{
    const pf_vk_device_info *info = pf_vk_info(lpv->ctx);
    uint64_t floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    return info->has_int64 && info->has_int64_atomics && floats <= UINT32_MAX &&
           floats * sizeof(int64_t) <= info->max_storage_buffer_range;
}

static pf_status pass_pipeline(pf_lpv *lpv, uint32_t pass, pf_vk_pipeline **out, pf_error *err)
{
    if (!lpv->inject[pass]) {
        pf_vk_spec_constant spec = {0, pass};
        pf_status status = pf_vk_pipeline_create_named(lpv->ctx, "lpv_inject", INJECT_BUFFERS,
                                                       sizeof(inject_push), &spec, 1,
                                                       &lpv->inject[pass], err);
        if (status != PF_OK)
            return status;
    }
    *out = lpv->inject[pass];
    return PF_OK;
}

/* Room for floats sums, and the cascades' and counters' buffers. */
static pf_status ensure_sums(pf_lpv *lpv, uint64_t floats, pf_error *err)
{
    pf_status status = PF_OK;
    if (lpv->sums_floats < floats) {
        if (lpv->sums)
            pf_vk_buffer_destroy(lpv->ctx, lpv->sums);
        lpv->sums = NULL;
        lpv->sums_floats = lpv->summed_floats = 0;
        status = pf_vk_buffer_create(lpv->ctx, floats * sizeof(int64_t), "LPV injection sums",
                                     &lpv->sums, err);
        if (status == PF_OK)
            lpv->sums_floats = floats;
    }
    if (status == PF_OK && !lpv->inject_cascades)
        status = pf_vk_buffer_create(lpv->ctx, PF_LPV_MAX_CASCADES * 4 * sizeof(float),
                                     "LPV injection cascades", &lpv->inject_cascades, err);
    if (status == PF_OK && !lpv->inject_counters)
        status = pf_vk_buffer_create(lpv->ctx, sizeof(inject_counters),
                                     "LPV injection counters", &lpv->inject_counters, err);
    return status;
}

/* One pass over items (floats or VPLs) with every binding: the passes share one layout. */
static pf_status record_pass(pf_lpv *lpv, pf_vk_commands *cmds, uint32_t pass,
                             pf_vk_buffer *photons, pf_vk_buffer *const targets[3],
                             inject_push push, uint64_t items, pf_error *err)
{
    pf_vk_pipeline *pipeline = NULL;
    pf_status status = pass_pipeline(lpv, pass, &pipeline, err);
    uint64_t groups = (items + GROUP_SIZE - 1) / GROUP_SIZE;
    if (groups > MAX_GROUPS)
        groups = MAX_GROUPS;
    if (groups == 0)
        groups = 1; /* the clear pass zeroes the counters whatever the volume */
    push.stride = (uint32_t)groups * GROUP_SIZE;
    pf_vk_buffer *buffers[INJECT_BUFFERS] = {
        photons,    lpv->inject_cascades, lpv->sums, lpv->inject_counters,
        targets[0], targets[1],           targets[2]};
    if (status == PF_OK)
        status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, INJECT_BUFFERS, &push, sizeof push,
                                    (uint32_t)groups, 1, 1, err);
    pf_vk_cmd_barrier(cmds);
    return status;
}

pf_status pf_lpv_record_resolve(pf_lpv *lpv, pf_vk_commands *cmds, uint64_t floats,
                                pf_error *err)
{
    if (lpv->summed_floats != floats || !lpv->injected)
        return pf_error_set(err, PF_ERR_INVALID,
                            "LPV: no device injection kept for a volume of %llu floats",
                            (unsigned long long)floats);
    inject_push push = {.all_targets = 1,
                        .float_count = (uint32_t)floats,
                        .resolve_scale = lpv->summed_flux_scale / FIXED_ONE};
    pf_vk_buffer *targets[3] = {lpv->injected, lpv->accumulated, lpv->snapshot};
    /* The pass reads no photon: the sums stand in for the binding. */
    return record_pass(lpv, cmds, PASS_RESOLVE, lpv->sums, targets, push, floats, err);
}

pf_status pf_lpv_inject_photons(pf_lpv *lpv, const pf_lpv_layout *layout,
                                pf_vk_buffer *photons, uint32_t count, float flux_scale,
                                float *read_back, pf_lpv_inject_stats *stats, double *gpu_ms,
                                pf_error *err)
{
    memset(stats, 0, sizeof *stats);
    *gpu_ms = -1.0;
    if (!pf_lpv_injects_on_device(lpv, layout))
        return pf_error_set(err, PF_ERR_UNSUPPORTED,
                            "LPV injection on '%s': no 64-bit buffer atomics, or a volume "
                            "past one buffer",
                            pf_vk_info(lpv->ctx)->name);
    if (count > 0 && !photons)
        return pf_error_set(err, PF_ERR_INVALID, "LPV injection: %u VPLs and no photon map",
                            count);
    uint64_t floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    /* The host's propagation reads the volume back; the device's resolves it itself. */
    pf_status status = pf_lpv_ensure_volumes(lpv, floats, read_back == NULL, err);
    if (status == PF_OK)
        status = ensure_sums(lpv, floats, err);
    if (status != PF_OK)
        return status;
    lpv->summed_floats = 0;
    float cascades[PF_LPV_MAX_CASCADES][4] = {{0}};
    for (uint32_t k = 0; k < layout->count; k++) {
        memcpy(cascades[k], layout->cascades[k].origin, 3 * sizeof(float));
        cascades[k][3] = layout->cascades[k].cell_size;
    }
    inject_push push = {.vpl_count = count,
                        .cascade_count = layout->count,
                        .size = layout->size,
                        .float_count = (uint32_t)floats,
                        .offset_cells = layout->offset_cells,
                        .resolve_scale = flux_scale / FIXED_ONE};
    /* Bound where a pass writes nothing: the accumulation (always allocated). */
    pf_vk_buffer *unused[3] = {lpv->accumulated, lpv->accumulated, lpv->accumulated};
    pf_vk_buffer *source = count > 0 ? photons : lpv->sums;
    inject_counters counters;
    pf_vk_commands *cmds = NULL;
    status = pf_vk_commands_begin(lpv->ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, lpv->inject_cascades, 0, cascades, sizeof cascades, err);
    int begin = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = record_pass(lpv, cmds, PASS_CLEAR, source, unused, push, floats, err);
    if (status == PF_OK && count > 0)
        status = record_pass(lpv, cmds, PASS_INJECT, source, unused, push, count, err);
    /* For the host: the floats in the accumulation (which its propagation overwrites). */
    if (status == PF_OK && read_back)
        status = record_pass(lpv, cmds, PASS_RESOLVE, source, unused, push, floats, err);
    int end = status == PF_OK ? pf_vk_cmd_timestamp(cmds) : -1;
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, lpv->inject_counters, 0, &counters, sizeof counters,
                                    err);
    if (status == PF_OK && read_back)
        status = pf_vk_cmd_download(cmds, lpv->accumulated, 0, read_back,
                                    floats * sizeof(float), err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    if (status == PF_OK && begin >= 0 && end >= 0)
        *gpu_ms = pf_vk_commands_elapsed_ms(cmds, begin, end);
    pf_vk_commands_destroy(cmds);
    if (status != PF_OK) {
        pf_error_prefix(err, "LPV injection (%u VPLs, %u cascades of %u³)", count,
                        layout->count, layout->size);
        return status;
    }
    memcpy(stats->injected, counters.injected, sizeof stats->injected);
    stats->outside = counters.outside;
    stats->rejected = counters.rejected;
    lpv->summed_floats = floats;
    lpv->summed_flux_scale = flux_scale;
    return PF_OK;
}
