r"""The simulated user study of Khokar 2009 §7.2: unassisted vs laser-assisted.

The thesis ran 10 subjects, 3 runs per mode, and reports only that "for each subject the time
taken ... in the unassisted mode was always more than ... in the laser assisted control mode"
(Fig. 75, lost), that assisted paths are straight and unassisted ones unsteady with loops near the
pick-up point (Fig. 74, lost), and six workload comments. :func:`run_study` repeats the protocol
with synthetic operators (:mod:`velfence.teleop.operator`), one :class:`OperatorProfile` drawn per
subject from a seeded generator, and returns every run's :class:`~velfence.teleop.task.TaskRecord`.
:func:`plot_times` and :func:`plot_paths` redraw Figs. 75 and 74 from it; :func:`write_study`
writes them with the records as JSON; :func:`record_animation` renders one assisted run.

Seeds: subject ``s``'s profile comes from ``default_rng([seed, s])``, run ``r`` of condition
``c`` from ``SeedSequence([seed, s, c, r])``, so a study is reproducible and adding subjects does
not change the earlier ones. Runs of one subject share the profile (no learning between runs —
the thesis trained subjects to a uniform comfort level first).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_positive_int, step_count
from velfence.errors import InvalidParameter
from velfence.teleop.operator import OperatorProfile
from velfence.teleop.task import CONDITIONS, MAX_TICKS, TaskRecord, TaskRun, run_task

#: Most runs per condition of one study (``n_subjects * runs``).
MAX_RUNS = 10_000

__all__ = [
    "StudyResult",
    "plot_paths",
    "plot_times",
    "record_animation",
    "run_study",
    "write_study",
]


_COLORS = {"unassisted": "#d62728", "assisted": "#1f77b4"}
_LABELS = {"unassisted": "Unassisted mode", "assisted": "Laser assisted mode"}


@dataclass(frozen=True)
class StudyResult:
    """All runs of a simulated study.

    Attributes:
        records: One :class:`TaskRecord` per run (subject-major, unassisted first).
        profiles: The subjects' profiles, index = subject.
        traces: ``(subject, condition, run) -> trace`` (wrist and fingertip path, decimated).
        runs: Runs per condition per subject.
        seed: The study seed.
    """

    records: tuple[TaskRecord, ...]
    profiles: tuple[OperatorProfile, ...]
    traces: dict[tuple[int, str, int], FloatArray]
    runs: int
    seed: int

    @property
    def n_subjects(self) -> int:
        """Number of subjects."""
        return len(self.profiles)

    def values(self, field: str, condition: str) -> FloatArray:
        """One measure of every run of a condition, shape (n_subjects, runs).

        Args:
            field: A numeric :class:`TaskRecord` field (e.g. ``"time"``).
            condition: ``"unassisted"`` or ``"assisted"``.
        """
        if condition not in CONDITIONS:
            raise InvalidParameter(
                f"condition: expected one of {list(CONDITIONS)}, got {condition!r}"
            )
        out = np.full((self.n_subjects, self.runs), math.nan)
        for r in self.records:
            if r.condition == condition:
                out[r.subject, r.run] = float(getattr(r, field))
        return out

    def subject_means(self, field: str = "time") -> FloatArray:
        """Per-subject mean of a measure, shape (n_subjects, 2): unassisted, assisted."""
        return np.stack([self.values(field, c).mean(axis=1) for c in CONDITIONS], axis=1)

    def summary(self) -> dict[str, Any]:
        """Headline numbers (JSON-able): per-condition means, and per-subject comparisons."""
        times = self.subject_means("time")
        out: dict[str, Any] = {
            "subjects": self.n_subjects,
            "runs": self.runs,
            "seed": self.seed,
            "completed": {c: int(self.values("done", c).sum()) for c in CONDITIONS},
            "subjects_faster_assisted": int(np.sum(times[:, 1] < times[:, 0])),
            "speedup_mean": float(np.mean(times[:, 0] / times[:, 1])),
        }
        for field in (
            "time",
            "path_length",
            "straightness",
            "segments",
            "pickup_detour",
            "collisions",
            "clutch_presses",
            "index_events",
            "keys",
            "active_time",
            "autonomous_time",
        ):
            m = self.subject_means(field)
            out[field] = {
                c: {
                    "mean": float(m[:, i].mean()),
                    "min": float(m[:, i].min()),
                    "max": float(m[:, i].max()),
                }
                for i, c in enumerate(CONDITIONS)
            }
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: summary, records and profiles."""
        return {
            "summary": self.summary(),
            "records": [r.to_dict() for r in self.records],
            "profiles": [p.to_dict() for p in self.profiles],
        }


def _seed(seed: int, *path: int) -> int:
    return int(np.random.SeedSequence([seed, *path]).generate_state(1)[0])


def run_study(
    n_subjects: int = 10,
    runs: int = 3,
    seed: int = 0,
    *,
    rate: float = 100.0,
    tick: float = 0.02,
    time_limit: float = 400.0,
    progress: Callable[[int, int], None] | None = None,
) -> StudyResult:
    """Run the simulated study: every subject does ``runs`` runs in each condition.

    Args:
        n_subjects: Number of simulated subjects, int ``>= 1`` (thesis 10).
        runs: Runs per condition per subject, int ``>= 1`` (thesis 3).
        seed: Study seed, int ``>= 0``.
        rate: Session control rate [Hz] (see :func:`~velfence.teleop.task.run_task`).
        tick: Operator period [s].
        time_limit: Per-run limit [s].
        progress: Called as ``progress(done, total)`` after every run.

    Returns:
        The :class:`StudyResult`.

    Raises:
        InvalidParameter: non-positive counts or a bad seed.
    """
    n_subjects = check_positive_int("n_subjects", n_subjects, maximum=MAX_RUNS, example=10)
    runs = check_positive_int("runs", runs, maximum=MAX_RUNS, example=3)
    check_positive_int("seed", seed, minimum=0, example=0)
    if n_subjects * runs > MAX_RUNS:
        raise InvalidParameter(
            f"n_subjects * runs: expected at most {MAX_RUNS:,} runs per condition, got "
            f"{n_subjects * runs:,}"
        )
    if progress is not None and not callable(progress):
        raise InvalidParameter(
            f"progress: expected a function (done, total) or None, got {type(progress).__name__}"
        )
    # rate, tick and time_limit are checked once here, before any subject is drawn.
    check_positive("rate", rate, unit="Hz")
    step_count("time_limit", time_limit, "tick", tick, max_steps=MAX_TICKS)
    profiles = tuple(
        OperatorProfile.draw(np.random.default_rng([int(seed), s])) for s in range(n_subjects)
    )
    records: list[TaskRecord] = []
    traces: dict[tuple[int, str, int], FloatArray] = {}
    total = n_subjects * runs * len(CONDITIONS)
    for s, profile in enumerate(profiles):
        for c, condition in enumerate(CONDITIONS):
            for r in range(runs):
                out = run_task(
                    condition,
                    profile,
                    seed=_seed(int(seed), s, c, r),
                    subject=s,
                    run=r,
                    rate=rate,
                    tick=tick,
                    time_limit=time_limit,
                )
                records.append(out.record)
                traces[(s, condition, r)] = out.trace
                if progress is not None:
                    progress(len(records), total)
    return StudyResult(
        records=tuple(records), profiles=profiles, traces=traces, runs=int(runs), seed=int(seed)
    )


# ------------------------------------------------------------------------------------ plots
def plot_times(result: StudyResult, path: str | Path) -> Path:
    """Fig. 75 redrawn: per-subject mean task time in both modes, runs as dots.

    Args:
        result: The study.
        path: Output image (``.png``).

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from velfence.viz.plots import save_figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = result.n_subjects
    x = np.arange(n)
    width = 0.38
    fig, ax = plt.subplots(figsize=(max(6.0, 0.8 * n + 2.0), 4.2))
    for i, cond in enumerate(CONDITIONS):
        vals = result.values("time", cond)
        xs = x + (i - 0.5) * width
        ax.bar(xs, vals.mean(axis=1), width, color=_COLORS[cond], alpha=0.8, label=_LABELS[cond])
        for k in range(vals.shape[1]):
            ax.plot(xs, vals[:, k], "k.", ms=3)
    ax.set_xticks(x, [str(s + 1) for s in range(n)])
    ax.set_xlabel("subject (simulated)")
    ax.set_ylabel("task time [s] (mean of runs; dots: runs)")
    faster = result.summary()["subjects_faster_assisted"]
    ax.set_title(
        f"Pick-and-place time, unassisted vs laser assisted ({faster}/{n} faster assisted)"
    )
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return save_figure(fig, out, dpi=110)


def plot_paths(
    result: StudyResult, path: str | Path, *, run: int = 0, max_subjects: int = 10
) -> Path:
    """Fig. 74 redrawn: each subject's end-effector (wrist-centre) path in both modes.

    Args:
        result: The study.
        path: Output image (``.png``).
        run: Which run of each subject to draw.
        max_subjects: Draw at most this many subjects (first ones).

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from velfence.viz.plots import save_figure

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    n = min(result.n_subjects, max_subjects)
    cols = min(n, 5)
    rows = math.ceil(n / cols)
    fig = plt.figure(figsize=(3.2 * cols, 3.0 * rows))
    for s in range(n):
        ax = fig.add_subplot(rows, cols, s + 1, projection="3d")
        for cond in CONDITIONS:
            tr = result.traces.get((s, cond, run))
            if tr is None:
                continue
            ax.plot(tr[:, 1], tr[:, 2], tr[:, 3], color=_COLORS[cond], lw=1.0, label=_LABELS[cond])
        ax.set_title(f"subject {s + 1}", fontsize=9)
        ax.tick_params(labelsize=6)
        ax.set_xlabel("x [m]", fontsize=7)
        ax.set_ylabel("y [m]", fontsize=7)
        ax.set_zlabel("z [m]", fontsize=7)
        if s == 0:
            ax.legend(fontsize=6, loc="upper left")
    fig.suptitle(
        "End-effector (wrist-centre) paths, pick-and-place (cf. thesis Fig. 74)", fontsize=10
    )
    return save_figure(fig, out, dpi=100)


def write_study(result: StudyResult, out: str | Path) -> list[Path]:
    """Write ``study.json`` (summary, records, profiles) and the two figures into ``out``.

    Returns:
        The files written.
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    data = folder / "study.json"
    data.write_text(json.dumps(result.to_dict(), indent=2) + "\n")
    return [
        data,
        plot_times(result, folder / "study_times.png"),
        plot_paths(result, folder / "study_paths.png"),
    ]


def record_animation(
    path: str | Path,
    *,
    seed: int = 0,
    profile: OperatorProfile | None = None,
    fps: int = 15,
    snapshot_rate: float = 5.0,
    rate: float = 100.0,
) -> tuple[Path, TaskRun]:
    """Run one assisted pick-and-place and render it (``velfence.viz.telerobotics``).

    Falls back to writing the snapshots and scene as JSON (``path`` with suffix ``.json``) when
    the renderer is not available.

    Args:
        path: Output animation (``.gif``).
        seed: Seed of the run.
        profile: The operator (default: subject 0 of a study with this seed).
        fps: Playback frames per second.
        snapshot_rate: Snapshots per simulated second [Hz].
        rate: Session control rate [Hz].

    Returns:
        ``(written path, the run)``.
    """
    prof = (
        profile if profile is not None else OperatorProfile.draw(np.random.default_rng([seed, 0]))
    )
    run = run_task(
        "assisted", prof, seed=_seed(seed, 0, 1, 0), rate=rate, snapshot_rate=snapshot_rate
    )
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        from velfence.viz.telerobotics import animate_session
    except ImportError:
        fallback = out.with_suffix(".json")
        payload = {"snapshots": list(run.snapshots), "scene": list(run.scene)}
        fallback.write_text(json.dumps(payload) + "\n")
        return fallback, run
    written = animate_session(list(run.snapshots), list(run.scene), out, fps=fps)
    return Path(written), run
