/*
 * velfence_rr.c -- resolved rate with the SR inverse for a 6-joint DH arm (see velfence_rr.h).
 * Build with -ffp-contract=off: the kinematics must stay the Python reference's operations.
 */
#include "velfence_rr.h"

#include "velfence_nd.h" /* vf_nd_chain_kinematics: the DH chain's one kinematics pass */

#include <math.h>
#include <stddef.h>

static int all_finite(const double *v, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        if (!isfinite(v[i])) {
            return 0;
        }
    }
    return 1;
}

static void jacobian(const vf_rr_arm *arm, const double *q, double *J)
{
    /* the chain's one kinematics pass (velfence_nd.h): joint points P_0 .. P_5, the tool point
     * P_6, axes z_0 .. z_5 */
    double P[7][3], z[6][3], flange[3];
    const double *p = P[6];
    int j;
    vf_nd_chain_kinematics(6, &arm->dh[0][0], arm->tool, q, &P[0][0], &z[0][0], flange);
    for (j = 0; j < 6; j++) {
        double dx = p[0] - P[j][0], dy = p[1] - P[j][1], dz = p[2] - P[j][2];
        double zx = z[j][0], zy = z[j][1], zz = z[j][2];
        J[0 * 6 + j] = zy * dz - zz * dy;
        J[1 * 6 + j] = zz * dx - zx * dz;
        J[2 * 6 + j] = zx * dy - zy * dx;
        J[3 * 6 + j] = zx;
        J[4 * 6 + j] = zy;
        J[5 * 6 + j] = zz;
    }
}

int vf_rr_jacobian(const vf_rr_arm *arm, const double *q, double *J)
{
    int i;
    if (arm == NULL || q == NULL || J == NULL) {
        return VF_ERR_NULL;
    }
    if (!all_finite(q, 6)) {
        for (i = 0; i < 36; i++) {
            J[i] = 0.0;
        }
        return VF_ERR_NONFINITE;
    }
    jacobian(arm, q, J);
    return VF_OK;
}

/* det of the 6 x 6 row-major M by LU with partial pivoting (M is overwritten). */
static double det6(double *M)
{
    double det = 1.0;
    int c, r, j;
    for (c = 0; c < 6; c++) {
        int piv = c;
        double best = fabs(M[c * 6 + c]);
        for (r = c + 1; r < 6; r++) {
            double v = fabs(M[r * 6 + c]);
            if (v > best) {
                best = v;
                piv = r;
            }
        }
        if (best == 0.0) {
            return 0.0;
        }
        if (piv != c) {
            for (j = 0; j < 6; j++) {
                double t = M[c * 6 + j];
                M[c * 6 + j] = M[piv * 6 + j];
                M[piv * 6 + j] = t;
            }
            det = -det;
        }
        det *= M[c * 6 + c];
        for (r = c + 1; r < 6; r++) {
            double f = M[r * 6 + c] / M[c * 6 + c];
            for (j = c + 1; j < 6; j++) {
                M[r * 6 + j] -= f * M[c * 6 + j];
            }
        }
    }
    return det;
}

static void stop(vf_rr_out *out)
{
    int i;
    for (i = 0; i < 6; i++) {
        out->q_dot[i] = 0.0;
    }
    out->scale = 1.0;
}

int vf_rr_sr_step(const vf_rr_arm *arm, const vf_rr_params *prm, const double *q,
                  const double *xdot, vf_rr_out *out)
{
    double J[36], M[36], A[36], y[6];
    double w, det, k;
    int i, j, l;
    if (out == NULL) {
        return VF_ERR_NULL;
    }
    out->w = out->det = out->k = NAN;
    out->singular = 0;
    stop(out);
    if (arm == NULL || prm == NULL || q == NULL || xdot == NULL) {
        return VF_ERR_NULL;
    }
    if (!(isfinite(prm->k0) && prm->k0 > 0.0 && isfinite(prm->w0) && prm->w0 > 0.0
          && prm->singular_tol >= 0.0 && prm->max_speed >= 0.0 && !isnan(prm->singular_tol)
          && !isnan(prm->max_speed))
        || !all_finite(arm->dh[0], 30) || !all_finite(arm->tool, 3)) {
        return VF_ERR_ARGUMENT;
    }
    if (!all_finite(q, 6) || !all_finite(xdot, 6)) {
        return VF_ERR_NONFINITE;
    }
    jacobian(arm, q, J);
    for (i = 0; i < 36; i++) {
        M[i] = J[i];
    }
    det = det6(M);
    w = fabs(det);
    out->det = det;
    out->w = w;
    if (!isfinite(det)) {
        /* a finite arm so large that det J overflowed (found by core/fuzz/fuzz_rr.c: VF_OK
         * with w = det = inf) */
        return VF_ERR_OVERFLOW;
    }
    out->singular = w <= prm->singular_tol;
    /* eq. 37, as ResolvedRate.explain writes it */
    k = w >= prm->w0 ? 0.0 : prm->k0 * pow(1.0 - w / prm->w0, 2.0);
    out->k = k;
    if (k == 0.0 && out->singular) {
        return VF_ERR_SINGULAR;
    }
    /* A = J J^T + k I (lower triangle), then its Cholesky factor L in place. */
    for (i = 0; i < 6; i++) {
        for (j = 0; j <= i; j++) {
            double s = 0.0;
            for (l = 0; l < 6; l++) {
                s += J[i * 6 + l] * J[j * 6 + l];
            }
            A[i * 6 + j] = s;
        }
        A[i * 6 + i] += k;
    }
    for (j = 0; j < 6; j++) {
        double s = A[j * 6 + j];
        for (l = 0; l < j; l++) {
            s -= A[j * 6 + l] * A[j * 6 + l];
        }
        if (!isfinite(s)) {
            return VF_ERR_OVERFLOW; /* J J^T + k I (or its factor) overflowed */
        }
        if (!(s > 0.0)) {
            return VF_ERR_SINGULAR; /* not numerically positive definite */
        }
        s = sqrt(s);
        A[j * 6 + j] = s;
        for (i = j + 1; i < 6; i++) {
            double t = A[i * 6 + j];
            for (l = 0; l < j; l++) {
                t -= A[i * 6 + l] * A[j * 6 + l];
            }
            A[i * 6 + j] = t / s;
        }
    }
    /* L L^T y = x' */
    for (i = 0; i < 6; i++) {
        double t = xdot[i];
        for (l = 0; l < i; l++) {
            t -= A[i * 6 + l] * y[l];
        }
        y[i] = t / A[i * 6 + i];
    }
    for (i = 5; i >= 0; i--) {
        double t = y[i];
        for (l = i + 1; l < 6; l++) {
            t -= A[l * 6 + i] * y[l];
        }
        y[i] = t / A[i * 6 + i];
    }
    /* q' = J^T y, the cap */
    {
        double qd[6], peak = 0.0, scale = 1.0;
        for (j = 0; j < 6; j++) {
            double s = 0.0;
            for (i = 0; i < 6; i++) {
                s += J[i * 6 + j] * y[i];
            }
            if (!isfinite(s)) {
                return VF_ERR_OVERFLOW;
            }
            qd[j] = s;
            if (fabs(s) > peak) {
                peak = fabs(s);
            }
        }
        if (prm->max_speed > 0.0 && peak > prm->max_speed) {
            /* (q / peak) max_speed: |q / peak| <= 1 meets the cap exactly; q (max_speed / peak)
             * rounded 5 to 5.000000000000001 (found by core/fuzz/fuzz_rr.c) */
            scale = prm->max_speed / peak;
            for (j = 0; j < 6; j++) {
                qd[j] = qd[j] / peak * prm->max_speed;
            }
        }
        for (j = 0; j < 6; j++) {
            out->q_dot[j] = qd[j];
        }
        out->scale = scale;
    }
    return VF_OK;
}
