"""The one progress display of every long ``velfence`` command, and its closing summary.

A command opens a :class:`Tracker` with a *plan*: its stages in order, each with a weight (about
the seconds it takes on a laptop), so the display can show one bar over the whole command with the
elapsed and the remaining time. The code doing the work (a reproduction, a plot, a GIF writer)
does not receive the tracker: it calls the module functions :func:`stage` and :func:`update`,
which report to the tracker that is active, and do nothing when none is (a library-style call
from Python stays silent).

Output goes to stderr. On a terminal it is one live, transient rich line::

    velfence sim fence-box  rendering: fence-box.mp4 frame 120/400 ━━━━━━━━  63% 0:02:58 ETA 0:01:44

When stderr is not a terminal (CI logs, pipes) nothing is drawn; instead one line is printed per
finished stage, and at most one every ``heartbeat_period`` while a stage reports its progress, so
a log shows the command is alive and about how long it still runs (the same estimate as the
live line's, from the plan's weights; none until a second and 1 % of the plan have passed)::

    velfence sim fence-box: [1/3] simulating done in 171.2 s (elapsed 171.9 s, ETA 0:01:05)

``quiet=True`` (the commands' ``--quiet``) prints neither. The library layers never import this
module; where a long library loop has to report, it accepts an optional callback
``on_progress(done, total, what)`` (:data:`OnProgress`) and the command passes
:func:`update`.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import Any

from velfence._extras import missing

try:
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import (
        BarColumn,
        Progress,
        ProgressColumn,
        Task,
        TextColumn,
        TimeElapsedColumn,
    )
    from rich.text import Text
except ModuleNotFoundError as exc:  # an optional dependency: name the extra
    raise missing(exc, what=__name__) from exc

from velfence._validate import (
    check_flag,
    check_positive,
    check_positive_int,
    check_text,
    describe,
)
from velfence.errors import InvalidParameter

__all__ = ["Tracker", "current", "frames", "note", "stage", "summary", "update"]

#: The type of ``on_progress(done, total, what)``: ``done`` of ``total`` units of the running
#: step, ``what`` a short description of it (e.g. ``"fence-box.mp4 frame 120/400"``).
OnProgress = Callable[[float, float, str], None]

_ACTIVE: ContextVar[Tracker | None] = ContextVar("velfence_progress_tracker", default=None)


#: Most stages in a plan, and most files in a summary (a longer list is a mistake).
MAX_ITEMS = 100_000


def _count(name: str, x: Any) -> float:
    """A finite, non-negative amount of work (``done``, ``total``, a weight)."""
    return check_positive(name, x, allow_zero=True)


def _count_text(done: float, total: float, frac: float) -> str:
    """A heartbeat's count: ``3/20`` in whole units, else the stage's percentage (``58 %``)."""
    if not total:
        return f"{done:g}" if float(done).is_integer() else ""
    if float(done).is_integer() and float(total).is_integer():
        return f"{done:g}/{total:g}"
    return f"{100.0 * frac:.0f} %"


def _items(name: str, x: Any) -> list[Any]:
    """A list or tuple of at most :data:`MAX_ITEMS` items, as a list."""
    if not isinstance(x, (list, tuple)):
        raise InvalidParameter(f"{name}: expected a list or tuple, got {describe(x)}")
    if len(x) > MAX_ITEMS:
        raise InvalidParameter(f"{name}: expected at most {MAX_ITEMS:,} items, got {len(x):,}")
    return list(x)


def _path(name: str, x: Any) -> Path:
    """A path given as ``str`` or ``os.PathLike`` (not bytes), non-empty."""
    if isinstance(x, (bytes, bytearray)) or not isinstance(x, (str, os.PathLike)):
        raise InvalidParameter(f"{name}: expected a path (str or Path), got {describe(x)}")
    p = os.fspath(x)
    if not isinstance(p, str) or not p or "\0" in p or len(p) > 4096:
        raise InvalidParameter(f"{name}: expected a non-empty path, got {describe(x)}")
    return Path(p)


def _clock(seconds: float) -> str:
    s = max(0, round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def _eta(fraction: float, elapsed: float) -> str | None:
    """``"ETA h:mm:ss"`` from the weighted fraction done and the elapsed time [s].

    None while there is too little history for an estimate (under 1 % done or under a second)
    and once everything is done.
    """
    if fraction < 0.01 or fraction >= 1.0 or elapsed < 1.0:
        return None
    return f"ETA {_clock(elapsed * (1.0 - fraction) / fraction)}"


class _Remaining(ProgressColumn):
    """``ETA h:mm:ss`` from the elapsed time and the weighted fraction done."""

    def render(self, task: Task) -> Text:
        eta = _eta(task.percentage / 100.0, task.elapsed or 0.0)
        return Text(eta or "ETA -:--:--", style="progress.remaining")


class Tracker:
    """One command's progress: a weighted plan of stages, shown live or as one line per stage.

    Args:
        plan: The stages in order as ``(name, weight)``; a weight is about the stage's seconds.
            A stage not in the plan counts with weight 0 (shown, but it does not move the bar).
        title: The command, e.g. ``"velfence reproduce telerobotics"``.
        console: Where the display goes (default: a stderr console).
        quiet: Print nothing (neither the live display nor the per-stage lines).
        live: Force the live display on or off (default: on when ``console`` is a terminal).
        heartbeat_period: Off a terminal, the least time [s] between two progress lines of a
            running stage (default 30); each finished stage prints its own line regardless.
    """

    def __init__(
        self,
        plan: Iterable[tuple[str, float]],
        *,
        title: str,
        console: Console | None = None,
        quiet: bool = False,
        live: bool | None = None,
        heartbeat_period: float = 30.0,
    ) -> None:
        self.title = check_text("title", title)
        self.heartbeat_period = check_positive("heartbeat_period", heartbeat_period, unit="s")
        steps = []
        for k, item in enumerate(_items("plan", plan)):
            if not isinstance(item, (list, tuple)) or len(item) != 2:
                raise InvalidParameter(
                    f"plan[{k}]: expected a (name, weight) pair, got {describe(item)}"
                )
            steps.append(
                (
                    check_text(f"plan[{k}] name", item[0]),
                    _count(f"plan[{k}] weight", item[1]),
                )
            )
        if not steps:
            raise InvalidParameter("plan: expected at least one (name, weight) stage, got none")
        self.plan = steps
        if console is not None and not isinstance(console, Console):
            raise InvalidParameter(
                f"console: expected a rich Console or None, got {describe(console)}"
            )
        self._weights = dict(self.plan)
        self._total = sum(self._weights.values()) or 1.0
        self.console = console if console is not None else Console(stderr=True, soft_wrap=True)
        self.quiet = check_flag("quiet", quiet)
        self.live = (
            (not self.quiet and self.console.is_terminal)
            if live is None
            else check_flag("live", live)
        )
        self.finished: list[tuple[str, float]] = []
        self._done = 0.0
        self._stage: str | None = None
        self._start = time.perf_counter()
        self._stage_start = self._start
        self._progress: Progress | None = None
        self._task: Any = None
        self._token: Any = None
        self._last_line = self._start

    @property
    def elapsed(self) -> float:
        """Seconds since the tracker started."""
        return time.perf_counter() - self._start

    def __enter__(self) -> Tracker:
        self._start = time.perf_counter()
        if self.live:
            self._progress = Progress(
                TextColumn(f"[bold]{escape(self.title)}[/]"),
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.percentage:>3.0f}%"),
                TimeElapsedColumn(),
                _Remaining(),
                console=self.console,
                transient=True,
            )
            self._progress.start()
            self._task = self._progress.add_task("starting", total=self._total)
        self._token = _ACTIVE.set(self)
        return self

    def __exit__(self, *exc: object) -> None:
        _ACTIVE.reset(self._token)
        if self._progress is not None:
            self._progress.stop()
            self._progress = None

    def stage(self, name: str) -> AbstractContextManager[OnProgress]:
        """Run one stage of the plan (a context manager giving ``on_progress(done, total, what)``).

        A stage opened while another runs (a helper reporting inside its caller's stage) only
        changes the description; the outer stage keeps the bar and the per-stage line.

        Args:
            name: The stage's name (from the plan).

        Returns:
            The context manager; it gives :meth:`update`.

        Raises:
            InvalidParameter: ``name`` is not a string.
        """
        return self._stage_cm(check_text("name", name))

    @contextmanager
    def _stage_cm(self, name: str) -> Iterator[OnProgress]:
        if self._stage is not None:
            self.update(0, 0, name)
            yield self.update
            return
        self._stage = name
        self._stage_start = time.perf_counter()
        self.update(0, 0, "")
        try:
            yield self.update
        finally:
            seconds = time.perf_counter() - self._stage_start
            self._stage = None
            self._done += self._weights.get(name, 0.0)
            self.finished.append((name, seconds))
            if self._progress is not None:
                self._progress.update(self._task, completed=min(self._done, self._total))
            elif not self.quiet:
                names = [n for n, _ in self.plan]
                pos = f"[{names.index(name) + 1}/{len(names)}] " if name in names else ""
                self._last_line = time.perf_counter()
                self.console.print(
                    f"{escape(self.title)}: {pos}{escape(name)} done in {seconds:.1f} s "
                    f"({self._times(self._done / self._total)})",
                    highlight=False,
                    soft_wrap=True,
                )

    def _times(self, fraction: float) -> str:
        """``elapsed 12.3 s`` and, once it can be estimated, ``, ETA 0:01:40`` (off a terminal)."""
        elapsed = self.elapsed
        eta = _eta(fraction, elapsed)
        return f"elapsed {elapsed:.1f} s" + (f", {eta}" if eta else "")

    def note(self, text: str) -> None:
        """Print one line now, on a terminal above the live line (``TITLE: text``).

        For what the user should know while the command runs (e.g. that a part reuses earlier
        results); nothing with ``quiet``.

        Args:
            text: The line.

        Raises:
            InvalidParameter: ``text`` is not a string.
        """
        text = check_text("text", text)
        if not self.quiet:
            self.console.print(
                f"{escape(self.title)}: {escape(text)}", highlight=False, soft_wrap=True
            )

    def update(self, done: float, total: float, what: str = "") -> None:
        """Report ``done`` of ``total`` units of the running stage (the :data:`OnProgress`).

        Args:
            done: Units done (frames rendered, runs finished, ...).
            total: Units in the stage; 0 when unknown (the bar stays at the stage's start).
            what: What is being done, e.g. ``"fence-box.mp4 frame 120/400"``.

        Raises:
            InvalidParameter: a count that is not a finite number >= 0, or ``what`` not a string.
        """
        done = _count("done", done)
        total = _count("total", total)
        what = check_text("what", what)
        name = self._stage or ""
        if self._progress is None:
            # Off a terminal: a line at most every heartbeat_period while a stage reports
            # progress, so that a CI log shows life during a long stage (a study, a video).
            now = time.perf_counter()
            quiet = self.quiet or not name or not (total or what)  # a stage's start reports 0/0
            if quiet or now - self._last_line < self.heartbeat_period:
                return
            self._last_line = now
            frac = min(1.0, done / total) if total else 0.0
            count = _count_text(done, total, frac)
            if count and count in what:  # "run 15/60" already says it
                count = ""
            sep = ", " if count.endswith("%") else " "  # "58 %, axis-limits 88 %"
            part = sep.join(p for p in (count, what) if p)
            fraction = (self._done + frac * self._weights.get(name, 0.0)) / self._total
            self.console.print(
                f"{escape(self.title)}: {escape(name)}: {escape(part)} ({self._times(fraction)})",
                highlight=False,
                soft_wrap=True,
            )
            return
        frac = min(1.0, done / total) if total else 0.0
        text = f"{name}: {what}" if what and name else (what or name)
        self._progress.update(
            self._task,
            completed=min(self._total, self._done + frac * self._weights.get(name, 0.0)),
            description=escape(text),
        )


def current() -> Tracker | None:
    """The active tracker.

    Returns:
        The tracker of the running command, or None (then :func:`stage` and :func:`update` do
        nothing).
    """
    return _ACTIVE.get()


def stage(name: str) -> AbstractContextManager[OnProgress]:
    """A stage of the active tracker (:meth:`Tracker.stage`); a no-op without one.

    Args:
        name: The stage's name (from the command's plan).

    Returns:
        A context manager giving the ``on_progress(done, total, what)`` callback of the stage.

    Raises:
        InvalidParameter: ``name`` is not a string.
    """
    return _stage_cm(check_text("name", name))


@contextmanager
def _stage_cm(name: str) -> Iterator[OnProgress]:
    tracker = _ACTIVE.get()
    if tracker is None:
        yield _nothing
        return
    with tracker.stage(name) as on_progress:
        yield on_progress


def update(done: float, total: float, what: str = "") -> None:
    """Report progress of the running stage of the active tracker; a no-op without one.

    Args:
        done: Units done.
        total: Units in the stage (0 when unknown).
        what: What is being done.

    Raises:
        InvalidParameter: a count that is not a finite number >= 0, or ``what`` not a string.
    """
    tracker = _ACTIVE.get()
    if tracker is not None:
        tracker.update(done, total, what)
    else:
        _count("done", done)
        _count("total", total)
        check_text("what", what)


def note(text: str) -> None:
    """Print one line through the active tracker (:meth:`Tracker.note`); a no-op without one.

    Args:
        text: The line.

    Raises:
        InvalidParameter: ``text`` is not a string.
    """
    tracker = _ACTIVE.get()
    if tracker is not None:
        tracker.note(text)
    else:
        check_text("text", text)


def frames(name: str) -> Callable[[int, int], None]:
    """A ``(frame index, frame count)`` callback reporting ``rendering NAME frame i/n``.

    Matplotlib's ``Animation.save(progress_callback=...)`` calls it with the 0-based index.

    Args:
        name: The file being rendered, e.g. ``"demo.gif"``.

    Returns:
        The callback (a no-op without an active tracker).

    Raises:
        InvalidParameter: ``name`` is not a string.
    """
    name = check_text("name", name)

    def on_frame(i: int, n: int) -> None:
        update(i + 1, n, f"rendering {name} frame {i + 1}/{n}")

    return on_frame


def _nothing(done: float, total: float, what: str = "") -> None:
    del done, total, what


def summary(
    folder: str | Path | None, files: Sequence[str | Path], verdict: str, *, main: int = 6
) -> list[str]:
    """The closing lines of a command: where its files are, the main ones, and the verdict.

    Only files that exist are named.

    Args:
        folder: The output folder (None when the files are spread out).
        files: Every file the command wrote.
        verdict: One line: what holds, and the exit code.
        main: How many files to name (the rest are counted).

    Returns:
        The lines, plain text (no markup).

    Raises:
        InvalidParameter: a path that is not a str or Path, ``files`` not a list or tuple,
            ``verdict`` not a string, ``main`` not an int >= 1.
    """
    base = None if folder is None else _path("folder", folder)
    paths = [_path(f"files[{k}]", f) for k, f in enumerate(_items("files", files))]
    verdict = check_text("verdict", verdict)
    main = check_positive_int("main", main, example=6, maximum=MAX_ITEMS)
    existing = [p for p in paths if p.exists()]
    lines = []
    if existing:
        if base is not None:
            names = [
                str(p.relative_to(base)) if p.is_relative_to(base) else str(p) for p in existing
            ]
            where = f"wrote {len(existing)} file{'s' * (len(existing) != 1)} to {base}/"
        else:
            names = [str(p) for p in existing]
            where = f"wrote {len(existing)} file{'s' * (len(existing) != 1)}"
        more = f" (+{len(names) - main} more)" if len(names) > main else ""
        shown = ", ".join(names[:main]) + more
        lines.append(f"{where}: {shown}")
    lines.append(verdict)
    return lines
