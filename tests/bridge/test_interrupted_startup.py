"""Ctrl-C while ``velfence bridge`` starts: one line and exit 130, no traceback.

Sending SIGINT to a real process at a given moment of its start-up is a race, so the start-up
steps are replaced by ones that raise :class:`KeyboardInterrupt` (what Python does on SIGINT
while no handler of the node is installed yet).
"""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

import velfence.bridge
from velfence.apps.cli import EXIT_INTERRUPTED_CODE, app
from velfence.bridge import EXIT_INTERRUPTED, node, serve

CONFIG = (
    "bridge:\n  command_in: {type: twist}\n  state: {type: odometry}\n  command_frame: body\n"
    "shaper:\n  kind: polygon\n  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]\n  buffer: 0.5\n"
)


def _interrupt(*_args: Any, **_kwargs: Any) -> Any:
    raise KeyboardInterrupt


def _write(tmp_path: Path) -> Path:
    p = tmp_path / "b.yaml"
    p.write_text(CONFIG, encoding="utf-8")
    return p


def test_the_cli_exit_code_is_the_bridges() -> None:
    assert EXIT_INTERRUPTED == EXIT_INTERRUPTED_CODE == 128 + signal.SIGINT


@pytest.mark.parametrize("step", ["load_bridge_config", "serve"])
def test_cli_ctrl_c_during_start_up(step: str, tmp_path: Path, monkeypatch: Any) -> None:
    monkeypatch.setattr(velfence.bridge, step, _interrupt)
    res = CliRunner().invoke(app, ["bridge", "--config", str(_write(tmp_path))])
    text = res.output + (getattr(res, "stderr", "") or "")
    assert res.exit_code == EXIT_INTERRUPTED, text
    assert "interrupted during start-up" in text
    assert "Traceback" not in text
    assert not isinstance(res.exception, KeyboardInterrupt)


def test_serve_ctrl_c_while_the_node_is_built(tmp_path: Path, monkeypatch: Any) -> None:
    before = signal.getsignal(signal.SIGINT)
    monkeypatch.setattr(node, "BridgeNode", _interrupt)
    code = serve(_write(tmp_path))
    assert code == EXIT_INTERRUPTED
    assert signal.getsignal(signal.SIGINT) is before  # nothing of the node left installed
