r"""Euclidean projection onto a polyhedron: the one solve behind every n-D minimum-change law.

.. math::
    x^\star = \arg\min_x \tfrac12 \|x - u\|^2 \quad\text{s.t.}\quad g_i\cdot x \ge b_i,
    \; i = 0, \dots, m-1

is solved exactly by a finite **dual active-set method** (Goldfarb and Idnani, "A numerically
stable dual method for solving strictly convex quadratic programs", Math. Programming 27, 1983),
specialised to the identity Hessian: start at the unconstrained optimum :math:`u`, add the most
violated constraint, move along the part of its normal orthogonal to the active normals while the
multipliers stay non-negative, drop a constraint whose multiplier would turn negative, and repeat.
Every iterate is optimal for the constraints added so far, so the objective grows monotonically and
no active set repeats: the method ends after finitely many steps with the optimum, or with a proof
of infeasibility (a violated constraint whose normal is a non-negative combination of active normals
that no step can satisfy). The active normals are kept as an orthonormal basis ``Q`` with a
triangular ``R`` (``N_A = Q R``, Gram-Schmidt twice for orthogonality to round-off); a new
constraint whose normal lies in their span is never added, so ``R`` stays invertible.

The answer then meets every bound *as evaluated in floating point* (a repair step moves it along
each bound that round-off left violated by a few ulps), which is what a safety filter has to
promise. Derivation and tests: ``docs/derivations.md`` §7.

:func:`project_kernel` is the plain-arithmetic kernel (loops over scalars and caller-provided
scratch, no allocation): it runs as ordinary Python and is compiled unchanged by numba for the
shapers' fast paths. :func:`project` is the validated public wrapper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import module_getattr
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import real_array
from velfence.errors import InvalidInput

__all__ = [
    "PROJECT_DEADLINE",
    "PROJECT_INFEASIBLE",
    "PROJECT_ITERATION_CAP",
    "PROJECT_OPTIMAL",
    "PROJECT_STALLED",
    "Projection",
    "default_iteration_cap",
    "project",
    "project_kernel",
    "project_kernel_opts",
    "projection_scratch",
    "scratch_length",
]

PROJECT_OPTIMAL = 0
PROJECT_INFEASIBLE = 1
#: Round-off stalled the method (C: VF_STALLED). Called PROJECT_ITERATION_LIMIT before 0.2, a
#: name too close to PROJECT_ITERATION_CAP; that name warns until 0.3.
PROJECT_STALLED = 2
PROJECT_ITERATION_CAP = 3  # the caller's iteration cap was reached (C: VF_ITERATION_CAP)
PROJECT_DEADLINE = 4  # the caller's deadline passed (C only: VF_DEADLINE)

_DEP_TOL = 1e-13  # |z| below this (relative to |g_p|): g_p lies in the span of the active normals
_VIOL_TOL = 1e-13  # violations below this (relative) end the dual iteration; repaired afterwards
_REPAIR_ULPS = 8.0 * 2.220446049250313e-16
_ROUND_OFF = 1e-12  # accepted residual violation (relative) when repairs cannot settle
_NO_WARM = np.zeros(1, dtype=np.int64)


def default_iteration_cap(m: int, n: int) -> int:
    """The iteration cap used when the caller gives none: ``4 (m + n) + 16`` inner iterations.

    Every inner iteration adds or drops one constraint and the method never repeats an active
    set, so a cap linear in the row count bounds the work of a solve (``O(cap · (m n + n³))``)
    without cutting off the solves seen in practice (docs/derivations.md §7).
    """
    return 4 * (m + n) + 16


def scratch_length(m: int, n: int) -> int:
    """Length of the float scratch :func:`project_kernel` needs for ``m`` rows in ``n``-D."""
    return 2 * n * n + 4 * n + m + 2


def projection_scratch(m: int, n: int) -> tuple[FloatArray, FloatArray, Any]:
    """Scratch for :func:`project_kernel`: floats ``(2 n² + 4 n + m + 2,)``, multipliers, ints.

    Returns:
        ``(wsf, lam, act)``: float scratch, multipliers (length ``n + 1``) and active indices
        (length ``n + 1``, int64).
    """
    return (
        np.zeros(scratch_length(m, n)),
        np.zeros(n + 1),
        np.zeros(n + 1, dtype=np.int64),
    )


def _rebuild(G: Any, act: Any, q: int, n: int, wsf: Any, oq: int, orr: int) -> int:
    """Gram-Schmidt (twice) of the active normals into Q (n x q) and R (q x q); returns the rank."""
    for c in range(q):
        g = act[c]
        for i in range(n):
            wsf[oq + i * n + c] = G[g * n + i]
        for r in range(c + 1):
            wsf[orr + r * n + c] = 0.0
        for _ in range(2):
            for r in range(c):
                h = 0.0
                for i in range(n):
                    h += wsf[oq + i * n + r] * wsf[oq + i * n + c]
                wsf[orr + r * n + c] += h
                for i in range(n):
                    wsf[oq + i * n + c] -= h * wsf[oq + i * n + r]
        rho = 0.0
        for i in range(n):
            rho += wsf[oq + i * n + c] * wsf[oq + i * n + c]
        rho = math.sqrt(rho)
        wsf[orr + c * n + c] = rho
        if rho > 0.0:
            for i in range(n):
                wsf[oq + i * n + c] /= rho
    return q


def _is_active(act: Any, q: int, i: int) -> bool:
    """Whether row ``i`` is among the ``q`` active rows (a loop: numba compiles no generators)."""
    for c in range(q):  # noqa: SIM110
        if act[c] == i:
            return True
    return False


def _consider(
    G: Any,
    b: Any,
    i: int,
    x: Any,
    n: int,
    wsf: Any,
    ogn: int,
    scale: float,
    act: Any,
    q: int,
    p: int,
    worst: float,
) -> tuple[int, float]:
    """Row ``i`` as the next row to add: ``(p, worst)``, updated when it is the most violated yet.

    Violation is relative to the normal's length; active rows are skipped. The tolerance is
    relative to the bound and to the current iterate (not to u): bounds far smaller than the
    target must still be met to their own precision. A negative stored norm marks a row accepted
    as met to round-off.
    """
    gn = wsf[ogn + i]
    if gn < 0.0:
        return p, worst
    s = _slack(G, b, i, x, n)
    tol = _VIOL_TOL * (abs(b[i]) + gn * (scale + 1e-300) + 1e-300)
    if s < -tol:
        v = s / gn if gn > 0.0 else -math.inf
        # the active set is looked up only for a row that would be picked
        if (p < 0 or v < worst) and not _is_active(act, q, i):
            return i, v
    return p, worst


def _row_norm(G: Any, i: int, n: int) -> float:
    s = 0.0
    for k in range(n):
        s += G[i * n + k] * G[i * n + k]
    return math.sqrt(s)


def _slack(G: Any, b: Any, i: int, x: Any, n: int) -> float:
    s = 0.0
    for k in range(n):
        s += G[i * n + k] * x[k]
    r: float = s - b[i]
    return r


def project_kernel(
    u: Any, G: Any, b: Any, m: int, n: int, x: Any, lam: Any, act: Any, wsf: Any
) -> tuple[int, int, int]:
    """:func:`project_kernel_opts` with the default iteration cap and no warm start."""
    return project_kernel_opts(u, G, b, m, n, x, lam, act, wsf, 0, act, 0)


def project_kernel_opts(
    u: Any,
    G: Any,
    b: Any,
    m: int,
    n: int,
    x: Any,
    lam: Any,
    act: Any,
    wsf: Any,
    cap: int,
    warm: Any,
    n_warm: int,
) -> tuple[int, int, int]:
    r"""Minimise :math:`\|x - u\|^2` s.t. ``G[i] · x >= b[i]`` for ``i < m`` (module docstring).

    Args:
        u: Target, (n,).
        G: Constraint normals, flat row-major (``G[i * n + k]``, length >= m·n): rows need not
            be unit; a zero row is met when ``b <= 0`` and makes the problem infeasible otherwise.
        b: Lower bounds, (>= m,); ``-inf`` rows are ignored.
        m: Number of constraints.
        n: Dimension.
        x: Output, (n,).
        lam: Output multipliers of the active constraints, (n + 1,).
        act: Output active constraint indices, (n + 1,), int.
        wsf: Float scratch from :func:`projection_scratch`.
        cap: Iteration cap: inner iterations allowed; ``<= 0`` for
            :func:`default_iteration_cap` (then reaching it means round-off stalled the method).
        warm: Row indices tried first when the next violated row is picked (e.g. the previous
            cycle's active rows), int array; only ``warm[:n_warm]`` is read.
        n_warm: Number of warm-start rows (0: none).

    Returns:
        ``(status, q, iterations)``: ``PROJECT_OPTIMAL`` (``x`` is the projection, its ``q``
        active constraints in ``act[:q]`` with multipliers ``lam[:q]`` >= 0, every bound met as
        evaluated, or to the round-off of forming ``x`` from ``u``,
        ``1e-12 (|b_i| + |g_i| (|x|_inf + |u|_inf))``, where several bounds through one point
        make exact satisfaction impossible), ``PROJECT_INFEASIBLE`` (the bounds have no common
        point; ``x`` finite, the last iterate), ``PROJECT_STALLED`` (round-off stalled the
        method at the default cap; ``x`` finite) or ``PROJECT_ITERATION_CAP`` (the caller's
        ``cap`` was reached; ``x`` finite, **not** feasible: the caller needs a safe fallback).
    """
    oq = 0  # Q, n x n, row-major with stride n
    orr = n * n  # R, n x n, upper triangular, stride n
    oz = 2 * n * n  # z (n)
    oh = oz + n  # Q^T g_p (n)
    orv = oh + n  # r = R^-1 Q^T g_p (n)
    ogn = orv + n  # |g_i| (m)
    for k in range(n):
        x[k] = u[k]
    for i in range(m):
        wsf[ogn + i] = _row_norm(G, i, n)
    q = 0
    iters = 0
    limit = cap if cap > 0 else 4 * (m + n) + 16
    over = PROJECT_ITERATION_CAP if cap > 0 else PROJECT_STALLED
    ubig = 0.0
    for k in range(n):
        if abs(u[k]) > ubig:
            ubig = abs(u[k])
    while True:
        # Most violated constraint (relative to its normal's length), not active. The tolerance
        # is relative to the bound and to the current iterate (not to u): bounds far smaller
        # than the target must still be met to their own precision.
        scale = 0.0
        for k in range(n):
            if abs(x[k]) > scale:
                scale = abs(x[k])
        p = -1
        worst = 0.0
        # Warm start: a violated row of the previous active set first (any violated row may
        # enter the dual method; picking likely-active ones first saves iterations).
        for w in range(n_warm):
            i = warm[w]
            if 0 <= i < m and b[i] != -math.inf:
                p, worst = _consider(G, b, i, x, n, wsf, ogn, scale, act, q, p, worst)
        for i in range(m if p < 0 else 0):
            if b[i] != -math.inf:
                p, worst = _consider(G, b, i, x, n, wsf, ogn, scale, act, q, p, worst)
        if p < 0:
            break
        if wsf[ogn + p] == 0.0:
            return PROJECT_INFEASIBLE, q, iters
        lp = 0.0  # multiplier of the constraint being added
        while True:
            iters += 1
            if iters > limit:
                return over, q, iters
            # h = Q^T g_p, z = g_p - Q h (twice, for orthogonality), r = R^-1 h.
            for c in range(q):
                wsf[oh + c] = 0.0
            for k in range(n):
                wsf[oz + k] = G[p * n + k]
            for _ in range(2):
                for c in range(q):
                    h = 0.0
                    for k in range(n):
                        h += wsf[oq + k * n + c] * wsf[oz + k]
                    wsf[oh + c] += h
                    for k in range(n):
                        wsf[oz + k] -= h * wsf[oq + k * n + c]
            for c in range(q - 1, -1, -1):
                s = wsf[oh + c]
                for j in range(c + 1, q):
                    s -= wsf[orr + c * n + j] * wsf[orv + j]
                wsf[orv + c] = s / wsf[orr + c * n + c]
            zz = 0.0
            for k in range(n):
                zz += wsf[oz + k] * wsf[oz + k]
            # Partial step: the first active multiplier to reach zero.
            t1 = math.inf
            kd = -1
            for c in range(q):
                r = wsf[orv + c]
                if r > 0.0:
                    t = lam[c] / r
                    if t < t1:
                        t1 = t
                        kd = c
            t2 = math.inf
            sp = _slack(G, b, p, x, n)
            # With n rows active their normals span R^n: row p lies in their span whatever z
            # says (a basis built from rows of extreme scale, norms 1e-162 beside 1e117, leaves
            # z far from zero), and a step would make an (n+1)-th row active, past act and lam.
            if q < n and zz > (_DEP_TOL * wsf[ogn + p]) ** 2:
                t2 = -sp / zz
            t = t1 if t1 < t2 else t2
            if t == math.inf:
                # No step meets row p. When it is violated only by the round-off of forming x
                # from u (a point outside a facet by -2e-16 at a vertex), that is no proof of
                # infeasibility: accept the row as met (marked by a negative norm) and go on.
                if -sp <= _ROUND_OFF * (abs(b[p]) + wsf[ogn + p] * (scale + ubig)):
                    wsf[ogn + p] = -wsf[ogn + p]
                    break
                return PROJECT_INFEASIBLE, q, iters
            if t2 < math.inf:
                for k in range(n):
                    x[k] += t * wsf[oz + k]
            for c in range(q):
                lam[c] -= t * wsf[orv + c]
            lp += t
            if t2 <= t1:
                # Full step: p becomes active.
                act[q] = p
                lam[q] = lp
                q += 1
                _rebuild(G, act, q, n, wsf, oq, orr)
                break
            # Drop constraint kd, keep the order of the others.
            for c in range(kd, q - 1):
                act[c] = act[c + 1]
                lam[c] = lam[c + 1]
            q -= 1
            _rebuild(G, act, q, n, wsf, oq, orr)
    # Polish: the optimum in closed form from its active set, x = (I - Q Qᵀ) u + Q R⁻ᵀ b_A (the
    # part of u along the active normals replaced by what the bounds demand). Unlike the
    # accumulated steps it keeps bounds far smaller than u (a corner at 1 m against a target at
    # 1e16 m) to their own precision, as the 2-D kernel's tangential form does.
    if q > 0:
        for c in range(q):
            h = 0.0
            for k in range(n):
                h += wsf[oq + k * n + c] * u[k]
            wsf[oh + c] = h
        for c in range(q):
            y = b[act[c]]
            for r in range(c):
                y -= wsf[orr + r * n + c] * wsf[oz + r]
            wsf[oz + c] = y / wsf[orr + c * n + c]
        for k in range(n):
            t = u[k]
            for c in range(q):
                t -= wsf[oq + k * n + c] * wsf[oh + c]
            # the tangential part first, then the bounds' part: summed the other way round the
            # large components would cancel the small ones
            for c in range(q):
                t += wsf[oq + k * n + c] * wsf[oz + c]
            x[k] = t
    # Repair: every bound as evaluated in floating point, not only to the dual tolerance.
    for _ in range(8):
        wi = -1
        wg = 0.0
        for i in range(m):
            if b[i] == -math.inf:
                continue
            g = -_slack(G, b, i, x, n)
            if g > 0.0:
                gn = abs(wsf[ogn + i])
                g = g / gn if gn > 0.0 else math.inf
                if g > wg:
                    wg = g
                    wi = i
        if wi < 0:
            return PROJECT_OPTIMAL, q, iters
        gn = abs(wsf[ogn + wi])
        if gn == 0.0:
            return PROJECT_INFEASIBLE, q, iters
        big = 0.0
        for k in range(n):
            if abs(x[k]) > big:
                big = abs(x[k])
        step = wg + _REPAIR_ULPS * (abs(b[wi]) / gn + big) + 1e-300
        for k in range(n):
            x[k] += step * G[wi * n + k] / gn
    # Repairs that fight each other (many bounds through one point): accept round-off. The
    # polish forms x from u, so x carries an absolute error of a few ulps of |u| (and of the
    # bounds): a residual below 1e-12 of that scale is the arithmetic's, not infeasibility (a
    # point outside a facet by its own round-off is no reason to give up; derivations §7).
    big = ubig
    for k in range(n):
        if abs(x[k]) > big:
            big = abs(x[k])
    for i in range(m):
        if b[i] == -math.inf:
            continue
        if -_slack(G, b, i, x, n) > _ROUND_OFF * (abs(b[i]) + abs(wsf[ogn + i]) * big):
            return PROJECT_STALLED, q, iters
    return PROJECT_OPTIMAL, q, iters


@dataclass(frozen=True)
class Projection:
    """The result of :func:`project`.

    Attributes:
        x: The projection (the minimiser), shape (n,); when ``feasible`` is False, the method's
            last iterate (finite, not feasible).
        active: Indices of the constraints active at ``x`` (in the order they were added).
        multipliers: Their Lagrange multipliers, >= 0, shape (len(active),): ``x - u =
            Σ multipliers[k] · G[active[k]]``.
        feasible: Whether the bounds have a common point (and ``x`` meets every bound as
            evaluated in floating point).
        iterations: Inner iterations taken.
    """

    x: FloatArray
    active: tuple[int, ...]
    multipliers: FloatArray
    feasible: bool
    iterations: int


def project(u: ArrayLike, G: ArrayLike, b: ArrayLike) -> Projection:
    r"""Euclidean projection of ``u`` onto :math:`\{x : G x \ge b\}` (module docstring).

    Args:
        u: The point to project, shape (n,), finite.
        G: Constraint normals, shape (m, n), finite (rows need not be unit).
        b: Lower bounds, shape (m,), finite.

    Returns:
        A :class:`Projection`.

    Raises:
        InvalidInput: for non-real, non-finite or mis-shaped inputs (naming the argument).
    """
    uu = real_array("u", u, (None,), what="a point")
    n = uu.shape[0]
    if n == 0:
        raise InvalidInput("u: expected at least one component, got shape (0,)")
    GG = real_array("G", G, (None, None), what="constraint normals")
    if GG.shape[1] != n and GG.shape[0] > 0:
        raise InvalidInput(
            f"u and G disagree: u has {n} components, G has shape {GG.shape} (expected (m, {n}))"
        )
    GG = GG.reshape(-1, n)
    m = GG.shape[0]
    bb = real_array("b", b, (None,), what="lower bounds")
    if bb.shape[0] != m:
        raise InvalidInput(
            f"b and G disagree: b has shape {bb.shape}, G has {m} rows (expected b of shape ({m},))"
        )
    x = np.zeros(n)
    wsf, lam, act = projection_scratch(m, n)
    status, q, iters = project_kernel(uu, GG.ravel(), bb, m, n, x, lam, act, wsf)
    return Projection(
        x=x,
        active=tuple(int(a) for a in act[:q]),
        multipliers=lam[:q].copy(),
        feasible=status == PROJECT_OPTIMAL,
        iterations=iters,
    )


__getattr__ = module_getattr(__name__, {"PROJECT_ITERATION_LIMIT": "PROJECT_STALLED"}, globals())

document_inits(globals())
