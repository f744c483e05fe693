"""Closed-loop steps per second of a ``velfence verify`` campaign, and where the time goes.

The campaign: the 7-joint arm (``DHChain.seven_dof``, 5 cm capsule links, 5 cm tool), a workspace
box and 5 spheres per case, 1 kHz, joint-velocity commands (the filter's whole cycle in C,
``SafetyFilter.cycle_in_c``), the soak's wandering operator, a kinematic plant. It runs once
serially in this process, then, with ``--workers N`` (N > 0) and the engine installed, through the
engine on N workers. The breakdown times the filter's cycle alone (``SafetyFilter.filter``) on the
states of one case beside the whole closed-loop step (operator, cycle, plant, margins).

Run: ``python benchmarks/verify.py [--cases 8] [--steps 2000] [--workers 2]``; prints one line per
measurement (docs/verify.md gives the numbers with the load they were measured under).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
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


def main() -> None:
    """Run the measurements and print them."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cases", type=int, default=8)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--workers", type=int, default=2, help="engine workers (0: serial only)")
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
        if args.workers > 0:
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
