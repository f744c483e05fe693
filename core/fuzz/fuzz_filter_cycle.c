/*
 * fuzz_filter_cycle.c -- libFuzzer target of the safety filter's whole cycle
 * (core/include/velfence_filter.h: vf_filter_check, vf_filter_doubles / _ints, vf_filter_cycle with
 * the ladder, the model check and the deadline fallback; vf_filter_cycle_metric with a full
 * metric's factor). Build: core/fuzz/build.sh. Input layout
 * (the byte cursor and double decoder of fuzz_common.h):
 *
 *   flags byte: bit 0 raw-ish state (q, u, previous any decoded doubles), bit 1 previous NULL,
 *     bit 2 amax NULL, bit 3 continuous time (dt = 0), bit 4 weights, bit 5 link radii NULL,
 *     bit 6 tamper: one field of the description overwritten by a decoded double, bit 7 opts NULL
 *   n = 1 + byte % 7 joints; per joint a rotation Rz(2 pi b0/256) Ry(2 pi b1/256) Rx(2 pi b2/256)
 *     and a translation three (byte - 128) / 256 [m] (the fixed transform), an axis from two angles,
 *     the type (prismatic when the byte is odd and there are no spheres), an offset 2 pi byte / 256;
 *     a tool transform likewise
 *   per joint: lower -inf (odd byte) or -(byte >> 1) / 32, upper +inf (odd) or (byte >> 1) / 32,
 *     vmax (1 + byte) / 32, amax +inf (byte 255) or (1 + byte) / 4, a profile (as fuzz_filter.c:
 *     even kind byte linear (d_max, k, r_max), odd three-zone derived as ThreeZoneBraking does)
 *   npoints = 1 + byte % 3: link byte % (n + 2) - 1, offset three (byte - 128) / 256
 *   nw = byte % 3 polytopes: point byte % npoints, nf = 1 + byte % 6, a profile, per facet a unit
 *     normal from two angles and an offset (byte - 128) / 128
 *   k = byte % 6 spheres (0 when a joint is prismatic): centre three (byte - 128) / 128, radius
 *     byte / 256; per link a capsule radius byte / 512; buffer (1 + byte) / 64, gain byte / 16
 *   dt = (1 + byte) / 1024; weights (1 + byte) / 32; opts: max_iterations byte % 6 (0: default),
 *     n_warm byte % 5 keys (level byte % 4, a byte % 8, b byte % 8)
 *   tamper (bit 6): field byte % 12 of the description replaced by a decoded double
 *   per joint q_j, u_j, previous_j: int16 / 4096 (structured) or decoded doubles (raw-ish)
 *   a full metric (vf_filter_cycle_metric, the twist mode's H = L L^T) when the input's LAST
 *     byte is FACTOR_MARK (0xFA; that byte is not read as data; no earlier input ends with it):
 *     after the state, per entry of L on and below the diagonal, row by row, a byte: diagonal
 *     (1 + byte) / 32, below (byte - 128) / 64; the entries above the diagonal NaN (not read);
 *     then a byte: when % 4 == 0, the entry byte % (n (n + 1) / 2) (on or below the diagonal,
 *     row by row) replaced by a decoded double (a tampered factor)
 *
 * Asserted (abort() after printing, on a violation):
 *   vf_filter_check's code equals the cycle's for a bad description (and the output is zero);
 *   a non-finite or > 1e150 state gives VF_ERR_NONFINITE and a zero output; else a factor with
 *   a non-finite entry on or below the diagonal or a diagonal entry <= 0 gives VF_ERR_ARGUMENT
 *   and a zero output;
 *   otherwise a status in {VF_OK, VF_ITERATION_CAP, VF_ERR_OVERFLOW} (no time budget: never
 *   VF_DEADLINE); a negative status has a zero output; else the output is finite, 0 <= m <=
 *   vf_filter_rows_max, rung in 1..6, every row of levels 0-2 meets min(b, 0) and every row its
 *   claimed bound (info.bound, unless -inf) to 1e-12 (|c| + |g|_1 (|x|_inf + |u|_inf)) (the
 *   spec's acceptance) and every joint speed |x_j| <= vmax_j (1 + 1e-9) (never relaxed: a tolerance
 *   relative to |x| would accept any far-off answer); the fallback's output is t u with
 *   0 <= t <= 1; a second call gives the same bits.
 * The scratch is malloc'ed at exactly vf_filter_doubles / vf_filter_ints, so AddressSanitizer
 * sees an overrun. VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) spoils the output of every
 * VF_OK cycle, for the tests' proof that a violation aborts.
 */
#define VF_FUZZ_BYTES_ONLY
#include "fuzz_common.h"
#include "velfence_filter.h"

#define MAXN 7
#define MAXP 3
#define MAXW 2
#define MAXF 6
#define MAXK 5
#define TWO_PI 6.283185307179586
#define FACTOR_MARK 0xFA /* the last byte that asks for a full metric's factor */

static void rot_trans(fz_reader *r, double *T)
{
    double a = TWO_PI * fz_byte(r) / 256.0, b = TWO_PI * fz_byte(r) / 256.0;
    double c = TWO_PI * fz_byte(r) / 256.0;
    double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b), cc = cos(c), sc = sin(c);
    /* Rz(a) Ry(b) Rx(c) */
    T[0] = ca * cb;
    T[1] = ca * sb * sc - sa * cc;
    T[2] = ca * sb * cc + sa * sc;
    T[4] = sa * cb;
    T[5] = sa * sb * sc + ca * cc;
    T[6] = sa * sb * cc - ca * sc;
    T[8] = -sb;
    T[9] = cb * sc;
    T[10] = cb * cc;
    T[3] = (fz_byte(r) - 128) / 256.0;
    T[7] = (fz_byte(r) - 128) / 256.0;
    T[11] = (fz_byte(r) - 128) / 256.0;
}

static void unit(fz_reader *r, double *v)
{
    double th = TWO_PI * fz_byte(r) / 256.0, ph = TWO_PI * fz_byte(r) / 256.0;
    v[0] = cos(th) * cos(ph);
    v[1] = sin(th) * cos(ph);
    v[2] = sin(ph);
}

/* The full metric's factor of the input being run (NULL: none), for report(). */
static const double *report_factor = NULL;

static void report(const char *what, const vf_filter *f, const double *q, const double *u,
                   const double *prev, const double *x, const vf_filter_info *info, int rc)
{
    int32_t a;
    fprintf(stderr, "contract violated: %s (rc %d, n %d, nw %d, k %d, dt %g)\n", what, rc,
            (int)f->n, (int)f->nw, (int)f->k, f->dt);
    for (a = 0; report_factor != NULL && a < f->n; a++) {
        fz_print_vec("factor row", report_factor + (size_t)a * f->n, a + 1);
    }
    fz_print_vec("q", q, f->n);
    fz_print_vec("u", u, f->n);
    if (prev != NULL) {
        fz_print_vec("previous", prev, f->n);
    }
    fz_print_vec("x", x, f->n);
    fprintf(stderr, "stages %d rung %d m %d deadline %d\n", (int)info->stages, (int)info->rung,
            (int)info->m, (int)info->deadline);
    abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const int full = size > 0 && data[size - 1] == FACTOR_MARK;
    fz_reader rd = {data, full ? size - 1 : size};
    fz_reader *r = &rd;
    vf_filter_joint joints[MAXN];
    vf_filter_point points[MAXP];
    vf_filter_polytope ws[MAXW];
    double lower[MAXN], upper[MAXN], vmax[MAXN], amax[MAXN], jprm[6 * MAXN], lrad[MAXN];
    double wts[MAXN], N[MAXW][3 * MAXF], off[MAXW][MAXF], C[3 * MAXK], rad[MAXK];
    double q[MAXN], u[MAXN], prev[MAXN], x[MAXN], x2[MAXN], Lf[MAXN * MAXN];
    const double *factor = NULL;
    int bad_factor = 0;
    int32_t jkind[MAXN], warm[3 * 4];
    vf_filter f;
    vf_filter_opts opts;
    vf_filter_info info, info2;
    uint8_t flags;
    int32_t n, j, w, i, rc, rc2, chk, prismatic = 0;
    double *scratch;
    int32_t *iscratch;
    const double *pp;
    memset(&f, 0, sizeof f);
    memset(&opts, 0, sizeof opts);
    flags = fz_byte(r);
    n = 1 + fz_byte(r) % MAXN;
    for (j = 0; j < n; j++) {
        rot_trans(r, joints[j].T);
        unit(r, joints[j].axis);
        joints[j].type = fz_byte(r) % 2 ? VF_FILTER_PRISMATIC : VF_FILTER_REVOLUTE;
        prismatic |= joints[j].type == VF_FILTER_PRISMATIC;
        joints[j].offset = TWO_PI * fz_byte(r) / 256.0;
        {
            uint8_t b = fz_byte(r);
            lower[j] = b % 2 ? -INFINITY : -(b >> 1) / 32.0;
            b = fz_byte(r);
            upper[j] = b % 2 ? INFINITY : (b >> 1) / 32.0;
        }
        vmax[j] = (1 + fz_byte(r)) / 32.0;
        {
            uint8_t b = fz_byte(r);
            amax[j] = b == 255 ? INFINITY : (1 + b) / 4.0;
        }
        fz_profile(r, jkind + j, jprm + 6 * j);
        lrad[j] = fz_byte(r) / 512.0;
        wts[j] = (1 + fz_byte(r)) / 32.0;
    }
    rot_trans(r, f.tool);
    f.n = n;
    f.joints = joints;
    f.lower = lower;
    f.upper = upper;
    f.vmax = vmax;
    f.amax = flags & 4 ? NULL : amax;
    f.jkind = jkind;
    f.jprm = jprm;
    f.npoints = 1 + fz_byte(r) % MAXP;
    for (i = 0; i < f.npoints; i++) {
        points[i].link = fz_byte(r) % (n + 2) - 1;
        points[i].offset[0] = (fz_byte(r) - 128) / 256.0;
        points[i].offset[1] = (fz_byte(r) - 128) / 256.0;
        points[i].offset[2] = (fz_byte(r) - 128) / 256.0;
    }
    f.points = points;
    f.nw = fz_byte(r) % (MAXW + 1);
    for (w = 0; w < f.nw; w++) {
        ws[w].point = fz_byte(r) % f.npoints;
        ws[w].nf = 1 + fz_byte(r) % MAXF;
        fz_profile(r, &ws[w].kind, ws[w].prm);
        for (i = 0; i < ws[w].nf; i++) {
            unit(r, N[w] + 3 * i);
            off[w][i] = (fz_byte(r) - 128) / 128.0;
        }
        ws[w].N = N[w];
        ws[w].off = off[w];
    }
    f.ws = ws;
    f.k = prismatic ? 0 : fz_byte(r) % (MAXK + 1);
    for (i = 0; i < f.k; i++) {
        C[3 * i] = (fz_byte(r) - 128) / 128.0;
        C[3 * i + 1] = (fz_byte(r) - 128) / 128.0;
        C[3 * i + 2] = (fz_byte(r) - 128) / 128.0;
        rad[i] = fz_byte(r) / 256.0;
    }
    f.centres = C;
    f.radii = rad;
    f.link_radius = flags & 32 ? NULL : lrad;
    f.obstacle_buffer = (1 + fz_byte(r)) / 64.0;
    f.spring_gain = fz_byte(r) / 16.0;
    f.dt = flags & 8 ? 0.0 : (1 + fz_byte(r)) / 1024.0;
    f.weights = flags & 16 ? wts : NULL;
    opts.max_iterations = fz_byte(r) % 6;
    opts.n_warm = fz_byte(r) % 5;
    for (i = 0; i < 3 * opts.n_warm; i++) {
        warm[i] = fz_byte(r) % (i % 3 == 0 ? 4 : 8);
    }
    opts.warm = warm;
    if (flags & 64) {
        double v = fz_double(r);
        switch (fz_byte(r) % 12) {
        case 0: vmax[0] = v; break;
        case 1: lower[0] = v; break;
        case 2: upper[n - 1] = v; break;
        case 3: joints[0].T[3] = v; break;
        case 4: joints[n - 1].axis[0] = v; break;
        case 5: f.dt = v; break;
        case 6: f.obstacle_buffer = v; break;
        case 7: f.spring_gain = v; break;
        case 8: jprm[0] = v; break;
        case 9: wts[0] = v; f.weights = wts; break;
        case 10: if (f.nw > 0) { N[0][0] = v; } break;
        default: if (f.k > 0) { rad[0] = v; } break;
        }
    }
    for (j = 0; j < n; j++) {
        if (flags & 1) {
            q[j] = fz_double(r);
            u[j] = fz_double(r);
            prev[j] = fz_double(r);
        } else {
            q[j] = fz_i16(r) / 4096.0;
            u[j] = fz_i16(r) / 4096.0;
            prev[j] = fz_i16(r) / 4096.0;
        }
    }
    pp = flags & 2 ? NULL : prev;
    if (full) {
        int32_t a, b, e = 0, tamper;
        for (a = 0; a < n; a++) {
            for (b = 0; b < n; b++) {
                Lf[a * n + b] = b > a ? NAN : b == a ? (1 + fz_byte(r)) / 32.0
                                                      : (fz_byte(r) - 128) / 64.0;
            }
        }
        if (fz_byte(r) % 4 == 0) {
            tamper = fz_byte(r) % (n * (n + 1) / 2);
            for (a = 0; a < n; a++) {
                for (b = 0; b <= a; b++, e++) {
                    if (e == tamper) {
                        Lf[a * n + b] = fz_double(r);
                    }
                }
            }
        }
        for (a = 0; a < n; a++) {
            for (b = 0; b <= a; b++) {
                bad_factor |= !isfinite(Lf[a * n + b]) || (a == b && !(Lf[a * n + b] > 0.0));
            }
        }
        factor = Lf;
    }
    report_factor = factor;
    chk = vf_filter_check(&f);
    if (chk != VF_OK) {
        double s0[1];
        int32_t i0[1];
        rc = vf_filter_cycle_metric(&f, q, u, pp, NULL, factor, flags & 128 ? NULL : &opts, x,
                                    &info, s0, i0);
        if (rc != chk) {
            report("a bad description's cycle code differs from vf_filter_check's", &f, q, u, pp,
                   x, &info, rc);
        }
        for (j = 0; j < n; j++) {
            if (x[j] != 0.0) {
                report("non-zero output on an error", &f, q, u, pp, x, &info, rc);
            }
        }
        if (vf_filter_doubles(&f) != 0 || vf_filter_ints(&f) != 0) {
            report("scratch sizes of a bad description", &f, q, u, pp, x, &info, rc);
        }
        return 0;
    }
    scratch = fz_alloc((int32_t)vf_filter_doubles(&f));
    iscratch = (int32_t *)malloc(vf_filter_ints(&f) * sizeof(int32_t));
    rc = vf_filter_cycle_metric(&f, q, u, pp, NULL, factor, flags & 128 ? NULL : &opts, x, &info,
                                scratch, iscratch);
#ifdef VF_FUZZ_CONTROL_TAMPER
    if (rc == VF_OK) {
        x[0] = NAN;
    }
#endif
    {
        int bad_state = 0;
        for (j = 0; j < n; j++) {
            if (!(fabs(q[j]) <= 1e150) || !(fabs(u[j]) <= 1e150)
                || (pp != NULL && !(fabs(pp[j]) <= 1e150))) {
                bad_state = 1;
            }
        }
        if (bad_state != (rc == VF_ERR_NONFINITE)) {
            report("VF_ERR_NONFINITE exactly for a non-finite or too large state", &f, q, u, pp,
                   x, &info, rc);
        }
        if (!bad_state && bad_factor != (rc == VF_ERR_ARGUMENT)) {
            report("VF_ERR_ARGUMENT exactly for a bad factor", &f, q, u, pp, x, &info, rc);
        }
    }
    if (rc < 0) {
        if (rc != VF_ERR_NONFINITE && rc != VF_ERR_OVERFLOW && rc != VF_ERR_ARGUMENT) {
            report("unexpected error code", &f, q, u, pp, x, &info, rc);
        }
        for (j = 0; j < n; j++) {
            if (x[j] != 0.0) {
                report("non-zero output on an error", &f, q, u, pp, x, &info, rc);
            }
        }
    } else {
        double xi = 0.0, ui = 0.0;
        int32_t rr;
        if (rc != VF_OK && rc != VF_ITERATION_CAP) {
            report("unexpected outcome (no time budget)", &f, q, u, pp, x, &info, rc);
        }
        for (j = 0; j < n; j++) {
            if (!isfinite(x[j])) {
                report("non-finite output", &f, q, u, pp, x, &info, rc);
            }
            xi = fabs(x[j]) > xi ? fabs(x[j]) : xi;
            ui = fabs(u[j]) > ui ? fabs(u[j]) : ui;
            if (!(fabs(x[j]) <= vmax[j] * (1.0 + 1e-9))) {
                /* the velocity rows are in every rung: never relaxed, never dropped */
                report("a joint speed limit exceeded", &f, q, u, pp, x, &info, rc);
            }
        }
        xi += ui; /* the round-off of forming x from u */
        if (info.m < 0 || (size_t)info.m > vf_filter_rows_max(&f) || info.rung < 1
            || info.rung > 6 || info.n_active > info.m) {
            report("info out of range", &f, q, u, pp, x, &info, rc);
        }
        for (rr = 0; rr < info.m; rr++) {
            const double *g = info.G + (size_t)rr * n;
            double gx = 0.0, g1 = 0.0, c = info.b[rr] < 0.0 ? info.b[rr] : 0.0;
            double lim = info.bound[rr];
            for (j = 0; j < n; j++) {
                gx += g[j] * x[j];
                g1 += fabs(g[j]);
            }
            if (info.level[rr] != VF_FILTER_LEVEL_RATE
                && !(gx - c >= -1e-12 * (fabs(c) + g1 * xi))) {
                fprintf(stderr, "row %d level %d: G x = %.17g, min(b, 0) = %.17g\n", (int)rr,
                        (int)info.level[rr], gx, c);
                report("a safety row goes further out", &f, q, u, pp, x, &info, rc);
            }
            if (lim != -INFINITY && !(gx - lim >= -1e-12 * (fabs(lim) + g1 * xi))) {
                fprintf(stderr, "row %d level %d: G x = %.17g, claimed bound %.17g\n", (int)rr,
                        (int)info.level[rr], gx, lim);
                report("a claimed bound missed", &f, q, u, pp, x, &info, rc);
            }
        }
        if (rc == VF_ITERATION_CAP) {
            /* the fallback: t u (after the command cap), 0 <= t <= 1 */
            double uu = 0.0, xu = 0.0;
            for (j = 0; j < n; j++) {
                uu += u[j] * u[j];
                xu += x[j] * u[j];
            }
            if (uu > 0.0 && !(xu >= -1e-12 * uu && xu <= uu * (1.0 + 1e-9))) {
                report("the fallback is not a scaled command", &f, q, u, pp, x, &info, rc);
            }
        }
        rc2 = vf_filter_cycle_metric(&f, q, u, pp, NULL, factor, flags & 128 ? NULL : &opts, x2,
                                     &info2, scratch, iscratch);
        for (j = 0; j < n; j++) {
            if (rc2 != rc || !fz_same_bits(x[j], x2[j])) {
                report("a second call differs", &f, q, u, pp, x, &info, rc);
            }
        }
    }
    free(scratch);
    free(iscratch);
    return 0;
}
