"""The ``velfence`` command line: ``demo``, ``reproduce NAME [--json]``, ``bench``, ...

The console script enters through :mod:`velfence.apps._entry`, which answers with one line naming
the
``[app]`` extra when typer or another app-layer dependency is not installed.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from velfence.errors import InvalidParameter, VelfenceError
from velfence.io.defaults import DEFAULT_MAX_STEPS

__all__ = [
    "REPRODUCTIONS",
    "SIM_SCENARIOS",
    "app",
    "main",
    "reproduction_dir",
    "reproduction_summary",
]

app = typer.Typer(
    help="Keep velocity-controlled robots inside their safe sets by shaping commanded velocity.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: name -> "module:function" returning a velfence.apps.reproduce.Report given an output folder.
REPRODUCTIONS: dict[str, str] = {
    "wrist": "velfence.apps.reproduce.wrist:run",
    "cospm": "velfence.apps.reproduce.cospm:run",
    "obstacles": "velfence.apps.reproduce.obstacles:run",
    "cobot": "velfence.apps.reproduce.cobot:run",
    "telerobotics": "velfence.apps.reproduce.telerobotics:run",
}


def _fail(msg: str) -> typer.Exit:
    # soft_wrap: the error stays on one line however narrow the terminal is.
    Console(stderr=True, soft_wrap=True).print(f"[bold red]error:[/] {escape(msg)}")
    return typer.Exit(code=2)


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
) -> None:
    """Run the built-in wrist scenario (or --scenario arm-box) for every method; write plots."""
    # Import everything the run needs first, so a missing app dependency is reported before any
    # simulation, not after it (velfence.apps._entry turns it into a one-line message).
    importlib.import_module("yaml")
    importlib.import_module("velfence.apps.viz.plots")
    from velfence.apps.demo import SCENARIOS, run_arm_demo, run_demo

    if scenario not in SCENARIOS:
        raise _fail(f"--scenario: expected one of {list(SCENARIOS)}, got {scenario!r}")
    if scenario == "arm-box" and config is not None:
        raise _fail("--config applies to the wrist scenario only; drop it for --scenario arm-box")
    console = Console()
    try:
        if scenario == "arm-box":
            importlib.import_module("velfence.apps.viz.arm")
            result = run_arm_demo(out_dir=out, console=console)
        else:
            result = run_demo(config_path=config, out_dir=out, console=console, max_steps=max_steps)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot write to {out}: {exc.strerror or exc}") from None
    console.print(result.table)
    console.print(f"[green]wrote[/] {len(result.artifacts)} files to {out}/")


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
) -> None:
    """Run a source's experiment and check our numbers against the source's."""
    if name not in REPRODUCTIONS:
        raise _fail(f"unknown reproduction {name!r}; expected one of {sorted(REPRODUCTIONS)}")
    folder = reproduction_dir(name, out)
    if folder.exists() and not folder.is_dir():
        raise _fail(f"--out {folder} exists and is not a folder")
    module, func = REPRODUCTIONS[name].split(":")
    run = getattr(importlib.import_module(module), func)
    err = Console(stderr=True)
    with _Working(err, f"reproduce {name}: running the source's experiment"):
        report = run(folder)
    line, code = reproduction_summary(report)
    if json_out:
        sys.stdout.write(report.to_json() + "\n")
        err.print(escape(line), soft_wrap=True)
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
                else ("[yellow]FAIL (source defect)[/]" if c.source_defect else "[red]FAIL[/]"),
            )
        console = Console()
        console.print(table)
        for a in report.artifacts:
            console.print(f"  wrote {a}")
        console.print(escape(line), soft_wrap=True)
    if code:
        raise typer.Exit(code=code)


class _Working:
    """A transient spinner with the elapsed time on stderr while a long step runs (rich)."""

    def __init__(self, console: Console, what: str) -> None:
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self._progress = Progress(
            SpinnerColumn(),
            TextColumn("{task.description}"),
            TimeElapsedColumn(),
            console=console,
            transient=True,
        )
        self._what = what

    def __enter__(self) -> _Working:
        self._progress.start()
        self._progress.add_task(escape(self._what), total=None)
        return self

    def __exit__(self, *exc: object) -> None:
        self._progress.stop()


def reproduction_summary(report: Any) -> tuple[str, int]:
    """The one-line summary of a reproduction and its exit code.

    Counts the checks that passed, the failures that document a defect of the source (its own
    law does not meet its claim; measured and explained in the check's note) and the genuine
    misses (a check the reproduction should meet and does not), and says what the exit code
    means: 0 when there is no genuine miss, 1 otherwise.

    Args:
        report: A :class:`velfence.apps.reproduce.Report`.

    Returns:
        The summary line and the exit code.
    """
    checks = report.checks
    passed = sum(1 for c in checks if c.passed)
    defects = sum(1 for c in checks if not c.passed and c.source_defect)
    misses = len(checks) - passed - defects
    if misses:
        meaning = "exit 1: a genuine miss, a check this reproduction should meet failed"
    elif defects:
        meaning = (
            "exit 0: every failure is a documented defect of the source, not of the reproduction"
        )
    else:
        meaning = "exit 0: every check passed"
    line = (
        f"summary: {passed} of {len(checks)} checks passed, {defects} documented source "
        f"defect{'s' * (defects != 1)}, {misses} genuine miss{'es' * (misses != 1)} — {meaning}"
    )
    return line, 1 if misses else 0


#: ``velfence sim --scenario NAME`` -> (module, the robots it runs on).
SIM_SCENARIOS: dict[str, tuple[str, tuple[str, ...]]] = {
    "fence-box": ("velfence.apps.scenarios.fence_box", ("panda",)),
    "wrist-push": ("velfence.apps.scenarios.wrist", ("wrist",)),
    "redundant-obstacle": ("velfence.apps.scenarios.obstacles", ("seven_dof",)),
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
) -> None:
    """Run a robot in MuJoCo with velfence and its baselines; write video, plots, metrics.json.

    Exit code 0: every named check passed; 1: a check failed; 2: bad options or a missing extra.
    """
    import os

    from rich.progress import Progress

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

    err = Console(stderr=True)
    try:
        with Progress(transient=True, console=err) as progress:
            task = progress.add_task(f"{scenario}: simulating", total=1.0)
            runner = importlib.import_module(module).run
            names: list[str] = []

            def step(name: str, f: float) -> None:
                if name not in names:
                    names.append(name)
                progress.update(task, description=f"{scenario}: {name}", completed=0.6 * f)

            result = runner(on_step=step)
            progress.update(task, description=f"{scenario}: rendering", completed=0.6)
            files = write_outputs(
                result,
                folder,
                video=video,
                width=width,
                height=height,
                fps=fps,
                columns=columns,
                progress=lambda f: progress.update(task, completed=0.6 + 0.4 * f),
            )
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    except OSError as exc:
        raise _fail(f"cannot write to {folder}: {exc.strerror or exc}") from None
    report = result.report
    if json_out:
        doc = report.to_dict()
        doc["artifacts"] = [str(f) for f in files]
        sys.stdout.write(json.dumps(doc, indent=2) + "\n")
    else:
        console = Console()
        table = Table(title=f"sim {scenario} (MuJoCo)")
        table.add_column(escape("metric [unit]"))
        for name in result.metrics:
            table.add_column(name)
        for key, unit in result.units.items():
            table.add_row(
                escape(f"{key} [{unit}]"),
                *(_short(result.metrics[m][key]) for m in result.metrics),
            )
        console.print(table)
        for c in report.checks:
            mark = "[green]pass[/]" if c.passed else "[red]FAIL[/]"
            console.print(f"{mark}  {escape(c.name)}: {_short(c.measured)} ({c.expected})")
        for f in files:
            console.print(f"  wrote {escape(str(f))}")
    failed = sum(1 for c in report.checks if not c.passed)
    Console(stderr=True).print(
        f"{len(report.checks) - failed}/{len(report.checks)} checks passed"
        + (f", {failed} failed (exit 1)" if failed else " (exit 0)")
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
) -> None:
    """Time shape() per call and shape_batch() throughput, side by side with a QP baseline."""
    from rich.progress import Progress

    from velfence.apps.bench import run_benchmarks, write_report

    for option, path in (("--out", out), ("--json", json_path)):
        if path is not None and path.is_dir():  # refused before minutes of timing, not after
            raise _fail(f"{option} {path} is a folder; expected a file path")
    with Progress(transient=True, console=Console(stderr=True)) as progress:
        task = progress.add_task("benchmarking", total=1.0)
        report = run_benchmarks(
            quick=quick,
            progress=lambda what, f: progress.update(task, completed=f, description=what),
        )
    # Status lines go to stderr when stdout carries the Markdown (so it can be redirected).
    console = Console(stderr=out is None)
    if out is not None:
        try:
            write_report(report, out)  # keeps a hand-written preamble above the generated part
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
    if out is not None:  # the Markdown was not printed: summarise the targets
        for t in report.targets:
            mark = "[green]pass[/]" if t.passed else "[red]FAIL[/]"
            console.print(f"{mark}  {escape(t.name)}: {t.measured:.3g} {t.unit} ({t.target})")


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

    The 3-D view is viser's (``velfence view --scene teleop``) when the ``web`` extra is
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
    scene: Annotated[
        str, typer.Option(help="Scene: teleop, arm-box or fence-box (MuJoCo, extra physics).")
    ] = "teleop",
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
    """Show a scene as a 3-D web view (viser, extra web) and drive it with the teleop keys."""
    from velfence.apps.viewer.view import serve_scene

    _serve_page(
        f"velfence view ({scene})", lambda: serve_scene(scene, port=port, start=start), port,
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
    console = Console()
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
    """Run the ROS 2 DDS filter node (extra ros). Exit 0 stopped, 2 bad config, 3 DDS failed."""
    from velfence.bridge import load_bridge_config, serve

    view = None
    try:
        loaded = load_bridge_config(config)  # read once: the node and the view share it
        if foxglove or record is not None:
            view = _bridge_view(loaded, foxglove_port if foxglove else None, record)
        code = serve(loaded, duration=duration, on_cycle=None if view is None else view[1])
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
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
    out: Annotated[Path, typer.Option(help="Folder for study.json, plots and animation.")] = Path(
        "out/study"
    ),
    json_out: Annotated[
        bool, typer.Option("--json", help="Print one JSON object (summary + artifacts).")
    ] = False,
    animation: Annotated[
        bool, typer.Option(help="Render one laser-assisted run as an animation.")
    ] = True,
) -> None:
    """Simulated pick-and-place study (Khokar 2009 §7.2): unassisted vs laser-assisted."""
    from rich.progress import Progress

    from velfence.apps.teleop.study import assisted_run, run_study
    from velfence.apps.viz.study import animate_run, write_study

    with Progress(transient=True, disable=json_out) as progress:
        task = progress.add_task("pick-and-place runs", total=subjects * runs * 2)
        result = run_study(
            subjects, runs, seed, progress=lambda done, _: progress.update(task, completed=done)
        )
    artifacts = [str(p) for p in write_study(result, out)]
    if animation:
        path = animate_run(assisted_run(seed=seed), out / "assisted_run.gif")
        artifacts.append(str(path))
    summary = result.summary()
    if json_out:
        sys.stdout.write(json.dumps({"summary": summary, "artifacts": artifacts}) + "\n")
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
    console = Console()
    console.print(table)
    console.print(
        f"faster with assistance: {summary['subjects_faster_assisted']}/{subjects} subjects "
        f"(thesis: 10/10); mean speed-up x{summary['speedup_mean']:.2f}"
    )
    for a in artifacts:
        console.print(f"  wrote {a}")


@app.command()
def replay(
    bag: Annotated[Path, typer.Argument(help="A rosbag2 directory (MCAP or sqlite3).")],
    config: Annotated[Path, typer.Option(help="YAML with shaper: and replay: (docs/replay.md).")],
    out: Annotated[Path, typer.Option(help="The bag directory to write (must not exist).")],
    plot: Annotated[Path | None, typer.Option(help="Also write this figure (.png).")] = None,
    storage: Annotated[
        str | None, typer.Option(help="mcap or sqlite3 (default: the input's storage).")
    ] = None,
) -> None:
    """Shape a bag's recorded commands with a configured shaper; write a new bag (+ figure)."""
    from rich.progress import Progress

    from velfence.io.bags import replay as run_replay

    try:
        with Progress(transient=True, console=Console(stderr=True)) as progress:
            task = progress.add_task(f"replay {bag.name}", total=1.0)
            s = run_replay(
                bag,
                config,
                out,
                storage=storage,
                progress=lambda f: progress.update(task, completed=f),
            )
        if plot is not None:
            from velfence.apps.viz.replay import plot_replay

            plot_replay(s, plot)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    console = Console(highlight=False)
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
    console.print(
        f"  wrote {escape(str(s.out))} ({s.storage}, {s.messages} messages, "
        f"shaped on {escape(s.output_topic)})"
    )
    if plot is not None:
        console.print(f"  wrote {escape(str(plot))}")


def _short(x: object) -> str:
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def main() -> None:
    """Entry point of the ``velfence`` script."""
    app()


if __name__ == "__main__":
    main()
