r"""Velocity shaping inside a convex polygon: US 8,676,382 (``"patent"``) and our exact law.

``method="patent"`` is algorithm 100 of the patent (steps 102-115) as reconstructed in
``docs/derivations.md`` §2: arc-segment selection of a primary and a secondary edge, pass-through
outside the buffer, the outward normal component scaled by :math:`\hat d = 1 - d/d_{max}` inside
the buffer, the two-stage corner projection, and outside: outward normal zeroed, tangent kept,
virtual spring :math:`k d n` blended between the two normals near a corner.

``method="exact"`` (derivations §3) is the minimum-change velocity subject to one half-plane bound
per nearby edge, solved in closed form:

.. math::
    v_o = \arg\min_x \|x - v\|^2 \;\text{s.t.}\;
    n_i\cdot x \ge \begin{cases} -(\|v\| + R)\, d_i/d_{max} & 0 \le d_i < d_{max}\\
    \min(k\,(-d_i),\ r_{max}) & d_i < 0 \end{cases}

with :math:`R` the largest recovery bound (0 inside). It keeps every edge's bound at once (no
sequential-projection error at corners), is continuous in position and command, never speeds up a
command inside, and outside always reduces every violation at a bounded recovery speed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon
from velfence.shaping import _kernels as kern
from velfence.shaping._accel import compiled_batch
from velfence.shaping.base import (
    FloatArray,
    ShapingResult,
    as_pair,
    as_rows,
    check_choice,
    check_positive,
)

__all__ = ["PolygonShaper"]

_METHODS = ("patent", "exact")


class PolygonShaper:
    r"""Shape commanded velocities so that a point stays inside a convex polygon.

    Args:
        polygon: The permissible workspace.
        buffer: Width :math:`d_{max}` of the buffer band inside the boundary, in workspace units
            (e.g. [rad] for the wrist). Must be > 0.
        spring_gain: Virtual-spring gain :math:`k` pulling a point outside back, in [1/s]
            (velocity per unit of penetration). Must be >= 0.
        method: ``"patent"`` (US 8,676,382, faithful) or ``"exact"`` (our improved law).
        corner_blend_angle: :math:`\theta_{max}` of the patent's spring blend near corners, in
            [rad], in (0, π). Only used by ``"patent"``.
        max_recovery_speed: Largest recovery speed the exact law demands outside, in workspace
            units per second; default ``spring_gain * buffer``. Only used by ``"exact"``.
        on_invalid: ``"raise"`` (default): non-finite inputs raise
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: return zero velocity, zone
            ``"invalid"``.
        accelerate: Use numba for :meth:`shape_batch` when it is installed (default True).

    Raises:
        InvalidParameter: for any parameter out of range, naming it and the value got.
    """

    __slots__ = (
        "_batch_args",
        "_fast",
        "accelerate",
        "buffer",
        "corner_blend_angle",
        "max_recovery_speed",
        "method",
        "on_invalid",
        "polygon",
        "spring_gain",
    )

    def __init__(
        self,
        polygon: ConvexPolygon,
        *,
        buffer: float,
        spring_gain: float = 0.0,
        method: str = "exact",
        corner_blend_angle: float = 0.3,
        max_recovery_speed: float | None = None,
        on_invalid: str = "raise",
        accelerate: bool = True,
    ) -> None:
        if not isinstance(polygon, ConvexPolygon):
            raise InvalidParameter(
                f"polygon must be a velfence.ConvexPolygon, got {type(polygon).__name__}; "
                "build one with velfence.ConvexPolygon(corners)"
            )
        self.polygon = polygon
        self.buffer = check_positive("buffer", buffer, unit="workspace units")
        self.spring_gain = check_positive("spring_gain", spring_gain, allow_zero=True, unit="1/s")
        self.method = check_choice("method", method, _METHODS)
        self.corner_blend_angle = check_positive(
            "corner_blend_angle", corner_blend_angle, unit="rad"
        )
        if self.corner_blend_angle >= math.pi:
            raise InvalidParameter(
                f"corner_blend_angle must be in (0, π) rad, got {corner_blend_angle!r}"
            )
        if max_recovery_speed is None:
            rmax = self.spring_gain * self.buffer
        else:
            rmax = check_positive(
                "max_recovery_speed", max_recovery_speed, unit="workspace units per second"
            )
        self.max_recovery_speed = rmax
        self.on_invalid = check_choice("on_invalid", on_invalid, ("raise", "stop"))
        self.accelerate = bool(accelerate)
        nx, ny, off, cx, cy, a0, beta, n = polygon._fast
        if self.method == "patent":
            fast: tuple[Any, ...] = (
                nx, ny, off, cx, cy, a0, beta, n,
                self.buffer, self.spring_gain, self.corner_blend_angle,
            )  # fmt: skip
        else:
            fast = (nx, ny, off, cx, cy, n, self.buffer, self.spring_gain, rmax)
        self._fast = fast
        self._batch_args = tuple(
            np.asarray(a, dtype=float) if isinstance(a, tuple) else a for a in fast
        )

    # ------------------------------------------------------------------ single call
    def _run(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[float, float, int, int, int, float, float, float, float, int]:
        if self.method == "patent":
            return kern.patent_kernel(px, py, vx, vy, *self._fast)
        n = self.polygon.n
        args = (*self._fast, [0.0] * n, [0.0] * n, [0] * n)  # kernel scratch: dist, bnd, work
        return kern.exact_kernel(px, py, vx, vy, *args)

    def _invalid(self, what: str) -> None:
        if self.on_invalid == "raise":
            raise InvalidInput(
                f"{what}; expected finite values. Pass on_invalid='stop' to get zero velocity "
                "instead of an exception"
            )

    def _checked(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[float, float, int, int, int, float, float, float, float, int] | None:
        """Kernel result, or None for invalid input / overflow under ``on_invalid="stop"``."""
        s = px + py + vx + vy
        if s - s != 0.0 and not _all_finite(px, py, vx, vy):
            self._invalid(f"non-finite input: position=({px}, {py}), command=({vx}, {vy})")
            return None
        r = self._run(px, py, vx, vy)
        if r[0] - r[0] != 0.0 or r[1] - r[1] != 0.0:
            self._invalid(f"input too large, the shaped velocity overflowed: command=({vx}, {vy})")
            return None
        return r

    def shape(self, p: ArrayLike, v: ArrayLike) -> FloatArray:
        """Shaped velocity.

        Args:
            p: Position of the reference point P, shape (2,), workspace units.
            v: Commanded velocity, shape (2,), workspace units per second.

        Returns:
            The admissible velocity, shape (2,), never non-finite.

        Raises:
            InvalidInput: wrong shape, or non-finite input with ``on_invalid="raise"``.
        """
        # Inlined fast path of as_pair(): the common case (two ndarrays of shape (2,)).
        try:
            if p.shape == (2,) and v.shape == (2,):  # type: ignore[union-attr]
                px, py = p.tolist()  # type: ignore[union-attr]
                vx, vy = v.tolist()  # type: ignore[union-attr]
            else:
                raise AttributeError
        except AttributeError:
            px, py = as_pair("position", p)
            vx, vy = as_pair("command", v)
        r = self._checked(float(px), float(py), float(vx), float(vy))
        if r is None:
            return np.zeros(2)
        return np.array((r[0], r[1]))

    def explain(self, p: ArrayLike, v: ArrayLike) -> ShapingResult:
        """Shaped velocity with the zone, edges, distances, spring and stages that produced it.

        Args:
            p: Position, shape (2,), workspace units.
            v: Command, shape (2,), workspace units per second.
        """
        px, py = as_pair("position", p)
        vx, vy = as_pair("command", v)
        pos = np.array((px, py))
        cmd = np.array((vx, vy))
        r = self._checked(px, py, vx, vy)
        if r is None:
            return ShapingResult(
                np.zeros(2), cmd, pos, "invalid", -1, -1, math.nan, math.nan, np.zeros(2),
                ("stop",), self.method,
            )  # fmt: skip
        stages = tuple(name for bit, name in enumerate(kern.STAGE_NAMES) if r[9] & (1 << bit))
        return ShapingResult(
            output=np.array((r[0], r[1])),
            command=cmd,
            position=pos,
            zone=kern.ZONE_NAMES[r[2]],
            primary=r[3],
            secondary=r[4],
            d1=r[5],
            d2=r[6],
            spring=np.array((r[7], r[8])),
            stages=stages,
            method=self.method,
        )

    # ------------------------------------------------------------------ batch
    def shape_batch(self, P: ArrayLike, V: ArrayLike) -> FloatArray:
        """Shaped velocities for N states at once; equal to looping :meth:`shape`.

        Args:
            P: Positions, shape (N, 2), workspace units.
            V: Commands, shape (N, 2), workspace units per second.

        Returns:
            Shape (N, 2).
        """
        return self.zones_batch(P, V)[0]

    def zones_batch(self, P: ArrayLike, V: ArrayLike) -> tuple[FloatArray, np.ndarray[Any, Any]]:
        """Like :meth:`shape_batch`, also returning the zone code of every row.

        Returns:
            ``(out, zones)``: shape (N, 2) and (N,) ints indexing
            ``velfence.shaping.ZONE_NAMES``.
        """
        Pa = as_rows("positions", P)
        Va = as_rows("commands", V)
        if Pa.shape != Va.shape:
            raise InvalidInput(
                f"positions and commands must have the same shape (N, 2), got {Pa.shape} and "
                f"{Va.shape}"
            )
        good: BoolArray | None = None
        if not (np.isfinite(Pa).all() and np.isfinite(Va).all()):
            ok = _finite_rows(Pa) & _finite_rows(Va)
            self._invalid(f"non-finite input in row(s) {np.flatnonzero(~ok)[:10].tolist()}")
            Pa = np.where(ok[:, None], Pa, 0.0)
            Va = np.where(ok[:, None], Va, 0.0)
            good = ok
        out = np.empty_like(Pa)
        zones = np.empty(Pa.shape[0], dtype=np.int64)
        fn = compiled_batch(self.method) if self.accelerate else None
        if fn is not None:
            fn(np.ascontiguousarray(Pa), np.ascontiguousarray(Va), out, zones, *self._batch_args)
        else:
            py_fn = kern.patent_batch if self.method == "patent" else kern.exact_batch
            res = np.zeros_like(Pa).tolist()
            zl = [0] * Pa.shape[0]
            py_fn(Pa.tolist(), Va.tolist(), res, zl, *self._fast)
            out[:] = res
            zones[:] = zl
        if not np.isfinite(out).all():
            finite = _finite_rows(out)
            self._invalid(
                f"input too large, the shaped velocity overflowed in row(s) "
                f"{np.flatnonzero(~finite)[:10].tolist()}"
            )
            good = finite if good is None else good & finite
        if good is not None:
            out[~good] = 0.0
            zones[~good] = kern.ZONE_INVALID
        return out, zones

    def __repr__(self) -> str:
        return (
            f"PolygonShaper({self.polygon.n}-gon, method={self.method!r}, buffer={self.buffer}, "
            f"spring_gain={self.spring_gain})"
        )


BoolArray = np.ndarray[Any, np.dtype[np.bool_]]


def _finite_rows(a: FloatArray) -> BoolArray:
    return np.asarray(np.isfinite(a).all(axis=1), dtype=np.bool_)


def _all_finite(*xs: float) -> bool:
    return all(math.isfinite(x) for x in xs)
