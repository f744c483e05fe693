"""Benchmark cases of the shapers: the polygon shapers and the joint-stop limiter.

Per-call latency and batch throughput of the polygon shapers (regular n-gons, every zone), and
per-call latency of the joint-stop limiter.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import cast

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_positive_int
from velfence.apps.bench.cases import Step
from velfence.apps.bench.rows import BatchRow, LatencyRow, StopLatencyRow, WorstZone
from velfence.apps.bench.settings import MAX_EDGES, ZONES, BenchSettings
from velfence.apps.bench.timing import as_fields, time_calls
from velfence.errors import InvalidGeometry
from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping.polygon import PolygonMethod, PolygonShaper

__all__ = [
    "METHODS",
    "Pool",
    "Pools",
    "batch",
    "latency",
    "regular_polygon",
    "shaper",
    "stop_latency",
    "worst_zone",
    "zone_pools",
]

#: The polygon shaper's methods, timed side by side.
METHODS: tuple[str, ...] = ("patent", "exact")

#: States (position, command) of one zone.
Pool = list[tuple[FloatArray, FloatArray]]
#: ``(edges, method) -> zone -> states``.
Pools = dict[tuple[int, str], dict[str, Pool]]


def regular_polygon(edges: int, *, radius: float = 1.0) -> ConvexPolygon:
    """Regular polygon about the origin, one edge bisected by the positive x axis.

    Args:
        edges: Number of edges, ``3 <= edges <=`` :data:`MAX_EDGES`.
        radius: Circumradius, workspace units (> 0).

    Returns:
        The polygon.

    Raises:
        InvalidParameter: ``edges`` is not an int in range, or ``radius`` is not positive.
        InvalidGeometry: ``radius`` is so small that the corners coincide.
    """
    edges = check_positive_int("edges", edges, minimum=3, maximum=MAX_EDGES, example=8)
    radius = check_positive("radius", radius)
    ang = math.pi / edges + 2.0 * math.pi * np.arange(edges) / edges
    try:
        return ConvexPolygon(radius * np.column_stack((np.cos(ang), np.sin(ang))))
    except InvalidGeometry as exc:  # a radius of 1e-320: the corners round together
        raise InvalidGeometry(f"radius: {radius!r} is too small for a polygon ({exc})") from None


def shaper(
    poly: ConvexPolygon, method: str, s: BenchSettings, *, accelerate: bool = True
) -> PolygonShaper:
    """The benchmark's :class:`PolygonShaper` of ``poly`` (buffer and gain from ``s``).

    The Python backend (numba for batches with ``accelerate``): these rows keep measuring the
    reference implementation whether or not the compiled core is installed; the core is timed
    beside it by ``benchmarks/bench_core.py`` (docs/core.md).
    """
    return PolygonShaper(
        poly,
        buffer=s.buffer,
        spring_gain=s.spring_gain,
        method=cast("PolygonMethod", method),  # checked by the constructor
        accelerate=accelerate,
        backend="python",
    )


def _zone_states(
    poly: ConvexPolygon, method: str, s: BenchSettings, rng: np.random.Generator
) -> dict[str, Pool]:
    """Up to ``states_per_zone`` states (position, command) per zone, as ``method`` classifies.

    Candidates lie within 1.5 buffers of the boundary on either side, plus a few near the
    centroid. Commands are standard normal, reflected so they head out through the nearest edge:
    the shaping is engaged wherever the zone allows, the case that matters for a deadline.
    """
    corners = poly.corners
    n = poly.n
    count = 40 * s.states_per_zone * max(1, n // 8)
    edge = rng.integers(0, n, count)
    u = rng.uniform(0.0, 1.0, count)
    depth = rng.uniform(-1.5 * s.buffer, 1.5 * s.buffer, count)
    a = corners[edge]
    b = corners[(edge + 1) % n]
    P = a + u[:, None] * (b - a) + depth[:, None] * poly.normals[edge]
    P = np.vstack((P, poly.centroid + rng.uniform(-0.2, 0.2, (s.states_per_zone, 2))))
    V = rng.standard_normal(P.shape)
    nearest = np.argmin(poly.signed_distances(P), axis=1)
    nn = poly.normals[nearest]
    inward = np.einsum("ij,ij->i", V, nn)
    V = V - 2.0 * np.maximum(inward, 0.0)[:, None] * nn
    _, zones = shaper(poly, method, s, accelerate=False).zones_batch(P, V)
    pools: dict[str, Pool] = {}
    for code, name in enumerate(ZONES):
        rows = np.flatnonzero(zones == code)[: s.states_per_zone]
        pools[name] = [(P[r].copy(), V[r].copy()) for r in rows]
    return pools


def zone_pools(s: BenchSettings, notes: list[str]) -> Pools:
    """The timed states of every (polygon, method, zone); zones that cannot occur go to ``notes``.

    Args:
        s: The settings (polygons, states per zone, buffer, gain, seed).
        notes: Appended to: one line per (polygon, method) with zones that do not occur.

    Returns:
        ``(edges, method) -> zone -> states``, the same states on every run (fixed seed).
    """
    rng = np.random.default_rng(s.seed)
    pools = {
        (edges, method): _zone_states(regular_polygon(edges), method, s, rng)
        for edges in s.latency_edges
        for method in METHODS
    }
    for (edges, method), pool in pools.items():
        missing = [z for z, states in pool.items() if not states]
        if missing:
            notes.append(
                f"{edges}-gon, {method}: zone(s) {', '.join(missing)} do not occur with "
                f"buffer {s.buffer:g} (every point near one edge is within the buffer of a "
                "neighbour too); not timed."
            )
    return pools


def latency(s: BenchSettings, pools: Pools, step: Step) -> tuple[list[LatencyRow], list[WorstZone]]:
    """Per-call latency of :meth:`PolygonShaper.shape` per (polygon, method, zone).

    Returns:
        The rows, and the slowest zone of each (polygon, method).
    """
    rows: list[LatencyRow] = []
    worst: list[WorstZone] = []
    for edges in s.latency_edges:
        poly = regular_polygon(edges)
        for method in METHODS:
            step(f"latency: {edges}-gon, {method}")
            fn = shaper(poly, method, s).shape
            mine = [
                LatencyRow(
                    **as_fields(time_calls(fn, pool, calls=s.calls, warmup=s.warmup)),
                    edges=edges,
                    method=method,
                    zone=zone,
                    states=len(pool),
                )
                for zone, pool in pools[edges, method].items()
                if pool
            ]
            rows.extend(mine)
            worst.append(worst_zone(mine))
    return rows, worst


def worst_zone(rows: Sequence[LatencyRow]) -> WorstZone:
    """The slowest of ``rows`` (by median, the first of equal ones), as a :class:`WorstZone`."""
    slow = max(rows, key=lambda r: r.median_us)
    return WorstZone(
        **as_fields(slow), edges=slow.edges, method=slow.method, zone=slow.zone, states=slow.states
    )


#: Names of the three-zone profile's zones (``StopResult.profile_zone``).
_ZONE_LABELS: dict[int | str, str] = {3: "nominal", 2: "braking", 1: "linear"}


def stop_latency(s: BenchSettings, step: Step) -> list[StopLatencyRow]:
    """The paper's limiter (stateless: no rate limiters) on the paper's stops, per zone."""
    from velfence.mechanisms.cospm import PAPER_STOPS, Q_AUX
    from velfence.shaping.profiles import ThreeZoneBraking
    from velfence.shaping.stops import StopLimiter

    prof = ThreeZoneBraking.from_actuator_limits(gain=100, max_speed=2, max_acceleration=20)
    rng = np.random.default_rng(s.seed + 1)
    rows: list[StopLatencyRow] = []
    for method in ("nearest", "exact"):
        step(f"latency: joint-stop limiter, {method}")
        lim = StopLimiter(PAPER_STOPS, profile=prof, transform=Q_AUX, method=method)
        pools: dict[str, Pool] = {}
        for _ in range(s.stop_candidates):
            q = np.array([rng.uniform(-1.0, 1.7), rng.uniform(-1.2, 0.8), rng.uniform(-1, 1)])
            th = Q_AUX.T @ q
            v = rng.normal(size=3)
            r = lim.explain(th, v)
            name = "outside" if r.delta < 0 else f"{r.profile_zone} " + _ZONE_LABELS[r.profile_zone]
            pool = pools.setdefault(name, [])
            if len(pool) < 64:
                pool.append((th, v))
        for zone in sorted(pools):
            pool = pools[zone]
            t = time_calls(lim.shape, pool, calls=s.calls, warmup=s.warmup)
            rows.append(StopLatencyRow(**as_fields(t), method=method, zone=zone, states=len(pool)))
    return rows


def _batch_states(
    poly: ConvexPolygon, n: int, rng: np.random.Generator
) -> tuple[FloatArray, FloatArray]:
    """Positions uniform in the bounding box grown by 10 % (5 % per side), normal commands."""
    lo = poly.corners.min(axis=0)
    hi = poly.corners.max(axis=0)
    grow = 0.05 * (hi - lo)
    P = rng.uniform(lo - grow, hi + grow, (n, 2))
    return P, rng.standard_normal((n, 2))


def batch(s: BenchSettings, numba_ok: bool, step: Step) -> list[BatchRow]:
    """Throughput of :meth:`PolygonShaper.shape_batch`, with numba (if installed) and without."""
    rows: list[BatchRow] = []
    rng = np.random.default_rng(s.seed + 1)
    for edges in s.batch_edges:
        poly = regular_polygon(edges)
        P, V = _batch_states(poly, s.batch_n, rng)
        for method in METHODS:
            if numba_ok:
                step(f"batch: {edges}-gon, {method}, numba, N={s.batch_n}")
                fast = shaper(poly, method, s, accelerate=True)
                t0 = time.perf_counter()
                fast.shape_batch(P[:16], V[:16])  # compiles on the first call of the process
                compile_s = time.perf_counter() - t0
                fast.shape_batch(P, V)  # warm caches and the thread pool
                times = []
                for _ in range(s.batch_repeats):
                    t0 = time.perf_counter()
                    fast.shape_batch(P, V)
                    times.append(time.perf_counter() - t0)
                med = float(np.median(times))
                rows.append(
                    BatchRow(
                        edges,
                        method,
                        "numba",
                        s.batch_n,
                        s.batch_repeats,
                        compile_s,
                        med,
                        s.batch_n / med,
                        s.batch_n / min(times),
                    )
                )
            step(f"batch: {edges}-gon, {method}, python, N={s.python_n}")
            slow = shaper(poly, method, s, accelerate=False)
            Ps, Vs = P[: s.python_n], V[: s.python_n]
            slow.shape_batch(Ps[:16], Vs[:16])
            t0 = time.perf_counter()
            slow.shape_batch(Ps, Vs)
            dt = time.perf_counter() - t0
            rows.append(
                BatchRow(
                    edges,
                    method,
                    "python",
                    s.python_n,
                    1,
                    0.0,
                    dt,
                    s.python_n / dt,
                    s.python_n / dt,
                )
            )
    return rows
