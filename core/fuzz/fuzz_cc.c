/*
 * fuzz_cc.c -- libFuzzer target of configuration control (core/include/velfence_cc.h):
 * vf_cc_check, vf_cc_solve with its workspace sized by vf_cc_doubles / vf_cc_ints (allocated at
 * exactly those sizes, as every output array, so that AddressSanitizer sees any overrun). Build:
 * core/fuzz/build.sh. Input layout (doubles and the byte cursor: fuzz_common.h):
 *
 *   flags byte: bit 0 raw, bit 1 overwrite one field (structured only), bit 7 one NULL-pointer
 *               case (a selector byte at the end)
 *   structured: a planar (byte bit 0: m = 2, every axis z, the chain in z = 0) or spatial (m = 3,
 *               twists +-pi/2 or 0) chain of n = 1 + byte % 8 revolute joints, per joint a link
 *               length (1 + byte) / 256, an angle 2 pi byte / 256, a twist byte and a capsule
 *               radius byte / 1024; k = byte % 9 obstacles, each near a link (link byte, place
 *               byte, an offset of three int16 / 65536 [m], z = 0 when planar) with a radius of
 *               influence (1 + byte) / 256; w_e = 1, w_z = 10^(byte % 7), lambda = 10^-(byte % 6),
 *               K_z = byte / 16, h = byte / 256 (byte bit 0 of h's byte: h = 0), max_speed 0 or
 *               byte / 32, recheck byte bit 0, rounds 4 k + 1 (or byte % 8 when the byte is odd);
 *               y_r m decoded doubles. Overwrite (flags bit 1): one of P, axes, y_r, C, rho, lrad,
 *               w_e, w_z, lambda, K_z, h, max_speed, m, n, k, rounds gets a decoded double (the
 *               sizes: an int32 that keeps the arrays in bounds: m in {-1, 0, 1, 4}, n < 1, k < 0;
 *               rounds -5..-1 or 0..63: the add rounds are the documented bound of the work, and
 *               millions of them (an active set that keeps adding and releasing rows runs to the
 *               bound) made single inputs take minutes)
 *   raw:        n = 1 + byte % 6, m = 2 + byte % 2, k = byte % 6, recheck and rounds from bytes
 *               (rounds an int16), every double (P, axes, y_r, C, rho, lrad and the six scalars)
 *               a decoded double
 *
 * Asserted (abort() on a violation, after printing the decoded input):
 *   vf_cc_check returns VF_CC_OK, VF_CC_ERR_NULL or VF_CC_ERR_ARGUMENT, and VF_CC_OK exactly when
 *     the problem meets the header's rules (n >= 1, m 2 or 3, k >= 0, rounds >= 0, w_e, w_z,
 *     lambda finite > 0, K_z and h finite >= 0, max_speed >= 0 (not NaN; +inf: no cap), lrad
 *     finite >= 0, rho finite > 0, C finite);
 *   vf_cc_solve returns the check's code when the check fails; else VF_CC_ERR_NONFINITE exactly
 *     when P, axes or y_r holds a NaN or +-inf, otherwise VF_CC_OK or VF_CC_ERR_OVERFLOW;
 *   on VF_CC_ERR_NONFINITE / VF_CC_ERR_OVERFLOW every output is the stop result, bit for bit
 *     (q_dot = q_free = +0, every double +0, n_active = 0, links and active -1);
 *   on VF_CC_OK every double of the answer is finite, links are links (0..n-1), 0 <= n_active <=
 *     k with distinct active obstacles, fractions in [0, 1], the condition number >= 1, the rate
 *     errors >= 0; with h = 0 every active obstacle's critical point is inside its sphere of
 *     influence (distance <= rho); with max_speed > 0 every |q_dot_j| <= max_speed exactly
 *     (the cap); on structured data the normals are unit (|n|^2 within 1e-9 of 1) where the
 *     centre is off the capsule's axis;
 *   a second call with the workspace full of NaN garbage (first call: zeroed) gives identical bits;
 *   NULL pointers (flags bit 7): pb, P, axes, y_r, out, dwork, iwork, q_dot, q_free, or (k > 0)
 *     any of the k-sized output arrays, C, rho, or lrad: VF_CC_ERR_NULL from vf_cc_solve (and
 *     from vf_cc_check for pb, lrad, C, rho).
 * VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) spoils every VF_CC_OK joint rate with a NaN,
 * for the tests' proof that a violation aborts.
 */
#define VF_FUZZ_BYTES_ONLY
#include "fuzz_common.h"
#include "velfence_cc.h"

#define FZ_CC_MAX_N 8
#define FZ_CC_MAX_K 8

typedef struct fz_cc {
    vf_cc_problem pb;
    int32_t n, m, k; /* the allocation sizes (pb's may be overwritten with invalid ones) */
    double *P, *axes, *yr, *C, *rho, *lrad;
    int structured;
} fz_cc;

typedef struct cc_out {
    vf_cc_out o;
    double *dwork;
    int32_t *iwork;
    size_t nd, ni;
} cc_out;

static const fz_cc *cur;

static void fail(const char *what, int rc, const vf_cc_out *o)
{
    const vf_cc_problem *pb = &cur->pb;
    int32_t n = cur->n, k = cur->k;
    fprintf(stderr, "\n*** velfence_cc contract violated: %s\n", what);
    fprintf(stderr,
            "problem n=%d m=%d k=%d w_e=%.17g w_z=%.17g lam=%.17g kz=%.17g h=%.17g "
            "max_speed=%.17g recheck=%d rounds=%d (structured %d)\n",
            (int)pb->n, (int)pb->m, (int)pb->k, pb->w_e, pb->w_z, pb->lam, pb->kz, pb->h,
            pb->max_speed, (int)pb->recheck, (int)pb->rounds, cur->structured);
    fz_print_vec("P", cur->P, 3 * (n + 1));
    fz_print_vec("axes", cur->axes, 3 * n);
    fz_print_vec("lrad", cur->lrad, n);
    fz_print_vec("y_r", cur->yr, cur->m);
    fz_print_vec("C", cur->C, 3 * k);
    fz_print_vec("rho", cur->rho, k);
    fprintf(stderr, "rc=%d\n", rc);
    if (o != NULL) {
        int32_t i;
        fz_print_vec("q_dot", o->q_dot, n);
        fz_print_vec("q_free", o->q_free, n);
        fz_print_vec("distances", o->distances, k);
        fprintf(stderr, "n_active=%d active:", (int)o->n_active);
        for (i = 0; i < k; i++) {
            fprintf(stderr, " %d", (int)o->active[i]);
        }
        fprintf(stderr, "\ncondition=%.17g ee_rate_error=%.17g ee_rate_error_free=%.17g\n",
                o->condition, o->ee_rate_error, o->ee_rate_error_free);
    }
    abort();
}

/* The planar / spatial chain of test_cc.c's kinematics: rotate about z by q_j, move along the
 * new x by len_j, twist about it by tw_j. */
static void kinematics(int32_t n, const double *len, const double *q, const double *tw,
                       double *P, double *axes)
{
    double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, o[3] = {0, 0, 0};
    int32_t j, r;
    for (j = 0; j < n; j++) {
        double c = cos(q[j]), s = sin(q[j]), ct = cos(tw[j]), st = sin(tw[j]);
        double x[3], y[3], z[3];
        for (r = 0; r < 3; r++) {
            P[3 * j + r] = o[r];
            axes[3 * j + r] = R[3 * r + 2];
        }
        for (r = 0; r < 3; r++) {
            x[r] = c * R[3 * r] + s * R[3 * r + 1];
            y[r] = -s * R[3 * r] + c * R[3 * r + 1];
            z[r] = R[3 * r + 2];
        }
        for (r = 0; r < 3; r++) {
            o[r] += len[j] * x[r];
            R[3 * r] = x[r];
            R[3 * r + 1] = ct * y[r] + st * z[r];
            R[3 * r + 2] = -st * y[r] + ct * z[r];
        }
    }
    for (r = 0; r < 3; r++) {
        P[3 * n + r] = o[r];
    }
}

static void alloc_arrays(fz_cc *g)
{
    g->P = fz_alloc(3 * (g->n + 1));
    g->axes = fz_alloc(3 * g->n);
    g->yr = fz_alloc(g->m);
    g->C = fz_alloc(3 * g->k);
    g->rho = fz_alloc(g->k);
    g->lrad = fz_alloc(g->n);
}

static void read_problem(fz_reader *r, uint8_t flags, fz_cc *g)
{
    vf_cc_problem *pb = &g->pb;
    int32_t i, j;
    memset(g, 0, sizeof *g);
    if (flags & 1) { /* raw */
        g->n = 1 + fz_byte(r) % 6;
        g->m = 2 + fz_byte(r) % 2;
        g->k = fz_byte(r) % 6;
        alloc_arrays(g);
        for (i = 0; i < 3 * (g->n + 1); i++) {
            g->P[i] = fz_double(r);
        }
        for (i = 0; i < 3 * g->n; i++) {
            g->axes[i] = fz_double(r);
        }
        for (i = 0; i < g->n; i++) {
            g->lrad[i] = fz_double(r);
        }
        for (i = 0; i < 3 * g->k; i++) {
            g->C[i] = fz_double(r);
        }
        for (i = 0; i < g->k; i++) {
            g->rho[i] = fz_double(r);
        }
        for (i = 0; i < g->m; i++) {
            g->yr[i] = fz_double(r);
        }
        pb->w_e = fz_double(r);
        pb->w_z = fz_double(r);
        pb->lam = fz_double(r);
        pb->kz = fz_double(r);
        pb->h = fz_double(r);
        pb->max_speed = fz_double(r);
        pb->recheck = fz_byte(r) & 1;
        pb->rounds = fz_i16(r);
    } else {
        double len[FZ_CC_MAX_N], q[FZ_CC_MAX_N], tw[FZ_CC_MAX_N];
        uint8_t b;
        int planar = fz_byte(r) & 1;
        g->n = 1 + fz_byte(r) % FZ_CC_MAX_N;
        g->m = planar ? 2 : 3;
        for (j = 0; j < g->n; j++) {
            len[j] = (1.0 + fz_byte(r)) / 256.0;
            q[j] = 6.283185307179586 * fz_byte(r) / 256.0;
            b = fz_byte(r);
            tw[j] = planar ? 0.0 : (b % 3 == 0 ? 0.0 : (b % 3 == 1 ? 1.5707963267948966 : -1.5707963267948966));
        }
        g->k = fz_byte(r) % (FZ_CC_MAX_K + 1);
        alloc_arrays(g);
        kinematics(g->n, len, q, tw, g->P, g->axes);
        for (j = 0; j < g->n; j++) {
            g->lrad[j] = fz_byte(r) / 1024.0;
        }
        for (i = 0; i < g->k; i++) {
            int32_t l = fz_byte(r) % g->n, c;
            double t = fz_byte(r) / 255.0;
            for (c = 0; c < 3; c++) {
                double base = g->P[3 * l + c] + t * (g->P[3 * l + 3 + c] - g->P[3 * l + c]);
                g->C[3 * i + c] = base + (double)fz_i16(r) / 65536.0;
            }
            if (planar) {
                g->C[3 * i + 2] = 0.0;
            }
            g->rho[i] = (1.0 + fz_byte(r)) / 256.0;
        }
        pb->w_e = 1.0;
        pb->w_z = pow(10.0, fz_byte(r) % 7);
        pb->lam = pow(10.0, -(double)(fz_byte(r) % 6));
        pb->kz = fz_byte(r) / 16.0;
        b = fz_byte(r);
        pb->h = (b & 1) ? 0.0 : b / 256.0;
        b = fz_byte(r);
        pb->max_speed = (b & 1) ? b / 32.0 : 0.0;
        pb->recheck = fz_byte(r) & 1;
        b = fz_byte(r);
        pb->rounds = (b & 1) ? b % 8 : 4 * g->k + 1;
        for (i = 0; i < g->m; i++) {
            g->yr[i] = fz_double(r);
        }
        g->structured = 1;
    }
    pb->n = g->n;
    pb->m = g->m;
    pb->k = g->k;
    pb->C = g->C;
    pb->rho = g->rho;
    pb->lrad = g->lrad;
    if (!(flags & 1) && (flags & 2)) { /* almost-valid data: one field overwritten */
        uint8_t which = fz_byte(r);
        int32_t at = fz_byte(r);
        double v = fz_double(r);
        static const int32_t bad_m[4] = {-1, 0, 1, 4};
        switch (which % 16) {
        case 0: g->P[at % (3 * (g->n + 1))] = v; break;
        case 1: g->axes[at % (3 * g->n)] = v; break;
        case 2: g->yr[at % g->m] = v; break;
        case 3: if (g->k > 0) g->C[at % (3 * g->k)] = v; break;
        case 4: if (g->k > 0) g->rho[at % g->k] = v; break;
        case 5: g->lrad[at % g->n] = v; break;
        case 6: pb->w_e = v; break;
        case 7: pb->w_z = v; break;
        case 8: pb->lam = v; break;
        case 9: pb->kz = v; break;
        case 10: pb->h = v; break;
        case 11: pb->max_speed = v; break;
        case 12: pb->m = bad_m[at % 4]; break;
        case 13: pb->n = -(at % 3); break;
        case 14: pb->k = -1 - at % 2; break;
        default: pb->rounds = (at & 1) ? -1 - at % 5 : at % 64; break;
        }
        g->structured = 0;
    }
}

static void free_problem(fz_cc *g)
{
    free(g->P);
    free(g->axes);
    free(g->yr);
    free(g->C);
    free(g->rho);
    free(g->lrad);
}

static void out_alloc(cc_out *b, int32_t n, int32_t m, int32_t k)
{
    vf_cc_out *o = &b->o;
    memset(b, 0, sizeof *b);
    o->q_dot = fz_alloc(n);
    o->q_free = fz_alloc(n);
    o->points = fz_alloc(3 * k);
    o->fractions = fz_alloc(k);
    o->distances = fz_alloc(k);
    o->normals = fz_alloc(3 * k);
    o->rows = fz_alloc(k * n);
    o->d_dot = fz_alloc(k);
    o->d_dot_free = fz_alloc(k);
    o->links = (int32_t *)malloc(k > 0 ? (size_t)k * sizeof(int32_t) : 1);
    o->active = (int32_t *)malloc(k > 0 ? (size_t)k * sizeof(int32_t) : 1);
    b->nd = vf_cc_doubles(n, m, k);
    b->ni = vf_cc_ints(k);
    b->dwork = (double *)malloc(b->nd * sizeof(double));
    b->iwork = (int32_t *)malloc(b->ni * sizeof(int32_t));
}

static void out_fill(cc_out *b, int32_t n, int32_t k, int byte)
{
    vf_cc_out *o = &b->o;
    size_t dn = (size_t)n * sizeof(double), dk = (size_t)k * sizeof(double);
    memset(o->q_dot, byte, dn);
    memset(o->q_free, byte, dn);
    memset(o->points, byte, 3 * dk);
    memset(o->fractions, byte, dk);
    memset(o->distances, byte, dk);
    memset(o->normals, byte, 3 * dk);
    memset(o->rows, byte, (size_t)n * dk);
    memset(o->d_dot, byte, dk);
    memset(o->d_dot_free, byte, dk);
    memset(o->links, byte, (size_t)k * sizeof(int32_t));
    memset(o->active, byte, (size_t)k * sizeof(int32_t));
    memset(&o->n_active, byte, sizeof o->n_active);
    memset(&o->condition, byte, sizeof o->condition);
    memset(&o->ee_rate_error, byte, sizeof o->ee_rate_error);
    memset(&o->ee_rate_error_free, byte, sizeof o->ee_rate_error_free);
    memset(b->dwork, byte, b->nd * sizeof(double));
    memset(b->iwork, byte, b->ni * sizeof(int32_t));
}

static void out_free(cc_out *b)
{
    vf_cc_out *o = &b->o;
    free(o->q_dot);
    free(o->q_free);
    free(o->points);
    free(o->fractions);
    free(o->distances);
    free(o->normals);
    free(o->rows);
    free(o->d_dot);
    free(o->d_dot_free);
    free(o->links);
    free(o->active);
    free(b->dwork);
    free(b->iwork);
}

static int same_doubles(const double *a, const double *b, int32_t count)
{
    return count <= 0 || memcmp(a, b, (size_t)count * sizeof(double)) == 0;
}

static int same_ints(const int32_t *a, const int32_t *b, int32_t count)
{
    return count <= 0 || memcmp(a, b, (size_t)count * sizeof(int32_t)) == 0;
}

static int same_out(const vf_cc_out *a, const vf_cc_out *b, int32_t n, int32_t k)
{
    return same_doubles(a->q_dot, b->q_dot, n) && same_doubles(a->q_free, b->q_free, n)
           && same_doubles(a->points, b->points, 3 * k)
           && same_doubles(a->fractions, b->fractions, k)
           && same_doubles(a->distances, b->distances, k)
           && same_doubles(a->normals, b->normals, 3 * k)
           && same_doubles(a->rows, b->rows, k * n) && same_doubles(a->d_dot, b->d_dot, k)
           && same_doubles(a->d_dot_free, b->d_dot_free, k) && same_ints(a->links, b->links, k)
           && same_ints(a->active, b->active, k) && a->n_active == b->n_active
           && fz_same_bits(a->condition, b->condition)
           && fz_same_bits(a->ee_rate_error, b->ee_rate_error)
           && fz_same_bits(a->ee_rate_error_free, b->ee_rate_error_free);
}

static int all_zero(const double *x, int32_t count)
{
    int32_t i;
    for (i = 0; i < count; i++) {
        if (!fz_same_bits(x[i], 0.0)) {
            return 0;
        }
    }
    return 1;
}

static int all_finite(const double *x, int32_t count)
{
    int32_t i;
    for (i = 0; i < count; i++) {
        if (!isfinite(x[i])) {
            return 0;
        }
    }
    return 1;
}

static int is_stop(const vf_cc_out *o, int32_t n, int32_t k)
{
    int32_t i;
    for (i = 0; i < k; i++) {
        if (o->links[i] != -1 || o->active[i] != -1) {
            return 0;
        }
    }
    return all_zero(o->q_dot, n) && all_zero(o->q_free, n) && all_zero(o->points, 3 * k)
           && all_zero(o->fractions, k) && all_zero(o->distances, k)
           && all_zero(o->normals, 3 * k) && all_zero(o->rows, k * n)
           && all_zero(o->d_dot, k) && all_zero(o->d_dot_free, k) && o->n_active == 0
           && fz_same_bits(o->condition, 0.0) && fz_same_bits(o->ee_rate_error, 0.0)
           && fz_same_bits(o->ee_rate_error_free, 0.0);
}

static int valid_by_header(const fz_cc *g)
{
    const vf_cc_problem *pb = &g->pb;
    int32_t i;
    if (pb->n < 1 || (pb->m != 2 && pb->m != 3) || pb->k < 0 || pb->rounds < 0) {
        return 0;
    }
    if (!(pb->w_e > 0.0 && isfinite(pb->w_e) && pb->w_z > 0.0 && isfinite(pb->w_z)
          && pb->lam > 0.0 && isfinite(pb->lam) && pb->kz >= 0.0 && isfinite(pb->kz)
          && pb->h >= 0.0 && isfinite(pb->h) && pb->max_speed >= 0.0)) {
        return 0;
    }
    for (i = 0; i < pb->n; i++) {
        if (!(pb->lrad[i] >= 0.0 && isfinite(pb->lrad[i]))) {
            return 0;
        }
    }
    for (i = 0; i < pb->k; i++) {
        if (!(pb->rho[i] > 0.0 && isfinite(pb->rho[i])) || !all_finite(pb->C + 3 * i, 3)) {
            return 0;
        }
    }
    return 1;
}

/* The perpendicular distance of c from the line through link l's ends (0: on the axis). */
static double off_axis(const double *P, int32_t l, const double *c)
{
    double a[3], w[3], x[3], aa = 0.0, xx = 0.0;
    int32_t r;
    for (r = 0; r < 3; r++) {
        a[r] = P[3 * l + 3 + r] - P[3 * l + r];
        w[r] = c[r] - P[3 * l + r];
        aa += a[r] * a[r];
    }
    x[0] = a[1] * w[2] - a[2] * w[1];
    x[1] = a[2] * w[0] - a[0] * w[2];
    x[2] = a[0] * w[1] - a[1] * w[0];
    for (r = 0; r < 3; r++) {
        xx += x[r] * x[r];
    }
    return aa > 0.0 ? sqrt(xx / aa) : 0.0;
}

static void check_ok(const fz_cc *g, const vf_cc_out *o)
{
    const vf_cc_problem *pb = &g->pb;
    const int32_t n = g->n, k = g->k;
    int32_t i, j;
    if (!all_finite(o->q_dot, n) || !all_finite(o->q_free, n) || !all_finite(o->points, 3 * k)
        || !all_finite(o->fractions, k) || !all_finite(o->distances, k)
        || !all_finite(o->normals, 3 * k) || !all_finite(o->rows, k * n)
        || !all_finite(o->d_dot, k) || !all_finite(o->d_dot_free, k) || !isfinite(o->condition)
        || !isfinite(o->ee_rate_error) || !isfinite(o->ee_rate_error_free)) {
        fail("VF_CC_OK with a non-finite double in the answer", VF_CC_OK, o);
    }
    if (o->n_active < 0 || o->n_active > k) {
        fail("VF_CC_OK with n_active outside 0..k", VF_CC_OK, o);
    }
    for (i = 0; i < k; i++) {
        if (o->links[i] < 0 || o->links[i] >= n) {
            fail("VF_CC_OK with a critical link outside 0..n-1", VF_CC_OK, o);
        }
        if (!(o->fractions[i] >= 0.0 && o->fractions[i] <= 1.0)) {
            fail("VF_CC_OK with a fraction outside [0, 1]", VF_CC_OK, o);
        }
    }
    for (i = 0; i < o->n_active; i++) {
        int32_t a = o->active[i];
        if (a < 0 || a >= k) {
            fail("VF_CC_OK with an active obstacle out of range", VF_CC_OK, o);
        }
        for (j = 0; j < i; j++) {
            if (o->active[j] == a) {
                fail("VF_CC_OK with an obstacle twice in the active set", VF_CC_OK, o);
            }
        }
        if (pb->h == 0.0 && !(o->distances[a] <= pb->rho[a])) {
            fail("h = 0 but an active obstacle's point is outside its sphere of influence",
                 VF_CC_OK, o);
        }
    }
    if (!(o->condition >= 1.0 * (1.0 - 1e-12)) || !(o->ee_rate_error >= 0.0)
        || !(o->ee_rate_error_free >= 0.0)) {
        fail("VF_CC_OK with condition < 1 or a negative rate error", VF_CC_OK, o);
    }
    if (pb->max_speed > 0.0) {
        for (j = 0; j < n; j++) {
            if (!(fabs(o->q_dot[j]) <= pb->max_speed)) {
                fprintf(stderr, "joint %d: |q_dot| = %.17g > max_speed\n", (int)j, o->q_dot[j]);
                fail("the joint-rate cap max_speed is not met", VF_CC_OK, o);
            }
        }
    }
    if (g->structured) {
        for (i = 0; i < k; i++) {
            const double *nv = o->normals + 3 * i;
            double nn = nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2];
            if (off_axis(g->P, o->links[i], g->C + 3 * i) > 1e-6 && !(fabs(nn - 1.0) <= 1e-9)) {
                fprintf(stderr, "obstacle %d: |n|^2 = %.17g\n", (int)i, nn);
                fail("VF_CC_OK with a normal that is not unit", VF_CC_OK, o);
            }
        }
    }
}

static void null_case(fz_reader *rd, fz_cc *g)
{
    uint8_t sel = fz_byte(rd);
    cc_out b;
    vf_cc_problem pb = g->pb;
    const vf_cc_problem *pp = &pb;
    const double *P = g->P, *ax = g->axes, *yr = g->yr;
    vf_cc_out o;
    vf_cc_out *oo = &o;
    double *dw;
    int32_t *iw;
    int rc, what = sel % 21, check_sees = 0;
    out_alloc(&b, g->n, g->m, g->k);
    o = b.o;
    dw = b.dwork;
    iw = b.iwork;
    switch (what) {
    case 0: pp = NULL; check_sees = 1; break;
    case 1: P = NULL; break;
    case 2: ax = NULL; break;
    case 3: yr = NULL; break;
    case 4: oo = NULL; break;
    case 5: dw = NULL; break;
    case 6: iw = NULL; break;
    case 7: o.q_dot = NULL; break;
    case 8: o.q_free = NULL; break;
    case 9: pb.lrad = NULL; check_sees = 1; break;
    default:
        if (g->k == 0) {
            goto done;
        }
        switch (what) {
        case 10: o.points = NULL; break;
        case 11: o.fractions = NULL; break;
        case 12: o.distances = NULL; break;
        case 13: o.normals = NULL; break;
        case 14: o.rows = NULL; break;
        case 15: o.d_dot = NULL; break;
        case 16: o.d_dot_free = NULL; break;
        case 17: o.links = NULL; break;
        case 18: o.active = NULL; break;
        case 19: pb.C = NULL; check_sees = 1; break;
        default: pb.rho = NULL; check_sees = 1; break;
        }
    }
    if (check_sees && vf_cc_check(pp) != VF_CC_ERR_NULL) {
        fprintf(stderr, "NULL pointer case %d\n", what);
        fail("vf_cc_check with a NULL pointer: not VF_CC_ERR_NULL", vf_cc_check(pp), NULL);
    }
    rc = vf_cc_solve(pp, P, ax, yr, oo, dw, iw);
    if (rc != VF_CC_ERR_NULL) {
        fprintf(stderr, "NULL pointer case %d\n", what);
        fail("vf_cc_solve with a NULL pointer: not VF_CC_ERR_NULL", rc, NULL);
    }
done:
    out_free(&b);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader rd = {data, size};
    uint8_t flags = fz_byte(&rd);
    fz_cc g;
    cc_out b1, b2;
    int rc, rc2, code, valid;
    read_problem(&rd, flags, &g);
    cur = &g;
    code = vf_cc_check(&g.pb);
    if (code != VF_CC_OK && code != VF_CC_ERR_NULL && code != VF_CC_ERR_ARGUMENT) {
        fail("vf_cc_check: code outside {OK, NULL, ARGUMENT}", code, NULL);
    }
    valid = valid_by_header(&g);
    if ((code == VF_CC_OK) != valid) {
        fprintf(stderr, "check rc=%d, the header's rules say %s\n", code,
                valid ? "valid" : "invalid");
        fail("vf_cc_check disagrees with the header's rules", code, NULL);
    }
    if (code == VF_CC_OK && (flags & 0x80)) {
        null_case(&rd, &g);
        free_problem(&g);
        return 0;
    }
    out_alloc(&b1, g.n, g.m, g.k);
    out_alloc(&b2, g.n, g.m, g.k);
    out_fill(&b1, g.n, g.k, 0);
    rc = vf_cc_solve(&g.pb, g.P, g.axes, g.yr, &b1.o, b1.dwork, b1.iwork);
#ifdef VF_FUZZ_CONTROL_TAMPER
    /* The liveness control of the tests: a result the contract must refuse (never in a real run). */
    if (rc == VF_CC_OK) {
        b1.o.q_dot[0] = NAN;
    }
#endif
    if (code != VF_CC_OK) {
        if (rc != code) {
            fail("vf_cc_solve: not the check's code on a problem the check refuses", rc, NULL);
        }
    } else {
        int finite_in = all_finite(g.P, 3 * (g.n + 1)) && all_finite(g.axes, 3 * g.n)
                        && all_finite(g.yr, g.m);
        if (rc != VF_CC_OK && rc != VF_CC_ERR_NONFINITE && rc != VF_CC_ERR_OVERFLOW) {
            fail("vf_cc_solve: code outside {OK, NONFINITE, OVERFLOW} on a checked problem", rc,
                 NULL);
        }
        if ((rc == VF_CC_ERR_NONFINITE) != !finite_in) {
            fail("vf_cc_solve: VF_CC_ERR_NONFINITE not exactly for non-finite P, axes, y_r", rc,
                 &b1.o);
        }
        if (rc != VF_CC_OK && !is_stop(&b1.o, g.n, g.k)) {
            fail("vf_cc_solve: an error code without the documented stop result", rc, &b1.o);
        }
        if (rc == VF_CC_OK) {
            check_ok(&g, &b1.o);
        }
        out_fill(&b2, g.n, g.k, 0xff); /* NaN garbage */
        rc2 = vf_cc_solve(&g.pb, g.P, g.axes, g.yr, &b2.o, b2.dwork, b2.iwork);
        if (rc2 != rc || !same_out(&b1.o, &b2.o, g.n, g.k)) {
            fail("vf_cc_solve: a second call (NaN garbage in the workspace) differs", rc, &b1.o);
        }
    }
    out_free(&b1);
    out_free(&b2);
    free_problem(&g);
    return 0;
}
