r"""Laser-assisted traded control of a PUMA 560 (Khokar 2009), simulated end to end.

Math contract (derivations in ``docs/telerobotics.md``): resolved-rate motion
:math:`\dot q = J^{-1}(q)\,\dot x` or the singularity-robust inverse
:math:`\dot q = J^\top (J J^\top + k I)^{-1}\dot x`, :math:`k = k_0 (1 - w/w_0)^2` below
:math:`w_0`; straight-line Cartesian trajectories with equivalent-angle-axis orientation
interpolation; a laser range sensor ray-cast into a scene of primitives; and the traded-control
modes whose virtual fixtures are velocity shapers from :mod:`velfence.shaping`.
"""

from velfence.apps.teleop.laser import (
    Characteristic,
    LaserRangeSensor,
    LaserReading,
    LaserStream,
    TabulatedCharacteristic,
    VoltageModel,
    calibrate,
    frequent_level_mean,
    moving_average,
    plane_from_points,
)
from velfence.apps.teleop.modes import ModeEvent, ModeManager, Segment, aligned_rotation
from velfence.apps.teleop.operator import OperatorProfile, SyntheticOperator
from velfence.apps.teleop.resolved_rate import (
    RateResult,
    ResolvedRate,
    angle_axis,
    damping,
    manipulability_of,
    pose_error,
    rotation_from_angle_axis,
    rotation_vector,
    sr_inverse,
)
from velfence.apps.teleop.scene import (
    Box,
    Cylinder,
    Disk,
    Hit,
    Plane,
    Primitive,
    Scene,
    door_scene,
    pick_and_place_scene,
    scene_to_dicts,
)
from velfence.apps.teleop.servo import FirstOrderServo, JointServo, PDGravityServo
from velfence.apps.teleop.session import Observation, Session
from velfence.apps.teleop.task import TaskRecord, TaskRun, run_task
from velfence.apps.teleop.trajectory import CartesianTrajectory, Execution, execute, straight_line

__all__ = [
    "Box",
    "CartesianTrajectory",
    "Characteristic",
    "Cylinder",
    "Disk",
    "Execution",
    "FirstOrderServo",
    "Hit",
    "JointServo",
    "LaserRangeSensor",
    "LaserReading",
    "LaserStream",
    "ModeEvent",
    "ModeManager",
    "Observation",
    "OperatorProfile",
    "PDGravityServo",
    "Plane",
    "Primitive",
    "RateResult",
    "ResolvedRate",
    "Scene",
    "Segment",
    "Session",
    "SyntheticOperator",
    "TabulatedCharacteristic",
    "TaskRecord",
    "TaskRun",
    "VoltageModel",
    "aligned_rotation",
    "angle_axis",
    "calibrate",
    "damping",
    "door_scene",
    "execute",
    "frequent_level_mean",
    "manipulability_of",
    "moving_average",
    "pick_and_place_scene",
    "plane_from_points",
    "pose_error",
    "rotation_from_angle_axis",
    "rotation_vector",
    "run_task",
    "scene_to_dicts",
    "sr_inverse",
    "straight_line",
]
