"""Wall time of one ``SafetyFilter`` cycle on the 7-DoF arm (the "Speed" table of the docs).

Usage: ``PYTHONPATH=src python benchmarks/safety_filter_speed.py [--calls N] [--python]``
prints a Markdown table (the one in ``docs/safety_filter.md``, section "Speed").

The case: ``DHChain.seven_dof(link_radius=0.05)``, 14 position and 14 velocity rows (every joint
limited both ways), a 6-facet box of ±0.15 m around the tool point (``WorkspaceLimit``, 5 cm
buffer), two ``SphereObstacle`` beside the upper arm and the forearm (inside their 5 cm buffer, so
obstacle rows are built and checked), ``dt`` = 1 ms (discrete-time model check). Each call
filters one of 500 seeded states (joint position near a bent pose, random command) in turn; the
whole call is timed (validation, kinematics and Jacobians, rows, solve, result). Joint mode is
``filter(q, qd)`` with a 1 rad/s command scale, twist mode ``filter_twist(q, v)`` with a
0.5 m/s tool twist. Median and 99th percentile over ``N`` calls after a warm-up of 300 calls.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from velfence.filter import JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.mechanisms.chain import DHChain

Q0 = np.array([0.1, 0.6, 0.0, -1.2, 0.0, 0.8, 0.0])
STATES = 500
WARMUP = 300


def make_filter(backend: str = "auto") -> SafetyFilter:
    """The benchmark's filter (module docstring)."""
    arm = DHChain.seven_dof(link_radius=0.05)
    lim = arm.joint_limits
    p0 = arm.fk(Q0)
    box = ConvexPolytope.box(p0 - 0.15, p0 + 0.15)
    segs = arm.link_segments(Q0)
    obstacles = []
    for link, radius in ((2, 0.08), (4, 0.06)):
        a, b = segs[link]
        mid = 0.5 * (a + b)
        side = np.cross(b - a, (0.0, 0.0, 1.0))
        side /= np.linalg.norm(side)
        # surface-to-surface gap of 3 cm (inside the 5 cm obstacle buffer)
        obstacles.append(SphereObstacle(mid + side * (0.05 + radius + 0.03), radius=radius))
    return SafetyFilter(
        arm,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(7, 1.5)),
        workspace=WorkspaceLimit(box, buffer=0.05),
        obstacles=obstacles,
        dt=1e-3,
        backend=backend,  # type: ignore[arg-type]
    )


def states(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded joint positions (500, 7), joint commands (500, 7) and tool twists (500, 3)."""
    rng = np.random.default_rng(seed)
    Q = Q0 + rng.uniform(-0.05, 0.05, (STATES, 7))
    QD = rng.uniform(-1.0, 1.0, (STATES, 7))
    V = rng.normal(size=(STATES, 3))
    V *= 0.5 / np.linalg.norm(V, axis=1, keepdims=True)
    return Q, QD, V


def time_calls(f: SafetyFilter, mode: str, calls: int) -> np.ndarray:
    """Wall time of ``calls`` cycles [µs], after the warm-up."""
    Q, QD, V = states()
    call = f.filter if mode == "joint" else f.filter_twist
    cmd = QD if mode == "joint" else V
    for k in range(WARMUP):
        call(Q[k % STATES], cmd[k % STATES])
    out = np.empty(calls)
    clock = time.perf_counter
    for k in range(calls):
        q, c = Q[k % STATES], cmd[k % STATES]
        t0 = clock()
        call(q, c)
        out[k] = clock() - t0
    return out * 1e6


def main() -> None:
    """Print the Markdown table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=3000)
    ap.add_argument("--python", action="store_true", help="the Python reference (no core)")
    args = ap.parse_args()
    f = make_filter("python" if args.python else "auto")
    print("| mode | calls | median [µs] | p99 [µs] | mean rows |")
    print("|---|---|---|---|---|")
    Q, QD, V = states()
    for mode in ("joint", "twist"):
        t = time_calls(f, mode, args.calls)
        res = [
            f.explain(Q[k], QD[k]) if mode == "joint" else f.explain_twist(Q[k], V[k])
            for k in range(50)
        ]
        rows = np.mean([r.rows[1].shape[0] for r in res])
        med, p99 = np.percentile(t, [50, 99])
        print(f"| {mode} | {args.calls} | {med:.0f} | {p99:.0f} | {rows:.1f} |")


if __name__ == "__main__":
    main()
