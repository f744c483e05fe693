"""Benchmark cases of redundant arms: one obstacle-avoidance control cycle (US 5,150,026).

Configuration control (weighted damped least squares over the active set) against the
velocity-damper QP (qpsolvers + daqp), on a planar 3R arm, a 7-DoF arm and a planar 20R arm,
with obstacles placed near random points of random links.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.bench.cases import Step
from velfence.apps.bench.rows import ControlCycleRow
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import as_fields, time_calls

__all__ = ["ARMS", "control_cycles", "obstacle_counts"]

#: Names of the arms timed, in order.
ARMS: tuple[str, ...] = ("planar 3R", "7-DoF", "planar 20R")


def obstacle_counts(s: BenchSettings) -> tuple[int, ...]:
    """Obstacle counts timed per arm (the quick run skips the largest)."""
    return (1, 5) if s.quick else (1, 5, 20)


def control_cycles(s: BenchSettings, step: Step, qp_ok: bool) -> list[ControlCycleRow]:
    """Configuration control vs the velocity-damper QP, one cycle, obstacles along the arm.

    Args:
        s: The settings.
        step: The progress hook.
        qp_ok: Whether qpsolvers and daqp are installed (else the QP rows are skipped).

    Returns:
        One row per (arm, obstacle count, method).
    """
    from velfence.filter import SphereObstacle
    from velfence.mechanisms.chain import DHChain, PlanarArm
    from velfence.redundancy import ConfigurationController, VelocityDamperQP

    rng = np.random.default_rng(s.seed + 2)
    arms: list[tuple[str, Any, FloatArray]] = [
        (ARMS[0], PlanarArm.three_r(), np.array([0.4, 0.9, 0.9])),
        (ARMS[1], DHChain.seven_dof(), np.array([0.2, 0.5, 0.1, -1.2, 0.1, 0.8, 0.0])),
        (ARMS[2], PlanarArm([0.1] * 20), np.full(20, 0.12)),
    ]
    calls = max(50, s.calls // 50)
    rows: list[ControlCycleRow] = []
    for name, chain, q0 in arms:
        segs = chain.link_segments(q0)
        for n_obs in obstacle_counts(s):
            step(f"control cycle: {name}, {n_obs} obstacles")
            obstacles = []
            for _ in range(n_obs):
                link = int(rng.integers(chain.n_links))
                a, b = segs[link]
                on_link = a + rng.uniform(0.2, 0.8) * (b - a)
                side = rng.normal(size=3)
                if chain.task_dim == 2:
                    side[2] = 0.0
                side /= np.linalg.norm(side)
                obstacles.append(
                    SphereObstacle(center=on_link + 0.12 * side, radius=0.02, influence=0.1)
                )
            pool = [
                (q0 + rng.normal(scale=0.02, size=q0.shape), rng.normal(size=chain.task_dim) * 0.2)
                for _ in range(16)
            ]
            makers: list[tuple[str, Any]] = [("configuration-control", ConfigurationController)]
            if qp_ok:
                makers.append(("velocity-damper-qp", VelocityDamperQP))
            for method, cls in makers:
                ctrl = cls(chain, obstacles)
                active = float(np.mean([len(ctrl.explain(q, v).active) for q, v in pool]))
                t = time_calls(ctrl.shape, pool, calls=calls, warmup=2)
                rows.append(
                    ControlCycleRow(
                        **as_fields(t),
                        arm=name,
                        links=chain.n_links,
                        obstacles=n_obs,
                        method=method,
                        active=active,
                    )
                )
    return rows
