"""Smoke test of the benchmark suite: structure only, never timings (DESIGN.md §6)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from velfence import benchmarking as bm


@pytest.fixture(scope="module")
def report() -> bm.BenchReport:
    calls: list[tuple[str, float]] = []
    rep = bm.run_benchmarks(quick=True, progress=lambda msg, frac: calls.append((msg, frac)))
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
    from velfence.benchmarking import qp_bounds, regular_polygon
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
    from velfence.benchmarking import BenchSettings, write_report
    from velfence.errors import InvalidParameter

    with pytest.raises(InvalidParameter, match="quick: expected True or False"):
        BenchSettings.make(quick="yes")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="report: expected a BenchReport"):
        write_report("report", "out.md")  # type: ignore[arg-type]
