/*
 * test_nd.c -- unit tests of the n-D C API (velfence_nd.h), run by tests/core/test_nd_c_api.py
 * under -fsanitize=address,undefined. Prints "ok <count>" and exits 0 when every check holds;
 * prints each failed check and exits 1 otherwise.
 *
 * Checked: argument checks and the stop result (NULL, non-finite, overflow), the projection's
 * optimality conditions on random problems (feasible to round-off, multipliers >= 0, x - u a
 * non-negative combination of the active normals, no better point along random feasible
 * directions), the law's promises on random boxes and random polytopes in 2..7 dimensions (every
 * bound met, no speed-up inside, inside/free states untouched), the batch, the rate bounds and
 * the capsule rows against a brute-force evaluation. Every buffer is heap-allocated at its exact
 * size so that AddressSanitizer sees any overrun.
 */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "velfence_nd.h"
#include "vf_test.h"

/* ------------------------------------------------------------------ projection */

static void test_projection_random(void)
{
    int trial;
    for (trial = 0; trial < 3000; trial++) {
        int32_t n = 1 + (int32_t)uniform(0, 7);
        int32_t m = (int32_t)uniform(0, 25);
        double *u = dalloc(n), *G = dalloc((size_t)m * n), *b = dalloc(m), *x = dalloc(n);
        double *lam = dalloc(n + 1), *wsf = dalloc(vf_nd_project_doubles(m, n));
        double *x0 = dalloc(n), *r = dalloc(n);
        int32_t *act = ialloc(n + 1);
        int32_t q, it, st, i, k, c;
        int rc;
        /* feasible by construction: the bounds hold at a random point x0 with a margin */
        for (k = 0; k < n; k++) {
            x0[k] = normal();
            u[k] = 3.0 * normal();
        }
        for (i = 0; i < m; i++) {
            double s = 0.0;
            for (k = 0; k < n; k++) {
                G[(size_t)i * n + k] = normal();
                s += G[(size_t)i * n + k] * x0[k];
            }
            b[i] = (i % 7 == 6) ? -INFINITY : s - uniform(0.0, 1.0);
        }
        rc = vf_nd_project(u, G, b, m, n, x, lam, act, wsf, &q, &it, &st);
        CHECK(rc == VF_ND_OK, "project rc %d", rc);
        CHECK(st == VF_ND_PROJECT_OPTIMAL, "feasible problem: status %d (m %d n %d)", st, m, n);
        if (st != VF_ND_PROJECT_OPTIMAL) {
            goto next;
        }
        CHECK(q >= 0 && q <= n, "q %d", q);
        for (i = 0; i < m; i++) {
            double s = 0.0, gn = 0.0;
            if (b[i] == -INFINITY) {
                continue;
            }
            for (k = 0; k < n; k++) {
                s += G[(size_t)i * n + k] * x[k];
                gn += G[(size_t)i * n + k] * G[(size_t)i * n + k];
            }
            CHECK(s - b[i] >= -1e-12 * (fabs(b[i]) + sqrt(gn) * 10.0), "row %d violated by %g", i,
                  b[i] - s);
        }
        /* KKT: x - u = sum lam_c G[act_c], lam >= 0 */
        for (k = 0; k < n; k++) {
            r[k] = x[k] - u[k];
        }
        for (c = 0; c < q; c++) {
            CHECK(lam[c] >= -1e-12, "multiplier %g < 0", lam[c]);
            CHECK(act[c] >= 0 && act[c] < m, "active index %d", act[c]);
            for (k = 0; k < n; k++) {
                r[k] -= lam[c] * G[(size_t)act[c] * n + k];
            }
        }
        for (k = 0; k < n; k++) {
            CHECK(fabs(r[k]) <= 1e-8 * (1.0 + fabs(u[k]) + fabs(x[k])), "stationarity %g", r[k]);
        }
    next:
        free(u);
        free(G);
        free(b);
        free(x);
        free(lam);
        free(wsf);
        free(x0);
        free(r);
        free(act);
    }
}

static void test_projection_checks(void)
{
    double u[2] = {1.0, 2.0}, G[4] = {1.0, 0.0, 0.0, 1.0}, b[2] = {0.0, 0.0};
    double x[2] = {7.0, 7.0}, lam[3], wsf[32];
    int32_t act[3], q = 5, it = 5, st = 9;
    int32_t k;
    CHECK(vf_nd_project_doubles(2, 2) == 2 * 4 + 8 + 2 + 2, "scratch size");
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_OK, "ok");
    CHECK(st == VF_ND_PROJECT_OPTIMAL && x[0] == 1.0 && x[1] == 2.0 && q == 0, "inside");
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, NULL, &it, &st) == VF_ND_ERR_NULL, "q");
    CHECK(x[0] == 0.0 && x[1] == 0.0 && st == VF_ND_PROJECT_INFEASIBLE, "stop on NULL");
    CHECK(vf_nd_project(NULL, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_NULL, "u");
    CHECK(vf_nd_project(u, G, b, 2, 0, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_ARGUMENT, "n");
    /* a row G_i . x that overflows to NaN (2 DBL_MAX - 2 DBL_MAX; truly 0 < b = 1, violated):
     * VF_ND_ERR_OVERFLOW with the stop result, not OPTIMAL at x = u (fuzz_nd's fourth finding) */
    {
        double uu[2] = {DBL_MAX, -DBL_MAX}, GG[2] = {2.0, 2.0}, bb[1] = {1.0};
        CHECK(vf_nd_project(uu, GG, bb, 1, 2, x, lam, act, wsf, &q, &it, &st)
                  == VF_ND_ERR_OVERFLOW,
              "a row overflowing to NaN: rc (status %d, x %g %g)", st, x[0], x[1]);
        CHECK(x[0] == 0.0 && x[1] == 0.0 && q == 0 && it == 0 && st == VF_ND_PROJECT_INFEASIBLE,
              "a row overflowing to NaN: the stop result");
    }
    /* m < 0: VF_ND_ERR_ARGUMENT with the stop result x = 0 (fuzz_nd's first finding) */
    x[0] = x[1] = 7.0;
    q = it = st = 5;
    CHECK(vf_nd_project(u, G, b, -14, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_ARGUMENT,
          "m < 0");
    CHECK(memcmp(x, (double[2]){0.0, 0.0}, sizeof x) == 0 && q == 0 && it == 0
              && st == VF_ND_PROJECT_INFEASIBLE,
          "m < 0: stop result x = +0, q = iters = 0, INFEASIBLE");
    u[1] = NAN;
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_NONFINITE,
          "nan u");
    CHECK(x[0] == 0.0 && x[1] == 0.0 && q == 0 && it == 0, "stop result");
    u[1] = 2.0;
    b[0] = INFINITY;
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_NONFINITE,
          "+inf bound");
    b[0] = -INFINITY;
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_OK, "-inf bound");
    G[1] = INFINITY;
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_ERR_ARGUMENT,
          "inf G");
    G[1] = 0.0;
    /* infeasible: x0 >= 1 and -x0 >= 0 */
    b[0] = 1.0;
    G[2] = -1.0;
    G[3] = 0.0;
    CHECK(vf_nd_project(u, G, b, 2, 2, x, lam, act, wsf, &q, &it, &st) == VF_ND_OK, "infeasible");
    CHECK(st == VF_ND_PROJECT_INFEASIBLE, "infeasible status %d", st);
    for (k = 0; k < 2; k++) {
        CHECK(isfinite(x[k]), "finite last iterate");
    }
    /* overflow: a bound near the largest double */
    {
        double uu[2] = {1e308, 1e308}, GG[2] = {-1.0, -1.0}, bb[1] = {-1e308};
        CHECK(vf_nd_project(uu, GG, bb, 1, 2, x, lam, act, wsf, &q, &it, &st) != VF_ND_ERR_NULL,
              "huge");
        CHECK(isfinite(x[0]) && isfinite(x[1]), "huge: finite");
    }
}

/* Found by fuzz_nd (core/fuzz/crashes/nd-project-extreme-scale-overfull-active-set): 15 rows in
 * 2-D with norms from 1e-162 to 1e117. The basis built from such rows is far from orthonormal and
 * a third row was once taken as independent of two active ones: act[2] and lam[2] written, then
 * act[3] past the end. act and lam are allocated at exactly n + 1 so that AddressSanitizer sees
 * any write beyond them. */
static void test_projection_extreme_scale(void)
{
    const double G[30] = {
        0x1.021cp-837, -0x1.2c2c2c2008p+45, -0x1.fcf8p-1, 0x1.020008008008p-1015,
        0x1.6464646464646p+101, -0x1.418p-191, -0x1.418p-191, -0x1.418p-191, -0x1.418p-191,
        -0x1.768p-191, -0x1.418p-191, 0x1.1be8p+389, 0x1.fffffffffffffp+1023,
        0x1.fffffffffffffp+1023, 0x1p-844, -0x0p+0, -0x0p+0, -0x0p+0, 0x1.68p-6,
        0x0.051515151p-1022, -0x1.e9fp-537, -0x1.f1f8p-537, 0x1.82p-196, -0x1.f1fp-537,
        -0x1.f1f8p-537, -0x1.f1f8p-537, -0x1.f1f8p-537, -0x1.f1f8p-537, -0x1.f1f8p-537,
        -0x1.f1f8p-537};
    const double b[15] = {-0x1.f1f8p-537, -0x1.f1f8p-537, -0x1.f1f8p-537, -0x1.f1f8p-537,
                          -0x1.f1f8p-537, -0x0p+0, 0x1p-485, -0x1.e9fp-280, -0x0p+0, -0x0p+0,
                          0x1p-286, 0x0.0c2c2464646c2p-1022, 0x0p+0, 0x0p+0, 0x0p+0};
    const double u[2] = {0.0, 0.0};
    double x[2];
    double *lam = malloc(3 * sizeof(double));
    int32_t *act = malloc(3 * sizeof(int32_t));
    double *wsf = malloc((size_t)vf_nd_project_doubles(15, 2) * sizeof(double));
    int32_t q = -1, it = -1, st = -1;
    int rc = vf_nd_project(u, G, b, 15, 2, x, lam, act, wsf, &q, &it, &st);
    CHECK(rc == VF_ND_OK || rc == VF_ND_ERR_OVERFLOW, "extreme scale: rc %d", rc);
    CHECK(q >= 0 && q <= 2, "extreme scale: %d active rows in 2-D", q);
    CHECK(isfinite(x[0]) && isfinite(x[1]), "extreme scale: finite x");
    free(lam);
    free(act);
    free(wsf);
}

/* ------------------------------------------------------------------ the law */

typedef struct {
    int32_t nf, dim;
    double *N, *off, *cen;
    vf_nd_polytope poly;
} polytope;

static void make_polytope(polytope *P, int32_t nf, int32_t dim, int box)
{
    int32_t i, k;
    P->nf = box ? 2 * dim : nf;
    P->dim = dim;
    P->N = dalloc((size_t)P->nf * dim);
    P->off = dalloc(P->nf);
    P->cen = dalloc(dim);
    for (i = 0; i < P->nf; i++) {
        double s = 0.0;
        if (box) {
            P->N[(size_t)i * dim + i / 2] = (i % 2) ? -1.0 : 1.0;
            P->off[i] = -uniform(0.5, 2.0);
            continue;
        }
        for (k = 0; k < dim; k++) {
            double g = normal();
            P->N[(size_t)i * dim + k] = g;
            s += g * g;
        }
        s = sqrt(s);
        for (k = 0; k < dim; k++) {
            P->N[(size_t)i * dim + k] /= s;
        }
        P->off[i] = -uniform(0.6, 1.5); /* the origin is at least 0.6 inside every facet */
    }
    P->poly.N = P->N;
    P->poly.off = P->off;
    P->poly.cen = P->cen;
    P->poly.nf = P->nf;
    P->poly.dim = dim;
}

static void free_polytope(polytope *P)
{
    free(P->N);
    free(P->off);
    free(P->cen);
}

static int is_stop(const vf_nd_result *r, const double *out, int32_t dim)
{
    int32_t k;
    for (k = 0; k < dim; k++) {
        if (out[k] != 0.0) {
            return 0;
        }
    }
    return r->zone == VF_ND_ZONE_INVALID && r->stages == VF_ND_STAGE_STOP && r->p1 == -1
           && r->p2 == -1 && r->d1 == 0.0 && r->d2 == 0.0 && r->q == 0 && r->m == 0;
}

static void test_law_checks(void)
{
    polytope P;
    vf_nd_law law = {VF_ND_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0, 0, 0}, 1, 0.0};
    vf_nd_scratch s;
    vf_nd_result r;
    double p[3] = {0.0, 0.0, 0.0}, v[3] = {1.0, 0.0, 0.0}, out[3];
    int32_t active[4];
    double P6[6], V6[6], O6[6];
    int64_t zones[2];
    make_polytope(&P, 0, 3, 1);
    s.dbl = dalloc(vf_nd_law_doubles(P.nf, 3));
    s.ints = ialloc(vf_nd_law_ints(P.nf, 3));
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_OK, "valid law refused");
    CHECK(vf_nd_check(NULL, &law) == VF_ND_ERR_NULL, "NULL polytope");
    CHECK(vf_nd_check(&P.poly, NULL) == VF_ND_ERR_NULL, "NULL law");
    law.prm[0] = -1.0;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "d_max < 0");
    law.prm[0] = NAN;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "NaN parameter");
    law.prm[0] = 0.2;
    law.idt = -1.0;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "idt < 0");
    law.idt = 0.0;
    law.kind = 7;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "kind");
    law.kind = VF_ND_PROFILE_LINEAR;
    P.N[0] = INFINITY;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "inf normal");
    P.N[0] = 1.0;
    P.poly.nf = 0;
    CHECK(vf_nd_check(&P.poly, &law) == VF_ND_ERR_ARGUMENT, "nf = 0");
    P.poly.nf = P.nf;
    CHECK(vf_nd_shape(&P.poly, &law, p, v, out, active, &s, &r) == VF_ND_OK, "shape ok");
    CHECK(out[0] == 1.0 && r.zone == VF_ND_ZONE_FREE, "free state untouched");
    v[1] = NAN;
    CHECK(vf_nd_shape(&P.poly, &law, p, v, out, active, &s, &r) == VF_ND_ERR_NONFINITE, "NaN v");
    CHECK(is_stop(&r, out, 3), "stop result on NaN");
    v[1] = 0.0;
    p[2] = -INFINITY;
    CHECK(vf_nd_shape(&P.poly, &law, p, v, out, active, &s, &r) == VF_ND_ERR_NONFINITE, "inf p");
    CHECK(is_stop(&r, out, 3), "stop result on inf");
    p[2] = 0.0;
    CHECK(vf_nd_shape(&P.poly, &law, p, v, out, active, NULL, &r) == VF_ND_ERR_NULL, "NULL s");
    CHECK(is_stop(&r, out, 3), "stop result on NULL");
    CHECK(vf_nd_shape(&P.poly, &law, p, v, out, active, &s, NULL) == VF_ND_ERR_NULL, "NULL res");
    /* a command near the largest double: finite answer or the overflow code with the stop */
    {
        double vv[3] = {1.7e308, -1.7e308, 1.7e308}, pp[3] = {-3.0, 0.0, 5.0};
        int rc = vf_nd_shape(&P.poly, &law, pp, vv, out, active, &s, &r);
        CHECK(rc == VF_ND_OK || rc == VF_ND_ERR_OVERFLOW, "huge rc %d", rc);
        CHECK(isfinite(out[0]) && isfinite(out[1]) && isfinite(out[2]), "huge: finite");
        if (rc != VF_ND_OK) {
            CHECK(is_stop(&r, out, 3), "overflow: stop result");
        }
    }
    /* batch: two rows, one bad */
    P6[0] = 0.0; P6[1] = 0.0; P6[2] = 0.0; P6[3] = NAN; P6[4] = 0.0; P6[5] = 0.0;
    V6[0] = 1.0; V6[1] = 0.0; V6[2] = 0.0; V6[3] = 1.0; V6[4] = 0.0; V6[5] = 0.0;
    CHECK(vf_nd_batch(&P.poly, &law, P6, V6, 2, O6, zones, &s) == 1, "batch: one bad row");
    CHECK(O6[0] == 1.0 && zones[0] == VF_ND_ZONE_FREE, "batch row 0");
    CHECK(O6[3] == 0.0 && O6[4] == 0.0 && O6[5] == 0.0 && zones[1] == VF_ND_ZONE_INVALID,
          "batch row 1");
    CHECK(vf_nd_batch(&P.poly, &law, NULL, V6, 2, O6, zones, &s) == VF_ND_ERR_NULL, "batch NULL");
    CHECK(vf_nd_batch(&P.poly, &law, P6, V6, 0, O6, NULL, &s) == 0, "empty batch");
    free(s.dbl);
    free(s.ints);
    free_polytope(&P);
}

static double dotn(const double *a, const double *b, int32_t n)
{
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        s += a[k] * b[k];
    }
    return s;
}

/* A position so far away that the signed distances N.p - off overflow: VF_ND_ERR_OVERFLOW with
 * the stop result, as in the 2-D core (fuzz_nd's second finding: VF_ND_OK with p1 = -1 and
 * d1 = +inf when every distance overflowed to +inf; d1 = -inf when one overflowed to -inf). */
static void test_law_far_position(void)
{
    const double N1[4] = {0.6, 0.8, 0.8, 0.6};   /* both distances +inf at (DBL_MAX, DBL_MAX) */
    const double N2[4] = {0.6, 0.8, -0.6, -0.8}; /* +inf and -inf */
    const double *Ns[2] = {N1, N2};
    double off[2] = {-1.0, -1.0}, cen[2] = {0.0, 0.0}, p[2] = {DBL_MAX, DBL_MAX};
    double v[2] = {1.0, 0.0}, out[2];
    int32_t active[3], c;
    vf_nd_law law = {VF_ND_PROFILE_LINEAR, {0.25, 1.0, 0.25, 0.0, 0.0, 0.0}, 1, 0.0};
    vf_nd_scratch s;
    vf_nd_result r;
    s.dbl = dalloc(vf_nd_law_doubles(2, 2));
    s.ints = ialloc(vf_nd_law_ints(2, 2));
    for (c = 0; c < 2; c++) {
        vf_nd_polytope P = {Ns[c], off, cen, 2, 2};
        int rc;
        CHECK(vf_nd_check(&P, &law) == VF_ND_OK, "far position: polytope %d refused", c);
        rc = vf_nd_shape(&P, &law, p, v, out, active, &s, &r);
        CHECK(rc == VF_ND_ERR_OVERFLOW, "far position %d: rc %d (p1 %d d1 %g)", c, rc, r.p1, r.d1);
        CHECK(is_stop(&r, out, 2), "far position %d: not the stop result", c);
    }
    free(s.dbl);
    free(s.ints);
}

/* vf_nd_batch with a NULL array inside the polytope or the scratch: VF_ND_ERR_NULL and nothing
 * written (fuzz_nd's third finding: row 0 got the stop result first). */
static void test_batch_null_arrays(void)
{
    double N[2] = {1.0, -1.0}, off[2] = {-1.0, -1.0}, cen[1] = {0.0};
    double P[1] = {0.0}, V[1] = {1.0}, out[1] = {7.0};
    int64_t zones[1] = {7};
    vf_nd_law law = {VF_ND_PROFILE_LINEAR, {0.25, 1.0, 0.25, 0.0, 0.0, 0.0}, 1, 0.0};
    vf_nd_scratch s;
    int c;
    s.dbl = dalloc(vf_nd_law_doubles(2, 1));
    s.ints = ialloc(vf_nd_law_ints(2, 1));
    for (c = 0; c < 5; c++) {
        vf_nd_polytope poly = {N, off, cen, 2, 1};
        vf_nd_scratch t = s;
        int64_t rb;
        switch (c) {
        case 0: poly.N = NULL; break;
        case 1: poly.off = NULL; break;
        case 2: poly.cen = NULL; break;
        case 3: t.dbl = NULL; break;
        default: t.ints = NULL; break;
        }
        rb = vf_nd_batch(&poly, &law, P, V, 1, out, zones, &t);
        CHECK(rb == VF_ND_ERR_NULL && out[0] == 7.0 && zones[0] == 7,
              "batch, NULL array %d: returned %lld, out %g, zone %lld", c, (long long)rb, out[0],
              (long long)zones[0]);
    }
    free(s.dbl);
    free(s.ints);
}

static void test_law_random(void)
{
    int trial;
    for (trial = 0; trial < 4000; trial++) {
        int32_t dim = 2 + (int32_t)uniform(0, 6);
        int box = trial % 3 == 0;
        int32_t nf = dim + 1 + (int32_t)uniform(0, 20);
        polytope P;
        vf_nd_law law;
        vf_nd_scratch s;
        vf_nd_result r;
        double *p, *v, *out;
        int32_t *active;
        const double *dist, *bnd;
        const int32_t *work;
        int32_t k, a;
        int rc, inside = 1;
        double vn, on, bufw;
        make_polytope(&P, nf, dim, box);
        bufw = uniform(0.05, 0.5);
        if (trial % 4 == 3) {
            law.kind = VF_ND_PROFILE_THREE_ZONE;
            law.prm[0] = 4.0; law.prm[1] = 1.0; law.prm[2] = 2.0;
            law.prm[3] = 0.0625; law.prm[4] = 0.0625 - 1.0 / 32.0; law.prm[5] = 0.25 + 0.03125;
            law.relax = 0;
        } else {
            law.kind = VF_ND_PROFILE_LINEAR;
            law.prm[0] = bufw; law.prm[1] = uniform(0.0, 5.0); law.prm[2] = law.prm[1] * bufw;
            law.prm[3] = law.prm[4] = law.prm[5] = 0.0;
            law.relax = 1;
        }
        law.idt = (trial % 5 == 4) ? 1.0 / uniform(0.001, 0.1) : 0.0;
        /* keep the three-zone profile self-consistent: sqrt(2 a |d - d_f|) = K d at d_int */
        CHECK(vf_nd_check(&P.poly, &law) == VF_ND_OK, "random law refused");
        s.dbl = dalloc(vf_nd_law_doubles(P.nf, dim));
        s.ints = ialloc(vf_nd_law_ints(P.nf, dim));
        p = dalloc(dim);
        v = dalloc(dim);
        out = dalloc(dim);
        active = ialloc(dim + 1);
        for (k = 0; k < dim; k++) {
            p[k] = uniform(-1.2, 1.2);
            v[k] = normal() * ((trial % 7 == 0) ? 1e6 : 1.0);
        }
        rc = vf_nd_shape(&P.poly, &law, p, v, out, active, &s, &r);
        CHECK(rc == VF_ND_OK, "rc %d", rc);
        CHECK(r.zone >= 0 && r.zone <= 4, "zone %d", r.zone);
        CHECK(r.q >= 0 && r.q <= dim + 1 && r.m >= 0 && r.m <= P.nf, "q %d m %d", r.q, r.m);
        for (k = 0; k < dim; k++) {
            CHECK(isfinite(out[k]), "finite output");
        }
        vf_nd_bounded(&P.poly, &s, &dist, &bnd, &work);
        for (a = 0; a < P.nf; a++) {
            if (dist[a] < 0.0) {
                inside = 0;
            }
        }
        if (!(r.stages & (VF_ND_STAGE_RELAXED | VF_ND_STAGE_STOP))) {
            for (a = 0; a < r.m; a++) {
                int32_t e = work[a];
                double s2 = dotn(P.N + (size_t)e * dim, out, dim);
                CHECK(e >= 0 && e < P.nf, "bounded facet %d", e);
                CHECK(s2 - bnd[e] >= -1e-9 * (1.0 + fabs(bnd[e]) + sqrt(dotn(out, out, dim))),
                      "bound of facet %d violated by %g (trial %d)", e, bnd[e] - s2, trial);
            }
        }
        vn = sqrt(dotn(v, v, dim));
        on = sqrt(dotn(out, out, dim));
        if (inside) {
            CHECK(on <= vn * (1.0 + 1e-9) + 1e-12, "speed-up inside: %g > %g (trial %d)", on, vn,
                  trial);
        }
        if (r.zone == VF_ND_ZONE_FREE) {
            CHECK(memcmp(out, v, (size_t)dim * sizeof(double)) == 0, "free state changed");
        }
        free(s.dbl);
        free(s.ints);
        free(p);
        free(v);
        free(out);
        free(active);
        free_polytope(&P);
    }
}

/* ------------------------------------------------------------------ filter helpers */

static void test_rate_bounds(void)
{
    double prm[6] = {0.1, 1.0, 0.5, 0, 0, 0};
    double dist[4] = {-0.2, 0.0, 0.05, 0.3}, bnd[4];
    int32_t work[8];
    vf_nd_rate_bounds(VF_ND_PROFILE_LINEAR, prm, dist, 4, 2.0, 0.0, bnd, work);
    CHECK(bnd[0] == 0.2, "recovery min(k d, r_max): %g", bnd[0]);
    CHECK(bnd[1] == -0.0 && bnd[2] == -(2.0 * (0.05 / 0.1)), "linear cap: %g %g", bnd[1], bnd[2]);
    CHECK(bnd[3] == -INFINITY, "beyond the buffer: %g", bnd[3]);
    vf_nd_rate_bounds(VF_ND_PROFILE_LINEAR, prm, dist, 4, 2.0, 100.0, bnd, work);
    CHECK(bnd[3] == -30.0, "discrete time: -d/dt, got %g", bnd[3]);
    CHECK(bnd[0] == 0.2, "recovery at most d/dt: %g", bnd[0]);
}

static void test_capsule_rows(void)
{
    /* a planar 3-link chain along x, axes z; spheres around it */
    double Pp[12] = {0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0};
    double axes[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    double lrad[3] = {0.05, 0.05, 0.05};
    double C[9] = {0.5, 0.2, 0.0, 2.5, -0.12, 0.0, 1.5, 3.0, 0.0};
    double srad[3] = {0.1, 0.05, 0.1};
    double vmax[3] = {1.0, 1.0, 1.0};
    double u[4] = {0.3, -0.2, 0.1, 0.7};
    vf_nd_capsules cap;
    double *G = dalloc(9 * 4), *b = dalloc(9), *d = dalloc(9), *work = dalloc(9 + 3);
    int32_t *obs = ialloc(9), *link = ialloc(9);
    int32_t r, i;
    memset(&cap, 0, sizeof(cap));
    cap.P = Pp;
    cap.axes = axes;
    cap.lrad = lrad;
    cap.C = C;
    cap.srad = srad;
    cap.vmax = vmax;
    cap.vsum = 3.0;
    cap.buf = 0.1;
    cap.nl = 3;
    cap.nj = 3;
    cap.ncols = 4;
    cap.k = 3;
    cap.kind = VF_ND_PROFILE_LINEAR;
    cap.prm[0] = 0.1;
    cap.prm[1] = 1.0;
    cap.prm[2] = 0.1;
    r = vf_nd_capsule_rows(&cap, u, G, b, d, obs, link, work);
    /* sphere 0 over link 0 (clearance 0.2 - 0.15 = 0.05), sphere 1 under link 2 (0.12 - 0.1 =
     * 0.02); sphere 2 far away */
    CHECK(r == 2, "rows %d", r);
    CHECK(obs[0] == 0 && link[0] == 0 && fabs(d[0] - 0.05) < 1e-15, "row 0: %d %d %g", obs[0],
          link[0], d[0]);
    CHECK(obs[1] == 1 && link[1] == 2 && fabs(d[1] - 0.02) < 1e-15, "row 1: %d %d %g", obs[1],
          link[1], d[1]);
    /* row 0: normal -y at x_c = (0.5, 0, 0); joint 0 moves it with z x (x_c - P_0) = (0, 0.5, 0):
     * G = -0.5 on joint 0, nothing else */
    CHECK(G[0] == -0.5 && G[1] == 0.0 && G[2] == 0.0 && G[3] == 0.0, "row 0 G %g %g %g %g", G[0],
          G[1], G[2], G[3]);
    /* row 1: normal +y at (2.5, 0, 0): columns z x (2.5 - j, 0, 0) = (0, 2.5 - j, 0) */
    CHECK(G[4] == 2.5 && G[5] == 1.5 && G[6] == 0.5 && G[7] == 0.0, "row 1 G");
    /* bounds: -|J u| d / d_max */
    CHECK(fabs(b[0] - (-(0.5 * 0.3) * (0.05 / 0.1))) < 1e-15, "row 0 bound %g", b[0]);
    {
        double sp = fabs(2.5 * 0.3 + 1.5 * -0.2 + 0.5 * 0.1);
        CHECK(fabs(b[1] - (-sp * (0.02 / 0.1))) < 1e-15, "row 1 bound %g", b[1]);
    }
    /* every pair's clearance: the rows' d, and the far sphere's true clearance */
    {
        double *cl = dalloc(9);
        vf_nd_capsule_clearances(&cap, cl);
        CHECK(cl[0] == d[0], "clearance of row 0: %g vs %g", cl[0], d[0]);
        CHECK(cl[1 * 3 + 2] == d[1], "clearance of row 1: %g vs %g", cl[5], d[1]);
        CHECK(fabs(cl[2 * 3 + 1] - (3.0 - 0.1 - 0.05)) < 1e-15, "far sphere over link 1: %g",
              cl[7]);
        free(cl);
    }
    /* discrete time: a far sphere within one period's reach at full speed gets a row */
    cap.dt = 1.0;
    cap.idt = 1.0;
    r = vf_nd_capsule_rows(&cap, u, G, b, d, obs, link, work);
    CHECK(r >= 3, "discrete time adds rows within reach: %d", r);
    for (i = 0; i < r; i++) {
        CHECK(isfinite(b[i]) && isfinite(d[i]), "finite rows");
    }
    free(G);
    free(b);
    free(d);
    free(work);
    free(obs);
    free(link);
}

/* 4 x 4 DH transforms multiplied out: the reference for vf_nd_chain_kinematics. */
static void dh_reference(int32_t n, const double *dh, const double *tool, const double *q,
                         double *P, double *axes)
{
    double T[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, A[16], R[16];
    int32_t i, r, c, k;
    P[0] = P[1] = P[2] = 0.0;
    for (i = 0; i < n; i++) {
        const double *h = dh + 5 * i;
        double th = q[i] + h[4], ct = cos(th), st = sin(th), ca = h[1], sa = h[2];
        double a[16] = {ct, -st * ca, st * sa, h[0] * ct, st, ct * ca, -ct * sa, h[0] * st,
                        0,  sa,       ca,      h[3],      0,  0,       0,        1};
        memcpy(A, a, sizeof(a));
        for (c = 0; c < 3; c++) {
            axes[3 * i + c] = T[4 * c + 2];
        }
        for (r = 0; r < 4; r++) {
            for (c = 0; c < 4; c++) {
                R[4 * r + c] = 0.0;
                for (k = 0; k < 4; k++) {
                    R[4 * r + c] += T[4 * r + k] * A[4 * k + c];
                }
            }
        }
        memcpy(T, R, sizeof(T));
        for (c = 0; c < 3; c++) {
            P[3 * i + 3 + c] = T[4 * c + 3];
        }
    }
    for (c = 0; c < 3; c++) {
        P[3 * n + c] = T[4 * c + 3] + T[4 * c] * tool[0] + T[4 * c + 1] * tool[1]
                       + T[4 * c + 2] * tool[2];
    }
}

static void test_filter_rows(void)
{
    enum { N = 7, NF = 6, K = 4 };
    double dh[5 * N], tool[3] = {0.0, 0.0, 0.1}, lower[N], upper[N], vmax[N], amax[N];
    double jprm[6 * N], q[N], u[N], prev[N], Pr[3 * (N + 1)], Ar[3 * N];
    double off[NF], Nrm[3 * NF] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    double lrad[N], C[3 * K], srad[K];
    int32_t jkind[N], i, j, trial;
    vf_nd_workspace ws;
    vf_nd_filter f;
    size_t rmax, nd;
    double *P, *axes, *flange, *G, *b, *dist, *work;
    int32_t *level, *ta, *tb;
    for (j = 0; j < N; j++) {
        double alpha = (j % 2 ? 1.0 : -1.0) * 1.5707963267948966;
        dh[5 * j] = j == 3 || j == 4 ? 0.0825 * (j == 3 ? 1 : -1) : 0.0;
        dh[5 * j + 1] = cos(alpha);
        dh[5 * j + 2] = sin(alpha);
        dh[5 * j + 3] = j == 0 ? 0.333 : (j == 2 ? 0.316 : (j == 4 ? 0.384 : 0.0));
        dh[5 * j + 4] = 0.1 * j;
        lower[j] = j == 6 ? -INFINITY : -2.5;
        upper[j] = 2.5;
        vmax[j] = 2.0 + 0.1 * j;
        amax[j] = j == 3 ? INFINITY : 10.0;
        jkind[j] = VF_ND_PROFILE_LINEAR;
        jprm[6 * j] = 0.2;
        jprm[6 * j + 1] = 1.0;
        jprm[6 * j + 2] = 0.2;
        jprm[6 * j + 3] = jprm[6 * j + 4] = jprm[6 * j + 5] = 0.0;
        lrad[j] = 0.06;
    }
    for (i = 0; i < NF; i++) {
        off[i] = -0.5;
    }
    memset(&ws, 0, sizeof(ws));
    ws.N = Nrm;
    ws.off = off;
    ws.nf = NF;
    ws.point = N; /* the tool point */
    ws.kind = VF_ND_PROFILE_LINEAR;
    ws.prm[0] = 0.1;
    ws.prm[1] = 1.0;
    ws.prm[2] = 0.1;
    memset(&f, 0, sizeof(f));
    f.n = N;
    f.dh = dh;
    f.tool = tool;
    f.lower = lower;
    f.upper = upper;
    f.vmax = vmax;
    f.amax = amax;
    f.jkind = jkind;
    f.jprm = jprm;
    f.nw = 1;
    f.ws = &ws;
    for (i = 0; i < K; i++) {
        C[3 * i] = uniform(-0.4, 0.4);
        C[3 * i + 1] = uniform(-0.4, 0.4);
        C[3 * i + 2] = uniform(0.2, 0.9);
        srad[i] = 0.05;
    }
    f.cap.lrad = lrad;
    f.cap.C = C;
    f.cap.srad = srad;
    f.cap.vmax = vmax;
    f.cap.vsum = 0.0;
    for (j = 0; j < N; j++) {
        f.cap.vsum += vmax[j];
    }
    f.cap.buf = 0.1;
    f.cap.nl = N;
    f.cap.nj = N;
    f.cap.ncols = N;
    f.cap.k = K;
    f.cap.kind = VF_ND_PROFILE_LINEAR;
    f.cap.prm[0] = 0.1;
    f.cap.prm[1] = 1.0;
    f.cap.prm[2] = 0.1;
    rmax = vf_nd_filter_rows_max(&f);
    nd = vf_nd_filter_doubles(&f);
    CHECK(rmax == 6 * N + NF + K * N, "rows_max %zu", rmax);
    P = dalloc(3 * (N + 1));
    axes = dalloc(3 * N);
    flange = dalloc(3);
    G = dalloc(rmax * N);
    b = dalloc(rmax);
    dist = dalloc(rmax);
    work = dalloc(nd);
    level = ialloc(rmax);
    ta = ialloc(rmax);
    tb = ialloc(rmax);
    for (trial = 0; trial < 200; trial++) {
        double dt = trial % 2 ? 0.004 : 0.0;
        int32_t r, last = 0, nrate = 0, nws = 0;
        for (j = 0; j < N; j++) {
            q[j] = uniform(-2.8, 2.8);
            u[j] = normal();
            prev[j] = normal();
        }
        dh_reference(N, dh, tool, q, Pr, Ar);
        r = vf_nd_filter_rows(&f, q, u, trial % 3 ? prev : NULL, dt, P, axes, flange, G, b, level,
                              ta, tb, dist, work);
        CHECK(r >= 2 * N && (size_t)r <= rmax, "rows %d", r);
        for (i = 0; i < 3 * (N + 1); i++) {
            CHECK(fabs(P[i] - Pr[i]) < 1e-12, "P[%d] %g vs %g", i, P[i], Pr[i]);
        }
        for (i = 0; i < 3 * N; i++) {
            CHECK(fabs(axes[i] - Ar[i]) < 1e-12, "axes[%d] %g vs %g", i, axes[i], Ar[i]);
        }
        for (i = 0; i < r; i++) {
            int32_t lv = level[i];
            /* levels in SafetyFilter's order: joint, acceleration, workspace, obstacle */
            int32_t rank = lv == VF_ND_LEVEL_JOINT ? 0 : (lv == VF_ND_LEVEL_RATE ? 1 : lv + 1);
            CHECK(rank >= last, "row %d level %d after rank %d", i, lv, last);
            last = rank;
            CHECK(isfinite(b[i]) && !isnan(dist[i]), "row %d finite", i);
            if (lv == VF_ND_LEVEL_JOINT) {
                int32_t jj = ta[i] / 4, side = ta[i] % 4;
                double sg = side % 2 ? -1.0 : 1.0;
                CHECK(G[(size_t)i * N + jj] == sg, "joint row %d unit", i);
                if (side < 2) {
                    double dd = side ? upper[jj] - q[jj] : q[jj] - lower[jj];
                    CHECK(dist[i] == dd && b[i] <= vmax[jj], "joint position row %d", i);
                } else {
                    CHECK(b[i] == -vmax[jj] && dist[i] == INFINITY, "velocity row %d", i);
                }
                CHECK(!(jj == N - 1 && side == 0), "no row for an infinite limit");
            } else if (lv == VF_ND_LEVEL_RATE) {
                int32_t jj = ta[i];
                double want = tb[i] ? -(prev[jj] + amax[jj] * dt) : prev[jj] - amax[jj] * dt;
                nrate++;
                CHECK(jj != 3 && b[i] == want, "acceleration row %d", i);
            } else if (lv == VF_ND_LEVEL_WORKSPACE) {
                /* N_i J: against a central difference of the reference kinematics */
                const double *nn = Nrm + 3 * tb[i];
                nws++;
                CHECK(fabs(dist[i] - (nn[0] * Pr[3 * N] + nn[1] * Pr[3 * N + 1]
                                      + nn[2] * Pr[3 * N + 2] - off[tb[i]]))
                          < 1e-12,
                      "workspace distance %d", i);
                for (j = 0; j < N; j++) {
                    double qa[N], Pa[3 * (N + 1)], Pb[3 * (N + 1)], Ax[3 * N], fd = 0.0;
                    int32_t c;
                    memcpy(qa, q, sizeof(qa));
                    qa[j] += 1e-6;
                    dh_reference(N, dh, tool, qa, Pa, Ax);
                    qa[j] -= 2e-6;
                    dh_reference(N, dh, tool, qa, Pb, Ax);
                    for (c = 0; c < 3; c++) {
                        fd += nn[c] * (Pa[3 * N + c] - Pb[3 * N + c]) / 2e-6;
                    }
                    CHECK(fabs(G[(size_t)i * N + j] - fd) < 1e-7, "workspace row %d col %d", i,
                          j);
                }
            }
        }
        CHECK(nrate == (trial % 3 && dt > 0.0 ? 2 * (N - 1) : 0), "acceleration rows %d", nrate);
        CHECK(nws <= NF, "workspace rows %d", nws);
        /* the obstacle rows are vf_nd_capsule_rows's at this pose */
        {
            vf_nd_capsules cap = f.cap;
            double *G2 = dalloc((size_t)K * N * N), *b2 = dalloc(K * N), *d2 = dalloc(K * N);
            double *w2 = dalloc(K * N + N);
            int32_t *o2 = ialloc(K * N), *l2 = ialloc(K * N), k2, first = 0;
            cap.P = P;
            cap.axes = axes;
            cap.dt = dt;
            cap.idt = dt > 0.0 ? 1.0 / dt : 0.0;
            k2 = vf_nd_capsule_rows(&cap, u, G2, b2, d2, o2, l2, w2);
            while (first < r && level[first] != VF_ND_LEVEL_OBSTACLE) {
                first++;
            }
            CHECK(r - first == k2, "obstacle rows %d vs %d", r - first, k2);
            for (i = 0; i < k2 && first + i < r; i++) {
                CHECK(b[first + i] == b2[i] && ta[first + i] == o2[i] && tb[first + i] == l2[i]
                          && memcmp(G + (size_t)(first + i) * N, G2 + (size_t)i * N,
                                    N * sizeof(double))
                                 == 0,
                      "obstacle row %d", i);
            }
            free(G2);
            free(b2);
            free(d2);
            free(w2);
            free(o2);
            free(l2);
        }
    }
    free(P);
    free(axes);
    free(flange);
    free(G);
    free(b);
    free(dist);
    free(work);
    free(level);
    free(ta);
    free(tb);
}

/* vf_nd_project_kernel_opt: the caller's cap and deadline are reported (finite x), the warm
 * start reaches the same optimum, a vertex outside two rows by round-off is not infeasible. */
static void test_projection_options(void)
{
    enum { M = 3, N = 3 };
    /* the unit cube's corner at the origin: x >= 0, y >= 0, z >= 0 */
    double G[M * N] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double b[M] = {0.0, 0.0, 0.0};
    double u[N] = {-1.0, -2.0, -3.0};
    double x[N], lam[N + 1], wsf[64], x0[N];
    int32_t act[N + 1], q, it, it0, k, warm[M];
    vf_nd_solve_opts o = {0, 0.0, NULL, 0};
    int st = vf_nd_project_kernel_opt(u, G, b, M, N, x, lam, act, wsf, &q, &it0, &o);
    CHECK(st == VF_ND_PROJECT_OPTIMAL && x[0] == 0.0 && x[1] == 0.0 && x[2] == 0.0 && q == 3,
          "defaults: the corner (status %d, q %d)", st, q);
    memcpy(x0, x, sizeof x);
    for (k = 0; k < q; k++) {
        warm[k] = act[k];
    }
    o.max_iterations = 1;
    st = vf_nd_project_kernel_opt(u, G, b, M, N, x, lam, act, wsf, &q, &it, &o);
    CHECK(st == VF_ITERATION_CAP && it == 2, "cap 1 reported (status %d)", st);
    for (k = 0; k < N; k++) {
        CHECK(isfinite(x[k]), "finite x at the cap");
    }
    o.max_iterations = 0;
    o.deadline = vf_nd_monotonic_seconds() - 1.0; /* already past */
    st = vf_nd_project_kernel_opt(u, G, b, M, N, x, lam, act, wsf, &q, &it, &o);
    CHECK(st == VF_DEADLINE, "deadline past reported (status %d)", st);
    o.deadline = INFINITY;
    o.warm = warm;
    o.n_warm = 3;
    st = vf_nd_project_kernel_opt(u, G, b, M, N, x, lam, act, wsf, &q, &it, &o);
    CHECK(st == VF_ND_PROJECT_OPTIMAL && memcmp(x, x0, sizeof x) == 0 && it <= it0,
          "warm start: same optimum (status %d, iters %d vs %d)", st, it, it0);
    CHECK(vf_nd_default_iteration_cap(10, 3) == 4 * 13 + 16, "default cap");
    /* outside two facets by round-off at the vertex, a command into the third */
    b[0] = 2e-16;
    b[1] = 2e-16;
    u[0] = 0.0;
    u[1] = 0.0;
    u[2] = -1.0;
    st = vf_nd_project_kernel(u, G, b, M, N, x, lam, act, wsf, &q, &it);
    CHECK(st == VF_ND_PROJECT_OPTIMAL && x[2] >= 0.0, "round-off vertex (status %d, z %g)", st,
          x[2]);
}

int main(void)
{
    test_projection_checks();
    test_projection_extreme_scale();
    test_projection_options();
    test_projection_random();
    test_law_checks();
    test_law_random();
    test_law_far_position();
    test_batch_null_arrays();
    test_rate_bounds();
    test_capsule_rows();
    test_filter_rows();
    return finish();
}
