"""Planar twists between a mobile base's body frame and the frame its pose is given in.

A ground robot's ``cmd_vel`` is a body-frame twist ``(vx, vy, wz)``: ``vx`` forward, ``vy`` to
the left [m/s], ``wz`` counter-clockwise [rad/s]. A shaper of the plane works in the frame of the
robot's pose (``odom``, ``map``: the *world* frame of the configs, ``docs/architecture.md``). With
the pose's heading ``yaw`` [rad] the linear part turns by ``R(yaw)``; ``wz`` is the same in both
frames (both are right-handed with ``z`` up).

Math contract: ``world = R(yaw) @ body`` and ``body = R(yaw)ᵀ @ world`` for the linear part,
``R(yaw) = [[cos, -sin], [sin, cos]]``; the two functions are each other's inverse to rounding.
"""

from __future__ import annotations

import math
from typing import Any

from velfence._typing import FloatArray
from velfence._validate import finite_scalar, real_array
from velfence.errors import InvalidInput

__all__ = ["body_to_world", "world_to_body"]


def _rotate(twist: Any, yaw: Any, sign: float) -> FloatArray:
    v = real_array("twist", twist, error=InvalidInput, what="a planar twist")
    if v.ndim != 1 or v.shape[0] not in (2, 3):
        raise InvalidInput(
            f"twist: expected (vx, vy) or (vx, vy, wz), shape (2,) or (3,), got shape {v.shape}"
        )
    a = finite_scalar("yaw", yaw, unit="rad", error=InvalidInput)
    c, s = math.cos(a), sign * math.sin(a)
    out = v.copy()
    out[0] = c * v[0] - s * v[1]
    out[1] = s * v[0] + c * v[1]
    return out


def body_to_world(twist: Any, yaw: Any) -> FloatArray:
    """A body-frame planar twist in the frame of the pose (turned by the heading).

    Args:
        twist: ``(vx, vy)`` [m/s] or ``(vx, vy, wz)`` [m/s, m/s, rad/s] in the body frame.
        yaw: The body's heading in the pose's frame [rad].

    Returns:
        The same twist in the pose's frame, a new array of the input's shape (``wz`` unchanged).

    Raises:
        InvalidInput: the twist is not 2 or 3 finite numbers, or ``yaw`` is not a finite number.
    """
    return _rotate(twist, yaw, 1.0)


def world_to_body(twist: Any, yaw: Any) -> FloatArray:
    """A planar twist in the pose's frame, in the body frame (the inverse of body_to_world).

    Args:
        twist: ``(vx, vy)`` [m/s] or ``(vx, vy, wz)`` [m/s, m/s, rad/s] in the pose's frame.
        yaw: The body's heading in the pose's frame [rad].

    Returns:
        The same twist in the body frame, a new array of the input's shape (``wz`` unchanged).

    Raises:
        InvalidInput: the twist is not 2 or 3 finite numbers, or ``yaw`` is not a finite number.
    """
    return _rotate(twist, yaw, -1.0)
