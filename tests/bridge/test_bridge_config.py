"""The bridge file: every field validated and named, the topics' types checked against the
shaper, the ROS 2 QoS profiles, and ``velfence bridge``'s exit codes and clean stop."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from setups import POLYGON

from conftest import DOMAIN, LOOPBACK, SRC
from velfence.bridge import (
    EXIT_CONFIG,
    EXIT_DDS,
    EXIT_OK,
    BridgeNode,
    load_bridge_config,
    msgs,
    parse_bridge_config,
    ros_qos,
)
from velfence.bridge.config import QosSettings
from velfence.errors import InvalidParameter

JOINTS = {
    "kind": "joint_limits",
    "joint_names": ["a", "b"],
    "lower": [-1.0, -1.0],
    "upper": [1.0, 1.0],
    "buffer": 0.1,
}
BOX3 = {"kind": "polytope", "lower": [0, 0, 0], "upper": [1, 1, 1], "buffer": 0.1}
PLANE = {
    "command_in": {"type": "twist"},
    "state": {"topic": "/odom", "type": "odometry"},
    "command_frame": "body",
}


def _parse(bridge: Any, shaper: Any = POLYGON) -> Any:
    return parse_bridge_config({"bridge": bridge, "shaper": shaper}, source="t.yaml")


def test_defaults_and_resolution() -> None:
    cfg = _parse(PLANE)
    s = cfg.settings
    assert (s.incoming_command_timeout, s.state_timeout, s.watchdog_period) == (0.1, 0.5, 0.05)
    assert cfg.output_type == "twist"  # "same" resolved
    assert s.state.qos.profile == "sensor_data"
    assert s.command_in.qos.profile == "default"
    assert cfg.joint_names is None
    assert cfg.dds_topics == {
        "command_in": "rt/cmd_vel_in",
        "command_out": "rt/cmd_vel_out",
        "state": "rt/odom",
        "diagnostics": "rt/diagnostics",
    }
    ns = _parse({**PLANE, "namespace": "/robot1"})
    assert ns.dds_topics["command_in"] == "rt/robot1/cmd_vel_in"
    assert ns.dds_topics["state"] == "rt/odom"  # absolute names keep theirs
    j = _parse(
        {"command_in": {"type": "joint_jog"}, "command_out": {"type": "joint_trajectory"}}, JOINTS
    )
    assert j.joint_names == ("a", "b")
    assert j.output_type == "joint_trajectory"


def test_domain_from_ros_domain_id(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "42")
    assert _parse(PLANE).domain_id == 42
    assert _parse({**PLANE, "domain_id": 7}).domain_id == 7
    monkeypatch.setenv("ROS_DOMAIN_ID", "x1")
    with pytest.raises(InvalidParameter, match="ROS_DOMAIN_ID"):
        _parse(PLANE)


@pytest.mark.parametrize(
    ("bridge", "shaper", "named"),
    [
        ({**PLANE, "colour": "red"}, POLYGON, "bridge.colour: Extra inputs"),
        ({**PLANE, "command_in": {"type": "twist", "rate": 3}}, POLYGON, "bridge.command_in.rate"),
        ({**PLANE, "incoming_command_timeout": 0}, POLYGON, "bridge.incoming_command_timeout"),
        ({**PLANE, "incoming_command_timeout": "0.1"}, POLYGON, "bridge.incoming_command_timeout"),
        ({**PLANE, "state_timeout": float("nan")}, POLYGON, "bridge.state_timeout"),
        ({**PLANE, "command_in": {"topic": "cmd vel"}}, POLYGON, "bridge.command_in.topic"),
        ({**PLANE, "command_in": {"topic": "/2cmd"}}, POLYGON, "bridge.command_in.topic"),
        ({**PLANE, "state": {"type": "imu"}}, POLYGON, "bridge.state.type"),
        ({**PLANE, "command_out": {"qos": "fast"}}, POLYGON, "bridge.command_out.qos.profile"),
        ({**PLANE, "command_out": {"qos": {"depth": 0}}}, POLYGON, "bridge.command_out.qos.depth"),
        ({**PLANE, "domain_id": 233}, POLYGON, "bridge.domain_id"),
        ({**PLANE, "command_frame": None}, POLYGON, "bridge.command_frame: required"),
        ({"command_in": {"type": "twist"}}, JOINTS, "bridge.command_in.type"),
        (
            {"state": {"type": "odometry"}, "command_in": {"type": "float64_multi_array"}},
            JOINTS,
            "bridge.state.type",
        ),
        ({**PLANE, "command_out": {"type": "joint_jog"}}, POLYGON, "bridge.command_out.type"),
        (
            {"command_in": {"type": "joint_jog"}, "command_out": {"type": "twist"}},
            JOINTS,
            "bridge.command_out.type",
        ),
        (
            {
                "command_in": {"type": "twist"},
                "state": {"type": "pose_stamped"},
                "command_frame": "body",
            },
            BOX3,
            "bridge.command_frame",
        ),
        (
            {"command_in": {"type": "float64_multi_array"}, "state": {"joint_names": ["x"]}},
            JOINTS,
            "bridge.state.joint_names",
        ),
        (
            {"command_in": {"type": "joint_jog"}, "state": {"joint_names": ["x", "x"]}},
            JOINTS,
            "bridge.state.joint_names",
        ),
        (
            {"command_in": {"type": "float64_multi_array"}, "state": {"joint_names": ["x", "y"]}},
            BOX3,
            "bridge.state.joint_names",
        ),
        (PLANE, {"kind": "polygon", "corners": [[0, 0]], "buffer": 0.5}, "shaper.corners"),
    ],
)
def test_bad_fields_named(bridge: Any, shaper: Any, named: str) -> None:
    with pytest.raises(InvalidParameter, match=named.replace(".", r"\.")) as info:
        _parse(bridge, shaper)
    assert "t.yaml" in str(info.value)


def test_document_level_errors() -> None:
    with pytest.raises(InvalidParameter, match="'shaper' section is missing"):
        parse_bridge_config({"bridge": PLANE})
    with pytest.raises(InvalidParameter, match="unknown section"):
        parse_bridge_config({"bridge": PLANE, "shaper": POLYGON, "robot": {}})
    with pytest.raises(InvalidParameter, match="expected a mapping"):
        parse_bridge_config([1, 2])
    with pytest.raises(InvalidParameter, match="bridge: expected a mapping"):
        parse_bridge_config({"bridge": [1], "shaper": POLYGON})


def test_workspace_with_joint_state_names() -> None:
    cfg = _parse(
        {
            "command_in": {"type": "float64_multi_array"},
            "state": {"type": "joint_state", "joint_names": ["x", "y", "z"]},
            "command_out": {"type": "joint_jog"},
        },
        BOX3,
    )
    assert cfg.joint_names == ("x", "y", "z")


def test_load_bridge_config_file(tmp_path: Path) -> None:
    p = tmp_path / "bridge.yaml"
    p.write_text(
        "bridge:\n  command_in: {type: twist_stamped}\n  state: {type: pose_stamped}\n"
        "  command_frame: world\nshaper:\n  kind: polygon\n"
        "  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n",
        encoding="utf-8",
    )
    assert load_bridge_config(p).shaper.kind == "polygon"
    p.write_text("bridge: &a {}\nshaper: *a\n", encoding="utf-8")
    with pytest.raises(InvalidParameter, match="anchors"):
        load_bridge_config(p)
    with pytest.raises(InvalidParameter, match="cannot read"):
        load_bridge_config(tmp_path / "missing.yaml")


def test_ros_qos_profiles() -> None:
    from cyclonedds.core import Policy

    d = ros_qos(QosSettings(), msgs.Twist)
    assert d[Policy.History] == Policy.History.KeepLast(10)
    assert isinstance(d[Policy.Reliability], Policy.Reliability.Reliable)
    assert d[Policy.Durability] == Policy.Durability.Volatile
    assert d[Policy.Userdata].data.startswith(b"typehash=RIHS01_9c45bf16")
    s = ros_qos(QosSettings(profile="sensor_data"), msgs.JointState)
    assert s[Policy.Reliability] == Policy.Reliability.BestEffort
    assert s[Policy.History] == Policy.History.KeepLast(5)
    o = ros_qos(
        QosSettings(
            profile="sensor_data", depth=50, reliability="reliable", durability="transient_local"
        ),
        msgs.JointState,
    )
    assert o[Policy.History] == Policy.History.KeepLast(50)
    assert isinstance(o[Policy.Reliability], Policy.Reliability.Reliable)
    assert o[Policy.Durability] == Policy.Durability.TransientLocal
    sd = ros_qos(QosSettings(profile="system_default"), msgs.Twist)
    assert Policy.History not in sd
    assert Policy.Reliability not in sd
    with pytest.raises(InvalidParameter, match="settings"):
        ros_qos("default", msgs.Twist)  # type: ignore[arg-type]


def test_node_arguments_checked_before_dds() -> None:
    cfg = _parse(PLANE)
    with pytest.raises(InvalidParameter, match="config"):
        BridgeNode({"bridge": PLANE})  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="on_cycle"):
        BridgeNode(cfg, on_cycle=3)  # type: ignore[arg-type]
    node = BridgeNode(cfg)
    for bad in (0, -1.0, float("nan"), float("inf"), "1", True):
        with pytest.raises(InvalidParameter, match="duration"):
            node.run(duration=bad)  # type: ignore[arg-type]
    assert node.node_state == "starting"  # nothing ran
    with pytest.raises(InvalidParameter, match="timeout"):
        node.wait_ready(float("nan"))


def _cli(args: list[str], cwd: Path) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(SRC), "CYCLONEDDS_URI": LOOPBACK}
    return subprocess.Popen(
        [sys.executable, "-m", "velfence.apps.cli", "bridge", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def test_cli_bad_config_exits_2(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text("bridge: {colour: red}\nshaper: {kind: polygon}\n")
    proc = _cli(["--config", "b.yaml"], tmp_path)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == EXIT_CONFIG
    assert "bridge.colour" in err


def test_cli_runs_and_stops_cleanly_on_sigterm(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(
        f"bridge:\n  domain_id: {DOMAIN}\n  namespace: /cli\n  command_in: {{type: twist}}\n"
        "  state: {type: odometry}\n  command_frame: body\n"
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
    )
    proc = _cli(["--config", "b.yaml"], tmp_path)
    assert proc.stderr is not None
    lines = []
    end = time.monotonic() + 60
    while time.monotonic() < end:
        line = proc.stderr.readline()
        lines.append(line)
        if "waiting_for_state" in line or not line:
            break
    assert any("starting -> waiting_for_state" in x for x in lines), lines
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == EXIT_OK, err
    assert "-> stopped" in err


class _NanShaper:
    """A broken shaper: NaN out (the bridge must never write it)."""

    def explain(self, p, v):  # type: ignore[no-untyped-def]
        import numpy as np

        class R:
            output = np.array([np.nan, 0.0])
            zone = "free"
            active = ()

        return R()


class _Writer:
    def __init__(self) -> None:
        self.written: list[Any] = []

    def write(self, m: Any) -> None:
        self.written.append(m)


def test_a_non_finite_shaper_output_is_never_written(bridge_log: Any) -> None:
    """Without DDS: the node's command path with a shaper that returns NaN."""
    import dataclasses

    import numpy as np

    cfg = _parse({**PLANE, "command_frame": "world"})
    broken = dataclasses.replace(cfg.shaper, shaper=_NanShaper())
    node = BridgeNode(dataclasses.replace(cfg, shaper=broken))
    w = _Writer()
    node._out_writer = w
    node._state, node._state_time = np.array([1.0, 1.0]), time.monotonic()
    cmd = msgs.Twist(linear=msgs.Vector3(x=0.5, y=0.1), angular=msgs.Vector3(z=0.3))
    node._on_command(cmd)
    assert len(w.written) == 1
    out = w.written[0]
    assert (out.linear.x, out.linear.y, out.linear.z, out.angular.z) == (0.0, 0.0, 0.0, 0.0)
    assert node.counters["dropped:output_nonfinite"] == 1
    assert any("non-finite" in r.getMessage() for r in bridge_log.records)


class _SlowFirstCall:
    """A shaper whose first call is slow (an import, a numba compile) and that keeps state."""

    def __init__(self, inner: Any) -> None:
        self.inner, self.calls, self.resets = inner, 0, 0

    def explain(self, p: Any, v: Any) -> Any:
        self.calls += 1
        return self.inner.explain(p, v)

    def reset(self) -> None:
        self.resets += 1


def test_the_shaper_is_warmed_up_before_the_readers_exist() -> None:
    """A cold first call (numba compiling for seconds) once starved a node's first commands:
    the node now calls its shaper once, and resets it, before it opens any reader."""
    import dataclasses

    cfg = _parse({**PLANE, "command_frame": "world"})
    slow = _SlowFirstCall(cfg.shaper.shaper)
    node = BridgeNode(dataclasses.replace(cfg, shaper=dataclasses.replace(cfg.shaper, shaper=slow)))
    seen: list[tuple[int, int, bool]] = []
    opened = node._open

    def spy_open() -> None:
        seen.append((slow.calls, slow.resets, hasattr(node, "_cmd_reader")))
        opened()

    node._open = spy_open  # type: ignore[method-assign]
    node.run(duration=0.05)
    assert seen == [(1, 1, False)]


def test_documented_files_load(tmp_path: Path) -> None:
    """The YAML of docs/bridge.md and examples/bridge.yaml is valid as written."""
    import re
    from importlib.util import find_spec

    import yaml

    root = SRC.parent
    text = (root / "docs" / "bridge.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```yaml\n(.*?)^```", text, re.M | re.S)
    for block in blocks:  # the zone file a bridge file names, beside it
        named = re.match(r"#\s*([\w.-]+\.yaml):", block)
        if named:
            (tmp_path / named[1]).write_text(block, encoding="utf-8")
    bridges = [b for b in blocks if re.search(r"^bridge:", b, re.M)]
    assert len(bridges) == 3
    for block in bridges:
        if "robot: ur5e" in block and find_spec("mujoco") is None:
            continue  # a shipped arm needs the physics extra
        cfg = parse_bridge_config(yaml.safe_load(block), source="docs/bridge.md", base_dir=tmp_path)
        assert cfg.settings.command_in.topic.startswith("/")
    example = load_bridge_config(root / "examples" / "bridge.yaml")
    assert example.settings.command_frame == "body"
    assert example.dds_topics["command_out"] == "rt/cmd_vel"


def test_cli_dds_failure_exits_3(tmp_path: Path) -> None:
    """A Cyclone DDS configuration naming an interface that does not exist: no participant."""
    (tmp_path / "b.yaml").write_text(
        f"bridge:\n  domain_id: {DOMAIN}\n  command_in: {{type: twist}}\n"
        "  state: {type: odometry}\n  command_frame: body\n"
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
    )
    bad = (
        '<CycloneDDS><Domain id="any"><General><Interfaces><NetworkInterface '
        'name="velfence_no_such_if0"/></Interfaces></General></Domain></CycloneDDS>'
    )
    env = {**os.environ, "PYTHONPATH": str(SRC), "CYCLONEDDS_URI": bad}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "velfence.apps.cli",
            "bridge",
            "--config",
            "b.yaml",
            "--duration",
            "1",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == EXIT_DDS, done.stderr
    assert "DDS could not be started" in done.stderr


def test_robot_joint_names_remap_the_shaper_s_joints() -> None:
    # An FR3 publishes fr3_joint1…; the shaper names its joints a, b: the topics use the robot's.
    cfg = _parse(
        {
            "command_in": {"type": "joint_jog"},
            "command_out": {"type": "joint_trajectory"},
            "state": {"type": "joint_state", "joint_names": ["fr3_joint1", "fr3_joint2"]},
        },
        JOINTS,
    )
    assert cfg.joint_names == ("fr3_joint1", "fr3_joint2")
    assert cfg.shaper.joint_names == ("a", "b")
