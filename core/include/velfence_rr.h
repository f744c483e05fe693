/*
 * velfence_rr.h -- one resolved-rate step of a 6-joint standard-DH arm with the singularity-robust
 * (SR) inverse (Khokar 2009 eqs. 32-37, after Nakamura), in plain C99.
 *
 *   vf_rr_jacobian  the base-frame geometric Jacobian [v; w] = J(q) q' of the tool point, from one
 *                   pass over the DH rows in doubles (the frames' columns x, y, z and origin o;
 *                   column j is [z_j x (p - o_j); z_j]).
 *   vf_rr_sr_step   J, w = |det J| (LU with partial pivoting), the damping
 *                       k = k0 (1 - w/w0)^2 if w < w0, else 0                       (eq. 37)
 *                   and q' = J^T (J J^T + k I)^-1 x' (eq. 36; Cholesky factorisation of the
 *                   symmetric positive definite J J^T + k I), then the optional speed cap (q'
 *                   scaled by one factor so that max |q'_i| <= max_speed).
 *                   velfence.apps.teleop.resolved_rate.ResolvedRate(Puma560(), inverse="sr")'s step.
 *
 * Agreement with the Python reference (ResolvedRate(..., backend="python")): the kinematics and J
 * are the same floating-point operations in the same order as DHChain._kinematics_lists and
 * Puma560._jacobian_validated (built with -ffp-contract=off: bit for bit); det J, J J^T and the
 * solve are not LAPACK's, so det, w, k agree to 1000 kappa(J) eps relative and q' to
 * max(1e-10, 1000 kappa^1.5 eps) relative, kappa = cond(J J^T + k I) (tests/teleop).
 *
 * Real-time use: reentrant, allocation-free (a few hundred bytes of stack), no global state; the
 * work per call is fixed (6 cos/sin pairs and O(6^3) flops).
 *
 * Arrays: row-major doubles. Units: metres, radians, seconds.
 *
 * Return codes (velfence_status.h): VF_OK (0) or a negative VF_ERR_* code. On VF_OK every double
 * of the answer is finite. On an error q_dot = 0, scale = 1 and w, det, k, singular are those
 * computed before the error (NaN when not reached); the caller applies its own policy (velfence's
 * Python layer re-runs its reference route, which raises or stops as configured).
 */
#ifndef VELFENCE_RR_H
#define VELFENCE_RR_H

#include <stdint.h>

#include "velfence_status.h" /* the return codes */

#ifdef __cplusplus
extern "C" {
#endif

/* Return codes (velfence_status.h): VF_OK; VF_ERR_NULL (a pointer is NULL); VF_ERR_ARGUMENT (k0
 * or w0 not finite > 0, singular_tol or max_speed < 0, ...); VF_ERR_NONFINITE (q or x' holds NaN
 * or +-inf); VF_ERR_SINGULAR (k = 0 and w <= singular_tol, only when singular_tol >= w0; or
 * J J^T + k I has a Cholesky pivot <= 0, not numerically positive definite); VF_ERR_OVERFLOW
 * (finite input so large that det J, J J^T + k I or a joint rate overflowed).
 * The VF_RR_* names are deprecated aliases, removed in 0.3. Their values changed with the shared
 * enum: SINGULAR -4 -> -5, OVERFLOW -6 -> -4, and FACTOR (was -5) is now VF_ERR_SINGULAR (a
 * non-finite pivot, J J^T + k I overflowed, is VF_ERR_OVERFLOW). */
#define VF_RR_OK VF_OK                       /* deprecated alias, removed in 0.3 */
#define VF_RR_ERR_NULL VF_ERR_NULL           /* deprecated alias, removed in 0.3 */
#define VF_RR_ERR_ARGUMENT VF_ERR_ARGUMENT   /* deprecated alias, removed in 0.3 */
#define VF_RR_ERR_NONFINITE VF_ERR_NONFINITE /* deprecated alias, removed in 0.3 */
#define VF_RR_ERR_SINGULAR VF_ERR_SINGULAR   /* deprecated alias, removed in 0.3 (was -4) */
#define VF_RR_ERR_FACTOR VF_ERR_SINGULAR     /* deprecated alias, removed in 0.3 (was -5) */
#define VF_RR_ERR_OVERFLOW VF_ERR_OVERFLOW   /* deprecated alias, removed in 0.3 (was -6) */

/* The arm: 6 standard-DH rows and the tool point. Read-only, shareable. */
typedef struct vf_rr_arm {
    double dh[6][5]; /* per joint: a [m], cos(alpha), sin(alpha), d [m], theta offset [rad] */
    double tool[3];  /* tool point in the last DH frame [m] */
} vf_rr_arm;

/* The SR law's parameters (velfence: k0 = 0.025, w0 = 0.014, singular_tol = 1e-10). */
typedef struct vf_rr_params {
    double k0;           /* damping at w = 0, > 0 (units of J J^T) */
    double w0;           /* manipulability at the border of the damped neighbourhood, > 0 */
    double singular_tol; /* w at or below which an undamped step is refused, >= 0 */
    double max_speed;    /* joint-rate cap [rad/s], or 0: none */
} vf_rr_params;

/* One step's answer. */
typedef struct vf_rr_out {
    double q_dot[6]; /* joint rates [rad/s], after the cap */
    double w;        /* manipulability |det J| */
    double det;      /* signed det J */
    double k;        /* damping used */
    double scale;    /* cap factor max_speed / peak in [0, 1] (1 when not limiting; 0 only when
                        that quotient underflows) */
    int32_t singular; /* 1 when w <= singular_tol */
} vf_rr_out;

/* J (6 x 6, row-major) of the tool point at q (6,). VF_OK, or VF_ERR_NULL / VF_ERR_NONFINITE
 * (J then all zero). */
int vf_rr_jacobian(const vf_rr_arm *arm, const double *q, double *J);

/* One SR step for the commanded twist xdot = [v; w] (6,) [m/s; rad/s] at q (6,) [rad]. */
int vf_rr_sr_step(const vf_rr_arm *arm, const vf_rr_params *prm, const double *q,
                  const double *xdot, vf_rr_out *out);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_RR_H */
