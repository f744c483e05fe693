"""A shaper from a validated ``shaper:`` section of a YAML file (the bridge and bag replay use it).

One section builds one of four shapers; every field has a type, a unit and a range, unknown keys
are refused, and a bad value raises :class:`~velfence.errors.InvalidParameter` naming the field
(``shaper.corners: ...``), before anything runs. The file is read by the same narrow YAML reader as
:func:`velfence.apps.demo.config.load_config` (:func:`load_yaml`). Format (``docs/config.md``)::

    shaper:
      kind: polygon              # 2-D fence: state (x, y) [m], command (vx, vy) [m/s]
      corners: [[0, 0], [4, 0], [4, 3], [0, 3]]
      buffer: 0.5                # [m]
      spring_gain: 1.0           # [1/s]
      method: exact              # or edge-scaling (US 8,676,382 as written; alias patent)

    shaper:
      kind: polytope             # n-D point: lower/upper box, or half-spaces n·x >= offset
      lower: [0, 0, 0]
      upper: [1, 1, 1]
      buffer: 0.1

    shaper:
      kind: joint_limits         # joint positions [rad], joint velocity commands [rad/s]
      joint_names: [j1, j2]
      lower: [-1.0, -2.0]
      upper: [1.0, 2.0]
      buffer: 0.1

    shaper:
      kind: safety_filter        # a shipped arm (velfence[physics]) with its joint limits
      robot: panda               # panda | ur5e | puma560 | seven_dof
      mode: twist                # twist: TCP velocity in [m/s] -> joint velocities; joint: joints
      max_speed: 2.0             # [rad/s], scalar or one per joint (max_velocity: deprecated)
      workspace: {lower: [0.3, -0.3, 0.2], upper: [0.7, 0.3, 0.6], buffer: 0.05}
      dt: 0.002                  # control period [s]

``method`` is optional in every section and, when given, is the ``.method`` the built shaper
reports (:data:`SHAPER_METHODS`), or ``patent``, the documented alias of ``edge-scaling``.

A fence may come from a vendor's zone file (:data:`ZONE_FILES`, read by :mod:`velfence.io.zones`):
``zone:`` in place of a polygon's ``corners``, of a polytope's box or half-spaces, or of a safety
filter workspace's box. A relative path is read from ``base_dir`` (the config file's folder)::

    shaper:
      kind: polygon              # one polygon of a Nav2 collision-monitor parameter file
      zone: {nav2: collision_monitor.yaml, polygon: FrontStop}   # node, circle_sides: optional
      buffer: 0.1

    shaper:
      kind: safety_filter
      robot: ur5e
      max_speed: 1.0
      dt: 0.002
      workspace:                 # UR style safety planes: the set of the workspace's point
        zone: {ur_safety_planes: cell.yaml}   # point: tcp | elbow, safety_mode: normal | reduced
        buffer: 0.05
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from velfence._extras import missing

try:
    from pydantic import Field, Strict, ValidationError, field_validator, model_validator
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._deprecate import method_name, warn_renamed
from velfence._docs import document_inits
from velfence._validate import MAX_PATH_LENGTH, show
from velfence.errors import InvalidParameter, VelfenceError
from velfence.io.config import (
    MAX_CORNERS,
    MIN_BUFFER,
    MIN_DT,
    NonNegative,
    Number,
    Positive,
    StrictModel,
    describe_validation_error,
)
from velfence.io.yaml_reader import did_you_mean, file_path, read_yaml

__all__ = [
    "COMMAND_SPACES",
    "MAX_JOINTS",
    "ROBOTS",
    "SHAPER_KINDS",
    "SHAPER_METHODS",
    "ZONE_FILES",
    "ConfiguredShaper",
    "SensorTopic",
    "load_yaml",
    "parse_shaper",
]

#: The ``kind`` values of a ``shaper:`` section.
SHAPER_KINDS: tuple[str, ...] = ("polygon", "polytope", "joint_limits", "safety_filter")
#: The ``method`` values of each kind: exactly the ``.method`` its shaper reports
#: (``PolygonShaper``: ``exact`` or ``edge-scaling``, ``PolytopeShaper``: ``exact``,
#: ``SafetyFilter``: ``safety-filter``); ``patent`` is also accepted for a polygon, as the alias
#: ``PolygonShaper`` keeps of ``edge-scaling``.
SHAPER_METHODS: dict[str, tuple[str, ...]] = {
    "polygon": ("exact", "edge-scaling"),
    "polytope": ("exact",),
    "joint_limits": ("exact",),
    "safety_filter": ("safety-filter",),
}
#: What a configured shaper's command means (:attr:`ConfiguredShaper.command_space`).
COMMAND_SPACES: tuple[str, ...] = ("plane", "workspace", "joint", "twist")
#: The shipped arms a ``safety_filter`` section may name (``velfence.robots``).
ROBOTS: tuple[str, ...] = ("panda", "ur5e", "puma560", "seven_dof")
#: Most joints (or dimensions) a section may have.
MAX_JOINTS = 64

#: The vendor zone files a ``zone:`` entry may name (``docs/zones.md``): a Nav2 collision-monitor
#: parameter file (one polygon of it) and a Universal Robots style safety-plane file.
ZONE_FILES: tuple[str, ...] = ("nav2", "ur_safety_planes")

Buffer = Annotated[float, Strict(), Field(ge=MIN_BUFFER, le=1e6, description="buffer width")]
Vector = Annotated[list[Number], Field(min_length=1, max_length=MAX_JOINTS)]
Speeds = Positive | Annotated[list[Positive], Field(min_length=1, max_length=MAX_JOINTS)]


ZonePath = Annotated[str, Strict(), Field(min_length=1, max_length=MAX_PATH_LENGTH)]
ZoneName = Annotated[str, Strict(), Field(min_length=1, max_length=200)]


class _Zone(StrictModel):
    """``zone:``: a set read from a vendor zone file (a path relative to the config file)."""

    nav2: ZonePath | None = None
    ur_safety_planes: ZonePath | None = None
    polygon: ZoneName | None = None
    node: ZoneName | None = None
    circle_sides: Annotated[int, Strict(), Field(ge=3, le=360)] | None = None
    point: Literal["tcp", "elbow"] | None = None
    safety_mode: Literal["normal", "reduced"] | None = None

    @field_validator("nav2", "ur_safety_planes")
    @classmethod
    def _no_nul(cls, value: str | None) -> str | None:
        if value is not None and "\x00" in value:
            raise ValueError("expected a file path without NUL characters")
        return value

    @model_validator(mode="after")
    def _one_file(self) -> _Zone:
        if (self.nav2 is None) == (self.ur_safety_planes is None):
            raise ValueError(
                "give one zone file: nav2 (a Nav2 collision-monitor parameter file, with polygon: "
                "its name) or ur_safety_planes (a safety-plane file)"
            )
        own = ("polygon", "node", "circle_sides") if self.nav2 else ("point", "safety_mode")
        other = [
            k
            for k in ("polygon", "node", "circle_sides", "point", "safety_mode")
            if k not in own and getattr(self, k) is not None
        ]
        if other:
            fmt = "nav2" if self.nav2 else "ur_safety_planes"
            raise ValueError(
                f"{', '.join(other)}: not a field of a {fmt} zone (its fields: "
                f"{', '.join((fmt, *own))})"
            )
        return self


class _Polygon(StrictModel):
    kind: Literal["polygon"]
    corners: (
        Annotated[list[tuple[Number, Number]], Field(min_length=3, max_length=MAX_CORNERS)] | None
    ) = None
    zone: _Zone | None = None
    buffer: Buffer
    spring_gain: NonNegative = 1.0
    method: Literal["exact", "edge-scaling", "patent"] = "exact"
    max_recovery_speed: Positive | None = None

    @model_validator(mode="after")
    def _one_form(self) -> _Polygon:
        if (self.corners is None) == (self.zone is None):
            raise ValueError(
                "give corners, or zone (a polygon of a Nav2 file): one of them"
                if self.corners is None
                else "give either corners or zone (a Nav2 polygon), not both"
            )
        if self.zone is not None and self.zone.nav2 is None:
            raise ValueError(
                "zone: a polygon shaper's fence is 2-D; a ur_safety_planes file gives 3-D sets "
                "(use kind: polytope, or a safety_filter's workspace)"
            )
        return self


class _Polytope(StrictModel):
    kind: Literal["polytope"]
    lower: Vector | None = None
    upper: Vector | None = None
    halfspaces: (
        Annotated[
            list[Annotated[list[Number], Field(min_length=2, max_length=MAX_JOINTS + 1)]],
            Field(min_length=1, max_length=MAX_CORNERS),
        ]
        | None
    ) = None
    zone: _Zone | None = None
    buffer: Buffer
    spring_gain: NonNegative = 1.0
    method: Literal["exact"] = "exact"

    @model_validator(mode="after")
    def _one_form(self) -> _Polytope:
        box = self.lower is not None or self.upper is not None
        if box + (self.halfspaces is not None) + (self.zone is not None) != 1:
            raise ValueError(
                "give either lower and upper (a box), halfspaces or zone (a vendor zone file): "
                "one of them"
            )
        if box and (self.lower is None or self.upper is None):
            raise ValueError("a box needs both lower and upper")
        if box and len(self.lower or ()) != len(self.upper or ()):
            raise ValueError(
                f"lower and upper must have one length, got {len(self.lower or ())} and "
                f"{len(self.upper or ())}"
            )
        if self.halfspaces is not None and len({len(r) for r in self.halfspaces}) != 1:
            raise ValueError("every halfspaces row must have the same length (n normals + offset)")
        return self


class _JointLimits(StrictModel):
    kind: Literal["joint_limits"]
    joint_names: Annotated[list[str], Field(min_length=1, max_length=MAX_JOINTS)]
    lower: Vector
    upper: Vector
    buffer: Buffer
    spring_gain: NonNegative = 1.0
    method: Literal["exact"] = "exact"

    @model_validator(mode="after")
    def _lengths(self) -> _JointLimits:
        n = len(self.joint_names)
        if len(set(self.joint_names)) != n:
            raise ValueError(f"joint_names must be distinct, got {self.joint_names}")
        if len(self.lower) != n or len(self.upper) != n:
            raise ValueError(
                f"lower and upper need one value per joint ({n}), got {len(self.lower)} and "
                f"{len(self.upper)}"
            )
        return self


class _Workspace(StrictModel):
    lower: Annotated[list[Number], Field(min_length=3, max_length=3)] | None = None
    upper: Annotated[list[Number], Field(min_length=3, max_length=3)] | None = None
    zone: _Zone | None = None
    buffer: Buffer
    point: str = "tcp"

    @model_validator(mode="after")
    def _one_form(self) -> _Workspace:
        box = self.lower is not None or self.upper is not None
        if box == (self.zone is not None):
            raise ValueError(
                "give either lower and upper (a box) or zone (a safety-plane file), not both"
                if box
                else "give lower and upper (a box), or zone (a safety-plane file)"
            )
        if box and (self.lower is None or self.upper is None):
            raise ValueError("a box needs both lower and upper")
        if self.zone is not None and self.zone.nav2 is not None:
            raise ValueError(
                "zone: a Nav2 polygon is 2-D; an arm's workspace is 3-D (use ur_safety_planes, "
                "or lower and upper)"
            )
        return self


class _SafetyFilter(StrictModel):
    kind: Literal["safety_filter"]
    robot: Literal["panda", "ur5e", "puma560", "seven_dof"]
    mode: Literal["joint", "twist"] = "twist"
    max_speed: Speeds | None = None
    max_velocity: Speeds | None = None  # the old name of max_speed (warns until 0.3)
    workspace: _Workspace | None = None
    dt: Annotated[float, Strict(), Field(ge=MIN_DT, le=1.0, description="control period [s]")]
    joint_buffer: Buffer = 0.1
    spring_gain: NonNegative = 1.0
    method: Literal["safety-filter"] = "safety-filter"

    @field_validator("method", mode="before")
    @classmethod
    def _former_method(cls, value: Any) -> Any:
        # "velfence" was the twist mode's .method before 0.2 (warns until 0.3)
        return method_name(value, what="shaper value of method", stacklevel=2)

    @model_validator(mode="after")
    def _one_speed(self) -> _SafetyFilter:
        if self.max_velocity is not None:
            if self.max_speed is not None:
                raise ValueError(
                    "max_speed and max_velocity are two names of one limit; give max_speed only"
                )
            warn_renamed("shaper key", "max_velocity", "max_speed", stacklevel=2)
            object.__setattr__(self, "max_speed", self.max_velocity)
            object.__setattr__(self, "max_velocity", None)
        if self.max_speed is None:
            raise ValueError("max_speed: missing (joint speed limits [rad/s])")
        return self


class SensorTopic(StrictModel):
    """A range sensor feeding a safety filter (an entry of ``bridge.sensors``/``replay.sensors``).

    Each entry gets its own :class:`~velfence.filter.PointCloudRows` in the filter
    (``docs/point_clouds.md``, "From ROS messages").

    Attributes:
        topic: The sensor's topic.
        type: ``point_cloud2`` (``sensor_msgs/msg/PointCloud2``) or ``laser_scan``
            (``sensor_msgs/msg/LaserScan``).
        base_frame: The robot's base frame (the frame of its links): each message's
            ``header.frame_id`` is transformed into it through ``/tf`` and ``/tf_static``; an
            empty ``frame_id`` means this frame. A message in a frame no transform reaches is
            dropped and counted.
        max_age: A message whose stamp is older than this [s] when it arrives is dropped and
            counted (stale).
        voxel: The voxel edge [m].
        decay: A voxel not seen for this long [s] is forgotten.
        buffer: The obstacle rows' buffer [m].
        spring_gain: The obstacle rows' recovery gain [1/s].
        nearest: Voxels per link that get rows.
        self_margin: Voxels this close [m] to a link's surface are the robot (default the
            voxel's half diagonal).
        max_points: The largest message accepted (points or readings).
    """

    topic: Annotated[str, Strict(), Field(min_length=1, max_length=255)]
    type: Literal["point_cloud2", "laser_scan"]
    base_frame: Annotated[str, Strict(), Field(min_length=1, max_length=255)] = "base_link"
    max_age: Annotated[float, Strict(), Field(allow_inf_nan=False, gt=0, le=3600.0)] = 0.5
    voxel: Annotated[float, Strict(), Field(allow_inf_nan=False, ge=1e-4, le=10.0)] = 0.02
    decay: Annotated[float, Strict(), Field(allow_inf_nan=False, gt=0, le=3600.0)] = 0.5
    buffer: Annotated[float, Strict(), Field(allow_inf_nan=False, ge=MIN_BUFFER, le=10.0)] = 0.05
    spring_gain: Positive = 1.0
    nearest: Annotated[int, Strict(), Field(ge=1, le=10_000)] = 8
    self_margin: Annotated[float, Strict(), Field(allow_inf_nan=False, ge=0, le=10.0)] | None = None
    max_points: Annotated[int, Strict(), Field(ge=1, le=10_000_000)] = 10_000_000


_MODELS: dict[str, type[StrictModel]] = {
    "polygon": _Polygon,
    "polytope": _Polytope,
    "joint_limits": _JointLimits,
    "safety_filter": _SafetyFilter,
}


@dataclass(frozen=True, eq=False)
class ConfiguredShaper:
    """A shaper built from a ``shaper:`` section, with what a transport needs to know about it.

    Attributes:
        kind: One of :data:`SHAPER_KINDS`.
        shaper: The shaper (``shape(p, v)``, ``explain(p, v)`` with ``.output`` and ``.zone``).
        state_dim: Length of the state ``p`` it reads (a point, or joint positions).
        command_dim: Length of the command ``v``.
        output_dim: Length of the shaped output (joint velocities in twist mode).
        command_space: One of :data:`COMMAND_SPACES`: ``"plane"`` (x, y [m/s]), ``"workspace"``
            (an n-D point's velocity), ``"joint"`` (joint velocities [rad/s]) or ``"twist"``
            (the TCP's linear velocity [m/s], output joint velocities).
        joint_names: The joints, in the order of the state, for joint-space shapers; else None.
        clouds: A safety filter's point-cloud row providers, one per sensor given to
            :func:`parse_shaper` (``sensors=``), in that order; else empty.
    """

    kind: str
    shaper: Any
    state_dim: int
    command_dim: int
    output_dim: int
    command_space: str
    joint_names: tuple[str, ...] | None
    clouds: tuple[Any, ...] = ()


def load_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML file as a mapping, read by :func:`~velfence.io.yaml_reader.read_yaml`'s narrow reader.

    Anchors, aliases, merge keys, duplicate keys, date/binary/set tags, ``.nan``/``.inf`` are
    refused with their line; the file is at most ``MAX_FILE_BYTES`` of UTF-8.

    Args:
        path: The file.

    Returns:
        The top-level mapping (an empty file gives ``{}``).

    Raises:
        InvalidParameter: a missing, oversized, non-UTF-8 or non-plain-YAML file, or one whose
            top level is not a mapping with string keys.
    """
    p = file_path(path)
    loaded = read_yaml(p)
    if loaded is None:
        return {}
    if not isinstance(loaded, dict):
        raise InvalidParameter(
            f"config file {p} must hold a mapping of fields, got {type(loaded).__name__}"
        )
    odd = [k for k in loaded if not isinstance(k, str)]
    if odd:
        raise InvalidParameter(f"config file {p}: expected string keys, got {odd[0]!r}")
    return loaded


def parse_shaper(
    section: Mapping[str, Any],
    *,
    where: str = "shaper",
    sensors: Sequence[SensorTopic] = (),
    base_dir: str | Path | None = None,
) -> ConfiguredShaper:
    """Validate a ``shaper:`` section and build its shaper (module docs for the format).

    Args:
        section: The section's mapping (e.g. ``load_yaml(path)["shaper"]``).
        where: How the section is named in messages (``"shaper"``, ``"bridge.yaml: shaper"``).
        sensors: Range sensors (validated :class:`SensorTopic` entries) whose points the
            filter keeps the arm out of: one :class:`~velfence.filter.PointCloudRows` each,
            in :attr:`ConfiguredShaper.clouds`; only a ``safety_filter`` shaper takes them.
        base_dir: The folder a relative ``zone:`` file path is read from: the config file's
            folder (the bridge and replay loaders pass it); ``None`` (default): the current
            directory.

    Returns:
        The shaper and what it reads and writes.

    Raises:
        InvalidParameter: a missing or unknown ``kind``, an unknown key, a field of the wrong type
            or range (named ``<where>.<field>``), geometry that does not close (named), a robot
            whose extra is not installed, sensors given to another kind of shaper, a ``zone:``
            file that is missing or malformed or lacks the named polygon (named with the file).
    """
    if not isinstance(where, str) or not where or len(where) > 200 or "\n" in where:
        got = f"{len(where)} characters" if isinstance(where, str) else type(where).__name__
        raise InvalidParameter(f"where: expected a short one-line name, got {got}")
    base = _base_dir(base_dir)
    if not isinstance(section, Mapping):
        raise InvalidParameter(
            f"section {where}: expected a mapping with a 'kind' ({', '.join(SHAPER_KINDS)}), "
            f"got {type(section).__name__}"
        )
    odd = [k for k in section if not isinstance(k, str)]
    if odd:
        raise InvalidParameter(
            f"section {where}: expected string keys, got a {type(odd[0]).__name__} key"
        )
    kind = section.get("kind")
    if not isinstance(kind, str) or kind not in SHAPER_KINDS:
        got = repr(kind)[:60] if isinstance(kind, str) else type(kind).__name__
        raise InvalidParameter(
            f"section {where}.kind: expected one of {list(SHAPER_KINDS)}, got {got}"
        )
    try:
        spec = _MODELS[kind].model_validate(dict(section))
    except ValidationError as err:
        text = describe_validation_error(err, _MODELS[kind])
        top = "(top level): "
        if text.startswith(top):
            raise InvalidParameter(f"section {where}: {text.removeprefix(top)}") from None
        raise InvalidParameter(f"section {where}.{text}") from None
    if not isinstance(sensors, (list, tuple)) or not all(
        isinstance(x, SensorTopic) for x in sensors
    ):
        raise InvalidParameter("sensors: expected a list of SensorTopic entries")
    if sensors and not isinstance(spec, _SafetyFilter):
        raise InvalidParameter(
            f"section {where}.kind: range sensors feed a safety filter's obstacle rows; "
            f"kind {kind!r} has none (use kind: safety_filter, or give no sensors)"
        )
    try:
        zone = _spec_zone(spec, base)
    except VelfenceError as exc:  # the message starts with the key: zone.nav2: ...
        raise InvalidParameter(f"section {where}.{exc}") from None
    try:
        if isinstance(spec, _SafetyFilter):
            return _safety_filter(spec, tuple(sensors), zone)
        return _build(spec, zone)
    except VelfenceError as exc:  # e.g. InvalidGeometry of corners that do not close
        raise InvalidParameter(f"section {where}: {exc}") from None


def _base_dir(base_dir: Any) -> Path | None:
    if base_dir is None:
        return None
    if isinstance(base_dir, (str, os.PathLike)) and not isinstance(base_dir, bytes):
        try:
            text = os.fspath(base_dir)
        except Exception:  # a hostile __fspath__ is refused, not propagated
            text = None
        if isinstance(text, str) and text and "\x00" not in text and len(text) <= MAX_PATH_LENGTH:
            return Path(text)
    raise InvalidParameter(
        "base_dir: expected a folder (a non-empty str or pathlib.Path without NUL, at most "
        f"{MAX_PATH_LENGTH} characters) or None, got {show(base_dir, 60)}"
    )


def _zone_path(name: str, base: Path | None) -> Path:
    path = Path(name)
    return path if base is None or path.is_absolute() else base / path


def _spec_zone(spec: Any, base: Path | None) -> Any:
    """The set a section's ``zone:`` names (a polygon or a polytope), or None without one."""
    if isinstance(spec, (_Polygon, _Polytope)) and spec.zone is not None:
        return _zone_set(spec.zone, base, "zone", "tcp")
    if isinstance(spec, _SafetyFilter) and spec.workspace is not None:
        w = spec.workspace
        if w.zone is not None:
            point: str | None = w.zone.point
            if point is None and w.zone.ur_safety_planes is not None:
                if w.point not in ("tcp", "elbow"):
                    raise InvalidParameter(
                        f"workspace.zone.point: missing; a safety-plane file limits the tcp or the "
                        f"elbow and workspace.point is {w.point!r}: choose the set with point: tcp "
                        "or point: elbow"
                    )
                point = w.point
            return _zone_set(w.zone, base, "workspace.zone", point or "tcp")
    return None


def _zone_set(zone: _Zone, base: Path | None, key: str, point: str) -> Any:
    """A ``zone:`` entry's set (messages start with the key: ``zone.nav2: ...``).

    The named Nav2 polygon (a ConvexPolygon), or the safety planes' polytope of ``point``
    (``tcp`` or ``elbow``).
    """
    from velfence.io import zones

    if zone.nav2 is not None:
        try:
            p, root, names = zones.nav2_file_polygons(_zone_path(zone.nav2, base), node=zone.node)
        except VelfenceError as exc:
            raise InvalidParameter(f"{key}.nav2: {exc}") from None
        listed = ", ".join(names[:10]) + (", ..." if len(names) > 10 else "")
        name = zone.polygon
        if name is None:
            if len(names) != 1:
                raise InvalidParameter(
                    f"{key}.polygon: missing; parameter file {p} lists {len(names)} polygons "
                    f"({listed}): name one"
                )
            name = names[0]
        elif name not in names:
            raise InvalidParameter(
                f"{key}.polygon: {name!r} is not a polygon of parameter file {p} (its polygons: "
                f"{listed})" + did_you_mean(name, names)
            )
        entry = root.get(name)
        if (
            zone.circle_sides is None
            and isinstance(entry, Mapping)
            and entry.get("type") == "circle"
        ):
            raise InvalidParameter(
                f"{key}.circle_sides: missing; polygon {name!r} of parameter file {p} is a circle "
                "and velfence fences are polygons: give circle_sides: k for the inscribed regular "
                "k-gon (inside the circle, at most r (1 - cos(π/k)) from it)"
            )
        try:
            return zones.nav2_zone(p, root, name, circle_sides=zone.circle_sides).polygon
        except VelfenceError as exc:
            raise InvalidParameter(f"{key}.nav2: {exc}") from None
    assert zone.ur_safety_planes is not None  # one of the two (the model's check)
    path = _zone_path(zone.ur_safety_planes, base)
    try:
        planes = zones.load_ur_safety_planes(path, safety_mode=zone.safety_mode or "normal")
    except VelfenceError as exc:
        raise InvalidParameter(f"{key}.ur_safety_planes: {exc}") from None
    which = zone.point or point
    poly = planes.tcp if which == "tcp" else planes.elbow
    if poly is None:
        raise InvalidParameter(
            f"{key}.point: no active plane of safety planes file {path} limits the {which} in "
            f"{planes.safety_mode} mode (active planes: {', '.join(planes.active) or 'none'})"
        )
    return poly


def _build(spec: Any, zone: Any = None) -> ConfiguredShaper:
    import numpy as np

    from velfence.geometry.polygon import ConvexPolygon
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.shaping.polygon import PolygonShaper
    from velfence.shaping.polytope import PolytopeShaper

    if isinstance(spec, _Polygon):
        polygon_shaper = PolygonShaper(
            zone if zone is not None else ConvexPolygon(np.array(spec.corners, dtype=float)),
            buffer=spec.buffer,
            spring_gain=spec.spring_gain,
            method=spec.method,
            max_recovery_speed=spec.max_recovery_speed,
        )
        return ConfiguredShaper("polygon", polygon_shaper, 2, 2, 2, "plane", None)
    if isinstance(spec, _Polytope):
        if zone is not None:
            poly = zone if isinstance(zone, ConvexPolytope) else ConvexPolytope.from_polygon(zone)
        elif spec.halfspaces is not None:
            rows = np.array(spec.halfspaces, dtype=float)
            poly = ConvexPolytope(rows[:, :-1], rows[:, -1])
        else:
            poly = ConvexPolytope.box(np.array(spec.lower), np.array(spec.upper))
        shaper = PolytopeShaper(poly, buffer=spec.buffer, spring_gain=spec.spring_gain)
        n = poly.dim
        return ConfiguredShaper("polytope", shaper, n, n, n, "workspace", None)
    if isinstance(spec, _JointLimits):
        names = tuple(spec.joint_names)
        facets = [f"{j}_{side}" for j in names for side in ("min", "max")]
        poly = ConvexPolytope.box(np.array(spec.lower), np.array(spec.upper), facet_names=facets)
        shaper = PolytopeShaper(poly, buffer=spec.buffer, spring_gain=spec.spring_gain)
        n = len(names)
        return ConfiguredShaper("joint_limits", shaper, n, n, n, "joint", names)
    return _safety_filter(spec, (), zone)


def _safety_filter(
    spec: _SafetyFilter, sensors: tuple[SensorTopic, ...] = (), zone: Any = None
) -> ConfiguredShaper:
    import numpy as np

    from velfence import robots
    from velfence.filter import PointCloudRows, SafetyFilter
    from velfence.filter.limits import JointLimits, WorkspaceLimit
    from velfence.filter.twist import TwistMode
    from velfence.geometry.polytope import ConvexPolytope

    robot = getattr(robots, spec.robot)()
    n = int(robot.dof)
    if isinstance(spec.max_speed, list) and len(spec.max_speed) not in (1, n):
        raise InvalidParameter(
            f"max_speed: expected a scalar or {n} values (robot {spec.robot!r}), got "
            f"{len(spec.max_speed)}"
        )
    vmax = np.broadcast_to(np.asarray(spec.max_speed, dtype=float), (n,)).copy()
    lim = robot.joint_limits
    names = tuple(robot.joint_names)
    workspace: tuple[WorkspaceLimit, ...] = ()
    if spec.workspace is not None:
        w = spec.workspace
        workspace = (
            WorkspaceLimit(
                zone
                if zone is not None
                else ConvexPolytope.box(np.array(w.lower), np.array(w.upper)),
                point=w.point,
                buffer=w.buffer,
            ),
        )
    clouds = tuple(
        PointCloudRows(
            voxel=x.voxel,
            link_radius=robot.link_radius,
            max_speed=vmax,
            buffer=x.buffer,
            spring_gain=x.spring_gain,
            decay=x.decay,
            self_margin=x.self_margin,
            nearest=x.nearest,
            max_points=x.max_points,
        )
        for x in sensors
    )
    f = SafetyFilter(
        robot,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=vmax, names=names),
        workspace=workspace,
        dt=spec.dt,
        joint_buffer=spec.joint_buffer,
        spring_gain=spec.spring_gain,
        providers=clouds,
    )
    if spec.mode == "joint":
        return ConfiguredShaper("safety_filter", f, n, n, n, "joint", names, clouds)
    return ConfiguredShaper("safety_filter", TwistMode(f), n, 3, n, "twist", names, clouds)


document_inits(globals())
