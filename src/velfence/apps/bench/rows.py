"""The rows of a benchmark report: one record per table row, built on :class:`Latency`.

Every per-call row *is* a :class:`~velfence.apps.bench.timing.Latency` (``calls``, ``median_us``,
``p99_us``, ``max_us``) plus the labels of what was timed; the comparison rows (:class:`QPRow`),
the throughput rows (:class:`BatchRow`) and the target checks have fields of their own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from velfence.apps.bench.timing import Latency

__all__ = [
    "BatchRow",
    "ControlCycleRow",
    "FilterRow",
    "Latency",
    "LatencyRow",
    "PolytopeBatchRow",
    "PolytopeLatencyRow",
    "PolytopeQPRow",
    "QPRow",
    "StepRow",
    "StopLatencyRow",
    "TargetCheck",
    "WorstZone",
]


@dataclass(frozen=True, kw_only=True)
class LatencyRow(Latency):
    """Latency of single :meth:`PolygonShaper.shape` calls for one (polygon, method, zone).

    Attributes:
        calls: Timed calls.
        median_us: Median latency, µs.
        p99_us: 99th percentile, µs.
        max_us: Largest latency, µs.
        edges: Number of polygon edges.
        method: ``"edge-scaling"`` (the patent's law) or ``"exact"``.
        zone: Zone of every timed state (as the method itself classifies it).
        states: Distinct states cycled through.
    """

    edges: int
    method: str
    zone: str
    states: int


@dataclass(frozen=True, kw_only=True)
class WorstZone(LatencyRow):
    """The row of the zone with the largest median latency for one (polygon, method).

    Attributes:
        calls: Timed calls.
        median_us: Median latency, µs.
        p99_us: 99th percentile, µs.
        max_us: Largest latency, µs.
        edges: Number of polygon edges.
        method: ``"edge-scaling"`` (the patent's law) or ``"exact"``.
        zone: The slowest zone.
        states: Distinct states cycled through.
    """


@dataclass(frozen=True, kw_only=True)
class StopLatencyRow(Latency):
    """Latency of single :meth:`StopLimiter.shape` calls (Lê et al. 2024's limiter, 3 joints).

    Attributes:
        method: ``"nearest"`` (faithful) or ``"exact"``.
        zone: Profile zone of the timed states (``3 nominal``, ``2 braking``, ``1 linear``,
            ``outside``).
        states: Distinct states cycled through.
    """

    method: str
    zone: str
    states: int


@dataclass(frozen=True, kw_only=True)
class ControlCycleRow(Latency):
    """One control cycle of obstacle avoidance (US 5,150,026) for an arm and an obstacle count.

    Attributes:
        arm: ``"planar 3R"``, ``"7-DoF"`` or ``"planar 20R"``.
        links: Number of links.
        obstacles: Number of obstacles.
        method: ``"configuration-control"`` or ``"velocity-damper-qp"``.
        active: Mean number of active constraint rows over the timed states.
    """

    arm: str
    links: int
    obstacles: int
    method: str
    active: float


@dataclass(frozen=True, kw_only=True)
class StepRow(Latency):
    """One step of a controller other than a shaper (cobot path following, resolved rate).

    Attributes:
        family: Source and controller, e.g. ``"cobot (Gillespie 1999)"``.
        step: What one call does.
        baseline: Name of the row this one is compared with (``""`` for none).
        ratio: ``median_us`` over the baseline's median (``nan`` without a baseline).
    """

    family: str
    step: str
    baseline: str = ""
    ratio: float = math.nan


@dataclass(frozen=True)
class QPRow:
    """The exact law against the same QP, for one (polygon, zone), on the same states.

    Latencies in µs. Ratios are QP time / velfence time (> 1: velfence is faster). ``build_*``
    is the NumPy construction of ``G, h`` from a state, which the QP timings do *not* include.
    Errors are the largest ``max(|exact - QP|)`` over the states, workspace units per second.

    Attributes:
        edges: Number of polygon edges (= QP constraint rows).
        zone: Zone of the states (exact-law classification).
        states: Distinct states.
        calls: Timed calls per route.
        velfence_median_us: ``PolygonShaper(method="exact").shape`` median.
        velfence_p99_us: Its 99th percentile.
        qpsolvers_median_us: ``qpsolvers.solve_qp(..., solver="daqp")`` median.
        qpsolvers_p99_us: Its 99th percentile.
        daqp_median_us: ``daqp.solve`` median.
        daqp_p99_us: Its 99th percentile.
        build_median_us: Median time to build ``G, h`` for one state.
        qpsolvers_ratio_median: ``qpsolvers_median_us / velfence_median_us``.
        qpsolvers_ratio_p99: ``qpsolvers_p99_us / velfence_p99_us``.
        daqp_ratio_median: ``daqp_median_us / velfence_median_us``.
        daqp_ratio_p99: ``daqp_p99_us / velfence_p99_us``.
        qpsolvers_max_error: Largest difference to the qpsolvers answer.
        daqp_max_error: Largest difference to the daqp answer.
    """

    edges: int
    zone: str
    states: int
    calls: int
    velfence_median_us: float
    velfence_p99_us: float
    qpsolvers_median_us: float
    qpsolvers_p99_us: float
    daqp_median_us: float
    daqp_p99_us: float
    build_median_us: float
    qpsolvers_ratio_median: float
    qpsolvers_ratio_p99: float
    daqp_ratio_median: float
    daqp_ratio_p99: float
    qpsolvers_max_error: float
    daqp_max_error: float


@dataclass(frozen=True)
class BatchRow:
    """Throughput of :meth:`PolygonShaper.shape_batch` for one (polygon, method, back-end).

    Attributes:
        edges: Number of polygon edges.
        method: ``"patent"`` or ``"exact"``.
        backend: ``"numba"`` (``accelerate=True``) or ``"python"`` (``accelerate=False``).
        n: Rows per call.
        repeats: Timed calls.
        compile_s: First (compiling) call, seconds; 0 for the Python back-end.
        median_s: Median wall time of one call, seconds.
        states_per_s: ``n / median_s``.
        best_states_per_s: ``n / min(call time)``.
    """

    edges: int
    method: str
    backend: str
    n: int
    repeats: int
    compile_s: float
    median_s: float
    states_per_s: float
    best_states_per_s: float


@dataclass(frozen=True)
class TargetCheck:
    """One timing target of the benchmark suite, measured (reported, never asserted).

    Attributes:
        name: What is checked.
        target: The target, as text.
        measured: The measured value in the target's unit.
        unit: Unit of ``measured``.
        passed: Whether the target is met.
    """

    name: str
    target: str
    measured: float
    unit: str
    passed: bool


@dataclass(frozen=True, kw_only=True)
class PolytopeLatencyRow(Latency):
    """Latency of single :meth:`PolytopeShaper.shape` calls (exact law) for one (case, zone).

    Attributes:
        calls: Timed calls.
        median_us: Median latency, µs.
        p99_us: 99th percentile, µs.
        max_us: Largest latency, µs.
        case: The polytope, e.g. ``"3-D box"``.
        dim: Dimension n.
        facets: Number of facets m.
        zone: Zone of every timed state (the shaper's classification), or a narrower label
            such as ``"outside-corner, 3 violated"``.
        states: Distinct states cycled through.
        rows: Mean number of bounded facets (QP constraint rows) over the states.
    """

    case: str
    dim: int
    facets: int
    zone: str
    states: int
    rows: float


@dataclass(frozen=True)
class PolytopeQPRow:
    """The n-D exact law against the same QP (its own bound rows), for one (case, zone).

    Latencies in µs; ratios are QP time / velfence time (> 1: velfence is faster). The QP
    timings are the solver call alone, with the rows (:meth:`PolytopeShaper.bound_rows`)
    prebuilt. Errors are the largest ``max(|velfence - QP|)`` over the states.

    Attributes:
        case: The polytope.
        dim: Dimension n.
        facets: Number of facets m.
        zone: Zone of the states.
        states: Distinct states.
        calls: Timed calls per route.
        rows: Mean number of constraint rows.
        velfence_median_us: ``PolytopeShaper.shape`` median.
        velfence_p99_us: Its 99th percentile.
        qpsolvers_median_us: ``qpsolvers.solve_qp(..., solver="daqp")`` median.
        qpsolvers_p99_us: Its 99th percentile.
        daqp_median_us: ``daqp.solve`` median.
        daqp_p99_us: Its 99th percentile.
        qpsolvers_ratio_median: ``qpsolvers_median_us / velfence_median_us``.
        daqp_ratio_median: ``daqp_median_us / velfence_median_us``.
        qpsolvers_max_error: Largest difference to the qpsolvers answer.
        daqp_max_error: Largest difference to the daqp answer.
    """

    case: str
    dim: int
    facets: int
    zone: str
    states: int
    calls: int
    rows: float
    velfence_median_us: float
    velfence_p99_us: float
    qpsolvers_median_us: float
    qpsolvers_p99_us: float
    daqp_median_us: float
    daqp_p99_us: float
    qpsolvers_ratio_median: float
    daqp_ratio_median: float
    qpsolvers_max_error: float
    daqp_max_error: float


@dataclass(frozen=True)
class PolytopeBatchRow:
    """Throughput of :meth:`PolytopeShaper.shape_batch` for one (case, back-end, N).

    Attributes:
        case: The polytope.
        dim: Dimension n.
        facets: Number of facets m.
        backend: ``"numba"`` (``accelerate=True``, all numba threads), ``"numba, 1 thread"``
            or ``"python"`` (``accelerate=False``).
        n: Rows per call.
        repeats: Timed calls.
        compile_s: First (compiling or cache-loading) call, seconds; 0 for the Python back-end.
        median_s: Median wall time of one call, seconds.
        rows_per_s: ``n / median_s``.
        best_rows_per_s: ``n / min(call time)``.
        ns_per_row: ``1e9 * median_s / n``.
    """

    case: str
    dim: int
    facets: int
    backend: str
    n: int
    repeats: int
    compile_s: float
    median_s: float
    rows_per_s: float
    best_rows_per_s: float
    ns_per_row: float


@dataclass(frozen=True, kw_only=True)
class FilterRow(Latency):
    """One cycle of the joint-space safety filter, or of a peer on the same problem.

    Attributes:
        calls: Timed calls.
        median_us: Median latency, µs.
        p99_us: 99th percentile, µs.
        max_us: Largest latency, µs.
        mode: ``"joint"`` (joint-velocity command), ``"twist"`` (TCP velocity) or either with
            the control period, e.g. ``"joint, dt 4 ms"``.
        route: What was timed: ``"velfence SafetyFilter"``, ``"qpsolvers+daqp (same rows)"``,
            ``"daqp (same rows)"`` or ``"mink solve_ik"``.
        zone: Zone of the states (the filter's classification) or ``"all"``.
        states: Distinct states cycled through.
        rows: Mean number of constraint rows.
        ratio: ``median_us`` over the velfence row's of the same mode and zone (1 for it).
        max_error: Largest ``max(|velfence - route|)`` over the states, rad/s (``nan`` where the
            route solves a different problem, e.g. mink).
    """

    mode: str
    route: str
    zone: str
    states: int
    rows: float
    ratio: float = math.nan
    max_error: float = math.nan
