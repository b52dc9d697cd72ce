/*
 * pf_run_ranges: every index of [0, count) is visited exactly once, by contiguous slices
 * no shorter than asked where the count allows, never more slices than asked; an empty
 * range calls nothing.
 */
#include "pf_common.h"
#include "pf_test.h"

#include <stdatomic.h>
#include <stdlib.h>

typedef struct visit_log {
    atomic_uchar *visits;
    atomic_uint calls;
    atomic_ullong shortest;
} visit_log;

static void visit(void *context, uint64_t begin, uint64_t end)
{
    visit_log *log = context;
    atomic_fetch_add(&log->calls, 1);
    unsigned long long length = end - begin, seen = atomic_load(&log->shortest);
    while (length < seen && !atomic_compare_exchange_weak(&log->shortest, &seen, length))
        continue;
    for (uint64_t i = begin; i < end; i++)
        atomic_fetch_add(&log->visits[i], 1);
}

PF_TEST(every_index_once_in_slices_as_asked)
{
    static const struct {
        uint64_t count;
        uint32_t most;
        uint64_t min_length;
    } cases[] = {{1, 64, 1}, {7, 64, 1}, {1000, 3, 1}, {1000, 64, 400}, {1000, 64, 2000},
                 {100003, 16, 1920}, {1u << 20, 64, 8u << 10}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        visit_log log = {calloc(cases[c].count, 1), 0, ~0ull};
        PF_REQUIRE(log.visits);
        pf_run_ranges(cases[c].count, cases[c].most, cases[c].min_length, visit, &log);
        uint64_t wrong = 0;
        for (uint64_t i = 0; i < cases[c].count; i++)
            wrong += atomic_load(&log.visits[i]) != 1;
        unsigned calls = atomic_load(&log.calls);
        PF_CHECK_MSG(wrong == 0, "count %llu: %llu indices not visited once",
                     (unsigned long long)cases[c].count, (unsigned long long)wrong);
        PF_CHECK_MSG(calls >= 1 && calls <= cases[c].most && calls <= pf_cpu_cores(64),
                     "count %llu: %u slices", (unsigned long long)cases[c].count, calls);
        /* Slices are at least min_length long, unless the whole range is shorter. */
        uint64_t floor = cases[c].min_length < cases[c].count ? cases[c].min_length
                                                               : cases[c].count;
        PF_CHECK_MSG(atomic_load(&log.shortest) >= floor, "count %llu: a slice of %llu",
                     (unsigned long long)cases[c].count,
                     (unsigned long long)atomic_load(&log.shortest));
        free(log.visits);
    }
    visit_log empty = {NULL, 0, ~0ull};
    pf_run_ranges(0, 64, 1, visit, &empty);
    PF_CHECK(atomic_load(&empty.calls) == 0);
}

int main(void)
{
    PF_RUN(every_index_once_in_slices_as_asked);
    return pf_test_finish();
}
