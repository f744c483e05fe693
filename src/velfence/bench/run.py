"""Run every benchmark family and assemble the :class:`~velfence.bench.report.BenchReport`."""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Sequence

from velfence._validate import check_flag
from velfence.bench.cases import controllers, peers, redundancy, shaping
from velfence.bench.machine import machine_info
from velfence.bench.report import BenchReport
from velfence.bench.rows import BatchRow, QPRow, TargetCheck, WorstZone
from velfence.bench.settings import (
    AGREEMENT_TARGET,
    LATENCY_TARGET_US,
    THROUGHPUT_TARGET,
    BenchSettings,
)
from velfence.bench.timing import timer_overhead_ns
from velfence.errors import InvalidParameter

__all__ = ["Progress", "run_benchmarks", "run_settings", "targets"]

#: ``progress(message, fraction_done)``, fraction in [0, 1].
Progress = Callable[[str, float], None]


class _Steps:
    """Progress bookkeeping: ``progress(message, fraction done)``."""

    def __init__(self, progress: Progress | None, total: int) -> None:
        self.progress = progress
        self.total = max(1, total)
        self.done = 0

    def __call__(self, message: str) -> None:
        if self.progress is not None:
            self.progress(message, min(1.0, self.done / self.total))
        self.done += 1


def _check_progress(progress: object) -> None:
    if progress is not None and not callable(progress):
        raise InvalidParameter(
            f"progress: expected a callable progress(message, fraction) or None, got "
            f"{type(progress).__name__}"
        )


def _step_count(s: BenchSettings, *, numba_ok: bool, qp_ok: bool) -> int:
    """Steps of one run: the progress hook is called once before each."""
    n_latency = len(s.latency_edges)
    return (
        1  # states and timer overhead
        + len(shaping.METHODS) * n_latency  # latency per (polygon, method)
        + n_latency * qp_ok  # QP baseline per polygon
        + len(s.batch_edges) * len(shaping.METHODS) * (2 if numba_ok else 1)  # batch
        + 2  # joint-stop limiter, two methods
        + len(redundancy.ARMS) * len(redundancy.obstacle_counts(s))  # control cycles
        + 2  # cobot, resolved rate
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


def run_benchmarks(*, quick: bool = False, progress: Progress | None = None) -> BenchReport:
    """Run every benchmark and return the report (timings are reported, never asserted).

    Args:
        quick: Small sizes and few repeats (a few seconds, for smoke tests); the numbers are
            then only indicative.
        progress: Called as ``progress(message, fraction_done)`` before each step, with
            ``fraction_done`` in [0, 1], and once with ``("done", 1.0)`` at the end.

    Returns:
        The :class:`~velfence.bench.report.BenchReport`.

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
        The :class:`~velfence.bench.report.BenchReport`.

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
    step = _Steps(progress, _step_count(s, numba_ok=numba_ok, qp_ok=qp_ok))

    step("states and timer overhead")
    pools = shaping.zone_pools(s, notes)
    overhead = timer_overhead_ns()
    latency, worst = shaping.latency(s, pools, step)
    qp = peers.qp(s, pools, latency, step) if qp_ok else []
    batch = shaping.batch(s, numba_ok, step)
    stops = shaping.stop_latency(s, step)
    control = redundancy.control_cycles(s, step, qp_ok)
    steps = controllers.cobot_steps(s, step) + controllers.resolved_rate_steps(s, step)
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
        targets=tuple(targets(worst, qp, batch)),
        notes=tuple(notes),
        stops=tuple(stops),
        control=tuple(control),
        steps=tuple(steps),
    )
