/*
 * core/lpv's propagation on the host (pf_lpv_propagate_host): what its
 * vector builds share. lpv_propagate_host.c lays the cascades out and runs
 * them; lpv_host_step_body.h is one iteration, built 4 lanes wide
 * (lpv_host_step_sse.c) and, on x86-64, 8 wide with AVX2
 * (lpv_host_step_avx2.c).
 *
 * A cascade on the host: 12 planes (R, G, B × 4 SH coefficients) of
 * (size + 2)³ floats, the cells surrounded by a layer of zeros, so a
 * neighbour outside the cascade is a zero source and adds nothing (the
 * kernel skips it) with no test per cell; the geometry volume likewise (a
 * face outside blocks nothing, as lpv_face_geometry's 0). The planes' rows
 * are interleaved: a row of cells is 12 consecutive rows of size + 2
 * floats, one per plane, so a run of cells and its neighbours are a few
 * sequential streams through memory instead of one per plane, which the
 * prefetcher keeps up with (bench/RESULTS.md).
 */
#ifndef PF_LPV_HOST_INTERNAL_H
#define PF_LPV_HOST_INTERNAL_H

#include "pf_lpv.h"

#include <stddef.h>
#include <stdint.h>

#define PF_LPV_HOST_PLANES 12u
#define PF_LPV_HOST_NEIGHBOURS 6
#define PF_LPV_HOST_FACES 5
#define PF_LPV_HOST_TRANSFERS (PF_LPV_HOST_NEIGHBOURS * PF_LPV_HOST_FACES)
/* Floats after a cascade's planes that a step may read: a run at a row's end reads a whole vector. */
#define PF_LPV_HOST_SLACK 8u

/* One (neighbour, face) transfer of lpv_propagate.comp's tables, (neighbour n, face f) at 5n + f. */
typedef struct pf_lpv_host_transfer {
    float basis[4];    /* SH basis of the direction from the neighbour's centre to the face */
    float blocking[4]; /* the basis of its reverse: the geometry volume's blocking */
    float lobe[4];     /* clamped-cosine lobe about the face's outward normal */
    float scale;       /* Δω_f / π */
} pf_lpv_host_transfer;

/* Floats of one cascade's planes, padding included. */
static inline size_t pf_lpv_host_floats(uint32_t size)
{
    size_t p = (size_t)size + 2u;
    return PF_LPV_HOST_PLANES * p * p * p;
}

/* Where cell (x, y, z)'s value is in plane 0; plane c's is size + 2 floats × c further. */
static inline size_t pf_lpv_host_index(uint32_t size, uint32_t x, uint32_t y, uint32_t z)
{
    size_t p = (size_t)size + 2u;
    return ((size_t)(z + 1u) * p + (y + 1u)) * PF_LPV_HOST_PLANES * p + (x + 1u);
}

/*
 * One iteration of one cascade: dst (its cells; the padding is left as it
 * is) from src and the geometry gv (NULL: no occlusion), then acc += dst
 * over the cells, in lpv_propagate.comp's order of operations.
 */
typedef void (*pf_lpv_host_step_fn)(const pf_lpv_host_transfer *transfers, const float *src,
                                    const float *gv, float *dst, float *acc, uint32_t size);
void pf_lpv_host_step_4(const pf_lpv_host_transfer *transfers, const float *src, const float *gv,
                        float *dst, float *acc, uint32_t size);
void pf_lpv_host_step_8(const pf_lpv_host_transfer *transfers, const float *src, const float *gv,
                        float *dst, float *acc, uint32_t size);

/* The step of width lanes (4 or 8) where it was built and this CPU runs it, else NULL. */
pf_lpv_host_step_fn pf_lpv_host_stepper(uint32_t width);

/*
 * pf_lpv_propagate_host with the step of a given width (tests: the widths
 * agree bit for bit). PF_ERR_INVALID when this build or CPU has no such step.
 */
pf_status pf_lpv_propagate_host_width(const pf_lpv_layout *layout, const float *injected,
                                      const float *gv, float *accumulated, float *snapshot,
                                      uint32_t width, pf_error *err);

#endif
