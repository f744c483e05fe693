"""The cobot reproduction (Gillespie et al. 1999 Fig. 5, virtual walls): run once, inspect."""

import json
from pathlib import Path

import numpy as np
import pytest

from shared_runs import check_figures, reproduction
from velfence.apps.reproduce.cobot import GAINS, fig5_cobot, fig5_ee
from velfence.sim.cobot import constant_speed

#: Slow, left out of `make check` (`make test` runs them): the whole reproduction (a minute).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    return reproduction("cobot", tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def report(recorded):
    return recorded.report


def test_every_figure_passes_the_figure_checker(recorded):
    assert check_figures(recorded)


def test_every_check_passes(report):
    failed = [(c.name, c.measured, c.tolerance) for c in report.checks if not c.passed]
    assert failed == []
    assert report.passed
    assert not any(c.source_defect for c in report.checks)


def test_the_issue_s_named_checks_are_there(report):
    names = " | ".join(c.name for c in report.checks)
    for needle in (
        "|ΔR| at s = 2",
        "|ΔR| at s = 5",
        "speed invariance",
        "generic C_EE vs four-space",
        "singular-M guard fires",
        "virtual wall",
    ):
        assert needle in names, needle


def test_convergence_numbers_match_the_notes_reconstruction(report):
    # An independent simulation of Fig. 5 (docs/reproductions.md): 8.1e-2 at s = 1, 1.8e-2 at 2.
    by = {c.name: c.measured for c in report.checks}
    assert by["r-θ cobot: |ΔR| at s = 2 m [m]"] == pytest.approx(1.83e-2, rel=0.02)
    assert by["C_EE model: |ΔR| at s = 2 m [m]"] == pytest.approx(1.83e-2, rel=0.02)


def test_json_and_artifacts(report):
    d = json.loads(report.to_json())
    assert d["name"] == "cobot"
    assert {"name", "source", "expected", "measured", "tolerance", "passed"} <= set(d["checks"][0])
    assert len(report.artifacts) == 4
    for p in report.artifacts:
        assert Path(p).stat().st_size > 10_000


def test_positions_on_the_circle_at_known_arc_lengths():
    # The independent simulation of Fig. 5 gives (0.673, 0.806), (-0.284, 0.953), (-0.748, -0.664),
    # (0.915, -0.404) at s = 1, 2, 4, 6 for every speed.
    tr = fig5_ee()
    np.testing.assert_allclose(
        tr.at_arc_length([1.0, 2.0, 4.0, 6.0]),
        [[0.673, 0.806], [-0.284, 0.953], [-0.748, -0.664], [0.915, -0.404]],
        atol=1.5e-3,
    )


def test_faster_gains_converge_faster():
    slow, fast = fig5_ee(gains=(1.0, 2.0)), fig5_ee(gains=(9.0, 6.0))
    assert fast.error_at(2.0)[0] < 0.25 * slow.error_at(2.0)[0]
    assert GAINS == (4.0, 4.0)


def test_cobot_trace_does_not_depend_on_the_time_step_much():
    a = fig5_cobot(constant_speed(1.0), duration=2.0, dt=2e-3)
    b = fig5_cobot(constant_speed(1.0), duration=2.0, dt=1e-3)
    s = np.linspace(0.0, 1.95, 50)
    assert np.max(np.linalg.norm(a.at_arc_length(s) - b.at_arc_length(s), axis=1)) < 2e-4
