r"""Straight-line Cartesian trajectories and their self-correcting execution (Khokar 2009 §6.2.1).

**Generator** (:func:`straight_line`). From pose :math:`T_0 = [R_0\,|\,X_0]` to
:math:`T_1 = [R_1\,|\,X_1]` the thesis places :math:`N` via points

.. math::

    X_i = X_0\,\frac{N - i}{N} + X_1\,\frac{i}{N}, \qquad
    R_i = R_0\,\mathrm{Rot}\!\left(k, \tfrac{i}{N}\phi\right), \qquad i = 0 … N,

with :math:`(k, \phi)` the equivalent angle-axis of :math:`R_0^\top R_1` (repair T6 of
``docs/telerobotics.md`` §8: subscripts ``_r``, ``sign()``, magnitudes compared, cumulative
angle ``iφ/N``). The position moves along the segment at constant speed and the orientation turns
about **one fixed axis** (:math:`R_0 k` in the base frame) at constant rate. Three quantities the
thesis merges or leaves out are kept separate here:

* ``spacing`` [m] — the largest distance between consecutive via points (the thesis's
  :math:`V_r\,dt` with :math:`dt = 1` ms);
* ``rate`` [Hz] — how fast via points are played back (the thesis's 200 Hz trajectory thread),
  so the speed is :math:`D/N \cdot` ``rate`` :math:`\le` ``spacing · rate``;
* ``angular_spacing`` [rad] — the duration rule for pure rotations, which the thesis lacks
  (its :math:`N = D/(V_r dt)` is 0 when :math:`D = 0`, e.g. the 'T'+'A' alignment).

:math:`N` (``timing="linear"``, faithful) is :math:`\lceil D/\text{spacing}\rceil`, or
:math:`\lceil\phi/\text{angular\_spacing}\rceil` when the translation is below ``min_distance``;
``timing="max"`` (improved) takes the larger of the two so that neither speed exceeds its
bound. Always :math:`N \ge 1`.

**Executor** (:func:`execute`). Each cycle of period :math:`h = 1/\text{rate}` the increment is
formed from the arm's **measured** pose :math:`T_m = \mathrm{FK}(q_m)` to the **next** via point
(§6.2.1, Fig. 40), turned into joint rates by resolved rate and accumulated onto the commanded
joints, which a joint servo then tracks:

.. math::

    \dot x = \frac{1}{h}\,e(T_m, T_{c+1}), \qquad
    \dot q = J^{\#}(q_m)\,\dot x, \qquad q_c \leftarrow q_c + h\,\dot q,

where :math:`e` is :func:`velfence.apps.teleop.resolved_rate.pose_error` and :math:`J^{\#}` the
resolver's inverse. Motor error therefore does not accumulate (the thesis's self-correction).
``feedback="commanded"`` is the thesis's routine as printed (steps 16-18: FK on the *commanded*
angles, blind to servo error), ``feedback="none"`` via-to-via increments (open-loop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import BoolArray, FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    MAX_STEPS,
    check_choice,
    check_positive,
    check_positive_int,
    finite_scalar,
    readonly,
    real_array,
)
from velfence.apps.teleop.resolved_rate import (
    ORIENTATION_ERRORS,
    OrientationError,
    ResolvedRate,
    _pose,
    angle_axis,
    manipulability_of,
    pose_error,
    rotation_from_angle_axis,
)
from velfence.apps.teleop.servo import FirstOrderServo, JointServo
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.geometry.primitives import points_segments_distances

__all__ = [
    "CartesianTrajectory",
    "Execution",
    "PoseArm",
    "execute",
    "straight_line",
]


Timing = Literal["linear", "max"]
TIMINGS: tuple[Timing, ...] = get_args(Timing)
#: Most via-point steps of one trajectory (83 min at 200 Hz; 2 km at the default spacing).
MAX_VIA_STEPS = 1_000_000
#: Most servo steps per trajectory cycle.
MAX_SUBSTEPS = 10_000
Feedback = Literal["measured", "commanded", "none"]
FEEDBACKS: tuple[Feedback, ...] = get_args(Feedback)


@runtime_checkable
class PoseArm(Protocol):
    """What the executor needs of an arm: forward kinematics and the base-frame Jacobian."""

    def fk(self, q: ArrayLike) -> FloatArray:
        """Tool pose in the base frame, shape (4, 4) [m]."""
        ...

    def jacobian(self, q: ArrayLike) -> FloatArray:
        """Base-frame geometric Jacobian ``[v; ω] = J q̇``, shape (6, n)."""
        ...


def _count(x: float) -> int:
    """``ceil(x)`` that does not add a via point for a quotient a rounding error above an int."""
    return math.ceil(x - 1e-9 * max(1.0, x))


@dataclass(frozen=True, eq=False)
class CartesianTrajectory:
    r"""A straight-line Cartesian trajectory: via points, their times and the nominal twist.

    Built by :func:`straight_line`; all arrays are read-only.

    Attributes:
        start: Start pose :math:`T_0`, shape (4, 4) [m].
        end: End pose :math:`T_1`, shape (4, 4) [m].
        times: Via-point times :math:`t_i = i/\text{rate}` [s], shape (N + 1,).
        poses: Via points :math:`T_i` (module docs), shape (N + 1, 4, 4); ``poses[0]`` is
            ``start`` and ``poses[N]`` is ``end`` exactly.
        twists: Nominal twist ``[v; ω]`` held over ``[t_i, t_{i+1})`` in the base frame
            [m/s; rad/s], shape (N + 1, 6); constant, and zero on the last row (at rest).
        axis: Rotation axis in the base frame, unit, shape (3,) (``(0, 0, 1)`` when
            ``angle = 0``).
        angle: Total rotation :math:`\phi \in [0, \pi]` [rad].
        distance: Straight-line length :math:`D = \lVert X_1 - X_0\rVert` [m].
        rate: Playback rate [Hz].
    """

    start: FloatArray
    end: FloatArray
    times: FloatArray
    poses: FloatArray
    twists: FloatArray
    axis: FloatArray
    angle: float
    distance: float
    rate: float

    @property
    def n_steps(self) -> int:
        """Number of via-point steps ``N`` (there are ``N + 1`` via points)."""
        return int(self.times.shape[0] - 1)

    @property
    def duration(self) -> float:
        """``N / rate`` [s]."""
        return float(self.times[-1])

    @property
    def positions(self) -> FloatArray:
        """Via-point positions [m], shape (N + 1, 3) (a read-only view)."""
        return self.poses[:, :3, 3]

    @property
    def speed(self) -> float:
        """Translation speed ``D / duration`` [m/s]."""
        return self.distance / self.duration

    @property
    def angular_speed(self) -> float:
        """Rotation rate ``φ / duration`` [rad/s]."""
        return self.angle / self.duration

    def sample(self, t: float) -> FloatArray:
        """Pose at time ``t`` on the continuous line (between via points too).

        Args:
            t: Time [s]; clamped into ``[0, duration]``.

        Returns:
            Homogeneous transform, shape (4, 4).

        Raises:
            InvalidInput: ``t`` is not a finite number.
        """
        tf = finite_scalar("t", t, unit="s", what="time")
        s = min(max(tf / self.duration, 0.0), 1.0)
        return _interpolate(self.start, self.end, self.axis, self.angle, s)


def _interpolate(
    T0: FloatArray, T1: FloatArray, axis_base: FloatArray, angle: float, s: float
) -> FloatArray:
    """Pose at fraction ``s`` of the line: lerp of positions, rotation ``s·φ`` about the axis."""
    T = np.eye(4)
    # X0 (1 - s) + X1 s, written so that a pure rotation keeps X0 bit for bit.
    T[:3, 3] = T0[:3, 3] + s * (T1[:3, 3] - T0[:3, 3])
    # R0 Rot(k, sφ) = Rot(R0 k, sφ) R0: one fixed axis in the base frame too.
    T[:3, :3] = rotation_from_angle_axis(axis_base, s * angle) @ T0[:3, :3]
    return T


def straight_line(
    T0: ArrayLike,
    T1: ArrayLike,
    *,
    spacing: float = 0.002,
    rate: float = 200.0,
    angular_spacing: float = 0.0025,
    timing: Timing = "linear",
    min_distance: float = 1e-9,
) -> CartesianTrajectory:
    r"""Straight-line trajectory from ``T0`` to ``T1`` (Khokar 2009 §6.2.1; module docs).

    Args:
        T0: Start pose, shape (4, 4) [m] (rotation block orthonormal, det +1).
        T1: End pose, shape (4, 4) [m].
        spacing: Largest distance between consecutive via points [m], ``> 0``. The default
            2 mm at 200 Hz is 0.4 m/s, the speed inferred from the thesis's §7.4 timings (the
            thesis never states :math:`V_r`). For a speed ``V`` at ``rate`` use ``V / rate``.
        rate: Playback rate of the via points [Hz], ``> 0`` (thesis: 200 Hz).
        angular_spacing: Largest rotation between consecutive via points [rad], ``> 0``; sets
            the duration of pure rotations (default 2.5 mrad: 0.5 rad/s at 200 Hz, our choice;
            the thesis gives none).
        timing: ``"linear"`` (faithful: the translation sets ``N`` unless it is below
            ``min_distance``) or ``"max"`` (the larger of the translational and angular counts).
        min_distance: Translation [m], ``>= 0``, below which a trajectory counts as a pure
            rotation.

    Returns:
        The immutable :class:`CartesianTrajectory`.

    Raises:
        InvalidInput: a pose that is not a finite homogeneous transform.
        InvalidParameter: an out-of-range parameter.
    """
    sp = check_positive("spacing", spacing, unit="m")
    hz = check_positive("rate", rate, unit="Hz")
    if hz < 1.0 / MAX_MAGNITUDE:  # the via-point period (and so the duration) must stay finite
        raise InvalidParameter(f"rate: expected a rate >= {1.0 / MAX_MAGNITUDE:g} Hz, got {hz:g}")
    asp = check_positive("angular_spacing", angular_spacing, unit="rad")
    how = check_choice("timing", timing, TIMINGS)
    dmin = check_positive("min_distance", min_distance, allow_zero=True, unit="m")
    A = _pose("T0", T0)
    B = _pose("T1", T1)
    k, phi = angle_axis(A[:3, :3].T @ B[:3, :3])
    axis_base = A[:3, :3] @ k
    dist = float(np.linalg.norm(B[:3, 3] - A[:3, 3]))
    for name, count, value in (("spacing", dist / sp, sp), ("angular_spacing", phi / asp, asp)):
        if not count <= MAX_VIA_STEPS:
            raise InvalidParameter(
                f"{name}: {value:g} needs {count:.3g} via-point steps for this trajectory; at "
                f"most {MAX_VIA_STEPS:,} are allowed: increase {name}"
            )
    n_lin = _count(dist / sp)
    n_ang = _count(phi / asp)
    # "linear": the translation sets N (thesis); a pure rotation falls back to the angle.
    N = max(n_lin, n_ang, 1) if how == "max" else max(n_ang if dist <= dmin else n_lin, 1)
    poses = np.empty((N + 1, 4, 4))
    for i in range(N + 1):
        poses[i] = _interpolate(A, B, axis_base, phi, i / N)
    poses[0] = A
    poses[N] = B
    duration = N / hz
    twists = np.zeros((N + 1, 6))
    twists[:N, :3] = (B[:3, 3] - A[:3, 3]) / duration
    twists[:N, 3:] = axis_base * (phi / duration)
    return CartesianTrajectory(
        start=readonly(A),
        end=readonly(B),
        times=readonly(np.arange(N + 1) / hz),
        poses=readonly(poses),
        twists=readonly(twists),
        axis=readonly(axis_base),
        angle=phi,
        distance=dist,
        rate=hz,
    )


@dataclass(frozen=True, eq=False)
class Execution:
    r"""A trajectory run on a simulated arm, one row per trajectory cycle (read-only arrays).

    Row ``c`` is the state at ``t[c] = c / rate`` and what the executor commanded from there;
    ``qdot[c]`` acts over ``[t[c], t[c+1])`` and the last row's ``qdot`` is zero.

    Attributes:
        t: Times [s], shape (K,).
        q: Measured joint angles (what the executor saw) [rad], shape (K, n).
        q_true: True joint angles of the servo [rad], shape (K, n).
        q_cmd: Commanded joint angles [rad], shape (K, n).
        qdot: Joint rates from resolved rate [rad/s], shape (K, n).
        w: Manipulability at the joints resolved rate was evaluated at — the feedback joints:
            the measured ones (``q``) for ``feedback="measured"``, the commanded ones
            (``q_cmd``) for ``"commanded"`` and ``"none"`` — shape (K,)
            (:func:`~velfence.apps.teleop.resolved_rate.manipulability_of`).
        det: Signed Jacobian determinant at the same joints, shape (K,) (NaN for a non-square
            Jacobian).
        k: SR damping used, shape (K,).
        stopped: Whether resolved rate refused the step (``on_invalid="stop"``), shape (K,).
        position: True tool position :math:`\mathrm{FK}(q_{true})` [m], shape (K, 3).
        reference: The via point due at ``t[c]`` (``poses[min(c, N)]``) position [m], (K, 3).
        tracking_error: ``|position - reference|`` [m], shape (K,) (the thesis's Table 3
            "error in trajectory points").
        orientation_error: Angle between the true and the due orientation [rad], shape (K,).
        path_deviation: Distance from the true position to the segment ``start → end`` [m],
            shape (K,).
        feedback: The executor's feedback mode.
    """

    t: FloatArray
    q: FloatArray
    q_true: FloatArray
    q_cmd: FloatArray
    qdot: FloatArray
    w: FloatArray
    det: FloatArray
    k: FloatArray
    stopped: BoolArray
    position: FloatArray
    reference: FloatArray
    tracking_error: FloatArray
    orientation_error: FloatArray
    path_deviation: FloatArray
    feedback: str

    @property
    def max_speed(self) -> float:
        """Largest commanded joint rate magnitude over the run [rad/s]."""
        return float(np.max(np.abs(self.qdot)))


def execute(
    trajectory: CartesianTrajectory,
    robot: PoseArm,
    q0: ArrayLike,
    *,
    resolver: ResolvedRate | None = None,
    servo: JointServo | None = None,
    feedback: Feedback = "measured",
    substeps: int = 5,
    settle: int = 0,
    orientation: OrientationError = "angle_axis",
    correction_gain: float = 1.0,
) -> Execution:
    r"""Run ``trajectory`` on ``robot`` through resolved rate and a joint servo (module docs).

    Args:
        trajectory: The via points to follow (:func:`straight_line`).
        robot: Arm with ``fk(q) -> (4, 4)`` and ``jacobian(q) -> (6, n)`` (e.g.
            :class:`velfence.mechanisms.puma560.Puma560`).
        q0: Initial joint angles [rad], shape (n,); the servo is reset there. ``FK(q0)`` need
            not equal ``trajectory.start`` (the self-correction absorbs an offset).
        resolver: Resolved-rate law; default ``ResolvedRate(robot)`` (SR inverse, thesis
            parameters).
        servo: Joint servo standing in for the arm; default perfect tracking
            (``FirstOrderServo(time_constant=0)``). It is reset to ``q0``.
        feedback: ``"measured"`` (self-correcting, default), ``"commanded"`` (thesis steps 16-18
            as printed) or ``"none"`` (via-to-via increments, open loop).
        substeps: Servo steps per trajectory cycle (int ``>= 1``; 5 = the thesis's 1 kHz servo
            under its 200 Hz trajectory thread).
        settle: Extra cycles after the last via point, aiming at the end pose (int ``>= 0``).
        orientation: Orientation error of the increment, ``"angle_axis"`` or ``"cross"`` (see
            :func:`velfence.apps.teleop.resolved_rate.pose_error`).
        correction_gain: Fraction :math:`\lambda \in (0, 1]` of the deviation from the due via
            point corrected per cycle (``"measured"``/``"commanded"`` feedback): the increment
            is :math:`e(T_m, T_{c+1}) - (1 - \lambda)\,e(T_m, T_c)`, i.e. the nominal via-point
            step plus :math:`\lambda` times the deviation. 1 (default) is the thesis's
            increment; a smaller gain keeps the loop stable on a slow servo (the accumulation
            onto the commanded joints is an integral action that a servo lag of several cycles
            destabilises at gain 1).

    Returns:
        The :class:`Execution` record, ``N + settle + 1`` rows.

    Raises:
        InvalidParameter: an out-of-range option or an arm without ``fk``/``jacobian``.
        InvalidInput: a bad ``q0``; and whatever the resolver raises (e.g. a singular
            Jacobian under ``inverse="jinv"`` with ``on_invalid="raise"``).
    """
    if not isinstance(trajectory, CartesianTrajectory):
        raise InvalidParameter(
            f"trajectory: expected a CartesianTrajectory, got {type(trajectory).__name__}"
        )
    if not (callable(getattr(robot, "fk", None)) and callable(getattr(robot, "jacobian", None))):
        raise InvalidParameter(
            f"robot: expected an arm with fk(q) and jacobian(q), got {type(robot).__name__}"
        )
    mode = check_choice("feedback", feedback, FEEDBACKS)
    how = check_choice("orientation", orientation, ORIENTATION_ERRORS)
    lam = check_positive("correction_gain", correction_gain)
    if lam > 1.0:
        raise InvalidParameter(f"correction_gain: expected a value in (0, 1], got {lam!r}")
    sub = check_positive_int("substeps", substeps, maximum=MAX_SUBSTEPS, example=5)
    extra = check_positive_int("settle", settle, minimum=0, maximum=MAX_VIA_STEPS, example=0)
    total = (trajectory.n_steps + extra + 1) * sub
    if total > MAX_STEPS:
        raise InvalidParameter(
            f"substeps={sub} and settle={extra} need {total:,} servo steps; at most "
            f"{MAX_STEPS:,} are allowed: lower substeps or settle"
        )
    q_start = real_array("q0 [rad]", q0, (None,), what="joint angles")
    try:
        robot.fk(q_start)
    except VelfenceError as exc:  # the arm's own message names its internal argument
        raise InvalidInput(f"q0: not a configuration of this robot: {exc}") from None
    rr = ResolvedRate(robot) if resolver is None else resolver
    if not isinstance(rr, ResolvedRate):
        raise InvalidParameter(f"resolver: expected a ResolvedRate, got {type(rr).__name__}")
    sv: JointServo = FirstOrderServo(time_constant=0.0) if servo is None else servo
    if not isinstance(sv, JointServo):
        raise InvalidParameter(
            f"servo: expected a JointServo (reset, step, q, command), got {type(sv).__name__}"
        )
    if sv.command not in ("position", "velocity"):
        raise InvalidParameter(
            f"servo.command: expected 'position' or 'velocity', got {sv.command!r}"
        )

    N = trajectory.n_steps
    h = 1.0 / trajectory.rate
    dt = h / sub
    K = N + extra + 1
    q_m = np.array(sv.reset(q_start), dtype=float)
    n = q_m.shape[0]
    q_cmd = np.array(sv.q, dtype=float)

    Q = np.empty((K, n))
    Qt = np.empty((K, n))
    Qc = np.empty((K, n))
    Qd = np.zeros((K, n))
    W = np.empty(K)
    Det = np.empty(K)
    Kd = np.zeros(K)
    stop = np.zeros(K, dtype=bool)
    P = np.empty((K, 3))
    Rerr = np.empty(K)
    poses = trajectory.poses

    for c in range(K):
        due = poses[min(c, N)]
        Q[c], Qt[c], Qc[c] = q_m, sv.q, q_cmd
        T_true = robot.fk(Qt[c])
        P[c] = T_true[:3, 3]
        Rerr[c] = angle_axis(T_true[:3, :3].T @ due[:3, :3])[1]
        if c == K - 1:
            J = np.asarray(robot.jacobian(q_m if mode == "measured" else q_cmd), dtype=float)
            Det[c] = float(np.linalg.det(J)) if J.shape[0] == J.shape[1] else math.nan
            W[c] = manipulability_of(J)
            break
        target = poses[min(c + 1, N)]
        if mode == "measured":
            q_fb, T_fb = q_m, robot.fk(q_m)
        elif mode == "commanded":
            q_fb, T_fb = q_cmd, robot.fk(q_cmd)
        else:
            q_fb, T_fb = q_cmd, due
        dX = pose_error(T_fb, target, orientation=how)
        if lam != 1.0 and mode != "none":
            dX = dX - (1.0 - lam) * pose_error(T_fb, due, orientation=how)
        res = rr.explain(q_fb, dX / h)
        Qd[c], W[c], Det[c], Kd[c], stop[c] = res.qdot, res.w, res.det, res.k, res.stopped
        q_cmd = q_cmd + h * res.qdot
        cmd = q_cmd if sv.command == "position" else res.qdot
        for _ in range(sub):
            q_m = np.array(sv.step(cmd, dt), dtype=float)

    ref = poses[np.minimum(np.arange(K), N), :3, 3]
    start, end = trajectory.start[:3, 3], trajectory.end[:3, 3]
    _, deviation = points_segments_distances(P, start[None], end[None])
    return Execution(
        t=readonly(np.arange(K, dtype=float) * h),
        q=readonly(Q),
        q_true=readonly(Qt),
        q_cmd=readonly(Qc),
        qdot=readonly(Qd),
        w=readonly(W),
        det=readonly(Det),
        k=readonly(Kd),
        stopped=readonly(stop),
        position=readonly(P),
        reference=readonly(np.array(ref)),
        tracking_error=readonly(np.asarray(np.linalg.norm(P - ref, axis=1), dtype=float)),
        orientation_error=readonly(Rerr),
        path_deviation=readonly(deviation[:, 0]),
        feedback=mode,
    )
