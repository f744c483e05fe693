"""A campaign on a real Dask cluster (a scheduler and two workers as separate processes on
127.0.0.1, the ``real_cluster`` fixture of tests/apps/conftest.py): the shard files and the
summary equal the serial run's bit for bit, through the command line's ``--cluster``; a worker
killed while it holds a shard loses nothing (slow: each starts a cluster)."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("typer", reason="the command line needs the [app] extra")
pytest.importorskip("distributed", reason="needs velfence[cluster] (dask)")

from typer.testing import CliRunner
from verify_campaigns import SMALL

from velfence.apps.cli import app
from velfence.apps.engine import Engine
from velfence.apps.verify import verify
from velfence.apps.verify.campaign import parse_campaign
from velfence.apps.verify.runner import plan, summarise

pytestmark = pytest.mark.slow

#: Eight shards of two cases that take a while each (half a second or more of CPU through the fast
#: route), so that a worker is still holding one when the first result arrives.
LONGER = {
    "robot": "seven_dof",
    "rate": 20.0,
    "shard_size": 2,
    "families": [{"name": "long", "cases": 16, "steps": 1200, "mode": "joint"}],
}


def _shards(out: Path) -> dict[str, Any]:
    """Every shard file's record without its run time (``seconds``), by file name."""
    recs = {}
    for p in sorted((out / "shards").glob("*.json")):
        rec = json.loads(p.read_text())
        rec.pop("seconds")
        recs[p.name] = rec
    return recs


def _summary(campaign: dict[str, Any], out: Path) -> dict[str, Any]:
    s = dataclasses.asdict(summarise(parse_campaign(campaign), out))
    s.pop("seconds")
    return s


def test_a_campaign_on_a_real_cluster_equals_the_serial_run(
    real_cluster: Any, tmp_path: Path
) -> None:
    import yaml

    verify(SMALL, tmp_path / "serial", report=False)
    spec = tmp_path / "small.yaml"
    spec.write_text(yaml.safe_dump(SMALL))
    out = tmp_path / "cluster"
    result = CliRunner().invoke(
        app, ["verify", str(spec), "--out", str(out), "--cluster", real_cluster.address, "-q"]
    )
    assert result.exit_code == 0, result.output
    serial = _shards(tmp_path / "serial")
    assert len(serial) == len(plan(parse_campaign(SMALL))) == 3
    assert _shards(out) == serial
    assert _summary(SMALL, out) == _summary(SMALL, tmp_path / "serial")
    assert "report.md" in os.listdir(out)


def test_a_worker_killed_mid_campaign_loses_nothing(real_cluster: Any, tmp_path: Path) -> None:
    from distributed import Client

    killed: list[int] = []
    with (
        Engine(cluster=real_cluster.address, timeout=30) as engine,
        Client(real_cluster.address, timeout=30) as spy,
    ):

        def killing(fn: Callable[[Any], Any], items: list[Any]) -> Iterator[tuple[int, Any]]:
            for n, pair in enumerate(engine.map(fn, items, retries=0)):
                yield pair
                if n == 0:  # SIGKILL a worker that holds a shard now
                    busy = [w for w, keys in spy.processing().items() if keys]
                    assert busy, "no worker held a shard after the first result"
                    pid = int(spy.run(os.getpid, workers=busy[:1])[busy[0]])
                    (victim,) = [p for p in real_cluster.workers if p.pid == pid]
                    os.kill(pid, signal.SIGKILL)
                    victim.wait(timeout=30)
                    killed.append(pid)

        o = verify(LONGER, tmp_path / "cluster", mapper=killing, report=False)
        assert engine.n_workers() == 1
    assert killed
    assert o.summary.complete
    assert o.shards_run == len(plan(parse_campaign(LONGER))) == 8
    verify(LONGER, tmp_path / "serial", report=False)
    assert _shards(tmp_path / "cluster") == _shards(tmp_path / "serial")
    assert _summary(LONGER, tmp_path / "cluster") == _summary(LONGER, tmp_path / "serial")
