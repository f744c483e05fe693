"""Replay with range sensors: a bag's PointCloud2 and LaserScan topics feed the safety filter.

The bag (written by rosbags' writer) holds a Panda's joint state, a camera placed in the base
frame by ``/tf_static``, a cloud of a ball in front of the TCP in the camera's frame, a stale
cloud, a cloud in a frame no transform reaches, and a laser scan; the TCP commands before the
cloud, right after it and after the cloud's voxels decayed are shaped as the same filter fed
the ball by hand shapes them, and the summary counts the clouds used and dropped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("rosbags")
pytest.importorskip("mujoco")

from velfence.errors import InvalidParameter
from velfence.io import parse_shaper, replay
from velfence.io.bags import message_typestore
from velfence.io.shaper_config import SensorTopic

NS = 1_000_000_000
TS = message_typestore("humble")
T = TS.types
PANDA = {"kind": "safety_filter", "robot": "panda", "max_speed": 2.0, "dt": 0.004}
CLOUD = {"topic": "/points", "type": "point_cloud2", "buffer": 0.1, "max_age": 0.5}
SCAN = {"topic": "/scan", "type": "laser_scan", "max_age": 0.5}
Q = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])


def _header(t: float, frame: str) -> Any:
    ns = round(t * NS)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=ns // NS, nanosec=ns % NS), frame_id=frame
    )


def _cloud(t: float, frame: str, pts: np.ndarray) -> Any:
    data = np.asarray(pts, dtype="<f4").tobytes()
    return T["sensor_msgs/msg/PointCloud2"](
        header=_header(t, frame),
        height=1,
        width=len(pts),
        fields=[
            T["sensor_msgs/msg/PointField"](name=n, offset=o, datatype=7, count=1)
            for n, o in (("x", 0), ("y", 4), ("z", 8))
        ],
        is_bigendian=False,
        point_step=12,
        row_step=12 * len(pts),
        data=np.frombuffer(data, dtype=np.uint8),
        is_dense=True,
    )


def _write(path: Path, topics: dict[str, tuple[str, list[tuple[float, Any]]]]) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for topic, (msgtype, items) in topics.items():
            conn = w.add_connection(topic, msgtype, typestore=TS)
            for t, m in items:
                w.write(conn, round(t * NS), TS.serialize_cdr(m, msgtype))
    return path


def _shaped(out: Path, topic: str) -> list[np.ndarray]:
    from rosbags.highlevel import AnyReader

    with AnyReader([out], default_typestore=TS) as r:
        conns = [c for c in r.connections if c.topic == topic]
        return [
            np.array([m.linear.x, m.linear.y, m.linear.z])
            for m in (r.deserialize(raw, c.msgtype) for c, _, raw in r.messages(conns))
        ]


def _bag(tmp_path: Path, names: list[str], ball: np.ndarray) -> Path:
    s2 = 0.5**0.5
    shift = np.array([0.3, -0.2, 0.5])
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    in_camera = (ball - shift) @ yaw  # R^T (p - t), row by row
    js = T["sensor_msgs/msg/JointState"](
        header=_header(0.0, ""),
        name=names,
        position=Q.copy(),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    V = T["geometry_msgs/msg/Vector3"]
    tf = T["tf2_msgs/msg/TFMessage"](
        transforms=[
            T["geometry_msgs/msg/TransformStamped"](
                header=_header(0.0, "base_link"),
                child_frame_id="camera",
                transform=T["geometry_msgs/msg/Transform"](
                    translation=V(x=shift[0], y=shift[1], z=shift[2]),
                    rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=s2, w=s2),
                ),
            )
        ]
    )
    cmd = T["geometry_msgs/msg/Twist"](linear=V(x=0.2, y=0.0, z=0.0), angular=V(x=0, y=0, z=0))
    scan = T["sensor_msgs/msg/LaserScan"](
        header=_header(0.7, "base_link"),
        angle_min=0.0,
        angle_max=0.2,
        angle_increment=0.1,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.1,
        range_max=5.0,
        ranges=np.array([3.0, np.nan, np.inf], dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )
    return _write(
        tmp_path / "in",
        {
            "/js": ("sensor_msgs/msg/JointState", [(0.0, js)]),
            "/tf_static": ("tf2_msgs/msg/TFMessage", [(0.0, tf)]),
            "/points": (
                "sensor_msgs/msg/PointCloud2",
                [
                    (0.5, _cloud(0.45, "camera", in_camera)),  # 50 ms old: used
                    (1.0, _cloud(0.2, "camera", in_camera)),  # 0.8 s old: stale
                    (1.1, _cloud(1.1, "nowhere", in_camera)),  # no transform: dropped
                ],
            ),
            "/scan": ("sensor_msgs/msg/LaserScan", [(0.7, scan)]),
            "/cmd": ("geometry_msgs/msg/Twist", [(0.2, cmd), (0.6, cmd), (2.0, cmd)]),
        },
    )


@pytest.mark.slow
def test_clouds_in_a_bag_shape_the_replayed_commands(tmp_path: Path) -> None:
    free = parse_shaper(PANDA)
    names = list(free.joint_names or ())
    robot = free.shaper.filter.robot
    rng = np.random.default_rng(4)
    d = rng.normal(size=(300, 3))
    ball = robot.fk(Q) + [0.11, 0.0, 0.0] + 0.04 * d / np.linalg.norm(d, axis=1)[:, None]
    bag = _bag(tmp_path, names, ball)
    cfg = {
        "shaper": PANDA,
        "replay": {"command_topic": "/cmd", "state_topic": "/js", "sensors": [CLOUD, SCAN]},
    }
    s = replay(bag, cfg, tmp_path / "out")
    assert s.clouds_used == 2
    assert dict(s.clouds_dropped) == {"stale": 1, "frame_unknown": 1}
    assert s.cloud_readings_dropped == 2  # the scan's NaN and inf
    out = _shaped(tmp_path / "out", "/cmd_shaped")
    assert len(out) == 3
    J = robot.jacobian(Q)
    v = np.array([0.2, 0.0, 0.0])
    ref = parse_shaper(PANDA, sensors=[SensorTopic(**CLOUD)])
    ref.clouds[0].update(ball, stamp=0.0)
    slowed = J @ ref.shaper.shape(Q, v)
    unshaped = J @ free.shaper.shape(Q, v)
    assert unshaped[0] == pytest.approx(0.2, abs=1e-3)
    assert slowed[0] < 0.17
    np.testing.assert_allclose(out[0], unshaped, atol=1e-6)  # before the cloud
    np.testing.assert_allclose(out[1], slowed, atol=2e-3)  # the ball in the way
    np.testing.assert_allclose(out[2], unshaped, atol=2e-3)  # its voxels decayed (0.5 s)


def test_sensor_topics_are_checked_against_the_bag(tmp_path: Path) -> None:
    free = parse_shaper(PANDA)
    bag = _bag(tmp_path, list(free.joint_names or ()), np.zeros((3, 3)))
    for sensors, words in (
        ([{**CLOUD, "topic": "/missing"}], "not in bag"),
        ([{**CLOUD, "type": "laser_scan"}], "expected sensor_msgs/msg/LaserScan"),
        ([CLOUD, CLOUD], "distinct"),
        ([{**CLOUD, "topic": "/cmd"}], "distinct"),
    ):
        cfg = {
            "shaper": PANDA,
            "replay": {"command_topic": "/cmd", "state_topic": "/js", "sensors": sensors},
        }
        with pytest.raises(InvalidParameter, match=words):
            replay(bag, cfg, tmp_path / "never")
    poly = {"kind": "polygon", "corners": [[0, 0], [1, 0], [1, 1]], "buffer": 0.1}
    cfg = {"shaper": poly, "replay": {"command_topic": "/a", "state_topic": "/b",
                                      "sensors": [CLOUD]}}  # fmt: skip
    with pytest.raises(InvalidParameter, match="sensors"):
        replay(bag, cfg, tmp_path / "never")
