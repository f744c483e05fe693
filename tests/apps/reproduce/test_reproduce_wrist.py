"""``velfence reproduce wrist``: every claim holds except the documented source defects."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from shared_runs import Recorded, check_figures, reproduction
from velfence.apps.reproduce.base import Report
from velfence.apps.reproduce.wrist import BUFFER, GAIN

#: Slow, left out of `make check` (`make test` runs them): the whole reproduction.
pytestmark = pytest.mark.slow

#: The patent's own law fails these claims (see docs/reproductions.md): the finding.
SOURCE_DEFECTS = {
    "patent: corner: outward speed toward the neighbouring edge not increased",
    "patent: a fast push into the acute corner never leaves",
}
CHECK_KEYS = {"name", "source", "expected", "measured", "tolerance", "passed"}
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    return reproduction("wrist", tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def out(recorded: Recorded) -> Path:
    return recorded.out


@pytest.fixture(scope="module")
def report(recorded: Recorded) -> Report:
    return recorded.report  # type: ignore[no-any-return]


def test_every_figure_passes_the_figure_checker(recorded: Recorded) -> None:
    assert check_figures(recorded) == {"velocity_patterns.png", "quiver.png"}


def _by_name(report: Report) -> dict[str, Any]:
    return {c.name: c for c in report.checks}


def test_names_are_unique(report: Report) -> None:
    names = [c.name for c in report.checks]
    assert len(names) == len(set(names))
    assert report.name == "wrist"
    assert len(names) >= 15


def test_exactly_the_documented_checks_are_source_defects(report: Report) -> None:
    flagged = {c.name for c in report.checks if c.source_defect}
    assert flagged == SOURCE_DEFECTS


def test_source_defects_fail_and_everything_else_passes(report: Report) -> None:
    failed = {c.name for c in report.checks if not c.passed}
    assert failed == SOURCE_DEFECTS
    assert report.passed  # source defects do not fail the reproduction


def test_source_defects_are_measured_and_explained(report: Report) -> None:
    checks = _by_name(report)
    for name in SOURCE_DEFECTS:
        c = checks[name]
        assert c.note, name
        assert c.source.startswith("US 8,676,382"), name
        assert isinstance(c.measured, float)
        assert math.isfinite(c.measured)
        assert c.measured > 0.0, name  # a real violation, not a rounding artefact
    # The exact law meets the same claim the patent law misses.
    assert checks["exact: a fast push into the acute corner never leaves"].measured == 0.0


def test_every_check_names_its_source(report: Report) -> None:
    for c in report.checks:
        assert c.source.strip(), c.name
        assert c.source.startswith(("US 8,676,382", "velfence requirement")), c.name


def test_spring_holds_penetration_at_push_over_gain(report: Report) -> None:
    c = _by_name(report)["external push: spring holds penetration at push/k"]
    assert c.expected == pytest.approx(0.2 / GAIN)
    assert c.measured == pytest.approx(0.2 / GAIN, rel=0.05)


def test_constants_are_the_demo_tuning() -> None:
    assert (BUFFER, GAIN) == (0.08, 8.0)


def test_to_dict_has_the_design_shape(report: Report) -> None:
    d = report.to_dict()
    assert set(d) == {"name", "checks", "artifacts"}
    assert d["name"] == "wrist"
    assert len(d["checks"]) == len(report.checks)
    for c in d["checks"]:
        assert set(c) >= CHECK_KEYS, c
        assert set(c) - CHECK_KEYS <= {"note", "source_defect"}, c
        assert isinstance(c["passed"], bool)
        assert isinstance(c["name"], str)
        assert isinstance(c["source"], str)
    flagged = {c["name"] for c in d["checks"] if c.get("source_defect")}
    assert flagged == SOURCE_DEFECTS
    assert all(isinstance(a, str) for a in d["artifacts"])


def test_to_json_is_strict_json(report: Report) -> None:
    def reject(token: str) -> None:
        raise AssertionError(f"non-standard JSON constant {token}")

    parsed = json.loads(report.to_json(), parse_constant=reject)
    assert parsed == report.to_dict()


def test_artifacts_exist_in_the_output_folder(report: Report, out: Path) -> None:
    paths = [Path(a) for a in report.artifacts]
    assert [p.name for p in paths] == ["velocity_patterns.png", "quiver.png"]
    for p in paths:
        assert p.parent == out
        assert p.is_file()
        assert p.read_bytes()[:8] == PNG
