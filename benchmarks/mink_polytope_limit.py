"""Per-cycle time of mink's ``solve_ik`` with ``PolytopeLimit`` beside ``SafetyFilter.shape``.

Usage: ``PYTHONPATH=src python benchmarks/mink_polytope_limit.py [--calls N]`` prints a Markdown
table (the one in ``docs/mink.md``, section "Cost").

The problem, shared by every route: the shipped Panda (``velfence.robots.panda()``, 7 joints,
MuJoCo kinematics), its TCP kept in a box of ±0.15 m around the TCP at the pose ``Q0`` (6
facets, 5 cm linear buffer), control period ``dt`` = 10 ms. 500 seeded joint positions near
``Q0`` (uniform ±0.25 rad per joint, so that many TCPs are inside a facet's buffer and some
outside the box) are visited in turn; each call is timed whole after a warm-up of 300 calls; the
routes take turns call by call (a passing load on the machine falls on all of them alike).
Routes:

* ``mink solve_ik + PolytopeLimit``: ``Configuration.update(q)`` then ``solve_ik`` with a
  position+orientation ``FrameTask`` on the TCP toward a target outside the box, a
  ``PostureTask`` (cost 1e-2), ``ConfigurationLimit`` and the ``PolytopeLimit`` (daqp).
* ``mink solve_ik, no PolytopeLimit``: the same without the box (what the limit adds).
* ``PolytopeLimit rows only``: ``compute_qp_inequalities`` alone.
* ``SafetyFilter.shape``: joint mode, ``SafetyFilter(panda, limits=JointLimits(..., 2.5 rad/s),
  workspace=WorkspaceLimit(box, buffer=0.05), dt=0.01).shape(q, qd)`` with a seeded joint
  command of 1 rad/s scale (validation, kinematics, rows, solve, model check, result).
* ``SafetyFilter.filter_twist``: twist mode, a 0.5 m/s TCP twist toward the target.

The two libraries solve different problems (mink: a task QP in ``Δq`` whose limit rows are the
filter's workspace rows; the filter: a minimum-change projection with joint rows and a
discrete-time model check), so the ratios compare the cost of one control cycle of each.
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable
from importlib.metadata import version

import mink
import numpy as np

from velfence.filter import JointLimits, SafetyFilter, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.integrations import PolytopeLimit
from velfence.robots import panda

Q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
DT = 0.01
STATES = 500
WARMUP = 300


def time_routes(routes: list[Callable[[int], object]], calls: int) -> np.ndarray:
    """Wall time [µs] of ``calls`` calls of every route, shape (routes, calls).

    The routes take turns call by call (state ``k`` for every route, then ``k + 1``), so a load
    that comes and goes on the machine falls on all of them alike; the warm-up runs first.
    """
    for k in range(WARMUP):
        for call in routes:
            call(k % STATES)
    out = np.empty((len(routes), calls))
    clock = time.perf_counter
    for k in range(calls):
        for r, call in enumerate(routes):
            t0 = clock()
            call(k % STATES)
            out[r, k] = clock() - t0
    return out * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=3000)
    calls = ap.parse_args().calls

    robot = panda()
    model = robot.model
    p0 = robot.fk(Q0)
    box = ConvexPolytope.box(p0 - 0.15, p0 + 0.15)
    target = p0 + np.array([0.4, 0.1, -0.05])
    rng = np.random.default_rng(0)
    lo, hi = robot.joint_limits.T
    Q = np.clip(Q0 + rng.uniform(-0.25, 0.25, (STATES, 7)), lo + 0.01, hi - 0.01)
    QD = rng.uniform(-1.0, 1.0, (STATES, 7))
    P = np.array([robot.fk(q) for q in Q])
    V = target - P
    V *= 0.5 / np.linalg.norm(V, axis=1, keepdims=True)
    d = box.signed_distances_batch(P).min(axis=1)

    conf = mink.Configuration(model)
    conf.update(Q0)
    rot = conf.get_transform_frame_to_world("tcp", "site").rotation()
    task = mink.FrameTask("tcp", "site", position_cost=1.0, orientation_cost=1.0)
    task.set_target(mink.SE3.from_rotation_and_translation(rot, target))
    posture = mink.PostureTask(model, cost=1e-2)
    posture.set_target(Q0)
    limit = PolytopeLimit(model, box, frame_name="tcp", buffer=0.05, speed=0.5)
    with_box = [mink.ConfigurationLimit(model), limit]
    without = [mink.ConfigurationLimit(model)]
    sf = SafetyFilter(
        robot,
        limits=JointLimits(lo, hi, max_speed=2.5),
        workspace=WorkspaceLimit(box, buffer=0.05),
        dt=DT,
    )

    def solve(limits: list[mink.Limit]) -> Callable[[int], object]:
        def run(k: int) -> object:
            conf.update(Q[k])
            return mink.solve_ik(conf, [task, posture], DT, "daqp", limits=limits, damping=1e-6)

        return run

    def rows(k: int) -> object:
        conf.update(Q[k])
        return limit.compute_qp_inequalities(conf, DT)

    routes: list[tuple[str, Callable[[int], object]]] = [
        ("SafetyFilter.shape (joint mode)", lambda k: sf.shape(Q[k], QD[k])),
        ("SafetyFilter.filter_twist", lambda k: sf.filter_twist(Q[k], V[k])),
        ("mink solve_ik + PolytopeLimit", solve(with_box)),
        ("mink solve_ik, no PolytopeLimit", solve(without)),
        ("PolytopeLimit rows only (with Configuration.update)", rows),
    ]
    measured = time_routes([fn for _, fn in routes], calls)
    times = {name: measured[r] for r, (name, _) in enumerate(routes)}
    ref = float(np.median(measured[0]))
    print(
        f"{calls} calls per route (interleaved) after {WARMUP} warm-up calls; {STATES} states: "
        f"{int(np.sum(d < 0.0))} with the TCP outside the box, "
        f"{int(np.sum((d >= 0.0) & (d < 0.05)))} inside a facet's buffer; "
        f"Python {platform.python_version()}, mink {version('mink')}, daqp {version('daqp')}, "
        f"{platform.machine()}"
    )
    print()
    print("| route | median [µs] | p99 [µs] | median / SafetyFilter.shape |")
    print("|---|---:|---:|---:|")
    for name, t in times.items():
        med = float(np.median(t))
        p99 = float(np.percentile(t, 99))
        print(f"| {name} | {med:.0f} | {p99:.0f} | {med / ref:.2f} |")


if __name__ == "__main__":
    main()
