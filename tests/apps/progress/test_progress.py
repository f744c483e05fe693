"""Progress of the long commands (velfence.apps.progress), their summaries and exit codes."""

from __future__ import annotations

import dataclasses
import io
import json
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from shared_runs import FIGURE_CHECKS, recording, reproduction, shared_scenario

pytest.importorskip("typer", reason="the command line needs the [app] extra")
from rich.console import Console
from typer.testing import CliRunner

from velfence.apps import cli, progress
from velfence.apps.cli import app
from velfence.errors import InvalidParameter

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


def test_a_heartbeat_shows_whole_counts_once_and_fractions_as_a_percentage() -> None:
    # "simulating: 2.88348/5 axis-limits 88 %" and "runs: 15/60 run 15/60" were hard to read.
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    tracker = progress.Tracker(
        [("simulating", 1.0)], title="velfence x", console=console, heartbeat_period=1e-9
    )
    with tracker, progress.stage("simulating") as report:
        report(2.88348, 5, "axis-limits 88 %")
        report(15, 60, "run 15/60")
        report(3, 20, "subject 2 run 1")
    lines = [ln.split(" (elapsed")[0] for ln in buf.getvalue().splitlines()[:3]]
    assert lines == [
        "velfence x: simulating: 58 %, axis-limits 88 %",
        "velfence x: simulating: run 15/60",
        "velfence x: simulating: 3/20 subject 2 run 1",
    ]


def test_off_a_terminal_the_lines_carry_the_remaining_time(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A CI log says how long a command still runs, as the live line does: the weighted
    # fraction of the plan done, extrapolated (ETA = elapsed * (1 - f) / f).
    now = [100.0]
    monkeypatch.setattr(progress, "time", type("Clock", (), {"perf_counter": lambda: now[0]}))
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    plan = [("runs", 3.0), ("plots", 1.0)]
    tracker = progress.Tracker(plan, title="velfence x", console=console, heartbeat_period=1.0)
    with tracker:
        with progress.stage("runs") as report:
            now[0] += 0.5
            report(1, 10, "run 1")  # under a second of history: no estimate yet
            now[0] += 59.5
            report(5, 10, "run 5")  # 60 s for 1.5 of 4 weight units: 100 s left
            now[0] += 60.0  # the stage ends at 120 s, 3 of 4 units: 40 s left
        with progress.stage("plots"):
            now[0] += 30.0  # the last stage: nothing left to estimate
    lines = buf.getvalue().splitlines()
    assert lines == [
        "velfence x: runs: 5/10 run 5 (elapsed 60.0 s, ETA 0:01:40)",
        "velfence x: [1/2] runs done in 120.0 s (elapsed 120.0 s, ETA 0:00:40)",
        "velfence x: [2/2] plots done in 30.0 s (elapsed 150.0 s)",
    ]


def test_a_note_is_one_line_now_and_nothing_when_quiet() -> None:
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    with progress.Tracker([("a", 1.0)], title="velfence x", console=console):
        progress.note("study: reusing 60 runs")
        assert buf.getvalue() == "velfence x: study: reusing 60 runs\n"
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=200)
    with progress.Tracker([("a", 1.0)], title="velfence x", console=console, quiet=True):
        progress.note("study: reusing 60 runs")
    assert buf.getvalue() == ""
    progress.note("no tracker: nothing")  # a library-style call stays silent
    with pytest.raises(InvalidParameter, match="text"):
        progress.note(7)  # type: ignore[arg-type]


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
    assert (out / "demo.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
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


@pytest.mark.slow  # about 15 s: every arm controller at one speed, and the GIF
def test_demo_arm_box_reports_every_stage(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """One short arm-box demo through the command line: its stages, its summary, its files and
    every figure and GIF frame it draws (the figure checker), in one run."""
    import velfence.apps.demo

    full = velfence.apps.demo.run_arm_demo

    def one_speed(**kwargs: Any) -> Any:  # the stages are the same at every speed
        return full(speeds=(0.5,), **kwargs)

    monkeypatch.setattr(velfence.apps.demo, "run_arm_demo", one_speed)
    with recording() as figures:
        result = _invoke("demo", "--scenario", "arm-box", "--out", str(tmp_path))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == [
        "simulating",
        "plots",
        "arm_velfence.gif",
        "metrics.md, metrics.json",
    ]
    assert tmp_path / "arm_velfence.gif" in _named_files_exist(result.stdout)
    text = " ".join(result.stdout.split())
    assert "arm in a box" in text
    assert "wrote 6 files" in text
    meta = json.loads((tmp_path / "metrics.json").read_text())
    assert list(meta["metrics"]) == ["0.5"]
    written = FIGURE_CHECKS.check_every(figures, tmp_path)
    assert {"arm_paths.png", "arm_joints.png", "arm_activity.png", "arm_velfence.gif"} <= written


@pytest.fixture
def cospm_once(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> Callable[[Path], Any]:
    """``cospm.run`` answered by the worker's one cospm run (tests/shared_runs.py), which the
    reproduction's own tests and figure checks share."""
    from velfence.apps.reproduce import cospm

    shared = reproduction("cospm", tmp_path_factory.getbasetemp()).report

    def run(out_dir: Path) -> Any:
        del out_dir  # the shared run's files are in its own folder; its report names them
        return shared

    monkeypatch.setattr(cospm, "run", run)
    return run


@pytest.mark.slow  # the cospm reproduction (shared with its own tests; test_cli.py: fake reports)
def test_reproduce_reports_progress_and_exits_0_on_documented_misses(
    tmp_path: Path, cospm_once: Callable[[Path], Any]
) -> None:
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


@pytest.mark.slow  # the cospm reproduction (shared, as above)
def test_reproduce_exits_1_on_an_undocumented_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cospm_once: Callable[[Path], Any]
) -> None:
    """The same reproduction with one passing check made to fail: exit 1."""
    from velfence.apps.reproduce import cospm

    original = cospm_once

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


def test_sim_reports_progress_and_names_its_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("mujoco", reason="velfence sim needs the [physics] extra")
    shared_scenario(monkeypatch, "wrist-push")  # one run with the physics and figure tests
    result = _invoke("sim", "--scenario", "wrist-push", "--no-video", "--out", str(tmp_path))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["simulating", "figures"]
    assert tmp_path / "metrics.json" in _named_files_exist(result.stdout)


@pytest.mark.slow  # about 14 s: one simulated subject, one run per mode
def test_study_reports_progress_and_the_reproduction_reuses_its_runs(tmp_path: Path) -> None:
    """One small study through the command line: its stages, its files, and its table's rows
    each naming their unit. The telerobotics reproduction's study part, given its folder,
    reuses its runs (saying so) and writes the same study.json as the fresh run did."""
    from velfence.apps.reproduce import telerobotics
    from velfence.apps.reproduce._telerobotics_study import study_checks

    out = tmp_path / "study"
    result = _invoke("study", "--subjects", "1", "--runs", "1", "--no-animation", "--out", str(out))
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["pick-and-place runs", "study files"]
    assert out / "study_runs.npz" in _named_files_exist(result.stdout)
    rows = [ln for ln in result.stdout.splitlines() if ln.startswith("│")]
    assert len(rows) == 7
    for row in rows:
        first = row.split("│")[1].strip()
        assert re.search(r"\[[^\]]+\]$", first), row

    # the command's plan counts the study stage as seconds when it will reuse the runs
    assert telerobotics.stages(out, subjects=1, runs=1)[-1] == ("study", telerobotics.REUSED_STUDY)
    assert telerobotics.stages(out) == telerobotics.STAGES  # 10 x 3: another study
    assert telerobotics.stages(None, subjects=1, runs=1) == telerobotics.STAGES
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=False, width=300)
    tracker = progress.Tracker([("study", 1.0)], title="velfence x", console=console)
    with tracker:
        checks, paths = study_checks(tmp_path / "repro", subjects=1, runs=1, study=out)
    lines = buf.getvalue().splitlines()
    reusing = f"velfence x: study: reusing the same study's 2 runs from {out}/study_runs.npz"
    assert re.fullmatch(re.escape(reusing) + r" \(key [0-9a-f]{12}\)", lines[0]), lines[0]
    assert STAGE_LINE.match(lines[1])
    assert [p.name for p in paths] == ["study.json", "study_times.png", "study_paths.png"]
    # the same numbers as the command's fresh run: its study.json, byte for byte
    assert paths[0].read_bytes() == (out / "study.json").read_bytes()
    assert len(checks) == 7


def test_reproduce_study_option_is_checked() -> None:
    result = _invoke("reproduce", "cospm", "--study", "out/study")
    assert result.exit_code == 2
    assert "--study applies to `velfence reproduce telerobotics` only" in result.stderr
    result = _invoke("reproduce", "telerobotics", "--study", "/nonexistent/study")
    assert result.exit_code == 2
    assert "--study /nonexistent/study: expected the folder of a `velfence study" in result.stderr


def test_help_documents_the_exit_codes() -> None:
    result = _invoke("--help")
    assert result.exit_code == 0
    text = " ".join(result.stdout.split())
    for words in ("Exit codes", "0:", "1:", "2: bad input", "--strict"):
        assert words in text, words
    assert "--strict" in _invoke("bench", "--help").stdout
    assert cli.EXIT_CODES.startswith("Exit codes")


# ------------------------------------------------------------------- replay, soak, soak_filter

BAG = Path(__file__).resolve().parents[3] / "examples" / "bags" / "mobile_base"


def test_replay_one_bag_reports_progress_and_ends_with_a_summary(tmp_path: Path) -> None:
    pytest.importorskip("rosbags", reason="velfence replay needs the [ros] extra")
    out, fig = tmp_path / "out", tmp_path / "fig.png"
    result = _invoke(
        "replay", str(BAG / "bag"), "--config", str(BAG / "replay.yaml"), "--out", str(out),
        "--plot", str(fig),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert _stages(result.stderr) == ["shaping", "figure"]
    lines = result.stdout.splitlines()
    assert lines[-2] == f"wrote 2 files: {out}, {fig}"
    assert out.is_dir()
    assert fig.is_file()
    # the verdict: the counts of the first line, and the exit code
    m = re.match(r"(\d+) commands on .*: (\d+) changed .*", lines[0])
    assert m, lines[0]
    zeroed = re.match(r"written as zero: (\d+) ", lines[1])
    assert zeroed, lines[1]
    assert lines[-1] == (
        f"summary: {m.group(1)} commands replayed, {m.group(2)} changed, {zeroed.group(1)} "
        "written as zero — exit 0"
    )


def test_replay_quiet(tmp_path: Path) -> None:
    pytest.importorskip("rosbags", reason="velfence replay needs the [ros] extra")
    out = tmp_path / "out"
    result = _invoke(
        "replay", str(BAG / "bag"), "--config", str(BAG / "replay.yaml"), "--out", str(out),
        "--quiet",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    assert result.stdout.splitlines()[-2] == f"wrote 1 file: {out}"


def _one_soak_case(monkeypatch: pytest.MonkeyPatch) -> str:
    """The soak's campaign cut to its first case, so that main() runs in a second."""
    from velfence.apps import soak

    first = soak.polygon_cases(episodes=2, polygons=1, seed=0)[0]
    monkeypatch.setattr(soak, "polygon_cases", lambda **_: [first])
    monkeypatch.setattr(soak, "stop_cases", lambda **_: [])
    return first.name


def test_soak_reports_progress_and_ends_with_a_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from velfence.apps import soak

    name = _one_soak_case(monkeypatch)
    out = tmp_path / "soak.md"
    assert soak.main(["--steps", "40", "--episode-steps", "20", "--out", str(out)]) == 0
    cap = capsys.readouterr()
    lines = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(lines) == 1
    assert re.match(rf"^soak: \[1/1\] {re.escape(name)} done in [0-9.]+ s \(elapsed", lines[0])
    stdout = cap.out.splitlines()
    assert stdout[0].startswith(f"{name}: 40 steps, escapes 0")
    assert stdout[-2] == f"wrote 1 file: {out}"
    assert stdout[-1].startswith("soak: 1/1 required cases contained")
    assert stdout[-1].endswith("exit 0: containment held")
    assert out.is_file()


def test_soak_reports_steps_within_a_case(monkeypatch: pytest.MonkeyPatch) -> None:
    from velfence.apps import soak

    case = soak.polygon_cases(episodes=2, polygons=1, seed=0)[0]
    seen: list[tuple[float, float, str]] = []
    soak.run_case(case, episodes=2, steps_per_episode=400, on_progress=lambda *a: seen.append(a))
    assert seen[0] == (0, 400, f"{case.name}: step 0/400")
    assert [s[0] for s in seen] == list(range(0, 400, 2))  # every 400 // 200 steps


def test_soak_quiet(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from velfence.apps import soak

    _one_soak_case(monkeypatch)
    assert soak.main(["--steps", "40", "--episode-steps", "20", "--quiet"]) == 0
    cap = capsys.readouterr()
    assert cap.err == ""
    assert cap.out.splitlines()[-1].endswith("exit 0: containment held")  # no file: no "wrote"
    assert not any(ln.startswith("wrote") for ln in cap.out.splitlines())


SOAK_FILTER_ARGS = [
    "--vertex-states", "60", "--filter-states", "6", "--steps", "20", "--episode-steps", "10",
    "--robots", "ur5e-dh", "--rates", "100",
]  # fmt: skip


def test_soak_filter_reports_progress_and_ends_with_a_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from velfence.apps import soak_filter

    out = tmp_path / "reliability.md"
    assert soak_filter.main([*SOAK_FILTER_ARGS, "--out", str(out)]) == 0
    cap = capsys.readouterr()
    stages = [m.group(3) for ln in cap.err.splitlines()
              if (m := re.match(r"^soak_filter: \[(\d)/(\d)\] (.+) done in", ln))]  # fmt: skip
    assert stages == ["vertex campaign", "UR5e (DHChain), 100 Hz"]
    stdout = cap.out.splitlines()
    assert stdout[0].startswith("PolytopeShaper exact, dt = 0.001 s: 60 states, escapes 0")
    assert stdout[2].startswith("UR5e (DHChain), 100 Hz: 20 steps")
    assert stdout[-2] == f"wrote 1 file: {out}"
    assert stdout[-1] == (
        "soak_filter: 3 campaign result(s) (2 vertex, 1 closed-loop); contained, exit 0"
    )
    assert "soak_filter: begin" in out.read_text()


def test_soak_filter_campaigns_report_done_of_total() -> None:
    from velfence.apps import soak_filter

    seen: list[tuple[float, float, str]] = []
    soak_filter.run_vertex_campaign(
        states=30, filter_states=0, per_polytope=10, on_progress=lambda *a: seen.append(a)
    )
    assert seen  # the first report is at once
    assert all(total == 30 and 0 <= done <= 30 for done, total, _ in seen)
    seen.clear()
    soak_filter.run_loop_campaign(
        "ur5e-dh", 100.0, steps=10, episode_steps=10, on_progress=lambda *a: seen.append(a)
    )
    assert seen
    assert all(total == 10 and 0 <= done <= 10 for done, total, _ in seen)


def test_soak_filter_quiet(capsys: pytest.CaptureFixture[str]) -> None:
    from velfence.apps import soak_filter

    assert soak_filter.main([*SOAK_FILTER_ARGS, "--quiet"]) == 0
    cap = capsys.readouterr()
    assert cap.err == ""
    assert cap.out.splitlines()[-1].endswith("contained, exit 0")
