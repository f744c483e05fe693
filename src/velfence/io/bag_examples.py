"""The example bags of ``velfence replay`` (``examples/bags/<name>/``), generated, not recorded.

:func:`make_example_bag` writes a rosbag2 directory and its replay config as a pure function of
the example's name, so a test can check that the shipped files are exactly what it writes
(``docs/replay.md``). ``rosbags`` (extra ``ros``) is imported inside the function only.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from velfence._validate import check_choice
from velfence.errors import InvalidParameter
from velfence.io.bags import (
    JOINT_JOG,
    JOINT_STATE,
    ODOMETRY,
    TWIST,
    TWIST_STAMPED,
    _fs_path,
    _probe,
    message_typestore,
)

if TYPE_CHECKING:
    from numpy.typing import NDArray

__all__ = ["EXAMPLE_BAGS", "arm_jog_messages", "make_example_bag", "mobile_base_messages"]

#: The example bags :func:`make_example_bag` writes (shipped under ``examples/bags/<name>/``).
EXAMPLE_BAGS: tuple[str, ...] = ("mobile_base", "arm_jog")

#: Start of the example bags' clock [ns] (2023-11-14 22:13:20 UTC; any fixed time would do).
_EPOCH_NS = 1_700_000_000 * 10**9

_MOBILE_BASE_YAML = """\
# A mobile base driven toward the wall of a 4 m x 3 m room (examples/bags/mobile_base/bag):
#   velfence replay examples/bags/mobile_base/bag --config examples/bags/mobile_base/replay.yaml \\
#     --out out/replay/mobile_base --plot docs/img/replay_mobile_base.png
shaper:
  kind: polygon
  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]   # the room's walls, odom frame [m]
  buffer: 0.5                                  # [m]
  spring_gain: 1.0                             # [1/s]
replay:
  command_topic: /cmd_vel        # geometry_msgs/msg/TwistStamped, (vx, vy) in the odom frame
  state_topic: /odom             # nav_msgs/msg/Odometry, (x, y)
  output_topic: /cmd_vel_shaped
  max_state_age: 0.3             # [s]: odometry drops out at 9.0-9.6 s
"""

_ARM_JOG_YAML = """\
# A 3-joint arm jogged past two joint limits (examples/bags/arm_jog/bag):
#   velfence replay examples/bags/arm_jog/bag --config examples/bags/arm_jog/replay.yaml \\
#     --out out/replay/arm_jog --plot docs/img/replay_arm_jog.png
shaper:
  kind: joint_limits
  joint_names: [pan, lift, elbow]
  lower: [-1.5, -1.0, -2.0]      # [rad]
  upper: [1.5, 1.0, 2.0]         # [rad]
  buffer: 0.3                    # [rad]
  spring_gain: 1.0               # [1/s]
replay:
  command_topic: /servo/delta_joint_cmds     # control_msgs/msg/JointJog
  state_topic: /joint_states                 # sensor_msgs/msg/JointState
  joint_names: [arm_pan, arm_lift, arm_elbow]  # the bag's names of pan, lift, elbow
"""


def mobile_base_messages(ts: Any) -> list[tuple[str, str, int, Any]]:
    """The messages of the ``mobile_base`` example bag: ``(topic, type, time [ns], message)``.

    Internal API (``make_example_bag`` writes them; ``benchmarks/replay_speed.py`` repeats them).
    ``ts``: the typestore (:func:`velfence.io.bags.message_typestore`).
    """
    T = ts.types
    Time, Header, Vec = (
        T["builtin_interfaces/msg/Time"],
        T["std_msgs/msg/Header"],
        T["geometry_msgs/msg/Vector3"],
    )
    Twist, Point, Quat = T[TWIST], T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    zero = Vec(x=0.0, y=0.0, z=0.0)

    def header(t_ns: int, frame: str) -> Any:
        return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame)

    def command(t: float) -> tuple[float, float]:  # a teleoperator [m/s]
        if t < 5.0:
            return 0.5, 0.1  # toward the east wall x = 4
        if t < 9.0:
            return 0.3, 0.35  # into the north-east corner
        return -0.3, 0.3  # along the north wall y = 3

    out: list[tuple[str, str, int, Any]] = []
    x, y, dt = 1.0, 1.0, 0.1
    cov = np.zeros(36)
    for i in range(120):  # 12 s at 10 Hz; the base was driven without a fence
        t = i * dt
        t_cmd = _EPOCH_NS + i * 100_000_000
        vx, vy = command(t)
        lin = Vec(x=vx, y=vy, z=0.0)
        msg = T[TWIST_STAMPED](header=header(t_cmd, "odom"), twist=Twist(linear=lin, angular=zero))
        out.append(("/cmd_vel", TWIST_STAMPED, t_cmd, msg))
        x, y = x + vx * dt, y + vy * dt
        t_odom = t_cmd + 50_000_000  # odometry 50 ms after each command
        if 9.0 <= t + 0.05 < 9.6:  # an odometry dropout
            continue
        pose = T["geometry_msgs/msg/Pose"](
            position=Point(x=round(x, 12), y=round(y, 12), z=0.0),
            orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
        )
        odom = T[ODOMETRY](
            header=header(t_odom, "odom"),
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=Twist(linear=lin, angular=zero), covariance=cov
            ),
        )
        out.append(("/odom", ODOMETRY, t_odom, odom))
    return out


def arm_jog_messages(ts: Any) -> list[tuple[str, str, int, Any]]:
    """The messages of the ``arm_jog`` example bag: ``(topic, type, time [ns], message)``.

    Internal API (``make_example_bag`` writes them; ``benchmarks/replay_speed.py`` repeats them).
    ``ts``: the typestore (:func:`velfence.io.bags.message_typestore`).
    """
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    bag_names = ["arm_pan", "arm_lift", "arm_elbow"]
    lower, upper = np.array([-1.5, -1.0, -2.0]), np.array([1.5, 1.0, 2.0])

    def header(t_ns: int) -> Any:
        return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id="")

    def command(t: float) -> NDArray[np.float64]:  # an operator jogging [rad/s]
        v = np.zeros(3)
        v[0] = 0.5 if t < 4.0 else -0.2
        v[1] = 0.25 if 1.0 <= t < 5.0 else 0.0
        v[2] = -0.6 if t >= 2.0 else 0.0
        return v

    out: list[tuple[str, str, int, Any]] = []
    q, dt = np.zeros(3), 0.05
    for i in range(160):  # 8 s at 20 Hz
        t = i * dt
        t_state = _EPOCH_NS + i * 50_000_000
        # The state lists the joints in another order, with a gripper the shaper ignores.
        state = T[JOINT_STATE](
            header=header(t_state),
            name=["arm_elbow", "gripper", "arm_pan", "arm_lift"],
            position=np.array([q[2], 0.02, q[0], q[1]]).round(12),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )
        out.append(("/joint_states", JOINT_STATE, t_state, state))
        v = command(t)
        t_cmd = t_state + 10_000_000  # the jog 10 ms after the state
        jog = T[JOINT_JOG](
            header=header(t_cmd),
            joint_names=list(bag_names),
            displacements=np.zeros(0),
            velocities=v,
            duration=0.0,
        )
        out.append(("/servo/delta_joint_cmds", JOINT_JOG, t_cmd, jog))
        # The recorded arm had no velfence: it stops only at hard stops 0.2 rad past the limits.
        q = np.clip(q + v * dt, lower - 0.2, upper + 0.2)
    return out


def make_example_bag(name: str, folder: str | Path) -> Path:
    """Write one of the example bags and its replay config (the shipped ``examples/bags``).

    ``mobile_base``: a base driven at 10 Hz toward the walls of a 4 m x 3 m room
    (``geometry_msgs/msg/TwistStamped`` on ``/cmd_vel``, ``nav_msgs/msg/Odometry`` on ``/odom``
    with a 0.6 s dropout), MCAP storage, a polygon config. ``arm_jog``: a 3-joint arm jogged at
    20 Hz past two joint limits (``control_msgs/msg/JointJog``, ``sensor_msgs/msg/JointState``
    with other joint names and order), sqlite3 storage, a joint_limits config. The output is a
    pure function of ``name``: the same bytes every time.

    Args:
        name: One of :data:`EXAMPLE_BAGS`.
        folder: A new folder (it must not exist, its parent must) for ``bag/`` (the rosbag2
            directory) and ``replay.yaml``.

    Returns:
        ``folder``.

    Raises:
        InvalidParameter: an unknown name, an existing folder or a missing parent, the ``ros``
            extra not installed.
    """
    which = check_choice("name", name, EXAMPLE_BAGS)
    root = _fs_path("folder", folder)
    if _probe(root, lambda q: os.path.lexists(q)):
        raise InvalidParameter(f"folder: {root} exists already; remove it first")
    if not _probe(root.parent, Path.is_dir):
        raise InvalidParameter(f"folder: the parent {root.parent} does not exist")
    bag, cfg = root / "bag", root / "replay.yaml"
    try:
        from rosbags.rosbag2 import StoragePlugin, Writer
    except ImportError:
        raise InvalidParameter(
            "make_example_bag needs rosbags: pip install 'velfence[ros]'"
        ) from None
    ts = message_typestore(None)
    if which == "mobile_base":
        msgs, plugin, text = mobile_base_messages(ts), StoragePlugin.MCAP, _MOBILE_BASE_YAML
    else:
        msgs, plugin, text = arm_jog_messages(ts), StoragePlugin.SQLITE3, _ARM_JOG_YAML
    root.mkdir()
    with Writer(bag, version=9, storage_plugin=plugin) as writer:
        conns: dict[str, Any] = {}
        for topic, msgtype, _, _ in msgs:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
        for topic, msgtype, t, msg in msgs:
            writer.write(conns[topic], t, ts.serialize_cdr(msg, msgtype))
    cfg.write_text(text, encoding="utf-8")
    return root
