"""Range sensors in the bridge: the ``sensors`` settings, and a cloud on DDS shaping the arm.

The loopback test publishes (from its own process, encoded by rosbags) a PointCloud2 of a ball
in front of a Panda's TCP, in a camera frame that ``/tf_static`` places in the base frame; the
bridge, commanded to move the TCP into the ball, slows it down, as the same filter with the
ball's points given in the base frame by hand does.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pytest
from setups import RELIABLE_DEEP

from conftest import DOMAIN, run_client
from velfence.bridge import parse_bridge_config
from velfence.errors import InvalidParameter
from velfence.io.shaper_config import SensorTopic, parse_shaper

PANDA = {"kind": "safety_filter", "robot": "panda", "max_speed": 2.0, "dt": 0.004}
CLOUD = {"topic": "points", "type": "point_cloud2", "buffer": 0.1, "max_age": 1.0}


def test_sensor_settings_are_checked() -> None:
    poly = {"kind": "polygon", "corners": [[0, 0], [1, 0], [1, 1]], "buffer": 0.1}
    doc = {"bridge": {"domain_id": DOMAIN, "sensors": [CLOUD]}, "shaper": poly}
    with pytest.raises(InvalidParameter, match=r"bridge\.sensors.*safety filter"):
        parse_bridge_config(doc)
    for bad, words in (
        ({**CLOUD, "type": "depth_image"}, "type"),
        ({**CLOUD, "voxel": 0.0}, "voxel"),
        ({**CLOUD, "max_age": math.inf}, "max_age"),
        ({**CLOUD, "topic": "no spaces"}, "topic"),
        ({**CLOUD, "extra": 1}, "extra"),
    ):
        doc = {"bridge": {"domain_id": DOMAIN, "sensors": [bad]}, "shaper": poly}
        with pytest.raises(InvalidParameter, match=words):
            parse_bridge_config(doc)
    with pytest.raises(InvalidParameter, match="sensors"):
        parse_shaper(poly, sensors=[SensorTopic(topic="/p", type="laser_scan")])
    with pytest.raises(InvalidParameter, match="sensors"):
        parse_shaper(poly, sensors="points")  # type: ignore[arg-type]


@pytest.mark.slow
def test_a_cloud_on_dds_shapes_the_command(bridge, tmp_path) -> None:
    pytest.importorskip("mujoco")
    names = [f"fr3_joint{i}" for i in range(1, 8)]
    b = bridge(
        {
            "command_in": {"topic": "cmd_in", "type": "twist", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "cmd_out", "type": "float64_multi_array",
                            "qos": RELIABLE_DEEP},
            "state": {"topic": "joints", "type": "joint_state", "qos": "default",
                      "joint_names": names},
            "tf": {"topic": "tf", "static_topic": "tf_static"},
            "sensors": [{**CLOUD, "base_frame": "base_link"}],
            "diagnostics": {"enabled": False},
        },
        PANDA,
    )  # fmt: skip
    robot = b.config.shaper.shaper.filter.robot
    q = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
    rng = np.random.default_rng(3)
    d = rng.normal(size=(300, 3))
    ball = robot.fk(q) + [0.11, 0.0, 0.0] + 0.04 * d / np.linalg.norm(d, axis=1)[:, None]
    # the camera: turned 90° about z and moved, in the base frame (tf_static)
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    shift = np.array([0.3, -0.2, 0.5])
    in_camera = (ball - shift) @ yaw  # R^T (p - t), row by row
    s2 = 0.5**0.5
    cmds = [{"values": [0.2, 0.0, 0.0]} for _ in range(30)]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("cmd_in"),
                "cmd_out": b.topic("cmd_out"),
                "state": b.topic("joints"),
                "tf_static": b.topic("tf_static"),
                "cloud": b.topic("points"),
            },
            "cmd_type": "twist",
            "out_type": "float64_multi_array",
            "state": {"type": "joint_state", "names": names, "values": q.tolist()},
            "tf_static": [
                {"parent": "base_link", "child": "camera", "xyzw": [0, 0, s2, s2],
                 "xyz": shift.tolist()}
            ],
            "cloud": {"frame": "camera", "points": in_camera.tolist()},
            "state_period": 0.02,
            "commands": cmds,
            "rate_hz": 50.0,
        },
        tmp_path,
        bridge=b,
    )  # fmt: skip
    c = b.node.counters
    assert c["clouds_used"] >= 5, c
    assert c["dropped_clouds"] == 0, c
    outs = [np.array(o["v"]) for o in res["outputs"]]
    assert len(outs) >= 25
    J = robot.jacobian(q)
    # the same filter fed the ball in the base frame by hand
    sensor = SensorTopic(**{**CLOUD, "topic": "/points"})
    ref = parse_shaper(PANDA, sensors=[sensor])
    ref.clouds[0].update(ball, stamp=0.0)
    want = ref.shaper.shape(q, np.array([0.2, 0.0, 0.0]))
    free = parse_shaper(PANDA).shaper.shape(q, np.array([0.2, 0.0, 0.0]))
    assert (J @ free)[0] == pytest.approx(0.2, abs=1e-3)  # nothing in the way: unchanged
    assert (J @ want)[0] < 0.17  # the ball slows the TCP down
    late = outs[-5:]  # the cloud arrived long before these
    for y in late:
        np.testing.assert_allclose(J @ y, J @ want, atol=2e-3)


@functools.cache
def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_JAZZY)


def _cloud_cdr(frame: str, stamp: float, pts: np.ndarray, *, truncate: int = 0) -> bytes:
    """A PointCloud2 (x, y, z FLOAT32) encoded by rosbags' typestore."""
    ts = _typestore()
    T = ts.types
    ns = round(stamp * 1e9)
    msg = T["sensor_msgs/msg/PointCloud2"](
        header=T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
            frame_id=frame,
        ),
        height=1,
        width=len(pts),
        fields=[
            T["sensor_msgs/msg/PointField"](name=n, offset=o, datatype=7, count=1)
            for n, o in (("x", 0), ("y", 4), ("z", 8))
        ],
        is_bigendian=False,
        point_step=12,
        row_step=12 * len(pts),
        data=np.frombuffer(np.asarray(pts, dtype="<f4").tobytes(), dtype=np.uint8),
        is_dense=True,
    )
    raw = bytes(ts.serialize_cdr(msg, "sensor_msgs/msg/PointCloud2"))
    return raw[: len(raw) - truncate]


@pytest.mark.slow  # the Panda's model loads in about 3 s
def test_stale_unknown_frame_and_malformed_clouds_are_dropped_and_counted(bridge_log) -> None:
    """The node's handling of one sensor message, without DDS: counted by reason, warned once."""
    import time

    from velfence.bridge import BridgeNode

    pytest.importorskip("mujoco")
    doc = {
        "bridge": {
            "domain_id": DOMAIN,
            "command_in": {"type": "float64_multi_array"},
            "state": {"type": "joint_state"},
            "sensors": [{**CLOUD, "base_frame": "base_link"}],
        },
        "shaper": {**PANDA, "mode": "joint"},
    }
    node = BridgeNode(parse_bridge_config(doc))
    x, rows = node._sensors[0], node._clouds[0]
    pts = np.array([[0.5, 0.0, 0.5], [np.nan, 0.0, 0.0]])
    node._tf.set("base_link", "camera", [0, 0, 0, 1], [0.0, 0.0, 0.25])
    _typestore()  # built before the first stamp
    fresh = time.time  # each message stamped as it is made (max_age 1 s, decay 0.5 s)
    node._use_cloud(x, rows, _cloud_cdr("camera", fresh(), pts))  # used, moved up by 0.25 m
    node._use_cloud(x, rows, _cloud_cdr("", fresh(), pts))  # no frame: the base frame
    for _ in range(3):
        node._use_cloud(x, rows, _cloud_cdr("camera", fresh() - 5.0, pts))  # stale
        node._use_cloud(x, rows, _cloud_cdr("nowhere", fresh(), pts))  # no transform
        node._use_cloud(x, rows, _cloud_cdr("camera", fresh(), pts, truncate=5))  # malformed
    c = node.counters
    assert c["clouds_used"] == 2
    assert c["cloud_readings_dropped"] == 2
    assert c["dropped_clouds"] == 9
    for reason in ("stale", "frame_unknown", "malformed"):
        assert c[f"dropped:cloud_{reason}"] == 3
        warned = [r for r in bridge_log.records if f"dropped:cloud_{reason}" in r.getMessage()]
        assert len(warned) == 1  # throttled: one line per reason within 10 s
    want = {
        (0.51, 0.01, 0.75),
        (0.51, 0.01, 0.51),
    }  # voxel centres of (0.5, 0, 0.75), (0.5, 0, 0.5)
    got = {tuple(np.round(c, 2)) for c in rows.centres}
    assert got == want
