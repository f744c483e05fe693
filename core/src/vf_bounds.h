/*
 * The one definition, in C, of the exact law's bounds (velfence.shaping._kernels: zone_code,
 * profile_cap, fill_bounds, bounds_from_distances, unbounded_candidates), shared by the 2-D core
 * (velfence_core.c) and the n-D core (velfence_nd.c). Private to the library: not installed, not
 * part of the C API. Same operations in the same order as the Python reference (compile without
 * floating-point contraction), so both cores stay bit-identical to it.
 */
#ifndef VF_BOUNDS_H
#define VF_BOUNDS_H

#include <math.h>
#include <stdint.h>

#include "velfence_core.h"

/* _kernels.zone_code */
static inline int32_t zone_code(int32_t n_out, int32_t n_near)
{
    if (n_out > 0) {
        return n_near <= 1 ? VF_ZONE_OUTSIDE : VF_ZONE_OUTSIDE_CORNER;
    }
    if (n_near == 0) {
        return VF_ZONE_FREE;
    }
    return n_near == 1 ? VF_ZONE_BUFFER : VF_ZONE_CORNER;
}

/* _kernels.profile_cap */
static inline double profile_cap(int32_t kind, const double *prm, int extend, double d, double s)
{
    double a;
    if (kind == VF_PROFILE_LINEAR) {
        double r;
        if (d >= 0.0) {
            if (d >= prm[0] && !extend) {
                return INFINITY;
            }
            return s * (d / prm[0]);
        }
        r = -prm[1] * d;
        if (r > prm[2]) {
            r = prm[2];
        }
        return -r;
    }
    a = fabs(d);
    if (a > prm[5]) {
        return copysign(prm[1], d);
    }
    if (a > prm[3]) {
        return copysign(sqrt(2.0 * prm[2] * fabs(a - prm[4])), d);
    }
    return prm[0] * d;
}

/* _kernels.fill_bounds */
static inline void fill_bounds(int32_t kind, const double *prm, int extend, const double *dist,
                        const int32_t *work, int32_t lo, int32_t hi, double cs, double scale,
                        double idt, double *bnd)
{
    double rate = idt / scale;
    int lin = kind == VF_PROFILE_LINEAR;
    int32_t a;
    for (a = lo; a < hi; a++) {
        int32_t e = work[a];
        double d = dist[e];
        double b;
        if (d < 0.0) {
            bnd[e] = bnd[e] / scale;
            continue;
        }
        if (lin) {
            b = -profile_cap(kind, prm, extend, d, cs);
        } else {
            b = -(profile_cap(kind, prm, extend, d, cs * scale) / scale);
        }
        if (idt > 0.0 && -rate * d > b) {
            b = -rate * d;
        }
        bnd[e] = b;
    }
}

typedef struct bounds_out {
    int32_t m, n_out, n_near;
    double rec, cs, scale;
    int32_t p1, p2;
    double d1, d2;
} bounds_out;

/* _kernels.bounds_from_distances */
static inline void bounds_from_distances(const double *dist, int32_t n, double vnorm, int32_t kind,
                                  const double *prm, int relax, double idt, int normalise,
                                  double *bnd, int32_t *work, bounds_out *o)
{
    int lin = kind == VF_PROFILE_LINEAR;
    double dmax = prm[0];
    double gate = lin ? dmax : INFINITY;
    double rec = 0.0;
    int32_t p1 = -1;
    int32_t p2 = -1;
    double d1 = INFINITY;
    double d2 = INFINITY;
    int32_t m = 0;
    int32_t n_out = 0;
    int32_t n_near, e, a;
    double speed, scale, cs;
    for (e = 0; e < n; e++) {
        double d = dist[e];
        if (d < gate) {
            if (d < 0.0) {
                double r;
                work[m] = e;
                m += 1;
                n_out += 1;
                r = -profile_cap(kind, prm, 0, d, 0.0);
                if (idt > 0.0 && r > -d * idt) {
                    r = -d * idt;
                }
                bnd[e] = r;
                if (r > rec) {
                    rec = r;
                }
            } else {
                work[m] = e;
                m += 1;
            }
        }
        if (d < d1) {
            d2 = d1;
            p2 = p1;
            d1 = d;
            p1 = e;
        } else if (d < d2) {
            d2 = d;
            p2 = e;
        }
    }
    o->p1 = p1;
    o->p2 = p2;
    o->d1 = d1;
    o->d2 = d2;
    o->n_out = 0;
    o->n_near = 0;
    o->rec = 0.0;
    o->cs = 0.0;
    o->scale = 1.0;
    o->m = 0;
    if (m == 0 && idt == 0.0) {
        return;
    }
    if (!lin) {
        int32_t c = 0;
        for (a = 0; a < m; a++) {
            double d;
            e = work[a];
            d = dist[e];
            if (d < 0.0 || profile_cap(kind, prm, relax, d, vnorm) < vnorm) {
                work[c] = e;
                c += 1;
            }
        }
        m = c;
        if (m == 0 && idt == 0.0) {
            return;
        }
    }
    speed = vnorm + rec;
    if (idt > 0.0 && (speed > dmax * idt || !lin)) {
        double reach = speed / idt;
        m = 0;
        for (e = 0; e < n; e++) {
            double d = dist[e];
            if (d < reach
                || (!lin && (d < 0.0 || profile_cap(kind, prm, relax, d, vnorm) < vnorm))) {
                work[m] = e;
                m += 1;
            }
        }
    }
    if (m == 0) {
        o->rec = rec;
        return;
    }
    scale = (normalise && speed > 0.0) ? speed : 1.0;
    cs = (relax ? speed : vnorm) / scale;
    if (relax) {
        n_near = m;
    } else {
        n_near = 0;
        for (a = 0; a < m; a++) {
            if (profile_cap(kind, prm, relax, dist[work[a]], vnorm) < vnorm) {
                n_near += 1;
            }
        }
    }
    fill_bounds(kind, prm, relax, dist, work, 0, m, cs, scale, idt, bnd);
    o->m = m;
    o->n_out = n_out;
    o->n_near = n_near;
    o->rec = rec;
    o->cs = cs;
    o->scale = scale;
}

/* _kernels.unbounded_candidates */
static inline int32_t unbounded_candidates(const double *dist, int32_t *work, int32_t m, int32_t n)
{
    int32_t c = m;
    int32_t e, a;
    for (e = 0; e < n; e++) {
        int in_work = 0;
        if (dist[e] < 0.0) {
            continue;
        }
        for (a = 0; a < m; a++) {
            if (work[a] == e) {
                in_work = 1;
                break;
            }
        }
        if (!in_work) {
            work[c] = e;
            c += 1;
        }
    }
    return c;
}

#endif /* VF_BOUNDS_H */
