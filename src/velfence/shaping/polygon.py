r"""Velocity shaping inside a convex polygon: US 8,676,382's edge scaling and our exact law.

``method="edge-scaling"`` (alias ``"patent"``, accepted forever) is algorithm 100 of the patent
(steps 102-115) as reconstructed in ``docs/derivations.md`` §2: arc-segment selection of a
primary and a secondary edge, pass-through outside the buffer, the outward normal component
scaled by :math:`\hat d = 1 - d/d_{max}` inside the buffer, the two-stage corner projection, and
outside: outward normal zeroed, tangent kept, virtual spring :math:`k d n` blended between the
two normals near a corner.

``method="exact"`` (derivations §3) is the minimum-change velocity subject to one half-plane bound
per nearby edge, solved in closed form:

.. math::
    v_o = \arg\min_x \|x - v\|^2 \;\text{s.t.}\;
    n_i\cdot x \ge \begin{cases} -(\|v\| + R)\, d_i/d_{max} & 0 \le d_i < d_{max}\\
    \min(k\,(-d_i),\ r_{max}) & d_i < 0 \end{cases}

with :math:`R` the largest recovery bound (0 inside). The bounds have one definition
(``_kernels.exact_bounds``, also behind :meth:`PolygonShaper.bounds`); a ``profile``
(:class:`~velfence.shaping.profiles.LinearBuffer`,
:class:`~velfence.shaping.profiles.ThreeZoneBraking`) replaces the linear buffer by
:math:`n_i\cdot x \ge -\mathrm{cap}(d_i, \|v\|)` in the same formulation (same solve, same zone
rule). It keeps every edge's bound at once (no sequential-projection error at corners), is
continuous in position and command, never speeds up a command inside, and outside always reduces
every violation at a bounded recovery speed.
"""

from __future__ import annotations

import math
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import (
    as_pair,
    as_rows,
    check_choice,
    check_flag,
    check_positive,
    real_array,
    show,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polygon import ConvexPolygon, as_polygon
from velfence.shaping import _kernels as kern
from velfence.shaping._accel import compiled_batch
from velfence.shaping.backend import BACKENDS, Backend, compiled_core, pick_backend
from velfence.shaping.base import KernelOut, OnInvalid, ShaperBase
from velfence.shaping.profiles import (
    ApproachProfile,
    LinearBuffer,
    ThreeZoneBraking,
    min_change_under_caps,
)

__all__ = ["BoundRows", "PolygonBackend", "PolygonMethod", "PolygonShaper"]

#: The laws of :class:`PolygonShaper`. ``"edge-scaling"`` is US 8,676,382's law (the normal
#: component scaled by d/d_max, two-stage projection at corners); ``"patent"`` is its alias
#: (accepted forever; ``.method`` reports ``"edge-scaling"``).
PolygonMethod = Literal["edge-scaling", "patent", "exact"]

_METHODS = ("edge-scaling", "patent", "exact")

#: Which implementation of the law :class:`PolygonShaper` runs: ``"auto"`` (the compiled core,
#: ``velfence_core``, when it is importable, else Python), ``"python"`` (the reference kernels of
#: ``velfence.shaping._kernels``; numba for batches when ``accelerate``) or ``"c"`` (the compiled
#: core, required).
PolygonBackend = Backend

_ALIASES = {"patent": "edge-scaling"}


class BoundRows(NamedTuple):
    """The exact law's bounds at one state, as plain floats (:meth:`PolygonShaper.bound_rows`).

    Attributes:
        rows: One ``(nx, ny, lower, edge)`` per bounded edge, in edge order: inward unit normal,
            lower bound on the normal component of the output [velocity units], edge index.
        primary: The nearest edge (smallest signed distance; first on ties).
        secondary: The second-nearest edge.
        d1: Signed distance to ``primary`` [workspace units], positive inside.
        d2: Signed distance to ``secondary``.
        n_out: Number of violated edges (signed distance < 0).
    """

    rows: tuple[tuple[float, float, float, int], ...]
    primary: int
    secondary: int
    d1: float
    d2: float
    n_out: int


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
        method: ``"edge-scaling"`` (US 8,676,382's law, faithful; ``"patent"`` is an alias and
            :attr:`method` then reads ``"edge-scaling"``) or ``"exact"`` (our improved law).
        corner_blend_angle: :math:`\theta_{max}` of the patent's spring blend near corners, in
            [rad], in (0, π). Only used by ``"edge-scaling"``.
        max_recovery_speed: Largest recovery speed the exact law demands outside, in workspace
            units per second; default ``spring_gain * buffer``. Only used by ``"exact"``.
        profile: An :class:`~velfence.shaping.profiles.ApproachProfile` (e.g.
            ``ThreeZoneBraking``) replacing the linear buffer of the exact law: every edge's
            approach speed is capped by ``profile.cap(d)`` (outside: a forced return). Only with
            ``method="exact"`` and no ``buffer``. ``LinearBuffer`` and ``ThreeZoneBraking`` run
            in the compiled kernels (their ``kernel_profile``); any other profile object runs
            in plain Python with the same solve and zone rule.
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
        accelerate: Use numba for :meth:`shape_batch` when it is installed (default True) and
            the Python backend runs.
        backend: Implementation of the law (:data:`PolygonBackend`): ``"auto"`` (default) runs
            the compiled C core (the separate ``velfence_core`` distribution, ``pip install
            ./core``) for :meth:`shape`, :meth:`explain` and the batches when it is importable,
            and the Python reference kernels otherwise; ``"python"`` always runs the reference
            (numba for batches with ``accelerate``); ``"c"`` requires the core. Both give
            bit-identical results (tests/core). A profile other than ``LinearBuffer`` /
            ``ThreeZoneBraking`` always runs in Python. :attr:`backend` reports the one in use.

    Raises:
        InvalidParameter: for any parameter out of range, naming it and the value got.
    """

    # __dict__: room for the instance attribute ``shape`` (the frameless C call, see __init__)
    __slots__ = (
        "__dict__",
        "_batch_args",
        "_core",
        "_core_shape",
        "_fast",
        "_generic",
        "_idt",
        "_ready",
        "accelerate",
        "backend",
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
        method: PolygonMethod = "exact",
        corner_blend_angle: float = 0.3,
        max_recovery_speed: float | None = None,
        profile: ApproachProfile | None = None,
        dt: float | None = None,
        on_invalid: OnInvalid = "raise",
        accelerate: bool = True,
        backend: PolygonBackend = "auto",
    ) -> None:
        self.polygon = as_polygon(polygon)
        chosen = check_choice("method", method, _METHODS)
        self.method: PolygonMethod = _ALIASES.get(chosen, chosen)  # type: ignore[assignment]
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
                    "drop spring_gain and max_recovery_speed, got "
                    f"spring_gain={show(spring_gain)}, "
                    f"max_recovery_speed={show(max_recovery_speed)}"
                )
            if dt is not None:
                raise InvalidParameter(
                    "dt is not supported with a profile: build the period into the profile "
                    f"(its cap), or use buffer=; got dt={show(dt)}"
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
            # a buffer within the polygon's cheap bound fits: the inradius search (about 5 ms)
            # runs only for a wider one
            if self.buffer > self.polygon.inradius_bound:
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
                f"corner_blend_angle must be in (0, π) rad, got {show(corner_blend_angle)}"
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
                f"dt: expected a control period of at least 1e-300 s, got {show(dt)}"
            )
        self._idt = idt
        super().__init__(on_invalid=on_invalid)
        self.accelerate = check_flag("accelerate", accelerate)
        nx, ny, off, cx, cy, a0, beta, n = self.polygon.kernel_data
        # A profile the kernels do not know: the plain-Python law calls its own cap.
        self._generic: ApproachProfile | None = None
        if self.method == "edge-scaling":
            fast: tuple[Any, ...] = (
                nx, ny, off, cx, cy, a0, beta, n,
                self.buffer, self.spring_gain, self.corner_blend_angle, idt,
            )  # fmt: skip
        else:
            # One formulation: a profile kind + its float parameters + whether the built-in
            # relaxation by the recovery speed R applies (kernels.exact_bounds).
            prm: tuple[float, ...]
            if profile is None:
                # LinearBuffer(buffer=buffer, spring_gain, max_recovery_speed)'s parameters.
                kind, prm = (
                    kern.PROFILE_LINEAR,
                    (self.buffer, self.spring_gain, rmax, 0.0, 0.0, 0.0),
                )
                relax = True
            elif isinstance(profile, (LinearBuffer, ThreeZoneBraking)):
                kind, prm = profile.kernel_profile
                relax = False
            else:
                # Not a kernel kind: _law_profile calls the profile's own cap.
                kind, prm, relax = kern.PROFILE_LINEAR, (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0), False
                self._generic = profile
            fast = (nx, ny, off, cx, cy, n, kind, prm, relax, idt)
        self._fast = fast
        # Arrays for the compiled loops: the per-edge tuples become float arrays; the profile's
        # parameters stay a tuple of floats (numba keeps them in registers, as it would separate
        # scalar arguments).
        per_edge = (nx, ny, off, beta)
        self._batch_args = tuple(
            np.asarray(a, dtype=float) if any(a is x for x in per_edge) else a for a in fast
        )
        self._core, self.backend = self._pick_backend(check_choice("backend", backend, BACKENDS))
        self._core_shape = None if self._core is None else self._core.__self__.shape_array
        if self._core_shape is not None and type(self).shape is PolygonShaper.shape:
            # No Python frame on the common path: ``self.shape`` becomes a C callable that runs
            # the core's fast path (two finite float64 (2,) arrays) and hands every other call
            # to the Python route (ShaperBase.shape: validation, on_invalid, refusals), which
            # gives the same answer bit for bit. A subclass overriding ``shape`` keeps its own.
            call = getattr(compiled_core(), "ShapeCall", None)
            if call is not None:
                object.__setattr__(self, "shape", call(self._core_shape, super().shape))
        self._ready = True

    def _pick_backend(self, backend: str) -> tuple[Any, Literal["python", "c"]]:
        """The compiled law object (or None) and the name of the backend in use."""
        core, name = pick_backend(
            backend,
            usable=self._generic is None,
            refusal="runs the kernels' own profiles (LinearBuffer, ThreeZoneBraking), got "
            f"profile={self._generic!r}",
            binding="core",
        )
        if core is None:
            return None, name
        law = core.ExactLaw if self.method == "exact" else core.PatentLaw
        return law(*self._fast).law, "c"

    def __setattr__(self, name: str, value: Any) -> None:
        # The kernels' arguments are precomputed from the parameters: a later change would be
        # silently ignored, so parameters are frozen once built.
        if getattr(self, "_ready", False):
            raise AttributeError(
                f"PolygonShaper is immutable (its law is precomputed): build a new one instead "
                f"of setting {name!r}"
            )
        object.__setattr__(self, name, value)

    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Shaped velocity.

        With the compiled core, two float64 arrays of shape (2,) with finite entries go straight
        to it (one call, no intermediate objects); anything else takes the generic path of
        :meth:`ShaperBase.shape <velfence.shaping.base.ShaperBase.shape>` (validation and the
        ``on_invalid`` policy), with the same result. With the C backend an instance's
        ``shape`` is a C callable (``velfence_core._core.ShapeCall``) doing exactly this with
        no Python frame on the common path: a call costs the core's own call from Python plus
        an attribute lookup.

        Args:
            position: Position of the reference point, shape (2,), workspace units.
            command: Commanded velocity, shape (2,), workspace units per second.

        Returns:
            The admissible velocity, shape (2,), never non-finite.

        Raises:
            InvalidInput: wrong shape, or non-finite input with ``on_invalid="raise"``.
        """
        fast = self._core_shape
        if fast is not None:
            out: FloatArray | None = fast(position, command)
            if out is not None:
                return out
        return super().shape(position, command)

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Shaped velocities for N states at once; equal to looping :meth:`shape`.

        With the compiled core and finite input, the rows go straight to its loop, writing
        only the output array (no zone array allocated and thrown away); anything else (a
        profile the core does not know, non-finite rows, an overflowed answer) takes the
        generic path of :meth:`zones_batch`, which owns the ``on_invalid`` policy.

        Args:
            positions: Positions, shape (N, 2), workspace units.
            commands: Commands, shape (N, 2), workspace units per second.

        Returns:
            Shape (N, 2), never non-finite.
        """
        core = self._core
        if core is None:
            return super().shape_batch(positions, commands)
        # (read only: the caller's arrays are not copied unless they are not C-contiguous)
        P = np.ascontiguousarray(as_rows("positions", positions, copy=False))
        V = np.ascontiguousarray(as_rows("commands", commands, copy=False))
        if P.shape != V.shape:
            return super().shape_batch(positions, commands)
        out = np.empty_like(P)
        if core.__self__.batch(P, V, out, None):  # rows not finite in or out: counted in C
            return super().shape_batch(positions, commands)
        return out

    # ------------------------------------------------------------------ the law
    def _checked(self, px: float, py: float, vx: float, vy: float) -> KernelOut | None:
        """The base class's check, also refusing overflowed distances.

        A position beyond ~1e300 makes ``d1``/``d2`` infinite while the recovery velocity stays
        finite; refused as the C core's checked entry refuses it (``VF_ERR_OVERFLOW``).
        """
        r = super()._checked(px, py, vx, vy)
        if r is not None and (r[5] - r[5] != 0.0 or r[6] - r[6] != 0.0):
            self._invalid(
                f"position too large, the distances to the edges overflowed: position=({px}, "
                f"{py}), command=({vx}, {vy})"
            )
            return None
        return r

    def _law(
        self, px: float, py: float, vx: float, vy: float
    ) -> tuple[float, float, int, int, int, float, float, float, float, int]:
        if self._core is not None:
            out: tuple[float, float, int, int, int, float, float, float, float, int]
            out = self._core(px, py, vx, vy)
            return out
        if self.method == "edge-scaling":
            return kern.patent_kernel(px, py, vx, vy, *self._fast)
        if self._generic is not None:
            return self._law_profile(px, py, vx, vy, self._generic)
        n = self._fast[5]
        args = (*self._fast, [0.0] * n, [0.0] * n, [0] * n)  # kernel scratch: dist, bnd, work
        return kern.exact_kernel(px, py, vx, vy, *args)

    def _law_profile(
        self, px: float, py: float, vx: float, vy: float, profile: ApproachProfile
    ) -> tuple[float, float, int, int, int, float, float, float, float, int]:
        """The exact law with a profile the kernels do not know (plain Python, calls its cap).

        The same formulation as the kernel path without the built-in relaxation: the same
        solve (``min_change_under_caps``), the same zone rule (``zone_code``) and stages.
        """
        nx, ny, off = self._fast[0], self._fast[1], self._fast[2]
        deltas = [nx[e] * px + ny[e] * py - off[e] for e in range(len(off))]
        ox, oy, relaxed = min_change_under_caps(vx, vy, deltas, nx, ny, profile)
        order = sorted(range(len(deltas)), key=deltas.__getitem__)
        p1, p2 = order[0], order[1]
        speed = math.hypot(vx, vy)
        near = sum(1 for d in deltas if profile.cap(d, speed) < speed)
        n_out = sum(1 for d in deltas if d < 0.0)
        zone = kern.zone_code(n_out, near)
        stages = (kern.STAGE_PROJECT if near else 0) | (kern.STAGE_SPRING if n_out else 0)
        if relaxed:
            stages |= kern.STAGE_RELAXED
        return ox, oy, zone, p1, p2, deltas[p1], deltas[p2], 0.0, 0.0, stages

    def _law_batch(self, P: FloatArray, V: FloatArray) -> tuple[FloatArray, IntArray]:
        if self._generic is not None:
            rows = [self._law(*p, *v) for p, v in zip(P.tolist(), V.tolist(), strict=True)]
            out_p = np.array([r[:2] for r in rows], dtype=float).reshape(P.shape)
            return out_p, np.array([r[2] for r in rows], dtype=np.int64)
        out = np.empty_like(P)
        zones = np.empty(P.shape[0], dtype=np.int64)
        if P.shape[0] == 0:  # nothing to shape (a (0,) list would not broadcast into (0, 2))
            return out, zones
        if self._core is not None:
            self._core.__self__.batch(P, V, out, zones)
            return out, zones
        exact = self.method == "exact"
        fn = compiled_batch("exact" if exact else "patent") if self.accelerate else None
        if fn is not None:
            fn(P, V, out, zones, *self._batch_args)
        else:
            py_fn = kern.exact_batch if exact else kern.patent_batch
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
        meets them all (unless they are infeasible together: stage ``relaxed``). These are the
        kernel's own bounds (one definition), in the caller's units. Other laws built on the same
        bounds (the passive :class:`~velfence.cobot.CasterWall`) read them here or, as plain
        floats, from :meth:`bound_rows`.

        Args:
            position: Position, shape (2,).
            command: Command, shape (2,).

        Returns:
            ``(normals, lower, edges)``: inward unit normals, shape (m, 2); lower bounds on
            :math:`n_i \cdot v_o`, shape (m,), velocity units; edge indices, shape (m,).

        Raises:
            InvalidParameter: For ``method="edge-scaling"`` or a ``profile`` (other bound forms).
            InvalidInput: Bad or non-finite input.
        """
        self._check_bounds_law()
        px, py = real_array("position", position, (2,), what="a 2-vector of real numbers").tolist()
        vx, vy = real_array("command", command, (2,), what="a 2-vector of real numbers").tolist()
        rows = self._bound_rows(px, py, vx, vy).rows
        if not rows:
            return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
        a = np.array(rows)
        return np.ascontiguousarray(a[:, :2]), a[:, 2].copy(), a[:, 3].astype(np.int64)

    def bound_rows(self, position: ArrayLike, command: ArrayLike) -> BoundRows:
        """:meth:`bounds` as plain floats, with the nearest edges (for laws built on them).

        Cheaper than :meth:`bounds` (no arrays are built); any finite magnitude is accepted,
        as by :meth:`shape`.

        Args:
            position: Position, shape (2,) [workspace units] (a tuple of two floats is fastest).
            command: Command, shape (2,) [workspace units/s].

        Returns:
            The :class:`BoundRows` (rows in edge order, caller's units).

        Raises:
            InvalidParameter: For ``method="edge-scaling"`` or a ``profile``.
            InvalidInput: Not two 2-vectors of finite real numbers.
        """
        self._check_bounds_law()
        px, py = as_pair("position", position)
        vx, vy = as_pair("command", command)
        s = px + py + vx + vy
        if s - s != 0.0 and not all(math.isfinite(x) for x in (px, py, vx, vy)):
            raise InvalidInput(
                f"bound_rows: expected finite values, got position=({px}, {py}), "
                f"command=({vx}, {vy})"
            )
        return self._bound_rows(px, py, vx, vy)

    def _check_bounds_law(self) -> None:
        if self.method != "exact" or self.profile is not None:
            raise InvalidParameter(
                "bounds() describes the exact law with a linear buffer; this shaper has "
                f"method={self.method!r}, profile={self.profile!r}"
            )

    def _bound_rows(self, px: float, py: float, vx: float, vy: float) -> BoundRows:
        """The kernel's bound definition (``exact_bounds``) in the caller's units."""
        nx, ny, off, _, _, n, kind, prm, relax, idt = self._fast
        dist = [0.0] * n
        bnd = [0.0] * n
        work = [0] * n
        m, n_out, _, _, _, _, p1, p2, d1, d2 = kern.exact_bounds(
            px, py, vx, vy, nx, ny, off, n, kind, prm, relax, idt, False, dist, bnd, work
        )
        rows = tuple((nx[e], ny[e], bnd[e], e) for e in work[:m])
        return BoundRows(rows, p1, p2, d1, d2, n_out)

    def __repr__(self) -> str:
        return (
            f"PolygonShaper({self.polygon.n}-gon, method={self.method!r}, buffer={self.buffer}, "
            f"spring_gain={self.spring_gain}, dt={self.dt})"
        )


document_inits(globals())
