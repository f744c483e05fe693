/*
 * The safety filter's row arithmetic shared by the whole C cycle (velfence_filter.c) and
 * vf_nd_filter_rows (velfence_nd.c): the joint position, joint velocity and acceleration rows, a
 * workspace polytope's facet rows and a sphere's clearance to a link capsule. Private to the
 * library: not installed, not part of the C API. Each caller passes its own levels and tags; the
 * operations are the ones both files had, in the same order, so both stay bit-identical to
 * velfence's filter.
 */
#ifndef VF_ROWS_H
#define VF_ROWS_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "velfence_nd.h" /* vf_nd_rate_bounds, VF_ND_PROFILE_PARAMS */

/* Where rows go: G (rows x n, row-major), b, dist, level and the two tags, one entry per row. */
typedef struct vf_rows {
    double *G, *b, *dist;
    int32_t *level, *ta, *tb;
    int32_t n;
} vf_rows;

/* Row r: sign x_col >= bound (a unit row of G), with its level, tags (a, t) and distance d. */
static inline void vf_unit_row(const vf_rows *o, int32_t r, int32_t col, double sign,
                               double bound, int32_t lv, int32_t a, int32_t t, double d)
{
    double *g = o->G + (size_t)r * o->n;
    int32_t j;
    for (j = 0; j < o->n; j++) {
        g[j] = 0.0 * sign; /* -0.0 in a negated unit row, as -eye[j] */
    }
    g[col] = sign;
    o->b[r] = bound;
    o->level[r] = lv;
    o->ta[r] = a;
    o->tb[r] = t;
    o->dist[r] = d;
}

/* Joint col's position rows from row r on: x >= b toward the lower limit (tags a0, t0) and
 * -x >= b toward the upper one (a1, t1), the braking profile's bound capped at the speed v; a
 * limit that is not finite, or whose bound is -inf, writes no row. Returns the next row. */
static inline int32_t vf_joint_position_rows(const vf_rows *o, int32_t r, int32_t col,
                                             int32_t kind, const double *prm, double q,
                                             double lower, double upper, double v, double idt,
                                             int32_t lv, int32_t a0, int32_t t0, int32_t a1,
                                             int32_t t1)
{
    double dl = q * 1.0 + (-lower);
    double du = q * -1.0 + upper;
    double bl = -INFINITY, bu = -INFINITY;
    int32_t wk[2];
    if (isfinite(lower)) {
        vf_nd_rate_bounds(kind, prm, &dl, 1, v, idt, &bl, wk);
    }
    if (isfinite(upper)) {
        vf_nd_rate_bounds(kind, prm, &du, 1, v, idt, &bu, wk);
    }
    if (bl != -INFINITY) {
        vf_unit_row(o, r++, col, 1.0, bl < v ? bl : v, lv, a0, t0, dl);
    }
    if (bu != -INFINITY) {
        vf_unit_row(o, r++, col, -1.0, bu < v ? bu : v, lv, a1, t1, du);
    }
    return r;
}

/* Joint col's velocity rows at r, r + 1: x >= -v (tags a0, t0), -x >= -v (a1, t1). */
static inline int32_t vf_joint_speed_rows(const vf_rows *o, int32_t r, int32_t col, double v,
                                          int32_t lv, int32_t a0, int32_t t0, int32_t a1,
                                          int32_t t1)
{
    vf_unit_row(o, r++, col, 1.0, -v, lv, a0, t0, INFINITY);
    vf_unit_row(o, r++, col, -1.0, -v, lv, a1, t1, INFINITY);
    return r;
}

/* The acceleration rows from row r on (with a previous output, dt > 0 and amax): for each joint
 * j of finite amax_j, x_j >= prev_j - amax_j dt (tags j, 0) and -x_j >= -(prev_j + amax_j dt)
 * (j, 1). Returns the next row. */
static inline int32_t vf_rate_rows(const vf_rows *o, int32_t r, const double *previous, double dt,
                                   const double *amax, int32_t lv)
{
    int32_t j;
    if (previous == NULL || !(dt > 0.0) || amax == NULL) {
        return r;
    }
    for (j = 0; j < o->n; j++) {
        double step;
        if (!isfinite(amax[j])) {
            continue;
        }
        step = amax[j] * dt;
        vf_unit_row(o, r++, j, 1.0, previous[j] - step, lv, j, 0, INFINITY);
        vf_unit_row(o, r++, j, -1.0, -(previous[j] + step), lv, j, 1, INFINITY);
    }
    return r;
}

/* The jerk rows from row r on (with the last two outputs previous, previous2, dt > 0 and jmax):
 * for each joint j of finite jmax_j, around c_j = prev_j + (prev_j - prev2_j) (the velocity the
 * last acceleration would reach), x_j >= c_j - jmax_j (dt dt) (tags j, 0) and
 * -x_j >= -(c_j + jmax_j (dt dt)) (j, 1). Returns the next row. */
static inline int32_t vf_jerk_rows(const vf_rows *o, int32_t r, const double *previous,
                                   const double *previous2, double dt, const double *jmax,
                                   int32_t lv)
{
    int32_t j;
    if (previous == NULL || previous2 == NULL || !(dt > 0.0) || jmax == NULL) {
        return r;
    }
    for (j = 0; j < o->n; j++) {
        double step, c;
        if (!isfinite(jmax[j])) {
            continue;
        }
        step = jmax[j] * (dt * dt);
        c = previous[j] + (previous[j] - previous2[j]);
        vf_unit_row(o, r++, j, 1.0, c - step, lv, j, 0, INFINITY);
        vf_unit_row(o, r++, j, -1.0, -(c + step), lv, j, 1, INFINITY);
    }
    return r;
}

/* Workspace polytope w's facet rows from row r on: the point p (speed: its speed under the
 * command) against the nf facets N (3 each, unit), off; J holds the point's Jacobian, column j
 * (j < k) at 3 j. wsd, wsb (nf doubles each) and wi (2 nf int32) are scratch. A facet whose bound
 * is -inf writes no row; a row is n_i J (zeros beyond k), tags (w, i). Returns the next row. */
static inline int32_t vf_workspace_rows(const vf_rows *o, int32_t r, int32_t w, const double *N,
                                        const double *off, int32_t nf, int32_t kind,
                                        const double *prm, const double *p, const double *J,
                                        int32_t k, double speed, double idt, int32_t lv,
                                        double *wsd, double *wsb, int32_t *wi)
{
    int32_t i, j;
    for (i = 0; i < nf; i++) {
        const double *nn = N + 3 * (size_t)i;
        wsd[i] = nn[0] * p[0] + nn[1] * p[1] + nn[2] * p[2] - off[i];
    }
    vf_nd_rate_bounds(kind, prm, wsd, nf, speed, idt, wsb, wi);
    for (i = 0; i < nf; i++) {
        const double *nn = N + 3 * (size_t)i;
        double *g;
        if (wsb[i] == -INFINITY) {
            continue;
        }
        g = o->G + (size_t)r * o->n;
        for (j = 0; j < o->n; j++) {
            g[j] = 0.0;
        }
        for (j = 0; j < k; j++) {
            const double *col = J + 3 * (size_t)j;
            g[j] = nn[0] * col[0] + nn[1] * col[1] + nn[2] * col[2];
        }
        o->b[r] = wsb[i];
        o->level[r] = lv;
        o->ta[r] = w;
        o->tb[r] = i;
        o->dist[r] = wsd[i];
        r += 1;
    }
    return r;
}

/* geometry.primitives._point_segment_t: the parameter in [0, 1] of the point of segment a -> b
 * nearest p. */
static inline double vf_seg_t(const double *p, const double *a, const double *b)
{
    double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    double dd = dx * dx + dy * dy + dz * dz;
    double t;
    if (dd == 0.0) {
        return 0.0;
    }
    t = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy + (p[2] - a[2]) * dz) / dd;
    return t <= 0.0 ? 0.0 : (t >= 1.0 ? 1.0 : t);
}

/* The clearance of the sphere at cc (radius srad) and the capsule a -> e (radius lrad): the
 * segment's nearest point by _lerp, its distance with sqrt instead of math.hypot, minus srad, then
 * lrad (the obstacle rows' and the model check's one definition). */
static inline double vf_capsule_clearance(const double *cc, const double *a, const double *e,
                                          double srad, double lrad)
{
    double t = vf_seg_t(cc, a, e);
    double x0, x1, x2, dx, dy, dz;
    if (t <= 0.5) {
        x0 = a[0] + t * (e[0] - a[0]);
        x1 = a[1] + t * (e[1] - a[1]);
        x2 = a[2] + t * (e[2] - a[2]);
    } else {
        double w = 1.0 - t;
        x0 = e[0] - w * (e[0] - a[0]);
        x1 = e[1] - w * (e[1] - a[1]);
        x2 = e[2] - w * (e[2] - a[2]);
    }
    dx = x0 - cc[0];
    dy = x1 - cc[1];
    dz = x2 - cc[2];
    return sqrt(dx * dx + dy * dy + dz * dz) - srad - lrad;
}

#endif /* VF_ROWS_H */
