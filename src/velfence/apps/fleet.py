"""Fleet replay: one configured shaper over many bags, one summary (``velfence replay --summary``).

Each bag is replayed by :func:`velfence.io.bags.replay` — the one replay; this module only reads
its :class:`~velfence.io.bags.ReplaySummary` — as one shard of an
:class:`~velfence.apps.engine.Engine` (serial, an embedded Dask cluster or a cluster at an
address). Per bag it reports the cycles (commands shaped), how often the filter acted (a shaped
command differs from the command by more than ``tol`` in any component), where it acted (the
components changed, and the bound nearest to the recorded state at each such command: a fence
edge, a polytope facet, a joint's ``_min`` / ``_max``), the largest change, and whether the
recorded state crossed a bound (how many commands, the first time, the worst margin). Bags are
grouped per robot (the sub-folder under the fleet folder, the command topic's namespace and
the command's components). A bag that cannot be read, or holds nothing to replay, is a row with
its reason; the summary says "N of M bags read" and is complete only when N = M.

Results are ordered by the bags' order, never by which worker finished first, so the summary is
the same with any engine (tested against replaying each bag alone).
"""

from __future__ import annotations

import csv
import io
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache, partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from velfence._validate import check_positive, check_text, describe
from velfence.errors import InvalidParameter, NothingToReplay, VelfenceError

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from velfence.apps.engine import Engine
    from velfence.apps.progress import OnProgress
    from velfence.io.bags import ReplaySummary
    from velfence.io.shaper_config import ConfiguredShaper

__all__ = [
    "BAG_SUFFIXES",
    "COLUMNS",
    "DEMO_FLEET_CONFIG",
    "BagReport",
    "FleetSummary",
    "RobotReport",
    "bounds_of",
    "find_bags",
    "fleet_replay",
    "make_demo_fleet",
    "output_names",
    "summarize_bag",
    "summarize_replay",
]

#: Files that are bags on their own (MCAP and sqlite3 storage).
BAG_SUFFIXES: tuple[str, ...] = (".mcap", ".db3")
#: Exit code of a bag with nothing to replay, and of one that cannot be read (``docs/cli.md``).
NOTHING_TO_REPLAY_CODE = 4
UNREADABLE_CODE = 2
#: Most bags one summary takes (a longer list is a mistake).
MAX_BAGS = 1_000_000


@dataclass(frozen=True, kw_only=True)
class BagReport:
    """One bag of a fleet replay.

    Attributes:
        bag: The bag's path, as given or found.
        robot: The robot it belongs to: ``"<folder> <namespace> (<components>)"``.
        status: ``"ok"``, ``"nothing to replay"`` or ``"unreadable"``.
        reason: Why a bag was not read (empty when ``status == "ok"``).
        code: The bag's exit code: 0 read, 2 unreadable, 4 nothing to replay.
        cycles: Commands shaped.
        acted: Commands whose shaped value differs from the command by more than ``tol``.
        zeroed: Commands written as zero (no state, stale state, non-finite values).
        unit: The command's unit (``"m/s"``, ``"rad/s"``).
        max_change: Largest ``|command − shaped|`` of any component, in ``unit``.
        max_change_time: When it happened [s since the bag's first message].
        components: ``(component, commands where it changed)``, components in command order.
        where: ``(bound, commands)``: the bound nearest to the held state at each command the
            filter acted on (``"no state"`` for a command without one), most first.
        bound_unit: The unit of the margins (``"m"`` for a point, ``"rad"`` for joints).
        crossings: Commands whose held state was beyond a bound (margin < 0).
        first_crossing: ``(time [s], bound, margin)`` of the first one, else None.
        worst_margin: The smallest margin of any held state (negative: beyond the bound).
        worst_bound: Its bound's name.
        worst_time: Its time [s].
    """

    bag: str
    robot: str
    status: str
    reason: str = ""
    code: int = 0
    cycles: int = 0
    acted: int = 0
    zeroed: int = 0
    unit: str = ""
    max_change: float = 0.0
    max_change_time: float = 0.0
    components: tuple[tuple[str, int], ...] = ()
    where: tuple[tuple[str, int], ...] = ()
    bound_unit: str = ""
    crossings: int = 0
    first_crossing: tuple[float, str, float] | None = None
    worst_margin: float = 0.0
    worst_bound: str = ""
    worst_time: float = 0.0

    @property
    def ok(self) -> bool:
        """Whether the bag was read and replayed."""
        return self.status == "ok"

    @property
    def acted_fraction(self) -> float:
        """``acted / cycles`` (0 for no cycles)."""
        return self.acted / self.cycles if self.cycles else 0.0


@dataclass(frozen=True, kw_only=True)
class RobotReport:
    """The bags of one robot, added up.

    Attributes:
        robot: As in :attr:`BagReport.robot`.
        bags: Bags of this robot that were read.
        cycles: Their commands.
        acted: Commands the filter acted on.
        unit: The command's unit.
        max_change: The largest change of any of its bags.
        where: ``(bound, commands)`` over its bags, most first.
        crossings: Commands with the state beyond a bound.
        crossed_bags: Bags with at least one crossing.
        worst_margin: The smallest margin of any of its bags.
        bound_unit: The margins' unit.
    """

    robot: str
    bags: int
    cycles: int
    acted: int
    unit: str
    max_change: float
    where: tuple[tuple[str, int], ...]
    crossings: int
    crossed_bags: int
    worst_margin: float
    bound_unit: str

    @property
    def acted_fraction(self) -> float:
        """``acted / cycles`` (0 for no cycles)."""
        return self.acted / self.cycles if self.cycles else 0.0


@dataclass(frozen=True, kw_only=True)
class FleetSummary:
    """A fleet replay: one :class:`BagReport` per bag, in the bags' order.

    Attributes:
        config: The replay configuration (its path, or ``"<mapping>"``).
        tol: The tolerance [command unit] above which a change counts as the filter acting.
        bags: The reports, in the order the bags were given.
    """

    config: str
    tol: float
    bags: tuple[BagReport, ...] = field(default=())

    @property
    def total(self) -> int:
        """Bags given."""
        return len(self.bags)

    @property
    def read(self) -> int:
        """Bags read and replayed."""
        return sum(1 for b in self.bags if b.ok)

    @property
    def complete(self) -> bool:
        """Whether every bag was read (only then is the summary the fleet's)."""
        return self.read == self.total

    @property
    def code(self) -> int:
        """The largest exit code of any bag (0 when complete)."""
        return max((b.code for b in self.bags), default=0)

    @property
    def headline(self) -> str:
        """``"N of M bags read"`` and, when not complete, that the summary is partial."""
        text = f"{self.read} of {self.total} bags read"
        if not self.complete:
            text += f" — PARTIAL: {self.total - self.read} skipped (listed with their reason)"
        return text

    def robots(self) -> tuple[RobotReport, ...]:
        """The bags read, added up per robot, robots in order of first appearance.

        Returns:
            One :class:`RobotReport` per robot.
        """
        groups: dict[str, list[BagReport]] = {}
        for b in self.bags:
            if b.ok:
                groups.setdefault(b.robot, []).append(b)
        out = []
        for robot, bags in groups.items():
            where: dict[str, int] = {}
            for b in bags:
                for name, n in b.where:
                    where[name] = where.get(name, 0) + n
            out.append(
                RobotReport(
                    robot=robot,
                    bags=len(bags),
                    cycles=sum(b.cycles for b in bags),
                    acted=sum(b.acted for b in bags),
                    unit=bags[0].unit,
                    max_change=max(b.max_change for b in bags),
                    where=_most_first(where),
                    crossings=sum(b.crossings for b in bags),
                    crossed_bags=sum(1 for b in bags if b.crossings),
                    worst_margin=min(b.worst_margin for b in bags),
                    bound_unit=bags[0].bound_unit,
                )
            )
        return tuple(out)

    def rows(self) -> list[dict[str, str]]:
        """The table, one row per bag then one per robot (``bag`` = ``"all bags"``), as text.

        Returns:
            Rows with the columns of :data:`COLUMNS`.
        """
        rows = [_bag_row(b) for b in self.bags]
        for r in self.robots():
            rows.append(
                {
                    "bag": f"all {r.bags} bags",
                    "robot": r.robot,
                    "cycles": str(r.cycles),
                    "acted": f"{r.acted} ({100 * r.acted_fraction:.1f} %)",
                    "where": _where_text(r.where),
                    "max change": f"{r.max_change:.4g} {r.unit}",
                    "bound crossed": (
                        f"{r.crossings} commands in {r.crossed_bags} bags" if r.crossings else "no"
                    ),
                    "worst margin": f"{r.worst_margin:.4g} {r.bound_unit}",
                    "status": f"{r.bags} read",
                }
            )
        return rows

    def markdown(self) -> str:
        """The table as Markdown, with the headline above it.

        Returns:
            The text (ends with a newline).
        """
        rows = self.rows()
        head = "| " + " | ".join(COLUMNS) + " |"
        rule = "|" + "|".join(" --- " for _ in COLUMNS) + "|"
        body = ["| " + " | ".join(r[c].replace("|", "\\|") for c in COLUMNS) + " |" for r in rows]
        title = f"Fleet replay with {self.config}: {self.headline}"
        return "\n".join([title, "", head, rule, *body]) + "\n"

    def csv(self) -> str:
        """The table as CSV (a header row, then the rows of :meth:`rows`).

        Returns:
            The text.
        """
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=list(COLUMNS), lineterminator="\n")
        writer.writeheader()
        writer.writerows(self.rows())
        return buf.getvalue()


#: The table's columns (:meth:`FleetSummary.rows`).
COLUMNS: tuple[str, ...] = (
    "bag",
    "robot",
    "cycles",
    "acted",
    "where",
    "max change",
    "bound crossed",
    "worst margin",
    "status",
)


def _path(name: str, value: Any) -> Path:
    """A path argument (``str`` or ``os.PathLike``, not empty) as a :class:`~pathlib.Path`."""
    if isinstance(value, (str, os.PathLike)):
        text = os.fspath(value)
        if isinstance(text, str) and text:
            return Path(check_text(name, text, max_length=4096))
    raise InvalidParameter(f"{name}: expected a path (str or pathlib.Path), got {describe(value)}")


def _config_arg(config: Any) -> None:
    """Refuse a ``config`` that is neither a path nor a mapping (its content is checked later)."""
    if not isinstance(config, Mapping):
        _path("config", config)


def _most_first(counts: Mapping[str, int]) -> tuple[tuple[str, int], ...]:
    return tuple(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))


def _where_text(where: Sequence[tuple[str, int]], top: int = 3) -> str:
    if not where:
        return "-"
    parts = [f"{name} ×{n}" for name, n in where[:top]]
    if len(where) > top:
        parts.append(f"+{len(where) - top} more")
    return ", ".join(parts)


def _bag_row(b: BagReport) -> dict[str, str]:
    if not b.ok:
        empty = dict.fromkeys(COLUMNS, "-")
        return {**empty, "bag": b.bag, "robot": b.robot, "status": f"{b.status}: {b.reason}"}
    crossed = "no"
    if b.first_crossing is not None:
        t, name, margin = b.first_crossing
        commands = "command" if b.crossings == 1 else "commands"
        crossed = (
            f"{b.crossings} {commands}; first {name} at {t:.2f} s ({margin:.3g} {b.bound_unit})"
        )
    return {
        "bag": b.bag,
        "robot": b.robot,
        "cycles": str(b.cycles),
        "acted": f"{b.acted} ({100 * b.acted_fraction:.1f} %)",
        "where": _where_text(b.where),
        "max change": f"{b.max_change:.4g} {b.unit} at {b.max_change_time:.2f} s",
        "bound crossed": crossed,
        "worst margin": f"{b.worst_margin:.4g} {b.bound_unit} ({b.worst_bound} at "
        f"{b.worst_time:.2f} s)",
        "status": "ok",
    }


# ------------------------------------------------------------------------------ bounds


def bounds_of(
    cs: ConfiguredShaper,
) -> tuple[tuple[str, ...], Callable[[NDArray[np.float64]], NDArray[np.float64]], str]:
    """The bounds a configured shaper keeps the state within, as signed margins.

    A polygon's edges (``"edge i"``, from corner i to corner i + 1, counted from 1), a polytope's
    facets (their ``facet_names``: ``<joint>_min`` / ``_max`` for ``joint_limits``), a safety
    filter's joint position limits (``<joint>_min`` / ``_max``; its workspace box is not checked
    here: that needs the robot's kinematics at every state).

    Args:
        cs: The configured shaper (:func:`velfence.io.bags.load_replay_config`).

    Returns:
        ``(names, margins, unit)``: ``margins(states)`` maps states, shape (N, state_dim), to
        signed margins, shape (N, len(names)), positive inside; ``unit`` is ``"m"`` or
        ``"rad"``.
    """
    from velfence.io.shaper_config import ConfiguredShaper

    if not isinstance(cs, ConfiguredShaper):
        raise InvalidParameter(f"cs: expected a ConfiguredShaper, got {describe(cs)}")
    shaper = cs.shaper
    if cs.kind == "polygon":
        polygon = shaper.polygon
        names = tuple(f"edge {i + 1}" for i in range(polygon.n))
        return names, lambda p: np.atleast_2d(polygon.signed_distances(p)), "m"
    if cs.kind in ("polytope", "joint_limits"):
        poly = shaper.polytope
        unit = "rad" if cs.kind == "joint_limits" else "m"
        return tuple(poly.facet_names), lambda p: poly.signed_distances_batch(p), unit
    sf = getattr(shaper, "filter", shaper)  # TwistMode wraps the SafetyFilter
    lim = sf.limits
    joints = cs.joint_names or tuple(f"joint {i + 1}" for i in range(len(lim.lower)))
    names = tuple(f"{j}_{side}" for j in joints for side in ("min", "max"))
    lower, upper = np.asarray(lim.lower, dtype=float), np.asarray(lim.upper, dtype=float)

    def margins(q: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.empty((q.shape[0], 2 * q.shape[1]))
        with np.errstate(invalid="ignore"):
            out[:, 0::2] = q - lower
            out[:, 1::2] = upper - q
        out[~np.isfinite(out)] = np.inf  # a joint without a limit on that side
        return out

    return names, margins, "rad"


# ------------------------------------------------------------------------------ one bag


def _namespace(topic: str) -> str:
    head, _, _ = topic.rpartition("/")
    return head or "/"


def summarize_replay(
    s: ReplaySummary, cs: ConfiguredShaper, *, tol: float, bag: str = "", group: str = ""
) -> BagReport:
    """A bag's report from its replay's summary (what :func:`summarize_bag` returns).

    Args:
        s: What :func:`velfence.io.bags.replay` returned for the bag.
        cs: The configured shaper of that replay.
        tol: A change larger than this [command unit] counts as the filter acting.
        bag: The bag's name in the report (default: ``s.bag``).
        group: The bag's folder under the fleet folder (part of the robot's name).

    Returns:
        The report.
    """
    from velfence.io.bags import ReplaySummary

    if not isinstance(s, ReplaySummary):
        raise InvalidParameter(f"s: expected a ReplaySummary (bags.replay), got {describe(s)}")
    tol = check_positive("tol", tol, allow_zero=True)
    bag = check_text("bag", bag, max_length=4096)
    group = check_text("group", group, max_length=4096)
    diff = np.abs(s.commanded - s.shaped)
    acted_rows = np.any(diff > tol, axis=1) if diff.size else np.zeros(0, dtype=bool)
    per_component = (diff > tol).sum(axis=0) if diff.size else np.zeros(len(s.components))
    names, margins_of, bound_unit = bounds_of(cs)
    held = s.has_state
    margins = np.full((len(s.times), len(names)), np.inf)
    if held.any():
        margins[held] = margins_of(s.positions[held])
    nearest = np.argmin(margins, axis=1) if len(names) else np.zeros(len(s.times), dtype=int)
    smallest = margins.min(axis=1) if len(names) else np.full(len(s.times), np.inf)
    where: dict[str, int] = {}
    for row in np.flatnonzero(acted_rows).tolist():
        key = names[nearest[row]] if held[row] and np.isfinite(smallest[row]) else "no state"
        where[key] = where.get(key, 0) + 1
    crossed = held & (smallest < 0.0)
    first = None
    if crossed.any():
        c = int(np.flatnonzero(crossed)[0])
        first = (float(s.times[c]), names[nearest[c]], float(smallest[c]))
    finite = held & np.isfinite(smallest)
    if finite.any():
        w = int(np.flatnonzero(finite)[np.argmin(smallest[finite])])
        worst = (float(smallest[w]), names[nearest[w]], float(s.times[w]))
    else:
        worst = (0.0, "-", 0.0)
    if diff.size:
        k = int(np.argmax(diff.max(axis=1)))
        biggest, when = float(diff[k].max()), float(s.times[k])
    else:
        biggest, when = 0.0, 0.0
    members = ", ".join(s.components)
    prefix = f"{group} " if group else ""
    return BagReport(
        bag=bag or str(s.bag),
        robot=f"{prefix}{_namespace(s.command_topic)} ({members})",
        status="ok",
        cycles=s.commands,
        acted=int(acted_rows.sum()),
        zeroed=s.zeroed,
        unit=s.unit,
        max_change=biggest,
        max_change_time=when,
        components=tuple(
            (c, int(n)) for c, n in zip(s.components, per_component.tolist(), strict=True)
        ),
        where=_most_first(where),
        bound_unit=bound_unit,
        crossings=int(crossed.sum()),
        first_crossing=first,
        worst_margin=worst[0],
        worst_bound=worst[1],
        worst_time=worst[2],
    )


def summarize_bag(
    bag: str | Path,
    config: str | Path | Mapping[str, Any],
    *,
    tol: float | None = None,
    out: str | Path | None = None,
    group: str = "",
) -> BagReport:
    """Replay one bag (:func:`velfence.io.bags.replay`) and report it; never raises for the bag.

    The shard of :func:`fleet_replay`: a bag that cannot be read, or holds nothing to replay,
    gives a report with its reason instead of an error.

    Args:
        bag: The bag (as :func:`velfence.io.bags.replay` takes it).
        config: The replay configuration (a YAML path or the mapping).
        tol: A change larger than this counts as acting (default
            :data:`velfence.io.bags.CHANGE_TOL`).
        out: Where to keep the shaped bag (a new directory); default: a temporary one, deleted.
        group: The bag's folder under the fleet folder (part of the robot's name).

    Returns:
        The bag's report.

    Raises:
        InvalidParameter: arguments of the wrong type, or a bad configuration (one error for
            every bag, checked before the bag is read).
    """
    from velfence.io.bags import CHANGE_TOL, replay

    tol = CHANGE_TOL if tol is None else check_positive("tol", tol, allow_zero=True)
    _path("bag", bag)
    name = str(bag)
    _config_arg(config)
    shaper = _shaper_of(config)  # a bad configuration is the caller's error, not the bag's
    group = check_text("group", group, max_length=4096)
    if out is not None:
        out = _path("out", out)
    robot = f"{group} ?" if group else "?"
    tmp = None if out is not None else tempfile.mkdtemp(prefix="velfence-fleet-")
    try:
        target = Path(out) if out is not None else Path(tmp or ".") / "shaped"
        s = replay(bag, config, target)
        return summarize_replay(s, shaper, tol=tol, bag=name, group=group)
    except NothingToReplay as exc:
        return BagReport(
            bag=name,
            robot=robot,
            status="nothing to replay",
            reason=_one_line(exc),
            code=NOTHING_TO_REPLAY_CODE,
        )
    except VelfenceError as exc:
        return BagReport(
            bag=name,
            robot=robot,
            status="unreadable",
            reason=_one_line(exc),
            code=UNREADABLE_CODE,
        )
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


def _shaper_of(config: str | Path | Mapping[str, Any]) -> ConfiguredShaper:
    """The configured shaper of a config, parsed once per file version in each process."""
    from velfence.io.bags import load_replay_config

    if isinstance(config, Mapping):
        return load_replay_config(config)[0]
    path = Path(os.fspath(config))
    if not path.is_file():
        return load_replay_config(path)[0]  # refused with the loader's message
    st = path.stat()
    return _cached_shaper(str(path.resolve()), st.st_mtime_ns, st.st_size)


@lru_cache(maxsize=8)
def _cached_shaper(path: str, mtime_ns: int, size: int) -> ConfiguredShaper:
    from velfence.io.bags import load_replay_config

    return load_replay_config(path)[0]


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text if len(text) <= 400 else text[:399] + "…"


# ------------------------------------------------------------------------------- fleet


def _is_bag_dir(path: Path) -> bool:
    return (path / "metadata.yaml").is_file()


def find_bags(paths: Iterable[str | Path]) -> list[tuple[Path, str]]:
    """The bags under the given paths, each with its group (the sub-folder it was found in).

    A directory with ``metadata.yaml`` is one bag; a ``.mcap`` or ``.db3`` file is one bag;
    any other directory is searched, in name order, and a bag found in it gets the path of its
    folder below the given directory as group (``robot_a`` for ``fleet/robot_a/run_1``).

    Args:
        paths: Bags and folders of bags.

    Returns:
        ``(bag, group)`` pairs in the order given, then by name.

    Raises:
        InvalidParameter: a path that does not exist, or more than :data:`MAX_BAGS` bags.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    if not isinstance(paths, (list, tuple)):
        raise InvalidParameter(f"paths: expected a list of paths, got {describe(paths)}")
    found: list[tuple[Path, str]] = []
    for given in paths:
        if not isinstance(given, (str, os.PathLike)) or not os.fspath(given):
            raise InvalidParameter(f"paths: expected bag or folder paths, got {describe(given)}")
        root = Path(check_text("paths", os.fspath(given), max_length=4096))
        if not root.exists():
            raise InvalidParameter(f"paths: {root} does not exist")
        if root.is_file() or _is_bag_dir(root):
            found.append((root, ""))
            continue
        for dirpath, dirnames, filenames in os.walk(root):
            here = Path(dirpath)
            dirnames.sort()
            group = here.relative_to(root).as_posix()
            group = "" if group == "." else group
            for f in sorted(filenames):
                if f.endswith(BAG_SUFFIXES):
                    found.append((here / f, group))
            keep = []
            for d in dirnames:
                if _is_bag_dir(here / d):
                    found.append((here / d, group))
                else:
                    keep.append(d)
            dirnames[:] = keep
        if len(found) > MAX_BAGS:
            raise InvalidParameter(f"bags: more than {MAX_BAGS:,} found under {root}")
    return found


def fleet_replay(
    bags: Sequence[str | Path | tuple[str | Path, str]],
    config: str | Path | Mapping[str, Any],
    *,
    engine: Engine | None = None,
    tol: float | None = None,
    out: str | Path | None = None,
    progress: OnProgress | None = None,
) -> FleetSummary:
    """Replay every bag with one configuration and summarize the fleet.

    Args:
        bags: Bags, or ``(bag, group)`` pairs as :func:`find_bags` gives them.
        config: The replay configuration (a YAML path, which every worker must be able to read,
            or the mapping); checked once here first.
        engine: Where the bags are replayed (default: serially in this process).
        tol: A change larger than this [command unit] counts as the filter acting (default
            :data:`velfence.io.bags.CHANGE_TOL`).
        out: A folder to keep the shaped bags in (``out/<bag name>``); default: none kept.
        progress: ``progress(done, total, what)`` after each bag (the engine's).

    Returns:
        One report per bag, in the order given.

    Raises:
        InvalidParameter: a bad configuration, bags, ``tol`` or ``out``.
        ClusterUnavailable: the engine could not start.
        MissingExtra: Dask (``velfence[cluster]``) for a Dask engine.
    """
    from velfence.apps.engine import Engine
    from velfence.io.bags import CHANGE_TOL, load_replay_config

    tol = CHANGE_TOL if tol is None else check_positive("tol", tol, allow_zero=True)
    if engine is not None and not isinstance(engine, Engine):
        raise InvalidParameter(f"engine: expected an Engine or None, got {describe(engine)}")
    folder = None if out is None else _path("out", out)
    _config_arg(config)
    load_replay_config(config)  # a bad config is one error, not one per bag
    if isinstance(bags, (str, os.PathLike)) or not isinstance(bags, Sequence):
        raise InvalidParameter(f"bags: expected a list of bags, got {describe(bags)}")
    pairs = [b if isinstance(b, tuple) else (b, "") for b in bags]
    if len(pairs) > MAX_BAGS:
        raise InvalidParameter(f"bags: expected at most {MAX_BAGS:,}, got {len(pairs):,}")
    names = output_names([Path(os.fspath(b)) for b, _ in pairs])
    if folder is not None:
        folder.mkdir(parents=True, exist_ok=True)
    items = [
        (os.fspath(b), group, None if folder is None else str(folder / n))
        for (b, group), n in zip(pairs, names, strict=True)
    ]
    shared = os.fspath(config) if isinstance(config, (str, os.PathLike)) else dict(config)
    shard = partial(_shard, config=shared, tol=tol)
    runner = engine if engine is not None else Engine(workers=0)
    reports = runner.run(shard, items, retries=1, progress=progress)
    label = os.fspath(config) if isinstance(config, (str, os.PathLike)) else "<mapping>"
    return FleetSummary(config=label, tol=tol, bags=tuple(reports))


def _shard(item: tuple[str, str, str | None], *, config: Any, tol: float) -> BagReport:
    bag, group, out = item
    return summarize_bag(bag, config, tol=tol, out=out, group=group)


def output_names(bags: Sequence[Path]) -> list[str]:
    """One output name per bag: its own name (a file's stem), with its folder's when two clash.

    ``velfence replay`` names the shaped bag of each input with it.

    Args:
        bags: The bags.

    Returns:
        Distinct names, in the bags' order (numbered when folder names do not separate them).
    """
    if not isinstance(bags, (list, tuple)) or not all(isinstance(b, Path) for b in bags):
        raise InvalidParameter(f"bags: expected a list of pathlib.Path, got {describe(bags)}")
    names = [b.stem if b.is_file() else b.name for b in bags]
    if len(set(names)) == len(names):
        return names
    names = [
        f"{b.parent.name}_{n}" if names.count(n) > 1 else n
        for b, n in zip(bags, names, strict=True)
    ]
    if len(set(names)) == len(names):
        return names
    return [f"{k + 1:02d}_{n}" for k, n in enumerate(names)]


# ------------------------------------------------------------------------- a demo fleet

#: The replay configuration of :func:`make_demo_fleet` (a mobile base in a 4 m x 3 m room).
DEMO_FLEET_CONFIG = """\
# A fleet of mobile bases in a 4 m x 3 m room (velfence.apps.fleet.make_demo_fleet).
shaper:
  kind: polygon
  corners: [[0, 0], [4, 0], [4, 3], [0, 3]]   # the room's walls, odom frame [m]
  buffer: 0.5                                  # [m]
  spring_gain: 1.0                             # [1/s]
replay:
  command_topic: /cmd_vel        # geometry_msgs/msg/TwistStamped
  state_topic: /odom             # nav_msgs/msg/Odometry
  max_state_age: 0.3             # [s]
"""

#: Start of the demo fleet's clock [ns] (any fixed time would do).
_DEMO_EPOCH_NS = 1_750_000_000 * 10**9


def _demo_messages(ts: Any, rng: np.random.Generator, cycles: int) -> list[tuple[Any, ...]]:
    """One drive: a random start in the room, two random legs; odometry 50 ms after each command."""
    from velfence.io.bags import ODOMETRY, TWIST, TWIST_STAMPED

    T = ts.types
    Time, Header, Vec = (
        T["builtin_interfaces/msg/Time"],
        T["std_msgs/msg/Header"],
        T["geometry_msgs/msg/Vector3"],
    )
    Twist, Point, Quat = T[TWIST], T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"]
    zero = Vec(x=0.0, y=0.0, z=0.0)
    cov = np.zeros(36)

    def header(t_ns: int) -> Any:
        return Header(stamp=Time(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id="odom")

    x, y = rng.uniform(0.3, 3.7), rng.uniform(0.3, 2.7)
    duration = 0.1 * cycles  # [s]; each drive covers 0.3 m to 2.5 m, however long it is
    legs = [
        rng.uniform(0.3, 2.5) / duration * np.array([np.cos(a), np.sin(a)])
        for a in rng.uniform(0.0, 2 * np.pi, 2)
    ]
    out: list[tuple[Any, ...]] = []
    for i in range(cycles):
        t_cmd = _DEMO_EPOCH_NS + i * 100_000_000
        vx, vy = (float(v) for v in legs[0 if i < cycles // 2 else 1])
        lin = Vec(x=vx, y=vy, z=0.0)
        cmd = T[TWIST_STAMPED](header=header(t_cmd), twist=Twist(linear=lin, angular=zero))
        out.append(("/cmd_vel", TWIST_STAMPED, t_cmd, cmd))
        x, y = x + 0.1 * vx, y + 0.1 * vy  # driven without a fence: it may leave the room
        t_odom = t_cmd + 50_000_000
        pose = T["geometry_msgs/msg/Pose"](
            position=Point(x=float(x), y=float(y), z=0.0),
            orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0),
        )
        odom = T[ODOMETRY](
            header=header(t_odom),
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=Twist(linear=lin, angular=zero), covariance=cov
            ),
        )
        out.append(("/odom", ODOMETRY, t_odom, odom))
    return out


def make_demo_fleet(
    folder: str | Path,
    *,
    bags: int = 20,
    robots: int = 2,
    corrupt: int = 0,
    cycles: int = 30,
    seed: int = 0,
) -> Path:
    """Write a small fleet of mobile-base bags and its replay configuration (``replay.yaml``).

    ``folder/robot_<r>/drive_<k>`` are rosbag2 directories (MCAP; every fifth sqlite3), each a
    drive of ``cycles`` commands at 10 Hz from a random start in a 4 m x 3 m room along two
    random straight legs (0.3 m to 2.5 m in all), recorded without a fence (so some drives
    leave the room); the ``corrupt`` extra bags are broken on purpose (alternately a
    ``metadata.yaml`` that is not a bag's, and an ``.mcap`` file of garbage). The bags are a
    pure function of the arguments.

    Args:
        folder: A new folder (its parent must exist).
        bags: Good bags (1 to 100,000).
        robots: Robots (sub-folders) they are spread over, round robin.
        corrupt: Broken bags added (0 to 1,000).
        cycles: Commands per bag (1 to 100,000).
        seed: The random drives' seed.

    Returns:
        ``folder`` (the configuration is ``folder / "replay.yaml"``).

    Raises:
        InvalidParameter: a bad argument, an existing folder, the ``ros`` extra not installed.
    """
    from velfence._validate import check_positive_int, check_seed
    from velfence.io.bags import message_typestore

    root = _path("folder", folder)
    n = check_positive_int("bags", bags, maximum=100_000)
    m = check_positive_int("robots", robots, maximum=1000)
    broken = check_positive_int("corrupt", corrupt, minimum=0, maximum=1000)
    steps = check_positive_int("cycles", cycles, maximum=100_000)
    rng = np.random.default_rng(check_seed("seed", seed))
    if root.exists():
        raise InvalidParameter(f"folder: {root} exists already; remove it first")
    try:
        from rosbags.rosbag2 import StoragePlugin, Writer
    except ImportError:
        raise InvalidParameter(
            "make_demo_fleet needs rosbags: pip install 'velfence[ros]'"
        ) from None
    ts = message_typestore(None)
    root.mkdir()
    (root / "replay.yaml").write_text(DEMO_FLEET_CONFIG, encoding="utf-8")
    for k in range(n):
        robot = root / f"robot_{k % m + 1}"
        robot.mkdir(exist_ok=True)
        plugin = StoragePlugin.SQLITE3 if k % 5 == 4 else StoragePlugin.MCAP
        msgs = _demo_messages(ts, rng, steps)
        with Writer(robot / f"drive_{k + 1:04d}", version=9, storage_plugin=plugin) as writer:
            conns: dict[str, Any] = {}
            for topic, msgtype, _, _ in msgs:
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
            for topic, msgtype, t, msg in msgs:
                writer.write(conns[topic], t, ts.serialize_cdr(msg, msgtype))
    for j in range(broken):
        robot = root / f"robot_{j % m + 1}"
        robot.mkdir(exist_ok=True)
        if j % 2 == 0:
            bad = robot / f"broken_{j + 1:04d}"
            bad.mkdir()
            (bad / "metadata.yaml").write_text("rosbag2_bagfile_information: [not a bag\n")
        else:
            (robot / f"broken_{j + 1:04d}.mcap").write_bytes(
                bytes(rng.integers(0, 256, 512).tolist())
            )
    return root
