"""ROS conventions of the bridge against a ROS 2 peer in another process (ros_client.py).

Checked on the wire: halting as MoveIt Servo did (``halt_messages`` zeros once commands go
stale, then silence until they resume); publishing on the node's own timer (``publish_period``),
each period the last command shaped against the newest state.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import run_client
from velfence.io.shaper_config import parse_shaper

POLYGON = {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
RELIABLE_DEEP = {"profile": "default", "depth": 5000}


def _plane(bridge, **section):  # type: ignore[no-untyped-def]
    base = {
        "command_in": {"topic": "cmd_vel_in", "type": "twist_stamped", "qos": RELIABLE_DEEP},
        "command_out": {"topic": "cmd_vel_out", "qos": RELIABLE_DEEP},
        "state": {"topic": "pose", "type": "pose_stamped", "qos": "default"},
        "command_frame": "world",
    }
    base.update(section)
    return bridge(base, POLYGON)


def _topics(b) -> dict[str, str]:  # type: ignore[no-untyped-def]
    return {
        "cmd_in": b.topic("cmd_vel_in"),
        "cmd_out": b.topic("cmd_vel_out"),
        "state": b.topic("pose"),
    }


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
    sent, outs = res["sent"], res["outputs"]
    answers = [o for o in outs if o["i"] < n]
    zeros = [o for o in outs if o["i"] >= n]  # stamped with the time, not an index
    assert [o["i"] for o in answers] == list(range(n))
    assert all(o["v"] == [0.0] * 6 for o in zeros)
    in_pause = [o for o in zeros if sent[4] < o["t"] < sent[5]]
    after_end = [o for o in zeros if o["t"] > sent[-1]]
    assert len(in_pause) == 3, [o["t"] - sent[4] for o in in_pause]
    assert len(after_end) == 3, [o["t"] - sent[-1] for o in after_end]
    assert len(zeros) == 6
    c = b.node.counters
    assert c["watchdog_zeros"] == 6
    assert c["outputs_published"] == n + 6


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
            "expect": 10_000,
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
