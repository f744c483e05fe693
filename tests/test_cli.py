"""The ``velfence`` command line (typer app) through typer's CliRunner."""

from __future__ import annotations

import importlib
import json
import sys
import types
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from velfence import cli
from velfence.cli import app
from velfence.reproduce.base import Check, Report

ENV = {"COLUMNS": "200", "NO_COLOR": "1"}
CHECK_KEYS = {"name", "source", "expected", "measured", "tolerance", "passed"}


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def _invoke(runner: CliRunner, *args: str) -> Any:
    return runner.invoke(app, list(args), env=ENV)


def _flat(text: str) -> str:
    return " ".join(text.split())


# -------------------------------------------------------------------------------------------- help


@pytest.mark.parametrize(
    ("args", "words"),
    [
        ((), ("demo", "reproduce", "bench", "safe sets")),
        (("demo",), ("--out", "--config", "metrics.json")),
        (("reproduce",), ("--json", "--out", "NAME", "wrist")),
        (("bench",), ("--out", "--quick")),
    ],
)
def test_help(runner: CliRunner, args: tuple[str, ...], words: tuple[str, ...]) -> None:
    result = _invoke(runner, *args, "--help")
    assert result.exit_code == 0, result.output
    text = result.stdout
    assert "Usage:" in text
    for w in words:
        assert w.lower() in text.lower(), w


def test_no_arguments_shows_help(runner: CliRunner) -> None:
    result = _invoke(runner)
    assert "Usage:" in result.output
    assert "reproduce" in result.output


def test_unknown_command(runner: CliRunner) -> None:
    result = _invoke(runner, "frobnicate")
    assert result.exit_code == 2


# --------------------------------------------------------------------------------------- reproduce


def test_reproduce_wrist_json(runner: CliRunner, tmp_path: Path) -> None:
    result = _invoke(runner, "reproduce", "wrist", "--json", "--out", str(tmp_path))
    # Source defects (documented findings) do not fail the reproduction.
    assert result.exit_code == 0, result.output
    # Exactly one JSON object on stdout, nothing else.
    obj, end = json.JSONDecoder().raw_decode(result.stdout)
    assert result.stdout[end:].strip() == ""
    assert set(obj) == {"name", "checks", "artifacts"}
    assert obj["name"] == "wrist"
    assert obj["checks"]
    for c in obj["checks"]:
        assert set(c) >= CHECK_KEYS
        assert isinstance(c["passed"], bool)
        assert c["passed"] or c.get("source_defect") is True, c["name"]
    assert any(c.get("source_defect") for c in obj["checks"])
    # Artifacts are written directly into --out (not OUT/NAME, and never OUT/NAME/NAME).
    assert obj["artifacts"]
    for a in obj["artifacts"]:
        p = Path(a)
        assert p.is_file()
        assert p.parent == tmp_path
    assert not (tmp_path / "wrist").exists()


def test_reproduce_unknown_name(runner: CliRunner, tmp_path: Path) -> None:
    result = _invoke(runner, "reproduce", "nope", "--json", "--out", str(tmp_path))
    assert result.exit_code == 2
    assert result.stdout == ""
    err = _flat(result.stderr)
    assert "unknown reproduction 'nope'" in err
    for name in cli.REPRODUCTIONS:
        assert repr(name) in err
    assert not (tmp_path / "nope").exists()


def test_reproduce_requires_a_name(runner: CliRunner) -> None:
    result = _invoke(runner, "reproduce")
    assert result.exit_code == 2


def _fake(monkeypatch: pytest.MonkeyPatch, checks: tuple[Check, ...]) -> list[Path]:
    """Register reproduction 'fake' returning a report with ``checks``; record its out_dir."""
    seen: list[Path] = []

    def run(out_dir: Path) -> Report:
        seen.append(Path(out_dir))
        return Report("fake", checks, ("fake.png",))

    module = types.ModuleType("_velfence_fake_reproduction")
    module.run = run  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setitem(cli.REPRODUCTIONS, "fake", f"{module.__name__}:run")
    assert importlib.import_module(module.__name__) is module
    return seen


OK = Check("all good", "src A", 0.0, 0.0, 0.0, True)
BAD = Check("really broken", "src B", "<= 0", 1.5, 0.0, False)
DEFECT = Check("source is wrong", "src C", "<= 0", 0.25, 0.0, False, source_defect=True)


@pytest.mark.parametrize(
    ("checks", "code"),
    [((OK,), 0), ((OK, DEFECT), 0), ((OK, BAD), 1), ((BAD, DEFECT), 1)],
)
@pytest.mark.parametrize("as_json", [True, False])
def test_reproduce_exit_code(
    runner: CliRunner,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    checks: tuple[Check, ...],
    code: int,
    as_json: bool,
) -> None:
    seen = _fake(monkeypatch, checks)
    args = ["reproduce", "fake", "--out", str(tmp_path)] + (["--json"] if as_json else [])
    result = _invoke(runner, *args)
    assert result.exit_code == code, result.output
    assert seen == [tmp_path]
    if as_json:
        assert json.loads(result.stdout) == Report("fake", checks, ("fake.png",)).to_dict()


def test_reproduce_table_marks_source_defects(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _fake(monkeypatch, (OK, BAD, DEFECT))
    result = _invoke(runner, "reproduce", "fake", "--out", str(tmp_path))
    assert result.exit_code == 1
    out = _flat(result.stdout)
    assert "FAIL (source defect)" in out
    assert out.count("FAIL") == 2
    assert "pass" in out
    assert "fake.png" in out
    with pytest.raises(json.JSONDecodeError):
        json.loads(result.stdout)


# -------------------------------------------------------------------------------------------- demo


def test_demo_bad_config_names_the_field(runner: CliRunner, tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("shaper: {buffer: -1}\n")
    out = tmp_path / "out"
    result = _invoke(runner, "demo", "--config", str(bad), "--out", str(out))
    assert result.exit_code == 2
    err = _flat(result.stderr)
    assert "error:" in err
    assert "shaper.buffer" in err
    assert "greater than 0" in err
    assert result.stdout == ""
    assert not (out / "metrics.json").exists()


def test_demo_missing_config_keeps_brackets_in_the_path(runner: CliRunner, tmp_path: Path) -> None:
    # Rich markup must not eat "[run1]" out of the message.
    missing = tmp_path / "scenario[run1].yaml"
    result = _invoke(runner, "demo", "--config", str(missing), "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    err = _flat(result.stderr)
    assert "cannot read config file" in err
    assert "scenario[run1].yaml" in err


def test_demo_with_short_config(runner: CliRunner, tmp_path: Path) -> None:
    cfg = tmp_path / "short.yaml"
    cfg.write_text("methods: [exact]\ngif: false\nduration: 0.2\n")
    out = tmp_path / "out"
    result = _invoke(runner, "demo", "--config", str(cfg), "--out", str(out))
    assert result.exit_code == 0, result.output
    meta = json.loads((out / "metrics.json").read_text())
    assert list(meta["metrics"]) == ["exact"]
    for name in ("workspace.png", "velocity.png", "quiver.png"):
        assert (out / name).is_file()
    text = _flat(result.stdout)
    assert "exact" in text
    assert "wrote 4 files" in text


# ------------------------------------------------------------------------------------------- bench


def test_bench_quick_writes_markdown(runner: CliRunner, tmp_path: Path) -> None:
    bm = pytest.importorskip("velfence.benchmarking")
    if not hasattr(bm, "run_benchmarks"):
        pytest.skip("velfence.benchmarking.run_benchmarks is not there yet")
    out = tmp_path / "bench.md"
    result = _invoke(runner, "bench", "--quick", "--out", str(out))
    assert result.exit_code == 0, result.output
    md = out.read_text()
    assert md.strip()
    assert "## Machine" in md
    assert "| " in md  # markdown tables
    assert str(out) in _flat(result.stdout)
