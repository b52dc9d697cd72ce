/*
 * The propagation on the host (pf_lpv.h, pf_lpv_propagate_host): the rule
 * of shaders/lpv_propagate.comp, with its transfer tables evaluated here
 * from the same definition, for a device that is the CPU anyway
 * (lavapipe). There the kernel's stores and texel fetches are loops over
 * the lanes; here every load and store is a plain vector one
 * (lpv_host_internal.h has the layout, bench/RESULTS.md the figures).
 */
#include "lpv_host_internal.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static pf_lpv_host_transfer transfers[PF_LPV_HOST_TRANSFERS];
static pthread_once_t transfers_once = PTHREAD_ONCE_INIT;

/*
 * Neighbour n = 2k + (s > 0) is q = d − s·e_k, the light flowing along a =
 * s·e_k into d; face 0 is the one opposite q (outward normal a), faces 1..4
 * the sides with outward normals +e_{k+1}, −e_{k+1}, +e_{k+2}, −e_{k+2}
 * (axes mod 3), seen from q's centre along (2a + b)/√5: the kernel's table,
 * entry for entry, so both sum in the same order.
 */
static void make_transfers(void)
{
    for (int n = 0; n < PF_LPV_HOST_NEIGHBOURS; n++) {
        int k = n / 2;
        double a[3] = {0, 0, 0};
        a[k] = (n & 1) ? 1.0 : -1.0;
        for (int f = 0; f < PF_LPV_HOST_FACES; f++) {
            double normal[3] = {a[0], a[1], a[2]}, direction[3] = {a[0], a[1], a[2]};
            double solid_angle = PF_LPV_SOLID_ANGLE_FRONT;
            if (f > 0) {
                double b[3] = {0, 0, 0};
                b[(k + 1 + (f - 1) / 2) % 3] = (f % 2) ? 1.0 : -1.0;
                for (int i = 0; i < 3; i++) {
                    normal[i] = b[i];
                    direction[i] = (2.0 * a[i] + b[i]) / sqrt(5.0);
                }
                solid_angle = PF_LPV_SOLID_ANGLE_SIDE;
            }
            pf_lpv_host_transfer *t = &transfers[PF_LPV_HOST_FACES * n + f];
            float towards[3], back[3], outward[3];
            for (int i = 0; i < 3; i++) {
                towards[i] = (float)direction[i];
                back[i] = (float)-direction[i];
                outward[i] = (float)normal[i];
            }
            pf_sh_basis(towards, t->basis);
            pf_sh_basis(back, t->blocking);
            pf_sh_cosine_lobe(outward, t->lobe);
            t->scale = (float)(solid_angle / 3.14159265358979323846);
        }
    }
}

pf_lpv_host_step_fn pf_lpv_host_stepper(uint32_t width)
{
    if (width == 4)
        return pf_lpv_host_step_4;
#if defined(PF_LPV_AVX2_STEP)
    /* The 8-wide build's code is AVX2 throughout: only where the CPU (and its OS) runs it. */
    if (width == 8 && __builtin_cpu_supports("avx2"))
        return pf_lpv_host_step_8;
#endif
    return NULL;
}

/*
 * Between cascade-major cells, 12 floats each (the device's layout), and
 * planes: into the planes when into_planes, else back out of them.
 */
static void copy_cells(uint32_t size, const float *from, float *to, int into_planes)
{
    size_t i = 0, plane = (size_t)size + 2u;
    for (uint32_t z = 0; z < size; z++)
        for (uint32_t y = 0; y < size; y++)
            for (uint32_t x = 0; x < size; x++, i++) {
                size_t at = pf_lpv_host_index(size, x, y, z);
                for (uint32_t c = 0; c < PF_LPV_HOST_PLANES; c++) {
                    size_t cell = i * PF_LPV_HOST_PLANES + c, in_plane = at + c * plane;
                    if (into_planes)
                        to[in_plane] = from[cell];
                    else
                        to[cell] = from[in_plane];
                }
            }
}

typedef struct cascade_job {
    const pf_lpv_layout *layout;
    const float *injected, *gv;
    float *accumulated, *snapshot;
    pf_lpv_host_step_fn step;
    uint32_t first, stride; /* the cascades first, first + stride, … */
    int failed;
} cascade_job;

/* One cascade's iterations: ping-pong planes, the accumulation, its snapshot. */
static int propagate_cascade(const cascade_job *job, uint32_t k)
{
    uint32_t size = job->layout->size;
    size_t cells = (size_t)size * size * size;
    size_t floats = pf_lpv_host_floats(size) + PF_LPV_HOST_SLACK;
    size_t offset = (size_t)k * cells * PF_LPV_FLOATS_PER_CELL;
    float *ping = calloc(floats, sizeof(float)), *pong = calloc(floats, sizeof(float));
    float *acc = calloc(floats, sizeof(float));
    float *gv = job->gv ? calloc(floats, sizeof(float)) : NULL;
    int ok = ping && pong && acc && (gv || !job->gv);
    if (ok) {
        copy_cells(size, job->injected + offset, ping, 1);
        copy_cells(size, job->injected + offset, acc, 1);
        if (gv)
            copy_cells(size, job->gv + (size_t)k * cells * PF_LPV_GV_FLOATS_PER_CELL, gv, 1);
        const pf_lpv_cascade *cascade = &job->layout->cascades[k];
        float *src = ping, *dst = pong;
        for (uint32_t i = 1; i <= cascade->iterations; i++) {
            job->step(transfers, src, gv, dst, acc, size);
            if (i == cascade->snapshot_iterations)
                copy_cells(size, acc, job->snapshot + offset, 0);
            float *swap = src;
            src = dst;
            dst = swap;
        }
        copy_cells(size, acc, job->accumulated + offset, 0);
    }
    free(ping);
    free(pong);
    free(acc);
    free(gv);
    return ok;
}

static void *cascade_entry(void *arg)
{
    cascade_job *job = arg;
    for (uint32_t k = job->first; k < job->layout->count; k += job->stride)
        if (!propagate_cascade(job, k))
            job->failed = 1;
    return NULL;
}

pf_status pf_lpv_propagate_host_width(const pf_lpv_layout *layout, const float *injected,
                                      const float *gv, float *accumulated, float *snapshot,
                                      uint32_t width, pf_error *err)
{
    pf_lpv_host_step_fn step = pf_lpv_host_stepper(width);
    if (!step)
        return pf_error_set(err, PF_ERR_INVALID,
                            "LPV propagation on the host: no %u-wide step on this CPU", width);
    pthread_once(&transfers_once, make_transfers);
    memcpy(snapshot, injected,
           pf_lpv_volume_floats(layout, PF_LPV_FLOATS_PER_CELL) * sizeof(float));
    /* The cascades are independent: one thread each, up to one per online CPU. */
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    uint32_t threads = online > 1 ? (uint32_t)online : 1u;
    if (threads > layout->count)
        threads = layout->count;
    if (threads > PF_LPV_MAX_CASCADES)
        threads = PF_LPV_MAX_CASCADES;
    if (threads == 0)
        threads = 1; /* no cascade: the job below runs none */
    cascade_job jobs[PF_LPV_MAX_CASCADES];
    pthread_t handles[PF_LPV_MAX_CASCADES];
    int started[PF_LPV_MAX_CASCADES] = {0};
    for (uint32_t t = 0; t < threads; t++) {
        jobs[t] = (cascade_job){layout, injected, gv, accumulated, snapshot, step, t, threads, 0};
        if (t > 0)
            started[t] = pthread_create(&handles[t], NULL, cascade_entry, &jobs[t]) == 0;
    }
    cascade_entry(&jobs[0]);
    int failed = jobs[0].failed;
    for (uint32_t t = 1; t < threads; t++) {
        /* A thread that did not start: its cascades run here instead. */
        if (started[t])
            pthread_join(handles[t], NULL);
        else
            cascade_entry(&jobs[t]);
        failed |= jobs[t].failed;
    }
    if (failed)
        return pf_error_set(err, PF_ERR_NOMEM,
                            "LPV propagation on the host (%u cascades of %u³): out of memory",
                            layout->count, layout->size);
    return PF_OK;
}

pf_status pf_lpv_propagate_host(const pf_lpv_layout *layout, const float *injected,
                                const float *gv, float *accumulated, float *snapshot,
                                pf_error *err)
{
    return pf_lpv_propagate_host_width(layout, injected, gv, accumulated, snapshot,
                                       pf_lpv_host_stepper(8) ? 8u : 4u, err);
}
