/*
 * The host's trace step of a wavefront (issue 43): where the device is the
 * CPU (lavapipe), its memory is the host's, and the wide AVX2 BIH traversal
 * (pf_bih_wide_trace_rays) traces several times faster than the device's GLSL
 * loop (bench/RESULTS.md, "The wide view"), so the host traces the queues a
 * kernel wrote, in place, on every core, and the kernel reads the hits. The
 * active list is split into one contiguous chunk per thread; each thread
 * gathers its chunk's rays, traces them in one call per kind and scatters
 * the hits, so the rays stay in pixel order (coherent) and no two threads
 * write the same path.
 */
#include "render_internal.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Threads beyond this many cores are not started (each has its own scratch). */
#define WAVE_MAX_THREADS 64u

/* One thread's chunk and scratch. */
typedef struct wave_worker {
    const pf_wave_tracer *tracer;
    const pf_wave_queues *queues;
    const uint32_t *active;
    uint32_t begin, end;
    /* Scratch for the chunk: the paths still waiting (then: those whose ray hit a surface,
     * and after them those to finish), the gathered rays and their hits. */
    uint32_t *kept, kept_count, hit_count;
    pf_ray *rays;
    pf_hit *hits;
    uint32_t *targets; /* where each gathered ray's hit goes */
    uint64_t traced;
    pthread_t thread;
    int started; /* on a thread of its own (else the caller ran it) */
    pf_status status;
    pf_error err;
} wave_worker;

struct pf_wave_tracer {
    const pf_bih *bih;
    pf_bih_wide wide;
    uint32_t thread_count;
    uint32_t chunk_capacity; /* paths per chunk at most */
    uint32_t shadow_slots;
    wave_worker workers[WAVE_MAX_THREADS];
};

/* Gathers the rays of kind (closest: the paths' own; any: their shadow rays), traces and
 * scatters them. */
static pf_status trace_kind(wave_worker *w, int any_hit)
{
    const pf_wave_queues *q = w->queues;
    uint32_t slots = w->tracer->shadow_slots, count = 0;
    for (uint32_t i = 0; i < w->kept_count; i++) {
        uint32_t path = w->kept[i], waiting = q->queue[path];
        if (!any_hit) {
            if (waiting & 1u) {
                w->targets[count] = path;
                w->rays[count++] = q->rays[path];
            }
            continue;
        }
        for (uint32_t k = 0; k < (waiting >> 1); k++) {
            size_t slot = (size_t)path * slots + k;
            w->targets[count] = (uint32_t)slot;
            w->rays[count++] = q->shadow_rays[slot];
        }
    }
    if (count == 0)
        return PF_OK;
    pf_status status = pf_bih_wide_trace_rays(w->tracer->bih, &w->tracer->wide, w->rays, count,
                                              any_hit, w->hits, &w->err);
    if (status != PF_OK)
        return status;
    pf_hit *out = any_hit ? q->shadow_hits : q->hits;
    for (uint32_t i = 0; i < count; i++)
        out[w->targets[i]] = w->hits[i];
    w->traced += count;
    return PF_OK;
}

static void *wave_worker_run(void *arg)
{
    wave_worker *w = arg;
    w->kept_count = 0;
    w->traced = 0;
    for (uint32_t i = w->begin; i < w->end; i++) {
        uint32_t path = w->active[i];
        if (w->queues->queue[path] != 0)
            w->kept[w->kept_count++] = path;
    }
    w->status = trace_kind(w, 0);
    if (w->status == PF_OK)
        w->status = trace_kind(w, 1);
    /* Stable partition: paths whose ray hit a surface first, then those with nothing but
     * shadow rays' light and the film left (their ray missed, or they had none). */
    w->hit_count = 0;
    uint32_t finishing = 0;
    for (uint32_t i = 0; i < w->kept_count; i++) {
        uint32_t path = w->kept[i];
        if ((w->queues->queue[path] & 1u) && w->queues->hits[path].triangle != PF_NO_HIT)
            w->kept[w->hit_count++] = path;
        else
            w->targets[finishing++] = path;
    }
    memcpy(w->kept + w->hit_count, w->targets, (size_t)finishing * sizeof *w->kept);
    return NULL;
}

static uint32_t online_cores(void)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (cores < 1)
        return 1;
    return cores > (long)WAVE_MAX_THREADS ? WAVE_MAX_THREADS : (uint32_t)cores;
}

pf_status pf_wave_tracer_create(const pf_bih *bih, uint32_t paths, uint32_t shadow_slots,
                                pf_wave_tracer **out, pf_error *err)
{
    *out = NULL;
    pf_wave_tracer *tracer = calloc(1, sizeof *tracer);
    if (!tracer)
        return pf_error_set(err, PF_ERR_NOMEM, "wavefront: out of memory");
    tracer->bih = bih;
    tracer->shadow_slots = shadow_slots;
    tracer->thread_count = online_cores();
    if (tracer->thread_count > paths)
        tracer->thread_count = paths > 0 ? paths : 1;
    tracer->chunk_capacity = (paths + tracer->thread_count - 1) / tracer->thread_count;
    pf_status status = pf_bih_wide_build(bih, &tracer->wide, err);
    /* A chunk's gathered rays: its closest rays, or its shadow rays (up to shadow_slots a path). */
    size_t ray_capacity = (size_t)tracer->chunk_capacity * (shadow_slots > 1 ? shadow_slots : 1);
    for (uint32_t t = 0; status == PF_OK && t < tracer->thread_count; t++) {
        wave_worker *w = &tracer->workers[t];
        w->tracer = tracer;
        w->kept = malloc((size_t)tracer->chunk_capacity * sizeof *w->kept + 1);
        w->rays = malloc(ray_capacity * sizeof *w->rays);
        w->hits = malloc(ray_capacity * sizeof *w->hits);
        w->targets = malloc(ray_capacity * sizeof *w->targets);
        if (!w->kept || !w->rays || !w->hits || !w->targets)
            status = pf_error_set(err, PF_ERR_NOMEM,
                                  "wavefront: out of memory for %zu rays a thread", ray_capacity);
    }
    if (status != PF_OK) {
        pf_wave_tracer_destroy(tracer);
        return status;
    }
    *out = tracer;
    return PF_OK;
}

void pf_wave_tracer_destroy(pf_wave_tracer *tracer)
{
    if (!tracer)
        return;
    for (uint32_t t = 0; t < WAVE_MAX_THREADS; t++) {
        free(tracer->workers[t].kept);
        free(tracer->workers[t].rays);
        free(tracer->workers[t].hits);
        free(tracer->workers[t].targets);
    }
    pf_bih_wide_free(&tracer->wide);
    free(tracer);
}

uint32_t pf_wave_tracer_threads(const pf_wave_tracer *tracer) { return tracer->thread_count; }

pf_status pf_wave_trace(pf_wave_tracer *tracer, const pf_wave_queues *queues, uint32_t *active,
                        uint32_t count, uint32_t *remaining, uint32_t *hit, uint64_t *rays,
                        pf_error *err)
{
    uint32_t threads = tracer->thread_count;
    uint32_t chunk = (count + threads - 1) / threads;
    for (uint32_t t = 0; t < threads; t++) {
        wave_worker *w = &tracer->workers[t];
        w->queues = queues;
        w->active = active;
        w->begin = t * chunk < count ? t * chunk : count;
        w->end = w->begin + chunk < count ? w->begin + chunk : count;
        w->status = PF_OK;
        /* Thread 0 is the caller; a thread that cannot start leaves its chunk to the caller. */
        w->started = t > 0 && pthread_create(&w->thread, NULL, wave_worker_run, w) == 0;
        if (t > 0 && !w->started)
            wave_worker_run(w);
    }
    wave_worker_run(&tracer->workers[0]);
    pf_status status = PF_OK;
    uint32_t kept = 0;
    for (uint32_t t = 0; t < threads; t++) {
        if (tracer->workers[t].started)
            pthread_join(tracer->workers[t].thread, NULL);
    }
    /* Every thread has read its chunk of active: the list is rewritten in order now, the
     * paths with a hit from every chunk first. */
    for (uint32_t t = 0; t < threads; t++) {
        wave_worker *w = &tracer->workers[t];
        if (status == PF_OK && w->status != PF_OK) {
            *err = w->err;
            status = w->status;
        }
        memcpy(active + kept, w->kept, (size_t)w->hit_count * sizeof *active);
        kept += w->hit_count;
        *rays += w->traced;
    }
    *hit = kept;
    for (uint32_t t = 0; t < threads; t++) {
        wave_worker *w = &tracer->workers[t];
        memcpy(active + kept, w->kept + w->hit_count,
               (size_t)(w->kept_count - w->hit_count) * sizeof *active);
        kept += w->kept_count - w->hit_count;
    }
    *remaining = kept;
    return status;
}
