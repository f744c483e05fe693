"""The distributed engine: serial, embedded LocalCluster and a real cluster give the same results.

The real cluster is started by the ``real_cluster`` fixture (tests/apps/conftest.py) as separate
processes (``dask scheduler`` and two ``dask worker --no-nanny`` on 127.0.0.1, free ports) and
torn down after the test. Killing the
worker that holds a shard must lose nothing: the scheduler gives the shard to the other worker.
"""

from __future__ import annotations

import importlib.util
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from velfence.apps.engine import (
    ClusterUnavailable,
    Engine,
    ShardFailed,
    default_workers,
    progress_text,
)
from velfence.errors import InvalidParameter, MissingExtra

HAVE_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason="needs velfence[cluster] (dask)")

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from dask_cluster import RealCluster, free_port  # noqa: E402
from engine_tasks import hold_once, square_sum  # noqa: E402

ITEMS = [(k, (7 * k) % 5) for k in range(23)]
EXPECTED = [square_sum(item) for item in ITEMS]


# ---------------------------------------------------------------------------- serial (fast)


def test_serial_engine_gives_results_in_item_order_with_progress() -> None:
    seen: list[tuple[float, float, str]] = []
    with Engine(workers=0) as engine:
        assert engine.mode == "serial"
        assert engine.started
        assert engine.n_workers() == 0
        pairs = list(engine.map(square_sum, ITEMS, progress=lambda d, t, w: seen.append((d, t, w))))
        assert engine.run(square_sum, ITEMS) == EXPECTED
    assert pairs == list(enumerate(EXPECTED))
    assert [d for d, _, _ in seen] == list(range(1, len(ITEMS) + 1))
    assert {t for _, t, _ in seen} == {len(ITEMS)}
    assert seen[-1][2].startswith(f"{len(ITEMS)}/{len(ITEMS)} shards, ")
    assert seen[-1][2].endswith("ETA 0:00:00")


def test_serial_engine_retries_then_names_the_failing_shard() -> None:
    calls: list[int] = []

    def flaky(x: int) -> int:
        calls.append(x)
        if x == 2 and calls.count(2) < 3:
            raise OSError("transient")
        if x == 4:
            raise ValueError("always")
        return 10 * x

    engine = Engine(workers=0)
    assert engine.run(flaky, [0, 1, 2, 3], retries=2) == [0, 10, 20, 30]
    with pytest.raises(
        ShardFailed, match=r"shard 1 failed after 2 attempt\(s\): ValueError: always"
    ):
        engine.run(flaky, [3, 4], retries=1)
    calls.clear()
    with pytest.raises(ShardFailed) as info:
        engine.run(flaky, [2], retries=0)
    assert info.value.index == 0
    assert calls == [2]


def test_progress_text_rate_and_eta() -> None:
    assert progress_text(0, 10, 0.0) == "0/10 shards, 0/s, ETA -"
    assert progress_text(30, 100, 10.0) == "30/100 shards, 3/s, ETA 0:00:23"
    assert progress_text(5, 3605, 1.0) == "5/3605 shards, 5/s, ETA 0:12:00"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"workers": -1}, "workers"),
        ({"workers": 2.0}, "workers"),
        ({"workers": True}, "workers"),
        ({"cluster": "tcp://127.0.0.1:8786", "workers": 2}, "not both"),
        ({"cluster": "http://x:1"}, "scheduler address"),
        ({"cluster": ""}, "scheduler address"),
        ({"cluster": 8786}, "cluster"),
        ({"timeout": 0}, "timeout"),
        ({"timeout": float("nan")}, "timeout"),
    ],
)
def test_bad_arguments_are_named(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(InvalidParameter, match=match):
        Engine(**kwargs)


def test_bad_map_arguments_are_named() -> None:
    engine = Engine(workers=0)
    with pytest.raises(InvalidParameter, match="fn"):
        list(engine.map(42, [1]))  # type: ignore[arg-type]
    with pytest.raises(InvalidParameter, match="items"):
        list(engine.map(str, 42))  # type: ignore[call-overload]
    with pytest.raises(InvalidParameter, match="retries"):
        list(engine.map(str, [1], retries=-1))
    with pytest.raises(InvalidParameter, match="progress"):
        list(engine.map(str, [1], progress="yes"))  # type: ignore[arg-type]


def test_default_workers_is_the_cores_of_this_process() -> None:
    expected = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert default_workers() == expected


def test_without_dask_a_dask_engine_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)
    monkeypatch.setitem(sys.modules, "dask", None)
    with pytest.raises(MissingExtra, match=r"pip install 'velfence\[cluster\]'"):
        Engine(workers=2).start()
    assert Engine(workers=0).run(square_sum, ITEMS[:3]) == EXPECTED[:3]  # serial needs no Dask


@needs_dask
def test_an_address_that_does_not_answer_is_a_clear_error_fast() -> None:
    port = free_port()  # nothing listens there
    start = time.monotonic()
    with pytest.raises(ClusterUnavailable, match=f"127.0.0.1:{port}.*within 2 s"):
        Engine(cluster=f"tcp://127.0.0.1:{port}", timeout=2.0).start()
    assert time.monotonic() - start < 15.0  # a bound against a hang, not a timing target


# --------------------------------------------------------------------------- clusters (slow)


@needs_dask
@pytest.mark.slow
def test_serial_local_and_real_cluster_give_equal_results(real_cluster: RealCluster) -> None:
    with Engine(workers=0) as serial:
        by_serial = serial.run(square_sum, ITEMS)
    with Engine(workers=2, timeout=30) as local:
        assert local.mode == "local"
        assert local.n_workers() == 2
        arrived = list(local.map(square_sum, ITEMS))
        by_local = local.run(square_sum, ITEMS)
    with Engine(cluster=real_cluster.address, timeout=30) as remote:
        assert remote.mode == "cluster"
        assert remote.n_workers() == 2
        by_remote = remote.run(square_sum, ITEMS)
    assert by_serial == by_local == by_remote == EXPECTED
    assert sorted(arrived) == list(enumerate(EXPECTED))


@needs_dask
@pytest.mark.slow
def test_dask_scheduler_address_from_the_environment(
    real_cluster: RealCluster, monkeypatch: pytest.MonkeyPatch
) -> None:
    import dask

    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", real_cluster.address)
    dask.config.refresh()
    try:
        with Engine(timeout=30) as engine:
            assert engine.mode == "cluster"
            assert engine.address == real_cluster.address
            assert engine.run(square_sum, ITEMS[:5]) == EXPECTED[:5]
    finally:
        monkeypatch.delenv("DASK_SCHEDULER_ADDRESS")
        dask.config.refresh()


@needs_dask
@pytest.mark.slow
def test_a_killed_worker_loses_nothing(real_cluster: RealCluster, tmp_path: Path) -> None:
    items = [(k, str(tmp_path)) for k in range(12)]
    flag = tmp_path / "held"
    results: dict[int, int] = {}
    with Engine(cluster=real_cluster.address, timeout=30) as engine:
        for index, value in engine.map(hold_once, items, retries=0):
            results[index] = value
            if len(results) == 1:
                deadline = time.monotonic() + 60
                while not flag.exists() and time.monotonic() < deadline:
                    time.sleep(0.02)
                pid = int(flag.read_text())
                victims = [p for p in real_cluster.workers if p.pid == pid]
                assert len(victims) == 1, (pid, [p.pid for p in real_cluster.workers])
                os.kill(pid, signal.SIGKILL)
                victims[0].wait(timeout=30)
        assert engine.n_workers() == 1
    assert results == {k: k * k for k in range(12)}


_INTERRUPTED = """
import sys
sys.path.insert(0, {here!r})
from engine_tasks import hold_once
from velfence.apps.engine import Engine

if __name__ == "__main__":
    try:
        with Engine(workers=2, timeout=60) as engine:
            engine.run(hold_once, [(k, {folder!r}) for k in range(12)])
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        sys.exit(130)
"""


@needs_dask
@pytest.mark.slow
def test_ctrl_c_stops_the_embedded_cluster_without_a_traceback(tmp_path: Path) -> None:
    script = tmp_path / "interrupted.py"
    script.write_text(_INTERRUPTED.format(here=str(HERE), folder=str(tmp_path)))
    proc = subprocess.Popen(
        [sys.executable, str(script)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120
        while not (tmp_path / "held").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert (tmp_path / "held").exists(), "shard 5 never started"
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the whole foreground process group
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    assert err == "interrupted\n"  # no worker printed a KeyboardInterrupt traceback
    worker = int((tmp_path / "held").read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(worker, 0)  # the worker holding shard 5 was stopped with the cluster
