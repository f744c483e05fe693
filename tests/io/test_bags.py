"""Bag replay: the written bag read back by independent readers, against the shaper run directly.

The MCAP output is decoded with the ``mcap`` reader and ``mcap_ros2``'s decoder (not rosbags), the
states are held and matched by name here, and the shaped values are compared bit for bit with
``parse_shaper(...).shaper.shape`` on the same inputs; the sqlite3 output is read back with
rosbags; ``metadata.yaml`` is parsed with PyYAML.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

pytest.importorskip("rosbags")

from velfence.errors import InvalidInput, InvalidParameter
from velfence.io import load_yaml, make_example_bag, parse_shaper
from velfence.io.bag_examples import EXAMPLE_BAGS
from velfence.io.bags import ReplaySummary, replay

EXAMPLES = Path(__file__).parent.parent.parent / "examples" / "bags"
NS = 10**9


@pytest.fixture(scope="module")
def examples(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("examples")
    for name in EXAMPLE_BAGS:
        make_example_bag(name, root / name)
    return root


# ----------------------------------------------------------------------- independent readers


def _mcap_messages(folder: Path) -> dict[str, list[tuple[int, Any, bytes]]]:
    """topic -> [(log_time ns, decoded message, raw CDR)] by the mcap library."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (path,) = folder.glob("*.mcap")
    out: dict[str, list[tuple[int, Any, bytes]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append((message.log_time, decoded, message.data))
    return out


def _rosbags_messages(folder: Path) -> dict[str, list[tuple[int, Any, bytes]]]:
    """topic -> [(timestamp ns, decoded message, raw CDR)] by rosbags' AnyReader."""
    from rosbags.highlevel import AnyReader

    out: dict[str, list[tuple[int, Any, bytes]]] = {}
    with AnyReader([folder]) as reader:
        for conn, t, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            out.setdefault(conn.topic, []).append((t, msg, bytes(raw)))
    return out


def _held(states: list[tuple[int, np.ndarray]], t: int) -> tuple[int, np.ndarray] | None:
    """The latest state at or before ``t`` (a plain loop, not the library's searchsorted)."""
    best = None
    for ts, x in states:
        if ts <= t and (best is None or ts >= best[0]):
            best = (ts, x)
    return best


# ------------------------------------------------------------------------------------- MCAP


def test_mcap_output_matches_the_shaper_bit_for_bit(examples: Path, tmp_path: Path) -> None:
    src = examples / "mobile_base"
    s = replay(src / "bag", src / "replay.yaml", tmp_path / "out")
    assert s.storage == "mcap"
    got = _mcap_messages(tmp_path / "out")
    odom = [
        (t, np.array([m.pose.pose.position.x, m.pose.pose.position.y])) for t, m, _ in got["/odom"]
    ]
    cmds = got["/cmd_vel"]
    shaped = got["/cmd_vel_shaped"]
    assert len(shaped) == len(cmds) == s.commands == 120
    shaper = parse_shaper(load_yaml(src / "replay.yaml")["shaper"]).shaper
    zero = {"no_state": 0, "stale": 0}
    changed = 0
    for (tc, c, _), (ts, out, _) in zip(cmds, shaped, strict=True):
        assert ts == tc  # stamped with the command's time
        assert (out.header.stamp.sec, out.header.stamp.nanosec) == (
            c.header.stamp.sec,
            c.header.stamp.nanosec,
        )
        v = np.array([c.twist.linear.x, c.twist.linear.y])
        w = np.array([out.twist.linear.x, out.twist.linear.y])
        held = _held(odom, tc)
        if held is None or tc - held[0] > 0.3 * NS:
            zero["no_state" if held is None else "stale"] += 1
            np.testing.assert_array_equal(w, 0.0)
            assert out.twist.angular.z == 0.0
            changed += bool(np.any(v != 0))
            continue
        expected = shaper.shape(held[1], v)
        np.testing.assert_array_equal(w, expected)  # bit-identical floats
        assert out.twist.linear.z == c.twist.linear.z
        changed += bool(np.any(np.abs(expected - v) > 1e-9))
    assert (s.zeroed_no_state, s.zeroed_stale, s.zeroed_invalid) == (
        zero["no_state"],
        zero["stale"],
        0,
    )
    assert zero == {"no_state": 1, "stale": 4}
    assert s.changed == changed
    # The base drove through the east wall; velfence would have stopped the approach.
    assert s.changed_fraction > 0.3
    assert s.max_abs_change == pytest.approx(np.abs(s.commanded - s.shaped).max())


def test_every_original_message_is_copied(examples: Path, tmp_path: Path) -> None:
    src = examples / "mobile_base"
    replay(src / "bag", src / "replay.yaml", tmp_path / "out")
    before = _rosbags_messages(src / "bag")
    after = _mcap_messages(tmp_path / "out")
    assert set(after) == {*before, "/cmd_vel_shaped"}
    for topic, msgs in before.items():
        assert [(t, raw) for t, _, raw in msgs] == [(t, raw) for t, _, raw in after[topic]]


def test_progress_rises_to_one_and_is_validated(examples: Path, tmp_path: Path) -> None:
    src = examples / "mobile_base"
    seen: list[float] = []
    s = replay(src / "bag", src / "replay.yaml", tmp_path / "out", progress=seen.append)
    assert seen[-1] == 1.0
    assert seen[0] < 0.5
    assert all(0.0 <= f <= 1.0 for f in seen)
    assert seen == sorted(seen)  # never goes back
    # Through shaping and through writing, not only at the end: a bar that moves.
    assert any(0.0 < f < 0.5 for f in seen)
    assert any(0.5 < f < 1.0 for f in seen)
    assert s.commands > 0
    with pytest.raises(InvalidParameter, match="progress"):
        replay(src / "bag", src / "replay.yaml", tmp_path / "out2", progress=3)  # type: ignore[arg-type]


def test_metadata_lists_every_topic_with_its_count(examples: Path, tmp_path: Path) -> None:
    src = examples / "mobile_base"
    s = replay(src / "bag", src / "replay.yaml", tmp_path / "out")
    info_in = yaml.safe_load((src / "bag" / "metadata.yaml").read_text())
    info = yaml.safe_load((tmp_path / "out" / "metadata.yaml").read_text())
    bi, bo = info_in["rosbag2_bagfile_information"], info["rosbag2_bagfile_information"]
    topics_in = {t["topic_metadata"]["name"]: t for t in bi["topics_with_message_count"]}
    topics = {t["topic_metadata"]["name"]: t for t in bo["topics_with_message_count"]}
    assert bo["storage_identifier"] == "mcap"
    assert set(topics) == {"/cmd_vel", "/odom", "/cmd_vel_shaped"}
    for name, t in topics_in.items():
        assert topics[name]["message_count"] == t["message_count"]
        assert topics[name]["topic_metadata"]["type"] == t["topic_metadata"]["type"]
    shaped = topics["/cmd_vel_shaped"]
    assert shaped["message_count"] == topics["/cmd_vel"]["message_count"] == 120
    cmd_meta = topics["/cmd_vel"]["topic_metadata"]
    assert shaped["topic_metadata"]["type"] == "geometry_msgs/msg/TwistStamped"
    assert shaped["topic_metadata"]["type_description_hash"] == cmd_meta["type_description_hash"]
    assert bo["message_count"] == bi["message_count"] + 120 == s.messages
    (path,) = bo["relative_file_paths"]
    assert (tmp_path / "out" / path).is_file()


# ------------------------------------------------------------------------------------ sqlite3


def test_sqlite_joint_jog_read_back_with_rosbags(examples: Path, tmp_path: Path) -> None:
    src = examples / "arm_jog"
    s = replay(src / "bag", src / "replay.yaml", tmp_path / "out")
    assert s.storage == "sqlite3"
    assert (tmp_path / "out" / "out.db3").is_file()
    got = _rosbags_messages(tmp_path / "out")
    names = ["arm_pan", "arm_lift", "arm_elbow"]
    states = [
        (t, np.array([list(m.position)[list(m.name).index(j)] for j in names]))
        for t, m, _ in got["/joint_states"]
    ]
    shaper = parse_shaper(load_yaml(src / "replay.yaml")["shaper"]).shaper
    shaped = got["/servo/delta_joint_cmds_shaped"]
    cmds = got["/servo/delta_joint_cmds"]
    assert len(shaped) == len(cmds) == 160
    for (tc, c, _), (ts, out, _) in zip(cmds, shaped, strict=True):
        assert ts == tc
        assert list(out.joint_names) == list(c.joint_names)
        order = [list(c.joint_names).index(j) for j in names]
        held = _held(states, tc)
        assert held is not None
        expected = shaper.shape(held[1], np.asarray(c.velocities)[order])
        np.testing.assert_array_equal(np.asarray(out.velocities)[order], expected)
    assert s.zeroed == 0
    assert s.components == tuple(names)
    # Both jogged joints were driven past their limits: the shaped jog turns them back.
    assert s.shaped[-1, 2] > 0 > s.commanded[-1, 2]


def test_storage_can_be_converted(examples: Path, tmp_path: Path) -> None:
    src = examples / "arm_jog"
    a = replay(src / "bag", src / "replay.yaml", tmp_path / "a")
    b = replay(src / "bag", src / "replay.yaml", tmp_path / "b", storage="mcap")
    assert (a.storage, b.storage) == ("sqlite3", "mcap")
    np.testing.assert_array_equal(a.shaped, b.shaped)
    got = _mcap_messages(tmp_path / "b")
    np.testing.assert_array_equal(
        [list(m.velocities) for _, m, _ in got["/servo/delta_joint_cmds_shaped"]], a.shaped
    )


# ------------------------------------------------------------------------- the shipped bags


def test_shipped_example_bags_are_reproducible(examples: Path) -> None:
    for name in EXAMPLE_BAGS:
        shipped, fresh = EXAMPLES / name, examples / name
        assert (shipped / "replay.yaml").read_text() == (fresh / "replay.yaml").read_text()
        meta = "bag/metadata.yaml"
        assert (shipped / meta).read_text() == (fresh / meta).read_text()
        a, b = _rosbags_messages(shipped / "bag"), _rosbags_messages(fresh / "bag")
        assert {k: [(t, raw) for t, _, raw in v] for k, v in a.items()} == {
            k: [(t, raw) for t, _, raw in v] for k, v in b.items()
        }
        size = sum(f.stat().st_size for f in (shipped / "bag").iterdir())
        assert size < 200_000, f"{name}: {size} bytes"


def test_make_example_bag_refuses_to_overwrite(examples: Path) -> None:
    with pytest.raises(InvalidParameter, match="exists already"):
        make_example_bag("arm_jog", examples / "arm_jog")
    with pytest.raises(InvalidParameter, match="name"):
        make_example_bag("forklift", examples / "x")


# ----------------------------------------------------------------------- hand-made bags


def _write_bag(
    path: Path, topics: dict[str, tuple[str, list[tuple[float, Any]]]], fmt: str = "mcap"
) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        for topic, (msgtype, msgs) in topics.items():
            conn = w.add_connection(topic, msgtype, typestore=ts)
            for t, m in msgs:
                w.write(conn, round(t * NS), ts.serialize_cdr(m, msgtype))
    return path


def _types() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE).types


def _twist(v: list[float]) -> Any:
    T = _types()
    V = T["geometry_msgs/msg/Vector3"]
    return T["geometry_msgs/msg/Twist"](
        linear=V(x=v[0], y=v[1], z=v[2]), angular=V(x=0.0, y=0.0, z=0.3)
    )


def _pose(p: list[float]) -> Any:
    T = _types()
    H, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    return T["geometry_msgs/msg/PoseStamped"](
        header=H(stamp=Time(sec=0, nanosec=0), frame_id="map"),
        pose=T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
            orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        ),
    )


def _joint_state(names: list[str], q: list[float]) -> Any:
    T = _types()
    H, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    return T["sensor_msgs/msg/JointState"](
        header=H(stamp=Time(sec=0, nanosec=0), frame_id=""),
        name=names,
        position=np.array(q, dtype=float),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )


def _array(v: list[float]) -> Any:
    T = _types()
    layout = T["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    return T["std_msgs/msg/Float64MultiArray"](layout=layout, data=np.array(v, dtype=float))


BOX3 = {"kind": "polytope", "lower": [0, 0, 0], "upper": [1, 1, 1], "buffer": 0.2}
JOINTS = {
    "kind": "joint_limits",
    "joint_names": ["a", "b"],
    "lower": [-1, -1],
    "upper": [1, 1],
    "buffer": 0.2,
}


def test_twist_and_pose_in_3d_with_a_non_finite_command(tmp_path: Path) -> None:
    bag = _write_bag(
        tmp_path / "in",
        {
            "/cmd": (
                "geometry_msgs/msg/Twist",
                [
                    (0.1, _twist([1.0, 0.0, -1.0])),
                    (0.3, _twist([float("nan"), 0, 0])),
                    (0.5, _twist([0.5, 0.5, 0.5])),
                ],
            ),
            "/pose": (
                "geometry_msgs/msg/PoseStamped",
                [(0.0, _pose([0.9, 0.5, 0.1])), (0.4, _pose([0.5, 0.95, 0.5]))],
            ),
        },
    )
    cfg = {
        "shaper": BOX3,
        "replay": {"command_topic": "/cmd", "state_topic": "/pose", "output_topic": "/safe"},
    }
    s = replay(bag, cfg, tmp_path / "out")
    assert (s.commands, s.states, s.zeroed_invalid, s.command_space) == (3, 2, 1, "workspace")
    got = _mcap_messages(tmp_path / "out")["/safe"]
    shaper = parse_shaper(BOX3).shaper
    out = [np.array([m.linear.x, m.linear.y, m.linear.z]) for _, m, _ in got]
    np.testing.assert_array_equal(out[0], shaper.shape([0.9, 0.5, 0.1], [1.0, 0.0, -1.0]))
    np.testing.assert_array_equal(out[1], 0.0)
    np.testing.assert_array_equal(out[2], shaper.shape([0.5, 0.95, 0.5], [0.5, 0.5, 0.5]))
    assert got[0][1].angular.z == 0.3  # the shaper does not touch the rotation
    assert got[1][1].angular.z == 0.0  # a zeroed command stops everything
    assert np.all(np.isfinite(s.commanded))


def test_float64_multiarray_with_sqlite_and_joint_names(tmp_path: Path) -> None:
    names = ["j_b", "extra", "j_a"]
    bag = _write_bag(
        tmp_path / "in",
        {
            "/js": ("sensor_msgs/msg/JointState", [(0.0, _joint_state(names, [0.95, 3.0, -0.5]))]),
            "/vel": (
                "std_msgs/msg/Float64MultiArray",
                [(0.1, _array([0.3, 0.7])), (0.2, _array([-0.3, -0.2]))],
            ),
        },
        fmt="sqlite3",
    )
    cfg = {
        "shaper": JOINTS,
        "replay": {"command_topic": "/vel", "state_topic": "/js", "joint_names": ["j_a", "j_b"]},
    }
    s = replay(bag, cfg, tmp_path / "out")
    got = _rosbags_messages(tmp_path / "out")["/vel_shaped"]
    shaper = parse_shaper(JOINTS).shaper
    for (_, m, _), v in zip(got, ([0.3, 0.7], [-0.3, -0.2]), strict=True):
        np.testing.assert_array_equal(m.data, shaper.shape([-0.5, 0.95], v))
    assert s.changed == 1  # b is braked near its upper limit; the second command moves away


# ------------------------------------------------------------------------------ refusals


def _cfg(**replay_fields: Any) -> dict[str, Any]:
    return {
        "shaper": JOINTS,
        "replay": {"command_topic": "/vel", "state_topic": "/js", **replay_fields},
    }


@pytest.fixture
def joint_bag(tmp_path: Path) -> Path:
    return _write_bag(
        tmp_path / "in",
        {
            "/js": ("sensor_msgs/msg/JointState", [(0.0, _joint_state(["a", "b"], [0.0, 0.0]))]),
            "/vel": ("std_msgs/msg/Float64MultiArray", [(0.1, _array([0.3, 0.7, 0.1]))]),
            "/twist": ("geometry_msgs/msg/Twist", [(0.1, _twist([0, 0, 0]))]),
        },
    )


def test_wrong_joint_count_names_the_topic(joint_bag: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"topic /vel: expected 2 values in data.*got 3"):
        replay(joint_bag, _cfg(), tmp_path / "out")
    assert not (tmp_path / "out").exists()  # nothing half-written left behind


def test_missing_joint_in_state_names_the_topic(joint_bag: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"topic /js: expected a JointState.*\['a', 'zz'\]"):
        replay(joint_bag, _cfg(joint_names=["a", "zz"]), tmp_path / "out")


def test_missing_topic_is_named(joint_bag: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"replay.state_topic /joints: not in bag"):
        replay(joint_bag, _cfg(state_topic="/joints"), tmp_path / "out")


def test_wrong_message_type_is_named(joint_bag: Path, tmp_path: Path) -> None:
    with pytest.raises(
        InvalidParameter, match=r"command_topic /twist: has type geometry_msgs/msg/Twist"
    ):
        replay(joint_bag, _cfg(command_topic="/twist"), tmp_path / "out")


def test_existing_output_topic_and_out_are_refused(joint_bag: Path, tmp_path: Path) -> None:
    with pytest.raises(InvalidParameter, match=r"output_topic /twist: bag .* has that topic"):
        replay(joint_bag, _cfg(output_topic="/twist"), tmp_path / "out")
    (tmp_path / "out").mkdir()
    with pytest.raises(InvalidParameter, match="exists already"):
        replay(joint_bag, _cfg(), tmp_path / "out")


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"speed": 1}, r"section replay.speed: Extra inputs"),
        ({"output_topic": "/vel"}, "must differ"),
        ({"max_state_age": -1.0}, r"section replay.max_state_age"),
        ({"command_topic": "no slash"}, r"section replay.command_topic"),
    ],
)
def test_bad_replay_section(
    joint_bag: Path, tmp_path: Path, fields: dict[str, Any], match: str
) -> None:
    with pytest.raises(InvalidParameter, match=match):
        replay(joint_bag, _cfg(**fields), tmp_path / "out")


def test_config_file_needs_both_sections(joint_bag: Path, tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("shaper:\n  kind: polygon\n  corners: [[0, 0], [1, 0], [0, 1]]\n  buffer: 0.1\n")
    with pytest.raises(InvalidParameter, match=r"missing section\(s\) \['replay'\]"):
        replay(joint_bag, cfg, tmp_path / "out")


def test_malformed_bags_are_refused(examples: Path, tmp_path: Path) -> None:
    src = examples / "mobile_base"
    cfg = src / "replay.yaml"
    with pytest.raises(InvalidParameter, match=r"no metadata\.yaml and 0 \.mcap/\.db3 files"):
        replay(tmp_path, cfg, tmp_path / "out")
    (tmp_path / "notes.txt").write_text("not a bag\n")
    with pytest.raises(InvalidParameter, match=r"got the file .*notes\.txt"):
        replay(tmp_path / "notes.txt", cfg, tmp_path / "out")
    broken = tmp_path / "broken"
    shutil.copytree(src / "bag", broken)
    (broken / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9}\n")
    with pytest.raises(InvalidParameter, match=f"bag {broken}: unreadable metadata.yaml"):
        replay(broken, cfg, tmp_path / "out")
    truncated = tmp_path / "truncated"
    shutil.copytree(src / "bag", truncated)
    data = (truncated / "bag.mcap").read_bytes()
    (truncated / "bag.mcap").write_bytes(data[: len(data) // 2])
    with pytest.raises(InvalidParameter, match=f"bag {truncated}: cannot"):
        replay(truncated, cfg, tmp_path / "out")
    assert not (tmp_path / "out").exists()


# --------------------------------------------------------------------------- plot and CLI


def test_plot_and_cli(examples: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    from typer.testing import CliRunner

    from velfence.apps.cli import app
    from velfence.apps.viz.replay import plot_replay

    src = examples / "mobile_base"
    args = ["replay", str(src / "bag"), "--config", str(src / "replay.yaml"), "--out"]
    result = CliRunner().invoke(
        app, [*args, str(tmp_path / "o"), "--plot", str(tmp_path / "p.png")]
    )
    assert result.exit_code == 0, result.output
    assert "120 commands on /cmd_vel" in result.output
    assert "1 before any state, 4 with a stale state" in result.output
    assert (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = CliRunner().invoke(app, [*args, str(tmp_path / "o")])
    assert again.exit_code == 2
    assert "exists already" in again.output
    helped = CliRunner().invoke(app, ["replay", "--help"])
    assert helped.exit_code == 0
    assert all(w in helped.stdout for w in ("--config", "--out", "--plot", "--storage"))
    bad = CliRunner().invoke(app, [*args, str(tmp_path / "o3"), "--storage", "rosbag1"])
    assert bad.exit_code == 2
    assert "storage" in bad.output
    assert not (tmp_path / "o3").exists()
    with pytest.raises(InvalidInput, match="summary"):
        plot_replay("not a summary", tmp_path / "x.png")  # type: ignore[arg-type]
    assert isinstance(replay(src / "bag", src / "replay.yaml", tmp_path / "o2"), ReplaySummary)


def test_twist_mode_safety_filter_writes_the_tcp_twist(tmp_path: Path) -> None:
    pytest.importorskip("mujoco")
    section = {
        "kind": "safety_filter",
        "robot": "panda",
        "mode": "twist",
        "max_speed": 2.0,
        "workspace": {"lower": [0.3, -0.3, 0.2], "upper": [0.5, 0.3, 0.6], "buffer": 0.05},
        "dt": 0.002,
    }
    cs = parse_shaper(section)
    assert cs.joint_names is not None
    q = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8]  # TCP at x = 0.474 m, in the buffer of x_max
    T = _types()
    H, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    stamped = T["geometry_msgs/msg/TwistStamped"](
        header=H(stamp=Time(sec=0, nanosec=1), frame_id="world"), twist=_twist([0.1, 0.05, 0.0])
    )
    bag = _write_bag(
        tmp_path / "in",
        {
            "/js": ("sensor_msgs/msg/JointState", [(0.0, _joint_state(list(cs.joint_names), q))]),
            "/servo": ("geometry_msgs/msg/TwistStamped", [(0.1, stamped)]),
        },
    )
    cfg = {"shaper": section, "replay": {"command_topic": "/servo", "state_topic": "/js"}}
    s = replay(bag, cfg, tmp_path / "out")
    ((_, out, _),) = _mcap_messages(tmp_path / "out")["/servo_shaped"]
    qdot = cs.shaper.shape(q, [0.1, 0.05, 0.0])
    robot = cs.shaper.filter.robot
    lin = np.array([out.twist.linear.x, out.twist.linear.y, out.twist.linear.z])
    ang = np.array([out.twist.angular.x, out.twist.angular.y, out.twist.angular.z])
    np.testing.assert_array_equal(lin, robot.jacobian(q) @ qdot)
    np.testing.assert_array_equal(ang, robot.angular_jacobian(q) @ qdot)
    assert (s.command_space, s.components) == ("twist", ("vx", "vy", "vz"))
    assert lin[0] < 0.1  # the approach to the x_max face is braked


def test_bag_without_message_definitions(examples: Path, tmp_path: Path) -> None:
    """An older bag carries no definitions: the distro's (plus JointJog's) are used."""
    import sqlite3

    src = examples / "arm_jog"
    bag = tmp_path / "old"
    shutil.copytree(src / "bag", bag)
    with sqlite3.connect(bag / "bag.db3") as db:
        db.execute("DELETE FROM message_definitions")
    db.close()
    a = replay(src / "bag", src / "replay.yaml", tmp_path / "a")
    b = replay(bag, src / "replay.yaml", tmp_path / "b", storage="mcap")
    np.testing.assert_array_equal(a.shaped, b.shaped)
    got = _mcap_messages(tmp_path / "b")  # the output carries definitions again (mcap decodes)
    assert len(got["/servo/delta_joint_cmds_shaped"]) == 160


def _odom(x: float, y: float, yaw: float) -> Any:
    T = _types()
    H, Time = T["std_msgs/msg/Header"], T["builtin_interfaces/msg/Time"]
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
        orientation=T["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=float(np.sin(yaw / 2)), w=float(np.cos(yaw / 2))
        ),
    )
    return T["nav_msgs/msg/Odometry"](
        header=H(stamp=Time(sec=0, nanosec=0), frame_id="odom"),
        child_frame_id="base_link",
        pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=_twist([0.0, 0.0, 0.0]), covariance=np.zeros(36)
        ),
    )


def test_body_frame_command_is_turned_by_the_heading(tmp_path: Path) -> None:
    """A base facing +y (yaw 90°) near the north wall, driving forward (body vx) into it."""
    room = {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5}
    yaw = 1.2  # [rad]
    bag = _write_bag(
        tmp_path / "in",
        {
            "/odom": ("nav_msgs/msg/Odometry", [(0.0, _odom(2.0, 2.8, yaw))]),
            "/cmd_vel": ("geometry_msgs/msg/Twist", [(0.1, _twist([0.5, 0.1, 0.0]))]),
        },
    )
    section = {"command_topic": "/cmd_vel", "state_topic": "/odom"}
    body = replay(
        bag, {"shaper": room, "replay": {**section, "command_frame": "body"}}, tmp_path / "b"
    )
    world = replay(bag, {"shaper": room, "replay": section}, tmp_path / "w")
    ((_, out, _),) = _mcap_messages(tmp_path / "b")["/cmd_vel_shaped"]
    c, s = np.cos(yaw), np.sin(yaw)
    R = np.array([[c, -s], [s, c]])  # body -> odom
    v_world = R @ np.array([0.5, 0.1])
    expected = R.T @ parse_shaper(room).shaper.shape([2.0, 2.8], v_world)
    np.testing.assert_allclose([out.linear.x, out.linear.y], expected, rtol=0, atol=1e-15)
    # In the room's frame: the motion along the wall is kept, the approach to it (0.2 m into
    # the 0.5 m buffer) is braked to well under half.
    shaped_world = R @ np.array([out.linear.x, out.linear.y])
    assert shaped_world[0] == pytest.approx(v_world[0], rel=1e-12)
    assert 0 < shaped_world[1] < 0.5 * v_world[1]
    assert not np.allclose(body.shaped, world.shaped)
    with pytest.raises(InvalidParameter, match=r"section replay.command_frame: 'body' applies"):
        replay(
            bag, {"shaper": BOX3, "replay": {**section, "command_frame": "body"}}, tmp_path / "x"
        )
