/*
 * velfence_filter.h -- the safety filter's whole cycle in plain C99 (SafetyFilter: joint and
 * twist mode).
 *
 * One call, vf_filter_cycle, takes the joint position q and the commanded joint velocity u of a
 * serial chain and returns the nearest joint velocity x (in the metric W = diag(weights), or a
 * full metric H = L L^T given by its factor L: vf_filter_cycle_metric) that meets every safety
 * row G x >= b at once:
 *
 *   1. kinematics of the chain given as data (below) at q;
 *   2. the built-in rows, in this order (the row keys (level, a, b) in brackets):
 *        joint position lower / upper rows of every joint where the limit is finite and the
 *          profile bounds the approach: x_j >= b, -x_j >= b     (VF_FILTER_LEVEL_JOINT, j, 0 / 1),
 *        joint velocity lower / upper rows of every joint  x_j >= -v_j, -x_j >= -v_j
 *                                                              (VF_FILTER_LEVEL_JOINT, j, 2 / 3),
 *        acceleration rows (previous != NULL, dt > 0, amax_j finite):
 *          x_j >= prev_j - a_j dt, -x_j >= -(prev_j + a_j dt)      (VF_FILTER_LEVEL_RATE, j, 0 / 1),
 *        jerk rows (previous and previous2 != NULL, dt > 0, jmax_j finite; c_j = 2 prev_j - prev2_j
 *          as prev_j + (prev_j - prev2_j)):
 *          x_j >= c_j - J_j dt^2, -x_j >= -(c_j + J_j dt^2)        (VF_FILTER_LEVEL_JERK, j, 0 / 1),
 *        workspace rows: facet i of polytope w on its point p: (N_i J_p) x >= b_i, the exact law's
 *          bound at the point's speed |J_p u| (facets without a bound left out)
 *                                                         (VF_FILTER_LEVEL_WORKSPACE, w, i),
 *        obstacle rows: sphere s against the capsule of link l, (n J_c) x >= b at the link's
 *          critical point (vf_nd_capsule_rows; pairs beyond the buffer and one period's reach
 *          left out)                                       (VF_FILTER_LEVEL_OBSTACLE, s, l),
 *        self-collision rows: link capsule i against link capsule j, nrm^T (J_i(pa) - J_j(pb)) x
 *          >= b at the closest axis points (vf_self_row; the obstacle profile, pairs beyond the
 *          buffer and the two links' one-period reach left out) (VF_FILTER_LEVEL_OBSTACLE, k + i, j);
 *      a row is *violated* when its signed distance is < 0; its bound is then a recovery bound;
 *   3. the feasibility test (G u >= b as evaluated: then x = u exactly), the projection
 *      (vf_nd_project_kernel_opt with the caller's iteration cap, deadline and warm rows; in the
 *      metric's coordinates y = sqrt(w) x or y = L^T x, then a repair along rows missed beyond
 *      the acceptance tolerance; an
 *      answer beyond the joint speed limits -- rows of every rung -- counts as a stalled solve),
 *      the discrete-time model check and the priority ladder, exactly as velfence.filter (the
 *      Python oracle):
 *        rung 1  every row as built;
 *        rung 2  drop the jerk rows                           (VF_FILTER_STAGE_DROPPED_JERK),
 *                then the acceleration rows too               (VF_FILTER_STAGE_DROPPED_RATE);
 *        rung 3  violated obstacle rows with b > 0: b scaled by 1/4, 1/16, ..., 4^-8, then 0
 *                                                             (VF_FILTER_STAGE_RELAXED_OBSTACLES);
 *        rung 4  the same for the workspace rows              (VF_FILTER_STAGE_RELAXED_WORKSPACE);
 *        rung 5  the same for the joint position rows         (VF_FILTER_STAGE_RELAXED_JOINT);
 *        rung 6  zero velocity                                (VF_FILTER_STAGE_STOP).
 *      Rows the point is inside are never relaxed; no workspace or obstacle row is dropped.
 *      Model check (dt > 0): the true next distance d1 of every workspace and obstacle row at
 *      q + x dt must be >= min(0, d0); a failing row's bound is raised by
 *      (min(0, d0) - d1) / dt (1 + 1e-6) + 1e-12 and the rung solved again (4 rounds); if that does
 *      not settle, x is scaled by the largest t in {1, 1/2, ..., 2^-10} with t x passing the model
 *      check and every row with its bound relaxed to min(b, 0) (VF_FILTER_STAGE_MODEL_SCALED),
 *      else 0 (VF_FILTER_STAGE_STOP); a re-solve that fails ends the rounds the same way.
 *      Deadline: when a solve hits the iteration cap or the cycle its time budget, the output is
 *      the safe fallback: the largest t in [0, 1] with t u meeting every row relaxed to
 *      min(b, 0) (closed form, halved until met as evaluated), then the model check's scaling
 *      as above; else zero (VF_FILTER_STAGE_DEADLINE, info->deadline; the ladder's stages and
 *      relaxed / dropped flags are replaced). Zero meets those rows, so it is always safe.
 *   4. the report: info (stages, rung, relaxed / dropped levels, relaxed rows, active rows --
 *      slack <= 1e-9 (1 + |b|) or violated --, the rows, the slack and the bounds the output
 *      claims to meet). Every claimed bound and every joint, workspace and obstacle row's
 *      min(b, 0) are met to 1e-12 (|c| + |g|_1 (|x|_inf + |u|_inf)) (the spec's acceptance).
 *
 * Warm start: pass the last cycle's active keys (level, key_a, key_b of info->active rows) in
 * opts->warm; the first solve tries those rows first (same answer, usually fewer iterations).
 *
 * Commands beyond 1e3 times the fastest joint limit are first shortened in their own direction
 * (VF_FILTER_STAGE_COMMAND_SCALED), as SafetyFilter does.
 *
 * The chain as data. Joint j (0 .. n-1) has a fixed transform T_j (3 x 4 row-major [R | p]) from
 * the previous joint's moving frame (the base for j = 0) to the joint frame, a unit axis a_j in
 * the joint frame, a type (VF_FILTER_REVOLUTE: rotation by q_j + offset_j about a_j through the
 * frame's origin; VF_FILTER_PRISMATIC: translation by q_j + offset_j along a_j) and an offset:
 *
 *     F_j = F_{j-1} T_j M_j(q_j + offset_j),      F_{-1} = I,      F_tool = F_{n-1} tool.
 *
 * Joint j's point P_j is the origin of F_{j-1} T_j (on its axis), its world axis z_j = R a_j;
 * P_n is the tool point (origin of F_tool). Link l (0 .. n-1) is the capsule P_l -> P_{l+1}.
 * A standard DH row (a, alpha, d, theta0) is the motion Rz(q + theta0) followed by the fixed
 * Tz(d) Tx(a) Rx(alpha), which becomes the next joint's T (and the tool's for the last joint):
 * T_0 = I, T_j = Tz(d_{j-1}) Tx(a_{j-1}) Rx(alpha_{j-1}), tool = Tz(d_{n-1}) Tx(a_{n-1})
 * Rx(alpha_{n-1}) Tt (rows 0-based, Tt the tool offset).
 * A modified DH (Craig) row (a_{i-1}, alpha_{i-1}, d_i, theta0) is T_j = Rx(alpha) Tx(a) Tz(d) with
 * motion Rz; a URDF / MJCF joint is its origin transform and axis directly.
 * Named points (workspace polytopes) sit on a frame: link -1 the base, 0 .. n-1 the frame F_link
 * (after joint `link`'s motion), n the tool frame, at `offset` in that frame.
 *
 * Obstacle rows need every joint revolute (VF_ERR_ARGUMENT otherwise): the capsule Jacobian of
 * vf_nd_capsule_rows is the revolute one.
 *
 * Twist mode and full metrics. SafetyFilter's twist mode (minimise 1/2 |J x - v|^2 +
 * 1/2 lambda^2 |x|^2 under the same rows) is the projection of u = H^-1 J^T v in the metric
 * H = J^T J + lambda^2 I. It runs here through vf_filter_cycle_metric with the metric's
 * Cholesky factor L (H = L L^T, lower triangular, n x n row-major) and that u: the solve runs in
 * y = L^T x on the rows G L^-T (a forward substitution per row, once per cycle), x = L^-T y (a
 * back substitution), then the repair above; everything else (rows, ladder, model check,
 * fallback, report) is the joint-mode cycle's. The factor replaces f->weights for that call.
 *
 * Real-time use: reentrant, allocation-free, no global state. The caller owns every buffer: the
 * scratch holds vf_filter_doubles(f) doubles and vf_filter_ints(f) int32_t (query once). The
 * description is read-only and shareable between threads; one scratch per thread. Every input is
 * validated on every call (the description too: it is cheap against a solve); on an error the
 * output is zero, info->stages = VF_FILTER_STAGE_STOP and a negative status is returned.
 *
 * Units: metres, radians, seconds (speeds per second, dt in s, deadline in s of CLOCK_MONOTONIC).
 */
#ifndef VELFENCE_FILTER_H
#define VELFENCE_FILTER_H

#include <stddef.h>
#include <stdint.h>

#include "velfence_nd.h"
#include "velfence_status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Status codes: velfence_status.h (VF_OK, VF_ERR_*, VF_ITERATION_CAP, VF_DEADLINE, ...). */

#define VF_FILTER_REVOLUTE 0
#define VF_FILTER_PRISMATIC 1

#define VF_FILTER_LEVEL_JOINT 0
#define VF_FILTER_LEVEL_WORKSPACE 1
#define VF_FILTER_LEVEL_OBSTACLE 2
#define VF_FILTER_LEVEL_RATE 3
#define VF_FILTER_LEVEL_JERK 4
#define VF_FILTER_LEVELS 5

/* Stage bits of info->stages (FilterResult.stages). */
#define VF_FILTER_STAGE_PROJECTION 1        /* the output differs from the (capped) command */
#define VF_FILTER_STAGE_RECOVERY 2          /* some row is violated */
#define VF_FILTER_STAGE_MODEL_CHECK 4       /* a bound was raised by the model check */
#define VF_FILTER_STAGE_DROPPED_RATE 8      /* the acceleration rows were dropped */
#define VF_FILTER_STAGE_RELAXED_OBSTACLES 16
#define VF_FILTER_STAGE_RELAXED_WORKSPACE 32
#define VF_FILTER_STAGE_RELAXED_JOINT 64
#define VF_FILTER_STAGE_STOP 128            /* zero velocity */
#define VF_FILTER_STAGE_DEADLINE 256        /* the safe fallback (iteration cap or time budget) */
#define VF_FILTER_STAGE_COMMAND_SCALED 512  /* the command was shortened first */
#define VF_FILTER_STAGE_MODEL_SCALED 1024   /* the model check scaled the solve's answer */
#define VF_FILTER_STAGE_DROPPED_JERK 2048   /* the jerk rows were dropped */

#define VF_FILTER_DEADLINE_NONE 0
#define VF_FILTER_DEADLINE_ITERATIONS 1
#define VF_FILTER_DEADLINE_TIME 2

typedef struct vf_filter_joint {
    double T[12];   /* fixed transform from the previous moving frame, [R | p] row-major */
    double axis[3]; /* unit axis in the joint frame */
    int32_t type;   /* VF_FILTER_REVOLUTE or VF_FILTER_PRISMATIC */
    double offset;  /* joint coordinate = q_j + offset [rad or m] */
} vf_filter_joint;

typedef struct vf_filter_point {
    int32_t link;     /* -1 base, 0 .. n-1 the frame after joint `link`, n the tool frame */
    double offset[3]; /* position in that frame [m] */
} vf_filter_point;

typedef struct vf_filter_polytope {
    int32_t point;    /* index into vf_filter.points */
    int32_t nf;       /* facets, >= 1 */
    const double *N;  /* unit inward normals, nf x 3 */
    const double *off;/* offsets (nf,): signed distance N_i . p - off_i [m] */
    int32_t kind;     /* approach profile VF_ND_PROFILE_* ... */
    double prm[VF_ND_PROFILE_PARAMS]; /* ... and its parameters (velfence profiles' kernel_profile) */
} vf_filter_polytope;

typedef struct vf_filter_attachment {
    int32_t link;   /* the frame it rides on: -1 base, 0 .. n-1 after joint `link`, n the tool */
    double a[3];    /* axis ends in that frame [m] (a == b: a sphere) */
    double b[3];
    double radius;  /* [m], >= 0 */
} vf_filter_attachment;

typedef struct vf_filter {
    int32_t n;                     /* joints, 1 .. 64 */
    const vf_filter_joint *joints; /* (n,) */
    double tool[12];               /* tool transform in F_{n-1}, [R | p] row-major */
    const double *lower, *upper;   /* joint position limits (n,); -inf / +inf: none */
    const double *vmax;            /* joint speed limits (n,), > 0 */
    const double *amax;            /* joint acceleration limits (n,) (> 0, inf: none), or NULL */
    const int32_t *jkind;          /* the joints' approach profiles (n,) (VF_ND_PROFILE_*) */
    const double *jprm;            /* and their parameters, n x VF_ND_PROFILE_PARAMS */
    int32_t npoints;               /* named points */
    const vf_filter_point *points; /* (npoints,) */
    int32_t nw;                    /* workspace polytopes */
    const vf_filter_polytope *ws;  /* (nw,) */
    int32_t k;                     /* sphere obstacles */
    const double *centres;         /* k x 3 [m] */
    const double *radii;           /* (k,) [m], >= 0 */
    const double *link_radius;     /* capsule radius per link (n,) [m], >= 0; NULL: 0 */
    double obstacle_buffer;        /* width of the obstacles' linear buffer [m], > 0 */
    double spring_gain;            /* obstacles' recovery gain [1/s], >= 0 */
    double dt;                     /* control period [s], 0 < dt <= 1e150, or 0: continuous */
    const double *weights;         /* diagonal metric (n,), > 0, or NULL (identity) */
    const double *jmax;            /* joint jerk limits (n,) (> 0, inf: none), or NULL */
    /* Self-collision (after the obstacle rows, the same level, profile and reach test): link
     * capsule i against link capsule j for each pair (i, j), 0 <= i < j < n, in `pairs`
     * (2 x npairs ints); row key (VF_FILTER_LEVEL_OBSTACLE, k + i, j). 0 / NULL: none.
     * (zero-initialise the struct: the fields default to none) */
    int32_t npairs;
    const int32_t *pairs;
    /* Tool and payload shapes (velfence.filter.attach): each shape's axis ends (one for a
     * sphere) keep radius from every facet of every polytope (after that polytope's rows of
     * all polytopes: (VF_FILTER_LEVEL_WORKSPACE, w, nf_w + (2 s + e) nf_w + i)), and every
     * sphere obstacle keeps off the shape (after the link obstacle rows:
     * (VF_FILTER_LEVEL_OBSTACLE, i, n + s)). 0 / NULL: none. */
    int32_t nattach;
    const vf_filter_attachment *attach;
} vf_filter;

typedef struct vf_filter_opts {
    int32_t max_iterations; /* per solve; <= 0: the default cap 4 (m + n) + 16 */
    double time_budget;     /* s for the whole cycle, > 0; 0: none */
    double deadline;        /* absolute CLOCK_MONOTONIC time [s]; 0 or inf: none */
    const int32_t *warm;    /* row keys (level, a, b) x n_warm tried first (the last active set) */
    int32_t n_warm;
} vf_filter_opts;

typedef struct vf_filter_info {
    int32_t status;        /* the return value */
    int32_t stages;        /* VF_FILTER_STAGE_* bits */
    int32_t rung;          /* the rung that answered, 1 .. 6 (0: the feasibility test / error) */
    int32_t deadline;      /* VF_FILTER_DEADLINE_* */
    int32_t relaxed[VF_FILTER_LEVELS]; /* per level: 1 when its recovery bounds were relaxed */
    int32_t dropped[VF_FILTER_LEVELS]; /* per level: 1 when its rows were dropped (rate, jerk) */
    double fraction;       /* the last relaxation fraction tried (1: none) */
    int32_t m;             /* rows built */
    int32_t n_active;      /* active rows: slack <= 1e-9 (1 + |b|) at the output, or violated */
    int32_t n_violated;
    int32_t n_relaxed;     /* rows whose bound was relaxed (FilterResult.relaxed) */
    int32_t iterations;    /* solver iterations, summed */
    int32_t solves;
    /* Views into the scratch, valid until its next use: the rows as built (G m x n row-major,
     * b, signed distance (+inf for velocity / acceleration rows), keys level / a / b), the slack
     * G x - b at the output, the active row indices (n_active,) and the bounds the output is
     * claimed to meet (bound: the answering rung's bounds after relaxation and the model check's
     * raises; min(b, 0) after a scaled answer, the fallback or the stop; -inf: a dropped row).
     * Every row of levels 0-2 always meets min(b, 0) (up to the spec's round-off tau). */
    const double *G, *b, *dist, *slack, *bound;
    const int32_t *level, *key_a, *key_b, *active, *relaxed_rows;
} vf_filter_info;

/* Closest points of segments [a0, a1] and [b0, b1] (3 doubles each): the parameters s, t in
 * [0, 1] (velfence.geometry.primitives.segment_pair_params, the same arithmetic: skew pairs the
 * clamped optimum (Ericsson 5.1.9), parallel pairs (sin^2 <= 1e-16) the middle of the overlap,
 * a zero-length segment its start), the points pa, pb, the unit normal nrm = (pa - pb) / |pa - pb|
 * (crossing axes: d_a x d_b normalised; parallel and touching: z x d_a normalised, else x) and
 * the distance |pa - pb| (returned). pa, pb, nrm may be NULL. No check: finite inputs. */
double vf_segment_pair(const double *a0, const double *a1, const double *b0, const double *b1,
                       double *s, double *t, double *pa, double *pb, double *nrm);

/* One self-collision row of links i, j of a chain whose joint points P ((n + 1) x 3) and axes
 * ((n) x 3, revolute) are given: g (n,) = nrm^T (J_i(pa) - J_j(pb)) with the closest points
 * held fixed, the relative speed |(J_i - J_j) u| into *speed; returns the clearance
 * |pa - pb| - ri - rj. */
double vf_self_row(int32_t n, const double *P, const double *axes, int32_t i, int32_t j,
                   double ri, double rj, const double *u, double *g, double *speed);

/* Checks the description: VF_OK or a negative VF_ERR_* code. */
int vf_filter_check(const vf_filter *f);
/* Largest number of rows: 8 n + sum nf (1 + 2 nattach) + k (n + nattach) + npairs. */
size_t vf_filter_rows_max(const vf_filter *f);
/* Scratch sizes of vf_filter_cycle (0 for an invalid description). */
size_t vf_filter_doubles(const vf_filter *f);
size_t vf_filter_ints(const vf_filter *f);

/* The obstacles' profile (a linear buffer of width obstacle_buffer): kind and params. */
void vf_filter_obstacle_profile(const vf_filter *f, int32_t *kind, double *prm);

/* One cycle: q (n,), u (n,), previous (n,) or NULL (no acceleration rows), opts or NULL
 * (defaults) -> out (n,), info. Returns VF_OK, a positive outcome (VF_ITERATION_CAP or
 * VF_DEADLINE: the safe fallback was used) or a negative VF_ERR_* code (out = 0). */
int vf_filter_cycle(const vf_filter *f, const double *q, const double *u, const double *previous,
                    const vf_filter_opts *opts, double *out, vf_filter_info *info,
                    double *scratch, int32_t *iscratch);

/* vf_filter_cycle with the output before previous, previous2 (n,) or NULL: with both, dt > 0 and
 * f->jmax, the jerk rows (vf_filter_cycle passes NULL: none). */
int vf_filter_cycle_jerk(const vf_filter *f, const double *q, const double *u,
                         const double *previous, const double *previous2,
                         const vf_filter_opts *opts, double *out, vf_filter_info *info,
                         double *scratch, int32_t *iscratch);

/* vf_filter_cycle_jerk in the full metric H = L L^T: factor (n x n, row-major) is L, lower
 * triangular (the entries above the diagonal are not read), or NULL (f->weights' metric, as
 * vf_filter_cycle_jerk). A factor with a non-finite entry or a diagonal entry <= 0 is refused
 * with VF_ERR_ARGUMENT (output zero); rows whose image G L^-T overflows with VF_ERR_OVERFLOW. */
int vf_filter_cycle_metric(const vf_filter *f, const double *q, const double *u,
                           const double *previous, const double *previous2, const double *factor,
                           const vf_filter_opts *opts, double *out, vf_filter_info *info,
                           double *scratch, int32_t *iscratch);

/* ------------------------------------------------------------------ many states at once
 *
 * vf_filter_cycle_batch runs vf_filter_cycle on `count` independent states of one description
 * (a vector of simulated arms, one per environment): row r reads q[r n .. r n + n), u[...] and
 * previous[...] (previous NULL: no acceleration rows for any row), writes out[r n ...] and
 * status[r] = that row's vf_filter_cycle return value (VF_OK, VF_ITERATION_CAP / VF_DEADLINE: the
 * safe fallback, or a negative VF_ERR_* code: the row's output is zero, e.g. VF_ERR_NONFINITE for
 * a NaN state; the other rows are unaffected), stages[r] its VF_FILTER_STAGE_* bits and
 * n_active[r] its active rows (both optional: NULL). opts (or NULL) is shared by every row: its
 * time budget is per row, its warm keys tried by every row. Each row equals vf_filter_cycle of
 * that state bit for bit (the same code on the row's own scratch; no state crosses rows).
 *
 * Threads: `threads` workers (<= 0: the online cores, sysconf(_SC_NPROCESSORS_ONLN)), at most
 * `count` and VF_FILTER_BATCH_MAX_THREADS; worker 0 is the calling thread, the others POSIX
 * threads created for the call and joined before it returns (pthread_create allocates their
 * stacks inside the C library: use threads = 1 in a real-time loop, which creates none). Rows
 * are split into contiguous chunks, one per worker. A worker that cannot be created has its
 * chunk run by the calling thread. Without POSIX threads (_WIN32) every row runs in the caller.
 *
 * The caller owns the scratch: vf_filter_batch_doubles(f, threads) doubles and
 * vf_filter_batch_ints(f, threads) int32_t (one cycle's scratch per worker). Returns VF_OK when
 * every row ran (each row's outcome is in status[]), or a negative code for the call itself
 * (VF_ERR_NULL: a required pointer NULL; VF_ERR_ARGUMENT: count < 0 or an invalid description):
 * then every row's output is zero and status[r] is that code (when status is not NULL). */
#define VF_FILTER_BATCH_MAX_THREADS 64

/* Workers vf_filter_cycle_batch uses for `count` rows and a `threads` request (>= 1 if count >= 1). */
int32_t vf_filter_batch_workers(int32_t threads, int32_t count);
size_t vf_filter_batch_doubles(const vf_filter *f, int32_t threads);
size_t vf_filter_batch_ints(const vf_filter *f, int32_t threads);

int vf_filter_cycle_batch(const vf_filter *f, int32_t count, const double *q, const double *u,
                          const double *previous, const vf_filter_opts *opts, double *out,
                          int32_t *status, int32_t *stages, int32_t *n_active, int32_t threads,
                          double *scratch, int32_t *iscratch);

/* Forward kinematics of the chain: joint points P_0 .. P_n ((n + 1) x 3, P_n the tool point),
 * world axes z_0 .. z_n-1 (n x 3), frames F_-1 .. F_n-1, F_tool ((n + 2) x 12). No check. */
void vf_filter_kinematics(const vf_filter *f, const double *q, double *P, double *axes,
                          double *frames);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_FILTER_H */
