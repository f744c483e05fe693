"""MujocoRobot.chain_frames: a serial MJCF arm runs the filter's whole cycle in C.

The C cycle on the chain as frames (``ChainFrames``) against the Python route on MuJoCo's own
kinematics (``backend="python"``): the same rows (names, ``G``, ``b``) and the same outputs (to
1e-9 relative) on the shipped Panda with a TCP box and two spheres near the links, and on an MJCF
written here with a joint offset from its body, an intermediate body without joints, a slide
joint, a tilted axis and a hinge ``ref``. A branching model gives ``None`` (the Python route).
"""

from __future__ import annotations

import numpy as np
import pytest

from velfence.filter import ChainFrames, JointLimits, SafetyFilter, SphereObstacle, WorkspaceLimit
from velfence.geometry.polytope import ConvexPolytope
from velfence.robots import MujocoRobot, panda

pytest.importorskip("mujoco")
pytest.importorskip("velfence_core._filter")

_ODD = """
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    <body name="base" pos="0.1 0 0.2" quat="0.9659 0 0 0.2588">
      <joint name="a" type="hinge" axis="0 0 1" pos="0.02 0 0" range="-2 2" ref="0.3"/>
      <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.04"/>
      <body name="spacer" pos="0 0 0.3" quat="0.7071 0.7071 0 0">
        <body name="l2" pos="0 0.05 0">
          <joint name="b" type="hinge" axis="0 0.6 0.8" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
          <body name="l3" pos="0.3 0 0">
            <joint name="c" type="slide" axis="1 0 0" range="-0.1 0.2"/>
            <geom type="box" size="0.02 0.02 0.02"/>
            <body name="tip" pos="0.1 0 0.05">
              <site name="tcp" pos="0.02 0.01 0"/>
              <site name="mid" pos="-0.05 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
    <site name="origin" pos="0 0 0.5"/>
  </worldbody>
</mujoco>
"""


def _compare(robot: MujocoRobot, q0: np.ndarray, obstacles: list[SphereObstacle]) -> None:
    lim = robot.joint_limits
    n = robot.dof
    p0 = robot.fk(q0)

    def make(backend: str) -> SafetyFilter:
        return SafetyFilter(
            robot,
            limits=JointLimits(lim[:, 0], lim[:, 1], max_speed=np.full(n, 1.5),
                               max_acceleration=np.full(n, 10.0)),
            workspace=WorkspaceLimit(ConvexPolytope.box(p0 - 0.12, p0 + 0.12), buffer=0.05),
            obstacles=obstacles, dt=0.002, backend=backend,  # type: ignore[arg-type]
        )  # fmt: skip

    fc, fp = make("auto"), make("python")
    assert fc._ccycle is not None  # the C cycle runs
    assert fp._ccycle is None
    rng = np.random.default_rng(3)
    changed = 0
    for _ in range(150):
        q = q0 + rng.normal(size=n) * 0.25
        u = rng.normal(size=n) * rng.choice([0.2, 1.0, 5.0])
        a, b = fc.explain(q, u), fp.explain(q, u)
        assert a.constraint_names == b.constraint_names
        np.testing.assert_allclose(a.rows[0], b.rows[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.rows[1], b.rows[1], rtol=0, atol=1e-9)
        scale = 1.0 + float(np.abs(u).max())
        np.testing.assert_allclose(a.output, b.output, rtol=0, atol=1e-9 * scale)
        changed += not np.array_equal(a.output, u)
    assert changed > 20  # the rows did bind


def test_panda_c_cycle_equals_mujoco_python_route() -> None:
    robot = panda(tool=[0.0, 0.0, 0.1], radius=0.05)
    q0 = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    p0 = robot.fk(q0)
    frames = robot.chain_frames()
    assert isinstance(frames, ChainFrames)
    assert frames.joints.shape == (7, 17)
    assert set(frames.points) == set(robot.points)
    _compare(robot, q0, [SphereObstacle(p0 + np.array([0.1, 0.1, 0.2]), radius=0.05),
                         SphereObstacle([0.2, 0.0, 0.5], radius=0.05)])  # fmt: skip


def test_offset_joints_slide_and_jointless_bodies() -> None:
    robot = MujocoRobot.from_xml(_ODD)
    f = robot.chain_frames()
    assert f is not None
    assert f.points["origin"][0] == -1.0  # a world site: the base frame
    assert f.joints[2, 15] == 1.0  # the slide
    assert f.joints[0, 16] == pytest.approx(-0.3)  # the hinge's ref
    _compare(robot, np.array([0.4, 0.3, 0.05]), [])


def test_branching_model_gives_none() -> None:
    xml = _ODD.replace(
        '<site name="origin" pos="0 0 0.5"/>',
        '<body name="side"><joint name="d" type="hinge" axis="1 0 0"/>'
        '<geom type="sphere" size="0.01"/></body>',
    )
    assert MujocoRobot.from_xml(xml).chain_frames() is None
