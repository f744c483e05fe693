r"""Joint-servo stand-ins for the real PUMA 560 (Khokar 2009 §3.1.1, §3.5.2).

The thesis's arm is driven by a 1 kHz PD + gravity-compensation joint controller whose gains and
gravity model are not given (§3.5.2). The trajectory layer only sees *where the joints got to*,
so a simulation needs a servo model between the commanded and the measured joint angles:

* :class:`FirstOrderServo` — every joint follows its command through a first-order lag of time
  constant :math:`\tau`, discretised exactly for a command held over the step
  (zero-order hold):

  .. math:: q \leftarrow q_c + (q - q_c)\,e^{-\Delta t/\tau}

  (``command="position"``), or the joint *velocity* follows the commanded rate with that lag
  and the position integrates it (``command="velocity"``). :math:`\tau = 0` is perfect
  tracking. It is the simplest stand-in that separates command from measurement. Its lag is
  **not fitted** to the thesis: the 10 ms the session and the reproduction use is an assumption
  (the thesis gives no gains), and with it the §7.1 straight lines track to about 0.29 mm where
  the real arm showed 1.2-1.4 mm (Table 3) — an ideal lag has no friction, backlash, gravity sag,
  coupling or calibration error, so the simulated arm is about 4× more accurate than the real one.
* :class:`PDGravityServo` — the thesis's control law :math:`\tau = K_p(q_c - q) - K_d\dot q +
  \hat g(q)` on a **documented simple plant**: one rigid body per joint with constant inertia
  :math:`I_i`, viscous friction :math:`b_i` and an optional gravity torque :math:`g(q)`,

  .. math:: I\,\ddot q = \tau - b\,\dot q - g(q),

  i.e. the PUMA's coupled inertia matrix, Coriolis and centrifugal terms are **not** modelled
  (the thesis gives no dynamics to model them from). With exact compensation
  (:math:`\hat g = g`) each joint is a mass-spring-damper; a compensation error
  :math:`\hat g = (1 - e)\,g` leaves the classical static offset :math:`e\,g/K_p`.

Both add seeded Gaussian encoder noise to what they *report* (never to the true state) and clip
to optional joint limits (the joint stops there, velocity zeroed). They hold state (the joint
angles), set by :meth:`reset`; the same seed gives the same run.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal, Protocol, get_args, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    check_seed,
    describe,
    readonly,
    real_array,
    step_count,
)
from velfence.errors import InvalidInput, InvalidParameter

__all__ = ["FirstOrderServo", "JointServo", "PDGravityServo"]

GravityFn = Callable[[FloatArray], ArrayLike]
"""Gravity torque ``g(q) -> (n,)`` [N·m] at joint position ``q`` (n,) [rad]."""

ServoCommand = Literal["position", "velocity"]
COMMANDS: tuple[ServoCommand, ...] = get_args(ServoCommand)


@runtime_checkable
class JointServo(Protocol):
    """A joint servo in the loop: reset to a state, then step with a command."""

    @property
    def command(self) -> str:
        """What :meth:`step` takes: ``"position"`` [rad] or ``"velocity"`` [rad/s]."""
        ...

    @property
    def q(self) -> FloatArray:
        """True joint position [rad], shape (n,)."""
        ...

    def reset(self, q0: ArrayLike) -> FloatArray:
        """Start at rest at ``q0`` (n,) [rad]; returns the measured position (n,)."""
        ...

    def step(self, command: ArrayLike, dt: float) -> FloatArray:
        """Advance ``dt`` [s] under ``command`` (n,); returns the measured position (n,) [rad]."""
        ...


def _vec(name: str, x: ArrayLike, n: int | None, unit: str) -> FloatArray:
    """A finite 1-D vector, of length ``n`` when given, else :class:`InvalidInput`."""
    label = f"{name} {unit}"
    a = real_array(label, x, None if n is None else (n,))
    if a.ndim != 1 or a.shape[0] == 0:
        raise InvalidInput(f"{label}: expected shape (n,) with n >= 1, got shape {a.shape}")
    return a


def _per_joint(name: str, value: Any, unit: str, *, allow_zero: bool) -> FloatArray:
    """A positive scalar or 1-D array parameter, as a read-only 1-D array (length 1 if scalar)."""
    scalar = isinstance(value, np.ndarray) and value.ndim == 0
    if scalar or not isinstance(value, (list, tuple, np.ndarray)):
        return readonly(np.array([check_positive(name, value, allow_zero=allow_zero, unit=unit)]))
    a = real_array(name, value, error=InvalidParameter, what=f"a number or 1-D numbers {unit}")
    ok = (a >= 0.0) if allow_zero else (a > 0.0)
    if a.ndim != 1 or a.shape[0] == 0 or not np.all(ok):
        bound = ">= 0" if allow_zero else "> 0"
        raise InvalidParameter(
            f"{name}: expected a finite number {bound} or a 1-D array of them {unit}, got "
            f"{describe(value)}"
        )
    return readonly(a)


def _limits(value: Any) -> FloatArray | None:
    if value is None:
        return None
    a = real_array(
        "joint_limits", value, error=InvalidParameter, allow_nonfinite=True, what="numbers [rad]"
    )
    if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] == 0:
        raise InvalidParameter(
            f"joint_limits: expected shape (n, 2) (lower, upper) [rad], got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)) or np.any(a[:, 0] >= a[:, 1]):
        raise InvalidParameter(
            f"joint_limits: expected finite lower < upper on every joint [rad], got {a.tolist()}"
        )
    return readonly(a)


#: Most integration sub-steps one :meth:`PDGravityServo.step` may take.
MAX_SUBSTEPS = 1_000_000


def _seed(seed: Any) -> int:
    return int(check_seed("seed", seed))


def _dt(dt: Any) -> float:
    return check_positive("dt", dt, unit="s", error=InvalidInput)


class _ServoBase:
    """State, noise, limits and validation shared by the servos."""

    def __init__(self, *, noise_std: float, seed: int, joint_limits: Any, command: str) -> None:
        self.noise_std = check_positive("noise_std", noise_std, allow_zero=True, unit="rad")
        self.seed = _seed(seed)
        self.joint_limits = _limits(joint_limits)
        self._command = check_choice("command", command, COMMANDS)
        self._q: FloatArray | None = None
        self._qd: FloatArray | None = None
        self._rng = np.random.default_rng(self.seed)

    @property
    def command(self) -> str:
        """What :meth:`step` takes: ``"position"`` [rad] or ``"velocity"`` [rad/s]."""
        return self._command

    @property
    def q(self) -> FloatArray:
        """True joint position [rad], shape (n,), a read-only copy (shape (0,) before reset)."""
        return readonly(np.array(self._q if self._q is not None else np.zeros(0)))

    @property
    def qdot(self) -> FloatArray:
        """True joint velocity [rad/s], shape (n,), a read-only copy (shape (0,) before reset)."""
        return readonly(np.array(self._qd if self._qd is not None else np.zeros(0)))

    def _state(self) -> tuple[FloatArray, FloatArray]:
        if self._q is None or self._qd is None:
            raise InvalidInput(f"{type(self).__name__}: call reset(q0) before step()")
        return self._q, self._qd

    def _check_dims(self, n: int) -> None:
        if self.joint_limits is not None and self.joint_limits.shape[0] != n:
            raise InvalidInput(
                f"q0: expected {self.joint_limits.shape[0]} joints to match joint_limits, got {n}"
            )

    def reset(self, q0: ArrayLike) -> FloatArray:
        """Start at rest at ``q0`` and re-seed the noise.

        Args:
            q0: Initial joint position [rad], shape (n,); clipped into the joint limits.

        Returns:
            The measured joint position [rad], shape (n,).
        """
        q = _vec("q0", q0, None, "[rad]")
        self._check_dims(q.shape[0])
        self._check_params(q.shape[0])
        self._q = self._clip(q)
        self._qd = np.zeros_like(q)
        self._rng = np.random.default_rng(self.seed)
        return self._measure()

    def _check_params(self, n: int) -> None:
        """Subclasses check per-joint parameter lengths against ``n``."""

    def _clip(self, q: FloatArray) -> FloatArray:
        if self.joint_limits is None:
            return q
        return np.clip(q, self.joint_limits[:, 0], self.joint_limits[:, 1])

    def _stop_at_limits(self, q: FloatArray, qd: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.joint_limits is None:
            return q, qd
        lo, hi = self.joint_limits[:, 0], self.joint_limits[:, 1]
        hit = ((q <= lo) & (qd < 0.0)) | ((q >= hi) & (qd > 0.0)) | (q < lo) | (q > hi)
        return np.clip(q, lo, hi), np.where(hit, 0.0, qd)

    def _measure(self) -> FloatArray:
        q, _ = self._state()
        if self.noise_std == 0.0:
            return np.array(q)
        return q + self._rng.normal(0.0, self.noise_std, q.shape[0])

    def _command_vec(self, command: ArrayLike) -> FloatArray:
        q, _ = self._state()
        unit = "[rad]" if self._command == "position" else "[rad/s]"
        return _vec("command", command, q.shape[0], unit)


def _per_joint_len(name: str, a: FloatArray, n: int) -> None:
    if a.shape[0] not in (1, n):
        raise InvalidInput(f"{name}: expected a scalar or {n} values (one per joint), got {a.size}")


class FirstOrderServo(_ServoBase):
    r"""Joints that follow their command with a first-order lag (module docs).

    Args:
        time_constant: Lag :math:`\tau` [s], ``>= 0`` (0: perfect tracking), a scalar or one
            per joint.
        noise_std: Standard deviation of the Gaussian noise on the *reported* joint angles
            [rad], ``>= 0``.
        seed: Seed of the noise generator (int ``>= 0``).
        joint_limits: Optional (n, 2) lower/upper joint stops [rad].
        command: ``"position"`` (default): :meth:`step` takes commanded joint angles [rad];
            ``"velocity"``: commanded joint rates [rad/s].

    Raises:
        InvalidParameter: an out-of-range parameter.
    """

    def __init__(
        self,
        *,
        time_constant: float | ArrayLike,
        noise_std: float = 0.0,
        seed: int = 0,
        joint_limits: ArrayLike | None = None,
        command: ServoCommand = "position",
    ) -> None:
        super().__init__(noise_std=noise_std, seed=seed, joint_limits=joint_limits, command=command)
        self.time_constant = _per_joint("time_constant", time_constant, "[s]", allow_zero=True)

    def __repr__(self) -> str:
        return (
            f"FirstOrderServo(time_constant={self.time_constant.tolist()}, "
            f"noise_std={self.noise_std:g}, seed={self.seed}, command={self._command!r})"
        )

    def _check_params(self, n: int) -> None:
        _per_joint_len("time_constant", self.time_constant, n)

    def step(self, command: ArrayLike, dt: float) -> FloatArray:
        """Advance ``dt`` with ``command`` held (exact discretisation of the lag).

        Args:
            command: Joint angles [rad] or rates [rad/s] (see ``command``), shape (n,).
            dt: Time step [s], ``> 0``.

        Returns:
            Measured joint position (true + noise) [rad], shape (n,).

        Raises:
            InvalidInput: before :meth:`reset`, wrong shape, non-finite values or a bad ``dt``.
        """
        c = self._command_vec(command)
        h = _dt(dt)
        q, qd = self._state()
        tau = self.time_constant
        with np.errstate(divide="ignore", over="ignore"):
            decay = np.where(tau > 0.0, np.exp(-h / np.where(tau > 0.0, tau, 1.0)), 0.0)
        if self._command == "position":
            q_new = c + (q - c) * decay
            qd_new = (q_new - q) / h
        else:
            # ∫ v dt with v(s) = c + (v0 - c) e^{-s/τ}; (1 - e^{-h/τ})τ → 0 as τ → 0.
            q_new = q + c * h + (qd - c) * tau * (1.0 - decay)
            qd_new = c + (qd - c) * decay
        if not (np.all(np.isfinite(q_new)) and np.all(np.isfinite(qd_new))):
            raise InvalidInput(
                f"the servo state overflowed under command {c.tolist()}; expected a bounded command"
            )
        self._q, self._qd = self._stop_at_limits(q_new, qd_new)
        return self._measure()


class PDGravityServo(_ServoBase):
    r"""PD + gravity compensation on one rigid body per joint (module docs; Khokar 2009 §3.5.2).

    Control law (the thesis names it, without gains; the form is our assumption):
    :math:`\tau = \mathrm{sat}\bigl(K_p(q_c - q) - K_d\dot q + (1 - e)\,g(q)\bigr)`; plant
    :math:`I\ddot q = \tau - b\dot q - g(q)`, integrated by semi-implicit Euler with sub-steps of
    at most ``max_substep``. Velocity feed-forward :math:`\dot q_d` is taken as zero (the
    thesis sends joint angles only).

    Args:
        kp: Proportional gain [N·m/rad], ``> 0``, scalar or per joint.
        inertia: Joint inertia :math:`I` [kg·m²], ``> 0``, scalar or per joint.
        kd: Derivative gain [N·m·s/rad], ``>= 0``; default :math:`2\sqrt{K_p I}` (critical
            damping of the undamped, friction-free joint).
        friction: Viscous friction :math:`b` [N·m·s/rad], ``>= 0``.
        gravity: Plant gravity torque ``g(q) -> (n,)`` [N·m]; ``None`` for none.
        compensation_error: Fraction :math:`e` of gravity the controller fails to compensate
            (0: exact compensation; 1: plain PD).
        max_torque: Optional actuator saturation [N·m], ``> 0``, scalar or per joint.
        noise_std: Gaussian noise on the reported angles [rad], ``>= 0``.
        seed: Seed of the noise generator (int ``>= 0``).
        joint_limits: Optional (n, 2) joint stops [rad].
        max_substep: Longest integration sub-step [s], ``> 0``; keep it well below
            :math:`2\sqrt{I/K_p}` for stability.

    Raises:
        InvalidParameter: an out-of-range parameter, or ``max_substep`` too long for the gains.
    """

    def __init__(
        self,
        *,
        kp: float | ArrayLike,
        inertia: float | ArrayLike,
        kd: float | ArrayLike | None = None,
        friction: float | ArrayLike = 0.0,
        gravity: GravityFn | None = None,
        compensation_error: float = 0.0,
        max_torque: float | ArrayLike | None = None,
        noise_std: float = 0.0,
        seed: int = 0,
        joint_limits: ArrayLike | None = None,
        max_substep: float = 1e-4,
    ) -> None:
        super().__init__(
            noise_std=noise_std, seed=seed, joint_limits=joint_limits, command="position"
        )
        self.kp = _per_joint("kp", kp, "[N·m/rad]", allow_zero=False)
        self.inertia = _per_joint("inertia", inertia, "[kg·m²]", allow_zero=False)
        self.friction = _per_joint("friction", friction, "[N·m·s/rad]", allow_zero=True)
        self.max_torque = (
            None
            if max_torque is None
            else _per_joint("max_torque", max_torque, "[N·m]", allow_zero=False)
        )
        sizes = {a.size for a in (self.kp, self.inertia, self.friction)} - {1}
        if len(sizes) > 1:
            raise InvalidParameter(
                "kp, inertia, friction: expected scalars or arrays of one common length n, got "
                f"lengths {self.kp.size}, {self.inertia.size}, {self.friction.size}"
            )
        self.kd = (
            readonly(2.0 * np.sqrt(self.kp * self.inertia))
            if kd is None
            else _per_joint("kd", kd, "[N·m·s/rad]", allow_zero=True)
        )
        if len(sizes | {self.kd.size} - {1}) > 1:
            raise InvalidParameter(
                f"kd: expected a scalar or {sizes.pop()} values to match kp, got {self.kd.size}"
            )
        if gravity is not None and (not callable(gravity) or isinstance(gravity, type)):
            raise InvalidParameter(
                f"gravity: expected a callable g(q) -> (n,) [N·m] or None, got {describe(gravity)}"
            )
        self.gravity = gravity
        self.compensation_error = check_positive(
            "compensation_error", compensation_error, allow_zero=True
        )
        self.max_substep = check_positive("max_substep", max_substep, unit="s")
        # Semi-implicit Euler on I q'' = -Kp q - (Kd + b) q' is stable iff h c < 2 and
        # h² ω² + 2 h c < 4 (ω² = Kp/I, c = (Kd + b)/I); keep a factor 2 of margin.
        h = self.max_substep
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            w2 = self.kp / self.inertia  # a tiny inertia overflows: inf, refused just below
            c = (self.kd + self.friction) / self.inertia
            margin = float(np.max(h * h * w2 + 2.0 * h * c))
            h_ok = 1.0 / float(np.max(np.sqrt(w2) + c))  # meets the bound with the margin
        if not margin < 2.0:
            raise InvalidParameter(
                f"max_substep (with kp, kd, friction and inertia): expected a sub-step short "
                f"enough for these gains (below about "
                f"{h_ok:.3g} s), got {h:g} s"
            )

    def __repr__(self) -> str:
        return (
            f"PDGravityServo(kp={self.kp.tolist()}, kd={self.kd.tolist()}, "
            f"inertia={self.inertia.tolist()}, compensation_error={self.compensation_error:g})"
        )

    def _check_params(self, n: int) -> None:
        for name in ("kp", "kd", "inertia", "friction"):
            _per_joint_len(name, getattr(self, name), n)
        if self.max_torque is not None:
            _per_joint_len("max_torque", self.max_torque, n)

    def _g(self, q: FloatArray) -> FloatArray:
        if self.gravity is None:
            return np.zeros_like(q)
        g = self.gravity(np.array(q))
        return _vec("gravity(q)", g, q.shape[0], "[N·m]")

    def step(self, command: ArrayLike, dt: float) -> FloatArray:
        """Advance ``dt`` with the joint-angle command held.

        Args:
            command: Commanded joint angles [rad], shape (n,).
            dt: Time step [s], ``> 0``; split into sub-steps of at most ``max_substep``.

        Returns:
            Measured joint position (true + noise) [rad], shape (n,).

        Raises:
            InvalidInput: before :meth:`reset`, wrong shape, non-finite values or a bad ``dt``.
        """
        c = self._command_vec(command)
        h = _dt(dt)
        q, qd = self._state()
        m = step_count(
            "dt", h, "max_substep", self.max_substep, max_steps=MAX_SUBSTEPS, error=InvalidInput
        )
        hs = h / m
        for _ in range(m):
            g = self._g(q)
            tau = self.kp * (c - q) - self.kd * qd + (1.0 - self.compensation_error) * g
            if self.max_torque is not None:
                tau = np.clip(tau, -self.max_torque, self.max_torque)
            qdd = (tau - self.friction * qd - g) / self.inertia
            qd = qd + hs * qdd
            q, qd = self._stop_at_limits(q + hs * qd, qd)
        self._q, self._qd = q, qd
        return self._measure()
