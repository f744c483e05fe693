/*
 * fuzz_rr.c -- libFuzzer target of the resolved-rate SR step (core/include/velfence_rr.h):
 * vf_rr_jacobian and vf_rr_sr_step. Build: core/fuzz/build.sh. Input layout (doubles and the byte
 * cursor: fuzz_common.h):
 *
 *   flags byte: bit 0 raw, bit 1 q as decoded doubles (structured), bit 7 one NULL-pointer case
 *               (a selector byte at the end)
 *   structured: six standard-DH rows, each a = byte / 256 [m], alpha one of 0, +pi/2, -pi/2
 *               (byte % 3), d = (byte - 128) / 256 [m], offset 2 pi byte / 256; the tool point
 *               three (byte - 128) / 512 [m]; k0 = (1 + byte) / 1024, w0 = (1 + byte) / 4096,
 *               singular_tol 0, 1e-10 or w0 (byte % 3), max_speed 0 or byte / 16; q six angles
 *               2 pi int16 / 65536 (or six decoded doubles); x' six decoded doubles
 *   raw:        every DH entry (cos and sin of alpha included), the tool, the four parameters,
 *               q and x' decoded doubles
 *
 * Asserted (abort() on a violation, after printing the decoded input):
 *   vf_rr_jacobian returns VF_OK, or VF_ERR_NONFINITE exactly when q holds a NaN or +-inf
 *     (J then all +0);
 *   vf_rr_sr_step returns VF_ERR_ARGUMENT exactly when the parameters or the arm break the
 *     header's rules (k0 and w0 finite > 0, singular_tol and max_speed >= 0 and not NaN, every DH
 *     and tool entry finite), else VF_ERR_NONFINITE exactly when q or x' is not finite, else
 *     VF_OK, VF_ERR_SINGULAR (only once w and the damping k are computed: the undamped
 *     k = 0, w <= singular_tol, or a Cholesky pivot <= 0) or VF_ERR_OVERFLOW;
 *   on an error q' = +0 and scale = 1;
 *   on VF_OK every double of the answer is finite, w = |det|, k = 0 when w >= w0 and
 *     0 <= k <= k0, singular exactly when w <= singular_tol, never k = 0 with singular (that
 *     step is VF_ERR_SINGULAR), scale in [0, 1] (1 without a cap), with max_speed > 0 every
 *     |q'_j| <= max_speed;
 *   a second call gives identical bits;
 *   NULL pointers (flags bit 7): arm, prm, q, xdot or out of vf_rr_sr_step, arm, q or J of
 *     vf_rr_jacobian: VF_ERR_NULL.
 * VF_FUZZ_CONTROL_TAMPER (build.sh --control-tamper) spoils every VF_OK joint rate with a NaN,
 * for the tests' proof that a violation aborts.
 */
#define VF_FUZZ_BYTES_ONLY
#include "fuzz_common.h"
#include "velfence_rr.h"

static vf_rr_arm arm;
static vf_rr_params prm;
static double q[6], xd[6];

static void print_input(void)
{
    int i, j;
    fprintf(stderr, "arm (a, cos alpha, sin alpha, d, offset):\n");
    for (i = 0; i < 6; i++) {
        for (j = 0; j < 5; j++) {
            fprintf(stderr, " %.17g", arm.dh[i][j]);
        }
        fprintf(stderr, "\n");
    }
    fprintf(stderr, "tool: %.17g %.17g %.17g\n", arm.tool[0], arm.tool[1], arm.tool[2]);
    fprintf(stderr, "k0 %.17g w0 %.17g singular_tol %.17g max_speed %.17g\n", prm.k0, prm.w0,
            prm.singular_tol, prm.max_speed);
    fprintf(stderr, "q:");
    for (i = 0; i < 6; i++) {
        fprintf(stderr, " %.17g", q[i]);
    }
    fprintf(stderr, "\nxdot:");
    for (i = 0; i < 6; i++) {
        fprintf(stderr, " %.17g", xd[i]);
    }
    fprintf(stderr, "\n");
}

static void fail(const char *what, int rc, const vf_rr_out *o)
{
    int i;
    fprintf(stderr, "velfence_rr contract violated: %s (rc %d)\n", what, rc);
    print_input();
    if (o != NULL) {
        fprintf(stderr, "q_dot:");
        for (i = 0; i < 6; i++) {
            fprintf(stderr, " %.17g", o->q_dot[i]);
        }
        fprintf(stderr, "\nw %.17g det %.17g k %.17g scale %.17g singular %d\n", o->w, o->det, o->k,
                o->scale, (int)o->singular);
    }
    abort();
}

static int finite_all(const double *x, int n)
{
    int i;
    for (i = 0; i < n; i++) {
        if (!isfinite(x[i])) {
            return 0;
        }
    }
    return 1;
}

static int same_out(const vf_rr_out *a, const vf_rr_out *b)
{
    int i;
    for (i = 0; i < 6; i++) {
        if (!fz_same_bits(a->q_dot[i], b->q_dot[i])) {
            return 0;
        }
    }
    return fz_same_bits(a->w, b->w) && fz_same_bits(a->det, b->det) && fz_same_bits(a->k, b->k)
           && fz_same_bits(a->scale, b->scale) && a->singular == b->singular;
}

static void decode(fz_reader *r, uint8_t flags)
{
    int i, j;
    if (flags & 1) {
        for (i = 0; i < 6; i++) {
            for (j = 0; j < 5; j++) {
                arm.dh[i][j] = fz_double(r);
            }
        }
        for (j = 0; j < 3; j++) {
            arm.tool[j] = fz_double(r);
        }
        prm.k0 = fz_double(r);
        prm.w0 = fz_double(r);
        prm.singular_tol = fz_double(r);
        prm.max_speed = fz_double(r);
        for (i = 0; i < 6; i++) {
            q[i] = fz_double(r);
        }
    } else {
        static const double ca[3] = {1.0, 6.123233995736766e-17, 6.123233995736766e-17};
        static const double sa[3] = {0.0, 1.0, -1.0};
        uint8_t b;
        for (i = 0; i < 6; i++) {
            int t;
            arm.dh[i][0] = fz_byte(r) / 256.0;
            t = fz_byte(r) % 3;
            arm.dh[i][1] = ca[t];
            arm.dh[i][2] = sa[t];
            arm.dh[i][3] = (fz_byte(r) - 128) / 256.0;
            arm.dh[i][4] = 6.283185307179586 * fz_byte(r) / 256.0;
        }
        for (j = 0; j < 3; j++) {
            arm.tool[j] = (fz_byte(r) - 128) / 512.0;
        }
        prm.k0 = (1 + fz_byte(r)) / 1024.0;
        prm.w0 = (1 + fz_byte(r)) / 4096.0;
        b = fz_byte(r) % 3;
        prm.singular_tol = b == 0 ? 0.0 : (b == 1 ? 1e-10 : prm.w0);
        b = fz_byte(r);
        prm.max_speed = b & 1 ? 0.0 : b / 16.0;
        for (i = 0; i < 6; i++) {
            q[i] = flags & 2 ? fz_double(r) : 6.283185307179586 * fz_i16(r) / 65536.0;
        }
    }
    for (i = 0; i < 6; i++) {
        xd[i] = fz_double(r);
    }
}

static int args_valid(void)
{
    return isfinite(prm.k0) && prm.k0 > 0.0 && isfinite(prm.w0) && prm.w0 > 0.0
           && !isnan(prm.singular_tol) && prm.singular_tol >= 0.0 && !isnan(prm.max_speed)
           && prm.max_speed >= 0.0 && finite_all(&arm.dh[0][0], 30) && finite_all(arm.tool, 3);
}

static void null_cases(uint8_t sel)
{
    vf_rr_out o;
    double *J = fz_alloc(36);
    int rc;
    switch (sel % 8) {
    case 0: rc = vf_rr_sr_step(NULL, &prm, q, xd, &o); break;
    case 1: rc = vf_rr_sr_step(&arm, NULL, q, xd, &o); break;
    case 2: rc = vf_rr_sr_step(&arm, &prm, NULL, xd, &o); break;
    case 3: rc = vf_rr_sr_step(&arm, &prm, q, NULL, &o); break;
    case 4: rc = vf_rr_sr_step(&arm, &prm, q, xd, NULL); break;
    case 5: rc = vf_rr_jacobian(NULL, q, J); break;
    case 6: rc = vf_rr_jacobian(&arm, NULL, J); break;
    default: rc = vf_rr_jacobian(&arm, q, NULL); break;
    }
    free(J);
    if (rc != VF_ERR_NULL) {
        fail("a NULL pointer without VF_ERR_NULL", rc, NULL);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_reader r = {data, size};
    uint8_t flags = fz_byte(&r);
    vf_rr_out o1, o2;
    double *J = fz_alloc(36), *qa = fz_alloc(6), *xa = fz_alloc(6);
    int rc, rc2, i;
    decode(&r, flags);
    memcpy(qa, q, sizeof q);
    memcpy(xa, xd, sizeof xd);
    /* the Jacobian */
    rc = vf_rr_jacobian(&arm, qa, J);
    if (finite_all(q, 6) ? rc != VF_OK : rc != VF_ERR_NONFINITE) {
        fail("vf_rr_jacobian's code", rc, NULL);
    }
    if (rc == VF_ERR_NONFINITE) {
        for (i = 0; i < 36; i++) {
            if (!fz_same_bits(J[i], 0.0)) {
                fail("VF_ERR_NONFINITE without a zero J", rc, NULL);
            }
        }
    }
    /* the step */
    rc = vf_rr_sr_step(&arm, &prm, qa, xa, &o1);
#ifdef VF_FUZZ_CONTROL_TAMPER
    if (rc == VF_OK) {
        o1.q_dot[0] = NAN;
    }
#endif
    if (!args_valid()) {
        if (rc != VF_ERR_ARGUMENT) {
            fail("invalid parameters or arm without VF_ERR_ARGUMENT", rc, &o1);
        }
    } else if (!(finite_all(q, 6) && finite_all(xd, 6))) {
        if (rc != VF_ERR_NONFINITE) {
            fail("non-finite q or xdot without VF_ERR_NONFINITE", rc, &o1);
        }
    } else if (!(rc == VF_OK || rc == VF_ERR_SINGULAR || rc == VF_ERR_OVERFLOW)) {
        fail("an undocumented code", rc, &o1);
    }
    if (rc == VF_ERR_SINGULAR && !(isfinite(o1.w) && o1.k >= 0.0 && o1.k <= prm.k0)) {
        fail("VF_ERR_SINGULAR before w and k were computed", rc, &o1);
    }
    if (rc == VF_OK && o1.k == 0.0 && o1.singular) {
        fail("VF_OK for an undamped step at w <= singular_tol (VF_ERR_SINGULAR)", rc, &o1);
    }
    if (rc != VF_OK) {
        for (i = 0; i < 6; i++) {
            if (!fz_same_bits(o1.q_dot[i], 0.0)) {
                fail("an error without q_dot = +0", rc, &o1);
            }
        }
        if (o1.scale != 1.0) {
            fail("an error without scale = 1", rc, &o1);
        }
    } else {
        if (!(finite_all(o1.q_dot, 6) && isfinite(o1.w) && isfinite(o1.det) && isfinite(o1.k)
              && isfinite(o1.scale))) {
            fail("VF_OK with a non-finite double", rc, &o1);
        }
        if (o1.w != fabs(o1.det) || !(o1.k >= 0.0 && o1.k <= prm.k0)
            || (o1.w >= prm.w0 && o1.k != 0.0)) {
            fail("w, det or k outside their definitions", rc, &o1);
        }
        if ((o1.singular != 0) != (o1.w <= prm.singular_tol)) {
            fail("the singular flag", rc, &o1);
        }
        if (!(o1.scale >= 0.0 && o1.scale <= 1.0) || (prm.max_speed == 0.0 && o1.scale != 1.0)) {
            fail("the cap's scale", rc, &o1);
        }
        if (prm.max_speed > 0.0) {
            for (i = 0; i < 6; i++) {
                if (fabs(o1.q_dot[i]) > prm.max_speed) {
                    fail("a joint rate above max_speed", rc, &o1);
                }
            }
        }
    }
    rc2 = vf_rr_sr_step(&arm, &prm, qa, xa, &o2);
#ifdef VF_FUZZ_CONTROL_TAMPER
    if (rc2 == VF_OK) {
        o2.q_dot[0] = NAN;
    }
#endif
    if (rc2 != rc || !same_out(&o1, &o2)) {
        fail("a second call differs", rc2, &o2);
    }
    if (flags & 0x80) {
        null_cases(fz_byte(&r));
    }
    free(J);
    free(qa);
    free(xa);
    return 0;
}
