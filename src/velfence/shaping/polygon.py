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

from velfence._typing import FloatArray, IntArray
from velfence._validate import check_choice, check_flag, check_positive, real_array
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.shaping import _kernels as kern
from velfence.shaping._accel import compiled_batch
from velfence.shaping.base import ShaperBase
from velfence.shaping.profiles import ApproachProfile, min_change_under_caps

__all__ = ["PolygonShaper"]

_METHODS = ("patent", "exact")


class PolygonShaper(ShaperBase):
    r"""Shape commanded velocities so that a point stays inside a convex polygon.

    Every parameter is keyword-only and validated (real numbers only: ``"0.2"`` and ``True`` are
    refused with :class:`~velfence.errors.InvalidParameter`).

    Args:
        polygon: The permissible workspace.
        buffer: Width :math:`d_{max}` of the buffer band inside the boundary, in workspace units
            (e.g. [rad] for the wrist). Must be > 0 and at most :attr:`ConvexPolygon.inradius
            <velfence.geometry.polygon.ConvexPolygon.inradius>`: a wider band leaves no point of
            the polygon free (every speed is cut everywhere) and makes the recovery bounds
            incompatible with the buffer bounds, so it is refused, the message giving the
            largest admissible width.
        spring_gain: Virtual-spring gain :math:`k` pulling a point outside back, in [1/s]
            (velocity per unit of penetration), >= 0. Default 1.0 /s (0.0 with a ``profile``,
            which sets its own return): a point outside with a zero command returns with time
            constant 1 s, at most ``max_recovery_speed``; 0 only stops outward motion, it does
            not recover.
        method: ``"patent"`` (US 8,676,382, faithful) or ``"exact"`` (our improved law).
        corner_blend_angle: :math:`\theta_{max}` of the patent's spring blend near corners, in
            [rad], in (0, π). Only used by ``"patent"``.
        max_recovery_speed: Largest recovery speed the exact law demands outside, in workspace
            units per second; default ``spring_gain * buffer``. Only used by ``"exact"``.
        profile: An :class:`~velfence.shaping.profiles.ApproachProfile` (e.g.
            ``ThreeZoneBraking``) replacing the linear buffer of the exact law: every edge's
            approach speed is capped by ``profile.cap(d)`` (outside: a forced return). Only with
            ``method="exact"`` and no ``buffer``; runs in plain Python (no numba batch).
        dt: Control period [s] of the loop that integrates the output, > 0, or None (default).
            **None: continuous-time law** — the bounds hold for the velocity itself, and a
            discrete loop that holds the output for ``dt`` may overshoot the boundary by up to
            ``|v|·dt`` per step. With ``dt`` the law is discrete-time safe: the approach to every
            edge in one period is also capped by the remaining distance (exact:
            :math:`n_i\cdot v_o \ge -d_i/dt` added to every bound, recovery at most
            :math:`-d_i/dt`; patent: the output scaled down until no edge is reached), so one
            explicit-Euler step ``p + dt·v_o`` from inside never leaves (to round-off).
        on_invalid: ``"raise"`` (default): non-finite inputs raise
            :class:`~velfence.errors.InvalidInput`; ``"stop"``: return zero velocity, zone
            ``"invalid"``. Type errors (strings, complex, wrong shapes) always raise.
        accelerate: Use numba for :meth:`shape_batch` when it is installed (default True).

    Raises:
        InvalidParameter: for any parameter out of range, naming it and the value got.
    """

    __slots__ = (
        "_batch_args",
        "_fast",
        "_idt",
        "_ready",
        "accelerate",
        "buffer",
        "corner_blend_angle",
        "dt",
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
        spring_gain: float | None = None,
        method: str = "exact",
        corner_blend_angle: float = 0.3,
        max_recovery_speed: float | None = None,
        profile: ApproachProfile | None = None,
        dt: float | None = None,
        on_invalid: str = "raise",
        accelerate: bool = True,
    ) -> None:
        self.polygon = as_polygon(polygon)
        self.method = check_choice("method", method, _METHODS)
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
            if spring_gain is not None or max_recovery_speed is not None:
                raise InvalidParameter(
                    "with a profile the recovery outside is the profile's (its negative cap): "
                    f"drop spring_gain and max_recovery_speed, got spring_gain={spring_gain!r}, "
                    f"max_recovery_speed={max_recovery_speed!r}"
                )
            if dt is not None:
                raise InvalidParameter(
                    "dt is not supported with a profile: build the period into the profile "
                    f"(its cap), or use buffer=; got dt={dt!r}"
                )
            buffer = math.inf
            spring_gain = 0.0
        elif buffer is None:
            raise InvalidParameter(
                "buffer must be given (width of the buffer band, workspace units) unless a "
                "profile is, got None"
            )
        self.profile = profile
        if profile is None:
            self.buffer = check_positive("buffer", buffer, unit="workspace units")
            limit = self.polygon.inradius
            if self.buffer > limit * (1.0 + 1e-9):
                raise InvalidParameter(
                    f"buffer={self.buffer:g} is wider than the polygon admits: its inradius "
                    f"(largest inscribed circle) is {limit:.6g}, so no point would be clear of "
                    "every edge's buffer (every speed cut everywhere) and, outside, recovery "
                    f"could not be combined with the other edges' bounds; use buffer <= "
                    f"{limit:.6g}"
                )
        else:
            self.buffer = math.inf
        self.spring_gain = check_positive(
            "spring_gain", 1.0 if spring_gain is None else spring_gain, allow_zero=True, unit="1/s"
        )
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
        self.dt = None if dt is None else check_positive("dt", dt, unit="s")
        idt = 0.0 if self.dt is None else 1.0 / self.dt
        if not math.isfinite(idt):
            raise InvalidParameter(
                f"dt: expected a control period of at least 1e-300 s, got {dt!r}"
            )
        self._idt = idt
        super().__init__(on_invalid=on_invalid)
        self.accelerate = check_flag("accelerate", accelerate)
        nx, ny, off, cx, cy, a0, beta, n = self.polygon._fast
        if self.method == "patent":
            fast: tuple[Any, ...] = (
                nx, ny, off, cx, cy, a0, beta, n,
                self.buffer, self.spring_gain, self.corner_blend_angle, idt,
            )  # fmt: skip
        else:
            fast = (nx, ny, off, cx, cy, n, self.buffer, self.spring_gain, rmax, idt)
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

    def bounds(
        self, position: ArrayLike, command: ArrayLike
    ) -> tuple[FloatArray, FloatArray, IntArray]:
        r"""The half-plane bounds the exact law enforces at ``position`` for ``command``.

        For every edge with :math:`d_i <` ``buffer``: :math:`n_i \cdot v_o \ge L_i` with
        :math:`n_i` the inward normal, :math:`L_i = -(|v| + R)\,d_i/d_{max}` inside and
        :math:`L_i = \min(k(-d_i), r_{max})` for a violated edge, :math:`R` the largest recovery
        bound (derivations §3). The exact law's output is the velocity closest to ``command`` that
        meets them all (unless they are infeasible together: stage ``relaxed``). Other laws built on
        the same bounds (the passive :class:`~velfence.cobot.CasterWall`) read them here.

        Args:
            position: Position, shape (2,).
            command: Command, shape (2,).

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
        px, py = real_array("position", position, (2,), what="a 2-vector of real numbers").tolist()
        vx, vy = real_array("command", command, (2,), what="a 2-vector of real numbers").tolist()
        rows = self._bounds(px, py, vx, vy)[0]
        if not rows:
            return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
        a = np.array(rows)
        return np.ascontiguousarray(a[:, :2]), a[:, 2].copy(), a[:, 3].astype(np.int64)

    def _bounds(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[list[tuple[float, float, float, int]], list[float]]:
        """Float-only :meth:`bounds`: rows ``(nx, ny, L, edge)`` and every edge's distance.

        The same arithmetic as the exact kernel (same recovery caps, same discrete-time terms,
        same set of edges), in the caller's units.
        """
        nx, ny, off = self._fast[0], self._fast[1], self._fast[2]
        n = len(off)
        k, rmax, dmax, idt = self.spring_gain, self.max_recovery_speed, self.buffer, self._idt
        d = [nx[e] * px + ny[e] * py - off[e] for e in range(n)]

        def recovery(de: float) -> float:
            r = min(k * -de, rmax)
            return min(r, -de * idt) if idt > 0.0 else r

        rec = 0.0
        for e in range(n):
            if d[e] < 0.0:
                rec = max(rec, recovery(d[e]))
        speed = math.hypot(vx, vy) + rec
        reach = dmax if idt == 0.0 else max(dmax, speed / idt)

        def lower(de: float) -> float:
            if de < 0.0:
                return recovery(de)
            b = -speed * (de / dmax)
            return max(b, -de * idt) if idt > 0.0 else b

        rows = [(nx[e], ny[e], lower(d[e]), e) for e in range(n) if d[e] < reach]
        return rows, d

    def __repr__(self) -> str:
        return (
            f"PolygonShaper({self.polygon.n}-gon, method={self.method!r}, buffer={self.buffer}, "
            f"spring_gain={self.spring_gain}, dt={self.dt})"
        )
