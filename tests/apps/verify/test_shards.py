"""``velfence verify``'s shards: the same results whatever runs them, resume (fast: no report)."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("typer", reason="the command line needs the [app] extra")
pytest.importorskip("matplotlib", reason="the report needs the [app] extra")
import matplotlib

matplotlib.use("Agg")
import sys

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viz"))

from verify_campaigns import SMALL

from velfence.apps.verify import verify
from velfence.apps.verify.campaign import parse_campaign
from velfence.apps.verify.runner import plan
from velfence.errors import InvalidParameter


def _cases(out: Path) -> list[dict[str, Any]]:
    """Every case record of the shard files, in shard order (timing left out)."""
    files = sorted((out / "shards").glob("*.json"))
    return [c for p in files for c in json.loads(p.read_text())["cases"]]


def _shuffled_map(fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
    """A mapper that runs the shards in reverse order, as another worker layout might."""
    for i in reversed(range(len(items))):
        yield i, fn(items[i])


def test_a_campaign_gives_the_same_results_whatever_runs_its_shards(tmp_path: Path) -> None:
    a = verify(SMALL, tmp_path / "serial", report=False)
    b = verify(SMALL, tmp_path / "other", mapper=_shuffled_map, report=False)
    assert a.summary.complete
    assert b.summary.complete
    assert len(plan(parse_campaign(SMALL))) == 3
    ca, cb = _cases(tmp_path / "serial"), _cases(tmp_path / "other")
    assert len(ca) == 5
    assert ca == cb
    assert sum(c["steps"] for c in ca) == 5 * 12
    assert a.summary.holds, a.summary.failing  # the filter with dt keeps every property


def test_resume_runs_only_the_missing_shards(tmp_path: Path) -> None:
    out = tmp_path / "run"
    verify(SMALL, out, report=False)
    before = _cases(out)
    (out / "shards" / "f000-s00001.json").unlink()
    calls: list[Any] = []

    def counting(fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
        for i, r in enumerate(map(fn, items)):
            calls.append(items[i][2])  # the shard number
            yield i, r

    o = verify(SMALL, out, resume=True, mapper=counting, report=False)
    assert calls == [1]
    assert o.shards_run == 1
    assert _cases(out) == before
    # A resume of a different campaign in the same folder is refused; so is a rerun without it.
    other = {**SMALL, "seed": 1}
    with pytest.raises(InvalidParameter, match="--resume refused"):
        verify(other, out, resume=True, report=False)
    with pytest.raises(InvalidParameter, match="pass --resume"):
        verify(SMALL, out, report=False)


def test_the_serial_engine_gives_the_same_results(tmp_path: Path) -> None:
    """The one-line campaign through the engine's serial mode equals the default run."""
    from velfence.apps.engine import Engine

    verify(SMALL, tmp_path / "default", report=False)
    with Engine(workers=0) as engine:
        verify(SMALL, tmp_path / "engine", report=False, mapper=engine.map)
    assert _cases(tmp_path / "engine") == _cases(tmp_path / "default")
