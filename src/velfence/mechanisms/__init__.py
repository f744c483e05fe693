r"""Mechanism kinematics: maps between joint space, where workspaces are drawn, and actuator space.

Math contract: a mechanism maps joint positions ``q`` (shape (2,) or (N, 2)) to actuator
coordinates ``L(q)`` with an **analytic** Jacobian ``J(q) = dL/dq`` (rows = actuators, columns =
joints; checked against finite differences in the tests). Velocities map as ``Ldot = J(q) qdot``;
the inverse map ``qdot = J(q)^{-1} Ldot`` and Newton forward kinematics refuse, with
:class:`~velfence.errors.InvalidInput`, where ``|det J|`` falls below a stated fraction of its home
value. Actuator speed limits are enforced by scaling the **whole** joint velocity by one factor
``s ∈ (0, 1]``, so its direction (the shaper's output) is kept. A mechanism derives its permissible
workspace as a :class:`~velfence.geometry.polygon.ConvexPolygon` in joint space whose every point
satisfies every physical limit ``g_k(q) <= 0`` (strokes, singularity margin, clearances).

Batches equal loops over their rows; non-finite inputs raise
:class:`~velfence.errors.InvalidInput`; dimensions are frozen dataclasses validated on construction.
"""

from velfence.mechanisms.wrist import LIMIT_NAMES, Wrist, WristGeometry

__all__ = ["LIMIT_NAMES", "Wrist", "WristGeometry"]
