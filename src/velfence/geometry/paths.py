r"""Arc-length parametrised paths with unit tangent and curvature vector, in n dimensions.

These are the planned paths :math:`C_p` of cobot path following (Gillespie, Colgate & Peshkin 1999,
§3.1; see ``docs/cobot.md`` §4). The controller's error equations (3.1)–(3.3) need,
at the reference arc length :math:`s_p`,

* the point :math:`R_p(s_p)`, shape (n,);
* the unit tangent :math:`T_p = dR_p/ds_p` (eq. 2.2), shape (n,), :math:`|T_p| = 1`;
* the curvature vector :math:`\kappa_p N_p = dT_p/ds_p` (eq. 2.3), shape (n,), orthogonal to
  :math:`T_p`, of magnitude :math:`1/\rho` (zero on straight parts);

and an initial :math:`s_p`: :meth:`Path.closest` gives the arc length of the closest point, globally
or inside a window around the previous value so that a tracker does not jump between branches.

Conventions:

* ``s`` is arc length in the path's length unit [m], in ``[0, length]``. Closed paths
  (:class:`Circle`, closed :class:`Polyline` and :class:`Spline`) wrap ``s`` modulo ``length``;
  open paths clamp ``s`` to ``[0, length]`` (the end point, with the end tangent and curvature,
  holds beyond the ends).
* Every path is immutable; the arrays it exposes are read-only.
* :class:`Line`, :class:`Circle` and :class:`Polyline` are exact (straight segments and circular
  arcs, closed forms). :class:`Spline` is a C² cubic re-parametrised by arc length through a dense
  table refined by Newton steps; the arc length is accurate to about ``1e-12`` relative and tangent
  and curvature are the exact derivatives of the evaluated curve (see :class:`Spline`).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, finite_scalar, readonly, real_array
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter

__all__ = ["Circle", "Line", "Path", "Polyline", "Spline"]


#: Candidates whose distances differ by less than ``TIE_RTOL * (1 + length + distance)`` are ties;
#: ties go to the candidate nearest ``s0`` along the path (or, without ``s0``, the smallest ``s``).
TIE_RTOL = 1e-12

#: Turn angles below this [rad] are treated as straight (no arc is inserted at that corner).
STRAIGHT_ANGLE = 1e-12

# 8-point Gauss–Legendre rule on [-1, 1], for the spline's arc-length table.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


@runtime_checkable
class Path(Protocol):
    """What a path gives the path-following controller (Gillespie 1999, eqs. 2.2, 2.3, 3.1–3.3)."""

    @property
    def length(self) -> float:
        """Total arc length [m]."""
        ...

    @property
    def closed(self) -> bool:
        """Whether ``s`` wraps modulo :attr:`length`."""
        ...

    @property
    def dim(self) -> int:
        """Dimension n of the space the path lives in."""
        ...

    def point(self, s: float) -> FloatArray:
        """:math:`R_p(s)`, shape (n,)."""
        ...

    def tangent(self, s: float) -> FloatArray:
        """Unit tangent :math:`T_p(s)`, shape (n,)."""
        ...

    def curvature(self, s: float) -> FloatArray:
        r"""Curvature vector :math:`\kappa_p N_p(s) = dT_p/ds`, shape (n,) [1/m]."""
        ...

    def frame(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(point, tangent, curvature)`` at ``s``, each shape (n,)."""
        ...

    def points(self, S: ArrayLike) -> FloatArray:
        """:math:`R_p` at many arc lengths, shape (N,) -> (N, n)."""
        ...

    def tangents(self, S: ArrayLike) -> FloatArray:
        """Unit tangents at many arc lengths, shape (N,) -> (N, n)."""
        ...

    def curvatures(self, S: ArrayLike) -> FloatArray:
        """Curvature vectors [1/m] at many arc lengths, shape (N,) -> (N, n)."""
        ...

    def closest(
        self, p: ArrayLike, *, s0: float | None = None, window: float | None = None
    ) -> float:
        """Arc length [m] of the point of the path closest to ``p``."""
        ...


# ---------------------------------------------------------------------------- validation
def _arc(name: str, s: Any) -> float:
    return finite_scalar(name, s, unit="m", what="arc length")


def _arcs(S: ArrayLike, maximum: int) -> FloatArray:
    a = real_array("S", S, what="arc lengths [m] of shape (N,)", allow_nonfinite=True)
    if a.ndim > 1:
        raise InvalidInput(f"S: expected shape (N,), got shape {a.shape}")
    a = a.reshape(-1)
    if a.size == 0:
        raise InvalidInput("S: expected at least one arc length [m], got none")
    if a.size > maximum:
        raise InvalidInput(
            f"S: expected at most {maximum} arc lengths per call on this path, got {a.size}; "
            "split the batch"
        )
    if not np.all(np.isfinite(a)):
        bad = np.flatnonzero(~np.isfinite(a))
        raise InvalidInput(
            f"S: expected finite arc lengths, got non-finite entries at {bad[:10].tolist()}"
        )
    return a


def _vector(
    name: str, x: ArrayLike, dim: int | None = None, *, error: type[Exception] = InvalidInput
) -> FloatArray:
    """One finite point, shape (dim,) (any dim >= 2 when ``dim`` is None)."""
    a = real_array(name, x, error=error, what="a point [m]")
    if dim is not None and a.shape != (dim,):
        raise error(f"{name}: expected shape ({dim},), got shape {a.shape}")
    if a.ndim != 1 or a.shape[0] < 2:
        raise error(f"{name}: expected shape (n,) with n >= 2, got shape {a.shape}")
    return a


def _vertices(name: str, x: ArrayLike, minimum: int) -> FloatArray:
    a = real_array(name, x, error=InvalidGeometry, what="coordinates [m] of shape (N, n)")
    if a.ndim != 2 or a.shape[1] < 2:
        raise InvalidGeometry(f"{name}: expected shape (N, n) with n >= 2, got shape {a.shape}")
    if a.shape[0] < minimum:
        raise InvalidGeometry(
            f"{name}: expected at least {minimum} points, got {a.shape[0]}; add points"
        )
    return a


def _readonly(a: FloatArray) -> FloatArray:
    return readonly(np.array(a, dtype=float))


def _unit(v: FloatArray) -> FloatArray:
    return np.asarray(v / np.linalg.norm(v), dtype=float)


def frame_floats(
    path: object,
) -> Callable[[float], tuple[list[float], list[float], list[float]]] | None:
    """The per-tick frame function of one of the library's paths, or None for any other path.

    Internal API (for :class:`velfence.cobot.PathFollower`, not for users): for a
    :class:`Line`, :class:`Circle`, :class:`Polyline` or :class:`Spline` (or a subclass), the
    function ``s -> (R_p, T_p, κ_p N_p)`` that :meth:`Path.frame` computes, as lists of floats
    (``s`` validated as by ``frame``); None for a path of another kind, which is only reached
    through the :class:`Path` protocol.

    Args:
        path: Any object.

    Returns:
        The bound frame function, or None.
    """
    return path._frame_floats if isinstance(path, _PathBase) else None


# ---------------------------------------------------------------------------- shared base
class _PathBase:
    """Arc-length wrapping, input checks, :meth:`closest` tie rules; subclasses add the curve."""

    __slots__ = ("_closed", "_dim", "_length")

    #: Largest batch of arc lengths one call of ``points``/``tangents``/``curvatures`` takes.
    MAX_BATCH = 10_000_000

    _closed: bool
    _dim: int
    _length: float

    @property
    def length(self) -> float:
        """Total arc length [m]."""
        return self._length

    @property
    def closed(self) -> bool:
        """Whether ``s`` wraps modulo :attr:`length` (else it is clamped to ``[0, length]``)."""
        return self._closed

    @property
    def dim(self) -> int:
        """Dimension n of the space the path lives in."""
        return self._dim

    # -- subclass hooks
    def _frames(self, S: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Points, unit tangents, curvature vectors at normalised ``S``, each (N, n)."""
        raise NotImplementedError  # pragma: no cover

    def _candidates(
        self, p: FloatArray, intervals: list[tuple[float, float]], ref: float | None
    ) -> list[float]:
        """Arc lengths that contain the closest point of each interval."""
        raise NotImplementedError  # pragma: no cover

    # -- arc-length handling
    def _normalise(self, S: FloatArray) -> FloatArray:
        if self._closed:
            return np.asarray(np.mod(S, self._length), dtype=float)
        return np.clip(S, 0.0, self._length)

    def frame(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        r"""Point, unit tangent and curvature vector at ``s`` in one evaluation.

        The same values as :meth:`point`, :meth:`tangent` and :meth:`curvature` (what the path
        follower needs every tick).

        Args:
            s: Arc length [m].

        Returns:
            ``(R_p, T_p, κ_p N_p)``, each shape (n,).
        """
        P, T, K = self._frames(self._normalise(np.array([_arc("s", s)])))
        return P[0], T[0], K[0]

    def _frame_floats(self, s: float) -> tuple[list[float], list[float], list[float]]:
        """:meth:`frame` as lists of floats (``s`` validated here); for per-tick callers."""
        P, T, K = self.frame(s)
        return P.tolist(), T.tolist(), K.tolist()

    def point(self, s: float) -> FloatArray:
        """The point :math:`R_p(s)` (Gillespie et al. 1999, eq. 3.1).

        Args:
            s: Arc length [m]; wrapped (closed) or clamped (open) into ``[0, length]``.

        Returns:
            Shape (n,), path units [m].
        """
        return np.asarray(self._frames(self._normalise(np.array([_arc("s", s)])))[0][0])

    def tangent(self, s: float) -> FloatArray:
        """The unit tangent :math:`T_p = dR_p/ds` (Gillespie et al. 1999, eq. 2.2).

        Args:
            s: Arc length [m].

        Returns:
            Shape (n,), unit length.
        """
        return np.asarray(self._frames(self._normalise(np.array([_arc("s", s)])))[1][0])

    def curvature(self, s: float) -> FloatArray:
        r"""The curvature vector :math:`\kappa_p N_p = dT_p/ds` (Gillespie et al. 1999, eq. 2.3).

        Args:
            s: Arc length [m].

        Returns:
            Shape (n,) [1/m]; orthogonal to the tangent, zero on straight parts.
        """
        return np.asarray(self._frames(self._normalise(np.array([_arc("s", s)])))[2][0])

    def points(self, S: ArrayLike) -> FloatArray:
        """Points at many arc lengths.

        Args:
            S: Arc lengths [m], shape (N,) (a scalar counts as N = 1).

        Returns:
            Shape (N, n).
        """
        return self._frames(self._normalise(_arcs(S, self.MAX_BATCH)))[0]

    def tangents(self, S: ArrayLike) -> FloatArray:
        """Unit tangents at many arc lengths, shape (N,) -> (N, n)."""
        return self._frames(self._normalise(_arcs(S, self.MAX_BATCH)))[1]

    def curvatures(self, S: ArrayLike) -> FloatArray:
        """Curvature vectors [1/m] at many arc lengths, shape (N,) -> (N, n)."""
        return self._frames(self._normalise(_arcs(S, self.MAX_BATCH)))[2]

    # -- closest point
    def _intervals(self, ref: float | None, window: float | None) -> list[tuple[float, float]]:
        L = self._length
        if ref is None or window is None:
            return [(0.0, L)]
        if not self._closed:
            return [(max(0.0, ref - window), min(L, ref + window))]
        if 2.0 * window >= L:
            return [(0.0, L)]
        lo, hi = ref - window, ref + window
        if lo < 0.0:
            return [(0.0, hi), (lo + L, L)]
        if hi > L:
            return [(lo, L), (0.0, hi - L)]
        return [(lo, hi)]

    def _along(self, s: float, ref: float) -> float:
        """Distance along the path between two arc lengths (the short way round if closed)."""
        d = abs(s - ref)
        return min(d, self._length - d) if self._closed else d

    def closest(
        self, p: ArrayLike, *, s0: float | None = None, window: float | None = None
    ) -> float:
        """Arc length of the point of the path closest to ``p`` (initialises :math:`s_p`).

        Args:
            p: Query point, shape (n,) [m].
            s0: Previous reference arc length [m] (optional). Alone it only breaks ties; with
                ``window`` it centres the local search.
            window: Half-width [m] of the local search ``[s0 - window, s0 + window]`` (wrapped on
                closed paths, clipped on open ones); needs ``s0``. A tracker that passes its
                previous ``s_p`` and a window shorter than the distance between branches never
                jumps to another branch.

        Returns:
            Arc length in ``[0, length)`` (closed) or ``[0, length]`` (open), in m. Ties (equal
            distances within ``TIE_RTOL``) go to the candidate nearest ``s0`` along the path,
            else to the smallest arc length, so the answer is deterministic.

        Raises:
            InvalidInput: ``p`` of the wrong shape or not finite; ``s0`` not finite.
            InvalidParameter: ``window`` not positive, or given without ``s0``.
        """
        q = _vector("p", p, self._dim)
        w: float | None = None
        if window is not None:
            w = check_positive("window", window, unit="m")
            if s0 is None:
                raise InvalidParameter(
                    f"window={w} needs s0 (the arc length to search around), got s0=None; "
                    "pass s0, or drop window for a global search"
                )
        ref = None if s0 is None else float(self._normalise(np.array([_arc("s0", s0)]))[0])
        cands = np.array(self._candidates(q, self._intervals(ref, w), ref), dtype=float)
        d = np.linalg.norm(self._frames(cands)[0] - q, axis=1)
        dmin = float(d.min())
        tied = np.flatnonzero(d <= dmin + TIE_RTOL * (1.0 + self._length + dmin))
        if ref is None:
            best = float(cands[tied].min())
        else:
            keys = [(self._along(float(cands[i]), ref), float(cands[i])) for i in tied]
            best = min(keys)[1]
        if self._closed and best >= self._length:
            best = 0.0
        return best


# ---------------------------------------------------------------------------- lines and arcs
class _Piecewise(_PathBase):
    """A chain of straight segments and circular arcs, evaluated in closed form."""

    __slots__ = ("_C", "_D", "_R", "_V", "_arc", "_lengths", "_pieces", "_starts", "_starts_list")

    def _build(
        self,
        pieces: list[tuple[str, FloatArray, FloatArray, FloatArray, float, float]],
        *,
        closed: bool,
    ) -> None:
        r"""Pieces are ``("line", start, dir, 0, 1, length)`` or ``("arc", c, u, v, r, sweep)``.

        An arc is :math:`c + r(\cos(\sigma/r) u + \sin(\sigma/r) v)`, ``u ⟂ v`` unit,
        ``σ`` its own arc length in ``[0, r·sweep]``.
        """
        lengths = [p[5] if p[0] == "line" else p[4] * p[5] for p in pieces]
        self._C = _readonly(np.array([p[1] for p in pieces]))
        self._D = _readonly(np.array([p[2] for p in pieces]))
        self._V = _readonly(np.array([p[3] for p in pieces]))
        self._R = _readonly(np.array([p[4] for p in pieces]))
        self._arc = np.array([p[0] == "arc" for p in pieces])
        self._arc.setflags(write=False)
        self._lengths = _readonly(np.array(lengths))
        self._starts = _readonly(np.concatenate(([0.0], np.cumsum(lengths)[:-1])))
        self._length = float(np.sum(lengths))
        self._closed = closed
        self._dim = int(self._C.shape[1])
        # The same constants as Python floats, for the one-point frame (no NumPy per call).
        self._starts_list: list[float] = self._starts.tolist()
        self._pieces: list[tuple[bool, list[float], list[float], list[float], float]] = [
            (bool(a), c, d, v, r)
            for a, c, d, v, r in zip(
                self._arc.tolist(),
                self._C.tolist(),
                self._D.tolist(),
                self._V.tolist(),
                self._R.tolist(),
                strict=True,
            )
        ]

    @property
    def joins(self) -> FloatArray:
        """Arc lengths [m] where pieces start, shape (pieces,), read-only (curvature may jump)."""
        return self._starts

    def _frames(self, S: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        k = np.clip(np.searchsorted(self._starts, S, side="right") - 1, 0, len(self._starts) - 1)
        sig = (S - self._starts[k])[:, None]
        C, D, V, R = self._C[k], self._D[k], self._V[k], self._R[k][:, None]
        arc = self._arc[k][:, None]
        phi = sig / R
        c, s = np.cos(phi), np.sin(phi)
        point = np.where(arc, C + R * (c * D + s * V), C + sig * D)
        tangent = np.where(arc, -s * D + c * V, D)
        curv = np.where(arc, -(c * D + s * V) / R, 0.0)
        return point, tangent, curv

    def frame(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        r"""Point, unit tangent and curvature vector at ``s`` in one evaluation.

        The values of :meth:`point`, :meth:`tangent` and :meth:`curvature` (the same float
        operations as the batch evaluation, in Python floats: no NumPy call for one point).

        Args:
            s: Arc length [m].

        Returns:
            ``(R_p, T_p, κ_p N_p)``, each shape (n,).
        """
        P, T, K = self._frame_floats(s)
        return np.array(P), np.array(T), np.array(K)

    def _frame_floats(self, s: float) -> tuple[list[float], list[float], list[float]]:
        """:meth:`frame` as lists of floats: :meth:`_frames` for one arc length, unrolled."""
        x = _arc("s", s)
        L = self._length
        # np.mod and Python's % are the same operation on floats (fmod, then the sign fix-up).
        x = x % L if self._closed else min(max(x, 0.0), L)
        k = min(max(bisect.bisect_right(self._starts_list, x) - 1, 0), len(self._pieces) - 1)
        arc, C, D, V, R = self._pieces[k]
        sig = x - self._starts_list[k]
        if not arc:
            return [c + sig * d for c, d in zip(C, D, strict=True)], list(D), [0.0] * len(D)
        phi = sig / R
        c, sn = math.cos(phi), math.sin(phi)
        radial = [c * d + sn * v for d, v in zip(D, V, strict=True)]
        return (
            [c0 + R * w for c0, w in zip(C, radial, strict=True)],
            [-sn * d + c * v for d, v in zip(D, V, strict=True)],
            [-w / R for w in radial],
        )

    def _candidates(
        self, p: FloatArray, intervals: list[tuple[float, float]], ref: float | None
    ) -> list[float]:
        out: list[float] = []
        for k in range(len(self._starts)):
            s_k, L_k = float(self._starts[k]), float(self._lengths[k])
            for lo, hi in intervals:
                a, b = max(lo, s_k) - s_k, min(hi, s_k + L_k) - s_k
                if a > b:
                    continue
                out += [s_k + a, s_k + b]
                rel = p - self._C[k]
                if not self._arc[k]:
                    out.append(s_k + float(np.clip(rel @ self._D[k], a, b)))
                    continue
                r = float(self._R[k])
                x, y = float(rel @ self._D[k]), float(rel @ self._V[k])
                if math.hypot(x, y) <= 1e-12 * r:
                    # On the arc's axis every point is equally far: prefer the reference.
                    if ref is not None:
                        out.append(s_k + float(np.clip(ref - s_k, a, b)))
                    continue
                sig = r * (math.atan2(y, x) % (2.0 * math.pi))
                if a <= sig <= b:
                    out.append(s_k + sig)
        return out


class Line(_Piecewise):
    r"""The straight segment from ``start`` to ``end``, in any dimension n >= 2.

    :math:`R_p(s) = start + s\,T`, :math:`T = (end - start)/|end - start|`, zero curvature.
    """

    __slots__ = ("_end", "_start")

    def __init__(self, start: ArrayLike, end: ArrayLike) -> None:
        """Validate and build the segment.

        Args:
            start: First point, shape (n,) [m], n >= 2.
            end: Last point, shape (n,) [m], distinct from ``start``.

        Raises:
            InvalidGeometry: mismatched shapes, non-finite values or ``start == end``.
        """
        a0 = _vector("start", start, error=InvalidGeometry)
        try:
            a1 = _vector("end", end, a0.shape[0], error=InvalidGeometry)
        except InvalidGeometry as exc:
            raise InvalidGeometry(f"{exc} (the shape of start)") from None
        a = np.array([a0, a1])
        d = a[1] - a[0]
        n = float(np.linalg.norm(d))
        if n == 0.0:
            raise InvalidGeometry(
                f"Line: expected distinct start and end, got both {a[0].tolist()}; a path "
                "needs a non-zero length"
            )
        self._start, self._end = _readonly(a[0]), _readonly(a[1])
        self._build([("line", a[0], d / n, np.zeros_like(d), 1.0, n)], closed=False)

    @property
    def start(self) -> FloatArray:
        """First point, shape (n,) [m], read-only."""
        return self._start

    @property
    def end(self) -> FloatArray:
        """Last point, shape (n,) [m], read-only."""
        return self._end


class Circle(_Piecewise):
    r"""A full circle, closed, in 2-D or (with a plane ``normal``) in 3-D.

    :math:`R_p(s) = c + r(\cos\theta\,e_1 + \sin\theta\,e_2)` with
    :math:`\theta = \theta_0 \pm s/r` (``+`` for ``ccw``), so the curvature vector is
    :math:`-(1/r)` times the radial unit vector.

    In 2-D, :math:`e_1 = (1, 0)`, :math:`e_2 = (0, 1)`: ``start_angle`` is measured from the x axis
    and ``ccw`` is counter-clockwise. In 3-D the plane is given by its ``normal``; :math:`e_1` is
    the unit projection onto the plane of the coordinate axis least aligned with the normal (x on
    ties), :math:`e_2 = \hat n \times e_1`, and ``ccw`` is right-handed about the normal.
    """

    __slots__ = ("_center", "_e1", "_e2", "_radius")

    def __init__(
        self,
        center: ArrayLike,
        *,
        radius: float,
        start_angle: float = 0.0,
        ccw: bool = True,
        normal: ArrayLike | None = None,
    ) -> None:
        """Validate and build the circle.

        Args:
            center: Centre, shape (2,) or (3,) [m].
            radius: Radius [m], > 0.
            start_angle: Angle [rad] of the point at ``s = 0``, from :math:`e_1` towards
                :math:`e_2`.
            ccw: Direction of increasing ``s``: counter-clockwise (right-handed about ``normal``
                in 3-D) if True.
            normal: Plane normal, shape (3,), non-zero; required in 3-D, refused in 2-D.

        Raises:
            InvalidGeometry: bad centre or normal.
            InvalidParameter: bad radius, start angle or ``ccw``.
        """
        c = _vector("center", center, error=InvalidGeometry)
        r = check_positive("radius", radius, unit="m")
        a0 = finite_scalar(
            "start_angle", start_angle, unit="rad", what="angle", error=InvalidParameter
        )
        if not isinstance(ccw, (bool, np.bool_)):
            raise InvalidParameter(f"ccw: expected True or False, got {type(ccw).__name__}")
        if c.shape[0] == 2:
            if normal is not None:
                raise InvalidGeometry(
                    "normal: a 2-D circle (center of shape (2,)) lies in its plane, expected "
                    f"normal=None, got {type(normal).__name__}"
                )
            e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
        elif c.shape[0] == 3:
            if normal is None:
                raise InvalidGeometry(
                    "normal: a 3-D circle (center of shape (3,)) needs its plane normal, "
                    "shape (3,), got None; pass normal=... or a 2-D center"
                )
            nv = _vector("normal", normal, 3, error=InvalidGeometry)
            nn = float(np.linalg.norm(nv))
            if nn == 0.0:
                raise InvalidGeometry("normal: expected a non-zero vector, got [0, 0, 0]")
            nv = nv / nn
            axis = np.eye(3)[int(np.argmin(np.abs(nv)))]
            e1 = _unit(axis - (axis @ nv) * nv)
            e2 = np.cross(nv, e1)
        else:
            raise InvalidGeometry(
                f"center: Circle is 2-D or 3-D, expected shape (2,) or (3,), got shape {c.shape}"
            )
        sign = 1.0 if ccw else -1.0
        u = math.cos(a0) * e1 + math.sin(a0) * e2
        v = sign * (-math.sin(a0) * e1 + math.cos(a0) * e2)
        self._center, self._radius = _readonly(c), r
        self._e1, self._e2 = _readonly(e1), _readonly(e2)
        self._build([("arc", c, u, v, r, 2.0 * math.pi)], closed=True)

    @property
    def center(self) -> FloatArray:
        """Centre, shape (n,) [m], read-only."""
        return self._center

    @property
    def radius(self) -> float:
        """Radius [m]."""
        return self._radius


class Polyline(_Piecewise):
    r"""Straight segments joined by circular arcs tangent to both neighbours (C¹, n-D).

    At a corner with unit directions :math:`d_1` (in) and :math:`d_2` (out), turn angle
    :math:`\alpha = \arccos(d_1 \cdot d_2)` and radius :math:`r`, the arc starts
    :math:`t = r\tan(\alpha/2)` before the vertex along :math:`d_1` and ends :math:`t` after it
    along :math:`d_2`; its length is :math:`r\alpha`. So the smoothed length is
    :math:`\sum_j |V_{j+1} - V_j| - \sum_i (2 t_i - r_i\alpha_i)`. Curvature is zero on the
    straight parts and :math:`1/r_i` on arc i: it jumps at the joins (the path is C¹, not C²).

    An open polyline has corners at its interior vertices and ``s = 0`` at the first vertex. A
    closed one has a corner at every vertex and ``s = 0`` where the path leaves the arc of
    vertex 0 along the segment towards vertex 1.
    """

    __slots__ = ("_radii", "_vertices")

    def __init__(
        self, vertices: ArrayLike, *, corner_radius: float | ArrayLike, closed: bool = False
    ) -> None:
        """Validate and build the smoothed polyline.

        Args:
            vertices: Vertices, shape (N, n) [m], n >= 2; N >= 2 (open) or N >= 3 (closed; a
                repeated first vertex at the end is dropped). Consecutive vertices must differ.
            corner_radius: Arc radius [m] at every corner (> 0), or one per corner, shape (N - 2,)
                open or (N,) closed, in the order of the vertices.
            closed: Join the last vertex back to the first.

        Raises:
            InvalidGeometry: bad vertices, a corner that reverses direction, or an arc that does
                not fit (its tangent length ``r·tan(α/2)`` exceeds half an adjacent segment).
            InvalidParameter: bad radii.
        """
        if not isinstance(closed, (bool, np.bool_)):
            raise InvalidParameter(f"closed: expected True or False, got {type(closed).__name__}")
        V = _vertices("vertices", vertices, 3 if closed else 2)
        if closed and V.shape[0] > 3 and np.array_equal(V[0], V[-1]):
            V = V[:-1]
        seg = (np.roll(V, -1, axis=0) - V) if closed else np.diff(V, axis=0)
        seg_len = np.linalg.norm(seg, axis=1)
        for jz in np.flatnonzero(seg_len == 0.0):
            raise InvalidGeometry(
                f"vertices: expected distinct consecutive vertices, got vertex {jz} equal to "
                f"vertex {(jz + 1) % len(V)} at {V[jz].tolist()}; remove the repeat"
            )
        dirs = seg / seg_len[:, None]
        corners: list[int] = list(range(len(V))) if closed else list(range(1, len(V) - 1))
        radii = self._radii_arg(corner_radius, len(corners))
        m = len(seg)
        tan_len = np.zeros(len(V))
        arcs: dict[int, tuple[str, FloatArray, FloatArray, FloatArray, float, float]] = {}
        for ci, (i, r) in enumerate(zip(corners, radii, strict=True)):
            d1, d2 = dirs[(i - 1) % m], dirs[i % m]
            cosa = float(np.clip(d1 @ d2, -1.0, 1.0))
            w = d2 - cosa * d1
            wn = float(np.linalg.norm(w))
            alpha = math.atan2(wn, cosa)
            if alpha < STRAIGHT_ANGLE:
                continue
            if wn <= 1e-12 or math.pi - alpha < 1e-9:
                raise InvalidGeometry(
                    f"corner {ci} (vertex {i} at {V[i].tolist()}) reverses direction (turn angle "
                    "180 deg); no tangent arc exists there; move or remove the vertex"
                )
            t = r * math.tan(alpha / 2.0)
            for adj in ((i - 1) % m, i % m):
                half = 0.5 * float(seg_len[adj])
                if t > half * (1.0 + 1e-12):
                    raise InvalidGeometry(
                        f"corner {ci} (vertex {i} at {V[i].tolist()}): the arc of radius {r} m "
                        f"needs a tangent length r*tan(alpha/2) = {t:.6g} m, expected <= half "
                        f"of the adjacent segment {adj} ({half:.6g} m); reduce corner_radius "
                        f"to <= {half / math.tan(alpha / 2.0):.6g} m"
                    )
            tan_len[i] = t
            nperp = w / wn
            start = V[i] - t * d1
            arcs[i] = ("arc", start + r * nperp, -nperp, d1, r, alpha)
        pieces: list[tuple[str, FloatArray, FloatArray, FloatArray, float, float]] = []
        zero = np.zeros(V.shape[1])
        for j in range(m):
            a, b = int(j), (int(j) + 1) % len(V)
            L = float(seg_len[j]) - tan_len[a] - tan_len[b]
            if float(seg_len[j]) * 1e-12 < L:
                pieces.append(("line", V[a] + tan_len[a] * dirs[j], dirs[j], zero, 1.0, L))
            if b in arcs and (closed or b != 0):
                pieces.append(arcs[b])
        self._vertices = _readonly(V)
        self._radii = _readonly(np.asarray(radii))
        self._build(pieces, closed=bool(closed))

    @staticmethod
    def _radii_arg(corner_radius: Any, count: int) -> list[float]:
        if not isinstance(corner_radius, (list, tuple, np.ndarray)) or (
            isinstance(corner_radius, np.ndarray) and corner_radius.ndim == 0
        ):
            r = check_positive("corner_radius", corner_radius, unit="m")
            return [r] * count
        arr = real_array(
            "corner_radius", corner_radius, error=InvalidParameter, what="radii [m]"
        ).reshape(-1)
        if arr.shape[0] != count:
            raise InvalidParameter(
                f"corner_radius: expected one radius per corner, shape ({count},), got "
                f"shape {np.shape(corner_radius)}"
            )
        return [
            check_positive(f"corner_radius[{i}]", x, unit="m") for i, x in enumerate(arr.tolist())
        ]

    @property
    def vertices(self) -> FloatArray:
        """Vertices, shape (N, n) [m], read-only."""
        return self._vertices

    @property
    def corner_radii(self) -> FloatArray:
        """Arc radius [m] per corner, shape (corners,), read-only."""
        return self._radii


# ---------------------------------------------------------------------------- spline
class Spline(_PathBase):
    r"""A C² cubic spline through points, re-parametrised by arc length (n-D).

    Construction: chord-length parameter :math:`u` (cumulative distances between the points); a
    natural cubic spline in each coordinate (zero second derivative at the ends) when open, a
    periodic one when closed. Arc length :math:`s(u) = \int |x'(u)|\,du` is tabulated on
    ``SUBDIVISIONS`` sub-pieces per interval with an 8-point Gauss–Legendre rule (relative error
    about ``1e-14`` for smooth data). For a query ``s`` the table gives a bracket and a linear
    first guess, then Newton steps on :math:`s(u) - s = 0` converge to round-off, so
    :math:`|R_p(s+h) - R_p(s)| = h + O(h^3\kappa^2)` holds to about ``1e-12`` relative.

    The tangent :math:`T = x'/|x'|` and the curvature vector
    :math:`\kappa N = (x'' - (x''\cdot T)T)/|x'|^2` are the exact derivatives of the evaluated
    curve, so they agree with finite differences of :meth:`point` to the differences' own error.

    Building solves a dense (N × N) system: fine for up to a few thousand points.
    """

    __slots__ = ("_S", "_U", "_X", "_coef", "_knots", "_points")

    #: A Newton solve per query (a few microseconds each): batches are bounded to stay well
    #: under a second per call.
    MAX_BATCH = 100_000

    #: Sub-pieces per spline interval in the arc-length table.
    SUBDIVISIONS = 16

    def __init__(self, points: ArrayLike, *, closed: bool = False) -> None:
        """Validate and build the spline.

        Args:
            points: Points the curve passes through, in order, shape (N, n) [m], n >= 2;
                N >= 2 open, N >= 3 closed (a repeated first point at the end is dropped).
                Consecutive points must differ.
            closed: Periodic spline through the points and back to the first.

        Raises:
            InvalidGeometry: bad points, repeated consecutive points, or a curve that nearly
                stops (a cusp: the points double back sharply).
            InvalidParameter: ``closed`` not a bool.
        """
        if not isinstance(closed, (bool, np.bool_)):
            raise InvalidParameter(f"closed: expected True or False, got {type(closed).__name__}")
        P = _vertices("points", points, 3 if closed else 2)
        if closed and P.shape[0] > 3 and np.array_equal(P[0], P[-1]):
            P = P[:-1]
        Y = np.vstack([P, P[:1]]) if closed else P
        h = np.linalg.norm(np.diff(Y, axis=0), axis=1)
        for j in np.flatnonzero(h == 0.0):
            raise InvalidGeometry(
                f"points: expected distinct consecutive points, got point {j} equal to point "
                f"{(j + 1) % len(P)} at {P[j].tolist()}; remove the repeat"
            )
        M = self._second_derivatives(Y, h, closed=bool(closed))
        a = Y[:-1]
        c = M[:-1] / 2.0
        d = (M[1:] - M[:-1]) / (6.0 * h[:, None])
        b = (Y[1:] - Y[:-1]) / h[:, None] - h[:, None] * (2.0 * M[:-1] + M[1:]) / 6.0
        self._coef = _readonly(np.stack([a, b, c, d]))  # (4, K, n)
        self._knots = _readonly(np.concatenate(([0.0], np.cumsum(h))))
        self._points = _readonly(P)
        self._closed = bool(closed)
        self._dim = int(P.shape[1])
        self._tabulate(h)

    @staticmethod
    def _second_derivatives(Y: FloatArray, h: FloatArray, *, closed: bool) -> FloatArray:
        K = len(h)
        slope = np.diff(Y, axis=0) / h[:, None]
        M = np.zeros_like(Y)
        if closed:
            A = np.zeros((K, K))
            rhs = np.zeros((K, Y.shape[1]))
            for k in range(K):
                hp, hk = h[k - 1], h[k]
                A[k, (k - 1) % K] += hp
                A[k, k] += 2.0 * (hp + hk)
                A[k, (k + 1) % K] += hk
                rhs[k] = 6.0 * (slope[k] - slope[k - 1])
            M[:-1] = np.linalg.solve(A, rhs)
            M[-1] = M[0]
        elif K > 1:
            A = np.zeros((K - 1, K - 1))
            for k in range(1, K):
                A[k - 1, k - 1] = 2.0 * (h[k - 1] + h[k])
                if k > 1:
                    A[k - 1, k - 2] = h[k - 1]
                if k < K - 1:
                    A[k - 1, k] = h[k]
            M[1:-1] = np.linalg.solve(A, 6.0 * np.diff(slope, axis=0))
        return M

    def _deriv(self, k: NDArray[np.intp], t: FloatArray) -> tuple[FloatArray, FloatArray]:
        """x'(u), x''(u) on intervals ``k`` at local parameters ``t`` (same leading shape)."""
        _, b, c, d = (self._coef[i][k] for i in range(4))
        tt = t[..., None]
        return b + tt * (2.0 * c + 3.0 * tt * d), 2.0 * c + 6.0 * tt * d

    def _speed_integral(self, k: NDArray[np.intp], t0: FloatArray, t1: FloatArray) -> FloatArray:
        r""":math:`\int_{t_0}^{t_1} |x'|` on interval ``k`` (Gauss–Legendre), shape (N,)."""
        half = (t1 - t0) / 2.0
        nodes = t0[:, None] + half[:, None] * (_GL_X[None, :] + 1.0)
        kk = np.broadcast_to(k[:, None], nodes.shape)
        speed = np.linalg.norm(self._deriv(kk, nodes)[0], axis=-1)
        return np.asarray(half * (speed @ _GL_W), dtype=float)

    def _tabulate(self, h: FloatArray) -> None:
        m = self.SUBDIVISIONS
        K = len(h)
        k = np.repeat(np.arange(K), m)
        frac = np.tile(np.arange(m) / m, K)
        t0 = frac * h[k]
        t1 = t0 + h[k] / m
        ds = self._speed_integral(k, t0, t1)
        self._S = _readonly(np.concatenate(([0.0], np.cumsum(ds))))
        self._U = _readonly(np.concatenate((self._knots[k] + t0, [self._knots[-1]])))
        self._length = float(self._S[-1])
        # A cusp check: the speed |x'| must stay well away from zero (else s(u) is not smooth).
        probe = np.concatenate([t0[:, None] + (t1 - t0)[:, None] * np.linspace(0, 1, 5)], axis=0)
        sp = np.linalg.norm(self._deriv(np.repeat(k[:, None], 5, axis=1), probe)[0], axis=-1)
        if float(sp.min()) < 1e-3:
            j = int(k[int(np.argmin(sp.min(axis=1)))])
            raise InvalidGeometry(
                f"points: the spline nearly stops (|dx/du| = {float(sp.min()):.3g}, expected "
                f">= 1e-3) between points {j} and {(j + 1) % len(self._points)}; the points "
                "double back sharply; add points there or use a Polyline"
            )
        self._X = _readonly(self._frames(self._S)[0])

    def _u_of_s(self, S: FloatArray) -> tuple[NDArray[np.intp], FloatArray]:
        """Interval index and local parameter of arc lengths ``S`` (in [0, length])."""
        J = len(self._S) - 1
        j = np.clip(np.searchsorted(self._S, S, side="right") - 1, 0, J - 1)
        s0, s1 = self._S[j], self._S[j + 1]
        u0, u1 = self._U[j], self._U[j + 1]
        k = j // self.SUBDIVISIONS
        base = self._knots[k]
        lo, hi = u0 - base, u1 - base
        t = lo + (S - s0) / (s1 - s0) * (hi - lo)
        for _ in range(3):
            F = s0 + self._speed_integral(k, lo, t) - S
            sp = np.linalg.norm(self._deriv(k, t)[0], axis=-1)
            t = np.clip(t - F / sp, lo, hi)
        return k, t

    def _frames(self, S: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        k, t = self._u_of_s(S)
        a, b, c, d = (self._coef[i][k] for i in range(4))
        tt = t[:, None]
        x = a + tt * (b + tt * (c + tt * d))
        x1, x2 = self._deriv(k, t)
        sp = np.linalg.norm(x1, axis=1)[:, None]
        T = x1 / sp
        kn = (x2 - np.sum(x2 * T, axis=1)[:, None] * T) / sp**2
        return x, T, kn

    def _candidates(
        self, p: FloatArray, intervals: list[tuple[float, float]], ref: float | None
    ) -> list[float]:
        out: list[float] = []
        spacing = float(np.max(np.diff(self._S)))
        for lo, hi in intervals:
            tab = self._S
            inside = np.flatnonzero((tab > lo) & (tab < hi))
            s = np.concatenate(([lo], tab[inside], [hi]))
            X = np.vstack([self._frames(np.array([lo]))[0], self._X[inside]])
            X = np.vstack([X, self._frames(np.array([hi]))[0]])
            d = np.linalg.norm(X - p, axis=1)
            out += [lo, hi]
            # Refine every sampled local minimum that could hold the true minimum.
            n = len(s)
            for i in range(n):
                left = d[i - 1] if i > 0 else np.inf
                right = d[i + 1] if i < n - 1 else np.inf
                if d[i] <= left and d[i] <= right and d[i] <= d.min() + spacing:
                    out.append(
                        self._refine(p, float(s[max(i - 1, 0)]), float(s[min(i + 1, n - 1)]))
                    )
        return out

    def _refine(self, p: FloatArray, a: float, b: float) -> float:
        """Root of g(s) = T·(R - p) in [a, b] by safeguarded Newton; an end if g keeps its sign."""

        def g(s: float) -> tuple[float, float]:
            x, T, kn = self._frames(np.array([s]))
            r = x[0] - p
            return float(T[0] @ r), 1.0 + float(kn[0] @ r)

        ga, gb = g(a)[0], g(b)[0]
        if ga >= 0.0 or gb <= 0.0:
            return a if ga >= 0.0 else b
        x = 0.5 * (a + b)
        for _ in range(60):
            gx, dg = g(x)
            if gx == 0.0:
                return x
            if gx < 0.0:
                a = x
            else:
                b = x
            xn = x - gx / dg if dg > 0.0 else math.nan
            step_ok = a < xn < b
            if step_ok and abs(xn - x) <= 4e-16 * (1.0 + self._length):
                return xn
            x = xn if step_ok else 0.5 * (a + b)
            if b - a <= 4e-16 * (1.0 + self._length):
                break
        return x

    @property
    def points_through(self) -> FloatArray:
        """The interpolated points, shape (N, n) [m], read-only."""
        return self._points


document_inits(globals())
