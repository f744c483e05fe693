/*
 * fuzz_filter.c -- libFuzzer target of the safety filter's row helpers (core/include/velfence_nd.h):
 * vf_nd_rate_bounds, vf_nd_capsule_clearances, vf_nd_capsule_rows, vf_nd_chain_kinematics and
 * vf_nd_filter_rows (with vf_nd_filter_rows_max and vf_nd_filter_doubles). Build:
 * core/fuzz/build.sh. Input layout (doubles and the byte cursor: fuzz_common.h):
 *
 *   flags byte: bit 0 raw-ish (q, u and previous decoded doubles), bit 1 previous NULL, bit 2 amax
 *               NULL, bit 3 continuous time (dt = 0), bit 4 (without bit 0) q, u and previous
 *               decoded doubles of magnitude <= 1e150 (others read as 0)
 *   n = 1 + byte % 8 joints; per joint the DH row a = (byte - 128) / 256 [m], alpha = 2 pi byte /
 *     256 (cos and sin stored), d = (byte - 128) / 256 [m], offset 2 pi byte / 256; the tool
 *     point three (byte - 128) / 512 [m]
 *   per joint: lower -inf (odd byte) or -(byte >> 1) / 32, upper +inf (odd byte) or (byte >> 1) /
 *     32 [rad], vmax (1 + byte) / 32 > 0, amax +inf (byte 255) or (1 + byte) / 4, a profile
 *   a profile: kind byte (even: VF_ND_PROFILE_LINEAR with d_max = (1 + byte) / 64 > 0, k = byte /
 *     16 >= 0, r_max = (1 + byte) / 64 > 0; odd: VF_ND_PROFILE_THREE_ZONE with K = (1 + byte) / 4,
 *     a = (1 + byte) / 4, max_speed = a / K (1 + (1 + byte) / 16) > a / K and d_int, d_f, d_phi
 *     derived as velfence.shaping.profiles.ThreeZoneBraking derives them)
 *   dt = (1 + byte) / 1024 [s] (0 with flags bit 3)
 *   nw = byte % 4 workspace limits: nf = 1 + byte % 6, point = byte % (n + 2) - 1 (-1 the flange),
 *     a profile, per facet a unit normal from two angles (2 pi byte / 256 each) and an offset
 *     (byte - 128) / 128 [m]
 *   k = byte % 5 spheres: the obstacle profile, buffer (1 + byte) / 64 [m], per link a capsule
 *     radius byte / 512 [m], per sphere a centre three (byte - 128) / 128 [m] and a radius byte /
 *     256 >= 0 [m]; cap.vmax = the joints' vmax (NULL with byte 1 of a further byte & 1)
 *   per joint q_j = 4 int16 / 32768 [rad], u_j and previous_j int16 / 4096 (flags bit 4: three
 *     decoded doubles, each of magnitude <= 1e150 or else 0; raw-ish: three decoded doubles)
 *
 * The helpers are documented "No input check" (SafetyFilter validates), so the filter data above
 * is always well-formed (finite DH rows with cos^2 + sin^2 = 1, unit normals, vmax > 0, valid
 * profile parameters, radii >= 0). In the structured mode the per-call input q, u, previous is
 * finite too and at most 1e150 in magnitude (what SafetyFilter accepts: it refuses larger finite
 * input as it refuses NaN and inf), and asserted (abort() on a violation, after printing the decoded input) is:
 *   the row count r: 2 n <= r <= vf_nd_filter_rows_max;
 *   P, axes, flange equal vf_nd_chain_kinematics called directly (bit for bit) and the
 *     multiplied-out 4x4 DH transforms within 1e-12 (1 + the chain's size sum |a| + |d| + |tool|);
 *   levels in SafetyFilter's order joint, acceleration (VF_ND_LEVEL_RATE), workspace, obstacle;
 *   every b finite (rows without a bound are left out);
 *   joint rows: tag_a = 4 j + side increasing, tag_b = 0, G = +e_j (sides 0, 2) or -e_j (1, 3);
 *     the velocity rows 4 j + 2, 4 j + 3 always, with b = -vmax_j and dist = +inf; a position
 *     row only for a finite limit, with dist = q_j - lower_j or upper_j - q_j;
 *   acceleration rows exactly when previous, dt > 0 and amax are given, two per joint with finite
 *     amax_j, tag (j, side), G = +-e_j, b = previous_j - amax_j dt and -(previous_j + amax_j dt)
 *     (bit for bit), dist = +inf;
 *   workspace rows: tag (limit, facet) in range and increasing, dist = N_i . p - off_i and b the
 *     bound vf_nd_rate_bounds gives at the point's speed |J u| (bit for bit), exactly the facets
 *     whose bound is not -inf; G = N_i J within tolerance (J: z_j x (p - P_j) of the
 *     reference kinematics), zero beyond the point's joints;
 *   obstacle rows: exactly vf_nd_capsule_rows called directly at the same pose (count, G, b, d,
 *     sphere, link: bit for bit), sphere-major with the pairs increasing, tags in range, dist the
 *     pair's clearance from vf_nd_capsule_clearances (bit for bit), below the buffer in
 *     continuous time;
 *   vf_nd_rate_bounds never gives NaN or +inf;
 *   a second call gives identical bits.
 * Raw-ish mode (flags bit 0): q, u and previous are any decoded doubles (NaN, inf, up to
 * DBL_MAX). A non-finite per-call input is outside the documented contract (no input check), so
 * only memory safety (ASan/UBSan) and 0 <= r <= vf_nd_filter_rows_max are asserted. (A finite u
 * near DBL_MAX makes the point speed |J u| overflow and gives NaN bounds: not promised by the
 * header, and refused by SafetyFilter above 1e150, so not asserted.)
 * Every output array is malloc'ed at exactly its documented size (rows_max rows,
 * vf_nd_filter_doubles doubles of work, k nl + nl doubles for vf_nd_capsule_rows), so
 * AddressSanitizer sees an overrun. VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) spoils the
 * first bound of every structured call with a NaN, for the tests' proof that a violation aborts.
 */
#define VF_FUZZ_BYTES_ONLY
#include "fuzz_common.h"
#include "velfence_nd.h"

#define MAXN 8
#define MAXW 3
#define MAXF 6
#define MAXK 4
#define TWO_PI 6.283185307179586

static uint8_t flags;
static int32_t n, nw;
static double dh[5 * MAXN], tool[3], lower[MAXN], upper[MAXN], vmax[MAXN], amax[MAXN];
static double jprm[VF_ND_PROFILE_PARAMS * MAXN], lrad[MAXN], C[3 * MAXK], srad[MAXK];
static double wN[MAXW][3 * MAXF], woff[MAXW][MAXF];
static double q[MAXN], u[MAXN], prev[MAXN], dt;
static int32_t jkind[MAXN];
static vf_nd_workspace ws[MAXW];
static vf_nd_filter f;

static void print_prm(int32_t kind, const double *prm)
{
    int i;
    fprintf(stderr, " kind %d prm", (int)kind);
    for (i = 0; i < VF_ND_PROFILE_PARAMS; i++) {
        fprintf(stderr, " %.17g", prm[i]);
    }
    fprintf(stderr, "\n");
}

static void print_input(void)
{
    int32_t i, j, w;
    fprintf(stderr, "filter n=%d flags %d dt %.17g\n", (int)n, (int)flags, dt);
    fprintf(stderr, "dh (a, cos alpha, sin alpha, d, offset):\n");
    for (i = 0; i < n; i++) {
        for (j = 0; j < 5; j++) {
            fprintf(stderr, " %.17g", dh[5 * i + j]);
        }
        fprintf(stderr, "\n");
    }
    fz_print_vec("tool", tool, 3);
    fz_print_vec("lower", lower, n);
    fz_print_vec("upper", upper, n);
    fz_print_vec("vmax", vmax, n);
    fz_print_vec("amax", amax, n);
    for (j = 0; j < n; j++) {
        fprintf(stderr, "joint %d", (int)j);
        print_prm(jkind[j], jprm + VF_ND_PROFILE_PARAMS * j);
    }
    for (w = 0; w < nw; w++) {
        fprintf(stderr, "workspace %d nf %d point %d", (int)w, (int)ws[w].nf, (int)ws[w].point);
        print_prm(ws[w].kind, ws[w].prm);
        fz_print_vec(" N", wN[w], 3 * ws[w].nf);
        fz_print_vec(" off", woff[w], ws[w].nf);
    }
    fprintf(stderr, "spheres k %d buf %.17g vmax %s", (int)f.cap.k, f.cap.buf,
            f.cap.vmax != NULL ? "given" : "NULL");
    print_prm(f.cap.kind, f.cap.prm);
    fz_print_vec(" lrad", lrad, n);
    fz_print_vec(" C", C, 3 * f.cap.k);
    fz_print_vec(" srad", srad, f.cap.k);
    fz_print_vec("q", q, n);
    fz_print_vec("u", u, n);
    fz_print_vec("previous", prev, n);
}

static void fail(const char *what, int32_t row, int32_t r, const double *b, const double *dist,
                 const int32_t *level, const int32_t *ta, const int32_t *tb)
{
    int32_t i;
    fprintf(stderr, "velfence_nd filter contract violated: %s (row %d of %d)\n", what, (int)row,
            (int)r);
    print_input();
    if (b != NULL) {
        for (i = 0; i < r; i++) {
            fprintf(stderr, "row %d: level %d tags %d %d b %.17g dist %.17g\n", (int)i,
                    (int)level[i], (int)ta[i], (int)tb[i], b[i], dist[i]);
        }
    }
    abort();
}

static double ubyte(fz_reader *rd, double base, double scale)
{
    return (fz_byte(rd) - base) / scale;
}

static void decode(fz_reader *rd)
{
    int32_t i, j, w;
    uint8_t bt;
    memset(&f, 0, sizeof f);
    n = 1 + fz_byte(rd) % MAXN;
    for (i = 0; i < n; i++) {
        double al;
        dh[5 * i] = ubyte(rd, 128.0, 256.0);
        al = TWO_PI * fz_byte(rd) / 256.0;
        dh[5 * i + 1] = cos(al);
        dh[5 * i + 2] = sin(al);
        dh[5 * i + 3] = ubyte(rd, 128.0, 256.0);
        dh[5 * i + 4] = TWO_PI * fz_byte(rd) / 256.0;
    }
    for (j = 0; j < 3; j++) {
        tool[j] = ubyte(rd, 128.0, 512.0);
    }
    for (j = 0; j < n; j++) {
        bt = fz_byte(rd);
        lower[j] = bt & 1 ? -INFINITY : -(bt >> 1) / 32.0;
        bt = fz_byte(rd);
        upper[j] = bt & 1 ? INFINITY : (bt >> 1) / 32.0;
        vmax[j] = (1 + fz_byte(rd)) / 32.0;
        bt = fz_byte(rd);
        amax[j] = bt == 255 ? INFINITY : (1 + bt) / 4.0;
        fz_profile(rd, &jkind[j], jprm + VF_ND_PROFILE_PARAMS * j);
    }
    dt = (1 + fz_byte(rd)) / 1024.0;
    if (flags & 8) {
        dt = 0.0;
    }
    nw = fz_byte(rd) % (MAXW + 1);
    for (w = 0; w < nw; w++) {
        vf_nd_workspace *s = ws + w;
        memset(s, 0, sizeof *s);
        s->nf = 1 + fz_byte(rd) % MAXF;
        s->point = fz_byte(rd) % (n + 2) - 1;
        fz_profile(rd, &s->kind, s->prm);
        for (i = 0; i < s->nf; i++) {
            double th = TWO_PI * fz_byte(rd) / 256.0, ph = TWO_PI * fz_byte(rd) / 256.0;
            wN[w][3 * i] = cos(ph) * cos(th);
            wN[w][3 * i + 1] = cos(ph) * sin(th);
            wN[w][3 * i + 2] = sin(ph);
            woff[w][i] = ubyte(rd, 128.0, 128.0);
        }
        s->N = wN[w];
        s->off = woff[w];
    }
    f.cap.k = fz_byte(rd) % (MAXK + 1);
    fz_profile(rd, &f.cap.kind, f.cap.prm);
    f.cap.buf = (1 + fz_byte(rd)) / 64.0;
    for (j = 0; j < n; j++) {
        lrad[j] = fz_byte(rd) / 512.0;
    }
    for (i = 0; i < f.cap.k; i++) {
        for (j = 0; j < 3; j++) {
            C[3 * i + j] = ubyte(rd, 128.0, 128.0);
        }
        srad[i] = fz_byte(rd) / 256.0;
    }
    f.cap.vmax = fz_byte(rd) & 1 ? NULL : vmax;
    f.cap.vsum = 0.0;
    for (j = 0; j < n; j++) {
        f.cap.vsum += vmax[j];
    }
    f.cap.lrad = lrad;
    f.cap.C = C;
    f.cap.srad = srad;
    f.cap.nl = f.cap.nj = f.cap.ncols = n;
    for (j = 0; j < n; j++) {
        if (flags & 1) {
            q[j] = fz_double(rd);
            u[j] = fz_double(rd);
            prev[j] = fz_double(rd);
        } else if (flags & 16) {
            /* decoded doubles within SafetyFilter's magnitude cap (1e150), else 0 */
            q[j] = fz_double(rd);
            u[j] = fz_double(rd);
            prev[j] = fz_double(rd);
            q[j] = fabs(q[j]) <= 1e150 ? q[j] : 0.0;
            u[j] = fabs(u[j]) <= 1e150 ? u[j] : 0.0;
            prev[j] = fabs(prev[j]) <= 1e150 ? prev[j] : 0.0;
        } else {
            q[j] = 4.0 * fz_i16(rd) / 32768.0;
            u[j] = fz_i16(rd) / 4096.0;
            prev[j] = fz_i16(rd) / 4096.0;
        }
    }
    f.n = n;
    f.dh = dh;
    f.tool = tool;
    f.lower = lower;
    f.upper = upper;
    f.vmax = vmax;
    f.amax = flags & 4 ? NULL : amax;
    f.jkind = jkind;
    f.jprm = jprm;
    f.nw = nw;
    f.ws = ws;
}

/* core/tests/test_nd.c's dh_reference: the multiplied-out 4x4 DH transforms (and the flange) */
static void dh_reference(const double *qq, double *P, double *axes, double *flange)
{
    double T[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}, R[16];
    int32_t i, r, c, k;
    P[0] = P[1] = P[2] = 0.0;
    for (i = 0; i < n; i++) {
        const double *h = dh + 5 * i;
        double th = qq[i] + h[4], ct = cos(th), st = sin(th), ca = h[1], sa = h[2];
        double A[16] = {ct, -st * ca, st * sa, h[0] * ct, st, ct * ca, -ct * sa, h[0] * st,
                        0,  sa,       ca,      h[3],      0,  0,       0,        1};
        for (c = 0; c < 3; c++) {
            axes[3 * i + c] = T[4 * c + 2];
        }
        for (r = 0; r < 4; r++) {
            for (c = 0; c < 4; c++) {
                R[4 * r + c] = 0.0;
                for (k = 0; k < 4; k++) {
                    R[4 * r + c] += T[4 * r + k] * A[4 * k + c];
                }
            }
        }
        memcpy(T, R, sizeof(T));
        for (c = 0; c < 3; c++) {
            P[3 * i + 3 + c] = T[4 * c + 3];
        }
    }
    for (c = 0; c < 3; c++) {
        flange[c] = T[4 * c + 3];
        P[3 * n + c] = T[4 * c + 3] + T[4 * c] * tool[0] + T[4 * c + 1] * tool[1]
                       + T[4 * c + 2] * tool[2];
    }
}

static int32_t *int_alloc(size_t count)
{
    return (int32_t *)malloc(count > 0 ? count * sizeof(int32_t) : 1);
}

typedef struct outs {
    double *P, *axes, *flange, *G, *b, *dist, *work;
    int32_t *level, *ta, *tb;
} outs;

static void outs_alloc(outs *o, size_t rmax, size_t nd)
{
    o->P = fz_alloc(3 * (n + 1));
    o->axes = fz_alloc(3 * n);
    o->flange = fz_alloc(3);
    o->G = fz_alloc((int32_t)(rmax * (size_t)n));
    o->b = fz_alloc((int32_t)rmax);
    o->dist = fz_alloc((int32_t)rmax);
    o->work = fz_alloc((int32_t)nd);
    o->level = int_alloc(rmax);
    o->ta = int_alloc(rmax);
    o->tb = int_alloc(rmax);
}

static void outs_free(outs *o)
{
    free(o->P);
    free(o->axes);
    free(o->flange);
    free(o->G);
    free(o->b);
    free(o->dist);
    free(o->work);
    free(o->level);
    free(o->ta);
    free(o->tb);
}

static int same(const double *a, const double *b, size_t m)
{
    size_t i;
    for (i = 0; i < m; i++) {
        if (!fz_same_bits(a[i], b[i])) {
            return 0;
        }
    }
    return 1;
}

static int same_i(const int32_t *a, const int32_t *b, size_t m)
{
    return m == 0 || memcmp(a, b, m * sizeof(int32_t)) == 0;
}

/* G row i is sign * e_col (other entries +-0) */
static int unit_row(const double *g, int32_t col, double sign)
{
    int32_t j;
    for (j = 0; j < n; j++) {
        if (j == col ? g[j] != sign : g[j] != 0.0) {
            return 0;
        }
    }
    return 1;
}

#define FAIL(what, row) fail(what, row, r, o.b, o.dist, o.level, o.ta, o.tb)

static void check(const outs *po, int32_t r, size_t rmax, const double *qq, const double *uu,
                  const double *pp)
{
    const outs o = *po;
    double Pr[3 * (MAXN + 1)], Ar[3 * MAXN], Fr[3], scale = 1.0, tol;
    double Pk[3 * (MAXN + 1)], Ak[3 * MAXN], Fk[3];
    int32_t i, j, w, row, rank, last = 0, lastjt = -1, lastws = -1, nacc = 0;
    const int accel = pp != NULL && dt > 0.0 && f.amax != NULL;
    if (r < 2 * n || (size_t)r > rmax) {
        FAIL("the row count outside 2 n .. vf_nd_filter_rows_max", -1);
    }
    /* kinematics */
    vf_nd_chain_kinematics(n, dh, tool, qq, Pk, Ak, Fk);
    if (!same(Pk, o.P, 3 * (size_t)(n + 1)) || !same(Ak, o.axes, 3 * (size_t)n)
        || !same(Fk, o.flange, 3)) {
        FAIL("P, axes or flange differ from vf_nd_chain_kinematics", -1);
    }
    dh_reference(qq, Pr, Ar, Fr);
    for (i = 0; i < n; i++) {
        scale += fabs(dh[5 * i]) + fabs(dh[5 * i + 3]);
    }
    scale += fabs(tool[0]) + fabs(tool[1]) + fabs(tool[2]);
    tol = 1e-12 * scale;
    for (i = 0; i < 3 * (n + 1); i++) {
        if (!(fabs(o.P[i] - Pr[i]) <= tol)) {
            FAIL("a joint point differs from the 4x4 DH transforms", -1);
        }
    }
    for (i = 0; i < 3 * n; i++) {
        if (!(fabs(o.axes[i] - Ar[i]) <= 1e-12 * (1.0 + n))) {
            FAIL("a joint axis differs from the 4x4 DH transforms", -1);
        }
    }
    for (i = 0; i < 3; i++) {
        if (!(fabs(o.flange[i] - Fr[i]) <= tol)) {
            FAIL("the flange differs from the 4x4 DH transforms", -1);
        }
    }
    for (row = 0; row < r; row++) {
        const int32_t lv = o.level[row];
        const double *g = o.G + (size_t)row * n;
        if (lv < 0 || lv > 3) {
            FAIL("a level out of range", row);
        }
        rank = lv == VF_ND_LEVEL_JOINT ? 0 : (lv == VF_ND_LEVEL_RATE ? 1 : lv + 1);
        if (rank < last) {
            FAIL("levels out of SafetyFilter's order", row);
        }
        last = rank;
        if (!isfinite(o.b[row])) {
            FAIL("a bound that is not finite", row);
        }
        if (lv == VF_ND_LEVEL_JOINT) {
            int32_t t = o.ta[row], side;
            if (t <= lastjt || t < 0 || t >= 4 * n || o.tb[row] != 0) {
                FAIL("a joint row's tags", row);
            }
            /* every velocity row of the joints before present */
            for (i = lastjt + 1; i < t; i++) {
                if (i % 4 >= 2) {
                    FAIL("a missing velocity row", row);
                }
            }
            lastjt = t;
            j = t / 4;
            side = t % 4;
            if (!unit_row(g, j, side % 2 ? -1.0 : 1.0)) {
                FAIL("a joint row that is not +-e_j", row);
            }
            if (side >= 2) {
                if (!fz_same_bits(o.b[row], -vmax[j]) || o.dist[row] != INFINITY) {
                    FAIL("a velocity row's b or dist", row);
                }
            } else if (side == 0) {
                if (!isfinite(lower[j]) || !fz_same_bits(o.dist[row], qq[j] - lower[j])) {
                    FAIL("a lower position row's limit or dist", row);
                }
            } else if (!isfinite(upper[j]) || !fz_same_bits(o.dist[row], upper[j] - qq[j])) {
                FAIL("an upper position row's limit or dist", row);
            }
        } else if (lv == VF_ND_LEVEL_RATE) {
            double step;
            j = o.ta[row];
            if (!accel || j < 0 || j >= n || !isfinite(amax[j]) || o.tb[row] != nacc % 2
                || (nacc % 2 == 1 && o.ta[row - 1] != j) || (nacc % 2 == 0 && nacc > 0
                                                             && o.ta[row - 1] >= j)) {
                FAIL("an acceleration row's tags or presence", row);
            }
            step = amax[j] * dt;
            if (!unit_row(g, j, o.tb[row] ? -1.0 : 1.0)
                || !fz_same_bits(o.b[row], o.tb[row] ? -(pp[j] + step) : pp[j] - step)
                || o.dist[row] != INFINITY) {
                FAIL("an acceleration row's G, b or dist", row);
            }
            nacc += 1;
        } else if (lv == VF_ND_LEVEL_WORKSPACE) {
            int32_t t = o.ta[row] * MAXF + o.tb[row];
            if (o.ta[row] < 0 || o.ta[row] >= nw || o.tb[row] < 0 || o.tb[row] >= ws[o.ta[row]].nf
                || t <= lastws) {
                FAIL("a workspace row's tags", row);
            }
            lastws = t;
        }
    }
    if (lastjt != 4 * n - 1) {
        FAIL("the last joint's velocity rows missing", -1);
    }
    {
        int32_t want = 0;
        if (accel) {
            for (j = 0; j < n; j++) {
                want += isfinite(amax[j]) ? 2 : 0;
            }
        }
        if (nacc != want) {
            FAIL("acceleration rows missing", -1);
        }
    }
    /* workspace rows against vf_nd_rate_bounds at the point's speed */
    row = 0;
    while (row < r && o.level[row] != VF_ND_LEVEL_WORKSPACE && o.level[row] != VF_ND_LEVEL_OBSTACLE) {
        row++;
    }
    for (w = 0; w < nw; w++) {
        const vf_nd_workspace *s = ws + w;
        const double *p = s->point < 0 ? o.flange : o.P + 3 * (size_t)s->point;
        const double *pr = s->point < 0 ? Fr : Pr + 3 * (size_t)s->point;
        const int32_t k = s->point < 0 ? n : s->point;
        double vx = 0.0, vy = 0.0, vz = 0.0, d[MAXF], bnd[MAXF], Jr[3 * MAXN];
        int32_t wk[2 * MAXF];
        for (j = 0; j < k; j++) {
            const double *z = o.axes + 3 * (size_t)j;
            const double *pj = o.P + 3 * (size_t)j;
            double dx = p[0] - pj[0], dy = p[1] - pj[1], dz = p[2] - pj[2];
            double jx = z[1] * dz - z[2] * dy, jy = z[2] * dx - z[0] * dz;
            double jz = z[0] * dy - z[1] * dx;
            vx += jx * uu[j];
            vy += jy * uu[j];
            vz += jz * uu[j];
            /* the reference Jacobian */
            z = Ar + 3 * (size_t)j;
            pj = Pr + 3 * (size_t)j;
            dx = pr[0] - pj[0];
            dy = pr[1] - pj[1];
            dz = pr[2] - pj[2];
            Jr[3 * j] = z[1] * dz - z[2] * dy;
            Jr[3 * j + 1] = z[2] * dx - z[0] * dz;
            Jr[3 * j + 2] = z[0] * dy - z[1] * dx;
        }
        for (i = 0; i < s->nf; i++) {
            const double *nn = s->N + 3 * (size_t)i;
            d[i] = nn[0] * p[0] + nn[1] * p[1] + nn[2] * p[2] - s->off[i];
        }
        vf_nd_rate_bounds(s->kind, s->prm, d, s->nf, sqrt(vx * vx + vy * vy + vz * vz), dt > 0.0 ? 1.0 / dt : 0.0,
                          bnd, wk);
        for (i = 0; i < s->nf; i++) {
            const double *nn = s->N + 3 * (size_t)i;
            const double *g = o.G + (size_t)row * n;
            if (isnan(bnd[i]) || bnd[i] == INFINITY) {
                FAIL("vf_nd_rate_bounds gave NaN or +inf", row);
            }
            if (bnd[i] == -INFINITY) {
                if (row < r && o.level[row] == VF_ND_LEVEL_WORKSPACE && o.ta[row] == w
                    && o.tb[row] == i) {
                    FAIL("a workspace row without a bound", row);
                }
                continue;
            }
            if (row >= r || o.level[row] != VF_ND_LEVEL_WORKSPACE || o.ta[row] != w
                || o.tb[row] != i) {
                FAIL("a bounded workspace facet without its row", row);
            }
            if (!fz_same_bits(o.b[row], bnd[i]) || !fz_same_bits(o.dist[row], d[i])) {
                FAIL("a workspace row's b or dist", row);
            }
            for (j = 0; j < n; j++) {
                double want = j < k ? nn[0] * Jr[3 * j] + nn[1] * Jr[3 * j + 1]
                                          + nn[2] * Jr[3 * j + 2]
                                    : 0.0;
                if (!(fabs(g[j] - want) <= 1e-11 * scale * scale)) {
                    FAIL("a workspace row's G differs from N_i J", row);
                }
            }
            row++;
        }
    }
    /* obstacle rows: vf_nd_capsule_rows at the same pose, its clearances */
    {
        const int32_t k = f.cap.k, pairs = f.cap.k * n;
        vf_nd_capsules cap = f.cap;
        double *G2 = fz_alloc(pairs * n), *b2 = fz_alloc(pairs), *d2 = fz_alloc(pairs);
        double *w2 = fz_alloc(pairs + n), *cl = fz_alloc(pairs);
        int32_t *obs = int_alloc((size_t)pairs), *lnk = int_alloc((size_t)pairs), m, c, lastp = -1;
        cap.P = o.P;
        cap.axes = o.axes;
        cap.dt = dt > 0.0 ? dt : 0.0;
        cap.idt = dt > 0.0 ? 1.0 / dt : 0.0;
        m = vf_nd_capsule_rows(&cap, uu, G2, b2, d2, obs, lnk, w2);
        vf_nd_capsule_clearances(&cap, cl);
        if (m < 0 || m > pairs || m != r - row) {
            FAIL("the obstacle row count differs from vf_nd_capsule_rows", row);
        }
        for (c = 0; c < m; c++) {
            const int32_t rr = row + c;
            if (o.level[rr] != VF_ND_LEVEL_OBSTACLE || o.ta[rr] != obs[c] || o.tb[rr] != lnk[c]
                || !fz_same_bits(o.b[rr], b2[c]) || !fz_same_bits(o.dist[rr], d2[c])
                || !same(o.G + (size_t)rr * n, G2 + (size_t)c * n, (size_t)n)) {
                FAIL("an obstacle row differs from vf_nd_capsule_rows", rr);
            }
            if (obs[c] < 0 || obs[c] >= k || lnk[c] < 0 || lnk[c] >= n
                || obs[c] * n + lnk[c] <= lastp) {
                FAIL("an obstacle row's tags", rr);
            }
            lastp = obs[c] * n + lnk[c];
            if (!fz_same_bits(d2[c], cl[lastp])) {
                FAIL("an obstacle row's dist differs from vf_nd_capsule_clearances", rr);
            }
            if (dt == 0.0 && !(d2[c] < f.cap.buf)) {
                FAIL("a continuous-time obstacle row beyond the buffer", rr);
            }
        }
        free(G2);
        free(b2);
        free(d2);
        free(w2);
        free(cl);
        free(obs);
        free(lnk);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader rd = {data, size};
    size_t rmax, nd;
    outs o, o2;
    double *qa, *ua, *pa;
    int32_t r, r2;
    flags = fz_byte(&rd);
    decode(&rd);
    rmax = vf_nd_filter_rows_max(&f);
    nd = vf_nd_filter_doubles(&f);
    outs_alloc(&o, rmax, nd);
    outs_alloc(&o2, rmax, nd);
    qa = fz_alloc(n);
    ua = fz_alloc(n);
    pa = fz_alloc(n);
    memcpy(qa, q, (size_t)n * sizeof(double));
    memcpy(ua, u, (size_t)n * sizeof(double));
    memcpy(pa, prev, (size_t)n * sizeof(double));
    r = vf_nd_filter_rows(&f, qa, ua, flags & 2 ? NULL : pa, dt, o.P, o.axes, o.flange, o.G, o.b,
                          o.level, o.ta, o.tb, o.dist, o.work);
    if (r < 0 || (size_t)r > rmax) {
        fail("the row count outside 0 .. vf_nd_filter_rows_max", -1, r, NULL, NULL, NULL, NULL,
             NULL);
    }
    if (!(flags & 1)) {
#ifdef VF_FUZZ_CONTROL_TAMPER
        o.b[0] = NAN;
#endif
        check(&o, r, rmax, qa, ua, flags & 2 ? NULL : pa);
        r2 = vf_nd_filter_rows(&f, qa, ua, flags & 2 ? NULL : pa, dt, o2.P, o2.axes, o2.flange,
                               o2.G, o2.b, o2.level, o2.ta, o2.tb, o2.dist, o2.work);
        if (r2 != r || !same(o.P, o2.P, 3 * (size_t)(n + 1)) || !same(o.axes, o2.axes, 3 * (size_t)n)
            || !same(o.flange, o2.flange, 3) || !same(o.G, o2.G, (size_t)r * n)
            || !same(o.b, o2.b, (size_t)r) || !same(o.dist, o2.dist, (size_t)r)
            || !same_i(o.level, o2.level, (size_t)r) || !same_i(o.ta, o2.ta, (size_t)r)
            || !same_i(o.tb, o2.tb, (size_t)r)) {
            fail("a second call differs", -1, r, o.b, o.dist, o.level, o.ta, o.tb);
        }
    } else {
        /* raw-ish: memory safety of the direct calls too */
        vf_nd_capsules cap = f.cap;
        const int32_t pairs = f.cap.k * n;
        double *G2 = fz_alloc(pairs * n), *b2 = fz_alloc(pairs), *d2 = fz_alloc(pairs);
        double *w2 = fz_alloc(pairs + n), *cl = fz_alloc(pairs);
        int32_t *obs = int_alloc((size_t)pairs), *lnk = int_alloc((size_t)pairs), m;
        cap.P = o.P;
        cap.axes = o.axes;
        cap.dt = dt;
        cap.idt = dt > 0.0 ? 1.0 / dt : 0.0;
        m = vf_nd_capsule_rows(&cap, ua, G2, b2, d2, obs, lnk, w2);
        vf_nd_capsule_clearances(&cap, cl);
        if (m < 0 || m > pairs) {
            fail("vf_nd_capsule_rows's count outside 0 .. k nl", -1, r, NULL, NULL, NULL, NULL,
                 NULL);
        }
        free(G2);
        free(b2);
        free(d2);
        free(w2);
        free(cl);
        free(obs);
        free(lnk);
    }
    outs_free(&o);
    outs_free(&o2);
    free(qa);
    free(ua);
    free(pa);
    return 0;
}
