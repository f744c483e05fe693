"""velfence: keep velocity-controlled robots in their safe sets by shaping the commanded velocity.

``v_out = shape(state, v_cmd)`` every control cycle. See ``docs/`` for the derivations of every law.

The top level is the library's facade: the shapers, the safety filter and its row providers,
geometry, approach profiles, robot models and the errors — the names most programs need. Each
subpackage (:mod:`velfence.shaping`, :mod:`velfence.filter`, :mod:`velfence.geometry`,
:mod:`velfence.robots`, :mod:`velfence.mechanisms`, :mod:`velfence.sim`, …) exports its own
names; the applications (CLI, reproductions, demo, viewers) are under :mod:`velfence.apps`.
Names load on first use, so ``import velfence`` costs a few milliseconds and pulls in neither
NumPy nor SciPy until a class is touched.
"""

from __future__ import annotations

from velfence import _lazy, _moved

TYPE_CHECKING = False  # typing.TYPE_CHECKING without importing typing (a few ms at start-up)

__version__ = "0.1.0"

_moved.install()

#: Public name -> the subpackage that defines it (loaded on first access).
_FACADE: dict[str, str] = {
    # errors
    "VelfenceError": "velfence.errors",
    "InvalidInput": "velfence.errors",
    "InvalidParameter": "velfence.errors",
    "InvalidGeometry": "velfence.errors",
    # geometry
    "ConvexPolygon": "velfence.geometry",
    "ConvexPolytope": "velfence.geometry",
    "Rectangle": "velfence.geometry",
    # shapers and their results
    "PolygonShaper": "velfence.shaping",
    "PolytopeShaper": "velfence.shaping",
    "StopLimiter": "velfence.shaping",
    "RateLimiter": "velfence.shaping",
    "LineFixture": "velfence.shaping",
    "LineScaling": "velfence.shaping",
    "LagCompensation": "velfence.shaping",
    "Shaper": "velfence.shaping",
    "ShapingResult": "velfence.shaping",
    "PolytopeResult": "velfence.shaping",
    # approach profiles
    "ApproachProfile": "velfence.shaping",
    "LinearBuffer": "velfence.shaping",
    "ThreeZoneBraking": "velfence.shaping",
    # the safety filter and its row providers
    "SafetyFilter": "velfence.filter",
    "FilterResult": "velfence.filter",
    "JointLimits": "velfence.filter",
    "WorkspaceLimit": "velfence.filter",
    "SphereObstacle": "velfence.filter",
    "Kinematics": "velfence.filter",
    "RowProvider": "velfence.filter",
    "JointPositionLimit": "velfence.filter",
    "JointVelocityLimit": "velfence.filter",
    "JointAccelerationLimit": "velfence.filter",
    "WorkspaceRows": "velfence.filter",
    "ObstacleRows": "velfence.filter",
    # robot models
    "DHChain": "velfence.mechanisms",
    "PlanarArm": "velfence.mechanisms",
    "MujocoRobot": "velfence.robots",
    "panda": "velfence.robots",
    "ur5e": "velfence.robots",
}

#: Names the top level exported before 0.2 that now live only in their subpackage (``module`` or
#: ``module:new_name``). They still resolve, with a DeprecationWarning naming it, until 0.3.
_FORMER: dict[str, str] = {
    "STAGE_NAMES": "velfence.shaping",
    "ZONE_NAMES": "velfence.shaping",
    "ShaperResult": "velfence.shaping:ShapingResultProtocol",
    "AxisLimits": "velfence.sim",
    "Disturbance": "velfence.sim",
    "HardStop": "velfence.sim",
    "NoLimit": "velfence.sim",
    "Trajectory": "velfence.sim",
    "simulate": "velfence.sim",
    "simulate_many": "velfence.sim",
    "CasterWall": "velfence.cobot",
    "Cobot": "velfence.cobot",
    "PathFollower": "velfence.cobot",
    "CoSPM": "velfence.mechanisms",
    "CoSPMDesign": "velfence.mechanisms",
    "Puma560": "velfence.mechanisms",
    "Wrist": "velfence.mechanisms",
    "WristGeometry": "velfence.mechanisms",
    "ConfigurationController": "velfence.redundancy",
    "Obstacle": "velfence.filter:SphereObstacle",
    "VelocityDamperQP": "velfence.redundancy",
    "decompose": "velfence.geometry",
    "inscribed_rectangle": "velfence.geometry",
}

__all__ = [
    "ApproachProfile",
    "ConvexPolygon",
    "ConvexPolytope",
    "DHChain",
    "FilterResult",
    "InvalidGeometry",
    "InvalidInput",
    "InvalidParameter",
    "JointAccelerationLimit",
    "JointLimits",
    "JointPositionLimit",
    "JointVelocityLimit",
    "Kinematics",
    "LagCompensation",
    "LineFixture",
    "LineScaling",
    "LinearBuffer",
    "MujocoRobot",
    "ObstacleRows",
    "PlanarArm",
    "PolygonShaper",
    "PolytopeResult",
    "PolytopeShaper",
    "RateLimiter",
    "Rectangle",
    "RowProvider",
    "SafetyFilter",
    "Shaper",
    "ShapingResult",
    "SphereObstacle",
    "StopLimiter",
    "ThreeZoneBraking",
    "VelfenceError",
    "WorkspaceLimit",
    "WorkspaceRows",
    "__version__",
    "panda",
    "ur5e",
]


__getattr__, __dir__ = _lazy.attach("velfence", _FACADE, globals(), former=_FORMER)


if TYPE_CHECKING:  # the same names, eagerly, for type checkers and IDEs
    from velfence.errors import InvalidGeometry, InvalidInput, InvalidParameter, VelfenceError
    from velfence.filter import (
        FilterResult,
        JointAccelerationLimit,
        JointLimits,
        JointPositionLimit,
        JointVelocityLimit,
        Kinematics,
        ObstacleRows,
        RowProvider,
        SafetyFilter,
        SphereObstacle,
        WorkspaceLimit,
        WorkspaceRows,
    )
    from velfence.geometry import ConvexPolygon, ConvexPolytope, Rectangle
    from velfence.mechanisms import DHChain, PlanarArm
    from velfence.robots import MujocoRobot, panda, ur5e
    from velfence.shaping import (
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
        ShapingResult,
        StopLimiter,
        ThreeZoneBraking,
    )
