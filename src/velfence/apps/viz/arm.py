"""Figures of the arm-in-a-box scenario: TCP paths in 3-D, joints and limits, active rows, a GIF."""

from __future__ import annotations

from collections.abc import Mapping
from itertools import product
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize

from velfence._typing import FloatArray
from velfence._validate import check_output_path, check_positive_int
from velfence.apps.labels import method_label
from velfence.apps.viz.plots import MAX_FPS, MAX_FRAMES, save_figure
from velfence.apps.viz.style import _save_frames
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.chain import DHChain
from velfence.sim.runner import Trajectory

__all__ = [
    "ARM_COLORS",
    "ArmRun",
    "ArmScene",
    "animate_arm",
    "plot_arm_activity",
    "plot_arm_joints",
    "plot_arm_paths",
]

#: Line colour of each compared controller (by ``.method``).
ARM_COLORS = {
    "no-limit": "#9e9e9e",
    "per-joint-clamp": "#ff7f0e",
    "scalar-scale": "#9467bd",
    "velocity-damper-qp": "#d62728",
    "safety-filter": "#2ca02c",
}


@runtime_checkable
class ArmScene(Protocol):
    """What the figures read of the arm-in-a-box scene (``velfence.apps.demo.arm_box.ArmScene``)."""

    robot: DHChain
    box_lower: FloatArray
    box_upper: FloatArray
    sphere_center: FloatArray
    sphere_radius: float
    lower: FloatArray
    upper: FloatArray


@runtime_checkable
class ArmRun(Protocol):
    """What the figures read of one run (:class:`velfence.apps.demo.arm_box.ArmRun`)."""

    trajectory: Trajectory
    tcp: FloatArray
    segments: FloatArray
    active: tuple[tuple[str, ...], ...]
    dropped: tuple[tuple[str, ...], ...]
    speed: float


def _runs(runs: Any) -> dict[str, ArmRun]:
    if not isinstance(runs, Mapping) or not runs:
        raise InvalidInput(
            f"runs: expected a non-empty mapping name -> ArmRun, got {type(runs).__name__}"
        )
    bad = sorted({type(r).__name__ for r in runs.values() if not isinstance(r, ArmRun)})
    if bad:
        raise InvalidInput(
            f"runs: expected ArmRun values (velfence.apps.demo.arm_box.run_arm), got {bad}"
        )
    return {str(k): v for k, v in runs.items()}


def _scene(scene: Any) -> ArmScene:
    if not isinstance(scene, ArmScene):
        raise InvalidInput(f"scene: expected an ArmScene, got {type(scene).__name__}")
    return scene


def _color(name: str, i: int) -> str:
    return ARM_COLORS.get(name, f"C{i % 10}")


#: Dash styles of successive controllers: a line drawn over an identical one leaves it visible.
_DASHES: tuple[Any, ...] = ("-", (0, (6, 3)), (0, (2, 2)), (0, (6, 2, 1, 2)), (0, (1, 3)))

#: A joint whose range over all runs is below this is drawn as constant [rad].
CONSTANT_JOINT = 1e-9


def _line_style(name: str, i: int) -> dict[str, Any]:
    """Wide solid first, then narrower dashed lines on top (coinciding runs both stay visible)."""
    return {
        "color": _color(name, i),
        "ls": _DASHES[i % len(_DASHES)],
        "lw": max(0.9, 2.4 - 0.4 * i),
        "zorder": 3 + i,
    }


def _box_edges(scene: ArmScene) -> list[tuple[np.ndarray, np.ndarray]]:
    lo, hi = scene.box_lower, scene.box_upper
    corners = np.array(
        [np.where(np.array(bits) == 1, hi, lo) for bits in product((0, 1), repeat=3)]
    )
    return [
        (corners[i], corners[j])
        for i, j in product(range(8), range(8))
        if i < j and np.count_nonzero(corners[i] != corners[j]) == 1
    ]


def _draw_scene(ax: Any, scene: ArmScene) -> None:
    """The box's edges and the sphere, each with one legend entry."""
    for k, (a, b) in enumerate(_box_edges(scene)):
        label = "box (TCP fence)" if k == 0 else None
        ax.plot(*np.stack([a, b]).T, color="k", lw=0.8, alpha=0.7, label=label)
    u, v = np.mgrid[0 : 2 * np.pi : 24j, 0 : np.pi : 12j]
    c, r = scene.sphere_center, scene.sphere_radius
    ax.plot_surface(
        c[0] + r * np.cos(u) * np.sin(v),
        c[1] + r * np.sin(u) * np.sin(v),
        c[2] + r * np.cos(v),
        color="#8c564b",
        alpha=0.35,
        linewidth=0,
        shade=False,  # one colour: the legend swatch matches the sphere
    )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")


def _legend_entries(ax: Any) -> tuple[list[Any], list[str]]:
    """The axes' labelled artists plus a proxy patch for the sphere (a surface has no entry)."""
    from matplotlib.patches import Patch

    handles, names = ax.get_legend_handles_labels()
    return [*handles, Patch(color="#8c564b", alpha=0.35)], [*names, "sphere (obstacle)"]


def plot_arm_paths(scene: ArmScene, runs: Mapping[str, ArmRun], path: str | Path) -> Path:
    """One 3-D panel per controller: the TCP path coloured by time, the box and the sphere.

    Args:
        scene: The scene (box, sphere).
        runs: Controller name -> run (same speed).
        path: Output image file.

    Returns:
        The path written.
    """
    sc, rs = _scene(scene), _runs(runs)
    out = check_output_path("path", path)
    k = len(rs)
    cols = min(3, k)
    rows_n = -(-k // cols)
    fig = plt.figure(figsize=(5.0 * cols + 1.0, 4.6 * rows_n + 0.4))
    t_max = max(float(r.trajectory.t[-1]) for r in rs.values())
    norm = Normalize(0.0, t_max)
    mappable = None
    for i, (name, run) in enumerate(rs.items()):
        ax = fig.add_subplot(rows_n, cols, i + 1, projection="3d")
        _draw_scene(ax, sc)
        p = run.tcp[:: max(1, len(run.tcp) // 1500)]
        t = run.trajectory.t[:: max(1, len(run.tcp) // 1500)]
        pts = np.stack([p[:-1], p[1:]], axis=1)
        from mpl_toolkits.mplot3d.art3d import Line3DCollection  # type: ignore[import-untyped]

        lc = Line3DCollection(pts, cmap="viridis", norm=norm, linewidths=1.6)
        lc.set_array(t[:-1])
        ax.add_collection3d(lc)
        mappable = lc
        ax.scatter(*run.tcp[0], color="k", s=12, label="start")
        ax.plot([], [], color=plt.get_cmap("viridis")(0.6), lw=1.6, label="TCP path")
        ax.set_title(f"{method_label(name)} (v = {run.speed:g} m/s)", fontsize=9)
        ax.view_init(elev=22, azim=-60)
        # The box and every TCP path framed (a path that leaves the box stays in view).
        lo = np.minimum(np.minimum(sc.box_lower, run.tcp.min(axis=0)), (0.4, -0.35, 0.3))
        hi = np.maximum(np.maximum(sc.box_upper, run.tcp.max(axis=0)), (0.9, 0.35, 0.8))
        pad = 0.03 * (hi - lo)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
        ax.set_zlim(lo[2] - pad[2], hi[2] + pad[2])
    handles, names = _legend_entries(fig.axes[0])
    fig.legend(handles, names, loc="lower center", ncol=len(names), fontsize=9)
    if mappable is not None:
        fig.colorbar(mappable, ax=fig.axes, shrink=0.5, pad=0.03, label="time [s]")
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_arm_joints(scene: ArmScene, runs: Mapping[str, ArmRun], path: str | Path) -> Path:
    """Joint positions over time for every controller, with the joint limits (dashed).

    Args:
        scene: The scene (limits).
        runs: Controller name -> run.
        path: Output image file.

    Returns:
        The path written.
    """
    sc, rs = _scene(scene), _runs(runs)
    check_output_path("path", path)
    n = sc.lower.shape[0]
    fig, axs = plt.subplots(
        n, 1, figsize=(9, 1.5 * n + 1.2), sharex=True, squeeze=False, layout="constrained"
    )
    axes = list(axs[:, 0])
    for j, ax in enumerate(axes):
        for i, (name, run) in enumerate(rs.items()):
            style = _line_style(name, i)
            ax.plot(run.trajectory.t, run.trajectory.p[:, j], label=method_label(name), **style)
        lo_q = min(float(r.trajectory.p[:, j].min()) for r in rs.values())
        hi_q = max(float(r.trajectory.p[:, j].max()) for r in rs.values())
        for lim in (sc.lower[j], sc.upper[j]):
            if lo_q - 0.3 <= lim <= hi_q + 0.3:
                ax.axhline(lim, color="k", ls="--", lw=0.9)
        if hi_q - lo_q < CONSTANT_JOINT:
            # A joint that never moves: a fixed range around its value, not round-off at 1e-16.
            mid = 0.5 * (lo_q + hi_q)
            ax.set_ylim(mid - 0.1, mid + 0.1)
            ax.text(
                0.01, 0.9, f"constant: q{j} = {mid + 0.0:.3f} rad in every run (no motion)",
                transform=ax.transAxes, fontsize=8, va="top",
            )  # fmt: skip
        ax.set_ylabel(f"q{j} [rad]")
        ax.grid(alpha=0.3)
    axes[0].plot([], [], color="k", ls="--", lw=0.9, label="joint limit")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=len(rs) + 1)
    fig.suptitle("joint positions (coinciding runs overlap: wide solid under dashed)")
    axes[-1].set_xlabel("time [s]")
    return save_figure(fig, path)


def plot_arm_activity(runs: Mapping[str, ArmRun], path: str | Path) -> Path:
    """Which constraint rows bind over time, one panel per controller (a bar where active).

    Args:
        runs: Controller name -> run.
        path: Output image file.

    Returns:
        The path written.
    """
    rs = _runs(runs)
    check_output_path("path", path)
    k = len(rs)
    names_per = {
        n: sorted(
            {a for row in r.active for a in row}
            | {f"dropped: {d}" for row in r.dropped for d in row}
        )
        for n, r in rs.items()
    }
    heights = [max(1, len(v)) for v in names_per.values()]
    fig, axes = plt.subplots(
        k, 1, figsize=(9, 0.9 + 0.32 * sum(heights) + 0.5 * k), sharex=True,
        gridspec_kw={"height_ratios": heights}, squeeze=False,
    )  # fmt: skip
    for ax, (name, run), i in zip(axes[:, 0], rs.items(), range(k), strict=True):
        t = run.trajectory.t
        rows = names_per[name]
        segs = []
        for r, label in enumerate(rows):
            if label.startswith("dropped: "):
                on = np.array([label.removeprefix("dropped: ") in d for d in run.dropped])
            else:
                on = np.array([label in a for a in run.active])
            edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
            for a, b in zip(edges[::2], edges[1::2], strict=True):
                segs.append([(t[a], r), (t[min(b, len(t) - 1)], r)])
        if segs:
            ax.add_collection(LineCollection(segs, colors=_color(name, i), linewidths=6))
        else:  # nothing to draw: the panel says so where the bars would be
            ax.text(
                0.5, 0.5, "no constraint row active in this run", transform=ax.transAxes,
                ha="center", va="center", fontsize=8, color="0.35",
            )  # fmt: skip
        ax.set_yticks(range(len(rows)), rows, fontsize=7)
        ax.set_ylim(-0.7, max(0.7, len(rows) - 0.3))
        ax.set_xlim(float(t[0]), float(t[-1]))
        label = method_label(name)
        ax.set_title(
            f"{label}: active rows" if rows else f"{label}: no row ever active", fontsize=9
        )
        ax.grid(alpha=0.3, axis="x")
    axes[-1, 0].set_xlabel("time [s]")
    return save_figure(fig, path)


def animate_arm(
    scene: ArmScene, run: ArmRun, path: str | Path, *, frames: int = 60, fps: int = 12
) -> Path:
    """A GIF of the arm (links as thick lines), its TCP trail, the box and the sphere.

    The figure is 7.5 in x 6 in at 96 dpi (720 x 576 px).

    Args:
        scene: The scene.
        run: The run to animate.
        path: Output ``.gif`` file.
        frames: Number of frames, 1 to :data:`~velfence.apps.viz.plots.MAX_FRAMES`.
        fps: Frames per second, 1 to :data:`~velfence.apps.viz.plots.MAX_FPS`.

    Returns:
        The path written.
    """
    sc = _scene(scene)
    if not isinstance(run, ArmRun):
        raise InvalidInput(f"run: expected an ArmRun, got {type(run).__name__}")
    n_frames = check_positive_int("frames", frames, maximum=MAX_FRAMES, example=60)
    rate = check_positive_int("fps", fps, maximum=MAX_FPS, example=12)
    out = check_output_path("path", path)
    fig = plt.figure(figsize=(7.5, 6.0))
    ax = fig.add_subplot(projection="3d")
    _draw_scene(ax, sc)
    ax.set_xlim(-0.1, 0.9)
    ax.set_ylim(-0.5, 0.5)
    ax.set_zlim(0.0, 1.0)
    ax.view_init(elev=20, azim=-50)
    n = len(run.tcp)
    idx = np.linspace(0, n - 1, n_frames).astype(int)
    (links,) = ax.plot([], [], [], "-o", color="#1f77b4", lw=5, ms=3, label="links")
    (trail,) = ax.plot([], [], [], color="#2ca02c", lw=1.2, label="TCP path")
    ax.legend(*_legend_entries(ax), loc="upper left", bbox_to_anchor=(-0.12, 1.0), fontsize=8)
    stamp = ax.set_title("", fontsize=9)

    def update(f: int) -> list[Any]:
        j = int(idx[f])
        seg = run.segments[j]
        pts = np.vstack([seg[:, 0], seg[-1:, 1]])
        links.set_data(pts[:, 0], pts[:, 1])
        links.set_3d_properties(pts[:, 2])
        trail.set_data(run.tcp[: j + 1, 0], run.tcp[: j + 1, 1])
        trail.set_3d_properties(run.tcp[: j + 1, 2])
        rows = sorted(run.active[j], key=lambda a: "acceleration" in a)  # limits first
        act = ", ".join(rows[:2]) + (f" (+{len(rows) - 2})" if len(rows) > 2 else "") or "none"
        who = method_label(run.trajectory.name)
        stamp.set_text(f"{who}, t = {run.trajectory.t[j]:.2f} s\nactive: {act}")
        return [links, trail, stamp]

    try:
        _save_frames(fig, update, n_frames, out, fps=rate, dpi=96)
    except (OSError, ValueError) as exc:
        raise InvalidParameter(f"path: cannot write {str(out)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return out
