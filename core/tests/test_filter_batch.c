/*
 * test_filter_batch.c -- vf_filter_cycle_batch (velfence_filter.h): a Panda-like arm (Franka's
 * modified DH table), a TCP box and 5 spheres, 203 states of every kind (free, near and beyond
 * the joint limits, saturating commands, a NaN row, previous outputs for acceleration rows):
 * every row's output, status, stages and active count equal vf_filter_cycle of that state bit
 * for bit, with 1, 2, 3 and the default number of workers (threads <= 0) and more workers than
 * rows; a NaN row gives VF_ERR_NONFINITE and zero without touching its neighbours; the call's
 * own errors (NULL pointers, count < 0, an invalid description) zero every row and report the
 * code per row; count 0 writes nothing. Exactly-sized heap buffers, so AddressSanitizer sees
 * any overrun of a worker's chunk or scratch. Prints "ok <count>".
 */
#include "velfence_filter.h"
#include "vf_test.h"

#include <string.h>

#define NJ 7
#define ROWS 203
#define K 5

static const double MDH[NJ][4] = {
    {0.0, 0.0, 0.333, 0.0},          {0.0, -1.5707963267948966, 0.0, 0.0},
    {0.0, 1.5707963267948966, 0.316, 0.0}, {0.0825, 1.5707963267948966, 0.0, 0.0},
    {-0.0825, -1.5707963267948966, 0.384, 0.0}, {0.0, 1.5707963267948966, 0.0, 0.0},
    {0.088, 1.5707963267948966, 0.0, 0.0},
};
static const double LOWER[NJ] = {-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973};
static const double UPPER[NJ] = {2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973};
static const double VMAX[NJ] = {2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
static const double AMAX[NJ] = {15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0};

static void rxtxtz(double a, double alpha, double d, double *T)
{
    double c = cos(alpha), s = sin(alpha);
    double M[12] = {1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d};
    memcpy(T, M, sizeof M);
}

/* Bitwise equality of two double arrays (NaN-safe, -0 != +0). */
static int same(const double *a, const double *b, size_t n)
{
    return memcmp(a, b, n * sizeof(double)) == 0;
}

int main(void)
{
    vf_filter_joint joints[NJ];
    int32_t jkind[NJ];
    double jprm[NJ * VF_ND_PROFILE_PARAMS], centres[3 * K], radii[K], lrad[NJ];
    vf_filter_point tcp = {NJ, {0.0, 0.0, 0.0}};
    static const double BOXN[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const double BOXO[6] = {-0.5, -0.5, -0.5, -0.5, 0.1, -1.0};
    vf_filter_polytope box;
    vf_filter f, bad;
    vf_filter_opts opts;
    vf_filter_info info;
    double *q = dalloc(ROWS * NJ), *u = dalloc(ROWS * NJ), *prev = dalloc(ROWS * NJ);
    double *ref = dalloc(ROWS * NJ), *out = dalloc(ROWS * NJ), *one = dalloc(NJ);
    int32_t *rst = ialloc(ROWS), *rsg = ialloc(ROWS), *rna = ialloc(ROWS);
    int32_t *st = ialloc(ROWS), *sg = ialloc(ROWS), *na = ialloc(ROWS);
    double *scratch1 = dalloc(1), *sc;
    int32_t *isc;
    int32_t r, j, t, w, with_prev;
    static const int32_t THREADS[5] = {1, 2, 3, 0, 64};
    for (j = 0; j < NJ; j++) {
        double Kg = 2.0 * AMAX[j] / VMAX[j], d_int = (AMAX[j] / Kg) / Kg;
        rxtxtz(MDH[j][0], MDH[j][1], MDH[j][2], joints[j].T);
        joints[j].axis[0] = 0.0;
        joints[j].axis[1] = 0.0;
        joints[j].axis[2] = 1.0;
        joints[j].type = VF_FILTER_REVOLUTE;
        joints[j].offset = MDH[j][3];
        jkind[j] = VF_ND_PROFILE_THREE_ZONE;
        jprm[6 * j] = Kg;
        jprm[6 * j + 1] = VMAX[j];
        jprm[6 * j + 2] = AMAX[j];
        jprm[6 * j + 3] = d_int;
        jprm[6 * j + 4] = 0.5 * d_int;
        jprm[6 * j + 5] = 0.5 * d_int + (VMAX[j] / AMAX[j]) * (0.5 * VMAX[j]);
        lrad[j] = 0.06;
    }
    memset(&f, 0, sizeof f);
    {
        double tool[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.207};
        memcpy(f.tool, tool, sizeof tool);
    }
    box.point = 0;
    box.nf = 6;
    box.N = BOXN;
    box.off = BOXO;
    box.kind = VF_ND_PROFILE_LINEAR;
    memset(box.prm, 0, sizeof box.prm);
    box.prm[0] = 0.05;
    for (r = 0; r < K; r++) {
        centres[3 * r] = uniform(-0.5, 0.5);
        centres[3 * r + 1] = uniform(-0.5, 0.5);
        centres[3 * r + 2] = uniform(0.2, 0.9);
        radii[r] = uniform(0.02, 0.08);
    }
    f.n = NJ;
    f.joints = joints;
    f.lower = LOWER;
    f.upper = UPPER;
    f.vmax = VMAX;
    f.amax = AMAX;
    f.jkind = jkind;
    f.jprm = jprm;
    f.npoints = 1;
    f.points = &tcp;
    f.nw = 1;
    f.ws = &box;
    f.k = K;
    f.centres = centres;
    f.radii = radii;
    f.link_radius = lrad;
    f.obstacle_buffer = 0.05;
    f.spring_gain = 1.0;
    f.dt = 0.002;
    CHECK(vf_filter_check(&f) == VF_OK, "the description");
    /* states: inside the limits, at them, beyond them; commands calm to 30x the speed limits */
    for (r = 0; r < ROWS; r++) {
        double scale = r % 4 == 0 ? 30.0 : r % 4 == 1 ? 3.0 : 0.5;
        for (j = 0; j < NJ; j++) {
            double span = UPPER[j] - LOWER[j];
            q[r * NJ + j] = r % 5 == 0 ? (r % 2 ? UPPER[j] : LOWER[j]) + uniform(-0.02, 0.02)
                                       : uniform(LOWER[j] - 0.05 * span, UPPER[j] + 0.05 * span);
            u[r * NJ + j] = scale * VMAX[j] * uniform(-1.0, 1.0);
            prev[r * NJ + j] = VMAX[j] * uniform(-1.0, 1.0);
        }
    }
    q[17 * NJ + 3] = NAN; /* one bad state */
    memset(&opts, 0, sizeof opts);
    for (with_prev = 0; with_prev < 2; with_prev++) {
        const double *p = with_prev ? prev : NULL;
        sc = dalloc(vf_filter_doubles(&f));
        isc = ialloc(vf_filter_ints(&f));
        for (r = 0; r < ROWS; r++) {
            rst[r] = vf_filter_cycle(&f, q + r * NJ, u + r * NJ, p ? p + r * NJ : NULL, &opts,
                                     ref + r * NJ, &info, sc, isc);
            rsg[r] = info.stages;
            rna[r] = rst[r] < 0 ? 0 : info.n_active;
        }
        free(sc);
        free(isc);
        CHECK(rst[17] == VF_ERR_NONFINITE, "the NaN row: %d", (int)rst[17]);
        for (t = 0; t < 5; t++) {
            w = vf_filter_batch_workers(THREADS[t], ROWS);
            CHECK(w >= 1 && w <= VF_FILTER_BATCH_MAX_THREADS && w <= ROWS, "workers %d", (int)w);
            CHECK(THREADS[t] <= 0 || w == THREADS[t], "workers asked %d got %d", (int)THREADS[t],
                  (int)w);
            sc = dalloc(vf_filter_batch_doubles(&f, THREADS[t]));
            isc = ialloc(vf_filter_batch_ints(&f, THREADS[t]));
            memset(out, 0xff, ROWS * NJ * sizeof(double));
            CHECK(vf_filter_cycle_batch(&f, ROWS, q, u, p, &opts, out, st, sg, na, THREADS[t],
                                        sc, isc) == VF_OK,
                  "batch threads %d", (int)THREADS[t]);
            CHECK(same(out, ref, ROWS * NJ), "outputs equal per-row calls (threads %d, prev %d)",
                  (int)THREADS[t], (int)with_prev);
            for (r = 0; r < ROWS; r++) {
                CHECK(st[r] == rst[r] && sg[r] == rsg[r] && na[r] == rna[r],
                      "row %d: status %d/%d stages %d/%d active %d/%d", (int)r, (int)st[r],
                      (int)rst[r], (int)sg[r], (int)rsg[r], (int)na[r], (int)rna[r]);
            }
            for (j = 0; j < NJ; j++) {
                CHECK(out[17 * NJ + j] == 0.0, "the NaN row's output is zero");
            }
            /* a batch of fewer rows than workers, optional outputs NULL */
            CHECK(vf_filter_cycle_batch(&f, 2, q, u, p, &opts, out, st, NULL, NULL, THREADS[t],
                                        sc, isc) == VF_OK,
                  "two rows");
            CHECK(same(out, ref, 2 * NJ) && st[0] == rst[0] && st[1] == rst[1], "two rows equal");
            free(sc);
            free(isc);
        }
    }
    /* the call's own errors */
    sc = dalloc(vf_filter_batch_doubles(&f, 2));
    isc = ialloc(vf_filter_batch_ints(&f, 2));
    CHECK(vf_filter_cycle_batch(NULL, ROWS, q, u, NULL, NULL, out, st, sg, na, 2, sc, isc)
              == VF_ERR_NULL && st[0] == VF_ERR_NULL && st[ROWS - 1] == VF_ERR_NULL,
          "NULL description");
    CHECK(vf_filter_cycle_batch(&f, ROWS, NULL, u, NULL, NULL, out, st, sg, na, 2, sc, isc)
              == VF_ERR_NULL,
          "NULL q");
    for (r = 0, j = 1; r < ROWS * NJ; r++) {
        j &= out[r] == 0.0;
    }
    CHECK(j && sg[5] == VF_FILTER_STAGE_STOP && na[5] == 0, "the error zeroes every row");
    CHECK(vf_filter_cycle_batch(&f, ROWS, q, u, NULL, NULL, out, NULL, sg, na, 2, sc, isc)
              == VF_ERR_NULL,
          "NULL status");
    CHECK(vf_filter_cycle_batch(&f, -1, q, u, NULL, NULL, out, st, sg, na, 2, sc, isc)
              == VF_ERR_ARGUMENT,
          "count < 0");
    bad = f;
    bad.vmax = NULL;
    out[0] = 7.0;
    CHECK(vf_filter_cycle_batch(&bad, 1, q, u, NULL, NULL, out, st, sg, na, 2, sc, isc) < 0
              && out[0] == 0.0 && st[0] < 0,
          "an invalid description");
    out[0] = 7.0;
    CHECK(vf_filter_cycle_batch(&f, 0, NULL, NULL, NULL, NULL, out, st, sg, na, 2, sc, isc)
              == VF_OK && out[0] == 7.0,
          "count 0 writes nothing");
    CHECK(vf_filter_batch_workers(5, 0) == 0 && vf_filter_batch_workers(1000, 3) == 3
              && vf_filter_batch_workers(1000, 1000) == VF_FILTER_BATCH_MAX_THREADS,
          "worker counts");
    (void)one;
    free(sc);
    free(isc);
    free(q);
    free(u);
    free(prev);
    free(ref);
    free(out);
    free(one);
    free(rst);
    free(rsg);
    free(rna);
    free(st);
    free(sg);
    free(na);
    free(scratch1);
    return finish();
}
