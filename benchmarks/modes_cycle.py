"""Safety modes: one filter cycle with ``ModeRows`` and 0, 1 or 5 mode zones.

Usage: ``PYTHONPATH=src python benchmarks/modes_cycle.py [--quick]`` prints a Markdown table (the
one in ``docs/modes.md``, "Cost").

The 7-joint arm (``DHChain.seven_dof(link_radius=0.04)``), ``dt`` = 4 ms, joint limits with
``max_speed`` 1.5 rad/s; ``ModeRows`` watching the TCP and the elbow with reduced-mode caps on
both (``joint_scale`` 0.3, TCP 0.25 m/s, elbow 0.5 m/s) and 0, 1 or 5 box zones, one of which
holds the TCP (so the cycle runs in reduced mode with its 7 joint caps and 2 x 26 direction
rows); with 0 zones the mode stays normal, which caps nothing (no rows). For reference, the
same filter without the provider, which runs the compiled C cycle (a custom provider keeps the
cycle on the Python route). Each cycle is ``modes.update(q, time=t)`` then
``SafetyFilter.filter(q, u)`` (the Python route: a custom provider keeps the cycle out of C),
timed with ``time.perf_counter_ns()`` on its own, the garbage collector off, in two ways:

* **back to back**: the cycles one after the other;
* **periodic**: one cycle every ``dt`` (the loop sleeps until the next period's start), as in a
  control loop; a cycle that starts more than a period late is counted and the schedule
  starts again from it.

The table gives the median, the 99th percentile and the maximum [ms] of the wall time, and the
median and 99th percentile of the thread's CPU time (``time.thread_time_ns()``: the cycle's own
cost, without the time other processes took the core).
"""

from __future__ import annotations

import argparse
import gc
import time
from typing import Any

import numpy as np

from velfence.filter import JointLimits, ModeLimits, ModeRows, ModeZone, SafetyFilter
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

DT = 0.004
ARM = DHChain.seven_dof(link_radius=0.04)
LO = np.radians([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0])
Q0 = np.array([0.0, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])


def _zones(count: int) -> list[ModeZone]:
    tcp = ARM.fk(Q0)
    out = [ModeZone(ConvexPolytope.box(tcp - 0.3, tcp + 0.3), name="around the tool")]
    for k in range(1, count):
        c = np.array([-1.0, -1.0 + 0.5 * k, 0.5])
        out.append(ModeZone(ConvexPolytope.box(c - 0.2, c + 0.2), mode="stop", name=f"z{k}"))
    return out[:count]


def _filter(count: int | None) -> tuple[SafetyFilter, ModeRows | None]:
    limits = JointLimits(LO, -LO, max_speed=np.full(7, 1.5))
    if count is None:
        return SafetyFilter(ARM, limits=limits, dt=DT), None
    modes = ModeRows(
        ARM,
        modes={"reduced": ModeLimits(joint_scale=0.3, point_speeds={"tcp": 0.25, "elbow": 0.5})},
        zones=_zones(count),
        points=["tcp", "elbow"],
        max_speed=limits.max_speed,
    )
    return SafetyFilter(ARM, limits=limits, dt=DT, providers=[modes]), modes


def _run(count: int | None, cycles: int, periodic: bool) -> tuple[np.ndarray, np.ndarray, int]:
    f, modes = _filter(count)
    rng = np.random.default_rng(3)
    U = rng.normal(scale=0.8, size=(cycles + 5, 7))
    q = Q0.copy()

    def cycle(k: int) -> Any:
        if modes is not None:
            modes.update(q, time=k * DT)
        return f.filter(q, U[k])

    for k in range(5):
        cycle(k)
    wall = np.empty(cycles)
    cpu = np.empty(cycles)
    late = 0
    gc.disable()
    try:
        start = time.perf_counter_ns()
        for k in range(cycles):
            if periodic:
                due = start + k * int(DT * 1e9)
                now = time.perf_counter_ns()
                if now < due:
                    time.sleep((due - now) / 1e9)
                elif now - due > int(DT * 1e9):  # a period missed: count it, start again from now
                    late += 1
                    start = now - k * int(DT * 1e9)
            c0 = time.thread_time_ns()
            t0 = time.perf_counter_ns()
            cycle(k + 5)
            wall[k] = (time.perf_counter_ns() - t0) / 1e6
            cpu[k] = (time.thread_time_ns() - c0) / 1e6
    finally:
        gc.enable()
    return wall, cpu, late


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="500 cycles instead of 3000")
    args = ap.parse_args()
    cycles = 500 if args.quick else 3000
    print("| provider | loop | median [ms] | p99 [ms] | max [ms] | CPU median | CPU p99 | late |")
    print("|---|---|---|---|---|---|---|---|")
    for count in (None, 0, 1, 5):
        label = "no provider (C cycle)" if count is None else f"ModeRows, {count} zones"
        for periodic in (False, True):
            wall, cpu, late = _run(count, cycles, periodic)
            loop = "periodic 250 Hz" if periodic else "back to back"
            med, p99 = np.percentile(wall, [50, 99])
            cmed, cp99 = np.percentile(cpu, [50, 99])
            print(
                f"| {label} | {loop} | {med:.3f} | {p99:.3f} | {wall.max():.3f} | {cmed:.3f} | "
                f"{cp99:.3f} | {late if periodic else '—'} |"
            )


if __name__ == "__main__":
    main()
