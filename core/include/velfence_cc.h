/*
 * velfence_cc.h -- configuration control (obstacle avoidance of a redundant serial arm by
 * US 5,150,026, steps A-F) for one control cycle, in plain C99.
 *
 *   vf_cc_solve   from one pose's joint points and axes: every obstacle's critical point on the
 *                 arm (the closest point of the nearest link capsule), its distance, normal and
 *                 constraint row u^T J_c (steps A-C); the active set of rows that stop an approach
 *                 inside the sphere of influence, searched in obstacle space (steps D-F); the
 *                 joint rate of the weighted damped least-squares solve over those rows; and the
 *                 cycle's diagnostics. velfence.redundancy.ConfigurationController's law.
 *
 * The law. With J_e (m x n) the end-effector Jacobian, R (k x n) the obstacles' rows, z_r the
 * desired approach rates K_z max(0, rho - d) and S the active set, the joint rate minimises
 *     w_e |J_e q' - y_r|^2 + w_z |R_S q' - z_r,S|^2 + lambda |q'|^2.
 * A row o joins S when, under the current solve, its rate r_o q' < z_r,o - 1e-12 and its critical
 * point is within rho_o + h max(0, -r_o q') of the obstacle (the nearest such point first); with
 * `recheck` an earlier row leaves S again when, solved without it, its point would not approach.
 * Obstacle space: with M0 = w_e J_e^T J_e + lambda I and x0 = M0^-1 w_e J_e^T y_r, the solve over S
 * is x0 + M0^-1 R_S^T y, y = (R_S M0^-1 R_S^T + I / w_z)^-1 (z_r,S - R_S x0), so adding a row
 * borders a small inverse and a release check is a rank-one downdate -- no solve per check.
 * The final joint rate is the stacked least-squares problem above solved by a Householder QR
 * factorisation (backward stable, as LAPACK's lstsq), its condition number kappa =
 * (s_max / s_min)^2 of the normal matrix from one-sided Jacobi on the task rows
 * B = [sqrt(w_e) J_e; sqrt(w_z) R_S] when they are fewer than the joints (the normal matrix is
 * B^T B + lambda I), else on R^T;
 * when kappa is so large that lstsq would drop a singular value, the minimum-norm solution of a
 * full one-sided Jacobi SVD instead.
 *
 * Agreement with the Python reference (velfence.redundancy.configuration_control): the same
 * decisions (active set, links; an exact tie between two links may be named either way) and every
 * float to within 1000 kappa eps relative (1e-10 at least): the factorisations here are not
 * LAPACK's, so the last bits differ.
 *
 * Real-time use: reentrant, allocation-free, no global state, nothing longjmps; the caller owns
 * every buffer, sized by vf_cc_doubles / vf_cc_ints. The work per call is bounded: O(k n_links)
 * for steps A-C, O(n^3 + n^2 k + n k^2) for the obstacle-space set-up, at most `rounds` add rounds
 * (each O(|S|^2 + k |S|)), O((m + k + n) n^2) for the QR and at most 64 Jacobi sweeps of
 * O(min(p, n)^2 n), p = m + |S|, for the condition number (twice that, on (m + k + n) x n, in the rare minimum-norm case).
 *
 * Shapes: row-major contiguous doubles; P is (n + 1) x 3 (the joint points P_0 .. P_n-1, then the
 * end-effector point P_n; link l runs P_l -> P_l+1, so there are n links), axes n x 3 (joint j's
 * unit axis z_j; joint j moves every point beyond P_j), y_r (m,) with m = 2 (a planar task, the x
 * and y components) or 3. Units: metres, radians, seconds.
 *
 * Return codes (velfence_status.h): VF_OK (0) or a negative VF_ERR_* code. On VF_OK every double
 * of the answer is finite. On VF_ERR_NONFINITE and VF_ERR_OVERFLOW every output is the stop
 * result: q_dot = q_free = 0, n_active = 0, every other double 0, links and active -1. On
 * VF_ERR_NULL and VF_ERR_ARGUMENT nothing is written (the sizes the outputs would be
 * written by are the refused ones); check the problem once with vf_cc_check outside the loop.
 */
#ifndef VELFENCE_CC_H
#define VELFENCE_CC_H

#include <stddef.h>
#include <stdint.h>

#include "velfence_status.h" /* the return codes */

#ifdef __cplusplus
extern "C" {
#endif

/* Return codes (velfence_status.h): VF_OK; VF_ERR_NULL (a required pointer is NULL);
 * VF_ERR_ARGUMENT (bad sizes or data: n < 1, m not 2 or 3, weights <= 0, ...); VF_ERR_NONFINITE
 * (a per-call input, P, axes or y_r, is NaN or +-inf); VF_ERR_OVERFLOW (finite input so large
 * that a rate overflowed). The VF_CC_* names are deprecated aliases, removed in 0.3. */
#define VF_CC_OK VF_OK                       /* deprecated alias, removed in 0.3 */
#define VF_CC_ERR_NULL VF_ERR_NULL           /* deprecated alias, removed in 0.3 */
#define VF_CC_ERR_ARGUMENT VF_ERR_ARGUMENT   /* deprecated alias, removed in 0.3 */
#define VF_CC_ERR_NONFINITE VF_ERR_NONFINITE /* deprecated alias, removed in 0.3 */
#define VF_CC_ERR_OVERFLOW VF_ERR_OVERFLOW   /* deprecated alias, removed in 0.3 */

/* The arm's links and the obstacles, and the law's parameters: read-only, shareable. */
typedef struct vf_cc_problem {
    int32_t n;           /* joints (and links), >= 1 */
    int32_t m;           /* task dimension: 2 or 3 */
    int32_t k;           /* obstacles, >= 0 */
    const double *C;     /* obstacle centres, k x 3 [m] */
    const double *rho;   /* radii of the spheres of influence (k,) [m], > 0 */
    const double *lrad;  /* capsule radius of every link (n,) [m], >= 0 */
    double w_e;          /* end-effector weight, > 0 */
    double w_z;          /* constraint weight, > 0 */
    double lam;          /* damping lambda [m^2/rad^2], > 0 */
    double kz;           /* spring gain K_z [1/s], >= 0 */
    double h;            /* activation look-ahead [s], >= 0 */
    double max_speed;    /* joint-rate cap [rad/s] (q_dot scaled by one factor), or 0: none */
    int32_t recheck;     /* 1: release rows whose point would not approach without them */
    int32_t rounds;      /* bound on the add rounds (4 k + 1 in velfence) */
} vf_cc_problem;

/* One cycle's answer. The caller points every array at its own storage. */
typedef struct vf_cc_out {
    double *q_dot;      /* (n,) joint rate [rad/s], after the speed cap */
    double *q_free;     /* (n,) the unconstrained solve (= q_dot when no row is active) */
    double *points;     /* k x 3 critical points [m] */
    double *fractions;  /* (k,) the critical point's place on its link, 0 .. 1 */
    double *distances;  /* (k,) distance from the obstacle centre to the link capsule [m] */
    double *normals;    /* k x 3 unit normals, from the centre to the critical point */
    double *rows;       /* k x n constraint rows u^T J_c [m/rad] */
    double *d_dot;      /* (k,) approach rates under q_dot [m/s] */
    double *d_dot_free; /* (k,) approach rates under q_free [m/s] */
    int32_t *links;     /* (k,) the critical link of every obstacle */
    int32_t *active;    /* (k,) the active rows in order of activation, n_active of them */
    int32_t n_active;
    double condition;          /* (s_max / s_min)^2 of the final stacked solve */
    double ee_rate_error;      /* |J_e q_dot - y_r| [m/s] */
    double ee_rate_error_free; /* |J_e q_free - y_r| [m/s] */
} vf_cc_out;

/* Doubles and int32s of scratch vf_cc_solve needs (one scratch per thread). */
size_t vf_cc_doubles(int32_t n, int32_t m, int32_t k);
size_t vf_cc_ints(int32_t k);

/* VF_CC_OK when the problem's sizes and data are valid. */
int vf_cc_check(const vf_cc_problem *pb);

/* One cycle (checked: the problem, finite P, axes and y_r; overflow). */
int vf_cc_solve(const vf_cc_problem *pb, const double *P, const double *axes, const double *yr,
                vf_cc_out *out, double *dwork, int32_t *iwork);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_CC_H */
