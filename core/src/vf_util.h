/*
 * Small helpers shared by the C core's sources (velfence_cc.c, velfence_filter.c). Private to the
 * library: not installed, not part of the C API.
 */
#ifndef VF_UTIL_H
#define VF_UTIL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

/* 1 if every one of the count doubles at x is finite (count 0: 1), else 0. */
static inline int vf_finite_all(const double *x, size_t count)
{
    size_t i;
    for (i = 0; i < count; i++) {
        if (!isfinite(x[i])) {
            return 0;
        }
    }
    return 1;
}

/* sum_k a_k b_k, summed in order k = 0 .. n - 1 (n <= 0: 0). */
static inline double vf_dot(const double *a, const double *b, int32_t n)
{
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        s += a[k] * b[k];
    }
    return s;
}

#endif /* VF_UTIL_H */
