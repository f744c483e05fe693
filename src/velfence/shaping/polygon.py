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

from velfence._validate import as_pair, check_choice, check_positive
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.shaping import _kernels as kern
from velfence.shaping._accel import compiled_batch
from velfence.shaping.base import FloatArray, IntArray, ShaperBase
from velfence.shaping.profiles import ApproachProfile, min_change_under_caps

__all__ = ["PolygonShaper"]

_METHODS = ("patent", "exact")


class PolygonShaper(ShaperBase):
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
        profile: An :class:`~velfence.shaping.profiles.ApproachProfile` (e.g.
            ``ThreeZoneBraking``) replacing the linear buffer of the exact law: every edge's
            approach speed is capped by ``profile.cap(d)`` (outside: a forced return). Only with
            ``method="exact"`` and no ``buffer``; runs in plain Python (no numba batch).
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
        "_ready",
        "accelerate",
        "buffer",
        "corner_blend_angle",
        "max_recovery_speed",
        "method",
        "polygon",
        "profile",
        "spring_gain",
    )

    def __init__(
        self,
        polygon: ConvexPolygon,
        *,
        buffer: float | None = None,
        spring_gain: float = 0.0,
        method: str = "exact",
        corner_blend_angle: float = 0.3,
        max_recovery_speed: float | None = None,
        profile: ApproachProfile | None = None,
        on_invalid: str = "raise",
        accelerate: bool = True,
    ) -> None:
        self.polygon = as_polygon(polygon)
        if profile is not None:
            if not isinstance(profile, ApproachProfile):
                raise InvalidParameter(
                    f"profile must be an ApproachProfile (cap, zone), got {type(profile).__name__}"
                )
            if method != "exact" or buffer is not None:
                raise InvalidParameter(
                    "profile replaces the linear buffer of the exact law: pass profile with "
                    f"method='exact' and no buffer, got method={method!r}, buffer={buffer!r}"
                )
            if spring_gain != 0.0 or max_recovery_speed is not None:
                raise InvalidParameter(
                    "with a profile the recovery outside is the profile's (its negative cap): "
                    f"drop spring_gain and max_recovery_speed, got spring_gain={spring_gain!r}, "
                    f"max_recovery_speed={max_recovery_speed!r}"
                )
            buffer = math.inf
        elif buffer is None:
            raise InvalidParameter(
                "buffer must be given (width of the buffer band, workspace units) unless a "
                "profile is, got None"
            )
        self.profile = profile
        self.buffer = (
            buffer
            if profile is not None
            else check_positive("buffer", buffer, unit="workspace units")
        )
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
            rmax = self.spring_gain * self.buffer if profile is None else 0.0
        else:
            rmax = check_positive(
                "max_recovery_speed", max_recovery_speed, unit="workspace units per second"
            )
        self.max_recovery_speed = rmax
        super().__init__(on_invalid=on_invalid)
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
        self._ready = True

    def __setattr__(self, name: str, value: Any) -> None:
        # The kernels' arguments are precomputed from the parameters: a later change would be
        # silently ignored, so parameters are frozen once built.
        if getattr(self, "_ready", False):
            raise AttributeError(
                f"PolygonShaper is immutable (its law is precomputed): build a new one instead "
                f"of setting {name!r}"
            )
        object.__setattr__(self, name, value)

    # ------------------------------------------------------------------ the law
    def _law(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[float, float, int, int, int, float, float, float, float, int]:
        if self.method == "patent":
            return kern.patent_kernel(px, py, vx, vy, *self._fast)
        if self.profile is not None:
            return self._law_profile(px, py, vx, vy, self.profile)
        n = self.polygon.n
        args = (*self._fast, [0.0] * n, [0.0] * n, [0] * n)  # kernel scratch: dist, bnd, work
        return kern.exact_kernel(px, py, vx, vy, *args)

    def _law_profile(
        self, px: float, py: float, vx: float, vy: float, profile: ApproachProfile
    ) -> tuple[float, float, int, int, int, float, float, float, float, int]:
        """The exact law with a general approach profile (plain Python; no numba twin)."""
        nx, ny, off = self._fast[0], self._fast[1], self._fast[2]
        deltas = [nx[e] * px + ny[e] * py - off[e] for e in range(len(off))]
        ox, oy, relaxed = min_change_under_caps(vx, vy, deltas, nx, ny, profile)
        order = sorted(range(len(deltas)), key=deltas.__getitem__)
        p1, p2 = order[0], order[1]
        speed = math.hypot(vx, vy)
        near = sum(1 for d in deltas if profile.cap(d, speed) < speed)
        if deltas[p1] < 0.0:
            zone = kern.ZONE_OUTSIDE if near <= 1 else kern.ZONE_OUTSIDE_CORNER
        else:
            zone = (kern.ZONE_FREE, kern.ZONE_BUFFER)[near] if near < 2 else kern.ZONE_CORNER
        stages = (kern.STAGE_PROJECT if near else 0) | (kern.STAGE_RELAXED if relaxed else 0)
        return ox, oy, zone, p1, p2, deltas[p1], deltas[p2], 0.0, 0.0, stages

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        if self.profile is not None:
            rows = [self._law(*p, *v) for p, v in zip(P.tolist(), V.tolist(), strict=True)]
            out_p = np.array([r[:2] for r in rows], dtype=float).reshape(P.shape)
            return out_p, np.array([r[2] for r in rows], dtype=np.int64)
        out = np.empty_like(P)
        zones = np.empty(P.shape[0], dtype=np.int64)
        fn = compiled_batch(self.method) if self.accelerate else None
        if fn is not None:
            fn(P, V, out, zones, *self._batch_args)
        else:
            py_fn = kern.patent_batch if self.method == "patent" else kern.exact_batch
            res = np.zeros_like(P).tolist()
            zl = [0] * P.shape[0]
            py_fn(P.tolist(), V.tolist(), res, zl, *self._fast)
            out[:] = res
            zones[:] = zl
        return out, zones

    def bounds(self, p: ArrayLike, v: ArrayLike) -> tuple[FloatArray, FloatArray, IntArray]:
        r"""The half-plane bounds the exact law enforces at ``p`` for command ``v``.

        For every edge with :math:`d_i <` ``buffer``: :math:`n_i \cdot v_o \ge L_i` with
        :math:`n_i` the inward normal, :math:`L_i = -(|v| + R)\,d_i/d_{max}` inside and
        :math:`L_i = \min(k(-d_i), r_{max})` for a violated edge, :math:`R` the largest recovery
        bound (derivations §3). The exact law's output is the velocity closest to ``v`` that meets
        them all (unless they are infeasible together: stage ``relaxed``). Other laws built on
        the same bounds (the passive :class:`~velfence.cobot.CasterWall`) read them here.

        Args:
            p: Position, shape (2,).
            v: Command, shape (2,).

        Returns:
            ``(normals, lower, edges)``: inward unit normals, shape (m, 2); lower bounds on
            :math:`n_i \cdot v_o`, shape (m,), velocity units; edge indices, shape (m,).

        Raises:
            InvalidParameter: For ``method="patent"`` or a ``profile`` (other bound forms).
            InvalidInput: Bad or non-finite input.
        """
        if self.method != "exact" or self.profile is not None:
            raise InvalidParameter(
                "bounds() describes the exact law with a linear buffer; this shaper has "
                f"method={self.method!r}, profile={self.profile!r}"
            )
        px, py = as_pair("position", p)
        vx, vy = as_pair("command", v)
        if not all(math.isfinite(x) for x in (px, py, vx, vy)):
            raise InvalidInput(
                f"bounds: expected finite values, got position=({px}, {py}), command=({vx}, {vy})"
            )
        rows = self._bounds(px, py, vx, vy)[0]
        if not rows:
            return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
        a = np.array(rows)
        return np.ascontiguousarray(a[:, :2]), a[:, 2].copy(), a[:, 3].astype(np.int64)

    def _bounds(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[list[tuple[float, float, float, int]], list[float]]:
        """Float-only :meth:`bounds`: rows ``(nx, ny, L, edge)`` and every edge's distance."""
        nx, ny, off = self._fast[0], self._fast[1], self._fast[2]
        n = len(off)
        d = [nx[e] * px + ny[e] * py - off[e] for e in range(n)]
        rec = 0.0
        for e in range(n):
            if d[e] < 0.0:
                rec = max(rec, min(self.spring_gain * -d[e], self.max_recovery_speed))
        scale = (math.hypot(vx, vy) + rec) / self.buffer
        rows = [
            (nx[e], ny[e], min(self.spring_gain * -d[e], self.max_recovery_speed)
             if d[e] < 0.0 else -scale * d[e], e)
            for e in range(n)
            if d[e] < self.buffer
        ]  # fmt: skip
        return rows, d

    def __repr__(self) -> str:
        return (
            f"PolygonShaper({self.polygon.n}-gon, method={self.method!r}, buffer={self.buffer}, "
            f"spring_gain={self.spring_gain})"
        )
