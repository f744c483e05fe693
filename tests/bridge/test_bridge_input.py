"""Hostile input against the bridge, sent by a ROS 2 peer in another process (ros_client.py).

Checked on the wire: an undecodable TwistStamped (its frame id not UTF-8, CDR encoded by the
peer byte by byte) is dropped alone and counted, the valid commands around it are answered in
order; a JointState naming a joint twice is dropped and counted, never applied; a QoS mismatch
names the policy Cyclone reports (its own ids); a 10 kHz stream for 2 s leaves the bridge
answering, with what loss DDS lets it see counted.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from setups import JOINTS, POLYGON, RELIABLE_DEEP
from setups import plane_bridge as _plane
from setups import plane_topics as _topics

from conftest import run_client
from velfence.io.shaper_config import parse_shaper


def _wait_received(b, n: int) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + 10.0
    while b.node.counters["commands_received"] < n and time.monotonic() < deadline:
        time.sleep(0.01)


def test_undecodable_sample_dropped_alone(bridge, tmp_path) -> None:
    b = _plane(bridge)
    p = np.array([0.3, 1.2])  # in the left edge's buffer: commands toward it are changed
    rng = np.random.default_rng(3)
    cmds = rng.normal(scale=0.8, size=(21, 2))
    items = [{"values": [*c, 0.0]} for c in cmds]
    # Index 10: a TwistStamped whose frame id is not UTF-8 (0xff 0xfe), in the same batch.
    items[10] = {"raw_frame_id": "fffe6f646f6d", "values": [0.5, 0.5, 0.0]}
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [*p, 0.0]},
            "commands": items,
            "rate_hz": 20000.0,  # as fast as the peer writes: the bridge takes them in batches
            "depth": 5000,
            "expect": 20,
            "tail": 0.3,
        },
        tmp_path,
        bridge=b,
    )
    _wait_received(b, 21)
    answers = [o for o in res["outputs"] if o["i"] < 21]  # not the watchdog's time-stamped zeros
    assert [o["i"] for o in answers] == [i for i in range(21) if i != 10]
    ref = parse_shaper(POLYGON).shaper
    got = np.array([o["v"][:2] for o in answers])
    want = np.array([ref.shape(p, c) for i, c in enumerate(cmds) if i != 10])
    assert np.array_equal(got, want)
    c = b.node.counters
    assert c["commands_received"] == 21
    assert c["commands_shaped"] == 20
    assert c["dropped_commands"] == 1
    assert c["dropped:command_undecodable"] == 1


def test_joint_state_naming_a_joint_twice_is_dropped(bridge, tmp_path) -> None:
    b = bridge(
        {
            "command_in": {"topic": "cmd", "type": "float64_multi_array", "qos": RELIABLE_DEEP},
            "command_out": {"topic": "out", "qos": RELIABLE_DEEP},
            "state": {"topic": "joint_states", "type": "joint_state", "qos": "default"},
        },
        JOINTS,
    )
    # j1 twice: 0.0 then 0.95 (near its upper limit). Applying either entry would shape the
    # command; the state is dropped instead, so every command is held at zero.
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
            "state": {
                "type": "joint_state",
                "names": ["j1", "j2", "j3", "j1"],
                "values": [0.0, 0.0, 0.0, 0.95],
            },
            "commands": [{"values": [0.5, 0.3, 0.3]}] * 5,
            "rate_hz": 100.0,
            "expect": 5,
        },
        tmp_path,
        bridge=b,
    )
    assert [o["v"] for o in res["outputs"]][:5] == [[0.0, 0.0, 0.0]] * 5
    c = b.node.counters
    assert c["commands_held"] == 5
    assert c["commands_shaped"] == 0
    assert c["dropped:state_duplicate_joints"] >= 1
    assert c["dropped:state_duplicate_joints"] == c["states_received"]
    assert b.node.node_state == "waiting_for_state"


@pytest.mark.parametrize(
    ("mismatch", "policy"),
    [("data_representation", "DATA_REPRESENTATION"), ("reliability", "RELIABILITY")],
)
def test_qos_mismatch_names_cyclones_policy(bridge, tmp_path, mismatch, policy) -> None:
    b = _plane(bridge)
    res = run_client(
        {
            "scenario": "qos_one",
            "mismatch": mismatch,
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
        },
        tmp_path,
    )
    reports = [v for k, v in res["diagnostics"].items() if k.startswith("qos_mismatch_")]
    assert reports, res["diagnostics"]
    assert all(f"requested {policy} " in r for r in reports), reports
    assert all(b.topic("cmd_vel_in") in r for r in reports), reports


@pytest.mark.slow
def test_10khz_for_2s_bridge_answers_and_counts_what_it_can_see(bridge, tmp_path) -> None:
    # ROS 2's default QoS (keep-last 10) on the commands: at 10 kHz the bridge cannot keep up,
    # its reader's history overwrites. It must stay alive, answer, and count what DDS shows.
    b = _plane(
        bridge,
        command_in={"topic": "cmd_vel_in", "type": "twist_stamped", "qos": "default"},
        command_out={"topic": "cmd_vel_out", "qos": RELIABLE_DEEP},
    )
    n = 20_000
    res = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [2.0, 1.5, 0.0]},
            "commands": [{"values": [0.1, 0.0, 0.0]}] * n,
            "rate_hz": 10_000.0,
            "depth": 10,
            "expect": n,  # not reached: the wait ends after its 10 s or when answers stop
            "tail": 0.5,
            "give_up_after": 1.0,
        },
        tmp_path,
        bridge=b,
        timeout=120.0,
    )
    sent = res["sent"]
    assert len(sent) == n
    answers = [o for o in res["outputs"] if o["i"] < n]
    assert len(answers) > 0
    c = b.node.counters
    assert b.thread.is_alive()
    assert c["commands_received"] == c["commands_shaped"] + c["dropped_commands"]
    lost = n - c["commands_received"]
    if lost > 0:
        # The overwritten samples are not counted by DDS (no status, no sequence number): the
        # bridge counts the takes that found its history full, which a loss needs.
        assert c["command_history_full"] > 0, c
    # Answers are in order (a stamp per command), each command at most once.
    idx = [o["i"] for o in answers]
    assert idx == sorted(set(idx))
    # And after the flood the bridge still answers a fresh command at once.
    res2 = run_client(
        {
            "scenario": "stream",
            "topics": _topics(b),
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [2.0, 1.5, 0.0]},
            "commands": [{"values": [0.2, 0.1, 0.0]}] * 3,
            "rate_hz": 50.0,
            "expect": 3,
            "expect_nonzero": True,
        },
        tmp_path,
        bridge=b,
    )
    assert [o["v"][:2] for o in res2["outputs"] if any(o["v"])][:3] == [[0.2, 0.1]] * 3
