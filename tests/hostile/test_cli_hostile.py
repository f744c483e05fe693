"""The ``velfence`` command line under hostile argv (docs/reliability-inputs.md, "What is
enumerated": the CLI is attacked through its command line, not its Python functions).

Each case is an argv and what must happen: the documented exit code (docs/cli.md: 2 for bad
input) and a message on stderr naming the option or the value — never a traceback, never an
exception escaping the command. Every case is refused before any work (a fraction of a second).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("typer", reason="the command line needs the [app] extra")
from typer.testing import CliRunner

from velfence.apps.cli import app

ENV = {"COLUMNS": "200", "NO_COLOR": "1"}
REPO = Path(__file__).resolve().parents[2]
BRIDGE_YAML = str(REPO / "examples" / "bridge.yaml")

#: (id, argv, exit code, words every one of which the output must hold). ``{file}`` is an
#: existing file, ``{dir}`` an existing folder, ``{missing}`` a path that does not exist, ``{ro}``
#: a path under a file (its folder cannot be created), ``{zone_bridge}`` / ``{zone_replay}`` a
#: bridge / replay file naming a zone file beside it (missing; without the named polygon).
CASES: list[tuple[str, list[str], int, tuple[str, ...]]] = [
    # the command and its options
    ("unknown-option", ["--nope"], 2, ("No such option", "--nope")),
    ("unknown-command", ["frobnicate"], 2, ("No such command", "frobnicate")),
    ("empty-command", [""], 2, ("No such command",)),
    ("unknown-option-of-command", ["demo", "--frobnicate", "1"], 2, ("No such option",)),
    ("option-without-value", ["demo", "--max-steps"], 2, ("requires an argument", "--max-steps")),
    # demo
    ("demo-steps-nan", ["demo", "--max-steps", "nan"], 2, ("--max-steps", "valid integer")),
    ("demo-steps-inf", ["demo", "--max-steps", "inf"], 2, ("--max-steps", "valid integer")),
    ("demo-steps-float", ["demo", "--max-steps", "2.5"], 2, ("--max-steps", "valid integer")),
    ("demo-steps-negative", ["demo", "--max-steps", "-1"], 2, ("max_steps", ">= 1")),
    ("demo-steps-zero", ["demo", "--max-steps", "0"], 2, ("max_steps", ">= 1")),
    ("demo-steps-huge", ["demo", "--max-steps", "9" * 30], 2, ("max_steps", "100,000,000")),
    ("demo-steps-empty", ["demo", "--max-steps", ""], 2, ("--max-steps",)),
    ("demo-config-missing", ["demo", "--config", "{missing}"], 2,
     ("cannot read", "check the path")),
    ("demo-config-empty", ["demo", "--config", ""], 2, ("cannot read", "directory")),
    ("demo-config-dir", ["demo", "--config", "{dir}"], 2, ("cannot read", "directory")),
    ("demo-config-not-yaml", ["demo", "--config", "{file}"], 2, ("mapping",)),
    ("demo-scenario-empty", ["demo", "--scenario", ""], 2, ("--scenario", "wrist")),
    ("demo-scenario-unknown", ["demo", "--scenario", "moon"], 2, ("--scenario", "'moon'")),
    ("demo-arm-box-config", ["demo", "--scenario", "arm-box", "--config", "{file}"], 2,
     ("--config", "wrist scenario only")),
    ("demo-out-unwritable", ["demo", "--out", "{ro}"], 2, ("cannot write", "Not a directory")),
    # reproduce
    ("reproduce-empty", ["reproduce", ""], 2, ("unknown reproduction", "wrist")),
    ("reproduce-unknown", ["reproduce", "../../etc/passwd"], 2, ("unknown reproduction",)),
    ("reproduce-no-name", ["reproduce"], 2, ("Missing argument", "name")),
    ("reproduce-out-file", ["reproduce", "wrist", "--out", "{file}"], 2,
     ("--out", "not a folder")),
    # sim
    ("sim-scenario-empty", ["sim", "--scenario", ""], 2, ("--scenario", "fence-box")),
    ("sim-robot-unknown", ["sim", "--robot", "r2d2"], 2, ("--robot", "'r2d2'")),
    ("sim-width-nan", ["sim", "--width", "nan"], 2, ("--width", "valid integer")),
    ("sim-width-negative", ["sim", "--width", "-5"], 2, ("--width", "64")),
    ("sim-width-huge", ["sim", "--width", "9" * 30], 2, ("--width",)),
    ("sim-height-zero", ["sim", "--height", "0"], 2, ("--height", "48")),
    ("sim-fps-inf", ["sim", "--fps", "inf"], 2, ("--fps", "valid integer")),
    ("sim-columns-zero", ["sim", "--columns", "0"], 2, ("--columns",)),
    ("sim-out-file", ["sim", "--out", "{file}"], 2, ("--out", "not a folder")),
    # bench
    ("bench-out-dir", ["bench", "--out", "{dir}"], 2, ("--out", "is a folder")),
    ("bench-json-dir", ["bench", "--json", "{dir}"], 2, ("--json", "is a folder")),
    # teleop and view
    ("teleop-port-negative", ["teleop", "--port", "-1", "--no-browser"], 2, ("port", ">= 0")),
    ("teleop-port-huge", ["teleop", "--port", "99999999999", "--no-browser"], 2,
     ("port", "65,535")),
    ("teleop-port-nan", ["teleop", "--port", "nan", "--no-browser"], 2,
     ("--port", "valid integer")),
    ("view-scene-empty", ["view", "--scene", "", "--no-browser"], 2, ("scene", "arm-box")),
    ("view-scene-traversal", ["view", "--scene", "../../etc", "--no-browser"], 2,
     ("scene", "'../../etc'")),
    ("view-port-negative", ["view", "--port", "-1", "--no-browser"], 2, ("--port",)),
    ("view-port-huge", ["view", "--port", "65536", "--no-browser"], 2, ("--port", "65535")),
    # bridge (refused before any DDS participant is created)
    ("bridge-no-config", ["bridge"], 2, ("Missing option", "--config")),
    ("bridge-config-missing", ["bridge", "--config", "{missing}"], 2, ("cannot read",)),
    ("bridge-config-empty", ["bridge", "--config", ""], 2, ("cannot read", "directory")),
    ("bridge-config-not-yaml", ["bridge", "--config", "{file}"], 2, ("mapping",)),
    ("bridge-duration-nan", ["bridge", "--config", BRIDGE_YAML, "--duration", "nan"], 2,
     ("duration",)),
    ("bridge-duration-inf", ["bridge", "--config", BRIDGE_YAML, "--duration", "inf"], 2,
     ("duration",)),
    ("bridge-duration-negative", ["bridge", "--config", BRIDGE_YAML, "--duration", "-1"], 2,
     ("duration",)),
    ("bridge-duration-zero", ["bridge", "--config", BRIDGE_YAML, "--duration", "0"], 2,
     ("duration",)),
    ("bridge-duration-huge", ["bridge", "--config", BRIDGE_YAML, "--duration", "1e308"], 2,
     ("duration",)),
    ("bridge-duration-word", ["bridge", "--config", BRIDGE_YAML, "--duration", "soon"], 2,
     ("--duration", "valid number")),
    ("bridge-foxglove-port-negative", ["bridge", "--config", BRIDGE_YAML,
     "--foxglove-port", "-3"], 2, ("--foxglove-port",)),
    # a zone file the config names (docs/config.md, "Zones from vendor files")
    ("bridge-zone-file-missing", ["bridge", "--config", "{zone_bridge}"], 2,
     ("shaper.zone.ur_safety_planes", "no_cell.yaml", "cannot read")),
    # study
    ("study-subjects-zero", ["study", "--subjects", "0"], 2, ("--subjects", "1")),
    ("study-subjects-nan", ["study", "--subjects", "nan"], 2, ("--subjects", "valid integer")),
    ("study-subjects-huge", ["study", "--subjects", "9" * 20, "--out", "{new}"], 2,
     ("n_subjects", "10,000")),
    ("study-runs-huge", ["study", "--runs", "9" * 20, "--out", "{new}"], 2, ("runs", "10,000")),
    ("study-runs-negative", ["study", "--runs", "-1"], 2, ("--runs",)),
    ("study-seed-negative", ["study", "--seed", "-1"], 2, ("--seed",)),
    ("study-out-file", ["study", "--out", "{file}", "--subjects", "1", "--runs", "1"], 2,
     ("--out", "not a folder")),
    # replay
    ("replay-nothing", ["replay"], 2, ("Missing",)),
    ("replay-no-config", ["replay", "{missing}", "--out", "{new}"], 2, ("--config",)),
    ("replay-config-missing", ["replay", "{missing}", "--config", "{missing}", "--out", "{new}"],
     2, ("cannot read",)),
    ("replay-config-not-yaml", ["replay", "{file}", "--config", "{file}", "--out", "{new}"], 2,
     ("mapping",)),
    ("replay-zone-polygon-unknown", ["replay", "{dir}", "--config", "{zone_replay}", "--out",
     "{new}"], 2, ("shaper.zone.polygon", "'FrontStp'", "did you mean 'FrontStop'?")),
    ("replay-storage-unknown", ["replay", "{missing}", "--config", "{missing}", "--out", "{new}",
     "--storage", "zip"], 2, ("storage", "mcap")),
    ("replay-same-bag-twice", ["replay", "{dir}", "{dir}", "--config", "{file}", "--out",
     "{new}"], 2, ("same bag",)),
    ("replay-many-out-file", ["replay", "{dir}", "{missing}", "--config", "{file}", "--out",
     "{file}"], 2, ("--out", "expected a folder")),
]  # fmt: skip


def _argv(argv: list[str], tmp: Path) -> list[str]:
    (tmp / "afile").write_text("just text\n", encoding="utf-8")
    (tmp / "adir").mkdir(exist_ok=True)
    zones = tmp / "zones"  # configs naming a zone file beside them
    zones.mkdir(exist_ok=True)
    (zones / "nav2.yaml").write_text(
        "collision_monitor:\n  ros__parameters:\n    polygons: [FrontStop]\n    FrontStop:\n"
        "      type: polygon\n      points: [0.3, 0.2, 0.3, -0.2, 0.0, -0.2, 0.0, 0.2]\n"
        "      action_type: stop\n",
        encoding="utf-8",
    )
    (zones / "bridge.yaml").write_text(
        "bridge:\n  command_in: {type: float64_multi_array}\n"
        "  state: {type: joint_state, joint_names: [x, y, z]}\n"
        "shaper:\n  kind: polytope\n  zone: {ur_safety_planes: no_cell.yaml}\n  buffer: 0.1\n",
        encoding="utf-8",
    )
    (zones / "replay.yaml").write_text(
        "shaper:\n  kind: polygon\n  zone: {nav2: nav2.yaml, polygon: FrontStp}\n  buffer: 0.1\n"
        "replay:\n  command_topic: /cmd_vel\n  state_topic: /odom\n",
        encoding="utf-8",
    )
    paths = {
        "{zone_bridge}": str(zones / "bridge.yaml"),
        "{zone_replay}": str(zones / "replay.yaml"),
        "{file}": str(tmp / "afile"),
        "{dir}": str(tmp / "adir"),
        "{missing}": str(tmp / "missing.yaml"),
        "{ro}": str(tmp / "afile" / "sub"),
        "{new}": str(tmp / "new"),
    }
    return [paths.get(a, a) for a in argv]


def test_at_least_60_cases() -> None:
    assert len(CASES) >= 60
    assert len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize(("argv", "code", "words"), [c[1:] for c in CASES],
                         ids=[c[0] for c in CASES])  # fmt: skip
def test_hostile_argv(
    argv: list[str], code: int, words: tuple[str, ...], tmp_path: Path, monkeypatch: Any
) -> None:
    monkeypatch.chdir(tmp_path)  # a command that would write does so in the scratch folder
    result = CliRunner().invoke(app, _argv(argv, tmp_path), env=ENV)
    out = result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        f"an exception escaped: {result.exception!r}\n{out}"
    )
    assert "Traceback" not in out
    assert result.exit_code == code, out
    flat = " ".join(out.replace("│", " ").split())
    for w in words:
        assert w in flat, (w, flat)
    # refused before any work: nothing written but the scratch files
    assert {p.name for p in tmp_path.iterdir()} <= {"afile", "adir", "zones"}, list(
        tmp_path.iterdir()
    )
