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

Parallel mechanisms (the CoSPM of Lê et al. 2024) give an implicit geometric model
``f(θ, χ) = 0`` instead, with ``χ̇ = J θ̇``, ``J = −A⁻¹B``, ``A = ∂f/∂χ``, ``B = ∂f/∂θ``, closed-form
inverse kinematics per leg and Newton forward kinematics by continuation; ``det A = 0`` (Type 2)
and ``det B = 0`` (Type 1) are their singularities.

Batches equal loops over their rows; non-finite inputs raise
:class:`~velfence.errors.InvalidInput`; dimensions are frozen dataclasses validated on construction.
"""

from velfence.mechanisms.chain import DHChain, PlanarArm, SerialChain
from velfence.mechanisms.cospm import PAPER_STOPS, PAPER_WORKSPACE, Q_AUX, CoSPM, CoSPMDesign
from velfence.mechanisms.cospm_region import (
    RegionReport,
    SingularGrid,
    WorkspaceMap,
    singular_curves,
    stops_polygon,
    validate_region,
    workspace_map,
)
from velfence.mechanisms.puma560 import Puma560
from velfence.mechanisms.wrist import LIMIT_NAMES, Wrist, WristGeometry

__all__ = [
    "LIMIT_NAMES",
    "PAPER_STOPS",
    "PAPER_WORKSPACE",
    "Q_AUX",
    "CoSPM",
    "CoSPMDesign",
    "DHChain",
    "PlanarArm",
    "Puma560",
    "RegionReport",
    "SerialChain",
    "SingularGrid",
    "WorkspaceMap",
    "Wrist",
    "WristGeometry",
    "singular_curves",
    "stops_polygon",
    "validate_region",
    "workspace_map",
]
