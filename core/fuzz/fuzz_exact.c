/*
 * fuzz_exact.c -- libFuzzer target of the exact law's checked API: vf_exact_check, vf_exact_shape,
 * vf_exact_batch (core/include/velfence_core.h). Build: core/fuzz/build.sh. Input layout:
 *
 *   flags byte | polygon (fuzz_common.h) | law | states (px, py, vx, vy), the rest of the bytes
 *   law: kind selector byte (0, 1: LINEAR; 2: THREE_ZONE; 3: a raw int32), 6 doubles prm,
 *        relax byte, idt selector byte (even: 0, odd: a double follows)
 *   flags bit 7: instead of states, one NULL-pointer case (a selector byte follows the law)
 *
 * Asserted (abort() on a violation, after printing the decoded input):
 *   vf_exact_check returns VF_OK, VF_ERR_NULL or VF_ERR_ARGUMENT, and VF_OK exactly when the
 *     data meets the header's rules (n >= 3, finite polygon data, a known kind, idt finite >= 0,
 *     no NaN parameter; linear: d_max > 0, k >= 0, r_max >= 0; three-zone: all finite >= 0);
 *   on checked data, per state: vf_exact_shape's code is VF_OK, VF_ERR_NONFINITE (exactly for
 *     non-finite input) or VF_ERR_OVERFLOW; on an error *out is the stop result bit for bit; on
 *     VF_OK every field is finite (d1/d2: see VF_FUZZ_STRICT_AUX_DISTANCES), sx = sy = 0, the
 *     zone is 0..4 and is "outside"/"outside-corner" exactly when some signed distance is < 0,
 *     primary/secondary are two edges, d1 is the smallest signed distance (bit for bit) and d2
 *     the distance of the secondary edge, only the exact law's stage bits are set; the result is
 *     bit-identical with a scratch full of NaN garbage and with a zeroed one (no read of stale
 *     scratch) and to vf_exact_kernel's;
 *   the law's bounds (docs/derivations.md section 3, 3.1, 3.3), on polygons built from corners
 *     (unit normals): linear kind, every state (relaxed: the violated edges' L_i read as 0, the
 *     recovery slowed but never outward; the bounds of edges the point is inside kept): n_i . v_o >= L_i - tol for
 *     every edge, with L_i the documented bound; three-zone kind, states inside; inside (every
 *     d_i >= 0) also |v_o| <= |v| (never faster inside); tol = 1e-12 (|v| + R) + 1e-12 |L_i|;
 *   vf_exact_batch returns the number of non-VF_OK states and writes the single calls' ox, oy and
 *     zones; with zones NULL the same velocities;
 *   NULL pointers (flags bit 7; any one of poly, law, nx, ny, off, scratch and its three arrays,
 *     out, P, V): VF_ERR_NULL from the entry points that read it, with the stop result from
 *     vf_exact_shape and nothing written by vf_exact_batch.
 */
#include "fuzz_common.h"

static const fz_polygon *cur_poly;
static const vf_exact_law *cur_law;

static void print_law(void)
{
    const vf_exact_law *l = cur_law;
    fprintf(stderr, "exact law kind=%d relax=%d idt=%.17g prm=(%.17g, %.17g, %.17g, %.17g, %.17g, %.17g)\n",
            (int)l->kind, (int)l->relax, l->idt, l->prm[0], l->prm[1], l->prm[2], l->prm[3],
            l->prm[4], l->prm[5]);
}

static void fail(const char *what, double px, double py, double vx, double vy, int rc,
                 const vf_result *r)
{
    fprintf(stderr, "\n*** velfence_core contract violated (exact law): %s\n", what);
    print_law();
    fz_print_polygon(&cur_poly->poly);
    fprintf(stderr, "state px=%.17g py=%.17g vx=%.17g vy=%.17g\n", px, py, vx, vy);
    if (r != NULL) {
        fz_print_result("result", rc, r);
    }
    abort();
}

static void fail_simple(const char *what)
{
    fail(what, 0.0, 0.0, 0.0, 0.0, 0, NULL);
}

static void read_law(fz_reader *r, vf_exact_law *law)
{
    uint8_t k = fz_byte(r);
    int i;
    memset(law, 0, sizeof *law);
    switch (k % 4) {
    case 0:
    case 1: law->kind = VF_PROFILE_LINEAR; break;
    case 2: law->kind = VF_PROFILE_THREE_ZONE; break;
    default: {
        uint32_t hi = (uint16_t)fz_i16(r);
        uint32_t lo = (uint16_t)fz_i16(r);
        law->kind = (int32_t)(hi << 16 | lo);
        break;
    }
    }
    for (i = 0; i < VF_PROFILE_PARAMS; i++) {
        law->prm[i] = fz_double(r);
    }
    law->relax = fz_byte(r) & 1;
    law->idt = (fz_byte(r) & 1) ? fz_double(r) : 0.0;
}

/* Whether the header's rules accept the data (the check must say VF_OK exactly then). */
static int valid_by_header(const vf_polygon *p, const vf_exact_law *l)
{
    int32_t e;
    int i;
    if (p->n < 3 || !isfinite(p->cx) || !isfinite(p->cy)) {
        return 0;
    }
    for (e = 0; e < p->n; e++) {
        if (!isfinite(p->nx[e]) || !isfinite(p->ny[e]) || !isfinite(p->off[e])) {
            return 0;
        }
    }
    if (!isfinite(l->idt) || l->idt < 0.0) {
        return 0;
    }
    for (i = 0; i < VF_PROFILE_PARAMS; i++) {
        if (isnan(l->prm[i])) {
            return 0;
        }
    }
    if (l->kind == VF_PROFILE_LINEAR) {
        return l->prm[0] > 0.0 && l->prm[1] >= 0.0 && l->prm[2] >= 0.0;
    }
    if (l->kind == VF_PROFILE_THREE_ZONE) {
        for (i = 0; i < VF_PROFILE_PARAMS; i++) {
            if (!isfinite(l->prm[i]) || l->prm[i] < 0.0) {
                return 0;
            }
        }
        return 1;
    }
    return 0;
}

/* _kernels.profile_cap of the three-zone kind (independent of the speed). */
static double three_zone_cap(const double *prm, double d)
{
    double a = fabs(d);
    if (a > prm[5]) {
        return copysign(prm[1], d);
    }
    if (a > prm[3]) {
        return copysign(sqrt(2.0 * prm[2] * fabs(a - prm[4])), d);
    }
    return prm[0] * d;
}

/* The documented bounds n_i . v_o >= L_i and |v_o| <= |v| inside (derivations section 3). */
static void check_bounds(const vf_polygon *p, const vf_exact_law *l, double px, double py,
                         double vx, double vy, const vf_result *r)
{
    const double idt = l->idt;
    double vn = hypot(vx, vy), R = 0.0, dmin = INFINITY, tol, on;
    int32_t e;
    int lin = l->kind == VF_PROFILE_LINEAR;
    const int relaxed = (r->stages & VF_STAGE_RELAXED) != 0;
    if (r->stages & VF_STAGE_STOP) {
        return; /* zero velocity */
    }
    for (e = 0; e < p->n; e++) {
        double d = fz_dist(p, e, px, py);
        if (d < dmin) {
            dmin = d;
        }
        if (d < 0.0 && lin) {
            double rr = l->prm[1] * -d;
            if (rr > l->prm[2]) {
                rr = l->prm[2];
            }
            if (idt > 0.0 && rr > -d * idt) {
                rr = -d * idt;
            }
            if (rr > R) {
                R = rr;
            }
        }
    }
    if (!lin && dmin < 0.0) {
        return; /* three-zone: checked inside only */
    }
    for (e = 0; e < p->n; e++) {
        double d = fz_dist(p, e, px, py), L, s;
        if (lin) {
            if (d < 0.0) {
                L = l->prm[1] * -d;
                if (L > l->prm[2]) {
                    L = l->prm[2];
                }
                if (idt > 0.0 && L > -d * idt) {
                    L = -d * idt;
                }
            } else if (l->relax || d < l->prm[0]) {
                s = l->relax ? vn + R : vn;
                L = -(s * (d / l->prm[0]));
                if (idt > 0.0 && -d * idt > L) {
                    L = -d * idt;
                }
            } else if (idt > 0.0) {
                L = -d * idt; /* a profile past d_max: only the one-period bound */
            } else {
                continue;
            }
        } else {
            L = -three_zone_cap(l->prm, d);
            if (idt > 0.0 && -d * idt > L) {
                L = -d * idt;
            }
        }
        if (!isfinite(L)) {
            continue; /* -inf: no bound; NaN (inf * 0): not a bound the law can state */
        }
        if (relaxed && d < 0.0) {
            L = 0.0; /* infeasible together: the recovery was slowed, never outward (documented) */
        }
        tol = 1e-12 * (vn + R) + 1e-12 * fabs(L) + 1e-300;
        if (!(p->nx[e] * r->ox + p->ny[e] * r->oy >= L - tol)) {
            fprintf(stderr, "edge %d: d=%.17g bound L=%.17g, n.v_o=%.17g, tol=%.3g\n", (int)e, d,
                    L, p->nx[e] * r->ox + p->ny[e] * r->oy, tol);
            fail("the exact law's bound n_i . v_o >= L_i is violated", px, py, vx, vy, VF_OK, r);
        }
    }
    on = hypot(r->ox, r->oy);
    if (dmin >= 0.0 && !(on <= vn * (1.0 + 1e-12) + 1e-300)) {
        fprintf(stderr, "|v_o| = %.17g > |v| = %.17g\n", on, vn);
        fail("inside, the exact law sped up (|v_o| > |v|)", px, py, vx, vy, VF_OK, r);
    }
}

static void check_state(const vf_polygon *p, const vf_exact_law *l, int structured, double px,
                        double py, double vx, double vy, vf_result *res, int *rc_out)
{
    const int32_t n = p->n;
    double *dist = fz_alloc(n), *bnd = fz_alloc(n);
    int32_t *work = (int32_t *)malloc((size_t)n * sizeof(int32_t));
    vf_scratch s = {dist, bnd, work};
    vf_result r2, rk;
    int rc, rc2;
    const int32_t allowed = VF_STAGE_PROJECT | VF_STAGE_SPRING | VF_STAGE_RELAXED | VF_STAGE_STOP;
    memset(dist, 0xff, (size_t)n * sizeof(double)); /* NaN garbage */
    memset(bnd, 0xff, (size_t)n * sizeof(double));
    memset(work, 0xff, (size_t)n * sizeof(int32_t));
    memset(res, 0xa5, sizeof *res); /* every field must be written */
    rc = vf_exact_shape(p, l, px, py, vx, vy, &s, res);
#ifdef VF_FUZZ_CONTROL_TAMPER
    /* The liveness control of the tests: a result the contract must refuse (never in a real run). */
    if (rc == VF_OK) {
        res->ox = NAN;
    }
#endif
    if (fz_common_contract("exact", p, px, py, vx, vy, rc, res, allowed, fail)) {
        double dmin = INFINITY;
        int32_t e;
        for (e = 0; e < n; e++) {
            double d = fz_dist(p, e, px, py);
            if (d < dmin) {
                dmin = d;
            }
        }
        if (res->sx != 0.0 || res->sy != 0.0) {
            fail("exact law: sx/sy not 0", px, py, vx, vy, rc, res);
        }
        if (!fz_same_bits(res->d1, dmin)) {
            fail("exact law: d1 is not the smallest signed distance", px, py, vx, vy, rc, res);
        }
        if ((res->zone >= VF_ZONE_OUTSIDE) != (dmin < 0.0)) {
            fail("exact law: zone outside/outside-corner not exactly when some d_i < 0", px, py,
                 vx, vy, rc, res);
        }
        if (structured && fz_unit_normals(p)
            && (l->kind == VF_PROFILE_LINEAR || l->kind == VF_PROFILE_THREE_ZONE)) {
            check_bounds(p, l, px, py, vx, vy, res);
        }
    }
    /* the same call with a zeroed scratch: bit-identical (nothing stale is read) */
    memset(dist, 0, (size_t)n * sizeof(double));
    memset(bnd, 0, (size_t)n * sizeof(double));
    memset(work, 0, (size_t)n * sizeof(int32_t));
    memset(&r2, 0x5a, sizeof r2);
    rc2 = vf_exact_shape(p, l, px, py, vx, vy, &s, &r2);
    if (rc2 != rc || !fz_same_result(res, &r2)) {
        fz_print_result("second call", rc2, &r2);
        fail("exact law: a second call (other scratch contents) differs", px, py, vx, vy, rc, res);
    }
    if (rc == VF_OK) {
        vf_exact_kernel(p, l, px, py, vx, vy, &s, &rk);
        if (!fz_same_result(res, &rk)) {
            fz_print_result("kernel", 0, &rk);
            fail("exact law: vf_exact_shape differs from vf_exact_kernel under VF_OK", px, py, vx,
                 vy, rc, res);
        }
    }
    free(dist);
    free(bnd);
    free(work);
    *rc_out = rc;
}

/* One NULL-pointer case: the selector names which pointer is NULL and which entry point sees it.
 * Checks: VF_ERR_NULL; shape writes the stop result (out non-NULL); batch writes nothing. */
static void null_cases(fz_reader *rd, const vf_polygon *p, const vf_exact_law *l)
{
    uint8_t sel = fz_byte(rd);
    const int32_t n = p->n;
    double *dist = fz_alloc(n), *bnd = fz_alloc(n);
    int32_t *work = (int32_t *)malloc((size_t)n * sizeof(int32_t));
    vf_scratch s = {dist, bnd, work};
    vf_polygon q = *p;
    const vf_polygon *pp = &q;
    const vf_exact_law *ll = l;
    vf_scratch *ss = &s;
    vf_result r, *rr = &r;
    double P[2] = {0.0, 0.0}, V[2] = {1.0, 0.0}, out[2] = {7.0, 7.0};
    const double *PP = P, *VV = V;
    double *OO = out;
    int64_t zones[1] = {7};
    int rc;
    int64_t rb;
    switch ((sel >> 3) % 10) { /* the NULL pointer */
    case 0: pp = NULL; break;
    case 1: ll = NULL; break;
    case 2: q.nx = NULL; break;
    case 3: q.ny = NULL; break;
    case 4: q.off = NULL; break;
    case 5: ss = NULL; break;
    case 6: s.dist = NULL; break;
    case 7: s.bnd = NULL; break;
    case 8: s.work = NULL; break;
    default: rr = NULL; break; /* out (shape), P, V or out (batch) */
    }
    switch (sel % 3) { /* the entry point */
    case 0:
        if ((sel >> 3) % 10 > 4) {
            break; /* the check reads neither scratch nor result */
        }
        if (vf_exact_check(pp, ll) != VF_ERR_NULL) {
            fail_simple("vf_exact_check with a NULL pointer: not VF_ERR_NULL");
        }
        break;
    case 1:
        memset(&r, 0xa5, sizeof r);
        rc = vf_exact_shape(pp, ll, 0.25, 0.0, 1.0, 0.0, ss, rr);
        if (rc != VF_ERR_NULL || (rr != NULL && !fz_is_stop(rr))) {
            fail_simple("vf_exact_shape with a NULL pointer: not VF_ERR_NULL with the stop result");
        }
        break;
    default:
        if (rr == NULL) {
            switch (sel % 7) {
            case 0: PP = NULL; break;
            case 1: VV = NULL; break;
            default: OO = NULL; break;
            }
        }
        rb = vf_exact_batch(pp, ll, PP, VV, 1, OO, zones, ss);
        if (rb != VF_ERR_NULL || out[0] != 7.0 || out[1] != 7.0 || zones[0] != 7) {
            fail_simple("vf_exact_batch with a NULL pointer: not VF_ERR_NULL, or it wrote");
        }
        break;
    }
    free(dist);
    free(bnd);
    free(work);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader rd = {data, size};
    uint8_t flags = fz_byte(&rd);
    fz_polygon g;
    vf_exact_law law;
    fz_states st;
    int rc, valid;
    size_t k;
    fz_read_polygon(&rd, &g);
    read_law(&rd, &law);
    cur_poly = &g;
    cur_law = &law;
    if (flags & 0x80) {
        if (g.poly.n >= 3 && vf_exact_check(&g.poly, &law) == VF_OK) {
            null_cases(&rd, &g.poly, &law);
        }
        fz_polygon_free(&g);
        return 0;
    }
    rc = vf_exact_check(&g.poly, &law);
    if (rc != VF_OK && rc != VF_ERR_ARGUMENT && rc != VF_ERR_NULL) {
        fail("vf_exact_check: return code outside {VF_OK, VF_ERR_NULL, VF_ERR_ARGUMENT}", 0, 0,
             0, 0, rc, NULL);
    }
    valid = valid_by_header(&g.poly, &law);
    if ((rc == VF_OK) != valid) {
        fprintf(stderr, "check rc=%d, header's rules say %s\n", rc, valid ? "valid" : "invalid");
        fail_simple("vf_exact_check disagrees with the header's rules");
    }
    if (rc == VF_OK) {
        vf_result *res;
        int *rcs;
        double *out, *out2;
        int64_t *zones, bad = 0, rb;
        double *dist = fz_alloc(g.poly.n), *bnd = fz_alloc(g.poly.n);
        int32_t *work = (int32_t *)malloc((size_t)g.poly.n * sizeof(int32_t));
        vf_scratch s = {dist, bnd, work};
        fz_read_states(&rd, &st);
        res = (vf_result *)malloc((st.count > 0 ? st.count : 1) * sizeof(vf_result));
        rcs = (int *)malloc((st.count > 0 ? st.count : 1) * sizeof(int));
        for (k = 0; k < st.count; k++) {
            check_state(&g.poly, &law, g.structured, st.P[2 * k], st.P[2 * k + 1], st.V[2 * k],
                        st.V[2 * k + 1], &res[k], &rcs[k]);
            bad += rcs[k] != VF_OK;
        }
        out = fz_alloc((int32_t)(2 * st.count));
        out2 = fz_alloc((int32_t)(2 * st.count));
        zones = (int64_t *)malloc((st.count > 0 ? st.count : 1) * sizeof(int64_t));
        rb = vf_exact_batch(&g.poly, &law, st.P, st.V, st.count, out, zones, &s);
        if (rb != bad) {
            fprintf(stderr, "batch returned %lld, single calls had %lld errors\n", (long long)rb,
                    (long long)bad);
            fail_simple("vf_exact_batch: count of invalid rows");
        }
        for (k = 0; k < st.count; k++) {
            if (!fz_same_bits(out[2 * k], res[k].ox) || !fz_same_bits(out[2 * k + 1], res[k].oy)
                || zones[k] != res[k].zone) {
                fail("vf_exact_batch: a row differs from the single call", st.P[2 * k],
                     st.P[2 * k + 1], st.V[2 * k], st.V[2 * k + 1], rcs[k], &res[k]);
            }
        }
        rb = vf_exact_batch(&g.poly, &law, st.P, st.V, st.count, out2, NULL, &s);
        if (rb != bad || (st.count > 0 && memcmp(out, out2, 2 * st.count * sizeof(double)) != 0)) {
            fail_simple("vf_exact_batch with zones NULL differs");
        }
        free(res);
        free(rcs);
        free(out);
        free(out2);
        free(zones);
        free(dist);
        free(bnd);
        free(work);
        fz_states_free(&st);
    }
    fz_polygon_free(&g);
    return 0;
}
