"""ROS 2 message types as keyless Cyclone DDS IDL structs, with their ROS 2 wire names.

Each class is registered under the DDS type name a ROS 2 node on ``rmw_cyclonedds_cpp`` uses
(``geometry_msgs::msg::dds_::Twist_``), so a topic ``rt/<name>`` of that type carries the same
CDR bytes as ROS 2 does. Field order, names and types follow the ``.msg`` definitions of ROS 2
Jazzy; :mod:`velfence.bridge.typehash` computes their RIHS01 type hashes from these classes.

Units follow ROS (REP-103): lengths [m], angles [rad], linear velocity [m/s], angular velocity
[rad/s], time ``sec`` [s] + ``nanosec`` [ns].

This module deliberately has no ``from __future__ import annotations``: the Cyclone DDS binding
reads the field annotations at class creation (cyclonedds-python#305).
"""

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from velfence._extras import missing

try:
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl import types as t
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._docs import document_inits

if TYPE_CHECKING:  # what a sequence or array field holds, for the type checker
    from collections.abc import Sequence as sequence  # noqa: N813

    Covariance = sequence[float]
else:
    sequence = t.sequence
    #: A row-major 6×6 covariance (``float64[36]``).
    Covariance = t.array[t.float64, 36]

__all__ = [
    "ALL_TYPES",
    "DiagnosticArray",
    "DiagnosticStatus",
    "Duration",
    "Float64MultiArray",
    "Header",
    "JointJog",
    "JointState",
    "JointTrajectory",
    "JointTrajectoryPoint",
    "KeyValue",
    "LaserScan",
    "MultiArrayDimension",
    "MultiArrayLayout",
    "Odometry",
    "Point",
    "PointCloud2",
    "PointField",
    "Pose",
    "PoseStamped",
    "PoseWithCovariance",
    "Quaternion",
    "String",
    "TFMessage",
    "Time",
    "Transform",
    "TransformStamped",
    "Twist",
    "TwistStamped",
    "TwistWithCovariance",
    "Vector3",
    "ros_name",
]


def _zeros36() -> list[float]:
    return [0.0] * 36


@dataclass
class Time(IdlStruct, typename="builtin_interfaces.msg.dds_.Time_"):
    """builtin_interfaces/msg/Time: ``sec`` [s] + ``nanosec`` [ns] since the epoch."""

    sec: t.int32 = 0
    nanosec: t.uint32 = 0


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces.msg.dds_.Duration_"):
    """builtin_interfaces/msg/Duration: ``sec`` [s] + ``nanosec`` [ns]."""

    sec: t.int32 = 0
    nanosec: t.uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs.msg.dds_.Header_"):
    """std_msgs/msg/Header: time stamp and coordinate frame."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class String(IdlStruct, typename="std_msgs.msg.dds_.String_"):
    """std_msgs/msg/String."""

    data: str = ""


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs.msg.dds_.MultiArrayDimension_"):
    """std_msgs/msg/MultiArrayDimension."""

    label: str = ""
    size: t.uint32 = 0
    stride: t.uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs.msg.dds_.MultiArrayLayout_"):
    """std_msgs/msg/MultiArrayLayout."""

    dim: sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: t.uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs.msg.dds_.Float64MultiArray_"):
    """std_msgs/msg/Float64MultiArray (the forward command controllers' input)."""

    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: sequence[t.float64] = field(default_factory=list)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs.msg.dds_.Vector3_"):
    """geometry_msgs/msg/Vector3."""

    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Twist(IdlStruct, typename="geometry_msgs.msg.dds_.Twist_"):
    """geometry_msgs/msg/Twist: ``linear`` [m/s] and ``angular`` [rad/s] velocity."""

    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistStamped(IdlStruct, typename="geometry_msgs.msg.dds_.TwistStamped_"):
    """geometry_msgs/msg/TwistStamped."""

    header: Header = field(default_factory=Header)
    twist: Twist = field(default_factory=Twist)


@dataclass
class Point(IdlStruct, typename="geometry_msgs.msg.dds_.Point_"):
    """geometry_msgs/msg/Point [m]."""

    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs.msg.dds_.Quaternion_"):
    """geometry_msgs/msg/Quaternion (x, y, z, w)."""

    x: t.float64 = 0.0
    y: t.float64 = 0.0
    z: t.float64 = 0.0
    w: t.float64 = 1.0


@dataclass
class Pose(IdlStruct, typename="geometry_msgs.msg.dds_.Pose_"):
    """geometry_msgs/msg/Pose."""

    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs.msg.dds_.PoseStamped_"):
    """geometry_msgs/msg/PoseStamped."""

    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs.msg.dds_.PoseWithCovariance_"):
    """geometry_msgs/msg/PoseWithCovariance (row-major 6×6 covariance)."""

    pose: Pose = field(default_factory=Pose)
    covariance: Covariance = field(default_factory=_zeros36)


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs.msg.dds_.TwistWithCovariance_"):
    """geometry_msgs/msg/TwistWithCovariance (row-major 6×6 covariance)."""

    twist: Twist = field(default_factory=Twist)
    covariance: Covariance = field(default_factory=_zeros36)


@dataclass
class Odometry(IdlStruct, typename="nav_msgs.msg.dds_.Odometry_"):
    """nav_msgs/msg/Odometry."""

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class Transform(IdlStruct, typename="geometry_msgs.msg.dds_.Transform_"):
    """geometry_msgs/msg/Transform: ``translation`` [m] and ``rotation`` of a frame."""

    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs.msg.dds_.TransformStamped_"):
    """geometry_msgs/msg/TransformStamped: ``child_frame_id``'s pose in ``header.frame_id``."""

    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs.msg.dds_.TFMessage_"):
    """tf2_msgs/msg/TFMessage (the ``/tf`` and ``/tf_static`` topics)."""

    transforms: sequence[TransformStamped] = field(default_factory=list)


@dataclass
class JointState(IdlStruct, typename="sensor_msgs.msg.dds_.JointState_"):
    """sensor_msgs/msg/JointState: ``position`` [rad or m], ``velocity``, ``effort``."""

    header: Header = field(default_factory=Header)
    name: sequence[str] = field(default_factory=list)
    position: sequence[t.float64] = field(default_factory=list)
    velocity: sequence[t.float64] = field(default_factory=list)
    effort: sequence[t.float64] = field(default_factory=list)


@dataclass
class PointField(IdlStruct, typename="sensor_msgs.msg.dds_.PointField_"):
    """sensor_msgs/msg/PointField: a field of a cloud's points (datatype 7 FLOAT32, 8 FLOAT64)."""

    name: str = ""
    offset: t.uint32 = 0
    datatype: t.uint8 = 0
    count: t.uint32 = 0


@dataclass
class PointCloud2(IdlStruct, typename="sensor_msgs.msg.dds_.PointCloud2_"):
    """sensor_msgs/msg/PointCloud2: ``height`` rows of ``width`` points of ``point_step`` bytes."""

    header: Header = field(default_factory=Header)
    height: t.uint32 = 0
    width: t.uint32 = 0
    fields: sequence[PointField] = field(default_factory=list)
    is_bigendian: bool = False
    point_step: t.uint32 = 0
    row_step: t.uint32 = 0
    data: sequence[t.uint8] = field(default_factory=list)
    is_dense: bool = False


@dataclass
class LaserScan(IdlStruct, typename="sensor_msgs.msg.dds_.LaserScan_"):
    """sensor_msgs/msg/LaserScan: angles [rad], times [s], ranges [m]."""

    header: Header = field(default_factory=Header)
    angle_min: t.float32 = 0.0
    angle_max: t.float32 = 0.0
    angle_increment: t.float32 = 0.0
    time_increment: t.float32 = 0.0
    scan_time: t.float32 = 0.0
    range_min: t.float32 = 0.0
    range_max: t.float32 = 0.0
    ranges: sequence[t.float32] = field(default_factory=list)
    intensities: sequence[t.float32] = field(default_factory=list)


@dataclass
class JointJog(IdlStruct, typename="control_msgs.msg.dds_.JointJog_"):
    """control_msgs/msg/JointJog (MoveIt Servo's joint command): ``velocities`` [rad/s]."""

    header: Header = field(default_factory=Header)
    joint_names: sequence[str] = field(default_factory=list)
    displacements: sequence[t.float64] = field(default_factory=list)
    velocities: sequence[t.float64] = field(default_factory=list)
    duration: t.float64 = 0.0


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs.msg.dds_.JointTrajectoryPoint_"):
    """trajectory_msgs/msg/JointTrajectoryPoint."""

    positions: sequence[t.float64] = field(default_factory=list)
    velocities: sequence[t.float64] = field(default_factory=list)
    accelerations: sequence[t.float64] = field(default_factory=list)
    effort: sequence[t.float64] = field(default_factory=list)
    time_from_start: Duration = field(default_factory=Duration)


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs.msg.dds_.JointTrajectory_"):
    """trajectory_msgs/msg/JointTrajectory."""

    header: Header = field(default_factory=Header)
    joint_names: sequence[str] = field(default_factory=list)
    points: sequence[JointTrajectoryPoint] = field(default_factory=list)


@dataclass
class KeyValue(IdlStruct, typename="diagnostic_msgs.msg.dds_.KeyValue_"):
    """diagnostic_msgs/msg/KeyValue."""

    key: str = ""
    value: str = ""


@dataclass
class DiagnosticStatus(IdlStruct, typename="diagnostic_msgs.msg.dds_.DiagnosticStatus_"):
    """diagnostic_msgs/msg/DiagnosticStatus (``level``: 0 OK, 1 WARN, 2 ERROR, 3 STALE)."""

    level: t.byte = 0
    name: str = ""
    message: str = ""
    hardware_id: str = ""
    values: sequence[KeyValue] = field(default_factory=list)


@dataclass
class DiagnosticArray(IdlStruct, typename="diagnostic_msgs.msg.dds_.DiagnosticArray_"):
    """diagnostic_msgs/msg/DiagnosticArray (the ``/diagnostics`` topic)."""

    header: Header = field(default_factory=Header)
    status: sequence[DiagnosticStatus] = field(default_factory=list)


#: Every message type of this module.
ALL_TYPES: tuple[type[IdlStruct], ...] = (
    Time,
    Duration,
    Header,
    String,
    MultiArrayDimension,
    MultiArrayLayout,
    Float64MultiArray,
    Vector3,
    Twist,
    TwistStamped,
    Point,
    Quaternion,
    Pose,
    PoseStamped,
    PoseWithCovariance,
    TwistWithCovariance,
    Odometry,
    Transform,
    TransformStamped,
    TFMessage,
    JointState,
    PointField,
    PointCloud2,
    LaserScan,
    JointJog,
    JointTrajectoryPoint,
    JointTrajectory,
    KeyValue,
    DiagnosticStatus,
    DiagnosticArray,
)


def ros_name(cls: type[IdlStruct]) -> str:
    """The ROS 2 interface name of a message class (``"geometry_msgs/msg/Twist"``).

    Args:
        cls: One of the message classes of this module.

    Returns:
        ``package/msg/Type``, derived from the DDS type name ``package::msg::dds_::Type_``.
    """
    dds = cls.__idl_typename__.replace("::", ".")
    pkg, kind, _dds, name = dds.split(".")
    return f"{pkg}/{kind}/{name.removesuffix('_')}"


document_inits(globals())
