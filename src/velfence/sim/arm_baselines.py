r"""Baselines for a serial arm under a Cartesian command: how an arm is usually kept safe.

Comparators for the safety filter (:class:`~velfence.filter.TwistMode`) on any
:class:`~velfence.mechanisms.DHChain`: the arm-in-a-box demo (``docs/arm_box.md``) and the
MuJoCo scenarios run them, and a user can run them beside the filter in the same loop.

Every controller maps a Cartesian TCP velocity command :math:`v` (shape (3,), [m/s]) at the
joint position :math:`q` (shape (n,), [rad]) to a joint velocity :math:`\dot q` (shape (n,),
[rad/s]), and follows the :class:`~velfence.shaping.base.Shaper` contract with the state ``q`` and
the command ``v`` (so :func:`velfence.sim.simulate` runs them in the same loop as the filter).
The first three start from the same damped least-squares (DLS) inverse of the TCP position
Jacobian :math:`J` (shape (3, n), [m/rad]):

.. math:: \dot q_{dls} = J^\top (J J^\top + \lambda I)^{-1} v .

* :class:`ResolvedRate` — no limit: :math:`\dot q_{dls}` as it is.
* :class:`JointClamp` — per-joint clamping as ros2_control's joint limiters do it: every joint
  independently clipped to :math:`[\max(-\dot q^{max}_i, (q^{lo}_i - q_i)/\Delta t),\
  \min(\dot q^{max}_i, (q^{hi}_i - q_i)/\Delta t)]` (the velocity limit and the
  position-derived velocity that lands exactly on the limit in one period). No knowledge of the
  workspace or of obstacles.
* :class:`ScalarScale` — one scalar on the whole joint command, as MoveIt Servo scales it:
  :math:`\dot q = s\,\dot q_{dls}` with the largest :math:`s \in [0, 1]` that keeps every row
  :math:`a_r^\top \dot q \ge -b_r` of the joint-velocity limits, the joint-position dampers
  :math:`\pm\dot q_i \le g_q (q^{hi/lo}_i - q_i)/\Delta t`, and the sphere dampers
  :math:`\dot d \ge -\xi (d - d_s)/(d_i - d_s)` (links within :math:`d_i`), times a singularity
  factor: 1 below the condition number :math:`\kappa_{lo}`, falling linearly to 0 at
  :math:`\kappa_{hi}`, applied only when the step increases :math:`\kappa(J)`. The workspace box
  is not known to it (Servo has no workspace limit).
* :class:`DamperQP` — a QP with velocity dampers as mink and NEO pose it, solved by qpsolvers with
  the daqp back-end:

  .. math:: \min_{\dot q} \|J\dot q - v\|^2 + \lambda\|\dot q\|^2 \quad\text{s.t.}\quad
     \max(-\dot q^{max}, g_q\tfrac{q^{lo} - q}{\Delta t}) \le \dot q \le
     \min(\dot q^{max}, g_q\tfrac{q^{hi} - q}{\Delta t}),\
     \dot d_l \ge -\xi\tfrac{d_l - d_s}{d_i - d_s}\ (d_l \le d_i),\
     n_f^\top J \dot q \ge -g_w\,\tfrac{\delta_f}{\Delta t}

  for every link capsule ``l`` with clearance :math:`d_l` to the sphere and every box face ``f``
  with signed TCP distance :math:`\delta_f` (positive inside). An infeasible QP answers zero
  velocity, zone ``"infeasible"``.

Sphere clearance :math:`d_l = |c - x_l| - r_s - r_l` (centre to link axis, minus both radii),
:math:`\dot d_l = -u_l^\top J_{x_l}\dot q` with :math:`u_l` from the link towards the centre (the
normal of :func:`velfence.geometry.primitives.sphere_capsule_distance`, reversed).

Active rows are named as the filter names them: ``"joint 4 position (upper)"``,
``"joint 2 velocity (lower)"``,
``"TCP face x_max"``, ``"obstacle 0 on link 6"`` (0-based joints, links and obstacles).
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from velfence._deprecate import renamed_attribute
from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_positive, readonly, real_array
from velfence.errors import InvalidInput, InvalidParameter
from velfence.geometry.primitives import points_segments_distances, sphere_capsule_distance
from velfence.mechanisms.chain import ChainFrame, DHChain

if TYPE_CHECKING:
    from velfence.geometry.polytope import ConvexPolytope

__all__ = [
    "ArmStep",
    "DamperQP",
    "JointClamp",
    "ResolvedRate",
    "ScalarScale",
]


class _Limits(Protocol):
    """What the baselines read of a joint-limit set (``velfence.filter.JointLimits``)."""

    @property
    def lower(self) -> FloatArray: ...

    @property
    def upper(self) -> FloatArray: ...

    @property
    def max_speed(self) -> FloatArray: ...


class _Sphere(Protocol):
    """What the baselines read of a sphere (``velfence.filter.SphereObstacle``)."""

    @property
    def center(self) -> FloatArray: ...

    @property
    def radius(self) -> float: ...


@dataclass(frozen=True)
class ArmStep:
    """What an arm controller did in one cycle.

    Attributes:
        output: Joint velocity sent to the robot, shape (n,), [rad/s].
        command: The TCP velocity command, shape (3,), [m/s].
        position: The joint position, shape (n,), [rad].
        zone: ``"free"`` (no row binding), ``"buffer"`` (one), ``"corner"`` (several),
            ``"infeasible"`` (QP without solution; zero output).
        active_names: Names of the binding rows (module docstring).
        stages: What the law applied, in order.
        method: The controller's name.
        scale: The scalar applied by :class:`ScalarScale` (1.0 for the others).
        dropped: Priority levels relaxed (always empty: the baselines have no levels).
    """

    output: FloatArray
    command: FloatArray
    position: FloatArray
    zone: str
    active_names: tuple[str, ...]
    stages: tuple[str, ...]
    method: str
    scale: float = 1.0
    dropped: tuple[str, ...] = field(default=())


def _zone(active: Sequence[str]) -> str:
    return "free" if not active else ("buffer" if len(active) == 1 else "corner")


class _ArmController:
    """Shared validation, kinematics and rows of the baselines."""

    max_velocity = renamed_attribute("max_velocity", "max_speed")

    method = "arm"

    def __init__(
        self,
        robot: DHChain,
        *,
        limits: _Limits,
        workspace: ConvexPolytope | None = None,
        obstacles: Sequence[_Sphere] = (),
        dt: float = 1e-3,
        damping: float = 1e-4,
        position_gain: float = 0.95,
        workspace_gain: float = 0.5,
        obstacle_gain: float = 0.5,
        influence: float = 0.1,
        safety: float = 0.0,
    ) -> None:
        r"""Build a baseline; each subclass's docstring says which arguments its law uses.

        Args:
            robot: The arm (:class:`~velfence.mechanisms.DHChain`).
            limits: Joint limits (``lower``, ``upper``, ``max_speed``, shape (n,) each).
            workspace: The TCP's convex polytope (3-D), or ``None``.
            obstacles: Spheres (``center``, ``radius``) the links keep away from.
            dt: Control period [s], > 0.
            damping: DLS damping :math:`\lambda` [m²], > 0.
            position_gain: Gain of the joint-position rows, dimensionless, > 0.
            workspace_gain: Gain of the workspace rows, > 0.
            obstacle_gain: Gain of the obstacle rows [m/s], > 0.
            influence: Clearance at which obstacle rows start [m], > ``safety``.
            safety: Clearance kept from obstacles [m], >= 0.

        Raises:
            InvalidParameter: a non-chain robot or an out-of-range parameter.
        """
        for attr in ("dof", "ee_jacobian", "end_effector", "link_segments", "point_jacobian"):
            if not hasattr(robot, attr):
                raise InvalidParameter(
                    f"robot must be a serial chain (velfence.mechanisms.DHChain), got "
                    f"{type(robot).__name__} without {attr}"
                )
        self.robot = robot
        # A library chain's frame is built from the q that explain has already validated (no
        # second check of the same vector); any other robot goes through its kinematics(q).
        self._own_frames = getattr(type(robot), "kinematics", None) is DHChain.kinematics
        n = int(robot.dof)
        self.dof = n
        lo = real_array("limits.lower", limits.lower, (n,), error=InvalidParameter)
        hi = real_array("limits.upper", limits.upper, (n,), error=InvalidParameter)
        vmax = real_array("limits.max_speed", limits.max_speed, (n,), error=InvalidParameter)
        if not np.all(lo < hi) or not np.all(vmax > 0.0):
            raise InvalidParameter(
                "limits: expected lower < upper and max_speed > 0 on every joint, got lower "
                f"{lo.tolist()}, upper {hi.tolist()}, max_speed {vmax.tolist()}"
            )
        self.lower, self.upper, self.max_speed = readonly(lo), readonly(hi), readonly(vmax)
        if workspace is not None and getattr(workspace, "dim", None) != 3:
            raise InvalidParameter(
                "workspace: expected a 3-D ConvexPolytope on the TCP or None, got "
                f"{type(workspace).__name__}"
            )
        self.workspace = workspace
        self.obstacles = tuple(obstacles)
        centers = [real_array("obstacles[].center", o.center, (3,)) for o in self.obstacles]
        self._centers = np.array(centers, dtype=float).reshape(-1, 3)
        self._radii = np.array(
            [check_positive("obstacles[].radius", o.radius, unit="m") for o in self.obstacles]
        )
        self._link_radius = np.asarray(robot.link_radius, dtype=float)
        self.dt = check_positive("dt", dt, unit="s")
        self.damping = check_positive("damping", damping, unit="m²")
        self._damped_eye = readonly(self.damping * np.eye(3))  # λI of the 3 x 3 DLS system
        self.position_gain = check_positive("position_gain", position_gain)
        self.workspace_gain = check_positive("workspace_gain", workspace_gain)
        self.obstacle_gain = check_positive("obstacle_gain", obstacle_gain, unit="m/s")
        self.influence = check_positive("influence", influence, unit="m")
        self.safety = check_positive("safety", safety, allow_zero=True, unit="m")
        if not self.influence > self.safety:
            raise InvalidParameter(
                f"influence must exceed safety, got influence={self.influence} m <= "
                f"safety={self.safety} m"
            )

    # ------------------------------------------------------------------ pieces
    def _inputs(self, q: ArrayLike, v: ArrayLike) -> tuple[FloatArray, FloatArray]:
        qa = real_array("q", q, (self.dof,), what="joint positions [rad]")
        va = real_array("twist", v, (3,), what="a TCP velocity [m/s]")
        return qa, va

    def _dls(self, J: FloatArray, v: FloatArray) -> FloatArray:
        A = J @ J.T + self._damped_eye
        return np.asarray(J.T @ np.linalg.solve(A, v), dtype=float)

    def _joint_bounds(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Per-joint velocity box: velocity limits and the position dampers, [rad/s]."""
        g = self.position_gain / self.dt
        lo = np.maximum(-self.max_speed, g * (self.lower - q))
        hi = np.minimum(self.max_speed, g * (self.upper - q))
        return lo, np.maximum(hi, lo)

    def _frame(self, q: FloatArray) -> Any:
        """The pose's kinematics, computed once per step (segments, points, Jacobians)."""
        if self._own_frames:
            return ChainFrame(self.robot, q)
        return self.robot.kinematics(q)

    def _ee_jacobian(self, frame: Any) -> FloatArray:
        """The TCP's Jacobian [m/rad], shape (3, n) (``robot.ee_jacobian`` from the frame)."""
        return np.array(frame.point_jacobian(self.dof - 1, 1.0)[:3], dtype=float)

    def _sphere_rows(self, frame: Any) -> tuple[FloatArray, FloatArray, list[str]]:
        """Damper rows ``a·qd >= -b`` of every link within the influence clearance."""
        if not self.obstacles:
            return np.zeros((0, self.dof)), np.zeros(0), []
        segs = np.asarray(frame.segments(), dtype=float)
        _, clear = points_segments_distances(
            self._centers, segs[:, 0], segs[:, 1], radii=self._link_radius
        )
        rows, bounds, names = [], [], []
        span = self.influence - self.safety
        for i in range(self._centers.shape[0]):
            for link in np.flatnonzero(clear[i] - self._radii[i] <= self.influence):
                d, _, t, n = sphere_capsule_distance(
                    self._centers[i],
                    segs[link, 0],
                    segs[link, 1],
                    sphere_radius=float(self._radii[i]),
                    capsule_radius=float(self._link_radius[link]),
                )
                Jc = np.asarray(frame.point_jacobian(int(link), float(t)), dtype=float)
                rows.append(n @ Jc)  # d_dot = n·(x_dot), n from the centre to the axis
                bounds.append(self.obstacle_gain * (d - self.safety) / span)
                names.append(f"obstacle {i} on link {int(link)}")
        return np.array(rows).reshape(-1, self.dof), np.array(bounds), names

    def _workspace_rows(self, frame: Any, J: FloatArray) -> tuple[FloatArray, FloatArray]:
        if self.workspace is None:
            return np.zeros((0, self.dof)), np.zeros(0)
        p = np.array(frame.segments()[-1, 1, :3], dtype=float)  # the TCP (robot.end_effector)
        d = np.asarray(self.workspace.signed_distances(p), dtype=float)
        N = np.asarray(self.workspace.normals, dtype=float)
        return N @ J, self.workspace_gain * d / self.dt

    def _step(self, q: FloatArray, v: FloatArray) -> ArmStep:
        raise NotImplementedError  # pragma: no cover

    # ------------------------------------------------------------------ the contract
    def explain(self, q: ArrayLike, twist: ArrayLike, /) -> ArmStep:
        """The joint velocity for TCP command ``twist`` at ``q``, with its active rows.

        Args:
            q: Joint position, shape (n,), [rad].
            twist: TCP velocity command, shape (3,), [m/s].

        Raises:
            InvalidInput: a non-finite or wrongly shaped input.
        """
        qa, va = self._inputs(q, twist)
        res = self._step(qa, va)
        if not all(map(math.isfinite, res.output.tolist())):
            raise InvalidInput(
                f"{self.method}: the joint velocity is not finite at q={qa.tolist()}"
            )
        return res

    def shape(self, q: ArrayLike, twist: ArrayLike, /) -> FloatArray:
        """``explain(q, twist).output``, shape (n,), [rad/s]."""
        return self.explain(q, twist).output

    def shape_batch(self, Q: ArrayLike, V: ArrayLike, /) -> FloatArray:
        """:meth:`shape` row by row: ``Q`` (N, n) [rad], ``V`` (N, 3) [m/s] -> (N, n) [rad/s]."""
        Qa = real_array("Q", Q, (None, self.dof), what="joint positions [rad]")
        Va = real_array("V", V, (Qa.shape[0], 3), what="TCP velocities [m/s]")
        return np.array([self.shape(q, v) for q, v in zip(Qa, Va, strict=True)]).reshape(
            Qa.shape[0], self.dof
        )


class ResolvedRate(_ArmController):
    r"""No limit: the damped least-squares joint velocity of the TCP command (module docstring).

    Args:
        robot: The arm (:class:`~velfence.mechanisms.DHChain`).
        limits: Joint limits (``lower``, ``upper``, ``max_speed``, shape (n,) each); unused
            here, kept so every baseline is built the same way.
        damping: DLS damping :math:`\lambda` [m²], > 0.
    """

    method = "no-limit"

    def _step(self, q: FloatArray, v: FloatArray) -> ArmStep:
        qd = self._dls(self._ee_jacobian(self._frame(q)), v)
        return ArmStep(qd, v, q, "free", (), ("dls",), self.method)


class JointClamp(_ArmController):
    """Per-joint clamping, ros2_control style (module docstring): no workspace knowledge.

    Args:
        robot: The arm.
        limits: Joint limits (``lower``, ``upper``, ``max_speed``, shape (n,) each).
        dt: Control period [s], > 0 (the position-derived velocity lands on the limit in one).
        damping: DLS damping [m²], > 0.
    """

    method = "per-joint-clamp"

    def _step(self, q: FloatArray, v: FloatArray) -> ArmStep:
        qd = self._dls(self._ee_jacobian(self._frame(q)), v)
        lo = np.maximum(-self.max_speed, (self.lower - q) / self.dt)
        hi = np.maximum(np.minimum(self.max_speed, (self.upper - q) / self.dt), lo)
        out = np.clip(qd, lo, hi)
        names = []
        for i in np.flatnonzero(out != qd):
            side = "upper" if qd[i] > 0 else "lower"
            pos = ((self.upper if qd[i] > 0 else self.lower)[i] - q[i]) / self.dt
            kind = "position" if abs(pos) < self.max_speed[i] else "velocity"
            names.append(f"joint {int(i)} {kind} ({side})")
        return ArmStep(out, v, q, _zone(names), tuple(names), ("dls", "clamp"), self.method)


class ScalarScale(_ArmController):
    r"""One scalar on the whole joint command, MoveIt Servo style (module docstring).

    Args:
        robot: The arm.
        limits: Joint limits (``lower``, ``upper``, ``max_speed``, shape (n,) each).
        obstacles: Spheres (``center`` (3,) [m], ``radius`` [m]).
        dt: Control period [s], > 0.
        damping: DLS damping [m²], > 0.
        position_gain: :math:`g_q`, > 0 (fraction of the distance to a joint limit per period).
        obstacle_gain: :math:`\xi` [m/s], > 0.
        influence: :math:`d_i` [m], > ``safety``.
        safety: :math:`d_s` [m], >= 0.
        singular_slow: :math:`\kappa_{lo}`, condition number where slowing starts, > 1.
        singular_stop: :math:`\kappa_{hi}`, condition number of a full stop, > ``singular_slow``.
    """

    method = "scalar-scale"

    def __init__(
        self,
        robot: DHChain,
        *,
        singular_slow: float = 17.0,
        singular_stop: float = 30.0,
        **kwargs: Any,
    ) -> None:
        super().__init__(robot, **kwargs)
        self.singular_slow = check_positive("singular_slow", singular_slow)
        self.singular_stop = check_positive("singular_stop", singular_stop)
        if not 1.0 < self.singular_slow < self.singular_stop:
            raise InvalidParameter(
                "singular_slow, singular_stop: expected 1 < singular_slow < singular_stop, got "
                f"{self.singular_slow} and {self.singular_stop}"
            )

    @staticmethod
    def _condition(J: FloatArray) -> float:
        sv = np.linalg.svd(J, compute_uv=False)
        return float(sv[0] / sv[-1]) if sv[-1] > 0.0 else math.inf

    def _step(self, q: FloatArray, v: FloatArray) -> ArmStep:
        frame = self._frame(q)
        J = self._ee_jacobian(frame)
        qd = self._dls(J, v)
        s, why = 1.0, ""
        lo, hi = self._joint_bounds(q)
        # The scan in Python floats (the same IEEE operations as on NumPy scalars, without
        # their per-operation overhead).
        his, los, qds = hi.tolist(), lo.tolist(), qd.tolist()
        vmax = self.max_speed.tolist()
        for i in range(self.dof):
            for bound, x, side in ((his[i], qds[i], "upper"), (-los[i], -qds[i], "lower")):
                if x > 0.0 and bound / x < s:
                    s = max(0.0, bound / x)
                    at_v = abs(bound - vmax[i]) <= 1e-12
                    why = f"joint {i} {'velocity' if at_v else 'position'} ({side})"
        rows, bounds, names = self._sphere_rows(frame)
        for a, b, name in zip(rows, bounds.tolist(), names, strict=True):
            rate = float(a @ qd)
            if rate < 0.0 and b / -rate < s:
                s, why = max(0.0, b / -rate), name
        kappa = self._condition(J)
        if kappa > self.singular_slow:
            ahead = self._condition(self._ee_jacobian(self._frame(q + self.dt * qd)))
            if ahead > kappa:
                f = (self.singular_stop - kappa) / (self.singular_stop - self.singular_slow)
                f = min(1.0, max(0.0, f))
                if f < s:
                    s, why = f, "singularity"
        active = (why,) if why else ()
        return ArmStep(s * qd, v, q, _zone(active), active, ("dls", "scale"), self.method, s)


def _qpsolvers() -> Any:
    try:
        qp = importlib.import_module("qpsolvers")
    except ImportError:
        raise InvalidParameter(
            "DamperQP needs qpsolvers, which is not installed; install it with "
            "pip install 'velfence[qp]' (qpsolvers + daqp)"
        ) from None
    if "daqp" not in qp.available_solvers:
        raise InvalidParameter(
            f"DamperQP needs the daqp back-end of qpsolvers, got only {qp.available_solvers}; "
            "pip install daqp"
        )
    return qp


class DamperQP(_ArmController):
    r"""A velocity-damper QP, mink style, solved by qpsolvers + daqp (module docstring).

    Args:
        robot: The arm.
        limits: Joint limits (``lower``, ``upper``, ``max_speed``, shape (n,) each).
        workspace: The TCP box (a 3-D :class:`~velfence.geometry.polytope.ConvexPolytope`).
        obstacles: Spheres (``center`` (3,) [m], ``radius`` [m]).
        dt: Control period [s], > 0.
        damping: :math:`\lambda` [m²/rad²], > 0.
        position_gain: :math:`g_q`, > 0.
        workspace_gain: :math:`g_w`, > 0 (fraction of the face distance closed per period).
        obstacle_gain: :math:`\xi` [m/s], > 0.
        influence: :math:`d_i` [m], > ``safety``.
        safety: :math:`d_s` [m], >= 0.
        tolerance: Slack below which a row counts as binding [m/s or rad/s], > 0.

    Raises:
        InvalidParameter: bad parameters, or qpsolvers / daqp not installed.
    """

    method = "velocity-damper-qp"

    def __init__(self, robot: DHChain, *, tolerance: float = 1e-6, **kwargs: Any) -> None:
        super().__init__(robot, **kwargs)
        self.tolerance = check_positive("tolerance", tolerance)
        self._qp = _qpsolvers()
        self._damped_eye_n = readonly(self.damping * np.eye(self.dof))  # λI of the QP's Hessian
        self._faces: tuple[Any, list[str]] = (None, [])  # (workspace, its rows' names)

    def _step(self, q: FloatArray, v: FloatArray) -> ArmStep:
        frame = self._frame(q)
        J = self._ee_jacobian(frame)
        n = self.dof
        P = J.T @ J + self._damped_eye_n
        c = -(J.T @ v)
        lo, hi = self._joint_bounds(q)
        S, sb, snames = self._sphere_rows(frame)
        W, wb = self._workspace_rows(frame, J)
        if self._faces[0] is not self.workspace:  # named once per workspace, not per step
            ws = self.workspace
            self._faces = (ws, [] if ws is None else [f"TCP face {f}" for f in ws.facet_names])
        wnames = self._faces[1]
        G = np.vstack([S, W])  # rows a·qd >= -b, i.e. -a·qd <= b
        b = np.concatenate([sb, wb])
        x = self._qp.solve_qp(
            0.5 * (P + P.T), c, -G if G.size else None, b if G.size else None,
            lb=lo, ub=hi, solver="daqp",
        )  # fmt: skip
        if x is None:
            return ArmStep(np.zeros(n), v, q, "infeasible", (), ("qp",), self.method)
        qd = np.asarray(x, dtype=float).reshape(n)
        tol = self.tolerance
        names = [
            name
            for name, a, bound in zip(snames + wnames, G, b, strict=True)
            if float(a @ qd) <= -bound + tol
        ]
        # The joint scan in Python floats (the same IEEE operations as on NumPy scalars).
        qds, his, los, vmax = qd.tolist(), hi.tolist(), lo.tolist(), self.max_speed.tolist()
        for i in range(n):
            if qds[i] >= his[i] - tol or qds[i] <= los[i] + tol:
                at_v = min(abs(qds[i]) - vmax[i], 0.0) >= -tol
                side = "upper" if qds[i] >= his[i] - tol else "lower"
                names.append(f"joint {i} {'velocity' if at_v else 'position'} ({side})")
        return ArmStep(qd, v, q, _zone(names), tuple(names), ("qp",), self.method)


document_inits(globals())
