/*
 * shape_example.c -- calling velfence's compiled 2-D laws from C, as a real-time loop would.
 *
 * Build (from core/):  gcc -std=c99 -O2 -ffp-contract=off -Iinclude examples/shape_example.c \
 *                          src/velfence_core.c -lm -o shape_example
 * Everything is set up before the loop; the per-cycle call allocates nothing.
 *
 * The polygon is the box [-1, 1] x [-0.5, 0.5] as velfence's ConvexPolygon.kernel_data gives it
 * (counter-clockwise corners from (-1, -0.5); inward normals, offsets with d = n.p - off; the
 * patent law's corner angles). Prints one line per state:
 *   law px py vx vy -> ox oy zone stages rc
 * with every double in %.17g (round-trips exactly), which tests/core compare with Python.
 */
#include <math.h>
#include <stdio.h>

#include "velfence_core.h"

#define N_EDGES 4

int main(void)
{
    static const double nx[N_EDGES] = {-0.0, -1.0, -0.0, 1.0};
    static const double ny[N_EDGES] = {1.0, 0.0, -1.0, 0.0};
    static const double off[N_EDGES] = {-0.5, -1.0, -0.5, -1.0};
    static const double beta[N_EDGES + 1] = {0.0, 2.214297435588181, 3.141592653589793,
                                             5.355890089177974, 6.283185307179586};
    static const double states[][4] = {
        {0.0, 0.0, 1.0, 0.5},     /* free */
        {0.9, 0.0, 2.0, 0.3},     /* buffer of the right edge, approaching */
        {0.95, 0.45, 1.0, 1.0},   /* corner */
        {1.1, 0.0, 0.5, -0.2},    /* outside: recovery */
        {1.05, 0.6, 0.0, 0.0},    /* outside a corner, zero command */
        {0.2, -0.45, -0.3, -2.0}, /* buffer of the bottom edge */
        {1e300, 0.0, 1e300, 0.0},      /* huge but answered */
        {-1.7e308, 0.0, 1.7e308, 0.0}, /* patent: the output overflows (rc VF_ERR_OVERFLOW) */
        {INFINITY, 0.0, 1.0, 0.0},     /* non-finite (rc VF_ERR_NONFINITE, stop result) */
    };
    const int n_states = (int)(sizeof states / sizeof states[0]);
    vf_polygon poly = {nx, ny, off, beta, 0.0, 0.0, -2.677945044588987, N_EDGES};
    /* PolygonShaper(buffer=0.2, spring_gain=1.0): LinearBuffer(0.2, 1.0, r_max = 0.2). */
    vf_exact_law exact = {VF_PROFILE_LINEAR, {0.2, 1.0, 0.2, 0.0, 0.0, 0.0}, 1, 0.0};
    /* PolygonShaper(buffer=0.2, spring_gain=1.0, method="edge-scaling"), blend angle 0.3 rad. */
    vf_patent_law patent = {0.2, 1.0, 0.3, 0.0};
    double dist[N_EDGES], bnd[N_EDGES];
    int32_t work[N_EDGES];
    vf_scratch scratch = {dist, bnd, work};
    vf_result r;
    int i, rc;

    if (vf_exact_check(&poly, &exact) != VF_OK || vf_patent_check(&poly, &patent) != VF_OK) {
        fprintf(stderr, "invalid polygon or law\n");
        return 1;
    }
    for (i = 0; i < n_states; i++) {
        const double *s = states[i];
        rc = vf_exact_shape(&poly, &exact, s[0], s[1], s[2], s[3], &scratch, &r);
        printf("exact %.17g %.17g %.17g %.17g -> %.17g %.17g %d %d %d\n", s[0], s[1], s[2], s[3],
               r.ox, r.oy, (int)r.zone, (int)r.stages, rc);
        rc = vf_patent_shape(&poly, &patent, s[0], s[1], s[2], s[3], &r);
        printf("patent %.17g %.17g %.17g %.17g -> %.17g %.17g %d %d %d\n", s[0], s[1], s[2], s[3],
               r.ox, r.oy, (int)r.zone, (int)r.stages, rc);
    }
    return 0;
}
