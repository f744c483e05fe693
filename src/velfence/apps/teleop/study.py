r"""The simulated user study of Khokar 2009 §7.2: unassisted vs laser-assisted.

The thesis ran 10 subjects, 3 runs per mode, and reports only that "for each subject the time
taken ... in the unassisted mode was always more than ... in the laser assisted control mode"
(Fig. 75, lost), that assisted paths are straight and unassisted ones unsteady with loops near the
pick-up point (Fig. 74, lost), and six workload comments. :func:`run_study` repeats the protocol
with synthetic operators (:mod:`velfence.apps.teleop.operator`), one :class:`OperatorProfile` drawn
per
subject from a seeded generator, and returns every run's
:class:`~velfence.apps.teleop.task.TaskRecord`.
:func:`assisted_run` is the one assisted run a study's animation shows. Drawing is in
:mod:`velfence.apps.viz.study` (Figs. 75 and 74 redrawn, the files of a study, the animation).

Seeds: subject ``s``'s profile comes from ``default_rng([seed, s])``, run ``r`` of condition
``c`` from ``SeedSequence([seed, s, c, r])``, so a study is reproducible and adding subjects does
not change the earlier ones. Runs of one subject share the profile (no learning between runs —
the thesis trained subjects to a uniform comfort level first).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_positive_int, step_count
from velfence.apps.teleop.operator import OperatorProfile
from velfence.apps.teleop.task import CONDITIONS, MAX_TICKS, TaskRecord, TaskRun, run_task
from velfence.errors import InvalidParameter

#: Most runs per condition of one study (``n_subjects * runs``).
MAX_RUNS = 10_000

__all__ = ["StudyResult", "assisted_run", "run_study"]


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
        rate: Session control rate [Hz] (see :func:`~velfence.apps.teleop.task.run_task`).
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


def assisted_run(
    *,
    seed: int = 0,
    profile: OperatorProfile | None = None,
    snapshot_rate: float = 5.0,
    rate: float = 100.0,
) -> TaskRun:
    """One laser-assisted pick-and-place with snapshots, the run a study's animation shows.

    Args:
        seed: Seed, int ``>= 0``; the run gets the seeds of subject 0's first assisted run in a
            study with this seed.
        profile: The operator (default: subject 0 of a study with this seed).
        snapshot_rate: Snapshots per simulated second [Hz].
        rate: Session control rate [Hz].

    Returns:
        The :class:`~velfence.apps.teleop.task.TaskRun` (record, snapshots, scene, trace).

    Raises:
        InvalidParameter: a bad seed or rate (see :func:`~velfence.apps.teleop.task.run_task`).
    """
    seed = check_positive_int("seed", seed, minimum=0, example=0)
    prof = (
        profile if profile is not None else OperatorProfile.draw(np.random.default_rng([seed, 0]))
    )
    return run_task(
        "assisted", prof, seed=_seed(seed, 0, 1, 0), rate=rate, snapshot_rate=snapshot_rate
    )
