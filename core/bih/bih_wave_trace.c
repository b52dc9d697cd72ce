/*
 * The host's trace step of a wavefront (issue 43): where the device is the
 * CPU (lavapipe), its memory is the host's, and the wide AVX2 BIH traversal
 * (pf_bih_wide_trace_rays) traces several times faster than the device's GLSL
 * loop (bench/RESULTS.md, "The wide view"), so the host traces the queues a
 * kernel wrote, in place, on every core, and the kernel reads the hits. The
 * active list goes in blocks of consecutive paths, handed to the tracer's
 * threads (created with it, kept for every wave of the frame) as each asks
 * for the next, so a thread whose rays were cheap takes more blocks. A
 * thread gathers its block's rays, traces them in one call per kind and
 * scatters the hits: the rays stay in pixel order (coherent), no two threads
 * write the same path, and the blocks' results are joined in block order, so
 * the next active list does not depend on which thread took which block.
 */
#include "bih_internal.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* Threads beyond this many cores are not started (each has its own scratch). */
#define WAVE_MAX_THREADS 64u
/* Paths a block: large enough that a block's gathered rays amortise a trace call, small
 * enough that two threads end a wave of a few thousand paths together. */
#define WAVE_BLOCK_PATHS 1024u

/* One thread's scratch: a block's gathered rays, their hits and where each goes. */
typedef struct wave_worker {
    struct pf_bih_wave_tracer *tracer;
    pf_ray *rays;
    pf_hit *hits;
    uint32_t *targets;
    uint64_t traced;
    pf_status status;
    pf_error err;
    pthread_t thread;
    int started;
} wave_worker;

struct pf_bih_wave_tracer {
    const pf_bih *bih;
    pf_bih_wide own_wide;    /* built here where the caller gave none */
    const pf_bih_wide *wide; /* the view traced: own_wide or the caller's */
    uint32_t thread_count;
    uint32_t shadow_slots;
    /* Per block b: its waiting paths, those with a hit first, at b × WAVE_BLOCK_PATHS. */
    uint32_t *block_paths;
    uint32_t *block_hit, *block_kept;
    /* The wave being traced. */
    const pf_bih_wave_queues *queues;
    const uint32_t *active;
    uint32_t count, block_count;
    atomic_uint next_block;
    /* The pool: a wave is a new generation; running counts the threads still at it. */
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    uint64_t generation;
    uint32_t running;
    int quit, pool_ready;
    wave_worker workers[WAVE_MAX_THREADS];
};

/* Gathers the rays of kind (closest: the paths' own; any: their shadow rays) of paths,
 * traces and scatters them. */
static pf_status trace_kind(wave_worker *w, const uint32_t *paths, uint32_t path_count,
                            int any_hit)
{
    const pf_bih_wave_queues *q = w->tracer->queues;
    uint32_t slots = w->tracer->shadow_slots, count = 0;
    for (uint32_t i = 0; i < path_count; i++) {
        uint32_t path = paths[i], waiting = q->queue[path];
        if (!any_hit) {
            if (waiting & 1u) {
                w->targets[count] = path;
                w->rays[count++] = q->rays[path];
            }
            continue;
        }
        for (uint32_t k = 0; k < ((waiting >> 1) & PF_BIH_WAVE_SHADOW_MAX); k++) {
            size_t slot = (size_t)path * slots + k;
            w->targets[count] = (uint32_t)slot;
            w->rays[count++] = q->shadow_rays[slot];
        }
    }
    if (count == 0)
        return PF_OK;
    pf_status status = pf_bih_wide_trace_rays(w->tracer->bih, w->tracer->wide, w->rays, count,
                                              any_hit, w->hits, &w->err);
    if (status != PF_OK)
        return status;
    pf_hit *out = any_hit ? q->shadow_hits : q->hits;
    for (uint32_t i = 0; i < count; i++)
        out[w->targets[i]] = w->hits[i];
    w->traced += count;
    return PF_OK;
}

/* Block b: its waiting paths traced, then split (stably) into those whose ray hit a
 * surface and those with only the shadow rays' light and the film left. */
static pf_status trace_block(wave_worker *w, uint32_t b)
{
    pf_bih_wave_tracer *tracer = w->tracer;
    const pf_bih_wave_queues *q = tracer->queues;
    uint32_t begin = b * WAVE_BLOCK_PATHS;
    uint32_t end = begin + WAVE_BLOCK_PATHS < tracer->count ? begin + WAVE_BLOCK_PATHS
                                                            : tracer->count;
    uint32_t *paths = tracer->block_paths + begin, kept = 0;
    for (uint32_t i = begin; i < end; i++)
        if (q->queue[tracer->active[i]] != 0)
            paths[kept++] = tracer->active[i];
    pf_status status = trace_kind(w, paths, kept, 0);
    if (status == PF_OK)
        status = trace_kind(w, paths, kept, 1);
    uint32_t hit = 0, finishing = 0;
    for (uint32_t i = 0; i < kept; i++) {
        uint32_t path = paths[i];
        if ((q->queue[path] & 1u) && q->hits[path].triangle != PF_NO_HIT)
            paths[hit++] = path;
        else
            w->targets[finishing++] = path;
    }
    memcpy(paths + hit, w->targets, (size_t)finishing * sizeof *paths);
    tracer->block_hit[b] = hit;
    tracer->block_kept[b] = kept;
    return status;
}

/* Takes blocks until none is left; the first error stays in the worker. */
static void take_blocks(wave_worker *w)
{
    pf_bih_wave_tracer *tracer = w->tracer;
    for (;;) {
        uint32_t b = atomic_fetch_add(&tracer->next_block, 1u);
        if (b >= tracer->block_count)
            return;
        if (w->status == PF_OK)
            w->status = trace_block(w, b);
        else
            tracer->block_hit[b] = tracer->block_kept[b] = 0;
    }
}

static void *pool_thread(void *arg)
{
    wave_worker *w = arg;
    pf_bih_wave_tracer *tracer = w->tracer;
    uint64_t seen = 0;
    pthread_mutex_lock(&tracer->lock);
    for (;;) {
        while (!tracer->quit && tracer->generation == seen)
            pthread_cond_wait(&tracer->wake, &tracer->lock);
        if (tracer->quit)
            break;
        seen = tracer->generation;
        pthread_mutex_unlock(&tracer->lock);
        take_blocks(w);
        pthread_mutex_lock(&tracer->lock);
        if (--tracer->running == 0)
            pthread_cond_signal(&tracer->done);
    }
    pthread_mutex_unlock(&tracer->lock);
    return NULL;
}

pf_status pf_bih_wave_tracer_create(const pf_bih *bih, const pf_bih_wide *wide, uint32_t paths,
                                    uint32_t shadow_slots, pf_bih_wave_tracer **out, pf_error *err)
{
    *out = NULL;
    pf_bih_wave_tracer *tracer = calloc(1, sizeof *tracer);
    if (!tracer)
        return pf_error_set(err, PF_ERR_NOMEM, "wavefront: out of memory");
    tracer->bih = bih;
    tracer->shadow_slots = shadow_slots;
    uint32_t blocks = (paths + WAVE_BLOCK_PATHS - 1) / WAVE_BLOCK_PATHS;
    tracer->thread_count = pf_cpu_cores(WAVE_MAX_THREADS);
    if (tracer->thread_count > blocks)
        tracer->thread_count = blocks > 0 ? blocks : 1;
    pf_status status = PF_OK;
    if (wide) {
        tracer->wide = wide;
    } else {
        status = pf_bih_wide_build(bih, &tracer->own_wide, err);
        tracer->wide = &tracer->own_wide;
    }
    tracer->block_paths = malloc(((size_t)paths + 1) * sizeof *tracer->block_paths);
    tracer->block_hit = malloc(((size_t)blocks + 1) * sizeof *tracer->block_hit);
    tracer->block_kept = malloc(((size_t)blocks + 1) * sizeof *tracer->block_kept);
    if (status == PF_OK && (!tracer->block_paths || !tracer->block_hit || !tracer->block_kept))
        status = pf_error_set(err, PF_ERR_NOMEM, "wavefront: out of memory for %u paths", paths);
    /* A block's gathered rays: its closest rays, or its shadow rays (up to shadow_slots a
     * path); the targets double as the partition's scratch. */
    size_t ray_capacity = (size_t)WAVE_BLOCK_PATHS * (shadow_slots > 1 ? shadow_slots : 1);
    for (uint32_t t = 0; status == PF_OK && t < tracer->thread_count; t++) {
        wave_worker *w = &tracer->workers[t];
        w->tracer = tracer;
        w->rays = malloc(ray_capacity * sizeof *w->rays);
        w->hits = malloc(ray_capacity * sizeof *w->hits);
        w->targets = malloc(ray_capacity * sizeof *w->targets);
        if (!w->rays || !w->hits || !w->targets)
            status = pf_error_set(err, PF_ERR_NOMEM,
                                  "wavefront: out of memory for %zu rays a thread", ray_capacity);
    }
    if (status == PF_OK && (pthread_mutex_init(&tracer->lock, NULL) != 0 ||
                            pthread_cond_init(&tracer->wake, NULL) != 0 ||
                            pthread_cond_init(&tracer->done, NULL) != 0))
        status = pf_error_set(err, PF_ERR_NOMEM, "wavefront: no thread synchronisation");
    if (status == PF_OK)
        tracer->pool_ready = 1;
    /* Thread 0 is the caller's; a thread that cannot start leaves its share to the others. */
    for (uint32_t t = 1; status == PF_OK && t < tracer->thread_count; t++)
        tracer->workers[t].started =
            pthread_create(&tracer->workers[t].thread, NULL, pool_thread, &tracer->workers[t]) == 0;
    if (status != PF_OK) {
        pf_bih_wave_tracer_destroy(tracer);
        return status;
    }
    *out = tracer;
    return PF_OK;
}

void pf_bih_wave_tracer_destroy(pf_bih_wave_tracer *tracer)
{
    if (!tracer)
        return;
    if (tracer->pool_ready) {
        pthread_mutex_lock(&tracer->lock);
        tracer->quit = 1;
        pthread_cond_broadcast(&tracer->wake);
        pthread_mutex_unlock(&tracer->lock);
        for (uint32_t t = 1; t < tracer->thread_count; t++)
            if (tracer->workers[t].started)
                pthread_join(tracer->workers[t].thread, NULL);
        pthread_cond_destroy(&tracer->done);
        pthread_cond_destroy(&tracer->wake);
        pthread_mutex_destroy(&tracer->lock);
    }
    for (uint32_t t = 0; t < WAVE_MAX_THREADS; t++) {
        free(tracer->workers[t].rays);
        free(tracer->workers[t].hits);
        free(tracer->workers[t].targets);
    }
    free(tracer->block_paths);
    free(tracer->block_hit);
    free(tracer->block_kept);
    pf_bih_wide_free(&tracer->own_wide);
    free(tracer);
}

uint32_t pf_bih_wave_tracer_threads(const pf_bih_wave_tracer *tracer)
{
    uint32_t started = 1;
    for (uint32_t t = 1; t < tracer->thread_count; t++)
        started += (uint32_t)tracer->workers[t].started;
    return started;
}

pf_status pf_bih_wave_trace(pf_bih_wave_tracer *tracer, const pf_bih_wave_queues *queues,
                            uint32_t *active, uint32_t count, uint32_t *remaining, uint32_t *hit,
                            uint64_t *rays, pf_error *err)
{
    tracer->queues = queues;
    tracer->active = active;
    tracer->count = count;
    tracer->block_count = (count + WAVE_BLOCK_PATHS - 1) / WAVE_BLOCK_PATHS;
    atomic_store(&tracer->next_block, 0u);
    uint32_t helpers = 0;
    for (uint32_t t = 0; t < tracer->thread_count; t++) {
        tracer->workers[t].status = PF_OK;
        tracer->workers[t].traced = 0;
        helpers += t > 0 && tracer->workers[t].started;
    }
    if (helpers > 0 && tracer->block_count > 1) {
        pthread_mutex_lock(&tracer->lock);
        tracer->running = helpers;
        tracer->generation++;
        pthread_cond_broadcast(&tracer->wake);
        pthread_mutex_unlock(&tracer->lock);
        take_blocks(&tracer->workers[0]);
        pthread_mutex_lock(&tracer->lock);
        while (tracer->running > 0)
            pthread_cond_wait(&tracer->done, &tracer->lock);
        pthread_mutex_unlock(&tracer->lock);
    } else {
        take_blocks(&tracer->workers[0]);
    }
    pf_status status = PF_OK;
    for (uint32_t t = 0; t < tracer->thread_count; t++) {
        wave_worker *w = &tracer->workers[t];
        if (status == PF_OK && w->status != PF_OK) {
            *err = w->err;
            status = w->status;
        }
        *rays += w->traced;
    }
    /* Every block has read its part of active: the list is rewritten now, in block order,
     * the paths with a hit from every block first. */
    uint32_t kept = 0;
    for (uint32_t b = 0; b < tracer->block_count; b++) {
        memcpy(active + kept, tracer->block_paths + (size_t)b * WAVE_BLOCK_PATHS,
               (size_t)tracer->block_hit[b] * sizeof *active);
        kept += tracer->block_hit[b];
    }
    *hit = kept;
    for (uint32_t b = 0; b < tracer->block_count; b++) {
        memcpy(active + kept,
               tracer->block_paths + (size_t)b * WAVE_BLOCK_PATHS + tracer->block_hit[b],
               (size_t)(tracer->block_kept[b] - tracer->block_hit[b]) * sizeof *active);
        kept += tracer->block_kept[b] - tracer->block_hit[b];
    }
    *remaining = kept;
    return status;
}
