"""The ``velfence`` command line: ``demo``, ``reproduce NAME [--json]``, ``bench``."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from velfence.errors import VelfenceError

__all__ = ["REPRODUCTIONS", "app", "main"]

app = typer.Typer(
    help="Keep velocity-controlled robots inside their safe sets by shaping commanded velocity.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

#: name -> "module:function" returning a velfence.reproduce.Report given an output folder.
REPRODUCTIONS: dict[str, str] = {
    "wrist": "velfence.reproduce.wrist:run",
    "cospm": "velfence.reproduce.cospm:run",
    "obstacles": "velfence.reproduce.obstacles:run",
    "cobot": "velfence.reproduce.cobot:run",
    "telerobotics": "velfence.reproduce.telerobotics:run",
}


def _fail(msg: str) -> typer.Exit:
    Console(stderr=True).print(f"[bold red]error:[/] {escape(msg)}")
    return typer.Exit(code=2)


@app.command()
def demo(
    out: Annotated[Path, typer.Option(help="Folder for plots, GIF and metrics.json.")] = Path(
        "out/demo"
    ),
    config: Annotated[
        Path | None, typer.Option(help="YAML scenario file (defaults built in).")
    ] = None,
) -> None:
    """Run the built-in wrist scenario for every method and baseline; write plots and metrics."""
    from velfence.demo import run_demo

    console = Console()
    try:
        result = run_demo(config_path=config, out_dir=out, console=console)
    except VelfenceError as exc:
        raise _fail(str(exc)) from None
    console.print(result.table)
    console.print(f"[green]wrote[/] {len(result.artifacts)} files to {out}/")


@app.command()
def reproduce(
    name: Annotated[str, typer.Argument(help=f"One of: {', '.join(REPRODUCTIONS)}.")],
    json_out: Annotated[
        bool, typer.Option("--json", help="Print one JSON object (checks + artifacts).")
    ] = False,
    out: Annotated[Path, typer.Option(help="Folder for the reproduction's plots.")] = Path(
        "out/reproduce"
    ),
) -> None:
    """Run a source's experiment and check our numbers against the source's."""
    if name not in REPRODUCTIONS:
        raise _fail(f"unknown reproduction {name!r}; expected one of {sorted(REPRODUCTIONS)}")
    module, func = REPRODUCTIONS[name].split(":")
    run = getattr(importlib.import_module(module), func)
    report = run(out / name)
    if json_out:
        sys.stdout.write(report.to_json() + "\n")
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
    if not report.passed:
        raise typer.Exit(code=1)


@app.command()
def bench(
    out: Annotated[
        Path | None, typer.Option(help="Write the markdown report here (e.g. docs/benchmarks.md).")
    ] = None,
    quick: Annotated[bool, typer.Option(help="Small sizes, a few seconds.")] = False,
) -> None:
    """Time shape() per call and shape_batch() throughput, side by side with a QP baseline."""
    from rich.progress import Progress

    from velfence.benchmarking import run_benchmarks, write_report

    with Progress(transient=True) as progress:
        task = progress.add_task("benchmarking", total=1.0)
        report = run_benchmarks(
            quick=quick,
            progress=lambda what, f: progress.update(task, completed=f, description=what),
        )
    if out is not None:
        write_report(report, out)  # keeps a hand-written preamble above the generated part
        Console().print(f"[green]wrote[/] {out}")
    else:
        sys.stdout.write(report.to_markdown())


def _short(x: object) -> str:
    if isinstance(x, float):
        return f"{x:.6g}"
    return str(x)


def main() -> None:
    """Entry point of the ``velfence`` script."""
    app()


if __name__ == "__main__":
    main()
