/*
 * The LPV's device side (pf_lpv.h): volumes for all cascades in one buffer
 * each (cascade k's cells start at k × size³), and the propagation of
 * shaders/lpv_propagate.comp, every cascade's iterations in one submission,
 * or on the host (lpv_propagate_host.c) with the results uploaded.
 */
#include "lpv_gpu_internal.h"

#include <stdlib.h>
#include <string.h>

#define PROPAGATE_BUFFERS 7u
#define SPEC_ACCUMULATE 0u
#define SPEC_SNAPSHOT 1u
#define SPEC_FAR_FIELD 2u
/* SPEC_ACCUMULATE's values (lpv_propagate.comp). */
#define ACCUMULATE_NONE 0u
#define ACCUMULATE_RESULT 1u
#define ACCUMULATE_SOURCE_AND_RESULT 2u
#define GROUP_EDGE 4u

typedef struct propagate_push {
    uint32_t size, base, occlusion;
} propagate_push;

pf_status pf_lpv_create(pf_vk_context *ctx, pf_lpv **out, pf_error *err)
{
    *out = NULL;
    pf_lpv *lpv = calloc(1, sizeof *lpv);
    if (!lpv)
        return pf_error_set(err, PF_ERR_NOMEM, "LPV: out of memory");
    lpv->ctx = ctx;
    *out = lpv;
    return PF_OK;
}

/* The propagation pipeline of one ACCUMULATE mode, with or without SNAPSHOT and FAR_FIELD. */
static pf_status propagate_pipeline(pf_lpv *lpv, uint32_t accumulate, int snapshot, int far,
                                    pf_vk_pipeline **out, pf_error *err)
{
    pf_vk_pipeline **slot = &lpv->propagate[accumulate][snapshot != 0][far != 0];
    if (!*slot) {
        pf_vk_spec_constant spec[3] = {{SPEC_ACCUMULATE, accumulate},
                                       {SPEC_SNAPSHOT, snapshot != 0},
                                       {SPEC_FAR_FIELD, far != 0}};
        pf_status status = pf_vk_pipeline_create_named(lpv->ctx, "lpv_propagate",
                                                       PROPAGATE_BUFFERS, sizeof(propagate_push),
                                                       spec, 3, slot, err);
        if (status != PF_OK)
            return status;
    }
    *out = *slot;
    return PF_OK;
}

static void release_volumes(pf_lpv *lpv)
{
    pf_vk_buffer **all[] = {&lpv->injected, &lpv->ping,     &lpv->pong,
                            &lpv->accumulated, &lpv->geometry, &lpv->snapshot};
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++) {
        if (*all[i])
            pf_vk_buffer_destroy(lpv->ctx, *all[i]);
        *all[i] = NULL;
    }
    lpv->floats = 0;
    lpv->iterating = 0;
}

void pf_lpv_destroy(pf_lpv *lpv)
{
    if (!lpv)
        return;
    release_volumes(lpv);
    pf_lpv_inject_release(lpv);
    free(lpv->host_volumes);
    for (uint32_t mode = 0; mode < PF_LPV_ACCUMULATE_MODES; mode++)
        for (int snapshot = 0; snapshot < 2; snapshot++)
            for (int far = 0; far < 2; far++)
                if (lpv->propagate[mode][snapshot][far])
                    pf_vk_pipeline_destroy(lpv->ctx, lpv->propagate[mode][snapshot][far]);
    free(lpv);
}

/* The volumes (lpv_gpu_internal.h): the accumulation, the snapshot, and a geometry volume of
 * a third of that, and with iterating the injected, ping and pong volumes. The host path
 * iterates in its own memory, so on a CPU device it allocates only the first three. */
pf_status pf_lpv_ensure_volumes(pf_lpv *lpv, uint64_t floats, int iterating, pf_error *err)
{
    if (lpv->floats == floats && (lpv->iterating || !iterating))
        return PF_OK;
    release_volumes(lpv);
    uint64_t bytes = floats * sizeof(float);
    uint64_t gv_bytes = bytes / PF_LPV_FLOATS_PER_CELL * PF_LPV_GV_FLOATS_PER_CELL;
    pf_status status = PF_OK;
    if (iterating) {
        status = pf_vk_buffer_create(lpv->ctx, bytes, "LPV injected volume", &lpv->injected,
                                     err);
        if (status == PF_OK)
            status = pf_vk_buffer_create(lpv->ctx, bytes, "LPV ping volume", &lpv->ping, err);
        if (status == PF_OK)
            status = pf_vk_buffer_create(lpv->ctx, bytes, "LPV pong volume", &lpv->pong, err);
    }
    if (status == PF_OK)
        status = pf_vk_buffer_create(lpv->ctx, bytes, "LPV accumulation volume",
                                     &lpv->accumulated, err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(lpv->ctx, gv_bytes, "LPV geometry volume", &lpv->geometry,
                                     err);
    if (status == PF_OK)
        status = pf_vk_buffer_create(lpv->ctx, bytes, "LPV snapshot / far-field volume",
                                     &lpv->snapshot, err);
    if (status != PF_OK) {
        release_volumes(lpv);
        return status;
    }
    lpv->floats = floats;
    lpv->iterating = iterating;
    return PF_OK;
}

/* floats zeros into buffer from float first on. */
/* Zeros into floats floats of buffer from first, recorded with cmds (issue 44). */
static pf_status record_zeros(pf_vk_commands *cmds, pf_vk_buffer *buffer, uint64_t first,
                              uint64_t floats, pf_error *err)
{
    void *zeros = calloc(floats, sizeof(float));
    if (!zeros)
        return pf_error_set(err, PF_ERR_NOMEM, "LPV: out of memory");
    pf_status status = pf_vk_cmd_upload(cmds, buffer, first * sizeof(float), zeros,
                                        floats * sizeof(float), err);
    free(zeros);
    return status;
}

/*
 * Records gv's upload, or zeros' when gv is NULL (no occlusion: the propagation skips
 * it, and the lookups see every face open).
 */
static pf_status record_geometry(pf_lpv *lpv, pf_vk_commands *cmds, const float *gv,
                                 pf_error *err)
{
    uint64_t bytes = pf_vk_buffer_size(lpv->geometry);
    if (gv)
        return pf_vk_cmd_upload(cmds, lpv->geometry, 0, gv, bytes, err);
    return record_zeros(cmds, lpv->geometry, 0, bytes / sizeof(float), err);
}

/*
 * Sizes the volumes for floats SH floats and begins a command buffer with the uploads
 * recorded: the injected volume (also as the accumulation and the 0-iteration snapshot
 * when accumulate; injected NULL: the kept device injection resolved into the three
 * instead) and the geometry volume. The propagation's dispatches follow in the same
 * submission.
 */
static pf_status begin_propagation(pf_lpv *lpv, uint64_t floats, const float *injected,
                                   const float *gv, int accumulate, pf_vk_commands **cmds,
                                   pf_error *err)
{
    uint64_t bytes = floats * sizeof(float);
    pf_status status = pf_lpv_ensure_volumes(lpv, floats, 1, err);
    if (status == PF_OK)
        status = pf_vk_commands_begin(lpv->ctx, cmds, err);
    pf_vk_buffer *targets[3] = {lpv->injected, lpv->accumulated, lpv->snapshot};
    if (status == PF_OK && !injected) /* the device injection's sums, kept on the device */
        status = accumulate ? pf_lpv_record_resolve(lpv, *cmds, floats, err)
                            : pf_error_set(err, PF_ERR_INVALID, "LPV: no injected volume");
    for (int t = 0; status == PF_OK && injected && t < (accumulate ? 3 : 1); t++)
        status = pf_vk_cmd_upload(*cmds, targets[t], 0, injected, bytes, err);
    if (status == PF_OK)
        status = record_geometry(lpv, *cmds, gv, err);
    if (status != PF_OK) {
        pf_vk_commands_destroy(*cmds);
        *cmds = NULL;
    }
    return status;
}

/*
 * How iteration i (from 1) of a cascade of n iterations, snapshot after
 * snapshot_at, adds to the accumulation: in pairs, the second of two
 * iterations adding the first's result (its source) and its own, so half
 * the iterations store no accumulation. An iteration whose accumulated value
 * is read (the snapshot, the last) adds its own alone when the one before it
 * was already added. *pending says whether the last result is not yet in.
 */
static uint32_t accumulate_mode(uint32_t i, uint32_t n, uint32_t snapshot_at, int *pending)
{
    if (*pending) {
        *pending = 0;
        return ACCUMULATE_SOURCE_AND_RESULT;
    }
    if (i == snapshot_at || i == n)
        return ACCUMULATE_RESULT;
    *pending = 1;
    return ACCUMULATE_NONE;
}

void pf_lpv_set_site(pf_lpv *lpv, pf_lpv_site site)
{
    lpv->site = site;
}

int pf_lpv_propagates_on_host(const pf_lpv *lpv)
{
    if (lpv->site != PF_LPV_SITE_AUTO)
        return lpv->site == PF_LPV_SITE_HOST;
    return pf_vk_device_is_cpu(lpv->ctx);
}

/* The iterations on the host, then the volumes the lookups read uploaded. */
static pf_status propagate_on_host(pf_lpv *lpv, const pf_lpv_layout *layout,
                                   const float *injected, const float *gv, uint64_t floats,
                                   pf_error *err)
{
    pf_status status = pf_lpv_ensure_volumes(lpv, floats, 0, err);
    if (status == PF_OK && lpv->host_floats != floats) {
        free(lpv->host_volumes);
        lpv->host_floats = 0;
        lpv->host_volumes = malloc(2u * floats * sizeof(float));
        if (!lpv->host_volumes)
            return pf_error_set(err, PF_ERR_NOMEM, "LPV: out of memory");
        lpv->host_floats = floats;
    }
    float *accumulated = lpv->host_volumes, *far = lpv->host_volumes + floats;
    if (status == PF_OK)
        status = pf_lpv_propagate_host(layout, injected, gv, accumulated, far, err);
    /* The snapshot into the far field, the same subtraction as the kernel's FAR_FIELD. */
    for (uint64_t i = 0; status == PF_OK && i < floats; i++)
        far[i] = accumulated[i] - far[i];
    /* The three volumes' uploads in one submission (issue 44). */
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = pf_vk_commands_begin(lpv->ctx, &cmds, err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, lpv->accumulated, 0, accumulated,
                                  floats * sizeof(float), err);
    if (status == PF_OK)
        status = pf_vk_cmd_upload(cmds, lpv->snapshot, 0, far, floats * sizeof(float), err);
    if (status == PF_OK)
        status = record_geometry(lpv, cmds, gv, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    return status;
}

pf_status pf_lpv_propagate(pf_lpv *lpv, const pf_lpv_layout *layout, const float *injected,
                           const float *gv, pf_lpv_propagate_stats *stats, pf_error *err)
{
    pf_lpv_propagate_stats local;
    if (!stats)
        stats = &local;
    memset(stats, 0, sizeof *stats);
    stats->gpu_ms = -1.0;
    for (uint32_t k = 0; k < PF_LPV_MAX_CASCADES; k++)
        stats->cascade_gpu_ms[k] = -1.0;
    uint64_t floats = pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL);
    uint64_t cells = (uint64_t)layout->size * layout->size * layout->size;
    for (uint32_t k = 0; k < layout->count; k++)
        stats->cell_updates += cells * layout->cascades[k].iterations;
    if (pf_lpv_propagates_on_host(lpv)) {
        if (!injected)
            return pf_error_set(err, PF_ERR_INVALID,
                                "LPV: the host's propagation needs the injected volume on the host");
        stats->on_host = 1;
        return propagate_on_host(lpv, layout, injected, gv, floats, err);
    }
    pf_vk_commands *cmds = NULL;
    pf_status status = begin_propagation(lpv, floats, injected, gv, 1, &cmds, err);
    if (status != PF_OK)
        return status;
    uint32_t groups = (layout->size + GROUP_EDGE - 1) / GROUP_EDGE;
    /* A cascade without iterations has no last one to make its far field: none, zeros. */
    for (uint32_t k = 0; status == PF_OK && k < layout->count; k++)
        if (layout->cascades[k].iterations == 0)
            status = record_zeros(cmds, lpv->snapshot, k * cells * PF_LPV_FLOATS_PER_CELL,
                                  cells * PF_LPV_FLOATS_PER_CELL, err);
    int stamps[PF_LPV_MAX_CASCADES + 1];
    stamps[0] = pf_vk_cmd_timestamp(cmds);
    for (uint32_t k = 0; status == PF_OK && k < layout->count; k++) {
        propagate_push push = {layout->size, (uint32_t)(k * cells), gv != NULL};
        pf_vk_buffer *source = lpv->injected;
        const pf_lpv_cascade *cascade = &layout->cascades[k];
        int pending = 0; /* the injection is in the accumulation from the start */
        for (uint32_t i = 0; status == PF_OK && i < cascade->iterations; i++) {
            pf_vk_buffer *destination = (i % 2u == 0) ? lpv->ping : lpv->pong;
            /* Bindings 5 and 6: the accumulation and the snapshot again, read as texels
             * (lpv_propagate.comp). */
            pf_vk_buffer *buffers[PROPAGATE_BUFFERS] = {
                source,        destination,      lpv->accumulated, lpv->geometry,
                lpv->snapshot, lpv->accumulated, lpv->snapshot};
            int snapshot = i + 1u == cascade->snapshot_iterations;
            int far = i + 1u == cascade->iterations;
            uint32_t mode = accumulate_mode(i + 1u, cascade->iterations,
                                            cascade->snapshot_iterations, &pending);
            pf_vk_pipeline *pipeline = NULL;
            status = propagate_pipeline(lpv, mode, snapshot, far, &pipeline, err);
            if (status == PF_OK)
                status = pf_vk_cmd_dispatch(cmds, pipeline, buffers, PROPAGATE_BUFFERS, &push,
                                            sizeof push, groups, groups, groups, err);
            pf_vk_cmd_barrier(cmds);
            source = destination;
        }
        stamps[k + 1] = pf_vk_cmd_timestamp(cmds);
    }
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    for (uint32_t k = 0; status == PF_OK && k < layout->count; k++)
        stats->cascade_gpu_ms[k] = pf_vk_commands_elapsed_ms(cmds, stamps[k], stamps[k + 1]);
    if (status == PF_OK && layout->count > 0)
        stats->gpu_ms = pf_vk_commands_elapsed_ms(cmds, stamps[0], stamps[layout->count]);
    pf_vk_commands_destroy(cmds);
    if (status != PF_OK)
        pf_error_prefix(err, "LPV propagation (%u cascades of %u³)", layout->count, layout->size);
    return status;
}

pf_vk_buffer *pf_lpv_accumulated(const pf_lpv *lpv)
{
    return lpv->floats ? lpv->accumulated : NULL;
}

pf_vk_buffer *pf_lpv_far_fields(const pf_lpv *lpv)
{
    return lpv->floats ? lpv->snapshot : NULL;
}

pf_vk_buffer *pf_lpv_geometry(const pf_lpv *lpv)
{
    return lpv->floats ? lpv->geometry : NULL;
}

pf_status pf_lpv_download(pf_lpv *lpv, float *out, uint64_t floats, pf_error *err)
{
    if (!lpv->floats || floats > lpv->floats)
        return pf_error_set(err, PF_ERR_INVALID, "LPV download of %llu floats: volume holds %llu",
                            (unsigned long long)floats, (unsigned long long)lpv->floats);
    return pf_vk_buffer_download(lpv->ctx, lpv->accumulated, 0, out, floats * sizeof(float),
                                 err);
}

pf_status pf_lpv_propagate_once(pf_lpv *lpv, uint32_t size, const float *src, const float *gv,
                                float *dst, pf_error *err)
{
    pf_vk_pipeline *once = NULL;
    pf_status status = propagate_pipeline(lpv, ACCUMULATE_NONE, 0, 0, &once, err);
    uint64_t floats = (uint64_t)size * size * size * PF_LPV_FLOATS_PER_CELL;
    uint64_t bytes = floats * sizeof(float);
    pf_vk_commands *cmds = NULL;
    if (status == PF_OK)
        status = begin_propagation(lpv, floats, src, gv, 0, &cmds, err);
    if (status != PF_OK)
        return status;
    uint32_t groups = (size + GROUP_EDGE - 1) / GROUP_EDGE;
    propagate_push push = {size, 0, gv != NULL};
    pf_vk_buffer *buffers[PROPAGATE_BUFFERS] = {lpv->injected, lpv->ping,     lpv->accumulated,
                                                lpv->geometry, lpv->snapshot, lpv->accumulated,
                                                lpv->snapshot};
    status = pf_vk_cmd_dispatch(cmds, once, buffers, PROPAGATE_BUFFERS, &push,
                                sizeof push, groups, groups, groups, err);
    if (status == PF_OK)
        status = pf_vk_cmd_download(cmds, lpv->ping, 0, dst, bytes, err);
    if (status == PF_OK)
        status = pf_vk_commands_submit(cmds, err);
    pf_vk_commands_destroy(cmds);
    return status;
}
