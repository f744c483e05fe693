r"""Safety modes, mode zones, slowdown and time-to-collision zones as rows of the safety filter.

What a cobot's safety configuration and a mobile base's collision monitor offer, as row
providers of :class:`~velfence.filter.SafetyFilter` (``docs/modes.md``, derivations in
``docs/derivations.md``):

* **Modes** (:class:`SafetyMode`: ``normal``, ``reduced``, ``stop``), each with its speed limits
  (:class:`ModeLimits`: a joint-speed scale or per-joint caps [rad/s], Cartesian speed caps
  [m/s] on named points). ``stop`` holds every joint velocity at zero.
* **Mode zones** (:class:`ModeZone`): convex polytopes that switch the mode while a monitored
  point is inside; the strictest mode of every zone holding a point and every external request
  (:meth:`ModeRows.request`, a light curtain's input) wins. A stricter mode applies at once; a
  laxer one only once the point is ``exit_distance`` out of the zone (hysteresis) and the mode
  has lasted ``dwell`` seconds. :class:`ModeRows` keeps the state and logs every switch
  (:class:`ModeEvent`).
* **Slowdown zones** (:class:`SlowdownZone`, Nav2's ``slowdown``): the point's speed cap falls
  linearly from ``far_speed`` at ``distance`` from the zone to ``near_speed`` at the zone.
* **Time-to-collision zones** (:class:`ApproachZone`, Nav2's ``approach``): the point's approach
  speed toward the zone is at most ``d / time_to_collision``.

A Cartesian cap ``|J_p x| <= v`` is not linear; it becomes the rows ``d_i · J_p x <= v cos α``
for the unit directions ``d_i`` of :func:`speed_cap_directions` (26 in 3-D, 8 in the plane),
whose covering angle is ``α``: an inner approximation, so the point's speed never exceeds ``v``
and is cut by at most the factor ``cos α`` (0.886 in 3-D, 0.924 in the plane).

The mode's state changes only in :meth:`ModeRows.update` (once per control cycle, keyed on its
``time``) and :meth:`ModeRows.request`; the rows never change it, so :meth:`SafetyFilter.explain`,
:meth:`~SafetyFilter.filter_batch` or a second call in one cycle see the same state. The rows
still apply a zone the point is in at once, even before the next ``update``.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import KW_ONLY, dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    check_positive_int,
    check_text,
    describe,
    finite_scalar,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.kinematics import checked, frame_of
from velfence.filter.parts import check_robot, robot_frame
from velfence.filter.rows import (
    LEVEL_JOINT,
    LEVEL_OBSTACLE,
    LEVEL_WORKSPACE,
    RowBlock,
    RowContext,
)
from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "ApproachRows",
    "ApproachZone",
    "ModeEvent",
    "ModeLimits",
    "ModeRows",
    "ModeZone",
    "SafetyMode",
    "SlowdownRows",
    "SlowdownZone",
    "speed_cap_directions",
]


class SafetyMode(StrEnum):
    """The safety modes, laxest first: ``normal``, ``reduced``, ``stop``.

    A string enum: ``SafetyMode.REDUCED == "reduced"`` (the values ``velfence.io.zones`` uses
    for UR's safety modes). :attr:`rank` orders them; the strictest of several wins.
    """

    NORMAL = "normal"
    REDUCED = "reduced"
    STOP = "stop"

    @property
    def rank(self) -> int:
        """0 for ``normal``, 1 for ``reduced``, 2 for ``stop`` (higher is stricter)."""
        return _ORDER.index(self)

    @classmethod
    def _missing_(cls, value: object) -> SafetyMode:
        """``SafetyMode(value)`` of anything but a mode's value: :class:`InvalidParameter`."""
        raise InvalidParameter(
            f"mode: expected one of {[m.value for m in cls]}, got {describe(value)}"
        )


_ORDER = (SafetyMode.NORMAL, SafetyMode.REDUCED, SafetyMode.STOP)


def _mode(name: str, value: Any) -> SafetyMode:
    """A :class:`SafetyMode` from a member or its value (``"reduced"``)."""
    if isinstance(value, str):
        for m in _ORDER:
            if value == m.value:
                return m
    raise InvalidParameter(
        f"{name}: expected one of {[m.value for m in _ORDER]}, got {describe(value)}"
    )


# ------------------------------------------------------------------------- the cap directions
def _cube_directions() -> tuple[FloatArray, float]:
    """The 26 directions of a cube's faces, edges and corners, and ``cos α`` of their cover.

    The largest angle from any unit vector to the nearest direction is reached at the
    circumcentre of the spherical triangle (face, edge, corner) = ``(1,0,0)``, ``(1,1,0)/√2``,
    ``(1,1,1)/√3`` (every triangle of their convex hull is congruent to it).
    """
    g = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], float)
    g = g[np.any(g != 0.0, axis=1)]
    D = g / np.linalg.norm(g, axis=1)[:, None]
    a = np.array([1.0, 0.0, 0.0])
    b = np.array([1.0, 1.0, 0.0]) / math.sqrt(2.0)
    c = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
    centre = np.cross(b - a, c - a)
    centre /= np.linalg.norm(centre)
    return readonly(D), float(abs(centre @ a))


_DIRECTIONS: dict[int, tuple[FloatArray, float]] = {
    3: _cube_directions(),
    2: (
        readonly(
            np.stack([np.cos(np.arange(8) * math.pi / 4), np.sin(np.arange(8) * math.pi / 4)], 1)
        ),
        math.cos(math.pi / 8),
    ),
}


def speed_cap_directions(dim: int) -> tuple[FloatArray, float]:
    """The unit directions ``d_i`` of the Cartesian speed-cap rows and ``cos α`` of their cover.

    ``|w| <= v`` is approximated from inside by ``d_i · w <= v cos α`` for every ``i``, where
    ``α`` is the covering angle of the directions (every unit vector lies within ``α`` of one of
    them): then ``|w| cos α <= d_i · w <= v cos α`` for the nearest ``d_i``, so ``|w| <= v``;
    and every ``w`` with ``|w| <= v cos α`` passes (``docs/derivations.md``).

    Args:
        dim: The task dimension: 3 (the 26 directions of a cube's faces, edges and corners,
            ``α`` 27.6°, ``cos α`` 0.886) or 2 (8 directions 45° apart, ``α`` 22.5°, ``cos α``
            0.924).

    Returns:
        ``(D, cos_alpha)``: ``D`` read-only, shape (k, dim), unit rows; ``cos_alpha`` in (0, 1).

    Raises:
        InvalidParameter: ``dim`` not 2 or 3.
    """
    d = check_positive_int("dim", dim, minimum=2, maximum=3, example=3)
    return _DIRECTIONS[d]


def _cap_rows(J: FloatArray, speed: float, dim: int) -> tuple[FloatArray, FloatArray]:
    """The rows ``-(d_i · J) x >= -speed cos α`` of ``|J x| <= speed`` (inner approximation)."""
    D, cosa = _DIRECTIONS[dim]
    G: FloatArray = -(D @ J)
    return G, np.full(D.shape[0], -speed * cosa)


# ------------------------------------------------------------------------- records
def _speeds_map(value: Any) -> dict[str, float]:
    if not isinstance(value, Mapping):
        raise InvalidParameter(
            f"point_speeds: expected a mapping from point names to speeds [m/s], got "
            f"{describe(value)}"
        )
    out: dict[str, float] = {}
    for k, v in value.items():
        name = check_text("point_speeds key", k, max_length=200)
        out[name] = check_positive(f"point_speeds[{name!r}]", v, allow_zero=True, unit="m/s")
    return out


@dataclass(frozen=True)
class ModeLimits:
    """The speed limits of one safety mode.

    Attributes:
        joint_scale: Fraction in [0, 1] of the joints' speed limits (the ``max_speed`` given to
            :class:`ModeRows`) each joint may reach in this mode; default 1 (no extra cap).
        max_speed: Per-joint speed caps [rad/s], shape (n,), >= 0 (``inf``: no cap on that
            joint), or ``None`` (default: none).
        point_speeds: Cartesian speed caps [m/s] >= 0 of named points of the robot
            (``{"tcp": 0.25, "elbow": 0.5}``), default none.

    Raises:
        InvalidParameter: a scale outside [0, 1], a negative or NaN cap, or a speed map that is
            not point names to speeds >= 0.
    """

    _: KW_ONLY
    joint_scale: float = 1.0
    max_speed: FloatArray | None = None
    point_speeds: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        put = object.__setattr__
        s = check_positive("joint_scale", self.joint_scale, allow_zero=True)
        if s > 1.0:
            raise InvalidParameter(f"joint_scale: expected a fraction in [0, 1], got {s!r}")
        put(self, "joint_scale", s)
        if self.max_speed is not None:
            v = real_array(
                "max_speed", self.max_speed, (None,), error=InvalidParameter,
                what="joint speeds [rad/s]", allow_nonfinite=True,
            )  # fmt: skip
            if v.shape[0] == 0 or not bool(np.all(v >= 0.0)):  # NaN fails too
                raise InvalidParameter(
                    f"max_speed: expected joint speeds >= 0 [rad/s] (inf: no cap), got "
                    f"{describe(self.max_speed)}"
                )
            put(self, "max_speed", readonly(v))
        put(self, "point_speeds", _speeds_map(self.point_speeds))


def _polytope(name: str, value: Any) -> ConvexPolytope:
    if not isinstance(value, ConvexPolytope):
        raise InvalidParameter(f"{name}: expected a ConvexPolytope, got {describe(value)}")
    return value


def _points(name: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)) or not value:
        raise InvalidParameter(
            f"{name}: expected a non-empty list or tuple of point names, got {describe(value)}"
        )
    return tuple(check_text(f"{name}[{i}]", p, max_length=200) for i, p in enumerate(value))


@dataclass(frozen=True)
class ModeZone:
    """A convex zone of the workspace that puts the robot in a mode while a point is inside.

    Attributes:
        polytope: The zone (a :class:`~velfence.geometry.polytope.ConvexPolytope` in the robot's
            base frame [m], of the task dimension).
        mode: The mode while a monitored point is in the zone: ``"reduced"`` (default) or
            ``"stop"`` (``"normal"`` is accepted and changes nothing).
        name: The zone's name in events and row names, default ``"zone"``.
        points: The points this zone watches (names of the robot's points), or ``None``
            (default): every point :class:`ModeRows` monitors.

    Raises:
        InvalidParameter: a non-polytope, an unknown mode, a bad name or point list.
    """

    polytope: ConvexPolytope
    _: KW_ONLY
    mode: SafetyMode = SafetyMode.REDUCED
    name: str = "zone"
    points: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "polytope", _polytope("polytope", self.polytope))
        put(self, "mode", _mode("mode", self.mode))
        put(self, "name", check_text("name", self.name, max_length=200))
        if self.points is not None:
            put(self, "points", _points("points", self.points))


@dataclass(frozen=True)
class ModeEvent:
    """One switch of :class:`ModeRows`' mode.

    Attributes:
        time: When [s] (the ``time`` of the :meth:`ModeRows.update` or
            :meth:`ModeRows.request` that switched).
        previous: The mode before.
        mode: The mode after.
        cause: ``"zone"`` (a point entered a zone), ``"request"`` (an external request),
            ``"release"`` (a laxer mode once hysteresis and dwell allowed it).
        zone: The zone (or request source) that sets the new mode, or ``None`` (none: normal).
        point: The point in that zone, or ``None``.
    """

    time: float
    previous: SafetyMode
    mode: SafetyMode
    cause: str
    zone: str | None
    point: str | None


# ------------------------------------------------------------------------- the mode rows
def _robot_dim(robot: Any) -> tuple[int, int]:
    check_robot(robot)
    n = check_positive_int("robot.dof", robot.dof, maximum=1000, example=7)
    return n, robot_frame(robot, n)[1]


def _known_point(robot: Any, name: str, point: str) -> None:
    if point not in tuple(robot.points):
        raise InvalidParameter(
            f"{name}: point {point!r} is not one of the robot's points {list(robot.points)}"
        )


class ModeRows:
    r"""Safety modes with mode zones and external requests (level :data:`LEVEL_JOINT`).

    **State.** :attr:`mode` starts ``normal``. Each :meth:`update` (once per control cycle, with
    the cycle's ``time``; a second call with the same ``time`` changes nothing) measures every
    (zone, point) pair's signed distance ``s = max_i (o_i - n_i · p)`` (negative inside: minus
    the depth; positive outside: a lower bound of the distance to the zone) and latches it
    *in* when ``s <= -enter_depth`` and *out* when ``s > exit_distance`` (between the two it
    keeps its state: the hysteresis band). The target is the strictest mode of the pairs
    latched in and of the open requests (:meth:`request`). A stricter target switches at once;
    a laxer one only when the current mode has lasted ``dwell`` seconds. Every switch is a
    :class:`ModeEvent` in :attr:`history`.

    **Rows** (the mode of the state, or a stricter one at once when a point of the cycle's pose
    is in a zone by ``enter_depth``, even before the next :meth:`update`; the rows never change
    the state): in ``stop`` ``x_j >= 0`` and ``-x_j >= 0`` for every joint (the output is zero;
    the row names say which zone or request stopped the robot). Otherwise per joint
    ``|x_j| <= c_j`` with ``c_j`` the smaller of ``joint_scale`` times ``max_speed_j`` and the
    mode's own cap, and per capped point ``|J_p x| <= v`` as the rows
    ``-(d_i · J_p) x >= -v cos α`` (:func:`speed_cap_directions`). In ``reduced`` the caps are
    the smaller of the reduced and the normal ones: a stricter mode is never laxer anywhere.
    None of these rows is ever violated (zero meets them all), so the ladder never relaxes them:
    when a switch makes the current velocity too fast, the caps hold at once and the
    acceleration and jerk rows give way (``FilterResult.rate_override``).

    Args:
        robot: The robot's kinematics (the :class:`~velfence.filter.Kinematics` protocol; the
            filter's robot): :meth:`update` evaluates the points on it.
        modes: The limits of ``"normal"`` and ``"reduced"`` (:class:`ModeLimits`), a mapping
            from the mode (or its value) to its limits; a missing mode has no caps.
        zones: The mode zones (:class:`ModeZone`), default none.
        points: The points the zones watch (names of the robot's points), default ``("tcp",)``.
        max_speed: The joints' speed limits [rad/s], shape (n,), > 0, the base of
            ``joint_scale`` (the filter's ``JointLimits.max_speed``); ``None``: a
            ``joint_scale`` below 1 is refused.
        enter_depth: How far inside a zone a point must be to switch [m], >= 0; default 0: on the
            boundary (UR switches when the TCP crosses a trigger plane).
        exit_distance: How far outside a zone a point must be before the zone lets go [m],
            >= 0; default 0.02 (UR's 20 mm band around a trigger plane).
        dwell: Least time in a mode before a switch to a laxer one [s], >= 0; default 0.
        history: Most events kept in :attr:`history` (the oldest are dropped), default 1000.

    Raises:
        InvalidParameter: a robot without the protocol, an unknown point, a zone of another
            dimension, bad limits or margins.
    """

    level = LEVEL_JOINT
    label = "modes"

    def __init__(
        self,
        robot: Any,
        *,
        modes: Mapping[Any, ModeLimits] | None = None,
        zones: Sequence[ModeZone] = (),
        points: Sequence[str] = ("tcp",),
        max_speed: Any = None,
        enter_depth: float = 0.0,
        exit_distance: float = 0.02,
        dwell: float = 0.0,
        history: int = 1000,
    ) -> None:
        n, dim = _robot_dim(robot)
        self.robot = robot
        self._n = n
        self._dim = dim
        self.points = _points("points", points)
        for p in self.points:
            _known_point(robot, "points", p)
        base = None
        if max_speed is not None:
            base = real_array(
                "max_speed", max_speed, (n,), error=InvalidParameter, what="joint speeds [rad/s]"
            )
            if not bool(np.all(base > 0.0)):
                raise InvalidParameter(f"max_speed: expected joint speeds > 0, got {base.tolist()}")
            base = readonly(base)
        self.max_speed: FloatArray | None = base
        self.limits = self._limits(modes)
        self.zones = self._zones(zones)
        self.enter_depth = check_positive("enter_depth", enter_depth, allow_zero=True, unit="m")
        self.exit_distance = check_positive(
            "exit_distance", exit_distance, allow_zero=True, unit="m"
        )
        self.dwell = check_positive("dwell", dwell, allow_zero=True, unit="s")
        keep = check_positive_int("history", history, maximum=10**6, example=1000)
        # (zone, point) pairs, the polytopes' rows stacked per pair
        self._pairs = [
            (z, p) for z in self.zones for p in (z.points if z.points is not None else self.points)
        ]
        self._watched = tuple(dict.fromkeys(p for _z, p in self._pairs))
        self._caps = {m: self._mode_caps(m) for m in (SafetyMode.NORMAL, SafetyMode.REDUCED)}
        self._mode = SafetyMode.NORMAL
        self._cause: tuple[str | None, str | None] = (None, None)
        self._since = -math.inf
        self._time: float | None = None
        self._inside = [False] * len(self._pairs)
        self._requests: dict[str, SafetyMode] = {}
        self._history: deque[ModeEvent] = deque(maxlen=keep)
        self._switches = 0

    # ------------------------------------------------------------------ construction
    def _limits(self, modes: Any) -> dict[SafetyMode, ModeLimits]:
        out = {SafetyMode.NORMAL: ModeLimits(), SafetyMode.REDUCED: ModeLimits()}
        if modes is None:
            return out
        if not isinstance(modes, Mapping):
            raise InvalidParameter(
                f"modes: expected a mapping from 'normal'/'reduced' to ModeLimits, got "
                f"{describe(modes)}"
            )
        for key, lim in modes.items():
            m = _mode("modes key", key)
            if m is SafetyMode.STOP:
                raise InvalidParameter("modes: 'stop' has fixed limits (every joint at rest)")
            if not isinstance(lim, ModeLimits):
                raise InvalidParameter(
                    f"modes[{m.value!r}]: expected ModeLimits, got {describe(lim)}"
                )
            if lim.max_speed is not None and lim.max_speed.shape[0] != self._n:
                raise InvalidParameter(
                    f"modes[{m.value!r}].max_speed: expected {self._n} joint speeds, got "
                    f"{lim.max_speed.shape[0]}"
                )
            if lim.joint_scale < 1.0 and self.max_speed is None:
                raise InvalidParameter(
                    f"modes[{m.value!r}].joint_scale: a scale below 1 needs the joints' "
                    "max_speed (ModeRows(max_speed=...))"
                )
            for p in lim.point_speeds:
                _known_point(self.robot, f"modes[{m.value!r}].point_speeds", p)
            out[m] = lim
        return out

    def _zones(self, zones: Any) -> tuple[ModeZone, ...]:
        if isinstance(zones, (str, bytes)) or not isinstance(zones, (list, tuple)):
            raise InvalidParameter(
                f"zones: expected a list or tuple of ModeZone, got {describe(zones)}"
            )
        for i, z in enumerate(zones):
            if not isinstance(z, ModeZone):
                raise InvalidParameter(f"zones[{i}]: expected a ModeZone, got {describe(z)}")
            if z.polytope.dim != self._dim:
                raise InvalidParameter(
                    f"zones[{i}]: the polytope of {z.name!r} is {z.polytope.dim}-D, the robot's "
                    f"task space is {self._dim}-D"
                )
            for p in z.points or ():
                _known_point(self.robot, f"zones[{i}].points", p)
        return tuple(zones)

    def _mode_caps(self, mode: SafetyMode) -> tuple[FloatArray, tuple[tuple[str, float], ...]]:
        """``(joint caps (n,) with inf for none, ((point, speed), ...))`` of a mode."""
        modes = (SafetyMode.NORMAL,) if mode is SafetyMode.NORMAL else (SafetyMode.NORMAL, mode)
        caps = np.full(self._n, math.inf)
        pts: dict[str, float] = {}
        for m in modes:
            lim = self.limits[m]
            if self.max_speed is not None and lim.joint_scale < 1.0:
                caps = np.minimum(caps, lim.joint_scale * self.max_speed)
            if lim.max_speed is not None:
                caps = np.minimum(caps, lim.max_speed)
            for p, v in lim.point_speeds.items():
                pts[p] = min(pts.get(p, math.inf), v)
        return readonly(caps), tuple(pts.items())

    # ------------------------------------------------------------------ state
    @property
    def mode(self) -> SafetyMode:
        """The current mode (of the last :meth:`update` or :meth:`request`)."""
        return self._mode

    @property
    def cause(self) -> tuple[str | None, str | None]:
        """``(zone or request source, point)`` that holds the current mode; ``(None, None)``."""
        return self._cause

    @property
    def history(self) -> tuple[ModeEvent, ...]:
        """The last switches, oldest first (at most ``history`` of them)."""
        return tuple(self._history)

    @property
    def switches(self) -> int:
        """How many switches there were in all (``history`` keeps the last ones)."""
        return self._switches

    @property
    def time(self) -> float | None:
        """The ``time`` of the last :meth:`update` [s], or ``None`` before the first."""
        return self._time

    def _signed(self, pos: Mapping[str, FloatArray]) -> list[float]:
        """``s`` of every (zone, point) pair: the largest distance outside a facet [m]."""
        out = []
        for z, p in self._pairs:
            P = z.polytope
            out.append(float(np.max(P.offsets - P.normals @ pos[p])))
        return out

    def _positions(self, frame: Any) -> dict[str, FloatArray]:
        return {
            p: checked(f"kinematics(q).point({p!r})", frame.point(p), (self._dim,))
            for p in self._watched
        }

    def _switch(self, mode: SafetyMode, t: float, cause: str, src: tuple[Any, Any]) -> None:
        self._history.append(ModeEvent(t, self._mode, mode, cause, src[0], src[1]))
        self._switches += 1
        self._mode = mode
        self._since = t

    def _target(self) -> tuple[SafetyMode, tuple[str | None, str | None]]:
        best = SafetyMode.NORMAL
        src: tuple[str | None, str | None] = (None, None)
        for k, (z, p) in enumerate(self._pairs):
            if self._inside[k] and z.mode.rank > best.rank:
                best, src = z.mode, (z.name, p)
        for name, m in self._requests.items():
            if m.rank > best.rank:
                best, src = m, (name, None)
        return best, src

    def update(self, position: Any, *, time: float) -> SafetyMode:
        """Advance the state by one control cycle; the mode after it.

        Call once per cycle before the filter (a second call with the same ``time`` is the same
        cycle and changes nothing). The filter's rows read the state; they never change it.

        Args:
            position: Joint position [rad], shape (n,), finite.
            time: The cycle's time [s] (any clock, the caller's), finite, not before the
                previous call's.

        Returns:
            The mode after this cycle.

        Raises:
            InvalidInput: a bad ``position``, a bad or earlier ``time``, or a kinematics answer
                that is not finite.
        """
        t = finite_scalar("time", time, unit="s", error=InvalidInput)
        q = real_array("position", position, (self._n,), what=f"{self._n} joint angles [rad]")
        if self._time is not None:
            if t < self._time:
                raise InvalidInput(
                    f"time: expected a time >= the previous update's {self._time!r} s, got {t!r}"
                )
            if t == self._time:
                return self._mode
        s = self._signed(self._positions(frame_of(self.robot, q))) if self._pairs else []
        for k, sk in enumerate(s):
            if sk <= -self.enter_depth:
                self._inside[k] = True
            elif sk > self.exit_distance:
                self._inside[k] = False
        self._time = t
        self._settle(t)
        return self._mode

    def _settle(self, t: float) -> None:
        target, src = self._target()
        if target.rank > self._mode.rank:
            self._switch(target, t, "zone" if src[1] is not None else "request", src)
            self._cause = src
        elif target.rank < self._mode.rank and t - self._since >= self.dwell:
            self._switch(target, t, "release", src)
            self._cause = src
        elif target is self._mode:
            self._cause = src

    def request(self, mode: Any, *, source: str = "external") -> SafetyMode:
        """An external request (a light curtain, a safety input): ``mode`` until released.

        The strictest of the zones and the open requests wins, as for the zones: a request
        stricter than the current mode applies now; ``request("normal", source=...)`` releases
        ``source``'s request, and the mode relaxes at the next :meth:`update` that the dwell
        allows.

        Args:
            mode: ``"normal"`` (release), ``"reduced"`` or ``"stop"`` (or a :class:`SafetyMode`).
            source: Who asks (its name in events), default ``"external"``.

        Returns:
            The mode after the request.

        Raises:
            InvalidParameter: an unknown mode or a source that is not a string.
        """
        m = _mode("mode", mode)
        src = check_text("source", source, max_length=200)
        if m is SafetyMode.NORMAL:
            self._requests.pop(src, None)
        else:
            self._requests[src] = m
        if m.rank > self._mode.rank:
            t = self._time if self._time is not None else 0.0
            self._switch(m, t, "request", (src, None))
            self._cause = (src, None)
        return self._mode

    # ------------------------------------------------------------------ rows
    def _effective(self, frame: Any) -> tuple[SafetyMode, str]:
        """The state's mode, or a stricter one of a zone a point of ``frame`` is in now."""
        mode = self._mode
        src = self._cause
        if self._pairs and mode is not SafetyMode.STOP:
            for k, sk in enumerate(self._signed(self._positions(frame))):
                z, p = self._pairs[k]
                if sk <= -self.enter_depth and z.mode.rank > mode.rank:
                    mode, src = z.mode, (z.name, p)
        if src[0] is None:
            return mode, f"mode {mode.value}"
        where = f"zone {src[0]!r} at {src[1]}" if src[1] is not None else f"request {src[0]!r}"
        return mode, f"mode {mode.value} ({where})"

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The caps of the cycle's mode (joint speeds and point speeds), or ``None``."""
        n = self._n
        if ctx.q.shape[0] != n:
            raise InvalidInput(
                f"robot: ModeRows was built for {n} joints, the cycle has {ctx.q.shape[0]}"
            )
        mode, why = self._effective(ctx.frame)
        eye = np.eye(n)
        if mode is SafetyMode.STOP:
            G = np.empty((2 * n, n))
            G[0::2] = eye
            G[1::2] = -eye
            keys = np.arange(2 * n, dtype=np.int64)
            return RowBlock(G, np.zeros(2 * n), np.zeros(2 * n, bool), keys, _namer(why, keys, ()))
        caps, pts = self._caps[mode]
        js = np.flatnonzero(np.isfinite(caps))
        blocks_G = []
        blocks_b = []
        keys_l = []
        if js.shape[0]:
            Gj = np.empty((2 * js.shape[0], n))
            Gj[0::2] = eye[js]
            Gj[1::2] = -eye[js]
            blocks_G.append(Gj)
            blocks_b.append(-np.repeat(caps[js], 2))
            keys_l.append(np.stack([2 * js, 2 * js + 1], 1).ravel())
        labels = []
        for i, (p, v) in enumerate(pts):
            J = checked(f"kinematics(q).jacobian({p!r})", ctx.frame.jacobian(p), (self._dim, n))
            G, b = _cap_rows(J, v, self._dim)
            blocks_G.append(G)
            blocks_b.append(b)
            keys_l.append(2 * n + 64 * i + np.arange(b.shape[0]))
            labels.append((p, v, b.shape[0]))
        if not blocks_G:
            return None
        keys = np.concatenate(keys_l).astype(np.int64)
        b_all = np.concatenate(blocks_b)
        return RowBlock(
            np.vstack(blocks_G), b_all, np.zeros(b_all.shape[0], bool), keys,
            _namer(why, keys[: 2 * js.shape[0]], labels),
        )  # fmt: skip


def _namer(
    why: str, joint_keys: Any, points: Sequence[tuple[str, float, int]]
) -> Callable[[], list[str]]:
    def names() -> list[str]:
        out = [
            f"{why}: joint {k // 2} speed ({'lower' if k % 2 == 0 else 'upper'})"
            for k in joint_keys.tolist()
        ]
        for p, v, k in points:
            out += [f"{why}: {p} speed <= {v:g} m/s, direction {i}" for i in range(k)]
        return out

    return names


# ------------------------------------------------------------------------- slowdown
@dataclass(frozen=True)
class SlowdownZone:
    """A zone near which a point slows down (Nav2's ``slowdown``, as a distance ramp).

    The point's speed cap at distance ``d`` from the zone (0 inside)::

        v(d) = near_speed + (far_speed - near_speed) d / distance     for d < distance

    and no cap from ``distance`` on.

    Attributes:
        polytope: The zone [m], of the task dimension.
        far_speed: The cap at ``distance`` from the zone [m/s], >= ``near_speed``.
        near_speed: The cap at and inside the zone [m/s], >= 0.
        distance: Width of the band where the cap ramps [m], > 0.
        point: The slowed point (a name of the robot's points), default ``"tcp"``.
        name: The zone's name in row names, default ``"slowdown"``.

    Raises:
        InvalidParameter: a non-polytope, speeds not ``0 <= near_speed <= far_speed``, a bad
            distance, point or name.
    """

    polytope: ConvexPolytope
    _: KW_ONLY
    far_speed: float
    near_speed: float
    distance: float
    point: str = "tcp"
    name: str = "slowdown"

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "polytope", _polytope("polytope", self.polytope))
        near = check_positive("near_speed", self.near_speed, allow_zero=True, unit="m/s")
        far = check_positive("far_speed", self.far_speed, allow_zero=True, unit="m/s")
        if far < near:
            raise InvalidParameter(
                f"far_speed: expected a speed >= near_speed ({near!r} m/s), got {far!r}"
            )
        put(self, "near_speed", near)
        put(self, "far_speed", far)
        put(self, "distance", check_positive("distance", self.distance, unit="m"))
        put(self, "point", check_text("point", self.point, max_length=200))
        put(self, "name", check_text("name", self.name, max_length=200))

    def speed_cap(self, distance: float) -> float:
        """The cap [m/s] at ``distance`` [m] from the zone (<= 0: inside); ``inf`` beyond the band.

        Raises:
            InvalidInput: a ``distance`` that is not a finite number.
        """
        d = finite_scalar("distance", distance, unit="m", error=InvalidInput)
        return self._cap(d)

    def _cap(self, d: float) -> float:
        if d >= self.distance:
            return math.inf
        d = max(d, 0.0)
        return self.near_speed + (self.far_speed - self.near_speed) * (d / self.distance)


def _zone_list(name: str, zones: Any, kind: type, robot: Any, dim: int) -> tuple[Any, ...]:
    if isinstance(zones, (str, bytes)) or not isinstance(zones, (list, tuple)):
        raise InvalidParameter(
            f"{name}: expected a list or tuple of {kind.__name__}, got {describe(zones)}"
        )
    for i, z in enumerate(zones):
        if not isinstance(z, kind):
            raise InvalidParameter(f"{name}[{i}]: expected a {kind.__name__}, got {describe(z)}")
        z = zones[i]  # (typed Any again)
        _known_point(robot, f"{name}[{i}].point", z.point)
        if z.polytope.dim != dim:
            raise InvalidParameter(
                f"{name}[{i}]: the polytope of {z.name!r} is {z.polytope.dim}-D, the robot's task "
                f"space is {dim}-D"
            )
    return tuple(zones)


def _outside(P: ConvexPolytope, p: FloatArray) -> float:
    """A lower bound of the distance from ``p`` to ``P`` [m] (0 inside): the largest facet gap."""
    return max(float(np.max(P.offsets - P.normals @ p)), 0.0)


class SlowdownRows:
    r"""Slowdown zones: each point's speed cap falls as it nears its zone (level workspace).

    For every :class:`SlowdownZone` whose point is nearer than its ``distance``: the exact
    distance ``d`` (:meth:`~velfence.geometry.polytope.ConvexPolytope.closest_point`; 0 inside)
    gives the cap ``v(d)`` and the rows ``-(d_i · J_p) x >= -v(d) cos α``
    (:func:`speed_cap_directions`, key ``64 z + i``). The cap holds for the whole period; the
    point moves at most ``v(d) dt`` nearer in one, so the next cycle's cap is that much lower.
    Never violated (zero meets every row).

    Args:
        robot: The robot's kinematics (the points and the task dimension are checked on it).
        zones: The slowdown zones (:class:`SlowdownZone`).

    Raises:
        InvalidParameter: a robot without the protocol, a zone that is not a ``SlowdownZone``,
            an unknown point or a polytope of another dimension.
    """

    level = LEVEL_WORKSPACE
    label = "slowdown"

    def __init__(self, robot: Any, zones: Sequence[SlowdownZone]) -> None:
        n, dim = _robot_dim(robot)
        self._n = n
        self._dim = dim
        self.zones = _zone_list("zones", zones, SlowdownZone, robot, dim)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The caps of the zones within their band."""
        n = self._n
        Gs, bs, keys, labels = [], [], [], []
        for zi, z in enumerate(self.zones):
            p = checked(f"kinematics(q).point({z.point!r})", ctx.frame.point(z.point), (self._dim,))
            if _outside(z.polytope, p) >= z.distance:
                continue  # the true distance is at least this lower bound
            inside = bool(np.all(z.polytope.normals @ p >= z.polytope.offsets))
            d = 0.0 if inside else float(np.linalg.norm(p - z.polytope.closest_point(p)))
            v = z._cap(d)
            if v == math.inf:
                continue
            J = checked(
                f"kinematics(q).jacobian({z.point!r})", ctx.frame.jacobian(z.point), (self._dim, n)
            )
            G, b = _cap_rows(J, v, self._dim)
            Gs.append(G)
            bs.append(b)
            keys.append(64 * zi + np.arange(b.shape[0]))
            labels.append((z.name, z.point, v, d, b.shape[0]))
        if not Gs:
            return None

        def names() -> list[str]:
            out = []
            for zn, pt, v, d, k in labels:
                out += [
                    f"slowdown {zn!r} on {pt} ({d:.3f} m): speed <= {v:.3f} m/s, direction {i}"
                    for i in range(k)
                ]
            return out

        b_all = np.concatenate(bs)
        return RowBlock(
            np.vstack(Gs), b_all, np.zeros(b_all.shape[0], bool),
            np.concatenate(keys).astype(np.int64), names,
        )  # fmt: skip


# ------------------------------------------------------------------------- time to collision
@dataclass(frozen=True)
class ApproachZone:
    """A zone a point must not reach sooner than ``time_to_collision`` (Nav2's ``approach``).

    Attributes:
        polytope: The zone [m] (an obstacle, a keep-out volume), of the task dimension.
        time_to_collision: ``T`` [s], > 0: at the current velocity the point reaches the zone
            no sooner than ``T`` (choose ``T`` above the control period).
        point: The point (a name of the robot's points), default ``"tcp"``.
        name: The zone's name in row names, default ``"approach"``.

    Raises:
        InvalidParameter: a non-polytope, a bad time, point or name.
    """

    polytope: ConvexPolytope
    _: KW_ONLY
    time_to_collision: float
    point: str = "tcp"
    name: str = "approach"

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "polytope", _polytope("polytope", self.polytope))
        put(
            self,
            "time_to_collision",
            check_positive("time_to_collision", self.time_to_collision, unit="s"),
        )
        put(self, "point", check_text("point", self.point, max_length=200))
        put(self, "name", check_text("name", self.name, max_length=200))


class ApproachRows:
    r"""Time-to-collision zones as rows (level :data:`LEVEL_OBSTACLE`).

    For every :class:`ApproachZone` (key: its index): the point ``p`` outside the zone, its
    closest point ``c`` on the zone, the distance ``d = |p - c|`` and the unit direction
    ``n = (p - c) / d``; the row caps the approach speed::

        (nᵀ J_p) x >= -d / T

    The distance to a convex set is a convex function of the position, so along the straight
    path of the current velocity it stays above its tangent ``d + t nᵀ ṗ >= d (1 - t / T)``: the
    zone is at least ``T`` away at that velocity (``docs/derivations.md``). A point already in
    the zone gets the row "no deeper" through its nearest facet (bound 0, flagged violated).

    Args:
        robot: The robot's kinematics (the points and the task dimension are checked on it).
        zones: The zones (:class:`ApproachZone`).

    Raises:
        InvalidParameter: a robot without the protocol, a zone that is not an ``ApproachZone``,
            an unknown point or a polytope of another dimension.
    """

    level = LEVEL_OBSTACLE
    label = "approach"

    def __init__(self, robot: Any, zones: Sequence[ApproachZone]) -> None:
        n, dim = _robot_dim(robot)
        self._n = n
        self._dim = dim
        self.zones = _zone_list("zones", zones, ApproachZone, robot, dim)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """One row per zone."""
        n = self._n
        k = len(self.zones)
        if k == 0:
            return None
        G = np.empty((k, n))
        b = np.empty(k)
        viol = np.zeros(k, bool)
        dist = []
        for zi, z in enumerate(self.zones):
            P = z.polytope
            p = checked(f"kinematics(q).point({z.point!r})", ctx.frame.point(z.point), (self._dim,))
            J = checked(
                f"kinematics(q).jacobian({z.point!r})", ctx.frame.jacobian(z.point), (self._dim, n)
            )
            sd = P.normals @ p - P.offsets
            if bool(np.all(sd >= 0.0)):  # inside: leave through the nearest facet, no deeper
                f = int(np.argmin(sd))
                nrm = -P.normals[f]
                b[zi] = 0.0
                viol[zi] = True
                dist.append(-float(sd[f]))
            else:
                c = P.closest_point(p)
                r = p - c
                d = float(np.linalg.norm(r))
                nrm = r / d if d > 0.0 else -P.normals[int(np.argmin(sd))]
                b[zi] = -d / z.time_to_collision
                dist.append(d)
            G[zi] = nrm @ J
        zones = self.zones

        def names() -> list[str]:
            return [
                f"approach {z.name!r} on {z.point} ({d:.3f} m, T {z.time_to_collision:g} s)"
                for z, d in zip(zones, dist, strict=True)
            ]

        return RowBlock(G, b, viol, np.arange(k, dtype=np.int64), names, distance=np.array(dist))


document_inits(globals())
