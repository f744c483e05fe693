"""Figures of the cobot reproduction (Gillespie et al. 1999 Fig. 5 style, errors, walls)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Protocol

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from velfence.apps.viz.plots import _draw_polygon, save_figure
from velfence.geometry.paths import Path as GeoPath
from velfence.geometry.polygon import ConvexPolygon
from velfence.sim.cobot import CobotTrace
from velfence.sim.runner import Trajectory

__all__ = ["WallTraces", "plot_errors", "plot_fig5", "plot_steering", "plot_walls"]


class WallTraces(Protocol):
    """What :func:`plot_walls` reads of the virtual-wall scenario.

    :class:`velfence.apps.reproduce.cobot.WallRuns` has these members; any object with them draws
    alike.
    """

    @property
    def actuated(self) -> Trajectory:
        """The actuated device under the exact polygon shaper."""
        ...

    @property
    def caster(self) -> Trajectory:
        """The ideal passive caster wall."""
        ...

    @property
    def cobot(self) -> Trajectory:
        """The simulated r-θ cobot."""
        ...


def plot_fig5(
    trace: CobotTrace,
    path_geo: GeoPath,
    out: str | Path,
    *,
    generic: CobotTrace | None = None,
    every: float = 0.25,
) -> Path:
    """The Fig. 5 picture: planned path, reference points (o) and cobot positions (*).

    Args:
        trace: A path-following run (with reference points recorded).
        path_geo: The planned path.
        out: File to write.
        generic: Optional C_EE-model trace drawn as a thin line for comparison.
        every: Arc-length spacing of the markers [m].
    """
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    S = np.linspace(0.0, path_geo.length, 400)
    P = path_geo.points(S)
    ax.plot(P[:, 0], P[:, 1], color="0.6", lw=1.0, label="planned path")
    ax.plot(trace.R[:, 0], trace.R[:, 1], color="C0", lw=1.2, label=f"{trace.name} trace")
    if generic is not None:
        ax.plot(generic.R[:, 0], generic.R[:, 1], "--", color="C3", lw=0.9, label="C_EE model")
    marks = np.searchsorted(trace.s, np.arange(0.0, trace.s[-1], every))
    ax.plot(trace.reference[marks, 0], trace.reference[marks, 1], "o", mfc="none", color="k",
            ms=6, label="reference points R_p(s_p)")  # fmt: skip
    ax.plot(trace.R[marks, 0], trace.R[marks, 1], "*", color="C1", ms=8, label="cobot positions")
    for j, k in enumerate(marks):
        ax.plot(
            [trace.R[k, 0], trace.reference[k, 0]], [trace.R[k, 1], trace.reference[k, 1]],
            color="0.75", lw=0.6, label="position to its reference point" if j == 0 else None,
        )  # fmt: skip
    ax.plot(0.0, 0.0, "k+", ms=8, label="circle centre")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Following the unit circle from (1.2, 0), heading +y (cf. Fig. 5)")
    # Inside the circle, below its centre: the legend covers no part of the path.
    ax.legend(loc="upper center", bbox_to_anchor=(0.45, 0.46), fontsize=8)
    return save_figure(fig, out)


def plot_errors(traces: Mapping[str, CobotTrace], out: str | Path) -> Path:
    """|ΔR| against arc length s (log scale) for several runs."""
    fig, ax = plt.subplots(figsize=(8, 4.8))
    for i, (name, tr) in enumerate(traces.items()):
        e = np.maximum(tr.error_norm, 1e-12)
        ax.semilogy(tr.s, e, lw=1.1, color=f"C{i % 10}", label=name,
                    ls="--" if name.startswith("C_EE") else "-")  # fmt: skip
    bounds = "checked bounds: 2e-2 m by s = 2 m, 1e-3 m by s = 5 m"
    ax.axhline(2e-2, color="0.5", lw=0.6, ls=":", label=bounds)
    ax.axhline(1e-3, color="0.5", lw=0.6, ls=":")  # the same kind: one legend entry
    ax.set_xlabel("arc length s [m]")
    ax.set_ylabel("|ΔR| [m]")
    ax.set_title("Path error against arc length: identical at every human speed")
    ax.legend(fontsize=7, ncol=2)
    return save_figure(fig, out)


def plot_steering(traces: Mapping[str, CobotTrace], out: str | Path) -> Path:
    """Steering angle and steering rate against arc length."""
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, (name, tr) in enumerate(traces.items()):
        a1.plot(tr.s, np.unwrap(tr.phi[:, 0]), color=f"C{i}", lw=1.1, label=name)
        a2.plot(tr.s, tr.phi_dot[:, 0], color=f"C{i}", lw=1.0, label=name)
    a1.set_ylabel("steering angle φ [rad]")
    a1.set_title("Tetrahedral CVT steering: φ(s) is the same, φ̇ scales with the human's speed")
    a2.set_ylabel("steering rate φ̇ [rad/s]")
    a2.set_xlabel("arc length s [m]")
    a1.legend(fontsize=8)
    return save_figure(fig, out)


def plot_walls(runs: WallTraces, polygon: ConvexPolygon, buffer: float, out: str | Path) -> Path:
    """One workspace polygon bounding an actuated device and a passive cobot."""
    fig, ax = plt.subplots(figsize=(7.5, 6.5))
    _draw_polygon(ax, polygon, buffer=buffer, margin=0.15)
    for i, tr in enumerate((runs.actuated, runs.caster, runs.cobot)):
        ax.plot(tr.p[:, 0], tr.p[:, 1], lw=1.3, color=f"C{i}", label=tr.name,
                ls=("-", "--", "-.")[i])  # fmt: skip
    ax.plot(runs.actuated.p[0, 0], runs.actuated.p[0, 1], "ko", ms=4, label="start point")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("Virtual wall: the same polygon for an actuated device and a cobot")
    ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, out)
