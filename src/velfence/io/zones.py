"""Vendor zones as velfence sets: UR-style safety planes, box workspaces, Nav2 polygons.

Formats and conventions (``docs/zones.md`` has the examples and the errors):

* **Safety planes** (Universal Robots style). Each plane has a unit ``normal`` (3,) that points
  **into the allowed side** (UR's manuals: the small arrow drawn on a plane marks the allowed
  side, and a positive *displacement* enlarges the allowed space by moving the plane against its
  normal) and either an ``offset`` [m] (allowed: ``normal · p >= offset``, in the robot base
  frame) or a ``point`` on the plane [m] with an optional UR ``displacement`` [m] (allowed:
  ``normal · (p - point) >= -displacement``). ``restrict`` says which point the plane limits:
  ``"tool"`` (the TCP), ``"elbow"`` or ``"both"``; ``mode`` is UR's plane mode (``"normal"``,
  ``"reduced"``, ``"both"``, or ``"trigger_reduced"`` / ``"disabled"``, which limit nothing).
  Half-spaces alone rarely close a set: an unbounded result is refused unless a ``bounds`` box
  closes it.
* **Box workspaces**: ``lower``/``upper`` corners (or MoveIt's ``min_corner``/``max_corner``,
  lists or ``{x, y, z}`` mappings) as a :class:`~velfence.geometry.polytope.ConvexPolytope`.
* **Nav2 collision-monitor polygons**: the ``collision_monitor`` node's parameters
  (``polygons: [names]`` and one entry per name with ``type``, ``points``, ``action_type``);
  ``points`` as Nav2 ≥ Iron writes them (a string ``"[[x, y], ...]"``), as Humble does (a flat
  list ``[x1, y1, x2, y2, ...]``) or as a list of pairs. Each polygon becomes a
  :class:`~velfence.geometry.polygon.ConvexPolygon` in the same frame (Nav2's ``base_frame_id``,
  robot-relative). A ``circle`` is refused unless ``circle_sides`` asks for the inscribed regular
  polygon. Nav2 stops the robot when *obstacles* enter these zones; velfence keeps a *point
  inside* a set: the import gives the geometry, not Nav2's behaviour.

Importing this module needs NumPy and SciPy only. Files are read with the one YAML reader
(:mod:`velfence.io.yaml_reader`: plain YAML, at most 1 MiB, no aliases, tags or duplicate keys),
which needs PyYAML (the ``app`` extra; without it a file load raises
:class:`~velfence.errors.MissingExtra` naming the extra); the functions that take already-parsed
mappings need nothing more. Until 0.3 the module is importable as ``velfence.bridge.zones`` too,
with a :class:`DeprecationWarning`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_choice, check_positive_int, readonly, real_array, show
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.geometry.polytope import ConvexPolytope
from velfence.io.yaml_reader import did_you_mean

__all__ = [
    "MAX_CIRCLE_SIDES",
    "MAX_PLANES",
    "MAX_POLYGONS",
    "NavZone",
    "PlaneZones",
    "SafetyPlane",
    "box_workspace",
    "load_nav2_polygons",
    "load_ur_safety_planes",
    "nav2_points",
    "nav2_polygons",
    "ur_safety_planes",
]

#: Most safety planes accepted (UR controllers allow 8; other vendors a few more).
MAX_PLANES = 64
#: Most polygons accepted in one collision-monitor configuration.
MAX_POLYGONS = 64
#: Most sides of the polygon inscribed in a Nav2 circle.
MAX_CIRCLE_SIDES = 360
#: Most corners of one Nav2 polygon.
_MAX_CORNERS = 1000
#: Longest accepted Nav2 ``points`` string [characters].
_MAX_POINTS_TEXT = 100_000
#: A plane normal is unit when its length is within this of 1.
_UNIT_TOL = 1e-6
#: Largest coordinate accepted [m]: far beyond any cell, small enough for the LPs.
_MAX_COORD = 1e6

Restrict = Literal["tool", "elbow", "both"]
PlaneMode = Literal["normal", "reduced", "both", "trigger_reduced", "disabled"]
SafetyMode = Literal["normal", "reduced"]
ActionType = Literal["stop", "slowdown", "limit", "approach", "none"]

_RESTRICT: tuple[Restrict, ...] = ("tool", "elbow", "both")
_PLANE_MODES: tuple[PlaneMode, ...] = ("normal", "reduced", "both", "trigger_reduced", "disabled")
_SAFETY_MODES: tuple[SafetyMode, ...] = ("normal", "reduced")
_ACTIONS: tuple[ActionType, ...] = ("stop", "slowdown", "limit", "approach", "none")
_PLANE_KEYS = frozenset({"name", "normal", "offset", "point", "displacement", "restrict", "mode"})


# ---------------------------------------------------------------------------- records


@dataclass(frozen=True, eq=False)
class SafetyPlane:
    """One safety plane, normalised: the allowed side is ``normal · p >= offset``.

    Attributes:
        name: The plane's name (``"plane i"`` when the input has none).
        normal: Unit normal pointing into the allowed side, shape (3,), read-only.
        offset: Offset [m]: the plane is ``normal · p = offset`` (base frame).
        restrict: Which point the plane limits: ``"tool"``, ``"elbow"`` or ``"both"``.
        mode: UR's plane mode: ``"normal"``, ``"reduced"``, ``"both"``, ``"trigger_reduced"``
            or ``"disabled"``.
    """

    name: str
    normal: FloatArray
    offset: float
    restrict: Restrict
    mode: PlaneMode


@dataclass(frozen=True, eq=False)
class PlaneZones:
    """The sets that a list of safety planes defines, one per limited point.

    Attributes:
        tcp: The set the TCP (tool point) must stay in, or ``None`` when no active plane limits
            the tool. Facets are named after the planes (and ``"bounds x_min"`` ... for the box).
        elbow: The same for the elbow, or ``None``.
        planes: Every plane of the input, normalised, in input order.
        active: Names of the planes that limit something in the chosen safety mode.
        ignored: Names of the planes that limit nothing in that mode (``trigger_reduced``,
            ``disabled``, or the other mode's planes).
        safety_mode: The safety mode the sets are for (``"normal"`` or ``"reduced"``).
    """

    tcp: ConvexPolytope | None
    elbow: ConvexPolytope | None
    planes: tuple[SafetyPlane, ...]
    active: tuple[str, ...]
    ignored: tuple[str, ...]
    safety_mode: SafetyMode


@dataclass(frozen=True, eq=False)
class NavZone:
    """One Nav2 collision-monitor polygon as a convex polygon.

    Attributes:
        name: The polygon's name (its entry in ``polygons``).
        polygon: The zone, in Nav2's ``base_frame_id`` (robot-relative) [m].
        action_type: Nav2's ``action_type``: ``"stop"``, ``"slowdown"``, ``"limit"``,
            ``"approach"`` or ``"none"``.
        shape: ``"polygon"``, or ``"circle"`` for an inscribed polygon of a circle.
        enabled: Nav2's ``enabled`` (default ``True``).
        radius: The circle's radius [m] for a ``"circle"``, ``None`` for a polygon.
    """

    name: str
    polygon: ConvexPolygon
    action_type: ActionType
    shape: Literal["polygon", "circle"]
    enabled: bool
    radius: float | None


# ---------------------------------------------------------------------------- helpers


def _mapping(name: str, value: Any) -> Mapping[Any, Any]:
    if not isinstance(value, Mapping):
        raise InvalidParameter(f"{name}: expected a mapping of fields, got {_type(value)}")
    return value


def _type(value: Any) -> str:
    return f"{type(value).__name__} {show(value, 60)}"


def _text(name: str, value: Any) -> str:
    if not isinstance(value, str) or not value or len(value) > 200:
        raise InvalidParameter(f"{name}: expected a non-empty name (a string), got {_type(value)}")
    return str(value)


def _number(name: str, value: Any, unit: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        hint = "; write numbers without quotes" if isinstance(value, str) else ""
        raise InvalidParameter(f"{name}: expected a number [{unit}], got {_type(value)}{hint}")
    v = float(value) if not isinstance(value, np.complexfloating) else math.nan
    if not math.isfinite(v) or abs(v) > _MAX_COORD:
        raise InvalidParameter(
            f"{name}: expected a finite number [{unit}] of magnitude <= {_MAX_COORD:g}, got {v!r}"
        )
    return v


def _vector3(name: str, value: Any, unit: str) -> FloatArray:
    if isinstance(value, Mapping):  # MoveIt / ROS style {x: .., y: .., z: ..}
        keys = set(value)
        if keys != {"x", "y", "z"}:
            raise InvalidParameter(
                f"{name}: expected the keys x, y, z, got {sorted(map(str, keys))}"
            )
        return np.array([_number(f"{name}.{k}", value[k], unit) for k in "xyz"])
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise InvalidParameter(f"{name}: expected 3 numbers [{unit}], got {_type(value)}")
    out = real_array(name, value, error=InvalidParameter, what=f"3 numbers [{unit}]")
    if out.shape != (3,):
        raise InvalidParameter(f"{name}: expected 3 numbers [{unit}], got shape {out.shape}")
    if np.any(np.abs(out) > _MAX_COORD):
        raise InvalidParameter(f"{name}: expected magnitudes <= {_MAX_COORD:g} [{unit}]")
    return out


def _read_yaml(path: Any) -> tuple[Path, Any]:
    """The path and the document of a YAML file, through velfence's one YAML reader."""
    from velfence.io.yaml_reader import file_path, read_yaml

    p = file_path(path)
    return p, read_yaml(p)


def _bounds(name: str, bounds: Any) -> tuple[FloatArray, FloatArray] | None:
    if bounds is None:
        return None
    if isinstance(bounds, Mapping):
        return _corners(name, bounds)
    if isinstance(bounds, (str, bytes)) or not isinstance(bounds, (Sequence, np.ndarray)):
        raise InvalidParameter(
            f"{name}: expected (lower, upper) corners [m] or a mapping with lower and upper, "
            f"got {_type(bounds)}"
        )
    if len(bounds) != 2:
        raise InvalidParameter(
            f"{name}: expected two corners (lower, upper) [m], got {len(bounds)} entries"
        )
    lo = _vector3(f"{name}[0] (lower)", bounds[0], "m")
    hi = _vector3(f"{name}[1] (upper)", bounds[1], "m")
    _check_order(name, lo, hi)
    return lo, hi


def _corners(name: str, spec: Mapping[Any, Any]) -> tuple[FloatArray, FloatArray]:
    pairs = (("lower", "upper"), ("min_corner", "max_corner"))
    for a, b in pairs:
        if a in spec or b in spec:
            extra = sorted(str(k) for k in spec if k not in (a, b, "header"))
            if extra:
                raise InvalidParameter(
                    f"{name}: unknown field(s) {extra}; expected {a}, {b}"
                    + did_you_mean(extra[0], (a, b))
                )
            for k in (a, b):
                if k not in spec:
                    raise InvalidParameter(f"{name}.{k}: missing (a box needs {a} and {b})")
            lo = _vector3(f"{name}.{a}", spec[a], "m")
            hi = _vector3(f"{name}.{b}", spec[b], "m")
            _check_order(name, lo, hi, a, b)
            return lo, hi
    raise InvalidParameter(
        f"{name}: expected the fields lower and upper (or min_corner and max_corner), got "
        f"{sorted(str(k) for k in spec)}"
    )


def _check_order(
    name: str, lo: FloatArray, hi: FloatArray, a: str = "lower", b: str = "upper"
) -> None:
    bad = np.flatnonzero(~(hi > lo))
    if bad.size:
        j = int(bad[0])
        raise InvalidGeometry(
            f"{name}: expected {b} > {a} on every axis, got {b}[{j}]={float(hi[j])!r} <= "
            f"{a}[{j}]={float(lo[j])!r}"
        )


# ---------------------------------------------------------------------------- boxes


def box_workspace(spec: Mapping[str, Any]) -> ConvexPolytope:
    """A box workspace (3-D, base frame) as a polytope.

    Args:
        spec: ``{"lower": [x, y, z], "upper": [x, y, z]}`` [m], or MoveIt's
            ``workspace_parameters`` form ``{"min_corner": {x, y, z}, "max_corner": {x, y, z}}``
            (an optional ``header`` is ignored); corners as lists or ``{x, y, z}`` mappings.

    Returns:
        The box (facets ``"x_min"``, ``"x_max"``, ``"y_min"``, ...).

    Raises:
        InvalidParameter: not a mapping, a missing or unknown field, a corner that is not 3
            finite numbers (the message names the field).
        InvalidGeometry: ``upper <= lower`` on some axis.
    """
    lo, hi = _corners("spec", _mapping("spec", spec))
    return ConvexPolytope.box(lo, hi)


# ---------------------------------------------------------------------------- safety planes


def _plane(i: int, entry: Any) -> SafetyPlane:
    where = f"planes[{i}]"
    entry = _mapping(where, entry)
    unknown = sorted(str(k) for k in entry if k not in _PLANE_KEYS)
    if unknown:
        raise InvalidParameter(
            f"{where}: unknown field(s) {unknown}; expected {sorted(_PLANE_KEYS)}"
            + did_you_mean(unknown[0], _PLANE_KEYS)
        )
    name = _text(f"{where}.name", entry["name"]) if "name" in entry else f"plane {i}"
    where = f"planes[{i}] ({name})"
    if "normal" not in entry:
        raise InvalidParameter(f"{where}.normal: missing (a unit normal into the allowed side)")
    n = _vector3(f"{where}.normal", entry["normal"], "unit")
    length = float(np.linalg.norm(n))
    if abs(length - 1.0) > _UNIT_TOL:
        raise InvalidParameter(
            f"{where}.normal: expected a unit vector (length 1 within {_UNIT_TOL:g}), got length "
            f"{length:.6g}; divide it by its length (and the offset too, if it was scaled)"
        )
    n = n / length
    has_offset, has_point = "offset" in entry, "point" in entry
    if has_offset == has_point:
        raise InvalidParameter(
            f"{where}: expected exactly one of offset [m] or point [m], got "
            f"{'both' if has_offset else 'neither'}"
        )
    if has_offset:
        if "displacement" in entry:
            raise InvalidParameter(
                f"{where}.displacement: only with point (fold it into offset: offset - "
                "displacement)"
            )
        offset = _number(f"{where}.offset", entry["offset"], "m")
    else:
        p = _vector3(f"{where}.point", entry["point"], "m")
        d = _number(f"{where}.displacement", entry.get("displacement", 0.0), "m")
        offset = float(n @ p) - d
    restrict = entry.get("restrict", "tool")
    if restrict not in _RESTRICT:
        raise InvalidParameter(
            f"{where}.restrict: expected one of {list(_RESTRICT)}, got {show(restrict, 40)}"
        )
    mode = entry.get("mode", "both")
    if mode not in _PLANE_MODES:
        raise InvalidParameter(
            f"{where}.mode: expected one of {list(_PLANE_MODES)}, got {show(mode, 40)}"
        )
    return SafetyPlane(name, readonly(n + 0.0), offset + 0.0, restrict, mode)


def _point_set(
    label: str,
    planes: list[SafetyPlane],
    box: tuple[FloatArray, FloatArray] | None,
) -> ConvexPolytope | None:
    if not planes:
        return None
    N = [p.normal for p in planes]
    off = [p.offset for p in planes]
    names = [p.name for p in planes]
    if box is not None:
        lo, hi = box
        for j, axis in enumerate("xyz"):
            e = np.zeros(3)
            e[j] = 1.0
            N += [e, -e]
            off += [float(lo[j]), -float(hi[j])]
            names += [f"bounds {axis}_min", f"bounds {axis}_max"]
    listed = ", ".join(p.name for p in planes)
    try:
        poly = ConvexPolytope(np.array(N), np.array(off), facet_names=names)
    except InvalidGeometry as exc:
        closing = " and the bounds" if box is not None else ""
        raise InvalidGeometry(
            f"planes limiting the {label} ({listed}){closing} leave no usable space: {exc}; "
            "the normals point into the allowed side"
        ) from None
    if not poly.bounded:
        raise InvalidGeometry(
            f"planes limiting the {label} ({listed}) leave an unbounded set: safety planes are "
            "half-spaces, a fence must be closed; give bounds=(lower, upper) (a box in the base "
            "frame [m], or `bounds:` in the file) to close it"
        )
    return poly


def ur_safety_planes(
    planes: Sequence[Mapping[str, Any]],
    *,
    bounds: Any = None,
    safety_mode: SafetyMode = "normal",
) -> PlaneZones:
    """UR-style safety planes as the polytopes the TCP and the elbow must stay in.

    Convention (UR's): each plane's unit ``normal`` points **into the allowed side**; the allowed
    side is ``normal · p >= offset`` (base frame, [m]), or, given a ``point`` on the plane and
    UR's ``displacement`` (positive enlarges the allowed side),
    ``normal · (p - point) >= -displacement``.

    Args:
        planes: One mapping per plane (at most :data:`MAX_PLANES`): ``normal`` (3 numbers, unit
            length within 1e-6), ``offset`` [m] or ``point`` [m] (+ optional ``displacement``
            [m]), optional ``name``, ``restrict`` (``"tool"`` default, ``"elbow"``, ``"both"``)
            and ``mode`` (``"both"`` default: a limit in normal and reduced mode; ``"normal"``,
            ``"reduced"``, ``"trigger_reduced"``, ``"disabled"``).
        bounds: A box closing the sets: ``(lower, upper)`` corners [m] or a mapping with
            ``lower``/``upper``; ``None`` (default) for none.
        safety_mode: Which planes are limits: ``"normal"`` (planes of mode normal or both) or
            ``"reduced"`` (reduced or both). ``trigger_reduced`` and ``disabled`` planes limit
            nothing and are listed in :attr:`PlaneZones.ignored`.

    Returns:
        The :class:`PlaneZones`: one polytope per limited point (``None`` for a point no active
        plane limits), the planes and which of them are active.

    Raises:
        InvalidParameter: a missing, unknown or malformed field (named as ``planes[i] (name).
            field``), a non-unit normal, duplicate plane names, too many planes, a bad
            ``safety_mode``.
        InvalidGeometry: the active planes (with the bounds) leave an empty or thin set, or an
            unbounded one without ``bounds`` (the message says to give ``bounds``).
    """
    mode = check_choice("safety_mode", safety_mode, _SAFETY_MODES)
    box = _bounds("bounds", bounds)
    if isinstance(planes, (str, bytes, Mapping)) or not isinstance(planes, (Sequence, np.ndarray)):
        raise InvalidParameter(f"planes: expected a list of plane mappings, got {_type(planes)}")
    if not 1 <= len(planes) <= MAX_PLANES:
        raise InvalidParameter(f"planes: expected 1 to {MAX_PLANES} planes, got {len(planes)}")
    parsed = [_plane(i, entry) for i, entry in enumerate(planes)]
    seen: dict[str, int] = {}
    for i, p in enumerate(parsed):
        if p.name in seen:
            raise InvalidParameter(
                f"planes[{i}].name: duplicate name {p.name!r} (also planes[{seen[p.name]}])"
            )
        seen[p.name] = i
    live = ("both", mode)
    active = [p for p in parsed if p.mode in live]
    tool = [p for p in active if p.restrict in ("tool", "both")]
    elbow = [p for p in active if p.restrict in ("elbow", "both")]
    return PlaneZones(
        tcp=_point_set("tcp", tool, box),
        elbow=_point_set("elbow", elbow, box),
        planes=tuple(parsed),
        active=tuple(p.name for p in active),
        ignored=tuple(p.name for p in parsed if p.mode not in live),
        safety_mode=mode,
    )


def load_ur_safety_planes(
    path: str | Path, *, bounds: Any = None, safety_mode: SafetyMode = "normal"
) -> PlaneZones:
    """Safety planes from a YAML file (format in ``docs/zones.md``).

    The file holds ``safety_planes:`` (the list :func:`ur_safety_planes` takes) and optionally
    ``bounds: {lower: [x, y, z], upper: [x, y, z]}`` [m].

    Args:
        path: The YAML file.
        bounds: A closing box that replaces the file's ``bounds`` (as in
            :func:`ur_safety_planes`); ``None`` (default): the file's, if any.
        safety_mode: ``"normal"`` (default) or ``"reduced"`` (see :func:`ur_safety_planes`).

    Returns:
        The :class:`PlaneZones`.

    Raises:
        InvalidParameter: the file is missing, too large, not UTF-8 or not plain YAML, or a field
            is wrong (the message names the file and the field).
        InvalidGeometry: as :func:`ur_safety_planes`, prefixed with the file's name.
    """
    p, data = _read_yaml(path)
    if not isinstance(data, Mapping) or "safety_planes" not in data:
        keys = sorted(map(str, data)) if isinstance(data, Mapping) else []
        got = f"keys {keys}" if isinstance(data, Mapping) else _type(data)
        hint = next((h for k in keys if (h := did_you_mean(k, ("safety_planes",)))), "")
        raise InvalidParameter(
            f"safety planes file {p}: expected a mapping with a 'safety_planes' list, got {got}"
            + hint
        )
    unknown = sorted(str(k) for k in data if k not in ("safety_planes", "bounds"))
    if unknown:
        raise InvalidParameter(
            f"safety planes file {p}: unknown key(s) {unknown}; expected safety_planes, bounds"
            + did_you_mean(unknown[0], ("safety_planes", "bounds"))
        )
    if bounds is None and "bounds" in data:
        bounds = _mapping(f"safety planes file {p}: bounds", data["bounds"])
    listed = data["safety_planes"]
    if not isinstance(listed, list):  # named by the file's key, not ur_safety_planes' argument
        raise InvalidParameter(
            f"safety planes file {p}: safety_planes: expected a list of plane mappings, got "
            f"{_type(listed)}"
        )
    try:
        return ur_safety_planes(data["safety_planes"], bounds=bounds, safety_mode=safety_mode)
    except (InvalidParameter, InvalidGeometry) as exc:
        raise type(exc)(f"safety planes file {p}: {exc}") from None


# ---------------------------------------------------------------------------- Nav2

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_PAIR = rf"\[\s*({_NUM})\s*,\s*({_NUM})\s*\]"
_POINTS_TEXT = re.compile(rf"\s*\[\s*(?:{_PAIR}\s*(?:,\s*{_PAIR}\s*)*)?\]\s*")
_PAIR_RE = re.compile(_PAIR)


def _polygon_names(root: Mapping[Any, Any]) -> Sequence[Any]:
    """The ``polygons`` list of a collision monitor's parameters, checked (not yet each name)."""
    names = root.get("polygons")
    if isinstance(names, str) or not isinstance(names, Sequence) or not names:
        raise InvalidParameter(
            f"polygons: expected a non-empty list of polygon names, got {_type(names)}"
        )
    if len(names) > MAX_POLYGONS:
        raise InvalidParameter(f"polygons: expected at most {MAX_POLYGONS} names, got {len(names)}")
    return names


def _nav2_corners(where: str, value: Any) -> FloatArray:
    """Corners (k, 2) of a Nav2 ``points`` value: string, flat list or list of pairs."""
    if isinstance(value, str):
        if len(value) > _MAX_POINTS_TEXT:
            raise InvalidParameter(
                f"{where}: expected at most {_MAX_POINTS_TEXT:,} characters, got {len(value):,}"
            )
        if not _POINTS_TEXT.fullmatch(value):
            raise InvalidParameter(
                f'{where}: expected a string of [x, y] pairs like "[[0.3, 0.3], [0.3, -0.3], '
                f'[0.0, 0.0]]", got {show(value, 60)}'
            )
        pairs = [(float(a), float(b)) for a, b in _PAIR_RE.findall(value)]
        c = np.array(pairs, dtype=float).reshape(-1, 2)
    elif isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, bytes):
        if len(value) > 2 * _MAX_CORNERS:
            raise InvalidParameter(f"{where}: expected at most {_MAX_CORNERS} corners")
        a = real_array(where, value, error=InvalidParameter, what="corner coordinates [m]")
        if a.ndim == 1:  # Humble: [x1, y1, x2, y2, ...]
            if a.size % 2:
                raise InvalidParameter(
                    f"{where}: expected an even number of coordinates (x1, y1, x2, y2, ...), "
                    f"got {a.size}"
                )
            c = a.reshape(-1, 2)
        elif a.ndim == 2 and a.shape[1] == 2:
            c = a
        else:
            raise InvalidParameter(
                f"{where}: expected [x1, y1, x2, y2, ...] or [[x, y], ...], got shape {a.shape}"
            )
    else:
        raise InvalidParameter(
            f'{where}: expected a string "[[x, y], ...]" or a list of numbers, got {_type(value)}'
        )
    if not 3 <= c.shape[0] <= _MAX_CORNERS:
        raise InvalidParameter(f"{where}: expected 3 to {_MAX_CORNERS} corners, got {c.shape[0]}")
    if not np.all(np.isfinite(c)) or np.any(np.abs(c) > _MAX_COORD):
        raise InvalidParameter(
            f"{where}: expected finite coordinates of magnitude <= {_MAX_COORD:g} [m]"
        )
    return c


def _circle(radius: float, sides: int) -> FloatArray:
    ang = 2.0 * np.pi * np.arange(sides) / sides
    return np.stack([radius * np.cos(ang), radius * np.sin(ang)], axis=1)


def _nav_zone(name: str, entry: Any, circle_sides: int | None) -> NavZone:
    where = f"polygon {name!r}"
    entry = _mapping(where, entry)
    kind = entry.get("type")
    if kind not in ("polygon", "circle"):
        more = ""
        if kind == "velocity_polygon":
            more = " (a velocity polygon switches shapes with the speed: import its sub-polygons)"
        raise InvalidParameter(
            f"{where}.type: expected 'polygon' or 'circle', got {show(kind, 40)}{more}"
        )
    action = entry.get("action_type")
    if action not in _ACTIONS:
        raise InvalidParameter(
            f"{where}.action_type: expected one of {list(_ACTIONS)}, got {show(action, 40)}"
        )
    enabled = entry.get("enabled", True)
    if not isinstance(enabled, bool):
        raise InvalidParameter(f"{where}.enabled: expected true or false, got {_type(enabled)}")
    radius: float | None = None
    if kind == "polygon":
        if "points" not in entry:
            dyn = next((k for k in ("footprint_topic", "polygon_sub_topic") if k in entry), None)
            more = f" (its shape comes from the topic {dyn}: not a static zone)" if dyn else ""
            raise InvalidParameter(f"{where}.points: missing{more}")
        corners = _nav2_corners(f"{where}.points", entry["points"])
    else:
        if "radius" not in entry:
            raise InvalidParameter(f"{where}.radius: missing (a circle needs a radius [m])")
        radius = _number(f"{where}.radius", entry["radius"], "m")
        if radius <= 0:
            raise InvalidGeometry(f"{where}.radius: expected a radius > 0 [m], got {radius!r}")
        if circle_sides is None:
            raise InvalidGeometry(
                f"{where} is a circle: velfence fences are polygons; pass circle_sides=k to use "
                f"the inscribed regular k-gon (it lies inside the circle, at most "
                f"r (1 - cos(π/k)) from it), or leave this polygon out"
            )
        corners = _circle(radius, circle_sides)
    try:
        polygon = ConvexPolygon(corners)
    except InvalidGeometry as exc:
        raise InvalidGeometry(f"{where}: {exc}") from None
    shape: Literal["polygon", "circle"] = "polygon" if kind == "polygon" else "circle"
    return NavZone(name, polygon, action, shape, enabled, radius)


def _monitor_params(params: Mapping[Any, Any], node: str | None) -> Mapping[Any, Any]:
    """The parameter mapping holding ``polygons``, found in a ROS 2 parameter file's layout."""
    if node is not None:
        if node not in params:
            raise InvalidParameter(
                f"node: {node!r} is not in the parameters (top-level keys: "
                f"{sorted(map(str, params))[:10]})"
            )
        inner = _mapping(node, params[node])
        inner = inner.get("ros__parameters", inner)
        return _mapping(f"{node}.ros__parameters", inner)
    if "polygons" in params:
        return params
    if "ros__parameters" in params:
        return _mapping("ros__parameters", params["ros__parameters"])
    found = [
        k
        for k, v in params.items()
        if isinstance(v, Mapping)
        and isinstance(v.get("ros__parameters"), Mapping)
        and "polygons" in v["ros__parameters"]
    ]
    if len(found) == 1:
        return _mapping(f"{found[0]}.ros__parameters", params[found[0]]["ros__parameters"])
    if not found:
        raise InvalidParameter(
            "params: no 'polygons' list found (expected the collision_monitor node's parameters: "
            "collision_monitor: {ros__parameters: {polygons: [...], ...}}, or the inner mapping)"
        )
    raise InvalidParameter(
        f"params: several nodes have polygons ({sorted(map(str, found))}); choose one with node="
    )


def nav2_polygons(
    params: Mapping[str, Any],
    *,
    node: str | None = None,
    circle_sides: int | None = None,
) -> tuple[NavZone, ...]:
    """Nav2 collision-monitor polygons as convex polygons, one per entry of ``polygons``.

    Nav2's polygons are zones in the robot's frame (``base_frame_id``) that stop or slow the
    robot when sensor points (obstacles) fall inside them; they are not fences the robot stays
    inside. The import keeps their geometry and ``action_type`` (``docs/zones.md`` describes the
    uses that fit velfence).

    Args:
        params: The parsed parameter file (``{collision_monitor: {ros__parameters: {...}}}``),
            the ``ros__parameters`` mapping, or any mapping holding ``polygons``.
        node: The node whose parameters to read, when the file has several; ``None`` (default):
            the only one with ``polygons``.
        circle_sides: For ``type: circle`` entries: the number of sides (3 to
            :data:`MAX_CIRCLE_SIDES`) of the inscribed regular polygon that replaces the circle;
            ``None`` (default) refuses circles.

    Returns:
        One :class:`NavZone` per name in ``polygons``, in that order.

    Raises:
        InvalidParameter: no ``polygons`` list, a listed polygon without an entry, a missing or
            malformed field (``polygon 'Name'.points: ...``), an unknown ``type`` or
            ``action_type``, a dynamic polygon (shape from a topic).
        InvalidGeometry: a non-convex, self-intersecting or degenerate polygon (named), or a
            circle without ``circle_sides``.
    """
    if circle_sides is not None:
        circle_sides = check_positive_int(
            "circle_sides", circle_sides, maximum=MAX_CIRCLE_SIDES, example=16
        )
        if circle_sides < 3:
            raise InvalidParameter(f"circle_sides: expected at least 3 sides, got {circle_sides}")
    if node is not None and (not isinstance(node, str) or not node):
        raise InvalidParameter(f"node: expected a node name (a string), got {_type(node)}")
    root = _monitor_params(_mapping("params", params), node)
    names = _polygon_names(root)
    zones = []
    for i, name in enumerate(names):
        label = _text(f"polygons[{i}]", name)
        if label not in root:
            raise InvalidParameter(
                f"polygons[{i}]: {label!r} is listed but has no entry (expected '{label}: "
                "{type: polygon, points: ..., action_type: ...}')"
            )
        zones.append(_nav_zone(label, root[label], circle_sides))
    return tuple(zones)


def load_nav2_polygons(
    path: str | Path, *, node: str | None = None, circle_sides: int | None = None
) -> tuple[NavZone, ...]:
    """Nav2 collision-monitor polygons from a ROS 2 parameter YAML file.

    Args:
        path: The parameter file (``collision_monitor: {ros__parameters: {...}}``).
        node: The node to read (see :func:`nav2_polygons`).
        circle_sides: Sides of the polygon inscribed in a circle (see :func:`nav2_polygons`).

    Returns:
        One :class:`NavZone` per listed polygon.

    Raises:
        InvalidParameter: the file is missing, too large, not UTF-8 or not plain YAML, or a field
            is wrong (the message names the file, the polygon and the field).
        InvalidGeometry: as :func:`nav2_polygons`, prefixed with the file's name.
    """
    p, data = _read_yaml(path)
    if not isinstance(data, Mapping):
        raise InvalidParameter(f"parameter file {p}: expected a mapping, got {_type(data)}")
    try:
        return nav2_polygons(data, node=node, circle_sides=circle_sides)
    except (InvalidParameter, InvalidGeometry) as exc:
        raise type(exc)(f"parameter file {p}: {exc}") from None


def nav2_file_polygons(
    path: Path, *, node: str | None
) -> tuple[Path, Mapping[Any, Any], list[str]]:
    """The parameters holding ``polygons`` in a Nav2 parameter file, and the listed names.

    Internal API of :mod:`velfence.io` (a ``zone: {nav2: ...}`` config entry picks one polygon by
    name; :func:`nav2_zone` builds it, so the file's other polygons, circles included, are not
    built).

    Args:
        path: The parameter file.
        node: The node whose parameters to read (see :func:`nav2_polygons`), or ``None``.

    Returns:
        The file's path, the mapping holding ``polygons``, and the names it lists.

    Raises:
        InvalidParameter: as :func:`load_nav2_polygons` for the file and the ``polygons`` list
            (the message names the file).
    """
    p, data = _read_yaml(path)
    try:
        if node is not None and (not isinstance(node, str) or not node):
            raise InvalidParameter(f"node: expected a node name (a string), got {_type(node)}")
        root = _monitor_params(_mapping("params", data), node)
        names = _polygon_names(root)
        listed = [_text(f"polygons[{i}]", name) for i, name in enumerate(names)]
    except InvalidParameter as exc:
        raise InvalidParameter(f"parameter file {p}: {exc}") from None
    return p, root, listed


def nav2_zone(p: Path, root: Mapping[Any, Any], name: str, *, circle_sides: int | None) -> NavZone:
    """One listed polygon of a Nav2 parameter file (internal API; see :func:`nav2_file_polygons`).

    Args:
        p: The file's path (for messages).
        root: The mapping holding ``polygons`` (from :func:`nav2_file_polygons`).
        name: A name the file lists.
        circle_sides: Sides of the polygon inscribed in a circle (see :func:`nav2_polygons`).

    Returns:
        The polygon.

    Raises:
        InvalidParameter: the listed polygon has no entry, or a malformed field (named).
        InvalidGeometry: a non-convex or degenerate polygon, or a circle without
            ``circle_sides`` (named).
    """
    try:
        if name not in root:
            raise InvalidParameter(
                f"polygons: {name!r} is listed but has no entry (expected '{name}: "
                "{type: polygon, points: ..., action_type: ...}')"
            )
        return _nav_zone(name, root[name], circle_sides)
    except (InvalidParameter, InvalidGeometry) as exc:
        raise type(exc)(f"parameter file {p}: {exc}") from None


def nav2_points(polygon: ConvexPolygon) -> str:
    """A polygon's corners as a Nav2 ``points`` string (the Iron and later form).

    Args:
        polygon: A :class:`~velfence.geometry.polygon.ConvexPolygon` [m].

    Returns:
        ``"[[x0, y0], [x1, y1], ...]"`` with every coordinate written with ``repr`` (exact
        round trip through :func:`nav2_polygons`).

    Raises:
        InvalidGeometry: ``polygon`` is not a ``ConvexPolygon``.
    """
    if not isinstance(polygon, ConvexPolygon):
        raise InvalidGeometry(f"polygon: expected a ConvexPolygon, got {_type(polygon)}")
    return "[" + ", ".join(f"[{x!r}, {y!r}]" for x, y in polygon.corners.tolist()) + "]"


document_inits(globals())
