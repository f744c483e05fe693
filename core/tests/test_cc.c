/*
 * test_cc.c -- unit tests of the configuration-control C API (velfence_cc.h), run by
 * tests/core/test_cc_c_api.py under -fsanitize=address,undefined. Prints "ok <count>" and exits 0
 * when every check holds; prints each failed check and exits 1 otherwise.
 *
 * Checked: the argument checks and the stop result (NULL, bad sizes and parameters, non-finite
 * inputs); on random planar and spatial arms among random obstacles: the critical point of every
 * obstacle against a brute-force search over the links (distance, point on its link, unit normal),
 * the constraint rows against central differences of the critical distance, the joint rate against
 * the normal equations of the stacked damped least-squares problem over the active rows, the
 * promises of the active set (every active row was a candidate: d <= rho + h max(0, -d_dot_free)
 * stretched by the add order; with recheck, spare redundancy and no recovery spring every active
 * row stops its approach, to the damping's error, and no inactive candidate inside its sphere
 * approaches), the speed cap, and finite outputs.
 * Every buffer is heap-allocated at its exact size so that AddressSanitizer sees any overrun.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "velfence_cc.h"

#define VF_TEST_SEED 0x2545F4914F6CDD1DULL
#include "vf_test.h"

/* A serial arm: joint points and axes of a chain of revolute joints (planar: every axis z). */
typedef struct arm {
    int32_t n, planar;
    double len[16], tw[16]; /* link lengths, twists (spatial) */
} arm;

static void kinematics(const arm *a, const double *q, double *P, double *axes)
{
    /* frame rotation R (columns x y z) and origin, composed joint by joint: rotate about the
     * current z by q_j, then move along the new x by len_j and twist about it by tw_j */
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, o[3] = {0, 0, 0};
    int32_t j, r;
    for (j = 0; j < a->n; j++) {
        double c = cos(q[j]), s = sin(q[j]), ct = cos(a->tw[j]), st = sin(a->tw[j]);
        double x[3], y[3], z[3];
        for (r = 0; r < 3; r++) {
            P[3 * j + r] = o[r];
            axes[3 * j + r] = R[3 * r + 2];
        }
        for (r = 0; r < 3; r++) {
            x[r] = c * R[3 * r] + s * R[3 * r + 1];
            y[r] = -s * R[3 * r] + c * R[3 * r + 1];
            z[r] = R[3 * r + 2];
        }
        for (r = 0; r < 3; r++) {
            o[r] += a->len[j] * x[r];
            R[3 * r] = x[r];
            R[3 * r + 1] = ct * y[r] + st * z[r];
            R[3 * r + 2] = -st * y[r] + ct * z[r];
        }
    }
    for (r = 0; r < 3; r++) {
        P[3 * a->n + r] = o[r];
    }
}

/* Brute-force critical distance of obstacle centre c over the links of P (capsule radii lr). */
static double brute_distance(const double *P, const double *lr, int32_t n, const double *c)
{
    double best = INFINITY;
    int32_t l, s;
    for (l = 0; l < n; l++) {
        for (s = 0; s <= 2000; s++) {
            double t = s / 2000.0, d2 = 0.0, d;
            int32_t r;
            for (r = 0; r < 3; r++) {
                double x = P[3 * l + r] + t * (P[3 * l + 3 + r] - P[3 * l + r]) - c[r];
                d2 += x * x;
            }
            d = sqrt(d2) - lr[l];
            best = d < best ? d : best;
        }
    }
    return best;
}

typedef struct bufs {
    double *q_dot, *q_free, *points, *fractions, *distances, *normals, *rows, *d_dot, *d_dot_free;
    int32_t *links, *active;
    double *work;
    int32_t *iwork;
} bufs;

static void out_alloc(vf_cc_out *o, bufs *b, int32_t n, int32_t m, int32_t k)
{
    b->q_dot = dalloc((size_t)n);
    b->q_free = dalloc((size_t)n);
    b->points = dalloc(3 * (size_t)k);
    b->fractions = dalloc((size_t)k);
    b->distances = dalloc((size_t)k);
    b->normals = dalloc(3 * (size_t)k);
    b->rows = dalloc((size_t)k * n);
    b->d_dot = dalloc((size_t)k);
    b->d_dot_free = dalloc((size_t)k);
    b->links = ialloc((size_t)k);
    b->active = ialloc((size_t)k);
    b->work = dalloc(vf_cc_doubles(n, m, k));
    b->iwork = ialloc(vf_cc_ints(k));
    o->q_dot = b->q_dot;
    o->q_free = b->q_free;
    o->points = b->points;
    o->fractions = b->fractions;
    o->distances = b->distances;
    o->normals = b->normals;
    o->rows = b->rows;
    o->d_dot = b->d_dot;
    o->d_dot_free = b->d_dot_free;
    o->links = b->links;
    o->active = b->active;
}

static void out_free(bufs *b)
{
    free(b->q_dot);
    free(b->q_free);
    free(b->points);
    free(b->fractions);
    free(b->distances);
    free(b->normals);
    free(b->rows);
    free(b->d_dot);
    free(b->d_dot_free);
    free(b->links);
    free(b->active);
    free(b->work);
    free(b->iwork);
}

static void test_arguments(void)
{
    double C[3] = {1, 0, 0}, rho[1] = {0.1}, lr[2] = {0.0, 0.0};
    double P[9] = {0, 0, 0, 1, 0, 0, 2, 0, 0}, ax[6] = {0, 0, 1, 0, 0, 1}, yr[3] = {0.1, 0, 0};
    vf_cc_problem pb = {2, 2, 1, C, rho, lr, 1.0, 1e4, 1e-2, 0.0, 0.0, 0.0, 1, 5};
    vf_cc_problem bad;
    vf_cc_out o;
    bufs b;
    int32_t i;
    out_alloc(&o, &b, 2, 2, 1);
    CHECK(vf_cc_check(&pb) == VF_CC_OK, "valid problem refused");
    CHECK(vf_cc_check(NULL) == VF_CC_ERR_NULL, "NULL problem");
    bad = pb;
    bad.m = 4;
    CHECK(vf_cc_check(&bad) == VF_CC_ERR_ARGUMENT, "m = 4");
    bad = pb;
    bad.n = 0;
    CHECK(vf_cc_check(&bad) == VF_CC_ERR_ARGUMENT, "n = 0");
    bad = pb;
    bad.lam = 0.0;
    CHECK(vf_cc_check(&bad) == VF_CC_ERR_ARGUMENT, "lam = 0");
    bad = pb;
    bad.w_z = NAN;
    CHECK(vf_cc_check(&bad) == VF_CC_ERR_ARGUMENT, "w_z NaN");
    bad = pb;
    bad.C = NULL;
    CHECK(vf_cc_check(&bad) == VF_CC_ERR_NULL, "C NULL");
    {
        double rneg[1] = {-1.0};
        bad = pb;
        bad.rho = rneg;
        CHECK(vf_cc_check(&bad) == VF_CC_ERR_ARGUMENT, "rho < 0");
    }
    CHECK(vf_cc_solve(&pb, NULL, ax, yr, &o, b.work, b.iwork) == VF_CC_ERR_NULL, "P NULL");
    CHECK(vf_cc_solve(&pb, P, ax, yr, &o, NULL, b.iwork) == VF_CC_ERR_NULL, "work NULL");
    CHECK(vf_cc_solve(&pb, P, ax, yr, &o, b.work, b.iwork) == VF_CC_OK, "valid call");
    for (i = 0; i < 4; i++) {
        double Pn[9], an[6], yn[3];
        memcpy(Pn, P, sizeof P);
        memcpy(an, ax, sizeof ax);
        memcpy(yn, yr, sizeof yr);
        if (i == 0) {
            Pn[4] = NAN;
        } else if (i == 1) {
            an[2] = INFINITY;
        } else if (i == 2) {
            yn[1] = -INFINITY;
        } else {
            yn[0] = NAN;
        }
        CHECK(vf_cc_solve(&pb, Pn, an, yn, &o, b.work, b.iwork) == VF_CC_ERR_NONFINITE,
              "non-finite input %d accepted", (int)i);
        CHECK(o.q_dot[0] == 0.0 && o.q_dot[1] == 0.0 && o.n_active == 0 && o.links[0] == -1,
              "non-finite input %d: not the stop result", (int)i);
    }
    {
        double big[3] = {1e300, 1e300, 0.0};
        int code = vf_cc_solve(&pb, P, ax, big, &o, b.work, b.iwork);
        CHECK(code == VF_CC_OK || code == VF_CC_ERR_OVERFLOW, "huge command: code %d", code);
        CHECK(isfinite(o.q_dot[0]) && isfinite(o.q_dot[1]), "huge command: non-finite q_dot");
    }
    out_free(&b);
}

/* One random scene: checks the critical points, rows, the final solve and the active set. */
static void random_scene(int32_t planar, int32_t n, int32_t k, int32_t recheck, double h,
                         double kz, double max_speed)
{
    arm a;
    const int32_t m = planar ? 2 : 3;
    double *q = dalloc((size_t)n), *P = dalloc(3 * (size_t)(n + 1)), *ax = dalloc(3 * (size_t)n);
    double *C = dalloc(3 * (size_t)k), *rho = dalloc((size_t)k), *lr = dalloc((size_t)n);
    double yr[3];
    vf_cc_problem pb;
    vf_cc_out o;
    bufs b;
    int32_t i, j, l, r, code;
    a.n = n;
    a.planar = planar;
    for (j = 0; j < n; j++) {
        a.len[j] = uniform(0.05, 0.4);
        a.tw[j] = planar ? 0.0 : (uniform(0, 1) < 0.5 ? 1.5707963267948966 : -1.5707963267948966);
        q[j] = uniform(-2.0, 2.0);
        lr[j] = uniform(0.0, 0.03);
    }
    kinematics(&a, q, P, ax);
    for (i = 0; i < k; i++) {
        l = (int32_t)uniform(0, n - 1e-9);
        for (r = 0; r < 3; r++) {
            double t = uniform(0.0, 1.0);
            C[3 * i + r] = P[3 * l + r] + t * (P[3 * l + 3 + r] - P[3 * l + r]) + uniform(-0.2, 0.2);
        }
        if (planar) {
            C[3 * i + 2] = 0.0;
        }
        rho[i] = uniform(0.05, 0.25);
    }
    for (r = 0; r < m; r++) {
        yr[r] = uniform(-0.5, 0.5);
    }
    pb.n = n;
    pb.m = m;
    pb.k = k;
    pb.C = C;
    pb.rho = rho;
    pb.lrad = lr;
    pb.w_e = 1.0;
    pb.w_z = 1e4;
    pb.lam = 1e-2;
    pb.kz = kz;
    pb.h = h;
    pb.max_speed = max_speed;
    pb.recheck = recheck;
    pb.rounds = 4 * k + 1;
    out_alloc(&o, &b, n, m, k);
    code = vf_cc_solve(&pb, P, ax, yr, &o, b.work, b.iwork);
    CHECK(code == VF_CC_OK, "random scene: code %d", code);
    for (j = 0; j < n; j++) {
        CHECK(isfinite(o.q_dot[j]) && isfinite(o.q_free[j]), "non-finite joint rate");
    }
    /* critical points: brute force, on the named link, unit normals */
    for (i = 0; i < k; i++) {
        double bd = brute_distance(P, lr, n, C + 3 * i), nn = 0.0, dd = 0.0;
        l = o.links[i];
        CHECK(l >= 0 && l < n, "link out of range");
        CHECK(o.distances[i] <= bd + 1e-12 && o.distances[i] >= bd - 1e-5,
              "critical distance %.17g vs brute force %.17g", o.distances[i], bd);
        CHECK(o.fractions[i] >= 0.0 && o.fractions[i] <= 1.0, "fraction out of [0, 1]");
        for (r = 0; r < 3; r++) {
            double x = P[3 * l + r] + o.fractions[i] * (P[3 * l + 3 + r] - P[3 * l + r]);
            CHECK(fabs(x - o.points[3 * i + r]) < 1e-12, "critical point not on its link");
            nn += o.normals[3 * i + r] * o.normals[3 * i + r];
            dd += (o.points[3 * i + r] - C[3 * i + r]) * (o.points[3 * i + r] - C[3 * i + r]);
        }
        CHECK(fabs(nn - 1.0) < 1e-12, "normal not unit");
        CHECK(fabs(sqrt(dd) - lr[l] - o.distances[i]) < 1e-12, "distance not |x - c| - r");
        /* the row is d(distance)/dq at fixed link and body point: central differences */
        for (j = 0; j < n; j++) {
            double qp[16], Pp[51], Pm[51], axp[48], xp[3], xm[3], dp = 0.0, dm = 0.0;
            const double eps = 1e-6;
            memcpy(qp, q, (size_t)n * sizeof(double));
            qp[j] += eps;
            kinematics(&a, qp, Pp, axp);
            qp[j] -= 2.0 * eps;
            kinematics(&a, qp, Pm, axp);
            for (r = 0; r < 3; r++) {
                /* the body-fixed point: the same place along the (rigid) link */
                xp[r] = Pp[3 * l + r] + o.fractions[i] * (Pp[3 * l + 3 + r] - Pp[3 * l + r]);
                xm[r] = Pm[3 * l + r] + o.fractions[i] * (Pm[3 * l + 3 + r] - Pm[3 * l + r]);
                dp += (xp[r] - C[3 * i + r]) * (xp[r] - C[3 * i + r]);
                dm += (xm[r] - C[3 * i + r]) * (xm[r] - C[3 * i + r]);
            }
            if (sqrt(dd) > 1e-3) {
                double fd = (sqrt(dp) - sqrt(dm)) / (2.0 * eps);
                CHECK(fabs(fd - o.rows[(size_t)i * n + j]) < 1e-6 * (1.0 + fabs(fd)),
                      "row %d joint %d: %.12g vs central difference %.12g", (int)i, (int)j,
                      o.rows[(size_t)i * n + j], fd);
            }
        }
    }
    /* the final solve: (w_e J'J + w_z R_S'R_S + lam I) q = w_e J'y_r + w_z R_S'z_r before the
     * cap; J from the joint points */
    {
        double Jc[3 * 16], N[16 * 16], g[16], res = 0.0, scale = 0.0, f = 1.0, peak = 0.0;
        double qd[16];
        for (j = 0; j < n; j++) {
            double dx = P[3 * n] - P[3 * j], dy = P[3 * n + 1] - P[3 * j + 1];
            double dz = P[3 * n + 2] - P[3 * j + 2];
            const double *z = ax + 3 * j;
            Jc[j] = z[1] * dz - z[2] * dy;
            Jc[16 + j] = z[2] * dx - z[0] * dz;
            Jc[32 + j] = z[0] * dy - z[1] * dx;
        }
        for (j = 0; j < n; j++) {
            peak = fabs(o.q_dot[j]) > peak ? fabs(o.q_dot[j]) : peak;
        }
        /* a capped rate is the solve scaled by an unknown factor < 1: check the cap instead */
        if (max_speed > 0.0 && peak >= max_speed * (1.0 - 1e-12)) {
            f = 0.0;
        }
        for (j = 0; j < n; j++) {
            qd[j] = o.q_dot[j];
        }
        for (i = 0; i < n; i++) {
            g[i] = 0.0;
            for (j = 0; j < n; j++) {
                double s = 0.0;
                for (r = 0; r < m; r++) {
                    s += Jc[16 * r + i] * Jc[16 * r + j];
                }
                N[16 * i + j] = s + (i == j ? pb.lam : 0.0);
            }
            for (r = 0; r < m; r++) {
                g[i] += Jc[16 * r + i] * yr[r];
            }
        }
        for (l = 0; l < o.n_active; l++) {
            int32_t ob = o.active[l];
            const double *row = o.rows + (size_t)ob * n;
            double pen = rho[ob] - o.distances[ob];
            double zr = kz * (pen > 0.0 ? pen : 0.0);
            for (i = 0; i < n; i++) {
                for (j = 0; j < n; j++) {
                    N[16 * i + j] += pb.w_z * row[i] * row[j];
                }
                g[i] += pb.w_z * row[i] * zr;
            }
        }
        if (f > 0.0) {
            for (i = 0; i < n; i++) {
                double s = -g[i];
                for (j = 0; j < n; j++) {
                    s += N[16 * i + j] * qd[j];
                }
                res = fabs(s) > res ? fabs(s) : res;
                scale = fabs(g[i]) > scale ? fabs(g[i]) : scale;
            }
            CHECK(res <= 1e-8 * (scale + 1e-300) * (1.0 + o.condition * 1e-8),
                  "normal equations residual %.3g (scale %.3g, cond %.3g)", res, scale,
                  o.condition);
        } else {
            CHECK(fabs(peak - max_speed) <= 1e-12 * max_speed, "cap not met: peak %.17g", peak);
        }
    }
    /* the active set: distinct members, inside their spheres when h = 0; with recheck, spare
     * redundancy and K_z = 0 every active row stops its approach (to the damping's error); a
     * recovery rate K_z (rho - d) > 0 may be out of reach (a row that cannot move the point) */
    for (l = 0; l < o.n_active; l++) {
        int32_t ob = o.active[l];
        CHECK(ob >= 0 && ob < k, "active index out of range");
        for (i = 0; i < l; i++) {
            CHECK(o.active[i] != ob, "an obstacle twice in the active set");
        }
        if (h == 0.0) {
            CHECK(o.distances[ob] <= rho[ob], "active row outside its sphere with h = 0");
        }
        if (recheck && o.n_active <= n - m && max_speed == 0.0 && kz == 0.0) {
            double pen = rho[ob] - o.distances[ob];
            double zr = kz * (pen > 0.0 ? pen : 0.0);
            CHECK(o.d_dot[ob] >= zr - 1e-3, "active row %d gave way: %.6g < %.6g", (int)ob,
                  o.d_dot[ob], zr);
        }
    }
    if (recheck && o.n_active < n - m && max_speed == 0.0 && h == 0.0) {
        for (i = 0; i < k; i++) {
            int in = 0;
            for (l = 0; l < o.n_active; l++) {
                in |= o.active[l] == i;
            }
            if (!in && o.distances[i] < rho[i] - 1e-9) {
                double pen = rho[i] - o.distances[i];
                double zr = kz * (pen > 0.0 ? pen : 0.0);
                CHECK(o.d_dot[i] >= zr - 1e-9 * (1.0 + fabs(zr)) - 1e-12,
                      "inactive candidate %d approaches: %.6g < %.6g", (int)i, o.d_dot[i], zr);
            }
        }
    }
    out_free(&b);
    free(q);
    free(P);
    free(ax);
    free(C);
    free(rho);
    free(lr);
}

/* The speed cap with a factor max_speed / peak below DBL_MIN: met exactly (fuzz_cc's finding:
 * q (max_speed / peak) with a subnormal factor left |q_dot| up to 4e-10 relative above the cap). */
static void test_tiny_cap(void)
{
    static const double caps[4] = {2.8728548032717271e-188, 1e-200, 3e-310, 1.390794793043109e-320};
    static const double big[3] = {1.8096363075122029e+127, 3e150, 7e300};
    double C[3] = {10, 10, 0}, rho[1] = {0.1}, lr[2] = {0.0, 0.0};
    double P[9] = {0, 0, 0, 0.3, 0.1, 0, 0.5, -0.2, 0}, ax[6] = {0, 0, 1, 0, 0, 1};
    vf_cc_problem pb = {2, 2, 1, C, rho, lr, 1.0, 1e3, 1e-3, 0.0, 0.0, 0.0, 1, 5};
    vf_cc_out o;
    bufs b;
    int32_t c, g, j;
    out_alloc(&o, &b, 2, 2, 1);
    for (c = 0; c < 4; c++) {
        for (g = 0; g < 3; g++) {
            double yr[2] = {big[g], 1.0};
            int code;
            pb.max_speed = caps[c];
            code = vf_cc_solve(&pb, P, ax, yr, &o, b.work, b.iwork);
            if (code != VF_CC_OK) {
                continue; /* an overflow refused is not the cap's case */
            }
            for (j = 0; j < 2; j++) {
                CHECK(fabs(o.q_dot[j]) <= caps[c], "cap %.17g, y_r %g: |q_dot_%d| = %.17g",
                      caps[c], big[g], (int)j, fabs(o.q_dot[j]));
            }
        }
    }
    out_free(&b);
}

int main(void)
{
    int32_t s;
    test_arguments();
    test_tiny_cap();
    for (s = 0; s < 600; s++) {
        int32_t planar = s % 2;
        int32_t n = 3 + (int32_t)uniform(0, 8);
        int32_t k = (int32_t)uniform(0, 12);
        int32_t recheck = uniform(0, 1) < 0.7;
        double h = uniform(0, 1) < 0.6 ? 0.0 : 0.05;
        double kz = uniform(0, 1) < 0.5 ? 0.0 : 2.0;
        double cap = uniform(0, 1) < 0.8 ? 0.0 : 0.5;
        random_scene(planar, n, k, recheck, h, kz, cap);
    }
    return finish();
}
