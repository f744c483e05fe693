/*
 * test_rr.c -- the resolved-rate SR step (velfence_rr.h) on the PUMA 560 and on random 6-joint DH
 * arms: the argument checks and the stop result; the Jacobian against the 4 x 4 DH frames (axes)
 * and central differences of the tool point (linear rows); det J against a Laplace expansion;
 * the damping law; the joint rate against the damped normal equations (J^T J + k I) q' = J^T x';
 * the speed cap; the bound |q'| <= |x'| / (2 sqrt k) at the wrist singularity; the refused
 * singular step and overflow. Prints "ok <count>".
 */
#include "velfence_rr.h"
#include "vf_test.h"

#include <math.h>
#include <string.h>

static const double PI = 3.141592653589793;

/* The standard-DH PUMA 560 of Khokar 2009 (velfence.mechanisms.chain.DHChain.puma560). */
static void puma(vf_rr_arm *arm)
{
    static const double rows[6][4] = {
        {0.0, -90.0, 0.0, 0.0}, {0.4318, 0.0, 0.15, 0.0}, {-0.0203, 90.0, 0.0, 0.0},
        {0.0, -90.0, 0.4331, 0.0}, {0.0, 90.0, 0.0, 0.0},  {0.0, 0.0, 0.0, 0.0},
    };
    int i;
    for (i = 0; i < 6; i++) {
        double al = rows[i][1] * PI / 180.0;
        arm->dh[i][0] = rows[i][0];
        arm->dh[i][1] = cos(al);
        arm->dh[i][2] = sin(al);
        arm->dh[i][3] = rows[i][2];
        arm->dh[i][4] = rows[i][3];
    }
    arm->tool[0] = arm->tool[1] = arm->tool[2] = 0.0;
}

static void random_arm(vf_rr_arm *arm)
{
    int i;
    for (i = 0; i < 6; i++) {
        double al = uniform(-PI, PI);
        arm->dh[i][0] = uniform(-0.5, 0.5);
        arm->dh[i][1] = cos(al);
        arm->dh[i][2] = sin(al);
        arm->dh[i][3] = uniform(-0.5, 0.5);
        arm->dh[i][4] = uniform(-PI, PI);
    }
    for (i = 0; i < 3; i++) {
        arm->tool[i] = uniform(-0.2, 0.2);
    }
}

/* C = A B for 4 x 4 row-major. */
static void mul4(const double *A, const double *B, double *C)
{
    int i, j, l;
    for (i = 0; i < 4; i++) {
        for (j = 0; j < 4; j++) {
            double s = 0.0;
            for (l = 0; l < 4; l++) {
                s += A[i * 4 + l] * B[l * 4 + j];
            }
            C[i * 4 + j] = s;
        }
    }
}

/* The frames 0..6 by 4 x 4 DH products (the textbook route) and the tool point. */
static void frames(const vf_rr_arm *arm, const double *q, double T[7][16], double p[3])
{
    int i, j;
    memset(T[0], 0, sizeof T[0]);
    T[0][0] = T[0][5] = T[0][10] = T[0][15] = 1.0;
    for (i = 0; i < 6; i++) {
        double th = q[i] + arm->dh[i][4], ct = cos(th), st = sin(th);
        double ca = arm->dh[i][1], sa = arm->dh[i][2], a = arm->dh[i][0], d = arm->dh[i][3];
        double A[16] = {ct, -st * ca, st * sa, a * ct, st, ct * ca, -ct * sa, a * st,
                        0.0, sa,       ca,      d,      0.0, 0.0,   0.0,      1.0};
        mul4(T[i], A, T[i + 1]);
    }
    for (j = 0; j < 3; j++) {
        p[j] = T[6][j * 4 + 3] + T[6][j * 4 + 0] * arm->tool[0] + T[6][j * 4 + 1] * arm->tool[1]
               + T[6][j * 4 + 2] * arm->tool[2];
    }
}

/* det by Laplace expansion along the first row of the n x n submatrix (rows r.., columns mask). */
static double laplace(const double *M, int row, unsigned mask)
{
    double s = 0.0, sign = 1.0;
    int c;
    if (row == 6) {
        return 1.0;
    }
    for (c = 0; c < 6; c++) {
        if (mask & (1u << c)) {
            continue;
        }
        s += sign * M[row * 6 + c] * laplace(M, row + 1, mask | (1u << c));
        sign = -sign;
    }
    return s;
}

static double norm6(const double *v)
{
    double s = 0.0;
    int i;
    for (i = 0; i < 6; i++) {
        s += v[i] * v[i];
    }
    return sqrt(s);
}

static void check_state(const vf_rr_arm *arm, const double *q, const double *x, double max_speed)
{
    vf_rr_params prm = {0.025, 0.014, 1e-10, 0.0};
    vf_rr_out out, capped;
    double J[36], T[7][16], p[3], h = 1e-6, jn = 0.0;
    double lhs[6], rhs[6], res = 0.0, scale = 0.0, det;
    int i, j, l, code;
    CHECK(vf_rr_jacobian(arm, q, J) == VF_OK, "jacobian");
    frames(arm, q, T, p);
    for (i = 0; i < 36; i++) {
        jn = fmax(jn, fabs(J[i]));
    }
    for (j = 0; j < 6; j++) {
        double qp[6], qm[6], Tp[7][16], Tm[7][16], pp[3], pm[3];
        memcpy(qp, q, sizeof qp);
        memcpy(qm, q, sizeof qm);
        qp[j] += h;
        qm[j] -= h;
        frames(arm, qp, Tp, pp);
        frames(arm, qm, Tm, pm);
        for (i = 0; i < 3; i++) {
            double fd = (pp[i] - pm[i]) / (2.0 * h);
            CHECK(fabs(J[i * 6 + j] - fd) < 1e-8, "J[%d][%d] %g vs differences %g", i, j,
                  J[i * 6 + j], fd);
            CHECK(fabs(J[(3 + i) * 6 + j] - T[j][i * 4 + 2]) < 1e-12, "axis J[%d][%d]", 3 + i, j);
        }
    }
    code = vf_rr_sr_step(arm, &prm, q, x, &out);
    CHECK(code == VF_OK, "step code %d", code);
    det = laplace(J, 0, 0u);
    CHECK(fabs(out.det - det) <= 1e-12 * (1.0 + jn * jn * jn * jn * jn * jn), "det %g vs %g",
          out.det, det);
    CHECK(out.w == fabs(out.det), "w = |det|");
    CHECK(out.k == (out.w >= prm.w0 ? 0.0 : prm.k0 * pow(1.0 - out.w / prm.w0, 2.0)), "eq. 37");
    CHECK(out.singular == (out.w <= prm.singular_tol), "singular flag");
    CHECK(out.scale == 1.0, "no cap");
    /* (J^T J + k I) q' = J^T x' */
    for (j = 0; j < 6; j++) {
        double a = out.k * out.q_dot[j], b = 0.0;
        for (i = 0; i < 6; i++) {
            double jq = 0.0;
            for (l = 0; l < 6; l++) {
                jq += J[i * 6 + l] * out.q_dot[l];
            }
            a += J[i * 6 + j] * jq;
            b += J[i * 6 + j] * x[i];
        }
        lhs[j] = a;
        rhs[j] = b;
        res = fmax(res, fabs(a - b));
        scale = fmax(scale, fabs(b));
    }
    CHECK(res <= 1e-9 * (1.0 + scale + jn * jn * norm6(out.q_dot)), "normal equations %g", res);
    (void)lhs;
    (void)rhs;
    if (out.k > 0.0) {
        CHECK(norm6(out.q_dot) <= norm6(x) / (2.0 * sqrt(out.k)) * (1.0 + 1e-9), "SR bound");
    }
    if (max_speed > 0.0) {
        double peak = 0.0;
        prm.max_speed = max_speed;
        CHECK(vf_rr_sr_step(arm, &prm, q, x, &capped) == VF_OK, "capped code");
        for (j = 0; j < 6; j++) {
            peak = fmax(peak, fabs(out.q_dot[j]));
        }
        if (peak > max_speed) {
            CHECK(capped.scale == max_speed / peak, "scale");
            for (j = 0; j < 6; j++) {
                CHECK(capped.q_dot[j] == out.q_dot[j] / peak * max_speed, "capped q'");
                CHECK(fabs(capped.q_dot[j]) <= max_speed, "cap held exactly");
            }
        } else {
            CHECK(capped.scale == 1.0 && memcmp(capped.q_dot, out.q_dot, sizeof out.q_dot) == 0,
                  "cap idle");
        }
    }
}

int main(void)
{
    vf_rr_arm arm;
    vf_rr_params prm = {0.025, 0.014, 1e-10, 0.0};
    vf_rr_out out;
    double q[6] = {-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345};
    double x[6] = {0.1, -0.05, 0.02, 0.1, 0.0, -0.2};
    double J[36];
    int i, t, j;

    puma(&arm);
    /* argument checks and the stop result */
    CHECK(vf_rr_sr_step(NULL, &prm, q, x, &out) == VF_ERR_NULL, "NULL arm");
    CHECK(out.q_dot[0] == 0.0 && out.scale == 1.0 && isnan(out.w), "stop result");
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, NULL) == VF_ERR_NULL, "NULL out");
    CHECK(vf_rr_jacobian(&arm, NULL, J) == VF_ERR_NULL, "NULL q");
    prm.k0 = 0.0;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_ARGUMENT, "k0 = 0");
    prm.k0 = 0.025;
    prm.w0 = NAN;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_ARGUMENT, "w0 NaN");
    prm.w0 = 0.014;
    prm.max_speed = -1.0;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_ARGUMENT, "max_speed < 0");
    prm.max_speed = 0.0;
    q[3] = NAN;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_NONFINITE, "q NaN");
    CHECK(vf_rr_jacobian(&arm, q, J) == VF_ERR_NONFINITE && J[7] == 0.0, "J of NaN");
    for (i = 0; i < 6; i++) {
        CHECK(out.q_dot[i] == 0.0, "zero rates");
    }
    q[3] = 0.17227;
    x[2] = INFINITY;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_NONFINITE, "x' inf");
    x[2] = 1e308;
    x[0] = -1e308;
    CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_ERR_OVERFLOW, "overflow");
    CHECK(out.q_dot[0] == 0.0 && isfinite(out.w), "overflow: zero rates, w kept");
    x[0] = 0.1;
    x[2] = 0.02;

    /* the PUMA: the closed-form manipulability |a2 (d4 c3 - a3 s3)(a2 c2 + a3 c23 + d4 s23) s5| */
    for (t = 0; t < 300; t++) {
        double c2, c3, s3, c23, s23, wcf;
        for (i = 0; i < 6; i++) {
            q[i] = uniform(-PI, PI);
            x[i] = normal();
        }
        check_state(&arm, q, x, uniform(0.1, 3.0));
        CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_OK, "puma step");
        c2 = cos(q[1]);
        c3 = cos(q[2]);
        s3 = sin(q[2]);
        c23 = cos(q[1] + q[2]);
        s23 = sin(q[1] + q[2]);
        wcf = fabs(0.4318 * (0.4331 * c3 + 0.0203 * s3) * (0.4318 * c2 - 0.0203 * c23 + 0.4331 * s23)
                   * sin(q[4]));
        CHECK(fabs(out.w - wcf) <= 1e-13, "closed-form w %g vs %g", out.w, wcf);
    }
    /* the wrist singularity: damped at k0, bounded; refused when singular_tol >= w0 */
    for (t = 0; t < 100; t++) {
        for (i = 0; i < 6; i++) {
            q[i] = uniform(-PI, PI);
            x[i] = normal();
        }
        q[4] = 0.0;
        check_state(&arm, q, x, 0.0);
        CHECK(vf_rr_sr_step(&arm, &prm, q, x, &out) == VF_OK, "through the singularity");
        CHECK(out.w < 1e-15 && fabs(out.k - prm.k0) < 1e-15 && out.singular, "k = k0 at w = 0");
        /* singular_tol >= w0: every undamped step (w >= w0) is refused, a damped one answers */
        prm.singular_tol = 1e9;
        q[4] = uniform(-PI, PI);
        i = vf_rr_sr_step(&arm, &prm, q, x, &out);
        CHECK(out.singular, "singular under a huge singular_tol");
        CHECK(i == (out.w >= prm.w0 ? VF_ERR_SINGULAR : VF_OK), "refused iff k = 0");
        if (i == VF_ERR_SINGULAR) {
            for (j = 0; j < 6; j++) {
                CHECK(out.q_dot[j] == 0.0, "refused: zero rates");
            }
        }
        prm.singular_tol = 1e-10;
    }
    /* a J J^T + k I that is not numerically positive definite is VF_ERR_SINGULAR (before the
     * shared enum: VF_RR_ERR_FACTOR): at the wrist singularity with w0 = 5e-324 the round-off
     * det J > 0 leaves the step undamped (k = 0) and J J^T has a Cholesky pivot <= 0 */
    {
        vf_rr_params p4 = {0.025, 5e-324, 0.0, 0.0};
        int refused = 0;
        for (t = 0; t < 300; t++) {
            for (i = 0; i < 6; i++) {
                q[i] = uniform(-PI, PI);
                x[i] = normal();
            }
            q[4] = 0.0;
            i = vf_rr_sr_step(&arm, &p4, q, x, &out);
            CHECK(i == VF_OK || i == VF_ERR_SINGULAR, "wrist, w0 = 5e-324: code %d", i);
            if (i == VF_ERR_SINGULAR) {
                refused++;
                CHECK(out.k == 0.0 && out.w > 0.0 && !out.singular, "a pivot <= 0, undamped");
                for (j = 0; j < 6; j++) {
                    CHECK(out.q_dot[j] == 0.0, "singular factor: zero rates");
                }
                CHECK(out.scale == 1.0, "singular factor: scale 1");
            }
        }
        CHECK(refused > 0, "no step reached a pivot <= 0 (%d)", refused);
    }
    /* random arms */
    for (t = 0; t < 500; t++) {
        random_arm(&arm);
        for (i = 0; i < 6; i++) {
            q[i] = uniform(-PI, PI);
            x[i] = normal();
        }
        check_state(&arm, q, x, uniform(0.1, 3.0));
    }
    /* fuzz_rr's findings: the cap held exactly where q (max_speed / peak) rounded above it, and
     * a finite arm whose det J overflows is VF_ERR_OVERFLOW, not VF_OK with w = inf */
    {
        vf_rr_arm big;
        vf_rr_params p2 = {2.0, 2.0, 2.0, 0.0};
        double q2[6] = {2, -1, 2, 2, 2, 2}, x2[6] = {2, 2, 2, 2, 2, 2};
        int r;
        for (i = 0; i < 6; i++) {
            for (j = 0; j < 5; j++) {
                big.dh[i][j] = 2.0;
            }
        }
        big.dh[0][0] = 2.5411376953125;
        big.dh[0][3] = -1.0000000000000001e+300;
        big.dh[0][4] = -1.0000000000000001e+300;
        big.dh[2][3] = 5.5255569660239963e+141;
        big.tool[0] = big.tool[1] = big.tool[2] = 2.0;
        r = vf_rr_sr_step(&big, &p2, q2, x2, &out);
        CHECK(r == VF_ERR_OVERFLOW && out.q_dot[0] == 0.0 && out.scale == 1.0,
              "det J overflowed: %d", r);
    }
    for (t = 0; t < 2000; t++) {
        double qq[6], xx[6], ms = uniform(0.01, 5.0);
        vf_rr_params p3 = {0.025, 0.014, 1e-10, 0.0};
        for (j = 0; j < 6; j++) {
            qq[j] = uniform(-3.0, 3.0);
            xx[j] = normal() * 10.0;
        }
        p3.max_speed = ms;
        if (vf_rr_sr_step(&arm, &p3, qq, xx, &out) == VF_OK) {
            for (j = 0; j < 6; j++) {
                CHECK(fabs(out.q_dot[j]) <= ms, "cap exact: %.17g > %.17g", out.q_dot[j], ms);
            }
        }
    }
    return finish();
}
