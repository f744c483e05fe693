r"""A joint-space safety filter: one minimum-change problem per control cycle.

Every cycle the commanded joint velocity ``u`` (or the joint velocity a task-space twist asks
for) is replaced by the nearest joint velocity ``x`` that meets every safety bound at once::

    minimise ½ (x - u)ᵀ W (x - u)                  joint mode (W = diag(weights), default I)
    or       ½ ‖J x - v‖² + ½ λ² ‖x‖²              twist mode (damped least squares, λ = damping)
    subject to  G x >= b                           (joint, workspace, obstacle, rate rows)

Both objectives are ``½ (x - u)ᵀ H (x - u) + const`` (twist mode: ``H = JᵀJ + λ²I``,
``u = H⁻¹ Jᵀ v``); with the Cholesky factor ``H = L Lᵀ`` and ``y = Lᵀ x`` the problem is the
Euclidean projection of ``Lᵀ u`` onto ``{y : G L⁻ᵀ y >= b}``, solved exactly by
:func:`velfence.geometry.projection.project`.

The rows (derivation and argument in ``docs/safety_filter.md``):

1. **joint position**: toward each finite limit at distance ``d`` the approach speed is capped by
   the exact law's bound definition (:func:`velfence.shaping._kernels.fill_bounds` with
   :func:`~velfence.shaping._kernels.profile_cap`): three-zone braking (Lê et al. 2024; the
   square-root zone is the braking law :math:`\sqrt{2 a d}`) for a joint with an acceleration
   limit, a linear buffer otherwise; beyond a limit the profile's forced return (capped at the
   joint's ``max_velocity``). With ``dt``: the approach per period is at most ``d``.
2. **joint velocity** ``|x_j| <= max_velocity_j``.
3. **acceleration** (with ``dt`` and ``max_acceleration``): ``|x - previous| <= a dt``.
4. **workspace**: for every facet ``i`` of each :class:`WorkspaceLimit` (a
   :class:`~velfence.geometry.polytope.ConvexPolytope` on a named point ``p``):
   ``(n_iᵀ J_p) x >= lower_i`` from the same bound definition.
5. **obstacles**: for every :class:`SphereObstacle` and every capsule link within reach: the
   critical point of the link (the closest axis point to the centre), its direction ``n`` and
   Jacobian ``J_c``: ``(nᵀ J_c) x >= lower`` from a linear buffer of width ``obstacle_buffer``.

In discrete time the linearised rows are checked on the kinematic model after the solve: a
workspace facet or obstacle clearance that the next position ``q + x dt`` would cross although
it is not crossed now has its bound tightened by the crossing and the problem is solved again
(a few rounds; second-order effects of the tangential motion are then not left to the recovery).

Priorities when the rows are infeasible together: joint limits (position and velocity) first,
then workspace, then obstacles, then the acceleration rows, then the task (the objective). The
ladder: drop the acceleration rows (``rate_override``); relax the obstacle recovery bounds to
"no further out" (0); drop the obstacles; the same for the workspace; relax the joint recovery
bounds; zero velocity (which meets every relaxed bound). The result names what was dropped.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive,
    describe,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.shaping._kernels import (
    ZONE_NAMES,
    bounds_from_distances,
    fill_bounds,
    zone_code,
)
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.kinematics import Kinematics
from velfence.shaping.limits import JointLimits, Profile, SphereObstacle, WorkspaceLimit
from velfence.shaping.polytope import PolytopeBackend, pick_backend
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

__all__ = [
    "FilterResult",
    "JointLimits",
    "Kinematics",
    "SafetyFilter",
    "SphereObstacle",
    "WorkspaceLimit",
]

#: Priority levels of the rows, highest first.
LEVEL_JOINT = 0
LEVEL_WORKSPACE = 1
LEVEL_OBSTACLE = 2
LEVEL_RATE = 3
LEVEL_NAMES = ("joint limits", "workspace", "obstacles", "acceleration")

_BINDING = 1e-9  # relative slack under which a row counts as active
_CORRECTION_ROUNDS = 4  # discrete-time model checks per cycle

# The metric's factor L (W = L Lᵀ): None (identity), a vector (diagonal) or a lower-triangular
# matrix.
_Metric = FloatArray | None


# ---------------------------------------------------------------------------------- result
@dataclass(frozen=True, eq=False)
class FilterResult:
    """What the safety filter did in one cycle.

    Attributes:
        output: The filtered joint velocity [rad/s], shape (n,); always finite.
        command: The command as given: joint velocity (n,) or twist (3,)/(6,).
        position: The joint position [rad], shape (n,).
        zone: :data:`~velfence.shaping.base.Zone` from ``zone_code(violated, active)``:
            ``"free"``, ``"buffer"``/``"corner"`` (one/several active rows, none violated),
            ``"outside"``/``"outside-corner"`` (some constraint violated), ``"invalid"``.
        active: Indices (into :attr:`constraint_names`) of the rows that bind at the output
            (slack <= 1e-9 relative) or whose constraint is violated.
        active_names: Their names (``"joint 4 position (upper)"``, ``"joint 2 velocity
            (lower)"``, ``"TCP face x_max"``, ``"obstacle 2 on link 5"``).
        slack: ``G x - b`` of every row, shape (m,) (``inf`` for an unbounded row; a dropped
            row's slack is still reported against its bound).
        constraint_names: Name of every row, in row order.
        stages: What was applied, in order: ``"projection"`` (the output differs from the
            unconstrained optimum), ``"recovery"``, ``"model-check"`` (a discrete-time bound
            was tightened), ``"relaxed <level>"``, ``"dropped <level>"``, ``"stop"``.
        dropped: Levels dropped or relaxed to reach feasibility: ``"acceleration"``,
            ``"obstacles"``, ``"workspace"``, ``"joint limits"`` (relaxed only).
        rate_override: Whether the acceleration rows were dropped (safety over smoothness).
        rows: ``(G (m, n), b (m,))``: the rows ``G x >= b`` as built this cycle, before any
            relaxation or discrete-time tightening (read-only).
        method: ``"safety-filter"``.
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: Zone
    active: tuple[int, ...]
    active_names: tuple[str, ...]
    slack: FloatArray
    constraint_names: tuple[str, ...]
    stages: tuple[str, ...]
    dropped: tuple[str, ...]
    rate_override: bool
    rows: tuple[FloatArray, FloatArray]
    method: str = "safety-filter"


class _Rows:
    """The rows of one cycle, appended in blocks, then :meth:`done` (arrays)."""

    __slots__ = (
        "G",
        "_G",
        "_b",
        "_level",
        "_namer",
        "_names",
        "_viol",
        "b",
        "check",
        "level",
        "m",
        "violated",
    )

    def __init__(self) -> None:
        self._G: list[FloatArray] = []
        self._b: list[FloatArray] = []
        self._level: list[tuple[int, int]] = []
        self._viol: list[Any] = []
        self._names: list[str] = []
        self._namer: Any = None  # rows from the compiled core: names made when first asked
        self.m = 0
        # discrete-time model checks: (row index, kind, key) with kind "ws" or "ob"
        self.check: list[tuple[int, str, tuple[int, int]]] = []
        self.G: FloatArray = np.zeros((0, 0))
        self.b: FloatArray = np.zeros(0)
        self.level: Any = np.zeros(0, dtype=np.int64)
        self.violated: Any = np.zeros(0, dtype=bool)

    def block(
        self, G: FloatArray, b: FloatArray, level: int, viol: Any, names: Sequence[str]
    ) -> int:
        """Append rows ``G x >= b`` (k, n) of one level; returns the first one's index."""
        first = self.m
        k = b.shape[0]
        if k:
            self._G.append(G)
            self._b.append(b)
            self._level.append((level, k))
            self._viol.append(viol)
            self._names.extend(names)
            self.m += k
        return first

    @property
    def names(self) -> list[str]:
        """Every row's name, in row order."""
        if self._namer is not None:
            self._names = self._namer()
            self._namer = None
        return self._names

    def done(self, n: int) -> _Rows:
        """Stack the blocks into ``G`` (m, n), ``b``, ``level`` and ``violated`` (m,)."""
        if self._b:
            self.G = np.concatenate(self._G).reshape(self.m, n)
            self.b = np.concatenate(self._b).astype(np.float64, copy=False)
            lv = self._level
            self.level = (
                np.full(self.m, lv[0][0], dtype=np.int64)
                if len(lv) == 1
                else np.repeat(np.array([x[0] for x in lv], dtype=np.int64), [x[1] for x in lv])
            )
            self.violated = np.concatenate(self._viol).astype(bool, copy=False)
        else:
            self.G = np.zeros((0, n))
        return self


#: The bound kernels: (bounds_from_distances, fill_bounds), plain Python or compiled twins.
_BoundKernels = tuple[Any, Any]
_PLAIN_BOUNDS: _BoundKernels = (bounds_from_distances, fill_bounds)


def _bounds(
    prm: Profile, dist: FloatArray, speed: float, idt: float, kern: _BoundKernels = _PLAIN_BOUNDS
) -> FloatArray:
    """Lower bounds on the approach rate ``n·x`` toward constraints at distances ``dist``.

    The exact law's one bound definition, :func:`velfence.shaping._kernels.bounds_from_distances`
    (cap speed ``speed`` shared by the rows): inside ``-cap(d, s)``, in discrete time at least
    ``-d/dt``; outside the profile's forced return, in discrete time at most the penetration per
    period. That function keeps only the rows that bind the *command* (cap below its speed,
    reachable in one period at its speed); here the output may move a point faster than the
    command does (a joint-space projection is not a Cartesian one), so the rows it leaves out
    get the same definition from :func:`~velfence.shaping._kernels.fill_bounds` (``-inf`` where
    the profile sets no cap and there is no period). Each row's bound depends on its own
    distance only (both kernels run with unit scale and the cap speed ``speed``), so rows of
    one profile and speed may share a call. ``kern``: the kernels, plain or compiled (numba), or
    ``(None, velfence_core._nd)``: the same definition in C (``rate_bounds``, bit for bit).
    """
    kind, params = prm.kernel_profile
    if kern[0] is None:
        out: FloatArray = kern[1].rate_bounds(kind, params, dist, speed, idt)
        return out
    k = dist.shape[0]
    bnd = np.zeros(k)
    work = np.zeros(k, dtype=np.int64)
    bfd, fill = kern
    m = bfd(dist, k, speed, kind, params, False, idt, False, bnd, work)[0]
    if m < k:
        # (violated rows are always chosen, so the rest holds rows with d >= 0 only)
        rest = np.ones(k, dtype=bool)
        rest[work[:m]] = False
        idx = np.flatnonzero(rest).astype(np.int64)
        fill(kind, params, False, dist, idx, 0, idx.shape[0], speed, 1.0, idt, bnd)
    return bnd


def workspace_bounds(
    profile: Profile, distances: FloatArray, speed: float, dt: float | None
) -> FloatArray:
    """The filter's workspace-facet bounds: lower bounds on ``n_i·ṗ`` [m/s], shape (k,).

    What :class:`SafetyFilter` puts on the right of its workspace rows ``(n_iᵀ J_p) x >= b_i``
    (:func:`_bounds` with the plain kernels), exposed for the other formulations of the same
    rows (``velfence.integrations.mink_limits.PolytopeLimit``) so that they share the law rather
    than a copy of it. Inputs are trusted (validated by the caller): ``profile`` a
    :data:`Profile`, ``distances`` the facets' signed distances [m] (positive inside, finite,
    float64, shape (k,)), ``speed`` the cap speed ``s`` >= 0 [m/s] (the filter passes the
    command's speed of the point, ``‖J u‖``), ``dt`` the control period [s] or ``None``.
    ``-inf`` marks a facet without a bound (continuous time, beyond the profile's reach).
    """
    return _bounds(profile, distances, speed, 0.0 if dt is None else 1.0 / dt)


def _bound1(prm: Profile, d: float, speed: float, idt: float) -> float:
    """:func:`_bounds` of one row, the plain kernels on Python floats (cheaper for one row)."""
    kind, params = prm.kernel_profile
    bnd = [0.0]
    work = [0]
    if bounds_from_distances([d], 1, speed, kind, params, False, idt, False, bnd, work)[0] == 0:
        fill_bounds(kind, params, False, [d], [0], 0, 1, speed, 1.0, idt, bnd)
    return bnd[0]


#: Fractions of a violated level's recovery bounds the priority ladder tries, in order, before it
#: drops the level: a slower way back (1/4, 1/16, ... down to 4^-8) before "no further out" (0).
_COMMAND_CAP = 1e3  # commands are shortened beyond this multiple of the fastest joint limit
_RECOVERY_FRACTIONS = (*(0.25**k for k in range(1, 9)), 0.0)


def _finite(x: FloatArray) -> bool:
    """Whether every entry of the vector ``x`` is finite (Python floats: cheaper than numpy)."""
    return all(map(math.isfinite, x.tolist()))


def _projection(
    u: FloatArray, G: FloatArray, b: FloatArray, kernel: Any = None
) -> tuple[bool, FloatArray]:
    """Projection of ``u`` onto ``{x : G x >= b}`` for the filter's own arrays: ``(feasible, x)``.

    :func:`velfence.geometry.projection.project_kernel` (the solve behind ``project``): its
    compiled twin ``kernel`` on contiguous float64 arrays, or (``kernel`` None) the plain kernel
    on Python lists, which plain Python indexes faster than arrays; the inputs are finite
    (``b`` finite), built by the filter.
    """
    from velfence.geometry.projection import PROJECT_OPTIMAL, project_kernel, scratch_length

    m, n = G.shape
    if kernel is not None:
        xa = np.zeros(n)
        status = kernel(
            np.ascontiguousarray(u, dtype=np.float64),
            np.ascontiguousarray(G, dtype=np.float64).reshape(m * n),
            np.ascontiguousarray(b, dtype=np.float64),
            m, n, xa, np.zeros(n + 1), np.zeros(n + 1, dtype=np.int64),
            np.zeros(scratch_length(m, n)),
        )[0]  # fmt: skip
        return status == PROJECT_OPTIMAL and _finite(xa), xa
    x = [0.0] * n
    lam = [0.0] * (n + 1)
    act = [0] * (n + 1)
    wsf = [0.0] * scratch_length(m, n)
    status = project_kernel(u.tolist(), G.ravel().tolist(), b.tolist(), m, n, x, lam, act, wsf)[0]
    xa = np.array(x, dtype=np.float64)
    return status == PROJECT_OPTIMAL and _finite(xa), xa


def _projection_c(
    core: Any, u: FloatArray, G: FloatArray, b: FloatArray
) -> tuple[bool, FloatArray]:
    """:func:`_projection` through the compiled core (``velfence_core._nd.project``).

    The same kernel in C, bit for bit; C-contiguous float64 arrays, finite.
    """
    status, x = core.project(
        np.ascontiguousarray(u, dtype=np.float64),
        np.ascontiguousarray(G, dtype=np.float64),
        np.ascontiguousarray(b, dtype=np.float64),
    )
    return status == 0 and _finite(x), x


def _factor(H: FloatArray) -> FloatArray:
    """Cholesky factor of the damped normal matrix; NaN when it has none (the caller stops).

    With a damping far below the Jacobian's scale (1e-9 against entries of 1) round-off can make
    ``JᵀJ + λ²I`` lose definiteness at a singular pose: a relative jitter of 1e-12 restores it.
    """
    if not np.all(np.isfinite(H)):
        return np.full_like(H, np.nan)
    n = H.shape[0]
    for jitter in (0.0, 1e-12, 1e-9):
        try:
            shift = jitter * (float(np.trace(H)) / n + 1e-300)
            L: FloatArray = np.linalg.cholesky(H + shift * np.eye(n))
            return L
        except np.linalg.LinAlgError:
            continue
    return np.full_like(H, np.nan)


def _cholesky(name: str, W: FloatArray) -> FloatArray:
    try:
        L: FloatArray = np.asarray(np.linalg.cholesky(W), dtype=np.float64)
        return L
    except np.linalg.LinAlgError:
        raise InvalidParameter(
            f"{name}: expected a symmetric positive definite matrix, got eigenvalues "
            f"{np.linalg.eigvalsh(0.5 * (W + W.T)).tolist()}"
        ) from None


class SafetyFilter(InvalidPolicy):
    r"""Minimum-change joint velocity under joint, workspace, obstacle and rate limits.

    See the module docstring and ``docs/safety_filter.md`` for the problem, the rows and the
    priorities.

    Args:
        robot: The kinematics (:class:`Kinematics`: ``DHChain``, ``PlanarArm``, ``Puma560``).
        limits: The joint limits (:class:`JointLimits`, ``dof`` joints; names checked against
            ``robot.joint_names`` when given).
        workspace: Workspace limits (:class:`WorkspaceLimit`, one or a sequence).
        obstacles: Sphere obstacles (:class:`SphereObstacle`); need the robot's capsule
            geometry (``link_segments``, ``link_radius``, ``point_jacobian``).
        dt: Control period [s] (``None``: continuous-time bounds). With ``dt`` every row also
            keeps one period's motion inside, the rows are checked on the model, and the
            acceleration rows apply.
        profile: One approach profile for every joint limit (radians); by default a
            three-zone braking profile for each joint with an acceleration limit
            (``ThreeZoneBraking(gain=2 a/v, max_speed=v, max_acceleration=a)`` with that
            joint's limits), else a linear buffer of width ``joint_buffer`` whose cap speed is
            the joint's ``max_velocity``.
        joint_buffer: Width of the default linear buffer at joint limits [rad], > 0.
        spring_gain: Recovery gain of the default joint buffers and the obstacles [1/s], >= 0.
        obstacle_buffer: Width of the obstacles' linear buffer [m], > 0.
        weights: Joint-mode metric ``W``: ``None`` (identity), per-joint weights (n,) > 0, or a
            symmetric positive definite (n, n) matrix.
        damping: :math:`\lambda` of the twist mode's damped least squares [m/rad], > 0.
        accelerate: With the Python backend, solve with the numba-compiled projection and
            bound kernels when numba is installed (default True; the same results to
            round-off); plain Python otherwise.
        backend: Implementation of the solve, the bounds and (for a ``DHChain`` / ``PlanarArm``)
            the obstacle rows (:data:`~velfence.shaping.polytope.PolytopeBackend`): ``"auto"``
            (default) runs the compiled C core (the separate ``velfence_core`` distribution)
            when it is importable, the Python reference otherwise; ``"python"`` always runs
            the reference (numba with ``accelerate``); ``"c"`` requires the core. The solve and
            the bounds are the reference's bit for bit; the obstacle geometry agrees to
            round-off. :attr:`backend` reports the one in use.
        on_invalid: ``"raise"`` or ``"stop"`` (zero velocity, zone ``"invalid"``).

    Raises:
        InvalidParameter: a bad parameter, limits of the wrong size or names, a workspace point
            the robot does not have or whose dimension differs from its polytope's, obstacles
            on a robot without capsule geometry.
    """

    __slots__ = (
        "_cached",
        "_caps",
        "_core",
        "_dpos",
        "_fused",
        "_has_accel",
        "_joint_prof",
        "_joint_rows",
        "_kern",
        "_metric",
        "_obstacle_geometry",
        "_obstacles",
        "_previous",
        "_rate_rows",
        "_solver",
        "_speed_scale",
        "_vsum",
        "_workspace",
        "_ws_names",
        "_ws_prof",
        "accelerate",
        "backend",
        "damping",
        "dof",
        "dt",
        "limits",
        "obstacle_buffer",
        "robot",
        "spring_gain",
        "task_dim",
    )

    method = "safety-filter"

    def __init__(
        self,
        robot: Kinematics,
        *,
        limits: JointLimits,
        workspace: WorkspaceLimit | Sequence[WorkspaceLimit] = (),
        obstacles: Sequence[SphereObstacle] = (),
        dt: float | None = None,
        profile: Profile | None = None,
        joint_buffer: float = 0.1,
        spring_gain: float = 1.0,
        obstacle_buffer: float = 0.05,
        weights: ArrayLike | None = None,
        damping: float = 1e-2,
        accelerate: bool = True,
        on_invalid: OnInvalid = "raise",
        backend: PolytopeBackend = "auto",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        for attr in ("dof", "joint_names", "points", "fk", "jacobian"):
            if not hasattr(robot, attr):
                raise InvalidParameter(
                    f"robot: expected the Kinematics protocol (dof, joint_names, points, fk, "
                    f"jacobian), got {type(robot).__name__} without {attr!r}"
                )
        self.robot = robot
        n = int(robot.dof)
        self.dof = n
        if not isinstance(limits, JointLimits):
            raise InvalidParameter(f"limits: expected a JointLimits, got {describe(limits)}")
        if limits.dof != n:
            raise InvalidParameter(
                f"limits: expected limits of the robot's {n} joints, got {limits.dof}"
            )
        if limits.names is not None and tuple(limits.names) != tuple(robot.joint_names):
            raise InvalidParameter(
                f"limits: joint names {list(limits.names)} differ from the robot's "
                f"{list(robot.joint_names)}"
            )
        self.limits = limits
        self._speed_scale = float(np.max(limits.max_velocity))
        self.dt = None if dt is None else check_positive("dt", dt, unit="s")
        self.spring_gain = check_positive("spring_gain", spring_gain, allow_zero=True, unit="1/s")
        jb = check_positive("joint_buffer", joint_buffer, unit="rad")
        self.obstacle_buffer = check_positive("obstacle_buffer", obstacle_buffer, unit="m")
        self.damping = check_positive("damping", damping, unit="m/rad")
        # Joint profiles, one per joint.
        if profile is not None and not isinstance(profile, (LinearBuffer, ThreeZoneBraking)):
            raise InvalidParameter(
                f"profile: expected None, a LinearBuffer or a ThreeZoneBraking, got "
                f"{describe(profile)}"
            )
        acc = limits.max_acceleration
        profs: list[Profile] = []
        for j in range(n):
            v = float(limits.max_velocity[j])
            if profile is not None:
                profs.append(profile)
            elif acc is not None and math.isfinite(acc[j]):
                a = float(acc[j])
                profs.append(ThreeZoneBraking(gain=2.0 * a / v, max_speed=v, max_acceleration=a))
            else:
                profs.append(
                    LinearBuffer(buffer=jb, spring_gain=self.spring_gain, max_recovery_speed=v)
                )
        self._joint_prof = tuple(profs)
        self._has_accel = acc is not None and self.dt is not None and bool(np.isfinite(acc).any())
        self._previous: FloatArray | None = None
        # Workspace limits.
        ws: Any = (workspace,) if isinstance(workspace, WorkspaceLimit) else workspace
        if isinstance(ws, (str, bytes)) or not isinstance(ws, Sequence):
            raise InvalidParameter(
                f"workspace: expected a WorkspaceLimit or a sequence of them, got "
                f"{describe(workspace)}"
            )
        q0 = np.zeros(n)
        for w in ws:
            if not isinstance(w, WorkspaceLimit):
                raise InvalidParameter(
                    f"workspace: expected WorkspaceLimit entries, got {describe(w)}"
                )
            if w.point not in robot.points:
                raise InvalidParameter(
                    f"workspace: point {w.point!r} is not one of the robot's points "
                    f"{list(robot.points)}"
                )
            dim = np.asarray(robot.fk(q0, w.point)).shape[0]
            if w.polytope.dim != dim:
                raise InvalidParameter(
                    f"workspace: the polytope on {w.point!r} is {w.polytope.dim}-D, the robot's "
                    f"task space is {dim}-D"
                )
        self._workspace: tuple[WorkspaceLimit, ...] = tuple(ws)
        self.task_dim = int(np.asarray(robot.fk(q0, "tcp")).shape[0])
        obs: Any = obstacles
        if isinstance(obs, (str, bytes)) or not isinstance(obs, Sequence):
            raise InvalidParameter(
                f"obstacles: expected a sequence of SphereObstacle, got {describe(obstacles)}"
            )
        for o in obs:
            if not isinstance(o, SphereObstacle):
                raise InvalidParameter(
                    f"obstacles: expected SphereObstacle entries, got {describe(o)}"
                )
        if obstacles:
            for attr in ("link_segments", "link_radius", "point_jacobian", "joint_positions"):
                if not hasattr(robot, attr):
                    raise InvalidParameter(
                        f"obstacles: the robot {type(robot).__name__} has no capsule geometry "
                        f"({attr!r}); use a DHChain or PlanarArm (Puma560.chain)"
                    )
        self._obstacles: tuple[SphereObstacle, ...] = tuple(obstacles)
        # DHChain / PlanarArm: the pose's geometry computed once per cycle (their private
        # _kinematics_cache and *_cached methods, q validated here); any other robot is asked
        # through the public protocol methods.
        self._cached = type(robot).__module__ == "velfence.mechanisms.chain" and all(
            hasattr(robot, a)
            for a in (
                "_kinematics_cache",
                "_fk_cached",
                "_jacobian_cached",
                "_segments_cached",
                "_jacobian_at",
            )
        )
        self.accelerate = check_flag("accelerate", accelerate)
        self._core, self.backend = pick_backend(backend)
        self._solver: Any = None
        self._kern: _BoundKernels = _PLAIN_BOUNDS
        if self._core is not None:
            self._kern = (None, self._core)
        elif self.accelerate:
            from velfence.shaping._accel import compiled_bounds, compiled_project

            self._solver = compiled_project()
            self._kern = compiled_bounds() or _PLAIN_BOUNDS
        self._joint_rows = self._joint_layout()
        self._dpos = (
            np.tile([1.0, -1.0], n),
            np.stack(
                [-np.asarray(limits.lower, float), np.asarray(limits.upper, float)], 1
            ).ravel(),
        )
        self._vsum = float(np.sum(limits.max_velocity))  # Σ_j v_j [rad/s]
        # Obstacles' fixed parts: centres (k, 3), radii (k,), the links' capsule radii, profile,
        # (centre, radius) as floats.
        self._obstacle_geometry: tuple[Any, ...] = ()
        if self._obstacles:
            capsules: Any = robot
            self._obstacle_geometry = (
                np.array([o.center for o in self._obstacles], dtype=float),
                np.array([o.radius for o in self._obstacles], dtype=float),
                np.array(capsules.link_radius, dtype=float).reshape(-1),
                LinearBuffer(buffer=self.obstacle_buffer, spring_gain=self.spring_gain),
                tuple((tuple(o.center.tolist()), o.radius) for o in self._obstacles),
            )
        # The compiled obstacle rows (a serial chain with the core): the fixed parts once.
        self._caps: Any = None
        if self._obstacles and self._cached and self._core is not None:
            kin0: Any = self._kinematics(q0)
            nl = int(kin0[0].shape[0]) - 1
            nj = int(kin0[1].shape[0])
            geo: Any = self._obstacle_geometry
            centres, srad, radii, oprof, _ = geo
            okind, oprm = oprof.kernel_profile
            lrad = np.broadcast_to(radii, (nl,)) if radii.shape[0] == 1 else radii[:nl]
            self._caps = self._core.CapsuleRows(
                np.ascontiguousarray(lrad, dtype=np.float64),
                np.ascontiguousarray(centres, dtype=np.float64).ravel(),
                np.ascontiguousarray(srad, dtype=np.float64),
                np.ascontiguousarray(limits.max_velocity[:nj], dtype=np.float64),
                nl, nj, n, len(self._obstacles), self.obstacle_buffer, self.dt or 0.0,
                okind, list(oprm),
            )  # fmt: skip
        self._rate_rows = self._rate_layout()
        self._ws_prof: tuple[Profile, ...] = tuple(
            w.profile if w.profile is not None else LinearBuffer(buffer=w.buffer)
            for w in self._workspace
        )
        self._ws_names = tuple(
            [
                f"{f'workspace {w_i}: ' if len(self._workspace) > 1 else ''}"
                f"{'TCP' if w.point == 'tcp' else w.point} face {name}"
                for name in w.polytope.facet_names
            ]
            for w_i, w in enumerate(self._workspace)
        )
        # A DH chain with the core: every row of a joint-mode cycle in one C call.
        self._fused: Any = None
        if self._core is not None and self._cached and hasattr(robot, "_dh_rows"):
            self._fused = self._fused_rows_object(robot)
        # Metric of the joint mode: W = L Lᵀ.
        self._metric: _Metric = None
        if weights is not None:
            Wa = real_array("weights", weights, error=InvalidParameter, what="weights")
            if Wa.shape == (n,):
                if not np.all(Wa > 0.0):
                    raise InvalidParameter(f"weights: expected weights > 0, got {Wa.tolist()}")
                self._metric = readonly(np.sqrt(Wa))
            elif Wa.shape == (n, n):
                if not np.allclose(Wa, Wa.T, rtol=1e-12, atol=0.0):
                    asym = float(np.max(np.abs(Wa - Wa.T)))
                    raise InvalidParameter(
                        f"weights: expected a symmetric ({n}, {n}) matrix, got one whose largest "
                        f"|W - Wᵀ| entry is {asym:g}"
                    )
                self._metric = readonly(_cholesky("weights", Wa))
            else:
                raise InvalidParameter(
                    f"weights: expected shape ({n},) or ({n}, {n}), got shape {Wa.shape}"
                )

    # ------------------------------------------------------------------ state
    @property
    def workspace(self) -> tuple[WorkspaceLimit, ...]:
        """The workspace limits."""
        return self._workspace

    @property
    def obstacles(self) -> tuple[SphereObstacle, ...]:
        """The obstacles."""
        return self._obstacles

    @property
    def stateful(self) -> bool:
        """True when acceleration rows apply and the filter remembers its last output."""
        return self._has_accel

    def reset(self) -> None:
        """Forget the remembered last output (the next cycle has no acceleration rows)."""
        self._previous = None

    # ------------------------------------------------------------------ rows
    def _fused_rows_object(self, robot: Any) -> Any:
        """The compiled rows (``velfence_core._nd.FilterRows``) of this filter on a DH chain."""
        n = self.dof
        lim = self.limits
        jkind: list[int] = []
        jprm: list[float] = []
        for j in range(n):
            kind, params = self._joint_prof[j].kernel_profile
            jkind.append(int(kind))
            jprm.extend(float(v) for v in params)
        ws = []
        for w_i, w in enumerate(self._workspace):
            kind, params = self._ws_prof[w_i].kernel_profile
            poly = w.polytope
            ws.append(
                (
                    np.ascontiguousarray(poly.normals, dtype=np.float64).ravel(),
                    np.ascontiguousarray(poly.offsets, dtype=np.float64),
                    int(robot._point_index(w.point)),
                    int(kind),
                    [float(v) for v in params],
                )
            )
        acc = lim.max_acceleration
        return self._core.FilterRows(
            [v for row in robot._dh_rows for v in row], list(robot._tool_xyz),
            np.asarray(lim.lower, dtype=np.float64), np.asarray(lim.upper, dtype=np.float64),
            np.asarray(lim.max_velocity, dtype=np.float64),
            None if acc is None else np.asarray(acc, dtype=np.float64), jkind, jprm, ws,
            self._caps,
        )  # fmt: skip

    def _rows_fused(self, q: FloatArray, u: FloatArray, previous: FloatArray | None) -> _Rows:
        """:meth:`_rows` of a joint-mode cycle on a DH chain, built by the compiled core.

        The same rows in the same order (joint, acceleration, workspace, obstacle); the
        workspace rows' sums in C rather than numpy's matrix products (agree to round-off).
        """
        prev = previous if self._has_accel else None
        G, b, level, ta, tb, dist = self._fused.rows(q, u, prev, self.dt or 0.0)
        rows = _Rows()
        rows.G, rows.b, rows.level = G, b, level
        rows.violated = dist < 0.0
        rows.m = int(b.shape[0])
        if self.dt is not None:
            lv = level.tolist()
            a = ta.tolist()
            t = tb.tolist()
            dl = dist.tolist()
            rows.check = [
                (r, "ws" if lv[r] == LEVEL_WORKSPACE else "ob", (a[r], t[r]))
                for r in range(rows.m)
                if (lv[r] == LEVEL_WORKSPACE or lv[r] == LEVEL_OBSTACLE) and dl[r] >= 0.0
            ]
        rows._namer = lambda: self._fused_names(level, ta, tb)
        return rows

    def _fused_names(self, level: Any, ta: Any, tb: Any) -> list[str]:
        names4 = self._joint_rows[1]
        names_r = self._rate_rows[1]
        rate_index = {j: i for i, j in enumerate(self._rate_rows[2].tolist())}
        out: list[str] = []
        for lv, a, t in zip(level.tolist(), ta.tolist(), tb.tolist(), strict=True):
            if lv == LEVEL_JOINT:
                out.append(names4[a])
            elif lv == LEVEL_RATE:
                out.append(names_r[2 * rate_index[a] + t])
            elif lv == LEVEL_WORKSPACE:
                out.append(self._ws_names[a][t])
            else:
                out.append(f"obstacle {a} on link {t}")
        return out

    def _joint_layout(self) -> tuple[Any, ...]:
        """The joint rows' fixed parts, in row order (per joint: position lower, upper, velocity).

        ``(G (4n, n), names, finite position sides (2n,), groups, vmax (2n,), position rows
        (2n,), bounds (4n,) with the velocity rows' filled in)``; per joint the rows are
        position lower, upper, velocity lower, upper; ``groups`` are ``(profile, speed,
        sides)`` sharing one bound call.
        """
        n = self.dof
        lim = self.limits
        eye = np.eye(n)
        G = np.zeros((4 * n, n))
        names: list[str] = []
        for j in range(n):
            G[4 * j : 4 * j + 4] = (eye[j], -eye[j], eye[j], -eye[j])
            names += [
                f"joint {j} position (lower)", f"joint {j} position (upper)",
                f"joint {j} velocity (lower)", f"joint {j} velocity (upper)",
            ]  # fmt: skip
        finite = np.isfinite(np.stack([lim.lower, lim.upper], axis=1).ravel())
        groups: dict[tuple[Any, ...], tuple[Profile, float, list[int]]] = {}
        for side in np.flatnonzero(finite).tolist():
            j = side // 2
            prof = self._joint_prof[j]
            v = float(lim.max_velocity[j])
            key = (*prof.kernel_profile, v)
            groups.setdefault(key, (prof, v, []))[2].append(side)
        grp = tuple((p, v, np.array(sides, dtype=np.int64)) for p, v, sides in groups.values())
        vmax = np.repeat(np.asarray(lim.max_velocity, dtype=float), 2)
        pos = (4 * np.arange(n)[:, None] + np.arange(2)[None, :]).ravel()  # position rows
        b = np.zeros(4 * n)
        b[2::4] = -vmax[0::2]
        b[3::4] = -vmax[0::2]
        return readonly(G), tuple(names), finite, grp, vmax, pos, b

    def _rate_layout(self) -> tuple[FloatArray, tuple[str, ...], Any, FloatArray]:
        """The acceleration rows' fixed parts: ``(G, names, joints, a (per joint))``."""
        n = self.dof
        acc = self.limits.max_acceleration
        joints = np.zeros(0, dtype=np.int64) if acc is None else np.flatnonzero(np.isfinite(acc))
        eye = np.eye(n)
        G = np.zeros((2 * joints.shape[0], n))
        G[0::2] = eye[joints]
        G[1::2] = -eye[joints]
        names = tuple(
            f"joint {j} acceleration ({side})"
            for j in joints.tolist()
            for side in ("lower", "upper")
        )
        step = np.zeros(0) if acc is None else np.asarray(acc, dtype=float)[joints]
        return readonly(G), names, joints, step

    def _kinematics(self, q: FloatArray) -> Any:
        """The pose's geometry for the cached fast path (None for other robots)."""
        if not self._cached:
            return None
        robot: Any = self.robot
        return robot._kinematics_cache(q)

    def _fk(self, q: FloatArray, kin: Any, point: str) -> FloatArray:
        if kin is None:
            return np.asarray(self.robot.fk(q, point), dtype=float)
        robot: Any = self.robot
        p: FloatArray = robot._fk_cached(kin, point)
        return p

    def _jac(self, q: FloatArray, kin: Any, point: str) -> FloatArray:
        if kin is None:
            return np.asarray(self.robot.jacobian(q, point), dtype=float)
        robot: Any = self.robot
        J: FloatArray = robot._jacobian_cached(kin, point)
        return J

    def _rows(
        self,
        q: FloatArray,
        u: FloatArray,
        previous: FloatArray | None,
        kin: Any = None,
        known: tuple[str, FloatArray] | None = None,
    ) -> _Rows:
        n = self.dof
        idt = 0.0 if self.dt is None else 1.0 / self.dt
        rows = _Rows()
        # Joint position and velocity rows (the fixed layout, bounds per profile group).
        G4, names4, finite, groups, vside, pos, b4 = self._joint_rows
        # per joint: q − lower, upper − q (as q·(±1) + (−lower | upper): the same bits)
        sgn, lohi = self._dpos
        dpos = np.repeat(q, 2) * sgn + lohi
        if len(groups) == 1 and groups[0][2].shape[0] == 2 * n:
            bpos = _bounds(groups[0][0], dpos, groups[0][1], idt, self._kern)
        else:
            bpos = np.full(2 * n, -math.inf)
            for prof, v, sides in groups:
                bpos[sides] = _bounds(prof, dpos[sides], v, idt, self._kern)
        keep_pos = finite & (bpos != -math.inf)  # beyond the profile's reach: no bound
        b = b4.copy()
        b[pos] = np.minimum(bpos, vside)  # a recovery no faster than the joint can move
        viol = np.zeros(4 * n, dtype=bool)
        viol[pos] = dpos < 0.0
        if keep_pos.all():
            rows.block(G4, b, LEVEL_JOINT, viol, names4)
        else:
            keep = np.ones(4 * n, dtype=bool)
            keep[pos] = keep_pos
            rows.block(
                G4[keep], b[keep], LEVEL_JOINT, viol[keep],
                [nm for nm, k in zip(names4, keep.tolist(), strict=True) if k],
            )  # fmt: skip
        if self._has_accel and previous is not None and self.dt is not None:
            Gr, names_r, joints, acc = self._rate_rows
            if joints.shape[0]:
                step = acc * self.dt
                pj = previous[joints]
                br = np.empty(2 * joints.shape[0])
                br[0::2] = pj - step
                br[1::2] = -(pj + step)
                rows.block(Gr, br, LEVEL_RATE, np.zeros(br.shape[0], dtype=bool), list(names_r))
        for w_i, w in enumerate(self._workspace):
            p = self._fk(q, kin, w.point)
            # (twist mode: the commanded point's Jacobian of this cycle, already computed)
            J = (
                known[1]
                if known is not None and known[0] == w.point
                else self._jac(q, kin, w.point)
            )
            poly = w.polytope
            dist = poly.normals @ p - poly.offsets
            ju = J @ u
            s = math.sqrt(float(ju @ ju))
            bnd = _bounds(self._ws_prof[w_i], dist, s, idt, self._kern)
            kept = np.flatnonzero(bnd != -math.inf)
            names = self._ws_names[w_i]
            first = rows.block(
                (poly.normals @ J)[kept], bnd[kept], LEVEL_WORKSPACE, dist[kept] < 0.0,
                [names[i] for i in kept.tolist()],
            )  # fmt: skip
            if idt > 0.0:
                for r, i in enumerate(kept.tolist()):
                    if dist[i] >= 0.0:
                        rows.check.append((first + r, "ws", (w_i, i)))
        if self._obstacles:
            self._obstacle_rows(q, u, idt, rows, kin)
        return rows.done(n)

    def _obstacle_rows(
        self, q: FloatArray, u: FloatArray, idt: float, rows: _Rows, kin: Any = None
    ) -> None:
        if kin is not None and self._caps is not None:
            G, b, d, oi, lk = self._caps.rows(kin[0], kin[1], np.ascontiguousarray(u), idt)
            if d.shape[0]:
                first = rows.block(
                    G, b, LEVEL_OBSTACLE, d < 0.0,
                    [f"obstacle {i} on link {k}" for i, k in zip(oi, lk, strict=True)],
                )  # fmt: skip
                if idt > 0.0:
                    dl = d.tolist()
                    rows.check.extend(
                        (first + r, "ob", (oi[r], lk[r])) for r in range(len(dl)) if dl[r] >= 0.0
                    )
            return
        if kin is not None:
            self._obstacle_rows_chain(u, idt, rows, kin)
            return
        self._obstacle_rows_generic(q, u, idt, rows)

    def _obstacle_rows_chain(self, u: FloatArray, idt: float, rows: _Rows, kin: Any) -> None:
        r"""The obstacle rows of a serial chain from its one kinematics pass, in numpy at once.

        Every (obstacle, link) pair's closest point, clearance and normal as (k, links) arrays
        (the arithmetic of :func:`velfence.geometry.primitives.sphere_capsule_distance`), then
        the rows of the pairs within reach: the normal's Jacobian row
        :math:`n\cdot(z_j \times (x_c - P_j))` for the joints moving the link, and the bound
        from the exact law's definition at the speed :math:`\|J_c u\|` of the critical point.
        """
        from velfence.geometry.primitives import _fallback_normal

        centres, srad, radii, prof, _ = self._obstacle_geometry
        P, axes = kin[0], kin[1]
        nl = P.shape[0] - 1
        A = P[:-1]
        B = P[1:]
        D = B - A
        dd = (D * D).sum(axis=1)
        W = centres[:, None, :] - A[None, :, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip((W * D[None, :, :]).sum(axis=2) / dd[None, :], 0.0, 1.0)
        t[:, dd == 0.0] = 0.0
        # a + t (b - a), exact at both ends (as _lerp)
        tt = t[:, :, None]
        X = np.where(tt <= 0.5, A[None] + tt * D[None], B[None] - (1.0 - tt) * D[None])
        R = X - centres[:, None, :]
        dist = np.sqrt((R * R).sum(axis=2))
        clear = dist - srad[:, None] - radii[None, :nl]
        buf = self.obstacle_buffer
        near = clear < buf
        reach: Any = None
        beyond = ~near
        if beyond.any() and self.dt is not None and idt > 0.0:
            far = float(clear[beyond].min())
            # Σ_j v_j |p − P_j| <= Σ_j v_j · 2 max_a |P_a − P_0| (triangle inequality): when
            # every pair beyond the buffer is farther than that (with margin), none is in reach.
            bound = 2.0 * float(np.linalg.norm(P - P[0], axis=1).max()) * self._vsum
            if not far > 1.5 * self.dt * bound * (1.0 + 1e-9):
                # |ṗ| <= Σ_{j <= k} v_j max(|a_k − P_j|, |b_k − P_j|) for every point of link k
                M = np.linalg.norm(P[:, None, :] - P[None, :nl], axis=2)
                lever = np.maximum(M[:-1], M[1:])
                reach = 1.5 * self.dt * (np.tril(lever) @ self.limits.max_velocity[:nl])
                near = near | (clear <= reach[None, :])
        obs_i, link = np.nonzero(near)
        if obs_i.shape[0] == 0:
            return
        d_sel = clear[obs_i, link]
        x_sel = X[obs_i, link]
        r_sel = R[obs_i, link]
        n_sel = dist[obs_i, link]
        with np.errstate(divide="ignore", invalid="ignore"):
            nrm = r_sel / n_sel[:, None]
        zero = np.flatnonzero(n_sel == 0.0)
        for z in zero.tolist():
            ln = int(link[z])
            nrm[z] = _fallback_normal(tuple(A[ln].tolist()), tuple(B[ln].tolist()))
        # Jacobian of each critical point: columns z_j × (x_c − P_j) for the joints j <= link.
        nj = axes.shape[0]
        Dp = x_sel[:, None, :] - P[None, :nj, :]
        ax = axes[None, :, :]
        cx = ax[..., 1] * Dp[..., 2] - ax[..., 2] * Dp[..., 1]
        cy = ax[..., 2] * Dp[..., 0] - ax[..., 0] * Dp[..., 2]
        cz = ax[..., 0] * Dp[..., 1] - ax[..., 1] * Dp[..., 0]
        moving = np.arange(nj)[None, :] <= link[:, None]
        cx = np.where(moving, cx, 0.0)
        cy = np.where(moving, cy, 0.0)
        cz = np.where(moving, cz, 0.0)
        if nj < self.dof:
            pad = ((0, 0), (0, self.dof - nj))
            cx, cy, cz = np.pad(cx, pad), np.pad(cy, pad), np.pad(cz, pad)
        G = nrm[:, 0:1] * cx + nrm[:, 1:2] * cy + nrm[:, 2:3] * cz
        speed = np.sqrt((cx @ u) ** 2 + (cy @ u) ** 2 + (cz @ u) ** 2).tolist()
        ds = d_sel.tolist()
        bs = [_bound1(prof, ds[r], speed[r], idt) for r in range(len(ds))]
        keep = [r for r in range(len(ds)) if bs[r] != -math.inf]
        if not keep:
            return
        oi = obs_i.tolist()
        lk = link.tolist()
        if len(keep) < len(ds):
            G = G[keep]
        first = rows.block(
            G, np.array([bs[r] for r in keep]), LEVEL_OBSTACLE,
            np.array([ds[r] < 0.0 for r in keep]),
            [f"obstacle {oi[r]} on link {lk[r]}" for r in keep],
        )  # fmt: skip
        if idt > 0.0:
            rows.check.extend(
                (first + c, "ob", (oi[r], lk[r])) for c, r in enumerate(keep) if ds[r] >= 0.0
            )

    def _obstacle_rows_generic(self, q: FloatArray, u: FloatArray, idt: float, rows: _Rows) -> None:
        """The obstacle rows through the robot's public capsule protocol (any robot)."""
        from velfence.geometry.primitives import _sphere_capsule

        robot: Any = self.robot
        segs = np.asarray(robot.link_segments(q), dtype=float)
        P = np.asarray(robot.joint_positions(q), dtype=float)
        S = segs.tolist()
        _, _, radii, prof, spheres = self._obstacle_geometry
        rl = radii.tolist()
        nl = len(S)
        # Every (obstacle, link) pair's clearance, critical point and normal, in plain floats.
        pairs = [
            _sphere_capsule(c, rs, (a[0], a[1], a[2]), (e[0], e[1], e[2]), rl[k])
            for c, rs in spheres
            for k, (a, e) in enumerate(S)
        ]
        buf = self.obstacle_buffer
        reach: Any = None
        far = [p[0] for p in pairs if p[0] >= buf]
        if idt > 0.0 and self.dt is not None and far:
            # |ṗ| <= Σ_j v_j |p − P_j| for every point of link k (j <= k): beyond one period's
            # reach at full joint speed (with margin), no bound needed. Per link (all at once):
            # Σ_{j <= k} v_j max(|a_k − P_j|, |b_k − P_j|).
            D = segs[:, :, None, :] - P[None, None, :nl]
            lever = np.linalg.norm(D, axis=3).max(axis=1)
            reach = (1.5 * self.dt * (np.tril(lever) @ self.limits.max_velocity[:nl])).tolist()
        G: list[FloatArray] = []
        bs: list[float] = []
        viol: list[bool] = []
        names: list[str] = []
        checks: list[tuple[int, tuple[int, int]]] = []
        for ip, (d, _x_c, t, nrm) in enumerate(pairs):
            if d >= buf and (reach is None or d > reach[ip % nl]):
                continue  # beyond the buffer: no cap; in discrete time also out of reach
            i, link = divmod(ip, nl)
            Jc = np.asarray(robot.point_jacobian(q, link, t), dtype=float)
            s = float(np.linalg.norm(Jc @ u))
            b = _bound1(prof, d, s, idt)
            if b == -math.inf:
                continue
            if idt > 0.0 and d >= 0.0:
                checks.append((len(bs), (i, link)))
            G.append(np.array(nrm) @ Jc)
            bs.append(b)
            viol.append(d < 0.0)
            names.append(f"obstacle {i} on link {link}")
        if not bs:
            return
        first = rows.block(np.array(G), np.array(bs), LEVEL_OBSTACLE, np.array(viol), names)
        rows.check.extend((first + r, "ob", key) for r, key in checks)

    # ------------------------------------------------------------------ solve
    def _solve(self, u: FloatArray, G: FloatArray, b: FloatArray) -> tuple[bool, FloatArray]:
        """The projection by the backend in use: ``(feasible, x)``."""
        if self._core is not None:
            return _projection_c(self._core, u, G, b)
        return _projection(u, G, b, self._solver)

    def _project(
        self, u: FloatArray, G: FloatArray, b: FloatArray, L: _Metric
    ) -> tuple[bool, FloatArray]:
        if G.shape[0] == 0 or bool(np.all(G @ u >= b)):
            # Nothing violated (as evaluated): the optimum is the command itself, exactly (the
            # metric's round trip L⁻ᵀ Lᵀ u would move it by round-off).
            return True, u.copy()
        if L is None:
            return self._solve(u, G, b)
        if L.ndim == 1:  # diagonal metric: L = diag(lv), y = lv * x
            ok, y = self._solve(u * L, G / L[None, :], b)
            x: FloatArray = y / L
        else:  # y = Lᵀ x: G x = G L⁻ᵀ y
            GL = np.asarray(np.linalg.solve(L, G.T).T, dtype=np.float64)
            ok, y = self._solve(L.T @ u, GL, b)
            x = np.asarray(np.linalg.solve(L.T, y), dtype=np.float64)
        if ok:
            # Round-off of the back-substitution: repair along the violated rows (a few ulps).
            for _ in range(4):
                gap = b - G @ x
                k = int(np.argmax(gap))
                if not gap[k] > 0.0:
                    break
                gk = G[k]
                x = x + (gap[k] * (1.0 + 1e-12) + 1e-300) * gk / float(gk @ gk)
        return ok, x

    def _next_distances(self, q: FloatArray, x: FloatArray, rows: _Rows) -> dict[int, float]:
        """True next distance of every checked row at ``q + x dt`` (model check)."""
        from velfence.geometry.primitives import _sphere_capsule

        q1 = q + x * (self.dt or 0.0)
        # (the compiled chain's kinematics: the same operations as the Python pass)
        kin = self._fused.kinematics(q1) if self._fused is not None else self._kinematics(q1)
        out: dict[int, float] = {}
        dists: dict[int, list[float]] = {}
        segs: Any = None
        rl: list[float] = []
        clear: Any = None
        for r, kind, (a, i) in rows.check:
            if kind == "ws":
                if a not in dists:
                    poly = self._workspace[a].polytope
                    p1 = self._fk(q1, kin, self._workspace[a].point)
                    dists[a] = (poly.normals @ p1 - poly.offsets).tolist()
                out[r] = dists[a][i]
            elif kin is not None and self._caps is not None:
                if clear is None:  # every pair at once, in C
                    clear = self._caps.clearances(kin[0])
                out[r] = clear[a * (kin[0].shape[0] - 1) + i]
            else:
                if segs is None:
                    robot: Any = self.robot
                    if kin is None:
                        segs = np.asarray(robot.link_segments(q1), dtype=float).tolist()
                    else:
                        pts = kin[0].tolist()
                        segs = [(pts[k], pts[k + 1]) for k in range(len(pts) - 1)]
                    rl = self._obstacle_geometry[2].tolist()
                c, rs = self._obstacle_geometry[4][a]
                sa, sb = segs[i]
                out[r] = _sphere_capsule(c, rs, tuple(sa), tuple(sb), rl[i])[0]
        return out

    @staticmethod
    def _steps(rows: _Rows) -> Any:
        """The ladder's steps, made as they are needed: (keep mask, bounds, dropped, stage)."""
        # first: every row as built (mask None: no copy of G)
        yield None, rows.b.copy(), None, None
        m = rows.m
        level = rows.level
        viol = rows.violated
        present = set(level.tolist())
        keep = np.ones(m, dtype=bool)
        b = rows.b.copy()
        if LEVEL_RATE in present:
            keep &= level != LEVEL_RATE
            yield keep.copy(), b.copy(), "acceleration", "dropped acceleration"
        for lv in (LEVEL_OBSTACLE, LEVEL_WORKSPACE):
            if lv not in present:
                continue
            rec = (level == lv) & viol
            if rec.any():
                # A slower recovery first (a quarter, a sixteenth, ...), "no further out" last.
                for frac in _RECOVERY_FRACTIONS:
                    bf = np.where(rec & (b > 0.0), b * frac, np.minimum(b, 0.0) if frac == 0 else b)
                    yield keep.copy(), bf, LEVEL_NAMES[lv], f"relaxed {LEVEL_NAMES[lv]}"
                b = np.where(rec, np.minimum(b, 0.0), b)
            keep &= level != lv
            yield keep.copy(), b.copy(), LEVEL_NAMES[lv], f"dropped {LEVEL_NAMES[lv]}"
        rec = (level == LEVEL_JOINT) & viol
        if rec.any():
            for frac in _RECOVERY_FRACTIONS:
                bf = np.where(rec & (b > 0.0), b * frac, np.minimum(b, 0.0) if frac == 0 else b)
                yield keep.copy(), bf, "joint limits", "relaxed joint limits"

    def _solve_ladder(
        self, q: FloatArray, u: FloatArray, rows: _Rows, L: _Metric
    ) -> tuple[FloatArray, FloatArray, list[str], list[str], bool]:
        """The priority ladder; returns (x, b used, dropped levels, stages, rate_override)."""
        n = self.dof
        G = rows.G
        b = rows.b.copy()
        dropped: list[str] = []
        stages: list[str] = []
        for mask, bb, drop, stage in self._steps(rows):
            if drop is not None and drop not in dropped:
                dropped.append(drop)
            if stage is not None:
                stages.append(stage)
            if mask is None:
                ok, x = self._project(u, G, bb, L)
            else:
                bb = bb.copy()
                ok, x = self._project(u, G[mask], bb[mask], L)
            if ok and rows.check:
                if mask is None:
                    mask = np.ones(rows.m, dtype=bool)
                ok, x, tightened = self._model_check(q, u, G, bb, mask, rows, x, L)
                if tightened:
                    stages.append("model-check")
            if ok and _finite(x):
                return x, bb, dropped, stages, "acceleration" in dropped
            b = bb
        stages.append("stop")
        return np.zeros(n), b, dropped, stages, "acceleration" in dropped

    def _model_check(
        self,
        q: FloatArray,
        u: FloatArray,
        G: FloatArray,
        bb: FloatArray,
        mask: Any,
        rows: _Rows,
        x: FloatArray,
        L: _Metric,
    ) -> tuple[bool, FloatArray, bool]:
        """Discrete time: tighten rows whose constraint the next position would cross."""
        dt = self.dt or 0.0
        tightened = False
        for _ in range(_CORRECTION_ROUNDS):
            nxt = self._next_distances(q, x, rows)
            bad = [(r, d) for r, d in nxt.items() if mask[r] and d < 0.0]
            if not bad:
                return True, x, tightened
            for r, d in bad:
                bb[r] += (-d) / dt * (1.0 + 1e-6) + 1e-12
            tightened = True
            ok, x = self._project(u, G[mask], bb[mask], L)
            if not ok:
                return False, x, tightened
        nxt = self._next_distances(q, x, rows)
        return all(d >= 0.0 for r, d in nxt.items() if mask[r]), x, tightened

    # ------------------------------------------------------------------ public
    def _state(self, name: str, x: Any, width: int, unit: str) -> FloatArray:
        if type(x) is np.ndarray and x.dtype == np.float64 and x.shape == (width,):
            # What real_array returns for this input (non-finite values let through): a copy.
            return x.copy()
        return real_array(
            name, x, (width,), what=f"{width} numbers [{unit}]", allow_nonfinite=True,
            max_abs=None,
        )  # fmt: skip

    def _stopped(self, q: FloatArray, cmd: FloatArray) -> FilterResult:
        return FilterResult(
            output=np.zeros(self.dof), command=cmd, position=q, zone="invalid", active=(),
            active_names=(), slack=np.zeros(0), constraint_names=(), stages=("stop",),
            dropped=(), rate_override=False, rows=(np.zeros((0, self.dof)), np.zeros(0)),
        )  # fmt: skip

    def _bad(self, *arrays: FloatArray) -> bool:
        # On Python floats (cheaper than numpy for a few entries): a NaN or inf makes the sum's
        # s - s NaN; finite entries up to MAX_MAGNITUDE cannot overflow the sum of a state.
        for a in arrays:
            if a.size:
                vals = a.ravel().tolist()
                s = sum(vals)
                if not (s - s == 0.0 and max(map(abs, vals)) <= MAX_MAGNITUDE):
                    return True
        return False

    def _cycle(
        self,
        q: FloatArray,
        u: FloatArray,
        cmd: FloatArray,
        L: _Metric,
        previous: Any,
        remember: bool,
        kin: Any = None,
        known: tuple[str, FloatArray] | None = None,
    ) -> FilterResult | tuple[_Rows, FloatArray, FloatArray, list[str], list[str], bool, bool]:
        """One cycle's rows and solve, without the diagnostics.

        Returns ``(rows, x, u, dropped, stages, override, scaled)``, or the stop result (a
        :class:`FilterResult`) for bad input; remembers ``x`` when asked.
        """
        prev: FloatArray | None = None
        if previous is not None:
            prev = self._state("previous", previous, self.dof, "rad/s")
            if self._bad(prev):
                self._invalid(f"non-finite previous={prev.tolist()}")
                return self._stopped(q, cmd)
        elif remember:
            prev = self._previous
        scaled = False
        cap = _COMMAND_CAP * self._speed_scale
        # (u is finite here: validated, or the twist's solve checked)
        big = max(map(abs, u.tolist())) if u.size else 0.0
        if big > cap:
            # A command far beyond what the joints can do (1e3 times their fastest limit) is
            # shortened in its own direction first, so the solve stays well inside floating
            # point; its answer meets every row as the full command's would.
            u = u * (cap / big)
            scaled = True
        with np.errstate(all="ignore"):
            if self._fused is not None and kin is None and known is None:
                rows = self._rows_fused(q, u, prev)
            else:
                rows = self._rows(q, u, prev, self._kinematics(q) if kin is None else kin, known)
            x, _, dropped, stages, override = self._solve_ladder(q, u, rows, L)
        if not _finite(x):
            self._invalid("input too large: the filtered velocity overflowed")
            return self._stopped(q, cmd)
        if remember and self._has_accel:
            self._previous = readonly(x.copy())
        return rows, x, u, dropped, stages, override, scaled

    def _run(
        self,
        q: FloatArray,
        u: FloatArray,
        cmd: FloatArray,
        L: _Metric,
        previous: Any,
        remember: bool,
        kin: Any = None,
        known: tuple[str, FloatArray] | None = None,
    ) -> FilterResult:
        c = self._cycle(q, u, cmd, L, previous, remember, kin, known)
        if isinstance(c, FilterResult):
            return c
        rows, x, u, dropped, stages, override, scaled = c
        G = rows.G
        b0 = rows.b
        fin = np.isfinite(b0)
        if fin.all():
            slack = G @ x - b0
            tol = _BINDING * (1.0 + np.abs(b0))
        else:
            with np.errstate(invalid="ignore"):
                slack = np.where(fin, G @ x - b0, math.inf)
            tol = _BINDING * (1.0 + np.abs(np.where(fin, b0, 0.0)))
        viol = rows.violated
        act = tuple(np.flatnonzero((slack <= tol) | viol).tolist())
        n_out = int(np.count_nonzero(viol))
        zone: Zone = ZONE_NAMES[zone_code(n_out, len(act))]  # type: ignore[assignment]
        pre: list[str] = ["command-scaled"] if scaled else []
        if not np.array_equal(x, u):
            pre.append("projection")
        if n_out:
            pre.append("recovery")
        return FilterResult(
            output=x, command=cmd, position=q, zone=zone, active=act,
            active_names=tuple(rows.names[i] for i in act), slack=readonly(slack),
            constraint_names=tuple(rows.names), stages=tuple(pre + stages),
            dropped=tuple(dropped), rate_override=override,
            rows=(readonly(G), readonly(b0)),
        )  # fmt: skip

    def explain(
        self, q: ArrayLike, qd_cmd: ArrayLike, *, previous: ArrayLike | None = None
    ) -> FilterResult:
        """Filter a joint-velocity command, with diagnostics.

        Args:
            q: Joint position [rad], shape (dof,).
            qd_cmd: Commanded joint velocity [rad/s], shape (dof,).
            previous: The last output [rad/s], shape (dof,), for the acceleration rows; when
                ``None`` and acceleration rows apply (``dt`` and ``max_acceleration``) the
                filter uses the output it remembered from its last call (none after
                :meth:`reset`).

        Returns:
            A :class:`FilterResult`.

        Raises:
            InvalidInput: wrong shapes, or non-finite values with ``on_invalid="raise"``.
        """
        qa = self._state("q", q, self.dof, "rad")
        ua = self._state("qd_cmd", qd_cmd, self.dof, "rad/s")
        if self._bad(qa, ua):
            self._invalid(f"non-finite input: q={qa.tolist()}, qd_cmd={ua.tolist()}")
            return self._stopped(qa, ua)
        return self._run(qa, ua, ua, self._metric, previous, True)

    def filter(
        self, q: ArrayLike, qd_cmd: ArrayLike, *, previous: ArrayLike | None = None
    ) -> FloatArray:
        """The filtered joint velocity [rad/s], shape (dof,) (:meth:`explain`'s output).

        The same cycle as :meth:`explain` without the diagnostics (zone, slack, names).
        """
        qa = self._state("q", q, self.dof, "rad")
        ua = self._state("qd_cmd", qd_cmd, self.dof, "rad/s")
        if self._bad(qa, ua):
            self._invalid(f"non-finite input: q={qa.tolist()}, qd_cmd={ua.tolist()}")
            return np.zeros(self.dof)
        c = self._cycle(qa, ua, ua, self._metric, previous, True)
        return c.output if isinstance(c, FilterResult) else c[1]

    def explain_twist(
        self,
        q: ArrayLike,
        twist: ArrayLike,
        *,
        point: str = "tcp",
        previous: ArrayLike | None = None,
    ) -> FilterResult:
        r"""Filter a task-space command: damped least squares under the same rows.

        Minimises :math:`\tfrac12\|J x - v\|^2 + \tfrac12\lambda^2\|x\|^2` (``λ = damping``)
        subject to every row; ``J`` is the point's linear Jacobian (twist of shape
        (task_dim,)) or, for a spatial robot with ``angular_jacobian``, stacked with the angular
        one (twist (6,): linear [m/s] then angular [rad/s]).

        Args:
            q: Joint position [rad], shape (dof,).
            twist: Desired velocity of ``point``, shape (task_dim,) or (6,).
            point: The point the twist is for (a name of the robot's ``points``).
            previous: As in :meth:`explain`.

        Raises:
            InvalidInput: wrong shapes or an unknown point; non-finite values with
                ``on_invalid="raise"``.
        """
        qa = self._state("q", q, self.dof, "rad")
        va = real_array("twist", twist, (None,), allow_nonfinite=True, max_abs=None)
        sizes = (self.task_dim, 6) if hasattr(self.robot, "angular_jacobian") else (self.task_dim,)
        if self.task_dim != 3:
            sizes = (self.task_dim,)
        if va.shape[0] not in sizes:
            raise InvalidInput(
                f"twist: expected shape {' or '.join(f'({s},)' for s in sizes)}, got shape "
                f"{va.shape}"
            )
        if not isinstance(point, str) or point not in self.robot.points:
            raise InvalidInput(
                f"point: expected one of {list(self.robot.points)}, got {describe(point)}"
            )
        if self._bad(qa, va):
            self._invalid(f"non-finite input: q={qa.tolist()}, twist={va.tolist()}")
            return self._stopped(qa, va)
        kin = self._kinematics(qa)
        J: Any = self._jac(qa, kin, point)
        known = (point, J)
        if va.shape[0] == 6 and self.task_dim == 3:
            robot: Any = self.robot
            Ja = robot.angular_jacobian(qa) if kin is None else kin[1].T
            J = np.vstack((J, np.asarray(Ja, dtype=np.float64)))
        with np.errstate(all="ignore"):
            H = J.T @ J + (self.damping**2) * np.eye(self.dof)
            L = _factor(H)
            u: FloatArray = np.asarray(
                np.linalg.solve(L.T, np.linalg.solve(L, J.T @ va)), dtype=np.float64
            )
        if self._bad(u):
            self._invalid("input too large: the twist's joint velocity overflowed")
            return self._stopped(qa, va)
        return self._run(qa, u, va, L, previous, True, kin, known)

    def filter_twist(
        self,
        q: ArrayLike,
        twist: ArrayLike,
        *,
        point: str = "tcp",
        previous: ArrayLike | None = None,
    ) -> FloatArray:
        """The filtered joint velocity for a twist [rad/s], shape (dof,) (:meth:`explain_twist`)."""
        return self.explain_twist(q, twist, point=point, previous=previous).output

    def shape(self, q: ArrayLike, qd_cmd: ArrayLike) -> FloatArray:
        """Contract alias of :meth:`filter` (joint position, joint-velocity command)."""
        return self.filter(q, qd_cmd)

    def shape_batch(self, Q: ArrayLike, QD: ArrayLike) -> FloatArray:
        """:meth:`filter` on N independent states (no remembered output read or written).

        Args:
            Q: Joint positions [rad], shape (N, dof).
            QD: Commanded joint velocities [rad/s], shape (N, dof).

        Returns:
            Shape (N, dof).

        Raises:
            InvalidInput: wrong shapes, or non-finite rows with ``on_invalid="raise"``.
        """
        n = self.dof
        Qa = real_array("Q", Q, (None, n), allow_nonfinite=True, max_abs=None)
        Va = real_array("QD", QD, (None, n), allow_nonfinite=True, max_abs=None)
        if Qa.shape != Va.shape:
            raise InvalidInput(
                f"Q and QD: expected the same shape (N, {n}), got {Qa.shape} and {Va.shape}"
            )
        out = np.zeros((Qa.shape[0], n))
        for k in range(Qa.shape[0]):
            if self._bad(Qa[k], Va[k]):
                try:
                    self._invalid(f"non-finite input in row {k}")
                except InvalidInput as exc:
                    raise InvalidInput(f"Q, QD row {k}: {exc}") from None
                continue
            out[k] = self._run(Qa[k], Va[k], Va[k], self._metric, None, False).output
        return out
