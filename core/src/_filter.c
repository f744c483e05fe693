/*
 * velfence_core._filter -- CPython binding of the safety filter's whole cycle (velfence_filter.h).
 *
 *   FilterCycle(joints, tool, lower, upper, vmax, amax, jkind, jprm, points, ws, centres, radii,
 *               link_radius, obstacle_buffer, spring_gain, dt, weights, jmax=None, self_pairs=None,
 *               attachments=None)
 *       joints: float64 (n * 17,): per joint T (12, [R | p] row-major), axis (3), type, offset;
 *       tool (12,); lower, upper, vmax (n,); amax (n,) or None; jkind: n ints; jprm (n * 6,);
 *       points (npoints * 4,): link, offset x, y, z; ws: list of (point, N (nf * 3,), off (nf,),
 *       kind, prm (6,)); centres (k * 3,), radii (k,); link_radius (n,) or None; weights (n,) or
 *       None; jmax (n,) or None (the jerk limits); self_pairs: 2 * npairs ints (link i, link j
 *       of each self-collision pair, i < j) or None. Everything is copied and checked once
 *       (vf_filter_check): ValueError when invalid.
 *     cycle(q, u, previous=None, out=None, previous2=None, factor=None) -> out: one cycle on
 *       float64 arrays (n,) (out: a caller array (n,) written in place, else a new one;
 *       previous2: the output before previous, for the jerk rows; factor: a C-contiguous float64
 *       (n, n) lower-triangular L of a full metric H = L L^T, the twist mode's:
 *       vf_filter_cycle_metric). ValueError on a negative status (the output is then zero); the
 *       info of the cycle stays readable (info(), rows(), active()).
 *     cycle_batch(q, u, previous=None, out=None, threads=0) -> (out, status, stages, n_active):
 *       vf_filter_cycle_batch on float64 C-contiguous arrays (count, n) (previous too, or None);
 *       out a caller array (count, n) or None; status, stages, n_active new int32 arrays
 *       (count,). Each row equals cycle() of that row bit for bit; a row C refuses has status < 0
 *       and output zero (no exception). threads <= 0: the online cores. The GIL is released.
 *       The options of set_options apply (no warm start across rows or calls).
 *     set_options(max_iterations=0, time_budget=0.0, warm=False): per-solve iteration cap (<= 0:
 *       default), time budget [s] per cycle (0: none), warm start from the last active set.
 *     info() -> dict (status, stages, rung, deadline, relaxed, dropped, fraction, m, n_active,
 *       n_violated, n_relaxed, iterations, solves); rows() -> (G, b, level, key_a, key_b, dist,
 *       slack, bound) of the last cycle (copies); active() / relaxed() -> the last active / relaxed
 *       rows' keys, lists of (level, a, b).
 *     deadline_misses: the number of cycles that used the deadline fallback; stages: the last
 *       cycle's VF_FILTER_STAGE_* bits (info()["stages"] without the dict).
 *     set_attachments(flat): replace the attached shapes (8 floats each: link, a (3), b (3),
 *       radius; the constructor's attachments= too) and resize the scratch (not per cycle).
 *   cycle_many(cycles, q, u, previous=None, previous2=None, out=None) -> (out, status, stages):
 *     row r is cycles[r].cycle(q[r], u[r], previous[r], None, previous2[r]) (one FilterCycle per
 *     row, each with its own description; the state cycle() updates is updated) on float64
 *     C-contiguous (count, n) arrays; a row C refuses has status < 0 and output zero (no
 *     exception); status and stages new int32 arrays (count,). The GIL is released.
 *   segment_pairs(a0, a1, b0, b1) -> (s, t, dist, nrm): vf_segment_pair on float64 (N, 3) arrays
 *     (the closest points of N segment pairs; tests and benchmarks).
 *   STAGE_* / LEVEL_* / DEADLINE_* constants as in the header.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <string.h>

#include "velfence_filter.h"

typedef struct {
    PyObject_HEAD
    vf_filter f;
    vf_filter_joint *joints;
    vf_filter_point *points;
    vf_filter_polytope *ws;
    double *mem;      /* every owned double: limits, profiles, polytopes, obstacles, scratch */
    int32_t *imem;    /* jkind, then the scratch ints, then the warm keys */
    int32_t *pairs;   /* self-collision pairs, 2 x npairs */
    vf_filter_attachment *attach; /* the attached shapes (set_attachments) */
    double *scratch;
    int32_t *iscratch;
    int32_t *warm;    /* 3 x rows_max */
    int32_t n_warm;
    int use_warm;
    vf_filter_opts opts;
    vf_filter_info info;
    int have_info;
    long long misses;
    double *bscratch; /* the batch's scratch: one cycle scratch per worker */
    int32_t *biscratch;
    int32_t bslots;   /* workers the batch scratch holds */
} FilterCycle;

static int read_into(PyObject *obj, const char *name, double *dst, Py_ssize_t count)
{
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(obj, NPY_DOUBLE, 0, 0,
                                                         NPY_ARRAY_CARRAY_RO);
    if (a == NULL) {
        return -1;
    }
    if (PyArray_SIZE(a) != count) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd floats, got %zd", name, count,
                     (Py_ssize_t)PyArray_SIZE(a));
        Py_DECREF(a);
        return -1;
    }
    if (count > 0) {
        memcpy(dst, PyArray_DATA(a), (size_t)count * sizeof(double));
    }
    Py_DECREF(a);
    return 0;
}

static Py_ssize_t size_of(PyObject *obj, const char *name)
{
    Py_ssize_t s;
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(obj, NPY_DOUBLE, 0, 0,
                                                         NPY_ARRAY_CARRAY_RO);
    if (a == NULL) {
        return -1;
    }
    s = (Py_ssize_t)PyArray_SIZE(a);
    Py_DECREF(a);
    (void)name;
    return s;
}

static void FilterCycle_dealloc(FilterCycle *self)
{
    PyMem_Free(self->joints);
    PyMem_Free(self->points);
    PyMem_Free(self->ws);
    PyMem_Free(self->mem);
    PyMem_Free(self->imem);
    PyMem_Free(self->pairs);
    PyMem_Free(self->attach);
    PyMem_Free(self->scratch);
    PyMem_Free(self->bscratch);
    PyMem_Free(self->biscratch);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* The attachments from a flat float sequence (8 per shape: link, a (3), b (3), radius) into
 * self->attach / self->f (not checked here: vf_filter_check does). */
static int read_attachments(FilterCycle *self, PyObject *obj)
{
    PyArrayObject *a = (PyArrayObject *)PyArray_FROMANY(obj, NPY_DOUBLE, 0, 0,
                                                         NPY_ARRAY_CARRAY_RO);
    vf_filter_attachment *at;
    Py_ssize_t m, i;
    const double *d;
    if (a == NULL) {
        return -1;
    }
    m = PyArray_SIZE(a);
    if (m % 8 != 0 || m / 8 > 1024) {
        Py_DECREF(a);
        PyErr_SetString(PyExc_ValueError, "attachments: expected 8 floats per shape, <= 1024");
        return -1;
    }
    m /= 8;
    at = PyMem_Calloc((size_t)(m > 0 ? m : 1), sizeof(vf_filter_attachment));
    if (at == NULL) {
        Py_DECREF(a);
        PyErr_NoMemory();
        return -1;
    }
    d = PyArray_DATA(a);
    for (i = 0; i < m; i++) {
        const double l = d[8 * i];
        at[i].link = (l >= -1.0 && l <= 65.0 && l == (double)(int32_t)l) ? (int32_t)l : -2;
        memcpy(at[i].a, d + 8 * i + 1, 3 * sizeof(double));
        memcpy(at[i].b, d + 8 * i + 4, 3 * sizeof(double));
        at[i].radius = d[8 * i + 7];
    }
    Py_DECREF(a);
    PyMem_Free(self->attach);
    self->attach = at;
    self->f.attach = at;
    self->f.nattach = (int32_t)m;
    return 0;
}

static int FilterCycle_init(FilterCycle *self, PyObject *args, PyObject *kwds)
{
    PyObject *joints, *tool, *lower, *upper, *vmax, *amax, *jkind, *jprm, *points, *ws, *centres,
        *radii, *lrad, *weights, *jmax = Py_None, *fast = NULL, *spairs = Py_None,
        *atts = Py_None;
    double buf, gain, dt;
    Py_ssize_t nj17, n, npt, nw, k, w, total = 0, o = 0, sumnf = 0, i;
    size_t nd, ni;
    int rc;
    static char *kwlist[] = {"joints", "tool", "lower", "upper", "vmax", "amax", "jkind", "jprm",
                             "points", "ws", "centres", "radii", "link_radius",
                             "obstacle_buffer", "spring_gain", "dt", "weights", "jmax",
                             "self_pairs", "attachments", NULL};
    if (self->mem != NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterCycle is already initialised");
        return -1;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOOOOOOOOOOdddO|OOO", kwlist, &joints,
                                     &tool, &lower, &upper, &vmax, &amax, &jkind, &jprm, &points,
                                     &ws, &centres, &radii, &lrad, &buf, &gain, &dt, &weights,
                                     &jmax, &spairs, &atts)) {
        return -1;
    }
    if (atts != Py_None && read_attachments(self, atts) < 0) {
        return -1;
    }
    if (spairs != Py_None) {
        PyObject *sp = PySequence_Fast(spairs, "self_pairs: expected 2 * npairs ints");
        Py_ssize_t np2, q;
        if (sp == NULL) {
            return -1;
        }
        np2 = PySequence_Fast_GET_SIZE(sp);
        if (np2 % 2 != 0 || np2 > 2 * 64 * 64) {
            Py_DECREF(sp);
            PyErr_SetString(PyExc_ValueError, "self_pairs: expected 2 * npairs ints");
            return -1;
        }
        self->pairs = PyMem_Calloc((size_t)(np2 > 0 ? np2 : 1), sizeof(int32_t));
        if (self->pairs == NULL) {
            Py_DECREF(sp);
            PyErr_NoMemory();
            return -1;
        }
        for (q = 0; q < np2; q++) {
            long v = PyLong_AsLong(PySequence_Fast_GET_ITEM(sp, q));
            if (v == -1 && PyErr_Occurred()) {
                Py_DECREF(sp);
                return -1;
            }
            self->pairs[q] = (v >= -1 && v <= 64) ? (int32_t)v : -1;
        }
        Py_DECREF(sp);
        self->f.npairs = (int32_t)(np2 / 2);
        self->f.pairs = self->pairs;
    }
    nj17 = size_of(joints, "joints");
    if (nj17 < 0) {
        return -1;
    }
    if (nj17 % 17 != 0 || nj17 == 0 || nj17 / 17 > 64) {
        PyErr_SetString(PyExc_ValueError, "joints: expected n * 17 floats, 1 <= n <= 64");
        return -1;
    }
    n = nj17 / 17;
    npt = size_of(points, "points");
    k = size_of(radii, "radii");
    if (npt < 0 || k < 0) {
        return -1;
    }
    if (npt % 4 != 0) {
        PyErr_SetString(PyExc_ValueError, "points: expected npoints * 4 floats");
        return -1;
    }
    npt /= 4;
    fast = PySequence_Fast(ws, "ws: expected a sequence of (point, N, off, kind, prm)");
    if (fast == NULL) {
        return -1;
    }
    nw = PySequence_Fast_GET_SIZE(fast);
    for (w = 0; w < nw; w++) {
        PyObject *t = PySequence_Fast_GET_ITEM(fast, w);
        Py_ssize_t s;
        if (!PyTuple_Check(t) || PyTuple_GET_SIZE(t) != 5) {
            PyErr_SetString(PyExc_ValueError, "ws: expected tuples (point, N, off, kind, prm)");
            goto fail;
        }
        s = size_of(PyTuple_GET_ITEM(t, 2), "ws off");
        if (s < 1) {
            if (s == 0) {
                PyErr_SetString(PyExc_ValueError, "ws: a polytope needs >= 1 facet");
            }
            goto fail;
        }
        sumnf += s;
    }
    self->joints = PyMem_Calloc((size_t)n, sizeof(vf_filter_joint));
    self->points = PyMem_Calloc((size_t)(npt > 0 ? npt : 1), sizeof(vf_filter_point));
    self->ws = PyMem_Calloc((size_t)(nw > 0 ? nw : 1), sizeof(vf_filter_polytope));
    total = 30 * n + 4 * npt + 4 * sumnf + 4 * k;
    self->mem = PyMem_Calloc((size_t)total + 1, sizeof(double));
    self->imem = PyMem_Calloc((size_t)n, sizeof(int32_t));
    if (self->joints == NULL || self->points == NULL || self->ws == NULL || self->mem == NULL
        || self->imem == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    {
        double *jd = self->mem + o;
        o += 17 * n;
        if (read_into(joints, "joints", jd, 17 * n) < 0) {
            goto fail;
        }
        for (i = 0; i < n; i++) {
            const double *s = jd + 17 * i;
            memcpy(self->joints[i].T, s, 12 * sizeof(double));
            memcpy(self->joints[i].axis, s + 12, 3 * sizeof(double));
            self->joints[i].type = s[15] == 1.0 ? VF_FILTER_PRISMATIC
                                   : s[15] == 0.0 ? VF_FILTER_REVOLUTE
                                                  : -1;
            self->joints[i].offset = s[16];
        }
    }
    if (read_into(tool, "tool", self->f.tool, 12) < 0) {
        goto fail;
    }
#define ARR(obj, name, count, field)                                                           \
    do {                                                                                       \
        self->f.field = self->mem + o;                                                         \
        if (read_into(obj, name, self->mem + o, count) < 0) {                                  \
            goto fail;                                                                         \
        }                                                                                      \
        o += count;                                                                            \
    } while (0)
    ARR(lower, "lower", n, lower);
    ARR(upper, "upper", n, upper);
    ARR(vmax, "vmax", n, vmax);
    if (amax != Py_None) {
        ARR(amax, "amax", n, amax);
    }
    if (jmax != Py_None) {
        ARR(jmax, "jmax", n, jmax);
    }
    ARR(jprm, "jprm", 6 * n, jprm);
    if (lrad != Py_None) {
        ARR(lrad, "link_radius", n, link_radius);
    }
    if (weights != Py_None) {
        ARR(weights, "weights", n, weights);
    }
    if (k > 0) {
        ARR(centres, "centres", 3 * k, centres);
        ARR(radii, "radii", k, radii);
    }
#undef ARR
    {
        double *pd = self->mem + o;
        o += 4 * npt;
        if (read_into(points, "points", pd, 4 * npt) < 0) {
            goto fail;
        }
        for (i = 0; i < npt; i++) {
            double l = pd[4 * i];
            self->points[i].link = (l >= -1.0 && l <= 65.0 && l == (double)(int32_t)l)
                                       ? (int32_t)l
                                       : -2;
            memcpy(self->points[i].offset, pd + 4 * i + 1, 3 * sizeof(double));
        }
    }
    {
        PyObject *jf = PySequence_Fast(jkind, "jkind: expected n ints");
        if (jf == NULL) {
            goto fail;
        }
        if (PySequence_Fast_GET_SIZE(jf) != n) {
            Py_DECREF(jf);
            PyErr_SetString(PyExc_ValueError, "jkind: expected n ints");
            goto fail;
        }
        for (i = 0; i < n; i++) {
            long v = PyLong_AsLong(PySequence_Fast_GET_ITEM(jf, i));
            if (v == -1 && PyErr_Occurred()) {
                Py_DECREF(jf);
                goto fail;
            }
            self->imem[i] = (int32_t)v;
        }
        Py_DECREF(jf);
        self->f.jkind = self->imem;
    }
    for (w = 0; w < nw; w++) {
        PyObject *t = PySequence_Fast_GET_ITEM(fast, w);
        vf_filter_polytope *p = self->ws + w;
        Py_ssize_t nf = size_of(PyTuple_GET_ITEM(t, 2), "ws off");
        long pt = PyLong_AsLong(PyTuple_GET_ITEM(t, 0));
        long kind = PyLong_AsLong(PyTuple_GET_ITEM(t, 3));
        if ((pt == -1 || kind == -1) && PyErr_Occurred()) {
            goto fail;
        }
        p->point = (int32_t)pt;
        p->kind = (int32_t)kind;
        p->nf = (int32_t)nf;
        if (read_into(PyTuple_GET_ITEM(t, 1), "ws N", self->mem + o, 3 * nf) < 0) {
            goto fail;
        }
        p->N = self->mem + o;
        o += 3 * nf;
        if (read_into(PyTuple_GET_ITEM(t, 2), "ws off", self->mem + o, nf) < 0) {
            goto fail;
        }
        p->off = self->mem + o;
        o += nf;
        if (read_into(PyTuple_GET_ITEM(t, 4), "ws prm", p->prm, 6) < 0) {
            goto fail;
        }
    }
    Py_CLEAR(fast);
    self->f.n = (int32_t)n;
    self->f.joints = self->joints;
    self->f.npoints = (int32_t)npt;
    self->f.points = self->points;
    self->f.nw = (int32_t)nw;
    self->f.ws = self->ws;
    self->f.k = (int32_t)k;
    self->f.obstacle_buffer = buf;
    self->f.spring_gain = gain;
    self->f.dt = dt;
    rc = vf_filter_check(&self->f);
    if (rc != VF_OK) {
        PyErr_Format(PyExc_ValueError, "the filter description is invalid (vf_filter_check: %d)",
                     rc);
        goto fail;
    }
    nd = vf_filter_doubles(&self->f);
    ni = vf_filter_ints(&self->f);
    self->scratch = PyMem_Calloc(nd, sizeof(double));
    {
        int32_t *im = PyMem_Realloc(self->imem,
                                    (n + ni + 3 * vf_filter_rows_max(&self->f) + 3) * sizeof(int32_t));
        if (im == NULL || self->scratch == NULL) {
            if (im != NULL) {
                self->imem = im;
            }
            PyErr_NoMemory();
            goto fail;
        }
        self->imem = im;
        self->f.jkind = im;
        self->iscratch = im + n;
        self->warm = im + n + ni;
    }
    return 0;
fail:
    Py_XDECREF(fast);
    PyMem_Free(self->joints);
    PyMem_Free(self->points);
    PyMem_Free(self->ws);
    PyMem_Free(self->mem);
    PyMem_Free(self->imem);
    PyMem_Free(self->scratch);
    self->joints = NULL;
    self->points = NULL;
    self->ws = NULL;
    self->mem = NULL;
    self->imem = NULL;
    self->scratch = NULL;
    return -1;
}

static const double *vec_arg(PyObject *o, int32_t n, const char *name)
{
    PyArrayObject *a = (PyArrayObject *)o;
    if (!PyArray_Check(o) || PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1
        || PyArray_DIM(a, 0) != n || !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a)) {
        PyErr_Format(PyExc_TypeError, "%s: expected a contiguous float64 array of shape (%d,)",
                     name, (int)n);
        return NULL;
    }
    return (const double *)PyArray_DATA(a);
}

/* One cycle of the object's filter into x, and what cycle() and cycle_many() both keep of it:
 * the info, the deadline misses and the warm keys. Returns vf_filter_cycle_jerk's status. No
 * Python API: cycle_many calls it with the GIL released. */
static int filter_cycle_run(FilterCycle *self, const double *q, const double *u,
                            const double *prev, const double *prev2, const double *factor,
                            double *x)
{
    int rc;
    self->opts.warm = self->warm;
    self->opts.n_warm = self->use_warm ? self->n_warm : 0;
    rc = vf_filter_cycle_metric(&self->f, q, u, prev, prev2, factor, &self->opts, x, &self->info,
                                self->scratch, self->iscratch);
    self->have_info = 1;
    if (rc == VF_ITERATION_CAP || rc == VF_DEADLINE) {
        self->misses += 1;
    }
    if (self->use_warm) {
        int32_t a;
        for (a = 0; a < self->info.n_active; a++) {
            int32_t r = self->info.active[a];
            self->warm[3 * a] = self->info.level[r];
            self->warm[3 * a + 1] = self->info.key_a[r];
            self->warm[3 * a + 2] = self->info.key_b[r];
        }
        self->n_warm = self->info.n_active;
    }
    return rc;
}

static PyObject *FilterCycle_cycle(FilterCycle *self, PyObject *const *args, Py_ssize_t nargs)
{
    const int32_t n = self->f.n;
    const double *q, *u, *prev = NULL, *prev2 = NULL, *factor = NULL;
    PyObject *out;
    int rc;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterCycle not initialised");
        return NULL;
    }
    if (nargs < 2 || nargs > 6) {
        PyErr_SetString(PyExc_TypeError,
                        "cycle(q, u, previous=None, out=None, previous2=None, factor=None)");
        return NULL;
    }
    if (nargs > 5 && args[5] != Py_None) {
        PyArrayObject *a = (PyArrayObject *)args[5];
        if (!PyArray_Check(args[5]) || PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 2
            || PyArray_DIM(a, 0) != n || PyArray_DIM(a, 1) != n || !PyArray_ISCARRAY_RO(a)
            || !PyArray_ISNOTSWAPPED(a)) {
            PyErr_Format(PyExc_TypeError,
                         "factor: expected a contiguous float64 array of shape (%d, %d)", (int)n,
                         (int)n);
            return NULL;
        }
        factor = (const double *)PyArray_DATA(a);
    }
    if ((q = vec_arg(args[0], n, "q")) == NULL || (u = vec_arg(args[1], n, "u")) == NULL) {
        return NULL;
    }
    if (nargs > 2 && args[2] != Py_None && (prev = vec_arg(args[2], n, "previous")) == NULL) {
        return NULL;
    }
    if (nargs > 4 && args[4] != Py_None && (prev2 = vec_arg(args[4], n, "previous2")) == NULL) {
        return NULL;
    }
    if (nargs > 3 && args[3] != Py_None) {
        PyArrayObject *a = (PyArrayObject *)args[3];
        if (!PyArray_Check(args[3]) || PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1
            || PyArray_DIM(a, 0) != n || !PyArray_ISCARRAY(a) || !PyArray_ISNOTSWAPPED(a)) {
            PyErr_Format(PyExc_TypeError,
                         "out: expected a writable contiguous float64 array of shape (%d,)",
                         (int)n);
            return NULL;
        }
        out = args[3];
        Py_INCREF(out);
    } else {
        npy_intp dim = n;
        out = PyArray_SimpleNew(1, &dim, NPY_DOUBLE);
        if (out == NULL) {
            return NULL;
        }
    }
    rc = filter_cycle_run(self, q, u, prev, prev2, factor,
                          (double *)PyArray_DATA((PyArrayObject *)out));
    if (rc < 0) {
        Py_DECREF(out);
        PyErr_Format(PyExc_ValueError, "vf_filter_cycle: status %d (%s)", rc,
                     rc == VF_ERR_NONFINITE ? "non-finite or too large input"
                     : rc == VF_ERR_OVERFLOW ? "overflow"
                                             : "bad argument");
        return NULL;
    }
    return out;
}


static int batch_arg(PyObject *o, Py_ssize_t *count, int32_t n, const char *name, int writable)
{
    PyArrayObject *a = (PyArrayObject *)o;
    if (!PyArray_Check(o) || PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 2
        || PyArray_DIM(a, 1) != n || !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a)
        || (writable && !PyArray_ISWRITEABLE(a))
        || (*count >= 0 && PyArray_DIM(a, 0) != *count)) {
        PyErr_Format(PyExc_TypeError,
                     "%s: expected a %scontiguous float64 array of shape (count, %d)%s", name,
                     writable ? "writable " : "", (int)n, *count >= 0 ? " like q" : "");
        return -1;
    }
    *count = PyArray_DIM(a, 0);
    return 0;
}

static PyObject *FilterCycle_cycle_batch(FilterCycle *self, PyObject *args, PyObject *kwds)
{
    PyObject *qo, *uo, *po = Py_None, *oo = Py_None, *out, *st, *sg, *na;
    int threads = 0, rc;
    int32_t slots;
    Py_ssize_t count = -1;
    const int32_t n = self->f.n;
    npy_intp dim;
    static char *kwlist[] = {"q", "u", "previous", "out", "threads", NULL};
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterCycle not initialised");
        return NULL;
    }
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OO|OOi", kwlist, &qo, &uo, &po, &oo,
                                     &threads)) {
        return NULL;
    }
    if (batch_arg(qo, &count, n, "q", 0) < 0 || batch_arg(uo, &count, n, "u", 0) < 0
        || (po != Py_None && batch_arg(po, &count, n, "previous", 0) < 0)
        || (oo != Py_None && batch_arg(oo, &count, n, "out", 1) < 0)) {
        return NULL;
    }
    if (count > INT32_MAX / 2) {
        PyErr_SetString(PyExc_ValueError, "q: too many rows");
        return NULL;
    }
    slots = vf_filter_batch_workers(threads, VF_FILTER_BATCH_MAX_THREADS);
    if (slots > self->bslots) {
        double *d = PyMem_Realloc(self->bscratch, vf_filter_batch_doubles(&self->f, threads)
                                                      * sizeof(double));
        int32_t *i;
        if (d == NULL) {
            return PyErr_NoMemory();
        }
        self->bscratch = d;
        i = PyMem_Realloc(self->biscratch,
                          vf_filter_batch_ints(&self->f, threads) * sizeof(int32_t));
        if (i == NULL) {
            return PyErr_NoMemory();
        }
        self->biscratch = i;
        self->bslots = slots;
    }
    dim = (npy_intp)count;
    if (oo != Py_None) {
        out = oo;
        Py_INCREF(out);
    } else {
        npy_intp dims[2] = {dim, n};
        out = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    }
    st = PyArray_SimpleNew(1, &dim, NPY_INT32);
    sg = PyArray_SimpleNew(1, &dim, NPY_INT32);
    na = PyArray_SimpleNew(1, &dim, NPY_INT32);
    if (out == NULL || st == NULL || sg == NULL || na == NULL) {
        Py_XDECREF(out);
        Py_XDECREF(st);
        Py_XDECREF(sg);
        Py_XDECREF(na);
        return NULL;
    }
    {
        const double *q = PyArray_DATA((PyArrayObject *)qo);
        const double *u = PyArray_DATA((PyArrayObject *)uo);
        const double *p = po == Py_None ? NULL : PyArray_DATA((PyArrayObject *)po);
        double *x = PyArray_DATA((PyArrayObject *)out);
        int32_t *s = PyArray_DATA((PyArrayObject *)st);
        int32_t *g = PyArray_DATA((PyArrayObject *)sg);
        int32_t *a = PyArray_DATA((PyArrayObject *)na);
        vf_filter_opts opts = self->opts;
        opts.warm = NULL;
        opts.n_warm = 0;
        Py_BEGIN_ALLOW_THREADS
        rc = vf_filter_cycle_batch(&self->f, (int32_t)count, q, u, p, &opts, x, s, g, a,
                                   slots, self->bscratch, self->biscratch);
        Py_END_ALLOW_THREADS
        if (rc == VF_OK) {
            Py_ssize_t r;
            for (r = 0; r < count; r++) {
                if (s[r] == VF_ITERATION_CAP || s[r] == VF_DEADLINE) {
                    self->misses += 1;
                }
            }
        }
    }
    if (rc != VF_OK) {
        Py_DECREF(out);
        Py_DECREF(st);
        Py_DECREF(sg);
        Py_DECREF(na);
        PyErr_Format(PyExc_ValueError, "vf_filter_cycle_batch: status %d", rc);
        return NULL;
    }
    return Py_BuildValue("(NNNN)", out, st, sg, na);
}

static PyObject *FilterCycle_set_options(FilterCycle *self, PyObject *args, PyObject *kwds)
{
    int maxit = 0, warm = 0;
    double budget = 0.0;
    static char *kwlist[] = {"max_iterations", "time_budget", "warm", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "|idp", kwlist, &maxit, &budget, &warm)) {
        return NULL;
    }
    if (!(budget >= 0.0)) {
        PyErr_SetString(PyExc_ValueError, "time_budget: expected >= 0");
        return NULL;
    }
    self->opts.max_iterations = maxit;
    self->opts.time_budget = budget;
    self->use_warm = warm;
    self->n_warm = 0;
    Py_RETURN_NONE;
}

static PyObject *FilterCycle_info(FilterCycle *self, PyObject *Py_UNUSED(ignored))
{
    const vf_filter_info *i = &self->info;
    return Py_BuildValue(
        "{s:i,s:i,s:i,s:i,s:(iiiii),s:(iiiii),s:d,s:i,s:i,s:i,s:i,s:i,s:i}", "status",
        i->status, "stages", i->stages, "rung", i->rung, "deadline", i->deadline, "relaxed",
        i->relaxed[0], i->relaxed[1], i->relaxed[2], i->relaxed[3], i->relaxed[4], "dropped",
        i->dropped[0], i->dropped[1], i->dropped[2], i->dropped[3], i->dropped[4], "fraction", i->fraction, "m", i->m, "n_active",
        i->n_active, "n_violated", i->n_violated, "n_relaxed", i->n_relaxed, "iterations",
        i->iterations, "solves",
        i->solves);
}

static PyObject *copy_d(const double *src, npy_intp rows, npy_intp cols, int two)
{
    npy_intp dims[2] = {rows, cols};
    PyObject *a = PyArray_SimpleNew(two ? 2 : 1, dims, NPY_DOUBLE);
    if (a != NULL && rows * cols > 0) {
        memcpy(PyArray_DATA((PyArrayObject *)a), src, (size_t)(rows * cols) * sizeof(double));
    }
    return a;
}

static PyObject *copy_i(const int32_t *src, npy_intp rows)
{
    PyObject *a = PyArray_SimpleNew(1, &rows, NPY_INT64);
    npy_intp r;
    if (a != NULL) {
        int64_t *d = (int64_t *)PyArray_DATA((PyArrayObject *)a);
        for (r = 0; r < rows; r++) {
            d[r] = src[r];
        }
    }
    return a;
}

static PyObject *FilterCycle_rows(FilterCycle *self, PyObject *Py_UNUSED(ignored))
{
    const vf_filter_info *i = &self->info;
    npy_intp m = i->m;
    if (!self->have_info || i->G == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "no successful cycle yet");
        return NULL;
    }
    return Py_BuildValue("(NNNNNNNN)", copy_d(i->G, m, self->f.n, 1), copy_d(i->b, m, 1, 0),
                         copy_i(i->level, m), copy_i(i->key_a, m), copy_i(i->key_b, m),
                         copy_d(i->dist, m, 1, 0), copy_d(i->slack, m, 1, 0),
                         copy_d(i->bound, m, 1, 0));
}

static PyObject *key_list(const vf_filter_info *i, const int32_t *rows, int32_t count)
{
    PyObject *lst;
    int32_t a;
    if (rows == NULL) {
        return PyList_New(0);
    }
    lst = PyList_New(count);
    if (lst == NULL) {
        return NULL;
    }
    for (a = 0; a < count; a++) {
        int32_t r = rows[a];
        PyObject *t = Py_BuildValue("(iii)", i->level[r], i->key_a[r], i->key_b[r]);
        if (t == NULL) {
            Py_DECREF(lst);
            return NULL;
        }
        PyList_SET_ITEM(lst, a, t);
    }
    return lst;
}

static PyObject *FilterCycle_active(FilterCycle *self, PyObject *Py_UNUSED(ignored))
{
    if (!self->have_info) {
        return PyList_New(0);
    }
    return key_list(&self->info, self->info.active, self->info.n_active);
}

static PyObject *FilterCycle_relaxed(FilterCycle *self, PyObject *Py_UNUSED(ignored))
{
    if (!self->have_info) {
        return PyList_New(0);
    }
    return key_list(&self->info, self->info.relaxed_rows, self->info.n_relaxed);
}

static PyObject *FilterCycle_misses(FilterCycle *self, void *Py_UNUSED(closure))
{
    return PyLong_FromLongLong(self->misses);
}

static PyObject *FilterCycle_stages(FilterCycle *self, void *Py_UNUSED(closure))
{
    return PyLong_FromLong(self->have_info ? (long)self->info.stages : 0L);
}

static PyObject *FilterCycle_dof(FilterCycle *self, void *Py_UNUSED(closure))
{
    return PyLong_FromLong(self->f.n);
}

/* set_attachments(flat): replace the attached shapes (8 floats each) and resize the scratch. */
static PyObject *FilterCycle_set_attachments(FilterCycle *self, PyObject *arg)
{
    const vf_filter_attachment *old = self->f.attach;
    vf_filter_attachment *keep = self->attach;
    int32_t nold = self->f.nattach;
    size_t nd, ni;
    double *sc;
    int32_t *im;
    const Py_ssize_t n = self->f.n;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterCycle is not initialised");
        return NULL;
    }
    self->attach = NULL; /* (read_attachments frees it: keep the old table until checked) */
    if (read_attachments(self, arg) < 0) {
        self->attach = keep;
        return NULL;
    }
    if (vf_filter_check(&self->f) != VF_OK) {
        PyMem_Free(self->attach);
        self->attach = keep;
        self->f.attach = old;
        self->f.nattach = nold;
        PyErr_SetString(PyExc_ValueError, "attachments: invalid (vf_filter_check)");
        return NULL;
    }
    PyMem_Free(keep);
    nd = vf_filter_doubles(&self->f);
    ni = vf_filter_ints(&self->f);
    sc = PyMem_Realloc(self->scratch, nd * sizeof(double));
    if (sc == NULL) {
        return PyErr_NoMemory();
    }
    self->scratch = sc;
    im = PyMem_Realloc(self->imem,
                       (n + ni + 3 * vf_filter_rows_max(&self->f) + 3) * sizeof(int32_t));
    if (im == NULL) {
        return PyErr_NoMemory();
    }
    self->imem = im;
    self->f.jkind = im;
    self->iscratch = im + n;
    self->warm = im + n + ni;
    self->n_warm = 0;
    self->have_info = 0;
    self->bslots = 0; /* (the batch scratch is resized on its next use) */
    Py_RETURN_NONE;
}

static PyMethodDef FilterCycle_methods[] = {
    {"set_attachments", (PyCFunction)FilterCycle_set_attachments, METH_O,
     "set_attachments(flat): the attached shapes, 8 floats each (link, a, b, radius)."},
    {"cycle", (PyCFunction)(void (*)(void))FilterCycle_cycle, METH_FASTCALL,
     "cycle(q, u, previous=None, out=None, previous2=None, factor=None) -> out: one cycle of "
     "the safety filter."},
    {"cycle_batch", (PyCFunction)(void (*)(void))FilterCycle_cycle_batch,
     METH_VARARGS | METH_KEYWORDS,
     "cycle_batch(q, u, previous=None, out=None, threads=0) -> (out, status, stages, n_active)"},
    {"set_options", (PyCFunction)(void (*)(void))FilterCycle_set_options,
     METH_VARARGS | METH_KEYWORDS, "set_options(max_iterations=0, time_budget=0.0, warm=False)"},
    {"info", (PyCFunction)FilterCycle_info, METH_NOARGS, "The last cycle's info, a dict."},
    {"rows", (PyCFunction)FilterCycle_rows, METH_NOARGS,
     "(G, b, level, key_a, key_b, dist, slack) of the last cycle."},
    {"active", (PyCFunction)FilterCycle_active, METH_NOARGS,
     "The last cycle's active row keys (level, a, b)."},
    {"relaxed", (PyCFunction)FilterCycle_relaxed, METH_NOARGS,
     "The last cycle's relaxed row keys (level, a, b)."},
    {NULL, NULL, 0, NULL},
};

static PyGetSetDef FilterCycle_getset[] = {
    {"deadline_misses", (getter)FilterCycle_misses, NULL, "cycles that used the fallback", NULL},
    {"dof", (getter)FilterCycle_dof, NULL, "joints", NULL},
    {"stages", (getter)FilterCycle_stages, NULL, "the last cycle's stage bits (0: none yet)",
     NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject FilterCycleType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._filter.FilterCycle",
    .tp_basicsize = sizeof(FilterCycle),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)FilterCycle_init,
    .tp_dealloc = (destructor)FilterCycle_dealloc,
    .tp_methods = FilterCycle_methods,
    .tp_getset = FilterCycle_getset,
    .tp_doc = "The safety filter's whole cycle in C (velfence_filter.h).",
};

/* segment_pairs(a0, a1, b0, b1) -> (s, t, dist, nrm): vf_segment_pair on N pairs (float64
 * arrays (N, 3) each; nrm (N, 3)). For tests and benchmarks; the GIL is released. */
static PyObject *segment_pairs(PyObject *mod, PyObject *args)
{
    PyObject *o[4];
    PyArrayObject *a[4] = {NULL, NULL, NULL, NULL};
    PyArrayObject *S = NULL, *T = NULL, *Dd = NULL, *Nn = NULL;
    npy_intp N, k, dims[2];
    int i;
    (void)mod;
    if (!PyArg_ParseTuple(args, "OOOO", o, o + 1, o + 2, o + 3)) {
        return NULL;
    }
    for (i = 0; i < 4; i++) {
        a[i] = (PyArrayObject *)PyArray_FROMANY(o[i], NPY_DOUBLE, 2, 2, NPY_ARRAY_CARRAY_RO);
        if (a[i] == NULL) {
            goto fail;
        }
        if (PyArray_DIM(a[i], 1) != 3 || PyArray_DIM(a[i], 0) != PyArray_DIM(a[0], 0)) {
            PyErr_SetString(PyExc_ValueError, "segment_pairs: expected four arrays (N, 3)");
            goto fail;
        }
    }
    N = PyArray_DIM(a[0], 0);
    dims[0] = N;
    dims[1] = 3;
    S = (PyArrayObject *)PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    T = (PyArrayObject *)PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    Dd = (PyArrayObject *)PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    Nn = (PyArrayObject *)PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (S == NULL || T == NULL || Dd == NULL || Nn == NULL) {
        goto fail;
    }
    {
        const double *A0 = PyArray_DATA(a[0]), *A1 = PyArray_DATA(a[1]);
        const double *B0 = PyArray_DATA(a[2]), *B1 = PyArray_DATA(a[3]);
        double *ss = PyArray_DATA(S), *tt = PyArray_DATA(T), *dd = PyArray_DATA(Dd);
        double *nn = PyArray_DATA(Nn);
        Py_BEGIN_ALLOW_THREADS
        for (k = 0; k < N; k++) {
            dd[k] = vf_segment_pair(A0 + 3 * k, A1 + 3 * k, B0 + 3 * k, B1 + 3 * k, ss + k, tt + k,
                                    NULL, NULL, nn + 3 * k);
        }
        Py_END_ALLOW_THREADS
    }
    for (i = 0; i < 4; i++) {
        Py_DECREF(a[i]);
    }
    return Py_BuildValue("NNNN", S, T, Dd, Nn);
fail:
    for (i = 0; i < 4; i++) {
        Py_XDECREF(a[i]);
    }
    Py_XDECREF(S);
    Py_XDECREF(T);
    Py_XDECREF(Dd);
    Py_XDECREF(Nn);
    return NULL;
}


/* cycle_many(cycles, q, u, previous=None, previous2=None, out=None) -> (out, status, stages):
 * row r is cycles[r].cycle(q[r], u[r], previous[r], None, previous2[r]) -- the same
 * vf_filter_cycle_jerk on that object's description, options, warm keys and scratch, with its
 * info, stages and deadline misses updated as cycle() does -- for `count` objects (a list or
 * tuple of FilterCycle, one per row, of one joint count n) on float64 C-contiguous (count, n)
 * arrays; previous / previous2 None: none for every row. A row C refuses has status < 0 and a
 * zero output (no exception). The GIL is released for the loop: the objects must not be used
 * by another thread meanwhile. (Many arms with different limits, zones and obstacles, one call
 * per control step: the verify campaigns' lock-step.) */
static PyObject *cycle_many(PyObject *mod, PyObject *args, PyObject *kwds)
{
    PyObject *co, *qo, *uo, *po = Py_None, *p2o = Py_None, *oo = Py_None;
    PyObject *seq = NULL, *out = NULL, *st = NULL, *sg = NULL;
    PyObject **items;
    Py_ssize_t count = -1, r;
    int32_t n;
    npy_intp dim;
    static char *kwlist[] = {"cycles", "q", "u", "previous", "previous2", "out", NULL};
    (void)mod;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOO|OOO", kwlist, &co, &qo, &uo, &po, &p2o,
                                     &oo)) {
        return NULL;
    }
    if (!PyList_Check(co) && !PyTuple_Check(co)) {
        PyErr_SetString(PyExc_TypeError, "cycles: expected a list or tuple of FilterCycle");
        return NULL;
    }
    seq = PySequence_Fast(co, "cycles: expected a list or tuple of FilterCycle");
    if (seq == NULL) {
        return NULL;
    }
    items = PySequence_Fast_ITEMS(seq);
    if (PySequence_Fast_GET_SIZE(seq) == 0) {
        PyErr_SetString(PyExc_ValueError, "cycles: expected at least one FilterCycle");
        goto fail;
    }
    for (r = 0; r < PySequence_Fast_GET_SIZE(seq); r++) {
        if (!PyObject_TypeCheck(items[r], &FilterCycleType)
            || ((FilterCycle *)items[r])->mem == NULL) {
            PyErr_Format(PyExc_TypeError, "cycles[%zd]: expected an initialised FilterCycle", r);
            goto fail;
        }
    }
    n = ((FilterCycle *)items[0])->f.n;
    for (r = 1; r < PySequence_Fast_GET_SIZE(seq); r++) {
        if (((FilterCycle *)items[r])->f.n != n) {
            PyErr_Format(PyExc_ValueError, "cycles[%zd]: %d joints, cycles[0] has %d", r,
                         (int)((FilterCycle *)items[r])->f.n, (int)n);
            goto fail;
        }
    }
    count = PySequence_Fast_GET_SIZE(seq);
    if (batch_arg(qo, &count, n, "q", 0) < 0 || batch_arg(uo, &count, n, "u", 0) < 0
        || (po != Py_None && batch_arg(po, &count, n, "previous", 0) < 0)
        || (p2o != Py_None && batch_arg(p2o, &count, n, "previous2", 0) < 0)
        || (oo != Py_None && batch_arg(oo, &count, n, "out", 1) < 0)) {
        goto fail;
    }
    dim = (npy_intp)count;
    if (oo != Py_None) {
        out = oo;
        Py_INCREF(out);
    } else {
        npy_intp dims[2] = {dim, n};
        out = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    }
    st = PyArray_SimpleNew(1, &dim, NPY_INT32);
    sg = PyArray_SimpleNew(1, &dim, NPY_INT32);
    if (out == NULL || st == NULL || sg == NULL) {
        goto fail;
    }
    {
        const double *q = PyArray_DATA((PyArrayObject *)qo);
        const double *u = PyArray_DATA((PyArrayObject *)uo);
        const double *p = po == Py_None ? NULL : PyArray_DATA((PyArrayObject *)po);
        const double *p2 = p2o == Py_None ? NULL : PyArray_DATA((PyArrayObject *)p2o);
        double *x = PyArray_DATA((PyArrayObject *)out);
        int32_t *s = PyArray_DATA((PyArrayObject *)st);
        int32_t *g = PyArray_DATA((PyArrayObject *)sg);
        Py_BEGIN_ALLOW_THREADS
        for (r = 0; r < count; r++) {
            FilterCycle *self = (FilterCycle *)items[r];
            const size_t o = (size_t)r * (size_t)n;
            s[r] = filter_cycle_run(self, q + o, u + o, p == NULL ? NULL : p + o,
                                    p2 == NULL ? NULL : p2 + o, NULL, x + o);
            g[r] = self->info.stages;
        }
        Py_END_ALLOW_THREADS
    }
    Py_DECREF(seq);
    return Py_BuildValue("(NNN)", out, st, sg);
fail:
    Py_XDECREF(seq);
    Py_XDECREF(out);
    Py_XDECREF(st);
    Py_XDECREF(sg);
    return NULL;
}

static PyMethodDef module_methods[] = {
    {"cycle_many", (PyCFunction)(void (*)(void))cycle_many, METH_VARARGS | METH_KEYWORDS,
     "cycle_many(cycles, q, u, previous=None, previous2=None, out=None) -> (out, status, "
     "stages): each row's FilterCycle.cycle in one call (the GIL released)."},
    {"segment_pairs", segment_pairs, METH_VARARGS,
     "segment_pairs(a0, a1, b0, b1) -> (s, t, dist, nrm): vf_segment_pair on (N, 3) arrays."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef filter_module = {
    PyModuleDef_HEAD_INIT, "_filter", "The safety filter's whole cycle in C.", -1,
    module_methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__filter(void)
{
    PyObject *m;
    import_array();
    if (PyType_Ready(&FilterCycleType) < 0) {
        return NULL;
    }
    m = PyModule_Create(&filter_module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&FilterCycleType);
    if (PyModule_AddObject(m, "FilterCycle", (PyObject *)&FilterCycleType) < 0) {
        Py_DECREF(&FilterCycleType);
        Py_DECREF(m);
        return NULL;
    }
#define C(name) PyModule_AddIntConstant(m, #name, VF_FILTER_##name)
    C(STAGE_PROJECTION);
    C(STAGE_RECOVERY);
    C(STAGE_MODEL_CHECK);
    C(STAGE_DROPPED_RATE);
    C(STAGE_RELAXED_OBSTACLES);
    C(STAGE_RELAXED_WORKSPACE);
    C(STAGE_RELAXED_JOINT);
    C(STAGE_STOP);
    C(STAGE_DEADLINE);
    C(STAGE_COMMAND_SCALED);
    C(STAGE_MODEL_SCALED);
    C(STAGE_DROPPED_JERK);
    C(LEVEL_JOINT);
    C(LEVEL_WORKSPACE);
    C(LEVEL_OBSTACLE);
    C(LEVEL_RATE);
    C(LEVEL_JERK);
    C(DEADLINE_NONE);
    C(DEADLINE_ITERATIONS);
    C(DEADLINE_TIME);
#undef C
    return m;
}
