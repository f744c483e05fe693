"""Robots in physics: scenarios run in MuJoCo with velfence in the loop (``velfence sim``).

Every scenario runs :func:`velfence.sim.simulate` with a :class:`~velfence.sim.physics.MujocoPlant`
(rigid-body dynamics behind a joint velocity servo, at its own step under a zero-order hold of the
filter's output) and reports named checks in the format of the reproductions
(:class:`~velfence.apps.reproduce.base.Report`), with metrics, plots and videos
(``docs/physics.md``):

* :mod:`~velfence.apps.scenarios.fence_box` — a Panda-like arm's TCP kept in a box under operator
  pushes and an external push, a sphere in the way; no limit, per-joint clamp, velfence and
  velfence with look-ahead side by side.
* :mod:`~velfence.apps.scenarios.wrist` — the patent's 2-DOF wrist as a closed chain with its two
  linear actuators, pushed outside its polygon: the patent's spring against the exact recovery.
* :mod:`~velfence.apps.scenarios.obstacles` — the redundant-arm obstacle scenario of US 5,150,026 on
  a 7-DoF model with a physical obstacle.
* :mod:`~velfence.apps.scenarios.person` — a person walks into the fence-box cell while the arm
  works: speed and separation rows from a tracker, point-cloud rows from a simulated depth
  sensor.
"""

from __future__ import annotations

from velfence.apps.scenarios.common import SCENARIOS, PhysicsRun, ScenarioResult

__all__ = ["SCENARIOS", "PhysicsRun", "ScenarioResult"]
