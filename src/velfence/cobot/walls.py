r"""Virtual walls for cobots: the passive-device analogue of the patent's shaping.

A cobot cannot brake or push, only choose the one direction (a line) it allows, and the human
supplies the speed along it. With the human's intended velocity :math:`v_h` (caster mode: force
sensing), the velocities a passive device can realise are :math:`w(\ell) = (\ell^\top v_h)\,\ell`
for unit :math:`\ell` — the circle with diameter :math:`v_h` (Thales), including 0 (steer across
the push: blocked). :class:`CasterWall` takes the *same* half-plane bounds as the actuated exact
law (:meth:`~velfence.shaping.polygon.PolygonShaper.bounds`: :math:`n_i^\top w \ge L_i` for every
edge within the buffer) and returns the realisable velocity closest to the intent that meets them:

.. math::

    w^* = \arg\min_{w = (\ell^\top v_h)\ell,\ n_i^\top w \ge L_i} |w - v_h|
        = \arg\max |w| .

Writing :math:`\ell` at angle :math:`\varphi` from :math:`v_h` and :math:`\beta_i` for the angle
from :math:`n_i` to :math:`v_h`, bound i reads
:math:`\tfrac{|v_h|}{2}[\cos\beta_i + \cos(2\varphi + \beta_i)] \ge L_i`, i.e. it excludes one arc
of :math:`\varphi` (mod π); the answer is the feasible :math:`\varphi` nearest 0 — 0 itself or an
arc end point, closed form. So one workspace definition serves both devices: inside the buffer the
passive wall *brakes by steering* (a head-on push is turned progressively toward the wall's
tangent, and its speed along the allowed line falls as :math:`\cos\varphi`), at a corner it turns
toward the open side or blocks. What physics still forbids: pushing back. If the recovery bounds
outside (``spring_gain > 0``) cannot be met by any realisable velocity, they are relaxed to "do
not go further out" (zone stage ``relaxed``).

:class:`WallSteering` realises the wall on a simulated cobot through its steering: it turns the
heading toward the allowed line :math:`\ell^*` with curvature :math:`\kappa N = g\,(I - TT^\top)
\ell^*` (a first-order lag of :math:`1/g` metres of travel).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import as_pair, check_positive
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.shaping.base import KernelOut, OnInvalid, ShaperBase, Zone
from velfence.shaping.polygon import PolygonShaper

__all__ = ["CasterWall", "WallSteering", "WallSteeringOutput"]


#: Angular slack [rad] when testing the bound arcs (round-off at arc end points).
_FEAS_TOL = 1e-12
#: Inward speed, relative to the intent's, demanded by bounds that point inward (a recovery or
#: the relaxed "not further out"), so that round-off never turns the velocity outward.
_INWARD = 1e-9


def _nearest_feasible(
    bounds: list[tuple[float, float, float]], psi: float, speed: float
) -> float | None:
    r"""The :math:`\varphi \in [-\pi/2, \pi/2]` nearest 0 meeting every bound, or None.

    Bound i holds iff :math:`\cos(2\varphi + \beta_i) \ge c_i`, :math:`c_i = 2L_i/|v| -
    \cos\beta_i`: an arc of half-width :math:`\arccos(c_i)/2` about :math:`-\beta_i/2` (mod π).
    """
    half_pi = 0.5 * math.pi
    cands = [0.0, half_pi]
    arcs = []
    for nx, ny, low in bounds:
        beta = psi - math.atan2(ny, nx)
        c = 2.0 * low / speed - math.cos(beta)
        if c <= -1.0:
            continue  # never binding
        if c > 1.0 + _FEAS_TOL:
            return None  # no realisable velocity meets it
        a = math.acos(min(c, 1.0))
        centre = -0.5 * beta
        arcs.append((centre, 0.5 * a))
        cands.extend((centre - 0.5 * a, centre + 0.5 * a))
    best: float | None = None
    for x in cands:
        y = (x + half_pi) % math.pi - half_pi  # into [-π/2, π/2)
        ok = all(abs((y - ctr + half_pi) % math.pi - half_pi) <= hw + _FEAS_TOL for ctr, hw in arcs)
        if ok and (best is None or abs(y) < abs(best) - 1e-15):
            best = y
    return best


class CasterWall(ShaperBase):
    """Caster mode bounded by a convex polygon, for a passive (steer-only) device.

    Args:
        polygon: The permitted workspace, a :class:`ConvexPolygon` [m].
        buffer: Width of the band inside the wall where the direction starts turning [m], > 0.
        spring_gain: Outside the wall, tilt the allowed direction inward as the exact shaper's
            recovery floor ``k·penetration`` would [1/s], >= 0 (0: no tilt). The device still
            only moves when and as fast as the human pushes along that direction.
        dt: Control period [s], > 0, or None (default: continuous-time bounds, so a loop that
            holds the realised velocity for ``dt`` may overshoot by up to ``|v|·dt`` per
            step). With ``dt`` the bounds are those of ``PolygonShaper(..., dt=dt)``: the
            approach to every edge per period is at most the remaining distance, so one
            explicit-Euler step from inside never leaves.
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity) for non-finite input.

    The realised velocity meets every bound of :meth:`PolygonShaper.bounds
    <velfence.shaping.polygon.PolygonShaper.bounds>` of :attr:`shaper` (to round-off relative
    to the intent's speed), or is zero (blocked). Zones, edges and distances are those of the
    underlying exact shaper.

    Raises:
        InvalidParameter: a parameter out of range, or a buffer wider than the polygon's
            inradius.
    """

    __slots__ = ("_inner", "buffer", "dt", "polygon")
    method = "caster-wall"

    def __init__(
        self,
        polygon: ConvexPolygon,
        *,
        buffer: float,
        spring_gain: float = 0.0,
        dt: float | None = None,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.polygon = as_polygon(polygon)
        self.buffer = check_positive("buffer", buffer, unit="m")
        k = check_positive("spring_gain", spring_gain, allow_zero=True, unit="1/s")
        self.dt = None if dt is None else check_positive("dt", dt, unit="s")
        self._inner = PolygonShaper(
            self.polygon, buffer=self.buffer, spring_gain=k, method="exact", dt=self.dt
        )

    @property
    def shaper(self) -> PolygonShaper:
        """The actuated-device shaper whose output gives the allowed direction."""
        return self._inner

    def line(self, position: ArrayLike, command: ArrayLike) -> tuple[FloatArray, FloatArray, int]:
        r"""The allowed line and realised velocity for intent ``command`` at ``position``.

        See the module docs for the law.

        Args:
            position: Position, shape (2,) [m].
            command: The human's intended velocity, shape (2,) [m/s].

        Returns:
            ``(ell, w, stages)``: unit direction of the allowed line (the intent's direction in
            the free zone; perpendicular to the intent when blocked; zeros when ``v = 0``),
            shape (2,); the realised velocity :math:`(\ell^\top v)\ell`, shape (2,); the stage
            bits (``velfence.shaping.STAGE_NAMES``).
        """
        px, py = as_pair("position", position)
        vx, vy = as_pair("command", command)
        if not all(math.isfinite(x) for x in (px, py, vx, vy)):
            raise InvalidInput(
                f"line: expected finite values, got position=({px}, {py}), command=({vx}, {vy})"
            )
        r, line = self._solve(px, py, vx, vy)
        return np.array(line), np.array((r[0], r[1])), int(r[9])

    def _law(self, px: float, py: float, vx: float, vy: float) -> KernelOut:
        return self._solve(px, py, vx, vy)[0]

    def _solve(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[KernelOut, tuple[float, float]]:
        """The law's output and the allowed line's direction (pure: no state)."""
        from velfence.shaping.shared_kernels import STAGE_PROJECT, STAGE_RELAXED, zone_code

        b = self._inner.bound_rows((px, py), (vx, vy))
        rows, p1, p2, d1, d2 = b.rows, b.primary, b.secondary, b.d1, b.d2
        speed = math.hypot(vx, vy)  # no overflow for huge commands (sqrt of squares would)
        m = len(rows)
        zone = zone_code(b.n_out, m)
        if m == 0 or speed == 0.0:
            line = (vx / speed, vy / speed) if speed > 0.0 else (0.0, 0.0)
            # No intent: the device stays put, which cannot meet a recovery bound (> 0).
            st = STAGE_RELAXED if any(r[2] > 0.0 for r in rows) else 0
            return (vx, vy, zone, p1, p2, d1, d2, 0.0, 0.0, st), line
        psi = math.atan2(vy, vx)
        stages = STAGE_PROJECT
        bounds = [(r[0], r[1], r[2]) for r in rows]

        def realise(phi: float) -> tuple[float, float, float, float]:
            lx, ly = math.cos(psi + phi), math.sin(psi + phi)
            u = 0.0 if abs(phi) >= 0.5 * math.pi else speed * math.cos(phi)
            return u * lx, u * ly, lx, ly

        def outward(phi: float) -> bool:
            """Whether round-off left the velocity pointing out through a wall (c >= 0)."""
            wx, wy = realise(phi)[:2]
            return any(a * wx + b * wy < 0.0 for a, b, c in bounds if c >= 0.0)

        # The arcs' end points meet their bounds only to round-off; where a bound says "inward"
        # (recovery, or the relaxed "not further out"), a sliver of inward speed absorbs it.
        floor = _INWARD * speed
        phi = _nearest_feasible(bounds, psi, speed)
        if phi is not None and outward(phi):
            strict = [(a, b, max(c, floor) if c >= 0.0 else c) for a, b, c in bounds]
            # no room for the sliver (a feasible set ~1e-9 rad wide): stand still
            phi = _nearest_feasible(strict, psi, speed)
            if phi is None:
                phi = 0.5 * math.pi
        if phi is None:  # recovery not realisable: only forbid going further out
            relaxed = [(a, b, floor if c >= 0.0 else c) for a, b, c in bounds]
            phi = _nearest_feasible(relaxed, psi, speed)
            stages |= STAGE_RELAXED
            if phi is not None and outward(phi):
                phi = None
        if phi is None:  # stand still (phi = π/2): w = 0 meets every bound <= 0 exactly
            phi = 0.5 * math.pi
        wx, wy, lx, ly = realise(phi)
        return (wx, wy, zone, p1, p2, d1, d2, 0.0, 0.0, stages), (lx, ly)

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        out = np.empty_like(P)
        zones = np.empty(P.shape[0], dtype=np.int64)
        for k in range(P.shape[0]):
            r = self._law(float(P[k, 0]), float(P[k, 1]), float(V[k, 0]), float(V[k, 1]))
            out[k, 0], out[k, 1], zones[k] = r[0], r[1], r[2]
        return out, zones

    def __repr__(self) -> str:
        return f"CasterWall({self.polygon.n}-gon, buffer={self.buffer}, dt={self.dt})"


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
    zone: Zone


class WallSteering:
    r"""Steer a cobot's heading toward the :class:`CasterWall` direction (module docs).

    Args:
        wall: The caster-mode wall.
        intent: The human's intended velocity ``(t, R) -> v_h`` [m/s], shape (2,).
        gain: Steering gain g [1/m] (heading lag of 1/g metres of travel), > 0.
        lookahead: The wall is evaluated at :math:`R + T\,\lambda/g`, λ lag lengths ahead
            along the heading, so the lagging heading turns early (0: at R). Measured in the
            cobot reproduction (g = 30 /m): 0 let the cart 47 mm out, 1 → 0.4 mm, 2 → 0.
    """

    def __init__(
        self,
        wall: CasterWall,
        intent: Callable[[float, FloatArray], ArrayLike],
        *,
        gain: float = 20.0,
        lookahead: float = 2.0,
    ) -> None:
        # Imported here so that this class's inputs stay beside it (the module's imports serve
        # CasterWall).
        from velfence._validate import MAX_MAGNITUDE

        if not isinstance(wall, CasterWall):
            raise InvalidParameter(f"wall: expected a CasterWall, got {type(wall).__name__}")
        if not callable(intent) or isinstance(intent, type):
            raise InvalidParameter(
                f"intent: expected a function (t, R) -> intended velocity [m/s], got "
                f"{type(intent).__name__}"
            )
        self.wall = wall
        self.intent = intent
        self.gain = check_positive("gain", gain, unit="1/m")
        self.lookahead = check_positive("lookahead", lookahead, allow_zero=True)
        # The look-ahead distance λ/g multiplies T: it must be a finite length.
        ahead = self.lookahead / self.gain
        if not ahead <= MAX_MAGNITUDE:
            raise InvalidParameter(
                f"lookahead, gain: the look-ahead distance lookahead/gain = {ahead:g} m exceeds "
                f"{MAX_MAGNITUDE:g} m; lower lookahead or raise gain"
            )
        self._ahead = ahead

    def step(
        self, R: ArrayLike, T: ArrayLike, ds: float, t: float | None = None
    ) -> WallSteeringOutput:
        """Curvature command at (R, T) for the intent at time ``t`` [s].

        Args:
            R: Cobot position, shape (2,) [m].
            T: Current heading, shape (2,) (unit).
            ds: Arc length travelled since the previous call [m], >= 0 (unused: the law is
                spatial; accepted for the :class:`~velfence.sim.cobot.HeadingController`
                protocol).
            t: Time [s], >= 0, passed to ``intent`` (0 when ``None``).

        Raises:
            InvalidInput: R, T not finite 2-vectors, ``ds`` or ``t`` not finite and >= 0, or the
                intent not a finite 2-vector.
        """
        from velfence._validate import MAX_MAGNITUDE, finite_scalar, real_array

        Ra = real_array("R", R, (2,), what="a position [m]")
        Ta = real_array("T", T, (2,), what="a heading")
        if finite_scalar("ds", ds, unit="m", what="arc length") < 0.0:
            raise InvalidInput(f"ds: expected the arc length travelled (>= 0), got {ds}")
        tt = 0.0 if t is None else finite_scalar("t", t, unit="s", what="time")
        if tt < 0.0:
            raise InvalidInput(f"t: expected a time >= 0 s, got {tt:g}")
        vh = real_array(
            "intent(t, R)", self.intent(tt, Ra), (2,), what="an intended velocity [m/s]"
        )
        with np.errstate(over="ignore", invalid="ignore"):
            ahead = Ra + Ta * self._ahead
        if not np.all(np.abs(ahead) <= MAX_MAGNITUDE):  # also False for inf/NaN
            raise InvalidInput(
                f"R, T: the look-ahead point R + T*lookahead/gain = {ahead.tolist()} is beyond "
                f"{MAX_MAGNITUDE:g} m; give R and a unit heading T"
            )
        target, _, _ = self.wall.line(ahead, vh)
        zone = self.wall.explain(Ra, vh).zone
        if float(target @ Ta) < 0.0:
            target = -target  # a direction is a line; turn the short way
        with np.errstate(over="ignore", invalid="ignore"):
            kN = self.gain * (target - Ta * float(Ta @ target))
        if not np.all(np.isfinite(kN)):
            raise InvalidInput(
                f"T: the curvature command is not finite for T = {Ta.tolist()}; give a unit heading"
            )
        return WallSteeringOutput(kN, target, vh, zone)


document_inits(globals())
