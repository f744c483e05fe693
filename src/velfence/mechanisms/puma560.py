r"""PUMA 560 kinematics as run in Khokar 2009: FK, Jacobian, manipulability, IK.

The implemented kinematics of the thesis are its eqs. 11-22, which are the **standard-DH PUMA of
Fu, Gonzalez & Lee** (checked against the recorded end points of Tables 4/5; repair T1 of
``docs/telerobotics.md`` §8):

============  =========  ========  ===========
joint         a [m]      d [m]     alpha
============  =========  ========  ===========
1             0          0         -π/2
2             0.4318     0.15      0
3             -0.0203    0         +π/2
4             0          0.4331    -π/2
5             0          0         +π/2
6             0          0 (d6)    0
============  =========  ========  ===========

Base frame at the shoulder, z up; frame 6 at the wrist centre (d6 = 0). The DH frames come from
:meth:`velfence.mechanisms.chain.DHChain.frames` of :meth:`DHChain.puma560` (one DH routine in the
library).

**Craig convention.** The thesis also prints a modified-DH table (its Table 2, Craig's
:math:`α_{i-1}, a_{i-1}, d_i, θ_i`) with :math:`a_3 = +0.0203` m, which is *not* the product its
FK formulas implement (repairs T1-T2). Both describe the same physical arm:

.. math:: T^{\text{fu}}_6(q) = T^{\text{craig}}_6(q_1, q_2, q_3 + π, q_4, q_5, q_6)\,R_z(π),

i.e. Craig's joint-3 angle is offset by π and its tool x6, y6 axes are reversed (z6 unchanged);
all joint senses agree. ``Puma560(convention="craig")`` takes Craig joint angles and returns the
Craig frame-6 pose; the laser offset of eq. 40 reads (+0.026, +0.115, 0.115) m in that tool frame
instead of (-0.026, -0.115, 0.115) m.

**Inverse kinematics** (thesis §4.4.1, corrected: repair T4): closed form for the wrist centre
(:math:`θ_1` from the shoulder offset, :math:`θ_3` from the law of cosines, :math:`θ_2` from the
planar arm), then the wrist, whose rotation :math:`{}^3R_6 = R_z(θ_4) R_y(θ_5) R_z(θ_6)` is a ZYZ
Euler triple in this DH convention. Branch labels follow Fu, Gonzalez & Lee's indicators
(shoulder = ARM, elbow = ELBOW) and the sign of :math:`\sin θ_5` (wrist); see
:meth:`Puma560.configuration`.

Units: metres, radians; poses are 4 x 4 homogeneous transforms in the base frame.
"""

from __future__ import annotations

import math
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import check_choice, check_flag, readonly, real_array, rigid_transform
from velfence.errors import InvalidGeometry, InvalidInput
from velfence.mechanisms.chain import DHChain

__all__ = [
    "CONFIGURATIONS",
    "CRAIG_TABLE2",
    "Puma560",
]

Shoulder = Literal["right", "left"]
Elbow = Literal["up", "down"]
WristLabel = Literal["noflip", "flip"]
Configuration = tuple[Shoulder, Elbow, WristLabel]

DHConvention = Literal["fu", "craig"]
_CONVENTIONS: tuple[DHConvention, ...] = get_args(DHConvention)
_SHOULDERS: tuple[Shoulder, ...] = get_args(Shoulder)
_ELBOWS: tuple[Elbow, ...] = get_args(Elbow)
_WRISTS: tuple[WristLabel, ...] = get_args(WristLabel)

CONFIGURATIONS: tuple[Configuration, ...] = tuple(
    (s, e, w) for s in _SHOULDERS for e in _ELBOWS for w in _WRISTS
)
"""The 8 IK branches ``(shoulder, elbow, wrist)`` in a fixed order."""

CRAIG_TABLE2: FloatArray = readonly(
    np.array(
        [
            # alpha_{i-1} [deg], a_{i-1} [m], d_i [m]   (thesis Table 2, as printed)
            [0.0, 0.0, 0.0],
            [-90.0, 0.0, 0.0],
            [0.0, 0.4318, 0.15],
            [-90.0, 0.0203, 0.4331],
            [90.0, 0.0, 0.0],
            [-90.0, 0.0, 0.0],
        ]
    )
)
"""Thesis Table 2 (modified DH, Craig): rows ``(alpha_{i-1} [deg], a_{i-1} [m], d_i [m])``, (6, 3).

Documentation only: ``convention="craig"`` is computed from the standard-DH chain with the offsets
of the module docstring, and the tests check it against these rows multiplied out independently.
"""

_ROT_Z_PI = readonly(np.diag([-1.0, -1.0, 1.0, 1.0]))
# Tolerances for accepting a pose: rotation orthonormal to 1e-6 (poses read from logs with 6-7
# significant digits pass), bottom row exact to 1e-9.
_ROT_TOL = 1e-6
# Relative slack under which a radicand slightly below zero (round-off at the workspace boundary)
# is treated as zero rather than unreachable.
_BOUNDARY_SLACK = 1e-10


def _wrap(a: float) -> float:
    """Angle in [-π, π) [rad]."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _fit(a: float, lo: float, hi: float) -> float:
    """The 2π-equivalent of ``a`` inside [lo, hi] of smallest magnitude, else ``wrap(a)``."""
    w = _wrap(a)
    for cand in sorted((w, w - 2.0 * math.pi, w + 2.0 * math.pi), key=abs):
        if lo <= cand <= hi:
            return cand
    return w


class Puma560:
    r"""PUMA 560 kinematics of Khokar 2009: FK, geometric Jacobian, manipulability, closed-form IK.

    See the module docstring for the DH table and the two conventions. The tool frame is frame 6
    (the wrist centre, d6 = 0) composed with ``tool``.

    Args:
        convention: ``"fu"`` (default): the implemented standard-DH kinematics of the thesis's
            eqs. 11-22 (Fu, Gonzalez & Lee). ``"craig"``: the printed modified-DH Table 2
            (a3 = +0.0203 m), whose joint-3 angle is the ``"fu"`` one plus π and whose frame 6 is
            the ``"fu"`` frame 6 turned by π about z6.
        tool: Tool frame in frame 6 of the chosen convention: ``None`` (identity, tool point =
            wrist centre as in the thesis), a translation ``(x, y, z)`` [m] of shape (3,), or a
            rigid 4 x 4 homogeneous transform (rotation part orthonormal, det +1).
        joint_limits: Lower/upper limit per joint in the chosen convention's angles [rad], shape
            (6, 2). Default: :meth:`DHChain.puma560`'s limits (deg: (-160, 160), (-225, 45),
            (-45, 225), (-110, 170), (-100, 100), (-266, 266)), joint 3 shifted by +π for
            ``"craig"``. The thesis gives none.

    Raises:
        InvalidParameter: Unknown convention or bad joint limits.
        InvalidGeometry: A tool that is not a finite (3,) translation or rigid (4, 4) transform.
    """

    def __init__(
        self,
        *,
        convention: DHConvention = "fu",
        tool: ArrayLike | None = None,
        joint_limits: ArrayLike | None = None,
    ) -> None:
        check_choice("convention", convention, _CONVENTIONS)
        self._convention = convention
        tool_T = _tool_transform(tool)
        # Everything is computed in the "fu" (standard DH) description; for "craig" the flange
        # transform absorbs the Rz(π) of frame 6 and joint 3 carries a -π offset.
        if convention == "craig":
            flange = _ROT_Z_PI @ tool_T
            offset = np.array([0.0, 0.0, math.pi, 0.0, 0.0, 0.0])
        else:
            flange = tool_T
            offset = np.zeros(6)
        self._tool = readonly(tool_T)
        self._flange = readonly(flange)
        self._flange_inv = readonly(_rigid_inverse(flange))
        self._offset = readonly(offset)
        base = DHChain.puma560()
        dh = np.array(base.dh)
        dh[:, 3] -= offset
        if joint_limits is None:
            joint_limits = np.array(base.joint_limits) + offset[:, None]
        self._chain = DHChain(
            dh,
            joint_limits=joint_limits,
            tool=flange[:3, 3],
            named_points={"elbow": 2, "wrist": 4},
        )
        fu = base.dh
        self._a2 = float(fu[1, 0])
        self._a3 = float(fu[2, 0])
        self._d3 = float(fu[1, 2])  # the thesis's "d3" = FGL's shoulder offset d2
        self._d4 = float(fu[3, 2])

    # ----------------------------------------------------------------------------------------
    # Properties
    # ----------------------------------------------------------------------------------------
    @property
    def convention(self) -> str:
        """``"fu"`` or ``"craig"``: which joint angles and frame 6 the methods use."""
        return self._convention

    @property
    def chain(self) -> DHChain:
        """The standard-DH chain (6 joints) in this convention's joint angles.

        Its tool point is this robot's tool point, so its ``link_segments``, ``point_jacobian``
        and ``end_effector`` serve configuration control and capsule geometry. Its DH frames are
        always the ``"fu"`` ones (joint 3 offset by -π for ``"craig"``).
        """
        return self._chain

    @property
    def joint_limits(self) -> FloatArray:
        """Lower/upper joint limits [rad], shape (6, 2), read-only."""
        return self._chain.joint_limits

    @property
    def tool(self) -> FloatArray:
        """Tool frame in frame 6 of this convention, 4 x 4 homogeneous transform, read-only."""
        return self._tool

    @property
    def reach(self) -> float:
        r"""Largest distance [m] of the wrist centre from the base origin.

        :math:`\sqrt{(a_2 + \sqrt{a_3^2 + d_4^2})^2 + d_3^2}` ≈ 0.8783 m.
        """
        return math.hypot(self._a2 + math.hypot(self._a3, self._d4), self._d3)

    # ----------------------------------------------------------------------------------------
    # Forward kinematics, Jacobian, manipulability
    # ----------------------------------------------------------------------------------------
    @property
    def dof(self) -> int:
        """Number of joints, 6."""
        return 6

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names ``"joint0"`` … ``"joint5"`` (the ``Kinematics`` protocol)."""
        return self._chain.joint_names

    @property
    def points(self) -> tuple[str, ...]:
        """Named points of :meth:`fk` and :meth:`jacobian` (the ``Kinematics`` protocol).

        ``"tcp"`` (the tool point), ``"flange"`` (frame 6's origin, the wrist centre),
        ``"elbow"`` (joint 2's point), ``"wrist"`` (the wrist centre) and ``"joint0"`` …
        ``"joint5"`` (see :meth:`DHChain.fk`).
        """
        return self._chain.points

    def fk(self, q: ArrayLike, point: str | None = None) -> FloatArray:
        """Tool pose in the base frame (thesis eqs. 11-22 composed with the tool), or a point.

        Without ``point`` this is the pose (the teleoperation code's use); with a point name it
        is that point's position, as the ``Kinematics`` protocol of
        :mod:`velfence.filter` asks (the safety filter always names the point).

        Args:
            q: Joint angles [rad], shape (6,), in this convention.
            point: ``None`` for the tool pose, else a name from :attr:`points`.

        Returns:
            Homogeneous transform ``[[R, p], [0, 1]]`` (p in [m]), shape (4, 4); or with
            ``point`` the position [m], shape (3,).

        Raises:
            InvalidInput: ``q`` of the wrong shape or not finite, or an unknown ``point``.
        """
        if point is not None:
            return self._chain.fk(q, point)
        T6: FloatArray = self._chain.frames(q)[6] @ self._flange
        return T6

    def kinematics(self, q: ArrayLike) -> Any:
        """The pose's kinematics computed once (``velfence.filter.KinematicsFrame``).

        The chain's :meth:`DHChain.kinematics` (named points, their Jacobians, link segments).

        Args:
            q: Joint angles [rad], shape (6,), in this convention.
        """
        return self._chain.kinematics(q)

    def chain_data(self) -> Any:
        """The chain as DH data (:meth:`DHChain.chain_data`), for compiled routes."""
        return self._chain.chain_data()

    def angular_jacobian(self, q: ArrayLike) -> FloatArray:
        """Angular-velocity rows of :meth:`jacobian`: the joint axes, shape (3, 6)."""
        return self._chain.angular_jacobian(q)

    def position(self, q: ArrayLike) -> FloatArray:
        """Tool point in the base frame.

        Args:
            q: Joint angles [rad], shape (6,).

        Returns:
            Position [m], shape (3,).
        """
        return np.array(self.fk(q)[:3, 3])

    def jacobian(self, q: ArrayLike, point: str | None = None) -> FloatArray:
        r"""Base-frame geometric Jacobian of the tool point (thesis eqs. 28-31, "Jac0").

        With a ``point`` name: that point's linear-velocity Jacobian (3, 6) instead, as the
        ``Kinematics`` protocol asks (:meth:`DHChain.jacobian`).

        Column ``i`` is :math:`[z_{i-1} \times (p - o_{i-1});\ z_{i-1}]` with :math:`z_{i-1},
        o_{i-1}` the axis and origin of joint ``i`` and ``p`` the tool point, so
        ``[v; ω] = J(q) q̇`` with ``v`` the tool point's velocity [m/s] and ``ω`` the angular
        velocity [rad/s], both in the base frame.

        Args:
            q: Joint angles [rad], shape (6,).
            point: ``None`` for the tool's 6 x 6 Jacobian, else a name from :attr:`points`.

        Returns:
            ``J`` of shape (6, 6): rows 0-2 in [m/rad], rows 3-5 dimensionless; with ``point``
            shape (3, 6) [m/rad].
        """
        if point is not None:
            return self._chain.jacobian(q, point)
        return self._jacobian_validated(self._chain._q(q))

    def _jacobian_validated(self, q: FloatArray) -> FloatArray:
        r""":meth:`jacobian` of the tool for a validated ``q`` (finite float64, shape (6,)).

        From the chain's one-pass kinematics (floats, no 4 x 4 products): joint axes
        :math:`z_j`, origins :math:`o_j` and the tool point ``p`` (the chain's tool is the
        flange offset), columns :math:`[z_j \times (p - o_j);\ z_j]`.
        """
        pts, axes, _ = self._chain._kinematics_lists(q.tolist())
        px, py, pz = pts[6]
        J = np.empty((6, 6))
        cols = []
        for (ox, oy, oz), (zx, zy, zz) in zip(pts, axes, strict=False):
            dx, dy, dz = px - ox, py - oy, pz - oz
            cols.append((zy * dz - zz * dy, zz * dx - zx * dz, zx * dy - zy * dx, zx, zy, zz))
        J[:] = cols
        return J.T.copy()

    def _jacobian_frames(self, q: ArrayLike) -> FloatArray:
        """The former route of :meth:`jacobian` (4 x 4 DH frames), kept as the test oracle."""
        F = self._chain.frames(q)
        p = F[6, :3, :3] @ self._flange[:3, 3] + F[6, :3, 3]
        z = F[:6, :3, 2]
        o = F[:6, :3, 3]
        J = np.empty((6, 6))
        J[:3] = np.cross(z, p[None, :] - o).T
        J[3:] = z.T
        return J

    def manipulability(self, q: ArrayLike) -> float:
        r"""Yoshikawa manipulability :math:`w = \sqrt{\det(J J^T)}` (thesis eq. 33).

        For the square 6 x 6 Jacobian this equals :math:`|\det J|`, which is how it is computed
        (no square root of a round-off negative). It does not depend on the tool point or on the
        frame ``J`` is expressed in (both change ``J`` by a factor of determinant ±1), so it is
        the quantity the thesis's threshold ``w0 = 0.014`` (eq. 37) was tuned on; units
        [m³/rad³] in the mixed ``[v; ω]`` rows. In closed form
        :math:`|a_2 (d_4 c_3 - a_3 s_3)(a_2 c_2 + a_3 c_{23} + d_4 s_{23}) \sin θ_5|` (elbow,
        shoulder and wrist singularities).

        Args:
            q: Joint angles [rad], shape (6,).

        Returns:
            ``w >= 0``.
        """
        return float(abs(np.linalg.det(self.jacobian(q))))

    # ----------------------------------------------------------------------------------------
    # Configuration labels, limits
    # ----------------------------------------------------------------------------------------
    def configuration(self, q: ArrayLike) -> Configuration:
        r"""IK branch labels ``(shoulder, elbow, wrist)`` of a joint vector.

        With the ``"fu"`` angles (Fu, Gonzalez & Lee's indicators):

        * shoulder ``"right"`` when :math:`r = a_2 c_2 + a_3 c_{23} + d_4 s_{23} \le 0` (ARM = +1),
          else ``"left"`` (``r`` is the wrist centre's reach in the arm plane, signed);
        * elbow ``"up"`` when ARM · sign(:math:`d_4 c_3 - a_3 s_3`) = +1 (ELBOW = +1), else
          ``"down"``;
        * wrist ``"noflip"`` when :math:`\sin θ_5 \le 0`, ``"flip"`` otherwise (the two wrist
          solutions are :math:`(θ_4, θ_5, θ_6)` and :math:`(θ_4 + π, -θ_5, θ_6 + π)`). The sign
          is chosen so that every pose the thesis records (§7.1, §7.4: all have
          :math:`θ_5 < 0`) is ``("right", "up", "noflip")``, the default branch of :meth:`ik`.

        At a singularity (``r = 0``, stretched elbow, ``sin θ_5 = 0``) the labels are the
        limits of these rules and two branches coincide.

        Args:
            q: Joint angles [rad], shape (6,), in this convention.

        Returns:
            ``(shoulder, elbow, wrist)``.
        """
        qf = self._chain._q(q) - self._offset
        c2, c3, s3 = math.cos(qf[1]), math.cos(qf[2]), math.sin(qf[2])
        c23, s23 = math.cos(qf[1] + qf[2]), math.sin(qf[1] + qf[2])
        r = self._a2 * c2 + self._a3 * c23 + self._d4 * s23
        arm = 1.0 if r <= 0.0 else -1.0
        elbow_sign = self._d4 * c3 - self._a3 * s3
        elbow = arm * (1.0 if elbow_sign >= 0.0 else -1.0)
        return (
            "right" if arm > 0 else "left",
            "up" if elbow > 0 else "down",
            "noflip" if math.sin(qf[4]) <= 0.0 else "flip",
        )

    def within_limits(self, q: ArrayLike, *, tol: float = 0.0) -> bool:
        """Whether every joint lies in ``[lower - tol, upper + tol]``.

        Args:
            q: Joint angles [rad], shape (6,).
            tol: Allowed excursion beyond each limit [rad], ``>= 0``.

        Returns:
            ``True`` when all joints are within their limits.
        """
        return self._chain.within_limits(q, tol=tol)

    # ----------------------------------------------------------------------------------------
    # Inverse kinematics
    # ----------------------------------------------------------------------------------------
    def ik(
        self,
        T: ArrayLike,
        *,
        shoulder: Shoulder = "right",
        elbow: Elbow = "up",
        wrist: WristLabel = "noflip",
        respect_limits: bool = False,
    ) -> FloatArray:
        r"""Closed-form inverse kinematics of one branch (thesis §4.4.1, corrected).

        Wrist centre :math:`p` (frame 6 origin, from ``T`` and the tool), then

        * :math:`θ_1 = \operatorname{atan2}(p_y, p_x) - \operatorname{atan2}(d_3, r)`,
          :math:`r = \mp\sqrt{p_x^2 + p_y^2 - d_3^2}` (right: −);
        * :math:`θ_3 = \operatorname{atan2}(κ, ±\sqrt{4a_2^2(a_3^2+d_4^2) - κ^2}) -
          \operatorname{atan2}(a_3, d_4)`, :math:`κ = r^2 + p_z^2 - a_2^2 - a_3^2 - d_4^2`
          (sign = ARM · ELBOW);
        * :math:`θ_{23} = \operatorname{atan2}(w_2 r - w_1 p_z, w_1 r + w_2 p_z)`,
          :math:`w_1 = a_2 c_3 + a_3`, :math:`w_2 = d_4 + a_2 s_3`, :math:`θ_2 = θ_{23} - θ_3`;
        * :math:`{}^3R_6 = R_z(θ_4)R_y(θ_5)R_z(θ_6)` solved as ZYZ Euler angles with
          :math:`\sin θ_5 \le 0` (``"noflip"``) or :math:`\ge 0` (``"flip"``); at
          :math:`\sin θ_5 = 0` the wrist is singular and :math:`θ_4 = 0` is chosen.

        These are the thesis's steps 1-3 with our corrections (repair T4 of ``docs/telerobotics.md``
        §8: ``-d3²`` in step 1, :math:`θ_3` not :math:`θ_1`, the ``*`` products of
        :math:`θ_{23}`); the wrist is solved
        from :math:`{}^3R_6` rather than the thesis's element formulas (same solutions). Each
        angle is returned as the 2π-equivalent inside the joint limits of smallest magnitude when
        one exists, else wrapped to [-π, π).

        Args:
            T: Desired tool pose in the base frame, shape (4, 4) (rigid; [m] translation).
            shoulder: ``"right"`` or ``"left"`` (see :meth:`configuration`).
            elbow: ``"up"`` or ``"down"``.
            wrist: ``"noflip"`` or ``"flip"``.
            respect_limits: Raise :class:`InvalidInput` when the branch's solution violates
                the joint limits (the thesis's step 9) instead of returning it.

        Returns:
            Joint angles [rad], shape (6,), in this convention, with ``fk(q) == T``.

        Raises:
            InvalidInput: ``T`` not a finite rigid transform, the wrist centre out of reach (the
                message names its distance and the reach), or limits violated with
                ``respect_limits=True``.
            InvalidParameter: Unknown branch label.
        """
        check_choice("shoulder", shoulder, _SHOULDERS)
        check_choice("elbow", elbow, _ELBOWS)
        check_choice("wrist", wrist, _WRISTS)
        check_flag("respect_limits", respect_limits)
        T6 = _pose(T) @ self._flange_inv
        q = self._solve(T6, shoulder, elbow, wrist)
        if respect_limits and not self._chain.within_limits(q):
            lo, hi = self.joint_limits[:, 0], self.joint_limits[:, 1]
            bad = np.flatnonzero((q < lo) | (q > hi))
            raise InvalidInput(
                f"T: expected a pose reachable within the joint limits on branch "
                f"({shoulder}, {elbow}, {wrist}), got joint(s) {(bad + 1).tolist()} at "
                f"{np.round(q[bad], 4).tolist()} rad outside "
                f"{np.round(self.joint_limits[bad], 4).tolist()}; try another branch "
                "(ik_all) or pass respect_limits=False"
            )
        return q

    def ik_all(
        self, T: ArrayLike, *, respect_limits: bool = False
    ) -> dict[tuple[str, str, str], FloatArray]:
        """Every IK branch that reaches ``T``.

        Args:
            T: Desired tool pose in the base frame, shape (4, 4).
            respect_limits: Leave out branches whose solution violates the joint limits.

        Returns:
            ``{(shoulder, elbow, wrist): q}`` with ``q`` of shape (6,) [rad], in the order of
            :data:`CONFIGURATIONS`; empty when only the joint limits exclude every branch.

        Raises:
            InvalidInput: ``T`` not a finite rigid transform, or the wrist centre out of reach
                (then no branch exists).
        """
        check_flag("respect_limits", respect_limits)
        T6 = _pose(T) @ self._flange_inv
        out: dict[tuple[str, str, str], FloatArray] = {}
        for s, e, w in CONFIGURATIONS:
            q = self._solve(T6, s, e, w)
            if not respect_limits or self._chain.within_limits(q):
                out[(s, e, w)] = q
        return out

    def ik_nearest(
        self, T: ArrayLike, q_ref: ArrayLike, *, respect_limits: bool = True
    ) -> FloatArray:
        """The IK solution closest to ``q_ref`` (thesis §4.4.1: "closest to the current").

        Distance is the Euclidean norm of the joint differences, each wrapped to [-π, π).

        Args:
            T: Desired tool pose in the base frame, shape (4, 4).
            q_ref: Reference (current) joint angles [rad], shape (6,).
            respect_limits: Only consider branches within the joint limits.

        Returns:
            Joint angles [rad], shape (6,).

        Raises:
            InvalidInput: Bad ``T`` or ``q_ref``, ``T`` out of reach, or no branch within the
                limits.
        """
        ref = self._chain._q(q_ref, "q_ref")
        check_flag("respect_limits", respect_limits)
        sols = self.ik_all(T, respect_limits=respect_limits)
        if not sols:
            raise InvalidInput(
                "T: expected a pose reachable within the joint limits, got one that every IK "
                "branch reaches only outside them; pass respect_limits=False to see them"
            )
        best = min(
            sols.values(),
            key=lambda q: float(np.linalg.norm((q - ref + math.pi) % (2 * math.pi) - math.pi)),
        )
        return np.array(best)

    def _solve(self, T6: FloatArray, shoulder: str, elbow: str, wrist: str) -> FloatArray:
        """One branch for a frame-6 pose of this convention (already validated)."""
        a2, a3, d3, d4 = self._a2, self._a3, self._d3, self._d4
        # Frame 6 of "fu": for "craig" the flange already folded in Rz(π).
        px, py, pz = (float(v) for v in T6[:3, 3])
        arm = 1.0 if shoulder == "right" else -1.0
        rho2 = a3 * a3 + d4 * d4
        rad1 = px * px + py * py - d3 * d3
        if rad1 < -_BOUNDARY_SLACK * d3 * d3:
            raise InvalidInput(
                f"T: expected a wrist centre at least d3 = {d3:g} m from the joint-1 axis, got "
                f"{math.hypot(px, py):.6g} m (wrist centre {np.round([px, py, pz], 6).tolist()} "
                f"m, reach {self.reach:.6g} m); the shoulder offset makes this pose unreachable"
            )
        r = -arm * math.sqrt(max(rad1, 0.0))
        th1 = math.atan2(py, px) - math.atan2(d3, r)
        kappa = r * r + pz * pz - a2 * a2 - rho2
        rad3 = 4.0 * a2 * a2 * rho2 - kappa * kappa
        if rad3 < -_BOUNDARY_SLACK * 4.0 * a2 * a2 * rho2:
            dist = math.hypot(r, pz)
            far = a2 + math.sqrt(rho2)
            near = abs(a2 - math.sqrt(rho2))
            raise InvalidInput(
                f"T: expected a wrist centre within the reach, got distance {dist:.6g} m from "
                f"the shoulder in the arm plane (allowed [{near:.6g}, {far:.6g}] m; "
                f"{math.sqrt(px * px + py * py + pz * pz):.6g} m from the base origin, reach "
                f"{self.reach:.6g} m); move the target closer to the shoulder"
            )
        elbow_sign = arm * (1.0 if elbow == "up" else -1.0)
        th3 = math.atan2(kappa, elbow_sign * math.sqrt(max(rad3, 0.0))) - math.atan2(a3, d4)
        c3, s3 = math.cos(th3), math.sin(th3)
        w1 = a2 * c3 + a3
        w2 = d4 + a2 * s3
        th23 = math.atan2(w2 * r - w1 * pz, w1 * r + w2 * pz)
        th2 = th23 - th3
        q = np.array([th1, th2, th3, 0.0, 0.0, 0.0]) + self._offset
        R3 = self._chain.frames(q)[3, :3, :3]
        W = R3.T @ T6[:3, :3]
        s5 = math.hypot(W[0, 2], W[1, 2])
        if s5 > 1e-12:
            if wrist == "flip":
                th4 = math.atan2(W[1, 2], W[0, 2])
                th5 = math.atan2(s5, W[2, 2])
                th6 = math.atan2(W[2, 1], -W[2, 0])
            else:
                th4 = math.atan2(-W[1, 2], -W[0, 2])
                th5 = math.atan2(-s5, W[2, 2])
                th6 = math.atan2(-W[2, 1], W[2, 0])
        else:
            # Wrist singular: only θ4 ± θ6 is determined; put it all in θ6.
            th4 = 0.0
            if W[2, 2] > 0.0:
                th5 = 0.0
                th6 = math.atan2(W[1, 0], W[0, 0])
            else:
                th5 = math.pi
                th6 = math.atan2(W[1, 0], W[1, 1])
        q[3:] = (th4, th5, th6)
        lim = self.joint_limits
        return np.array([_fit(float(q[i]), float(lim[i, 0]), float(lim[i, 1])) for i in range(6)])


def _rigid_inverse(T: FloatArray) -> FloatArray:
    R = T[:3, :3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ T[:3, 3]
    return out


def _is_rigid(T: FloatArray) -> bool:
    R = T[:3, :3]
    return bool(
        np.allclose(R.T @ R, np.eye(3), atol=_ROT_TOL, rtol=0.0)
        and np.linalg.det(R) > 0.0
        and np.allclose(T[3], (0.0, 0.0, 0.0, 1.0), atol=1e-9, rtol=0.0)
    )


def _tool_transform(tool: Any) -> FloatArray:
    """Validate ``tool`` into a rigid 4 x 4 transform (frame 6 → tool)."""
    if tool is None:
        return np.eye(4)
    a = real_array(
        "tool",
        tool,
        error=InvalidGeometry,
        what="a translation (3,) [m] or a 4 x 4 transform",
        allow_nonfinite=True,
    )
    if a.shape == (3,):
        T = np.eye(4)
        T[:3, 3] = a
        a = T
    if a.shape != (4, 4):
        raise InvalidGeometry(
            f"tool: expected shape (3,) (translation [m]) or (4, 4) (transform), got shape "
            f"{a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise InvalidGeometry("tool: expected finite values, got NaN or inf")
    if not _is_rigid(a):
        raise InvalidGeometry(
            "tool: expected a rigid transform (orthonormal rotation with det +1, bottom row "
            f"[0, 0, 0, 1]), got {np.round(a, 6).tolist()}"
        )
    return a


def _pose(T: ArrayLike) -> FloatArray:
    """Validate a pose argument into a float (4, 4) rigid transform."""
    return rigid_transform("T", T, tol=_ROT_TOL)


document_inits(globals())
