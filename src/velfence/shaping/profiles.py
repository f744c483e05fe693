r"""Approach profiles: the admissible approach speed toward a constraint as a function of distance.

A profile maps the signed distance :math:`\delta` to a constraint (positive inside) to a **cap** on
the approach speed toward it: a shaper lets the normal velocity toward the constraint be at most
``cap(δ, speed)``. Inside the cap is >= 0 and vanishes on the boundary; outside it is negative, i.e.
a forced return speed. The same object serves the polygon shaper (linear buffer of
US 8,676,382) and the joint-stop limiter (three-zone braking of Lê et al. 2024); derivations in
``docs/derivations.md`` §4.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from velfence._docs import document_inits
from velfence._validate import MAX_MAGNITUDE, check_positive, finite_scalar
from velfence.errors import InvalidInput, InvalidParameter
from velfence.shaping._kernels import PROFILE_LINEAR, PROFILE_THREE_ZONE, profile_cap

__all__ = ["ApproachProfile", "LinearBuffer", "ThreeZoneBraking", "min_change_under_caps"]


@runtime_checkable
class ApproachProfile(Protocol):
    """Admissible approach speed toward a constraint at signed distance ``delta``."""

    def cap(self, delta: float, speed: float = 0.0) -> float:
        """Largest allowed approach speed [units/s]; negative means a forced return.

        Args:
            delta: Signed distance to the constraint, positive inside [units].
            speed: The command's speed [units/s] (profiles that scale with it use it).
        """
        ...

    def zone(self, delta: float) -> int:
        """Zone index of ``delta`` (profile-specific; 0 means unconstrained)."""
        ...


def _delta(delta: float) -> float:
    """``delta`` checked: a plain finite float passes at once (the shapers' inner loops)."""
    if type(delta) is float and -MAX_MAGNITUDE <= delta <= MAX_MAGNITUDE:
        return delta
    return finite_scalar("delta", delta, unit="units", what="signed distance")


def _speed(speed: float) -> float:
    """``speed`` checked: a finite real number >= 0 (plain floats take the fast path)."""
    if type(speed) is float and 0.0 <= speed <= MAX_MAGNITUDE:
        return speed
    x = finite_scalar("speed", speed, unit="units/s", what="speed")
    if x < 0.0:
        raise InvalidInput(f"speed: expected a speed >= 0 [units/s], got {x:g}; pass |v|")
    return x


@dataclass(frozen=True, kw_only=True)
class LinearBuffer:
    r"""US 8,676,382's buffer: approach speed at most :math:`\|v\|\,\delta/d_{max}` inside.

    Inside the buffer the cap grows linearly from 0 on the boundary to the command's own speed at
    the inner boundary (a command straight into the edge is scaled by :math:`\delta/d_{max}`, the
    patent's step 110); beyond it nothing is limited. Outside, the cap is the negative recovery
    speed :math:`-\min(k\,|\delta|, r_{max})`. Used with the exact law it equals the built-in
    ``PolygonShaper(buffer=…)`` inside the polygon; outside, the built-in law also relaxes the
    non-violated edges by the recovery speed R (derivations.md §3), which a per-edge profile
    cannot see.

    Every parameter is keyword-only (``LinearBuffer(buffer=0.1)``); numeric strings and booleans
    are refused.

    Attributes:
        buffer: Buffer width :math:`d_{max}` [units], > 0.
        spring_gain: Recovery gain k outside [1/s], >= 0.
        max_recovery_speed: Cap on the recovery speed [units/s]; default ``spring_gain * buffer``.
    """

    buffer: float
    spring_gain: float = 0.0
    max_recovery_speed: float | None = None
    _params: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        d = check_positive("buffer", self.buffer, unit="units")
        k = check_positive("spring_gain", self.spring_gain, allow_zero=True, unit="1/s")
        object.__setattr__(self, "buffer", d)
        object.__setattr__(self, "spring_gain", k)
        if self.max_recovery_speed is not None:
            r = check_positive("max_recovery_speed", self.max_recovery_speed, unit="units/s")
            object.__setattr__(self, "max_recovery_speed", r)
        object.__setattr__(self, "_params", (d, k, self.recovery_cap, 0.0, 0.0, 0.0))

    @property
    def kernel_profile(self) -> tuple[int, tuple[float, ...]]:
        """``(kind, params)``: this profile as the compiled shaping kernels read it.

        ``kind`` is the linear-buffer code, ``params`` is ``(buffer, spring_gain,
        recovery_cap, 0, 0, 0)``; the cap is evaluated by the same kernel function either way.
        """
        return PROFILE_LINEAR, self._params

    @property
    def recovery_cap(self) -> float:
        """The recovery speed cap actually used [units/s]."""
        if self.max_recovery_speed is None:
            return self.spring_gain * self.buffer
        return self.max_recovery_speed

    def cap(self, delta: float, speed: float = 0.0) -> float:
        """See :class:`ApproachProfile` (``math.inf``, no cap, beyond the buffer).

        Raises:
            InvalidInput: ``delta`` or ``speed`` not a finite real number, or ``speed < 0``.
        """
        return profile_cap(PROFILE_LINEAR, self._params, False, _delta(delta), _speed(speed))

    def zone(self, delta: float) -> int:
        """0 beyond the buffer, 1 inside it, 2 outside the constraint."""
        delta = _delta(delta)
        return 0 if delta >= self.buffer else (1 if delta >= 0.0 else 2)


@dataclass(frozen=True, kw_only=True)
class ThreeZoneBraking:
    r"""Lê et al. 2024 eq. (4): nominal / maximal deceleration / linear approach.

    .. math::
        \mathrm{cap}(\delta) = \begin{cases}
          \mathrm{sgn}(\delta)\, v_{max} & |\delta| > \delta_\varphi \quad\text{(zone 3)}\\
          \mathrm{sgn}(\delta)\sqrt{2 a_{max}\,\big||\delta| - \delta_f\big|}
             & \delta_{int} < |\delta| \le \delta_\varphi \quad\text{(zone 2)}\\
          K\,\delta & |\delta| \le \delta_{int} \quad\text{(zone 1)}
        \end{cases}

    with :math:`\delta_{int} = a_{max}/K^2`, :math:`\delta_f = \delta_{int}/2` and
    :math:`\delta_\varphi = \delta_f + v_{max}^2/(2 a_{max})`: the cap is C¹ at
    :math:`\delta_{int}` (the line :math:`K\delta` is tangent to the braking parabola),
    continuous at :math:`\delta_\varphi`, and riding it decelerates at exactly :math:`a_{max}` in
    zone 2.

    Every parameter is keyword-only:
    ``ThreeZoneBraking(gain=100, max_speed=2.83, max_acceleration=28.3)`` (positionally, a
    swapped speed and acceleration would silently give a wrong profile).
    Parameters whose derived thresholds would overflow or underflow (e.g. ``gain=1e-200``) are
    refused, naming the parameters, and so is ``max_speed <= max_acceleration/gain`` (the linear
    zone would then end above ``max_speed``).

    Attributes:
        gain: K [1/s], > 0 (zone-1 time constant 1/K; a discrete loop needs K·Te < 1).
        max_speed: Nominal maximum normal speed [units/s], > 0.
        max_acceleration: Maximum normal deceleration [units/s²], > 0.
    """

    gain: float
    max_speed: float
    max_acceleration: float
    delta_int: float = field(init=False)
    delta_f: float = field(init=False)
    delta_phi: float = field(init=False)
    _params: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        K = check_positive("gain", self.gain, unit="1/s")
        v = check_positive("max_speed", self.max_speed, unit="units/s")
        a = check_positive("max_acceleration", self.max_acceleration, unit="units/s²")
        # Store plain floats (NumPy scalars in, floats out) so every derived value is a float.
        object.__setattr__(self, "gain", K)
        object.__setattr__(self, "max_speed", v)
        object.__setattr__(self, "max_acceleration", a)
        # a/K² as (a/K)/K: K² alone overflows (OverflowError) for K > 1e154 and underflows to 0
        # (ZeroDivisionError) for K < 1e-162. Inputs are <= 1e150, so each quotient is finite or
        # inf, never an exception; inf or a subnormal result is refused below.
        d_int = (a / K) / K
        if not (math.isfinite(d_int) and d_int >= sys.float_info.min):
            raise InvalidParameter(
                f"gain={K:g} 1/s with max_acceleration={a:g} units/s²: the linear zone width "
                f"δ_int = max_acceleration/gain² = {d_int:g} is not a usable positive number; "
                "choose gain and max_acceleration with max_acceleration/gain² between 1e-307 and "
                "1e307 (e.g. gain=100, max_acceleration=28.3)"
            )
        if not v > a / K:
            # Then δ_φ < δ_int: the linear zone would end above max_speed and the cap would jump
            # down to max_speed at δ_φ (neither continuous nor bounded by max_speed).
            raise InvalidParameter(
                f"max_speed={v:g} units/s must exceed max_acceleration/gain = {a:g}/{K:g} = "
                f"{a / K:g} units/s (the speed at the top of the linear zone); raise max_speed or "
                "gain, or lower max_acceleration"
            )
        brake = (v / a) * (0.5 * v)  # v²/(2a) without forming v² (finite for finite inputs)
        d_phi = 0.5 * d_int + brake
        if not math.isfinite(d_phi):
            raise InvalidParameter(
                f"max_speed={v:g} units/s with max_acceleration={a:g} units/s²: the braking "
                "distance max_speed²/(2·max_acceleration) overflows; lower max_speed or raise "
                "max_acceleration"
            )
        object.__setattr__(self, "delta_int", d_int)
        object.__setattr__(self, "delta_f", 0.5 * d_int)
        object.__setattr__(self, "delta_phi", d_phi)
        object.__setattr__(self, "_params", (K, v, a, d_int, 0.5 * d_int, d_phi))

    @property
    def kernel_profile(self) -> tuple[int, tuple[float, ...]]:
        """``(kind, params)``: this profile as the compiled shaping kernels read it.

        ``kind`` is the three-zone code, ``params`` is ``(gain, max_speed, max_acceleration,
        delta_int, delta_f, delta_phi)``; the cap is evaluated by the same kernel function either
        way.
        """
        return PROFILE_THREE_ZONE, self._params

    @classmethod
    def from_actuator_limits(
        cls, *, gain: float, max_speed: float, max_acceleration: float
    ) -> ThreeZoneBraking:
        r"""The paper's profile for identical actuators (eq. 3).

        The joint-velocity cube projects on the auxiliary plane to a hexagon containing the disk
        of radius :math:`\sqrt2\,\dot\theta_{max}`, so :math:`v_{max} = \sqrt2\,\dot\theta_{max}`
        and :math:`a_{max} = \sqrt2\,\ddot\theta_{max}`.

        Args:
            gain: K [1/s].
            max_speed: :math:`\dot\theta_{max}` [rad/s].
            max_acceleration: :math:`\ddot\theta_{max}` [rad/s²].
        """
        r2 = math.sqrt(2.0)
        speed = check_positive("max_speed", max_speed, unit="rad/s")
        accel = check_positive("max_acceleration", max_acceleration, unit="rad/s²")
        try:
            return cls(gain=gain, max_speed=r2 * speed, max_acceleration=r2 * accel)
        except InvalidParameter as exc:  # name the arguments the caller passed
            raise InvalidParameter(
                f"max_speed={speed:g} rad/s, max_acceleration={accel:g} rad/s² "
                f"(max_speed = √2·max_speed, max_acceleration = √2·max_acceleration): {exc}"
            ) from None

    def check_period(self, dt: float) -> None:
        """Raise if the zone-1 discrete loop ``δ[k+1] = (1 − K·dt) δ[k]`` would not converge.

        Args:
            dt: Control period [s].
        """
        dt = check_positive("dt", dt, unit="s")
        if not self.gain * dt < 1.0:
            raise InvalidParameter(
                f"gain·dt must be < 1 for the linear zone to converge in discrete time, got "
                f"K={self.gain} 1/s, dt={dt} s (K·dt={self.gain * dt:g}); lower K or dt"
            )

    def cap(self, delta: float, speed: float = 0.0) -> float:
        """See :class:`ApproachProfile` (``speed`` is checked but not used).

        Raises:
            InvalidInput: ``delta`` or ``speed`` not a finite real number, or ``speed < 0``.
        """
        delta = _delta(delta)
        _speed(speed)
        return profile_cap(PROFILE_THREE_ZONE, self._params, False, delta, 0.0)

    def zone(self, delta: float) -> int:
        """The paper's zone flag of ``|δ|``: 3 nominal, 2 maximal deceleration, 1 linear.

        As in the paper, the flag depends on ``|δ|`` only: outside (``δ < 0``) zone 3 means a
        forced return at ``max_speed``, not free motion; read the sign of ``δ`` alongside.
        """
        a = abs(_delta(delta))
        return 3 if a > self.delta_phi else (2 if a > self.delta_int else 1)


def min_change_under_caps(
    vx: float,
    vy: float,
    deltas: Sequence[float],
    nx: Sequence[float],
    ny: Sequence[float],
    profile: ApproachProfile,
) -> tuple[float, float, bool]:
    r"""The exact multi-constraint law with any profile: minimum change under every cap at once.

    .. math::
        v_o = \arg\min_x \|x - v\|^2 \ \text{s.t.}\ n_k\cdot x \ge -\mathrm{cap}(\delta_k, \|v\|)

    for every constraint with a finite cap (inward unit normals ``n_k``; outside, ``-cap > 0``
    forces the return). Solved in closed form by the 2-D projection of the exact polygon law. If
    the caps cannot all hold (a region thinner than the braking distance), the violated
    constraints' return bounds are slowed (1/4, 1/16, ..., 4**-8, then "no further out") while
    every cap of a constraint the point is inside is kept, as in the kernels.

    Args:
        vx: Command, x component [units/s].
        vy: Command, y component [units/s].
        deltas: Signed distance to each constraint, positive inside [units].
        nx: Inward unit normals, x components.
        ny: Inward unit normals, y components.
        profile: The approach profile.

    Returns:
        ``(x, y, relaxed)``: the shaped velocity, and whether the caps were infeasible together
        so that the violated constraints' return bounds were slowed.
    """
    from velfence.shaping._kernels import RELAX_STEPS, _solve

    speed = math.hypot(vx, vy)
    caps = [profile.cap(d, speed) for d in deltas]
    work = [k for k, cp in enumerate(caps) if math.isfinite(cp)]
    bnd = [-cp if math.isfinite(cp) else -math.inf for cp in caps]
    ok, ox, oy = _solve(vx, vy, work, len(work), nx, ny, bnd)
    if ok:
        return ox, oy, False
    if not any(deltas[k] < 0.0 for k in work):
        return 0.0, 0.0, False  # inside, zero meets every cap: reached only by round-off
    for r in range(RELAX_STEPS):
        for k in work:
            if deltas[k] < 0.0 and bnd[k] > 0.0:
                bnd[k] = bnd[k] * 0.25 if r + 1 < RELAX_STEPS else 0.0
        ok, ox, oy = _solve(vx, vy, work, len(work), nx, ny, bnd)
        if ok:
            return ox, oy, True
    return 0.0, 0.0, True  # pragma: no cover - zero meets every bound once they are relaxed


document_inits(globals())
