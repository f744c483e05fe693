/*
 * vf_test.h -- the small harness shared by the core's C tests (test_core.c, test_nd.c, test_cc.c,
 * test_rr.c): a counting CHECK macro, a fixed-seed generator, exactly-sized heap buffers (so that
 * AddressSanitizer sees any overrun) and the "ok <count>" summary the Python tests read.
 *
 * One test program per translation unit: the counters and the generator state are file statics.
 * Define VF_TEST_SEED before including to choose the generator's seed.
 */
#ifndef VF_TEST_H
#define VF_TEST_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#ifndef VF_TEST_SEED
#define VF_TEST_SEED 0x9E3779B97F4A7C15ULL
#endif

static int failures = 0;
static long checks = 0;

/* Counts the check; prints the first 50 failures with their place and message. */
#define CHECK(cond, ...)                                    \
    do {                                                    \
        checks++;                                           \
        if (!(cond)) {                                      \
            failures++;                                     \
            if (failures < 50) {                            \
                printf("FAIL %s:%d: ", __FILE__, __LINE__); \
                printf(__VA_ARGS__);                        \
                printf("\n");                               \
            }                                               \
        }                                                   \
    } while (0)

static unsigned long long rng_state = VF_TEST_SEED;

/* Uniform in [lo, hi) from a 64-bit linear congruential generator (deterministic runs). */
static inline double uniform(double lo, double hi)
{
    rng_state = rng_state * 6364136223846793005ULL + 1442695040888963407ULL;
    return lo + (hi - lo) * (double)(rng_state >> 11) / 9007199254740992.0;
}

/* Standard normal (Box-Muller). */
static inline double normal(void)
{
    double u1 = uniform(1e-12, 1.0), u2 = uniform(0.0, 1.0);
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

static inline double *dalloc(size_t n)
{
    double *p = calloc(n ? n : 1, sizeof(double));
    if (p == NULL) {
        exit(2);
    }
    return p;
}

static inline int32_t *ialloc(size_t n)
{
    int32_t *p = calloc(n ? n : 1, sizeof(int32_t));
    if (p == NULL) {
        exit(2);
    }
    return p;
}

/* "ok <count>" and 0 when every check held, else the failure count and 1 (main's return). */
static inline int finish(void)
{
    if (failures) {
        printf("%d of %ld checks failed\n", failures, checks);
        return 1;
    }
    printf("ok %ld\n", checks);
    return 0;
}

#endif /* VF_TEST_H */
