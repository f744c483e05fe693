r"""Path following for cobots in the spatial domain (Gillespie et al. 1999, §3, eqs. 3.1–3.8).

The human sets the speed, the cobot only the heading, so the controller is designed in the cobot's
own arc length :math:`s` (' = d/ds). With the reference point :math:`R_p(s_p)` on the path,

.. math::

    \Delta R = R - R_p(s_p),\quad \Delta R' = T - s_p' T_p,\quad
    \Delta R'' = \kappa N - s_p'' T_p - s_p'^2\,\kappa_p N_p.          \tag{3.1–3.3}

The inputs are the two projections of one n-vector U: :math:`s_p'' = T^\top U` (3.4) and
:math:`\kappa N = (I - TT^\top)U` (3.5), so :math:`\Delta R'' = MU - b` with
:math:`M = I - TT^\top - T_pT^\top`, :math:`b = s_p'^2\kappa_pN_p` (3.6), and
:math:`U = M^{-1}(v + b)` (3.7) makes :math:`\Delta R'' = v`; the outer loop
:math:`v = -(k_1\Delta R + k_2\Delta R')` (3.8) gives
:math:`\Delta R'' + k_2\Delta R' + k_1\Delta R = 0` — poles in 1/length, independent of how fast
the human pushes. :math:`\det M = -T^\top T_p`; with :math:`w = v + b` the inverse is

.. math::

    s_p'' = -\frac{T^\top w}{T^\top T_p},\qquad \kappa N = (I - TT^\top)(w + s_p'' T_p)

(Sherman–Morrison; ``docs/cobot.md`` §4). When :math:`|T^\top T_p|` falls below ``guard`` the
heading is nearly perpendicular to the path and the inverse blows up: the controller flags it and,
per ``on_singular``, raises or (``"clamp"``) holds the reference, :math:`s_p'' = 0`, and steers with
:math:`\kappa N = (I - TT^\top)w`. At :math:`T \perp T_p` the range of M is the complement of T, so
no input reaches the T component of :math:`\Delta R''`, while every :math:`s_p''` gives the exact
normal part :math:`(I - TT^\top)\Delta R'' = (I - TT^\top)v`; of these least-squares solutions the
one with :math:`s_p'' = 0` does not kick the reference state, and its curvature is bounded,
:math:`|\kappa N| \le |w|`. (Dividing by a clamped :math:`\pm` ``guard`` instead gave :math:`|s_p''|
= |T^\top w|/` ``guard`` — 5800 for the r-θ start with the heading ⟂ the path — whose zero-order
hold over one step turned the heading by radians and left the run's fate to rounding.)

The reference state :math:`(s_p, s_p')` belongs to the controller and is integrated over the
*measured* arc length: ``ds = 0`` (the human stopped) leaves it unchanged.

On a velfence path in the plane (:class:`~velfence.geometry.paths.Line`, ``Circle``, ``Polyline``,
``Spline``) :meth:`PathFollower.evaluate` computes in Python floats on the path's one-point frame;
other paths and dimensions take the array route, which is the oracle the float route is tested
against (equal to rounding).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_choice,
    check_positive,
    finite_scalar,
    real_array,
    real_floats,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.paths import Path, frame_floats

__all__ = ["FollowerOutput", "PathFollower", "critically_damped", "gains_from_poles"]

OnSingular = Literal["clamp", "raise"]


def gains_from_poles(p1: complex, p2: complex) -> tuple[float, float]:
    r"""Outer-loop gains placing the spatial poles of :math:`x'' + k_2x' + k_1x = 0` at p1, p2.

    :math:`k_1 = p_1 p_2`, :math:`k_2 = -(p_1 + p_2)`. Poles are in 1/length [1/m]; a complex
    pair must be conjugate.

    Args:
        p1: First pole [1/m], real part < 0.
        p2: Second pole [1/m], real part < 0.

    Returns:
        ``(k1, k2)`` in [1/m²] and [1/m].

    Raises:
        InvalidParameter: An unstable/marginal pole, or a non-conjugate complex pair.
    """
    a, b = _pole("p1", p1), _pole("p2", p2)
    if abs(a.imag + b.imag) > 1e-12 * (1.0 + abs(a) + abs(b)) or (
        a.imag != 0.0 and abs(a.real - b.real) > 1e-12 * (1.0 + abs(a))
    ):
        raise InvalidParameter(f"poles: a complex pair must be conjugate, got {a} and {b}")
    return float((a * b).real), float(-(a + b).real)


def _pole(name: str, p: object) -> complex:
    """A pole as a finite complex number with real part < 0 (strings and booleans refused)."""
    if isinstance(p, np.ndarray) and p.shape == () and p.dtype.kind in "iufc":
        p = p[()]  # a 0-d array is a scalar
    if isinstance(p, (bool, np.bool_)) or not isinstance(p, numbers.Number):
        raise InvalidParameter(
            f"{name}: expected a stable pole (a real or complex number) in 1/m, got "
            f"{type(p).__name__}"
        )
    try:
        z: complex = complex(p)  # type: ignore[call-overload]
    except (OverflowError, TypeError, ValueError):
        z = complex(math.inf)
    if not (math.isfinite(z.real) and math.isfinite(z.imag)) or abs(z) > MAX_MAGNITUDE:
        raise InvalidParameter(
            f"{name}: expected a stable pole (finite, magnitude <= {MAX_MAGNITUDE:g}) in 1/m, "
            f"got {p!r:.60}"
        )
    if z.real >= 0.0:
        raise InvalidParameter(f"{name}: expected a stable pole (real part < 0) in 1/m, got {z}")
    return z


def critically_damped(omega: float) -> tuple[float, float]:
    r"""Gains for a double pole at :math:`-\omega` [1/m]: :math:`(\omega^2, 2\omega)`.

    Args:
        omega: The pole's magnitude [1/m], finite and > 0.

    Returns:
        ``(k1, k2) = (omega², 2 omega)`` in [1/m²] and [1/m].

    Raises:
        InvalidParameter: ``omega`` not a finite number > 0.
    """
    w = check_positive("omega", omega, unit="1/m")
    return w * w, 2.0 * w


@dataclass(frozen=True)
class FollowerOutput:
    r"""One evaluation of the path follower.

    Attributes:
        kN: Curvature command :math:`\kappa N` (eq. 3.5), shape (n,), orthogonal to T.
        sp_dd: :math:`s_p''` (eq. 3.4).
        U: The input vector (eq. 3.7), shape (n,).
        v: Outer-loop output (eq. 3.8), shape (n,).
        error: :math:`\Delta R`, shape (n,).
        error_rate: :math:`\Delta R'`, shape (n,).
        s_p: Reference arc length [m].
        sp_d: :math:`s_p'`.
        reference: :math:`R_p(s_p)`, shape (n,).
        alignment: :math:`T^\top T_p` (= :math:`-\det M`).
        singular: True when :math:`|T^\top T_p| <` ``guard`` (the guard acted).
    """

    kN: FloatArray
    sp_dd: float
    U: FloatArray
    v: FloatArray
    error: FloatArray
    error_rate: FloatArray
    s_p: float
    sp_d: float
    reference: FloatArray
    alignment: float
    singular: bool


class PathFollower:
    r"""The feedback-linearising path follower of §3 (module docs), with its reference state.

    Args:
        path: The planned path :math:`C_p` (any :class:`~velfence.geometry.paths.Path`).
        gains: ``(k1, k2)`` [1/m², 1/m], both > 0 (stable); see :func:`gains_from_poles` and
            :func:`critically_damped`. The paper gives none; (4, 4) is a double pole at -2 /m.
        guard: Threshold on :math:`|T^\top T_p|` below which M counts as singular, in (0, 1).
        on_singular: ``"clamp"`` (hold the reference, :math:`s_p'' = 0`, and steer with
            :math:`(I - TT^\top)w`; bounded, flagged; module docs) or ``"raise"``.
        max_curvature: Optional bound on :math:`|\kappa N|` [1/m] (a steering-rate limit seen in
            C_EE); ``None`` for none. When it acts the linearisation is no longer exact.

    Raises:
        InvalidParameter: Bad gains, guard or options.
    """

    def __init__(
        self,
        path: Path,
        *,
        gains: tuple[float, float] = (4.0, 4.0),
        guard: float = 1e-3,
        on_singular: OnSingular = "clamp",
        max_curvature: float | None = None,
    ) -> None:
        if not isinstance(path, Path):
            raise InvalidParameter(f"path: expected a velfence Path, got {type(path).__name__}")
        # Only a pair in a list, tuple or array: unpacking a set, an iterator or a memoryview
        # would read an arbitrary order or bytes.
        given: object = gains
        if isinstance(given, np.ndarray) and given.shape == (2,):
            k1, k2 = given.tolist()
        elif isinstance(given, (list, tuple)) and len(given) == 2:
            k1, k2 = given
        else:
            raise InvalidParameter(
                f"gains: expected a pair (k1, k2) of positive numbers, got {type(gains).__name__}"
            )
        self._k1 = check_positive("gains[0] (k1)", k1, unit="1/m²")
        self._k2 = check_positive("gains[1] (k2)", k2, unit="1/m")
        g = check_positive("guard", guard)
        if g >= 1.0:
            raise InvalidParameter(f"guard: expected a value in (0, 1) on |T·T_p|, got {g}")
        self._guard = g
        self._on_singular = check_choice("on_singular", on_singular, get_args(OnSingular))
        self._kmax = (
            None if max_curvature is None else check_positive("max_curvature", max_curvature)
        )
        self._path = path
        self._n = int(path.dim)
        # A velfence path in the plane: the law in Python floats on its one-point frame.
        self._frame2 = frame_floats(path) if self._n == 2 else None
        self._sp = 0.0
        self._spd = 1.0
        self._spdd = 0.0

    @property
    def path(self) -> Path:
        """The planned path."""
        return self._path

    @property
    def gains(self) -> tuple[float, float]:
        """``(k1, k2)``."""
        return self._k1, self._k2

    @property
    def state(self) -> tuple[float, float]:
        r"""The reference state :math:`(s_p, s_p')`."""
        return self._sp, self._spd

    def reset(
        self, R: ArrayLike, *, s_p: float | None = None, sp_d: float = 1.0
    ) -> tuple[float, float]:
        r"""Initialise the reference state: :math:`s_p` at the closest point (or as given).

        Args:
            R: Current end-effector configuration, shape (n,).
            s_p: Reference arc length [m]; the closest point of the path to R when ``None``.
            sp_d: Initial :math:`s_p'` (1: the reference moves as fast as the cobot).

        Returns:
            The new state.
        """
        Ra = self._vector("R", R)
        if s_p is None:
            self._sp = float(self._path.closest(Ra))
        else:
            self._sp = finite_scalar("s_p", s_p)
        self._spd = finite_scalar("sp_d", sp_d)
        self._spdd = 0.0
        return self.state

    def _vector(self, name: str, x: ArrayLike) -> FloatArray:
        return real_array(name, x, (self._n,))

    def evaluate(
        self, R: ArrayLike, T: ArrayLike, *, s_p: float | None = None, sp_d: float | None = None
    ) -> FollowerOutput:
        r"""The control law at (R, T) for a reference state (default: the controller's own).

        Pure: does not change the state.

        Args:
            R: End-effector configuration, shape (n,).
            T: Unit heading, shape (n,) (normalised here; must be non-zero).
            s_p: Reference arc length [m] (default: the controller's).
            sp_d: :math:`s_p'` (default: the controller's).

        Raises:
            InvalidInput: Bad shapes, non-finite values, zero T; or M singular with
                ``on_singular="raise"``.
        """
        frame = self._frame2
        if frame is not None:
            try:
                return self._evaluate2(frame, R, T, s_p, sp_d)
            except ZeroDivisionError:  # where Python refuses a division NumPy answers (inf/nan)
                pass
        return self._evaluate_nd(R, T, s_p, sp_d)

    def _evaluate_nd(
        self, R: ArrayLike, T: ArrayLike, s_p: float | None, sp_d: float | None
    ) -> FollowerOutput:
        """:meth:`evaluate` in arrays, any n (the n = 2 float route's reference)."""
        Ra = self._vector("R", R)
        Ta = self._vector("T", T)
        nT = float(np.linalg.norm(Ta))
        if nT == 0.0:
            raise InvalidInput("T: expected a non-zero heading, got the zero vector")
        Ta = Ta / nT
        sp = self._sp if s_p is None else finite_scalar("s_p", s_p)
        spd = self._spd if sp_d is None else finite_scalar("sp_d", sp_d)
        Rp, Tp, kpNp = self._path.frame(sp)
        e = Ra - Rp  # (3.1)
        ed = Ta - spd * Tp  # (3.2)
        v = -(self._k1 * e + self._k2 * ed)  # (3.8)
        w = v + spd * spd * kpNp  # v + b
        c = float(Ta @ Tp)  # -det M
        singular = abs(c) < self._guard
        if singular:
            if self._on_singular == "raise":
                raise InvalidInput(
                    f"M is singular: T·T_p = {c:.3g} (|T·T_p| < guard = {self._guard}); the "
                    "heading is perpendicular to the path at the reference point. Use "
                    "on_singular='clamp' or re-initialise s_p with reset()"
                )
            # Every U leaves the T component of ΔR'' at -s_p'^2 T·κ_pN_p when T ⟂ T_p (the
            # range of M is T's orthogonal complement), and every s_p'' gives the exact normal
            # part (I - TTᵀ)ΔR'' = (I - TTᵀ)v with κN = (I - TTᵀ)(w + s_p'' T_p): hold the
            # reference (s_p'' = 0) and steer with the reachable part, |κN| <= |w|.
            spdd = 0.0
            U = w - Ta * float(Ta @ w)
            kN = U
        else:
            spdd = -float(Ta @ w) / c  # (3.4) via Sherman–Morrison
            U = w + (Ta + Tp) * spdd
            kN = U - Ta * float(Ta @ U)  # (3.5)
        if self._kmax is not None:
            mag = float(np.linalg.norm(kN))
            if mag > self._kmax:
                kN = kN * (self._kmax / mag)
        return FollowerOutput(kN, spdd, U, v, e, ed, sp, spd, Rp, float(Ta @ Tp), singular)

    def _evaluate2(
        self,
        frame: Callable[[float], tuple[list[float], list[float], list[float]]],
        R: ArrayLike,
        T: ArrayLike,
        s_p: float | None,
        sp_d: float | None,
    ) -> FollowerOutput:
        """:meth:`evaluate` for n = 2 on a velfence path, in Python floats.

        The operations of :meth:`_evaluate_nd` component by component (dot products summed left
        to right), equal to it to rounding (tests/cobot/test_cobot_floats.py).
        """
        x, y = real_floats("R", R, 2)
        tx, ty = real_floats("T", T, 2)
        nT = math.sqrt(tx * tx + ty * ty)
        if nT == 0.0:
            raise InvalidInput("T: expected a non-zero heading, got the zero vector")
        tx, ty = tx / nT, ty / nT
        sp = self._sp if s_p is None else finite_scalar("s_p", s_p)
        spd = self._spd if sp_d is None else finite_scalar("sp_d", sp_d)
        (px, py), (ux, uy), (kx, ky) = frame(sp)
        ex, ey = x - px, y - py  # (3.1)
        dx, dy = tx - spd * ux, ty - spd * uy  # (3.2)
        k1, k2 = self._k1, self._k2
        vx, vy = -(k1 * ex + k2 * dx), -(k1 * ey + k2 * dy)  # (3.8)
        b = spd * spd
        wx, wy = vx + b * kx, vy + b * ky  # v + b
        c = tx * ux + ty * uy  # -det M
        singular = abs(c) < self._guard
        if singular:
            if self._on_singular == "raise":
                return self._evaluate_nd(R, T, s_p, sp_d)  # raises, with its message
            spdd = 0.0  # hold the reference, steer with (I - TTᵀ)w (see _evaluate_nd)
            tw = tx * wx + ty * wy
            Ux, Uy = wx - tx * tw, wy - ty * tw
            nx, ny = Ux, Uy
        else:
            spdd = -(tx * wx + ty * wy) / c  # (3.4) via Sherman–Morrison
            Ux, Uy = wx + (tx + ux) * spdd, wy + (ty + uy) * spdd
            tU = tx * Ux + ty * Uy
            nx, ny = Ux - tx * tU, Uy - ty * tU  # (3.5)
        if self._kmax is not None:
            mag = math.sqrt(nx * nx + ny * ny)
            if mag > self._kmax:
                f = self._kmax / mag
                nx, ny = nx * f, ny * f
        return FollowerOutput(
            np.array([nx, ny]),
            spdd,
            np.array([Ux, Uy]),
            np.array([vx, vy]),
            np.array([ex, ey]),
            np.array([dx, dy]),
            sp,
            spd,
            np.array([px, py]),
            c,
            singular,
        )

    def step(self, R: ArrayLike, T: ArrayLike, ds: float, t: float | None = None) -> FollowerOutput:
        r"""Advance the reference by the measured arc length ``ds``, then evaluate at (R, T).

        The reference integrates :math:`s_p' \mathrel{+}= s_p''\,ds`,
        :math:`s_p \mathrel{+}= s_p'\,ds` (exact for constant :math:`s_p''` over ``ds``) with the
        :math:`s_p''` of the previous evaluation. ``ds = 0`` leaves it untouched.

        Args:
            R: Measured end-effector configuration, shape (n,).
            T: Measured unit heading, shape (n,).
            ds: Arc length travelled since the previous call [m], >= 0.
            t: Time [s]; unused (the law is spatial), accepted for the
                :class:`~velfence.sim.cobot.HeadingController` protocol.
        """
        d = finite_scalar("ds", ds, unit="m")
        if t is not None and finite_scalar("t", t, unit="s", what="time") < 0.0:
            raise InvalidInput(f"t: expected a time >= 0 s, got {t}")
        if d < 0.0:
            raise InvalidInput(f"ds: expected the arc length travelled (>= 0), got {d}")
        if d > 0.0:
            self._sp += self._spd * d + 0.5 * self._spdd * d * d
            self._spd += self._spdd * d
            if self._path.closed:
                self._sp %= self._path.length
        out = self.evaluate(R, T)
        self._spdd = out.sp_dd
        return out


document_inits(globals())
