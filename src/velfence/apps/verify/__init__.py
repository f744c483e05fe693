"""``velfence verify``: evidence campaigns at scale, shrunk counterexamples, a report.

A campaign file (:mod:`~velfence.apps.verify.campaign`, ``docs/config.md``) names a robot, the
safety filter's settings, families of randomised closed-loop cases and the properties every step
must keep. :func:`verify` runs its shards (:mod:`~velfence.apps.verify.runner`) serially or
through the distributed engine, writes one file per shard to the output folder (``--resume``
skips the finished ones), shrinks failing cases to minimal reproducers written as YAML
scenarios (:mod:`~velfence.apps.verify.cases`; :func:`replay` runs one again) and writes the
evidence report (:mod:`~velfence.apps.verify.report`). ``docs/verify.md`` walks through it.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from velfence._validate import check_flag, describe
from velfence.apps.verify.campaign import PROPERTIES, Campaign, load_campaign, parse_campaign
from velfence.apps.verify.cases import (
    CaseResult,
    Scenario,
    load_scenario,
    run,
    sample,
    shrink,
    write_scenario,
)
from velfence.apps.verify.report import (
    Counterexample,
    plot_counterexample,
    plot_histograms,
    write_report,
)
from velfence.apps.verify.runner import (
    Mapper,
    Summary,
    plan,
    prepare,
    run_shards,
    summarise,
)
from velfence.errors import InvalidParameter

__all__ = [
    "Campaign",
    "CaseResult",
    "Outcome",
    "Scenario",
    "load_campaign",
    "load_scenario",
    "parse_campaign",
    "replay",
    "verify",
]

#: ``on_progress(done, total, what)`` (:data:`velfence.apps.progress.OnProgress`).
OnProgress = Callable[[float, float, str], None]


@dataclass(kw_only=True)
class Outcome:
    """What :func:`verify` did.

    Attributes:
        summary: The gathered results.
        counterexamples: The shrunk failing cases written.
        files: The report, its figures and the scenarios written.
        shards_run: Shards run by this call (not skipped by a resume).
        steps_per_second: Closed-loop steps per second of wall time of this call's shards.
        interrupted: Stopped early (Ctrl-C): the report says incomplete.
    """

    summary: Summary
    counterexamples: list[Counterexample] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    shards_run: int = 0
    steps_per_second: float = 0.0
    interrupted: bool = False


def verify(
    campaign: Campaign | Any,
    out: Path,
    *,
    resume: bool = False,
    mapper: Mapper | None = None,
    on_progress: OnProgress | None = None,
    report: bool = True,
) -> Outcome:
    """Run a campaign: shards, shrinking, report (module docstring).

    Args:
        campaign: A :class:`Campaign` or its mapping.
        out: The output folder.
        resume: Skip the shards already in ``out`` (refused if ``out`` holds another campaign).
        mapper: Runs the shards: ``mapper(fn, items)`` yields ``(index, result)``, e.g. the
            ``map`` of a started :class:`velfence.apps.engine.Engine`; None: the serial engine
            (``Engine(workers=0)``, in this process).
        on_progress: Called after each shard with cases done, cases in total and a line with
            the steps/s and the worst margin so far.
        report: Shrink the failing cases and write the report (False: the shards only).

    Returns:
        The :class:`Outcome`.

    Raises:
        InvalidParameter: an invalid campaign, an unusable ``out`` or a refused resume.
    """
    campaign = parse_campaign(campaign, where="campaign")
    if not isinstance(out, (str, os.PathLike)) or not os.fspath(out):
        raise InvalidParameter(
            f"out: expected a folder path (str or pathlib.Path), got {describe(out)}"
        )
    out = Path(out)
    resume = check_flag("resume", resume)
    if mapper is not None and not callable(mapper):
        raise InvalidParameter(f"mapper: expected a callable or None, got {describe(mapper)}")
    if on_progress is not None and not callable(on_progress):
        raise InvalidParameter(
            f"on_progress: expected a callable or None, got {describe(on_progress)}"
        )
    report = check_flag("report", report)
    done = prepare(campaign, out, resume=resume)
    shards = plan(campaign)
    total = sum(s.stop - s.start for s in shards)
    cases_done = sum(s.stop - s.start for s in shards if s.name in done)
    steps = 0
    worst: dict[str, float] = {}
    t0 = time.perf_counter()

    def on_shard(rec: dict[str, Any]) -> None:
        nonlocal cases_done, steps
        cases_done += len(rec["cases"])
        steps += int(rec["steps"])
        for c in rec["cases"]:
            for prop, (m, _) in c["worst"].items():
                worst[prop] = min(worst.get(prop, m), m)
        if on_progress is not None:
            rate = steps / max(time.perf_counter() - t0, 1e-9)
            w = ", ".join(f"{p} {worst[p]:.3g}" for p in PROPERTIES if p in worst)
            on_progress(cases_done, total, f"cases {cases_done:,}/{total:,}, {rate:,.0f} steps/s, "
                        f"worst margin {w}")  # fmt: skip

    outcome = Outcome(summary=Summary(0, len(shards)))
    if on_progress is not None:
        on_progress(cases_done, total, f"cases {cases_done:,}/{total:,}")
    try:
        if mapper is None:
            from velfence.apps.engine import Engine

            with Engine(workers=0) as serial:
                outcome.shards_run = run_shards(
                    campaign, out, done=done, mapper=serial.map, on_shard=on_shard
                )
        else:
            outcome.shards_run = run_shards(
                campaign, out, done=done, mapper=mapper, on_shard=on_shard
            )
    except KeyboardInterrupt:
        outcome.interrupted = True
    seconds = time.perf_counter() - t0
    outcome.steps_per_second = steps / seconds if seconds > 0 and steps else 0.0
    summary = summarise(campaign, out)
    outcome.summary = summary
    if not report:
        return outcome
    if not outcome.interrupted:
        outcome.counterexamples = _counterexamples(campaign, summary, out)
    figures = plot_histograms(summary, out)
    md, page = write_report(
        campaign,
        summary,
        out,
        counterexamples=outcome.counterexamples,
        figures=figures,
        steps_per_second=outcome.steps_per_second or None,
    )
    outcome.files = [md, page, *figures]
    for cx in outcome.counterexamples:
        outcome.files += [cx.path, cx.picture]
    return outcome


def _counterexamples(campaign: Campaign, summary: Summary, out: Path) -> list[Counterexample]:
    """Shrink up to ``campaign.shrink`` failing cases (one per property first) and write them."""
    chosen: list[tuple[str, int, list[str]]] = []
    for prop in PROPERTIES:  # the first failing case of each property, then the others
        for f in summary.failing:
            if prop in f[2] and f not in chosen:
                chosen.append(f)
                break
    chosen += [f for f in summary.failing if f not in chosen]
    chosen = chosen[: campaign.shrink]
    if not chosen:
        return []
    folder = out / "counterexamples"
    folder.mkdir(exist_ok=True)
    names = [f.name for f in campaign.families]
    found = []
    for fam, index, _ in chosen:
        original = sample(campaign, names.index(fam), index)
        small = shrink(original)
        r = run(small, record=True)
        stem = f"{fam}-{index:06d}"
        path = write_scenario(
            small,
            folder / f"{stem}.yaml",
            comment=f"velfence verify counterexample: family {fam}, case {index}, shrunk; it "
            f"violates {', '.join(r.violated)}.\nReplay: velfence verify --replay {stem}.yaml",
        )
        pic = plot_counterexample(r.trace, f"{fam} #{index}: {', '.join(r.violated)}",
                                  folder / f"{stem}.png")  # fmt: skip
        found.append(
            Counterexample(fam, index, tuple(r.violated), path, pic, small.steps, original.steps)
        )
    return found


def replay(path: str | Path) -> CaseResult:
    """Run a scenario file again (a counterexample): deterministic, bit for bit.

    Args:
        path: The scenario (YAML, as written by ``velfence verify``).

    Returns:
        The run's :class:`CaseResult` (``violated`` empty: it holds now).

    Raises:
        InvalidParameter: a missing or invalid scenario file.
    """
    sc = load_scenario(path)
    return run(sc, family=Path(path).stem)
