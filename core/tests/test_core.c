/*
 * test_core.c -- unit tests of the C API (velfence_core.h), run by tests/core/test_c_api.py under
 * -fsanitize=address,undefined. Prints "ok <count>" and exits 0 when every check holds; prints each
 * failed check and exits 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "velfence_core.h"
#include "vf_test.h"

#define MAXN 64

typedef struct {
    double nx[MAXN], ny[MAXN], off[MAXN], beta[MAXN + 1];
    vf_polygon poly;
} regular;

/* A regular n-gon of circumradius 1 about the origin (normals, offsets, the patent's angles). */
static void make_regular(regular *g, int n)
{
    const double two_pi = 6.283185307179586;
    int i;
    for (i = 0; i < n; i++) {
        double a = two_pi * (i + 0.5) / n; /* edge i's outward normal direction */
        g->nx[i] = -cos(a);
        g->ny[i] = -sin(a);
        g->off[i] = -cos(3.141592653589793 / n);
        g->beta[i] = two_pi * i / n;
    }
    g->beta[n] = two_pi;
    g->poly.nx = g->nx;
    g->poly.ny = g->ny;
    g->poly.off = g->off;
    g->poly.beta = g->beta;
    g->poly.cx = 0.0;
    g->poly.cy = 0.0;
    g->poly.a0 = 0.0;
    g->poly.n = n;
}

static int is_stop(const vf_result *r)
{
    return r->ox == 0.0 && r->oy == 0.0 && r->zone == VF_ZONE_INVALID && r->stages == VF_STAGE_STOP
           && r->primary == -1 && r->secondary == -1 && r->d1 == 0.0 && r->d2 == 0.0;
}

static void test_checks(void)
{
    regular g;
    vf_exact_law law = {VF_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0, 0, 0}, 1, 0.0};
    vf_patent_law pat = {0.2, 1.0, 0.3, 0.0};
    vf_polygon bad;
    make_regular(&g, 8);
    CHECK(vf_exact_check(&g.poly, &law) == VF_OK, "valid exact law refused");
    CHECK(vf_patent_check(&g.poly, &pat) == VF_OK, "valid patent law refused");
    CHECK(vf_exact_check(NULL, &law) == VF_ERR_NULL, "NULL polygon");
    CHECK(vf_exact_check(&g.poly, NULL) == VF_ERR_NULL, "NULL law");
    bad = g.poly;
    bad.n = 2;
    CHECK(vf_exact_check(&bad, &law) == VF_ERR_ARGUMENT, "n = 2 accepted");
    bad = g.poly;
    bad.nx = NULL;
    CHECK(vf_exact_check(&bad, &law) == VF_ERR_NULL, "NULL nx accepted");
    bad = g.poly;
    bad.beta = NULL;
    CHECK(vf_patent_check(&bad, &pat) == VF_ERR_NULL, "patent without beta accepted");
    CHECK(vf_exact_check(&bad, &law) == VF_OK, "exact law needs no beta");
    g.off[3] = NAN;
    CHECK(vf_exact_check(&g.poly, &law) == VF_ERR_ARGUMENT, "NaN offset accepted");
    make_regular(&g, 8);
    law.kind = 7;
    CHECK(vf_exact_check(&g.poly, &law) == VF_ERR_ARGUMENT, "unknown profile kind accepted");
    law.kind = VF_PROFILE_LINEAR;
    law.idt = -1.0;
    CHECK(vf_exact_check(&g.poly, &law) == VF_ERR_ARGUMENT, "negative idt accepted");
    law.idt = 0.0;
    law.prm[0] = 0.0;
    CHECK(vf_exact_check(&g.poly, &law) == VF_ERR_ARGUMENT, "d_max = 0 accepted");
    pat.theta_max = 3.2;
    CHECK(vf_patent_check(&g.poly, &pat) == VF_ERR_ARGUMENT, "theta_max > pi accepted");
    pat.theta_max = 0.3;
    pat.dmax = NAN;
    CHECK(vf_patent_check(&g.poly, &pat) == VF_ERR_ARGUMENT, "NaN d_max accepted");
}

static void test_invalid_inputs(void)
{
    regular g;
    vf_exact_law law = {VF_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0, 0, 0}, 1, 0.0};
    vf_patent_law pat = {0.2, 1.0, 0.3, 0.0};
    double dist[8], bnd[8];
    int32_t work[8];
    vf_scratch s = {dist, bnd, work};
    vf_scratch s_null = {NULL, bnd, work};
    const double bads[] = {NAN, INFINITY, -INFINITY};
    vf_result r;
    int i, k;
    make_regular(&g, 8);
    for (k = 0; k < 3; k++) {
        for (i = 0; i < 4; i++) {
            double v[4] = {0.1, 0.2, 0.3, 0.4};
            v[i] = bads[k];
            memset(&r, 0xff, sizeof r); /* garbage: every field must be written */
            CHECK(vf_exact_shape(&g.poly, &law, v[0], v[1], v[2], v[3], &s, &r)
                      == VF_ERR_NONFINITE, "exact: non-finite input %d/%d", k, i);
            CHECK(is_stop(&r), "exact: not the stop result for input %d/%d", k, i);
            memset(&r, 0xff, sizeof r);
            CHECK(vf_patent_shape(&g.poly, &pat, v[0], v[1], v[2], v[3], &r) == VF_ERR_NONFINITE,
                  "patent: non-finite input %d/%d", k, i);
            CHECK(is_stop(&r), "patent: not the stop result for input %d/%d", k, i);
        }
    }
    CHECK(vf_exact_shape(&g.poly, &law, 0, 0, 1, 1, &s_null, &r) == VF_ERR_NULL && is_stop(&r),
          "NULL scratch");
    CHECK(vf_exact_shape(&g.poly, &law, 0, 0, 1, 1, NULL, &r) == VF_ERR_NULL && is_stop(&r),
          "NULL scratch struct");
    CHECK(vf_exact_shape(&g.poly, &law, 0, 0, 1, 1, &s, NULL) == VF_ERR_NULL, "NULL out");
    CHECK(vf_patent_shape(NULL, &pat, 0, 0, 1, 1, &r) == VF_ERR_NULL && is_stop(&r),
          "NULL polygon");
    /* overflow: outside the left, spring + command overflow (patent) */
    CHECK(vf_patent_shape(&g.poly, &pat, -1.7e308, 0.0, 1.7e308, 0.0, &r) == VF_ERR_OVERFLOW
              && is_stop(&r), "patent overflow not reported");
}

/* The exact law's promises on random states of a regular n-gon (derivations section 3). */
static void test_exact_properties(int n, int discrete)
{
    regular g;
    const double dmax = 0.2;
    vf_exact_law law = {VF_PROFILE_LINEAR, {dmax, 1.0, dmax, 0, 0, 0}, 1, discrete ? 100.0 : 0.0};
    double dist[MAXN], bnd[MAXN];
    int32_t work[MAXN];
    vf_scratch s = {dist, bnd, work};
    vf_result r;
    int t, e;
    make_regular(&g, n);
    for (t = 0; t < 20000; t++) {
        double px = uniform(-1.2, 1.2), py = uniform(-1.2, 1.2);
        double vx = uniform(-3, 3), vy = uniform(-3, 3);
        double vn = sqrt(vx * vx + vy * vy), on, dmin = INFINITY;
        int rc = vf_exact_shape(&g.poly, &law, px, py, vx, vy, &s, &r);
        CHECK(rc == VF_OK, "rc %d", rc);
        CHECK(isfinite(r.ox) && isfinite(r.oy) && isfinite(r.d1) && isfinite(r.d2),
              "non-finite result");
        CHECK(r.zone >= VF_ZONE_FREE && r.zone <= VF_ZONE_OUTSIDE_CORNER, "zone %d", r.zone);
        CHECK(r.primary >= 0 && r.primary < n && r.secondary >= 0 && r.secondary < n
                  && r.primary != r.secondary, "edges %d %d", r.primary, r.secondary);
        for (e = 0; e < n; e++) {
            double d = g.nx[e] * px + g.ny[e] * py - g.off[e];
            if (d < dmin) {
                dmin = d;
            }
        }
        CHECK(r.d1 == dmin, "d1 %.17g is not the smallest distance %.17g", r.d1, dmin);
        if (dmin < 0.0) {
            continue;
        }
        on = sqrt(r.ox * r.ox + r.oy * r.oy);
        CHECK(on <= vn * (1.0 + 1e-12), "inside, the law sped up: %g > %g", on, vn);
        if (dmin >= dmax && !discrete) {
            CHECK(r.ox == vx && r.oy == vy && r.zone == VF_ZONE_FREE, "free state changed");
        }
        for (e = 0; e < n; e++) {
            double d = g.nx[e] * px + g.ny[e] * py - g.off[e];
            double lower = d < dmax ? -vn * d / dmax : -INFINITY;
            if (discrete && -d * 100.0 > lower) {
                lower = -d * 100.0;
            }
            CHECK(g.nx[e] * r.ox + g.ny[e] * r.oy >= lower - 1e-9 * (1.0 + vn),
                  "edge %d bound violated", e);
        }
    }
}

static void test_patent_and_profile(void)
{
    regular g;
    vf_patent_law pat = {0.2, 2.0, 0.3, 50.0};
    /* ThreeZoneBraking(gain=4, max_speed=1, max_acceleration=2): delta_int, delta_f, delta_phi */
    vf_exact_law tz = {VF_PROFILE_THREE_ZONE, {4.0, 1.0, 2.0, 0.0625, 0.03125, 0.28125}, 0, 0.0};
    double dist[MAXN], bnd[MAXN];
    int32_t work[MAXN];
    vf_scratch s = {dist, bnd, work};
    vf_result r;
    int t;
    make_regular(&g, 6);
    CHECK(vf_exact_check(&g.poly, &tz) == VF_OK, "three-zone profile refused");
    for (t = 0; t < 20000; t++) {
        double px = uniform(-1.3, 1.3), py = uniform(-1.3, 1.3);
        double vx = uniform(-5, 5), vy = uniform(-5, 5);
        int rc = vf_patent_shape(&g.poly, &pat, px, py, vx, vy, &r);
        CHECK(rc == VF_OK && isfinite(r.ox) && isfinite(r.oy) && isfinite(r.sx)
                  && isfinite(r.sy), "patent rc %d", rc);
        rc = vf_exact_shape(&g.poly, &tz, px, py, vx, vy, &s, &r);
        CHECK(rc == VF_OK && isfinite(r.ox) && isfinite(r.oy), "three-zone rc %d", rc);
    }
}

static void test_batch(void)
{
    regular g;
    vf_exact_law law = {VF_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0, 0, 0}, 1, 0.0};
    vf_patent_law pat = {0.2, 1.0, 0.3, 0.0};
    double P[10] = {0.0, 0.0, 0.9, 0.1, NAN, 0.0, 0.5, 0.5, -1.7e308, 0.0};
    double V[10] = {1.0, 0.0, 1.0, 0.0, 1.0, 0.0, INFINITY, 0.0, 1.7e308, 0.0};
    double out[10];
    int64_t zones[5];
    double dist[8], bnd[8];
    int32_t work[8];
    vf_scratch s = {dist, bnd, work};
    vf_result r;
    int i;
    make_regular(&g, 8);
    CHECK(vf_exact_batch(&g.poly, &law, P, V, 5, out, zones, &s) == 2, "exact: 2 invalid rows");
    for (i = 0; i < 5; i++) {
        CHECK(isfinite(out[2 * i]) && isfinite(out[2 * i + 1]), "batch row %d not finite", i);
        if (i == 2 || i == 3) {
            CHECK(zones[i] == VF_ZONE_INVALID && out[2 * i] == 0.0, "row %d not stopped", i);
        } else {
            vf_exact_shape(&g.poly, &law, P[2 * i], P[2 * i + 1], V[2 * i], V[2 * i + 1], &s,
                           &r);
            CHECK(out[2 * i] == r.ox && out[2 * i + 1] == r.oy && zones[i] == r.zone,
                  "batch row %d differs from the single call", i);
        }
    }
    CHECK(vf_patent_batch(&g.poly, &pat, P, V, 5, out, NULL) == 3, "patent: 3 invalid rows");
    CHECK(vf_exact_batch(&g.poly, &law, NULL, NULL, 0, NULL, NULL, &s) == 0, "empty batch");
    CHECK(vf_exact_batch(&g.poly, &law, NULL, V, 1, out, zones, &s) == VF_ERR_NULL, "NULL P");
}

int main(void)
{
    test_checks();
    test_invalid_inputs();
    test_exact_properties(3, 0);
    test_exact_properties(8, 0);
    test_exact_properties(8, 1);
    test_exact_properties(64, 0);
    test_patent_and_profile();
    test_batch();
    return finish();
}
