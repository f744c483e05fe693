/*
 * velfence_core.h -- the 2-D shaping laws of velfence in plain C99.
 *
 * Two laws keep a point inside a convex polygon by shaping its commanded velocity:
 *
 *   vf_exact_shape   the exact law (minimum-change velocity under one half-plane bound per nearby
 *                    edge; docs/derivations.md section 3), velfence's PolygonShaper(method="exact").
 *   vf_patent_shape  US 8,676,382's edge-scaling law (docs/derivations.md section 2),
 *                    PolygonShaper(method="edge-scaling").
 *
 * They compute the same operations in the same order as the Python reference
 * (velfence.shaping._kernels), so with IEEE double arithmetic and no contraction of a*b+c into a
 * fused multiply-add (compile with -ffp-contract=off) their results are bit-identical to it.
 *
 * Real-time use: every function here is reentrant and allocation-free. The caller owns every buffer
 * (polygon data, law parameters, scratch, results); nothing is allocated, no global state is read or
 * written, nothing longjmps or throws. The work per call is bounded: the exact law solves its
 * minimum-change problem by a dual active-set method (Goldfarb-Idnani in the plane, at most two
 * active bounds), one pass over its m bounded edges per step and a handful of steps, plus one
 * O(n) pass over the far edges when recovery makes the answer fast;
 * measured 20-50 ns per call for an 8-gon and a p99 of about 5 us at a 1024-gon's outside corner
 * (docs/core.md). One vf_scratch per thread; polygon and law data are read-only and shareable.
 *
 * Units: positions and distances in workspace units (m, rad, ...), velocities in workspace units
 * per second, idt = 1/dt in 1/s, angles in rad. Shapes: every per-edge array has n entries
 * (beta: n + 1), all arrays are contiguous doubles (int32_t for vf_scratch.work).
 *
 * Return codes (int): VF_OK (0) or a negative VF_ERR_* code. Whatever the code, *out is written
 * and every double in it is finite: on an error the answer is the stop result (zero velocity,
 * zone VF_ZONE_INVALID, stage VF_STAGE_STOP, edges -1, distances 0).
 */
#ifndef VELFENCE_CORE_H
#define VELFENCE_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "velfence_constants.h" /* VF_ZONE_*, VF_STAGE_*, VF_PROFILE_*, VF_VERSION */
#include "velfence_status.h"    /* the return codes: VF_OK and the negative VF_ERR_* */

#ifdef __cplusplus
extern "C" {
#endif

#define VF_CORE_VERSION VF_VERSION /* deprecated alias, removed in 0.3 */

/* A convex polygon as the laws read it (velfence ConvexPolygon.kernel_data). Borrowed pointers. */
typedef struct vf_polygon {
    const double *nx;   /* inward unit normals, x, (n,) */
    const double *ny;   /* inward unit normals, y, (n,) */
    const double *off;  /* offsets (n,): signed distance d_e = nx[e]*px + ny[e]*py - off[e] */
    const double *beta; /* patent only (else may be NULL): corner angles from corner 0, (n + 1,),
                           increasing in [0, 2 pi), last = 2 pi [rad] */
    double cx, cy;      /* centroid [units] */
    double a0;          /* patent only: angle of corner 0 seen from the centroid [rad] */
    int32_t n;          /* number of edges, >= 3 */
} vf_polygon;

/* The exact law's parameters (PolygonShaper(method="exact") builds them). */
typedef struct vf_exact_law {
    int32_t kind;                   /* VF_PROFILE_* */
    double prm[VF_PROFILE_PARAMS];  /* the kind's parameters (above) */
    int32_t relax;                  /* 1: built-in buffer (cap speed |v| + R); 0: a profile */
    double idt;                     /* 1/dt [1/s] of a discrete-time law, 0: continuous time */
} vf_exact_law;

/* The edge-scaling (patent) law's parameters. */
typedef struct vf_patent_law {
    double dmax;      /* buffer width d_max > 0 [units] */
    double k;         /* spring gain >= 0 [1/s] */
    double theta_max; /* corner blend angle in (0, pi) [rad] */
    double idt;       /* 1/dt [1/s], 0: continuous time */
} vf_patent_law;

/* Caller-owned scratch of the exact law: each array has at least n entries. */
typedef struct vf_scratch {
    double *dist;
    double *bnd;
    int32_t *work;
} vf_scratch;

/* One shaped state (the fields of velfence's ShapingResult). */
typedef struct vf_result {
    double ox, oy;      /* shaped velocity [units/s] */
    int32_t zone;       /* VF_ZONE_* */
    int32_t primary;    /* nearest edge (patent: the wedge's edge), -1 on error */
    int32_t secondary;  /* second-nearest edge (patent: neighbour at the nearer corner) */
    double d1, d2;      /* signed distances to them [units], positive inside */
    double sx, sy;      /* patent: virtual-spring velocity added outside [units/s]; exact: 0 */
    int32_t stages;     /* bit mask of VF_STAGE_* */
} vf_result;

/* Checks the polygon and law data once (outside the control loop). VF_OK or VF_ERR_*. */
int vf_exact_check(const vf_polygon *poly, const vf_exact_law *law);
int vf_patent_check(const vf_polygon *poly, const vf_patent_law *law);

/* Shapes command (vx, vy) at position (px, py). Returns VF_OK, VF_ERR_NONFINITE (non-finite
 * input), VF_ERR_OVERFLOW (some double of the result overflowed), VF_ERR_NULL; *out always
 * written, every double in it finite. VF_ERR_OVERFLOW also covers a position so far away
 * (beyond ~1e300) that the signed distances n.p - off overflow to +-inf while the velocity
 * (recovery at a capped speed) would stay finite: such a state is refused with the stop result
 * rather than answered with clamped distances, because a position of that size is a fault
 * upstream (no workspace is 1e300 units wide), stopping is the safe answer to a fault, the
 * distances d1/d2 would be fabricated (DBL_MAX is not the distance), and the velocity would
 * depend only on which sums happened to overflow.
 * The polygon and law are NOT re-checked per call: validate them once with vf_*_check. */
int vf_exact_shape(const vf_polygon *poly, const vf_exact_law *law, double px, double py,
                   double vx, double vy, vf_scratch *scratch, vf_result *out);
int vf_patent_shape(const vf_polygon *poly, const vf_patent_law *law, double px, double py,
                    double vx, double vy, vf_result *out);

/* Batches: rows r = 0..N-1 of P, V (N x 2 row-major) -> out (N x 2), zones (N,) (zones may be
 * NULL). A row with non-finite input or an overflowed result (as in vf_*_shape) gets zero
 * velocity and zone
 * VF_ZONE_INVALID. Returns the number of such rows (>= 0), or a negative VF_ERR_* code (then
 * nothing is written). */
int64_t vf_exact_batch(const vf_polygon *poly, const vf_exact_law *law, const double *P,
                       const double *V, size_t N, double *out, int64_t *zones,
                       vf_scratch *scratch);
int64_t vf_patent_batch(const vf_polygon *poly, const vf_patent_law *law, const double *P,
                        const double *V, size_t N, double *out, int64_t *zones);

/* The unchecked kernels, exactly the Python reference's: no input check, and an output that
 * overflowed is returned as is (possibly inf/NaN). For bindings that check on their side. */
void vf_exact_kernel(const vf_polygon *poly, const vf_exact_law *law, double px, double py,
                     double vx, double vy, vf_scratch *scratch, vf_result *out);
void vf_patent_kernel(const vf_polygon *poly, const vf_patent_law *law, double px, double py,
                      double vx, double vy, vf_result *out);

#ifdef __cplusplus
}
#endif

#endif /* VELFENCE_CORE_H */
