"""Run every benchmark family and assemble the :class:`~velfence.apps.bench.report.BenchReport`."""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Sequence

from velfence._validate import check_flag
from velfence.apps.bench.cases import controllers, peers, redundancy, shaping
from velfence.apps.bench.cases import filter as filter_cases
from velfence.apps.bench.cases import polytope as polytope_cases
from velfence.apps.bench.machine import machine_info
from velfence.apps.bench.plan import Progress, Steps, step_plan
from velfence.apps.bench.report import BenchReport
from velfence.apps.bench.rows import (
    BatchRow,
    FilterRow,
    PolytopeLatencyRow,
    PolytopeQPRow,
    QPRow,
    TargetCheck,
    WorstZone,
)
from velfence.apps.bench.settings import (
    AGREEMENT_TARGET,
    FILTER_MEDIAN_TARGET_US,
    FILTER_P99_TARGET_US,
    LATENCY_TARGET_US,
    POLYTOPE_BOX_TARGET_US,
    POLYTOPE_FACETS_TARGET_US,
    THROUGHPUT_TARGET,
    BenchSettings,
)
from velfence.apps.bench.timing import timer_overhead_ns
from velfence.errors import InvalidParameter

__all__ = ["Progress", "nd_targets", "run_benchmarks", "run_settings", "targets"]


def _check_progress(progress: object) -> None:
    if progress is not None and not callable(progress):
        raise InvalidParameter(
            f"progress: expected a callable progress(message, fraction) or None, got "
            f"{type(progress).__name__}"
        )


def targets(
    worst: Sequence[WorstZone], qp: Sequence[QPRow], batch: Sequence[BatchRow]
) -> list[TargetCheck]:
    """The project's timing targets, measured (reported, never asserted).

    Args:
        worst: Slowest zone per (polygon, method): the 8-gon rows give the latency target.
        qp: The QP rows: the largest difference gives the agreement target.
        batch: The batch rows: the numba rows give the throughput target.

    Returns:
        One check per target row.
    """
    out: list[TargetCheck] = []
    for w in worst:
        if w.edges == 8:
            out.append(
                TargetCheck(
                    f"8-edge `shape` median, worst zone ({w.zone}), {w.method}",
                    f"≤ {LATENCY_TARGET_US:g} µs",
                    w.median_us,
                    "µs",
                    w.median_us <= LATENCY_TARGET_US,
                )
            )
    if qp:
        err = max(max(r.qpsolvers_max_error, r.daqp_max_error) for r in qp)
        out.append(
            TargetCheck(
                "exact law vs QP (qpsolvers and daqp), max ‖Δv‖∞ over all benchmark states",
                f"≤ {AGREEMENT_TARGET:g}",
                err,
                "units/s",
                err <= AGREEMENT_TARGET,
            )
        )
    for b in batch:
        if b.backend == "numba":
            out.append(
                TargetCheck(
                    f"`shape_batch` {b.edges}-gon, {b.method}, numba, N={b.n}",
                    f"≥ {THROUGHPUT_TARGET / 1e6:g} M states/s",
                    b.states_per_s / 1e6,
                    "M states/s",
                    b.states_per_s >= THROUGHPUT_TARGET,
                )
            )
    return out


def nd_targets(
    polytope: Sequence[PolytopeLatencyRow],
    polytope_qp: Sequence[PolytopeQPRow],
    filter_rows: Sequence[FilterRow],
) -> list[TargetCheck]:
    """The n-D law's and the safety filter's targets, measured (reported, never asserted).

    Args:
        polytope: The :class:`PolytopeShaper` latency rows: the box's three-facet corner row and
            the icosahedron's slowest zone give the latency targets.
        polytope_qp: Its QP rows: the largest difference gives the agreement target.
        filter_rows: The safety-filter rows: the slowest joint-mode zone (continuous time)
            gives the median and p99 targets, the QP rows the agreement target.

    Returns:
        One check per target row (none for a family without rows).
    """
    out: list[TargetCheck] = []
    box = [r for r in polytope if r.case == polytope_cases.CASES[0]]
    box = [r for r in box if r.zone == polytope_cases.BOX_CORNER]
    for r in box:
        out.append(
            TargetCheck(
                f"`PolytopeShaper.shape` 3-D box, {r.zone}, median",
                f"≤ {POLYTOPE_BOX_TARGET_US:g} µs",
                r.median_us,
                "µs",
                r.median_us <= POLYTOPE_BOX_TARGET_US,
            )
        )
    ico = polytope_cases.worst(polytope, polytope_cases.CASES[1])
    if ico is not None:
        out.append(
            TargetCheck(
                f"`PolytopeShaper.shape` {ico.case} ({ico.facets} facets), worst zone "
                f"({ico.zone}), median",
                f"≤ {POLYTOPE_FACETS_TARGET_US:g} µs",
                ico.median_us,
                "µs",
                ico.median_us <= POLYTOPE_FACETS_TARGET_US,
            )
        )
    if polytope_qp:
        err = max(max(r.qpsolvers_max_error, r.daqp_max_error) for r in polytope_qp)
        out.append(
            TargetCheck(
                "n-D exact law vs QP on its bound rows (qpsolvers and daqp), max ‖Δv‖∞",
                f"≤ {AGREEMENT_TARGET:g}",
                err,
                "units/s",
                err <= AGREEMENT_TARGET,
            )
        )
    joint = [r for r in filter_rows if r.mode == "joint" and r.route == filter_cases.ROUTE_VF]
    if joint:
        slow = max(joint, key=lambda r: r.median_us)
        out.append(
            TargetCheck(
                f"`SafetyFilter.filter` 7-DoF, worst zone ({slow.zone}), median",
                f"≤ {FILTER_MEDIAN_TARGET_US:g} µs",
                slow.median_us,
                "µs",
                slow.median_us <= FILTER_MEDIAN_TARGET_US,
            )
        )
        tail = max(joint, key=lambda r: r.p99_us)
        out.append(
            TargetCheck(
                f"`SafetyFilter.filter` 7-DoF, worst zone ({tail.zone}), p99",
                f"≤ {FILTER_P99_TARGET_US:g} µs",
                tail.p99_us,
                "µs",
                tail.p99_us <= FILTER_P99_TARGET_US,
            )
        )
    same = [r for r in filter_rows if not math.isnan(r.max_error)]
    if same:
        err = max(r.max_error for r in same)
        out.append(
            TargetCheck(
                "`SafetyFilter` vs QP on its own rows (qpsolvers and daqp), max ‖Δq̇‖∞",
                f"≤ {AGREEMENT_TARGET:g}",
                err,
                "rad/s",
                err <= AGREEMENT_TARGET,
            )
        )
    return out


def run_benchmarks(*, quick: bool = False, progress: Progress | None = None) -> BenchReport:
    """Run every benchmark and return the report (timings are reported, never asserted).

    Args:
        quick: Small sizes and few repeats (a few seconds, for smoke tests); the numbers are
            then only indicative.
        progress: Called as ``progress(message, fraction_done)`` before each step, with
            ``fraction_done`` in [0, 1] the share of the run's expected seconds done (each step
            weighted by its expected cost, :mod:`velfence.apps.bench.plan`), and once with
            ``("done", 1.0)`` at the end.

    Returns:
        The :class:`~velfence.apps.bench.report.BenchReport`.

    Raises:
        InvalidParameter: ``quick`` is not a boolean or ``progress`` is not callable.
    """
    quick = check_flag("quick", quick)
    _check_progress(progress)
    return run_settings(BenchSettings.make(quick=quick), progress=progress)


def run_settings(s: BenchSettings, *, progress: Progress | None = None) -> BenchReport:
    """:func:`run_benchmarks` with explicit settings, e.g. a tiny configuration for tests.

    Args:
        s: The settings (:class:`BenchSettings` checks its own fields).
        progress: As for :func:`run_benchmarks`.

    Returns:
        The :class:`~velfence.apps.bench.report.BenchReport`.

    Raises:
        InvalidParameter: ``s`` is not a :class:`BenchSettings` or ``progress`` is not callable.
    """
    if not isinstance(s, BenchSettings):
        raise InvalidParameter(
            f"s: expected a BenchSettings (e.g. BenchSettings.make(quick=True)), got "
            f"{type(s).__name__}"
        )
    _check_progress(progress)
    numba_ok = importlib.util.find_spec("numba") is not None
    qp_ok = all(importlib.util.find_spec(m) is not None for m in ("qpsolvers", "daqp"))
    notes: list[str] = []
    if not numba_ok:
        notes.append("numba is not installed: the numba batch rows are skipped.")
    if not qp_ok:
        notes.append("qpsolvers or daqp is not installed: the QP baseline is skipped.")
    mink_ok = filter_cases.mink_ok()
    step = Steps(progress, step_plan(s, numba_ok=numba_ok, qp_ok=qp_ok, mink_ok=mink_ok))

    step("states and timer overhead")
    pools = shaping.zone_pools(s, notes)
    overhead = timer_overhead_ns()
    latency, worst = shaping.latency(s, pools, step)
    qp = peers.qp(s, pools, latency, step) if qp_ok else []
    batch = shaping.batch(s, numba_ok, step)
    stops = shaping.stop_latency(s, step)
    control = redundancy.control_cycles(s, step, qp_ok)
    steps = controllers.cobot_steps(s, step) + controllers.resolved_rate_steps(s, step)
    nd_pools = polytope_cases.zone_pools(s, notes)
    nd = polytope_cases.latency(s, nd_pools, step)
    nd_qp = polytope_cases.qp(s, nd_pools, nd, step) if qp_ok else []
    nd_batch = polytope_cases.batch(s, numba_ok, step)
    filt = filter_cases.cycles(s, step, qp_ok, notes)
    if progress is not None:
        progress("done", 1.0)
    return BenchReport(
        settings=s,
        machine=machine_info(),
        timer_overhead_ns=overhead,
        latency=tuple(latency),
        worst=tuple(worst),
        qp=tuple(qp),
        batch=tuple(batch),
        targets=tuple(targets(worst, qp, batch) + nd_targets(nd, nd_qp, filt)),
        notes=tuple(notes),
        stops=tuple(stops),
        control=tuple(control),
        steps=tuple(steps),
        polytope=tuple(nd),
        polytope_qp=tuple(nd_qp),
        polytope_batch=tuple(nd_batch),
        filter=tuple(filt),
    )
