/*
 * velfence_nd.h -- velfence's n-D minimum-change solve and n-D exact law in plain C99.
 *
 *   vf_nd_project   Euclidean projection of u onto {x : G x >= b} by a finite dual active-set
 *                   method (Goldfarb-Idnani, identity Hessian): velfence.geometry.projection's
 *                   project_kernel, the solve behind SafetyFilter and PolytopeShaper.
 *   vf_nd_shape     the exact law inside a convex polytope of any dimension (one half-space bound
 *                   per nearby facet, all held at once): velfence.shaping._nd_kernels's
 *                   polytope_kernel, PolytopeShaper's law.
 *
 * Both compute the same operations in the same order as the Python reference, so with IEEE double
 * arithmetic, no contraction of a*b+c into fused multiply-adds (-ffp-contract=off) and the same
 * libm (sqrt, pow(x, 2) -- both correctly rounded) their results are bit-identical to it.
 *
 * Real-time use: reentrant, allocation-free, no global state, nothing longjmps. The caller owns
 * every buffer; their sizes come from vf_nd_project_doubles / vf_nd_law_doubles / vf_nd_law_ints.
 * The work per call is bounded: the dual method takes at most 4 (m + n) + 16 inner iterations of
 * O(n^2 + m n) each (plus an O(q n^2) rebuild per change of the active set); the law solves at most
 * 2 (nf + 1) + 1 projections (in practice one). One scratch per thread; polytope and law data are
 * read-only and shareable.
 *
 * Shapes: N (nf x dim) and G (m x n) are row-major contiguous doubles; every vector is contiguous.
 * Units: the caller's (positions [m or rad], velocities per second, idt = 1/dt [1/s]).
 *
 * Return codes (int): VF_ND_OK (0) or a negative VF_ND_ERR_* code. Whatever the code, every output
 * is written and every double in it is finite: on an error the answer is the stop result (zero
 * velocity / x = 0, zone VF_ND_ZONE_INVALID, stage VF_ND_STAGE_STOP, facets -1, distances 0,
 * q = 0, m = 0).
 */
#ifndef VELFENCE_ND_H
#define VELFENCE_ND_H

#include <stddef.h>
#include <stdint.h>

#include "velfence_constants.h" /* zones, stage bits, profiles, levels, VF_VERSION */
#include "velfence_status.h"    /* vf_status: VF_OK, VF_ERR_*, VF_INFEASIBLE, VF_STALLED, ... */

#ifdef __cplusplus
extern "C" {
#endif

#define VF_ND_VERSION VF_VERSION /* deprecated alias, removed in 0.3 */

/* Return codes: deprecated aliases, removed in 0.3. */
#define VF_ND_OK VF_OK                        /* deprecated alias, removed in 0.3 */
#define VF_ND_ERR_NULL VF_ERR_NULL            /* deprecated alias, removed in 0.3 */
#define VF_ND_ERR_ARGUMENT VF_ERR_ARGUMENT    /* deprecated alias, removed in 0.3 */
#define VF_ND_ERR_NONFINITE VF_ERR_NONFINITE  /* deprecated alias, removed in 0.3 */
#define VF_ND_ERR_OVERFLOW VF_ERR_OVERFLOW    /* deprecated alias, removed in 0.3 */

/* Status of the projection (velfence.geometry.projection.PROJECT_*): deprecated aliases of the
 * vf_status outcomes, removed in 0.3. */
#define VF_ND_PROJECT_OPTIMAL VF_OK                 /* deprecated alias, removed in 0.3 */
#define VF_ND_PROJECT_INFEASIBLE VF_INFEASIBLE      /* deprecated alias, removed in 0.3 */
#define VF_ND_PROJECT_ITERATION_LIMIT VF_STALLED    /* deprecated alias, removed in 0.3 */

/* Zones and stage bits (velfence.shaping._kernels.ZONE_* / STAGE_*): deprecated aliases of
 * VF_ZONE_* / VF_STAGE_*, removed in 0.3. */
#define VF_ND_ZONE_FREE VF_ZONE_FREE                     /* deprecated alias, removed in 0.3 */
#define VF_ND_ZONE_BUFFER VF_ZONE_BUFFER                 /* deprecated alias, removed in 0.3 */
#define VF_ND_ZONE_CORNER VF_ZONE_CORNER                 /* deprecated alias, removed in 0.3 */
#define VF_ND_ZONE_OUTSIDE VF_ZONE_OUTSIDE               /* deprecated alias, removed in 0.3 */
#define VF_ND_ZONE_OUTSIDE_CORNER VF_ZONE_OUTSIDE_CORNER /* deprecated alias, removed in 0.3 */
#define VF_ND_ZONE_INVALID VF_ZONE_INVALID               /* deprecated alias, removed in 0.3 */
#define VF_ND_STAGE_SPRING VF_STAGE_SPRING               /* deprecated alias, removed in 0.3 */
#define VF_ND_STAGE_PROJECT VF_STAGE_PROJECT             /* deprecated alias, removed in 0.3 */
#define VF_ND_STAGE_RELAXED VF_STAGE_RELAXED             /* deprecated alias, removed in 0.3 */
#define VF_ND_STAGE_STOP VF_STAGE_STOP                   /* deprecated alias, removed in 0.3 */
#define VF_ND_STAGE_SCALED VF_STAGE_SCALED               /* deprecated alias, removed in 0.3 */

/* Approach-profile kinds (velfence.shaping._kernels.PROFILE_*): deprecated aliases of
 * VF_PROFILE_*, removed in 0.3. */
#define VF_ND_PROFILE_LINEAR VF_PROFILE_LINEAR         /* deprecated alias, removed in 0.3 */
#define VF_ND_PROFILE_THREE_ZONE VF_PROFILE_THREE_ZONE /* deprecated alias, removed in 0.3 */
#define VF_ND_PROFILE_PARAMS VF_PROFILE_PARAMS         /* deprecated alias, removed in 0.3 */

/* ------------------------------------------------------------------ the projection */

/* Doubles of float scratch vf_nd_project_kernel needs for m rows in n-D: 2 n^2 + 4 n + m + 2. */
size_t vf_nd_project_doubles(int32_t m, int32_t n);

/* The unchecked reference kernel (project_kernel): minimise |x - u|^2 s.t. G[i].x >= b[i], i < m.
 * u (n,), G (m x n), b (m,) (-inf rows are ignored), x out (n,), lam out (n + 1,), act out (n + 1,),
 * wsf scratch (vf_nd_project_doubles). Returns VF_ND_PROJECT_*; *q active rows act[:q] with
 * multipliers lam[:q]; *iters inner iterations. No input check. */
int vf_nd_project_kernel(const double *u, const double *G, const double *b, int32_t m, int32_t n,
                         double *x, double *lam, int32_t *act, double *wsf, int32_t *q,
                         int32_t *iters);

/* Options of a solve. max_iterations <= 0: the default cap vf_nd_default_iteration_cap(m, n)
 * (reaching it then means round-off stalled the method: VF_STALLED); > 0: the
 * caller's cap (reaching it: VF_ITERATION_CAP). deadline: an absolute time on
 * CLOCK_MONOTONIC in seconds (vf_nd_monotonic_seconds()), checked once per inner iteration; 0 or
 * INFINITY for none (passing it: VF_DEADLINE). warm[:n_warm]: row indices tried first
 * when the next violated row is picked (the previous cycle's active rows; out-of-range entries
 * are ignored). On VF_ITERATION_CAP or VF_DEADLINE, x is finite but NOT feasible: the
 * caller needs a safe fallback. */
typedef struct vf_nd_solve_opts {
    int32_t max_iterations;
    double deadline;
    const int32_t *warm;
    int32_t n_warm;
} vf_nd_solve_opts;

/* 4 (m + n) + 16: the default iteration cap (linear in the row count). */
int32_t vf_nd_default_iteration_cap(int32_t m, int32_t n);

/* Seconds on CLOCK_MONOTONIC, the clock of vf_nd_solve_opts.deadline. */
double vf_nd_monotonic_seconds(void);

/* vf_nd_project_kernel with options (opts may be NULL: the defaults). Accepts a row as met when
 * G_i.x - b_i >= -1e-12 (|b_i| + |G_i| max(|x|_inf, |u|_inf)): the round-off of forming x from u.
 * A point outside a facet by its own round-off never makes a problem infeasible. */
int vf_nd_project_kernel_opt(const double *u, const double *G, const double *b, int32_t m,
                             int32_t n, double *x, double *lam, int32_t *act, double *wsf,
                             int32_t *q, int32_t *iters, const vf_nd_solve_opts *opts);

/* The checked projection: VF_ND_OK (then *status is VF_ND_PROJECT_*), VF_ND_ERR_NULL,
 * VF_ND_ERR_ARGUMENT (m < 0, n < 1, non-finite G), VF_ND_ERR_NONFINITE (u non-finite, b NaN or
 * +inf), VF_ND_ERR_OVERFLOW (x overflowed, or a row G_i . x with a bound did). On an error x = 0, *q = 0, *iters = 0 and *status =
 * VF_ND_PROJECT_INFEASIBLE (when status is not NULL). */
int vf_nd_project(const double *u, const double *G, const double *b, int32_t m, int32_t n,
                  double *x, double *lam, int32_t *act, double *wsf, int32_t *q, int32_t *iters,
                  int32_t *status);

/* ------------------------------------------------------------------ the n-D exact law */

/* A convex polytope {p : N p >= off} as the law reads it (ConvexPolytope: normals, offsets,
 * chebyshev_center). Borrowed pointers. */
typedef struct vf_nd_polytope {
    const double *N;   /* inward unit normals, (nf x dim) row-major */
    const double *off; /* offsets (nf,): signed distance d_i = N[i].p - off[i] */
    const double *cen; /* an interior point (dim,) (the Chebyshev centre) */
    int32_t nf;        /* number of facets, >= 1 */
    int32_t dim;       /* dimension, >= 1 */
} vf_nd_polytope;

/* The law's parameters (PolytopeShaper builds them). */
typedef struct vf_nd_law {
    int32_t kind;                     /* VF_ND_PROFILE_* */
    double prm[VF_ND_PROFILE_PARAMS]; /* the kind's parameters */
    int32_t relax;                    /* 1: built-in buffer (cap speed |v| + R); 0: a profile */
    double idt;                       /* 1/dt [1/s], 0: continuous time */
} vf_nd_law;

/* Caller-owned scratch: dbl has vf_nd_law_doubles(nf, dim) doubles, ints vf_nd_law_ints(nf, dim)
 * int32_t. */
typedef struct vf_nd_scratch {
    double *dbl;
    int32_t *ints;
} vf_nd_scratch;

size_t vf_nd_law_doubles(int32_t nf, int32_t dim);
size_t vf_nd_law_ints(int32_t nf, int32_t dim);

/* One shaped state (polytope_kernel's tuple). out: the velocity (dim,), caller-owned. */
typedef struct vf_nd_result {
    int32_t zone;      /* VF_ND_ZONE_* */
    int32_t stages;    /* bit mask of VF_ND_STAGE_* */
    int32_t q;         /* binding facets, in active[:q] (active: caller array of dim + 1) */
    int32_t p1, p2;    /* nearest and second-nearest facet (-1: none / error) */
    double d1, d2;     /* their signed distances [units] (inf when absent, 0 on error) */
    int32_t m;         /* bounded facets (vf_nd_bounded gives them and their bounds) */
} vf_nd_result;

/* Checks the polytope and law once (outside the control loop): VF_ND_OK or VF_ND_ERR_*. */
int vf_nd_check(const vf_nd_polytope *poly, const vf_nd_law *law);

/* The unchecked reference kernel (polytope_kernel): shapes command v (dim,) at position p (dim,)
 * into out (dim,), binding facets into active (dim + 1,). No check; an overflowed output is
 * returned as is. After the call the scratch holds the signed distances, the bounded facets and
 * their bounds (vf_nd_bounded). */
void vf_nd_kernel(const vf_nd_polytope *poly, const vf_nd_law *law, const double *p,
                  const double *v, double *out, int32_t *active, vf_nd_scratch *scratch,
                  vf_nd_result *res);

/* The checked law: VF_ND_OK, VF_ND_ERR_NULL, VF_ND_ERR_NONFINITE (p or v non-finite),
 * VF_ND_ERR_OVERFLOW (the output overflowed, or d1/d2 did: a position so far away that the signed
 * distances N.p - off are not finite; d2 = +inf only when absent, nf = 1). The polytope and law are NOT re-checked per call:
 * validate them once with vf_nd_check. On an error: out = 0, the stop result in *res. */
int vf_nd_shape(const vf_nd_polytope *poly, const vf_nd_law *law, const double *p,
                const double *v, double *out, int32_t *active, vf_nd_scratch *scratch,
                vf_nd_result *res);

/* Views into the scratch after vf_nd_kernel / vf_nd_shape: signed distances (nf,), bounds
 * indexed by facet (nf,; valid for the facets in work[:m]) and the bounded facets work (nf,). */
void vf_nd_bounded(const vf_nd_polytope *poly, vf_nd_scratch *scratch, const double **dist,
                   const double **bnd, const int32_t **work);

/* Rows r = 0..rows-1 of P, V (rows x dim) -> out (rows x dim), zones (rows,) (may be NULL); dim
 * <= 63 (VF_ND_ERR_ARGUMENT otherwise: use vf_nd_shape, whose active array the caller sizes). A row
 * with non-finite input or an overflowed output gets zero velocity and zone VF_ND_ZONE_INVALID.
 * Returns the number of such rows, or a negative VF_ND_ERR_* code (then nothing is written). */
int64_t vf_nd_batch(const vf_nd_polytope *poly, const vf_nd_law *law, const double *P,
                    const double *V, size_t rows, double *out, int64_t *zones,
                    vf_nd_scratch *scratch);


/* ------------------------------------------------------------------ safety-filter helpers */

/* The safety filter's bounds on the approach rates of k constraints at signed distances dist
 * (velfence.shaping.filter._bounds): the exact law's bound definition with cap speed `speed`, no
 * relaxation, unit scale; every row gets a bound (-inf: no cap). work: 2 k int32_t. */
void vf_nd_rate_bounds(int32_t kind, const double *prm, const double *dist, int32_t k,
                       double speed, double idt, double *bnd, int32_t *work);

/* A serial chain's capsule links and sphere obstacles (SafetyFilter's obstacle rows). */
typedef struct vf_nd_capsules {
    const double *P;    /* joint points P_0 .. P_nl, (nl + 1) x 3 [m]; link l runs P_l -> P_l+1 */
    const double *axes; /* joint axes z_0 .. z_nj-1, nj x 3 (unit; joint j moves links >= j) */
    const double *lrad; /* capsule radius of every link (nl,) [m] */
    const double *C;    /* sphere centres, k x 3 [m] */
    const double *srad; /* sphere radii (k,) [m] */
    const double *vmax; /* joint speed limits (nj,) [rad/s] for the discrete-time reach; or NULL */
    double vsum;        /* sum of vmax */
    double buf;         /* obstacle buffer [m] */
    double dt, idt;     /* control period [s] and 1/dt, or 0 and 0 */
    int32_t nl, nj, ncols, k; /* links, axes, columns of a row (>= nj), spheres */
    int32_t kind;                     /* the obstacles' profile (VF_ND_PROFILE_*) */
    double prm[VF_ND_PROFILE_PARAMS]; /* and its parameters */
} vf_nd_capsules;

/* The obstacle rows G x >= b of every (sphere, link) pair within the buffer (or, in discrete
 * time, within one period's reach at full joint speed), sphere-major: row r is the clearance
 * normal's Jacobian row n . (z_j x (x_c - P_j)) (j <= link) at the link's critical point x_c, its
 * bound from vf_nd_rate_bounds at the speed |J_c u| of that point, d[r] the clearance, obs[r] /
 * link[r] the pair. Rows without a bound (-inf) are left out. Outputs hold k * nl rows (G: k nl
 * ncols doubles); work: k nl + nl doubles. Returns the number of rows. No input check. */
int32_t vf_nd_capsule_rows(const vf_nd_capsules *cap, const double *u, double *G, double *b,
                           double *d, int32_t *obs, int32_t *link, double *work);

/* The clearance of every (sphere, link) pair, sphere-major: clear[i nl + l] = |x_c - C_i| - srad_i
 * - lrad_l (k nl doubles) [m]; what vf_nd_capsule_rows selects from (and the discrete-time model
 * check reads at the next pose). */
void vf_nd_capsule_clearances(const vf_nd_capsules *cap, double *clear);

/* ------------------------------------------------------------------ a DH chain's filter rows */

/* Forward kinematics of a serial chain of n revolute joints in Denavit-Hartenberg form
 * (velfence.mechanisms.chain.DHChain._kinematics_lists, the same operations in the same order):
 * dh (n x 5) holds per joint a [m], cos(alpha), sin(alpha), d [m] and the angle offset [rad];
 * tool (3,) the tool point in the last frame [m]. Writes the joint points P_0 .. P_n ((n + 1) x 3,
 * P_n the tool point), the joint axes z_0 .. z_n-1 (n x 3) and the last frame's origin flange (3,). */
void vf_nd_chain_kinematics(int32_t n, const double *dh, const double *tool, const double *q,
                            double *P, double *axes, double *flange);

/* One workspace limit of the filter: a point of the chain kept in the polytope N p >= off. */
typedef struct vf_nd_workspace {
    const double *N;   /* unit inward normals, nf x 3 */
    const double *off; /* offsets (nf,) [m] */
    int32_t nf;        /* facets */
    int32_t point;     /* the point: joint point P_point (0 .. n; n the tool point), -1 the flange */
    int32_t kind;      /* approach profile (VF_ND_PROFILE_*) */
    double prm[VF_ND_PROFILE_PARAMS];
} vf_nd_workspace;

/* The safety filter's problem on a DH chain (SafetyFilter on a DHChain, joint mode). */
typedef struct vf_nd_filter {
    int32_t n;                 /* joints */
    const double *dh, *tool;   /* vf_nd_chain_kinematics's chain */
    const double *lower;       /* joint position limits (n,) [rad]; -inf / +inf: none */
    const double *upper;
    const double *vmax;        /* joint speed limits (n,) [rad/s], > 0 */
    const double *amax;        /* joint acceleration limits (n,) [rad/s^2] (inf: none), or NULL */
    const int32_t *jkind;      /* the joints' approach profiles (n,) */
    const double *jprm;        /* and their parameters, n x VF_ND_PROFILE_PARAMS */
    int32_t nw;                /* workspace limits */
    const vf_nd_workspace *ws; /* (nw,) */
    vf_nd_capsules cap;        /* obstacles (cap.k = 0: none); P, axes, dt, idt set per call */
} vf_nd_filter;

/* Row levels of vf_nd_filter_rows (velfence.shaping.filter.LEVEL_*): deprecated aliases of
 * VF_LEVEL_*, removed in 0.3. */
#define VF_ND_LEVEL_JOINT VF_LEVEL_JOINT         /* deprecated alias, removed in 0.3 */
#define VF_ND_LEVEL_WORKSPACE VF_LEVEL_WORKSPACE /* deprecated alias, removed in 0.3 */
#define VF_ND_LEVEL_OBSTACLE VF_LEVEL_OBSTACLE   /* deprecated alias, removed in 0.3 */
#define VF_ND_LEVEL_RATE VF_LEVEL_RATE           /* deprecated alias, removed in 0.3 */

/* Largest number of rows vf_nd_filter_rows writes: 4 n + 2 n + sum nf + k n. */
size_t vf_nd_filter_rows_max(const vf_nd_filter *f);
/* Doubles of scratch vf_nd_filter_rows needs: k n + n + 3 max(nf) + 3 n + 4 (the obstacle rows'
 * k n + n, a workspace's distances and bounds, 2 max(nf) int32 of work, its point's Jacobian,
 * 4 spare). */
size_t vf_nd_filter_doubles(const vf_nd_filter *f);

/* Every row G x >= b of one cycle of the safety filter on a DH chain at joint position q (n,)
 * with command u (n,), in SafetyFilter's order: per joint its position lower / upper rows (where
 * the limit is finite and the profile bounds the approach) and velocity lower / upper rows; the
 * acceleration rows (previous != NULL, dt > 0, amax given: x_j >= previous_j - amax_j dt and
 * -x_j >= -(previous_j + amax_j dt)); every workspace limit's rows (the point's Jacobian row
 * N_i J and the exact law's bound at the point's speed |J u|, facets without a bound left out);
 * the obstacle rows of vf_nd_capsule_rows. dt = 0: continuous time. Outputs (rows_max rows):
 * G (rows x n), b, level (VF_ND_LEVEL_*), tag_a / tag_b (joint rows: 4 j + side, 0; acceleration:
 * j, side; workspace: limit, facet; obstacle: sphere, link), dist (the signed distance of
 * position, workspace and obstacle rows, +inf for velocity and acceleration rows); P, axes,
 * flange: the kinematics. Returns the number of rows. No input check: the caller passes finite
 * q, u and previous of magnitude <= 1e150, as SafetyFilter does (it validates them and shortens
 * larger commands first); beyond that |J u| can overflow and bounds come out NaN (the solve then
 * refuses them, but the rows are meaningless). */
int32_t vf_nd_filter_rows(const vf_nd_filter *f, const double *q, const double *u,
                          const double *previous, double dt, double *P, double *axes,
                          double *flange, double *G, double *b, int32_t *level, int32_t *tag_a,
                          int32_t *tag_b, double *dist, double *work);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_ND_H */
