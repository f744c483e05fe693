"""Bridge set-ups shared by the bridge tests: shapers, a deep reliable QoS, a plane bridge."""

from __future__ import annotations

from typing import Any

POLYGON = {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
JOINTS = {
    "kind": "joint_limits",
    "joint_names": ["j1", "j2", "j3"],
    "lower": [-1.0, -2.0, -1.5],
    "upper": [1.0, 2.0, 1.5],
    "buffer": 0.2,
}
#: Reliable with a history deep enough that a test stream is never overwritten.
RELIABLE_DEEP = {"profile": "default", "depth": 5000}


def plane_bridge(bridge: Any, **section: Any) -> Any:
    """A running bridge (the ``bridge`` fixture) shaping TwistStamped in the 4 m x 3 m room.

    ``section`` overrides fields of the ``bridge:`` section.
    """
    base = {
        "command_in": {"topic": "cmd_vel_in", "type": "twist_stamped", "qos": RELIABLE_DEEP},
        "command_out": {"topic": "cmd_vel_out", "qos": RELIABLE_DEEP},
        "state": {"topic": "pose", "type": "pose_stamped", "qos": "default"},
        "command_frame": "world",
        "diagnostics": {"topic": "diagnostics", "period": 0.2},
    }
    base.update(section)
    return bridge(base, POLYGON)


def plane_topics(b: Any) -> dict[str, str]:
    """The DDS topics of :func:`plane_bridge`'s bridge, as the peer client names them."""
    return {
        "cmd_in": b.topic("cmd_vel_in"),
        "cmd_out": b.topic("cmd_vel_out"),
        "state": b.topic("pose"),
        "diag": b.topic("diagnostics"),
    }
