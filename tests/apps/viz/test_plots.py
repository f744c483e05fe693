"""Workspace, velocity and animation plots (velfence.apps.viz.plots): files written, inputs
refused."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib", reason="velfence.apps.viz needs the [app] extra")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import velfence as vf  # noqa: E402
from velfence.apps.viz import plots  # noqa: E402
from velfence.errors import InvalidInput, InvalidParameter  # noqa: E402
from velfence.geometry.polygon import ConvexPolygon  # noqa: E402
from velfence.sim import Trajectory  # noqa: E402

SQUARE = ConvexPolygon([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


def _traj() -> Trajectory:
    t = np.linspace(0.0, 0.49, 50)
    p = np.column_stack([np.linspace(0.0, 1.2, 50), np.zeros(50)])
    v = np.tile([2.4, 0.0], (50, 1))
    return Trajectory(t, p, v, v)


def _shaper() -> vf.PolygonShaper:
    return vf.PolygonShaper(SQUARE, buffer=0.2, accelerate=False)


def _png(path: Path) -> None:
    assert path.stat().st_size > 500
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_every_plot_writes_its_file(tmp_path: Path) -> None:
    trs = {"exact": _traj()}
    shs = {"exact": _shaper()}
    rect = vf.Rectangle(xmin=-0.5, xmax=0.5, ymin=-0.5, ymax=0.5)
    out = plots.plot_workspace(
        SQUARE, trs, tmp_path / "w.png", buffer=0.2, rectangle=rect, labels=("x", "y")
    )
    _png(out)
    _png(plots.plot_velocity_profiles(SQUARE, trs, str(tmp_path / "v.png")))
    # NumPy scalars and int64 counts are valid.
    _png(plots.plot_quiver(SQUARE, shs, tmp_path / "q.png", command=np.array([1, 0]), grid=5))
    _png(
        plots.plot_velocity_patterns(
            SQUARE, shs, np.array([[0.5, 0.5]], dtype=np.float32), tmp_path / "p.png",
            speed=np.float32(0.5), rays=np.int64(12),
        )
    )  # fmt: skip
    gif = plots.animate_trajectories(SQUARE, trs, tmp_path / "a.gif", frames=3, fps=5)
    assert gif.read_bytes()[:3] == b"GIF"


@pytest.mark.parametrize(
    ("fn", "kwargs", "match"),
    [
        (plots.plot_workspace, {"polygon": "12"}, r"^polygon: expected a velfence ConvexPolygon"),
        (plots.plot_workspace, {"trajectories": {"a": 1.0}}, r"^trajectories\['a'\]: expected"),
        (plots.plot_workspace, {"trajectories": {}}, r"^trajectories: expected 1 to 100"),
        (plots.plot_workspace, {"buffer": "12"}, r"^buffer must be a number"),
        (plots.plot_workspace, {"buffer": -1}, r"^buffer must be finite and > 0"),
        (plots.plot_workspace, {"labels": "12"}, r"^labels: expected two axis labels"),
        (plots.plot_workspace, {"labels": ("x", 3)}, r"^labels: expected a string"),
        (plots.plot_workspace, {"title": 1.0}, r"^title: expected a string"),
        (plots.plot_workspace, {"rectangle": SQUARE}, r"^rectangle: expected a velfence Rect"),
        (plots.plot_workspace, {"path": {"x": 1}}, r"^path: expected a file path"),
        (plots.plot_workspace, {"path": "/nonexistent-dir-xyz/a.png"}, r"^path: the directory"),
        (plots.animate_trajectories, {"frames": 10**9}, r"^frames: expected an int <="),
        (plots.animate_trajectories, {"fps": True}, r"^fps: expected a positive int"),
    ],
)
def test_trajectory_plots_refuse_bad_arguments(fn: Any, kwargs: dict[str, Any], match: str) -> None:
    args: dict[str, Any] = {"polygon": SQUARE, "trajectories": {"a": _traj()}, "path": "x.png"}
    with pytest.raises((InvalidInput, InvalidParameter), match=match):
        fn(**{**args, **kwargs})


@pytest.mark.parametrize(
    ("fn", "kwargs", "match"),
    [
        (plots.plot_quiver, {"shapers": {"a": "not a shaper"}}, r"^shapers\['a'\]: expected"),
        (plots.plot_quiver, {"shapers": True}, r"^shapers: expected a mapping"),
        (plots.plot_quiver, {"command": "12"}, r"^command: expected"),
        (plots.plot_quiver, {"command": (0.0, 0.0)}, r"^command: expected a nonzero"),
        (plots.plot_quiver, {"grid": 1}, r"^grid: expected an int >= 2"),
        (plots.plot_quiver, {"grid": 10**6}, r"^grid: expected an int <="),
        (plots.plot_velocity_patterns, {"points": "12"}, r"^points: expected"),
        (plots.plot_velocity_patterns, {"points": [[np.nan, 0.0]]}, r"^points: expected finite"),
        (plots.plot_velocity_patterns, {"speed": 0.0}, r"^speed must be finite and > 0"),
        (plots.plot_velocity_patterns, {"radius": 1e308}, r"^radius must be <="),
        (plots.plot_velocity_patterns, {"rays": 2}, r"^rays: expected an int >= 3"),
    ],
)
def test_shaper_plots_refuse_bad_arguments(fn: Any, kwargs: dict[str, Any], match: str) -> None:
    args: dict[str, Any] = {"polygon": SQUARE, "shapers": {"a": _shaper()}, "path": "x.png"}
    if fn is plots.plot_velocity_patterns:
        args["points"] = [[0.5, 0.5]]
    with pytest.raises((InvalidInput, InvalidParameter), match=match):
        fn(**{**args, **kwargs})


def test_save_figure_checks_and_releases(tmp_path: Path) -> None:
    with pytest.raises(InvalidInput, match=r"^fig: expected a matplotlib Figure"):
        plots.save_figure("12", tmp_path / "f.png")
    fig = plt.figure()
    with pytest.raises(InvalidParameter, match=r"^dpi: expected an int <= 1,200"):
        plots.save_figure(fig, tmp_path / "f.png", dpi=10**6)
    assert not plt.fignum_exists(fig.number)  # a refused call does not leak the figure
    with pytest.raises(InvalidParameter, match=r"^path: expected a file path, got the directory"):
        plots.save_figure(Figure(), tmp_path)
    with pytest.raises(InvalidParameter, match=r"^path: cannot write"):
        plots.save_figure(Figure(), tmp_path / "f.unknown-suffix")
    _png(plots.save_figure(Figure(), tmp_path / "f.png", dpi=np.int64(50)))
