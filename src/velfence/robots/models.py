"""The shipped arms: MJCF generated from published DH tables.

The standard DH tables and joint limits of :func:`seven_dof`, :func:`ur5e` and :func:`puma560`
are read from ``velfence.mechanisms.DHChain``'s factories of the same names (one table each), so
both give the same kinematics. :func:`panda` is a
Franka-Emika-Panda-like arm from Franka's published modified-DH parameters. Masses, centres of
mass, inertias and effort/velocity limits are the published ones where they exist; the
approximations and their sources are listed in ``docs/robots.md``.
"""

from __future__ import annotations

import math

from numpy.typing import ArrayLike

from velfence.mechanisms.chain import DHChain
from velfence.robots.mjcf import dh_mjcf, mdh_mjcf
from velfence.robots.model import MujocoRobot

__all__ = ["PANDA_LINK_RADII", "panda", "puma560", "seven_dof", "ur5e"]

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


#: Capsule radius [m] of each of :func:`panda`'s seven joint-to-joint links that covers the
#: Panda's collision meshes (franka_description's ``panda_link1`` … ``panda_link7`` STL files, as
#: example-robot-data ships them), rounded up to the millimetre:
#: ``fit_collision_capsules(...).link_radii(panda(), bodies=...)`` (docs/robots.md, "Collision
#: geometry from the model"). Links 0 and 4 have zero length (a sphere at the shoulder, at the
#: wrist), hence their large radii. ``panda(radius=PANDA_LINK_RADII)`` uses them.
PANDA_LINK_RADII = (0.200, 0.130, 0.134, 0.117, 0.270, 0.084, 0.091)

# Gaz, Cognetti, Oliva, Robuffo Giordano, De Luca, "Dynamic identification of the Franka Emika
# Panda robot with retrieval of feasible parameters using penalty-based optimization", IEEE RA-L
# 4(4), 2019: link masses [kg], centres of mass [m] and inertias about them [kg·m²]
# (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) in the modified-DH frames of links 1..7 (the values
# franka_description and MuJoCo Menagerie ship).
_PANDA_MASSES = (4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522)
_PANDA_COMS = (
    (3.875e-3, 2.081e-3, -4.762e-2),
    (-3.141e-3, -2.872e-2, 3.495e-3),
    (2.7518e-2, 3.9252e-2, -6.6502e-2),
    (-5.317e-2, 1.04419e-1, 2.7454e-2),
    (-1.1953e-2, 4.1065e-2, -3.8437e-2),
    (6.0149e-2, -1.4117e-2, -1.0517e-2),
    (1.0517e-2, -4.252e-3, 6.1597e-2),
)
_PANDA_INERTIAS = (
    (7.0337e-1, 7.0661e-1, 9.117e-3, -1.39e-4, 6.772e-3, 1.9169e-2),
    (7.962e-3, 2.811e-2, 2.5995e-2, -3.925e-3, 1.0254e-2, 7.04e-4),
    (3.7242e-2, 3.6155e-2, 1.083e-2, -4.761e-3, -1.1396e-2, -1.2805e-2),
    (2.5853e-2, 1.9552e-2, 2.8323e-2, 7.796e-3, -1.332e-3, 8.641e-3),
    (3.5549e-2, 2.9474e-2, 8.627e-3, -2.117e-3, -4.037e-3, 2.29e-4),
    (1.964e-3, 4.354e-3, 5.433e-3, 1.09e-4, -1.158e-3, 3.41e-4),
    (1.2516e-2, 1.0027e-2, 4.815e-3, -4.28e-4, -1.196e-3, -7.41e-4),
)
# Franka's FCI documentation, "Robot and interface specifications", the table "Limits for Panda"
# (the Franka Emika Robot, FER; not the Franka Research 3, whose limits differ): joint torque
# [N·m], speed [rad/s], acceleration [rad/s²] and jerk [rad/s³] limits.
_PANDA_EFFORT = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
_PANDA_VELOCITY = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
_PANDA_ACCELERATION = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
_PANDA_JERK = (7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0)

# Universal Robots, "DH parameters for calculations of kinematics and dynamics", UR5e column:
# link masses [kg] and centres of mass [m] in the DH frames 1..6 (no inertias are published: the
# generator's cylinder approximation is used). Datasheet: torques [N·m] (size 3 and size 1
# joints), all joint speeds 180°/s.
_UR5E_MASSES = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
_UR5E_COMS = (
    (0.0, -0.02561, 0.00193),
    (0.2125, 0.0, 0.11336),
    (0.15, 0.0, 0.0265),
    (0.0, -0.0018, 0.01634),
    (0.0, 0.0018, 0.01634),
    (0.0, 0.0, -0.001159),
)
_UR5E_EFFORT = (150.0, 150.0, 150.0, 28.0, 28.0, 28.0)
_UR5E_VELOCITY = (math.pi,) * 6

# Armstrong, Khatib & Burdick, "The explicit dynamic model and inertial parameters of the PUMA 560
# arm", ICRA 1986 (the values of Corke's toolbox): masses of links 2..6 [kg], centres of mass [m]
# and principal inertias [kg·m²] moved from Corke's DH frames to the Fu-Gonzalez-Lee frames of
# DHChain.puma560 (docs/robots.md). Link 1: only its inertia about axis 1 (0.35 kg·m²) is given;
# its mass is a 1 g placeholder on that axis and its two other moments (which never enter the
# dynamics: it turns about axis 1 only) are set to make a valid tensor. Link 3's published
# moments (0.066, 0.086, 0.0125) are not a physical tensor; its Izz is raised to 0.020.
_PUMA_MASSES = (0.001, 17.4, 4.8, 0.82, 0.34, 0.09)
_PUMA_COMS = (
    (0.0, 0.0, 0.0),
    (-0.3638, 0.006, 0.2275 - 0.15),
    (0.0203, 0.0141, 0.070),
    (0.0, -0.019, 0.0),
    (0.0, 0.0, 0.0),
    (0.0, 0.0, 0.032),
)
_PUMA_INERTIAS = (
    (0.18, 0.35, 0.18),
    (0.13, 0.524, 0.539),
    (0.066, 0.086, 0.020),  # Armstrong: Izz 0.0125, which violates 0.066 + Izz >= 0.086
    (1.8e-3, 1.3e-3, 1.8e-3),
    (0.3e-3, 0.4e-3, 0.3e-3),
    (0.15e-3, 0.15e-3, 0.04e-3),
)

# KUKA publishes no per-link masses of the LBR iiwa 14 R820: the masses [kg] are the placeholder
# values of the iiwa_stack URDF (ROS), centres of mass and inertias the generator's
# approximations. KUKA datasheet: torques [N·m] and speeds [°/s].
_IIWA_MASSES = (4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3)
_IIWA_EFFORT = (320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0)
_IIWA_VELOCITY = tuple(math.radians(v) for v in (85.0, 85.0, 100.0, 75.0, 130.0, 135.0, 135.0))


def _with_names(xml: str, names: tuple[str, ...]) -> str:
    """Rename the generated joints ``joint{i}`` (the sites keep their names)."""
    for i, name in enumerate(names):
        xml = xml.replace(f'<joint name="joint{i}" ', f'<joint name="{name}" ', 1)
    return xml


def seven_dof(*, tool: ArrayLike | None = None, radius: float | ArrayLike = 0.0) -> MujocoRobot:
    """A 7R S-R-S arm with the KUKA LBR iiwa 14 R820's dimensions (``DHChain.seven_dof``).

    Standard DH: d = 0.36, 0, 0.42, 0, 0.40, 0, 0.126 m, a = 0, alpha alternating -π/2, +π/2
    (last 0); straight up at ``q = 0``. Limits ±170°, ±120°, ±170°, ±120°, ±170°, ±120°,
    ±175°. Effort and speed limits of the iiwa 14 datasheet; link masses are the ROS
    ``iiwa_stack`` placeholders (KUKA publishes none), inertias cylinder approximations
    (docs/robots.md). Sites ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 3), ``"wrist"``
    (joint 5), ``"joint0"`` … ``"joint6"``.

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0``, one for all links or one per
            link (``0``: none).

    Returns:
        The robot (7 joints ``joint0`` … ``joint6``).
    """
    rows, lim = _table(DHChain.seven_dof())
    xml = dh_mjcf(
        rows,
        joint_limits=lim,
        tool=tool,
        name="seven_dof",
        radius=radius,
        named_points={"elbow": 3, "wrist": 5},
        masses=_IIWA_MASSES,
        velocity_limits=_IIWA_VELOCITY,
        effort_limits=_IIWA_EFFORT,
    )
    return MujocoRobot.from_xml(xml)


def ur5e(*, tool: ArrayLike | None = None, radius: float | ArrayLike = 0.0) -> MujocoRobot:
    """The Universal Robots UR5e from Universal Robots' published standard DH (``DHChain.ur5e``).

    Source: Universal Robots, "DH parameters for calculations of kinematics and dynamics"
    (UR5e: d1 = 0.1625, a2 = -0.425, a3 = -0.3922, d4 = 0.1333, d5 = 0.0997, d6 = 0.0996 m).
    Joints named as in ``ur_robot_driver`` (``shoulder_pan_joint`` … ``wrist_3_joint``),
    limits ±2π. Link masses and centres of mass from the same article (inertias: cylinder
    approximations), effort limits 150/28 N·m and speeds π rad/s from the datasheet. Sites
    ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 2), ``"wrist"`` (joint 3), ``"joint0"`` …
    ``"joint5"``.

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0``, one for all links or one per
            link (``0``: none).

    Returns:
        The robot (6 joints).
    """
    rows, lim = _table(DHChain.ur5e())
    xml = dh_mjcf(
        rows,
        joint_limits=lim,
        tool=tool,
        name="ur5e",
        radius=radius,
        named_points={"elbow": 2, "wrist": 3},
        masses=_UR5E_MASSES,
        centers_of_mass=_UR5E_COMS,
        velocity_limits=_UR5E_VELOCITY,
        effort_limits=_UR5E_EFFORT,
    )
    return MujocoRobot.from_xml(_with_names(xml, _UR5E_JOINTS))


def puma560(*, tool: ArrayLike | None = None, radius: float | ArrayLike = 0.0) -> MujocoRobot:
    """The PUMA 560, standard DH of Fu, Gonzalez & Lee (``DHChain.puma560``).

    a2 = 0.4318, d2 = 0.15, a3 = -0.0203, d4 = 0.4331 m; tool point the wrist centre unless
    ``tool`` is given. Limits [deg] (-160, 160), (-225, 45), (-45, 225), (-110, 170),
    (-100, 100), (-266, 266). Masses, centres of mass and inertias of Armstrong, Khatib &
    Burdick (1986), moved to these frames (docs/robots.md); no effort or speed limits. Sites
    ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 2), ``"wrist"``
    (joint 4), ``"joint0"`` … ``"joint5"``.

    Args:
        tool: Tool point in frame 6 [m], shape (3,); its origin when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0``, one for all links or one per
            link (``0``: none).

    Returns:
        The robot (6 joints ``joint0`` … ``joint5``).
    """
    rows, lim = _table(DHChain.puma560())
    xml = dh_mjcf(
        rows,
        joint_limits=lim,
        tool=tool,
        name="puma560",
        radius=radius,
        named_points={"elbow": 2, "wrist": 4},
        masses=_PUMA_MASSES,
        centers_of_mass=_PUMA_COMS,
        inertias=_PUMA_INERTIAS,
    )
    return MujocoRobot.from_xml(xml)


def panda(*, tool: ArrayLike | None = None, radius: float | ArrayLike = 0.0) -> MujocoRobot:
    """A Franka-Emika-Panda-like 7-DoF arm from Franka's modified-DH (Craig) parameters.

    Source: Franka Emika, "Robot and interface specifications" (Panda): a = 0, 0, 0, 0.0825,
    -0.0825, 0, 0.088 m; d = 0.333, 0, 0.316, 0, 0.384, 0, 0 m; alpha = 0, -π/2, π/2, π/2,
    -π/2, π/2, π/2; flange d = 0.107 m. Joint limits [rad] from the same datasheet: ±2.8973,
    ±1.7628, ±2.8973, (-3.0718, -0.0698), ±2.8973, (-0.0175, 3.7525), ±2.8973. Kinematics
    only (no masses, meshes or hand). Joints ``panda_joint1`` … ``panda_joint7``; sites
    ``"tcp"``, ``"flange"``, ``"elbow"`` (joint 3), ``"wrist"`` (joint 5), ``"joint0"`` …
    ``"joint6"``. Joint speed, acceleration and jerk limits from Franka's FCI table "Limits for
    Panda" (the Franka Emika Robot; ``velocity_limits``, ``acceleration_limits``,
    ``jerk_limits``; :meth:`MujocoRobot.limits` gives them as a ``JointLimits``).

    Args:
        tool: Tool point in the flange frame [m], shape (3,); the flange when ``None``.
        radius: Capsule radius of the link geoms [m], ``>= 0``, one for all links or one per
            link (``0``: none); :data:`PANDA_LINK_RADII` covers the Panda's collision meshes.

    Returns:
        The robot (7 joints).
    """
    xml = mdh_mjcf(
        _PANDA_MDH,
        joint_limits=_PANDA_LIMITS,
        tool=tool,
        name="panda",
        flange_d=_PANDA_FLANGE_D,
        radius=radius,
        named_points={"elbow": 3, "wrist": 5},
        masses=_PANDA_MASSES,
        centers_of_mass=_PANDA_COMS,
        inertias=_PANDA_INERTIAS,
        velocity_limits=_PANDA_VELOCITY,
        effort_limits=_PANDA_EFFORT,
        acceleration_limits=_PANDA_ACCELERATION,
        jerk_limits=_PANDA_JERK,
    )
    names = tuple(f"panda_joint{i + 1}" for i in range(7))
    return MujocoRobot.from_xml(_with_names(xml, names))
