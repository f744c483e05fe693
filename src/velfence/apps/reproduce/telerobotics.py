"""Reproduction of Khokar 2009: laser-assisted traded control of a PUMA 560.

Named checks from four parts, each in its own module:

* kinematics (:mod:`velfence.apps.reproduce._telerobotics_kinematics`) — forward kinematics of the
  recorded joint angles against Tables 4/5, Tables 6/7 recomputed from Tables 4/5, the printed
  a3 sign, inverse kinematics of the recorded poses;
* laser (:mod:`velfence.apps.reproduce._telerobotics_laser`) — eq. (1) from Table 1, the calibration
  procedure, reproducibility and accuracy at the Table 9 distances, old vs new sampling scheme;
* motion (:mod:`velfence.apps.reproduce._telerobotics_motion`) — singularity times 0.63 s and 2.1 s
  with J⁻¹ on the §7.4 trajectories (at the speed we fitted to those times, so their
  ratio is the independent check), bounded joint speeds with the SR inverse, straight-line
  accuracy (a one-sided bound), a pure rotation about the fingertip, and the plots the thesis
  lost;
* study (:mod:`velfence.apps.reproduce._telerobotics_study`) — simulated subjects doing the
  pick-and-place task unassisted and laser-assisted.

Every discrepancy is explained in its check's note and in ``docs/reproductions.md``.
"""

from __future__ import annotations

from pathlib import Path

from velfence.apps import progress
from velfence.apps.reproduce._telerobotics_kinematics import kinematics_checks
from velfence.apps.reproduce._telerobotics_laser import laser_checks
from velfence.apps.reproduce._telerobotics_motion import motion_checks
from velfence.apps.reproduce._telerobotics_study import study_checks
from velfence.apps.reproduce.base import Check, Report
from velfence.apps.teleop.study import runs_key, study_key

__all__ = ["REUSED_STUDY", "STAGES", "run", "stages"]

#: The parts of :func:`run` as progress stages, with their weights: their seconds with the
#: thesis's 10 subjects x 3 runs, measured on the 2-core development machine with other jobs
#: running (2026-12-08, load about 9): kinematics 3.0 s, laser 3.5 s, motion 52 s, the study's
#: 60 runs 1612 s (27 s a run). At load about 6 the first three took 4.3, 4.9 and 40 s.
STAGES: tuple[tuple[str, float], ...] = (
    ("kinematics", 3.0),
    ("laser", 3.5),
    ("motion", 52.0),
    ("study", 1612.0),
)

#: The study stage's seconds when it reuses saved runs (loading them, writing its files).
REUSED_STUDY = 5.0


def stages(
    study: str | Path | None = None, *, subjects: int = 10, runs: int = 3
) -> tuple[tuple[str, float], ...]:
    """The progress stages of :func:`run` with these arguments.

    Args:
        study: As for :func:`run`: when it holds this study's runs, the study stage only loads
            them and writes its files (:data:`REUSED_STUDY` seconds).
        subjects: As for :func:`run`.
        runs: As for :func:`run`.

    Returns:
        :data:`STAGES`, the study's weight lowered when its runs will be reused.
    """
    if study is not None and runs_key(study) == study_key(subjects, runs):
        return (*STAGES[:-1], ("study", REUSED_STUDY))
    return STAGES


def run(
    out_dir: str | Path = "out/reproduce/telerobotics",
    *,
    subjects: int = 10,
    runs: int = 3,
    study: str | Path | None = None,
) -> Report:
    """Run every part and write the figures.

    Args:
        out_dir: Folder for the figures and ``study.json``.
        subjects: Simulated subjects of the study (the thesis had 10; about 12 s each).
        runs: Runs per mode per subject (the thesis: 3).
        study: A ``velfence study --out`` folder: its runs are reused when they are the same
            study (same settings, seed, velfence version and code; docs/telerobotics.md), else
            the study runs. None: the study runs.

    Returns:
        The report (its JSON via ``to_json()``, format in :mod:`velfence.apps.reproduce.base`).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    checks: list[Check] = []
    artifacts: list[Path] = []
    for name, part in (
        ("kinematics", kinematics_checks),
        ("laser", laser_checks),
        ("motion", motion_checks),
    ):
        with progress.stage(name):
            c, a = part(out)
        checks.extend(c)
        artifacts.extend(a)
    c, a = study_checks(out, subjects=subjects, runs=runs, study=study)  # its own stage
    checks.extend(c)
    artifacts.extend(a)
    return Report("telerobotics", tuple(checks), tuple(str(p) for p in artifacts))
