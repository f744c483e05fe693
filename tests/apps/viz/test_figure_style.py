"""Figures that explain themselves, checked on the matplotlib objects (not on pixels).

Every figure the demo writes (built-in scenario and a user's own config in metres), the wrist
reproduction's two figures and the obstacles reproduction's clearance figure (short runs) are
rendered while ``Figure.savefig`` is recorded (the study's and the CoSPM reproduction's figures:
``test_figure_checks.py``); then, for each figure:

* no axes is empty (it holds lines, collections, patches or images);
* every data axes has an x and a y label (and a z label in 3-D) with a unit in brackets;
* every colour-mapped artist (a ScalarMappable with an array, not a fixed-colour contour band)
  has a colour bar on its norm;
* every kind of artist an axes draws is explained by a legend, and nothing is cut off by the
  canvas (the rules of ``figure_checks.py``; every figure in the output folder, and the first,
  middle and last frame of each GIF);
* the user's config in metres never shows "rad" or the wrist's title.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="velfence.apps.viz needs the [app] extra")
matplotlib.use("Agg")
from figure_checks import (  # noqa: E402
    Recorded,
    check_all,
    check_every,
    colour_mapped,
    has_data,
    is_colorbar,
    problems,
    record_figures,
)
from matplotlib.figure import Figure  # noqa: E402

from velfence.apps.demo import run_demo  # noqa: E402
from velfence.apps.demo.config import DemoConfig  # noqa: E402

UNIT = re.compile(r"\[[^\[\]]+\]")

#: A user's own scenario: a fence in metres at dt = 0.02 s, short.
USER = {
    "polygon": [[0.0, 0.0], [2.0, 0.0], [2.5, 1.5], [0.5, 2.0]],
    "dt": 0.02,
    "unit": "m",
    "duration": 4.0,
    "shaper": {"buffer": 0.2},
}


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch) -> Iterator[Recorded]:
    """Figures written while the test runs, keyed by the file name they were saved to."""
    with record_figures(monkeypatch) as figures:
        yield figures


# One figure checker (tests/apps/viz/figure_checks.py): these tests use its rules.
_is_colorbar = is_colorbar
_has_data = has_data
_colour_mapped = colour_mapped
_check_all = check_all


def test_the_checker_catches_what_it_should() -> None:
    """An unlabelled, uncoloured-barred, half-empty figure fails on every rule."""
    fig = Figure()
    ax1, _ax2 = fig.subplots(1, 2)
    ax1.quiver([0, 1], [0, 1], [1, 1], [1, 0], [0.5, 2.0])
    ax1.set_xlabel("pitch")
    found = problems("bad", fig)
    assert any("x label 'pitch' has no unit" in p for p in found)
    assert any("y label" in p for p in found)
    assert any("without a colour bar" in p for p in found)
    assert any("axes 1" in p and "empty" in p for p in found)
    fig2 = Figure()
    ax = fig2.subplots()
    q = ax.quiver([0, 1], [0, 1], [1, 1], [1, 0], [0.5, 2.0])
    fig2.colorbar(q, ax=ax, label="speed [m/s]")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    assert problems("good", fig2) == []


def test_demo_figures_explain_themselves(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    run_demo(config=DemoConfig(duration=3.0, dt=0.005), out_dir=tmp_path / "wrist")
    # Every figure and every picture in the folder; demo.gif's first, middle and last frames.
    written = check_every(recorded, tmp_path / "wrist")
    assert {"workspace.png", "velocity.png", "quiver.png", "demo.gif"} <= written
    assert len(recorded.animations["demo.gif"]) >= 3
    gif = [f for n, f in recorded.items() if n.startswith("frame-of-")]
    assert gif, "demo.gif's frames were not rendered"
    width = gif[0].get_size_inches()[0] * 84  # GIF_DPI
    assert width >= 600
    ws = recorded["workspace.png"]
    legend = ws.legends[0] if ws.legends else ws.axes[0].get_legend()
    entries = [t.get_text() for t in legend.get_texts()]
    assert any(e.startswith("buffer band") for e in entries), entries
    assert ws.axes[0].get_xlabel() == "pitch [rad]"
    quiver = recorded["quiver.png"]
    assert len([a for a in quiver.axes if not _is_colorbar(a)]) == 5  # five methods, 5 panels
    bar = next(a for a in quiver.axes if _is_colorbar(a))
    assert bar.get_ylabel().startswith("shaped speed [rad/s]")


def test_a_users_config_in_metres_is_labelled_from_the_config(
    tmp_path: Path, recorded: dict[str, Figure]
) -> None:
    result = run_demo(config=DemoConfig(**USER, gif=False), out_dir=tmp_path / "user")
    _check_all(recorded, {"workspace.png", "velocity.png", "quiver.png"})
    texts: list[str] = []
    for fig in recorded.values():
        if fig._suptitle is not None:
            texts.append(fig._suptitle.get_text())
        for ax in fig.axes:
            texts += [ax.get_xlabel(), ax.get_ylabel(), ax.get_title()]
    joined = " | ".join(texts)
    for wanted in ("[m]", "[m/s]", "custom scenario (50 Hz"):
        assert wanted in joined
    for unwanted in ("rad", "pitch", "1 kHz"):
        assert unwanted not in joined
    assert "50 Hz" in str(result.table.title)
    assert "wrist" not in str(result.table.title)


def test_wrist_reproduction_figures(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from velfence.apps.reproduce import wrist
    from velfence.mechanisms.wrist import Wrist, WristGeometry

    poly = Wrist(geometry=WristGeometry()).default_polygon()
    wrist._figures(poly, wrist._shapers(poly), tmp_path)
    _check_all(recorded, {"velocity_patterns.png", "quiver.png"})
    for ax in recorded["velocity_patterns.png"].axes:
        entries = [t.get_text() for t in ax.get_legend().get_texts()]
        assert entries[-3:] == [
            "commands (all directions)",
            f"shaped output ({ax.get_title().split(':')[0]})",
            "sample point",
        ]
    quiver = recorded["quiver.png"]
    assert len([a for a in quiver.axes if not _is_colorbar(a)]) == 2  # no empty third panel


def test_obstacle_clearance_figure(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from velfence.apps.reproduce import obstacles as ob
    from velfence.apps.viz.obstacles import plot_clearance
    from velfence.filter import SphereObstacle
    from velfence.mechanisms.chain import PlanarArm
    from velfence.redundancy import ConfigurationController, cosine_line

    arm = PlanarArm.three_r()
    q0 = ob._ik(arm, (2.0, 1.0), (-0.4, 0.8, 1.0))
    line = cosine_line((2.0, 1.0), (0.0, -1.0), 2.0, 5.0, back=True)
    obs = [SphereObstacle(center=np.array([1.5, -1.4]), radius=ob.BODY, influence=ob.RHO)]
    runs = [
        ob.run_scenario(f"run {k}", ConfigurationController(arm, obs), line, q0, 0.05)
        for k in range(4)
    ]
    plot_clearance(runs, tmp_path / "clearance.png")
    assert check_every(recorded, tmp_path) == {"clearance.png"}
    fig = recorded["clearance.png"]
    assert len(fig.axes) == 8  # 4 runs x (clearance, EE error): the 2 unused panels removed
    assert fig.get_size_inches()[0] * 90 <= 1300  # readable at 100 %: at most 3 columns
