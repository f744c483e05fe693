"""Closed-loop steps per second of a ``velfence verify`` campaign, and where the time goes.

The campaign: the 7-joint arm (``DHChain.seven_dof``, 5 cm capsule links, 5 cm tool), a workspace
box and 5 spheres per case, 1 kHz, joint-velocity commands (the filter's whole cycle in C,
``SafetyFilter.cycle_in_c``), the soak's wandering operator, a kinematic plant. It runs once
serially in this process, then, with ``--workers N`` (N > 0) and the engine installed, through the
engine on N workers. The breakdown times the filter's cycle alone (``SafetyFilter.filter``) on the
states of one case beside the whole closed-loop step (operator, cycle, plant, margins).

With ``--cluster-compare`` it runs the same campaign twice more, on the engine's embedded
``LocalCluster`` of ``--workers`` processes and on a local cluster started as separate processes
(``dask scheduler`` and ``--workers`` ``dask worker --no-nanny`` processes on 127.0.0.1, as a user
would start them), and prints both rates, their ratio (the target: the cluster at 80 % of the
embedded rate or more) and the engine's overhead: per shard, the wall time the workers spent
beyond the shards' own run time (``(wall x workers - sum of the shards' seconds) / shards``),
and the round trip of an empty shard (``engine.map(abs, ...)``: submit, schedule, run nothing,
gather). Both engines are warmed up first by a small campaign (every worker imports velfence and
builds a filter once), which is not timed.

Run: ``python benchmarks/verify.py [--cases 8] [--steps 2000] [--workers 2] [--cluster-compare]``;
prints one line per measurement (docs/verify.md gives the numbers with the load they were
measured under).
"""

from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np


def campaign(cases: int, steps: int) -> dict[str, Any]:
    """The benchmark's campaign: one family, one case per shard."""
    return {
        "robot": "seven_dof",
        "rate": 1000.0,
        "shard_size": 1,
        "families": [
            {
                "name": "box-5-spheres",
                "cases": cases,
                "steps": steps,
                "mode": "joint",
                "operator": "wander",
                "obstacles": {"count": [5, 5]},
            }
        ],
    }


def breakdown(spec: dict[str, Any]) -> tuple[float, float]:
    """(µs per closed-loop step, µs per filter cycle alone) on case 0."""
    from velfence.apps.verify.campaign import parse_campaign
    from velfence.apps.verify.cases import build_filter, chain, run, sample

    sc = sample(parse_campaign(spec), 0, 0)
    r = run(sc, record=True)  # warm
    t0 = time.perf_counter()
    r = run(sc, record=True)
    step_us = (time.perf_counter() - t0) / r.steps * 1e6
    robot = chain(sc.robot, sc.link_radius)
    flt = build_filter(sc, robot)
    assert flt.cycle_in_c, "the benchmark expects the C cycle (velfence_core installed)"
    Q = r.trace["q"]
    rng = np.random.default_rng(0)
    U = rng.uniform(-1.0, 1.0, Q.shape) * np.asarray(sc.max_speed)
    for q, u in zip(Q[:100], U[:100], strict=True):
        flt.filter(q, u)
    t0 = time.perf_counter()
    for q, u in zip(Q, U, strict=True):
        flt.filter(q, u)
    cycle_us = (time.perf_counter() - t0) / Q.shape[0] * 1e6
    return step_us, cycle_us


@contextmanager
def local_cluster(workers: int, log: Path) -> Iterator[str]:
    """A scheduler and ``workers`` workers, separate processes on 127.0.0.1; yields its address."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).with_name("dask"))
    with log.open("w") as out:
        procs = [
            subprocess.Popen(
                [dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                stdout=out,
                stderr=subprocess.STDOUT,
            )
        ]
        try:
            for k in range(workers):
                argv = [dask, "worker", address, "--no-nanny", "--nthreads", "1", "--host",
                        "127.0.0.1", "--no-dashboard", "--name", f"w{k}"]  # fmt: skip
                procs.append(subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT))
            from distributed import Client

            with Client(address, timeout=60) as client:
                client.wait_for_workers(workers, timeout=120)
            yield address
        finally:
            for proc in reversed(procs):
                proc.terminate()
            for proc in procs:
                try:
                    proc.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


def on_engine(spec: dict[str, Any], out: Path, engine: Any) -> tuple[int, float, float, int]:
    """Run the campaign through a started engine: (steps, wall [s], shards' own seconds, shards).

    A small campaign runs first (two 10-step shards per worker, not timed), so that every worker
    has imported velfence and built a filter once: the rates compare the engines at work, not
    their workers' first imports (the start-up is printed on its own).
    """
    from velfence.apps.verify import verify

    warm = campaign(2 * engine.n_workers(), 10)
    verify(warm, out.with_name(out.name + "-warm-up"), report=False, mapper=engine.map)

    t0 = time.perf_counter()
    o = verify(spec, out, report=False, mapper=engine.map)
    wall = time.perf_counter() - t0
    return sum(o.summary.steps.values()), wall, o.summary.seconds, o.summary.shards_done


def round_trip(engine: Any, n: int = 200) -> float:
    """Seconds per empty shard: ``engine.run(abs, range(n))`` (a builtin: no code to ship)."""
    engine.run(abs, range(20))  # warm
    t0 = time.perf_counter()
    engine.run(abs, range(n))
    return (time.perf_counter() - t0) / n


def cluster_compare(spec: dict[str, Any], workers: int, tmp: Path) -> None:
    """Embedded LocalCluster against a cluster of separate processes, the same campaign."""
    from velfence.apps.engine import Engine

    rows = []
    t0 = time.perf_counter()
    with Engine(workers=workers, timeout=60) as engine:
        start = time.perf_counter() - t0
        rows.append(("embedded", start, *on_engine(spec, tmp / "embedded", engine),
                     round_trip(engine)))  # fmt: skip
    t0 = time.perf_counter()
    with (
        local_cluster(workers, tmp / "dask.log") as address,
        Engine(cluster=address, timeout=60) as engine,
    ):
        start = time.perf_counter() - t0
        rows.append(("cluster", start, *on_engine(spec, tmp / "cluster", engine),
                     round_trip(engine)))  # fmt: skip
    rates = {}
    for name, start, steps, wall, busy, shards, trip in rows:
        rates[name] = steps / wall
        overhead = (wall * workers - busy) / shards
        print(
            f"{name}, {workers} workers: {steps:,} steps in {wall:.2f} s = {steps / wall:,.0f} "
            f"steps/s (start-up {start:.1f} s, not counted); shards' own time {busy:.2f} s; "
            f"engine overhead {overhead * 1e3:.1f} ms per shard ({shards} shards); empty shard "
            f"round trip {trip * 1e3:.2f} ms"
        )
    same = (tmp / "embedded" / "shards").exists() and all(
        _cases(tmp / "embedded" / "shards" / f.name) == _cases(f)
        for f in sorted((tmp / "cluster" / "shards").glob("*.json"))
    )
    print(
        f"cluster / embedded: {rates['cluster'] / rates['embedded']:.0%} (target >= 80 %); "
        f"shard results equal: {same}"
    )


def _cases(path: Path) -> Any:
    import json

    return json.loads(path.read_text())["cases"]


def main() -> None:
    """Run the measurements and print them."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", type=int, default=8)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--workers", type=int, default=2, help="engine workers (0: serial only)")
    ap.add_argument(
        "--cluster-compare",
        action="store_true",
        help="also run on the embedded engine and on a local cluster of separate processes",
    )
    args = ap.parse_args()
    from velfence.apps.verify import verify

    spec = campaign(args.cases, args.steps)
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}, {os.cpu_count()} cores")
    step_us, cycle_us = breakdown(spec)
    print(
        f"one case: {step_us:.1f} µs per closed-loop step, {cycle_us:.1f} µs of it the filter's "
        f"C cycle ({cycle_us / step_us:.0%}); the rest: operator, plant, forward kinematics and "
        "the margins in Python"
    )
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        o = verify(spec, Path(tmp) / "serial", report=False)
        wall = time.perf_counter() - t0
        steps = sum(o.summary.steps.values())
        print(f"serial: {steps:,} steps in {wall:.1f} s = {steps / wall:,.0f} steps/s")
        if args.workers > 0 and args.cluster_compare:
            cluster_compare(spec, args.workers, Path(tmp))
        elif args.workers > 0:
            try:
                from velfence.apps.engine import Engine  # type: ignore[import-not-found,unused-ignore]
            except ImportError:
                print("engine: not installed (velfence.apps.engine); serial only")
                return
            with Engine(workers=args.workers) as engine:
                t0 = time.perf_counter()
                o = verify(spec, Path(tmp) / "engine", report=False, mapper=engine.map)
                wall = time.perf_counter() - t0
            steps = sum(o.summary.steps.values())
            print(
                f"engine, {args.workers} workers: {steps:,} steps in {wall:.1f} s = "
                f"{steps / wall:,.0f} steps/s (start-up of the workers included)"
            )
    print("target: >= 100,000 closed-loop steps/s on 2 cores")


if __name__ == "__main__":
    main()
