"""Workspace, velocity-profile, velocity-field and animation plots."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from velfence._extras import missing

try:
    import matplotlib
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from velfence._validate import (
    check_output_path,
    check_positive,
    check_positive_int,
    check_text,
    describe,
    real_array,
)
from velfence.apps.viz.style import (
    DPI,
    FONT,
    GIF_DPI,
    _save_frames,
    add_colorbar,
    drop_unused,
    styled,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, Rectangle
from velfence.shaping.base import Shaper
from velfence.sim.runner import Trajectory

__all__ = [
    "animate_trajectories",
    "plot_quiver",
    "plot_velocity_patterns",
    "plot_velocity_profiles",
    "plot_workspace",
    "save_figure",
]


#: Most panels (shapers) one figure draws; more would make an unreadable, huge image.
MAX_PANELS = 24
#: Most trajectories one figure draws.
MAX_TRAJECTORIES = 100
#: Most sample points of :func:`plot_velocity_patterns`.
MAX_POINTS = 1000
#: Largest quiver grid side (grid² arrows per panel).
MAX_GRID = 200
#: Most commands per circle of :func:`plot_velocity_patterns`.
MAX_RAYS = 3600
#: Most frames of an animation, and the largest frame rate [1/s].
MAX_FRAMES = 2000
MAX_FPS = 100
#: Largest resolution of a written figure [dots per inch].
MAX_DPI = 1200
#: Percentile of all arrow speeds at which a quiver's colour range is clipped (robust range).
CLIP_PERCENTILE = 98.0

COLORS = {
    "none": "#9e9e9e",
    "no-limit": "#9e9e9e",
    "hard-stop": "#d62728",
    "axis-limits": "#ff7f0e",
    "patent": "#1f77b4",
    "edge-scaling": "#1f77b4",
    "exact": "#2ca02c",
}


def _check_polygon(name: str, polygon: Any) -> ConvexPolygon:
    if not isinstance(polygon, ConvexPolygon):
        raise InvalidInput(
            f"{name}: expected a velfence ConvexPolygon (the workspace), got {describe(polygon)}"
        )
    return polygon


def _check_named(name: str, items: Any, kind: type, what: str, maximum: int) -> dict[str, Any]:
    """A non-empty mapping of string labels to ``kind`` objects (at most ``maximum``)."""
    if not isinstance(items, Mapping):
        raise InvalidInput(f"{name}: expected a mapping of name -> {what}, got {describe(items)}")
    if not 1 <= len(items) <= maximum:
        raise InvalidInput(
            f"{name}: expected 1 to {maximum} entries (name -> {what}), got {len(items)}"
        )
    out: dict[str, Any] = {}
    for key, value in items.items():
        label = check_text(f"{name} key", key, max_length=200, error=InvalidInput)
        if not isinstance(value, kind):
            raise InvalidInput(f"{name}[{key!r}]: expected a {what}, got {describe(value)}")
        out[label] = value
    return out


def _check_trajectories(name: str, trajectories: Any) -> dict[str, Trajectory]:
    trs = _check_named(
        name, trajectories, Trajectory, "velfence Trajectory (velfence.sim)", MAX_TRAJECTORIES
    )
    for key, tr in trs.items():
        if tr.p.ndim != 2 or tr.p.shape[1] != 2 or tr.v_out.shape != tr.p.shape:
            raise InvalidInput(
                f"{name}[{key!r}]: expected a planar trajectory (positions of shape (N, 2)), "
                f"got positions of shape {tr.p.shape}"
            )
    return trs


def _check_labels(labels: Any) -> tuple[str, str]:
    """Two axis labels ``("pitch [rad]", "yaw [rad]")``, each naming its unit in brackets."""
    if not isinstance(labels, (list, tuple)) or len(labels) != 2:
        raise InvalidParameter(
            f"labels: expected two axis labels (x, y) as a tuple of strings, got {describe(labels)}"
        )
    return check_text("labels", labels[0]), check_text("labels", labels[1])


def _unit_of(label: str) -> str:
    """The unit in a label's last brackets (``"pitch [rad]"`` -> ``"rad"``), else ``"units"``."""
    lo, hi = label.rfind("["), label.rfind("]")
    return (label[lo + 1 : hi].strip() or "units") if 0 <= lo < hi else "units"


def _check_buffer(buffer: Any) -> float | None:
    if buffer is None:
        return None
    return check_positive("buffer", buffer, unit="workspace units")


def save_figure(fig: Any, path: str | Path, *, dpi: int = 130) -> Path:
    """Lay out ``fig``, write it to ``path`` at ``dpi``, close it, and return the path.

    Every figure of the library is written this way (one place for layout and resource release).

    Args:
        fig: A matplotlib ``Figure``.
        path: Output file; its directory must exist. The format follows the suffix.
        dpi: Resolution, 1 to :data:`MAX_DPI` dots per inch.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``fig`` is not a matplotlib figure.
        InvalidParameter: ``path`` or ``dpi`` is unusable (the figure is closed all the same).
    """
    if not isinstance(fig, Figure):
        raise InvalidInput(f"fig: expected a matplotlib Figure, got {describe(fig)}")
    try:
        dots = check_positive_int("dpi", dpi, maximum=MAX_DPI, example=130)
        out = check_output_path("path", path)
    except InvalidParameter:
        plt.close(fig)  # an unusable argument must not leak the figure
        raise
    return _write(fig, out, dots)


def _write(fig: Figure, out: Path, dpi: int) -> Path:
    """Lay out, write and close ``fig`` (arguments already validated)."""
    if fig.get_layout_engine() is None:
        fig.tight_layout()
    try:
        fig.savefig(out, dpi=dpi)
    except (OSError, ValueError) as exc:  # unwritable file, unknown suffix
        raise InvalidParameter(f"path: cannot write {str(out)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return out


def _color(name: str, i: int) -> str:
    return COLORS.get(name, f"C{i % 10}")


#: Dash styles of successive paths: a path drawn over an identical one leaves it visible.
DASHES: tuple[Any, ...] = ("-", (0, (6, 3)), (0, (2, 2)), (0, (6, 2, 1, 2)), (0, (1, 3)))


def _path_style(name: str, i: int) -> dict[str, Any]:
    """The ``i``-th path's style: wide solid first, narrower dashes on top (overlaps stay seen)."""
    return {
        "color": _color(name, i),
        "ls": DASHES[i % len(DASHES)],
        "lw": max(1.0, 2.8 - 0.5 * i),
        "zorder": 4 + i,
        "alpha": 0.95,
    }


def _draw_polygon(
    ax: Any,
    polygon: ConvexPolygon,
    *,
    buffer: float | None = None,
    rectangle: Rectangle | None = None,
    margin: float = 0.25,
    unit: str = "",
    extra: Any = None,
) -> None:
    """The polygon, its buffer band and rectangle, framed with ``extra`` (points (N, 2)) in view."""
    c = polygon.corners
    closed = np.vstack([c, c[:1]])
    ax.plot(closed[:, 0], closed[:, 1], color="k", lw=1.8, label="workspace polygon", zorder=3)
    lo = c.min(axis=0)
    hi = c.max(axis=0)
    if extra is not None and len(extra):
        pts = np.asarray(extra, dtype=float)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts):
            lo = np.minimum(lo, pts.min(axis=0))
            hi = np.maximum(hi, pts.max(axis=0))
    span = hi - lo
    lo = lo - margin * span
    hi = hi + margin * span
    if buffer is not None:
        xs = np.linspace(lo[0], hi[0], 300)
        ys = np.linspace(lo[1], hi[1], 300)
        X, Y = np.meshgrid(xs, ys)
        D = polygon.signed_distances(np.stack([X.ravel(), Y.ravel()], axis=1)).min(axis=1)
        ax.contourf(X, Y, D.reshape(X.shape), levels=[0.0, buffer], colors=["#fde9c9"], zorder=0)
        ax.contour(
            X, Y, D.reshape(X.shape), levels=[buffer], colors=["#e0a030"], linewidths=0.8,
            linestyles="--",
        )  # fmt: skip
        # The band in the legend (contour sets have no legend entry of their own).
        ax.fill(
            [], [], facecolor="#fde9c9", edgecolor="#e0a030", linestyle="--", lw=0.8,
            label=f"buffer band ({buffer:g} {unit or 'units'} wide)",
        )  # fmt: skip
    if rectangle is not None:
        r = np.vstack([rectangle.corners, rectangle.corners[:1]])
        ax.plot(r[:, 0], r[:, 1], color="#7b3294", lw=1.0, ls=":", label="inscribed rectangle")
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")


@styled
def plot_workspace(
    polygon: ConvexPolygon,
    trajectories: Mapping[str, Trajectory],
    path: str | Path,
    *,
    buffer: float | None = None,
    rectangle: Rectangle | None = None,
    labels: Sequence[str] = ("pitch [rad]", "yaw [rad]"),
    title: str = "Workspace and trajectories",
) -> Path:
    """The polygon, its buffer band, the inscribed rectangle and every trajectory.

    Args:
        polygon: The permitted workspace.
        trajectories: Label -> run, each drawn as its path.
        path: Output file; its directory must exist.
        buffer: Width of the buffer band to shade inside the polygon; ``None``: none.
        rectangle: An inscribed rectangle to draw; ``None``: none.
        labels: The x and y axis labels.
        title: The figure's title.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``polygon``, ``trajectories`` or ``rectangle`` of the wrong type.
        InvalidParameter: ``buffer``, ``labels``, ``title`` or ``path`` unusable.
    """
    _check_polygon("polygon", polygon)
    trs = _check_trajectories("trajectories", trajectories)
    width = _check_buffer(buffer)
    if rectangle is not None and not isinstance(rectangle, Rectangle):
        raise InvalidInput(f"rectangle: expected a velfence Rectangle, got {describe(rectangle)}")
    xlabel, ylabel = _check_labels(labels)
    heading = check_text("title", title)
    out = check_output_path("path", path)
    fig, ax = plt.subplots(figsize=(8.8, 6.2), layout="constrained")
    every = np.vstack([tr.p for tr in trs.values()])
    _draw_polygon(
        ax, polygon, buffer=width, rectangle=rectangle, unit=_unit_of(xlabel), margin=0.08,
        extra=every,
    )  # fmt: skip
    for i, (name, tr) in enumerate(trs.items()):
        ax.plot(tr.p[:, 0], tr.p[:, 1], label=name, **_path_style(name, i))
        ax.plot(tr.p[0, 0], tr.p[0, 1], "o", color=_color(name, i), ms=4, zorder=6 + i)
    ax.plot([], [], "o", color="0.35", ms=4, label="start point")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(heading)
    # Outside the axes (the layout engine makes room): the legend never covers a path.
    fig.legend(loc="outside right upper", fontsize=FONT - 1)
    if len(trs) > 1:
        ax.text(
            0.01, 0.01, "paths drawn on top of each other in different dash styles",
            transform=ax.transAxes, fontsize=FONT - 2, color="0.3", va="bottom",
        )  # fmt: skip
    return _write(fig, out, DPI)


@styled
def plot_velocity_profiles(
    polygon: ConvexPolygon,
    trajectories: Mapping[str, Trajectory],
    path: str | Path,
    *,
    unit: str = "rad",
) -> Path:
    """Speed, normal speed and boundary distance of every method against time.

    Panels: commanded vs shaped speed; inward normal speed towards the nearest edge; the
    smallest signed distance to the boundary (negative = outside).

    Args:
        polygon: The workspace.
        trajectories: Name -> trajectory, one line each.
        path: Output file.
        unit: The workspace's length unit (``"rad"`` for the wrist, ``"m"`` ...); speeds are
            labelled in ``unit/s``.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``polygon`` or ``trajectories`` of the wrong type.
        InvalidParameter: ``path`` unusable.
    """
    _check_polygon("polygon", polygon)
    trs = _check_trajectories("trajectories", trajectories)
    u = check_text("unit", unit, max_length=40)
    out = check_output_path("path", path)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for i, (name, tr) in enumerate(trs.items()):
        d = polygon.signed_distances(tr.p)
        nearest = np.argmin(d, axis=1)
        normals = polygon.normals[nearest]
        vn = np.einsum("ij,ij->i", tr.v_out, normals)
        style = _path_style(name, i) | {"lw": max(0.9, 2.2 - 0.4 * i)}
        axes[0].plot(tr.t, np.linalg.norm(tr.v_out, axis=1), label=name, **style)
        axes[1].plot(tr.t, vn, label=name, **style)
        axes[2].plot(tr.t, d.min(axis=1), label=name, **style)
    first = next(iter(trs.values()))
    axes[0].plot(
        first.t, np.linalg.norm(first.v_cmd, axis=1), color="k", lw=0.8, ls=":", label="commanded"
    )
    axes[0].set_ylabel(f"speed [{u}/s]")
    axes[1].set_ylabel(f"inward normal speed\n(nearest edge) [{u}/s]")
    axes[2].set_ylabel(f"min signed distance [{u}]")
    axes[2].axhline(0.0, color="k", lw=0.8, label="boundary (0)")
    for ax in axes:
        ax.set_xlabel("time [s]")
    axes[0].legend(fontsize=FONT - 1, ncol=3)
    axes[2].legend(fontsize=FONT - 1, ncol=3)
    return _write(fig, out, DPI)


@styled
def plot_quiver(
    polygon: ConvexPolygon,
    shapers: Mapping[str, Shaper],
    path: str | Path,
    *,
    command: Sequence[float] = (1.0, 0.35),
    buffer: float | None = None,
    grid: int = 23,
    labels: Sequence[str] = ("pitch [rad]", "yaw [rad]"),
) -> Path:
    """The velocity field of each shaper for one constant command, over the workspace.

    One panel per shaper (no empty panels); arrows show the shaped velocity's direction, their
    colour its speed (one colour bar for all panels, in the workspace unit per second).

    Args:
        polygon: The workspace.
        shapers: Name -> shaper, one panel each.
        path: Output file.
        command: The constant command velocity [workspace units/s].
        buffer: Buffer width to shade, workspace units.
        grid: Arrows per side.
        labels: The x and y axis labels with their unit in brackets; the unit also names the
            speed unit of the colour bar.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``polygon``, ``shapers`` or ``command`` unusable.
        InvalidParameter: ``buffer``, ``grid`` or ``path`` unusable.
    """
    _check_polygon("polygon", polygon)
    shs = _check_named("shapers", shapers, Shaper, "velfence shaper", MAX_PANELS)
    cmd = real_array("command", command, (2,), what="a 2-D command velocity")
    norm = float(np.linalg.norm(cmd))
    if not norm > 0.0:
        raise InvalidInput("command: expected a nonzero 2-D command velocity, got (0, 0)")
    width = _check_buffer(buffer)
    n = check_positive_int("grid", grid, minimum=2, maximum=MAX_GRID, example=23)
    xlabel, ylabel = _check_labels(labels)
    out_path = check_output_path("path", path)
    k = len(shs)
    cols = min(k, 3)
    rows = (k + cols - 1) // cols
    fig, axes = plt.subplots(
        rows, cols, figsize=(4.4 * cols + 1.2, 4.3 * rows), squeeze=False, layout="constrained"
    )
    c = polygon.corners
    lo, hi = c.min(axis=0), c.max(axis=0)
    span = hi - lo
    xs = np.linspace(lo[0] - 0.15 * span[0], hi[0] + 0.15 * span[0], n)
    ys = np.linspace(lo[1] - 0.15 * span[1], hi[1] + 0.15 * span[1], n)
    X, Y = np.meshgrid(xs, ys)
    P = np.stack([X.ravel(), Y.ravel()], axis=1)
    V = np.tile(cmd, (P.shape[0], 1))
    fields = {name: shaper.shape_batch(P, V) for name, shaper in shs.items()}
    speeds = np.concatenate([np.linalg.norm(f, axis=1) for f in fields.values()])
    top = float(np.max(speeds))
    # A robust colour range: one method's few fast arrows (a spring pulling back from far
    # outside) must not leave every other panel one colour. Faster arrows get the top colour.
    # At most twice the command's speed: the arrows inside the fence keep distinct colours.
    robust = min(max(float(np.percentile(speeds, CLIP_PERCENTILE)), norm), 2.0 * norm)
    clipped = top > robust * (1.0 + 1e-9)
    colour = Normalize(vmin=0.0, vmax=robust if clipped else max(top, norm))
    arrows = None
    for ax, (name, out) in zip(axes.ravel(), fields.items(), strict=False):
        _draw_polygon(ax, polygon, buffer=width, margin=0.18, unit=_unit_of(xlabel))
        mag = np.linalg.norm(out, axis=1)
        arrows = ax.quiver(
            P[:, 0], P[:, 1], out[:, 0], out[:, 1], mag, cmap="viridis", norm=colour,
            angles="xy", scale_units="xy", scale=norm / (0.8 * (xs[1] - xs[0])),
            width=0.004,
        )  # fmt: skip
        ax.set_title(name, fontsize=FONT + 1)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
    drop_unused(axes.ravel(), k)
    shown = tuple(round(x, 2) for x in cmd.tolist())
    fig.suptitle(f"Shaped velocity field for the constant command {shown} [{_unit_of(xlabel)}/s]")
    bar_label = f"shaped speed [{_unit_of(xlabel)}/s]"
    if clipped:
        # Short lines: the label runs along the bar and must fit the figure's height.
        bar_label += (
            f"\n(clipped at {robust:.3g}: the {CLIP_PERCENTILE:g}th percentile,\nat most "
            f"twice the command's speed;\nfaster arrows, up to {top:.3g}, in the top colour)"
        )
    bar = add_colorbar(fig, arrows, list(axes.ravel()[:k]), bar_label)
    if clipped:
        bar.extend = "max"
    handles, names = axes.ravel()[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside lower center", ncol=len(names))
    return _write(fig, out_path, DPI)


@styled
def animate_trajectories(
    polygon: ConvexPolygon,
    trajectories: Mapping[str, Trajectory],
    path: str | Path,
    *,
    buffer: float | None = None,
    frames: int = 60,
    fps: int = 12,
    labels: Sequence[str] = ("pitch [rad]", "yaw [rad]"),
) -> Path:
    """A GIF of every trajectory's point moving through the workspace, with a fading trail.

    At least 600 px wide; labelled axes; the legend sits beside the workspace.

    Args:
        polygon: The workspace.
        trajectories: Name -> trajectory.
        path: Output file (``.gif``).
        buffer: Buffer width to shade, workspace units.
        frames: Number of frames.
        fps: Frames per second.
        labels: The x and y axis labels with their unit in brackets.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``polygon`` or ``trajectories`` of the wrong type.
        InvalidParameter: ``buffer``, ``frames``, ``fps`` or ``path`` unusable.
    """
    _check_polygon("polygon", polygon)
    trs = _check_trajectories("trajectories", trajectories)
    width = _check_buffer(buffer)
    n_frames = check_positive_int("frames", frames, maximum=MAX_FRAMES, example=60)
    rate = check_positive_int("fps", fps, maximum=MAX_FPS, example=12)
    xlabel, ylabel = _check_labels(labels)
    out = check_output_path("path", path)
    fig, ax = plt.subplots(figsize=(7.6, 5.6), layout="constrained")
    every = np.vstack([tr.p for tr in trs.values()])
    _draw_polygon(ax, polygon, buffer=width, unit=_unit_of(xlabel), margin=0.08, extra=every)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    first = next(iter(trs.values()))
    n = len(first.t)
    idx = np.linspace(0, n - 1, n_frames).astype(int)
    trails = {}
    for i, name in enumerate(trs):
        # One artist per run: its trail, with a dot on its newest point (the legend shows both).
        (trails[name],) = ax.plot(
            [], [], marker="o", ms=5, markevery=[-1], label=name,
            **(_path_style(name, i) | {"alpha": 0.7}),
        )  # fmt: skip
    # Outside the axes: the legend never covers a corner of the workspace.
    fig.legend(loc="outside right upper", fontsize=FONT - 1)
    stamp = ax.set_title("")

    def update(f: int) -> list[Any]:
        j = idx[f]
        for name, tr in trs.items():
            lo = max(0, j - n // 8)
            trails[name].set_data(tr.p[lo : j + 1, 0], tr.p[lo : j + 1, 1])
        stamp.set_text(f"t = {first.t[j]:.2f} s")
        return [*trails.values(), stamp]

    try:
        _save_frames(fig, update, n_frames, out, fps=rate, dpi=GIF_DPI)
    except (OSError, ValueError) as exc:  # unwritable file, unknown suffix
        raise InvalidParameter(f"path: cannot write {str(out)!r}: {exc}") from None
    finally:
        plt.close(fig)
    return out


@styled
def plot_velocity_patterns(
    polygon: ConvexPolygon,
    shapers: Mapping[str, Shaper],
    points: Sequence[Sequence[float]],
    path: str | Path,
    *,
    buffer: float | None = None,
    speed: float = 1.0,
    radius: float | None = None,
    rays: int = 48,
    labels: Sequence[str] = ("pitch [rad]", "yaw [rad]"),
) -> Path:
    """The patent's FIG. 7: at sample points, the shaped output of a ring of commands.

    Each point shows the ends of ``shape(p, speed·u)`` for unit vectors ``u`` around the circle
    (dotted: the commands), drawn so that ``speed`` spans ``radius`` workspace units: a full
    circle where motion is free, a flattened circle in the buffer, a semicircle shifted inward by
    the spring outside.

    Args:
        polygon: The workspace.
        shapers: Name -> shaper, one panel each.
        points: Sample positions, workspace units.
        path: Output file.
        buffer: Buffer width to shade, workspace units.
        speed: Command speed [units/s].
        radius: Drawn radius of the command circle [workspace units]; default 3 % of the
            polygon's span.
        rays: Commands per circle.
        labels: The x and y axis labels with their unit in brackets.

    Returns:
        The path written.

    Raises:
        InvalidInput: ``polygon``, ``shapers`` or ``points`` unusable.
        InvalidParameter: ``buffer``, ``speed``, ``radius``, ``rays`` or ``path`` unusable.
    """
    _check_polygon("polygon", polygon)
    shs = _check_named("shapers", shapers, Shaper, "velfence shaper", MAX_PANELS)
    pts = real_array("points", points, (None, 2), what="sample positions (workspace units)")
    if pts.shape[0] > MAX_POINTS:
        raise InvalidInput(f"points: expected at most {MAX_POINTS} points, got {pts.shape[0]}")
    width = _check_buffer(buffer)
    v = check_positive("speed", speed, unit="units/s")
    r = None if radius is None else check_positive("radius", radius, unit="workspace units")
    n_rays = check_positive_int("rays", rays, minimum=3, maximum=MAX_RAYS, example=48)
    xlabel, ylabel = _check_labels(labels)
    out_path = check_output_path("path", path)
    k = len(shs)
    fig, axes = plt.subplots(1, k, figsize=(5.4 * k, 5.6), squeeze=False, layout="constrained")
    ang = np.linspace(0.0, 2.0 * np.pi, n_rays, endpoint=False)
    U = v * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    span = float(np.max(polygon.corners.max(axis=0) - polygon.corners.min(axis=0)))
    draw = (0.03 * span if r is None else r) / v
    for ax, (i, (name, shaper)) in zip(axes.ravel(), enumerate(shs.items()), strict=False):
        _draw_polygon(ax, polygon, buffer=width, margin=0.12, unit=_unit_of(xlabel))
        for p in pts:
            P = np.tile(p, (n_rays, 1))
            out = draw * shaper.shape_batch(P, U)
            ring = np.vstack([P + out, P[:1] + out[:1]])
            ax.plot(ring[:, 0], ring[:, 1], color=_color(name, i), lw=1.2)
            cmd = np.vstack([P + draw * U, P[:1] + draw * U[:1]])
            ax.plot(cmd[:, 0], cmd[:, 1], color="k", lw=0.5, ls=":")
            ax.plot(P[0, 0], P[0, 1], "k.", ms=3)
        ax.set_title(f"{name}: allowed velocities (FIG. 7)", fontsize=FONT + 1)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        # What the rings mean: proxies (one entry per kind, not one per sample point).
        ax.plot([], [], color="k", lw=0.8, ls=":", label="commands (all directions)")
        ax.plot([], [], color=_color(name, i), lw=1.2, label=f"shaped output ({name})")
        ax.plot([], [], "k.", ms=4, label="sample point")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2, fontsize=FONT - 1)
    return _write(fig, out_path, DPI)
