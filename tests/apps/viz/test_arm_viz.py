"""velfence.apps.viz.arm: every figure is written, sized and labelled; bad arguments are named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from PIL import Image

from velfence.apps.demo.arm_box import ArmRun, arm_box_scene
from velfence.apps.viz.arm import (
    animate_arm,
    plot_arm_activity,
    plot_arm_joints,
    plot_arm_paths,
)
from velfence.errors import InvalidInput
from velfence.sim.runner import Trajectory

SCENE = arm_box_scene()


def fake_run(name: str, shift: float) -> ArmRun:
    """A hand-made 40-row run: joint 0 sweeps, with one row active and one dropped level."""
    n = 40
    t = 0.01 * np.arange(n)
    q = np.tile(SCENE.q0, (n, 1))
    q[:, 0] = np.linspace(0.0, -0.15 + shift, n)
    tcp = np.array([SCENE.robot.fk(r) for r in q])
    segs = np.array([SCENE.robot.link_segments(r) for r in q])
    tr = Trajectory(t, q, np.zeros((n, 3)), np.zeros((n, 7)), name=name)
    active = tuple(("TCP face x_max",) if k > 20 else () for k in range(n))
    dropped = tuple(("obstacles",) if k == 30 else () for k in range(n))
    return ArmRun(tr, tcp, segs, active, dropped, 0.25)


RUNS = {"no-limit": fake_run("no-limit", 0.05), "safety-filter": fake_run("safety-filter", 0.0)}


@pytest.mark.parametrize(
    "draw",
    [
        lambda p: plot_arm_paths(SCENE, RUNS, p),
        lambda p: plot_arm_joints(SCENE, RUNS, p),
        lambda p: plot_arm_activity(RUNS, p),
    ],
    ids=["paths", "joints", "activity"],
)
def test_figures_are_written(draw, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = draw(tmp_path / "fig.png")
    assert out == tmp_path / "fig.png"
    with Image.open(out) as im:
        assert im.size[0] >= 600


def test_gif_is_at_least_600_px_wide(tmp_path: Path) -> None:
    out = animate_arm(SCENE, RUNS["safety-filter"], tmp_path / "arm.gif", frames=5, fps=5)
    with Image.open(out) as im:
        assert im.size[0] >= 600
        assert im.n_frames == 5


def test_bad_arguments_are_named(tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match="runs"):
        plot_arm_paths(SCENE, {}, tmp_path / "a.png")
    with pytest.raises(InvalidInput, match="runs"):
        plot_arm_activity({"x": 3}, tmp_path / "a.png")
    with pytest.raises(InvalidInput, match="scene"):
        plot_arm_joints("scene", RUNS, tmp_path / "a.png")
    with pytest.raises(InvalidInput, match="run"):
        animate_arm(SCENE, RUNS, tmp_path / "a.gif")
