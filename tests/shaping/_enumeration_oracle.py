"""The 2-D exact law's former solve, kept only as a test oracle.

Before the dual active-set method (``_kernels._solve_tol``), the 2-D exact law ENUMERATED the
candidate active sets of its bounded edges (cubic in them) and added far edges with
:func:`velfence.shaping._kernels.unbounded_candidates` (quadratic). This module is that code,
unchanged but for names, so that the tests can compare the new kernel with it on many states.
Not part of the library.
"""

from __future__ import annotations

import math
from typing import Any

from velfence.shaping._kernels import (
    _FEAS_TOL,
    _REPAIR_ULPS,
    STAGE_PROJECT,
    STAGE_RELAXED,
    STAGE_SPRING,
    STAGE_STOP,
    ZONE_FREE,
    _violates,
    exact_bounds,
    fill_bounds,
    unbounded_candidates,
    zone_code,
)


def _enum_solve_tol(
    vx: float, vy: float, work: Any, m: int, nx: Any, ny: Any, bnd: Any, tol: float
) -> tuple[bool, float, float]:
    """Minimise ||x - v||² s.t. n_w · x >= b_w for w in work[:m], by enumeration.

    In 2-D at most two bounds are active at the optimum, so the optimum is ``v`` itself, the
    projection onto one bound line, or the intersection of two; the feasible candidate nearest to
    ``v`` is the optimum. Two shortcuts end the search early: a projection onto one bound that
    satisfies every other bound *is* the optimum (the feasible set lies in that half-plane), and so
    is a feasible vertex whose two multipliers are non-negative (KKT). Feasibility is tested with
    slack ``tol`` (relative, see :func:`_violates`); the caller runs it with ``tol = 0`` first so
    that a candidate that is only *almost* feasible never hides the true optimum (at a near-flat
    corner the two differ by ``tol / sin θ``). Returns (feasible, x, y).

    The projection onto one bound is built from the tangential part of ``v`` plus ``b_w n_w``
    (not ``v + gap n_w``): when ``v`` is huge against ``b_w`` the sum would lose ``b_w`` (a
    recovery bound of 1e-17 in units of a 1e15 command), the tangential form keeps it.
    """
    ok = True
    for a in range(m):
        w = work[a]
        if _violates(vx, vy, nx[w], ny[w], bnd[w], tol):
            ok = False
            break
    if ok:
        return True, vx, vy
    best = math.inf
    bx = 0.0
    by = 0.0
    for a in range(m):
        w = work[a]
        gap = bnd[w] - (nx[w] * vx + ny[w] * vy)
        if gap <= 0.0:
            continue
        vt = ny[w] * vx - nx[w] * vy  # component of v along the tangent t = (ny, -nx)
        x = vt * ny[w] + bnd[w] * nx[w]
        y = bnd[w] * ny[w] - vt * nx[w]
        feas = True
        for c in range(m):
            u = work[c]
            if u != w and _violates(x, y, nx[u], ny[u], bnd[u], tol):
                feas = False
                break
        if feas:
            return True, x, y
    for a in range(m):
        w = work[a]
        for c in range(a + 1, m):
            u = work[c]
            det = nx[w] * ny[u] - ny[w] * nx[u]
            if abs(det) < 1e-12:
                continue
            x = (bnd[w] * ny[u] - ny[w] * bnd[u]) / det
            y = (nx[w] * bnd[u] - bnd[w] * nx[u]) / det
            dist = (x - vx) * (x - vx) + (y - vy) * (y - vy)
            if dist >= best:
                continue
            feas = True
            for e in range(m):
                q = work[e]
                if q != w and q != u and _violates(x, y, nx[q], ny[q], bnd[q], tol):
                    feas = False
                    break
            if feas:
                # x - v = lw n_w + lu n_u; both multipliers >= 0 makes x the optimum (KKT).
                dx = x - vx
                dy = y - vy
                lw = (dx * ny[u] - dy * nx[u]) / det
                lu = (nx[w] * dy - ny[w] * dx) / det
                if lw >= -_FEAS_TOL and lu >= -_FEAS_TOL:
                    return True, x, y
                best = dist
                bx = x
                by = y
    if best == math.inf:
        return False, 0.0, 0.0
    return True, bx, by


def _enum_solve(
    vx: float, vy: float, work: Any, m: int, nx: Any, ny: Any, bnd: Any
) -> tuple[bool, float, float]:
    """:func:`_solve_tol` whose answer meets every bound in floating point, or (False, 0, 0).

    Strict pass first (``tol = 0``): its answer already meets every bound as evaluated. Only when
    round-off makes the strict pass find nothing (three bound lines through one point), the
    tolerant pass runs and its answer is repaired: each violated bound in turn is met by moving
    along its normal by the violation plus a few ulps (at most ``_FEAS_TOL`` relative, because
    the tolerant pass accepted it). A few rounds settle any case in which the repaired bounds do
    not fight each other; otherwise the caller falls back to an answer known to be feasible.
    """
    ok, x, y = _enum_solve_tol(vx, vy, work, m, nx, ny, bnd, 0.0)
    if ok:
        return True, x, y
    ok, x, y = _enum_solve_tol(vx, vy, work, m, nx, ny, bnd, _FEAS_TOL)
    if not ok:
        return False, 0.0, 0.0
    for _ in range(8):
        worst = 0.0
        wi = -1
        for a in range(m):
            w = work[a]
            g = bnd[w] - (nx[w] * x + ny[w] * y)
            if g > worst:
                worst = g
                wi = w
        if wi < 0:
            return True, x, y
        g = worst + _REPAIR_ULPS * (1.0 + abs(bnd[wi]) + abs(x) + abs(y))
        x += g * nx[wi]
        y += g * ny[wi]
    return False, 0.0, 0.0


def oracle_kernel(
    px: float,
    py: float,
    vx: float,
    vy: float,
    nx: Any,
    ny: Any,
    off: Any,
    cx: float,
    cy: float,
    n: int,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    dist: Any,
    bnd: Any,
    work: Any,
) -> tuple[float, float, int, int, int, float, float, float, float, int]:
    r"""Minimum-change velocity subject to one half-plane bound per nearby edge (derivations §3).

    The bounds are :func:`exact_bounds` (one definition, shared with
    :meth:`~velfence.shaping.polygon.PolygonShaper.bounds`); the built-in linear buffer
    (``kind = PROFILE_LINEAR``, ``relax``) gives ``n_i · v_o >= -(|v| + R) d_i / d_max`` for
    edges with ``0 <= d_i < d_max`` and ``n_i · v_o >= min(k (-d_i), r_max)`` for violated
    edges, ``R`` the largest recovery bound (0 inside). A profile gives ``n_i · v_o >=
    -cap(d_i, |v|)``. Zones follow :func:`zone_code`.

    ``idt`` is ``1 / dt`` for a discrete-time law (0: continuous time). Then every edge's bound
    also caps the approach per period by the remaining distance, ``n_i · v_o >= -d_i / dt``, and
    the recovery by the penetration, ``min(k (-d_i), r_max, -d_i / dt)``; edges up to
    ``(|v| + R) dt`` away (not only ``d_max``) are bounded (derivations §3.3).

    The answer meets every bound as evaluated in floating point in the kernel's units (strict
    solve, else tolerant solve plus repair, else a known-feasible fallback).

    ``dist``, ``bnd`` (floats) and ``work`` (ints) are caller-provided scratch of length >= n, so
    the kernel itself allocates nothing.
    """
    m, n_out, n_near, rec, unit, scale, p1, p2, d1, d2 = exact_bounds(
        px, py, vx, vy, nx, ny, off, n, kind, prm, relax, idt, True, dist, bnd, work
    )
    if m == 0:
        return vx, vy, ZONE_FREE, p1, p2, d1, d2, 0.0, 0.0, 0
    zone = zone_code(n_out, n_near)
    stages = STAGE_PROJECT if n_near > 0 else 0
    if n_out > 0:
        stages |= STAGE_SPRING
    ux = vx / scale
    uy = vy / scale
    while True:
        ok, ox, oy = _enum_solve(ux, uy, work, m, nx, ny, bnd)
        if not ok:
            break
        # An unbounded edge's bound is <= -cap speed (beyond the cap's reach; and d >= (|v| + R)
        # dt in discrete time), binding only when the answer is faster than that
        # (Cauchy-Schwarz). Inside that never happens (0 is feasible, so the projection is no
        # faster than v); outside, recovery can cause it: add those edges.
        if n_out == 0 or ox * ox + oy * oy <= unit * unit:
            return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages
        c = unbounded_candidates(dist, work, m, n)
        fill_bounds(kind, prm, relax, dist, work, m, c, unit, scale, idt, bnd)
        added = False
        for a in range(m, c):
            e = work[a]
            b = bnd[e]
            if b > -math.inf and _violates(ox, oy, nx[e], ny[e], b, 0.0):
                work[m] = e
                m += 1
                added = True
        if not added:
            return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages
    if n_out == 0:
        # Inside every bound is <= 0, so zero velocity meets them all exactly. Reached only if
        # round-off defeats both solves (never observed); stopping is the safe answer.
        return 0.0, 0.0, zone, p1, p2, d1, d2, 0.0, 0.0, stages | STAGE_STOP
    # Infeasible together (the buffer is refused wider than the inradius, so only by round-off
    # or a far edge; a profile steeper than the polygon is thin): recovery first.
    m = 0
    for e in range(n):
        if dist[e] < 0.0:
            work[m] = e
            m += 1
    ok, ox, oy = _enum_solve(ux, uy, work, m, nx, ny, bnd)
    if ok:
        return ox * scale, oy * scale, zone, p1, p2, d1, d2, 0.0, 0.0, stages | STAGE_RELAXED
    # Unreachable for a valid convex polygon (violated inward normals always admit a common
    # direction); kept so that no input can produce a non-finite or outward answer: head home.
    hx = cx - px
    hy = cy - py
    big = abs(hx) if abs(hx) > abs(hy) else abs(hy)
    hx /= big
    hy /= big
    hn = math.sqrt(hx * hx + hy * hy)
    return rec * hx / hn, rec * hy / hn, zone, p1, p2, d1, d2, 0.0, 0.0, stages | STAGE_RELAXED
