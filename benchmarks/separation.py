"""Filter cycle time with speed and separation monitoring rows, by number of person capsules.

Usage: ``PYTHONPATH=src python benchmarks/separation.py [--quick]`` prints a Markdown table (the
one in ``docs/benchmarks.md``, "Speed and separation monitoring").

One cycle is ``SeparationRows.update(people)`` followed by ``SafetyFilter.filter(q, u)`` on the
7-joint arm (``DHChain.seven_dof(link_radius=0.06)``, joint limits, ``dt`` = 1 ms, the separation
rows as a provider), with 0, 1, 10 and 50 person capsules placed around the arm (0.4 to 2 m
from its base axis, 0 to 1.7 m high, 0.4 m long, radius 0.1 m, half of them with a measured
velocity), cycling over 64 fixed states (seeded). Beside it, the same filter without the
provider (the compiled cycle when the core is installed). Two ways of calling:

* **back-to-back**: one call after the other;
* **periodic 1 kHz**: sleep one period (1 ms), then one call: the caches are colder, as in a
  real control loop.

Each call is timed on its own with ``time.perf_counter_ns()`` (wall) and
``time.thread_time_ns()`` (the thread's CPU time: the cycle's own cost without the time the
scheduler took the processor away), the garbage collector off; the table gives the median, the
99th percentile and the maximum [µs] and the mean number of separation rows per cycle.
"""

from __future__ import annotations

import argparse
import gc
import time

import numpy as np

from velfence.filter import (
    JointLimits,
    PersonCapsule,
    SafetyFilter,
    SeparationParameters,
    SeparationRows,
)
from velfence.mechanisms.chain import DHChain

DT = 1e-3
STATES = 64
COUNTS = (0, 1, 10, 50)
PARAMS = SeparationParameters(
    reaction_time=0.1,
    stopping_time=0.3,
    max_deceleration=2.0,
    intrusion=0.1,
    human_uncertainty=0.05,
    robot_uncertainty=0.01,
)


def _people(rng: np.random.Generator, count: int) -> list[PersonCapsule]:
    out = []
    for i in range(count):
        r = rng.uniform(0.4, 2.0)
        phi = rng.uniform(-np.pi, np.pi)
        base = np.array([r * np.cos(phi), r * np.sin(phi), rng.uniform(0.0, 1.3)])
        vel = rng.normal(scale=0.8, size=3) if i % 2 == 0 else None
        out.append(
            PersonCapsule(base, b=base + np.array([0.0, 0.0, 0.4]), radius=0.1, velocity=vel)
        )
    return out


def _time(call, states, periodic: bool, calls: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-call wall and thread CPU times [µs] of ``call(state)`` over ``calls`` calls."""
    for s in states[:8]:  # warm-up
        call(s)
    wall = np.empty(calls)
    cpu = np.empty(calls)
    gc.disable()
    try:
        for k in range(calls):
            if periodic:
                time.sleep(DT)
            s = states[k % len(states)]
            c0 = time.thread_time_ns()
            t0 = time.perf_counter_ns()
            call(s)
            wall[k] = (time.perf_counter_ns() - t0) / 1e3
            cpu[k] = (time.thread_time_ns() - c0) / 1e3
    finally:
        gc.enable()
    return wall, cpu


def _row(label: str, how: str, rows: str, wall: np.ndarray, cpu: np.ndarray) -> str:
    w = np.percentile(wall, [50, 99])
    c = np.percentile(cpu, [50, 99])
    return (
        f"| {label} | {how} | {rows} | {w[0]:.0f} | {w[1]:.0f} | {wall.max():.0f} | "
        f"{c[0]:.0f} | {c[1]:.0f} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="200 calls per row instead of 2000")
    args = ap.parse_args()
    calls = 200 if args.quick else 2000
    arm = DHChain.seven_dof(link_radius=0.06)
    lim = np.asarray(arm.joint_limits)
    limits = JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5))
    rng = np.random.default_rng(30)
    q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
    qs = [q0 + rng.normal(scale=0.2, size=7) for _ in range(STATES)]
    us = [rng.normal(scale=0.8, size=7) for _ in range(STATES)]
    plain = SafetyFilter(arm, limits=limits, dt=DT)
    print(f"Filter cycle, 7-joint arm, dt = 1 ms, {calls} calls per row, [µs]\n")
    print("| person capsules | calling | rows | median | p99 | max | CPU median | CPU p99 |")
    print("|---|---|---|---|---|---|---|---|")
    for periodic in (False, True):
        how = "periodic 1 kHz" if periodic else "back-to-back"
        states0 = list(zip(qs, us, strict=True))
        wall, cpu = _time(lambda s: plain.filter(s[0], s[1]), states0, periodic, calls)
        print(_row(f"no provider ({plain.backend})", how, "–", wall, cpu))
        for count in COUNTS:
            rows = SeparationRows(PARAMS, link_radius=arm.link_radius, max_speed=limits.max_speed)
            filt = SafetyFilter(arm, limits=limits, providers=[rows], dt=DT)
            states = [(q, u, _people(rng, count)) for q, u in zip(qs, us, strict=True)]

            def cycle(s, rows=rows, filt=filt) -> None:
                rows.update(s[2])
                filt.filter(s[0], s[1])

            wall, cpu = _time(cycle, states, periodic, calls)
            n_rows = []
            for q, u, people in states:
                rows.update(people)
                res = filt.explain(q, u)
                n_rows.append(sum(s.startswith("separation") for s in res.constraint_names))
            print(_row(str(count), how, f"{np.mean(n_rows):.1f}", wall, cpu))


if __name__ == "__main__":
    main()
