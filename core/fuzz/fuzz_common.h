/*
 * fuzz_common.h -- shared by the libFuzzer targets of core/fuzz/ (fuzz_exact.c, fuzz_patent.c;
 * the byte decoding also by fuzz_nd.c and fuzz_cc.c).
 *
 * The input bytes are read by a small cursor (fz_reader): every value a target needs is taken from
 * the bytes in order, and an exhausted input reads as zeros. Doubles come in four encodings chosen
 * by a selector byte, so that the fuzzer reaches both arbitrary bit patterns and useful values:
 *
 *   selector   0.. 63  the next 8 bytes as an IEEE double (any NaN, inf, subnormal)
 *   selector  64..127  a special value (0, -0, +-1, +-DBL_MAX, +-inf, NaN, 5e-324, 1e+-300, ...)
 *   selector 128..191  a moderate value: (int16 from 2 bytes) / 8192, in [-4, 4)
 *   selector 192..255  a scaled value: ldexp((int16) / 32768, e), e from 2 bytes in [-1100, 1100)
 *
 * A polygon is "structured" (corners on an ellipse, with inward unit normals, offsets, centroid,
 * a0 and beta computed as ConvexPolygon.kernel_data computes them, optionally one field overwritten
 * by a decoded double) or "raw" (n from a signed byte, every array entry a decoded double). Every
 * array is malloc'ed with exactly its documented length, so AddressSanitizer reports any read or
 * write past it.
 *
 * A violated contract prints what was decoded and the result, then abort()s: libFuzzer saves the
 * input as a crash file. Running the target binary on that file reproduces the report.
 *
 * Switch VF_FUZZ_STRICT_AUX_DISTANCES (default 1): d1 and d2 must be finite under VF_OK, as the
 * header says ("every double in it is finite"). 0 restores the lenient check written while
 * "positions beyond ~1e300 give VF_OK with -inf d1/d2" was open (it is fixed: such results are
 * VF_ERR_OVERFLOW): a non-finite d1 or d2 under VF_OK is then accepted only when one of the
 * polygon's signed distances itself overflows. Set at build time (build.sh --lenient-aux,
 * -DVF_FUZZ_STRICT_AUX_DISTANCES=0) or at run time by the environment variable of that name
 * (=1 or =0, read once at start-up). VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) makes
 * fuzz_exact spoil every VF_OK result, for the tests' proof that a violation aborts.
 *
 * VF_FUZZ_BYTES_ONLY (defined by fuzz_nd.c, fuzz_cc.c, fuzz_rr.c and fuzz_filter.c before the
 * include): only the byte cursor, the double decoder, fz_alloc, fz_same_bits, fz_print_vec and
 * fz_profile; no polygon, states or 2-D contract.
 */
#ifndef VF_FUZZ_COMMON_H
#define VF_FUZZ_COMMON_H

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "velfence_core.h"

#ifndef VF_FUZZ_BYTES_ONLY
#ifndef VF_FUZZ_STRICT_AUX_DISTANCES
#define VF_FUZZ_STRICT_AUX_DISTANCES 1
#endif

static int fz_strict_aux = VF_FUZZ_STRICT_AUX_DISTANCES;

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    const char *v = getenv("VF_FUZZ_STRICT_AUX_DISTANCES");
    (void)argc;
    (void)argv;
    if (v != NULL && (v[0] == '0' || v[0] == '1') && v[1] == '\0') {
        fz_strict_aux = v[0] == '1';
    }
    if (fz_strict_aux) {
        fprintf(stderr, "VF_FUZZ_STRICT_AUX_DISTANCES=1: d1/d2 must be finite under VF_OK\n");
    }
    return 0;
}
#endif /* VF_FUZZ_BYTES_ONLY */

#define FZ_MAX_N 24      /* structured polygons: 3..24 edges (raw: n in -23..23) */
#define FZ_MAX_STATES 32 /* states per input */

typedef struct fz_reader {
    const uint8_t *p;
    size_t left;
} fz_reader;

static uint8_t fz_byte(fz_reader *r)
{
    uint8_t b = 0;
    if (r->left > 0) {
        b = *r->p;
        r->p++;
        r->left--;
    }
    return b;
}

static int16_t fz_i16(fz_reader *r)
{
    unsigned lo = fz_byte(r);
    unsigned hi = fz_byte(r);
    return (int16_t)(uint16_t)(lo | hi << 8);
}

static const double fz_special[] = {
    0.0, -0.0, 1.0, -1.0, 0.5, 2.0, DBL_MAX, -DBL_MAX, INFINITY, -INFINITY, NAN,
    4.9406564584124654e-324, -4.9406564584124654e-324, DBL_MIN, 1e-300, -1e-300, 1e300, -1e300,
    1e150, -1e150, 1e-12, 3.141592653589793, 6.283185307179586, 1e15,
};
#define FZ_NSPECIAL ((int)(sizeof fz_special / sizeof fz_special[0]))

static double fz_double(fz_reader *r)
{
    uint8_t sel = fz_byte(r);
    if (sel < 64) {
        uint8_t raw[8] = {0};
        double x;
        int i;
        for (i = 0; i < 8; i++) {
            raw[i] = fz_byte(r);
        }
        memcpy(&x, raw, sizeof x);
        return x;
    }
    if (sel < 128) {
        return fz_special[(sel - 64) % FZ_NSPECIAL];
    }
    if (sel < 192) {
        return (double)fz_i16(r) / 8192.0;
    }
    {
        double m = (double)fz_i16(r) / 32768.0;
        int e = ((int)fz_i16(r) % 1100 + 1100) % 2200 - 1100;
        return ldexp(m, e);
    }
}

static double *fz_alloc(int32_t count)
{
    /* exactly count doubles (at least one byte so that the pointer is not NULL) */
    return (double *)malloc(count > 0 ? (size_t)count * sizeof(double) : 1);
}

static int fz_same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

/* "name: x_0 x_1 ..." on stderr, every double to 17 digits (the targets' reports). */
static inline void fz_print_vec(const char *name, const double *x, int32_t n)
{
    int32_t k;
    fprintf(stderr, "%s:", name);
    for (k = 0; k < n; k++) {
        fprintf(stderr, " %.17g", x[k]);
    }
    fprintf(stderr, "\n");
}

/* A profile (kind, prm[VF_PROFILE_PARAMS]) from the bytes: linear (dmax, gain, cap) for an even
 * first byte, else three-zone (K, v, a and the zone distances as ThreeZoneProfile derives them);
 * every value positive and finite (fuzz_filter.c, fuzz_filter_cycle.c). */
static inline void fz_profile(fz_reader *r, int32_t *kind, double *prm)
{
    uint8_t kb = fz_byte(r);
    memset(prm, 0, VF_PROFILE_PARAMS * sizeof(double));
    if (kb % 2 == 0) {
        *kind = VF_PROFILE_LINEAR;
        prm[0] = (1 + fz_byte(r)) / 64.0;
        prm[1] = fz_byte(r) / 16.0;
        prm[2] = (1 + fz_byte(r)) / 64.0;
    } else {
        double K = (1 + fz_byte(r)) / 4.0, a = (1 + fz_byte(r)) / 4.0;
        double v = a / K * (1.0 + (1 + fz_byte(r)) / 16.0);
        double d_int = (a / K) / K;
        *kind = VF_PROFILE_THREE_ZONE;
        prm[0] = K;
        prm[1] = v;
        prm[2] = a;
        prm[3] = d_int;
        prm[4] = 0.5 * d_int;
        prm[5] = 0.5 * d_int + (v / a) * (0.5 * v);
    }
}

#ifndef VF_FUZZ_BYTES_ONLY /* the 2-D targets: polygons, states, their contract */

/* A polygon with owned, exactly sized arrays. */
typedef struct fz_polygon {
    vf_polygon poly;
    double *nx, *ny, *off, *beta;
    int structured; /* 1: built from corners (unit normals), nothing overwritten */
} fz_polygon;

static void fz_polygon_free(fz_polygon *g)
{
    free(g->nx);
    free(g->ny);
    free(g->off);
    free(g->beta);
}

/* Python's float % for a positive divisor (as velfence_core.c's py_mod). */
static double fz_pymod(double x, double w)
{
    double m = fmod(x, w);
    if (m != 0.0) {
        if (m < 0.0) {
            m += w;
        }
    } else {
        m = 0.0;
    }
    return m;
}

static void fz_read_polygon(fz_reader *r, fz_polygon *g)
{
    uint8_t mode = fz_byte(r);
    int32_t n, e;
    memset(g, 0, sizeof *g);
    if (mode & 1) { /* raw */
        n = (int8_t)fz_byte(r) % FZ_MAX_N;
        g->nx = fz_alloc(n);
        g->ny = fz_alloc(n);
        g->off = fz_alloc(n);
        g->beta = fz_alloc(n + 1);
        for (e = 0; e < n; e++) {
            g->nx[e] = fz_double(r);
            g->ny[e] = fz_double(r);
            g->off[e] = fz_double(r);
        }
        for (e = 0; e <= n && n >= 0; e++) {
            g->beta[e] = fz_double(r);
        }
        g->poly.cx = fz_double(r);
        g->poly.cy = fz_double(r);
        g->poly.a0 = fz_double(r);
        g->structured = 0;
    } else { /* corners on an ellipse, CCW */
        double x[FZ_MAX_N], y[FZ_MAX_N], ang[FZ_MAX_N];
        double total = 0.0, acc = 0.0, phase, ccx, ccy, rad, asp, sx = 0.0, sy = 0.0, a0;
        n = 3 + fz_byte(r) % (FZ_MAX_N - 2);
        phase = 6.283185307179586 * fz_byte(r) / 256.0;
        for (e = 0; e < n; e++) {
            ang[e] = 1.0 + fz_byte(r);
            total += ang[e];
        }
        ccx = fz_double(r);
        ccy = fz_double(r);
        rad = fabs(fz_double(r));
        asp = (1.0 + fz_byte(r)) / 32.0;
        for (e = 0; e < n; e++) {
            double a = phase + 6.283185307179586 * acc / total;
            acc += ang[e];
            x[e] = ccx + rad * cos(a);
            y[e] = ccy + rad * asp * sin(a);
        }
        g->nx = fz_alloc(n);
        g->ny = fz_alloc(n);
        g->off = fz_alloc(n);
        g->beta = fz_alloc(n + 1);
        for (e = 0; e < n; e++) {
            int32_t f = e + 1 == n ? 0 : e + 1;
            double ex = x[f] - x[e], ey = y[f] - y[e], len = hypot(ex, ey);
            g->nx[e] = -ey / len;
            g->ny[e] = ex / len;
            g->off[e] = g->nx[e] * x[e] + g->ny[e] * y[e];
            sx += x[e];
            sy += y[e];
        }
        g->poly.cx = sx / n;
        g->poly.cy = sy / n;
        a0 = atan2(y[0] - g->poly.cy, x[0] - g->poly.cx);
        g->poly.a0 = a0;
        g->beta[0] = 0.0;
        for (e = 1; e < n; e++) {
            g->beta[e] = fz_pymod(atan2(y[e] - g->poly.cy, x[e] - g->poly.cx) - a0,
                                  6.283185307179586);
        }
        g->beta[n] = 6.283185307179586;
        g->structured = 1;
        if (mode & 2) { /* overwrite one field with a decoded double: almost-valid data */
            uint8_t which = fz_byte(r);
            int32_t at = fz_byte(r) % (n + 1);
            double v = fz_double(r);
            switch (which % 7) {
            case 0: g->nx[at % n] = v; break;
            case 1: g->ny[at % n] = v; break;
            case 2: g->off[at % n] = v; break;
            case 3: g->beta[at] = v; break;
            case 4: g->poly.cx = v; break;
            case 5: g->poly.cy = v; break;
            default: g->poly.a0 = v; break;
            }
            g->structured = 0;
        }
    }
    g->poly.nx = g->nx;
    g->poly.ny = g->ny;
    g->poly.off = g->off;
    g->poly.beta = g->beta;
    g->poly.n = n;
}

static int fz_unit_normals(const vf_polygon *p)
{
    int32_t e;
    for (e = 0; e < p->n; e++) {
        if (!(fabs(p->nx[e] * p->nx[e] + p->ny[e] * p->ny[e] - 1.0) <= 1e-14)) {
            return 0;
        }
    }
    return 1;
}

/* The signed distance of edge e, computed as the core computes it. */
static double fz_dist(const vf_polygon *p, int32_t e, double px, double py)
{
    return p->nx[e] * px + p->ny[e] * py - p->off[e];
}

static int fz_all_distances_finite(const vf_polygon *p, double px, double py)
{
    int32_t e;
    for (e = 0; e < p->n; e++) {
        if (!isfinite(fz_dist(p, e, px, py))) {
            return 0;
        }
    }
    return 1;
}

static int fz_same_result(const vf_result *a, const vf_result *b)
{
    return fz_same_bits(a->ox, b->ox) && fz_same_bits(a->oy, b->oy) && a->zone == b->zone
           && a->primary == b->primary && a->secondary == b->secondary
           && fz_same_bits(a->d1, b->d1) && fz_same_bits(a->d2, b->d2)
           && fz_same_bits(a->sx, b->sx) && fz_same_bits(a->sy, b->sy) && a->stages == b->stages;
}

/* The documented stop result, bit for bit (+0.0, not -0.0). */
static int fz_is_stop(const vf_result *r)
{
    vf_result s;
    s.ox = s.oy = s.d1 = s.d2 = s.sx = s.sy = 0.0;
    s.zone = VF_ZONE_INVALID;
    s.primary = s.secondary = -1;
    s.stages = VF_STAGE_STOP;
    return fz_same_result(r, &s);
}

static void fz_print_polygon(const vf_polygon *p)
{
    int32_t e;
    fprintf(stderr, "polygon n=%d cx=%a cy=%a a0=%a\n", (int)p->n, p->cx, p->cy, p->a0);
    for (e = 0; e < p->n && e < 128; e++) {
        fprintf(stderr, "  edge %d: nx=%.17g ny=%.17g off=%.17g\n", (int)e, p->nx[e], p->ny[e],
                p->off[e]);
    }
    if (p->beta != NULL && p->n >= 0) {
        fprintf(stderr, "  beta:");
        for (e = 0; e <= p->n && e < 129; e++) {
            fprintf(stderr, " %.17g", p->beta[e]);
        }
        fprintf(stderr, "\n");
    }
}

static void fz_print_result(const char *what, int rc, const vf_result *r)
{
    fprintf(stderr,
            "%s: rc=%d ox=%.17g oy=%.17g zone=%d primary=%d secondary=%d d1=%.17g d2=%.17g "
            "sx=%.17g sy=%.17g stages=%d\n",
            what, rc, r->ox, r->oy, (int)r->zone, (int)r->primary, (int)r->secondary, r->d1, r->d2,
            r->sx, r->sy, (int)r->stages);
}

/* The states (px, py, vx, vy) of an input: the rest of the bytes, at most FZ_MAX_STATES. */
typedef struct fz_states {
    size_t count;
    double *P; /* count x 2, exactly sized */
    double *V; /* count x 2 */
} fz_states;

static void fz_read_states(fz_reader *r, fz_states *s)
{
    double buf[4 * FZ_MAX_STATES];
    size_t k;
    s->count = 0;
    while (r->left > 0 && s->count < FZ_MAX_STATES) {
        for (k = 0; k < 4; k++) {
            buf[4 * s->count + k] = fz_double(r);
        }
        s->count++;
    }
    s->P = fz_alloc((int32_t)(2 * s->count));
    s->V = fz_alloc((int32_t)(2 * s->count));
    for (k = 0; k < s->count; k++) {
        s->P[2 * k] = buf[4 * k];
        s->P[2 * k + 1] = buf[4 * k + 1];
        s->V[2 * k] = buf[4 * k + 2];
        s->V[2 * k + 1] = buf[4 * k + 3];
    }
}

static void fz_states_free(fz_states *s)
{
    free(s->P);
    free(s->V);
}

/* The checks shared by both laws on one checked call. Returns 1 when the result is VF_OK and its
 * polygon distances are all finite (the caller then checks the law's own promises). */
static int fz_common_contract(const char *law, const vf_polygon *poly, double px, double py,
                              double vx, double vy, int rc, const vf_result *r, int32_t allowed,
                              void (*report)(const char *, double, double, double, double, int,
                                             const vf_result *))
{
    int finite_in = isfinite(px) && isfinite(py) && isfinite(vx) && isfinite(vy);
    int dfin = fz_all_distances_finite(poly, px, py);
    (void)law;
    if (rc != VF_OK && rc != VF_ERR_NONFINITE && rc != VF_ERR_OVERFLOW) {
        report("return code outside {VF_OK, VF_ERR_NONFINITE, VF_ERR_OVERFLOW}", px, py, vx, vy,
               rc, r);
    }
    if ((rc == VF_ERR_NONFINITE) != !finite_in) {
        report("VF_ERR_NONFINITE must be returned exactly for non-finite input", px, py, vx, vy,
               rc, r);
    }
    if (rc != VF_OK) {
        if (!fz_is_stop(r)) {
            report("an error code without the documented stop result", px, py, vx, vy, rc, r);
        }
        return 0;
    }
    if (!isfinite(r->ox) || !isfinite(r->oy) || !isfinite(r->sx) || !isfinite(r->sy)) {
        report("VF_OK with a non-finite velocity or spring term", px, py, vx, vy, rc, r);
    }
    if (!isfinite(r->d1) || !isfinite(r->d2)) {
        if (fz_strict_aux || dfin) {
            report("VF_OK with non-finite auxiliary distances d1/d2", px, py, vx, vy, rc, r);
        }
        return 0; /* the known defect: an edge's signed distance itself overflowed */
    }
    if (r->zone < VF_ZONE_FREE || r->zone > VF_ZONE_OUTSIDE_CORNER) {
        report("VF_OK with a zone outside 0..4", px, py, vx, vy, rc, r);
    }
    if ((r->stages & ~allowed) != 0) {
        report("VF_OK with a stage bit this law never sets", px, py, vx, vy, rc, r);
    }
    if (!dfin) {
        return 0;
    }
    if (r->primary < 0 || r->primary >= poly->n || r->secondary < 0 || r->secondary >= poly->n
        || r->primary == r->secondary) {
        report("VF_OK with primary/secondary edges not two distinct edges of the polygon", px, py,
               vx, vy, rc, r);
    }
    if (!fz_same_bits(r->d1, fz_dist(poly, r->primary, px, py))
        || !fz_same_bits(r->d2, fz_dist(poly, r->secondary, px, py))) {
        report("d1/d2 are not the signed distances of the primary/secondary edges", px, py, vx,
               vy, rc, r);
    }
    return 1;
}

#endif /* VF_FUZZ_BYTES_ONLY */

#endif /* VF_FUZZ_COMMON_H */
