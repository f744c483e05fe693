"""Figures of the obstacle reproduction (configuration control, US 5,150,026 claim 1).

Arm snapshots with obstacle bodies, spheres of influence and critical points (planar, or two
projections for a spatial chain), clearance and EE error over time, the active-set timeline, and
a GIF of scenario (i).
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import PillowWriter
from matplotlib.patches import Circle
from numpy.typing import NDArray

from velfence._typing import FloatArray
from velfence.apps import progress
from velfence.apps.viz.plots import save_figure
from velfence.filter import SphereObstacle
from velfence.mechanisms.chain import SerialChain
from velfence.redundancy.configuration_control import ControlResult

__all__ = ["ArmRun", "animate_arm", "plot_active_sets", "plot_clearance", "plot_snapshots"]


class ArmRun(Protocol):
    """What the figures read of a closed-loop configuration-control run.

    :class:`velfence.apps.reproduce.obstacles.ScenarioRun` has these members; any object with them
    draws alike.
    """

    @property
    def name(self) -> str:
        """Label of the run."""
        ...

    @property
    def chain(self) -> SerialChain:
        """The kinematics."""
        ...

    @property
    def obstacles(self) -> Sequence[SphereObstacle]:
        """The obstacles."""
        ...

    @property
    def t(self) -> FloatArray:
        """Times [s], shape (N,)."""
        ...

    @property
    def q(self) -> FloatArray:
        """Joint positions [rad], shape (N, n)."""
        ...

    @property
    def y(self) -> FloatArray:
        """End-effector positions [m], shape (N, m)."""
        ...

    @property
    def y_d(self) -> FloatArray:
        """Reference positions [m], shape (N, m)."""
        ...

    @property
    def results(self) -> Sequence[ControlResult]:
        """Every cycle's result, length N."""
        ...

    @property
    def ee_error(self) -> FloatArray:
        """End-effector position error [m], shape (N,)."""
        ...

    @property
    def distances(self) -> FloatArray:
        """Critical distances [m], shape (N, N_o)."""
        ...

    @property
    def rho(self) -> FloatArray:
        """Sphere-of-influence radii [m], shape (N_o,)."""
        ...

    @property
    def active(self) -> NDArray[np.bool_]:
        """Whether each obstacle's row was enforced, shape (N, N_o)."""
        ...


_PLANES = {"x-y": (0, 1), "x-z": (0, 2), "y-z": (1, 2)}
#: Clearance [m] below which the clearance panels are linear (logarithmic above).
_CLEARANCE_LINEAR = 0.1


def _obstacles(ax: Any, run: ArmRun, axes: tuple[int, int]) -> None:
    """The obstacle bodies (grey, one legend entry) and each sphere of influence (its colour)."""
    for i, ob in enumerate(run.obstacles):
        c = ob.center[list(axes)]
        body = "obstacle body" if i == 0 else "_nolegend_"
        ax.add_patch(Circle(tuple(c), ob.radius, color="0.3", zorder=1, label=body))
        if ob.influence is not None:
            ax.add_patch(
                Circle(
                    tuple(c), ob.influence, fill=False, ls="--", color=f"C{i + 3}", zorder=1,
                    label=f"obstacle {i}: sphere of influence",
                )
            )  # fmt: skip


def _arm(
    ax: Any, run: ArmRun, k: int, axes: tuple[int, int], alpha: float, *, label: bool = True
) -> None:
    """The arm at sample ``k`` and the critical points of its active rows (red).

    ``label``: name the arm in the legend; the first critical point of a panel is named.
    """
    pts = np.asarray(run.chain.joint_positions(run.q[k]))[:, list(axes)]
    ax.plot(
        pts[:, 0], pts[:, 1], "-o", color="C0", lw=1.5, ms=2.5, alpha=alpha, zorder=2,
        label="arm (light to dark: time)" if label else "_nolegend_",
    )  # fmt: skip
    res = run.results[k]
    for o in res.active:
        c = res.critical_points[o][list(axes)]
        named = not any(ln.get_label() == _CRITICAL for ln in ax.lines)  # once per panel
        ax.plot(
            c[0], c[1], "o", color="r", ms=4, zorder=3, label=_CRITICAL if named else "_nolegend_"
        )


#: The legend entry of the critical points.
_CRITICAL = "critical point (active row)"


def _snapshot_panel(ax: Any, run: ArmRun, axes: tuple[int, int], n_snap: int = 9) -> None:
    _obstacles(ax, run, axes)
    ks = np.linspace(0, len(run.t) - 1, n_snap).astype(int)
    for j, k in enumerate(ks):
        _arm(ax, run, int(k), axes, 0.25 + 0.75 * j / max(1, n_snap - 1), label=j == n_snap - 1)
    ax.plot(run.y_d[:, axes[0]], run.y_d[:, axes[1]], "k:", lw=0.8, label="EE reference")
    if run.y.shape[1] > max(axes):
        ax.plot(run.y[:, axes[0]], run.y[:, axes[1]], color="C1", lw=1.0, label="EE path")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.legend(fontsize=7, loc="best")


def plot_snapshots(runs: Sequence[ArmRun], path: str | Path) -> Path:
    """Arm snapshots over time (light to dark) among the obstacles.

    Obstacle bodies (grey), spheres of influence (dashed), critical points of the active rows
    (red); spatial chains on the x-z and y-z planes.

    Returns:
        The path written.
    """
    panels: list[tuple[ArmRun, str]] = []
    for r in runs:
        if r.y.shape[1] == 2:
            panels.append((r, "x-y"))
        else:
            panels.extend(((r, "x-z"), (r, "y-z")))
    fig, axs = plt.subplots(1, len(panels), figsize=(5.0 * len(panels), 5.0), squeeze=False)
    for ax, (r, plane) in zip(axs[0], panels, strict=True):
        axes = _PLANES[plane]
        _snapshot_panel(ax, r, axes)
        ax.set_title(f"{r.name} ({plane})", fontsize=9)
        ax.set_xlabel(f"{plane[0]} [m]")
        ax.set_ylabel(f"{plane[2]} [m]")
    return save_figure(fig, path, dpi=90)


def plot_clearance(runs: Sequence[ArmRun], path: str | Path) -> Path:
    """Clearance d − ρ of every obstacle (top) and EE error (bottom) over time, one column per run.

    Returns:
        The path written.
    """
    # At most three runs a row, so titles and ticks stay readable at 100 % (one wide strip of six
    # panels was 1944 px wide with 8-pt titles).
    cols = min(len(runs), 3)
    rows = math.ceil(len(runs) / cols)
    fig, grid = plt.subplots(
        2 * rows, cols, figsize=(4.6 * cols, 5.4 * rows), squeeze=False, layout="constrained"
    )
    for j in range(len(runs), rows * cols):  # no empty panels
        grid[2 * (j // cols), j % cols].remove()
        grid[2 * (j // cols) + 1, j % cols].remove()
    for col, r in enumerate(runs):
        top, low = grid[2 * (col // cols), col % cols], grid[2 * (col // cols) + 1, col % cols]
        d = r.distances - r.rho
        for o in range(d.shape[1]):
            top.plot(r.t, d[:, o], color=f"C{o + 3}", lw=1.0, label=f"obstacle {o}")
        top.axhline(0.0, color="k", lw=0.8, label="edge of the sphere of influence (d = ρ)")
        # Linear near contact (|d − ρ| < 0.1 m, where the fence acts), logarithmic above, so the
        # approach from afar stays in view. Never clip a penetration: the lower limit follows
        # the deepest point, the upper one the farthest.
        top.set_yscale("symlog", linthresh=_CLEARANCE_LINEAR, linscale=3.0)
        top.set_ylim(min(-0.01, 1.1 * float(np.min(d))), max(0.1, 1.5 * float(np.max(d))))
        top.set_title(textwrap.fill(r.name, 34), fontsize=10)
        top.set_ylabel(f"clearance d − ρ [m]\n(log above {_CLEARANCE_LINEAR:g} m)")
        top.set_xlabel("t [s]")
        top.legend(fontsize=8)
        low.semilogy(r.t, np.maximum(r.ee_error, 1e-9), color="C1", lw=1.0)
        low.set_ylabel("EE error [m]")
        low.set_xlabel("t [s]")
    return save_figure(fig, path, dpi=90)


def plot_active_sets(runs: Sequence[ArmRun], path: str | Path) -> Path:
    """Active-set timeline: one bar per obstacle where its row is enforced, and the row count.

    Returns:
        The path written.
    """
    # Each run on its own time axis (their lengths differ by a factor of four), each labelled.
    fig, axs = plt.subplots(
        len(runs), 1, figsize=(9.0, 2.0 * len(runs)), squeeze=False, layout="constrained"
    )
    for ax, r in zip(axs[:, 0], runs, strict=True):
        a = r.active
        for o in range(a.shape[1]):
            ax.fill_between(
                r.t, o + 0.1, o + 0.9, where=a[:, o], step="post", color=f"C{o + 3}", alpha=0.7,
                label=f"obstacle {o}: row enforced",
            )  # fmt: skip
        ax.step(r.t, a.sum(axis=1), where="post", color="k", lw=0.8, label="rows")
        ax.axhline(r.results[0].redundancy, color="r", ls=":", lw=0.8, label="redundancy")
        ax.set_ylim(-0.1, max(a.shape[1], r.results[0].redundancy) + 0.2)
        ax.set_title(r.name, fontsize=8)
        ax.set_ylabel("obstacle bar /\nactive rows [1]")
        ax.set_xlabel("t [s]", labelpad=1)
        ax.legend(fontsize=6, loc="upper left")
    return save_figure(fig, path, dpi=90)


def animate_arm(run: ArmRun, path: str | Path, *, frames: int = 40) -> Path:
    """GIF of a planar run: the arm, obstacles, spheres and active critical points.

    Returns:
        The path written.
    """
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    fig.subplots_adjust(left=0.1, right=0.6, bottom=0.12, top=0.86)  # the legend at the right
    ks = np.linspace(0, len(run.t) - 1, frames).astype(int)
    writer = PillowWriter(fps=8)
    out = Path(path)
    pts = np.array([np.asarray(run.chain.joint_positions(q))[:, :2] for q in run.q[ks]])
    lo, hi = pts.reshape(-1, 2).min(axis=0) - 0.3, pts.reshape(-1, 2).max(axis=0) + 0.3
    with writer.saving(fig, str(out), dpi=60):
        on_frame = progress.frames(out.name)
        for j, k in enumerate(ks):
            on_frame(j, len(ks))
            ax.clear()
            _obstacles(ax, run, (0, 1))
            _arm(ax, run, int(k), (0, 1), 1.0)
            ax.plot(run.y_d[:, 0], run.y_d[:, 1], "k:", lw=0.8, label="EE reference")
            if not any(ln.get_label() == _CRITICAL for ln in ax.lines):  # a steady legend
                ax.plot([], [], "o", color="r", ms=4, label=_CRITICAL)
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_aspect("equal")
            ax.set_xlabel("x [m]", fontsize=7)
            ax.set_ylabel("y [m]", fontsize=7)
            ax.tick_params(labelsize=6)
            ax.set_title(f"{run.name}\nt = {run.t[k]:.2f} s", fontsize=7)
            ax.legend(fontsize=6, loc="upper left", bbox_to_anchor=(1.03, 1.0))
            writer.grab_frame()
    plt.close(fig)
    return out
