"""Scripted operators and the built-in demo scenario.

An operator is a callable ``command(t, p) -> v`` (workspace units per second). The waypoint operator
heads for the current target at up to the waypoint's speed, slowing linearly inside
``speed / gain`` of it; targets placed beyond the boundary make it push into edges and corners,
which is what the demo needs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, finite_scalar, real_array, show
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon

__all__ = [
    "Script",
    "Waypoint",
    "WaypointOperator",
    "constant",
    "default_script",
    "operator_from",
]


def _pair(name: str, x: object, what: str) -> tuple[float, float]:
    a, b = real_array(name, x, (2,), error=InvalidParameter, what=what).tolist()
    return (a, b)


@dataclass(frozen=True, kw_only=True)
class Waypoint:
    """From time ``t`` [s] head for ``target`` (workspace units) at up to ``speed`` [units/s].

    Attributes:
        t: When the operator starts heading for this waypoint [s], >= 0.
        target: The point ``(x, y)`` to head for, workspace units.
        speed: The operator's speed towards it [units/s], > 0.

    Raises:
        InvalidParameter: ``t`` not a finite time >= 0, ``target`` not two finite numbers, or
            ``speed`` not finite and > 0.
    """

    t: float
    target: tuple[float, float]
    speed: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "t", check_positive("t", self.t, allow_zero=True, unit="s"))
        object.__setattr__(self, "target", _pair("target", self.target, "a target (x, y)"))
        object.__setattr__(self, "speed", check_positive("speed", self.speed, unit="units/s"))


@dataclass(frozen=True, kw_only=True)
class Script:
    """A scenario: start point, operator waypoints, disturbance pushes and duration.

    Attributes:
        start: The start point ``(x, y)``, workspace units.
        waypoints: The operator's :class:`Waypoint` entries, in time order.
        pushes: Disturbances ``(t0, t1, (vx, vy))``: from ``t0`` to ``t1`` [s] the point is
            pushed at ``(vx, vy)`` [units/s].
        duration: Length of the run [s], > 0.
        labels: Optional text labels for plots (default none).

    Raises:
        InvalidParameter: a field of the wrong kind (``start`` not two finite numbers, a
            waypoint that is not a :class:`Waypoint`, a push not ``(t0, t1, (vx, vy))``, a
            ``duration`` not finite and > 0, labels not strings).
    """

    start: tuple[float, float]
    waypoints: tuple[Waypoint, ...]
    pushes: tuple[tuple[float, float, tuple[float, float]], ...]  # (t0, t1, velocity)
    duration: float
    labels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _pair("start", self.start, "a start point (x, y)"))
        object.__setattr__(self, "waypoints", _waypoints(self.waypoints))
        if not isinstance(self.pushes, (tuple, list)):
            raise InvalidParameter(
                f"pushes: expected a tuple of (t0, t1, (vx, vy)), got {type(self.pushes).__name__}"
            )
        pushes = []
        for i, push in enumerate(self.pushes):
            if not isinstance(push, (tuple, list)) or len(push) != 3:
                raise InvalidParameter(
                    f"pushes[{i}]: expected (t0, t1, (vx, vy)), got {show(push)}"
                )
            t0 = check_positive(f"pushes[{i}] t0", push[0], allow_zero=True, unit="s")
            t1 = real_array(
                f"pushes[{i}] t1", push[1], (), error=InvalidParameter, allow_nonfinite=True
            )
            if not float(t1) > t0:
                raise InvalidParameter(
                    f"pushes[{i}]: expected t1 > t0 = {t0} s, got {show(push[1])}"
                )
            v = _pair(f"pushes[{i}] velocity", push[2], "a push velocity (vx, vy)")
            pushes.append((t0, float(t1), v))
        object.__setattr__(self, "pushes", tuple(pushes))
        object.__setattr__(self, "duration", check_positive("duration", self.duration, unit="s"))
        if not isinstance(self.labels, (tuple, list)) or not all(
            isinstance(x, str) for x in self.labels
        ):
            raise InvalidParameter(f"labels: expected a tuple of str, got {self.labels!r}")
        object.__setattr__(self, "labels", tuple(self.labels))


def _waypoints(waypoints: object) -> tuple[Waypoint, ...]:
    if not isinstance(waypoints, (tuple, list)) or not all(
        isinstance(w, Waypoint) for w in waypoints
    ):
        raise InvalidParameter(
            f"waypoints: expected a tuple of Waypoint, got {type(waypoints).__name__}; build "
            "them with Waypoint(t=..., target=..., speed=...)"
        )
    return tuple(waypoints)


class WaypointOperator:
    """A scripted operator following :class:`Waypoint` targets.

    Args:
        waypoints: In time order; the first must start at t = 0.
        gain: Proportional gain near the target [1/s].
    """

    def __init__(self, waypoints: tuple[Waypoint, ...], *, gain: float = 6.0) -> None:
        waypoints = _waypoints(waypoints)
        if not waypoints:
            raise InvalidParameter("an operator needs at least one waypoint, got none")
        self.waypoints = waypoints
        self.gain = check_positive("gain", gain, unit="1/s")
        self._times = [w.t for w in waypoints]

    def active(self, t: float) -> Waypoint:
        """The waypoint in force at time ``t`` [s].

        Raises:
            InvalidInput: ``t`` not a finite real number.
        """
        t = finite_scalar("t", t, unit="s", what="time")
        i = 0
        for k, tk in enumerate(self._times):
            if tk <= t:
                i = k
        return self.waypoints[i]

    def __call__(self, t: float, p: FloatArray) -> FloatArray:
        """Commanded velocity at time ``t`` [s] from position ``p`` (shape (2,)).

        Raises:
            InvalidInput: ``t`` not a finite real number, ``p`` not a finite (2,) position.
        """
        w = self.active(t)
        e = np.asarray(w.target, dtype=float) - real_array("p", p, (2,), what="a position")
        dist = math.hypot(e[0], e[1])
        speed = min(w.speed, self.gain * dist)
        if dist == 0.0:
            return np.zeros(2)
        return np.asarray(e * (speed / dist), dtype=float)


def default_script(polygon: ConvexPolygon, *, buffer: float) -> Script:
    """The built-in demo script, derived from the polygon's features.

    Phases, each long enough to travel its distance at its speed and then dwell: start outside the
    longest edge and come in; press into that edge and sweep along it; push into the most acute
    corner; push into the most obtuse corner; a fast move into the far side; hold near the long
    edge while an external push drives the mechanism outward, then let go.

    Args:
        polygon: The workspace (:class:`~velfence.geometry.polygon.ConvexPolygon`).
        buffer: The shaper's buffer width, workspace units, > 0 (sets the start and hold points).

    Raises:
        InvalidParameter: ``polygon`` not a polygon or ``buffer`` not finite and > 0.
    """
    polygon = as_polygon(polygon)
    buffer = check_positive("buffer", buffer, unit="workspace units")
    c = polygon.corners
    n = polygon.n
    cen = polygon.centroid
    size = float(np.max(np.linalg.norm(c - cen, axis=1)))
    lengths = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
    e = int(np.argmax(lengths))
    a, b = c[e], c[(e + 1) % n]
    normal = polygon.normals[e]
    start = 0.5 * (a + b) - 0.6 * buffer * normal
    ang = polygon.interior_angles
    acute = int(np.argmin(ang))
    obtuse = int(np.argmax(np.where(np.arange(n) == acute, -1.0, ang)))
    far = int(np.argmin(polygon.normals @ polygon.normals[obtuse - 1]))  # faces corner's edge

    def beyond_corner(i: int) -> FloatArray:
        d = c[i] - cen
        return np.asarray(c[i] + 0.4 * size * d / np.linalg.norm(d), dtype=float)

    plan: list[tuple[str, FloatArray, float, float]] = [  # label, target, speed, dwell [s]
        ("start outside, come in", cen.copy(), 0.6, 0.2),
        ("press into the long edge", a + 0.3 * (b - a) - 0.4 * size * normal, 0.8, 0.4),
        ("sweep along it, pressing", a + 0.85 * (b - a) - 0.4 * size * normal, 0.7, 0.3),
        (f"push into acute corner {acute}", beyond_corner(acute), 0.6, 0.8),
        (f"push into obtuse corner {obtuse}", beyond_corner(obtuse), 0.6, 0.8),
        (
            "fast move into the far side",
            0.5 * (c[far] + c[(far + 1) % n]) - 0.4 * size * polygon.normals[far],
            2.0,
            0.4,
        ),
        ("hold near the long edge", 0.5 * (a + b) + 0.5 * buffer * normal, 0.6, 0.3),
    ]
    t = 0.0
    pos = np.asarray(start, dtype=float)
    wps = []
    for _label, target, speed, dwell in plan:
        wps.append(Waypoint(t=t, target=(float(target[0]), float(target[1])), speed=speed))
        reach = polygon.closest_point(target)
        t += float(np.linalg.norm(reach - pos)) / speed + dwell
        pos = reach
    push_v = -0.5 * normal
    pushes = ((t, t + 0.8, (float(push_v[0]), float(push_v[1]))),)
    return Script(
        start=(float(start[0]), float(start[1])),
        waypoints=tuple(wps),
        pushes=pushes,
        duration=t + 2.0,
        labels=tuple(p[0] for p in plan),
    )


def constant(
    velocity: tuple[float, float] | FloatArray,
) -> Callable[[float, FloatArray], FloatArray]:
    """An operator that always commands ``velocity`` (shape (2,), workspace units per second).

    Raises:
        InvalidParameter: ``velocity`` not two finite real numbers.
    """
    v = real_array("velocity", velocity, (2,), error=InvalidParameter, what="a velocity")
    v.setflags(write=False)

    def command(t: float, p: FloatArray) -> FloatArray:
        return v

    return command


def operator_from(script: Script) -> Callable[[float, FloatArray], FloatArray]:
    """The :class:`WaypointOperator` of a script.

    Raises:
        InvalidParameter: ``script`` is not a :class:`Script`.
    """
    if not isinstance(script, Script):
        raise InvalidParameter(f"script: expected a Script, got {type(script).__name__}")
    return WaypointOperator(script.waypoints)


document_inits(globals())
