"""``velfence demo --scenario arm-box``: the option, its errors, and a short run through the CLI."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

for _extra in ("typer", "rich", "matplotlib", "yaml", "qpsolvers"):
    pytest.importorskip(_extra)

from typer.testing import CliRunner  # noqa: E402

import velfence.apps.demo  # noqa: E402
from velfence.apps.cli import app  # noqa: E402

ENV = {"COLUMNS": "200", "NO_COLOR": "1", "TERM": "dumb"}


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_unknown_scenario_is_refused(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["demo", "--scenario", "moon", "--out", str(tmp_path)], env=ENV
    )
    assert result.exit_code == 2
    assert "--scenario: expected one of ['wrist', 'arm-box'], got 'moon'" in _flat(result.stderr)


def test_config_is_for_the_wrist_only(tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("methods: [exact]\n")
    args = ["demo", "--scenario", "arm-box", "--config", str(cfg), "--out", str(tmp_path)]
    result = CliRunner().invoke(app, args, env=ENV)
    assert result.exit_code == 2
    assert "--config applies to the wrist scenario only" in _flat(result.stderr)


@pytest.mark.slow
def test_arm_box_through_the_cli(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    full = velfence.apps.demo.run_arm_demo

    def short(**kwargs: Any) -> Any:  # one fast speed, two controllers, no GIF
        return full(speeds=(0.5,), methods=("no-limit", "safety-filter"), gif=False, **kwargs)

    monkeypatch.setattr(velfence.apps.demo, "run_arm_demo", short)
    out = tmp_path / "arm"
    result = CliRunner().invoke(app, ["demo", "--scenario", "arm-box", "--out", str(out)], env=ENV)
    assert result.exit_code == 0, result.output
    meta = json.loads((out / "metrics.json").read_text())
    assert list(meta["metrics"]["0.5"]) == ["no-limit", "safety-filter"]
    text = _flat(result.stdout)
    assert "arm in a box" in text
    assert "wrote 5 files" in text
