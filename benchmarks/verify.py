"""Closed-loop steps per second of a ``velfence verify`` campaign, and where the time goes.

The campaign: the 7-joint arm (``DHChain.seven_dof``, 5 cm capsule links, 5 cm tool), a workspace
box and 5 spheres per case, 1 kHz, joint-velocity commands (the filter's whole cycle in C), the
soak's wandering operator, a kinematic plant, 2,000 steps per case, 64 cases per shard. Measured:

* **per-case route** (``cases.run``, the oracle): µs per closed-loop step of one case;
* **fast route, serial** (``verify`` in this process: ``batch.run_batch`` on each shard): steps/s
  of wall time and µs of CPU time per step (on a shared machine the wall time also counts the
  other processes), and the CPU time per step by part (``run_batch(timings=...)``: sampling the
  scenarios, building the filters, the operator, the filter's C cycles, the plant, the forward
  kinematics, the clearance, the margins);
* **the C cycle alone**, in one case's closed loop (its states and commands): median, p99 and
  max µs per ``FilterCycle.cycle`` call, split into the cycles the feasibility test answers
  (the rows only: kinematics, rows, ``G u >= b``) and those that solve the projection;
* **fast route on the engine** with ``--workers N`` (N > 0, the ``[cluster]`` extra installed):
  the embedded Dask cluster's start-up, then the campaign's steps/s of wall time;
* or, with ``--cluster-compare`` instead, **the embedded engine beside a cluster of separate
  processes**: the same campaign (its shards through the fast route, as every shard of the
  kinematic plant) on the engine's embedded ``LocalCluster`` of ``--workers`` processes and on a
  local cluster started as a user would start one (``dask scheduler`` and ``--workers`` ``dask
  worker --no-nanny`` processes on 127.0.0.1). It prints both rates, their ratio (the target:
  the cluster at 80 % of the embedded rate or more), whether their shard files are equal, and
  the engine's overhead: per shard, the wall time the workers spent beyond the shards' own run
  time (``(wall x workers - sum of the shards' seconds) / shards``), and the round trip of an
  empty shard (``engine.run(abs, ...)``: submit, schedule, run nothing, gather). Both engines are
  warmed up first by a small campaign (every worker imports velfence and builds a filter once),
  which is not timed. Without ``--shard-size`` the cases are cut into two shards per worker (at
  most 64 cases each), so that every worker has work.

Run: ``python benchmarks/verify.py [--cases 256] [--steps 2000] [--shard-size 64] [--workers 2]
[--cluster-compare]``; prints one line per measurement with the load average before and after
(docs/verify.md gives the numbers).
"""

from __future__ import annotations

import argparse
import math
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


def campaign(cases: int, steps: int, shard_size: int = 64) -> dict[str, Any]:
    """The benchmark's campaign: one family, ``shard_size`` cases per shard."""
    return {
        "robot": "seven_dof",
        "rate": 1000.0,
        "shard_size": shard_size,
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


def load() -> str:
    """The load average (1, 5, 15 min) and the cores, as ``uptime`` shows them."""
    a = os.getloadavg()
    return f"load average {a[0]:.2f} / {a[1]:.2f} / {a[2]:.2f} on {os.cpu_count()} cores"


def per_case(spec: dict[str, Any]) -> float:
    """µs per closed-loop step of case 0 through ``cases.run`` (the per-case oracle)."""
    from velfence.apps.verify.campaign import parse_campaign
    from velfence.apps.verify.cases import run, sample

    sc = sample(parse_campaign(spec), 0, 0)
    run(sc)  # warm
    t0 = time.process_time()
    r = run(sc)
    return (time.process_time() - t0) / r.steps * 1e6


def parts(spec: dict[str, Any], cases: int) -> tuple[dict[str, float], int]:
    """CPU seconds by part of one shard of ``cases`` cases through ``run_batch``, and its steps."""
    from velfence.apps.verify.batch import run_batch
    from velfence.apps.verify.campaign import parse_campaign
    from velfence.apps.verify.cases import sample

    c = parse_campaign(spec)
    t0 = time.process_time()
    scs = [sample(c, 0, i) for i in range(cases)]
    tm: dict[str, float] = {"sample": time.process_time() - t0}
    rs = run_batch(scs, timings=tm)
    return tm, sum(r.steps for r in rs)


def cycle_alone(spec: dict[str, Any]) -> dict[str, Any]:
    """The C cycle in case 0's closed loop: µs per call, split by whether it solved.

    The loop is the campaign's for this family (no lag, latency, noise or push: ``q += dt x``
    with the case's own wandering commands), so the states and commands are the campaign's.
    """
    from velfence.apps.soak_filter import soak_command
    from velfence.apps.verify.campaign import parse_campaign
    from velfence.apps.verify.cases import build_filter, chain, sample
    from velfence.filter.ccycle import c_cycle_or_none

    sc = sample(parse_campaign(spec), 0, 0)
    robot = chain(sc.robot, sc.link_radius)
    cyc = c_cycle_or_none(build_filter(sc, robot))
    assert cyc is not None, "the benchmark expects the C cycle (velfence_core installed)"
    rng = np.random.default_rng(sc.command_seed)
    vmax = np.asarray(sc.max_speed)
    q = np.array(sc.q0)
    p = np.asarray(robot.fk(q))
    dt = 1.0 / sc.rate
    none3, none = np.zeros((0, 3)), np.zeros(0)
    t: list[float] = []
    solved: list[bool] = []
    rows: list[int] = []
    its: list[int] = []
    clock = time.perf_counter_ns
    hold = 0
    cmd = np.zeros_like(q)
    for _ in range(sc.steps):
        if hold <= 0:
            cmd, hold = soak_command(rng, twist=False, N=none3, o=none, p=p, vmax=vmax,
                                     rate=sc.rate, push_probability=0.0)  # fmt: skip
        hold -= 1
        t0 = clock()
        x = cyc.cycle(q, cmd)
        t.append((clock() - t0) / 1e3)
        q = q + dt * x
        info = cyc.info()
        solved.append(info["solves"] > 0)
        rows.append(info["m"])
        its.append(info["iterations"])
    a = np.array(t)
    s = np.array(solved)
    return {
        "all": a,
        "rows only": a[~s],
        "solved": a[s],
        "m": float(np.mean(rows)),
        "iterations": float(np.mean(np.array(its)[s])) if s.any() else 0.0,
    }


def _stats(a: np.ndarray) -> str:
    if a.size == 0:
        return "none"
    p = np.percentile(a, [50, 99])
    return f"median {p[0]:.1f}, p99 {p[1]:.1f}, max {a.max():.1f} µs ({a.size} cycles)"


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

    warm = campaign(2 * engine.n_workers(), 10, shard_size=1)
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
    ap.add_argument("--cases", type=int, default=256)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument(
        "--shard-size",
        type=int,
        default=None,
        help="cases per shard (default 64; with --cluster-compare two shards per worker)",
    )
    ap.add_argument("--workers", type=int, default=2, help="engine workers (0: serial only)")
    ap.add_argument(
        "--cluster-compare",
        action="store_true",
        help="run on the embedded engine and on a local cluster of separate processes",
    )
    args = ap.parse_args()
    from velfence.apps.verify import verify

    size = args.shard_size
    if size is None:
        size = 64
        if args.cluster_compare and args.workers > 0:
            size = min(size, math.ceil(args.cases / (2 * args.workers)))
    spec = campaign(args.cases, args.steps, size)
    print(f"before: {load()}")
    print(f"per-case route (cases.run): {per_case(spec):.1f} µs CPU per closed-loop step")
    tm, n = parts(spec, min(size, args.cases))
    total = sum(tm.values())
    shown = ", ".join(f"{k} {v / n * 1e6:.2f}" for k, v in tm.items())
    print(f"fast route, one shard of {min(size, args.cases)} cases: "
          f"{total / n * 1e6:.2f} µs CPU per step = {shown}")  # fmt: skip
    cyc = cycle_alone(spec)
    print(f"C cycle alone (FilterCycle.cycle, {cyc['m']:.0f} rows on average): "
          f"{_stats(cyc['all'])}")  # fmt: skip
    print(f"  answered by the feasibility test (rows only): {_stats(cyc['rows only'])}")
    print(f"  solved ({cyc['iterations']:.1f} iterations on average): {_stats(cyc['solved'])}")
    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = time.process_time(), time.perf_counter()
        o = verify(spec, Path(tmp) / "serial", report=False)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        steps = sum(o.summary.steps.values())
        print(
            f"fast route, serial: {steps:,} steps in {wall:.1f} s = {steps / wall:,.0f} steps/s "
            f"(wall); {cpu / steps * 1e6:.2f} µs CPU per step = {steps / cpu:,.0f} steps/s per "
            "core of CPU time"
        )
        if args.workers > 0 and args.cluster_compare:
            cluster_compare(spec, args.workers, Path(tmp))
        elif args.workers > 0:
            try:
                from velfence.apps.engine import Engine
            except ImportError:
                print("engine: not installed (velfence.apps.engine); serial only")
                return
            t0 = time.perf_counter()
            with Engine(workers=args.workers) as engine:
                t1 = time.perf_counter()
                o = verify(spec, Path(tmp) / "engine", report=False, mapper=engine.map)
                t2 = time.perf_counter()
            steps = sum(o.summary.steps.values())
            print(
                f"engine, {args.workers} workers: start-up {t1 - t0:.1f} s, then {steps:,} steps "
                f"in {t2 - t1:.1f} s = {steps / (t2 - t1):,.0f} steps/s (wall; "
                f"{steps / (t2 - t0):,.0f} with the start-up)"
            )
    print(f"after: {load()}")
    print("target: >= 100,000 closed-loop steps/s on 2 cores")


if __name__ == "__main__":
    main()
