r"""The joint-space safety filter: row providers, the priority ladder, the kinematics protocol.

Math contract: every cycle, for a joint position ``q`` and a command (joint velocity ``u`` or a
twist), :class:`SafetyFilter` returns the joint velocity ``x`` nearest the command (in the
joint metric ``W``, or the twist's damped least squares) subject to ``G x >= b``, the rows of
every :class:`~velfence.filter.rows.RowProvider` built from one
:class:`~velfence.filter.kinematics.KinematicsFrame` of ``q``: joint position (braking profile)
and velocity, acceleration, workspace polytopes on named points, sphere obstacles against capsule
links, speed and separation monitoring against tracked people (:mod:`~velfence.filter.separation`,
advisory), obstacles from point clouds (:mod:`~velfence.filter.point_cloud`), safety modes with
mode, slowdown and time-to-collision zones (:mod:`~velfence.filter.modes`), and the user's
own. When the rows have no common point the ladder
(:mod:`velfence.filter.ladder`) drops the acceleration rows, then relaxes only violated rows'
recovery bounds (obstacles, workspace, joints) toward "no further out", else stops: zero meets
every row of the safety levels once relaxed, so no workspace or obstacle row is ever dropped.
With ``dt`` the next pose is checked on the kinematics (``d1 >= min(0, d0)``). With
``max_iterations``/``time_budget`` a cycle that runs out answers a safe fallback. The output is
always finite; bad input raises a :class:`~velfence.errors.VelfenceError` naming the argument.

Modules: :mod:`~velfence.filter.kinematics` (protocol and per-cycle cache),
:mod:`~velfence.filter.limits` (limit value objects), :mod:`~velfence.filter.rows` (row
providers), :mod:`~velfence.filter.ladder` (priority ladder and fallbacks),
:mod:`~velfence.filter.result` (:class:`FilterResult`), :mod:`~velfence.filter.solve` (the
projection under the metric, its backends, cap and warm start), :mod:`~velfence.filter.stack`
(one cycle's stacked rows and their keys), :mod:`~velfence.filter.parts` (the validated parts,
checked at construction), :mod:`~velfence.filter.filter` (:class:`SafetyFilter`),
:mod:`~velfence.filter.twist` (:class:`TwistMode`: the filter in twist mode as a shaper on
``(q, v)``), :mod:`~velfence.filter.clearance` (:func:`link_clearances`: every link-obstacle
clearance at a position or along a run, for plots and checks).
"""

from velfence.filter.attach import (
    AttachmentObstacleRows,
    AttachmentTable,
    AttachmentWorkspaceRows,
)
from velfence.filter.clearance import LinkClearances, link_clearances
from velfence.filter.filter import SafetyFilter
from velfence.filter.kinematics import (
    CachedFrame,
    ChainData,
    ChainFrames,
    Kinematics,
    KinematicsFrame,
)
from velfence.filter.limits import (
    Capsule,
    JointLimits,
    Profile,
    SelfCollision,
    Sphere,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.filter.modes import (
    ApproachRows,
    ApproachZone,
    ModeEvent,
    ModeLimits,
    ModeRows,
    ModeZone,
    SafetyMode,
    SlowdownRows,
    SlowdownZone,
    speed_cap_directions,
)
from velfence.filter.point_cloud import MAX_CLOUD_POINTS, PointCloudRows
from velfence.filter.result import FilterBatch, FilterResult
from velfence.filter.rows import (
    LEVEL_JERK,
    LEVEL_JOINT,
    LEVEL_NAMES,
    LEVEL_OBSTACLE,
    LEVEL_RATE,
    LEVEL_WORKSPACE,
    JointAccelerationLimit,
    JointJerkLimit,
    JointPositionLimit,
    JointVelocityLimit,
    ObstacleRows,
    RowBlock,
    RowContext,
    RowProvider,
    SelfCollisionRows,
    WorkspaceRows,
)
from velfence.filter.separation import (
    WALKING_SPEED,
    PersonCapsule,
    SeparationParameters,
    SeparationRows,
    max_approach_speed,
    separation_distance,
)
from velfence.filter.twist import TwistMode

__all__ = [
    "LEVEL_JERK",
    "LEVEL_JOINT",
    "LEVEL_NAMES",
    "LEVEL_OBSTACLE",
    "LEVEL_RATE",
    "LEVEL_WORKSPACE",
    "MAX_CLOUD_POINTS",
    "WALKING_SPEED",
    "ApproachRows",
    "ApproachZone",
    "AttachmentObstacleRows",
    "AttachmentTable",
    "AttachmentWorkspaceRows",
    "CachedFrame",
    "Capsule",
    "ChainData",
    "ChainFrames",
    "FilterBatch",
    "FilterResult",
    "JointAccelerationLimit",
    "JointJerkLimit",
    "JointLimits",
    "JointPositionLimit",
    "JointVelocityLimit",
    "Kinematics",
    "KinematicsFrame",
    "LinkClearances",
    "ModeEvent",
    "ModeLimits",
    "ModeRows",
    "ModeZone",
    "ObstacleRows",
    "PersonCapsule",
    "PointCloudRows",
    "Profile",
    "RowBlock",
    "RowContext",
    "RowProvider",
    "SafetyFilter",
    "SafetyMode",
    "SelfCollision",
    "SelfCollisionRows",
    "SeparationParameters",
    "SeparationRows",
    "SlowdownRows",
    "SlowdownZone",
    "Sphere",
    "SphereObstacle",
    "TwistMode",
    "WorkspaceLimit",
    "WorkspaceRows",
    "link_clearances",
    "max_approach_speed",
    "separation_distance",
    "speed_cap_directions",
]
