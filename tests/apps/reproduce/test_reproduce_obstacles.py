"""``velfence reproduce obstacles``: configuration control among obstacles (US 5,150,026)."""

import json
import math
from pathlib import Path

import pytest

from shared_runs import check_figures, reproduction

pytest.importorskip("qpsolvers")
pytest.importorskip("daqp")

#: Slow, left out of `make check` (`make test` runs them): the whole reproduction (30 s).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    return reproduction("obstacles", tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def report(recorded):
    return recorded.report


def test_every_figure_passes_the_figure_checker(recorded):
    assert check_figures(recorded)


def test_every_check_passes(report):
    failed = [(c.name, c.measured, c.tolerance) for c in report.checks if not c.passed]
    assert failed == []
    assert report.passed


def test_checks_are_named_sourced_and_finite(report):
    names = [c.name for c in report.checks]
    assert len(names) == len(set(names))
    for c in report.checks:
        assert c.source.startswith(("US 5,150,026 claim 1", "velfence scenario")), c.name
        if isinstance(c.measured, float):
            assert math.isfinite(c.measured), c.name
    text = " ".join(names)
    for needle in ("(i)", "(ii)", "(iii)", "(iv)", "(v)", "baseline (i)", "baseline (ii)"):
        assert needle in text


def test_baseline_table_in_notes(report):
    notes = [c.note for c in report.checks if c.name.startswith("baseline")]
    assert len(notes) == 2
    for n in notes:
        assert "median cycle" in n
        assert "max EE error" in n
        assert "max joint-rate jump" in n


def test_json_shape_and_artifacts(report):
    d = json.loads(report.to_json())
    assert d["name"] == "obstacles"
    assert set(d) == {"name", "checks", "artifacts"}
    for c in d["checks"]:
        assert {"name", "source", "expected", "measured", "tolerance", "passed"} <= set(c)
    names = sorted(Path(p).name for p in d["artifacts"])
    assert names == [
        "active_sets.png",
        "clearance.png",
        "scenario_i.gif",
        "snapshots_7r.png",
        "snapshots_planar.png",
    ]
    for p in d["artifacts"]:
        assert Path(p).stat().st_size > 0
    gif = next(Path(p) for p in d["artifacts"] if p.endswith(".gif"))
    assert gif.stat().st_size < 1_000_000
