"""The ROS 2 graph, parameter, lifecycle and log interfaces as Cyclone DDS IDL structs.

Like :mod:`velfence.bridge.msgs`, each class carries the DDS type name ``rmw_cyclonedds_cpp``
uses (``rcl_interfaces::msg::dds_::Log_``), with fields in the order of the ``.msg`` / ``.srv``
definitions of ROS 2 Jazzy (rmw_dds_common, rcl_interfaces, lifecycle_msgs) and of
ros/bond_core (``bond/msg/Status``, the bonds of Nav2).

A service's request and reply travel on two topics, ``rq/<service>Request`` and
``rr/<service>Reply``, and rmw_cyclonedds writes a 16-byte header before the message's fields:
the client's 64-bit writer id and a 64-bit sequence number. The request and response classes
here (``*_Request`` / ``*_Response``) start with those two fields, ``_rmw_guid`` and
``_rmw_seq``; their names start with ``_`` so that :mod:`velfence.bridge.typehash` leaves them
out of the type hash, which is the hash of the ROS 2 type without the header.

The graph message ``rmw_dds_common/msg/Gid`` is ``char[24]`` in Humble and ``char[16]`` in
Jazzy: both forms are here (:data:`GRAPH_TYPES` picks them by distro). ``char`` travels as one
byte; the classes declare it as ``uint8`` (Cyclone's Python ``char`` is signed) and name the
field in ``__ros_char_fields__`` so that the type hash still says ``char``.

This module deliberately has no ``from __future__ import annotations`` (see
:mod:`velfence.bridge.msgs`).
"""

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, ClassVar

from velfence._extras import missing

try:
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl import types as t
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._docs import document_inits
from velfence.bridge.msgs import Header, Time

if TYPE_CHECKING:  # what a sequence or array field holds, for the type checker
    from collections.abc import Sequence as sequence  # noqa: N813

    Gid16Data = sequence[int]
    Gid24Data = sequence[int]
    Name256 = str
    OneRange = sequence
else:
    sequence = t.sequence
    Gid16Data = t.array[t.uint8, 16]
    Gid24Data = t.array[t.uint8, 24]
    #: ``string<=256``.
    Name256 = t.bounded_str[256]

    class OneRange:
        """``T[<=1]``: ``OneRange[T]`` is a bounded sequence of at most one element."""

        def __class_getitem__(cls, of: type) -> object:
            return t.sequence[of, 1]


__all__ = [
    "GRAPH_TYPES",
    "BondStatus",
    "ChangeState_Request",
    "ChangeState_Response",
    "DescribeParameters_Request",
    "DescribeParameters_Response",
    "FloatingPointRange",
    "GetAvailableStates_Request",
    "GetAvailableStates_Response",
    "GetAvailableTransitions_Request",
    "GetAvailableTransitions_Response",
    "GetParameterTypes_Request",
    "GetParameterTypes_Response",
    "GetParameters_Request",
    "GetParameters_Response",
    "GetState_Request",
    "GetState_Response",
    "Gid16",
    "Gid24",
    "IntegerRange",
    "LifecycleState",
    "LifecycleTransition",
    "ListParametersResult",
    "ListParameters_Request",
    "ListParameters_Response",
    "Log",
    "NodeEntitiesInfo16",
    "NodeEntitiesInfo24",
    "Parameter",
    "ParameterDescriptor",
    "ParameterEvent",
    "ParameterValue",
    "ParticipantEntitiesInfo16",
    "ParticipantEntitiesInfo24",
    "SetParametersAtomically_Request",
    "SetParametersAtomically_Response",
    "SetParametersResult",
    "SetParameters_Request",
    "SetParameters_Response",
    "TransitionDescription",
    "TransitionEvent",
]


def _zeros16() -> list[int]:
    return [0] * 16


def _zeros24() -> list[int]:
    return [0] * 24


# ---------------------------------------------------------------- rmw_dds_common (the graph)
@dataclass
class Gid16(IdlStruct, typename="rmw_dds_common.msg.dds_.Gid_"):
    """rmw_dds_common/msg/Gid of Jazzy: ``char[16]``, the entity's DDS GUID."""

    __ros_char_fields__: ClassVar[tuple[str, ...]] = ("data",)
    data: Gid16Data = field(default_factory=_zeros16)


@dataclass
class NodeEntitiesInfo16(IdlStruct, typename="rmw_dds_common.msg.dds_.NodeEntitiesInfo_"):
    """rmw_dds_common/msg/NodeEntitiesInfo of Jazzy: a node and its readers' and writers' gids."""

    node_namespace: Name256 = ""
    node_name: Name256 = ""
    reader_gid_seq: sequence[Gid16] = field(default_factory=list)
    writer_gid_seq: sequence[Gid16] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo16(
    IdlStruct, typename="rmw_dds_common.msg.dds_.ParticipantEntitiesInfo_"
):
    """rmw_dds_common/msg/ParticipantEntitiesInfo of Jazzy (the ``ros_discovery_info`` topic)."""

    gid: Gid16 = field(default_factory=Gid16)
    node_entities_info_seq: sequence[NodeEntitiesInfo16] = field(default_factory=list)


@dataclass
class Gid24(IdlStruct, typename="rmw_dds_common.msg.dds_.Gid_"):
    """rmw_dds_common/msg/Gid of Humble: ``char[24]``, the DDS GUID padded with zeros."""

    __ros_char_fields__: ClassVar[tuple[str, ...]] = ("data",)
    data: Gid24Data = field(default_factory=_zeros24)


@dataclass
class NodeEntitiesInfo24(IdlStruct, typename="rmw_dds_common.msg.dds_.NodeEntitiesInfo_"):
    """rmw_dds_common/msg/NodeEntitiesInfo of Humble."""

    node_namespace: Name256 = ""
    node_name: Name256 = ""
    reader_gid_seq: sequence[Gid24] = field(default_factory=list)
    writer_gid_seq: sequence[Gid24] = field(default_factory=list)


@dataclass
class ParticipantEntitiesInfo24(
    IdlStruct, typename="rmw_dds_common.msg.dds_.ParticipantEntitiesInfo_"
):
    """rmw_dds_common/msg/ParticipantEntitiesInfo of Humble."""

    gid: Gid24 = field(default_factory=Gid24)
    node_entities_info_seq: sequence[NodeEntitiesInfo24] = field(default_factory=list)


#: Per target distro: (gid size in bytes, Gid, NodeEntitiesInfo, ParticipantEntitiesInfo).
GRAPH_TYPES: dict[str, tuple[int, type, type, type]] = {
    "jazzy": (16, Gid16, NodeEntitiesInfo16, ParticipantEntitiesInfo16),
    "humble": (24, Gid24, NodeEntitiesInfo24, ParticipantEntitiesInfo24),
}


# ---------------------------------------------------------------- rcl_interfaces: messages
@dataclass
class Log(IdlStruct, typename="rcl_interfaces.msg.dds_.Log_"):
    """rcl_interfaces/msg/Log (the ``/rosout`` topic); ``level`` 10 DEBUG … 50 FATAL."""

    stamp: Time = field(default_factory=Time)
    level: t.uint8 = 0
    name: str = ""
    msg: str = ""
    file: str = ""
    function: str = ""
    line: t.uint32 = 0


@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces.msg.dds_.ParameterValue_"):
    """rcl_interfaces/msg/ParameterValue: ``type`` says which field holds the value."""

    type: t.uint8 = 0
    bool_value: bool = False
    integer_value: t.int64 = 0
    double_value: t.float64 = 0.0
    string_value: str = ""
    byte_array_value: sequence[t.byte] = field(default_factory=list)
    bool_array_value: sequence[bool] = field(default_factory=list)
    integer_array_value: sequence[t.int64] = field(default_factory=list)
    double_array_value: sequence[t.float64] = field(default_factory=list)
    string_array_value: sequence[str] = field(default_factory=list)


@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces.msg.dds_.Parameter_"):
    """rcl_interfaces/msg/Parameter."""

    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@dataclass
class FloatingPointRange(IdlStruct, typename="rcl_interfaces.msg.dds_.FloatingPointRange_"):
    """rcl_interfaces/msg/FloatingPointRange (``step`` 0: any value in the range)."""

    from_value: t.float64 = 0.0
    to_value: t.float64 = 0.0
    step: t.float64 = 0.0


@dataclass
class IntegerRange(IdlStruct, typename="rcl_interfaces.msg.dds_.IntegerRange_"):
    """rcl_interfaces/msg/IntegerRange."""

    from_value: t.int64 = 0
    to_value: t.int64 = 0
    step: t.uint64 = 0


@dataclass
class ParameterDescriptor(IdlStruct, typename="rcl_interfaces.msg.dds_.ParameterDescriptor_"):
    """rcl_interfaces/msg/ParameterDescriptor."""

    name: str = ""
    type: t.uint8 = 0
    description: str = ""
    additional_constraints: str = ""
    read_only: bool = False
    dynamic_typing: bool = False
    floating_point_range: OneRange[FloatingPointRange] = field(default_factory=list)
    integer_range: OneRange[IntegerRange] = field(default_factory=list)


@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces.msg.dds_.SetParametersResult_"):
    """rcl_interfaces/msg/SetParametersResult."""

    successful: bool = False
    reason: str = ""


@dataclass
class ListParametersResult(IdlStruct, typename="rcl_interfaces.msg.dds_.ListParametersResult_"):
    """rcl_interfaces/msg/ListParametersResult."""

    names: sequence[str] = field(default_factory=list)
    prefixes: sequence[str] = field(default_factory=list)


@dataclass
class ParameterEvent(IdlStruct, typename="rcl_interfaces.msg.dds_.ParameterEvent_"):
    """rcl_interfaces/msg/ParameterEvent (the ``/parameter_events`` topic)."""

    stamp: Time = field(default_factory=Time)
    node: str = ""
    new_parameters: sequence[Parameter] = field(default_factory=list)
    changed_parameters: sequence[Parameter] = field(default_factory=list)
    deleted_parameters: sequence[Parameter] = field(default_factory=list)


# ---------------------------------------------------------------- rcl_interfaces: services
@dataclass
class ListParameters_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.ListParameters_Request_"
):
    """rcl_interfaces/srv/ListParameters request (``depth`` 0: recursive)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    prefixes: sequence[str] = field(default_factory=list)
    depth: t.uint64 = 0


@dataclass
class ListParameters_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.ListParameters_Response_"
):
    """rcl_interfaces/srv/ListParameters response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    result: ListParametersResult = field(default_factory=ListParametersResult)


@dataclass
class GetParameters_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.GetParameters_Request_"
):
    """rcl_interfaces/srv/GetParameters request."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    names: sequence[str] = field(default_factory=list)


@dataclass
class GetParameters_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.GetParameters_Response_"
):
    """rcl_interfaces/srv/GetParameters response (one value per name; NOT_SET if unknown)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    values: sequence[ParameterValue] = field(default_factory=list)


@dataclass
class SetParameters_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.SetParameters_Request_"
):
    """rcl_interfaces/srv/SetParameters request."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    parameters: sequence[Parameter] = field(default_factory=list)


@dataclass
class SetParameters_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.SetParameters_Response_"
):
    """rcl_interfaces/srv/SetParameters response (one result per parameter)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    results: sequence[SetParametersResult] = field(default_factory=list)


@dataclass
class SetParametersAtomically_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.SetParametersAtomically_Request_"
):
    """rcl_interfaces/srv/SetParametersAtomically request."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    parameters: sequence[Parameter] = field(default_factory=list)


@dataclass
class SetParametersAtomically_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.SetParametersAtomically_Response_"
):
    """rcl_interfaces/srv/SetParametersAtomically response (all set, or none)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    result: SetParametersResult = field(default_factory=SetParametersResult)


@dataclass
class DescribeParameters_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.DescribeParameters_Request_"
):
    """rcl_interfaces/srv/DescribeParameters request."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    names: sequence[str] = field(default_factory=list)


@dataclass
class DescribeParameters_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.DescribeParameters_Response_"
):
    """rcl_interfaces/srv/DescribeParameters response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    descriptors: sequence[ParameterDescriptor] = field(default_factory=list)


@dataclass
class GetParameterTypes_Request(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.GetParameterTypes_Request_"
):
    """rcl_interfaces/srv/GetParameterTypes request."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    names: sequence[str] = field(default_factory=list)


@dataclass
class GetParameterTypes_Response(  # noqa: N801
    IdlStruct, typename="rcl_interfaces.srv.dds_.GetParameterTypes_Response_"
):
    """rcl_interfaces/srv/GetParameterTypes response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    types: sequence[t.uint8] = field(default_factory=list)


# ---------------------------------------------------------------- lifecycle_msgs
@dataclass
class LifecycleState(IdlStruct, typename="lifecycle_msgs.msg.dds_.State_"):
    """lifecycle_msgs/msg/State: ``id`` (1 unconfigured, 2 inactive, 3 active, …) and label."""

    id: t.uint8 = 0
    label: str = ""


@dataclass
class LifecycleTransition(IdlStruct, typename="lifecycle_msgs.msg.dds_.Transition_"):
    """lifecycle_msgs/msg/Transition: ``id`` (1 configure, 3 activate, …) and label."""

    id: t.uint8 = 0
    label: str = ""


@dataclass
class TransitionDescription(IdlStruct, typename="lifecycle_msgs.msg.dds_.TransitionDescription_"):
    """lifecycle_msgs/msg/TransitionDescription."""

    transition: LifecycleTransition = field(default_factory=LifecycleTransition)
    start_state: LifecycleState = field(default_factory=LifecycleState)
    goal_state: LifecycleState = field(default_factory=LifecycleState)


@dataclass
class TransitionEvent(IdlStruct, typename="lifecycle_msgs.msg.dds_.TransitionEvent_"):
    """lifecycle_msgs/msg/TransitionEvent (the ``<node>/transition_event`` topic)."""

    timestamp: t.uint64 = 0
    transition: LifecycleTransition = field(default_factory=LifecycleTransition)
    start_state: LifecycleState = field(default_factory=LifecycleState)
    goal_state: LifecycleState = field(default_factory=LifecycleState)


@dataclass
class ChangeState_Request(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.ChangeState_Request_"
):
    """lifecycle_msgs/srv/ChangeState request (a label, when given, takes precedence)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    transition: LifecycleTransition = field(default_factory=LifecycleTransition)


@dataclass
class ChangeState_Response(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.ChangeState_Response_"
):
    """lifecycle_msgs/srv/ChangeState response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    success: bool = False


@dataclass
class GetState_Request(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetState_Request_"
):
    """lifecycle_msgs/srv/GetState request (empty: ROS gives it one placeholder byte)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class GetState_Response(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetState_Response_"
):
    """lifecycle_msgs/srv/GetState response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    current_state: LifecycleState = field(default_factory=LifecycleState)


@dataclass
class GetAvailableStates_Request(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetAvailableStates_Request_"
):
    """lifecycle_msgs/srv/GetAvailableStates request (empty)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class GetAvailableStates_Response(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetAvailableStates_Response_"
):
    """lifecycle_msgs/srv/GetAvailableStates response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    available_states: sequence[LifecycleState] = field(default_factory=list)


@dataclass
class GetAvailableTransitions_Request(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetAvailableTransitions_Request_"
):
    """lifecycle_msgs/srv/GetAvailableTransitions request (empty)."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    structure_needs_at_least_one_member: t.uint8 = 0


@dataclass
class GetAvailableTransitions_Response(  # noqa: N801
    IdlStruct, typename="lifecycle_msgs.srv.dds_.GetAvailableTransitions_Response_"
):
    """lifecycle_msgs/srv/GetAvailableTransitions response."""

    _rmw_guid: t.uint64 = 0
    _rmw_seq: t.int64 = 0
    available_transitions: sequence[TransitionDescription] = field(default_factory=list)


# ---------------------------------------------------------------- bond (ros/bond_core, ros2)
@dataclass
class BondStatus(IdlStruct, typename="bond.msg.dds_.Status_"):
    """bond/msg/Status (the ``bond`` topic of Nav2's lifecycle manager and its nodes)."""

    header: Header = field(default_factory=Header)
    id: str = ""
    instance_id: str = ""
    active: bool = False
    heartbeat_timeout: t.float32 = 0.0
    heartbeat_period: t.float32 = 0.0


document_inits(globals())
