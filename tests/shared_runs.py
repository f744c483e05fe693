"""Whole runs that several test files inspect, made once per pytest worker.

A reproduction takes seconds to minutes; its verdicts (the reproduction's tests), its figures
(the figure checker), its command line (exit codes, progress) used to be run once for each of
those files. :func:`reproduction` runs ``velfence.apps.reproduce.<name>.run`` once per worker,
with every figure it saves recorded (:func:`recording`); the tests that inspect the same run are
one unit of work under ``-n`` (``GROUPS`` in tests/conftest.py), so one worker makes it: one run
per test session.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

import pytest


def _figure_checks() -> ModuleType:
    path = Path(__file__).parent / "apps" / "viz" / "figure_checks.py"
    spec = importlib.util.spec_from_file_location("figure_checks", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: The figure checker (one copy: tests/apps/viz/figure_checks.py).
FIGURE_CHECKS = _figure_checks()


class Recorded(NamedTuple):
    """A run's report, its folder and the figures it saved (by file name)."""

    out: Path
    report: Any
    figures: Any


@contextmanager
def recording() -> Iterator[Any]:
    """Record every figure saved inside the block (the checker's ``record_figures``)."""
    with pytest.MonkeyPatch.context() as mp, FIGURE_CHECKS.record_figures(mp) as figures:
        yield figures


def recorded_run(run: Callable[[Path], Any], out: Path) -> Recorded:
    """``run(out)`` with its figures recorded."""
    with recording() as figures:
        report = run(out)
    return Recorded(out, report, figures)


def check_figures(run: Recorded) -> set[str]:
    """Every picture the run wrote passes the figure checker; the names of the pictures."""
    written = FIGURE_CHECKS.check_every(run.figures, run.out)
    assert written, "no figure written"
    return set(written)


_RUNS: dict[str, Recorded] = {}


def reproduction(name: str, base: Path) -> Recorded:
    """``velfence.apps.reproduce.<name>.run`` into ``base / name``, once per worker."""
    if name not in _RUNS:
        module = importlib.import_module(f"velfence.apps.reproduce.{name}")
        _RUNS[name] = recorded_run(module.run, base / name)
    return _RUNS[name]


_SCENARIOS: dict[str, Any] = {}


def scenario(name: str) -> Any:
    """The MuJoCo scenario ``name`` of ``velfence sim`` (its ``run()``), once per worker."""
    if name not in _SCENARIOS:
        from velfence.apps.cli import SIM_SCENARIOS

        module, _ = SIM_SCENARIOS[name]
        _SCENARIOS[name] = importlib.import_module(module).run()
    return _SCENARIOS[name]


def shared_scenario(monkeypatch: pytest.MonkeyPatch, name: str) -> Any:
    """Make ``velfence sim --scenario name`` simulate nothing: its ``run`` answers the worker's
    shared run of :func:`scenario` (the command still writes every figure and video)."""
    from velfence.apps.cli import SIM_SCENARIOS

    result = scenario(name)
    module = importlib.import_module(SIM_SCENARIOS[name][0])

    def run(*, on_step: Callable[[str, float], None] | None = None) -> Any:
        if on_step is not None:
            on_step(name, 1.0)
        return result

    monkeypatch.setattr(module, "run", run)
    return result


_BENCH: list[tuple[Any, list[tuple[str, float]]]] = []


def bench_quick() -> tuple[Any, list[tuple[str, float]]]:
    """The quick benchmark once per worker: the report and every progress call.

    The quick configuration (``BenchSettings.make(quick=True)``: the same families, polygons,
    cases and peers, the same code path as ``velfence bench --quick``) with fewer timed calls
    and smaller batches: the tests read the report's structure, never its timings, and the
    full quick run's extra calls only cost minutes of the suite.
    """
    if not _BENCH:
        import dataclasses

        from velfence.apps import bench
        from velfence.apps.bench import run

        settings = dataclasses.replace(
            bench.BenchSettings.make(quick=True),
            calls=20, warmup=1, states_per_zone=4, batch_n=1_000, batch_repeats=1,
            python_n=64, stop_candidates=2_000, nd_batch_n=(1_000,), nd_python_n=32,
            filter_calls=20, filter_states=2,
        )  # fmt: skip
        calls: list[tuple[str, float]] = []
        report = run.run_settings(settings, progress=lambda m, f: calls.append((m, f)))
        _BENCH.append((report, calls))
    return _BENCH[0]


def shared_bench(monkeypatch: pytest.MonkeyPatch) -> Any:
    """Make ``velfence bench --quick`` time nothing: ``run_benchmarks`` replays the worker's one
    quick run (:func:`bench_quick`) with its progress calls (the command still writes every
    file)."""
    from velfence.apps import bench

    report, calls = bench_quick()

    def run(*, quick: bool = False, progress: Callable[[str, float], None] | None = None) -> Any:
        assert quick, "only the quick run is shared"
        for what, fraction in calls:
            if progress is not None:
                progress(what, fraction)
        return report

    monkeypatch.setattr(bench, "run_benchmarks", run)
    return report
