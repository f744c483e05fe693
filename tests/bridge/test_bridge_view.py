"""The bridge's live view: ``view_hook`` and ``velfence bridge --foxglove/--record``.

The hook is fed a bridge's real cycles (a ROS 2 peer in another process sends the commands) and
the view's MCAP recording is read back with the ``mcap`` reader: one status message per shown
command, the zone the node reported, nothing for a fail-safe cycle without a state.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from mcap.reader import make_reader
from setups import POLYGON

from conftest import DOMAIN, LOOPBACK, SRC, run_client
from velfence.bridge import EXIT_CONFIG, EXIT_OK, FoxgloveView, view_hook
from velfence.bridge.foxglove import SCENE_TOPIC, STATUS_TOPIC, VELOCITY_TOPIC
from velfence.errors import InvalidParameter
from velfence.geometry.polygon import ConvexPolygon

DEEP = {"profile": "default", "depth": 1000}


def _messages(path: Path, topic: str) -> list[dict]:
    with path.open("rb") as f:
        return [
            json.loads(m.data)
            for _s, c, m in make_reader(f).iter_messages(log_time_order=True)
            if c.topic == topic
        ]


def test_hook_skips_stateless_cycles_and_zero_fills_watchdog_zeros(tmp_path: Path) -> None:
    path = tmp_path / "view.mcap"
    fence = ConvexPolygon(POLYGON["corners"])
    with FoxgloveView(port=None, record=path, fence=fence) as view:
        hook = view_hook(view)
        z = np.zeros(2)
        hook(SimpleNamespace(t=10.0, state=None, command=None, shaped=z, zone="held", active=()))
        hook(
            SimpleNamespace(
                t=10.5,
                state=np.array([3.8, 1.0]),
                command=np.array([1.0, 0.0]),
                shaped=np.array([0.4, 0.0]),
                zone="buffer",
                active=("e1",),
            )
        )
        hook(
            SimpleNamespace(
                t=10.7, state=np.array([3.9, 1.0]), command=None, shaped=z, zone="held", active=()
            )
        )
    status = _messages(path, STATUS_TOPIC)
    assert [s["zone"] for s in status] == ["buffer", "held"]
    assert [s["t"] for s in status] == pytest.approx([0.0, 0.2])  # from the first shown cycle
    assert status[0]["changed_by"] == pytest.approx(0.6)
    assert status[1]["changed_by"] == 0.0  # a watchdog zero against a zero command
    velocity = _messages(path, VELOCITY_TOPIC)
    assert velocity[1]["command"] == [0.0, 0.0]


def test_hook_refuses_a_closed_view(tmp_path: Path) -> None:
    view = FoxgloveView(port=None, record=tmp_path / "v.mcap")
    view.close()
    with pytest.raises(InvalidParameter, match="view"):
        view_hook(view)


def test_a_bridge_records_every_command_it_publishes(bridge, tmp_path: Path) -> None:
    path = tmp_path / "bridge.mcap"
    view = FoxgloveView(port=None, record=path, fence=ConvexPolygon(POLYGON["corners"]))
    b = bridge(
        {
            "command_in": {"topic": "cmd_in", "type": "twist_stamped", "qos": DEEP},
            "command_out": {"topic": "cmd_out", "qos": DEEP},
            "state": {"topic": "pose", "type": "pose_stamped", "qos": "default"},
            "command_frame": "world",
        },
        POLYGON,
        on_cycle=view_hook(view),
    )
    cmds = [[1.0, 0.0], [0.5, 0.5], [-1.0, 0.0], [0.0, -1.0]]
    res = run_client(
        {
            "scenario": "stream",
            "topics": {
                "cmd_in": b.topic("cmd_in"),
                "cmd_out": b.topic("cmd_out"),
                "state": b.topic("pose"),
            },
            "cmd_type": "twist_stamped",
            "out_type": "twist_stamped",
            "state": {"type": "pose_stamped", "values": [3.8, 1.5, 0.0]},
            "commands": [{"values": c} for c in cmds],
            "rate_hz": 50.0,
            "expect": len(cmds),
            "depth": 1000,
        },
        tmp_path,
        bridge=b,
    )
    b.close()
    view.close()
    published = np.array([o["v"][:2] for o in res["outputs"][: len(cmds)]])
    velocity = [v for v in _messages(path, VELOCITY_TOPIC) if v["command"] != [0.0, 0.0]]
    assert len(velocity) == len(cmds)
    np.testing.assert_array_equal(np.array([v["shaped"] for v in velocity]), published)
    np.testing.assert_array_equal(np.array([v["command"] for v in velocity]), np.array(cmds))


def _cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {"PYTHONPATH": str(SRC), "CYCLONEDDS_URI": LOOPBACK, "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-m", "velfence.apps.cli", "bridge", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_cli_records_the_view_and_refuses_twist_mode(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(
        f"bridge:\n  domain_id: {DOMAIN}\n  namespace: /cliview\n  command_in: {{type: twist}}\n"
        "  state: {type: odometry}\n  command_frame: body\n"
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
    )
    ok = _cli(["--config", "b.yaml", "--duration", "0.5", "--record", "v.mcap"], tmp_path)
    assert ok.returncode == EXIT_OK, ok.stderr
    with (tmp_path / "v.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    # No command came: the recording holds the fence's scene only.
    assert {c.topic for c in summary.channels.values()} == {SCENE_TOPIC}
    pytest.importorskip("mujoco")
    (tmp_path / "t.yaml").write_text(
        f"bridge:\n  domain_id: {DOMAIN}\n  command_in: {{type: twist}}\n"
        "  command_out: {type: float64_multi_array}\n  state: {type: joint_state}\n"
        "shaper:\n  kind: safety_filter\n  robot: panda\n  max_speed: 2.0\n  dt: 0.002\n"
    )
    bad = _cli(["--config", "t.yaml", "--record", "w.mcap"], tmp_path)
    assert bad.returncode == EXIT_CONFIG
    assert "twist-mode" in bad.stderr


def test_cli_reads_the_bridge_file_once_for_the_node_and_the_view(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The node and the view run on one loaded configuration: one read of the YAML file."""
    from typer.testing import CliRunner

    import velfence.bridge
    from velfence.apps.cli import app
    from velfence.bridge import BridgeConfig
    from velfence.io import yaml_reader

    (tmp_path / "b.yaml").write_text(
        f"bridge:\n  domain_id: {DOMAIN}\n  command_in: {{type: twist}}\n"
        "  state: {type: odometry}\n  command_frame: body\n"
        "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
    )
    reads: list[Path] = []
    real_read = yaml_reader._read_text  # every YAML file velfence reads passes here

    def counting_read(path, what):
        reads.append(Path(path))
        return real_read(path, what)

    served: list[object] = []

    def fake_serve(config, *, duration=None, on_cycle=None):
        served.append(config)
        assert on_cycle is not None  # the view's hook reaches the node
        return EXIT_OK

    monkeypatch.setattr(yaml_reader, "_read_text", counting_read)
    monkeypatch.setattr(velfence.bridge, "serve", fake_serve)
    res = CliRunner().invoke(
        app,
        ["bridge", "--config", str(tmp_path / "b.yaml"), "--record", str(tmp_path / "v.mcap")],
    )
    assert res.exit_code == EXIT_OK, res.output
    assert reads == [tmp_path / "b.yaml"]
    assert len(served) == 1
    assert isinstance(served[0], BridgeConfig)
