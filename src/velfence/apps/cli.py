"""The ``velfence`` command line: ``demo``, ``reproduce NAME [--json]``, ``bench``, ...

The console script enters through :mod:`velfence.apps._entry`, which answers with one line naming
the
``[app]`` extra when typer or another app-layer dependency is not installed.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import json
import sys
from pathlib import Path
from typing import Annotated, Any

from velfence._extras import missing

try:
    import typer
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence.errors import InvalidParameter, VelfenceError
from velfence.io.defaults import DEFAULT_MAX_STEPS

__all__ = [
    "EXIT_CODES",
    "EXIT_CODE_TABLE",
    "EXIT_VIOLATED",
    "REPRODUCTIONS",
    "SIM_SCENARIOS",
    "app",
    "main",
    "reproduction_dir",
    "reproduction_summary",
]

#: The exit codes of every ``velfence`` command: ``(code, commands, meaning)``, one row per case
#: (the table of docs/cli.md, row for row; tests/apps/cli/test_cli.py compares them).
EXIT_CODE_TABLE: tuple[tuple[int, str, str], ...] = (
    (0, "all", "everything the command claims holds"),
    (
        0,
        "reproduce",
        "a reproduction whose only failing checks are documented misses (counted in its summary)",
    ),
    (0, "bench", "bench without --strict that missed a target (the summary counts them)"),
    (1, "reproduce, sim", "a check failed that is not a documented miss"),
    (1, "bench --strict", "a benchmark target was missed, with --strict"),
    (
        2,
        "all",
        "bad input (an option, a config file, an unwritable --out) or a missing extra",
    ),
    (3, "bridge", "the DDS layer failed"),
    (
        4,
        "replay",
        "a bag holds nothing to replay (no message, no command or state topic, no command with "
        "a usable state)",
    ),
    (4, "bridge", "an unexpected internal error of the node (a bug; the traceback is logged)"),
    (
        5,
        "verify",
        "a property was violated: counterexamples written (with --replay: the scenario still "
        "fails)",
    ),
    (
        130,
        "all",
        "interrupted (Ctrl-C); teleop and view serve until Ctrl-C, which stops them cleanly (0), "
        "and bridge exits 130 only during start-up (once the node runs, SIGINT is a clean stop, 0)",
    ),
)

EXIT_CODES = "Exit codes (docs/cli.md):\n\n" + "\n\n".join(
    f"{code}: {meaning} ({'every command' if commands == 'all' else 'velfence ' + commands})"
    for code, commands, meaning in EXIT_CODE_TABLE
)

app = typer.Typer(
    help="Keep velocity-controlled robots inside their safe sets by shaping commanded velocity.",
    epilog=EXIT_CODES,
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: Exit code of ``velfence bridge`` after Ctrl-C during start-up (velfence.bridge's
#: ``EXIT_INTERRUPTED``; not imported from there: that loads the DDS binding).
EXIT_INTERRUPTED_CODE = 130
#: Exit code of ``velfence verify`` when a property was violated (counterexamples written), and
#: of ``velfence verify --replay`` when the scenario still fails.
EXIT_VIOLATED = 5

#: name -> "module:function" returning a velfence.apps.reproduce.Report given an output folder.
REPRODUCTIONS: dict[str, str] = {
    "wrist": "velfence.apps.reproduce.wrist:run",
    "cospm": "velfence.apps.reproduce.cospm:run",
    "obstacles": "velfence.apps.reproduce.obstacles:run",
    "cobot": "velfence.apps.reproduce.cobot:run",
    "telerobotics": "velfence.apps.reproduce.telerobotics:run",
}


#: Width of the output when stdout is not a terminal (a pipe, a file): wide enough that a table
#: prints every cell in full instead of cutting it to "per-j…" at rich's default of 80 columns.
PIPE_WIDTH = 10_000


def _stdout_console(**kwargs: Any) -> Console:
    """The console of a command's results: the terminal's width, or unlimited when piped."""
    return Console(width=None if sys.stdout.isatty() else PIPE_WIDTH, **kwargs)


def _fail(msg: str, code: int = 2) -> typer.Exit:
    # soft_wrap: the error stays on one line however narrow the terminal is.
    Console(stderr=True, soft_wrap=True).print(f"[bold red]error:[/] {escape(msg)}")
    return typer.Exit(code=code)


QuietOption = Annotated[
    bool,
    typer.Option(
        "--quiet",
        "-q",
        help="No progress display and no per-stage lines on stderr (results and errors only).",
    ),
]


def _tracker(title: str, plan: Any, quiet: bool, *, heartbeat_period: float = 30.0) -> Any:
    """The command's progress display on stderr (velfence.apps.progress)."""
    from velfence.apps.progress import Tracker

    return Tracker(
        plan,
        title=title,
        console=Console(stderr=True, soft_wrap=True),
        quiet=quiet,
        heartbeat_period=heartbeat_period,
    )


def _summary(console: Console, folder: Path | None, files: Any, verdict: str) -> None:
    """Print the closing summary: the folder and its main files, then the verdict."""
    from velfence.apps.progress import summary

    for line in summary(folder, list(files), verdict):
        console.print(escape(line), soft_wrap=True, highlight=False)


#: Where ``velfence study`` writes by default; ``velfence reproduce telerobotics`` reuses the
#: runs found there when they are the same study.
DEFAULT_STUDY_DIR = Path("out/study")


def reproduction_dir(name: str, out: Path | None) -> Path:
    """Where ``velfence reproduce NAME [--out DIR]`` writes: DIR itself, else out/reproduce/NAME.

    Args:
        name: The reproduction's name.
        out: The ``--out`` folder, or ``None`` when not given.

    Returns:
        The output folder.
    """
    return Path("out/reproduce") / name if out is None else out


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for plots, GIF and metrics.json.")] = Path(
        "out/demo"
    ),
    config: Annotated[
        Path | None,
        typer.Option(help="YAML scenario file (format: docs/config.md; defaults built in)."),
    ] = None,
    max_steps: Annotated[
        int,
        typer.Option(
            help="Largest number of simulated steps per method (duration / dt); raise it only "
            "for a deliberately long run (at most 100,000,000)."
        ),
    ] = DEFAULT_MAX_STEPS,
    scenario: Annotated[
        str,
        typer.Option(
            help="Which scenario: 'wrist' (the 2-D wrist, configurable with --config) or "
            "'arm-box' (a 7-DoF arm with its TCP in a box; docs/arm_box.md)."
        ),
    ] = "wrist",
    quiet: QuietOption = False,
) -> None:
    """Run the built-in wrist scenario (or --scenario arm-box) for every method; write plots.

    Exit code 0 when every file is written; 2 on bad input.
    """
    # Import everything the run needs first, so a missing app dependency is reported before any
    # simulation, not after it (velfence.apps._entry turns it into a one-line message).
    importlib.import_module("yaml")
    importlib.import_module("velfence.apps.viz.plots")
    from velfence.apps.demo import ARM_STAGES, SCENARIOS, WRIST_STAGES, run_arm_demo, run_demo

    if scenario not in SCENARIOS:
        raise _fail(f"--scenario: expected one of {list(SCENARIOS)}, got {scenario!r}")
    if scenario == "arm-box" and config is not None:
        raise _fail("--config applies to the wrist scenario only; drop it for --scenario arm-box")
    console = _stdout_console()
    arm = scenario == "arm-box"
    try:
        if arm:
            importlib.import_module("velfence.apps.viz.arm")
        with _tracker(f"velfence demo {scenario}", ARM_STAGES if arm else WRIST_STAGES, quiet):
            if arm:
                result = run_arm_demo(out_dir=out)
            else:
                result = run_demo(config_path=config, out_dir=out, max_steps=max_steps)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot write to {out}: {exc.strerror or exc}") from None
    console.print(result.table)
    _summary(console, out, result.artifacts, f"demo {scenario}: done (exit 0)")


@app.command()
def reproduce(
    name: Annotated[str, typer.Argument(help=f"One of: {', '.join(REPRODUCTIONS)}.")],
    json_out: Annotated[
        bool, typer.Option("--json", help="Print one JSON object (checks + artifacts).")
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Folder for the reproduction's files, written directly into it "
            "(default: out/reproduce/NAME)."
        ),
    ] = None,
    study: Annotated[
        Path | None,
        typer.Option(
            help="telerobotics only: reuse the runs of `velfence study --out DIR` when they are "
            "the same study (same settings, seed, velfence version and code; else it runs). "
            f"Default: {DEFAULT_STUDY_DIR} when it holds a study's runs."
        ),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Run a source's experiment and check our numbers against the source's.

    Exit code 0 when every check passes or is a documented miss (a source defect or an expected
    miss of ours, explained in docs/reproductions.md; counted in the summary); 1 when a check
    that is not a documented miss fails; 2 on bad input.
    """
    if name not in REPRODUCTIONS:
        raise _fail(f"unknown reproduction {name!r}; expected one of {sorted(REPRODUCTIONS)}")
    folder = reproduction_dir(name, out)
    if folder.exists() and not folder.is_dir():
        raise _fail(f"--out {folder} exists and is not a folder")
    options: dict[str, Any] = {}
    if name == "telerobotics":
        from velfence.apps.teleop.study import STUDY_RUNS

        if study is not None and not study.is_dir():
            raise _fail(f"--study {study}: expected the folder of a `velfence study --out` run")
        if study is None and (DEFAULT_STUDY_DIR / STUDY_RUNS).is_file():
            study = DEFAULT_STUDY_DIR
        options["study"] = study
    elif study is not None:
        raise _fail("--study applies to `velfence reproduce telerobotics` only")
    module, func = REPRODUCTIONS[name].split(":")
    loaded = importlib.import_module(module)
    run = getattr(loaded, func)
    err = Console(stderr=True)
    # A reproduction with stages reports them itself; any other runs as one stage.
    stages = getattr(loaded, "STAGES", None)
    if name == "telerobotics":  # reused study runs: a study stage of seconds, not minutes
        stages = loaded.stages(options["study"])
    from velfence.apps import progress

    with (
        _tracker(f"velfence reproduce {name}", stages or (("checks", 1.0),), quiet),
        progress.stage("checks") if stages is None else contextlib.nullcontext(),
    ):
        report = run(folder, **options)
    line, code = reproduction_summary(report)
    if json_out:
        sys.stdout.write(report.to_json() + "\n")
        _summary(err, folder, report.artifacts, line)
    else:
        table = Table(title=f"reproduce {name}", show_lines=True)
        table.add_column("check (source)", ratio=3)
        table.add_column("expected", ratio=1)
        table.add_column("measured", ratio=1)
        table.add_column("result", ratio=1)
        for c in report.checks:
            table.add_row(
                f"{c.name}\n[dim]{c.source}[/]",
                f"{c.expected} (tol {_short(c.tolerance)})",
                _short(c.measured),
                "[green]pass[/]"
                if c.passed
                else "[yellow]FAIL (source defect)[/]"
                if c.source_defect
                else "[yellow]FAIL (documented miss)[/]"
                if c.expected_miss
                else "[red]FAIL[/]",
            )
        console = _stdout_console()
        console.print(table)
        _summary(console, folder, report.artifacts, line)
    if code:
        raise typer.Exit(code=code)


def reproduction_summary(report: Any) -> tuple[str, int]:
    """The one-line summary of a reproduction and its exit code.

    Counts the checks that passed, the documented misses (failed checks flagged
    ``source_defect`` — the source's own law does not meet its claim — or ``expected_miss`` — a
    known miss of ours; both explained in the check's note and in docs/reproductions.md) and the
    undocumented failures, and says what the exit code means: 0 when there is no undocumented
    failure, 1 otherwise.

    Args:
        report: A :class:`velfence.apps.reproduce.Report`.

    Returns:
        The summary line and the exit code.
    """
    checks = report.checks
    passed = sum(1 for c in checks if c.passed)
    defects = sum(1 for c in checks if not c.passed and c.source_defect)
    documented = sum(1 for c in checks if c.documented_miss)
    failures = len(checks) - passed - documented
    if failures:
        meaning = "exit 1: a check that is not a documented miss failed"
    elif documented:
        meaning = "exit 0: every failure is a documented miss (see the notes and the report)"
    else:
        meaning = "exit 0: every check passed"
    line = (
        f"summary: {passed} of {len(checks)} checks passed, {documented} documented "
        f"miss{'es' * (documented != 1)} ({defects} source defect{'s' * (defects != 1)}, "
        f"{documented - defects} expected miss{'es' * (documented - defects != 1)} of ours), "
        f"{failures} undocumented failure{'s' * (failures != 1)} — {meaning}"
    )
    return line, 1 if failures else 0


#: ``velfence sim --scenario NAME`` -> (module, the robots it runs on).
SIM_SCENARIOS: dict[str, tuple[str, tuple[str, ...]]] = {
    "fence-box": ("velfence.apps.scenarios.fence_box", ("panda",)),
    "wrist-push": ("velfence.apps.scenarios.wrist", ("wrist",)),
    "redundant-obstacle": ("velfence.apps.scenarios.obstacles", ("seven_dof",)),
    "person-cell": ("velfence.apps.scenarios.person", ("panda",)),
}


@app.command()
def sim(
    scenario: Annotated[
        str, typer.Option(help=f"One of: {', '.join(SIM_SCENARIOS)} (docs/physics.md).")
    ] = "fence-box",
    robot: Annotated[
        str | None,
        typer.Option(help="The robot (each scenario has its own: panda, wrist, seven_dof)."),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(help="Folder for video, figures and metrics.json (default out/sim/NAME)."),
    ] = None,
    video: Annotated[bool, typer.Option(help="Render the side-by-side MP4 and GIF.")] = True,
    width: Annotated[int, typer.Option(min=64, max=1920, help="Video panel width (px).")] = 480,
    height: Annotated[int, typer.Option(min=48, max=1080, help="Video panel height (px).")] = 360,
    fps: Annotated[int, typer.Option(min=1, max=60, help="Video frames per second.")] = 25,
    columns: Annotated[
        int | None,
        typer.Option(min=1, max=8, help="Video panels per row (default: all in one row)."),
    ] = None,
    json_out: Annotated[
        bool, typer.Option("--json", help="Print one JSON object (checks + artifacts).")
    ] = False,
    quiet: QuietOption = False,
) -> None:
    """Run a robot in MuJoCo with velfence and its baselines; write video, plots, metrics.json.

    Exit code 0: every named check passed; 1: a check failed; 2: bad options or a missing extra.
    """
    import os

    from velfence.apps import progress

    if scenario not in SIM_SCENARIOS:
        raise _fail(f"--scenario: expected one of {list(SIM_SCENARIOS)}, got {scenario!r}")
    module, robots = SIM_SCENARIOS[scenario]
    if robot is not None and robot not in robots:
        raise _fail(f"--robot: scenario {scenario!r} runs on {list(robots)}, got {robot!r}")
    folder = Path("out/sim") / scenario if out is None else out
    if folder.exists() and not folder.is_dir():
        raise _fail(f"--out {folder} exists and is not a folder")
    if importlib.util.find_spec("mujoco") is None:
        raise _fail("velfence sim needs MuJoCo: pip install 'velfence[physics]'")
    os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering, read when MuJoCo loads
    from velfence.apps.scenarios.output import write_outputs

    plan = (("simulating", 120.0), ("figures and video" if video else "figures", 100.0 * video + 5))
    try:
        with _tracker(f"velfence sim {scenario}", plan, quiet):
            with progress.stage("simulating") as report_sim:
                runner = importlib.import_module(module).run

                def step(name: str, f: float) -> None:
                    report_sim(f, 1.0, name)

                result = runner(on_step=step)
            with progress.stage(plan[1][0]):
                files = write_outputs(
                    result,
                    folder,
                    video=video,
                    width=width,
                    height=height,
                    fps=fps,
                    columns=columns,
                )
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot write to {folder}: {exc.strerror or exc}") from None
    report = result.report
    # A scenario's notice (person-cell: advisory, not certified) goes with its results.
    notice = getattr(importlib.import_module(module), "NOTICE", None)
    if json_out:
        doc = report.to_dict()
        doc["artifacts"] = [str(f) for f in files]
        if notice is not None:
            doc["notice"] = notice
        sys.stdout.write(json.dumps(doc, indent=2) + "\n")
    else:
        console = _stdout_console()
        table = Table(title=f"sim {scenario} (MuJoCo)")
        table.add_column(escape("metric [unit]"))
        for name in result.metrics:
            table.add_column(name)
        for key, unit in result.units.items():
            table.add_row(
                escape(f"{key} [{unit}]"),
                # A run may lack a metric (person-cell's mode metrics: only the people run).
                *(
                    _short(result.metrics[m][key]) if key in result.metrics[m] else "-"
                    for m in result.metrics
                ),
            )
        console.print(table)
        for c in report.checks:
            mark = "[green]pass[/]" if c.passed else "[red]FAIL[/]"
            console.print(f"{mark}  {escape(c.name)}: {_short(c.measured)} ({c.expected})")
        if notice is not None:
            console.print(f"[yellow]note:[/] {escape(notice)}")
    failed = sum(1 for c in report.checks if not c.passed)
    _summary(
        Console(stderr=True) if json_out else Console(),
        folder,
        files,
        f"{len(report.checks) - failed}/{len(report.checks)} checks passed"
        + (f", {failed} failed (exit 1)" if failed else " (exit 0)"),
    )
    if failed:
        raise typer.Exit(code=1)


@app.command()
def bench(
    out: Annotated[
        Path | None,
        typer.Option(
            help="Write the markdown report here (e.g. out/benchmarks.md; docs/benchmarks.md "
            "only to update the published numbers). Default: print it."
        ),
    ] = None,
    quick: Annotated[bool, typer.Option(help="Small sizes, a few seconds.")] = False,
    json_path: Annotated[
        Path | None, typer.Option("--json", help="Also write the raw report as JSON here.")
    ] = None,
    strict: Annotated[
        bool, typer.Option("--strict", help="Exit 1 when a benchmark target is missed.")
    ] = False,
    quiet: QuietOption = False,
) -> None:
    """Time shape() per call and shape_batch() throughput, side by side with a QP baseline.

    Exit code 0 (the summary counts the missed targets); with --strict, 1 when a target is
    missed; 2 on bad input.
    """
    from velfence.apps import bench as bench_app
    from velfence.apps import progress

    for option, path in (("--out", out), ("--json", json_path)):
        if path is not None and path.is_dir():  # refused before minutes of timing, not after
            raise _fail(f"{option} {path} is a folder; expected a file path")
    # Seconds on the development machine (quick: 26-43 s with numba's kernels cached, 86-140 s
    # when they compile); within the stage each step counts its expected cost
    # (velfence.apps.bench.plan), and off a terminal a line every 10 s carries the estimate.
    plan = (("benchmarks", 60.0 if quick else 300.0),)
    tracker = _tracker("velfence bench", plan, quiet, heartbeat_period=10.0)
    with tracker, progress.stage("benchmarks") as report_bench:
        report = bench_app.run_benchmarks(
            quick=quick, progress=lambda what, f: report_bench(f, 1.0, what)
        )
    # Status lines go to stderr when stdout carries the Markdown (so it can be redirected).
    console = Console(stderr=True) if out is None else _stdout_console()
    if out is not None:
        try:
            bench_app.write_report(
                report, out
            )  # keeps a hand-written preamble above the generated part
        except VelfenceError as exc:
            raise _fail(str(exc)) from None
        console.print(f"[green]wrote[/] {escape(str(out))}")
    else:
        sys.stdout.write(report.to_markdown())
    if json_path is not None:
        try:
            json_path.parent.mkdir(parents=True, exist_ok=True)
            json_path.write_text(json.dumps(report.to_dict(), indent=2) + "\n", encoding="utf-8")
        except OSError as exc:
            raise _fail(f"--json: cannot write {json_path}: {exc.strerror or exc}") from None
        console.print(f"[green]wrote[/] {escape(str(json_path))}")
    if out is not None:  # the Markdown was not printed: list the targets
        for t in report.targets:
            mark = "[green]pass[/]" if t.passed else "[red]FAIL[/]"
            console.print(f"{mark}  {escape(t.name)}: {t.measured:.3g} {t.unit} ({t.target})")
    missed = sum(1 for t in report.targets if not t.passed)
    code = 1 if strict and missed else 0
    verdict = (
        f"bench: {len(report.targets) - missed} of {len(report.targets)} targets met, "
        f"{missed} missed"
        + (
            f" (exit {code}{'' if strict else '; --strict makes a missed target exit 1'})"
            if missed
            else " (exit 0)"
        )
    )
    written = [p for p in (out, json_path) if p is not None]
    _summary(console, None, written, verdict)
    if code:
        raise typer.Exit(code=code)


@app.command()
def teleop(
    port: Annotated[int, typer.Option(help="TCP port on 127.0.0.1 (0 picks a free one).")] = 8765,
    no_browser: Annotated[
        bool, typer.Option("--no-browser", help="Print the URL only; do not open a browser.")
    ] = False,
    start: Annotated[
        bool, typer.Option("--start", help="Start the clock now, not when the page is opened.")
    ] = False,
    canvas: Annotated[
        bool,
        typer.Option(
            "--canvas",
            help="The light 2-D canvas page (no viser); the default when the web extra is absent.",
        ),
    ] = False,
) -> None:
    """Drive the simulated PUMA 560 (laser-assisted traded control) from a local web page.

    The 3-D view is viser's (``velfence view --scenario teleop``) when the ``web`` extra is
    installed; ``--canvas`` (or no viser) serves the dependency-free canvas page instead.
    """
    if not canvas and importlib.util.find_spec("viser") is not None:
        from velfence.apps.viewer.view import serve_scene

        _serve_page(
            "velfence teleop", lambda: serve_scene("teleop", port=port, start=start), port,
            no_browser,
        )  # fmt: skip
        return
    from velfence.apps.teleop.session import Session
    from velfence.apps.viewer import server as viewer

    _serve_page(
        "velfence teleop", lambda: viewer.serve(Session(), port=port, start=start), port, no_browser
    )


@app.command()
def view(
    scenario: Annotated[
        str, typer.Option(help="Scenario: teleop, arm-box or fence-box (MuJoCo, extra physics).")
    ] = "teleop",
    scene: Annotated[
        str | None,
        typer.Option(hidden=True, help="Former name of --scenario (warns; goes in 0.3)."),
    ] = None,
    port: Annotated[
        int, typer.Option(min=0, max=65535, help="TCP port on 127.0.0.1 (0 picks a free one).")
    ] = 8765,
    start: Annotated[
        bool, typer.Option("--start", help="Start the clock now, not when the page is opened.")
    ] = False,
    no_browser: Annotated[
        bool, typer.Option("--no-browser", help="Print the URL only; do not open a browser.")
    ] = False,
) -> None:
    """Show a scenario as a 3-D web view (viser, extra web) and drive it with the teleop keys."""
    from velfence.apps.viewer.view import serve_scene

    if scene is not None:  # the option's name before 0.2: the same values as demo/sim --scenario
        typer.echo(
            "warning: velfence view --scene is now --scenario; the old option goes in 0.3",
            err=True,
        )
        scenario = scene

    _serve_page(
        f"velfence view ({scenario})", lambda: serve_scene(scenario, port=port, start=start), port,
        no_browser,
    )  # fmt: skip


def _serve_page(title: str, serve: Any, port: int, no_browser: bool) -> None:
    """Start a local web page's server, print (and open) its URL, serve until Ctrl-C."""
    import webbrowser

    try:
        server = serve()
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot listen on 127.0.0.1:{port} ({exc}); try another --port") from None
    console = _stdout_console()
    console.print(f"{title}: open {server.url}  (Ctrl-C to stop)", highlight=False)
    if not no_browser:
        webbrowser.open(server.url)
    try:
        while not server.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    console.print("stopped")


@app.command()
def bridge(
    config: Annotated[
        Path, typer.Option(help="Bridge YAML file: bridge: + shaper: sections (docs/bridge.md).")
    ],
    duration: Annotated[
        float | None, typer.Option(help="Stop after this many seconds (default: SIGINT/SIGTERM).")
    ] = None,
    foxglove: Annotated[
        bool, typer.Option(help="Serve a live Foxglove view on 127.0.0.1 (docs/foxglove.md).")
    ] = False,
    foxglove_port: Annotated[
        int, typer.Option(min=0, max=65535, help="Port of the Foxglove view (0: any free one).")
    ] = 8765,
    record: Annotated[
        Path | None, typer.Option(help="Also record the view to this new MCAP file.")
    ] = None,
) -> None:
    """Run the ROS 2 DDS filter node (extra ros).

    Exit 0 stopped, 2 bad config, 3 DDS failed, 4 internal error (a bug), 130 interrupted
    (Ctrl-C) during start-up.
    """
    view = None
    try:
        from velfence.bridge import load_bridge_config, serve

        loaded = load_bridge_config(config)  # read once: the node and the view share it
        if foxglove or record is not None:
            view = _bridge_view(loaded, foxglove_port if foxglove else None, record)
        code = serve(loaded, duration=duration, on_cycle=None if view is None else view[1])
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except KeyboardInterrupt:  # Ctrl-C before the node's own SIGINT handler is in place
        Console(stderr=True, soft_wrap=True).print("velfence bridge: interrupted during start-up")
        code = EXIT_INTERRUPTED_CODE
    finally:
        if view is not None:
            view[0].close()
    raise typer.Exit(code=code)


def _bridge_view(config: Any, port: int | None, record: Path | None) -> tuple[Any, Any]:
    """The Foxglove view of ``velfence bridge --foxglove/--record`` and its on_cycle hook.

    ``config`` is the loaded :class:`~velfence.bridge.BridgeConfig` the node runs.
    """
    from velfence.bridge import FoxgloveView, view_hook

    shaped = config.shaper
    if shaped.command_space == "twist":
        raise InvalidParameter(
            "--foxglove/--record: a twist-mode safety filter is not drawn (its command is a TCP "
            "velocity, its output joint velocities); use mode: joint, or leave the view off"
        )
    fence = getattr(shaped.shaper, "polygon", None) or getattr(shaped.shaper, "polytope", None)
    if fence is not None and getattr(fence, "dim", 2) > 3:
        fence = None  # a joint-space box of more than 3 joints: status and velocities only
    view = FoxgloveView(port=port, record=record, fence=fence)
    return view, view_hook(view)


@app.command()
def study(
    subjects: Annotated[int, typer.Option(min=1, help="Simulated subjects (thesis: 10).")] = 10,
    runs: Annotated[int, typer.Option(min=1, help="Runs per mode per subject (thesis: 3).")] = 3,
    seed: Annotated[int, typer.Option(min=0, help="Study seed (reproducible).")] = 0,
    out: Annotated[
        Path,
        typer.Option(
            help="Folder for study.json, plots, animation and the runs (study_runs.npz, which "
            "`velfence reproduce telerobotics --study DIR` reuses)."
        ),
    ] = DEFAULT_STUDY_DIR,
    json_out: Annotated[
        bool, typer.Option("--json", help="Print one JSON object (summary + artifacts).")
    ] = False,
    animation: Annotated[
        bool,
        typer.Option(
            help="Render one laser-assisted run as an animation (assisted_run.gif) and one "
            "picture of its autonomous approach (assisted_snapshot.png)."
        ),
    ] = True,
    quiet: QuietOption = False,
) -> None:
    """Simulated pick-and-place study (Khokar 2009 §7.2): unassisted vs laser-assisted.

    Exit code 0 when every file is written; 2 on bad input.
    """
    from velfence.apps import progress
    from velfence.apps.teleop.study import assisted_run, run_study, save_runs
    from velfence.apps.viz.study import animate_run, snapshot_run, write_study

    if out.exists() and not out.is_dir():  # refused before minutes of runs, not after
        raise _fail(f"--out {out} exists and is not a folder")
    n_runs = subjects * runs * 2
    plan = [("pick-and-place runs", 5.0 * n_runs), ("study files", 3.0)]
    if animation:
        plan += [("assisted run", 6.0), ("assisted_run.gif", 10.0), ("assisted_snapshot.png", 1.0)]
    try:  # run_study checks the counts and the seed before any run: a bad one exits 2 at once
        with _tracker("velfence study", plan, quiet):
            with progress.stage("pick-and-place runs") as report_runs:
                result = run_study(
                    subjects,
                    runs,
                    seed,
                    progress=lambda done, n: report_runs(done, n, f"run {done}/{n}"),
                )
            with progress.stage("study files"):
                artifacts = [str(p) for p in write_study(result, out)]
                artifacts.append(str(save_runs(result, out)))
            if animation:
                with progress.stage("assisted run"):
                    run = assisted_run(seed=seed)
                with progress.stage("assisted_run.gif"):
                    artifacts.append(str(animate_run(run, out / "assisted_run.gif")))
                with progress.stage("assisted_snapshot.png"):
                    artifacts.append(str(snapshot_run(run, out / "assisted_snapshot.png")))
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot write to {out}: {exc.strerror or exc}") from None
    summary = result.summary()
    verdict = (
        f"study: {summary['subjects_faster_assisted']}/{subjects} subjects faster with "
        "assistance (exit 0)"
    )
    if json_out:
        sys.stdout.write(json.dumps({"summary": summary, "artifacts": artifacts}) + "\n")
        _summary(Console(stderr=True), out, artifacts, verdict)
        return
    table = Table(title=f"simulated study: {subjects} subjects x {runs} runs per mode")
    table.add_column("per-subject mean")
    table.add_column("unassisted", justify="right")
    table.add_column("laser assisted", justify="right")
    for key, unit in (
        ("time", "s"),
        ("path_length", "m"),
        ("straightness", "1"),
        ("segments", "count"),
        ("clutch_presses", "count"),
        ("index_events", "count"),
        ("collisions", "count"),
    ):
        row = summary[key]
        table.add_row(
            escape(f"{key} [{unit}]"),  # unescaped, rich would read "[s]" as markup
            f"{row['unassisted']['mean']:.3g}",
            f"{row['assisted']['mean']:.3g}",
        )
    console = _stdout_console()
    console.print(table)
    console.print(
        f"faster with assistance: {summary['subjects_faster_assisted']}/{subjects} subjects "
        f"(thesis: 10/10); mean speed-up x{summary['speedup_mean']:.2f}"
    )
    _summary(console, out, artifacts, verdict)


#: ``velfence replay``'s exit code when a bag holds nothing to replay (docs/cli.md).
NOTHING_TO_REPLAY = 4


@app.command()
def verify(
    campaign: Annotated[
        Path | None,
        typer.Argument(help="Campaign YAML (docs/config.md, docs/verify.md).", show_default=False),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option(
            help="Output folder: shards, report, counterexamples (default out/verify/CAMPAIGN)."
        ),
    ] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Skip the shards already in --out (same campaign).")
    ] = False,
    workers: Annotated[
        int | None,
        typer.Option(
            min=0,
            help="Run the shards on the engine's embedded Dask cluster with N worker processes "
            "(0: the serial engine; default: serial in this process).",
        ),
    ] = None,
    cluster: Annotated[
        str | None,
        typer.Option(help="Address of a running Dask scheduler to run the shards on."),
    ] = None,
    replay_file: Annotated[
        Path | None,
        typer.Option("--replay", help="Run a counterexample scenario (YAML) again instead."),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Run an evidence campaign (randomised closed loops, margins per step); write its report.

    Shards run serially or through the engine (--workers, --cluster); failing cases are shrunk to
    YAML scenarios that --replay runs again. Exit codes: 0 every property held; 5 a property was
    violated (counterexamples written; with --replay: the scenario still fails); 2 bad input;
    130 interrupted (the report then says incomplete).
    """
    from velfence.apps import progress

    if replay_file is not None:
        if campaign is not None:
            raise _fail("give a campaign file or --replay SCENARIO, not both")
        from velfence.apps.verify import replay as run_again

        try:
            r = run_again(replay_file)
        except VelfenceError as exc:
            raise _fail(str(exc)) from None
        console = _stdout_console(highlight=False)
        for prop, (m, step) in r.worst.items():
            console.print(f"{prop}: worst margin {m:.6g} at step {step}", highlight=False)
        if r.violated:
            verdict = (
                f"summary: {replay_file} still fails ({', '.join(r.violated)}, first at step "
                f"{min(r.first.values())} of {r.steps}) — exit {EXIT_VIOLATED}"
            )
        else:
            verdict = f"summary: {replay_file} holds every property in {r.steps} steps — exit 0"
        _summary(console, None, [], verdict)
        if r.violated:
            raise typer.Exit(code=EXIT_VIOLATED)
        return
    if campaign is None:
        raise _fail("give a campaign file (velfence verify CAMPAIGN.yaml) or --replay SCENARIO")
    from velfence.apps.verify import load_campaign
    from velfence.apps.verify import verify as run_campaign

    try:
        spec = load_campaign(campaign)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    folder = Path("out/verify") / campaign.stem if out is None else out
    try:
        with contextlib.ExitStack() as stack:
            mapper = None
            if workers is not None or cluster is not None:
                mapper = stack.enter_context(_engine_map(workers, cluster))
            stack.enter_context(
                _tracker(f"velfence verify {campaign.name}", [("cases", 1.0)], quiet)
            )
            report = stack.enter_context(progress.stage("cases"))
            kwargs: dict[str, Any] = {} if mapper is None else {"mapper": mapper}
            outcome = run_campaign(spec, folder, resume=resume, on_progress=report, **kwargs)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    console = _stdout_console(highlight=False)
    s = outcome.summary
    for prop, (m, fam, index, step) in s.worst.items():
        console.print(f"{prop}: worst margin {m:.6g} ({fam} #{index}, step {step})")
    if outcome.interrupted:
        verdict = (
            f"summary: stopped early, {s.shards_done}/{s.shards_total} shards; report marked "
            f"INCOMPLETE — exit {EXIT_INTERRUPTED_CODE}"
        )
        code = EXIT_INTERRUPTED_CODE
    elif s.holds:
        verdict = (
            f"summary: {sum(s.cases.values()):,} cases, {sum(s.steps.values()):,} steps, every "
            "property held — exit 0"
        )
        code = 0
    else:
        verdict = (
            f"summary: {len(s.failing)} of {sum(s.cases.values()):,} cases violated a property; "
            f"{len(outcome.counterexamples)} counterexample(s) written — exit {EXIT_VIOLATED}"
        )
        code = EXIT_VIOLATED
    _summary(console, folder, outcome.files, verdict)
    if code:
        raise typer.Exit(code=code)


@contextlib.contextmanager
def _engine_map(workers: int | None, cluster: str | None) -> Any:
    """The engine's ``map`` as a verify mapper (velfence.apps.engine), the engine started."""
    from velfence.apps.engine import Engine

    with Engine(cluster=cluster, workers=workers) as engine:
        yield engine.map


@app.command()
def replay(
    bags: Annotated[
        list[Path],
        typer.Argument(
            help="One or more bags: rosbag2 directories (MCAP or sqlite3), folders holding one "
            ".mcap or .db3 file, or such files.",
            show_default=False,
        ),
    ],
    config: Annotated[Path, typer.Option(help="YAML with shaper: and replay: (docs/replay.md).")],
    out: Annotated[
        Path | None,
        typer.Option(
            help="The bag directory to write (must not exist); with several bags, the folder "
            "that gets one output bag per input. Optional with --summary (then the shaped bags "
            "are kept only when it is given).",
            show_default=False,
        ),
    ] = None,
    plot: Annotated[
        Path | None,
        typer.Option(
            help="Also write this figure (.png); with several bags, a folder of them; with "
            "--summary, the fleet's figure (.png)."
        ),
    ] = None,
    storage: Annotated[
        str | None, typer.Option(help="mcap or sqlite3 (default: the input's storage).")
    ] = None,
    summary: Annotated[
        bool,
        typer.Option(
            "--summary",
            help="Fleet replay: every bag given or found under the folders given, one table "
            "per bag and per robot (docs/replay.md); unreadable bags are listed and skipped.",
        ),
    ] = False,
    cluster: Annotated[
        str | None,
        typer.Option(
            help="With --summary: the Dask scheduler to run on (tcp://host:8786; default: "
            "DASK_SCHEDULER_ADDRESS, else an embedded cluster; docs/distributed.md).",
            show_default=False,
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(
            help="With --summary: worker processes of the embedded cluster (default: the "
            "cores); 0 replays the bags one after the other in this process.",
            show_default=False,
        ),
    ] = None,
    table: Annotated[
        Path | None,
        typer.Option(help="With --summary: also write the table to this .md or .csv file."),
    ] = None,
    tol: Annotated[
        float | None,
        typer.Option(
            help="With --summary: a change larger than this [command unit] counts as the filter "
            "acting (default 1e-9).",
            show_default=False,
        ),
    ] = None,
    quiet: QuietOption = False,
) -> None:
    """Shape bags' recorded commands with a configured shaper; write new bags (+ figures).

    With --summary, replay a whole fleet (folders of bags, on an embedded Dask cluster, a
    cluster at --cluster, or --workers 0 in this process) and print one table.

    Exit codes: 0 every bag replayed; 2 bad input (config, a malformed bag, an existing --out);
    4 a bag holds nothing to replay (no messages, no command or state topic, no command paired
    with a state). With several bags, the largest code of any bag; 130 on Ctrl-C.
    """
    from velfence.apps import progress
    from velfence.errors import NothingToReplay
    from velfence.io.bags import replay as run_replay

    if summary:
        _replay_fleet(bags, config, out, plot, cluster, workers, table, tol, quiet)
        return
    extra = [n for n, v in (("--cluster", cluster), ("--workers", workers), ("--table", table),
                            ("--tol", tol)) if v is not None]  # fmt: skip
    if extra:
        raise _fail(f"{', '.join(extra)}: only with --summary (a fleet replay)")
    if out is None:
        raise _fail("--out: the bag directory to write is required (or give --summary)")
    if len(bags) == 1:
        plan = [("shaping", 10.0)] + ([("figure", 2.0)] if plot is not None else [])
        try:
            with _tracker(f"velfence replay {bags[0].name}", plan, quiet):
                with progress.stage("shaping") as report_shaping:
                    s = run_replay(
                        bags[0],
                        config,
                        out,
                        storage=storage,
                        progress=lambda f: report_shaping(f, 1.0, "messages"),
                    )
                if plot is not None:
                    from velfence.apps.viz.replay import plot_replay

                    with progress.stage("figure"):
                        plot_replay(s, plot)
        except NothingToReplay as exc:
            raise _fail(str(exc), code=NOTHING_TO_REPLAY) from None
        except VelfenceError as exc:
            raise _fail(str(exc)) from None
        console = _stdout_console(highlight=False)
        _print_replay(console, s)
        verdict = (
            f"summary: {s.commands} commands replayed, {s.changed} changed, {s.zeroed} written "
            "as zero — exit 0"
        )
        _summary(console, None, [s.out, *([plot] if plot is not None else [])], verdict)
        return
    _replay_many(bags, config, out, plot, storage, quiet)


def _print_replay(console: Console, s: Any) -> None:
    console.print(
        f"{s.commands} commands on {escape(s.command_topic)} ({s.command_type}) shaped by a "
        f"{s.kind} shaper with {s.states} states of {escape(s.state_topic)}: {s.changed} changed "
        f"({100 * s.changed_fraction:.1f} %), max |command - shaped| = {s.max_abs_change:.4g} "
        f"{s.unit}"
    )
    console.print(
        f"written as zero: {s.zeroed} ({s.zeroed_no_state} before any state, {s.zeroed_stale} "
        f"with a stale state, {s.zeroed_invalid} non-finite)"
    )
    if s.clouds_used or s.clouds_dropped:
        dropped = ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in s.clouds_dropped.items())
        console.print(
            f"sensor messages: {s.clouds_used} used, {sum(s.clouds_dropped.values())} dropped"
            + (f" ({dropped})" if dropped else "")
        )
    console.print(
        f"  wrote {escape(str(s.out))} ({s.storage}, {s.messages} messages, "
        f"shaped on {escape(s.output_topic)})"
    )


def _fraction_of_messages(report: Any) -> Any:
    """A replay's progress callback (a fraction) reported to a stage as messages done."""

    def on_fraction(f: float) -> None:
        report(f, 1.0, "messages")

    return on_fraction


def _bag_weight(bag: Path) -> float:
    """A bag's share of the progress bar: its size in MB (at least a little)."""
    try:
        files = [bag] if bag.is_file() else [f for f in bag.iterdir() if f.is_file()]
        return max(sum(f.stat().st_size for f in files) / 1e6, 0.01)
    except OSError:
        return 0.01


def _replay_many(
    bags: list[Path],
    config: Path,
    out: Path,
    plot: Path | None,
    storage: str | None,
    quiet: bool,
) -> None:
    """``velfence replay IN IN ...``: each bag to OUT/<name>, one table, the largest exit code."""
    from rich.table import Table

    from velfence.apps import progress
    from velfence.errors import NothingToReplay
    from velfence.io.bags import load_replay_config
    from velfence.io.bags import replay as run_replay

    if len(set(bags)) != len(bags):
        raise _fail(f"bags: the same bag is given twice ({[str(b) for b in bags]})")
    for folder, what in ((out, "--out"), (plot, "--plot")):
        if folder is not None and folder.exists() and not folder.is_dir():
            raise _fail(f"{what}: with several bags, expected a folder, got the file {folder}")
    try:  # a bad config is one error for the command, not one per bag
        load_replay_config(config)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    from velfence.apps.fleet import output_names

    names = output_names(bags)
    plan = [
        (f"{k + 1}/{len(bags)} {n}", _bag_weight(b))
        for k, (b, n) in enumerate(zip(bags, names, strict=True))
    ]
    rows: list[tuple[str, Any, str, int]] = []  # name, summary or None, status, code
    out.mkdir(parents=True, exist_ok=True)
    if plot is not None:
        plot.mkdir(parents=True, exist_ok=True)
    with _tracker(f"velfence replay {len(bags)} bags", plan, quiet):
        for (stage, _), bag, name in zip(plan, bags, names, strict=True):
            with progress.stage(stage) as report:
                try:
                    s = run_replay(
                        bag,
                        config,
                        out / name,
                        storage=storage,
                        progress=_fraction_of_messages(report),
                    )
                    if plot is not None:
                        from velfence.apps.viz.replay import plot_replay

                        plot_replay(s, plot / f"{name}.png")
                except NothingToReplay as exc:
                    rows.append((name, None, f"nothing to replay: {exc}", NOTHING_TO_REPLAY))
                except VelfenceError as exc:
                    rows.append((name, None, f"error: {exc}", 2))
                else:
                    rows.append((name, s, "ok", 0))
    table = Table(title=f"velfence replay: {len(bags)} bags with {config.name}")
    for col in ("bag", "commands", "changed", "max change", "written as zero", "status"):
        table.add_column(col, justify="left" if col in ("bag", "status") else "right")
    for (_, s, status, code), bag in zip(rows, bags, strict=True):
        if s is None:
            short = status.split(":", 1)[0]
            table.add_row(escape(str(bag)), "-", "-", "-", "-", f"{short} (exit {code})")
        else:
            table.add_row(
                escape(str(bag)),
                str(s.commands),
                f"{100 * s.changed_fraction:.1f} %",
                f"{s.max_abs_change:.4g} {s.unit}",
                str(s.zeroed),
                "ok",
            )
    console = _stdout_console(highlight=False)
    console.print(table)
    for (_, s, status, _), bag in zip(rows, bags, strict=True):
        if s is None:
            console.print(f"{escape(str(bag))}: {escape(status)}", soft_wrap=True)
    code = max(c for *_, c in rows)
    ok = sum(1 for *_, c in rows if c == 0)
    files = [out / n for (n, _, _, c) in rows if c == 0]
    verdict = f"summary: {ok} of {len(bags)} bags replayed — exit {code}"
    _summary(console, out, files, verdict)
    if code:
        raise typer.Exit(code=code)


def _replay_fleet(
    bags: list[Path],
    config: Path,
    out: Path | None,
    plot: Path | None,
    cluster: str | None,
    workers: int | None,
    table: Path | None,
    tol: float | None,
    quiet: bool,
) -> None:
    """``velfence replay DIR_OR_BAGS --summary``: the fleet's table, the largest exit code."""
    from rich.table import Table

    from velfence.apps import progress
    from velfence.apps.engine import Engine
    from velfence.apps.fleet import COLUMNS, find_bags, fleet_replay

    for path, what, suffixes in ((plot, "--plot", (".png", ".svg", ".pdf")),
                                 (table, "--table", (".md", ".csv"))):  # fmt: skip
        if path is not None and path.suffix.lower() not in suffixes:
            raise _fail(f"{what}: expected a {' or '.join(suffixes)} file, got {path}")
    interrupted = False
    engine: Engine | None = None
    try:
        found = find_bags(bags)
        if not found:
            raise _fail(f"bags: no bag (metadata.yaml, .mcap, .db3) under {[str(b) for b in bags]}")
        engine = Engine(cluster=cluster, workers=workers)
        title = f"velfence replay --summary: {len(found)} bags"
        plan = [("engine", 2.0), ("bags", 10.0)] + ([("figure", 1.0)] if plot else [])
        with _tracker(title, plan, quiet):
            with progress.stage("engine"):
                engine.start()
            with progress.stage("bags") as report:
                fleet = fleet_replay(
                    found, config, engine=engine, tol=tol, out=out, progress=report
                )
            if plot is not None:
                from velfence.apps.viz.fleet import plot_fleet

                with progress.stage("figure"):
                    plot_fleet(fleet, plot)
    except KeyboardInterrupt:
        interrupted = True
    except typer.Exit:
        raise
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    finally:
        if engine is not None:
            try:
                engine.close()
            except KeyboardInterrupt:  # a second Ctrl-C while the cluster stops
                interrupted = True
    if interrupted:
        Console(stderr=True).print("velfence replay: interrupted; no summary (exit 130)")
        raise typer.Exit(code=EXIT_INTERRUPTED_CODE)
    grid = Table(title=f"velfence replay --summary with {config.name}: {fleet.headline}")
    for col in COLUMNS:
        grid.add_column(col, justify="right" if col in ("cycles", "acted") else "left")
    for row in fleet.rows():
        grid.add_row(*(escape(row[c]) for c in COLUMNS))
    console = _stdout_console(highlight=False)
    console.print(grid)
    files: list[Path] = []
    if table is not None:
        text = fleet.csv() if table.suffix.lower() == ".csv" else fleet.markdown()
        try:
            table.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise _fail(f"--table: cannot write {table}: {exc.strerror or exc}") from None
        files.append(table)
    if plot is not None:
        files.append(plot)
    mode = "serial" if engine is None else engine.mode
    address = "" if engine is None else engine.address
    where = {"serial": "in this process", "local": "on an embedded Dask cluster",
             "cluster": f"on {address}"}[mode]  # fmt: skip
    verdict = f"summary: {fleet.headline} ({where}) — exit {fleet.code}"
    _summary(console, out, files, verdict)
    if fleet.code:
        raise typer.Exit(code=fleet.code)


def _short(x: object) -> str:
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def plain_help(text: str | None) -> str | None:
    """Docstring text as plain terminal help: RST roles and inline literals without markup.

    ``:class:`~velfence.bridge.BridgeConfig``` becomes ``BridgeConfig``, ````velfence view````
    becomes ``velfence view``; typer shows a command's docstring as its ``--help`` text.

    Args:
        text: A docstring or help string (``None`` passes through).

    Returns:
        The plain text.
    """
    if text is None:
        return None
    import re

    def role(m: re.Match[str]) -> str:
        target = m.group(1)
        return target.lstrip("~").rsplit(".", 1)[-1] if target.startswith("~") else target

    text = re.sub(r":[a-z]+(?::[a-z]+)?:`([^`]+)`", role, text)
    return reflow(re.sub(r"``([^`]+)``", r"\1", text))


def reflow(text: str) -> str:
    """Each paragraph of ``text`` on one line, so the terminal wraps it at its own width.

    A docstring's hard line breaks would otherwise be kept inside a paragraph and break lines
    mid-sentence in ``--help``. Paragraphs are separated by blank lines; a paragraph with an
    indented line or a list item (``-``, ``*``) keeps its lines.

    Args:
        text: Help text, dedented or not.

    Returns:
        The text with its paragraphs joined and separated by one blank line.
    """
    import inspect
    import re

    out = []
    for para in re.split(r"\n[ \t]*\n", inspect.cleandoc(text)):
        lines = para.split("\n")
        if any(ln.startswith((" ", "\t", "- ", "* ")) for ln in lines[1:]):
            out.append(para)
        else:
            out.append(" ".join(ln.strip() for ln in lines))
    return "\n\n".join(out)


def _plain_command_help() -> None:
    """Every command's help (its docstring unless given) and every option's help, plain."""
    import inspect
    import typing

    for cmd in app.registered_commands:
        cmd.help = plain_help(cmd.help or inspect.getdoc(cmd.callback))
        hints = typing.get_type_hints(cmd.callback, include_extras=True)
        for hint in hints.values():
            for meta in getattr(hint, "__metadata__", ()):
                if isinstance(getattr(meta, "help", None), str):
                    meta.help = plain_help(meta.help)


_plain_command_help()


def main() -> None:
    """Entry point of the ``velfence`` script."""
    app()


if __name__ == "__main__":
    main()
