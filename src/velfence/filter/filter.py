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
profile, joint velocity, joint acceleration and jerk, a workspace polytope per
:class:`WorkspaceLimit`, sphere obstacles against capsule links, and the user's own), all from
one kinematics frame per cycle (:mod:`velfence.filter.kinematics`). When they have no common
point the priority ladder (:mod:`velfence.filter.ladder`) decides what gives way; with
``max_iterations`` or ``time_budget`` a cycle that runs out answers the ladder's safe fallback.
"""

from __future__ import annotations

import math
import os
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import renamed_args
from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_flag,
    check_positive,
    check_positive_int,
    check_text,
    describe,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter, StartedInViolation
from velfence.filter import parts
from velfence.filter.attach import AttachmentObstacleRows, AttachmentWorkspaceRows
from velfence.filter.compiled import compiled_rows
from velfence.filter.kinematics import Kinematics, checked, frame_of
from velfence.filter.ladder import DeadlineHit, LadderOutcome, run_ladder, safe_fallback
from velfence.filter.limits import (
    JointLimits,
    Profile,
    SelfCollision,
    SphereObstacle,
    WorkspaceLimit,
    spatial_obstacles,
)
from velfence.filter.result import STAGE_BITS, FilterBatch, FilterResult
from velfence.filter.rows import (
    LEVEL_JERK,
    LEVEL_JOINT,
    LEVEL_OBSTACLE,
    LEVEL_RATE,
    LEVEL_WORKSPACE,
    PLAIN_BOUNDS,
    BoundKernels,
    JointAccelerationLimit,
    JointJerkLimit,
    JointPositionLimit,
    JointVelocityLimit,
    RowContext,
    RowProvider,
    WorkspaceRows,
)
from velfence.filter.solve import Metric, Projector, damped_factor, factor_solve, finite
from velfence.filter.stack import RowStack, collect
from velfence.shaping.backend import pick_backend
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.polytope import PolytopeBackend
from velfence.shaping.shared_kernels import ZONE_NAMES, zone_code

__all__ = ["SafetyFilter"]

_BINDING = 1e-9  # relative slack under which a row counts as active
#: The C cycle's stage bits (velfence_filter.h VF_FILTER_STAGE_*) and names, in report order.
_C_STAGES = STAGE_BITS
#: The levels a report names as dropped or relaxed, in the ladder's order.
_C_DROPPED = (
    (LEVEL_JERK, "jerk"), (LEVEL_RATE, "acceleration"), (LEVEL_OBSTACLE, "obstacles"),
    (LEVEL_WORKSPACE, "workspace"), (LEVEL_JOINT, "joint limits"),
)  # fmt: skip
_STAGE_DROPPED_JERK = 2048  # VF_FILTER_STAGE_DROPPED_JERK
_STAGE_RECOVERY = 2  # VF_FILTER_STAGE_RECOVERY: some row is violated
_NAMED = 5  # violated constraints named in the StartedInViolation message
#: A start violating nothing deeper than this [m or rad] gives no StartedInViolation: the
#: filter's own closed loop holds its constraints to 1e-9 (docs/safety_filter.md §6), so a
#: shallower start is where a run of it stopped (the report still lists it).
_START_TOLERANCE = 1e-9
_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep  # velfence/
_APPS_DIR = os.path.join(_PACKAGE_DIR, "apps", "")  # an application is a caller too
_COMMAND_CAP = 1e3  # commands are shortened beyond this multiple of the fastest joint limit


def _warn_started(violations: Sequence[tuple[str, float | None]], spring_gain: float) -> None:
    """Warn :class:`StartedInViolation` naming each violated constraint and its depth.

    Only when one is deeper than :data:`_START_TOLERANCE`: a start within round-off of a face
    (a robot stopped on it, then ``reset()``) is where the filter's own loop leaves it.
    """
    if not any(d is None or d > _START_TOLERANCE for _, d in violations):
        return
    parts_: list[str] = []
    for name, depth in violations[:_NAMED]:
        unit = "rad" if " position (" in name and name.startswith("joint ") else "m"
        how = "depth unknown" if depth is None else f"{depth:.4g} {unit} deep"
        parts_.append(f"{name} ({how})")
    more = len(violations) - _NAMED
    listed = "; ".join(parts_) + (f"; and {more} more" if more > 0 else "")
    k = len(violations)
    level = 2  # the caller of this function; then the first frame outside velfence
    frame = sys._getframe(1)
    while (
        frame is not None
        and frame.f_code.co_filename.startswith(_PACKAGE_DIR)
        and not frame.f_code.co_filename.startswith(_APPS_DIR)
    ):
        frame = frame.f_back  # type: ignore[assignment]
        level += 1
    warnings.warn(
        f"SafetyFilter: the first cycle starts with {k} constraint{'s' * (k != 1)} already "
        f"violated: {listed}. The filter is in recovery: its output moves the robot back out "
        f"(an obstacle at spring_gain x depth, spring_gain {spring_gain:g}/s), even for a zero "
        "command. If the robot is not really there, check the obstacles, link radii and units. "
        "FilterResult.violations names them every cycle; this warning comes once per start "
        "(construction or reset()).",
        StartedInViolation,
        stacklevel=level,
    )


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
        self_collision: Keep the robot's capsule links apart: ``True`` (every pair of
            non-adjacent links), a :class:`~velfence.filter.limits.SelfCollision` (pairs left
            out by ``exclude=``), or ``None``/``False`` (default: none). The pairs share the
            obstacles' ``obstacle_buffer`` and ``spring_gain`` and their ladder level.
        attachments: Tool and payload shapes (:class:`~velfence.filter.limits.Sphere`,
            :class:`~velfence.filter.limits.Capsule`) on the robot's links, kept inside every
            workspace polytope and outside every obstacle: a mapping name -> shape, or a
            sequence (named ``"attachment 0"``, …); ``None`` (default): none, and no
            :meth:`attach` later. Needs the robot's link frames (a ``DHChain``); the C cycle
            runs them too.
        providers: Further row providers (:class:`~velfence.filter.rows.RowProvider`), each at
            its declared level of the ladder.
        dt: Control period [s] (``None``: continuous-time bounds). With ``dt`` every row also
            keeps one period's motion inside, the rows are checked on the model, and the
            acceleration and jerk rows apply.
        profile: One approach profile for every joint limit (radians); by default a
            three-zone braking profile for each joint with an acceleration limit
            (``ThreeZoneBraking(gain=2 a/v, max_speed=v, max_acceleration=a)``), else a linear
            buffer of width ``joint_buffer`` whose cap speed is the joint's ``max_speed``.
        joint_buffer: Width of the default linear buffer at joint limits [rad], > 0.
        spring_gain: Recovery gain of the default joint buffers and the obstacles [1/s], >= 0.
        obstacle_buffer: Width of the obstacles' linear buffer [m], > 0.
        weights: Joint-mode metric ``W``: ``None`` (identity), per-joint weights (n,) > 0, or a
            symmetric positive definite (n, n) matrix; the largest weight (eigenvalue) at most
            1e12 times the smallest.
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
        "_attach",
        "_ccycle",
        "_clock",
        "_compiled",
        "_has_accel",
        "_has_jerk",
        "_metric",
        "_n_builtin",
        "_obstacles",
        "_previous",
        "_previous2",
        "_projector",
        "_providers",
        "_remember",
        "_self_pairs",
        "_speed_scale",
        "_started",
        "_warm",
        "_workspace",
        "backend",
        "damping",
        "deadline_misses",
        "dof",
        "dt",
        "jerk_overrides",
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
        self_collision: bool | SelfCollision | None = None,
        attachments: Any = None,
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
        parts.check_robot(robot)
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
        self._speed_scale = float(np.max(limits.max_speed))
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
        self._started = False  # a cycle ran since construction or reset() (StartedInViolation)
        #: Cycles (of ``filter``, ``explain`` and their twist forms) whose jerk rows gave way.
        self.jerk_overrides = 0
        self._clock: Callable[[], float] = time.perf_counter
        self._warm: set[tuple[int, int]] = set()
        core, self.backend = pick_backend(backend)
        self._projector = Projector(
            core, self.max_iterations, np.asarray(self.limits.max_speed, dtype=np.float64)
        )
        kern: BoundKernels = PLAIN_BOUNDS if core is None else (None, core)
        profs = parts.joint_profiles(limits, profile, joint_buffer=jb, spring_gain=self.spring_gain)
        acc = limits.max_acceleration
        self._has_accel = acc is not None and self.dt is not None and bool(np.isfinite(acc).any())
        jerk = limits.max_jerk
        self._has_jerk = jerk is not None and self.dt is not None and bool(np.isfinite(jerk).any())
        self._remember = self._has_accel or self._has_jerk
        self._previous: FloatArray | None = None
        self._previous2: FloatArray | None = None
        frame0, self.task_dim = parts.robot_frame(robot, n)
        self._workspace = parts.workspaces(robot, workspace, frame0)
        self._obstacles = spatial_obstacles(parts.obstacle_list(obstacles), self.task_dim)
        rows: list[Any] = [
            JointPositionLimit(limits, profs, kernels=kern),
            JointVelocityLimit(limits),
        ]
        if self._has_accel:
            rows.append(JointAccelerationLimit(limits))
        if self._has_jerk:
            rows.append(JointJerkLimit(limits))
        multi = len(self._workspace) > 1
        for w_i, w in enumerate(self._workspace):
            pre = f"workspace {w_i}: " if multi else ""
            rows.append(WorkspaceRows(w, dim=self.task_dim, prefix=pre, kernels=kern))
        self._attach = None
        if attachments is not None:
            self._attach = parts.attachment_table(robot, attachments, frame0, n)
            for w_i, w in enumerate(self._workspace):
                pre = f"workspace {w_i}: " if multi else ""
                rows.append(AttachmentWorkspaceRows(w, self._attach, prefix=pre, kernels=kern))
        if self._obstacles:
            rows.append(
                parts.obstacle_rows(
                    robot,
                    self._obstacles,
                    frame0,
                    n=n,
                    buffer=self.obstacle_buffer,
                    spring_gain=self.spring_gain,
                    max_speed=limits.max_speed,
                )
            )
        if self._attach is not None and self._obstacles:
            rows.append(
                AttachmentObstacleRows(
                    self._obstacles, self._attach, buffer=self.obstacle_buffer,
                    spring_gain=self.spring_gain, max_speed=limits.max_speed,
                )
            )  # fmt: skip
        self._self_pairs: tuple[tuple[int, int], ...] = ()
        sc = parts.self_collision(self_collision)
        if sc is not None:
            prov = parts.self_collision_rows(
                robot, sc, frame0, n=n, buffer=self.obstacle_buffer,
                spring_gain=self.spring_gain, max_speed=limits.max_speed,
            )  # fmt: skip
            self._self_pairs = prov.pairs
            rows.append(prov)
        self._n_builtin = len(rows)
        rows.extend(parts.custom_providers(providers))
        self._providers: tuple[Any, ...] = tuple(rows)
        # (the compiled rows of velfence_nd know no self-collision pairs or attachments: the
        # Python providers build them on that route; the C cycle below has them)
        self._compiled = (
            None
            if providers or self._has_jerk or sc is not None or attachments is not None
            else compiled_rows(core, self, profs)
        )
        self._metric: Metric = parts.metric(weights, n)
        # The whole cycle in C (velfence_filter.h) when the core is in use, the robot gives its
        # chain as data and no custom provider runs: filter(), shape() and shape_batch() call it
        # and explain() builds its report from it; twist mode passes its metric's factor L
        # (vf_filter_cycle_metric). Every other case (a full weight matrix in joint mode too)
        # keeps the Python route (backend="python": the oracle it is tested equal to).
        self._ccycle: Any = None
        if core is not None and not providers:
            from velfence.filter.ccycle import c_cycle_or_none

            self._ccycle = c_cycle_or_none(self, profs)

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
    def attachments(self) -> dict[str, Any]:
        """The attached shapes, name -> shape (empty without ``attachments``)."""
        return {} if self._attach is None else self._attach.shapes()

    def attach(self, name: str, shape: Any) -> None:
        """Attach a shape under ``name`` (a grasp), or replace the one of that name.

        Takes effect from the next cycle; the filter is not rebuilt.

        Args:
            name: The shape's name (its rows' names start with it).
            shape: A :class:`~velfence.filter.limits.Sphere` or
                :class:`~velfence.filter.limits.Capsule` on a link the robot has.

        Raises:
            InvalidParameter: the filter was built without ``attachments``, a bad name, a
                non-shape, or a link the robot does not have.
        """
        if self._attach is None:
            raise InvalidParameter(
                "attach: the filter was built without attachments= (pass attachments={} to "
                "attach shapes later)"
            )
        parts.add_attachment(self._attach, name, shape, "shape")
        self._attachments_changed()

    def _attachments_changed(self) -> None:
        """The C cycle takes the new table (and the warm start, keyed by row, restarts)."""
        self._warm = set()
        if self._ccycle is not None and self._attach is not None:
            self._ccycle.set_attachments(self._attach.flat())

    def detach(self, name: str) -> None:
        """Detach the shape ``name`` (a release); from the next cycle on it has no rows.

        Raises:
            InvalidParameter: no shape of that name is attached.
        """
        name = check_text("name", name)
        if self._attach is None or not self._attach.remove(name):
            have = [] if self._attach is None else list(self._attach.names())
            raise InvalidParameter(f"name: no shape {name!r} is attached (attached: {have})")
        self._attachments_changed()

    @property
    def self_collision_pairs(self) -> tuple[tuple[int, int], ...]:
        """The link pairs the self-collision rows guard (empty without ``self_collision``)."""
        return self._self_pairs

    @property
    def providers(self) -> tuple[RowProvider, ...]:
        """Every row provider in row order: the built-in ones, then the user's."""
        return self._providers

    @property
    def cycle_in_c(self) -> bool:
        """True when each cycle, joint mode and twist mode, runs whole in the compiled core.

        That is ``vf_filter_cycle`` of ``velfence_filter.h`` (twist mode:
        ``vf_filter_cycle_metric`` with the factor of ``JᵀJ + λ²I``): ``backend="c"`` (or
        ``"auto"`` with the core installed), a robot with chain data (``DHChain``, ``Puma560``, a
        chain ``MujocoRobot``), no row provider of the user's and no full weight matrix. False
        on the other routes (the compiled rows, or Python).
        """
        return self._ccycle is not None

    @property
    def last_cycle_rows(self) -> tuple[FloatArray, FloatArray, IntArray, FloatArray] | None:
        """The rows of the last cycle run whole in the compiled core, or ``None``.

        ``(G (m, n), b (m,), level (m,), bound (m,))`` (copies): the rows ``G x >= b`` as built,
        each row's level (:data:`LEVEL_NAMES` index) and the bound the output claims to meet
        (after relaxation and the discrete-time tightening; ``-inf``: none claimed). For checking
        an output of :meth:`filter` against every row without a second cycle (``explain`` gives
        the rows on every route). ``None`` when :attr:`cycle_in_c` is false or before the first
        cycle the core completed.
        """
        if self._ccycle is None:
            return None
        try:
            G, b, level, _, _, _, _, bound = self._ccycle.rows()
        except RuntimeError:  # "no successful cycle yet"
            return None
        return (
            np.asarray(G, dtype=np.float64),
            np.asarray(b, dtype=np.float64),
            np.asarray(level, dtype=np.int64),
            np.asarray(bound, dtype=np.float64),
        )

    @property
    def stateful(self) -> bool:
        """True when acceleration or jerk rows apply and the filter remembers its last outputs."""
        return self._remember

    def reset(self, *, velocity: ArrayLike | None = None) -> None:
        """Forget the remembered outputs and the warm start (a fresh start).

        Args:
            velocity: ``None`` (default): nothing is remembered, so the next cycle has neither
                acceleration nor jerk rows, the one after acceleration rows only, and the jerk
                rows start on the third. A joint velocity [rad/s], shape (dof,) (zeros: a robot
                at rest): remembered as the last two outputs, so the next cycle already has
                both (the robot moved steadily at ``velocity``).

        Raises:
            InvalidInput: ``velocity`` of the wrong shape or not finite.
        """
        v: FloatArray | None = None
        if velocity is not None:
            v = real_array("velocity", velocity, (self.dof,), what=f"{self.dof} numbers [rad/s]")
            v = readonly(v)
        self._previous = v if self._remember else None
        self._previous2 = v if self._has_jerk else None
        self._warm = set()
        self._started = False
        if self._ccycle is not None:
            from velfence.filter.ccycle import c_options

            self._ccycle.set_options(**c_options(self))

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
        L: Metric,
        previous: Any,
        remember: bool,
        frame: Any = None,
    ) -> FilterResult | tuple[Any, ...]:
        """One cycle's rows and solve: ``(cycle, x, u, outcome, scaled, deadline)`` or a stop."""
        t0 = self._clock() if self.time_budget is not None else 0.0
        prev: FloatArray | None = None
        prev2: FloatArray | None = None
        if previous is not None:
            prev = self._state("previous", previous, self.dof, "rad/s")
            if self._bad(prev):
                self._invalid(f"non-finite previous={prev.tolist()}")
                return self._stopped(q, cmd)
        elif remember:
            prev = self._previous
            prev2 = self._previous2
        scaled = False
        cap = _COMMAND_CAP * self._speed_scale
        big = max(map(abs, u.tolist())) if u.size else 0.0
        if big > cap:
            # A command far beyond what the joints can do is shortened in its own direction, so
            # the solve stays well inside floating point.
            u = u * (cap / big)
            scaled = True
        with np.errstate(all="ignore"):
            cyc = self._build_rows(q, u, prev, frame, prev2 if self._has_jerk else None)
            budget = self.time_budget

            def solve(G: FloatArray, b: FloatArray, warm: Any) -> tuple[int, FloatArray]:
                over = budget is not None and self._clock() - t0 > budget
                if over and G.shape[0] and not bool(np.all(G @ u >= b)):
                    raise DeadlineHit("time")
                return self._projector.project(u, G, b, L, warm)

            nxt = self._next_distances(q, cyc) if len(cyc.checked) and self.dt else None
            warm = cyc.rows_of(self._warm) if self._warm else None
            deadline: str | None = None
            try:
                out = run_ladder(
                    cyc.G, cyc.b, cyc.level, cyc.violated, solve, warm=warm,
                    checked=cyc.checked if nxt is not None else None, d0=cyc.d0,
                    next_distances=nxt, dt=self.dt,
                    scale=float(np.max(np.abs(u))) if u.size else 0.0,
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
                rate = bool(relaxed) and bool(np.any(cyc.level[relaxed] == LEVEL_RATE))
                jerk = bool(relaxed) and bool(np.any(cyc.level[relaxed] == LEVEL_JERK))
                out = LadderOutcome(
                    x, relaxed, ["jerk"] * jerk + ["acceleration"] * rate, stages, rate, jerk
                )
        if not finite(x):
            self._invalid("input too large: the filtered velocity overflowed")
            return self._stopped(q, cmd)
        if remember:
            if self._remember:
                if self._has_jerk:
                    self._previous2 = None if prev is None else readonly(prev)
                    self.jerk_overrides += out.jerk_override
                self._previous = readonly(x.copy())
            self._remember_active(cyc, x)
            if not self._started:
                self._started = True
                if cyc.violated.any():
                    _warn_started(
                        cyc.violations(cyc.names(), providers=self._n_builtin), self.spring_gain
                    )
        return cyc, x, u, out, scaled, deadline

    def _build_rows(
        self,
        q: FloatArray,
        u: FloatArray,
        prev: FloatArray | None,
        frame: Any = None,
        prev2: FloatArray | None = None,
    ) -> RowStack:
        """This cycle's rows by the route in use (compiled for a DH chain in joint mode)."""
        if self._compiled is not None and frame is None:
            return self._compiled.stack(q, u, prev if self._has_accel else None)
        if frame is None:
            frame = frame_of(self.robot, q)
        ctx = RowContext(q, u, prev, self.dt, frame, prev2)
        return collect(self._providers, self._n_builtin, ctx, self.dof)

    def _remember_active(self, cyc: RowStack, x: FloatArray) -> None:
        """The rows binding at ``x``, by key: the next cycle's warm start."""
        if not self._projector.warm_starts:
            return
        if cyc.G.shape[0] == 0:
            self._warm = set()
            return
        with np.errstate(invalid="ignore"):
            slack = cyc.G @ x - cyc.b
        act = np.flatnonzero(slack <= _BINDING * (1.0 + np.abs(cyc.b)))
        self._warm = cyc.keys(act.tolist()) if act.shape[0] else set()

    def _next_distances(self, q: FloatArray, cyc: RowStack) -> Callable[[FloatArray], FloatArray]:
        """The model check's true next distances: ``x -> d1`` at ``q + x dt`` (a new frame)."""
        dt = self.dt or 0.0

        def nxt(x: FloatArray) -> FloatArray:
            return cyc.distances_at(self.robot, q + x * dt)

        return nxt

    def _run(
        self,
        q: FloatArray,
        u: FloatArray,
        cmd: FloatArray,
        L: Metric,
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
            violations=cyc.violations(names) if n_out else (),
            active_names=tuple(names[i] for i in act), slack=readonly(slack),
            constraint_names=tuple(names), stages=tuple(pre + out.stages),
            dropped=tuple(out.dropped), rate_override=out.rate_override,
            jerk_override=out.jerk_override,
            rows=(readonly(G), readonly(b0)), relaxed=tuple(names[i] for i in out.relaxed),
            deadline=deadline,
        )  # fmt: skip

    # ------------------------------------------------------------------ public
    @renamed_args(q="position", qd_cmd="command")
    def explain(
        self, position: ArrayLike, command: ArrayLike, *, previous: ArrayLike | None = None
    ) -> FilterResult:
        """Filter a joint-velocity command, with diagnostics.

        Args:
            position: Joint position [rad], shape (dof,).
            command: Commanded joint velocity [rad/s], shape (dof,).
            previous: The last output [rad/s], shape (dof,), for the acceleration rows; when
                ``None`` and acceleration or jerk rows apply (``dt`` and ``max_acceleration``
                or ``max_jerk``) the filter uses the outputs it remembered from its last calls
                (none after :meth:`reset`). The jerk rows need the two last outputs: a cycle
                given ``previous`` has none (it knows no output before it); the next cycle's
                jerk rows then use ``previous`` and this cycle's output.

        Returns:
            A :class:`~velfence.filter.result.FilterResult`.

        Raises:
            InvalidInput: wrong shapes, non-finite values with ``on_invalid="raise"``, a
                kinematics answer of the wrong shape or not finite (naming ``robot``), a row
                provider that raises or returns bad rows (naming it).
        """
        qa = self._state("position", position, self.dof, "rad")
        ua = self._state("command", command, self.dof, "rad/s")
        if self._bad(qa, ua):
            self._invalid(f"non-finite input: position={qa.tolist()}, command={ua.tolist()}")
            return self._stopped(qa, ua)
        if self._ccycle is not None:
            return self._explain_c(qa, ua, previous)
        return self._run(qa, ua, ua, self._metric, previous, True)

    @renamed_args(q="position", qd_cmd="command")
    def filter(
        self, position: ArrayLike, command: ArrayLike, *, previous: ArrayLike | None = None
    ) -> FloatArray:
        """The filtered joint velocity [rad/s], shape (dof,) (:meth:`explain`'s output).

        The same cycle as :meth:`explain` without the diagnostics (zone, slack, names).

        Args:
            position: Joint position [rad], shape (dof,).
            command: Commanded joint velocity [rad/s], shape (dof,).
            previous: As in :meth:`explain`.

        Returns:
            The joint velocity [rad/s], shape (dof,), always finite.
        """
        cyc = self._ccycle
        if cyc is not None and previous is None:
            # The C cycle's fast path: float64 arrays of shape (dof,) go straight in (the
            # binding checks their type, shape and finiteness); anything else, or an input C
            # refuses, takes the validated route below (the same cycle, with the messages).
            misses = cyc.deadline_misses
            try:
                x: FloatArray = cyc.cycle(
                    position, command, self._previous if self._remember else None, None,
                    self._previous2 if self._has_jerk else None,
                )  # fmt: skip
            except (TypeError, ValueError):
                pass
            else:
                if cyc.deadline_misses != misses:
                    self.deadline_misses += 1
                if self._remember:
                    self._remember_c(x, self._previous)
                if not self._started:
                    self._first_c()
                return x
        qa = self._state("position", position, self.dof, "rad")
        ua = self._state("command", command, self.dof, "rad/s")
        if self._bad(qa, ua):
            self._invalid(f"non-finite input: position={qa.tolist()}, command={ua.tolist()}")
            return np.zeros(self.dof)
        if cyc is not None:
            return self._filter_c(qa, ua, previous, True)
        c = self._cycle(qa, ua, ua, self._metric, previous, True)
        return c.output if isinstance(c, FilterResult) else c[1]

    # ------------------------------------------------------------------ the C cycle
    def _filter_c(
        self,
        qa: FloatArray,
        ua: FloatArray,
        previous: Any,
        remember: bool,
        factor: FloatArray | None = None,
    ) -> FloatArray:
        """:meth:`filter` by the C cycle (validated ``qa``, ``ua``; the same rows and ladder).

        ``factor``: the full metric's lower-triangular ``L`` (twist mode's ``H = L Lᵀ``), C
        contiguous, or ``None`` (the joint-mode weights).
        """
        prev: FloatArray | None = None
        prev2: FloatArray | None = None
        if previous is not None:
            prev = self._state("previous", previous, self.dof, "rad/s")
            if self._bad(prev):
                self._invalid(f"non-finite previous={prev.tolist()}")
                return np.zeros(self.dof)
        elif remember:
            prev = self._previous
            prev2 = self._previous2
        cyc = self._ccycle
        misses = cyc.deadline_misses
        try:
            x: FloatArray = cyc.cycle(
                qa, ua, prev if self._remember else None, None,
                prev2 if self._has_jerk else None, factor,
            )  # fmt: skip
        except ValueError:
            self._invalid("input too large: the filtered velocity overflowed")
            return np.zeros(self.dof)
        if cyc.deadline_misses != misses:
            self.deadline_misses += 1
        if remember and self._remember:
            self._remember_c(x, prev)
        if remember and not self._started:
            self._first_c()
        return x

    def _first_c(self) -> None:
        """The first C cycle since construction or :meth:`reset`: warn if it started inside."""
        self._started = True
        cyc = self._ccycle
        if cyc.stages & _STAGE_RECOVERY:
            try:
                _, _, level, ka, kb, dist, _, _ = cyc.rows()
            except RuntimeError:  # pragma: no cover - "no successful cycle yet"
                return
            keys = list(zip(level.tolist(), ka.tolist(), kb.tolist(), strict=True))
            names = self._c_names(keys)
            viol = np.flatnonzero(dist < 0.0).tolist()
            _warn_started(tuple((names[r], -float(dist[r])) for r in viol), self.spring_gain)

    def _remember_c(self, x: FloatArray, prev: FloatArray | None) -> None:
        """The C cycle's output as the last output (``prev`` the one before), jerk overrides."""
        if self._has_jerk:
            self._previous2 = None if prev is None else readonly(prev)
            if self._ccycle.stages & _STAGE_DROPPED_JERK:
                self.jerk_overrides += 1
        self._previous = readonly(x.copy())

    def _explain_c(
        self,
        qa: FloatArray,
        ua: FloatArray,
        previous: Any,
        cmd: FloatArray | None = None,
        factor: FloatArray | None = None,
    ) -> FilterResult:
        """:meth:`explain` by the C cycle: its output, and the report built from its info.

        Twist mode: ``ua`` the twist's joint velocity ``H⁻¹ Jᵀ v``, ``cmd`` the twist, ``factor``
        the metric's ``L`` (as :meth:`_filter_c`).
        """
        cmd = ua if cmd is None else cmd
        x = self._filter_c(qa, ua, previous, True, factor)
        cyc = self._ccycle
        info = cyc.info()
        if info["status"] < 0:  # refused (on_invalid="stop"): the stop result
            return self._stopped(qa, cmd)
        G, b, level, ka, kb, dist, slack, _ = cyc.rows()
        keys = list(zip(level.tolist(), ka.tolist(), kb.tolist(), strict=True))
        names = self._c_names(keys)
        viol = dist < 0.0
        act = tuple(np.flatnonzero((slack <= _BINDING * (1.0 + np.abs(b))) | viol).tolist())
        n_out = int(np.count_nonzero(viol))
        zone: Zone = ZONE_NAMES[zone_code(n_out, len(act))]  # type: ignore[assignment]
        bits = info["stages"]
        relaxed_keys = set(cyc.relaxed())
        return FilterResult(
            output=x, command=cmd, position=qa, zone=zone, active=act,
            active_names=tuple(names[i] for i in act), slack=readonly(slack),
            constraint_names=tuple(names), stages=tuple(s for bit, s in _C_STAGES if bits & bit),
            dropped=tuple(
                nm for lv, nm in _C_DROPPED if info["relaxed"][lv] or info["dropped"][lv]
            ),
            rate_override=bool(info["dropped"][LEVEL_RATE]), rows=(readonly(G), readonly(b)),
            jerk_override=bool(info["dropped"][LEVEL_JERK]),
            relaxed=tuple(names[r] for r, k in enumerate(keys) if k in relaxed_keys),
            deadline={0: None, 1: "iterations", 2: "time"}[info["deadline"]],
            violations=tuple((names[r], -float(dist[r])) for r in np.flatnonzero(viol).tolist()),
        )  # fmt: skip

    def _c_names(self, keys: list[tuple[int, int, int]]) -> list[str]:
        """The row names of the C cycle's keys (the providers' names)."""
        ws = [p for p in self._providers if isinstance(p, WorkspaceRows)]
        att = () if self._attach is None else self._attach.names()
        out: list[str] = []
        for lv, a, k in keys:
            if lv == LEVEL_JOINT:
                what = "position" if k < 2 else "velocity"
                out.append(f"joint {a} {what} ({'lower' if k % 2 == 0 else 'upper'})")
            elif lv == LEVEL_RATE:
                out.append(f"joint {a} acceleration ({'lower' if k == 0 else 'upper'})")
            elif lv == LEVEL_WORKSPACE and k >= len(ws[a].facet_row_names):
                nf = len(ws[a].facet_row_names)
                se, fi = divmod(k - nf, nf)
                pre = f"workspace {a}: " if len(ws) > 1 else ""
                facet = ws[a].limit.polytope.facet_names[fi]
                out.append(f"{pre}{att[se // 2]} end {se % 2} face {facet}")
            elif lv == LEVEL_JERK:
                out.append(f"joint {a} jerk ({'lower' if k == 0 else 'upper'})")
            elif lv == LEVEL_WORKSPACE:
                out.append(ws[a].facet_row_names[k])
            elif k >= self.dof and a < len(self._obstacles):
                out.append(f"obstacle {a} on {att[k - self.dof]}")
            elif a >= len(self._obstacles):
                out.append(f"link {a - len(self._obstacles)} and link {k}")
            else:
                out.append(f"obstacle {a} on link {k}")
        return out

    @renamed_args(q="position", twist="command")
    def explain_twist(
        self,
        position: ArrayLike,
        command: ArrayLike,
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
            position: Joint position [rad], shape (dof,).
            command: The twist: desired velocity of ``point``, shape (task_dim,) or (6,).
            point: The point the twist is for (a name of the robot's ``points``).
            previous: As in :meth:`explain`.

        Raises:
            InvalidInput: wrong shapes or an unknown point; non-finite values with
                ``on_invalid="raise"``.
        """
        t = self._twist(position, command, point)
        if isinstance(t, FilterResult):
            return t
        qa, va, u, L, frame = t
        if self._ccycle is not None:
            return self._explain_c(qa, u, previous, va, L)
        return self._run(qa, u, va, L, previous, True, frame)

    def _twist(
        self, position: ArrayLike, command: ArrayLike, point: str
    ) -> FilterResult | tuple[FloatArray, FloatArray, FloatArray, FloatArray, Any]:
        """A twist's validated state, joint velocity and metric: ``(q, v, u, L, frame)``.

        ``u = H⁻¹ Jᵀ v`` and ``H = L Lᵀ = JᵀJ + λ²I`` (``L`` C-contiguous, lower triangular);
        the stop result for a non-finite input or ``u`` with ``on_invalid="stop"``.
        """
        qa = self._state("position", position, self.dof, "rad")
        va = real_array("command", command, (None,), allow_nonfinite=True, max_abs=None)
        has_ang = hasattr(self.robot, "angular_jacobian")
        sizes = (self.task_dim, 6) if has_ang and self.task_dim == 3 else (self.task_dim,)
        if va.shape[0] not in sizes:
            raise InvalidInput(
                f"command: expected a twist of shape {' or '.join(f'({s},)' for s in sizes)}, "
                f"got shape {va.shape}"
            )
        if not isinstance(point, str) or point not in self.robot.points:
            raise InvalidInput(
                f"point: expected one of {list(self.robot.points)}, got {describe(point)}"
            )
        if self._bad(qa, va):
            self._invalid(f"non-finite input: position={qa.tolist()}, command={va.tolist()}")
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
            H = J.T @ J
            H.flat[:: n + 1] += self.damping**2  # + λ² I
            L = damped_factor(H)
            u = factor_solve(L, J.T @ va)
        if self._bad(u):
            self._invalid("input too large: the twist's joint velocity overflowed")
            return self._stopped(qa, va)
        return qa, va, u, np.ascontiguousarray(L, dtype=np.float64), frame

    @renamed_args(q="position", twist="command")
    def filter_twist(
        self,
        position: ArrayLike,
        command: ArrayLike,
        *,
        point: str = "tcp",
        previous: ArrayLike | None = None,
    ) -> FloatArray:
        """The filtered joint velocity for a twist [rad/s], shape (dof,) (:meth:`explain_twist`)."""
        if self._ccycle is None:
            return self.explain_twist(position, command, point=point, previous=previous).output
        t = self._twist(position, command, point)
        if isinstance(t, FilterResult):
            return t.output
        qa, _, u, L, _ = t
        return self._filter_c(qa, u, previous, True, L)

    @renamed_args(q="position", qd_cmd="command")
    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Contract alias of :meth:`filter` (joint position, joint-velocity command)."""
        return self.filter(position, command)

    @renamed_args(Q="positions", QD="commands")
    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """:meth:`filter` on N independent states (no remembered output or warm start).

        Args:
            positions: Joint positions [rad], shape (N, dof).
            commands: Commanded joint velocities [rad/s], shape (N, dof).

        Returns:
            Shape (N, dof).

        Raises:
            InvalidInput: wrong shapes, or non-finite rows with ``on_invalid="raise"``.
        """
        n = self.dof
        Qa = real_array("positions", positions, (None, n), allow_nonfinite=True, max_abs=None)
        Va = real_array("commands", commands, (None, n), allow_nonfinite=True, max_abs=None)
        if Qa.shape != Va.shape:
            raise InvalidInput(
                f"positions and commands: expected the same shape (N, {n}), got {Qa.shape} and "
                f"{Va.shape}"
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
                        raise InvalidInput(f"positions, commands row {k}: {exc}") from None
                    continue
                if self._ccycle is not None:
                    out[k] = self._filter_c(Qa[k].copy(), Va[k].copy(), None, False)
                    continue
                c = self._cycle(Qa[k], Va[k], Va[k], self._metric, None, False)
                out[k] = c.output if isinstance(c, FilterResult) else c[1]
        finally:
            self._warm = warm
        return out

    def filter_batch(
        self,
        positions: ArrayLike,
        commands: ArrayLike,
        *,
        previous: ArrayLike | None = None,
        threads: int = 0,
    ) -> FilterBatch:
        """One cycle of N independent states in one call (a vector of environments).

        With the compiled core and a robot that gives its chain as data, every row runs the C
        cycle in one call of ``vf_filter_cycle_batch`` on ``threads`` POSIX threads (the GIL is
        released); each row's output equals :meth:`filter` of that state with ``previous=`` its
        row bit for bit. Otherwise the rows run one after the other on the Python route (same
        results as :meth:`explain` of each). Nothing is remembered: neither the previous output
        nor a warm start.

        Args:
            positions: Joint positions [rad], shape (N, dof).
            commands: Commanded joint velocities [rad/s], shape (N, dof).
            previous: Each row's previous output [rad/s], shape (N, dof), for the acceleration
                rows; ``None``: no acceleration rows. A batch has no jerk rows (it remembers
                no outputs).
            threads: Worker threads, an int >= 0 (0: one per online core).

        Returns:
            A :class:`~velfence.filter.result.FilterBatch`: outputs (N, dof), per-row status,
            stage bits and active-row counts.

        Raises:
            InvalidInput: wrong shapes, or a non-finite row with ``on_invalid="raise"`` (naming
                the first such row); with ``on_invalid="stop"`` such a row gives zero and a
                negative status.
            InvalidParameter: ``threads`` is not an int >= 0.
        """
        n = self.dof
        th = check_positive_int("threads", threads, minimum=0, maximum=64, example=2)
        Qa = self._batch_state("positions", positions, None)
        N = Qa.shape[0]
        Va = self._batch_state("commands", commands, N)
        Pa = None if previous is None else self._batch_state("previous", previous, N)
        if not self._remember:
            Pa = None
        arrays = (Qa, Va) if Pa is None else (Qa, Va, Pa)
        # A row is invalid as filter() sees it: a NaN, an inf or an entry beyond MAX_MAGNITUDE.
        with np.errstate(invalid="ignore"):
            ok = np.abs(np.hstack(arrays)) <= MAX_MAGNITUDE
        bad = ~np.all(ok, axis=1) if N else np.zeros(0, bool)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            names = "positions, commands" if Pa is None else "positions, commands, previous"
            try:
                self._invalid(f"non-finite input in row {k}")
            except InvalidInput as exc:
                raise InvalidInput(f"{names} row {k}: {exc}") from None
        cyc = self._ccycle
        if cyc is not None:
            misses = cyc.deadline_misses
            try:
                out, st, sg, na = cyc.cycle_batch(Qa, Va, Pa, None, th)
            except (TypeError, ValueError) as exc:  # pragma: no cover - checked above
                raise InvalidInput(f"positions, commands: {exc}") from None
            self.deadline_misses += cyc.deadline_misses - misses
            late = bad & (st >= 0)  # finite beyond MAX_MAGNITUDE: refused here, as filter() does
            if late.any():
                out[late], st[late], sg[late] = 0.0, -3, 128  # VF_ERR_NONFINITE, the stop bit
            return FilterBatch(
                output=out, status=st.astype(np.int64), stages=sg.astype(np.int64),
                n_active=na.astype(np.int64),
            )  # fmt: skip
        out = np.zeros((N, n))
        st = np.zeros(N, dtype=np.int64)
        sg = np.zeros(N, dtype=np.int64)
        na = np.zeros(N, dtype=np.int64)
        bits = {name: bit for bit, name in STAGE_BITS}
        warm = self._warm
        self._warm = set()
        try:
            for k in range(N):
                if bad[k]:
                    st[k], sg[k] = -3, bits["stop"]  # VF_ERR_NONFINITE, as the C route
                    continue
                r = self._run(Qa[k], Va[k], Va[k], self._metric, None if Pa is None else Pa[k],
                              False)  # fmt: skip
                out[k] = r.output
                st[k] = {None: 0, "iterations": 3, "time": 4}[r.deadline]
                sg[k] = sum(bits[s] for s in set(r.stages))
                na[k] = len(r.active)
        finally:
            self._warm = warm
        return FilterBatch(output=out, status=st, stages=sg, n_active=na)

    def _batch_state(self, name: str, x: Any, rows: int | None) -> FloatArray:
        """A C-contiguous float64 (rows, dof) array (non-finite entries kept for the check)."""
        n = self.dof
        if rows is not None:  # the message names positions too: its rows set the batch's size
            name = f"{name} (one row per row of positions)"
        a = real_array(name, x, (rows, n), allow_nonfinite=True, max_abs=None)
        return np.ascontiguousarray(a, dtype=np.float64)


document_inits(globals())
