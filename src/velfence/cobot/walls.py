r"""Virtual walls for cobots: the passive-device analogue of the patent's shaping.

A cobot cannot brake or push, only choose the one direction it allows (its CVTs), and the human
supplies the speed along it. In *caster mode* the direction follows the human's intent (force
sensing); a virtual wall bends it tangent to the wall at the boundary. :class:`CasterWall` uses the
same :class:`~velfence.geometry.polygon.ConvexPolygon` and the same exact shaping law as an
actuated device (:class:`~velfence.shaping.polygon.PolygonShaper`, ``method="exact"``), and turns
the shaped velocity :math:`v_s` into what the passive device does:

.. math::

    \ell = v_s/|v_s|,\qquad v_{out} = \max(0, \ell^\top v_h)\,\ell,

(:math:`v_{out} = 0` when :math:`v_s = 0`: the device steers across the push and blocks it). So
one workspace definition serves both kinds of device. Differences from the actuated shaper, by
physics rather than by choice: the speed along the allowed direction is the human's (inside the
buffer :math:`|v_{out}|` can exceed :math:`|v_s|`, never :math:`|v_h|`); a head-on push reaches
the wall at full speed and stops there (a passive device cannot brake, only block), so in discrete
time it may cross by at most :math:`|v_h|\,dt`; and outside it never pushes back (no recovery
motion unless the human's push has an inward component).

:class:`WallSteering` realises the same wall on a simulated cobot through its steering: it
turns the heading toward :math:`\ell` with curvature :math:`\kappa N = g\,(I - TT^\top)\ell` (a
first-order lag of :math:`1/g` metres of travel), so the passive device's direction error is
what the wall's buffer must absorb (measured in the cobot reproduction).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.shaping.base import IntArray, KernelOut, ShaperBase, check_positive
from velfence.shaping.polygon import PolygonShaper

__all__ = ["CasterWall", "WallSteering", "WallSteeringOutput"]

FloatArray = NDArray[np.float64]

#: Shaped speeds below this fraction of the command count as "blocked" (direction undefined).
_BLOCKED = 1e-12


class CasterWall(ShaperBase):
    """Caster mode bounded by a convex polygon, for a passive (steer-only) device.

    Args:
        polygon: The permitted workspace (corners or a :class:`ConvexPolygon`).
        buffer: Width of the band inside the wall where the direction starts turning [m], > 0.
        recovery_gain: Outside the wall, tilt the allowed direction inward as the exact shaper's
            recovery floor ``k·penetration`` would [1/s], >= 0 (0: no tilt). The device still
            only moves when and as fast as the human pushes along that direction.
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity) for non-finite input.

    Zones, edges and distances are those of the underlying exact shaper.
    """

    __slots__ = ("_inner", "buffer", "polygon")
    method = "caster-wall"

    def __init__(
        self,
        polygon: ConvexPolygon | ArrayLike,
        *,
        buffer: float,
        recovery_gain: float = 0.0,
        on_invalid: str = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.polygon = as_polygon(polygon)
        self.buffer = check_positive("buffer", buffer, unit="m")
        k = check_positive("recovery_gain", recovery_gain, allow_zero=True, unit="1/s")
        self._inner = PolygonShaper(self.polygon, buffer=self.buffer, spring_gain=k, method="exact")

    @property
    def shaper(self) -> PolygonShaper:
        """The actuated-device shaper whose output gives the allowed direction."""
        return self._inner

    def _law(self, px: float, py: float, vx: float, vy: float) -> KernelOut:
        r = self._inner._law(px, py, vx, vy)
        sx, sy = r[0], r[1]
        # sqrt of the sum of squares (not hypot) so that the batch path rounds identically.
        ns = math.sqrt(sx * sx + sy * sy)
        if ns <= _BLOCKED * (1.0 + math.sqrt(vx * vx + vy * vy)):
            ox = oy = 0.0
        else:
            lx, ly = sx / ns, sy / ns
            u = max(0.0, lx * vx + ly * vy)
            ox, oy = u * lx, u * ly
        return (ox, oy, *r[2:])

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        S, zones = self._inner._law_batch(P, V)
        ns = np.sqrt(S[:, 0] * S[:, 0] + S[:, 1] * S[:, 1])
        blocked = ns <= _BLOCKED * (1.0 + np.sqrt(V[:, 0] * V[:, 0] + V[:, 1] * V[:, 1]))
        L = S / np.where(blocked, 1.0, ns)[:, None]
        u = np.maximum(0.0, L[:, 0] * V[:, 0] + L[:, 1] * V[:, 1])
        out = np.where(blocked[:, None], 0.0, u[:, None] * L)
        return out, zones

    def __repr__(self) -> str:
        return f"CasterWall({self.polygon.n}-gon, buffer={self.buffer})"


@dataclass(frozen=True)
class WallSteeringOutput:
    r"""One step of :class:`WallSteering`.

    Attributes:
        kN: Curvature command, shape (2,), orthogonal to T.
        target: The allowed direction :math:`\ell` (unit, or zero when blocked), shape (2,).
        intent: The human's intended velocity, shape (2,).
        zone: The wall shaper's zone at R.
    """

    kN: FloatArray
    target: FloatArray
    intent: FloatArray
    zone: str


class WallSteering:
    r"""Steer a cobot's heading toward the :class:`CasterWall` direction (module docs).

    Args:
        wall: The caster-mode wall.
        intent: The human's intended velocity ``(t, R) -> v_h`` [m/s], shape (2,).
        gain: Steering gain g [1/m] (heading lag of 1/g metres of travel), > 0.
        lookahead: The wall is evaluated at :math:`R + T\,\lambda/g`, λ lag lengths ahead
            along the heading, so the lagging heading turns early (0: at R, the plain law). With
            g = 30 /m, 1 lag length still cut 7.7 mm past a 103° corner in the cobot
            reproduction; 2 kept the cart inside (measured, ``velfence reproduce cobot``).
    """

    def __init__(
        self,
        wall: CasterWall,
        intent: Callable[[float, FloatArray], ArrayLike],
        *,
        gain: float = 20.0,
        lookahead: float = 2.0,
    ) -> None:
        if not isinstance(wall, CasterWall):
            raise InvalidParameter(f"wall: expected a CasterWall, got {wall!r}")
        self.wall = wall
        self.intent = intent
        self.gain = check_positive("gain", gain, unit="1/m")
        self.lookahead = check_positive("lookahead", lookahead, allow_zero=True)

    def step(
        self, R: ArrayLike, T: ArrayLike, ds: float, t: float | None = None
    ) -> WallSteeringOutput:
        """Curvature command at (R, T) for the intent at time ``t`` [s] (``ds`` unused)."""
        Ra = np.asarray(R, dtype=float)
        Ta = np.asarray(T, dtype=float)
        vh = np.asarray(self.intent(0.0 if t is None else float(t), Ra), dtype=float)
        r = self.wall.explain(Ra + Ta * (self.lookahead / self.gain), vh)
        out = r.output
        n = float(np.linalg.norm(out))
        target = out / n if n > 0.0 else np.zeros(2)
        if n == 0.0 and float(np.linalg.norm(vh)) > 0.0:
            # Blocked: turn across the push so that the human's force does no work.
            target = np.array([-vh[1], vh[0]]) / float(np.linalg.norm(vh))
        if float(target @ Ta) < 0.0:
            target = -target  # a direction is a line; turn the short way
        kN = self.gain * (target - Ta * float(Ta @ target))
        return WallSteeringOutput(kN, target, vh, r.zone)
