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

**Reusing a study's runs.** ``velfence study`` and ``velfence reproduce telerobotics`` run the
same 60-run study (minutes of CPU). :func:`save_runs` writes a study's runs to
``study_runs.npz`` in its output folder with a key, :func:`study_key`: a hash of everything that
determines them (subjects, runs per mode, seed, rate, tick, time limit, the velfence and NumPy
versions and the velfence source code itself). :func:`load_runs` gives them back only when the
key of the study asked for is the same; the loaded runs equal a fresh run's bit for bit.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import math
import os
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence._validate import check_positive, check_positive_int, describe, step_count
from velfence.apps.teleop.operator import OperatorProfile
from velfence.apps.teleop.task import CONDITIONS, MAX_TICKS, TaskRecord, TaskRun, run_task
from velfence.errors import InvalidParameter, VelfenceError

#: Most runs per condition of one study (``n_subjects * runs``).
MAX_RUNS = 10_000

#: The file of a study's runs in its output folder (:func:`save_runs`).
STUDY_RUNS = "study_runs.npz"

__all__ = [
    "STUDY_RUNS",
    "StudyResult",
    "assisted_run",
    "load_runs",
    "run_study",
    "runs_key",
    "save_runs",
    "study_key",
]


@dataclass(frozen=True)
class StudyResult:
    """All runs of a simulated study.

    Attributes:
        records: One :class:`TaskRecord` per run (subject-major, unassisted first).
        profiles: The subjects' profiles, index = subject.
        traces: ``(subject, condition, run) -> trace`` (wrist and fingertip path, decimated).
        runs: Runs per condition per subject.
        seed: The study seed.
        rate: Session control rate [Hz].
        tick: Operator period [s].
        time_limit: Per-run limit [s].
    """

    records: tuple[TaskRecord, ...]
    profiles: tuple[OperatorProfile, ...]
    traces: dict[tuple[int, str, int], FloatArray]
    runs: int
    seed: int
    rate: float = 100.0
    tick: float = 0.02
    time_limit: float = 400.0

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
        records=tuple(records),
        profiles=profiles,
        traces=traces,
        runs=int(runs),
        seed=int(seed),
        rate=float(rate),
        tick=float(tick),
        time_limit=float(time_limit),
    )


def _source_digest() -> str:
    """SHA-256 of velfence's Python sources (the code a study runs), paths included."""
    root = Path(__file__).resolve().parents[2]  # .../velfence
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(f.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(f.read_bytes())
    return h.hexdigest()


def _version(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def study_key(
    n_subjects: int = 10,
    runs: int = 3,
    seed: int = 0,
    *,
    rate: float = 100.0,
    tick: float = 0.02,
    time_limit: float = 400.0,
) -> str:
    """The key of a study: a hash of everything that determines its runs.

    The arguments of :func:`run_study`, the velfence, velfence-core and NumPy versions and a
    hash of velfence's source files (so a changed line of code is a different study even at the
    same version number).

    Args:
        n_subjects: Simulated subjects.
        runs: Runs per condition per subject.
        seed: Study seed.
        rate: Session control rate [Hz].
        tick: Operator period [s].
        time_limit: Per-run limit [s].

    Returns:
        A 64-character hexadecimal SHA-256.

    Raises:
        InvalidParameter: a count, seed or period out of range (as :func:`run_study`).
    """
    what = {
        "n_subjects": check_positive_int("n_subjects", n_subjects, maximum=MAX_RUNS, example=10),
        "runs": check_positive_int("runs", runs, maximum=MAX_RUNS, example=3),
        "seed": check_positive_int("seed", seed, minimum=0, example=0),
        "rate": float(check_positive("rate", rate, unit="Hz")),
        "tick": float(check_positive("tick", tick, unit="s")),
        "time_limit": float(check_positive("time_limit", time_limit, unit="s")),
        "velfence": _version("velfence"),
        "velfence-core": _version("velfence-core"),
        "numpy": np.__version__,
        "source": _source_digest(),
    }
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()


def _key_of(result: StudyResult) -> str:
    return study_key(
        result.n_subjects,
        result.runs,
        result.seed,
        rate=result.rate,
        tick=result.tick,
        time_limit=result.time_limit,
    )


def _folder(name: str, x: Any) -> Path:
    if isinstance(x, (bytes, bytearray)) or not isinstance(x, (str, os.PathLike)):
        raise InvalidParameter(f"{name}: expected a folder path (str or Path), got {describe(x)}")
    text = os.fspath(x)
    if not isinstance(text, str) or not text or "\0" in text or len(text) > 4096:
        raise InvalidParameter(f"{name}: expected a non-empty folder path, got {describe(x)}")
    return Path(text)


def save_runs(result: StudyResult, folder: str | Path) -> Path:
    """Write a study's runs, with their :func:`study_key`, to ``folder/study_runs.npz``.

    Args:
        result: The study.
        folder: Its output folder (created if missing).

    Returns:
        The file written.

    Raises:
        InvalidParameter: ``result`` is not a :class:`StudyResult` or ``folder`` not a path.
    """
    if not isinstance(result, StudyResult):
        raise InvalidParameter(f"result: expected a StudyResult, got {describe(result)}")
    out = _folder("folder", folder)
    out.mkdir(parents=True, exist_ok=True)
    keys = list(result.traces)
    meta = {
        "runs": result.runs,
        "seed": result.seed,
        "rate": result.rate,
        "tick": result.tick,
        "time_limit": result.time_limit,
        "records": [r.to_dict() for r in result.records],
        "profiles": [p.to_dict() for p in result.profiles],
        "traces": [list(k) for k in keys],
    }
    arrays: dict[str, Any] = {"key": np.array(_key_of(result)), "meta": np.array(json.dumps(meta))}
    arrays.update({f"trace_{i}": np.asarray(result.traces[k]) for i, k in enumerate(keys)})
    path = out / STUDY_RUNS
    np.savez_compressed(path, **arrays)
    return path


def runs_key(folder: str | Path) -> str | None:
    """The :func:`study_key` of the runs saved in ``folder``, read alone (fast).

    Args:
        folder: A study's output folder.

    Returns:
        The key, or None when there is no readable ``study_runs.npz``.

    Raises:
        InvalidParameter: ``folder`` is not a path.
    """
    path = _folder("folder", folder) / STUDY_RUNS
    try:
        with np.load(path, allow_pickle=False) as data:
            return str(data["key"])
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return None


def load_runs(folder: str | Path, key: str) -> tuple[StudyResult | None, str]:
    """The runs :func:`save_runs` wrote to ``folder``, if they are the study of ``key``.

    Args:
        folder: A study's output folder (``velfence study --out``).
        key: The :func:`study_key` of the study wanted.

    Returns:
        ``(result, why)``: the study (None when there is no file, it is unreadable or its key
        differs) and one line saying which.

    Raises:
        InvalidParameter: ``folder`` is not a path or ``key`` not a string.
    """
    path = _folder("folder", folder) / STUDY_RUNS
    if not isinstance(key, str):
        raise InvalidParameter(f"key: expected the str of study_key(), got {describe(key)}")
    if not path.is_file():
        return None, f"no {STUDY_RUNS} in {path.parent}"
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["key"]) != key:
                return None, (
                    f"{path} holds a different study (settings, seed, velfence version or code)"
                )
            meta = json.loads(str(data["meta"]))
            traces = {
                (int(s), str(c), int(r)): np.array(data[f"trace_{i}"])
                for i, (s, c, r) in enumerate(meta["traces"])
            }
        result = StudyResult(
            records=tuple(TaskRecord(**d) for d in meta["records"]),
            profiles=tuple(OperatorProfile(**d) for d in meta["profiles"]),
            traces=traces,
            runs=int(meta["runs"]),
            seed=int(meta["seed"]),
            rate=float(meta["rate"]),
            tick=float(meta["tick"]),
            time_limit=float(meta["time_limit"]),
        )
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile, VelfenceError) as exc:
        return None, f"{path} is unreadable ({type(exc).__name__}: {exc})"
    n = len(result.records)
    return result, f"the same study's {n} runs from {path} (key {key[:12]})"


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
