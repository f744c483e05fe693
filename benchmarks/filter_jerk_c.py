"""What the jerk rows cost in the safety filter's C cycle: the Panda, a TCP box, 20 spheres.

Usage: ``PYTHONPATH=src python benchmarks/filter_jerk_c.py [--cycles N] [--seed S]`` prints a
Markdown table with the load average before and after.

Scene: :func:`velfence.robots.panda` (capsule links of 5 cm; the C cycle runs it through its chain
frames) with Franka's published Panda limits (:meth:`MujocoRobot.limits`: joint ranges, speeds,
accelerations, jerks), a 0.3 m box around the TCP, 20 spheres of 3 cm placed 2-12 cm from the links
of the start pose, ``dt`` = 1 ms, started at rest (``reset(velocity=0)``). A closed loop integrates
``q += x dt`` toward random joint targets (a new one every 0.5 s, gain 1/s, so the box, the spheres
and the rate rows bind now and then). The same loop runs twice, with ``max_jerk`` and without it
(the acceleration rows kept); each cycle is timed around the public call ``SafetyFilter.filter``
(the C cycle and its Python binding; the binding's overhead is common to both columns; every 97th
cycle runs ``explain`` instead, untimed, to count rows). Reported: median, p99 and max per cycle
[µs], the rows per cycle, the cycles whose jerk rows gave way, and the largest jerk of the outputs
over the limit (from the outputs alone).
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np


def _scene(jerk: bool, seed: int) -> tuple[Any, Any]:
    from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
    from velfence.geometry.polytope import ConvexPolytope
    from velfence.robots import panda

    robot = panda(radius=0.05)
    q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
    pub = robot.limits()
    limits = JointLimits(
        pub.lower, pub.upper, max_speed=pub.max_speed, max_acceleration=pub.max_acceleration,
        max_jerk=pub.max_jerk if jerk else None, names=pub.names,
    )  # fmt: skip
    tcp = robot.fk(q0)
    rng = np.random.default_rng(seed)
    pts = np.array([robot.fk(q0, f"joint{k}") for k in range(7)])
    box = WorkspaceLimit(ConvexPolytope.box(tcp - 0.15, tcp + 0.15), point="tcp")
    spheres: list[Any] = []
    while True:
        while len(spheres) < 20:
            k = int(rng.integers(1, 7))
            p = pts[k - 1] + rng.uniform() * (pts[k] - pts[k - 1])
            d = rng.normal(size=3)
            d /= np.linalg.norm(d)
            gap = 0.05 + 0.03 + rng.uniform(0.02, 0.12)
            spheres.append(SphereObstacle(p + d * gap, radius=0.03))
        sf = SafetyFilter(robot, limits=limits, dt=1e-3, obstacles=spheres, workspace=box)
        # a sphere that some link already touches (at zero command its row binds) is drawn again
        r = sf.explain(q0, np.zeros(7))
        touched = {int(n.split()[1]) for n in r.active_names if n.startswith("obstacle")}
        if not touched:
            break
        spheres = [s for i, s in enumerate(spheres) if i not in touched]
    return sf, q0


def _loop(jerk: bool, cycles: int, seed: int) -> dict[str, float]:
    sf, q = _scene(jerk, seed)
    rng = np.random.default_rng(seed + 1)
    lo, hi = sf.limits.lower, sf.limits.upper
    sf.reset(velocity=np.zeros(7))
    times = []
    xs = np.zeros((cycles + 2, 7))
    rows = []
    target = q.copy()
    for k in range(cycles):
        if k % 500 == 0:
            target = lo + (hi - lo) * rng.uniform(0.2, 0.8, 7)
        u = 1.0 * (target - q)
        if k % 97 == 0:  # a sample of the rows (explain: the same cycle, not timed)
            r = sf.explain(q, u)
            rows.append(len(r.constraint_names))
            x = r.output
        else:
            t0 = time.perf_counter()
            x = sf.filter(q, u)
            times.append(time.perf_counter() - t0)
        xs[k + 2] = x
        q = q + x * 1e-3
    jmax = sf.limits.max_jerk if sf.limits.max_jerk is not None else np.full(7, np.inf)
    jerk_out = np.abs(np.diff(xs, 2, axis=0)) / 1e-6 / jmax
    us = np.array(times) * 1e6
    return {
        "median": float(np.median(us)),
        "p99": float(np.percentile(us, 99)),
        "max": float(us.max()),
        "rows": float(np.mean(rows)),
        "overrides": float(sf.jerk_overrides),
        "jerk": float(jerk_out.max()) if jerk else float("nan"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=20_000)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    res = {name: _loop(name == "with jerk rows", args.cycles, args.seed)
           for name in ("without jerk rows", "with jerk rows")}  # fmt: skip
    load1 = os.getloadavg()[0]
    print(f"{args.cycles} cycles each; load average {load0:.2f} before, {load1:.2f} after\n")
    print("| C cycle (Panda, box, 20 spheres, 1 ms) | median [µs] | p99 [µs] | max [µs] "
          "| rows per cycle | jerk overrides | max jerk / limit |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    for name, r in res.items():
        jerk = "—" if np.isnan(r["jerk"]) else f"{r['jerk']:.3f}"
        print(
            f"| {name} | {r['median']:.1f} | {r['p99']:.1f} | {r['max']:.1f} | {r['rows']:.1f} "
            f"| {int(r['overrides'])} | {jerk} |"
        )


if __name__ == "__main__":
    main()
