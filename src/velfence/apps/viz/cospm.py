"""Figures of the CoSPM reproduction (Lê et al. 2024 Fig. 8 style, vertex scenario, region)."""

from __future__ import annotations

import math
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

from velfence._typing import FloatArray
from velfence.apps.viz.plots import save_figure
from velfence.geometry.polygon import ConvexPolygon
from velfence.sim.runner import Trajectory

__all__ = ["StopRun", "plot_fig8", "plot_region", "plot_vertex"]


class StopRun(Protocol):
    """What :func:`plot_fig8` reads of a stop-limiter run.

    :class:`velfence.apps.reproduce.cospm.PaperRun` has these members; any object with them draws
    alike.
    """

    @property
    def traj(self) -> Trajectory:
        """The closed-loop trajectory."""
        ...

    @property
    def chi_dot(self) -> FloatArray | None:
        """Platform angular rates χ̇ [rad/s], shape (N, 3), or None when not computed."""
        ...

    def column(self, name: str) -> FloatArray:
        """One per-step result field over time, shape (N,) or (N, k)."""
        ...


def _stops(ax: Any, polygon: ConvexPolygon, labels: bool = True) -> None:
    c = np.vstack([polygon.corners, polygon.corners[:1]])
    ax.fill(c[:, 0], c[:, 1], color="#e8f1fa", zorder=0, label="Q* (inside the stops)")
    ax.plot(c[:, 0], c[:, 1], "k-", lw=1.4, label="joint stops")
    if labels:
        for k in range(polygon.n):
            mid = 0.5 * (polygon.corners[k] + polygon.corners[(k + 1) % polygon.n])
            ax.annotate(
                f"d{k + 1}", mid - 0.12 * polygon.normals[k], ha="center", va="center", fontsize=9
            )
    ax.set_xlabel("q1 [rad]")
    ax.set_ylabel("q2 [rad]")
    ax.set_aspect("equal")


def plot_fig8(
    run: StopRun, polygon: ConvexPolygon, path: str | Path, *, compare: StopRun | None = None
) -> Path:
    """Four panels like the paper's Fig. 8.

    (a) commanded vs limited joint velocities, (b) normal/tangential velocities w.r.t. the
    nearest stop with the zone flag, (c) the path in (q1, q2) over Q*, (d) χ̇.

    Returns:
        The path written.
    """
    t = run.traj.t
    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    a = ax[0, 0]
    for i in range(3):
        a.plot(t, run.traj.v_cmd[:, i], ls="--", color=f"C{i}", lw=0.9)
        a.plot(t, run.traj.v_out[:, i], color=f"C{i}", lw=1.3, label=f"θ̇{i + 1}")
    if compare is not None:
        for i in range(3):
            a.plot(compare.traj.t, compare.traj.v_out[:, i], color=f"C{i}", lw=0.8, ls=":")
    a.set_title("(a) θ̇_c (dashed), θ̇_lim (solid); dotted: exact + post limiter", fontsize=9)
    a.set_xlabel("t [s]")
    a.set_ylabel("[rad/s]")
    a.legend(fontsize=8)
    b = ax[0, 1]
    b.plot(t, run.column("v_perp_lim"), label="q̇⊥ lim")
    b.plot(t, run.column("v_par_lim"), label="q̇∥ lim")
    b.plot(t, run.column("v_perp"), ls="--", lw=0.8, label="q̇⊥ before")
    b2 = b.twinx()
    b2.step(t, run.column("profile_zone"), color="k", lw=0.8, where="post", label="zone")
    b2.step(t, run.column("stop") + 1, color="C3", lw=0.8, where="post", label="stop k")
    b2.set_ylabel("zone (3 nominal, 2 braking, 1 linear) / stop k [index]")
    b.set_title("(b) normal / tangential velocity w.r.t. the nearest stop", fontsize=9)
    b.set_xlabel("t [s]")
    b.set_ylabel("[rad/s]")
    b.legend(fontsize=8, loc="lower left")
    b2.legend(fontsize=8, loc="lower right")
    c = ax[1, 0]
    _stops(c, polygon)
    q = run.column("q")
    c.plot(q[:, 0], q[:, 1], color="C0", lw=1.5, label="faithful")
    if compare is not None:
        qc = compare.column("q")
        c.plot(qc[:, 0], qc[:, 1], color="C2", lw=1.0, ls="--", label="exact + post limiter")
    c.plot(0, 0, "ko", ms=4, label="q = 0")
    c.set_title("(c) trajectory in (q1, q2) over Q*", fontsize=9)
    c.legend(fontsize=8)
    d = ax[1, 1]
    if run.chi_dot is not None:
        for i, name in enumerate(("bank χ̇1", "elevation χ̇2", "bearing χ̇3")):
            d.plot(t, run.chi_dot[:, i], label=name)
    d.set_title("(d) χ̇ = J θ̇_lim", fontsize=9)
    d.set_xlabel("t [s]")
    d.set_ylabel("[rad/s]")
    d.legend(fontsize=8)
    return save_figure(fig, path, dpi=110)


def plot_vertex(
    polygon: ConvexPolygon, vertex: dict[str, list[dict[str, Any]]], path: str | Path
) -> Path:
    """Paths in (q1, q2) of each law commanded straight at each vertex of Q*.

    Returns:
        The path written.
    """
    k = len(vertex)
    fig, axes = plt.subplots(2, k, figsize=(5 * k, 8), squeeze=False)
    for col, (name, rows) in enumerate(vertex.items()):
        ax = axes[0, col]
        _stops(ax, polygon, labels=False)
        low = axes[1, col]
        for i, row in enumerate(rows):
            q = np.asarray(row["q"])
            ax.plot(q[:, 0], q[:, 1], lw=1.0, color=f"C{i}")
            md = np.asarray(row["min_delta_t"])
            low.plot(np.arange(len(md)) * 1e-3, md, lw=0.8, color=f"C{i}", label=f"vertex {i}")
        low.axhline(0.0, color="k", lw=0.8, label="on a stop (δ = 0)")
        # Linear where the stops act (|δ| < 0.05 rad), logarithmic above: the start, far from
        # the stops, stays in view without flattening the part near 0.
        top = max(0.05, 1.5 * max(float(np.max(r["min_delta_t"])) for r in rows))
        low.set_yscale("symlog", linthresh=0.05, linscale=3.0)
        low.set_ylim(min(-0.02, 1.2 * min(float(np.min(r["min_delta_t"])) for r in rows)), top)
        low.set_xlabel("t [s]")
        low.set_ylabel("min signed distance to the stops [rad]\n(log above 0.05 rad)")
        low.legend(fontsize=7)
        worst = min(r["min_delta"] for r in rows)
        sw = max(r["switches"] for r in rows)
        ax.set_title(f"{name}: min δ {worst:.2g} rad, ≤ {sw:.0f} stop switches", fontsize=9)
    # One legend for the paths' panels (their colours are the vertices of the panels below).
    axes[0, 0].legend(fontsize=7, loc="lower left")
    return save_figure(fig, path, dpi=110)


def plot_region(path: str | Path, *, step: float = 0.04) -> Path:
    """Q*, its stops and the Type-1 singular curves (det B = 0) of the home leaf in (q1, q2).

    Returns:
        The path written.
    """
    from velfence.mechanisms.cospm import PAPER_STOPS
    from velfence.mechanisms.cospm_region import singular_curves, stops_polygon

    grid = singular_curves(step=step)
    poly = stops_polygon(PAPER_STOPS)
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    Q1, Q2 = np.meshgrid(grid.q1, grid.q2)
    detb = np.where(grid.reached, grid.det_b, math.nan)
    cs = ax.contourf(Q1, Q2, detb, levels=20, cmap="RdBu", alpha=0.6)
    fig.colorbar(cs, ax=ax, label="det B [1] (Type 1 when 0)")
    if np.nanmin(detb) < 0.0 < np.nanmax(detb):
        ax.contour(Q1, Q2, detb, levels=[0.0], colors="r", linewidths=1.5)
        ax.plot([], [], color="r", lw=1.5, label="det B = 0 (Type 1 singular)")
    ax.contour(Q1, Q2, grid.reached.astype(float), levels=[0.5], colors="m", linewidths=1.0)
    ax.plot([], [], color="m", lw=1.0, label="edge of the home leaf (Type 2 fold)")
    _stops(ax, poly)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(
        "Q* (stops d1–d4), det B, edge of the home leaf (magenta: Type 2 fold)", fontsize=9
    )
    return save_figure(fig, path, dpi=110)
