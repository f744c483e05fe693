/*
 * bench_core_c.c -- the C timing loop of benchmarks/bench_core.py: vf_exact_shape called directly.
 *
 * Arguments: [REP SAMPLES [nobatch]] (default 64 20000).
 * stdin: n, then nx[n], ny[n], off[n], cx, cy, prm[6], relax, idt; then blocks "count" followed by
 * count states (px py vx vy), until EOF. For each block prints one line
 *   median_ns p99_ns max_ns checksum
 * of the per-call time: blocks of REP calls (cycling over the block's states) are timed with
 * CLOCK_MONOTONIC and divided by REP (a single call is shorter than the clock's own overhead).
 * A last line "batch ns_per_state" times vf_exact_batch over 10^6 states drawn from all blocks
 * (best of 5).
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "velfence_core.h"

static int REP = 64;       /* calls per timed block (argv[1]) */
static int SAMPLES = 20000; /* timed blocks per state pool (argv[2]) */

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    int n, i, k, count, relax;
    double *nx, *ny, *off, *dist, *bnd, *times, *all = NULL, *out;
    int32_t *work;
    size_t n_all = 0;
    vf_polygon poly;
    vf_exact_law law;
    vf_scratch s;
    vf_result r;
    if (argc > 2) {
        REP = atoi(argv[1]);
        SAMPLES = atoi(argv[2]);
        if (REP < 1 || SAMPLES < 100) return 1;
    }
    if (scanf("%d", &n) != 1 || n < 3) return 1;
    nx = malloc(sizeof(double) * (size_t)n * 5);
    ny = nx + n; off = nx + 2 * n; dist = nx + 3 * n; bnd = nx + 4 * n;
    work = malloc(sizeof(int32_t) * (size_t)n);
    for (i = 0; i < 3 * n; i++) if (scanf("%lf", nx + i) != 1) return 1;
    poly.nx = nx; poly.ny = ny; poly.off = off; poly.beta = NULL; poly.a0 = 0.0; poly.n = n;
    if (scanf("%lf %lf", &poly.cx, &poly.cy) != 2) return 1;
    law.kind = VF_PROFILE_LINEAR;
    for (i = 0; i < 6; i++) if (scanf("%lf", &law.prm[i]) != 1) return 1;
    if (scanf("%d %lf", &relax, &law.idt) != 2) return 1;
    law.relax = relax;
    s.dist = dist; s.bnd = bnd; s.work = work;
    if (vf_exact_check(&poly, &law) != VF_OK) return 2;
    times = malloc(sizeof(double) * SAMPLES);
    while (scanf("%d", &count) == 1) {
        double *st = malloc(sizeof(double) * 4 * (size_t)count), sum = 0.0;
        for (i = 0; i < 4 * count; i++) if (scanf("%lf", st + i) != 1) return 1;
        all = realloc(all, sizeof(double) * 4 * (n_all + (size_t)count));
        for (i = 0; i < 4 * count; i++) all[4 * n_all + (size_t)i] = st[i];
        n_all += (size_t)count;
        for (k = 0; k < 200; k++) { /* warm-up */
            const double *q = st + 4 * (k % count);
            vf_exact_shape(&poly, &law, q[0], q[1], q[2], q[3], &s, &r);
        }
        for (k = 0; k < SAMPLES; k++) {
            double t0 = now_ns();
            for (i = 0; i < REP; i++) {
                const double *q = st + 4 * ((k * REP + i) % count);
                vf_exact_shape(&poly, &law, q[0], q[1], q[2], q[3], &s, &r);
                sum += r.ox;
            }
            times[k] = (now_ns() - t0) / REP;
        }
        qsort(times, SAMPLES, sizeof(double), cmp);
        printf("%.2f %.2f %.2f %.6g\n", times[SAMPLES / 2], times[(SAMPLES * 99) / 100],
               times[SAMPLES - 1], sum);
        free(st);
    }
    if (n_all > 0 && !(argc > 3 && argv[3][0] == 'n')) { /* argv[3] "nobatch": skip */
        size_t N = 1000000, j;
        double *P = malloc(sizeof(double) * 4 * N), t0;
        out = malloc(sizeof(double) * 2 * N);
        for (j = 0; j < N; j++) {
            const double *q = all + 4 * (j % n_all);
            P[2 * j] = q[0]; P[2 * j + 1] = q[1];
            P[2 * N + 2 * j] = q[2]; P[2 * N + 2 * j + 1] = q[3];
        }
        double best = 1e300;
        int rep;
        for (j = 0; j < 2 * N; j++) out[j] = 0.0; /* touch the pages before timing */
        for (rep = 0; rep < 5; rep++) {
            t0 = now_ns();
            vf_exact_batch(&poly, &law, P, P + 2 * N, N, out, NULL, &s);
            t0 = (now_ns() - t0) / (double)N;
            if (t0 < best) best = t0;
        }
        printf("batch %.2f\n", best);
        free(P); free(out);
    }
    return 0;
}
