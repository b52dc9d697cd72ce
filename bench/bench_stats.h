/*
 * Order statistics the bench programs print (header only: each bench is a program of its
 * own): timings sorted ascending, and their median.
 */
#ifndef PF_BENCH_STATS_H
#define PF_BENCH_STATS_H

#include <stdlib.h>

static inline int bench_compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Sorts values ascending: values[0] is the best time, values[count / 2] the median. */
static inline void bench_sort(double *values, int count)
{
    qsort(values, (size_t)count, sizeof *values, bench_compare_doubles);
}

/* The median of values (sorting them). */
static inline double bench_median(double *values, int count)
{
    bench_sort(values, count);
    return values[count / 2];
}

#endif
