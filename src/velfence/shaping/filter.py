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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._typing import FloatArray
from velfence._validate import (
    MAX_MAGNITUDE,
    check_positive,
    check_text,
    describe,
    finite_scalar,
    readonly,
    real_array,
)
from velfence.errors import InvalidInput, InvalidParameter
from velfence.shaping._kernels import (
    STAGE_NAMES,
    ZONE_NAMES,
    fill_bounds,
    profile_cap,
    zone_code,
)
from velfence.shaping.base import InvalidPolicy, OnInvalid, Zone
from velfence.shaping.profiles import LinearBuffer, ThreeZoneBraking

__all__ = [
    "FilterResult",
    "JointLimits",
    "Kinematics",
    "SafetyFilter",
    "SphereObstacle",
    "WorkspaceLimit",
]

_ = STAGE_NAMES  # the 2-D laws' stage names; the filter reports its own (FilterResult.stages)

#: Priority levels of the rows, highest first.
LEVEL_JOINT = 0
LEVEL_WORKSPACE = 1
LEVEL_OBSTACLE = 2
LEVEL_RATE = 3
LEVEL_NAMES = ("joint limits", "workspace", "obstacles", "acceleration")

_BINDING = 1e-9  # relative slack under which a row counts as active
_CORRECTION_ROUNDS = 4  # discrete-time model checks per cycle

Profile = LinearBuffer | ThreeZoneBraking
# The metric's factor L (W = L Lᵀ): None (identity), a vector (diagonal) or a lower-triangular
# matrix.
_Metric = FloatArray | None


@runtime_checkable
class Kinematics(Protocol):
    """The kinematics a :class:`SafetyFilter` needs.

    Implemented structurally by ``DHChain``, ``PlanarArm`` and ``Puma560`` of
    :mod:`velfence.mechanisms` (``Puma560.fk``/``jacobian`` without a point keep returning the
    tool pose and the 6 x 6 geometric Jacobian; the filter always names the point).

    Obstacles additionally need the capsule geometry of
    :class:`~velfence.mechanisms.chain.SerialChain`: ``link_segments(q)`` (L, 2, 3),
    ``link_radius`` (L,) and ``point_jacobian(q, link, t)`` (3, dof); a twist of shape (6,)
    needs ``angular_jacobian(q)`` (3, dof).
    """

    @property
    def dof(self) -> int:
        """Number of joints."""
        ...

    @property
    def joint_names(self) -> tuple[str, ...]:
        """One name per joint."""
        ...

    @property
    def points(self) -> tuple[str, ...]:
        """Names of the points ``fk`` and ``jacobian`` accept; ``"tcp"`` always."""
        ...

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Position of a named point [m], shape (task_dim,), for joints ``q`` (dof,) [rad]."""
        ...

    def jacobian(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Linear-velocity Jacobian of a named point [m/rad], shape (task_dim, dof)."""
        ...


# ---------------------------------------------------------------------------------- limits
def _vector(name: str, x: Any, n: int | None, what: str, *, nonfinite: bool = False) -> FloatArray:
    a = real_array(
        name, x, (n,), error=InvalidParameter, what=what, allow_nonfinite=nonfinite, max_abs=None
    )
    if np.isnan(a).any():
        raise InvalidParameter(f"{name}: expected {what}, got NaN in {a.tolist()}")
    big = np.isfinite(a) & (np.abs(a) > MAX_MAGNITUDE)
    if big.any():
        raise InvalidParameter(f"{name}: expected magnitudes <= {MAX_MAGNITUDE:g}, got {a[big]}")
    return a


@dataclass(frozen=True)
class JointLimits:
    """Position, velocity and (optional) acceleration limits of every joint.

    Attributes:
        lower: Lower position limit of each joint [rad], shape (n,); ``-inf``: none.
        upper: Upper position limit [rad], shape (n,), ``> lower``; ``+inf``: none.
        max_velocity: Largest joint speed [rad/s], shape (n,), finite and > 0 (a scalar is
            repeated).
        max_acceleration: Largest joint acceleration [rad/s²], shape (n,), > 0, ``inf`` for a
            joint without one; ``None`` (the default): none on any joint.
        names: One name per joint, or ``None``; when given, a :class:`SafetyFilter` checks it
            against the robot's ``joint_names``.

    Raises:
        InvalidParameter: wrong shapes, NaN, ``lower >= upper``, non-positive or infinite
            speeds, non-positive accelerations, or names of the wrong number.
    """

    lower: FloatArray
    upper: FloatArray
    max_velocity: FloatArray
    max_acceleration: FloatArray | None = None
    names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        lo = _vector("lower", self.lower, None, "lower limits [rad] of shape (n,)", nonfinite=True)
        n = lo.shape[0]
        if n < 1:
            raise InvalidParameter("lower: expected at least one joint, got shape (0,)")
        hi = _vector("upper", self.upper, n, f"upper limits [rad] of shape ({n},)", nonfinite=True)
        if lo.max() == math.inf or hi.min() == -math.inf:
            raise InvalidParameter(
                "lower, upper: expected lower < +inf and upper > -inf (infinite limits mean no "
                f"limit on that side), got lower={lo.tolist()}, upper={hi.tolist()}"
            )
        bad = np.flatnonzero(~(hi > lo))
        if bad.size:
            j = int(bad[0])
            raise InvalidParameter(
                f"upper: expected upper > lower on every joint, got upper[{j}]={hi[j]!r} <= "
                f"lower[{j}]={lo[j]!r}"
            )
        vraw: Any = self.max_velocity
        if isinstance(vraw, (int, float, np.integer, np.floating)) and not isinstance(vraw, bool):
            vraw = np.full(n, check_positive("max_velocity", vraw, unit="rad/s"))
        v = _vector("max_velocity", vraw, n, f"joint speeds [rad/s] of shape ({n},)")
        if not np.all(v > 0.0):
            raise InvalidParameter(f"max_velocity: expected speeds > 0 [rad/s], got {v.tolist()}")
        acc: FloatArray | None = None
        if self.max_acceleration is not None:
            araw: Any = self.max_acceleration
            if isinstance(araw, (int, float, np.integer, np.floating)) and not isinstance(
                araw, bool
            ):
                araw = np.full(n, float(araw))
            acc = _vector(
                "max_acceleration", araw, n, f"accelerations [rad/s²] of shape ({n},)",
                nonfinite=True,
            )  # fmt: skip
            if not np.all(acc > 0.0):
                raise InvalidParameter(
                    f"max_acceleration: expected accelerations > 0 [rad/s²] (inf: none), got "
                    f"{acc.tolist()}"
                )
            acc = readonly(acc)
        names = None
        raw_names: Any = self.names
        if raw_names is not None:
            if isinstance(raw_names, (str, bytes)) or not isinstance(raw_names, (list, tuple)):
                raise InvalidParameter(
                    f"names: expected {n} joint names, got {describe(raw_names)}"
                )
            names = tuple(check_text("names", s, max_length=200) for s in raw_names)
            if len(names) != n or len(set(names)) != n:
                raise InvalidParameter(
                    f"names: expected {n} distinct joint names, got {len(names)}: {list(names)}"
                )
        object.__setattr__(self, "lower", readonly(lo))
        object.__setattr__(self, "upper", readonly(hi))
        object.__setattr__(self, "max_velocity", readonly(v))
        object.__setattr__(self, "max_acceleration", acc)
        object.__setattr__(self, "names", names)

    @property
    def dof(self) -> int:
        """Number of joints."""
        return int(self.lower.shape[0])

    @classmethod
    def from_ros2_control(
        cls, mapping: Mapping[str, Any], joint_names: Sequence[str]
    ) -> JointLimits:
        """Limits from a ros2_control ``joint_limits`` mapping, ordered as ``joint_names``.

        The mapping is ``{"joint_limits": {name: {...}}}`` (the YAML file's document) or the
        inner ``{name: {...}}``; each joint's entry has ``has_position_limits``,
        ``min_position``, ``max_position``, ``has_velocity_limits``, ``max_velocity``,
        ``has_acceleration_limits``, ``max_acceleration`` (a limit's value is only read when its
        ``has_…`` flag is true). The joints must be exactly ``joint_names``: a missing or an
        extra joint is refused (a 7-joint file on a 6-joint arm, say), and so is a joint without
        a velocity limit (the filter needs every joint's speed).

        Args:
            mapping: The parsed document.
            joint_names: The robot's joint names, in order.

        Returns:
            The limits (``names`` = ``joint_names``).

        Raises:
            InvalidParameter: wrong structure, joint set or values (the message names the
                joint and the field).
        """
        names = tuple(check_text("joint_names", s, max_length=200) for s in joint_names)
        if not isinstance(mapping, Mapping):
            raise InvalidParameter(
                f"joint_limits: expected a mapping of joint names, got {describe(mapping)}"
            )
        inner = mapping.get("joint_limits", mapping)
        if not isinstance(inner, Mapping):
            raise InvalidParameter(
                f"joint_limits: expected a mapping of joint names, got {describe(inner)}"
            )
        keys = [str(k) for k in inner]
        missing = [s for s in names if s not in inner]
        extra = [k for k in keys if k not in names]
        if missing or extra:
            raise InvalidParameter(
                f"joint_limits: expected the robot's {len(names)} joints {list(names)}, got "
                f"{len(keys)} joint(s) {keys} (missing {missing}, not on this robot {extra})"
            )
        n = len(names)
        lo, hi = np.full(n, -math.inf), np.full(n, math.inf)
        vel, acc = np.zeros(n), np.full(n, math.inf)
        for j, s in enumerate(names):
            entry = inner[s]
            if not isinstance(entry, Mapping):
                raise InvalidParameter(
                    f"joint_limits.{s}: expected a mapping of limit fields, got {describe(entry)}"
                )
            if _flag(entry, s, "has_position_limits"):
                lo[j] = _number(entry, s, "min_position", "rad")
                hi[j] = _number(entry, s, "max_position", "rad")
            if not _flag(entry, s, "has_velocity_limits"):
                raise InvalidParameter(
                    f"joint_limits.{s}.has_velocity_limits: expected true (the safety filter "
                    "needs every joint's max_velocity), got false"
                )
            vel[j] = _number(entry, s, "max_velocity", "rad/s")
            if _flag(entry, s, "has_acceleration_limits"):
                acc[j] = _number(entry, s, "max_acceleration", "rad/s²")
        try:
            return cls(
                lo,
                hi,
                vel,
                acc if np.isfinite(acc).any() else None,
                names=names,
            )
        except InvalidParameter as exc:
            raise InvalidParameter(f"joint_limits: {exc}") from None


def _flag(entry: Mapping[str, Any], joint: str, key: str) -> bool:
    if key not in entry:
        raise InvalidParameter(f"joint_limits.{joint}.{key}: missing (expected true or false)")
    v = entry[key]
    if not isinstance(v, bool):
        raise InvalidParameter(f"joint_limits.{joint}.{key}: expected true or false, got {v!r}")
    return v


def _number(entry: Mapping[str, Any], joint: str, key: str, unit: str) -> float:
    if key not in entry:
        raise InvalidParameter(f"joint_limits.{joint}.{key}: missing (expected a number [{unit}])")
    return finite_scalar(
        f"joint_limits.{joint}.{key}", entry[key], unit=unit, error=InvalidParameter
    )


# ---------------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class WorkspaceLimit:
    """A convex polytope a named point of the robot must stay in.

    Attributes:
        polytope: The allowed region (a :class:`~velfence.geometry.polytope.ConvexPolytope` in
            the robot's task space: 3-D, or 2-D for a ``PlanarArm``) [m].
        point: The guarded point (a name of the robot's ``points``), default ``"tcp"``.
        buffer: Width of the linear buffer inside every facet [m], > 0: the point's approach
            speed toward a facet at distance ``d < buffer`` is at most ``s d / buffer``, ``s``
            the commanded speed of the point (the exact law's buffer).
        spring_gain: Recovery gain outside [1/s], >= 0.
        max_recovery_speed: Cap on the recovery speed [m/s]; default ``spring_gain * buffer``.
        profile: An approach profile instead of the linear buffer (``LinearBuffer`` or
            ``ThreeZoneBraking``, in metres).

    Raises:
        InvalidParameter: a non-polytope, a non-string point or a bad buffer/gain/profile.
    """

    polytope: Any
    point: str = "tcp"
    buffer: float = 0.05
    spring_gain: float = 1.0
    max_recovery_speed: float | None = None
    profile: Profile | None = None

    def __post_init__(self) -> None:
        from velfence.geometry.polytope import ConvexPolytope

        if not isinstance(self.polytope, ConvexPolytope):
            raise InvalidParameter(
                f"polytope: expected a ConvexPolytope, got {describe(self.polytope)}"
            )
        object.__setattr__(self, "point", check_text("point", self.point, max_length=200))
        if self.profile is None:
            prof: Profile = LinearBuffer(
                buffer=self.buffer,
                spring_gain=self.spring_gain,
                max_recovery_speed=self.max_recovery_speed,
            )
        elif isinstance(self.profile, (LinearBuffer, ThreeZoneBraking)):
            prof = self.profile
        else:
            raise InvalidParameter(
                f"profile: expected a LinearBuffer or ThreeZoneBraking, got "
                f"{describe(self.profile)}"
            )
        object.__setattr__(self, "profile", prof)


@dataclass(frozen=True)
class SphereObstacle:
    """A spherical obstacle no capsule link may enter.

    Attributes:
        center: Centre [m], shape (3,) (a (2,) centre of a planar scene gets z = 0).
        radius: Radius [m], >= 0.
        name: Optional label for reports.

    Raises:
        InvalidParameter: a bad centre or radius, or a non-string name.
    """

    center: FloatArray
    radius: float
    name: str | None = None

    def __post_init__(self) -> None:
        c = real_array("center", self.center, error=InvalidParameter, what="2 or 3 numbers [m]")
        if c.shape not in ((2,), (3,)):
            raise InvalidParameter(f"center: expected shape (2,) or (3,) [m], got shape {c.shape}")
        if c.shape == (2,):
            c = np.append(c, 0.0)
        object.__setattr__(self, "center", readonly(c))
        r = check_positive("radius", self.radius, allow_zero=True, unit="m")
        object.__setattr__(self, "radius", r)
        if self.name is not None:
            object.__setattr__(self, "name", check_text("name", self.name, max_length=200))


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
    method: str = "safety-filter"
    _rows: tuple[FloatArray, FloatArray] | None = field(default=None, repr=False)

    @property
    def rows(self) -> tuple[FloatArray, FloatArray]:
        """``(G (m, n), b (m,))``: the rows as built this cycle (before any relaxation)."""
        if self._rows is None:
            return np.zeros((0, self.output.shape[0])), np.zeros(0)
        return self._rows


@dataclass
class _Rows:
    G: list[FloatArray] = field(default_factory=list)
    b: list[float] = field(default_factory=list)
    level: list[int] = field(default_factory=list)
    violated: list[bool] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    # discrete-time model checks: (row index, kind, key) with kind "ws" or "ob"
    check: list[tuple[int, str, tuple[int, int]]] = field(default_factory=list)

    def add(self, g: FloatArray, b: float, level: int, violated: bool, name: str) -> int:
        self.G.append(g)
        self.b.append(b)
        self.level.append(level)
        self.violated.append(violated)
        self.names.append(name)
        return len(self.b) - 1


def _bounds(prm: Profile, dist: FloatArray, speed: FloatArray, idt: float) -> FloatArray:
    """Lower bounds on the approach rate ``n·x`` toward constraints at distances ``dist``.

    The exact law's bound definition (``exact_bounds`` / ``fill_bounds`` of
    :mod:`velfence.shaping._kernels`): inside ``-cap(d, s)``, in discrete time at least ``-d/dt``;
    outside the profile's forced return ``-cap(d)``, in discrete time at most the penetration
    per period. ``speed`` is the cap speed ``s`` of each row (linear profiles scale with it).
    """
    kind, params = prm.kernel_profile
    k = dist.shape[0]
    bnd = np.zeros(k)
    work = np.arange(k, dtype=np.int64)
    for e in range(k):
        d = float(dist[e])
        if d < 0.0:
            r = -profile_cap(kind, params, False, d, 0.0)
            if idt > 0.0 and r > -d * idt:
                r = -d * idt
            bnd[e] = r
        fill_bounds(kind, params, False, dist, work, e, e + 1, float(speed[e]), 1.0, idt, bnd)
    return bnd


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
        on_invalid: ``"raise"`` or ``"stop"`` (zero velocity, zone ``"invalid"``).

    Raises:
        InvalidParameter: a bad parameter, limits of the wrong size or names, a workspace point
            the robot does not have or whose dimension differs from its polytope's, obstacles
            on a robot without capsule geometry.
    """

    __slots__ = (
        "_acc_rows",
        "_has_accel",
        "_joint_prof",
        "_metric",
        "_obstacles",
        "_previous",
        "_q0",
        "_workspace",
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
        on_invalid: OnInvalid = "raise",
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
        self._q0 = np.zeros(n)
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
            dim = np.asarray(robot.fk(self._q0, w.point)).shape[0]
            if w.polytope.dim != dim:
                raise InvalidParameter(
                    f"workspace: the polytope on {w.point!r} is {w.polytope.dim}-D, the robot's "
                    f"task space is {dim}-D"
                )
        self._workspace: tuple[WorkspaceLimit, ...] = tuple(ws)
        self.task_dim = int(np.asarray(robot.fk(self._q0, "tcp")).shape[0])
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
            for attr in ("link_segments", "link_radius", "point_jacobian"):
                if not hasattr(robot, attr):
                    raise InvalidParameter(
                        f"obstacles: the robot {type(robot).__name__} has no capsule geometry "
                        f"({attr!r}); use a DHChain or PlanarArm (Puma560.chain)"
                    )
        self._obstacles: tuple[SphereObstacle, ...] = tuple(obstacles)
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
                    raise InvalidParameter("weights: expected a symmetric (n, n) matrix")
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
    def _rows(self, q: FloatArray, u: FloatArray, previous: FloatArray | None) -> _Rows:
        n = self.dof
        idt = 0.0 if self.dt is None else 1.0 / self.dt
        rows = _Rows()
        lim = self.limits
        eye = np.eye(n)
        for j in range(n):
            v = float(lim.max_velocity[j])
            prof = self._joint_prof[j]
            for side, sign, d in (
                ("lower", 1.0, q[j] - lim.lower[j]),
                ("upper", -1.0, lim.upper[j] - q[j]),
            ):
                if not math.isfinite(d):
                    continue
                b = float(_bounds(prof, np.array([d]), np.array([v]), idt)[0])
                b = min(b, v)  # a recovery no faster than the joint can move
                rows.add(sign * eye[j], b, LEVEL_JOINT, d < 0.0, f"joint {j} position ({side})")
            rows.add(eye[j], -v, LEVEL_JOINT, False, f"joint {j} velocity (lower)")
            rows.add(-eye[j], -v, LEVEL_JOINT, False, f"joint {j} velocity (upper)")
        if self._has_accel and previous is not None and self.dt is not None:
            acc = lim.max_acceleration
            if acc is not None:
                for j in range(n):
                    if math.isfinite(acc[j]):
                        step = float(acc[j]) * self.dt
                        rows.add(
                            eye[j], float(previous[j]) - step, LEVEL_RATE, False,
                            f"joint {j} acceleration (lower)",
                        )  # fmt: skip
                        rows.add(
                            -eye[j], -(float(previous[j]) + step), LEVEL_RATE, False,
                            f"joint {j} acceleration (upper)",
                        )  # fmt: skip
        for w_i, w in enumerate(self._workspace):
            p = np.asarray(self.robot.fk(q, w.point), dtype=float)
            J = np.asarray(self.robot.jacobian(q, w.point), dtype=float)
            poly = w.polytope
            dist = poly.normals @ p - poly.offsets
            s = float(np.linalg.norm(J @ u))
            prof = w.profile if w.profile is not None else LinearBuffer(buffer=w.buffer)
            bnd = _bounds(prof, dist, np.full(dist.shape[0], s), idt)
            label = "TCP" if w.point == "tcp" else w.point
            prefix = f"workspace {w_i}: " if len(self._workspace) > 1 else ""
            NJ = poly.normals @ J
            for i in range(dist.shape[0]):
                if bnd[i] == -math.inf:
                    continue
                r = rows.add(
                    NJ[i], float(bnd[i]), LEVEL_WORKSPACE, bool(dist[i] < 0.0),
                    f"{prefix}{label} face {poly.facet_names[i]}",
                )  # fmt: skip
                if idt > 0.0 and dist[i] >= 0.0:
                    rows.check.append((r, "ws", (w_i, i)))
        if self._obstacles:
            self._obstacle_rows(q, u, idt, rows)
        return rows

    def _obstacle_rows(self, q: FloatArray, u: FloatArray, idt: float, rows: _Rows) -> None:
        from velfence.geometry.primitives import points_segments_distances, sphere_capsule_distance

        robot: Any = self.robot
        segs = np.asarray(robot.link_segments(q), dtype=float)
        radii = np.asarray(robot.link_radius, dtype=float).reshape(-1)
        centers = np.array([o.center for o in self._obstacles])
        _, clear = points_segments_distances(centers, segs[:, 0], segs[:, 1], radii)
        vmax = self.limits.max_velocity
        prof = LinearBuffer(buffer=self.obstacle_buffer, spring_gain=self.spring_gain)
        for i, o in enumerate(self._obstacles):
            for link in range(segs.shape[0]):
                c0 = float(clear[i, link]) - o.radius
                if c0 >= self.obstacle_buffer and idt == 0.0:
                    continue  # beyond the buffer the linear cap is infinite
                d, _, t, nrm = sphere_capsule_distance(
                    o.center, o.radius, segs[link, 0], segs[link, 1], float(radii[link])
                )
                Jc = np.asarray(robot.point_jacobian(q, link, t), dtype=float)
                g = nrm @ Jc
                if idt > 0.0 and d >= self.obstacle_buffer:
                    reach = float(np.abs(Jc).sum(axis=0) @ vmax) * self.dt if self.dt else 0.0
                    if d > 2.0 * reach:
                        continue  # not reachable in one period, even at full joint speed
                s = float(np.linalg.norm(Jc @ u))
                b = float(_bounds(prof, np.array([d]), np.array([s]), idt)[0])
                if b == -math.inf:
                    continue
                r = rows.add(g, b, LEVEL_OBSTACLE, d < 0.0, f"obstacle {i} on link {link}")
                if idt > 0.0 and d >= 0.0:
                    rows.check.append((r, "ob", (i, link)))

    # ------------------------------------------------------------------ solve
    def _project(
        self, u: FloatArray, G: FloatArray, b: FloatArray, L: _Metric
    ) -> tuple[bool, FloatArray]:
        from velfence.geometry.projection import project

        if G.shape[0] == 0:
            return True, u.copy()
        if L is None:
            res = project(u, G, b)
            return res.feasible, res.x
        if L.ndim == 1:  # diagonal metric: L = diag(lv)
            res = project(u * L, G / L[None, :], b)
            return res.feasible, res.x / L
        # y = Lᵀ x: G x = G L⁻ᵀ y.
        GL = np.linalg.solve(L, G.T).T
        res = project(L.T @ u, GL, b)
        x: FloatArray = np.asarray(np.linalg.solve(L.T, res.x), dtype=np.float64)
        if res.feasible:
            # Round-off of the back-substitution: repair along the violated rows (a few ulps).
            for _ in range(4):
                gap = b - G @ x
                k = int(np.argmax(gap))
                if not gap[k] > 0.0:
                    break
                gk = G[k]
                x = x + (gap[k] * (1.0 + 1e-12) + 1e-300) * gk / float(gk @ gk)
        return res.feasible, x

    def _next_distances(self, q: FloatArray, x: FloatArray, rows: _Rows) -> dict[int, float]:
        """True next distance of every checked row at ``q + x dt`` (model check)."""
        from velfence.geometry.primitives import points_segments_distances

        q1 = q + x * (self.dt or 0.0)
        out: dict[int, float] = {}
        pts: dict[int, FloatArray] = {}
        clear = None
        for r, kind, (a, i) in rows.check:
            if kind == "ws":
                if a not in pts:
                    w = self._workspace[a]
                    pts[a] = np.asarray(self.robot.fk(q1, w.point), dtype=float)
                poly = self._workspace[a].polytope
                out[r] = float(poly.normals[i] @ pts[a] - poly.offsets[i])
            else:
                if clear is None:
                    robot: Any = self.robot
                    segs = np.asarray(robot.link_segments(q1), dtype=float)
                    radii = np.asarray(robot.link_radius, dtype=float).reshape(-1)
                    centers = np.array([o.center for o in self._obstacles])
                    _, clear = points_segments_distances(centers, segs[:, 0], segs[:, 1], radii)
                out[r] = float(clear[a, i]) - self._obstacles[a].radius
        return out

    def _solve_ladder(
        self, q: FloatArray, u: FloatArray, rows: _Rows, L: _Metric
    ) -> tuple[FloatArray, FloatArray, list[str], list[str], bool]:
        """The priority ladder; returns (x, b used, dropped levels, stages, rate_override)."""
        n = self.dof
        m = len(rows.b)
        G = np.array(rows.G).reshape(m, n)
        b0 = np.array(rows.b, dtype=float)
        level = np.array(rows.level, dtype=np.int64)
        viol = np.array(rows.violated, dtype=bool)
        present = set(rows.level)
        # Each step: (keep mask, bounds, dropped label, stage label)
        steps: list[tuple[FloatArray, FloatArray, str | None, str | None]] = []
        keep = np.ones(m, dtype=bool)
        b = b0.copy()
        steps.append((keep.copy(), b.copy(), None, None))
        if LEVEL_RATE in present:
            keep &= level != LEVEL_RATE
            steps.append((keep.copy(), b.copy(), "acceleration", "dropped acceleration"))
        for lv in (LEVEL_OBSTACLE, LEVEL_WORKSPACE):
            if lv not in present:
                continue
            rec = (level == lv) & viol
            if rec.any():
                b = np.where(rec, np.minimum(b, 0.0), b)
                steps.append((keep.copy(), b.copy(), LEVEL_NAMES[lv], f"relaxed {LEVEL_NAMES[lv]}"))
            keep &= level != lv
            steps.append((keep.copy(), b.copy(), LEVEL_NAMES[lv], f"dropped {LEVEL_NAMES[lv]}"))
        rec = (level == LEVEL_JOINT) & viol
        if rec.any():
            b = np.where(rec, np.minimum(b, 0.0), b)
            steps.append((keep.copy(), b.copy(), "joint limits", "relaxed joint limits"))
        dropped: list[str] = []
        stages: list[str] = []
        for mask, bb, drop, stage in steps:
            if drop is not None and drop not in dropped:
                dropped.append(drop)
            if stage is not None:
                stages.append(stage)
            bb = bb.copy()
            ok, x = self._project(u, G[mask], bb[mask], L)
            if ok and rows.check:
                ok, x, tightened = self._model_check(q, u, G, bb, mask, rows, x, L)
                if tightened:
                    stages.append("model-check")
            if ok and np.all(np.isfinite(x)):
                return x, bb, dropped, stages, "acceleration" in dropped
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
        return real_array(
            name, x, (width,), what=f"{width} numbers [{unit}]", allow_nonfinite=True,
            max_abs=None,
        )  # fmt: skip

    def _stopped(self, q: FloatArray, cmd: FloatArray) -> FilterResult:
        return FilterResult(
            output=np.zeros(self.dof), command=cmd, position=q, zone="invalid", active=(),
            active_names=(), slack=np.zeros(0), constraint_names=(), stages=("stop",),
            dropped=(), rate_override=False,
        )  # fmt: skip

    def _bad(self, *arrays: FloatArray) -> bool:
        return not all(
            bool(np.all(np.isfinite(a)) and np.all(np.abs(a) <= MAX_MAGNITUDE)) for a in arrays
        )

    def _run(
        self,
        q: FloatArray,
        u: FloatArray,
        cmd: FloatArray,
        L: _Metric,
        previous: Any,
        remember: bool,
    ) -> FilterResult:
        prev: FloatArray | None = None
        if previous is not None:
            prev = self._state("previous", previous, self.dof, "rad/s")
            if self._bad(prev):
                self._invalid(f"non-finite previous={prev.tolist()}")
                return self._stopped(q, cmd)
        elif remember:
            prev = self._previous
        with np.errstate(all="ignore"):
            rows = self._rows(q, u, prev)
            x, _, dropped, stages, override = self._solve_ladder(q, u, rows, L)
        if not np.all(np.isfinite(x)):
            self._invalid("input too large: the filtered velocity overflowed")
            return self._stopped(q, cmd)
        m = len(rows.b)
        G = np.array(rows.G).reshape(m, self.dof)
        b0 = np.array(rows.b, dtype=float)
        with np.errstate(invalid="ignore"):
            slack = np.where(np.isfinite(b0), G @ x - b0, math.inf)
        viol = np.array(rows.violated, dtype=bool)
        tol = _BINDING * (1.0 + np.abs(np.where(np.isfinite(b0), b0, 0.0)))
        act = tuple(int(i) for i in np.flatnonzero((slack <= tol) | viol))
        n_out = int(viol.sum())
        zone: Zone = ZONE_NAMES[zone_code(n_out, len(act))]  # type: ignore[assignment]
        pre: list[str] = []
        if not np.array_equal(x, u):
            pre.append("projection")
        if n_out:
            pre.append("recovery")
        if remember and self._has_accel:
            self._previous = readonly(x.copy())
        return FilterResult(
            output=x, command=cmd, position=q, zone=zone, active=act,
            active_names=tuple(rows.names[i] for i in act), slack=readonly(slack),
            constraint_names=tuple(rows.names), stages=tuple(pre + stages),
            dropped=tuple(dropped), rate_override=override,
            _rows=(readonly(G), readonly(b0)),
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
        """The filtered joint velocity [rad/s], shape (dof,) (:meth:`explain`'s output)."""
        return self.explain(q, qd_cmd, previous=previous).output

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
        J = np.asarray(self.robot.jacobian(qa, point), dtype=float)
        if va.shape[0] == 6 and self.task_dim == 3:
            robot: Any = self.robot
            J = np.vstack((J, np.asarray(robot.angular_jacobian(qa), dtype=float)))
        with np.errstate(all="ignore"):
            H = J.T @ J + (self.damping**2) * np.eye(self.dof)
            L = np.linalg.cholesky(H) if np.all(np.isfinite(H)) else np.full_like(H, np.nan)
            u = np.linalg.solve(L.T, np.linalg.solve(L, J.T @ va))
        if self._bad(u):
            self._invalid("input too large: the twist's joint velocity overflowed")
            return self._stopped(qa, va)
        return self._run(qa, u, va, L, previous, True)

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
