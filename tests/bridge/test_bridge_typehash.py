"""RIHS01 type hashes against values published by ROS 2, and the CDR bytes against rosbags.

Known hashes and where they were found (public sources, via the code search index):

* geometry_msgs/msg/Twist, std_msgs/msg/Header, sensor_msgs/msg/JointState,
  control_msgs/msg/JointJog: the ``<Type>__TYPE_HASH`` byte arrays that ROS 2's own
  ``rosidl_generator_c`` writes into ``<pkg>/msg/detail/<type>__struct.h`` (Iron+ builds of the
  interface packages; e.g. control_msgs/msg/detail/joint_jog__struct.h as vendored in
  micro-ROS builds).
* geometry_msgs/msg/TwistStamped: ``Topic type hash:`` in the output of
  ``ros2 topic info /cmd_vel -v`` (a ros_gz_bridge subscription) quoted in a public ROS 2
  networking guide; sensor_msgs/msg/JointState also in the same command's output for
  ``/joint_states`` of joint_state_broadcaster in a public ros2_control tutorial.
* std_msgs/msg/String: ``type_description_hash`` in a rosbag2 ``metadata.yaml`` quoted in a
  public ROS 2 course.

rosbags (an independent implementation, a test dependency of the ``ros`` extra) cross-checks
every other type of :mod:`velfence.bridge.msgs`.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from velfence.bridge import msgs
from velfence.bridge.typehash import rihs01, type_description, user_data
from velfence.errors import InvalidParameter


def _from_c_bytes(*rows: str) -> str:
    """A ``rosidl_type_hash_t`` byte array as written in the generated C header."""
    hexes = "".join(rows).replace("0x", "").replace(",", "").split()
    return "RIHS01_" + "".join(hexes)


KNOWN = {
    # rosidl_generator_c: geometry_msgs/msg/detail/twist__struct.h
    msgs.Twist: _from_c_bytes(
        "0x9c, 0x45, 0xbf, 0x16, 0xfe, 0x09, 0x83, 0xd8,",
        "0x0e, 0x3c, 0xfe, 0x75, 0x0d, 0x68, 0x35, 0x84,",
        "0x3d, 0x26, 0x5a, 0x9a, 0x6c, 0x46, 0xbd, 0x2e,",
        "0x60, 0x9f, 0xcd, 0xdd, 0xe6, 0xfb, 0x8d, 0x2a,",
    ),
    # rosidl_generator_c: std_msgs/msg/detail/header__struct.h
    msgs.Header: _from_c_bytes(
        "0xf4, 0x9f, 0xb3, 0xae, 0x2c, 0xf0, 0x70, 0xf7,",
        "0x93, 0x64, 0x5f, 0xf7, 0x49, 0x68, 0x3a, 0xc6,",
        "0xb0, 0x62, 0x03, 0xe4, 0x1c, 0x89, 0x1e, 0x17,",
        "0x70, 0x1b, 0x1c, 0xb5, 0x97, 0xce, 0x6a, 0x01,",
    ),
    # rosidl_generator_c: sensor_msgs/msg/detail/joint_state__struct.h; the same value in
    # `ros2 topic info /joint_states -v` (joint_state_broadcaster) of a ros2_control tutorial.
    msgs.JointState: _from_c_bytes(
        "0xa1, 0x3e, 0xe3, 0xa3, 0x30, 0xe3, 0x46, 0xc9,",
        "0xd8, 0x7b, 0x5a, 0xa1, 0x8d, 0x24, 0xe1, 0x16,",
        "0x90, 0x75, 0x2b, 0xd3, 0x3a, 0x03, 0x50, 0xf1,",
        "0x1c, 0x58, 0x82, 0xbc, 0x91, 0x79, 0x26, 0x0e,",
    ),
    # rosidl_generator_c: control_msgs/msg/detail/joint_jog__struct.h (not in rosbags' stores)
    msgs.JointJog: _from_c_bytes(
        "0xba, 0x24, 0x94, 0x55, 0xa2, 0x0f, 0x70, 0x16,",
        "0x8a, 0x1a, 0xcb, 0x7b, 0xf4, 0x3b, 0x77, 0x6b,",
        "0x72, 0xff, 0x1f, 0x7e, 0xb5, 0xfc, 0x4c, 0xfe,",
        "0xa4, 0x43, 0xf7, 0x49, 0xe9, 0x63, 0xc6, 0xe7,",
    ),
    # `ros2 topic info /cmd_vel -v`, Topic type hash of a ros_gz_bridge subscription
    msgs.TwistStamped: "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
    # rosbag2 metadata.yaml, type_description_hash of a std_msgs/msg/String topic
    msgs.String: "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
}


@pytest.mark.parametrize("typ", list(KNOWN), ids=[msgs.ros_name(t) for t in KNOWN])
def test_known_published_hashes(typ: type) -> None:
    assert rihs01(typ) == KNOWN[typ]


def test_every_type_matches_rosbags() -> None:
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    checked = 0
    for typ in msgs.ALL_TYPES:
        name = msgs.ros_name(typ)
        if name not in store.fielddefs:
            continue  # control_msgs is not in rosbags' store (checked against ROS above)
        assert rihs01(typ) == store.hash_rihs01(name), name
        checked += 1
    assert checked == len(msgs.ALL_TYPES) - 1


def test_description_shape_and_hash_route() -> None:
    d = type_description(msgs.JointState)
    assert d["type_description"]["type_name"] == "sensor_msgs/msg/JointState"
    fields = {f["name"]: f["type"] for f in d["type_description"]["fields"]}
    assert fields["header"] == {
        "type_id": 1,
        "capacity": 0,
        "string_capacity": 0,
        "nested_type_name": "std_msgs/msg/Header",
    }
    assert fields["name"]["type_id"] == 17 + 144  # string[] (unbounded sequence)
    assert fields["position"]["type_id"] == 11 + 144  # float64[]
    refs = [r["type_name"] for r in d["referenced_type_descriptions"]]
    assert refs == ["builtin_interfaces/msg/Time", "std_msgs/msg/Header"]  # sorted, transitive
    cov = {
        f["name"]: f["type"]
        for f in type_description(msgs.PoseWithCovariance)["type_description"]["fields"]
    }["covariance"]
    assert (cov["type_id"], cov["capacity"]) == (11 + 48, 36)  # float64[36]
    text = json.dumps(d, separators=(", ", ": "))
    assert rihs01(msgs.JointState) == "RIHS01_" + hashlib.sha256(text.encode()).hexdigest()
    assert user_data(msgs.Twist) == f"typehash={KNOWN[msgs.Twist]};".encode()


@pytest.mark.parametrize("bad", [int, 3, "geometry_msgs/msg/Twist", None, np.ndarray])
def test_not_a_message_type_refused(bad: object) -> None:
    with pytest.raises(InvalidParameter, match="msg_type"):
        rihs01(bad)  # type: ignore[arg-type]


def test_cdr_bytes_read_by_rosbags() -> None:
    """The CDR the bridge writes is what a ROS 2 node reads (rosbags as the ROS 2 side)."""
    typesys = pytest.importorskip("rosbags.typesys")
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    js = msgs.JointState(
        header=msgs.Header(stamp=msgs.Time(sec=12, nanosec=34), frame_id="base"),
        name=["a", "bb"],
        position=[0.5, -1.25],
        velocity=[1e-3],
    )
    got = store.deserialize_cdr(js.serialize(), "sensor_msgs/msg/JointState")
    assert (got.header.stamp.sec, got.header.stamp.nanosec) == (12, 34)
    assert got.header.frame_id == "base"
    assert got.name == ["a", "bb"]
    assert got.position.tolist() == [0.5, -1.25]
    assert got.velocity.tolist() == [1e-3]
    diag = msgs.DiagnosticArray(
        status=[
            msgs.DiagnosticStatus(
                level=2, name="n", message="m", values=[msgs.KeyValue(key="k", value="v")]
            )
        ]
    )
    d = store.deserialize_cdr(diag.serialize(), "diagnostic_msgs/msg/DiagnosticArray")
    assert d.status[0].level == 2
    assert (d.status[0].values[0].key, d.status[0].values[0].value) == ("k", "v")
    odo = msgs.Odometry(child_frame_id="base_link")
    odo.pose.pose.position.x = 1.5
    odo.pose.covariance[35] = 0.25
    o = store.deserialize_cdr(odo.serialize(), "nav_msgs/msg/Odometry")
    assert o.pose.pose.position.x == 1.5
    assert o.pose.covariance[35] == 0.25
    # And back: rosbags' bytes read by the bridge's type.
    ros = store.types["geometry_msgs/msg/TwistStamped"]
    hdr = store.types["std_msgs/msg/Header"]
    tm = store.types["builtin_interfaces/msg/Time"]
    v3 = store.types["geometry_msgs/msg/Vector3"]
    tw = store.types["geometry_msgs/msg/Twist"]
    raw = store.serialize_cdr(
        ros(
            header=hdr(stamp=tm(sec=1, nanosec=2), frame_id="f"),
            twist=tw(linear=v3(x=0.1, y=0.2, z=0.3), angular=v3(x=0.0, y=0.0, z=1.0)),
        ),
        "geometry_msgs/msg/TwistStamped",
    )
    back = msgs.TwistStamped.deserialize(bytes(raw))
    assert (back.twist.linear.y, back.twist.angular.z, back.header.frame_id) == (0.2, 1.0, "f")
