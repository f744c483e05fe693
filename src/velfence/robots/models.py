"""The shipped arms: MJCF generated from published DH tables.

The standard DH tables and joint limits of :func:`seven_dof`, :func:`ur5e` and :func:`puma560`
are read from ``velfence.mechanisms.DHChain``'s factories of the same names (one table each), so
both give the same kinematics. :func:`panda` is a
Franka-Emika-Panda-like arm from Franka's published modified-DH parameters.
"""

from __future__ import annotations

import math

from numpy.typing import ArrayLike

from velfence.mechanisms.chain import DHChain
from velfence.robots.mjcf import dh_mjcf, mdh_mjcf
from velfence.robots.model import MujocoRobot

__all__ = ["panda", "puma560", "seven_dof", "ur5e"]

_H = math.pi / 2.0
_UR5E_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)


def _table(chain: DHChain) -> tuple[list[tuple[float, ...]], list[tuple[float, ...]]]:
    """A DH chain's rows and joint limits, as the MJCF generator takes them."""
    rows = [tuple(float(x) for x in r) for r in chain.dh.tolist()]
    lim = [tuple(float(x) for x in r) for r in chain.joint_limits.tolist()]
    return rows, lim


# Franka Emika, "Robot and interface specifications": modified DH (Craig) rows
# (a_{i-1} [m], alpha_{i-1} [rad], d_i [m], theta_offset), flange d = 0.107 m, joint limits [rad].
_PANDA_MDH = (
    (0.0, 0.0, 0.333, 0.0),
    (0.0, -_H, 0.0, 0.0),
    (0.0, _H, 0.316, 0.0),
    (0.0825, _H, 0.0, 0.0),
    (-0.0825, -_H, 0.384, 0.0),
    (0.0, _H, 0.0, 0.0),
    (0.088, _H, 0.0, 0.0),
)
_PANDA_FLANGE_D = 0.107
_PANDA_LIMITS = (
    (-2.8973, 2.8973),
    (-1.7628, 1.7628),
    (-2.8973, 2.8973),
    (-3.0718, -0.0698),
    (-2.8973, 2.8973),
    (-0.0175, 3.7525),
    (-2.8973, 2.8973),
)


def _with_names(xml: str, names: tuple[str, ...]) -> str:
    """Rename the generated joints ``joint{i}`` (the sites keep their names)."""
    for i, name in enumerate(names):
        xml = xml.replace(f'<joint name="joint{i}" ', f'<joint name="{name}" ', 1)
    return xml


def seven_dof(*, tool: ArrayLike | None = None, radius: float = 0.0) -> MujocoRobot:
    """A 7R S-R-S arm with the KUKA LBR iiwa 14 R820's dimensions (``DHChain.seven_dof``).

    Standard DH: d = 0.36, 0, 0.42, 0, 0.40, 0, 0.126 m, a = 0, alpha alternating -π/2, +π/2
    (last 0); straight up at ``q = 0``. Limits ±170°, ±120°, ±170°, ±120°, ±170°, ±120°,
    ±175°. Sites ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 3), ``"wrist"`` (joint 5),
    ``"joint0"`` … ``"joint6"``.

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0`` (``0``: none).

    Returns:
        The robot (7 joints ``joint0`` … ``joint6``).
    """
    rows, lim = _table(DHChain.seven_dof())
    xml = dh_mjcf(
        rows, lim, tool, "seven_dof", radius=radius, named_points={"elbow": 3, "wrist": 5}
    )
    return MujocoRobot.from_xml(xml)


def ur5e(*, tool: ArrayLike | None = None, radius: float = 0.0) -> MujocoRobot:
    """The Universal Robots UR5e from Universal Robots' published standard DH (``DHChain.ur5e``).

    Source: Universal Robots, "DH parameters for calculations of kinematics and dynamics"
    (UR5e: d1 = 0.1625, a2 = -0.425, a3 = -0.3922, d4 = 0.1333, d5 = 0.0997, d6 = 0.0996 m).
    Joints named as in ``ur_robot_driver`` (``shoulder_pan_joint`` … ``wrist_3_joint``),
    limits ±2π. Sites ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 2), ``"wrist"`` (joint 3),
    ``"joint0"`` … ``"joint5"``.

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0`` (``0``: none).

    Returns:
        The robot (6 joints).
    """
    rows, lim = _table(DHChain.ur5e())
    xml = dh_mjcf(rows, lim, tool, "ur5e", radius=radius, named_points={"elbow": 2, "wrist": 3})
    return MujocoRobot.from_xml(_with_names(xml, _UR5E_JOINTS))


def puma560(*, tool: ArrayLike | None = None, radius: float = 0.0) -> MujocoRobot:
    """The PUMA 560, standard DH of Fu, Gonzalez & Lee (``DHChain.puma560``).

    a2 = 0.4318, d2 = 0.15, a3 = -0.0203, d4 = 0.4331 m; tool point the wrist centre unless
    ``tool`` is given. Limits [deg] (-160, 160), (-225, 45), (-45, 225), (-110, 170),
    (-100, 100), (-266, 266). Sites ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 2), ``"wrist"``
    (joint 4), ``"joint0"`` … ``"joint5"``.

    Args:
        tool: Tool point in frame 6 [m], shape (3,); its origin when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0`` (``0``: none).

    Returns:
        The robot (6 joints ``joint0`` … ``joint5``).
    """
    rows, lim = _table(DHChain.puma560())
    xml = dh_mjcf(rows, lim, tool, "puma560", radius=radius, named_points={"elbow": 2, "wrist": 4})
    return MujocoRobot.from_xml(xml)


def panda(*, tool: ArrayLike | None = None, radius: float = 0.0) -> MujocoRobot:
    """A Franka-Emika-Panda-like 7-DoF arm from Franka's modified-DH (Craig) parameters.

    Source: Franka Emika, "Robot and interface specifications" (Panda): a = 0, 0, 0, 0.0825,
    -0.0825, 0, 0.088 m; d = 0.333, 0, 0.316, 0, 0.384, 0, 0 m; alpha = 0, -π/2, π/2, π/2,
    -π/2, π/2, π/2; flange d = 0.107 m. Joint limits [rad] from the same datasheet: ±2.8973,
    ±1.7628, ±2.8973, (-3.0718, -0.0698), ±2.8973, (-0.0175, 3.7525), ±2.8973. Kinematics
    only (no masses, meshes or hand). Joints ``panda_joint1`` … ``panda_joint7``; sites
    ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 3), ``"wrist"`` (joint 5), ``"joint0"`` …
    ``"joint6"``.

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0`` (``0``: none).

    Returns:
        The robot (7 joints).
    """
    xml = mdh_mjcf(
        _PANDA_MDH,
        _PANDA_LIMITS,
        tool,
        "panda",
        flange_d=_PANDA_FLANGE_D,
        radius=radius,
        named_points={"elbow": 3, "wrist": 5},
    )
    names = tuple(f"panda_joint{i + 1}" for i in range(7))
    return MujocoRobot.from_xml(_with_names(xml, names))
