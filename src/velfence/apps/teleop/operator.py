r"""A synthetic teleoperator for the Khokar 2009 study (§7.2).

The thesis's subjects (10, §7.2) are replaced by a model of a human driving a Phantom Omni while
watching the remote scene. It is built from standard motor-control ingredients; every number is a
**modelling choice** (the thesis reports no human data beyond "every subject was faster with
assistance", §7.2), drawn per subject from the ranges of :meth:`OperatorProfile.draw`:

* **Sub-movements.** A reach is a sequence of minimum-jerk strokes (Flash & Hogan), each aimed at
  the *perceived* remaining error (perception noise ``perception`` [m]) and landing with an
  endpoint error proportional to its amplitude (``endpoint_noise``), along a bowed path
  (``curvature``) with velocity tremor (``tremor``). Each stroke lasts the longer of a Fitts-law
  time :math:`a + b \log_2(2A/W + 1)` and the time that keeps its peak speed
  :math:`1.875 A/T` under ``peak_speed``; a reaction pause (``reaction``) precedes it.
  Corrective strokes follow until the error is within the tolerance.
* **Orientation difficulty.** Re-orienting under the Cartesian mapping is what the subjects found
  hardest (§7.2 comments 3 and 5; the loops near the pick-up point in Fig. 74). Orientation
  strokes are preceded by a planning pause (``orient_plan``, mental rotation), are slower
  (``orient_peak``, ``orient_a``, ``orient_b``) and noisier in angle (``orient_noise``) and
  axis (``orient_axis_noise``) than translations; rotating about the wrist swings the
  fingertips, which then need new position corrections.
* **Pointing the laser** ("only wrist movements", comment 4) is a rotation stroke with the laser
  spot as direct visual feedback: modest noise (``aim_noise``, ``aim_axis_noise``), no planning
  pause.
* **Clutch and indexing.** The hand lives in the Omni's 160 × 120 × 70 mm workspace (App. A;
  Omni frame x right, y up, z toward the user, mapped to the PUMA by eq. 38). A stroke that would
  leave it is cut at the edge; when no room is left the operator releases the stylus button
  (clutch, ``clutch_time``), moves the hand back across the workspace (``index_speed``) and
  re-engages — an *index* event. The robot does not move meanwhile: the session drops the hand's
  motion while disengaged.
* **Keys.** Each key press costs ``key_time`` (look at the keyboard, press); recording laser
  points waits ``laser_wait`` after the beam stops (the thesis's 0.5-0.55 s filter settling).

The operator is written as generator *behaviours* (:meth:`SyntheticOperator.reach`,
:meth:`~SyntheticOperator.orient`, :meth:`~SyntheticOperator.aim`,
:meth:`~SyntheticOperator.press`, :meth:`~SyntheticOperator.wait_until`, …) that a task plan
composes with ``yield from`` (see :mod:`velfence.apps.teleop.task`); :meth:`SyntheticOperator.act`
advances the plan by one tick and returns an :class:`Action` (jog velocities in the PUMA base
frame and the keys to press). A seeded generator makes every run reproducible.

Scaled teleoperation ('S') and the line fixture ('F') are not used by the thesis's study (§1.1)
and the operator does not model adapting to their gains.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator, Iterator, Mapping
from dataclasses import KW_ONLY, asdict, dataclass, fields
from types import MappingProxyType
from typing import Any

import numpy as np

from velfence._deprecate import positional_deprecated
from velfence._typing import FloatArray
from velfence._validate import (
    check_positive,
    check_positive_int,
    check_seed,
    describe,
    finite_scalar,
    real_array,
    step_count,
)
from velfence.apps.teleop.modes import aligned_rotation
from velfence.apps.teleop.resolved_rate import rotation_from_angle_axis, rotation_vector
from velfence.apps.teleop.session import OMNI_TO_PUMA, SESSION_KEYS, Observation
from velfence.errors import InvalidInput, InvalidParameter

__all__ = [
    "OMNI_WORKSPACE",
    "PROFILE_RANGES",
    "Action",
    "Behaviour",
    "OperatorProfile",
    "OperatorStats",
    "SyntheticOperator",
]


OMNI_WORKSPACE = (0.160, 0.120, 0.070)
#: Most operator ticks one waiting or moving behaviour may last (5.5 h at 50 Hz).
MAX_TICKS = 1_000_000
"""Phantom Omni workspace W × H × D [m] (App. A), along the Omni x, y, z axes."""

#: Parameter ranges [low, high] a subject's profile is drawn from (uniform); units as in
#: :class:`OperatorProfile`. Modelling choices, see the module docstring. Read-only.
PROFILE_RANGES: Mapping[str, tuple[float, float]] = MappingProxyType(
    {
        "reaction": (0.20, 0.40),
        "fitts_a": (0.20, 0.40),
        "fitts_b": (0.10, 0.20),
        "peak_speed": (0.030, 0.060),
        "endpoint_noise": (0.06, 0.15),
        "curvature": (0.04, 0.12),
        "tremor": (0.001, 0.003),
        "perception": (0.001, 0.002),
        "orient_plan": (0.5, 1.5),
        "orient_a": (0.3, 0.6),
        "orient_b": (0.2, 0.4),
        "orient_peak": (0.20, 0.50),
        "orient_noise": (0.20, 0.40),
        "orient_axis_noise": (0.20, 0.50),
        "aim_noise": (0.05, 0.12),
        "aim_axis_noise": (0.05, 0.15),
        "aim_peak": (0.30, 0.60),
        "key_time": (0.30, 0.60),
        "clutch_time": (0.25, 0.50),
        "index_speed": (0.10, 0.20),
        "laser_wait": (0.55, 0.80),
        "lift_margin": (0.04, 0.12),
    }
)


@dataclass(frozen=True, kw_only=True)
class OperatorProfile:
    """One subject's parameters (module docstring; draw them with :meth:`draw`).

    Attributes:
        reaction: Pause before each stroke [s].
        fitts_a: Fitts intercept of translation strokes [s].
        fitts_b: Fitts slope of translation strokes [s/bit].
        peak_speed: Largest hand speed of a translation stroke [m/s].
        endpoint_noise: Endpoint error std per axis, fraction of the stroke amplitude.
        curvature: Std of the path bow (mid-stroke lateral offset), fraction of the amplitude.
        tremor: Std of the velocity tremor per axis [m/s].
        perception: Std of the perceived position error per axis [m].
        orient_plan: Planning pause before each orientation stroke [s].
        orient_a: Fitts intercept of orientation strokes [s].
        orient_b: Fitts slope of orientation strokes [s/bit].
        orient_peak: Largest angular speed of an orientation stroke [rad/s].
        orient_noise: Angle error std of an orientation stroke, fraction of its angle.
        orient_axis_noise: Axis error std of an orientation stroke [rad].
        aim_noise: Angle error std of a laser-pointing stroke, fraction of its angle.
        aim_axis_noise: Axis error std of a pointing stroke [rad].
        aim_peak: Largest angular speed of a pointing stroke [rad/s].
        key_time: Time per key press [s].
        clutch_time: Time per stylus-button press or release [s].
        index_speed: Peak hand speed while re-centring during indexing [m/s].
        laser_wait: Wait after the beam stops before recording a laser point [s].
        lift_margin: Clearance the subject keeps above the obstacle when lifting [m].
        rainbow: Whether the subject carries the cup on an arc ("rainbow") rather than an
            inverted U (§7.2: the subjects could choose).
    """

    reaction: float = 0.3
    fitts_a: float = 0.3
    fitts_b: float = 0.15
    peak_speed: float = 0.045
    endpoint_noise: float = 0.10
    curvature: float = 0.08
    tremor: float = 0.002
    perception: float = 0.0015
    orient_plan: float = 1.0
    orient_a: float = 0.45
    orient_b: float = 0.3
    orient_peak: float = 0.35
    orient_noise: float = 0.3
    orient_axis_noise: float = 0.35
    aim_noise: float = 0.08
    aim_axis_noise: float = 0.1
    aim_peak: float = 0.45
    key_time: float = 0.45
    clutch_time: float = 0.35
    index_speed: float = 0.15
    laser_wait: float = 0.65
    lift_margin: float = 0.08
    rainbow: bool = False

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "rainbow":
                continue
            value = check_positive(f.name, getattr(self, f.name), allow_zero=True)
            object.__setattr__(self, f.name, value)
        if not isinstance(self.rainbow, (bool, np.bool_)):
            raise InvalidParameter(f"rainbow: expected True or False, got {describe(self.rainbow)}")
        object.__setattr__(self, "rainbow", bool(self.rainbow))
        for name in ("peak_speed", "orient_peak", "aim_peak", "index_speed"):
            if not getattr(self, name) > 0.0:
                raise InvalidParameter(f"{name}: expected a speed > 0, got {getattr(self, name)!r}")

    @classmethod
    def draw(cls, rng: np.random.Generator) -> OperatorProfile:
        """A random subject: every parameter uniform in :data:`PROFILE_RANGES`, ``rainbow`` 50 %.

        Args:
            rng: Seeded generator (the subject's stream).

        Raises:
            InvalidParameter: ``rng`` is not a ``numpy.random.Generator``.
        """
        if not isinstance(rng, np.random.Generator):
            raise InvalidParameter(
                f"rng: expected a numpy.random.Generator, got {type(rng).__name__}"
            )
        values: dict[str, Any] = {
            name: float(rng.uniform(lo, hi)) for name, (lo, hi) in PROFILE_RANGES.items()
        }
        values["rainbow"] = bool(rng.uniform() < 0.5)
        return cls(**values)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able parameters."""
        return asdict(self)


@dataclass(frozen=True)
class Action:
    """What the operator does during one tick.

    Attributes:
        linear: Hand velocity mapped to the PUMA base frame [m/s], shape (3,).
        angular: Hand angular velocity in the PUMA base frame [rad/s], shape (3,).
        keys: Keys to press at the start of the tick, in order.
    """

    linear: FloatArray
    angular: FloatArray
    _: KW_ONLY
    keys: tuple[str, ...] = ()


@dataclass(kw_only=True)
class OperatorStats:
    """Counters of what the operator did (workload proxies; the thesis has no numeric workload).

    Attributes:
        strokes: Translation strokes (primary and corrective sub-movements).
        orient_strokes: Orientation strokes.
        aim_strokes: Laser-pointing strokes.
        clutch_presses: Stylus-button presses and releases (every 'C').
        index_events: Re-centrings of the hand at the workspace edge.
        keys: Mode-key presses (everything but 'C').
        hand_path: Distance the hand travelled in the Omni workspace [m].
        active_time: Time spent moving the engaged hand [s].
    """

    strokes: int = 0
    orient_strokes: int = 0
    aim_strokes: int = 0
    clutch_presses: int = 0
    index_events: int = 0
    keys: int = 0
    hand_path: float = 0.0
    active_time: float = 0.0


Behaviour = Generator[Action, None, Any]
"""A behaviour: yields one :class:`Action` per tick, reads :attr:`SyntheticOperator.obs`."""

_IDLE_V = np.zeros(3)


def _min_jerk_rate(tau: float) -> float:
    """d/dτ of 10τ³ - 15τ⁴ + 6τ⁵."""
    return 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau)


def _bow_rate(tau: float) -> float:
    """d/dτ of the bow shape 4s(1 - s) with s the minimum-jerk profile (zero at both ends)."""
    s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau)
    return 4.0 * (1.0 - 2.0 * s) * _min_jerk_rate(tau)


def _unit_perpendicular(d: FloatArray, rng: np.random.Generator) -> FloatArray:
    r = rng.normal(size=3)
    r -= (r @ d) / (d @ d) * d
    n = float(np.linalg.norm(r))
    return r / n if n > 0.0 else np.zeros(3)


def _perturb_axis(axis: FloatArray, sigma: float, rng: np.random.Generator) -> FloatArray:
    """Rotate a unit axis by a random angle ~ N(0, sigma) about a random perpendicular."""
    if sigma <= 0.0:
        return axis
    perp = _unit_perpendicular(axis, rng)
    if not perp.any():
        return axis
    out = rotation_from_angle_axis(perp, float(rng.normal(0.0, sigma))) @ axis
    return np.asarray(out, dtype=float)


class SyntheticOperator:
    """A simulated human at the Omni (module docstring).

    Args:
        profile: The subject's parameters (default: the nominal :class:`OperatorProfile`).
        seed: Seed (int >= 0) or generator of this run's randomness.
        tick: Operator update period [s], ``> 0`` (default 0.02: 50 Hz; the thesis's Omni PC
            sent increments from its ~30 Hz graphics loop).
        workspace: Omni workspace W × H × D [m].

    Raises:
        InvalidParameter: a bad profile, seed, tick or workspace.
    """

    def __init__(
        self,
        *,
        profile: OperatorProfile | None = None,
        seed: int | np.random.Generator = 0,
        tick: float = 0.02,
        workspace: tuple[float, float, float] = OMNI_WORKSPACE,
    ) -> None:
        self.profile = OperatorProfile() if profile is None else profile
        if not isinstance(self.profile, OperatorProfile):
            raise InvalidParameter(f"profile: expected an OperatorProfile, got {describe(profile)}")
        s = check_seed("seed", seed, allow_generator=True)
        self.rng = s if isinstance(s, np.random.Generator) else np.random.default_rng(s)
        self.tick = check_positive("tick", tick, unit="s")
        ws = real_array("workspace", workspace, (3,), error=InvalidParameter, what="sizes [m]")
        if not np.all(ws > 0.0):
            raise InvalidParameter(f"workspace: expected 3 sizes > 0 [m], got {ws.tolist()}")
        self.half = 0.5 * ws
        self.hand = np.zeros(3)  # Omni-frame hand position, workspace centre at 0
        self.stats = OperatorStats()
        self._plan: Iterator[Action] | None = None
        self._obs: Observation | None = None
        self.finished = False
        self._engaged = False

    # ------------------------------------------------------------------------------ driving
    @property
    def obs(self) -> Observation:
        """The latest observation (set by :meth:`act`)."""
        if self._obs is None:
            raise InvalidParameter("no observation yet: call act(observation) first")
        return self._obs

    def start(self, plan: Callable[[SyntheticOperator], Behaviour]) -> None:
        """Start a plan: a function of this operator returning a behaviour.

        Raises:
            InvalidInput: ``plan`` is not a function, or does not return an iterator.
        """
        _check_callable("plan", plan)
        behaviour = plan(self)
        if not isinstance(behaviour, Iterator):
            raise InvalidInput(
                f"plan: expected a function returning a behaviour (a generator of Actions), "
                f"got one returning {type(behaviour).__name__}"
            )
        self._plan = behaviour
        self.finished = False

    def act(self, obs: Observation) -> Action:
        """Advance the plan by one tick given what the operator sees.

        Returns:
            The tick's :class:`Action` (idle once the plan is finished).

        Raises:
            InvalidInput: ``obs`` is not an :class:`Observation`.
        """
        if not isinstance(obs, Observation):
            raise InvalidInput(
                f"obs: expected an Observation (Session.observe()), got {type(obs).__name__}"
            )
        self._obs = obs
        self._engaged = obs.clutch
        if self._plan is None:
            return Action(_IDLE_V, _IDLE_V)
        try:
            action: Any = next(self._plan)  # a user plan may yield anything
        except StopIteration:
            self._plan = None
            self.finished = True
            return Action(_IDLE_V, _IDLE_V)
        if not isinstance(action, Action):
            self._plan = None
            raise InvalidInput(
                f"plan: expected a behaviour yielding Actions, got {type(action).__name__}"
            )
        self._account(action)
        return action

    def _account(self, a: Action) -> None:
        if a.linear is _IDLE_V:
            return
        hand_v = OMNI_TO_PUMA @ a.linear  # M is its own inverse: PUMA -> Omni frame
        self.hand = self.hand + self.tick * hand_v
        self.stats.hand_path += self.tick * float(np.linalg.norm(hand_v))
        if self._engaged:
            self.stats.active_time += self.tick

    def _ticks(self, duration: float, name: str = "duration", *, allow_zero: bool = True) -> int:
        d = check_positive(name, duration, allow_zero=allow_zero, unit="s", error=InvalidInput)
        if d == 0.0:
            return 1
        return step_count(name, d, "tick", self.tick, max_steps=MAX_TICKS, error=InvalidInput)

    # ------------------------------------------------------------------------------ primitives
    # Every public behaviour validates its arguments when it is called (not when its generator
    # is first advanced, which may be many ticks later inside a plan), then returns the
    # generator of its private ``_name`` twin.
    def wait(self, duration: float) -> Behaviour:
        """Do nothing for ``duration`` [s], ``>= 0`` (at least one tick).

        Raises:
            InvalidInput: ``duration`` is not a real number >= 0 or needs too many ticks.
        """
        return self._idle(self._ticks(duration))

    def _idle(self, n: int) -> Behaviour:
        for _ in range(n):
            yield Action(_IDLE_V, _IDLE_V)

    def wait_until(
        self, predicate: Callable[[Observation], bool], *, limit: float = 120.0
    ) -> Behaviour:
        """Idle until ``predicate(observation)`` holds (or ``limit`` [s], ``> 0``, passes).

        Raises:
            InvalidInput: ``predicate`` is not a function, or ``limit`` is not > 0 or needs
                too many ticks; (while running) ``predicate`` returns something else than a bool.
        """
        _check_callable("predicate", predicate)
        return self._wait_until(predicate, self._ticks(limit, "limit", allow_zero=False))

    def _wait_until(self, predicate: Callable[[Observation], bool], n: int) -> Behaviour:
        for _ in range(n):
            if _truth("predicate", predicate(self.obs)):
                return
            yield Action(_IDLE_V, _IDLE_V)

    def press(self, *keys: str) -> Behaviour:
        """Press keys one after another, each after ``key_time`` (``C`` after ``clutch_time``).

        Raises:
            InvalidInput: a key is not one of :data:`~velfence.apps.teleop.session.SESSION_KEYS`.
        """
        return self._press(_check_keys(keys))

    def _press(self, keys: tuple[str, ...]) -> Behaviour:
        for key in keys:
            delay = self.profile.clutch_time if key == "C" else self.profile.key_time
            yield from self.wait(max(delay - self.tick, 0.0))
            if key == "C":
                self.stats.clutch_presses += 1
            else:
                self.stats.keys += 1
            yield Action(_IDLE_V, _IDLE_V, keys=(key,))

    def engage(self) -> Behaviour:
        """Engage the clutch if it is not (one stylus-button press)."""
        if not self.obs.clutch:
            yield from self.press("C")
            yield from self.wait_until(lambda o: o.clutch, limit=1.0)

    def disengage(self) -> Behaviour:
        """Release the clutch if it is engaged."""
        if self.obs.clutch:
            yield from self.press("C")
            yield from self.wait_until(lambda o: not o.clutch, limit=1.0)

    def _room(self, hand_d: FloatArray) -> float:
        """Largest fraction of the hand displacement that stays in the workspace (margin 3 mm)."""
        s = 1.0
        lim = self.half - 0.003
        for i in range(3):
            d = float(hand_d[i])
            if d > 0.0:
                s = min(s, max(lim[i] - self.hand[i], 0.0) / d)
            elif d < 0.0:
                s = min(s, max(lim[i] + self.hand[i], 0.0) / -d)
        return s

    def index(self, hand_d: FloatArray) -> Behaviour:
        """Clutch out, move the hand back across the workspace against ``hand_d``, clutch in.

        Args:
            hand_d: The hand displacement that ran out of room (Omni frame) [m], shape (3,),
                not zero.

        Raises:
            InvalidInput: ``hand_d`` is not a finite non-zero 3-vector.
        """
        hd = _vector3("hand_d", hand_d, "a hand displacement [m]")
        norm = float(np.linalg.norm(hd))
        if not norm > 0.0:
            raise InvalidInput(f"hand_d: expected a non-zero displacement [m], got {hd.tolist()}")
        return self._index(hd / norm)

    def _index(self, u: FloatArray) -> Behaviour:
        self.stats.index_events += 1
        yield from self.disengage()
        goal = np.where(np.abs(u) > 0.3, -0.6 * self.half * np.sign(u), 0.5 * self.hand)
        move = goal - self.hand
        dist = float(np.linalg.norm(move))
        if dist > 1e-4:
            T = max(0.3, 1.875 * dist / self.profile.index_speed)
            n = self._ticks(T)
            for i in range(n):
                rate = _min_jerk_rate((i + 0.5) / n) / (n * self.tick)
                yield Action(np.asarray(OMNI_TO_PUMA @ (move * rate), dtype=float), _IDLE_V)
        yield from self.engage()

    @positional_deprecated(2, ("self", "d", "tol"))
    def stroke(self, d: FloatArray, *, tol: float) -> Behaviour:
        """One minimum-jerk translation of the robot by ``d`` [m] (base frame).

        Indexes first when the hand has no room left in that direction; otherwise the stroke is
        cut at the workspace edge (the corrective strokes continue from there).

        Args:
            d: Displacement [m], shape (3,), magnitude <= :data:`MAX_STROKE`.
            tol: Tolerance [m] the stroke is aimed at (Fitts-law width), ``> 0``.

        Raises:
            InvalidInput: ``d`` or ``tol`` out of range.
        """
        dv = _vector3("d", d, "a displacement [m]", limit=MAX_STROKE)
        tl = check_positive("tol", tol, unit="m", error=InvalidInput)
        return self._stroke(dv, tl)

    def _stroke(self, d: FloatArray, tol: float) -> Behaviour:
        amp = float(np.linalg.norm(d))
        if amp < 1e-6:
            return
        yield from self.engage()
        hand_d = OMNI_TO_PUMA @ d
        s = self._room(hand_d)
        if s * amp < min(0.015, 0.5 * amp):
            yield from self._index(hand_d / float(np.linalg.norm(hand_d)))
            s = self._room(hand_d)
        d = s * d
        amp = float(np.linalg.norm(d))
        if amp < 1e-6:
            return
        p = self.profile
        self.stats.strokes += 1
        T = max(
            p.fitts_a + p.fitts_b * math.log2(2.0 * amp / max(tol, 1e-3) + 1.0),
            1.875 * amp / p.peak_speed,
        )
        n = self._ticks(T)
        Tn = n * self.tick
        bow = _unit_perpendicular(d, self.rng) * float(self.rng.normal(0.0, p.curvature * amp))
        for i in range(n):
            tau = (i + 0.5) / n
            v = d * (_min_jerk_rate(tau) / Tn) + bow * (_bow_rate(tau) / Tn)
            if p.tremor > 0.0:
                v = v + self.rng.normal(0.0, p.tremor, 3)
            yield Action(np.asarray(v, dtype=float), _IDLE_V)

    def turn(self, rotvec: FloatArray, *, peak: float, a: float, b: float, tol: float) -> Behaviour:
        """One minimum-jerk rotation of the tool by the rotation vector ``rotvec`` [rad].

        Args:
            rotvec: Rotation vector [rad], shape (3,), angle <= 2π.
            peak: Largest angular speed [rad/s], ``> 0``.
            a: Fitts intercept [s], ``>= 0``.
            b: Fitts slope [s/bit], ``>= 0``.
            tol: Angular tolerance [rad] (Fitts-law width), ``> 0``.

        Raises:
            InvalidInput: an argument out of range.
        """
        rv = _vector3("rotvec", rotvec, "a rotation vector [rad]", limit=2.0 * math.pi)
        pk = check_positive("peak", peak, unit="rad/s", error=InvalidInput)
        fa = check_positive("a", a, allow_zero=True, unit="s", error=InvalidInput)
        fb = check_positive("b", b, allow_zero=True, unit="s/bit", error=InvalidInput)
        tl = check_positive("tol", tol, unit="rad", error=InvalidInput)
        # the stroke's duration is bounded here, before any tick is produced
        angle = float(np.linalg.norm(rv))
        T = _turn_time(angle, pk, fa, fb, tl)
        if not MAX_TICKS * self.tick >= T:
            raise InvalidInput(
                f"peak, a, b: a turn by {angle:.3g} rad with peak={pk:g} rad/s, a={fa:g} s and "
                f"b={fb:g} s/bit lasts {T:.3g} s, more than {MAX_TICKS:,} ticks of {self.tick:g} s"
            )
        return self._turn(rv, pk, fa, fb, tl)

    def _turn(self, rotvec: FloatArray, peak: float, a: float, b: float, tol: float) -> Behaviour:
        angle = float(np.linalg.norm(rotvec))
        if angle < 1e-6:
            return
        yield from self.engage()
        n = self._ticks(_turn_time(angle, peak, a, b, tol))
        Tn = n * self.tick
        axis = rotvec / angle
        for i in range(n):
            w = axis * (angle * _min_jerk_rate((i + 0.5) / n) / Tn)
            yield Action(_IDLE_V, np.asarray(w, dtype=float))

    # ------------------------------------------------------------------------------ behaviours
    @positional_deprecated(2, ("self", "target", "tol"))
    def reach(
        self,
        target: Callable[[Observation], FloatArray],
        *,
        tol: float,
        point: str = "tip",
        max_strokes: int = 40,
    ) -> Behaviour:
        """Bring a point of the robot within ``tol`` [m] of ``target(obs)`` by sub-movements.

        Args:
            target: The goal position [m] as a function of the observation.
            tol: Tolerance [m] the operator is satisfied with, ``> 0``.
            point: ``"tip"`` (fingertips), ``"wrist"`` (frame 6) or ``"cup"`` (held cup bottom).
            max_strokes: Give up after this many strokes (1 to :data:`MAX_STROKES`).

        Raises:
            InvalidInput: a bad argument; (while running) ``target`` returns no 3-vector.
        """
        _check_callable("target", target)
        tl = check_positive("tol", tol, unit="m", error=InvalidInput)
        pt = _choice("point", point, ("tip", "wrist", "cup"))
        n = check_positive_int("max_strokes", max_strokes, maximum=MAX_STROKES, example=40)
        return self._reach(target, tl, pt, n)

    def _reach(
        self, target: Callable[[Observation], FloatArray], tol: float, point: str, n: int
    ) -> Behaviour:
        p = self.profile
        for _ in range(n):
            yield from self.wait(p.reaction)
            obs = self.obs
            cur = obs.tip if point == "tip" else obs.cup if point == "cup" else obs.pose[:3, 3]
            goal = _vector3("target", target(obs), "a position [m] from target(obs)")
            err = goal - cur
            err = err + self.rng.normal(0.0, p.perception, 3)
            if not np.all(np.isfinite(err)):
                return  # no cup to carry (its position is NaN): nothing to reach
            if float(np.linalg.norm(err)) <= tol:
                return
            amp = float(np.linalg.norm(err))
            d = err + self.rng.normal(0.0, p.endpoint_noise * amp / math.sqrt(3.0), 3)
            d = _clip_norm(d, MAX_STROKE)
            yield from self._stroke(d, tol)

    @positional_deprecated(2, ("self", "target", "tol"))
    def orient(
        self,
        target: Callable[[Observation], FloatArray],
        *,
        tol: float,
        error: Callable[[Observation], float] | None = None,
        max_strokes: int = 20,
    ) -> Behaviour:
        """Turn the tool toward the rotation ``target(obs)`` (3×3) until within ``tol`` [rad].

        Args:
            target: Goal rotation as a function of the observation.
            tol: Tolerance [rad] on ``error(obs)`` (default: the full rotation angle), ``> 0``.
            error: The angle the operator judges [rad], e.g. only the tilt of the tool axis.
            max_strokes: Give up after this many strokes (1 to :data:`MAX_STROKES`).

        Raises:
            InvalidInput: a bad argument; (while running) ``target`` returns no rotation or
                ``error`` no angle.
        """
        _check_callable("target", target)
        tl = check_positive("tol", tol, unit="rad", error=InvalidInput)
        if error is not None:
            _check_callable("error", error)
        n = check_positive_int("max_strokes", max_strokes, maximum=MAX_STROKES, example=20)
        return self._orient(target, tl, error, n)

    def _orient(
        self,
        target: Callable[[Observation], FloatArray],
        tol: float,
        error: Callable[[Observation], float] | None,
        n: int,
    ) -> Behaviour:
        p = self.profile
        for _ in range(n):
            yield from self.wait(p.reaction + p.orient_plan)
            obs = self.obs
            R = obs.pose[:3, :3]
            goal = real_array("target", target(obs), (3, 3), what="a rotation from target(obs)")
            e = rotation_vector(goal @ R.T)
            if error is None:
                judged = float(np.linalg.norm(e))
            else:
                judged = finite_scalar(
                    "error", error(obs), unit="rad", what="angle from error(obs)"
                )
            if judged <= tol:
                return
            norm_e = float(np.linalg.norm(e))
            if norm_e < 1e-12:
                return
            angle = norm_e * (1.0 + float(self.rng.normal(0.0, p.orient_noise)))
            angle = max(-2.0 * math.pi, min(2.0 * math.pi, angle))
            axis = _perturb_axis(e / norm_e, p.orient_axis_noise, self.rng)
            self.stats.orient_strokes += 1
            yield from self._turn(axis * angle, p.orient_peak, p.orient_a, p.orient_b, tol)

    @positional_deprecated(2, ("self", "target", "tol"))
    def aim(self, target: FloatArray, *, tol: float, max_strokes: int = 25) -> Behaviour:
        """Point the laser spot within ``tol`` [m] of ``target`` by wrist rotations.

        The rotation is judged about the wrist centre, from the direction of the visible spot
        to the direction of the target (the beam's offset from the wrist makes this approximate;
        the corrective strokes absorb it).

        Args:
            target: The point to put the spot on [m], shape (3,).
            tol: Tolerance [m], ``> 0``.
            max_strokes: Give up after this many strokes (1 to :data:`MAX_STROKES`).

        Raises:
            InvalidInput: a bad argument.
        """
        goal = _vector3("target", target, "a point [m]")
        tl = check_positive("tol", tol, unit="m", error=InvalidInput)
        n = check_positive_int("max_strokes", max_strokes, maximum=MAX_STROKES, example=25)
        return self._aim(goal, tl, n)

    def _aim(self, goal: FloatArray, tol: float, n: int) -> Behaviour:
        p = self.profile
        for _ in range(n):
            yield from self.wait(p.reaction)
            obs = self.obs
            c = obs.pose[:3, 3]
            spot = obs.spot if obs.spot is not None else c + 0.6 * obs.pose[:3, 2]
            seen = spot + self.rng.normal(0.0, p.perception, 3)
            if float(np.linalg.norm(seen - goal)) <= tol:
                return
            r1 = float(np.linalg.norm(seen - c))
            r2 = float(np.linalg.norm(goal - c))
            if r1 < 1e-9 or r2 < 1e-9:
                return  # the target is at the wrist centre: no direction to point in
            u1 = (seen - c) / r1
            u2 = (goal - c) / r2
            axis = np.cross(u1, u2)
            s = float(np.linalg.norm(axis))
            if s < 1e-9:
                return
            angle = math.atan2(s, float(u1 @ u2)) * (1.0 + float(self.rng.normal(0.0, p.aim_noise)))
            axis = _perturb_axis(axis / s, p.aim_axis_noise, self.rng)
            self.stats.aim_strokes += 1
            angle_tol = tol / r2
            yield from self._turn(axis * angle, p.aim_peak, p.fitts_a, p.fitts_b, angle_tol)

    def record(self, *keys: str) -> Behaviour:
        """Hold still for the laser to settle (``laser_wait``), then press ``keys``.

        Raises:
            InvalidInput: a key is not one of :data:`~velfence.apps.teleop.session.SESSION_KEYS`.
        """
        return self._record(_check_keys(keys))

    def _record(self, keys: tuple[str, ...]) -> Behaviour:
        yield from self.wait(self.profile.laser_wait)
        yield from self._press(keys)

    def vertical(self, tol: float) -> Behaviour:
        """Orient the tool axis straight down (least rotation) within ``tol`` [rad] of tilt.

        Raises:
            InvalidInput: ``tol`` is not > 0.
        """
        tl = check_positive("tol", tol, unit="rad", error=InvalidInput)

        def goal(o: Observation) -> FloatArray:
            return aligned_rotation(o.pose[:3, :3], (0.0, 0.0, 1.0), alignment="geodesic")

        def tilt(o: Observation) -> float:
            return math.acos(max(-1.0, min(1.0, -float(o.pose[2, 2]))))

        return self._orient(goal, tl, tilt, 20)


#: Largest displacement one translation stroke may ask for [m] (far beyond any teleoperated
#: reach; keeps stroke durations and tick counts bounded).
MAX_STROKE = 100.0
#: Most strokes one reaching, orienting or aiming behaviour may make.
MAX_STROKES = 10_000


def _turn_time(angle: float, peak: float, a: float, b: float, tol: float) -> float:
    return max(a + b * math.log2(2.0 * angle / max(tol, 1e-3) + 1.0), 1.875 * angle / peak)


def _clip_norm(v: FloatArray, limit: float) -> FloatArray:
    n = float(np.linalg.norm(v))
    return v * (limit / n) if n > limit else v


def _check_callable(name: str, fn: Any) -> None:
    """A function (classes such as ``float`` are callable but not behaviour callbacks)."""
    if not callable(fn) or isinstance(fn, type):
        raise InvalidInput(f"{name}: expected a function, got {type(fn).__name__}")


def _truth(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInput(
            f"{name}: expected a function returning True or False, got a {type(value).__name__}"
        )
    return bool(value)


def _choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    if not isinstance(value, str) or value not in choices:
        shown = repr(value) if isinstance(value, str) else type(value).__name__
        raise InvalidInput(f"{name}: expected one of {list(choices)}, got {shown:.60}")
    return value


def _check_keys(keys: tuple[Any, ...]) -> tuple[str, ...]:
    out = []
    for k in keys:
        if not isinstance(k, str) or k.upper() not in SESSION_KEYS:
            shown = repr(k) if isinstance(k, str) else type(k).__name__
            raise InvalidInput(f"keys: expected keys among {list(SESSION_KEYS)}, got {shown:.40}")
        out.append(k.upper())
    return tuple(out)


def _vector3(name: str, x: Any, what: str, limit: float | None = None) -> FloatArray:
    v = real_array(name, x, (3,), what=what)
    if limit is not None and not float(np.linalg.norm(v)) <= limit:
        raise InvalidInput(f"{name}: expected {what} of length <= {limit:g}, got {v.tolist()}")
    return v
