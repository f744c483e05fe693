r"""Configuration control with obstacle-avoidance inequality tasks (US 5,150,026 claim 1).

The claim's steps A–F, formalised in ``docs/configuration_control.md``, for a serial chain
(:class:`velfence.mechanisms.chain.SerialChain`) among spherical obstacles
(:class:`velfence.filter.SphereObstacle`, each with its sphere of influence):

A. *critical point* — for every obstacle :math:`o` and link :math:`l`, the closest point
   :math:`c_{o,l}` of the link axis (segment) to the obstacle centre :math:`x_o`; the critical
   point of :math:`o` is the one of the link with the smallest critical distance (ties: the lower
   link index);
B. *critical distance* :math:`d_o = \|c_o - x_o\| - r_l`, the distance from the obstacle centre to
   the surface of the link's capsule (axis distance minus link radius; equal to the axis distance
   for thin links); the claim's inequality is :math:`d_o > \rho_o`;
C. *constraint row* :math:`J_{z,o} = u_o^\top J_{c,o}` with :math:`u_o = (c_o - x_o)/\|c_o - x_o\|`
   and :math:`J_{c,o}` the linear-velocity Jacobian of the body-fixed point of link :math:`l`
   that coincides with :math:`c_o` (held fixed on the link during the cycle), so that
   :math:`\dot d_o = J_{z,o}\dot\theta`;
D. *activation* — obstacle :math:`o` joins the active set iff
   :math:`d_o \le \rho_o + h\,\max(0, -\dot d_o)` (``activation_margin`` :math:`h` [s], the
   discrete-time look-ahead; :math:`h = 0` is the claim's "when the critical distance equals the
   radius") **and** the motion computed without it approaches, :math:`\dot d_o < \dot z_{r,o}`;
   candidates are added one at a time in order of clearance :math:`d_o - \rho_o`, re-solving after
   each, so a second, third … row joins while the earlier ones stay enforced (steps d–f);
E. *augmented task*, weighted damped least squares (configuration control):

   .. math::
       \dot\theta = \Big[J_e^\top W_e J_e + \sum_{o\in\mathcal A} J_{z,o}^\top w_z J_{z,o}
       + W_v\Big]^{-1}\Big[J_e^\top W_e \dot Y_r + \sum_{o\in\mathcal A} J_{z,o}^\top w_z
       \dot z_{r,o}\Big],

   :math:`\dot Y_r = \dot Y_d + K_e(Y_d - Y)` (the feedback term only with ``ee_target``),
   :math:`\dot z_{r,o} = K_z \max(0, \rho_o - d_o)` (0 — "stop the approach" — at or outside
   :math:`\rho_o`; recovery ``[OURS]`` when penetrated), :math:`W_e = w_e I`,
   :math:`W_v = \lambda I`. It is solved as the equivalent stacked least-squares problem
   (square roots of the weights), which is better conditioned than the normal matrix;
F. only the approach is stopped: an obstacle whose motion is tangential or retreating
   (:math:`\dot d_o \ge \dot z_{r,o}`) never enters the active set.

Up to :math:`r = n - m` active rows can be met together with the end-effector task; beyond that
the damped solve trades them off, the result is flagged ``exhausted`` and the tasks that gave way
are named. The joint rate is bounded by :math:`\|b\|/\sqrt{\lambda}` in every case.

Degenerate direction: when the obstacle centre lies on the link axis (:math:`\|c_o - x_o\| = 0`,
:math:`u_o` undefined) the fallback is the deterministic one of
:func:`velfence.geometry.primitives.sphere_capsule_distance`: :math:`\hat z \times (b - a)`
normalised (the in-plane perpendicular for planar chains), or :math:`\hat x` when the link is
along z or has zero length.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import module_getattr, renamed_args
from velfence._docs import document_inits
from velfence._typing import FloatArray, IntArray
from velfence._validate import check_choice, check_positive, readonly, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.filter.limits import SphereObstacle
from velfence.mechanisms.chain import is_library_chain
from velfence.shaping.backend import pick_backend
from velfence.shaping.base import InvalidPolicy, OnInvalid
from velfence.shaping.polytope import PolytopeBackend

if TYPE_CHECKING:
    from velfence.mechanisms.chain import SerialChain

__all__ = ["ConfigurationController", "ControlResult"]

Release = Literal["recheck", "sequential"]


_RATE_EPS = 1e-12  # [m/s] rounding deadband: a tangential motion (ḋ = 0 up to rounding) stays free
_TUNING = frozenset(
    ("release", "max_speed", "ee_weight", "constraint_weight", "damping", "spring_gain",
     "activation_margin")
)  # fmt: skip
_CHAIN_ATTRS = (
    "dof",
    "n_links",
    "task_dim",
    "link_radius",
    "link_segments",
    "point_jacobian",
    "end_effector",
    "ee_jacobian",
)


@dataclass(frozen=True, eq=False, kw_only=True)
class ControlResult:
    r"""What a configuration controller (or the QP baseline) did in one control cycle.

    Per-obstacle arrays are in the order of the controller's ``obstacles``; ``N_o`` obstacles,
    ``n`` joints, ``m`` end-effector coordinates.

    Attributes:
        q_dot: Joint velocity, shape (n,) [rad/s] (or [m/s] for prismatic joints); never
            non-finite.
        command: The commanded end-effector velocity as given, shape (m,) [m/s].
        ee_reference: :math:`\dot Y_r`, the command plus the position feedback, shape (m,) [m/s].
        zone: ``"free"`` (no active row), ``"active"``, ``"recovering"`` (an active obstacle is
            penetrated, :math:`d < \rho`), ``"exhausted"`` (more active rows than redundancy),
            ``"infeasible"`` (QP baseline: solver failed, zero output) or ``"invalid"``
            (non-finite input under ``on_invalid="stop"``, zero output).
        active: Indices of the obstacles whose rows were enforced, in order of activation.
        critical_points: Critical point of each obstacle on the link axis, shape (N_o, 3) [m].
        links: Link index of each critical point, shape (N_o,).
        fractions: Fraction t in [0, 1] of the critical point along its link, shape (N_o,).
        distances: Critical distance d (obstacle centre to the link capsule surface), shape
            (N_o,) [m].
        normals: Unit vector u from the obstacle centre to the critical point, shape (N_o, 3).
        d_dot: :math:`\dot d = u^\top J_c \dot\theta` under ``q_dot``, shape (N_o,) [m/s].
        d_dot_free: :math:`\dot d` under the solution without any obstacle row, shape (N_o,)
            [m/s].
        ee_rate_error: :math:`\|J_e\dot\theta - \dot Y_r\|` [m/s].
        ee_error: :math:`\|Y_d - Y\|` [m] when an ``ee_target`` was given, else NaN.
        condition: 2-norm condition number of the normal matrix of the final solve.
        exhausted: More active rows than the redundancy :math:`r = n - m`.
        ee_yielded: The end-effector task gave way (``ee_rate_error`` > ``task_tolerance``).
        violated: Active obstacles whose rate task gave way
            (:math:`\dot d < \dot z_r -` ``task_tolerance``).
        redundancy: :math:`r = n - m`.
        method: ``"configuration-control"`` or ``"velocity-damper-qp"``.
    """

    q_dot: FloatArray
    command: FloatArray
    ee_reference: FloatArray
    zone: str
    active: tuple[int, ...]
    critical_points: FloatArray
    links: IntArray
    fractions: FloatArray
    distances: FloatArray
    normals: FloatArray
    d_dot: FloatArray
    d_dot_free: FloatArray
    ee_rate_error: float
    ee_error: float
    condition: float
    exhausted: bool
    ee_yielded: bool
    violated: tuple[int, ...]
    redundancy: int
    method: str

    @property
    def output(self) -> FloatArray:
        """The shaped output (the shaper contract's name for ``q_dot``), shape (n,)."""
        return self.q_dot


@dataclass(frozen=True, eq=False)
class Critical:
    r"""Steps A–C for every obstacle at one configuration (internal, shared with the baseline).

    Attributes:
        points: Critical points, shape (N_o, 3) [m].
        links: Their links, shape (N_o,).
        fractions: Fractions along the links, shape (N_o,).
        distances: Critical distances d, shape (N_o,) [m].
        normals: Unit vectors u, shape (N_o, 3).
        rows: Constraint rows :math:`J_z = u^\top J_c`, shape (N_o, n) [m/rad].
    """

    points: FloatArray
    links: IntArray
    fractions: FloatArray
    distances: FloatArray
    normals: FloatArray
    rows: FloatArray


class ChainObstacleBase(InvalidPolicy):
    """Shared plumbing of the obstacle-avoiding chain controllers (validation, steps A–C, policy).

    Subclasses implement ``_law(q, ee_velocity, ee_target) -> ControlResult``.
    """

    method = "chain-obstacles"

    def __init__(
        self,
        chain: SerialChain,
        obstacles: Sequence[SphereObstacle],
        *,
        on_invalid: OnInvalid = "raise",
    ) -> None:
        super().__init__(on_invalid=on_invalid)
        missing = [a for a in _CHAIN_ATTRS if not hasattr(chain, a)]
        if missing:
            raise InvalidParameter(
                f"chain must implement the SerialChain protocol (velfence.mechanisms.chain), "
                f"got {type(chain).__name__} missing {missing}"
            )
        # A str is a Sequence too (of characters); the message names types only, since a
        # value's __repr__ is user code.
        ok = isinstance(obstacles, Sequence) and not isinstance(obstacles, (str, bytes))
        obs = tuple(obstacles) if ok else None
        if obs is None or not all(isinstance(o, SphereObstacle) for o in obs):
            got = type(obstacles).__name__
            if obs is not None:
                got += " containing " + ", ".join(
                    sorted({type(o).__name__ for o in obs if not isinstance(o, SphereObstacle)})
                )
            raise InvalidParameter(
                f"obstacles must be a sequence of SphereObstacle, got {got}; wrap centres and "
                "radii in velfence.filter.SphereObstacle(center, radius=..., influence=...)"
            )
        self.chain = chain
        self._obstacles: tuple[SphereObstacle, ...] = obs
        self.dof = int(chain.dof)
        self.task_dim = int(chain.task_dim)
        self.redundancy = self.dof - self.task_dim
        radii = np.array(chain.link_radius, dtype=float).reshape(-1)
        self._link_radius = readonly(radii)
        self._centers = readonly(np.array([ob.center for ob in obs], dtype=float).reshape(-1, 3))
        self._fast = is_library_chain(chain)

    @property
    def obstacles(self) -> tuple[SphereObstacle, ...]:
        """The obstacles (read-only: per-obstacle data is cached; build a new controller)."""
        return self._obstacles

    # ------------------------------------------------------------------ input
    def _parse(
        self, q: ArrayLike, v: ArrayLike, target: ArrayLike | None
    ) -> tuple[FloatArray, FloatArray, FloatArray | None, bool]:
        # Non-finite and huge entries pass to the on_invalid policy (and the overflow guard).
        qa = _policy_vector("position", q, self.dof, "rad")
        va = _policy_vector("command", v, self.task_dim, "m/s")
        ta = None if target is None else _policy_vector("ee_target", target, self.task_dim, "m")
        ok = bool(np.all(np.isfinite(qa)) and np.all(np.isfinite(va)))
        ok = ok and (ta is None or bool(np.all(np.isfinite(ta))))
        if not ok:
            self._invalid(
                f"non-finite input: position={qa.tolist()}, command={va.tolist()}, "
                f"ee_target={None if ta is None else ta.tolist()}"
            )
        return qa, va, ta, ok

    # ------------------------------------------------------------------ steps A–C
    def critical(self, q: FloatArray) -> Critical:
        """Critical point, distance, direction and constraint row of every obstacle (steps A–C).

        Args:
            q: Joint positions, shape (n,) [rad], finite.

        Returns:
            A :class:`Critical` with one row per obstacle.

        Raises:
            InvalidInput: ``q`` has the wrong shape or is not finite.
        """
        if not self._fast:
            return self._critical_protocol(q)
        qa = self.chain._q(q)  # type: ignore[attr-defined]
        return self._pose(qa)[0]

    def _critical_protocol(self, q: FloatArray) -> Critical:
        """Steps A–C through the public :class:`SerialChain` protocol, one obstacle at a time.

        The route for chains that are not the library's own (and the test oracle of the
        one-pass route :meth:`_pose`): one ``point_jacobian`` (a forward-kinematics pass) per
        obstacle.
        """
        from velfence.geometry.primitives import points_segments_distances, sphere_capsule_distance

        segs = np.asarray(self.chain.link_segments(q), dtype=float)
        centers = self._centers
        _, clear = points_segments_distances(
            centers, segs[:, 0], segs[:, 1], radii=self._link_radius
        )
        n_o = len(self.obstacles)
        points = np.zeros((n_o, 3))
        links = np.zeros(n_o, dtype=np.int64)
        fractions = np.zeros(n_o)
        distances = np.zeros(n_o)
        normals = np.zeros((n_o, 3))
        rows = np.zeros((n_o, self.dof))
        for i, ob in enumerate(self.obstacles):
            link = int(np.argmin(clear[i]))  # first minimum: ties keep the more proximal link
            d, x, t, n = sphere_capsule_distance(
                ob.center,
                segs[link, 0],
                segs[link, 1],
                sphere_radius=0.0,
                capsule_radius=float(self._link_radius[link]),
            )
            points[i], links[i], fractions[i], distances[i] = x, link, t, d
            normals[i] = n
            jc = np.asarray(
                self.chain.point_jacobian(q, int(links[i]), float(fractions[i])), dtype=float
            )
            rows[i] = normals[i] @ jc
        return Critical(points, links, fractions, distances, normals, rows)

    def _pose(self, q: FloatArray) -> tuple[Critical, FloatArray, FloatArray]:
        r"""Steps A–C, the end-effector Jacobian and position from ONE forward-kinematics pass.

        For the library's chains (``_fast``) and a validated ``q``: the chain's
        ``_kinematics_cache`` once, then every obstacle at once — the all-pairs search of
        :func:`~velfence.geometry.primitives.points_segments_distances` (same arithmetic, so the
        same link), the closest point of :func:`sphere_capsule_distance` on the chosen link
        (same float operations element-wise) and the constraint rows
        :math:`u_o^\top J_{c,o}` from the columns :math:`z_j \times (p_o - P_j)`, masked to
        the joints carrying the link. Returns ``(critical, J_e (m, n), Y (m,))``.
        """
        chain = self.chain
        m, n = self.task_dim, self.dof
        points, axes, _ = chain._kinematics_cache(q)  # type: ignore[attr-defined]
        # z_j x P_j once per pose: every Jacobian column z_j x (p - P_j) is z_j x p - z_j x P_j.
        zxp = _cross(axes, points[:n])
        je = np.array((_cross(axes, points[n]) - zxp).T[:m])
        y = np.array(points[n, :m])
        A = points[:-1]
        C, R = self._centers, self._link_radius
        n_o = C.shape[0]
        if n_o == 0:
            e3, e1 = np.zeros((0, 3)), np.zeros(0)
            crit = Critical(e3, np.zeros(0, dtype=np.int64), e1, e1, e3, np.zeros((0, n)))
            return crit, je, y
        # Step A, all pairs: the arithmetic of points_segments_distances (hence the same link).
        E = points[1:] - A
        ee = np.einsum("ij,ij->i", E, E)
        rel = C[:, None, :] - A[None, :, :]
        t_all = np.where(ee > 0.0, np.einsum("psk,sk->ps", rel, E) / np.where(ee > 0, ee, 1.0), 0.0)
        t_all = np.minimum(np.maximum(t_all, 0.0), 1.0)
        diff = rel - t_all[:, :, None] * E[None, :, :]
        clear = np.sqrt(np.einsum("psk,psk->ps", diff, diff)) - R
        links = np.argmin(clear, axis=1)  # first minimum: ties keep the more proximal link
        # Step B on the chosen link (sphere_capsule_distance's quantities, to rounding).
        t = t_all[np.arange(n_o), links]
        x = A[links] + t[:, None] * E[links]
        r = x - C
        dist = np.sqrt(np.einsum("ij,ij->i", r, r))
        normals = r / np.where(dist > 0.0, dist, 1.0)[:, None]
        for i in np.flatnonzero(dist == 0.0).tolist():  # centre on the axis: the fallback
            hx, hy = float(E[links[i], 0]), float(E[links[i], 1])
            h = math.hypot(hx, hy)
            normals[i] = (1.0, 0.0, 0.0) if h == 0.0 else (-hy / h, hx / h, 0.0)
        distances = dist - R[links]
        # Step C: u . (z_j x (x - P_j)) = z_j . (x x u) - u . (z_j x P_j) for the joints j <= link
        # that carry the link (chain module docs), zero for the others.
        rows = _cross(x, normals) @ axes.T - normals @ zxp.T
        rows = np.where(np.arange(n)[None, :] <= links[:, None], rows, 0.0)
        crit = Critical(x, links.astype(np.int64), t, distances, normals, rows)
        return crit, je, y

    def _ee_reference(
        self, q: FloatArray, v: FloatArray, target: FloatArray | None, gain: float
    ) -> tuple[FloatArray, float]:
        if target is None:
            return v.copy(), math.nan
        err = target - np.asarray(self.chain.end_effector(q), dtype=float)
        return v + gain * err, float(np.linalg.norm(err))

    # ------------------------------------------------------------------ the contract
    def _law(self, q: FloatArray, v: FloatArray, target: FloatArray | None) -> ControlResult:
        raise NotImplementedError  # pragma: no cover

    def _stopped(self, v: FloatArray, n_o: int) -> ControlResult:
        nan = math.nan
        return ControlResult(
            q_dot=np.zeros(self.dof), command=v, ee_reference=np.zeros(self.task_dim),
            zone="invalid", active=(), critical_points=np.full((n_o, 3), nan),
            links=np.full(n_o, -1, dtype=np.int64), fractions=np.full(n_o, nan),
            distances=np.full(n_o, nan), normals=np.full((n_o, 3), nan),
            d_dot=np.full(n_o, nan), d_dot_free=np.full(n_o, nan), ee_rate_error=nan,
            ee_error=nan, condition=nan, exhausted=False, ee_yielded=False, violated=(),
            redundancy=self.redundancy, method=self.method,
        )  # fmt: skip

    @renamed_args(q="position", ee_velocity="command")
    def control(
        self, position: ArrayLike, command: ArrayLike, *, ee_target: ArrayLike | None = None
    ) -> ControlResult:
        r"""One control cycle: joint velocity and diagnostics.

        Args:
            position: Joint positions, shape (n,) [rad].
            command: Desired end-effector velocity :math:`\dot Y_d`, shape (m,) [m/s].
            ee_target: Desired end-effector position :math:`Y_d`, shape (m,) [m]; when given
                the reference gets the feedback term :math:`K_e(Y_d - Y)`.

        Returns:
            The :class:`ControlResult`; its ``q_dot`` is always finite.

        Raises:
            InvalidInput: wrong shapes, or non-finite values with ``on_invalid="raise"``.
        """
        qa, va, ta, ok = self._parse(position, command, ee_target)
        if not ok:
            return self._stopped(va, len(self.obstacles))
        with np.errstate(all="ignore"):
            res = self._law(qa, va, ta)
        if not np.all(np.isfinite(res.q_dot)):
            self._invalid(f"input too large, the joint velocity overflowed: command={va}")
            return self._stopped(va, len(self.obstacles))
        return res

    @renamed_args(q="position", ee_velocity="command")
    def explain(self, position: ArrayLike, command: ArrayLike) -> ControlResult:
        """Joint velocity with diagnostics (:meth:`control` without a target).

        Args:
            position: Joint positions, shape (n,) [rad].
            command: Desired end-effector velocity, shape (m,) [m/s].
        """
        return self.control(position, command)

    @renamed_args(q="position", ee_velocity="command")
    def shape(self, position: ArrayLike, command: ArrayLike) -> FloatArray:
        """Joint velocity, shape (n,) [rad/s], for an end-effector velocity command.

        Args:
            position: Joint positions, shape (n,) [rad].
            command: Desired end-effector velocity, shape (m,) [m/s].

        Raises:
            InvalidInput: wrong shapes, or non-finite values with ``on_invalid="raise"``.
        """
        return self.control(position, command).q_dot

    @renamed_args(Q="positions", V="commands")
    def shape_batch(self, positions: ArrayLike, commands: ArrayLike) -> FloatArray:
        """Joint velocities for N independent states; equal to looping :meth:`shape`.

        Args:
            positions: Joint positions, shape (N, n) [rad].
            commands: End-effector velocity commands, shape (N, m) [m/s].

        Returns:
            Shape (N, n).

        Raises:
            InvalidInput: wrong shapes, or non-finite rows with ``on_invalid="raise"``.
        """
        Qa = real_array(
            "positions",
            positions,
            what=f"joint positions of shape (N, {self.dof}) [rad]",
            allow_nonfinite=True,
            max_abs=None,
        )
        Va = real_array(
            "commands",
            commands,
            what=f"end-effector velocities of shape (N, {self.task_dim}) [m/s]",
            allow_nonfinite=True,
            max_abs=None,
        )
        if (
            Qa.ndim != 2
            or Va.ndim != 2
            or Qa.shape[1] != self.dof
            or Va.shape[1] != self.task_dim
            or Qa.shape[0] != Va.shape[0]
        ):
            raise InvalidInput(
                f"positions and commands must have shapes (N, {self.dof}) and "
                f"(N, {self.task_dim}), got "
                f"{Qa.shape} and {Va.shape}"
            )
        out = np.zeros((Qa.shape[0], self.dof))
        for k in range(Qa.shape[0]):
            try:
                out[k] = self.shape(Qa[k], Va[k])
            except InvalidInput as exc:
                # shape() names its own position / command; say which batch row it was.
                raise InvalidInput(f"positions, commands row {k}: {exc}") from None
        return out


def _policy_vector(name: str, x: ArrayLike, width: int, unit: str) -> FloatArray:
    """A (width,) vector of real numbers; NaN/inf pass to the ``on_invalid`` policy."""
    return real_array(
        name, x, (width,), what=f"{width} numbers [{unit}]", allow_nonfinite=True, max_abs=None
    )


def _active_set(
    G_a: FloatArray,
    rx0_a: FloatArray,
    zr: list[float],
    d: list[float],
    rho: list[float],
    h: float,
    inv_wz: float,
    recheck: bool,
    rounds: int,
) -> list[int] | None:
    r"""Steps D–F of :class:`ConfigurationController` in obstacle space (see ``_law``).

    ``G_a`` (N, N) is :math:`R M_0^{-1} R^\top`, ``rx0_a`` the rates under the free solve, the rest
    per obstacle as in the law; indices are positions in these lists. Returns the active set in
    order of activation, or ``None`` when a rate is not finite.
    """
    G, rx0 = G_a.tolist(), rx0_a.tolist()
    nn = len(rx0)
    thr = [z - _RATE_EPS for z in zr]
    clear = [di - ri for di, ri in zip(d, rho, strict=True)]
    in_set = [False] * nn
    A: list[int] = []
    H: list[list[float]] = []
    y: list[float] = []
    dd = list(rx0)
    for _ in range(rounds):  # bounded: add/release cannot cycle long
        if not all(map(math.isfinite, dd)):
            return None
        best, key = -1, math.inf
        for i in range(nn):
            di = dd[i]
            if (
                not in_set[i]
                and di < thr[i]
                and d[i] <= rho[i] + h * max(0.0, -di)
                and clear[i] < key
            ):
                best, key = i, clear[i]  # strict: ties keep the lower index
        if best < 0:
            break
        # Border H = (G_SS + I/w_z)^-1 with the new row.
        g = [G[best][a] for a in A]
        p = G[best][best] + inv_wz
        if A:
            Hg = [sum(map(operator.mul, row, g)) for row in H]
            inv_s = 1.0 / (p - sum(map(operator.mul, g, Hg)))
            w = [-v * inv_s for v in Hg]
            H = [[hij - hi * wj for hij, wj in zip(row, w, strict=True)] + [wi]
                 for row, hi, wi in zip(H, Hg, w, strict=True)] + [[*w, inv_s]]  # fmt: skip
        else:
            H = [[1.0 / p]]
        A.append(best)
        in_set[best] = True
        r = [zr[a] - rx0[a] for a in A]
        y = [sum(map(operator.mul, row, r)) for row in H]
        k = 0
        while recheck and k < len(A) - 1:
            a = A[k]
            hkk = H[k][k]
            if zr[a] - y[k] / hkk >= thr[a]:  # without it, its point would not approach
                col = [row[k] for row in H]
                f = y[k] / hkk
                y = [yi - ci * f for i, (yi, ci) in enumerate(zip(y, col, strict=True)) if i != k]
                H = [
                    [hij - ci * cj / hkk for j, (hij, cj) in enumerate(zip(row, col, strict=True))
                     if j != k]
                    for i, (row, ci) in enumerate(zip(H, col, strict=True)) if i != k
                ]  # fmt: skip
                A.pop(k)
                in_set[a] = False
            else:
                k += 1
        dd = (rx0_a + G_a[:, A] @ np.array(y)).tolist()
    return A


def _cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """Row-wise cross product of (N, 3) arrays (or one (3,) operand), without np.cross' overhead."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def _solve_stacked(
    je: FloatArray,
    yr: FloatArray,
    rows: FloatArray,
    zr: FloatArray,
    w_e: float,
    w_z: float,
    lam: float,
) -> tuple[FloatArray, float]:
    """Weighted damped least squares (step E) as a stacked problem; returns (q_dot, cond(N))."""
    n = je.shape[1]
    A = np.concatenate((math.sqrt(w_e) * je, math.sqrt(w_z) * rows, math.sqrt(lam) * np.eye(n)))
    b = np.concatenate((math.sqrt(w_e) * yr, math.sqrt(w_z) * zr, np.zeros(n)))
    if not (np.isfinite(A).all() and np.isfinite(b).all()):
        return np.full(n, math.nan), math.inf
    x, _, _, s = np.linalg.lstsq(A, b, rcond=None)
    cond = float((s[0] / s[-1]) ** 2) if s[-1] > 0 else math.inf
    return np.asarray(x, dtype=float), cond


class ConfigurationController(ChainObstacleBase):
    r"""Obstacle avoidance by configuration control, US 5,150,026 claim 1 (steps A–F).

    Maps a desired end-effector velocity to joint rates that track it while no link approaches
    an obstacle's sphere of influence; the law and its active-set logic are in the module
    docstring and ``docs/configuration_control.md``. Stateless: every cycle rebuilds the active
    set, so a constraint stays enforced exactly as long as the unconstrained motion would push
    the critical point into the sphere.

    Args:
        chain: The kinematics (:class:`~velfence.mechanisms.chain.SerialChain`: ``PlanarArm``,
            ``DHChain`` …).
        obstacles: :class:`~velfence.filter.SphereObstacle` entries, each with its sphere of
            influence ``influence`` (may be empty).
        ee_gain: :math:`K_e`, end-effector position feedback gain [1/s], >= 0 (only used with
            ``ee_target``).
        damping: :math:`\lambda` of :math:`W_v = \lambda I`, [m²/rad²], > 0; bounds the joint
            rate near singularities and when redundancy is exhausted.
        ee_weight: :math:`w_e` of :math:`W_e = w_e I`, dimensionless, > 0.
        constraint_weight: :math:`w_z`, dimensionless, > 0; large (default 1e4 × ``ee_weight``)
            so that obstacle rows dominate the end-effector task when they conflict.
        spring_gain: :math:`K_z` [1/s], >= 0: desired :math:`\dot z_r = K_z(\rho - d)` when
            penetrated (``[OURS]``; 0 is the faithful "stop the approach").
        activation_margin: Look-ahead :math:`h` [s], >= 0: a constraint is a candidate once
            :math:`d \le \rho + h\max(0, -\dot d)`; set it to the control period to stop before
            the sphere instead of overshooting by up to :math:`|\dot d|\,\Delta t` (0: faithful).
        task_tolerance: Rate error [m/s], > 0, above which a task counts as having given way.
        release: ``"recheck"`` (default): after a row joins, every earlier row is released if,
            solved without it, its critical point would not approach — only the approach is ever
            stopped, a retreat stays free. ``"sequential"``: the claim's literal reading, rows are
            added one by one ("continuing to stop motion of said first critical point") and kept
            for the cycle, which can hold a row whose point would retreat (a review measured this
            in 170 of 6,396 two-row states of a 4R).
        max_speed: Optional cap on every joint rate [rad/s], applied by scaling the whole
            ``q_dot`` by one factor (direction kept). Near a singular combination of the
            end-effector task and the active rows the damped solve can be fast (the linearised
            ``ḋ = 0`` then no longer holds over one step); the cap, or more ``damping``, bounds it.
        on_invalid: ``"raise"`` or ``"stop"`` (zero joint rate, zone ``"invalid"``).
        backend: ``"auto"`` (default): for the library's own chains (``DHChain``,
            ``PlanarArm`` …) the whole cycle after the forward kinematics runs in the compiled
            core (``velfence_core``, ``velfence_cc.h``) when it is installed, else in Python;
            ``"python"``: the NumPy route; ``"c"``: the core, required (raises
            :class:`~velfence.errors.InvalidParameter` when it is not installed or the chain is
            not one of the library's). Both make the same decisions and agree to
            :math:`\max(10^{-10}, 1000\,\kappa\,\varepsilon)` relative (``docs/core.md``).
            :attr:`backend` reports the one in use.

    Raises:
        InvalidParameter: for an out-of-range parameter, a non-chain, non-obstacles or an
            obstacle without ``influence``.
    """

    method = "configuration-control"

    def __init__(
        self,
        chain: SerialChain,
        obstacles: Sequence[SphereObstacle],
        *,
        ee_gain: float = 1.0,
        damping: float = 1e-2,
        ee_weight: float = 1.0,
        constraint_weight: float = 1e4,
        spring_gain: float = 0.0,
        activation_margin: float = 0.0,
        task_tolerance: float = 1e-3,
        release: Release = "recheck",
        max_speed: float | None = None,
        on_invalid: OnInvalid = "raise",
        backend: PolytopeBackend = "auto",
    ) -> None:
        super().__init__(chain, obstacles, on_invalid=on_invalid)
        bare = [i for i, o in enumerate(self.obstacles) if o.influence is None]
        if bare:
            raise InvalidParameter(
                f"obstacles {bare[:5]}: configuration control needs each obstacle's sphere of "
                "influence; give it as SphereObstacle(center, radius=..., influence=...) with "
                "influence > radius [m]"
            )
        self.release = check_choice("release", release, get_args(Release))
        self.max_speed = (
            None if max_speed is None else check_positive("max_speed", max_speed, unit="rad/s")
        )
        self.ee_gain = check_positive("ee_gain", ee_gain, allow_zero=True, unit="1/s")
        self.damping = check_positive("damping", damping, unit="m²/rad²")
        self.ee_weight = check_positive("ee_weight", ee_weight)
        self.constraint_weight = check_positive("constraint_weight", constraint_weight)
        self.spring_gain = check_positive("spring_gain", spring_gain, allow_zero=True, unit="1/s")
        self.activation_margin = check_positive(
            "activation_margin", activation_margin, allow_zero=True, unit="s"
        )
        self.task_tolerance = check_positive("task_tolerance", task_tolerance, unit="m/s")
        self._rho = readonly(np.array([o.influence for o in self.obstacles], dtype=float))
        self._rho_list: list[float] = self._rho.tolist()
        self._cc: Any = None
        self.backend: Literal["python", "c"] = "python"
        self._cc, self.backend = self._compiled(backend)

    def __setattr__(self, name: str, value: object) -> None:
        # The compiled route holds the tuning in C: a later change of one rebuilds it, so that
        # both routes always run the parameters the attributes show.
        super().__setattr__(name, value)
        if name in _TUNING and getattr(self, "_cc", None) is not None:
            self._cc, self.backend = self._compiled(self.backend)

    def _compiled(self, backend: object) -> tuple[Any, Literal["python", "c"]]:
        """``(velfence_core._nd.ConfigControl or None, backend in use)`` for ``backend``."""
        core, name = pick_backend(
            backend,
            usable=self._fast and self._link_radius.shape == (self.dof,),
            refusal="runs the library's own chains (DHChain, PlanarArm, … with one link per "
            f"joint), got {type(self.chain).__name__}",
        )
        if core is None:
            return None, name
        cc = core.ConfigControl(
            C=self._centers.ravel(), rho=self._rho, lrad=self._link_radius, n=self.dof,
            m=self.task_dim, k=len(self.obstacles), w_e=self.ee_weight,
            w_z=self.constraint_weight, lam=self.damping, kz=self.spring_gain,
            h=self.activation_margin, max_speed=0.0 if self.max_speed is None else self.max_speed,
            recheck=self.release == "recheck", rounds=4 * len(self.obstacles) + 1,
        )  # fmt: skip
        return cc, "c"

    def _law(self, q: FloatArray, v: FloatArray, target: FloatArray | None) -> ControlResult:
        if self._cc is not None:
            res = self._law_c(q, v, target)
            if res is not None:
                return res
            return self._law_reference(q, v, target)
        if not self._fast:
            return self._law_reference(q, v, target)
        crit, je, y = self._pose(q)
        if target is None:
            yr, ee_err = v.copy(), math.nan
        else:
            err = target - y
            yr, ee_err = v + self.ee_gain * err, float(np.linalg.norm(err))
        d, rho, rows = crit.distances, self._rho, crit.rows
        zr = self.spring_gain * np.maximum(0.0, rho - d)
        w_e, w_z, lam = self.ee_weight, self.constraint_weight, self.damping
        h = self.activation_margin
        # Only an obstacle with d <= rho + h max(0, -ḋ) can join; with h = 0 that is d <= rho
        # whatever the motion, so the active-set search runs over those alone.
        near = np.flatnonzero(d <= rho) if h == 0.0 else np.arange(len(self.obstacles))
        # Steps D-F in obstacle space (Woodbury): with M0 = w_e Je'Je + lam I, x0 = M0^-1 w_e Je'yr
        # (the free solve), K = M0^-1 R' and G = R K, the solve over an active set S is
        # x_S = x0 + K_S y with y = H (zr_S - (R x0)_S), H = (G_SS + I/w_z)^-1, and every row's
        # rate under it is R x_S = R x0 + G_{:,S} y. Leaving o out of S changes o's own rate to
        # zr_o - y_o / H_oo (block inversion), so a release check costs no solve; H grows by
        # bordering and shrinks by a rank-one downdate. Plain floats: the sets are small.
        rn = rows[near]
        M0 = w_e * (je.T @ je)
        M0.flat[:: self.dof + 1] += lam
        X = np.linalg.solve(M0, np.column_stack((w_e * (je.T @ yr), rn.T)))
        x0 = X[:, 0]
        Gn = rn @ X[:, 1:]
        rx0n = rn @ x0
        if not (np.all(np.isfinite(Gn)) and np.all(np.isfinite(x0))):
            return self._law_reference(q, v, target)
        found = _active_set(
            Gn,
            rx0n,
            zr[near].tolist(),
            d[near].tolist(),
            rho[near].tolist(),
            h,
            1.0 / w_z,
            self.release == "recheck",
            4 * len(self.obstacles) + 1,
        )
        if found is None:  # an obstacle-space rate overflowed
            return self._law_reference(q, v, target)
        active = [int(near[k]) for k in found]
        # The final solve exactly as the reference: the stacked lstsq over the active rows.
        idx = np.array(active, dtype=np.int64)
        q_dot, cond = _solve_stacked(je, yr, rows[idx], zr[idx], w_e, w_z, lam)
        q_free: FloatArray = q_dot if not active else np.asarray(x0, dtype=float)
        return self._result(v, yr, ee_err, crit, q_dot, q_free, cond, active, je)

    def _law_c(
        self, q: FloatArray, v: FloatArray, target: FloatArray | None
    ) -> ControlResult | None:
        """The cycle after the forward kinematics in the compiled core (``vf_cc_solve``).

        None when the core reports an overflow (huge commands): the caller then takes the
        lstsq-only route :meth:`_law_reference`, as :meth:`_law` does.
        """
        points, axes, _ = self.chain._kinematics_cache(q)  # type: ignore[attr-defined]
        if target is None:
            yr, ee_err = v.copy(), math.nan
        else:
            err = target - points[self.dof, : self.task_dim]
            yr, ee_err = v + self.ee_gain * err, float(np.linalg.norm(err))
        (code, q_dot, _, x, links, t, d, normals, rows, d_dot, d_dot_free, active, cond, e,
         e_free) = self._cc.solve(points, axes, yr)  # fmt: skip
        if code != 0:
            return None
        crit = Critical(x, links, t, d, normals, rows)
        return self._package(v, yr, ee_err, crit, q_dot, cond, active, d_dot, d_dot_free, e, e_free)

    def _law_reference(
        self, q: FloatArray, v: FloatArray, target: FloatArray | None
    ) -> ControlResult:
        """The law re-solved from scratch for every add/release check (one stacked lstsq each).

        The straightforward transcription of steps D–F, kept as the oracle of :meth:`_law`
        (tests compare them) and as its route when the obstacle-space quantities of the fast
        route overflow (huge commands), where the lstsq-only route keeps the old behaviour.
        """
        je = np.asarray(self.chain.ee_jacobian(q), dtype=float)
        yr, ee_err = self._ee_reference(q, v, target, self.ee_gain)
        crit = self._critical_protocol(q)
        d, rho, rows = crit.distances, self._rho, crit.rows
        zr = self.spring_gain * np.maximum(0.0, rho - d)
        solve_args = (self.ee_weight, self.constraint_weight, self.damping)
        q_dot, cond = _solve_stacked(je, yr, rows[:0], zr[:0], *solve_args)
        q_free = q_dot
        active: list[int] = []
        h = self.activation_margin
        for _ in range(4 * len(self.obstacles) + 1):  # bounded: add/release cannot cycle long
            dd = rows @ q_dot
            cand = [
                o
                for o in range(len(self.obstacles))
                if o not in active
                and dd[o] < zr[o] - _RATE_EPS
                and d[o] <= rho[o] + h * max(0.0, -dd[o])
            ]
            if not cand or not np.all(np.isfinite(dd)):
                break
            active.append(min(cand, key=lambda o: (d[o] - rho[o], o)))
            idx = np.array(active)
            q_dot, cond = _solve_stacked(je, yr, rows[idx], zr[idx], *solve_args)
            # A row added earlier may no longer be needed once a later one shapes the motion:
            # release it if, solved without it, its critical point would not approach (only the
            # approach is ever stopped; a retreat must stay free). "sequential" keeps the claim's
            # literal order: rows added in a cycle stay for that cycle.
            for o in list(active[:-1]) if self.release == "recheck" else []:
                rest = np.array([a for a in active if a != o])
                trial, trial_cond = _solve_stacked(je, yr, rows[rest], zr[rest], *solve_args)
                if float(rows[o] @ trial) >= zr[o] - _RATE_EPS:
                    active.remove(o)
                    q_dot, cond = trial, trial_cond
        return self._result(v, yr, ee_err, crit, q_dot, q_free, cond, active, je)

    def _result(
        self,
        v: FloatArray,
        yr: FloatArray,
        ee_err: float,
        crit: Critical,
        q_dot: FloatArray,
        q_free: FloatArray,
        cond: float,
        active: list[int],
        je: FloatArray,
    ) -> ControlResult:
        """The speed cap and the diagnostics of one cycle (shared by both routes)."""
        rows = crit.rows
        d_dot_free = rows @ q_free
        if self.max_speed is not None:
            # One factor for every joint keeps the direction, hence the sign of every ḋ: a
            # stopped approach stays stopped; the end-effector task is what slows down.
            peak = float(np.max(np.abs(q_dot)))
            if peak > self.max_speed:
                # (q / peak) max_speed: |q / peak| <= 1, so the cap holds exactly; the factor
                # max_speed / peak first could round |q̇| one ulp above it (or be subnormal).
                q_dot = q_dot / peak * self.max_speed
        d_dot = rows @ q_dot
        e = je @ q_dot - yr
        ee_rate_error = math.sqrt(float(e @ e))  # = np.linalg.norm(e)
        # Yielding is measured against the unconstrained solve, whose error is the damping's.
        e = je @ q_free - yr
        ee_rate_error_free = math.sqrt(float(e @ e))
        return self._package(
            v, yr, ee_err, crit, q_dot, cond, active, d_dot, d_dot_free, ee_rate_error,
            ee_rate_error_free,
        )  # fmt: skip

    def _package(
        self,
        v: FloatArray,
        yr: FloatArray,
        ee_err: float,
        crit: Critical,
        q_dot: FloatArray,
        cond: float,
        active: list[int],
        d_dot: FloatArray,
        d_dot_free: FloatArray,
        ee_rate_error: float,
        ee_rate_error_free: float,
    ) -> ControlResult:
        """The zone, the tasks that gave way and the result (shared by every route)."""
        tol = self.task_tolerance
        d = crit.distances
        zl: list[float] = []
        if active:
            zl = (self.spring_gain * np.maximum(0.0, self._rho - d)).tolist()
        dl, rl = (d_dot.tolist(), d.tolist()) if active else ([], [])
        violated = tuple(o for o in active if dl[o] < zl[o] - tol)
        exhausted = len(active) > self.redundancy
        rhol = self._rho_list
        if exhausted:
            zone = "exhausted"
        elif any(rl[o] < rhol[o] for o in active):
            zone = "recovering"
        elif active:
            zone = "active"
        else:
            zone = "free"
        return ControlResult(
            q_dot=q_dot,
            command=v,
            ee_reference=yr,
            zone=zone,
            active=tuple(active),
            critical_points=crit.points,
            links=crit.links,
            fractions=crit.fractions,
            distances=d,
            normals=crit.normals,
            d_dot=d_dot,
            d_dot_free=d_dot_free,
            ee_rate_error=ee_rate_error,
            ee_error=ee_err,
            condition=cond,
            exhausted=exhausted,
            ee_yielded=ee_rate_error > ee_rate_error_free + tol,
            violated=violated,
            redundancy=self.redundancy,
            method=self.method,
        )


#: Former names of :class:`velfence.filter.SphereObstacle`; they construct it until 0.3.
__getattr__ = module_getattr(
    __name__, {"Obstacle": "SphereObstacle", "InfluenceObstacle": "SphereObstacle"}, globals()
)

document_inits(globals())
