"""One control cycle of configuration control, the cobot tick and the PUMA 560 SR step.

Usage::

    PYTHONPATH=src python benchmarks/bench_cycles.py [--calls N] [--callgrind K] [--before SRC]
        [--single]

prints Markdown tables (the ones in ``docs/benchmarks.md``, section "Control cycles").

Timing. Every route is timed call by call with ``time.perf_counter`` and, beside it, the CPU
time of the thread (``time.thread_time``: a route that is descheduled on a loaded machine is not
charged for the wait); the routes of one table take turns call by call (state ``k`` for every
route, then ``k + 1``), so a load that comes and goes falls on all of them alike; a warm-up of
50 calls per route runs first. Reported: median, p99 and max [µs].

Routes (obstacles 0.12 m beside random points of random links, influence 0.1 m, radius 0.02 m,
16 joint positions scattered by 0.02 rad and 16 random end-effector commands — the scene of
``velfence bench``):

* ``ConfigurationController.shape`` on the 7-DoF (KUKA-sized ``DHChain.seven_dof``) and the
  planar 20R (links 0.1 m), 1 / 5 / 20 / 50 obstacles;
* its former route ``_law_reference`` (per-obstacle kinematics, one stacked lstsq per add/release
  check), the oracle the tests compare against — a same-run "before";
* ``VelocityDamperQP.shape`` (qpsolvers + daqp) on the same chain and obstacles;
* mink's ``solve_ik`` with a position ``FrameTask`` on the tool point (target: the tool point
  moved by the command over 4 ms), ``ConfigurationLimit`` and a ``CollisionAvoidanceLimit``
  between every link capsule and every obstacle sphere (detection distance 0.1 m), on the MJCF
  twin of the chain (``velfence.apps.bench.cases.filter.seven_dof_mjcf``; the 20R as a DH chain
  with ``a = 0.1`` m, ``α = 0``);
* the cobot tick (r-θ cobot: ``heading`` + ``kinematics.position`` + ``PathFollower.evaluate``
  + ``steering_rates``) and the PUMA 560 resolved-rate SR step (``ResolvedRate.step``).

``--callgrind K`` also counts instructions (valgrind's callgrind, deterministic: independent of
the machine's load) of ``K`` calls of the single-cycle routes, minus a run with 0 calls (start-up
and set-up), divided by ``K``; ``--before SRC`` repeats that count with ``PYTHONPATH=SRC`` (e.g.
a checkout of the code before the change) for a before/after in instructions. ``--single``
skips the configuration-control table (and mink): the single-cycle routes only, ``4 * calls``
calls each.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

WARMUP = 50
COUNTS = (1, 5, 20, 50)
MINK_DT = 0.004


def scene(chain: Any, q0: np.ndarray, n_obs: int, seed: int) -> tuple[list[Any], list[Any]]:
    """Obstacles beside the links at ``q0`` and a pool of 16 (q, command) states."""
    from velfence.filter import SphereObstacle

    rng = np.random.default_rng(seed)
    segs = chain.link_segments(q0)
    obstacles = []
    for _ in range(n_obs):
        link = int(rng.integers(chain.n_links))
        a, b = segs[link]
        on_link = a + rng.uniform(0.2, 0.8) * (b - a)
        side = rng.normal(size=3)
        if chain.task_dim == 2:
            side[2] = 0.0
        side /= np.linalg.norm(side)
        obstacles.append(SphereObstacle(center=on_link + 0.12 * side, radius=0.02, influence=0.1))
    pool = [
        (q0 + rng.normal(scale=0.02, size=q0.shape), rng.normal(size=chain.task_dim) * 0.2)
        for _ in range(16)
    ]
    return obstacles, pool


def arms() -> list[tuple[str, Any, Any, np.ndarray]]:
    """(name, chain, its DH twin for MuJoCo, q0)."""
    from velfence.mechanisms.chain import DHChain, PlanarArm

    seven = DHChain.seven_dof()
    planar = PlanarArm([0.1] * 20)
    twin = DHChain([[0.1, 0.0, 0.0, 0.0]] * 20)
    return [
        ("7-DoF", seven, seven, np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0])),
        ("planar 20R", planar, twin, np.full(20, 0.12)),
    ]


class MinkRoute:
    """mink's solve_ik with link-obstacle collision avoidance, one call per cycle."""

    def __init__(self, twin: Any, obstacles: list[Any], planar: bool) -> None:
        import mink
        import mujoco

        from velfence.apps.bench.cases.filter import seven_dof_mjcf

        self.mink = mink
        self.planar = planar
        self.model = mujoco.MjModel.from_xml_string(seven_dof_mjcf(twin, obstacles))
        self.config = mink.Configuration(self.model)
        self.limits: list[Any] = [mink.ConfigurationLimit(self.model)]
        if obstacles:
            self.limits.append(
                mink.CollisionAvoidanceLimit(
                    self.model,
                    geom_pairs=[
                        (
                            [f"link{k}" for k in range(twin.n_links)],
                            [f"obstacle{i}" for i in range(len(obstacles))],
                        )
                    ],
                    minimum_distance_from_collisions=0.0,
                    collision_detection_distance=0.1,
                )
            )
        self.task = mink.FrameTask("tcp", "site", position_cost=1.0, orientation_cost=0.0)

    def __call__(self, q: np.ndarray, v: np.ndarray) -> Any:
        mink = self.mink
        self.config.update(q)
        T = self.config.get_transform_frame_to_world("tcp", "site")
        v3 = np.append(v, 0.0) if self.planar else v
        self.task.set_target(
            mink.SE3.from_rotation_and_translation(T.rotation(), T.translation() + v3 * MINK_DT)
        )
        return mink.solve_ik(
            self.config, [self.task], MINK_DT, "daqp", damping=1e-6, limits=self.limits
        )


def time_routes(routes: list[Callable[[int], object]], calls: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall and thread-CPU time [µs] of ``calls`` interleaved calls, each shape (routes, calls)."""
    for k in range(WARMUP):
        for call in routes:
            call(k % 16)
    wall = np.empty((len(routes), calls))
    cpu = np.empty((len(routes), calls))
    clock, tclock = time.perf_counter, time.thread_time
    for k in range(calls):
        for r, call in enumerate(routes):
            c0 = tclock()
            t0 = clock()
            call(k % 16)
            t1 = clock()
            cpu[r, k] = tclock() - c0
            wall[r, k] = t1 - t0
    return wall * 1e6, cpu * 1e6


def _stats(t: np.ndarray) -> str:
    return f"{np.median(t):.0f} | {np.percentile(t, 99):.0f} | {t.max():.0f}"


def control_cycles(calls: int, with_mink: bool) -> None:
    """The configuration-control table (one row per arm, obstacle count and route)."""
    from velfence.redundancy import ConfigurationController, VelocityDamperQP

    print("| arm | obstacles | route | active rows (mean) | wall median | p99 | max | "
          "CPU median | p99 | max |")  # fmt: skip
    print("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for name, chain, twin, q0 in arms():
        for n_obs in COUNTS:
            obstacles, pool = scene(chain, q0, n_obs, seed=n_obs)
            cc = ConfigurationController(chain, obstacles)
            cpy = ConfigurationController(chain, obstacles, backend="python")
            qp = VelocityDamperQP(chain, obstacles)
            active = float(np.mean([len(cc.explain(q, v).active) for q, v in pool]))
            P = [(np.asarray(q), np.asarray(v)) for q, v in pool]

            def ref(k: int, cc: Any = cc, P: Any = P) -> object:
                with np.errstate(all="ignore"):
                    return cc._law_reference(P[k][0], P[k][1], None)

            routes: list[tuple[str, Callable[[int], object]]] = [
                (
                    f"ConfigurationController.shape (backend {cc.backend})",
                    lambda k, cc=cc, P=P: cc.shape(*P[k]),
                ),
                (
                    "ConfigurationController.shape (backend python)",
                    lambda k, c=cpy, P=P: c.shape(*P[k]),
                ),
                ("former route (_law_reference)", ref),
                ("VelocityDamperQP.shape (daqp)", lambda k, qp=qp, P=P: qp.shape(*P[k])),
            ]
            if with_mink:
                mk = MinkRoute(twin, obstacles, planar=chain.task_dim == 2)
                routes.append(("mink solve_ik + CollisionAvoidanceLimit",
                               lambda k, mk=mk, P=P: mk(*P[k])))  # fmt: skip
            n_calls = calls if n_obs < 50 else max(calls // 4, 100)
            wall, cpu = time_routes([fn for _, fn in routes], n_calls)
            for r, (route, _) in enumerate(routes):
                print(f"| {name} | {n_obs} | {route} | {active:.1f} | {_stats(wall[r])} | "
                      f"{_stats(cpu[r])} |")  # fmt: skip
            sys.stdout.flush()


def _single_routes() -> dict[str, Callable[[int], object]]:
    """The single-cycle routes (public API only, so that ``--before`` can run them too)."""
    from velfence.apps.teleop.resolved_rate import ResolvedRate
    from velfence.cobot import PathFollower, r_theta_cobot
    from velfence.geometry.paths import Circle
    from velfence.mechanisms.puma560 import Puma560
    from velfence.redundancy import ConfigurationController

    rng = np.random.default_rng(3)
    cob = r_theta_cobot()
    follower = PathFollower(Circle([0.0, 0.0], radius=1.0), gains=(4.0, 4.0))
    states = []
    for _ in range(16):
        ang = rng.uniform(0, 2 * math.pi)
        R = (1.0 + rng.uniform(-0.2, 0.2)) * np.array([math.cos(ang), math.sin(ang)])
        h = rng.uniform(0, 2 * math.pi)
        T = np.array([math.cos(h), math.sin(h)])
        states.append((cob.kinematics.joints(R), cob.steering_angles(R, T)))
    ones = np.ones(2)

    def tick(k: int) -> object:
        q, phi = states[k]
        hd = cob.heading(q, phi, reference=ones)
        R = cob.kinematics.position(q)
        out = follower.evaluate(R, hd.T, s_p=0.3, sp_d=1.0)
        return cob.steering_rates(R, phi, hd.T, out.kN, 1.0)

    robot = Puma560()
    sr = ResolvedRate(robot, inverse="sr")
    q_reg = np.array([-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345])
    prng = np.random.default_rng(4)
    ppool = [
        (q_reg + prng.normal(scale=0.01, size=6), prng.normal(size=6) * 0.1) for _ in range(16)
    ]
    routes: dict[str, Callable[[int], object]] = {
        "cobot tick (heading + follower + steering)": tick,
        "PUMA 560 SR step (ResolvedRate.step)": lambda k: sr.step(*ppool[k]),
    }
    for name, chain, _, q0 in arms():
        for n_obs in (1, 20):
            obstacles, pool = scene(chain, q0, n_obs, seed=n_obs)
            cc = ConfigurationController(chain, obstacles)
            routes[f"configuration control, {name}, {n_obs} obstacles"] = (
                lambda k, cc=cc, pool=pool: cc.shape(*pool[k])
            )
    return routes


def single_cycles(calls: int) -> None:
    """The cobot tick and the PUMA SR step (wall and CPU time)."""
    routes = _single_routes()
    keep = [n for n in routes if not n.startswith("configuration")]
    wall, cpu = time_routes([routes[n] for n in keep], calls)
    print("| route | wall median | p99 | max | CPU median | p99 | max |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r, name in enumerate(keep):
        print(f"| {name} | {_stats(wall[r])} | {_stats(cpu[r])} |")


def _child(route: str, n: int) -> None:
    """Run ``n`` calls of one route (under valgrind), after one warm-up call."""
    fn = _single_routes()[route]
    fn(0)
    for k in range(n):
        fn(k % 16)


def _instructions(route: str, n: int, src: str) -> int:
    """Instructions callgrind counts for the child running ``n`` calls of ``route``."""
    env = dict(os.environ, PYTHONPATH=src)
    with tempfile.TemporaryDirectory() as tmp:
        out = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.out",
             sys.executable, __file__, "--child", route, "--child-calls", str(n)],
            env=env, capture_output=True, text=True, check=True,
        )  # fmt: skip
    m = re.search(r"Collected : (\d+)", out.stderr)
    if m is None:
        raise RuntimeError(f"callgrind gave no count: {out.stderr[-500:]}")
    return int(m.group(1))


def callgrind(k: int, sources: list[tuple[str, str]]) -> None:
    """Instructions per call of the single-cycle routes, for each source tree."""
    names = list(_single_routes())
    head = " | ".join(f"{label} [instructions/call]" for label, _ in sources)
    print(f"| route | {head} |")
    print("|---|" + "---:|" * len(sources))
    for name in names:
        cells = []
        for _, src in sources:
            base = _instructions(name, 0, src)
            full = _instructions(name, k, src)
            cells.append(f"{(full - base) / k:,.0f}")
        print(f"| {name} | {' | '.join(cells)} |")
        sys.stdout.flush()


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--calls", type=int, default=1000)
    ap.add_argument("--callgrind", type=int, default=0, metavar="K")
    ap.add_argument("--before", default="", metavar="SRC")
    ap.add_argument("--no-mink", action="store_true")
    ap.add_argument(
        "--single",
        action="store_true",
        help="only the single-cycle table (cobot tick, PUMA SR step) and --callgrind",
    )
    ap.add_argument("--child", default="", help=argparse.SUPPRESS)
    ap.add_argument("--child-calls", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.child, args.child_calls)
        return
    from importlib.metadata import version

    with_mink = not args.no_mink and not args.single
    print(
        f"{args.calls} calls per route (interleaved, {WARMUP} warm-up calls), times in µs; "
        f"Python {platform.python_version()}, numpy {np.__version__}"
        + (f", mink {version('mink')}, daqp {version('daqp')}" if with_mink else "")
        + f", {platform.machine()}, {os.cpu_count()} CPUs, load average "
        f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} at the start"
    )
    print()
    if not args.single:
        control_cycles(args.calls, with_mink)
        print()
    single_cycles(args.calls * 4)
    if args.callgrind:
        print()
        here = os.environ.get("PYTHONPATH", "src")
        sources = [("this tree", here)]
        if args.before:
            sources.insert(0, ("before", args.before))
        callgrind(args.callgrind, sources)
    print()
    print(f"load average at the end: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
