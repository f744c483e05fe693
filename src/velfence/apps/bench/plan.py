"""The expected cost of every step of a benchmark run, so that its progress follows the work.

A run calls its progress hook once before each step (a polygon's latency, one QP baseline, one
batch size, ...). The steps differ by four orders of magnitude: a latency step of the quick run
takes 0.1 s, the first numba batch of the exact law half a minute when numba compiles its
kernels (nothing cached yet) and 0.2 s when it loads them from its cache. Counting the steps
equally put the remaining-time estimate off by a factor of 2 to 5; :func:`step_plan` gives each
step its expected seconds instead, and :class:`Steps` reports the fraction of the expected
seconds done.

A step's cost is ``fixed + per_call * calls``: ``calls`` is what the settings make the step do
(timed calls over its zones, batch rows, candidate states), the two constants were measured
once. The fixed parts are the quick run's steps with numba's cache warm (2 cores, load about 4,
2026-12-08); the per-call parts are a call's wall time in such a run (the shaper's median plus
the timing loop, a QP solve, a batch row), so that the full run, a few hundred times the calls,
is weighted by its calls. Three places compile numba kernels on a cold cache: the 2-D batch of
each method and the n-D per-call and batch kernels (3 s, 27 s, 20 s and 9 s measured; warm, they
load in well under a second). Whether the cache is cold is learnt from the first of them: when
it ends faster than a third of its compile time, the cache was warm and the later compile steps
are counted warm.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from velfence.apps.bench.cases import filter as filter_cases
from velfence.apps.bench.cases import polytope as polytope_cases
from velfence.apps.bench.cases import redundancy, shaping
from velfence.apps.bench.settings import BenchSettings

__all__ = ["Progress", "StepCost", "Steps", "expected_seconds", "step_plan"]

#: ``progress(message, fraction_done)``, fraction in [0, 1].
Progress = Callable[[str, float], None]

#: Zones timed per latency or QP step (five of the 2-D shapers, up to six of the others).
_ZONES_2D = 5
_ZONES_ND = 6
#: Compile seconds of a cold numba cache (measured, see the module docstring).
_COMPILE_2D = {"patent": 4.2, "exact": 31.0}
_COMPILE_ND_CALL = 24.0
_COMPILE_ND_BATCH = 16.0


@dataclass(frozen=True)
class StepCost:
    """One step of a run and its expected seconds.

    Attributes:
        prefix: How the step's progress message starts (e.g. ``"latency: 8-gon, exact"``).
        seconds: Expected seconds with numba's cache warm.
        compile: Extra seconds when numba compiles the kernels in this step (cold cache).
    """

    prefix: str
    seconds: float
    compile: float = 0.0


def _nd_batch_calls(s: BenchSettings, n: int) -> int:
    """``shape_batch`` calls of one n-D numba batch size: a warm one and ``reps``, two ways."""
    reps = max(s.batch_repeats, min(101, 100_000 // n))
    return 2 * (reps + 1)


def step_plan(s: BenchSettings, *, numba_ok: bool, qp_ok: bool, mink_ok: bool) -> list[StepCost]:
    """The steps of one run, in order, with their expected cost (module docstring).

    Args:
        s: The settings.
        numba_ok: Whether numba is installed (the numba batch steps).
        qp_ok: Whether qpsolvers and daqp are installed (the QP steps).
        mink_ok: Whether mink is installed (the filter's mink steps).

    Returns:
        One :class:`StepCost` per call of the progress hook before the final ``"done"``.
    """
    out = [StepCost("states and timer overhead", 0.2)]
    for edges in s.latency_edges:
        for method in shaping.METHODS:
            setup = 6e-4 * edges**2 if method == "exact" else 0.0  # the exact law's tables
            out.append(
                StepCost(f"latency: {edges}-gon, {method}", 0.1 + setup + 4e-6 * s.calls * 5)
            )
    if qp_ok:
        for edges in s.latency_edges:
            out.append(StepCost(f"QP baseline: {edges}-gon", 0.6 + 60e-6 * s.calls * _ZONES_2D))
    first = True  # numba's first batch: its thread pool starts, its kernels load or compile
    for edges in s.batch_edges:
        for method in shaping.METHODS:
            if numba_ok:
                rows = s.batch_n * (s.batch_repeats + 1)
                out.append(
                    StepCost(
                        f"batch: {edges}-gon, {method}, numba",
                        0.05 + (0.9 if first and method == "patent" else 0.0) + 60e-9 * rows,
                        _COMPILE_2D[method] if first else 0.0,
                    )
                )
            out.append(StepCost(f"batch: {edges}-gon, {method}, python", 50e-6 * s.python_n))
        first = False
    for method in ("nearest", "exact"):
        out.append(
            StepCost(
                f"latency: joint-stop limiter, {method}",
                150e-6 * s.stop_candidates + 5e-6 * s.calls * 4,
            )
        )
    cycle_calls = max(50, s.calls // 50)
    for arm in redundancy.ARMS:
        for n_obs in redundancy.obstacle_counts(s):
            out.append(StepCost(f"control cycle: {arm}, {n_obs} ", 0.4 + 1e-3 * cycle_calls))
    controller_calls = max(200, s.calls // 20)
    out.append(StepCost("cobot path following", 0.9 + 40e-6 * controller_calls))
    out.append(StepCost("resolved rate (PUMA 560)", 1.5 + 5e-6 * controller_calls))
    for k, case in enumerate(polytope_cases.CASES):
        out.append(
            StepCost(
                f"latency: PolytopeShaper, {case}",
                0.6 + 8e-6 * s.calls * _ZONES_ND,
                _COMPILE_ND_CALL if k == 0 else 0.0,
            )
        )
    if qp_ok:
        for case in polytope_cases.CASES:
            out.append(
                StepCost(f"QP baseline: PolytopeShaper, {case}", 0.95 + 60e-6 * s.calls * _ZONES_ND)
            )
    for k, case in enumerate(polytope_cases.CASES):
        if numba_ok:
            for j, n in enumerate(s.nd_batch_n):
                calls = _nd_batch_calls(s, n)
                out.append(
                    StepCost(
                        f"batch: PolytopeShaper, {case}, numba, N={n}",
                        calls * (5e-3 + 150e-9 * n),
                        _COMPILE_ND_BATCH if k == 0 and j == 0 else 0.0,
                    )
                )
        out.append(
            StepCost(f"batch: PolytopeShaper, {case}, python", 0.005 + 250e-6 * s.nd_python_n)
        )
    filter_calls = s.filter_calls * _ZONES_ND
    for mode in filter_cases.MODES:
        joint = mode == "joint"
        per_call = 20e-6 * (1 + joint)  # joint mode also times the row building alone
        out.append(StepCost(f"safety filter: 7-DoF, {mode} mode", 0.85 + per_call * filter_calls))
        if joint:
            out.append(
                StepCost("safety filter: 7-DoF, joint mode, dt", 0.45 + 15e-6 * filter_calls)
            )
        if qp_ok:
            out.append(
                StepCost(
                    f"safety filter: 7-DoF, {mode} mode, QP peers", 0.9 + 300e-6 * filter_calls
                )
            )
        if mink_ok:
            out.append(
                StepCost(f"safety filter: 7-DoF, {mode} mode, mink", 0.8 + 250e-6 * filter_calls)
            )
    return out


def expected_seconds(plan: list[StepCost], *, cold: bool = True) -> float:
    """The expected seconds of a whole run.

    Args:
        plan: From :func:`step_plan`.
        cold: Whether numba compiles its kernels (no cache yet).

    Returns:
        The sum of the steps' expected seconds.
    """
    return sum(c.seconds + (c.compile if cold else 0.0) for c in plan)


class Steps:
    """Progress bookkeeping of a run: ``progress(message, fraction of the expected seconds)``.

    Args:
        progress: The run's hook, or None.
        plan: The steps, from :func:`step_plan`; a step beyond the plan counts nothing.
        clock: Seconds (``time.perf_counter``; a test gives its own).
    """

    def __init__(
        self,
        progress: Progress | None,
        plan: list[StepCost],
        *,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.progress = progress
        self.plan = list(plan)
        self.clock = clock
        self.done = 0
        self.cold = True  # a fresh install's first run; learnt at the first compile step
        self._learnt = False
        self._started = 0.0

    def _cost(self, c: StepCost) -> float:
        return c.seconds + (c.compile if self.cold else 0.0)

    def fraction(self) -> float:
        """The expected seconds of the steps done over those of the whole run."""
        total = sum(self._cost(c) for c in self.plan)
        done = sum(self._cost(c) for c in self.plan[: self.done])
        return min(1.0, done / total) if total > 0 else 0.0

    def __call__(self, message: str) -> None:
        """Report the fraction done, then count the step named ``message`` as started."""
        now = self.clock()
        if 0 < self.done <= len(self.plan) and not self._learnt:
            last = self.plan[self.done - 1]
            if last.compile > 0.0:  # the first compile step has ended: was the cache cold?
                self.cold = now - self._started > last.seconds + last.compile / 3.0
                self._learnt = True
        if self.progress is not None:
            self.progress(message, self.fraction())
        self._started = now
        self.done += 1
