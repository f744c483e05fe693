r"""Cobot control (Gillespie, Colgate & Peshkin 1999): steer direction, never speed.

Math contract (derivations, and every equation reconstructed from the damaged printed text, in
``docs/cobot.md``). A non-redundant cobot with n joints has n - 1 CVTs and allows one direction
of motion at a time; the human supplies the speed. Four spaces — end effector C_EE (R, T, κN, s),
joints C_J (q), one coupling space Σ_i per CVT, steering Φ (φ_i) — are linked by

* tangent/curvature transforms C_EE → C_J → Σ_i (eqs. 2.5, 2.7, 2.10, 2.11) or C_EE → Σ_i
  directly (2.13, 2.14), all one formula (:func:`map_tangent_curvature`);
* CVT models (:class:`SteeredWheel` eq. 2.15, :class:`TetrahedralCVT` eqs. 2.16–2.18):
  φ → t_i and κ_i → φ̇_i;
* the forward transformation φ → T through Ω and the generalised cross product Λ (2.21–2.24),
  singular configurations detected and reported;

and the path follower (eqs. 3.1–3.8) computes κN from the spatial error dynamics
ΔR'' + k₂ΔR' + k₁ΔR = 0, so the trace does not depend on how fast the human pushes.
:class:`CasterWall` is the passive-device analogue of the polygon shaper.
"""

from velfence.cobot.cvt import CVT, SteeredWheel, TetrahedralCVT
from velfence.cobot.follower import (
    FollowerOutput,
    PathFollower,
    critically_damped,
    gains_from_poles,
)
from velfence.cobot.model import (
    Cobot,
    CobotKinematics,
    Coupling,
    Heading,
    IdentityKinematics,
    RThetaKinematics,
    Steering,
    generalised_cross,
    r_theta_cobot,
    unicycle,
)
from velfence.cobot.transforms import (
    coupling_from_ee,
    coupling_from_joint,
    joint_from_ee,
    map_tangent_curvature,
    normalised_derivative,
)
from velfence.cobot.walls import CasterWall, WallSteering, WallSteeringOutput

__all__ = [
    "CVT",
    "CasterWall",
    "Cobot",
    "CobotKinematics",
    "Coupling",
    "FollowerOutput",
    "Heading",
    "IdentityKinematics",
    "PathFollower",
    "RThetaKinematics",
    "SteeredWheel",
    "Steering",
    "TetrahedralCVT",
    "WallSteering",
    "WallSteeringOutput",
    "coupling_from_ee",
    "coupling_from_joint",
    "critically_damped",
    "gains_from_poles",
    "generalised_cross",
    "joint_from_ee",
    "map_tangent_curvature",
    "normalised_derivative",
    "r_theta_cobot",
    "unicycle",
]

#: Names that moved to :mod:`velfence.sim.cobot` in 0.2 (the simulators are in one place).
_MOVED_TO_SIM = (
    "CobotTrace",
    "HeadingController",
    "constant_speed",
    "follow_in_ee",
    "pushing",
    "simulate_cobot",
)


def __getattr__(name: str) -> object:
    if name in _MOVED_TO_SIM:
        import warnings

        warnings.warn(
            f"velfence.cobot.{name} moved to velfence.sim.cobot.{name}; the old name goes in 0.3",
            DeprecationWarning,
            stacklevel=2,
        )
        from velfence.sim import cobot

        return getattr(cobot, name)
    raise AttributeError(f"module 'velfence.cobot' has no attribute {name!r}")
