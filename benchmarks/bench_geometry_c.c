/*
 * bench_geometry_c.c -- time vf_segment_pair and vf_self_row per pair (velfence_filter.h).
 *
 * Built and run by benchmarks/safety_filter_geometry_speed.py: 4096 random segment pairs (1 in 8
 * parallel, 1 in 16 with a zero-length segment), timed in blocks of the whole set and divided;
 * prints "segment_pair_ns <median> self_row_ns <median>" over 200 repetitions (thread CPU time,
 * so a shared machine's preemption is not counted). The self rows are
 * of a random 7-joint chain (joint points and unit axes), every non-adjacent link pair.
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "velfence_filter.h"

#define NP 4096
#define REPS 200

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts); /* the thread's own CPU time: no preemption */
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double urand(unsigned *s)
{
    *s = *s * 1103515245u + 12345u;
    return ((*s >> 8) & 0xFFFFFF) / 16777216.0 * 2.0 - 1.0;
}

static int cmp(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(void)
{
    static double seg[NP][12];
    double t_seg[REPS], t_row[REPS], sink = 0.0;
    double P[8 * 3], axes[7 * 3], u[7], g[7];
    int32_t pairs[64][2], npairs = 0;
    unsigned s = 12345u;
    int i, k, r;
    for (i = 0; i < NP; i++) {
        for (k = 0; k < 12; k++) {
            seg[i][k] = urand(&s);
        }
        if (i % 8 == 0) { /* parallel */
            for (k = 0; k < 3; k++) {
                seg[i][9 + k] = seg[i][6 + k] + 0.7 * (seg[i][3 + k] - seg[i][k]);
            }
        }
        if (i % 16 == 1) { /* zero length */
            for (k = 0; k < 3; k++) {
                seg[i][3 + k] = seg[i][k];
            }
        }
    }
    for (i = 0; i < 8; i++) {
        for (k = 0; k < 3; k++) {
            P[3 * i + k] = 0.3 * i * (k == 2) + 0.1 * urand(&s);
        }
    }
    for (i = 0; i < 7; i++) {
        double a0 = urand(&s), a1 = urand(&s), a2 = urand(&s), h = sqrt(a0 * a0 + a1 * a1 + a2 * a2);
        axes[3 * i] = a0 / h;
        axes[3 * i + 1] = a1 / h;
        axes[3 * i + 2] = a2 / h;
        u[i] = urand(&s);
    }
    for (i = 0; i < 7; i++) {
        for (k = i + 2; k < 7; k++) {
            pairs[npairs][0] = i;
            pairs[npairs][1] = k;
            npairs++;
        }
    }
    for (r = 0; r < REPS; r++) {
        double t0 = now(), sp;
        for (i = 0; i < NP; i++) {
            double ss, tt, nn[3];
            sink += vf_segment_pair(seg[i], seg[i] + 3, seg[i] + 6, seg[i] + 9, &ss, &tt, NULL, NULL,
                                    nn);
        }
        t_seg[r] = (now() - t0) / NP * 1e9;
        t0 = now();
        for (i = 0; i < NP; i++) {
            const int32_t *p = pairs[i % npairs];
            sink += vf_self_row(7, P, axes, p[0], p[1], 0.04, 0.04, u, g, &sp) + g[0] + sp;
        }
        t_row[r] = (now() - t0) / NP * 1e9;
    }
    qsort(t_seg, REPS, sizeof(double), cmp);
    qsort(t_row, REPS, sizeof(double), cmp);
    printf("segment_pair_ns %.2f self_row_ns %.2f sink %g\n", t_seg[REPS / 2], t_row[REPS / 2],
           sink);
    return 0;
}
