r"""The MuJoCo plant of a campaign's closed loop (``plant: mujoco``; the ``physics`` extra).

A family's ``plant`` decides what the filter's output drives. ``kinematic`` (the default) is the
integrator :class:`velfence.apps.verify.cases.KinematicPlant`; ``mujoco`` is this module's
:class:`MujocoArm`: the same case (the same scenario file, the same operator draws, the same
properties) on the robot simulated by MuJoCo, its properties measured on MuJoCo's state. Both
are driven by the one closed loop of :func:`velfence.apps.verify.cases.run` (the operator, the
filter, noise, latency, pushes and the margins' rules are that loop's, whatever the plant).

The model:

* **the arm** is the shipped MJCF of the campaign's robot (:func:`velfence.robots.seven_dof`,
  :func:`~velfence.robots.ur5e`, :func:`~velfence.robots.puma560`, built from the same DH tables
  as the kinematic plant's ``DHChain``), with capsule geoms of the campaign's ``link_radius`` and
  one more capsule from the flange to the tool point, so that MuJoCo's geoms are the filter's
  capsules (``DHChain`` links ``P_k -> P_{k+1}``, the last one ending at the tool point);
* **the spheres** are sphere geoms that collide with the arm's capsules
  (:class:`velfence.sim.physics.MujocoPlant`'s obstacles): a contact is a real one, counted by
  MuJoCo's collision detection (``trace["contacts"]`` with ``record``), and its depth shows as a
  negative containment margin;
* **the workspace box** is a box geom that collides with nothing: the box is a zone in the air,
  not a wall (a wall would hold the arm in and hide the very escape a campaign looks for); the
  TCP's margin is measured against the geom's pose and size as MuJoCo holds them;
* **the servo** is :class:`~velfence.sim.physics.MujocoPlant`'s computed-torque velocity servo
  (``velfence.robots.servo.computed_torque``: gravity and the arm's inertia compensated, clipped
  at the model's effort limits), driven by the filter's output delayed by ``latency`` steps and
  held over the control period. Its bandwidth is ``1 / lag``: below the effort limits each joint
  follows its reference as the first-order lag of the campaign, the kinematic plant's law. A lag
  shorter than MuJoCo's step (``lag: 0`` included) gives bandwidth ``1 / physics_dt``, the
  servo that reaches its reference in one physics step. MuJoCo's step is the largest divisor of
  the control period not above 0.5 ms (2 steps per period at 1 kHz, 100 at 20 Hz).

**Pushes** are the campaign's joint-velocity disturbance, applied as such: after the servo's
period, the joints are moved by ``dt * w`` (what a push of ``w`` rad/s does in one period), and
the containment and joint-limit margins of the step are measured before the push, on the robot's
own motion, as on the kinematic plant. A body force (MuJoCo's ``xfrc_applied``) was weighed and
not taken: its motion depends on the servo's stiffness and the pose (a velocity servo drifts at
about ``(bandwidth M)^-1 J^T F``), so one campaign value would be a different disturbance on the
two plants and in every pose, halving it while shrinking would not halve the motion, a random
joint direction has no force on one body that makes it, and the filter's share of an escape
could not be told from the push's.

Properties are measured on MuJoCo's state after each period: the joints from ``data.qpos``, the
TCP from the ``tcp`` site's ``site_xpos``, the clearances from the capsule and sphere geoms'
poses and sizes (``geom_xpos``, ``geom_xmat``, ``geom_size``), the box margin from the box geom.
The operator and the filter read the joints as the kinematic plant's do (plus the same noise). The
arm starts at rest, and a filter with acceleration or jerk bounds is told so
(``SafetyFilter.reset(velocity=0)``): otherwise its first output is a velocity step from rest,
which no torque makes (the kinematic plant, which makes any step, leaves the filter as it is).

``mujoco`` is imported when a MuJoCo case runs, never at import; without it a case says
``pip install 'velfence[physics]'``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from velfence._extras import require
from velfence._typing import FloatArray
from velfence.apps.soak_filter import clearance
from velfence.errors import InvalidGeometry

__all__ = ["MAX_PHYSICS_DT", "MujocoArm"]

#: MuJoCo's time step is the largest divisor of the control period not above this [s].
MAX_PHYSICS_DT = 5e-4

_WHAT = "the MuJoCo plant of velfence verify (a family with plant: mujoco)"
#: The arm's collision bits in the shipped MJCF (``velfence.robots.mjcf``: capsules contype 2).
_ARM_CONTYPE = 2


class MujocoArm:
    """One case's robot in MuJoCo: the model, the servo, the measurements (module docstring).

    Args:
        sc: The case's :class:`~velfence.apps.verify.cases.Scenario`.
        tool: The tool point in the flange frame [m], shape (3,) (the kinematic plant's).

    Raises:
        MissingExtra: MuJoCo is not installed (``pip install 'velfence[physics]'``).
    """

    def __init__(self, sc: Any, *, tool: tuple[float, float, float]) -> None:
        mj = require("mujoco", what=_WHAT, extra="physics")
        from velfence import robots
        from velfence.filter import SphereObstacle
        from velfence.sim.physics import MujocoPlant

        self._mj = mj
        arm = {"seven_dof": robots.seven_dof, "ur5e": robots.ur5e, "puma560": robots.puma560}
        model = arm[sc.robot](tool=np.array(tool), radius=sc.link_radius)
        # The extra geoms are written into the MJCF text with every digit (``repr``), so that
        # MuJoCo holds the scenario's numbers exactly (MjSpec.to_xml would round them).
        xml = model.xml
        if sc.link_radius > 0.0 and float(np.linalg.norm(tool)) > 0.0:
            xml = _insert(
                xml,
                '<site name="tcp"',
                f'<geom name="velfence_tool" type="capsule" size="{sc.link_radius!r}" '
                f'fromto="0 0 0 {_xyz(tool)}" contype="{_ARM_CONTYPE}" conaffinity="0" '
                'mass="0"/>',
            )
        if sc.box is not None:
            lo, hi = np.array(sc.box.lower), np.array(sc.box.upper)
            xml = _insert(
                xml,
                "<worldbody>",
                f'<geom name="velfence_box" type="box" pos="{_xyz((lo + hi) / 2)}" '
                f'size="{_xyz(np.maximum((hi - lo) / 2, 1e-9))}" contype="0" conaffinity="0" '
                'mass="0" rgba="0.2 0.5 0.9 0.15"/>',
                after=True,
            )
        self.dt = 1.0 / sc.rate
        sub = max(1, math.ceil(self.dt / MAX_PHYSICS_DT - 1e-9))
        self.physics_dt = self.dt / sub
        bandwidth = 1.0 / max(sc.lag, self.physics_dt)
        obstacles = [SphereObstacle(np.array(s[:3]), radius=s[3]) for s in sc.spheres]
        self.plant = MujocoPlant(
            xml,
            servo="computed-torque",
            bandwidth=bandwidth,
            physics_dt=self.physics_dt,
            obstacles=obstacles,
        )
        m, d = self.plant.model, self.plant.data
        self.model, self.data = m, d
        self._qadr = np.array([m.jnt_qposadr[m.joint(n).id] for n in self.plant.joints])
        self._tcp = m.site("tcp").id
        self._box = m.geom("velfence_box").id if sc.box is not None else -1
        arm_geoms = [
            i
            for i in range(m.ngeom)
            if int(m.geom_contype[i]) == _ARM_CONTYPE
            and int(m.geom_type[i]) in (mj.mjtGeom.mjGEOM_CAPSULE, mj.mjtGeom.mjGEOM_SPHERE)
        ]
        self._arm = np.array(arm_geoms, dtype=np.int64)
        self._capsule = np.array(
            [int(m.geom_type[i]) == mj.mjtGeom.mjGEOM_CAPSULE for i in arm_geoms], dtype=bool
        )
        self._spheres = np.array(
            [m.geom(f"velfence_obstacle{i}").id for i in range(len(obstacles))], dtype=np.int64
        )
        self.plant.reset(np.array(sc.q0), self.dt)

    def q(self) -> FloatArray:
        """The joints now [rad] (MuJoCo's ``qpos``), shape (n,)."""
        return np.array(self.data.qpos[self._qadr], dtype=np.float64)

    def measure(self) -> tuple[FloatArray, float, float]:
        """The TCP [m], its margin inside the box [m], the links' clearance to the spheres [m].

        Measured on MuJoCo's state now (``inf`` without a box or without spheres).
        """
        mj, m, d = self._mj, self.model, self.data
        mj.mj_kinematics(m, d)  # positions of the qpos now (mj_step2 leaves them a step behind)
        p = np.array(d.site_xpos[self._tcp], dtype=np.float64)
        box = math.inf
        if self._box >= 0:
            rot = np.asarray(d.geom_xmat[self._box], dtype=np.float64).reshape(3, 3)
            local = rot.T @ (p - d.geom_xpos[self._box])
            box = float(np.min(m.geom_size[self._box] - np.abs(local)))
        gap = math.inf
        if self._spheres.size and self._arm.size:
            axis = np.asarray(d.geom_xmat[self._arm], dtype=np.float64)[:, 2::3]  # local z, world
            half = np.where(self._capsule, m.geom_size[self._arm, 1], 0.0)[:, None] * axis
            centre = np.asarray(d.geom_xpos[self._arm], dtype=np.float64)
            seg = np.stack([centre - half, centre + half], axis=1)
            gap = clearance(
                seg,
                np.asarray(m.geom_size[self._arm, 0], dtype=np.float64),
                np.asarray(d.geom_xpos[self._spheres], dtype=np.float64),
                np.asarray(m.geom_size[self._spheres, 0], dtype=np.float64),
            )
        return p, box, gap

    def state(self) -> tuple[FloatArray, FloatArray, float]:
        """The joints [rad], the TCP [m] and the containment margin [m] on MuJoCo's state now.

        The containment margin is the smaller of the TCP's margin inside the box geom and the
        links' clearance to the sphere geoms (:meth:`measure`).
        """
        q = self.q()
        p, box, gap = self.measure()
        return q, p, min(box, gap)

    def advance(self, reference: FloatArray, t: float) -> FloatArray:
        """Hold the servo's velocity reference [rad/s] over one control period from ``t`` [s].

        Returns:
            The joints' mean velocity over the period [rad/s] (their motion over ``dt``).

        Raises:
            VelfenceError: the physics diverged (a non-finite state).
        """
        q = self.q()
        self.plant.advance(reference, t)
        return np.asarray((self.q() - q) / self.dt, dtype=np.float64)

    def displace(self, dq: FloatArray) -> None:
        """Move the joints by ``dq`` [rad] (a push's motion in one period), velocities kept."""
        self.data.qpos[self._qadr] += dq

    def contacts(self) -> np.ndarray[Any, np.dtype[np.int64]]:
        """Arm-sphere contacts MuJoCo found in each period so far, shape (periods,).

        The largest count at one physics step of the period (MuJoCo's collision detection).
        """
        return np.asarray(self.plant.record.contacts[1:], dtype=np.int64)

    def extra_trace(self, steps: int) -> dict[str, Any]:
        """``contacts``: :meth:`contacts` of the first ``steps`` periods (a case's trace)."""
        return {"contacts": self.contacts()[:steps]}


def _xyz(v: Any) -> str:
    """Three numbers for an MJCF attribute, every digit kept."""
    return " ".join(repr(float(x)) for x in v)


def _insert(xml: str, anchor: str, element: str, *, after: bool = False) -> str:
    """``element`` on its own line before (or after) the line holding ``anchor`` (once)."""
    lines = xml.splitlines()
    at = [i for i, line in enumerate(lines) if anchor in line]
    if len(at) != 1:  # the shipped MJCF has one of each; anything else is a bug here
        raise InvalidGeometry(f"MJCF of the arm: expected one {anchor!r}, found {len(at)}")
    lines.insert(at[0] + (1 if after else 0), element)
    return "\n".join(lines)
