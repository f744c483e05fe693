"""``velfence demo --scenario arm-box``: the option, its errors, and a short run through the CLI."""

from __future__ import annotations

from pathlib import Path

import pytest

for _extra in ("typer", "rich", "matplotlib", "yaml", "qpsolvers"):
    pytest.importorskip(_extra)

from typer.testing import CliRunner  # noqa: E402

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
