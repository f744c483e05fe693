r"""Velocity shaping inside a convex polytope of any dimension: the exact law in n-D.

The 2-D exact law of :class:`~velfence.shaping.polygon.PolygonShaper` (derivations §3) carried to
``n`` coordinates (derivations §7): one half-space bound per nearby facet,

.. math::
    v_o = \arg\min_x \|x - v\|^2 \;\text{s.t.}\;
    n_i\cdot x \ge \begin{cases} -(\|v\| + R)\, d_i/d_{max} & 0 \le d_i < d_{max}\\
    \min(k\,(-d_i),\ r_{max}) & d_i < 0 \end{cases}

(or :math:`n_i\cdot x \ge -\mathrm{cap}(d_i, \|v\|)` for a ``profile``), all held at once. The
bounds are the one definition of the exact law (``_kernels.bounds_from_distances``, which the 2-D
kernel calls too), and the minimum-change velocity is the exact projection onto them
(:func:`velfence.geometry.projection.project`, a finite dual active-set method). For ``n = 2`` the
result equals ``PolygonShaper(method="exact")`` to round-off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import BoolArray, FloatArray, IntArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive,
    real_array,
    show,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.projection import PROJECT_OPTIMAL, project_kernel, scratch_length
from velfence.shaping import _kernels as kern
from velfence.shaping import _nd_kernels as nd
from velfence.shaping._accel import compiled_polytope
from velfence.shaping.backend import Backend, compiled_core, pick_backend
from velfence.shaping.backend import compiled_nd as compiled_nd  # its old home: still importable
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.profiles import ApproachProfile, LinearBuffer, ThreeZoneBraking

__all__ = ["PolytopeBackend", "PolytopeResult", "PolytopeShaper"]

#: Implementations of the n-D law (and of the safety filter's solve): ``"auto"`` (the compiled
#: core when importable, else Python), ``"python"`` (the reference kernels, numba with
#: ``accelerate``) or ``"c"`` (the core, required).
PolytopeBackend = Backend


@dataclass(frozen=True, kw_only=True)
class PolytopeResult:
    r"""What :class:`PolytopeShaper` did to one command.

    Attributes:
        output: Shaped velocity, shape (n,), the command's units.
        command: The command as given, shape (n,).
        position: The position as given, shape (n,).
        zone: A :data:`~velfence.shaping.base.Zone` name: ``"free"``, ``"buffer"`` (one facet
            bounds the command), ``"corner"`` (several), ``"outside"`` / ``"outside-corner"``
            (some facet violated; at most one / several bound), ``"invalid"``.
        active: The facets the zone refers to: every facet with a bound at this state (violated,
            or near enough that its cap is below the command's speed), ascending.
        active_names: Their names (``ConvexPolytope.facet_names``).
        lower: Their lower bounds on :math:`n_i\cdot v_o` [velocity units], shape (len(active),).
        binding: The facets whose bound holds with equality at the output (the projection's
            active set), in the order the solver took them.
        binding_names: Their names.
        slack: :math:`n_i\cdot v_o - L_i` for every facet in ``active``, shape
            (len(active),): 0 on a binding bound.
        distances: Signed distance to every facet, shape (m,), positive inside.
        stages: Names of the stages applied (``"exact-projection"``, ``"spring"``,
            ``"relaxed"``, ``"stop"``).
        method: ``"exact"``.
        relaxed: True when the bounds were infeasible together and only the recovery bounds were
            kept (a polytope thinner than the profile's reach).
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    active: tuple[int, ...]
    active_names: tuple[str, ...]
    lower: FloatArray
    binding: tuple[int, ...]
    binding_names: tuple[str, ...]
    slack: FloatArray
    distances: FloatArray
    stages: tuple[str, ...]
    method: str = "exact"
    relaxed: bool = False


class PolytopeShaper(InvalidPolicy):
    r"""Shape commanded velocities so that a point stays inside a convex polytope (any dimension).

    The exact law of :class:`~velfence.shaping.polygon.PolygonShaper` in ``n`` coordinates
    (module docstring): a Cartesian workspace box for a tool point, a joint-space box, a few
    safety planes (an unbounded polytope), a 2-D fence. Every parameter is keyword-only and
    validated.

    Args:
        polytope: The permissible set (:class:`~velfence.geometry.polytope.ConvexPolytope`).
        buffer: Width :math:`d_{max}` of the approach band inside every facet [workspace units],
            > 0 and at most the polytope's Chebyshev radius (a wider band leaves no point clear
            of every facet's band and makes recovery incompatible with the other bounds).
        spring_gain: Recovery gain :math:`k` outside [1/s], >= 0; default 1.0 (0 with a
            ``profile``, which sets its own return).
        max_recovery_speed: Largest recovery speed [workspace units/s]; default
            ``spring_gain * buffer``.
        profile: An :class:`~velfence.shaping.profiles.ApproachProfile` replacing the linear
            buffer (no ``buffer``, ``spring_gain`` or ``dt`` then): every facet's approach speed
            is capped by ``profile.cap(d, |v|)``, outside a forced return. ``LinearBuffer`` and
            ``ThreeZoneBraking`` run in the kernels; other profiles in plain Python with the
            same formulation.
        dt: Control period [s] of the loop that integrates the output, or None (continuous
            time). With ``dt`` every facet's approach in one period is also capped by its
            distance (:math:`n_i\cdot v_o \ge -d_i/dt`) and recovery by the penetration, so one
            explicit-Euler step from inside never leaves (to round-off).
        on_invalid: ``"raise"`` (default) or ``"stop"`` (zero velocity, zone ``"invalid"``)
            for non-finite inputs.
        accelerate: Run the compiled (numba) kernels when numba is installed and the Python
            backend runs (default True); results are identical to the plain-Python kernels
            (tested).
        backend: Implementation of the law (:data:`PolytopeBackend`): ``"auto"`` (default) runs
            the compiled C core (the separate ``velfence_core`` distribution, ``pip install
            ./core``) for :meth:`shape`, :meth:`explain` and the batches when it is importable,
            the Python reference kernels otherwise; ``"python"`` always runs the reference
            (numba with ``accelerate``); ``"c"`` requires the core. Both give bit-identical
            results (tests/core). A profile other than ``LinearBuffer`` / ``ThreeZoneBraking``
            always runs in Python. :attr:`backend` reports the one in use.

    Raises:
        InvalidParameter: for any parameter out of range, naming it and the value got.
    """

    # __dict__: room for the instance attribute ``shape`` (the frameless C call, see __init__)
    __slots__ = (
        "__dict__",
        "_args",
        "_core",
        "_core_shape",
        "_generic",
        "_lists",
        "_ready",
        "accelerate",
        "backend",
        "buffer",
        "dt",
        "max_recovery_speed",
        "polytope",
        "profile",
        "spring_gain",
    )

    method = "exact"

    def __init__(
        self,
        polytope: ConvexPolytope,
        *,
        buffer: float | None = None,
        spring_gain: float | None = None,
        max_recovery_speed: float | None = None,
        profile: ApproachProfile | None = None,
        dt: float | None = None,
        on_invalid: OnInvalid = "raise",
        accelerate: bool = True,
        backend: PolytopeBackend = "auto",
    ) -> None:
        if not isinstance(polytope, ConvexPolytope):
            raise InvalidParameter(
                f"polytope must be a ConvexPolytope, got {type(polytope).__name__}; build one "
                "with ConvexPolytope(normals, offsets), .box(lower, upper) or .from_vertices()"
            )
        self.polytope = polytope
        if profile is not None:
            if not isinstance(profile, ApproachProfile):
                raise InvalidParameter(
                    f"profile must be an ApproachProfile (cap, zone), got {type(profile).__name__}"
                )
            if buffer is not None or spring_gain is not None or max_recovery_speed is not None:
                raise InvalidParameter(
                    "profile replaces the linear buffer and its recovery: drop buffer, "
                    f"spring_gain and max_recovery_speed, got buffer={show(buffer)}, "
                    f"spring_gain={show(spring_gain)}, "
                    f"max_recovery_speed={show(max_recovery_speed)}"
                )
            if dt is not None:
                raise InvalidParameter(
                    "dt is not supported with a profile: build the period into the profile "
                    f"(its cap), or use buffer=; got dt={show(dt)}"
                )
            self.buffer = math.inf
            self.spring_gain = 0.0
            self.max_recovery_speed = 0.0
        else:
            if buffer is None:
                raise InvalidParameter(
                    "buffer must be given (width of the approach band, workspace units) unless "
                    "a profile is, got None"
                )
            self.buffer = check_positive("buffer", buffer, unit="workspace units")
            limit = polytope.chebyshev_radius
            if self.buffer > limit * (1.0 + 1e-9):
                raise InvalidParameter(
                    f"buffer={self.buffer:g} is wider than the polytope admits: its Chebyshev "
                    f"radius (largest inscribed ball) is {limit:.6g}, so no point would be clear "
                    "of every facet's band and recovery could not be combined with the other "
                    f"facets' bounds; use buffer <= {limit:.6g}"
                )
            self.spring_gain = check_positive(
                "spring_gain",
                1.0 if spring_gain is None else spring_gain,
                allow_zero=True,
                unit="1/s",
            )
            self.max_recovery_speed = (
                self.spring_gain * self.buffer
                if max_recovery_speed is None
                else check_positive(
                    "max_recovery_speed", max_recovery_speed, unit="workspace units per second"
                )
            )
        self.profile = profile
        self.dt = None if dt is None else check_positive("dt", dt, unit="s")
        idt = 0.0 if self.dt is None else 1.0 / self.dt
        if not math.isfinite(idt):
            raise InvalidParameter(
                f"dt: expected a control period of at least 1e-300 s, got {show(dt)}"
            )
        super().__init__(on_invalid=on_invalid)
        self.accelerate = check_flag("accelerate", accelerate)
        self._generic: ApproachProfile | None = None
        prm: tuple[float, ...]
        if profile is None:
            kind = kern.PROFILE_LINEAR
            prm = (self.buffer, self.spring_gain, self.max_recovery_speed, 0.0, 0.0, 0.0)
            relax = True
        elif isinstance(profile, (LinearBuffer, ThreeZoneBraking)):
            kind, prm = profile.kernel_profile
            relax = False
        else:
            kind, prm, relax = kern.PROFILE_LINEAR, (math.inf, 0.0, 0.0, 0.0, 0.0, 0.0), False
            self._generic = profile
        N = np.ascontiguousarray(polytope.normals, dtype=float).ravel()
        off = np.ascontiguousarray(polytope.offsets, dtype=float)
        cen = np.ascontiguousarray(polytope.chebyshev_center, dtype=float)
        nf, dim = polytope.normals.shape
        # The compiled kernels take the profile's parameters as an array (cheaper to pass than a
        # tuple of six floats); the plain-Python kernel takes lists.
        self._args: tuple[Any, ...] = (N, off, nf, dim, cen, kind, np.array(prm), relax, idt)
        self._lists: tuple[Any, ...] = (
            N.tolist(), off.tolist(), nf, dim, cen.tolist(), kind, prm, relax, idt
        )  # fmt: skip
        nd_core, self.backend = pick_backend(backend, self._generic is None)
        self._core: Any = None
        self._core_shape: Any = None
        if nd_core is not None:
            self._core = nd_core.PolytopeLaw(
                N, off, cen, nf, dim, kind, list(prm), relax, idt, MAX_MAGNITUDE
            )
            self._core_shape = self._core.shape_array
            if type(self).shape is PolytopeShaper.shape:
                # No Python frame on the common path: ``self.shape`` becomes a C callable that
                # runs the core's fast path (two finite float64 (n,) arrays within MAX_MAGNITUDE)
                # and hands every other call to the Python route (validation, on_invalid,
                # refusals), which gives the same answer bit for bit. A subclass overriding
                # ``shape`` keeps its own.
                call = getattr(compiled_core(), "ShapeCall", None)
                if call is not None:
                    object.__setattr__(self, "shape", call(self._core_shape, self._shape_generic))
        self._ready = True

    def __setattr__(self, name: str, value: Any) -> None:
        if getattr(self, "_ready", False):
            raise AttributeError(
                f"PolytopeShaper is immutable (its law is precomputed): build a new one instead "
                f"of setting {name!r}"
            )
        object.__setattr__(self, name, value)

    @property
    def dim(self) -> int:
        """Dimension n of the shaped space."""
        return int(self._args[3])

    # ------------------------------------------------------------------ inputs
    def _vectors(
        self, position: ArrayLike, command: ArrayLike
    ) -> tuple[FloatArray, FloatArray, bool]:
        """Validated position and command, and whether both are finite."""
        n = self.dim
        if (
            type(position) is np.ndarray
            and type(command) is np.ndarray
            and position.shape == (n,)
            and command.shape == (n,)
            and position.dtype.char == "d"
            and command.dtype.char == "d"
        ):
            # Fast path for the common call (two float64 vectors): only the magnitude check of
            # real_array is needed; non-finite values go on to the on_invalid policy.
            vals = position.tolist() + command.tolist()
            s = sum(vals)
            if s - s == 0.0 and max(map(abs, vals)) <= MAX_MAGNITUDE:
                return position, command, True
        p = real_array("position", position, (n,), what=f"a {n}-vector", allow_nonfinite=True)
        v = real_array("command", command, (n,), what=f"a {n}-vector", allow_nonfinite=True)
        return p, v, bool(np.isfinite(p).all() and np.isfinite(v).all())

    def _run(
        self, p: FloatArray, v: FloatArray, compiled: bool = True
    ) -> tuple[FloatArray, tuple[int, int, int, int, int, float, float, int], Any, Any, Any]:
        """One state through the kernel: (out, result tuple, active, dist, bnd/work pair)."""
        nf, dim = self._args[2], self._args[3]
        if self._generic is not None:
            return self._run_generic(p, v, self._generic)
        if self._core is not None:
            out_c, res_c, active_c, dist_c, bnd_c, work_c = self._core.law(p, v)
            return out_c, res_c, active_c, dist_c, (bnd_c, work_c)
        fn = compiled_polytope()[0] if compiled and self.accelerate else None
        if fn is not None:
            out = np.zeros(dim)
            active = np.zeros(dim + 1, dtype=np.int64)
            dist = np.zeros(nf)
            bnd = np.zeros(nf)
            work = np.zeros(nf, dtype=np.int64)
            res = fn(p, v, *self._args, out, active, dist, bnd, work)
            return out, res, active, dist, (bnd, work)
        outl = [0.0] * dim
        activel = [0] * (dim + 1)
        distl = [0.0] * nf
        bndl = [0.0] * nf
        workl = [0] * nf
        scratch = (
            [0.0] * (nf * dim), [0.0] * nf, [0.0] * dim, [0.0] * dim, [0.0] * (dim + 1),
            [0] * (dim + 1), [0.0] * scratch_length(nf, dim),
        )  # fmt: skip
        res = nd.polytope_kernel(
            p.tolist(),
            v.tolist(),
            *self._lists,
            outl,
            activel,
            distl,
            bndl,
            workl,
            *scratch,  # type: ignore[call-arg]
        )
        return np.array(outl), res, activel, distl, (bndl, workl)

    def _run_generic(
        self, p: FloatArray, v: FloatArray, profile: ApproachProfile
    ) -> tuple[FloatArray, tuple[int, int, int, int, int, float, float, int], Any, Any, Any]:
        """The exact law with a profile the kernels do not know (plain Python, its own cap)."""
        N = self.polytope.normals
        nf, dim = N.shape
        dist = (N @ p - self.polytope.offsets).tolist()
        speed = nd.vector_norm(v.tolist(), dim)
        caps = [profile.cap(d, speed) for d in dist]
        bounded = [e for e in range(nf) if dist[e] < 0.0 or caps[e] < speed]
        n_out = sum(1 for d in dist if d < 0.0)
        zone = kern.zone_code(n_out, sum(1 for c in caps if c < speed))
        order = sorted(range(nf), key=dist.__getitem__)
        p1 = order[0]
        p2 = order[1] if nf > 1 else -1
        d1 = dist[p1]
        d2 = dist[p2] if p2 >= 0 else math.inf
        bnd = [0.0] * nf
        for e in bounded:
            bnd[e] = -caps[e]
        work = list(bounded) + [0] * (nf - len(bounded))
        stages = (kern.STAGE_PROJECT if bounded else 0) | (kern.STAGE_SPRING if n_out else 0)
        out = v.copy()
        active = [0] * (dim + 1)
        q = 0
        if bounded:
            rows = list(bounded)
            steps = iter(nd.RECOVERY_FRACTIONS)
            while True:
                G = N[rows].ravel().tolist()
                b = [bnd[e] for e in rows]
                x = [0.0] * dim
                lam = [0.0] * (dim + 1)
                act = [0] * (dim + 1)
                wsf = [0.0] * scratch_length(len(rows), dim)
                status, q, _ = project_kernel(v.tolist(), G, b, len(rows), dim, x, lam, act, wsf)
                if status == PROJECT_OPTIMAL:
                    # Outside, the answer can be faster than the command: a facet whose cap was
                    # not below |v| may bind then (as in the kernels); bound those it violates.
                    xa = np.array(x)
                    extra = [
                        e for e in range(nf)
                        if e not in rows and dist[e] >= 0.0 and float(N[e] @ xa) < -caps[e]
                    ] if n_out else []  # fmt: skip
                    if extra:
                        for e in extra:
                            bnd[e] = -caps[e]
                        rows += extra
                        bounded = sorted(set(bounded) | set(extra))
                        continue
                    out = xa
                    for c in range(q):
                        active[c] = rows[act[c]]
                    break
                q = 0
                frac = next(steps, None) if n_out > 0 else None
                if frac is not None:
                    # As the kernels: slow the outside facets' recovery (1/4, 1/16, ..., then
                    # "no further out"), every bound of a facet the point is inside kept.
                    for e in rows:
                        if dist[e] < 0.0 and bnd[e] > 0.0:
                            bnd[e] = bnd[e] * 0.25 if frac > 0.0 else 0.0
                    stages |= kern.STAGE_RELAXED
                    continue
                out = np.zeros(dim)
                stages |= kern.STAGE_STOP
                break
            work = list(bounded) + [0] * (nf - len(bounded))
        res = (zone, stages, q, p1, p2, d1, d2, len(bounded))
        return out, res, active, dist, (bnd, work)

    # ------------------------------------------------------------------ the contract
    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Shaped velocity.

        With the C backend an instance's ``shape`` is a C callable
        (``velfence_core._core.ShapeCall``): two finite float64 vectors of shape (n,) within
        ``MAX_MAGNITUDE`` run the core with no Python frame; every other call takes this
        method's Python route, with the same result.

        Args:
            position: Position of the shaped point, shape (n,) [workspace units].
            command: Commanded velocity, shape (n,) [workspace units/s].

        Returns:
            The admissible velocity, shape (n,), never non-finite.

        Raises:
            InvalidInput: wrong shape or type, or non-finite input with ``on_invalid="raise"``.
        """
        fast = self._core_shape
        if fast is not None:
            # Two finite float64 vectors of shape (n,) go straight to C; anything else (and an
            # overflowed answer) takes the generic path below, with the same result.
            res: FloatArray | None = fast(position, command)
            if res is not None:
                return res
        return self._shape_generic(position, command)

    def _shape_generic(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """:meth:`shape`'s Python route: validation, the ``on_invalid`` policy, the kernel.

        Args:
            position: Position of the shaped point, shape (n,) [workspace units].
            command: Commanded velocity, shape (n,) [workspace units/s].

        Returns:
            The admissible velocity, shape (n,), never non-finite.

        Raises:
            InvalidInput: wrong shape or type, or non-finite input with ``on_invalid="raise"``.
        """
        p, v, finite = self._vectors(position, command)
        if not finite:
            self._invalid(f"non-finite input: position={p.tolist()}, command={v.tolist()}")
            return np.zeros(self.dim)
        out = self._run(p, v)[0]
        s = sum(out.tolist())
        if s - s != 0.0:
            self._invalid("input too large, the shaped velocity overflowed")
            return np.zeros(self.dim)
        return out

    def explain(self, position: ArrayLike, command: ArrayLike) -> PolytopeResult:
        """Shaped velocity with the zone, the bounded and binding facets and their slack.

        Args:
            position: Position, shape (n,) [workspace units].
            command: Command, shape (n,) [workspace units/s].

        Returns:
            A :class:`PolytopeResult`.
        """
        p, v, finite = self._vectors(position, command)
        nf = self._args[2]
        if not finite:
            self._invalid(f"non-finite input: position={p.tolist()}, command={v.tolist()}")
            return self._stopped(p, v)
        out, res, active, dist, (bnd, work) = self._run(p, v)
        if not np.isfinite(out).all():
            self._invalid("input too large, the shaped velocity overflowed")
            return self._stopped(p, v)
        zone_c, stages_c, q, *_, m = res
        names = self.polytope.facet_names
        binding = tuple(int(a) for a in list(active)[:q])
        bounded = tuple(sorted(int(e) for e in list(work)[:m]))
        lower = np.array([bnd[e] for e in bounded], dtype=float)
        N = self.polytope.normals
        idx = list(bounded)
        slack = N[idx] @ out - lower if bounded else np.zeros(0)
        zone: Zone = kern.ZONE_NAMES[zone_c]  # type: ignore[assignment]
        stages = tuple(n for bit, n in enumerate(kern.STAGE_NAMES) if stages_c & (1 << bit))
        return PolytopeResult(
            output=out,
            command=v,
            position=p,
            zone=zone,
            active=bounded,
            active_names=tuple(names[a] for a in bounded),
            lower=lower,
            binding=binding,
            binding_names=tuple(names[a] for a in binding),
            slack=slack,
            distances=np.array(dist[:nf], dtype=float),
            stages=stages,
            relaxed=bool(stages_c & kern.STAGE_RELAXED),
        )

    def _stopped(self, p: FloatArray, v: FloatArray) -> PolytopeResult:
        nf, dim = self._args[2], self._args[3]
        return PolytopeResult(
            output=np.zeros(dim), command=v, position=p, zone="invalid", active=(),
            active_names=(), lower=np.zeros(0), binding=(), binding_names=(), slack=np.zeros(0),
            distances=np.zeros(nf), stages=("stop",),
        )  # fmt: skip

    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Shaped velocities for N states at once; equal to looping :meth:`shape`.

        With the compiled core, validated rows that are all finite go to its velocity-only loop
        (``PolytopeLaw.batch_velocity``: only the output array is written, no zones); anything
        else (non-finite rows, an overflowed answer, mismatched shapes) takes
        :meth:`zones_batch`, which owns the ``on_invalid`` policy and the messages.

        Args:
            positions: Positions, shape (N, n) [workspace units].
            commands: Commands, shape (N, n) [workspace units/s].

        Returns:
            Shape (N, n); rows with non-finite input are zero under ``on_invalid="stop"``.
        """
        core = self._core
        if core is None:
            return self.zones_batch(positions, commands)[0]
        n = self.dim
        # The same validation as zones_batch (same messages); read only, so not copied.
        P = real_array(
            "positions", positions, (None, n), what=f"rows of {n}", allow_nonfinite=True,
            copy=False,
        )  # fmt: skip
        V = real_array(
            "commands", commands, (None, n), what=f"rows of {n}", allow_nonfinite=True, copy=False
        )
        if P.shape != V.shape:
            return self.zones_batch(positions, commands)[0]
        out = np.empty(P.shape)  # C order (the core writes rows in place)
        if core.batch_velocity(np.ascontiguousarray(P), np.ascontiguousarray(V), out):
            return self.zones_batch(positions, commands)[0]  # rows not finite in or out
        return out

    def zones_batch(self, positions: ArrayLike, commands: ArrayLike) -> tuple[FloatArray, IntArray]:
        """Like :meth:`shape_batch`, also returning every row's zone code (``ZONE_NAMES`` index).

        Args:
            positions: Positions, shape (N, n).
            commands: Commands, shape (N, n).

        Returns:
            ``(out (N, n), zones (N,))``.
        """
        n = self.dim
        P = real_array("positions", positions, (None, n), what=f"rows of {n}", allow_nonfinite=True)
        V = real_array("commands", commands, (None, n), what=f"rows of {n}", allow_nonfinite=True)
        if P.shape != V.shape:
            raise InvalidInput(
                f"positions and commands must have the same shape (N, {n}), got {P.shape} and "
                f"{V.shape}"
            )
        ok_p = np.isfinite(P).all(axis=1)
        ok_v = np.isfinite(V).all(axis=1)
        good: BoolArray = np.asarray(ok_p & ok_v)
        if not good.all():
            which = " and ".join(
                n for n, o in (("positions", ok_p), ("commands", ok_v)) if not o.all()
            )
            self._invalid(f"non-finite {which} in row(s) {np.flatnonzero(~good)[:10].tolist()}")
            P = np.where(good[:, None], P, 0.0)
            V = np.where(good[:, None], V, 0.0)
        out = np.zeros(P.shape)  # C order (the core writes rows in place)
        zones = np.zeros(P.shape[0], dtype=np.int64)
        fn = compiled_polytope()[1] if self.accelerate and self._generic is None else None
        if P.shape[0] == 0:
            pass
        elif self._core is not None:
            self._core.batch(np.ascontiguousarray(P), np.ascontiguousarray(V), out, zones)
        elif fn is not None:
            fn(np.ascontiguousarray(P), np.ascontiguousarray(V), out, zones, *self._args)
        else:
            for r in range(P.shape[0]):
                o, res, *_ = self._run(P[r], V[r], compiled=False)
                out[r] = o
                zones[r] = res[0]
        bad = ~np.isfinite(out).all(axis=1)
        if bad.any():
            self._invalid(
                f"positions or commands too large, the shaped velocity overflowed in row(s) "
                f"{np.flatnonzero(bad)[:10].tolist()}"
            )
            good = good & ~bad
        out[~good] = 0.0
        zones[~good] = kern.ZONE_INVALID
        return out, zones

    def bound_rows(
        self, position: ArrayLike, command: ArrayLike
    ) -> tuple[FloatArray, FloatArray, IntArray]:
        r"""The half-space bounds the law enforces at ``position`` for ``command``.

        Args:
            position: Position, shape (n,).
            command: Command, shape (n,).

        Returns:
            ``(normals (k, n), lower (k,), facets (k,))``: :math:`n_i\cdot v_o \ge L_i` for every
            bounded facet (caller's units), ascending facet order.

        Raises:
            InvalidInput: bad or non-finite input.
        """
        r = self.explain(position, command)
        if r.zone == "invalid":
            return np.zeros((0, self.dim)), np.zeros(0), np.zeros(0, dtype=np.int64)
        idx = np.array(r.active, dtype=np.int64)
        return self.polytope.normals[idx].copy(), r.lower.copy(), idx

    def __repr__(self) -> str:
        return (
            f"PolytopeShaper({self.polytope.n_facets} facets in {self.dim}-D, "
            f"buffer={self.buffer}, spring_gain={self.spring_gain}, dt={self.dt}, "
            f"backend={self.backend!r})"
        )


document_inits(globals())
