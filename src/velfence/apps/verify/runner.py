"""Shards of a campaign: the plan, one shard's run, the output folder, resume, the summary.

Family ``f``'s cases are cut into fixed ranges of ``shard_size`` cases (shard ``f``-``j`` holds
cases ``j * shard_size`` to ``(j + 1) * shard_size - 1``); each case's scenario depends on the
campaign's seed, ``f`` and its index only (:func:`velfence.apps.verify.cases.sample`), so the
results are the same whatever runs the shards and in whatever order. A finished shard is one JSON
file ``shards/<name>.json`` in the output folder, written to a temporary name and renamed (a
shard is there whole or not at all). ``manifest.json`` records the campaign's hash (of its
normalised configuration, :func:`velfence.apps.verify.campaign.campaign_hash`); a resume skips
the shards whose file is there and refuses an output folder of another campaign.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from velfence.apps.verify.campaign import PROPERTIES, Campaign, campaign_hash, parse_campaign
from velfence.errors import InvalidParameter

__all__ = [
    "Shard",
    "Summary",
    "plan",
    "prepare",
    "run_shard",
    "run_shards",
    "summarise",
]

#: ``mapper(fn, items)`` yields ``(index, fn(items[index]))`` in any order (the engine's map).
Mapper = Callable[[Callable[[Any], Any], list[Any]], Iterable[tuple[int, Any]]]
#: ``on_shard(record)``: called in the main process after each shard's file is written.
OnShard = Callable[[dict[str, Any]], None]

MANIFEST = "manifest.json"
SHARDS = "shards"


@dataclass(frozen=True)
class Shard:
    """A fixed range of one family's cases.

    Attributes:
        family: The family's index.
        number: The shard's number within its family.
        start: First case index.
        stop: One past the last case index.
    """

    family: int
    number: int
    start: int
    stop: int

    @property
    def name(self) -> str:
        """The shard's file stem, ``f000-s00000``."""
        return f"f{self.family:03d}-s{self.number:05d}"


def plan(campaign: Campaign) -> list[Shard]:
    """Every shard of the campaign, family by family.

    Args:
        campaign: The campaign.

    Returns:
        The shards in order.
    """
    out = []
    size = campaign.shard_size
    for f, fam in enumerate(campaign.families):
        for j in range(math.ceil(fam.cases / size)):
            out.append(Shard(f, j, j * size, min(fam.cases, (j + 1) * size)))
    return out


def run_shard(item: tuple[dict[str, Any], int, int, int, int]) -> dict[str, Any]:
    """Run one shard's cases (a top-level function: it is shipped to the engine's workers).

    Args:
        item: ``(normalised campaign, family, number, start, stop)``.

    Returns:
        The shard record: ``shard``, ``hash``, ``cases`` (each case's
        :meth:`~velfence.apps.verify.cases.CaseResult.to_json`), ``steps``, ``seconds``.
    """
    from velfence.apps.verify.batch import run_batch
    from velfence.apps.verify.cases import sample

    data, f, number, start, stop = item
    campaign = parse_campaign(data)
    name = campaign.families[f].name
    t0 = time.perf_counter()
    # The shard's cases in lock-step (the kinematic plant; any other plant runs case by case
    # inside run_batch): each result equals cases.run's bit for bit, whatever the shard size.
    idx = list(range(start, stop))
    results = run_batch([sample(campaign, f, i) for i in idx], family=name, indices=idx)
    cases = [r.to_json() for r in results]
    return {
        "shard": Shard(f, number, start, stop).name,
        "hash": campaign_hash(campaign),
        "cases": cases,
        "steps": sum(c["steps"] for c in cases),
        "seconds": time.perf_counter() - t0,
    }


def _write_json(path: Path, data: Any) -> None:
    """Write JSON atomically (a temporary file renamed over ``path``)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
    os.replace(tmp, path)


def prepare(campaign: Campaign, out: Path, *, resume: bool) -> set[str]:
    """Make the output folder ready and name the shards already done.

    Args:
        campaign: The campaign.
        out: The output folder (created if missing).
        resume: Continue a campaign started in ``out`` (else ``out`` must hold none).

    Returns:
        The names of the finished shards (empty without ``resume``).

    Raises:
        InvalidParameter: ``out`` holds another campaign (its hash differs) on resume, holds a
            campaign without ``resume``, or is not a writable folder.
    """
    h = campaign_hash(campaign)
    manifest = out / MANIFEST
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / SHARDS).mkdir(exist_ok=True)
    except OSError as exc:
        raise InvalidParameter(f"--out {out}: cannot create the folder ({exc})") from None
    if manifest.exists():
        try:
            old = json.loads(manifest.read_text()).get("hash")
        except (OSError, ValueError, AttributeError):
            old = None
        if not resume:
            raise InvalidParameter(
                f"--out {out}: holds a campaign already (manifest.json); pass --resume to "
                "continue it, or choose another folder"
            )
        if old != h:
            raise InvalidParameter(
                f"--resume refused: {out} holds campaign {str(old)[:12]}…, this campaign's hash "
                f"is {h[:12]}… (a different configuration); use another --out"
            )
    from velfence import __version__

    _write_json(manifest, {"hash": h, "version": __version__, "shards": len(plan(campaign))})
    import yaml

    (out / "campaign.yaml").write_text(yaml.safe_dump(campaign.normalised(), sort_keys=False))
    done = set()
    if resume:
        for p in (out / SHARDS).glob("*.json"):
            try:
                rec = json.loads(p.read_text())
            except (OSError, ValueError):
                continue
            if isinstance(rec, dict) and rec.get("hash") == h:
                done.add(p.stem)
    return done


def run_shards(
    campaign: Campaign,
    out: Path,
    *,
    done: set[str],
    mapper: Mapper,
    on_shard: OnShard | None = None,
) -> int:
    """Run every shard not in ``done`` through ``mapper`` and write its file.

    Args:
        campaign: The campaign.
        out: Its output folder.
        done: Names of the shards to skip.
        mapper: Runs the shards (``mapper(fn, items)`` yields ``(index, result)``).
        on_shard: Called with each shard's record after its file is written.

    Returns:
        The number of shards run.
    """
    data = campaign.normalised()
    todo = [s for s in plan(campaign) if s.name not in done]
    items = [(data, s.family, s.number, s.start, s.stop) for s in todo]
    ran = 0
    for i, rec in mapper(run_shard, items):
        _write_json(out / SHARDS / f"{todo[i].name}.json", rec)
        ran += 1
        if on_shard is not None:
            on_shard(rec)
    return ran


@dataclass
class Summary:
    """The campaign's results gathered from its shard files.

    Attributes:
        shards_done: Shards whose file is there.
        shards_total: Shards in the plan.
        cases: Family name -> cases done.
        steps: Family name -> steps run.
        worst: Property -> ``(margin, family, index, step)`` of the worst case.
        margins: Property -> every case's worst margin.
        interventions: Every case's mean relative intervention.
        failing: ``(family, index, violated properties)`` of every failing case.
        seconds: Sum of the shards' run times [s].
    """

    shards_done: int
    shards_total: int
    cases: dict[str, int] = field(default_factory=dict)
    steps: dict[str, int] = field(default_factory=dict)
    worst: dict[str, tuple[float, str, int, int]] = field(default_factory=dict)
    margins: dict[str, list[float]] = field(default_factory=dict)
    interventions: list[float] = field(default_factory=list)
    failing: list[tuple[str, int, list[str]]] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def complete(self) -> bool:
        """Every shard of the plan is done."""
        return self.shards_done == self.shards_total

    @property
    def holds(self) -> bool:
        """No case violated a property."""
        return not self.failing


def summarise(campaign: Campaign, out: Path) -> Summary:
    """Gather the shard files of ``out`` (shards of this campaign only), in plan order.

    Args:
        campaign: The campaign.
        out: Its output folder.

    Returns:
        The :class:`Summary`.
    """
    h = campaign_hash(campaign)
    shards = plan(campaign)
    s = Summary(0, len(shards))
    for fam in campaign.families:
        s.cases[fam.name] = 0
        s.steps[fam.name] = 0
    for sh in shards:
        p = out / SHARDS / f"{sh.name}.json"
        try:
            rec = json.loads(p.read_text())
        except (OSError, ValueError):
            continue
        if not isinstance(rec, dict) or rec.get("hash") != h:
            continue
        s.shards_done += 1
        s.seconds += float(rec.get("seconds", 0.0))
        for c in rec["cases"]:
            fam = c["family"]
            s.cases[fam] += 1
            s.steps[fam] += int(c["steps"])
            s.interventions.append(float(c["intervention_mean"]))
            for prop in PROPERTIES:
                if prop in c["worst"]:
                    m, step = c["worst"][prop]
                    s.margins.setdefault(prop, []).append(float(m))
                    w = s.worst.get(prop)
                    if w is None or m < w[0]:
                        s.worst[prop] = (float(m), fam, int(c["index"]), int(step))
            if c["violated"]:
                s.failing.append((fam, int(c["index"]), list(c["violated"])))
    return s
