r"""A synthetic teleoperator for the Khokar 2009 study (source 002, notes §6 "synthetic operator").

The thesis's subjects (10, §7.2) are replaced by a model of a human driving a Phantom Omni while
watching the remote scene. It is built from standard motor-control ingredients; every number is a
**modelling choice** (the thesis reports no human data beyond "every subject was faster with
assistance", §4.4 of the notes), drawn per subject from the ranges of :meth:`OperatorProfile.draw`:

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
composes with ``yield from`` (see :mod:`velfence.teleop.task`); :meth:`SyntheticOperator.act`
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
from numpy.typing import NDArray

from velfence._validate import check_positive, finite_array, step_count
from velfence.errors import InvalidParameter
from velfence.teleop.modes import aligned_rotation
from velfence.teleop.resolved_rate import rotation_from_angle_axis, rotation_vector
from velfence.teleop.session import OMNI_TO_PUMA, Observation

__all__ = [
    "OMNI_WORKSPACE",
    "PROFILE_RANGES",
    "Action",
    "Behaviour",
    "OperatorProfile",
    "OperatorStats",
    "SyntheticOperator",
]

FloatArray = NDArray[np.float64]

OMNI_WORKSPACE = (0.160, 0.120, 0.070)
#: Most operator ticks one waiting or moving behaviour may last (5.5 h at 50 Hz).
MAX_TICKS = 1_000_000
"""Phantom Omni workspace W × H × D [m] (App. A; notes §2.16), along the Omni x, y, z axes."""

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
            raise InvalidParameter(f"rainbow: expected True or False, got {self.rainbow!r:.60}")
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
            raise InvalidParameter(f"profile: expected an OperatorProfile, got {profile!r}")
        if isinstance(seed, np.random.Generator):
            self.rng = seed
        elif isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0:
            self.rng = np.random.default_rng(int(seed))
        else:
            raise InvalidParameter(f"seed: expected an int >= 0 or a Generator, got {seed!r}")
        self.tick = check_positive("tick", tick, unit="s")
        ws = finite_array("workspace", workspace, (3,), error=InvalidParameter, what="sizes [m]")
        if not np.all(ws > 0.0):
            raise InvalidParameter(f"workspace: expected 3 sizes > 0 [m], got {workspace!r}")
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
        """Start a plan: a function of this operator returning a behaviour."""
        self._plan = plan(self)
        self.finished = False

    def act(self, obs: Observation) -> Action:
        """Advance the plan by one tick given what the operator sees.

        Returns:
            The tick's :class:`Action` (idle once the plan is finished).
        """
        self._obs = obs
        self._engaged = obs.clutch
        if self._plan is None:
            return Action(_IDLE_V, _IDLE_V)
        try:
            action = next(self._plan)
        except StopIteration:
            self._plan = None
            self.finished = True
            return Action(_IDLE_V, _IDLE_V)
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

    def _ticks(self, duration: float, name: str = "duration") -> int:
        d = check_positive(name, duration, allow_zero=True, unit="s")
        if d == 0.0:
            return 1
        return step_count(name, d, "tick", self.tick, max_steps=MAX_TICKS)

    # ------------------------------------------------------------------------------ primitives
    def wait(self, duration: float) -> Behaviour:
        """Do nothing for ``duration`` [s] (at least one tick)."""
        for _ in range(self._ticks(duration)):
            yield Action(_IDLE_V, _IDLE_V)

    def wait_until(
        self, predicate: Callable[[Observation], bool], *, limit: float = 120.0
    ) -> Behaviour:
        """Idle until ``predicate(observation)`` holds (or ``limit`` [s] passes)."""
        for _ in range(self._ticks(limit, "limit")):
            if predicate(self.obs):
                return
            yield Action(_IDLE_V, _IDLE_V)

    def press(self, *keys: str) -> Behaviour:
        """Press keys one after another, each after ``key_time`` (``C`` after ``clutch_time``)."""
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
        """Clutch out, move the hand back across the workspace against ``hand_d``, clutch in."""
        self.stats.index_events += 1
        yield from self.disengage()
        u = hand_d / float(np.linalg.norm(hand_d))
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

    def stroke(self, d: FloatArray, tol: float) -> Behaviour:
        """One minimum-jerk translation of the robot by ``d`` [m] (base frame).

        Indexes first when the hand has no room left in that direction; otherwise the stroke is
        cut at the workspace edge (the corrective strokes continue from there).
        """
        amp = float(np.linalg.norm(d))
        if amp < 1e-6:
            return
        yield from self.engage()
        hand_d = OMNI_TO_PUMA @ d
        s = self._room(hand_d)
        if s * amp < min(0.015, 0.5 * amp):
            yield from self.index(hand_d)
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
        """One minimum-jerk rotation of the tool by the rotation vector ``rotvec`` [rad]."""
        angle = float(np.linalg.norm(rotvec))
        if angle < 1e-6:
            return
        yield from self.engage()
        T = max(a + b * math.log2(2.0 * angle / max(tol, 1e-3) + 1.0), 1.875 * angle / peak)
        n = self._ticks(T)
        Tn = n * self.tick
        axis = rotvec / angle
        for i in range(n):
            w = axis * (angle * _min_jerk_rate((i + 0.5) / n) / Tn)
            yield Action(_IDLE_V, np.asarray(w, dtype=float))

    # ------------------------------------------------------------------------------ behaviours
    def reach(
        self,
        target: Callable[[Observation], FloatArray],
        tol: float,
        *,
        point: str = "tip",
        max_strokes: int = 40,
    ) -> Behaviour:
        """Bring a point of the robot within ``tol`` [m] of ``target(obs)`` by sub-movements.

        Args:
            target: The goal position [m] as a function of the observation.
            tol: Tolerance [m] the operator is satisfied with.
            point: ``"tip"`` (fingertips), ``"wrist"`` (frame 6) or ``"cup"`` (held cup bottom).
            max_strokes: Give up after this many strokes.
        """
        p = self.profile
        for _ in range(max_strokes):
            yield from self.wait(p.reaction)
            obs = self.obs
            cur = obs.tip if point == "tip" else obs.cup if point == "cup" else obs.pose[:3, 3]
            err = np.asarray(target(obs), dtype=float) - cur
            err = err + self.rng.normal(0.0, p.perception, 3)
            if float(np.linalg.norm(err)) <= tol:
                return
            amp = float(np.linalg.norm(err))
            d = err + self.rng.normal(0.0, p.endpoint_noise * amp / math.sqrt(3.0), 3)
            yield from self.stroke(d, tol)

    def orient(
        self,
        target: Callable[[Observation], FloatArray],
        tol: float,
        *,
        error: Callable[[Observation], float] | None = None,
        max_strokes: int = 20,
    ) -> Behaviour:
        """Turn the tool toward the rotation ``target(obs)`` (3×3) until within ``tol`` [rad].

        Args:
            target: Goal rotation as a function of the observation.
            tol: Tolerance [rad] on ``error(obs)`` (default: the full rotation angle).
            error: The angle the operator judges [rad], e.g. only the tilt of the tool axis.
            max_strokes: Give up after this many strokes.
        """
        p = self.profile
        for _ in range(max_strokes):
            yield from self.wait(p.reaction + p.orient_plan)
            obs = self.obs
            R = obs.pose[:3, :3]
            e = rotation_vector(np.asarray(target(obs), dtype=float) @ R.T)
            judged = float(np.linalg.norm(e)) if error is None else error(obs)
            if judged <= tol:
                return
            angle = float(np.linalg.norm(e)) * (1.0 + float(self.rng.normal(0.0, p.orient_noise)))
            axis = _perturb_axis(e / float(np.linalg.norm(e)), p.orient_axis_noise, self.rng)
            self.stats.orient_strokes += 1
            yield from self.turn(
                axis * angle, peak=p.orient_peak, a=p.orient_a, b=p.orient_b, tol=tol
            )

    def aim(self, target: FloatArray, tol: float, *, max_strokes: int = 25) -> Behaviour:
        """Point the laser spot within ``tol`` [m] of ``target`` by wrist rotations.

        The rotation is judged about the wrist centre, from the direction of the visible spot
        to the direction of the target (the beam's offset from the wrist makes this approximate;
        the corrective strokes absorb it).
        """
        p = self.profile
        goal = np.asarray(target, dtype=float)
        for _ in range(max_strokes):
            yield from self.wait(p.reaction)
            obs = self.obs
            c = obs.pose[:3, 3]
            spot = obs.spot if obs.spot is not None else c + 0.6 * obs.pose[:3, 2]
            seen = spot + self.rng.normal(0.0, p.perception, 3)
            if float(np.linalg.norm(seen - goal)) <= tol:
                return
            u1 = (seen - c) / float(np.linalg.norm(seen - c))
            u2 = (goal - c) / float(np.linalg.norm(goal - c))
            axis = np.cross(u1, u2)
            s = float(np.linalg.norm(axis))
            if s < 1e-9:
                return
            angle = math.atan2(s, float(u1 @ u2)) * (1.0 + float(self.rng.normal(0.0, p.aim_noise)))
            axis = _perturb_axis(axis / s, p.aim_axis_noise, self.rng)
            self.stats.aim_strokes += 1
            angle_tol = tol / float(np.linalg.norm(goal - c))
            yield from self.turn(
                axis * angle, peak=p.aim_peak, a=p.fitts_a, b=p.fitts_b, tol=angle_tol
            )

    def record(self, *keys: str) -> Behaviour:
        """Hold still for the laser to settle (``laser_wait``), then press ``keys``."""
        yield from self.wait(self.profile.laser_wait)
        yield from self.press(*keys)

    def vertical(self, tol: float) -> Behaviour:
        """Orient the tool axis straight down (least rotation) within ``tol`` [rad] of tilt."""

        def goal(o: Observation) -> FloatArray:
            return aligned_rotation(o.pose[:3, :3], (0.0, 0.0, 1.0), alignment="geodesic")

        def tilt(o: Observation) -> float:
            return math.acos(max(-1.0, min(1.0, -float(o.pose[2, 2]))))

        yield from self.orient(goal, tol, error=tilt)
