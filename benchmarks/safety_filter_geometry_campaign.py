"""Closed-loop campaign of the safety filter's geometry rows: tools, payloads, self-collision.

A kinematic loop ``q += x dt`` of a 7-joint arm (``DHChain.seven_dof``) under random joint
commands and random TCP twists, with a random tool (capsule or sphere on the TCP) in a box
workspace among random sphere obstacles, self-collision on, and grasp / release events (a
random payload capsule attached to the TCP, later detached). Every step is checked with the
library's geometry, not with the filter's rows:

* every attached shape inside the box: both axis ends at least ``radius`` inside every facet;
* every attached shape and every link capsule outside every obstacle
  (:func:`~velfence.geometry.primitives.sphere_capsule_distance`);
* every guarded link pair apart (:func:`~velfence.geometry.primitives.segment_segment_distance`
  minus the two radii);
* every output finite.

A violation counts when it exceeds round-off (``TOL`` = 1e-9 m) and is deeper than at the step
before (a state that starts inside stays inside; recovery from a start outside is not asked).
Episodes restart from a random safe pose. Run::

    .venv/bin/python benchmarks/safety_filter_geometry_campaign.py --steps 1000000

and it prints the counts (the test ``tests/filter/test_geometry_campaign.py`` runs a few
thousand steps of the same loop).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from velfence.filter import (
    Capsule,
    JointLimits,
    SafetyFilter,
    Sphere,
    SphereObstacle,
    WorkspaceLimit,
)
from velfence.geometry.polytope import ConvexPolytope
from velfence.geometry.primitives import segment_segment_distance, sphere_capsule_distance
from velfence.mechanisms.chain import DHChain

TOL = 1e-9
DT = 0.01


def _shape(rng: np.random.Generator, link: Any) -> Any:
    r = float(rng.uniform(0.01, 0.05))
    if rng.uniform() < 0.3:
        return Sphere(link, [0.0, 0.0, float(rng.uniform(0.0, 0.1))], radius=r)
    a = np.array([0.0, 0.0, 0.0])
    b = np.array([*rng.normal(size=2) * 0.03, rng.uniform(0.05, 0.2)])
    return Capsule(link, a, b, radius=r)


def _world(robot: DHChain, q: Any, shape: Any) -> tuple[np.ndarray, np.ndarray, float]:
    link = robot.dof if shape.link == "tcp" else int(shape.link)
    F = robot.kinematics(q).link_frame(link)
    a, b = shape.ends
    return F[:, :3] @ a + F[:, 3], F[:, :3] @ b + F[:, 3], float(shape.radius)


def depths(sf: SafetyFilter, q: Any, box: Any, obstacles: Any) -> dict[str, float]:
    """The deepest violation of each kind at ``q`` [m] (<= 0: none)."""
    robot: Any = sf.robot
    segs = robot.link_segments(q)
    rad = np.broadcast_to(np.asarray(robot.link_radius, float).reshape(-1), (segs.shape[0],))
    out = {"workspace": -np.inf, "tool-obstacle": -np.inf, "link-obstacle": -np.inf,
           "link-link": -np.inf}  # fmt: skip
    N, o = np.asarray(box.normals), np.asarray(box.offsets)
    for shape in sf.attachments.values():
        A, B, r = _world(robot, q, shape)
        for p in (A, B):
            out["workspace"] = max(out["workspace"], float(np.max(r - (N @ p - o))))
        for ob in obstacles:
            d = sphere_capsule_distance(ob.center, A, B, sphere_radius=ob.radius, capsule_radius=r)[
                0
            ]
            out["tool-obstacle"] = max(out["tool-obstacle"], -d)
    for ob in obstacles:
        for k in range(segs.shape[0]):
            d = sphere_capsule_distance(
                ob.center,
                segs[k, 0],
                segs[k, 1],
                sphere_radius=ob.radius,
                capsule_radius=float(rad[k]),
            )[0]
            out["link-obstacle"] = max(out["link-obstacle"], -d)
    for i, j in sf.self_collision_pairs:
        d = segment_segment_distance(segs[i, 0], segs[i, 1], segs[j, 0], segs[j, 1])
        out["link-link"] = max(out["link-link"], rad[i] + rad[j] - d)
    return out


def _episode(rng: np.random.Generator, robot: DHChain, lim: JointLimits) -> Any:
    """A random safe start: box, obstacles, tool and a pose inside everything."""
    for _ in range(200):
        q = rng.uniform(-1.2, 1.2, robot.dof)
        tool = _shape(rng, "tcp")
        tcp = robot.fk(q, "tcp")
        half = rng.uniform(0.3, 0.6, 3)
        box = ConvexPolytope.box(tcp - half * rng.uniform(0.4, 1.6, 3), tcp + half)
        obstacles = []
        for _ in range(int(rng.integers(1, 5))):
            obstacles.append(
                SphereObstacle(
                    center=tcp + rng.normal(size=3) * 0.25, radius=float(rng.uniform(0.03, 0.1))
                )
            )
        sf = SafetyFilter(
            robot, limits=lim, workspace=WorkspaceLimit(box, buffer=0.05), obstacles=obstacles,
            self_collision=True, attachments={"tool": tool}, dt=DT, obstacle_buffer=0.05,
        )  # fmt: skip
        if all(v < -1e-3 for v in depths(sf, q, box, obstacles).values()):
            return sf, q, box, obstacles
    raise RuntimeError("no safe start found")


def run(steps: int, *, seed: int = 0, episode: int = 500) -> dict[str, Any]:
    """The campaign: ``steps`` filter cycles in episodes of ``episode`` steps; the counts."""
    rng = np.random.default_rng(seed)
    robot = DHChain.seven_dof(link_radius=0.04, tool=(0.0, 0.0, 0.05))
    lim = JointLimits(robot.joint_limits[:, 0], robot.joint_limits[:, 1],
                      max_speed=np.full(7, 1.5), max_acceleration=np.full(7, 20.0))  # fmt: skip
    counts = {"steps": 0, "episodes": 0, "grasps": 0, "releases": 0, "twist_steps": 0,
              "non_finite": 0, "workspace": 0, "tool-obstacle": 0, "link-obstacle": 0,
              "link-link": 0}  # fmt: skip
    worst = dict.fromkeys(("workspace", "tool-obstacle", "link-obstacle", "link-link"), -np.inf)
    t0 = time.perf_counter()
    while counts["steps"] < steps:
        sf, q, box, obstacles = _episode(rng, robot, lim)
        counts["episodes"] += 1
        prev = depths(sf, q, box, obstacles)
        u = rng.normal(size=7)
        for k in range(min(episode, steps - counts["steps"])):
            if k % 50 == 0:
                u = rng.normal(size=7) * rng.choice([0.3, 1.0, 3.0])
            ev = rng.uniform()
            if ev < 0.01 and "payload" not in sf.attachments:
                sf.attach("payload", _shape(rng, "tcp"))
                counts["grasps"] += 1
                prev = depths(sf, q, box, obstacles)  # (a grasp may start outside)
            elif ev < 0.02 and "payload" in sf.attachments:
                sf.detach("payload")
                counts["releases"] += 1
            if k % 100 >= 90:  # a stretch of TCP twists (the Python route)
                x = sf.filter_twist(q, rng.normal(size=3) * 0.5)
                counts["twist_steps"] += 1
            else:
                x = sf.filter(q, u)
            if not np.all(np.isfinite(x)):
                counts["non_finite"] += 1
                break
            q = q + x * DT
            now = depths(sf, q, box, obstacles)
            for key, d in now.items():
                worst[key] = max(worst[key], d)
                if d > TOL and d > prev[key] + TOL:
                    counts[key] += 1
            prev = now
            counts["steps"] += 1
    counts["seconds"] = time.perf_counter() - t0
    counts["worst"] = worst
    return counts


def main() -> None:
    """Command line: ``--steps``, ``--seed``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20_000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    print(run(a.steps, seed=a.seed))


if __name__ == "__main__":
    main()
