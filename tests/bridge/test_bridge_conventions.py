"""ROS conventions of the bridge against a ROS 2 peer in another process (ros_client.py).

Checked on the wire: halting as MoveIt Servo did (``halt_messages`` zeros once commands go
stale, then silence until they resume); publishing on the node's own timer (``publish_period``),
each period the last command shaped against the newest state.
"""

from __future__ import annotations

import numpy as np
import pytest
from setups import POLYGON, RELIABLE_DEEP
from setups import plane_bridge as _plane
from setups import plane_topics as _topics

from conftest import run_client
from velfence.io.shaper_config import parse_shaper


def test_halt_publishes_exactly_n_zeros_then_nothing(bridge, tmp_path) -> None:
    b = _plane(bridge, incoming_command_timeout=0.1, watchdog_period=0.05, halt_messages=3)
    n = 10
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [2.0, 1.5, 0.0]},
            "commands": [{"values": [0.3, -0.2, 0.0]}] * n,
            "rate_hz": 100.0,
            "pause_after": [5, 0.6],  # 0.5 s stale: room for 10 zeros at 0.05 s, 3 are sent
            "expect": n,
            "tail": 0.6,
        },
        tmp_path,
        bridge=b,
    )
    outs = res["outputs"]
    assert len(res["sent"]) == n
    answers = [o for o in outs if o["i"] < n]
    zeros = [o for o in outs if o["i"] >= n]  # stamped with the time, not an index
    assert [o["i"] for o in answers] == list(range(n))
    assert all(o["v"] == [0.0] * 6 for o in zeros)
    # Zeros grouped by the answer before them: each stale episode ends in at most 3 zeros (a
    # loaded machine may stall the peer past the timeout mid-burst: a shorter episode), the
    # pause and the end in exactly 3, then nothing.
    groups: dict[int, int] = {}
    last = -1
    for o in outs:
        if o["i"] < n:
            last = o["i"]
        else:
            groups[last] = groups.get(last, 0) + 1
    assert all(k <= 3 for k in groups.values()), groups
    assert groups[4] == 3, groups  # the pause after command 4
    assert groups[n - 1] == 3, groups  # after the last command, silence after 3
    c = b.node.counters
    assert c["watchdog_zeros"] == len(zeros)
    assert c["outputs_published"] == n + len(zeros)


def test_timer_publishes_every_period_against_the_newest_state(bridge, tmp_path) -> None:
    period = 0.02
    b = _plane(bridge, publish_period=period, incoming_command_timeout=0.5, halt_messages=2)
    p1, p2 = np.array([2.0, 1.5]), np.array([3.8, 1.5])  # the middle; then 0.2 m from x = 4
    c = np.array([0.6, 0.1])  # toward x = 4: unchanged in the middle, braked near the edge
    n = 8
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [*p1, 0.0]},
            "state_switch": {"after": 4, "values": [*p2, 0.0]},
            "commands": [{"values": [*c, 0.0]}] * n,
            "rate_hz": 5.0,  # a command every 0.2 s; the timer answers every 0.02 s
            "expect": 1,  # then the tail decides how long it listens
            "tail": 1.2,  # past the timeout: the halt (2 zeros), then silence
        },
        tmp_path,
        bridge=b,
    )
    sent, outs = res["sent"], res["outputs"]
    ref = parse_shaper(POLYGON).shaper
    free, braked = list(ref.shape(p1, c)), list(ref.shape(p2, c))
    assert free == list(c)  # the two states really differ for c
    assert braked[0] < 0.6
    moving = [o for o in outs if any(o["v"])]
    vals = [o["v"][:2] for o in moving]
    assert set(map(tuple, vals)) == {tuple(free), tuple(braked)}
    # Every period the newest state: once braked appears, the free answer never comes back,
    # and most braked answers come from re-shaping the same command, between commands.
    first_braked = vals.index(braked)
    assert all(v == braked for v in vals[first_braked:])
    # The period is honoured: about span / period messages while commands were fresh (a loaded
    # machine may delay some; none may come faster than the timer allows).
    span = moving[-1]["t"] - moving[0]["t"]
    count = len(moving)
    assert count <= span / period + 3
    assert count >= 0.6 * span / period, (count, span)
    assert span > sent[-1] - sent[0]  # answers went on after the last command...
    assert moving[-1]["t"] < sent[-1] + 0.5 + 0.25  # ...until it went stale (0.5 s)
    zeros = [o for o in outs if not any(o["v"])]
    assert len(zeros) == 2  # the halt on the timer, then silence
    assert all(z["t"] > moving[-1]["t"] for z in zeros)


def test_convention_fields_defaults_and_refusals() -> None:
    from velfence.bridge import parse_bridge_config
    from velfence.errors import InvalidParameter

    plane = {
        "command_in": {"type": "twist_stamped"},
        "state": {"type": "odometry"},
        "command_frame": "body",
    }

    def parse(section):  # type: ignore[no-untyped-def]
        return parse_bridge_config({"bridge": section, "shaper": POLYGON}, source="t.yaml")

    s = parse(plane).settings
    assert s.publish_period is None  # one answer per command
    assert s.halt_messages == 4  # MoveIt Servo's num_outgoing_halt_msgs_to_publish default
    assert s.command_frame_id is None
    assert (s.tf.topic, s.tf.static_topic) == ("/tf", "/tf_static")
    assert s.tf.static_qos.durability == "transient_local"
    assert parse({**plane, "halt_messages": None}).settings.halt_messages is None
    assert parse({**plane, "publish_period": 0.01}).settings.publish_period == 0.01
    bad = [
        ({**plane, "publish_period": 0}, "bridge.publish_period"),
        ({**plane, "publish_period": "0.01"}, "bridge.publish_period"),
        ({**plane, "halt_messages": 0}, "bridge.halt_messages"),
        ({**plane, "halt_messages": 2.0}, "bridge.halt_messages"),
        ({**plane, "command_frame_id": ""}, "bridge.command_frame_id"),
        ({**plane, "tf": {"topic": "t f"}}, "bridge.tf.topic"),
        (
            {**plane, "command_in": {"type": "twist"}, "command_frame_id": "odom"},
            "bridge.command_frame_id: only a twist_stamped",
        ),
    ]
    for section, named in bad:
        with pytest.raises(InvalidParameter, match=named):
            parse(section)


# ---------------------------------------------------------------- joint_trajectory_controller
#: float's epsilon (std::numeric_limits<float>::epsilon()), the controller's zero velocity.
FLT_EPSILON = float(np.finfo(np.float32).eps)


def jtc_violations(
    traj: dict, controller_joints: list[str], *, now_s: float, effort_interface: bool = False
) -> list[str]:
    """What ros2_control's JointTrajectoryController refuses in ``traj``, with default parameters.

    ``JointTrajectoryController::validate_trajectory_msg`` and
    ``validate_trajectory_point_field`` of ros2_controllers 6.9.0 (commit 94e74de35f9d), with the
    parameters' defaults: ``allow_partial_joints_goal: false``,
    ``allow_nonzero_velocity_at_trajectory_end: false``,
    ``allow_integration_in_goal_trajectories: false``; ``effort_interface`` says whether
    ``command_interfaces`` holds ``effort``. Plus one rule of ours (the last line):
    ``time_from_start`` of the first point > 0, so the controller has a segment to interpolate.
    ``traj`` is a JointTrajectory decoded by rosbags (ros_client.trajectory_from_cdr).
    """
    v: list[str] = []
    names, points = traj["joint_names"], traj["points"]
    if len(names) != len(controller_joints):
        v.append("partial joints goal")
    if not names:
        v.append("empty joint names")
    if not points:
        v.append("empty trajectory")
        return v
    v += [f"joint {n} not the controller's" for n in names if n not in controller_joints]
    last = points[-1]
    if any(abs(x) > FLT_EPSILON for x in last["velocities"]):
        v.append("velocity of the last point not zero")

    def seconds(d: list[int]) -> float:
        return d[0] + d[1] * 1e-9

    start = seconds(traj["stamp"])
    if start != 0.0 and start + seconds(last["time_from_start"]) < now_s:
        v.append("non-zero start time and ends in the past")
    previous = 0.0
    for i, p in enumerate(points):
        t = seconds(p["time_from_start"])
        if i > 0 and t <= previous:
            v.append(f"time not strictly increasing at point {i}")
        previous = t
        if len(p["positions"]) != len(names):
            v.append(f"positions size at point {i}")
        for field in ("velocities", "accelerations"):
            if p[field] and len(p[field]) != len(names):
                v.append(f"{field} size at point {i}")
        if p["effort"] and not effort_interface:
            v.append(f"effort without an effort command interface at point {i}")
    if seconds(points[0]["time_from_start"]) <= 0.0:
        v.append("time_from_start of the first point not > 0")
    return v


def test_the_trajectory_rules_can_fail() -> None:
    ok = {
        "stamp": [0, 0],
        "frame_id": "",
        "joint_names": ["a", "b"],
        "points": [
            {
                "positions": [0.1, 0.2],
                "velocities": [0.0, 0.0],
                "accelerations": [],
                "effort": [],
                "time_from_start": [0, 100_000_000],
            }
        ],
    }
    assert jtc_violations(ok, ["a", "b"], now_s=1e9) == []
    # The bridge's former output: velocities only, moving at the end.
    old = {**ok, "points": [{**ok["points"][0], "positions": [], "velocities": [0.5, 0.0]}]}
    assert jtc_violations(old, ["a", "b"], now_s=1e9) == [
        "velocity of the last point not zero",
        "positions size at point 0",
    ]
    assert jtc_violations({**ok, "stamp": [5, 0]}, ["a", "b"], now_s=6.0) == [
        "non-zero start time and ends in the past"
    ]
    assert jtc_violations(ok, ["a", "b", "c"], now_s=0.0) == ["partial joints goal"]
    assert "joint b not the controller's" in jtc_violations(ok, ["a", "x"], now_s=0.0)
    two = {**ok, "points": [ok["points"][0], ok["points"][0]]}
    assert jtc_violations(two, ["a", "b"], now_s=0.0) == ["time not strictly increasing at point 1"]
    eff = {**ok, "points": [{**ok["points"][0], "effort": [1.0, 1.0]}]}
    assert jtc_violations(eff, ["a", "b"], now_s=0.0) == [
        "effort without an effort command interface at point 0"
    ]


def test_joint_trajectory_output_passes_the_controllers_rules(bridge, tmp_path) -> None:
    joints = {
        "kind": "joint_limits",
        "joint_names": ["j1", "j2", "j3"],
        "lower": [-1.0, -2.0, -1.5],
        "upper": [1.0, 2.0, 1.5],
        "buffer": 0.2,
    }
    wire = ["fr3_joint1", "fr3_joint2", "fr3_joint3"]  # the controller's joints
    b = bridge(
        {
            "command_in": {"topic": "jog", "type": "joint_jog", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "traj", "type": "joint_trajectory", "qos": RELIABLE_DEEP},
            "state": {
                "topic": "joint_states",
                "type": "joint_state",
                "qos": "default",
                "joint_names": wire,
            },
            "incoming_command_timeout": 0.1,
            "halt_messages": 2,
        },
        joints,
    )
    q = np.array([0.0, 1.9, -0.5])  # j2 near its upper limit: a jog toward it is braked
    cmds = [{"names": ["fr3_joint2"], "values": [1.0]}, {"names": wire, "values": [0.3, 0.2, -0.4]}]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("jog"),
                "cmd_out": b.topic("traj"),
                "state": b.topic("joint_states"),
            },
            "cmd_type": "joint_jog",
            "out_type": "joint_trajectory",
            "state": {"type": "joint_state", "names": wire[::-1], "values": list(q[::-1])},
            "commands": cmds,
            "rate_hz": 50.0,
            "expect": 4,  # two answers, then (at least) the halt's two holds
            "tail": 0.4,
        },
        tmp_path,
        bridge=b,
    )
    import time

    trajs = [o["traj"] for o in res["outputs"]]
    # Two answers (moving), each stale episode ends in at most two holds of the measured
    # position (a loaded machine may stall the peer past the timeout between the commands).
    moving = [tr for tr in trajs if tr["points"][0]["positions"] != list(q)]
    holds = [tr for tr in trajs if tr["points"][0]["positions"] == list(q)]
    assert len(moving) == 2, trajs
    assert 2 <= len(holds) <= 4, trajs
    for tr in trajs:
        assert jtc_violations(tr, wire, now_s=time.time()) == [], tr
        assert tr["joint_names"] == wire  # as configured, every joint
        assert tr["stamp"] == [0, 0]  # start now
        (point,) = tr["points"]
        assert point["time_from_start"] == [0, 100_000_000]  # incoming_command_timeout
        assert point["velocities"] == [0.0, 0.0, 0.0]
    ref = parse_shaper(joints).shaper
    want = [ref.shape(q, np.array([0.0, 1.0, 0.0])), ref.shape(q, np.array([0.3, 0.2, -0.4]))]
    assert want[0][1] < 1.0  # braked near the limit
    for tr, w in zip(moving, want, strict=True):
        np.testing.assert_allclose(tr["points"][0]["positions"], q + 0.1 * w, rtol=0, atol=1e-15)
    assert trajs[-1] in holds  # the last: a hold


# ---------------------------------------------------------------- command frames through /tf
def test_command_frames_resolved_through_tf(bridge, tmp_path) -> None:
    # The shaper works in odom; base_link is turned 90° (yaw) in odom by a static transform,
    # and a camera frame hangs under base_link on /tf (turned 90° about its x axis).
    b = _plane(
        bridge,
        command_frame_id="odom",
        tf={"topic": "tf", "static_topic": "tf_static"},  # namespaced: this test's own
    )
    s2 = 0.5**0.5
    p = np.array([2.0, 2.8])  # 0.2 m below the top edge y = 3: +y (odom) is braked
    cmds = [
        {"values": [1.0, 0.0, 0.0], "frame_id": "base_link"},  # base x = odom +y: braked
        {"values": [0.0, 1.0, 0.0], "frame_id": "odom"},  # odom +y: braked
        {"values": [1.0, 0.0, 0.0], "frame_id": ""},  # no frame: odom's, along the edge
        {"values": [0.5, 0.0, 0.0], "frame_id": "nowhere"},  # no transform: refused
        {"values": [0.0, 0.0, 1.0], "frame_id": "camera"},  # camera z = base -y = odom +x
    ]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {**_topics(b), "tf": b.topic("tf"), "tf_static": b.topic("tf_static")},
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [*p, 0.0]},
            "tf_static": [{"parent": "odom", "child": "base_link", "xyzw": [0, 0, s2, s2]}],
            "tf": [{"parent": "base_link", "child": "camera", "xyzw": [s2, 0, 0, s2]}],
            "commands": cmds,
            "rate_hz": 20.0,
            "expect": 4,
            "tail": 0.1,
        },
        tmp_path,
        bridge=b,
    )
    outs = {o["i"]: o["v"] for o in res["outputs"] if o["i"] < len(cmds)}
    assert sorted(outs) == [0, 1, 2, 4]  # the command of unknown frame is not answered
    ref = parse_shaper(POLYGON).shaper
    # Rotations written out by hand: base_link -> odom is yaw +90°; camera -> base_link is
    # +90° about x (camera z = base -y).
    yaw = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    roll = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    for i, rot in ((0, yaw), (1, np.eye(3)), (2, np.eye(3)), (4, yaw @ roll)):
        v_odom = rot @ np.array(cmds[i]["values"])
        shaped = np.array([*ref.shape(p, v_odom[:2]), v_odom[2]])
        want = rot.T @ shaped  # answered in the command's own frame
        np.testing.assert_allclose(outs[i][:3], want, rtol=0, atol=1e-12, err_msg=str(i))
    assert outs[0][0] < 0.5  # braked, though base x looks sideways to the edge
    assert outs[2][:2] == [1.0, 0.0]  # along the edge: unchanged
    np.testing.assert_allclose(outs[4][:3], [0.0, 0.0, 1.0], atol=1e-12)  # odom +x: free
    c = b.node.counters
    assert c["dropped:command_frame_unknown"] == 1
    assert c["transforms_received"] >= 2
    assert c["dropped_transforms"] == 0
