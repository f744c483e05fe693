"""The kinematics protocol of the safety filter, with its per-cycle cache.

A filter cycle asks one pose many questions: the position and Jacobian of every guarded point,
every link's capsule segment, the Jacobian of the critical point of every obstacle pair within
reach. :meth:`Kinematics.kinematics` answers them from one evaluation: it returns a
:class:`KinematicsFrame` for the joint vector ``q`` that computes the pose once and each answer at
most once. The filter makes one frame per cycle (and one per model check of the next pose).

Implemented by ``DHChain``, ``PlanarArm`` and ``Puma560`` (:mod:`velfence.mechanisms`) and
``MujocoRobot`` (:mod:`velfence.robots`), structurally: the filter never looks at a robot's type
or module. A robot with only ``fk`` and ``jacobian`` (and, for obstacles, ``link_segments`` and
``point_jacobian``) gets the memoising adapter :class:`CachedFrame`.

Defined here, in the filter's layer, so that the filter needs no import from the mechanisms or
robots (higher layers).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from velfence._docs import document_inits
from velfence._typing import FloatArray
from velfence._validate import real_array, show
from velfence.errors import InvalidInput
from velfence.geometry.so3 import rotation_from_angle_axis

__all__ = [
    "CachedFrame",
    "ChainData",
    "ChainFrames",
    "Kinematics",
    "KinematicsFrame",
    "checked",
    "frame_of",
]


@runtime_checkable
class KinematicsFrame(Protocol):
    """The kinematics of one pose, each quantity computed at most once.

    Shapes: ``task_dim`` is 3 for a spatial robot, 2 for a planar one; ``dof`` joints; ``L``
    capsule links. Optional, looked up by name: ``point_jacobians(links, ts)`` (k, 3, dof), many
    :meth:`point_jacobian` at once (the obstacle rows use it when present), and
    ``angular_jacobian()`` (3, dof) (twists of shape (6,)).
    """

    def point(self, name: str) -> FloatArray:
        """Position of a named point [m], shape (task_dim,)."""
        ...

    def jacobian(self, name: str) -> FloatArray:
        """Linear-velocity Jacobian of a named point [m/rad], shape (task_dim, dof)."""
        ...

    def segments(self) -> FloatArray:
        """Every capsule link's axis from ``P_k`` to ``P_{k+1}`` [m], shape (L, 2, 3)."""
        ...

    def point_jacobian(self, link: int, t: float) -> FloatArray:
        """Jacobian of the point at fraction ``t`` in [0, 1] along ``link`` [m/rad], (3, dof)."""
        ...


@runtime_checkable
class Kinematics(Protocol):
    """The kinematics a :class:`~velfence.filter.SafetyFilter` needs.

    ``dof``, ``joint_names``, ``points`` (names ``fk``/``jacobian`` and the frame accept;
    ``"tcp"`` always), ``fk(q, point)`` (task_dim,) [m], ``jacobian(q, point)`` (task_dim, dof)
    [m/rad]. Optional, looked up by name (never by type): ``kinematics(q)`` (a
    :class:`KinematicsFrame`; without it :class:`CachedFrame` wraps ``fk``/``jacobian``),
    ``link_radius`` (L,) or (1,) [m] (capsule links: obstacles need it), ``angular_jacobian(q)``
    (3, dof) (twists of shape (6,)), ``chain_data()`` (a :class:`ChainData` or ``None``: the
    chain as data, for compiled routes).
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


@dataclass(frozen=True)
class ChainData:
    """A serial revolute chain as data (standard DH), for compiled routes of the filter.

    Attributes:
        dh: Per joint ``(a [m], cos α, sin α, d [m], θ offset [rad])``, shape (n, 5).
        tool: Tool point in the last frame [m], shape (3,).
        point_index: Joint-point index of each named point (``n``: the tool point, ``-1``: the
            origin of the last frame).
    """

    dh: FloatArray
    tool: FloatArray
    point_index: dict[str, int]


@dataclass(frozen=True)
class ChainFrames:
    """A serial chain as fixed transforms and joint axes (URDF / MJCF style), for the C cycle.

    The C cycle's chain description (``velfence_filter.h``): ``F_j = F_{j-1} T_j M_j(q_j +
    offset_j)``, ``M_j`` a rotation about (revolute) or a translation along (prismatic) the unit
    axis ``a_j`` through the joint frame's origin; ``F_tool = F_{n-1} tool``. Joint ``j``'s point
    ``P_j`` is the origin of ``F_{j-1} T_j`` and link ``l`` the capsule ``P_l -> P_{l+1}``
    (``P_n`` the tool origin). Robots that are not DH tables give it by ``chain_frames()``
    (``MujocoRobot`` for a serial MJCF arm).

    Attributes:
        joints: Per joint ``T`` (12, ``[R | p]`` row-major), axis (3), type (0 revolute,
            1 prismatic), offset: shape (n, 17).
        tool: The tool transform in ``F_{n-1}``, ``[R | p]`` row-major, shape (12,).
        points: Every named point as ``(link, x, y, z)``: ``link`` -1 the base, ``0 … n-1`` the
            frame ``F_link``, ``n`` the tool frame; ``(x, y, z)`` [m] in that frame.
    """

    joints: FloatArray
    tool: FloatArray
    points: dict[str, tuple[float, float, float, float]]

    def fk(self, q: ArrayLike, point: str = "tcp") -> FloatArray:
        """Position of a named point in the base frame for joints ``q``, by these frames.

        The C cycle's forward kinematics in Python (to check a description against the robot
        it was made from: ``MujocoRobot.chain_frames()`` against MuJoCo).

        Args:
            q: Joint position [rad] (prismatic [m]), shape (n,).
            point: A name of :attr:`points`.

        Returns:
            Position [m], shape (3,).

        Raises:
            InvalidInput: bad ``q`` or an unknown ``point``.
        """
        rows = np.asarray(self.joints, dtype=np.float64).reshape(-1, 17)
        n = rows.shape[0]
        qa = real_array("q", q, (n,), what=f"{n} joint positions [rad]")
        if not isinstance(point, str) or point not in self.points:
            raise InvalidInput(
                f"point: expected one of {list(self.points)[:20]}, got {show(point)}"
            )
        link, *xyz = self.points[point]
        F = np.eye(4)
        for j in range(min(int(link) + 1, n)):  # F_link: joints 0 … link (none for the base)
            T = np.eye(4)
            T[:3] = rows[j, :12].reshape(3, 4)
            M = np.eye(4)
            angle = float(qa[j] + rows[j, 16])
            if rows[j, 15] == 1.0:  # prismatic: a translation along the axis
                M[:3, 3] = rows[j, 12:15] * angle
            else:
                M[:3, :3] = rotation_from_angle_axis(rows[j, 12:15], angle)
            F = F @ T @ M
        if int(link) == n:  # the tool frame
            T = np.eye(4)
            T[:3] = np.asarray(self.tool, dtype=np.float64).reshape(3, 4)
            F = F @ T
        return np.asarray(F[:3, :3] @ np.array(xyz) + F[:3, 3], dtype=np.float64)


class CachedFrame:
    """A :class:`KinematicsFrame` from the robot's public per-call methods, memoised.

    For robots without their own ``kinematics(q)``: ``fk``, ``jacobian``, ``link_segments`` and
    ``point_jacobian`` are called at most once per question for this ``q``.

    Args:
        robot: The robot (the :class:`Kinematics` protocol).
        q: Joint position [rad], shape (dof,), validated by the caller.
    """

    __slots__ = ("_cache", "_q", "_robot")

    def __init__(self, robot: Any, q: FloatArray) -> None:
        self._robot = robot
        self._q = q
        self._cache: dict[Any, FloatArray] = {}

    def point(self, name: str) -> FloatArray:
        """Position of a named point [m], shape (task_dim,)."""
        key = ("p", name)
        if key not in self._cache:
            self._cache[key] = np.asarray(self._robot.fk(self._q, name), dtype=np.float64)
        return self._cache[key]

    def jacobian(self, name: str) -> FloatArray:
        """Jacobian of a named point [m/rad], shape (task_dim, dof)."""
        key = ("J", name)
        if key not in self._cache:
            self._cache[key] = np.asarray(self._robot.jacobian(self._q, name), dtype=np.float64)
        return self._cache[key]

    def segments(self) -> FloatArray:
        """Capsule link axes [m], shape (L, 2, 3)."""
        key = ("s",)
        if key not in self._cache:
            self._cache[key] = np.asarray(self._robot.link_segments(self._q), dtype=np.float64)
        return self._cache[key]

    def point_jacobian(self, link: int, t: float) -> FloatArray:
        """Jacobian of the point at fraction ``t`` along ``link`` [m/rad], shape (3, dof)."""
        key = ("c", link, t)
        if key not in self._cache:
            J = self._robot.point_jacobian(self._q, link, t)
            self._cache[key] = np.asarray(J, dtype=np.float64)
        return self._cache[key]


def frame_of(robot: Any, q: FloatArray) -> KinematicsFrame:
    """The robot's frame for a validated ``q``: ``robot.kinematics(q)``, else a CachedFrame."""
    make = getattr(robot, "kinematics", None)
    if make is None:
        return CachedFrame(robot, q)
    frame: KinematicsFrame = make(q)
    return frame


def checked(what: str, value: Any, shape: tuple[int, ...]) -> FloatArray:
    """A kinematics answer as float64 of ``shape``, finite; else :class:`InvalidInput`.

    ``what`` names the call (``"robot.kinematics(q).point('tcp')"``): a provider returning NaN or
    the wrong shape is reported, never passed on to the rows.
    """
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInput(
            f"robot: {what} expected an array of shape {shape}, got {type(value).__name__}"
        ) from None
    if a.shape != shape:
        raise InvalidInput(f"robot: {what} expected shape {shape}, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise InvalidInput(
            f"robot: {what} expected finite values, got non-finite entries (a kinematics "
            "provider returning NaN or inf)"
        )
    return a


document_inits(globals())
