/*
 * velfence_core.c -- C99 port of velfence.shaping._kernels (2-D exact and edge-scaling laws).
 *
 * Every function mirrors its Python namesake operation by operation (same order, same
 * comparisons), so that the results are bit-identical with -ffp-contract=off. Comments name the
 * Python function each block ports; the derivations are in docs/derivations.md sections 2 and 3.
 */
#include "velfence_core.h"

#include <math.h>

#include "vf_bounds.h" /* zone_code, profile_cap, fill_bounds, bounds_from_distances */

#define VF_TWO_PI 6.283185307179586 /* 2.0 * math.pi */
#define VF_FEAS_TOL 1e-12
#define VF_REPAIR_ULPS (4.0 * 2.220446049250313e-16)
#define VF_RELAX_STEPS 9 /* _kernels.RELAX_STEPS */

/* Python's float % (result takes the sign of the divisor). */
static double py_mod(double x, double w)
{
    double mod = fmod(x, w);
    if (mod != 0.0) {
        if ((w < 0.0) != (mod < 0.0)) {
            mod += w;
        }
    } else {
        mod = copysign(0.0, w);
    }
    return mod;
}

static void set_result(vf_result *o, double ox, double oy, int32_t zone, int32_t p1, int32_t p2,
                       double d1, double d2, double sx, double sy, int32_t stages)
{
    o->ox = ox;
    o->oy = oy;
    o->zone = zone;
    o->primary = p1;
    o->secondary = p2;
    o->d1 = d1;
    o->d2 = d2;
    o->sx = sx;
    o->sy = sy;
    o->stages = stages;
}

static void set_stop(vf_result *o)
{
    set_result(o, 0.0, 0.0, VF_ZONE_INVALID, -1, -1, 0.0, 0.0, 0.0, 0.0, VF_STAGE_STOP);
}

/* ------------------------------------------------------------------ patent (edge scaling) */

/* geometry.polygon.wedge_search */
static int32_t wedge_search(double b, const double *beta, int32_t n)
{
    int32_t lo = 0;
    int32_t hi = n;
    while (hi - lo > 1) {
        int32_t mid = (lo + hi) / 2;
        if (beta[mid] <= b) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

/* geometry.polygon.wedge_angle */
static double wedge_b(double px, double py, double cx, double cy, double a0)
{
    double rx = px - cx;
    double ry = py - cy;
    if (rx == 0.0 && ry == 0.0) {
        return 0.0;
    }
    return py_mod(atan2(ry, rx) - a0, VF_TWO_PI);
}

/* _kernels._patent_core */
static void patent_core(const vf_polygon *poly, const vf_patent_law *law, double px, double py,
                        double vx, double vy, vf_result *out)
{
    const double *nx = poly->nx;
    const double *ny = poly->ny;
    const double *off = poly->off;
    const double *beta = poly->beta;
    const int32_t n = poly->n;
    const double dmax = law->dmax;
    const double k = law->k;
    const double theta_max = law->theta_max;
    double b = wedge_b(px, py, poly->cx, poly->cy, poly->a0);
    int32_t i = wedge_search(b, beta, n);
    double th_i = b - beta[i];
    double th_j = beta[i + 1] - b;
    int32_t j;
    double th2, n1x, n1y, n2x, n2y, d1, d2, ox, oy, sx, sy, vn, s, pen;
    int32_t stages = 0;
    int32_t zone;
    if (th_j < th_i) {
        j = i + 1;
        if (j == n) {
            j = 0;
        }
        th2 = th_j;
    } else {
        j = i - 1;
        if (j < 0) {
            j = n - 1;
        }
        th2 = th_i;
    }
    n1x = nx[i];
    n1y = ny[i];
    n2x = nx[j];
    n2y = ny[j];
    d1 = n1x * px + n1y * py - off[i];
    d2 = n2x * px + n2y * py - off[j];
    ox = vx;
    oy = vy;
    sx = 0.0;
    sy = 0.0;
    if (d1 >= 0.0) {
        if (d1 >= dmax) {
            set_result(out, ox, oy, VF_ZONE_FREE, i, j, d1, d2, sx, sy, stages);
            return;
        }
        zone = VF_ZONE_BUFFER;
        if (d2 < dmax) {
            zone = VF_ZONE_CORNER;
            vn = ox * n2x + oy * n2y;
            if (vn < 0.0) {
                s = (1.0 - d2 / dmax) * vn;
                ox -= s * n2x;
                oy -= s * n2y;
                stages |= VF_STAGE_SECONDARY;
            }
        }
        vn = ox * n1x + oy * n1y;
        if (vn < 0.0) {
            s = (1.0 - d1 / dmax) * vn;
            ox -= s * n1x;
            oy -= s * n1y;
            stages |= VF_STAGE_PRIMARY;
        }
        set_result(out, ox, oy, zone, i, j, d1, d2, sx, sy, stages);
        return;
    }
    pen = -d1;
    if (th2 < theta_max) {
        double w = 0.5 * (1.0 - th2 / theta_max);
        sx = k * pen * ((1.0 - w) * n1x + w * n2x);
        sy = k * pen * ((1.0 - w) * n1y + w * n2y);
        stages |= VF_STAGE_BLEND;
    } else {
        sx = k * pen * n1x;
        sy = k * pen * n1y;
    }
    stages |= VF_STAGE_SPRING;
    vn = ox * n1x + oy * n1y;
    if (vn < 0.0) {
        ox -= vn * n1x;
        oy -= vn * n1y;
        stages |= VF_STAGE_ZERO_OUTWARD;
    }
    ox += sx;
    oy += sy;
    zone = VF_ZONE_OUTSIDE;
    if (d2 < dmax) {
        zone = VF_ZONE_OUTSIDE_CORNER;
        vn = ox * n2x + oy * n2y;
        if (vn < 0.0) {
            double dd = d2 > 0.0 ? d2 : 0.0;
            s = (1.0 - dd / dmax) * vn;
            ox -= s * n2x;
            oy -= s * n2y;
            stages |= VF_STAGE_SECONDARY;
        }
    }
    set_result(out, ox, oy, zone, i, j, d1, d2, sx, sy, stages);
}

/* _kernels.patent_kernel */
void vf_patent_kernel(const vf_polygon *poly, const vf_patent_law *law, double px, double py,
                      double vx, double vy, vf_result *out)
{
    const double idt = law->idt;
    double ox, oy, t;
    int32_t e;
    patent_core(poly, law, px, py, vx, vy, out);
    if (idt <= 0.0) {
        return;
    }
    ox = out->ox;
    oy = out->oy;
    t = 1.0;
    for (e = 0; e < poly->n; e++) {
        double d = poly->nx[e] * px + poly->ny[e] * py - poly->off[e];
        if (d >= 0.0) {
            double a = -(poly->nx[e] * ox + poly->ny[e] * oy);
            if (a > d * idt) {
                double c = d * idt / a;
                if (c < t) {
                    t = c;
                }
            }
        }
    }
    if (t >= 1.0) {
        return;
    }
    out->ox = ox * t;
    out->oy = oy * t;
    out->stages |= VF_STAGE_PERIOD;
}

/* ------------------------------------------------------------------ exact law */

/* _kernels._violates */
static int violates(double x, double y, double nxe, double nye, double b, double tol)
{
    return nxe * x + nye * y < b - tol * (fabs(b) + fabs(x) + fabs(y));
}

/* _kernels._solve_tol: the dual active-set method (Goldfarb-Idnani in the plane, at most two
 * active bounds). Returns 1 (feasible) with *rx, *ry, else 0 with zeros. */
static int solve_tol(double vx, double vy, const int32_t *work, int32_t m, const double *nx,
                     const double *ny, const double *bnd, double tol, double *rx, double *ry)
{
    double x = vx;
    double y = vy;
    int q = 0;
    int32_t a1 = -1;
    int32_t a2 = -1;
    double l1 = 0.0;
    double l2 = 0.0;
    int64_t steps = 0;
    int64_t limit = 2 * (int64_t)m + 16;
    int32_t a;
    *rx = 0.0;
    *ry = 0.0;
    for (;;) {
        int32_t p = -1;
        double worst = 0.0;
        double lp = 0.0;
        for (a = 0; a < m; a++) {
            int32_t w = work[a];
            if (w == a1 || w == a2) {
                continue;
            }
            if (violates(x, y, nx[w], ny[w], bnd[w], tol)) {
                double g = bnd[w] - (nx[w] * x + ny[w] * y);
                if (p < 0 || g > worst) {
                    worst = g;
                    p = w;
                }
            }
        }
        if (p < 0) {
            *rx = x;
            *ry = y;
            return 1;
        }
        for (;;) {
            double sp, c, t1, t2, t, zx, zy;
            steps += 1;
            if (steps > limit) {
                return 0;
            }
            if (q == 2) {
                double det = nx[a1] * ny[a2] - ny[a1] * nx[a2];
                double r1 = (nx[p] * ny[a2] - ny[p] * nx[a2]) / det;
                double r2 = (nx[a1] * ny[p] - ny[a1] * nx[p]) / det;
                int kd = 0;
                t = INFINITY;
                if (r1 > 0.0) {
                    t = l1 / r1;
                    kd = 1;
                }
                if (r2 > 0.0 && l2 / r2 < t) {
                    t = l2 / r2;
                    kd = 2;
                }
                if (kd == 0) {
                    return 0;
                }
                l1 -= t * r1;
                l2 -= t * r2;
                lp += t;
                if (kd == 1) {
                    a1 = a2;
                    l1 = l2;
                }
                a2 = -1;
                l2 = 0.0;
                q = 1;
                continue;
            }
            sp = nx[p] * x + ny[p] * y - bnd[p];
            c = 0.0;
            t1 = INFINITY;
            t2 = INFINITY;
            if (q == 1) {
                c = nx[p] * nx[a1] + ny[p] * ny[a1];
                zx = nx[p] - c * nx[a1];
                zy = ny[p] - c * ny[a1];
                if (c > 0.0) {
                    t1 = l1 / c;
                }
                if (fabs(nx[a1] * ny[p] - ny[a1] * nx[p]) >= 1e-12) {
                    t2 = -sp / (zx * zx + zy * zy);
                }
            } else {
                zx = nx[p];
                zy = ny[p];
                t2 = -sp / (zx * zx + zy * zy);
            }
            t = t1 < t2 ? t1 : t2;
            if (t == INFINITY) {
                return 0;
            }
            if (t2 < INFINITY) {
                x += t * zx;
                y += t * zy;
            }
            l1 -= t * c;
            lp += t;
            if (t2 <= t1) {
                if (q == 0) {
                    double vt = ny[p] * vx - nx[p] * vy;
                    a1 = p;
                    l1 = lp;
                    q = 1;
                    x = vt * ny[p] + bnd[p] * nx[p];
                    y = bnd[p] * ny[p] - vt * nx[p];
                } else {
                    double det = nx[a1] * ny[p] - ny[a1] * nx[p];
                    a2 = p;
                    l2 = lp;
                    q = 2;
                    x = (bnd[a1] * ny[p] - ny[a1] * bnd[p]) / det;
                    y = (nx[a1] * bnd[p] - bnd[a1] * nx[p]) / det;
                }
                break;
            }
            a1 = -1;
            l1 = 0.0;
            q = 0;
        }
    }
}

/* _kernels._solve */
static int solve(double vx, double vy, const int32_t *work, int32_t m, const double *nx,
                 const double *ny, const double *bnd, double *rx, double *ry)
{
    double x, y, x0, y0;
    int r;
    int32_t a;
    if (solve_tol(vx, vy, work, m, nx, ny, bnd, 0.0, &x, &y)) {
        *rx = x;
        *ry = y;
        return 1;
    }
    if (!solve_tol(vx, vy, work, m, nx, ny, bnd, VF_FEAS_TOL, &x0, &y0)) {
        *rx = 0.0;
        *ry = 0.0;
        return 0;
    }
    x = x0;
    y = y0;
    for (r = 0; r < 8; r++) {
        double worst = 0.0;
        double g;
        int32_t wi = -1;
        for (a = 0; a < m; a++) {
            int32_t w = work[a];
            g = bnd[w] - (nx[w] * x + ny[w] * y);
            if (g > worst) {
                worst = g;
                wi = w;
            }
        }
        if (wi < 0) {
            *rx = x;
            *ry = y;
            return 1;
        }
        g = worst + VF_REPAIR_ULPS * (1.0 + fabs(bnd[wi]) + fabs(x) + fabs(y));
        x += g * nx[wi];
        y += g * ny[wi];
    }
    /* the repairs fight: no point meets every bound as evaluated; the caller relaxes and says so */
    *rx = 0.0;
    *ry = 0.0;
    return 0;
}

/* _kernels.exact_kernel (with exact_bounds inlined) */
void vf_exact_kernel(const vf_polygon *poly, const vf_exact_law *law, double px, double py,
                     double vx, double vy, vf_scratch *scratch, vf_result *out)
{
    const double *nx = poly->nx;
    const double *ny = poly->ny;
    const double *off = poly->off;
    const int32_t n = poly->n;
    const int32_t kind = law->kind;
    const double *prm = law->prm;
    const int relax = law->relax != 0;
    const double idt = law->idt;
    double *dist = scratch->dist;
    double *bnd = scratch->bnd;
    int32_t *work = scratch->work;
    bounds_out bo;
    double big, vnorm, ux, uy, ox, oy, unit, scale;
    int32_t e, m, zone, stages, r, a;
    /* _kernels.exact_bounds */
    for (e = 0; e < n; e++) {
        dist[e] = nx[e] * px + ny[e] * py - off[e];
    }
    big = fabs(vx) > fabs(vy) ? fabs(vx) : fabs(vy);
    vnorm = 0.0;
    if (big > 0.0) {
        double qx = vx / big;
        double qy = vy / big;
        vnorm = big * sqrt(qx * qx + qy * qy);
    }
    bounds_from_distances(dist, n, vnorm, kind, prm, relax, idt, 1, bnd, work, &bo);
    m = bo.m;
    if (m == 0) {
        set_result(out, vx, vy, VF_ZONE_FREE, bo.p1, bo.p2, bo.d1, bo.d2, 0.0, 0.0, 0);
        return;
    }
    zone = zone_code(bo.n_out, bo.n_near);
    stages = bo.n_near > 0 ? VF_STAGE_PROJECT : 0;
    if (bo.n_out > 0) {
        stages |= VF_STAGE_SPRING;
    }
    unit = bo.cs;
    scale = bo.scale;
    ux = vx / scale;
    uy = vy / scale;
    for (;;) {
        int32_t a;
        int added;
        if (!solve(ux, uy, work, m, nx, ny, bnd, &ox, &oy)) {
            break;
        }
        if (bo.n_out == 0 || ox * ox + oy * oy <= unit * unit) {
            set_result(out, ox * scale, oy * scale, zone, bo.p1, bo.p2, bo.d1, bo.d2, 0.0, 0.0,
                       stages);
            return;
        }
        added = 0;
        for (e = 0; e < n && m < n; e++) {
            if (dist[e] >= 0.0 && nx[e] * ox + ny[e] * oy < -0.5 * unit) {
                double b;
                work[m] = e;
                fill_bounds(kind, prm, relax, dist, work, m, m + 1, unit, scale, idt, bnd);
                b = bnd[e];
                if (b > -INFINITY && violates(ox, oy, nx[e], ny[e], b, 0.0)) {
                    int known = 0;
                    for (a = 0; a < m; a++) {
                        if (work[a] == e) {
                            known = 1;
                            break;
                        }
                    }
                    if (!known) {
                        m += 1;
                        added = 1;
                    }
                }
            }
        }
        if (!added) {
            set_result(out, ox * scale, oy * scale, zone, bo.p1, bo.p2, bo.d1, bo.d2, 0.0, 0.0,
                       stages);
            return;
        }
    }
    if (bo.n_out > 0) {
        /* _kernels.RELAX_STEPS: the outside edges' recovery bounds times 1/4, ..., 4^-8, then 0;
         * every bound of an edge the point is inside kept. */
        for (r = 0; r < VF_RELAX_STEPS; r++) {
            for (a = 0; a < m; a++) {
                e = work[a];
                if (dist[e] < 0.0 && bnd[e] > 0.0) {
                    bnd[e] = r + 1 < VF_RELAX_STEPS ? bnd[e] * 0.25 : 0.0;
                }
            }
            if (solve(ux, uy, work, m, nx, ny, bnd, &ox, &oy)) {
                set_result(out, ox * scale, oy * scale, zone, bo.p1, bo.p2, bo.d1, bo.d2, 0.0,
                           0.0, stages | VF_STAGE_RELAXED);
                return;
            }
        }
    }
    set_result(out, 0.0, 0.0, zone, bo.p1, bo.p2, bo.d1, bo.d2, 0.0, 0.0,
               stages | VF_STAGE_STOP | (bo.n_out > 0 ? VF_STAGE_RELAXED : 0));
}

/* ------------------------------------------------------------------ checked API */

/* Every double of a result finite. A position beyond ~1e300 makes the signed distances
 * n.p - off overflow to +-inf while the velocity (recovery at a capped speed) stays finite: the
 * answer overflowed all the same, and is refused (VF_ERR_OVERFLOW, the stop result). */
static int result_finite(const vf_result *r)
{
    return isfinite(r->ox) && isfinite(r->oy) && isfinite(r->d1) && isfinite(r->d2)
           && isfinite(r->sx) && isfinite(r->sy);
}

static int finite4(double a, double b, double c, double d)
{
    return isfinite(a) && isfinite(b) && isfinite(c) && isfinite(d);
}

static int check_polygon(const vf_polygon *poly, int need_beta)
{
    int32_t e;
    if (poly->nx == NULL || poly->ny == NULL || poly->off == NULL) {
        return VF_ERR_NULL;
    }
    if (poly->n < 3 || !isfinite(poly->cx) || !isfinite(poly->cy)) {
        return VF_ERR_ARGUMENT;
    }
    for (e = 0; e < poly->n; e++) {
        if (!isfinite(poly->nx[e]) || !isfinite(poly->ny[e]) || !isfinite(poly->off[e])) {
            return VF_ERR_ARGUMENT;
        }
    }
    if (need_beta) {
        if (poly->beta == NULL) {
            return VF_ERR_NULL;
        }
        if (!isfinite(poly->a0)) {
            return VF_ERR_ARGUMENT;
        }
        for (e = 0; e <= poly->n; e++) {
            if (!isfinite(poly->beta[e]) || (e > 0 && !(poly->beta[e] >= poly->beta[e - 1]))) {
                return VF_ERR_ARGUMENT;
            }
        }
    }
    return VF_OK;
}

int vf_exact_check(const vf_polygon *poly, const vf_exact_law *law)
{
    int rc;
    int i;
    if (poly == NULL || law == NULL) {
        return VF_ERR_NULL;
    }
    rc = check_polygon(poly, 0);
    if (rc != VF_OK) {
        return rc;
    }
    if (!(law->idt >= 0.0) || !isfinite(law->idt)) {
        return VF_ERR_ARGUMENT;
    }
    for (i = 0; i < VF_PROFILE_PARAMS; i++) {
        if (isnan(law->prm[i])) {
            return VF_ERR_ARGUMENT;
        }
    }
    if (law->kind == VF_PROFILE_LINEAR) {
        /* d_max > 0 (may be +inf), k >= 0, r_max >= 0 */
        if (!(law->prm[0] > 0.0) || !(law->prm[1] >= 0.0) || !(law->prm[2] >= 0.0)) {
            return VF_ERR_ARGUMENT;
        }
    } else if (law->kind == VF_PROFILE_THREE_ZONE) {
        for (i = 0; i < VF_PROFILE_PARAMS; i++) {
            if (!isfinite(law->prm[i]) || law->prm[i] < 0.0) {
                return VF_ERR_ARGUMENT;
            }
        }
    } else {
        return VF_ERR_ARGUMENT;
    }
    return VF_OK;
}

int vf_patent_check(const vf_polygon *poly, const vf_patent_law *law)
{
    int rc;
    if (poly == NULL || law == NULL) {
        return VF_ERR_NULL;
    }
    rc = check_polygon(poly, 1);
    if (rc != VF_OK) {
        return rc;
    }
    if (!(law->dmax > 0.0) || !(law->k >= 0.0) || !isfinite(law->k)
        || !(law->theta_max > 0.0) || !(law->theta_max < 3.141592653589793)
        || !(law->idt >= 0.0) || !isfinite(law->idt) || isnan(law->dmax)) {
        return VF_ERR_ARGUMENT;
    }
    return VF_OK;
}

int vf_exact_shape(const vf_polygon *poly, const vf_exact_law *law, double px, double py,
                   double vx, double vy, vf_scratch *scratch, vf_result *out)
{
    if (out == NULL) {
        return VF_ERR_NULL;
    }
    if (poly == NULL || law == NULL || scratch == NULL || scratch->dist == NULL
        || scratch->bnd == NULL || scratch->work == NULL || poly->nx == NULL
        || poly->ny == NULL || poly->off == NULL) {
        set_stop(out);
        return VF_ERR_NULL;
    }
    if (!finite4(px, py, vx, vy)) {
        set_stop(out);
        return VF_ERR_NONFINITE;
    }
    vf_exact_kernel(poly, law, px, py, vx, vy, scratch, out);
    if (!result_finite(out)) {
        set_stop(out);
        return VF_ERR_OVERFLOW;
    }
    return VF_OK;
}

int vf_patent_shape(const vf_polygon *poly, const vf_patent_law *law, double px, double py,
                    double vx, double vy, vf_result *out)
{
    if (out == NULL) {
        return VF_ERR_NULL;
    }
    if (poly == NULL || law == NULL || poly->nx == NULL || poly->ny == NULL
        || poly->off == NULL || poly->beta == NULL) {
        set_stop(out);
        return VF_ERR_NULL;
    }
    if (!finite4(px, py, vx, vy)) {
        set_stop(out);
        return VF_ERR_NONFINITE;
    }
    vf_patent_kernel(poly, law, px, py, vx, vy, out);
    if (!result_finite(out)) {
        set_stop(out);
        return VF_ERR_OVERFLOW;
    }
    return VF_OK;
}

int64_t vf_exact_batch(const vf_polygon *poly, const vf_exact_law *law, const double *P,
                       const double *V, size_t N, double *out, int64_t *zones,
                       vf_scratch *scratch)
{
    size_t r;
    int64_t bad = 0;
    vf_result res;
    if (poly == NULL || law == NULL || scratch == NULL || (N > 0 && (P == NULL || V == NULL
        || out == NULL))) {
        return VF_ERR_NULL;
    }
    for (r = 0; r < N; r++) {
        int rc = vf_exact_shape(poly, law, P[2 * r], P[2 * r + 1], V[2 * r], V[2 * r + 1],
                                scratch, &res);
        if (rc == VF_ERR_NULL) {
            return rc;
        }
        if (rc != VF_OK) {
            bad += 1;
        }
        out[2 * r] = res.ox;
        out[2 * r + 1] = res.oy;
        if (zones != NULL) {
            zones[r] = res.zone;
        }
    }
    return bad;
}

int64_t vf_patent_batch(const vf_polygon *poly, const vf_patent_law *law, const double *P,
                        const double *V, size_t N, double *out, int64_t *zones)
{
    size_t r;
    int64_t bad = 0;
    vf_result res;
    if (poly == NULL || law == NULL || (N > 0 && (P == NULL || V == NULL || out == NULL))) {
        return VF_ERR_NULL;
    }
    for (r = 0; r < N; r++) {
        int rc = vf_patent_shape(poly, law, P[2 * r], P[2 * r + 1], V[2 * r], V[2 * r + 1], &res);
        if (rc == VF_ERR_NULL) {
            return rc;
        }
        if (rc != VF_OK) {
            bad += 1;
        }
        out[2 * r] = res.ox;
        out[2 * r + 1] = res.oy;
        if (zones != NULL) {
            zones[r] = res.zone;
        }
    }
    return bad;
}
