/*
 * velfence_cc.c -- configuration control for one control cycle (velfence_cc.h).
 *
 * The Python reference is velfence.redundancy.configuration_control (ConfigurationController._pose,
 * _active_set, _solve_stacked and _result); the comments name the step each block follows.
 */
#include "velfence_cc.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "vf_util.h" /* vf_finite_all, vf_dot */

#define RATE_EPS 1e-12 /* configuration_control._RATE_EPS */
#define MAX_SWEEPS 64

size_t vf_cc_doubles(int32_t n, int32_t m, int32_t k)
{
    size_t nn = n > 0 ? (size_t)n : 0, mm = m > 0 ? (size_t)m : 0, kk = k > 0 ? (size_t)k : 0;
    size_t r = mm + kk + nn;
    /* je, zxp, M0 (Cholesky), K, G, H, stacked A + b, V, vectors */
    return mm * nn + 3 * nn + nn * nn + nn * kk + 2 * kk * kk + r * (nn + 1) + nn * nn
           + 12 * kk + 6 * nn + 8;
}

size_t vf_cc_ints(int32_t k)
{
    return 3 * (size_t)(k > 0 ? k : 0) + 1;
}

int vf_cc_check(const vf_cc_problem *pb)
{
    int32_t i;
    if (pb == NULL) {
        return VF_CC_ERR_NULL;
    }
    if (pb->n < 1 || (pb->m != 2 && pb->m != 3) || pb->k < 0 || pb->rounds < 0
        || pb->n > 4096 || pb->k > (1 << 20)) {
        return VF_CC_ERR_ARGUMENT;
    }
    if (pb->lrad == NULL || (pb->k > 0 && (pb->C == NULL || pb->rho == NULL))) {
        return VF_CC_ERR_NULL;
    }
    if (!(pb->w_e > 0.0 && pb->w_z > 0.0 && pb->lam > 0.0 && pb->kz >= 0.0 && pb->h >= 0.0
          && pb->max_speed >= 0.0 && isfinite(pb->w_e) && isfinite(pb->w_z) && isfinite(pb->lam)
          && isfinite(pb->kz) && isfinite(pb->h) && !isnan(pb->max_speed))) {
        return VF_CC_ERR_ARGUMENT;
    }
    for (i = 0; i < pb->n; i++) {
        if (!(pb->lrad[i] >= 0.0 && isfinite(pb->lrad[i]))) {
            return VF_CC_ERR_ARGUMENT;
        }
    }
    for (i = 0; i < pb->k; i++) {
        if (!(pb->rho[i] > 0.0 && isfinite(pb->rho[i]))
            || !vf_finite_all(pb->C + 3 * (size_t)i, 3)) {
            return VF_CC_ERR_ARGUMENT;
        }
    }
    return VF_CC_OK;
}

static void stop(const vf_cc_problem *pb, vf_cc_out *out)
{
    int32_t n = pb->n, k = pb->k, i;
    memset(out->q_dot, 0, (size_t)n * sizeof(double));
    memset(out->q_free, 0, (size_t)n * sizeof(double));
    if (k > 0) {
        memset(out->points, 0, 3 * (size_t)k * sizeof(double));
        memset(out->fractions, 0, (size_t)k * sizeof(double));
        memset(out->distances, 0, (size_t)k * sizeof(double));
        memset(out->normals, 0, 3 * (size_t)k * sizeof(double));
        memset(out->rows, 0, (size_t)k * (size_t)n * sizeof(double));
        memset(out->d_dot, 0, (size_t)k * sizeof(double));
        memset(out->d_dot_free, 0, (size_t)k * sizeof(double));
        for (i = 0; i < k; i++) {
            out->links[i] = -1;
            out->active[i] = -1;
        }
    }
    out->n_active = 0;
    out->condition = 0.0;
    out->ee_rate_error = 0.0;
    out->ee_rate_error_free = 0.0;
}

/* Steps A-C (ConfigurationController._pose): the nearest link of every obstacle (the first minimum
 * of the capsule clearances), the critical point on it, the distance, normal and row. */
static void critical(const vf_cc_problem *pb, const double *P, const double *axes,
                     const double *zxp, vf_cc_out *out)
{
    const int32_t n = pb->n;
    int32_t i, l, j;
    for (i = 0; i < pb->k; i++) {
        const double *c = pb->C + 3 * (size_t)i;
        double best = INFINITY, bt = 0.0;
        int32_t bl = 0;
        double *x = out->points + 3 * (size_t)i;
        double *u = out->normals + 3 * (size_t)i;
        double *row = out->rows + (size_t)i * (size_t)n;
        double rx, ry, rz, dist, cxu0, cxu1, cxu2;
        for (l = 0; l < n; l++) {
            const double *a = P + 3 * (size_t)l;
            double ex = a[3] - a[0], ey = a[4] - a[1], ez = a[5] - a[2];
            double ee = ex * ex + ey * ey + ez * ez;
            double q0 = c[0] - a[0], q1 = c[1] - a[1], q2 = c[2] - a[2];
            double t = ee > 0.0 ? (q0 * ex + q1 * ey + q2 * ez) / ee : 0.0;
            double d0, d1, d2, cl;
            t = t > 0.0 ? t : 0.0;
            t = t < 1.0 ? t : 1.0;
            d0 = q0 - t * ex;
            d1 = q1 - t * ey;
            d2 = q2 - t * ez;
            cl = sqrt(d0 * d0 + d1 * d1 + d2 * d2) - pb->lrad[l];
            if (cl < best || l == 0) { /* strict: ties keep the more proximal link */
                best = cl;
                bl = l;
                bt = t;
            }
        }
        {
            const double *a = P + 3 * (size_t)bl;
            double ex = a[3] - a[0], ey = a[4] - a[1], ez = a[5] - a[2];
            x[0] = a[0] + bt * ex;
            x[1] = a[1] + bt * ey;
            x[2] = a[2] + bt * ez;
            rx = x[0] - c[0];
            ry = x[1] - c[1];
            rz = x[2] - c[2];
            dist = sqrt(rx * rx + ry * ry + rz * rz);
            if (dist > 0.0) {
                u[0] = rx / dist;
                u[1] = ry / dist;
                u[2] = rz / dist;
            } else { /* the centre on the link's axis: a normal of the link in the plane */
                double hh = hypot(ex, ey);
                u[0] = hh == 0.0 ? 1.0 : -ey / hh;
                u[1] = hh == 0.0 ? 0.0 : ex / hh;
                u[2] = 0.0;
            }
        }
        out->links[i] = bl;
        out->fractions[i] = bt;
        out->distances[i] = dist - pb->lrad[bl];
        /* Step C: u . (z_j x (x - P_j)) = z_j . (x x u) - u . (z_j x P_j), joints j <= link. */
        cxu0 = x[1] * u[2] - x[2] * u[1];
        cxu1 = x[2] * u[0] - x[0] * u[2];
        cxu2 = x[0] * u[1] - x[1] * u[0];
        for (j = 0; j < n; j++) {
            const double *z = axes + 3 * (size_t)j;
            const double *w = zxp + 3 * (size_t)j;
            row[j] = j <= bl ? (cxu0 * z[0] + cxu1 * z[1] + cxu2 * z[2])
                                   - (u[0] * w[0] + u[1] * w[1] + u[2] * w[2])
                             : 0.0;
        }
    }
}

/* Cholesky factor L (lower, in place) of the n x n SPD matrix M; 0 when a pivot is not positive. */
static int cholesky(double *M, int32_t n)
{
    int32_t i, j, p;
    for (j = 0; j < n; j++) {
        double s = M[(size_t)j * n + j];
        for (p = 0; p < j; p++) {
            s -= M[(size_t)j * n + p] * M[(size_t)j * n + p];
        }
        if (!(s > 0.0) || !isfinite(s)) {
            return 0;
        }
        s = sqrt(s);
        M[(size_t)j * n + j] = s;
        for (i = j + 1; i < n; i++) {
            double t = M[(size_t)i * n + j];
            for (p = 0; p < j; p++) {
                t -= M[(size_t)i * n + p] * M[(size_t)j * n + p];
            }
            M[(size_t)i * n + j] = t / s;
        }
    }
    return 1;
}

/* x <- (L L^T)^-1 x for the factor of cholesky(). */
static void chol_solve(const double *L, int32_t n, double *x)
{
    int32_t i, p;
    for (i = 0; i < n; i++) {
        double s = x[i];
        for (p = 0; p < i; p++) {
            s -= L[(size_t)i * n + p] * x[p];
        }
        x[i] = s / L[(size_t)i * n + i];
    }
    for (i = n - 1; i >= 0; i--) {
        double s = x[i];
        for (p = i + 1; p < n; p++) {
            s -= L[(size_t)p * n + i] * x[p];
        }
        x[i] = s / L[(size_t)i * n + i];
    }
}

/* a . b with four partial sums: the additions of one sum wait on each other, so four
 * independent chains run about four times faster on a pipelined FPU (the rounding differs from a
 * single running sum; nothing here is bit-matched to Python). */
static double dot4(const double *a, const double *b, int32_t n)
{
    double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int32_t i = 0;
    for (; i + 3 < n; i += 4) {
        s0 += a[i] * b[i];
        s1 += a[i + 1] * b[i + 1];
        s2 += a[i + 2] * b[i + 2];
        s3 += a[i + 3] * b[i + 3];
    }
    for (; i < n; i++) {
        s0 += a[i] * b[i];
    }
    return (s0 + s1) + (s2 + s3);
}

/* One-sided Jacobi (Hestenes): rotate pairs of columns of the r x n column-major matrix Acol until
 * they are orthogonal to working precision; with V (n x n, column-major) the rotations are
 * accumulated into it, V = I first; nrm: n doubles of scratch. Afterwards the column norms are the
 * singular values. */
static void jacobi_columns(double *Acol, int32_t r, int32_t n, double *V, double *nrm)
{
    int32_t p, q, i, sweep;
    if (V != NULL) {
        memset(V, 0, (size_t)n * (size_t)n * sizeof(double));
        for (p = 0; p < n; p++) {
            V[(size_t)p * n + p] = 1.0;
        }
    }
    for (sweep = 0; sweep < MAX_SWEEPS; sweep++) {
        int rotated = 0;
        /* squared column norms, exact at the start of every sweep and updated by each rotation
         * (a' = a - t g, b' = b + t g): one dot product per pair instead of three */
        for (p = 0; p < n; p++) {
            const double *ap = Acol + (size_t)p * r;
            nrm[p] = dot4(ap, ap, r);
        }
        for (p = 0; p < n - 1; p++) {
            for (q = p + 1; q < n; q++) {
                double *ap = Acol + (size_t)p * r, *aq = Acol + (size_t)q * r;
                double al = nrm[p], be = nrm[q], ga = dot4(ap, aq, r), zeta, t, c, s;
                if (!(fabs(ga) > DBL_EPSILON * sqrt(al * be)) || ga == 0.0) {
                    continue;
                }
                rotated = 1;
                zeta = (be - al) / (2.0 * ga);
                if (fabs(zeta) > 1e150) {
                    t = 0.5 / zeta;
                } else {
                    t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                }
                c = 1.0 / sqrt(1.0 + t * t);
                s = c * t;
                for (i = 0; i < r; i++) {
                    double u = ap[i], w = aq[i];
                    ap[i] = c * u - s * w;
                    aq[i] = s * u + c * w;
                }
                nrm[p] = al - t * ga;
                nrm[q] = be + t * ga;
                if (V != NULL) {
                    double *vp = V + (size_t)p * n, *vq = V + (size_t)q * n;
                    for (i = 0; i < n; i++) {
                        double u = vp[i], w = vq[i];
                        vp[i] = c * u - s * w;
                        vq[i] = s * u + c * w;
                    }
                }
            }
        }
        if (!rotated) {
            break;
        }
    }
}

/* Largest and smallest column norm of the r x n column-major matrix Acol. */
static void norm_range(const double *Acol, int32_t r, int32_t n, double *smax, double *smin)
{
    int32_t p, i;
    *smax = 0.0;
    *smin = INFINITY;
    for (p = 0; p < n; p++) {
        const double *ap = Acol + (size_t)p * r;
        double s2 = 0.0;
        for (i = 0; i < r; i++) {
            s2 += ap[i] * ap[i];
        }
        s2 = sqrt(s2);
        *smax = s2 > *smax ? s2 : *smax;
        *smin = s2 < *smin ? s2 : *smin;
    }
}

static double condition_of(double smax, double smin)
{
    return smin > 0.0 ? (smax / smin) * (smax / smin) : INFINITY;
}

/* The minimum-norm least-squares solution by the full one-sided Jacobi SVD of Acol (r x n), as
 * numpy's lstsq with rcond=None: singular values at or below eps max(r, n) s_max are dropped.
 * x = sum_j V_j (a_j . b) / s_j^2. Returns the condition number (s_max / s_min)^2. */
static double svd_solve(double *Acol, const double *b, int32_t r, int32_t n, double *V, double *x,
                        double *nrm)
{
    int32_t p, i;
    double smax, smin, cut;
    jacobi_columns(Acol, r, n, V, nrm);
    norm_range(Acol, r, n, &smax, &smin);
    cut = DBL_EPSILON * (double)(r > n ? r : n) * smax;
    memset(x, 0, (size_t)n * sizeof(double));
    for (p = 0; p < n; p++) {
        const double *ap = Acol + (size_t)p * r;
        const double *vp = V + (size_t)p * n;
        double s2 = 0.0, ab = 0.0, f;
        for (i = 0; i < r; i++) {
            s2 += ap[i] * ap[i];
            ab += ap[i] * b[i];
        }
        if (!(sqrt(s2) > cut)) {
            continue;
        }
        f = ab / s2;
        for (i = 0; i < n; i++) {
            x[i] += vp[i] * f;
        }
    }
    return condition_of(smax, smin);
}

/* Householder QR of Acol (r x n, r >= n, column-major) in place, applied to b as well: R in the
 * upper triangle of the first n rows, Q^T b in b. */
static void householder(double *Acol, double *b, int32_t r, int32_t n)
{
    int32_t j, c, i;
    for (j = 0; j < n; j++) {
        double *aj = Acol + (size_t)j * r;
        double nrm = 0.0, alpha, v0, vv;
        for (i = j; i < r; i++) {
            nrm += aj[i] * aj[i];
        }
        nrm = sqrt(nrm);
        if (nrm == 0.0) {
            continue;
        }
        alpha = aj[j] > 0.0 ? -nrm : nrm; /* v = a - alpha e_j without cancellation */
        v0 = aj[j] - alpha;
        aj[j] = v0; /* the reflector v in aj[j..r-1] for now */
        vv = v0 * v0;
        for (i = j + 1; i < r; i++) {
            vv += aj[i] * aj[i];
        }
        for (c = j + 1; c < n; c++) {
            double *ac = Acol + (size_t)c * r, s = 0.0, f;
            for (i = j; i < r; i++) {
                s += aj[i] * ac[i];
            }
            f = 2.0 * s / vv;
            for (i = j; i < r; i++) {
                ac[i] -= f * aj[i];
            }
        }
        {
            double s = 0.0, f;
            for (i = j; i < r; i++) {
                s += aj[i] * b[i];
            }
            f = 2.0 * s / vv;
            for (i = j; i < r; i++) {
                b[i] -= f * aj[i];
            }
        }
        aj[j] = alpha;
        for (i = j + 1; i < r; i++) {
            aj[i] = 0.0;
        }
    }
}

/* The stacked problem A = [sqrt(w_e) J_e; sqrt(w_z) R_S; sqrt(lam) I] (r x n, column-major in
 * Acol) and its right-hand side b = [sqrt(w_e) y_r; sqrt(w_z) z_r,S; 0]. */
static void assemble(const vf_cc_problem *pb, const double *je, const double *yr,
                     const double *rows, const double *zr, const int32_t *act, int32_t na,
                     double *Acol, double *b)
{
    const int32_t n = pb->n, m = pb->m, r = pb->m + na + pb->n;
    const double se = sqrt(pb->w_e), sz = sqrt(pb->w_z), sl = sqrt(pb->lam);
    int32_t i, j;
    for (j = 0; j < n; j++) {
        double *col = Acol + (size_t)j * r;
        for (i = 0; i < m; i++) {
            col[i] = se * je[(size_t)i * n + j];
        }
        for (i = 0; i < na; i++) {
            col[m + i] = sz * rows[(size_t)act[i] * n + j];
        }
        for (i = 0; i < n; i++) {
            col[m + na + i] = i == j ? sl : 0.0;
        }
    }
    for (i = 0; i < m; i++) {
        b[i] = se * yr[i];
    }
    for (i = 0; i < na; i++) {
        b[m + i] = sz * zr[act[i]];
    }
    for (i = 0; i < n; i++) {
        b[m + na + i] = 0.0;
    }
}

/* The final solve over the active rows (configuration_control._solve_stacked): the damped
 * least-squares problem by Householder QR (R x = Q^T b); its condition number from the singular
 * values of B = [sqrt(w_e) J_e; sqrt(w_z) R_S] when B has fewer rows than columns (the common case:
 * a few tasks on a redundant arm; Jacobi on p columns), else of R by one-sided Jacobi on R^T. When
 * the problem is so ill-conditioned that lstsq would drop a singular value (s_min <= eps max(r, n)
 * s_max; only with a damping negligible against the rows), the minimum-norm solution of the full
 * SVD instead. Returns the condition number (s_max / s_min)^2 of the normal matrix. */
static double final_solve(const vf_cc_problem *pb, const double *je, const double *yr,
                          const double *rows, const double *zr, const int32_t *act, int32_t na,
                          double *Acol, double *b, double *V, double *x, double *nrm)
{
    const int32_t n = pb->n, r = pb->m + na + pb->n;
    int32_t i, j;
    double smax, smin;
    const int32_t p = pb->m + na; /* rows of B = [sqrt(w_e) J_e; sqrt(w_z) R_S] */
    assemble(pb, je, yr, rows, zr, act, na, Acol, b);
    if (p < n) {
        /* A^T A = B^T B + lam I: its eigenvalues are s_i(B)^2 + lam and, n - p times, lam. The
         * singular values of B from Jacobi on the p columns of B^T (n x p, in V), before the QR
         * overwrites A. */
        for (i = 0; i < p; i++) {
            for (j = 0; j < n; j++) {
                V[(size_t)i * n + j] = Acol[(size_t)j * r + i];
            }
        }
        jacobi_columns(V, n, p, NULL, nrm);
        norm_range(V, n, p, &smax, &smin);
        smax = sqrt(smax * smax + pb->lam);
        smin = sqrt(pb->lam);
    }
    householder(Acol, b, r, n);
    for (i = n - 1; i >= 0; i--) { /* back substitution R x = (Q^T b)[0:n] */
        double s = b[i];
        for (j = i + 1; j < n; j++) {
            s -= Acol[(size_t)j * r + i] * x[j];
        }
        x[i] = s / Acol[(size_t)i * r + i];
    }
    if (p >= n) { /* the singular values of A are those of R: Jacobi on W = R^T */
        for (i = 0; i < n; i++) { /* column i of W is row i of R */
            for (j = 0; j < n; j++) {
                V[(size_t)i * n + j] = j >= i ? Acol[(size_t)j * r + i] : 0.0;
            }
        }
        jacobi_columns(V, n, n, NULL, nrm);
        norm_range(V, n, n, &smax, &smin);
    }
    if (smin > DBL_EPSILON * (double)(r > n ? r : n) * smax && vf_finite_all(x, (size_t)n)) {
        return condition_of(smax, smin);
    }
    assemble(pb, je, yr, rows, zr, act, na, Acol, b);
    return svd_solve(Acol, b, r, n, V, x, nrm);
}

/* |J_e x - y_r| */
static double rate_error(const double *je, const double *x, const double *yr, int32_t m, int32_t n)
{
    double s = 0.0;
    int32_t i;
    for (i = 0; i < m; i++) {
        double e = vf_dot(je + (size_t)i * n, x, n) - yr[i];
        s += e * e;
    }
    return sqrt(s);
}

int vf_cc_solve(const vf_cc_problem *pb, const double *P, const double *axes, const double *yr,
                vf_cc_out *out, double *dwork, int32_t *iwork)
{
    int32_t n, m, k, i, j, p, nn, na = 0, round;
    double *je, *zxp, *M0, *K, *G, *H, *Acol, *b, *V, *x0, *nrm, *zr, *rx0, *dd, *yv, *hg, *wv;
    double *thr, *clr;
    int32_t *near, *in_set, *act;
    int code;
    if (out == NULL || dwork == NULL || iwork == NULL || P == NULL || axes == NULL || yr == NULL) {
        return VF_CC_ERR_NULL;
    }
    code = vf_cc_check(pb);
    if (code != VF_CC_OK) {
        return code;
    }
    if (out->q_dot == NULL || out->q_free == NULL
        || (pb->k > 0
            && (out->points == NULL || out->fractions == NULL || out->distances == NULL
                || out->normals == NULL || out->rows == NULL || out->d_dot == NULL
                || out->d_dot_free == NULL || out->links == NULL || out->active == NULL))) {
        return VF_CC_ERR_NULL;
    }
    n = pb->n;
    m = pb->m;
    k = pb->k;
    if (!vf_finite_all(P, 3 * (size_t)(n + 1)) || !vf_finite_all(axes, 3 * (size_t)n)
        || !vf_finite_all(yr, (size_t)m)) {
        stop(pb, out);
        return VF_CC_ERR_NONFINITE;
    }
    /* scratch layout (vf_cc_doubles) */
    je = dwork;
    zxp = je + (size_t)m * n;
    M0 = zxp + 3 * (size_t)n;
    K = M0 + (size_t)n * n;
    G = K + (size_t)n * k;
    H = G + (size_t)k * k;
    Acol = H + (size_t)k * k;
    b = Acol + (size_t)(m + k + n) * n;
    V = b + (size_t)(m + k + n);
    x0 = V + (size_t)n * n;
    nrm = x0 + n;
    zr = nrm + n;
    rx0 = zr + k;
    dd = rx0 + k;
    yv = dd + k;
    hg = yv + k;
    wv = hg + k;
    thr = wv + k;
    clr = thr + k;
    near = iwork;
    in_set = near + k;
    act = in_set + k;

    /* z_j x P_j and the end-effector Jacobian: columns z_j x P_n - z_j x P_j (first m rows) */
    for (j = 0; j < n; j++) {
        const double *z = axes + 3 * (size_t)j, *pj = P + 3 * (size_t)j, *pe = P + 3 * (size_t)n;
        double *w = zxp + 3 * (size_t)j;
        double c0 = z[1] * pe[2] - z[2] * pe[1];
        double c1 = z[2] * pe[0] - z[0] * pe[2];
        double c2 = z[0] * pe[1] - z[1] * pe[0];
        w[0] = z[1] * pj[2] - z[2] * pj[1];
        w[1] = z[2] * pj[0] - z[0] * pj[2];
        w[2] = z[0] * pj[1] - z[1] * pj[0];
        je[j] = c0 - w[0];
        je[(size_t)n + j] = c1 - w[1];
        if (m == 3) {
            je[2 * (size_t)n + j] = c2 - w[2];
        }
    }
    critical(pb, P, axes, zxp, out);

    /* desired approach rates and the candidates (only d <= rho can join when h = 0) */
    nn = 0;
    for (i = 0; i < k; i++) {
        double pen = pb->rho[i] - out->distances[i];
        zr[i] = pb->kz * (pen > 0.0 ? pen : 0.0);
        if (pb->h > 0.0 || out->distances[i] <= pb->rho[i]) {
            near[nn++] = i;
        }
    }

    /* M0 = w_e Je^T Je + lam I (factored), x0 = M0^-1 w_e Je^T y_r */
    for (i = 0; i < n; i++) {
        for (j = 0; j <= i; j++) {
            double s = 0.0;
            for (p = 0; p < m; p++) {
                s += je[(size_t)p * n + i] * je[(size_t)p * n + j];
            }
            M0[(size_t)i * n + j] = pb->w_e * s + (i == j ? pb->lam : 0.0);
        }
        x0[i] = 0.0;
        for (p = 0; p < m; p++) {
            x0[i] += je[(size_t)p * n + i] * yr[p];
        }
        x0[i] *= pb->w_e;
    }
    if (!cholesky(M0, n)) {
        stop(pb, out);
        return VF_CC_ERR_OVERFLOW;
    }
    chol_solve(M0, n, x0);
    /* K = M0^-1 R_near^T (column c stored as K[c * n ..]), G = R_near K, rx0 = R_near x0 */
    for (i = 0; i < nn; i++) {
        double *kc = K + (size_t)i * n;
        memcpy(kc, out->rows + (size_t)near[i] * n, (size_t)n * sizeof(double));
        chol_solve(M0, n, kc);
    }
    for (i = 0; i < nn; i++) {
        const double *ri = out->rows + (size_t)near[i] * n;
        for (j = 0; j < nn; j++) {
            G[(size_t)i * nn + j] = vf_dot(ri, K + (size_t)j * n, n);
        }
        rx0[i] = vf_dot(ri, x0, n);
        if (!isfinite(rx0[i])) {
            stop(pb, out);
            return VF_CC_ERR_OVERFLOW;
        }
    }
    if (!vf_finite_all(x0, (size_t)n) || !vf_finite_all(G, (size_t)nn * nn)) {
        stop(pb, out);
        return VF_CC_ERR_OVERFLOW;
    }

    /* Steps D-F in obstacle space (configuration_control._active_set), on positions 0..nn-1 */
    for (i = 0; i < nn; i++) {
        int32_t o = near[i];
        thr[i] = zr[o] - RATE_EPS;
        clr[i] = out->distances[o] - pb->rho[o];
        in_set[i] = 0;
        dd[i] = rx0[i];
    }
    for (round = 0; round < pb->rounds; round++) {
        int32_t best = -1, a, kk;
        double key = INFINITY, pv, inv_s;
        for (i = 0; i < nn; i++) {
            int32_t o = near[i];
            double di = dd[i];
            if (!isfinite(di)) {
                stop(pb, out);
                return VF_CC_ERR_OVERFLOW;
            }
            if (!in_set[i] && di < thr[i]
                && out->distances[o] <= pb->rho[o] + pb->h * (di < 0.0 ? -di : 0.0)
                && clr[i] < key) {
                best = i;
                key = clr[i];
            }
        }
        if (best < 0) {
            break;
        }
        /* border H = (G_SS + I / w_z)^-1 with the new row (H is na x na, stride nn) */
        pv = G[(size_t)best * nn + best] + 1.0 / pb->w_z;
        if (na > 0) {
            double sg = 0.0;
            for (i = 0; i < na; i++) {
                double s = 0.0;
                for (j = 0; j < na; j++) {
                    s += H[(size_t)i * nn + j] * G[(size_t)best * nn + act[j]];
                }
                hg[i] = s;
                sg += G[(size_t)best * nn + act[i]] * s;
            }
            inv_s = 1.0 / (pv - sg);
            for (i = 0; i < na; i++) {
                wv[i] = -hg[i] * inv_s;
            }
            for (i = 0; i < na; i++) {
                for (j = 0; j < na; j++) {
                    H[(size_t)i * nn + j] -= hg[i] * wv[j];
                }
                H[(size_t)i * nn + na] = wv[i];
                H[(size_t)na * nn + i] = wv[i];
            }
            H[(size_t)na * nn + na] = inv_s;
        } else {
            H[0] = 1.0 / pv;
        }
        act[na++] = best;
        in_set[best] = 1;
        for (i = 0; i < na; i++) {
            double s = 0.0;
            for (j = 0; j < na; j++) {
                s += H[(size_t)i * nn + j] * (zr[near[act[j]]] - rx0[act[j]]);
            }
            yv[i] = s;
        }
        kk = 0;
        while (pb->recheck && kk < na - 1) {
            double hkk;
            a = act[kk];
            hkk = H[(size_t)kk * nn + kk];
            if (zr[near[a]] - yv[kk] / hkk >= thr[a]) { /* its point would not approach */
                double f = yv[kk] / hkk;
                int32_t ii, jj, ri = 0;
                for (ii = 0; ii < na; ii++) {
                    hg[ii] = H[(size_t)ii * nn + kk];
                }
                for (ii = 0; ii < na; ii++) {
                    int32_t rj = 0;
                    if (ii == kk) {
                        continue;
                    }
                    yv[ri] = yv[ii] - hg[ii] * f;
                    for (jj = 0; jj < na; jj++) {
                        if (jj == kk) {
                            continue;
                        }
                        H[(size_t)ri * nn + rj] = H[(size_t)ii * nn + jj] - hg[ii] * hg[jj] / hkk;
                        rj++;
                    }
                    ri++;
                }
                for (ii = kk; ii < na - 1; ii++) {
                    act[ii] = act[ii + 1];
                }
                na -= 1;
                in_set[a] = 0;
            } else {
                kk += 1;
            }
        }
        for (i = 0; i < nn; i++) {
            double s = rx0[i];
            for (j = 0; j < na; j++) {
                s += G[(size_t)i * nn + act[j]] * yv[j];
            }
            dd[i] = s;
        }
    }
    for (i = 0; i < na; i++) {
        out->active[i] = near[act[i]];
    }
    for (i = na; i < k; i++) {
        out->active[i] = -1;
    }
    out->n_active = na;

    /* the final stacked solve over the active rows */
    out->condition = final_solve(pb, je, yr, out->rows, zr, out->active, na, Acol, b, V,
                                 out->q_dot, nrm);
    memcpy(out->q_free, na > 0 ? x0 : out->q_dot, (size_t)n * sizeof(double));
    if (!vf_finite_all(out->q_dot, (size_t)n)) {
        stop(pb, out);
        return VF_CC_ERR_OVERFLOW;
    }
    /* the speed cap (one factor keeps the direction) and the diagnostics (_result) */
    if (pb->max_speed > 0.0) {
        double peak = 0.0;
        for (i = 0; i < n; i++) {
            double a = fabs(out->q_dot[i]);
            peak = a > peak ? a : peak;
        }
        if (peak > pb->max_speed) {
            /* (q / peak) max_speed, not q (max_speed / peak): the factor max_speed / peak can be
             * subnormal (found by core/fuzz/fuzz_cc.c: max_speed 2.9e-188 over a peak of 1e127
             * left |q_dot| 3.9e-10 above the cap); |q / peak| <= 1 meets the cap exactly */
            for (i = 0; i < n; i++) {
                out->q_dot[i] = out->q_dot[i] / peak * pb->max_speed;
            }
        }
    }
    for (i = 0; i < k; i++) {
        out->d_dot[i] = vf_dot(out->rows + (size_t)i * n, out->q_dot, n);
        out->d_dot_free[i] = vf_dot(out->rows + (size_t)i * n, out->q_free, n);
    }
    out->ee_rate_error = rate_error(je, out->q_dot, yr, m, n);
    out->ee_rate_error_free = rate_error(je, out->q_free, yr, m, n);
    if (!vf_finite_all(out->d_dot, (size_t)k) || !vf_finite_all(out->d_dot_free, (size_t)k)
        || !isfinite(out->ee_rate_error) || !isfinite(out->ee_rate_error_free)
        || !isfinite(out->condition) || !vf_finite_all(out->distances, (size_t)k)
        || !vf_finite_all(out->points, 3 * (size_t)k) || !vf_finite_all(out->normals, 3 * (size_t)k)
        || !vf_finite_all(out->rows, (size_t)k * (size_t)n)) {
        stop(pb, out);
        return VF_CC_ERR_OVERFLOW;
    }
    return VF_CC_OK;
}
