"""Wall time of one ``LeRobotShield.shield`` call on the SO-101 (the table of docs/lerobot.md).

Usage: ``PYTHONPATH=src python benchmarks/lerobot_shield.py [--calls N] [--hz F]`` prints a
Markdown table.

The case: ``so_arm()`` (example-robot-data's SO-101 URDF), degrees, ``dt`` = 1/30 s, 90 deg/s on
every joint, a table plane at z = 0, a box of 0.32 × 0.5 × 0.35 m, a 2 cm gripper sphere and one
obstacle sphere of 3 cm at (0.25, 0, 0.30). The states come from a closed loop of the shield on
a perfect servo (the next measured position is the sent target) chasing seeded random goals, so
the gripper rests on the box faces, the links against the obstacle and the joints at their
speed limits for part of the run (the shares of calls with active rows are printed). Each call
takes LeRobot's two dictionaries and returns the safe one; the whole call is timed.

* back-to-back: the ``N`` calls one after another (the warm caches of a tight loop);
* periodic: sleep one period of ``1 / F`` s, then one call (a control loop at ``F`` Hz, whose
  caches go cold between calls), ``N / 10`` calls.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from velfence.filter import SphereObstacle
from velfence.integrations.lerobot import ARM_JOINTS, JOINTS, LeRobotShield, so_arm

WARMUP = 300


def make_shield() -> LeRobotShield:
    """The benchmark's shield (module docstring)."""
    return LeRobotShield(
        so_arm(),
        dt=1.0 / 30.0,
        max_speed=dict.fromkeys(JOINTS, 90.0),
        table_height=0.0,
        workspace=((0.10, -0.25, 0.0), (0.42, 0.25, 0.35)),
        tool_radius=0.02,
        obstacles=[SphereObstacle([0.25, 0.0, 0.30], radius=0.03)],
    )


def states(sh: LeRobotShield, n: int, seed: int = 0) -> tuple[list[dict[str, float]], ...]:
    """``n`` (action, observation) pairs from a closed loop, and the share with active rows."""
    rng = np.random.default_rng(seed)
    q = [0.0, -20.0, 20.0, 60.0, 0.0, 50.0]
    acts, obs = [], []
    active = 0
    goal: list[float] = []
    for k in range(n):
        if k % 15 == 0:
            goal = [*(rng.uniform(-90, 90, 5) + np.array([0, 30, -20, 30, 0])), 50.0]
        a = {f"{j}.pos": float(v) for j, v in zip(JOINTS, goal, strict=True)}
        o = {f"{j}.pos": float(v) for j, v in zip(JOINTS, q, strict=True)}
        r = sh.explain(observation=o, action=a)
        assert r.filter_result is not None
        active += r.filter_result.zone != "free"
        acts.append(a)
        obs.append(o)
        q = [r.action[f"{j}.pos"] for j in (*ARM_JOINTS, "gripper")]
    sh.reset()
    return acts, obs, [{"active": active / n}]


def _row(name: str, t: np.ndarray) -> str:
    us = t * 1e6
    med, p99, mx = np.median(us), np.percentile(us, 99), us.max()
    return f"| {name} | {len(us)} | {med:.1f} | {p99:.1f} | {mx:.1f} |"


def main() -> None:
    """Time the calls and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000, help="back-to-back calls")
    ap.add_argument("--hz", type=float, default=200.0, help="rate of the periodic loop [Hz]")
    args = ap.parse_args()
    sh = make_shield()
    acts, obs, info = states(sh, 600)
    m = len(acts)
    shield = sh.shield
    clock = time.perf_counter
    for i in range(WARMUP):
        shield(observation=obs[i % m], action=acts[i % m])
    t = np.empty(args.calls)
    for i in range(args.calls):
        a, o = acts[i % m], obs[i % m]
        t0 = clock()
        shield(observation=o, action=a)
        t[i] = clock() - t0
    n_per = max(1, args.calls // 10)
    tp = np.empty(n_per)
    period = 1.0 / args.hz
    for i in range(n_per):
        a, o = acts[i % m], obs[i % m]
        time.sleep(period)
        t0 = clock()
        shield(observation=o, action=a)
        tp[i] = clock() - t0
    print(f"states with active rows: {info[0]['active']:.0%} of {m}")
    print("| loop | calls | median [µs] | p99 [µs] | max [µs] |")
    print("| --- | ---: | ---: | ---: | ---: |")
    print(_row("back-to-back", t))
    print(_row(f"periodic ({args.hz:g} Hz: sleep, then one call)", tp))


if __name__ == "__main__":
    main()
