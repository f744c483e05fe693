r"""Cobot simulation: the human chooses the speed, the controller only steers.

Two simulators, both recording a :class:`CobotTrace`:

* :func:`follow_in_ee` — the generic C_EE model, in arc length: :math:`R' = T`,
  :math:`T' = \kappa N` with :math:`\kappa N` held over each step ``ds``; ``integrator="arc"``
  advances exactly along the circular arc of that curvature (no drift off :math:`|T| = 1`),
  ``"euler"`` is the explicit Euler step. Time does not appear: this is the model the controller
  is designed on.
* :func:`simulate_cobot` — the full four-space cobot in time. The state is the joint configuration
  q and the steering angles φ; the plant moves along the one allowed direction (forward route,
  :meth:`~velfence.cobot.model.Cobot.heading`) at the human's speed, the controller runs every
  ``dt`` on the measured (R, T, ds), and its steering rates (inverse route,
  :meth:`~velfence.cobot.model.Cobot.steering_rates`) are held over the period (zero-order hold,
  as a steering motor's velocity command). The plant is integrated with classical RK4 inside each
  period.

Why not :func:`velfence.sim.simulate`: that runner integrates a *commanded velocity*; a cobot's
controller commands *steering rates* and the velocity magnitude is an exogenous human input, so the
state (q, φ, controller reference) and the integration differ. The caster-mode wall, which is a
velocity shaper, does run on :func:`velfence.sim.simulate` (see the cobot reproduction).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Literal, Protocol, get_args

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    check_choice,
    check_positive,
    finite_scalar,
    real_array,
    step_count,
)
from velfence.cobot.model import Cobot, Route
from velfence.errors import InvalidInput, InvalidParameter
from velfence.sim.runner import Trajectory

__all__ = [
    "CobotTrace",
    "HeadingController",
    "SpeedFn",
    "constant_speed",
    "follow_in_ee",
    "pushing",
    "simulate_cobot",
]

Integrator = Literal["arc", "euler"]


#: The human: ``(t, R, T) -> u``, the signed speed [m/s] along the allowed direction T.
SpeedFn = Callable[[float, FloatArray, FloatArray], float]


class _HasKN(Protocol):
    @property
    def kN(self) -> FloatArray: ...


class HeadingController(Protocol):
    """A steering controller: ``step(R, T, ds, t)`` returns an object with ``kN`` (shape (n,))."""

    def step(self, R: ArrayLike, T: ArrayLike, ds: float, t: float | None = None) -> Any:
        """Curvature command for the measured state and the arc length travelled since last."""
        ...


def constant_speed(u: float) -> SpeedFn:
    """A human pushing at constant speed ``u`` [m/s], >= 0, along whatever direction is allowed.

    A backward push is a direction, not a negative speed: use :func:`pushing` with the intended
    velocity (a negative constant speed would flip the heading every tick).

    Args:
        u: The speed [m/s], finite and >= 0.

    Returns:
        The speed function ``(t, R, T) -> u`` for :func:`simulate_cobot`.

    Raises:
        InvalidParameter: ``u`` not a finite number >= 0.
    """
    v = check_positive("u", u, allow_zero=True, unit="m/s")

    def speed(t: float, R: FloatArray, T: FloatArray) -> float:
        return v

    return speed


def pushing(intent: Callable[[float, FloatArray], ArrayLike]) -> SpeedFn:
    r"""A human pushing with intended velocity ``intent(t, R)``: speed :math:`u = T^\top v_h`.

    Args:
        intent: The intended velocity ``(t, R) -> v_h`` [m/s], of the shape of ``R``.

    Returns:
        The speed function ``(t, R, T) -> T·v_h`` for :func:`simulate_cobot`.

    Raises:
        InvalidParameter: ``intent`` is not callable.
        InvalidInput: (when called) ``intent`` returned a velocity that is not a finite vector of
            the shape of ``T``.
    """
    if not callable(intent) or isinstance(intent, type):
        raise InvalidParameter(
            f"intent: expected a function (t, R) -> velocity, got {type(intent).__name__}"
        )

    def speed(t: float, R: FloatArray, T: FloatArray) -> float:
        Ta = np.asarray(T, dtype=float)
        v = real_array("intent(t, R)", intent(t, R), Ta.shape, what="a velocity [m/s]")
        return float(Ta @ v)

    return speed


@dataclass
class CobotTrace:
    r"""A recorded cobot run (rows are control ticks).

    Attributes:
        s: Arc length travelled [m], shape (N,).
        R: End-effector configuration, shape (N, n).
        T: Heading, shape (N, n).
        kN: Curvature command, shape (N, n).
        t: Time [s], shape (N,) (the arc-length model: equal to ``s``).
        q: Joint configuration, shape (N, n) (empty for the C_EE model).
        phi: Steering angles [rad], shape (N, n-1) (empty for the C_EE model).
        phi_dot: Steering rates [rad/s], shape (N, n-1) (empty for the C_EE model).
        error: Path error :math:`\Delta R` when the controller is a path follower, shape (N, n).
        reference: :math:`R_p(s_p)` when the controller is a path follower, shape (N, n).
        s_p: Reference arc length when the controller is a path follower, shape (N,).
        singular: Whether the follower's M guard acted, shape (N,).
        zone: Wall zone per tick for wall steering (else empty).
        name: Label.
    """

    s: FloatArray
    R: FloatArray
    T: FloatArray
    kN: FloatArray
    t: FloatArray
    _: KW_ONLY
    q: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    phi: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    phi_dot: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    error: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    reference: FloatArray = field(default_factory=lambda: np.zeros((0, 0)))
    s_p: FloatArray = field(default_factory=lambda: np.zeros(0))
    singular: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    zone: tuple[str, ...] = ()
    name: str = ""

    @property
    def error_norm(self) -> FloatArray:
        r""":math:`|\Delta R|` per tick, shape (N,)."""
        return np.asarray(np.linalg.norm(self.error, axis=1), dtype=float)

    def to_trajectory(self, v_cmd: ArrayLike | None = None) -> Trajectory:
        """The run as a :class:`~velfence.sim.Trajectory` (for :mod:`velfence.sim.metrics`).

        ``v_out`` is the realised velocity :math:`(R_{k+1} - R_k)/(t_{k+1} - t_k)` (the last row
        repeats); ``v_cmd`` defaults to it (e.g. pass the human's intent instead).
        """
        if self.t.shape[0] >= 2:
            v = np.diff(self.R, axis=0) / np.diff(self.t)[:, None]
            v = np.vstack([v, v[-1:]])
        else:
            v = np.zeros_like(self.R)
        zone = self.zone if len(self.zone) == self.t.shape[0] else None
        cmd = v if v_cmd is None else real_array("v_cmd", v_cmd, v.shape, what="velocities")
        return Trajectory(self.t, self.R, cmd, v, zone=zone, name=self.name)

    def at_arc_length(self, s: ArrayLike) -> FloatArray:
        """Positions R interpolated at arc lengths ``s`` [m], shape (M, n)."""
        S = _arc_lengths(s)
        return np.stack([np.interp(S, self.s, self.R[:, j]) for j in range(self.R.shape[1])], 1)

    def error_at(self, s: ArrayLike) -> FloatArray:
        r""":math:`|\Delta R|` interpolated at arc lengths ``s`` [m], shape (M,)."""
        S = _arc_lengths(s)
        return np.asarray(np.interp(S, self.s, self.error_norm), dtype=float)


def _arc_lengths(s: ArrayLike) -> FloatArray:
    """Arc lengths to interpolate at: one number or a non-empty (M,) vector."""
    S = real_array("s", s, what="arc lengths [m]")
    if S.ndim > 1 or S.size == 0:
        raise InvalidInput(
            f"s: expected an arc length or a non-empty vector of shape (M,), got shape {S.shape}"
        )
    return np.atleast_1d(S)


class _Recorder:
    def __init__(self) -> None:
        self.rows: dict[str, list[Any]] = {}

    def add(self, **kw: Any) -> None:
        for k, v in kw.items():
            self.rows.setdefault(k, []).append(v)

    def array(self, key: str) -> FloatArray:
        return np.array(self.rows[key], dtype=float) if key in self.rows else np.zeros((0, 0))


def _record_output(rec: _Recorder, out: Any) -> None:
    extra: dict[str, Any] = {}
    if hasattr(out, "error"):
        extra.update(
            error=np.array(out.error),
            reference=np.array(out.reference),
            s_p=out.s_p,
            singular=out.singular,
        )
    if hasattr(out, "zone"):
        extra["zone"] = out.zone
    rec.add(kN=np.array(out.kN), **extra)


def _trace(rec: _Recorder, name: str) -> CobotTrace:
    r = rec.rows
    return CobotTrace(
        s=rec.array("s"),
        R=rec.array("R"),
        T=rec.array("T"),
        kN=rec.array("kN"),
        t=rec.array("t"),
        q=rec.array("q"),
        phi=rec.array("phi"),
        phi_dot=rec.array("phi_dot"),
        error=rec.array("error"),
        reference=rec.array("reference"),
        s_p=np.array(r.get("s_p", []), dtype=float),
        singular=np.array(r.get("singular", []), dtype=bool),
        zone=tuple(r.get("zone", ())),
        name=name,
    )


def _controller(controller: Any) -> HeadingController:
    if not callable(getattr(controller, "step", None)):
        raise InvalidParameter(
            "controller: expected a heading controller with step(R, T, ds, t) (e.g. a "
            f"PathFollower), got {type(controller).__name__}"
        )
    return controller  # type: ignore[no-any-return]


def _kN(out: Any, n: int) -> FloatArray:
    """The controller's curvature command, validated (a bad controller must not corrupt R)."""
    kN = getattr(out, "kN", None)
    if kN is None:
        raise InvalidInput(
            f"controller.step(...): expected an output with a kN attribute, got "
            f"{type(out).__name__}"
        )
    return real_array("controller.step(...).kN", kN, (n,), what="a curvature vector")


def _label(name: Any) -> str:
    if not isinstance(name, str):
        raise InvalidParameter(f"name: expected a str label, got {type(name).__name__}")
    return name


def _unit(name: str, x: ArrayLike, n: int | None = None) -> FloatArray:
    a = real_array(name, x, None if n is None else (n,), what="a direction")
    if a.ndim != 1:
        raise InvalidInput(f"{name}: expected shape ({n or 'n'},), got shape {a.shape}")
    m = float(np.linalg.norm(a))
    if m == 0.0:
        raise InvalidInput(f"{name}: expected a non-zero direction, got the zero vector")
    return a / m


def follow_in_ee(
    controller: HeadingController,
    R0: ArrayLike,
    T0: ArrayLike,
    *,
    length: float,
    ds: float = 1e-3,
    integrator: Integrator = "arc",
    name: str = "C_EE",
) -> CobotTrace:
    r"""Run a heading controller on the generic C_EE model in arc length (module docs).

    Args:
        controller: E.g. a :class:`~velfence.cobot.follower.PathFollower` (already reset).
        R0: Initial configuration, shape (n,).
        T0: Initial heading, shape (n,) (normalised).
        length: Arc length to travel [m], > 0.
        ds: Step [m], > 0.
        integrator: ``"arc"`` (exact for curvature held over the step) or ``"euler"``.
        name: Trace label.

    Returns:
        The :class:`CobotTrace` of the run (one row per arc-length step).

    Raises:
        InvalidInput: bad initial configuration or heading, or a controller output that is not
            a finite curvature of the right shape.
        InvalidParameter: a length, step or integrator out of range.
    """
    _controller(controller)
    R = real_array("R0", R0, (None,), what="a configuration")
    if R.shape[0] == 0:
        raise InvalidInput("R0: expected a configuration of shape (n,) with n >= 1, got shape (0,)")
    T = _unit("T0", T0)
    if T.shape != R.shape:
        raise InvalidInput(
            f"T0: expected shape {R.shape}, the shape of R0, got shape {T.shape} (R0 and T0 must "
            "have the same length)"
        )
    steps = step_count("length", length, "ds", ds)
    h = check_positive("ds", ds, unit="m")
    check_choice("integrator", integrator, get_args(Integrator))
    label = _label(name)
    rec = _Recorder()
    s = 0.0
    step_ds = 0.0
    for _ in range(steps + 1):
        out = controller.step(R, T, step_ds, s)
        rec.add(s=s, t=s, R=R.copy(), T=T.copy())
        try:
            kN = _kN(out, R.shape[0])
        except InvalidInput as e:
            raise InvalidInput(
                f"the run from R0, T0 stopped at s = {s:g} m: {e} (the controller diverged; "
                "start closer to its path or lower its gains)"
            ) from None
        _record_output(rec, out)
        if integrator == "euler":
            R = R + h * T
            T = T + h * kN
            T = T / np.linalg.norm(T)
        else:
            k = float(np.linalg.norm(kN))
            if k * h < 1e-12:
                R = R + h * T + 0.5 * h * h * kN
            else:
                N = kN / k
                a = k * h
                R = R + T * (math.sin(a) / k) + N * ((1.0 - math.cos(a)) / k)
                T = T * math.cos(a) + N * math.sin(a)
        s += h
        step_ds = h
    return _trace(rec, label)


def simulate_cobot(
    cobot: Cobot,
    controller: HeadingController,
    q0: ArrayLike,
    phi0: ArrayLike,
    *,
    speed: SpeedFn,
    duration: float,
    dt: float = 1e-3,
    heading0: ArrayLike | None = None,
    route: Route = "direct",
    name: str | None = None,
) -> CobotTrace:
    r"""Run a cobot in time: human speed in, steering rates out (module docs).

    Args:
        cobot: The mechanism and its CVTs.
        controller: Heading controller (reset beforehand), e.g. a path follower.
        q0: Initial joint configuration, shape (n,).
        phi0: Initial steering angles [rad], shape (n-1,) (see
            :meth:`~velfence.cobot.model.Cobot.steering_angles`).
        speed: The human, ``(t, R, T) -> u`` [m/s] (:func:`constant_speed`, :func:`pushing`):
            the signed speed along the direction T it is given. A negative value means the
            human pushes backward: the heading is flipped (it is the motion's direction) and
            the speed is read again along it, where it must not be negative.
        duration: Simulated time [s], > 0.
        dt: Control period [s], > 0.
        heading0: Resolves the initial sign of the allowed direction, shape (n,); the sign of
            :math:`\Lambda` when ``None``.
        route: ``"direct"`` or ``"joint"`` steering transform (same answer).
        name: Trace label (default: the cobot's name).

    Returns:
        The :class:`CobotTrace` of the run (one row per control period).

    Raises:
        InvalidInput: The cobot reaches a singular configuration (named) or bad input.
    """
    if not isinstance(cobot, Cobot):
        raise InvalidParameter(f"cobot: expected a Cobot, got {type(cobot).__name__}")
    _controller(controller)
    n = cobot.dim
    q = real_array("q0", q0, (n,), what="joint angles")
    phi = real_array("phi0", phi0, (n - 1,), what="steering angles [rad]")
    steps = step_count("duration", duration, "dt", dt)
    h = check_positive("dt", dt, unit="s")
    if h > float(duration):
        raise InvalidParameter(f"dt: expected a step <= duration = {duration:g} s, got {h:g} s")
    check_choice("route", route, ("direct", "joint"))
    if not callable(speed) or isinstance(speed, type):
        raise InvalidParameter(
            f"speed: expected a function (t, R, T) -> u, got {type(speed).__name__}"
        )
    label = cobot.name if name is None else (_label(name) or cobot.name)
    ref0 = None if heading0 is None else real_array("heading0", heading0, (n,))

    def human(tt: float, Rr: FloatArray, Tt: FloatArray) -> float:
        return finite_scalar("speed(t, R, T)", speed(tt, Rr, Tt), unit="m/s", what="speed")

    kin = cobot.kinematics

    def heading(qq: FloatArray, pp: FloatArray, ref: FloatArray | None) -> FloatArray:
        hd = cobot.heading(qq, pp, reference=ref)
        if hd.singular:
            raise InvalidInput(
                f"the cobot reached a singular configuration ({hd.singular}) at q={qq.tolist()}, "
                f"phi={pp.tolist()}: the allowed direction is undefined there"
            )
        return hd.T

    try:
        T = heading(q, phi, ref0)
    except InvalidInput as e:
        raise InvalidInput(f"q0, phi0: no allowed direction at the start: {e}") from None
    rec = _Recorder()
    s = 0.0
    ds = 0.0
    t = 0.0
    for k in range(steps + 1):
        t = k * h
        R = kin.position(q)
        u_now = human(t, R, T)
        if u_now < 0.0:  # the human pushes backward: the heading is the motion's direction
            T = -T
            u_now = human(t, R, T)
            if u_now < 0.0:
                raise InvalidInput(
                    f"speed: negative along both T and -T at t = {t:g} s; the human model must "
                    "give the signed speed along the direction it is given (e.g. pushing(intent)"
                    "), a direction-blind negative speed would flip the heading every tick"
                )
        out = controller.step(R, T, ds, t)
        kN = _kN(out, n)
        st = cobot.steering_rates(R, phi, T, kN, abs(u_now), route=route)
        rec.add(s=s, t=t, R=R, T=T.copy(), q=q.copy(), phi=phi.copy(), phi_dot=st.phi_dot)
        _record_output(rec, out)
        if k == steps:
            break
        # RK4 over one period, steering rates held (ZOH); y = (q, phi, s).
        T_ref = T

        def f(
            tt: float, qq: FloatArray, pp: FloatArray, ref: FloatArray = T_ref
        ) -> tuple[FloatArray, float, FloatArray]:
            Rr = kin.position(qq)
            Tt = heading(qq, pp, ref)
            u = abs(human(tt, Rr, Tt))
            return kin.jacobian(Rr) @ Tt * u, u, Tt

        rate = st.phi_dot
        k1q, k1s, _ = f(t, q, phi)
        k2q, k2s, _ = f(t + h / 2, q + h / 2 * k1q, phi + h / 2 * rate)
        k3q, k3s, _ = f(t + h / 2, q + h / 2 * k2q, phi + h / 2 * rate)
        k4q, k4s, _ = f(t + h, q + h * k3q, phi + h * rate)
        q = q + h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        phi = phi + h * rate
        ds = h / 6 * (k1s + 2 * k2s + 2 * k3s + k4s)
        s += ds
        T = heading(q, phi, T_ref)
    return _trace(rec, label)


document_inits(globals())
