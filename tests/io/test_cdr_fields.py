"""The replay's CDR field readers and its patching writer, against rosbags' own codec.

Messages of every type a replay reads are encoded by rosbags (little- and big-endian, frame ids
of every length modulo 8 so every padding occurs, a JointJog with its joints out of order, a
Float64MultiArray with layout dimensions); the replay's readers must give the values rosbags
decodes, and the bytes it writes must decode (by rosbags) to the original message with only the
velocities changed. Short or inconsistent bytes are refused with an error naming the topic.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")

from velfence.errors import InvalidParameter
from velfence.io import parse_shaper
from velfence.io._cdr import CdrError, CdrReader
from velfence.io.bags import (
    FLOAT_ARRAY,
    JOINT_JOG,
    JOINT_STATE,
    ODOMETRY,
    POSE_STAMPED,
    TWIST,
    TWIST_STAMPED,
    _joint_codec,
    _state_reader,
    _twist_codec,
    message_typestore,
)

TS = message_typestore(None)
T = TS.types
POLYGON = parse_shaper(
    {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
)
JOINTS = parse_shaper(
    {
        "kind": "joint_limits",
        "joint_names": ["a", "b", "c"],
        "lower": [-1] * 3,
        "upper": [1] * 3,
        "buffer": 0.2,
    }
)
FRAMES = ["", "m", "ma", "map", "odom", "odom1", "odom12", "odom123", "odom1234"]
ENDIAN = [True, False]


def _header(frame: str) -> Any:
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=7, nanosec=9), frame_id=frame
    )


def _v3(x: float, y: float, z: float) -> Any:
    return T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)


def _twist(k: int) -> Any:
    return T[TWIST](linear=_v3(0.1 * k, -0.2, 0.3), angular=_v3(0.4, 0.5, -0.6 * k))


def _pose(k: int) -> Any:
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=1.0 + k, y=2.0 - k, z=0.5),
        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.3, w=0.9539392014169457),
    )


def _encode(msg: Any, msgtype: str, little: bool) -> bytes:
    return bytes(TS.serialize_cdr(msg, msgtype, little_endian=little))


def _decode(raw: bytes, msgtype: str) -> Any:
    return TS.deserialize_cdr(raw, msgtype)


@pytest.mark.parametrize("little", ENDIAN)
@pytest.mark.parametrize("stamped", [False, True])
def test_twist_read_and_patch(little: bool, stamped: bool) -> None:
    codec = _twist_codec(POLYGON, TWIST_STAMPED if stamped else TWIST)
    for k, frame in enumerate(FRAMES):
        msg = _twist(k)
        msgtype = TWIST
        if stamped:
            msg, msgtype = T[TWIST_STAMPED](header=_header(frame), twist=msg), TWIST_STAMPED
        raw = _encode(msg, msgtype, little)
        v, token = codec.read(raw)
        np.testing.assert_array_equal(v, [0.1 * k, -0.2])
        out = _decode(codec.write(raw, token, np.array([9.0, 8.0]), None), msgtype)
        tw = out.twist if stamped else out
        assert (tw.linear.x, tw.linear.y, tw.linear.z) == (9.0, 8.0, 0.3)
        assert (tw.angular.x, tw.angular.y, tw.angular.z) == (0.4, 0.5, -0.6 * k)
        if stamped:
            assert out.header.frame_id == frame
            assert (out.header.stamp.sec, out.header.stamp.nanosec) == (7, 9)
        stopped = _decode(codec.write(raw, token, None, None), msgtype)
        st = stopped.twist if stamped else stopped
        assert [
            st.linear.x,
            st.linear.y,
            st.linear.z,
            st.angular.x,
            st.angular.y,
            st.angular.z,
        ] == [0.0] * 6
        turned = _decode(
            codec.write(raw, token, np.array([1.0, 2.0]), np.array([3, 4, 5.0])), msgtype
        )
        tt = turned.twist if stamped else turned
        assert (tt.angular.x, tt.angular.y, tt.angular.z) == (3.0, 4.0, 5.0)


@pytest.mark.parametrize("little", ENDIAN)
@pytest.mark.parametrize("heading", [False, True])
def test_pose_and_odometry_read(little: bool, heading: bool) -> None:
    for msgtype in (POSE_STAMPED, ODOMETRY):
        read = _state_reader(POLYGON, msgtype, (), "/s", heading)
        for k, frame in enumerate(FRAMES):
            if msgtype == POSE_STAMPED:
                msg = T[POSE_STAMPED](header=_header(frame), pose=_pose(k))
            else:
                msg = T[ODOMETRY](
                    header=_header(frame),
                    child_frame_id=FRAMES[-1 - k],
                    pose=T["geometry_msgs/msg/PoseWithCovariance"](
                        pose=_pose(k), covariance=np.arange(36.0)
                    ),
                    twist=T["geometry_msgs/msg/TwistWithCovariance"](
                        twist=_twist(k), covariance=np.zeros(36)
                    ),
                )
            got = read(_encode(msg, msgtype, little))
            want = [1.0 + k, 2.0 - k]
            if heading:  # yaw of (0, 0, 0.3, 0.954): 2 asin(0.3)
                want.append(2 * np.arcsin(0.3))
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
            assert got[:2].tolist() == [1.0 + k, 2.0 - k]


@pytest.mark.parametrize("little", ENDIAN)
def test_joint_state_and_jog(little: bool) -> None:
    joints = ("a", "b", "c")
    read_state = _state_reader(JOINTS, JOINT_STATE, joints, "/js", False)
    codec = _joint_codec(JOINTS, JOINT_JOG, joints, "/jog")
    for frame in FRAMES:
        js = T[JOINT_STATE](
            header=_header(frame),
            name=["gripper", "c", "a", "b"],
            position=np.array([9.0, 0.3, 0.1, 0.2]),
            velocity=np.zeros(4),
            effort=np.zeros(0),
        )
        np.testing.assert_array_equal(read_state(_encode(js, JOINT_STATE, little)), [0.1, 0.2, 0.3])
        jog = T[JOINT_JOG](
            header=_header(frame),
            joint_names=["c", "a", "b"],
            displacements=np.zeros(0),
            velocities=np.array([3.0, 1.0, 2.0]),
            duration=0.25,
        )
        raw = _encode(jog, JOINT_JOG, little)
        v, token = codec.read(raw)
        np.testing.assert_array_equal(v, [1.0, 2.0, 3.0])
        out = _decode(codec.write(raw, token, np.array([-1.0, -2.0, -3.0]), None), JOINT_JOG)
        assert out.joint_names == ["c", "a", "b"]
        np.testing.assert_array_equal(out.velocities, [-3.0, -1.0, -2.0])
        assert out.duration == 0.25
        assert out.header.frame_id == frame
        zero = _decode(codec.write(raw, token, None, None), JOINT_JOG)
        np.testing.assert_array_equal(zero.velocities, [0.0, 0.0, 0.0])
        with_displacements = T[JOINT_JOG](
            header=_header(frame),
            joint_names=["c", "a", "b"],
            displacements=np.ones(3),
            velocities=np.zeros(0),
            duration=0.0,
        )
        with pytest.raises(InvalidParameter, match="topic /jog: expected a JointJog"):
            codec.read(_encode(with_displacements, JOINT_JOG, little))
    # The readers remember each list of names they met: a new order is read anew.
    for names in (["b", "c", "a"], ["c", "a", "b"], ["a", "b", "c", "gripper"]):
        js = T[JOINT_STATE](
            header=_header("x"),
            name=names,
            position=np.array([{"a": 0.1, "b": 0.2, "c": 0.3, "gripper": 9.0}[n] for n in names]),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )
        np.testing.assert_array_equal(read_state(_encode(js, JOINT_STATE, little)), [0.1, 0.2, 0.3])
    short = T[JOINT_STATE](
        header=_header("x"),
        name=["a", "c"],
        position=np.zeros(2),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    with pytest.raises(InvalidParameter, match=r"topic /js: expected a JointState.*\['a', 'c'\]"):
        read_state(_encode(short, JOINT_STATE, little))


@pytest.mark.parametrize("little", ENDIAN)
def test_float64_multiarray_with_layout(little: bool) -> None:
    codec = _joint_codec(JOINTS, FLOAT_ARRAY, ("a", "b", "c"), "/vel")
    for label in FRAMES:
        dim = T["std_msgs/msg/MultiArrayDimension"](label=label, size=3, stride=3)
        layout = T["std_msgs/msg/MultiArrayLayout"](dim=[dim, dim], data_offset=1)
        msg = T[FLOAT_ARRAY](layout=layout, data=np.array([0.5, 0.6, 0.7]))
        raw = _encode(msg, FLOAT_ARRAY, little)
        v, token = codec.read(raw)
        np.testing.assert_array_equal(v, [0.5, 0.6, 0.7])
        out = _decode(codec.write(raw, token, np.array([1.5, 1.6, 1.7]), None), FLOAT_ARRAY)
        np.testing.assert_array_equal(out.data, [1.5, 1.6, 1.7])
        assert out.layout.data_offset == 1
        assert [d.label for d in out.layout.dim] == [label, label]


def test_short_and_foreign_bytes_are_refused() -> None:
    raw = _encode(T[TWIST_STAMPED](header=_header("odom"), twist=_twist(1)), TWIST_STAMPED, True)
    codec = _twist_codec(POLYGON, TWIST_STAMPED)
    for cut in (0, 3, 4, 10, 20, len(raw) - 1):
        with pytest.raises(CdrError):
            codec.read(raw[:cut])
    with pytest.raises(CdrError, match="encapsulation"):
        CdrReader(b"\x00\x02\x00\x00" + raw[4:])  # a PL_CDR (XCDR2) header: not ours
    huge = bytearray(raw)
    huge[12:16] = (2**31).to_bytes(4, "little")  # a frame_id length past the end
    with pytest.raises(CdrError, match="ends inside a string"):
        codec.read(bytes(huge))
