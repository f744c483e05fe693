r"""Row providers: each safety limit turns into rows ``G x >= b`` of the filter's problem.

In the style of mink's ``Limit`` -> ``Constraint(G, h)``: a provider declares its priority
``level`` (:data:`LEVEL_JOINT` 0, :data:`LEVEL_WORKSPACE` 1, :data:`LEVEL_OBSTACLE` 2,
:data:`LEVEL_RATE` 3, :data:`LEVEL_JERK` 4; the ladder of :mod:`velfence.filter.ladder` relaxes
by level) and, every cycle, returns a :class:`RowBlock` from the cycle's :class:`RowContext`
(``q``, the command, the previous outputs, ``dt`` and the one shared
:class:`~velfence.filter.kinematics.KinematicsFrame`):

* ``G`` (k, n), ``b`` (k,): the rows;
* ``violated`` (k,): the row's constraint is violated now (geometric distance < 0): its bound is
  a *recovery* bound (``b > 0`` possible), the only kind the ladder may relax;
* ``keys`` (k,): a stable integer per row within the provider (facet, joint side, obstacle-link
  pair): with the provider's index, the key of the warm start from the previous cycle;
* ``names``: made only when asked (``FilterResult`` asks; ``SafetyFilter.filter`` never does), a
  callable, because formatting a string per row costs more than building the row;
* ``distance`` (k,) or ``None``: the current signed distance of each row (a violated row's
  depth in ``FilterResult.violations``); the discrete-time model check follows the rows of a
  provider that also implements ``next_distances(frame, block)``, the same distances at another
  pose (workspace and obstacles).

A user's own provider needs only ``level``, ``label`` and ``rows`` (:class:`RowProvider`); see
``docs/safety_filter.md`` and ``examples/custom_row_provider.py``.

The bound of every built-in row is the exact law's one bound definition
(:func:`velfence.shaping._kernels.bounds_from_distances` with
:func:`~velfence.shaping._kernels.fill_bounds`): inside ``-cap(d, s)`` and in discrete time at
least ``-d/dt``; outside the profile's forced return, in discrete time at most the penetration per
period (derivation: ``docs/safety_filter.md``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from velfence._deprecate import renamed_args
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence.filter.kinematics import KinematicsFrame, checked
from velfence.filter.limits import JointLimits, Profile, SphereObstacle, WorkspaceLimit
from velfence.geometry.primitives import segment_pair_params
from velfence.shaping.profiles import LinearBuffer
from velfence.shaping.shared_kernels import bounds_from_distances, fill_bounds

__all__ = [
    "LEVEL_JERK",
    "LEVEL_JOINT",
    "LEVEL_NAMES",
    "LEVEL_OBSTACLE",
    "LEVEL_RATE",
    "LEVEL_WORKSPACE",
    "JointAccelerationLimit",
    "JointJerkLimit",
    "JointPositionLimit",
    "JointVelocityLimit",
    "ObstacleRows",
    "RowBlock",
    "RowContext",
    "RowProvider",
    "SelfCollisionRows",
    "WorkspaceRows",
    "workspace_bounds",
]

#: Priority levels of the rows, highest priority first.
LEVEL_JOINT = 0
LEVEL_WORKSPACE = 1
LEVEL_OBSTACLE = 2
LEVEL_RATE = 3
LEVEL_JERK = 4
LEVEL_NAMES = ("joint limits", "workspace", "obstacles", "acceleration", "jerk")

_IntArray = Any


@dataclass(frozen=True)
class RowContext:
    """What a provider may read in one cycle.

    Attributes:
        q: Joint position [rad], shape (n,), finite.
        command: The joint-velocity command the rows are built for [rad/s], shape (n,) (after
            the filter's command cap; in twist mode the damped least-squares joint velocity).
        previous: The previous output [rad/s], shape (n,), or ``None``.
        dt: Control period [s] or ``None`` (continuous time).
        frame: The cycle's kinematics (:class:`~velfence.filter.kinematics.KinematicsFrame`),
            shared by every provider: each quantity computed once.
        previous2: The output before ``previous`` [rad/s], shape (n,), or ``None`` (the jerk
            rows need both).
    """

    q: FloatArray
    command: FloatArray
    previous: FloatArray | None
    dt: float | None
    frame: KinematicsFrame
    previous2: FloatArray | None = None


@dataclass(frozen=True, eq=False)
class RowBlock:
    """One provider's rows of one cycle (module docstring).

    Attributes:
        G: Row normals, shape (k, n).
        b: Lower bounds, shape (k,) (finite, or ``-inf`` for a row without a bound).
        violated: Whether each row's constraint is violated now, shape (k,), bool.
        keys: A stable integer per row within the provider, shape (k,).
        names: Row names, or a callable making them (called only when names are asked for).
        distance: Current signed distance of each row to its constraint ([m]; [rad] for a
            joint position), shape (k,), negative when violated: a violated row's depth in
            :attr:`FilterResult.violations <velfence.filter.result.FilterResult.violations>`,
            and, from a provider with ``next_distances``, what the discrete-time model check
            follows; ``None``: none (no model check, no depth).
        data: The provider's own data for ``next_distances`` (opaque to the filter).
    """

    G: FloatArray
    b: FloatArray
    violated: Any
    keys: _IntArray
    names: Sequence[str] | Callable[[], Sequence[str]]
    distance: FloatArray | None = None
    data: Any = None

    @property
    def size(self) -> int:
        """Number of rows ``k`` (0 for a ``b`` that is not a vector: refused when checked)."""
        shape = np.shape(self.b)
        return int(shape[0]) if len(shape) == 1 else 0


@runtime_checkable
class RowProvider(Protocol):
    """A source of rows taking part in the filter's priority ladder.

    ``level``: the priority (one of the ``LEVEL_*`` constants). ``label``: a short name for
    messages. ``rows(ctx)``: the cycle's :class:`RowBlock`, or ``None`` for no rows. Optional:
    ``next_distances(frame, block)`` (k,): the block's geometric distances at another pose, for
    the discrete-time model check of rows that carry a ``distance``.
    """

    level: int
    label: str

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """This cycle's rows."""
        ...


# ------------------------------------------------------------------------------- bounds
#: The bound kernels: (bounds_from_distances, fill_bounds) in plain Python, or (None, core):
#: the compiled core's ``rate_bounds`` (the same definition in C, bit for bit).
BoundKernels = tuple[Any, Any]
PLAIN_BOUNDS: BoundKernels = (bounds_from_distances, fill_bounds)


def rate_bounds(
    prm: Profile, dist: FloatArray, speed: float, idt: float, kern: BoundKernels = PLAIN_BOUNDS
) -> FloatArray:
    """Lower bounds on the approach rate ``n·x`` toward constraints at distances ``dist``.

    The exact law's bound definition at cap speed ``speed``; rows the command does not bind get
    the same definition from ``fill_bounds`` (``-inf`` where the profile sets no cap and there is
    no period): the output may move a point faster than the command does. Each row's bound
    depends on its own distance only, so rows of one profile and speed share a call.
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
        rest = np.ones(k, dtype=bool)
        rest[work[:m]] = False
        idx = np.flatnonzero(rest).astype(np.int64)
        fill(kind, params, False, dist, idx, 0, idx.shape[0], speed, 1.0, idt, bnd)
    return bnd


def workspace_bounds(
    profile: Profile, distances: FloatArray, speed: float, dt: float | None
) -> FloatArray:
    """The filter's workspace-facet bounds: lower bounds on ``n_i·ṗ`` [m/s].

    What :class:`WorkspaceRows` puts on the right of its rows ``(n_iᵀ J_p) x >= b_i``, exposed
    for other formulations of the same rows (``velfence.integrations.mink_limits``). Inputs are
    trusted (validated by the caller).

    Args:
        profile: The approach profile (``LinearBuffer`` or ``ThreeZoneBraking``, in metres).
        distances: The facets' signed distances [m] (positive inside), finite float64, (k,).
        speed: The cap speed [m/s], >= 0 (the filter passes the point's commanded speed).
        dt: The control period [s], or ``None`` (continuous time).

    Returns:
        The bounds [m/s], shape (k,); ``-inf`` marks a facet without a bound.
    """
    return rate_bounds(profile, distances, speed, 0.0 if dt is None else 1.0 / dt)


def _bound1(prm: Profile, d: float, speed: float, idt: float) -> float:
    """:func:`rate_bounds` of one row on Python floats (cheaper for one row)."""
    kind, params = prm.kernel_profile
    bnd = [0.0]
    work = [0]
    if bounds_from_distances([d], 1, speed, kind, params, False, idt, False, bnd, work)[0] == 0:
        fill_bounds(kind, params, False, [d], [0], 0, 1, speed, 1.0, idt, bnd)
    return bnd[0]


def _point_jacobians(frame: KinematicsFrame, links: Any, ts: Any, n: int) -> FloatArray:
    """The Jacobians (k, 3, n) of the points at parameters ``ts`` of the capsule ``links``.

    The frame's batch ``point_jacobians`` when it has one, else one ``point_jacobian`` each;
    checked for shape and finiteness.
    """
    links = np.asarray(links)
    batch = getattr(frame, "point_jacobians", None)
    if batch is not None:
        Js = batch(links, ts)
    else:
        Js = [
            frame.point_jacobian(k, tk)
            for k, tk in zip(links.tolist(), np.asarray(ts).tolist(), strict=True)
        ]
    return checked("kinematics(q).point_jacobian(link, t)", Js, (links.shape[0], 3, n))


def _idt(dt: float | None) -> float:
    return 0.0 if dt is None else 1.0 / dt


# ------------------------------------------------------------------------------- joints
class JointPositionLimit:
    """Joint position rows with their braking profile (level :data:`LEVEL_JOINT`).

    Toward each finite limit at distance ``d`` the approach speed is capped by the joint's
    profile (three-zone braking with an acceleration limit, else a linear buffer), never above
    the joint's ``max_speed``; beyond a limit the profile's forced return. Row ``e_j x >= b``
    (lower side, key ``2 j``) or ``-e_j x >= b`` (upper side, key ``2 j + 1``).

    Args:
        limits: The joint limits.
        profiles: One approach profile per joint (radians).
        kernels: The bound kernels (plain or compiled, the same values).
    """

    level = LEVEL_JOINT
    label = "joint position"

    def __init__(
        self,
        limits: JointLimits,
        profiles: Sequence[Profile],
        *,
        kernels: BoundKernels = PLAIN_BOUNDS,
    ) -> None:
        n = limits.dof
        self._n = n
        self._kern = kernels
        self._sgn = np.tile([1.0, -1.0], n)
        self._lohi = np.stack(
            [-np.asarray(limits.lower, float), np.asarray(limits.upper, float)], 1
        ).ravel()
        self._finite = np.isfinite(np.stack([limits.lower, limits.upper], axis=1).ravel())
        groups: dict[tuple[Any, ...], tuple[Profile, float, list[int]]] = {}
        for side in np.flatnonzero(self._finite).tolist():
            j = side // 2
            v = float(limits.max_speed[j])
            key = (*profiles[j].kernel_profile, v)
            groups.setdefault(key, (profiles[j], v, []))[2].append(side)
        self._groups = tuple(
            (p, v, np.array(sides, dtype=np.int64)) for p, v, sides in groups.values()
        )
        self._vside = np.repeat(np.asarray(limits.max_speed, dtype=float), 2)
        self._G = np.zeros((2 * n, n))
        self._G[0::2] = np.eye(n)
        self._G[1::2] = -np.eye(n)
        self._keys = np.arange(2 * n, dtype=np.int64)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """Position rows of every finite limit within the profile's reach."""
        n = self._n
        idt = _idt(ctx.dt)
        dpos = np.repeat(ctx.q, 2) * self._sgn + self._lohi  # q - lower, upper - q
        grp = self._groups
        if len(grp) == 1 and grp[0][2].shape[0] == 2 * n:
            bpos = rate_bounds(grp[0][0], dpos, grp[0][1], idt, self._kern)
        else:
            bpos = np.full(2 * n, -math.inf)
            for prof, v, sides in grp:
                bpos[sides] = rate_bounds(prof, dpos[sides], v, idt, self._kern)
        b = np.minimum(bpos, self._vside)  # a recovery no faster than the joint can move
        keep = self._finite & (bpos != -math.inf)
        if keep.all():
            return RowBlock(
                self._G, b, dpos < 0.0, self._keys, _joint_namer(self._keys, "position"),
                distance=dpos,
            )  # fmt: skip
        idx = np.flatnonzero(keep)
        keys = self._keys[idx]
        return RowBlock(
            self._G[idx], b[idx], dpos[idx] < 0.0, keys, _joint_namer(keys, "position"),
            distance=dpos[idx],
        )  # fmt: skip


def _joint_namer(keys: Any, what: str) -> Callable[[], list[str]]:
    def names() -> list[str]:
        return [
            f"joint {k // 2} {what} ({'lower' if k % 2 == 0 else 'upper'})" for k in keys.tolist()
        ]

    return names


class JointVelocityLimit:
    """Joint speed rows ``|x_j| <= max_speed_j`` (level :data:`LEVEL_JOINT`, never violated).

    Args:
        limits: The joint limits.
    """

    level = LEVEL_JOINT
    label = "joint velocity"

    def __init__(self, limits: JointLimits) -> None:
        n = limits.dof
        self._G = np.zeros((2 * n, n))
        self._G[0::2] = np.eye(n)
        self._G[1::2] = -np.eye(n)
        self._b = -np.repeat(np.asarray(limits.max_speed, dtype=float), 2)
        self._viol = np.zeros(2 * n, dtype=bool)
        self._keys = np.arange(2 * n, dtype=np.int64)

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The constant speed rows."""
        return RowBlock(
            self._G, self._b.copy(), self._viol, self._keys, _joint_namer(self._keys, "velocity")
        )


class _JointIntervals:
    """Per-joint interval rows ``|x_j - c_j| <= h_j`` for the joints with a finite limit.

    Row ``2 j`` is ``x_j >= c_j - h_j``, row ``2 j + 1`` is ``-x_j >= -(c_j + h_j)``; the
    providers below give the centre ``c`` and the half-width ``h`` (a limit times a power of
    ``dt``).
    """

    def __init__(self, limit: FloatArray | None, n: int, what: str) -> None:
        self._joints = (
            np.zeros(0, dtype=np.int64) if limit is None else np.flatnonzero(np.isfinite(limit))
        )
        eye = np.eye(n)
        self._G = np.zeros((2 * self._joints.shape[0], n))
        self._G[0::2] = eye[self._joints]
        self._G[1::2] = -eye[self._joints]
        self._limit = np.zeros(0) if limit is None else np.asarray(limit, dtype=float)[self._joints]
        self._keys = np.stack([2 * self._joints, 2 * self._joints + 1], 1).ravel()
        self._what = what

    def _block(self, c: FloatArray, step: FloatArray) -> RowBlock:
        b = np.empty(2 * c.shape[0])
        b[0::2] = c - step
        b[1::2] = -(c + step)
        return RowBlock(
            self._G, b, np.zeros(b.shape[0], dtype=bool), self._keys,
            _joint_namer(self._keys, self._what),
        )  # fmt: skip


class JointAccelerationLimit(_JointIntervals):
    """Acceleration rows ``|x - previous| <= a dt`` (level :data:`LEVEL_RATE`).

    Only with ``dt`` and a previous output; joints without a finite acceleration limit have none.
    The ladder drops these rows first (comfort loses to safety: ``rate_override``).

    Args:
        limits: The joint limits (``max_acceleration`` [rad/s²]).
    """

    level = LEVEL_RATE
    label = "joint acceleration"

    def __init__(self, limits: JointLimits) -> None:
        super().__init__(limits.max_acceleration, limits.dof, "acceleration")

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows around the previous output, or ``None`` without one or without ``dt``."""
        if ctx.previous is None or ctx.dt is None or self._joints.shape[0] == 0:
            return None
        return self._block(ctx.previous[self._joints], self._limit * ctx.dt)


class JointJerkLimit(_JointIntervals):
    r"""Jerk rows ``|x - (2 previous - previous2)| <= J dt²`` (level :data:`LEVEL_JERK`).

    With the last two outputs ``p = previous`` and ``p2 = previous2`` the last acceleration is
    ``(p - p2)/dt``; the next one, ``(x - p)/dt``, may differ from it by at most ``J dt`` (the
    jerk limit ``J`` times one period), so ``x`` lies in the interval of half-width ``J dt²``
    around ``c = p + (p - p2)`` (computed so, in C too): rows ``x_j >= c_j - J_j dt²`` (key
    ``2 j``) and ``-x_j >= -(c_j + J_j dt²)`` (key ``2 j + 1``). Only with ``dt`` and both
    outputs; joints without a finite jerk limit have none. The ladder drops these rows first,
    before the acceleration rows (``jerk_override``; ``docs/derivations.md``).

    Args:
        limits: The joint limits (``max_jerk`` [rad/s³]).
    """

    level = LEVEL_JERK
    label = "joint jerk"

    def __init__(self, limits: JointLimits) -> None:
        super().__init__(limits.max_jerk, limits.dof, "jerk")

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows around ``2 previous - previous2``, or ``None`` without both or ``dt``."""
        if (
            ctx.previous is None
            or ctx.previous2 is None
            or ctx.dt is None
            or self._joints.shape[0] == 0
        ):
            return None
        pj = ctx.previous[self._joints]
        return self._block(pj + (pj - ctx.previous2[self._joints]), self._limit * (ctx.dt * ctx.dt))


# ------------------------------------------------------------------------------- workspace
class WorkspaceRows:
    """A convex polytope on a named point (level :data:`LEVEL_WORKSPACE`).

    For every facet ``i`` (key ``i``) of ``limit.polytope``: ``(n_iᵀ J_p) x >= b_i`` from the
    facet's distance and the point's commanded speed ``‖J_p u‖`` (the exact law's bound).

    Args:
        limit: The workspace limit (polytope, point, profile).
        dim: The robot's task dimension (the polytope's, checked by the filter).
        prefix: Prefix of the row names (``"workspace 1: "`` with several limits).
        kernels: The bound kernels.
    """

    level = LEVEL_WORKSPACE
    label = "workspace"

    def __init__(
        self,
        limit: WorkspaceLimit,
        *,
        dim: int,
        prefix: str = "",
        kernels: BoundKernels = PLAIN_BOUNDS,
    ) -> None:
        self.limit = limit
        self._dim = dim
        self._kern = kernels
        self.profile: Profile = (
            limit.profile if limit.profile is not None else LinearBuffer(buffer=limit.buffer)
        )
        poly = limit.polytope
        self._N = np.asarray(poly.normals, dtype=float)
        self._o = np.asarray(poly.offsets, dtype=float)
        point = "TCP" if limit.point == "tcp" else limit.point
        #: Row name of every facet (the rows keep those within the profile's reach).
        self.facet_row_names = tuple(f"{prefix}{point} face {nm}" for nm in poly.facet_names)
        self.label = f"workspace on {limit.point!r}"

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The facet rows within the profile's reach."""
        pt = self.limit.point
        n = ctx.q.shape[0]
        p = checked(f"kinematics(q).point({pt!r})", ctx.frame.point(pt), (self._dim,))
        J = checked(f"kinematics(q).jacobian({pt!r})", ctx.frame.jacobian(pt), (self._dim, n))
        dist = self._N @ p - self._o
        ju = J @ ctx.command
        s = math.sqrt(float(ju @ ju))
        bnd = rate_bounds(self.profile, dist, s, _idt(ctx.dt), self._kern)
        kept = np.flatnonzero(bnd != -math.inf)
        names = self.facet_row_names
        return RowBlock(
            (self._N @ J)[kept], bnd[kept], dist[kept] < 0.0, kept,
            lambda: [names[i] for i in kept.tolist()], distance=dist[kept], data=kept,
        )  # fmt: skip

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's facet distances [m] at the pose of ``frame``, shape (k,)."""
        pt = self.limit.point
        p = checked(f"kinematics(q).point({pt!r})", frame.point(pt), (self._dim,))
        out: FloatArray = self._N[block.data] @ p - self._o[block.data]
        return out


# ------------------------------------------------------------------------------- obstacles
def link_speed_bounds(segs: FloatArray, max_speed: FloatArray) -> FloatArray:
    """A bound on the speed of every point of each capsule link [m/s], shape (L,).

    ``|ṗ| <= Σ_{j <= k} v_j max(|a_k − P_j|, |b_k − P_j|)`` for every point of link ``k``
    (``P_j`` the joint points, the links' starts and the last link's end, ``v_j`` the joints'
    ``max_speed``): the reach of the obstacle, self-collision and separation rows. Internal API
    of :mod:`velfence.filter` (trusted inputs: ``segs`` (L, 2, 3), ``max_speed`` (n,)).
    """
    nl = segs.shape[0]
    P = np.concatenate([segs[:, 0], segs[-1:, 1]])
    nj = min(nl, max_speed.shape[0])
    M = np.linalg.norm(P[:, None, :] - P[None, :nj], axis=2)
    lever = np.maximum(M[:-1], M[1:])
    out: FloatArray = np.tril(lever) @ max_speed[:nj]
    return out


def _clearances(
    segs: FloatArray, centres: FloatArray, srad: FloatArray, radii: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Every (obstacle, link) pair at once: ``(clearance, t, X, R, |R|)``, each (k, L[, 3]).

    The arithmetic of :func:`velfence.geometry.primitives.sphere_capsule_distance`: closest
    axis point ``X`` at fraction ``t``, ``R = X - centre``, clearance ``|R| - r_s - r_link``.
    """
    A = segs[:, 0]
    B = segs[:, 1]
    D = B - A
    dd = (D * D).sum(axis=1)
    W = centres[:, None, :] - A[None, :, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip((W * D[None, :, :]).sum(axis=2) / dd[None, :], 0.0, 1.0)
    t[:, dd == 0.0] = 0.0
    tt = t[:, :, None]  # a + t (b - a), exact at both ends
    X = np.where(tt <= 0.5, A[None] + tt * D[None], B[None] - (1.0 - tt) * D[None])
    R = X - centres[:, None, :]
    dist = np.sqrt((R * R).sum(axis=2))
    return dist - srad[:, None] - radii[None, :], t, X, R, dist


class ObstacleRows:
    """Sphere obstacles against the robot's capsule links (level :data:`LEVEL_OBSTACLE`).

    For every (obstacle ``i``, link ``k``) pair within the linear buffer (or, with ``dt``,
    within one period's reach at full joint speed; key ``i L + k``): the link's critical point
    (closest axis point to the centre), the direction ``n`` from the centre and the point's
    Jacobian ``J_c``: ``(nᵀ J_c) x >= b`` from a linear buffer of width ``buffer``.

    Args:
        obstacles: The spheres.
        link_radius: Capsule radius of every link [m], shape (L,) or (1,).
        buffer: Width of the linear buffer [m].
        spring_gain: Recovery gain outside [1/s].
        max_speed: Joint speed limits [rad/s], shape (n,) (the reach bound); ``max_velocity``
            is its deprecated name (warns; goes in 0.3).
    """

    level = LEVEL_OBSTACLE
    label = "obstacles"

    @renamed_args(max_velocity="max_speed")
    def __init__(
        self,
        obstacles: Sequence[SphereObstacle],
        link_radius: FloatArray,
        *,
        buffer: float,
        spring_gain: float,
        max_speed: FloatArray,
    ) -> None:
        self.obstacles = tuple(obstacles)
        self._centres = np.array([o.center for o in self.obstacles], dtype=float).reshape(-1, 3)
        self._srad = np.array([o.radius for o in self.obstacles], dtype=float)
        self._radius = np.asarray(link_radius, dtype=float).reshape(-1)
        self._buffer = buffer
        self._prof = LinearBuffer(buffer=buffer, spring_gain=spring_gain)
        self._vmax = np.asarray(max_speed, dtype=float)

    def _radii(self, nl: int) -> FloatArray:
        r = self._radius
        return np.broadcast_to(r, (nl,)) if r.shape[0] == 1 else r[:nl]

    def segments(self, frame: KinematicsFrame) -> FloatArray:
        """The frame's link segments (L, 2, 3), checked against the link radii."""
        segs = np.asarray(frame.segments(), dtype=np.float64)
        nl = segs.shape[0] if segs.ndim == 3 else -1
        segs = checked("kinematics(q).segments()", segs, (max(nl, 0), 2, 3))
        if self._radius.shape[0] not in (1, nl):
            raise_inconsistent(nl, self._radius.shape[0])
        return segs

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows of the pairs within reach."""
        segs = self.segments(ctx.frame)
        nl = segs.shape[0]
        n = ctx.q.shape[0]
        clear, t, _X, R, dist = _clearances(segs, self._centres, self._srad, self._radii(nl))
        near = clear < self._buffer
        beyond = ~near
        if beyond.any() and ctx.dt is not None:
            # farther than 1.5 periods of the link's speed bound (with margin) is out of reach.
            reach = 1.5 * ctx.dt * link_speed_bounds(segs, self._vmax)
            near = near | (clear <= reach[None, :])
        obs_i, link = np.nonzero(near)
        if obs_i.shape[0] == 0:
            return None
        u = ctx.command
        idt = _idt(ctx.dt)
        ts = t[obs_i, link]
        Jc = _point_jacobians(ctx.frame, link, ts, n)
        speed = np.sqrt(((Jc @ u) ** 2).sum(axis=1)).tolist()
        d_sel = clear[obs_i, link].tolist()
        r_sel = dist[obs_i, link]
        with np.errstate(divide="ignore", invalid="ignore"):
            nrm = R[obs_i, link] / r_sel[:, None]
        for z in np.flatnonzero(r_sel == 0.0).tolist():
            nrm[z] = _fallback(segs[int(link[z])])
        bs = [_bound1(self._prof, d_sel[r], speed[r], idt) for r in range(len(d_sel))]
        keep = [r for r in range(len(bs)) if bs[r] != -math.inf]
        if not keep:
            return None
        G = np.einsum("ki,kij->kj", nrm[keep], Jc[keep])
        bs = [bs[r] for r in keep]
        oi = obs_i[keep]
        lk = link[keep]
        d0 = clear[oi, lk]

        def names() -> list[str]:
            return [
                f"obstacle {a} on link {c}" for a, c in zip(oi.tolist(), lk.tolist(), strict=True)
            ]

        return RowBlock(
            G, np.array(bs), d0 < 0.0, oi * nl + lk,
            names,
            distance=d0, data=(oi, lk),
        )  # fmt: skip

    def clearances(self, frame: KinematicsFrame) -> FloatArray:
        """Every (obstacle, link) pair's clearance [m] at the pose of ``frame``, shape (k, L)."""
        segs = self.segments(frame)
        return _clearances(segs, self._centres, self._srad, self._radii(segs.shape[0]))[0]

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's pairs' clearances [m] at the pose of ``frame``, shape (k,)."""
        oi, lk = block.data
        out: FloatArray = self.clearances(frame)[oi, lk]
        return out


# ------------------------------------------------------------------------------- self-collision
def _pair_geometry(
    sa: FloatArray, sb: FloatArray
) -> tuple[float, float, float, tuple[float, float, float]]:
    """Closest axis points of two link segments: ``(s, t, |pa - pb|, unit normal b -> a)``.

    The normal of crossing axes (``pa == pb``) is ``d_a × d_b`` normalised, else that of
    :func:`_fallback` on ``sa`` (the C core's ``vf_segment_pair`` makes the same choices).
    """
    a0 = (float(sa[0, 0]), float(sa[0, 1]), float(sa[0, 2]))
    a1 = (float(sa[1, 0]), float(sa[1, 1]), float(sa[1, 2]))
    b0 = (float(sb[0, 0]), float(sb[0, 1]), float(sb[0, 2]))
    b1 = (float(sb[1, 0]), float(sb[1, 1]), float(sb[1, 2]))
    s, t = segment_pair_params(a0, a1, b0, b1)
    pa = [a0[c] + s * (a1[c] - a0[c]) if s <= 0.5 else a1[c] - (1.0 - s) * (a1[c] - a0[c])
          for c in range(3)]  # fmt: skip
    pb = [b0[c] + t * (b1[c] - b0[c]) if t <= 0.5 else b1[c] - (1.0 - t) * (b1[c] - b0[c])
          for c in range(3)]  # fmt: skip
    r = (pa[0] - pb[0], pa[1] - pb[1], pa[2] - pb[2])
    dist = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    if dist > 0.0:
        return s, t, dist, (r[0] / dist, r[1] / dist, r[2] / dist)
    da = (a1[0] - a0[0], a1[1] - a0[1], a1[2] - a0[2])
    db = (b1[0] - b0[0], b1[1] - b0[1], b1[2] - b0[2])
    cx = da[1] * db[2] - da[2] * db[1]
    cy = da[2] * db[0] - da[0] * db[2]
    cz = da[0] * db[1] - da[1] * db[0]
    h = math.sqrt(cx * cx + cy * cy + cz * cz)
    if h > 0.0:
        return s, t, 0.0, (cx / h, cy / h, cz / h)
    fb = _fallback(sa)
    return s, t, 0.0, (float(fb[0]), float(fb[1]), float(fb[2]))


class SelfCollisionRows:
    r"""Link capsules against link capsules (level :data:`LEVEL_OBSTACLE`).

    For every guarded pair ``(i, j)`` (key: its index in ``pairs``) within the linear buffer
    (or, with ``dt``, within one period's reach of the two links at full joint speed): the
    closest points ``p_a`` on link ``i``'s axis and ``p_b`` on link ``j``'s
    (:func:`~velfence.geometry.primitives.segment_pair_params`), the unit normal
    ``n = (p_a - p_b) / |p_a - p_b|``, the clearance ``d = |p_a - p_b| - r_i - r_j`` and the row
    ``nᵀ (J_a(p_a) - J_b(p_b)) x >= b`` with the closest points held fixed (derivation:
    ``docs/derivations.md``); ``b`` is the obstacle rows' linear buffer at the pair's relative
    commanded speed ``|(J_a - J_b) u|``.

    Args:
        pairs: The guarded link pairs ``(i, j)``, ``i < j``
            (:meth:`~velfence.filter.limits.SelfCollision.pairs`).
        link_radius: Capsule radius of every link [m], shape (L,) or (1,).
        buffer: Width of the linear buffer [m].
        spring_gain: Recovery gain outside [1/s].
        max_speed: Joint speed limits [rad/s], shape (n,) (the reach bound).
    """

    level = LEVEL_OBSTACLE
    label = "self-collision"

    def __init__(
        self,
        pairs: Sequence[tuple[int, int]],
        *,
        link_radius: FloatArray,
        buffer: float,
        spring_gain: float,
        max_speed: FloatArray,
    ) -> None:
        self.pairs = tuple((int(i), int(j)) for i, j in pairs)
        self._radius = np.asarray(link_radius, dtype=float).reshape(-1)
        self._prof = LinearBuffer(buffer=buffer, spring_gain=spring_gain)
        self._buffer = buffer
        self._vmax = np.asarray(max_speed, dtype=float)

    def _rad(self, link: int) -> float:
        r = self._radius
        return float(r[0] if r.shape[0] == 1 else r[link])

    def _geometry(self, segs: FloatArray, which: Sequence[int]) -> list[Any]:
        out = []
        for p in which:
            i, j = self.pairs[p]
            s, t, dist, nrm = _pair_geometry(segs[i], segs[j])
            out.append((s, t, dist - self._rad(i) - self._rad(j), nrm))
        return out

    def _reach(self, segs: FloatArray, dt: float) -> list[float]:
        """Per link: 1.5 periods of its points' largest speed (as :class:`ObstacleRows`)."""
        out: list[float] = (1.5 * dt * link_speed_bounds(segs, self._vmax)).tolist()
        return out

    def rows(self, ctx: RowContext) -> RowBlock | None:
        """The rows of the pairs within reach."""
        if not self.pairs:
            return None
        segs = np.asarray(ctx.frame.segments(), dtype=np.float64)
        nl = segs.shape[0] if segs.ndim == 3 else -1
        segs = checked("kinematics(q).segments()", segs, (max(nl, 0), 2, 3))
        if self._radius.shape[0] not in (1, nl):
            raise_inconsistent(nl, self._radius.shape[0])
        geo = self._geometry(segs, range(len(self.pairs)))
        buf = self._buffer
        reach = self._reach(segs, ctx.dt) if ctx.dt is not None else None
        near = []
        for p, g in enumerate(geo):
            i, j = self.pairs[p]
            if g[2] < buf or (reach is not None and g[2] <= reach[i] + reach[j]):
                near.append(p)
        if not near:
            return None
        n = ctx.q.shape[0]
        links = np.array([self.pairs[p][k] for p in near for k in (0, 1)], dtype=np.int64)
        ts = np.array([geo[p][k] for p in near for k in (0, 1)])
        Jc = _point_jacobians(ctx.frame, links, ts, n)
        Jrel = Jc[0::2] - Jc[1::2]
        nrm = np.array([geo[p][3] for p in near])
        G = np.einsum("ki,kij->kj", nrm, Jrel)
        speed = np.sqrt(((Jrel @ ctx.command) ** 2).sum(axis=1)).tolist()
        idt = _idt(ctx.dt)
        keep = []
        bs = []
        for r, p in enumerate(near):
            bnd = _bound1(self._prof, geo[p][2], speed[r], idt)
            if bnd != -math.inf:
                keep.append(r)
                bs.append(bnd)
        if not keep:
            return None
        keys = np.array([near[r] for r in keep], dtype=np.int64)
        d0 = np.array([geo[near[r]][2] for r in keep])
        pairs = self.pairs

        def names() -> list[str]:
            return [f"link {pairs[p][0]} and link {pairs[p][1]}" for p in keys.tolist()]

        return RowBlock(
            G[keep], np.array(bs), d0 < 0.0, keys, names, distance=d0, data=keys.tolist()
        )

    def next_distances(self, frame: KinematicsFrame, block: RowBlock) -> FloatArray:
        """The block's pairs' clearances [m] at the pose of ``frame``, shape (k,)."""
        segs = checked("kinematics(q).segments()", frame.segments(), (self._nl(frame), 2, 3))
        return np.array([g[2] for g in self._geometry(segs, block.data)])

    @staticmethod
    def _nl(frame: KinematicsFrame) -> int:
        return int(np.shape(frame.segments())[0])


def _fallback(seg: FloatArray) -> FloatArray:
    """A unit normal when the centre lies on the link's axis: ``ẑ × (b - a)`` normalised, else x̂."""
    dx = float(seg[1, 0] - seg[0, 0])
    dy = float(seg[1, 1] - seg[0, 1])
    h = math.hypot(dx, dy)
    if h == 0.0:
        return np.array([1.0, 0.0, 0.0])
    return np.array([-dy / h, dx / h, 0.0])


def raise_inconsistent(links: int, radii: int) -> None:
    """The robot's capsule data disagree: :class:`~velfence.errors.InvalidInput` naming it."""
    from velfence.errors import InvalidInput

    raise InvalidInput(
        f"robot: inconsistent chain data: kinematics(q).segments() has {links} links, "
        f"link_radius has {radii} radii (expected {links} or 1)"
    )


document_inits(globals())
