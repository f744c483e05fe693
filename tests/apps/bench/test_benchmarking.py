"""The benchmark suite through its real code path: structure only, never timings.

Timing targets are reported by the benchmarks (docs/benchmarks.md), never asserted in tests: a
loaded machine must not fail the suite. The quick configuration runs once with fewer timed calls
(tests/shared_runs.py: the same families and cases as ``velfence bench --quick``, through
:func:`velfence.apps.bench.run.run_settings`) and its rows and Markdown are checked; a tiny one
(a few calls per row) runs each case family again on its own.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from shared_runs import bench_quick
from velfence.apps import bench as bm
from velfence.apps.bench import plan, run
from velfence.apps.bench.cases import controllers, peers, redundancy, shaping
from velfence.apps.bench.cases import filter as filter_cases
from velfence.apps.bench.cases.shaping import METHODS
from velfence.apps.bench.timing import Latency, latency_of, time_calls


@pytest.fixture(scope="module")
def report() -> bm.BenchReport:
    # The worker's one quick run, shared with `velfence bench --quick` (tests/shared_runs.py).
    rep, calls = bench_quick()
    fracs = [f for _, f in calls]
    assert fracs == sorted(fracs)
    assert all(0.0 <= f <= 1.0 for f in fracs)
    assert calls[-1] == ("done", 1.0)
    return rep


def test_settings_are_quick(report: bm.BenchReport) -> None:
    assert report.settings.quick
    assert report.settings.latency_edges == (4, 8, 32)


def test_latency_rows_cover_both_methods_and_every_polygon(report: bm.BenchReport) -> None:
    keys = {(r.edges, r.method) for r in report.latency}
    assert keys == {(e, m) for e in (4, 8, 32) for m in ("patent", "exact")}
    for e in (4, 8):  # every zone occurs in these polygons with the benchmark buffer
        for m in ("patent", "exact"):
            zones = {r.zone for r in report.latency if (r.edges, r.method) == (e, m)}
            assert zones == set(bm.ZONES)
    for r in report.latency:
        assert r.calls == report.settings.calls
        assert 0 < r.states <= report.settings.states_per_zone
        assert 0.0 < r.median_us <= r.p99_us <= r.max_us


def test_worst_zone_is_the_slowest_median(report: bm.BenchReport) -> None:
    assert len(report.worst) == 6
    for w in report.worst:
        medians = [
            r.median_us for r in report.latency if (r.edges, r.method) == (w.edges, w.method)
        ]
        assert w.median_us == max(medians)


def test_qp_rows_agree_with_the_exact_law(report: bm.BenchReport) -> None:
    pytest.importorskip("qpsolvers")
    pytest.importorskip("daqp")
    assert {q.edges for q in report.qp} == {4, 8, 32}
    for q in report.qp:
        assert math.isclose(q.qpsolvers_ratio_median, q.qpsolvers_median_us / q.velfence_median_us)
        assert math.isclose(q.daqp_ratio_p99, q.daqp_p99_us / q.velfence_p99_us)
        # Correctness, not timing: the closed form and the QP solve the same problem.
        assert q.qpsolvers_max_error <= bm.AGREEMENT_TARGET
        assert q.daqp_max_error <= bm.AGREEMENT_TARGET


def test_batch_rows(report: bm.BenchReport) -> None:
    backends = {b.backend for b in report.batch}
    assert "python" in backends
    for b in report.batch:
        assert b.edges in (8, 32)
        assert b.states_per_s > 0.0
        assert b.best_states_per_s >= b.states_per_s


def test_targets_are_reported_not_asserted(report: bm.BenchReport) -> None:
    names = [t.name for t in report.targets]
    assert sum("8-edge" in n for n in names) == 2
    assert all(isinstance(t.passed, bool) for t in report.targets)


def test_machine_description(report: bm.BenchReport) -> None:
    m = report.machine
    assert m.cpu
    assert m.logical_cores >= 1
    assert m.numpy != "not installed"
    assert m.python.startswith(("CPython", "PyPy"))


def test_to_dict_is_json_and_markdown_has_every_section(report: bm.BenchReport) -> None:
    d = json.loads(json.dumps(report.to_dict()))
    assert set(d) >= {"settings", "machine", "latency", "worst", "qp", "batch", "targets"}
    md = report.to_markdown()
    for heading in ("## Machine", "## Targets", "## Single-call latency", "## Batch throughput"):
        assert heading in md
    for block in md.split("\n\n"):  # every table row has as many cells as its header
        rows = [line for line in block.splitlines() if line.startswith("|")]
        if rows:
            assert {row.count("|") for row in rows} == {rows[0].count("|")}, block


def test_write_report_keeps_the_hand_written_preamble(
    report: bm.BenchReport, tmp_path: Path
) -> None:
    path = tmp_path / "bench.md"
    bm.write_report(report, path)
    assert path.read_text(encoding="utf-8").startswith(bm.DEFAULT_PREAMBLE.rstrip("\n"))
    text = path.read_text(encoding="utf-8")
    path.write_text(text.replace("# Benchmarks", "# My preamble"), encoding="utf-8")
    bm.write_report(report, path)
    again = path.read_text(encoding="utf-8")
    assert again.startswith("# My preamble")
    assert again.count(bm.GENERATED_MARKER) == 1


def test_qp_bounds_match_the_law() -> None:
    poly = bm.regular_polygon(4)  # square, inradius cos(pi/4); edge 3 faces +x
    h = math.cos(math.pi / 4)
    b = bm.qp_bounds(
        poly, np.array([h - 0.05, 0.0]), np.array([3.0, 4.0]), buffer=0.1, spring_gain=4.0
    )
    assert b[3] == pytest.approx(-5.0 * 0.05 / 0.1)  # buffer edge: -(|v| + 0) d / d_max
    out = bm.qp_bounds(
        poly, np.array([h + 0.5, 0.0]), np.array([0.0, 0.0]), buffer=0.1, spring_gain=4.0
    )
    assert out[3] == pytest.approx(0.4)  # recovery capped at k d_max


def test_qp_bounds_and_regular_polygon_refuse_bad_inputs_by_name() -> None:
    from velfence.apps.bench import qp_bounds, regular_polygon
    from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

    poly = regular_polygon(6)
    p, v = np.array([0.5, 0.2]), np.array([1.0, 0.3])
    with pytest.raises(InvalidParameter, match="edges: expected an int >= 3"):
        regular_polygon(2)
    with pytest.raises(InvalidParameter, match="edges: expected"):
        regular_polygon(6.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="radius"):
        regular_polygon(6, radius=-1.0)
    with pytest.raises(InvalidGeometry, match="radius: 5e-324 is too small"):
        regular_polygon(6, radius=5e-324)
    with pytest.raises(InvalidParameter, match="poly: expected a ConvexPolygon"):
        qp_bounds("square", p, v, buffer=0.2, spring_gain=2.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidInput, match="v: expected shape"):
        qp_bounds(poly, p, [1.0], buffer=0.2, spring_gain=2.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="buffer"):
        qp_bounds(poly, p, v, buffer=0.0, spring_gain=2.0)
    with pytest.raises(InvalidParameter, match="buffer: 5e-324 is too small"):
        qp_bounds(poly, p, v, buffer=5e-324, spring_gain=2.0)
    assert np.all(np.isfinite(qp_bounds(poly, p, v, buffer=0.2, spring_gain=2.0)))


def test_bench_settings_and_write_report_refuse_bad_inputs_by_name() -> None:
    from velfence.apps.bench import BenchSettings, write_report
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match="quick: expected True or False"):
        BenchSettings.make(quick="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="report: expected a BenchReport"):
        write_report("report", "out.md")  # type: ignore[arg-type]


# ------------------------------------------------------------------ the tiny configuration

TINY = bm.BenchSettings(
    quick=True,
    calls=5,
    warmup=1,
    states_per_zone=2,
    latency_edges=(4, 8),
    batch_edges=(8,),
    batch_n=64,
    batch_repeats=1,
    python_n=32,
    stop_candidates=400,
    nd_batch_n=(64, 128),
    nd_python_n=32,
    filter_calls=5,
    filter_states=2,
)
HAVE_QP = all(importlib.util.find_spec(m) is not None for m in ("qpsolvers", "daqp"))
HAVE_NUMBA = importlib.util.find_spec("numba") is not None


class _Recorder:
    def __init__(self) -> None:
        self.messages: list[str] = []

    def __call__(self, message: str) -> None:
        self.messages.append(message)


@pytest.fixture(scope="module")
def tiny() -> tuple[bm.BenchReport, list[tuple[str, float]]]:
    """The shared run (tests/shared_runs.py), through :func:`run.run_settings` with settings
    of its own (the quick configuration with few calls): its rows and Markdown checked against
    those settings."""
    return bench_quick()


def test_tiny_run_reports_every_step_once_in_order(
    tiny: tuple[bm.BenchReport, list[tuple[str, float]]],
) -> None:
    rep, calls = tiny
    assert calls[-1] == ("done", 1.0)
    steps = calls[:-1]
    steps_plan = plan.step_plan(
        rep.settings, numba_ok=HAVE_NUMBA, qp_ok=HAVE_QP, mink_ok=filter_cases.mink_ok()
    )
    assert len(steps) == len(steps_plan)  # one call before each step of the plan
    for (message, _), cost in zip(steps, steps_plan, strict=True):
        assert message.startswith(cost.prefix), (message, cost.prefix)
    assert len({m for m, _ in steps}) == len(steps)
    # The fraction is the share of the expected seconds done, numba's cache taken as cold
    # until the first compile step has ended, then as it was found.
    first = next((k for k, c in enumerate(steps_plan) if c.compile), len(steps_plan))

    def shares(cold: bool) -> list[float]:
        cost = [c.seconds + cold * c.compile for c in steps_plan]
        return [sum(cost[:k]) / sum(cost) for k in range(len(cost))]

    fracs = [f for _, f in steps]
    assert fracs[: first + 1] == pytest.approx(shares(True)[: first + 1], abs=1e-12)
    assert any(
        fracs[first + 1 :] == pytest.approx(shares(cold)[first + 1 :], abs=1e-12)
        for cold in (True, False)
    )


def test_tiny_run_has_rows_of_every_family(
    tiny: tuple[bm.BenchReport, list[tuple[str, float]]],
) -> None:
    rep, _ = tiny
    edges = rep.settings.latency_edges
    assert {(r.edges, r.method) for r in rep.latency} == {(e, m) for e in edges for m in METHODS}
    assert len(rep.worst) == len(edges) * len(METHODS)
    assert {b.backend for b in rep.batch} == ({"numba", "python"} if HAVE_NUMBA else {"python"})
    assert {r.method for r in rep.stops} == {"nearest", "exact"}
    arms = {r.arm for r in rep.control}
    assert arms == set(redundancy.ARMS)
    assert {r.obstacles for r in rep.control} == set(redundancy.obstacle_counts(rep.settings))
    families = {r.family for r in rep.steps}
    assert families == {"cobot (Gillespie 1999)", "resolved rate (Khokar 2009)"}
    if HAVE_QP:
        assert {q.edges for q in rep.qp} == set(edges)
        assert {r.method for r in rep.control} == {"configuration-control", "velocity-damper-qp"}
    else:
        assert rep.qp == ()


def test_tiny_run_has_the_nd_and_filter_families(
    tiny: tuple[bm.BenchReport, list[tuple[str, float]]],
) -> None:
    from velfence.apps.bench.cases import polytope

    rep, _ = tiny
    assert {r.case for r in rep.polytope} == set(polytope.CASES)
    assert {r.case for r in rep.polytope_batch} == set(polytope.CASES)
    assert {r.mode for r in rep.filter} == {"joint", "twist", "joint, dt 4 ms"}
    assert bool(rep.polytope_qp) == HAVE_QP
    names = [t.name for t in rep.targets]
    assert sum("`PolytopeShaper.shape`" in n for n in names) == 2
    assert sum("`SafetyFilter.filter`" in n for n in names) == 2
    md = rep.to_markdown()
    tables = _tables(md)
    ((_, body),) = _section(tables, "n-D exact law: single-call latency")
    assert len(body) == len(rep.polytope)
    ((_, body),) = _section(tables, "n-D exact law: batch throughput")
    assert len(body) == len(rep.polytope_batch)
    ((head, body),) = _section(tables, "One cycle of `SafetyFilter`")
    assert len(body) == len(rep.filter)
    j = head.index("ratio")
    assert [row[j] for row in body] == [f"{r.ratio:.3f}" for r in rep.filter]
    if HAVE_QP:
        ((_, body),) = _section(tables, "n-D exact law against the same QP")
        assert len(body) == len(rep.polytope_qp)


def test_per_call_rows_are_latency_records(
    tiny: tuple[bm.BenchReport, list[tuple[str, float]]],
) -> None:
    rep, _ = tiny
    rows: list[Latency] = [
        *rep.latency, *rep.worst, *rep.stops, *rep.control, *rep.steps, *rep.polytope,
        *rep.filter,
    ]  # fmt: skip
    assert rows
    for r in rows:
        assert isinstance(r, Latency)
        assert r.calls >= rep.settings.calls
        assert 0.0 < r.median_us <= r.p99_us <= r.max_us
    for r in rep.latency:
        assert r.calls == rep.settings.calls
        assert 0 < r.states <= rep.settings.states_per_zone
    for r in rep.stops:
        assert r.calls == rep.settings.calls
        assert 0 < r.states <= 64
    for c in rep.control:
        assert c.calls == 50  # at least 50 cycles per row, whatever the settings
        assert c.active >= 0.0
    for st in rep.steps:
        assert st.calls == 200
        if st.baseline:
            base = [b for b in rep.steps if b.family == st.family and b.baseline == ""]
            assert base
            assert st.ratio > 0.0
        else:
            assert math.isnan(st.ratio)


def test_rows_share_one_definition_of_the_timing_fields() -> None:
    shared = {f.name for f in dataclasses.fields(Latency)}
    assert shared == {"calls", "median_us", "p99_us", "max_us"}
    for cls in (
        bm.LatencyRow,
        bm.WorstZone,
        bm.StopLatencyRow,
        bm.ControlCycleRow,
        bm.StepRow,
    ):
        assert issubclass(cls, Latency)
        own = set(vars(cls).get("__annotations__", {}))
        assert not own & shared, (cls.__name__, own & shared)  # not copied, inherited
        assert shared <= {f.name for f in dataclasses.fields(cls)}


def test_worst_zone_picks_the_largest_median() -> None:
    def row(zone: str, median: float) -> bm.LatencyRow:
        return bm.LatencyRow(
            calls=3, median_us=median, p99_us=median + 1, max_us=median + 2,
            edges=8, method="exact", zone=zone, states=2,
        )  # fmt: skip

    w = shaping.worst_zone([row("free", 1.0), row("corner", 3.0), row("buffer", 2.0)])
    assert (w.zone, w.median_us, w.p99_us, w.max_us, w.edges) == ("corner", 3.0, 4.0, 5.0, 8)


def test_time_calls_calls_every_pool_entry_warm_and_timed() -> None:
    seen: list[tuple[int, int]] = []
    lat = time_calls(lambda a, b: seen.append((a, b)), [(1, 2), (3, 4)], calls=5, warmup=2)
    assert seen == [(1, 2), (3, 4)] * 2 + [(1, 2), (3, 4), (1, 2), (3, 4), (1, 2)]
    assert lat.calls == 5
    assert 0.0 < lat.median_us <= lat.p99_us <= lat.max_us
    assert latency_of([1000, 2000, 3000]) == Latency(3, 2.0, pytest.approx(2.98), 3.0)


def test_each_family_runs_on_its_own() -> None:
    notes: list[str] = []
    pools = shaping.zone_pools(TINY, notes)
    assert set(pools) == {(e, m) for e in (4, 8) for m in METHODS}
    step = _Recorder()
    rows, worst = shaping.latency(TINY, pools, step)
    assert step.messages == [f"latency: {e}-gon, {m}" for e in (4, 8) for m in METHODS]
    assert {w.zone for w in worst} <= set(bm.ZONES)
    assert len(rows) == sum(1 for p in pools.values() for states in p.values() if states)

    step = _Recorder()
    stops = shaping.stop_latency(TINY, step)
    assert step.messages == [
        "latency: joint-stop limiter, nearest",
        "latency: joint-stop limiter, exact",
    ]
    assert {r.zone for r in stops} <= {"3 nominal", "2 braking", "1 linear", "outside"}

    step = _Recorder()
    batch = shaping.batch(TINY, False, step)  # the Python back-end only
    assert [(b.backend, b.n, b.repeats, b.compile_s) for b in batch] == [("python", 32, 1, 0.0)] * 2

    step = _Recorder()
    control = redundancy.control_cycles(TINY, step, False)  # without the QP baseline
    assert {c.method for c in control} == {"configuration-control"}
    assert len(step.messages) == len(redundancy.ARMS) * len(redundancy.obstacle_counts(TINY))

    step = _Recorder()
    cobot = controllers.cobot_steps(TINY, step)
    rate = controllers.resolved_rate_steps(TINY, step)
    assert step.messages == ["cobot path following", "resolved rate (PUMA 560)"]
    assert [r.baseline for r in cobot] == [""] * 5 + ["PolygonShaper exact"]
    assert [r.baseline for r in rate] == ["", "J⁻¹ step", "J⁻¹ step", "J⁻¹ step"]
    for r in rate[1:]:
        assert r.ratio == pytest.approx(r.median_us / rate[0].median_us)

    if HAVE_QP:
        step = _Recorder()
        qp = peers.qp(TINY, pools, rows, step)
        assert step.messages == ["QP baseline: 4-gon", "QP baseline: 8-gon"]
        by_key = {(r.edges, r.zone): r for r in rows if r.method == "exact"}
        for q in qp:
            vf = by_key[q.edges, q.zone]
            assert (q.velfence_median_us, q.velfence_p99_us) == (vf.median_us, vf.p99_us)
            assert q.calls == TINY.calls
            assert q.daqp_ratio_median == pytest.approx(q.daqp_median_us / vf.median_us)
            assert q.qpsolvers_max_error <= bm.AGREEMENT_TARGET
            assert q.daqp_max_error <= bm.AGREEMENT_TARGET


# ------------------------------------------------------------------ the Markdown of a report


def _tables(md: str) -> dict[str, list[tuple[list[str], list[list[str]]]]]:
    """Section heading -> its tables, each as (header cells, body rows of cells)."""
    out: dict[str, list[tuple[list[str], list[list[str]]]]] = {}
    section = ""
    for block in md.split("\n\n"):
        if block.startswith("## "):
            section = block[3:].strip()
            continue
        lines = [ln for ln in block.splitlines() if ln.startswith("|")]
        if not lines:
            continue
        cells = [[c.strip() for c in ln.strip().strip("|").split("|")] for ln in lines]
        assert all(set(c) <= set("-: ") for c in cells[1]), block  # the rule line
        out.setdefault(section, []).append((cells[0], cells[2:]))
    return out


_NUMBER = re.compile(r"^-?\d+(\.\d+)?(e[-+]\d+)?$")
#: Columns of counts and labels (no unit): everything else that holds numbers must name one.
_UNITLESS = {"edges", "states", "N", "links", "obstacles", "active", "facets", "rows"}
_UNITS = ("µs", "ms", " s", "M states/s", "ratio", "‖Δv‖∞", "ns", "M rows/s", "‖Δq̇‖∞")


def _numeric(cell: str) -> bool:
    return all(_NUMBER.match(part.strip()) for part in cell.split(" / "))


def _columns_without_units(
    tables: dict[str, list[tuple[list[str], list[list[str]]]]],
) -> list[tuple[str, str]]:
    """(section, column) of every numeric column that is neither a count nor names a unit."""
    out = []
    for section, found in tables.items():
        for header, body in found:
            assert body, section
            for row in body:
                assert len(row) == len(header), (section, row)
            for j, name in enumerate(header):
                numeric = all(_numeric(row[j]) for row in body)
                if numeric and name not in _UNITLESS and not any(u in name for u in _UNITS):
                    out.append((section, name))
    return out


def _section(tables: dict[str, Any], prefix: str) -> list[tuple[list[str], list[list[str]]]]:
    (key,) = [k for k in tables if k.startswith(prefix)]
    return tables[key]


def test_markdown_tables_name_units_and_match_the_rows(
    tiny: tuple[bm.BenchReport, list[tuple[str, float]]],
) -> None:
    rep, _ = tiny
    md = rep.to_markdown()
    tables = _tables(md)
    assert _columns_without_units(tables) == []
    ((head, body),) = [t for t in _section(tables, "Single-call latency") if "zone" in t[0]]
    assert head[4:] == ["median µs", "p99 µs", "max µs"]
    assert len(body) == len(rep.latency)
    ((head, body),) = _section(tables, "Batch throughput")
    assert "median ms / call" in head
    assert "M states/s (median)" in head
    assert len(body) == len(rep.batch)
    ((head, body),) = _section(tables, "Per-call latency of `StopLimiter")
    assert len(body) == len(rep.stops)
    ((head, body),) = _section(tables, "One obstacle-avoidance control cycle")
    assert len(body) == len(rep.control)
    # ratio columns: the cells are the rows' ratios, "—" where a row has no baseline
    ((head, body),) = _section(tables, "One step of the other controllers")
    j = head.index("ratio")
    assert [row[j] for row in body] == [
        "—" if math.isnan(r.ratio) else f"{r.ratio:.2f}" for r in rep.steps
    ]
    assert [row[head.index("baseline")] for row in body] == [r.baseline or "—" for r in rep.steps]
    if HAVE_QP:
        ((head, body),) = _section(tables, "The exact law against the same QP")
        j = head.index("qpsolvers ratio med / p99")
        k = head.index("daqp ratio med / p99")
        assert len(body) == len(rep.qp)
        for row, q in zip(body, rep.qp, strict=True):
            assert row[j] == f"{q.qpsolvers_ratio_median:.1f} / {q.qpsolvers_ratio_p99:.1f}"
            assert row[k] == f"{q.daqp_ratio_median:.1f} / {q.daqp_ratio_p99:.1f}"


def test_unit_check_finds_a_numeric_column_without_a_unit() -> None:
    bad = "## T\n\n| edges | median | p99 µs |\n| --- | ---: | ---: |\n| 4 | 1.00 | 2.0 |\n"
    assert _columns_without_units(_tables(bad)) == [("T", "median")]


# ------------------------------------------------------------------ API edges


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("calls", 0, "calls: expected an int >= 1"),
        ("calls", 2.5, "calls: expected a positive int"),
        ("warmup", -1, "warmup: expected an int >= 0"),
        ("batch_n", 10**12, "batch_n: expected an int <="),
        ("latency_edges", (), "latency_edges: expected a non-empty tuple"),
        ("latency_edges", [8], "latency_edges: expected a non-empty tuple"),
        ("batch_edges", (8, 2), r"batch_edges\[1\]: expected an int >= 3"),
        ("buffer", 0.0, "buffer"),
        ("spring_gain", math.nan, "spring_gain"),
        ("quick", "yes", "quick: expected True or False"),
        ("stop_candidates", True, "stop_candidates: expected a positive int"),
        ("nd_batch_n", (), "nd_batch_n: expected a non-empty tuple"),
        ("nd_batch_n", (1000, 4), r"nd_batch_n\[1\]: expected an int >= 16"),
        ("nd_python_n", 0, "nd_python_n: expected an int >= 16"),
        ("filter_calls", 0, "filter_calls: expected an int >= 1"),
        ("filter_states", 1.5, "filter_states: expected a positive int"),
    ],
)
def test_bench_settings_refuse_bad_fields_by_name(field: str, value: Any, message: str) -> None:
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match=message):
        dataclasses.replace(TINY, **{field: value})


def test_run_settings_refuses_other_objects_by_name() -> None:
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match="s: expected a BenchSettings"):
        run.run_settings({"calls": 5})  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="progress: expected a callable"):
        run.run_settings(TINY, progress="bar")  # type: ignore[arg-type]


STEPS_MEASURED = Path(__file__).with_name("quick_run_steps.json")


def _etas(steps: list[list[Any]]) -> list[tuple[float, float, float]]:
    """``(elapsed, estimated remaining, real remaining)`` [s] at the start of each step of a
    recorded ``--quick`` run, the estimate the progress lines print (elapsed * (1 - f) / f)."""
    s = bm.BenchSettings.make(quick=True)
    steps_plan = plan.step_plan(s, numba_ok=True, qp_ok=True, mink_ok=True)
    assert [m.startswith(c.prefix) for (m, _), c in zip(steps, steps_plan, strict=True)] == [
        True
    ] * len(steps)
    total = sum(float(d) for _, d in steps)
    now = [0.0]
    seen: list[tuple[float, float]] = []
    step = plan.Steps(lambda m, f: seen.append((now[0], f)), steps_plan, clock=lambda: now[0])
    for message, seconds in steps:
        step(message)
        now[0] += float(seconds)
    return [(t, t * (1.0 - f) / f, total - t) for t, f in seen if f > 0.0]


@pytest.mark.parametrize("cache", ["cold", "warm"])
def test_quick_bench_remaining_time_follows_the_work(cache: str) -> None:
    """The estimate printed once a fifth of the run has passed is within a factor 1.5 of the
    time the run really still took, with numba compiling its kernels (half the run) and with
    them cached; counting the steps equally was off by 2-5x."""
    steps = json.loads(STEPS_MEASURED.read_text())[cache]
    total = sum(float(d) for _, d in steps)
    late = [(t, eta, real) for t, eta, real in _etas(steps) if t >= 0.2 * total and real > 0]
    t, eta, real = late[0]
    assert real / 1.5 <= eta <= 1.5 * real, (t, eta, real)
    for t, eta, real in late:  # and no later line is off by more than 2x
        assert real / 2.0 <= eta <= 2.0 * real, (t, eta, real)


def test_quick_bench_learns_whether_numba_compiles() -> None:
    """The first compile step tells a cold cache (its seconds) from a warm one."""
    s = bm.BenchSettings.make(quick=True)
    steps_plan = plan.step_plan(s, numba_ok=True, qp_ok=True, mink_ok=True)
    for cache, cold in (("cold", True), ("warm", False)):
        now = [0.0]
        step = plan.Steps(None, steps_plan, clock=lambda t=now: t[0])
        for message, seconds in json.loads(STEPS_MEASURED.read_text())[cache]:
            step(message)
            now[0] += float(seconds)
        assert step.cold is cold
    assert plan.expected_seconds(steps_plan, cold=True) > 2 * plan.expected_seconds(
        steps_plan, cold=False
    )
