"""velfence: keep velocity-controlled robots in their safe sets by shaping the commanded velocity.

``v_out = shape(state, v_cmd)`` every control cycle. See ``docs/`` for the derivations of every law.
"""

from velfence import _moved
from velfence.cobot import CasterWall, Cobot, PathFollower
from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter, VelfenceError
from velfence.filter import (
    FilterResult,
    JointLimits,
    Kinematics,
    SafetyFilter,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.geometry import (
    ConvexPolygon,
    ConvexPolytope,
    Rectangle,
    decompose,
    inscribed_rectangle,
)
from velfence.mechanisms import (
    CoSPM,
    CoSPMDesign,
    DHChain,
    PlanarArm,
    Puma560,
    Wrist,
    WristGeometry,
)
from velfence.redundancy import ConfigurationController, Obstacle, VelocityDamperQP
from velfence.shaping import (
    STAGE_NAMES,
    ZONE_NAMES,
    ApproachProfile,
    LagCompensation,
    LinearBuffer,
    LineFixture,
    LineScaling,
    PolygonShaper,
    PolytopeResult,
    PolytopeShaper,
    RateLimiter,
    Shaper,
    ShaperResult,
    ShapingResult,
    StopLimiter,
    ThreeZoneBraking,
)
from velfence.sim import (
    AxisLimits,
    Disturbance,
    HardStop,
    NoLimit,
    Trajectory,
    simulate,
    simulate_many,
)

__version__ = "0.1.0"

_moved.install()

__all__ = [
    "STAGE_NAMES",
    "ZONE_NAMES",
    "ApproachProfile",
    "AxisLimits",
    "CasterWall",
    "CoSPM",
    "CoSPMDesign",
    "Cobot",
    "ConfigurationController",
    "ConvexPolygon",
    "ConvexPolytope",
    "DHChain",
    "Disturbance",
    "FilterResult",
    "HardStop",
    "InvalidGeometry",
    "InvalidInput",
    "InvalidParameter",
    "JointLimits",
    "Kinematics",
    "LagCompensation",
    "LineFixture",
    "LineScaling",
    "LinearBuffer",
    "NoLimit",
    "Obstacle",
    "PathFollower",
    "PlanarArm",
    "PolygonShaper",
    "PolytopeResult",
    "PolytopeShaper",
    "Puma560",
    "RateLimiter",
    "Rectangle",
    "SafetyFilter",
    "Shaper",
    "ShaperResult",
    "ShapingResult",
    "SphereObstacle",
    "StopLimiter",
    "ThreeZoneBraking",
    "Trajectory",
    "VelfenceError",
    "VelocityDamperQP",
    "WorkspaceLimit",
    "Wrist",
    "WristGeometry",
    "__version__",
    "decompose",
    "inscribed_rectangle",
    "simulate",
    "simulate_many",
]
