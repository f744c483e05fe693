"""Every figure the CLI writes passes the figure checker (``figure_checks.py``), which itself
fails on a planted bad figure (one per rule).

Each command's test checks every figure it saved and every frame check of every animation it
wrote (first, middle, last), and that each ``.png``/``.gif``/``.mp4`` in its output folder is
one of those (``check_every``); MuJoCo's video frames are not matplotlib figures and are checked
here on the decoded file. Covered: ``velfence demo --config examples/demo-config.yaml`` (short),
the arm-box demo's figures and GIF (hand-made runs here; the real demo at one speed through the
command line: test_progress.py), ``velfence replay --plot`` on both example bags (mobile base,
arm jog), ``velfence sim`` margin figures (on a hand-made result here; the three real scenarios,
each with its video at the smallest size, are slow) and ``velfence study`` at one subject
(slow). Every reproduction's figures are checked in its own test file (tests/apps/reproduce: the
run that the reproduction's checks inspect, recorded once, ``tests/shared_runs.py``). ``velfence
bench`` writes no figure. The built-in demo with its GIF, the wrist's and the study's figures
are also checked in ``test_figure_style.py`` with the same checker.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="velfence.apps.viz needs the [app] extra")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from figure_checks import Recorded, check_every, problems, record_figures  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from shared_runs import shared_scenario  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def recorded(monkeypatch: pytest.MonkeyPatch) -> Iterator[Recorded]:
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


def _snapshots(ax: Any, legend: bool) -> None:
    """A panel like obstacles_snapshots.png: an obstacle, its influence circle, arm poses, a
    closest point and the end effector's path (only the path labelled)."""
    from matplotlib.patches import Circle

    ax.add_patch(Circle((0.5, 0.5), 0.1, color="0.3"))
    ax.add_patch(Circle((0.5, 0.5), 0.2, fill=False, ls="--", color="C3"))
    for k in range(3):
        ax.plot([0.0, 0.3, 0.3 + 0.1 * k], [0.0, 0.2, 0.4], "-o", color="C0", alpha=0.3 + 0.3 * k)
    ax.plot([0.35], [0.4], "o", color="r")
    ax.plot([0.3, 0.5], [0.4, 0.4], color="C1", label="EE path")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    if legend:  # proxies for the unlabelled kinds, one entry each
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch

        extra = [
            (Patch(color="0.3"), "obstacle"),
            (Patch(fill=False, ls="--", color="C3"), "sphere of influence"),
            (Line2D([], [], marker="o", color="C0"), "arm pose (light: early)"),
            (Line2D([], [], marker="o", ls="", color="r"), "closest point"),
        ]
        handles, labels = ax.get_legend_handles_labels()
        ax.legend([*handles, *(h for h, _ in extra)], [*labels, *(t for _, t in extra)])
    else:
        ax.legend()


def test_the_legend_rule_sees_unlabelled_kinds_of_artists() -> None:
    # One labelled series and a legend for it pass the label rule; the obstacle, its dashed
    # influence circle, the arm poses and the red closest point are still unexplained.
    fig = Figure()
    _snapshots(fig.subplots(), legend=False)
    found = "\n".join(problems("snap", fig))
    assert "kinds of artists no legend explains" in found
    for kind in (
        "area #4c4c4c",
        "line #d62728 '--'",
        "line #1f77b4 '-' 'o'",
        "line #ff0000 'o'",
    ):
        assert kind in found, found
    assert "#ff7f0e" not in found  # the labelled EE path is explained
    good = Figure()
    _snapshots(good.subplots(), legend=True)
    assert problems("snap", good) == []
    # Exempt: one kind (a single series needs no legend), an image, and a colour-mapped
    # scatter whose colour bar explains it beside one line.
    fig = Figure()
    a, b, c = fig.subplots(1, 3)
    for k in range(3):
        a.plot([0, 1], [0.1 * k, 0.5 + 0.1 * k], color="C0")
    a.set_ylim(0.0, 1.0)
    b.imshow(np.zeros((3, 3, 3)))
    sc = c.scatter([0, 1], [0, 1], c=[0.0, 1.0])
    fig.colorbar(sc, ax=c, label="speed [m/s]")
    c.plot([0, 1], [1, 0], color="k")
    for ax in (a, c):
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    assert problems("exempt", fig) == []
    plt.close("all")


def test_the_clipping_rule_sees_text_cut_off_and_a_legend_over_a_title() -> None:
    # Like the old physics_obstacle.png: a title pushed past the left edge of the canvas, and a
    # legend placed over it.
    fig = Figure(figsize=(4.0, 3.0))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="velfence")
    ax.plot([0, 1], [1, 0], label="no limit")
    ax.set_title("clearance to the obstacle surface over the whole run", loc="left", x=-0.4)
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, 0.98), ncol=2)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("clearance [mm]")
    found = "\n".join(problems("clip", fig))
    assert "axes 0 ('') title 'clearance to the obstacle surface" in found
    assert "cut off by the canvas" in found
    assert "legend 0 of axes 0 covers the axes 0 ('') title" in found
    # Laid out by the layout engine and the legend beside the axes: nothing cut off.
    fig = Figure(figsize=(6.0, 3.0), layout="constrained")
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1], label="velfence")
    ax.plot([0, 1], [1, 0], label="no limit")
    ax.set_title("clearance to the obstacle surface")
    fig.legend(loc="outside right upper")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("clearance [mm]")
    fig.suptitle("a suptitle inside the canvas")
    assert problems("fits", fig) == []
    # A suptitle and an axis label beyond the canvas are reported too.
    fig.suptitle("a suptitle far too long for a figure six inches wide, running off both sides")
    ax.set_ylabel("a y label so long that it runs past the bottom and the top of the canvas [mm]")
    found = "\n".join(problems("fits", fig))
    assert "suptitle 'a suptitle far too long" in found
    assert "y label 'a y label so long" in found
    plt.close("all")


# --- the CLI's figures ----------------------------------------------------------------------


def _cli(*args: str) -> Any:
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    return CliRunner().invoke(app, list(args))


def test_demo_with_the_example_config(tmp_path: Path, recorded: Recorded) -> None:
    from velfence.apps.demo import run_demo
    from velfence.apps.demo.config import load_config

    cfg = load_config(ROOT / "examples" / "demo-config.yaml")
    # No GIF here (it made this test take minutes): the built-in scenario's demo.gif is
    # checked frame by frame in test_figure_style.py.
    cfg = cfg.model_copy(update={"gif": False, "duration": 5.0})
    run_demo(config=cfg, out_dir=tmp_path)
    written = check_every(recorded, tmp_path)
    assert {"workspace.png", "velocity.png", "quiver.png"} <= written
    # Each path drawn in its own dash style, above the one before it: none hides another.
    ax = recorded["workspace.png"].axes[0]
    paths = [ln for ln in ax.lines if ln.get_label() in ("hard-stop", "patent", "exact")]
    assert len({(ln.get_linestyle(), ln.get_linewidth()) for ln in paths}) == 3
    assert len({ln.get_zorder() for ln in paths}) == 3
    entries = [t.get_text() for t in recorded["workspace.png"].legends[0].get_texts()]
    assert any(e == "buffer band (0.08 rad wide)" for e in entries), entries


def test_arm_box_figures_on_hand_made_runs(tmp_path: Path, recorded: Recorded) -> None:
    from test_arm_viz import RUNS, SCENE

    from velfence.apps.viz.arm import (
        animate_arm,
        plot_arm_activity,
        plot_arm_joints,
        plot_arm_paths,
    )

    plot_arm_paths(SCENE, RUNS, tmp_path / "arm_paths.png")
    plot_arm_joints(SCENE, RUNS, tmp_path / "arm_joints.png")
    plot_arm_activity(RUNS, tmp_path / "arm_activity.png")
    animate_arm(SCENE, RUNS["safety-filter"], tmp_path / "arm_velfence.gif", frames=5, fps=5)
    check_every(recorded, tmp_path)
    assert len(recorded.animations["arm_velfence.gif"]) == 5
    legend = recorded["arm_paths.png"].legends[0]
    entries = {t.get_text() for t in legend.get_texts()}
    assert {"box (TCP fence)", "sphere (obstacle)", "TCP path"} <= entries
    # The GIF's legend names the box and the sphere too (the published one did not).
    gif = next(f for n, f in recorded.items() if n.startswith("frame-of-"))
    gif_entries = {t.get_text() for t in gif.axes[0].get_legend().get_texts()}
    assert {"box (TCP fence)", "sphere (obstacle)", "links", "TCP path"} <= gif_entries
    # The hand-made runs hold joints 1..6 constant: a fixed range and a note, not round-off.
    joints = [a for a in recorded["arm_joints.png"].axes if a.get_ylabel().startswith("q")]
    q6 = joints[6]
    lo, hi = q6.get_ylim()
    assert hi - lo >= 0.1
    assert any("constant" in t.get_text() for t in q6.texts)


@pytest.mark.parametrize("bag", ["mobile_base", "arm_jog"])
def test_replay_figures_name_whose_path_it_is(tmp_path: Path, recorded: Recorded, bag: str) -> None:
    folder = ROOT / "examples" / "bags" / bag
    plot = tmp_path / f"replay_{bag}.png"
    result = _cli(
        "replay", str(folder / "bag"), "--config", str(folder / "replay.yaml"),
        "--out", str(tmp_path / "out"), "--plot", str(plot),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert check_every(recorded, tmp_path) == {plot.name}
    texts = " ".join(
        t.get_text() for ax in recorded[plot.name].axes if ax.get_legend()
        for t in ax.get_legend().get_texts()
    )  # fmt: skip
    assert "operator's command (recorded)" in texts
    assert "velfence's output (shaped)" in texts
    if bag == "mobile_base":  # the planar layout: the recorded path beside the commands
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
def test_sim_margin_figure(tmp_path: Path, recorded: Recorded, contacts: bool) -> None:
    from velfence.apps.scenarios.output import plot_margins

    plot_margins(_fake_result(contacts), tmp_path / "fake_margins.png")
    check_every(recorded, tmp_path)
    fig = recorded["fake_margins.png"]
    assert len(fig.axes) == (2 if contacts else 1)  # no empty contacts panel
    if contacts:  # a count has whole-number ticks
        ticks = fig.axes[1].get_yticks()
        assert len(ticks) >= 2
        assert np.all(ticks == np.round(ticks)), ticks
    ax = fig.axes[0]
    entries = {t.get_text() for t in fig.legends[0].get_texts()}
    assert "obstacle surface (0 mm)" in entries  # the line the title names is in the legend
    assert "below the obstacle surface line" in ax.get_title().replace("\n", " ")
    a, b = (ln for ln in ax.lines if ln.get_label() in ("no limit", "per-joint clamp"))
    assert (a.get_linestyle(), a.get_linewidth()) != (b.get_linestyle(), b.get_linewidth())
    assert b.get_zorder() > a.get_zorder()


# --- heavy: the real runs ---------------------------------------------------------------------


def _video_frames(path: Path) -> list[np.ndarray]:
    """The first, a middle and the last frame of a written GIF or MP4, decoded."""
    if path.suffix == ".gif":
        from PIL import Image, ImageSequence

        with Image.open(path) as im:
            frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]
    else:
        imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
        reader = imageio_ffmpeg.read_frames(str(path))
        meta = next(reader)
        w, h = meta["size"]
        frames = [np.frombuffer(b, np.uint8).reshape(h, w, 3) for b in reader]
    assert frames, f"{path.name}: no frame"
    return [frames[0], frames[len(frames) // 2], frames[-1]]


@pytest.mark.slow  # about a minute each: a MuJoCo scenario with its video at 64 x 48 px
@pytest.mark.parametrize(
    "scenario", ["fence-box", "wrist-push", "redundant-obstacle", "person-cell"]
)
def test_sim_scenarios(tmp_path: Path, recorded: Recorded, scenario: str) -> None:
    pytest.importorskip("mujoco")
    monkeypatch = pytest.MonkeyPatch()
    monkeypatch.setenv("MUJOCO_GL", "egl")
    # The simulation is the one the scenario's own tests inspect (tests/shared_runs.py); the
    # command draws its figures and video from it here.
    shared_scenario(monkeypatch, scenario)
    out = tmp_path / scenario
    result = _cli(
        "sim", "--scenario", scenario, "--out", str(out), "--quiet",
        "--width", "64", "--height", "48", "--fps", "2",
    )  # fmt: skip
    monkeypatch.undo()
    # docs/physics.md: every named check of the scenarios passes (exit code 0).
    assert result.exit_code == 0, result.output
    if scenario == "person-cell":  # advisory, and the command says so with its results
        assert "not a certified safety function" in " ".join(result.output.split())
    videos = {f"{scenario}.mp4", f"{scenario}.gif"}
    written = check_every(recorded, out, videos=videos)
    assert {f"{scenario}_margins.png", *videos} <= written
    # MuJoCo's frames are pictures, not figures: the first, middle and last frame each show a
    # scene (not one colour), at least one panel wide, and the robot moves between them.
    for name in videos:
        frames = _video_frames(out / name)
        for frame in frames:
            assert frame.shape[1] >= 64
            assert float(frame.std()) > 5.0, f"{name}: a blank frame"
        first, last = (f.astype(float) for f in (frames[0], frames[-1]))
        moved = np.count_nonzero(np.abs(first - last).max(axis=2) > 30.0)  # not codec noise
        assert moved >= 10, f"{name}: nothing moves ({moved} pixels changed)"


@pytest.mark.slow  # one subject, one run per mode and the assisted run's GIF (minutes here)
def test_study(tmp_path: Path, recorded: Recorded) -> None:
    # One run for the figures and the --json contract (tests/apps/teleop/test_study.py: the parts).
    result = _cli(
        "study", "--subjects", "1", "--runs", "1", "--seed", "2", "--out", str(tmp_path),
        "--quiet", "--json",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    obj = json.loads(result.stdout)
    assert obj["summary"]["subjects"] == 1
    assert {p.split("/")[-1] for p in obj["artifacts"]} == {
        "study.json",
        "study_times.png",
        "study_paths.png",
        "assisted_run.gif",
        "assisted_snapshot.png",
        "study_runs.npz",  # the runs, for `reproduce telerobotics --study` to reuse
    }
    written = check_every(recorded, tmp_path)
    assert {"study_paths.png", "study_times.png", "assisted_run.gif", "assisted_snapshot.png"} <= (
        written
    )
    for ax in recorded["study_paths.png"].axes:
        assert len(ax.get_xticks()) <= 5  # no overlapping tick labels on the small 3-D panels
