"""The ``velfence`` command line (typer app) through typer's CliRunner."""

from __future__ import annotations

import importlib
import json
import math
import os
import subprocess
import sys
import tomllib
import types
from pathlib import Path
from typing import Any

import pytest

from shared_runs import shared_bench

pytest.importorskip("typer", reason="the command line needs the [app] extra")
pytest.importorskip("rich", reason="the command line needs the [app] extra")
from typer.testing import CliRunner

import velfence
from velfence.apps import _entry, cli
from velfence.apps.cli import app
from velfence.apps.reproduce.base import Check, Report

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


@pytest.mark.slow
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
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        (Path(out_dir) / "fake.png").write_bytes(b"")  # the summary names files that exist
        return Report("fake", checks, (str(Path(out_dir) / "fake.png"),))

    module = types.ModuleType("_velfence_fake_reproduction")
    module.run = run  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setitem(cli.REPRODUCTIONS, "fake", f"{module.__name__}:run")
    assert importlib.import_module(module.__name__) is module
    return seen


OK = Check("all good", "src A", 0.0, 0.0, 0.0, True)
BAD = Check("really broken", "src B", "<= 0", 1.5, 0.0, False)
DEFECT = Check("source is wrong", "src C", "<= 0", 0.25, 0.0, False, source_defect=True)
MISS = Check("our known miss", "src D", ">= 7", 2, 7, False, note="why", expected_miss=True)


@pytest.mark.parametrize(
    ("checks", "code"),
    [
        ((OK,), 0),
        ((OK, DEFECT), 0),
        ((OK, MISS), 0),
        ((OK, MISS, DEFECT), 0),
        ((OK, BAD), 1),
        ((BAD, DEFECT), 1),
        ((BAD, MISS), 1),
    ],
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
        expected = Report("fake", checks, (str(tmp_path / "fake.png"),)).to_dict()
        assert json.loads(result.stdout) == expected


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


@pytest.mark.parametrize(
    ("checks", "counts", "code", "meaning"),
    [
        ((OK,), (1, 1, 0, 0), 0, "exit 0: every check passed"),
        ((OK, DEFECT), (1, 2, 1, 0), 0, "exit 0: every failure is a documented miss"),
        ((OK, MISS, DEFECT), (1, 3, 2, 0), 0, "exit 0: every failure is a documented miss"),
        ((OK, BAD, DEFECT), (1, 3, 1, 1), 1, "exit 1: a check that is not a documented miss"),
    ],
)
@pytest.mark.parametrize("as_json", [True, False])
def test_reproduce_ends_with_a_summary_line(
    runner: CliRunner,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    checks: tuple[Check, ...],
    counts: tuple[int, int, int, int],
    code: int,
    meaning: str,
    as_json: bool,
) -> None:
    """One line: passed / documented misses / undocumented failures, and the exit code's meaning.

    With --json the line goes to stderr, so stdout stays one JSON object.
    """
    _fake(monkeypatch, checks)
    args = ["reproduce", "fake", "--out", str(tmp_path)] + (["--json"] if as_json else [])
    result = _invoke(runner, *args)
    assert result.exit_code == code
    passed, total, documented, failures = counts
    where = result.stderr if as_json else result.stdout
    lines = [ln for ln in where.splitlines() if ln.startswith("summary:")]
    assert len(lines) == 1, where
    line = lines[0]
    assert f"{passed} of {total} checks passed" in line
    assert f"{documented} documented miss" in line
    assert f"{failures} undocumented failure" in line
    assert meaning in line
    assert cli.reproduction_summary(Report("fake", checks))[1] == code
    if as_json:
        json.loads(result.stdout)  # still exactly one JSON object


@pytest.mark.slow  # about 14 s: one simulated subject
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
    assert "greater than or equal to 0.000001" in err
    assert result.stdout == ""
    assert not out.exists()  # refused before any work: not even the folder is created


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


def test_bench_quick_writes_markdown(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from velfence.apps.bench import GENERATED_MARKER

    shared_bench(monkeypatch)  # the quick run test_benchmarking.py inspects (one per session)

    out = tmp_path / "bench.md"
    js = tmp_path / "raw" / "bench.json"
    result = _invoke(runner, "bench", "--quick", "--out", str(out), "--json", str(js))
    assert result.exit_code == 0, result.output
    md = out.read_text()
    assert md.strip()
    assert "## Machine" in md
    assert "| " in md  # markdown tables
    assert md.count(GENERATED_MARKER) == 1
    assert "quick (indicative only) mode" in md
    text = _flat(result.stdout)
    assert str(out) in text
    assert str(js) in text
    raw = json.loads(js.read_text())
    assert raw["settings"]["quick"] is True
    assert {"latency", "qp", "batch", "stops", "control", "steps", "targets"} <= set(raw)
    for t in raw["targets"]:  # one pass/FAIL line per target, reported, not asserted
        assert t["name"] in text


def test_bench_without_out_prints_only_the_markdown(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import velfence.apps.bench as bm

    report = bm.BenchReport(
        settings=bm.BenchSettings.make(quick=True),
        machine=bm.machine_info(),
        timer_overhead_ns=40.0,
        latency=(),
        worst=(),
        qp=(),
        batch=(),
        targets=(bm.TargetCheck("a target", "≤ 5 µs", 1.0, "µs", True),),
    )
    seen: dict[str, Any] = {}

    def fake_run(**kwargs: Any) -> bm.BenchReport:
        seen.update(kwargs)
        return report

    monkeypatch.setattr(bm, "run_benchmarks", fake_run)
    js = tmp_path / "bench.json"
    result = _invoke(runner, "bench", "--quick", "--json", str(js))
    assert result.exit_code == 0, result.output
    assert seen["quick"] is True
    assert result.stdout == report.to_markdown()  # redirectable: no status lines mixed in
    assert f"wrote {js}" in _flat(result.stderr)
    assert json.loads(js.read_text())["timer_overhead_ns"] == 40.0


@pytest.mark.parametrize("option", ["--out", "--json"])
def test_bench_refuses_a_folder_before_timing(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, option: str
) -> None:
    import velfence.apps.bench

    def boom(**kwargs: Any) -> None:
        raise AssertionError("the benchmarks ran")

    monkeypatch.setattr(velfence.apps.bench, "run_benchmarks", boom)
    result = _invoke(runner, "bench", "--quick", option, str(tmp_path))
    assert result.exit_code == 2
    assert f"{option} {tmp_path} is a folder" in _flat(result.stderr)


# ---------------------------------------------------------------------- demo: bad config files
# Each reproducer is refused before any work (no output folder), exit code 2, one line on stderr
# naming the field, and no traceback.

_ANGLES = [2 * math.pi * k / 3000 for k in range(3000)]
LONG_POLYGON = "polygon:\n" + "".join(f"  - [{math.cos(a)!r}, {math.sin(a)!r}]\n" for a in _ANGLES)


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (b"dt: 0.001\nmethods: [\xff]\n", ("not UTF-8", "line 2, column 11")),
        (("a: " + "[" * 5000 + "]" * 5000 + "\n").encode(), ("nesting deeper than 16",)),
        (b"dt: 1.0e-320\n", ("dt: ", "greater than or equal to 0.000001")),
        (b"duration: 1.0e308\n", ("duration: ", "less than or equal to 1000000")),
        (b"shaper: {buffer: 1.0e-320}\n", ("shaper.buffer: ",)),
        (b"dt: 0.001\ndt: 0.002\n", ("duplicate key 'dt'", "line 2", "first at line 1")),
        (b'shaper: {buffer: "0.2"}\n', ("shaper.buffer: ", "without quotes")),
        (b"duration: 9000\n", ("duration=9000 s", "at most 100,000", "--max-steps")),
        (LONG_POLYGON.encode(), ("polygon: ", "3000 corners", "at most 1000")),
        (b"a: &a [1, 2]\nb: [*a, *a]\n", ("anchors (&a) are not accepted", "line 1")),
        (b"dt: true\n", ("dt: ", "valid number", "got bool True")),
        (b"noise_std: .nan\n", ("noise_std: ", "finite")),
        (b"bogus: 1\n", ("bogus: ", "Extra inputs")),
        (b"- 1\n", ("must hold a mapping",)),
    ],
    ids=[
        "non-utf8",
        "deep",
        "tiny-dt",
        "huge-duration",
        "tiny-buffer",
        "duplicate-key",
        "quoted-number",
        "long-run",
        "many-corners",
        "aliases",
        "bool-number",
        "nan",
        "unknown-key",
        "not-a-mapping",
    ],
)
def test_demo_refuses_bad_config_before_any_work(
    runner: CliRunner, tmp_path: Path, content: bytes, words: tuple[str, ...]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(content)
    out = tmp_path / "out"
    result = runner.invoke(
        app, ["demo", "--config", str(bad), "--out", str(out)], env={**ENV, "COLUMNS": "40"}
    )
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    err = result.stderr
    assert err.startswith("error: ")
    assert err.count("\n") == 1, err  # one line, even on a 40-column terminal
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert result.stdout == ""
    assert not out.exists()


def test_demo_missing_and_directory_config(runner: CliRunner, tmp_path: Path) -> None:
    for path, words in (
        (tmp_path / "nope.yaml", "No such file"),
        (tmp_path, "it is a directory"),
    ):
        result = _invoke(runner, "demo", "--config", str(path), "--out", str(tmp_path / "o"))
        assert result.exit_code == 2
        assert "cannot read config file" in result.stderr
        assert words in result.stderr


def test_demo_max_steps_option(runner: CliRunner, tmp_path: Path) -> None:
    cfg = tmp_path / "c.yaml"
    cfg.write_text("methods: [none]\ngif: false\nduration: 0.3\n")  # 300 steps
    out = tmp_path / "out"
    result = _invoke(runner, "demo", "--config", str(cfg), "--out", str(out), "--max-steps", "299")
    assert result.exit_code == 2
    assert "needs 300 steps; at most 299 are allowed" in _flat(result.stderr)
    assert not out.exists()
    result = _invoke(runner, "demo", "--config", str(cfg), "--out", str(out), "--max-steps", "300")
    assert result.exit_code == 0, result.output
    assert (out / "metrics.json").is_file()


@pytest.mark.parametrize("value", ["0", "-5", "100000001"])
def test_demo_bad_max_steps(runner: CliRunner, tmp_path: Path, value: str) -> None:
    result = _invoke(runner, "demo", "--out", str(tmp_path / "o"), "--max-steps", value)
    assert result.exit_code == 2
    assert "max_steps: expected an int" in _flat(result.stderr)
    assert not (tmp_path / "o").exists()


def test_demo_help_documents_max_steps(runner: CliRunner) -> None:
    text = _flat(_invoke(runner, "demo", "--help").stdout)
    assert "--max-steps" in text
    assert "100000" in text.replace(",", "")
    assert "docs/config.md" in text


# ------------------------------------------------------------------------- reproduce: out folder


def test_reproduction_dir() -> None:
    assert cli.reproduction_dir("wrist", None) == Path("out/reproduce/wrist")
    assert cli.reproduction_dir("wrist", Path("x/y")) == Path("x/y")
    # A folder already named after the reproduction is used as is (no x/wrist/wrist).
    assert cli.reproduction_dir("wrist", Path("x/wrist")) == Path("x/wrist")


def test_reproduce_default_out(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    seen = _fake(monkeypatch, (OK,))
    monkeypatch.chdir(tmp_path)
    assert _invoke(runner, "reproduce", "fake", "--json").exit_code == 0
    assert seen == [Path("out/reproduce/fake")]


def test_reproduce_out_named_like_the_reproduction(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    seen = _fake(monkeypatch, (OK,))
    out = tmp_path / "fake"
    assert _invoke(runner, "reproduce", "fake", "--json", "--out", str(out)).exit_code == 0
    assert seen == [out]


def test_reproduce_out_is_a_file(
    runner: CliRunner, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    seen = _fake(monkeypatch, (OK,))
    out = tmp_path / "file.txt"
    out.write_text("x")
    result = _invoke(runner, "reproduce", "fake", "--out", str(out))
    assert result.exit_code == 2
    assert "exists and is not a folder" in _flat(result.stderr)
    assert seen == []


def test_reproduce_help_says_where_files_go(runner: CliRunner) -> None:
    text = _flat(_invoke(runner, "reproduce", "--help").stdout)
    assert "directly into it" in text
    assert "out/reproduce/NAME" in text


# ------------------------------------------------------------------- console script entry point

SRC = str(Path(velfence.__file__).resolve().parents[1])


def _run_entry(blocked: str | None, *args: str, cwd: Path | None = None, prelude: str = "") -> Any:
    """Run the console-script entry in a fresh interpreter with module ``blocked`` missing."""
    code = (
        "import sys\n"
        + prelude
        + (f"sys.modules[{blocked!r}] = None\n" if blocked else "")
        + f"sys.argv = ['velfence', *{list(args)!r}]\n"
        + "from velfence.apps._entry import main\n"
        + "main()\n"
    )
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": "200", "NO_COLOR": "1"}
    return subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=120,
        check=False,
    )


def test_ctrl_c_while_the_cli_loads_is_one_line_and_exit_130(tmp_path: Path) -> None:
    # Ctrl-C lands while typer is being imported (the first second of any command): a finder
    # that raises KeyboardInterrupt there stands in for the signal.
    prelude = (
        "class _CtrlC:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'typer':\n"
        "            raise KeyboardInterrupt\n"
        "sys.meta_path.insert(0, _CtrlC())\n"
    )
    proc = _run_entry(None, "bridge", "--config", "b.yaml", cwd=tmp_path, prelude=prelude)
    assert proc.returncode == 130, proc.stderr
    assert proc.stdout == ""
    assert "Traceback" not in proc.stderr
    assert proc.stderr.splitlines() == ["velfence: interrupted while starting (exit 130)"]


def test_script_entry_is_the_guarded_one() -> None:
    pyproject = Path(SRC).parent / "pyproject.toml"
    scripts = tomllib.loads(pyproject.read_text())["project"]["scripts"]
    assert scripts == {"velfence": "velfence.apps._entry:main"}


@pytest.mark.parametrize(
    ("blocked", "args"),
    [
        ("typer", ("--help",)),
        ("rich", ("--help",)),
        # --help needs no validator (it stays fast); the first command that reads a config does.
        ("pydantic", ("demo", "--out", "never-written")),
    ],
)
def test_core_only_install_gets_one_line(
    blocked: str, args: tuple[str, ...], tmp_path: Path
) -> None:
    proc = _run_entry(blocked, *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "pip install 'velfence[app]'" in lines[0]
    assert f"({blocked} is not installed)" in lines[0]
    assert not (tmp_path / "never-written").exists()


def test_help_needs_no_validator_and_no_numpy() -> None:
    code = (
        "import sys\nsys.argv = ['velfence', '--help']\n"
        "from velfence.apps._entry import main\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in ('pydantic', 'numpy', 'yaml', 'rosbags') if m in sys.modules))\n"
    )
    env = {**os.environ, "PYTHONPATH": SRC, "COLUMNS": "200", "NO_COLOR": "1"}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "[]"


def test_missing_matplotlib_is_reported_before_the_demo_runs(tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = _run_entry("matplotlib", "demo", "--out", str(out))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == [
        "velfence: the velfence command needs the optional 'app' dependencies (matplotlib is "
        "not installed); install them with: pip install 'velfence[app]'"
    ]
    assert not out.exists()


def test_entry_runs_the_cli_when_installed() -> None:
    proc = _run_entry(None, "--help")
    assert proc.returncode == 0, proc.stderr
    assert "reproduce" in proc.stdout


def test_missing_module_inside_velfence_is_not_masked(monkeypatch: pytest.MonkeyPatch) -> None:
    # A bug (a velfence module that cannot be imported) must surface, not read as a missing extra.
    monkeypatch.setitem(sys.modules, "velfence.apps.cli", None)
    with pytest.raises(ModuleNotFoundError, match=r"velfence\.apps\.cli"):
        _entry.main()


def test_missing_extra_mapping() -> None:
    assert _entry.missing_extra(ModuleNotFoundError("x", name="typer")) == "app"
    assert _entry.missing_extra(ModuleNotFoundError("x", name="yaml.constructor")) == "app"
    assert _entry.missing_extra(ModuleNotFoundError("x", name="qpsolvers")) == "qp"
    assert _entry.missing_extra(ModuleNotFoundError("x", name="velfence.geometry")) is None
    assert _entry.missing_extra(ModuleNotFoundError("x")) is None


# ------------------------------------------------------------------ plain help, full-width tables


def _commands() -> list[tuple[str, ...]]:
    return [(), *((c.name or c.callback.__name__,) for c in app.registered_commands)]


@pytest.mark.parametrize("args", _commands(), ids=lambda a: " ".join(a) or "velfence")
def test_help_has_no_rst_markup(runner: CliRunner, args: tuple[str, ...]) -> None:
    result = _invoke(runner, *args, "--help")
    assert result.exit_code == 0, result.output
    assert "Usage:" in result.stdout
    for markup in ("``", ":class:", ":func:", ":data:", ":meth:"):
        assert markup not in result.stdout, markup


def test_plain_help_strips_roles_and_literals() -> None:
    text = "Use ``velfence view`` with :class:`~velfence.bridge.BridgeConfig` (:func:`a.b`)."
    assert cli.plain_help(text) == "Use velfence view with BridgeConfig (a.b)."
    assert cli.plain_help(None) is None


def test_piped_tables_are_never_cut(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    long_name = "per-joint clamp against velfence on the seven-joint arm in the fence box"
    check = Check(long_name, "velfence's own tests, scenario fence-box", "0 escapes", 0, 0, True)
    _fake(monkeypatch, (check,))
    # Narrow COLUMNS as a pipe would have by default; CliRunner's stdout is not a terminal.
    result = CliRunner().invoke(
        app, ["reproduce", "fake", "--out", str(tmp_path)], env={"COLUMNS": "60", "NO_COLOR": "1"}
    )
    assert result.exit_code == 0, result.output
    assert "…" not in result.stdout
    assert long_name in result.stdout
    assert "velfence's own tests, scenario fence-box" in result.stdout


# ---------------------------------------------------------------------------------- exit codes


def _docs_exit_table() -> list[tuple[int, str]]:
    text = (Path(__file__).resolve().parents[3] / "docs" / "cli.md").read_text(encoding="utf-8")
    body = text.split("| code | meaning | commands |", 1)[1].split("\n\n", 1)[0]
    rows = []
    for line in body.strip().splitlines()[1:]:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        rows.append((int(cells[0]), cells[-1].replace("`", "")))
    return rows


def test_the_docs_exit_code_table_is_the_code_s() -> None:
    """docs/cli.md's table has the rows of ``EXIT_CODE_TABLE`` (code and commands, in order),
    ``velfence --help`` prints each of them, and every exit code the commands use is a row for
    that command."""
    code_rows = [(code, commands) for code, commands, _ in cli.EXIT_CODE_TABLE]
    assert _docs_exit_table() == code_rows
    result = _invoke_plain("--help")
    text = " ".join(result.split())
    for code, _, meaning in cli.EXIT_CODE_TABLE:
        assert f"{code}: {' '.join(meaning.split())}" in text, meaning
    assert (cli.NOTHING_TO_REPLAY, "replay") in code_rows
    assert (cli.EXIT_INTERRUPTED_CODE, "all") in code_rows
    import velfence.bridge as bridge

    assert (bridge.EXIT_INTERNAL, "bridge") in code_rows
    assert (bridge.EXIT_DDS, "bridge") in code_rows
    assert (bridge.EXIT_INTERRUPTED, "all") in code_rows
    assert (bridge.EXIT_CONFIG, "all") in code_rows  # bad input
    assert bridge.EXIT_OK == 0


def _invoke_plain(*args: str) -> str:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "200", "NO_COLOR": "1"})
    assert result.exit_code == 0, result.output
    return result.stdout


@pytest.mark.parametrize("args", _commands(), ids=lambda a: " ".join(a) or "velfence")
def test_help_paragraphs_are_not_broken_mid_sentence(args: tuple[str, ...]) -> None:
    """A docstring's hard line breaks do not reach ``--help``: at 200 columns every paragraph of
    the command's help is one line (typer then wraps at the terminal's width)."""
    cmd = next(
        (c for c in app.registered_commands if (c.name or c.callback.__name__,) == args), None
    )
    help_text = app.info.help if cmd is None else cmd.help
    assert help_text
    for para in help_text.split("\n\n"):
        assert "\n" not in para or any(
            ln.startswith((" ", "- ", "* ")) for ln in para.split("\n")[1:]
        )
    shown = " ".join(_invoke_plain(*args, "--help").split())
    for para in help_text.split("\n\n")[1:]:
        assert " ".join(para.split()) in shown, para


def test_reflow_joins_paragraph_lines_and_keeps_lists() -> None:
    text = (
        "First line\n    goes on.\n\n    Second paragraph\n    continues here.\n\n    - a\n    - b"
    )
    assert cli.reflow(text) == (
        "First line goes on.\n\nSecond paragraph continues here.\n\n- a\n- b"
    )
    assert cli.reflow("Exit 0 stopped, 2 bad\nconfig.") == "Exit 0 stopped, 2 bad config."
