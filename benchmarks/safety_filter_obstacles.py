"""SafetyFilter (twist mode + sphere obstacles) vs configuration control on its scenarios.

Usage: ``PYTHONPATH=src python benchmarks/safety_filter_obstacles.py`` prints a Markdown table
(the one in ``docs/safety_filter.md``). The scenarios are those of
:mod:`velfence.apps.reproduce.obstacles` (US 5,150,026 claim 1): the same chains, start poses,
reference lines, operator command ``Ẏ_d + K_fb (Y_d - Y)`` and 1 ms period; scenario (iii) (the
critical point moving from link 1 to link 2) happens inside run (i).

The configuration controller keeps each link's surface outside the sphere of influence
``ρ``; the filter gets the same sphere as a :class:`~velfence.filter.SphereObstacle` of
radius ``ρ`` with a 5 cm linear buffer, the same damping (``λ²`` = the controller's ``λ`` =
1e-2) and, for (iv), the same 2 rad/s joint-speed cap. Columns: the smallest clearance of any
link surface to ``ρ`` (negative: inside the sphere of influence) and to the obstacle body, the
largest and RMS end-effector error, and the mean wall time of one cycle.
"""

from __future__ import annotations

import math
import time

import numpy as np

from velfence.apps.reproduce.obstacles import DT, K_FB, MAX_JOINT_SPEED, ScenarioRun, scenarios
from velfence.filter import JointLimits, SafetyFilter, SphereObstacle
from velfence.geometry.primitives import points_segments_distances

BUFFER = 0.05  # [m] the filter's obstacle buffer


def _lines() -> dict[str, object]:
    """The reference lines of the scenarios (rebuilt as in velfence.apps.reproduce.obstacles)."""
    from velfence.apps.reproduce.obstacles import SEVEN_PERIOD, SEVEN_REACH, cosine_line

    return {
        "i": (cosine_line((2.0, 1.0), (0.0, -1.0), 2.0, 5.0, back=True), 10.0),
        "ii": (cosine_line((2.5, 1.0), (0.0, -1.0), 2.0, 10.0, back=False), 10.0),
        "iv": (cosine_line((2.5, 1.0), (0.0, -1.0), 0.6, 2.0, back=False), 2.5),
        "v": (None, SEVEN_PERIOD + 0.5, SEVEN_REACH, SEVEN_PERIOD),
    }


def _clearances(chain, obstacles, q: np.ndarray) -> tuple[float, float]:
    """(min over obstacles of surface distance − ρ, min of surface distance − body radius) [m]."""
    segs = np.asarray(chain.link_segments(q), dtype=float)
    centres = np.array([o.center for o in obstacles])
    _, d = points_segments_distances(centres, segs[:, 0], segs[:, 1], radii=chain.link_radius)
    d = d.min(axis=1)
    rho = np.array([o.influence for o in obstacles])
    body = np.array([o.radius for o in obstacles])
    return float((d - rho).min()), float((d - body).min())


def run_filter(key: str, ref: ScenarioRun, line, duration: float) -> dict[str, float]:
    chain = ref.chain
    lim = np.asarray(chain.joint_limits)
    vmax = MAX_JOINT_SPEED if key == "iv" else 100.0
    f = SafetyFilter(
        chain,
        limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(chain.dof, vmax)),
        obstacles=[SphereObstacle(o.center, radius=o.influence) for o in ref.obstacles],
        obstacle_buffer=BUFFER,
        dt=DT,
        damping=0.1,
    )
    q = np.array(ref.q[0])
    steps = round(duration / DT)
    err, rho_c, body_c, times = [], [], [], []
    for k in range(steps + 1):
        t = k * DT
        yd, vd = line(t)
        y = np.asarray(chain.end_effector(q), dtype=float)
        err.append(float(np.linalg.norm(yd - y)))
        a, b = _clearances(chain, ref.obstacles, q)
        rho_c.append(a)
        body_c.append(b)
        if k == steps:
            break
        t0 = time.perf_counter()
        x = f.filter_twist(q, vd + K_FB * (yd - y))
        times.append(time.perf_counter() - t0)
        q = q + x * DT
    e = np.array(err)
    return {
        "rho": min(rho_c),
        "body": min(body_c),
        "max_err": float(e.max()),
        "rms_err": float(math.sqrt(np.mean(e**2))),
        "us": 1e6 * float(np.mean(times)),
    }


def summarise_cc(ref: ScenarioRun) -> dict[str, float]:
    cl = [_clearances(ref.chain, ref.obstacles, q) for q in ref.q]
    e = ref.ee_error
    return {
        "rho": min(c[0] for c in cl),
        "body": min(c[1] for c in cl),
        "max_err": float(e.max()),
        "rms_err": float(math.sqrt(np.mean(e**2))),
        "us": float(np.mean(ref.cycle_us)),
    }


def main() -> None:
    from velfence.apps.reproduce.obstacles import cosine_line

    runs = scenarios(baseline=False)
    lines = _lines()
    rows = []
    for key in ("i", "ii", "iv", "v"):
        ref = runs[key]
        if key == "v":
            _, duration, reach, period = lines["v"]  # type: ignore[misc]
            y0 = np.asarray(ref.chain.end_effector(ref.q[0]), dtype=float)
            line = cosine_line(y0, (0.0, 1.0, 0.0), reach, period, back=False)
        else:
            line, duration = lines[key]  # type: ignore[misc]
        rows.append((key, "configuration control", summarise_cc(ref)))
        rows.append((key, "SafetyFilter (twist)", run_filter(key, ref, line, duration)))
    print(
        "| scenario | method | min clearance to ρ [mm] | min clearance to body [mm] | "
        "max EE error [mm] | RMS EE error [mm] | mean cycle [µs] |"
    )
    print("|---|---|---:|---:|---:|---:|---:|")
    for key, name, s in rows:
        print(
            f"| ({key}) | {name} | {1e3 * s['rho']:.2f} | {1e3 * s['body']:.1f} | "
            f"{1e3 * s['max_err']:.1f} | {1e3 * s['rms_err']:.1f} | {s['us']:.0f} |"
        )


if __name__ == "__main__":
    main()
