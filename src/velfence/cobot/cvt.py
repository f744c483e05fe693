r"""Continuously variable transmissions: steering angle ↔ allowed direction in a coupling space.

A CVT i constrains the two speeds of its coupling space :math:`\Sigma_i` to one ratio set by its
steering angle :math:`\varphi_i` (Gillespie et al. 1999, §2.3). Each model gives

* the **forward map** :math:`\varphi_i \to t_i(\varphi_i)`, the allowed direction (up to sign);
* its **angle rate** :math:`d\psi/d\varphi`, where :math:`\psi` is the polar angle of
  :math:`t_i`;
* the **inverse map** :math:`\varphi \leftarrow t` (which steering angle allows a direction);
* the **steering rate** for a wanted coupling-space curvature:
  :math:`\dot\varphi_i = \kappa_i\,\dot s_i / (d\psi/d\varphi)`, with
  :math:`\kappa_i = (W t_i)^\top \kappa_i n_i` the signed curvature and
  :math:`\dot s_i = t_i^\top S_i V_J` the signed coupling-space speed (eq. 2.18's bracket).

Since the curvature of a direction is the rate of turn of its angle per unit arc length,
:math:`\dot\psi = \kappa_i \dot s_i`, so the one formula gives eq. (2.15) for the steered wheel
(:math:`d\psi/d\varphi = 1`) and eq. (2.18) for the tetrahedral CVT
(:math:`d\psi/d\varphi = \sqrt2/(1 + \cos^2\varphi)`), and it stays right for either sign
convention of eq. (2.16) — the OCR lost the sign (``docs/cobot.md`` §2), ``convention=-1`` mirrors
:math:`\varphi`. The product :math:`\kappa_i \dot s_i` does not depend on the sign chosen for
:math:`t_i`, so neither does :math:`\dot\varphi_i`. Add a CVT by implementing :class:`CVT`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import finite_scalar, real_array
from velfence.errors import InvalidInput, InvalidParameter

__all__ = ["CVT", "SteeredWheel", "TetrahedralCVT"]

_SQRT2 = math.sqrt(2.0)


@runtime_checkable
class CVT(Protocol):
    """What the cobot framework needs from a transmission model (module docs)."""

    @property
    def name(self) -> str:
        """Short label for plots and reports."""
        ...

    def direction(self, phi: float) -> FloatArray:
        r"""Unit allowed direction :math:`t(\varphi)` in the coupling space, shape (2,)."""
        ...

    def angle_rate(self, phi: float) -> float:
        r""":math:`d\psi/d\varphi` (never zero)."""
        ...

    def steering_angle(self, t: FloatArray) -> float:
        r"""A steering angle whose direction is parallel (either sign) to ``t``, shape (2,)."""
        ...

    def steering_rate(self, phi: float, curvature: float, speed: float) -> float:
        r""":math:`\dot\varphi` [rad/s] for signed curvature [1/unit] and signed speed [unit/s]."""
        ...


def _angle(name: str, phi: float) -> float:
    return finite_scalar(name, phi, unit="rad", what="steering angle")


def _direction_arg(t: FloatArray) -> tuple[float, float]:
    a = real_array("t", t, (2,), what="a direction")
    if not np.any(a):
        raise InvalidInput("t: expected a non-zero direction of shape (2,), got [0.0, 0.0]")
    return float(a[0]), float(a[1])


def _rate_args(curvature: float, speed: float) -> tuple[float, float]:
    k = finite_scalar("curvature", curvature, unit="1/unit", what="signed curvature")
    u = finite_scalar("speed", speed, unit="unit/s", what="speed")
    return k, u


@dataclass(frozen=True)
class SteeredWheel:
    r"""A steered wheel rolling on a plane (eq. 2.15): :math:`t = (\cos\varphi, \sin\varphi)`.

    The coupling space is the plane the wheel rolls on (for the Unicycle and Scooter cobots the
    wheel's plane velocity, :math:`J_i` computed directly); :math:`\dot\varphi = u\,\kappa`,
    :math:`u` the signed wheel speed [m/s].
    """

    @property
    def name(self) -> str:
        """``"wheel"``."""
        return "wheel"

    def direction(self, phi: float) -> FloatArray:
        """Unit rolling direction, shape (2,)."""
        return np.array(self._direction_floats(_angle("phi", phi)))

    def _direction_floats(self, p: float) -> tuple[float, float]:
        """:meth:`direction` at a checked angle, as floats."""
        return math.cos(p), math.sin(p)

    def angle_rate(self, phi: float) -> float:
        """Always 1: the wheel's direction angle is its steering angle."""
        _angle("phi", phi)
        return 1.0

    def steering_angle(self, t: FloatArray) -> float:
        """``atan2(t_y, t_x)``, in (-π, π]."""
        x, y = _direction_arg(t)
        return math.atan2(y, x)

    def steering_rate(self, phi: float, curvature: float, speed: float) -> float:
        """Eq. (2.15): ``speed * curvature``."""
        k, u = _rate_args(curvature, speed)
        return u * k / self.angle_rate(phi)


@dataclass(frozen=True, kw_only=True)
class TetrahedralCVT:
    r"""The tetrahedral CVT (eqs. 2.16–2.18, reconstructed; ``docs/cobot.md`` §2).

    Ratio :math:`M(\varphi) = \omega_1/\omega_2 = (\sin\varphi + c\sqrt2\cos\varphi) /
    (\sin\varphi - c\sqrt2\cos\varphi)` with ``c = convention`` (±1), so

    .. math::

        t(\varphi) = \frac{(\sin\varphi + c\sqrt2\cos\varphi,\;
                             \sin\varphi - c\sqrt2\cos\varphi)}{\sqrt{2 + 2\cos^2\varphi}},
        \qquad \frac{d\psi}{d\varphi} = \frac{c\sqrt2}{1 + \cos^2\varphi}.

    Every direction is reached once for :math:`\varphi \in [0, \pi)`; :math:`\varphi` and
    :math:`\varphi + \pi` give opposite directions.

    Attributes:
        convention: +1 (our reading of eq. 2.16) or -1 (the mirrored sign of eq. 2.16).
    """

    convention: int = 1

    def __post_init__(self) -> None:
        c: object = self.convention
        want = "+1 or -1 (the sign lost from eq. 2.16)"
        # timedelta64 is an integer type to NumPy; it is a duration, not a sign.
        if isinstance(c, (np.timedelta64, np.datetime64)):
            raise InvalidParameter(f"convention: expected {want}, got {type(c).__name__}")
        try:
            v = finite_scalar("convention", c, what="sign", error=InvalidParameter)
        except InvalidParameter:
            raise InvalidParameter(f"convention: expected {want}, got {type(c).__name__}") from None
        if v not in (1.0, -1.0):
            raise InvalidParameter(f"convention: expected {want}, got {v:g}")
        object.__setattr__(self, "convention", int(v))

    @property
    def name(self) -> str:
        """``"tetrahedral"``."""
        return "tetrahedral"

    def direction(self, phi: float) -> FloatArray:
        """Eq. (2.17): unit direction of (ω1, ω2), shape (2,)."""
        return np.array(self._direction_floats(_angle("phi", phi)))

    def _direction_floats(self, p: float) -> tuple[float, float]:
        """:meth:`direction` at a checked angle, as floats."""
        s, c = math.sin(p), self.convention * _SQRT2 * math.cos(p)
        n = math.sqrt(2.0 + 2.0 * math.cos(p) ** 2)
        return (s + c) / n, (s - c) / n

    def ratio(self, phi: float) -> float:
        r"""Eq. (2.16): :math:`M = \omega_1/\omega_2` (``inf`` where :math:`\omega_2 = 0`)."""
        p = _angle("phi", phi)
        s, c = math.sin(p), self.convention * _SQRT2 * math.cos(p)
        return (s + c) / (s - c) if s != c else math.inf

    def angle_rate(self, phi: float) -> float:
        r""":math:`d\psi/d\varphi = c\sqrt2/(1 + \cos^2\varphi)`."""
        p = _angle("phi", phi)
        return self.convention * _SQRT2 / (1.0 + math.cos(p) ** 2)

    def steering_angle(self, t: FloatArray) -> float:
        r"""Steering angle for a direction (inverse of :meth:`direction` up to sign).

        :math:`\tan\varphi = c\sqrt2(t_1+t_2)/(t_1-t_2)`.
        Returns the angle whose :meth:`direction` equals ``t/|t|`` exactly (in (-π, π]).
        """
        x, y = _direction_arg(t)
        # t1 + t2 ∝ 2 sin φ, t1 - t2 ∝ 2 c √2 cos φ (same positive scale).
        return math.atan2(_SQRT2 * (x + y), self.convention * (x - y))

    def steering_rate(self, phi: float, curvature: float, speed: float) -> float:
        """Eq. (2.18): ``curvature * speed * (1 + cos² φ) / (c √2)``."""
        k, u = _rate_args(curvature, speed)
        return k * u / self.angle_rate(phi)


document_inits(globals())
