"""ROS 2 interface definitions for the graph tests, as published text (the peer's own types).

Provenance: the ``.msg`` / ``.srv`` files of ROS 2 Jazzy — ros2/rcl_interfaces (packages
``builtin_interfaces``, ``rcl_interfaces``, ``lifecycle_msgs``) and ros2/rmw_dds_common
(``rmw_dds_common/msg``; Humble's ``Gid`` is ``char[24]``, Jazzy's ``char[16]``) — with comments
and constants left out (neither is on the wire). A service's ``.srv`` text is split at ``---``
into its ``_Request`` and ``_Response`` messages, as rosidl does. The peer registers these with
rosbags' typestore and never uses velfence's own message classes.

``bond/msg/Status`` is ros/bond_core's (branch ``ros2``, ``bond/msg/Status.msg``, the package
Nav2's lifecycle manager and nodes use for their bonds); rosbags ships no definition of it.
The command and state messages the peer streams (``geometry_msgs/msg/Twist``,
``nav_msgs/msg/Odometry`` and what they contain) are taken from rosbags' own Jazzy typestore.
"""

from __future__ import annotations

import re

#: What rosidl puts into an empty message (one byte on the wire).
EMPTY = "uint8 structure_needs_at_least_one_member\n"

MSGS: dict[str, str] = {
    "builtin_interfaces/msg/Time": "int32 sec\nuint32 nanosec\n",
    "rcl_interfaces/msg/ParameterValue": (
        "uint8 type\nbool bool_value\nint64 integer_value\nfloat64 double_value\n"
        "string string_value\nbyte[] byte_array_value\nbool[] bool_array_value\n"
        "int64[] integer_array_value\nfloat64[] double_array_value\n"
        "string[] string_array_value\n"
    ),
    "rcl_interfaces/msg/Parameter": "string name\nParameterValue value\n",
    "rcl_interfaces/msg/FloatingPointRange": (
        "float64 from_value\nfloat64 to_value\nfloat64 step\n"
    ),
    "rcl_interfaces/msg/IntegerRange": "int64 from_value\nint64 to_value\nuint64 step\n",
    "rcl_interfaces/msg/ParameterDescriptor": (
        "string name\nuint8 type\nstring description\nstring additional_constraints\n"
        "bool read_only false\nbool dynamic_typing false\n"
        "FloatingPointRange[<=1] floating_point_range\nIntegerRange[<=1] integer_range\n"
    ),
    "rcl_interfaces/msg/SetParametersResult": "bool successful\nstring reason\n",
    "rcl_interfaces/msg/ListParametersResult": "string[] names\nstring[] prefixes\n",
    "std_msgs/msg/Header": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "rcl_interfaces/msg/ParameterEvent": (
        "builtin_interfaces/Time stamp\nstring node\nParameter[] new_parameters\n"
        "Parameter[] changed_parameters\nParameter[] deleted_parameters\n"
    ),
    "bond/msg/Status": (
        "std_msgs/Header header\nstring id\nstring instance_id\nbool active\n"
        "float32 heartbeat_timeout\nfloat32 heartbeat_period\n"
    ),
    "rcl_interfaces/msg/Log": (
        "builtin_interfaces/Time stamp\nuint8 level\nstring name\nstring msg\nstring file\n"
        "string function\nuint32 line\n"
    ),
    "lifecycle_msgs/msg/State": "uint8 id\nstring label\n",
    "lifecycle_msgs/msg/Transition": "uint8 id\nstring label\n",
    "lifecycle_msgs/msg/TransitionDescription": (
        "Transition transition\nState start_state\nState goal_state\n"
    ),
    "lifecycle_msgs/msg/TransitionEvent": (
        "uint64 timestamp\nTransition transition\nState start_state\nState goal_state\n"
    ),
}

SRVS: dict[str, str] = {
    "rcl_interfaces/srv/ListParameters": (
        "string[] prefixes\nuint64 depth\n---\nListParametersResult result\n"
    ),
    "rcl_interfaces/srv/GetParameters": "string[] names\n---\nParameterValue[] values\n",
    "rcl_interfaces/srv/SetParameters": (
        "Parameter[] parameters\n---\nSetParametersResult[] results\n"
    ),
    "rcl_interfaces/srv/SetParametersAtomically": (
        "Parameter[] parameters\n---\nSetParametersResult result\n"
    ),
    "rcl_interfaces/srv/DescribeParameters": (
        "string[] names\n---\nParameterDescriptor[] descriptors\n"
    ),
    "rcl_interfaces/srv/GetParameterTypes": "string[] names\n---\nuint8[] types\n",
    "lifecycle_msgs/srv/ChangeState": "Transition transition\n---\nbool success\n",
    "lifecycle_msgs/srv/GetState": EMPTY + "---\nState current_state\n",
    "lifecycle_msgs/srv/GetAvailableStates": EMPTY + "---\nState[] available_states\n",
    "lifecycle_msgs/srv/GetAvailableTransitions": (
        EMPTY + "---\nTransitionDescription[] available_transitions\n"
    ),
}

#: rmw_dds_common per distro: (Gid, NodeEntitiesInfo, ParticipantEntitiesInfo).
GRAPH: dict[str, dict[str, str]] = {
    distro: {
        "rmw_dds_common/msg/Gid": f"char[{size}] data\n",
        "rmw_dds_common/msg/NodeEntitiesInfo": (
            "string<=256 node_namespace\nstring<=256 node_name\nGid[] reader_gid_seq\n"
            "Gid[] writer_gid_seq\n"
        ),
        "rmw_dds_common/msg/ParticipantEntitiesInfo": (
            "Gid gid\nNodeEntitiesInfo[] node_entities_info_seq\n"
        ),
    }
    for distro, size in (("jazzy", 16), ("humble", 24))
}


#: The streamed messages, with everything they contain (from rosbags' Jazzy typestore).
STREAMED = (
    "geometry_msgs/msg/Vector3",
    "geometry_msgs/msg/Twist",
    "geometry_msgs/msg/Point",
    "geometry_msgs/msg/Quaternion",
    "geometry_msgs/msg/Pose",
    "geometry_msgs/msg/PoseWithCovariance",
    "geometry_msgs/msg/TwistWithCovariance",
    "nav_msgs/msg/Odometry",
)


def typestore(distro: str = "jazzy") -> object:
    """A rosbags typestore with every definition above registered (services split at ``---``)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, object] = {name: jazzy.fielddefs[name] for name in STREAMED}
    for name, text in {**MSGS, **GRAPH[distro]}.items():
        types.update(get_types_from_msg(text, name))
    for name, text in SRVS.items():
        request, response = text.split("---\n")
        pkg = name.split("/")[0]
        for part, body in (("_Request", request), ("_Response", response)):
            # a message of the same package, named as in a .msg file of that package
            body = re.sub(r"^([A-Z]\w*)", pkg + r"/\1", body, flags=re.MULTILINE)
            # rosbags files a srv part under pkg/srv/msg/Name: keep ROS 2's pkg/srv/Name_Request
            for key, value in get_types_from_msg(body, name + part).items():
                types[key.replace("/srv/msg/", "/srv/")] = value
    store.register(types)  # type: ignore[arg-type]
    return store
