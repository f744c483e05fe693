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
 *                   velfence.teleop.resolved_rate.ResolvedRate(Puma560(), inverse="sr")'s step.
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
 * Return codes: VF_RR_OK (0) or a negative VF_RR_ERR_* code. On VF_RR_OK every double of the
 * answer is finite. On an error q_dot = 0, scale = 1 and w, det, k, singular are those computed
 * before the error (NaN when not reached); the caller applies its own policy (velfence's Python
 * layer re-runs its reference route, which raises or stops as configured).
 */
#ifndef VELFENCE_RR_H
#define VELFENCE_RR_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VF_RR_OK 0
#define VF_RR_ERR_NULL (-1)      /* a pointer is NULL */
#define VF_RR_ERR_ARGUMENT (-2)  /* k0 or w0 not finite > 0, singular_tol or max_speed < 0, ... */
#define VF_RR_ERR_NONFINITE (-3) /* q or x' holds NaN or +-inf */
#define VF_RR_ERR_SINGULAR (-4)  /* k = 0 and w <= singular_tol (only when singular_tol >= w0) */
#define VF_RR_ERR_FACTOR (-5)    /* J J^T + k I not numerically positive definite */
#define VF_RR_ERR_OVERFLOW (-6)  /* finite input so large that det J or a joint rate overflowed */

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

/* J (6 x 6, row-major) of the tool point at q (6,). VF_RR_OK, or VF_RR_ERR_NULL /
 * VF_RR_ERR_NONFINITE (J then all zero). */
int vf_rr_jacobian(const vf_rr_arm *arm, const double *q, double *J);

/* One SR step for the commanded twist xdot = [v; w] (6,) [m/s; rad/s] at q (6,) [rad]. */
int vf_rr_sr_step(const vf_rr_arm *arm, const vf_rr_params *prm, const double *q,
                  const double *xdot, vf_rr_out *out);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_RR_H */
