/*
 * filter_cycle.c -- a 1 kHz safety-filter loop of a 7-joint arm in plain C (velfence_filter.h).
 *
 * A Franka-Emika-Panda-like arm (Franka's published modified DH (Craig) table, flange 0.107 m, a
 * 0.1 m tool), joint limits, speeds and accelerations from the datasheet, its tool point kept in a
 * box and its links' capsules away from 20 spheres. The loop integrates q += x dt (a simulated
 * robot) and commands a joint velocity toward random targets (a new one every 0.5 s); every cycle's output is checked
 * against every row (the claimed bounds and, for the joint, workspace and obstacle rows, at
 * least "no further out": min(b, 0)). Exit status 0 only when every output met every row.
 *
 *   filter_cycle [--cycles NJ] [--back-to-back] [--dense] [--budget SECONDS] [--iterations K]
 *
 * --cycles      number of cycles (default 2000);
 * --back-to-back no sleeping: cycles run one after another (default: clock_nanosleep to absolute
 *               1 ms deadlines, as a real-time thread does);
 * --dense       80 spheres 1-10 cm from the links, a 0.3 m obstacle buffer and a command that
 *               pushes into them: >= 400 rows, >= 60 of them violated by the command;
 * --saturating  targets beyond the joint limits and a 3/s gain: the command exceeds the joint
 *               speeds and runs into the limits most cycles (default: targets inside the limits,
 *               a 1/s gain: the rows bind now and then);
 * --budget      the cycle's time budget [s] (default none); --iterations the solve's cap.
 * Prints the cycle time's median, p99 and max [us] (vf_filter_cycle alone; wall clock, and the
 * thread's CPU time without preemption: cpu_*), the deadline
 * fallbacks, stops, the mean number of rows and of rows the command violates ("binding").
 *
 * Build: cc -std=c99 -O2 -Icore/include core/examples/filter_cycle.c core/src/velfence_filter.c
 *        core/src/velfence_nd.c -lm
 */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "velfence_filter.h"

#define NJ 7
#define MAXK 96
#define DT 0.001

static const double MDH[NJ][4] = {
    /* a_{i-1} [m], alpha_{i-1} [rad], d_i [m], theta offset */
    {0.0, 0.0, 0.333, 0.0},          {0.0, -1.5707963267948966, 0.0, 0.0},
    {0.0, 1.5707963267948966, 0.316, 0.0}, {0.0825, 1.5707963267948966, 0.0, 0.0},
    {-0.0825, -1.5707963267948966, 0.384, 0.0}, {0.0, 1.5707963267948966, 0.0, 0.0},
    {0.088, 1.5707963267948966, 0.0, 0.0},
};
static const double LOWER[NJ] = {-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973};
static const double UPPER[NJ] = {2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973};
static const double VMAX[NJ] = {2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61};
static const double AMAX[NJ] = {15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0};

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The thread's CPU time [s]: a cycle's own cost, without the time the scheduler took the CPU
 * away (wall-clock maxima on a shared VM are preemptions of 0.3-50 ms). */
static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static uint64_t rng_state = 0x9E3779B97F4A7C15ULL;
static double uniform(double lo, double hi)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return lo + (hi - lo) * (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Rx(alpha) Tx(a) Tz(d): a modified DH row's fixed transform. */
static void rxtxtz(double a, double alpha, double d, double *T)
{
    double c = cos(alpha), s = sin(alpha);
    double M[12] = {1.0, 0.0, 0.0, a, 0.0, c, -s, -s * d, 0.0, s, c, c * d};
    memcpy(T, M, sizeof M);
}

/* Every row met to the round-off of forming x from u (tolerance 1e-12 (|c| + |g|_1 (|x|_inf +
 * |u|_inf)), the spec's acceptance): its claimed bound, and min(b, 0) for the joint, workspace and obstacle rows
 * (the safety property: inside stays inside, outside goes no further out). */
static int verify(const vf_filter_info *info, const double *x, const double *u)
{
    int32_t r, j;
    double xn = 0.0, un = 0.0;
    for (j = 0; j < NJ; j++) {
        xn = fabs(x[j]) > xn ? fabs(x[j]) : xn;
        un = fabs(u[j]) > un ? fabs(u[j]) : un;
    }
    xn += un;
    for (r = 0; r < info->m; r++) {
        const double *g = info->G + (size_t)r * NJ;
        double gx = 0.0, g1 = 0.0, b = info->b[r], lim, c;
        for (j = 0; j < NJ; j++) {
            gx += g[j] * x[j];
            g1 += fabs(g[j]);
        }
        lim = info->bound[r];
        if (lim != -INFINITY && gx - lim < -1e-12 * (fabs(lim) + g1 * xn)) {
            fprintf(stderr, "row %d (level %d) misses its claimed bound by %g\n", (int)r,
                    (int)info->level[r], lim - gx);
            return 0;
        }
        c = b < 0.0 ? b : 0.0;
        if (info->level[r] != VF_FILTER_LEVEL_RATE && gx - c < -1e-12 * (fabs(c) + g1 * xn)) {
            fprintf(stderr, "row %d (level %d) goes further out by %g\n", (int)r,
                    (int)info->level[r], c - gx);
            return 0;
        }
    }
    return 1;
}

int main(int argc, char **argv)
{
    long cycles = 2000, c;
    int back = 0, dense = 0, saturate = 0, a, j, i, bad = 0;
    double budget = 0.0;
    int maxit = 0;
    vf_filter_joint joints[NJ];
    int32_t jkind[NJ];
    double jprm[NJ * VF_ND_PROFILE_PARAMS];
    double centres[3 * MAXK], radii[MAXK], lrad[NJ];
    vf_filter_point tcp = {NJ, {0.0, 0.0, 0.0}};
    static const double BOXN[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    static const double BOXO[6] = {-0.7, -0.7, -0.7, -0.7, 0.05, -1.2}; /* |x|,|y| <= 0.7 ... */
    vf_filter_polytope box;
    vf_filter f;
    vf_filter_opts opts;
    vf_filter_info info;
    double q[NJ], u[NJ], x[NJ], prev[NJ], target[NJ], *times, *cpu, *scratch;
    int32_t *iscratch, *warm;
    double P[3 * (NJ + 1)], axes[3 * NJ], frames[12 * (NJ + 2)];
    long fallbacks = 0, stops = 0;
    double rows_sum = 0.0, binding_sum = 0.0, violated_sum = 0.0;
    struct timespec next;
    for (a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "--cycles") && a + 1 < argc) {
            cycles = atol(argv[++a]);
        } else if (!strcmp(argv[a], "--back-to-back")) {
            back = 1;
        } else if (!strcmp(argv[a], "--dense")) {
            dense = 1;
        } else if (!strcmp(argv[a], "--saturating")) {
            saturate = 1;
        } else if (!strcmp(argv[a], "--budget") && a + 1 < argc) {
            budget = atof(argv[++a]);
        } else if (!strcmp(argv[a], "--iterations") && a + 1 < argc) {
            maxit = atoi(argv[++a]);
        } else {
            fprintf(stderr, "usage: %s [--cycles NJ] [--back-to-back] [--dense] [--budget S] "
                            "[--iterations K]\n", argv[0]);
            return 2;
        }
    }
    if (cycles < 1) {
        return 2;
    }
    /* the chain: modified DH rows as fixed transforms, motion Rz(q) */
    for (j = 0; j < NJ; j++) {
        double K = 2.0 * AMAX[j] / VMAX[j], d_int = (AMAX[j] / K) / K;
        rxtxtz(MDH[j][0], MDH[j][1], MDH[j][2], joints[j].T);
        joints[j].axis[0] = 0.0;
        joints[j].axis[1] = 0.0;
        joints[j].axis[2] = 1.0;
        joints[j].type = VF_FILTER_REVOLUTE;
        joints[j].offset = MDH[j][3];
        /* ThreeZoneBraking(gain = 2 a / v, max_speed = v, max_acceleration = a) */
        jkind[j] = VF_ND_PROFILE_THREE_ZONE;
        jprm[6 * j] = K;
        jprm[6 * j + 1] = VMAX[j];
        jprm[6 * j + 2] = AMAX[j];
        jprm[6 * j + 3] = d_int;
        jprm[6 * j + 4] = 0.5 * d_int;
        jprm[6 * j + 5] = 0.5 * d_int + (VMAX[j] / AMAX[j]) * (0.5 * VMAX[j]);
        lrad[j] = 0.06;
    }
    memset(&f, 0, sizeof f);
    {
        double tool[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.107 + 0.1};
        memcpy(f.tool, tool, sizeof tool);
    }
    box.point = 0;
    box.nf = 6;
    box.N = BOXN;
    box.off = BOXO;
    box.kind = VF_ND_PROFILE_LINEAR; /* LinearBuffer(buffer=0.05) */
    memset(box.prm, 0, sizeof box.prm);
    box.prm[0] = 0.05;
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
    f.centres = centres;
    f.radii = radii;
    f.link_radius = lrad;
    f.obstacle_buffer = dense ? 0.3 : 0.05;
    f.spring_gain = 1.0;
    f.dt = DT;
    /* the start pose and the obstacles */
    {
        static const double Q0[NJ] = {0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8};
        memcpy(q, Q0, sizeof q);
    }
    f.k = dense ? 80 : 20;
    vf_filter_kinematics(&f, q, P, axes, frames);
    for (i = 0; i < f.k; i++) {
        if (dense) {
            /* close to link i % 7 at the start pose: 1-10 cm from its capsule, clear of all */
            int l = i % NJ, tries;
            for (tries = 0; tries < 1000; tries++) {
                double t = uniform(0.0, 1.0), dir[3], nd, worst = INFINITY;
                int m;
                for (a = 0; a < 3; a++) {
                    dir[a] = uniform(-1.0, 1.0);
                }
                nd = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]) + 1e-9;
                radii[i] = 0.04;
                for (a = 0; a < 3; a++) {
                    double p = P[3 * l + a] + t * (P[3 * (l + 1) + a] - P[3 * l + a]);
                    centres[3 * i + a] = p + dir[a] / nd * (lrad[l] + radii[i] + uniform(0.01, 0.1));
                }
                for (m = 0; m < NJ; m++) { /* clearance to every link's capsule */
                    const double *pa = P + 3 * m, *pb = P + 3 * (m + 1);
                    double dd = 0.0, w = 0.0, s, e[3];
                    for (a = 0; a < 3; a++) {
                        dd += (pb[a] - pa[a]) * (pb[a] - pa[a]);
                        w += (centres[3 * i + a] - pa[a]) * (pb[a] - pa[a]);
                    }
                    s = dd > 0.0 ? w / dd : 0.0;
                    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
                    for (a = 0; a < 3; a++) {
                        e[a] = pa[a] + s * (pb[a] - pa[a]) - centres[3 * i + a];
                    }
                    s = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) - radii[i] - lrad[m];
                    worst = s < worst ? s : worst;
                }
                if (worst > 0.01) {
                    break;
                }
            }
        } else {
            /* around the workspace, away from the start pose's links */
            double r;
            do {
                double best = INFINITY;
                int l;
                centres[3 * i] = uniform(-0.7, 0.7);
                centres[3 * i + 1] = uniform(-0.7, 0.7);
                centres[3 * i + 2] = uniform(0.1, 1.1);
                radii[i] = uniform(0.03, 0.08);
                for (l = 0; l < NJ; l++) {
                    double d2 = 0.0;
                    for (a = 0; a < 3; a++) {
                        double dd = centres[3 * i + a] - 0.5 * (P[3 * l + a] + P[3 * (l + 1) + a]);
                        d2 += dd * dd;
                    }
                    best = d2 < best ? d2 : best;
                }
                r = sqrt(best);
            } while (r < 0.3);
        }
    }
    if (vf_filter_check(&f) != VF_OK) {
        fprintf(stderr, "invalid filter description: %d\n", vf_filter_check(&f));
        return 1;
    }
    scratch = malloc(vf_filter_doubles(&f) * sizeof(double));
    iscratch = malloc(vf_filter_ints(&f) * sizeof(int32_t));
    times = malloc((size_t)cycles * sizeof(double));
    cpu = malloc((size_t)cycles * sizeof(double));
    warm = malloc(3 * vf_filter_rows_max(&f) * sizeof(int32_t));
    if (scratch == NULL || iscratch == NULL || times == NULL || warm == NULL) {
        return 1;
    }
    memset(&opts, 0, sizeof opts);
    opts.max_iterations = maxit;
    opts.time_budget = budget;
    opts.warm = warm; /* the last cycle's active rows by key: the solve tries them first */
    opts.n_warm = 0;
    memset(prev, 0, sizeof prev);
    for (j = 0; j < NJ; j++) {
        target[j] = q[j];
    }
    clock_gettime(CLOCK_MONOTONIC, &next);
    for (c = 0; c < cycles; c++) {
        double t0, t1, c0;
        int rc;
        if (c % 500 == 0) {
            for (j = 0; j < NJ; j++) {
                target[j] = saturate || dense ? uniform(LOWER[j] - 0.2, UPPER[j] + 0.2)
                                              : uniform(LOWER[j] + 0.2, UPPER[j] - 0.2);
            }
        }
        for (j = 0; j < NJ; j++) {
            u[j] = saturate || dense ? 3.0 * (target[j] - q[j])
                                           + (dense ? uniform(-3.0, 3.0) : uniform(-0.2, 0.2))
                                     : 1.0 * (target[j] - q[j]);
        }
        if (!back) {
            next.tv_nsec += 1000000L;
            if (next.tv_nsec >= 1000000000L) {
                next.tv_nsec -= 1000000000L;
                next.tv_sec += 1;
            }
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL);
        }
        c0 = cpu_s();
        t0 = now_s();
        rc = vf_filter_cycle(&f, q, u, prev, &opts, x, &info, scratch, iscratch);
        t1 = now_s();
        times[c] = (t1 - t0) * 1e6;
        cpu[c] = (cpu_s() - c0) * 1e6;
        if (rc < 0) {
            fprintf(stderr, "cycle %ld: status %d\n", c, rc);
            return 1;
        }
        if (rc == VF_ITERATION_CAP || rc == VF_DEADLINE) {
            fallbacks += 1;
        }
        if (info.stages & VF_FILTER_STAGE_STOP) {
            stops += 1;
        }
        if (!verify(&info, x, u)) {
            fprintf(stderr, "cycle %ld: an output missed a row (stages %d)\n", c, info.stages);
            bad += 1;
        }
        rows_sum += info.m;
        for (i = 0; i < info.n_active; i++) {
            int32_t r = info.active[i];
            warm[3 * i] = info.level[r];
            warm[3 * i + 1] = info.key_a[r];
            warm[3 * i + 2] = info.key_b[r];
        }
        opts.n_warm = info.n_active;
        violated_sum += info.n_violated;
        for (i = 0; i < info.m; i++) {
            double gu = 0.0;
            for (j = 0; j < NJ; j++) {
                gu += info.G[(size_t)i * NJ + j] * u[j];
            }
            binding_sum += gu < info.b[i];
        }
        for (j = 0; j < NJ; j++) {
            q[j] += x[j] * DT;
            prev[j] = x[j];
        }
    }
    qsort(times, (size_t)cycles, sizeof(double), cmp);
    qsort(cpu, (size_t)cycles, sizeof(double), cmp);
    printf("mode %s%s cycles %ld median_us %.3f p99_us %.3f max_us %.3f fallbacks %ld stops %ld "
           "rows_mean %.1f binding_mean %.1f violated_mean %.1f violations %d "
           "cpu_median_us %.3f cpu_p99_us %.3f cpu_max_us %.3f\n",
           dense ? "dense-" : "", back ? "back-to-back" : "periodic-1kHz", cycles,
           times[cycles / 2], times[(size_t)((double)cycles * 0.99)], times[cycles - 1],
           fallbacks, stops, rows_sum / (double)cycles, binding_sum / (double)cycles,
           violated_sum / (double)cycles, bad, cpu[cycles / 2],
           cpu[(size_t)((double)cycles * 0.99)], cpu[cycles - 1]);
    free(scratch);
    free(iscratch);
    free(times);
    free(cpu);
    free(warm);
    return bad == 0 ? 0 : 1;
}
