/*
 * test_filter_metric.c -- vf_filter_cycle_metric (velfence_filter.h): the safety filter's cycle
 * in a full metric H = L L^T (the twist mode's J^T J + lambda^2 I). A Panda-like arm (Franka's
 * modified DH table) with a TCP box and 4 spheres, 300 states (inside, at and beyond the joint
 * limits; calm to saturating commands) in continuous and discrete time:
 *
 *   - a diagonal factor L = diag(sqrt(w)) gives the output of vf_filter_cycle with weights w
 *     (the diagonal fast path), value for value, and the same stages and active rows;
 *   - the factor replaces f->weights (with weights set, the same output as without);
 *   - with a full factor (H = J^T J + lambda^2 I of a random 6 x 7 J, lambda = 0.01, and a
 *     random well-conditioned H), a first-rung answer in continuous time is the H-nearest point:
 *     no direction d that keeps every claimed row met lowers the objective, checked on 64
 *     random directions per state, d^T H (x - u) >= -1e-9 |H (x - u)| |d| (the Euclidean
 *     projection fails this where it differs: checked too, so the check can fail); a first-rung
 *     answer without the model check moved the command (the stage PROJECTION) exactly when the
 *     command misses a row;
 *   - every output: finite, within the joint speed limits, every joint, workspace and obstacle
 *     row meets min(b, 0) and every claimed bound is met to the spec's tolerance 1e-12 (|c| +
 *     |g|_1 (|x|_inf + |u|_inf)); a second call gives the same bits;
 *   - refused with VF_ERR_ARGUMENT, a zero output and the stop stage: a NaN or infinite entry on
 *     or below the diagonal, a zero or negative diagonal entry; the entries above the diagonal
 *     are not read (NaN there changes nothing); a valid factor whose image of the rows G L^-T
 *     overflows: VF_ERR_OVERFLOW, a zero output.
 * Exactly-sized heap buffers (AddressSanitizer). Prints "ok <count>".
 */
#include "velfence_filter.h"
#include "vf_test.h"

#include <string.h>

#define NJ 7
#define STATES 300
#define K 4
#define DIRS 64

static const double MDH[NJ][4] = {
    {0.0, 0.0, 0.333, 0.0},          {0.0, -1.5707963267948966, 0.0, 0.0},
    {0.0, 1.5707963267948966, 0.316, 0.0}, {0.0825, 1.5707963267948966, 0.0, 0.0},
    {-0.0825, -1.5707963267948966, 0.384, 0.0}, {0.0, 1.5707963267948966, 0.0, 0.0},
    {0.088, 1.5707963267948966, 0.0, 0.0},
};
static const double LOWER[NJ] = {-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973};
static const double UPPER[NJ] = {2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973};
static const double VMAX[NJ] = {2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
static const double AMAX[NJ] = {15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0};

static void rxtxtz(double a, double alpha, double d, double *T)
{
    double c = cos(alpha), s = sin(alpha);
    double M[12] = {1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d};
    memcpy(T, M, sizeof M);
}

/* Cholesky factor L (row-major, lower; zeros above) of the SPD H (n x n). */
static void cholesky(const double *H, int n, double *L)
{
    int i, j, k;
    memset(L, 0, sizeof(double) * (size_t)(n * n));
    for (j = 0; j < n; j++) {
        double s = H[j * n + j];
        for (k = 0; k < j; k++) {
            s -= L[j * n + k] * L[j * n + k];
        }
        L[j * n + j] = sqrt(s);
        for (i = j + 1; i < n; i++) {
            double t = H[i * n + j];
            for (k = 0; k < j; k++) {
                t -= L[i * n + k] * L[j * n + k];
            }
            L[i * n + j] = t / L[j * n + j];
        }
    }
}

/* A random metric: twist = 1: J^T J + 1e-4 I (J 6 x n, entries N(0, 0.25)); else A A^T + I. */
static void random_metric(int twist, double *H)
{
    double A[6 * NJ], B[NJ * NJ];
    int i, j, k;
    if (twist) {
        for (i = 0; i < 6 * NJ; i++) {
            A[i] = 0.5 * normal();
        }
        for (i = 0; i < NJ; i++) {
            for (j = 0; j < NJ; j++) {
                double s = i == j ? 1e-4 : 0.0;
                for (k = 0; k < 6; k++) {
                    s += A[k * NJ + i] * A[k * NJ + j];
                }
                H[i * NJ + j] = s;
            }
        }
        return;
    }
    for (i = 0; i < NJ * NJ; i++) {
        B[i] = normal();
    }
    for (i = 0; i < NJ; i++) {
        for (j = 0; j < NJ; j++) {
            double s = i == j ? 1.0 : 0.0;
            for (k = 0; k < NJ; k++) {
                s += B[i * NJ + k] * B[j * NJ + k];
            }
            H[i * NJ + j] = s;
        }
    }
}

/* The output's safety and claims (the spec's acceptance), its speeds and finiteness. */
static void check_output(const double *x, const double *u, const vf_filter_info *info,
                         const char *what, int32_t s)
{
    double xi = 0.0, ui = 0.0;
    int32_t r, j;
    for (j = 0; j < NJ; j++) {
        CHECK(isfinite(x[j]) && fabs(x[j]) <= VMAX[j] * (1.0 + 1e-9), "%s %d: joint %d speed %g",
              what, (int)s, (int)j, x[j]);
        xi = fabs(x[j]) > xi ? fabs(x[j]) : xi;
        ui = fabs(u[j]) > ui ? fabs(u[j]) : ui;
    }
    for (r = 0; r < info->m; r++) {
        const double *g = info->G + (size_t)r * NJ;
        double gx = 0.0, g1 = 0.0, c = info->b[r] < 0.0 ? info->b[r] : 0.0;
        const double lim = info->bound[r];
        for (j = 0; j < NJ; j++) {
            gx += g[j] * x[j];
            g1 += fabs(g[j]);
        }
        if (info->level[r] != VF_FILTER_LEVEL_RATE && info->level[r] != VF_FILTER_LEVEL_JERK) {
            CHECK(gx - c >= -1e-12 * (fabs(c) + g1 * (xi + ui)),
                  "%s %d: row %d goes further out", what, (int)s, (int)r);
        }
        if (lim != -INFINITY) {
            CHECK(gx - lim >= -1e-12 * (fabs(lim) + g1 * (xi + ui)),
                  "%s %d: row %d misses its claimed bound", what, (int)s, (int)r);
        }
    }
}

/* The smallest d^T H (x - u) / (|H (x - u)| |d|) over DIRS random directions d that keep every
 * claimed row met from x (rows binding at x: g d >= 0); 1 when none qualifies. */
static double worst_descent(const double *H, const double *x, const double *u,
                            const vf_filter_info *info)
{
    double grad[NJ], gn = 0.0, worst = 1.0;
    int32_t i, j, r, t;
    for (i = 0; i < NJ; i++) {
        double s = 0.0;
        for (j = 0; j < NJ; j++) {
            s += H[i * NJ + j] * (x[j] - u[j]);
        }
        grad[i] = s;
        gn += s * s;
    }
    gn = sqrt(gn);
    if (gn == 0.0) {
        return 1.0;
    }
    for (t = 0; t < DIRS; t++) {
        double d[NJ], dn = 0.0, gd = 0.0;
        int ok = 1;
        for (j = 0; j < NJ; j++) {
            d[j] = normal();
            dn += d[j] * d[j];
        }
        dn = sqrt(dn);
        for (r = 0; r < info->m && ok; r++) {
            const double *g = info->G + (size_t)r * NJ;
            double gx = 0.0, gdr = 0.0;
            if (info->bound[r] == -INFINITY) {
                continue;
            }
            for (j = 0; j < NJ; j++) {
                gx += g[j] * x[j];
                gdr += g[j] * d[j];
            }
            if (gx - info->bound[r] <= 1e-9 * (1.0 + fabs(info->bound[r])) && gdr < 0.0) {
                ok = 0; /* leaves a binding row */
            }
        }
        for (j = 0; j < NJ && ok; j++) { /* and the speed limits (rows of every rung) */
            if ((x[j] >= VMAX[j] * (1.0 - 1e-9) && d[j] > 0.0)
                || (x[j] <= -VMAX[j] * (1.0 - 1e-9) && d[j] < 0.0)) {
                ok = 0;
            }
        }
        if (!ok) {
            continue;
        }
        for (j = 0; j < NJ; j++) {
            gd += grad[j] * d[j];
        }
        gd /= gn * dn;
        worst = gd < worst ? gd : worst;
    }
    return worst;
}

int main(void)
{
    vf_filter_joint joints[NJ];
    int32_t jkind[NJ];
    double jprm[NJ * VF_ND_PROFILE_PARAMS], centres[3 * K], radii[K], lrad[NJ], w[NJ];
    vf_filter_point tcp = {NJ, {0.0, 0.0, 0.0}};
    static const double BOXN[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const double BOXO[6] = {-0.5, -0.5, -0.5, -0.5, 0.1, -1.0};
    vf_filter_polytope box;
    vf_filter f, fw;
    vf_filter_info info, info2;
    double *H = dalloc(NJ * NJ), *L = dalloc(NJ * NJ), *Ld = dalloc(NJ * NJ);
    double *x = dalloc(NJ), *x2 = dalloc(NJ), *ref = dalloc(NJ), *q = dalloc(NJ);
    double *u = dalloc(NJ), *prev = dalloc(NJ), *sc, *sc2;
    int32_t *isc, *isc2;
    int32_t s, j, i, rc, rc2, cont, rung1 = 0, moved = 0, euclid_caught = 0, euclid_tried = 0;
    for (j = 0; j < NJ; j++) {
        double Kg = 2.0 * AMAX[j] / VMAX[j], d_int = (AMAX[j] / Kg) / Kg;
        rxtxtz(MDH[j][0], MDH[j][1], MDH[j][2], joints[j].T);
        joints[j].axis[0] = 0.0;
        joints[j].axis[1] = 0.0;
        joints[j].axis[2] = 1.0;
        joints[j].type = VF_FILTER_REVOLUTE;
        joints[j].offset = MDH[j][3];
        jkind[j] = VF_ND_PROFILE_THREE_ZONE;
        jprm[6 * j] = Kg;
        jprm[6 * j + 1] = VMAX[j];
        jprm[6 * j + 2] = AMAX[j];
        jprm[6 * j + 3] = d_int;
        jprm[6 * j + 4] = 0.5 * d_int;
        jprm[6 * j + 5] = 0.5 * d_int + (VMAX[j] / AMAX[j]) * (0.5 * VMAX[j]);
        lrad[j] = 0.06;
    }
    memset(&f, 0, sizeof f);
    {
        double tool[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.207};
        memcpy(f.tool, tool, sizeof tool);
    }
    box.point = 0;
    box.nf = 6;
    box.N = BOXN;
    box.off = BOXO;
    box.kind = VF_ND_PROFILE_LINEAR;
    memset(box.prm, 0, sizeof box.prm);
    box.prm[0] = 0.05;
    for (i = 0; i < K; i++) {
        centres[3 * i] = uniform(-0.5, 0.5);
        centres[3 * i + 1] = uniform(-0.5, 0.5);
        centres[3 * i + 2] = uniform(0.2, 0.9);
        radii[i] = uniform(0.02, 0.08);
    }
    f.n = NJ;
    f.joints = joints;
    f.lower = LOWER;
    f.upper = UPPER;
    f.vmax = VMAX;
    f.amax = AMAX;
    f.jkind = jkind;
    f.jprm = jprm;
    f.npoints = 1;
    f.points = &tcp;
    f.nw = 1;
    f.ws = &box;
    f.k = K;
    f.centres = centres;
    f.radii = radii;
    f.link_radius = lrad;
    f.obstacle_buffer = 0.05;
    f.spring_gain = 1.0;
    for (j = 0; j < NJ; j++) {
        w[j] = uniform(0.2, 5.0);
    }
    fw = f;
    fw.weights = w;
    CHECK(vf_filter_check(&f) == VF_OK && vf_filter_check(&fw) == VF_OK, "the descriptions");
    sc = dalloc(vf_filter_doubles(&fw));
    isc = ialloc(vf_filter_ints(&fw));
    sc2 = dalloc(vf_filter_doubles(&f));
    isc2 = ialloc(vf_filter_ints(&f));
    memset(Ld, 0, sizeof(double) * NJ * NJ);
    for (j = 0; j < NJ; j++) {
        Ld[j * NJ + j] = sqrt(w[j]);
    }
    for (s = 0; s < STATES; s++) {
        const double scale = s % 4 == 0 ? 30.0 : s % 4 == 1 ? 3.0 : 0.5;
        const int has_prev = s % 3 == 0;
        cont = s % 2 == 0;
        f.dt = fw.dt = cont ? 0.0 : 0.002;
        for (j = 0; j < NJ; j++) {
            const double span = UPPER[j] - LOWER[j];
            q[j] = s % 5 == 0 ? (s % 2 ? UPPER[j] : LOWER[j]) + uniform(-0.02, 0.02)
                              : uniform(LOWER[j] - 0.05 * span, UPPER[j] + 0.05 * span);
            u[j] = scale * VMAX[j] * uniform(-1.0, 1.0);
            prev[j] = VMAX[j] * uniform(-1.0, 1.0);
        }
        /* the diagonal factor equals the diagonal weights */
        rc = vf_filter_cycle_metric(&f, q, u, has_prev ? prev : NULL, NULL, Ld, NULL, x, &info,
                                    sc2, isc2);
        rc2 = vf_filter_cycle(&fw, q, u, has_prev ? prev : NULL, NULL, ref, &info2, sc, isc);
        CHECK(rc == rc2 && info.stages == info2.stages && info.n_active == info2.n_active,
              "state %d: diagonal factor vs weights: status %d/%d stages %d/%d", (int)s, rc,
              rc2, (int)info.stages, (int)info2.stages);
        for (j = 0; j < NJ; j++) {
            CHECK(x[j] == ref[j], "state %d: diagonal factor vs weights, joint %d: %.17g %.17g",
                  (int)s, (int)j, x[j], ref[j]);
        }
        /* the factor replaces the weights */
        rc2 = vf_filter_cycle_metric(&fw, q, u, has_prev ? prev : NULL, NULL, Ld, NULL, x2,
                                     &info2, sc, isc);
        CHECK(rc2 == rc && memcmp(x, x2, sizeof(double) * NJ) == 0,
              "state %d: the factor replaces f->weights", (int)s);
        /* a full factor */
        random_metric(s % 3 != 2, H);
        cholesky(H, NJ, L);
        for (j = 1; j < NJ; j++) {
            L[j] = NAN; /* above the diagonal: not read (row 0, columns 1 ..) */
        }
        rc = vf_filter_cycle_metric(&f, q, u, has_prev ? prev : NULL, NULL, L, NULL, x, &info,
                                    sc2, isc2);
        CHECK(rc == VF_OK, "state %d: full factor status %d", (int)s, rc);
        check_output(x, u, &info, "full factor", s);
        rc2 = vf_filter_cycle_metric(&f, q, u, has_prev ? prev : NULL, NULL, L, NULL, x2, &info2,
                                     sc2, isc2);
        CHECK(rc2 == rc && memcmp(x, x2, sizeof(double) * NJ) == 0,
              "state %d: a second call differs", (int)s);
        {
            int misses = 0;
            for (i = 0; i < info.m; i++) {
                double gu = 0.0;
                for (j = 0; j < NJ; j++) {
                    gu += info.G[(size_t)i * NJ + j] * u[j];
                }
                misses |= !(gu >= info.b[i]);
            }
            if (info.rung == 1
                && !(info.stages & (VF_FILTER_STAGE_MODEL_CHECK | VF_FILTER_STAGE_MODEL_SCALED
                                    | VF_FILTER_STAGE_COMMAND_SCALED))) {
                CHECK(((info.stages & VF_FILTER_STAGE_PROJECTION) != 0) == misses,
                      "state %d: the command is moved exactly when it misses a row", (int)s);
                moved += misses;
            }
        }
        if (cont && info.rung == 1 && (info.stages & VF_FILTER_STAGE_PROJECTION)
            && !(info.stages & (VF_FILTER_STAGE_MODEL_SCALED | VF_FILTER_STAGE_COMMAND_SCALED))) {
            const double wd = worst_descent(H, x, u, &info);
            CHECK(wd >= -1e-9, "state %d: a feasible descent direction (%.3g) at the answer",
                  (int)s, wd);
            rung1 += 1;
            /* the check can fail: the Euclidean projection (no metric) is not H-nearest */
            if (vf_filter_cycle(&f, q, u, has_prev ? prev : NULL, NULL, x2, &info2, sc2, isc2)
                    == VF_OK
                && info2.rung == 1) {
                euclid_tried += 1;
                euclid_caught += worst_descent(H, x2, u, &info2) < -1e-6;
            }
        }
    }
    CHECK(rung1 >= 30 && moved >= 60, "enough projected states: %d first-rung, %d moved",
          (int)rung1, (int)moved);
    CHECK(euclid_tried >= 20 && euclid_caught >= 20,
          "the optimality check catches the Euclidean answer (%d of %d)", (int)euclid_caught,
          (int)euclid_tried);
    /* refusals: VF_ERR_ARGUMENT, zero output, the stop stage */
    {
        static const double BAD[4] = {NAN, INFINITY, 0.0, -1.0};
        int b;
        f.dt = 0.002;
        random_metric(1, H);
        cholesky(H, NJ, L);
        for (b = 0; b < 4; b++) {
            double keep;
            int at = b < 2 ? 3 * NJ + 1 : 4 * NJ + 4; /* below the diagonal, then on it */
            keep = L[at];
            L[at] = BAD[b];
            for (j = 0; j < NJ; j++) {
                x[j] = 7.0;
            }
            rc = vf_filter_cycle_metric(&f, q, u, prev, NULL, L, NULL, x, &info, sc2, isc2);
            CHECK(rc == VF_ERR_ARGUMENT && info.status == VF_ERR_ARGUMENT
                      && info.stages == VF_FILTER_STAGE_STOP,
                  "bad factor %d: status %d", b, rc);
            for (j = 0; j < NJ; j++) {
                CHECK(x[j] == 0.0, "bad factor %d: output zero", b);
            }
            L[at] = keep;
        }
        rc = vf_filter_cycle_metric(&f, q, u, prev, NULL, L, NULL, x, &info, sc2, isc2);
        CHECK(rc == VF_OK, "the repaired factor runs: %d", rc);
        /* a valid factor whose image of the rows overflows: VF_ERR_OVERFLOW, output zero */
        for (i = 0; i < NJ; i++) {
            for (j = 0; j <= i; j++) {
                Ld[i * NJ + j] = i == j ? 1e-200 : 1e200;
            }
        }
        rc = vf_filter_cycle_metric(&f, q, u, prev, NULL, Ld, NULL, x, &info, sc2, isc2);
        CHECK(rc == VF_ERR_OVERFLOW && info.stages == VF_FILTER_STAGE_STOP, "overflow: %d", rc);
        for (j = 0; j < NJ; j++) {
            CHECK(x[j] == 0.0, "overflow: output zero");
        }
    }
    free(H);
    free(L);
    free(Ld);
    free(x);
    free(x2);
    free(ref);
    free(q);
    free(u);
    free(prev);
    free(sc);
    free(isc);
    free(sc2);
    free(isc2);
    return finish();
}
