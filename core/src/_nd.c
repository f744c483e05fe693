/*
 * velfence_core._nd -- CPython binding of the n-D projection and exact law (velfence_nd.h).
 *
 *   project(u, G, b) -> (status, x)          vf_nd_project_kernel on float64 buffers u (n,),
 *                                             G (m, n) C-contiguous, b (m,); x a new array (n,).
 *   project_full(u, G, b) -> (status, q, iters, x, act, lam)   the same with the active set.
 *   PolytopeLaw(N, off, cen, nf, dim, kind, prm, relax, idt)   (PolytopeShaper's kernel data)
 *     law(p, v)         -> (out, res, active, dist, bnd, work): polytope_kernel's outputs
 *                          (out a new float64 array (dim,), res the 8-tuple, the rest lists)
 *     shape_array(p, v) -> the shaped velocity as a new array (dim,), or None when p, v are not
 *                          float64 ndarrays of shape (dim,), not finite, or the output overflowed
 *                          (the caller's generic path then owns the on_invalid policy).
 *     batch(P, V, out, zones) -> None: the unchecked kernel over rows (P, V float64 (N, dim)
 *                          C-contiguous, out float64 (N, dim), zones int64 (N,)); releases the GIL.
 * The kernels are the unchecked ones: Python keeps its own checks and policies, as with _core.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <string.h>

#include "velfence_nd.h"

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
    int nf, dim, kind, relax;
    size_t f, d, nd, ni;
    static char *kwlist[] = {"N", "off", "cen", "nf", "dim", "kind", "prm", "relax", "idt", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOiiiOpd", kwlist, &N, &off, &cen, &nf, &dim,
                                     &kind, &prm, &relax, &idt)) {
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
            if (!isfinite(dst[k])) {
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

static PyObject *PolytopeLaw_batch(PolytopeLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer P = {0}, V = {0}, out = {0}, zones = {0};
    Py_ssize_t rows, r;
    int32_t dim = self->poly.dim;
    double *dbl = NULL;
    int32_t *ints = NULL;
    PyObject *ret = NULL;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PolytopeLaw not initialised");
        return NULL;
    }
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "expected 4 arguments (P, V, out, zones), got %zd", nargs);
        return NULL;
    }
    if (get_view(args[0], &P, 0, "d", "P") < 0 || get_view(args[1], &V, 0, "d", "V") < 0
        || get_view(args[2], &out, 1, "d", "out") < 0
        || get_view(args[3], &zones, 1, "q", "zones") < 0) {
        goto done;
    }
    rows = zones.len / 8;
    if (P.len != 8 * rows * dim || V.len != 8 * rows * dim || out.len != 8 * rows * dim) {
        PyErr_SetString(PyExc_ValueError, "P, V, out must be (N, dim) and zones (N,)");
        goto done;
    }
    dbl = PyMem_Malloc(vf_nd_law_doubles(self->poly.nf, dim) * sizeof(double));
    ints = PyMem_Malloc((vf_nd_law_ints(self->poly.nf, dim) + (size_t)dim + 1) * sizeof(int32_t));
    if (dbl == NULL || ints == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        vf_nd_scratch s;
        vf_nd_result res;
        int32_t *active = ints + vf_nd_law_ints(self->poly.nf, dim);
        s.dbl = dbl;
        s.ints = ints;
        for (r = 0; r < rows; r++) {
            size_t o = (size_t)r * (size_t)dim;
            vf_nd_kernel(&self->poly, &self->law, (const double *)P.buf + o,
                         (const double *)V.buf + o, (double *)out.buf + o, active, &s, &res);
            ((int64_t *)zones.buf)[r] = res.zone;
        }
    }
    Py_END_ALLOW_THREADS
    ret = Py_None;
    Py_INCREF(ret);
done:
    release(&P);
    release(&V);
    release(&out);
    release(&zones);
    PyMem_Free(dbl);
    PyMem_Free(ints);
    return ret;
}

static PyMethodDef PolytopeLaw_methods[] = {
    {"law", (PyCFunction)(void (*)(void))PolytopeLaw_law, METH_FASTCALL,
     "law(p, v) -> (out, res, active, dist, bnd, work): polytope_kernel's outputs."},
    {"shape_array", (PyCFunction)(void (*)(void))PolytopeLaw_shape_array, METH_FASTCALL,
     "shape_array(p, v) -> the shaped velocity (dim,), or None (not the fast path)."},
    {"batch", (PyCFunction)(void (*)(void))PolytopeLaw_batch, METH_FASTCALL,
     "batch(P, V, out, zones) -> None: the kernel over rows."},
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

static PyMethodDef nd_methods[] = {
    {"project", (PyCFunction)(void (*)(void))nd_project, METH_FASTCALL,
     "project(u, G, b) -> (status, x): vf_nd_project_kernel."},
    {"project_full", (PyCFunction)(void (*)(void))nd_project_full, METH_FASTCALL,
     "project_full(u, G, b) -> (status, q, iterations, x, active, multipliers)."},
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
    if (PyType_Ready(&PolytopeLawType) < 0) {
        return NULL;
    }
    m = PyModule_Create(&nd_module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&PolytopeLawType);
    if (PyModule_AddObject(m, "PolytopeLaw", (PyObject *)&PolytopeLawType) < 0
        || PyModule_AddStringConstant(m, "VERSION", VF_ND_VERSION) < 0) {
        Py_DECREF(&PolytopeLawType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
