/*
 * bench_shape_fast_c.c -- the C floor of benchmarks/bench_shape_fast.py: the minimal C loop over
 * the same states as shape_batch, with the same law, timed in C.
 *
 * Usage: bench_shape_fast_c MODE LAW_FILE P_FILE V_FILE N REPS OUT_FILE
 *   MODE      "2d" (vf_exact_kernel, velfence_core.h) or "nd" (vf_nd_kernel, velfence_nd.h)
 *   LAW_FILE  text: 2d: n, nx[n], ny[n], off[n], cx, cy, kind, prm[6], relax, idt
 *                   nd: nf, dim, N[nf * dim], off[nf], cen[dim], kind, prm[6], relax, idt
 *   P_FILE, V_FILE  N rows of float64 (2 or dim per row), native byte order (numpy tofile)
 *   OUT_FILE  the loop's last output, written as float64 rows (the caller checks it against
 *             shape_batch bit for bit: the same law on the same states)
 * The loop is the least a C caller does: one kernel call per row writing the velocity row, no
 * checks, no zones, scratch allocated once. Prints one line per repetition: the time of the whole
 * loop in ns (CLOCK_MONOTONIC); one untimed warm-up pass first.
 */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "velfence_core.h"
#include "velfence_nd.h"

static double now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e9 + (double)t.tv_nsec;
}

static int read_n(FILE *f, double *dst, size_t count)
{
    size_t i;
    for (i = 0; i < count; i++) {
        if (fscanf(f, "%lf", dst + i) != 1) {
            return -1;
        }
    }
    return 0;
}

static double *read_rows(const char *path, size_t count)
{
    FILE *f = fopen(path, "rb");
    double *d = malloc(sizeof(double) * count);
    if (f == NULL || d == NULL || fread(d, sizeof(double), count, f) != count) {
        return NULL;
    }
    fclose(f);
    return d;
}

int main(int argc, char **argv)
{
    FILE *lf, *of;
    size_t N, r, width;
    int reps, rep, kind, relax;
    double *P, *V, *out;
    if (argc != 8) {
        fprintf(stderr, "usage: %s MODE LAW_FILE P_FILE V_FILE N REPS OUT_FILE\n", argv[0]);
        return 1;
    }
    N = (size_t)atol(argv[5]);
    reps = atoi(argv[6]);
    lf = fopen(argv[2], "r");
    if (lf == NULL || reps < 1) {
        return 1;
    }
    if (argv[1][0] == '2') {
        int n;
        double *mem;
        int32_t *work;
        vf_polygon poly;
        vf_exact_law law;
        vf_scratch s;
        vf_result res;
        if (fscanf(lf, "%d", &n) != 1 || n < 3) return 1;
        mem = malloc(sizeof(double) * 5 * (size_t)n);
        work = malloc(sizeof(int32_t) * (size_t)n);
        if (mem == NULL || work == NULL || read_n(lf, mem, 3 * (size_t)n) < 0) return 1;
        poly.nx = mem; poly.ny = mem + n; poly.off = mem + 2 * n; poly.beta = NULL;
        poly.a0 = 0.0; poly.n = n;
        if (fscanf(lf, "%lf %lf %d", &poly.cx, &poly.cy, &kind) != 3) return 1;
        law.kind = kind;
        if (read_n(lf, law.prm, VF_PROFILE_PARAMS) < 0) return 1;
        if (fscanf(lf, "%d %lf", &relax, &law.idt) != 2) return 1;
        law.relax = relax;
        if (vf_exact_check(&poly, &law) != VF_OK) return 2;
        s.dist = mem + 3 * n; s.bnd = mem + 4 * n; s.work = work;
        width = 2;
        P = read_rows(argv[3], width * N);
        V = read_rows(argv[4], width * N);
        out = malloc(sizeof(double) * width * N);
        if (P == NULL || V == NULL || out == NULL) return 1;
        for (rep = -1; rep < reps; rep++) {
            double t0 = now_ns();
            for (r = 0; r < N; r++) {
                vf_exact_kernel(&poly, &law, P[2 * r], P[2 * r + 1], V[2 * r], V[2 * r + 1], &s,
                                &res);
                out[2 * r] = res.ox;
                out[2 * r + 1] = res.oy;
            }
            if (rep >= 0) printf("%.0f\n", now_ns() - t0);
        }
    } else {
        int nf, dim;
        double *mem, *dbl;
        int32_t *ints, *active;
        vf_nd_polytope poly;
        vf_nd_law law;
        vf_nd_scratch s;
        vf_nd_result res;
        if (fscanf(lf, "%d %d", &nf, &dim) != 2 || nf < 1 || dim < 1) return 1;
        mem = malloc(sizeof(double) * ((size_t)nf * (size_t)dim + (size_t)nf + (size_t)dim));
        if (mem == NULL || read_n(lf, mem, (size_t)nf * (size_t)dim + (size_t)nf + (size_t)dim) < 0)
            return 1;
        poly.N = mem; poly.off = mem + (size_t)nf * (size_t)dim; poly.cen = poly.off + nf;
        poly.nf = nf; poly.dim = dim;
        if (fscanf(lf, "%d", &kind) != 1) return 1;
        law.kind = kind;
        if (read_n(lf, law.prm, VF_ND_PROFILE_PARAMS) < 0) return 1;
        if (fscanf(lf, "%d %lf", &relax, &law.idt) != 2) return 1;
        law.relax = relax;
        if (vf_nd_check(&poly, &law) != VF_ND_OK) return 2;
        dbl = malloc(sizeof(double) * vf_nd_law_doubles(nf, dim));
        ints = malloc(sizeof(int32_t) * (vf_nd_law_ints(nf, dim) + (size_t)dim + 1));
        if (dbl == NULL || ints == NULL) return 1;
        active = ints + vf_nd_law_ints(nf, dim);
        s.dbl = dbl; s.ints = ints;
        width = (size_t)dim;
        P = read_rows(argv[3], width * N);
        V = read_rows(argv[4], width * N);
        out = malloc(sizeof(double) * width * N);
        if (P == NULL || V == NULL || out == NULL) return 1;
        for (rep = -1; rep < reps; rep++) {
            double t0 = now_ns();
            for (r = 0; r < N; r++) {
                vf_nd_kernel(&poly, &law, P + r * width, V + r * width, out + r * width, active,
                             &s, &res);
            }
            if (rep >= 0) printf("%.0f\n", now_ns() - t0);
        }
    }
    fclose(lf);
    of = fopen(argv[7], "wb");
    if (of == NULL || fwrite(out, sizeof(double), width * N, of) != width * N) return 1;
    fclose(of);
    return 0;
}
