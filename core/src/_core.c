/*
 * velfence_core._core -- CPython binding of the C core (C99 + the CPython C API, no NumPy headers).
 *
 * Two types hold a copy of one law's polygon and parameters plus its scratch:
 *   ExactLaw(nx, ny, off, cx, cy, n, kind, prm, relax, idt)                 (PolygonShaper._fast)
 *   PatentLaw(nx, ny, off, cx, cy, a0, beta, n, dmax, k, theta_max, idt)
 * with methods
 *   law(px, py, vx, vy)   -> the reference kernel's 10-tuple (unchecked, as the Python kernel)
 *   shape(px, py, vx, vy) -> (rc, 10-tuple) through the checked C API (vf_*_shape)
 *   shape_array(position, command) -> the shaped velocity as a new float64 array (2,), or None
 *                         when the fast path does not apply (not two float64 ndarrays of shape (2,),
 *                         non-finite input, overflowed output): the caller then runs its generic
 *                         path, which owns the on_invalid policy.
 *   batch(P, V, out, zones) -> the number of rows whose input or answer is not finite: the
 *                         unchecked kernel over rows (buffers: P, V float64 (N, 2) C-contiguous,
 *                         out float64 (N, 2) writable, zones int64 (N,) writable or None; a row
 *                         whose distances overflowed gets a NaN velocity); releases the GIL, its
 *                         scratch is per call.
 * and
 *   ShapeCall(fast, fallback) -> a callable: fast(position, command) (a law's shape_array, its C
 *                         function called directly), else fallback(position, command) (the
 *                         shaper's Python route); PolygonShaper / PolytopeShaper install it as
 *                         their instance attribute `shape` (no Python frame on the common path).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <math.h>
#include <string.h>

#include "velfence_core.h"

/* ------------------------------------------------------------------ helpers */

static int read_doubles(PyObject *seq, const char *name, double *dst, Py_ssize_t count)
{
    PyObject *fast = PySequence_Fast(seq, name);
    Py_ssize_t i;
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

static PyObject *result_tuple(const vf_result *r)
{
    return Py_BuildValue("(ddiiiddddi)", r->ox, r->oy, (int)r->zone, (int)r->primary,
                         (int)r->secondary, r->d1, r->d2, r->sx, r->sy, (int)r->stages);
}

static int four_doubles(PyObject *const *args, Py_ssize_t nargs, double *v)
{
    Py_ssize_t i;
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "expected 4 arguments (px, py, vx, vy), got %zd", nargs);
        return -1;
    }
    for (i = 0; i < 4; i++) {
        PyObject *o = args[i];
        if (PyFloat_CheckExact(o)) {
            v[i] = PyFloat_AS_DOUBLE(o);
        } else {
            v[i] = PyFloat_AsDouble(o);
            if (v[i] == -1.0 && PyErr_Occurred()) {
                return -1;
            }
        }
    }
    return 0;
}

/* Two float64 ndarrays of shape (2,) read into v[0..3]; 0 if they are not that. */
static int two_pairs(PyObject *const *args, Py_ssize_t nargs, double *v)
{
    int i;
    if (nargs != 2) {
        return 0;
    }
    for (i = 0; i < 2; i++) {
        PyArrayObject *a = (PyArrayObject *)args[i];
        if (!PyArray_CheckExact(args[i]) || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != 2
            || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a)) {
            return 0;
        }
        v[2 * i] = *(const double *)PyArray_GETPTR1(a, 0);
        v[2 * i + 1] = *(const double *)PyArray_GETPTR1(a, 1);
    }
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]) && isfinite(v[3]);
}

static PyObject *pair_array(double x, double y)
{
    npy_intp dim = 2;
    PyObject *o;
    double *d;
    if (!isfinite(x) || !isfinite(y)) {
        Py_RETURN_NONE;
    }
    o = PyArray_SimpleNew(1, &dim, NPY_DOUBLE);
    if (o == NULL) {
        return NULL;
    }
    d = (double *)PyArray_DATA((PyArrayObject *)o);
    d[0] = x;
    d[1] = y;
    return o;
}

typedef struct {
    Py_buffer P, V, out, zones;
    Py_ssize_t N;
} batch_views;

static void release_views(batch_views *b)
{
    if (b->P.obj) PyBuffer_Release(&b->P);
    if (b->V.obj) PyBuffer_Release(&b->V);
    if (b->out.obj) PyBuffer_Release(&b->out);
    if (b->zones.obj) PyBuffer_Release(&b->zones);
}

static int get_view(PyObject *o, Py_buffer *view, int writable, const char *fmt, Py_ssize_t isz,
                    const char *name)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, view, flags) < 0) {
        return -1;
    }
    if (view->itemsize != isz || view->format == NULL
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

static int batch_parse(PyObject *const *args, Py_ssize_t nargs, batch_views *b)
{
    memset(b, 0, sizeof(*b));
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "expected 4 arguments (P, V, out, zones), got %zd", nargs);
        return -1;
    }
    if (get_view(args[0], &b->P, 0, "d", 8, "P") < 0 || get_view(args[1], &b->V, 0, "d", 8, "V") < 0
        || get_view(args[2], &b->out, 1, "d", 8, "out") < 0
        || (args[3] != Py_None && get_view(args[3], &b->zones, 1, "q", 8, "zones") < 0)) {
        release_views(b);
        return -1;
    }
    /* zones may be None (shape_batch: no zone array allocated and thrown away) */
    b->N = args[3] != Py_None ? b->zones.len / 8 : b->out.len / 16;
    if (b->P.len != 16 * b->N || b->V.len != 16 * b->N || b->out.len != 16 * b->N) {
        PyErr_SetString(PyExc_ValueError, "P, V, out must be (N, 2) and zones (N,)");
        release_views(b);
        return -1;
    }
    return 0;
}

/* A batch row whose input or answer is not finite (the caller's generic path decides). */
static int row_bad(const double *P, const double *V, Py_ssize_t r, const vf_result *res)
{
    return !(isfinite(P[2 * r]) && isfinite(P[2 * r + 1]) && isfinite(V[2 * r])
             && isfinite(V[2 * r + 1]) && isfinite(res->ox) && isfinite(res->oy));
}

/* ------------------------------------------------------------------ ExactLaw */

typedef struct {
    PyObject_HEAD
    vf_polygon poly;
    vf_exact_law law;
    double *mem;        /* nx, ny, off, dist, bnd: 5 n doubles */
    int32_t *work;
    vf_scratch scratch; /* for law() / shape(), used under the GIL */
} ExactLaw;

static void ExactLaw_dealloc(ExactLaw *self)
{
    PyMem_Free(self->mem);
    PyMem_Free(self->work);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int ExactLaw_init(ExactLaw *self, PyObject *args, PyObject *kwds)
{
    PyObject *nx, *ny, *off, *prm;
    double cx, cy, idt;
    int n, kind, relax;
    static char *kwlist[] = {"nx", "ny", "off", "cx", "cy", "n", "kind", "prm", "relax", "idt",
                             NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOddiiOpd", kwlist, &nx, &ny, &off, &cx, &cy,
                                     &n, &kind, &prm, &relax, &idt)) {
        return -1;
    }
    if (n < 3) {
        PyErr_Format(PyExc_ValueError, "n: expected at least 3 edges, got %d", n);
        return -1;
    }
    PyMem_Free(self->mem);
    PyMem_Free(self->work);
    self->mem = PyMem_Calloc((size_t)n * 5, sizeof(double));
    self->work = PyMem_Calloc((size_t)n, sizeof(int32_t));
    if (self->mem == NULL || self->work == NULL) {
        PyErr_NoMemory();
        goto fail;
    }
    if (read_doubles(nx, "nx", self->mem, n) < 0 || read_doubles(ny, "ny", self->mem + n, n) < 0
        || read_doubles(off, "off", self->mem + 2 * n, n) < 0
        || read_doubles(prm, "prm", self->law.prm, VF_PROFILE_PARAMS) < 0) {
        goto fail;
    }
    self->poly.nx = self->mem;
    self->poly.ny = self->mem + n;
    self->poly.off = self->mem + 2 * n;
    self->poly.beta = NULL;
    self->poly.cx = cx;
    self->poly.cy = cy;
    self->poly.a0 = 0.0;
    self->poly.n = n;
    self->law.kind = kind;
    self->law.relax = relax;
    self->law.idt = idt;
    self->scratch.dist = self->mem + 3 * n;
    self->scratch.bnd = self->mem + 4 * n;
    self->scratch.work = self->work;
    if (vf_exact_check(&self->poly, &self->law) != VF_OK) {
        PyErr_SetString(PyExc_ValueError, "invalid polygon or exact-law data (vf_exact_check)");
        goto fail;
    }
    return 0;
fail: /* a half-built object must not be usable: the methods check mem */
    PyMem_Free(self->mem);
    PyMem_Free(self->work);
    self->mem = NULL;
    self->work = NULL;
    return -1;
}

static PyObject *ExactLaw_law(ExactLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "ExactLaw not initialised");
        return NULL;
    }
    if (four_doubles(args, nargs, v) < 0) {
        return NULL;
    }
    vf_exact_kernel(&self->poly, &self->law, v[0], v[1], v[2], v[3], &self->scratch, &r);
    return result_tuple(&r);
}

static PyObject *ExactLaw_shape(ExactLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    int rc;
    PyObject *t, *res;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "ExactLaw not initialised");
        return NULL;
    }
    if (four_doubles(args, nargs, v) < 0) {
        return NULL;
    }
    rc = vf_exact_shape(&self->poly, &self->law, v[0], v[1], v[2], v[3], &self->scratch, &r);
    t = result_tuple(&r);
    if (t == NULL) {
        return NULL;
    }
    res = Py_BuildValue("(iN)", rc, t);
    return res;
}

static PyObject *ExactLaw_shape_array(ExactLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    if (self->mem == NULL || !two_pairs(args, nargs, v)) {
        Py_RETURN_NONE;
    }
    vf_exact_kernel(&self->poly, &self->law, v[0], v[1], v[2], v[3], &self->scratch, &r);
    if (!isfinite(r.d1) || !isfinite(r.d2)) {
        Py_RETURN_NONE; /* overflowed distances: the generic path refuses the state */
    }
    return pair_array(r.ox, r.oy);
}

static PyObject *ExactLaw_batch(ExactLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    batch_views b;
    double *dist, *bnd;
    int32_t *work;
    vf_scratch s;
    Py_ssize_t r, bad = 0;
    const double *P, *V;
    double *out;
    int64_t *zones;
    int32_t n = self->poly.n;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "ExactLaw not initialised");
        return NULL;
    }
    if (batch_parse(args, nargs, &b) < 0) {
        return NULL;
    }
    dist = PyMem_RawMalloc(sizeof(double) * 2 * (size_t)n);
    work = PyMem_RawMalloc(sizeof(int32_t) * (size_t)n);
    if (dist == NULL || work == NULL) {
        PyMem_RawFree(dist);
        PyMem_RawFree(work);
        release_views(&b);
        return PyErr_NoMemory();
    }
    bnd = dist + n;
    s.dist = dist;
    s.bnd = bnd;
    s.work = work;
    P = b.P.buf;
    V = b.V.buf;
    out = b.out.buf;
    zones = b.zones.obj ? b.zones.buf : NULL;
    Py_BEGIN_ALLOW_THREADS
    for (r = 0; r < b.N; r++) {
        vf_result res;
        vf_exact_kernel(&self->poly, &self->law, P[2 * r], P[2 * r + 1], V[2 * r], V[2 * r + 1],
                        &s, &res);
        if (!isfinite(res.d1) || !isfinite(res.d2)) {
            res.ox = NAN; /* overflowed distances: flagged like an overflowed velocity */
            res.oy = NAN;
        }
        out[2 * r] = res.ox;
        out[2 * r + 1] = res.oy;
        if (zones != NULL) {
            zones[r] = res.zone;
        }
        bad += row_bad(P, V, r, &res);
    }
    Py_END_ALLOW_THREADS
    PyMem_RawFree(dist);
    PyMem_RawFree(work);
    release_views(&b);
    return PyLong_FromSsize_t(bad);
}

static PyMethodDef ExactLaw_methods[] = {
    {"law", (PyCFunction)(void (*)(void))ExactLaw_law, METH_FASTCALL,
     "law(px, py, vx, vy) -> the reference kernel's 10-tuple (unchecked)."},
    {"shape", (PyCFunction)(void (*)(void))ExactLaw_shape, METH_FASTCALL,
     "shape(px, py, vx, vy) -> (rc, 10-tuple) through the checked C API."},
    {"shape_array", (PyCFunction)(void (*)(void))ExactLaw_shape_array, METH_FASTCALL,
     "shape_array(position, command) -> new float64 (2,) array, or None (use the generic path)."},
    {"batch", (PyCFunction)(void (*)(void))ExactLaw_batch, METH_FASTCALL,
     "batch(P, V, out, zones) -> the number of rows not finite in or out: the unchecked kernel "
     "over rows."},
    {NULL, NULL, 0, NULL}};

static PyTypeObject ExactLawType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._core.ExactLaw",
    .tp_basicsize = sizeof(ExactLaw),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The 2-D exact law on one polygon (vf_exact_*).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)ExactLaw_init,
    .tp_dealloc = (destructor)ExactLaw_dealloc,
    .tp_methods = ExactLaw_methods,
};

/* ------------------------------------------------------------------ PatentLaw */

typedef struct {
    PyObject_HEAD
    vf_polygon poly;
    vf_patent_law law;
    double *mem; /* nx, ny, off (n each), beta (n + 1) */
} PatentLaw;

static void PatentLaw_dealloc(PatentLaw *self)
{
    PyMem_Free(self->mem);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int PatentLaw_init(PatentLaw *self, PyObject *args, PyObject *kwds)
{
    PyObject *nx, *ny, *off, *beta;
    double cx, cy, a0, dmax, k, theta_max, idt;
    int n;
    static char *kwlist[] = {"nx", "ny", "off", "cx", "cy", "a0", "beta", "n",
                             "dmax", "k", "theta_max", "idt", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOdddOidddd", kwlist, &nx, &ny, &off, &cx,
                                     &cy, &a0, &beta, &n, &dmax, &k, &theta_max, &idt)) {
        return -1;
    }
    if (n < 3) {
        PyErr_Format(PyExc_ValueError, "n: expected at least 3 edges, got %d", n);
        return -1;
    }
    PyMem_Free(self->mem);
    self->mem = PyMem_Calloc((size_t)n * 4 + 1, sizeof(double));
    if (self->mem == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    if (read_doubles(nx, "nx", self->mem, n) < 0 || read_doubles(ny, "ny", self->mem + n, n) < 0
        || read_doubles(off, "off", self->mem + 2 * n, n) < 0
        || read_doubles(beta, "beta", self->mem + 3 * n, n + 1) < 0) {
        goto fail;
    }
    self->poly.nx = self->mem;
    self->poly.ny = self->mem + n;
    self->poly.off = self->mem + 2 * n;
    self->poly.beta = self->mem + 3 * n;
    self->poly.cx = cx;
    self->poly.cy = cy;
    self->poly.a0 = a0;
    self->poly.n = n;
    self->law.dmax = dmax;
    self->law.k = k;
    self->law.theta_max = theta_max;
    self->law.idt = idt;
    if (vf_patent_check(&self->poly, &self->law) != VF_OK) {
        PyErr_SetString(PyExc_ValueError, "invalid polygon or patent-law data (vf_patent_check)");
        goto fail;
    }
    return 0;
fail: /* a half-built object must not be usable: the methods check mem */
    PyMem_Free(self->mem);
    self->mem = NULL;
    return -1;
}

static PyObject *PatentLaw_law(PatentLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PatentLaw not initialised");
        return NULL;
    }
    if (four_doubles(args, nargs, v) < 0) {
        return NULL;
    }
    vf_patent_kernel(&self->poly, &self->law, v[0], v[1], v[2], v[3], &r);
    return result_tuple(&r);
}

static PyObject *PatentLaw_shape(PatentLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    int rc;
    PyObject *t;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PatentLaw not initialised");
        return NULL;
    }
    if (four_doubles(args, nargs, v) < 0) {
        return NULL;
    }
    rc = vf_patent_shape(&self->poly, &self->law, v[0], v[1], v[2], v[3], &r);
    t = result_tuple(&r);
    if (t == NULL) {
        return NULL;
    }
    return Py_BuildValue("(iN)", rc, t);
}

static PyObject *PatentLaw_shape_array(PatentLaw *self, PyObject *const *args,
                                       Py_ssize_t nargs)
{
    double v[4];
    vf_result r;
    if (self->mem == NULL || !two_pairs(args, nargs, v)) {
        Py_RETURN_NONE;
    }
    vf_patent_kernel(&self->poly, &self->law, v[0], v[1], v[2], v[3], &r);
    if (!isfinite(r.d1) || !isfinite(r.d2) || !isfinite(r.sx) || !isfinite(r.sy)) {
        Py_RETURN_NONE;
    }
    return pair_array(r.ox, r.oy);
}

static PyObject *PatentLaw_batch(PatentLaw *self, PyObject *const *args, Py_ssize_t nargs)
{
    batch_views b;
    Py_ssize_t r, bad = 0;
    const double *P, *V;
    double *out;
    int64_t *zones;
    if (self->mem == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "PatentLaw not initialised");
        return NULL;
    }
    if (batch_parse(args, nargs, &b) < 0) {
        return NULL;
    }
    P = b.P.buf;
    V = b.V.buf;
    out = b.out.buf;
    zones = b.zones.obj ? b.zones.buf : NULL;
    Py_BEGIN_ALLOW_THREADS
    for (r = 0; r < b.N; r++) {
        vf_result res;
        vf_patent_kernel(&self->poly, &self->law, P[2 * r], P[2 * r + 1], V[2 * r], V[2 * r + 1],
                         &res);
        if (!isfinite(res.d1) || !isfinite(res.d2)) {
            res.ox = NAN;
            res.oy = NAN;
        }
        out[2 * r] = res.ox;
        out[2 * r + 1] = res.oy;
        if (zones != NULL) {
            zones[r] = res.zone;
        }
        bad += row_bad(P, V, r, &res);
    }
    Py_END_ALLOW_THREADS
    release_views(&b);
    return PyLong_FromSsize_t(bad);
}

static PyMethodDef PatentLaw_methods[] = {
    {"law", (PyCFunction)(void (*)(void))PatentLaw_law, METH_FASTCALL,
     "law(px, py, vx, vy) -> the reference kernel's 10-tuple (unchecked)."},
    {"shape", (PyCFunction)(void (*)(void))PatentLaw_shape, METH_FASTCALL,
     "shape(px, py, vx, vy) -> (rc, 10-tuple) through the checked C API."},
    {"shape_array", (PyCFunction)(void (*)(void))PatentLaw_shape_array, METH_FASTCALL,
     "shape_array(position, command) -> new float64 (2,) array, or None (use the generic path)."},
    {"batch", (PyCFunction)(void (*)(void))PatentLaw_batch, METH_FASTCALL,
     "batch(P, V, out, zones) -> the number of rows not finite in or out: the unchecked kernel "
     "over rows."},
    {NULL, NULL, 0, NULL}};

static PyTypeObject PatentLawType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._core.PatentLaw",
    .tp_basicsize = sizeof(PatentLaw),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "US 8,676,382's edge-scaling law on one polygon (vf_patent_*).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)PatentLaw_init,
    .tp_dealloc = (destructor)PatentLaw_dealloc,
    .tp_methods = PatentLaw_methods,
};

/* ------------------------------------------------------------------ ShapeCall */

/*
 * ShapeCall(fast, fallback): a shaper's `shape` with no Python frame on the common path.
 *
 * `fast` is a bound METH_FASTCALL method of a law object (ExactLaw.shape_array,
 * PatentLaw.shape_array, velfence_core._nd.PolytopeLaw.shape_array) that answers None when its
 * fast path does not apply; `fallback` is the shaper's Python route (any callable taking
 * (position, command)). A call with two positional arguments runs `fast`'s C function directly
 * (no bound-method dispatch, no Python frame); None from it, or any other call (keywords, another
 * number of arguments), goes to `fallback` with the arguments unchanged, so every message, the
 * on_invalid policy and every refusal are the Python route's own. The shaper installs it as its
 * instance attribute `shape` (velfence.shaping.polygon / polytope).
 */
typedef struct {
    PyObject_HEAD
    PyObject *fast;     /* the bound builtin method (kept alive: it owns fself) */
    PyObject *fself;    /* its __self__ (borrowed from fast) */
    _PyCFunctionFast fn;
    PyObject *fallback;
    vectorcallfunc vectorcall;
} ShapeCall;

static PyObject *ShapeCall_vectorcall(PyObject *callable, PyObject *const *args, size_t nargsf,
                                      PyObject *kwnames)
{
    ShapeCall *self = (ShapeCall *)callable;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    if (kwnames == NULL && nargs == 2) {
        PyObject *r = self->fn(self->fself, args, nargs);
        if (r != Py_None) {
            return r; /* the shaped velocity, or NULL with an exception set (out of memory) */
        }
        Py_DECREF(r);
    }
    if (self->fallback == NULL) { /* cleared by the garbage collector (unreachable) */
        PyErr_SetString(PyExc_RuntimeError, "ShapeCall: its shaper is gone");
        return NULL;
    }
    return PyObject_Vectorcall(self->fallback, args, nargsf, kwnames);
}

static PyObject *ShapeCall_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PyObject *fast, *fallback;
    ShapeCall *self;
    static char *kwlist[] = {"fast", "fallback", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OO:ShapeCall", kwlist, &fast, &fallback)) {
        return NULL;
    }
    if (!PyCFunction_Check(fast) || PyCFunction_GET_SELF(fast) == NULL
        || PyCFunction_GET_FLAGS(fast) != METH_FASTCALL) {
        PyErr_SetString(PyExc_TypeError,
                        "fast: expected a bound METH_FASTCALL builtin method (a law's shape_array)");
        return NULL;
    }
    if (!PyCallable_Check(fallback)) {
        PyErr_SetString(PyExc_TypeError, "fallback: expected a callable (position, command)");
        return NULL;
    }
    self = (ShapeCall *)type->tp_alloc(type, 0);
    if (self == NULL) {
        return NULL;
    }
    Py_INCREF(fast);
    Py_INCREF(fallback);
    self->fast = fast;
    self->fself = PyCFunction_GET_SELF(fast);
    self->fn = (_PyCFunctionFast)(void (*)(void))PyCFunction_GET_FUNCTION(fast);
    self->fallback = fallback;
    self->vectorcall = ShapeCall_vectorcall;
    return (PyObject *)self;
}

static int ShapeCall_traverse(ShapeCall *self, visitproc visit, void *arg)
{
    Py_VISIT(self->fast);
    Py_VISIT(self->fallback);
    return 0;
}

static int ShapeCall_clear(ShapeCall *self)
{
    /* the fallback (the shaper's bound method) closes the cycle shaper -> shape -> shaper */
    Py_CLEAR(self->fallback);
    return 0;
}

static void ShapeCall_dealloc(ShapeCall *self)
{
    PyObject_GC_UnTrack(self);
    Py_CLEAR(self->fallback);
    Py_CLEAR(self->fast);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyObject *ShapeCall_get_wrapped(ShapeCall *self, void *closure)
{
    (void)closure;
    if (self->fallback == NULL) {
        Py_RETURN_NONE;
    }
    Py_INCREF(self->fallback);
    return self->fallback;
}

static PyObject *ShapeCall_get_doc(ShapeCall *self, void *closure)
{
    (void)closure;
    if (self->fallback == NULL) {
        Py_RETURN_NONE;
    }
    return PyObject_GetAttrString(self->fallback, "__doc__");
}

static PyObject *ShapeCall_get_fast(ShapeCall *self, void *closure)
{
    (void)closure;
    Py_INCREF(self->fast);
    return self->fast;
}

static PyObject *ShapeCall_repr(ShapeCall *self)
{
    if (self->fallback == NULL) {
        return PyUnicode_FromString("<ShapeCall (cleared)>");
    }
    return PyUnicode_FromFormat("<ShapeCall: %R in C, else %R>", self->fast, self->fallback);
}

static PyGetSetDef ShapeCall_getset[] = {
    {"__wrapped__", (getter)ShapeCall_get_wrapped, NULL,
     "The Python route (its signature is the call's: inspect.signature follows it).", NULL},
    {"__doc__", (getter)ShapeCall_get_doc, NULL, "The Python route's docstring.", NULL},
    {"fast", (getter)ShapeCall_get_fast, NULL, "The law's fast-path method.", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyTypeObject ShapeCallType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "velfence_core._core.ShapeCall",
    .tp_basicsize = sizeof(ShapeCall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_new = ShapeCall_new,
    .tp_dealloc = (destructor)ShapeCall_dealloc,
    .tp_traverse = (traverseproc)ShapeCall_traverse,
    .tp_clear = (inquiry)ShapeCall_clear,
    .tp_call = PyVectorcall_Call,
    .tp_vectorcall_offset = offsetof(ShapeCall, vectorcall),
    .tp_repr = (reprfunc)ShapeCall_repr,
    .tp_getset = ShapeCall_getset,
};

/* ------------------------------------------------------------------ module */

static struct PyModuleDef core_module = {
    PyModuleDef_HEAD_INIT, "_core",
    "velfence's 2-D shaping laws in C99 (see core/include/velfence_core.h).", -1, NULL,
    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__core(void)
{
    PyObject *m;
    import_array();
    if (PyType_Ready(&ExactLawType) < 0 || PyType_Ready(&PatentLawType) < 0
        || PyType_Ready(&ShapeCallType) < 0) {
        return NULL;
    }
    m = PyModule_Create(&core_module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&ExactLawType);
    Py_INCREF(&PatentLawType);
    Py_INCREF(&ShapeCallType);
    if (PyModule_AddObject(m, "ExactLaw", (PyObject *)&ExactLawType) < 0
        || PyModule_AddObject(m, "PatentLaw", (PyObject *)&PatentLawType) < 0
        || PyModule_AddObject(m, "ShapeCall", (PyObject *)&ShapeCallType) < 0
        || PyModule_AddStringConstant(m, "VERSION", VF_CORE_VERSION) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
