"""Robot models whose kinematics MuJoCo computes (the ``physics`` extra).

:class:`MujocoRobot` loads an MJCF arm and implements the ``Kinematics`` protocol of the
:class:`~velfence.filter.SafetyFilter` (or a URDF: :meth:`MujocoRobot.from_urdf`);
:func:`dh_mjcf` and :func:`mdh_mjcf` write the MJCF of a revolute arm from a standard or
modified DH table, with link masses and inertias and joint effort/velocity limits;
:func:`panda`, :func:`ur5e`, :func:`seven_dof` and :func:`puma560` are the shipped arms. MuJoCo
is imported only when a model is loaded. :func:`fit_collision_capsules` fits capsules to a
model's collision geometry and reports the fit (``velfence.robots.collision``).
"""

from __future__ import annotations

from velfence.robots.collision import (
    CollisionFit,
    LinkCapsule,
    LinkRadii,
    fit_collision_capsules,
)
from velfence.robots.mjcf import dh_mjcf, mdh_mjcf
from velfence.robots.model import MujocoRobot
from velfence.robots.models import PANDA_LINK_RADII, panda, puma560, seven_dof, ur5e
from velfence.robots.wrist_model import wrist_mjcf, wrist_qpos, wrist_robot

__all__ = [
    "PANDA_LINK_RADII",
    "CollisionFit",
    "LinkCapsule",
    "LinkRadii",
    "MujocoRobot",
    "dh_mjcf",
    "fit_collision_capsules",
    "mdh_mjcf",
    "panda",
    "puma560",
    "seven_dof",
    "ur5e",
    "wrist_mjcf",
    "wrist_qpos",
    "wrist_robot",
]
