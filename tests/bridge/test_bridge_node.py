"""The bridge node against a ROS 2 peer in another process (tests/bridge/ros_client.py).

Checked on the wire: a 1 kHz command stream is answered one-for-one on reliable QoS and every
answer equals ``shaper.shape(state, command)`` bit for bit; the watchdog sends zeros after the
timeout and the bridge recovers; malformed samples are dropped and counted, never answered; a
QoS mismatch is logged and reported on the diagnostics topic; every endpoint carries the RIHS01
type hash in its USER_DATA (read back through the builtin DCPSPublication/DCPSSubscription).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from setups import JOINTS, POLYGON, RELIABLE_DEEP
from setups import plane_bridge as _plane_bridge
from setups import plane_topics as _topics

from conftest import run_client
from velfence.bridge import msgs
from velfence.bridge.typehash import rihs01
from velfence.io.shaper_config import parse_shaper


def test_1khz_stream_answered_one_for_one_and_equal_to_shape(bridge, tmp_path) -> None:
    b = _plane_bridge(bridge)
    rng = np.random.default_rng(7)
    n = 3000
    cmds = rng.normal(scale=0.8, size=(n, 2))
    angular = rng.normal(size=(n, 3))
    p = np.array([0.3, 1.2])  # inside the buffer of the left edge: many commands are changed
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [*p, 0.0]},
            "commands": [
                {"values": [*c, 0.25], "angular": list(a)}
                for c, a in zip(cmds, angular, strict=True)
            ],
            "rate_hz": 1000.0,
            "depth": 5000,
            "expect_nonzero": True,  # answers carry linear.z = 0.25; a watchdog zero does not
        },
        tmp_path,
        bridge=b,
    )
    # A loaded machine can stall the sending process longer than the command timeout (0.1 s):
    # the bridge then rightly publishes a watchdog zero, stamped with the time rather than an
    # index. Those are checked to be zeros and set aside; every command must still be answered.
    outs = [o for o in res["outputs"] if o["i"] < n]
    zeros = [o for o in res["outputs"] if o["i"] >= n]
    assert all(o["v"] == [0.0] * 6 for o in zeros)
    assert len(res["sent"]) == n
    assert len(outs) == n, f"{n} commands sent, {len(outs)} answered"
    assert [o["i"] for o in outs] == list(range(n)), "answers out of order or duplicated"
    # An independent shaper built from the same section: the published values are its output.
    ref = parse_shaper(POLYGON).shaper
    got = np.array([o["v"] for o in outs])
    want = np.array([ref.shape(p, c) for c in cmds])
    assert np.array_equal(got[:, :2], want)  # bit-identical
    assert np.array_equal(got[:, 2], np.full(n, 0.25))  # linear.z passes through
    assert np.array_equal(got[:, 3:], angular)  # angular passes through
    changed = np.any(got[:, :2] != cmds, axis=1).sum()
    assert changed > n // 10  # the test does exercise the shaping
    c = b.node.counters
    assert c["commands_received"] == n
    assert c["commands_shaped"] == n
    assert c["commands_changed"] == changed
    assert c["dropped_commands"] == 0
    # The rate was really ~1 kHz: 3000 commands in about 3 s.
    span = res["sent"][-1] - res["sent"][0]
    assert 2.9 < span < 4.5, span


def test_watchdog_zeros_after_timeout_then_recovers(bridge, tmp_path, bridge_log) -> None:
    b = _plane_bridge(
        bridge,
        incoming_command_timeout=0.1,
        watchdog_period=0.05,
        state_timeout=0.5,
        halt_messages=None,  # zeros for as long as commands are stale (the default halts)
    )
    p = np.array([2.0, 1.5])  # the middle: commands pass unchanged
    cmds = [{"values": [0.3, -0.2, 0.0]} for _ in range(60)]
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [*p, 0.0]},
            "commands": cmds,
            "rate_hz": 100.0,
            "pause_after": [30, 0.6],
            "expect": 60,
            "tail": 0.35,
        },
        tmp_path,
        bridge=b,
    )
    outs = res["outputs"]
    sent = res["sent"]
    last_before, first_after = sent[29], sent[30]
    answers = [o for o in outs if o["i"] < len(cmds)]  # zeros carry the time as their stamp
    zeros = [o for o in outs if o["i"] >= len(cmds)]
    assert [o["i"] for o in answers] == list(range(60))  # every command answered, in order
    assert all(o["v"][:2] == [0.3, -0.2] for o in answers)  # unchanged in the middle
    assert all(o["v"] == [0.0] * 6 for o in zeros)
    pause_zeros = [o["t"] for o in zeros if last_before < o["t"] < first_after]
    # The first zero comes after the timeout (0.1 s), not before; then one every 0.05 s.
    assert pause_zeros, "no zero command during the pause"
    assert 0.1 <= pause_zeros[0] - last_before < 0.1 + 0.1
    gaps = np.diff(pause_zeros)
    assert len(pause_zeros) >= 6  # 0.5 s of staleness at 0.05 s
    assert np.median(gaps) == pytest.approx(0.05, abs=0.02)
    # Recovery: no zero while the second burst flows; zeros again once it has ended.
    burst = (answers[30]["t"], answers[59]["t"])
    assert not [o for o in zeros if burst[0] < o["t"] < burst[1]]
    assert [o for o in zeros if o["t"] > sent[-1] + 0.1]
    assert b.node.counters["watchdog_zeros"] >= len(pause_zeros)
    states = [r.getMessage() for r in bridge_log.records if "state:" in r.getMessage()]
    assert "state: running -> stale_command" in states
    assert "state: stale_command -> running" in states


def test_malformed_commands_dropped_and_counted(bridge, tmp_path) -> None:
    b = bridge(
        {
            "command_in": {"topic": "cmd", "type": "float64_multi_array", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "out", "type": "joint_trajectory", "qos": RELIABLE_DEEP},
            "state": {"topic": "joint_states", "type": "joint_state", "qos": "default"},
        },
        JOINTS,
    )
    good = [0.5, -0.25, 1.0]
    nan = math.nan
    items = [
        good,
        [0.5, 0.1],  # too short
        [nan, 0.0, 0.0],  # NaN
        good,
        [0.1, 0.2, 0.3, 0.4],  # too long
        [math.inf, 0.0, 0.0],  # inf
        good,
    ]
    q = [0.9, 0.0, -1.45]  # j1 near its upper limit, j3 near its lower limit
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("cmd"),
                "cmd_out": b.topic("out"),
                "state": b.topic("joint_states"),
            },
            "cmd_type": "float64_multi_array",
            "out_type": "joint_trajectory",
            # Names in another order than the shaper's, plus an unrelated joint.
            "state": {
                "type": "joint_state",
                "names": ["j3", "gripper", "j1", "j2"],
                "values": [q[2], 0.04, q[0], q[1]],
            },
            "commands": [{"values": v} for v in items],
            "rate_hz": 200.0,
            "expect": 3,
            "expect_nonzero": True,
            "tail": 0.2,
        },
        tmp_path,
        bridge=b,
    )
    # The node may still be taking the last samples when the peer leaves: wait (with a deadline)
    # until it has counted every command the peer sent.
    deadline = time.monotonic() + 10.0
    while b.node.counters["commands_received"] < len(items) and time.monotonic() < deadline:
        time.sleep(0.01)
    # The answers are the trajectories that move (the halt's hold the measured position). The
    # trajectory's point is the measured position plus velocity x incoming_command_timeout.
    outs = [o for o in res["outputs"] if o["traj"]["points"][0]["positions"] != q]
    assert len(outs) == 3, b.node.counters  # only the good ones answered
    want = parse_shaper(JOINTS).shaper.shape(np.array(q), np.array(good))
    for o in outs:
        pos = np.array(o["traj"]["points"][0]["positions"])
        np.testing.assert_allclose(pos, np.array(q) + 0.1 * want, rtol=0, atol=1e-15)
        assert all(math.isfinite(x) for x in pos)
    c = b.node.counters
    assert c["dropped_commands"] == 4
    assert c["dropped:command_wrong_length"] == 2
    assert c["dropped:command_nonfinite"] == 2


def test_joint_jog_subset_and_missing_state_joint(bridge, tmp_path) -> None:
    b = bridge(
        {
            "command_in": {"topic": "jog", "type": "joint_jog", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "out", "type": "same", "qos": RELIABLE_DEEP},
            "state": {"topic": "joint_states", "type": "joint_state", "qos": "default"},
            "state_timeout": 0.3,
        },
        JOINTS,
    )
    q = [0.0, 1.9, 0.0]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("jog"),
                "cmd_out": b.topic("out"),
                "state": b.topic("joint_states"),
            },
            "cmd_type": "joint_jog",
            "out_type": "joint_jog",
            "state": {"type": "joint_state", "names": ["j1", "j2", "j3"], "values": q},
            "commands": [
                {"names": ["j2"], "values": [1.0]},  # a subset: j1, j3 commanded zero
                {"names": ["j3", "j1"], "values": [0.2, -0.1]},
                {"names": ["elbow"], "values": [0.5]},  # unknown joint: dropped
                {"names": ["j1", "j1"], "values": [0.5, 0.5]},  # duplicate: dropped
            ],
            "rate_hz": 100.0,
            "expect": 2,
            "tail": 0.2,
        },
        tmp_path,
        bridge=b,
    )
    outs = [o for o in res["outputs"] if o["i"] < 4]  # not the watchdog's zeros
    assert [o["i"] for o in outs] == [0, 1]
    ref = parse_shaper(JOINTS).shaper
    assert np.array_equal(outs[0]["v"], ref.shape(np.array(q), np.array([0.0, 1.0, 0.0])))
    assert np.array_equal(outs[1]["v"], ref.shape(np.array(q), np.array([-0.1, 0.0, 0.2])))
    assert outs[0]["v"][1] < 1.0  # j2 near its upper limit is braked
    c = b.node.counters
    assert c["dropped:command_unknown_joints"] == 1
    assert c["dropped:command_duplicate_joints"] == 1


def test_robot_joint_names_on_the_wire(bridge, tmp_path) -> None:
    # The robot calls the shaper's j1, j2, j3 "fr3_joint1…3": state and jog in those names.
    wire = ["fr3_joint1", "fr3_joint2", "fr3_joint3"]
    b = bridge(
        {
            "command_in": {"topic": "jog", "type": "joint_jog", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "out", "type": "same", "qos": RELIABLE_DEEP},
            "state": {
                "topic": "joint_states",
                "type": "joint_state",
                "qos": "default",
                "joint_names": wire,
            },
        },
        JOINTS,
    )
    q = [0.0, 1.9, 0.0]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("jog"),
                "cmd_out": b.topic("out"),
                "state": b.topic("joint_states"),
            },
            "cmd_type": "joint_jog",
            "out_type": "joint_jog",
            "state": {"type": "joint_state", "names": wire[::-1], "values": q[::-1]},
            "commands": [
                {"names": ["fr3_joint2"], "values": [1.0]},
                {"names": ["j2"], "values": [1.0]},  # the shaper's name is not the robot's
            ],
            "rate_hz": 100.0,
            "expect": 1,
            "tail": 0.2,
        },
        tmp_path,
        bridge=b,
    )
    outs = [o for o in res["outputs"] if o["i"] < 2]
    assert [o["i"] for o in outs] == [0]
    ref = parse_shaper(JOINTS).shaper
    assert np.array_equal(outs[0]["v"], ref.shape(np.array(q), np.array([0.0, 1.0, 0.0])))
    assert b.node.counters["dropped:command_unknown_joints"] == 1


def test_state_missing_a_joint_is_dropped_and_commands_held(bridge, tmp_path) -> None:
    b = bridge(
        {
            "command_in": {"topic": "cmd", "type": "float64_multi_array", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "out", "qos": RELIABLE_DEEP},
            "state": {"topic": "joint_states", "type": "joint_state", "qos": "default"},
        },
        JOINTS,
    )
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("cmd"),
                "cmd_out": b.topic("out"),
                "state": b.topic("joint_states"),
            },
            "cmd_type": "float64_multi_array",
            "out_type": "float64_multi_array",
            "state": {"type": "joint_state", "names": ["j1", "j2"], "values": [0.0, 0.0]},
            "commands": [{"values": [0.3, 0.3, 0.3]}] * 5,
            "rate_hz": 100.0,
            "expect": 5,
        },
        tmp_path,
        bridge=b,
    )
    assert [o["v"] for o in res["outputs"]] == [[0.0, 0.0, 0.0]] * 5  # no state: held at zero
    c = b.node.counters
    assert c["commands_held"] == 5
    assert c["dropped:state_missing_joints"] >= 1
    assert b.node.node_state == "waiting_for_state"


def test_qos_mismatch_logged_and_in_diagnostics(bridge, tmp_path, bridge_log) -> None:
    b = _plane_bridge(bridge)
    res = run_client(
        {
            "scenario": "qos",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
        },
        tmp_path,
    )
    diag = res["diagnostics"]
    assert int(diag["qos_incompatible"]) >= 2
    reports = [v for k, v in diag.items() if k.startswith("qos_mismatch_")]
    assert any("RELIABILITY" in r and "reader" in r for r in reports), reports
    assert any("DURABILITY" in r and "writer" in r for r in reports), reports
    lines = [r.getMessage() for r in bridge_log.records if "QoS mismatch" in r.getMessage()]
    assert any(b.topic("cmd_vel_in") in line for line in lines)
    assert any(b.topic("cmd_vel_out") in line for line in lines)


def test_endpoints_carry_the_type_hash(bridge, tmp_path) -> None:
    b = _plane_bridge(bridge)
    topics = [
        b.topic("cmd_vel_in"),
        b.topic("pose"),
        b.topic("cmd_vel_out"),
        b.topic("diagnostics"),
    ]
    res = run_client({"scenario": "endpoints", "topics": topics, "expect": 4}, tmp_path)
    ep = res["endpoints"]
    want = {
        f"subscription:{topics[0]}": msgs.TwistStamped,
        f"subscription:{topics[1]}": msgs.PoseStamped,
        f"publication:{topics[2]}": msgs.TwistStamped,
        f"publication:{topics[3]}": msgs.DiagnosticArray,
    }
    for key, typ in want.items():
        assert key in ep, sorted(ep)
        assert ep[key]["type"] == typ.__idl_typename__.replace(".", "::")
        assert ep[key]["user_data"] == f"typehash={rihs01(typ)};"


def test_body_frame_twist_rotated_by_the_odometry_yaw_and_on_cycle(bridge, tmp_path) -> None:
    seen = []
    b = bridge(
        {
            "command_in": {"topic": "cmd_vel", "type": "twist", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "cmd_vel_safe", "qos": RELIABLE_DEEP},
            "state": {"topic": "odom", "type": "odometry", "qos": "default"},
            "command_frame": "body",
        },
        POLYGON,
        on_cycle=seen.append,
    )
    p, yaw = np.array([2.0, 2.8]), math.pi / 2  # facing +y, 0.2 m from the top edge
    cmds = [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.3]]  # forward (toward the edge), left, back
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("cmd_vel"),
                "cmd_out": b.topic("cmd_vel_safe"),
                "state": b.topic("odom"),
            },
            "cmd_type": "twist",
            "out_type": "twist",
            "state": {"type": "odometry", "values": [*p, 0.0], "yaw": yaw},
            "commands": [{"values": c} for c in cmds],
            "rate_hz": 50.0,
            "expect": 3,
            "expect_nonzero": True,  # a stalled machine may put a watchdog zero between them
        },
        tmp_path,
        bridge=b,
    )
    got = np.array([o["v"][:2] for o in res["outputs"] if any(o["v"])][:3])
    ref = parse_shaper(POLYGON).shaper
    rot = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    want = np.array([rot.T @ ref.shape(p, rot @ np.array(c)) for c in cmds])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert got[0, 0] < 0.5  # forward, toward the edge: braked
    assert got[1] == pytest.approx([0.0, 1.0])  # sideways along the edge: unchanged
    assert got[2] == pytest.approx([-1.0, 0.3])  # away from the edge: unchanged
    shaped = [c for c in seen if c.command is not None]
    assert len(shaped) == 3
    assert shaped[0].zone == "buffer"
    assert shaped[0].active  # the top edge, by name
    assert shaped[0].changed
    assert not shaped[1].changed
    assert np.array_equal(shaped[0].state, p)
    assert np.array_equal(shaped[0].shaped, got[0])
