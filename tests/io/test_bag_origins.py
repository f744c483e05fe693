"""Bags of any origin, and bags with nothing to replay.

The same run (Twist commands on ``/cmd_vel``, odometry on ``/odom``) is written here by the
independent writers a user's bag comes from: rosbags' rosbag2 ``Writer`` (MCAP and sqlite3, with
``metadata.yaml``), Foxglove's ``mcap_ros2.writer.Writer`` (channels without
``offered_qos_profiles``, no ``metadata.yaml``) and the ``mcap`` library's own ``Writer``; the
message bytes come from those writers (or rosbags' encoder), never from velfence. Each bag is
given as the writers leave it (a rosbag2 directory, a bare ``.mcap``/``.db3`` file, a folder with
one file) and every replay must give the same shaped commands, which are computed here with a plain
loop (the latest odometry at or before each command) and ``shaper.shape``; the MCAP outputs are
read back with the ``mcap`` reader and ``mcap_ros2``'s decoder.
"""

from __future__ import annotations

import copy
import dataclasses
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

pytest.importorskip("rosbags")
pytest.importorskip("mcap_ros2")

from velfence.errors import InvalidParameter, NothingToReplay
from velfence.io import parse_shaper
from velfence.io.bags import replay

NS = 10**9
T0 = 1_700_000_000 * NS
TWIST = "geometry_msgs/msg/Twist"
ODOM = "nav_msgs/msg/Odometry"
CONFIG: dict[str, Any] = {
    "shaper": {"kind": "polygon", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]], "buffer": 0.5},
    "replay": {"command_topic": "/cmd_vel", "state_topic": "/odom"},
}
# Foxglove Studio / rosbag2 record QoS like this in metadata.yaml (Jazzy's list form).
QOS = [
    {
        "history": "keep_last",
        "depth": 10,
        "reliability": "reliable",
        "durability": "volatile",
        "deadline": {"sec": 9223372036, "nsec": 854775807},
        "lifespan": {"sec": 9223372036, "nsec": 854775807},
        "liveliness": "automatic",
        "liveliness_lease_duration": {"sec": 9223372036, "nsec": 854775807},
        "avoid_ros_namespace_conventions": False,
    }
]


def _run() -> list[tuple[str, int, dict[str, Any]]]:
    """(topic, time ns, message as a plain dict): 30 commands, odometry 50 ms after each but the
    first, so the first command has no state; the base drives toward the east wall."""
    out: list[tuple[str, int, dict[str, Any]]] = []
    for k in range(30):
        t = T0 + k * NS // 10
        out.append(
            (
                "/cmd_vel",
                t,
                {
                    "linear": {"x": 0.5 + 0.01 * k, "y": 0.1, "z": 0.0},
                    "angular": {"x": 0.0, "y": 0.0, "z": 0.2},
                },
            )
        )
        ts = t + NS // 20
        pose = {
            "position": {"x": 2.8 + 0.05 * k, "y": 1.5, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        }
        out.append(
            (
                "/odom",
                ts,
                {
                    "header": {
                        "stamp": {"sec": ts // NS, "nanosec": ts % NS},
                        "frame_id": "odom" + "x" * (k % 5),  # every alignment of what follows
                    },
                    "child_frame_id": "base_link",
                    "pose": {"pose": pose, "covariance": [0.0] * 36},
                    "twist": {
                        "twist": {
                            "linear": {"x": 0.0, "y": 0.0, "z": 0.0},
                            "angular": {"x": 0.0, "y": 0.0, "z": 0.0},
                        },
                        "covariance": [0.0] * 36,
                    },
                },
            )
        )
    return sorted(out, key=lambda m: m[1])


def _typestore() -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _rosbags_msg(ts: Any, msgtype: str, d: dict[str, Any]) -> Any:
    """A rosbags message object from a plain dict (recursively, by the type's fields)."""
    cls = ts.types[msgtype]
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.name == "__msgtype__":
            continue
        value = d[f.name]
        sub = ts.fielddefs[msgtype][1]
        kind = dict(sub)[f.name]
        if isinstance(value, dict):
            kwargs[f.name] = _rosbags_msg(ts, kind[1], value)
        elif isinstance(value, list):
            kwargs[f.name] = np.array(value, dtype=float)
        else:
            kwargs[f.name] = value
    return cls(**kwargs)


def _msgtype(topic: str) -> str:
    return TWIST if topic == "/cmd_vel" else ODOM


# ------------------------------------------------------------------------------ the writers


def _rosbags_bag(folder: Path, storage: str) -> Path:
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = _typestore()
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(folder, version=9, storage_plugin=plugin) as w:
        conns = {
            topic: w.add_connection(topic, _msgtype(topic), typestore=ts)
            for topic in ("/cmd_vel", "/odom")
        }
        for topic, t, d in _run():
            raw = ts.serialize_cdr(_rosbags_msg(ts, _msgtype(topic), d), _msgtype(topic))
            w.write(conns[topic], t, raw)
    return folder


def _foxglove_mcap(path: Path, run: list[tuple[str, int, dict[str, Any]]] | None = None) -> Path:
    """Foxglove's writer: ros2msg schemas, CDR by mcap_ros2's encoder, no QoS metadata."""
    from mcap_ros2.writer import Writer

    ts = _typestore()
    with path.open("wb") as f:
        w = Writer(f)
        schemas = {
            t: w.register_msgdef(t, ts.generate_msgdef(t, ros_version=2)[0]) for t in (TWIST, ODOM)
        }
        for topic, t, d in _run() if run is None else run:
            w.write_message(topic, schemas[_msgtype(topic)], d, log_time=t, publish_time=t)
        w.finish()
    return path


def _mcap_library(path: Path) -> Path:
    """The mcap library's own writer (lz4 chunks), CDR bytes from rosbags' encoder."""
    from mcap.writer import CompressionType, Writer

    ts = _typestore()
    with path.open("wb") as f:
        w = Writer(f, compression=CompressionType.LZ4)
        w.start(profile="ros2", library="test")
        channels = {}
        for topic in ("/cmd_vel", "/odom"):
            msgtype = _msgtype(topic)
            schema = w.register_schema(
                msgtype, "ros2msg", ts.generate_msgdef(msgtype, ros_version=2)[0].encode()
            )
            channels[topic] = w.register_channel(topic, "cdr", schema)
        for topic, t, d in _run():
            raw = ts.serialize_cdr(_rosbags_msg(ts, _msgtype(topic), d), _msgtype(topic))
            w.add_message(channels[topic], log_time=t, data=bytes(raw), publish_time=t)
        w.finish()
    return path


def _metadata_with_qos(folder: Path, mcap_name: str) -> None:
    """A rosbag2 metadata.yaml whose topics declare QoS profiles the MCAP channels lack."""
    run = _run()
    topics = []
    for topic in ("/cmd_vel", "/odom"):
        topics.append(
            {
                "topic_metadata": {
                    "name": topic,
                    "type": _msgtype(topic),
                    "serialization_format": "cdr",
                    "offered_qos_profiles": copy.deepcopy(QOS),  # no YAML anchors
                    "type_description_hash": "",
                },
                "message_count": sum(1 for m in run if m[0] == topic),
            }
        )
    info = {
        "version": 9,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": run[-1][1] - run[0][1]},
        "starting_time": {"nanoseconds_since_epoch": run[0][1]},
        "message_count": len(run),
        "topics_with_message_count": topics,
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [mcap_name],
        "files": [],
        "custom_data": None,
        "ros_distro": "jazzy",
    }
    text = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)
    (folder / "metadata.yaml").write_text(text)


def _origins(root: Path) -> dict[str, Path]:
    bags = {
        "rosbags mcap": _rosbags_bag(root / "rosbags_mcap", "mcap"),
        "rosbags sqlite3": _rosbags_bag(root / "rosbags_sqlite3", "sqlite3"),
    }
    (db3,) = (root / "rosbags_sqlite3").glob("*.db3")
    bags["bare .db3"] = db3
    bags["foxglove .mcap"] = _foxglove_mcap(root / "foxglove.mcap")
    (root / "foxglove_folder").mkdir()
    bags["foxglove folder"] = root / "foxglove_folder"
    shutil.copy(root / "foxglove.mcap", root / "foxglove_folder" / "run.mcap")
    (root / "foxglove_metadata").mkdir()
    shutil.copy(root / "foxglove.mcap", root / "foxglove_metadata" / "run_0.mcap")
    _metadata_with_qos(root / "foxglove_metadata", "run_0.mcap")
    bags["foxglove + metadata with QoS"] = root / "foxglove_metadata"
    bags["mcap library"] = _mcap_library(root / "mcap_library.mcap")
    return bags


@pytest.fixture(scope="module")
def origins(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return _origins(tmp_path_factory.mktemp("origins"))


def _expected() -> tuple[np.ndarray, np.ndarray, int]:
    """Commands and shaped commands by a plain loop and shaper.shape; the zeroed count."""
    shaper = parse_shaper(CONFIG["shaper"]).shaper
    held = None
    cmds, shaped, zeroed = [], [], 0
    for topic, _, d in _run():
        if topic == "/odom":
            p = d["pose"]["pose"]["position"]
            held = np.array([p["x"], p["y"]])
            continue
        v = np.array([d["linear"]["x"], d["linear"]["y"]])
        cmds.append(v)
        if held is None:
            shaped.append(np.zeros(2))
            zeroed += 1
        else:
            shaped.append(shaper.shape(held, v))
    return np.array(cmds), np.array(shaped), zeroed


def _read_mcap(folder: Path) -> dict[str, list[Any]]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (path,) = folder.glob("*.mcap")
    out: dict[str, list[Any]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append(decoded)
    return out


@pytest.mark.parametrize(
    "origin",
    [
        "rosbags mcap",
        "rosbags sqlite3",
        "bare .db3",
        "foxglove .mcap",
        "foxglove folder",
        "foxglove + metadata with QoS",
        "mcap library",
    ],
)
def test_every_origin_gives_the_same_shaped_commands(
    origin: str, origins: dict[str, Path], tmp_path: Path
) -> None:
    cmds, shaped, zeroed = _expected()
    s = replay(origins[origin], CONFIG, tmp_path / "out", storage="mcap")
    assert (s.commands, s.states, s.zeroed_no_state, s.zeroed) == (30, 30, zeroed, zeroed)
    np.testing.assert_array_equal(s.commanded, cmds)
    np.testing.assert_array_equal(s.shaped, shaped)  # bit for bit
    np.testing.assert_allclose(s.times, 0.1 * np.arange(30), rtol=0, atol=1e-12)
    assert s.changed > 10  # the wall is in the way: the run is worth replaying
    got = _read_mcap(tmp_path / "out")
    assert len(got["/cmd_vel"]) == len(got["/odom"]) == len(got["/cmd_vel_shaped"]) == 30
    out = np.array([[m.linear.x, m.linear.y] for m in got["/cmd_vel_shaped"]])
    np.testing.assert_array_equal(out, shaped)
    # The fields the shaper does not use are the command's own; a zeroed twist stops rotating.
    wz = [m.angular.z for m in got["/cmd_vel_shaped"]]
    assert wz == [0.0] + [0.2] * 29


def test_metadata_counts_are_reported_when_the_storage_holds_nothing(tmp_path: Path) -> None:
    # metadata.yaml lists 60 messages; the MCAP it names holds none: the error says both.
    folder = tmp_path / "hollow"
    folder.mkdir()
    _foxglove_mcap(folder / "run_0.mcap", run=[])
    _metadata_with_qos(folder, "run_0.mcap")
    with pytest.raises(NothingToReplay) as err:
        replay(folder, CONFIG, tmp_path / "out")
    text = str(err.value)
    assert "the bag holds no topic" in text or "no messages" in text
    assert "metadata.yaml lists 60 messages" in text
    assert "/cmd_vel (geometry_msgs/msg/Twist or geometry_msgs/msg/TwistStamped)" in text
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------- nothing to replay


def _bag_of(
    folder: Path,
    run: list[tuple[str, int, dict[str, Any]]],
    topics: list[str],
    rename: dict[str, str] | None = None,
) -> Path:
    """A rosbags MCAP bag of ``run`` with the connections ``topics`` (optionally renamed)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = _typestore()
    names = rename or {}
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {t: w.add_connection(names.get(t, t), _msgtype(t), typestore=ts) for t in topics}
        for topic, t, d in run:
            raw = ts.serialize_cdr(_rosbags_msg(ts, _msgtype(topic), d), _msgtype(topic))
            w.write(conns[topic], t, raw)
    return folder


@pytest.mark.parametrize(
    ("case", "match"),
    [
        ("empty", r"command_topic /cmd_vel: not in bag .*the bag holds no topic"),
        ("no command topic", r"not in bag .*: /odom \(nav_msgs/msg/Odometry, 30 messages\)"),
        ("no command message", r"no message on /cmd_vel; .*Twist, 0 messages\)"),
        ("commands before states", r"of 30 commands, 30 came before the first state"),
        ("other names", r"commands on /cmd_vel .*/robot/cmd \(geometry_msgs/msg/Twist, 30 "),
    ],
)  # fmt: skip
def test_nothing_to_replay_names_what_the_bag_holds(case: str, match: str, tmp_path: Path) -> None:
    run = _run()
    cmds = [m for m in run if m[0] == "/cmd_vel"]
    odom = [m for m in run if m[0] == "/odom"]
    both = ["/cmd_vel", "/odom"]
    bag = tmp_path / "bag"
    if case == "empty":
        _bag_of(bag, [], [])
    elif case == "no command topic":
        _bag_of(bag, odom, ["/odom"])
    elif case == "no command message":
        _bag_of(bag, odom, both)
    elif case == "commands before states":
        late = [(topic, t + 10 * NS, d) for topic, t, d in odom]
        _bag_of(bag, sorted(cmds + late, key=lambda m: m[1]), both)
    else:  # the bag names its topics otherwise than the config
        _bag_of(bag, run, both, rename={"/cmd_vel": "/robot/cmd", "/odom": "/robot/odom"})
    with pytest.raises(NothingToReplay, match=match):
        replay(bag, CONFIG, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_stale_states_only_is_nothing_to_replay(tmp_path: Path) -> None:
    run = _run()
    bag = _bag_of(tmp_path / "bag", run, ["/cmd_vel", "/odom"])
    cfg = {**CONFIG, "replay": {**CONFIG["replay"], "max_state_age": 0.01}}  # odom is 50 ms old
    with pytest.raises(NothingToReplay, match=r"29 had a state older than max_state_age=0.01 s"):
        replay(bag, cfg, tmp_path / "out")
    # A missing topic is still an InvalidParameter for code that caught that before.
    assert issubclass(NothingToReplay, InvalidParameter)


def test_folder_with_several_storage_files_is_refused(
    origins: dict[str, Path], tmp_path: Path
) -> None:
    shutil.copy(origins["foxglove .mcap"], tmp_path / "a.mcap")
    shutil.copy(origins["foxglove .mcap"], tmp_path / "b.mcap")
    with pytest.raises(
        InvalidParameter,
        match=r"2 \.mcap/\.db3 files \(\['a.mcap', 'b.mcap'\]; give each as its own bag\)",
    ):
        replay(tmp_path, CONFIG, tmp_path / "out")


# ------------------------------------------------------------------------------- the command


def test_cli_exit_codes_and_several_bags(origins: dict[str, Path], tmp_path: Path) -> None:
    pytest.importorskip("typer")
    from typer.testing import CliRunner

    from velfence.apps.cli import app

    cfg = tmp_path / "replay.yaml"
    cfg.write_text(yaml.safe_dump(CONFIG))
    empty = _bag_of(tmp_path / "empty", [], [])
    run = CliRunner()
    one = run.invoke(
        app, ["replay", str(empty), "--config", str(cfg), "--out", str(tmp_path / "o")]
    )
    assert one.exit_code == 4, one.output
    assert "the bag holds no topic" in one.output
    assert not (tmp_path / "o").exists()
    good = run.invoke(
        app,
        [
            "replay",
            str(origins["foxglove .mcap"]),
            "--config",
            str(cfg),
            "--out",
            str(tmp_path / "g"),
        ],
    )
    assert good.exit_code == 0, good.output
    assert "30 commands on /cmd_vel" in good.output
    # Several bags: one output each under --out, one table, the largest exit code.
    bags = [origins["rosbags sqlite3"], origins["foxglove .mcap"], origins["bare .db3"], empty]
    many = run.invoke(
        app, ["replay", *map(str, bags), "--config", str(cfg), "--out", str(tmp_path / "many")]
    )
    assert many.exit_code == 4, many.output
    rows = [line for line in many.stdout.splitlines() if line.startswith("│")]
    assert len(rows) == 4
    cmds, shaped, zeroed = _expected()
    diff = np.abs(cmds - shaped)
    changed = np.count_nonzero((diff > 1e-9).any(axis=1))
    want = ["30", f"{100 * changed / 30:.1f} %", f"{diff.max():.4g} m/s", str(zeroed), "ok"]
    for row in rows[:3]:
        assert [c.strip() for c in row.strip("│").split("│")][1:] == want
    assert "nothing to replay (exit 4)" in rows[3]
    assert "the bag holds no topic" in many.stdout
    assert "summary: 3 of 4 bags replayed — exit 4" in many.stdout
    # Each output is named after its bag; the two named rosbags_sqlite3 get their folders' names.
    outs = sorted(p.name for p in (tmp_path / "many").iterdir())
    db3_parent = origins["rosbags sqlite3"].parent.name
    assert outs == sorted(
        ["foxglove", f"{db3_parent}_rosbags_sqlite3", "rosbags_sqlite3_rosbags_sqlite3"]
    )
    for out in (tmp_path / "many").iterdir():
        assert (out / "metadata.yaml").is_file()
    # A bad config is one error (code 2) before any bag is read.
    bad = tmp_path / "bad.yaml"
    bad.write_text("shaper: {kind: polygon}\n")
    refused = run.invoke(
        app, ["replay", *map(str, bags[:2]), "--config", str(bad), "--out", str(tmp_path / "x")]
    )
    assert refused.exit_code == 2
    assert "missing section(s) ['replay']" in refused.output
    assert not (tmp_path / "x").exists()
