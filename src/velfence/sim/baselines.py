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
import sys
from typing import Any

import numpy as np

from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import MAX_MAGNITUDE, check_positive, show
from velfence.errors import InvalidGeometry, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, Rectangle, as_polygon
from velfence.shaping import ZONE_NAMES
from velfence.shaping.base import OnInvalid, ShaperBase
from velfence.shaping.shared_kernels import compiled_loop, zone_code

__all__ = ["AxisLimits", "HardStop", "NoLimit"]


_FREE = ZONE_NAMES.index("free")

# (ox, oy, zone, primary, secondary, d1, d2, sx, sy, stages)
_Out = tuple[float, float, int, int, int, float, float, float, float, tuple[str, ...]]


# ---------------------------------------------------------------- kernels
# Each baseline's law is written once, as a scalar kernel on floats; `_law` runs it as Python and
# `_law_batch` runs its `*_batch` loop, compiled with numba when installed (else as Python), so
# the two can only agree. Plain arithmetic only (see velfence.shaping._kernels).

# Replaced by numba.prange in the compiled twins; plain range in pure Python.
prange = range


def hard_stop_kernel(
    px: float, py: float, vx: float, vy: float, nx: Any, ny: Any, off: Any, n: int, dt: float
) -> tuple[float, float, int, int, int, float, float]:
    """HardStop's law: ``(ox, oy, zone, primary, secondary, d1, d2)`` (class docs)."""
    p1 = -1
    p2 = -1
    d1 = math.inf
    d2 = math.inf
    qx = px + dt * vx
    qy = py + dt * vy
    blocked = False
    for e in range(n):
        d = nx[e] * px + ny[e] * py - off[e]
        if d < d1:
            d2 = d1
            p2 = p1
            d1 = d
            p1 = e
        elif d < d2:
            d2 = d
            p2 = e
        if nx[e] * qx + ny[e] * qy - off[e] < 0.0:
            blocked = True
    # Outside: one violated constraint reported; inside: the blocked step is the near one.
    zone = zone_code(1 if d1 < 0.0 else 0, 1 if blocked else 0)
    if blocked:
        return 0.0, 0.0, zone, p1, p2, d1, d2
    return vx, vy, zone, p1, p2, d1, d2


def hard_stop_batch(
    P: Any, V: Any, out: Any, zones: Any, nx: Any, ny: Any, off: Any, n: int, dt: float
) -> None:
    """Loop of :func:`hard_stop_kernel` over rows (writes ``out`` (N, 2), ``zones`` (N,))."""
    for r in prange(len(P)):
        res = hard_stop_kernel(P[r][0], P[r][1], V[r][0], V[r][1], nx, ny, off, n, dt)
        out[r][0] = res[0]
        out[r][1] = res[1]
        zones[r] = res[2]


def _axis(u: float, d_lo: float, d_hi: float, b: float, k: float) -> tuple[float, float, int]:
    """One axis of AxisLimits: (shaped component, spring, stage bits 1=scaled 2=zeroed)."""
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


def axis_limits_kernel(
    px: float,
    py: float,
    vx: float,
    vy: float,
    xmin: float,
    xmax: float,
    ymin: float,
    ymax: float,
    b: float,
    k: float,
) -> tuple[float, float, int, int, int, float, float, float, float, int]:
    """AxisLimits' law: ``(ox, oy, zone, primary, secondary, d1, d2, sx, sy, bits)``.

    The limit distances are ``d = [y - ymin, xmax - x, ymax - y, x - xmin]``; ``bits``: 1 a
    component was scaled, 2 one was zeroed.
    """
    p1 = -1
    p2 = -1
    d1 = math.inf
    d2 = math.inf
    near = 0
    for e in range(4):
        if e == 0:
            d = py - ymin
        elif e == 1:
            d = xmax - px
        elif e == 2:
            d = ymax - py
        else:
            d = px - xmin
        if d < b:
            near += 1
        if d < d1:
            d2 = d1
            p2 = p1
            d1 = d
            p1 = e
        elif d < d2:
            d2 = d
            p2 = e
    ox, sx, bx = _axis(vx, px - xmin, xmax - px, b, k)
    oy, sy, by = _axis(vy, py - ymin, ymax - py, b, k)
    zone = zone_code(1 if d1 < 0.0 else 0, near)
    return ox, oy, zone, p1, p2, d1, d2, sx, sy, bx | by


def axis_limits_batch(
    P: Any,
    V: Any,
    out: Any,
    zones: Any,
    xmin: float,
    xmax: float,
    ymin: float,
    ymax: float,
    b: float,
    k: float,
) -> None:
    """Loop of :func:`axis_limits_kernel` over rows (writes ``out`` (N, 2), ``zones`` (N,))."""
    for r in prange(len(P)):
        res = axis_limits_kernel(
            P[r][0], P[r][1], V[r][0], V[r][1], xmin, xmax, ymin, ymax, b, k
        )  # fmt: skip
        out[r][0] = res[0]
        out[r][1] = res[1]
        zones[r] = res[2]


def _run_batch(name: str, P: FloatArray, V: FloatArray, *args: Any) -> tuple[FloatArray, IntArray]:
    """Run the ``name`` batch loop: compiled when numba is installed, else as Python."""
    out = np.empty_like(P)
    zones = np.empty(P.shape[0], dtype=np.int64)
    deps = {
        "hard_stop_batch": ("hard_stop_kernel",),
        "axis_limits_batch": ("_axis", "axis_limits_kernel"),
    }
    fn = compiled_loop(sys.modules[__name__], *deps[name], name)
    if fn is not None:
        fn(P, V, out, zones, *args)
        return out, zones
    res = np.zeros_like(P).tolist()
    zl = [0] * P.shape[0]
    globals()[name](P.tolist(), V.tolist(), res, zl, *args)
    out[:] = res
    zones[:] = zl
    return out, zones


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

    def __init__(self, *, on_invalid: OnInvalid = "raise") -> None:
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

    def __init__(
        self, polygon: ConvexPolygon, *, dt: float, on_invalid: OnInvalid = "raise"
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        self.polygon = as_polygon(polygon)
        self.dt = check_positive("dt", dt, unit="s")
        self._nx = tuple(float(a) for a in polygon.normals[:, 0])
        self._ny = tuple(float(a) for a in polygon.normals[:, 1])
        self._off = tuple(float(a) for a in polygon.offsets)

    def _law(self, px: float, py: float, vx: float, vy: float) -> _Out:
        r = hard_stop_kernel(px, py, vx, vy, self._nx, self._ny, self._off, len(self._off), self.dt)
        return r[0], r[1], r[2], r[3], r[4], r[5], r[6], 0.0, 0.0, ()

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        return _run_batch(
            "hard_stop_batch", P, V, np.asarray(self._nx), np.asarray(self._ny),
            np.asarray(self._off), len(self._off), self.dt,
        )  # fmt: skip

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
        on_invalid: OnInvalid = "raise",
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
                f"rectangle must be finite with xmin < xmax and ymin < ymax, got {show(r)}"
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
        on_invalid: OnInvalid = "raise",
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

    def _law(self, px: float, py: float, vx: float, vy: float) -> _Out:
        r = self.rectangle
        ox, oy, zone, p1, p2, d1, d2, sx, sy, bits = axis_limits_kernel(
            px, py, vx, vy, r.xmin, r.xmax, r.ymin, r.ymax, self.buffer, self.spring_gain
        )
        stages: list[str] = []
        if bits & 1:
            stages.append("primary-projection")
        if bits & 2:
            stages.append("zero-outward")
        if d1 < 0.0 and self.spring_gain > 0.0:
            stages.append("spring")
        return ox, oy, zone, p1, p2, d1, d2, sx, sy, tuple(stages)

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        r = self.rectangle
        return _run_batch(
            "axis_limits_batch", P, V, float(r.xmin), float(r.xmax), float(r.ymin),
            float(r.ymax), self.buffer, self.spring_gain,
        )  # fmt: skip

    def __repr__(self) -> str:
        r = self.rectangle
        return (
            f"AxisLimits(x=[{r.xmin:.4g}, {r.xmax:.4g}], y=[{r.ymin:.4g}, {r.ymax:.4g}], "
            f"buffer={self.buffer}, spring_gain={self.spring_gain})"
        )


document_inits(globals())
