r"""One simulated traded-control world of Khokar 2009, advanced in time.

A :class:`Session` couples the pieces the other ``teleop`` modules provide:

* the PUMA 560 (:class:`~velfence.mechanisms.puma560.Puma560`, frame 6 at the wrist centre, the
  thesis's "end effector") driven by resolved rate with the SR inverse
  (:class:`~velfence.apps.teleop.resolved_rate.ResolvedRate`) through a joint servo (default a 10 ms
  first-order lag, :class:`~velfence.apps.teleop.servo.FirstOrderServo`);
* the DT60 laser on the flange (:class:`~velfence.apps.teleop.laser.LaserStream`: 90 Hz, 50-sample
  moving average) ray-cast into a :class:`~velfence.apps.teleop.scene.Scene`;
* the traded-control :class:`~velfence.apps.teleop.modes.ModeManager` (keys, clutch, shaping,
  autonomous segments);
* the Barrett Hand as a binary gripper 0.23 m along :math:`z_6` (§6.3) and the task object (the
  cup), which is carried once grasped.

Each control cycle (period ``1/rate``, thesis 200 Hz): the laser is ray-cast from the *true*
flange pose (the servo's true joints: encoder noise moves the estimate, not the beam); the mode
manager turns the hand's velocity (or the next via point) into a twist at the *measured* pose;
resolved rate turns it into joint rates at the *measured* joints; the commanded joints integrate
them and the servo tracks them. The physical world — the beam, the fingertip, the carried cup,
collisions and the trace — follows the true pose; the control layer sees only the measured one.

**Protocol** (the interactive viewer and the study drive it):

* :meth:`Session.press` — ``"A" "S" "F" "D" "G" "P" "T"`` (thesis keys), ``"C"`` toggles the
  clutch, and ``"H"`` toggles the hand (close/open; our key: the thesis commands the Barrett Hand
  from the Omni PC without naming one);
* :meth:`Session.jog` — the master hand's linear and angular velocity **already mapped to the
  PUMA base frame** (m/s, rad/s; :func:`omni_to_puma` applies the thesis's eq. 38 map to Omni-
  frame vectors), held until the next call;
* :meth:`Session.advance` — step the world by ``dt`` seconds at the control rate;
* :meth:`Session.snapshot` — a JSON-able state; :meth:`Session.scene_primitives` — the scene.

Teleoperation mapping (repair T10 of ``docs/telerobotics.md`` §8): the translation increment is
added in the base frame (§6.2.2's "added to the current PUMA position") and the rotation is the
hand's angular velocity in the base frame (the thesis's tool-frame ``R_{P1} dR`` expressed there);
no position scale.

**Joint limits.** The thesis gives none (only the symbols J1LO … J6HI). :class:`Puma560`'s default
table has joint 4 in (-110°, 170°); in this task the wrist works close to its singularity
(:math:`\theta_5` between about -45° and -10° for a tool pointing at the table), laser pointing
and hand re-orientation can carry it through :math:`\theta_5 = 0` into the flipped branch, and
there a vertical tool needs :math:`\theta_4 \approx \pm 180°` — beyond that stop, so the
alignment and the grasp got stuck at it in our runs. The PUMA 560 is also documented with a 532°
wrist roll; the session's default arm (:func:`default_robot`) uses joint 4 in ±266°, the other
joints unchanged.

**Task bookkeeping** (our stand-ins; the thesis gives no numbers): the hand grasps the cup when,
at the end of closing, the fingertip point (0.23 m along :math:`z_6`) lies within
:data:`GRASP_RADIAL` of the cup's axis, between :data:`GRASP_DEPTH` below the rim and 5 mm below
it, with the tool axis within :data:`GRASP_TILT` of vertical. Opening the hand drops the cup onto
the table below; the task is **done** when it lands within the destination mark's radius with a
drop of at most :data:`PLACE_DROP`. A **collision** is counted each time the fingertip, or the held
cup, enters the folder (any box of the scene) or goes below the table top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    MAX_STEPS,
    check_positive,
    check_positive_int,
    check_range,
    check_seed,
    describe,
    readonly,
    real_array,
    step_count,
)
from velfence.apps.teleop.laser import LaserRangeSensor, LaserStream
from velfence.apps.teleop.modes import KEYS, ModeEvent, ModeManager
from velfence.apps.teleop.resolved_rate import ResolvedRate
from velfence.apps.teleop.scene import (
    Box,
    Cylinder,
    Disk,
    Plane,
    Scene,
    pick_and_place_scene,
    scene_to_dicts,
)
from velfence.apps.teleop.servo import FirstOrderServo, JointServo
from velfence.apps.teleop.thesis_data import TRAJECTORY_FINAL_Q_RAD
from velfence.errors import InvalidInput, InvalidParameter
from velfence.mechanisms.puma560 import Puma560

__all__ = [
    "GRASP_DEPTH",
    "GRASP_RADIAL",
    "GRASP_TILT",
    "GRIPPER_LENGTH",
    "HAND_TIME",
    "OMNI_TO_PUMA",
    "PLACE_DROP",
    "READY_POSITION",
    "SESSION_KEYS",
    "WRIST_ROLL_LIMIT",
    "Observation",
    "Session",
    "default_robot",
    "omni_to_puma",
    "ready_pose",
]


GRIPPER_LENGTH = 0.23
"""Barrett Hand length beyond frame 6 along :math:`z_6` [m] (thesis §6.3)."""
GRASP_RADIAL = 0.015
"""Largest distance of the fingertip point from the cup axis for a grasp [m] (our guess)."""
GRASP_DEPTH = 0.06
"""Deepest fingertip position below the cup rim for a grasp [m] (our guess)."""
GRASP_TILT = math.radians(10.0)
"""Largest tilt of the tool axis from vertical for a grasp from the top [rad] (our guess)."""
PLACE_DROP = 0.03
"""Largest height of the cup bottom above the table on release for a placement [m] (our guess)."""
HAND_TIME = 1.0
"""Time to close or open the Barrett Hand [s] (our guess; its serial link runs at ~10 Hz)."""
READY_POSITION = (0.10, 0.55, 0.05)
"""Wrist-centre position of the ready pose [m] (our choice; the thesis shows it only in lost
figures). The beam lands on the table 10 cm beyond the cup. High and forward enough that the
forearm is far from the directions the tool points in during the task: every laser aim and the
vertical grasp keep |θ5| above about 30° in one wrist branch (a ready pose lower and
closer, e.g. (0.10, 0.45, -0.05), put the wrist singularity between the aims and the wrist flipped
while pointing)."""
SESSION_KEYS = (*KEYS, "H")
MAX_ADVANCE_CYCLES = 1_000_000
"""Most control cycles one :meth:`Session.advance` call may run (83 min at 200 Hz)."""
WRIST_ROLL_LIMIT = math.radians(266.0)
"""Joint-4 range of the session's default arm, ±266° [rad] (module docstring, "joint limits")."""
"""Keys :meth:`Session.press` accepts: the mode keys, ``C`` (clutch) and ``H`` (hand)."""

OMNI_TO_PUMA: FloatArray = readonly(np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]))
"""Thesis eq. 38: ``(X_p, Y_p, Z_p) = (x_o, y_o, z_o) M`` — self-inverse, det +1 (eq. 49)."""


def omni_to_puma(v: ArrayLike) -> FloatArray:
    """Map an Omni-frame vector to the PUMA base frame (thesis eq. 38; its own inverse).

    Args:
        v: Vector in the Omni base frame, shape (3,) (x right, y up, z toward the user).

    Returns:
        ``v M`` in the PUMA base frame, shape (3,).
    """
    return np.asarray(real_array("v", v, (3,)) @ OMNI_TO_PUMA, dtype=float)


def default_robot() -> Puma560:
    """The session's PUMA 560: :class:`Puma560` with joint 4 widened to ±266° (module docs)."""
    limits = np.array(Puma560().joint_limits)
    limits[3] = (-WRIST_ROLL_LIMIT, WRIST_ROLL_LIMIT)
    return Puma560(joint_limits=limits)


def ready_pose(robot: Puma560 | None = None) -> tuple[FloatArray, FloatArray]:
    """The ready pose: wrist centre at :data:`READY_POSITION`, tool tilted as the thesis's arm.

    The orientation is that of the recorded §7.1 end pose (Table 4, tool axis about
    ``(0.30, 0.26, -0.92)``): pointing down and forward, so the laser lands on the table near
    the cup and a grasp from the top needs a re-orientation.

    Args:
        robot: The arm (default :func:`default_robot`).

    Returns:
        ``(q, T)``: joint angles [rad], shape (6,) (branch right/up/noflip), and the pose (4, 4).
    """
    arm = default_robot() if robot is None else _robot(robot)
    T = np.array(arm.fk(TRAJECTORY_FINAL_Q_RAD[0]))
    T[:3, 3] = READY_POSITION
    q = arm.ik(T, shoulder="right", elbow="up", wrist="noflip")
    return q, np.asarray(arm.fk(q), dtype=float)


@dataclass(frozen=True)
class Observation:
    """What a (synthetic) operator perceives of the session: the scene and the screen.

    Attributes:
        t: Session time [s].
        pose: True tool (frame 6) pose, shape (4, 4).
        tip: Fingertip point [m], shape (3,).
        spot: The visible laser spot [m], shape (3,), or ``None`` (nothing within range).
        distance: The filtered laser reading [m] or ``None``.
        settled: Whether the laser's averaging window is full.
        mode: The mode manager's mode.
        clutch: Whether the master is engaged.
        busy: Whether an autonomous segment runs.
        hand: ``"open"``, ``"closing"``, ``"closed"`` or ``"opening"``.
        holding: Whether the cup is grasped.
        done: Whether the cup has been placed on the destination.
        cup: Centre of the cup's bottom [m], shape (3,) (NaN without a cup).
        legs_done: Path legs completed.
        status: The status message.
    """

    t: float
    pose: FloatArray
    tip: FloatArray
    spot: FloatArray | None
    distance: float | None
    settled: bool
    mode: str
    clutch: bool
    busy: bool
    hand: str
    holding: bool
    done: bool
    cup: FloatArray
    legs_done: int
    status: str


def _floats(a: ArrayLike) -> list[Any]:
    out: list[Any] = np.asarray(a, dtype=float).tolist()
    return out


class Session:
    r"""A simulated PUMA 560 + laser + scene + traded-control modes, stepped at the control rate.

    See the module docstring for the protocol and the task rules. All parameters keyword-only.

    Args:
        scene: The remote scene (default :func:`~velfence.apps.teleop.scene.pick_and_place_scene`).
            A cylinder named ``"cup"`` is the graspable object, a disk named ``"destination"``
            its target, a plane named ``"table"`` the surface, boxes are obstacles.
        robot: The arm (default :func:`default_robot`, frame 6 at the wrist centre).
        laser: The laser sensor (default the DT60 model with the thesis's offset and filter).
        servo: Joint servo (default a 10 ms first-order lag with the arm's joint limits).
        modes: The mode manager (default ``ModeManager(laser=laser, rate=rate)``); its ``rate`` must
            equal ``rate``.
        rate: Control rate [Hz], ``> 0`` (thesis 200).
        q0: Initial joint angles [rad], shape (6,); default :func:`ready_pose`.
        seed: Seed of the laser noise (int ``>= 0``).
        hand_time: Time the hand takes to close or open [s], ``>= 0``.
        trace_every: Keep every n-th control cycle in :attr:`trace` (int ``>= 1``).

    Raises:
        InvalidParameter: inconsistent or out-of-range parameters.
    """

    def __init__(
        self,
        *,
        scene: Scene | None = None,
        robot: Puma560 | None = None,
        laser: LaserRangeSensor | None = None,
        servo: JointServo | None = None,
        modes: ModeManager | None = None,
        rate: float = 200.0,
        q0: ArrayLike | None = None,
        seed: int = 0,
        hand_time: float = HAND_TIME,
        trace_every: int = 1,
    ) -> None:
        # >= 1/MAX_MAGNITUDE: the control period must be a finite number of seconds.
        self.rate = check_range("rate", rate, low=1.0 / MAX_MAGNITUDE, low_open=False, unit="Hz")
        self._h = 1.0 / self.rate
        self.scene = pick_and_place_scene() if scene is None else scene
        if not isinstance(self.scene, Scene):
            raise InvalidParameter(f"scene: expected a Scene, got {type(self.scene).__name__}")
        self.robot = default_robot() if robot is None else _robot(robot)
        self.laser = LaserRangeSensor() if laser is None else laser
        if not isinstance(self.laser, LaserRangeSensor):
            raise InvalidParameter(
                f"laser: expected a LaserRangeSensor, got {type(self.laser).__name__}"
            )
        if modes is not None and not isinstance(modes, ModeManager):
            raise InvalidParameter(f"modes: expected a ModeManager, got {type(modes).__name__}")
        if modes is None:
            modes = ModeManager(laser=self.laser, rate=self.rate)
        elif abs(modes.rate - self.rate) > 1e-9 * self.rate:
            raise InvalidParameter(
                f"modes.rate: expected the session's control rate {self.rate:g} Hz, got "
                f"{modes.rate:g} Hz"
            )
        self.modes = modes
        self.servo: JointServo = (
            FirstOrderServo(time_constant=0.010, joint_limits=self.robot.joint_limits)
            if servo is None
            else servo
        )
        if not isinstance(self.servo, JointServo):
            raise InvalidParameter(
                f"servo: expected a JointServo (reset, step, q, command), got "
                f"{type(self.servo).__name__}"
            )
        if self.servo.command != "position":
            raise InvalidParameter(
                f"servo.command: expected 'position' (joint angles), got {self.servo.command!r}"
            )
        self.resolver = ResolvedRate(self.robot, on_invalid="stop")
        self.hand_time = check_positive("hand_time", hand_time, allow_zero=True, unit="s")
        self._trace_every = check_positive_int("trace_every", trace_every, maximum=MAX_STEPS)
        self.seed = int(check_seed("seed", seed))
        self._q0 = ready_pose(self.robot)[0] if q0 is None else _vec6(q0)
        names = self.scene.names
        cup = self.scene["cup"] if "cup" in names else None
        self._cup0: Cylinder | None = cup if isinstance(cup, Cylinder) else None
        dest = self.scene["destination"] if "destination" in names else None
        self._dest: Disk | None = dest if isinstance(dest, Disk) else None
        table = self.scene["table"] if "table" in names else None
        self._table: Plane | None = table if isinstance(table, Plane) else None
        self._boxes = tuple((n, p) for n, p in self.scene.items() if isinstance(p, Box))
        self.reset()

    # ------------------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to the start: ready pose, teleoperation disengaged, hand open, cup in place."""
        self._k = 0
        self._t_goal = 0.0
        q = np.array(self.servo.reset(self._q0), dtype=float)
        self._q_meas = q
        self._q_cmd = np.array(self.servo.q, dtype=float)
        self._T = np.asarray(self.robot.fk(self._q_meas), dtype=float)
        self._T_true = np.asarray(self.robot.fk(self.servo.q), dtype=float)
        self.modes.reset()
        self._stream: LaserStream = self.laser.stream(seed=self.seed)
        self._lin = np.zeros(3)
        self._ang = np.zeros(3)
        self._hand = "open"
        self._hand_until = 0.0
        self._holding = False
        self._grip: FloatArray | None = None  # cup bottom in the tool frame, homogeneous (4,)
        self._cup = None if self._cup0 is None else np.array(self._cup0.base_center, dtype=float)
        self._laser_scene = self.scene
        self._scene_cup = None if self._cup is None else self._cup.copy()
        self._done = False
        self._placements = 0
        self._grasps = 0
        self._misses = 0
        self._collisions = 0
        self._contact: set[str] = set()
        self._collision_log: list[tuple[float, str]] = []
        self._events: list[ModeEvent] = []
        self._status_extra: str | None = None
        self._trace: list[tuple[float, ...]] = []
        self._record_trace()

    @property
    def t(self) -> float:
        """Session time [s]."""
        return self._k * self._h

    @property
    def q(self) -> FloatArray:
        """True joint angles [rad], shape (6,)."""
        return np.array(self.servo.q, dtype=float)

    @property
    def pose(self) -> FloatArray:
        """Measured tool (frame 6) pose, shape (4, 4): what the control layer sees."""
        return np.array(self._T)

    @property
    def true_pose(self) -> FloatArray:
        """True tool (frame 6) pose, shape (4, 4): where the beam and the hand really are."""
        return np.array(self._T_true)

    @property
    def tip(self) -> FloatArray:
        """True fingertip point [m], shape (3,): ``GRIPPER_LENGTH`` along :math:`z_6`."""
        T = self._T_true
        return np.asarray(T[:3, 3] + GRIPPER_LENGTH * T[:3, 2], dtype=float)

    @property
    def events(self) -> tuple[ModeEvent, ...]:
        """Every mode-manager and hand event, in order."""
        return tuple(self._events)

    @property
    def collisions(self) -> int:
        """Collision events so far (see the module docstring)."""
        return self._collisions

    @property
    def collision_log(self) -> tuple[tuple[float, str], ...]:
        """``(t, primitive name)`` of every collision event."""
        return tuple(self._collision_log)

    @property
    def done(self) -> bool:
        """Whether the cup has been placed on the destination."""
        return self._done

    @property
    def holding(self) -> bool:
        """Whether the hand holds the cup."""
        return self._holding

    @property
    def cup(self) -> FloatArray | None:
        """Centre of the cup's bottom [m], shape (3,), or ``None`` without a cup."""
        return None if self._cup is None else np.array(self._cup)

    @property
    def trace(self) -> FloatArray:
        """Logged ``(t, x, y, z, tip_x, tip_y, tip_z, engaged, autonomous)`` rows, shape (K, 9).

        ``x, y, z`` is the wrist centre (frame 6, the thesis's end effector, whose path Fig. 74
        plots) [m]; ``engaged`` 1.0 while the clutch is engaged; ``autonomous`` 1.0 during a
        segment.
        """
        return np.array(self._trace, dtype=float).reshape(-1, 9)

    @property
    def grasps(self) -> int:
        """Successful grasps."""
        return self._grasps

    @property
    def missed_grasps(self) -> int:
        """Hand closures that did not catch the cup."""
        return self._misses

    # ------------------------------------------------------------------------------ protocol
    def press(self, key: str) -> None:
        """Press a key: ``A S F D G P T`` (modes), ``C`` (clutch), ``H`` (hand); case-insensitive.

        Raises:
            InvalidInput: an unknown key (the message lists the valid ones).
        """
        if not isinstance(key, str) or key.upper() not in SESSION_KEYS:
            raise InvalidInput(f"key: expected one of {list(SESSION_KEYS)}, got {describe(key)}")
        k = key.upper()
        t = self.t
        self._status_extra = None
        if k == "H":
            self._toggle_hand(t)
            return
        reading = self._stream.last
        distance = None if reading is None else reading.distance
        self._events.extend(self.modes.press(k, t=t, pose=self._T, distance=distance))

    def jog(self, linear: ArrayLike, angular: ArrayLike) -> None:
        """Set the master hand's velocity, held until the next call.

        Args:
            linear: Linear velocity in the PUMA base frame [m/s], shape (3,).
            angular: Angular velocity in the PUMA base frame [rad/s], shape (3,).

        Raises:
            InvalidInput: wrong shapes or non-finite values.
        """
        self._lin = real_array("linear [m/s]", linear, (3,))
        self._ang = real_array("angular [rad/s]", angular, (3,))

    def advance(self, dt: float) -> None:
        """Advance the world by ``dt`` [s] in control cycles of ``1/rate``.

        Time not filling a whole cycle carries over to the next call, so many short calls add up
        exactly.

        Raises:
            InvalidInput: ``dt`` negative or not finite.
        """
        d = check_positive("dt", dt, allow_zero=True, unit="s", error=InvalidInput)
        if d > 0.0:  # bounded before any cycle runs: no hang, no overflow on 1e308
            step_count("dt", d, "1/rate", self._h, max_steps=MAX_ADVANCE_CYCLES, error=InvalidInput)
        self._t_goal += d
        n = math.floor(self._t_goal * self.rate + 1e-9) - self._k
        for _ in range(max(n, 0)):
            self._step()

    def observe(self) -> Observation:
        """What the operator perceives now (cheap; no JSON conversion)."""
        reading = self._stream.last
        hit = self.laser.true_hit(self._T_true, self._laser_scene)
        seg_busy = self.modes.busy
        return Observation(
            t=self.t,
            pose=np.array(self._T_true),
            tip=self.tip,
            spot=None if hit is None else np.array(hit.point),
            distance=None if reading is None else reading.distance,
            settled=False if reading is None else reading.settled,
            mode=self.modes.mode,
            clutch=self.modes.clutch,
            busy=seg_busy,
            hand=self._hand,
            holding=self._holding,
            done=self._done,
            cup=np.full(3, math.nan) if self._cup is None else np.array(self._cup),
            legs_done=self.modes.legs_done,
            status=self.status,
        )

    @property
    def status(self) -> str:
        """The status message for the operator's display."""
        return self._status_extra or self.modes.status

    def snapshot(self) -> dict[str, Any]:
        """The state as a JSON-able dict (see the module docstring for the protocol).

        Keys: ``t`` [s], ``mode``, ``clutch``, ``q`` (6 angles [rad]), ``joints`` (points from
        the base to frame 6 [m]), ``tool`` (4×4 nested list), ``gripper`` (``start``/``end``
        [m]), ``laser`` (``origin``, ``point`` or ``None``, ``distance`` or ``None``),
        ``fixture`` (``start``/``end`` of the 'S'/'F' line or ``None``), ``segment`` (kind of
        the running autonomous segment or ``None``), ``status``, ``destination``,
        ``plane_points``, ``task`` (``holding``, ``done``, ``hand``, ``collisions``, ``cup``:
        bottom centre [m] or ``None``).
        """
        q = self.servo.q
        T = self._T_true
        origin, _ = self.laser.beam(T)
        hit = self.laser.true_hit(T, self._laser_scene)
        reading = self._stream.last
        line = self.modes.line
        seg = self.modes.segment
        dest = self.modes.destination
        return {
            "t": float(self.t),
            "mode": self.modes.mode,
            "clutch": bool(self.modes.clutch),
            "q": _floats(q),
            "joints": _floats(self.robot.chain.joint_positions(q)),
            "tool": _floats(T),
            "gripper": {
                "start": _floats(T[:3, 3]),
                "end": _floats(T[:3, 3] + GRIPPER_LENGTH * T[:3, 2]),
            },
            "laser": {
                "origin": _floats(origin),
                "point": None if hit is None else _floats(hit.point),
                "distance": None if reading is None else reading.distance,
            },
            "fixture": None
            if line is None
            else {"start": _floats(line[0]), "end": _floats(line[1])},
            "segment": None if seg is None else seg.kind,
            "status": self.status,
            "destination": None if dest is None else _floats(dest),
            "plane_points": [_floats(p) for p in self.modes.plane_points],
            "task": {
                "holding": bool(self._holding),
                "done": bool(self._done),
                "hand": self._hand,
                "collisions": int(self._collisions),
                "cup": None if self._cup is None else _floats(self._cup),
            },
        }

    def scene_primitives(self) -> list[dict[str, Any]]:
        """The scene as built, JSON-able: :func:`~velfence.apps.teleop.scene.scene_to_dicts`.

        The graspable cup (if any) is marked ``"dynamic": True``; its live position is the
        snapshot's ``task["cup"]`` (bottom centre [m], ``None`` without a cup).
        """
        return scene_to_dicts(self.scene, dynamic=("cup",) if self._cup0 is not None else ())

    # ------------------------------------------------------------------------------ stepping
    def _step(self) -> None:
        self._k += 1
        t = self._k * self._h
        cup, seen = self._cup, self._scene_cup
        if cup is not None and seen is not None and float(np.max(np.abs(cup - seen))) > 5e-4:
            self._rebuild_laser_scene()
        self._stream.poll(t, self._T_true, self._laser_scene)
        n_events = len(self.modes.events)
        twist = self.modes.control(t=t, pose=self._T, linear=self._lin, angular=self._ang)
        if len(self.modes.events) > n_events:
            self._events.extend(self.modes.events[n_events:])
        if twist.any():
            qdot = self.resolver.step(self._q_meas, twist)
            q_cmd = self._q_cmd + self._h * qdot
            lim = self.robot.joint_limits
            self._q_cmd = np.clip(q_cmd, lim[:, 0], lim[:, 1])
        self._q_meas = np.array(self.servo.step(self._q_cmd, self._h), dtype=float)
        self._T = np.asarray(self.robot.fk(self._q_meas), dtype=float)
        self._T_true = np.asarray(self.robot.fk(self.servo.q), dtype=float)
        self._update_hand(t)
        self._update_contacts(t)
        if self._k % self._trace_every == 0:
            self._record_trace()

    def _record_trace(self) -> None:
        p = self._T_true[:3, 3]
        tip = self.tip
        self._trace.append(
            (
                self.t,
                float(p[0]),
                float(p[1]),
                float(p[2]),
                float(tip[0]),
                float(tip[1]),
                float(tip[2]),
                1.0 if self.modes.clutch else 0.0,
                1.0 if self.modes.busy else 0.0,
            )
        )

    def _rebuild_laser_scene(self) -> None:
        if self._cup0 is None or self._cup is None:
            return
        cup = Cylinder(self._cup, radius=self._cup0.radius, height=self._cup0.height)
        prims = {n: (cup if p is self._cup0 else p) for n, p in self.scene.items()}
        self._laser_scene = Scene(prims)
        self._scene_cup = self._cup.copy()

    # ------------------------------------------------------------------------------ hand / task
    def _hand_event(self, t: float, message: str) -> None:
        ev = ModeEvent(t=t, key="H", kind="hand", message=message, mode=self.modes.mode)
        self._events.append(ev)
        self._status_extra = message

    def _toggle_hand(self, t: float) -> None:
        if self._hand in ("closing", "opening"):
            self._hand_event(t, f"H ignored: the hand is {self._hand}")
            return
        self._hand = "closing" if self._hand == "open" else "opening"
        self._hand_until = t + self.hand_time
        self._hand_event(t, f"hand {self._hand}")
        self._update_hand(t)

    def _update_hand(self, t: float) -> None:
        if self._hand in ("open", "closed") or t + 1e-12 < self._hand_until:
            if self._holding and self._grip is not None:
                self._cup = (self._T_true @ self._grip)[:3]
            return
        if self._hand == "closing":
            self._hand = "closed"
            if self._cup is not None and not self._done and self._graspable():
                self._holding = True
                self._grasps += 1
                T_inv = np.linalg.inv(self._T_true)
                self._grip = T_inv @ np.append(self._cup, 1.0)
                self._hand_event(t, "hand closed: cup grasped")
            else:
                self._misses += 1
                self._hand_event(t, "hand closed: missed the cup")
            return
        self._hand = "open"
        if self._holding and self._cup is not None:
            self._holding = False
            self._grip = None
            self._release(t)
        else:
            self._hand_event(t, "hand open")

    def _graspable(self) -> bool:
        if self._cup0 is None or self._cup is None:
            return False
        tip = self.tip
        top = float(self._cup[2]) + self._cup0.height
        radial = math.hypot(float(tip[0] - self._cup[0]), float(tip[1] - self._cup[1]))
        tilt = math.acos(max(-1.0, min(1.0, -float(self._T_true[2, 2]))))
        depth = top - float(tip[2])
        return radial <= GRASP_RADIAL and 0.005 <= depth <= GRASP_DEPTH and tilt <= GRASP_TILT

    def _release(self, t: float) -> None:
        cup = self._cup
        if cup is None:  # pragma: no cover - guarded by the caller
            return
        floor = float(self._table.point[2]) if self._table is not None else float(cup[2])
        drop = float(cup[2]) - floor
        self._cup = np.array([cup[0], cup[1], floor], dtype=float)
        on_mark = False
        if self._dest is not None:
            off = math.hypot(
                float(self._cup[0] - self._dest.center[0]),
                float(self._cup[1] - self._dest.center[1]),
            )
            on_mark = off <= self._dest.radius
        else:
            off = math.nan
        if on_mark and -0.005 <= drop <= PLACE_DROP:
            self._done = True
            self._placements += 1
            self._hand_event(
                t, f"hand open: cup placed on the destination ({1e3 * off:.0f} mm off the cross)"
            )
        else:
            self._hand_event(
                t,
                f"hand open: cup released {1e3 * drop:.0f} mm above the table, "
                f"{1e3 * off:.0f} mm from the cross (not placed)",
            )

    def _contact_points(self) -> list[FloatArray]:
        pts = [self.tip]
        if self._holding and self._cup is not None and self._cup0 is not None:
            r = self._cup0.radius
            c = self._cup
            pts.extend(
                np.array([c[0] + dx, c[1] + dy, c[2]])
                for dx, dy in ((0.0, 0.0), (r, 0.0), (-r, 0.0), (0.0, r), (0.0, -r))
            )
        return pts

    def _update_contacts(self, t: float) -> None:
        pts = self._contact_points()
        now: set[str] = set()
        for name, box in self._boxes:
            if any(box.contains(p) for p in pts):
                now.add(name)
        if self._table is not None:
            ztop = float(self._table.point[2])
            for p in pts:
                if float(p[2]) < ztop - 1e-3 and self._table.distance((p[0], p[1], ztop)) == 0.0:
                    now.add("table")
                    break
        for name in now - self._contact:
            self._collisions += 1
            self._collision_log.append((t, name))
        self._contact = now


def _robot(robot: Any) -> Puma560:
    if not isinstance(robot, Puma560):
        raise InvalidParameter(f"robot: expected a Puma560, got {type(robot).__name__}")
    return robot


def _vec6(x: ArrayLike) -> FloatArray:
    return real_array("q0 [rad]", x, (6,), error=InvalidParameter)
