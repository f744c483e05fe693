/*
 * velfence_core._nd -- CPython binding of the n-D projection and exact law (velfence_nd.h).
 *
 *   project(u, G, b) -> (status, x)          vf_nd_project_kernel on float64 buffers u (n,),
 *                                             G (m, n) C-contiguous, b (m,); x a new array (n,).
 *   project_full(u, G, b) -> (status, q, iters, x, act, lam)   the same with the active set.
 *   PolytopeLaw(N, off, cen, nf, dim, kind, prm, relax, idt, max_abs=1e150)
 *                       (PolytopeShaper's kernel data)
 *     law(p, v)         -> (out, res, active, dist, bnd, work): polytope_kernel's outputs
 *                          (out a new float64 array (dim,), res the 8-tuple, the rest lists)
 *     shape_array(p, v) -> the shaped velocity as a new array (dim,), or None when p, v are not
 *                          float64 ndarrays of shape (dim,), not finite or beyond max_abs, or the
 *                          output overflowed
 *                          (the caller's generic path then owns the on_invalid policy).
 *     batch(P, V, out, zones) -> None: the unchecked kernel over rows (P, V float64 (N, dim)
 *                          C-contiguous, out float64 (N, dim), zones int64 (N,)); releases the GIL.
 *     batch_velocity(P, V, out) -> the number of rows not finite in or out: shape_batch's loop,
 *                          writing only the velocities (rows with non-finite input are not run;
 *                          the caller then takes its generic path); releases the GIL.
 *   rate_bounds(kind, prm, dist, speed, idt) -> bounds (k,)   vf_nd_rate_bounds (velfence.filter.rows.rate_bounds)
 *   CapsuleRows(lrad, C, srad, vmax, nl, nj, ncols, k, buf, dt, kind, prm)
 *     rows(P, axes, u, idt) -> (G (r, ncols), b (r,), d (r,), obstacles, links): the safety
 *                          filter's obstacle rows (vf_nd_capsule_rows) from one kinematics pass.
 *     clearances(P) -> list of every pair's clearance (vf_nd_capsule_clearances).
 *   ConfigControl(C, rho, lrad, n, m, k, w_e, w_z, lam, kz, h, max_speed, recheck, rounds)
 *     solve(P, axes, yr) -> (code, q_dot, q_free, points, links, fractions, distances, normals,
 *                          rows, d_dot, d_dot_free, active, condition, ee_rate_error,
 *                          ee_rate_error_free): one cycle of configuration control (velfence_cc.h)
 *                          from one kinematics pass; code is VF_CC_OK or a VF_CC_ERR_* code.
 *   rr_sr_step(arm, q, xdot) -> (q_dot, w, det, k, singular, scale) or an int VF_RR_ERR_* code:
 *                          one resolved-rate SR step of a 6-joint DH arm (velfence_rr.h); arm a
 *                          float64 array (37,): the DH rows (a, cos alpha, sin alpha, d, offset)
 *                          x 6, the tool point (3), k0, w0, singular_tol, max_speed (0: none);
 *                          q, xdot float64 ndarrays (6,) (anything else: TypeError).
 *   rr_jacobian(arm, q) -> J, a new float64 array (6, 6) (vf_rr_jacobian), or an int code.
 * The kernels are the unchecked ones: Python keeps its own checks and policies, as with _core.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <string.h>

#include "velfence_cc.h"
#include "velfence_nd.h"
#include "velfence_rr.h"

/* ------------------------------------------------------------------ helpers */

static int read_doubles(PyObject *seq, const char *name, double *dst, Py_ssize_t count)
{
    PyObject *fast;
    Py_ssize_t i;
    if (PyArray_CheckExact(seq)) {
        PyArrayObject *a = (PyArrayObject *)seq;
        if (PyArray_NDIM(a) == 1 && PyArray_TYPE(a) == NPY_DOUBLE && PyArray_ISCARRAY_RO(a)
            && PyArray_ISNOTSWAPPED(a)) {
            if (PyArray_DIM(a, 0) != count) {
                PyErr_Format(PyExc_ValueError, "%s: expected %zd floats, got %zd", name, count,
                             (Py_ssize_t)PyArray_DIM(a, 0));
                return -1;
            }
            memcpy(dst, PyArray_DATA(a), (size_t)count * sizeof(double));
            return 0;
        }
    }
    fast = PySequence_Fast(seq, name);
    if (fast == NULL) {
        return -1;
    }
    if (PySequence_Fast_GET_SIZE(fast) != count) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd floats, got %zd", name, count,
                     PySequence_Fast_GET_SIZE(fast));
        Py_DECREF(fast);
        return -1;
    }
    for (i = 0; i < count; i++) {
        double v = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, i));
        if (v == -1.0 && PyErr_Occurred()) {
            Py_DECREF(fast);
            return -1;
        }
        dst[i] = v;
    }
    Py_DECREF(fast);
    return 0;
}

static int get_view(PyObject *o, Py_buffer *view, int writable, const char *fmt, const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, view, flags) < 0) {
        return -1;
    }
    if (view->itemsize != 8 || view->format == NULL
        || !(strcmp(view->format, fmt) == 0 || (fmt[0] == 'q' && strcmp(view->format, "l") == 0
                                                && sizeof(long) == 8))) {
        PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous buffer of format '%s', got '%s'",
                     name, fmt, view->format ? view->format : "?");
        PyBuffer_Release(view);
        view->obj = NULL;
        return -1;
    }
    return 0;
}

static void release(Py_buffer *v)
{
    if (v->obj) {
        PyBuffer_Release(v);
        v->obj = NULL;
    }
}

static PyObject *new_vector(const double *x, npy_intp n)
{
    PyObject *o = PyArray_SimpleNew(1, &n, NPY_DOUBLE);
    if (o == NULL) {
        return NULL;
    }
    memcpy(PyArray_DATA((PyArrayObject *)o), x, (size_t)n * sizeof(double));
    return o;
}

static PyObject *int_list(const int32_t *a, Py_ssize_t n)
{
    PyObject *l = PyList_New(n);
    Py_ssize_t i;
    if (l == NULL) {
        return NULL;
    }
    for (i = 0; i < n; i++) {
        PyObject *v = PyLong_FromLong((long)a[i]);
        if (v == NULL) {
            Py_DECREF(l);
            return NULL;
        }
        PyList_SET_ITEM(l, i, v);
    }
    return l;
}

static PyObject *float_list(const double *a, Py_ssize_t n)
{
    PyObject *l = PyList_New(n);
    Py_ssize_t i;
    if (l == NULL) {
        return NULL;
    }
    for (i = 0; i < n; i++) {
        PyObject *v = PyFloat_FromDouble(a[i]);
        if (v == NULL) {
            Py_DECREF(l);
            return NULL;
        }
        PyList_SET_ITEM(l, i, v);
    }
    return l;
}

/* ------------------------------------------------------------------ project */

/* Runs the kernel on (u, G, b); returns (status, x) or, with full, (status, q, iterations, x,
 * active, multipliers). */
static PyObject *run_project(PyObject *const *args, Py_ssize_t nargs, int full)
{
    Py_buffer u = {0}, G = {0}, b = {0};
    Py_ssize_t n, m;
    double *mem = NULL;
    int32_t *act = NULL;
    PyObject *ret = NULL;
    if (nargs != 3) {
        PyErr_Format(PyExc_TypeError, "expected 3 arguments (u, G, b), got %zd", nargs);
        return NULL;
    }
    if (get_view(args[0], &u, 0, "d", "u") < 0 || get_view(args[1], &G, 0, "d", "G") < 0
        || get_view(args[2], &b, 0, "d", "b") < 0) {
        goto done;
    }
    n = u.len / 8;
    m = b.len / 8;
    if (n < 1 || n > (1 << 12) || m > (1 << 24) || G.len != 8 * n * m) {
        PyErr_SetString(PyExc_ValueError, "u must be (n,) with n >= 1, G (m, n) and b (m,)");
        goto done;
    }
    {
        size_t nw = vf_nd_project_doubles((int32_t)m, (int32_t)n);
        int status;
        int32_t q = 0, iters = 0;
        PyObject *x;
        mem = PyMem_Malloc((nw + 2 * (size_t)n + 1) * sizeof(double));
        act = PyMem_Malloc(((size_t)n + 1) * sizeof(int32_t));
        if (mem == NULL || act == NULL) {
            PyErr_NoMemory();
            goto done;
        }
        status = vf_nd_project_kernel((const double *)u.buf, (const double *)G.buf,
                                      (const double *)b.buf, (int32_t)m, (int32_t)n, mem + nw,
                                      mem + nw + n, act, mem, &q, &iters);
        x = new_vector(mem + nw, (npy_intp)n);
        if (x == NULL) {
            goto done;
        }
        if (!full) {
            ret = Py_BuildValue("(iN)", status, x);
        } else {
            PyObject *a = int_list(act, q);
            PyObject *l = float_list(mem + nw + n, q);
            if (a == NULL || l == NULL) {
                Py_XDECREF(a);
                Py_XDECREF(l);
                Py_DECREF(x);
                goto done;
            }
            ret = Py_BuildValue("(iiiNNN)", status, (int)q, (int)iters, x, a, l);
        }
    }
done:
    release(&u);
    release(&G);
    release(&b);
    PyMem_Free(mem);
    PyMem_Free(act);
    return ret;
}

static PyObject *nd_project(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    return run_project(args, nargs, 0);
}

static PyObject *nd_project_full(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    (void)mod;
    return run_project(args, nargs, 1);
}

/* ------------------------------------------------------------------ PolytopeLaw */

typedef struct {
    PyObject_HEAD
    vf_nd_polytope poly;
    vf_nd_law law;
    double *mem; /* N, off, cen, p, v, out, then the law's scratch */
    int32_t *ints;
    int32_t *active;
    vf_nd_scratch scratch;
    double *p, *v, *out;
    double max_abs; /* shape_array: larger inputs take the caller's generic path */
} PolytopeLaw;

static void PolytopeLaw_dealloc(PolytopeLaw *self)
{
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int PolytopeLaw_init(PolytopeLaw *self, PyObject *args, PyObject *kwds)
{
    PyObject *N, *off, *cen, *prm;
    double idt;
    double max_abs = 1e150;
    int nf, dim, kind, relax;
    size_t f, d, nd, ni;
    static char *kwlist[] = {"N",    "off",  "cen", "nf",      "dim", "kind",
                             "prm",  "relax", "idt", "max_abs", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOiiiOpd|d", kwlist, &N, &off, &cen, &nf,
                                     &dim, &kind, &prm, &relax, &idt, &max_abs)) {
        return -1;
    }
    if (nf < 1 || dim < 1 || nf > (1 << 20) || dim > (1 << 12)) {
        PyErr_Format(PyExc_ValueError, "nf, dim: expected 1..2^20 facets in 1..4096 dimensions, "
                     "got %d, %d", nf, dim);
        return -1;
    }
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    self->mem = NULL;
    self->ints = NULL;
    f = (size_t)nf;
    d = (size_t)dim;
    nd = vf_nd_law_doubles(nf, dim);
    ni = vf_nd_law_ints(nf, dim);
    self->mem = PyMem_Calloc(f * d + f + 4 * d + nd, sizeof(double));
    self->ints = PyMem_Calloc(ni + d + 1, sizeof(int32_t));
    if (self->mem == NULL || self->ints == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    {
        double *Nd = self->mem;
        double *offd = Nd + f * d;
        double *cend = offd + f;
        self->p = cend + d;
        self->v = self->p + d;
        self->out = self->v + d;
        self->scratch.dbl = self->out + d;
        self->scratch.ints = self->ints;
        self->active = self->ints + ni;
        if (read_doubles(N, "N", Nd, (Py_ssize_t)(f * d)) < 0
            || read_doubles(off, "off", offd, nf) < 0 || read_doubles(cen, "cen", cend, dim) < 0
            || read_doubles(prm, "prm", self->law.prm, VF_ND_PROFILE_PARAMS) < 0) {
            return -1;
        }
        self->poly.N = Nd;
        self->poly.off = offd;
        self->poly.cen = cend;
        self->poly.nf = nf;
        self->poly.dim = dim;
    }
    self->max_abs = max_abs;
    self->law.kind = kind;
    self->law.relax = relax;
    self->law.idt = idt;
    if (vf_nd_check(&self->poly, &self->law) != VF_ND_OK) {
        PyErr_SetString(PyExc_ValueError, "invalid polytope or law data (vf_nd_check)");
        return -1;
    }
    return 0;
}

static int read_state(PolytopeLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PolytopeLaw not initialised");
        return -1;
    }
    if (nargs != 2) {
        PyErr_Format(PyExc_TypeError, "expected 2 arguments (p, v), got %zd", nargs);
        return -1;
    }
    if (read_doubles(args[0], "p", self->p, self->poly.dim) < 0
        || read_doubles(args[1], "v", self->v, self->poly.dim) < 0) {
        return -1;
    }
    return 0;
}

static PyObject *PolytopeLaw_law(PolytopeLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    vf_nd_result r;
    const double *dist, *bnd;
    const int32_t *work;
    PyObject *out, *act, *dl, *bl, *wl;
    if (read_state(self, args, nargs) < 0) {
        return NULL;
    }
    vf_nd_kernel(&self->poly, &self->law, self->p, self->v, self->out, self->active,
                 &self->scratch, &r);
    vf_nd_bounded(&self->poly, &self->scratch, &dist, &bnd, &work);
    out = new_vector(self->out, self->poly.dim);
    act = int_list(self->active, r.q);
    dl = float_list(dist, self->poly.nf);
    bl = float_list(bnd, self->poly.nf);
    wl = int_list(work, self->poly.nf);
    if (out == NULL || act == NULL || dl == NULL || bl == NULL || wl == NULL) {
        Py_XDECREF(out);
        Py_XDECREF(act);
        Py_XDECREF(dl);
        Py_XDECREF(bl);
        Py_XDECREF(wl);
        return NULL;
    }
    return Py_BuildValue("(N(iiiiiddi)NNNN)", out, (int)r.zone, (int)r.stages, (int)r.q,
                         (int)r.p1, (int)r.p2, r.d1, r.d2, (int)r.m, act, dl, bl, wl);
}

static PyObject *PolytopeLaw_shape_array(PolytopeLaw *self, PyObject *const *args,
                                         Py_ssize_t nargs)
{
    vf_nd_result r;
    int i, k;
    int32_t dim = self->poly.dim;
    double s = 0.0;
    if (self->mem == NULL || nargs != 2) {
        Py_RETURN_NONE;
    }
    for (i = 0; i < 2; i++) {
        PyArrayObject *a = (PyArrayObject *)args[i];
        double *dst = i == 0 ? self->p : self->v;
        if (!PyArray_CheckExact(args[i]) || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != dim
            || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a)) {
            Py_RETURN_NONE;
        }
        for (k = 0; k < dim; k++) {
            dst[k] = *(const double *)PyArray_GETPTR1(a, k);
            if (!(fabs(dst[k]) <= self->max_abs)) {
                Py_RETURN_NONE;
            }
        }
    }
    vf_nd_kernel(&self->poly, &self->law, self->p, self->v, self->out, self->active,
                 &self->scratch, &r);
    /* PolytopeShaper.shape's overflow test: the sum of the output, in order, is finite */
    for (k = 0; k < dim; k++) {
        s += self->out[k];
    }
    if (!(s - s == 0.0)) {
        Py_RETURN_NONE;
    }
    return new_vector(self->out, dim);
}

/* What batch and batch_velocity share: the views P, V (read) and out (written), and the kernel's
 * scratch with the active set after it. nd_batch_close releases whatever was taken. */
typedef struct {
    Py_buffer P, V, out;
    vf_nd_scratch s;
    int32_t *active;
} nd_batch;

/* The law initialised, nargs == want (names lists them for the message), then the views P, V, out
 * in that order. Returns -1 with an exception set on failure. */
static int nd_batch_open(PolytopeLaw *self, PyObject *const *args, Py_ssize_t nargs,
                         Py_ssize_t want, const char *names, nd_batch *b)
{
    memset(b, 0, sizeof(*b));
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PolytopeLaw not initialised");
        return -1;
    }
    if (nargs != want) {
        PyErr_Format(PyExc_TypeError, "expected %zd arguments (%s), got %zd", want, names, nargs);
        return -1;
    }
    if (get_view(args[0], &b->P, 0, "d", "P") < 0 || get_view(args[1], &b->V, 0, "d", "V") < 0
        || get_view(args[2], &b->out, 1, "d", "out") < 0) {
        return -1;
    }
    return 0;
}

/* P, V and out each hold rows x dim doubles (else ValueError with msg, -1); then the scratch for
 * one kernel call and the active set (else MemoryError, -1). */
static int nd_batch_prepare(PolytopeLaw *self, nd_batch *b, Py_ssize_t rows, const char *msg)
{
    int32_t dim = self->poly.dim;
    size_t nints = vf_nd_law_ints(self->poly.nf, dim);
    if (b->P.len != 8 * rows * dim || b->V.len != 8 * rows * dim
        || b->out.len != 8 * rows * dim) {
        PyErr_SetString(PyExc_ValueError, msg);
        return -1;
    }
    b->s.dbl = PyMem_Malloc(vf_nd_law_doubles(self->poly.nf, dim) * sizeof(double));
    b->s.ints = PyMem_Malloc((nints + (size_t)dim + 1) * sizeof(int32_t));
    if (b->s.dbl == NULL || b->s.ints == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    b->active = b->s.ints + nints;
    return 0;
}

static void nd_batch_close(nd_batch *b)
{
    release(&b->P);
    release(&b->V);
    release(&b->out);
    PyMem_Free(b->s.dbl);
    PyMem_Free(b->s.ints);
}

static PyObject *PolytopeLaw_batch(PolytopeLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    nd_batch b;
    Py_buffer zones = {0};
    Py_ssize_t rows, r;
    int32_t dim = self->poly.dim;
    PyObject *ret = NULL;
    if (nd_batch_open(self, args, nargs, 4, "P, V, out, zones", &b) < 0
        || get_view(args[3], &zones, 1, "q", "zones") < 0) {
        goto done;
    }
    rows = zones.len / 8;
    if (nd_batch_prepare(self, &b, rows, "P, V, out must be (N, dim) and zones (N,)") < 0) {
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        vf_nd_result res;
        for (r = 0; r < rows; r++) {
            size_t o = (size_t)r * (size_t)dim;
            vf_nd_kernel(&self->poly, &self->law, (const double *)b.P.buf + o,
                         (const double *)b.V.buf + o, (double *)b.out.buf + o, b.active, &b.s,
                         &res);
            ((int64_t *)zones.buf)[r] = res.zone;
        }
    }
    Py_END_ALLOW_THREADS
    ret = Py_None;
    Py_INCREF(ret);
done:
    nd_batch_close(&b);
    release(&zones);
    return ret;
}

/* shape_batch's velocity-only loop: the unchecked kernel over the rows of P, V into out, nothing
 * else written (no zones, no active set kept). A row whose input is not finite is not run (its
 * output is set to 0); returns the number of rows not finite in or out, for which the caller
 * takes its generic path (zones_batch, which owns the on_invalid policy). */
static PyObject *PolytopeLaw_batch_velocity(PolytopeLaw *self, PyObject *const *args,
                                            Py_ssize_t nargs)
{
    nd_batch b;
    Py_ssize_t rows, r, bad = 0;
    int32_t dim = self->poly.dim;
    PyObject *ret = NULL;
    if (nd_batch_open(self, args, nargs, 3, "P, V, out", &b) < 0) {
        goto done;
    }
    rows = b.out.len / (8 * (Py_ssize_t)dim);
    if (nd_batch_prepare(self, &b, rows, "P, V, out must be (N, dim)") < 0) {
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        vf_nd_result res;
        for (r = 0; r < rows; r++) {
            size_t o = (size_t)r * (size_t)dim;
            const double *p = (const double *)b.P.buf + o, *v = (const double *)b.V.buf + o;
            double *x = (double *)b.out.buf + o;
            int32_t k, ok = 1;
            for (k = 0; k < dim; k++) {
                ok &= isfinite(p[k]) && isfinite(v[k]);
            }
            if (!ok) {
                for (k = 0; k < dim; k++) {
                    x[k] = 0.0;
                }
                bad += 1;
                continue;
            }
            vf_nd_kernel(&self->poly, &self->law, p, v, x, b.active, &b.s, &res);
            for (k = 0; k < dim; k++) {
                ok &= isfinite(x[k]);
            }
            bad += !ok;
        }
    }
    Py_END_ALLOW_THREADS
    ret = PyLong_FromSsize_t(bad);
done:
    nd_batch_close(&b);
    return ret;
}

static PyMethodDef PolytopeLaw_methods[] = {
    {"law", (PyCFunction)(void (*)(void))PolytopeLaw_law, METH_FASTCALL,
     "law(p, v) -> (out, res, active, dist, bnd, work): polytope_kernel's outputs."},
    {"shape_array", (PyCFunction)(void (*)(void))PolytopeLaw_shape_array, METH_FASTCALL,
     "shape_array(p, v) -> the shaped velocity (dim,), or None (not the fast path)."},
    {"batch", (PyCFunction)(void (*)(void))PolytopeLaw_batch, METH_FASTCALL,
     "batch(P, V, out, zones) -> None: the kernel over rows."},
    {"batch_velocity", (PyCFunction)(void (*)(void))PolytopeLaw_batch_velocity, METH_FASTCALL,
     "batch_velocity(P, V, out) -> rows not finite in or out: the kernel over rows, velocities "
     "only."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject PolytopeLawType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._nd.PolytopeLaw",
    .tp_basicsize = sizeof(PolytopeLaw),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The n-D exact law on one polytope (vf_nd_*).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)PolytopeLaw_init,
    .tp_dealloc = (destructor)PolytopeLaw_dealloc,
    .tp_methods = PolytopeLaw_methods,
};


/* ------------------------------------------------------------------ filter helpers */

static PyObject *nd_rate_bounds(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    int kind;
    double prm[VF_ND_PROFILE_PARAMS], speed, idt;
    Py_buffer dist = {0};
    Py_ssize_t k;
    int32_t *work = NULL;
    PyObject *out = NULL;
    npy_intp dims;
    (void)mod;
    if (nargs != 5) {
        PyErr_Format(PyExc_TypeError, "expected 5 arguments (kind, prm, dist, speed, idt), got %zd",
                     nargs);
        return NULL;
    }
    kind = (int)PyLong_AsLong(args[0]);
    if (kind == -1 && PyErr_Occurred()) {
        return NULL;
    }
    speed = PyFloat_AsDouble(args[3]);
    idt = PyFloat_AsDouble(args[4]);
    if (PyErr_Occurred() || read_doubles(args[1], "prm", prm, VF_ND_PROFILE_PARAMS) < 0) {
        return NULL;
    }
    if (get_view(args[2], &dist, 0, "d", "dist") < 0) {
        return NULL;
    }
    k = dist.len / 8;
    dims = k;
    work = PyMem_Malloc((2 * (size_t)k + 1) * sizeof(int32_t));
    if (work == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    out = PyArray_SimpleNew(1, &dims, NPY_DOUBLE);
    if (out == NULL) {
        goto done;
    }
    vf_nd_rate_bounds(kind, prm, (const double *)dist.buf, (int32_t)k, speed, idt,
                      (double *)PyArray_DATA((PyArrayObject *)out), work);
done:
    release(&dist);
    PyMem_Free(work);
    return out;
}

typedef struct {
    PyObject_HEAD
    vf_nd_capsules cap;
    double *mem; /* lrad, C, srad, vmax, then the outputs: G, b, d, work */
    int32_t *ints; /* obs, link */
    double *G, *b, *d, *work;
} CapsuleRows;

static void CapsuleRows_dealloc(CapsuleRows *self)
{
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int CapsuleRows_init(CapsuleRows *self, PyObject *args, PyObject *kwds)
{
    PyObject *lrad, *C, *srad, *vmax, *prm;
    int nl, nj, ncols, k, kind;
    double buf, dt;
    size_t pairs;
    static char *kwlist[] = {"lrad", "C", "srad", "vmax", "nl", "nj", "ncols", "k", "buf", "dt",
                             "kind", "prm", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOiiiiddiO", kwlist, &lrad, &C, &srad, &vmax,
                                     &nl, &nj, &ncols, &k, &buf, &dt, &kind, &prm)) {
        return -1;
    }
    if (nl < 1 || nj < 0 || nj > nl || ncols < nj || k < 0 || nl > 4096 || ncols > 4096
        || k > (1 << 16) || !(dt >= 0.0)) {
        PyErr_SetString(PyExc_ValueError, "CapsuleRows: bad sizes");
        return -1;
    }
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    pairs = (size_t)k * (size_t)nl;
    self->mem = PyMem_Calloc((size_t)nl + 4 * (size_t)k + (size_t)nj + pairs * (size_t)ncols
                                 + 3 * pairs + (size_t)nl + 1,
                             sizeof(double));
    self->ints = PyMem_Calloc(2 * pairs + 1, sizeof(int32_t));
    if (self->mem == NULL || self->ints == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    {
        double *lr = self->mem;
        double *cc = lr + nl;
        double *sr = cc + 3 * (size_t)k;
        double *vm = sr + k;
        int32_t j;
        self->G = vm + nj;
        self->b = self->G + pairs * (size_t)ncols;
        self->d = self->b + pairs;
        self->work = self->d + pairs;
        if (read_doubles(lrad, "lrad", lr, nl) < 0 || read_doubles(C, "C", cc, 3 * (Py_ssize_t)k) < 0
            || read_doubles(srad, "srad", sr, k) < 0 || read_doubles(vmax, "vmax", vm, nj) < 0
            || read_doubles(prm, "prm", self->cap.prm, VF_ND_PROFILE_PARAMS) < 0) {
            return -1;
        }
        self->cap.lrad = lr;
        self->cap.C = cc;
        self->cap.srad = sr;
        self->cap.vmax = vm;
        self->cap.vsum = 0.0;
        for (j = 0; j < nj; j++) {
            self->cap.vsum += vm[j];
        }
    }
    self->cap.nl = nl;
    self->cap.nj = nj;
    self->cap.ncols = ncols;
    self->cap.k = k;
    self->cap.buf = buf;
    self->cap.dt = dt;
    self->cap.idt = dt > 0.0 ? 1.0 / dt : 0.0;
    self->cap.kind = kind;
    return 0;
}

/* rows(P, axes, u, idt) -> (G (r, ncols), b (r,), d (r,), obs list, link list) */
static PyObject *CapsuleRows_rows(CapsuleRows *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer P = {0}, A = {0}, u = {0};
    PyObject *ret = NULL, *G = NULL, *b = NULL, *d = NULL, *ol = NULL, *ll = NULL;
    vf_nd_capsules cap;
    int32_t r;
    npy_intp dims[2];
    size_t pairs;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "CapsuleRows not initialised");
        return NULL;
    }
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "expected 4 arguments (P, axes, u, idt), got %zd", nargs);
        return NULL;
    }
    cap = self->cap;
    cap.idt = PyFloat_AsDouble(args[3]);
    if (cap.idt == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    if (!(cap.idt > 0.0)) {
        cap.dt = 0.0;
        cap.idt = 0.0;
    }
    if (get_view(args[0], &P, 0, "d", "P") < 0 || get_view(args[1], &A, 0, "d", "axes") < 0
        || get_view(args[2], &u, 0, "d", "u") < 0) {
        goto done;
    }
    if (P.len != 8 * 3 * ((Py_ssize_t)cap.nl + 1) || A.len < 8 * 3 * (Py_ssize_t)cap.nj
        || u.len != 8 * (Py_ssize_t)cap.ncols) {
        PyErr_SetString(PyExc_ValueError, "P must be (nl + 1, 3), axes (>= nj, 3), u (ncols,)");
        goto done;
    }
    cap.P = (const double *)P.buf;
    cap.axes = (const double *)A.buf;
    pairs = (size_t)cap.k * (size_t)cap.nl;
    r = vf_nd_capsule_rows(&cap, (const double *)u.buf, self->G, self->b, self->d, self->ints,
                           self->ints + pairs, self->work);
    dims[0] = r;
    dims[1] = cap.ncols;
    G = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    b = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    d = PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    ol = int_list(self->ints, r);
    ll = int_list(self->ints + pairs, r);
    if (G == NULL || b == NULL || d == NULL || ol == NULL || ll == NULL) {
        Py_XDECREF(G);
        Py_XDECREF(b);
        Py_XDECREF(d);
        Py_XDECREF(ol);
        Py_XDECREF(ll);
        goto done;
    }
    memcpy(PyArray_DATA((PyArrayObject *)G), self->G, (size_t)r * cap.ncols * sizeof(double));
    memcpy(PyArray_DATA((PyArrayObject *)b), self->b, (size_t)r * sizeof(double));
    memcpy(PyArray_DATA((PyArrayObject *)d), self->d, (size_t)r * sizeof(double));
    ret = Py_BuildValue("(NNNNN)", G, b, d, ol, ll);
done:
    release(&P);
    release(&A);
    release(&u);
    return ret;
}

/* clearances(P) -> list of the k * nl clearances (sphere-major) at the joint points P */
static PyObject *CapsuleRows_clearances(CapsuleRows *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer P = {0};
    vf_nd_capsules cap;
    PyObject *ret = NULL;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "CapsuleRows not initialised");
        return NULL;
    }
    if (nargs != 1) {
        PyErr_Format(PyExc_TypeError, "expected 1 argument (P), got %zd", nargs);
        return NULL;
    }
    if (get_view(args[0], &P, 0, "d", "P") < 0) {
        return NULL;
    }
    if (P.len != 8 * 3 * ((Py_ssize_t)self->cap.nl + 1)) {
        PyErr_SetString(PyExc_ValueError, "P must be (nl + 1, 3)");
        release(&P);
        return NULL;
    }
    cap = self->cap;
    cap.P = (const double *)P.buf;
    vf_nd_capsule_clearances(&cap, self->work);
    ret = float_list(self->work, (Py_ssize_t)cap.k * cap.nl);
    release(&P);
    return ret;
}

static PyMethodDef CapsuleRows_methods[] = {
    {"clearances", (PyCFunction)(void (*)(void))CapsuleRows_clearances, METH_FASTCALL,
     "clearances(P) -> the k * nl pair clearances (sphere-major): vf_nd_capsule_clearances."},
    {"rows", (PyCFunction)(void (*)(void))CapsuleRows_rows, METH_FASTCALL,
     "rows(P, axes, u, idt) -> (G, b, d, obstacles, links): vf_nd_capsule_rows."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject CapsuleRowsType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._nd.CapsuleRows",
    .tp_basicsize = sizeof(CapsuleRows),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "A chain's capsule links and sphere obstacles: the safety filter's obstacle rows.",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)CapsuleRows_init,
    .tp_dealloc = (destructor)CapsuleRows_dealloc,
    .tp_methods = CapsuleRows_methods,
};

/* ------------------------------------------------------------------ a DH chain's filter rows */

typedef struct {
    PyObject_HEAD
    vf_nd_filter f;
    PyObject *caps;        /* the CapsuleRows whose obstacle data f.cap points into, or NULL */
    double *mem;           /* dh, tool, lower, upper, vmax, amax, jprm, the workspaces' N, off */
    int32_t *jkind;
    vf_nd_workspace *ws;
    double *out;           /* P, axes, flange, G, b, dist, work */
    int32_t *iout;         /* level, tag_a, tag_b */
    size_t rmax;
} FilterRows;

static void FilterRows_dealloc(FilterRows *self)
{
    Py_XDECREF(self->caps);
    PyMem_Free(self->mem);
    PyMem_Free(self->jkind);
    PyMem_Free(self->ws);
    PyMem_Free(self->out);
    PyMem_Free(self->iout);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* FilterRows(dh, tool, lower, upper, vmax, amax | None, jkind, jprm, workspaces, caps | None):
 * workspaces a list of (N (nf * 3), off (nf,), point, kind, prm (6,)). */
static int FilterRows_init(FilterRows *self, PyObject *args, PyObject *kwds)
{
    PyObject *dh, *tool, *lower, *upper, *vmax, *amax, *jkind, *jprm, *wsl, *caps, *fast = NULL;
    Py_ssize_t n, nw, w, total = 0;
    double *m;
    int32_t j;
    static char *kwlist[] = {"dh",    "tool", "lower", "upper",      "vmax", "amax",
                             "jkind", "jprm", "workspaces", "caps", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOOOOOOO", kwlist, &dh, &tool, &lower, &upper,
                                     &vmax, &amax, &jkind, &jprm, &wsl, &caps)) {
        return -1;
    }
    if (self->mem != NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterRows is initialised once");
        return -1;
    }
    n = PySequence_Size(vmax);
    if (n < 1 || n > 4096) {
        PyErr_SetString(PyExc_ValueError, "FilterRows: 1 to 4096 joints");
        return -1;
    }
    fast = PySequence_Fast(wsl, "workspaces");
    if (fast == NULL) {
        return -1;
    }
    nw = PySequence_Fast_GET_SIZE(fast);
    for (w = 0; w < nw; w++) {
        PyObject *item = PySequence_Fast_GET_ITEM(fast, w);
        Py_ssize_t len = PyTuple_Check(item) && PyTuple_GET_SIZE(item) == 5
                             ? PySequence_Size(PyTuple_GET_ITEM(item, 1))
                             : -1;
        if (len < 1 || len > (1 << 20)) {
            PyErr_SetString(PyExc_ValueError, "workspaces: (N, off, point, kind, prm) tuples");
            goto fail;
        }
        total += len;
    }
    self->mem = PyMem_Calloc(15 * (size_t)n + 3 + 4 * (size_t)total + 1, sizeof(double));
    self->jkind = PyMem_Calloc((size_t)n, sizeof(int32_t));
    self->ws = PyMem_Calloc((size_t)nw + 1, sizeof(vf_nd_workspace));
    if (self->mem == NULL || self->jkind == NULL || self->ws == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    m = self->mem;
    self->f.n = (int32_t)n;
    self->f.dh = m;
    self->f.tool = m + 5 * n;
    self->f.lower = m + 5 * n + 3;
    self->f.upper = self->f.lower + n;
    self->f.vmax = self->f.upper + n;
    self->f.jprm = self->f.vmax + n; /* n x 6 */
    if (read_doubles(dh, "dh", m, 5 * n) < 0 || read_doubles(tool, "tool", m + 5 * n, 3) < 0
        || read_doubles(lower, "lower", (double *)self->f.lower, n) < 0
        || read_doubles(upper, "upper", (double *)self->f.upper, n) < 0
        || read_doubles(vmax, "vmax", (double *)self->f.vmax, n) < 0
        || read_doubles(jprm, "jprm", (double *)self->f.jprm, VF_ND_PROFILE_PARAMS * n) < 0) {
        goto fail;
    }
    m = (double *)self->f.jprm + VF_ND_PROFILE_PARAMS * n; /* after 14 n + 3 doubles */
    if (amax == Py_None) {
        self->f.amax = NULL;
    } else {
        if (read_doubles(amax, "amax", m, n) < 0) {
            goto fail;
        }
        self->f.amax = m;
    }
    m += n;
    {
        double tmp[4096];
        if (read_doubles(jkind, "jkind", tmp, n) < 0) {
            goto fail;
        }
        for (j = 0; j < n; j++) {
            self->jkind[j] = (int32_t)tmp[j];
        }
    }
    self->f.jkind = self->jkind;
    for (w = 0; w < nw; w++) {
        PyObject *item = PySequence_Fast_GET_ITEM(fast, w);
        vf_nd_workspace *ws = self->ws + w;
        Py_ssize_t nf = PySequence_Size(PyTuple_GET_ITEM(item, 1));
        long pt = PyLong_AsLong(PyTuple_GET_ITEM(item, 2));
        long kind = PyLong_AsLong(PyTuple_GET_ITEM(item, 3));
        if (PyErr_Occurred()) {
            goto fail;
        }
        if (pt < -1 || pt > n) {
            PyErr_SetString(PyExc_ValueError, "workspaces: point out of range");
            goto fail;
        }
        if (read_doubles(PyTuple_GET_ITEM(item, 0), "N", m, 3 * nf) < 0
            || read_doubles(PyTuple_GET_ITEM(item, 1), "off", m + 3 * nf, nf) < 0
            || read_doubles(PyTuple_GET_ITEM(item, 4), "prm", ws->prm, VF_ND_PROFILE_PARAMS) < 0) {
            goto fail;
        }
        ws->N = m;
        ws->off = m + 3 * nf;
        ws->nf = (int32_t)nf;
        ws->point = (int32_t)pt;
        ws->kind = (int32_t)kind;
        m += 4 * nf;
    }
    self->f.nw = (int32_t)nw;
    self->f.ws = self->ws;
    memset(&self->f.cap, 0, sizeof(self->f.cap));
    if (caps != Py_None) {
        if (!PyObject_TypeCheck(caps, &CapsuleRowsType)) {
            PyErr_SetString(PyExc_TypeError, "caps: a CapsuleRows or None");
            goto fail;
        }
        if (((CapsuleRows *)caps)->cap.nl != n || ((CapsuleRows *)caps)->cap.ncols != n
            || ((CapsuleRows *)caps)->cap.nj != n) {
            PyErr_SetString(PyExc_ValueError, "caps: a chain of the same n links and joints");
            goto fail;
        }
        self->f.cap = ((CapsuleRows *)caps)->cap;
        Py_INCREF(caps);
        self->caps = caps;
    }
    self->rmax = vf_nd_filter_rows_max(&self->f);
    self->out = PyMem_Calloc(3 * ((size_t)n + 1) + 3 * (size_t)n + 3 + self->rmax * ((size_t)n + 2)
                                 + vf_nd_filter_doubles(&self->f),
                             sizeof(double));
    self->iout = PyMem_Calloc(3 * self->rmax + 1, sizeof(int32_t));
    if (self->out == NULL || self->iout == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    Py_DECREF(fast);
    return 0;
fail:
    Py_XDECREF(fast);
    PyMem_Free(self->mem);
    self->mem = NULL;
    return -1;
}

static PyObject *new_array(int nd, npy_intp *dims, int type, const void *src, size_t bytes)
{
    PyObject *o = PyArray_SimpleNew(nd, dims, type);
    if (o != NULL && bytes) {
        memcpy(PyArray_DATA((PyArrayObject *)o), src, bytes);
    }
    return o;
}

/* rows(q, u, previous | None, dt) -> (G (r, n), b, level (int32), tag_a, tag_b, dist) */
static PyObject *FilterRows_rows(FilterRows *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer q = {0}, u = {0}, pv = {0};
    PyObject *o[6] = {NULL, NULL, NULL, NULL, NULL, NULL}, *ret = NULL;
    const int32_t n = self->f.n;
    double dt, *P, *axes, *flange, *G, *b, *dist, *work;
    int32_t r, i, *level, *ta, *tb;
    npy_intp dims[2];
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "FilterRows not initialised");
        return NULL;
    }
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "expected 4 arguments (q, u, previous, dt), got %zd", nargs);
        return NULL;
    }
    dt = PyFloat_AsDouble(args[3]);
    if (dt == -1.0 && PyErr_Occurred()) {
        return NULL;
    }
    if (get_view(args[0], &q, 0, "d", "q") < 0 || get_view(args[1], &u, 0, "d", "u") < 0
        || (args[2] != Py_None && get_view(args[2], &pv, 0, "d", "previous") < 0)) {
        goto done;
    }
    if (q.len != 8 * (Py_ssize_t)n || u.len != 8 * (Py_ssize_t)n
        || (pv.obj != NULL && pv.len != 8 * (Py_ssize_t)n)) {
        PyErr_SetString(PyExc_ValueError, "q, u and previous must hold n floats");
        goto done;
    }
    P = self->out;
    axes = P + 3 * ((size_t)n + 1);
    flange = axes + 3 * (size_t)n;
    G = flange + 3;
    b = G + self->rmax * (size_t)n;
    dist = b + self->rmax;
    work = dist + self->rmax;
    level = self->iout;
    ta = level + self->rmax;
    tb = ta + self->rmax;
    r = vf_nd_filter_rows(&self->f, (const double *)q.buf, (const double *)u.buf,
                          pv.obj != NULL ? (const double *)pv.buf : NULL, dt > 0.0 ? dt : 0.0, P,
                          axes, flange, G, b, level, ta, tb, dist, work);
    dims[0] = r;
    dims[1] = n;
    o[0] = new_array(2, dims, NPY_DOUBLE, G, (size_t)r * n * sizeof(double));
    o[1] = new_array(1, dims, NPY_DOUBLE, b, (size_t)r * sizeof(double));
    o[2] = new_array(1, dims, NPY_INT32, level, (size_t)r * sizeof(int32_t));
    o[3] = new_array(1, dims, NPY_INT32, ta, (size_t)r * sizeof(int32_t));
    o[4] = new_array(1, dims, NPY_INT32, tb, (size_t)r * sizeof(int32_t));
    o[5] = new_array(1, dims, NPY_DOUBLE, dist, (size_t)r * sizeof(double));
    for (i = 0; i < 6; i++) {
        if (o[i] == NULL) {
            for (i = 0; i < 6; i++) {
                Py_XDECREF(o[i]);
            }
            goto done;
        }
    }
    ret = Py_BuildValue("(NNNNNN)", o[0], o[1], o[2], o[3], o[4], o[5]);
done:
    release(&q);
    release(&u);
    release(&pv);
    return ret;
}

/* kinematics(q) -> (P (n + 1, 3), axes (n, 3), flange (3,)): vf_nd_chain_kinematics */
static PyObject *FilterRows_kinematics(FilterRows *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer q = {0};
    PyObject *a = NULL, *x = NULL, *fl = NULL;
    const int32_t n = self->f.n;
    npy_intp dp[2] = {n + 1, 3}, da[2] = {n, 3}, df = 3;
    if (self->mem == NULL || nargs != 1) {
        PyErr_SetString(PyExc_TypeError, "kinematics(q) on an initialised FilterRows");
        return NULL;
    }
    if (get_view(args[0], &q, 0, "d", "q") < 0) {
        return NULL;
    }
    if (q.len != 8 * (Py_ssize_t)n) {
        PyErr_SetString(PyExc_ValueError, "q must hold n floats");
        release(&q);
        return NULL;
    }
    a = PyArray_SimpleNew(2, dp, NPY_DOUBLE);
    x = PyArray_SimpleNew(2, da, NPY_DOUBLE);
    fl = PyArray_SimpleNew(1, &df, NPY_DOUBLE);
    if (a == NULL || x == NULL || fl == NULL) {
        release(&q);
        Py_XDECREF(a);
        Py_XDECREF(x);
        Py_XDECREF(fl);
        return NULL;
    }
    vf_nd_chain_kinematics(n, self->f.dh, self->f.tool, (const double *)q.buf,
                           (double *)PyArray_DATA((PyArrayObject *)a),
                           (double *)PyArray_DATA((PyArrayObject *)x),
                           (double *)PyArray_DATA((PyArrayObject *)fl));
    release(&q);
    return Py_BuildValue("(NNN)", a, x, fl);
}

static PyMethodDef FilterRows_methods[] = {
    {"rows", (PyCFunction)(void (*)(void))FilterRows_rows, METH_FASTCALL,
     "rows(q, u, previous, dt) -> (G, b, level, tag_a, tag_b, dist): vf_nd_filter_rows."},
    {"kinematics", (PyCFunction)(void (*)(void))FilterRows_kinematics, METH_FASTCALL,
     "kinematics(q) -> (P, axes, flange): vf_nd_chain_kinematics."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject FilterRowsType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._nd.FilterRows",
    .tp_basicsize = sizeof(FilterRows),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The safety filter's rows on a DH chain (vf_nd_filter_rows).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)FilterRows_init,
    .tp_dealloc = (destructor)FilterRows_dealloc,
    .tp_methods = FilterRows_methods,
};

/* ------------------------------------------------------------------ configuration control */

typedef struct {
    PyObject_HEAD
    vf_cc_problem pb;
    double *mem;   /* C, rho, lrad, then the outputs and the scratch */
    int32_t *ints; /* links, active, then the scratch */
    vf_cc_out out;
    double *work;
    int32_t *iwork;
} ConfigControl;

static void ConfigControl_dealloc(ConfigControl *self)
{
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int ConfigControl_init(ConfigControl *self, PyObject *args, PyObject *kwds)
{
    PyObject *C, *rho, *lrad;
    int n, m, k, recheck, rounds;
    double w_e, w_z, lam, kz, h, max_speed;
    size_t nn, kk, total;
    static char *kwlist[] = {"C",   "rho", "lrad", "n",  "m", "k",         "w_e",     "w_z",
                             "lam", "kz",  "h",    "max_speed", "recheck", "rounds", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOiiiddddddpi", kwlist, &C, &rho, &lrad, &n,
                                     &m, &k, &w_e, &w_z, &lam, &kz, &h, &max_speed, &recheck,
                                     &rounds)) {
        return -1;
    }
    if (n < 1 || n > 4096 || (m != 2 && m != 3) || k < 0 || k > (1 << 16) || rounds < 0) {
        PyErr_SetString(PyExc_ValueError, "ConfigControl: bad sizes");
        return -1;
    }
    PyMem_Free(self->mem);
    PyMem_Free(self->ints);
    self->mem = NULL;
    self->ints = NULL;
    nn = (size_t)n;
    kk = (size_t)k;
    /* C, rho, lrad | q_dot, q_free, points, fractions, distances, normals, rows, d_dot, d_dot_free */
    total = 3 * kk + kk + nn + 2 * nn + 3 * kk + 2 * kk + 3 * kk + kk * nn + 2 * kk
            + vf_cc_doubles(n, m, k);
    self->mem = PyMem_Calloc(total + 1, sizeof(double));
    self->ints = PyMem_Calloc(2 * kk + vf_cc_ints(k) + 1, sizeof(int32_t));
    if (self->mem == NULL || self->ints == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    {
        double *cc = self->mem, *rh = cc + 3 * kk, *lr = rh + kk, *o = lr + nn;
        if (read_doubles(C, "C", cc, 3 * (Py_ssize_t)k) < 0
            || read_doubles(rho, "rho", rh, k) < 0 || read_doubles(lrad, "lrad", lr, n) < 0) {
            return -1;
        }
        self->pb.C = cc;
        self->pb.rho = rh;
        self->pb.lrad = lr;
        self->out.q_dot = o;
        self->out.q_free = o + nn;
        self->out.points = o + 2 * nn;
        self->out.fractions = self->out.points + 3 * kk;
        self->out.distances = self->out.fractions + kk;
        self->out.normals = self->out.distances + kk;
        self->out.rows = self->out.normals + 3 * kk;
        self->out.d_dot = self->out.rows + kk * nn;
        self->out.d_dot_free = self->out.d_dot + kk;
        self->work = self->out.d_dot_free + kk;
        self->out.links = self->ints;
        self->out.active = self->ints + kk;
        self->iwork = self->ints + 2 * kk;
    }
    self->pb.n = n;
    self->pb.m = m;
    self->pb.k = k;
    self->pb.w_e = w_e;
    self->pb.w_z = w_z;
    self->pb.lam = lam;
    self->pb.kz = kz;
    self->pb.h = h;
    self->pb.max_speed = max_speed;
    self->pb.recheck = recheck;
    self->pb.rounds = rounds;
    if (vf_cc_check(&self->pb) != VF_CC_OK) {
        PyErr_SetString(PyExc_ValueError, "ConfigControl: invalid parameters (vf_cc_check)");
        return -1;
    }
    return 0;
}

static PyObject *new_matrix(const double *x, npy_intp r, npy_intp c)
{
    npy_intp dims[2];
    PyObject *o;
    dims[0] = r;
    dims[1] = c;
    o = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (o != NULL && r * c > 0) {
        memcpy(PyArray_DATA((PyArrayObject *)o), x, (size_t)(r * c) * sizeof(double));
    }
    return o;
}

/* solve(P, axes, yr) -> (code, q_dot, q_free, points, links, fractions, distances, normals, rows,
 *                        d_dot, d_dot_free, active, condition, ee_rate_error, ee_rate_error_free) */
static PyObject *ConfigControl_solve(ConfigControl *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer P = {0}, A = {0}, y = {0};
    PyObject *ret = NULL, *links = NULL;
    npy_intp kdim;
    int code, i;
    const vf_cc_problem *pb = &self->pb;
    vf_cc_out *out = &self->out;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "ConfigControl not initialised");
        return NULL;
    }
    if (nargs != 3) {
        PyErr_Format(PyExc_TypeError, "expected 3 arguments (P, axes, yr), got %zd", nargs);
        return NULL;
    }
    if (get_view(args[0], &P, 0, "d", "P") < 0 || get_view(args[1], &A, 0, "d", "axes") < 0
        || get_view(args[2], &y, 0, "d", "yr") < 0) {
        goto done;
    }
    if (P.len != 8 * 3 * ((Py_ssize_t)pb->n + 1) || A.len != 8 * 3 * (Py_ssize_t)pb->n
        || y.len != 8 * (Py_ssize_t)pb->m) {
        PyErr_SetString(PyExc_ValueError, "P must be (n + 1, 3), axes (n, 3), yr (m,)");
        goto done;
    }
    code = vf_cc_solve(pb, (const double *)P.buf, (const double *)A.buf, (const double *)y.buf,
                       out, self->work, self->iwork);
    kdim = pb->k;
    links = PyArray_SimpleNew(1, &kdim, NPY_INT64);
    if (links == NULL) {
        goto done;
    }
    for (i = 0; i < pb->k; i++) {
        ((int64_t *)PyArray_DATA((PyArrayObject *)links))[i] = out->links[i];
    }
    ret = Py_BuildValue("(iNNNNNNNNNNNddd)", code, new_vector(out->q_dot, pb->n),
                        new_vector(out->q_free, pb->n), new_matrix(out->points, pb->k, 3), links,
                        new_vector(out->fractions, pb->k), new_vector(out->distances, pb->k),
                        new_matrix(out->normals, pb->k, 3), new_matrix(out->rows, pb->k, pb->n),
                        new_vector(out->d_dot, pb->k), new_vector(out->d_dot_free, pb->k),
                        int_list(out->active, out->n_active), out->condition,
                        out->ee_rate_error, out->ee_rate_error_free);
done:
    release(&P);
    release(&A);
    release(&y);
    return ret;
}

static PyMethodDef ConfigControl_methods[] = {
    {"solve", (PyCFunction)(void (*)(void))ConfigControl_solve, METH_FASTCALL,
     "solve(P, axes, yr) -> (code, q_dot, q_free, points, links, fractions, distances, normals, "
     "rows, d_dot, d_dot_free, active, condition, ee_rate_error, ee_rate_error_free): "
     "vf_cc_solve."},
    {NULL, NULL, 0, NULL},
};

static PyTypeObject ConfigControlType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._nd.ConfigControl",
    .tp_basicsize = sizeof(ConfigControl),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Configuration control of a serial arm among sphere obstacles (velfence_cc.h).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)ConfigControl_init,
    .tp_dealloc = (destructor)ConfigControl_dealloc,
    .tp_methods = ConfigControl_methods,
};

/* ------------------------------------------------------------------ resolved rate */

static const double *rr_vector(PyObject *obj, npy_intp n, const char *name)
{
    PyArrayObject *a = (PyArrayObject *)obj;
    if (!PyArray_CheckExact(obj) || PyArray_NDIM(a) != 1 || PyArray_TYPE(a) != NPY_DOUBLE
        || PyArray_DIM(a, 0) != n || !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a)) {
        PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous float64 ndarray (%zd,)", name,
                     (Py_ssize_t)n);
        return NULL;
    }
    return (const double *)PyArray_DATA(a);
}

static PyObject *nd_rr_sr_step(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    const double *prm, *q, *xd;
    vf_rr_arm arm;
    vf_rr_params par;
    vf_rr_out out;
    npy_intp dims = 6;
    PyObject *qd;
    int code;
    (void)mod;
    if (nargs != 3) {
        PyErr_Format(PyExc_TypeError, "expected 3 arguments (arm, q, xdot), got %zd", nargs);
        return NULL;
    }
    if ((prm = rr_vector(args[0], 37, "arm")) == NULL || (q = rr_vector(args[1], 6, "q")) == NULL
        || (xd = rr_vector(args[2], 6, "xdot")) == NULL) {
        return NULL;
    }
    memcpy(arm.dh, prm, 30 * sizeof(double));
    memcpy(arm.tool, prm + 30, 3 * sizeof(double));
    par.k0 = prm[33];
    par.w0 = prm[34];
    par.singular_tol = prm[35];
    par.max_speed = prm[36];
    code = vf_rr_sr_step(&arm, &par, q, xd, &out);
    if (code != VF_RR_OK) {
        return PyLong_FromLong(code);
    }
    qd = PyArray_SimpleNew(1, &dims, NPY_DOUBLE);
    if (qd == NULL) {
        return NULL;
    }
    memcpy(PyArray_DATA((PyArrayObject *)qd), out.q_dot, 6 * sizeof(double));
    return Py_BuildValue("(NdddOd)", qd, out.w, out.det, out.k,
                         out.singular ? Py_True : Py_False, out.scale);
}

static PyObject *nd_rr_jacobian(PyObject *mod, PyObject *const *args, Py_ssize_t nargs)
{
    const double *prm, *q;
    vf_rr_arm arm;
    npy_intp dims[2] = {6, 6};
    PyObject *J;
    int code;
    (void)mod;
    if (nargs != 2) {
        PyErr_Format(PyExc_TypeError, "expected 2 arguments (arm, q), got %zd", nargs);
        return NULL;
    }
    if ((prm = rr_vector(args[0], 37, "arm")) == NULL || (q = rr_vector(args[1], 6, "q")) == NULL) {
        return NULL;
    }
    memcpy(arm.dh, prm, 30 * sizeof(double));
    memcpy(arm.tool, prm + 30, 3 * sizeof(double));
    J = PyArray_SimpleNew(2, dims, NPY_DOUBLE);
    if (J == NULL) {
        return NULL;
    }
    code = vf_rr_jacobian(&arm, q, (double *)PyArray_DATA((PyArrayObject *)J));
    if (code != VF_RR_OK) {
        Py_DECREF(J);
        return PyLong_FromLong(code);
    }
    return J;
}

static PyMethodDef nd_methods[] = {
    {"rate_bounds", (PyCFunction)(void (*)(void))nd_rate_bounds, METH_FASTCALL,
     "rate_bounds(kind, prm, dist, speed, idt) -> bounds (k,): vf_nd_rate_bounds."},
    {"project", (PyCFunction)(void (*)(void))nd_project, METH_FASTCALL,
     "project(u, G, b) -> (status, x): vf_nd_project_kernel."},
    {"project_full", (PyCFunction)(void (*)(void))nd_project_full, METH_FASTCALL,
     "project_full(u, G, b) -> (status, q, iterations, x, active, multipliers)."},
    {"rr_sr_step", (PyCFunction)(void (*)(void))nd_rr_sr_step, METH_FASTCALL,
     "rr_sr_step(arm, q, xdot) -> (q_dot, w, det, k, singular, scale) or a VF_RR_ERR_* code."},
    {"rr_jacobian", (PyCFunction)(void (*)(void))nd_rr_jacobian, METH_FASTCALL,
     "rr_jacobian(arm, q) -> J (6, 6): vf_rr_jacobian, or a VF_RR_ERR_* code."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef nd_module = {
    PyModuleDef_HEAD_INIT, "_nd",
    "velfence's n-D projection and exact law compiled (velfence_nd.h).", -1, nd_methods,
};

PyMODINIT_FUNC PyInit__nd(void)
{
    PyObject *m;
    import_array();
    if (PyType_Ready(&PolytopeLawType) < 0 || PyType_Ready(&CapsuleRowsType) < 0
        || PyType_Ready(&ConfigControlType) < 0 || PyType_Ready(&FilterRowsType) < 0) {
        return NULL;
    }
    m = PyModule_Create(&nd_module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&PolytopeLawType);
    Py_INCREF(&CapsuleRowsType);
    Py_INCREF(&ConfigControlType);
    Py_INCREF(&FilterRowsType);
    if (PyModule_AddObject(m, "PolytopeLaw", (PyObject *)&PolytopeLawType) < 0
        || PyModule_AddObject(m, "CapsuleRows", (PyObject *)&CapsuleRowsType) < 0
        || PyModule_AddObject(m, "ConfigControl", (PyObject *)&ConfigControlType) < 0
        || PyModule_AddObject(m, "FilterRows", (PyObject *)&FilterRowsType) < 0
        || PyModule_AddStringConstant(m, "VERSION", VF_ND_VERSION) < 0) {
        Py_DECREF(&PolytopeLawType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
