/*
 * Small helpers shared by the C core's sources (velfence_cc.c, velfence_filter.c). Private to the
 * library: not installed, not part of the C API.
 */
#ifndef VF_UTIL_H
#define VF_UTIL_H

#include <math.h>
#include <stddef.h>

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

#endif /* VF_UTIL_H */
