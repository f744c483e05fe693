"""The n-D exact law and the safety filter: Python, numba and the C core, beside daqp and mink.

Usage::

    PYTHONPATH=src python benchmarks/bench_nd.py [--rounds R] [--quick] [--no-mink] [--no-cost]

prints Markdown tables (the ones in ``docs/core.md``, section "The n-D law and the safety
filter"). Everything is measured in ONE run, the routes of a table interleaved: every round times
each route once over the same seeded states (one ``perf_counter_ns`` pair per call), so a passing
load on this shared machine falls on all of them alike. Columns: median, p99 and max in µs.

1. ``PolytopeShaper.shape`` on a 3-D box (6 facets, buffer 0.2) and on a 20-facet polytope in
   3-D (random unit normals, the origin 0.6–1.5 inside every facet, buffer 0.2), 256 states
   (positions uniform in ±1.2 per axis, so some outside and many in the buffer; standard normal
   commands): ``backend="python"`` without numba, ``backend="python"`` with numba (compiled and
   warm), ``backend="c"``; and the law's own rows (``bound_rows``, prebuilt) solved as the QP
   ``min ½‖x − v‖² s.t. G x >= b`` by ``qpsolvers.solve_qp(..., solver="daqp")`` and by
   ``daqp.solve`` on prebuilt matrices.
2. ``SafetyFilter.filter``: the 7-joint ``DHChain.seven_dof`` (capsule radius 0.06 m), its joint
   position limits, 1.5 rad/s, 10 rad/s² (three-zone braking at the limits), a 6-facet TCP box
   (``velfence.apps.bench.cases.filter.scenario``), 0 / 5 / 20 sphere obstacles (seeded, 4–50 cm
   from
   the links at the nominal pose, obstacle buffer 0.1 m), 200 states (nominal pose scattered by
   0.05 rad, commands 0.5 rad/s standard normal): the C backend in continuous time and with
   ``dt`` = 4 ms, the Python backend (numba) in continuous time; beside mink's ``solve_ik`` (daqp)
   on the MJCF model of the same arm (``seven_dof_mjcf``) with ``ConfigurationLimit``,
   ``VelocityLimit``, ``CollisionAvoidanceLimit`` over every link × obstacle pair (detection
   distance 0.1 m) and velfence's ``PolytopeLimit`` for the same TCP box, a posture task on
   ``q + u dt``, ``dt`` = 4 ms. mink solves a different (discrete-time, task-QP) problem with the
   same limits, so only its time is compared.
3. (``--no-cost`` skips it) what numba costs for the n-D paths: a fresh process with an empty
   numba cache compiles ``compiled_polytope`` (first call; the filter's numba solve is gone), and
   the resident-set growth of ``import numba`` against ``import velfence_core._nd``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import PolytopeShaper
from velfence.shaping.backend import compiled_nd

Route = tuple[str, Callable[[int], object]]


def time_routes(routes: Sequence[Route], n_states: int, rounds: int) -> dict[str, np.ndarray]:
    """Interleaved timing: each round runs every route once over all states (µs per call)."""
    clock = time.perf_counter_ns
    samples: dict[str, list[int]] = {name: [] for name, _ in routes}
    for _, fn in routes:  # warm-up
        for k in range(n_states):
            fn(k)
    for _ in range(rounds):
        for name, fn in routes:
            out = samples[name]
            for k in range(n_states):
                t0 = clock()
                fn(k)
                out.append(clock() - t0)
    return {name: np.array(v, dtype=float) / 1e3 for name, v in samples.items()}


def table(title: str, res: dict[str, np.ndarray], ref: str | None = None) -> str:
    lines = [f"**{title}**", "", "| route | median µs | p99 µs | max µs | median / C |"]
    lines.append("| --- | ---: | ---: | ---: | ---: |")
    base = float(np.median(res[ref])) if ref is not None and ref in res else None
    for name, t in res.items():
        med = float(np.median(t))
        ratio = f"{med / base:.1f}×" if base else ""
        lines.append(
            f"| {name} | {med:.2f} | {np.percentile(t, 99):.2f} | {t.max():.1f} | {ratio} |"
        )
    return "\n".join(lines)


# ---------------------------------------------------------------------------- 1. the shaper
def polytope20() -> ConvexPolytope:
    rng = np.random.default_rng(20)
    N = rng.normal(size=(20, 3))
    N /= np.linalg.norm(N, axis=1)[:, None]
    return ConvexPolytope(N, -rng.uniform(0.6, 1.5, 20))


def shaper_routes(poly: ConvexPolytope, n_states: int) -> list[Route]:
    import daqp
    import qpsolvers

    rng = np.random.default_rng(1)
    P = rng.uniform(-1.2, 1.2, (n_states, 3))
    V = rng.normal(size=(n_states, 3))
    py = PolytopeShaper(poly, buffer=0.2, backend="python", accelerate=False)
    nb = PolytopeShaper(poly, buffer=0.2, backend="python", accelerate=True)
    routes: list[Route] = [
        ("Python kernels", lambda k: py.shape(P[k], V[k])),
        ("numba kernels", lambda k: nb.shape(P[k], V[k])),
    ]
    if compiled_nd() is not None:
        c = PolytopeShaper(poly, buffer=0.2, backend="c")
        routes.append(('**C core** (`backend="c"`)', lambda k: c.shape(P[k], V[k])))
    rows = [py.bound_rows(P[k], V[k]) for k in range(n_states)]
    eye = np.eye(3)
    qp = [(-rows[k][0], -rows[k][1]) for k in range(n_states)]

    def solve_qp(k: int) -> object:
        G, h = qp[k]
        if G.shape[0] == 0:
            return V[k]
        return qpsolvers.solve_qp(eye, -V[k], G, h, solver="daqp")

    inf = np.full(3, np.inf)
    pre = []
    for k in range(n_states):
        A, b = rows[k][0], rows[k][1]
        m = A.shape[0]
        pre.append(
            (
                np.ascontiguousarray(A, dtype=float),
                np.concatenate((inf, np.full(m, np.inf))),
                np.concatenate((-inf, b)),
                np.zeros(3 + m, dtype=np.intc),
            )
        )

    def solve_daqp(k: int) -> object:
        A, bu, bl, sense = pre[k]
        return daqp.solve(eye, -V[k], A, bu, bl, sense)

    routes.append(("qpsolvers + daqp (same rows)", solve_qp))
    routes.append(("`daqp.solve` (same rows, prebuilt)", solve_daqp))
    return routes


# ---------------------------------------------------------------------------- 2. the filter
def obstacles(sc: Any, k: int, seed: int = 3) -> tuple[Any, ...]:
    """``k`` spheres 4–50 cm from the links at ``sc.q0`` (at least 3.5 cm from every link)."""
    from velfence.filter import SphereObstacle

    rng = np.random.default_rng(seed)
    segs = np.asarray(sc.arm.link_segments(sc.q0), dtype=float)
    A, B = segs[:, 0], segs[:, 1]
    out: list[Any] = []
    while len(out) < k:
        link = int(rng.integers(0, len(segs)))
        a, b = segs[link]
        if np.linalg.norm(b - a) < 1e-6:
            continue
        d = rng.normal(size=3)
        d -= d @ (b - a) / ((b - a) @ (b - a)) * (b - a)
        d /= np.linalg.norm(d)
        r = float(rng.uniform(0.03, 0.08))
        c = a + rng.uniform(0.1, 0.9) * (b - a) + (0.06 + r + rng.uniform(0.04, 0.5)) * d
        dd = np.maximum(((B - A) ** 2).sum(1), 1e-12)
        s = np.clip(((c - A) * (B - A)).sum(1) / dd, 0.0, 1.0)
        if np.linalg.norm(c - (A + s[:, None] * (B - A)), axis=1).min() - 0.06 - r >= 0.035:
            out.append(SphereObstacle(center=c, radius=r, name=f"sphere {len(out)}"))
    return tuple(out)


def filter_routes(k: int, n_states: int, with_mink: bool) -> list[Route]:
    from velfence.apps.bench.cases.filter import MINK_DT, Scenario, scenario, seven_dof_mjcf
    from velfence.filter import SafetyFilter

    base = scenario()
    sc = Scenario(base.arm, base.limits, base.workspace, obstacles(base, k), base.q0)
    rng = np.random.default_rng(1)
    Q = [sc.q0 + rng.normal(scale=0.05, size=7) for _ in range(n_states)]
    U = [rng.normal(size=7) * 0.5 for _ in range(n_states)]

    def make(**kw: Any) -> Any:
        return SafetyFilter(
            sc.arm, limits=sc.limits, workspace=sc.workspace, obstacles=sc.obstacles,
            obstacle_buffer=0.1, **kw,
        )  # fmt: skip

    routes: list[Route] = []
    if compiled_nd() is not None:
        fc = make(backend="c")
        fd = make(backend="c", dt=MINK_DT)
        routes.append(("**C backend**, continuous time", lambda i: fc.filter(Q[i], U[i])))
        routes.append(("C backend, dt = 4 ms", lambda i: fd.filter(Q[i], U[i], previous=U[i])))
    fp = make(backend="python")
    routes.append(("Python backend (numba), continuous time", lambda i: fp.filter(Q[i], U[i])))
    if with_mink:
        import mink
        import mujoco

        from velfence.integrations import PolytopeLimit

        model = mujoco.MjModel.from_xml_string(seven_dof_mjcf(sc.arm, sc.obstacles))
        conf = mink.Configuration(model)
        vmax = {n: float(v) for n, v in zip(sc.arm.joint_names, sc.limits.max_speed, strict=True)}
        limits: list[Any] = [
            mink.ConfigurationLimit(model),
            mink.VelocityLimit(model, vmax),
            PolytopeLimit(model, sc.workspace.polytope, frame_name="tcp", buffer=0.1),
        ]
        if k:
            limits.append(
                mink.CollisionAvoidanceLimit(
                    model,
                    geom_pairs=[
                        (
                            [f"link{j}" for j in range(int(sc.arm.n_links))],
                            [f"obstacle{i}" for i in range(k)],
                        )
                    ],
                    minimum_distance_from_collisions=0.0,
                    collision_detection_distance=0.1,
                )
            )
        task = mink.PostureTask(model, cost=1.0)

        def run_mink(i: int) -> object:
            conf.update(Q[i])
            task.set_target(Q[i] + U[i] * MINK_DT)
            return mink.solve_ik(conf, [task], MINK_DT, "daqp", damping=1e-12, limits=limits)

        routes.append(("mink `solve_ik` (same limits, daqp)", run_mink))
    return routes


# ---------------------------------------------------------------------------- 3. numba's cost
_COST = r"""
import json, time, sys
import numpy as np
def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024.0
out = {}
r0 = rss()
t = time.perf_counter()
import velfence
from velfence.geometry.polytope import ConvexPolytope
from velfence.shaping import PolytopeShaper
box = ConvexPolytope.box([-1.0] * 3, [1.0] * 3)  # (scipy's linprog: the Chebyshev ball)
box.chebyshev_radius
r1 = rss()
what = sys.argv[1]
if what.startswith("numba"):
    t = time.perf_counter()
    import numba
    out["import s"] = time.perf_counter() - t
    r2 = rss()
    t = time.perf_counter()
    s = PolytopeShaper(box, buffer=0.2, backend="python")
    s.shape(np.array([0.9, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    out["polytope first call s"] = time.perf_counter() - t
else:
    t = time.perf_counter()
    import velfence_core._nd
    out["import s"] = time.perf_counter() - t
    r2 = rss()
    t = time.perf_counter()
    s = PolytopeShaper(box, buffer=0.2, backend="c")
    s.shape(np.array([0.9, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    out["polytope first call s"] = time.perf_counter() - t
out["import RSS MB"] = r2 - r1
out["total RSS MB"] = rss() - r1
print(json.dumps(out))
"""


def numba_cost() -> str:
    rows = ["| | import [s] | RSS after import [MB] | first n-D law call [s] | "
            "first projection call [s] | RSS growth in all [MB] |",
            "| --- | ---: | ---: | ---: | ---: | ---: |"]  # fmt: skip
    for what in ("numba-law", "c"):
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            done = subprocess.run(
                [sys.executable, "-c", _COST, what], capture_output=True, text=True, env=env,
                timeout=600, check=True,
            )  # fmt: skip
        r = json.loads(done.stdout.strip().splitlines()[-1])
        label = {
            "numba-law": "numba, empty cache: the n-D law (its projection compiled with it)",
            "c": "`velfence_core._nd`",
        }[what]
        law = f"{r['polytope first call s']:.3f}"
        rows.append(
            f"| {label} | {r['import s']:.3f} | {r['import RSS MB']:.1f} | {law} | "
            f"– | {r['total RSS MB']:.1f} |"
        )
    return "\n".join(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=20, help="interleaved rounds (default 20)")
    ap.add_argument("--quick", action="store_true", help="3 rounds, fewer states")
    ap.add_argument("--no-mink", action="store_true", help="skip mink")
    ap.add_argument("--no-cost", action="store_true", help="skip numba's compile/RSS cost")
    args = ap.parse_args()
    rounds = 3 if args.quick else args.rounds
    n_shape = 64 if args.quick else 256
    n_filter = 50 if args.quick else 200
    with_mink = not args.no_mink
    if with_mink:
        try:
            import mink  # noqa: F401
            import mujoco  # noqa: F401
        except ImportError:
            with_mink = False
    print(f"`python benchmarks/bench_nd.py {' '.join(sys.argv[1:])}`".replace(" `", "`"))
    print(
        f"\n{platform.python_version()}, numpy {np.__version__}, {os.cpu_count()} CPUs, load "
        f"average {os.getloadavg()[0]:.2f} at start; {rounds} interleaved rounds\n"
    )
    ref = '**C core** (`backend="c"`)'
    for name, poly in (("3-D box, 6 facets", ConvexPolytope.box([-1.0] * 3, [1.0] * 3)),
                       ("20 facets in 3-D", polytope20())):  # fmt: skip
        res = time_routes(shaper_routes(poly, n_shape), n_shape, rounds)
        print(table(f"`PolytopeShaper.shape`, {name} ({n_shape} states)", res, ref) + "\n")
    for k in (0, 5, 20):
        res = time_routes(filter_routes(k, n_filter, with_mink), n_filter, max(1, rounds // 4))
        print(
            table(
                f"`SafetyFilter.filter`, 7 joints, TCP box, {k} obstacles ({n_filter} states)",
                res,
                "**C backend**, continuous time",
            )
            + "\n"
        )
    if not args.no_cost:
        print(numba_cost())
    print(f"\nload average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
