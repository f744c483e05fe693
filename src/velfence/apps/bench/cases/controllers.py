"""Benchmark cases of the other controllers: cobot path following and resolved rate.

One step of cobot path following (Gillespie et al. 1999) and one resolved-rate step of the PUMA
560 (Khokar 2009), each beside its baseline.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence._typing import FloatArray
from velfence.apps.bench.cases import Step
from velfence.apps.bench.cases.shaping import regular_polygon
from velfence.apps.bench.rows import StepRow
from velfence.apps.bench.settings import BenchSettings
from velfence.apps.bench.timing import as_fields, time_calls

__all__ = ["cobot_steps", "resolved_rate_steps"]


def cobot_steps(s: BenchSettings, step: Step) -> list[StepRow]:
    """One tick of cobot path following (Gillespie et al. 1999) on the r-θ cobot.

    The passive caster wall is compared with the actuated exact law on the same states.
    """
    from velfence.cobot import CasterWall, PathFollower, r_theta_cobot
    from velfence.geometry.paths import Circle
    from velfence.shaping.polygon import PolygonShaper

    step("cobot path following")
    rng = np.random.default_rng(s.seed + 3)
    cob = r_theta_cobot()
    follower = PathFollower(Circle([0.0, 0.0], radius=1.0), gains=(4.0, 4.0))
    calls = max(200, s.calls // 20)
    states = []
    for _ in range(16):
        ang = rng.uniform(0, 2 * math.pi)
        R = (1.0 + rng.uniform(-0.2, 0.2)) * np.array([math.cos(ang), math.sin(ang)])
        h = rng.uniform(0, 2 * math.pi)
        T = np.array([math.cos(h), math.sin(h)])
        q = cob.kinematics.joints(R)
        phi = cob.steering_angles(R, T)
        states.append((R, T, q, phi))
    fam = "cobot (Gillespie 1999)"

    def follow(R: FloatArray, T: FloatArray) -> Any:
        return follower.evaluate(R, T, s_p=0.3, sp_d=1.0)

    def steer(R: FloatArray, T: FloatArray) -> Any:
        return cob.steering_rates(R, np.zeros(1), T, np.array([-T[1], T[0]]) * 0.7, 1.0)

    def forward(q: FloatArray, phi: FloatArray) -> Any:
        return cob.heading(q, phi, reference=np.ones(2))

    def tick(q: FloatArray, phi: FloatArray) -> Any:
        hd = cob.heading(q, phi, reference=np.ones(2))
        R = cob.kinematics.position(q)
        out = follower.evaluate(R, hd.T, s_p=0.3, sp_d=1.0)
        return cob.steering_rates(R, phi, hd.T, out.kN, 1.0)

    wall = CasterWall(regular_polygon(8), buffer=0.2)
    actuated = PolygonShaper(regular_polygon(8), buffer=0.2, method="exact")
    rows: list[StepRow] = []
    for name, fn, pool in (
        ("path follower (eqs. 3.1-3.8): R, T -> κN", follow, [(a, b) for a, b, _, _ in states]),
        ("steering (eqs. 2.13, 2.14, 2.18): κN -> φ̇", steer, [(a, b) for a, b, _, _ in states]),
        ("forward transformation (eqs. 2.17-2.24): q, φ -> T", forward,
         [(c, d) for _, _, c, d in states]),
        ("whole tick: heading + follower + steering", tick, [(c, d) for _, _, c, d in states]),
        ("PolygonShaper.shape, exact (8-gon, the same states)", actuated.shape,
         [(0.8 * a / np.linalg.norm(a), b) for a, b, _, _ in states]),
        ("CasterWall.shape (8-gon, passive exact law)", wall.shape,
         [(0.8 * a / np.linalg.norm(a), b) for a, b, _, _ in states]),
    ):  # fmt: skip
        t = time_calls(fn, pool, calls=calls, warmup=2)
        if name.startswith("CasterWall"):
            ratio = t.median_us / rows[-1].median_us
            rows.append(
                StepRow(
                    **as_fields(t),
                    family=fam,
                    step=name,
                    baseline="PolygonShaper exact",
                    ratio=ratio,
                )
            )
        else:
            rows.append(StepRow(**as_fields(t), family=fam, step=name))
    return rows


def resolved_rate_steps(s: BenchSettings, step: Step) -> list[StepRow]:
    """One resolved-rate step of the PUMA 560 (Khokar 2009): J⁻¹ vs the SR inverse."""
    from velfence.apps.teleop.resolved_rate import ResolvedRate
    from velfence.mechanisms.puma560 import Puma560

    step("resolved rate (PUMA 560)")
    rng = np.random.default_rng(s.seed + 4)
    robot = Puma560()
    q_reg = np.array([-1.05628, -2.1085, 0.05893, 0.17227, -0.74605, 0.01345])  # §7.1 start
    q_wrist = q_reg.copy()
    q_wrist[4] = 1e-7  # wrist singularity: the SR inverse damps, J⁻¹ cannot be timed here
    pool_reg = [
        (q_reg + rng.normal(scale=0.01, size=6), rng.normal(size=6) * 0.1) for _ in range(16)
    ]
    pool_sing = [(q_wrist, rng.normal(size=6) * 0.1) for _ in range(16)]
    calls = max(200, s.calls // 20)
    fam = "resolved rate (Khokar 2009)"
    jinv = ResolvedRate(robot, inverse="jinv")
    sr = ResolvedRate(robot, inverse="sr")
    rows: list[StepRow] = []
    base = math.nan
    for name, fn, pool in (
        ("J⁻¹ step (Jacobian + solve), regular pose", jinv.step, pool_reg),
        ("SR-inverse step, regular pose (w > w0, k = 0)", sr.step, pool_reg),
        ("SR-inverse step at the wrist singularity (damped)", sr.step, pool_sing),
        ("Puma560.jacobian alone", lambda q, v: robot.jacobian(q), pool_reg),
    ):
        t = time_calls(fn, pool, calls=calls, warmup=2)
        if math.isnan(base):
            base = t.median_us
            rows.append(StepRow(**as_fields(t), family=fam, step=name))
        else:
            rows.append(
                StepRow(
                    **as_fields(t),
                    family=fam,
                    step=name,
                    baseline="J⁻¹ step",
                    ratio=t.median_us / base,
                )
            )
    return rows
