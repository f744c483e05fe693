r"""The exact law in any dimension: scalar kernels for convex polytopes.

The same law as the 2-D exact kernel (``_kernels.exact_kernel``, derivations §3), written for
``dim`` coordinates: the bounds come from the one bound definition
(:func:`~velfence.shaping._kernels.bounds_from_distances`), the minimum-change velocity under all
of them at once from the exact projection of :mod:`velfence.geometry.projection`. Like the 2-D
kernels they are plain arithmetic on flat row-major arrays with caller-provided scratch, run as
ordinary Python and compiled unchanged by numba (:mod:`velfence.shaping._accel`).

Return value of :func:`polytope_kernel` (a flat tuple)::

    (zone, stages, q, p1, p2, d1, d2, m)

``zone``/``stages`` as in the 2-D kernels, ``q`` binding facets in ``active[:q]``, the nearest two
facets and their distances, and ``m`` the number of bounded facets (``work[:m]``, bounds in
``bnd`` in caller units).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence.geometry.projection import PROJECT_OPTIMAL, project_kernel, scratch_length
from velfence.shaping._kernels import (
    STAGE_PROJECT,
    STAGE_RELAXED,
    STAGE_SCALED,
    STAGE_SPRING,
    STAGE_STOP,
    ZONE_FREE,
    bounds_from_distances,
    fill_bounds,
    unbounded_candidates,
    zone_code,
)

# Replaced by numba.prange in the compiled twins (see _accel); plain range in pure Python.
prange = range

#: The relaxation of outside facets' recovery bounds when the bounds conflict: each step
#: multiplies them by 1/4 (1/4, 1/16, ..., 4**-8), the last sets them to 0 ("no further out").
RECOVERY_FRACTIONS = (*(0.25**k for k in range(1, 9)), 0.0)

BATCH_CHUNK = 1024  # rows per parallel work item; each item owns its scratch


def vector_norm(v: Any, n: int) -> float:
    """``|v|`` scaled by its largest component (no overflow; the same bits compiled or not)."""
    big = 0.0
    for k in range(n):
        if abs(v[k]) > big:
            big = abs(v[k])
    if big == 0.0:
        return 0.0
    s = 0.0
    for k in range(n):
        t = v[k] / big
        s += t * t
    return big * math.sqrt(s)


def _solve_rows(
    u: Any,
    N: Any,
    bnd: Any,
    work: Any,
    m: int,
    dim: int,
    G: Any,
    b: Any,
    x: Any,
    lam: Any,
    act: Any,
    wsf: Any,
) -> tuple[int, int]:
    """Project ``u`` onto the bounds of facets ``work[:m]`` (rows copied into ``G``, ``b``)."""
    for a in range(m):
        e = work[a]
        for k in range(dim):
            G[a * dim + k] = N[e * dim + k]
        b[a] = bnd[e]
    status, q, _ = project_kernel(u, G, b, m, dim, x, lam, act, wsf)
    return status, q


def _answer(
    x: Any,
    scale: float,
    dim: int,
    out: Any,
    active: Any,
    work: Any,
    act: Any,
    q: int,
    bnd: Any,
    m: int,
) -> None:
    """Write a solve's answer: ``out = x · scale``, binding facets, bounds in caller units."""
    for k in range(dim):
        out[k] = x[k] * scale
    for c in range(q):
        active[c] = work[act[c]]
    for a in range(m):
        bnd[work[a]] *= scale


def polytope_kernel(
    p: Any,
    v: Any,
    N: Any,
    off: Any,
    nf: int,
    dim: int,
    cen: Any,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    out: Any,
    active: Any,
    dist: Any,
    bnd: Any,
    work: Any,
    G: Any,
    b: Any,
    u: Any,
    x: Any,
    lam: Any,
    act: Any,
    wsf: Any,
) -> tuple[int, int, int, int, int, float, float, int]:
    r"""Minimum-change velocity under one half-space bound per nearby facet (derivations §7).

    :math:`v_o = \arg\min_x \|x - v\|^2` s.t. :math:`n_i\cdot x \ge L_i` for every bounded facet
    ``i``, with :math:`L_i` from :func:`~velfence.shaping._kernels.bounds_from_distances`
    (profile kind ``kind`` with parameters ``prm``, the built-in relaxation ``relax``, ``idt =
    1/dt`` or 0) — the 2-D exact law's formulation, so for ``dim = 2`` the two agree to
    round-off. Solved in units of ``|v| + R`` by the exact projection; outside, facets that the
    answer's speed could reach are added until none is violated (as in 2-D). When the bounds
    are infeasible together (a polytope thinner than the profile's reach), the recovery bounds
    alone are kept (stage ``relaxed``); should even they fail (never for a valid polytope), the
    answer heads for the Chebyshev centre ``cen`` at the recovery speed.

    Args:
        p: Position (dim,).
        v: Command (dim,).
        N: Inward unit normals, flat (nf·dim,).
        off: Offsets (nf,): ``d_i = n_i·p - off_i``.
        nf: Number of facets.
        dim: Dimension.
        cen: An interior point (dim,) (the Chebyshev centre).
        kind: ``PROFILE_*`` code.
        prm: The profile's float parameters.
        relax: The built-in linear buffer's relaxation.
        idt: ``1/dt`` [1/s] or 0.
        out: Output velocity (dim,).
        active: Output binding facets (>= dim + 1,), ints.
        dist: Scratch (nf,) floats: the signed distances on return.
        bnd: Scratch (nf,) floats: the bounds of ``work[:m]`` on return (caller units).
        work: Scratch (nf,) ints: the bounded facets on return.
        G: Scratch (nf·dim,).
        b: Scratch (nf,).
        u: Scratch (dim,).
        x: Scratch (dim,).
        lam: Scratch (dim + 1,).
        act: Scratch (dim + 1,) ints.
        wsf: Scratch from :func:`~velfence.geometry.projection.projection_scratch` (nf, dim).
    """
    for e in range(nf):
        s = 0.0
        for k in range(dim):
            s += N[e * dim + k] * p[k]
        dist[e] = s - off[e]
    vnorm = vector_norm(v, dim)
    m, n_out, n_near, _rec, unit, scale, p1, p2, d1, d2 = bounds_from_distances(
        dist, nf, vnorm, kind, prm, relax, idt, True, bnd, work
    )
    if m == 0:
        for k in range(dim):
            out[k] = v[k]
        return ZONE_FREE, 0, 0, p1, p2, d1, d2, 0
    zone = zone_code(n_out, n_near)
    stages = STAGE_PROJECT if n_near > 0 else 0
    if n_out > 0:
        stages |= STAGE_SPRING
    for k in range(dim):
        u[k] = v[k] / scale
    for attempt in range(2):
        if attempt == 1:
            # The solve failed in floating point: a command many orders of magnitude beyond
            # every bound (1e12 against a 1 m/s cap) leaves the bounds below the round-off of
            # the arithmetic on it. Solve once more for the command shortened (direction kept)
            # to 1e3 times the largest bound: its projection meets every bound as well.
            bmax = 0.0
            for a in range(m):
                if abs(bnd[work[a]]) > bmax:
                    bmax = abs(bnd[work[a]])
            un = vector_norm(u, dim)
            if not un > 1e3 * bmax:
                break
            f = 1e3 * bmax / un
            for k in range(dim):
                u[k] *= f
            stages |= STAGE_SCALED
        while True:
            status, q = _solve_rows(u, N, bnd, work, m, dim, G, b, x, lam, act, wsf)
            if status != PROJECT_OPTIMAL:
                break
            done = n_out == 0
            if not done:
                xx = 0.0
                for k in range(dim):
                    xx += x[k] * x[k]
                done = xx <= unit * unit
            if not done:
                # Outside, recovery can make the answer faster than an unbounded facet's reach
                # (Cauchy-Schwarz): bound every facet not yet bounded and keep those it violates.
                c = unbounded_candidates(dist, work, m, nf)
                fill_bounds(kind, prm, relax, dist, work, m, c, unit, scale, idt, bnd)
                added = False
                for a in range(m, c):
                    e = work[a]
                    if bnd[e] > -math.inf:
                        s = 0.0
                        for k in range(dim):
                            s += N[e * dim + k] * x[k]
                        if s < bnd[e]:
                            work[m] = e
                            m += 1
                            added = True
                done = not added
            if done:
                _answer(x, scale, dim, out, active, work, act, q, bnd, m)
                return zone, stages, q, p1, p2, d1, d2, m
    if n_out > 0:
        # Infeasible together (a polytope thinner than the profile's reach, or round-off at a
        # vertex): slow the recovery of the facets the point is outside (a quarter, a sixteenth,
        # ..., then "no further out"), every other facet's bound kept. The point is inside those
        # facets, so relaxing them would let it out (derivations §7); once the recovery bounds are
        # 0, zero velocity meets every bound, so the projection exists.
        for r in range(len(RECOVERY_FRACTIONS)):
            for a in range(m):
                e = work[a]
                if dist[e] < 0.0 and bnd[e] > 0.0:
                    bnd[e] = bnd[e] * 0.25 if r + 1 < len(RECOVERY_FRACTIONS) else 0.0
            status, q = _solve_rows(u, N, bnd, work, m, dim, G, b, x, lam, act, wsf)
            if status == PROJECT_OPTIMAL:
                _answer(x, scale, dim, out, active, work, act, q, bnd, m)
                return zone, stages | STAGE_RELAXED, q, p1, p2, d1, d2, m
    # Reached only if round-off defeats the projection of a problem zero velocity solves (never
    # observed): stopping is the safe answer, inside and out.
    for k in range(dim):
        out[k] = 0.0
    for a in range(m):
        bnd[work[a]] *= scale
    return zone, stages | STAGE_STOP | (STAGE_RELAXED if n_out > 0 else 0), 0, p1, p2, d1, d2, m


def polytope_scratch(nf: int, dim: int) -> tuple[Any, ...]:
    """Scratch arrays for :func:`polytope_kernel`, in its argument order from ``active`` on."""
    return (
        np.zeros(dim + 1, dtype=np.int64),  # active
        np.zeros(nf),  # dist
        np.zeros(nf),  # bnd
        np.zeros(nf, dtype=np.int64),  # work
        np.zeros(nf * dim),  # G
        np.zeros(nf),  # b
        np.zeros(dim),  # u
        np.zeros(dim),  # x
        np.zeros(dim + 1),  # lam
        np.zeros(dim + 1, dtype=np.int64),  # act
        np.zeros(scratch_length(nf, dim)),  # wsf
    )


def polytope_batch(
    P: Any,
    V: Any,
    out: Any,
    zones: Any,
    N: Any,
    off: Any,
    nf: int,
    dim: int,
    cen: Any,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
) -> None:
    """Loop of :func:`polytope_kernel` over rows of P, V (writes ``out`` (N, dim), ``zones``)."""
    rows = len(P)
    for c in prange((rows + BATCH_CHUNK - 1) // BATCH_CHUNK):
        active, dist, bnd, work, G, b, u, x, lam, act, wsf = polytope_scratch(nf, dim)
        for r in range(c * BATCH_CHUNK, min(rows, (c + 1) * BATCH_CHUNK)):
            res = polytope_kernel(
                P[r], V[r], N, off, nf, dim, cen, kind, prm, relax, idt, out[r], active, dist,
                bnd, work, G, b, u, x, lam, act, wsf,
            )  # fmt: skip
            zones[r] = res[0]


def polytope_one(
    p: Any,
    v: Any,
    N: Any,
    off: Any,
    nf: int,
    dim: int,
    cen: Any,
    kind: int,
    prm: Any,
    relax: bool,
    idt: float,
    out: Any,
    active: Any,
    dist: Any,
    bnd: Any,
    work: Any,
) -> tuple[int, int, int, int, int, float, float, int]:
    """One call of :func:`polytope_kernel` that owns its solver scratch (the compiled entry)."""
    G = np.zeros(nf * dim)
    b = np.zeros(nf)
    u = np.zeros(dim)
    x = np.zeros(dim)
    lam = np.zeros(dim + 1)
    act = np.zeros(dim + 1, dtype=np.int64)
    wsf = np.zeros(scratch_length(nf, dim))
    return polytope_kernel(
        p, v, N, off, nf, dim, cen, kind, prm, relax, idt, out, active, dist, bnd, work, G, b, u,
        x, lam, act, wsf,
    )  # fmt: skip
