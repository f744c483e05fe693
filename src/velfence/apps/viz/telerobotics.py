r"""3-D views of a laser-assisted traded-control session (Khokar 2009).

Pictures of the simulated PUMA 560 and its remote scene, drawn with matplotlib's 3-D axes (Agg):
the arm as thick links with joint dots and the tool frame's axes, the scene primitives (table,
cup, folder, destination mark), the laser beam from its origin to the spot (or a short dashed ray
when the sensor has no reading) and the virtual-fixture line. :func:`plot_snapshot` writes one
picture, :func:`animate_session` a GIF (or MP4 when an ffmpeg is available) of a recorded run
with a text overlay of time, mode, clutch and status.

Inputs are plain JSON-able data, so recordings from the web viewer, from a log file or from an
in-process run draw alike:

* a **snapshot** (``Session.snapshot()``) is a mapping with ``t`` [s], ``mode`` (str),
  ``clutch`` (bool, ``True`` = hand coupled to the arm), ``q`` (6 angles [rad]), ``joints``
  (points [m] from the base to the tool, shape (n, 3), n >= 2), ``tool`` (4 x 4 pose, nested
  lists), ``laser`` (``{"origin": [3], "point": [3] or None}``, optionally ``"direction": [3]``;
  ``None`` when there is no laser), ``fixture`` (``{"start": [3], "end": [3]}`` or ``None``),
  ``status`` (str) and ``task`` (dict). Only ``joints`` and ``tool`` are required here.
  Optional extras drawn when present: ``gripper`` (``{"start": [3], "end": [3]}``, the hand
  along ``z6``), ``destination`` ([3], key 'D'), ``plane_points`` (list of [3], key 'P'), and
  ``objects`` (primitive dicts replacing the static ones of the same name);
* a **scene** is a list of primitive dicts in the one format of
  :func:`velfence.apps.teleop.scene.scene_to_dicts` (or a
  :class:`~velfence.apps.teleop.scene.Scene`),
  as ``Session.scene_primitives()`` returns it: planes with ``point`` (and ``corners`` when
  bounded; an infinite plane is drawn as a 2 m square), boxes with ``corners``. A primitive
  with ``"dynamic": true`` whose name is a key of the snapshot's ``task`` moves with it:
  ``task[name]`` is its new ``base_center`` (cylinder) or ``center`` / ``point`` (others), or
  ``None`` to hide it (the carried cup).

Coordinates: the PUMA base frame at the shoulder, metres, ``z`` up. The default view box is
:data:`VIEW_LIMITS` (about ±1 m around the arm and the table).
"""

from __future__ import annotations

import importlib
import math
import time
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
from matplotlib.animation import FFMpegWriter, PillowWriter, writers
from numpy.typing import ArrayLike, NDArray

from velfence._typing import FloatArray
from velfence._validate import finite_array
from velfence.apps import progress
from velfence.apps.teleop.scene import Scene, scene_to_dicts
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.primitives import orthonormal_complement

__all__ = [
    "VIEW_LIMITS",
    "animate_session",
    "draw_arm",
    "draw_fixture",
    "draw_laser",
    "draw_scene",
    "draw_snapshot",
    "frame_indices",
    "new_axes",
    "plot_snapshot",
]


#: Default view box ``((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))`` [m]: 2 m cubed around the
#: shoulder (reach 0.88 m) and the pick-and-place table (y from 0.3 to 1.0 m, z = -0.6 m).
VIEW_LIMITS: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] = (
    (-1.0, 1.0),
    (-0.6, 1.4),
    (-1.0, 1.0),
)

_FACE = {
    "plane": "#d9d9cf",
    "disk": "#ff9628",
    "cylinder": "#4682c8",
    "box": "#a07846",
}
_EDGE = {"plane": "#8a8a80", "disk": "#c06000", "cylinder": "#244a70", "box": "#6b4a22"}
_LINK = "#4a6f96"
_LASER = "#e00000"
_FIXTURE = "#c000c0"
_AXES = ("#dd2222", "#22aa22", "#2222dd")
TOOL_AXIS_LENGTH = 0.1  # [m], drawn length of the tool frame's axes
NO_READING_RAY = 0.3  # [m], drawn length of the beam when the sensor reads nothing


# ---------------------------------------------------------------------------------- inputs
def _vec(name: str, x: Any) -> FloatArray:
    return finite_array(name, x, (3,))


def _joints(snapshot: Mapping[str, Any]) -> FloatArray:
    if "joints" not in snapshot:
        raise InvalidInput(
            f"snapshot: expected a 'joints' entry (points base to tool), got keys "
            f"{sorted(snapshot)}"
        )
    try:
        J = np.asarray(snapshot["joints"], dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(
            f"snapshot['joints']: expected points [m] of shape (n, 3), got {snapshot['joints']!r}"
        ) from None
    if J.ndim != 2 or J.shape[1] != 3 or J.shape[0] < 2 or not np.all(np.isfinite(J)):
        raise InvalidInput(
            f"snapshot['joints']: expected finite points [m] of shape (n >= 2, 3), got shape "
            f"{J.shape}"
        )
    return J


def _tool(snapshot: Mapping[str, Any]) -> FloatArray:
    if "tool" not in snapshot:
        raise InvalidInput(
            f"snapshot: expected a 'tool' entry (4 x 4 pose), got keys {sorted(snapshot)}"
        )
    try:
        T = np.asarray(snapshot["tool"], dtype=float)
    except (TypeError, ValueError):
        raise InvalidInput(
            f"snapshot['tool']: expected a 4 x 4 pose, got {snapshot['tool']!r}"
        ) from None
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise InvalidInput(f"snapshot['tool']: expected a finite 4 x 4 pose, got shape {T.shape}")
    return T


def _scene_list(scene: Any) -> list[Mapping[str, Any]]:
    if isinstance(scene, Scene):
        return list(scene_to_dicts(scene))
    if isinstance(scene, Mapping) or not isinstance(scene, Sequence):
        raise InvalidInput(
            f"scene: expected a Scene or a list of primitive dicts, got {type(scene).__name__}"
        )
    for i, prim in enumerate(scene):
        if not isinstance(prim, Mapping) or "type" not in prim:
            raise InvalidInput(f"scene[{i}]: expected a dict with a 'type', got {prim!r}")
    return list(scene)


def _circle(center: FloatArray, normal: FloatArray, radius: float, n: int = 32) -> FloatArray:
    u, v = orthonormal_complement(normal)
    ang = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    pts: FloatArray = center + radius * (np.outer(np.cos(ang), u) + np.outer(np.sin(ang), v))
    return pts


def _faces(prim: Mapping[str, Any]) -> list[FloatArray]:
    """Polygons [m] (each shape (k, 3)) that draw one primitive dict."""
    kind = prim["type"]
    name = prim.get("name", "?")
    if kind == "plane":
        if prim.get("half_extents") is not None:
            return [finite_array(f"{name}.corners", prim.get("corners"), (4, 3))]
        # an infinite plane is drawn as a 2 m square about its point
        p = _vec(f"{name}.point", prim.get("point"))
        u = _vec(f"{name}.u_axis", prim.get("u_axis"))
        v = _vec(f"{name}.v_axis", prim.get("v_axis"))
        signs = ((1, 1), (-1, 1), (-1, -1), (1, -1))
        return [np.array([p + a * u + b * v for a, b in signs])]
    if kind == "disk":
        c = _vec(f"{name}.center", prim["center"])
        return [_circle(c, _vec(f"{name}.normal", prim["normal"]), float(prim["radius"]))]
    if kind == "cylinder":
        b = _vec(f"{name}.base_center", prim["base_center"])
        r, h = float(prim["radius"]), float(prim["height"])
        z = np.array([0.0, 0.0, 1.0])
        lo = _circle(b, z, r, 24)
        hi = lo + h * z
        sides = [np.array([lo[i], lo[(i + 1) % 24], hi[(i + 1) % 24], hi[i]]) for i in range(24)]
        return [lo, *sides, hi]
    if kind == "box":
        c = finite_array(f"{name}.corners", prim.get("corners"), (8, 3))
        out = []
        for axis in range(3):
            o1, o2 = (k for k in range(3) if k != axis)
            for side in (0, 1):
                idx = [
                    (side << axis) | (a << o1) | (b2 << o2)
                    for a, b2 in ((0, 0), (1, 0), (1, 1), (0, 1))
                ]
                out.append(c[idx])
        return out
    raise InvalidInput(
        f"scene primitive {name!r}: expected type plane, disk, cylinder or box, got {kind!r}"
    )


_POINT_FIELDS = ("base_center", "center", "top", "point")


def _translated(prim: Mapping[str, Any], delta: FloatArray) -> dict[str, Any]:
    """A copy of ``prim`` moved by ``delta`` [m] (every point-valued field)."""
    out = dict(prim)
    for key in _POINT_FIELDS:
        if out.get(key) is not None:
            out[key] = (np.asarray(out[key], dtype=float) + delta).tolist()
    if out.get("corners") is not None:
        out["corners"] = (np.asarray(out["corners"], dtype=float) + delta).tolist()
    return out


def _moved(prim: Mapping[str, Any], snapshot: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """A dynamic primitive where the snapshot's ``task`` puts it (``None``: hidden)."""
    task = snapshot.get("task")
    name = prim.get("name")
    if not isinstance(task, Mapping) or name not in task:
        return prim
    where = task[name]
    if where is None:
        return None
    ref_key = next((k for k in _POINT_FIELDS if prim.get(k) is not None), None)
    if ref_key is None:
        return prim
    delta = _vec(f"task[{name!r}]", where) - np.asarray(prim[ref_key], dtype=float)
    return _translated(prim, delta)


def _anchor(prim: Mapping[str, Any]) -> FloatArray | None:
    if prim.get("type") == "plane":
        return np.asarray(_faces(prim)[0][0], dtype=float)
    if prim.get("type") == "cylinder":
        top: FloatArray = np.asarray(prim["base_center"], dtype=float) + np.array(
            [0.0, 0.0, float(prim["height"])]
        )
        return top
    for key in ("top", "center", "point"):
        if prim.get(key) is not None:
            return np.asarray(prim[key], dtype=float)
    return None


# ---------------------------------------------------------------------------------- drawing
def new_axes(
    *,
    figsize: tuple[float, float] = (6.4, 5.6),
    limits: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] = VIEW_LIMITS,
    elev: float = 22.0,
    azim: float = -150.0,
    zoom: float = 1.0,
) -> tuple[Any, Any]:
    """A figure with one 3-D axes set up for the PUMA scene.

    Args:
        figsize: Figure size [inch].
        limits: ``((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))`` [m]; equal spans keep the
            aspect true.
        elev: Camera elevation [deg].
        azim: Camera azimuth [deg] (matplotlib's convention; -150 looks at the arm from its
            side, with the table behind it).
        zoom: Axes zoom (matplotlib ``set_box_aspect``), > 0.

    Returns:
        ``(figure, axes)``.
    """
    fig = plt.figure(figsize=figsize)
    # Painter's order from zorder: matplotlib's per-artist depth sort puts table-top objects in
    # front of the arm above them; draw_scene ranks the solids by depth itself.
    ax = fig.add_subplot(projection="3d", computed_zorder=False)
    (x0, x1), (y0, y1), (z0, z1) = limits
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_zlim(z0, z1)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=1.0)
    ax.set_box_aspect((x1 - x0, y1 - y0, z1 - z0), zoom=zoom)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.view_init(elev=elev, azim=azim)
    return fig, ax


def draw_scene(
    ax: Any,
    scene: Scene | Sequence[Mapping[str, Any]],
    *,
    labels: bool = True,
    pedestal: bool = True,
) -> list[Any]:
    """Draw scene primitives (table, cup, folder, destination mark) on a 3-D axes.

    Args:
        ax: A matplotlib 3-D axes.
        scene: A :class:`~velfence.apps.teleop.scene.Scene` or a list of primitive dicts in the
            :func:`~velfence.apps.teleop.scene.scene_to_dicts` format.
        labels: Write each primitive's name next to it.
        pedestal: Draw the base frame axes and a grey column under the shoulder (illustration
            only: the base frame is at the shoulder; the pedestal height is not modelled).

    Returns:
        The artists added.

    Raises:
        InvalidInput: a primitive of unknown type or with malformed fields.
    """
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

    artists: list[Any] = []
    if pedestal:
        z_lo = float(ax.get_zlim()[0])
        artists += ax.plot([0, 0], [0, 0], [0, z_lo], color="0.75", lw=9, solid_capstyle="butt",
                           zorder=1.5)  # fmt: skip
        for k, col in enumerate(_AXES):
            e = np.zeros(3)
            e[k] = 0.15
            artists += ax.plot([0, e[0]], [0, e[1]], [0, e[2]], color=col, lw=1.2, zorder=1.6)
    el, az = math.radians(float(ax.elev)), math.radians(float(ax.azim))
    toward_camera = np.array(
        [math.cos(az) * math.cos(el), math.sin(az) * math.cos(el), math.sin(el)]
    )
    drawn = [(prim, _faces(prim)) for prim in _scene_list(scene)]
    solids = sorted(
        (float(np.mean(np.vstack(polys) @ toward_camera)), i)
        for i, (prim, polys) in enumerate(drawn)
        if prim["type"] in ("cylinder", "box")
    )
    rank = {i: r for r, (_, i) in enumerate(solids)}
    for i, (prim, polys) in enumerate(drawn):
        kind = str(prim["type"])
        zorder = {"plane": 1.0, "disk": 1.2}.get(kind, 2.0 + 0.1 * rank.get(i, 0))
        coll = Poly3DCollection(
            polys,
            facecolors=_FACE.get(kind, "0.7"),
            edgecolors=_EDGE.get(kind, "0.3") if kind != "cylinder" else "none",
            linewidths=0.6,
            alpha=0.5 if kind in ("plane", "box") else 0.8,
            zorder=zorder,
        )
        ax.add_collection3d(coll)
        artists.append(coll)
        if kind == "cylinder":
            for ring in (polys[0], polys[-1]):
                closed = np.vstack([ring, ring[:1]])
                artists += ax.plot(*closed.T, color=_EDGE["cylinder"], lw=0.8, zorder=zorder)
        at = _anchor(prim)
        if labels and at is not None:
            x, y, z = at.tolist()
            name = str(prim.get("name", ""))
            artists.append(ax.text(x, y, z + 0.03, name, fontsize=7, color="0.3", zorder=9))
    return artists


def draw_arm(ax: Any, snapshot: Mapping[str, Any]) -> list[Any]:
    """Draw the arm: links as thick lines, joints as dots, and the tool frame's axes.

    Args:
        ax: A matplotlib 3-D axes.
        snapshot: A session snapshot; uses ``joints`` (points [m] base to tool, (n, 3)),
            ``tool`` (4 x 4 pose; x, y, z axes drawn red, green, blue, 0.1 m long) and, if
            present, ``gripper`` (a grey bar from ``start`` to ``end``).

    Returns:
        The artists added.

    Raises:
        InvalidInput: missing or malformed ``joints`` or ``tool``.
    """
    J = _joints(snapshot)
    T = _tool(snapshot)
    artists: list[Any] = []
    artists += ax.plot(*J.T, color=_LINK, lw=7, solid_capstyle="round", alpha=0.9, zorder=11)
    artists += ax.plot(*J.T, "o", color="#223344", ms=4, ls="none", zorder=12)
    gripper = snapshot.get("gripper")
    if gripper:
        G = np.stack([_vec("gripper.start", gripper["start"]), _vec("gripper.end", gripper["end"])])
        artists += ax.plot(*G.T, color="#707070", lw=4, solid_capstyle="butt", zorder=11)
    o = T[:3, 3]
    for k, col in enumerate(_AXES):
        tip = o + TOOL_AXIS_LENGTH * T[:3, k]
        artists += ax.plot(
            [o[0], tip[0]], [o[1], tip[1]], [o[2], tip[2]], color=col, lw=2, zorder=13
        )
    return artists


def draw_laser(ax: Any, snapshot: Mapping[str, Any]) -> list[Any]:
    """Draw the laser beam: origin to spot, or a dashed 0.3 m ray when there is no reading.

    The ray's direction is ``laser["direction"]`` when given, else the tool's z axis (the beam is
    parallel to ``z6``, thesis eq. 40).

    Args:
        ax: A matplotlib 3-D axes.
        snapshot: A session snapshot; uses ``laser`` (``None`` draws nothing) and ``tool``.

    Returns:
        The artists added.
    """
    laser = snapshot.get("laser")
    if not laser or laser.get("origin") is None:
        return []
    o = _vec("laser.origin", laser["origin"])
    artists: list[Any] = []
    if laser.get("point") is not None:
        p = _vec("laser.point", laser["point"])
        artists += ax.plot(*np.stack([o, p]).T, color=_LASER, lw=1.6, zorder=10)
        artists += ax.plot([p[0]], [p[1]], [p[2]], "o", color=_LASER, ms=5, zorder=10)
    else:
        if laser.get("direction") is not None:
            d = _vec("laser.direction", laser["direction"])
        else:
            d = _tool(snapshot)[:3, 2]
        d = d / max(float(np.linalg.norm(d)), 1e-12)
        end = o + NO_READING_RAY * d
        artists += ax.plot(*np.stack([o, end]).T, color=_LASER, lw=1.2, ls="--", zorder=10)
    return artists


def draw_fixture(ax: Any, snapshot: Mapping[str, Any]) -> list[Any]:
    """Draw the virtual-fixture line (key 'F' or 'S'): a thick dashed magenta segment.

    Args:
        ax: A matplotlib 3-D axes.
        snapshot: A session snapshot; uses ``fixture`` (``{"start": [3], "end": [3]}`` or
            ``None``, which draws nothing).

    Returns:
        The artists added.
    """
    fixture = snapshot.get("fixture")
    if not fixture:
        return []
    a = _vec("fixture.start", fixture["start"])
    b = _vec("fixture.end", fixture["end"])
    return list(ax.plot(*np.stack([a, b]).T, color=_FIXTURE, lw=2.5, ls=(0, (6, 3)), zorder=10))


def draw_snapshot(ax: Any, snapshot: Mapping[str, Any]) -> list[Any]:
    """Draw the moving parts of one snapshot: moved objects, task points, fixture, laser, arm.

    Args:
        ax: A matplotlib 3-D axes.
        snapshot: A session snapshot.

    Returns:
        The artists added (remove them to draw the next frame).
    """
    artists: list[Any] = []
    objects = snapshot.get("objects")
    if objects:
        artists += draw_scene(ax, objects, labels=False, pedestal=False)
    artists += _draw_task_points(ax, snapshot)
    artists += draw_fixture(ax, snapshot)
    artists += draw_laser(ax, snapshot)
    artists += draw_arm(ax, snapshot)
    return artists


def _draw_task_points(ax: Any, snapshot: Mapping[str, Any]) -> list[Any]:
    artists: list[Any] = []
    dest = snapshot.get("destination")
    if dest is not None:
        d = _vec("destination", dest)
        artists += ax.plot([d[0]], [d[1]], [d[2]], "X", color="#ff7f00", ms=8, zorder=10)
    pts = snapshot.get("plane_points") or []
    if len(pts):
        P = np.array([_vec("plane_points[]", p) for p in pts])
        artists += ax.plot(*P.T, "^", color="#7b3294", ms=6, ls="none", zorder=10)
    return artists


#: Figure width [inch] with the legend beside the 3-D scene, and the scene's share of it.
LEGEND_FIGSIZE = (8.6, 5.6)
_SCENE_SHARE = 0.74


def _legend(
    fig: Any, scene: Sequence[Mapping[str, Any]], snapshots: Sequence[Mapping[str, Any]]
) -> Any:
    """One legend beside the scene naming every kind of thing the frames draw.

    Built from the scene and all the snapshots (not one frame), so it stays the same through an
    animation: the primitives by type with their names, the pedestal and frame axes, the arm,
    the laser, the fixture line and the task points when any snapshot has them.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    def line(label: str, colour: Any, **kw: Any) -> tuple[Any, str]:
        return Line2D([], [], color=colour, **kw), label

    prims = [*scene, *(o for s in snapshots for o in (s.get("objects") or ()))]
    entries: list[tuple[Any, str]] = []
    for kind in ("plane", "box", "disk", "cylinder"):
        names = sorted({str(p.get("name") or kind) for p in prims if p.get("type") == kind})
        if names:
            entries.append((Patch(facecolor=_FACE[kind], edgecolor=_EDGE[kind]), ", ".join(names)))
    entries += [
        line("pedestal (illustration)", "0.75", lw=6),
        *(
            line(f"{a} axis (base, tool frames)", c, lw=2)
            for a, c in zip("xyz", _AXES, strict=True)
        ),
        line("arm links", _LINK, lw=5),
        line("joints", "#223344", marker="o", ls="none", ms=4),
    ]
    if any(s.get("gripper") for s in snapshots):
        entries.append(line("gripper", "#707070", lw=4))
    lasers: list[Mapping[str, Any]] = [s["laser"] for s in snapshots if s.get("laser")]
    if any(la.get("point") is not None for la in lasers):
        entries += [
            line("laser beam", _LASER, lw=1.6),
            line("laser spot", _LASER, marker="o", ls="none", ms=5),
        ]
    if any(la.get("point") is None and la.get("origin") is not None for la in lasers):
        entries.append(line(f"laser, no reading ({NO_READING_RAY:g} m ray)", _LASER, ls="--"))
    if any(s.get("fixture") for s in snapshots):
        entries.append(line("virtual fixture line", _FIXTURE, lw=2.5, ls=(0, (6, 3))))
    if any(s.get("destination") is not None for s in snapshots):
        entries.append(line("destination point", "#ff7f00", marker="X", ls="none", ms=8))
    if any(len(s.get("plane_points") or []) for s in snapshots):
        entries.append(line("plane points", "#7b3294", marker="^", ls="none", ms=6))
    fig.set_size_inches(*LEGEND_FIGSIZE)
    fig.subplots_adjust(left=0.0, right=_SCENE_SHARE, bottom=0.0, top=1.0)
    handles, labels = zip(*entries, strict=True)
    return fig.legend(
        handles, labels, loc="center left", bbox_to_anchor=(_SCENE_SHARE, 0.5), fontsize=7,
        frameon=False,
    )  # fmt: skip


def _overlay(snapshot: Mapping[str, Any], speedup: float | None = None) -> str:
    t = snapshot.get("t")
    clutch = snapshot.get("clutch")
    head = "t = " + (f"{float(t):6.2f} s" if t is not None else "?")
    head += f"   mode: {snapshot.get('mode', '?')}"
    head += "   clutch: " + ("?" if clutch is None else ("engaged" if clutch else "free"))
    if speedup is not None and speedup > 1.05:
        head += f"   (×{speedup:.1f})"
    status = str(snapshot.get("status") or "")
    if len(status) > 90:
        status = status[:87] + "..."
    return head + ("\n" + status if status else "")


def _static_and_dynamic(
    scene: Sequence[Mapping[str, Any]], snapshots: Sequence[Mapping[str, Any]]
) -> tuple[list[Mapping[str, Any]], dict[str, Mapping[str, Any]]]:
    moved = {str(o.get("name")) for s in snapshots for o in (s.get("objects") or ())}
    moved |= {str(p.get("name")) for p in scene if p.get("dynamic")}
    static = [p for p in scene if str(p.get("name")) not in moved]
    dynamic = {str(p.get("name")): p for p in scene if str(p.get("name")) in moved}
    return static, dynamic


def _frame_objects(
    snapshot: Mapping[str, Any], dynamic: Mapping[str, Mapping[str, Any]]
) -> dict[str, Any]:
    """The snapshot with ``objects`` completed by static versions of the moved primitives."""
    own = {str(o.get("name")): o for o in (snapshot.get("objects") or ())}
    merged: list[Mapping[str, Any]] = []
    for name, prim in dynamic.items():
        placed = own[name] if name in own else _moved(prim, snapshot)
        if placed is not None:
            merged.append(placed)
    merged += [o for name, o in own.items() if name not in dynamic]
    return {**snapshot, "objects": merged}


def plot_snapshot(
    snapshot: Mapping[str, Any],
    scene: Scene | Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    title: str | None = None,
    limits: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] = VIEW_LIMITS,
    elev: float = 22.0,
    azim: float = -150.0,
    dpi: int = 110,
) -> Path:
    """One 3-D picture of the arm, scene, laser beam and fixture line.

    Args:
        snapshot: A session snapshot (see the module docstring).
        scene: A Scene or a list of primitive dicts.
        path: Output image file (format from its suffix, e.g. ``.png``).
        title: Figure title (default: the overlay of time, mode, clutch and status).
        limits: View box [m], see :func:`new_axes`.
        elev: Camera elevation [deg].
        azim: Camera azimuth [deg].
        dpi: Resolution [dots per inch].

    Returns:
        The path written.

    Raises:
        InvalidInput: a malformed snapshot or scene.
    """
    scene_list = _scene_list(scene)
    static, dynamic = _static_and_dynamic(scene_list, [snapshot])
    fig, ax = new_axes(limits=limits, elev=elev, azim=azim)
    try:
        draw_scene(ax, static)
        draw_snapshot(ax, _frame_objects(snapshot, dynamic) if dynamic else snapshot)
        _legend(fig, scene_list, [snapshot])
        text = _overlay(snapshot) if title is None else title
        fig.text(0.02, 0.98, text, fontsize=9, va="top", family="monospace")
        out = Path(path)
        fig.savefig(out, dpi=dpi)
    finally:
        plt.close(fig)
    return out


def frame_indices(times: ArrayLike, *, fps: float, max_frames: int) -> NDArray[np.intp]:
    """Which snapshots become animation frames: evenly spaced in time, at most ``max_frames``.

    The number of frames is ``min(max_frames, len(times), floor(duration · fps) + 1)``; frame
    ``k`` shows the snapshot nearest to ``t_0 + k · duration / (frames - 1)``. Duplicates (two
    frame times nearest to one snapshot) are dropped, so the result is strictly increasing.

    Args:
        times: Snapshot times [s], shape (n,), n >= 1, finite, non-decreasing.
        fps: Playback frames per second, > 0.
        max_frames: Upper bound on the frame count, >= 1.

    Returns:
        Indices into ``times``, shape (frames,), strictly increasing; first 0 and last n - 1
        (a single frame shows the last snapshot).

    Raises:
        InvalidInput: empty, non-finite or decreasing times.
        InvalidParameter: ``fps <= 0`` or ``max_frames < 1``.
    """
    if not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
        raise InvalidParameter(f"fps: expected a number > 0 [1/s], got {fps!r}")
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise InvalidParameter(f"max_frames: expected an integer >= 1, got {max_frames!r}")
    t = np.asarray(times, dtype=float)
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)):
        raise InvalidInput(f"times: expected finite snapshot times [s], shape (n >= 1,), got {t!r}")
    if np.any(np.diff(t) < 0):
        raise InvalidInput("times: expected non-decreasing snapshot times [s]")
    duration = float(t[-1] - t[0])
    n = min(max_frames, t.size, math.floor(duration * fps + 1e-9) + 1)
    if n == 1:
        return np.array([t.size - 1], dtype=np.intp)
    targets = np.linspace(t[0], t[-1], n)
    hi = np.clip(np.searchsorted(t, targets, side="left"), 1, t.size - 1)
    lo = hi - 1
    idx = np.where(targets - t[lo] <= t[hi] - targets, lo, hi)
    idx[0], idx[-1] = 0, t.size - 1
    return np.unique(idx).astype(np.intp)


def _writer(path: Path, fps: int) -> Any:
    suffix = path.suffix.lower()
    if suffix == ".gif":
        return PillowWriter(fps=fps)
    if suffix == ".mp4":
        try:  # optional: the imageio-ffmpeg wheel bundles an ffmpeg binary
            ffmpeg = importlib.import_module("imageio_ffmpeg")
            matplotlib.rcParams["animation.ffmpeg_path"] = ffmpeg.get_ffmpeg_exe()
        except ImportError:
            pass
        if not writers.is_available("ffmpeg"):
            raise InvalidParameter(
                f"path: an .mp4 needs ffmpeg (pip install imageio-ffmpeg), none found for "
                f"{str(path)!r}; write a .gif instead"
            )
        return FFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
    raise InvalidParameter(f"path: expected a .gif or .mp4 file, got {str(path)!r}")


def animate_session(
    snapshots: Sequence[Mapping[str, Any]],
    scene: Scene | Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    fps: int = 15,
    max_frames: int = 150,
    limits: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] = VIEW_LIMITS,
    elev: float = 22.0,
    azim: float = -150.0,
    dpi: int = 72,
    timings: dict[str, float] | None = None,
) -> Path:
    """Render a recorded session as a GIF (or MP4) with a time / mode / clutch overlay.

    Snapshots are subsampled evenly in time by :func:`frame_indices`; a session longer than
    ``max_frames / fps`` seconds plays faster than real time (the overlay shows the factor).
    The static scene is drawn once; each frame redraws the arm, beam, fixture and any moved
    objects; a legend beside the scene names every kind of thing drawn. The default 150 frames
    at 72 dpi (619 x 403 px) render in about 8 s here.

    Args:
        snapshots: Session snapshots in time order (each needs ``t``, ``joints``, ``tool``).
        scene: A Scene or a list of primitive dicts.
        path: Output ``.gif`` (Pillow) or ``.mp4`` (needs an ffmpeg).
        fps: Playback frames per second, > 0.
        max_frames: Most frames to render, >= 1 (render time is about linear in it).
        limits: View box [m], see :func:`new_axes`.
        elev: Camera elevation [deg].
        azim: Camera azimuth [deg].
        dpi: Resolution [dots per inch] of the 8.6 x 5.6 inch figure.
        timings: If given, filled with ``frames`` (count), ``render_s`` (wall time [s]) and
            ``speedup`` (simulated seconds per playback second).

    Returns:
        The path written.

    Raises:
        InvalidInput: no snapshots, or a malformed snapshot or scene.
        InvalidParameter: bad ``fps`` / ``max_frames``, an unsupported suffix, or ``.mp4``
            without ffmpeg.
    """
    start = time.perf_counter()
    if len(snapshots) == 0:
        raise InvalidInput("snapshots: expected at least one snapshot, got none")
    for i, s in enumerate(snapshots):
        if not isinstance(s, Mapping) or s.get("t") is None:
            raise InvalidInput(f"snapshots[{i}]: expected a mapping with a time 't' [s]")
    out = Path(path)
    writer = _writer(out, fps)
    times = np.array([float(s["t"]) for s in snapshots])
    idx = frame_indices(times, fps=fps, max_frames=max_frames)
    duration = float(times[-1] - times[0])
    # frames are duration / (frames - 1) simulated seconds apart and 1 / fps apart on playback
    speedup = duration * fps / (len(idx) - 1) if len(idx) > 1 else 1.0
    scene_list = _scene_list(scene)
    static, dynamic = _static_and_dynamic(scene_list, snapshots)
    fig, ax = new_axes(limits=limits, elev=elev, azim=azim)
    try:
        draw_scene(ax, static)
        _legend(fig, scene_list, snapshots)
        stamp = fig.text(0.02, 0.98, "", fontsize=9, va="top", family="monospace")
        with writer.saving(fig, str(out), dpi):
            on_frame = progress.frames(out.name)
            for j, k in enumerate(idx):
                on_frame(j, len(idx))
                snap = snapshots[int(k)]
                artists = draw_snapshot(ax, _frame_objects(snap, dynamic) if dynamic else snap)
                stamp.set_text(_overlay(snap, speedup))
                writer.grab_frame()
                for a in artists:
                    a.remove()
    finally:
        plt.close(fig)
    if timings is not None:
        timings.update(
            frames=float(len(idx)), render_s=time.perf_counter() - start, speedup=speedup
        )
    return out
