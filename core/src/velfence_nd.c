/*
 * velfence_nd.c -- the n-D projection and exact law (see include/velfence_nd.h).
 *
 * A line-by-line port of velfence.geometry.projection.project_kernel and
 * velfence.shaping._nd_kernels.polytope_kernel (with the bound definition of
 * velfence.shaping._kernels it calls): the same operations in the same order, so that the results
 * are bit-identical to the Python reference when compiled with -ffp-contract=off. Each function
 * names the Python function it ports; keep them in step.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime for the deadline */
#include "velfence_nd.h"

#include <math.h>
#include <stdint.h>
#include <time.h>

#include "vf_bounds.h" /* the exact law's bounds, shared with the 2-D core */
#include "vf_rows.h"   /* the filter's row arithmetic, shared with velfence_filter.c */

/* vf_bounds.h speaks the 2-D header's codes; the n-D header's must be the same numbers. */
#if VF_ND_ZONE_FREE != VF_ZONE_FREE || VF_ND_ZONE_BUFFER != VF_ZONE_BUFFER ||                     \
    VF_ND_ZONE_CORNER != VF_ZONE_CORNER || VF_ND_ZONE_OUTSIDE != VF_ZONE_OUTSIDE ||               \
    VF_ND_ZONE_OUTSIDE_CORNER != VF_ZONE_OUTSIDE_CORNER ||                                        \
    VF_ND_PROFILE_LINEAR != VF_PROFILE_LINEAR || VF_ND_PROFILE_THREE_ZONE != VF_PROFILE_THREE_ZONE
#error "velfence_nd.h and velfence_core.h disagree on zone or profile codes"
#endif

/* projection.py's tolerances */
#define DEP_TOL 1e-13
#define VIOL_TOL 1e-13
#define REPAIR_ULPS (8.0 * 2.220446049250313e-16)
#define ROUND_OFF 1e-12
#define VF_ND_RELAX_STEPS 9 /* len(_nd_kernels.RECOVERY_FRACTIONS) */

/* ------------------------------------------------------------------ the projection */

size_t vf_nd_project_doubles(int32_t m, int32_t n)
{
    size_t mm = m > 0 ? (size_t)m : 0;
    size_t nn = n > 0 ? (size_t)n : 0;
    return 2 * nn * nn + 4 * nn + mm + 2;
}

/* projection._rebuild: Gram-Schmidt (twice) of the active normals into Q (n x q), R (q x q). */
static void rebuild(const double *G, const int32_t *act, int32_t q, int32_t n, double *wsf,
                    size_t oq, size_t orr)
{
    int32_t c, r, i, pass;
    for (c = 0; c < q; c++) {
        int32_t g = act[c];
        double rho;
        for (i = 0; i < n; i++) {
            wsf[oq + (size_t)i * n + c] = G[(size_t)g * n + i];
        }
        for (r = 0; r <= c; r++) {
            wsf[orr + (size_t)r * n + c] = 0.0;
        }
        for (pass = 0; pass < 2; pass++) {
            for (r = 0; r < c; r++) {
                double h = 0.0;
                for (i = 0; i < n; i++) {
                    h += wsf[oq + (size_t)i * n + r] * wsf[oq + (size_t)i * n + c];
                }
                wsf[orr + (size_t)r * n + c] += h;
                for (i = 0; i < n; i++) {
                    wsf[oq + (size_t)i * n + c] -= h * wsf[oq + (size_t)i * n + r];
                }
            }
        }
        rho = 0.0;
        for (i = 0; i < n; i++) {
            rho += wsf[oq + (size_t)i * n + c] * wsf[oq + (size_t)i * n + c];
        }
        rho = sqrt(rho);
        wsf[orr + (size_t)c * n + c] = rho;
        if (rho > 0.0) {
            for (i = 0; i < n; i++) {
                wsf[oq + (size_t)i * n + c] /= rho;
            }
        }
    }
}

/* projection._row_norm */
static double row_norm(const double *G, int32_t i, int32_t n)
{
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        s += G[(size_t)i * n + k] * G[(size_t)i * n + k];
    }
    return sqrt(s);
}

/* projection._slack */
static double slack(const double *G, const double *b, int32_t i, const double *x, int32_t n)
{
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        s += G[(size_t)i * n + k] * x[k];
    }
    return s - b[i];
}

/* Seconds on CLOCK_MONOTONIC (the deadline's clock). */
static double monotonic_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double vf_nd_monotonic_seconds(void)
{
    return monotonic_seconds();
}

int32_t vf_nd_default_iteration_cap(int32_t m, int32_t n)
{
    int64_t c = 4 * ((int64_t)(m > 0 ? m : 0) + (n > 0 ? n : 0)) + 16;
    return c > INT32_MAX ? INT32_MAX : (int32_t)c;
}

/* projection._is_active */
static int is_active(const int32_t *act, int32_t q, int32_t i)
{
    int32_t c;
    for (c = 0; c < q; c++) {
        if (act[c] == i) {
            return 1;
        }
    }
    return 0;
}

/* projection._consider: row i as the next row to add (violated more than the best so far, not
 * active; a negative stored norm marks a row accepted as met to round-off) */
static void consider(const double *G, const double *b, int32_t i, const double *x, int32_t n,
                     const double *wsf, size_t ogn, double scale, const int32_t *act, int32_t q,
                     int32_t *p, double *worst)
{
    const double gn = wsf[ogn + i];
    double s, tol;
    if (gn < 0.0) {
        return;
    }
    s = slack(G, b, i, x, n);
    tol = VIOL_TOL * (fabs(b[i]) + gn * (scale + 1e-300) + 1e-300);
    if (s < -tol) {
        double v = gn > 0.0 ? s / gn : -INFINITY;
        /* the active set is looked up only for a row that would be picked */
        if ((*p < 0 || v < *worst) && !is_active(act, q, i)) {
            *worst = v;
            *p = i;
        }
    }
}

/* projection.project_kernel */
int vf_nd_project_kernel(const double *u, const double *G, const double *b, int32_t m, int32_t n,
                         double *x, double *lam, int32_t *act, double *wsf, int32_t *q_out,
                         int32_t *iters_out)
{
    return vf_nd_project_kernel_opt(u, G, b, m, n, x, lam, act, wsf, q_out, iters_out, NULL);
}

/* projection.project_kernel_opts (+ the deadline, which only C checks) */
int vf_nd_project_kernel_opt(const double *u, const double *G, const double *b, int32_t m,
                             int32_t n, double *x, double *lam, int32_t *act, double *wsf,
                             int32_t *q_out, int32_t *iters_out, const vf_nd_solve_opts *opts)
{
    const size_t oq = 0;
    const size_t orr = (size_t)n * n;
    const size_t oz = 2 * (size_t)n * n;
    const size_t oh = oz + n;
    const size_t orv = oh + n;
    const size_t ogn = orv + n;
    int32_t q = 0;
    int32_t iters = 0;
    const int32_t cap = opts != NULL ? opts->max_iterations : 0;
    const int64_t limit = cap > 0 ? (int64_t)cap : 4 * ((int64_t)m + n) + 16;
    const int over = cap > 0 ? VF_ITERATION_CAP : VF_ND_PROJECT_ITERATION_LIMIT;
    const int32_t n_warm = opts != NULL && opts->warm != NULL ? opts->n_warm : 0;
    const double deadline = opts != NULL ? opts->deadline : 0.0;
    const int timed = deadline > 0.0 && deadline < INFINITY;
    int32_t i, k, c, j, r, w, scan;
    int status = VF_ND_PROJECT_OPTIMAL;
    double big;
    double ubig = 0.0;
    for (k = 0; k < n; k++) {
        x[k] = u[k];
    }
    for (k = 0; k < n; k++) {
        if (fabs(u[k]) > ubig) {
            ubig = fabs(u[k]);
        }
    }
    for (i = 0; i < m; i++) {
        wsf[ogn + i] = row_norm(G, i, n);
    }
    for (;;) {
        double scale = 0.0;
        double worst = 0.0;
        double lp;
        int32_t p = -1;
        for (k = 0; k < n; k++) {
            if (fabs(x[k]) > scale) {
                scale = fabs(x[k]);
            }
        }
        /* Warm start: a violated row of the previous active set first. */
        for (w = 0; w < n_warm; w++) {
            i = opts->warm[w];
            if (i >= 0 && i < m && b[i] != -INFINITY) {
                consider(G, b, i, x, n, wsf, ogn, scale, act, q, &p, &worst);
            }
        }
        scan = p < 0 ? m : 0; /* the whole scan only when no warm row is violated */
        for (i = 0; i < scan; i++) {
            if (b[i] != -INFINITY) {
                consider(G, b, i, x, n, wsf, ogn, scale, act, q, &p, &worst);
            }
        }
        if (p < 0) {
            break;
        }
        if (wsf[ogn + p] == 0.0) {
            *q_out = q;
            *iters_out = iters;
            return VF_ND_PROJECT_INFEASIBLE;
        }
        lp = 0.0;
        for (;;) {
            double zz, t1, t2, t, sp;
            int32_t kd, pass;
            iters += 1;
            if (iters > limit) {
                *q_out = q;
                *iters_out = iters;
                return over;
            }
            if (timed && monotonic_seconds() > deadline) {
                *q_out = q;
                *iters_out = iters;
                return VF_DEADLINE;
            }
            for (c = 0; c < q; c++) {
                wsf[oh + c] = 0.0;
            }
            for (k = 0; k < n; k++) {
                wsf[oz + k] = G[(size_t)p * n + k];
            }
            for (pass = 0; pass < 2; pass++) {
                for (c = 0; c < q; c++) {
                    double h = 0.0;
                    for (k = 0; k < n; k++) {
                        h += wsf[oq + (size_t)k * n + c] * wsf[oz + k];
                    }
                    wsf[oh + c] += h;
                    for (k = 0; k < n; k++) {
                        wsf[oz + k] -= h * wsf[oq + (size_t)k * n + c];
                    }
                }
            }
            for (c = q - 1; c >= 0; c--) {
                double s = wsf[oh + c];
                for (j = c + 1; j < q; j++) {
                    s -= wsf[orr + (size_t)c * n + j] * wsf[orv + j];
                }
                wsf[orv + c] = s / wsf[orr + (size_t)c * n + c];
            }
            zz = 0.0;
            for (k = 0; k < n; k++) {
                zz += wsf[oz + k] * wsf[oz + k];
            }
            t1 = INFINITY;
            kd = -1;
            for (c = 0; c < q; c++) {
                double rr = wsf[orv + c];
                if (rr > 0.0) {
                    double tt = lam[c] / rr;
                    if (tt < t1) {
                        t1 = tt;
                        kd = c;
                    }
                }
            }
            t2 = INFINITY;
            sp = slack(G, b, p, x, n);
            /* Python's (tol * gn) ** 2 is pow(., 2.0). With n rows active their normals span
             * R^n and row p lies in their span whatever z says: a basis built from rows of
             * extreme scale (norms 1e-162 beside 1e117) leaves z far from zero, and a step there
             * would make an (n+1)-th row active, past the end of act and lam. */
            if (q < n && zz > pow(DEP_TOL * wsf[ogn + p], 2.0)) {
                t2 = -sp / zz;
            }
            t = t1 < t2 ? t1 : t2;
            if (t == INFINITY) {
                /* violated by the round-off of forming x from u only: accepted as met */
                if (-sp <= ROUND_OFF * (fabs(b[p]) + wsf[ogn + p] * (scale + ubig))) {
                    wsf[ogn + p] = -wsf[ogn + p];
                    break;
                }
                *q_out = q;
                *iters_out = iters;
                return VF_ND_PROJECT_INFEASIBLE;
            }
            if (t2 < INFINITY) {
                for (k = 0; k < n; k++) {
                    x[k] += t * wsf[oz + k];
                }
            }
            for (c = 0; c < q; c++) {
                lam[c] -= t * wsf[orv + c];
            }
            lp += t;
            if (t2 <= t1) {
                act[q] = p;
                lam[q] = lp;
                q += 1;
                rebuild(G, act, q, n, wsf, oq, orr);
                break;
            }
            for (c = kd; c < q - 1; c++) {
                act[c] = act[c + 1];
                lam[c] = lam[c + 1];
            }
            q -= 1;
            rebuild(G, act, q, n, wsf, oq, orr);
        }
    }
    /* Polish: x = (I - Q Q^T) u + Q R^-T b_A. */
    if (q > 0) {
        for (c = 0; c < q; c++) {
            double h = 0.0;
            for (k = 0; k < n; k++) {
                h += wsf[oq + (size_t)k * n + c] * u[k];
            }
            wsf[oh + c] = h;
        }
        for (c = 0; c < q; c++) {
            double y = b[act[c]];
            for (r = 0; r < c; r++) {
                y -= wsf[orr + (size_t)r * n + c] * wsf[oz + r];
            }
            wsf[oz + c] = y / wsf[orr + (size_t)c * n + c];
        }
        for (k = 0; k < n; k++) {
            double t = u[k];
            for (c = 0; c < q; c++) {
                t -= wsf[oq + (size_t)k * n + c] * wsf[oh + c];
            }
            for (c = 0; c < q; c++) {
                t += wsf[oq + (size_t)k * n + c] * wsf[oz + c];
            }
            x[k] = t;
        }
    }
    *q_out = q;
    *iters_out = iters;
    /* Repair: every bound as evaluated in floating point. */
    for (r = 0; r < 8; r++) {
        int32_t wi = -1;
        double wg = 0.0;
        double gn, step;
        for (i = 0; i < m; i++) {
            double g;
            if (b[i] == -INFINITY) {
                continue;
            }
            g = -slack(G, b, i, x, n);
            if (g > 0.0) {
                double gni = fabs(wsf[ogn + i]);
                g = gni > 0.0 ? g / gni : INFINITY;
                if (g > wg) {
                    wg = g;
                    wi = i;
                }
            }
        }
        if (wi < 0) {
            return VF_ND_PROJECT_OPTIMAL;
        }
        gn = fabs(wsf[ogn + wi]);
        if (gn == 0.0) {
            return VF_ND_PROJECT_INFEASIBLE;
        }
        big = 0.0;
        for (k = 0; k < n; k++) {
            if (fabs(x[k]) > big) {
                big = fabs(x[k]);
            }
        }
        step = wg + REPAIR_ULPS * (fabs(b[wi]) / gn + big) + 1e-300;
        for (k = 0; k < n; k++) {
            x[k] += step * G[(size_t)wi * n + k] / gn;
        }
    }
    big = ubig;
    for (k = 0; k < n; k++) {
        if (fabs(x[k]) > big) {
            big = fabs(x[k]);
        }
    }
    for (i = 0; i < m; i++) {
        if (b[i] == -INFINITY) {
            continue;
        }
        if (-slack(G, b, i, x, n) > ROUND_OFF * (fabs(b[i]) + fabs(wsf[ogn + i]) * big)) {
            status = VF_ND_PROJECT_ITERATION_LIMIT;
            break;
        }
    }
    return status;
}

int vf_nd_project(const double *u, const double *G, const double *b, int32_t m, int32_t n,
                  double *x, double *lam, int32_t *act, double *wsf, int32_t *q, int32_t *iters,
                  int32_t *status)
{
    int32_t i, k;
    size_t a;
    int rc = VF_ND_OK;
    int st;
    if (x == NULL || q == NULL || iters == NULL || status == NULL) {
        if (x != NULL && n > 0) {
            for (k = 0; k < n; k++) {
                x[k] = 0.0;
            }
        }
        if (q != NULL) *q = 0;
        if (iters != NULL) *iters = 0;
        if (status != NULL) *status = VF_ND_PROJECT_INFEASIBLE;
        return VF_ND_ERR_NULL;
    }
    *q = 0;
    *iters = 0;
    *status = VF_ND_PROJECT_INFEASIBLE;
    if (n < 1) {
        return VF_ND_ERR_ARGUMENT;
    }
    for (k = 0; k < n; k++) {
        x[k] = 0.0; /* the stop result, also for m < 0 (found by core/fuzz/fuzz_nd.c) */
    }
    if (m < 0) {
        return VF_ND_ERR_ARGUMENT;
    }
    if (u == NULL || lam == NULL || act == NULL || wsf == NULL
        || (m > 0 && (G == NULL || b == NULL))) {
        return VF_ND_ERR_NULL;
    }
    for (a = 0; a < (size_t)m * (size_t)n; a++) {
        if (!isfinite(G[a])) {
            return VF_ND_ERR_ARGUMENT;
        }
    }
    for (k = 0; k < n; k++) {
        if (!isfinite(u[k])) {
            rc = VF_ND_ERR_NONFINITE;
        }
    }
    for (i = 0; i < m; i++) {
        if (isnan(b[i]) || b[i] == INFINITY) {
            rc = VF_ND_ERR_NONFINITE;
        }
    }
    if (rc != VF_ND_OK) {
        return rc;
    }
    st = vf_nd_project_kernel(u, G, b, m, n, x, lam, act, wsf, q, iters);
    /* a row G_i . x that overflows cannot be told met (NaN compares false: found by
     * core/fuzz/fuzz_nd.c, u near DBL_MAX returned as OPTIMAL while violating a row): the answer
     * overflowed */
    for (i = 0; i < m && rc == VF_ND_OK; i++) {
        double s = 0.0;
        if (b[i] == -INFINITY) {
            continue;
        }
        for (k = 0; k < n; k++) {
            s += G[(size_t)i * n + k] * x[k];
        }
        if (!isfinite(s)) {
            rc = VF_ND_ERR_OVERFLOW;
        }
    }
    for (k = 0; k < n; k++) {
        if (rc != VF_ND_OK || !isfinite(x[k])) {
            for (k = 0; k < n; k++) {
                x[k] = 0.0;
            }
            *q = 0;
            *iters = 0;
            return VF_ND_ERR_OVERFLOW;
        }
    }
    *status = st;
    return VF_ND_OK;
}

/* ------------------------------------------------------------------ the bound definition */

/* ------------------------------------------------------------------ the n-D exact law */

/* Scratch layout (doubles): dist nf, bnd nf, G nf*dim, b nf, u dim, x dim, lam dim+1, wsf.
 * (ints): work nf, act dim+1. */
size_t vf_nd_law_doubles(int32_t nf, int32_t dim)
{
    size_t f = nf > 0 ? (size_t)nf : 0;
    size_t d = dim > 0 ? (size_t)dim : 0;
    return 3 * f + f * d + 3 * d + 1 + vf_nd_project_doubles(nf, dim);
}

size_t vf_nd_law_ints(int32_t nf, int32_t dim)
{
    size_t f = nf > 0 ? (size_t)nf : 0;
    size_t d = dim > 0 ? (size_t)dim : 0;
    return f + d + 1;
}

typedef struct nd_views {
    double *dist, *bnd, *G, *b, *u, *x, *lam, *wsf;
    int32_t *work, *act;
} nd_views;

/* _nd_kernels._answer: out = x scale, the binding facets, the bounds in caller units */
static void answer(const nd_views *w, double scale, int32_t dim, double *out, int32_t *active,
                   int32_t q, int32_t m)
{
    int32_t k, c, a;
    for (k = 0; k < dim; k++) {
        out[k] = w->x[k] * scale;
    }
    for (c = 0; c < q; c++) {
        active[c] = w->work[w->act[c]];
    }
    for (a = 0; a < m; a++) {
        w->bnd[w->work[a]] *= scale;
    }
}

static void views(int32_t nf, int32_t dim, vf_nd_scratch *s, nd_views *v)
{
    size_t f = (size_t)nf;
    size_t d = (size_t)dim;
    v->dist = s->dbl;
    v->bnd = v->dist + f;
    v->G = v->bnd + f;
    v->b = v->G + f * d;
    v->u = v->b + f;
    v->x = v->u + d;
    v->lam = v->x + d;
    v->wsf = v->lam + d + 1;
    v->work = s->ints;
    v->act = v->work + f;
}

void vf_nd_bounded(const vf_nd_polytope *poly, vf_nd_scratch *scratch, const double **dist,
                   const double **bnd, const int32_t **work)
{
    nd_views v;
    views(poly->nf, poly->dim, scratch, &v);
    *dist = v.dist;
    *bnd = v.bnd;
    *work = v.work;
}

/* _nd_kernels.vector_norm */
static double vector_norm(const double *v, int32_t n)
{
    double big = 0.0;
    double s = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        if (fabs(v[k]) > big) {
            big = fabs(v[k]);
        }
    }
    if (big == 0.0) {
        return 0.0;
    }
    for (k = 0; k < n; k++) {
        double t = v[k] / big;
        s += t * t;
    }
    return big * sqrt(s);
}

/* _nd_kernels._solve_rows */
static int solve_rows(const double *N, int32_t m, int32_t dim, nd_views *w, int32_t *q)
{
    int32_t a, k, iters;
    for (a = 0; a < m; a++) {
        int32_t e = w->work[a];
        for (k = 0; k < dim; k++) {
            w->G[(size_t)a * dim + k] = N[(size_t)e * dim + k];
        }
        w->b[a] = w->bnd[e];
    }
    return vf_nd_project_kernel(w->u, w->G, w->b, m, dim, w->x, w->lam, w->act, w->wsf, q,
                                &iters);
}

static void set_res(vf_nd_result *r, int32_t zone, int32_t stages, int32_t q, int32_t p1,
                    int32_t p2, double d1, double d2, int32_t m)
{
    r->zone = zone;
    r->stages = stages;
    r->q = q;
    r->p1 = p1;
    r->p2 = p2;
    r->d1 = d1;
    r->d2 = d2;
    r->m = m;
}

/* _nd_kernels.polytope_kernel */
void vf_nd_kernel(const vf_nd_polytope *poly, const vf_nd_law *law, const double *p,
                  const double *v, double *out, int32_t *active, vf_nd_scratch *scratch,
                  vf_nd_result *res)
{
    const double *N = poly->N;
    const double *off = poly->off;
    const int32_t nf = poly->nf;
    const int32_t dim = poly->dim;
    const int32_t kind = law->kind;
    const double *prm = law->prm;
    const int relax = law->relax != 0;
    const double idt = law->idt;
    nd_views w;
    bounds_out bo;
    double vnorm, unit, scale;
    int32_t e, k, a, c, m, n_out, zone, stages, attempt, q, r;
    int status;
    views(nf, dim, scratch, &w);
    for (e = 0; e < nf; e++) {
        double s = 0.0;
        for (k = 0; k < dim; k++) {
            s += N[(size_t)e * dim + k] * p[k];
        }
        w.dist[e] = s - off[e];
    }
    vnorm = vector_norm(v, dim);
    bounds_from_distances(w.dist, nf, vnorm, kind, prm, relax, idt, 1, w.bnd, w.work, &bo);
    m = bo.m;
    n_out = bo.n_out;
    unit = bo.cs;
    scale = bo.scale;
    if (m == 0) {
        for (k = 0; k < dim; k++) {
            out[k] = v[k];
        }
        set_res(res, VF_ND_ZONE_FREE, 0, 0, bo.p1, bo.p2, bo.d1, bo.d2, 0);
        return;
    }
    zone = zone_code(n_out, bo.n_near);
    stages = bo.n_near > 0 ? VF_ND_STAGE_PROJECT : 0;
    if (n_out > 0) {
        stages |= VF_ND_STAGE_SPRING;
    }
    for (k = 0; k < dim; k++) {
        w.u[k] = v[k] / scale;
    }
    for (attempt = 0; attempt < 2; attempt++) {
        if (attempt == 1) {
            double bmax = 0.0;
            double un, f;
            for (a = 0; a < m; a++) {
                if (fabs(w.bnd[w.work[a]]) > bmax) {
                    bmax = fabs(w.bnd[w.work[a]]);
                }
            }
            un = vector_norm(w.u, dim);
            if (!(un > 1e3 * bmax)) {
                break;
            }
            f = 1e3 * bmax / un;
            for (k = 0; k < dim; k++) {
                w.u[k] *= f;
            }
            stages |= VF_ND_STAGE_SCALED;
        }
        for (;;) {
            int done;
            status = solve_rows(N, m, dim, &w, &q);
            if (status != VF_ND_PROJECT_OPTIMAL) {
                break;
            }
            done = n_out == 0;
            if (!done) {
                double xx = 0.0;
                for (k = 0; k < dim; k++) {
                    xx += w.x[k] * w.x[k];
                }
                done = xx <= unit * unit;
            }
            if (!done) {
                int added = 0;
                int32_t m0 = m;
                c = unbounded_candidates(w.dist, w.work, m, nf);
                fill_bounds(kind, prm, relax, w.dist, w.work, m, c, unit, scale, idt, w.bnd);
                for (a = m0; a < c; a++) {
                    e = w.work[a];
                    if (w.bnd[e] > -INFINITY) {
                        double s = 0.0;
                        for (k = 0; k < dim; k++) {
                            s += N[(size_t)e * dim + k] * w.x[k];
                        }
                        if (s < w.bnd[e]) {
                            w.work[m] = e;
                            m += 1;
                            added = 1;
                        }
                    }
                }
                done = !added;
            }
            if (done) {
                answer(&w, scale, dim, out, active, q, m);
                set_res(res, zone, stages, q, bo.p1, bo.p2, bo.d1, bo.d2, m);
                return;
            }
        }
    }
    if (n_out > 0) {
        /* _nd_kernels.RECOVERY_FRACTIONS: the outside facets' recovery bounds times 1/4, ...,
         * 4^-8, then 0; every other facet's bound kept (the point is inside those). */
        for (r = 0; r < VF_ND_RELAX_STEPS; r++) {
            for (a = 0; a < m; a++) {
                e = w.work[a];
                if (w.dist[e] < 0.0 && w.bnd[e] > 0.0) {
                    w.bnd[e] = r + 1 < VF_ND_RELAX_STEPS ? w.bnd[e] * 0.25 : 0.0;
                }
            }
            status = solve_rows(N, m, dim, &w, &q);
            if (status == VF_ND_PROJECT_OPTIMAL) {
                answer(&w, scale, dim, out, active, q, m);
                set_res(res, zone, stages | VF_ND_STAGE_RELAXED, q, bo.p1, bo.p2, bo.d1, bo.d2,
                        m);
                return;
            }
        }
    }
    /* round-off defeated a problem zero velocity solves (never observed): stop */
    for (k = 0; k < dim; k++) {
        out[k] = 0.0;
    }
    for (a = 0; a < m; a++) {
        w.bnd[w.work[a]] *= scale;
    }
    set_res(res, zone, stages | VF_ND_STAGE_STOP | (n_out > 0 ? VF_ND_STAGE_RELAXED : 0), 0,
            bo.p1, bo.p2, bo.d1, bo.d2, m);
}

/* ------------------------------------------------------------------ checked API */

int vf_nd_check(const vf_nd_polytope *poly, const vf_nd_law *law)
{
    size_t a;
    int32_t i;
    if (poly == NULL || law == NULL) {
        return VF_ND_ERR_NULL;
    }
    if (poly->N == NULL || poly->off == NULL || poly->cen == NULL) {
        return VF_ND_ERR_NULL;
    }
    if (poly->nf < 1 || poly->dim < 1) {
        return VF_ND_ERR_ARGUMENT;
    }
    for (a = 0; a < (size_t)poly->nf * (size_t)poly->dim; a++) {
        if (!isfinite(poly->N[a])) {
            return VF_ND_ERR_ARGUMENT;
        }
    }
    for (i = 0; i < poly->nf; i++) {
        if (!isfinite(poly->off[i])) {
            return VF_ND_ERR_ARGUMENT;
        }
    }
    for (i = 0; i < poly->dim; i++) {
        if (!isfinite(poly->cen[i])) {
            return VF_ND_ERR_ARGUMENT;
        }
    }
    if (!(law->idt >= 0.0) || !isfinite(law->idt)) {
        return VF_ND_ERR_ARGUMENT;
    }
    for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
        if (isnan(law->prm[i])) {
            return VF_ND_ERR_ARGUMENT;
        }
    }
    if (law->kind == VF_ND_PROFILE_LINEAR) {
        if (!(law->prm[0] > 0.0) || !(law->prm[1] >= 0.0) || !(law->prm[2] >= 0.0)) {
            return VF_ND_ERR_ARGUMENT;
        }
    } else if (law->kind == VF_ND_PROFILE_THREE_ZONE) {
        for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
            if (!isfinite(law->prm[i]) || law->prm[i] < 0.0) {
                return VF_ND_ERR_ARGUMENT;
            }
        }
    } else {
        return VF_ND_ERR_ARGUMENT;
    }
    return VF_ND_OK;
}

static void set_stop(vf_nd_result *res, double *out, int32_t dim)
{
    int32_t k;
    if (out != NULL) {
        for (k = 0; k < dim; k++) {
            out[k] = 0.0;
        }
    }
    set_res(res, VF_ND_ZONE_INVALID, VF_ND_STAGE_STOP, 0, -1, -1, 0.0, 0.0, 0);
}

int vf_nd_shape(const vf_nd_polytope *poly, const vf_nd_law *law, const double *p,
                const double *v, double *out, int32_t *active, vf_nd_scratch *scratch,
                vf_nd_result *res)
{
    int32_t k, dim;
    if (res == NULL) {
        return VF_ND_ERR_NULL;
    }
    if (poly == NULL) {
        set_stop(res, NULL, 0);
        return VF_ND_ERR_NULL;
    }
    dim = poly->dim;
    if (law == NULL || p == NULL || v == NULL || out == NULL || active == NULL || scratch == NULL
        || scratch->dbl == NULL || scratch->ints == NULL || poly->N == NULL
        || poly->off == NULL || poly->cen == NULL) {
        set_stop(res, out, dim);
        return VF_ND_ERR_NULL;
    }
    for (k = 0; k < dim; k++) {
        if (!isfinite(p[k]) || !isfinite(v[k])) {
            set_stop(res, out, dim);
            return VF_ND_ERR_NONFINITE;
        }
    }
    vf_nd_kernel(poly, law, p, v, out, active, scratch, res);
    /* Every double of the answer finite, as in the 2-D core: a position so far away that the
     * signed distances N.p - off overflow (found by core/fuzz/fuzz_nd.c: p1 = -1, d1 = +inf under
     * VF_ND_OK) is refused. d2 is +inf only when absent (one facet). */
    if (!isfinite(res->d1) || !(isfinite(res->d2) || (poly->nf < 2 && res->p2 == -1))) {
        set_stop(res, out, dim);
        return VF_ND_ERR_OVERFLOW;
    }
    for (k = 0; k < dim; k++) {
        if (!isfinite(out[k])) {
            set_stop(res, out, dim);
            return VF_ND_ERR_OVERFLOW;
        }
    }
    return VF_ND_OK;
}

int64_t vf_nd_batch(const vf_nd_polytope *poly, const vf_nd_law *law, const double *P,
                    const double *V, size_t rows, double *out, int64_t *zones,
                    vf_nd_scratch *scratch)
{
    size_t r;
    int64_t bad = 0;
    vf_nd_result res;
    int32_t active[64];
    int32_t *act = active;
    /* every pointer vf_nd_shape reads, checked before the first row: then nothing is written
     * (found by core/fuzz/fuzz_nd.c: a NULL cen or scratch array zeroed row 0 first) */
    if (poly == NULL || law == NULL || scratch == NULL
        || (rows > 0 && (P == NULL || V == NULL || out == NULL || poly->N == NULL
                         || poly->off == NULL || poly->cen == NULL || scratch->dbl == NULL
                         || scratch->ints == NULL))) {
        return VF_ND_ERR_NULL;
    }
    if (poly->dim < 1 || poly->dim > 63) {
        /* the binding facets are not returned by the batch; a larger dim needs vf_nd_shape */
        return VF_ND_ERR_ARGUMENT;
    }
    for (r = 0; r < rows; r++) {
        size_t o = r * (size_t)poly->dim;
        int rc = vf_nd_shape(poly, law, P + o, V + o, out + o, act, scratch, &res);
        if (rc == VF_ND_ERR_NULL) {
            return rc;
        }
        if (rc != VF_ND_OK) {
            bad += 1;
        }
        if (zones != NULL) {
            zones[r] = res.zone;
        }
    }
    return bad;
}

/* ------------------------------------------------------------------ safety-filter helpers */

/* velfence.shaping.filter._bounds: bounds_from_distances (relax off, unit scale) and fill_bounds
 * for the rows it leaves out. */
void vf_nd_rate_bounds(int32_t kind, const double *prm, const double *dist, int32_t k,
                       double speed, double idt, double *bnd, int32_t *work)
{
    bounds_out o;
    int32_t *rest = work + k;
    int32_t e, a, r;
    for (e = 0; e < k; e++) {
        bnd[e] = 0.0;
    }
    bounds_from_distances(dist, k, speed, kind, prm, 0, idt, 0, bnd, work, &o);
    if (o.m < k) {
        for (e = 0; e < k; e++) {
            rest[e] = 1;
        }
        for (a = 0; a < o.m; a++) {
            rest[work[a]] = 0;
        }
        r = 0;
        for (e = 0; e < k; e++) {
            if (rest[e]) {
                rest[r] = e;
                r += 1;
            }
        }
        fill_bounds(kind, prm, 0, dist, rest, 0, r, speed, 1.0, idt, bnd);
    }
}

void vf_nd_capsule_clearances(const vf_nd_capsules *cap, double *clear)
{
    int32_t i, l;
    for (i = 0; i < cap->k; i++) {
        const double *cc = cap->C + 3 * (size_t)i;
        for (l = 0; l < cap->nl; l++) {
            const double *a = cap->P + 3 * (size_t)l;
            clear[(size_t)i * cap->nl + l] = vf_capsule_clearance(cc, a, a + 3, cap->srad[i],
                                                                  cap->lrad[l]);
        }
    }
}

int32_t vf_nd_capsule_rows(const vf_nd_capsules *cap, const double *u, double *G, double *b,
                           double *d, int32_t *obs, int32_t *link, double *work)
{
    const int32_t nl = cap->nl;
    const int32_t nj = cap->nj;
    const int32_t nc = cap->ncols;
    const int32_t k = cap->k;
    const double *P = cap->P;
    double *clear = work;          /* k * nl */
    double *reach = work + (size_t)k * nl; /* nl */
    int use_reach = 0;
    int32_t i, l, j, c, rows = 0;
    vf_nd_capsule_clearances(cap, clear);
    if (cap->dt > 0.0 && cap->idt > 0.0 && cap->vmax != NULL) {
        double far = INFINITY;
        double big = 0.0;
        for (c = 0; c < k * nl; c++) {
            if (clear[c] >= cap->buf && clear[c] < far) {
                far = clear[c];
            }
        }
        for (l = 0; l <= nl; l++) {
            double ex = P[3 * l] - P[0], ey = P[3 * l + 1] - P[1], ez = P[3 * l + 2] - P[2];
            double h = sqrt(ex * ex + ey * ey + ez * ez);
            if (h > big) {
                big = h;
            }
        }
        if (far < INFINITY && !(far > 1.5 * cap->dt * (2.0 * big * cap->vsum) * (1.0 + 1e-9))) {
            use_reach = 1;
            for (l = 0; l < nl; l++) {
                double s = 0.0;
                for (j = 0; j <= l && j < nj; j++) {
                    const double *pj = P + 3 * (size_t)j;
                    const double *pa = P + 3 * (size_t)l;
                    const double *pb = pa + 3;
                    double ax = pa[0] - pj[0], ay = pa[1] - pj[1], az = pa[2] - pj[2];
                    double bx = pb[0] - pj[0], by = pb[1] - pj[1], bz = pb[2] - pj[2];
                    double ma = sqrt(ax * ax + ay * ay + az * az);
                    double mb = sqrt(bx * bx + by * by + bz * bz);
                    s += (ma > mb ? ma : mb) * cap->vmax[j];
                }
                reach[l] = 1.5 * cap->dt * s;
            }
        }
    }
    for (i = 0; i < k; i++) {
        const double *cc = cap->C + 3 * (size_t)i;
        for (l = 0; l < nl; l++) {
            double cl = clear[(size_t)i * nl + l];
            const double *a = P + 3 * (size_t)l;
            const double *e = a + 3;
            double t, x[3], n[3], dist, vx = 0.0, vy = 0.0, vz = 0.0, bound;
            double *g = G + (size_t)rows * nc;
            int32_t wk[2];
            if (!(cl < cap->buf || (use_reach && cl <= reach[l]))) {
                continue;
            }
            t = vf_seg_t(cc, a, e);
            for (c = 0; c < 3; c++) {
                x[c] = t <= 0.5 ? a[c] + t * (e[c] - a[c]) : e[c] - (1.0 - t) * (e[c] - a[c]);
                n[c] = x[c] - cc[c];
            }
            dist = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (dist > 0.0) {
                n[0] /= dist;
                n[1] /= dist;
                n[2] /= dist;
            } else {
                double hx = e[0] - a[0], hy = e[1] - a[1];
                double h = sqrt(hx * hx + hy * hy);
                n[0] = h == 0.0 ? 1.0 : -hy / h;
                n[1] = h == 0.0 ? 0.0 : hx / h;
                n[2] = 0.0;
            }
            for (j = 0; j < nc; j++) {
                g[j] = 0.0;
            }
            for (j = 0; j <= l && j < nj; j++) {
                const double *z = cap->axes + 3 * (size_t)j;
                const double *pj = P + 3 * (size_t)j;
                double ddx = x[0] - pj[0], ddy = x[1] - pj[1], ddz = x[2] - pj[2];
                double jx = z[1] * ddz - z[2] * ddy;
                double jy = z[2] * ddx - z[0] * ddz;
                double jz = z[0] * ddy - z[1] * ddx;
                g[j] = n[0] * jx + n[1] * jy + n[2] * jz;
                vx += jx * u[j];
                vy += jy * u[j];
                vz += jz * u[j];
            }
            vf_nd_rate_bounds(cap->kind, cap->prm, &cl, 1, sqrt(vx * vx + vy * vy + vz * vz),
                              cap->idt, &bound, wk);
            if (bound == -INFINITY) {
                continue;
            }
            b[rows] = bound;
            d[rows] = cl;
            obs[rows] = i;
            link[rows] = l;
            rows += 1;
        }
    }
    return rows;
}

/* ------------------------------------------------------------------ a DH chain's filter rows */

void vf_nd_chain_kinematics(int32_t n, const double *dh, const double *tool, const double *q,
                            double *P, double *axes, double *flange)
{
    /* The frames' rotation columns x, y, z and origin o, with u = c y - s x:
     * x' = c x + s y, o' = o + a x' + d z, y' = ca u + sa z, z' = ca z - sa u. */
    double xx = 1.0, xy = 0.0, xz = 0.0;
    double yx = 0.0, yy = 1.0, yz = 0.0;
    double zx = 0.0, zy = 0.0, zz = 1.0;
    double ox = 0.0, oy = 0.0, oz = 0.0;
    int32_t i;
    P[0] = 0.0;
    P[1] = 0.0;
    P[2] = 0.0;
    for (i = 0; i < n; i++) {
        const double *r = dh + 5 * (size_t)i;
        double a = r[0], ca = r[1], sa = r[2], d = r[3];
        double th = q[i] + r[4];
        double ct = cos(th), st = sin(th);
        double ux = ct * yx - st * xx, uy = ct * yy - st * xy, uz = ct * yz - st * xz;
        double nx = ct * xx + st * yx, ny = ct * xy + st * yy, nz = ct * xz + st * yz;
        axes[3 * (size_t)i] = zx; /* z of the frame before joint i moves it */
        axes[3 * (size_t)i + 1] = zy;
        axes[3 * (size_t)i + 2] = zz;
        xx = nx;
        xy = ny;
        xz = nz;
        ox += a * xx + d * zx;
        oy += a * xy + d * zy;
        oz += a * xz + d * zz;
        yx = ca * ux + sa * zx;
        yy = ca * uy + sa * zy;
        yz = ca * uz + sa * zz;
        zx = ca * zx - sa * ux;
        zy = ca * zy - sa * uy;
        zz = ca * zz - sa * uz;
        P[3 * (size_t)i + 3] = ox;
        P[3 * (size_t)i + 4] = oy;
        P[3 * (size_t)i + 5] = oz;
    }
    flange[0] = ox;
    flange[1] = oy;
    flange[2] = oz;
    P[3 * (size_t)n] = ox + tool[0] * xx + tool[1] * yx + tool[2] * zx;
    P[3 * (size_t)n + 1] = oy + tool[0] * xy + tool[1] * yy + tool[2] * zy;
    P[3 * (size_t)n + 2] = oz + tool[0] * xz + tool[1] * yz + tool[2] * zz;
}

size_t vf_nd_filter_rows_max(const vf_nd_filter *f)
{
    size_t rows = 6 * (size_t)f->n + (size_t)f->cap.k * (size_t)f->n;
    int32_t w;
    for (w = 0; w < f->nw; w++) {
        rows += (size_t)f->ws[w].nf;
    }
    return rows;
}

size_t vf_nd_filter_doubles(const vf_nd_filter *f)
{
    size_t nf = 1;
    int32_t w;
    for (w = 0; w < f->nw; w++) {
        if ((size_t)f->ws[w].nf > nf) {
            nf = (size_t)f->ws[w].nf;
        }
    }
    return (size_t)f->cap.k * (size_t)f->n + (size_t)f->n + 3 * nf + 3 * (size_t)f->n + 4;
}

int32_t vf_nd_filter_rows(const vf_nd_filter *f, const double *q, const double *u,
                          const double *previous, double dt, double *P, double *axes,
                          double *flange, double *G, double *b, int32_t *level, int32_t *tag_a,
                          int32_t *tag_b, double *dist, double *work)
{
    const int32_t n = f->n;
    const double idt = dt > 0.0 ? 1.0 / dt : 0.0;
    int32_t r = 0, j, w;
    size_t nfmax = 1;
    double *ws_d, *ws_b, *ws_J;
    int32_t *ws_i;
    const vf_rows o = {G, b, dist, level, tag_a, tag_b, n};
    for (w = 0; w < f->nw; w++) {
        if ((size_t)f->ws[w].nf > nfmax) {
            nfmax = (size_t)f->ws[w].nf;
        }
    }
    ws_d = work + (size_t)f->cap.k * (size_t)n + (size_t)n;
    ws_b = ws_d + nfmax;
    ws_i = (int32_t *)(void *)(ws_b + nfmax);
    ws_J = ws_b + 2 * nfmax; /* (ws_i: nfmax doubles' worth of int32 pairs) */
    vf_nd_chain_kinematics(n, f->dh, f->tool, q, P, axes, flange);
    /* joint position and velocity rows */
    for (j = 0; j < n; j++) {
        r = vf_joint_position_rows(&o, r, j, f->jkind[j],
                                   f->jprm + (size_t)VF_ND_PROFILE_PARAMS * j, q[j], f->lower[j],
                                   f->upper[j], f->vmax[j], idt, VF_ND_LEVEL_JOINT, 4 * j, 0,
                                   4 * j + 1, 0);
        r = vf_joint_speed_rows(&o, r, j, f->vmax[j], VF_ND_LEVEL_JOINT, 4 * j + 2, 0, 4 * j + 3,
                                0);
    }
    /* acceleration rows */
    r = vf_rate_rows(&o, r, previous, dt, f->amax, VF_ND_LEVEL_RATE);
    /* workspace rows: the point's Jacobian J (columns z_j x (p - P_j), j < k; ws_J holds column
     * j at 3 j), computed once per limit and shared by its speed and its facets' rows */
    for (w = 0; w < f->nw; w++) {
        const vf_nd_workspace *ws = f->ws + w;
        const double *p = ws->point < 0 ? flange : P + 3 * (size_t)ws->point;
        const int32_t k = ws->point < 0 ? n : ws->point;
        double vx = 0.0, vy = 0.0, vz = 0.0;
        for (j = 0; j < k; j++) {
            const double *z = axes + 3 * (size_t)j;
            const double *pj = P + 3 * (size_t)j;
            double *c = ws_J + 3 * (size_t)j;
            double dx = p[0] - pj[0], dy = p[1] - pj[1], dz = p[2] - pj[2];
            c[0] = z[1] * dz - z[2] * dy;
            c[1] = z[2] * dx - z[0] * dz;
            c[2] = z[0] * dy - z[1] * dx;
            vx += c[0] * u[j];
            vy += c[1] * u[j];
            vz += c[2] * u[j];
        }
        r = vf_workspace_rows(&o, r, w, ws->N, ws->off, ws->nf, ws->kind, ws->prm, p, ws_J, k,
                              sqrt(vx * vx + vy * vy + vz * vz), idt, VF_ND_LEVEL_WORKSPACE, ws_d,
                              ws_b, ws_i);
    }
    /* obstacle rows */
    if (f->cap.k > 0) {
        vf_nd_capsules cap = f->cap;
        int32_t c, k;
        cap.P = P;
        cap.axes = axes;
        cap.dt = idt > 0.0 ? dt : 0.0;
        cap.idt = idt;
        k = vf_nd_capsule_rows(&cap, u, G + (size_t)r * n, b + r, dist + r, tag_a + r, tag_b + r,
                               work);
        for (c = 0; c < k; c++) {
            level[r + c] = VF_ND_LEVEL_OBSTACLE;
        }
        r += k;
    }
    return r;
}
