"""The figure of a bag replay (``velfence replay --plot``): commanded vs shaped, and the path."""

from __future__ import annotations

from pathlib import Path

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from velfence._validate import check_output_path
from velfence.apps.viz.plots import _draw_polygon, save_figure
from velfence.errors import InvalidInput
from velfence.geometry.polygon import ConvexPolygon
from velfence.io.bags import ReplaySummary

__all__ = ["plot_replay"]


def plot_replay(summary: ReplaySummary, path: str | Path) -> Path:
    """Plot each command component over time, commanded vs shaped, plus a planar path.

    One panel per component (time [s] against the command's unit), the commands written as zero
    (no state, stale state, non-finite) shaded; for a polygon shaper a last panel with the
    recorded path (x, y) [m], the fence and its buffer's inner edge.

    Args:
        summary: What :func:`velfence.io.bags.replay` returned.
        path: The image file (``.png``, ``.svg``, ...); its folder must exist.

    Returns:
        ``path``.

    Raises:
        InvalidInput: ``summary`` is not a :class:`~velfence.io.bags.ReplaySummary`.
        InvalidParameter: an unusable ``path``.
    """
    if not isinstance(summary, ReplaySummary):
        raise InvalidInput(f"summary: expected a ReplaySummary, got {type(summary).__name__}")
    out = check_output_path("path", path)
    s = summary
    k = len(s.components)
    planar = s.fence is not None
    ncols = 2 if planar else 1
    fig = plt.figure(figsize=(12 if planar else 7.5, max(2.2 * k, 4.5)), layout="constrained")
    grid = fig.add_gridspec(k, ncols, width_ratios=[1.4, 1.0] if planar else [1.0])
    zeroed = ~s.has_state
    first = None
    for i, name in enumerate(s.components):
        ax = fig.add_subplot(grid[i, 0], sharex=first)
        first = first or ax
        ax.plot(
            s.times, s.commanded[:, i], color="0.55", lw=2.4, label="operator's command (recorded)"
        )
        ax.plot(
            s.times, s.shaped[:, i], color="C2", lw=1.3, ls=(0, (5, 2)),
            label="velfence's output (shaped)",
        )  # fmt: skip
        if zeroed.any():
            ax.fill_between(
                s.times,
                0,
                1,
                where=zeroed,
                step="mid",
                color="C3",
                alpha=0.15,
                transform=ax.get_xaxis_transform(),
                label="written as zero",
            )
        ax.set_ylabel(f"{name} [{s.unit}]")
        ax.grid(alpha=0.3)
        if i == 0:
            ax.set_title(f"{s.command_topic} → {s.output_topic} ({s.kind})")
            ax.legend(loc="best", fontsize=8)
        if i == k - 1:
            ax.set_xlabel("time since the bag's start [s]")
    if planar and s.fence is not None:
        ax = fig.add_subplot(grid[:, 1])
        held = s.positions[s.has_state]
        _draw_polygon(ax, ConvexPolygon(s.fence), buffer=s.buffer, unit="m", extra=held)
        # The bag's own positions: the robot moved under the operator's raw commands, with no
        # velfence in the loop, so this path may leave the fence; velfence's output is the
        # shaped command on the left, not a path here.
        ax.plot(
            held[:, 0], held[:, 1], color="C0", lw=1.4, zorder=4,
            label="recorded path (operator's raw commands,\nvelfence not in the loop)",
        )  # fmt: skip
        if len(held):
            ax.plot(*held[0], "o", color="C0", ms=5, label="start", zorder=4)
            pts = np.vstack([s.fence, held])
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            pad = 0.1 * float(np.max(hi - lo))
            ax.set_xlim(lo[0] - pad, hi[0] + pad)
            ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        ax.set_title(
            f"{s.state_topic}: as recorded, before velfence\n"
            "(open-loop replay: velfence's output never drove this robot)",
            fontsize=9,
        )
    return save_figure(fig, out)
