r"""Scripted operators: what a simulated user commands, ``command(t, p) -> v``.

An operator is a callable ``command(t, p) -> v`` (workspace units per second; for an arm, ``p``
is the joint position and ``v`` a point's Cartesian velocity). The waypoint operator
(:class:`WaypointOperator`, on a :class:`Script`) heads for the current target at up to the
waypoint's speed, slowing linearly inside ``speed / gain`` of it; targets placed beyond the
boundary make it push into edges and corners. :class:`TcpJog` is the same law in 3-D on any
forward kinematics: :math:`v = \min(s, g\,\|e\|)\,e/\|e\|`, :math:`e = x^\star(t) - x(q)`.
:func:`constant` commands one velocity.

The demo's built-in scripts are the applications' (:mod:`velfence.apps.demo.script`,
:mod:`velfence.apps.demo.arm_box`); ``default_script`` here still works until 0.3 with a warning.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from velfence import _lazy
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, finite_scalar, real_array, show
from velfence.errors import InvalidParameter

__all__ = [
    "Script",
    "TcpJog",
    "Waypoint",
    "WaypointOperator",
    "constant",
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


class TcpJog:
    r"""A scripted Cartesian jog ``(t, q) -> v``: towards the target of the phase in force.

    :math:`v = \min(s, g\,\|e\|)\,e/\|e\|` with :math:`e = x^\star(t) - x(q)`: the jog speed
    ``s`` far from the target, a proportional approach (gain ``g``) near it. Phase ``k`` is in
    force while ``t < t_end[k]`` (after the last end, the last target holds); a target may lie
    outside the permitted region, which makes the jog press against its boundary.

    Args:
        fk: Forward kinematics of the jogged point, ``q -> x`` [m], shape (3,) (a
            :meth:`DHChain.end_effector <velfence.mechanisms.DHChain.end_effector>`, a robot
            model's ``fk``).
        phases: ``(t_end [s], target (3,) [m])`` pairs, at least one, ``t_end`` finite and
            increasing.
        speed: Jog speed ``s`` [m/s], > 0.
        gain: Approach gain ``g`` near a target [1/s], > 0.

    Raises:
        InvalidParameter: ``fk`` not callable, phases empty or not ``(t_end, target)`` pairs in
            time order, or a speed or gain out of range.
    """

    def __init__(
        self,
        fk: Callable[[FloatArray], ArrayLike],
        phases: Sequence[tuple[float, ArrayLike]],
        *,
        speed: float,
        gain: float = 8.0,
    ) -> None:
        if not callable(fk) or isinstance(fk, type):
            raise InvalidParameter(f"fk: expected a function q -> x (3,), got {show(fk)}")
        given: object = phases
        if isinstance(given, (str, bytes)) or not isinstance(given, Sequence) or not given:
            raise InvalidParameter(
                f"phases: expected a non-empty list of (t_end, target), got {show(phases)}"
            )
        checked: list[tuple[float, FloatArray]] = []
        for k, phase in enumerate(phases):
            if not isinstance(phase, (tuple, list)) or len(phase) != 2:
                raise InvalidParameter(f"phases[{k}]: expected (t_end, target), got {show(phase)}")
            t_end = finite_scalar(f"phases[{k}] t_end", phase[0], unit="s", error=InvalidParameter)
            if checked and not t_end > checked[-1][0]:
                raise InvalidParameter(
                    f"phases[{k}] t_end: expected after {checked[-1][0]:g} s (time order), got "
                    f"{t_end:g} s"
                )
            target = real_array(
                f"phases[{k}] target", phase[1], (3,), error=InvalidParameter, what="a point [m]"
            )
            target.setflags(write=False)
            checked.append((t_end, target))
        self.fk = fk
        self.phases: tuple[tuple[float, FloatArray], ...] = tuple(checked)
        self.speed = check_positive("speed", speed, unit="m/s")
        self.gain = check_positive("gain", gain, unit="1/s")

    def target(self, t: float) -> FloatArray:
        """The target in force at time ``t`` [s], shape (3,), [m].

        Raises:
            InvalidInput: ``t`` not a finite number.
        """
        t = finite_scalar("t", t, unit="s", what="time")
        for t_end, x in self.phases:
            if t < t_end:
                return x
        return self.phases[-1][1]

    def __call__(self, t: float, q: FloatArray) -> FloatArray:
        """TCP velocity command [m/s], shape (3,), at time ``t`` [s] and joint position ``q``.

        Raises:
            InvalidInput: ``t`` not finite, or the kinematics giving no finite point (3,).
        """
        x = real_array("fk(q)", self.fk(q), (3,), what="the jogged point [m]")
        e = self.target(t) - x
        dist = math.sqrt(e.dot(e))  # np.linalg.norm's arithmetic for a vector
        if dist == 0.0:
            return np.zeros(3)
        return np.asarray(e * (min(self.speed, self.gain * dist) / dist), dtype=float)


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


#: The demo's built-in script moved to velfence.apps.demo.script in 0.2 (it is an application's).
__getattr__, _ = _lazy.attach(
    __name__, {}, globals(), former={"default_script": "velfence.apps.demo.script"}
)

document_inits(globals())
