r"""Benchmark cases against peer libraries: the exact law and the same QP.

The exact law's constraint set, every edge,

.. math::
    \min_x \|x - v\|^2 \;\text{s.t.}\; n_i\cdot x \ge b_i \quad (i = 1..n),

solved as a 2-variable QP through :func:`qpsolvers.solve_qp` (``solver="daqp"``) and through
``daqp.solve`` directly, on the states of the exact-law latency rows, with the ratios QP /
velfence and the largest difference between the answers.
"""

from __future__ import annotations

import ctypes
import functools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive, real_array
from velfence.apps.bench.cases import Step
from velfence.apps.bench.cases.shaping import Pool, Pools, regular_polygon, shaper
from velfence.apps.bench.rows import LatencyRow, QPRow
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import time_calls
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon

__all__ = ["qp", "qp_bounds"]


def qp_bounds(
    poly: ConvexPolygon, p: FloatArray, v: FloatArray, *, buffer: float, spring_gain: float
) -> FloatArray:
    r"""Right-hand sides ``b`` of the exact law's constraints ``n_i · x >= b_i``, every edge.

    ``b_i = -(\|v\| + R) d_i / d_{max}`` for ``d_i >= 0`` (for ``d_i >= d_max`` this far-edge row
    is what the kernel adds when needed, so including it always is harmless) and
    ``b_i = \min(k(-d_i), r_{max})`` for ``d_i < 0``, ``R`` the largest recovery bound (0 inside),
    ``r_max = k d_max``.

    Args:
        poly: The polygon.
        p: Position, shape (2,), workspace units.
        v: Command, shape (2,), workspace units per second.
        buffer: ``d_max``, workspace units.
        spring_gain: ``k``, 1/s.

    Returns:
        Shape (n,), workspace units per second.

    Raises:
        InvalidParameter: ``poly`` is not a :class:`~velfence.geometry.ConvexPolygon`, or
            ``buffer`` / ``spring_gain`` is not a positive (non-negative) number, or so small
            that the bounds overflow.
        InvalidInput: ``p`` or ``v`` is not a finite 2-vector.
    """
    if not isinstance(poly, ConvexPolygon):
        raise InvalidParameter(f"poly: expected a ConvexPolygon, got {type(poly).__name__}")
    p = real_array("p", p, (2,), what="position")
    v = real_array("v", v, (2,), what="command")
    buffer = check_positive("buffer", buffer)
    spring_gain = check_positive("spring_gain", spring_gain, allow_zero=True)
    out = _qp_bounds(poly, p, v, buffer, spring_gain)
    if not np.all(np.isfinite(out)):
        raise InvalidParameter(
            f"buffer: {buffer!r} is too small for this position and command: the bounds "
            "overflow; use a buffer of a sensible width (e.g. 0.2)"
        )
    return out


def _qp_bounds(
    poly: ConvexPolygon, p: FloatArray, v: FloatArray, buffer: float, spring_gain: float
) -> FloatArray:
    """:func:`qp_bounds` without the input checks (the timed QP build calls it)."""
    d = poly.signed_distances(p)
    rec = np.minimum(-spring_gain * d, spring_gain * buffer)
    big_r = float(rec[d < 0.0].max()) if np.any(d < 0.0) else 0.0
    with np.errstate(all="ignore"):  # qp_bounds reports an overflow, naming the cause
        scale = (math.hypot(float(v[0]), float(v[1])) + big_r) / buffer
        return np.where(d >= 0.0, -scale * d, rec)


def _qp_data(
    poly: ConvexPolygon, p: FloatArray, v: FloatArray, s: BenchSettings
) -> tuple[FloatArray, FloatArray]:
    """``G, h`` of the QP in qpsolvers form ``G x <= h``, from one state."""
    return -poly.normals, -_qp_bounds(poly, p, v, s.buffer, s.spring_gain)


def _max_error(fn: Any, pool: Sequence[tuple[FloatArray, FloatArray]], xs: list[Any]) -> float:
    err = 0.0
    for (p, v), x in zip(pool, xs, strict=True):
        if x is None:
            return math.inf
        err = max(err, float(np.max(np.abs(fn(p, v) - np.asarray(x)))))
    return err


def qp(s: BenchSettings, pools: Pools, latency: Sequence[LatencyRow], step: Step) -> list[QPRow]:
    """The exact law against qpsolvers and daqp on the exact rows' states, per (polygon, zone).

    Args:
        s: The settings.
        pools: The states of :func:`~velfence.apps.bench.cases.shaping.zone_pools`.
        latency: The exact-law latency rows of the same states (the ratios' denominators).
        step: The progress hook.

    Returns:
        One row per (polygon, zone) with states.
    """
    import daqp
    import qpsolvers

    by_key = {(r.edges, r.method, r.zone): r for r in latency}
    solve_qp = functools.partial(qpsolvers.solve_qp, solver="daqp")
    rows: list[QPRow] = []
    for edges in s.latency_edges:
        step(f"QP baseline: {edges}-gon")
        poly = regular_polygon(edges)
        exact = shaper(poly, "exact", s).shape
        G = np.array(-poly.normals)  # writable, C-contiguous copies: daqp needs both
        A = np.array(poly.normals)
        upper = np.full(edges, 1e30)
        sense = np.zeros(edges, dtype=ctypes.c_int)
        H = np.eye(2)
        for zone, pool in pools[edges, "exact"].items():
            if not pool:
                continue
            bounds = [
                qp_bounds(poly, p, v, buffer=s.buffer, spring_gain=s.spring_gain) for p, v in pool
            ]
            qs = [(H, -v, G, -b) for (_, v), b in zip(pool, bounds, strict=True)]
            ds = [(H, -v, A, upper, b, sense) for (_, v), b in zip(pool, bounds, strict=True)]
            x_qps = [solve_qp(*q) for q in qs]
            x_daqp = [daqp.solve(*d)[0] for d in ds]
            q_t = time_calls(solve_qp, qs, calls=s.calls, warmup=s.warmup)
            d_t = time_calls(daqp.solve, ds, calls=s.calls, warmup=s.warmup)
            build = _time_build(poly, pool, s)
            vf = by_key[edges, "exact", zone]
            rows.append(
                QPRow(
                    edges=edges,
                    zone=zone,
                    states=len(pool),
                    calls=s.calls,
                    velfence_median_us=vf.median_us,
                    velfence_p99_us=vf.p99_us,
                    qpsolvers_median_us=q_t.median_us,
                    qpsolvers_p99_us=q_t.p99_us,
                    daqp_median_us=d_t.median_us,
                    daqp_p99_us=d_t.p99_us,
                    build_median_us=build,
                    qpsolvers_ratio_median=q_t.median_us / vf.median_us,
                    qpsolvers_ratio_p99=q_t.p99_us / vf.p99_us,
                    daqp_ratio_median=d_t.median_us / vf.median_us,
                    daqp_ratio_p99=d_t.p99_us / vf.p99_us,
                    qpsolvers_max_error=_max_error(exact, pool, x_qps),
                    daqp_max_error=_max_error(exact, pool, x_daqp),
                )
            )
    return rows


def _time_build(poly: ConvexPolygon, pool: Pool, s: BenchSettings) -> float:
    """Median time to build ``G, h`` from one state, µs (no warm-up)."""
    args = [(poly, p, v, s) for p, v in pool]
    return time_calls(_qp_data, args, calls=s.calls, warmup=0).median_us
