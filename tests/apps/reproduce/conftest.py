"""Whole reproductions run once per test session and shared by every test file that inspects them.

``velfence reproduce telerobotics`` is four parts (kinematics, laser, motion, study). The assembled
run is made once, through :func:`velfence.apps.reproduce.telerobotics.run` itself, and each part's
own return value is recorded on the way, so the per-part test files inspect the very checks and
figures of that run instead of running the part a second time.

Every reproduction's figures are recorded while it runs (``tests/shared_runs.py``) and checked by
the figure checker in the reproduction's own test file: one run gives both the verdicts and the
pictures (the figure tests used to run each reproduction again).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import pytest

from shared_runs import recording
from velfence.apps.reproduce import telerobotics
from velfence.apps.reproduce.base import Check, Report

PARTS = ("kinematics_checks", "laser_checks", "motion_checks", "study_checks")
#: The study size of the shared run (``velfence reproduce telerobotics`` runs 10 subjects x 3).
SUBJECTS, RUNS = 2, 1


class TeleroboticsRun(NamedTuple):
    """One assembled run: its folder, its report, each part's (checks, figures), the figures."""

    out: Path
    report: Report
    parts: dict[str, tuple[list[Check], list[Path]]]
    calls: dict[str, tuple[tuple[Any, ...], dict[str, Any]]]
    figures: Any


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test that needs the shared telerobotics run is ``slow`` (about 35 s of CPU)."""
    for item in items:
        if "telerobotics_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def telerobotics_run(tmp_path_factory: pytest.TempPathFactory) -> TeleroboticsRun:
    out = tmp_path_factory.mktemp("telerobotics")
    parts: dict[str, tuple[list[Check], list[Path]]] = {}
    calls: dict[str, tuple[tuple[Any, ...], dict[str, Any]]] = {}

    def recorded(name: str, part: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            assert name not in parts, f"{name} ran twice in one reproduction"
            calls[name] = (args, kwargs)
            parts[name] = part(*args, **kwargs)
            return parts[name]

        return call

    with pytest.MonkeyPatch.context() as mp, recording() as figures:
        for name in PARTS:
            mp.setattr(telerobotics, name, recorded(name, getattr(telerobotics, name)))
        report = telerobotics.run(out, subjects=SUBJECTS, runs=RUNS)
    assert set(parts) == set(PARTS)
    return TeleroboticsRun(out, report, parts, calls, figures)
