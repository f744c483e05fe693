"""Every figure the CLI writes passes the figure checker (``figure_checks.py``), which itself
fails on a planted bad figure.

Covered: ``velfence demo --config examples/demo-config.yaml`` (short), the arm-box demo's three
figures (hand-made runs here; the real demo at one speed is slow), ``velfence replay --plot``
on the example mobile-base bag, ``velfence sim`` margin figures (on a hand-made result here; the
three real scenarios are slow), and the reproductions' figures (wrist fast, the others slow).
``velfence bench`` writes no figure. The built-in demo, its GIF, the wrist's and the study's
figures are checked in ``test_figure_style.py`` with the same checker.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="velfence.apps.viz needs the [app] extra")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from figure_checks import check_all, problems, record_figures  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, Figure]]:
    """Figures saved while the test runs, keyed by file name."""
    with record_figures(monkeypatch) as figures:
        yield figures


# --- the checker fails on a planted bad figure ------------------------------------------------


def test_the_checker_reports_each_problem_of_a_bad_figure() -> None:
    fig = Figure()
    a, _b, c, d = fig.subplots(1, 4)
    # a: two labelled series, no legend; labels without units; a line far outside the limits.
    a.plot([0, 1], [0, 1], label="one")
    a.plot([0, 1], [1, 0], label="two")
    a.plot([0, 5], [0, 0.5])
    a.set_xlim(0, 1)
    a.set_xlabel("time")
    a.set_ylabel("speed")
    # b: empty, no text saying why.
    # c: a scatter whose colour bar is set by one outlier (every other point one colour).
    values = np.r_[np.linspace(0.0, 1.0, 99), 100.0]
    sc = c.scatter(np.linspace(0, 1, 100), np.linspace(0, 1, 100), c=values)
    fig.colorbar(sc, ax=c, label="speed [m/s]")
    c.set_xlabel("x [m]")
    c.set_ylabel("y [m]")
    # d: a colour-mapped image whose bar range holds little of its data, and a bar without unit.
    im = d.imshow(np.linspace(0.0, 10.0, 100).reshape(10, 10), vmin=0.0, vmax=1.0)
    fig.colorbar(im, ax=d, label="density")
    found = "\n".join(problems("bad", fig))
    assert "axes 0 ('')" in found
    assert "x label 'time' has no unit" in found
    assert "y label 'speed' has no unit" in found
    assert "no legend entry for ['one', 'two']" in found
    assert "drawn outside the axes limits" in found
    assert "bad axes 1 (''): empty" in found
    assert "set by outliers" in found
    assert "holds only" in found
    assert "label 'density' has no unit" in found


def test_the_checker_passes_a_good_figure_and_its_exemptions() -> None:
    fig = Figure()
    a, b, c, d = fig.subplots(1, 4)
    a.plot([0, 1], [0, 1], label="one")
    a.plot([0, 1], [1, 0], label="two")
    a.legend()
    a.set_xlabel("time [s]")
    a.set_ylabel("ratio [1]")
    b.text(0.5, 0.5, "no contact in any run")  # an empty panel that says why
    c.imshow(np.zeros((3, 3, 3)))  # an image panel (no colour scale): no labels needed
    d.plot([0, 1], [0, 1])
    d.set_yticks([0, 1], ["row a", "row b"])  # categorical: the ticks name the rows
    d.set_xlabel("time [s]")
    assert problems("good", fig) == []
    plt.close("all")


def test_a_figure_level_label_stands_for_panels_without_their_own() -> None:
    # A 2 x 2 grid, each panel its own y range: one supylabel and one supxlabel name them all.
    fig = Figure()
    axes = fig.subplots(2, 2)
    for ax in axes.ravel():
        ax.plot([0, 1], [0, 1])
    fig.supxlabel("time [s]")
    fig.supylabel("reading [cm]")
    assert problems("grid", fig) == []
    # The figure label must carry a unit too, and a panel's own label still counts first.
    fig.supylabel("reading")
    axes[0, 0].set_xlabel("time")
    found = "\n".join(problems("grid", fig))
    assert "grid axes 1 (''): y label 'reading' has no unit" in found
    assert "grid axes 0 (''): x label 'time' has no unit" in found
    assert "grid axes 1 (''): x label" not in found
    # Without any figure label the panels are unlabelled.
    bare = Figure()
    bare.subplots(1, 2)[1].plot([0, 1], [0, 1])
    assert "bare axes 1 (''): y label '' has no unit" in "\n".join(problems("bare", bare))
    plt.close("all")


# --- the CLI's figures ----------------------------------------------------------------------


def test_demo_with_the_example_config(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from velfence.apps.demo import run_demo
    from velfence.apps.demo.config import load_config

    cfg = load_config(ROOT / "examples" / "demo-config.yaml")
    cfg = cfg.model_copy(update={"gif": False, "duration": 5.0})
    run_demo(config=cfg, out_dir=tmp_path)
    check_all(recorded, {"workspace.png", "velocity.png", "quiver.png"})
    # Each path drawn in its own dash style, above the one before it: none hides another.
    ax = recorded["workspace.png"].axes[0]
    paths = [ln for ln in ax.lines if ln.get_label() in ("hard-stop", "patent", "exact")]
    assert len({(ln.get_linestyle(), ln.get_linewidth()) for ln in paths}) == 3
    assert len({ln.get_zorder() for ln in paths}) == 3
    entries = [t.get_text() for t in recorded["workspace.png"].legends[0].get_texts()]
    assert any(e == "buffer band (0.08 rad wide)" for e in entries), entries


def test_arm_box_figures_on_hand_made_runs(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from test_arm_viz import RUNS, SCENE

    from velfence.apps.viz.arm import plot_arm_activity, plot_arm_joints, plot_arm_paths

    plot_arm_paths(SCENE, RUNS, tmp_path / "arm_paths.png")
    plot_arm_joints(SCENE, RUNS, tmp_path / "arm_joints.png")
    plot_arm_activity(RUNS, tmp_path / "arm_activity.png")
    check_all(recorded, {"arm_paths.png", "arm_joints.png", "arm_activity.png"})
    legend = recorded["arm_paths.png"].legends[0]
    entries = {t.get_text() for t in legend.get_texts()}
    assert {"box (TCP fence)", "sphere (obstacle)", "TCP path"} <= entries
    # The hand-made runs hold joints 1..6 constant: a fixed range and a note, not round-off.
    joints = [a for a in recorded["arm_joints.png"].axes if a.get_ylabel().startswith("q")]
    q6 = joints[6]
    lo, hi = q6.get_ylim()
    assert hi - lo >= 0.1
    assert any("constant" in t.get_text() for t in q6.texts)


def test_replay_figure_names_whose_path_it_is(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    bag = ROOT / "examples" / "bags" / "mobile_base"
    result = CliRunner().invoke(
        app,
        [
            "replay", str(bag / "bag"), "--config", str(bag / "replay.yaml"),
            "--out", str(tmp_path / "out"), "--plot", str(tmp_path / "replay.png"),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    check_all(recorded, {"replay.png"})
    texts = " ".join(
        t.get_text() for ax in recorded["replay.png"].axes if ax.get_legend()
        for t in ax.get_legend().get_texts()
    )  # fmt: skip
    assert "operator's command (recorded)" in texts
    assert "velfence's output (shaped)" in texts
    assert "velfence not in the loop" in texts


def _fake_result(contacts: bool) -> Any:
    """A two-method ScenarioResult-like object, the first two runs identical."""
    t = np.linspace(0.0, 2.0, 50)
    margin = 0.05 - 0.04 * np.sin(t)
    runs = {}
    for name in ("no-limit", "per-joint-clamp", "safety-filter"):
        rec = SimpleNamespace(contacts=(t > 1.0).astype(int) if contacts else np.zeros(50))
        runs[name] = SimpleNamespace(
            trajectory=SimpleNamespace(t=t), record=rec, extra={"margin": margin}
        )
    scene = {
        "margin": ("obstacle clearance", "m", {"influence": 0.03, "obstacle surface": 0.0}),
        "push": (0.5, 0.7),
    }
    return SimpleNamespace(name="fake", runs=runs, scene=scene)


@pytest.mark.parametrize("contacts", [True, False])
def test_sim_margin_figure(tmp_path: Path, recorded: dict[str, Figure], contacts: bool) -> None:
    from velfence.apps.scenarios.output import plot_margins

    plot_margins(_fake_result(contacts), tmp_path / "fake_margins.png")
    check_all(recorded, {"fake_margins.png"})
    fig = recorded["fake_margins.png"]
    assert len(fig.axes) == (2 if contacts else 1)  # no empty contacts panel
    ax = fig.axes[0]
    entries = {t.get_text() for t in fig.legends[0].get_texts()}
    assert "obstacle surface (0 mm)" in entries  # the line the title names is in the legend
    assert "below the obstacle surface line" in ax.get_title()
    a, b = (ln for ln in ax.lines if ln.get_label() in ("no limit", "per-joint clamp"))
    assert (a.get_linestyle(), a.get_linewidth()) != (b.get_linestyle(), b.get_linewidth())
    assert b.get_zorder() > a.get_zorder()


def test_wrist_reproduction_figures(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from velfence.apps.reproduce import wrist
    from velfence.mechanisms.wrist import Wrist, WristGeometry

    poly = Wrist(geometry=WristGeometry()).default_polygon()
    wrist._figures(poly, wrist._shapers(poly), tmp_path)
    check_all(recorded, {"velocity_patterns.png", "quiver.png"})


# --- heavy: the real runs ---------------------------------------------------------------------


@pytest.mark.slow  # about 15 s: five controllers at one speed
def test_arm_box_demo(tmp_path: Path, recorded: dict[str, Figure]) -> None:
    from velfence.apps.demo import run_arm_demo

    run_arm_demo(out_dir=tmp_path, speeds=(0.25,), gif=False)
    check_all(recorded, {"arm_paths.png", "arm_joints.png", "arm_activity.png"})


@pytest.mark.slow  # about 45 s: the three MuJoCo scenarios, without video
@pytest.mark.parametrize("scenario", ["fence-box", "wrist-push", "redundant-obstacle"])
def test_sim_scenarios(tmp_path: Path, recorded: dict[str, Figure], scenario: str) -> None:
    pytest.importorskip("mujoco")
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    out = tmp_path / scenario
    result = CliRunner().invoke(
        app, ["sim", "--scenario", scenario, "--no-video", "--out", str(out)]
    )
    assert result.exit_code in (0, 1), result.output
    check_all(recorded, {f"{scenario}_margins.png"})


@pytest.mark.slow  # the reproductions at their own (small) sizes: about a minute together
@pytest.mark.parametrize("source", ["obstacles", "cobot", "cospm", "telerobotics"])
def test_reproductions(tmp_path: Path, recorded: dict[str, Figure], source: str) -> None:
    import importlib

    module = importlib.import_module(f"velfence.apps.reproduce.{source}")
    report = module.run(tmp_path)
    names = {Path(a).name for a in report.artifacts if str(a).endswith(".png")}
    assert names
    check_all(recorded, names)
