/*
 * fuzz_nd.c -- libFuzzer target of the n-D checked API (core/include/velfence_nd.h): the exact law
 * inside a convex polytope (vf_nd_check, vf_nd_shape, vf_nd_batch, with vf_nd_kernel and
 * vf_nd_bounded as references) and the minimum-change projection (vf_nd_project), the solve behind
 * SafetyFilter and PolytopeShaper. Build: core/fuzz/build.sh. Input layout (doubles and the byte
 * cursor: fuzz_common.h):
 *
 *   flags byte: bit 6 the projection instead of the law, bit 7 one NULL-pointer case
 *   law part:   polytope | law (as fuzz_exact's: kind selector, 6 doubles, relax, idt selector)
 *               | states (p, v: dim doubles each), the rest of the bytes, at most FZ_ND_STATES
 *   polytope:   mode byte; bit 0 raw: dim = (int8) % 8, nf = (int8) % 26 (zero or negative
 *               included), every entry of N (nf x dim), off (nf,), cen (dim,) a decoded double;
 *               else structured: dim 1..6, nf 1..24, each facet normal from dim moderate values
 *               (int16 / 8192) normalised to unit length (a zero draw: +-e_i), the Chebyshev
 *               centre c from dim decoded doubles and off_i = N_i . c - w_i with a width
 *               w_i = (1 + byte) / 64 (c is inside, at least 1/64 from every facet); mode bit 1
 *               then overwrites one entry of N, off or cen with a decoded double (almost-valid
 *               data, no longer structured)
 *   projection: mode byte; n = 1 + byte % 8 and m = byte % 24, or (mode bit 0, raw) n = (int8) %
 *               10, m = (int8) % 26; G (m x n), b (m,), u (n,): structured: G moderate values,
 *               b_i = G_i . x0 - margin (feasible at x0, moderate) or -inf, u decoded doubles;
 *               raw: every entry a decoded double
 *
 * Asserted (abort() on a violation, after printing the decoded input):
 *   vf_nd_check returns VF_ND_OK, VF_ND_ERR_NULL or VF_ND_ERR_ARGUMENT, and VF_ND_OK exactly when
 *     the data meets the rules (nf >= 1, dim >= 1, finite N, off and cen, idt finite >= 0, no NaN
 *     parameter, a known kind; linear: d_max > 0, k >= 0, r_max >= 0; three-zone: all finite
 *     >= 0 -- the 2-D law's rules, docs/core.md);
 *   on checked data, per state: vf_nd_shape's code is VF_ND_OK, VF_ND_ERR_NONFINITE (exactly when
 *     p or v is not finite) or VF_ND_ERR_OVERFLOW; on an error out = +0.0 and the stop result bit
 *     for bit (zone VF_ND_ZONE_INVALID, stage VF_ND_STAGE_STOP, q = m = 0, facets -1, distances
 *     +0.0); on VF_ND_OK: out finite, zone 0..4, only the law's stage bits, 0 <= q <= dim + 1 with
 *     active[:q] facets, 0 <= m <= nf, p1 a facet, p2 a facet other than p1 or -1, d1 finite, d2
 *     finite (+inf only when absent: nf = 1, p2 = -1); in continuous time (idt = 0) zone
 *     FREE leaves v unchanged (bits; with idt > 0 the one-period bound -d idt may still bind);
 *   the law's bounds on structured polytopes (unit normals), unless the result is STOP (RELAXED:
 *   the slowed recovery bounds vf_nd_bounded reports, every other bound as stated)
 *     (documented: then only recovery is kept): every bounded facet e = work[a], a < m, of
 *     vf_nd_bounded has N_e . out >= bnd_e - tol, tol = 1e-9 (1 + |bnd_e| + |out| + |v|) (a NaN
 *     or -inf bnd_e, from inf - inf of huge parameters, states no bound and is skipped); inside
 *     (every signed distance >= 0) |out| <= |v| (1 + 1e-9) (never faster inside);
 *   the same call with the scratch filled with NaN garbage and zeroed gives identical bits, and
 *     vf_nd_kernel the same under VF_ND_OK; vf_nd_batch returns the number of non-OK states and
 *     writes the single calls' velocities and zones (with zones NULL the same velocities);
 *   vf_nd_project returns VF_ND_ERR_ARGUMENT exactly for n < 1, m < 0 or non-finite G, else
 *     VF_ND_ERR_NONFINITE exactly for non-finite u or b NaN / +inf, else VF_ND_OK or
 *     VF_ND_ERR_OVERFLOW; on an error x = +0.0, q = iters = 0, status INFEASIBLE; on VF_ND_OK x
 *     finite, status one of the three, 0 <= q <= n + 1 with act[:q] rows; OPTIMAL on structured
 *     data: G_i . x >= b_i - tol for every row, tol = 1e-9 (|b_i| + |G_i| (|x| + |u|)) (the
 *     problem's constraints); a second call (garbage scratch) identical; the workspace is exactly
 *     vf_nd_project_doubles(m, n) doubles;
 *   NULL pointers (flags bit 7): any one of the pointers vf_nd_check, vf_nd_shape, vf_nd_batch or
 *     vf_nd_project read gives VF_ND_ERR_NULL, with the stop result (and out = 0) from vf_nd_shape
 *     when res (and out) is given, nothing written by vf_nd_batch, and x = 0, q = iters = 0,
 *     status INFEASIBLE (those not NULL) from vf_nd_project.
 * VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) spoils every VF_ND_OK velocity of the law with
 * a NaN, for the tests' proof that a violation aborts.
 */
#define VF_FUZZ_BYTES_ONLY
#include "fuzz_common.h"
#include "velfence_nd.h"

#define FZ_ND_MAX_DIM 6
#define FZ_ND_MAX_NF 24
#define FZ_ND_STATES 16

typedef struct fz_nd_polytope {
    vf_nd_polytope poly;
    double *N, *off, *cen;
    int structured;
} fz_nd_polytope;

static const fz_nd_polytope *cur_poly;
static const vf_nd_law *cur_law;

static void print_polytope(const vf_nd_polytope *p)
{
    int32_t i, k;
    fprintf(stderr, "polytope nf=%d dim=%d\n", (int)p->nf, (int)p->dim);
    if (p->nf < 1 || p->dim < 1) {
        return;
    }
    fprintf(stderr, "  cen:");
    for (k = 0; k < p->dim; k++) {
        fprintf(stderr, " %.17g", p->cen[k]);
    }
    fprintf(stderr, "\n");
    for (i = 0; i < p->nf && i < 64; i++) {
        fprintf(stderr, "  facet %d: off=%.17g N=", (int)i, p->off[i]);
        for (k = 0; k < p->dim; k++) {
            fprintf(stderr, " %.17g", p->N[(size_t)i * p->dim + k]);
        }
        fprintf(stderr, "\n");
    }
}

static void fail(const char *what, const double *p, const double *v, const double *out,
                 const vf_nd_result *r, int rc)
{
    const vf_nd_law *l = cur_law;
    fprintf(stderr, "\n*** velfence_nd contract violated (n-D law): %s\n", what);
    fprintf(stderr, "nd law kind=%d relax=%d idt=%.17g prm=(%.17g, %.17g, %.17g, %.17g, %.17g, %.17g)\n",
            (int)l->kind, (int)l->relax, l->idt, l->prm[0], l->prm[1], l->prm[2], l->prm[3],
            l->prm[4], l->prm[5]);
    print_polytope(&cur_poly->poly);
    if (p != NULL) {
        fz_print_vec("state p", p, cur_poly->poly.dim);
        fz_print_vec("state v", v, cur_poly->poly.dim);
    }
    if (r != NULL) {
        fprintf(stderr, "result: rc=%d zone=%d stages=%d q=%d p1=%d p2=%d d1=%.17g d2=%.17g m=%d\n",
                rc, (int)r->zone, (int)r->stages, (int)r->q, (int)r->p1, (int)r->p2, r->d1, r->d2,
                (int)r->m);
    }
    if (out != NULL) {
        fz_print_vec("out", out, cur_poly->poly.dim);
    }
    abort();
}

static void fail_simple(const char *what)
{
    fail(what, NULL, NULL, NULL, NULL, 0);
}

static void read_polytope(fz_reader *r, fz_nd_polytope *g)
{
    uint8_t mode = fz_byte(r);
    int32_t nf, dim, i, k;
    memset(g, 0, sizeof *g);
    if (mode & 1) { /* raw */
        dim = (int8_t)fz_byte(r) % 8;
        nf = (int8_t)fz_byte(r) % 26;
        g->N = fz_alloc(nf > 0 && dim > 0 ? nf * dim : 0);
        g->off = fz_alloc(nf);
        g->cen = fz_alloc(dim);
        for (i = 0; i < nf; i++) {
            for (k = 0; k < dim; k++) {
                g->N[(size_t)i * dim + k] = fz_double(r);
            }
            g->off[i] = fz_double(r);
        }
        for (k = 0; k < dim; k++) {
            g->cen[k] = fz_double(r);
        }
    } else {
        dim = 1 + fz_byte(r) % FZ_ND_MAX_DIM;
        nf = 1 + fz_byte(r) % FZ_ND_MAX_NF;
        g->N = fz_alloc(nf * dim);
        g->off = fz_alloc(nf);
        g->cen = fz_alloc(dim);
        for (k = 0; k < dim; k++) {
            g->cen[k] = fz_double(r);
        }
        for (i = 0; i < nf; i++) {
            double *row = g->N + (size_t)i * dim, s = 0.0, w, c = 0.0;
            for (k = 0; k < dim; k++) {
                row[k] = (double)fz_i16(r) / 8192.0;
                s += row[k] * row[k];
            }
            if (s > 0.0) {
                s = sqrt(s);
                for (k = 0; k < dim; k++) {
                    row[k] /= s;
                }
            } else {
                row[(i / 2) % dim] = (i % 2) ? -1.0 : 1.0;
            }
            w = (1.0 + fz_byte(r)) / 64.0;
            for (k = 0; k < dim; k++) {
                c += row[k] * g->cen[k];
            }
            g->off[i] = c - w;
        }
        g->structured = 1;
        if (mode & 2) {
            uint8_t which = fz_byte(r);
            int32_t at = fz_byte(r);
            double v = fz_double(r);
            switch (which % 3) {
            case 0: g->N[at % (nf * dim)] = v; break;
            case 1: g->off[at % nf] = v; break;
            default: g->cen[at % dim] = v; break;
            }
            g->structured = 0;
        }
    }
    g->poly.N = g->N;
    g->poly.off = g->off;
    g->poly.cen = g->cen;
    g->poly.nf = nf;
    g->poly.dim = dim;
}

static void free_polytope(fz_nd_polytope *g)
{
    free(g->N);
    free(g->off);
    free(g->cen);
}

static void read_law(fz_reader *r, vf_nd_law *law)
{
    uint8_t k = fz_byte(r);
    int i;
    memset(law, 0, sizeof *law);
    switch (k % 4) {
    case 0:
    case 1: law->kind = VF_ND_PROFILE_LINEAR; break;
    case 2: law->kind = VF_ND_PROFILE_THREE_ZONE; break;
    default: {
        uint32_t hi = (uint16_t)fz_i16(r);
        uint32_t lo = (uint16_t)fz_i16(r);
        law->kind = (int32_t)(hi << 16 | lo);
        break;
    }
    }
    for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
        law->prm[i] = fz_double(r);
    }
    law->relax = fz_byte(r) & 1;
    law->idt = (fz_byte(r) & 1) ? fz_double(r) : 0.0;
}

static int valid_by_rules(const vf_nd_polytope *p, const vf_nd_law *l)
{
    int32_t i;
    if (p->nf < 1 || p->dim < 1) {
        return 0;
    }
    for (i = 0; i < p->nf * p->dim; i++) {
        if (!isfinite(p->N[i])) {
            return 0;
        }
    }
    for (i = 0; i < p->nf; i++) {
        if (!isfinite(p->off[i])) {
            return 0;
        }
    }
    for (i = 0; i < p->dim; i++) {
        if (!isfinite(p->cen[i])) {
            return 0;
        }
    }
    if (!isfinite(l->idt) || l->idt < 0.0) {
        return 0;
    }
    for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
        if (isnan(l->prm[i])) {
            return 0;
        }
    }
    if (l->kind == VF_ND_PROFILE_LINEAR) {
        return l->prm[0] > 0.0 && l->prm[1] >= 0.0 && l->prm[2] >= 0.0;
    }
    if (l->kind == VF_ND_PROFILE_THREE_ZONE) {
        for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
            if (!isfinite(l->prm[i]) || l->prm[i] < 0.0) {
                return 0;
            }
        }
        return 1;
    }
    return 0;
}

static int same_vec(const double *a, const double *b, int32_t n)
{
    return n <= 0 || memcmp(a, b, (size_t)n * sizeof(double)) == 0;
}

static int same_res(const vf_nd_result *a, const vf_nd_result *b)
{
    return a->zone == b->zone && a->stages == b->stages && a->q == b->q && a->p1 == b->p1
           && a->p2 == b->p2 && fz_same_bits(a->d1, b->d1) && fz_same_bits(a->d2, b->d2)
           && a->m == b->m;
}

/* The documented stop result, bit for bit (+0.0 distances and velocity). */
static int is_stop(const vf_nd_result *r, const double *out, int32_t dim)
{
    vf_nd_result s;
    int32_t k;
    memset(&s, 0, sizeof s);
    s.zone = VF_ND_ZONE_INVALID;
    s.stages = VF_ND_STAGE_STOP;
    s.p1 = s.p2 = -1;
    if (out != NULL) {
        for (k = 0; k < dim; k++) {
            if (!fz_same_bits(out[k], 0.0)) {
                return 0;
            }
        }
    }
    return same_res(r, &s);
}

/* The Euclidean norm, scaled by the largest entry (no overflow for finite x). */
static double norm(const double *x, int32_t n)
{
    double s = 0.0, big = 0.0;
    int32_t k;
    for (k = 0; k < n; k++) {
        big = fabs(x[k]) > big ? fabs(x[k]) : big;
    }
    if (!(big > 0.0) || !isfinite(big)) {
        return big;
    }
    for (k = 0; k < n; k++) {
        s += (x[k] / big) * (x[k] / big);
    }
    return big * sqrt(s);
}

typedef struct law_bufs {
    vf_nd_scratch s;
    size_t nd, ni;
} law_bufs;

static void bufs_alloc(law_bufs *b, int32_t nf, int32_t dim)
{
    b->nd = vf_nd_law_doubles(nf, dim);
    b->ni = vf_nd_law_ints(nf, dim);
    b->s.dbl = (double *)malloc(b->nd * sizeof(double));
    b->s.ints = (int32_t *)malloc(b->ni * sizeof(int32_t));
}

static void bufs_fill(law_bufs *b, int byte)
{
    memset(b->s.dbl, byte, b->nd * sizeof(double));
    memset(b->s.ints, byte, b->ni * sizeof(int32_t));
}

static void bufs_free(law_bufs *b)
{
    free(b->s.dbl);
    free(b->s.ints);
}

static void check_state(const fz_nd_polytope *g, const vf_nd_law *l, const double *p,
                        const double *v, double *out, vf_nd_result *res, int *rc_out)
{
    const vf_nd_polytope *P = &g->poly;
    const int32_t dim = P->dim, nf = P->nf;
    const int32_t allowed = VF_ND_STAGE_SPRING | VF_ND_STAGE_PROJECT | VF_ND_STAGE_RELAXED
                            | VF_ND_STAGE_STOP | VF_ND_STAGE_SCALED;
    law_bufs b;
    int32_t *active = (int32_t *)malloc((size_t)(dim + 1) * sizeof(int32_t));
    int32_t *active2 = (int32_t *)malloc((size_t)(dim + 1) * sizeof(int32_t));
    double *out2 = fz_alloc(dim);
    vf_nd_result r2;
    int rc, rc2, finite_in = 1;
    int32_t k, a;
    bufs_alloc(&b, nf, dim);
    bufs_fill(&b, 0xff); /* NaN garbage */
    memset(active, 0xa5, (size_t)(dim + 1) * sizeof(int32_t));
    memset(out, 0xa5, (size_t)dim * sizeof(double));
    memset(res, 0xa5, sizeof *res);
    rc = vf_nd_shape(P, l, p, v, out, active, &b.s, res);
#ifdef VF_FUZZ_CONTROL_TAMPER
    /* The liveness control of the tests: a result the contract must refuse (never in a real run). */
    if (rc == VF_ND_OK) {
        out[0] = NAN;
    }
#endif
    for (k = 0; k < dim; k++) {
        finite_in = finite_in && isfinite(p[k]) && isfinite(v[k]);
    }
    if (rc != VF_ND_OK && rc != VF_ND_ERR_NONFINITE && rc != VF_ND_ERR_OVERFLOW) {
        fail("vf_nd_shape: code outside {OK, NONFINITE, OVERFLOW}", p, v, out, res, rc);
    }
    if ((rc == VF_ND_ERR_NONFINITE) != !finite_in) {
        fail("vf_nd_shape: VF_ND_ERR_NONFINITE not exactly for non-finite input", p, v, out, res,
             rc);
    }
    if (rc != VF_ND_OK) {
        if (!is_stop(res, out, dim)) {
            fail("vf_nd_shape: an error code without the documented stop result", p, v, out, res,
                 rc);
        }
    } else {
        const double *dist, *bnd;
        const int32_t *work;
        int inside = 1;
        double on = norm(out, dim), vn = norm(v, dim);
        for (k = 0; k < dim; k++) {
            if (!isfinite(out[k])) {
                fail("VF_ND_OK with a non-finite velocity", p, v, out, res, rc);
            }
        }
        if (res->zone < VF_ND_ZONE_FREE || res->zone > VF_ND_ZONE_OUTSIDE_CORNER) {
            fail("VF_ND_OK with a zone outside 0..4", p, v, out, res, rc);
        }
        if ((res->stages & ~allowed) != 0) {
            fail("VF_ND_OK with a stage bit the law never sets", p, v, out, res, rc);
        }
        if (res->q < 0 || res->q > dim + 1 || res->m < 0 || res->m > nf) {
            fail("VF_ND_OK with q outside 0..dim+1 or m outside 0..nf", p, v, out, res, rc);
        }
        for (a = 0; a < res->q; a++) {
            if (active[a] < 0 || active[a] >= nf) {
                fail("VF_ND_OK with a binding facet out of range", p, v, out, res, rc);
            }
        }
        if (res->p1 < 0 || res->p1 >= nf || res->p2 < -1 || res->p2 >= nf
            || res->p2 == res->p1) {
            fail("VF_ND_OK with p1/p2 not the nearest facets (p2 -1: none)", p, v, out, res, rc);
        }
        if (!isfinite(res->d1) || !(isfinite(res->d2) || (res->d2 == INFINITY && res->p2 == -1 && nf == 1))) {
            fail("VF_ND_OK with non-finite distances d1/d2 (d2 = +inf only when absent)", p, v,
                 out, res, rc);
        }
        if (l->idt == 0.0 && res->zone == VF_ND_ZONE_FREE && !same_vec(out, v, dim)) {
            fail("zone FREE but the command was changed", p, v, out, res, rc);
        }
        vf_nd_bounded(P, &b.s, &dist, &bnd, &work);
        for (a = 0; a < res->m; a++) {
            if (work[a] < 0 || work[a] >= nf) {
                fail("a bounded facet (vf_nd_bounded) out of range", p, v, out, res, rc);
            }
        }
        for (a = 0; a < nf; a++) {
            if (dist[a] < 0.0) {
                inside = 0;
            }
        }
        /* relaxed: bnd holds the slowed recovery bounds, every other bound as stated */
        if (g->structured && !(res->stages & VF_ND_STAGE_STOP)) {
            for (a = 0; a < res->m; a++) {
                int32_t e = work[a];
                double s = 0.0, tol;
                if (isnan(bnd[e]) || bnd[e] == -INFINITY) {
                    continue; /* -inf: no bound; NaN (inf - inf of huge parameters): not a bound
                                 the law can state (as fuzz_exact) */
                }
                for (k = 0; k < dim; k++) {
                    s += P->N[(size_t)e * dim + k] * out[k];
                }
                tol = 1e-9 * (1.0 + fabs(bnd[e]) + on + vn);
                if (!(s >= bnd[e] - tol)) {
                    fprintf(stderr, "facet %d: d=%.17g bound %.17g, N.out=%.17g, tol=%.3g\n",
                            (int)e, dist[e], bnd[e], s, tol);
                    fail("the n-D law's bound N_e . out >= bnd_e is violated", p, v, out, res, rc);
                }
            }
        }
        if (g->structured && inside && !(on <= vn * (1.0 + 1e-9) + 1e-300)) {
            fprintf(stderr, "|out| = %.17g > |v| = %.17g\n", on, vn);
            fail("inside, the n-D law sped up (|out| > |v|)", p, v, out, res, rc);
        }
    }
    /* again with a zeroed scratch: identical bits */
    bufs_fill(&b, 0);
    memset(active2, 0x5a, (size_t)(dim + 1) * sizeof(int32_t));
    memset(&r2, 0x5a, sizeof r2);
    rc2 = vf_nd_shape(P, l, p, v, out2, active2, &b.s, &r2);
    if (rc2 != rc || !same_res(res, &r2) || !same_vec(out, out2, dim)
        || (rc == VF_ND_OK && res->q > 0
            && memcmp(active, active2, (size_t)res->q * sizeof(int32_t)) != 0)) {
        fail("vf_nd_shape: a second call (other scratch contents) differs", p, v, out, res, rc);
    }
    if (rc == VF_ND_OK) {
        memset(&r2, 0x5a, sizeof r2);
        vf_nd_kernel(P, l, p, v, out2, active2, &b.s, &r2);
        if (!same_res(res, &r2) || !same_vec(out, out2, dim)) {
            fail("vf_nd_shape differs from vf_nd_kernel under VF_ND_OK", p, v, out, res, rc);
        }
    }
    bufs_free(&b);
    free(active);
    free(active2);
    free(out2);
    *rc_out = rc;
}

/* One NULL-pointer case of the law's entry points. */
static void law_null_case(fz_reader *rd, const vf_nd_polytope *P, const vf_nd_law *l)
{
    uint8_t sel = fz_byte(rd);
    const int32_t dim = P->dim;
    law_bufs b;
    vf_nd_polytope q = *P;
    const vf_nd_polytope *pp = &q;
    const vf_nd_law *ll = l;
    vf_nd_scratch sc, *ss = &sc;
    vf_nd_result r, *rr = &r;
    double *pv = fz_alloc(dim), *vv = fz_alloc(dim), *out = fz_alloc(dim);
    int32_t *active = (int32_t *)malloc((size_t)(dim + 1) * sizeof(int32_t));
    const double *PP = pv, *VV = vv;
    double *OO = out;
    int32_t *AA = active;
    int64_t zones[1] = {7}, rb;
    int32_t k, what = (sel >> 2) % 13;
    int rc;
    bufs_alloc(&b, P->nf, dim);
    sc = b.s;
    for (k = 0; k < dim; k++) {
        pv[k] = 0.0;
        vv[k] = 1.0;
        out[k] = 7.0;
    }
    switch (what) {
    case 0: pp = NULL; break;
    case 1: ll = NULL; break;
    case 2: q.N = NULL; break;
    case 3: q.off = NULL; break;
    case 4: q.cen = NULL; break;
    case 5: ss = NULL; break;
    case 6: sc.dbl = NULL; break;
    case 7: sc.ints = NULL; break;
    case 8: PP = NULL; break;
    case 9: VV = NULL; break;
    case 10: OO = NULL; break;
    case 11: AA = NULL; break;
    default: rr = NULL; break;
    }
    switch (sel % 3) {
    case 0:
        if (what <= 4 && vf_nd_check(pp, ll) != VF_ND_ERR_NULL) {
            fail_simple("vf_nd_check with a NULL pointer: not VF_ND_ERR_NULL");
        }
        break;
    case 1:
        memset(&r, 0xa5, sizeof r);
        rc = vf_nd_shape(pp, ll, PP, VV, OO, AA, ss, rr);
        if (rc != VF_ND_ERR_NULL
            || (rr != NULL && !is_stop(rr, (OO != NULL && pp != NULL) ? OO : NULL, dim))) {
            fail_simple("vf_nd_shape with a NULL pointer: not VF_ND_ERR_NULL with the stop result");
        }
        break;
    default:
        if (what == 11 || what == 12) {
            break; /* the batch has its own active array and result */
        }
        rb = vf_nd_batch(pp, ll, PP, VV, 1, OO, zones, ss);
        for (k = 0; k < dim; k++) {
            if (out[k] != 7.0) {
                rb = 1; /* written */
            }
        }
        if (rb != VF_ND_ERR_NULL || zones[0] != 7) {
            fprintf(stderr, "NULL pointer case %d: batch returned %lld\n", (int)what,
                    (long long)rb);
            fail_simple("vf_nd_batch with a NULL pointer: not VF_ND_ERR_NULL, or it wrote");
        }
        break;
    }
    bufs_free(&b);
    free(pv);
    free(vv);
    free(out);
    free(active);
}

static void law_case(fz_reader *rd, uint8_t flags)
{
    fz_nd_polytope g;
    vf_nd_law law;
    int rc, valid;
    read_polytope(rd, &g);
    read_law(rd, &law);
    cur_poly = &g;
    cur_law = &law;
    rc = vf_nd_check(&g.poly, &law);
    if (rc != VF_ND_OK && rc != VF_ND_ERR_ARGUMENT && rc != VF_ND_ERR_NULL) {
        fail_simple("vf_nd_check: code outside {OK, NULL, ARGUMENT}");
    }
    valid = valid_by_rules(&g.poly, &law);
    if ((rc == VF_ND_OK) != valid) {
        fprintf(stderr, "check rc=%d, the rules say %s\n", rc, valid ? "valid" : "invalid");
        fail_simple("vf_nd_check disagrees with the rules");
    }
    if (rc == VF_ND_OK && (flags & 0x80)) {
        law_null_case(rd, &g.poly, &law);
    } else if (rc == VF_ND_OK) {
        const int32_t dim = g.poly.dim;
        double *Pm, *Vm, *outs, *bout, *bout2;
        vf_nd_result *res;
        int *rcs;
        int64_t *zones, bad = 0, rb;
        size_t count = 0, k;
        law_bufs b;
        double buf[FZ_ND_STATES * 2 * 8]; /* raw polytopes: dim up to 7 */
        while (rd->left > 0 && count < FZ_ND_STATES) {
            for (k = 0; k < 2 * (size_t)dim; k++) {
                buf[count * 2 * dim + k] = fz_double(rd);
            }
            count++;
        }
        Pm = fz_alloc((int32_t)(count * dim));
        Vm = fz_alloc((int32_t)(count * dim));
        for (k = 0; k < count * dim; k++) {
            Pm[k] = buf[(k / dim) * 2 * dim + k % dim];
            Vm[k] = buf[(k / dim) * 2 * dim + dim + k % dim];
        }
        outs = fz_alloc((int32_t)(count * dim));
        bout = fz_alloc((int32_t)(count * dim));
        bout2 = fz_alloc((int32_t)(count * dim));
        res = (vf_nd_result *)malloc((count > 0 ? count : 1) * sizeof(vf_nd_result));
        rcs = (int *)malloc((count > 0 ? count : 1) * sizeof(int));
        zones = (int64_t *)malloc((count > 0 ? count : 1) * sizeof(int64_t));
        for (k = 0; k < count; k++) {
            check_state(&g, &law, Pm + k * dim, Vm + k * dim, outs + k * dim, &res[k], &rcs[k]);
            bad += rcs[k] != VF_ND_OK;
        }
        bufs_alloc(&b, g.poly.nf, dim);
        bufs_fill(&b, 0xff);
        rb = vf_nd_batch(&g.poly, &law, Pm, Vm, count, bout, zones, &b.s);
        if (rb != bad) {
            fprintf(stderr, "batch returned %lld, single calls had %lld errors\n", (long long)rb,
                    (long long)bad);
            fail_simple("vf_nd_batch: count of invalid rows");
        }
        for (k = 0; k < count; k++) {
            if (!same_vec(bout + k * dim, outs + k * dim, dim) || zones[k] != res[k].zone) {
                fail("vf_nd_batch: a row differs from the single call", Pm + k * dim,
                     Vm + k * dim, outs + k * dim, &res[k], rcs[k]);
            }
        }
        rb = vf_nd_batch(&g.poly, &law, Pm, Vm, count, bout2, NULL, &b.s);
        if (rb != bad || !same_vec(bout, bout2, (int32_t)(count * dim))) {
            fail_simple("vf_nd_batch with zones NULL differs");
        }
        bufs_free(&b);
        free(Pm);
        free(Vm);
        free(outs);
        free(bout);
        free(bout2);
        free(res);
        free(rcs);
        free(zones);
    }
    free_polytope(&g);
}

/* ------------------------------------------------------------------ the projection */

typedef struct fz_proj {
    int32_t m, n;
    double *G, *b, *u;
    int structured;
} fz_proj;

static const fz_proj *cur_proj;

static void fail_proj(const char *what, int rc, const double *x, int32_t q, int32_t iters,
                      int32_t status)
{
    const fz_proj *pr = cur_proj;
    int32_t i;
    fprintf(stderr, "\n*** velfence_nd contract violated (projection): %s\n", what);
    fprintf(stderr, "m=%d n=%d structured=%d\n", (int)pr->m, (int)pr->n, pr->structured);
    if (pr->n > 0) {
        fz_print_vec("u", pr->u, pr->n);
        for (i = 0; i < pr->m; i++) {
            fprintf(stderr, "row %d: b=%.17g ", (int)i, pr->b[i]);
            fz_print_vec("G", pr->G + (size_t)i * pr->n, pr->n);
        }
    }
    fprintf(stderr, "rc=%d q=%d iters=%d status=%d\n", rc, (int)q, (int)iters, (int)status);
    if (x != NULL && pr->n > 0) {
        fz_print_vec("x", x, pr->n);
    }
    abort();
}

static void read_proj(fz_reader *r, fz_proj *pr)
{
    uint8_t mode = fz_byte(r);
    int32_t i, k, cells;
    memset(pr, 0, sizeof *pr);
    if (mode & 1) {
        pr->n = (int8_t)fz_byte(r) % 10;
        pr->m = (int8_t)fz_byte(r) % 26;
    } else {
        pr->n = 1 + fz_byte(r) % 8;
        pr->m = fz_byte(r) % 24;
        pr->structured = 1;
    }
    cells = pr->m > 0 && pr->n > 0 ? pr->m * pr->n : 0;
    pr->G = fz_alloc(cells);
    pr->b = fz_alloc(pr->m);
    pr->u = fz_alloc(pr->n);
    if (pr->structured) {
        double x0[8];
        for (k = 0; k < pr->n; k++) {
            x0[k] = (double)fz_i16(r) / 8192.0;
        }
        for (i = 0; i < pr->m; i++) {
            double s = 0.0;
            uint8_t kind;
            for (k = 0; k < pr->n; k++) {
                double gk = (double)fz_i16(r) / 8192.0;
                pr->G[(size_t)i * pr->n + k] = gk;
                s += gk * x0[k];
            }
            kind = fz_byte(r);
            pr->b[i] = kind == 255 ? -INFINITY : s - kind / 64.0;
        }
        for (k = 0; k < pr->n; k++) {
            pr->u[k] = fz_double(r);
        }
    } else {
        for (i = 0; i < cells; i++) {
            pr->G[i] = fz_double(r);
        }
        for (i = 0; i < pr->m; i++) {
            pr->b[i] = fz_double(r);
        }
        for (k = 0; k < pr->n; k++) {
            pr->u[k] = fz_double(r);
        }
    }
}

static void proj_null_case(fz_reader *rd, const fz_proj *pr)
{
    uint8_t sel = fz_byte(rd);
    const int32_t n = pr->n, m = pr->m;
    double *x = fz_alloc(n), *lam = fz_alloc(n + 1);
    double *wsf = (double *)malloc(vf_nd_project_doubles(m, n) * sizeof(double) + 1);
    int32_t *act = (int32_t *)malloc((size_t)(n + 1) * sizeof(int32_t));
    int32_t q = 5, it = 5, st = 9, k;
    const double *uu = pr->u, *GG = pr->G, *bb = pr->b;
    double *xx = x, *ll = lam, *ww = wsf;
    int32_t *aa = act, *qq = &q, *ii = &it, *ss = &st;
    int rc;
    for (k = 0; k < n; k++) {
        x[k] = 7.0;
    }
    switch (sel % 10) {
    case 0: uu = NULL; break;
    case 1: GG = m > 0 ? NULL : GG; break;
    case 2: bb = m > 0 ? NULL : bb; break;
    case 3: xx = NULL; break;
    case 4: ll = NULL; break;
    case 5: aa = NULL; break;
    case 6: ww = NULL; break;
    case 7: qq = NULL; break;
    case 8: ii = NULL; break;
    default: ss = NULL; break;
    }
    if ((sel % 10 == 1 || sel % 10 == 2) && m == 0) {
        goto done;
    }
    rc = vf_nd_project(uu, GG, bb, m, n, xx, ll, aa, ww, qq, ii, ss);
    if (rc != VF_ND_ERR_NULL) {
        fail_proj("vf_nd_project with a NULL pointer: not VF_ND_ERR_NULL", rc, NULL, q, it, st);
    }
    for (k = 0; k < n && xx != NULL; k++) {
        if (!fz_same_bits(x[k], 0.0)) {
            fail_proj("vf_nd_project with a NULL pointer: x not 0", rc, x, q, it, st);
        }
    }
    if ((qq != NULL && q != 0) || (ii != NULL && it != 0)
        || (ss != NULL && st != VF_ND_PROJECT_INFEASIBLE)) {
        fail_proj("vf_nd_project with a NULL pointer: q, iters, status not 0, 0, INFEASIBLE", rc,
                  NULL, q, it, st);
    }
done:
    free(x);
    free(lam);
    free(wsf);
    free(act);
}

static void proj_case(fz_reader *rd, uint8_t flags)
{
    fz_proj pr;
    int32_t n, m, i, k, q, it, st, q2, it2, st2;
    double *x, *x2, *lam, *lam2, *wsf;
    int32_t *act, *act2;
    size_t nw;
    int rc, rc2, expect = VF_ND_OK;
    read_proj(rd, &pr);
    cur_proj = &pr;
    n = pr.n;
    m = pr.m;
    if (n >= 1 && m >= 0 && (flags & 0x80)) {
        proj_null_case(rd, &pr);
        goto done;
    }
    if (n < 1 || m < 0) {
        expect = VF_ND_ERR_ARGUMENT;
    } else {
        for (i = 0; i < m * n; i++) {
            if (!isfinite(pr.G[i])) {
                expect = VF_ND_ERR_ARGUMENT;
            }
        }
        if (expect == VF_ND_OK) {
            for (k = 0; k < n; k++) {
                if (!isfinite(pr.u[k])) {
                    expect = VF_ND_ERR_NONFINITE;
                }
            }
            for (i = 0; i < m; i++) {
                if (isnan(pr.b[i]) || pr.b[i] == INFINITY) {
                    expect = VF_ND_ERR_NONFINITE;
                }
            }
        }
    }
    nw = vf_nd_project_doubles(m, n);
    x = fz_alloc(n);
    x2 = fz_alloc(n);
    lam = fz_alloc(n + 1);
    lam2 = fz_alloc(n + 1);
    wsf = (double *)malloc(nw > 0 ? nw * sizeof(double) : 1);
    act = (int32_t *)malloc((size_t)(n + 1 > 0 ? n + 1 : 1) * sizeof(int32_t));
    act2 = (int32_t *)malloc((size_t)(n + 1 > 0 ? n + 1 : 1) * sizeof(int32_t));
    memset(x, 0xa5, (size_t)(n > 0 ? n : 0) * sizeof(double));
    memset(wsf, 0xff, nw * sizeof(double));
    q = it = st = -77;
    rc = vf_nd_project(pr.u, pr.G, pr.b, m, n, x, lam, act, wsf, &q, &it, &st);
    if (rc != VF_ND_OK && rc != VF_ND_ERR_ARGUMENT && rc != VF_ND_ERR_NONFINITE
        && rc != VF_ND_ERR_OVERFLOW) {
        fail_proj("vf_nd_project: code outside {OK, ARGUMENT, NONFINITE, OVERFLOW}", rc, x, q, it,
                  st);
    }
    if (expect != VF_ND_OK ? rc != expect : (rc != VF_ND_OK && rc != VF_ND_ERR_OVERFLOW)) {
        fprintf(stderr, "expected code %d\n", expect);
        fail_proj("vf_nd_project: the code is not the documented one", rc, x, q, it, st);
    }
    if (rc != VF_ND_OK) {
        for (k = 0; k < n; k++) {
            if (!fz_same_bits(x[k], 0.0)) {
                fail_proj("vf_nd_project: an error without x = 0", rc, x, q, it, st);
            }
        }
        if (q != 0 || it != 0 || st != VF_ND_PROJECT_INFEASIBLE) {
            fail_proj("vf_nd_project: an error without q = iters = 0, status INFEASIBLE", rc, x,
                      q, it, st);
        }
        goto freeing;
    }
    for (k = 0; k < n; k++) {
        if (!isfinite(x[k])) {
            fail_proj("vf_nd_project: VF_ND_OK with a non-finite x", rc, x, q, it, st);
        }
    }
    if (st != VF_ND_PROJECT_OPTIMAL && st != VF_ND_PROJECT_INFEASIBLE
        && st != VF_ND_PROJECT_ITERATION_LIMIT) {
        fail_proj("vf_nd_project: status outside the three", rc, x, q, it, st);
    }
    if (q < 0 || q > n + 1 || it < 0) {
        fail_proj("vf_nd_project: q outside 0..n+1 or negative iterations", rc, x, q, it, st);
    }
    for (i = 0; i < q; i++) {
        if (act[i] < 0 || act[i] >= m) {
            fail_proj("vf_nd_project: an active row out of range", rc, x, q, it, st);
        }
    }
    if (pr.structured && st == VF_ND_PROJECT_OPTIMAL) {
        double xn = norm(x, n), un = norm(pr.u, n);
        for (i = 0; i < m; i++) {
            const double *g = pr.G + (size_t)i * n;
            double s = 0.0, tol, gn;
            if (pr.b[i] == -INFINITY) {
                continue;
            }
            for (k = 0; k < n; k++) {
                s += g[k] * x[k];
            }
            gn = norm(g, n);
            tol = 1e-9 * (fabs(pr.b[i]) + (gn > 0.0 ? gn * (xn + un) : 0.0)) + 1e-300;
            if (!(s >= pr.b[i] - tol)) {
                fprintf(stderr, "row %d: G.x = %.17g < b = %.17g (tol %.3g)\n", (int)i, s,
                        pr.b[i], tol);
                fail_proj("vf_nd_project: OPTIMAL but a constraint G_i . x >= b_i is violated", rc,
                          x, q, it, st);
            }
        }
    }
    memset(wsf, 0, nw * sizeof(double));
    rc2 = vf_nd_project(pr.u, pr.G, pr.b, m, n, x2, lam2, act2, wsf, &q2, &it2, &st2);
    if (rc2 != rc || q2 != q || it2 != it || st2 != st || !same_vec(x, x2, n)
        || !same_vec(lam, lam2, q) || (q > 0 && memcmp(act, act2, (size_t)q * sizeof(int32_t)))) {
        fail_proj("vf_nd_project: a second call (other scratch contents) differs", rc, x, q, it,
                  st);
    }
freeing:
    free(x);
    free(x2);
    free(lam);
    free(lam2);
    free(wsf);
    free(act);
    free(act2);
done:
    free(pr.G);
    free(pr.b);
    free(pr.u);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader rd = {data, size};
    uint8_t flags = fz_byte(&rd);
    if (flags & 0x40) {
        proj_case(&rd, flags);
    } else {
        law_case(&rd, flags);
    }
    return 0;
}
