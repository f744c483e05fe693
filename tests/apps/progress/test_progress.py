"""Progress of the long commands (velfence.apps.progress), their summaries and exit codes."""

from __future__ import annotations

import dataclasses
import io
import json
import re
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("typer", reason="the command line needs the [app] extra")
from rich.console import Console
from typer.testing import CliRunner

from velfence.apps import cli, progress
from velfence.apps.cli import app

ENV = {"COLUMNS": "200", "NO_COLOR": "1"}
STAGE_LINE = re.compile(r"^(velfence [^:]+): \[(\d+)/(\d+)\] (.+) done in [0-9.]+ s \(elapsed")


def _invoke(*args: str) -> Any:
    return CliRunner().invoke(app, list(args), env=ENV)


def _stages(stderr: str) -> list[str]:
    """The stage names of the per-stage lines (what a CI log shows), in order."""
    return [m.group(4) for ln in stderr.splitlines() if (m := STAGE_LINE.match(ln))]


# --------------------------------------------------------------------------------- the module


def test_off_a_terminal_one_line_per_finished_stage() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    with progress.Tracker([("a", 1.0), ("b", 2.0)], title="velfence x", console=console) as t:
        assert progress.current() is t
        with progress.stage("a") as report:
            report(1, 2, "half")
            progress.update(2, 2, "all")
            with progress.stage("inner"):  # nested: a description, not a stage
                pass
        with progress.stage("b"):
            assert buf.getvalue().count("\n") == 1  # a line per *finished* stage
    assert progress.current() is None
    lines = buf.getvalue().splitlines()
    assert [STAGE_LINE.match(ln).group(2, 3, 4) for ln in lines] == [  # type: ignore[union-attr]
        ("1", "2", "a"),
        ("2", "2", "b"),
    ]
    assert [name for name, _ in t.finished] == ["a", "b"]


def test_off_a_terminal_a_long_stage_prints_a_heartbeat() -> None:
    # A CI log must show life during a long stage (a study, a video), not only when it ends.
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    tracker = progress.Tracker(
        [("study", 1.0)], title="velfence x", console=console, heartbeat_period=1e-9
    )
    with tracker, progress.stage("study") as report:
        report(3, 20, "subject 2 run 1")
        report(4, 20, "subject 2 run 2")
    lines = buf.getvalue().splitlines()
    assert lines[0].startswith("velfence x: study: 3/20 subject 2 run 1 (elapsed ")
    assert lines[1].startswith("velfence x: study: 4/20 subject 2 run 2 (elapsed ")
    assert STAGE_LINE.match(lines[2])
    # the default period keeps a quick stage to its one finished-stage line
    buf2 = io.StringIO()
    quick = Console(file=buf2, force_terminal=False, width=200)
    t = progress.Tracker([("a", 1.0)], title="velfence x", console=quick)
    with t, progress.stage("a") as report:
        report(1, 2, "half")
    assert len(buf2.getvalue().splitlines()) == 1
    assert t.heartbeat_period == 30.0


def test_quiet_prints_nothing() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=200)
    tracker = progress.Tracker([("a", 1.0)], title="velfence x", console=console, quiet=True)
    with tracker, progress.stage("a") as report:
        report(1, 1, "done")
    assert buf.getvalue() == ""


def test_on_a_terminal_a_live_line_with_step_elapsed_and_eta() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=True, width=200, color_system=None)
    with progress.Tracker([("rendering", 1.0)], title="velfence x", console=console) as t:
        assert t.live
        with progress.stage("rendering"):
            on_frame = progress.frames("fence-box.mp4")
            for i in range(40):
                on_frame(i, 400)
            time.sleep(1.3)  # the ETA needs a second of history; rich redraws 10 times a second
    text = buf.getvalue()
    assert "velfence x" in text
    assert "rendering: rendering fence-box.mp4 frame 40/400" in text
    assert "10%" in text
    assert re.search(r"ETA \d:\d\d:\d\d", text), text
    assert not _stages(text)  # no per-stage lines on a terminal


def test_without_a_tracker_the_reports_do_nothing() -> None:
    assert progress.current() is None
    with progress.stage("a") as report:
        report(1, 2, "x")
        progress.update(1, 2, "y")
        progress.frames("z.gif")(0, 3)


def test_summary_names_only_files_that_exist(tmp_path: Path) -> None:
    (tmp_path / "a.png").write_bytes(b"")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.json").write_text("{}")
    files = [tmp_path / "a.png", tmp_path / "missing.gif", tmp_path / "sub" / "b.json"]
    lines = progress.summary(tmp_path, files, "all good (exit 0)")
    assert lines == [f"wrote 2 files to {tmp_path}/: a.png, sub/b.json", "all good (exit 0)"]
    many = [tmp_path / "a.png"] * 8
    assert "(+2 more)" in progress.summary(None, many, "v", main=6)[0]
    assert progress.summary(tmp_path, [tmp_path / "missing.gif"], "v") == ["v"]


# ------------------------------------------------------------------------------- the commands


def _named_files_exist(text: str) -> list[Path]:
    """The files a ``wrote N files to DIR/: a, b`` summary line names; asserts they exist."""
    line = next(ln for ln in text.splitlines() if ln.startswith("wrote "))
    m = re.match(r"wrote (\d+) files? to (.+?)/: (.+)$", line)
    assert m, line
    folder = Path(m.group(2))
    names = [n for n in m.group(3).split(", ") if not n.startswith("(+")]
    paths = [folder / n.split(" (+")[0] for n in names]
    for p in paths:
        assert p.is_file(), p
    return paths


@pytest.mark.slow  # about 12-25 s: the GIF
def test_demo_reports_every_stage_through_the_gif(tmp_path: Path) -> None:
    cfg = tmp_path / "short.yaml"
    cfg.write_text("methods: [exact]\ngif: true\nduration: 0.2\n")
    out = tmp_path / "out"
    result = _invoke("demo", "--config", str(cfg), "--out", str(out))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["simulating", "metrics", "plots", "demo.gif", "metrics.json"]
    named = _named_files_exist(result.stdout)
    assert out / "demo.gif" in named
    assert out / "metrics.json" in named
    assert "demo wrist: done (exit 0)" in result.stdout


def test_demo_reports_its_stages(tmp_path: Path) -> None:
    cfg = tmp_path / "short.yaml"
    cfg.write_text("methods: [exact]\ngif: false\nduration: 0.2\n")
    result = _invoke("demo", "--config", str(cfg), "--out", str(tmp_path / "o"))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["simulating", "metrics", "plots", "metrics.json"]
    assert tmp_path / "o" / "quiver.png" in _named_files_exist(result.stdout)


def test_demo_quiet(tmp_path: Path) -> None:
    cfg = tmp_path / "short.yaml"
    cfg.write_text("methods: [exact]\ngif: false\nduration: 0.2\n")
    result = _invoke("demo", "--quiet", "--config", str(cfg), "--out", str(tmp_path / "o"))
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    _named_files_exist(result.stdout)


@pytest.mark.slow  # about 70 s: every arm controller at every speed, and the GIF
def test_demo_arm_box_reports_every_stage(tmp_path: Path) -> None:
    result = _invoke("demo", "--scenario", "arm-box", "--out", str(tmp_path))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == [
        "simulating",
        "plots",
        "arm_velfence.gif",
        "metrics.md, metrics.json",
    ]
    assert tmp_path / "arm_velfence.gif" in _named_files_exist(result.stdout)


@pytest.mark.slow  # about 9-13 s (the fast exit-code tests with a fake report: test_cli.py)
def test_reproduce_reports_progress_and_exits_0_on_documented_misses(tmp_path: Path) -> None:
    """cospm: two source defects, documented; the rest pass: exit 0, counted in the summary."""
    result = _invoke("reproduce", "cospm", "--json", "--out", str(tmp_path))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["checks"]
    doc = json.loads(result.stdout)
    failed = [c for c in doc["checks"] if not c["passed"]]
    assert failed  # the misses stay visible in the JSON
    assert all(c.get("source_defect") or c.get("expected_miss") for c in failed)
    assert f"{len(failed)} documented misses" in result.stderr
    assert "0 undocumented failures" in result.stderr
    _named_files_exist(result.stderr)


@pytest.mark.slow  # about 9-13 s
def test_reproduce_exits_1_on_an_undocumented_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same reproduction with one passing check made to fail: exit 1."""
    from velfence.apps.reproduce import cospm

    original = cospm.run

    def broken(out_dir: Path) -> Any:
        report = original(out_dir)
        k = next(i for i, c in enumerate(report.checks) if c.passed)
        checks = list(report.checks)
        checks[k] = dataclasses.replace(checks[k], passed=False)
        return dataclasses.replace(report, checks=tuple(checks))

    monkeypatch.setattr(cospm, "run", broken)
    result = _invoke("reproduce", "cospm", "--out", str(tmp_path))
    assert result.exit_code == 1, result.output
    assert "1 undocumented failure —" in " ".join(result.stdout.split())


def test_telerobotics_marks_its_own_two_misses_as_documented() -> None:
    """The two failures of ours that docs/reproductions.md explains carry ``expected_miss``."""
    import inspect

    from velfence.apps.reproduce import _telerobotics_laser, _telerobotics_motion

    for module in (_telerobotics_laser, _telerobotics_motion):
        assert "expected_miss=" in inspect.getsource(module)
    doc = (Path(__file__).parents[3] / "docs" / "reproductions.md").read_text()
    assert "expected_miss" in doc


def _fake_bench(monkeypatch: pytest.MonkeyPatch, passed: tuple[bool, ...]) -> None:
    import velfence.apps.bench as bm

    targets = tuple(
        bm.TargetCheck(f"target {i}", "≤ 5 µs", 1.0 if ok else 9.0, "µs", ok)
        for i, ok in enumerate(passed)
    )
    report = bm.BenchReport(
        settings=bm.BenchSettings.make(quick=True),
        machine=bm.machine_info(),
        timer_overhead_ns=40.0,
        latency=(),
        worst=(),
        qp=(),
        batch=(),
        targets=targets,
    )

    def fake_run(**kwargs: Any) -> bm.BenchReport:
        kwargs["progress"]("timing", 0.5)
        return report

    monkeypatch.setattr(bm, "run_benchmarks", fake_run)


@pytest.mark.parametrize(
    ("strict", "passed", "code", "words"),
    [
        (False, (True, False), 0, "1 of 2 targets met, 1 missed (exit 0; --strict"),
        (True, (True, False), 1, "1 of 2 targets met, 1 missed (exit 1)"),
        (True, (True, True), 0, "2 of 2 targets met, 0 missed (exit 0)"),
    ],
)
def test_bench_strict_exit_code(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    strict: bool,
    passed: tuple[bool, ...],
    code: int,
    words: str,
) -> None:
    _fake_bench(monkeypatch, passed)
    out = tmp_path / "bench.md"
    args = ["bench", "--quick", "--out", str(out)] + (["--strict"] if strict else [])
    result = _invoke(*args)
    assert result.exit_code == code, result.output
    assert _stages(result.stderr) == ["benchmarks"]
    assert words in result.stdout
    assert f"wrote 1 file: {out}" in result.stdout


def test_sim_reports_progress_and_names_its_files(tmp_path: Path) -> None:
    pytest.importorskip("mujoco", reason="velfence sim needs the [physics] extra")
    result = _invoke("sim", "--scenario", "wrist-push", "--no-video", "--out", str(tmp_path))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["simulating", "figures"]
    assert tmp_path / "metrics.json" in _named_files_exist(result.stdout)


@pytest.mark.slow  # about 14 s: one simulated subject, one run per mode
def test_study_reports_progress(tmp_path: Path) -> None:
    result = _invoke(
        "study", "--subjects", "1", "--runs", "1", "--no-animation", "--out", str(tmp_path)
    )
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["pick-and-place runs", "study files"]
    _named_files_exist(result.stdout)


def test_help_documents_the_exit_codes() -> None:
    result = _invoke("--help")
    assert result.exit_code == 0
    text = " ".join(result.stdout.split())
    for words in ("Exit codes", "0:", "1:", "2: bad input", "--strict"):
        assert words in text, words
    assert "--strict" in _invoke("bench", "--help").stdout
    assert cli.EXIT_CODES.startswith("Exit codes")
