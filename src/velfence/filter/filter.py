r"""The joint-space safety filter: one minimum-change problem per control cycle.

Every cycle the commanded joint velocity ``u`` (or the joint velocity a task-space twist asks
for) is replaced by the nearest joint velocity ``x`` that meets every safety row at once::

    minimise ½ (x - u)ᵀ W (x - u)                  joint mode (W = diag(weights), default I)
    or       ½ ‖J x - v‖² + ½ λ² ‖x‖²              twist mode (damped least squares, λ = damping)
    subject to  G x >= b                           (the rows of every provider)

Both objectives are ``½ (x - u)ᵀ H (x - u) + const`` (twist mode: ``H = JᵀJ + λ²I``,
``u = H⁻¹ Jᵀ v``); with ``H = L Lᵀ`` and ``y = Lᵀ x`` the problem is the Euclidean projection of
``Lᵀ u`` onto ``{y : G L⁻ᵀ y >= b}``, solved exactly by :mod:`velfence.geometry.projection`.

The rows come from row providers (:mod:`velfence.filter.rows`: joint position with its braking
profile, joint velocity, joint acceleration, a workspace polytope per :class:`WorkspaceLimit`,
sphere obstacles against capsule links, and the user's own), all from one kinematics frame per
cycle (:mod:`velfence.filter.kinematics`). When they have no common point the priority ladder
(:mod:`velfence.filter.ladder`) decides what gives way; with ``max_iterations`` or
``time_budget`` a cycle that runs out answers the ladder's safe fallback.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive,
    check_positive_int,
    describe,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter, VelfenceError
from velfence.filter.kinematics import Kinematics, checked, frame_of
from velfence.filter.ladder import DeadlineHit, run_ladder, safe_fallback
from velfence.filter.limits import JointLimits, Profile, SphereObstacle, WorkspaceLimit
from velfence.filter.result import FilterResult
from velfence.filter.rows import (
    LEVEL_NAMES,
    PLAIN_BOUNDS,
    BoundKernels,
    JointAccelerationLimit,
    JointPositionLimit,
    JointVelocityLimit,
    ObstacleRows,
    RowBlock,
    RowContext,
    RowProvider,
    WorkspaceRows,
)
from velfence.shaping._kernels import ZONE_NAMES, zone_code
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.polytope import PolytopeBackend, pick_backend
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

__all__ = ["SafetyFilter"]

_BINDING = 1e-9  # relative slack under which a row counts as active
_COMMAND_CAP = 1e3  # commands are shortened beyond this multiple of the fastest joint limit

# The metric's factor L (W = L Lᵀ): None (identity), a vector (diagonal) or a lower-triangular
# matrix.
_Metric = FloatArray | None


def _finite(x: FloatArray) -> bool:
    """Whether every entry of the vector ``x`` is finite (Python floats: cheaper than numpy)."""
    return all(map(math.isfinite, x.tolist()))


def _python_solve(
    u: FloatArray, G: FloatArray, b: FloatArray, cap: int, warm: Any
) -> tuple[int, FloatArray]:
    """:func:`velfence.geometry.projection.project_kernel_opts` on Python lists: ``(status, x)``."""
    from velfence.geometry import projection as pj

    m, n = G.shape
    x = [0.0] * n
    lam = [0.0] * (n + 1)
    act = [0] * (n + 1)
    wsf = [0.0] * pj.scratch_length(m, n)
    opts = getattr(pj, "project_kernel_opts", None)
    args = (u.tolist(), G.ravel().tolist(), b.tolist(), m, n, x, lam, act, wsf)
    if opts is not None:
        w = [] if warm is None else [int(i) for i in warm]
        status = opts(*args, cap, w, len(w))[0]
    else:  # the projection before the deadline options (no cap, no warm start)
        status = pj.project_kernel(*args)[0]
    return int(status), np.array(x, dtype=np.float64)


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


class _Cycle:
    """One cycle's stacked rows: ``G``, ``b``, levels, violated, keys, model-checked rows."""

    __slots__ = ("G", "b", "blocks", "checked", "d0", "level", "violated")

    def __init__(self, blocks: list[tuple[int, Any, RowBlock]], n: int) -> None:
        self.blocks = blocks
        if blocks:
            self.G = np.concatenate([blk.G for _, _, blk in blocks]).reshape(-1, n)
            self.b = np.concatenate([blk.b for _, _, blk in blocks]).astype(np.float64)
            self.level = np.concatenate(
                [np.full(blk.size, int(p.level), dtype=np.int64) for _, p, blk in blocks]
            )
            self.violated = np.concatenate(
                [np.asarray(blk.violated, dtype=bool) for _, _, blk in blocks]
            )
        else:
            self.G = np.zeros((0, n))
            self.b = np.zeros(0)
            self.level = np.zeros(0, dtype=np.int64)
            self.violated = np.zeros(0, dtype=bool)
        chk: list[Any] = []
        d0: list[Any] = []
        first = 0
        for _, p, blk in blocks:
            if blk.distance is not None and hasattr(p, "next_distances"):
                chk.append(np.arange(first, first + blk.size))
                d0.append(blk.distance)
            first += blk.size
        self.checked = np.concatenate(chk) if chk else np.zeros(0, dtype=np.int64)
        self.d0 = np.concatenate(d0) if d0 else np.zeros(0)

    def names(self) -> list[str]:
        out: list[str] = []
        for _, _, blk in self.blocks:
            names = blk.names() if callable(blk.names) else blk.names
            out.extend(str(s) for s in names)
        return out

    def keys(self, rows: Any) -> set[tuple[int, int]]:
        """``(provider index, key)`` of the given row indices."""
        out: set[tuple[int, int]] = set()
        want = set(rows)
        first = 0
        for pi, _, blk in self.blocks:
            k = blk.size
            for r in [r for r in range(first, first + k) if r in want]:
                out.add((pi, int(blk.keys[r - first])))
            first += k
        return out

    def rows_of(self, keys: set[tuple[int, int]]) -> list[int]:
        """Row indices of the given keys (those still present)."""
        out: list[int] = []
        first = 0
        for pi, _, blk in self.blocks:
            want = [k for p, k in keys if p == pi]
            if want:
                hit = np.flatnonzero(np.isin(np.asarray(blk.keys), want))
                out.extend((hit + first).tolist())
            first += blk.size
        return out


class SafetyFilter(InvalidPolicy):
    r"""Minimum-change joint velocity under joint, workspace, obstacle and rate limits.

    See :mod:`velfence.filter` and ``docs/safety_filter.md`` for the problem, the rows and the
    priority ladder.

    Args:
        robot: The kinematics (:class:`~velfence.filter.kinematics.Kinematics`: ``DHChain``,
            ``PlanarArm``, ``Puma560``, ``MujocoRobot``, or any object with that protocol).
        limits: The joint limits (:class:`JointLimits`, ``dof`` joints; names checked against
            ``robot.joint_names`` when given).
        workspace: Workspace limits (:class:`WorkspaceLimit`, one or a sequence).
        obstacles: Sphere obstacles (:class:`SphereObstacle`); need the robot's capsule
            geometry (``link_radius`` and the frame's ``segments``/``point_jacobian``).
        providers: Further row providers (:class:`~velfence.filter.rows.RowProvider`), each at
            its declared level of the ladder.
        dt: Control period [s] (``None``: continuous-time bounds). With ``dt`` every row also
            keeps one period's motion inside, the rows are checked on the model, and the
            acceleration rows apply.
        profile: One approach profile for every joint limit (radians); by default a
            three-zone braking profile for each joint with an acceleration limit
            (``ThreeZoneBraking(gain=2 a/v, max_speed=v, max_acceleration=a)``), else a linear
            buffer of width ``joint_buffer`` whose cap speed is the joint's ``max_velocity``.
        joint_buffer: Width of the default linear buffer at joint limits [rad], > 0.
        spring_gain: Recovery gain of the default joint buffers and the obstacles [1/s], >= 0.
        obstacle_buffer: Width of the obstacles' linear buffer [m], > 0.
        weights: Joint-mode metric ``W``: ``None`` (identity), per-joint weights (n,) > 0, or a
            symmetric positive definite (n, n) matrix.
        damping: :math:`\lambda` of the twist mode's damped least squares [m/rad], > 0.
        max_iterations: Iteration cap of every solve, an int >= 1; ``None`` (default): the
            projection's own cap ``4 (m + n) + 16``. A solve that hits it ends the cycle on the
            safe fallback (``deadline="iterations"``).
        time_budget: Time budget of one cycle [s], > 0; ``None`` (default): none. A cycle past
            it starts no further solve and answers the safe fallback (``deadline="time"``).
        accelerate: Deprecated and ignored (the numba filter solve is gone); a
            ``DeprecationWarning`` when given.
        on_invalid: ``"raise"`` or ``"stop"`` (zero velocity, zone ``"invalid"``).
        backend: Implementation of the solve and the bounds
            (:data:`~velfence.shaping.polytope.PolytopeBackend`): ``"auto"`` (default) the
            compiled C core when importable, else the Python reference; ``"python"``; ``"c"``
            requires the core. The same arithmetic bit for bit. A solve with ``max_iterations``
            or a warm start runs the Python kernel until the core exposes those options.

    Raises:
        InvalidParameter: a bad parameter, limits of the wrong size or names, a workspace point
            the robot does not have or whose dimension differs from its polytope's, obstacles
            on a robot without capsule geometry, a provider without ``level``/``rows``, or
            kinematics or chain data of the wrong shape.
    """

    __slots__ = (
        "_clock",
        "_core",
        "_has_accel",
        "_joint_prof",
        "_metric",
        "_n_builtin",
        "_obstacles",
        "_previous",
        "_providers",
        "_speed_scale",
        "_warm",
        "_workspace",
        "backend",
        "damping",
        "deadline_misses",
        "dof",
        "dt",
        "limits",
        "max_iterations",
        "obstacle_buffer",
        "robot",
        "spring_gain",
        "task_dim",
        "time_budget",
    )

    method = "safety-filter"

    def __init__(
        self,
        robot: Kinematics,
        *,
        limits: JointLimits,
        workspace: WorkspaceLimit | Sequence[WorkspaceLimit] = (),
        obstacles: Sequence[SphereObstacle] = (),
        providers: Sequence[RowProvider] = (),
        dt: float | None = None,
        profile: Profile | None = None,
        joint_buffer: float = 0.1,
        spring_gain: float = 1.0,
        obstacle_buffer: float = 0.05,
        weights: ArrayLike | None = None,
        damping: float = 1e-2,
        max_iterations: int | None = None,
        time_budget: float | None = None,
        accelerate: bool | None = None,
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
        if accelerate is not None:
            check_flag("accelerate", accelerate)
            warnings.warn(
                "SafetyFilter(accelerate=...) is deprecated and ignored: the numba filter solve "
                "is gone (backend= chooses the compiled core)",
                DeprecationWarning,
                stacklevel=2,
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
        self.max_iterations = (
            None
            if max_iterations is None
            else check_positive_int("max_iterations", max_iterations, example=50, maximum=2**31 - 1)
        )
        self.time_budget = (
            None if time_budget is None else check_positive("time_budget", time_budget, unit="s")
        )
        self.deadline_misses = 0
        self._clock: Callable[[], float] = time.perf_counter
        self._warm: set[tuple[int, int]] = set()
        self._core, self.backend = pick_backend(backend)
        kern: BoundKernels = PLAIN_BOUNDS if self._core is None else (None, self._core)
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
        q0 = np.zeros(n)
        frame0 = self._frame0(q0)
        self.task_dim = int(np.asarray(frame0.point("tcp")).shape[0])
        self._check_frame(frame0, q0)
        self._workspace = self._workspaces(workspace, frame0)
        self._obstacles = self._obstacle_list(obstacles)
        rows: list[Any] = [
            JointPositionLimit(limits, profs, kernels=kern),
            JointVelocityLimit(limits),
        ]
        if self._has_accel:
            rows.append(JointAccelerationLimit(limits))
        multi = len(self._workspace) > 1
        for w_i, w in enumerate(self._workspace):
            pre = f"workspace {w_i}: " if multi else ""
            rows.append(WorkspaceRows(w, dim=self.task_dim, prefix=pre, kernels=kern))
        if self._obstacles:
            rows.append(self._obstacle_rows(frame0))
        self._n_builtin = len(rows)
        rows.extend(self._custom(providers))
        self._providers: tuple[Any, ...] = tuple(rows)
        self._metric: _Metric = self._weights(weights)

    # ------------------------------------------------------------------ construction
    def _frame0(self, q0: FloatArray) -> Any:
        try:
            return frame_of(self.robot, q0)
        except VelfenceError as exc:
            raise InvalidParameter(f"robot: kinematics(q) at q = 0 failed: {exc}") from None

    def _check_frame(self, frame: Any, q0: FloatArray) -> None:
        """The robot's kinematics and chain data agree with ``dof`` (else InvalidParameter)."""
        n = self.dof
        dim = self.task_dim
        try:
            if dim not in (2, 3):
                raise InvalidInput(f"robot: kinematics(q).point('tcp') has {dim} coordinates")
            checked("kinematics(q).point('tcp')", frame.point("tcp"), (dim,))
            checked("kinematics(q).jacobian('tcp')", frame.jacobian("tcp"), (dim, n))
        except InvalidInput as exc:
            raise InvalidParameter(str(exc)) from None
        data = getattr(self.robot, "chain_data", None)
        cd = data() if callable(data) else None
        if cd is not None:
            dh = np.asarray(getattr(cd, "dh", None), dtype=object)
            tool = np.asarray(getattr(cd, "tool", None), dtype=object)
            ok = dh.shape == (n, 5) and tool.shape == (3,)
            if ok:
                ok = bool(
                    np.isfinite(dh.astype(float)).all() and np.isfinite(tool.astype(float)).all()
                )
            if not ok:
                raise InvalidParameter(
                    f"robot: inconsistent chain data: chain_data() expected dh of shape ({n}, 5) "
                    f"and tool of shape (3,), finite, got dh {dh.shape}, tool {tool.shape}"
                )

    def _workspaces(self, workspace: Any, frame0: Any) -> tuple[WorkspaceLimit, ...]:
        ws: Any = (workspace,) if isinstance(workspace, WorkspaceLimit) else workspace
        if isinstance(ws, (str, bytes)) or not isinstance(ws, Sequence):
            raise InvalidParameter(
                f"workspace: expected a WorkspaceLimit or a sequence of them, got "
                f"{describe(workspace)}"
            )
        for w in ws:
            if not isinstance(w, WorkspaceLimit):
                raise InvalidParameter(
                    f"workspace: expected WorkspaceLimit entries, got {describe(w)}"
                )
            if w.point not in self.robot.points:
                raise InvalidParameter(
                    f"workspace: point {w.point!r} is not one of the robot's points "
                    f"{list(self.robot.points)}"
                )
            dim = np.asarray(frame0.point(w.point)).shape[0]
            if w.polytope.dim != dim:
                raise InvalidParameter(
                    f"workspace: the polytope on {w.point!r} is {w.polytope.dim}-D, the robot's "
                    f"task space is {dim}-D"
                )
        return tuple(ws)

    def _obstacle_list(self, obstacles: Any) -> tuple[SphereObstacle, ...]:
        if isinstance(obstacles, (str, bytes)) or not isinstance(obstacles, Sequence):
            raise InvalidParameter(
                f"obstacles: expected a sequence of SphereObstacle, got {describe(obstacles)}"
            )
        for o in obstacles:
            if not isinstance(o, SphereObstacle):
                raise InvalidParameter(
                    f"obstacles: expected SphereObstacle entries, got {describe(o)}"
                )
        return tuple(obstacles)

    def _obstacle_rows(self, frame0: Any) -> ObstacleRows:
        robot: Any = self.robot
        if not hasattr(robot, "link_radius"):
            raise InvalidParameter(
                f"obstacles: the robot {type(robot).__name__} has no capsule geometry "
                "('link_radius'); use a DHChain, PlanarArm or MujocoRobot (Puma560.chain)"
            )
        radius = np.asarray(robot.link_radius, dtype=float).reshape(-1)
        prov = ObstacleRows(
            self._obstacles, radius, buffer=self.obstacle_buffer,
            spring_gain=self.spring_gain, max_velocity=self.limits.max_velocity,
        )  # fmt: skip
        try:
            segs = prov._segments(frame0)
            checked("kinematics(q).point_jacobian(0, 0.5)", frame0.point_jacobian(0, 0.5),
                    (3, self.dof))  # fmt: skip
        except (InvalidInput, AttributeError, TypeError) as exc:
            raise InvalidParameter(
                f"obstacles: the robot's capsule geometry is unusable: {exc}"
            ) from None
        if segs.shape[0] == 0:
            raise InvalidParameter("obstacles: the robot has no capsule links")
        return prov

    def _custom(self, providers: Any) -> list[Any]:
        if isinstance(providers, (str, bytes)) or not isinstance(providers, Sequence):
            raise InvalidParameter(
                f"providers: expected a sequence of row providers, got {describe(providers)}"
            )
        out = []
        for i, p in enumerate(providers):
            level = getattr(p, "level", None)
            if not callable(getattr(p, "rows", None)):
                raise InvalidParameter(
                    f"providers[{i}]: expected a RowProvider (level, label, rows(ctx)), got "
                    f"{describe(p)} without rows()"
                )
            if isinstance(level, bool) or level not in range(len(LEVEL_NAMES)):
                raise InvalidParameter(
                    f"providers[{i}]: expected level 0-3 ({', '.join(LEVEL_NAMES)}), got {level!r}"
                )
            out.append(p)
        return out

    def _weights(self, weights: Any) -> _Metric:
        if weights is None:
            return None
        n = self.dof
        Wa = real_array("weights", weights, error=InvalidParameter, what="weights")
        if Wa.shape == (n,):
            if not np.all(Wa > 0.0):
                raise InvalidParameter(f"weights: expected weights > 0, got {Wa.tolist()}")
            return readonly(np.sqrt(Wa))
        if Wa.shape == (n, n):
            if not np.allclose(Wa, Wa.T, rtol=1e-12, atol=0.0):
                asym = float(np.max(np.abs(Wa - Wa.T)))
                raise InvalidParameter(
                    f"weights: expected a symmetric ({n}, {n}) matrix, got one whose largest "
                    f"|W - Wᵀ| entry is {asym:g}"
                )
            return readonly(_cholesky("weights", Wa))
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
    def providers(self) -> tuple[RowProvider, ...]:
        """Every row provider in row order: the built-in ones, then the user's."""
        return self._providers

    @property
    def stateful(self) -> bool:
        """True when acceleration rows apply and the filter remembers its last output."""
        return self._has_accel

    def reset(self) -> None:
        """Forget the remembered last output and the warm start (a fresh start)."""
        self._previous = None
        self._warm = set()

    # ------------------------------------------------------------------ rows
    def _blocks(self, ctx: RowContext) -> _Cycle:
        n = self.dof
        out: list[tuple[int, Any, RowBlock]] = []
        for i, p in enumerate(self._providers):
            builtin = i < self._n_builtin
            try:
                blk = p.rows(ctx)
            except VelfenceError:
                if builtin:
                    raise
                exc_v = _sys_exc()
                raise InvalidInput(f"{self._who(i, p)}: raised {exc_v}") from exc_v
            except Exception as exc:
                who = f"robot (via the {p.label} rows)" if builtin else self._who(i, p)
                raise InvalidInput(f"{who}: raised {type(exc).__name__}: {exc}") from exc
            if blk is None or blk.size == 0:
                continue
            if not builtin:
                self._check_block(i, p, blk, n)
            out.append((i, p, blk))
        return _Cycle(out, n)

    def _who(self, i: int, p: Any) -> str:
        return f"providers[{i - self._n_builtin}] ({getattr(p, 'label', type(p).__name__)})"

    def _check_block(self, i: int, p: Any, blk: Any, n: int) -> None:
        who = self._who(i, p)
        if not isinstance(blk, RowBlock):
            raise InvalidInput(f"{who}: rows() expected a RowBlock or None, got {describe(blk)}")
        k = blk.size
        G = np.asarray(blk.G)
        ok = (
            G.shape == (k, n)
            and np.asarray(blk.b).shape == (k,)
            and np.shape(blk.violated) == (k,)
            and np.shape(blk.keys) == (k,)
        )
        if not ok:
            raise InvalidInput(
                f"{who}: rows() expected G ({k}, {n}), b, violated and keys ({k},), got G "
                f"{G.shape}, b {np.shape(blk.b)}, violated {np.shape(blk.violated)}, keys "
                f"{np.shape(blk.keys)}"
            )
        bb = np.asarray(blk.b, dtype=float)
        if not np.isfinite(G).all() or np.isnan(bb).any() or (bb == math.inf).any():
            raise InvalidInput(f"{who}: rows() expected finite G and b (or b = -inf), got NaN/inf")

    # ------------------------------------------------------------------ solve
    def _solve(
        self, u: FloatArray, G: FloatArray, b: FloatArray, warm: Any
    ) -> tuple[int, FloatArray]:
        """The projection by the backend in use: ``(status, x)``."""
        cap = self.max_iterations or 0
        if self._core is not None and cap == 0 and not warm:
            status, x = self._core.project(
                np.ascontiguousarray(u, dtype=np.float64),
                np.ascontiguousarray(G, dtype=np.float64),
                np.ascontiguousarray(b, dtype=np.float64),
            )
        else:
            status, x = _python_solve(u, G, b, cap, warm)
        if status == 0 and not _finite(x):
            status = 1
        return int(status), x

    def _project(
        self, u: FloatArray, G: FloatArray, b: FloatArray, L: _Metric, warm: Any
    ) -> tuple[int, FloatArray]:
        if G.shape[0] == 0 or bool(np.all(G @ u >= b)):
            # Nothing violated (as evaluated): the optimum is the command itself, exactly.
            return 0, u.copy()
        if L is None:
            return self._solve(u, G, b, warm)
        if L.ndim == 1:  # diagonal metric: L = diag(lv), y = lv * x
            st, y = self._solve(u * L, G / L[None, :], b, warm)
            x: FloatArray = y / L
        else:  # y = Lᵀ x: G x = G L⁻ᵀ y
            GL = np.asarray(np.linalg.solve(L, G.T).T, dtype=np.float64)
            st, y = self._solve(L.T @ u, GL, b, warm)
            x = np.asarray(np.linalg.solve(L.T, y), dtype=np.float64)
        if st == 0:
            # Round-off of the back-substitution: repair along the violated rows (a few ulps).
            for _ in range(4):
                gap = b - G @ x
                k = int(np.argmax(gap))
                if not gap[k] > 0.0:
                    break
                gk = G[k]
                x = x + (gap[k] * (1.0 + 1e-12) + 1e-300) * gk / float(gk @ gk)
        return st, x

    # ------------------------------------------------------------------ the cycle
    def _state(self, name: str, x: Any, width: int, unit: str) -> FloatArray:
        if type(x) is np.ndarray and x.dtype == np.float64 and x.shape == (width,):
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
        frame: Any = None,
    ) -> FilterResult | tuple[Any, ...]:
        """One cycle's rows and solve: ``(cycle, x, u, outcome, scaled, deadline)`` or a stop."""
        t0 = self._clock() if self.time_budget is not None else 0.0
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
        big = max(map(abs, u.tolist())) if u.size else 0.0
        if big > cap:
            # A command far beyond what the joints can do is shortened in its own direction, so
            # the solve stays well inside floating point.
            u = u * (cap / big)
            scaled = True
        with np.errstate(all="ignore"):
            if frame is None:
                frame = frame_of(self.robot, q)
            cyc = self._blocks(RowContext(q, u, prev, self.dt, frame))
            budget = self.time_budget

            def solve(G: FloatArray, b: FloatArray, warm: Any) -> tuple[int, FloatArray]:
                over = budget is not None and self._clock() - t0 > budget
                if over and G.shape[0] and not bool(np.all(G @ u >= b)):
                    raise DeadlineHit("time")
                return self._project(u, G, b, L, warm)

            nxt = self._next_distances(q, cyc) if len(cyc.checked) and self.dt else None
            warm = cyc.rows_of(self._warm) if self._warm else None
            deadline: str | None = None
            try:
                out = run_ladder(
                    cyc.G, cyc.b, cyc.level, cyc.violated, solve, warm=warm,
                    checked=cyc.checked if nxt is not None else None, d0=cyc.d0,
                    next_distances=nxt, dt=self.dt,
                )  # fmt: skip
                x = out.x
            except DeadlineHit as hit:
                deadline = hit.kind
                self.deadline_misses += 1
                x, relaxed, how = safe_fallback(
                    u, cyc.G, cyc.b, checked=cyc.checked if nxt is not None else None,
                    d0=cyc.d0, next_distances=nxt, dt=self.dt,
                )  # fmt: skip
                stages = ["deadline"] + ([how] if how else [])
                out = _Outcome(x, relaxed, stages)
        if not _finite(x):
            self._invalid("input too large: the filtered velocity overflowed")
            return self._stopped(q, cmd)
        if remember:
            if self._has_accel:
                self._previous = readonly(x.copy())
            self._remember_active(cyc, x)
        return cyc, x, u, out, scaled, deadline

    def _remember_active(self, cyc: _Cycle, x: FloatArray) -> None:
        """The rows binding at ``x``, by key: the next cycle's warm start."""
        if cyc.G.shape[0] == 0:
            self._warm = set()
            return
        with np.errstate(invalid="ignore"):
            slack = cyc.G @ x - cyc.b
        act = np.flatnonzero(slack <= _BINDING * (1.0 + np.abs(cyc.b)))
        self._warm = cyc.keys(act.tolist()) if act.shape[0] else set()

    def _next_distances(self, q: FloatArray, cyc: _Cycle) -> Callable[[FloatArray], FloatArray]:
        dt = self.dt or 0.0
        parts = [
            (p, blk) for _, p, blk in cyc.blocks
            if blk.distance is not None and hasattr(p, "next_distances")
        ]  # fmt: skip

        def nxt(x: FloatArray) -> FloatArray:
            frame1 = frame_of(self.robot, q + x * dt)
            return np.concatenate(
                [np.asarray(p.next_distances(frame1, blk), dtype=float) for p, blk in parts]
            )

        return nxt

    def _run(
        self,
        q: FloatArray,
        u: FloatArray,
        cmd: FloatArray,
        L: _Metric,
        previous: Any,
        remember: bool,
        frame: Any = None,
    ) -> FilterResult:
        c = self._cycle(q, u, cmd, L, previous, remember, frame)
        if isinstance(c, FilterResult):
            return c
        cyc, x, u, out, scaled, deadline = c
        G = cyc.G
        b0 = cyc.b
        fin = np.isfinite(b0)
        with np.errstate(invalid="ignore"):
            slack = np.where(fin, G @ x - b0, math.inf)
        tol = _BINDING * (1.0 + np.abs(np.where(fin, b0, 0.0)))
        viol = cyc.violated
        act = tuple(np.flatnonzero((slack <= tol) | viol).tolist())
        n_out = int(np.count_nonzero(viol))
        zone: Zone = ZONE_NAMES[zone_code(n_out, len(act))]  # type: ignore[assignment]
        pre: list[str] = ["command-scaled"] if scaled else []
        if not np.array_equal(x, u):
            pre.append("projection")
        if n_out:
            pre.append("recovery")
        names = cyc.names()
        return FilterResult(
            output=x, command=cmd, position=q, zone=zone, active=act,
            active_names=tuple(names[i] for i in act), slack=readonly(slack),
            constraint_names=tuple(names), stages=tuple(pre + out.stages),
            dropped=tuple(out.dropped), rate_override=out.rate_override,
            rows=(readonly(G), readonly(b0)), relaxed=tuple(names[i] for i in out.relaxed),
            deadline=deadline,  # type: ignore[arg-type]
        )  # fmt: skip

    # ------------------------------------------------------------------ public
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
            A :class:`~velfence.filter.result.FilterResult`.

        Raises:
            InvalidInput: wrong shapes, non-finite values with ``on_invalid="raise"``, a
                kinematics answer of the wrong shape or not finite (naming ``robot``), a row
                provider that raises or returns bad rows (naming it).
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
        has_ang = hasattr(self.robot, "angular_jacobian")
        sizes = (self.task_dim, 6) if has_ang and self.task_dim == 3 else (self.task_dim,)
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
        frame = frame_of(self.robot, qa)
        n = self.dof
        J: Any = checked(f"kinematics(q).jacobian({point!r})", frame.jacobian(point),
                         (self.task_dim, n))  # fmt: skip
        if va.shape[0] == 6 and self.task_dim == 3:
            ang = getattr(frame, "angular_jacobian", None)
            robot: Any = self.robot
            Ja = ang() if ang is not None else robot.angular_jacobian(qa)
            J = np.vstack((J, checked("angular_jacobian(q)", Ja, (3, n))))
        with np.errstate(all="ignore"):
            H = J.T @ J + (self.damping**2) * np.eye(n)
            L = _factor(H)
            u: FloatArray = np.asarray(
                np.linalg.solve(L.T, np.linalg.solve(L, J.T @ va)), dtype=np.float64
            )
        if self._bad(u):
            self._invalid("input too large: the twist's joint velocity overflowed")
            return self._stopped(qa, va)
        return self._run(qa, u, va, L, previous, True, frame)

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
        """:meth:`filter` on N independent states (no remembered output or warm start).

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
        warm = self._warm
        self._warm = set()
        try:
            for k in range(Qa.shape[0]):
                if self._bad(Qa[k], Va[k]):
                    try:
                        self._invalid(f"non-finite input in row {k}")
                    except InvalidInput as exc:
                        raise InvalidInput(f"Q, QD row {k}: {exc}") from None
                    continue
                c = self._cycle(Qa[k], Va[k], Va[k], self._metric, None, False)
                out[k] = c.output if isinstance(c, FilterResult) else c[1]
        finally:
            self._warm = warm
        return out


def _sys_exc() -> BaseException:
    import sys

    exc = sys.exc_info()[1]
    return exc if exc is not None else RuntimeError("unknown")


class _Outcome:
    """The deadline fallback's outcome, as a ``LadderOutcome``."""

    __slots__ = ("dropped", "rate_override", "relaxed", "stages", "x")

    def __init__(self, x: FloatArray, relaxed: list[int], stages: list[str]) -> None:
        self.x = x
        self.relaxed = relaxed
        self.stages = stages
        self.dropped: list[str] = []
        self.rate_override = False
