"""Baseline shapers to compare velfence's laws against, on the same :class:`Shaper` contract.

* :class:`NoLimit` passes every command unchanged (the unprotected robot).
* :class:`HardStop` is the classic sticky software limit: zero velocity whenever the next explicit
  Euler step ``p + dt·v`` would leave the polygon, the command unchanged otherwise.
* :class:`AxisLimits` is a conventional per-joint limit: each axis of an axis-aligned rectangle
  (usually the polygon's largest inscribed rectangle) is limited on its own, with a linear buffer.

Every baseline implements ``shape``, ``explain``, ``shape_batch`` and ``zones_batch`` with the same
semantics as :class:`~velfence.shaping.polygon.PolygonShaper` (zones index
``velfence.shaping.ZONE_NAMES``; non-finite input raises or, with ``on_invalid="stop"``, gives zero
velocity and zone ``"invalid"``). Definitions in ``docs/simulation.md`` §3.
"""

from __future__ import annotations

import math

import numpy as np

from velfence._typing import FloatArray, IntArray
from velfence._validate import MAX_MAGNITUDE, check_positive
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, Rectangle, as_polygon
from velfence.shaping import ZONE_NAMES
from velfence.shaping.base import ShaperBase

__all__ = ["AxisLimits", "HardStop", "NoLimit"]


_FREE = ZONE_NAMES.index("free")
_BUFFER = ZONE_NAMES.index("buffer")
_CORNER = ZONE_NAMES.index("corner")
_OUTSIDE = ZONE_NAMES.index("outside")
_OUTSIDE_CORNER = ZONE_NAMES.index("outside-corner")
_INVALID = ZONE_NAMES.index("invalid")

# (ox, oy, zone, primary, secondary, d1, d2, sx, sy, stages)
_Out = tuple[float, float, int, int, int, float, float, float, float, tuple[str, ...]]


def _two_smallest(d: list[float]) -> tuple[int, int, float, float]:
    """Indices and values of the smallest and second-smallest entries (first index on ties)."""
    p1 = p2 = -1
    d1 = d2 = math.inf
    for i, x in enumerate(d):
        if x < d1:
            p2, d2 = p1, d1
            p1, d1 = i, x
        elif x < d2:
            p2, d2 = i, x
    return p1, p2, d1, d2


class _Baseline(ShaperBase):
    """A baseline: its law twice, on floats and on arrays, with identical results.

    Both versions use the same floating-point operations in the same order; parsing,
    ``on_invalid`` and batch validation come from :class:`ShaperBase`.
    """

    __slots__ = ()
    method = "baseline"


class NoLimit(_Baseline):
    """The unprotected robot: every command passes unchanged (zone always ``"free"``).

    Args:
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity, zone ``"invalid"``) for
            non-finite input.
    """

    __slots__ = ()
    method = "no-limit"

    def __init__(self, *, on_invalid: str = "raise") -> None:
        super().__init__(on_invalid=on_invalid)

    def _law(self, px: float, py: float, vx: float, vy: float) -> _Out:
        # No edges (primary = secondary = -1): the distances report "farther than any
        # workspace" as the largest magnitude the library handles, a finite number.
        return vx, vy, _FREE, -1, -1, MAX_MAGNITUDE, MAX_MAGNITUDE, 0.0, 0.0, ()

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        return V.copy(), np.full(V.shape[0], _FREE, dtype=np.int64)

    def __repr__(self) -> str:
        return "NoLimit()"


class HardStop(_Baseline):
    """The classic sticky software limit on a convex polygon.

    Output is zero when the next explicit Euler step ``p + dt·v`` leaves the closed polygon
    (any signed distance ``< 0``), and the command unchanged otherwise. Faithful to the classic
    limit, also **outside**: there every command whose single step does not land back inside is
    zeroed, so a point pushed out by more than ``dt·|v|`` is deadlocked (see
    ``docs/simulation.md`` §3.2).

    Zones: ``"outside"`` when ``p`` is outside; otherwise ``"buffer"`` when the step was blocked
    and ``"free"`` when it passed. ``primary``/``secondary`` are the nearest and second-nearest
    edges (smallest signed distances) at ``p``.

    Args:
        polygon: The permissible workspace.
        dt: Control period used to predict the next position, in [s]. Must be > 0.
        on_invalid: ``"raise"`` (default) or ``"stop"`` for non-finite input.

    Raises:
        InvalidParameter: for a non-polygon or a non-positive ``dt``.
    """

    __slots__ = ("_nx", "_ny", "_off", "dt", "polygon")
    method = "hard-stop"

    def __init__(self, polygon: ConvexPolygon, *, dt: float, on_invalid: str = "raise") -> None:
        super().__init__(on_invalid=on_invalid)
        self.polygon = as_polygon(polygon)
        self.dt = check_positive("dt", dt, unit="s")
        self._nx = tuple(float(a) for a in polygon.normals[:, 0])
        self._ny = tuple(float(a) for a in polygon.normals[:, 1])
        self._off = tuple(float(a) for a in polygon.offsets)

    def _dist(self, x: float, y: float) -> list[float]:
        return [a * x + b * y - o for a, b, o in zip(self._nx, self._ny, self._off, strict=True)]

    def _law(self, px: float, py: float, vx: float, vy: float) -> _Out:
        d = self._dist(px, py)
        p1, p2, d1, d2 = _two_smallest(d)
        nxt = self._dist(px + self.dt * vx, py + self.dt * vy)
        blocked = min(nxt) < 0.0
        zone = _OUTSIDE if d1 < 0.0 else (_BUFFER if blocked else _FREE)
        if blocked:
            return 0.0, 0.0, zone, p1, p2, d1, d2, 0.0, 0.0, ()
        return vx, vy, zone, p1, p2, d1, d2, 0.0, 0.0, ()

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        nx = np.asarray(self._nx)[None, :]
        ny = np.asarray(self._ny)[None, :]
        off = np.asarray(self._off)[None, :]
        d = P[:, 0:1] * nx + P[:, 1:2] * ny - off
        Q = P + self.dt * V
        dn = Q[:, 0:1] * nx + Q[:, 1:2] * ny - off
        blocked = dn.min(axis=1) < 0.0
        outside = d.min(axis=1) < 0.0
        out = np.where(blocked[:, None], 0.0, V)
        zones = np.where(outside, _OUTSIDE, np.where(blocked, _BUFFER, _FREE)).astype(np.int64)
        return out, zones

    def __repr__(self) -> str:
        return f"HardStop({self.polygon.n}-gon, dt={self.dt})"


class AxisLimits(_Baseline):
    r"""Independent per-axis joint limits on an axis-aligned rectangle, with a linear buffer.

    Per axis, with limits ``[lo, hi]``, coordinate ``x`` and commanded component ``u``
    (``d_hi = hi - x``, ``d_lo = x - lo``):

    * ``u > 0``: unchanged if ``d_hi >= buffer``; scaled by ``d_hi / buffer`` if
      ``0 <= d_hi < buffer``; zeroed if ``d_hi < 0`` (beyond the limit);
    * ``u < 0``: the same with ``d_lo``;
    * then, beyond a limit, a per-axis spring is added: ``+spring_gain · d_hi`` if ``d_hi < 0``,
      ``-spring_gain · d_lo`` if ``d_lo < 0`` (zero for the default ``spring_gain = 0``).

    The scaling is the same linear profile as the patent's buffer (``d/d_max``), applied to each
    joint separately instead of to the normal of the nearest edge.

    Zones (from the four limit distances ``d = [y - ymin, xmax - x, ymax - y, x - xmin]``, the
    edges of :attr:`Rectangle.corners` in order): ``"free"`` when every ``d >= buffer``;
    ``"buffer"`` when exactly one ``d < buffer``; ``"corner"`` when two or more; ``"outside"`` /
    ``"outside-corner"`` when some ``d < 0`` and one / several ``d < buffer``. Stages:
    ``"primary-projection"`` when a component was scaled, ``"zero-outward"`` when one was zeroed,
    ``"spring"`` when a spring was added.

    Args:
        rectangle: The joint limits, workspace units.
        buffer: Width of the buffer band inside each limit, workspace units. Must be > 0.
        spring_gain: Per-axis spring gain beyond a limit, in [1/s]. Must be >= 0.
        on_invalid: ``"raise"`` (default) or ``"stop"`` for non-finite input.

    Raises:
        InvalidGeometry: for an empty or non-finite rectangle.
        InvalidParameter: for a non-rectangle or an out-of-range parameter.
    """

    __slots__ = ("buffer", "rectangle", "spring_gain")
    method = "axis-limits"

    def __init__(
        self,
        rectangle: Rectangle,
        *,
        buffer: float,
        spring_gain: float = 0.0,
        on_invalid: str = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        if not isinstance(rectangle, Rectangle):
            raise InvalidParameter(
                f"rectangle must be a velfence.Rectangle, got {type(rectangle).__name__}; "
                "use polygon.inscribed_rectangle() or AxisLimits.inscribed(polygon, ...)"
            )
        r = rectangle
        values = (r.xmin, r.xmax, r.ymin, r.ymax)
        if not all(math.isfinite(x) for x in values) or not (r.xmin < r.xmax and r.ymin < r.ymax):
            raise InvalidGeometry(
                f"rectangle must be finite with xmin < xmax and ymin < ymax, got {r!r}"
            )
        self.rectangle = rectangle
        self.buffer = check_positive("buffer", buffer, unit="workspace units")
        self.spring_gain = check_positive("spring_gain", spring_gain, allow_zero=True, unit="1/s")

    @classmethod
    def inscribed(
        cls,
        polygon: ConvexPolygon,
        *,
        buffer: float,
        spring_gain: float = 0.0,
        on_invalid: str = "raise",
    ) -> AxisLimits:
        """Axis limits on the polygon's largest inscribed axis-aligned rectangle.

        Args:
            polygon: The workspace whose conventional joint limits are wanted.
            buffer: Buffer width, workspace units (> 0).
            spring_gain: Per-axis spring gain beyond a limit, [1/s] (>= 0).
            on_invalid: ``"raise"`` or ``"stop"``.
        """
        as_polygon(polygon)
        return cls(
            polygon.inscribed_rectangle(),
            buffer=buffer,
            spring_gain=spring_gain,
            on_invalid=on_invalid,
        )

    def _axis(self, u: float, d_lo: float, d_hi: float) -> tuple[float, float, int]:
        """One axis: (shaped component, spring, stage bits 1=scaled 2=zeroed)."""
        b = self.buffer
        k = self.spring_gain
        bits = 0
        if u > 0.0:
            if d_hi < 0.0:
                u = 0.0
                bits |= 2
            elif d_hi < b:
                u = u * (d_hi / b)
                bits |= 1
        elif u < 0.0:
            if d_lo < 0.0:
                u = 0.0
                bits |= 2
            elif d_lo < b:
                u = u * (d_lo / b)
                bits |= 1
        s = 0.0
        if d_hi < 0.0:
            s = k * d_hi
        elif d_lo < 0.0:
            s = -k * d_lo
        return u + s, s, bits

    def _law(self, px: float, py: float, vx: float, vy: float) -> _Out:
        r = self.rectangle
        d = [py - r.ymin, r.xmax - px, r.ymax - py, px - r.xmin]
        p1, p2, d1, d2 = _two_smallest(d)
        ox, sx, bx = self._axis(vx, d[3], d[1])
        oy, sy, by = self._axis(vy, d[0], d[2])
        zone = _zone(sum(1 for x in d if x < self.buffer), d1 < 0.0)
        bits = bx | by
        stages: list[str] = []
        if bits & 1:
            stages.append("primary-projection")
        if bits & 2:
            stages.append("zero-outward")
        if d1 < 0.0 and self.spring_gain > 0.0:
            stages.append("spring")
        return ox, oy, zone, p1, p2, d1, d2, sx, sy, tuple(stages)

    def _axis_batch(self, u: FloatArray, d_lo: FloatArray, d_hi: FloatArray) -> FloatArray:
        b = self.buffer
        k = self.spring_gain
        up = np.where(d_hi < 0.0, 0.0, np.where(d_hi < b, u * (d_hi / b), u))
        down = np.where(d_lo < 0.0, 0.0, np.where(d_lo < b, u * (d_lo / b), u))
        shaped = np.where(u > 0.0, up, np.where(u < 0.0, down, u))
        s = np.where(d_hi < 0.0, k * d_hi, np.where(d_lo < 0.0, -k * d_lo, 0.0))
        out: FloatArray = shaped + s
        return out

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        r = self.rectangle
        x, y = P[:, 0], P[:, 1]
        d = np.stack([y - r.ymin, r.xmax - x, r.ymax - y, x - r.xmin], axis=1)
        out = np.stack(
            [
                self._axis_batch(V[:, 0], d[:, 3], d[:, 1]),
                self._axis_batch(V[:, 1], d[:, 0], d[:, 2]),
            ],
            axis=1,
        )
        near = (d < self.buffer).sum(axis=1)
        outside = d.min(axis=1) < 0.0
        zones = np.where(
            outside,
            np.where(near <= 1, _OUTSIDE, _OUTSIDE_CORNER),
            np.where(near == 0, _FREE, np.where(near == 1, _BUFFER, _CORNER)),
        ).astype(np.int64)
        return out, zones

    def __repr__(self) -> str:
        r = self.rectangle
        return (
            f"AxisLimits(x=[{r.xmin:.4g}, {r.xmax:.4g}], y=[{r.ymin:.4g}, {r.ymax:.4g}], "
            f"buffer={self.buffer}, spring_gain={self.spring_gain})"
        )


def _zone(n_near: int, outside: bool) -> int:
    if outside:
        return _OUTSIDE if n_near <= 1 else _OUTSIDE_CORNER
    if n_near == 0:
        return _FREE
    return _BUFFER if n_near == 1 else _CORNER
