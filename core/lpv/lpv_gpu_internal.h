/*
 * core/lpv's device side (pf_lpv.h): what its two files share. lpv_gpu.c
 * holds the volumes and propagates; lpv_inject_device.c injects the VPLs into
 * fixed-point sums that stay on the device, and turns them into the injected
 * volume at the start of the propagation that reads it.
 */
#ifndef PF_LPV_GPU_INTERNAL_H
#define PF_LPV_GPU_INTERNAL_H

#include "pf_lpv.h"

/* lpv_propagate.comp's ACCUMULATE values. */
#define PF_LPV_ACCUMULATE_MODES 3u
/* lpv_inject.comp's PASS values. */
#define PF_LPV_INJECT_PASSES 3u

struct pf_lpv {
    pf_vk_context *ctx;
    /* [ACCUMULATE][SNAPSHOT][FAR_FIELD], each created on first use (a layout needs 4 to 7). */
    pf_vk_pipeline *propagate[PF_LPV_ACCUMULATE_MODES][2][2];
    uint64_t floats; /* SH floats of one volume (0: none allocated) */
    int iterating;   /* the injected, ping and pong volumes exist too (the device path) */
    pf_lpv_site site;
    float *host_volumes;  /* the host path's accumulation, then its snapshot / far field */
    uint64_t host_floats; /* floats of each */
    /* snapshot: the accumulation after snapshot_iterations, and once a propagation is
     * done, the far field (accumulated − snapshot) that pf_lpv_far_fields gives. */
    pf_vk_buffer *injected, *ping, *pong, *accumulated, *geometry, *snapshot;

    /* The device injection (lpv_inject_device.c): one pipeline per pass, the 64-bit sums
     * of the last injection, its cascades and counters. */
    pf_vk_pipeline *inject[PF_LPV_INJECT_PASSES];
    pf_vk_buffer *sums, *inject_cascades, *inject_counters;
    uint64_t sums_floats;   /* floats the sums buffer holds room for */
    uint64_t summed_floats; /* floats of the layout the sums hold (0: no injection kept) */
    float summed_flux_scale;
};

/*
 * Makes the volumes the lookups read hold floats SH floats, and with iterating also
 * the ones the device's iterations use (injected, ping, pong); reallocating drops
 * what they held.
 */
pf_status pf_lpv_ensure_volumes(pf_lpv *lpv, uint64_t floats, int iterating, pf_error *err);

/*
 * Records the kept injection's sums turned into the injected, accumulation and snapshot
 * volumes (floats of them: the layout they were injected for), which a propagation
 * starts from. PF_ERR_INVALID when no injection of that size is kept.
 */
pf_status pf_lpv_record_resolve(pf_lpv *lpv, pf_vk_commands *cmds, uint64_t floats,
                                pf_error *err);

/* Frees the injection's buffers and pipelines (pf_lpv_destroy). */
void pf_lpv_inject_release(pf_lpv *lpv);

#endif
