/* Work split between the cores: one slice a thread, no pool (pf_common.h). */
#include "pf_common.h"

#include <pthread.h>
#include <stdlib.h>
#include <unistd.h>

uint32_t pf_cpu_cores(uint32_t most)
{
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    if (cores < 1 || most < 1)
        return 1;
    return cores > (long)most ? most : (uint32_t)cores;
}

typedef struct parallel_item {
    void (*fn)(void *item);
    void *item;
} parallel_item;

static void *parallel_entry(void *argument)
{
    parallel_item *run = argument;
    run->fn(run->item);
    return NULL;
}

void pf_run_parallel(void *items, size_t item_size, uint32_t count, void (*fn)(void *item))
{
    if (count == 0)
        return;
    parallel_item *runs = count > 1 ? calloc(count, sizeof *runs) : NULL;
    pthread_t *ids = count > 1 ? calloc(count, sizeof *ids) : NULL;
    unsigned char *started = count > 1 ? calloc(count, 1) : NULL;
    if (!runs || !ids || !started) {
        /* Out of memory for the bookkeeping (or one item): every item on this thread. */
        for (uint32_t i = 0; i < count; i++)
            fn((char *)items + (size_t)i * item_size);
        free(runs);
        free(ids);
        free(started);
        return;
    }
    for (uint32_t i = 1; i < count; i++) {
        runs[i] = (parallel_item){fn, (char *)items + (size_t)i * item_size};
        started[i] = pthread_create(&ids[i], NULL, parallel_entry, &runs[i]) == 0;
    }
    fn(items);
    for (uint32_t i = 1; i < count; i++) {
        if (started[i])
            pthread_join(ids[i], NULL);
        else
            fn(runs[i].item); /* no thread: this one does the item */
    }
    free(runs);
    free(ids);
    free(started);
}

typedef struct range_job {
    void (*fn)(void *context, uint64_t begin, uint64_t end);
    void *context;
    uint64_t begin, end;
} range_job;

static void range_entry(void *item)
{
    range_job *job = item;
    job->fn(job->context, job->begin, job->end);
}

void pf_run_ranges(uint64_t count, uint32_t most, uint64_t min_length,
                   void (*fn)(void *context, uint64_t begin, uint64_t end), void *context)
{
    if (count == 0)
        return;
    uint64_t by_length = count / (min_length > 0 ? min_length : 1);
    uint32_t slices = most < PF_RUN_RANGES_MAX ? most : PF_RUN_RANGES_MAX;
    if (by_length < slices)
        slices = (uint32_t)by_length;
    slices = pf_cpu_cores(slices > 0 ? slices : 1);
    range_job jobs[PF_RUN_RANGES_MAX];
    for (uint32_t t = 0; t < slices; t++)
        jobs[t] = (range_job){fn, context, count * t / slices, count * (t + 1) / slices};
    pf_run_parallel(jobs, sizeof jobs[0], slices, range_entry);
}
