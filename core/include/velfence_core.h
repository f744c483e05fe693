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

#ifdef __cplusplus
extern "C" {
#endif

#define VF_CORE_VERSION "0.1.0"

/* Return codes. */
#define VF_OK 0
#define VF_ERR_NULL (-1)        /* a required pointer is NULL */
#define VF_ERR_ARGUMENT (-2)    /* bad polygon or law data (n < 3, non-finite, out of range) */
#define VF_ERR_NONFINITE (-3)   /* position or command not finite (NaN or +-inf) */
#define VF_ERR_OVERFLOW (-4)    /* finite input, overflowed result (velocity or distances) */

/* Zones (ShapingResult.zone, same codes as velfence.shaping.ZONE_NAMES). */
#define VF_ZONE_FREE 0
#define VF_ZONE_BUFFER 1
#define VF_ZONE_CORNER 2
#define VF_ZONE_OUTSIDE 3
#define VF_ZONE_OUTSIDE_CORNER 4
#define VF_ZONE_INVALID 5

/* Stage bits (velfence.shaping._kernels.STAGE_*). */
#define VF_STAGE_SECONDARY 1
#define VF_STAGE_PRIMARY 2
#define VF_STAGE_ZERO_OUTWARD 4
#define VF_STAGE_SPRING 8
#define VF_STAGE_BLEND 16
#define VF_STAGE_PROJECT 32
#define VF_STAGE_RELAXED 64
#define VF_STAGE_STOP 128
#define VF_STAGE_PERIOD 256

/* Approach-profile kinds of the exact law (velfence.shaping._kernels.PROFILE_*). */
#define VF_PROFILE_LINEAR 0     /* prm = (d_max, k, r_max, 0, 0, 0) */
#define VF_PROFILE_THREE_ZONE 1 /* prm = (K, max_speed, max_acceleration, d_int, d_f, d_phi) */
#define VF_PROFILE_PARAMS 6

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
