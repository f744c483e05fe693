/*
 * velfence_filter.c -- the safety filter's whole cycle (see include/velfence_filter.h).
 *
 * The rows' bounds come from vf_nd_rate_bounds (the exact law's one bound definition,
 * vf_bounds.h), the obstacle rows from vf_nd_capsule_rows, the solve from vf_nd_project_kernel:
 * this file adds the chain-as-data kinematics, the workspace rows of a named point, the ladder,
 * the model check and the deadline fallback (velfence.filter's, spec-24 section 3).
 */
#define _POSIX_C_SOURCE 200809L /* sysconf, POSIX threads (the batch) */
#include "velfence_filter.h"

#include <math.h>
#include <string.h>
#ifndef _WIN32
#include <pthread.h>
#include <unistd.h>
#endif
#ifdef VF_FILTER_DEBUG
#include <stdio.h>
#endif

#include "vf_rows.h" /* the row arithmetic shared with vf_nd_filter_rows */
#include "vf_util.h" /* vf_finite_all, vf_dot */

#define MAX_JOINTS 64
#define MAX_MAG 1e150
#define COMMAND_CAP 1e3
#define BINDING 1e-9
#define ROUNDS 4
#define ORTHO_TOL 1e-9

/* ------------------------------------------------------------------ kinematics */

/* C = A B for 3 x 4 [R | p] transforms (C may not alias). */
static void compose(const double *A, const double *B, double *C)
{
    int r, c;
    for (r = 0; r < 3; r++) {
        for (c = 0; c < 3; c++) {
            C[4 * r + c] = A[4 * r] * B[c] + A[4 * r + 1] * B[4 + c] + A[4 * r + 2] * B[8 + c];
        }
        C[4 * r + 3] = A[4 * r] * B[3] + A[4 * r + 1] * B[7] + A[4 * r + 2] * B[11] + A[4 * r + 3];
    }
}

void vf_filter_kinematics(const vf_filter *f, const double *q, double *P, double *axes,
                          double *frames)
{
    const int32_t n = f->n;
    double A[12];
    int32_t j;
    int r;
    static const double I[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    memcpy(frames, I, sizeof I);
    for (j = 0; j < n; j++) {
        const vf_filter_joint *jt = f->joints + j;
        const double *a = jt->axis;
        double *F = frames + 12 * (size_t)(j + 1);
        double th = q[j] + jt->offset;
        double z[3];
        compose(frames + 12 * (size_t)j, jt->T, A);
        for (r = 0; r < 3; r++) {
            z[r] = A[4 * r] * a[0] + A[4 * r + 1] * a[1] + A[4 * r + 2] * a[2];
            P[3 * j + r] = A[4 * r + 3];
            axes[3 * j + r] = z[r];
        }
        if (jt->type == VF_FILTER_PRISMATIC) {
            memcpy(F, A, sizeof A);
            for (r = 0; r < 3; r++) {
                F[4 * r + 3] += z[r] * th;
            }
        } else if (a[0] == 0.0 && a[1] == 0.0 && a[2] == 1.0) {
            /* the common case (DH, most URDF / MJCF joints): F = A Rz(th) */
            double c = cos(th), s = sin(th);
            for (r = 0; r < 3; r++) {
                const double x0 = A[4 * r], y0 = A[4 * r + 1];
                F[4 * r] = c * x0 + s * y0;
                F[4 * r + 1] = c * y0 - s * x0;
                F[4 * r + 2] = A[4 * r + 2];
                F[4 * r + 3] = A[4 * r + 3];
            }
        } else {
            double c = cos(th), s = sin(th), v = 1.0 - c;
            double M[12];
            M[0] = c + v * a[0] * a[0];
            M[1] = v * a[0] * a[1] - s * a[2];
            M[2] = v * a[0] * a[2] + s * a[1];
            M[4] = v * a[1] * a[0] + s * a[2];
            M[5] = c + v * a[1] * a[1];
            M[6] = v * a[1] * a[2] - s * a[0];
            M[8] = v * a[2] * a[0] - s * a[1];
            M[9] = v * a[2] * a[1] + s * a[0];
            M[10] = c + v * a[2] * a[2];
            M[3] = M[7] = M[11] = 0.0;
            compose(A, M, F);
        }
    }
    compose(frames + 12 * (size_t)n, f->tool, frames + 12 * (size_t)(n + 1));
    for (r = 0; r < 3; r++) {
        P[3 * n + r] = frames[12 * (size_t)(n + 1) + 4 * r + 3];
    }
}

/* A named point's position p (3,) and the number of joints moving it. */
static int32_t point_at(const vf_filter *f, const vf_filter_point *pt, const double *frames,
                        double *p)
{
    const double *F = frames + 12 * (size_t)(pt->link + 1);
    int r;
    for (r = 0; r < 3; r++) {
        p[r] = F[4 * r] * pt->offset[0] + F[4 * r + 1] * pt->offset[1]
               + F[4 * r + 2] * pt->offset[2] + F[4 * r + 3];
    }
    return pt->link >= f->n ? f->n : pt->link + 1;
}

/* ------------------------------------------------------------------ self-collision */

static double clamp01(double x)
{
    return x <= 0.0 ? 0.0 : (x >= 1.0 ? 1.0 : x);
}

static double point_seg_t(const double *p, const double *a, const double *b)
{
    const double dx = b[0] - a[0], dy = b[1] - a[1], dz = b[2] - a[2];
    const double dd = dx * dx + dy * dy + dz * dz;
    if (dd == 0.0) {
        return 0.0;
    }
    return clamp01(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy + (p[2] - a[2]) * dz) / dd);
}

/* primitives._segments_st, operation for operation */
static void seg_params(const double *a0, const double *a1, const double *b0, const double *b1,
                       double *ps, double *pt)
{
    const double d1[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]};
    const double d2[3] = {b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]};
    const double r[3] = {a0[0] - b0[0], a0[1] - b0[1], a0[2] - b0[2]};
    const double a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
    const double e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
    double b, cc, f, cx, cy, cz, denom, s, t;
    if (a == 0.0) {
        *ps = 0.0;
        *pt = point_seg_t(a0, b0, b1);
        return;
    }
    if (e == 0.0) {
        *ps = point_seg_t(b0, a0, a1);
        *pt = 0.0;
        return;
    }
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
    cc = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
    cx = d1[1] * d2[2] - d1[2] * d2[1];
    cy = d1[2] * d2[0] - d1[0] * d2[2];
    cz = d1[0] * d2[1] - d1[1] * d2[0];
    denom = cx * cx + cy * cy + cz * cz;
    if (denom > 1e-16 * a * e) {
        s = clamp01((b * f - cc * e) / denom);
    } else {
        /* parallel: the middle of the overlap of B's shadow on A, else A's end nearest B */
        double u0 = -cc / a, u1 = (b - cc) / a, lo, hi;
        lo = u0 <= u1 ? u0 : u1;
        hi = u0 <= u1 ? u1 : u0;
        lo = lo > 0.0 ? lo : 0.0;
        hi = hi < 1.0 ? hi : 1.0;
        if (lo <= hi) {
            s = 0.5 * (lo + hi);
            *ps = s;
            *pt = clamp01((b * s + f) / e);
            return;
        }
        s = hi < 0.0 ? 0.0 : 1.0;
    }
    t = (b * s + f) / e;
    if (t < 0.0) {
        *ps = clamp01(-cc / a);
        *pt = 0.0;
    } else if (t > 1.0) {
        *ps = clamp01((b - cc) / a);
        *pt = 1.0;
    } else {
        *ps = s;
        *pt = t;
    }
}

static void lerp3(const double *a, const double *b, double t, double *x)
{
    int c;
    for (c = 0; c < 3; c++) {
        x[c] = t <= 0.5 ? a[c] + t * (b[c] - a[c]) : b[c] - (1.0 - t) * (b[c] - a[c]);
    }
}

double vf_segment_pair(const double *a0, const double *a1, const double *b0, const double *b1,
                       double *s, double *t, double *pa, double *pb, double *nrm)
{
    double xa[3], xb[3], r[3], dist, ss, tt;
    seg_params(a0, a1, b0, b1, &ss, &tt);
    lerp3(a0, a1, ss, xa);
    lerp3(b0, b1, tt, xb);
    r[0] = xa[0] - xb[0];
    r[1] = xa[1] - xb[1];
    r[2] = xa[2] - xb[2];
    dist = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (s != NULL) {
        *s = ss;
    }
    if (t != NULL) {
        *t = tt;
    }
    if (pa != NULL) {
        memcpy(pa, xa, sizeof xa);
    }
    if (pb != NULL) {
        memcpy(pb, xb, sizeof xb);
    }
    if (nrm != NULL) {
        if (dist > 0.0) {
            nrm[0] = r[0] / dist;
            nrm[1] = r[1] / dist;
            nrm[2] = r[2] / dist;
        } else {
            const double da[3] = {a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2]};
            const double db[3] = {b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2]};
            const double cx = da[1] * db[2] - da[2] * db[1];
            const double cy = da[2] * db[0] - da[0] * db[2];
            const double cz = da[0] * db[1] - da[1] * db[0];
            const double h = sqrt(cx * cx + cy * cy + cz * cz);
            if (h > 0.0) {
                nrm[0] = cx / h;
                nrm[1] = cy / h;
                nrm[2] = cz / h;
            } else {
                const double hh = hypot(da[0], da[1]);
                nrm[0] = hh == 0.0 ? 1.0 : -da[1] / hh;
                nrm[1] = hh == 0.0 ? 0.0 : da[0] / hh;
                nrm[2] = 0.0;
            }
        }
    }
    return dist;
}

double vf_self_row(int32_t n, const double *P, const double *axes, int32_t i, int32_t j,
                   double ri, double rj, const double *u, double *g, double *speed)
{
    /* Joints 0 .. i move both closest points as one rigid body: their columns of J_a - J_b are
     * z_k x (pa - pb), normal to nrm (parallel to pa - pb), so their g is 0 and their part of
     * the relative velocity is (sum u_k z_k) x (pa - pb). Joints i < k <= j move pb only. */
    const double *a = P + 3 * (size_t)i, *e = P + 3 * (size_t)j;
    double xa[3], xb[3], nr[3], r[3], w[3] = {0.0, 0.0, 0.0}, v[3], dist;
    int32_t k;
    dist = vf_segment_pair(a, a + 3, e, e + 3, NULL, NULL, xa, xb, nr);
    r[0] = xa[0] - xb[0];
    r[1] = xa[1] - xb[1];
    r[2] = xa[2] - xb[2];
    for (k = 0; k <= i; k++) {
        const double *z = axes + 3 * (size_t)k;
        w[0] += u[k] * z[0];
        w[1] += u[k] * z[1];
        w[2] += u[k] * z[2];
        g[k] = 0.0;
    }
    v[0] = w[1] * r[2] - w[2] * r[1];
    v[1] = w[2] * r[0] - w[0] * r[2];
    v[2] = w[0] * r[1] - w[1] * r[0];
    for (k = i + 1; k < n; k++) {
        const double *z = axes + 3 * (size_t)k;
        const double *pk = P + 3 * (size_t)k;
        double dx, dy, dz, jx, jy, jz;
        if (k > j) {
            g[k] = 0.0;
            continue;
        }
        dx = xb[0] - pk[0];
        dy = xb[1] - pk[1];
        dz = xb[2] - pk[2];
        jx = z[1] * dz - z[2] * dy;
        jy = z[2] * dx - z[0] * dz;
        jz = z[0] * dy - z[1] * dx;
        g[k] = -(nr[0] * jx + nr[1] * jy + nr[2] * jz);
        v[0] -= jx * u[k];
        v[1] -= jy * u[k];
        v[2] -= jz * u[k];
    }
    *speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return dist - ri - rj;
}

/* The pair's clearance only (the model check). */
static double self_clearance(const vf_filter *f, const double *P, int32_t i, int32_t j)
{
    const double *a = P + 3 * (size_t)i, *e = P + 3 * (size_t)j;
    const double ri = f->link_radius != NULL ? f->link_radius[i] : 0.0;
    const double rj = f->link_radius != NULL ? f->link_radius[j] : 0.0;
    return vf_segment_pair(a, a + 3, e, e + 3, NULL, NULL, NULL, NULL, NULL) - ri - rj;
}

/* ------------------------------------------------------------------ checks and sizes */

static int rigid(const double *T)
{
    int a, b, c;
    if (!vf_finite_all(T, 12)) {
        return 0;
    }
    for (a = 0; a < 3; a++) {
        for (b = 0; b < 3; b++) {
            double s = 0.0;
            for (c = 0; c < 3; c++) {
                s += T[4 * c + a] * T[4 * c + b];
            }
            if (fabs(s - (a == b ? 1.0 : 0.0)) > ORTHO_TOL) {
                return 0;
            }
        }
    }
    /* a rotation, not a reflection */
    return T[0] * (T[5] * T[10] - T[6] * T[9]) - T[1] * (T[4] * T[10] - T[6] * T[8])
               + T[2] * (T[4] * T[9] - T[5] * T[8])
           > 0.0;
}

static int profile_ok(int32_t kind, const double *prm)
{
    if (!vf_finite_all(prm, VF_ND_PROFILE_PARAMS)) {
        return 0;
    }
    if (kind == VF_ND_PROFILE_LINEAR) {
        return prm[0] > 0.0 && prm[1] >= 0.0 && prm[2] >= 0.0;
    }
    if (kind == VF_ND_PROFILE_THREE_ZONE) {
        return prm[0] > 0.0 && prm[1] > 0.0 && prm[2] > 0.0 && prm[3] >= 0.0 && prm[4] >= 0.0
               && prm[5] >= prm[3];
    }
    return 0;
}

int vf_filter_check(const vf_filter *f)
{
    int32_t j, i, w;
    if (f == NULL) {
        return VF_ERR_NULL;
    }
    if (f->n < 1 || f->n > MAX_JOINTS || f->npoints < 0 || f->nw < 0 || f->k < 0) {
        return VF_ERR_ARGUMENT;
    }
    if (f->joints == NULL || f->lower == NULL || f->upper == NULL || f->vmax == NULL
        || f->jkind == NULL || f->jprm == NULL || (f->npoints > 0 && f->points == NULL)
        || (f->nw > 0 && f->ws == NULL)
        || (f->k > 0 && (f->centres == NULL || f->radii == NULL))) {
        return VF_ERR_NULL;
    }
    if (!rigid(f->tool)) {
        return VF_ERR_ARGUMENT;
    }
    for (j = 0; j < f->n; j++) {
        const vf_filter_joint *jt = f->joints + j;
        double an;
        if (!rigid(jt->T) || !vf_finite_all(jt->axis, 3) || !isfinite(jt->offset)
            || (jt->type != VF_FILTER_REVOLUTE && jt->type != VF_FILTER_PRISMATIC)) {
            return VF_ERR_ARGUMENT;
        }
        an = sqrt(jt->axis[0] * jt->axis[0] + jt->axis[1] * jt->axis[1]
                  + jt->axis[2] * jt->axis[2]);
        if (fabs(an - 1.0) > ORTHO_TOL) {
            return VF_ERR_ARGUMENT;
        }
        if (f->k > 0 && jt->type != VF_FILTER_REVOLUTE) {
            return VF_ERR_ARGUMENT; /* capsule rows: revolute Jacobians only */
        }
        if (isnan(f->lower[j]) || isnan(f->upper[j]) || !(f->lower[j] <= f->upper[j])
            || f->lower[j] == INFINITY || f->upper[j] == -INFINITY) {
            return VF_ERR_ARGUMENT;
        }
        if (!(isfinite(f->vmax[j]) && f->vmax[j] > 0.0)) {
            return VF_ERR_ARGUMENT;
        }
        if (f->jmax != NULL && !(f->jmax[j] > 0.0)) {
            return VF_ERR_ARGUMENT;
        }
        if (f->amax != NULL && !(f->amax[j] > 0.0)) {
            return VF_ERR_ARGUMENT; /* NaN, 0 or negative (inf: none) */
        }
        if (!profile_ok(f->jkind[j], f->jprm + (size_t)VF_ND_PROFILE_PARAMS * j)) {
            return VF_ERR_ARGUMENT;
        }
        if (f->link_radius != NULL && !(isfinite(f->link_radius[j]) && f->link_radius[j] >= 0.0)) {
            return VF_ERR_ARGUMENT;
        }
        if (f->weights != NULL && !(isfinite(f->weights[j]) && f->weights[j] > 0.0)) {
            return VF_ERR_ARGUMENT;
        }
    }
    for (i = 0; i < f->npoints; i++) {
        if (f->points[i].link < -1 || f->points[i].link > f->n
            || !vf_finite_all(f->points[i].offset, 3)) {
            return VF_ERR_ARGUMENT;
        }
    }
    for (w = 0; w < f->nw; w++) {
        const vf_filter_polytope *p = f->ws + w;
        if (p->N == NULL || p->off == NULL) {
            return VF_ERR_NULL;
        }
        if (p->point < 0 || p->point >= f->npoints || p->nf < 1 || p->nf > (1 << 20)
            || !profile_ok(p->kind, p->prm) || !vf_finite_all(p->N, 3 * (size_t)p->nf)
            || !vf_finite_all(p->off, (size_t)p->nf)) {
            return VF_ERR_ARGUMENT;
        }
        for (i = 0; i < p->nf; i++) {
            const double *nn = p->N + 3 * (size_t)i;
            if (fabs(sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]) - 1.0) > 1e-6) {
                return VF_ERR_ARGUMENT;
            }
        }
    }
    if (f->k > (1 << 20)) {
        return VF_ERR_ARGUMENT;
    }
    if (f->nattach < 0 || f->nattach > 1024 || (f->nattach > 0 && f->attach == NULL)) {
        return f->nattach > 0 && f->attach == NULL ? VF_ERR_NULL : VF_ERR_ARGUMENT;
    }
    for (i = 0; i < f->nattach; i++) {
        const vf_filter_attachment *at = f->attach + i;
        if (at->link < -1 || at->link > f->n || !vf_finite_all(at->a, 3)
            || !vf_finite_all(at->b, 3) || !(isfinite(at->radius) && at->radius >= 0.0)) {
            return VF_ERR_ARGUMENT;
        }
    }
    if (f->npairs < 0 || f->npairs > f->n * f->n) {
        return VF_ERR_ARGUMENT;
    }
    if (f->npairs > 0 && f->pairs == NULL) {
        return VF_ERR_NULL;
    }
    for (i = 0; i < f->npairs; i++) {
        const int32_t a = f->pairs[2 * (size_t)i], b = f->pairs[2 * (size_t)i + 1];
        if (a < 0 || b <= a || b >= f->n) {
            return VF_ERR_ARGUMENT;
        }
    }
    for (j = 0; j < f->n && f->npairs > 0; j++) {
        if (f->joints[j].type != VF_FILTER_REVOLUTE) {
            return VF_ERR_ARGUMENT; /* capsule rows: revolute Jacobians only */
        }
    }
    for (i = 0; i < f->k; i++) {
        if (!vf_finite_all(f->centres + 3 * (size_t)i, 3) || !isfinite(f->radii[i])
            || f->radii[i] < 0.0) {
            return VF_ERR_ARGUMENT;
        }
    }
    if (!(isfinite(f->obstacle_buffer) && f->obstacle_buffer > 0.0)
        || !(isfinite(f->spring_gain) && f->spring_gain >= 0.0)
        || !(f->dt >= 0.0 && f->dt <= MAX_MAG)) {
        return VF_ERR_ARGUMENT;
    }
    return VF_OK;
}

static size_t max_nf(const vf_filter *f)
{
    size_t nf = 1;
    int32_t w;
    for (w = 0; w < f->nw; w++) {
        if ((size_t)f->ws[w].nf > nf) {
            nf = (size_t)f->ws[w].nf;
        }
    }
    return nf;
}

size_t vf_filter_rows_max(const vf_filter *f)
{
    size_t rows, na;
    int32_t w;
    if (f == NULL || f->n < 1 || f->n > MAX_JOINTS || f->nw < 0 || f->k < 0
        || (f->nw > 0 && f->ws == NULL)) {
        return 0;
    }
    na = f->nattach > 0 ? (size_t)f->nattach : 0;
    rows = 8 * (size_t)f->n + (size_t)f->k * ((size_t)f->n + na)
           + (f->npairs > 0 ? (size_t)f->npairs : 0);
    for (w = 0; w < f->nw; w++) {
        rows += f->ws[w].nf > 0 ? (size_t)f->ws[w].nf * (1 + 2 * na) : 0;
    }
    return rows;
}

/* The scratch layout (doubles, then int32). */
typedef struct layout {
    size_t M, n;
    /* doubles */
    size_t frames, P, axes, frames1, P1, axes1, q1, G, Gs, b, dist, slack, cur, bb, bt, used, us, ys,
        x, x1, xc, xt, ucmd, zeros, lam, wsf, capw, clear, wsd, wsb, wsJ, reach, offr, attw, total;
    /* ints */
    size_t level, ka, kb, active, relaxed, slot, act, warm, ri, itotal;
} layout;

static void make_layout(const vf_filter *f, layout *L)
{
    const size_t n = (size_t)f->n;
    const size_t M = vf_filter_rows_max(f);
    const size_t K = (size_t)f->k * (n + (f->nattach > 0 ? (size_t)f->nattach : 0));
    const size_t nf = max_nf(f);
    size_t o = 0, io = 0;
    L->M = M;
    L->n = n;
#define TAKE(field, count) (L->field = o, o += (count))
#define ITAKE(field, count) (L->field = io, io += (count))
    TAKE(frames, 12 * (n + 2));
    TAKE(P, 3 * (n + 1));
    TAKE(axes, 3 * n);
    TAKE(frames1, 12 * (n + 2));
    TAKE(P1, 3 * (n + 1));
    TAKE(axes1, 3 * n);
    TAKE(q1, n);
    TAKE(G, M * n);
    TAKE(Gs, M * n); /* the rows in the metric's coordinates (weights or a full factor) */
    TAKE(b, M);
    TAKE(dist, M);
    TAKE(slack, M);
    TAKE(cur, M);
    TAKE(bb, M);
    TAKE(bt, M);
    TAKE(used, M);
    TAKE(us, n);
    TAKE(ys, n);
    TAKE(x, n);
    TAKE(x1, n);
    TAKE(xc, n);
    TAKE(xt, n);
    TAKE(ucmd, n);
    TAKE(zeros, n);
    TAKE(lam, n + 1);
    TAKE(wsf, vf_nd_project_doubles((int32_t)M, (int32_t)n));
    TAKE(capw, K + n);
    TAKE(clear, K + 1);
    TAKE(wsd, nf);
    TAKE(wsb, nf);
    TAKE(wsJ, 3 * n);
    TAKE(reach, n);
    TAKE(offr, nf);
    TAKE(attw, 6 * (f->nattach > 0 ? (size_t)f->nattach : 0) + 1);
    L->total = o;
    ITAKE(level, M);
    ITAKE(ka, M);
    ITAKE(kb, M);
    ITAKE(active, M);
    ITAKE(relaxed, M);
    ITAKE(slot, M);
    ITAKE(act, n + 1);
    ITAKE(warm, M + 1);
    ITAKE(ri, 2 * nf + 2);
    L->itotal = io;
#undef TAKE
#undef ITAKE
}

size_t vf_filter_doubles(const vf_filter *f)
{
    layout L;
    if (vf_filter_check(f) != VF_OK) {
        return 0;
    }
    make_layout(f, &L);
    return L.total;
}

size_t vf_filter_ints(const vf_filter *f)
{
    layout L;
    if (vf_filter_check(f) != VF_OK) {
        return 0;
    }
    make_layout(f, &L);
    return L.itotal;
}

void vf_filter_obstacle_profile(const vf_filter *f, int32_t *kind, double *prm)
{
    int i;
    *kind = VF_ND_PROFILE_LINEAR;
    for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
        prm[i] = 0.0;
    }
    prm[0] = f->obstacle_buffer;
    prm[1] = f->spring_gain;
    prm[2] = f->spring_gain * f->obstacle_buffer; /* LinearBuffer's default recovery cap */
}

/* ------------------------------------------------------------------ the cycle's state */

typedef struct ctx {
    const vf_filter *f;
    layout L;
    double *d;
    int32_t *i;
    int32_t m, n;
    double idt;
    const double *q;
    const double *u; /* the (capped) command */
    double unorm;    /* |u|_inf */
    double deadline; /* absolute, inf: none */
    int32_t maxit;
    int32_t n_warm;  /* warm rows mapped, for the first solve */
    const double *answer; /* the answering rung's bounds (before the model check's raises) */
    const double *factor; /* the full metric's factor L (n x n row-major, lower), or NULL */
    int first;
    int has_check;   /* dt > 0 and some workspace / obstacle row */
    vf_filter_info *info;
} ctx;

#define D(c, field) ((c)->d + (c)->L.field)
#define IV(c, field) ((c)->i + (c)->L.field)


/* Attachment at's axis ends in the base frame (A, B) at the frames; the joints moving it. */
static int32_t attach_axis(const vf_filter *f, const vf_filter_attachment *at,
                           const double *frames, double *A, double *B)
{
    vf_filter_point pt;
    pt.link = at->link;
    memcpy(pt.offset, at->a, sizeof pt.offset);
    point_at(f, &pt, frames, A);
    memcpy(pt.offset, at->b, sizeof pt.offset);
    return point_at(f, &pt, frames, B);
}

/* The Jacobian of the point p moved by joints 0 .. k-1 (column j at J + 3 j) and its speed
 * under u. */
static double point_jac(const vf_filter *f, const double *P, const double *axes, const double *p,
                        int32_t k, const double *u, double *J)
{
    double vx = 0.0, vy = 0.0, vz = 0.0;
    int32_t j;
    for (j = 0; j < k; j++) {
        const double *z = axes + 3 * (size_t)j;
        double *col = J + 3 * (size_t)j;
        if (f->joints[j].type == VF_FILTER_PRISMATIC) {
            col[0] = z[0];
            col[1] = z[1];
            col[2] = z[2];
        } else {
            const double *pj = P + 3 * (size_t)j;
            const double dx = p[0] - pj[0], dy = p[1] - pj[1], dz = p[2] - pj[2];
            col[0] = z[1] * dz - z[2] * dy;
            col[1] = z[2] * dx - z[0] * dz;
            col[2] = z[0] * dy - z[1] * dx;
        }
        vx += col[0] * u[j];
        vy += col[1] * u[j];
        vz += col[2] * u[j];
    }
    return sqrt(vx * vx + vy * vy + vz * vz);
}

/* The attachments' workspace rows of every polytope, from row r on. */
static int32_t attach_ws_rows(ctx *c, const vf_rows *o, int32_t r)
{
    const vf_filter *f = c->f;
    int32_t w, s, e, i, r0, k;
    double *A = D(c, attw);
    for (s = 0; s < f->nattach; s++) {
        attach_axis(f, f->attach + s, D(c, frames), A + 6 * (size_t)s, A + 6 * (size_t)s + 3);
    }
    for (w = 0; w < f->nw; w++) {
        const vf_filter_polytope *ws = f->ws + w;
        for (s = 0; s < f->nattach; s++) {
            const vf_filter_attachment *at = f->attach + s;
            const int32_t ends = memcmp(at->a, at->b, sizeof at->a) == 0 ? 1 : 2;
            k = at->link >= f->n ? f->n : at->link + 1;
            for (i = 0; i < ws->nf; i++) {
                D(c, offr)[i] = ws->off[i] + at->radius;
            }
            for (e = 0; e < ends; e++) {
                const double *p = A + 6 * (size_t)s + 3 * (size_t)e;
                const double sp = point_jac(f, D(c, P), D(c, axes), p, k, c->u, D(c, wsJ));
                r0 = r;
                r = vf_workspace_rows(o, r, w, ws->N, D(c, offr), ws->nf, ws->kind, ws->prm, p,
                                      D(c, wsJ), k, sp, c->idt, VF_FILTER_LEVEL_WORKSPACE,
                                      D(c, wsd), D(c, wsb), IV(c, ri));
                for (i = r0; i < r; i++) {
                    IV(c, kb)[i] += ws->nf + (2 * s + e) * ws->nf;
                }
            }
        }
    }
    return r;
}

/* Sphere obstacles against the attachments, from row r on (after the link rows). */
static int32_t attach_obstacle_rows(ctx *c, int32_t r)
{
    const vf_filter *f = c->f;
    const int32_t n = c->n;
    const double *P = D(c, P);
    const double *A = D(c, attw);
    int32_t i, s, j, kind;
    double prm[VF_ND_PROFILE_PARAMS], reach[1];
    vf_filter_obstacle_profile(f, &kind, prm);
    for (i = 0; i < f->k; i++) {
        const double *cc = f->centres + 3 * (size_t)i;
        for (s = 0; s < f->nattach; s++) {
            const vf_filter_attachment *at = f->attach + s;
            const double *a = A + 6 * (size_t)s, *e = a + 3;
            const int32_t k = at->link >= n ? n : at->link + 1;
            const double cl = vf_capsule_clearance(cc, a, e, f->radii[i], at->radius);
            double t, x[3], nr[3], dist, speed, bound;
            double *g = D(c, G) + (size_t)r * n;
            int32_t wk[2], m;
            reach[0] = 0.0;
            if (f->dt > 0.0) {
                for (j = 0; j < k; j++) {
                    const double *pj = P + 3 * (size_t)j;
                    const double ax = a[0] - pj[0], ay = a[1] - pj[1], az = a[2] - pj[2];
                    const double bx = e[0] - pj[0], by = e[1] - pj[1], bz = e[2] - pj[2];
                    const double ma = sqrt(ax * ax + ay * ay + az * az);
                    const double mb = sqrt(bx * bx + by * by + bz * bz);
                    reach[0] += (ma > mb ? ma : mb) * f->vmax[j];
                }
                reach[0] *= 1.5 * f->dt;
            }
            if (!(cl < f->obstacle_buffer || (f->dt > 0.0 && cl <= reach[0]))) {
                continue;
            }
            t = vf_seg_t(cc, a, e);
            for (m = 0; m < 3; m++) {
                x[m] = t <= 0.5 ? a[m] + t * (e[m] - a[m]) : e[m] - (1.0 - t) * (e[m] - a[m]);
                nr[m] = x[m] - cc[m];
            }
            dist = sqrt(nr[0] * nr[0] + nr[1] * nr[1] + nr[2] * nr[2]);
            if (dist > 0.0) {
                nr[0] /= dist;
                nr[1] /= dist;
                nr[2] /= dist;
            } else {
                const double hx = e[0] - a[0], hy = e[1] - a[1];
                const double h = hypot(hx, hy);
                nr[0] = h == 0.0 ? 1.0 : -hy / h;
                nr[1] = h == 0.0 ? 0.0 : hx / h;
                nr[2] = 0.0;
            }
            speed = point_jac(f, P, D(c, axes), x, k, c->u, D(c, wsJ));
            for (j = 0; j < n; j++) {
                const double *col = D(c, wsJ) + 3 * (size_t)j;
                g[j] = j < k ? nr[0] * col[0] + nr[1] * col[1] + nr[2] * col[2] : 0.0;
            }
            vf_nd_rate_bounds(kind, prm, &cl, 1, speed, c->idt, &bound, wk);
            if (bound == -INFINITY) {
                continue;
            }
            D(c, b)[r] = bound;
            D(c, dist)[r] = cl;
            IV(c, level)[r] = VF_FILTER_LEVEL_OBSTACLE;
            IV(c, ka)[r] = i;
            IV(c, kb)[r] = n + s;
            r += 1;
        }
    }
    return r;
}

/* The self-collision rows from row r on (the header's order); returns the next row. */
static int32_t self_rows(ctx *c, int32_t r)
{
    const vf_filter *f = c->f;
    const int32_t n = c->n;
    const double *P = D(c, P);
    double *reach = D(c, reach);
    int32_t p, l, j, kind;
    double prm[VF_ND_PROFILE_PARAMS];
    vf_filter_obstacle_profile(f, &kind, prm);
    if (f->dt > 0.0) {
        /* per link: 1.5 periods of its points' largest speed (SelfCollisionRows._reach) */
        for (l = 0; l < n; l++) {
            double s = 0.0;
            for (j = 0; j <= l; j++) {
                const double *pj = P + 3 * (size_t)j, *pa = P + 3 * (size_t)l, *pb = pa + 3;
                const double ax = pa[0] - pj[0], ay = pa[1] - pj[1], az = pa[2] - pj[2];
                const double bx = pb[0] - pj[0], by = pb[1] - pj[1], bz = pb[2] - pj[2];
                const double ma = sqrt(ax * ax + ay * ay + az * az);
                const double mb = sqrt(bx * bx + by * by + bz * bz);
                s += (ma > mb ? ma : mb) * f->vmax[j];
            }
            reach[l] = 1.5 * f->dt * s;
        }
    }
    for (p = 0; p < f->npairs; p++) {
        const int32_t i = f->pairs[2 * (size_t)p], k = f->pairs[2 * (size_t)p + 1];
        const double ri = f->link_radius != NULL ? f->link_radius[i] : 0.0;
        const double rk = f->link_radius != NULL ? f->link_radius[k] : 0.0;
        double *g = D(c, G) + (size_t)r * n;
        double speed, bound, cl;
        int32_t wk[2];
        cl = vf_self_row(n, P, D(c, axes), i, k, ri, rk, c->u, g, &speed);
        if (!(cl < f->obstacle_buffer || (f->dt > 0.0 && cl <= reach[i] + reach[k]))) {
            continue;
        }
        vf_nd_rate_bounds(kind, prm, &cl, 1, speed, c->idt, &bound, wk);
        if (bound == -INFINITY) {
            continue;
        }
        D(c, b)[r] = bound;
        D(c, dist)[r] = cl;
        IV(c, level)[r] = VF_FILTER_LEVEL_OBSTACLE;
        IV(c, ka)[r] = f->k + i;
        IV(c, kb)[r] = k;
        r += 1;
    }
    return r;
}

/* Every row of the cycle (the header's order); returns their number. */
static int32_t build_rows(ctx *c, const double *previous, const double *previous2)
{
    const vf_filter *f = c->f;
    const int32_t n = c->n;
    const double *q = c->q, *u = c->u;
    const double idt = c->idt;
    double *P = D(c, P), *axes = D(c, axes);
    int32_t r = 0, j, w;
    const vf_rows o = {D(c, G), D(c, b), D(c, dist), IV(c, level), IV(c, ka), IV(c, kb), n};
    vf_filter_kinematics(f, q, P, axes, D(c, frames));
    for (j = 0; j < n; j++) {
        r = vf_joint_position_rows(&o, r, j, f->jkind[j],
                                   f->jprm + (size_t)VF_ND_PROFILE_PARAMS * j, q[j], f->lower[j],
                                   f->upper[j], f->vmax[j], idt, VF_FILTER_LEVEL_JOINT, j, 0, j, 1);
    }
    for (j = 0; j < n; j++) {
        r = vf_joint_speed_rows(&o, r, j, f->vmax[j], VF_FILTER_LEVEL_JOINT, j, 2, j, 3);
    }
    r = vf_rate_rows(&o, r, previous, f->dt, f->amax, VF_FILTER_LEVEL_RATE);
    r = vf_jerk_rows(&o, r, previous, previous2, f->dt, f->jmax, VF_FILTER_LEVEL_JERK);
    for (w = 0; w < f->nw; w++) {
        const vf_filter_polytope *ws = f->ws + w;
        const vf_filter_point *pt = f->points + ws->point;
        double p[3];
        double *J = D(c, wsJ);
        const int32_t k = point_at(f, pt, D(c, frames), p);
        const double speed = point_jac(f, P, axes, p, k, u, J);
        r = vf_workspace_rows(&o, r, w, ws->N, ws->off, ws->nf, ws->kind, ws->prm, p, J, k, speed,
                              idt, VF_FILTER_LEVEL_WORKSPACE, D(c, wsd), D(c, wsb), IV(c, ri));
    }
    if (f->nattach > 0) {
        r = attach_ws_rows(c, &o, r);
    }
    if (f->k > 0) {
        vf_nd_capsules cap;
        int32_t kk, cc;
        double vsum = 0.0;
        memset(&cap, 0, sizeof cap);
        for (j = 0; j < n; j++) {
            vsum += f->vmax[j];
        }
        cap.P = P;
        cap.axes = axes;
        cap.lrad = f->link_radius != NULL ? f->link_radius : D(c, zeros);
        cap.C = f->centres;
        cap.srad = f->radii;
        cap.vmax = f->vmax;
        cap.vsum = vsum;
        cap.buf = f->obstacle_buffer;
        cap.dt = idt > 0.0 ? f->dt : 0.0;
        cap.idt = idt;
        cap.nl = n;
        cap.nj = n;
        cap.ncols = n;
        cap.k = f->k;
        vf_filter_obstacle_profile(f, &cap.kind, cap.prm);
        kk = vf_nd_capsule_rows(&cap, u, D(c, G) + (size_t)r * n, D(c, b) + r, D(c, dist) + r,
                                IV(c, ka) + r, IV(c, kb) + r, D(c, capw));
        for (cc = 0; cc < kk; cc++) {
            IV(c, level)[r + cc] = VF_FILTER_LEVEL_OBSTACLE;
        }
        r += kk;
        if (f->nattach > 0) {
            r = attach_obstacle_rows(c, r);
        }
    }
    if (f->npairs > 0) {
        r = self_rows(c, r);
    }
    return r;
}

/* ------------------------------------------------------------------ solve, model check */

static double inf_norm(const double *v, int32_t n)
{
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        if (fabs(v[k]) > s) {
            s = fabs(v[k]);
        }
    }
    return s;
}

/* After a solve in the metric's coordinates: round-off of the back-substitution, repaired
 * along the most violated row (gap beyond the acceptance tolerance tau = 1e-12 (|b| + |g|_1 (|x|
 * + |u|)) only: a nearly zero row missed within tau would be "repaired" by gap / |g| -- a huge
 * step; found by fuzz_filter_cycle); then every row must meet tau, else the solve stalled
 * (VF_STALLED; VF_OK otherwise). velfence.filter.solve.Projector.project's repair. */
static int repair(ctx *c, const double *bnd, double *x)
{
    const int32_t n = c->n, m = c->m;
    const double *G = D(c, G);
    int32_t i, k;
    int round;
    for (round = 0; round <= 4; round++) {
        double worst = 0.0, gg, xi = inf_norm(x, n) + c->unorm;
        int32_t wi = -1;
        for (i = 0; i < m; i++) {
            const double *g = G + (size_t)i * n;
            double gap, g1 = 0.0;
            if (bnd[i] == -INFINITY) {
                continue;
            }
            gap = bnd[i] - vf_dot(g, x, n);
            if (!(gap > 0.0)) {
                continue;
            }
            for (k = 0; k < n; k++) {
                g1 += fabs(g[k]);
            }
            if (gap > 1e-12 * (fabs(bnd[i]) + g1 * xi) && (wi < 0 || gap > worst)) {
                worst = gap;
                wi = i;
            }
        }
        if (wi < 0) {
            break;
        }
        if (round == 4) {
            return VF_STALLED; /* not repaired */
        }
        gg = vf_dot(G + (size_t)wi * n, G + (size_t)wi * n, n);
        for (k = 0; k < n; k++) {
            x[k] += (worst * (1.0 + 1e-12) + 1e-300) * G[(size_t)wi * n + k] / gg;
        }
    }
    return VF_OK;
}

/* Projection of c->u onto the rows with bound bnd (-inf: left out) into x: VF_OK, VF_INFEASIBLE,
 * VF_STALLED, VF_ITERATION_CAP or VF_DEADLINE. */
static int project(ctx *c, const double *bnd, double *x)
{
    const int32_t n = c->n, m = c->m;
    const vf_filter *f = c->f;
    const double *G = D(c, G);
    const double *u = c->u;
    int32_t i, k, q = 0, it = 0;
    int st, feasible = 1;
    vf_nd_solve_opts so;
    for (i = 0; i < m && feasible; i++) {
        if (bnd[i] != -INFINITY && !(vf_dot(G + (size_t)i * n, u, n) >= bnd[i])) {
            feasible = 0;
        }
    }
    if (feasible) {
        for (k = 0; k < n; k++) {
            x[k] = u[k];
        }
        return VF_OK;
    }
    if (c->deadline < INFINITY && vf_nd_monotonic_seconds() > c->deadline) {
        return VF_DEADLINE;
    }
    so.max_iterations = c->maxit;
    so.deadline = c->deadline < INFINITY ? c->deadline : 0.0;
    so.warm = c->first ? IV(c, warm) : NULL;
    so.n_warm = c->first ? c->n_warm : 0;
    c->first = 0;
    if (f->weights == NULL && c->factor == NULL) {
        st = vf_nd_project_kernel_opt(u, G, bnd, m, n, x, D(c, lam), IV(c, act), D(c, wsf), &q,
                                      &it, &so);
    } else {
        double *us = D(c, us), *ys = D(c, ys);
        const double *Lf = c->factor;
        if (Lf == NULL) { /* diagonal metric W = diag(w): y = sqrt(w) x */
            for (k = 0; k < n; k++) {
                us[k] = u[k] * sqrt(f->weights[k]);
            }
        } else { /* full metric H = L L^T: y = L^T x */
            for (k = 0; k < n; k++) {
                double s = 0.0;
                for (i = k; i < n; i++) {
                    s += Lf[(size_t)i * n + k] * u[i];
                }
                us[k] = s;
            }
        }
        st = vf_nd_project_kernel_opt(us, D(c, Gs), bnd, m, n, ys, D(c, lam), IV(c, act),
                                      D(c, wsf), &q, &it, &so);
        if (Lf == NULL) {
            for (k = 0; k < n; k++) {
                x[k] = ys[k] / sqrt(f->weights[k]);
            }
        } else { /* x = L^-T y: back substitution */
            for (k = n - 1; k >= 0; k--) {
                double s = ys[k];
                for (i = k + 1; i < n; i++) {
                    s -= Lf[(size_t)i * n + k] * x[i];
                }
                x[k] = s / Lf[(size_t)k * n + k];
            }
        }
        if (st == VF_OK) {
            st = repair(c, bnd, x);
        }
    }
#ifdef VF_FILTER_DEBUG
    fprintf(stderr, "solve m=%d st=%d it=%d\n", (int)m, st, (int)it);
#endif
    c->info->iterations += it;
    c->info->solves += 1;
    if (st == VF_ITERATION_CAP || st == VF_DEADLINE) {
        return st;
    }
    if (st == VF_OK) {
        /* Every rung keeps the velocity rows |x_j| <= v_j, so a true answer is within them; the
         * kernel's acceptance is relative to |x|, and on nearly dependent rows it can accept a
         * far-off point (|x| ~ 1e60; fuzz_filter_cycle): such an answer is a stalled solve. */
        for (k = 0; k < n; k++) {
            if (!(fabs(x[k]) <= f->vmax[k] * (1.0 + 1e-9))) {
                return VF_STALLED;
            }
        }
        return VF_OK;
    }
    return st == VF_INFEASIBLE ? VF_INFEASIBLE : VF_STALLED;
}

/* The clearance of sphere i and link l at joint points P: vf_nd_capsule_clearances's for one
 * pair (vf_capsule_clearance, so the same bits). */
static double pair_clearance(const vf_filter *f, const double *P, int32_t i, int32_t l)
{
    const double *a = P + 3 * (size_t)l;
    return vf_capsule_clearance(f->centres + 3 * (size_t)i, a, a + 3, f->radii[i],
                                f->link_radius != NULL ? f->link_radius[l] : 0.0);
}

/* The model check at q + x dt: counts the workspace / obstacle rows whose true next distance is
 * below min(0, d0) and (bnd not NULL) raises their bounds in bnd. */
static int32_t model_check(ctx *c, const double *x, double *bnd)
{
    const vf_filter *f = c->f;
    const int32_t n = c->n;
    double *q1 = D(c, q1);
    const double *frames1 = D(c, frames1);
    int32_t r, j, bad = 0, wlast = -1;
    double p[3];
    for (j = 0; j < n; j++) {
        q1[j] = c->q[j] + x[j] * f->dt;
    }
    vf_filter_kinematics(f, q1, D(c, P1), D(c, axes1), D(c, frames1));
    for (r = 0; r < c->m; r++) {
        const int32_t lv = IV(c, level)[r];
        double d1, target;
        if (lv != VF_FILTER_LEVEL_WORKSPACE && lv != VF_FILTER_LEVEL_OBSTACLE) {
            continue;
        }
        if (lv == VF_FILTER_LEVEL_WORKSPACE && IV(c, kb)[r] >= f->ws[IV(c, ka)[r]].nf) {
            /* an attachment's end: kb = nf + (2 s + e) nf + i */
            const vf_filter_polytope *ws = f->ws + IV(c, ka)[r];
            const int32_t rest = IV(c, kb)[r] - ws->nf, fi = rest % ws->nf, se = rest / ws->nf;
            const vf_filter_attachment *at = f->attach + se / 2;
            const double *nn = ws->N + 3 * (size_t)fi;
            double A[3], B[3];
            attach_axis(f, at, frames1, A, B);
            {
                const double *pe = se % 2 == 0 ? A : B;
                d1 = nn[0] * pe[0] + nn[1] * pe[1] + nn[2] * pe[2] - (ws->off[fi] + at->radius);
            }
        } else if (lv == VF_FILTER_LEVEL_WORKSPACE) {
            const vf_filter_polytope *ws = f->ws + IV(c, ka)[r];
            const double *nn = ws->N + 3 * (size_t)IV(c, kb)[r];
            if (IV(c, ka)[r] != wlast) {
                point_at(f, f->points + ws->point, frames1, p);
                wlast = IV(c, ka)[r];
            }
            d1 = nn[0] * p[0] + nn[1] * p[1] + nn[2] * p[2] - ws->off[IV(c, kb)[r]];
        } else if (IV(c, ka)[r] < f->k && IV(c, kb)[r] >= n) {
            const vf_filter_attachment *at = f->attach + (IV(c, kb)[r] - n);
            double A[3], B[3];
            attach_axis(f, at, frames1, A, B);
            d1 = vf_capsule_clearance(f->centres + 3 * (size_t)IV(c, ka)[r], A, B,
                                      f->radii[IV(c, ka)[r]], at->radius);
        } else if (IV(c, ka)[r] >= f->k) {
            d1 = self_clearance(f, D(c, P1), IV(c, ka)[r] - f->k, IV(c, kb)[r]);
        } else {
            d1 = pair_clearance(f, D(c, P1), IV(c, ka)[r], IV(c, kb)[r]);
        }
        target = D(c, dist)[r] < 0.0 ? D(c, dist)[r] : 0.0;
        if (!(d1 >= target)) {
            bad += 1;
            if (bnd != NULL) { /* (a non-finite next distance or raise: failed, no raise) */
                const double nb = bnd[r] + ((target - d1) / f->dt * (1.0 + 1e-6) + 1e-12);
                if (isfinite(nb)) {
                    bnd[r] = nb;
                }
            }
        }
    }
    return bad;
}

/* Whether G x >= c for every row with c = min(bnd, 0) (bnd -inf: left out), to the round-off
 * of forming x: tolerance 1e-12 (|c| + |g|_1 (|x|_inf + scale)) per row, scale = |u|_inf for a
 * solve's answer (and its multiples), 0 for t u formed exactly (velfence.filter.ladder.meets). */
static int meets_relaxed(ctx *c, const double *bnd, const double *x, double scale)
{
    const int32_t n = c->n;
    const double xi = inf_norm(x, n);
    int32_t r, k;
    for (r = 0; r < c->m; r++) {
        const double *g = D(c, G) + (size_t)r * n;
        double cc = bnd[r], g1 = 0.0;
        if (cc == -INFINITY) {
            continue;
        }
        if (cc > 0.0) {
            cc = 0.0;
        }
        for (k = 0; k < n; k++) {
            g1 += fabs(g[k]);
        }
        if (!(vf_dot(g, x, n) - cc >= -(1e-12 * (fabs(cc) + g1 * (xi + scale))))) {
            return 0;
        }
    }
    return 1;
}

/* The claimed bounds: bnd relaxed to min(b, 0) (-inf rows stay out). */
static void claim_relaxed(ctx *c, const double *bnd)
{
    int32_t r;
    for (r = 0; r < c->m; r++) {
        D(c, used)[r] = bnd[r] < 0.0 ? bnd[r] : 0.0;
    }
}

/* ladder._scaled: the largest t x0, t in {1, 1/2, ..., 2^-10}, meeting the rows relaxed to
 * min(bnd, 0) (to the round-off of forming x0 from a vector of size scale) and the model check,
 * into x (stage MODEL_SCALED); else zero (stage STOP). */
static void scaled(ctx *c, const double *bnd, const double *x0, double *x, double scale)
{
    int s;
    int32_t k;
    double t = 1.0;
    claim_relaxed(c, bnd);
    for (s = 0; s <= 10; s++, t *= 0.5) {
        for (k = 0; k < c->n; k++) {
            x[k] = x0[k] * t;
        }
        if (meets_relaxed(c, bnd, x, scale) && model_check(c, x, NULL) == 0) {
            c->info->stages |= VF_FILTER_STAGE_MODEL_SCALED;
            return;
        }
    }
    for (k = 0; k < c->n; k++) {
        x[k] = 0.0;
    }
    c->info->stages |= VF_FILTER_STAGE_STOP;
}

static int rung(ctx *c, const double *bnd, double *x);

/* After a rung that failed with status st: the rows of ladder level lv dropped from the
 * bounds cur (set to -inf), flagged with `stage`, and the rung run again; st unchanged when the
 * rung had succeeded or no row has that level. */
static int drop_level(ctx *c, double *cur, double *x, int st, int lv, int stage)
{
    int32_t r;
    int any = 0;
    if (st == VF_OK || st == VF_ITERATION_CAP || st == VF_DEADLINE) {
        return st;
    }
    for (r = 0; r < c->m; r++) {
        if (IV(c, level)[r] == lv) {
            cur[r] = -INFINITY;
            any = 1;
        }
    }
    if (!any) {
        return st;
    }
    c->info->rung = 2;
    c->info->dropped[lv] = 1;
    c->info->stages |= stage;
    return rung(c, cur, x);
}

/* One rung (ladder.run_ladder's body and _model_check): solve with the bounds bnd, then the
 * model check. VF_OK with the answer in x, VF_ITERATION_CAP / VF_DEADLINE, or the failing
 * solve's status (the next rung). */
static int rung(ctx *c, const double *bnd, double *x)
{
    double *bt = D(c, bt), *x1 = D(c, x1);
    int st, round, tightened = 0, settled = 0;
    st = project(c, bnd, x);
    if (st != VF_OK) {
        return st;
    }
    c->answer = bnd;
    memcpy(D(c, used), bnd, sizeof(double) * (size_t)c->m);
    if (!c->has_check) {
        return VF_OK;
    }
    memcpy(bt, bnd, sizeof(double) * (size_t)c->m);
    for (round = 0; round <= ROUNDS; round++) {
        if (model_check(c, x, round < ROUNDS ? bt : NULL) == 0) {
            settled = 1;
            break;
        }
        if (round == ROUNDS) {
            break;
        }
        tightened = 1;
        st = project(c, bt, x1);
        if (st == VF_ITERATION_CAP || st == VF_DEADLINE) {
            return st;
        }
        if (st != VF_OK) {
            break;
        }
        memcpy(x, x1, sizeof(double) * (size_t)c->n);
    }
    if (settled) {
        memcpy(D(c, used), bt, sizeof(double) * (size_t)c->m);
        if (tightened) {
            c->info->stages |= VF_FILTER_STAGE_MODEL_CHECK;
        }
        return VF_OK;
    }
    memcpy(x1, x, sizeof(double) * (size_t)c->n);
    scaled(c, bnd, x1, x, c->unorm); /* x1: a solve's answer from u */
    return VF_OK;
}

/* ladder.safe_fallback: the largest t in [0, 1] with t u meeting every row relaxed to
 * min(b, 0) (closed form, then halved until met as evaluated), then the model check's scaling. */
static void fallback(ctx *c, double *x)
{
    const int32_t n = c->n;
    double *bb = D(c, bb);
    double t = 1.0;
    int32_t r, k;
    int tries;
    for (r = 0; r < c->m; r++) {
        const double b = D(c, b)[r];
        const double lim = b < 0.0 ? b : 0.0;
        const double s = vf_dot(D(c, G) + (size_t)r * n, c->u, n);
        bb[r] = lim;
        if (s < 0.0 && lim / s < t) {
            t = lim / s;
        }
    }
    if (!(t >= 0.0) || !isfinite(t)) {
        t = 0.0;
    }
    for (k = 0; k < n; k++) {
        x[k] = c->u[k] * t;
    }
    for (tries = 0; tries < 60; tries++) {
        if (meets_relaxed(c, bb, x, 0.0)) {
            break;
        }
        t *= t > 1e-300 ? 0.5 : 0.0;
        for (k = 0; k < n; k++) {
            x[k] = c->u[k] * t;
        }
    }
    if (tries == 60) {
        for (k = 0; k < n; k++) {
            x[k] = 0.0;
        }
    }
    claim_relaxed(c, bb);
    if (c->has_check && model_check(c, x, NULL) != 0) {
        memcpy(D(c, x1), x, sizeof(double) * (size_t)n);
        scaled(c, bb, D(c, x1), x, 0.0);
    }
}

/* The slot of a row key in [0, rows_max): joint rows 4 a + b, acceleration 4 n + 2 a + b,
 * jerk 6 n + 2 a + b, workspace 8 n + (facets of the earlier polytopes) + b, obstacles
 * 8 n + sum nf + n a + b; -1 for a key out of range. */
static int32_t key_slot(const vf_filter *f, int32_t lv, int32_t a, int32_t b)
{
    const int32_t n = f->n;
    int32_t off = 8 * n, w;
    if (lv == VF_FILTER_LEVEL_JOINT) {
        return a >= 0 && a < n && b >= 0 && b < 4 ? 4 * a + b : -1;
    }
    if (lv == VF_FILTER_LEVEL_RATE) {
        return a >= 0 && a < n && b >= 0 && b < 2 ? 4 * n + 2 * a + b : -1;
    }
    if (lv == VF_FILTER_LEVEL_JERK) {
        return a >= 0 && a < n && b >= 0 && b < 2 ? 6 * n + 2 * a + b : -1;
    }
    if (lv == VF_FILTER_LEVEL_WORKSPACE) {
        if (a < 0 || a >= f->nw || b < 0 || b >= f->ws[a].nf * (1 + 2 * f->nattach)) {
            return -1;
        }
        for (w = 0; w < a; w++) {
            off += f->ws[w].nf * (1 + 2 * f->nattach);
        }
        return off + b;
    }
    if (lv == VF_FILTER_LEVEL_OBSTACLE) {
        const int32_t per = n + f->nattach;
        for (w = 0; w < f->nw; w++) {
            off += f->ws[w].nf * (1 + 2 * f->nattach);
        }
        if (a >= f->k && a < f->k + n) { /* self-collision pair (a - k, b) */
            for (w = 0; w < f->npairs; w++) {
                if (f->pairs[2 * (size_t)w] == a - f->k && f->pairs[2 * (size_t)w + 1] == b) {
                    return off + per * f->k + w;
                }
            }
            return -1;
        }
        if (a < 0 || a >= f->k || b < 0 || b >= per) {
            return -1;
        }
        return off + per * a + b;
    }
    return -1;
}

/* ------------------------------------------------------------------ the cycle */

static void zero_info(vf_filter_info *info)
{
    memset(info, 0, sizeof *info);
    info->fraction = 1.0;
}

static int fail(int code, const vf_filter *f, double *out, vf_filter_info *info)
{
    int32_t k;
    if (out != NULL && f != NULL && f->n > 0 && f->n <= MAX_JOINTS) {
        for (k = 0; k < f->n; k++) {
            out[k] = 0.0;
        }
    }
    if (info != NULL) {
        zero_info(info);
        info->status = code;
        info->stages = VF_FILTER_STAGE_STOP;
    }
    return code;
}

static int state_ok(const double *v, int32_t n)
{
    int32_t k;
    for (k = 0; k < n; k++) {
        if (!(fabs(v[k]) <= MAX_MAG)) {
            return 0;
        }
    }
    return 1;
}

int vf_filter_cycle(const vf_filter *f, const double *q, const double *u, const double *previous,
                    const vf_filter_opts *opts, double *out, vf_filter_info *info,
                    double *scratch, int32_t *iscratch)
{
    return vf_filter_cycle_jerk(f, q, u, previous, NULL, opts, out, info, scratch, iscratch);
}

int vf_filter_cycle_jerk(const vf_filter *f, const double *q, const double *u,
                         const double *previous, const double *previous2,
                         const vf_filter_opts *opts, double *out, vf_filter_info *info,
                         double *scratch, int32_t *iscratch)
{
    return vf_filter_cycle_metric(f, q, u, previous, previous2, NULL, opts, out, info, scratch,
                                  iscratch);
}

/* Whether the lower triangle of the n x n row-major factor L is finite with a positive
 * diagonal (the entries above the diagonal are not read). */
static int factor_ok(const double *L, int32_t n)
{
    int32_t i, k;
    for (i = 0; i < n; i++) {
        for (k = 0; k <= i; k++) {
            if (!isfinite(L[(size_t)i * n + k])) {
                return 0;
            }
        }
        if (!(L[(size_t)i * n + i] > 0.0)) {
            return 0;
        }
    }
    return 1;
}

int vf_filter_cycle_metric(const vf_filter *f, const double *q, const double *u,
                           const double *previous, const double *previous2, const double *factor,
                           const vf_filter_opts *opts, double *out, vf_filter_info *info,
                           double *scratch, int32_t *iscratch)
{
    ctx cx;
    ctx *c = &cx;
    int32_t n, k, r, lv;
    double cap, big;
    double *x, *cur;
    int st = VF_OK, rc;
    static const double FRACTIONS[9] = {0.25, 0.0625, 0.015625, 0.00390625, 0.0009765625,
                                        0.000244140625, 6.103515625e-05, 1.52587890625e-05, 0.0};
    if (out == NULL || info == NULL || scratch == NULL || iscratch == NULL || q == NULL
        || u == NULL) {
        return fail(VF_ERR_NULL, f, out, info);
    }
    rc = vf_filter_check(f);
    if (rc != VF_OK) {
        return fail(rc, f, out, info);
    }
    n = f->n;
    if (!state_ok(q, n) || !state_ok(u, n) || (previous != NULL && !state_ok(previous, n))
        || (previous2 != NULL && !state_ok(previous2, n))) {
        return fail(VF_ERR_NONFINITE, f, out, info);
    }
    if (factor != NULL && !factor_ok(factor, n)) {
        return fail(VF_ERR_ARGUMENT, f, out, info);
    }
    zero_info(info);
    memset(c, 0, sizeof *c);
    c->f = f;
    make_layout(f, &c->L);
    c->d = scratch;
    c->i = iscratch;
    c->n = n;
    c->idt = f->dt > 0.0 ? 1.0 / f->dt : 0.0;
    c->q = q;
    c->info = info;
    c->deadline = INFINITY;
    c->first = 1;
    c->factor = factor;
    if (opts != NULL) {
        if (isnan(opts->time_budget) || opts->time_budget < 0.0 || isnan(opts->deadline)
            || opts->n_warm < 0 || (opts->n_warm > 0 && opts->warm == NULL)) {
            return fail(VF_ERR_ARGUMENT, f, out, info);
        }
        c->maxit = opts->max_iterations;
        if (opts->time_budget > 0.0 && isfinite(opts->time_budget)) {
            c->deadline = vf_nd_monotonic_seconds() + opts->time_budget;
        }
        if (opts->deadline > 0.0 && opts->deadline < c->deadline) {
            c->deadline = opts->deadline;
        }
    }
    /* the command, shortened beyond 1e3 times the fastest joint limit */
    x = D(c, x);
    cap = 0.0;
    for (k = 0; k < n; k++) {
        if (f->vmax[k] > cap) {
            cap = f->vmax[k];
        }
    }
    cap *= COMMAND_CAP;
    big = inf_norm(u, n);
    for (k = 0; k < n; k++) {
        D(c, zeros)[k] = 0.0;
        D(c, ucmd)[k] = big > cap ? u[k] * (cap / big) : u[k];
    }
    if (big > cap) {
        info->stages |= VF_FILTER_STAGE_COMMAND_SCALED;
    }
    c->u = D(c, ucmd);
    c->unorm = inf_norm(c->u, n);
    c->m = build_rows(c, f->dt > 0.0 ? previous : NULL, f->dt > 0.0 ? previous2 : NULL);
    info->m = c->m;
    for (r = 0; r < c->m; r++) {
        if (!isfinite(D(c, b)[r]) || !vf_finite_all(D(c, G) + (size_t)r * n, (size_t)n)) {
            return fail(VF_ERR_OVERFLOW, f, out, info);
        }
        lv = IV(c, level)[r];
        if (D(c, dist)[r] < 0.0) {
            info->n_violated += 1;
        }
        if (f->dt > 0.0 && (lv == VF_FILTER_LEVEL_WORKSPACE || lv == VF_FILTER_LEVEL_OBSTACLE)) {
            c->has_check = 1;
        }
    }
    if (factor != NULL) {
        /* the rows in y = L^T x: G x = (G L^-T) y, row g -> L^-1 g (forward substitution) */
        double *Gs = D(c, Gs);
        for (r = 0; r < c->m; r++) {
            const double *g = D(c, G) + (size_t)r * n;
            double *z = Gs + (size_t)r * n;
            int32_t i;
            for (i = 0; i < n; i++) {
                double s = g[i];
                for (k = 0; k < i; k++) {
                    s -= factor[(size_t)i * n + k] * z[k];
                }
                z[i] = s / factor[(size_t)i * n + i];
            }
            if (!vf_finite_all(z, (size_t)n)) {
                return fail(VF_ERR_OVERFLOW, f, out, info);
            }
        }
    } else if (f->weights != NULL) {
        double *Gs = D(c, Gs);
        for (r = 0; r < c->m; r++) {
            for (k = 0; k < n; k++) {
                Gs[(size_t)r * n + k] = D(c, G)[(size_t)r * n + k] / sqrt(f->weights[k]);
            }
        }
    }
    if (opts != NULL && opts->n_warm > 0) {
        /* the previous active set, by key, as row indices (the solver's warm start): a table
         * of every possible key's slot (rows_max of them) -> row, then one look-up per key */
        int32_t *slot = IV(c, slot);
        int32_t w, cnt = 0;
        const int32_t M = (int32_t)c->L.M;
        for (r = 0; r < M; r++) {
            slot[r] = -1;
        }
        for (r = 0; r < c->m; r++) {
            k = key_slot(f, IV(c, level)[r], IV(c, ka)[r], IV(c, kb)[r]);
            if (k >= 0) {
                slot[k] = r;
            }
        }
        for (w = 0; w < opts->n_warm; w++) {
            const int32_t *key = opts->warm + 3 * (size_t)w;
            k = key_slot(f, key[0], key[1], key[2]);
            if (k >= 0 && slot[k] >= 0) {
                IV(c, warm)[cnt++] = slot[k];
                slot[k] = -1; /* (once) */
            }
        }
        c->n_warm = cnt;
    }
    /* the ladder */
    cur = D(c, cur);
    memcpy(cur, D(c, b), sizeof(double) * (size_t)c->m);
    info->rung = 1;
    st = rung(c, cur, x);
    /* comfort gives way to safety: the jerk rows first, then the acceleration rows */
    st = drop_level(c, cur, x, st, VF_FILTER_LEVEL_JERK, VF_FILTER_STAGE_DROPPED_JERK);
    st = drop_level(c, cur, x, st, VF_FILTER_LEVEL_RATE, VF_FILTER_STAGE_DROPPED_RATE);
    {
        static const int32_t LEVELS[3] = {VF_FILTER_LEVEL_OBSTACLE, VF_FILTER_LEVEL_WORKSPACE,
                                          VF_FILTER_LEVEL_JOINT};
        static const int32_t STAGE[3] = {VF_FILTER_STAGE_RELAXED_OBSTACLES,
                                         VF_FILTER_STAGE_RELAXED_WORKSPACE,
                                         VF_FILTER_STAGE_RELAXED_JOINT};
        int li, fi;
        double *bb = D(c, bb);
        for (li = 0; li < 3 && st != VF_OK && st != VF_ITERATION_CAP && st != VF_DEADLINE; li++) {
            int any = 0;
            lv = LEVELS[li];
            for (r = 0; r < c->m; r++) {
                if (IV(c, level)[r] == lv && D(c, dist)[r] < 0.0 && cur[r] > 0.0) {
                    any = 1;
                }
            }
            if (!any) {
                continue;
            }
            info->rung = 3 + li;
            info->relaxed[lv] = 1;
            info->stages |= STAGE[li];
            for (fi = 0; fi < 9; fi++) {
                memcpy(bb, cur, sizeof(double) * (size_t)c->m);
                for (r = 0; r < c->m; r++) {
                    if (IV(c, level)[r] == lv && D(c, dist)[r] < 0.0 && cur[r] > 0.0) {
                        bb[r] = cur[r] * FRACTIONS[fi];
                    }
                }
                info->fraction = FRACTIONS[fi];
                st = rung(c, bb, x);
                if (st == VF_OK || st == VF_ITERATION_CAP || st == VF_DEADLINE) {
                    break;
                }
            }
            if (st != VF_OK) {
                memcpy(cur, bb, sizeof(double) * (size_t)c->m);
            }
        }
    }
    rc = VF_OK;
    if (st == VF_ITERATION_CAP || st == VF_DEADLINE) {
        info->deadline =
            st == VF_DEADLINE ? VF_FILTER_DEADLINE_TIME : VF_FILTER_DEADLINE_ITERATIONS;
        /* (as velfence.filter: the fallback's report replaces the ladder's) */
        info->stages = (info->stages & VF_FILTER_STAGE_COMMAND_SCALED) | VF_FILTER_STAGE_DEADLINE;
        memset(info->relaxed, 0, sizeof info->relaxed);
        memset(info->dropped, 0, sizeof info->dropped);
        fallback(c, x);
        rc = st;
    } else if (st != VF_OK) {
        info->rung = 6;
        info->stages |= VF_FILTER_STAGE_STOP;
        for (k = 0; k < n; k++) {
            x[k] = 0.0;
        }
        claim_relaxed(c, D(c, b));
    }
    if (!vf_finite_all(x, (size_t)n)) {
        return fail(VF_ERR_OVERFLOW, f, out, info);
    }
    /* the output and what it did */
    {
        double *sl = D(c, slack);
        int32_t na = 0;
        for (k = 0; k < n; k++) {
            out[k] = x[k];
            if (x[k] != c->u[k]) {
                info->stages |= VF_FILTER_STAGE_PROJECTION;
            }
        }
        if (info->n_violated > 0) {
            info->stages |= VF_FILTER_STAGE_RECOVERY;
        }
        for (r = 0; r < c->m; r++) {
            double b = D(c, b)[r];
            sl[r] = vf_dot(D(c, G) + (size_t)r * n, x, n) - b;
            if (sl[r] <= BINDING * (1.0 + fabs(b)) || D(c, dist)[r] < 0.0) {
                IV(c, active)[na++] = r;
            }
        }
        info->n_active = na;
        na = 0;
        for (r = 0; r < c->m; r++) {
            const double b = D(c, b)[r];
            int rel;
            if (rc != VF_OK) { /* the fallback relaxed every positive bound */
                rel = b > 0.0;
            } else if (c->answer == NULL) { /* the stop */
                rel = D(c, dist)[r] < 0.0 && b > 0.0;
            } else {
                rel = c->answer[r] != -INFINITY && c->answer[r] < b;
            }
            if (rel) {
                IV(c, relaxed)[na++] = r;
            }
        }
        info->n_relaxed = na;
        info->relaxed_rows = IV(c, relaxed);
        info->G = D(c, G);
        info->b = D(c, b);
        info->dist = D(c, dist);
        info->slack = sl;
        info->bound = D(c, used);
        info->level = IV(c, level);
        info->key_a = IV(c, ka);
        info->key_b = IV(c, kb);
        info->active = IV(c, active);
    }
    info->status = rc;
    return rc;
}

/* ------------------------------------------------------------------ the batch */

int32_t vf_filter_batch_workers(int32_t threads, int32_t count)
{
    int32_t w = threads;
    if (count <= 0) {
        return 0;
    }
    if (w <= 0) {
#ifndef _WIN32
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        w = cores >= 1 ? (cores > VF_FILTER_BATCH_MAX_THREADS ? VF_FILTER_BATCH_MAX_THREADS
                                                              : (int32_t)cores)
                       : 1;
#else
        w = 1;
#endif
    }
    if (w > VF_FILTER_BATCH_MAX_THREADS) {
        w = VF_FILTER_BATCH_MAX_THREADS;
    }
    return w < count ? w : count;
}

static int32_t batch_slots(int32_t threads)
{
    int32_t w = vf_filter_batch_workers(threads, VF_FILTER_BATCH_MAX_THREADS);
    return w < 1 ? 1 : w;
}

size_t vf_filter_batch_doubles(const vf_filter *f, int32_t threads)
{
    return vf_filter_doubles(f) * (size_t)batch_slots(threads);
}

size_t vf_filter_batch_ints(const vf_filter *f, int32_t threads)
{
    return vf_filter_ints(f) * (size_t)batch_slots(threads);
}

typedef struct batch_job {
    const vf_filter *f;
    const vf_filter_opts *opts;
    const double *q, *u, *previous;
    double *out;
    int32_t *status, *stages, *n_active;
    int32_t lo, hi;
    double *scratch;
    int32_t *iscratch;
} batch_job;

static void *batch_run(void *arg)
{
    const batch_job *j = (const batch_job *)arg;
    const size_t n = (size_t)j->f->n;
    vf_filter_info info;
    int32_t r;
    for (r = j->lo; r < j->hi; r++) {
        const size_t o = (size_t)r * n;
        int rc = vf_filter_cycle(j->f, j->q + o, j->u + o,
                                 j->previous != NULL ? j->previous + o : NULL, j->opts,
                                 j->out + o, &info, j->scratch, j->iscratch);
        j->status[r] = rc;
        if (j->stages != NULL) {
            j->stages[r] = info.stages;
        }
        if (j->n_active != NULL) {
            j->n_active[r] = rc < 0 ? 0 : info.n_active;
        }
    }
    return NULL;
}

int vf_filter_cycle_batch(const vf_filter *f, int32_t count, const double *q, const double *u,
                          const double *previous, const vf_filter_opts *opts, double *out,
                          int32_t *status, int32_t *stages, int32_t *n_active, int32_t threads,
                          double *scratch, int32_t *iscratch)
{
    batch_job jobs[VF_FILTER_BATCH_MAX_THREADS];
    int32_t w, k, r;
    int rc = VF_OK;
    size_t nd, ni;
    if (f == NULL || out == NULL || status == NULL || (count > 0 && (q == NULL || u == NULL))
        || scratch == NULL || iscratch == NULL) {
        rc = VF_ERR_NULL;
    } else if (count < 0) {
        rc = VF_ERR_ARGUMENT;
    } else {
        rc = vf_filter_check(f);
    }
    if (rc != VF_OK) {
        if (f != NULL && out != NULL && count > 0 && f->n > 0 && f->n <= MAX_JOINTS) {
            memset(out, 0, (size_t)count * (size_t)f->n * sizeof(double));
        }
        for (r = 0; status != NULL && r < count; r++) {
            status[r] = rc;
            if (stages != NULL) {
                stages[r] = VF_FILTER_STAGE_STOP;
            }
            if (n_active != NULL) {
                n_active[r] = 0;
            }
        }
        return rc;
    }
    if (count == 0) {
        return VF_OK;
    }
    w = vf_filter_batch_workers(threads, count);
    nd = vf_filter_doubles(f);
    ni = vf_filter_ints(f);
    for (k = 0; k < w; k++) {
        batch_job *j = jobs + k;
        j->f = f;
        j->opts = opts;
        j->q = q;
        j->u = u;
        j->previous = previous;
        j->out = out;
        j->status = status;
        j->stages = stages;
        j->n_active = n_active;
        j->lo = (int32_t)(((int64_t)count * k) / w);
        j->hi = (int32_t)(((int64_t)count * (k + 1)) / w);
        j->scratch = scratch + nd * (size_t)k;
        j->iscratch = iscratch + ni * (size_t)k;
    }
#ifndef _WIN32
    {
        pthread_t tid[VF_FILTER_BATCH_MAX_THREADS];
        int started[VF_FILTER_BATCH_MAX_THREADS];
        for (k = 1; k < w; k++) {
            started[k] = pthread_create(tid + k, NULL, batch_run, jobs + k) == 0;
        }
        batch_run(jobs);
        for (k = 1; k < w; k++) {
            if (started[k]) {
                pthread_join(tid[k], NULL);
            } else { /* not created: the caller runs its chunk */
                batch_run(jobs + k);
            }
        }
    }
#else
    for (k = 0; k < w; k++) {
        batch_run(jobs + k);
    }
#endif
    return VF_OK;
}
