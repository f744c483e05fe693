/*
 * fuzz_patent.c -- libFuzzer target of the edge-scaling (patent) law's checked API:
 * vf_patent_check, vf_patent_shape, vf_patent_batch (core/include/velfence_core.h).
 * Build: core/fuzz/build.sh. Input layout:
 *
 *   flags byte | polygon (fuzz_common.h) | law: dmax, k, theta_max doubles, idt selector byte
 *   (even: 0, odd: a double follows) | states (px, py, vx, vy), the rest of the bytes
 *   flags bit 7: instead of states, one NULL-pointer case (a selector byte follows the law)
 *
 * Asserted (abort() on a violation, after printing the decoded input):
 *   vf_patent_check returns VF_OK, VF_ERR_NULL or VF_ERR_ARGUMENT, and VF_OK only for data that
 *     meets the header's rules (n >= 3, finite polygon data, beta non-decreasing, d_max > 0,
 *     k finite >= 0, theta_max in (0, pi), idt finite >= 0);
 *   on checked data, per state: the code is VF_OK, VF_ERR_NONFINITE (exactly for non-finite
 *     input) or VF_ERR_OVERFLOW; on an error *out is the stop result bit for bit; on VF_OK every
 *     field is finite (d1/d2: see VF_FUZZ_STRICT_AUX_DISTANCES), the zone is 0..4 and
 *     "outside"/"outside-corner" exactly when d1 < 0, primary/secondary are two edges whose signed
 *     distances are d1/d2 (bit for bit), only the patent's stage bits are set, no spring term
 *     (sx = sy = 0) inside the primary edge; in continuous time a free state is passed unchanged;
 *     the result equals vf_patent_kernel's; repeating the call gives the same bits;
 *   on polygons built from corners (unit normals), states inside (every d_i >= 0): |v_o| <= |v|
 *     (the patent law only removes approaching normal components, derivations section 2);
 *   vf_patent_batch returns the number of non-VF_OK states and writes the single calls' ox, oy
 *     and zones; with zones NULL the same velocities;
 *   NULL pointers (flags bit 7; any one of poly, law, nx, ny, off, beta, out, P, V): VF_ERR_NULL
 *     from the entry points that read it, with the stop result from vf_patent_shape and nothing
 *     written by vf_patent_batch.
 */
#include "fuzz_common.h"

static const fz_polygon *cur_poly;
static const vf_patent_law *cur_law;

static void fail(const char *what, double px, double py, double vx, double vy, int rc,
                 const vf_result *r)
{
    const vf_patent_law *l = cur_law;
    fprintf(stderr, "\n*** velfence_core contract violated (patent law): %s\n", what);
    fprintf(stderr, "patent law dmax=%.17g k=%.17g theta_max=%.17g idt=%.17g\n", l->dmax, l->k,
            l->theta_max, l->idt);
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

static void read_law(fz_reader *r, vf_patent_law *law)
{
    law->dmax = fz_double(r);
    law->k = fz_double(r);
    law->theta_max = fz_double(r);
    law->idt = (fz_byte(r) & 1) ? fz_double(r) : 0.0;
}

static int valid_by_header(const vf_polygon *p, const vf_patent_law *l)
{
    int32_t e;
    if (p->n < 3 || !isfinite(p->cx) || !isfinite(p->cy) || !isfinite(p->a0)) {
        return 0;
    }
    for (e = 0; e < p->n; e++) {
        if (!isfinite(p->nx[e]) || !isfinite(p->ny[e]) || !isfinite(p->off[e])) {
            return 0;
        }
    }
    for (e = 0; e <= p->n; e++) {
        if (!isfinite(p->beta[e]) || (e > 0 && p->beta[e] < p->beta[e - 1])) {
            return 0;
        }
    }
    return l->dmax > 0.0 && isfinite(l->k) && l->k >= 0.0 && l->theta_max > 0.0
           && l->theta_max < 3.141592653589793 && isfinite(l->idt) && l->idt >= 0.0;
}

static void check_state(const vf_polygon *p, const vf_patent_law *l, int structured, double px,
                        double py, double vx, double vy, vf_result *res, int *rc_out)
{
    vf_result r2, rk;
    int rc, rc2;
    const int32_t allowed = VF_STAGE_SECONDARY | VF_STAGE_PRIMARY | VF_STAGE_ZERO_OUTWARD
                            | VF_STAGE_SPRING | VF_STAGE_BLEND | VF_STAGE_PERIOD;
    memset(res, 0xa5, sizeof *res);
    rc = vf_patent_shape(p, l, px, py, vx, vy, res);
    if (fz_common_contract("patent", p, px, py, vx, vy, rc, res, allowed, fail)) {
        double dmin = INFINITY;
        int32_t e;
        for (e = 0; e < p->n; e++) {
            double d = fz_dist(p, e, px, py);
            if (d < dmin) {
                dmin = d;
            }
        }
        if ((res->zone >= VF_ZONE_OUTSIDE) != (res->d1 < 0.0)) {
            fail("patent law: zone outside/outside-corner not exactly when d1 < 0", px, py, vx,
                 vy, rc, res);
        }
        if (res->zone < VF_ZONE_OUTSIDE && (res->sx != 0.0 || res->sy != 0.0)) {
            fail("patent law: a spring term inside the primary edge", px, py, vx, vy, rc, res);
        }
        if (res->zone == VF_ZONE_FREE && l->idt == 0.0
            && (!fz_same_bits(res->ox, vx) || !fz_same_bits(res->oy, vy))) {
            fail("patent law: a free state changed (continuous time)", px, py, vx, vy, rc, res);
        }
        if (structured && fz_unit_normals(p) && dmin >= 0.0) {
            double vn = hypot(vx, vy), on = hypot(res->ox, res->oy);
            if (!(on <= vn * (1.0 + 1e-12) + 1e-300)) {
                fprintf(stderr, "|v_o| = %.17g > |v| = %.17g\n", on, vn);
                fail("inside, the patent law sped up (|v_o| > |v|)", px, py, vx, vy, rc, res);
            }
        }
    }
    memset(&r2, 0x5a, sizeof r2);
    rc2 = vf_patent_shape(p, l, px, py, vx, vy, &r2);
    if (rc2 != rc || !fz_same_result(res, &r2)) {
        fz_print_result("second call", rc2, &r2);
        fail("patent law: a second call differs", px, py, vx, vy, rc, res);
    }
    if (rc == VF_OK) {
        vf_patent_kernel(p, l, px, py, vx, vy, &rk);
        if (!fz_same_result(res, &rk)) {
            fz_print_result("kernel", 0, &rk);
            fail("patent law: vf_patent_shape differs from vf_patent_kernel under VF_OK", px, py,
                 vx, vy, rc, res);
        }
    }
    *rc_out = rc;
}

/* One NULL-pointer case: the selector names which pointer is NULL and which entry point sees it.
 * Checks: VF_ERR_NULL; shape writes the stop result (out non-NULL); batch writes nothing. */
static void null_cases(fz_reader *rd, const vf_polygon *p, const vf_patent_law *l)
{
    uint8_t sel = fz_byte(rd);
    vf_polygon q = *p;
    const vf_polygon *pp = &q;
    const vf_patent_law *ll = l;
    vf_result r, *rr = &r;
    double P[2] = {0.0, 0.0}, V[2] = {1.0, 0.0}, out[2] = {7.0, 7.0};
    const double *PP = P, *VV = V;
    double *OO = out;
    int64_t zones[1] = {7};
    int rc;
    int64_t rb;
    switch ((sel >> 3) % 7) { /* the NULL pointer */
    case 0: pp = NULL; break;
    case 1: ll = NULL; break;
    case 2: q.nx = NULL; break;
    case 3: q.ny = NULL; break;
    case 4: q.off = NULL; break;
    case 5: q.beta = NULL; break;
    default: rr = NULL; break; /* out (shape), P, V or out (batch) */
    }
    switch (sel % 3) { /* the entry point */
    case 0:
        if (rr == NULL) {
            break; /* the check has no result */
        }
        if (vf_patent_check(pp, ll) != VF_ERR_NULL) {
            fail_simple("vf_patent_check with a NULL pointer: not VF_ERR_NULL");
        }
        break;
    case 1:
        memset(&r, 0xa5, sizeof r);
        rc = vf_patent_shape(pp, ll, 0.25, 0.0, 1.0, 0.0, rr);
        if (rc != VF_ERR_NULL || (rr != NULL && !fz_is_stop(rr))) {
            fail_simple("vf_patent_shape with a NULL pointer: not VF_ERR_NULL with the stop result");
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
        rb = vf_patent_batch(pp, ll, PP, VV, 1, OO, zones);
        if (rb != VF_ERR_NULL || out[0] != 7.0 || out[1] != 7.0 || zones[0] != 7) {
            fail_simple("vf_patent_batch with a NULL pointer: not VF_ERR_NULL, or it wrote");
        }
        break;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader rd = {data, size};
    uint8_t flags = fz_byte(&rd);
    fz_polygon g;
    vf_patent_law law;
    fz_states st;
    int rc;
    size_t k;
    fz_read_polygon(&rd, &g);
    read_law(&rd, &law);
    cur_poly = &g;
    cur_law = &law;
    if (flags & 0x80) {
        if (g.poly.n >= 3 && vf_patent_check(&g.poly, &law) == VF_OK) {
            null_cases(&rd, &g.poly, &law);
        }
        fz_polygon_free(&g);
        return 0;
    }
    rc = vf_patent_check(&g.poly, &law);
    if (rc != VF_OK && rc != VF_ERR_ARGUMENT && rc != VF_ERR_NULL) {
        fail("vf_patent_check: return code outside {VF_OK, VF_ERR_NULL, VF_ERR_ARGUMENT}", 0, 0,
             0, 0, rc, NULL);
    }
    if (rc == VF_OK && !valid_by_header(&g.poly, &law)) {
        fail_simple("vf_patent_check accepted data the header's rules refuse");
    }
    if (rc == VF_OK) {
        vf_result *res;
        int *rcs;
        double *out, *out2;
        int64_t *zones, bad = 0, rb;
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
        rb = vf_patent_batch(&g.poly, &law, st.P, st.V, st.count, out, zones);
        if (rb != bad) {
            fprintf(stderr, "batch returned %lld, single calls had %lld errors\n", (long long)rb,
                    (long long)bad);
            fail_simple("vf_patent_batch: count of invalid rows");
        }
        for (k = 0; k < st.count; k++) {
            if (!fz_same_bits(out[2 * k], res[k].ox) || !fz_same_bits(out[2 * k + 1], res[k].oy)
                || zones[k] != res[k].zone) {
                fail("vf_patent_batch: a row differs from the single call", st.P[2 * k],
                     st.P[2 * k + 1], st.V[2 * k], st.V[2 * k + 1], rcs[k], &res[k]);
            }
        }
        rb = vf_patent_batch(&g.poly, &law, st.P, st.V, st.count, out2, NULL);
        if (rb != bad || (st.count > 0 && memcmp(out, out2, 2 * st.count * sizeof(double)) != 0)) {
            fail_simple("vf_patent_batch with zones NULL differs");
        }
        free(res);
        free(rcs);
        free(out);
        free(out2);
        free(zones);
        fz_states_free(&st);
    }
    fz_polygon_free(&g);
    return 0;
}
