r"""Benchmark cases of the n-D exact law: :class:`~velfence.shaping.polytope.PolytopeShaper`.

Three polytopes: a 3-D box (6 facets), a regular icosahedron (20 facets) and the 7-D joint box
of :meth:`DHChain.seven_dof() <velfence.mechanisms.chain.DHChain.seven_dof>` (14 facets, the
arm's joint limits in rad). Per call, every zone, and on the box a corner state outside three
facets at once; beside it the same bound rows (:meth:`PolytopeShaper.bound_rows`) solved as the
QP

.. math::
    \min_x \|x - v\|^2 \;\text{s.t.}\; n_i\cdot x \ge L_i

through :func:`qpsolvers.solve_qp` (``solver="daqp"``) and ``daqp.solve``; and the throughput
of :meth:`PolytopeShaper.shape_batch` compiled (numba) and in plain Python.
"""

from __future__ import annotations

import ctypes
import functools
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_choice
from velfence.apps.bench.cases import Step
from velfence.apps.bench.rows import PolytopeBatchRow, PolytopeLatencyRow, PolytopeQPRow
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import as_fields, time_calls
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import ZONE_NAMES
from velfence.shaping.polytope import PolytopeShaper

__all__ = [
    "BOX_CORNER",
    "CASES",
    "NDPools",
    "batch",
    "icosahedron",
    "latency",
    "nd_shaper",
    "polytope_case",
    "qp",
    "worst",
    "zone_pools",
]

#: The polytopes timed, in order.
CASES: tuple[str, ...] = ("3-D box", "3-D icosahedron", "7-D joint box")

#: Label of the box's corner states outside three facets at once (the latency target's state).
BOX_CORNER = "outside-corner, 3 violated"

#: Zones timed, in the order of ``velfence.shaping.ZONE_NAMES``.
_ZONES: tuple[str, ...] = ZONE_NAMES[:5]

#: ``case -> zone -> states (position, command)``.
NDPools = dict[str, dict[str, list[tuple[FloatArray, FloatArray]]]]


def icosahedron(*, radius: float = 1.0) -> ConvexPolytope:
    """The regular icosahedron of circumradius ``radius`` about the origin (20 facets).

    Args:
        radius: Circumradius, workspace units (> 0).

    Returns:
        The hull of its 12 vertices ``(0, ±1, ±φ)`` and their cyclic permutations, scaled.
    """
    phi = (1.0 + math.sqrt(5.0)) / 2.0
    pts = []
    for a in (-1.0, 1.0):
        for b in (-phi, phi):
            pts += [(0.0, a, b), (a, b, 0.0), (b, 0.0, a)]
    P = np.array(pts) * (radius / math.hypot(1.0, phi))
    return ConvexPolytope.from_vertices(P)


def polytope_case(case: str) -> ConvexPolytope:
    """The polytope of one of :data:`CASES`.

    Args:
        case: ``"3-D box"`` (``[-1, 1]^3``), ``"3-D icosahedron"`` (circumradius 1) or
            ``"7-D joint box"`` (the 7-DoF arm's joint limits, rad).

    Returns:
        The polytope.

    Raises:
        InvalidParameter: ``case`` is not one of :data:`CASES`.
    """
    case = check_choice("case", case, CASES)
    if case == CASES[0]:
        return ConvexPolytope.box(-np.ones(3), np.ones(3))
    if case == CASES[1]:
        return icosahedron()
    from velfence.mechanisms.chain import DHChain

    lim = DHChain.seven_dof().joint_limits
    return ConvexPolytope.box(lim[:, 0], lim[:, 1])


def nd_shaper(poly: ConvexPolytope, s: BenchSettings, *, accelerate: bool = True) -> PolytopeShaper:
    """The benchmark's :class:`PolytopeShaper` of ``poly`` (buffer and gain from ``s``).

    The Python backend (its rows are labelled numba / python); the compiled core is timed by
    ``benchmarks/bench_nd.py``.
    """
    return PolytopeShaper(
        poly, buffer=s.buffer, spring_gain=s.spring_gain, accelerate=accelerate, backend="python"
    )


def _exit_distance(poly: ConvexPolytope, c: FloatArray, U: FloatArray) -> FloatArray:
    """Distance along each unit row of ``U`` from the interior point ``c`` to the boundary."""
    d0 = poly.normals @ c - poly.offsets  # > 0 inside
    rate = U @ poly.normals.T  # (N, m): change of each distance per unit step
    with np.errstate(divide="ignore"):
        t = np.where(rate < 0.0, d0[None, :] / -np.where(rate < 0.0, rate, -1.0), math.inf)
    return np.asarray(t.min(axis=1))


def _candidates(
    poly: ConvexPolytope, s: BenchSettings, rng: np.random.Generator, count: int
) -> tuple[FloatArray, FloatArray]:
    """Positions within 1.5 buffers of the boundary (either side), commands heading out.

    Rays from the Chebyshev centre: half Gaussian directions, half towards the corners of
    ``k``-faces of the bounding box (``k`` random coordinates at ±1, the others near 0), so that
    edges and corners (several facets near at once) are well represented.
    """
    n = poly.dim
    c = poly.chebyshev_center
    U = rng.standard_normal((count, n))
    half = count // 2
    signs = rng.choice([-1.0, 1.0], (half, n))
    keep = rng.uniform(size=(half, n)) < rng.uniform(0.2, 1.0, (half, 1))
    U[:half] = np.where(keep, signs, 0.0) + 0.05 * rng.standard_normal((half, n))
    U /= np.linalg.norm(U, axis=1)[:, None]
    t = _exit_distance(poly, c, U)
    depth = rng.uniform(-1.5 * s.buffer, 1.5 * s.buffer, count)
    P = c + (t + depth)[:, None] * U
    P = np.vstack((P, c + rng.uniform(-0.1, 0.1, (s.states_per_zone, n))))
    V = rng.standard_normal(P.shape)
    nearest = np.argmin(poly.signed_distances_batch(P), axis=1)
    nn = poly.normals[nearest]
    inward = np.einsum("ij,ij->i", V, nn)
    V = V - 2.0 * np.maximum(inward, 0.0)[:, None] * nn
    return P, V


def _box_corner_states(
    s: BenchSettings, rng: np.random.Generator
) -> list[tuple[FloatArray, FloatArray]]:
    """States outside three facets of ``[-1, 1]^3`` at once, commands heading further out."""
    out = []
    for _ in range(s.states_per_zone):
        sign = rng.choice([-1.0, 1.0], 3)
        p = sign * (1.0 + rng.uniform(0.01, 1.5 * s.buffer, 3))
        v = sign * np.abs(rng.standard_normal(3))
        out.append((p, v))
    return out


def zone_pools(s: BenchSettings, notes: list[str]) -> NDPools:
    """The timed states of every case and zone (plus the box's three-facet corner states).

    Args:
        s: The settings (states per zone, buffer, gain, seed).
        notes: Appended to: one line per case with zones that do not occur.

    Returns:
        ``case -> zone -> states``, the same states on every run (fixed seed).
    """
    rng = np.random.default_rng(s.seed + 10)
    pools: NDPools = {}
    for case in CASES:
        poly = polytope_case(case)
        P, V = _candidates(poly, s, rng, 60 * s.states_per_zone * max(1, poly.n_facets // 6))
        _, zones = nd_shaper(poly, s, accelerate=False).zones_batch(P, V)
        pools[case] = {}
        for code, name in enumerate(_ZONES):
            rows = np.flatnonzero(zones == code)[: s.states_per_zone]
            pools[case][name] = [(P[r].copy(), V[r].copy()) for r in rows]
        if case == CASES[0]:
            pools[case][BOX_CORNER] = _box_corner_states(s, rng)
        missing = [z for z, states in pools[case].items() if not states]
        if missing:
            notes.append(f"{case}: zone(s) {', '.join(missing)} did not occur; not timed.")
    return pools


def _mean_rows(sh: PolytopeShaper, pool: Sequence[tuple[FloatArray, FloatArray]]) -> float:
    return float(np.mean([len(sh.explain(p, v).active) for p, v in pool]))


def latency(s: BenchSettings, pools: NDPools, step: Step) -> list[PolytopeLatencyRow]:
    """Per-call latency of :meth:`PolytopeShaper.shape` per (case, zone), compiled kernels.

    Args:
        s: The settings.
        pools: The states of :func:`zone_pools`.
        step: The progress hook.

    Returns:
        One row per (case, zone) with states.
    """
    rows: list[PolytopeLatencyRow] = []
    for case in CASES:
        step(f"latency: PolytopeShaper, {case}")
        poly = polytope_case(case)
        sh = nd_shaper(poly, s)
        for zone, pool in pools[case].items():
            if not pool:
                continue
            t = time_calls(sh.shape, pool, calls=s.calls, warmup=s.warmup)
            rows.append(
                PolytopeLatencyRow(
                    **as_fields(t),
                    case=case,
                    dim=poly.dim,
                    facets=poly.n_facets,
                    zone=zone,
                    states=len(pool),
                    rows=_mean_rows(sh, pool),
                )
            )
    return rows


def worst(rows: Sequence[PolytopeLatencyRow], case: str) -> PolytopeLatencyRow | None:
    """The slowest zone (by median) of ``case`` among the per-zone rows, or None without rows."""
    mine = [r for r in rows if r.case == case and r.zone in _ZONES]
    return max(mine, key=lambda r: r.median_us) if mine else None


def _max_error(
    shape: Any, pool: Sequence[tuple[FloatArray, FloatArray]], xs: Sequence[Any]
) -> float:
    err = 0.0
    for (p, v), x in zip(pool, xs, strict=True):
        if x is None:
            return math.inf
        err = max(err, float(np.max(np.abs(shape(p, v) - np.asarray(x)))))
    return err


def qp(
    s: BenchSettings, pools: NDPools, latency_rows: Sequence[PolytopeLatencyRow], step: Step
) -> list[PolytopeQPRow]:
    """The n-D exact law against qpsolvers and daqp on its own bound rows, per (case, zone).

    States whose bounds were relaxed (infeasible together) and the free zone (no rows) are
    left out.

    Args:
        s: The settings.
        pools: The states of :func:`zone_pools`.
        latency_rows: The latency rows of the same states (the ratios' denominators).
        step: The progress hook.

    Returns:
        One row per (case, zone) with bounded states.
    """
    import daqp
    import qpsolvers

    by_key = {(r.case, r.zone): r for r in latency_rows}
    solve_qp = functools.partial(qpsolvers.solve_qp, solver="daqp")
    out: list[PolytopeQPRow] = []
    for case in CASES:
        step(f"QP baseline: PolytopeShaper, {case}")
        poly = polytope_case(case)
        sh = nd_shaper(poly, s)
        n = poly.dim
        H = np.eye(n)
        for zone, pool in pools[case].items():
            states = [(p, v) for p, v in pool if not sh.explain(p, v).relaxed]
            states = [(p, v) for p, v in states if sh.bound_rows(p, v)[0].shape[0] > 0]
            if not states or (case, zone) not in by_key:
                continue
            qs, ds = [], []
            for p, v in states:
                N, lower, _ = sh.bound_rows(p, v)
                k = lower.shape[0]
                qs.append((H, -v, np.array(-N), np.array(-lower)))
                ds.append(
                    (
                        H,
                        np.array(-v),
                        np.ascontiguousarray(N),  # writable, C-contiguous: daqp needs both
                        np.full(k, 1e30),
                        np.array(lower),
                        np.zeros(k, dtype=ctypes.c_int),
                    )
                )
            x_qps = [solve_qp(*a) for a in qs]
            x_daqp = [daqp.solve(*a)[0] for a in ds]
            q_t = time_calls(solve_qp, qs, calls=s.calls, warmup=s.warmup)
            d_t = time_calls(daqp.solve, ds, calls=s.calls, warmup=s.warmup)
            vf = by_key[case, zone]
            out.append(
                PolytopeQPRow(
                    case=case,
                    dim=n,
                    facets=poly.n_facets,
                    zone=zone,
                    states=len(states),
                    calls=s.calls,
                    rows=float(np.mean([a[3].shape[0] for a in qs])),
                    velfence_median_us=vf.median_us,
                    velfence_p99_us=vf.p99_us,
                    qpsolvers_median_us=q_t.median_us,
                    qpsolvers_p99_us=q_t.p99_us,
                    daqp_median_us=d_t.median_us,
                    daqp_p99_us=d_t.p99_us,
                    qpsolvers_ratio_median=q_t.median_us / vf.median_us,
                    daqp_ratio_median=d_t.median_us / vf.median_us,
                    qpsolvers_max_error=_max_error(sh.shape, states, x_qps),
                    daqp_max_error=_max_error(sh.shape, states, x_daqp),
                )
            )
    return out


def _batch_states(
    poly: ConvexPolytope, n: int, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray]:
    """Positions uniform in a box about the Chebyshev centre grown by 10 %, normal commands.

    The box reaches, along each axis, as far as the polytope does from the centre (its
    bounding box for the benchmark's centrally symmetric polytopes).
    """
    c = poly.chebyshev_center
    E = np.vstack((np.eye(poly.dim), -np.eye(poly.dim)))
    reach = _exit_distance(poly, c, E)
    lo = c - reach[poly.dim :]
    hi = c + reach[: poly.dim]
    grow = 0.05 * (hi - lo)
    P = rng.uniform(lo - grow, hi + grow, (n, poly.dim))
    return P, rng.standard_normal((n, poly.dim))


def _time_batch(
    fast: PolytopeShaper, P: FloatArray, V: FloatArray, reps: int, threads: int
) -> list[float]:
    """Wall times of ``reps`` calls after a warm one; ``threads``: numba threads (0: all)."""
    import numba

    before = numba.get_num_threads()
    if threads:
        numba.set_num_threads(threads)
    try:
        fast.shape_batch(P, V)  # warm caches and the thread pool
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            fast.shape_batch(P, V)
            times.append(time.perf_counter() - t0)
    finally:
        numba.set_num_threads(before)
    return times


def batch(s: BenchSettings, numba_ok: bool, step: Step) -> list[PolytopeBatchRow]:
    """Throughput of :meth:`PolytopeShaper.shape_batch` per case: numba per N, Python at one N.

    numba runs twice per N: on all its threads and on one (the kernel's own cost per row, free
    of the thread pool's wake-up and of other processes holding a core).

    Args:
        s: The settings (``nd_batch_n``, ``nd_python_n``, ``batch_repeats``).
        numba_ok: Whether numba is installed (else only the Python rows).
        step: The progress hook.

    Returns:
        The rows, per case: one per numba size, then the Python one.
    """
    rows: list[PolytopeBatchRow] = []
    rng = np.random.default_rng(s.seed + 11)
    for case in CASES:
        poly = polytope_case(case)
        big = max(max(s.nd_batch_n), s.nd_python_n)
        P, V = _batch_states(poly, big, rng)
        label = (case, poly.dim, poly.n_facets)
        if numba_ok:
            # The first size's step includes the compilation (the progress plan counts it there).
            step(f"batch: PolytopeShaper, {case}, numba, N={s.nd_batch_n[0]}")
            fast = nd_shaper(poly, s, accelerate=True)
            t0 = time.perf_counter()
            fast.shape_batch(P[:16], V[:16])  # compiles (or loads the cache) once per process
            compile_s = time.perf_counter() - t0
            for j, n in enumerate(s.nd_batch_n):
                if j:
                    step(f"batch: PolytopeShaper, {case}, numba, N={n}")
                Pn, Vn = P[:n], V[:n]
                reps = max(s.batch_repeats, min(101, 100_000 // n))
                for backend, threads in (("numba", 0), ("numba, 1 thread", 1)):
                    times = _time_batch(fast, Pn, Vn, reps, threads)
                    med = float(np.median(times))
                    rows.append(
                        PolytopeBatchRow(
                            *label,
                            backend,
                            n,
                            reps,
                            compile_s,
                            med,
                            n / med,
                            n / min(times),
                            1e9 * med / n,
                        )
                    )
        n = s.nd_python_n
        step(f"batch: PolytopeShaper, {case}, python, N={n}")
        slow = nd_shaper(poly, s, accelerate=False)
        slow.shape_batch(P[:16], V[:16])
        t0 = time.perf_counter()
        slow.shape_batch(P[:n], V[:n])
        dt = time.perf_counter() - t0
        rows.append(PolytopeBatchRow(*label, "python", n, 1, 0.0, dt, n / dt, n / dt, 1e9 * dt / n))
    return rows
